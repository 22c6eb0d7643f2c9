"""One policy for cellgl's in-process caches: bounded, least recently used dropped first.

A cache of derived values (an octave mean, a folded function, a compiled snippet unit, a PUPs
scene) is a :class:`Bounded`: a mapping of at most ``size`` entries that drops the entry read or
written longest ago when a new one would pass the bound. Every cache says what it holds
(``about``) and its bound, and :func:`clear` empties them all (tests, a long-running host that
wants its memory back). :func:`caches` lists them. A cache keyed by a function's own (hashable)
arguments is ``functools.lru_cache(maxsize=N)`` instead: the same policy, bounded and least
recently used first (``cache_clear`` empties it).

The bounds, by what an entry costs and how many a process meets: 256 octave means
(:mod:`cellgl.texture.means`), 4096 folded function bodies (:mod:`cellgl.export.fold`), 64
compiled snippet units (:mod:`cellgl.export.snippets`), 20,000 token splits of GLSL texts
(:mod:`cellgl.export.translate.tokens`), 4 PUPs scenes and 4 scaled layers (:mod:`cellgl.pups.recipe`:
each holds a whole point set), 8 decoded density and cell images (:mod:`cellgl.texture.images`).
The GL objects kept per context are not process caches: they live and go with their context
(:mod:`cellgl.gl.registry`). Each used to have its own rule (the first in dropped, or all
dropped at once past the bound, one of them at first unbounded); now one.

Why not ``functools.lru_cache``: the caches here are looked up by a key computed from an object
(a recipe, a syntax tree) that is not itself the key or is not hashable, and some hold values
that are made from more than the key. The standard library's ``OrderedDict`` does the ordering.
"""
from __future__ import annotations

import threading
import weakref
from collections import OrderedDict
from collections.abc import Hashable

__all__ = ["Bounded", "caches", "clear", "CACHE_SIZE"]

#: the default bound (entries)
CACHE_SIZE = 256

_ALL: weakref.WeakSet = weakref.WeakSet()


class Bounded:
    """At most ``size`` entries, the least recently used dropped first; thread-safe."""

    def __init__(self, about: str, size: int = CACHE_SIZE):
        if not isinstance(size, int) or size < 1:
            raise ValueError(f"a cache's size must be an int >= 1, got {size!r}")
        self.about = about
        self.size = size
        self._data: OrderedDict = OrderedDict()
        self._lock = threading.Lock()
        _ALL.add(self)

    def get(self, key: Hashable, default=None):
        """The value kept for ``key`` (now the most recently used), or ``default``."""
        with self._lock:
            if key not in self._data:
                return default
            self._data.move_to_end(key)
            return self._data[key]

    def __contains__(self, key: Hashable) -> bool:
        with self._lock:
            return key in self._data

    def put(self, key: Hashable, value) -> None:
        """Keep ``value`` for ``key``, dropping the least recently used entries past the bound."""
        with self._lock:
            self._data[key] = value
            self._data.move_to_end(key)
            while len(self._data) > self.size:
                self._data.popitem(last=False)

    def clear(self) -> None:
        with self._lock:
            self._data.clear()

    def __len__(self) -> int:
        return len(self._data)

    def __repr__(self) -> str:
        return f"Bounded({self.about!r}, {len(self)}/{self.size})"


def caches() -> list[Bounded]:
    """Every cache made so far (those still alive)."""
    return sorted(_ALL, key=lambda c: c.about)


def clear() -> None:
    """Empty every cache."""
    for c in list(_ALL):
        c.clear()
