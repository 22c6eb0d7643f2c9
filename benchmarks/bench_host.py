#!/usr/bin/env python
"""The host's own cost per sample (issue 40, item 3): cellgl's GPU calls with a stub kernel that
writes constants (``CELL_STUB=1`` in ``shaders/cellular.*``: no search), against one bare read of
the same bytes from a GL buffer into a NumPy array.

What the host does per call (upload, dispatches or draws, tiles, barriers, readback, flags, the
result's assembly) is what is left when the kernel costs nothing; on llvmpipe the stub's own
shading (a few instructions a sample, on the CPU) is in it too. Rows (the process's CPU time, all
threads, the steadier measure on a shared machine, and the wall time; medians of ``--repeat``
after a warm-up, one context):

* ``bare read``: ``buffer.read_into(array)`` of the grid's F1+F2 bytes (float32, 8 bytes a sample);
* ``bare read, new array``: the same into a new ``np.empty`` array each time, as a call that
  returns its result must (the difference is the kernel's first touch of the array's pages);
* ``grid <path>``: ``cellgl.cellular_grid((size, size), n=2)`` (2D, F1+F2 into NumPy);
* ``points <path>``: ``cellgl.cellular(points, n=2)`` on ``--points`` scattered 3D points.

    python benchmarks/bench_host.py                  # 4096^2 grid, 4e6 points, both paths
    python benchmarks/bench_host.py --size 1024 --points 1000000 --repeat 3
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _median(fn, repeat: int) -> tuple[float, float, float]:
    """Medians of the process's CPU time (every thread: llvmpipe's shading threads too), the
    calling thread's CPU time (the host's own work: on llvmpipe the kernel runs on the driver's
    threads) and the wall time."""
    fn()
    cpu, own, wall = [], [], []
    for _ in range(repeat):
        c0, t0, w0 = time.process_time(), time.thread_time(), time.perf_counter()
        fn()
        cpu.append(time.process_time() - c0)
        own.append(time.thread_time() - t0)
        wall.append(time.perf_counter() - w0)
    return statistics.median(cpu), statistics.median(own), statistics.median(wall)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=int, default=4096, help="grid side (default 4096)")
    ap.add_argument("--points", type=int, default=4_000_000, help="scattered 3D points (default 4e6)")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--paths", default="compute,fragment")
    args = ap.parse_args(argv)

    # the stub answers nothing right: the known-answer check (cellgl.basis.selfcheck) would refuse
    # the path it runs on (the check of an unchanged tree is on disk and would not run at all)
    os.environ["CELLGL_SELFCHECK"] = "0"
    import cellgl
    from cellgl.basis import gpu
    from cellgl.gl import context
    from cellgl.gl.path import has_compute

    orig = gpu.defines_for
    gpu.defines_for = lambda *a, **k: {**orig(*a, **k), "CELL_STUB": 1}

    ctx = context.get_context()
    N = args.size * args.size
    rows = []
    buf = ctx.buffer(reserve=8 * N)
    dest = np.empty((N, 2), np.float32)
    bare = _median(lambda: buf.read_into(dest), args.repeat)
    fresh = _median(lambda: buf.read_into(np.empty((N, 2), np.float32)), args.repeat)
    buf.release()
    rows.append(("bare read", N, bare, None))
    rows.append(("bare read, new array", N, fresh, None))
    pts = np.random.default_rng(0).uniform(-100.0, 100.0, (args.points, 3))
    for path in args.paths.split(","):
        if path == "compute" and not has_compute(ctx):
            continue
        os.environ["CELLGL_PATH"] = path
        g = _median(lambda: cellgl.cellular_grid((args.size, args.size), n=2, outputs=("F",)), args.repeat)
        rows.append((f"grid {path}", N, g, (g[0] / bare[0], g[1] / bare[1])))
        if args.points:
            p = _median(lambda: cellgl.cellular(pts, 2, outputs=("F",)), args.repeat)
            rows.append((f"points {path}", args.points, p, None))
    os.environ.pop("CELLGL_PATH", None)
    print(f"stub kernel (CELL_STUB=1), F1+F2 float32; {ctx.info['GL_RENDERER']}; "
          f"load {os.getloadavg()[0]:.1f}")
    print("| what | samples | CPU ms | CPU ns/sample | CPU x bare read | host thread ns/sample "
          "| host thread x bare read | wall ms |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for name, n, (c, t, w), ratio in rows:
        r, rt = ("", "") if ratio is None else (f"{ratio[0]:.2f}", f"{ratio[1]:.2f}")
        print(f"| {name} | {n} | {c * 1e3:.1f} | {c * 1e9 / n:.2f} | {r} | {t * 1e9 / n:.2f} | {rt} "
              f"| {w * 1e3:.1f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
