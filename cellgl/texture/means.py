"""The octave mean, where it comes from: carried by the package for the presets, measured (NumPy
reference) once per process for any other basis.

The octave mean (:func:`octave_mean`) is the value a band-limited fractal octave fades to
(:mod:`cellgl.texture.antialias`). It is defined by a measurement: the NumPy reference
(:func:`cellgl.texture.reference.measure_mean`) at :data:`SAMPLES` fixed points, rounded to
float32. The GPU render, the NumPy reference and the exported snippets all carry that one value,
so they agree bit for bit (the snippets must not need a GPU, so the GPU cannot measure it: its
float32 sums would differ from NumPy's in the last bits).

The measurement costs 0.01-0.08 s on an idle 2-core machine (0.15-0.4 s under load) and used to
run before the first GPU render of every preset. Now:

* **carried**: ``octave_means.json`` beside this module holds the mean of every preset and preset
  variant, keyed by a digest of what the measurement reads (:func:`mean_key`). A recipe whose key
  is in the table uses the stored value; no NumPy runs. The key is the recipe's own values, so a
  stored value cannot go stale for a changed recipe: ``--set seed=5`` is another key, and is
  measured (then kept). The table is written by ``python -m cellgl.texture`` and checked
  by a test that measures every entry again and compares the bits
  (tests/test_octave_means.py): a change to the reference that moves a mean fails it.
* **measured**: any other key is measured once per process and kept in a bounded cache
  (:data:`cellgl._cache.CACHE_SIZE` entries, least recently used dropped).

Why not a persistent cache on disk for the rest: a stored value would have to be invalidated
by any change to the reference's code (a digest of the sources), and checked against hostile
files, for 0.01-0.08 s once per basis per process; the presets, the common case, need none of it.
"""
from __future__ import annotations

import hashlib
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

from cellgl._cache import Bounded
from cellgl.texture.params import PARAMS

__all__ = ["octave_mean", "mean_key", "key_digest", "table", "table_text", "write_table", "SAMPLES", "RNG_SEED"]

#: points the octave mean is measured at (fixed, so the mean is the same bits every run)
SAMPLES = 4096
#: the seed of the generator (NumPy's default_rng) that places them
RNG_SEED = 20001
#: the recipe groups the measurement reads whole (the basis and the combination)
_GROUPS = ("basis", "combination")
#: the table of the presets' means (written by ``python -m cellgl.texture``)
TABLE = Path(__file__).with_name("octave_means.json")
#: what the table says it holds (its "about")
_ABOUT = ("cellgl octave means: the mean over the plane of one fractal octave's term for each "
          "preset's basis (cellgl.texture.means), keyed by the digest of the values the NumPy "
          "measurement reads; written by python -m cellgl.texture")


def mean_key(recipe) -> tuple:
    """Everything :func:`cellgl.texture.reference.measure_mean` reads of ``recipe``: the basis
    and combination groups, whether the fractal is qin's (``|0.5 - b|``), the noise frequency
    where the combination adds noise, and with a density map the domain values that place it
    (and the map image's size and pixels: 2 x 8 and 4 x 4 pixels of the same bytes differ)."""
    v = recipe.values
    key: tuple = tuple((p.name, v[p.name]) for p in PARAMS if p.group in _GROUPS)
    key += (("qin", v["fractal"] in ("qin", "qin_cube")),)
    if v["c_noise"] != 0.0:
        key += (("noise_frequency", v["noise_frequency"]),)
    if v["density_map"] != "none":
        key += tuple((n, v[n]) for n in ("frequency", "aspect", "offset_x", "offset_y", "offset_z", "time"))
        if v["density_map"] == "image":
            px = recipe.density_pixels()
            key += (("density_pixels", tuple(px.shape), hashlib.sha256(px.tobytes()).hexdigest()),)
    return key


def key_digest(key: tuple) -> str:
    """A stable name for ``key`` (the same in every process and on every machine): SHA-256 of its
    JSON with the measurement's constants (floats as Python writes them: exact)."""
    text = json.dumps([SAMPLES, RNG_SEED, key], separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


#: means measured in this process, by key
_MEASURED = Bounded("octave means measured by the NumPy reference")
#: the carried table, read once: {digest: mean}
_TABLE: dict[str, float] = {}
_TABLE_READ: list[bool] = []


def _carried() -> dict[str, float]:
    """The carried table, ``{digest: mean}``; empty where the file is missing, unreadable, not
    such a table, or made with other measurement constants (then every mean is measured)."""
    if not _TABLE_READ:
        _TABLE_READ.append(True)
        try:
            data = json.loads(TABLE.read_text(encoding="utf-8"))
            if data.get("samples") == SAMPLES and data.get("rng_seed") == RNG_SEED:
                _TABLE.update({str(k): float(e["mean"]) for k, e in data["means"].items()})
        except (OSError, ValueError, KeyError, TypeError, AttributeError):
            _TABLE.clear()
    return _TABLE


def octave_mean(recipe, measure: Callable[[Any], float]) -> float:
    """The mean over the plane of one octave's fractal term, ``b`` (fractal ``none`` and ``sum``)
    or ``|0.5 - b|`` (``qin``, ``qin_cube``), with ``b = clamp((v - range_lo) / (range_hi -
    range_lo), 0, 1)``: what a band-limited octave fades to.

    Defined as the NumPy reference's value at :data:`SAMPLES` fixed points (as
    :func:`cellgl.texture.measure_range` places them: a 1000-cell square in 2D, 100-cell cube in
    3D/4D, or the texture's uv square with a density map), rounded to float32. Read from the
    carried table where the recipe's :func:`mean_key` is in it (every preset), else
    ``measure(recipe)`` (:func:`cellgl.texture.reference.measure_mean`, which calls this with
    itself) once per process.
    """
    key = mean_key(recipe)
    hit = _MEASURED.get(key)
    if hit is None:
        hit = _carried().get(key_digest(key))
        if hit is None:
            hit = measure(recipe)
        _MEASURED.put(key, hit)
    return hit


def _recipes():
    """Every preset and preset variant, as ``(name, recipe)``."""
    from cellgl.texture.presets import list_presets, load_recipe

    for name, _ in list_presets():
        r = load_recipe(name)
        yield name, r
        for var in r.variants:
            yield f"{name}/{var.name}", var


def table(measure: Callable[[Any], float]) -> dict:
    """The table :data:`TABLE` should hold, measured now with ``measure``
    (:func:`cellgl.texture.reference.measure_mean`): ``{digest: {"mean", "presets"}}``."""
    out: dict = {}
    for name, r in _recipes():
        d = key_digest(mean_key(r))
        if d not in out:
            out[d] = {"mean": measure(r), "presets": []}
        out[d]["presets"].append(name)
    return out


def table_text(means: dict) -> str:
    """The file text of a table of ``means`` (:func:`table`)."""
    doc = {"about": _ABOUT, "samples": SAMPLES, "rng_seed": RNG_SEED,
           "means": dict(sorted(means.items(), key=lambda kv: kv[1]["presets"][0]))}
    return json.dumps(doc, indent=1) + "\n"


def write_table(measure: Callable[[Any], float]) -> Path:
    """Measure every preset's mean and rewrite :data:`TABLE` (written whole, with the usual
    permissions: :func:`cellgl.io.formats.atomic_path`); ``python -m cellgl.texture`` runs it."""
    from cellgl.io.formats import atomic_path

    text = table_text(table(measure))
    with atomic_path(TABLE) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return TABLE
