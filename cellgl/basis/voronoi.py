"""Blender's Voronoi Texture node, socket for socket, over the exact cellular basis.

:func:`voronoi` takes the node's sockets and modes with the node's names and defaults and
returns its outputs (Distance, Color, Position, W, Radius). Each octave is one call of
:func:`cellgl.basis.core.cellular` (the exact search and feature walks, on the GPU or in NumPy);
this module only assembles the octaves as the node does:

* fractal Detail / Roughness / Lacunarity: octave ``i`` samples ``coord * lacunarity^i`` with
  amplitude ``roughness^i``; distances and colours are summed with the amplitudes, positions
  blended towards each octave's with its amplitude; a fractional detail blends the last octave
  in by its fraction; Detail, Roughness or Lacunarity 0 is the plain first octave.
* Normalize: the sum divided by the summed amplitudes times the node's largest distance of an
  octave (``(0.5 + 0.5 randomness)`` along every axis, measured with the metric; twice that for
  F2). Distance to edge keeps a running minimum over octaves (each divided by its scale) and
  normalizes by its own blended ``(0.5 + 0.5 randomness) / scale``.

Where the node's fixed 3^d window misses the true nearest point (or the true nearest bisector),
this returns the exact answer; ``distribution="blender"`` otherwise reproduces the node's points
and colours. Smooth F1 uses the node's own polynomial fold (``smooth="polynomial"`` of the
basis), which is defined over the node's 5^d window.
"""
from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import numpy as np

from cellgl.basis import core
from cellgl.basis.arrays import real_array
from cellgl.basis.enums import Distribution, Metric, parse_enum
from cellgl.basis.reference import minkowski_floor, minkowski_message
from cellgl.basis.population import blender_color, blender_owner_cells, warn_blender_far

__all__ = ["VoronoiResult", "voronoi", "FEATURES"]

#: the node's Feature modes, in cellgl's spelling
FEATURES = ("F1", "F2", "smooth_F1", "distance_to_edge", "n_sphere_radius")
DETAIL_MAX = 15.0              #: the node clamps Detail to [0, 15]
LACUNARITY_MAX = 1000.0        #: the node's Lacunarity soft range
#: accepted range of each float socket (the command line's help shows these)
RANGES = {"exponent": (0.25, 64.0), "scale": (0.0, 1e6), "detail": (0.0, DETAIL_MAX),
          "roughness": (0.0, 1.0), "lacunarity": (0.0, LACUNARITY_MAX), "randomness": (0.0, 1.0),
          "smoothness": (0.0, 1.0)}


@dataclass
class VoronoiResult:
    """The node's outputs (``None`` where the feature has none), N samples, d dimensions.

    distance : float32 (N,) -- Distance (F1, F2, smooth F1, distance to edge)
    color : float32 (N, 3) -- Color (F1, F2, smooth F1)
    position : float32 (N, min(d, 3)) -- Position (2D..4D; F1, F2, smooth F1)
    w : float32 (N,) -- W (1D and 4D; F1, F2, smooth F1)
    radius : float32 (N,) -- Radius (n-sphere radius)
    exact : bool (N,) -- False where a search reached its cap (never in practice)
    """

    distance: np.ndarray | None
    color: np.ndarray | None
    position: np.ndarray | None
    w: np.ndarray | None
    radius: np.ndarray | None
    exact: np.ndarray


def _real(name, value, lo, hi):
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value) \
            or not lo <= value <= hi:
        raise ValueError(f"{name} must be a number in [{lo}, {hi}], got {value!r}")
    return float(value)


