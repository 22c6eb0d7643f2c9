"""Which OpenGL context each desktop platform offers, how to make one, and what to tell the user
when none can be made.

========  ===========================================  ==========================================
platform  backends, in the order tried                 what the platform's own backend gives
========  ===========================================  ==========================================
Linux     ``egl``, ``glx`` (``DISPLAY`` set),          Mesa (llvmpipe: 4.5) or the GPU driver
          ``osmesa`` (libOSMesa found)                 (NVIDIA: 4.6)
Windows   ``wgl``, ``osmesa`` (OSMesa DLL found)       the driver's ``opengl32.dll`` (or Mesa's,
                                                       ``GLCONTEXT_WIN_LIBGL``)
macOS     ``cgl``, ``osmesa`` (libOSMesa found)        Apple's OpenGL: 4.1 core, no compute
========  ===========================================  ==========================================

Every backend climbs the one version ladder of :mod:`cellgl.gl.versions` (4.6, 4.5, 4.3, 4.1,
3.3 core; the first the driver gives wins): a driver may give exactly the version asked
(NVIDIA's EGL and GLX do), so asking 3.3 would leave the compute path unused.

The platform backends are glcontext's: on Windows and macOS it is glcontext's default backend
(:func:`cellgl.gl.versions.glcontext_context` with ``"native"``). glcontext's WGL backend asks
``wglCreateContextAttribsARB`` for a core profile of the requested version; its CGL backend
ignores the version and asks for ``kCGLOGLPVersion_GL4_Core`` (then ``GL3_Core``), which is
4.1 core on every Mac that has it (a legacy context would stop at 2.1).

On a machine with several GPUs ``CELLGL_DEVICE=N`` picks EGL device ``N`` (glcontext's
``device_index``; :func:`egl_devices` lists them, ``cellgl info`` shows the one in use).

Everything here is plain data and small functions; :mod:`cellgl.gl.context` owns the contexts.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import sys
from typing import Any

from cellgl.gl import versions

__all__ = ["ALL_BACKENDS", "PLATFORM_BACKENDS", "platform", "platform_backends", "check_backend",
           "create_native", "install_hint", "get_proc", "CurrentEGLLoader", "egl_devices",
           "device_setting", "check_device", "device_backends", "device_line"]

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


def create_native(backend: str) -> tuple[Any, list[tuple[int, str | None]]]:
    """A new standalone context of the platform's own backend ``glx``, ``wgl`` or ``cgl``
    (glcontext's default backend there), current on this thread: the first rung of
    :data:`cellgl.gl.versions.LADDER` the driver gives (CGL ignores the version asked: 4.1 core,
    or 3.2 core on old Macs, refused below 3.3), with the rungs tried
    (:func:`cellgl.gl.versions.climb`).

    Raises
    ------
    cellgl.gl.versions.LadderError
        No rung worked; the message lists each version asked with the driver's answer.
    """
    if backend not in ("glx", "wgl", "cgl"):
        raise ValueError(f"not a native backend: {backend!r}")
    return versions.climb(lambda code: versions.glcontext_context("native", code))


# --------------------------------------------------------------------------------------------
# EGL devices (CELLGL_DEVICE)
# --------------------------------------------------------------------------------------------

_EGL_VENDOR = 0x3053
_EGL_EXTENSIONS = 0x3055
_EGL_DRM_DEVICE_FILE_EXT = 0x3233
_EGL_RENDERER_EXT = 0x335F


#: the name of Mesa's software EGL device: the driver behind it is llvmpipe, softpipe or zink, as
#: ``GALLIUM_DRIVER`` picks (docs/platforms.md), so the device alone does not name it
MESA_SOFTWARE = "Mesa software renderer"


def egl_devices() -> list[str] | None:
    """One line per EGL device (``eglQueryDevicesEXT``, in the order of glcontext's
    ``device_index``): its name where the driver tells it, else its DRM node or kind. None when
    libEGL cannot list devices (no ``EGL_EXT_device_enumeration``)."""
    name = ctypes.util.find_library("EGL")
    if not name:
        return None
    try:
        egl = ctypes.CDLL(name)
        egl.eglGetProcAddress.restype = ctypes.c_void_p
        egl.eglGetProcAddress.argtypes = [ctypes.c_char_p]
        query = egl.eglGetProcAddress(b"eglQueryDevicesEXT")
        string = egl.eglGetProcAddress(b"eglQueryDeviceStringEXT")
    except (OSError, AttributeError):
        return None
    if not query:
        return None
    vp = ctypes.c_void_p
    query = ctypes.CFUNCTYPE(ctypes.c_uint, ctypes.c_int, ctypes.POINTER(vp),
                             ctypes.POINTER(ctypes.c_int))(query)
    devices, count = (vp * 64)(), ctypes.c_int(0)
    if not query(64, devices, ctypes.byref(count)):
        return None
    text = ctypes.CFUNCTYPE(ctypes.c_char_p, vp, ctypes.c_int)(string) if string else None

    def get(dev, key) -> str | None:
        value = text(dev, key) if text else None
        return value.decode(errors="replace").strip() if value else None

    out = []
    for i in range(count.value):
        ext = (get(devices[i], _EGL_EXTENSIONS) or "").split()
        parts = []
        if "EGL_EXT_device_query_name" in ext:
            parts += [v for v in (get(devices[i], _EGL_VENDOR), get(devices[i], _EGL_RENDERER_EXT))
                      if v]
        if "EGL_EXT_device_drm" in ext:
            parts += [v for v in (get(devices[i], _EGL_DRM_DEVICE_FILE_EXT),) if v]
        if "EGL_MESA_device_software" in ext:
            parts.append(MESA_SOFTWARE)     # which of Mesa's drivers: GALLIUM_DRIVER picks
        if "EGL_NV_device_cuda" in ext:
            parts.append("NVIDIA CUDA device")
        out.append(", ".join(dict.fromkeys(parts)) or "EGL device")
    return out


def _range(devices: list[str] | None) -> str:
    if devices is None:
        return "a device index from 0 (this machine's libEGL cannot list its devices)"
    if not devices:
        return "none (EGL lists no device on this machine)"
    listing = "; ".join(f"{i}: {d}" for i, d in enumerate(devices))
    return f"0..{len(devices) - 1} ({listing})"


#: the variables that name an EGL device: cellgl's, and glcontext's own (read by its EGL backend)
DEVICE_VARS = ("CELLGL_DEVICE", "GLCONTEXT_DEVICE_INDEX")


def device_variable() -> str:
    """``"CELLGL_DEVICE=1"``: the variable (and value) that names the device, for messages."""
    for name in DEVICE_VARS:
        if os.environ.get(name, ""):
            return f"{name}={os.environ[name].strip()}"
    return "CELLGL_DEVICE"


def device_setting() -> int | None:
    """The EGL device index named by ``CELLGL_DEVICE`` or glcontext's ``GLCONTEXT_DEVICE_INDEX``
    (None when both are unset or empty).

    Raises
    ------
    ValueError
        Either is not a whole number from 0, or they name different devices; the message names
        the variable and the accepted values.
    """
    found = {}
    for name in DEVICE_VARS:
        raw = os.environ.get(name, "")
        if not raw:
            continue
        try:
            index = int(raw.strip(), 10)
        except ValueError:
            index = -1
        if index < 0:
            raise ValueError(f"{name}={raw!r} is not an EGL device index; accepted values: "
                             f"{_range(egl_devices())}")
        found[name] = index
    if len(set(found.values())) > 1:
        raise ValueError(f"CELLGL_DEVICE={found['CELLGL_DEVICE']} and GLCONTEXT_DEVICE_INDEX="
                         f"{found['GLCONTEXT_DEVICE_INDEX']} name different EGL devices; unset "
                         "one of them")
    return next(iter(found.values()), None)


#: glcontext's own settings of the libraries its backends load (OSMesa, cellgl's own loader,
#: reads none of them)
GLCONTEXT_LIBRARIES = ("GLCONTEXT_LINUX_LIBEGL", "GLCONTEXT_LINUX_LIBGL", "GLCONTEXT_LINUX_LIBX11",
                       "GLCONTEXT_WIN_LIBGL")


def glcontext_setting() -> str | None:
    """``"GLCONTEXT_LINUX_LIBEGL=/x"``: the first of glcontext's library settings that is set."""
    for name in GLCONTEXT_LIBRARIES:
        if os.environ.get(name):
            return f"{name}={os.environ[name]}"
    return None


def skip_reasons() -> dict:
    """Why a backend of the platform was not tried when none was named (for the error)."""
    chosen = glcontext_setting()
    return {"glx": "DISPLAY not set",
            "osmesa": (f"{chosen} is set: glcontext's backends only" if chosen
                       else "libOSMesa not found")}


def device_backends(candidates: list[str], named: bool) -> list[str]:
    """``candidates`` (the backends to try; ``named``: chosen by the user), or with
    ``CELLGL_DEVICE`` set only ``egl`` (the API that picks a device), the index checked; with one
    of glcontext's library settings (:data:`GLCONTEXT_LIBRARIES`) set, not ``osmesa`` unless
    named: a library that fails to load is an error, never a silent fall back to the CPU.

    Raises
    ------
    ValueError
        A bad ``CELLGL_DEVICE`` (naming the devices), or one set beside another backend.
    """
    device = device_setting()
    if not named and glcontext_setting() and len(candidates) > 1:
        candidates = [c for c in candidates if c != "osmesa"]
    if device is None:
        return candidates
    own = platform_backends()
    if named and candidates != ["egl"] or "egl" not in own:
        var = device_variable()
        raise ValueError(
            f"{var} picks an EGL device, but the backend is "
            f"{candidates[0] if named else own[0]} on {platform_name()}: unset {var.split('=')[0]}"
            + (" or set CELLGL_BACKEND=egl" if "egl" in own else ""))
    check_device(device)
    return ["egl"]


def device_line(index: int, renderer: str | None = None) -> str:
    """``"0 of 2: NVIDIA ..."``: device ``index`` among this machine's EGL devices. ``renderer``
    (the context's ``GL_RENDERER``) is added to Mesa's software device, which says nothing of
    the driver that runs (``"0 of 1: Mesa software renderer (softpipe)"``)."""
    devices = egl_devices()
    if not devices or index >= len(devices):
        return str(index)
    name = devices[index]
    if renderer and name.endswith(MESA_SOFTWARE):
        name = f"{name} ({renderer})"
    return f"{index} of {len(devices)}: {name}"


def check_device(index: int) -> None:
    """Raise ValueError when ``index`` is not one of this machine's EGL devices (naming them)."""
    devices = egl_devices()
    if devices is not None and index >= len(devices):
        raise ValueError(f"{device_variable().split('=')[0]}={index} is not an EGL device of "
                         "this machine; "
                         f"accepted values: {_range(devices)}")


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
        if sys.platform.startswith("win"):     # (as platform() says "win32"; mypy reads this form)
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
