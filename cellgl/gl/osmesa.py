"""Mesa's off-screen library ``libOSMesa`` as a moderngl loader, and a probe that tries it in a
child process first (a misconfigured driver crashes the process instead of failing).

Used by :mod:`cellgl.gl.context` for its ``osmesa`` backend.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import subprocess
import sys

from cellgl.gl import versions

__all__ = ["OSMesaError", "OSMesaLoader", "probe", "DRIVER_ENV"]


class OSMesaError(RuntimeError):
    """libOSMesa is missing, crashed in the probe, or cannot give a 3.3 (or later) core context."""


_OSMESA_RGBA = 0x1908
_GL_UNSIGNED_BYTE = 0x1401
_OSMESA_FORMAT = 0x22
_OSMESA_DEPTH_BITS = 0x30
_OSMESA_STENCIL_BITS = 0x31
_OSMESA_ACCUM_BITS = 0x32
_OSMESA_PROFILE = 0x33
_OSMESA_CORE_PROFILE = 0x34
_OSMESA_CONTEXT_MAJOR_VERSION = 0x36
_OSMESA_CONTEXT_MINOR_VERSION = 0x37


class OSMesaLoader:
    """A moderngl loader (``load_opengl_function``, ``release``) backed by libOSMesa.

    Creates a core-profile context of version ``version`` (a moderngl version code), or with
    ``version=None`` the first of :data:`cellgl.gl.versions.LADDER` OSMesa gives (llvmpipe: 4.5),
    and makes it current on a small RGBA pbuffer.
    """

    def __init__(self, width: int = 16, height: int = 16, library: str | None = None,
                 version: int | None = None):
        path = library or ctypes.util.find_library("OSMesa")
        if not path:
            raise OSMesaError("libOSMesa not found (Debian/Ubuntu: apt-get install libosmesa6)")
        lib = ctypes.CDLL(path)
        self._lib = lib
        lib.OSMesaCreateContextAttribs.restype = ctypes.c_void_p
        lib.OSMesaCreateContextAttribs.argtypes = [ctypes.POINTER(ctypes.c_int), ctypes.c_void_p]
        lib.OSMesaMakeCurrent.restype = ctypes.c_ubyte
        lib.OSMesaMakeCurrent.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_uint,
                                          ctypes.c_int, ctypes.c_int]
        lib.OSMesaGetProcAddress.restype = ctypes.c_void_p
        lib.OSMesaGetProcAddress.argtypes = [ctypes.c_char_p]
        lib.OSMesaDestroyContext.restype = None
        lib.OSMesaDestroyContext.argtypes = [ctypes.c_void_p]

        self._ctx = None
        ladder = versions.LADDER if version is None else (version,)
        try:
            handle, tried = versions.climb(self._create, ladder=ladder)
        except versions.LadderError as exc:
            raise OSMesaError(
                f"OSMesa ({path}) could not create a core profile context ({exc}); cellgl needs "
                "OpenGL 3.3 core (4.3 for the compute path; a gallium/llvmpipe OSMesa, e.g. "
                "Mesa >= 20)"
            ) from None
        self._ctx = handle.value
        #: the rungs tried: (version code, error or None) (cellgl.gl.versions.describe)
        self.ladder = tried
        self._width, self._height = width, height
        self._buffer = ctypes.create_string_buffer(width * height * 4)
        self.make_current()

    def _create(self, code: int) -> ctypes.c_void_p:
        major, minor = versions.major_minor(code)
        attribs = [
            _OSMESA_FORMAT, _OSMESA_RGBA,
            _OSMESA_DEPTH_BITS, 24,
            _OSMESA_STENCIL_BITS, 8,
            _OSMESA_ACCUM_BITS, 0,
            _OSMESA_PROFILE, _OSMESA_CORE_PROFILE,
            _OSMESA_CONTEXT_MAJOR_VERSION, major,
            _OSMESA_CONTEXT_MINOR_VERSION, minor,
            0,
        ]
        handle = self._lib.OSMesaCreateContextAttribs((ctypes.c_int * len(attribs))(*attribs), None)
        if not handle:
            raise OSMesaError("OSMesaCreateContextAttribs returned no context")
        return ctypes.c_void_p(handle)

    def make_current(self) -> None:
        ok = self._lib.OSMesaMakeCurrent(self._ctx, self._buffer, _GL_UNSIGNED_BYTE,
                                         self._width, self._height)
        if not ok:
            raise OSMesaError("OSMesaMakeCurrent failed")

    def load_opengl_function(self, name: str) -> int:
        return self._lib.OSMesaGetProcAddress(name.encode("ascii")) or 0

    def __enter__(self):
        self.make_current()

    def __exit__(self, *args):
        self._lib.OSMesaMakeCurrent(None, None, _GL_UNSIGNED_BYTE, 0, 0)  # none current here

    def release(self) -> None:
        if self._ctx:
            self._lib.OSMesaDestroyContext(self._ctx)
            self._ctx = None


#: environment variables that steer Mesa's choice of driver (named when a probe crashes)
DRIVER_ENV = ("GALLIUM_DRIVER", "MESA_LOADER_DRIVER_OVERRIDE", "LIBGL_ALWAYS_SOFTWARE",
               "LIBGL_DRIVERS_PATH", "MESA_GL_VERSION_OVERRIDE")
#: (library, driver environment) -> library path, of probes that passed
probed: dict[tuple, str] = {}

_PROBE = """
import ctypes, sys
lib = ctypes.CDLL(sys.argv[1])
lib.OSMesaCreateContextAttribs.restype = ctypes.c_void_p
lib.OSMesaCreateContextAttribs.argtypes = [ctypes.POINTER(ctypes.c_int), ctypes.c_void_p]
lib.OSMesaMakeCurrent.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_uint, ctypes.c_int,
                                  ctypes.c_int]
