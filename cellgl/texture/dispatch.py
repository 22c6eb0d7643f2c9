"""Run ``shaders/texture.comp`` for :func:`cellgl.texture.evaluate` and :func:`cellgl.texture.render`.

Where the time goes, and what this module does about it (``benchmarks/bench_texture.py``):

* **Baked programs.** With the recipe's values as uniforms, the compiler cannot know that most
  coefficients are 0, that ``light`` is 0 or how many ramp keys there are, so every pixel pays
  for all 24 combination terms, the copies of the uniform arrays into ``CellTextureParams``,
  their dynamic indexing, the lighting and both ramp modes. A bake compiles ``texture.comp``
  with ``texture_uniforms.glsl`` replaced by the recipe's values as constants
  (:func:`cellgl.texture.shader.glsl_baked_uniforms_file`: the same
  :func:`~cellgl.texture.shader.glsl_constant_block` the snippets use), so the compiler folds
  all of that away; the viewer keeps uniforms (it changes them every frame). A compile costs ~0.1 s on llvmpipe; the last
  :data:`MAX_BAKED` programs are kept.
* **Only the outputs asked for** are written (``CELL_TEX_OUT``) and read back, from storage
  buffers reused across calls instead of five fresh ones per dispatch.

The driver's loop limit (docs/exactness.md): ``texture.comp`` counts the samples whose loops
llvmpipe cut (its canary); :func:`run` raises :class:`LoopLimitError` rather than return them.
"""
from __future__ import annotations

from collections import OrderedDict

import numpy as np

from cellgl.gl.threads import gl_call

__all__ = ["MAX_BAKED", "LoopLimitError", "run", "output_mask"]

#: llvmpipe's loop limiter (Mesa gallivm LP_MAX_TGSI_LOOP_ITERATIONS; docs/exactness.md)
DRIVER_LOOP_LIMIT = 65535


class LoopLimitError(ValueError):
    """The driver cut the loops of some samples (llvmpipe's 65535 loop passes per SIMD vector):
    their values would be wrong, so none are returned. A ValueError: the request is too heavy for
    the driver (fewer octaves, less supersampling or a smaller smoothness serve it); the command
    line reports it as a user error."""

_CHUNK = 1 << 20            # samples per dispatch
#: baked programs kept (least recently used dropped)
MAX_BAKED = 16
#: False: compile with uniforms, as the viewer does (benchmarks/bench_texture.py --uniforms)
BAKE_CONSTANTS = True

#: output buffer -> (binding, bytes per sample, bit in CELL_TEX_OUT, channels it carries)
_OUTPUTS = {
    "color": (1, 16, 1, ("color",)),
    "aux": (2, 16, 2, ("height", "normal")),
    "F": (3, 16, 4, ("F1", "F2", "F3", "F4")),
    "grad": (4, 16, 8, ("grad", "value")),
    "id": (5, 4, 16, ("id",)),
}

_baked: dict = {}   # id(ctx) -> OrderedDict of its baked programs
_pool: dict = {}


def output_mask(channels) -> int:
    """``CELL_TEX_OUT`` for these channels."""
    return sum(bit for _, _, bit, chans in _OUTPUTS.values() if set(chans) & set(channels))


def _program(recipe, defines: dict, pan=None, pan_only=False):
    """texture.comp for ``recipe`` with ``defines``: baked (constants, LRU-cached) or with uniforms
    (always with a ``pan``: one program serves every pan, where baking would compile per pan;
    ``pan_only``: the program's other uniforms are already this recipe's)."""
    from cellgl.gl import context, dispatch
    from cellgl.texture import shader as texture

    ctx = context.get_context()
    fragment = dispatch.path(ctx) == "fragment"
    if not BAKE_CONSTANTS or pan is not None:
        if fragment:
            prog = dispatch.program(_FRAGMENT_ENTRY, defines)
        else:
            prog = context.compute_program("texture.comp", defines)
        texture.set_uniforms(prog, recipe, pan=(0.0, 0.0) if pan is None else pan,
                             pan_only=pan_only and pan is not None)
        return prog
    consts = texture.glsl_baked_uniforms_file(recipe)
    key = (tuple(sorted(defines.items())), consts, fragment)
    # one LRU per context: a program is released only while its own context is current
    baked = _baked.setdefault(id(ctx), OrderedDict())
    prog = baked.get(key)
    if prog is not None:
        baked.move_to_end(key)
    else:
        files = {"texture_uniforms.glsl": consts}
        if fragment:
            prog = dispatch.program(_FRAGMENT_ENTRY, defines, files=files, cache=False)
        else:
            prog = context.compute_program("texture.comp", defines, files=files, cache=False)
        baked[key] = prog
        while len(baked) > MAX_BAKED:
            baked.popitem(last=False)[1].release()
    if recipe.values["density_map"] == "image" or recipe.values["cell_color"] == "image":
        texture.set_uniforms(prog, recipe)        # binds the density or cell image (no uniforms left)
    return prog


