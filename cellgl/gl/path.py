"""Which GPU path runs cellgl's shaders on a context: compute, or fragment.

The compute path needs OpenGL 4.3 (compute shaders, storage buffers). Everywhere else from
OpenGL 3.3 core up (Apple's 4.1 core included) the fragment path runs the same ``shaders/lib``
code in fragment programs over tiled quads, with inputs in textures and outputs in render
targets, and gives the same bits.

``CELLGL_PATH=compute|fragment`` forces one (for tests and comparisons); unset or empty, the
context decides.

A driver nobody has tried may still give wrong answers on one path. So the first time a path is
used on a context, the checks registered with :func:`on_first_use` run on it (the basis layer
registers a known-answer check, :mod:`cellgl.basis.selfcheck`: a few hundred samples against
the NumPy reference). When the path fails and the context has the other one, the context
switches to it (:func:`set_path`) with one :class:`GPUPathWarning` naming the driver and what
differed; when both fail (or the failing path was forced with ``CELLGL_PATH``),
:class:`PathError`. ``CELLGL_SELFCHECK=0`` turns the checks off.
"""

from __future__ import annotations

import contextlib
import functools
import os
import re
import threading
import time
import warnings

from cellgl.gl import registry

#: Accepted values of ``CELLGL_PATH``.
PATHS = ("compute", "fragment")


class GPUPathWarning(RuntimeWarning):
    """A path failed its known-answer check on this driver; the context runs the other one."""


class PathError(RuntimeError):
    """No path of this context passes its known-answer check (or the forced one fails)."""

#: moderngl's version code of the first OpenGL with compute shaders.
COMPUTE_GL = 430

#: On the fragment path, what the compute entries read from a storage buffer (density-image
#: levels, cell-colour images, PUPs control points) is an R32UI texture 2^STORAGE_ROW_BITS words
#: wide on the texture unit numbered like the buffer's binding (``shaders/storage.glsl``). A
#: 4096 x 4096 image makes a 4096 x 4096 texture, within every OpenGL 4.1 implementation's 16384.
STORAGE_ROW_BITS = 12


@functools.lru_cache(maxsize=1)
def storage_bindings_needed() -> int:
    """1 + the highest shader-storage ``binding`` of the compute entries (``shaders/**/*.comp``
    and ``*.glsl``): the bindings, and blocks in one compute shader, a context must offer.
    OpenGL 4.3 guarantees only 8 of each (``GL_MAX_SHADER_STORAGE_BUFFER_BINDINGS``,
    ``GL_MAX_COMPUTE_SHADER_STORAGE_BLOCKS``); desktop drivers give 16-96."""
    from cellgl.gl.glsl import shader_dir

    top = -1
    for f in sorted(shader_dir().rglob("*")):
        if f.suffix in (".comp", ".glsl"):
            for m in _STORAGE_BINDING.finditer(f.read_text(encoding="utf-8")):
                top = max(top, int(m.group(1)))
    return top + 1


_STORAGE_BINDING = re.compile(r"layout\s*\(\s*std430\s*,\s*binding\s*=\s*(\d+)\s*\)")


def compute_missing(ctx) -> str | None:
    """Why ``ctx`` (a moderngl context) cannot run cellgl's compute entries, or None when it can:
    OpenGL 4.3, and the shader-storage bindings and compute blocks they use
    (:func:`storage_bindings_needed`; a context whose limits cannot be read counts as enough)."""
    if ctx.version_code < COMPUTE_GL:
        return f"this OpenGL {_version(ctx)} context has no compute shaders (OpenGL 4.3)"
    try:
        info = ctx.info
        limits = {k: int(info[k]) for k in ("GL_MAX_SHADER_STORAGE_BUFFER_BINDINGS",
                                             "GL_MAX_COMPUTE_SHADER_STORAGE_BLOCKS")}
    except Exception:  # noqa: BLE001 - a stand-in context without limits
        return None
    need = storage_bindings_needed()
    short = [f"{k} {v}" for k, v in limits.items() if v < need]
    if short:
        return (f"this OpenGL {_version(ctx)} context offers {', '.join(short)}; cellgl's compute "
                f"entries use {need} (the fragment path needs none)")
    return None


def has_compute(ctx) -> bool:
    """True when ``ctx`` (a moderngl context) runs cellgl's compute entries
    (:func:`compute_missing`)."""
    return compute_missing(ctx) is None


