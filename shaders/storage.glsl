// cellgl fragment path: storage words in textures (included by the fragment entries).
// What a compute entry reads from storage buffer B (density-image levels, cell-image texels,
// PUPs control points) the fragment path uploads as an R32UI texture 2^CELL_STORAGE_ROW_BITS
// words wide on texture unit B (cellgl/gl/dispatch.py, bind_words): word k at texel
// (k mod width, k / width). Macro: CELL_STORAGE_ROW_BITS.

uniform usampler2D u_storage_5;
uniform usampler2D u_storage_6;
uniform usampler2D u_storage_7;

#define CELL_STORAGE_TEXEL(k) ivec2(int(uint(k) & ((1u << CELL_STORAGE_ROW_BITS) - 1u)), int(uint(k) >> CELL_STORAGE_ROW_BITS))
#define cell_storage_word(s, k) texelFetch(s, CELL_STORAGE_TEXEL(k), 0).r
