"""The ``cloud`` channel: a packed cloud-noise texture (RGBA), the layout real-time volumetric
cloud renderers sample.

Horizon Zero Dawn's clouds (Schneider and Vos, "The Real-time Volumetric Cloudscapes of
Horizon: Zero Dawn", SIGGRAPH 2015 Advances; Schneider, GPU Pro 7, 2016) and their successors
(Nubis; Hillaire's Frostbite clouds, 2016, and his open TileableVolumeNoise) read one tileable
3D "shape" texture of four channels, a low-frequency Perlin-Worley noise and three Worley noises
at increasing frequencies that erode it. cellgl fills the same layout from any texture recipe's
basis and domain (its distribution, metric, density, jitter, frequency ``f``, seed, offsets,
warp, ``tileable``), replacing its combination, fractal and mapping:

* ``W(k)``: Worley fBm, inverted F1 (``1 - F1``, the billows), 3 octaves of lacunarity 2 and
  gain 0.5, at frequency ``k f``, seed ``seed + k``, F1's range measured for the recipe's basis
  (:func:`cellgl.texture.measure_range`, NumPy, 4096 points) so it spans [0, 1];
* ``P``: Perlin fBm, cellgl's gradient noise (``c_noise``) with the same fractal, at ``f``;
* ``R = W(1) + P (1 - W(1))`` (Perlin remapped from [0, 1] to [W(1), 1], as Schneider's
  Perlin-Worley), ``G = W(1)``, ``B = W(2)``, ``A = W(4)``.

Each of the four is the ``height`` channel of a derived recipe (:func:`cloud_recipes`), so the
channel tiles (in depth too, for solid recipes) when the recipe does, supersamples and tiles
bit-identically like any other, and the GPU agrees with the NumPy reference within the
height's bound; R is then computed from the two heights in float64 and rounded to float32 once,
the same on either path. Data, not colour: files never tag it as a colour space.

Not a shader of its own: four heights from the existing texture shader are the whole cost
(about four ``height`` renders), and no new GLSL was needed.
"""
from __future__ import annotations

import functools
import json

import numpy as np

from cellgl.texture.params import PARAMS

__all__ = ["CLOUD", "CLOUD_LAYOUT", "cloud_recipes", "pack", "with_cloud"]

#: the channel's name
CLOUD = "cloud"
#: what each sample holds
CLOUD_LAYOUT = ("R: Perlin-Worley, W(f) + P(f) (1 - W(f))", "G: Worley fBm (1 - F1) at f",
                "B: Worley fBm at 2 f", "A: Worley fBm at 4 f")
#: frequency multiples of the three Worley layers (G, B, A)
MULTIPLES = (1, 2, 4)
_RESET = ("combination", "fractal", "mapping")


@functools.lru_cache(maxsize=64)
def _measured(measure, probe_json: str) -> tuple[float, float]:
    """The combination's range (NumPy: the same on either backend), once per recipe."""
    from cellgl.texture.recipe import Recipe

    return measure(Recipe.from_dict(json.loads(probe_json)), samples=4096, backend="numpy")


def _fbm(recipe, measure, **combination):
    """``recipe`` with its combination, fractal and mapping reset to this fBm's."""
    r = recipe.replace(**{p.name: p.default for p in PARAMS if p.group in _RESET and not p.derived})
    r = r.replace(**combination)
    lo, hi = _measured(measure, json.dumps(r.to_dict(), sort_keys=True))
    return r.replace(range_lo=lo, range_hi=hi, fractal="sum", octaves=3.0, lacunarity=2.0, gain=0.5)


def cloud_recipes(recipe, measure) -> tuple:
    """The four derived recipes whose heights make the channel: ``(P, W(1), W(2), W(4))``;
    ``measure`` is :func:`cellgl.texture.measure_range` (passed in: this module sits below
    :mod:`cellgl.texture.evaluation`, which calls it)."""
    from cellgl.texture.presets import load_recipe

    recipe = load_recipe(recipe)
    f, seed = float(recipe.get("frequency")), int(recipe.get("seed"))
    perlin = _fbm(recipe, measure, c1=0.0, c_noise=1.0)
    worley = _fbm(recipe, measure, c1=1.0)
    layers = [worley.replace(invert=True, frequency=f * k, seed=(seed + k) & 0xFFFFFFFF) for k in MULTIPLES]
    return (perlin, *layers)


def pack(heights) -> np.ndarray:
    """The channel from the heights of :func:`cloud_recipes` (each shape S): (*S, 4) float32."""
    p, w1, w2, w4 = (np.asarray(h, dtype=np.float64) for h in heights)
    return np.stack([w1 + p * (1.0 - w1), w1, w2, w4], axis=-1).astype(np.float32)


def with_cloud(fn, recipe, channels: tuple, measure) -> dict:
    """``fn(recipe, channels)`` (a render or an evaluation) with ``cloud`` among ``channels``:
    the others from ``recipe`` as asked, ``cloud`` packed from the derived recipes' heights."""
    rest = tuple(c for c in channels if c != CLOUD)
    got = fn(recipe, rest) if rest else {}
    got[CLOUD] = pack([fn(r, ("height",))["height"] for r in cloud_recipes(recipe, measure)])
    return {c: got[c] for c in channels}
