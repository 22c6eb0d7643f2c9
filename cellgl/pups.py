"""PUPs texture synthesis on the GPU.

After *Partition of unity parametrics for texture synthesis*: values stored at scattered 2D
control points are interpolated with partition-of-unity weights built on a Delaunay graph.

Pipeline
--------
1. Control points (:class:`PupsPoints`): positions, a value (scalar or RGB), an integer label
   and an orientation (a unit vector in R^3; only its xy part shifts weights). Generators:
   :func:`poisson_disk`, :func:`poisson_disk_variable`, :func:`space_giraffe`,
   :func:`cluster_labels`, :func:`labels_from_image`, :func:`labels_by_ramp`,
   :func:`random_orientations`.
2. Graph (:func:`pups_graph`): Delaunay triangulation (``scipy.spatial``); each point's axes are
   its edges. Periodic point sets are triangulated with their 8 copies around the domain, so
   the graph, and therefore the texture, wraps seamlessly.
3. Support: the weight of a point vanishes beyond the end of any axis, so its support is the
   convex polygon ``{u : (u - c).a <= f |a|^2}`` for its axes ``a`` (``f`` = axis-length
   factor). Its bounding box is computed exactly (feet of the axes and the corners between
   consecutive axes). Note that the corners may lie further than ``f`` times the longest
   axis, so a disc of that radius is *not* a safe bound.
4. Evaluation (:func:`pups_evaluate`): the points (and the periodic copies whose support
   reaches the domain) go to the GPU with their axes (CSR) and a uniform grid of candidate
   lists (a point is listed in every grid cell its support box touches). The compute shader
   ``shaders/pups.comp`` evaluates ``shaders/lib/pups.glsl``; ``backend="numpy"`` runs the
   float64 twin in :mod:`cellgl.pups_reference`.

The domain defaults to ``[-1, 1]^2`` as in the paper; pixel ``(i, j)`` (row ``j`` from the top)
samples ``x = x0 + (i + 0.5) (x1 - x0) / width``, ``y = y0 + (j + 0.5) (y1 - y0) / height``.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from enum import IntEnum
from pathlib import Path

import numpy as np
from scipy.spatial import Delaunay, cKDTree

from .gl_call import gl_call
from .pups_reference import evaluate_reference

__all__ = [
    "PupsMode",
    "PupsPoints",
    "PupsGraph",
    "PupsPacked",
    "DEFAULT_DOMAIN",
    "pups_points",
    "poisson_disk",
    "poisson_disk_variable",
    "space_giraffe",
    "cluster_labels",
    "labels_from_image",
    "labels_by_ramp",
    "random_orientations",
    "pups_graph",
    "pups_pack",
    "pups_evaluate",
    "pups_render",
    "pups_presets",
]

DEFAULT_DOMAIN = (-1.0, -1.0, 1.0, 1.0)


class PupsMode(IntEnum):
    """What a PUPs evaluation writes per pixel (the value of ``CELL_PUPS_MODE`` in the shader)."""

    INTERPOLATE = 0  #: weighted mean of values, eq. (3)
    LABEL = 1  #: value and label of the heaviest point
    WEIGHTED_SUM = 2  #: sum of value * weight, not normalised (shows raw weights)


# --------------------------------------------------------------------------------------------
# validation helpers
# --------------------------------------------------------------------------------------------


def _check_domain(domain):
    try:
        x0, y0, x1, y1 = (float(v) for v in domain)
    except (TypeError, ValueError):
        raise ValueError(f"domain must be (x0, y0, x1, y1), got {domain!r}") from None
    if not (np.isfinite([x0, y0, x1, y1]).all() and x1 > x0 and y1 > y0):
        raise ValueError(f"domain must be finite with x1 > x0 and y1 > y0, got {domain!r}")
    return (x0, y0, x1, y1)


def _check_size(width, height):
    for name, v in (("width", width), ("height", height)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
            raise ValueError(f"{name} must be an integer in [1, 16384], got {v!r}")
        if not 1 <= int(v) <= 16384:
            raise ValueError(f"{name} must be in [1, 16384], got {v}")
    return int(width), int(height)


def _check_positive(name, v, upper=None):
    try:
        f = float(v)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number > 0, got {v!r}") from None
    if not math.isfinite(f) or f <= 0 or (upper is not None and f > upper):
        rng = f"(0, {upper}]" if upper is not None else "> 0"
        raise ValueError(f"{name} must be {rng}, got {v!r}")
    return f


def _check_epsilon(epsilon):
    try:
        e = float(epsilon)
    except (TypeError, ValueError):
        raise ValueError(f"epsilon must be in [0, 1), got {epsilon!r}") from None
    if not 0.0 <= e < 1.0:
        raise ValueError(f"epsilon must be in [0, 1), got {epsilon!r}")
    return e


def _rng(seed):
    if isinstance(seed, np.random.Generator):
        return seed
    return np.random.default_rng(seed)


# --------------------------------------------------------------------------------------------
# control points
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class PupsPoints:
    """A set of PUPs control points.

    Attributes
    ----------
    positions : numpy.ndarray of float64, shape (N, 2)
        Inside ``domain`` (wrapped into it when ``periodic``).
    values : numpy.ndarray of float64, shape (N, C)
        C = 1 (intensity) or 3 (RGB).
    labels : numpy.ndarray of int32, shape (N,)
        Group label, >= 0.
    orientations : numpy.ndarray of float64, shape (N, 3)
        Unit vectors (or zero: no shift); the xy part shifts the weight (eq. 4).
    domain : tuple of 4 float
        ``(x0, y0, x1, y1)``.
    periodic : bool
        Whether the set tiles the plane with period ``(x1 - x0, y1 - y0)``.
    """

    positions: np.ndarray
    values: np.ndarray
    labels: np.ndarray
    orientations: np.ndarray
    domain: tuple = DEFAULT_DOMAIN
    periodic: bool = True

    def __len__(self):
        return self.positions.shape[0]

    @property
    def channels(self) -> int:
        """Number of value channels (1 or 3)."""
        return self.values.shape[1]

    def replace(self, **changes) -> "PupsPoints":
        """Return a validated copy with some fields replaced (as :func:`pups_points`)."""
        kw = dict(positions=self.positions, values=self.values, labels=self.labels,
                  orientations=self.orientations, domain=self.domain, periodic=self.periodic)
        kw.update(changes)
        return pups_points(**kw)


def pups_points(positions, values=None, labels=None, orientations=None, *,
                domain=DEFAULT_DOMAIN, periodic=True) -> PupsPoints:
    """Validate and bundle control points.

    Parameters
    ----------
    positions : array_like, shape (N, 2)
        Point positions, N >= 3.
    values : array_like, shape (N,) or (N, 3), optional
        Intensities or RGB colours; default 0.
    labels : array_like of int, shape (N,), optional
        Labels >= 0; default ``arange(N)`` (one label per point).
    orientations : array_like, shape (N, 2) or (N, 3), optional
        Orientation vectors of norm <= 1 (a 2-vector is the xy part of a unit 3-vector);
        default zero (no shift).
    domain : tuple of 4 float
        ``(x0, y0, x1, y1)``, default ``[-1, 1]^2``.
    periodic : bool
        Treat the set as one tile of a periodic set; positions are wrapped into the domain.

    Returns
    -------
    PupsPoints

    Raises
    ------
    ValueError
        On a wrong shape, non-finite values, negative labels, an orientation longer than 1,
        or (non-periodic) positions outside the domain.
    """
    domain = _check_domain(domain)
    pos = np.array(positions, dtype=np.float64)
    if pos.ndim != 2 or pos.shape[1] != 2:
        raise ValueError(f"positions must have shape (N, 2), got {pos.shape}")
    n = pos.shape[0]
    if n < 3:
        raise ValueError(f"need at least 3 control points, got {n}")
    if not np.isfinite(pos).all():
        raise ValueError("positions must be finite")
    x0, y0, x1, y1 = domain
    if periodic:
        pos[:, 0] = x0 + np.mod(pos[:, 0] - x0, x1 - x0)
        pos[:, 1] = y0 + np.mod(pos[:, 1] - y0, y1 - y0)
        pos[:, 0] = np.where(pos[:, 0] >= x1, x0, pos[:, 0])
        pos[:, 1] = np.where(pos[:, 1] >= y1, y0, pos[:, 1])
    elif (pos[:, 0] < x0).any() or (pos[:, 0] > x1).any() or (pos[:, 1] < y0).any() \
            or (pos[:, 1] > y1).any():
        raise ValueError(f"positions must lie in the domain {domain} when not periodic")
    if values is None:
        vals = np.zeros((n, 1))
    else:
        vals = np.array(values, dtype=np.float64)
        if vals.ndim == 1:
            vals = vals[:, None]
        if vals.shape not in ((n, 1), (n, 3)):
            raise ValueError(f"values must have shape ({n},) or ({n}, 3), got {vals.shape}")
        if not np.isfinite(vals).all():
            raise ValueError("values must be finite")
    if labels is None:
        labs = np.arange(n, dtype=np.int32)
    else:
        labs = np.asarray(labels)
        if labs.shape != (n,):
            raise ValueError(f"labels must have shape ({n},), got {labs.shape}")
        if not np.issubdtype(labs.dtype, np.integer):
            raise ValueError(f"labels must be integers, got dtype {labs.dtype}")
        if n and (labs.min() < 0 or labs.max() > 2**31 - 1):
            raise ValueError(f"labels must be in [0, 2^31 - 1], got range "
                             f"[{labs.min()}, {labs.max()}]")
        labs = labs.astype(np.int32)
    if orientations is None:
        ori = np.zeros((n, 3))
    else:
        ori = np.array(orientations, dtype=np.float64)
        if ori.shape == (n, 2):
            ori = np.concatenate([ori, np.sqrt(np.clip(1 - (ori ** 2).sum(1), 0, None))[:, None]],
                                 axis=1)
        if ori.shape != (n, 3):
            raise ValueError(f"orientations must have shape ({n}, 2) or ({n}, 3), got {ori.shape}")
        norm = np.hypot(ori[:, 0], ori[:, 1])
        if not np.isfinite(ori).all() or (norm > 1 + 1e-9).any():
            raise ValueError(f"orientation xy parts must have norm in [0, 1], got max "
                             f"{norm.max():.6g}")
    return PupsPoints(pos, vals, labs, ori, domain, bool(periodic))


# --------------------------------------------------------------------------------------------
# generators
# --------------------------------------------------------------------------------------------


def _sample_map(density, xy, domain):
    """Nearest sample of a (H, W) map over the domain (row 0 at y0) at positions (N, 2)."""
    x0, y0, x1, y1 = domain
    h, w = density.shape
    i = np.clip(((xy[:, 0] - x0) / (x1 - x0) * w).astype(np.int64), 0, w - 1)
    j = np.clip(((xy[:, 1] - y0) / (y1 - y0) * h).astype(np.int64), 0, h - 1)
    return density[j, i]


def _bridson(radius_at, rmin, rmax, domain, periodic, rng, k):
    x0, y0, x1, y1 = domain
    wd, hd = x1 - x0, y1 - y0
    nx = max(1, math.ceil(wd / (rmin / math.sqrt(2))))
    ny = max(1, math.ceil(hd / (rmin / math.sqrt(2))))
    cw, ch = wd / nx, hd / ny
    grid = np.full((ny, nx), -1, dtype=np.int64)
    cap = int(wd * hd / (rmin * rmin) * 1.5) + 16
    pts = np.empty((cap, 2))
    rad = np.empty(cap)
    n = 0

    def add(p, r):
        nonlocal n, pts, rad
        if n == pts.shape[0]:
            pts = np.concatenate([pts, np.empty_like(pts)])
            rad = np.concatenate([rad, np.empty_like(rad)])
        pts[n] = p
        rad[n] = r
        grid[min(int((p[1] - y0) / ch), ny - 1), min(int((p[0] - x0) / cw), nx - 1)] = n
        n += 1
        return n - 1

    p0 = np.array([x0 + rng.random() * wd, y0 + rng.random() * hd])
    active = [add(p0, float(radius_at(p0[None])[0]))]
    reach_x = math.ceil(rmax / cw)
    reach_y = math.ceil(rmax / ch)
    while active:
        a = int(rng.integers(len(active)))
        i = active[a]
        p, r = pts[i], rad[i]
        ang = rng.random(k) * (2 * math.pi)
        dist = r * np.sqrt(1.0 + 3.0 * rng.random(k))  # uniform over the annulus [r, 2r]
        cand = p + dist[:, None] * np.stack([np.cos(ang), np.sin(ang)], axis=1)
        if periodic:
            cand[:, 0] = x0 + np.mod(cand[:, 0] - x0, wd)
            cand[:, 1] = y0 + np.mod(cand[:, 1] - y0, hd)
            inside = np.ones(k, dtype=bool)
        else:
            inside = (cand[:, 0] >= x0) & (cand[:, 0] < x1) & (cand[:, 1] >= y0) & (cand[:, 1] < y1)
        rc = radius_at(cand)
        cx, cy = int((p[0] - x0) / cw), int((p[1] - y0) / ch)
        sx = reach_x + math.ceil(2 * r / cw)
        sy = reach_y + math.ceil(2 * r / ch)
        if periodic:
            ii = np.arange(cx - sx, cx + sx + 1) % nx
            jj = np.arange(cy - sy, cy + sy + 1) % ny
            ii, jj = np.unique(ii), np.unique(jj)
        else:
            ii = np.arange(max(cx - sx, 0), min(cx + sx + 1, nx))
            jj = np.arange(max(cy - sy, 0), min(cy + sy + 1, ny))
        block = grid[np.ix_(jj, ii)].ravel()
        idx = block[block >= 0]
        diff = cand[:, None, :] - pts[idx][None, :, :]
        if periodic:
            diff[..., 0] -= wd * np.round(diff[..., 0] / wd)
            diff[..., 1] -= hd * np.round(diff[..., 1] / hd)
        d2 = (diff ** 2).sum(-1)
        need = np.maximum(rc[:, None], rad[idx][None, :])
        ok = inside & (d2 >= need * need).all(axis=1)
        if ok.any():
            j = int(np.argmax(ok))
            active.append(add(cand[j], float(rc[j])))
        else:
            active[a] = active[-1]
            active.pop()
    return pts[:n].copy()


def _dart_throwing(r, domain, periodic, rng, rounds=64, misses=8):
    """Fixed-radius Poisson-disk sampling by vectorised dart throwing on a background grid.

    Grid cells of side <= r / sqrt(2) hold at most one point. Each round throws one dart,
    uniform in its cell, into every *active* cell (empty and not yet covered), rejects darts
    closer than ``r`` to an existing point (in the neighbour cells near enough to hold one:
    the 5 x 5 block) or to a dart of higher random
    priority thrown in the same round, and accepts the rest together. A cell is retired once
    one existing point's disc holds all four of its corners (nothing can go there any more)
    or after ``misses`` rejected darts in a row (a sliver left between several discs), so the
    active set shrinks to nothing: the result is maximal up to such slivers.
    """
    x0, y0, x1, y1 = domain
    wd, hd = x1 - x0, y1 - y0
    nx = max(1, math.ceil(wd * math.sqrt(2) / r))
    ny = max(1, math.ceil(hd * math.sqrt(2) / r))
    cw, ch = wd / nx, hd / ny
    # neighbour cells that can hold a point closer than r to a point of the centre cell
    rx, ry = math.ceil(r / cw), math.ceil(r / ch)
    offs = np.array([(di, dj) for dj in range(-ry, ry + 1) for di in range(-rx, rx + 1)
                     if (max(abs(di) - 1, 0) * cw) ** 2 + (max(abs(dj) - 1, 0) * ch) ** 2 < r * r])
    r2 = r * r
    px = np.full(nx * ny + 1, np.nan)  # one slot per cell, plus an always-empty sentinel
    py = np.full(nx * ny + 1, np.nan)
    order = np.full(nx * ny + 1, -1, dtype=np.int64)  # acceptance order, for the output
    n = 0
    active = np.arange(nx * ny)
    missed = np.zeros(nx * ny, dtype=np.int64)
    oi, oj = offs[:, 0], offs[:, 1]

    def neighbours(cells):
        ci, cj = cells % nx, cells // nx
        ni, nj = ci[:, None] + oi, cj[:, None] + oj
        if periodic:
            return (nj % ny) * nx + ni % nx
        out = (ni < 0) | (ni >= nx) | (nj < 0) | (nj >= ny)
        return np.where(out, nx * ny, nj * nx + ni)

    def dist2(qx, qy, ax, ay):
        dx, dy = qx - ax, qy - ay
        if periodic:
            dx -= wd * np.round(dx / wd)
            dy -= hd * np.round(dy / hd)
        return dx * dx + dy * dy

    for _ in range(rounds):
        if active.size == 0:
            break
        ci, cj = active % nx, active // nx
        u = rng.random((active.size, 2))
        dx_ = x0 + (ci + u[:, 0]) * cw
        dy_ = y0 + (cj + u[:, 1]) * ch
        nb = neighbours(active)
        # against existing points (NaN distances compare False)
        ok = ~(dist2(dx_[:, None], dy_[:, None], px[nb], py[nb]) < r2).any(axis=1)
        # against the other darts of this round: the higher priority wins
        prio = rng.random(active.size)
        tx = np.full(nx * ny + 1, np.nan)
        ty = np.full(nx * ny + 1, np.nan)
        tp = np.full(nx * ny + 1, -1.0)
        cand = active[ok]
        tx[cand], ty[cand], tp[cand] = dx_[ok], dy_[ok], prio[ok]
        nbc = nb[ok]
        clash = (dist2(dx_[ok][:, None], dy_[ok][:, None], tx[nbc], ty[nbc]) < r2) \
            & (tp[nbc] > prio[ok][:, None])
        win = ~clash.any(axis=1)
        acc = cand[win]
        px[acc], py[acc] = dx_[ok][win], dy_[ok][win]
        order[acc] = n + np.arange(acc.size)
        n += acc.size
        # retire filled cells and cells covered by a single disc
        lost = np.ones(active.size, dtype=bool)
        lost[np.flatnonzero(ok)[win]] = False
        missed[active[lost]] += 1
        rest = active[lost & (missed[active] < misses)]
        ri, rj = rest % nx, rest // nx
        nbr = neighbours(rest)
        covered = np.ones(nbr.shape, dtype=bool)
        for ex in (0.0, 1.0):
            for ey in (0.0, 1.0):
                covered &= dist2(x0 + (ri + ex) * cw, y0 + (rj + ey) * ch,
                                 px[nbr].T, py[nbr].T).T < r2
        active = rest[~covered.any(axis=1)]
    filled = np.flatnonzero(order >= 0)
    filled = filled[np.argsort(order[filled], kind="stable")]
    return np.stack([px[filled], py[filled]], axis=1)


def poisson_disk(radius, *, domain=DEFAULT_DOMAIN, periodic=True, seed=0, k=8) -> np.ndarray:
    """Poisson-disk points with a fixed minimum distance (vectorised dart throwing).

    Every empty grid cell (side <= radius / sqrt(2)) gets a dart per round; darts too close
    to a point or to a higher-priority dart of the same round are rejected, the rest are
    accepted together (see :func:`_dart_throwing`). Same density and coverage as Bridson's
    algorithm (about 700 points at radius 0.0595 on the default domain), about 7x faster.

    Parameters
    ----------
    radius : float
        Minimum distance between points, in domain units, > 0 and at most half the domain's
        smaller side.
    domain : tuple of 4 float
        ``(x0, y0, x1, y1)``.
    periodic : bool
        Measure distances on the torus, so the set tiles.
    seed : int or numpy.random.Generator
        Same seed, same points (bit for bit).
    k : int
        Rejected darts in a row after which a cell is given up, >= 1.

    Returns
    -------
    numpy.ndarray of float64, shape (N, 2)
        In acceptance order.
    """
    domain = _check_domain(domain)
    side = min(domain[2] - domain[0], domain[3] - domain[1])
    r = _check_positive("radius", radius, upper=side / 2)
    if side / r > 4000:
        raise ValueError(f"radius must be >= domain side / 4000 = {side / 4000:.6g}, got {radius}")
    k = int(k)
    if k < 1:
        raise ValueError(f"k must be >= 1, got {k}")
    return _dart_throwing(r, domain, periodic, _rng(seed), rounds=max(8 * k, 64), misses=k)


def poisson_disk_variable(radius_min, radius_max, density, *, domain=DEFAULT_DOMAIN,
                          periodic=True, seed=0, k=30) -> np.ndarray:
    """Poisson-disk points whose minimum distance follows a density map (progressive textures).

    The local radius is ``radius_max + (radius_min - radius_max) * density(x, y)``: density 1
    gives the closest packing. Two points conflict when closer than the larger of their radii.

    Parameters
    ----------
    radius_min, radius_max : float
        ``0 < radius_min <= radius_max <= half the domain's smaller side``.
    density : callable or array_like
        ``density(xy)`` with ``xy`` of shape (M, 2) returning (M,) values in [0, 1], or an
        array of shape (H, W) in [0, 1] over the domain (row 0 at ``y0``), sampled nearest.
    domain, periodic, seed
        As :func:`poisson_disk`.
    k : int
        Candidates per active point (Bridson's algorithm), >= 1.

    Returns
    -------
    numpy.ndarray of float64, shape (N, 2)
    """
    domain = _check_domain(domain)
    side = min(domain[2] - domain[0], domain[3] - domain[1])
    rmin = _check_positive("radius_min", radius_min, upper=side / 2)
    rmax = _check_positive("radius_max", radius_max, upper=side / 2)
    if rmax < rmin:
        raise ValueError(f"radius_max must be >= radius_min = {rmin}, got {radius_max}")
    if side / rmin > 4000:
        raise ValueError(f"radius_min must be >= {side / 4000:.6g}, got {radius_min}")
    if callable(density):
        dens = density
    else:
        arr = np.asarray(density, dtype=np.float64)
        if arr.ndim != 2 or arr.size == 0:
            raise ValueError(f"density map must have shape (H, W), got {arr.shape}")
        if not np.isfinite(arr).all() or arr.min() < 0 or arr.max() > 1:
            raise ValueError("density map values must be in [0, 1]")

        def dens(xy):
            return _sample_map(arr, xy, domain)

    def radius_at(xy):
        d = np.clip(np.asarray(dens(xy), dtype=np.float64), 0.0, 1.0)
        return rmax + (rmin - rmax) * d

    return _bridson(radius_at, rmin, rmax, domain, periodic, _rng(seed), int(k))


def random_orientations(n, *, seed=0) -> np.ndarray:
    """Orientations uniform on the unit sphere.

    Parameters
    ----------
    n : int
        Number of vectors.
    seed : int or numpy.random.Generator

    Returns
    -------
    numpy.ndarray of float64, shape (n, 3)
    """
    rng = _rng(seed)
    z = rng.random(n) * 2 - 1
    phi = rng.random(n) * 2 * math.pi
    s = np.sqrt(1 - z * z)
    return np.stack([s * np.cos(phi), s * np.sin(phi), z], axis=1)


def space_giraffe(centres, *, n_range=(10, 20), domain=DEFAULT_DOMAIN, periodic=True, seed=0):
    """The "space giraffe" construction: irregular spots around cell centres.

    For each centre, ``r`` is half the distance to its nearest neighbour; ``n`` is drawn from
    ``n_range`` (inclusive) and at angles ``phase + 2 pi m / n`` a pair of radii is drawn
    from ``U(0, r)``: the inner point gets the spot label (1), the outer the background
    label (0). The centre itself keeps the spot label.

    Parameters
    ----------
    centres : array_like, shape (M, 2)
        Cell centres (e.g. from :func:`poisson_disk`), M >= 2.
    n_range : (int, int)
        Inclusive range of the number of angles per cell, ``3 <= lo <= hi``.
    domain, periodic, seed
        As :func:`poisson_disk`.

    Returns
    -------
    positions : numpy.ndarray of float64, shape (N, 2)
        ``N = M + 2 * sum(n)``.
    labels : numpy.ndarray of int32, shape (N,)
        1 = spot, 0 = background.
    """
    domain = _check_domain(domain)
    c = np.asarray(centres, dtype=np.float64)
    if c.ndim != 2 or c.shape[1] != 2 or c.shape[0] < 2:
        raise ValueError(f"centres must have shape (M, 2) with M >= 2, got {c.shape}")
    lo, hi = (int(v) for v in n_range)
    if not 3 <= lo <= hi:
        raise ValueError(f"n_range must satisfy 3 <= lo <= hi, got {n_range!r}")
    rng = _rng(seed)
    x0, y0, x1, y1 = domain
    if periodic:
        box = np.array([x1 - x0, y1 - y0])
        rel = np.mod(c - [x0, y0], box)
        rel = np.where(rel >= box, 0.0, rel)
        tree = cKDTree(rel, boxsize=box)
        dist, _ = tree.query(rel, k=2)
    else:
        dist, _ = cKDTree(c).query(c, k=2)
    r = dist[:, 1] / 2
    ns = rng.integers(lo, hi + 1, size=c.shape[0])
    out_pos = [c]
    out_lab = [np.ones(c.shape[0], dtype=np.int32)]
    for i in range(c.shape[0]):
        n = int(ns[i])
        ang = rng.random() * 2 * math.pi + 2 * math.pi * np.arange(n) / n
        radii = rng.random((n, 2)) * r[i]
        inner, outer = radii.min(1), radii.max(1)
        u = np.stack([np.cos(ang), np.sin(ang)], axis=1)
        out_pos += [c[i] + inner[:, None] * u, c[i] + outer[:, None] * u]
        out_lab += [np.ones(n, dtype=np.int32), np.zeros(n, dtype=np.int32)]
    pos = np.concatenate(out_pos)
    lab = np.concatenate(out_lab)
    if not periodic:
        keep = (pos[:, 0] >= x0) & (pos[:, 0] <= x1) & (pos[:, 1] >= y0) & (pos[:, 1] <= y1)
        pos, lab = pos[keep], lab[keep]
    return pos, lab


def cluster_labels(graph, *, sizes=(3, 4), seed=0) -> np.ndarray:
    """Group points into clusters of graph neighbours, one label per cluster.

    Points are visited in random order; an unlabelled point starts a cluster of a size drawn
    from ``sizes`` (inclusive range) and grows it by the nearest unlabelled graph neighbours
    of the cluster. A cluster may end smaller when no unlabelled neighbour is left.

    Parameters
    ----------
    graph : PupsGraph
        Delaunay graph of the points.
    sizes : (int, int)
        Inclusive range of cluster sizes, ``1 <= lo <= hi``.
    seed : int or numpy.random.Generator

    Returns
    -------
    numpy.ndarray of int32, shape (N,)
        Labels ``0 .. n_clusters - 1``.
    """
    lo, hi = (int(v) for v in sizes)
    if not 1 <= lo <= hi:
        raise ValueError(f"sizes must satisfy 1 <= lo <= hi, got {sizes!r}")
    rng = _rng(seed)
    n = len(graph.points)
    labels = np.full(n, -1, dtype=np.int32)
    off, nb = graph.offsets, graph.neighbours
    length = np.hypot(graph.axes[:, 0], graph.axes[:, 1])
    nxt = 0
    for i in rng.permutation(n):
        if labels[i] >= 0:
            continue
        size = int(rng.integers(lo, hi + 1))
        labels[i] = nxt
        members = [i]
        while len(members) < size:
            best, best_d = -1, np.inf
            for m in members:
                for e in range(off[m], off[m + 1]):
                    j = nb[e]
                    if labels[j] < 0 and length[e] < best_d:
                        best, best_d = j, length[e]
            if best < 0:
                break
            labels[best] = nxt
            members.append(best)
        nxt += 1
    return labels


def labels_from_image(positions, image, *, domain=DEFAULT_DOMAIN, seed=0) -> np.ndarray:
    """Binary labels from a grayscale reference image.

    A point gets label 1 (white) when a uniform random number is below the image intensity at
    its position, else 0 (black).

    Parameters
    ----------
    positions : array_like, shape (N, 2)
    image : array_like, shape (H, W)
        Intensities in [0, 1] over the domain (row 0 at ``y0``); sampled nearest.
    domain : tuple of 4 float
    seed : int or numpy.random.Generator

    Returns
    -------
    numpy.ndarray of int32, shape (N,)
    """
    domain = _check_domain(domain)
    img = np.asarray(image, dtype=np.float64)
    if img.ndim != 2 or img.size == 0:
        raise ValueError(f"reference image must be grayscale with shape (H, W), got {img.shape}")
    if not np.isfinite(img).all() or img.min() < 0 or img.max() > 1:
        raise ValueError("reference image intensities must be in [0, 1]")
    pos = np.asarray(positions, dtype=np.float64)
    inten = _sample_map(img, pos, domain)
    return (_rng(seed).random(pos.shape[0]) < inten).astype(np.int32)


def labels_by_ramp(positions, *, domain=DEFAULT_DOMAIN, axis=0, seed=0) -> np.ndarray:
    """Binary labels with a probability of white that ramps linearly along one axis.

    Parameters
    ----------
    positions : array_like, shape (N, 2)
    domain : tuple of 4 float
    axis : int
        0: ramp from x0 (all black) to x1 (all white); 1: along y.
    seed : int or numpy.random.Generator

    Returns
    -------
    numpy.ndarray of int32, shape (N,)
    """
    domain = _check_domain(domain)
    if axis not in (0, 1):
        raise ValueError(f"axis must be 0 or 1, got {axis!r}")
    pos = np.asarray(positions, dtype=np.float64)
    lo, hi = domain[axis], domain[axis + 2]
    prob = np.clip((pos[:, axis] - lo) / (hi - lo), 0, 1)
    return (_rng(seed).random(pos.shape[0]) < prob).astype(np.int32)


# --------------------------------------------------------------------------------------------
# graph and support
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class PupsGraph:
    """Delaunay graph of a point set and the support of each point.

    Attributes
    ----------
    points : PupsPoints
    axis_factor : float
        Axis-length factor f (1: interpolating; > 1: longer axes, smoother, approximating).
    offsets : numpy.ndarray of int64, shape (N + 1,)
        CSR row starts: the axes of point i are ``offsets[i]:offsets[i + 1]``, sorted by angle.
    neighbours : numpy.ndarray of int64, shape (M,)
        Neighbour index of each axis.
    axes : numpy.ndarray of float64, shape (M, 2)
        Axis vectors (neighbour - point, using the nearest periodic copy of the neighbour).
    bbox : numpy.ndarray of float64, shape (N, 4)
        Support bounding box ``(x0, y0, x1, y1)`` of each point, absolute; may cross the
        domain edge for periodic sets.
    radius : numpy.ndarray of float64, shape (N,)
        Exact support radius (furthest point of the support polygon from the point; inf for
        a non-periodic hull point).
    """

    points: PupsPoints
    axis_factor: float
    offsets: np.ndarray
    neighbours: np.ndarray
    axes: np.ndarray
    bbox: np.ndarray
    radius: np.ndarray


_SHIFTS = np.array([(0, 0), (-1, -1), (0, -1), (1, -1), (-1, 0), (1, 0), (-1, 1), (0, 1), (1, 1)])


def _delaunay_edges(points: PupsPoints):
    """Return (owner, neighbour, axis vector) arrays of every directed Delaunay edge."""
    pos = points.positions
    n = pos.shape[0]
    if points.periodic:
        x0, y0, x1, y1 = points.domain
        period = np.array([x1 - x0, y1 - y0])
        tiled = (pos[None, :, :] + (_SHIFTS * period)[:, None, :]).reshape(-1, 2)
        ids = np.arange(tiled.shape[0])
        # First try with only the copies in a margin of a few mean spacings around the domain
        # (much smaller triangulation); fall back to the full ring of 8 copies when the
        # result is not consistent.
        spacing = math.sqrt(period[0] * period[1] / n)
        for margin in (4.0 * spacing, np.inf):
            keep = ids[(tiled[:, 0] >= x0 - margin) & (tiled[:, 0] <= x1 + margin)
                       & (tiled[:, 1] >= y0 - margin) & (tiled[:, 1] <= y1 + margin)]
            tri = Delaunay(tiled[keep])
            indptr, indices = tri.vertex_neighbor_vertices
            owner = np.repeat(np.arange(n), np.diff(indptr[:n + 1]))
            nbt = keep[indices[indptr[0]:indptr[n]]]
            nb = nbt % n
            axes = tiled[nbt] - pos[owner]
            # Every edge must appear in both directions with opposite vectors, and a copy
            # must never be its own original's neighbour at a zero offset.
            key_a = np.round(np.c_[owner, nb, axes * 1e9]).astype(np.int64)
            key_b = np.round(np.c_[nb, owner, -axes * 1e9]).astype(np.int64)
            sa = key_a[np.lexsort(key_a.T[::-1])]
            sb = key_b[np.lexsort(key_b.T[::-1])]
            if sa.shape == sb.shape and np.array_equal(sa, sb):
                break
        else:
            raise ValueError(f"periodic Delaunay graph is inconsistent for {n} points; use more "
                             "points (about 10 or more per domain)")
    else:
        tri = Delaunay(pos)
        indptr, indices = tri.vertex_neighbor_vertices
        owner = np.repeat(np.arange(n), np.diff(indptr))
        nb = indices.astype(np.int64)
        axes = pos[nb] - pos[owner]
    return owner, nb.astype(np.int64), axes


def _support(owner, axes, n, f):
    """Exact support box of each point relative to it: (N, 4) and radius (N,), inf if open."""
    ang = np.arctan2(axes[:, 1], axes[:, 0])
    order = np.lexsort((ang, owner))
    owner, axes, ang = owner[order], axes[order], ang[order]
    count = np.bincount(owner, minlength=n)
    start = np.concatenate([[0], np.cumsum(count)])
    pos_in = np.arange(owner.size) - start[owner]
    nxt = np.where(pos_in + 1 < count[owner], np.arange(owner.size) + 1, start[owner])
    b = axes[nxt]
    gap = np.mod(ang[nxt] - ang, 2 * np.pi)
    gap = np.where(count[owner] == 1, 2 * np.pi, gap)
    open_ = np.zeros(n, dtype=bool)
    np.logical_or.at(open_, owner, gap >= np.pi - 1e-9)
    ha = f * (axes ** 2).sum(1)
    hb = f * (b ** 2).sum(1)
    det = axes[:, 0] * b[:, 1] - axes[:, 1] * b[:, 0]
    safe = np.where(np.abs(det) > 0, det, 1.0)
    vx = (ha * b[:, 1] - hb * axes[:, 1]) / safe
    vy = (axes[:, 0] * hb - b[:, 0] * ha) / safe
    in_wedge = (det > 0) & (axes[:, 0] * vy - axes[:, 1] * vx >= 0) & (vx * b[:, 1] - vy * b[:, 0] >= 0)
    vx = np.where(in_wedge, vx, 0.0)
    vy = np.where(in_wedge, vy, 0.0)
    fx, fy = f * axes[:, 0], f * axes[:, 1]
    box = np.zeros((n, 4))
    np.minimum.at(box[:, 0], owner, np.minimum(fx, vx))
    np.minimum.at(box[:, 1], owner, np.minimum(fy, vy))
    np.maximum.at(box[:, 2], owner, np.maximum(fx, vx))
    np.maximum.at(box[:, 3], owner, np.maximum(fy, vy))
    rad = np.zeros(n)
    np.maximum.at(rad, owner, np.maximum(np.hypot(fx, fy), np.hypot(vx, vy)))
    rad[open_] = np.inf
    return order, box, rad, open_


def pups_graph(points: PupsPoints, axis_factor=1.0) -> PupsGraph:
    """Build the Delaunay graph, each point's axes and its exact support.

    Parameters
    ----------
    points : PupsPoints
    axis_factor : float
        Axis-length factor in (0, 16]; 1 interpolates the values, larger is smoother.

    Returns
    -------
    PupsGraph

    Raises
    ------
    ValueError
        If ``axis_factor`` is out of range or the points are degenerate (all collinear).
    """
    if not isinstance(points, PupsPoints):
        raise ValueError(f"points must be a PupsPoints, got {type(points).__name__}")
    f = _check_positive("axis_factor", axis_factor, upper=16.0)
    n = len(points)
    try:
        owner, nb, axes = _delaunay_edges(points)
    except Exception as e:  # scipy.spatial.QhullError on degenerate input
        if isinstance(e, ValueError):
            raise
        raise ValueError(f"cannot triangulate the {n} control points: {e}") from None
    order, box, rad, open_ = _support(owner, axes, n, f)
    owner, nb, axes = owner[order], nb[order], axes[order]
    offsets = np.concatenate([[0], np.cumsum(np.bincount(owner, minlength=n))]).astype(np.int64)
    pos = points.positions
    bbox = box + np.c_[pos, pos]
    if open_.any():
        if points.periodic:
            raise ValueError("periodic graph has a point with an open support; use more points")
        x0, y0, x1, y1 = points.domain
        bbox[open_] = (x0, y0, x1, y1)
    if not points.periodic:
        x0, y0, x1, y1 = points.domain
        bbox = np.c_[np.maximum(bbox[:, 0], x0), np.maximum(bbox[:, 1], y0),
                     np.minimum(bbox[:, 2], x1), np.minimum(bbox[:, 3], y1)]
    return PupsGraph(points, f, offsets, nb, axes, bbox, rad)


# --------------------------------------------------------------------------------------------
# packing: instances, pixel boxes and the candidate grid
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class PupsPacked:
    """Everything an evaluation of one image needs, as flat arrays (GPU and NumPy alike).

    An *instance* is a control point or one of its periodic copies whose support reaches the
    image. Instances are ordered by copy, then by point index.

    Attributes
    ----------
    point_index : int64 (K,)
        Control point of each instance.
    positions : float64 (K, 2)
    orient : float64 (K, 2)
        xy part of the orientation.
    values : float64 (K, C)
    labels : int32 (K,)
    axis_begin, axis_count : int64 (K,)
        The instance's axes in ``axes_scaled``.
    axes_scaled : float64 (M, 2)
        ``axis / (f |axis|^2)``.
    pixel_box : int64 (K, 4)
        ``(i0, j0, i1, j1)`` inclusive pixel range that may see a non-zero weight (one pixel of
        slack each side); empty when ``i1 < i0``.
    origin, pixel : (float, float)
        Domain position of the centre of pixel (0, 0), and the pixel size.
    width, height, tile : int
        Image size and candidate-grid cell size in pixels.
    grid_shape : (int, int)
        ``(rows, cols)`` of the candidate grid.
    cell_offsets : uint32 (rows * cols + 1,)
    cell_items : uint32 (L,)
        Instances listed per grid cell, in increasing index order.
    cell_masks : uint32 (L,)
        Per listed instance, bit r set when axis r can project above 0 somewhere in the cell;
        the other axes give a factor of exactly 1 there and are skipped. All bits set for a
        point with more than 32 axes (every axis is then visited).
    stream : (uint32 (rows * cols, 4), uint32 (R, 4))
        The same grid as the shaders read it: per cell a header, per candidate its
        position, orientation, value, label and masked-in axes inline (see
        :func:`_cell_stream`).
    """

    point_index: np.ndarray
    positions: np.ndarray
    orient: np.ndarray
    values: np.ndarray
    labels: np.ndarray
    axis_begin: np.ndarray
    axis_count: np.ndarray
    axes_scaled: np.ndarray
    pixel_box: np.ndarray
    origin: tuple
    pixel: tuple
    width: int
    height: int
    tile: int
    grid_shape: tuple
    cell_offsets: np.ndarray
    cell_items: np.ndarray
    cell_masks: np.ndarray
    timings: dict = field(default_factory=dict)
    stream: tuple = None


def pups_pack(graph: PupsGraph, width, height, *, tile=None, grid=True) -> PupsPacked:
    """Lay out a graph for evaluation on a ``width`` x ``height`` pixel grid.

    Parameters
    ----------
    graph : PupsGraph
    width, height : int
        Image size in pixels, each in [1, 16384].
    tile : int, optional
        Candidate-grid cell size in pixels, in [1, 1024]; default: about half the mean point
        spacing.
    grid : bool
        Build the candidate grid and stream (the compute and fragment paths need them; the
        raster path does not). Without it ``cell_offsets`` lists no item, ``grid_shape`` is
        ``(0, 0)`` and ``stream`` is None.

    Returns
    -------
    PupsPacked
    """
    width, height = _check_size(width, height)
    pts = graph.points
    x0, y0, x1, y1 = pts.domain
    px, py = (x1 - x0) / width, (y1 - y0) / height
    n = len(pts)
    bbox = graph.bbox
    if pts.periodic:
        wd, hd = x1 - x0, y1 - y0
        sx0 = np.ceil((x0 - bbox[:, 2]) / wd).astype(np.int64)
        sx1 = np.floor((x1 - bbox[:, 0]) / wd).astype(np.int64)
        sy0 = np.ceil((y0 - bbox[:, 3]) / hd).astype(np.int64)
        sy1 = np.floor((y1 - bbox[:, 1]) / hd).astype(np.int64)
        reach = int(max(np.abs(np.r_[sx0, sx1, sy0, sy1]).max(), 0))
        shifts = [(0, 0)] + [(a, b) for b in range(-reach, reach + 1)
                             for a in range(-reach, reach + 1) if (a, b) != (0, 0)]
        idx, sh = [], []
        for a, b in shifts:
            sel = np.nonzero((sx0 <= a) & (a <= sx1) & (sy0 <= b) & (b <= sy1))[0]
            idx.append(sel)
            sh.append(np.tile([a * wd, b * hd], (sel.size, 1)))
        point_index = np.concatenate(idx)
        shift = np.concatenate(sh)
    else:
        point_index = np.arange(n)
        shift = np.zeros((n, 2))
    positions = pts.positions[point_index] + shift
    ibox = bbox[point_index] + np.c_[shift, shift]
    ox, oy = x0 + 0.5 * px, y0 + 0.5 * py
    i0 = np.clip(np.ceil((ibox[:, 0] - ox) / px) - 1, 0, width).astype(np.int64)
    i1 = np.clip(np.floor((ibox[:, 2] - ox) / px) + 1, -1, width - 1).astype(np.int64)
    j0 = np.clip(np.ceil((ibox[:, 1] - oy) / py) - 1, 0, height).astype(np.int64)
    j1 = np.clip(np.floor((ibox[:, 3] - oy) / py) + 1, -1, height - 1).astype(np.int64)
    pixel_box = np.c_[i0, j0, i1, j1]
    if tile is None:
        # about half the mean spacing, a multiple of the 8 x 8 workgroup so that a workgroup
        # shares one candidate list
        spacing = math.sqrt(width * height / max(n, 1))
        tile = int(min(64, max(8, 8 * round(spacing / 16))))
    else:
        if isinstance(tile, bool) or not isinstance(tile, (int, np.integer)) or not 1 <= tile <= 1024:
            raise ValueError(f"tile must be an integer in [1, 1024], got {tile!r}")
        tile = int(tile)
    f = graph.axis_factor
    axes_scaled = graph.axes / (f * (graph.axes ** 2).sum(1))[:, None]
    axis_begin = graph.offsets[point_index]
    axis_count = np.diff(graph.offsets)[point_index]
    orient = pts.orientations[point_index, :2]
    values = pts.values[point_index]
    labels = pts.labels[point_index]
    if not grid:
        none = np.zeros(0, dtype=np.uint32)
        return PupsPacked(
            point_index=point_index, positions=positions, orient=orient, values=values,
            labels=labels, axis_begin=axis_begin, axis_count=axis_count,
            axes_scaled=axes_scaled, pixel_box=pixel_box, origin=(ox, oy), pixel=(px, py),
            width=width, height=height, tile=tile, grid_shape=(0, 0),
            cell_offsets=np.zeros(1, dtype=np.uint32), cell_items=none, cell_masks=none)
    gw, gh = -(-width // tile), -(-height // tile)
    nonempty = (i1 >= i0) & (j1 >= j0)
    k = np.nonzero(nonempty)[0]
    c0, c1 = i0[k] // tile, i1[k] // tile
    r0, r1 = j0[k] // tile, j1[k] // tile
    ncx, ncy = c1 - c0 + 1, r1 - r0 + 1
    cnt = ncx * ncy
    inst = np.repeat(k, cnt)
    local = np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt)
    rep_ncx = np.repeat(ncx, cnt)
    cell = (np.repeat(r0, cnt) + local // rep_ncx) * gw + np.repeat(c0, cnt) + local % rep_ncx
    sep, mask, kpair, kslot, kaxis = _cull(inst, cell, gw, tile, width, height, positions, axis_begin,
                                           axis_count, axes_scaled, (ox, oy), (px, py))
    keep = ~sep
    inst, cell, mask = inst[keep], cell[keep], mask[keep]
    row_ok = keep[kpair]
    kpair, kslot, kaxis = (np.cumsum(keep) - 1)[kpair[row_ok]], kslot[row_ok], kaxis[row_ok]
    order = np.argsort(cell * (point_index.size + 1) + inst, kind="stable")
    items = inst[order].astype(np.uint32)
    masks = mask[order]
    counts = np.bincount(cell, minlength=gw * gh)
    cell_offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.uint32)
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    cell_sorted = cell[order]
    slot = np.arange(order.size) - cell_offsets[cell_sorted].astype(np.int64)
    si = inst[order]
    stream = _stream(cell_offsets, cell_sorted, slot, rank[kpair], kslot, kaxis, inst.size,
                     positions[si], orient[si], values[si], labels[si], axes_scaled)
    return PupsPacked(
        point_index=point_index, positions=positions,
        orient=orient, values=values,
        labels=labels, axis_begin=axis_begin,
        axis_count=axis_count, axes_scaled=axes_scaled,
        pixel_box=pixel_box, origin=(ox, oy), pixel=(px, py), width=width, height=height,
        tile=tile, grid_shape=(gh, gw), cell_offsets=cell_offsets, cell_items=items,
        cell_masks=masks, stream=stream)


def _cull(inst, cell, gw, tile, width, height, positions, axis_begin, axis_count,
          axes_scaled, origin, pixel):
    """Cull (instance, grid cell) pairs and find the axes that matter in each cell.

    The support polygon and the rectangle of the cell's pixel centres are convex, so (with
    the box overlap already known) they are disjoint exactly when one of the polygon's edge
    lines separates them (separating axis theorem): some axis has ``p >= 1`` at all four
    corners. An axis with ``p <= 0`` at all four corners gives the factor 1 everywhere in the
    cell and is left out of the pair's mask. Margins of 1e-4 keep float32 rounding on the
    safe side. One vectorised pass per axis rank (pairs sorted by axis count, so the pairs
    with an axis of rank r are a prefix).

    Returns
    -------
    separated : bool (L,)
    mask : uint32 (L,)
    kept_pair, kept_slot, kept_axis : int64 (A,)
        The axes that matter (the masked-in ones, or every axis of a point with more than
        32), as (pair, rank among the pair's kept axes in axis order, index into
        ``axes_scaled``).
    """
    if inst.size == 0:
        z = np.zeros(0, dtype=np.int64)
        return np.zeros(0, dtype=bool), np.zeros(0, dtype=np.uint32), z, z, z
    # pairs sorted by axis count (descending): the pairs that have an axis r are a prefix
    cnt_all = axis_count[inst]
    perm = np.argsort(-cnt_all, kind="stable")
    inst_p, cell_p = inst[perm], cell[perm]
    cnt = cnt_all[perm]
    beg = axis_begin[inst_p]
    cx, cy = cell_p % gw, cell_p // gw
    i0 = cx * tile
    i1 = np.minimum(i0 + tile, width) - 1
    j0 = cy * tile
    j1 = np.minimum(j0 + tile, height) - 1
    x0 = i0 * pixel[0] + origin[0] - positions[inst_p, 0]
    x1 = i1 * pixel[0] + origin[0] - positions[inst_p, 0]
    y0 = j0 * pixel[1] + origin[1] - positions[inst_p, 1]
    y1 = j1 * pixel[1] + origin[1] - positions[inst_p, 1]
    n = inst.size
    sep = np.zeros(n, dtype=bool)
    mask = np.zeros(n, dtype=np.uint32)
    many = cnt > 32
    nkept = np.zeros(n, dtype=np.int64)
    kp, ks, ka = [], [], []
    dmax = int(cnt[0])
    for r in range(dmax):
        m = int(np.searchsorted(-cnt, -r, side="left"))  # pairs with cnt > r: cnt[:m]
        a = axes_scaled[beg[:m] + r]
        ax, ay = a[:, 0], a[:, 1]
        # a linear function over a rectangle: extremes at corners (x0 <= x1, y0 <= y1)
        xa0, xa1, ya0, ya1 = x0[:m] * ax, x1[:m] * ax, y0[:m] * ay, y1[:m] * ay
        pmin = np.minimum(xa0, xa1) + np.minimum(ya0, ya1)
        pmax = np.maximum(xa0, xa1) + np.maximum(ya0, ya1)
        sep[:m] |= pmin >= 1.0 + 1e-4
        live = pmax > -1e-4
        if r < 32:
            mask[:m] |= live.astype(np.uint32) << np.uint32(r)
        idx = np.flatnonzero(live | many[:m])
        kp.append(idx)
        ks.append(nkept[idx])
        ka.append(beg[idx] + r)
        nkept[idx] += 1
    mask[many] = np.uint32(0xFFFFFFFF)
    inv = np.empty_like(perm)
    inv[perm] = np.arange(n)
    kp = perm[np.concatenate(kp)] if kp else np.zeros(0, dtype=np.int64)
    return (sep[inv], mask[inv], kp, np.concatenate(ks) if ks else kp,
            np.concatenate(ka) if ka else kp)


def _stream(cell_offsets, cell_of, slot, kept_pair, kept_slot, kept_axis, npairs_total, pos,
            orient, values, labels, axes_scaled):
    """Build the shaders' candidate stream (see :func:`_cell_stream`).

    Pairs in list order (by cell, then instance). ``cell_of`` / ``slot``: grid cell and
    index within that cell's list of each pair;
    ``kept_pair`` / ``kept_slot`` / ``kept_axis``: the pairs' axes, with their rank in the
    pair's list; ``pos`` .. ``labels``: per pair.
    """
    offsets = cell_offsets.astype(np.int64)
    ncell = offsets.size - 1
    n = npairs_total
    ncand = np.diff(offsets)
    pairs = np.zeros(ncell, dtype=np.int64)
    if n:
        naxes = np.bincount(kept_pair, minlength=n)
        nonempty = ncand > 0
        pairs[nonempty] = np.maximum.reduceat((naxes + 1) // 2, offsets[:-1][nonempty])
    per = 2 + pairs  # records per candidate, per cell
    cell_begin = np.concatenate([[0], np.cumsum(ncand * per)])
    base = cell_begin[cell_of] + slot * per[cell_of]
    rec = np.zeros((max(int(cell_begin[-1]), 1), 4), dtype="<u4")
    head = np.zeros((n, 8), dtype="<f4")
    head[:, 0:2] = pos
    head[:, 2:4] = orient
    head[:, 4:4 + values.shape[1]] = values
    head.view("<u4")[:, 7] = labels.astype("<i4").view("<u4")
    # scatter whole records (16 bytes as one complex128) and whole axes (8 bytes as uint64)
    rec16 = rec.view(np.complex128).reshape(-1)
    head16 = head.view(np.complex128)
    rec16[base] = head16[:, 0]
    rec16[base + 1] = head16[:, 1]
    ax = np.ascontiguousarray(axes_scaled[kept_axis], dtype="<f4").view(np.uint64).reshape(-1)
    rec.view(np.uint64).reshape(-1)[2 * (base[kept_pair] + 2) + kept_slot] = ax
    cells = np.zeros((max(ncell, 1), 4), dtype="<u4")
    cells[:ncell, 0] = cell_begin[:-1]
    cells[:ncell, 1] = ncand
    cells[:ncell, 2] = pairs
    return cells, rec


# --------------------------------------------------------------------------------------------
# GPU driver
# --------------------------------------------------------------------------------------------

_LOCAL = (8, 8)
_fragment_target = {}


def _context():
    """The shared headless context (:func:`cellgl.context.get_context`)."""
    from .context import get_context

    return get_context()


def _compute_program(defines):
    from .context import compute_program

    return compute_program("pups.comp", defines)


def _cell_stream(packed: PupsPacked):
    """The candidate grid as one stream of uvec4 records, laid out for the shaders.

    Per grid cell: a header ``(first record, candidates, axis pairs per candidate, 0)``.
    Per listed candidate, ``2 + pairs`` records: ``(pos.x, pos.y, orient.x, orient.y)``,
    ``(value.r, value.g, value.b, label)`` and its masked-in axes, two per record, in axis
    order, padded with zero axes (factor exactly 1). ``pairs`` is the largest over the
    cell's candidates, so a work group inside one cell runs uniform loops with every load
    at a uniform address, and needs no indirection to the instance arrays.

    Returns
    -------
    cells : uint32 (rows * cols, 4)
    records : uint32 (R, 4)
    """
    if packed.stream is not None:
        return packed.stream
    offsets = packed.cell_offsets.astype(np.int64)
    items = packed.cell_items.astype(np.int64)
    n = items.size
    cnt = packed.axis_count[items]
    rep = np.repeat(np.arange(n), cnt)
    r = np.arange(rep.size) - (np.cumsum(cnt) - cnt)[rep]
    bit = (packed.cell_masks[rep] >> np.minimum(r, 31).astype(np.uint32)) & 1
    keep = (r >= 32) | bit.astype(bool)
    cell_of = np.repeat(np.arange(offsets.size - 1), np.diff(offsets))
    kept_pair = rep[keep]
    naxes = np.bincount(kept_pair, minlength=n)
    kept_slot = np.arange(kept_pair.size) - (np.cumsum(naxes) - naxes)[kept_pair]
    return _stream(offsets, cell_of, np.arange(n) - offsets[cell_of], kept_pair, kept_slot,
                   (packed.axis_begin[items][rep] + r)[keep], n, packed.positions[items],
                   packed.orient[items], packed.values[items], packed.labels[items],
                   packed.axes_scaled)


def _gpu_buffers(packed: PupsPacked):
    """Pack the candidate grid for the shaders (std430 bytes: cell headers, records)."""
    cells, rec = _cell_stream(packed)
    return [cells.tobytes(), rec.tobytes()]


def _evaluate_gpu(packed: PupsPacked, mode: PupsMode, epsilon: float, timings: dict):
    t0 = time.perf_counter()
    ctx = _context()
    c = packed.values.shape[1]
    labels = mode == PupsMode.LABEL
    defines = {"CELL_PUPS_CHANNELS": c, "CELL_PUPS_MODE": int(mode)}
    group_cells = packed.tile % _LOCAL[0] == 0 and packed.tile % _LOCAL[1] == 0
    data = _gpu_buffers(packed)
    if group_cells:
        defines["CELL_PUPS_GROUP_CELLS"] = 1
    prog = _compute_program(defines)
    t1 = time.perf_counter()
    w, h = packed.width, packed.height
    bufs = [ctx.buffer(d) for d in data]
    out = ctx.buffer(reserve=4 * w * h * c)
    lab = ctx.buffer(reserve=4 * w * h if labels else 4)
    for b, binding in zip(bufs + [out, lab], range(4)):
        b.bind_to_storage_buffer(binding)
    t2 = time.perf_counter()
    for name, v in (("u_size", (w, h)), ("u_origin", packed.origin), ("u_pixel", packed.pixel),
                    ("u_tile", packed.tile), ("u_grid_w", packed.grid_shape[1]),
                    ("u_epsilon", epsilon), ("u_tile_groups", packed.tile // _LOCAL[0])):
        if name in prog:
            prog[name] = v
    prog.run(-(-w // _LOCAL[0]), -(-h // _LOCAL[1]), 1)
    ctx.finish()
    t3 = time.perf_counter()
    vals = np.frombuffer(out.read(), dtype=np.float32).reshape(h, w, c)
    labs = np.frombuffer(lab.read(), dtype=np.int32).reshape(h, w) if labels else None
    for b in bufs + [out, lab]:
        b.release()
    t4 = time.perf_counter()
    timings.update(pack=t1 - t0, upload=t2 - t1, gpu=t3 - t2, readback=t4 - t3)
    return vals, labs


def _evaluate_fragment(packed: PupsPacked, mode: PupsMode, epsilon: float):
    """The viewer's path: ``shaders/pups.frag`` into an RGBA32F target.

    Returns float32 (H, W, 4): rgb value, alpha the label as a float.
    """
    from .context import program
    ctx = _context()
    prog = program("fullscreen.vert", "pups.frag", {"CELL_PUPS_MODE": int(mode)})
    w, h = packed.width, packed.height
    data = _gpu_buffers(packed)
    bufs = [ctx.buffer(d) for d in data]
    for binding, b in enumerate(bufs):
        b.bind_to_storage_buffer(binding)
    # One render target, kept while the size stays: deleting the bound framebuffer would
    # leave moderngl restoring a dead binding (GL_INVALID_OPERATION) on the next one.
    target = _fragment_target.setdefault(id(ctx), {})  # per context: never another's objects
    if target.get("key") != (w, h):
        tex = ctx.texture((w, h), 4, dtype="f4")
        fbo = ctx.framebuffer(color_attachments=[tex])
        fbo.use()
        for o in target.get("objects", ()):
            o.release()
        target.update(key=(w, h), objects=(fbo, tex))
    fbo, tex = target["objects"]
    vao = ctx.vertex_array(prog, [])
    for name, v in (("u_size", (w, h)), ("u_origin", packed.origin), ("u_pixel", packed.pixel),
                    ("u_tile", packed.tile), ("u_grid_w", packed.grid_shape[1]),
                    ("u_epsilon", epsilon)):
        if name in prog:
            prog[name] = v
    fbo.use()
    fbo.viewport = (0, 0, w, h)
    vao.render(mode=ctx.TRIANGLES, vertices=3)
    out = np.frombuffer(fbo.read(components=4, dtype="f4"), dtype=np.float32).reshape(h, w, 4)
    for o in bufs + [vao]:
        o.release()
    return out.copy()


_raster_target = {}


def _raster_polygons(packed: PupsPacked):
    """Convex polygons to rasterise for :func:`_evaluate_raster`, in pixel units.

    Per instance with a non-empty pixel box: the intersection of its axes' half-planes
    ``d.a <= 1`` (``a`` pre-scaled), each pushed out by one pixel, with its pixel box (pixel
    edges), so every pixel centre where the weight can be non-zero lies well inside. Found as
    the feasible pairwise intersections of the boundary lines, sorted by angle.

    Returns
    -------
    k : int64 (K',)
        The instances drawn, increasing (the compute path's summation order).
    corners : float64 (K', V, 2)
        Polygon vertices in order (pixel units, pixel (i, j) centred at (i + .5, j + .5)),
        padded by repeating the last one.
    count : int64 (K',)
        Vertices per polygon (0: empty).
    """
    box = packed.pixel_box
    k = np.flatnonzero((box[:, 2] >= box[:, 0]) & (box[:, 3] >= box[:, 1]))
    if k.size == 0:
        return k, np.zeros((0, 3, 2)), np.zeros(0, dtype=np.int64)
    (ox, oy), (px, py) = packed.origin, packed.pixel
    c = packed.positions[k]
    n = k.size
    cnt = packed.axis_count[k]
    d = int(cnt.max())
    # lines nrm . x <= hh in coordinates relative to the point (domain units); 4 box sides
    # first, then the axes (padding repeats a box side)
    nrm = np.zeros((n, d + 4, 2))
    hh = np.zeros((n, d + 4))
    ex0 = ox + (box[k, 0] - 0.5) * px - c[:, 0]
    ey0 = oy + (box[k, 1] - 0.5) * py - c[:, 1]
    ex1 = ox + (box[k, 2] + 0.5) * px - c[:, 0]
    ey1 = oy + (box[k, 3] + 0.5) * py - c[:, 1]
    nrm[:, 0] = (-1, 0)
    hh[:, 0] = -ex0
    nrm[:, 1] = (0, -1)
    hh[:, 1] = -ey0
    nrm[:, 2] = (1, 0)
    hh[:, 2] = ex1
    nrm[:, 3] = (0, 1)
    hh[:, 3] = ey1
    r = np.arange(d)
    valid = r[None] < cnt[:, None]
    ai = packed.axis_begin[k][:, None] + np.minimum(r[None], np.maximum(cnt[:, None] - 1, 0))
    a = packed.axes_scaled[ai]
    margin = max(px, py)
    nrm[:, 4:] = np.where(valid[..., None], a, nrm[:, 0:1])
    hh[:, 4:] = np.where(valid, 1.0 + margin * np.hypot(a[..., 0], a[..., 1]), hh[:, 0:1])
    # unit normals, so the tolerance below is in domain units
    ln = np.hypot(nrm[..., 0], nrm[..., 1])
    nrm /= ln[..., None]
    hh /= ln
    i, j = np.triu_indices(d + 4, 1)
    n1, n2 = nrm[:, i], nrm[:, j]
    det = n1[..., 0] * n2[..., 1] - n1[..., 1] * n2[..., 0]
    ok = np.abs(det) > 1e-12
    sd = np.where(ok, det, 1.0)
    vx = (hh[:, i] * n2[..., 1] - hh[:, j] * n1[..., 1]) / sd
    vy = (n1[..., 0] * hh[:, j] - n2[..., 0] * hh[:, i]) / sd
    slack = 1e-9 * (1.0 + np.abs(hh).max(axis=1))
    feas = ok.copy()
    lim = hh + slack[:, None]
    for q in range(d + 4):  # inside every half-plane (a loop: small arrays, no big temporary)
        feas &= nrm[:, q, 0:1] * vx + nrm[:, q, 1:2] * vy <= lim[:, q:q + 1]
    nf = feas.sum(1)
    cx = np.where(feas, vx, 0).sum(1) / np.maximum(nf, 1)
    cy = np.where(feas, vy, 0).sum(1) / np.maximum(nf, 1)
    ang = np.where(feas, np.arctan2(vy - cy[:, None], vx - cx[:, None]), np.inf)
    order = np.argsort(ang, axis=1, kind="stable")
    vmax = max(int(nf.max()), 3)
    order = order[:, :vmax]
    last = np.take_along_axis(order, np.maximum(nf - 1, 0)[:, None], 1)
    order = np.where(np.arange(vmax)[None] < nf[:, None], order, last)
    corners = np.empty((n, vmax, 2))
    corners[..., 0] = (np.take_along_axis(vx, order, 1) + c[:, 0:1] - ox) / px + 0.5
    corners[..., 1] = (np.take_along_axis(vy, order, 1) + c[:, 1:2] - oy) / py + 0.5
    return k, corners, nf


def _raster_pairs_limit(ctx):
    """Largest axis-pair count the raster path can pass as flat vertex outputs: 4 floats per
    pair next to the point and value vec4s (GL_MAX_VERTEX_OUTPUT_COMPONENTS, 128 on most
    drivers), and one vertex attribute per pair next to the corner, point and value
    (GL_MAX_VERTEX_ATTRIBS, 16: 13 pairs, 26 axes)."""
    comps = int(ctx.info.get("GL_MAX_VERTEX_OUTPUT_COMPONENTS") or 64)
    attribs = int(ctx.info.get("GL_MAX_VERTEX_ATTRIBS") or 16)
    return max(0, min((comps - 8) // 4, attribs - 3))


def _raster_applies(graph: PupsGraph, mode: PupsMode) -> bool:
    """Whether :func:`_evaluate_raster` can evaluate ``graph``: modes ``interpolate`` and
    ``weighted_sum``, every axis list within the varying budget (else: compute)."""
    if mode == PupsMode.LABEL:
        return False
    cnt = np.diff(graph.offsets)
    d = int(cnt.max()) if cnt.size else 0
    return (d + 1) // 2 <= _raster_pairs_limit(_context())


def _evaluate_raster(packed: PupsPacked, mode: PupsMode, epsilon: float, timings: dict):
    """Rasterised evaluation (``method="raster"``): per instance the triangles of a convex
    polygon around its support (:func:`_raster_polygons`), one indexed draw in instance order;
    each vertex carries its instance's position, orientation, value, label and pre-scaled
    axes (zero-padded to ``CELL_PUPS_RASTER_PAIRS`` pairs), passed on as ``flat`` outputs, so
    ``shaders/pups_raster.frag`` reads no buffer. It writes ``(w * value, w)`` and additive
    blending sums them into an RGBA32F target in instance order (the compute path's order);
    the division (interpolate) is done here. Modes ``interpolate`` and ``weighted_sum``, at
    most :func:`_raster_pairs_limit` axis pairs per point (see :func:`_raster_applies`).
    """
    from .context import program
    t0 = time.perf_counter()
    ctx = _context()
    import moderngl
    w, h = packed.width, packed.height
    k, corners, nv = _raster_polygons(packed)
    pairs = (int(packed.axis_count[k].max()) + 1) // 2 if k.size else 0
    if pairs > _raster_pairs_limit(ctx):
        raise ValueError("too many axes per point for method='raster'")
    prog = program("pups_raster.vert", "pups_raster.frag", {"CELL_PUPS_RASTER_PAIRS": pairs})
    # the polygons' vertices, each with its instance's data; fan triangles (0, v, v + 1)
    n = k.size
    vmax = corners.shape[1]
    keep = np.arange(vmax)[None] < nv[:, None]
    vinst = np.repeat(np.arange(n), nv)
    nf = 10 + 4 * pairs
    vert = np.zeros((vinst.size, nf), dtype="<f4")
    vert[:, 0:2] = corners[keep]
    kk = k[vinst]
    vert[:, 2:4] = packed.positions[kk]
    vert[:, 4:6] = packed.orient[kk]
    vert[:, 6:6 + packed.values.shape[1]] = packed.values[kk]
    vert[:, 9] = packed.labels[kk]
    if pairs:
        cnt = packed.axis_count[k]
        r = np.arange(2 * pairs)
        valid = r[None] < cnt[:, None]
        ai = packed.axis_begin[k][:, None] + np.minimum(r[None], np.maximum(cnt[:, None] - 1, 0))
        ax = np.where(valid[..., None], packed.axes_scaled[np.minimum(ai, max(
            packed.axes_scaled.shape[0] - 1, 0))], 0.0).astype("<f4").reshape(n, 4 * pairs)
        vert[:, 10:] = ax[vinst]
    ntri = np.maximum(nv - 2, 0)
    first = np.cumsum(nv) - nv
    tri_inst = np.repeat(np.arange(n), ntri)
    tri_v = np.arange(tri_inst.size) - np.repeat(np.cumsum(ntri) - ntri, ntri) + 1
    base = first[tri_inst]
    idx = np.stack([base, base + tri_v, base + tri_v + 1], axis=1).astype("<u4").reshape(-1)
    t1 = time.perf_counter()
    vbuf = ctx.buffer(vert.tobytes() if vert.size else b"\0" * (4 * nf))
    ibuf = ctx.buffer(idx.tobytes() if idx.size else b"\0" * 4)
    # one render target, kept while the size stays (as in _evaluate_fragment)
    target = _raster_target.setdefault(id(ctx), {})  # per context: never another's objects
    if target.get("key") != (w, h):
        tex = ctx.texture((w, h), 4, dtype="f4")
        fbo = ctx.framebuffer(color_attachments=[tex])
        fbo.use()
        for o in target.get("objects", ()):
            o.release()
        # the readback array too: reading into pages already mapped saves ~10 ms at 1000^2
        target.update(key=(w, h), objects=(fbo, tex), acc=np.empty((h, w, 4), dtype=np.float32))
    fbo, tex = target["objects"]
    acc = target["acc"]
    fmt = "2f 4f 4f" + (f" {4 * pairs}f" if pairs else "")
    names = ["in_corner", "in_point", "in_value"] + (["in_axes"] if pairs else [])
    vao = ctx.vertex_array(prog, [(vbuf, fmt, *names)], index_buffer=ibuf, index_element_size=4)
    for name, v in (("u_size", (w, h)), ("u_origin", packed.origin), ("u_pixel", packed.pixel),
                    ("u_epsilon", epsilon)):
        if name in prog:
            prog[name] = v
    t2 = time.perf_counter()
    fbo.use()
    fbo.viewport = (0, 0, w, h)
    fbo.clear(0.0, 0.0, 0.0, 0.0)
    ctx.enable(moderngl.BLEND)
    ctx.blend_func = moderngl.ONE, moderngl.ONE
    ctx.blend_equation = moderngl.FUNC_ADD
    try:
        if idx.size:
            vao.render(mode=moderngl.TRIANGLES, vertices=int(idx.size))
        ctx.finish()
    finally:
        ctx.disable(moderngl.BLEND)
    t3 = time.perf_counter()
    fbo.read_into(acc, components=4, dtype="f4")
    c = packed.values.shape[1]
    if mode == PupsMode.WEIGHTED_SUM:
        vals = acc[..., :c].copy()
    else:
        # sum(w T) / sum(w) as the compute path divides (float32), 0 where no weight
        wsum = acc[..., 3:4]
        with np.errstate(divide="ignore", invalid="ignore"):
            vals = acc[..., :c] / wsum
        vals[wsum[..., 0] == 0] = 0
    for o in (vao, vbuf, ibuf):
        o.release()
    t4 = time.perf_counter()
    timings.update(pack=t1 - t0, upload=t2 - t1, gpu=t3 - t2, readback=t4 - t3)
    return vals, None


# --------------------------------------------------------------------------------------------
# evaluation
# --------------------------------------------------------------------------------------------


@gl_call
def pups_evaluate(graph: PupsGraph, width, height, *, mode="interpolate", epsilon=0.5,
                  backend="gpu", tile=None, return_labels=False, timings=None,
                  method=None):
    """Evaluate a PUPs texture on a pixel grid covering the points' domain.

    Parameters
    ----------
    graph : PupsGraph
        From :func:`pups_graph`.
    width, height : int
        Image size in pixels, each in [1, 16384].
    mode : {"interpolate", "label", "weighted_sum"} or PupsMode
        ``interpolate``: weighted mean of the values (eq. 3); ``label``: the value of the
        heaviest point (cellular textures); ``weighted_sum``: sum of value * weight without
        normalising (with one-hot values it shows one point's weight, fig. 1).
    epsilon : float
        Orientation strength in [0, 1) (paper default 0.5).
    backend : {"gpu", "numpy"}
        Compute shader (float32) or the float64 reference.
    tile : int, optional
        Candidate-grid cell size in pixels (see :func:`pups_pack`).
    return_labels : bool
        Also return the label image (mode ``label`` only).
    timings : dict, optional
        Filled with stage times in seconds (``pack``, ``upload``, ``gpu``, ``readback``).
    method : {None, "raster", "compute"}
        GPU path (backend ``gpu``). ``compute``: the compute shader over candidate lists
        (``shaders/pups.comp``). ``raster`` (modes ``interpolate`` and ``weighted_sum``):
        each point's support polygon drawn as triangles, its data and axes passed as flat
        vertex outputs, weighted per fragment and summed by additive blending
        (``shaders/pups_raster.*``); same maths, same summation order, the same image. A set
        with more axes per point than the varying budget (:func:`_raster_pairs_limit`: 26
        axes on llvmpipe) falls back to ``compute``. Default None: ``raster`` where it
        applies, else ``compute`` (mode ``label``).

    Returns
    -------
    image : numpy.ndarray of float32, shape (height, width) or (height, width, 3)
        Per the values' channel count; 0 where no weight is non-zero.
    labels : numpy.ndarray of int32, shape (height, width)
        Only with ``return_labels``; -1 where no weight is non-zero.
    """
    if not isinstance(graph, PupsGraph):
        raise ValueError(f"graph must be a PupsGraph, got {type(graph).__name__}")
    mode = _parse_mode(mode)
    epsilon = _check_epsilon(epsilon)
    if backend not in ("gpu", "numpy"):
        raise ValueError(f"backend must be 'gpu' or 'numpy', got {backend!r}")
    if return_labels and mode != PupsMode.LABEL:
        raise ValueError("return_labels needs mode='label'")
    if method not in (None, "compute", "raster"):
        raise ValueError(f"method must be None, 'compute' or 'raster', got {method!r}")
    if method == "raster" and mode == PupsMode.LABEL:
        raise ValueError("method='raster' supports modes 'interpolate' and 'weighted_sum'")
    timings = {} if timings is None else timings
    t0 = time.perf_counter()
    raster = backend == "gpu" and method != "compute" and _raster_applies(graph, mode)
    packed = pups_pack(graph, width, height, tile=tile, grid=not raster)
    timings["grid"] = time.perf_counter() - t0
    if raster:
        vals, labs = _evaluate_raster(packed, mode, epsilon, timings)
    elif backend == "gpu":
        vals, labs = _evaluate_gpu(packed, mode, epsilon, timings)
    else:
        t1 = time.perf_counter()
        value, best, label, wsum = evaluate_reference(packed, packed.width, packed.height,
                                                      epsilon)
        vals = {PupsMode.INTERPOLATE: value, PupsMode.LABEL: best,
                PupsMode.WEIGHTED_SUM: wsum}[mode].astype(np.float32)
        labs = label
        timings["reference"] = time.perf_counter() - t1
    img = vals[..., 0] if vals.shape[-1] == 1 else vals
    img = np.ascontiguousarray(img, dtype=np.float32)
    if return_labels:
        return img, np.ascontiguousarray(labs, dtype=np.int32)
    return img


def _parse_mode(mode):
    if isinstance(mode, PupsMode):
        return mode
    if isinstance(mode, str) and mode.upper() in PupsMode.__members__:
        return PupsMode[mode.upper()]
    if isinstance(mode, (int, np.integer)) and not isinstance(mode, bool) and int(mode) in (0, 1, 2):
        return PupsMode(int(mode))
    raise ValueError(f"mode must be one of 'interpolate', 'label', 'weighted_sum', got {mode!r}")


def pups_presets():
    """Names of the built-in PUPs presets.

    Returns
    -------
    list of str
    """
    from .pups_presets import PUPS_PRESETS
    return sorted(PUPS_PRESETS)


def pups_render(preset_or_params, width, height, *, seed=0, backend="gpu") -> np.ndarray:
    """Render a PUPs preset (by name) or a parameter dict to an image.

    Parameters
    ----------
    preset_or_params : str or dict
        A name from :func:`pups_presets` (``"pups-cow"``; the ``pups-`` prefix is optional) or
        a JSON-able parameter dict as in :data:`cellgl.pups_presets.PUPS_PRESETS`.
    width, height : int
        Image size in pixels, each in [1, 16384].
    seed : int
        Seed for every random choice; same seed, same bits.
    backend : {"gpu", "numpy"}

    Returns
    -------
    numpy.ndarray of float32, shape (height, width) or (height, width, 3)
        Values in [0, 1] for the built-in presets.
    """
    from .pups_presets import build_pups
    return build_pups(preset_or_params, width, height, seed=seed, backend=backend)
