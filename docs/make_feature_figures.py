"""Draw the figures of docs/textures.md's cell-feature section from ``cellgl.cellular_grid``:

* ``docs/gallery/features.png``: F1, distance to edge, smooth F1 (k = 0.1), n-sphere radius (as
  F1 - r: dark discs that just touch), cell position (x, y -> red, green) and smooth cell colour;
* ``docs/gallery/edge-window.png``: on a sparse Poisson process (density 0.3, empty cells), the
  exact distance to edge, what a fixed 3x3 window of cells gives (Blender, Material Maker), and
  where the two differ (red).

Run from the repository root: ``PYTHONPATH=. python docs/make_feature_figures.py``
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import cellgl  # noqa: E402
from cellgl.basis import features, reference  # noqa: E402
from cellgl.basis.core import make_params, split  # noqa: E402

OUT = Path(__file__).resolve().parent / "gallery"
SIDE = 192


def grey(a, lo, hi):
    g = np.clip((np.asarray(a, np.float64) - lo) / (hi - lo), 0, 1)
    return np.repeat((g * 255).astype(np.uint8)[..., None], 3, axis=2)


def sheet(panels, labels, path):
    pad, lab = 6, 18
    im = Image.new("RGB", (len(panels) * (SIDE + pad) + pad, SIDE + lab + pad), (24, 24, 24))
    d = ImageDraw.Draw(im)
    for i, (p, t) in enumerate(zip(panels, labels)):
        x = pad + i * (SIDE + pad)
        im.paste(Image.fromarray(p), (x, pad))
        d.text((x + 2, SIDE + pad + 3), t, fill=(230, 230, 230))
    im.save(path, optimize=True)
    print(f"wrote {path}")


def features_figure():
    kw = dict(spacing=6.0 / SIDE, n=1, density=1.5, seed=3)
    r = cellgl.cellular_grid((SIDE, SIDE), outputs=("F", "edge", "nsphere", "position", "smooth_F1",
                                                    "smooth_color"), smoothness=0.1, **kw)
    F1 = r.F[..., 0]
    pos = r.position / 6.0
    rg = np.zeros((SIDE, SIDE, 3), np.uint8)
    rg[..., 0] = np.clip(pos[..., 0] * 255, 0, 255)
    rg[..., 1] = np.clip(pos[..., 1] * 255, 0, 255)
    rg[..., 2] = 60
    panels = [grey(F1, 0, 0.7), grey(r.edge, 0, 0.35), grey(r.smooth_F1, -0.2, 0.7),
              grey(F1 - r.nsphere, -0.03, 0.03), rg, (np.clip(r.smooth_color, 0, 1) * 255).astype(np.uint8)]
    sheet(panels, ["F1", "edge", "smooth F1, k=0.1", "F1 - n-sphere r", "position", "smooth colour"],
          OUT / "features.png")


def window_figure():
    kw = dict(distribution="poisson", density=0.3, min_points=0, seed=1)
    spacing = 10.0 / SIDE
    r = cellgl.cellular_grid((SIDE, SIDE), spacing=spacing, n=1, outputs=("edge",), **kw)
    ys, xs = np.mgrid[0:SIDE, 0:SIDE]
    pts = np.stack([xs * spacing, ys * spacing], -1).reshape(-1, 2)
    p = make_params(2, **kw)
    cells, fr = split(pts)
    F, D, I, ex = reference.search(cells, fr, p, 1)
    win = features.features(cells, fr, p, F, D, I, ex, ("edge",), max_ring=1)["edge"].reshape(SIDE, SIDE)
    wrong = np.abs(win - r.edge) > 1e-4
    diff = grey(r.edge, 0, 1.0)
    diff[wrong] = (220, 40, 40)
    found = win < 1e30
    print(f"3x3 window wrong at {wrong.mean() * 100:.1f}% of the pixels, no border at all at "
          f"{(~found).mean() * 100:.1f}%; largest error where it found one: "
          f"{np.abs(win - r.edge)[found].max():.3f} cells")
    sheet([grey(r.edge, 0, 1.0), grey(np.minimum(win, 3.0), 0, 1.0), diff],
          ["exact (cellgl)", "3x3 window", "differ (red)"], OUT / "edge-window.png")


if __name__ == "__main__":
    features_figure()
    window_figure()
