"""The one OpenGL version ladder: the core versions cellgl asks of every context API, in order.

Drivers answer a request for "OpenGL X.Y core" differently. Mesa gives its highest core version
whatever is asked (llvmpipe: 4.5); NVIDIA's EGL and GLX give exactly the version asked (3.3 asked,
3.3 given: no compute shaders). So cellgl asks for the newest first and walks down,
:data:`LADDER`: 4.6, 4.5, 4.3 (compute shaders: the compute path), 4.1 (macOS), 3.3 core (the
least the fragment path runs on). The first rung a driver accepts wins; what each refused rung
said is kept for the one error message when none works, and with a context made in its state
(:class:`cellgl.gl.registry.ContextState`, ``ladder``: `cellgl info`'s ``gl_ladder``).

Every way cellgl makes a context climbs this ladder: EGL, GLX, WGL and CGL through glcontext
(:func:`glcontext_context`; glcontext's CGL backend ignores the version and gives 4.1 core),
OSMesa and the surfaceless EGL display of a forked child through cellgl's own loaders, and the
viewer's GLFW window (``viewer/app.py``).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Any, TypeVar

from cellgl.gl import moderngl_seam, registry

__all__ = ["LADDER", "MINIMUM", "LadderError", "label", "major_minor", "first_line", "climb",
           "glcontext_context", "describe", "check_settings"]

T = TypeVar("T")

#: moderngl version codes asked for, newest first (core profile).
LADDER = (460, 450, 430, 410, 330)
#: the least cellgl runs on (the fragment path); 4.3 adds the compute path (cellgl.gl.path).
MINIMUM = 330


def label(code: int) -> str:
    """``460`` -> ``"4.6"``."""
    return f"{code // 100}.{code % 100 // 10}"


def major_minor(code: int) -> tuple[int, int]:
    """``460`` -> ``(4, 6)``."""
    return code // 100, code % 100 // 10


def first_line(exc: BaseException) -> str:
    """The first line of what ``exc`` says (its type's name when it says nothing): one line of
    an error message per failed rung or backend."""
    text = str(exc).strip() or type(exc).__name__
    return text.splitlines()[0]


class LadderError(RuntimeError):
    """No rung of the ladder gave a context. ``attempts``: (version code, why it failed)."""

    def __init__(self, what: str, attempts: list[tuple[int, str]]):
        self.attempts = attempts
        tried = "; ".join(f"{label(code)} core: {why}" for code, why in attempts)
        super().__init__(f"{what}: {tried}" if what else tried)


def climb(make: Callable[[int], T], what: str = "",
          ladder: tuple[int, ...] = LADDER) -> tuple[T, list[tuple[int, str | None]]]:
    """Ask ``make(code)`` for each version code of ``ladder`` in turn; the first context it
    returns wins. ``make`` raises when the driver refuses that version (any exception: each API
    fails in its own way).

    Returns
    -------
    (context, attempts)
        What ``make`` returned, and the rungs tried: (version code, error or None) in order.
        Kept in the context's state (:class:`cellgl.gl.registry.ContextState`, ``ladder``) for
        :func:`describe`.

    Raises
    ------
    LadderError
        Every rung failed; its message lists each version with the driver's answer.
    """
    attempts: list[tuple[int, str | None]] = []
    for code in ladder:
        try:
            ctx = make(code)
        except Exception as exc:  # noqa: BLE001 - glcontext raises bare Exception
            attempts.append((code, first_line(exc)))
            continue
        attempts.append((code, None))
        return ctx, attempts
    raise LadderError(what, [(code, why or "") for code, why in attempts])


def describe(ctx) -> str:
    """What the ladder did for ``ctx``: ``"4.6 refused (eglCreateContext failed (0x3009)), 4.5
    asked, got 4.5"``; ``"not climbed"`` for a context cellgl did not make (a window's)."""
    st = registry.peek(ctx)
    attempts = st.ladder if st is not None else None
    if not attempts:
        return "not climbed (a context cellgl attached to, not one it made)"
    parts = [f"{label(code)} refused ({why})" for code, why in attempts if why is not None]
    asked = attempts[-1][0]
    got = getattr(ctx, "version_code", None)
    parts.append(f"{label(asked)} asked, got {label(got) if got else 'unknown'}")
    return ", ".join(parts)


def check_settings() -> None:
    """Refuse glcontext's ``GLCONTEXT_GLVERSION``: it replaces the version asked at every rung
    (on EGL, GLX and WGL, not on cellgl's own OSMesa loader), so the ladder would not be what
    it reports, and a version the driver lacks would fall through to another backend unsaid.

    Raises
    ------
    ValueError
        ``GLCONTEXT_GLVERSION`` is set (one line naming it and what to do).
    """
    raw = os.environ.get("GLCONTEXT_GLVERSION", "")
    if raw:
        raise ValueError(
            f"GLCONTEXT_GLVERSION={raw!r} is set: glcontext would ask that version at every rung "
            f"of cellgl's version ladder ({', '.join(label(c) for c in LADDER)} core, newest "
            "first: the driver's newest is taken) on some backends but not others; unset it")


def glcontext_context(api: str, code: int, **settings: Any) -> Any:
    """A standalone moderngl context from glcontext's backend for ``api`` asking for version
    ``code`` core: ``"egl"`` (its EGL backend; ``device_index`` picks the EGL device), or
    ``"native"`` (its default backend: GLX on Linux, WGL on Windows, CGL on macOS), made by
    ``moderngl.create_context(context=loader)`` (:func:`cellgl.gl.moderngl_seam.create`).
    Whatever version the driver gives from 3.3 up is accepted (a driver may give more than
    asked; CGL gives 4.1); below it the loader is released and ValueError raised.

    Note: glcontext lets ``GLCONTEXT_GLVERSION`` replace the version asked (every rung then asks
    the same: :func:`check_settings` refuses it) and ``GLCONTEXT_DEVICE_INDEX`` the device (checked
    as ``CELLGL_DEVICE`` is: :func:`cellgl.gl.platforms.device_setting`).
    """
    import glcontext

    create = glcontext.get_backend_by_name("egl") if api == "egl" else glcontext.default_backend()
    return moderngl_seam.create(create(mode="standalone", glversion=code, **settings), MINIMUM)
