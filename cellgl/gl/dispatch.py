"""The fragment path's runner (:class:`FragmentRunner`; the seam: :mod:`cellgl.gl.runner`).

OpenGL 3.3 core and up without compute shaders (Apple's 4.1 core included; :mod:`cellgl.gl.path`)
runs the same ``shaders/lib`` code in fragment programs over tiled quads:

* **Programs.** A ``#version 330 core`` fragment entry of ``shaders/`` with ``tiles.vert`` (a
  triangle covering the viewport from ``gl_VertexID``), compiled once per context into the
  runner's one cache together with its vertex array; storage samplers bound to their units
  (:data:`SAMPLERS`).
* **Inputs.** Storage words (:meth:`cellgl.gl.runner.Runner.bind_words`) are an R32UI texture
  2^STORAGE_ROW_BITS words wide on texture unit ``binding`` (``shaders/storage.glsl``); records
  RGBA32UI (``u_in<binding>``). Sample inputs are textures :data:`WIDTH` texels wide, sample j at
  texel (j % WIDTH, j // WIDTH). Positions are split into cell and float32 fraction in NumPy with
  cellular.comp's float64 operations (OpenGL 3.3 has no doubles; :func:`split_points`); a grid is
  separable (:func:`axis_tables`).
* **Outputs.** Fragment (x, y) of a :data:`WIDTH`-wide target is sample ``y * WIDTH + x``. Each
  output's components are spread over render targets of at most 4 channels of its own kind (float,
  uint or int: integers travel in integer targets), packed tight (R, RG or RGBA), location 0 the
  flag; where they exceed the draw buffers, several draws each write a part (:func:`slots`). The
  entry defines ``row_<name>`` arrays; the runner writes ``CELL_FRAG_DECL`` and
  ``CELL_FRAG_WRITE`` from them. Readback goes straight into the caller's array where one target
  carries a whole output.
* **Tiles.** Draws of at most :func:`cellgl.gl.runner.tile_samples` samples (the watchdog).
"""
from __future__ import annotations

from collections import OrderedDict

import numpy as np

from cellgl.gl.path import STORAGE_ROW_BITS
from cellgl.gl.runner import (SAMPLERS, WIDTH, Grid, Image, Index, Pass, Positions, Result, Rows, Runner,
                              set_uniform, store, tile_samples)

__all__ = ["WIDTH", "CHUNK", "STORAGE_ROW_BITS", "FragmentRunner", "slots", "draw_buffers",
           "split_points", "axis_tables", "MAX_TARGETS"]

#: samples per upload and read-back (one render-target set; a multiple of WIDTH)
CHUNK = 1 << 19
#: render-target sets kept per context (least recently used released)
MAX_TARGETS = 4
_COORD_LIMIT = 1073741824.0
_KIND = {"f": ("f4", "float", "vec"), "u": ("u4", "uint", "uvec"), "i": ("i4", "int", "ivec")}


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


def _target_comps(k: int) -> int:
    """Channels of the target of a slot of ``k`` components: R, RG or RGBA (RGB32F, RGB32UI are
    not colour-renderable in OpenGL 3.3)."""
    return k if k in (1, 2) else 4


def split_points(pts: np.ndarray, scale: float, dim: int):
    """cellular.comp's split of positions ``pts`` (N, dim) float64 times ``scale``: (cell int32
    (N, dim), fraction float32 (N, dim), in range (N,) bool). Out of range (|x| >= 2^30 cells, or
    NaN): searched at 0 and flagged, as there."""
    x = pts[:, :dim] * np.float64(scale)
    lo, hi = (x.min(), x.max()) if x.size else (0.0, 0.0)
    if -_COORD_LIMIT < lo and hi < _COORD_LIMIT:        # False for NaN: the careful way below
        ok = np.ones(len(x), bool)
    else:
        with np.errstate(invalid="ignore"):
            inside = np.abs(x) < _COORD_LIMIT
        x[~inside] = 0.0
        ok = inside.all(axis=1)
    fl = np.floor(x)
    np.subtract(x, fl, out=x)
    frac = x.astype(np.float32)                         # float64 -> float32, to nearest
    cell = fl.astype(np.int32)
    up = frac >= 1.0                                    # a fraction just below 1 rounds up to 1
    if up.any():
        cell += up
        frac[up] = 0.0
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


def _kind(a: np.ndarray) -> str:
    return {"f": "f", "u": "u", "i": "i"}[a.dtype.kind]


