"""The loop budget every GPU path of the cellular basis spends (docs/exactness.md).

Runs the measurement build of ``shaders/cellular.comp`` (``CELL_LOOP_PROBE``,
:func:`cellgl.basis.gpu.loop_probe`) over a matrix of dimensions x distributions x metrics x n x
outputs (the basis, and each feature walk in its own pass, smooth at the largest smoothness), with
stretch, period and density maps, and prints per case: the largest count of the search's own
counter per invocation (``own``, bounded by ``CELL_LOOP_BUDGET``), the largest count llvmpipe's
limiter took for one SIMD vector of invocations (``driver``, limit 65535) and the share of samples
the GPU flagged (recomputed by the NumPy reference before they reach the user).

    python benchmarks/loop_budget.py [--samples 1024] [--quick]
    python benchmarks/loop_budget.py --fallback     # what the NumPy fallback costs
    python benchmarks/loop_budget.py --sparse       # flagged shares of sparse Poisson, by density
"""
from __future__ import annotations

import argparse
import itertools
import time

import numpy as np

from cellgl.basis import core, gpu
from cellgl.basis.density import DensityMap
from cellgl.basis.features import SMOOTHNESS_MAX

METRICS = ("euclidean", "manhattan", "chebyshev", "minkowski")
DISTS = {
    "poisson 3": dict(distribution="poisson"),
    "poisson 16 (16 max)": dict(distribution="poisson", density=16.0, min_points=0, max_points=16),
    "poisson 0.25 (min 0)": dict(distribution="poisson", density=0.25, min_points=0),
    "jitter 1": dict(distribution="jitter"),
    "worley1996": dict(distribution="worley1996"),
}
FEATURES = {"edge": ("edge", "edge_grad"), "nsphere": ("nsphere",), "smooth 0.25": ("smooth_F1",)}


def cases(quick: bool):
    ns = (1, 8) if quick else (1, 4, 8)
    for dim, (dname, kw), metric, n in itertools.product((2, 3, 4), DISTS.items(), METRICS, ns):
        if kw["distribution"] == "worley1996" and dim != 3:
            continue
        yield dim, dname, dict(kw, metric=metric), n, "F, delta, id, grad"
    for dim, (dname, kw), (fname, _outs) in itertools.product((2, 3, 4), DISTS.items(), FEATURES.items()):
        if kw["distribution"] == "worley1996" and dim != 3:
            continue
        yield dim, dname, dict(kw), 1, fname
        if fname == "smooth 0.25":
            yield dim, dname, dict(kw, metric="minkowski", minkowski_p=0.5), 1, fname + " minkowski 0.5"
    for dim in (2, 3, 4):
        yield dim, "poisson 3", dict(stretch=[8.0] + [1.0] * (dim - 1)), 8, "stretch 8: F"
        yield dim, "poisson 3", dict(period=[5] * dim), 8, "period 5: F"
        dm = DensityMap("ramp", axis=0, start=-30.0, end=30.0, density_min=0.1, density_max=16.0)
        yield dim, "ramp 0.1..16", dict(density_map=dm, min_points=0, max_points=16), 8, "density map: F"
        yield dim, "poisson 3", dict(metric="minkowski", minkowski_p=0.25), 8, "minkowski 0.25: F"


def _outputs(label: str):
    for name, outs in FEATURES.items():
        if label.startswith(name):
            return outs
    return ("F", "delta", "id", "grad")


