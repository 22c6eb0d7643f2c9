"""How each backend makes a context (the context-creation half of :mod:`cellgl.gl.context`):
every one climbs :data:`cellgl.gl.versions.LADDER`, on a display whose driver threads exist in
this process (see :mod:`cellgl.gl.surfaceless`), each rung one ``moderngl.create_context`` call
(:func:`cellgl.gl.moderngl_seam.create`); what the ladder did is kept in the context's state
(:class:`cellgl.gl.registry.ContextState`, ``ladder``), with the backend's name."""

from __future__ import annotations

import os
from typing import Any

import moderngl

from cellgl.gl import moderngl_seam, osmesa, platforms, registry, versions

__all__ = ["ContextError", "create", "context_from_loader", "from_loader", "FORKED"]


class ContextError(RuntimeError):
    """No usable OpenGL context (3.3 core or later) could be created."""


def context_from_loader(loader: Any, require: int, *, standalone: bool = True) -> moderngl.Context:
    """A moderngl.Context over a loader object (``load_opengl_function``, ``release``,
    ``__enter__``/``__exit__``: glcontext's or cellgl's own); ``standalone=False``: over the
    context current on this thread (a window's). Too old a context is a ContextError (the
    loader of a standalone one released)."""
    try:
        return moderngl_seam.create(loader, require, standalone=standalone)
    except ValueError as exc:
        raise ContextError(f"OpenGL {versions.label(require)} core required ({exc})") from None


def _climbed(made: tuple[moderngl.Context, list]) -> moderngl.Context:
    ctx, ladder = made
    registry.held(ctx).ladder = ladder
    return ctx


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
            return _climbed(versions.climb(
                lambda code: versions.glcontext_context("egl", code, **settings)))
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
        return _climbed(platforms.create_native("glx"))
    if backend == "osmesa":
        library = osmesa.probe()
        opened.add("osmesa")
        return from_loader(osmesa.OSMesaLoader(library=library))
    if backend in ("wgl", "cgl"):
        opened.add(backend)
        return _climbed(platforms.create_native(backend))
    raise ValueError(f"unknown OpenGL backend {backend!r}")


FORKED = ("this process was forked from one that had already used every display this backend "
          "can open (Mesa's driver threads do not survive fork, so those displays would hang); "
          "start it with multiprocessing's 'spawn' or 'forkserver' method instead")


def from_loader(loader: Any) -> moderngl.Context:
    """A context over one of cellgl's loaders (OSMesa, surfaceless EGL), which climbed the
    ladder itself (``loader.ladder``)."""
    return _climbed((context_from_loader(loader, versions.MINIMUM), loader.ladder))


