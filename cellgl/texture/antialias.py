"""Antialiasing of texture recipes: band-limited fractals and supersampled bakes.

Band limit (Qin's ``smoothscale``)
----------------------------------
Qin (2000, eq. 7) multiplies each octave of the cloud fractal by ``smoothscale(2^i x)``, a
factor that depends on "the differential surface area" at the point (the pixel's footprint),
so that octaves finer than a pixel fade out instead of aliasing. cellgl does the same for every
fractal mode (``shaders/lib/texture.glsl``, ``cell_texture_filtered``): with the footprint ``r``
(the pixel's size in basis units) and ``feature_frequency`` (:func:`feature_frequency`), octave
``i`` spans ``w_i = antialias * feature_frequency * L^i * r`` feature spacings per pixel and
its term (``b`` or ``|0.5 - b|``) becomes ``a_i term + (1 - a_i) octave_mean`` with
``a_i = 1 - smoothstep(0.5, 1, w_i)`` (:func:`smoothscale`) and ``octave_mean`` the term's
mean over the plane (:func:`cellgl.texture.reference.octave_mean`). The weights and their sum
are untouched, so a bake large enough that every ``a_i = 1`` is unchanged, bit for bit.

The footprint comes from the bake (``1 / W`` of a W-pixel side, divided by the supersampling
grid), from derivatives (``fwidth`` in the viewer and in the snippets' ``cellgl_texture(uv)``) or
from the caller (:func:`cellgl.texture.evaluate`'s ``filter_width``; default 0: point samples).

Supersampling
-------------
``samples = n^2`` (1, 4, 9, ... 64) averages colour, height, gradient and normal (renormalised)
over the centres of an ``n x n`` grid of sub-pixels (stratified and deterministic: the same
offsets every pixel, so tiles stay bit-identical to one-pass bakes); ``id``, ``F1``..``F4`` and
``value`` stay those of the pixel centre. Each sub-sample is band-limited to its own footprint
(the pixel's over ``n``).
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["AA_LO", "AA_HI", "MAX_SAMPLES", "smoothscale", "feature_frequency", "check_samples", "grid_side",
           "subsample_offsets"]

#: the band limit starts fading an octave at AA_LO feature spacings per pixel and ends at AA_HI
#: (the GLSL's CELL_TEX_AA_LO / CELL_TEX_AA_HI; a test checks they agree)
AA_LO = 0.5
AA_HI = 1.0
#: most samples per pixel of a supersampled bake (an 8 x 8 grid)
MAX_SAMPLES = 64


def smoothscale(w) -> np.ndarray:
    """``cell_texture_smoothscale``: ``1 - smoothstep(AA_LO, AA_HI, w)`` (float64)."""
    x = np.clip((np.asarray(w, dtype=np.float64) - AA_LO) / (AA_HI - AA_LO), 0.0, 1.0)
    return 1.0 - x * x * (3.0 - 2.0 * x)


def fades(values, duvz) -> bool:
    """Whether a sample of footprint ``duvz`` (texture space; the largest of a pass) may fade an
    octave (``a_i < 1``). If not, every ``a_i`` is exactly 1 (smoothstep below ``AA_LO`` is 0),
    each term is ``1 term + 0 octave_mean``, and the octave mean is never needed: a GPU pass then
    skips measuring it (:func:`cellgl.texture.reference.octave_mean`, NumPy) and carries 0.
    Conservative: the float64 bound with a margin far above float32's rounding."""
    f = float(values["frequency"])
    d = [abs(float(c)) for c in duvz] + [0.0] * (3 - len(duvz))
    r = max(d[0] * f, d[1] * f * float(values["aspect"]), d[2] * f)
    n = 1 if values["fractal"] == "none" else math.ceil(float(values["octaves"]))
    top = max(1.0, float(values["lacunarity"]) ** (n - 1))
    return float(values["antialias"]) * feature_frequency(values) * r * top > AA_LO * (1.0 - 1e-4)


def feature_frequency(values) -> float:
    """Feature points per basis unit along a line, ``dist_scale * density^(1/dim)``: the inverse
    of the mean spacing of an octave-0 feature (``density_max`` with a density map: the finest
    features; 1 point per cell for the jitter and blender distributions)."""
    from cellgl.basis.reference import W96_DENSITY_ADJUSTMENT

    dim = int(values["dimension"])
    if values["distribution"] in ("jitter", "blender"):
        density = 1.0
    elif values["distribution"] == "worley1996":
        density = 2.5          # the mean of the book's population table (cellgl.reference)
    elif values["density_map"] != "none":
        density = float(values["density_max"])
    else:
        density = float(values["density"])
    scale = W96_DENSITY_ADJUSTMENT if values["distribution"] == "worley1996" else 1.0
    return float(scale * density ** (1.0 / dim))


def check_samples(samples) -> int:
    """``samples`` as an int: a square 1, 4, 9, ..., 64; a clear ValueError otherwise."""
    ok = isinstance(samples, (int, np.integer)) and not isinstance(samples, bool) and 1 <= samples <= MAX_SAMPLES
    if not ok or math.isqrt(int(samples)) ** 2 != samples:
        squares = ", ".join(str(k * k) for k in range(1, math.isqrt(MAX_SAMPLES) + 1))
        raise ValueError(f"samples must be a square number of samples per pixel (an n x n grid): "
                         f"one of {squares}; got {samples!r}")
    return int(samples)


def grid_side(samples: int) -> int:
    """n of an n x n supersampling grid of ``samples`` (checked)."""
    return math.isqrt(check_samples(samples))


def subsample_offsets(samples: int) -> np.ndarray:
    """(samples, 2) float64: offsets of the sub-pixel centres from the pixel centre, in pixels,
    in the order the shader sums them (x fastest): ``((i + 0.5) / n - 0.5, (j + 0.5) / n - 0.5)``."""
    n = grid_side(samples)
    k = (np.arange(n) + 0.5) / n - 0.5
    return np.stack(np.meshgrid(k, k, indexing="xy"), axis=-1).reshape(-1, 2)
