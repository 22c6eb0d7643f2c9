"""Stretched cells, domain warp, orbiting points: what a fixed 3^d window would get wrong, and
what each feature costs.

1. Stretched cells: F1 by cellgl's exact search (GPU) against the nearest point among the
   sample's 3 x 3 block of cells (what a fixed-window search sees) under the same weighted
   metric, for a few stretches: the fraction of samples whose F1 feature differs.
2. Render time of the same texture plain, warped, stretched, orbiting and with all three, side
   by side in one run (median of ``--repeat`` interleaved rounds after a warm-up; ratios to plain).

    python benchmarks/domain_features.py [--samples 4000] [--size 256] [--repeat 5]
"""
from __future__ import annotations

import argparse
import itertools
import os
import statistics
import time

import numpy as np

import cellgl
from cellgl.basis import reference
from cellgl.texture.recipe import Recipe


def window_errors(stretch, density: float, samples: int, seed: int = 0) -> float:
    """Fraction of samples whose nearest point within the 3 x 3 block of cells is not F1."""
    rng = np.random.default_rng(seed)
    pts = rng.uniform(0.0, 60.0, (samples, 2))
    exact = cellgl.cellular(pts, 1, stretch=stretch, density=density, outputs=("id",)).id[:, 0]
    w = np.asarray(reference.axis_scale(stretch, 2)[:2])
    cells = np.floor(pts).astype(np.int64)
    lo = cells.min(0) - 1
    hi = cells.max(0) + 1
    grid = np.array(list(itertools.product(range(lo[0], hi[0] + 1), range(lo[1], hi[1] + 1))))
    fp = cellgl.feature_points(grid, density=density)
    ny = hi[1] - lo[1] + 1
    key = (grid[fp.cell_index, 0] - lo[0]) * ny + (grid[fp.cell_index, 1] - lo[1])
    order = np.argsort(key, kind="stable")
    starts = np.searchsorted(key[order], np.arange((hi[0] - lo[0] + 1) * ny + 1))
    wrong = 0
    for s in range(samples):
        idx = []
        for dx, dy in itertools.product((-1, 0, 1), repeat=2):
            k = (cells[s, 0] + dx - lo[0]) * ny + (cells[s, 1] + dy - lo[1])
            idx.extend(order[starts[k]:starts[k + 1]])
        d = ((fp.positions[idx] - pts[s]) * w) ** 2
        wrong += fp.ids[idx][np.argmin(d.sum(1))] != exact[s]
    return wrong / samples


def render_times(size: int, repeat: int) -> list[tuple[str, float]]:
    base = Recipe().replace(c1=-1.0, c2=1.0, range_hi=0.6, frequency=8.0)
    cases = [("plain F2 - F1", base),
             ("warp (3 octaves)", base.replace(warp_amount=0.3, warp_frequency=1.5)),
             ("stretch 12:1", base.replace(stretch_x=3.0, stretch_y=0.25)),
             ("orbit r = 0.3", base.replace(orbit_radius=0.3, orbit_phase=0.2)),
             ("all three", base.replace(warp_amount=0.3, warp_frequency=1.5, stretch_x=3.0, stretch_y=0.25,
                                        orbit_radius=0.3, orbit_phase=0.2))]
    for _, r in cases:
        cellgl.render(r, size, size)           # compile + warm up
    times: dict = {name: [] for name, _ in cases}
    for _ in range(repeat):                    # interleaved rounds: load changes hit every case
        for name, r in cases:
            t = time.perf_counter()
            cellgl.render(r, size, size)
            times[name].append(time.perf_counter() - t)
    return [(name, statistics.median(times[name])) for name, _ in cases]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=4000)
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--repeat", type=int, default=9)
    args = ap.parse_args(argv)
    print(f"load average: {os.getloadavg()[0]:.2f}")
    print(f"{'stretch':<12} {'density':>7} {'3x3 window: F1 wrong':>21}   (cellgl: exact)")
    for stretch, density in (((1.0, 1.0), 3.0), ((4.0, 1.0), 3.0), ((3.0, 0.25), 2.0), ((8.0, 1.0), 1.0)):
        err = window_errors(stretch, density, args.samples)
        print(f"{str(stretch):<12} {density:7.1f} {100 * err:20.2f}%")
    print(f"\nrender {args.size} x {args.size}, median of {args.repeat}:")
    rows = render_times(args.size, args.repeat)
    plain = rows[0][1]
    for name, t in rows:
        print(f"  {name:<18} {1000 * t:8.1f} ms  x{t / plain:5.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
