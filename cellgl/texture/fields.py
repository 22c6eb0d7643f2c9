"""The cellular recipe's schema beyond its parameter table (:mod:`cellgl.texture.params`, whose
values :func:`cellgl.texture.schema.coerce` checks one by one): the colour ramp, the output
channels, the images a recipe refers to, the coefficient lists of the combination, and the
constraints between fields (:func:`check_fields`).

Each check raises :class:`~cellgl.texture.schema.RecipeError` naming the field path, the bad value
and what is accepted. The :class:`~cellgl.texture.recipe.Recipe` model runs them on every recipe
it makes; :mod:`cellgl.texture.recipe_json` runs them on each section of a recipe file as it reads
it.
"""
from __future__ import annotations

import math
import numbers

from cellgl.basis.reference import minkowski_floor, minkowski_message, sparse_message
from cellgl.texture import domain
from cellgl.texture.params import LINEAR, MAX_RAMP_KEYS, N_LINEAR, PARAMS_BY_NAME
from cellgl.texture.schema import CHANNELS, RecipeError, coerce, value_error

__all__ = ["check_ramp", "check_outputs", "check_image", "density_pixels", "coefficients", "check_fields"]


def check_ramp(value, path: str) -> tuple:
    accepted = f"a list of 1..{MAX_RAMP_KEYS} keys [t, r, g, b], t ascending in [0, 1], r, g, b in [0, 1]"
    if not isinstance(value, (list, tuple)) or not 1 <= len(value) <= MAX_RAMP_KEYS:
        raise value_error(path, value, accepted, "expected a colour ramp, got")
    keys = []
    for k, key in enumerate(value):
        ok = isinstance(key, (list, tuple)) and len(key) == 4 and all(
            isinstance(c, numbers.Real) and not isinstance(c, bool) and math.isfinite(c) and 0.0 <= c <= 1.0
            for c in key)
        if not ok:
            raise value_error(f"{path}[{k}]", key, accepted, "bad ramp key")
        if keys and key[0] < keys[-1][0]:
            raise value_error(f"{path}[{k}]", key, accepted, "ramp positions must not decrease; key")
        keys.append(tuple(float(c) for c in key))
    return tuple(keys)


def check_outputs(value, path: str) -> tuple:
    accepted = "a list of: " + ", ".join(CHANNELS)
    if isinstance(value, str):
        value = [value]
    if not isinstance(value, (list, tuple)) or not value:
        raise value_error(path, value, accepted, "expected a list of channels, got")
    for v in value:
        if v not in CHANNELS:
            raise value_error(path, v, accepted, "unknown channel")
    return tuple(value)


def check_image(value, path: str, kind: str, base=None):
    """An image path checked readable (:func:`cellgl.texture.images.resolve`), absolute, or None."""
    from cellgl.texture import images

    try:
        return images.resolve(value, path, kind, base)
    except images.ImageError as exc:
        raise RecipeError(str(exc)) from None


def density_pixels(file: str, path: str = "basis.density_image"):
    """The density image ``file`` as float64 (h, w) in [0, 1] (grayscale, row 0 at the top: v = 0),
    read with Pillow and cached by path and modification time; :class:`RecipeError` if unreadable."""
    from cellgl.texture import images

    try:
        return images.density_pixels(file, path)
    except images.ImageError as exc:
        raise RecipeError(str(exc)) from None


def coefficients(key: str, value, path: str) -> dict:
    out = {}
    if key == "linear":
        if not isinstance(value, (list, tuple)) or not 1 <= len(value) <= N_LINEAR:
            raise value_error(path, value, f"a list of 1..{N_LINEAR} numbers (weights of F1..F{N_LINEAR})",
                              "expected a list, got")
        for i, c in enumerate(value):
            out[LINEAR[i]] = coerce(PARAMS_BY_NAME[LINEAR[i]], c, f"{path}[{i}]")
        for name in LINEAR[len(value):]:
            out[name] = 0.0
        return out
    accepted = "a 4 x 4 list of numbers (weights of F_i F_j)"
    if not isinstance(value, (list, tuple)) or len(value) != 4:
        raise value_error(path, value, accepted, "expected 4 rows, got")
    for i, row in enumerate(value):
        if not isinstance(row, (list, tuple)) or len(row) != 4:
            raise value_error(f"{path}[{i}]", row, accepted, "expected 4 numbers, got")
        for j, c in enumerate(row):
            name = f"c{i + 1}{j + 1}"
            out[name] = coerce(PARAMS_BY_NAME[name], c, f"{path}[{i}][{j}]")
    return out


