"""Write ``cellgl/presets/*.json``: every texture the papers show, with measured ranges.

Each preset is declared here as a partial recipe; the script measures the range of its
combination once (:func:`cellgl.texture.measure_range`, Worley's "empirically determining the
range ... only done once for each combination, after which it was simply hard-wired") and
writes the full recipe, then the table of every preset's octave mean
(``cellgl/texture/octave_means.json``, :mod:`cellgl.texture.means`). Run from the repository root::

    PYTHONPATH=. python docs/make_presets.py [NAME ...]
"""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from cellgl.texture.presets import preset_dir  # noqa: E402
from cellgl.texture.recipe import Recipe  # noqa: E402
from cellgl.texture import measure_range  # noqa: E402
from cellgl.texture.means import write_table  # noqa: E402
from cellgl.texture.reference import measure_mean  # noqa: E402

GREY = [[0.0, 0.0, 0.0, 0.0], [1.0, 1.0, 1.0, 1.0]]
# Qin 2000, section 4.1: the 13-key blue marble spline.
_A, _B, _C, _D = (0.25, 0.25, 0.35), (0.10, 0.10, 0.30), (0.05, 0.05, 0.26), (0.03, 0.03, 0.20)
BLUE_MARBLE = [[i / 12.0, *c] for i, c in enumerate([_A, _A, _B, _B, _B, _A, _A, _C, _C, _D, _D, _A, _D])]
SPECTRUM = [[0.0, 0.05, 0.05, 0.3], [0.25, 0.1, 0.45, 0.8], [0.5, 0.35, 0.8, 0.5],
            [0.75, 0.95, 0.8, 0.2], [1.0, 1.0, 0.95, 0.9]]
STONE = [[0.0, 0.42, 0.38, 0.34], [0.3, 0.58, 0.52, 0.44], [0.55, 0.47, 0.40, 0.37],
         [0.8, 0.62, 0.50, 0.40], [1.0, 0.70, 0.66, 0.58]]
WOOD = [[0.0, 0.45, 0.26, 0.12], [0.0, 0.45, 0.26, 0.12], [0.5, 0.72, 0.50, 0.28],
        [1.0, 0.36, 0.20, 0.09], [1.0, 0.36, 0.20, 0.09]]
FLAME = [[0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0], [0.25, 0.45, 0.02, 0.0], [0.45, 0.85, 0.15, 0.0],
         [0.65, 1.0, 0.5, 0.05], [0.85, 1.0, 0.85, 0.3], [1.0, 1.0, 1.0, 0.85], [1.0, 1.0, 1.0, 0.85]]
PASTEL = [[0.0, 0.55, 0.62, 0.78], [0.35, 0.85, 0.66, 0.62], [0.7, 0.93, 0.85, 0.6], [1.0, 0.62, 0.8, 0.66]]
# Qin's eq. 7: mix(sky, cloud, smoothstep(0, 1, .)) with smoothstep sampled at quarter steps.
CLOUD = [[0.0, 0.15, 0.15, 0.60], [0.25, 0.2825, 0.2825, 0.6625], [0.5, 0.575, 0.575, 0.80],
         [0.75, 0.8675, 0.8675, 0.9375], [1.0, 1.0, 1.0, 1.0]]


def lin(*c):
    return {"linear": list(c) + [0.0] * (8 - len(c)), "products": [[0.0] * 4 for _ in range(4)]}


def prod(linear, pairs):
    d = lin(*linear)
    for (i, j), c in pairs.items():
        d["products"][i - 1][j - 1] = c
    return d


