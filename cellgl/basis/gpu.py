"""GPU evaluation of the cellular basis: each call describes a pass of ``shaders/cellular.*``
(entries, defines, uniforms, the samples, the outputs asked for) and hands it to the context's
runner (:mod:`cellgl.gl.runner`), which runs it on the compute or the fragment path in tiles and
reads the outputs straight into the arrays made here.

Only :mod:`cellgl.basis.core` calls this; it receives validated parameters. Only the outputs that
were asked for are computed (compile-time switches) and read back.
"""
from __future__ import annotations

import math
import os

import numpy as np

from cellgl.gl import runner as _runner
from cellgl.gl.runner import Flag, Grid, Output, Pass, Positions, Rows
from cellgl.basis import features as _features
from cellgl.gl.threads import gl_call
from cellgl.basis.enums import Distribution, glsl_defines
from cellgl.basis.reference import MAX_POINTS, Params, max_ring_default

LOCAL_SIZE = _runner.LOCAL_SIZE
#: the sample texture of :func:`search_points` is 2^_SAMPLE_ROW_BITS texels wide (cellular.comp)
_SAMPLE_ROW_BITS = _runner.SAMPLE_ROW_BITS
#: the search's loop budget when none is given (shaders/lib/walk.glsl, CELL_LOOP_BUDGET)
LOOP_BUDGET = 6144
#: passes of the loop probe's counting loop (``u_loop_probe``): past llvmpipe's limiter
#: (:data:`DRIVER_LOOP_LIMIT`), so the count is what the limiter had left, and bounded, so a GPU
#: without a limiter runs 2^17 empty passes a sample (milliseconds a tile), never hangs
PROBE_PASSES = 1 << 17


#: llvmpipe's loop limiter per SIMD vector (Mesa gallivm LP_MAX_TGSI_LOOP_ITERATIONS;
#: docs/exactness.md); the one definition: texture/dispatch.py and pups/gpu.py import it
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


def params_uniforms(p: Params) -> dict:
    """The uniforms of the basis entries for ``p``, as the runner sets them (a pass's
    ``uniforms``; arrays cut to the entries the compiler kept), the density image bound."""
    u = {"u_seed": int(p.seed), "u_jitter": float(p.jitter), "u_min_points": int(p.min_points),
         "u_max_points": int(p.max_points), "u_thresholds": p.thresholds.astype(np.uint32),
         "u_period": tuple(int(v) for v in p.period), "u_minkowski_p": float(p.minkowski_p),
         "u_out_scale": float(1.0 / p.scale), "u_orbit_radius": float(p.orbit_radius),
         "u_orbit_turn": int(p.orbit_turn), "u_axis_scale": tuple(float(v) for v in p.axis_scale)}
    u.update(density_uniforms(p.density_map))
    return u


def density_uniforms(enc) -> dict:
    """The density-map uniforms (``u_density_*``) of a :class:`cellgl.basis.density.DensityEncoding`
    (None: none), its image levels bound to storage binding 7."""
    if enc is None:
        return {}
    bind_density_image(enc.levels)
    return {"u_density_thresholds": enc.thresholds.astype(np.uint32),
            "u_density_axis": enc.axes.astype(np.int32), "u_density_info": enc.info}


#: the density image's storage binding (``cell_density_image_level`` of the entries and of
#: shaders/texture_uniforms.glsl reads its words there)
DENSITY_IMAGE_BINDING = 7


def bind_density_image(levels, ctx=None) -> None:
    """Upload (cached by content, one buffer per context) and bind density-image levels (uint32)
    to storage buffer 7 of ``ctx`` (default: cellgl's context; the viewer passes its window's)."""
    if levels is not None:
        bind_storage(levels, DENSITY_IMAGE_BINDING, ctx)


def bind_storage(words, binding: int, ctx=None) -> None:
    """Upload uint32 ``words`` (cached by content, one per context and binding) and bind them where
    the entries read them (storage buffer or texture ``binding``: :meth:`cellgl.gl.runner.Runner.bind_words`)
    on ``ctx`` (default: cellgl's context)."""
    _runner.runner(ctx).bind_words(words, binding)


#: each output's storage binding in cellular.comp (its ``row_<name>`` in cellular.frag)
_BINDING = {"F": 2, "delta": 3, "id": 4, "grad": 5, "features": 1, "probe": 8}
#: the flag: cellular.comp's list of the samples whose search was cut (binding 6), cellular.frag's
#: ``o_exact``
_FLAG = Flag("exact", 6, "list")


def _cost(d: dict) -> int:
    """The most loop passes one invocation of cellular.* with defines ``d`` spends: the search's
    budget, and as much again for the feature walks (they carry on the search's count), and the
    probe's counting loop."""
    budget = int(d.get("CELL_LOOP_BUDGET", LOOP_BUDGET))
    walks = 2 if (d.get("CELL_EDGE") or d.get("CELL_SMOOTH") or d.get("CELL_NSPHERE")) else 1
    return budget * walks + (PROBE_PASSES if d.get("CELL_LOOP_PROBE") else 0) + 2


@gl_call
def cell_counts(cells: np.ndarray, p: Params) -> tuple[np.ndarray, np.ndarray]:
    """Point count and density level of each integer cell (M, 4) int, on the GPU (as the
    search sees them; ``shaders/cell_counts.*``). Returns (count int64 (M,), level int64 (M,))."""
    d = defines_for(p, 1)
    cells = np.ascontiguousarray(cells, dtype=np.int32)
    out = np.empty((len(cells), 2), np.int32)
    if len(cells):
        _runner.runner().run(Pass("cell_counts.comp", "cell_counts.frag", d, len(cells), Rows(cells, 0),
                                  [Output("count", 2, out)], uniforms=params_uniforms(p),
                                  cost=64))
    out = out.astype(np.int64)
    return out[:, 0], out[:, 1]


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


