"""How each backend makes a context (the context-creation half of :mod:`cellgl.gl.context`):
every one climbs :data:`cellgl.gl.versions.LADDER`, on a display whose driver threads exist in
this process (see :mod:`cellgl.gl.surfaceless`)."""

from __future__ import annotations

import os

import moderngl

from cellgl.gl import osmesa, platforms, versions

__all__ = ["ContextError", "create", "context_from_loader", "from_loader", "FORKED"]


class ContextError(RuntimeError):
    """No usable OpenGL context (3.3 core or later) could be created."""


def context_from_loader(loader, require: int, mode: str = "standalone") -> moderngl.Context:
    """Wrap a loader object (None: glcontext's default backend) in a moderngl.Context
    (:func:`cellgl.gl.versions.wrap_loader`; too old a context is a ContextError)."""
    try:
        return versions.wrap_loader(loader, require, mode)
    except ValueError as exc:
        raise ContextError(str(exc)) from None


def create(backend: str, tainted: set, opened: set) -> moderngl.Context:
    """A new context of ``backend``, current on this thread, on a display whose driver threads
    exist in this process (see :mod:`cellgl.gl.surfaceless`): the first rung of
    :data:`cellgl.gl.versions.LADDER` the driver gives. ``tainted``: the displays a parent
    process used before fork (cellgl.gl.context); ``opened`` gets the one used."""
    why = platforms.check_backend(backend)
    if why:
        raise ContextError(why)
    if backend == "egl":
        if "egl" not in tainted:
            device = platforms.device_setting()
            settings = {} if device is None else {"device_index": device}
            opened.add("egl")
            return versions.climb(lambda code: versions.glcontext_context("egl", code, **settings))
        if "egl-surfaceless" not in tainted:
            from cellgl.gl.surfaceless import SurfacelessEGLLoader

            opened.add("egl-surfaceless")
            return from_loader(SurfacelessEGLLoader())
        raise ContextError(FORKED)
    if backend in tainted:
        raise ContextError(FORKED)
    if backend == "glx":
        if not os.environ.get("DISPLAY"):
            raise ContextError("DISPLAY is not set")
        opened.add("glx")
        # glcontext's default backend on Linux is X11/GLX.
        return platforms.create_native("glx")
    if backend == "osmesa":
        library = osmesa.probe()
        opened.add("osmesa")
        return from_loader(osmesa.OSMesaLoader(library=library))
    if backend in ("wgl", "cgl"):
        opened.add(backend)
        return platforms.create_native(backend)
    raise ValueError(f"unknown OpenGL backend {backend!r}")


FORKED = ("this process was forked from one that had already used every display this backend "
          "can open (Mesa's driver threads do not survive fork, so those displays would hang); "
          "start it with multiprocessing's 'spawn' or 'forkserver' method instead")


def from_loader(loader) -> moderngl.Context:
    """A context over one of cellgl's loaders (OSMesa, surfaceless EGL), which climbed the
    ladder itself (``loader.ladder``)."""
    ctx = context_from_loader(loader, versions.MINIMUM)
    ctx._cellgl_ladder = getattr(loader, "ladder", None)
    return ctx


