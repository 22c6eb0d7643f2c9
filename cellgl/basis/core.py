"""The public cellular-basis API: :func:`cellular`, :func:`cellular_grid`, :func:`feature_points`.

Validates every argument (errors name the bad value and the accepted range),
splits float64 positions into an integer cell and a float fraction, and
dispatches to the GPU (:mod:`cellgl.basis.gpu`) or the NumPy reference
(:mod:`cellgl.basis.reference`).
"""
from __future__ import annotations

import math
import numbers
import operator
from dataclasses import dataclass

import numpy as np

from cellgl.basis import features as _features
from cellgl.basis import passes as _passes
from cellgl.basis import reference
from cellgl.basis.arrays import real_array, refuse_masked
from cellgl.basis.density import encode as _encode_density
from cellgl.basis.enums import Distribution, Metric, parse_enum
from cellgl.basis.population import warn_blender_far

__all__ = ["CellularResult", "FeaturePoints", "cellular", "cellular_grid", "feature_points", "make_params"]

N_MAX = 8                       #: largest n (F1..F8)
OUTPUTS = ("F", "delta", "id", "grad") + _features.OUTPUTS
BACKENDS = ("gpu", "numpy")
COORD_LIMIT = 2.0 ** 30         #: |position| (in cells) must stay below this


@dataclass
class CellularResult:
    """Result of :func:`cellular` / :func:`cellular_grid`.

    Attributes (``None`` when not requested in ``outputs``), with ``S`` the
    sample shape ((N,) for point lists, the grid shape for grids):

    F : float32 (*S, n) -- distances F1..Fn, ascending
    delta : float32 (*S, n, d) -- feature point minus sample position
    id : uint32 (*S, n) -- feature point IDs
    grad : float32 (*S, n, d) -- gradient of each F_k with respect to the sample position
    exact : bool (*S) -- False where the search cap was reached (the result may then be
        missing a nearer point); True everywhere in practice
    edge : float32 (*S) -- distance to the border of the sample's Voronoi cell (Euclidean)
    edge_grad : float32 (*S, d) -- its gradient (minus the normal of the nearest border plane)
    nsphere : float32 (*S) -- half the distance from the F1 point to its nearest other point
    position : float64 (*S, d) -- the F1 feature point
    color : float32 (*S, 3) -- the F1 cell's colour (from its ID)
    smooth_F1 : float32 (*S) -- smooth F1, ``-k log sum_j exp(-F_j / k)``, k = ``smoothness``
    smooth_position, smooth_grad : float64 / float32 (*S, d); smooth_color : float32 (*S, 3) --
        the feature position, gradient and cell colour averaged with the same weights
    """

    F: np.ndarray | None
    delta: np.ndarray | None
    id: np.ndarray | None
    grad: np.ndarray | None
    exact: np.ndarray
    edge: np.ndarray | None = None
    edge_grad: np.ndarray | None = None
    nsphere: np.ndarray | None = None
    position: np.ndarray | None = None
    color: np.ndarray | None = None
    smooth_F1: np.ndarray | None = None
    smooth_position: np.ndarray | None = None
    smooth_grad: np.ndarray | None = None
    smooth_color: np.ndarray | None = None


@dataclass
class FeaturePoints:
    """Result of :func:`feature_points`.

    positions : float64 (K, d); ids : uint32 (K,); cell_index : int64 (K,) row of ``cells``
    each point came from. Points are ordered by cell, then by their order in the cell.
    """

    positions: np.ndarray
    ids: np.ndarray
    cell_index: np.ndarray


def _number(name, value, lo, hi, *, integer=False, lo_open=False):
    ok_type = isinstance(value, numbers.Integral) if integer else isinstance(value, numbers.Real)
    if isinstance(value, bool) or not ok_type:
        kind = "an integer" if integer else "a number"
        raise ValueError(f"{name} must be {kind} in [{lo}, {hi}], got {value!r}")
    v = float(value)
    if not math.isfinite(v) or v > hi or v < lo or (lo_open and v <= lo):
        rng = f"({lo}, {hi}]" if lo_open else f"[{lo}, {hi}]"
        raise ValueError(f"{name} must be in {rng}, got {value!r}")
    return int(value) if integer else v


