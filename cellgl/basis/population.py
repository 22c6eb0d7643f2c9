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


def _u(x) -> np.ndarray:
    return np.asarray(x, dtype=np.uint64) & M32


def _mul(a, b):
    return (_u(a) * _u(b)) & M32


def _add(a, b):
    return (_u(a) + _u(b)) & M32


# --------------------------------------------------------------------------- hash.glsl

def hash_u32(x):
    """``cell_hash_u32``: lowbias32 avalanche of uint32 values."""
    x = _u(x)
    x ^= x >> np.uint64(16)
    x = _mul(x, 0x7FEB352D)
    x ^= x >> np.uint64(15)
    x = _mul(x, 0x846CA68B)
    x ^= x >> np.uint64(16)
    return x


def u16(v):
    """``cell_u16``: a 16-bit value as a float in (0, 1), centred in its step."""
    return (_u(v).astype(np.float64) + 0.5) * (1.0 / 65536.0)


# --------------------------------------------------------------------------- points.glsl

_W96_TABLE: np.ndarray | None = None


def worley1996_table() -> np.ndarray:
    """The 256-entry 1996 population table, read from ``shaders/lib/points.glsl``
    (the one source of truth the GPU compiles)."""
    global _W96_TABLE
    if _W96_TABLE is None:
        from cellgl.gl import glsl

        text = (glsl.shader_dir() / "lib" / "points.glsl").read_text()
        body = re.search(r"_cell_w96_table\[256\]\s*=\s*int\[256\]\(([^)]*)\)", text).group(1)
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
