"""PUPs graph and support: Delaunay axes per control point (periodic sets with their 8 copies)
and the exact bounding box of each support polygon. Steps 2-3 of the pipeline in :mod:`cellgl.pups`."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from cellgl.pups.points import PupsPoints, check_positive

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
    from scipy.spatial import Delaunay     # here: `import cellgl` needs no SciPy (Blender's extension)

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
    f = check_positive("axis_factor", axis_factor, upper=16.0)
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
