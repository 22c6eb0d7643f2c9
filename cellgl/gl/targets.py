"""Offscreen float render targets kept between calls (one per context and use), in the context's
state (:func:`cellgl.gl.registry.store`): released with it, never another context's objects."""
from __future__ import annotations

__all__ = ["float_target"]


def float_target(cache: dict, ctx, width: int, height: int) -> dict:
    """An RGBA32F texture and its framebuffer of ``width x height`` on ``ctx``, kept in ``cache``
    (a store of ``ctx``'s own: ``cellgl.gl.registry.store(name, ctx)``) while the size stays.

    Returns the cache: ``cache["objects"]`` is ``(fbo, tex)``; callers may keep more in it (it is
    emptied when the size changes). The old objects are released only after the new framebuffer
    is bound: deleting the bound framebuffer would leave moderngl restoring a dead binding
    (GL_INVALID_OPERATION) on the next one.

    Raises
    ------
    ValueError
        ``cache`` holds another context's objects (it is not a store of ``ctx``).
    """
    held = cache.get("objects", ())
    if any(o.ctx is not ctx for o in held):
        raise ValueError("float_target: the cache given holds another context's render target; "
                         "pass cellgl.gl.registry.store(name, ctx) of this context")
    if cache.get("key") != (width, height):
        tex = ctx.texture((width, height), 4, dtype="f4")
        fbo = ctx.framebuffer(color_attachments=[tex])
        fbo.use()
        for o in held:
            o.release()
        cache.clear()
        cache.update(key=(width, height), objects=(fbo, tex))
    return cache
