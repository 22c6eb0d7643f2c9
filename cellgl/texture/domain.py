"""Stretched cells, domain warp and loopable animation of texture recipes (issue 12, items 5-7).

The parameters live in the table (:mod:`cellgl.params`: ``stretch_x``/``_y``/``_z``,
``orbit_radius``, ``orbit_phase``, ``warp_amount``, ``warp_frequency``, ``warp_octaves``); this
module holds what the recipe, the shaders' uniforms and the NumPy twin derive from them:

* **stretched cells**: the distance weights axis ``a`` by ``w_a = g / stretch_a`` (``g`` the
  geometric mean of the stretches, so ``prod w = 1``): the Voronoi cells are ``stretch_a`` long
  relative to each other, their mean size (one per feature point) and F's distribution
  unchanged. The search stays exact under the weights (``shaders/lib/cellular.glsl``,
  ``CELL_ANISO``); the lattice is not stretched, so tiling is unaffected.
* **domain warp**: the sample moves to ``s + warp_amount (n_0, n_1, ...)`` with ``n_a`` fractal
  gradient noise at ``warp_frequency`` (``cell_texture_warp``); its lattice origin is split
  like the others (``warp_cell`` + ``warp_frac``), and it repeats with the texture when tileable.
* **orbit**: the feature points circle in their cells (``cell_orbit``, ``CELL_ORBIT``); the
  time ``orbit_phase`` in loops reaches the GPU as the integer ``orbit_turn`` (phase * 2^32 mod
  2^32), so frame ``k`` of ``N`` and frame ``k + N`` are the same bits.
"""
from __future__ import annotations

from cellgl.basis import reference
from cellgl.basis.reference import orbit_turn

__all__ = ["axis_scale", "aniso", "orbit", "check", "tileable_changes", "orbit_turn", "WARP_SEED",
           "WARP_SEED_STEP"]

#: seed of the warp noise along axis a: seed + WARP_SEED + WARP_SEED_STEP a (octave i adds i)
WARP_SEED = 31337
WARP_SEED_STEP = 101


def axis_scale(v) -> tuple[float, float, float, float]:
    """The distance weight per axis of a recipe's stretched cells (:func:`cellgl.basis.reference.axis_scale`
    of ``(stretch_x, stretch_y, stretch_z)`` over its dimension; 1 past it)."""
    dim = int(v["dimension"])
    return reference.axis_scale((v["stretch_x"], v["stretch_y"], v["stretch_z"], 1.0), min(dim, 3))


def aniso(v) -> bool:
    """Whether a recipe's cells are stretched (``CELL_ANISO``)."""
    return any(c != 1.0 for c in axis_scale(v))


def orbit(v) -> bool:
    """Whether a recipe's feature points orbit (``CELL_ORBIT``)."""
    return float(v["orbit_radius"]) > 0.0


def check(v) -> None:
    """Constraints between these parameters and the rest of a recipe (values ``v``)."""
    from cellgl.texture.schema import RecipeError

    used = [k for k in ("c_edge", "c_nsphere", "c_smooth") if k in v and v[k] != 0.0]
    if aniso(v) and used:
        raise RecipeError(f"combination.{used[0]}: the cell features (distance to edge, n-sphere radius, smooth "
                          "F1) measure unweighted distances, so they are not available with stretched cells "
                          f"(basis.stretch_x/_y/_z != 1); accepted: {used[0]} 0, or every stretch 1")
    if v["tileable"] and v["warp_amount"] != 0.0:
        wf = v["warp_frequency"]
        if abs(wf - round(wf)) > 1e-6 or round(wf) < 1:
            raise RecipeError(f"domain.warp_frequency: {wf!r} must be a positive integer when domain.tileable "
                              "is true (the warp noise repeats with the texture)")


def tileable_changes(v, notes: list) -> dict:
    """For :meth:`cellgl.recipe.Recipe.tileable`: the warp frequency that makes a recipe seamless
    (rounded to a positive integer), with a note if it changed."""
    if v["warp_amount"] == 0.0:
        return {}
    wf = float(v["warp_frequency"])
    n = max(1, round(wf))
    if abs(wf - n) > 1e-6:
        notes.append(f"warp_frequency {wf:g} -> {n}")
    return {"warp_frequency": float(n)}
