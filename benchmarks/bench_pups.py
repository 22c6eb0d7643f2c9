"""PUPs benchmark: 1000x1000 image, ~700 control points, end to end, GPU vs NumPy reference.

Usage: python benchmarks/bench_pups.py [--size 1000] [--radius 0.0595] [--repeat 5]
       [--tile N] [--mode interpolate|weighted_sum|label] [--no-numpy]

GPU columns: "raster" (method="raster": support polygons with flat per-point inputs, additive
blending; modes interpolate and weighted_sum) and "compute" (method="compute": the compute
shader over the candidate grid), measured in the same run, interleaved run by run.

Stages (median over --repeat runs, after one warm-up that compiles the shader):
  points    Poisson-disk positions (vectorised dart throwing), random values and orientations
  delaunay  periodic Delaunay graph, axes, exact support boxes (pups_graph)
  grid      periodic copies, pixel boxes, candidate grid + axis masks (pups_pack; raster:
            no candidate grid)
  upload    compute: buffer creation (the std430 stream is built in pups_pack, counted in
            grid); raster: support polygons, vertex data and buffers
  gpu       compute dispatch (raster: the draw) + glFinish
  readback  buffer read into NumPy
The paper's prototype: ~30 s for 1000x1000 with 700 points.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from cellgl import pups as P  # noqa: E402
from cellgl.pups import gpu as G  # noqa: E402


def run_once(args, backend):
    """backend: "raster" or "compute" (GPU methods) or "numpy"."""
    t = {}
    t0 = time.perf_counter()
    pos = P.poisson_disk(args.radius, seed=args.seed)
    rng = np.random.default_rng(args.seed)
    pts = P.pups_points(pos, rng.random(len(pos)),
                        orientations=P.random_orientations(len(pos), seed=rng))
    t1 = time.perf_counter()
    g = P.pups_graph(pts)
    t2 = time.perf_counter()
    st = {}
    if backend != "numpy":
        img = P.pups_evaluate(g, args.size, args.size, mode=args.mode, tile=args.tile,
                              timings=st, method=backend)
        t.update(grid=st["grid"], upload=st["pack"] + st["upload"], gpu=st["gpu"],
                 readback=st["readback"])
    else:
        img = P.pups_evaluate(g, args.size, args.size, mode=args.mode, tile=args.tile,
                              backend="numpy", timings=st)
        t.update(grid=st["grid"], upload=0.0, gpu=st["reference"], readback=0.0)
    t3 = time.perf_counter()
    t.update(points=t1 - t0, delaunay=t2 - t1)
    t["from point set"] = t3 - t1
    t["total"] = t3 - t0
    return t, len(pos), img


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=1000)
    ap.add_argument("--radius", type=float, default=0.0595, help="Poisson radius (0.0595: ~700)")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--tile", type=int, default=None)
    ap.add_argument("--mode", default="interpolate",
                    choices=["interpolate", "weighted_sum", "label"])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--no-numpy", action="store_true")
    args = ap.parse_args(argv)
    ctx = G._context()
    print(f"device: {ctx.info.get('GL_RENDERER')}  ({ctx.info.get('GL_VERSION')})")
    gpu = ["compute"] if args.mode == "label" else ["raster", "compute"]
    backends = gpu + ([] if args.no_numpy else ["numpy"])
    res = {}
    runs = {b: [] for b in backends}
    for b in gpu:
        run_once(args, b)  # warm-up: shader compile, caches
    for _ in range(args.repeat):  # the GPU methods interleaved, so they share the load
        for b in gpu:
            t, n, img = run_once(args, b)
            runs[b].append(t)
            res[b + "_img"] = img
    if not args.no_numpy:
        for _ in range(max(1, min(args.repeat, 2))):
            t, n, img = run_once(args, "numpy")
            runs["numpy"].append(t)
            res["numpy_img"] = img
    for b in backends:
        res[b] = {k: statistics.median(r[k] for r in runs[b]) for k in runs[b][0]}
    print(f"{args.size}x{args.size}, {n} points, mode {args.mode}, median of {args.repeat} "
          f"(numpy: of {max(1, min(args.repeat, 2))})")
    print(f"{'stage':16s}" + "".join(f"{b:>12s}" for b in backends))
    for k in ["points", "delaunay", "grid", "upload", "gpu", "readback", "from point set",
              "total"]:
        name = "eval" if k == "gpu" else k
        print(f"{name:16s}" + "".join(f"{res[b][k] * 1000:10.1f}ms" for b in backends))
    if "raster" in res:
        same = res["raster_img"].tobytes() == res["compute_img"].tobytes()
        d = np.abs(res["raster_img"].astype(np.float64) - res["compute_img"]).max()
        print(f"raster vs compute: {'identical' if same else f'max |diff| = {d:.2e}'}")
    for b in gpu:
        if "numpy" in res:
            d = np.abs(res[b + "_img"].astype(np.float64) - res["numpy_img"]).max()
            print(f"max |{b} - numpy| = {d:.2e}")
    best = gpu[0]
    g = res[best]["from point set"]
    print(f"speed-up over the paper's ~30 s ({best}): {30 / g:.0f}x from the point set, "
          f"{30 / res[best]['total']:.0f}x including point generation")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
