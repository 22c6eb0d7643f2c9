"""Raster and full-screen draws on a context, and what a runner keeps there (the seam:
:mod:`cellgl.gl.runner`; every :class:`cellgl.gl.runner.Runner` is a :class:`Drawing`).

A draw (:class:`cellgl.gl.dispatch.Draw`) names its vertex + fragment program, its render target
(:meth:`Drawing.target`: kept per key, remade when its size or formats change), its vertices
(:class:`cellgl.gl.dispatch.Vertices`: buffers kept per key and grown; none: one full-screen
triangle of the program's own empty vertex array), its uniforms, textures, viewport, clear, blend
and depth test; :meth:`Drawing.read` reads a target back. PUPs' raster path,
:func:`cellgl.texture.render_fragment` and the viewer draw only so: no module above ``gl/`` makes
a GL object or sets a uniform itself (:func:`set_uniform`, the one way).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from cellgl.gl.dispatch import Draw, Vertices
from cellgl.gl.registry import release_object

__all__ = ["Drawing", "Target", "set_uniform", "set_uniforms"]


def set_uniform(prog, name: str, value) -> None:
    """Set ``prog[name]`` where the compiler kept it (``name in prog`` would walk every member):
    a number or tuple as its value; a NumPy array of the uniform's scalar type (one row per
    element; a matrix column-major) written whole, cut to the elements the compiler kept (it may
    trim an array to the entries in use). The one way cellgl sets a uniform."""
    u = prog.get(name, None)
    if u is None:
        return
    if isinstance(value, np.ndarray):     # the elements kept, each of u.dimension scalars
        a = np.ascontiguousarray(value).reshape(-1)
        u.write(a[: getattr(u, "array_length", 1) * getattr(u, "dimension", a.size)].tobytes())
    else:
        u.value = value


def set_uniforms(prog, values) -> None:
    """:func:`set_uniform` for each ``name: value`` of ``values`` (None: none)."""
    for name, value in (values or {}).items():
        set_uniform(prog, name, value)


#: texture filters (min, mag): linear -> (GL_LINEAR, GL_LINEAR), else (GL_NEAREST, GL_NEAREST)
FILTERS = {False: (0x2600, 0x2600), True: (0x2601, 0x2601)}
#: moderngl's texture dtypes (f1: normalised bytes; u1, u4, i4: integers) as NumPy's
_NUMPY = {"f1": np.uint8, "u1": np.uint8, "f2": np.float16, "f4": np.float32, "u4": np.uint32, "i4": np.int32}


#: the target bound while a bound one is released (:meth:`Drawing.release`)
_PARKED = "gl.parked"


class Target:
    """A render target of a runner (:meth:`Drawing.target`): its framebuffer ``fbo``, its
    colour ``textures`` and their ``formats``, its ``depth`` buffer (or None) and ``size`` (w, h)."""

    def __init__(self, fbo, textures, depth, size, formats):
        self.fbo, self.textures, self.depth, self.size = fbo, list(textures), depth, tuple(size)
        self.formats = tuple(formats)     # (dtype, components) per colour attachment
        self.arrays: dict = {}            # read-back arrays kept (Runner.read)

    def release(self) -> None:
        for o in [self.fbo, *self.textures, self.depth]:
            release_object(o)


class _Vertices:
    """A draw's kept vertex buffers and their vertex array for one program."""

    def __init__(self, prog, layout, vbo, ibo, vao):
        self.prog, self.layout, self.vbo, self.ibo, self.vao = prog, layout, vbo, ibo, vao

    def release(self) -> None:
        for o in (self.vao, self.vbo, self.ibo):
            release_object(o)


