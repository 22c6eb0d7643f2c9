"""The seam between cellgl's two GPU paths: one :class:`Runner` per context, the only code that
dispatches or draws.

The layers above (``basis/``, ``texture/``, ``pups/``) describe a pass (:class:`Pass`: the entry of
each path, its ``#define``s and uniforms, the samples' input, the outputs and their destination
arrays, the flag, the path choices it would like: ``group_defines``, ``check``) and hand it to
``runner(ctx).run(pass)``; they never ask which path runs. The runner of a context is chosen by
:func:`cellgl.gl.path.gpu_path` (compute from OpenGL 4.3, else fragment; ``CELLGL_PATH`` forces one):

* :class:`ComputeRunner` dispatches the ``*.comp`` entry: inputs in storage buffers and textures,
  each output a storage buffer at its binding, read back straight into the destination array
  (the layout: :mod:`cellgl.gl.compute`);
* :class:`FragmentRunner` draws the fragment entry over a render target
  ``WIDTH`` samples wide: inputs in textures, each output a tightly packed render target (R, RG or
  RGBA of its kind: float, uint or int), location 0 the flag (the layout: :mod:`cellgl.gl.fragment`).

Both tile the work so that no dispatch or draw runs longer than about a second on the slowest GPU
cellgl supports (:func:`tile_samples`; docs/architecture.md, "The seam"). Raster and full-screen
draws (:class:`Draw`: PUPs' raster path, ``render_fragment``, the viewer) run through
:meth:`Runner.draw` (:mod:`cellgl.gl.draws`), with the path's programs (:meth:`Runner.program`).

What a pass and a draw are: :mod:`cellgl.gl.dispatch`. Everything a context holds for cellgl,
programs (the ONE cache: compute entries, fragment entries and the vertex + fragment programs of
the draws), storage words, sample inputs, render targets and vertex buffers, lives in one registry
entry per context (:mod:`cellgl.gl.registry`): dropped with the context and, without touching the
parent's driver objects, in a forked child.
"""
from __future__ import annotations

from collections import OrderedDict

import numpy as np

from cellgl.gl import compute as _comp
from cellgl.gl import context, glsl
from cellgl.gl import dispatch as _d
from cellgl.gl import fragment as _frag
from cellgl.gl import path as _path
from cellgl.gl import registry
from cellgl.gl.compute import (CHUNK_BYTES, LOCAL_SIZE, SAMPLE_ROW_BITS, STORAGE_BLOCK_MAX, STORAGE_BLOCK_MIN,
                               TEXTURE_ROWS_MAX, grid_slabs)
from cellgl.gl.dispatch import (Draw, Flag, Grid, Image, Index, Output, Pass, Positions, Result, Rows, Sampler,
                                Vertices, tile_samples)
from cellgl.gl.fragment import (CHUNK, KIND, MAX_TARGETS, SAMPLERS, STORAGE_ROW_BITS, WIDTH, axis_tables,
                                draw_buffers, kind_of, pass_defines, read_rows, slots, split_points, target_comps)
from cellgl.gl.draws import FILTERS, Drawing, Target, set_uniform, set_uniforms
from cellgl.gl.registry import release_object, drop, held, store

__all__ = ["Runner", "ComputeRunner", "FragmentRunner", "runner", "held", "drop", "store", "Pass", "Output",
           "Flag", "Positions", "Grid", "Rows", "Index", "Image", "Result", "tile_samples", "set_uniform",
           "set_uniforms", "Draw", "Vertices", "Sampler", "Target"]


def runner(ctx=None) -> Runner:
    """The runner of ``ctx`` (default: cellgl's context) for the path
    :func:`cellgl.gl.path.gpu_path` gives it, made on first use and kept in the context's entry."""
    h = held(ctx if ctx is not None else context.get_context())
    kind = _path.gpu_path(h.ctx)   # (looked up on the module: tests stand in for it)
    r = h.runners.get(kind)
    if r is None:
        r = h.runners[kind] = (ComputeRunner if kind == "compute" else FragmentRunner)(h)
    return r