def _coords(points, dimensions, w) -> np.ndarray:
    """The (N, dimensions) float64 coordinates: 2D takes x, y of (N, 2) or (N, 3) points; 4D
    takes w from a fourth column or from ``w``; 1D takes (N,) or (N, 1) values, or ``w``."""
    if dimensions == 1 and points is None:
        return real_array("w", w, "of shape (N,)").reshape(-1, 1).astype(np.float64)
    pts = real_array("points", points, f"of shape (N, d) for dimensions={dimensions}")
    if dimensions == 1 and pts.ndim == 1:
        pts = pts[:, None]
    if pts.ndim != 2 or len(pts) == 0:
        raise ValueError(f"points must have shape (N, d) with N >= 1, got shape {pts.shape}")
    cols = pts.shape[1]
    ok = {1: (1,), 2: (2, 3), 3: (3,), 4: (3, 4)}[dimensions]
    if cols not in ok:
        raise ValueError(f"points must have {' or '.join(map(str, ok))} columns for dimensions="
                         f"{dimensions}, got shape {pts.shape}")
    pts = pts[:, :dimensions].astype(np.float64)
    if dimensions == 4 and cols == 3:
        wv = real_array("w", w, f"a number or of shape ({len(pts)},), one per point")
        if wv.ndim > 1 or wv.size not in (1, len(pts)):
            raise ValueError(f"w must be a number or have shape ({len(pts)},), one per point; got "
                             f"shape {wv.shape}")
        if not np.isfinite(wv).all():
            raise ValueError(f"w must be finite; w[{int(np.argmax(~np.isfinite(wv.ravel())))}] is "
                             f"{wv.ravel()[~np.isfinite(wv.ravel())][0]}")
        wv = np.broadcast_to(wv.reshape(-1), (len(pts),))
        pts = np.concatenate([pts, wv[:, None]], axis=1)
    return pts


#: keywords of cellular() that voronoi() sets from its own sockets
_OWN = {"points", "n", "outputs", "smoothness", "smooth", "backend", "metric", "distribution",
        "jitter", "minkowski_p"}


def _check_basis(basis: dict) -> None:
    import inspect

    accepted = [k for k in inspect.signature(core.cellular).parameters if k not in _OWN]
    for k in basis:
        if k not in accepted:
            raise TypeError(f"voronoi() got an unexpected keyword argument {k!r}; accepted besides "
                            f"the node's sockets: {', '.join(accepted)}")


def _check_reach(coord: np.ndarray, octaves: int, lacunarity: float, detail: float) -> None:
    """The last octave samples coord * lacunarity^(octaves - 1): it must stay within +-2^30 cells."""
    if octaves <= 1 or lacunarity <= 1.0 or not len(coord):
        return
    top = float(np.max(np.abs(coord))) * lacunarity ** (octaves - 1)
    if top >= core.COORD_LIMIT:
        raise ValueError(f"detail {detail:g} x lacunarity {lacunarity:g}: the last octave samples "
                         f"|coordinate| x scale x lacunarity^{octaves - 1} = {top:.4g} cells, beyond "
                         f"the +-2^30 accepted; lower detail, lacunarity or scale")


def _check_coords(coord: np.ndarray, scale: float, what: str) -> None:
    """The node's Vector (W in 1D) times Scale must be finite and within +-2^30 cells, the range
    :func:`cellgl.basis.core.cellular` takes (checked here for every dimension, 1D too)."""
    if not len(coord) or (coord.min() > -core.COORD_LIMIT and coord.max() < core.COORD_LIMIT):
        return
    bad = ~np.isfinite(coord)
    if bad.any():
        i, j = (int(x) for x in np.argwhere(bad)[0])
        raise ValueError(f"{what} must be finite; {what}[{i}, {j}] times scale {scale:g} is {coord[i, j]}")
    i, j = (int(x) for x in np.argwhere(np.abs(coord) >= core.COORD_LIMIT)[0])
    raw = coord[i, j] / scale
    raise ValueError(f"{what}[{i}, {j}] = {raw!r} times scale {scale:g} is {coord[i, j]:.6g} cells; accepted: "
                     f"within +-2^30 cells, so |{what}| < {core.COORD_LIMIT / scale:.6g} at this scale")


def _max_distance(metric: Metric, exponent: float, dim: int, randomness: float) -> float:
    """The node's distance from the origin to (0.5 + 0.5 randomness) on every axis."""
    a = 0.5 + 0.5 * randomness
    if dim == 1 or metric == Metric.CHEBYSHEV:
        return a
    if metric == Metric.EUCLIDEAN:
        return math.sqrt(dim) * a
    if metric == Metric.MANHATTAN:
        return dim * a
    return (dim * a ** exponent) ** (1.0 / exponent)