def forced_path() -> str | None:
    """The path named by ``CELLGL_PATH``, or None when it is unset or empty.

    Raises
    ------
    ValueError
        ``CELLGL_PATH`` names no path.
    """
    value = os.environ.get("CELLGL_PATH", "").strip().lower()
    if not value:
        return None
    if value not in PATHS:
        raise ValueError(
            f"CELLGL_PATH={os.environ['CELLGL_PATH']!r} is not a GPU path; accepted values: "
            f"{', '.join(PATHS)} (or unset it: compute where the context has OpenGL 4.3)"
        )
    return value


def selfcheck_enabled() -> bool:
    """False when ``CELLGL_SELFCHECK=0``.

    Raises
    ------
    ValueError
        ``CELLGL_SELFCHECK`` is neither 0 nor 1 (nor unset or empty).
    """
    value = os.environ.get("CELLGL_SELFCHECK", "").strip()
    if value not in ("", "0", "1"):
        raise ValueError(f"CELLGL_SELFCHECK={os.environ['CELLGL_SELFCHECK']!r}; accepted values: "
                         "0 (skip the known-answer check of the GPU path) or 1 (the default)")
    return value != "0"


# --------------------------------------------------------------------------------------------
# Per-context state: the override, the first-use checks
# --------------------------------------------------------------------------------------------

#: fn(ctx, path) -> None when ``path`` gives right answers on ``ctx``, else what differed
_hooks: list = []
#: the GL lock's section (cellgl.gl.context sets it): the checks run inside it
_guard = contextlib.nullcontext
#: driver strings already warned about (one warning per driver and process)
_warned: set = set()


def on_first_use(fn) -> None:
    """Register a check ``fn(ctx, path)`` run the first time ``path`` is used on a context,
    inside :func:`gpu_path` (once per context and path; ``fn`` may itself do GPU work: inside
    it, :func:`gpu_path` returns the path under check). It returns None when the path is right
    on that context, else a short text of what differed. Registering the same function twice
    keeps one."""
    if fn not in _hooks:
        _hooks.append(fn)


def set_guard(section) -> None:
    """The context manager that holds the GL lock (cellgl.gl.context's): the checks run in it."""
    global _guard
    _guard = section


def _state(ctx) -> registry.PathState:
    """The path's record in the context's state (:class:`cellgl.gl.registry.ContextState`)."""
    return registry.held(ctx).path


def set_path(ctx, path: str, why: str) -> None:
    """Make ``ctx`` run ``path`` from now on (``why``: one line for `cellgl info`), unless
    ``CELLGL_PATH`` forces one.

    Raises
    ------
    ValueError
        ``path`` is not a path, or ``compute`` on a context without compute shaders.
    """
    if path not in PATHS:
        raise ValueError(f"unknown GPU path {path!r}; accepted values: {', '.join(PATHS)}")
    missing = compute_missing(ctx) if path == "compute" else None
    if missing:
        raise ValueError(missing)
    st = _state(ctx)
    st.override, st.why = path, why


def forget(ctx) -> None:
    """Drop the override and the check results of ``ctx`` (tests; a driver update in place)."""
    st = registry.peek(ctx)
    if st is not None:
        st.path = registry.PathState()


def note(ctx, path: str, text: str) -> None:
    """Keep ``text`` (what a check found) for :func:`check_summary`."""
    _state(ctx).notes[path] = text


def _version(ctx) -> str:
    return f"{ctx.version_code // 100}.{ctx.version_code % 100 // 10}"


def _natural(ctx) -> str:
    return "compute" if has_compute(ctx) else "fragment"


def driver(ctx) -> str:
    """``GL_VENDOR / GL_RENDERER / GL_VERSION`` of ``ctx`` (for messages)."""
    try:
        info = ctx.info
        return " / ".join(str(info.get(k)) for k in ("GL_VENDOR", "GL_RENDERER", "GL_VERSION"))
    except Exception:  # noqa: BLE001 - a context without info (a stand-in)
        return f"OpenGL {_version(ctx)}"


