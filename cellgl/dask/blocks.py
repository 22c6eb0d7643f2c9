"""Blocks of a cellgl image as Dask tasks: the layout, the per-process GL thread, :func:`to_dask`.

A block is a tile: ``cellgl.recipes.render(recipe, W, H, x0=, y0=, tile_w=, tile_h=)``, which
gives the same bits as the same region of a one-pass render. So any cluster, any chunking and any
order of blocks assemble into exactly the image :func:`cellgl.render` would give.

GL in a worker: each worker process has one GL context, driven by one thread of its own (the
"GL thread", made on first use). Every render in the process runs there, whatever thread Dask
runs the task on, so several threads per worker are safe and share the one context; the other
threads meanwhile compress and write. In your own process (Dask's local schedulers) a block
renders on the thread that computes it, like any other cellgl call there.
"""

from __future__ import annotations

import math
import operator
import os
import sys
import threading
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from cellgl import recipes
from cellgl.bake import core as _bake
from cellgl.recipes import MAX_SIDE  # 2**20: float32 uv keeps pixels apart there

__all__ = ["DaskError", "Layout", "to_dask", "on_gl_thread", "render_block", "require",
           "MAX_SIDE", "MAX_CHUNK", "DEFAULT_CHUNK"]

MAX_CHUNK = 4096         #: largest chunk side (one render pass: about 2 GB of working memory)
DEFAULT_CHUNK = 1024     #: default chunk side: 4 MiB of float32 height per chunk


class DaskError(ValueError):
    """A bad distributed request (size, chunk, missing extra): the message names the value."""


def require(module: str = "dask"):
    """Import ``module`` (dask, distributed, zarr) or explain how to install the extra."""
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise DaskError(f"this needs the '{module}' package ({exc}); "
                        f"install the extra: pip install 'cellgl[dask]'") from None


# --------------------------------------------------------------------------------------------
# the GL thread of this process
# --------------------------------------------------------------------------------------------

_pool_lock = threading.Lock()
_pool: ThreadPoolExecutor | None = None
_pool_pid: int | None = None
_gl_thread: threading.Thread | None = None


def _mark_gl_thread() -> None:
    global _gl_thread
    _gl_thread = threading.current_thread()


def _in_worker() -> bool:
    distributed = sys.modules.get("distributed")
    if distributed is None:
        return False
    try:
        distributed.get_worker()
    except ValueError:
        return False
    return True


def on_gl_thread(fn, *args, **kwargs):
    """Run ``fn(*args, **kwargs)`` where this process does its GL work and return its result.

    In a ``distributed`` worker that is the process's GL thread (one per process, a fresh one in
    a forked or spawned child), so the worker's GL context is only ever used from it and calls
    from several task threads queue up in order. Elsewhere it is the calling thread.
    """
    global _pool, _pool_pid
    if not _in_worker() or (threading.current_thread() is _gl_thread
                            and _pool_pid == os.getpid()):
        return fn(*args, **kwargs)
    with _pool_lock:
        if _pool is None or _pool_pid != os.getpid():
            _pool = ThreadPoolExecutor(1, thread_name_prefix="cellgl-gl",
                                       initializer=_mark_gl_thread)
            _pool_pid = os.getpid()
        pool = _pool
    return pool.submit(fn, *args, **kwargs).result()


# --------------------------------------------------------------------------------------------
# layout
# --------------------------------------------------------------------------------------------


