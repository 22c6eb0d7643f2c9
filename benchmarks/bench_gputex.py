#!/usr/bin/env python
"""A BC7 DDS with its mip chain against a plain PNG bake, and against the block encoder alone.

For one preset and size S, in one process, interleaved (A, B, C, A, B, C, ...), best of K:

* ``png``: ``bake(preset, "x.png", size=S)``: level 0, no mips (the bake a user runs today);
* ``dds``: ``bake(preset, "x.dds", size=S, mips=True)``: every level rendered at its own size,
  quantised, BC7-encoded on every core, written;
* ``encoder``: ``cellgl.io.blocks.encode_levels("bc7", levels)`` on the same pixels (the chain
  rendered once beforehand), on every core, and on one (``encoder, 1 core``).

``dds - encoder`` is cellgl's own work around the encoder (rendering 4/3 of the pixels, the
quantisation, the container); its ratio to ``png`` is the number issue 45 bounds (<= 1.5x).
``encoder, 1 core / encoder`` is how much of the machine the encoder uses.

    python benchmarks/bench_gputex.py --size 1024 --repeats 3
    python benchmarks/bench_gputex.py --size 4096 --repeats 1 flagstone

Results: docs/performance.md ("GPU texture files").
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile

_REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if _REPO not in sys.path:
    sys.path.insert(0, _REPO)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from bench_core import best_times, seconds_table  # noqa: E402 - after the path is set


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("preset", nargs="?", default="flagstone")
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args(argv)

    from cellgl.bake import core as B
    from cellgl.bake import mips
    from cellgl.io import gpu_textures
    from cellgl.io import blocks
    from cellgl.io.formats import usable_cores
    from cellgl.recipes import load_recipe

    recipe = load_recipe(args.preset)
    s = args.size
    fmt = gpu_textures.containers.TEX_FORMATS["BC7_SRGB"]
    levels = [gpu_textures.texel_samples(fmt, "color", res["color"])
              for _, _, res in mips.render_chain(recipe, s, s, rounding="down")]
    px = sum(a.shape[0] * a.shape[1] for a in levels)
    with tempfile.TemporaryDirectory() as d:
        rows = {
            "png (level 0, no mips)": lambda: B.bake(recipe, os.path.join(d, "x.png"), size=s, progress=False),
            "dds BC7 + mips": lambda: B.bake(recipe, os.path.join(d, "x.dds"), size=s, mips=True, progress=False),
            "encoder": lambda: blocks.encode_levels("bc7", levels),
            "encoder, 1 core": lambda: blocks.encode_levels("bc7", levels, workers=1),
        }
        for fn in rows.values():        # warm-up: shaders, the pool's first start
            fn()
        best = best_times(rows, args.repeats)
        size = os.path.getsize(os.path.join(d, "x.dds"))
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"{args.preset} {s}^2, chain {len(levels)} levels ({px / 1e6:.2f} Mpx), {usable_cores()} cores, "
          f"load {load:.1f}, best of {args.repeats}; dds {size / 2**20:.2f} MiB")
    print(seconds_table(best))
    own = best["dds BC7 + mips"] - best["encoder"]
    print(f"| cellgl's own work in the dds bake (dds - encoder) | {own:.2f} |")
    print(f"\nown work / png: {own / best['png (level 0, no mips)']:.2f}x (issue 45: <= 1.5x); "
          f"encoder on every core vs one: {best['encoder, 1 core'] / best['encoder']:.2f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
