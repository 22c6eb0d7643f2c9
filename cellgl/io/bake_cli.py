"""Command line of ``cellgl bake`` (docs/bake.md): arguments, then :func:`cellgl.io.bake.bake`."""
from __future__ import annotations

import argparse
import os
import sys
import time

from cellgl.io.bake import bake
from cellgl.io.spec import DEFAULT_BUDGET, DEFAULT_SIZE, BakeError
from cellgl.texture.antialias import MAX_SAMPLES

__all__ = ["add_parser", "run_cli"]


_EPILOG = """\
formats (from the extension) and --depth (bits per sample):
  .png  8 (default) or 16     .exr  16 (half) or 32 (float, default)
  .tif  8, 16 or 32 (float, default; tiled)     .npy  32 (float32)
channels: color (RGB), height, normal (RGB), id (uint32; false colour in .png), F1..F4.
  An .exr holds every channel asked for; other formats write <stem>_<channel><ext> each.
examples:
  cellgl bake flagstone -o flagstone.png
  cellgl bake flagstone -o flagstone.exr --size 2048 --channels color,height,normal
  cellgl bake crumple -o crumple.png --size 256 --samples 4
  cellgl bake my_recipe.json -o big.tif --size 16384x16384 --tileable
  cellgl bake flagstone -o vol.npy --size 64x64x64 --channels F1
"""


def add_parser(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Declare ``cellgl bake``'s arguments on a subparsers object."""
    p = sub.add_parser(
        "bake", help="render a preset or recipe to .png/.exr/.tif/.npy",
        description="Render a preset or recipe JSON to an image or volume file.",
        epilog=_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("recipe", metavar="PRESET_OR_RECIPE",
                   help="a preset name (cellgl presets) or a recipe .json file")
    p.add_argument("-o", "--output", required=True, metavar="FILE",
                   help="output file: .png, .exr, .tif/.tiff or .npy")
    p.add_argument("--size", default=f"{DEFAULT_SIZE[0]}x{DEFAULT_SIZE[1]}", metavar="W[xH[xD]]",
                   help="pixels (default %(default)s); a third number bakes a volume of D slices")
    p.add_argument("--set", dest="sets", action="append", default=[], metavar="NAME=VALUE",
                   help="override a recipe parameter (repeatable)")
    p.add_argument("--tileable", action="store_true", default=None,
                   help="make the texture wrap around at its edges")
    p.add_argument("--channels", action="append", default=None, metavar="LIST",
                   help="comma-separated: color, height, normal, id, F1..F4 (default color)")
    p.add_argument("--depth", default=None, metavar="BITS",
                   help="bits per sample: 8|16|32 (default per format, see below)")
    p.add_argument("--samples", default="1", metavar="N",
                   help="samples per pixel: 1 (default), 4, 9, 16, ... 64 (an n x n grid averaged: "
                        "smooth edges; band-limited fractals need none)")
    p.add_argument("--tile", default=None, metavar="N",
                   help="advanced: render N x N tiles (multiple of 16) instead of a size chosen "
                        "from --memory")
    p.add_argument("--memory", default=None, metavar="MB",
                   help=f"advanced: MB of working memory to stay within; sets the tile size "
                        f"(default {DEFAULT_BUDGET >> 20})")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar, no summary")
    return p


def _int_arg(flag: str, text, lo: int, hi: int) -> int:
    try:
        v = int(str(text).strip())
    except ValueError:
        raise BakeError(f"{flag} {text!r}: expected a whole number in {lo}..{hi}") from None
    if not lo <= v <= hi:
        raise BakeError(f"{flag} {v}: out of range; accepted {lo}..{hi}")
    return v


def run_cli(args: argparse.Namespace) -> int:
    """Run ``cellgl bake`` from parsed arguments; errors are raised as BakeError (ValueError)."""
    budget = DEFAULT_BUDGET if args.memory is None else \
        _int_arg("--memory", args.memory, 1, 1 << 20) << 20
    tile = None if args.tile is None else _int_arg("--tile", args.tile, 16, 8192)
    samples = _int_arg("--samples", args.samples, 1, MAX_SAMPLES)
    t0 = time.perf_counter()
    try:
        paths = bake(args.recipe, args.output, size=args.size,
                     channels=tuple(args.channels or ("color",)), bit_depth=args.depth,
                     tileable=args.tileable, sets=args.sets, tile=tile, samples=samples,
                     progress=not args.quiet, memory_budget=budget)
    except OSError as exc:
        where = f" {exc.filename}" if exc.filename else ""
        raise BakeError(f"cannot write{where}: {exc.strerror or exc}") from None
    if not args.quiet:
        secs = time.perf_counter() - t0
        for p in paths:
            print(f"wrote {p} ({os.path.getsize(p) / 1024:.0f} KiB, {secs:.1f} s)",
                  file=sys.stderr)
    return 0
