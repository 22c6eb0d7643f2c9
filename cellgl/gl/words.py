"""uint32 arrays as integer textures, for programs that read storage words from textures.

A shader hook that reads word ``k`` of an array reads a storage buffer on the compute path and,
in programs compiled with ``CELL_STORAGE_ROW_BITS`` (the fragment path: OpenGL 3.3 to 4.2, Apple's
4.1, or ``CELLGL_PATH=fragment``), texel ``(k mod 4096, k / 4096)`` of an R32UI texture on the
texture unit numbered like the buffer's binding (``shaders/storage.glsl``, ``u_storage_<binding>``).
The largest arrays bound this way (a 4096 x 4096 cell or density image) make a 4096 x 4096
texture, within the texture size of every OpenGL 4.1 implementation (16384).
"""

from __future__ import annotations

import numpy as np

__all__ = ["ROW_BITS", "as_rows", "bind"]

#: log2 of the words per texture row (shaders/storage.glsl's CELL_STORAGE_ROW_BITS)
ROW_BITS = 12

_GL_NEAREST = 0x2600
#: (id(ctx), unit) -> (content key, texture, ctx)
_held: dict = {}


def as_rows(words) -> np.ndarray:
    """uint32 words as a (rows, 4096) array, zero-padded (what :func:`bind` uploads)."""
    flat = np.ascontiguousarray(words, dtype=np.uint32).ravel()
    width = 1 << ROW_BITS
    out = np.zeros(max(1, -(-flat.size // width)) * width, dtype=np.uint32)
    out[: flat.size] = flat
    return out.reshape(-1, width)


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
