"""The only module that relies on moderngl beyond its public API, one function per need.

cellgl makes its contexts with ``moderngl.create_context`` (public: ``standalone``, ``require``
and ``context=`` a loader object, glcontext's or cellgl's own). Three things it needs have no
public way in moderngl 5.13; each is done here, in one function, and
``tests/test_context.py::test_moderngl_still_has_what_the_seam_uses`` fails (through
:func:`missing`) when moderngl no longer has what they use:

:func:`create`
    ``moderngl.create_context`` makes every context it creates moderngl's *default context*
    (what ``moderngl.get_context()`` returns, and what a later plain ``moderngl.create_context()``
    returns instead of detecting the caller's window). cellgl's contexts are its own: the default
    context there was before is put back (``moderngl._store.default_context``).
:func:`make_current` / :func:`release_current`
    cellgl makes a context current for a whole call and releases it at the call's end, possibly
    from another function (:func:`cellgl.gl.context.section`); moderngl offers that only as its
    context-manager protocol (``with ctx:``), whose two halves are called here apart
    (``Context.__enter__`` / ``__exit__``).
:func:`released`
    moderngl has no "is this context released": ``Context.release()`` replaces the context's
    ``mglo`` with a ``moderngl.InvalidObject``.
"""
from __future__ import annotations

from typing import Any

__all__ = ["create", "make_current", "release_current", "released", "missing"]


def create(loader: Any, require: int, *, standalone: bool = True) -> Any:
    """``moderngl.create_context(standalone=..., require=require, context=loader)``, leaving
    moderngl's default context as it was. ``standalone=False``: a context over the one current
    on this thread (a window's), its default framebuffer as ``ctx.screen``.

    Raises
    ------
    ValueError
        moderngl's: the context is older than ``require``. The loader of a standalone context
        is released first (a detected one belongs to its window).
    """
    import moderngl

    store = moderngl._store   # type: ignore[attr-defined]  # (not in moderngl's stubs: private)
    before = store.default_context
    try:
        return moderngl.create_context(standalone=standalone, require=require, context=loader)
    except Exception:
        if standalone:
            loader.release()
        raise
    finally:
        store.default_context = before


def make_current(ctx: Any) -> None:
    """Make ``ctx`` current on this thread (cheap when it already is)."""
    ctx.__enter__()


def release_current(ctx: Any) -> None:
    """Make ``ctx`` current on no thread (so that another thread can make it current)."""
    if not released(ctx):
        ctx.__exit__(None, None, None)


def released(ctx: Any) -> bool:
    """Whether ``ctx`` was released (or is no moderngl context at all: nothing to release)."""
    import moderngl

    mglo = getattr(ctx, "mglo", None)
    return mglo is None or isinstance(mglo, moderngl.InvalidObject)


def missing(ctx: Any) -> list[str]:
    """What of moderngl this module uses is missing, on the live context ``ctx`` (empty: all
    there)."""
    import moderngl

    gone = [name for name in ("_store", "InvalidObject", "create_context")
            if not hasattr(moderngl, name)]
    if hasattr(moderngl, "_store") and not hasattr(moderngl._store, "default_context"):
        gone.append("_store.default_context")
    gone += [f"Context.{name}" for name in ("__enter__", "__exit__", "mglo", "release")
             if not hasattr(ctx, name)]
    if not gone and released(ctx):
        gone.append("a live context's mglo (it reads as released)")
    return gone
