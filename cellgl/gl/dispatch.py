"""What a pass of cellgl's GPU paths is, and the NumPy side of running one (the seam:
:mod:`cellgl.gl.runner`, whose runners use these).

* **A pass** (:class:`Pass`): the entry of each path, its ``#define``s, a uniform setter, the
  samples' input (:class:`Positions`, :class:`Grid`, :class:`Rows`, :class:`Index`,
  :class:`Image`), its outputs (:class:`Output`: a destination array each) and its flag
  (:class:`Flag`), with the worst loop passes one sample may spend (its ``cost``).
* **A draw** (:class:`Draw`): a raster or full-screen draw of a vertex + fragment program into
  a render target of the runner (PUPs' raster path, the viewer), its :class:`Vertices` and
  :class:`Sampler` textures.
* **Tiles** (:func:`tile_samples`): the watchdog's bound on the samples of one dispatch or draw.
* **The fragment path's layout.** Fragment (x, y) of a :data:`WIDTH`-wide target is sample
  ``y * WIDTH + x``. Each output's components are spread over render targets of at most 4
  channels of its own kind (float, uint or int: integers travel in integer targets), packed tight
  (R, RG or RGBA; :func:`slots`), location 0 the flag; the entry defines ``row_<name>`` arrays and
  the runner writes ``CELL_FRAG_DECL`` / ``CELL_FRAG_WRITE`` from them (:func:`pass_defines`).
  Positions are split into cell and float32 fraction in NumPy with cellular.comp's float64
  operations (OpenGL 3.3 has no doubles; :func:`split_points`); a grid is separable
  (:func:`axis_tables`).
* **The compute path's layout.** A grid in slabs of rows or layers (:func:`grid_slabs`).
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from collections.abc import Callable

import numpy as np

from cellgl.gl.path import STORAGE_ROW_BITS

__all__ = ["has_watchdog", "Pass", "Output", "Flag", "Positions", "Grid", "Rows", "Index", "Image", "Result",
           "Draw", "Vertices", "Sampler",
           "tile_samples", "forced_tile", "slots", "draw_buffers", "split_points", "axis_tables",
           "grid_slabs", "pass_defines", "read_rows", "WIDTH", "CHUNK", "LOCAL_SIZE", "SAMPLE_ROW_BITS",
           "STORAGE_ROW_BITS", "SLOW_PASSES_PER_S", "DISPATCH_SECONDS", "MAX_TILE", "MAX_TARGETS"]


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

#: The watchdog (docs/fragment-path.md, "Tiles: no dispatch or draw runs long"). Windows (TDR) and
#: macOS reset a GPU whose batch runs past about 2 s; cellgl keeps every dispatch and draw under
#: DISPATCH_SECONDS on the slowest GPU it supports, in the worst case. A pass declares the most loop
#: passes one sample may spend (its ``cost``: the search's loop budget, counted in loop passes of
#: the search and the walks); SLOW_PASSES_PER_S is the slow GPU's rate in such passes per second
#: over all its lanes. Measured: an H200 runs 2D poisson F1+F2 (~30 passes a sample) at 962e6
#: samples/s, ~3e10 passes/s. The slowest GPU cellgl supports, an OpenGL 3.3-class integrated one
#: (Intel HD 4000: 0.33 TFLOPS against the H200's 67), is ~200x slower, ~1.5e8; the bound takes 1e8.
#: A tile holds at most SLOW_PASSES_PER_S * DISPATCH_SECONDS / cost samples (at least 1024).
SLOW_PASSES_PER_S = 1e8
DISPATCH_SECONDS = 1.0
#: the most samples any tile holds (a few MB of outputs per dispatch)
MAX_TILE = 1 << 20
_MIN_TILE = 1024
#: width of the fragment entries' render targets and sample-input textures, in samples
WIDTH = 1024
#: passes of the entries' loop canary (docs/exactness.md): a loop that runs this often unless the
#: driver's loop limiter cut the invocation's loops. The runner hands the length to the entry in
#: storage (compute: the word after the flag's counter; fragment: one texel on
#: :data:`CANARY_UNIT`), never as a constant or a uniform, which a compiler may fold into the
#: shader (zink inlines uniforms) and then unroll the loop past the limiter's reach.
LOOP_CANARY_PASSES = 2
#: the texture unit of the canary's length on the fragment path (``u_loop_canary``)
CANARY_UNIT = 8
#: sampler uniform -> texture unit: the storage words of each binding and the sample inputs
SAMPLERS = {"u_storage_5": 5, "u_storage_6": 6, "u_storage_7": 7,
            "u_in0": 0, "u_in1": 1, "u_in2": 2, "u_in3": 3, "u_in11": 11,
            "u_loop_canary": CANARY_UNIT}


def tile_samples(cost: int, watchdog: bool = True) -> int:
    """Samples per dispatch or draw for a pass whose samples spend at most ``cost`` loop passes
    each: within :data:`DISPATCH_SECONDS` on the slow GPU (:data:`SLOW_PASSES_PER_S`), a multiple
    of 1024, at least 1024 and at most :data:`MAX_TILE`; ``watchdog=False`` (a renderer on the CPU,
    which no watchdog resets: llvmpipe): :data:`MAX_TILE`. ``CELLGL_TILE_SAMPLES`` (a positive
    integer) forces a smaller tile (tests: tiny tiles give the same bits)."""
    n = MAX_TILE
    if watchdog:
        n = int(SLOW_PASSES_PER_S * DISPATCH_SECONDS // max(1, int(cost)))
        n = max(_MIN_TILE, min(MAX_TILE, n // _MIN_TILE * _MIN_TILE))
    forced = forced_tile()
    if forced:
        n = min(n, forced)
    return n


#: renderers on the CPU (GL_RENDERER), which no GPU watchdog resets: their tiles are as large as
#: memory asks, not as the watchdog does
SOFTWARE_RENDERERS = ("llvmpipe", "softpipe", "swiftshader", "lavapipe", "software rasterizer")


def has_watchdog(ctx) -> bool:
    """Whether a GPU watchdog can reset ``ctx``'s device (False for a renderer on the CPU)."""
    name = str(ctx.info.get("GL_RENDERER", "")).lower()
    return not any(s in name for s in SOFTWARE_RENDERERS)