def _octave(coord, dim, feature, kw, backend, smoothness):
    """One octave at lattice coordinates ``coord`` (N, dim): (distance, colour, position in
    lattice units, exact)."""
    outs = {"F1": ("F", "delta", "id"), "F2": ("F", "delta", "id"),
            "smooth_F1": ("smooth_F1", "smooth_position", "smooth_color")}[feature]
    n = 2 if feature == "F2" else 1
    if dim == 1:
        return _octave_1d(coord, feature, kw, smoothness)
    r = core.cellular(coord, n=n, outputs=outs, smoothness=smoothness, smooth="polynomial",
                      backend=backend, **kw)
    if feature == "smooth_F1":
        assert r.smooth_F1 is not None and r.smooth_color is not None    # requested in outs
        return (r.smooth_F1.astype(np.float64), r.smooth_color.astype(np.float64),
                r.smooth_position, r.exact)
    assert r.F is not None and r.delta is not None and r.id is not None  # requested in outs
    k = n - 1
    pos = coord + r.delta[:, k].astype(np.float64)
    if kw["distribution"] == Distribution.BLENDER:
        col = blender_color(blender_owner_cells(pos, r.id[:, k], dim), dim).astype(np.float64)
    else:
        from cellgl.basis.features import id_color

        col = id_color(r.id[:, k])
    return r.F[:, k].astype(np.float64), col, pos, r.exact


def _points_1d(cells, randomness):
    from cellgl.basis.population import blender_point

    return cells + blender_point(cells[:, None], 1)[:, 0].astype(np.float64) * np.float32(randomness)


def _octave_1d(coord, feature, kw, smoothness):
    """1D (Blender's points only): every point within reach is in the 7 cells around the
    sample's (one point per cell, in [c, c + 1])."""
    x = coord[:, 0]
    warn_blender_far(float(np.abs(x).max()), stacklevel=4)
    c0 = np.floor(x).astype(np.int64)
    offs = np.arange(-3, 4)
    cells = c0[:, None] + offs[None, :]
    q = _points_1d(cells.ravel(), kw["jitter"]).reshape(cells.shape)
    d = np.abs(q - x[:, None])
    if feature == "smooth_F1":
        k = 0.5 * smoothness
        s = np.full(len(x), 8.0)
        pos = np.zeros(len(x))
        col = np.zeros((len(x), 3))
        for j in range(1, 6):                     # the node's window: offsets -2..2
            dj = d[:, j]
            if k > 0:
                t = np.clip(0.5 + 0.5 * (s - dj) / k, 0.0, 1.0)
                h = t * t * (3.0 - 2.0 * t)
            else:
                h = (dj < s).astype(np.float64)
            c = k * h * (1.0 - h)
            s = s + h * (dj - s) - c
            c1 = c / (1.0 + 3.0 * k)
            col = col + h[:, None] * (blender_color(cells[:, j:j + 1], 1) - col) - c1[:, None]
            pos = pos + h * (q[:, j] - pos) - c1
        return s, col, pos[:, None], np.ones(len(x), bool)
    order = np.argsort(d, axis=1, kind="stable")
    k = 1 if feature == "F2" else 0
    pick = order[:, k]
    rows = np.arange(len(x))
    cell = cells[rows, pick]
    return d[rows, pick], blender_color(cell[:, None], 1).astype(np.float64), \
        q[rows, pick][:, None], np.ones(len(x), bool)


def _edge_1d(coord, randomness):
    x = coord[:, 0]
    warn_blender_far(float(np.abs(x).max()), stacklevel=4)
    c0 = np.floor(x).astype(np.int64)
    cells = c0[:, None] + np.arange(-3, 4)[None, :]
    q = _points_1d(cells.ravel(), randomness).reshape(cells.shape)
    i1 = np.argmin(np.abs(q - x[:, None]), axis=1)
    rows = np.arange(len(x))
    p1 = q[rows, i1]
    left, right = q[rows, i1 - 1], q[rows, i1 + 1]
    return np.minimum(np.abs(0.5 * (p1 + left) - x), np.abs(0.5 * (p1 + right) - x)), \
        np.minimum(p1 - left, right - p1) * 0.5


