"""Run a texture recipe's pass (``shaders/texture.comp`` / ``texture_samples.frag``) for
:func:`cellgl.texture.evaluate` and :func:`cellgl.texture.render`, through the context's runner
(:mod:`cellgl.gl.runner`: either GPU path, in tiles, outputs read straight into the arrays here).

Where the time goes, and what this module does about it (``benchmarks/bench_texture.py``):

* **Baked programs.** With the recipe's values as uniforms, the compiler cannot know that most
  coefficients are 0, that ``light`` is 0 or how many ramp keys there are, so every pixel pays
  for all 24 combination terms, the copies of the uniform arrays into ``CellTextureParams``,
  their dynamic indexing, the lighting and both ramp modes. A bake compiles the entry
  with ``texture_uniforms.glsl`` replaced by the recipe's values as constants
  (:func:`cellgl.texture.shader.glsl_baked_uniforms_file`: the same
  :func:`~cellgl.texture.shader.glsl_constant_block` the snippets use), so the compiler folds
  all of that away; the viewer keeps uniforms (it changes them every frame). A compile costs ~0.1 s
  on llvmpipe; the last :data:`MAX_BAKED` programs are kept (the runner's cache, group
  ``texture.baked``).
* **Only the outputs asked for** are written (``CELL_TEX_OUT``) and read back.

The driver's loop limit (docs/exactness.md): the entry counts the samples whose loops llvmpipe cut
(its canary); :func:`run` raises :class:`LoopLimitError` rather than return them.
"""
from __future__ import annotations

import numpy as np

from cellgl.basis.gpu import DRIVER_LOOP_LIMIT, PROBE_PASSES
from cellgl.gl.threads import gl_call

__all__ = ["MAX_BAKED", "LoopLimitError", "run", "output_mask"]


class LoopLimitError(ValueError):
    """The driver cut the loops of some samples (llvmpipe's 65535 loop passes per SIMD vector):
    their values would be wrong, so none are returned. A ValueError: the request is too heavy for
    the driver (the message names what in the recipe lengthens its searches: :func:`lighter`);
    the command line reports it as a user error."""

#: storage buffer / texture unit of the far points' group records (texture.comp, texture_samples.frag)
GROUPS_BINDING = 11
#: baked programs kept (least recently used dropped)
MAX_BAKED = 16
#: False: compile with uniforms, as the viewer does (benchmarks/bench_texture.py --uniforms)
BAKE_CONSTANTS = True

#: output -> (binding in texture.comp, components, bit in CELL_TEX_OUT, channels it carries);
#: texture_samples.frag writes ``row_<output>``
_OUTPUTS = {
    "color": (1, 4, 1, ("color",)),
    "aux": (2, 4, 2, ("height", "normal")),
    "F": (3, 4, 4, ("F1", "F2", "F3", "F4")),
    "grad": (4, 4, 8, ("grad", "value")),
    "id": (5, 1, 16, ("id",)),
    "material": (8, 4, 32, ("roughness", "ao", "metallic")),
}
#: the search's loop passes the watchdog assumes for one search of a texture (the search stops at
#: the ring cap; llvmpipe cuts and the canary refuses a vector past 65535)
SEARCH_PASSES = 6144


def output_mask(channels) -> int:
    """``CELL_TEX_OUT`` for these channels."""
    return sum(bit for _, _, bit, chans in _OUTPUTS.values() if set(chans) & set(channels))


