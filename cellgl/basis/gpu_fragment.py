"""The cellular basis on the fragment path (``shaders/cellular.frag``; :mod:`cellgl.gl.dispatch`).

:mod:`cellgl.basis.gpu` hands its calls here where the context has no compute shaders (or
``CELL_PATH=fragment``). The same ``shaders/lib`` code runs once per fragment, and gives the same
bits as ``cellular.comp``:

* **Positions.** cellular.comp splits each position into an integer cell and a float32 fraction in
  float64; OpenGL 3.3 has no doubles, so the same split runs here in NumPy (IEEE float64, the same
  operations in the same order) and the cells and fractions go in as textures (in 2D one RGBA32I
  texel: the cell and the fraction's bits). A grid is separable: each axis's cells and fractions
  are one table (``origin + spacing * index``, as the compute entry computes it; RG32I texels),
  looked up per sample.
* **Outputs.** Each sample's rows (F, id, delta, grad, the feature record) are spread over render
  targets of 4 channels (:func:`cellgl.gl.dispatch.slots`), location 0 being the exact flag;
  where they exceed the draw buffers, several draws each write a part and every draw's flag counts.
* **Exactness.** The loop budget and the canary of cellular.comp are the same code; positions
  beyond +-2^30 cells are searched at 0 and flagged, as there.
"""
from __future__ import annotations

import numpy as np

from cellgl.gl import context
from cellgl.gl import dispatch

#: samples per upload and read-back (a multiple of dispatch.WIDTH)
CHUNK = 1 << 19
_COORD_LIMIT = 1073741824.0


def split_points(pts: np.ndarray, scale: float, dim: int):
    """cellular.comp's split of positions ``pts`` (N, dim) float64 times ``scale``: (cell int32
    (N, dim), fraction float32 (N, dim), in range (N,) bool). Out of range (|x| >= 2^30 cells, or
    NaN): searched at 0 and flagged, as there."""
    x = pts[:, :dim] * np.float64(scale)
    lo, hi = (x.min(), x.max()) if x.size else (0.0, 0.0)
    if -_COORD_LIMIT < lo and hi < _COORD_LIMIT:        # False for NaN: the careful way below
        ok = np.ones(len(x), bool)
    else:
        with np.errstate(invalid="ignore"):
            inside = np.abs(x) < _COORD_LIMIT
        x[~inside] = 0.0
        ok = inside.all(axis=1)
    fl = np.floor(x)
    np.subtract(x, fl, out=x)
    frac = x.astype(np.float32)                         # float64 -> float32, to nearest
    cell = fl.astype(np.int32)
    up = frac >= 1.0                                    # a fraction just below 1 rounds up to 1
    if up.any():
        cell += up
        frac[up] = 0.0
    return cell, frac, ok


def axis_tables(shape_xyzw, origin_cell, origin_frac, spacing):
    """Per axis, the integer cell and float32 fraction of every grid index (cellular.comp's
    ``u_origin_frac + u_spacing * idx`` in float64): (cells int32, fractions float32, offsets (4,))
    with axis a's entries from offsets[a]."""
    cells, fracs, offsets, at = [], [], [], 0
    for a in range(4):
        idx = np.arange(int(shape_xyzw[a]), dtype=np.float64)
        pos = np.float64(origin_frac[a]) + np.float64(spacing[a]) * idx
        fl = np.floor(pos)
        fr = (pos - fl).astype(np.float32)
        up = fr >= 1.0
        cells.append((int(origin_cell[a]) + fl.astype(np.int64) + up).astype(np.int32))
        fracs.append(np.where(up, np.float32(0.0), fr))
        offsets.append(at)
        at += len(idx)
    return np.concatenate(cells), np.concatenate(fracs), offsets


def _layout(outputs, n: int, dim: int, stride: int):
    """(name, kind, components per sample) of each output buffer."""
    size = {"F": n, "id": n, "delta": n * dim, "grad": n * dim, "features": stride}
    return [(name, "u" if name == "id" else "f", size[name]) for name in outputs]


def _passes(layout, ctx):
    """The draws: each a list of slots (name, kind, first component), at most draw buffers - 1."""
    per = dispatch.draw_buffers(ctx) - 1
    all_slots = dispatch.slots(layout)
    return [all_slots[i:i + per] for i in range(0, len(all_slots), per)]


