"""Integer hashing and point populations: the NumPy twin of ``shaders/lib/hash.glsl`` and the
population tables of ``shaders/lib/points.glsl`` (uint32 arithmetic wraps as in GLSL).

The lowest piece of the basis: :mod:`cellgl.basis.density` and :mod:`cellgl.basis.reference`
both build on it.
"""
from __future__ import annotations

import math
import re

import numpy as np

M32 = np.uint64(0xFFFFFFFF)
MAX_POINTS = 16        #: CELL_MAX_POINTS: the largest allowed ``max_points``
BIG = 3.0e38           #: "no point yet" distance, as in the GLSL
W96_DENSITY_ADJUSTMENT = 0.398150


def as_u32(x) -> np.ndarray:
    """``x`` as GLSL's uint32 holds it (uint64 values below 2^32: the low 32 bits)."""
    return np.asarray(x, dtype=np.uint64) & M32


def mul_u32(a, b):
    """``a * b`` in uint32, wrapping as GLSL does."""
    return (as_u32(a) * as_u32(b)) & M32


def add_u32(a, b):
    """``a + b`` in uint32, wrapping as GLSL does."""
    return (as_u32(a) + as_u32(b)) & M32


# --------------------------------------------------------------------------- hash.glsl

def hash_u32(x):
    """``cell_hash_u32``: lowbias32 avalanche of uint32 values (as uint64). Computed in uint32,
    which wraps as GLSL's does."""
    x = as_u32(x).astype(np.uint32)
    with np.errstate(over="ignore"):        # (a 0-d input's scalar product says it wraps)
        x ^= x >> np.uint32(16)
        x *= np.uint32(0x7FEB352D)
        x ^= x >> np.uint32(15)
        x *= np.uint32(0x846CA68B)
        x ^= x >> np.uint32(16)
    return x.astype(np.uint64)


def u16(v):
    """``cell_u16``: a 16-bit value as a float in (0, 1), centred in its step."""
    return (as_u32(v).astype(np.float64) + 0.5) * (1.0 / 65536.0)


# --------------------------------------------------------------------------- points.glsl

_W96_TABLE: np.ndarray | None = None


def worley1996_table() -> np.ndarray:
    """The 256-entry 1996 population table, read from ``shaders/lib/points.glsl``
    (the one source of truth the GPU compiles)."""
    global _W96_TABLE
    if _W96_TABLE is None:
        from cellgl.gl import glsl

        text = (glsl.shader_dir() / "lib" / "points.glsl").read_text()
        found = re.search(r"_cell_w96_table\[256\]\s*=\s*int\[256\]\(([^)]*)\)", text)
        assert found is not None, "points.glsl lost _cell_w96_table[256]"
        body = found.group(1)
        _W96_TABLE = np.array([int(v) for v in body.replace("\n", " ").split(",")], dtype=np.int64)
        assert _W96_TABLE.shape == (256,)
    return _W96_TABLE


def poisson_thresholds(density: float) -> np.ndarray:
    """Population table of a Poisson process, in run-length form.

    Returns uint32 (MAX_POINTS,) with ``t[k] = floor(2**32 * P(X <= k))`` for
    ``X ~ Poisson(density)``: a uniform 32-bit hash value ``u`` maps to the count
    ``k`` with ``t[k-1] <= u < t[k]``, which is Worley's 256-entry table indexed
    by hash bits, with 2**32 entries instead of 256.
    """
    cdf = 0.0
    out = np.zeros(MAX_POINTS, dtype=np.uint64)
    for k in range(MAX_POINTS):
        cdf += math.exp(-density + k * math.log(density) - math.lgamma(k + 1))
        out[k] = min(int(math.floor(min(cdf, 1.0) * 4294967296.0)), 0xFFFFFFFF)
    return out.astype(np.uint32)


# --------------------------------------------------------------------------- Blender's points

def _rot(x, k: int):
    """Rotate uint32 values (uint32 arrays) left by k bits."""
    return (x << np.uint32(k)) | (x >> np.uint32(32 - k))


def _jenkins_final(a, b, c):
    """Bob Jenkins' lookup3 final mix of three uint32 words (uint32 arrays); returns c."""
    w = {"a": a, "b": b, "c": c}
    for x, y, k in (("c", "b", 14), ("a", "c", 11), ("b", "a", 25), ("c", "b", 16),
                    ("a", "c", 4), ("b", "a", 14), ("c", "b", 24)):
        w[x] = (w[x] ^ w[y]) - _rot(w[y], k)       # x ^= y; x -= rot(y, k)
    return w["c"]


def _jenkins_mix(a, b, c):
    """lookup3's reversible mix of three uint32 words (used before the last word of 4)."""
    w = {"a": a, "b": b, "c": c}
    for x, y, z, k in (("a", "c", "b", 4), ("b", "a", "c", 6), ("c", "b", "a", 8),
                       ("a", "c", "b", 16), ("b", "a", "c", 19), ("c", "b", "a", 4)):
        # x -= y; x ^= rot(y, k); y += z
        w[x] = (w[x] - w[y]) ^ _rot(w[y], k)
        w[y] = w[y] + w[z]
    return w["a"], w["b"], w["c"]


def jenkins_hash(*words):
    """lookup3 hash of 1..4 uint32 words (arrays broadcast), as Blender hashes a cell's float bits;
    uint64 values < 2^32 (computed in uint32 arithmetic, which wraps as lookup3's does)."""
    n = len(words)
    u = [np.asarray(as_u32(x)).astype(np.uint32) for x in words]
    init = np.asarray(0xDEADBEEF + (n << 2) + 13, dtype=np.uint32)
    a = b = c = init
    with np.errstate(over="ignore"):
        if n == 4:
            a, b, c = a + u[0], b + u[1], c + u[2]
            a, b, c = _jenkins_mix(a, b, c)
            a = a + u[3]
        else:
            a = a + u[0]
            if n >= 2:
                b = b + u[1]
            if n >= 3:
                c = c + u[2]
        c = _jenkins_final(a, b, c)
    return np.asarray(c).astype(np.uint64)


