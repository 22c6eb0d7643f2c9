"""The seam between cellgl's two GPU paths: one :class:`Runner` per context.

The layers above (``basis/``, ``texture/``, ``pups/``) describe a pass (:class:`Pass`: the entry of
each path, its ``#define``s, a uniform setter, the samples' input, the outputs and their
destination arrays, the flag) and hand it to ``runner(ctx).run(pass)``; they never ask which path
runs. The runner of a context is chosen by :func:`cellgl.gl.path.gpu_path` (compute from OpenGL 4.3,
else fragment; ``CELLGL_PATH`` forces one):

* :class:`ComputeRunner` dispatches the ``*.comp`` entry: inputs in storage buffers and textures,
  each output a storage buffer at its binding, read back straight into the destination array;
* :class:`cellgl.gl.dispatch.FragmentRunner` draws the fragment entry over a render target
  ``WIDTH`` samples wide: inputs in textures, each output a tightly packed render target (R, RG or
  RGBA of its kind: float, uint or int), location 0 the flag.

Both tile the work so that no dispatch or draw runs longer than about a second on the slowest GPU
cellgl supports (:func:`tile_samples`; docs/architecture.md, "The seam").

Everything a context holds for cellgl, programs (the ONE cache: compute entries, fragment entries
and the vertex + fragment programs of the viewer), storage words, sample inputs, render targets and
vertex arrays, lives in one registry entry per context (:func:`held`): dropped with the context
(:func:`drop`, or found released on the next call) and, without touching the parent's driver
objects, in a forked child.
"""
from __future__ import annotations

import os
import threading
from collections import OrderedDict
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from cellgl.gl import glsl
from cellgl.gl import path as _path

__all__ = ["Runner", "ComputeRunner", "Pass", "Output", "Flag", "Positions", "Grid", "Rows", "Index",
           "Image", "runner", "held", "drop", "store", "clear_programs", "tile_samples", "LOCAL_SIZE",
           "SAMPLE_ROW_BITS", "SLOW_PASSES_PER_S", "DISPATCH_SECONDS"]

#: work-group size of the 1D compute entries (``CELL_LOCAL_SIZE``)
LOCAL_SIZE = 64
#: the float64 positions of :class:`Positions` on the compute path: an RGBA32UI texture
#: 2^SAMPLE_ROW_BITS texels wide (cellular.comp, ``u_samples``)
SAMPLE_ROW_BITS = 12
_TEXTURE_ROWS_MAX = 16384     #: GL_MAX_TEXTURE_SIZE is at least this in every OpenGL 4.3 driver
_MAX_GROUPS = 65535           #: work groups per axis GL guarantees
#: OpenGL 4.3's guaranteed GL_MAX_SHADER_STORAGE_BLOCK_SIZE (bytes): the output buffers of one
#: dispatch stay within the context's own limit, and never above this default where it is unknown
_STORAGE_BLOCK_MIN = 16 << 20
_STORAGE_BLOCK_MAX = 128 << 20

#: The watchdog (docs/architecture.md, "Tiles and the watchdog"). Windows (TDR) and macOS reset a
#: GPU whose batch runs past about 2 s; cellgl keeps every dispatch and draw under
#: DISPATCH_SECONDS on the slowest GPU it supports. SLOW_PASSES_PER_S is that GPU's rate in loop
#: passes of the search (one pass: a cell or point visit, ~40-80 ALU operations) per second over
#: all its lanes. Measured: an H200 runs the 3x3 jitter F1 snippet at 3.1e9 samples/s, 9 passes
#: each: ~2.8e10 passes/s. The slowest GPU cellgl supports (an integrated GPU of ~0.4 TFLOPS
#: against the H200's ~60) is ~150x slower: ~1.9e8; the bound takes 1.5e8. A tile holds at most
#: SLOW_PASSES_PER_S * DISPATCH_SECONDS / (worst passes per sample) samples.
SLOW_PASSES_PER_S = 1.5e8
DISPATCH_SECONDS = 1.0
#: the most samples any tile holds (a few MB of outputs per dispatch)
MAX_TILE = 1 << 20
_MIN_TILE = 1024
#: width of the fragment entries' render targets and sample-input textures, in samples
WIDTH = 1024
#: sampler uniform -> texture unit: the storage words of each binding and the sample inputs
SAMPLERS = {"u_storage_5": 5, "u_storage_6": 6, "u_storage_7": 7,
            "u_in0": 0, "u_in1": 1, "u_in2": 2, "u_in3": 3}


