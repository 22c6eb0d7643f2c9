"""docs/gallery/blender-features.png: cellgl.voronoi's five features of Blender's Voronoi node
(2D, the node's defaults: scale 5, randomness 1, smoothness 1), left to right F1 (colour), F2,
smooth F1 (colour), distance to edge, n-sphere radius.

    PYTHONPATH=. python docs/make_blender_figure.py
"""
from pathlib import Path

import numpy as np
from PIL import Image

import cellgl

SIZE = 160


def main() -> None:
    u = (np.arange(SIZE) + 0.5) / SIZE
    uu, vv = np.meshgrid(u, 1.0 - u)
    pts = np.stack([uu.ravel(), vv.ravel()], 1)
    tiles = []
    for feature, output, gain in (("F1", "color", 1.0), ("F2", "distance", 0.8), ("smooth_F1", "color", 1.0),
                                  ("distance_to_edge", "distance", 2.5), ("n_sphere_radius", "radius", 1.6)):
        r = cellgl.voronoi(pts, dimensions=2, feature=feature)
        a = np.clip(getattr(r, output) * gain, 0.0, 1.0)
        a = np.repeat(a[:, None], 3, 1) if a.ndim == 1 else a
        tiles.append((a.reshape(SIZE, SIZE, 3) * 255).round().astype(np.uint8))
    gap = np.full((SIZE, 4, 3), 255, np.uint8)
    row = np.concatenate([t if i == 0 else np.concatenate([gap, t], 1) for i, t in enumerate(tiles)], 1)
    out = Path(__file__).with_name("gallery") / "blender-features.png"
    Image.fromarray(row).save(out, optimize=True)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
