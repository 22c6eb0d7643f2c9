"""Draw ``cellgl/presets/images/sunset.png``: the picture the ``stained-glass`` preset samples
at each cell's feature point (cell-attribute lookup). A flat-coloured scene (sky bands, sun,
hills, sea) so that every cell takes a clear colour. Run from the repository root::

    PYTHONPATH=. python docs/make_cell_image.py
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image

SIZE = 256


def draw(size: int = SIZE) -> np.ndarray:
    """The picture as uint8 (size, size, 3), row 0 at the top."""
    v, u = (np.mgrid[0:size, 0:size] + 0.5) / size
    img = np.zeros((size, size, 3))
    # sky: deep blue at the top to orange at the horizon, in bands
    t = np.clip(v / 0.62, 0.0, 1.0)
    t = np.floor(t * 6.0) / 5.0
    top, low = np.array([0.10, 0.12, 0.45]), np.array([0.98, 0.55, 0.20])
    img[:] = top + (low - top) * t[..., None]
    # sun
    sun = (u - 0.62) ** 2 + (v - 0.50) ** 2 < 0.13 ** 2
    img[sun] = (1.0, 0.85, 0.25)
    # hills: two ridges
    ridge1 = 0.60 + 0.06 * np.sin(u * 7.0 + 0.5)
    ridge2 = 0.66 + 0.05 * np.sin(u * 11.0 + 2.0)
    img[v > ridge1] = (0.25, 0.42, 0.22)
    img[v > ridge2] = (0.12, 0.30, 0.15)
    # sea with a sun glitter column
    sea = v > 0.78
    img[sea] = (0.05, 0.25, 0.45)
    glitter = sea & (np.abs(u - 0.62) < 0.05 + 0.25 * (v - 0.78)) & (np.floor(v * 40) % 2 == 0)
    img[glitter] = (0.95, 0.75, 0.30)
    return np.round(img * 255).astype(np.uint8)


def main() -> None:
    out = Path(__file__).resolve().parents[1] / "cellgl" / "presets" / "images" / "sunset.png"
    Image.fromarray(draw()).save(out, optimize=True)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
