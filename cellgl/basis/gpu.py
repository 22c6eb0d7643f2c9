"""GPU evaluation of the cellular basis: compute shader over sample lists and grids.

Only :mod:`cellgl.basis.core` calls this; it receives validated parameters. Work is
split into chunks so that no storage buffer exceeds a few tens of MB, and only
the outputs that were asked for are computed (compile-time switches) and read
back.
"""
from __future__ import annotations

import math
import os

import numpy as np

from cellgl.gl import context
from cellgl.basis import features as _features
from cellgl.gl.threads import gl_call
from cellgl.basis.enums import Distribution, glsl_defines
from cellgl.basis.reference import MAX_POINTS, Params, max_ring_default

LOCAL_SIZE = 64
#: the sample texture of :func:`search_points` is 2^_SAMPLE_ROW_BITS texels wide (cellular.comp)
_SAMPLE_ROW_BITS = 12
_TEXTURE_ROWS_MAX = 16384   #: GL_MAX_TEXTURE_SIZE is at least this in every OpenGL 4.3 driver
_CHUNK_BYTES = 48 << 20     # largest output buffer per dispatch
_MAX_GROUPS = 65535


#: llvmpipe's loop limiter (Mesa gallivm LP_MAX_TGSI_LOOP_ITERATIONS; docs/exactness.md)
DRIVER_LOOP_LIMIT = 65535


def defines_for(p: Params, n: int, outputs=("F",), grid: bool = False, smooth: str = "exp") -> dict:
    """The compile-time macros of ``shaders/cellular.comp`` for these parameters."""
    d = glsl_defines()
    d.update(
        CELL_DIM=p.dim,
        # a feature pass needs F1 alone: its walks read r.F[0], delta[0], id[0]
        CELL_N=n if set(outputs) & {"F", "delta", "id", "grad"} else 1,
        CELL_METRIC=int(p.metric),
        CELL_DIST=int(p.distribution),
        CELL_MAX_POINTS=MAX_POINTS,
        CELL_MAX_RING=max_ring_default(p.dim, p.axis_scale),
        CELL_GRID=int(grid),
        CELL_PERIODIC=int(any(p.period)),
        CELL_OUT_F=int("F" in outputs),
        CELL_OUT_DELTA=int("delta" in outputs),
        CELL_OUT_ID=int("id" in outputs),
        CELL_OUT_GRAD=int("grad" in outputs),
        CELL_LOCAL_SIZE=LOCAL_SIZE,
        CELL_SAMPLE_ROW_BITS=_SAMPLE_ROW_BITS,
        CELL_DENSITY_MAP=0 if p.density_map is None else int(p.density_map.kind),
        CELL_ORBIT=int(p.orbit),
        CELL_ANISO=int(p.aniso),
        # min_points, max_points as constants: the count compares only what can count
        CELL_COUNT_CONST=1,
        CELL_MIN_POINTS=int(p.min_points),
        CELL_MAX_COUNT=int(p.max_points),
    )
    d.update(_features.defines(outputs, p.dim, smooth))
    return d


def _buffers(outputs) -> tuple[str, ...]:
    """The output buffers for ``outputs``: the basis outputs, and ``features`` (the record of
    ``shaders/lib/features.glsl``) when a feature output needs a walk."""
    basis = tuple(o for o in outputs if o in ("F", "delta", "id", "grad"))
    return basis + (("features",) if any(_features.flags(outputs).values()) else ())


def _set(prog, name, value):
    if name in prog:
        prog[name].value = value


def _set_params(prog, p: Params):
    _set(prog, "u_seed", int(p.seed))
    _set(prog, "u_jitter", float(p.jitter))
    _set(prog, "u_min_points", int(p.min_points))
    _set(prog, "u_max_points", int(p.max_points))
    if "u_thresholds" in prog:
        u = prog["u_thresholds"]         # the compiler may trim the array to the entries in use
        u.write(p.thresholds[: getattr(u, "array_length", len(p.thresholds))].astype(np.uint32).tobytes())
    _set(prog, "u_period", tuple(int(v) for v in p.period))
    _set(prog, "u_minkowski_p", float(p.minkowski_p))
    _set(prog, "u_out_scale", float(1.0 / p.scale))
    _set(prog, "u_orbit_radius", float(p.orbit_radius))
    _set(prog, "u_orbit_turn", int(p.orbit_turn))
    _set(prog, "u_axis_scale", tuple(float(v) for v in p.axis_scale))
    _set(prog, "u_loop_canary", 2)
    set_density(prog, p.density_map)