def _period(period, dim) -> tuple[int, int, int, int]:
    if period is None:
        return (0, 0, 0, 0)
    if isinstance(period, (numbers.Number, np.generic)):     # one value for every axis
        vals = [period] * dim
    elif isinstance(period, (str, bytes)):
        vals = None
    else:
        try:
            vals = list(period)
        except TypeError:
            vals = None
    if vals is None or len(vals) != dim:
        raise ValueError(f"period must be an integer or a sequence of {dim} integers (one per axis), got {period!r}")
    out = []
    for v in vals:
        if v is None:
            v = 0
        out.append(_number("period", v, 0, 2 ** 24, integer=True))
    return tuple(out + [0] * (4 - dim))


STRETCH_RANGE = (1.0 / 256.0, 256.0)   #: accepted relative length of a stretched cell along an axis
ORBIT_MAX = 0.5                         #: largest orbit radius (a point's circle spans its cell)


def _stretch(stretch, dim) -> tuple[float, float, float, float]:
    if stretch is None:
        return (1.0, 1.0, 1.0, 1.0)
    vals = [stretch] * dim if isinstance(stretch, numbers.Real) else list(np.ravel(stretch))
    if len(vals) != dim:
        raise ValueError(f"stretch must be a number or a sequence of {dim} numbers (one per axis), "
                         f"got {stretch!r}")
    lo, hi = STRETCH_RANGE
    out = [_number("stretch", v if not isinstance(v, np.generic) else v.item(), lo, hi) for v in vals]
    return tuple(out + [1.0] * (4 - dim))


def make_params(dim, *, metric="euclidean", distribution="poisson", density=3.0, jitter=1.0,
                min_points=1, max_points=9, minkowski_p=3.0, seed=0, period=None,
                density_map=None, stretch=None, orbit_radius=0.0, orbit_phase=0.0) -> reference.Params:
    """Validate the basis parameters and bundle them as :class:`cellgl.basis.reference.Params`."""
    metric = parse_enum(Metric, metric, "metric")
    distribution = parse_enum(Distribution, distribution, "distribution")
    if dim not in (2, 3, 4):
        raise ValueError(f"points must have 2, 3 or 4 coordinates, got {dim}")
    if distribution == Distribution.WORLEY1996 and dim != 3:
        raise ValueError(f"distribution 'worley1996' is 3D only, got {dim}D points")
    if distribution == Distribution.BLENDER and seed != 0:
        raise ValueError(f"distribution 'blender' has no seed (Blender's node has none; offset the "
                         f"points instead), got seed={seed!r}; accepted: 0")
    density = _number("density", density, 0.0, 16.0, lo_open=True)
    jitter = _number("jitter", jitter, 0.0, 1.0)
    min_points = _number("min_points", min_points, 0, reference.MAX_POINTS, integer=True)
    max_points = _number("max_points", max_points, 1, reference.MAX_POINTS, integer=True)
    if min_points > max_points:
        raise ValueError(f"min_points ({min_points}) must not exceed max_points ({max_points})")
    minkowski_p = _number("minkowski_p", minkowski_p, 0.25, 64.0)
    seed = _number("seed", seed, 0, 2 ** 32 - 1, integer=True)
    stretch = _stretch(stretch, dim)
    orbit_radius = _number("orbit_radius", orbit_radius, 0.0, ORBIT_MAX)
    orbit_phase = _number("orbit_phase", orbit_phase, -1e9, 1e9)
    enc = None
    if density_map is not None:
        if distribution != Distribution.POISSON:
            raise ValueError(f"density_map needs distribution 'poisson', got {distribution.name.lower()!r}")
        enc = _encode_density(density_map, dim)
    return reference.Params(dim=dim, metric=metric, distribution=distribution, density=density,
                            jitter=jitter, min_points=min_points, max_points=max_points,
                            minkowski_p=minkowski_p, seed=seed, period=_period(period, dim),
                            density_map=enc, axis_scale=reference.axis_scale(stretch, dim),
                            orbit_radius=orbit_radius,
                            orbit_turn=reference.orbit_turn(orbit_phase))



