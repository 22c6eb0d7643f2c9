"""Stretched cells, domain warp and loopable animation of texture recipes (issue 12, items 5-7).

The parameters live in the table (:mod:`cellgl.params`: ``stretch_x``/``_y``/``_z``,
``orbit_radius``, ``orbit_phase``, ``warp_amount``, ``warp_frequency``, ``warp_octaves``); this
module holds what the recipe, the shaders' uniforms and the NumPy twin derive from them:

* **stretched cells**: basis position ``x`` lies in lattice cell ``floor(x dist_scale / s)``
  (``s`` the per-axis stretch); the search measures distances in basis units, exactly
  (``shaders/lib/cellular.glsl``, ``CELL_ANISO``). A tileable texture needs a whole number of
  lattice cells per repeat: ``frequency / stretch_x`` and ``frequency aspect / stretch_y``.
* **domain warp**: the sample moves to ``s + warp_amount (n_0, n_1, ...)`` with ``n_a`` fractal
  gradient noise at ``warp_frequency`` (``cell_texture_warp``); its lattice origin is split
  like the others (``warp_cell`` + ``warp_frac``), and it repeats with the texture when tileable.
* **orbit**: the feature points circle in their cells (``cell_orbit``, ``CELL_ORBIT``); the
  time ``orbit_phase`` in loops reaches the GPU as the integer ``orbit_turn`` (phase * 2^32 mod
  2^32), so frame ``k`` of ``N`` and frame ``k + N`` are the same bits.
"""
from __future__ import annotations

import numpy as np

from .reference import orbit_turn

__all__ = ["stretch", "aniso", "orbit", "check", "tileable_changes", "lattice_period", "orbit_turn",
           "WARP_SEED", "WARP_SEED_STEP"]

#: seed of the warp noise along axis a: seed + WARP_SEED + WARP_SEED_STEP a (octave i adds i)
WARP_SEED = 31337
WARP_SEED_STEP = 101


def stretch(v) -> tuple[float, float, float, float]:
    """The cell length per axis ``(stretch_x, stretch_y, stretch_z, 1)``, 1 past the dimension."""
    s = [float(v["stretch_x"]), float(v["stretch_y"]), float(v["stretch_z"]), 1.0]
    for a in range(int(v["dimension"]), 4):
        s[a] = 1.0
    return tuple(s)


def aniso(v) -> bool:
    """Whether a recipe's cells are stretched (``CELL_ANISO``)."""
    return any(c != 1.0 for c in stretch(v))


def orbit(v) -> bool:
    """Whether a recipe's feature points orbit (``CELL_ORBIT``)."""
    return float(v["orbit_radius"]) > 0.0


def _whole(x: float) -> bool:
    return abs(x - round(x)) <= 1e-6 and round(x) >= 1


def check(v) -> None:
    """Constraints between these parameters and the rest of a recipe (values ``v``)."""
    from .recipe import RecipeError

    if aniso(v):
        if v["density_map"] != "none":
            raise RecipeError(f"basis.density_map: {v['density_map']!r} is not available with stretched cells "
                              f"(basis.stretch_x/_y/_z = {stretch(v)[:int(v['dimension'])]}); accepted: "
                              "density_map 'none', or every stretch 1")
        if v["tileable"]:
            for path, cells, s in (("domain.frequency / basis.stretch_x", v["frequency"], v["stretch_x"]),
                                   ("domain.frequency * domain.aspect / basis.stretch_y",
                                    v["frequency"] * v["aspect"], v["stretch_y"])):
                if not _whole(cells / s):
                    raise RecipeError(f"{path}: {cells / s!r} must be a positive integer when domain.tileable "
                                      "is true (whole stretched cells per repeat)")
    if v["tileable"] and v["warp_amount"] != 0.0 and not _whole(v["warp_frequency"]):
        raise RecipeError(f"domain.warp_frequency: {v['warp_frequency']!r} must be a positive integer when "
                          "domain.tileable is true (the warp noise repeats with the texture)")


def tileable_changes(v, frequency: float, aspect: float, notes: list) -> dict:
    """For :meth:`cellgl.recipe.Recipe.tileable`: the stretch and warp values that make a recipe
    with this (integer) ``frequency`` and ``aspect`` seamless, with a note per changed value."""
    out = {}
    for name, cells in (("stretch_x", frequency), ("stretch_y", frequency * aspect)):
        s = float(v[name])
        if s != 1.0:
            n = max(1, round(cells / s))
            new = cells / n
            if abs(new - s) > 1e-9:
                notes.append(f"{name} {s:g} -> {new:g}")
            out[name] = new
    if v["warp_amount"] != 0.0:
        wf = float(v["warp_frequency"])
        n = max(1, round(wf))
        if abs(wf - n) > 1e-6:
            notes.append(f"warp_frequency {wf:g} -> {n}")
        out["warp_frequency"] = float(n)
    return out


def lattice_period(per, v) -> np.ndarray:
    """``cell_texture_lattice_period``: the basis-space repeat ``per`` (4,) int in lattice cells
    (divided by the stretch, rounded; 0 stays 0)."""
    per = np.asarray(per, dtype=np.int64)
    if not aniso(v):
        return per
    return np.round(per / np.asarray(stretch(v))).astype(np.int64)
