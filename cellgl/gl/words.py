"""uint32 arrays as integer textures, where storage buffers are missing (GLSL below 4.30).

A shader hook that reads word ``index`` of an array reads a storage buffer from GLSL 4.30 and,
below it (OpenGL 3.3 to 4.2, Apple's 4.1), texel ``(index & 4095, index >> 12)`` of an R32UI
texture: :data:`ROW_BITS` words per row, the rows as many as needed. The largest arrays cellgl
binds this way (a 4096 x 4096 cell or density image) make a 4096 x 4096 texture, within the
texture size of every OpenGL 4.1 implementation (16384) and every real 3.3 one.
"""

from __future__ import annotations

import numpy as np

__all__ = ["ROW_BITS", "glsl_fetch", "as_rows", "bind"]

#: log2 of the words per texture row
ROW_BITS = 12

_GL_NEAREST = 0x2600
#: (id(ctx), unit) -> (content key, texture, ctx)
_held: dict = {}


def glsl_fetch(sampler: str, index: str) -> str:
    """GLSL expression: word ``index`` (an int) of the array bound as ``sampler`` (usampler2D)."""
    mask = (1 << ROW_BITS) - 1
    return f"texelFetch({sampler}, ivec2(({index}) & {mask}, ({index}) >> {ROW_BITS}), 0).r"


def as_rows(words) -> np.ndarray:
    """uint32 words as a (rows, 4096) array, zero-padded (what :func:`bind` uploads)."""
    flat = np.ascontiguousarray(words, dtype=np.uint32).ravel()
    width = 1 << ROW_BITS
    rows = max(1, -(-flat.size // width))
    if rows == 1:
        width = max(1, flat.size)
    out = np.zeros(rows * width, dtype=np.uint32)
    out[: flat.size] = flat
    return out.reshape(rows, width)


def bind(words, unit: int, ctx) -> None:
    """Upload (cached by content, one texture per context and unit) uint32 ``words`` as an
    R32UI texture (:func:`as_rows`) and bind it to texture unit ``unit`` of ``ctx``."""
    rows = as_rows(words)
    data = rows.tobytes()
    key = (hash(data), rows.shape)
    held = _held.get((id(ctx), unit))
    if held is None or held[0] != key or held[2] is not ctx:
        if held is not None and held[2] is ctx:
            held[1].release()
        tex = ctx.texture((rows.shape[1], rows.shape[0]), 1, data, dtype="u4")
        tex.filter = (_GL_NEAREST, _GL_NEAREST)   # integer textures sample only with NEAREST
        held = _held[(id(ctx), unit)] = (key, tex, ctx)
    held[1].use(unit)