class Drawing:
    """What a runner keeps on its context (``self.ctx``, registry entry ``self.held``) and how it
    draws; :meth:`_program` (the path's vertex + fragment programs) is the runner's."""

    held: Any

    @property
    def ctx(self) -> Any:
        """The context (through its state's weak reference: a runner never keeps it alive)."""
        return self.held.ctx

    def _program(self, vertex: str, fragment: str, defines=None) -> tuple:  # pragma: no cover
        raise NotImplementedError

    def _object(self, key, content, make):
        """The GL object under ``key``, remade (the old one released) when ``content`` changed."""
        objs = self.held.objects
        got = objs.get(key)
        if got is None or got[0] != content:
            obj = make()
            if got is not None:
                release_object(got[1])
            objs[key] = got = (content, obj)
        return got[1]

    def target(self, key: str, size, formats=(("f4", 4),), depth: bool = False, linear: bool = False) -> Target:
        """A render target ``size`` (w, h) kept under ``key``: one texture per ``formats`` entry
        (moderngl's dtype: ``"f1"`` normalised bytes, ``"f4"``, ``"u4"``...; components), a depth
        buffer with ``depth``; remade (the old one
        released after the new one is bound) when the size or formats change."""
        size = (max(1, int(size[0])), max(1, int(size[1])))

        def make():
            texs = [self.ctx.texture(size, c, dtype=dt) for dt, c in formats]
            for t in texs:
                t.filter = FILTERS[linear]
            rb = self.ctx.depth_renderbuffer(size) if depth else None
            fbo = self.ctx.framebuffer(texs, rb)
            fbo.use()            # bound before the old one goes (moderngl restores the last binding)
            return Target(fbo, texs, rb, size, formats)
        return self._object(("target", key), (size, tuple(formats), depth), make)

    def image(self, key: str, array: np.ndarray) -> object:
        """A float32 (h, w, c) ``array`` (c in 1..4) as a texture kept under ``key`` (rewritten;
        remade when the shape changes); row 0 at texture coordinate t = 0."""
        a = np.ascontiguousarray(array, np.float32)
        h, w, c = a.shape
        tex = self._object(("image", key), (w, h, c), lambda: self.ctx.texture((w, h), c, dtype="f4"))
        tex.write(a)
        return tex

    def release(self, key: str) -> None:
        """Release what is kept under ``key`` (:meth:`target`, :meth:`image`, a draw's vertices).
        A bound target is unbound first (a 1 x 1 target bound instead): moderngl rebinds the last
        framebuffer after a read, and a released one is GL_INVALID_OPERATION."""
        for k in [k for k in self.held.objects if isinstance(k, tuple) and k[1:2] == (key,)]:
            obj = self.held.objects[k][1]
            if isinstance(obj, Target) and key != _PARKED and getattr(self.ctx, "fbo", None) is obj.fbo:
                self.target(_PARKED, (1, 1)).fbo.use()
            release_object(self.held.objects.pop(k)[1])

    def read(self, target: Target, dest: np.ndarray | None = None, attachment: int = 0,
             viewport=None) -> np.ndarray:
        """Read ``attachment`` of ``target`` (``viewport`` (x, y, w, h): a part, default all) into
        ``dest`` ((h, w, c) of the attachment's dtype, C-contiguous; row 0 the bottom row) and
        return it; ``dest`` None: an array kept with the target (overwritten by the next read)."""
        dt, comps = target.formats[attachment]
        if dest is None:
            w, h = target.size if viewport is None else viewport[2:]
            got = target.arrays.get((attachment, w, h))
            if got is None:
                got = target.arrays[(attachment, w, h)] = np.empty((h, w, comps), _NUMPY[dt])
            dest = got
        target.fbo.read_into(dest, viewport=viewport, components=dest.shape[-1], attachment=attachment,
                             dtype=dt, alignment=1)
        return dest

    def finish(self) -> None:
        """Wait for the GPU (a draw's time measured to its end)."""
        self.ctx.finish()

    def draw(self, d: Draw):
        """Draw ``d`` (:class:`cellgl.gl.dispatch.Draw`); returns the program it drew with."""
        if d.blend not in (None, "add"):
            raise ValueError(f"unknown blend {d.blend!r}; accepted: 'add' or None")
        prog, vao = self._program(d.vertex, d.fragment, d.defines)
        set_uniforms(prog, d.uniforms)
        for unit, smp in (d.textures or {}).items():
            smp.texture.filter = FILTERS[smp.linear]
            smp.texture.repeat_x = smp.texture.repeat_y = smp.repeat
            smp.texture.use(unit)
        count = 3
        if d.vertices is not None:
            vao, count = self._vertices(prog, d.vertices)
        t = d.target
        t.fbo.use()
        t.fbo.viewport = d.viewport if d.viewport is not None else (0, 0, *t.size)
        if d.clear is not None:
            t.fbo.clear(*d.clear, depth=1.0)           # the whole target
        ctx = self.ctx
        flags = (ctx.DEPTH_TEST if d.depth_test else 0) | (ctx.BLEND if d.blend else 0)
        try:
            ctx.enable_only(flags)
            if d.blend == "add":
                ctx.blend_func = ctx.ONE, ctx.ONE
                ctx.blend_equation = ctx.FUNC_ADD
            if count:
                vao.render(mode=ctx.TRIANGLES, vertices=count)
        finally:
            ctx.enable_only(ctx.NOTHING)
        return prog

    def _vertices(self, prog, v: Vertices):
        """The vertex array of ``v`` for ``prog``: buffers kept under ``v.key`` (grown when too
        small), the array remade when the program or layout changes. Returns (array, count)."""
        data = np.ascontiguousarray(v.array, dtype="<f4")
        idx = None if v.indices is None else np.ascontiguousarray(v.indices, dtype="<u4")
        key = ("vertices", v.key)
        got = self.held.objects.get(key)
        kept = got[1] if got is not None else None
        if (kept is None or kept.prog is not prog or kept.layout != (v.layout, tuple(v.names))
                or kept.vbo.size < max(4, data.nbytes) or (idx is not None) != (kept.ibo is not None)
                or (idx is not None and kept.ibo.size < max(4, idx.nbytes))):
            release_object(kept)
            vbo = self.ctx.buffer(reserve=max(64, data.nbytes + data.nbytes // 4))
            ibo = None if idx is None else self.ctx.buffer(reserve=max(64, idx.nbytes + idx.nbytes // 4))
            vao = self.ctx.vertex_array(prog, [(vbo, v.layout, *v.names)], index_buffer=ibo,
                                        index_element_size=4)
            kept = _Vertices(prog, (v.layout, tuple(v.names)), vbo, ibo, vao)
            self.held.objects[key] = (None, kept)
        if data.nbytes:
            kept.vbo.write(data)
        if idx is not None and idx.nbytes:
            kept.ibo.write(idx)
        return kept.vao, int(idx.size if idx is not None else len(data))

    def _bind_words(self, data, raw, content, binding, comps):  # pragma: no cover
        raise NotImplementedError
