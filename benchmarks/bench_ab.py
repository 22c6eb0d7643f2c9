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

``--smooth K``: instead, smooth F1 (``smooth="exp"``, smoothness K) on benchmarks/bench_blender.py's
grid (``--size``^2 samples, distribution blender; cases ``2`` and ``3``, the dimension), e.g.

    python benchmarks/bench_ab.py --baseline /tmp/base --smooth 0.25 --rounds 5 3 2

``--feature edge`` or ``--feature nsphere``: that feature alone on the same grid (distribution
poisson; cases ``2`` and ``3``). ``--texture``: the cases are texture presets, each rendered at
``--size``^2 pixels (``cellgl.render``, the colour), e.g.

    python benchmarks/bench_ab.py --baseline /tmp/base --feature edge --rounds 5 3 2
    python benchmarks/bench_ab.py --baseline /tmp/base --texture --size 512 flagstone rock

Either way the table says whether both checkouts' answers (of the first call) are bit-identical.
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

# The worker: reads case names on stdin, answers [cpu seconds, wall seconds] per call; first
# "ready" and a digest of each case's answer (the same bits on both sides?).
_WORKER = r"""
import hashlib, json, sys, time
import numpy as np
import cellgl
points, n, cases, smooth = int(sys.argv[1]), int(sys.argv[2]), json.loads(sys.argv[3]), json.loads(sys.argv[4])
rng = np.random.default_rng(0)
pts = {d: rng.uniform(0.0, 64.0, (points, d)) for d in sorted({c[0] for c in cases.values()})} if smooth is None else {}
calls = {}
for name, (d, kw) in cases.items():
    if smooth is None:
        calls[name] = (lambda p=pts[d], kw=kw: cellgl.cellular(p, n=n, outputs=("F",), **kw).F)
    elif smooth["kind"] == "texture":
        calls[name] = (lambda rec=cellgl.load_recipe(name), s=smooth["size"]: cellgl.render(rec, s, s)["color"])
    elif smooth["kind"] != "smooth":   # a feature alone on the same plane
        size, h, out = smooth["size"], 32.0 / smooth["size"], smooth["kind"]
        origin = (-16.0 + h / 2, -16.0 + h / 2) + ((0.37,) if d == 3 else ())
        shape = (size, size) if d == 2 else (1, size, size)
        calls[name] = (lambda shape=shape, origin=origin, h=h, out=out: getattr(cellgl.cellular_grid(
            shape, origin=origin, spacing=h, n=1, outputs=(out,)), out))
    else:                   # bench_blender.py's plane: 32 cells across, z = 0.37 (3D)
        size, h = smooth["size"], 32.0 / smooth["size"]
        origin = (-16.0 + h / 2, -16.0 + h / 2) + ((0.37,) if d == 3 else ())
        shape = (size, size) if d == 2 else (1, size, size)
        calls[name] = (lambda shape=shape, origin=origin, h=h: cellgl.cellular_grid(
            shape, origin=origin, spacing=h, n=1, distribution="blender", jitter=1.0,
            outputs=("smooth_F1",), smooth="exp", smoothness=smooth["k"]).smooth_F1)
digests = {name: hashlib.sha1(np.ascontiguousarray(call()).tobytes()).hexdigest() for name, call in calls.items()}
print("ready " + json.dumps(digests), flush=True)
for line in sys.stdin:
    call = calls[line.strip()]
    c0, w0 = time.process_time(), time.perf_counter()
    call()
    print(json.dumps([time.process_time() - c0, time.perf_counter() - w0]), flush=True)
"""


def _cases(names: list[str], smooth: bool = False, texture: bool = False) -> dict:
    out = {}
    for name in names:
        if texture:
            out[name] = (0, {})
            continue
        if smooth:
            if name not in ("2", "3"):
                raise ValueError(f"with --smooth a case is the dimension 2 or 3, got {name!r}")
            out[name] = (int(name), {})
            continue
        if len(name) != 2 or name[0] not in "234" or name[1] not in _DIST or name[1] == "w" and name[0] != "3":
            raise ValueError(f"case must be <dim 2..4><p|j|b|w> (w: 3D only), got {name!r}")
        out[name] = (int(name[0]), _DIST[name[1]])
    return out


def _start(root: str, points: int, n: int, cases: dict, smooth) -> tuple[subprocess.Popen, dict]:
    env = dict(os.environ, PYTHONPATH=root)
    proc = subprocess.Popen([sys.executable, "-c", _WORKER, str(points), str(n), json.dumps(cases),
                             json.dumps(smooth)],
                            cwd=root, env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    line = proc.stdout.readline().strip()
    if not line.startswith("ready "):
        raise RuntimeError(f"the worker for {root} did not start")
    return proc, json.loads(line[len("ready "):])


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
    ap.add_argument("--smooth", type=float, default=None, metavar="K",
                    help="time smooth F1 (exp, smoothness K) on a grid instead; cases 2 and 3")
    ap.add_argument("--feature", choices=("edge", "nsphere"), default=None,
                    help="time that feature alone on the grid instead; cases 2 and 3")
    ap.add_argument("--texture", action="store_true", help="the cases are texture presets, rendered")
    ap.add_argument("--size", type=int, default=1024,
                    help="with --smooth/--feature: the grid's side, --texture: the image's (default 1024)")
    args = ap.parse_args(argv)
    if sum(x is not None and x is not False for x in (args.smooth, args.feature, args.texture)) > 1:
        ap.error("--smooth, --feature and --texture are exclusive")
    smooth = (None if args.smooth is None and args.feature is None and not args.texture else
              {"kind": "texture" if args.texture else (args.feature or "smooth"), "k": args.smooth, "size": args.size})
    if args.smooth is not None and not 0.0 <= args.smooth <= 0.25:
        ap.error(f"--smooth must be in [0, 0.25], got {args.smooth}")
    if args.texture and args.cases == ["3p", "2p"]:
        ap.error("--texture needs the presets to render, e.g. flagstone rock")
    try:
        cases = _cases(args.cases if args.cases != ["3p", "2p"] or smooth is None else ["3", "2"],
                       smooth is not None, args.texture)
    except ValueError as e:
        ap.error(str(e))
    this, bits_this = _start(_REPO, int(args.points), args.n, cases, smooth)
    base, bits_base = _start(os.path.abspath(args.baseline), int(args.points), args.n, cases, smooth)
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
    what = (f"F1..F{args.n}, {int(args.points)} scattered points" if smooth is None else
            f"texture presets rendered at {args.size}^2" if args.texture else
            f"{args.feature} alone, {args.size}^2 grid, distribution poisson" if args.feature else
            f"smooth F1 (exp, k = {args.smooth:g}), {args.size}^2 grid, distribution blender")
    print(f"{what}, {args.rounds} interleaved rounds; "
          f"load {load0:.1f} -> {os.getloadavg()[0]:.1f} (1 min); this / {args.baseline}")
    print("| case | CPU time, this / baseline (min-max) | wall time (min-max) | baseline CPU s | same bits |")
    print("| --- | ---: | ---: | ---: | --- |")
    for case, cpu, wall, tb in rows:
        same = "yes" if bits_this[case] == bits_base[case] else "**no**"
        print(f"| {case} | **{statistics.median(cpu):.3f}** ({min(cpu):.2f}-{max(cpu):.2f}) | "
              f"{statistics.median(wall):.3f} ({min(wall):.2f}-{max(wall):.2f}) | {tb:.3f} | {same} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