def float_bits(x) -> np.ndarray:
    """The IEEE bits of float32 values, as uint64 (``floatBitsToUint``)."""
    return np.asarray(x, dtype=np.float32).view(np.uint32).astype(np.uint64)


def unit_float(h) -> np.ndarray:
    """A uint32 hash as Blender's float in [0, 1]: float32(h) / 2^32 (float32, rounded to nearest)."""
    return (as_u32(h).astype(np.float32) * np.float32(1.0 / 4294967296.0)).astype(np.float32)


_ONE, _TWO = 0x3F800000, 0x40000000      # float bits of 1.0 and 2.0

#: Blender hashes a cell's coordinates as float32, whose 24-bit mantissa holds every integer
#: only below 2^24: from there on neighbouring cells hash alike (2^25, 2^25 + 1 and 2^25 + 2 get
#: one point and one ID), in Blender as here. docs/blender.md, "Far from the origin".
BLENDER_HASH_LIMIT = 2.0 ** 24
_BLENDER_REACH = 3.0    #: cells beyond the sample's whose points the node's window reads


def warn_blender_far(extent: float, stacklevel: int = 3) -> None:
    """RuntimeWarning if samples ``extent`` cells from the origin (the largest |coordinate|,
    in cells) read cells Blender's float hash cannot tell apart."""
    if extent + _BLENDER_REACH >= BLENDER_HASH_LIMIT:
        import warnings

        warnings.warn(
            f"distribution 'blender' at {extent:.4g} cells from the origin: beyond 2^24 = 16777216 "
            "cells Blender's float hash gives neighbouring cells the same point and ID (as Blender "
            "itself does), so the cells repeat; for distinct cells there (not Blender's points) use "
            "distribution 'jitter' (one point per cell, integer hash, exact to +-2^30 cells)",
            RuntimeWarning, stacklevel=stacklevel)


def blender_cell_words(cells, dim: int) -> list:
    """The float bits of each cell coordinate (cells (N, >= dim) int)."""
    c = np.asarray(cells)
    return [float_bits(c[:, a].astype(np.float32)) for a in range(dim)]


def blender_point(cells, dim: int) -> np.ndarray:
    """Blender's feature point of each integer cell, before Randomness: float32 (N, dim) in
    [0, 1], the hash of the cell's coordinates as floats (x from one hash, y, z, w from the same
    coordinates with a constant or a rotation appended)."""
    k = blender_cell_words(cells, dim)
    one, two = as_u32(_ONE), as_u32(_TWO)
    if dim == 1:
        hs = [jenkins_hash(k[0])]
    elif dim == 2:
        hs = [jenkins_hash(k[0], k[1]), jenkins_hash(k[0], k[1], one)]
    elif dim == 3:
        hs = [jenkins_hash(*k), jenkins_hash(*k, one), jenkins_hash(*k, two)]
    else:
        x, y, z, w = k
        hs = [jenkins_hash(x, y, z, w), jenkins_hash(w, x, y, z), jenkins_hash(z, w, x, y),
              jenkins_hash(y, z, w, x)]
    return np.stack([unit_float(h) for h in hs], axis=1)


def blender_id(cells, dim: int) -> np.ndarray:
    """The ID of Blender's point in each cell: the hash of its coordinates (the first of
    :func:`blender_point`'s hashes, and of :func:`blender_color`'s), uint64 values < 2^32."""
    return jenkins_hash(*blender_cell_words(cells, dim))


def blender_color(cells, dim: int) -> np.ndarray:
    """Blender's colour of each integer cell: float32 (N, 3) in [0, 1], three hashes of the
    cell's coordinates as floats."""
    k = blender_cell_words(cells, dim)
    one, two = as_u32(_ONE), as_u32(_TWO)
    if dim == 1:
        hs = [jenkins_hash(k[0]), jenkins_hash(k[0], one), jenkins_hash(k[0], two)]
    elif dim == 2:
        hs = [jenkins_hash(k[0], k[1]), jenkins_hash(k[0], k[1], one), jenkins_hash(k[0], k[1], two)]
    elif dim == 3:
        hs = [jenkins_hash(*k), jenkins_hash(*k, one), jenkins_hash(*k, two)]
    else:
        x, y, z, w = k
        hs = [jenkins_hash(x, y, z, w), jenkins_hash(z, x, w, y), jenkins_hash(w, z, y, x)]
    return np.stack([unit_float(h) for h in hs], axis=1)


def blender_owner_cells(lattice_pos, ids, dim: int) -> np.ndarray:
    """The integer cell of each Blender point (N, dim) int64, from its position (N, >= dim) in
    lattice units and its ID (the hash of its cell, :func:`blender_id`): the cell holding the
    position, or the neighbour whose hash is the ID where the point lies on a face (a hash of
    1.0, or the rounding of a float32 offset)."""
    import itertools

    cells = np.floor(np.asarray(lattice_pos, dtype=np.float64)[:, :dim]).astype(np.int64)
    ids = as_u32(ids)
    rows = np.nonzero(blender_id(cells, dim) != ids)[0]
    for o in itertools.product((-1, 0, 1), repeat=dim):
        if not len(rows):
            break
        cand = cells[rows] + np.array(o)
        hit = blender_id(cand, dim) == ids[rows]
        cells[rows[hit]] = cand[hit]
        rows = rows[~hit]
    return cells