_bound_buffers: dict = {}


def set_density(prog, enc) -> None:
    """Set the density-map uniforms of ``prog`` (``u_density_*``) from a
    :class:`cellgl.basis.density.DensityEncoding` and bind its image levels to storage buffer 7."""
    if enc is None:
        return
    if "u_density_thresholds" in prog:
        prog["u_density_thresholds"].write(enc.thresholds.astype(np.uint32).tobytes())
    if "u_density_axis" in prog:
        u = prog["u_density_axis"]       # the compiler may trim the array to the axes in use
        u.write(enc.axes[: getattr(u, "array_length", 4)].astype(np.int32).tobytes())
    _set(prog, "u_density_info", enc.info)
    bind_density_image(enc.levels)


def bind_density_image(levels, ctx=None) -> None:
    """Upload (cached by content, one buffer per context) and bind density-image levels (uint32)
    to storage buffer 7 of ``ctx`` (default: cellgl's context; the viewer passes its window's)."""
    if levels is not None:
        bind_storage(levels, 7, ctx)


def bind_storage(words, binding: int, ctx=None) -> None:
    """Upload uint32 ``words`` (cached by content, one buffer per context and binding) and bind
    them to storage buffer ``binding`` of ``ctx`` (default: cellgl's context)."""
    ctx = ctx or context.get_context()
    data = np.ascontiguousarray(words, dtype=np.uint32).tobytes()
    key = (hash(data), len(data))
    held = _bound_buffers.get((id(ctx), binding))
    if held is None or held[0] != key or held[2] is not ctx:
        if held is not None and held[2] is ctx:
            held[1].release()
        held = _bound_buffers[(id(ctx), binding)] = (key, ctx.buffer(data), ctx)
    held[1].bind_to_storage_buffer(binding)


