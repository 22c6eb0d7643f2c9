#!/usr/bin/env python
"""Exact F1 + F2 from cellgl against FastNoiseLite's approximate Distance2, interleaved.

The same scattered points (uniform in [0, 64)^d, 1e6 by default) go to both, round by round
(FastNoiseLite, then each cellgl distribution), and the table gives the median rate of each and
the median of the per-round ratios cellgl / FastNoiseLite, so a change of load on a shared machine
hits both sides alike. FastNoiseLite: Cellular, Euclidean, Distance2 (F1 and F2 in one loop),
jitter 1, frequency 1, one thread (pyfastnoiselite). cellgl: ``cellgl.cellular(points, n=2,
outputs=("F",))`` on the GPU, float64 points in, F read back (jitter 1, and poisson at the default
density 3). See benchmarks/README.md for what FastNoiseLite does not search.

The last column compares CPU time (this process, all threads) instead of wall time: FastNoiseLite
uses one core, llvmpipe two, so on an idle 2-core machine the wall-time ratio approaches twice the
CPU-time ratio; on a loaded one the CPU-time ratio is the steadier of the two.

    python benchmarks/bench_vs_fnl.py [--points 1e6] [--repeats 7] [--dims 2 3]

``--grid S``: instead of scattered points, the S x S grid slice of [0, 64)^2 (3D: at z = 0.37),
pixel centres, spacing 64 / S: FastNoiseLite gets their coordinates, cellgl calls
``cellgl.cellular_grid`` (the grid path of the compute shader, where a workgroup's samples are
neighbours). ``--cache on|off|both``: cellgl's workgroup-shared cell cache on the grid path
(``CELLGL_CELL_CACHE``; docs/performance.md), both: a row each.
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

import numpy as np

_REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if _REPO not in sys.path:
    sys.path.insert(0, _REPO)


def fnl(n: int):
    from pyfastnoiselite.pyfastnoiselite import (CellularDistanceFunction, CellularReturnType,
                                                 FastNoiseLite, NoiseType)

    f = FastNoiseLite(0)
    f.noise_type = NoiseType.NoiseType_Cellular
    f.cellular_distance_function = CellularDistanceFunction.CellularDistanceFunction_Euclidean
    f.cellular_return_type = (CellularReturnType.CellularReturnType_Distance if n == 1
                              else CellularReturnType.CellularReturnType_Distance2)
    f.cellular_jitter = 1.0
    f.frequency = 1.0
    return f


def _with_cache(call, cache):
    """``call`` with CELLGL_CELL_CACHE set to ``cache`` (None: as the environment has it)."""
    if cache is None:
        return call

    def run():
        old = os.environ.get("CELLGL_CELL_CACHE")
        os.environ["CELLGL_CELL_CACHE"] = cache
        try:
            return call()
        finally:
            if old is None:
                os.environ.pop("CELLGL_CELL_CACHE")
            else:
                os.environ["CELLGL_CELL_CACHE"] = old
    return run


def timed(fn) -> tuple[float, float]:
    """(wall seconds, CPU seconds of this process: every thread, llvmpipe's included)."""
    t0, c0 = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - t0, time.process_time() - c0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--points", type=float, default=1e6)
    ap.add_argument("--repeats", type=int, default=7, help="interleaved rounds (medians reported)")
    ap.add_argument("--dims", type=int, nargs="+", default=[3, 2], choices=(2, 3))
    ap.add_argument("--n", type=int, default=2, choices=(1, 2), help="1: F1, 2: F1 and F2")
    ap.add_argument("--grid", type=int, default=0, help="S: an S x S grid slice instead of points")
    ap.add_argument("--cache", default="default", choices=("default", "on", "off", "both"),
                    help="the grid path's shared cell cache (CELLGL_CELL_CACHE)")
    a = ap.parse_args()
    import cellgl

    N = int(a.points)
    rng = np.random.default_rng(0)
    load0 = os.getloadavg()[0]
    rows = []
    caches = {"default": [None], "on": ["1"], "off": ["0"], "both": ["0", "1"]}[a.cache]
    for d in a.dims:
        if a.grid:
            S, h = a.grid, 64.0 / a.grid
            origin = (h / 2, h / 2) + ((0.37,) if d == 3 else ())
            shape = (S, S) if d == 2 else (1, S, S)
            N = S * S
            yy, xx = np.meshgrid(origin[1] + h * np.arange(S), origin[0] + h * np.arange(S), indexing="ij")
            coords = np.stack([xx.ravel(), yy.ravel()] + ([np.full(N, 0.37)] if d == 3 else [])).astype(np.float32)
        else:
            pts = rng.uniform(0.0, 64.0, (N, d))
            coords = np.ascontiguousarray(pts.T, dtype=np.float32)
        f = fnl(a.n)
        calls = {"FastNoiseLite": lambda f=f, coords=coords: f.gen_from_coords(coords)}
        for dist in ("jitter", "poisson"):
            for cache in caches:
                name = f"cellgl {dist}" + ("" if cache is None else f" cache {'on' if cache == '1' else 'off'}")
                if a.grid:
                    def call(dist=dist, shape=shape, origin=origin, h=h):
                        return np.asarray(cellgl.cellular_grid(
                            shape, origin=origin, spacing=h, n=a.n, distribution=dist, jitter=1.0, seed=0,
                            outputs=("F",)).F)
                else:
                    def call(dist=dist, pts=pts):
                        return np.asarray(cellgl.cellular(
                            pts, n=a.n, distribution=dist, jitter=1.0, seed=0, outputs=("F",)).F)
                calls[name] = _with_cache(call, cache)
        for fn in calls.values():
            fn()                                     # warm-up (compiles the shaders)
        t = {k: [] for k in calls}
        for _ in range(a.repeats):
            for k, fn in calls.items():
                t[k].append(timed(fn))
        base = t["FastNoiseLite"]
        for k in calls:
            ratios = [b[0] / x[0] for b, x in zip(base, t[k])]
            cpu = statistics.median(b[1] / x[1] for b, x in zip(base, t[k]))
            rows.append((d, k, N / statistics.median(x[0] for x in t[k]) / 1e6, statistics.median(ratios),
                         min(ratios), max(ratios), cpu))
    load1 = os.getloadavg()[0]
    what = "F1 + F2" if a.n == 2 else "F1"
    where = f"a {a.grid}^2 grid slice" if a.grid else f"{N} scattered points"
    print(f"{what}, {where}, median of {a.repeats} interleaved rounds; "
          f"load {load0:.1f} -> {load1:.1f} (1 min), {os.cpu_count()} cores")
    print("| dim | library | Ms/s | x FastNoiseLite (median, min-max) | x FastNoiseLite, CPU time |")
    print("| --- | --- | ---: | ---: | ---: |")
    for d, k, rate, r, lo, hi, cpu in rows:
        print(f"| {d}D | {k} | {rate:.2f} | {r:.2f} ({lo:.2f}-{hi:.2f}) | {cpu:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
