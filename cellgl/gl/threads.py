"""The decorator that makes a cellgl function one "cellgl call" for threads (see
:mod:`cellgl.gl.context`): imported without importing moderngl, which loads on the first call."""

from __future__ import annotations

import functools

__all__ = ["gl_call"]


def gl_call(fn):
    """Run ``fn`` as one cellgl call: the process's GL lock held, and the contexts it makes
    current on this thread released from it afterwards (unless current here before), so other
    threads can use them. No context is made unless ``fn`` asks for one."""
    @functools.wraps(fn)
    def call(*args, **kwargs):
        from cellgl.gl.context import section

        with section():
            return fn(*args, **kwargs)

    return call