def _check_stretch_features(p: reference.Params, outputs) -> None:
    """The cell features (edge, n-sphere, smooth, position, colour) measure unweighted distances:
    refuse them with stretched cells rather than answer under the wrong metric."""
    feats = [o for o in outputs if o in _features.OUTPUTS]
    if p.aniso and feats:
        raise ValueError(f"outputs {', '.join(feats)} are not available with stretched cells (stretch != 1); "
                         "accepted with stretch: F, delta, id, grad")


def _outputs(outputs) -> tuple[str, ...]:
    if isinstance(outputs, str):
        outputs = (outputs,)
    try:
        outs = tuple(outputs)
    except TypeError:
        raise ValueError(f"outputs must be a sequence of names among: {', '.join(OUTPUTS)}; "
                         f"got {outputs!r}") from None
    for o in outs:
        if o not in OUTPUTS:
            raise ValueError(f"unknown output {o!r}; expected any of: {', '.join(OUTPUTS)}")
    if not outs:
        raise ValueError(f"outputs must name at least one of: {', '.join(OUTPUTS)}")
    return tuple(o for o in OUTPUTS if o in outs)


def _check_n_backend(n, backend):
    n = _number("n", n, 1, N_MAX, integer=True)
    if backend not in BACKENDS:
        raise ValueError(f"unknown backend {backend!r}; expected one of: {', '.join(BACKENDS)}")
    return n


def _points(points) -> np.ndarray:
    pts = real_array("points", points, "of shape (N, d), d in 2..4", copy=False)     # read only
    if pts.ndim != 2 or pts.shape[1] not in (2, 3, 4):
        raise ValueError(f"points must have shape (N, d) with d in 2..4, got shape {pts.shape}")
    if pts.shape[0] == 0:
        raise ValueError("points is empty (shape (0, d)); pass at least one sample")
    return pts


def _check_coords(pos: np.ndarray, scaled: np.ndarray) -> None:
    """Raise for NaN, infinite or too large coordinates (two reductions in the common case).
    ``scaled`` is ``pos`` in cells (after the distribution's scale)."""
    if scaled.min() > -COORD_LIMIT and scaled.max() < COORD_LIMIT:     # False for NaN too
        return
    bad = ~np.isfinite(pos)
    if bad.any():
        i, j = np.argwhere(bad)[0]
        raise ValueError(f"points must be finite; points[{i}, {j}] is {pos[i, j]}")
    i, j = np.argwhere(np.abs(scaled) >= COORD_LIMIT)[0]
    raise ValueError(f"coordinates must lie within +-2^30 cells; got {pos[i, j]!r} at [{i}, {j}]")


def split(pos: np.ndarray):
    """Split float64 positions (N, d) into int64 cells (N, 4) and float64 fractions (N, 4)
    in [0, 1) (unused axes 0), as the NumPy reference takes them."""
    _check_coords(pos, pos)
    fl = np.floor(pos)
    N, d = pos.shape
    cells = np.zeros((N, 4), dtype=np.int64)
    cells[:, :d] = fl.astype(np.int64)
    fr = np.zeros((N, 4), dtype=np.float64)
    fr[:, :d] = pos - fl
    return cells, fr


def _finish(out: dict, exact, shape, p: reference.Params, n: int, outputs) -> CellularResult:
    def get(name, tail):
        a = out.get(name) if name in outputs else None
        return None if a is None else a.reshape(tuple(shape) + tail)

    d, dim = p.dim, p.dim
    tails = {"edge": (), "edge_grad": (d,), "nsphere": (), "position": (dim,), "color": (3,),
             "smooth_F1": (), "smooth_position": (d,), "smooth_grad": (d,), "smooth_color": (3,)}
    return CellularResult(F=get("F", (n,)), delta=get("delta", (n, p.dim)), id=get("id", (n,)),
                          grad=get("grad", (n, p.dim)), exact=np.asarray(exact).reshape(shape),
                          **{k: get(k, t) for k, t in tails.items()})