for code in map(int, sys.argv[2].split(",")):   # the ladder (cellgl.gl.versions.LADDER)
    a = [0x22, 0x1908, 0x33, 0x34, 0x36, code // 100, 0x37, code % 100 // 10, 0]
    ctx = lib.OSMesaCreateContextAttribs((ctypes.c_int * len(a))(*a), None)
    if ctx:
        break
if not ctx:
    sys.exit(3)
buf = ctypes.create_string_buffer(16 * 16 * 4)
sys.exit(0 if lib.OSMesaMakeCurrent(ctx, buf, 0x1401, 16, 16) else 4)
"""


def probe() -> str:
    """Path of libOSMesa after creating a context with it in a child process first.

    A misconfigured driver (``GALLIUM_DRIVER=iris`` without that GPU, ...) makes libOSMesa
    crash the process (SIGSEGV) rather than fail; the probe turns that into a OSMesaError
    naming the settings. Cached per library path and driver environment.
    """
    path = ctypes.util.find_library("OSMesa")
    if not path:
        raise OSMesaError("libOSMesa not found (Debian/Ubuntu: apt-get install libosmesa6)")
    env = tuple((k, os.environ.get(k)) for k in DRIVER_ENV)
    if (path, env) in probed:
        return path
    try:
        ladder = ",".join(map(str, versions.LADDER))
        res = subprocess.run([sys.executable, "-I", "-S", "-c", _PROBE, path, ladder],
                             capture_output=True, timeout=120)
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise OSMesaError(f"could not probe OSMesa ({path}) in a child process: {exc}") from None
    if res.returncode != 0:
        settings = ", ".join(f"{k}={v}" for k, v in env if v is not None)
        why = (f"crashed ({_signal_name(-res.returncode)})" if res.returncode < 0 else
               "could not create a core profile 3.3 (or later) context" if res.returncode == 3 else
               f"failed (exit status {res.returncode}: "
               f"{res.stderr.decode(errors='replace').strip()[-300:]})")
        hint = (f"; check the driver settings in the environment: {settings}" if settings else
                "; is libOSMesa a gallium/llvmpipe build (Mesa >= 20)?")
        raise OSMesaError(f"OSMesa ({path}) {why} in a probe process{hint}")
    probed[(path, env)] = path
    return path


def _signal_name(num: int) -> str:
    import signal

    try:
        return signal.Signals(num).name
    except ValueError:
        return f"signal {num}"
