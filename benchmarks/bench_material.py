#!/usr/bin/env python
"""An engine material set with mips in DDS BC7 against the same maps as PNG without mips, and
against the block encoder alone on the same pixels (issue 45, item 6).

For one preset, engine (default ``unreal``: BC, N, ORM, H) and size S, in one process,
interleaved (A, B, C, D, A, ...), best of K, after a warm-up at 64^2 (shaders, the encoder's pool):

* ``png set``: ``bake_material(preset, DIR, engine, size=S)``: every map as PNG, level 0 only;
* ``dds set``: ``bake_material(..., map_format="dds", mips=True)``: every level of every map
  rendered at its own size and packed, BC7 sRGB colour, BC5 normal, BC7 linear ORM, R16 height
  (``cellgl.bake.material_sets.gpu_format``), the blocks on every core, the containers written;
* ``encoder``: ``cellgl.io.blocks.encode_levels`` of each block-format map's levels, on the very
  pixels the dds set encodes (captured from one dds bake beforehand), on every core, and on one
  (``encoder, 1 core``).

``dds set - encoder`` is cellgl's own work around the encoder (rendering 4/3 of the pixels, the
packing, the containers); its ratio to the PNG set is the number issue 45 bounds (<= 1.5x).

    python benchmarks/bench_material.py --size 1024 --repeats 2
    python benchmarks/bench_material.py --size 4096 --repeats 1 flagstone unreal

Results: docs/performance.md ("Material sets as DDS").
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
    ap.add_argument("engine", nargs="?", default="unreal")
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--repeats", type=int, default=2)
    args = ap.parse_args(argv)

    from cellgl.io import gpu_textures
    from cellgl.io import blocks
    from cellgl.bake import material_sets as M
    from cellgl.io.formats import usable_cores
    from cellgl.recipes import load_recipe

    recipe = load_recipe(args.preset)
    s = args.size
    captured = []
    real = gpu_textures.packed_levels

    def spy(fmt, images):
        images = list(images)
        if fmt.compressed:
            captured.append((fmt, images))
        return real(fmt, images)

    with tempfile.TemporaryDirectory() as d:
        def png(size=s):
            return M.bake_material(recipe, os.path.join(d, "png"), args.engine, size=size, progress=False)

        def dds(size=s):
            return M.bake_material(recipe, os.path.join(d, "dds"), args.engine, size=size, map_format="dds",
                                   mips=True, progress=False)

        png(64), dds(64)                      # warm-up: shaders, the encoder pool's first start
        gpu_textures.packed_levels = spy
        try:
            dds()                             # the pixels the encoder rows encode
        finally:
            gpu_textures.packed_levels = real
        px = sum(a.shape[0] * a.shape[1] for _, images in captured for a in images)

        def encoder(workers=None):
            for fmt, images in captured:
                blocks.encode_levels(fmt.codec, images, workers=workers, perceptual=fmt.srgb)

        rows = {"png set (level 0, no mips)": png, "dds set (BC7/BC5/R16, every mip level)": dds,
                "encoder (same pixels, every core)": encoder, "encoder, 1 core": lambda: encoder(1)}
        best = best_times(rows, args.repeats)
        mib = {f: sum(os.path.getsize(os.path.join(d, f, n)) for n in os.listdir(os.path.join(d, f))) / 2 ** 20
               for f in ("png", "dds")}
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"{args.preset} --material {args.engine} {s}^2: {len(captured)} block-encoded maps, "
          f"{px / 1e6:.2f} Mpx through the encoder; {usable_cores()} cores, load {load:.1f}, best of "
          f"{args.repeats}; png set {mib['png']:.2f} MiB, dds set {mib['dds']:.2f} MiB")
    print(seconds_table(best))
    own = best["dds set (BC7/BC5/R16, every mip level)"] - best["encoder (same pixels, every core)"]
    print(f"| cellgl's own work in the dds set (dds - encoder) | {own:.2f} |")
    print(f"\ndds set / png set: {best['dds set (BC7/BC5/R16, every mip level)'] / best['png set (level 0, no mips)']:.2f}x; "
          f"own work / png set: {own / best['png set (level 0, no mips)']:.2f}x (issue 45: <= 1.5x); "
          f"encoder / dds set: {best['encoder (same pixels, every core)'] / best['dds set (BC7/BC5/R16, every mip level)']:.2f}; "
          f"encoder on every core vs one: {best['encoder, 1 core'] / best['encoder (same pixels, every core)']:.2f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
