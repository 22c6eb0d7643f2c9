"""PUPs control points: the point record, input checks, and the generators (Poisson-disk
sets, space giraffe, labels, orientations). Step 1 of the pipeline in :mod:`cellgl.pups`."""
from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum

import numpy as np

DEFAULT_DOMAIN = (-1.0, -1.0, 1.0, 1.0)


class PupsMode(IntEnum):
    """What a PUPs evaluation writes per pixel (the value of ``CELL_PUPS_MODE`` in the shader)."""

    INTERPOLATE = 0  #: weighted mean of values, eq. (3)
    LABEL = 1  #: value and label of the heaviest point
    WEIGHTED_SUM = 2  #: sum of value * weight, not normalised (shows raw weights)


# --------------------------------------------------------------------------------------------
# validation helpers
# --------------------------------------------------------------------------------------------


# The argument checks the generators, graphs, packing and synthesis share: each returns the value
# normalised or raises ValueError naming it and the accepted range.

def check_domain(domain):
    """``(x0, y0, x1, y1)`` as floats: finite, non-empty."""
    try:
        x0, y0, x1, y1 = (float(v) for v in domain)
    except (TypeError, ValueError):
        raise ValueError(f"domain must be (x0, y0, x1, y1), got {domain!r}") from None
    if not (np.isfinite([x0, y0, x1, y1]).all() and x1 > x0 and y1 > y0):
        raise ValueError(f"domain must be finite with x1 > x0 and y1 > y0, got {domain!r}")
    return (x0, y0, x1, y1)


def check_size(width, height):
    """``(width, height)``: integers in [1, 16384]."""
    for name, v in (("width", width), ("height", height)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
            raise ValueError(f"{name} must be an integer in [1, 16384], got {v!r}")
        if not 1 <= int(v) <= 16384:
            raise ValueError(f"{name} must be in [1, 16384], got {v}")
    return int(width), int(height)


def check_positive(name, v, upper=None):
    """``v`` as a float > 0 (and <= ``upper``)."""
    try:
        f = float(v)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number > 0, got {v!r}") from None
    if not math.isfinite(f) or f <= 0 or (upper is not None and f > upper):
        rng = f"(0, {upper}]" if upper is not None else "> 0"
        raise ValueError(f"{name} must be {rng}, got {v!r}")
    return f


def check_epsilon(epsilon):
    """``epsilon`` as a float in [0, 1)."""
    try:
        e = float(epsilon)
    except (TypeError, ValueError):
        raise ValueError(f"epsilon must be in [0, 1), got {epsilon!r}") from None
    if not 0.0 <= e < 1.0:
        raise ValueError(f"epsilon must be in [0, 1), got {epsilon!r}")
    return e


def as_rng(seed):
    """A NumPy generator: ``seed`` itself if it is one, else one seeded with it."""
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

    def replace(self, **changes) -> PupsPoints:
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
    domain = check_domain(domain)
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