def forced_tile() -> int | None:
    """``CELLGL_TILE_SAMPLES`` as an int (None when unset); a clear error when it is not one."""
    raw = os.environ.get("CELLGL_TILE_SAMPLES", "").strip()
    if not raw:
        return None
    try:
        value = int(raw)
    except ValueError:
        value = 0
    if value < 1:
        raise ValueError(f"CELLGL_TILE_SAMPLES={raw!r} must be a positive integer (samples per "
                         "dispatch or draw), or unset")
    return value


# ---------------------------------------------------------------------------------------------
# What a pass is
# ---------------------------------------------------------------------------------------------

@dataclass
class Output:
    """One per-sample output of an entry: the storage buffer at ``binding`` (compute) or the
    entry's ``row_<name>`` array (fragment); ``array`` (count, components) float32, uint32 or int32,
    C-contiguous: the destination, written in place. ``row``: the components the compute entry
    writes per sample when more than the array takes (its first ``components`` are kept; the
    fragment path writes only those)."""
    name: str
    binding: int
    array: np.ndarray
    row: int | None = None

    @property
    def row_bytes(self) -> int:
        """Bytes per sample in the compute entry's buffer."""
        return 4 * max(self.row or 0, self.array.shape[1])


@dataclass
class Flag:
    """The entry's per-sample flag: on the compute path ``"list"`` (a counter then the indices of
    the flagged samples, storage buffer ``binding``) or ``"count"`` (a counter); on the fragment
    path ``o_<name>`` at location 0 (1: fine)."""
    name: str
    binding: int
    mode: str = "list"


@dataclass
class Positions:
    """float64 sample positions (count, dim), C-contiguous, times ``scale``: the compute entry
    splits them into cell and float32 fraction in double precision (``u_samples``, ``u_scale``);
    the fragment path, which has no doubles, does the same split in NumPy."""
    pts: np.ndarray
    scale: float
    dim: int


@dataclass
class Grid:
    """A regular 4D grid (x fastest): ``shape`` (4,), origin split into ``cell`` (4,) int and
    ``frac`` (4,) float64, ``spacing`` (4,), all in lattice units."""
    shape: tuple
    cell: tuple
    frac: tuple
    spacing: tuple


