"""NumPy float64 twin of ``shaders/lib/pups.glsl``: PUPs weights, function for function.

The names match the GLSL (``cell_pups_axial`` here is ``cell_pups_axial`` there). The GPU
evaluates in float32, so results agree to float32 rounding; labels agree exactly except
where the two heaviest weights tie within that rounding.

See :mod:`cellgl.pups` for the public API; this module is the arithmetic only.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "cell_pups_axial",
    "cell_pups_project",
    "cell_pups_weight",
    "cell_pups_orient",
    "evaluate_reference",
]


def cell_pups_axial(p):
    """Axial weight ``A(p) = (1 - p)^2 (1 + 2p)`` of eq. (1), ``p`` clamped to [0, 1].

    Parameters
    ----------
    p : array_like of float
        Normalised projections, any shape.

    Returns
    -------
    numpy.ndarray of float64
        Same shape as ``p``; 1 at ``p <= 0``, 0 at ``p >= 1``.
    """
    p = np.clip(np.asarray(p, dtype=np.float64), 0.0, 1.0)
    q = 1.0 - p
    return q * q * (1.0 + 2.0 * p)


def cell_pups_project(d, axis_scaled):
    """Normalised projection of ``d = u - c`` on a pre-scaled axis, clamped to [0, 1].

    Parameters
    ----------
    d : array_like, shape (..., 2)
        Offsets from the control point.
    axis_scaled : array_like, shape (2,)
        ``axis / (factor * |axis|^2)``.

    Returns
    -------
    numpy.ndarray of float64, shape (...)
    """
    d = np.asarray(d, dtype=np.float64)
    a = np.asarray(axis_scaled, dtype=np.float64)
    return np.clip(d[..., 0] * a[0] + d[..., 1] * a[1], 0.0, 1.0)


def cell_pups_weight(d, axes_scaled):
    """Unshifted weight of eq. (2): product of axial weights over a point's axes.

    Parameters
    ----------
    d : array_like, shape (..., 2)
        Offsets ``u - c``.
    axes_scaled : array_like, shape (n_axes, 2)
        The point's pre-scaled axes.

    Returns
    -------
    numpy.ndarray of float64, shape (...)
    """
    d = np.asarray(d, dtype=np.float64)
    w = np.ones(d.shape[:-1])
    for a in np.asarray(axes_scaled, dtype=np.float64):
        w *= cell_pups_axial(cell_pups_project(d, a))
    return w


def cell_pups_orient(w, d, v, epsilon):
    """Orientation shift of eq. (4).

    ``eta = d.v / |d|`` (0 at ``d = 0``), ``K = epsilon * eta``;
    ``w' = w^(1 - K)`` for ``K >= 0`` and ``w^(1 / (1 + K))`` otherwise.

    Parameters
    ----------
    w : array_like of float, shape (...)
        Weights in [0, 1].
    d : array_like, shape (..., 2)
        Offsets ``u - c``.
    v : array_like, shape (2,)
        The xy part of the point's orientation (a unit vector in R^3).
    epsilon : float
        Shift strength in [0, 1).

    Returns
    -------
    numpy.ndarray of float64, shape (...)
    """
    w = np.asarray(w, dtype=np.float64)
    d = np.asarray(d, dtype=np.float64)
    length = np.hypot(d[..., 0], d[..., 1])
    dot = d[..., 0] * v[0] + d[..., 1] * v[1]
    eta = np.divide(dot, length, out=np.zeros_like(dot), where=length > 0)
    k = epsilon * eta
    e = np.where(k >= 0, 1.0 - k, 1.0 / (1.0 + k))
    with np.errstate(divide="ignore"):
        return np.where(w > 0, np.power(np.where(w > 0, w, 1.0), e), 0.0)


def evaluate_reference(packed, width, height, epsilon):
    """Evaluate packed PUPs instances on a pixel grid, in float64.

    Visits the instances in index order and keeps the first heaviest on exact ties,
    as the GPU does with its index-ordered candidate lists.

    Parameters
    ----------
    packed : cellgl.pups.PupsPacked
        Instances (control points and their periodic copies), axes and pixel ranges.
    width, height : int
        Image size in pixels.
    epsilon : float
        Orientation strength in [0, 1).

    Returns
    -------
    value : numpy.ndarray of float64, shape (height, width, C)
        Interpolated value (eq. 3); 0 where no weight is non-zero.
    best : numpy.ndarray of float64, shape (height, width, C)
        Value of the heaviest point.
    label : numpy.ndarray of int32, shape (height, width)
        Label of the heaviest point; -1 where no weight is non-zero.
    weighted_sum : numpy.ndarray of float64, shape (height, width, C)
        Sum of value * weight, not normalised.
    """
    c = packed.values.shape[1]
    acc = np.zeros((height, width, c))
    wsum = np.zeros((height, width))
    wmax = np.zeros((height, width))
    label = np.full((height, width), -1, dtype=np.int32)
    best = np.zeros((height, width, c))
    x0, y0 = packed.origin
    px, py = packed.pixel
    for k in range(packed.positions.shape[0]):
        i0, j0, i1, j1 = packed.pixel_box[k]
        if i1 < i0 or j1 < j0:
            continue
        xs = x0 + np.arange(i0, i1 + 1) * px
        ys = y0 + np.arange(j0, j1 + 1) * py
        d = np.empty((ys.size, xs.size, 2))
        d[..., 0] = xs[None, :] - packed.positions[k, 0]
        d[..., 1] = ys[:, None] - packed.positions[k, 1]
        a0, na = packed.axis_begin[k], packed.axis_count[k]
        w = cell_pups_weight(d, packed.axes_scaled[a0:a0 + na])
        w = cell_pups_orient(w, d, packed.orient[k], epsilon)
        sl = (slice(j0, j1 + 1), slice(i0, i1 + 1))
        acc[sl] += w[..., None] * packed.values[k]
        wsum[sl] += w
        better = w > wmax[sl]
        wmax[sl] = np.where(better, w, wmax[sl])
        label[sl] = np.where(better, packed.labels[k], label[sl])
        best[sl] = np.where(better[..., None], packed.values[k], best[sl])
    value = np.divide(acc, wsum[..., None], out=np.zeros_like(acc), where=wsum[..., None] > 0)
    return value, best, label, acc