def _all_exact(passes) -> np.ndarray:
    """Where every pass was exact: the one pass's own flags, or the passes' AND folded into a copy
    of the first (``np.logical_and.reduce`` of a list first stacks it: an (k, N) copy)."""
    exact = passes[0][1]
    if len(passes) > 1:
        exact = exact.copy()
        for _, ok in passes[1:]:
            np.logical_and(exact, ok, out=exact)
    return exact


def _gpu_finish(out: dict, outs, positions, p) -> None:
    """Turn the GPU's feature record into the requested feature outputs."""
    if set(outs) & set(_features.OUTPUTS):
        feats = out.pop("features", {})        # unpacked by the passes (cellgl.basis.passes)
        _features.finish(out, feats, positions, 1.0, p.dim, outs, p.distribution == Distribution.BLENDER)


def cellular(points, n=4, *, metric="euclidean", distribution="poisson", density=3.0, jitter=1.0,
             min_points=1, max_points=9, minkowski_p=3.0, seed=0, period=None, density_map=None,
             stretch=None, orbit_radius=0.0, orbit_phase=0.0,
             outputs=("F", "delta", "id"), smoothness=0.1, smooth="exp", backend="gpu") -> CellularResult:
    """Worley's cellular basis F1..Fn at arbitrary points.

    Parameters
    ----------
    points : array_like, (N, d) float, d in 2..4
        Sample positions, in cells (feature density is per unit cell).
    n : int, 1..8
        Number of nearest feature points (F1..Fn).
    metric : {"euclidean", "manhattan", "chebyshev", "minkowski"}
    distribution : {"poisson", "jitter", "worley1996"}
        ``poisson``: per-cell count ~ Poisson(``density``) clamped to
        [``min_points``, ``max_points``]; ``jitter``: one point per cell displaced by
        ``jitter`` from the centre; ``worley1996``: the book's reference program (3D),
        bit for bit (positions are scaled by 0.398150 first, distances divided by it).
    density : float in (0, 16]
        Mean points per cell (poisson).
    jitter : float in [0, 1]
    min_points, max_points : int in [0, 16], [1, 16]
    minkowski_p : float in [0.25, 64]
    seed : int in [0, 2**32 - 1]
    period : None, int or sequence of d ints >= 0
        Cells repeat with this period on each axis (0: no wrap): the texture tiles
        over ``period`` units.
    density_map : None or cellgl.DensityMap
        Spatially varying density (``poisson`` only; ``density`` is then unused): each
        cell's count is drawn with the density of the map at the cell centre, quantised to
        16 levels between ``density_min`` and ``density_max`` (see :mod:`cellgl.basis.density`).
    stretch : None, float or sequence of d floats in [1/256, 256]
        Stretched cells: distances are measured with axis ``a`` weighted by ``w_a = g / s_a``
        (``g`` the geometric mean of the ``s_a``, so ``prod w = 1``), so the Voronoi cells are
        ``s_a`` long relative to each other along each axis, with their mean size unchanged.
        F is that weighted distance, exactly (the search's bounds are weighted too); ``delta``
        stays in sample units and ``grad`` is the gradient of the weighted F.
    orbit_radius : float in [0, 0.5]
        Loopable animation: every feature point circles (in x, y) inside its cell with this
        radius in cells, once per loop, from its own phase, in its own direction.
    orbit_phase : float
        Time in loops: ``orbit_phase`` and ``orbit_phase + 1`` give the same bits.
    outputs : sequence of {"F", "delta", "id", "grad", "edge", "edge_grad", "nsphere",
              "position", "color", "smooth_F1", "smooth_position", "smooth_grad", "smooth_color"}
        Only these are computed and read back. ``edge`` (distance to the cell's border) and
        ``nsphere`` need the Euclidean metric; the ``smooth_*`` outputs blend every feature
        point with weight ``exp(-(F_j - F1) / smoothness)`` (see :mod:`cellgl.basis.features`).
    smoothness : float in [0, 0.25] (``smooth="exp"``) or [0, 1] (``"polynomial"``)
        ``k`` of smooth F1, in sample units (0: the hard minimum); for ``"polynomial"`` the
        Smoothness socket of Blender's node (its fold uses k = smoothness / 2).
    smooth : {"exp", "polynomial"}
        ``exp``: the log-sum-exp smooth minimum over every point (exact); ``polynomial``:
        Blender's running polynomial smooth minimum over the 5^d block of cells around the
        sample's, in the node's order (:func:`cellgl.basis.features.poly_smooth`).
    backend : {"gpu", "numpy"}

    Returns
    -------
    CellularResult
        ``F`` float32 (N, n), ``delta`` float32 (N, n, d), ``id`` uint32 (N, n),
        ``grad`` float32 (N, n, d), ``exact`` bool (N,), and the feature outputs asked for.
    """
    pts = _points(points)
    n = _check_n_backend(n, backend)
    outs = _outputs(outputs)
    p = make_params(pts.shape[1], metric=metric, distribution=distribution, density=density,
                    jitter=jitter, min_points=min_points, max_points=max_points,
                    minkowski_p=minkowski_p, seed=seed, period=period, density_map=density_map,
                    stretch=stretch, orbit_radius=orbit_radius, orbit_phase=orbit_phase)
    smoothness = _features.check(outs, p.metric, smoothness, smooth)
    _check_stretch_features(p, outs)
    if p.distribution == Distribution.BLENDER and len(pts):
        warn_blender_far(float(np.abs(pts).max()) * p.scale)   # NaN: no warning, an error below
    if backend == "numpy":
        cells, fr = split(pts * p.scale if p.scale != 1.0 else pts)
        out, exact = _passes.numpy_search(cells, fr, p, n, outs, smoothness, pts, smooth)
        _passes.warn_inexact(exact, p)
    else:
        from cellgl.basis import gpu

        # The coordinates are checked here, before the upload: a GPU comparison cannot catch NaN
        # or infinity where the driver compiles with fast-math semantics (GLSL does not promise
        # that a comparison with NaN is false), so the shader's own range guard (cellular.comp)
        # only keeps its float-to-int conversions defined. Two reductions; scale > 0, so the
        # scaled extremes are the extremes scaled (and NaN stays NaN).
        lo, hi = float(pts.min()) * p.scale, float(pts.max()) * p.scale
        if not (lo > -COORD_LIMIT and hi < COORD_LIMIT):
            _check_coords(pts, pts * p.scale if p.scale != 1.0 else pts)
        out, passes = _passes.gpu_passes(
            lambda o: gpu.search_points(pts, p, n, o, smoothness * p.scale, smooth), outs, len(pts), p, n)
        exact = _all_exact(passes)
        _gpu_finish(out, outs, pts, p)
        if not exact.all():
            def where(rows):
                cells, fr = split(pts[rows] * p.scale if p.scale != 1.0 else pts[rows])
                return cells, fr, pts[rows]
            exact = _passes.fallback(out, passes, where, p, n, outs, smoothness, smooth)
            _passes.warn_inexact(exact, p)
    return _finish(out, exact, (len(pts),), p, n, outs)