PRESETS: dict[str, dict] = {
    "f1": dict(doc="F1 as a grey gradient: spots around each feature point (Worley 1996 Fig. 1 upper left; "
               "T&M Fig. 4.2)", combination=lin(1), color={"ramp": GREY}, outputs=["color", "height"]),
    "f2": dict(doc="F2 as a grey gradient (Worley 1996 Fig. 1 upper right; T&M Fig. 4.2)",
               combination=lin(0, 1), color={"ramp": GREY}),
    "f3": dict(doc="F3 as a grey gradient (Worley 1996 Fig. 1 lower left; T&M Fig. 4.2)",
               combination=lin(0, 0, 1), color={"ramp": GREY}),
    "f4": dict(doc="F4 as a grey gradient (Worley 1996: 'F4 and higher n start looking similar')",
               combination=lin(0, 0, 0, 1), color={"ramp": GREY}),
    "veins": dict(doc="F2 - F1: zero on the Voronoi boundaries, a vein-like tracery (Worley 1996 Fig. 1 "
                  "lower right; T&M Fig. 4.2)", combination=lin(-1, 1), color={"ramp": GREY}),
    "density": dict(doc="Spatially varying feature density: flagstones, large on the left and small, dense "
                    "ones on the right (ramp_x from 0.3 to 8 points per cell; Worley 1996: 'small, dense "
                    "features in one area and larger in another')",
                    basis={"density_map": "ramp_x", "density_min": 0.3, "density_max": 8.0,
                           "density_start": 0.0, "density_end": 1.0, "min_points": 0, "max_points": 16},
                    domain={"frequency": 6.0}, combination=lin(-1, 1),
                    noise={"noise_color": 0.35, "noise_frequency": 3.0, "noise_octaves": 5},
                    mapping={"level_hi": 0.08, "bump": 0.05, "light": 0.8},
                    color={"cell_mix": 1.0, "shade": 0.85, "ramp": STONE},
                    outputs=["color", "normal", "height", "id"]),
    "polka": dict(doc="Small F1 mapped to a colour: polka dots (Worley 1996, 'Application to texturing')",
                  basis={"density": 1.5}, domain={"frequency": 10.0}, combination=lin(1),
                  color={"ramp": [[0.0, 0.75, 0.1, 0.12], [0.22, 0.75, 0.1, 0.12], [0.26, 0.97, 0.94, 0.84],
                                  [1.0, 0.97, 0.94, 0.84]]}),
    "flagstone": dict(doc="Flagstones: a constant colour per cell from the F1 ID, F2 - F1 grout bumps, fractal "
                      "noise discoloration (Worley 1996 Fig. 2; T&M Fig. 4.7)",
                      basis={"dimension": 3}, domain={"frequency": 5.0}, combination=lin(-1, 1),
                      noise={"noise_color": 0.35, "noise_frequency": 3.0, "noise_octaves": 5},
                      mapping={"level_hi": 0.12, "bump": 0.05, "light": 0.8},
                      color={"cell_mix": 1.0, "shade": 0.85, "ramp": STONE},
                      outputs=["color", "normal", "height", "id"]),
    "crumple": dict(doc="Fractal F1 (i = 0..5) applied solely as a bump: crumpled paper or tinfoil (Worley "
                    "1996 'crumple'; T&M Fig. 4.5)", basis={"dimension": 3}, domain={"frequency": 4.0},
                    combination=lin(1), fractal={"fractal": "sum", "octaves": 6.0},
                    mapping={"bump": 0.25, "light": 1.0},
                    color={"ramp": [[0.0, 0.78, 0.78, 0.8], [1.0, 0.85, 0.85, 0.87]]},
                    outputs=["normal", "color", "height"]),
    "sea": dict(doc="Sea surface: bump-mapped fractal F1, the crumple on water (Worley 1996 Fig. 7; T&M Fig. "
                "4.6)", basis={"dimension": 3}, domain={"frequency": 3.0, "aspect": 2.5},
                combination=lin(1), fractal={"fractal": "sum", "octaves": 5.0},
                mapping={"bump": 0.1, "light": 1.0},
                color={"ramp": [[0.0, 0.02, 0.12, 0.25], [0.6, 0.05, 0.3, 0.42], [1.0, 0.3, 0.6, 0.65]]},
                outputs=["normal", "color", "height"]),
    "hide": dict(doc="Reptile hide: fractal F1 forms the spots and bumps, fractal noise the colour variation "
                 "(Worley 1996 Fig. 5; T&M Fig. 4.4)", basis={"dimension": 3}, domain={"frequency": 7.0},
                 combination=lin(1), fractal={"fractal": "sum", "octaves": 3.0, "gain": 0.4},
                 noise={"noise_color": 0.25, "noise_frequency": 0.3, "noise_octaves": 3},
                 mapping={"bump": 0.15, "light": 0.8},
                 color={"ramp": [[0.0, 0.12, 0.08, 0.03], [0.3, 0.25, 0.2, 0.07], [0.5, 0.42, 0.45, 0.15],
                                 [0.8, 0.62, 0.62, 0.3], [1.0, 0.8, 0.78, 0.5]]},
                 outputs=["color", "normal", "height"]),
    "hull": dict(doc="Manhattan-metric F1: rigidly rectangular random regions, right-angle channels for "
                 "space ship hulls (Worley 1996 Fig. 3)", basis={"dimension": 3, "metric": "manhattan"},
                 domain={"frequency": 5.0}, combination=lin(1), mapping={"bump": 0.15, "light": 0.9},
                 color={"ramp": [[0.0, 0.25, 0.27, 0.3], [0.5, 0.55, 0.57, 0.6], [1.0, 0.75, 0.76, 0.78]]},
                 outputs=["color", "normal", "height"]),
    "craters": dict(doc="Craters: rims where |0.5 - F1| vanishes, floors and plains flattened, three octaves "
                    "(Worley 1996 abstract: 'craters')", basis={"dimension": 3, "density": 1.5},
                    domain={"frequency": 4.0}, combination=lin(1),
                    fractal={"fractal": "qin", "octaves": 3.0, "gain": 0.45},
                    mapping={"invert": True, "level_lo": 0.35, "level_hi": 1.0, "bump": 0.15, "light": 1.0},
                    color={"ramp": [[0.0, 0.45, 0.43, 0.4], [1.0, 0.72, 0.7, 0.66]]},
                    outputs=["color", "normal", "height"]),
    "rock": dict(doc="Rock: fractal F2 - F1 cracks with noise discoloration (Worley 1996 abstract: 'rock')",
                 basis={"dimension": 3}, domain={"frequency": 4.0}, combination=lin(-1, 1),
                 fractal={"fractal": "sum", "octaves": 5.0, "gain": 0.55},
                 noise={"noise_color": 0.3, "noise_frequency": 1.0, "noise_octaves": 5},
                 mapping={"bump": 0.1, "light": 0.9},
                 color={"ramp": [[0.0, 0.2, 0.18, 0.16], [0.45, 0.45, 0.42, 0.38], [1.0, 0.68, 0.64, 0.58]]},
                 outputs=["color", "normal", "height"]),
    "ice": dict(doc="Ice: crystals of constant pale-blue shade per cell with thin F2 - F1 cracks at two "
                "scales (Worley 1996 abstract: 'ice')", basis={"dimension": 3}, domain={"frequency": 4.0},
                combination=lin(-1, 1), fractal={"fractal": "sum", "octaves": 2.0, "gain": 0.6},
                mapping={"level_hi": 0.35, "bump": 0.04, "light": 0.5},
                color={"cell_mix": 0.8, "shade": 0.5,
                       "ramp": [[0.0, 0.55, 0.7, 0.85], [0.5, 0.75, 0.87, 0.95], [1.0, 0.9, 0.96, 1.0]]},
                outputs=["color", "normal", "height"]),
    "mountains": dict(doc="Mountain ranges: a fractal F1 heightfield, ridges along the cell boundaries "
                      "(Worley 1996 abstract: 'mountain ranges')", basis={"dimension": 2},
                      domain={"frequency": 3.0}, combination=lin(1),
                      fractal={"fractal": "sum", "octaves": 6.0, "gain": 0.45},
                      mapping={"bump": 0.2, "light": 1.0},
                      color={"ramp": [[0.0, 0.12, 0.3, 0.12], [0.35, 0.3, 0.45, 0.2], [0.6, 0.5, 0.42, 0.32],
                                      [0.8, 0.6, 0.58, 0.56], [0.9, 0.95, 0.95, 0.97], [1.0, 1.0, 1.0, 1.0]]},
                      outputs=["height", "color", "normal"]),
    "qin-marble": dict(doc="Qin 2000 marble: sum (-1)^i F_i + sum (-1)^(i+j) F_i F_j, i, j <= 4, in the 13-key "
                       "blue marble spline (Qin Fig. 2, Fig. 6a vase)", basis={"dimension": 3},
                       domain={"frequency": 3.0},
                       combination=prod([-1, 1, -1, 1], {(i, j): (-1.0) ** (i + j) for i in range(1, 5)
                                                         for j in range(1, 5)}),
                       color={"ramp_mode": "spline", "ramp": BLUE_MARBLE}),
    "qin-wood": dict(doc="Qin 2000 wood: F1 - F1 F1 (Qin Fig. 6a table)", basis={"dimension": 3},
                     domain={"frequency": 3.0}, combination=prod([1], {(1, 1): -1.0}),
                     color={"ramp_mode": "spline", "ramp": WOOD}),
    "qin-trunk": dict(doc="Qin 2000 tree trunk: F3 - F3 F3 (Qin Fig. 6b)", basis={"dimension": 3},
                      domain={"frequency": 3.0}, combination=prod([0, 0, 1], {(3, 3): -1.0}),
                      color={"ramp_mode": "spline", "ramp": WOOD}),
    "qin-cloud": dict(doc="Qin 2000 cloud: fractal of F1 F2 + F2 F3 through mix(sky, white, smoothstep) "
                      "(Qin eq. 7, Fig. 5, Fig. 6a sky)", basis={"dimension": 3}, domain={"frequency": 3.0},
                      combination=prod([], {(1, 2): 1.0, (2, 3): 1.0}),
                      fractal={"fractal": "sum", "octaves": 6.0},
                      mapping={"invert": True, "level_lo": 0.5, "level_hi": 0.75},
                      color={"ramp": CLOUD}),
    "qin-flame": dict(doc="Qin 2000 flame: fractal F1 through a flame colour spline (Qin Fig. 6c)",
                      basis={"dimension": 3}, domain={"frequency": 3.0, "aspect": 0.4},
                      combination=lin(1), fractal={"fractal": "sum", "octaves": 5.0},
                      mapping={"invert": True, "level_lo": 0.2, "level_hi": 0.9},
                      color={"ramp_mode": "spline", "ramp": FLAME}),
    "qin-wrinkle": dict(doc="Qin 2000 crumpled wrinkles: bump (sum_{i=0..4} |0.5 - GCTBF(2^i x)| / 2^i)^3, "
                        "GCTBF = F2 - F1 - F1 F1 (Qin eq. 6, Fig. 4; variants :0..:4 = octaves 0..4)",
                        basis={"dimension": 3}, domain={"frequency": 3.0},
                        combination=prod([-1, 1], {(1, 1): -1.0}),
                        fractal={"fractal": "qin_cube", "octaves": 5.0},
                        mapping={"bump": 0.7, "light": 1.0},
                        color={"ramp": [[0.0, 0.8, 0.78, 0.74], [1.0, 0.8, 0.78, 0.74]]},
                        outputs=["normal", "color", "height"]),
    "wobbly-cells": dict(doc="Domain warp: cells whose borders wander, the sample displaced by fractal gradient "
                         "noise before the basis (as Substance's and FastNoiseLite's domain warp); still the exact "
                         "F2 - F1", domain={"frequency": 6.0, "warp_amount": 0.3, "warp_frequency": 1.5,
                                              "warp_octaves": 3},
                         combination=lin(-1, 1), mapping={"level_hi": 0.1, "bump": 0.05, "light": 0.8},
                         color={"cell_mix": 1.0, "shade": 0.85, "ramp": PASTEL},
                         outputs=["color", "normal", "height", "id"]),
    "wood-grain": dict(doc="Stretched cells: Qin's wood F1 - F1 F1 on cells 12 times longer along x than y "
                       "(exact distances under the stretch), lightly warped: planks of long grain",
                       domain={"frequency": 8.0, "warp_amount": 0.15, "warp_frequency": 0.5},
                       basis={"stretch_x": 3.0, "stretch_y": 0.25, "density": 2.0},
                       combination=prod([1], {(1, 1): -1.0}), fractal={"fractal": "sum", "octaves": 2.0},
                       color={"ramp_mode": "spline", "ramp": WOOD}),
    "caustics": dict(doc="Loopable animation: F2 - F1 ridges of light on water, the feature points orbiting in "
                     "their cells (orbit_radius 0.3); `cellgl bake caustics --frames 48 -o c.webp` loops "
                     "seamlessly", basis={"distribution": "jitter", "jitter": 0.8, "orbit_radius": 0.3},
                     domain={"frequency": 6.0, "warp_amount": 0.2, "warp_frequency": 0.5},
                     combination=lin(-1, 1), mapping={"invert": True, "level_lo": 0.55},
                     color={"ramp": [[0.0, 0.02, 0.22, 0.38], [0.55, 0.05, 0.42, 0.6], [0.85, 0.45, 0.8, 0.9],
                                     [1.0, 0.92, 1.0, 1.0]]}),
    "worley-gallery": dict(doc="Worley 1996 Fig. 4 (T&M Fig. 4.3): 20 linear combinations c1 F1 + .. + c4 F4 "
                           "in a generic colour spline; variants :0..:19", basis={"dimension": 3},
                           domain={"frequency": 4.0}, combination=lin(1), color={"ramp": SPECTRUM}),
    # ---- issue 12: the features artists reach for in Blender, Houdini and Substance
    "edge-tiles": dict(doc="Tiles from the exact distance to the cell's border: flat faces, a bevel and dark "
                       "grout of even width (Blender's Distance to Edge, exact next to big cells)",
                       basis={"density": 1.2}, domain={"frequency": 6.0}, combination=dict(lin(0), c_edge=1.0),
                       mapping={"level_hi": 0.22, "bump": 0.1, "light": 0.9},
                       color={"cell_mix": 1.0, "shade": 0.9,
                              "ramp": [[0.0, 0.62, 0.30, 0.20], [0.35, 0.75, 0.45, 0.30], [0.7, 0.85, 0.72, 0.55],
                                       [1.0, 0.55, 0.60, 0.58]]},
                       outputs=["color", "normal", "height", "id"]),
    "edge-cracks": dict(doc="Dried mud: distance to edge over three octaves combined by min (Blender's "
                        "distance-to-edge fractal): cracks within cracks", basis={"density": 1.0},
                        domain={"frequency": 2.0}, combination=dict(lin(0), c_edge=1.0),
                        fractal={"fractal": "min", "octaves": 3.0},
                        mapping={"level_hi": 0.12, "bump": 0.06, "light": 0.6},
                        color={"cell_mix": 0.6, "shade": 0.7,
                               "ramp": [[0.0, 0.42, 0.3, 0.2], [0.5, 0.72, 0.58, 0.42], [1.0, 0.85, 0.74, 0.58]]},
                        outputs=["color", "normal", "height"]),
    "hammered": dict(doc="Hammered copper: smooth F1 (k = 0.12 cells) dimples that merge without creases, "
                     "the patina of each cell blended with the same weights", basis={"density": 2.0},
                     domain={"frequency": 6.0}, combination=dict(lin(0), c_smooth=1.0, smoothness=0.12),
                     range=(-0.35, 0.85), mapping={"bump": 0.8, "light": 1.0},
                     color={"cell_mix": 0.35,
                            "ramp": [[0.0, 0.45, 0.22, 0.12], [0.5, 0.78, 0.45, 0.28], [0.8, 0.9, 0.62, 0.42],
                                     [1.0, 0.62, 0.36, 0.22]]},
                     outputs=["color", "normal", "height"]),
    "nsphere-dots": dict(doc="Dots as large as each cell allows: F1 - r, r the n-sphere radius (half the "
                         "distance to the nearest other point), so neighbouring dots just touch",
                         basis={"density": 1.5}, domain={"frequency": 8.0},
                         combination=dict(lin(1), c_nsphere=-1.0), range=(-0.03, 0.03),
                         color={"cell_mix": 0.4,
                                "ramp": [[0.0, 0.85, 0.2, 0.2], [0.13, 0.95, 0.65, 0.15], [0.26, 0.2, 0.6, 0.35],
                                         [0.4, 0.2, 0.35, 0.8], [0.6, 0.96, 0.93, 0.86], [1.0, 0.96, 0.93, 0.86]]}),
    "stained-glass": dict(doc="Stained glass: each cell takes the colour of a picture at its feature point "
                          "(cell-attribute lookup, cellgl/presets/images/sunset.png), lead came from the "
                          "distance to edge", domain={"frequency": 12.0},
                          combination=dict(lin(0), c_edge=1.0), range=(0.0, 1.0),
                          mapping={"level_hi": 0.06, "bump": 0.02, "light": 0.5},
                          color={"cell_color": "image", "cell_image": "IMAGES/sunset.png", "cell_mix": 1.0,
                                 "shade": 1.0},
                          outputs=["color", "normal", "height"]),
}

