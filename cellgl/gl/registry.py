"""Everything cellgl knows about a GL context, in one object per context: :class:`ContextState`.

What a context's state holds: the backend it came from, the thread cellgl made it current on,
whether it is a thread's private context (:mod:`cellgl.gl.context`), the version ladder's record
(:mod:`cellgl.gl.versions`), the GPU path's override and known-answer results
(:mod:`cellgl.gl.path`), its programs (the ONE program cache: compute entries, fragment entries
with their vertex arrays, vertex + fragment programs; :func:`cached`, with least-recently-used
groups for programs made per recipe), its GPU objects (storage words, sample inputs, storage
buffers, render targets and draws' vertex buffers: :mod:`cellgl.gl.draws`), the stores modules
keep their own objects in (:func:`store`: the fragment path's target sets) and its runners
(:mod:`cellgl.gl.runner`).

How a context reaches its state: a :class:`weakref.WeakKeyDictionary` keyed by the
``moderngl.Context`` itself (:func:`held`; :func:`peek` without making one). Not moderngl's
public slot ``Context.extra``: moderngl documents it as the user's data, and cellgl hands its
contexts to users (:func:`cellgl.gl.context.get_context`) and works on theirs (``ctx=``, the
viewer's window), so cellgl taking the slot would overwrite theirs or be overwritten. Keyed by
the object, not by its ``id()``: an id is reused by the next object once a context is gone, and a
new context would inherit a dead one's programs. The mapping itself never keeps a context
alive; the GL objects in a state do (each moderngl object refers to its context), so a state
goes when its context is released (found so on the next call: :func:`held` sweeps), when cellgl
drops it (:func:`drop`), or in a forked child (kept alive there, never released: the parent's
driver threads do not exist in the child, and releasing would hang).
"""
from __future__ import annotations

import os
import threading
import weakref
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from cellgl.gl import moderngl_seam

__all__ = ["ContextState", "PathState", "held", "peek", "states", "cached", "drop", "store",
           "program_key", "release_object"]


@dataclass(eq=False)
class PathState:
    """The GPU path's record on one context (:mod:`cellgl.gl.path`)."""
    #: the path :func:`cellgl.gl.path.set_path` chose, and why (one line for `cellgl info`)
    override: str | None = None
    why: str | None = None
    #: path -> None (its known-answer check passed) or what differed
    results: dict[str, str | None] = field(default_factory=dict)
    #: path -> what the check found, for `cellgl info`
    notes: dict[str, str] = field(default_factory=dict)
    #: the thread running the checks (their own GPU work runs the path under check)
    running: int | None = None


@dataclass(eq=False)
class ContextState:
    """Everything cellgl knows about one context; see the module's doc."""
    ref: weakref.ReferenceType
    #: the backend the context came from (cellgl.gl.context.get_context); None: not cellgl's
    backend: str | None = None
    #: whether it is a thread's private context (made while the shared one was held elsewhere)
    private: bool = False
    #: ident of the thread cellgl made it current on (None: current on no thread as far as
    #: cellgl made it so)
    thread: int | None = None
    #: the rungs of the version ladder tried: (version code, error or None); None: not climbed
    ladder: list[tuple[int, str | None]] | None = None
    path: PathState = field(default_factory=PathState)
    programs: dict = field(default_factory=dict)       # key -> (program, vertex array or None)
    groups: dict = field(default_factory=dict)         # lru name -> OrderedDict of keys
    objects: dict = field(default_factory=dict)        # key -> (content key, GL object)
    stores: dict = field(default_factory=dict)         # name -> dict a module keeps (targets)
    runners: dict = field(default_factory=dict)        # path -> Runner

    @property
    def ctx(self) -> Any:
        """The context (None once it has been garbage collected)."""
        return self.ref()

    def release(self) -> None:
        """Release every GL object held (the context must be current and alive)."""
        _release_programs(list(self.programs.values()))
        for _, obj in self.objects.values():
            release_object(obj)
        for s in self.stores.values():
            _release_all(s)
        self.programs.clear()
        self.groups.clear()
        self.objects.clear()
        self.stores.clear()
        self.runners.clear()


