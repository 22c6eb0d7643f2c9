// cellgl: the cell image of a texture (color.cell_color "image"): each cell
// coloured by the image under its feature point.
//
// Requires: texture_params.glsl (included; struct CellTextureParams).
// Macros: CELL_TEX_CELL_IMAGE (1: compiled), CELL_PERIODIC (1: the image
// wraps, a tileable texture).

#include "texture_params.glsl"

#if CELL_TEX_CELL_IMAGE
// Provided by the entry point (a storage buffer, cellgl/texture/images.py): texel
// `index` = row * width + column of the cell image as r | g << 8 | b << 16.
uint cell_texture_image_texel(int index);

// The cell image (over the uv square, row 0 at v = 0) at uv: bilinear between
// texel centres, edges clamped, or wrapped when tileable.
vec3 cell_texture_image(vec2 uv, CellTextureParams t)
{
    ivec2 size = ivec2(t.cell_image_info.zw);
#if CELL_PERIODIC
    uv -= floor(uv);
#endif
    vec2 x = uv * vec2(size) - 0.5;
#if !CELL_PERIODIC
    // Far outside the image (uv 10^9: x past the int range) the edge texels are all there is.
    x = clamp(x, vec2(-1.0), vec2(size));
#endif
    vec2 x0 = floor(x);
    vec2 fr = x - x0;
    vec3 c = vec3(0.0);
    for (int k = 0; k < 4; k++) {
        ivec2 d = ivec2(k & 1, k >> 1);
        ivec2 q = ivec2(x0) + d;
#if CELL_PERIODIC
        // uv - floor(uv) lies in [0, 1] (1 where a tiny negative uv rounds up), so q lies in
        // [-1, size]: one integer step wraps it, exactly (a float division need not be exact);
        // the clamp after it keeps the index inside the image whatever arrives (NaN uv).
        q += size * (ivec2(lessThan(q, ivec2(0))) - ivec2(greaterThanEqual(q, size)));
#endif
        q = clamp(q, ivec2(0), size - 1);
        uint u = cell_texture_image_texel(q.y * size.x + q.x);
        float w = (d.x == 1 ? fr.x : 1.0 - fr.x) * (d.y == 1 ? fr.y : 1.0 - fr.y);
        c += w * vec3(float(u & 255u), float((u >> 8) & 255u), float((u >> 16) & 255u));
    }
    return c * (1.0 / 255.0);
}
#endif
