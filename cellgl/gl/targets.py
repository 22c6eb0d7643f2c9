"""Offscreen float render targets kept between calls (one per context and use)."""
from __future__ import annotations

__all__ = ["float_target"]


def float_target(cache: dict, ctx, width: int, height: int) -> dict:
    """An RGBA32F texture and its framebuffer of ``width x height`` on ``ctx``, kept in ``cache``
    (keyed per context: never another context's objects) while the size stays.

    Returns the cache entry: ``entry["objects"]`` is ``(fbo, tex)``; callers may keep more in it
    (it is emptied when the size changes). The old objects are released only after the new
    framebuffer is bound: deleting the bound framebuffer would leave moderngl restoring a dead
    binding (GL_INVALID_OPERATION) on the next one.
    """
    entry = cache.setdefault(id(ctx), {})
    if entry.get("key") != (width, height):
        tex = ctx.texture((width, height), 4, dtype="f4")
        fbo = ctx.framebuffer(color_attachments=[tex])
        fbo.use()
        for o in entry.get("objects", ()):
            o.release()
        entry.clear()
        entry.update(key=(width, height), objects=(fbo, tex))
    return entry
