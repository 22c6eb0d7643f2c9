"""Bake every texture preset to docs/gallery/<name>.png and a labelled contact sheet.

Usage: python docs/make_gallery.py [--size 256] [--columns 8] [--no-variants] [--out DIR] [names...]

A preset's variants (``worley-gallery:3``) are baked too, to ``<name>-<variant>.png``. Each image is made with :func:`cellgl.bake.core.bake` (what ``cellgl bake NAME -o NAME.png`` does), so
the gallery shows exactly what the command line gives. The contact sheet
(``contact_sheet.png``, shown in the README) lays the images out in a grid with each preset's
name under it.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

from PIL import Image, ImageDraw, ImageFont

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from cellgl.io import formats as cio  # noqa: E402
from cellgl.bake.core import bake  # noqa: E402
from cellgl.texture.presets import list_presets, load_recipe  # noqa: E402

HERE = Path(__file__).resolve().parent


def _font(size: int):
    for name in ("DejaVuSans.ttf", "Arial.ttf"):
        try:
            return ImageFont.truetype(name, size)
        except OSError:
            pass
    try:
        return ImageFont.load_default(size)
    except TypeError:  # Pillow < 10.1
        return ImageFont.load_default()


def contact_sheet(images: list[tuple[str, Path]], path: Path, *, thumb: int = 160,
                  columns: int = 8, pad: int = 8, label: int = 22) -> None:
    """Lay out ``(name, png)`` pairs in a grid, names underneath; write ``path`` atomically."""
    columns = max(1, min(columns, len(images)))
    rows = math.ceil(len(images) / columns)
    cw, ch = thumb + pad, thumb + label + pad
    sheet = Image.new("RGB", (columns * cw + pad, rows * ch + pad), (24, 24, 24))
    draw = ImageDraw.Draw(sheet)
    font = _font(14)
    for i, (name, png) in enumerate(images):
        x, y = pad + (i % columns) * cw, pad + (i // columns) * ch
        with Image.open(png) as im:
            sheet.paste(im.convert("RGB").resize((thumb, thumb), Image.LANCZOS), (x, y))
        text = name
        while draw.textlength(text, font=font) > thumb and len(text) > 2:
            text = text[:-2] + "…"
        tw = draw.textlength(text, font=font)
        draw.text((x + (thumb - tw) / 2, y + thumb + 3), text, fill=(230, 230, 230), font=font)
    # A 256-colour palette (dithered) keeps the README's image near 0.6 MB instead of 2 MB.
    palette = sheet.quantize(256, method=Image.Quantize.MEDIANCUT)
    sheet = sheet.quantize(palette=palette, dither=Image.Dither.FLOYDSTEINBERG)
    with cio.atomic_path(path) as tmp:
        sheet.save(tmp, format="PNG", optimize=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*", help="presets to bake (default: all)")
    ap.add_argument("--size", type=int, default=256, help="pixels per side (default 256)")
    ap.add_argument("--thumb", type=int, default=160, help="contact sheet cell size")
    ap.add_argument("--columns", type=int, default=8)
    ap.add_argument("--no-variants", action="store_true",
                    help="only the presets themselves, not their variants (name:variant)")
    ap.add_argument("--out", type=Path, default=HERE / "gallery")
    args = ap.parse_args(argv)

    presets = []
    for name, _ in list_presets():
        if name.startswith("pups-"):  # docs/make_pups_gallery.py renders those (512, grey)
            continue
        presets.append(name)
        if not args.no_variants:
            presets += [v.name if v.name.startswith(f"{name}:") else f"{name}:{k}"
                        for k, v in enumerate(load_recipe(name).variants)]
    unknown = [n for n in args.names if n not in presets]
    if unknown:
        ap.error(f"unknown preset(s) {', '.join(unknown)}; accepted {', '.join(presets)}")
    names = args.names or presets
    args.out.mkdir(parents=True, exist_ok=True)
    done = []
    for name in names:
        t = time.perf_counter()
        (png,) = bake(name, args.out / f"{name.replace(':', '-')}.png", size=(args.size, args.size),
                      progress=False)
        done.append((name, png))
        print(f"{name:24s} {time.perf_counter() - t:6.2f} s  {png}")
    if not args.names:  # the sheet shows every preset; a partial run leaves it alone
        sheet = args.out / "contact_sheet.png"
        contact_sheet(done, sheet, thumb=args.thumb, columns=args.columns)
        print(f"contact sheet: {sheet}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
