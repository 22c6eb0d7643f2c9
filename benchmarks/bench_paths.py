#!/usr/bin/env python
"""The fragment path beside the compute path (issue 29; docs/fragment-path.md), interleaved.

One process, one context with compute shaders; every round runs each case once on each path
(``CELLGL_PATH=compute`` / ``fragment``, alternating which goes first) after a warm-up call
(compiles). The table gives per case the samples, the median wall time per sample on each path
in nanoseconds, and the median of the per-round speed ratios compute time / fragment time
(1: as fast; above 1: the fragment path is faster) of the process CPU time (all threads, llvmpipe's
included: the steadier measure on a shared machine), with their min-max, and of the wall time. Also whether both paths'
answers were bit-identical. The load average is printed with the table.

    python benchmarks/bench_paths.py                  # every case, 5 rounds
    python benchmarks/bench_paths.py --rounds 3 grid2 points2 bake
    python benchmarks/bench_paths.py --quick          # smaller sizes, 2 rounds

Cases: ``grid2`` (cellular_grid 1024^2, F1..F4), ``grid3`` (128 x 128 x 32, F1 F2 and the edge),
``points2`` (1e6 scattered 2D points, F1..F4), ``points3`` (5e5 scattered 3D points, F1 F2),
``bake`` (render flagstone 1024^2, colour), ``pups`` (render pups-cow 512^2).
"""
from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np


def _cases(quick: bool) -> dict:
    import cellgl

    k = 4 if quick else 1
    rng = np.random.default_rng(0)
    p2 = rng.uniform(0.0, 64.0, (1_000_000 // k, 2))
    p3 = rng.uniform(0.0, 64.0, (500_000 // k, 3))
    side, bake = 1024 // (2 if quick else 1), 1024 // (2 if quick else 1)
    return {
        "grid2": (side * side, lambda: cellgl.cellular_grid((side, side), n=4, outputs=("F",)).F),
        "grid3": (128 * 128 * 32 // k, lambda: cellgl.cellular_grid((128, 128, 32 // k), n=2,
                                                                      outputs=("F", "edge")).edge),
        "points2": (len(p2), lambda: cellgl.cellular(p2, 4, outputs=("F",)).F),
        "points3": (len(p3), lambda: cellgl.cellular(p3, 2, outputs=("F",)).F),
        "bake": (bake * bake, lambda: cellgl.render("flagstone", bake, bake)["color"]),
        "pups": (512 * 512 // k, lambda: cellgl.render("pups-cow", 512 // (2 if quick else 1),
                                                       512 // (2 if quick else 1))["color"]),
    }


def _timed(path: str, fn):
    """(wall seconds, process CPU seconds (all threads: llvmpipe's too), the answer)."""
    os.environ["CELLGL_PATH"] = path
    t, c = time.perf_counter(), time.process_time()
    out = fn()
    return time.perf_counter() - t, time.process_time() - c, out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("cases", nargs="*", help="cases to run (default: all)")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args(argv)
    from cellgl.gl import context
    from cellgl.gl.path import has_compute

    ctx = context.get_context()
    if not has_compute(ctx):
        raise SystemExit("bench_paths needs a context with compute shaders to compare the two paths")
    cases = _cases(args.quick)
    names = args.cases or list(cases)
    unknown = [n for n in names if n not in cases]
    if unknown:
        raise SystemExit(f"unknown case(s) {', '.join(unknown)}; accepted: {', '.join(cases)}")
    rows = []
    for name in names:
        count, fn = cases[name]
        a = _timed("compute", fn)[2]
        b = _timed("fragment", fn)[2]
        same = np.asarray(a).tobytes() == np.asarray(b).tobytes()
        t = {"compute": [], "fragment": []}
        for r in range(args.rounds):
            order = ("compute", "fragment") if r % 2 == 0 else ("fragment", "compute")
            for path in order:
                t[path].append(_timed(path, fn)[:2])
        cpu = [c[1] / f[1] for c, f in zip(t["compute"], t["fragment"])]
        wall = [c[0] / f[0] for c, f in zip(t["compute"], t["fragment"])]
        rows.append((name, count, statistics.median(x[0] for x in t["compute"]) / count * 1e9,
                     statistics.median(x[0] for x in t["fragment"]) / count * 1e9,
                     statistics.median(cpu), min(cpu), max(cpu), statistics.median(wall), same))
        print(f"  {name}: done", flush=True)
    os.environ.pop("CELLGL_PATH", None)
    print(f"\n{ctx.info['GL_RENDERER']}, {args.rounds} rounds, load average {os.getloadavg()[0]:.2f}")
    print("| case | samples | compute ns/sample | fragment ns/sample | compute / fragment, CPU time (min-max) "
          "| wall | same bits |")
    print("|---|---:|---:|---:|---|---:|---|")
    for name, count, nc, nf, med, lo, hi, wall, same in rows:
        print(f"| {name} | {count} | {nc:.0f} | {nf:.0f} | {med:.2f} ({lo:.2f}-{hi:.2f}) | {wall:.2f} "
              f"| {'yes' if same else 'NO'} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