@gl_call
def run(recipe, channels, count: int, uniforms, *, grid: bool, points=None, supersample: int = 1, pan=None,
        pan_only: bool = False, probe: bool = False, groups=None, footprint=None) -> dict:
    """Run the recipe's entry over ``count`` samples and return ``{channel: array}`` (flat, one row
    per sample). ``uniforms``: the entry's own (the image and tile of a grid, the filter width of
    points; a dict the runner sets, or a callable ``setup(prog)`` run first); ``points`` (count, 4) float32 (u, v, z, -): the samples when not a
    ``grid``; ``supersample``: n of the n x n sub-pixel grid (grid only); ``pan`` (du, dv, dz):
    added to the samples' texture position in float64, through the split origins; ``pan_only``:
    the last call ran this recipe with the same channels (only the pan changed); ``probe``: the
    measurement build, adding ``"loops"``: the loop passes llvmpipe counted for each sample's SIMD
    vector (benchmarks/loop_budget.py); ``groups``: the records of
    :func:`cellgl.texture.shader.group_records` for points whose fourth component is their group
    (far points in one pass, ``shaders/lib/texture_groups.glsl``); ``footprint`` (du, dv, dz): the
    largest of any sample, where no octave fades at it (:func:`cellgl.texture.antialias.fades`)
    the pass carries octave mean 0 instead of measuring it (None: measured). Raises :class:`LoopLimitError` if the driver cut any
    sample's loops."""
    from cellgl.gl import runner as _runner
    from cellgl.texture import shader as texture

    mask = output_mask(channels)
    d = texture.defines(recipe, channels)
    d.update(CELL_TEX_GRID=int(grid), CELL_LOCAL_SIZE=texture.LOCAL_SIZE, CELL_TEX_OUT=mask,
             CELL_TEX_SUPERSAMPLE=int(supersample))
    for name, (_, _, bit, _) in _OUTPUTS.items():
        if name != "material" or mask & bit:       # (no new define in the programs without it)
            d[f"CELL_TEX_WANT_{name.upper()}"] = int(bool(mask & bit))
    # No loop budget of the search's own (cellular.glsl): a texture invocation searches once per
    # octave and sub-sample and reports no per-sample flag; the canary reports the driver's.
    d["CELL_LOOP_BUDGET"] = 1 << 30
    out = {}
    outputs = []
    for name, (binding, comps, bit, chans) in _OUTPUTS.items():
        if mask & bit:
            # F1..F4: only up to the last one asked for (F1 alone: one float a sample), written
            # so on both paths (texture.comp's CELL_TEX_F_COMPS) and read back without a copy
            k = max(int(c[1]) for c in channels if c in chans) if name == "F" else comps
            if name == "F":
                d["CELL_TEX_F_COMPS"] = k
            out[name] = np.empty((count, k), np.uint32 if name == "id" else np.float32)
            outputs.append(_runner.Output(name, binding, out[name], row=k))
    loops = None
    if probe:
        d["CELL_LOOP_PROBE"] = 1
        loops = np.empty((count, 1), np.int32)
        outputs.append(_runner.Output("loops", 10, loops))
    if groups is not None:
        d["CELL_TEX_GROUPS"] = 1
        d["CELL_TEX_GROUP_OCTAVES"] = texture.group_octaves(recipe)
    # far points (a pan or groups) run with uniforms, as the viewer pans: the bits they always had
    baked = BAKE_CONSTANTS and pan is None and groups is None
    from cellgl.texture.antialias import fades

    mean = footprint is None or fades(recipe.values, footprint)
    files = ({"texture_uniforms.glsl": texture.glsl_baked_uniforms_file(recipe, bool(mask & 32), mean=mean)}
             if baked else None)

    searches = _searches(recipe) * (int(supersample) ** 2 + 1 if supersample > 1 else 1)
    inputs = _runner.Index() if grid else _runner.Rows(np.ascontiguousarray(points, np.float32), 0)
    if count:
        if not baked:
            values = texture.recipe_uniforms(recipe, pan=(0.0, 0.0) if pan is None else pan,
                                             pan_only=pan_only and pan is not None, mean=mean)
        else:
            values = {}
            if recipe.values["density_map"] == "image" or recipe.values["cell_color"] == "image":
                texture.recipe_uniforms(recipe, pan_only=True)    # binds the density or cell image
        values["u_loop_probe"] = PROBE_PASSES
        values.update(uniforms if isinstance(uniforms, dict) else {})
        if groups is not None:
            _runner.runner().bind_records(groups, GROUPS_BINDING)
        res = _runner.runner().run(_runner.Pass(
            "texture.comp", "texture_samples.frag", d, count, inputs, outputs,
            setup=None if isinstance(uniforms, dict) else uniforms, uniforms=values,
            flag=_runner.Flag("canary", 9, "count"), files=files,
            cost=searches * SEARCH_PASSES + (PROBE_PASSES if probe else 0),
            lru=("texture.baked", MAX_BAKED) if baked else None))
        _check_cut(res.cut, count, recipe, supersample)
    if loops is not None:
        loops = DRIVER_LOOP_LIMIT - 2 - loops[:, 0].astype(np.int64)
    return _unpack(channels, out, loops)


