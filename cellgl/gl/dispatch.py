"""Run a pass of cellgl's shaders on either GPU path: the one place that knows both.

A pass evaluates ``shaders/lib`` code once per sample. On the compute path (OpenGL 4.3) the
callers dispatch their ``*.comp`` entries themselves; this module gives them what differs on the
fragment path (OpenGL 3.3 core and up, Apple's 4.1 core included; :mod:`cellgl.gl.path`):

* :func:`program`: a ``#version 330 core`` fragment entry of ``shaders/`` with ``tiles.vert``,
  compiled once per context, defines and generated files, with its storage samplers bound to
  their units.
* :func:`bind_words`: what the lib's entries take from a storage buffer (density-image levels,
  cell-image texels, PUPs control points: "provided by the entry point") goes to storage buffer
  ``binding`` on the compute path and to an R32UI texture on texture unit ``binding`` on the
  fragment path, read with ``texelFetch`` (``shaders/storage.glsl``, ``cell_storage_word``).
* :func:`draw`: the program over ``count`` samples, fragment ``(x, y)`` of a
  :data:`WIDTH`-wide target being sample ``y * WIDTH + x``, each output location a render target
  (MRT) read back into one array per location. The draws are tiles of at most
  :data:`TILE_SAMPLES` samples each (docs/fragment-path.md: Windows and macOS reset a GPU whose
  batch runs past about 2 s).
* :func:`slots`: how a pass's per-sample outputs are spread over render targets of 4 channels
  and over several draws where they exceed the draw buffers.
"""
from __future__ import annotations

from collections import OrderedDict

import numpy as np

from cellgl.gl import context, glsl
from cellgl.gl.path import STORAGE_ROW_BITS, gpu_path

__all__ = ["WIDTH", "TILE_SAMPLES", "STORAGE_ROW_BITS", "path", "program", "bind_words", "draw",
           "slots", "draw_buffers"]

#: width of the fragment path's render targets, in samples
WIDTH = 1024
#: most samples one draw covers (docs/fragment-path.md, "Tiles"): 256 rows of WIDTH. The loop
#: budget bounds a sample's work (~6144 cell visits): the worst tile is ~20 ms on a discrete GPU,
#: ~200 ms on a small integrated one, 10x under the ~2 s after which Windows (TDR) and macOS
#: reset the GPU.
TILE_SAMPLES = 1 << 18
#: sampler uniform -> texture unit: the storage words of each binding (bind_words) and the
#: sample inputs of the entries (units 0..3)
SAMPLERS = {"u_storage_5": 5, "u_storage_6": 6, "u_storage_7": 7,
            "u_in0": 0, "u_in1": 1, "u_in2": 2, "u_in3": 3}

_programs: dict = {}
_words: dict = {}
_targets: dict = {}
_vaos: dict = {}


def path(ctx=None) -> str:
    """``"compute"`` or ``"fragment"``: the path cellgl runs on ``ctx`` (default its context)."""
    return gpu_path(ctx if ctx is not None else context.get_context())


def draw_buffers(ctx) -> int:
    """Render targets one draw may write (GL_MAX_DRAW_BUFFERS, at most 8; OpenGL 3.3 has 8)."""
    return max(2, min(8, int(ctx.info.get("GL_MAX_DRAW_BUFFERS", 8)),
                      int(ctx.info.get("GL_MAX_COLOR_ATTACHMENTS", 8))))


def program(fragment: str, defines=None, *, files=None, ctx=None, cache: bool = True):
    """The fragment entry ``shaders/<fragment>`` (``#version 330 core``) with ``tiles.vert``,
    ``defines`` and generated include ``files`` (:func:`cellgl.gl.glsl.load`), compiled once per
    context (``cache=False``: the caller owns and releases it). Its storage samplers are bound to
    their units (:data:`SAMPLERS`)."""
    ctx = ctx if ctx is not None else context.get_context()
    d = dict(defines or {})
    d.setdefault("CELL_FRAG_WIDTH", WIDTH)
    d.setdefault("CELL_STORAGE_ROW_BITS", STORAGE_ROW_BITS)
    key = (id(ctx), fragment, tuple(sorted((k, str(v)) for k, v in d.items())),
           tuple(sorted((files or {}).items())))
    prog = _programs.get(key) if cache else None
    if prog is not None and prog.ctx is ctx:
        return prog
    vs = glsl.load("tiles.vert", d)
    fs = glsl.load(fragment, d, files=files)
    try:
        prog = ctx.program(vertex_shader=vs.text, fragment_shader=fs.text)
    except Exception as exc:                           # moderngl.Error: the compiler's log
        err = glsl.ShaderError(f"compiling tiles.vert + {fragment}: {glsl.map_error(str(exc), fs).strip()}")
        err.sources = [vs, fs]
        raise err from None
    for name, unit in SAMPLERS.items():
        if name in prog:
            prog[name].value = unit
    if cache:
        _programs[key] = prog
    return prog


