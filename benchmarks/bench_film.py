"""A tiled, mip-mapped ``.tx`` (every level rendered) against a plain scanline EXR of the same
size, in one run: ``python benchmarks/bench_film.py [--size 4096] [--recipe flagstone]``.

Each bake is a whole ``cellgl bake ... -q`` process (what a user waits for), run in turn; the
table gives wall time, the CPU time of the process, its peak memory (max RSS) and the file size.
docs/performance.md ("Film textures") holds the numbers of a run.
"""
from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time


def run(args: list[str]) -> tuple[float, float, int]:
    """(wall s, CPU s, peak RSS KiB) of one child process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(args, check=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, after.ru_maxrss


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=int, default=4096)
    ap.add_argument("--recipe", default="flagstone")
    a = ap.parse_args(argv)
    cases = [("plain EXR (scanline, float)", "x.exr", []),
             (".tx (tiled TIFF, float, every level)", "x.tx", []),
             ("--tiled --mips EXR (float)", "t.exr", ["--tiled", "--mips"])]
    print(f"| bake {a.recipe} {a.size}^2, colour | wall | CPU | peak RSS | file |")
    print("| --- | ---: | ---: | ---: | ---: |")
    with tempfile.TemporaryDirectory(prefix="bench_film.") as d:
        for label, name, extra in cases:
            out = os.path.join(d, name)
            wall, cpu, rss = run([sys.executable, "-m", "cellgl", "bake", a.recipe, "-o", out,
                                  "--size", str(a.size), "-q", *extra])
            print(f"| {label} | {wall:.1f} s | {cpu:.1f} s | {rss / 1024:.0f} MiB | "
                  f"{os.path.getsize(out) / 2**20:.1f} MiB |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