def voronoi(points, dimensions=3, feature="F1", metric="euclidean", exponent=0.5, scale=5.0,
            detail=0.0, roughness=0.5, lacunarity=2.0, normalize=False, randomness=1.0,
            smoothness=1.0, w=0.0, distribution="blender", *, backend="gpu", allow_inexact=False,
            **basis) -> VoronoiResult:
    """Blender's Voronoi Texture node at arbitrary points, exact.

    Parameters
    ----------
    points : array_like, float
        (N, 2) or (N, 3) for ``dimensions=2`` (z ignored, as the node); (N, 3) for 3; (N, 4),
        or (N, 3) with ``w``, for 4; (N,) or (N, 1) for 1 (the node's W; or pass
        ``points=None`` and the values as ``w``). The node's Vector input, before Scale.
    dimensions : {1, 2, 3, 4}
    feature : {"F1", "F2", "smooth_F1", "distance_to_edge", "n_sphere_radius"}
    metric : {"euclidean", "manhattan", "chebyshev", "minkowski"}
        The node's Distance Metric (distance to edge and n-sphere radius are Euclidean, as in
        the node).
    exponent : float in [0.25, 64]
        Minkowski exponent.
    scale : float in [0, 1e6]
    detail : float in [0, 15]
    roughness : float in [0, 1]
    lacunarity : float in [0, 1000]
    normalize : bool
    randomness : float in [0, 1]
    smoothness : float in [0, 1]
        Smooth F1 only.
    w : float or array (N,)
        The W input (1D, 4D with 3-column points).
    distribution : {"blender", "poisson", "jitter", "worley1996"}
        ``blender``: the node's own points (one per cell from its hash, ``randomness`` the
        spread from the cell's lower corner) and colours; cellgl's distributions take
        ``randomness`` as their ``jitter`` and further basis keywords (``density``, ``seed``,
        ...) in ``**basis``; their colour is :func:`cellgl.basis.features.id_color`.
    backend : {"gpu", "numpy"}
        1D runs in NumPy on either.
    allow_inexact : bool
        F1, F2 and smooth F1 with the Minkowski metric need ``exponent`` >= ln(d) / ln(R) (R the rings the
        search visits: 0.443 in 3D, 0.713 in 4D; :func:`cellgl.basis.reference.minkowski_floor`)
        to be exact; below it ValueError, unless this is True: then the samples the search
        cannot settle are the nearest point within the cap, flagged False in ``exact``, with a
        RuntimeWarning.

    Returns
    -------
    VoronoiResult
        ``distance``, ``color``, ``position``, ``w``, ``radius`` as the node's sockets (float32),
        ``None`` where the feature has no such output.
    """
    if dimensions not in (1, 2, 3, 4) or isinstance(dimensions, bool):
        raise ValueError(f"dimensions must be 1, 2, 3 or 4, got {dimensions!r}")
    if feature not in FEATURES:
        raise ValueError(f"unknown feature {feature!r}; expected one of: {', '.join(FEATURES)}")
    metric = parse_enum(Metric, metric, "metric")
    dist = parse_enum(Distribution, distribution, "distribution")
    if dimensions == 1 and dist != Distribution.BLENDER:
        raise ValueError(f"dimensions=1 needs distribution 'blender', got {dist.name.lower()!r}")
    exponent = _real("exponent", exponent, *RANGES["exponent"])
    scale = _real("scale", scale, *RANGES["scale"])
    detail = _real("detail", detail, *RANGES["detail"])
    roughness = _real("roughness", roughness, *RANGES["roughness"])
    lacunarity = _real("lacunarity", lacunarity, *RANGES["lacunarity"])
    randomness = _real("randomness", randomness, *RANGES["randomness"])
    smoothness = _real("smoothness", smoothness, *RANGES["smoothness"])
    if not isinstance(allow_inexact, (bool, np.bool_)):
        raise ValueError(f"allow_inexact must be True or False, got {allow_inexact!r}")
    if (metric == Metric.MINKOWSKI and feature in ("F1", "F2", "smooth_F1") and dimensions > 1 and not allow_inexact
            and exponent < minkowski_floor(dimensions)):
        raise ValueError(minkowski_message("exponent", exponent, dimensions, "dimensions")
                         + "; or pass allow_inexact=True for the nearest point within that cap, flagged "
                           "False in .exact")
    if not isinstance(normalize, (bool, np.bool_)):
        raise ValueError(f"normalize must be True or False, got {normalize!r}")
    if backend not in core.BACKENDS:
        raise ValueError(f"unknown backend {backend!r}; expected one of: {', '.join(core.BACKENDS)}")
    _check_basis(basis)
    coord = _coords(points, dimensions, w) * scale
    _check_coords(coord, scale, "w" if points is None else "points")
    N = len(coord)
    euclid = feature in ("distance_to_edge", "n_sphere_radius")
    kw = dict(distribution=dist, jitter=randomness, metric=Metric.EUCLIDEAN if euclid else metric,
              minkowski_p=exponent, **basis)
    f32 = np.float32
    out: dict[str, np.ndarray | None] = dict(distance=None, color=None, position=None, w=None, radius=None)

    if feature == "n_sphere_radius":              # no fractal in the node
        if dimensions == 1:
            radius, exact = _edge_1d(coord, randomness)[1], np.ones(N, bool)
        else:
            r = core.cellular(coord, n=1, outputs=("nsphere",), backend=backend, **kw)
            radius, exact = r.nsphere, r.exact
        out["radius"] = np.asarray(radius, f32)
        return VoronoiResult(exact=np.asarray(exact), **out)

    zero = detail == 0.0 or roughness == 0.0 or lacunarity == 0.0
    octaves = 1 if zero else int(math.ceil(detail)) + 1
    rmd = detail - math.floor(detail)
    _check_reach(coord, octaves, lacunarity, detail)
    amp, sc = 1.0, 1.0
    exact = np.ones(N, bool)

    if feature == "distance_to_edge":
        a0 = 0.5 + 0.5 * randomness
        max_amp, dist_v = a0, np.full(N, 8.0)
        for i in range(octaves):
            c = coord * sc
            if dimensions == 1:
                e = _edge_1d(c, randomness)[0]
            else:
                r = core.cellular(c, n=1, outputs=("edge",), backend=backend, **kw)
                assert r.edge is not None                   # requested in outputs
                e, exact = r.edge.astype(np.float64), exact & r.exact
            if zero:
                dist_v, max_amp = e, 1.0
                break
            if i <= detail:
                max_amp = max_amp + amp * (a0 / sc - max_amp)
                dist_v = dist_v + amp * (np.minimum(dist_v, e / sc) - dist_v)
                sc *= lacunarity
                amp *= roughness
            elif rmd != 0.0:
                lerp_amp = max_amp + amp * (a0 / sc - max_amp)
                max_amp = max_amp + rmd * (lerp_amp - max_amp)
                lerp_d = dist_v + amp * (np.minimum(dist_v, e / sc) - dist_v)
                dist_v = dist_v + rmd * (np.minimum(dist_v, lerp_d) - dist_v)
        if normalize:
            dist_v = dist_v / max_amp
        out["distance"] = dist_v.astype(f32)
        return VoronoiResult(exact=exact, **out)

    max_amp = 0.0
    dist_v, col, pos = np.zeros(N), np.zeros((N, 3)), np.zeros((N, dimensions))
    for i in range(octaves):
        d, c, p, ex = _octave(coord * sc, dimensions, feature, kw, backend, smoothness)
        exact &= np.asarray(ex)
        if zero:
            max_amp, dist_v, col, pos = 1.0, d, c, p
            break
        if i <= detail:
            max_amp += amp
            dist_v = dist_v + d * amp
            col = col + c * amp
            pos = pos + amp * (p / sc - pos)
            sc *= lacunarity
            amp *= roughness
        elif rmd != 0.0:
            max_amp = max_amp + rmd * amp
            dist_v = dist_v + rmd * d * amp
            col = col + rmd * c * amp
            pos = pos + rmd * amp * (p / sc - pos)
    if normalize:
        dist_v = dist_v / (max_amp * _max_distance(metric, exponent, dimensions, randomness)
                           * (2.0 if feature == "F2" else 1.0))
        col = col / max_amp
    pos = pos / scale if scale != 0.0 else np.zeros_like(pos)
    out["distance"] = dist_v.astype(f32)
    out["color"] = col.astype(f32)
    if dimensions >= 2:
        out["position"] = pos[:, : min(dimensions, 3)].astype(f32)
    if dimensions in (1, 4):
        out["w"] = pos[:, -1].astype(f32)
    return VoronoiResult(exact=exact, **out)
