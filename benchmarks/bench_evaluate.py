#!/usr/bin/env python
"""The two places where data went back and forth between the CPU and the GPU (issue 47, "no cliffs").

Rows (median of ``--repeats`` calls after a warm-up call, seconds, end to end):

* ``evaluate, one cell``: ``cellgl.evaluate(PRESET, pts, ("F1",))`` for ``--points`` points
  inside one whole uv cell away from the origin, [5, 6)^2 (a whole part to pan by);
* ``evaluate, spread``: the same number of points spread over [0, S)^2 with S chosen so they
  fall in about 8,600 distinct whole uv cells (the count is printed); ``x one cell`` is the ratio
  (issue 47's goal: at most 2);
* ``octave mean, first render``: the time ``cellgl.render(PRESET, 64, 64)`` spends measuring the
  antialias's octave mean (NumPy, ``cellgl.texture.reference._measure_mean``) right after the
  recipe's seed changed (a new basis: the mean is not known yet); 0 where the render does not
  measure it (no octave fades at its footprint). Beside it, the whole first render (it compiles
  the new recipe's program too, unless the driver's shader cache has it).

    python benchmarks/bench_evaluate.py                   # f1, 20,000 points, median of 5
    python benchmarks/bench_evaluate.py --preset flagstone --repeats 3

Results: docs/performance.md ("Far points and the octave mean").
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

_REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if _REPO not in sys.path:
    sys.path.insert(0, _REPO)

import numpy as np  # noqa: E402

import cellgl  # noqa: E402
from cellgl.texture.presets import load_recipe  # noqa: E402


def _median(fn, repeats: int) -> float:
    fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--preset", default="f1")
    ap.add_argument("--points", type=int, default=20000)
    ap.add_argument("--repeats", type=int, default=5)
    a = ap.parse_args(argv)
    rng = np.random.default_rng(7)
    n = a.points
    # S^2 (1 - exp(-n / S^2)) distinct cells expected: S = 100 gives ~8,650 for 20,000 points
    side = 100.0 * (n / 20000.0) ** 0.5
    one = 5.0 + rng.uniform(0.0, 1.0, size=(n, 2))
    spread = rng.uniform(0.0, side, size=(n, 2))
    cells = len(np.unique(np.floor(spread), axis=0))
    recipe = load_recipe(a.preset)
    t_one = _median(lambda: cellgl.evaluate(recipe, one, ("F1",)), a.repeats)
    t_spread = _median(lambda: cellgl.evaluate(recipe, spread, ("F1",)), a.repeats)

    from cellgl.texture import reference

    seeds = iter(range(1000, 1000 + 10 * (a.repeats + 1)))
    spent = []
    measure = reference._measure_mean

    def timed_measure(r):
        t0 = time.perf_counter()
        try:
            return measure(r)
        finally:
            spent.append(time.perf_counter() - t0)

    reference._measure_mean = timed_measure

    def first_render():
        spent.clear()
        t0 = time.perf_counter()
        cellgl.render(recipe.replace(seed=next(seeds)), 64, 64)
        return sum(spent), time.perf_counter() - t0

    first_render()
    rows = [first_render() for _ in range(a.repeats)]
    reference._measure_mean = measure
    t_mean = statistics.median(m for m, _ in rows)
    t_first = statistics.median(t for _, t in rows)
    from cellgl.gl.context import get_context
    print(f"renderer: {get_context().info['GL_RENDERER']}")
    print("| row | seconds |")
    print("| --- | --- |")
    print(f"| evaluate {n} points of {a.preset} (F1), one cell | {t_one:.4f} |")
    print(f"| evaluate {n} points of {a.preset} (F1), spread over {cells} cells | {t_spread:.4f} "
          f"(x one cell: {t_spread / t_one:.2f}) |")
    print(f"| octave mean in the first 64^2 render after a seed change (the whole render) | {t_mean:.4f} "
          f"({t_first:.4f}) |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