@dataclass
class Rows:
    """Per-sample input rows (count, 4) of int32, uint32 or float32: storage buffer ``binding``
    (compute) or the RGBA texture ``u_in<binding>`` (fragment), row i for sample i."""
    array: np.ndarray
    binding: int = 0


@dataclass
class Index:
    """No input: sample i of the pass is ``u_first + i`` (the entry derives its position)."""


@dataclass
class Image:
    """A ``width x height`` pixel grid, pixel (x, y) sample ``y * width + x``: 2D work groups of
    ``local`` (compute: tiles are bands of rows, a multiple of ``align``, ``u_row0`` the first)."""
    width: int
    height: int
    local: tuple = (8, 8)
    align: int = 8
    #: the bands' alignment where the pass runs grouped (:attr:`Pass.group_defines`): e.g. whole
    #: grid cells of PUPs per work group (None: ``align``)
    group_align: int | None = None


@dataclass
class Pass:
    """A pass of an entry over ``count`` samples (see the module's doc)."""
    compute: str
    fragment: str
    defines: dict
    count: int
    inputs: object
    outputs: list
    setup: Callable | None = None
    flag: Flag | None = None
    files: dict | None = None
    #: the worst loop passes one sample may spend (the watchdog's tile size)
    cost: int = 1 << 14
    #: keep the program in a least-recently-used group (name, size) instead of for good
    lru: tuple | None = None
    #: defines for where invocations run in work groups (the compute path; e.g. a work group's
    #: shared cell cache), left out elsewhere: the pass's "group samples if you can"
    group_defines: dict | None = None
    #: called before the pass runs with whether it runs grouped (``group_defines`` applied): a
    #: pass may refuse what the ungrouped or the grouped layout cannot do (e.g. PUPs' loop budget)
    check: Callable | None = None
    #: uniforms the runner sets (:func:`cellgl.gl.runner.set_uniforms`; after ``setup``)
    uniforms: dict | None = None


@dataclass
class Vertices:
    """The vertices of a :class:`Draw`: ``array`` (V, k) float32 rows in moderngl's ``layout``
    (e.g. ``"2f 4f 4f"``) for the attributes ``names``; ``indices`` uint32 (3 T,): triangles (None:
    the vertices in order). The runner keeps the buffers under ``key`` (one set per key, grown and
    rewritten by the next draw of the key)."""
    array: np.ndarray
    layout: str
    names: tuple
    indices: np.ndarray | None = None
    key: str = "draw"


@dataclass
class Sampler:
    """A texture a :class:`Draw` samples: ``texture`` (made by the runner: :meth:`Runner.image`,
    a :class:`Target`'s), ``linear`` filtering (else nearest), ``repeat`` (else clamp)."""
    texture: object
    linear: bool = False
    repeat: bool = False


@dataclass
class Draw:
    """A raster or full-screen draw of the vertex + fragment program ``vertex``, ``fragment``
    (``shaders/``, with ``defines``) into ``target`` (a :class:`Target` of the runner):
    ``vertices`` (None: one triangle over the whole viewport, ``gl_VertexID`` 0..2), the
    ``uniforms`` the runner sets, ``textures`` (unit -> :class:`Sampler`), the ``viewport``
    (default: the whole target), ``clear`` (RGBA, and depth 1 where the target has a depth
    buffer) before it, ``blend`` (``"add"``: ONE, ONE, FUNC_ADD; None: off), ``depth_test``."""
    vertex: str
    fragment: str
    target: object
    defines: dict | None = None
    uniforms: dict | None = None
    vertices: Vertices | None = None
    textures: dict | None = None
    viewport: tuple | None = None
    clear: tuple | None = None
    blend: str | None = None
    depth_test: bool = False


@dataclass
class Result:
    """What a run reports besides its outputs: ``flagged`` (count,) bool (a ``"list"`` flag: the
    flagged samples), ``cut`` (a ``"count"`` flag: how many)."""
    flagged: np.ndarray | None = None
    cut: int = 0


# ---------------------------------------------------------------------------------------------
# Layouts
# ---------------------------------------------------------------------------------------------

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
