"""GPU against brute force: how often does cellgl's F1..Fn differ from the truth?

For every dimension x metric x distribution, samples in a box, the n nearest of *all* feature
points in a surrounding block of cells (from ``cellgl.feature_points``) are the truth. Prints
the number of (sample, k) slots whose feature ID differs (``id mismatches``; those at true ties,
where two points are equally far within 1e-6, are counted apart), the largest |F error| and the
samples the search itself flagged as inexact (the cap).

    python benchmarks/exactness.py [--samples N] [--n 4]
"""
from __future__ import annotations

import argparse
import itertools
import time

import numpy as np

import cellgl
from cellgl.basis import reference

METRICS = ("euclidean", "manhattan", "chebyshev", "minkowski")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=4000)
    ap.add_argument("--n", type=int, default=4)
    args = ap.parse_args(argv)
    cases = [(d, m, dist, kw) for d in (2, 3, 4) for m in METRICS
             for dist, kw in (("poisson", {}), ("poisson", {"density": 0.7, "min_points": 0}),
                              ("jitter", {}))]
    cases += [(3, m, "worley1996", {}) for m in METRICS]
    print(f"{'dim':>3} {'metric':<10} {'distribution':<34} {'samples':>7} {'slots':>7} "
          f"{'id mismatches':>13} {'at ties':>7} {'max |dF|':>9} {'inexact':>7}")
    total = mism_total = 0
    t0 = time.perf_counter()
    for dim, metric, dist, kw in cases:
        n = args.n
        rng = np.random.default_rng(dim * 100 + len(metric))
        samples = args.samples if dim < 4 else args.samples // 4
        pts = rng.uniform(-2.0, 2.0, (samples, dim))
        g = cellgl.cellular(pts, n, metric=metric, distribution=dist, outputs=("F", "id"), **kw)
        scale = reference.W96_DENSITY_ADJUSTMENT if dist == "worley1996" else 1.0
        reach = {2: 8, 3: 5, 4: 3}[dim]
        lo, hi = int(np.floor(-2.0 * scale)) - reach, int(np.floor(2.0 * scale)) + reach
        cells = np.array(list(itertools.product(range(lo, hi + 1), repeat=dim)))
        fp = cellgl.feature_points(cells, distribution=dist, **kw)
        F, ids = reference.brute_force(pts, fp.positions, fp.ids, metric, n + 1)
        ok = g.exact
        diff = (g.id != ids[:, :n]) & ok[:, None]
        gap = np.minimum(np.abs(np.diff(F, axis=1))[:, :n],
                         np.abs(np.diff(F, axis=1, prepend=-1.0))[:, :n])
        ties = diff & (gap < 1e-6)
        real = int((diff & ~ties).sum())
        err = float(np.abs(g.F[ok] - F[ok, :n]).max()) if ok.any() else 0.0
        total += ok.sum() * n
        mism_total += real
        label = dist + (" " + ",".join(f"{k}={v}" for k, v in kw.items()) if kw else "")
        print(f"{dim:>3} {metric:<10} {label:<34} {samples:>7} {int(ok.sum()) * n:>7} {real:>13} "
              f"{int(ties.sum()):>7} {err:>9.2e} {int((~ok).sum()):>7}")
    print(f"total: {mism_total} ID mismatches (away from ties) in {total} slots "
          f"({time.perf_counter() - t0:.0f} s)")
    return 0 if mism_total == 0 else 1


if __name__ == "__main__":
    raise SystemExit(main())