def _gpu_outputs(outs, p: reference.Params) -> tuple[str, ...]:
    """What the compute shader is asked for: the basis outputs ``outs`` need, and the feature
    outputs (which become its feature record)."""
    return (_passes.basis_outputs(outs, p.distribution == Distribution.BLENDER)
            + tuple(o for o in outs if o in _features.OUTPUTS))


def cellular_grid(shape, origin=None, spacing=1.0, n=4, *, metric="euclidean", distribution="poisson",
                  density=3.0, jitter=1.0, min_points=1, max_points=9, minkowski_p=3.0, seed=0,
                  period=None, density_map=None, stretch=None, orbit_radius=0.0, orbit_phase=0.0,
                  outputs=("F", "delta", "id"), smoothness=0.1, smooth="exp", backend="gpu") -> CellularResult:
    """The cellular basis on a regular grid, with sample positions generated on the GPU.

    Parameters
    ----------
    shape : tuple of 2..4 ints
        Grid shape in array order, last axis = x: ``(H, W)`` for an image,
        ``(D, H, W)`` for a volume, ``(T, D, H, W)`` in 4D.
    origin : float or sequence of d floats, in (x, y, z, w) order
        Position of sample ``[0, ..., 0]``; default all zeros.
    spacing : float or sequence of d floats > 0, in (x, y, z, w) order
        Distance between neighbouring samples along each axis.
    n, metric, distribution, ... : as :func:`cellular`.

    Returns
    -------
    CellularResult
        Arrays shaped ``shape + (n,)`` (F, id) and ``shape + (n, d)`` (delta, grad).
        Sample ``[..., i, j]`` lies at ``origin + spacing * (j, i, ...)`` (computed in float64 on
    the GPU, then split into cell and fraction: exact however far from ``origin``).
    """
    shape_in = shape
    try:
        shape = tuple(operator.index(s) if not isinstance(s, (bool, np.bool_)) else None for s in shape)
    except TypeError:
        shape = None
    if shape is None or None in shape:
        raise ValueError(f"shape must be a tuple of 2..4 positive ints (whole numbers, not floats), "
                         f"got {shape_in!r}")
    dim = len(shape)
    if dim not in (2, 3, 4) or any(s < 1 for s in shape):
        raise ValueError(f"shape must be a tuple of 2..4 positive ints, got {shape!r}")
    total = math.prod(shape)
    if total > 2 ** 31 - 1:
        raise ValueError(f"grid has {total} samples; at most 2^31 - 1 per call (bake in tiles)")
    n = _check_n_backend(n, backend)
    outs = _outputs(outputs)
    p = make_params(dim, metric=metric, distribution=distribution, density=density, jitter=jitter,
                    min_points=min_points, max_points=max_points, minkowski_p=minkowski_p,
                    seed=seed, period=period, density_map=density_map, stretch=stretch,
                    orbit_radius=orbit_radius, orbit_phase=orbit_phase)
    smoothness = _features.check(outs, p.metric, smoothness, smooth)
    _check_stretch_features(p, outs)

    def vec(name, v, default):
        v = default if v is None else v
        arr = real_array(name, v, f"(a number or {dim} numbers x, y, ...)")
        arr = np.broadcast_to(arr, (dim,)) if arr.ndim == 0 else arr
        if arr.shape != (dim,):
            raise ValueError(f"{name} must be a number or {dim} numbers (x, y, ...), got {v!r}")
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{name} must be finite, got {v!r}")
        return arr.astype(np.float64)

    org = vec("origin", origin, 0.0) * p.scale
    spc = vec("spacing", spacing, 1.0)
    if np.any(spc <= 0):
        raise ValueError(f"spacing must be > 0 on every axis, got {spacing!r}")
    spc = spc * p.scale
    shape_xyzw = list(reversed(shape)) + [1] * (4 - dim)
    far = org + spc * (np.array(shape_xyzw[:dim]) - 1)
    if np.any(np.abs(far) >= COORD_LIMIT) or np.any(np.abs(org) >= COORD_LIMIT):
        raise ValueError("grid extends beyond +-2^30 cells; move origin closer to 0")
    if p.distribution == Distribution.BLENDER:
        warn_blender_far(float(max(np.abs(far).max(), np.abs(org).max())))
    positions = None
    if backend == "numpy" or {"position", "smooth_position"} & set(outs) \
            or ("color" in outs and p.distribution == Distribution.BLENDER):
        axes = [org[a] + spc[a] * np.arange(shape_xyzw[a]) for a in range(dim)]
        mesh = np.meshgrid(*reversed(axes), indexing="ij")        # array order
        pts = np.stack(list(reversed(mesh)), axis=-1).reshape(-1, dim)
        positions = pts / p.scale if p.scale != 1.0 else pts
    if backend == "numpy":
        cells, fr = split(pts)
        out, exact = _passes.numpy_search(cells, fr, p, n, outs, smoothness, positions, smooth)
        _passes.warn_inexact(exact, p)
    else:
        from cellgl.basis import gpu

        ocell = np.zeros(4, dtype=np.int64)
        ofrac = np.zeros(4)
        ocell[:dim] = np.floor(org)
        ofrac[:dim] = org - np.floor(org)
        sp4 = np.zeros(4)
        sp4[:dim] = spc
        out, passes = _passes.gpu_passes(
            lambda o: gpu.search_grid(shape_xyzw, ocell, ofrac, sp4, p, n, o, smoothness * p.scale, smooth),
            outs, total, p, n)
        _gpu_finish(out, outs, positions, p)
        exact = _all_exact(passes)
        if not exact.all():
            def where(rows):
                # sample index -> position, as the shader computes it (cellular.comp, CELL_GRID)
                idx = np.stack(np.unravel_index(rows, shape_xyzw[::-1])[::-1], axis=1).astype(np.float64)
                pos = ofrac[:dim] + sp4[:dim] * idx[:, :dim]
                fl = np.floor(pos)
                cells = np.zeros((len(rows), 4), dtype=np.int64)
                cells[:, :dim] = ocell[:dim] + fl.astype(np.int64)
                fr = np.zeros((len(rows), 4))
                fr[:, :dim] = pos - fl
                return cells, fr, None if positions is None else positions[rows]
            exact = _passes.fallback(out, passes, where, p, n, outs, smoothness, smooth)
            _passes.warn_inexact(exact, p)
    return _finish(out, exact, shape, p, n, outs)