class Runner(Drawing):
    """The runner of one context and path; see the module's doc (draws, render targets and the
    objects it keeps: :class:`cellgl.gl.draws.Drawing`)."""

    path = ""
    #: whether invocations run in work groups of :attr:`Image.local` aligned to the image (an
    #: entry may then share work across a group, e.g. PUPs' one grid cell per group)
    groups = False

    def __init__(self, h):
        self.held = h
        #: whether a GPU watchdog can reset the device (tiles: :func:`cellgl.gl.dispatch.tile_samples`)
        self.watchdog = _d.has_watchdog(self.ctx)

    # -- programs ------------------------------------------------------------------------------

    def compute_program(self, name: str, defines=None, *, files=None, lru=None):
        """The compute shader ``shaders/<name>`` with ``defines`` and generated ``files``
        (:func:`cellgl.gl.context.compute_program`); ``lru`` (name, size): kept among the group's
        last ``size`` programs only."""
        return context.compute_program(name, defines, ctx=self.ctx, files=files, lru=lru)

    def program(self, vertex: str, fragment: str, defines=None):
        """A vertex + fragment program of ``shaders/`` with this path's ``#define``s
        (:meth:`path_defines`) and sampler units, in the context's one cache."""
        return self._program(vertex, fragment, defines)[0]

    def _program(self, vertex: str, fragment: str, defines=None):
        """``(program, empty vertex array)``: :meth:`program` and what draws it full-screen."""
        d = {**(defines or {}), **self.path_defines()}
        prog, vao = context.program_entry(vertex, fragment, d, ctx=self.ctx)
        self._samplers(prog)
        return prog, vao

    def path_defines(self) -> dict:
        """The ``#define``s this path adds to every vertex + fragment program (the storage words'
        layout, ``shaders/storage.glsl``)."""
        return {}

    def _samplers(self, prog) -> None:
        """Point the storage words' samplers at their units (the fragment path)."""

    def entry(self, fragment: str, defines=None, *, files=None, lru=None):
        """``(program, vertex array)``: the fragment entry ``shaders/<fragment>`` with
        ``tiles.vert``, ``defines`` and generated ``files``, in the context's one cache."""
        d = dict(defines or {})
        d.setdefault("CELL_FRAG_WIDTH", WIDTH)
        d.setdefault("CELL_STORAGE_ROW_BITS", STORAGE_ROW_BITS)
        key = registry.program_key("fragment", fragment, defines=d, files=files)

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
            set_uniforms(prog, SAMPLERS)
            return prog, self.ctx.vertex_array(prog, [])
        return registry.cached(self.ctx, key, make, lru)

    # -- objects --------------------------------------------------------------------------------

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
            release_object(tex)
            tex = self.ctx.texture((width, max(rows, 8)), comps, dtype=dtype)
            tex.filter = FILTERS[False]
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
        self._bind_words(data, raw, raw, binding, 1)    # matched by the bytes: a hash can collide

    def bind_records(self, records, binding: int) -> None:
        """Upload uint32 ``records`` (R, 4) (cached by content per binding) and bind them where the
        entries read them: storage buffer ``binding`` or an RGBA32UI texture ``u_in<binding>``,
        record k at texel (k mod 2^STORAGE_ROW_BITS, k >> STORAGE_ROW_BITS)."""
        data = np.ascontiguousarray(records, dtype=np.uint32).reshape(-1, 4)
        if not len(data):
            data = np.zeros((1, 4), np.uint32)
        raw = data.tobytes()
        self._bind_words(data, raw, raw, binding, 4)

    def run(self, p: Pass) -> Result:  # pragma: no cover - each path's own
        raise NotImplementedError

    def grouped(self, p: Pass) -> bool:
        """Whether ``p`` runs grouped here: it asks to (``group_defines``) and this path runs
        invocations in work groups aligned to the samples (:attr:`groups`)."""
        return self.groups and p.group_defines is not None

    def _prepare(self, p: Pass, prog) -> None:
        """The pass's own setup and uniforms on ``prog``."""
        if p.setup is not None:
            p.setup(prog)
        set_uniforms(prog, p.uniforms)