def _buffer(ctx, binding: int, nbytes: int):
    """A storage buffer of at least ``nbytes`` at ``binding``, reused across calls."""
    key = (id(ctx), binding)
    buf = _pool.get(key)
    if buf is None or buf.size < nbytes:
        if buf is not None:
            buf.release()
        buf = _pool[key] = ctx.buffer(reserve=max(64, nbytes))
    buf.bind_to_storage_buffer(binding)
    return buf


@gl_call
def run(recipe, channels, count: int, setup, *, grid: bool, supersample: int = 1, pan=None,
        pan_only: bool = False, probe: bool = False) -> dict:
    """Dispatch texture.comp over ``count`` samples and return ``{channel: array}`` (flat, one row
    per sample). ``setup(prog, first, n)`` sets the entry's own uniforms and returns buffers to
    release after the chunk; ``supersample``: n of the n x n sub-pixel grid (grid only); ``pan``
    (du, dv, dz): added to the samples' texture position in float64, through the split origins;
    ``pan_only``: the last call ran this recipe with the same channels (only the pan changed);
    ``probe``: the measurement build, adding ``"loops"``: the loop passes llvmpipe counted for each
    sample's SIMD vector (benchmarks/loop_budget.py). Raises :class:`LoopLimitError` if the driver
    cut any sample's loops."""
    from cellgl.gl import context
    from cellgl.texture import shader as texture

    local_size = texture.LOCAL_SIZE
    ctx = context.get_context()
    mask = output_mask(channels)
    d = texture.defines(recipe, channels)
    d.update(CELL_TEX_GRID=int(grid), CELL_LOCAL_SIZE=local_size, CELL_TEX_OUT=mask,
             CELL_TEX_SUPERSAMPLE=int(supersample))
    # No loop budget of the search's own (cellular.glsl): a texture invocation searches once per
    # octave and sub-sample and reports no per-sample flag; the canary below reports the driver's.
    d["CELL_LOOP_BUDGET"] = 1 << 30
    if probe:
        d["CELL_LOOP_PROBE"] = 1
    fragment = _fragment(d, mask, probe)
    prog = _program(recipe, d, pan, pan_only)
    if fragment:
        return _unpack(channels, _run_fragment(prog, mask, count, setup), None)
    cut = 0
    loops = np.empty(count, np.int64) if probe else None
    out = {}
    for name, (binding, size, bit, _) in _OUTPUTS.items():
        if mask & bit:
            shape = (count,) if name == "id" else (count, 4)
            out[name] = np.empty(shape, np.uint32 if name == "id" else np.float32)
    for start in range(0, count, _CHUNK):
        n = min(_CHUNK, count - start)
        bufs = {name: _buffer(ctx, _OUTPUTS[name][0], n * _OUTPUTS[name][1]) for name in out}
        extra = setup(prog, start, n)
        for name, value in (("u_count", n), ("u_first", start), ("u_loop_canary", 2), ("u_loop_probe", 1 << 30)):
            if name in prog:
                prog[name].value = value
        flag = _buffer(ctx, 9, 4)        # texture.comp's LoopCut (6, 7: the cell and density images)
        flag.write(b"\0\0\0\0")
        pbuf = _buffer(ctx, 10, 4 * n) if probe else None
        prog.run(group_x=(n + local_size - 1) // local_size)
        ctx.memory_barrier()
        for name, buf in bufs.items():
            buf.read_into(out[name][start:start + n], size=n * _OUTPUTS[name][1])
        cut += int(np.frombuffer(flag.read(4), dtype=np.uint32)[0])
        if probe:
            left = np.frombuffer(pbuf.read(4 * n), dtype=np.int32)
            loops[start:start + n] = DRIVER_LOOP_LIMIT - 2 - left
        for b in extra:
            b.release()
    _check_cut(cut, count)
    return _unpack(channels, out, loops)


def _check_cut(cut: int, count: int) -> None:
    if cut:
        raise LoopLimitError(
            f"the GPU driver cut the loops of {cut} of {count} samples (Mesa llvmpipe allows 65535 loop "
            "passes per SIMD vector of samples): their values would be wrong, so none are returned. "
            "Use fewer octaves, less supersampling or a smaller smoothness (docs/exactness.md)")


#: the fragment path's entry (cellgl.gl.dispatch): texture.comp's work in a fragment program
_FRAGMENT_ENTRY = "texture_samples.frag"


def _fragment(d: dict, mask: int, probe: bool) -> bool:
    """True on the fragment path; then adds its defines to ``d``: the render target of each
    output asked for (``CELL_TEX_LOC_*``; location 0 is the canary)."""
    from cellgl.gl import dispatch

    if dispatch.path() != "fragment":
        return False
    if probe:
        raise ValueError("the loop probe (benchmarks/loop_budget.py) measures the compute path; "
                         "unset CELLGL_PATH or run it where OpenGL 4.3 is")
    loc = 1
    for name, (_, _, bit, _) in _OUTPUTS.items():
        d[f"CELL_TEX_WANT_{name.upper()}"] = int(bool(mask & bit))
        if mask & bit:
            d[f"CELL_TEX_LOC_{name.upper()}"] = loc
            loc += 1
    return True


def _run_fragment(prog, mask: int, count: int, setup) -> dict:
    """texture_samples.frag over ``count`` samples in chunks (as :func:`run`); the outputs by name."""
    from cellgl.gl import dispatch

    names = [name for name, (_, _, bit, _) in _OUTPUTS.items() if mask & bit]
    formats = [(1, "u4")] + [(1, "u4") if name == "id" else (4, "f4") for name in names]
    out = {name: np.empty((count,) if name == "id" else (count, 4), np.uint32 if name == "id" else np.float32)
           for name in names}
    cut = 0
    for start in range(0, count, _CHUNK):
        n = min(_CHUNK, count - start)
        extra = setup(prog, start, n)
        for name, value in (("u_first", start), ("u_loop_canary", 2)):
            if name in prog:
                prog[name].value = value
        res = dispatch.draw(prog, n, formats)
        cut += int(np.count_nonzero(res[0][:, 0] == 0))
        for name, data in zip(names, res[1:]):
            out[name][start:start + n] = data[:, 0] if name == "id" else data
        for b in extra:
            b.release()
    _check_cut(cut, count)
    return out


def bind_points(p4: np.ndarray) -> list:
    """Hand the points (n, 4) float32 (u, v, z, -) of a chunk to the entry: storage buffer 0
    (texture.comp) or texture unit 0 (the fragment path). Returns what to release after the chunk."""
    from cellgl.gl import context, dispatch

    ctx = context.get_context()
    if dispatch.path(ctx) == "fragment":
        dispatch.input_texture(ctx, 0, np.ascontiguousarray(p4, np.float32))
        return []
    b = ctx.buffer(np.ascontiguousarray(p4, np.float32).tobytes())
    b.bind_to_storage_buffer(0)
    return [b]


def _unpack(channels, out: dict, loops) -> dict:
    """The channels asked for from the output buffers."""
    res = {} if loops is None else {"loops": loops}
    for c in channels:
        if c == "color":
            res[c] = out["color"]
        elif c == "height":
            res[c] = out["aux"][:, 0].copy()
        elif c == "normal":
            res[c] = out["aux"][:, 1:4].copy()
        elif c == "id":
            res[c] = out["id"]
        elif c in ("F1", "F2", "F3", "F4"):
            res[c] = out["F"][:, int(c[1]) - 1].copy()
        elif c == "grad":
            res[c] = out["grad"][:, :3].copy()
        elif c == "value":
            res[c] = out["grad"][:, 3].copy()
    return res
