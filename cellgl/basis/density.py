"""Spatially varying feature density: :class:`DensityMap` and its exact integer encoding.

Worley (1996) notes that the density of feature points may vary over space ("small, dense
features in one area and larger in another"). A density map gives every integer cell of the
lattice a **level** ``L`` in 0..15, and the Poisson count of the cell is drawn from the
population table of density

    density_L = density_min * (density_max / density_min) ** (L / 15)

(geometric steps: equal ratios of cell size between neighbouring levels). The 16 tables are
computed here in Python (:func:`cellgl.basis.reference.poisson_thresholds`) and passed to the GPU as a
16 x 16 uint32 table, one row per level.

The level of a cell is a function of the cell's **centre** ``c + 0.5`` (lattice units), but it
is computed with integer arithmetic only, so the GPU (any GPU) and the NumPy reference agree on
every cell, bit for bit. Each lattice axis ``a`` carries a fixed-point affine term

    e_a(c) = ((2 clamp(c_a - o_a, 0, n_a) + 1) m_a + b_a) >> shift

(``o, n``: a window of cells outside which the map is constant; ``m, b``: the affine map from
the cell centre ``(2t + 1) / 2`` to map units, scaled by ``2^shift`` and rounded; ``>>``:
arithmetic shift, i.e. floor). All values stay below 2^30, so int32 never overflows. Then

* ``ramp``: ``L = clamp(sum_a e_a, 0, 15)``, with ``e`` in level units: ``v = (x - start) /
  (end - start)`` along ``axis``, ``L = floor(15 v + 0.5)`` (rounded to 2^-shift);
* ``radial``: ``e_a`` in units of ``radius / 15360``, clamped to +-15361; ``L = #{k in 1..15 :
  sum e_a^2 >= ((2k - 1) 512)^2}``, i.e. ``L = floor(15 d / radius + 0.5)`` clamped to 15;
* ``image``: ``e_0, e_1`` are the texel column and row (nearest texel at the cell centre,
  clamped to the edge; row 0 at ``y0``); the image is quantised to levels
  ``floor(15 value + 0.5)`` here, and the GPU reads the level from a storage buffer.
"""
from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from cellgl.basis.arrays import real_array
from cellgl.basis.enums import DensityMapKind
from cellgl.basis.population import MAX_POINTS, poisson_thresholds

__all__ = ["DensityMap", "DensityEncoding", "KINDS", "LEVELS", "encode", "levels_reference"]

LEVELS = 16                     #: CELL_DENSITY_LEVELS
KINDS = ("ramp", "radial", "image")
#: CELL_DMAP_* values (0: no map)
KIND_CODES = {m.name.lower(): int(m) for m in DensityMapKind}
RADIAL_UNIT = 512               #: radius = 30 * RADIAL_UNIT units
RADIAL_R = 30 * RADIAL_UNIT     #: 15360
MAX_IMAGE_SIDE = 4096
_LIMIT = 2 ** 30
_COORD = 2.0 ** 30


def _real(name, value, lo=None, hi=None, *, lo_open=False):
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(float(value)):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    v = float(value)
    if (lo is not None and (v < lo or (lo_open and v <= lo))) or (hi is not None and v > hi):
        lo_b = "(" if lo_open else "["
        raise ValueError(f"{name} must be in {lo_b}{lo}, {hi}], got {value!r}")
    return v