def _searches(recipe) -> int:
    """Searches of one sample: one per octave (a cell-image or domain-warp pass adds as many)."""
    v = recipe.values
    octaves = 1 if v.get("fractal", "none") == "none" else int(np.ceil(float(v.get("octaves", 1))))
    return 2 * max(1, octaves)


def lighter(recipe, supersample: int = 1) -> list[str]:
    """What would shorten the searches of ``recipe``'s samples, among what it has (the advice of
    :class:`LoopLimitError`): fewer octaves, less supersampling, a smaller smoothness, a larger
    Minkowski exponent (below 1 a point k cells away along every axis lies dim^(1/p) k away), a
    point in every cell (sparse cells leave a sample's nearest point many cells away), lighter
    feature walks, fewer points per cell, fewer dimensions: only those that apply."""
    from cellgl.texture.params import inactive

    v = recipe.values
    off = inactive(v)
    dim = v["dimension"]
    ways = []
    if "octaves" not in off and v["octaves"] > 1:
        ways.append(f"fewer fractal.octaves (it has {v['octaves']:g})")
    if supersample > 1:
        ways.append(f"less supersampling (it has {supersample * supersample} samples a pixel)")
    if "smoothness" not in off and v["smoothness"] > 0:
        ways.append(f"a smaller combination.smoothness (it has {v['smoothness']:g})")
    if v["metric"] == "minkowski" and v["minkowski_p"] < 1:
        p = v["minkowski_p"]
        ways.append(f"a larger basis.minkowski_p (it has {p:g}: a point k cells away along every axis lies "
                    f"{dim}^(1/{p:g}) k = {dim ** (1 / p):.3g} k away, so the search reaches that much further)")
    if "min_points" not in off and v["min_points"] == 0:
        ways.append(f"basis.min_points 1 or more, or a larger basis.density (it has min_points 0 and density "
                    f"{v['density']:g}: cells are left empty, so a sample's nearest point can lie many cells away)")
    walks = [t for t in ("c_edge", "c_nsphere") if t not in off and v[t] != 0]
    if walks:
        ways.append(" and ".join(f"combination.{t} 0" for t in walks) + " (their walks go past F1)")
    if "density" not in off and v["distribution"] == "poisson" and v["density"] > 8:
        ways.append(f"a smaller basis.density (it has {v['density']:g} points a cell)")
    if dim == 4:
        ways.append("a smaller basis.dimension (4D searches visit the most cells)")
    return ways


def _check_cut(cut: int, count: int, recipe=None, supersample: int = 1) -> None:
    if cut:
        ways = lighter(recipe, supersample) if recipe is not None else []
        advice = ("; or ".join(ways) if ways else
                  "fewer octaves, less supersampling or a smaller smoothness, where the recipe has them")
        raise LoopLimitError(
            f"the GPU driver cut the loops of {cut} of {count} samples (Mesa's llvmpipe, and lavapipe "
            "under zink, allow 65535 loop passes per SIMD vector of samples): their values would be "
            "wrong, so none are returned. "
            + (f"Recipe {recipe.name!r} would need shorter searches: " if recipe is not None else "Use ")
            + advice + " (docs/exactness.md)")


def _unpack(channels, out: dict, loops) -> dict:
    """The channels asked for from the output arrays."""
    res = {} if loops is None else {"loops": loops}
    for c in channels:
        if c == "color":
            res[c] = out["color"]
        elif c == "height":
            res[c] = out["aux"][:, 0].copy()
        elif c == "normal":
            res[c] = out["aux"][:, 1:4].copy()
        elif c == "id":
            res[c] = out["id"][:, 0]
        elif c in ("F1", "F2", "F3", "F4"):
            f = out["F"][:, int(c[1]) - 1]
            res[c] = f if out["F"].shape[1] == 1 else f.copy()     # F1 alone: the array itself
        elif c == "grad":
            res[c] = out["grad"][:, :3].copy()
        elif c == "value":
            res[c] = out["grad"][:, 3].copy()
        elif c in ("roughness", "ao", "metallic"):
            res[c] = out["material"][:, ("roughness", "ao", "metallic").index(c)].copy()
    return res
