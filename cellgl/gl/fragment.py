"""The fragment path's layout (:class:`cellgl.gl.runner.FragmentRunner` runs it; OpenGL 3.3 core
and up, no compute shaders; docs/fragment-path.md).

Fragment (x, y) of a :data:`WIDTH`-wide target is sample ``y * WIDTH + x``. Each output's
components are spread over render targets of at most 4 channels of its own kind (float, uint or
int: integers travel in integer targets), packed tight (R, RG or RGBA; :func:`slots`), location 0
the flag; the entry defines ``row_<name>`` arrays and the runner writes ``CELL_FRAG_DECL`` /
``CELL_FRAG_WRITE`` from them (:func:`pass_defines`). Positions are split into cell and float32
fraction in NumPy with cellular.comp's float64 operations (OpenGL 3.3 has no doubles;
:func:`split_points`); a grid is separable (:func:`axis_tables`). What the compute entries read
from storage buffers comes in as integer textures on the unit numbered as the binding
(``shaders/storage.glsl``; :data:`SAMPLERS`). A draw covers whole rows, or runs of one row
(:func:`tiles`).
"""
from __future__ import annotations

import numpy as np

from cellgl.gl.path import STORAGE_ROW_BITS

__all__ = ["WIDTH", "CHUNK", "MAX_TARGETS", "KIND", "CANARY_UNIT", "SAMPLERS", "STORAGE_ROW_BITS",
           "draw_buffers", "slots", "target_comps", "split_points", "axis_tables", "kind_of",
           "pass_defines", "read_rows", "tiles"]

#: width of the fragment entries' render targets and sample-input textures, in samples
WIDTH = 1024
#: the texture unit of the canary's length on the fragment path (``u_loop_canary``)
CANARY_UNIT = 8
#: sampler uniform -> texture unit: the storage words of each binding and the sample inputs
SAMPLERS = {"u_storage_5": 5, "u_storage_6": 6, "u_storage_7": 7,
            "u_in0": 0, "u_in1": 1, "u_in2": 2, "u_in3": 3, "u_in11": 11,
            "u_loop_canary": CANARY_UNIT}
#: samples per upload and read-back (one render-target set; a multiple of WIDTH)
CHUNK = 1 << 19
#: render-target sets kept per context (least recently used released)
MAX_TARGETS = 4
_COORD_LIMIT = 1073741824.0
KIND = {"f": ("f4", "float", "vec"), "u": ("u4", "uint", "uvec"), "i": ("i4", "int", "ivec")}


def draw_buffers(ctx) -> int:
    """Render targets one draw may write (GL_MAX_DRAW_BUFFERS, at most 8; OpenGL 3.3 has 8)."""
    return max(2, min(8, int(ctx.info.get("GL_MAX_DRAW_BUFFERS", 8)),
                      int(ctx.info.get("GL_MAX_COLOR_ATTACHMENTS", 8))))


def slots(outputs) -> list[tuple[str, str, int, int]]:
    """Spread per-sample outputs over render targets of at most 4 channels. ``outputs``: (name,
    kind ``"f"``, ``"u"`` or ``"i"``, length) in order. Returns the slots in order, each
    (name, kind, first component, components) (one kind per slot: a name never shares a slot)."""
    out = []
    for name, kind, length in outputs:
        for first in range(0, length, 4):
            out.append((name, kind, first, min(4, length - first)))
    return out


def target_comps(k: int) -> int:
    """Channels of the target of a slot of ``k`` components: R, RG or RGBA (RGB32F, RGB32UI are
    not colour-renderable in OpenGL 3.3)."""
    return k if k in (1, 2) else 4


#: rows split at once by :func:`split_points` (its float64 temporaries stay in the cache)
_SPLIT_BLOCK = 1 << 14