def release_object(obj) -> None:
    if obj is None:
        return
    try:
        obj.release()
    except Exception:  # noqa: BLE001 - already gone with its context
        pass


def _release_programs(programs) -> None:
    for prog, vao in programs:
        release_object(vao)
        release_object(prog)


def _release_all(value) -> None:
    if isinstance(value, dict):
        for v in value.values():
            _release_all(v)
    elif isinstance(value, (list, tuple)):
        for v in value:
            _release_all(v)
    elif callable(getattr(value, "release", None)):
        release_object(value)


_lock = threading.RLock()
_states: weakref.WeakKeyDictionary[Any, ContextState] = weakref.WeakKeyDictionary()
_pid = os.getpid()
#: a forked child's inherited states: kept alive, never released (the parent's driver threads
#: do not exist here; releasing would hang)
_orphans: list = []


def _after_fork_in_child() -> None:
    """In a forked child (also one a C library forked, past ``register_at_fork``): set the
    parent's states aside; elsewhere nothing."""
    global _lock, _states, _pid
    if _pid == os.getpid():
        return
    _orphans.append(list(_states.items()))
    _states, _lock, _pid = weakref.WeakKeyDictionary(), threading.RLock(), os.getpid()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_after_fork_in_child)


def _sweep() -> None:
    """Forget the states of contexts released since (their objects went with them)."""
    for ctx in [c for c in list(_states.keys()) if moderngl_seam.released(c)]:
        _states.pop(ctx, None)


def held(ctx) -> ContextState:
    """The state of ``ctx``, made on first use. States of contexts released since are dropped
    on the way (their objects went with them)."""
    _after_fork_in_child()
    with _lock:
        st = _states.get(ctx)
        # (one state, ``ctx``'s own: nothing else to look at; one of another context: it may be
        # released, and the first call for ``ctx`` must sweep it too)
        if len(_states) > 1 or (_states and st is None):
            _sweep()
        if st is None:
            st = _states[ctx] = ContextState(weakref.ref(ctx))
        return st


def peek(ctx) -> ContextState | None:
    """The state of ``ctx`` if cellgl has one, without making one."""
    _after_fork_in_child()
    with _lock:
        return _states.get(ctx)


def states() -> list[tuple[Any, ContextState]]:
    """Every (context, state) cellgl knows of in this process, a snapshot."""
    _after_fork_in_child()
    with _lock:
        return list(_states.items())


def drop(ctx) -> None:
    """Forget ``ctx``: release what cellgl holds on it and its state. The objects are released
    with ``ctx`` made current on this thread (a program or buffer name means nothing, or another
    object, in another context), so it must not be current on another thread; it stays current
    here after."""
    with _lock:
        st = _states.pop(ctx, None)
    if st is not None and not moderngl_seam.released(ctx):
        moderngl_seam.make_current(ctx)
        st.release()


def store(name: str, ctx) -> dict:
    """A dict kept on ``ctx`` for a module's own GL objects (e.g. its render targets): dropped
    and released with the context's state."""
    return held(ctx).stores.setdefault(name, {})


def cached(ctx, key, make: Callable[[], tuple], lru: tuple[str, int] | None = None) -> tuple:
    """``(program, vertex array or None)`` under ``key`` in ``ctx``'s one program cache, made by
    ``make()`` once; ``lru`` (name, size): kept among the group's last ``size`` (older ones
    released with their vertex arrays)."""
    h = held(ctx)
    with _lock:
        got = h.programs.get(key)
        if got is None:
            got = h.programs[key] = make()
        if lru is not None:
            name, size = lru
            group = h.groups.setdefault(name, OrderedDict())
            group[key] = True
            group.move_to_end(key)
            while len(group) > size:
                old = h.programs.pop(group.popitem(last=False)[0], None)
                if old is not None:
                    release_object(old[1])
                    release_object(old[0])
        return got


def program_key(kind: str, *names, defines=None, files=None) -> tuple:
    """The cache key of a program: its kind, entry files, ``#define``s and generated files."""
    return (kind,) + names + (tuple(sorted((str(k), repr(v)) for k, v in (defines or {}).items())),
                              tuple(sorted((files or {}).items())))
