"""Shader text surgery for the snippet exporter: specialise, prefix, translate.

Pure text, no GL. Three steps turn the resolved ``shaders/lib`` sources into a snippet:

1. :func:`specialise` -- a small C preprocessor for the subset the library uses
   (``#if``/``#elif``/``#else``/``#endif``, ``#ifdef``/``#ifndef``, object-like
   ``#define``/``#undef``, ``defined()``, integer expressions). Inactive branches are dropped and
   every macro name in the code is replaced by its value, so no directive and no macro is left.
2. :func:`prefix_names` -- every top-level name (function, struct, global constant) gets the
   ``cellgl_`` prefix (structs ``Cellgl``), so nothing unprefixed leaks into the user's shader.
3. :func:`to_wgsl` / :func:`to_osl` -- translation of the specialised GLSL's tree
   (:mod:`cellgl.export.syntax`) into WGSL and OSL; GLSL, GLSL ES, Godot and HLSL are printed
   from the same tree by :mod:`cellgl.export.printer`.

The translators cover the GLSL subset the library is written in (see DESIGN.md): scalars,
vectors, structs, fixed-size arrays, ``in``/``out``/``inout`` parameters, for/if/else, ternaries,
the built-ins. Anything else raises :class:`TranslateError` naming the construct, instead of
emitting text that would not compile.
"""
from __future__ import annotations

from cellgl.export.translate.osl import to_osl
from cellgl.export.translate.preprocess import prefix_names, prefixed, specialise, top_level_names
from cellgl.export.translate.tokens import TranslateError
from cellgl.export.translate.wgsl import to_wgsl

__all__ = ["TranslateError", "specialise", "top_level_names", "prefix_names", "prefixed",
           "to_wgsl", "to_osl"]