def _pass_defines(slots, layout) -> dict:
    """CELL_FRAG_DECL and CELL_FRAG_WRITE of one draw."""
    length = {name: size for name, _, size in layout}
    decl = ["layout(location = 0) out uint o_exact;"]
    write = []
    for loc, (name, kind, first) in enumerate(slots, start=1):
        vec = "uvec4" if kind == "u" else "vec4"
        zero = "0u" if kind == "u" else "0.0"
        decl.append(f"layout(location = {loc}) out {vec} o_{loc};")
        comps = [f"row_{name}[{first + c}]" if first + c < length[name] else zero for c in range(4)]
        write.append(f"o_{loc} = {vec}({', '.join(comps)});")
    return {"CELL_FRAG_DECL": " ".join(decl), "CELL_FRAG_WRITE": " ".join(write)}


def _set(prog, name, value):
    if name in prog:
        prog[name].value = value


def run(defines: dict, set_params, count: int, outputs, n: int, dim: int, stride: int,
        out: dict, exact: np.ndarray, inputs, probe: np.ndarray | None = None) -> None:
    """Evaluate ``count`` samples into ``out`` (arrays as cellgl.basis.gpu._alloc) and ``exact``.
    ``set_params(prog)`` sets the parameter uniforms; ``inputs(prog, start, m)`` uploads chunk
    ``[start, start + m)``'s positions (and returns its in-range flags or None). ``probe``
    (count, 2) int: the measurement build (``CELL_LOOP_PROBE``): the search's own loop count and
    what the driver's limiter had left, from the first draw."""
    ctx = context.get_context()
    layout = _layout(outputs, n, dim, stride)
    passes = _passes(layout, ctx) or [[]]
    if probe is not None and len(passes[0]) == dispatch.draw_buffers(ctx) - 1:
        passes = [passes[0][:-1], passes[0][-1:]] + passes[1:]   # room for the probe's target
    progs = []
    for i, slots in enumerate(passes):
        d = dict(defines)
        d.update(_pass_defines(slots, layout))
        if probe is not None and i == 0:
            d.update(CELL_LOOP_PROBE=1, CELL_FRAG_PROBE_LOC=len(slots) + 1)
        prog = dispatch.program("cellular.frag", d)
        set_params(prog)
        _set(prog, "u_loop_canary", 2)
        _set(prog, "u_loop_probe", 1 << 30)
        progs.append(prog)
    for start in range(0, count, CHUNK):
        m = min(CHUNK, count - start)
        ok = None
        for i, (prog, slots) in enumerate(zip(progs, passes)):
            ok = inputs(prog, start, m)
            formats = [(1, "u4")] + [(4, "u4" if kind == "u" else "f4") for _, kind, _ in slots]
            if probe is not None and i == 0:
                formats.append((4, "i4"))
            res = dispatch.draw(prog, m, formats, ctx)
            if probe is not None and i == 0:
                probe[start:start + m] = res.pop()[:, :2]
            exact[start:start + m] &= res[0][:, 0] != 0
            for (name, _, first), data in zip(slots, res[1:]):
                dest = out[name][start:start + m].reshape(m, -1)
                k = min(4, dest.shape[1] - first)
                dest[:, first:first + k] = data[:, :k].view(dest.dtype)
        if ok is not None:
            exact[start:start + m] &= ok


def points_inputs(pts: np.ndarray, scale: float, dim: int):
    """``inputs`` of :func:`run` for sample positions ``pts`` (N, dim) float64."""
    def inputs(prog, start, m):
        cell, frac, ok = split_points(pts[start:start + m], scale, dim)
        ctx = context.get_context()
        if dim == 2:                    # one texel: the cell and the fraction's bits
            dispatch.input_texture(ctx, 0, np.concatenate([cell, frac.view(np.int32)], axis=1))
        else:
            dispatch.input_texture(ctx, 0, cell)
            dispatch.input_texture(ctx, 1, frac)
        return ok
    return inputs


def grid_inputs(shape_xyzw, origin_cell, origin_frac, spacing):
    """``inputs`` of :func:`run` for a grid (as cellgl.basis.gpu.search_grid)."""
    cells, fracs, offsets = axis_tables(shape_xyzw, origin_cell, origin_frac, spacing)
    table = np.stack([cells, fracs.view(np.int32)], axis=1)      # RG32I: cell, the fraction's bits
    width = 1 << dispatch.STORAGE_ROW_BITS

    def inputs(prog, start, m):
        ctx = context.get_context()
        dispatch.input_texture(ctx, 0, table, width)
        _set(prog, "u_grid", tuple(int(v) for v in shape_xyzw))
        _set(prog, "u_axis_offset", tuple(offsets))
        _set(prog, "u_axis_cell", tuple(int(cells[o]) for o in offsets))
        _set(prog, "u_axis_frac", tuple(float(fracs[o]) for o in offsets))
        _set(prog, "u_first", int(start))
        return None
    return inputs
