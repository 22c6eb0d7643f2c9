"""The compute path's layout (:class:`cellgl.gl.runner.ComputeRunner` runs it; OpenGL 4.3).

Inputs in storage buffers and textures, each output a storage buffer at its binding, read back
straight into the destination array, a chunk of dispatches per read-back (:data:`CHUNK_BYTES`)
within the context's storage block; float64 positions as the 32-bit words of an RGBA32UI texture
(:func:`sample_words`); a grid in slabs of rows or layers (:func:`grid_slabs`); an image in bands
of rows (:func:`image_bands`).
"""
from __future__ import annotations

import numpy as np

__all__ = ["LOCAL_SIZE", "SAMPLE_ROW_BITS", "TEXTURE_ROWS_MAX", "MAX_GROUPS", "STORAGE_BLOCK_MIN",
           "STORAGE_BLOCK_MAX", "CHUNK_BYTES", "grid_slabs", "image_bands", "sample_words"]

#: work-group size of the 1D compute entries (``CELL_LOCAL_SIZE``)
LOCAL_SIZE = 64
#: the float64 positions of :class:`Positions` on the compute path: an RGBA32UI texture
#: 2^SAMPLE_ROW_BITS texels wide (cellular.comp, ``u_samples``)
SAMPLE_ROW_BITS = 12
TEXTURE_ROWS_MAX = 16384     #: GL_MAX_TEXTURE_SIZE is at least this in every OpenGL 4.3 driver
MAX_GROUPS = 65535           #: work groups per axis GL guarantees
#: OpenGL 4.3's guaranteed GL_MAX_SHADER_STORAGE_BLOCK_SIZE (bytes): the output buffers of one
#: dispatch stay within the context's own limit, and never above this default where it is unknown
STORAGE_BLOCK_MIN = 16 << 20
STORAGE_BLOCK_MAX = 128 << 20
#: bytes of one output the compute path reads back at once (the tiles of a chunk write ranges of
#: one buffer; docs/performance.md)
CHUNK_BYTES = 64 << 20


def grid_slabs(X: int, Y: int, Z: int, W: int, step: int, local: int = LOCAL_SIZE):
    """The dispatches of an X x Y x Z x W grid (x fastest), each contiguous in the output and within
    :data:`MAX_GROUPS` work groups on every axis: yields ``((x0, y0, z0, w, cols, rows), first
    output index, (groups x, y, z))``. Several z-layers of full rows, or some rows of one layer,
    or (a row wider than ``step``) a run of columns of one row."""
    if X > step:          # wider than one dispatch: split rows
        for w in range(W):
            for z in range(Z):
                for y in range(Y):
                    row = ((w * Z + z) * Y + y) * X
                    for x0 in range(0, X, step):
                        cx = min(step, X - x0)
                        yield (x0, y, z, w, cx, 1), row + x0, ((cx + local - 1) // local, 1, 1)
        return
    if X * Y <= step and Y <= MAX_GROUPS:
        ny, nz = Y, max(1, min(step // (X * Y), MAX_GROUPS))
    else:
        ny, nz = max(1, min(step // X, MAX_GROUPS)), 1
    gx = (X + local - 1) // local
    for w in range(W):
        for z0 in range(0, Z, nz):
            for y0 in range(0, Y, ny):
                cy, cz = min(ny, Y - y0), min(nz, Z - z0)
                yield (0, y0, z0, w, X, cy), ((w * Z + z0) * Y + y0) * X, (gx, cy, cz)


def image_bands(width: int, height: int, local, rows: int):
    """The dispatches of a ``width x height`` image in bands of ``rows`` rows (work groups of
    ``local``): yields (first sample, samples, work groups, extra uniforms ``u_row0``)."""
    lx, ly = local
    for y0 in range(0, height, rows):
        r = min(rows, height - y0)
        yield y0 * width, r * width, (-(-width // lx), -(-r // ly), 1), (("u_row0", y0),)


def sample_words(pts: np.ndarray):
    """float64 positions (m, d) as the 32-bit words of an RGBA32UI texture 2^SAMPLE_ROW_BITS texels
    wide, d / 2 texels per sample, no padding between samples: (full rows (rows, width * 4) of
    words, the last row's words padded to whole texels). RuntimeError past
    :data:`TEXTURE_ROWS_MAX` rows."""
    words = np.ascontiguousarray(pts, dtype=np.float64).reshape(-1).view(np.uint32)
    width = 1 << SAMPLE_ROW_BITS
    rows, tail = divmod(words.size, 4 * width)
    if rows + 1 > TEXTURE_ROWS_MAX:
        raise RuntimeError(f"internal error: {words.size // 4} texels of positions need more than "
                           f"{TEXTURE_ROWS_MAX} rows of {width}")
    rest = words[rows * width * 4:]
    if tail % 4:                         # 3D, an odd count: the last texel is half a sample
        rest = np.concatenate([rest, np.zeros(4 - tail % 4, np.uint32)])
    return words[: rows * width * 4], rest
