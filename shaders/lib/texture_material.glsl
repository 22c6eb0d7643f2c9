// cellgl: the material channels of a texture (the recipe's "material" section):
// roughness, ambient occlusion and metallic, from what the texel already holds.
//
//   k = the cell value (CellTexel.cell.w: the F1 ID's value, as colour's cell_mix)
//   e = 1 - smoothstep(0, edge_width, F2 - F1)   edge mask: 1 on a cell border
//                                                (the grout), 0 inside (octave 0)
//   c = 1 - height                               cavity
//   roughness = roughness + roughness_cell (k - 0.5) + roughness_edge e + roughness_cavity c
//   ao        = 1 - ao_edge e - ao_cavity c
//   metallic  = metallic + metallic_cell (k - 0.5)
// each clamped to [0, 1]. Deterministic: integer-hashed cells, no noise of its own.
// The NumPy twin is cellgl/texture/material.py.
//
// Included by texture.glsl after struct CellTexel (F2 - F1 needs CELL_N >= 2:
// cellgl.texture.shader.defines raises it for these channels).
// Requires: texture_params.glsl (included; struct CellTextureParams).
// Macros: CELL_TEX_MATERIAL (1: compiled; the parameters exist only then).

#include "texture_params.glsl"

#if CELL_TEX_MATERIAL
// The edge mask e of texel o: 1 where F2 = F1 (a border), 0 from edge_width cells in.
float cell_texture_edge_mask(CellTexel o, CellTextureParams t)
{
    // smoothstep(0, w, x) written out, as the NumPy twin computes it
    float x = clamp((o.F.y - o.F.x) / t.edge_width, 0.0, 1.0);
    return 1.0 - x * x * (3.0 - 2.0 * x);
}

// (roughness, ao, metallic) of texel o, each in [0, 1].
vec3 cell_texture_material(CellTexel o, CellTextureParams t)
{
    float e = cell_texture_edge_mask(o, t);
    float c = 1.0 - o.height;
    float k = o.cell.w - 0.5;
    CELL_PRECISE float r = t.roughness + t.roughness_cell * k + t.roughness_edge * e + t.roughness_cavity * c;
    CELL_PRECISE float ao = 1.0 - t.ao_edge * e - t.ao_cavity * c;
    CELL_PRECISE float m = t.metallic + t.metallic_cell * k;
    return clamp(vec3(r, ao, m), 0.0, 1.0);
}
#endif
