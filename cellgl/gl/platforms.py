"""Which OpenGL context each desktop platform offers, how to make one, and what to tell the user
when none can be made.

========  ===========================================  ==========================================
platform  backends, in the order tried                 what the platform's own backend gives
========  ===========================================  ==========================================
Linux     ``egl``, ``glx`` (``DISPLAY`` set),          Mesa or the GPU driver: the highest core
          ``osmesa`` (libOSMesa found)                 version it has (Mesa llvmpipe: 4.5)
Windows   ``wgl``, ``osmesa`` (OSMesa DLL found)       the driver's ``opengl32.dll`` (or Mesa's,
                                                       ``GLCONTEXT_WIN_LIBGL``): 4.3 core is asked
                                                       for first, then 3.3 core
macOS     ``cgl``, ``osmesa`` (libOSMesa found)        Apple's OpenGL: 4.1 core, no compute
========  ===========================================  ==========================================

The platform backends are glcontext's: on Windows and macOS it is glcontext's default backend,
so ``moderngl.create_context(standalone=True)`` with no ``backend=``. glcontext's WGL backend
asks ``wglCreateContextAttribsARB`` for a core profile of the requested version; its CGL backend
ignores the version and asks for ``kCGLOGLPVersion_GL4_Core`` (then ``GL3_Core``), which is
4.1 core on every Mac that has it (a legacy context would stop at 2.1).

Everything here is plain data and small functions; :mod:`cellgl.gl.context` owns the contexts.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import sys

__all__ = ["ALL_BACKENDS", "PLATFORM_BACKENDS", "platform", "platform_backends", "check_backend",
           "create_native", "install_hint", "get_proc", "CurrentEGLLoader"]

#: Backends of each platform, in the order tried (those with a condition are tried only when it
#: holds; see :func:`platform_backends`).
PLATFORM_BACKENDS = {
    "linux": ("egl", "glx", "osmesa"),
    "win32": ("wgl", "osmesa"),
    "darwin": ("cgl", "osmesa"),
}
#: Every backend name ``CELLGL_BACKEND`` accepts somewhere.
ALL_BACKENDS = ("egl", "glx", "osmesa", "wgl", "cgl")

_PLATFORM_NAMES = {"linux": "Linux", "win32": "Windows", "darwin": "macOS"}
_HOME = {"egl": "linux", "glx": "linux", "wgl": "win32", "cgl": "darwin"}

#: GL versions asked of WGL, in order: compute shaders first, else what the fragment path needs.
WGL_VERSIONS = (430, 330)


def platform() -> str:
    """``"linux"``, ``"win32"`` or ``"darwin"`` (other Unix systems count as Linux: EGL, GLX)."""
    if sys.platform.startswith("win"):
        return "win32"
    if sys.platform == "darwin":
        return "darwin"
    return "linux"


def platform_name(key: str | None = None) -> str:
    return _PLATFORM_NAMES[key or platform()]


def platform_backends() -> tuple[str, ...]:
    """The backends this platform has (:data:`PLATFORM_BACKENDS`), in the order tried."""
    return PLATFORM_BACKENDS[platform()]


def check_backend(name: str) -> str | None:
    """None when backend ``name`` exists on this platform, else why not (one line)."""
    if name in platform_backends():
        return None
    home = _HOME.get(name)
    here = platform()
    return (f"{name} is the {platform_name(home)} context API, not available on "
            f"{platform_name(here)}: set CELLGL_BACKEND to one of "
            f"{', '.join(PLATFORM_BACKENDS[here])}, or unset it")


def osmesa_library() -> str | None:
    """Path of Mesa's off-screen library (``libOSMesa`` / ``osmesa.dll``), or None."""
    return ctypes.util.find_library("OSMesa") or ctypes.util.find_library("osmesa")


