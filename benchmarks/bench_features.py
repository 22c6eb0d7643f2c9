#!/usr/bin/env python
"""What the Voronoi-cell features cost, and that the F1..Fn fast path did not slow down.

1. Feature cost: ``cellgl.cellular_grid`` with F1 only, then with each feature output (distance
   to edge, smooth F1, n-sphere radius), on the GPU; times and ratios against F1 alone.
2. ``--baseline REPO``: the fast path (F1..F4 on grids, two preset bakes) timed with this
   checkout and with another one (e.g. a checkout of main), alternating in subprocesses, best
   of ``--repeats``; the ratio this / baseline.

3. ``--smooth``: smooth F1 against smoothness, log-sum-exp against Blender's polynomial fold.

    python benchmarks/bench_features.py [--quick] [--baseline /path/to/other/checkout] [--smooth]
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

_REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# The fast-path workload, run in a subprocess with PYTHONPATH set to a checkout.
_FAST = r"""
import json, sys, time
import cellgl
from cellgl.recipes import load_recipe, render
size2, size3, bake = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
def best(fn, k=3):
    fn()
    t = float("inf")
    for _ in range(k):
        t0 = time.perf_counter(); fn(); t = min(t, time.perf_counter() - t0)
    return t
out = {
  "grid 2D F1..F4": best(lambda: cellgl.cellular_grid((size2, size2), spacing=1 / 16, n=4, outputs=("F",))),
  "grid 3D F1..F2": best(lambda: cellgl.cellular_grid((size3,) * 3, spacing=1 / 8, n=2, outputs=("F",))),
}
for name in ("flagstone", "rock"):
    r = load_recipe(name)
    out[f"bake {name}"] = best(lambda: render(r, bake, bake))
print(json.dumps(out))
"""


def best(fn, repeats=3):
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from bench_core import best_time

    return best_time(fn, repeats)


def feature_cost(quick: bool) -> None:
    sys.path.insert(0, _REPO)
    import cellgl

    rows = []
    for dim, side, spacing in ((2, 256 if quick else 512, 1 / 16), (3, 24 if quick else 48, 1 / 6)):
        shape = (side,) * dim
        base = best(lambda shape=shape, spacing=spacing: cellgl.cellular_grid(shape, spacing=spacing, n=1, outputs=("F",)))
        rows.append((dim, side, "F1", base, 1.0))
        for name, outs in (("edge", ("edge",)), ("smooth_F1 (k = 0.1)", ("smooth_F1",)),
                           ("nsphere", ("nsphere",)), ("all", ("edge", "smooth_F1", "nsphere"))):
            t = best(lambda shape=shape, spacing=spacing, outs=outs: cellgl.cellular_grid(shape, spacing=spacing, n=1,
                                                                                   outputs=outs, smoothness=0.1))
            rows.append((dim, side, name, t, t / base))
    print("| dim | grid | outputs | time (ms) | / F1 |")
    print("| --- | --- | --- | --- | --- |")
    for dim, side, name, t, ratio in rows:
        print(f"| {dim}D | {side}^{dim} | {name} | {t * 1e3:.1f} | {ratio:.2f} |")


def smooth_cost(quick: bool) -> None:
    """Smooth F1 against smoothness: cellgl's log-sum-exp walk (visits every point within
    F1 + 16 k) and Blender's polynomial fold (the node's 5^d block: flat in k)."""
    sys.path.insert(0, _REPO)
    import cellgl

    rows = []
    for dim, side, spacing in ((2, 256 if quick else 512, 1 / 16), (3, 24 if quick else 48, 1 / 6)):
        shape = (side,) * dim
        kw = dict(spacing=spacing, n=1, distribution="blender")
        base = best(lambda shape=shape, kw=kw: cellgl.cellular_grid(shape, outputs=("F",), **kw))
        rows.append((dim, side, "F1", "", base))
        for mode, ks in (("exp", (0.05, 0.1, 0.25)), ("polynomial", (0.25, 0.5, 1.0))):
            for k in ks:
                t = best(lambda shape=shape, k=k, mode=mode, kw=kw: cellgl.cellular_grid(
                    shape, outputs=("smooth_F1",), smoothness=k, smooth=mode, **kw))
                rows.append((dim, side, f"smooth_F1 {mode}", k, t))
    print("| dim | grid | outputs | smoothness | time (ms) | / F1 |")
    print("| --- | --- | --- | --- | --- | --- |")
    base = {}
    for dim, side, name, k, t in rows:
        base.setdefault(dim, t)
        print(f"| {dim}D | {side}^{dim} | {name} | {k} | {t * 1e3:.1f} | {t / base[dim]:.2f} |")


def fast_path(baseline: str, quick: bool, repeats: int) -> None:
    args = ["256", "32", "256"] if quick else ["1024", "96", "512"]
    times: dict = {"this": {}, "baseline": {}}
    for _ in range(repeats):
        for who, repo in (("this", _REPO), ("baseline", baseline)):
            env = dict(os.environ, PYTHONPATH=repo)
            res = subprocess.run([sys.executable, "-c", _FAST, *args], env=env, cwd=repo, check=True,
                                 capture_output=True, text=True)
            for k, v in json.loads(res.stdout.strip().splitlines()[-1]).items():
                times[who][k] = min(times[who].get(k, float("inf")), v)
    print(f"\nfast path, best of {repeats} alternating runs: this = {_REPO}, baseline = {baseline}")
    print("| workload | this (ms) | baseline (ms) | this / baseline |")
    print("| --- | --- | --- | --- |")
    for k in times["this"]:
        a, b = times["this"][k], times["baseline"][k]
        print(f"| {k} | {a * 1e3:.1f} | {b * 1e3:.1f} | {a / b:.3f} |")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="small sizes (a smoke run)")
    ap.add_argument("--baseline", metavar="REPO", help="another checkout to time the fast path against")
    ap.add_argument("--repeats", type=int, default=3, help="alternating rounds against the baseline")
    ap.add_argument("--smooth", action="store_true",
                    help="only smooth F1 against smoothness (log-sum-exp vs Blender's polynomial fold)")
    a = ap.parse_args()
    print(f"load: {os.getloadavg()[0]:.2f} (1 min), {os.cpu_count()} cores")
    if a.smooth:
        smooth_cost(a.quick)
        return 0
    feature_cost(a.quick)
    if a.baseline:
        fast_path(os.path.abspath(a.baseline), a.quick, a.repeats)
    return 0


if __name__ == "__main__":
    sys.exit(main())