def fallback_cost(samples: int) -> None:
    """Seconds per call of :func:`cellgl.cellular` where the GPU serves every sample, where the
    fallback recomputes every sample (4D smooth F1 at the largest smoothness: no invocation can
    finish it inside llvmpipe's limit), and the NumPy backend for the same request."""
    import cellgl

    rng = np.random.default_rng(3)
    print(f"{'case':<34} {'samples':>7} {'gpu s':>7} {'flagged':>8} {'numpy s':>8}")
    for dim, label, kw in [(4, "smooth_F1 k=0.25 (4D)", dict(outputs=("smooth_F1",), smoothness=SMOOTHNESS_MAX)),
                           (3, "smooth_F1 k=0.25 (3D)", dict(outputs=("smooth_F1",), smoothness=SMOOTHNESS_MAX)),
                           (4, "F1..F4 (4D)", dict(outputs=("F",)))]:
        pts = rng.uniform(-50, 50, (samples, dim))
        p = core.make_params(dim)
        cellgl.cellular(pts[:64], 4 if label.startswith("F") else 1, **kw)     # compile
        _, _, flagged = gpu.loop_probe(pts[: min(samples, 4096)], p, 1, core._gpu_outputs(kw["outputs"], p),
                                       kw.get("smoothness", 0.0))
        t = time.perf_counter()
        cellgl.cellular(pts, 4 if label.startswith("F") else 1, **kw)
        tg = time.perf_counter() - t
        t = time.perf_counter()
        cellgl.cellular(pts, 4 if label.startswith("F") else 1, backend="numpy", **kw)
        tn = time.perf_counter() - t
        print(f"{label:<34} {samples:>7} {tg:>7.2f} {flagged.mean():>8.1%} {tn:>8.2f}", flush=True)


def sparse(samples: int) -> None:
    """Sparse Poisson (``min_points=0``): the share of samples the GPU flagged (and the fallback
    recomputed) and the share still flagged in ``exact`` after the fallback, by dimension and
    density, for F1..F4 and F1..F8."""
    import warnings

    import cellgl

    rng = np.random.default_rng(11)
    print(f"{'dim':>3} {'density':>8} {'n':>2} {'GPU flagged':>11} {'returned inexact':>16} {'s':>6}")
    for dim in (2, 3, 4):
        for density in (0.25, 0.1, 0.05, 0.02, 0.01, 0.005, 0.002, 0.001):
            for n in (4, 8):
                pts = rng.uniform(-1000, 1000, (samples, dim))
                p = core.make_params(dim, density=density, min_points=0)
                _, _, flagged = gpu.loop_probe(pts[:4096], p, n, ("F",))
                t = time.perf_counter()
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    r = cellgl.cellular(pts, n, density=density, min_points=0, outputs=("F",))
                dt = time.perf_counter() - t
                print(f"{dim:>3} {density:>8} {n:>2} {flagged.mean():>11.3%} {1 - r.exact.mean():>16.3%} {dt:>6.2f}",
                      flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=1024)
    ap.add_argument("--quick", action="store_true", help="n in (1, 8) only")
    ap.add_argument("--fallback", action="store_true", help="time the NumPy fallback instead")
    ap.add_argument("--sparse", action="store_true", help="flagged shares of sparse Poisson instead")
    args = ap.parse_args(argv)
    if args.fallback:
        fallback_cost(args.samples)
        return 0
    if args.sparse:
        sparse(args.samples)
        return 0
    rng = np.random.default_rng(7)
    print(f"{'dim':>3} {'points':<22} {'metric':<10} {'n':>2} {'pass':<28} {'own':>5} {'driver':>6} {'flagged':>8}")
    worst = {}
    for dim, dname, kw, n, label in cases(args.quick):
        pts = rng.uniform(-30, 30, (args.samples, dim))
        outs = _outputs(label)
        smooth = SMOOTHNESS_MAX if label.startswith("smooth") else 0.0
        kw = dict(kw)
        metric = kw.get("metric", "euclidean")
        if any(o in ("edge", "nsphere") for o in outs) and metric != "euclidean":
            continue
        p = core.make_params(dim, **kw)
        own, driver, flagged = gpu.loop_probe(pts, p, n, core._gpu_outputs(outs, p), smooth * p.scale)
        print(f"{dim:>3} {dname:<22} {metric:<10} {n:>2} {label:<28} {own.max():>5} {driver.max():>6} "
              f"{flagged.mean():>8.2%}", flush=True)
        key = (dim, label.split(":")[0] if ":" in label else ("basis" if label.startswith("F,") else label))
        w = worst.setdefault(key, [0, 0, 0.0])
        w[0], w[1], w[2] = max(w[0], own.max()), max(w[1], driver.max()), max(w[2], flagged.mean())
    print("\nworst case per dimension and pass (own counter, llvmpipe per SIMD vector, flagged share)")
    for (dim, label), (o, d, f) in sorted(worst.items()):
        print(f"{dim}D {label:<28} own {o:>5}  driver {d:>6}  flagged {f:.2%}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