def _whole(name: str, value, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not lo <= value <= hi:
        raise DaskError(f"{name} {value!r} is out of range; accepted a whole number in {lo}..{hi}")
    return int(value)


def samples(channel: str) -> int:
    """Samples per pixel of a channel as render() gives it (color is RGBA)."""
    return _bake.CHANNELS[channel]


def dtype(channel: str) -> np.dtype:
    return np.dtype(np.uint32 if channel == "id" else np.float32)


@dataclass(frozen=True)
class Layout:
    """A ``width x height`` image of ``recipe`` cut into ``chunk_h x chunk_w`` blocks."""

    recipe: object
    width: int
    height: int
    channels: tuple[str, ...]
    chunk_w: int
    chunk_h: int

    @classmethod
    def make(cls, recipe, shape, chunks, channels) -> Layout:
        """Check and build. ``shape``: ``N`` or ``(height, width)``; ``chunks``: ``N`` or
        ``(rows, cols)``; ``channels``: names (see :data:`cellgl.io.spec.CHANNELS`)."""
        h, w = pair("shape", shape)
        ch, cw = pair("chunks", chunks)
        h, w = _whole("height", h, 1, MAX_SIDE), _whole("width", w, 1, MAX_SIDE)
        ch = _whole("chunk rows", ch, 1, MAX_CHUNK)
        cw = _whole("chunk columns", cw, 1, MAX_CHUNK)
        chans = _bake.parse_channels(channels)
        if max(w, h) > (side := recipes.max_side(recipe)):
            raise DaskError(f"a PUPs recipe renders at most {side} pixels a side, got {w}x{h}")
        return cls(recipe, w, h, chans, min(cw, w), min(ch, h))

    @property
    def grid(self) -> tuple[int, int]:
        """Blocks down and across: ``(rows, cols)``."""
        return math.ceil(self.height / self.chunk_h), math.ceil(self.width / self.chunk_w)

    def block(self, i: int, j: int) -> tuple[int, int, int, int]:
        """``(y0, x0, rows, cols)`` of block ``(i, j)``."""
        y0, x0 = i * self.chunk_h, j * self.chunk_w
        return y0, x0, min(self.chunk_h, self.height - y0), min(self.chunk_w, self.width - x0)

    def blocks(self):
        rows, cols = self.grid
        return [(i, j) for i in range(rows) for j in range(cols)]

    def chunks(self, channel: str) -> tuple[tuple[int, ...], ...]:
        """Dask ``chunks`` of one channel's array, ``(H, W)`` or ``(H, W, S)``."""
        rows = tuple(self.block(i, 0)[2] for i in range(self.grid[0]))
        cols = tuple(self.block(0, j)[3] for j in range(self.grid[1]))
        s = samples(channel)
        return (rows, cols) + (((s,),) if s > 1 else ())

    def shape(self, channel: str) -> tuple[int, ...]:
        s = samples(channel)
        return (self.height, self.width) + ((s,) if s > 1 else ())


def pair(name: str, value, form: str = "N or (rows, cols)") -> tuple:
    """``N`` -> ``(N, N)``; a pair as it is; else a DaskError saying ``form`` is expected."""
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        return value, value
    try:
        a, b = value
    except (TypeError, ValueError):
        raise DaskError(f"{name} {value!r}: expected {form}") from None
    return a, b


def render_block(layout: Layout, i: int, j: int) -> dict[str, np.ndarray]:
    """Render block ``(i, j)``: ``{channel: (rows, cols[, S]) array}``, on this process's GL
    thread; the same bits as that region of ``cellgl.render(recipe, W, H)``."""
    y0, x0, h, w = layout.block(i, j)
    return on_gl_thread(recipes.render, layout.recipe, layout.width, layout.height,
                        channels=layout.channels, x0=x0, y0=y0, tile_w=w, tile_h=h)


def _render_one(layout: Layout, i: int, j: int) -> np.ndarray:
    return render_block(layout, i, j)[layout.channels[0]]


# --------------------------------------------------------------------------------------------
# to_dask
# --------------------------------------------------------------------------------------------


def load(recipe_or_name, sets=(), tileable=None):
    """A recipe object from a Recipe, preset name or JSON path, with ``--set`` overrides."""
    return _bake.load_recipe_sets(recipe_or_name, sets, tileable)


def to_dask(recipe, shape, chunks=DEFAULT_CHUNK, channels="color", *, sets=(), tileable=None):
    """A lazy ``dask.array`` of a recipe's image, rendered block by block by cellgl.

    Parameters
    ----------
    recipe : Recipe or str or PathLike
        A recipe, a preset name or a recipe JSON file.
    shape : int or (int, int)
        Image size in NumPy order, ``(height, width)``; ``N`` is square. Sides 1..2**20.
    chunks : int or (int, int)
        Block size ``(rows, cols)`` (1..4096 each); each block is one render pass. Default 1024.
    channels : str or sequence of str
        One name gives one array; several give a dict ``{channel: array}`` whose blocks come from
        one render per block. Names as ``cellgl bake --channels``: ``color`` (RGBA, so the
        array is ``(H, W, 4)``), ``height``, ``normal`` ``(H, W, 3)``, ``id`` (uint32),
        ``F1``..``F4``. Default ``color``, as :func:`cellgl.render`.
    sets : sequence of str
        ``"name=value"`` recipe overrides.
    tileable : bool, optional
        Override the recipe's ``tileable``.

    Returns
    -------
    dask.array.Array or dict of str -> dask.array.Array
        float32 (``id``: uint32), shape ``(H, W)`` or ``(H, W, S)``. Computing any region gives
        the same bits as ``cellgl.render(recipe, W, H, channels=...)`` of that region, on any
        scheduler: the local threads, or a ``distributed`` cluster (one GL context per worker
        process; see ``docs/scale.md``).
    """
    da = require("dask.array")
    from dask.base import tokenize

    single = isinstance(channels, str)
    layout = Layout.make(load(recipe, sets, tileable), shape, chunks, channels)
    if single and len(layout.channels) != 1:
        single = False  # "height,normal"
    try:
        rkey = layout.recipe.to_dict()
    except Exception:  # noqa: BLE001 - any recipe object that pickles will do
        rkey = repr(layout.recipe)
    token = tokenize(rkey, layout.width, layout.height, layout.channels, layout.chunk_w,
                     layout.chunk_h)
    spec = f"cellgl-layout-{token}"
    dsk: dict = {spec: layout}
    out = {}
    if single:
        (c,) = layout.channels
        name = f"cellgl-{c}-{token}"
        tail = (0,) if samples(c) > 1 else ()
        for i, j in layout.blocks():
            dsk[(name, i, j) + tail] = (_render_one, spec, i, j)
        return da.Array(dsk, name, layout.chunks(c), dtype=dtype(c))
    rname = f"cellgl-render-{token}"
    for i, j in layout.blocks():
        dsk[(rname, i, j)] = (render_block, spec, i, j)
    for c in layout.channels:
        name = f"cellgl-{c}-{token}"
        tail = (0,) if samples(c) > 1 else ()
        layer = dict(dsk)
        for i, j in layout.blocks():
            layer[(name, i, j) + tail] = (operator.getitem, (rname, i, j), c)
        out[c] = da.Array(layer, name, layout.chunks(c), dtype=dtype(c))
    return out