def tile_samples(cost: int, ctx_limit: int | None = None) -> int:
    """Samples per dispatch or draw for a pass whose samples spend at most ``cost`` loop passes
    each: within :data:`DISPATCH_SECONDS` on the slow GPU (:data:`SLOW_PASSES_PER_S`), a multiple
    of 1024, at least 1024 and at most :data:`MAX_TILE`. ``CELLGL_TILE_SAMPLES`` (a positive
    integer) forces a smaller tile (tests: tiny tiles give the same bits)."""
    n = int(SLOW_PASSES_PER_S * DISPATCH_SECONDS // max(1, int(cost)))
    n = max(_MIN_TILE, min(MAX_TILE, n // _MIN_TILE * _MIN_TILE))
    forced = forced_tile()
    if forced:
        n = min(n, forced)
    if ctx_limit:
        n = min(n, ctx_limit)
    return n


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
    C-contiguous: the destination, written in place."""
    name: str
    binding: int
    array: np.ndarray


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


@dataclass
class Result:
    """What a run reports besides its outputs: ``flagged`` (count,) bool (a ``"list"`` flag: the
    flagged samples), ``cut`` (a ``"count"`` flag: how many)."""
    flagged: np.ndarray | None = None
    cut: int = 0


# ---------------------------------------------------------------------------------------------
# The registry
# ---------------------------------------------------------------------------------------------

@dataclass
class _Held:
    """Everything cellgl keeps on one context."""
    ctx: object
    programs: dict = field(default_factory=dict)       # key -> (program, vertex array or None)
    groups: dict = field(default_factory=dict)         # lru name -> OrderedDict of keys
    objects: dict = field(default_factory=dict)        # key -> (content key, GL object)
    stores: dict = field(default_factory=dict)         # name -> dict a module keeps (float targets)
    runners: dict = field(default_factory=dict)        # path -> Runner

    def release(self) -> None:
        """Release every GL object held (the context must be current and alive)."""
        for prog, vao in self.programs.values():
            _release(vao)
            _release(prog)
        for _, obj in self.objects.values():
            _release(obj)
        for s in self.stores.values():
            _release_all(s)
        self.programs.clear()
        self.groups.clear()
        self.objects.clear()
        self.stores.clear()


def _release(obj) -> None:
    if obj is None:
        return
    try:
        obj.release()
    except Exception:  # noqa: BLE001 - already gone with its context
        pass


def _release_all(value) -> None:
    if isinstance(value, dict):
        for v in value.values():
            _release_all(v)
    elif isinstance(value, (list, tuple)):
        for v in value:
            _release_all(v)
    elif hasattr(value, "mglo") and hasattr(value, "release"):
        _release(value)


_lock = threading.RLock()
_registry: dict[int, _Held] = {}
_pid = os.getpid()
#: a forked child's inherited entries: kept alive, never released (the parent's driver threads
#: do not exist here; releasing would hang)
_orphans: list = []


def _after_fork_in_child() -> None:
    global _lock, _pid
    if _pid == os.getpid():
        return
    _orphans.append(dict(_registry))
    _registry.clear()
    _lock, _pid = threading.RLock(), os.getpid()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_after_fork_in_child)


def _alive(ctx) -> bool:
    mglo = getattr(ctx, "mglo", None)
    return mglo is not None and type(mglo).__name__ != "InvalidObject"


def _default_ctx(ctx):
    if ctx is not None:
        return ctx
    from cellgl.gl import context        # same layer; context's programs come back here

    return context.get_context()


def held(ctx=None) -> _Held:
    """The registry entry of ``ctx`` (default: cellgl's context), made on first use. Entries of
    contexts released since are dropped on the way (their objects went with them)."""
    ctx = _default_ctx(ctx)
    if _pid != os.getpid():
        _after_fork_in_child()
    with _lock:
        h = _registry.get(id(ctx))
        if h is not None and h.ctx is ctx:
            return h
        for k, other in list(_registry.items()):     # released since: their objects went with them
            if not _alive(other.ctx):
                del _registry[k]
        h = _registry[id(ctx)] = _Held(ctx)
        return h


def runner(ctx=None) -> "Runner":
    """The runner of ``ctx`` (default: cellgl's context) for the path
    :func:`cellgl.gl.path.gpu_path` gives it, made on first use."""
    h = held(ctx)
    kind = _path.gpu_path(h.ctx)
    r = h.runners.get(kind)
    if r is None:
        if kind == "compute":
            r = ComputeRunner(h)
        else:
            from cellgl.gl.dispatch import FragmentRunner

            r = FragmentRunner(h)
        h.runners[kind] = r
    return r


def drop(ctx) -> None:
    """Forget ``ctx``: release what cellgl holds on it (while it is alive) and its entry."""
    with _lock:
        h = _registry.pop(id(ctx), None)
    if h is not None and h.ctx is ctx and _alive(ctx):
        h.release()


def store(name: str, ctx=None) -> dict:
    """A dict kept on ``ctx`` for a module's own GL objects (e.g. its float targets): dropped and
    released with the context's entry."""
    return held(ctx).stores.setdefault(name, {})


def clear_programs() -> None:
    """Release every context's programs (after editing shader files)."""
    with _lock:
        for h in list(_registry.values()):
            if _alive(h.ctx):
                for prog, vao in h.programs.values():
                    _release(vao)
                    _release(prog)
            h.programs.clear()
            h.groups.clear()


def _defines_key(defines) -> tuple:
    return tuple(sorted((str(k), repr(v)) for k, v in (defines or {}).items()))


def _files_key(files) -> tuple:
    return tuple(sorted((files or {}).items()))


# ---------------------------------------------------------------------------------------------
# The runner: what both paths share
# ---------------------------------------------------------------------------------------------

class Runner:
    """The runner of one context and path; see the module's doc."""

    path = ""
    #: whether invocations run in work groups of :attr:`Image.local` aligned to the image (an
    #: entry may then share work across a group, e.g. PUPs' one grid cell per group)
    groups = False

    def __init__(self, h: _Held):
        self.held = h
        self.ctx = h.ctx

    # -- programs ------------------------------------------------------------------------------

    def cached(self, key, make, lru: tuple | None = None):
        """``(program, vertex array)`` under ``key`` in the context's one cache, made by ``make()``
        once; ``lru`` (name, size): kept among the group's last ``size`` (older ones released)."""
        h = self.held
        with _lock:
            got = h.programs.get(key)
            if got is None:
                got = h.programs[key] = make()
            if lru is not None:
                name, size = lru
                group = h.groups.setdefault(name, OrderedDict())
                group[key] = True
                group.move_to_end(key)
                while len(group) > size:
                    old = h.programs.pop(group.popitem(last=False)[0], None)
                    if old is not None:
                        _release(old[1])
                        _release(old[0])
            return got

    def compute_program(self, name: str, defines=None, *, files=None, cache: bool = True, lru=None):
        """The compute shader ``shaders/<name>`` with ``defines`` and generated ``files``."""
        def make():
            src = glsl.load(name, defines, files=files)
            try:
                return self.ctx.compute_shader(src.text), None
            except Exception as exc:                       # moderngl.Error: the compiler's log
                err = glsl.ShaderError(f"compiling {name}: {glsl.map_error(str(exc), src).strip()}")
                err.sources = [src]
                raise err from None
        if not cache:
            return make()[0]
        key = ("compute", name, _defines_key(defines), _files_key(files))
        return self.cached(key, make, lru)[0]

    def program(self, vertex: str, fragment: str, defines=None):
        """A vertex + fragment program of ``shaders/`` (the viewer's, the raster paths'), its
        ``#version`` lowered to the context's (:func:`cellgl.gl.context.glsl_version`); where the
        fragment path runs, storage words are read from textures (``CELL_STORAGE_ROW_BITS``)."""
        from cellgl.gl import context

        if self.path == "fragment":
            defines = {**(defines or {}), "CELL_STORAGE_ROW_BITS": _path.STORAGE_ROW_BITS}
        key = ("program", vertex, fragment, _defines_key(defines))

        def make():
            version = context.glsl_version(self.ctx)
            vs = glsl.lower_version(glsl.load(vertex, defines), version)
            fs = glsl.lower_version(glsl.load(fragment, defines), version)
            try:
                prog = self.ctx.program(vertex_shader=vs.text, fragment_shader=fs.text)
            except Exception as exc:
                raise context._program_error(vertex, fragment, exc, vs, fs) from None
            for unit in (5, 6, 7):   # the storage bindings read from textures (storage.glsl)
                if f"u_storage_{unit}" in prog:
                    prog[f"u_storage_{unit}"].value = unit
            return prog, None
        return self.cached(key, make)[0]

    def entry(self, fragment: str, defines=None, *, files=None, lru=None):
        """``(program, vertex array)``: the fragment entry ``shaders/<fragment>`` with
        ``tiles.vert``, ``defines`` and generated ``files``, in the context's one cache."""
        d = dict(defines or {})
        d.setdefault("CELL_FRAG_WIDTH", WIDTH)
        d.setdefault("CELL_STORAGE_ROW_BITS", _path.STORAGE_ROW_BITS)
        key = ("fragment", fragment, tuple(sorted((k, str(v)) for k, v in d.items())),
               tuple(sorted((files or {}).items())))

        def make():
            vs = glsl.load("tiles.vert", d)
            fs = glsl.load(fragment, d, files=files)
            try:
                prog = self.ctx.program(vertex_shader=vs.text, fragment_shader=fs.text)
            except Exception as exc:                       # moderngl.Error: the compiler's log
                err = glsl.ShaderError(f"compiling tiles.vert + {fragment}: "
                                       f"{glsl.map_error(str(exc), fs).strip()}")
                err.sources = [vs, fs]
                raise err from None
            for name, unit in SAMPLERS.items():
                if name in prog:
                    prog[name].value = unit
            return prog, self.ctx.vertex_array(prog, [])
        return self.cached(key, make, lru)

    # -- objects --------------------------------------------------------------------------------

    def _object(self, key, content, make):
        """The GL object under ``key``, remade (the old one released) when ``content`` changed."""
        objs = self.held.objects
        got = objs.get(key)
        if got is None or got[0] != content:
            obj = make()
            if got is not None:
                _release(got[1])
            objs[key] = got = (content, obj)
        return got[1]

    def input_texture(self, unit: int, array: np.ndarray, width: int = WIDTH):
        """Upload ``array`` (count, c) of int32, uint32 or float32 to texture unit ``unit``: sample
        j at texel (j % width, j // width), c components; kept and grown across calls."""
        count, comps = array.shape
        dtype = {"i": "i4", "u": "u4", "f": "f4"}[array.dtype.kind]
        rows = max(1, -(-count // width))
        objs = self.held.objects
        got = objs.get(("input", unit))
        tex = got[1] if got is not None else None
        if tex is None or tex.height < rows or tex.width != width or tex.components != comps or tex.dtype != dtype:
            _release(tex)
            tex = self.ctx.texture((width, max(rows, 8)), comps, dtype=dtype)
            tex.filter = (0x2600, 0x2600)
            objs[("input", unit)] = (None, tex)
        full, tail = divmod(count, width)
        a = np.ascontiguousarray(array)
        if full:
            tex.write(a[: full * width], viewport=(0, 0, width, full))
        if tail:
            tex.write(a[full * width:], viewport=(0, full, tail, 1))
        tex.use(unit)
        return tex

    def bind_words(self, words, binding: int) -> None:
        """Upload uint32 ``words`` (cached by content per binding) and bind them where the entries
        read them: storage buffer ``binding`` or an R32UI texture on unit ``binding``."""
        data = np.ascontiguousarray(words, dtype=np.uint32).reshape(-1)
        raw = data.tobytes()
        self._bind_words(data, raw, (hash(raw), len(raw)), binding, 1)

    def bind_records(self, records, binding: int) -> None:
        """Upload uint32 ``records`` (R, 4) (cached by content per binding) and bind them where the
        entries read them: storage buffer ``binding`` or an RGBA32UI texture ``u_in<binding>``,
        record k at texel (k mod 2^STORAGE_ROW_BITS, k >> STORAGE_ROW_BITS)."""
        data = np.ascontiguousarray(records, dtype=np.uint32).reshape(-1, 4)
        if not len(data):
            data = np.zeros((1, 4), np.uint32)
        raw = data.tobytes()
        self._bind_words(data, raw, (hash(raw), len(raw)), binding, 4)

    def run(self, p: Pass) -> Result:  # pragma: no cover - each path's own
        raise NotImplementedError

    def _bind_words(self, data, raw, content, binding, comps):  # pragma: no cover
        raise NotImplementedError


def set_uniform(prog, name: str, value) -> None:
    """Set ``prog[name]`` where the compiler kept it."""
    if name in prog:
        prog[name].value = value


# ---------------------------------------------------------------------------------------------
# The compute path
# ---------------------------------------------------------------------------------------------

class ComputeRunner(Runner):
    """OpenGL 4.3: dispatches of the ``*.comp`` entry, outputs in storage buffers."""

    path = "compute"
    groups = True

    def _bind_words(self, data, raw, content, binding, comps):
        buf = self._object(("words", binding), content, lambda: self.ctx.buffer(raw if raw else b"\0" * 4))
        buf.bind_to_storage_buffer(binding)

    def storage(self, binding: int, nbytes: int):
        """A storage buffer of at least ``nbytes`` bound to ``binding``, reused across calls."""
        objs = self.held.objects
        got = objs.get(("storage", binding))
        if got is None or got[1].size < nbytes:
            if got is not None:
                _release(got[1])
            got = objs[("storage", binding)] = (None, self.ctx.buffer(reserve=max(64, nbytes + nbytes // 4)))
        got[1].bind_to_storage_buffer(binding)
        return got[1]

    def block_bytes(self) -> int:
        """The bytes one storage block may hold on this context (GL_MAX_SHADER_STORAGE_BLOCK_SIZE),
        within [16 MiB (GL 4.3's guarantee), 128 MiB]."""
        v = self.ctx.info.get("GL_MAX_SHADER_STORAGE_BLOCK_SIZE") or _STORAGE_BLOCK_MIN
        return int(min(_STORAGE_BLOCK_MAX, max(_STORAGE_BLOCK_MIN, int(v))))

    def _step(self, p: Pass, local: int) -> int:
        per = max([o.array.strides[0] for o in p.outputs] + [4])
        by_bytes = self.block_bytes() // per
        step = min(tile_samples(p.cost), by_bytes, local * _MAX_GROUPS)
        return max(local, step // local * local)

    def run(self, p: Pass) -> Result:
        d = dict(p.defines)
        d.setdefault("CELL_LOCAL_SIZE", LOCAL_SIZE)
        local = int(d["CELL_LOCAL_SIZE"])
        prog = self.compute_program(p.compute, d, files=p.files, lru=p.lru)
        if p.setup is not None:
            p.setup(prog)
        inp = p.inputs
        if isinstance(inp, Positions):
            set_uniform(prog, "u_scale", float(inp.scale))
        elif isinstance(inp, Grid):
            set_uniform(prog, "u_origin_cell", tuple(int(v) for v in inp.cell))
            set_uniform(prog, "u_origin_frac", tuple(float(v) for v in inp.frac))     # dvec4
            set_uniform(prog, "u_spacing", tuple(float(v) for v in inp.spacing))
        res = Result(flagged=np.zeros(p.count, bool) if p.flag and p.flag.mode == "list" else None)
        for first, m, groups, extra in self._pieces(p, local):
            if isinstance(inp, Positions):
                self._upload_positions(prog, inp.pts[first:first + m])
            elif isinstance(inp, Rows):
                rows = np.ascontiguousarray(inp.array[first:first + m])
                buf = self.storage(inp.binding, rows.nbytes)
                buf.write(rows)
            for name, value in extra:
                set_uniform(prog, name, value)
            set_uniform(prog, "u_count", m)
            set_uniform(prog, "u_first", first)
            bufs = [(o, self.storage(o.binding, m * o.array.strides[0])) for o in p.outputs]
            flag = None
            if p.flag is not None:
                flag = self.storage(p.flag.binding, 4 * (m + 1) if p.flag.mode == "list" else 4)
                flag.write(b"\0\0\0\0")
            if max(groups) > _MAX_GROUPS:  # GL drops such a dispatch: the buffers would stay unwritten
                raise RuntimeError(f"internal error: dispatch of {groups} work groups exceeds {_MAX_GROUPS}")
            prog.run(*groups)
            self.ctx.memory_barrier()
            for o, buf in bufs:
                buf.read_into(o.array[first:first + m], size=m * o.array.strides[0])
            if flag is not None:
                nbad = int(np.frombuffer(flag.read(4), dtype=np.uint32)[0])
                if p.flag.mode == "count":
                    res.cut += nbad
                elif nbad:
                    idx = np.frombuffer(flag.read(4 * nbad, offset=4), dtype=np.uint32)
                    res.flagged[first + idx.astype(np.int64)] = True
        return res

    def _pieces(self, p: Pass, local: int):
        """The dispatches: (first sample, samples, work groups, extra uniforms)."""
        step = self._step(p, local)
        inp = p.inputs
        if isinstance(inp, Grid):
            X, Y, Z, W = (int(v) for v in inp.shape)
            for slab, start, groups in grid_slabs(X, Y, Z, W, step, local):
                yield start, slab[4] * slab[5] * groups[2], groups, (("u_slab", slab[:4]), ("u_slab_size", slab[4:]))
            return
        if isinstance(inp, Image):
            w, h = inp.width, inp.height
            lx, ly = inp.local
            rows = max(inp.align, (step // max(1, w)) // inp.align * inp.align)
            for y0 in range(0, h, rows):
                r = min(rows, h - y0)
                yield y0 * w, r * w, (-(-w // lx), -(-r // ly), 1), (("u_row0", y0),)
            return
        for first in range(0, p.count, step):
            m = min(step, p.count - first)
            yield first, m, (-(-m // local), 1, 1), ()

    def _upload_positions(self, prog, pts: np.ndarray) -> None:
        """float64 positions (m, d) as the 32-bit words of an RGBA32UI texture
        2^SAMPLE_ROW_BITS texels wide on unit 0 (``u_samples``), d / 2 texels per sample, no padding
        between samples; kept and grown across calls."""
        words = np.ascontiguousarray(pts, dtype=np.float64).reshape(-1).view(np.uint32)
        width = 1 << SAMPLE_ROW_BITS
        rows, tail = divmod(words.size, 4 * width)
        if rows + 1 > _TEXTURE_ROWS_MAX:
            raise RuntimeError(f"internal error: {words.size // 4} texels of positions need more than "
                               f"{_TEXTURE_ROWS_MAX} rows of {width}")
        objs = self.held.objects
        got = objs.get("samples")
        tex = got[1] if got is not None else None
        if tex is None or tex.height < rows + 1:
            _release(tex)
            tex = self.ctx.texture((width, min(_TEXTURE_ROWS_MAX, max(rows + 1, (rows + 1) * 5 // 4))), 4, dtype="u4")
            tex.filter = (0x2600, 0x2600)        # GL_NEAREST: an integer texture is complete only so
            objs["samples"] = (None, tex)
        if rows:
            tex.write(words[: rows * width * 4], viewport=(0, 0, width, rows))
        if tail:
            rest = words[rows * width * 4:]
            if tail % 4:                         # 3D, an odd count: the last texel is half a sample
                rest = np.concatenate([rest, np.zeros(4 - tail % 4, np.uint32)])
            tex.write(rest, viewport=(0, rows, rest.size // 4, 1))
        tex.use(0)
        set_uniform(prog, "u_samples", 0)


def grid_slabs(X: int, Y: int, Z: int, W: int, step: int, local: int = LOCAL_SIZE):
    """The dispatches of an X x Y x Z x W grid (x fastest), each contiguous in the output and within
    :data:`_MAX_GROUPS` work groups on every axis: yields ``((x0, y0, z0, w, cols, rows), first
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
    if X * Y <= step and Y <= _MAX_GROUPS:
        ny, nz = Y, max(1, min(step // (X * Y), _MAX_GROUPS))
    else:
        ny, nz = max(1, min(step // X, _MAX_GROUPS)), 1
    gx = (X + local - 1) // local
    for w in range(W):
        for z0 in range(0, Z, nz):
            for y0 in range(0, Y, ny):
                cy, cz = min(ny, Y - y0), min(nz, Z - z0)
                yield (0, y0, z0, w, X, cy), ((w * Z + z0) * Y + y0) * X, (gx, cy, cz)
