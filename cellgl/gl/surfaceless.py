"""A headless EGL context on Mesa's surfaceless platform, for a process forked from one that
had already used EGL (see :mod:`cellgl.gl.context`, "fork").

Why a second display: a forked child inherits the parent's EGL display already initialised,
together with the driver's worker threads' state but not the threads (Mesa llvmpipe runs compute
dispatches on a thread pool made when the display is initialised). Any context on that display,
old or new, then waits forever for threads that do not exist. Mesa opens one display per
platform, so the child opens the *surfaceless* platform's display instead (a fresh one, with
its own threads) and makes a context there. It needs ``EGL_MESA_platform_surfaceless`` and
``EGL_KHR_surfaceless_context`` (Mesa has both).
"""

from __future__ import annotations

import ctypes
import ctypes.util

from cellgl.gl import versions

__all__ = ["SurfacelessEGLLoader"]

_EGL_PLATFORM_SURFACELESS_MESA = 0x31DD
_EGL_NONE = 0x3038
_EGL_RENDERABLE_TYPE = 0x3040
_EGL_OPENGL_BIT = 0x0008
_EGL_SURFACE_TYPE = 0x3033
_EGL_OPENGL_API = 0x30A2
_EGL_CONTEXT_MAJOR_VERSION = 0x3098
_EGL_CONTEXT_MINOR_VERSION = 0x30FB
_EGL_CONTEXT_OPENGL_PROFILE_MASK = 0x30FD
_EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT = 0x1


class SurfacelessEGLLoader:
    """A moderngl loader (``load_opengl_function``, ``__enter__``/``__exit__``, ``release``)
    owning a core-profile context on the surfaceless EGL display: of version ``version`` (a
    moderngl version code), or with ``version=None`` the first of
    :data:`cellgl.gl.versions.LADDER` the driver gives.

    Raises
    ------
    RuntimeError
        libEGL missing, or the display, config or context cannot be made; the message names
        the EGL call and its error code.
    """

    def __init__(self, version: int | None = None):
        name = ctypes.util.find_library("EGL")
        if not name:
            raise RuntimeError("libEGL not found")
        egl = ctypes.CDLL(name)
        self._egl = egl
        vp, i = ctypes.c_void_p, ctypes.c_int
        egl.eglGetProcAddress.restype = vp
        egl.eglGetProcAddress.argtypes = [ctypes.c_char_p]
        egl.eglGetError.restype = i
        egl.eglInitialize.argtypes = [vp, ctypes.POINTER(i), ctypes.POINTER(i)]
        egl.eglBindAPI.argtypes = [ctypes.c_uint]
        egl.eglChooseConfig.argtypes = [vp, ctypes.POINTER(i), ctypes.POINTER(vp), i,
                                        ctypes.POINTER(i)]
        egl.eglCreateContext.restype = vp
        egl.eglCreateContext.argtypes = [vp, vp, vp, ctypes.POINTER(i)]
        egl.eglMakeCurrent.argtypes = [vp, vp, vp, vp]
        egl.eglDestroyContext.argtypes = [vp, vp]
        addr = egl.eglGetProcAddress(b"eglGetPlatformDisplayEXT")
        if not addr:
            raise RuntimeError("eglGetPlatformDisplayEXT not available")
        get_display = ctypes.CFUNCTYPE(vp, ctypes.c_uint, vp, vp)(addr)
        self._dpy = get_display(_EGL_PLATFORM_SURFACELESS_MESA, None, None)
        if not self._dpy:
            self._fail("eglGetPlatformDisplayEXT(surfaceless)")
        major, minor = i(), i()
        if not egl.eglInitialize(self._dpy, ctypes.byref(major), ctypes.byref(minor)):
            self._fail("eglInitialize(surfaceless)")
        if not egl.eglBindAPI(_EGL_OPENGL_API):
            self._fail("eglBindAPI(OpenGL)")
        attrs = (i * 5)(_EGL_RENDERABLE_TYPE, _EGL_OPENGL_BIT, _EGL_SURFACE_TYPE, 0, _EGL_NONE)
        cfg, n = vp(), i()
        if not egl.eglChooseConfig(self._dpy, attrs, ctypes.byref(cfg), 1, ctypes.byref(n)) \
                or n.value < 1:
            self._fail("eglChooseConfig(OpenGL, no surface)")
        self._ctx = None
        self._cfg = cfg
        ladder = versions.LADDER if version is None else (version,)
        try:
            handle, tried = versions.climb(self._create, ladder=ladder)
        except versions.LadderError as exc:
            raise RuntimeError(f"eglCreateContext(surfaceless): {exc}") from None
        self._ctx = handle.value
        #: the rungs tried: (version code, error or None) (cellgl.gl.versions.describe)
        self.ladder = tried
        self.__enter__()

    def _create(self, code: int) -> ctypes.c_void_p:
        i = ctypes.c_int
        major, minor = versions.major_minor(code)
        cattrs = (i * 7)(_EGL_CONTEXT_MAJOR_VERSION, major, _EGL_CONTEXT_MINOR_VERSION, minor,
                         _EGL_CONTEXT_OPENGL_PROFILE_MASK, _EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                         _EGL_NONE)
        handle = self._egl.eglCreateContext(self._dpy, self._cfg, None, cattrs)
        if not handle:
            self._fail("eglCreateContext")
        return ctypes.c_void_p(handle)

    def _fail(self, what: str):
        raise RuntimeError(f"{what} failed (0x{self._egl.eglGetError():x})")

    def load_opengl_function(self, name: str) -> int:
        return self._egl.eglGetProcAddress(name.encode("ascii")) or 0

    def __enter__(self):
        if self._ctx and not self._egl.eglMakeCurrent(self._dpy, None, None, self._ctx):
            self._fail("eglMakeCurrent(surfaceless)")

    def __exit__(self, *args):
        self._egl.eglMakeCurrent(self._dpy, None, None, None)

    def release(self) -> None:
        if self._ctx:
            self.__exit__()
            self._egl.eglDestroyContext(self._dpy, self._ctx)
            self._ctx = None