#: the 20 linear combinations (the figure does not print its coefficients: these are
#: representative differences and sums of F1..F4, Worley's "2 F3 - F2 - F1 or F1 + F2" included)
GALLERY = [(1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1), (-1, 1, 0, 0), (0, -1, 1, 0), (-1, 0, 1, 0),
           (0, 0, -1, 1), (1, 1, 0, 0), (-1, -1, 2, 0), (1, 1, 1, 1), (-2, 1, 1, 0), (2, -1, 0, 0),
           (-1, 0, 0, 1), (0, -2, 1, 1), (-1, 1, -1, 1), (1, -2, 1, 0), (-1, 1, 1, -1), (1, 1, -1, 0),
           (0, -1, 0, 1)]


def _fmt(c) -> str:
    terms = []
    for i, x in enumerate(c, 1):
        if x:
            sign = "-" if x < 0 else "+"
            mag = "" if abs(x) == 1 else f"{abs(x):g} "
            terms.append(f"{sign} {mag}F{i}")
    s = " ".join(terms)
    return s[2:] if s.startswith("+ ") else "-" + s[2:]


def build(name: str, spec: dict) -> Recipe:
    spec = dict(spec)
    doc = spec.pop("doc")
    outputs = spec.pop("outputs", ["color"])
    fixed = spec.pop("range", None)       # set by hand (a level set at v = 0, a distance in cells)
    if "cell_image" in spec.get("color", {}):
        spec["color"] = dict(spec["color"], cell_image=spec["color"]["cell_image"].replace(
            "IMAGES", str(preset_dir() / "images")))
    d = {"name": name, "doc": doc, "outputs": outputs, **spec}
    r = Recipe.from_dict(d)
    lo, hi = fixed or measure_range(r)
    r = r.replace(range_lo=lo, range_hi=hi)
    variants = []
    if name == "worley-gallery":
        for k, c in enumerate(GALLERY):
            v = r.replace(linear=list(c), name=f"{name}:{k}", doc=_fmt(c))
            lo, hi = measure_range(v)
            variants.append(v.replace(range_lo=lo, range_hi=hi))
    elif name == "qin-wrinkle":
        variants = [r.replace(octaves=float(k + 1), name=f"{name}:{k}", doc=f"octaves 0..{k}") for k in range(5)]
    elif name == "qin-marble":
        v = r.replace(linear=[0.0], products=[[0.0] * 4] * 4, c_noise=1.0, name=f"{name}:noise",
                      doc="the same spline over gradient noise (Qin Fig. 2, the Perlin-noise comparison)")
        lo, hi = measure_range(v)
        variants.append(v.replace(range_lo=lo, range_hi=hi))
    object.__setattr__(r, "_variants", tuple(variants))
    return r


def main(argv) -> int:
    names = argv or list(PRESETS)
    for name in names:
        r = build(name, PRESETS[name])
        r.save(preset_dir() / f"{name}.json")
        print(f"{name}: range [{r.get('range_lo')}, {r.get('range_hi')}]"
              + (f", {len(r.variants)} variants" if r.variants else ""))
    print(f"wrote {write_table(measure_mean)} (the presets' octave means)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
