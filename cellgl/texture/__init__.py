"""Cellular textures: recipes over the basis (Worley's combinations, Qin's generalisation,
fractals, bump, colour ramps).

Bottom to top: :mod:`~cellgl.texture.params` (the parameter table that drives uniforms, sliders,
``--set`` and snippet constants), :mod:`~cellgl.texture.fields` (the recipe's structured fields and the constraints between them),
:mod:`~cellgl.texture.recipe_json` (its JSON form and ``--set`` text), :mod:`~cellgl.texture.recipe`
(the :class:`Recipe`), :mod:`~cellgl.texture.presets` (the preset folder, ``load_recipe``), :mod:`~cellgl.texture.reference` (the NumPy twin of ``shaders/lib/texture.glsl``),
:mod:`~cellgl.texture.shader` (generated GLSL, macros, uniforms) and
:mod:`~cellgl.texture.evaluation` (GPU evaluation: ``evaluate``, ``render``).
"""
from __future__ import annotations

from cellgl.texture.evaluation import OUTPUTS, evaluate, measure_range, render, render_fragment
from cellgl.texture.recipe import Recipe, RecipeError
from cellgl.texture.shader import (MAX_OCTAVES, defines, density_encodings, generated_files, glsl_constant_block,
                                   glsl_params_from_uniforms, lattice_origins, set_uniforms, set_view,
                                   uniform_values)

__all__ = ["Recipe", "RecipeError", "OUTPUTS", "MAX_OCTAVES", "evaluate", "render", "render_fragment", "measure_range", "defines",
           "uniform_values", "density_encodings", "set_uniforms", "set_view", "lattice_origins",
           "glsl_constant_block", "glsl_params_from_uniforms", "generated_files"]