@gl_call
def cell_counts(cells: np.ndarray, p: Params) -> tuple[np.ndarray, np.ndarray]:
    """Point count and density level of each integer cell (M, 4) int, on the GPU (as the
    search sees them; ``shaders/cell_counts.comp``). Returns (count int64 (M,), level int64 (M,))."""
    ctx = context.get_context()
    d = defines_for(p, 1)
    prog = context.compute_program("cell_counts.comp", d)
    _set_params(prog, p)
    cells = np.ascontiguousarray(cells, dtype=np.int32)
    parts = []
    step = LOCAL_SIZE * _MAX_GROUPS      # one dispatch's worth (a larger one would be dropped)
    for first in range(0, len(cells), step):
        chunk = cells[first:first + step]
        M = len(chunk)
        cb = ctx.buffer(chunk.tobytes())
        cb.bind_to_storage_buffer(0)
        ob = ctx.buffer(reserve=8 * M)
        ob.bind_to_storage_buffer(2)
        _set(prog, "u_count", M)
        prog.run(group_x=(M + LOCAL_SIZE - 1) // LOCAL_SIZE)
        ctx.memory_barrier()
        parts.append(np.frombuffer(ob.read(), dtype=np.int32).reshape(M, 2).astype(np.int64))
        cb.release()
        ob.release()
    out = np.concatenate(parts)
    return out[:, 0], out[:, 1]


def _chunk_size(n: int, dim: int, outputs, stride: int = 0) -> int:
    per = 4 * n * (dim if ("delta" in outputs or "grad" in outputs) else 1)
    per = max(per, 4 * stride if "features" in outputs else 0)
    return max(LOCAL_SIZE, min(LOCAL_SIZE * _MAX_GROUPS, (_CHUNK_BYTES // per) // LOCAL_SIZE * LOCAL_SIZE))


_pool: dict = {}


def _held(key, ctx):
    """The buffer or texture of ``_pool`` under ``key`` if it belongs to ``ctx`` (not to a context
    gone since, whose id ``ctx`` now has), else None."""
    obj = _pool.get(key)
    return obj if obj is not None and obj.ctx is ctx else None


def _storage(ctx, binding: int, nbytes: int):
    """A storage buffer of at least ``nbytes`` bound to ``binding``, reused across calls
    (allocating fresh tens-of-MB buffers every call costs as much as a small dispatch)."""
    key = (id(ctx), binding)
    buf = _held(key, ctx)
    if buf is None or buf.size < nbytes:
        if buf is not None:
            buf.release()
        buf = ctx.buffer(reserve=max(64, nbytes + nbytes // 4))
        _pool[key] = buf
    buf.bind_to_storage_buffer(binding)
    return buf


def upload_samples(ctx, prog, pts: np.ndarray) -> None:
    """Hand the float64 positions ``pts`` (count, d), C-contiguous, to ``prog`` (``cellular.comp``,
    ``u_samples``) as the 32-bit words of an RGBA32UI texture ``2^_SAMPLE_ROW_BITS`` texels wide,
    d / 2 texels per sample, no padding between samples. The texture is kept and reused across
    calls (grown when a chunk needs more rows)."""
    words = pts.reshape(-1).view(np.uint32)
    width = 1 << _SAMPLE_ROW_BITS
    rows, tail = divmod(words.size, 4 * width)
    if rows + 1 > _TEXTURE_ROWS_MAX:      # a chunk holds at most 2 * LOCAL_SIZE * _MAX_GROUPS texels
        raise RuntimeError(f"internal error: {words.size // 4} texels of positions need more than "
                           f"{_TEXTURE_ROWS_MAX} rows of {width}")
    key = (id(ctx), "samples")
    tex = _held(key, ctx)
    if tex is None or tex.height < rows + 1:
        if tex is not None:
            tex.release()
        tex = ctx.texture((width, min(_TEXTURE_ROWS_MAX, max(rows + 1, (rows + 1) * 5 // 4))), 4, dtype="u4")
        tex.filter = (0x2600, 0x2600)        # GL_NEAREST: an integer texture is complete only so
        _pool[key] = tex
    if rows:
        tex.write(words[: rows * width * 4], viewport=(0, 0, width, rows))
    if tail:
        rest = words[rows * width * 4:]
        if tail % 4:                         # 3D, an odd count: the last texel is half a sample
            rest = np.concatenate([rest, np.zeros(4 - tail % 4, np.uint32)])
        tex.write(rest, viewport=(0, rows, rest.size // 4, 1))
    tex.use(0)
    _set(prog, "u_samples", 0)


def _run(prog, ctx, count: int, n: int, dim: int, outputs, out: dict, start: int, exact: np.ndarray,
         groups=None, stride: int = 0):
    """Dispatch one chunk of ``count`` samples (``groups``: work groups x, y, z; default a
    1D dispatch) and copy results into ``out[start:start + count]``."""
    bufs = {}
    sizes = {"F": 4 * n, "delta": 4 * n * dim, "id": 4 * n, "grad": 4 * n * dim,
             "features": 4 * stride}
    binding = {"F": 2, "delta": 3, "id": 4, "grad": 5, "features": 1}
    for name in outputs:
        bufs[name] = _storage(ctx, binding[name], count * sizes[name])
    # Samples whose search hit the cap: a counter and a list of their indices.
    flags = _storage(ctx, 6, 4 * (count + 1))
    flags.write(b"\0\0\0\0")
    _set(prog, "u_count", count)
    gx, gy, gz = groups or ((count + LOCAL_SIZE - 1) // LOCAL_SIZE, 1, 1)
    if max(gx, gy, gz) > _MAX_GROUPS:   # GL drops such a dispatch: the buffers would stay unwritten
        raise RuntimeError(f"internal error: dispatch of {gx} x {gy} x {gz} work groups exceeds {_MAX_GROUPS}")
    prog.run(group_x=gx, group_y=gy, group_z=gz)
    ctx.memory_barrier()
    for name, buf in bufs.items():
        # Straight into the result array (a contiguous run of whole samples).
        buf.read_into(out[name][start:start + count], size=count * sizes[name])
    nbad = int(np.frombuffer(flags.read(4), dtype=np.uint32)[0])
    if nbad:
        idx = np.frombuffer(flags.read(4 * nbad, offset=4), dtype=np.uint32)
        exact[start + idx.astype(np.int64)] = False


def _alloc(N: int, n: int, dim: int, outputs, stride: int = 0) -> dict:
    out = {}
    for name in outputs:
        if name in ("delta", "grad"):
            out[name] = np.empty((N, n, dim), dtype=np.float32)
        elif name == "features":
            out[name] = np.empty((N, stride), dtype=np.float32)
        else:
            out[name] = np.empty((N, n), dtype=np.uint32 if name == "id" else np.float32)
    return out


@gl_call
def search_points(pts: np.ndarray, p: Params, n: int, outputs, smoothness: float = 0.0,
                  smooth: str = "exp") -> tuple[dict, np.ndarray]:
    """Cellular basis at sample positions ``pts`` (N, d) float64, in sample units.

    The shader scales them by ``p.scale`` and splits them into an integer cell
    and a float32 fraction in double precision. Returns ({output name: array},
    exact (N,) bool). Feature outputs (:data:`cellgl.basis.features.OUTPUTS`) in ``outputs`` switch
    on the walks of ``shaders/lib/features.glsl`` (``smoothness`` in lattice units) and add
    ``"features"``, its per-sample record, to the result.
    """
    ctx = context.get_context()
    prog = context.compute_program("cellular.comp", defines_for(p, n, outputs, grid=False, smooth=smooth))
    _set_params(prog, p)
    _set(prog, "u_smoothness", float(smoothness))
    stride, outputs = _features.stride(outputs), _buffers(outputs)     # floats per sample of the record
    _set(prog, "u_scale", float(p.scale))
    N = len(pts)
    out = _alloc(N, n, p.dim, outputs, stride)
    exact = np.ones(N, dtype=bool)
    step = _chunk_size(n, p.dim, outputs, stride)
    pts = np.ascontiguousarray(pts, dtype=np.float64)
    for start in range(0, N, step):
        count = min(step, N - start)
        upload_samples(ctx, prog, pts[start:start + count])
        _run(prog, ctx, count, n, p.dim, outputs, out, start, exact, stride=stride)
    return out, exact


@gl_call
def search_grid(shape_xyzw, origin_cell, origin_frac, spacing, p: Params, n: int, outputs,
                smoothness: float = 0.0, smooth: str = "exp") -> tuple[dict, np.ndarray]:
    """Cellular basis on a regular grid generated on the GPU.

    shape_xyzw: samples along x, y, z, w (unused axes 1); origin split into
    int cell (4,) and float fraction (4,); spacing (4,) (all already scaled).
    Returns flat arrays in x-fastest order, as :func:`search_points`.
    """
    ctx = context.get_context()
    d = defines_for(p, n, outputs, grid=True, smooth=smooth)
    d.update(cell_cache_defines(p, float(spacing[0])))
    prog = context.compute_program("cellular.comp", d)
    _set_params(prog, p)
    _set(prog, "u_smoothness", float(smoothness))
    stride, outputs = _features.stride(outputs), _buffers(outputs)     # floats per sample of the record
    _set(prog, "u_origin_cell", tuple(int(v) for v in origin_cell))
    _set(prog, "u_origin_frac", tuple(float(v) for v in origin_frac))      # dvec4: float64
    _set(prog, "u_spacing", tuple(float(v) for v in spacing))
    X, Y, Z, W = (int(v) for v in shape_xyzw)
    N = X * Y * Z * W
    out = _alloc(N, n, p.dim, outputs, stride)
    exact = np.ones(N, dtype=bool)
    for slab, start, groups in _grid_slabs(X, Y, Z, W, _chunk_size(n, p.dim, outputs, stride)):
        _set(prog, "u_slab", slab[:4])
        _set(prog, "u_slab_size", slab[4:])
        count = slab[4] * slab[5] * groups[2]
        _run(prog, ctx, count, n, p.dim, outputs, out, start, exact, groups=groups, stride=stride)
    return out, exact


#: the shared memory a workgroup's cell cache may take (GL's guaranteed minimum)
_CACHE_BYTES = 32768


def cell_cache_defines(p: Params, spacing_x: float) -> dict:
    """The macros of the workgroup-shared cell cache of ``shaders/cellular.comp`` on a grid of
    this x spacing (lattice units): ``{}`` where it is off. A workgroup's LOCAL_SIZE samples span
    at most ceil((LOCAL_SIZE - 1) |spacing|) + 2 cells along x (a fraction rounding up to the next
    cell included), ring 1 adds one on each side. ``CELLGL_CELL_CACHE=1``: on where it fits;
    off by default (on llvmpipe it costs 2-5x: docs/performance.md, "The cell cache")."""
    if os.environ.get("CELLGL_CELL_CACHE", "0") != "1" or p.density_map is not None:
        return {}
    nx = math.ceil((LOCAL_SIZE - 1) * abs(spacing_x)) + 4
    single = int(p.distribution) in (int(Distribution.JITTER), int(Distribution.BLENDER))
    points = 1 if single else (int(p.max_points) if int(p.distribution) == int(Distribution.POISSON) else MAX_POINTS)
    cells = nx * 3 ** (p.dim - 1)
    if cells * (4 + 20 * points) > _CACHE_BYTES:
        return {}
    return dict(CELL_SHARED_CELLS=1, CELL_CACHE_NX=nx)


def _grid_slabs(X: int, Y: int, Z: int, W: int, step: int):
    """The dispatches of an X x Y x Z x W grid (x fastest), each contiguous in the output and within
    :data:`_MAX_GROUPS` work groups on every axis: yields ``((x0, y0, z0, w, cols, rows), first
    output index, (groups x, y, z))``. Several z-layers of full rows, or some rows of one layer,
    or (a row wider than ``step``) a run of columns of one row."""
    if X > step:          # wider than one dispatch (> LOCAL_SIZE * _MAX_GROUPS samples): split rows
        for w in range(W):
            for z in range(Z):
                for y in range(Y):
                    row = ((w * Z + z) * Y + y) * X
                    for x0 in range(0, X, step):
                        cx = min(step, X - x0)
                        yield (x0, y, z, w, cx, 1), row + x0, ((cx + LOCAL_SIZE - 1) // LOCAL_SIZE, 1, 1)
        return
    if X * Y <= step and Y <= _MAX_GROUPS:
        ny, nz = Y, max(1, min(step // (X * Y), _MAX_GROUPS))
    else:
        ny, nz = max(1, min(step // X, _MAX_GROUPS)), 1
    gx = (X + LOCAL_SIZE - 1) // LOCAL_SIZE
    for w in range(W):
        for z0 in range(0, Z, nz):
            for y0 in range(0, Y, ny):
                cy, cz = min(ny, Y - y0), min(nz, Z - z0)
                yield (0, y0, z0, w, X, cy), ((w * Z + z0) * Y + y0) * X, (gx, cy, cz)


@gl_call
def loop_probe(pts: np.ndarray, p: Params, n: int, outputs, smoothness: float = 0.0,
               budget: int | None = None, smooth: str = "exp") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Measure the loop budget of :func:`search_points` (the measurement build of
    ``shaders/cellular.comp``, ``CELL_LOOP_PROBE``): per sample the search's own count of loop
    iterations (``CellResult.loops``), the iterations the driver's limiter counted for the sample's
    SIMD vector of invocations (llvmpipe; :data:`DRIVER_LOOP_LIMIT` minus what it had left at the
    end), and whether the sample was flagged inexact. ``budget`` overrides ``CELL_LOOP_BUDGET``."""
    ctx = context.get_context()
    d = defines_for(p, n, outputs, grid=False, smooth=smooth)
    d["CELL_LOOP_PROBE"] = 1
    if budget is not None:
        d["CELL_LOOP_BUDGET"] = int(budget)
    prog = context.compute_program("cellular.comp", d)
    _set_params(prog, p)
    _set(prog, "u_smoothness", float(smoothness))
    _set(prog, "u_scale", float(p.scale))
    _set(prog, "u_loop_probe", 1 << 30)
    stride, outputs = _features.stride(outputs), _buffers(outputs)     # floats per sample of the record
    pts = np.ascontiguousarray(pts, dtype=np.float64)
    N = len(pts)
    if N > _chunk_size(n, p.dim, outputs, stride):
        raise ValueError(f"loop_probe takes at most {_chunk_size(n, p.dim, outputs, stride)} samples, got {N}")
    out = _alloc(N, n, p.dim, outputs, stride)
    exact = np.ones(N, dtype=bool)
    upload_samples(ctx, prog, pts)
    probe = _storage(ctx, 8, 8 * N)
    _run(prog, ctx, N, n, p.dim, outputs, out, 0, exact, stride=stride)
    raw = np.frombuffer(probe.read(8 * N), dtype=np.int32).reshape(N, 2).astype(np.int64)
    # the canary loop (2 passes) ran before the probe
    return raw[:, 0], DRIVER_LOOP_LIMIT - 2 - raw[:, 1], ~exact