@dataclass(frozen=True, eq=False)
class DensityMap:
    """A spatially varying density of feature points (``distribution="poisson"`` only).

    Parameters
    ----------
    kind : {"ramp", "radial", "image"}
    density_min, density_max : float in (0, 16]
        Mean points per cell where the map value is 0 and 1 (``density_min > density_max``
        is allowed and reverses the map).
    axis : int, ramp only
        Lattice axis of the ramp (0 = x, 1 = y, 2 = z, 3 = w).
    start, end : float, ramp only
        Map value 0 at ``start`` and 1 at ``end`` along ``axis`` (lattice units; clamped outside).
    center : sequence of 1..4 floats, radial only
        Centre of the map (lattice units, (x, y, ...)); axes past its length do not count.
    radius : float > 0, radial only
        Map value 0 at the centre, 1 at ``radius`` and beyond (lattice units).
    image : array_like (h, w) float in [0, 1], image only
        Grayscale map, row 0 at ``y0``; sides 1..4096.
    rect : (x0, y0, x1, y1), image only
        The lattice rectangle the image covers (x0 < x1, y0 < y1); outside it the edge
        texels continue. The nearest texel to each cell centre gives the cell's level.
    """

    kind: str
    density_min: float = 0.5
    density_max: float = 8.0
    axis: int = 0
    start: float = 0.0
    end: float = 1.0
    center: tuple = (0.0, 0.0)
    radius: float = 1.0
    image: np.ndarray | None = field(default=None, repr=False)
    rect: tuple = (0.0, 0.0, 1.0, 1.0)

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"unknown density map kind {self.kind!r}; expected one of: {', '.join(KINDS)}")
        set_ = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731
        set_("density_min", _real("density_min", self.density_min, 0.0, 16.0, lo_open=True))
        set_("density_max", _real("density_max", self.density_max, 0.0, 16.0, lo_open=True))
        if self.kind == "ramp":
            if isinstance(self.axis, bool) or not isinstance(self.axis, numbers.Integral) or not 0 <= self.axis <= 3:
                raise ValueError(f"axis must be an integer in [0, 3], got {self.axis!r}")
            s = _real("start", self.start, -_COORD, _COORD)
            e = _real("end", self.end, -_COORD, _COORD)
            if s == e:
                raise ValueError(f"start and end must differ, got start = end = {s!r}")
            set_("start", s)
            set_("end", e)
        elif self.kind == "radial":
            c = tuple(np.atleast_1d(np.asarray(self.center, dtype=object)).tolist())
            if not 1 <= len(c) <= 4:
                raise ValueError(f"center must have 1..4 coordinates, got {self.center!r}")
            set_("center", tuple(_real("center", v, -_COORD, _COORD) for v in c))
            set_("radius", _real("radius", self.radius, 0.0, 2.0 ** 20, lo_open=True))
        else:
            img = real_array("image", [] if self.image is None else self.image,
                             "of shape (h, w) with values in [0, 1]")
            if self.image is None or img.ndim != 2 or not (1 <= img.shape[0] <= MAX_IMAGE_SIDE
                                                           and 1 <= img.shape[1] <= MAX_IMAGE_SIDE):
                raise ValueError(f"image must have shape (h, w) with 1 <= h, w <= {MAX_IMAGE_SIDE}, "
                                 f"got {None if self.image is None else img.shape}")
            if not np.all(np.isfinite(img)) or img.min() < 0.0 or img.max() > 1.0:
                raise ValueError(f"image values must be finite and in [0, 1], got range "
                                 f"[{np.nanmin(img)}, {np.nanmax(img)}]")
            set_("image", img)
            try:
                r = tuple(self.rect)
            except TypeError:
                r = ()
            if len(r) != 4:
                raise ValueError(f"rect must be (x0, y0, x1, y1), got {self.rect!r}")
            r = tuple(_real("rect", v) for v in r)      # refuses bool, complex, text, nan
            if not all(abs(v) < _COORD for v in r) \
                    or not (r[0] < r[2] and r[1] < r[3]):
                raise ValueError(f"rect must be (x0, y0, x1, y1) with x0 < x1, y0 < y1, finite, got {self.rect!r}")
            set_("rect", r)

    def level_densities(self) -> np.ndarray:
        """float64 (16,): the density of each level."""
        L = np.arange(LEVELS) / (LEVELS - 1)
        return self.density_min * (self.density_max / self.density_min) ** L

    def scaled(self, scale: float, offset=(0.0, 0.0, 0.0, 0.0)) -> DensityMap:
        """The same map seen from a lattice ``x' = scale * (x + offset)`` (an octave of a
        texture: its lattice is the basis lattice times lacunarity^i)."""
        o = tuple(offset) + (0.0,) * (4 - len(tuple(offset)))
        kw: dict[str, Any] = dict(kind=self.kind, density_min=self.density_min, density_max=self.density_max)
        if self.kind == "ramp":
            return DensityMap(**kw, axis=self.axis, start=scale * (self.start + o[self.axis]),
                              end=scale * (self.end + o[self.axis]))
        if self.kind == "radial":
            return DensityMap(**kw, center=tuple(scale * (c + o[a]) for a, c in enumerate(self.center)),
                              radius=scale * self.radius)
        x0, y0, x1, y1 = self.rect
        return DensityMap(**kw, image=self.image, rect=(scale * (x0 + o[0]), scale * (y0 + o[1]),
                                                        scale * (x1 + o[0]), scale * (y1 + o[1])))


@dataclass(frozen=True, eq=False)
class DensityEncoding:
    """The integer form of a :class:`DensityMap` that the shaders and the reference read.

    kind : int (CELL_DMAP_*); axes : int64 (4, 4) rows (o, n, m, b); shift : int;
    size : (w, h) of the image (0, 0 otherwise); levels : uint32 (h * w,) image levels or None;
    thresholds : uint32 (16, 16), row L = Poisson table of level L.
    """

    kind: int
    axes: np.ndarray
    shift: int
    size: tuple
    levels: np.ndarray | None
    thresholds: np.ndarray

    @property
    def info(self) -> tuple:
        """``density_info``: (shift, image width, image height, 0)."""
        return (int(self.shift), int(self.size[0]), int(self.size[1]), 0)


