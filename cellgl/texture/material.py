"""The material channels of a texture, ``roughness``, ``ao`` and ``metallic``: the NumPy twin of
``shaders/lib/texture_material.glsl`` (the maths is written there; this is the same arithmetic in
float64, as :mod:`cellgl.texture.reference` is of ``texture.glsl``).

A recipe's ``material`` section (:data:`cellgl.texture.params.PARAMS`, group ``material``) says
what each channel is made of: the cell value ``k`` (the F1 ID's, as colour's ``cell_mix``), the
edge mask ``e = 1 - smoothstep(0, edge_width, F2 - F1)`` (octave 0; 1 on a cell border, the grout)
and the cavity ``c = 1 - height``::

    roughness = roughness + roughness_cell (k - 0.5) + roughness_edge e + roughness_cavity c
    ao        = 1 - ao_edge e - ao_cavity c
    metallic  = metallic + metallic_cell (k - 0.5)

each clamped to [0, 1].
"""
from __future__ import annotations

import numpy as np

from cellgl.texture.params import MATERIAL_CHANNELS

__all__ = ["MATERIAL_CHANNELS", "edge_mask", "material"]


def edge_mask(F: np.ndarray, t) -> np.ndarray:
    """``cell_texture_edge_mask``: ``1 - smoothstep(0, edge_width, F2 - F1)`` of F (N, >= 2) (N,)."""
    x = np.clip((F[:, 1] - F[:, 0]) / t["edge_width"], 0.0, 1.0)
    return 1.0 - x * x * (3.0 - 2.0 * x)


def material(o: dict, t) -> dict:
    """``cell_texture_material``: ``{"roughness", "ao", "metallic"}`` (N,) float64 in [0, 1] of the
    texels ``o`` (:func:`cellgl.texture.reference.texture`'s dict: ``height``, ``F`` (N, 4) with
    F1, F2 filled, ``cell`` (N, 4)) under the recipe values ``t`` (a mapping by parameter name)."""
    e = edge_mask(o["F"], t)
    c = 1.0 - o["height"]
    k = o["cell"][:, 3] - 0.5
    r = t["roughness"] + t["roughness_cell"] * k + t["roughness_edge"] * e + t["roughness_cavity"] * c
    ao = 1.0 - t["ao_edge"] * e - t["ao_cavity"] * c
    m = t["metallic"] + t["metallic_cell"] * k
    return {name: np.clip(x, 0.0, 1.0) for name, x in zip(MATERIAL_CHANNELS, (r, ao, m))}
