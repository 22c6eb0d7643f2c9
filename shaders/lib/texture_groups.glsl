// cellgl.evaluate's points spread over many whole uv cells, in one pass (cellgl/texture/
// evaluation.py). A point far from the origin goes as its fraction, and the fourth component of
// its row holds g, the index of its group (the points of one whole part (u, v, z), g < 2^24: an
// exact float). The CPU splits each group's origins in float64 exactly as it splits a pan
// (cellgl.texture.shader.lattice_origins) and passes them as records of 4 words: record
// g * CELL_TEX_GROUP_RECORDS + r holds, for r = 4 i + 0..3, octave i's origin_cell, origin_frac,
// noise_cell and noise_frac (fractions as float bits), and for r = 4 CELL_TEX_GROUP_OCTAVES + 0, 1
// the warp lattice's cell and fraction. They replace the uniforms' (pan 0): the same values, so
// the same bits, as a pass per group panned by its whole part. CELL_TEX_GROUP_OCTAVES: the
// octaves a sample reads (cellgl.texture.shader.group_octaves; the others are never read).
// The records are storage binding 11's (../storage.glsl: a storage buffer or a texture, as the
// path has them; cellgl.texture.dispatch.GROUPS_BINDING).

#define CELL_STORAGE_RECORDS_11
#include "../storage.glsl"
#define CELL_TEX_GROUP_RECORD(k) cell_storage_record_11(k)
#define CELL_TEX_GROUP_RECORDS (4 * CELL_TEX_GROUP_OCTAVES + 2)

void cell_texture_group(inout CellTextureParams t, int g)
{
    int base = g * CELL_TEX_GROUP_RECORDS;
    for (int i = 0; i < CELL_TEX_GROUP_OCTAVES; i++) {
        t.origin_cell[i] = ivec4(CELL_TEX_GROUP_RECORD(base + 4 * i));      // bits kept (GLSL)
        t.origin_frac[i] = uintBitsToFloat(CELL_TEX_GROUP_RECORD(base + 4 * i + 1));
        t.noise_cell[i] = ivec4(CELL_TEX_GROUP_RECORD(base + 4 * i + 2));
        t.noise_frac[i] = uintBitsToFloat(CELL_TEX_GROUP_RECORD(base + 4 * i + 3));
    }
    t.warp_cell = ivec4(CELL_TEX_GROUP_RECORD(base + 4 * CELL_TEX_GROUP_OCTAVES));
    t.warp_frac = uintBitsToFloat(CELL_TEX_GROUP_RECORD(base + 4 * CELL_TEX_GROUP_OCTAVES + 1));
}
