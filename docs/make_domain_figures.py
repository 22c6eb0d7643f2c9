"""The figures of docs/textures.md "Domain warp, stretched cells, loopable animation".

    PYTHONPATH=. python docs/make_domain_figures.py

Writes docs/gallery/feature-warp.png (wobbly-cells without and with its warp),
feature-stretch.png (wood-grain's cells unstretched and stretched, with F1 IDs as colours),
feature-orbit.png (four frames of the caustics loop) and caustics.gif (the loop itself, made by
``cellgl bake caustics --frames 16 --fps 8 --size 128``), each image baked by cellgl itself.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from PIL import Image

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from cellgl import recipes  # noqa: E402
from cellgl.io import formats as cio  # noqa: E402
from cellgl.io.spec import id_colors  # noqa: E402
from cellgl.bake.frames import bake_frames  # noqa: E402

OUT = Path(__file__).resolve().parent / "gallery"
SIZE = 256
GAP = 8


def _rgb(recipe, channel="color") -> Image.Image:
    a = recipes.render(recipe, SIZE, SIZE, channels=(channel,))[channel]
    if channel == "id":
        return Image.fromarray(id_colors(a), "RGB")
    return Image.fromarray(np.round(np.clip(a[..., :3], 0, 1) * 255).astype(np.uint8), "RGB")


def strip(images, path: Path) -> None:
    sheet = Image.new("RGB", (len(images) * (SIZE + GAP) - GAP, SIZE), (255, 255, 255))
    for k, im in enumerate(images):
        sheet.paste(im, (k * (SIZE + GAP), 0))
    with cio.atomic_path(path) as tmp:
        sheet.save(tmp, format="PNG", optimize=True)
    print(f"wrote {path}")


def main() -> int:
    wobbly = recipes.load_recipe("wobbly-cells")
    strip([_rgb(wobbly.replace(warp_amount=0.0)), _rgb(wobbly)], OUT / "feature-warp.png")
    wood = recipes.load_recipe("wood-grain")
    flat = wood.replace(stretch_x=1.0, stretch_y=1.0, warp_amount=0.0)
    strip([_rgb(flat, "id"), _rgb(wood.replace(warp_amount=0.0), "id"), _rgb(wood)], OUT / "feature-stretch.png")
    caustics = recipes.load_recipe("caustics")
    strip([_rgb(caustics.replace(orbit_phase=k / 4)) for k in range(4)], OUT / "feature-orbit.png")
    (gif,) = bake_frames(caustics, OUT / "caustics.gif", 16, fps=8, size=(128, 128))
    print(f"wrote {gif}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
