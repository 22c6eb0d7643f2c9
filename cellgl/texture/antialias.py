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
mean over the plane (:func:`octave_mean`). The weights and their sum are untouched, so a bake
large enough that every ``a_i = 1`` is unchanged, bit for bit.

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

__all__ = ["AA_LO", "AA_HI", "MAX_SAMPLES", "smoothscale", "feature_frequency", "octave_mean",
           "check_samples", "grid_side", "subsample_offsets"]

#: the band limit starts fading an octave at AA_LO feature spacings per pixel and ends at AA_HI
#: (the GLSL's CELL_TEX_AA_LO / CELL_TEX_AA_HI; a test checks they agree)
AA_LO = 0.5
AA_HI = 1.0
#: most samples per pixel of a supersampled bake (an 8 x 8 grid)
MAX_SAMPLES = 64
#: points the octave mean is measured at (fixed, so the mean is the same bits every run)
_MEAN_SAMPLES = 4096


def smoothscale(w) -> np.ndarray:
    """``cell_texture_smoothscale``: ``1 - smoothstep(AA_LO, AA_HI, w)`` (float64)."""
    x = np.clip((np.asarray(w, dtype=np.float64) - AA_LO) / (AA_HI - AA_LO), 0.0, 1.0)
    return 1.0 - x * x * (3.0 - 2.0 * x)


def feature_frequency(values) -> float:
    """Feature points per basis unit along a line, ``dist_scale * density^(1/dim)``: the inverse
    of the mean spacing of an octave-0 feature (``density_max`` with a density map: the finest
    features; 1 point per cell for the jitter distribution)."""
    from cellgl.basis.reference import W96_DENSITY_ADJUSTMENT

    dim = int(values["dimension"])
    if values["distribution"] == "jitter":
        density = 1.0
    elif values["distribution"] == "worley1996":
        density = 2.5          # the mean of the book's population table (cellgl.reference)
    elif values["density_map"] != "none":
        density = float(values["density_max"])
    else:
        density = float(values["density"])
    scale = W96_DENSITY_ADJUSTMENT if values["distribution"] == "worley1996" else 1.0
    return float(scale * density ** (1.0 / dim))


#: the recipe values the octave mean depends on (the basis and the combination)
_MEAN_GROUPS = ("basis", "combination")


def octave_mean(recipe) -> float:
    """The mean over the plane of one octave's fractal term, ``b`` (fractal ``none`` and ``sum``)
    or ``|0.5 - b|`` (``qin``, ``qin_cube``), with ``b = clamp((v - range_lo) / (range_hi -
    range_lo), 0, 1)``: what a band-limited octave fades to.

    Measured with the NumPy reference at 4096 fixed points (as :func:`cellgl.texture.measure_range`
    places them: a 1000-cell square in 2D, 100-cell cube in 3D/4D, or the texture's uv square with
    a density map), rounded to float32, cached per basis and combination.
    """
    from cellgl.texture.params import PARAMS

    v = recipe.values
    key = tuple((p.name, v[p.name]) for p in PARAMS if p.group in _MEAN_GROUPS)
    key += (v["fractal"] in ("qin", "qin_cube"),)
    if v["density_map"] != "none":
        key += (v["frequency"], v["aspect"], v["offset_x"], v["offset_y"], v["offset_z"], v["time"])
        if v["density_map"] == "image":
            key += (recipe.density_pixels().tobytes(),)
    return _octave_mean(key, recipe)


#: measured means by key (the oldest dropped past 256 entries)
_MEANS: dict = {}


def _octave_mean(key, recipe) -> float:
    hit = _MEANS.get(key)
    if hit is None:
        hit = _MEANS[key] = _measure_mean(recipe)
        if len(_MEANS) > 256:
            _MEANS.pop(next(iter(_MEANS)))
    return hit


def _measure_mean(recipe) -> float:
    from cellgl.texture import reference as texture_reference
    from cellgl.texture.recipe import needed_n

    v = recipe.values
    rng = np.random.default_rng(20001)
    dim = int(v["dimension"])
    pts = np.zeros((_MEAN_SAMPLES, 3))
    if v["density_map"] != "none":
        probe = recipe.replace(fractal="none")
        pts[:, :2] = rng.uniform(0.0, 1.0, size=(_MEAN_SAMPLES, 2))
    else:
        probe = recipe.replace(tileable=False, fractal="none", frequency=1.0, aspect=1.0,
                               offset_x=0.0, offset_y=0.0, offset_z=0.0, time=0.0)
        side = 1000.0 if dim == 2 else 100.0
        pts[:, : min(dim, 3)] = rng.uniform(0.0, side, size=(_MEAN_SAMPLES, min(dim, 3)))
    t = texture_reference._tex(probe, mean=False)
    s = texture_reference.texture_local(pts, t)
    val, _, _, _ = texture_reference.texture_combination(s, t, 0, needed_n(probe))
    b = np.clip((val - v["range_lo"]) / (v["range_hi"] - v["range_lo"]), 0.0, 1.0)
    term = np.abs(0.5 - b) if v["fractal"] in ("qin", "qin_cube") else b
    return float(np.float32(term.mean()))


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