def bind_words(words, binding: int, ctx=None) -> None:
    """Upload uint32 ``words`` (cached by content, one per context and binding) and bind them
    where the entries read them: storage buffer ``binding`` (compute path) or an R32UI texture
    2^:data:`STORAGE_ROW_BITS` words wide on texture unit ``binding`` (fragment path)."""
    ctx = ctx if ctx is not None else context.get_context()
    data = np.ascontiguousarray(words, dtype=np.uint32).reshape(-1)
    fragment = gpu_path(ctx) == "fragment"
    raw = data.tobytes()
    key = (hash(raw), len(raw), fragment)
    held = _words.get((id(ctx), binding))
    if held is None or held[0] != key or held[2] is not ctx:
        if held is not None and held[2] is ctx:
            held[1].release()
        if fragment:
            width = 1 << STORAGE_ROW_BITS
            rows = max(1, -(-data.size // width))
            padded = np.zeros(rows * width, np.uint32)
            padded[:data.size] = data
            obj = ctx.texture((width, rows), 1, padded.tobytes(), dtype="u4")
            obj.filter = (0x2600, 0x2600)          # GL_NEAREST: an integer texture is complete only so
        else:
            obj = ctx.buffer(raw if raw else b"\0\0\0\0")
        held = _words[(id(ctx), binding)] = (key, obj, ctx)
    if fragment:
        held[1].use(binding)
    else:
        held[1].bind_to_storage_buffer(binding)


def input_texture(ctx, unit: int, array: np.ndarray, width: int = WIDTH):
    """Upload ``array`` (count, c) of int32 / uint32 / float32 to texture unit ``unit``: sample j
    at texel (j % width, j // width), c components, reused across calls (grown as needed)."""
    count, comps = array.shape
    dtype = {"i": "i4", "u": "u4", "f": "f4"}[array.dtype.kind]
    rows = max(1, -(-count // width))
    key = (id(ctx), "input", unit)
    held = _targets.get(key)
    tex = held[1] if held is not None and held[0] is ctx else None
    if tex is None or tex.height < rows or tex.components != comps or tex.dtype != dtype:
        if tex is not None:
            tex.release()
        tex = ctx.texture((width, max(rows, 8)), comps, dtype=dtype)
        tex.filter = (0x2600, 0x2600)
        _targets[key] = (ctx, tex)
    full, tail = divmod(count, width)
    a = np.ascontiguousarray(array)
    if full:
        tex.write(a[: full * width].tobytes(), viewport=(0, 0, width, full))
    if tail:
        tex.write(a[full * width:].tobytes(), viewport=(0, full, tail, 1))
    tex.use(unit)
    return tex


def slots(outputs) -> list[list[tuple[str, str, int]]]:
    """Spread per-sample outputs over render targets of 4 channels. ``outputs``: (name, kind
    ``"f"`` or ``"u"``, length) in order. Returns the slots in order, each a list of
    (name, kind, first component) (one kind per slot: a name never shares a slot)."""
    out = []
    for name, kind, length in outputs:
        for first in range(0, length, 4):
            out.append((name, kind, first))
    return out


#: render-target sets kept per context (least recently used released): a chunk's set of 8
#: RGBA32 targets is 8 x 16 MB
MAX_TARGETS = 4


def _target(ctx, formats, rows: int):
    """A framebuffer of len(formats) attachments WIDTH x rows (or taller), kept per context and
    formats (the last :data:`MAX_TARGETS`)."""
    held_all = _targets.setdefault((id(ctx), "fbos"), OrderedDict())
    key = tuple(formats)
    held = held_all.get(key)
    if held is None or held[0] is not ctx or held[1] < rows:
        height = max(rows, 8)
        texs = [ctx.texture((WIDTH, height), c, dtype=dt) for c, dt in formats]
        fbo = ctx.framebuffer(color_attachments=texs)
        fbo.use()            # bound before the old ones go (moderngl restores the last binding)
        if held is not None and held[0] is ctx:
            for o in held[2]:
                o.release()
        held = held_all[key] = (ctx, height, [fbo] + texs)
        while len(held_all) > MAX_TARGETS:
            old = held_all.popitem(last=False)[1]
            if old[0] is ctx:
                for o in old[2]:
                    o.release()
    held_all.move_to_end(key)
    return held[2][0]


def draw(prog, count: int, formats, ctx=None, before_tile=None) -> list[np.ndarray]:
    """Run fragment program ``prog`` over ``count`` samples (fragment (x, y) = sample
    ``y * WIDTH + x``) in draws of at most :data:`TILE_SAMPLES`; ``formats``: per output location
    (components, ``"f4"`` or ``"u4"``). ``before_tile(first_sample)`` is called before each draw.
    Returns per location an array (count, components)."""
    ctx = ctx if ctx is not None else context.get_context()
    rows = max(1, -(-count // WIDTH))
    fbo = _target(ctx, formats, rows)
    fbo.use()
    vkey = (id(ctx), id(prog))
    held = _vaos.get(vkey)
    if held is None or held[0] is not prog:
        held = _vaos[vkey] = (prog, ctx.vertex_array(prog, []))
    vao = held[1]
    tile = TILE_SAMPLES // WIDTH
    for r0 in range(0, rows, tile):
        if before_tile is not None:
            before_tile(r0 * WIDTH)
        fbo.viewport = (0, r0, WIDTH, min(tile, rows - r0))
        vao.render(mode=ctx.TRIANGLES, vertices=3)
    out = []
    for k, (comps, dt) in enumerate(formats):
        data = np.empty((rows * WIDTH, comps), np.dtype(dt))      # read straight into the array
        fbo.read_into(data, viewport=(0, 0, WIDTH, rows), components=comps, attachment=k, dtype=dt)
        out.append(data[:count])
    return out
