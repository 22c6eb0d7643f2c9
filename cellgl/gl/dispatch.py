"""What a pass and a draw of cellgl's GPU paths are (the seam: :mod:`cellgl.gl.runner`, whose
runners run them).

* **A pass** (:class:`Pass`): the entry of each path, its ``#define``s, its uniforms, the
  samples' input (:class:`Positions`, :class:`Grid`, :class:`Rows`, :class:`Index`,
  :class:`Image`), its outputs (:class:`Output`: a destination array each) and its flag
  (:class:`Flag`), with the worst loop passes one sample may spend (its ``cost``), and the path
  choices the runner honours (``group_defines``: group samples where the path runs work groups;
  ``check``: refuse what the layout that runs cannot do).
* **A draw** (:class:`Draw`): a raster or full-screen draw of a vertex + fragment program into
  a render target of the runner (PUPs' raster path, the viewer), its :class:`Vertices` and
  :class:`Sampler` textures.
* **Tiles** (:func:`tile_samples`): the watchdog's bound on the samples of one dispatch or draw.
* **Each path's layout** in its own module: :mod:`cellgl.gl.fragment` (render targets
  :data:`WIDTH` samples wide, outputs spread over tight targets of their kind, positions split in
  NumPy) and :mod:`cellgl.gl.compute` (storage buffers, a grid in slabs, an image in bands); their
  names are here too (:func:`slots`, :func:`grid_slabs`, ...), as the runners and tests know them.
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from collections.abc import Callable
from typing import Any

import numpy as np

from cellgl.gl.compute import (CHUNK_BYTES, LOCAL_SIZE, MAX_GROUPS, SAMPLE_ROW_BITS, STORAGE_BLOCK_MAX,
                               STORAGE_BLOCK_MIN, TEXTURE_ROWS_MAX, grid_slabs)
from cellgl.gl.fragment import (CANARY_UNIT, CHUNK, KIND, MAX_TARGETS, SAMPLERS, STORAGE_ROW_BITS, WIDTH,
                                axis_tables, draw_buffers, kind_of, pass_defines, read_rows, slots,
                                split_points, target_comps)

__all__ = ["has_watchdog", "Pass", "Output", "Flag", "Positions", "Grid", "Rows", "Index", "Image", "Result",
           "Draw", "Vertices", "Sampler", "tile_samples", "forced_tile", "SLOW_PASSES_PER_S", "DISPATCH_SECONDS",
           "MAX_TILE", "LOOP_CANARY_PASSES", "SOFTWARE_RENDERERS",
           # the layouts' names (cellgl.gl.fragment, cellgl.gl.compute)
           "CHUNK_BYTES", "LOCAL_SIZE", "MAX_GROUPS", "SAMPLE_ROW_BITS", "STORAGE_BLOCK_MAX", "STORAGE_BLOCK_MIN",
           "TEXTURE_ROWS_MAX", "grid_slabs", "CANARY_UNIT", "CHUNK", "KIND", "MAX_TARGETS", "SAMPLERS",
           "STORAGE_ROW_BITS", "WIDTH", "axis_tables", "draw_buffers", "kind_of", "pass_defines", "read_rows",
           "slots", "split_points", "target_comps"]


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
#: passes of the entries' loop canary (docs/exactness.md): a loop that runs this often unless the
#: driver's loop limiter cut the invocation's loops. The runner hands the length to the entry in
#: storage (compute: the word after the flag's counter; fragment: one texel on
#: :data:`CANARY_UNIT`), never as a constant or a uniform, which a compiler may fold into the
#: shader (zink inlines uniforms) and then unroll the loop past the limiter's reach.
LOOP_CANARY_PASSES = 2
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
    #: ``setup(prog)``, run on the program before its ``uniforms`` are set: a caller's own work on
    #: the program (the library's passes carry ``uniforms`` only)
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
    #: the entry's uniforms, name -> value, which the runner sets (:func:`cellgl.gl.draws.set_uniform`:
    #: where the compiler kept them; NumPy arrays cut to the elements kept)
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
    texture: Any
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
    target: Any
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
