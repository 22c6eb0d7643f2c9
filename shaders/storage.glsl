// cellgl: storage words and records as each GPU path has them (the one place that knows).
// An entry or a generated include that reads words from storage binding B (5, 6 or 7:
// density-image levels, cell-image texels) defines CELL_STORAGE_WORDS_B before including this
// file and reads word k as cell_storage_word_B(k) (uint); records of binding 11 (the far
// points' groups) likewise: CELL_STORAGE_RECORDS_11, cell_storage_record_11(k) (uvec4).
// The runner uploads them (cellgl/gl/runner.py, bind_words / bind_records):
// * the compute path: a readonly std430 storage buffer at binding B;
// * the fragment path (the runner defines CELL_STORAGE_ROW_BITS): an integer texture
//   2^CELL_STORAGE_ROW_BITS texels wide on texture unit B (words: R32UI u_storage_B; records:
//   RGBA32UI u_in11), word or record k at texel (k mod width, k / width).
// Included each time: each binding is declared once, the first time it is asked for.
#pragma cellgl include_each_time

#ifdef CELL_STORAGE_ROW_BITS
#ifndef CELL_STORAGE_TEXEL
uniform usampler2D u_storage_5;
uniform usampler2D u_storage_6;
uniform usampler2D u_storage_7;
#define CELL_STORAGE_TEXEL(k) ivec2(int(uint(k) & ((1u << CELL_STORAGE_ROW_BITS) - 1u)), int(uint(k) >> CELL_STORAGE_ROW_BITS))
#define cell_storage_word(s, k) texelFetch(s, CELL_STORAGE_TEXEL(k), 0).r
#define cell_storage_word_5(k) cell_storage_word(u_storage_5, k)
#define cell_storage_word_6(k) cell_storage_word(u_storage_6, k)
#define cell_storage_word_7(k) cell_storage_word(u_storage_7, k)
#endif
#if defined(CELL_STORAGE_RECORDS_11) && !defined(cell_storage_record_11)
uniform usampler2D u_in11;
#define cell_storage_record_11(k) texelFetch(u_in11, CELL_STORAGE_TEXEL(k), 0)
#endif
#else
#if defined(CELL_STORAGE_WORDS_5) && !defined(cell_storage_word_5)
layout(std430, binding = 5) readonly buffer CellStorage5 { uint cell_storage_5[]; };
#define cell_storage_word_5(k) cell_storage_5[k]
#endif
#if defined(CELL_STORAGE_WORDS_6) && !defined(cell_storage_word_6)
layout(std430, binding = 6) readonly buffer CellStorage6 { uint cell_storage_6[]; };
#define cell_storage_word_6(k) cell_storage_6[k]
#endif
#if defined(CELL_STORAGE_WORDS_7) && !defined(cell_storage_word_7)
layout(std430, binding = 7) readonly buffer CellStorage7 { uint cell_storage_7[]; };
#define cell_storage_word_7(k) cell_storage_7[k]
#endif
#if defined(CELL_STORAGE_RECORDS_11) && !defined(cell_storage_record_11)
layout(std430, binding = 11) readonly buffer CellStorage11 { uvec4 cell_storage_11[]; };
#define cell_storage_record_11(k) cell_storage_11[k]
#endif
#endif
