#!/usr/bin/env python
"""The two places where data went back and forth between the CPU and the GPU (issue 47, "no cliffs").

Rows (median of ``--repeats`` calls after a warm-up call, seconds, end to end):

* ``evaluate, one cell``: ``cellgl.evaluate(PRESET, pts, ("F1",))`` for ``--points`` points
  inside one whole uv cell away from the origin, [5, 6)^2 (a whole part to pan by);
* ``evaluate, spread``: the same number of points spread over [0, S)^2 with S chosen so they
  fall in about 8,600 distinct whole uv cells (the count is printed); ``x one cell`` is the ratio
  (issue 47's goal: at most 2);
* ``octave mean, first render``: the time the first ``cellgl.render(PRESET, 64, 64)`` of a process
  spends measuring the antialias's octave mean (NumPy, ``cellgl.texture.reference.measure_mean``):
  with the carried table set aside (before it existed: measured), with it (a preset: read from
  ``cellgl/texture/octave_means.json``, 0), and right after the recipe's seed changed (a new
  basis: measured once per process); 0 where the render does not measure it. Beside it, the
  whole first render.

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

    from cellgl.texture import means, reference, shader

    spent = []
    measure = reference.measure_mean

    def timed_measure(r):
        t0 = time.perf_counter()
        try:
            return measure(r)
        finally:
            spent.append(time.perf_counter() - t0)

    def first_render(r, table=True):
        """(seconds measuring the mean, seconds of the whole render) of ``r``'s first 64^2
        render in this process (the process's means forgotten); ``table=False``: the carried
        table set aside, as before it existed."""
        means._MEASURED.clear()
        shader._baked_uniforms_file.cache_clear()        # (it holds the mean of a recipe seen)
        carried = dict(means._carried())
        if not table:
            means._TABLE.clear()
        spent.clear()
        try:
            t0 = time.perf_counter()
            cellgl.render(r, 64, 64)
            return sum(spent), time.perf_counter() - t0
        finally:
            means._TABLE.update(carried)

    def median_rows(rows):
        return statistics.median(m for m, _ in rows), statistics.median(t for _, t in rows)

    reference.measure_mean = timed_measure
    try:
        first_render(recipe)                              # the program compiled once
        seeds = iter(range(1000, 1000 + 10 * (a.repeats + 1)))
        seed_rows = [first_render(recipe.replace(seed=next(seeds))) for _ in range(a.repeats)]
        before = [first_render(recipe, table=False) for _ in range(a.repeats)]
        after = [first_render(recipe) for _ in range(a.repeats)]
    finally:
        reference.measure_mean = measure
    from cellgl.gl.context import get_context
    print(f"renderer: {get_context().info['GL_RENDERER']}")
    print("| row | seconds |")
    print("| --- | --- |")
    print(f"| evaluate {n} points of {a.preset} (F1), one cell | {t_one:.4f} |")
    print(f"| evaluate {n} points of {a.preset} (F1), spread over {cells} cells | {t_spread:.4f} "
          f"(x one cell: {t_spread / t_one:.2f}) |")
    for label, rows in ((f"first 64^2 render of {a.preset}, table set aside (before: measured)", before),
                        (f"first 64^2 render of {a.preset}, mean from the carried table (after)", after),
                        (f"first 64^2 render of {a.preset} after a seed change (a new basis: measured)",
                         seed_rows)):
        t_mean, t_first = median_rows(rows)
        print(f"| octave mean in the {label} (the whole render) | {t_mean:.4f} ({t_first:.4f}) |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