def gpu_path(ctx) -> str:
    """``"compute"`` or ``"fragment"``: the path cellgl runs on ``ctx``.

    ``CELLGL_PATH`` when set, else the path :func:`set_path` chose, else compute from OpenGL
    4.3. The first use of a path on a context runs the :func:`on_first_use` checks on it.

    Raises
    ------
    ValueError
        ``CELLGL_PATH`` names no path, or forces ``compute`` on a context without compute
        shaders; ``CELLGL_SELFCHECK`` is neither 0 nor 1.
    PathError
        The path failed its check and the other one failed too (or cannot run here, or the
        failing path is forced by ``CELLGL_PATH``): every call on this context raises it.
    """
    forced = forced_path()
    missing = compute_missing(ctx) if forced == "compute" else None
    if missing:
        raise ValueError(f"CELLGL_PATH=compute, but {missing}; unset CELLGL_PATH or set "
                         "CELLGL_PATH=fragment")
    st = _state(ctx)
    chosen = forced or st.override or _natural(ctx)
    if chosen in st.results and st.results[chosen] is None:
        return chosen
    if st.running == threading.get_ident():   # a check's own GPU work
        return chosen
    if not _hooks or not selfcheck_enabled():
        return chosen
    with _guard():
        if chosen not in st.results:
            st.running = threading.get_ident()
            try:
                chosen = _first_use(ctx, st, chosen, forced)
            finally:
                st.running = None
    return _verdict(ctx, st, forced or st.override or _natural(ctx), forced)


def _check(ctx, st: registry.PathState, path: str) -> str | None:
    """Run the checks on ``path`` (as the context's path meanwhile); keep the result."""
    saved = st.override
    st.override = path
    try:
        what = None
        for fn in list(_hooks):
            try:
                what = fn(ctx, path)
            except Exception as exc:  # noqa: BLE001 - a path that raises is a failing path
                what = f"raised {type(exc).__name__}: {str(exc).strip().splitlines()[0] if str(exc).strip() else ''}"
            if what:
                break
    finally:
        st.override = saved
    st.results[path] = what or None
    return what or None


def _first_use(ctx, st: registry.PathState, chosen: str, forced: str | None) -> str:
    started = time.perf_counter()
    what = _check(ctx, st, chosen)
    if what is None or forced:
        return chosen
    other = "fragment" if chosen == "compute" else "compute"
    if other == "compute" and not has_compute(ctx):
        return chosen
    if other not in st.results:
        _check(ctx, st, other)
    if st.results[other] is None:
        set_path(ctx, other, f"the {chosen} path failed its known-answer check: {what}")
        name = driver(ctx)
        if name not in _warned:
            _warned.add(name)
            warnings.warn(
                f"cellgl: the {chosen} path gave wrong answers on this driver ({name}) in its "
                f"known-answer check: {what}. This context runs the {other} path instead "
                f"(right, maybe slower; checked in {time.perf_counter() - started:.2f} s). Please "
                "report it with the output of `cellgl info`; CELLGL_SELFCHECK=0 skips the check.",
                GPUPathWarning, stacklevel=4)
        return other
    return chosen


def _verdict(ctx, st: registry.PathState, chosen: str, forced: str | None) -> str:
    what = st.results.get(chosen)
    if what is None:
        return chosen
    name = driver(ctx)
    if forced:
        raise PathError(
            f"CELLGL_PATH={forced}: the {forced} path gives wrong answers on this driver ({name}) "
            f"in cellgl's known-answer check: {what}. Unset CELLGL_PATH (cellgl then runs a path "
            "that passes), or set CELLGL_SELFCHECK=0 to skip the check")
    other = "fragment" if chosen == "compute" else "compute"
    tail = (f"the {other} path failed too: {st.results[other]}" if st.results.get(other)
            else f"this OpenGL {_version(ctx)} context has no other path")
    raise PathError(
        f"cellgl's known-answer check failed on this driver ({name}): the {chosen} path: {what}; "
        f"{tail}. cellgl will not return wrong answers: update the GPU driver, try another "
        "(CELLGL_BACKEND, CELLGL_DEVICE), or set CELLGL_SELFCHECK=0 to skip the check at your "
        "own risk")


def check_summary(ctx) -> str:
    """What the known-answer checks found on ``ctx``, one line (for `cellgl info`)."""
    try:
        enabled = selfcheck_enabled()
    except ValueError as exc:
        return str(exc)
    if not enabled:
        return "off (CELLGL_SELFCHECK=0)"
    if not _hooks:
        return "not registered (import cellgl.basis to register the known-answer check)"
    held = registry.peek(ctx)
    st = held.path if held is not None else None
    if st is None or not st.results:
        return "not run yet (it runs on the first GPU call)"
    parts = []
    for path, what in st.results.items():
        text = st.notes.get(path, "passed") if what is None else f"FAILED ({what})"
        parts.append(f"{path}: {text}")
    if st.override:
        parts.append(f"running {st.override}: {st.why}")
    return "; ".join(parts)