def _run(d: dict, p: Params, smoothness: float, inputs, N: int, out: dict, extra=None,
         group=None) -> np.ndarray:
    """Run cellular.* with defines ``d`` (and ``group``: those of a work group's cell cache) over
    ``N`` samples of ``inputs`` into ``out``; returns exact (N,) bool."""
    outputs = [Output(name, _BINDING[name], a.reshape(N, -1)) for name, a in out.items()]
    outputs += [Output(name, _BINDING[name], a) for name, a in (extra or {}).items()]
    if not N:
        return np.ones(0, bool)
    uniforms = params_uniforms(p)
    uniforms.update(u_smoothness=float(smoothness), u_loop_probe=PROBE_PASSES)
    res = _runner.runner().run(Pass("cellular.comp", "cellular.frag", d, N, inputs, outputs,
                                    uniforms=uniforms, flag=_FLAG, cost=_cost(d), group_defines=group))
    flagged = res.flagged
    assert flagged is not None              # _FLAG is a "list" flag
    return np.logical_not(flagged, out=flagged)     # in place: no second (N,) array


@gl_call
def search_points(pts: np.ndarray, p: Params, n: int, outputs, smoothness: float = 0.0,
                  smooth: str = "exp") -> tuple[dict, np.ndarray]:
    """Cellular basis at sample positions ``pts`` (N, d) float64, in sample units.

    The positions are scaled by ``p.scale`` and split into an integer cell and a float32 fraction
    in double precision. Returns ({output name: array}, exact (N,) bool). Feature outputs
    (:data:`cellgl.basis.features.OUTPUTS`) in ``outputs`` switch on the walks of
    ``shaders/lib/features.glsl`` (``smoothness`` in lattice units) and add ``"features"``, its
    per-sample record, to the result.
    """
    d = defines_for(p, n, outputs, grid=False, smooth=smooth)
    stride, outputs = _features.stride(outputs), _buffers(outputs)     # floats per sample of the record
    pts = np.ascontiguousarray(pts, dtype=np.float64)
    N = len(pts)
    out = _alloc(N, n, p.dim, outputs, stride)
    exact = _run(d, p, smoothness, Positions(pts, float(p.scale), p.dim), N, out)
    return out, exact


@gl_call
def search_grid(shape_xyzw, origin_cell, origin_frac, spacing, p: Params, n: int, outputs,
                smoothness: float = 0.0, smooth: str = "exp") -> tuple[dict, np.ndarray]:
    """Cellular basis on a regular grid generated on the GPU.

    shape_xyzw: samples along x, y, z, w (unused axes 1); origin split into
    int cell (4,) and float fraction (4,); spacing (4,) (all already scaled).
    Returns flat arrays in x-fastest order, as :func:`search_points`.
    """
    d = defines_for(p, n, outputs, grid=True, smooth=smooth)
    stride, outputs = _features.stride(outputs), _buffers(outputs)     # floats per sample of the record
    X, Y, Z, W = (int(v) for v in shape_xyzw)
    N = X * Y * Z * W
    if N >= 1 << 32:
        raise ValueError(f"a grid of {N} samples is too large (at most 2^32 - 1 samples)")
    out = _alloc(N, n, p.dim, outputs, stride)
    grid = Grid((X, Y, Z, W), tuple(int(v) for v in origin_cell), tuple(float(v) for v in origin_frac),
                tuple(float(v) for v in spacing))
    exact = _run(d, p, smoothness, grid, N, out, group=cell_cache_defines(p, float(spacing[0])))
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


@gl_call
def loop_probe(pts: np.ndarray, p: Params, n: int, outputs, smoothness: float = 0.0,
               budget: int | None = None, smooth: str = "exp") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Measure the loop budget of :func:`search_points` (the measurement build of
    ``shaders/cellular.*``, ``CELL_LOOP_PROBE``): per sample the search's own count of loop
    iterations (``CellResult.loops``), the iterations the driver's limiter counted for the sample's
    SIMD vector of invocations (llvmpipe; :data:`DRIVER_LOOP_LIMIT` minus what it had left at the
    end), and whether the sample was flagged inexact. ``budget`` overrides ``CELL_LOOP_BUDGET``
    (at most 2^20). The probe's own counting loop is :data:`PROBE_PASSES` long: on a GPU without
    llvmpipe's limiter the driver's count is meaningless, never a hang."""
    d = defines_for(p, n, outputs, grid=False, smooth=smooth)
    if budget is not None:
        if not 1 <= int(budget) <= 1 << 20:
            raise ValueError(f"loop_probe budget must be in [1, 2^20], got {budget}")
        d["CELL_LOOP_BUDGET"] = int(budget)
    d["CELL_LOOP_PROBE"] = 1
    stride, outputs = _features.stride(outputs), _buffers(outputs)     # floats per sample of the record
    pts = np.ascontiguousarray(pts, dtype=np.float64)
    N = len(pts)
    out = _alloc(N, n, p.dim, outputs, stride)
    raw = np.zeros((N, 2), np.int32)
    exact = _run(d, p, smoothness, Positions(pts, float(p.scale), p.dim), N, out, {"probe": raw})
    raw = raw.astype(np.int64)
    # the canary loop (2 passes) ran before the probe
    return raw[:, 0], DRIVER_LOOP_LIMIT - 2 - raw[:, 1], ~exact