def check_fields(v, ramp: tuple, cell_image, density_image) -> None:
    """Constraints between fields: ``v`` the parameter values (every name of the table), ``ramp``,
    ``cell_image`` and ``density_image`` as checked above."""
    if v["min_points"] > v["max_points"]:
        raise RecipeError(f"basis.min_points: {v['min_points']} exceeds basis.max_points "
                          f"({v['max_points']}); accepted: min_points <= max_points")
    if v["distribution"] == "worley1996" and v["dimension"] != 3:
        raise RecipeError(f"basis.distribution: 'worley1996' needs basis.dimension 3, got "
                          f"{v['dimension']}; accepted: poisson, jitter for dimension 2 and 4")
    if v["distribution"] == "blender" and v["seed"] != 0:
        raise RecipeError(f"basis.seed: {v['seed']!r} with basis.distribution 'blender' (Blender's points "
                          "have no seed; move the texture with domain.offset_x/offset_y instead); "
                          "accepted: seed 0")
    if v["metric"] == "minkowski" and v["minkowski_p"] < minkowski_floor(v["dimension"]):
        raise RecipeError(minkowski_message("basis.minkowski_p", v["minkowski_p"], v["dimension"], "basis.dimension"))
    if why := sparse_message(v):           # min_points 0: the sample's own cell may be empty
        raise RecipeError(why)
    if v["smooth"] == "exp" and v["smoothness"] > 0.25:
        raise RecipeError(f"combination.smoothness: {v['smoothness']!r} exceeds 0.25 with combination.smooth "
                          "'exp' (its walk reaches F1 + 16 smoothness); accepted: [0, 0.25], or smooth "
                          "'polynomial' for up to 1")
    if not v["range_hi"] > v["range_lo"]:
        raise RecipeError(f"combination.range_hi: {v['range_hi']} must exceed combination.range_lo "
                          f"({v['range_lo']})")
    if not v["level_hi"] > v["level_lo"]:
        raise RecipeError(f"mapping.level_hi: {v['level_hi']} must exceed mapping.level_lo ({v['level_lo']})")
    if v["ramp_mode"] == "spline" and len(ramp) < 4:
        raise RecipeError(f"color.ramp: spline mode needs at least 4 keys, got {len(ramp)}; "
                          "accepted: 4..16 keys, or color.ramp_mode 'linear'")
    for term in ("c_edge", "c_nsphere"):
        if v[term] != 0.0 and v["metric"] != "euclidean":
            raise RecipeError(f"combination.{term}: {v[term]!r} needs basis.metric 'euclidean' (the distance "
                              f"to a bisector plane and the inscribed ball are Euclidean), got {v['metric']!r}; "
                              f"accepted: {term} 0 with other metrics")
    if v["cell_color"] == "image" and cell_image is None:
        raise RecipeError("color.cell_color: 'image' needs color.cell_image (the path of an RGB image, "
                          "relative to the recipe file)")
    dmap = v["density_map"]
    if dmap != "none":
        if v["distribution"] != "poisson":
            raise RecipeError(f"basis.density_map: {dmap!r} needs basis.distribution 'poisson' (a Poisson "
                              f"count per cell), got {v['distribution']!r}; accepted: density_map 'none' "
                              "with jitter or worley1996")
        if dmap == "image" and density_image is None:
            raise RecipeError("basis.density_map: 'image' needs basis.density_image (the path of a "
                              "grayscale image, relative to the recipe file)")
        if dmap.startswith("ramp") and v["density_start"] == v["density_end"]:
            raise RecipeError(f"basis.density_end: {v['density_end']!r} must differ from "
                              f"basis.density_start ({v['density_start']!r}) (the ramp runs between them)")
        if v["tileable"]:
            raise RecipeError(f"domain.tileable: not available with basis.density_map {dmap!r} (the map "
                              "does not repeat, so neither would the texture); accepted: tileable false, "
                              "or density_map 'none'")
    if v["tileable"]:
        if v["distribution"] == "worley1996":
            raise RecipeError("domain.tileable: not available with basis.distribution 'worley1996' "
                              "(its lattice is scaled); accepted: poisson, jitter")

        def integral(path, x):
            if abs(x - round(x)) > 1e-6 or round(x) < 1:
                raise RecipeError(f"{path}: {x!r} must be a positive integer when domain.tileable is true "
                                  "(the texture repeats every that many cells)")
        integral("domain.frequency", v["frequency"])
        integral("domain.frequency * domain.aspect", v["frequency"] * v["aspect"])
        if v["fractal"] != "none":
            integral("fractal.lacunarity", v["lacunarity"])
        if v["c_noise"] != 0.0 or v["noise_color"] != 0.0:
            integral("noise.noise_frequency", v["noise_frequency"])
    domain.check(v)