def _pass_defines(flag, draw_slots) -> dict:
    """CELL_FRAG_DECL and CELL_FRAG_WRITE of one draw: the flag at location 0 (``o_<name>``), then
    each slot a target of its kind, written from the entry's ``row_<name>``."""
    decl, write = [], []
    loc = 0
    if flag is not None:
        decl.append(f"layout(location = 0) out uint o_{flag.name};")
        loc = 1
    for name, kind, first, k in draw_slots:
        _, scalar, vec = _KIND[kind]
        tc = _target_comps(k)
        t = scalar if tc == 1 else f"{vec}{tc}"
        zero = {"f": "0.0", "u": "0u", "i": "0"}[kind]
        comps = [f"row_{name}[{first + c}]" if c < k else zero for c in range(tc)]
        decl.append(f"layout(location = {loc}) out {t} o_{loc};")
        write.append(f"o_{loc} = {t}({', '.join(comps)});")
        loc += 1
    return {"CELL_FRAG_DECL": " ".join(decl), "CELL_FRAG_WRITE": " ".join(write)}


class FragmentRunner(Runner):
    """OpenGL 3.3 core and up: draws of the fragment entry, outputs in render targets."""

    path = "fragment"

    # -- programs and objects -------------------------------------------------------------------

    def _bind_words(self, data, raw, content, binding, comps):
        width = 1 << STORAGE_ROW_BITS

        def make():
            texels = data.size // comps
            rows = max(1, -(-texels // width))
            padded = np.zeros(rows * width * comps, np.uint32)
            padded[:data.size] = data.reshape(-1)
            tex = self.ctx.texture((width, rows), comps, padded.tobytes(), dtype="u4")
            tex.filter = (0x2600, 0x2600)          # GL_NEAREST: an integer texture is complete only so
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
        layout = [(o.name, _kind(o.array), o.array.shape[1]) for o in p.outputs]
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
            d.update(_pass_defines(p.flag, draw_slots))
            prog, vao = self.entry(p.fragment, d, files=p.files, lru=p.lru)
            if p.setup is not None:
                p.setup(prog)
            progs.append((prog, vao, draw_slots))
        if isinstance(inp, Grid):
            self._grid(inp, [q for q, _, _ in progs])
        by_name = {o.name: o.array for o in p.outputs}
        res = Result(flagged=np.zeros(p.count, bool) if p.flag and p.flag.mode == "list" else None)
        tile_rows = max(1, tile_samples(p.cost) // WIDTH)
        chunk = max(CHUNK, tile_rows * WIDTH)
        for first in range(0, p.count, chunk):
            m = min(chunk, p.count - first)
            ok = self._inputs(inp, first, m)
            for prog, vao, draw_slots in progs:
                set_uniform(prog, "u_first", first)
                formats = ([(1, "u4")] if p.flag is not None else [])
                formats += [(_target_comps(k), _KIND[kind][0]) for _, kind, _, k in draw_slots]
                rows = -(-m // WIDTH)
                fbo = self._target(formats, rows)
                fbo.use()
                for r0 in range(0, rows, tile_rows):
                    fbo.viewport = (0, r0, WIDTH, min(tile_rows, rows - r0))
                    vao.render(mode=self.ctx.TRIANGLES, vertices=3)
                att = 0
                if p.flag is not None:
                    flags = np.empty((m, 1), np.uint32)
                    _read(fbo, 0, flags, "u4")
                    if p.flag.mode == "count":
                        res.cut += int(np.count_nonzero(flags[:, 0] == 0))
                    else:
                        res.flagged[first:first + m] |= flags[:, 0] == 0
                    att = 1
                for k_att, (name, kind, c0, k) in enumerate(draw_slots, start=att):
                    dest = by_name[name][first:first + m]
                    tc = _target_comps(k)
                    if c0 == 0 and k == tc == dest.shape[1]:
                        _read(fbo, k_att, dest, _KIND[kind][0])      # straight into the caller's array
                    else:
                        tmp = np.empty((m, tc), dest.dtype)
                        _read(fbo, k_att, tmp, _KIND[kind][0])
                        dest[:, c0:c0 + k] = tmp[:, :k]
            if ok is not None:
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
            cell, frac, ok = split_points(inp.pts[first:first + m], inp.scale, inp.dim)
            if inp.dim == 2:                    # one texel: the cell and the fraction's bits
                self.input_texture(0, np.concatenate([cell, frac.view(np.int32)], axis=1))
            else:
                self.input_texture(0, cell)
                self.input_texture(1, frac)
            return ok
        if isinstance(inp, Rows):
            self.input_texture(inp.binding, inp.array[first:first + m])
        elif not isinstance(inp, (Grid, Index, Image)):
            raise TypeError(f"unknown input {inp!r}")
        return None


def _read(fbo, attachment: int, dest: np.ndarray, dtype: str) -> None:
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
