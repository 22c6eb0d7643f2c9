"""Everything cellgl keeps on a GL context, in one registry (the seam: :mod:`cellgl.gl.runner`).

Per context one entry (:func:`held`): its programs (the ONE program cache: compute entries,
fragment entries with their vertex arrays, vertex + fragment programs; :func:`cached`, with
least-recently-used groups for programs made per recipe), its GPU objects (storage words, sample
inputs, storage buffers), the stores modules keep their own objects in (:func:`store`: float render
targets) and its runners. An entry is dropped with its context (:func:`drop`, or found released on
the next call: its objects went with it) and, without touching the parent's driver objects, in a
forked child (they are kept alive there, never released: the driver's threads are gone).
"""
from __future__ import annotations

import os
import threading
from collections import OrderedDict
from dataclasses import dataclass, field

__all__ = ["held", "cached", "drop", "store", "program_key"]


@dataclass
class _Held:
    """Everything cellgl keeps on one context."""
    ctx: object
    programs: dict = field(default_factory=dict)       # key -> (program, vertex array or None)
    groups: dict = field(default_factory=dict)         # lru name -> OrderedDict of keys
    objects: dict = field(default_factory=dict)        # key -> (content key, GL object)
    stores: dict = field(default_factory=dict)         # name -> dict a module keeps (float targets)
    runners: dict = field(default_factory=dict)        # path -> Runner

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
    elif hasattr(value, "mglo") and hasattr(value, "release"):
        release_object(value)


_lock = threading.RLock()
_registry: dict[int, _Held] = {}
_pid = os.getpid()
#: a forked child's inherited entries: kept alive, never released (the parent's driver threads
#: do not exist here; releasing would hang)
_orphans: list = []


def _after_fork_in_child() -> None:
    global _lock, _pid
    if _pid == os.getpid():
        return
    _orphans.append(dict(_registry))
    _registry.clear()
    _lock, _pid = threading.RLock(), os.getpid()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_after_fork_in_child)


def _alive(ctx) -> bool:
    mglo = getattr(ctx, "mglo", None)
    return mglo is not None and type(mglo).__name__ != "InvalidObject"


def held(ctx) -> _Held:
    """The registry entry of ``ctx``, made on first use. Entries of contexts released since are
    dropped on the way (their objects went with them)."""
    if _pid != os.getpid():
        _after_fork_in_child()
    with _lock:
        # (one entry, ``ctx``'s own: nothing else to look at; one of another context: it may be
        # released, and the first call for ``ctx`` must sweep it too)
        if len(_registry) > 1 or (_registry and id(ctx) not in _registry):
            for k, other in list(_registry.items()):   # released since: their objects went with them
                if not _alive(other.ctx):
                    del _registry[k]
        h = _registry.get(id(ctx))
        if h is None or h.ctx is not ctx:
            h = _registry[id(ctx)] = _Held(ctx)
        return h


def drop(ctx) -> None:
    """Forget ``ctx``: release what cellgl holds on it and its entry. The objects are released
    with ``ctx`` made current on this thread (a program or buffer name means nothing, or another
    object, in another context), so it must not be current on another thread; it stays current
    here after."""
    with _lock:
        h = _registry.pop(id(ctx), None)
    if h is not None and h.ctx is ctx and _alive(ctx):
        ctx.mglo.__enter__()
        h.release()


def store(name: str, ctx) -> dict:
    """A dict kept on ``ctx`` for a module's own GL objects (e.g. its float targets): dropped and
    released with the context's entry."""
    return held(ctx).stores.setdefault(name, {})


def cached(ctx, key, make, lru: tuple | None = None):
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
