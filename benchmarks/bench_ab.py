#!/usr/bin/env python
"""The exact search of this checkout against another one (e.g. main), interleaved round by round.

One worker process per checkout (``PYTHONPATH`` set to it), each holding the same scattered
points (uniform in [0, 64)^d, 1e6 by default, seed 0); every round calls
``cellgl.cellular(points, n=N, outputs=("F",))`` once in each, in alternating order, and the
table gives the median of the per-round ratios this / baseline of the process CPU time (all
threads: the steadier measure on a shared machine) and of the wall time, with their min-max.
Below 1: this checkout is faster. The load average is printed with the table.

    git worktree add --detach /tmp/base main
    python benchmarks/bench_ab.py --baseline /tmp/base --rounds 7 3p 2p 3b 3w

Cases: ``<dim><distribution>``, dim 2 or 3 (4: 4D), distribution p (poisson, default density),
j (jitter 1), b (blender, jitter 1), w (worley1996, 3D only).
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys

_REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
_DIST = {"p": dict(distribution="poisson"), "j": dict(distribution="jitter", jitter=1.0),
         "b": dict(distribution="blender", jitter=1.0), "w": dict(distribution="worley1996")}

# The worker: reads case names on stdin, answers [cpu seconds, wall seconds] per call.
_WORKER = r"""
import json, sys, time
import numpy as np
import cellgl
points, n, cases = int(sys.argv[1]), int(sys.argv[2]), json.loads(sys.argv[3])
rng = np.random.default_rng(0)
pts = {d: rng.uniform(0.0, 64.0, (points, d)) for d in sorted({c[0] for c in cases.values()})}
for d, kw in cases.values():
    cellgl.cellular(pts[d][:1000], n=n, outputs=("F",), **kw)      # compiles
print("ready", flush=True)
for line in sys.stdin:
    d, kw = cases[line.strip()]
    c0, w0 = time.process_time(), time.perf_counter()
    cellgl.cellular(pts[d], n=n, outputs=("F",), **kw)
    print(json.dumps([time.process_time() - c0, time.perf_counter() - w0]), flush=True)
"""


def _cases(names: list[str]) -> dict:
    out = {}
    for name in names:
        if len(name) != 2 or name[0] not in "234" or name[1] not in _DIST or name[1] == "w" and name[0] != "3":
            raise ValueError(f"case must be <dim 2..4><p|j|b|w> (w: 3D only), got {name!r}")
        out[name] = (int(name[0]), _DIST[name[1]])
    return out


def _start(root: str, points: int, n: int, cases: dict) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=root)
    proc = subprocess.Popen([sys.executable, "-c", _WORKER, str(points), str(n), json.dumps(cases)],
                            cwd=root, env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    if proc.stdout.readline().strip() != "ready":
        raise RuntimeError(f"the worker for {root} did not start")
    return proc


def _call(proc: subprocess.Popen, case: str) -> list[float]:
    proc.stdin.write(case + "\n")
    proc.stdin.flush()
    return json.loads(proc.stdout.readline())


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("cases", nargs="*", default=["3p", "2p"], help="e.g. 3p 2p 3b 3w (default 3p 2p)")
    ap.add_argument("--baseline", required=True, metavar="REPO", help="the other checkout")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--points", type=float, default=1e6)
    ap.add_argument("--n", type=int, default=2, help="F1..Fn (default 2)")
    args = ap.parse_args(argv)
    try:
        cases = _cases(args.cases)
    except ValueError as e:
        ap.error(str(e))
    this = _start(_REPO, int(args.points), args.n, cases)
    base = _start(os.path.abspath(args.baseline), int(args.points), args.n, cases)
    load0 = os.getloadavg()[0]
    rows = []
    try:
        for case in cases:
            cpu, wall, t_base = [], [], []
            for r in range(args.rounds):
                if r % 2:
                    b = _call(base, case)
                    a = _call(this, case)
                else:
                    a = _call(this, case)
                    b = _call(base, case)
                cpu.append(a[0] / b[0])
                wall.append(a[1] / b[1])
                t_base.append(b[0])
            rows.append((case, cpu, wall, statistics.median(t_base)))
    finally:
        for proc in (this, base):
            proc.stdin.close()
            proc.wait()
    print(f"F1..F{args.n}, {int(args.points)} scattered points, {args.rounds} interleaved rounds; "
          f"load {load0:.1f} -> {os.getloadavg()[0]:.1f} (1 min); this / {args.baseline}")
    print("| case | CPU time, this / baseline (min-max) | wall time (min-max) | baseline CPU s |")
    print("| --- | ---: | ---: | ---: |")
    for case, cpu, wall, tb in rows:
        print(f"| {case} | **{statistics.median(cpu):.3f}** ({min(cpu):.2f}-{max(cpu):.2f}) | "
              f"{statistics.median(wall):.3f} ({min(wall):.2f}-{max(wall):.2f}) | {tb:.3f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