def split_points(pts: np.ndarray, scale: float, dim: int, cell=None, frac=None):
    """cellular.comp's split of positions ``pts`` (N, dim) float64 times ``scale``: (cell int32
    (N, dim), fraction float32 (N, dim), in range (N,) bool or None when all are). Out of range
    (|x| >= 2^30 cells, or NaN): searched at 0 and flagged, as there. ``cell``, ``frac``: arrays
    (N, dim) to fill (views of one texel array in 2D), else new ones. In blocks of
    :data:`_SPLIT_BLOCK` rows, each the same operations in the same order: the same bits."""
    n = len(pts)
    cell = np.empty((n, dim), np.int32) if cell is None else cell
    frac = np.empty((n, dim), np.float32) if frac is None else frac
    ok = None
    sc = np.float64(scale)
    rows = min(n, _SPLIT_BLOCK)
    xs, fls = np.empty((rows, dim)), np.empty((rows, dim))     # one pair of temporaries, reused
    for b in range(0, n, _SPLIT_BLOCK):
        e = min(n, b + _SPLIT_BLOCK)
        x, fl = xs[:e - b], fls[:e - b]
        np.multiply(pts[b:e, :dim], sc, out=x)
        if not (x.min() > -_COORD_LIMIT and x.max() < _COORD_LIMIT):   # also NaN: the careful way
            with np.errstate(invalid="ignore"):
                inside = np.abs(x) < _COORD_LIMIT
            x[~inside] = 0.0
            if ok is None:
                ok = np.ones(n, bool)
            ok[b:e] = inside.all(axis=1)
        np.floor(x, out=fl)
        np.subtract(x, fl, out=x)
        fr = frac[b:e]
        fr[...] = x                                     # float64 -> float32, to nearest
        cl = cell[b:e]
        cl[...] = fl
        if fr.max() >= 1.0:                             # a fraction just below 1 rounds up to 1
            up = fr >= 1.0
            cl += up
            fr[up] = 0.0
    return cell, frac, ok


def axis_tables(shape_xyzw, origin_cell, origin_frac, spacing):
    """Per axis, the integer cell and float32 fraction of every grid index (cellular.comp's
    ``u_origin_frac + u_spacing * idx`` in float64): (cells int32, fractions float32, offsets (4,))
    with axis a's entries from offsets[a]."""
    cells, fracs, offsets, at = [], [], [], 0
    for a in range(4):
        idx = np.arange(int(shape_xyzw[a]), dtype=np.float64)
        pos = np.float64(origin_frac[a]) + np.float64(spacing[a]) * idx
        fl = np.floor(pos)
        fr = (pos - fl).astype(np.float32)
        up = fr >= 1.0
        cells.append((int(origin_cell[a]) + fl.astype(np.int64) + up).astype(np.int32))
        fracs.append(np.where(up, np.float32(0.0), fr))
        offsets.append(at)
        at += len(idx)
    return np.concatenate(cells), np.concatenate(fracs), offsets


def kind_of(a: np.ndarray) -> str:
    return {"f": "f", "u": "u", "i": "i"}[a.dtype.kind]


def pass_defines(flag, draw_slots) -> dict:
    """CELL_FRAG_DECL and CELL_FRAG_WRITE of one draw: the flag at location 0 (``o_<name>``), then
    each slot a target of its kind, written from the entry's ``row_<name>``."""
    decl, write = [], []
    loc = 0
    if flag is not None:
        decl.append(f"layout(location = 0) out uint o_{flag.name};")
        loc = 1
    for name, kind, first, k in draw_slots:
        _, scalar, vec = KIND[kind]
        tc = target_comps(k)
        t = scalar if tc == 1 else f"{vec}{tc}"
        zero = {"f": "0.0", "u": "0u", "i": "0"}[kind]
        comps = [f"row_{name}[{first + c}]" if c < k else zero for c in range(tc)]
        decl.append(f"layout(location = {loc}) out {t} o_{loc};")
        write.append(f"o_{loc} = {t}({', '.join(comps)});")
        loc += 1
    return {"CELL_FRAG_DECL": " ".join(decl), "CELL_FRAG_WRITE": " ".join(write)}


def read_rows(fbo, attachment: int, dest: np.ndarray, dtype: str) -> None:
    """Read samples [0, len(dest)) of ``attachment`` (fragment (x, y): sample y * WIDTH + x) into
    ``dest`` (m, components), C-contiguous: whole rows, then the last row's part."""
    m, comps = dest.shape
    full, tail = divmod(m, WIDTH)
    if full:
        fbo.read_into(dest[: full * WIDTH], viewport=(0, 0, WIDTH, full), components=comps,
                      attachment=attachment, dtype=dtype)
    if tail:
        fbo.read_into(dest[full * WIDTH:], viewport=(0, full, tail, 1), components=comps,
                      attachment=attachment, dtype=dtype)


def tiles(rows: int, tile: int):
    """The viewports of the draws over ``rows`` rows of WIDTH samples, at most ``tile`` samples
    each: whole rows, or (a tile under a row) runs of one row."""
    if tile >= WIDTH:
        step = tile // WIDTH
        for r0 in range(0, rows, step):
            yield (0, r0, WIDTH, min(step, rows - r0))
        return
    for r in range(rows):
        for x0 in range(0, WIDTH, tile):
            yield (x0, r, min(tile, WIDTH - x0), 1)
