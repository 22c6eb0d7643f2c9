"""A stand-in GPU driver that gives EXACTLY the OpenGL version asked, as NVIDIA's EGL and GLX do
(Mesa gives its highest core version whatever is asked, which hid issue 39 on llvmpipe).

It sits where a driver sits for cellgl: behind glcontext's EGL backend. Each context request
is passed to Mesa (llvmpipe, whose own limit is 4.5: a request above it fails in Mesa itself, as
a request above a driver's version fails there), and the context it returns reports exactly
the version asked: ``glGetIntegerv(GL_MAJOR_VERSION / GL_MINOR_VERSION)`` and
``glGetString(GL_VERSION)``, which moderngl and cellgl read, are answered from the request.
Mesa's own override (``MESA_GL_VERSION_OVERRIDE``) cannot do this: Mesa reads it once per
process, so every later request gets the first one's version.

``CELLGL_TEST_DRIVER_MAX=4.1`` makes the stand-in refuse every version above 4.1 (an older
driver), as ``eglCreateContext`` does: EGL_BAD_MATCH.

Use: ``import exact_driver; exact_driver.install()`` before cellgl makes its context (in a
child process: tests/test_versions.py).
"""

from __future__ import annotations

import ctypes
import os

GL_MAJOR_VERSION = 0x821B
GL_MINOR_VERSION = 0x821C
GL_VERSION = 0x1F02
GL_SHADING_LANGUAGE_VERSION = 0x8B8C

_GET_INTEGERV = ctypes.CFUNCTYPE(None, ctypes.c_uint, ctypes.POINTER(ctypes.c_int))
_GET_STRING = ctypes.CFUNCTYPE(ctypes.c_void_p, ctypes.c_uint)

#: every request the stand-in saw: (major, minor, refused)
requests: list[tuple[int, int, bool]] = []


class ExactLoader:
    """glcontext's loader for a Mesa context, answering version queries with ``(major, minor)``."""

    def __init__(self, inner, major: int, minor: int):
        self._inner = inner
        self.major, self.minor = major, minor
        self._real_integer = _GET_INTEGERV(inner.load_opengl_function("glGetIntegerv"))
        self._real_string = _GET_STRING(inner.load_opengl_function("glGetString"))
        real = ctypes.string_at(self._real_string(GL_VERSION)).decode()
        self._version = ctypes.create_string_buffer(
            f"{major}.{minor}.0 exact-version stand-in (over {real})".encode())
        self._glsl = ctypes.create_string_buffer(f"{major}.{minor}0".encode())
        self._integer = _GET_INTEGERV(self._get_integer)
        self._string = _GET_STRING(self._get_string)

    def _get_integer(self, pname, out):
        if pname == GL_MAJOR_VERSION:
            out[0] = self.major
        elif pname == GL_MINOR_VERSION:
            out[0] = self.minor
        else:
            self._real_integer(pname, out)

    def _get_string(self, name):
        if name == GL_VERSION:
            return ctypes.addressof(self._version)
        if name == GL_SHADING_LANGUAGE_VERSION:
            return ctypes.addressof(self._glsl)
        return self._real_string(name)

    def load_opengl_function(self, name: str) -> int:
        if name == "glGetIntegerv":
            return ctypes.cast(self._integer, ctypes.c_void_p).value
        if name == "glGetString":
            return ctypes.cast(self._string, ctypes.c_void_p).value
        return self._inner.load_opengl_function(name)

    def __enter__(self):
        return self._inner.__enter__()

    def __exit__(self, *args):
        return self._inner.__exit__(*args)

    def release(self):
        self._inner.release()


def install() -> None:
    """Put the stand-in behind glcontext's EGL backend in this process."""
    import glcontext

    real = glcontext.get_backend_by_name
    limit = os.environ.get("CELLGL_TEST_DRIVER_MAX", "").strip()
    top = tuple(int(v) for v in limit.split(".")) if limit else (9, 9)

    def get_backend_by_name(name: str):
        create = real(name)
        if name != "egl":
            return create

        def exact(*args, **kwargs):
            code = int(kwargs.get("glversion", 330))
            major, minor = code // 100, code % 100 // 10
            if (major, minor) > top:
                requests.append((major, minor, True))
                raise Exception("eglCreateContext failed (0x3009)")   # EGL_BAD_MATCH
            try:
                inner = create(*args, **kwargs)
            except Exception:
                requests.append((major, minor, True))
                raise
            requests.append((major, minor, False))
            return ExactLoader(inner, major, minor)

        return exact

    glcontext.get_backend_by_name = get_backend_by_name