def create_native(backend: str, require: int):
    """A new standalone context of the platform's own backend ``wgl`` or ``cgl`` (glcontext's
    default backend there), current on this thread.

    ``wgl`` asks for each of :data:`WGL_VERSIONS` in turn (a driver may give exactly the core
    version asked for), keeping the first that works; ``cgl`` gets 4.1 core (or 3.2 core on
    old Macs, refused below ``require``).
    """
    import moderngl

    if backend == "cgl":
        return moderngl.create_context(standalone=True, require=require)
    if backend != "wgl":
        raise ValueError(f"not a native backend: {backend!r}")
    errors = []
    for version in WGL_VERSIONS:
        if version < require:
            continue
        try:
            return moderngl.create_context(standalone=True, require=version)
        except Exception as exc:  # noqa: BLE001 - glcontext raises bare Exception
            text = (str(exc).strip() or type(exc).__name__).splitlines()[0]
            errors.append(f"{version // 100}.{version % 100 // 10} core: {text}")
    raise RuntimeError("; ".join(errors))


def install_hint() -> str:
    """What a user of this platform can do when no context could be made (one paragraph)."""
    need = ("cellgl needs OpenGL 3.3 core: the fragment path runs there (Apple's 4.1 included); "
            "OpenGL 4.3 adds compute shaders, the compute path (`cellgl info` shows which runs). ")
    key = platform()
    if key == "win32":
        return need + (
            "On Windows install or update the GPU driver (WGL comes with it). With no GPU "
            "(a virtual machine, a CI runner) use Mesa's llvmpipe build for Windows: put its "
            "opengl32.dll next to python.exe, or set GLCONTEXT_WIN_LIBGL to its full path "
            "(docs/platforms.md).")
    if key == "darwin":
        return need + (
            "macOS provides OpenGL 4.1 core through CGL; if it fails, run from a logged-in "
            "desktop session (not a bare ssh login) and check that nothing sets "
            "CELLGL_BACKEND to another platform's backend (docs/platforms.md).")
    return need + (
        "On Debian/Ubuntu install Mesa's headless EGL driver: `apt-get install libegl1 "
        "libegl-mesa0 libgl1-mesa-dri` (or `apt-get install libosmesa6` and set "
        "CELLGL_BACKEND=osmesa).")


def _gl_library():
    """The platform's OpenGL library (Windows' opengl32, macOS' OpenGL framework), or None."""
    try:
        if platform() == "win32":
            return ctypes.WinDLL(os.environ.get("GLCONTEXT_WIN_LIBGL") or "opengl32")
        if platform() == "darwin":
            return ctypes.CDLL("/System/Library/Frameworks/OpenGL.framework/OpenGL")
    except (OSError, AttributeError):
        return None
    return None


def get_proc(backend: str | None, name: str) -> int:
    """Address of GL function ``name`` for the current context of ``backend`` (0 if unknown).

    ``wgl``/``cgl``: the entry point exported by the platform's GL library (enough for the
    OpenGL 1.x functions cellgl looks up this way, such as ``glGetIntegerv``)."""
    bname = name.encode("ascii")
    try:
        if backend in ("wgl", "cgl"):
            lib = _gl_library()
            return ctypes.cast(getattr(lib, name), ctypes.c_void_p).value or 0 if lib else 0
        if backend == "osmesa":
            lib = ctypes.CDLL(osmesa_library())
            fn = lib.OSMesaGetProcAddress
        elif backend == "glx":
            lib = ctypes.CDLL(ctypes.util.find_library("GL"))
            fn = lib.glXGetProcAddressARB
        else:
            lib = ctypes.CDLL(ctypes.util.find_library("EGL"))
            fn = lib.eglGetProcAddress
        fn.restype = ctypes.c_void_p
        fn.argtypes = [ctypes.c_char_p]
        return fn(bname) or 0
    except (OSError, AttributeError, TypeError):
        return 0


class CurrentEGLLoader:
    """GL entry points of whatever EGL context is current (a window's); creates nothing."""

    def __init__(self):
        name = ctypes.util.find_library("EGL")
        if not name:
            raise RuntimeError("libEGL not found; " + install_hint())
        self._egl = ctypes.CDLL(name)
        self._egl.eglGetProcAddress.restype = ctypes.c_void_p
        self._egl.eglGetProcAddress.argtypes = [ctypes.c_char_p]
        self._egl.eglGetCurrentContext.restype = ctypes.c_void_p
        if not self._egl.eglGetCurrentContext():
            raise RuntimeError("no EGL context is current on this thread")

    def load_opengl_function(self, name: str) -> int:
        return self._egl.eglGetProcAddress(name.encode("ascii")) or 0

    def __enter__(self):
        pass

    def __exit__(self, *args):
        pass

    def release(self) -> None:
        pass