def _affine(lo: float, hi: float, target_lo: float, target_hi: float):
    """Window and real affine map for one axis: cell centre x -> target, with x = lo -> target_lo
    and x = hi -> target_hi (lo < hi). Returns (o, n, slope per half-cell, value at t = 0 edge)."""
    o = math.floor(lo) - 1
    n = math.ceil(hi - lo) + 3
    k = (target_hi - target_lo) / (hi - lo)          # map units per cell
    # target(x) = target_lo + k (x - lo), x = o + (2t + 1) / 2
    return o, n, k / 2.0, target_lo + k * (o - lo)


def _encode_axes(specs):
    """specs: per axis None or (o, n, half_slope, base). Picks the largest shift that keeps every
    intermediate below 2^30 and returns (axes (4, 4) int64, shift)."""
    for shift in range(24, -1, -1):
        rows = np.zeros((4, 4), dtype=np.int64)
        ok = True
        for a, s in enumerate(specs):
            if s is None:
                continue
            o, n, hs, base = s
            m = round(hs * 2 ** shift)
            b = round(base * 2 ** shift)
            worst = max(abs(m) * (2 * n + 1) + abs(b), abs(m), abs(b), abs(o), n)
            if worst >= _LIMIT or abs(o) + n >= 2 ** 31 - 1:
                ok = False
                break
            rows[a] = (o, n, m, b)
        if ok:
            return rows, shift
    raise ValueError("density map too large for its 32-bit integer encoding (shrink the ramp, "
                     "radius or image rectangle)")


def encode(dm: DensityMap, dim: int) -> DensityEncoding:
    """Encode ``dm`` for a ``dim``-dimensional lattice (validates the map against ``dim``)."""
    if not isinstance(dm, DensityMap):
        raise ValueError(f"density_map must be None or a cellgl.DensityMap, got {type(dm).__name__}")
    specs = [None] * 4
    size, levels = (0, 0), None
    if dm.kind == "ramp":
        if dm.axis >= dim:
            raise ValueError(f"density map axis must be in [0, {dim - 1}] for {dim}D points, got {dm.axis}")
        lo, hi = sorted((dm.start, dm.end))
        # level target: 15 v + 0.5, v = (x - start) / (end - start)
        t_lo = 15.0 * (lo - dm.start) / (dm.end - dm.start) + 0.5
        t_hi = 15.0 * (hi - dm.start) / (dm.end - dm.start) + 0.5
        specs[dm.axis] = _affine(lo, hi, t_lo, t_hi)
    elif dm.kind == "radial":
        if len(dm.center) > dim:
            raise ValueError(f"density map center must have at most {dim} coordinates for {dim}D "
                             f"points, got {len(dm.center)}")
        for a, c in enumerate(dm.center):
            specs[a] = _affine(c - dm.radius, c + dm.radius, -float(RADIAL_R), float(RADIAL_R))
    else:
        assert dm.image is not None     # __post_init__ checked it for kind "image"
        h, w = dm.image.shape
        x0, y0, x1, y1 = dm.rect
        specs[0] = _affine(x0, x1, 0.0, float(w))
        specs[1] = _affine(y0, y1, 0.0, float(h))
        size = (w, h)
        levels = np.floor(dm.image * (LEVELS - 1) + 0.5).astype(np.uint32).ravel()
    axes, shift = _encode_axes(specs)
    table = np.stack([poisson_thresholds(float(d)) for d in dm.level_densities()]).astype(np.uint32)
    assert table.shape == (LEVELS, MAX_POINTS)
    return DensityEncoding(KIND_CODES[dm.kind], axes, shift, size, levels, table)


def levels_reference(cells: np.ndarray, enc: DensityEncoding) -> np.ndarray:
    """``cell_density_level``: the level (int64 (N,)) of each cell (N, 4) int64 (already wrapped)."""
    cells = np.asarray(cells, dtype=np.int64)
    e = np.zeros((len(cells), 4), dtype=np.int64)
    for a in range(4):
        o, n, m, b = (int(v) for v in enc.axes[a])
        t = np.clip(cells[:, a] - o, 0, n)
        e[:, a] = ((2 * t + 1) * m + b) >> enc.shift
    if enc.kind == KIND_CODES["ramp"]:
        return np.clip(e.sum(axis=1), 0, LEVELS - 1)
    if enc.kind == KIND_CODES["radial"]:
        ec = np.clip(e, -RADIAL_R - 1, RADIAL_R + 1)
        d2 = (ec * ec).sum(axis=1)
        k = np.arange(1, LEVELS)
        return (d2[:, None] >= ((2 * k - 1) * RADIAL_UNIT) ** 2).sum(axis=1).astype(np.int64)
    assert enc.levels is not None   # kind "image" carries its levels
    w, h = enc.size
    tx = np.clip(e[:, 0], 0, w - 1)
    ty = np.clip(e[:, 1], 0, h - 1)
    return enc.levels[ty * w + tx].astype(np.int64)