def feature_points(cells, *, distribution="poisson", density=3.0, jitter=1.0, min_points=1,
                   max_points=9, seed=0, period=None, density_map=None, stretch=None,
                   orbit_radius=0.0, orbit_phase=0.0) -> FeaturePoints:
    """Every feature point in the given integer cells.

    Parameters
    ----------
    cells : array_like, (M, d) int, d in 2..4
        Integer cells (for ``worley1996``, cubes of the scaled lattice: side
        1/0.398150 in sample units).
    distribution, density, jitter, min_points, max_points, seed, period, density_map, stretch,
    orbit_radius, orbit_phase :
        as :func:`cellular` (``stretch`` changes distances, not positions).

    Returns
    -------
    FeaturePoints
        ``positions`` float64 (K, d) in sample units, ``ids`` uint32 (K,),
        ``cell_index`` int64 (K,).
    """
    refuse_masked("cells", cells)
    raw = np.asarray(cells) if not isinstance(cells, np.ndarray) else cells
    if raw.dtype.kind in "iu":
        arr = raw                   # compared as integers below (uint64 2^63 must not wrap)
    else:
        arr = real_array("cells", cells, "of integers, shape (M, d), d in 2..4")
    if arr.ndim != 2 or arr.shape[1] not in (2, 3, 4):
        raise ValueError(f"cells must have shape (M, d) with d in 2..4, got shape {arr.shape}")
    if arr.shape[0] == 0:
        raise ValueError("cells is empty (shape (0, d)); pass at least one cell")
    if arr.dtype.kind == "f" and (not np.all(np.isfinite(arr)) or not np.all(arr == np.floor(arr))):
        i, j = np.argwhere(~np.isfinite(arr) | (arr != np.floor(arr)))[0]
        raise ValueError(f"cells must hold integers; cells[{i}, {j}] is {arr[i, j]!r}")
    # range check in the input's own type (a cast first would wrap 2^63 or overflow abs(int64 min))
    out_of_range = (arr >= COORD_LIMIT) | (arr <= -COORD_LIMIT)
    if out_of_range.any():
        i, j = np.argwhere(out_of_range)[0]
        raise ValueError(f"cells must lie within +-2^30 (exclusive); cells[{i}, {j}] is {arr[i, j]!r}")
    arr = arr.astype(np.int64)
    p = make_params(arr.shape[1], distribution=distribution, density=density, jitter=jitter,
                    min_points=min_points, max_points=max_points, seed=seed, period=period,
                    density_map=density_map, stretch=stretch, orbit_radius=orbit_radius,
                    orbit_phase=orbit_phase)
    pos, ids, which = reference.feature_points(arr, p)
    return FeaturePoints(positions=pos / p.scale, ids=ids, cell_index=which)