#: the head of the flag's region on the compute path: the counter (0) and the canary's length
_CANARY_HEADER = np.array([0, _d.LOOP_CANARY_PASSES], np.uint32).tobytes()


class FragmentRunner(Runner):
    """OpenGL 3.3 core and up: draws of the fragment entry, outputs in render targets."""

    path = "fragment"

    # -- programs and objects -------------------------------------------------------------------

    def path_defines(self) -> dict:
        # storage words in textures (shaders/storage.glsl: defined, the textures' row bits)
        return {"CELL_STORAGE_ROW_BITS": STORAGE_ROW_BITS}

    def _samplers(self, prog) -> None:
        for name, unit in SAMPLERS.items():
            set_uniform(prog, name, unit)

    def _bind_words(self, data, raw, content, binding, comps):
        width = 1 << STORAGE_ROW_BITS

        def make():
            texels = data.size // comps
            rows = max(1, -(-texels // width))
            padded = np.zeros(rows * width * comps, np.uint32)
            padded[:data.size] = data.reshape(-1)
            tex = self.ctx.texture((width, rows), comps, padded.tobytes(), dtype="u4")
            tex.filter = FILTERS[False]          # nearest: an integer texture is complete only so
            return tex
        self._object(("words", binding), (content, comps), make).use(binding)

    def _target(self, formats, rows: int):
        """A framebuffer of len(formats) attachments WIDTH x rows (or taller), kept per formats
        (the last :data:`MAX_TARGETS`)."""
        held_all = store("fragment.targets", self.ctx).setdefault("sets", OrderedDict())
        key = tuple(formats)
        got = held_all.get(key)
        if got is None or got[0] < rows:
            height = max(rows, 8)
            texs = [self.ctx.texture((WIDTH, height), c, dtype=dt) for c, dt in formats]
            fbo = self.ctx.framebuffer(color_attachments=texs)
            fbo.use()            # bound before the old ones go (moderngl restores the last binding)
            if got is not None:
                for o in got[1]:
                    o.release()
            got = held_all[key] = (height, [fbo] + texs)
            while len(held_all) > MAX_TARGETS:
                for o in held_all.popitem(last=False)[1][1]:
                    o.release()
        held_all.move_to_end(key)
        return got[1][0]

    # -- running a pass -------------------------------------------------------------------------

    def run(self, p: Pass) -> Result:
        if p.check is not None:
            p.check(False)
        layout = [(o.name, kind_of(o.array), o.array.shape[1]) for o in p.outputs]
        per = draw_buffers(self.ctx) - (1 if p.flag is not None else 0)
        all_slots = slots(layout)
        draws = [all_slots[i:i + per] for i in range(0, len(all_slots), per)] or [[]]
        base = dict(p.defines)
        inp = p.inputs
        if isinstance(inp, Grid):
            base["CELL_FRAG_GRID_AXES"] = max([1] + [a + 1 for a, e in enumerate(inp.shape) if int(e) > 1])
        progs = []
        for draw_slots in draws:
            d = dict(base)
            d.update(pass_defines(p.flag, draw_slots))
            prog, vao = self.entry(p.fragment, d, files=p.files, lru=p.lru)
            self._prepare(p, prog)
            progs.append((prog, vao, draw_slots))
        if isinstance(inp, Grid):
            self._grid(inp, [q for q, _, _ in progs])
        # the canary's length, one texel (never a uniform: a compiler may fold those and unroll)
        self.bind_words(np.array([_d.LOOP_CANARY_PASSES], np.uint32), _d.CANARY_UNIT)
        by_name = {o.name: o.array for o in p.outputs}
        self.ctx.enable_only(self.ctx.NOTHING)     # no blend or depth test left by another draw
        res = Result(flagged=np.zeros(p.count, bool) if p.flag and p.flag.mode == "list" else None)
        tile = tile_samples(p.cost, self.watchdog)
        chunk = max(CHUNK, tile // WIDTH * WIDTH)
        for first in range(0, p.count, chunk):
            m = min(chunk, p.count - first)
            ok = self._inputs(inp, first, m)
            for prog, vao, draw_slots in progs:
                set_uniform(prog, "u_first", first)
                # the flag (0 or 1) in an R8UI target: a quarter of the bytes of R32UI to read back
                formats = ([(1, "u1")] if p.flag is not None else [])
                formats += [(target_comps(k), KIND[kind][0]) for _, kind, _, k in draw_slots]
                rows = -(-m // WIDTH)
                fbo = self._target(formats, rows)
                fbo.use()
                for viewport in _frag.tiles(rows, tile):
                    fbo.viewport = viewport
                    vao.render(mode=self.ctx.TRIANGLES, vertices=3)
                att = 0
                if p.flag is not None:
                    flags = np.empty((m, 1), np.uint8)
                    read_rows(fbo, 0, flags, "u1")
                    if p.flag.mode == "count":
                        res.cut += m - int(np.count_nonzero(flags))
                    else:
                        assert res.flagged is not None          # a "list" flag: made above
                        np.logical_or(res.flagged[first:first + m], flags[:, 0] == 0,
                                      out=res.flagged[first:first + m])
                    att = 1
                for k_att, (name, kind, c0, k) in enumerate(draw_slots, start=att):
                    dest = by_name[name][first:first + m]
                    tc = target_comps(k)
                    if c0 == 0 and k == tc == dest.shape[1]:
                        read_rows(fbo, k_att, dest, KIND[kind][0])      # straight into the caller's array
                    else:
                        tmp = np.empty((m, tc), dest.dtype)
                        read_rows(fbo, k_att, tmp, KIND[kind][0])
                        dest[:, c0:c0 + k] = tmp[:, :k]
            if ok is not None:
                assert res.flagged is not None, "points split on the CPU need a 'list' flag to report them"
                res.flagged[first:first + m] |= ~ok
        return res

    def _grid(self, g: Grid, progs) -> None:
        cells, fracs, offsets = axis_tables(g.shape, g.cell, g.frac, g.spacing)
        table = np.stack([cells, fracs.view(np.int32)], axis=1)      # RG32I: cell, the fraction's bits
        self.input_texture(0, table, 1 << STORAGE_ROW_BITS)
        for prog in progs:
            set_uniform(prog, "u_grid", tuple(int(v) for v in g.shape))
            set_uniform(prog, "u_axis_offset", tuple(offsets))
            set_uniform(prog, "u_axis_cell", tuple(int(cells[o]) for o in offsets))
            set_uniform(prog, "u_axis_frac", tuple(float(fracs[o]) for o in offsets))

    def _inputs(self, inp, first: int, m: int):
        """Upload chunk [first, first + m) of the samples' input; the in-range flags of positions."""
        if isinstance(inp, Positions):
            pts = inp.pts[first:first + m]
            if inp.dim == 2:                    # one texel: the cell and the fraction's bits
                texels = np.empty((m, 4), np.int32)
                _, _, ok = split_points(pts, inp.scale, 2, texels[:, :2], texels[:, 2:].view(np.float32))
                self.input_texture(0, texels)
            else:
                cell, frac, ok = split_points(pts, inp.scale, inp.dim)
                self.input_texture(0, cell)
                self.input_texture(1, frac)
            return ok
        if isinstance(inp, Rows):
            self.input_texture(inp.binding, inp.array[first:first + m])
        elif not isinstance(inp, (Grid, Index, Image)):
            raise TypeError(f"unknown input {inp!r}")
        return None


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

    def storage(self, binding: int, nbytes: int, bind: bool = True):
        """A storage buffer of at least ``nbytes`` for ``binding`` (bound to it unless ``bind`` is
        False), reused across calls (grown, its content lost, when too small)."""
        objs = self.held.objects
        got = objs.get(("storage", binding))
        if got is None or got[1].size < nbytes:
            if got is not None:
                release_object(got[1])
            got = objs[("storage", binding)] = (None, self.ctx.buffer(reserve=max(64, nbytes + nbytes // 4)))
        if bind:
            got[1].bind_to_storage_buffer(binding)
        return got[1]

    def block_bytes(self) -> int:
        """The bytes one storage block may hold on this context (GL_MAX_SHADER_STORAGE_BLOCK_SIZE),
        within [16 MiB (GL 4.3's guarantee), 128 MiB]."""
        v = self.ctx.info.get("GL_MAX_SHADER_STORAGE_BLOCK_SIZE") or STORAGE_BLOCK_MIN
        return int(min(STORAGE_BLOCK_MAX, max(STORAGE_BLOCK_MIN, int(v))))

    def _step(self, p: Pass, local: int) -> int:
        """Samples per dispatch: the watchdog's tile, within the context's storage block."""
        per = max([o.row_bytes for o in p.outputs] + [4])
        by_bytes = self.block_bytes() // per
        step = min(tile_samples(p.cost, self.watchdog), by_bytes, local * _d.MAX_GROUPS)
        return max(local, step // local * local)

    def offset_alignment(self) -> int:
        """GL_SHADER_STORAGE_BUFFER_OFFSET_ALIGNMENT (256, the most the spec allows, where unknown)."""
        got = self.held.objects.get("ssbo-align")
        if got is None:
            v = context.get_integer(self.ctx, 0x90DF)
            got = self.held.objects["ssbo-align"] = (None, int(v) if v and v > 0 else 256)
        return got[1]

    def run(self, p: Pass) -> Result:
        """Dispatch ``p`` in tiles (the watchdog's); the tiles of a chunk write ranges of one
        buffer per output, read back once per chunk straight into the destination arrays."""
        grouped = self.grouped(p)
        if p.check is not None:
            p.check(grouped)
        d = dict(p.defines)
        d.update((p.group_defines or {}) if grouped else {})
        d.setdefault("CELL_LOCAL_SIZE", LOCAL_SIZE)
        local = int(d["CELL_LOCAL_SIZE"])
        prog = self.compute_program(p.compute, d, files=p.files, lru=p.lru)
        self._prepare(p, prog)
        inp = p.inputs
        if isinstance(inp, Positions):
            set_uniform(prog, "u_scale", float(inp.scale))
        elif isinstance(inp, Grid):
            set_uniform(prog, "u_origin_cell", tuple(int(v) for v in inp.cell))
            set_uniform(prog, "u_origin_frac", tuple(float(v) for v in inp.frac))     # dvec4
            set_uniform(prog, "u_spacing", tuple(float(v) for v in inp.spacing))
        res = Result(flagged=np.zeros(p.count, bool) if p.flag and p.flag.mode == "list" else None)
        align = self.offset_alignment()
        sizes = [o.row_bytes for o in p.outputs]
        step = self._step(p, local)
        cap = max(step, CHUNK_BYTES // max(sizes + [4]) // step * step)
        # the flag's region of each piece: a counter, the canary's length (and the list mode's
        # indices), aligned
        stride = -(-4 * (step + 2 if p.flag and p.flag.mode == "list" else 2) // align) * align
        chunk: list = []
        slots = 0
        for piece in self._pieces(p, local):
            first, m = piece[0], piece[1]
            if chunk and (first + m - chunk[0][0] > cap or len(chunk) == slots
                          or any((first - chunk[0][0]) * b % align for b in sizes)):
                self._flush(p, chunk, res, stride)
                chunk = []
            if not chunk:                   # the chunk's buffers, whole (a dispatch never grows them)
                n = min(cap, p.count - first)
                for o in p.outputs:
                    self.storage(o.binding, n * o.row_bytes, bind=False)
                slots = 2 * -(-n // step) + 1       # flag regions: pieces may be shorter than a tile
                if p.flag is not None:
                    self.storage(p.flag.binding, slots * stride, bind=False)
            chunk.append(piece)
            self._dispatch(p, prog, chunk, stride)
        if chunk:
            self._flush(p, chunk, res, stride)
        return res

    def _dispatch(self, p: Pass, prog, chunk: list, stride: int) -> None:
        """Dispatch the last piece of ``chunk`` into its ranges of the chunk's buffers."""
        first, m, groups, extra = chunk[-1]
        c0 = chunk[0][0]
        inp = p.inputs
        if isinstance(inp, Positions):
            self._upload_positions(prog, inp.pts[first:first + m])
        elif isinstance(inp, Rows):
            rows = np.ascontiguousarray(inp.array[first:first + m])
            self.storage(inp.binding, rows.nbytes).write(rows)
        for name, value in extra:
            set_uniform(prog, name, value)
        set_uniform(prog, "u_count", m)
        set_uniform(prog, "u_first", first)
        objs = self.held.objects
        for o in p.outputs:
            rb = o.row_bytes
            objs[("storage", o.binding)][1].bind_to_storage_buffer(o.binding, offset=(first - c0) * rb, size=m * rb)
        if p.flag is not None:
            at = (len(chunk) - 1) * stride
            flag = objs[("storage", p.flag.binding)][1]
            # the counter, 0, and the canary's length: storage, so no compiler folds it (_d)
            flag.write(_CANARY_HEADER, offset=at)
            flag.bind_to_storage_buffer(p.flag.binding, offset=at, size=stride)
        if max(groups) > _d.MAX_GROUPS:  # GL drops such a dispatch: the buffers would stay unwritten
            raise RuntimeError(f"internal error: dispatch of {groups} work groups exceeds {_d.MAX_GROUPS}")
        prog.run(*groups)

    def _flush(self, p: Pass, chunk: list, res: Result, stride: int) -> None:
        """Wait for the chunk's dispatches; read its outputs and flags."""
        self.ctx.memory_barrier()
        c0 = chunk[0][0]
        end = chunk[-1][0] + chunk[-1][1] - c0
        objs = self.held.objects
        for o in p.outputs:
            rb = o.row_bytes
            buf = objs[("storage", o.binding)][1]
            if rb == o.array.strides[0]:        # straight into the caller's array
                buf.read_into(o.array[c0:c0 + end], size=end * rb)
            else:                               # the entry writes more than is wanted
                rows = np.empty((end, rb // 4), o.array.dtype)
                buf.read_into(rows, size=end * rb)
                o.array[c0:c0 + end] = rows[:, :o.array.shape[1]]
        if p.flag is None:
            return
        flag = objs[("storage", p.flag.binding)][1]
        for k, (first, _m, _, _) in enumerate(chunk):
            nbad = int(np.frombuffer(flag.read(4, offset=k * stride), dtype=np.uint32)[0])
            if p.flag.mode == "count":
                res.cut += nbad
            elif nbad:
                assert res.flagged is not None          # a "list" flag: made by the caller
                idx = np.frombuffer(flag.read(4 * nbad, offset=k * stride + 8), dtype=np.uint32)
                res.flagged[first + idx.astype(np.int64)] = True

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
            align = inp.group_align if self.grouped(p) and inp.group_align else inp.align
            yield from _comp.image_bands(inp.width, inp.height, inp.local,
                                         max(align, (step // max(1, inp.width)) // align * align))
            return
        for first in range(0, p.count, step):
            m = min(step, p.count - first)
            yield first, m, (-(-m // local), 1, 1), ()

    def _upload_positions(self, prog, pts: np.ndarray) -> None:
        """float64 positions (m, d) on unit 0 (``u_samples``) as :func:`cellgl.gl.compute.
        sample_words` lays them out; the texture kept and grown across calls."""
        full, rest = _comp.sample_words(pts)
        width = 1 << SAMPLE_ROW_BITS
        rows = full.size // (4 * width)
        objs = self.held.objects
        got = objs.get("samples")
        tex = got[1] if got is not None else None
        if tex is None or tex.height < rows + 1:
            release_object(tex)
            tex = self.ctx.texture((width, min(TEXTURE_ROWS_MAX, max(rows + 1, (rows + 1) * 5 // 4))), 4, dtype="u4")
            tex.filter = FILTERS[False]         # an integer texture is complete only so
            objs["samples"] = (None, tex)
        if rows:
            tex.write(full, viewport=(0, 0, width, rows))
        if rest.size:
            tex.write(rest, viewport=(0, rows, rest.size // 4, 1))
        tex.use(0)
        set_uniform(prog, "u_samples", 0)
