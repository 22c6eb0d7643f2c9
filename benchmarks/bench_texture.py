#!/usr/bin/env python
"""Texture layer vs the basis it wraps: ``cellgl.render`` next to ``cellgl.cellular_grid``.

For each preset, in one run, side by side:

* ``texture``: ``cellgl.render(preset, S, S)`` (colour only: what ``cellgl bake`` computes),
  in Msamples/s (pixels per second);
* ``basis``: ``cellgl.cellular_grid`` over the same S x S grid with the same basis (dimension,
  metric, distribution, density, jitter, seed, the highest F_n the recipe reads, outputs F),
  in Msamples/s, divided by the number of octaves the texture evaluates per pixel (a 6-octave
  fractal searches the basis 6 times per pixel), so that ``basis`` is the rate the texture would
  reach if it cost nothing beyond its basis searches;
* ``ratio`` = basis / texture: the factor the texture layer costs over its own basis searches
  (1.0: free);
* ``uniform`` and its ratio: the same render with the recipe's values as uniforms (as the viewer
  runs it, and as bakes ran before the baked programs of ``cellgl/texture/dispatch.py``).

The recipes are rendered with ``antialias = 0`` so that every octave is searched, as the basis
rate assumes (the band limit skips octaves finer than two pixels: faster still; ``--band`` keeps
the recipe's value).

    python benchmarks/bench_texture.py                    # every texture preset, 512^2, best of 5
    python benchmarks/bench_texture.py --size 256 --repeats 2 f1 qin-cloud
    python benchmarks/bench_texture.py --samples 4        # bakes with 4 samples per pixel

Rates on a shared machine are noisy; the ratio, measured in the same run, is the number to
compare. See benchmarks/README.md.
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import time

_REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if _REPO not in sys.path:
    sys.path.insert(0, _REPO)


def best_times(fns, repeats: int) -> list[float]:
    """Best wall time of each of ``fns``, after one warm-up call of each (compiles shaders); the
    calls are interleaved (fn0, fn1, ..., fn0, fn1, ...) so that a change of load on a shared
    machine hits every row alike."""
    for fn in fns:
        fn()
    best = [float("inf")] * len(fns)
    for _ in range(repeats):
        for k, fn in enumerate(fns):
            t0 = time.perf_counter()
            fn()
            best[k] = min(best[k], time.perf_counter() - t0)
    return best


def _uniform_program(fn):
    """fn run with the recipe's values as uniforms (the viewer's program) instead of baked."""
    from cellgl.texture import dispatch

    def run():
        dispatch.BAKE_CONSTANTS = False
        try:
            fn()
        finally:
            dispatch.BAKE_CONSTANTS = True
    return run


def basis_args(recipe) -> tuple[dict, int]:
    """(cellular_grid keyword arguments for the recipe's basis, basis searches per pixel)."""
    from cellgl.texture.recipe import needed_n

    v = recipe.values
    octaves = 1 if v["fractal"] == "none" else int(math.ceil(v["octaves"]))
    kw = dict(n=needed_n(recipe), metric=v["metric"], distribution=v["distribution"],
              density=v["density"], jitter=v["jitter"], min_points=v["min_points"],
              max_points=v["max_points"], minkowski_p=v["minkowski_p"], seed=v["seed"],
              outputs=("F",))
    return kw, octaves


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("presets", nargs="*", help="texture presets (default: all)")
    ap.add_argument("--size", type=int, default=512, help="S x S pixels (default 512)")
    ap.add_argument("--repeats", type=int, default=5, help="timed runs per row, best kept (default 5)")
    ap.add_argument("--samples", type=int, default=1, help="samples per pixel of the texture bake")
    ap.add_argument("--band", action="store_true", help="keep the recipes' band limit (antialias)")
    args = ap.parse_args(argv)

    import cellgl
    from cellgl.recipes import is_pups, load_recipe

    # Texture presets without a density map (cellular_grid would need the map rebuilt in cells).
    names = args.presets or [n for n, _ in cellgl.list_presets()
                             if not is_pups(load_recipe(n)) and load_recipe(n).get("density_map") == "none"]
    S = args.size
    print(f"# {S}x{S}, best of {args.repeats}, samples {args.samples}; "
          f"load: {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f} {os.getloadavg()[2]:.2f}")
    print(f"{'preset':<14} {'dim':>3} {'oct':>3} {'texture Ms/s':>13} {'basis Ms/s':>11} {'ratio':>6} "
          f"{'uniform Ms/s':>13} {'ratio':>6}")
    ratios, uratios = [], []
    for name in names:
        recipe = load_recipe(name)
        if not args.band:
            recipe = recipe.replace(antialias=0.0)
        kw, octaves = basis_args(recipe)
        dim = recipe.get("dimension")
        shape = (S, S) if dim == 2 else (1, S, S) if dim == 3 else (1, 1, S, S)
        kwargs = {"samples": args.samples} if args.samples != 1 else {}
        spacing = recipe.get("frequency") / S     # the texture's octave-0 lattice step per pixel

        def tex_fn(recipe=recipe, kwargs=kwargs):
            cellgl.render(recipe, S, S, **kwargs)

        def basis_fn(shape=shape, spacing=spacing, kw=kw):
            cellgl.cellular_grid(shape, spacing=spacing, **kw)

        t_tex, t_basis, t_uni = best_times([tex_fn, basis_fn, _uniform_program(tex_fn)], args.repeats)
        tex = S * S / t_tex / 1e6
        uni = S * S / t_uni / 1e6
        basis = S * S / t_basis / 1e6 / octaves
        ratios.append(basis / tex)
        uratios.append(basis / uni)
        print(f"{name:<14} {dim:>3} {octaves:>3} {tex:>13.2f} {basis:>11.2f} {basis / tex:>6.2f} "
              f"{uni:>13.2f} {basis / uni:>6.2f}", flush=True)
    if ratios:
        def geo(rs):
            return math.exp(sum(math.log(r) for r in rs) / len(rs))

        print(f"# ratio basis/texture: geometric mean {geo(ratios):.2f}, max {max(ratios):.2f} "
              f"(uniform program: {geo(uratios):.2f}, max {max(uratios):.2f}); "
              f"load after: {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
