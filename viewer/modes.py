"""View modes and panel layout, shared by the app, its panel and the command line."""

MODES = ("2d", "3d", "tiled", "anim")
MODE_LABELS = {"2d": "2D texture", "3d": "3D object", "tiled": "3x3 tiled", "anim": "4D animation"}
#: modes a PUPs recipe cannot show (it is a 2D texture without a solid or time dimension)
PUPS_REFUSED_MODES = ("3d", "anim")
PANEL_WIDTH = 360
