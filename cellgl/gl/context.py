"""Headless OpenGL 4.3+ context and shader program cache.

One context per backend per process. Backends, in the order tried when none is named:

``egl``
    glcontext's EGL backend (headless; Mesa llvmpipe or a GPU driver).
``glx``
    glcontext's X11 backend, only when ``DISPLAY`` is set.
``osmesa``
    Mesa's off-screen library ``libOSMesa`` through a small ctypes loader, only when the library
    can be found.

The environment variable ``CELLGL_BACKEND`` (``egl``, ``glx`` or ``osmesa``) forces one backend.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import threading
from collections import deque
from collections.abc import Mapping

import moderngl

from cellgl.gl import glsl

__all__ = [
    "BACKENDS",
    "ContextError",
    "REQUIRED_GL",
    "check_gl_error",
    "compute_program",
    "context_info",
    "get_context",
    "program",
]

#: Accepted backend names, in the order tried.
BACKENDS = ("egl", "glx", "osmesa")

#: Minimum OpenGL version (compute shaders, SSBOs), as moderngl's version code.
REQUIRED_GL = 430

_INSTALL_HINT = (
    "cellgl needs an OpenGL 4.3 (core) context for compute shaders. On Debian/Ubuntu install "
    "Mesa's headless EGL driver: `apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri` "
    "(or `apt-get install libosmesa6` and set CELLGL_BACKEND=osmesa)."
)


class ContextError(RuntimeError):
    """No usable OpenGL 4.3 context could be created."""


_lock = threading.RLock()
_contexts: dict[str, moderngl.Context] = {}
_default_backend: str | None = None
_backend_of: dict[int, str] = {}
_programs: dict[tuple, object] = {}


# --------------------------------------------------------------------------------------------
# OSMesa loader
# --------------------------------------------------------------------------------------------

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

    Creates a core-profile context (4.5, else 4.3) and makes it current on a small RGBA pbuffer.
    """

    def __init__(self, width: int = 16, height: int = 16, library: str | None = None):
        path = library or ctypes.util.find_library("OSMesa")
        if not path:
            raise ContextError("libOSMesa not found (Debian/Ubuntu: apt-get install libosmesa6)")
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
        tried = []
        for major, minor in ((4, 5), (4, 3)):
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
            arr = (ctypes.c_int * len(attribs))(*attribs)
            handle = lib.OSMesaCreateContextAttribs(arr, None)
            if handle:
                self._ctx = handle
                break
            tried.append(f"{major}.{minor}")
        if not self._ctx:
            raise ContextError(
                f"OSMesa ({path}) could not create a core profile context of version "
                f"{' or '.join(tried)}; cellgl needs OpenGL 4.3 (a gallium/llvmpipe OSMesa, "
                "e.g. Mesa >= 20)"
            )
        self._width, self._height = width, height
        self._buffer = ctypes.create_string_buffer(width * height * 4)
        self.make_current()

    def make_current(self) -> None:
        ok = self._lib.OSMesaMakeCurrent(self._ctx, self._buffer, _GL_UNSIGNED_BYTE,
                                         self._width, self._height)
        if not ok:
            raise ContextError("OSMesaMakeCurrent failed")

    def load_opengl_function(self, name: str) -> int:
        return self._lib.OSMesaGetProcAddress(name.encode("ascii")) or 0

    def __enter__(self):
        self.make_current()

    def __exit__(self, *args):
        pass

    def release(self) -> None:
        if self._ctx:
            self._lib.OSMesaDestroyContext(self._ctx)
            self._ctx = None


def _context_from_loader(loader, require: int) -> moderngl.Context:
    """Wrap a loader object in a standalone moderngl.Context (moderngl 5.10+ internals)."""
    ctx = moderngl.Context.__new__(moderngl.Context)
    ctx.mglo, ctx.version_code = moderngl.mgl.create_context(
        glversion=require, mode="standalone", context=loader
    )
    ctx._info = None
    ctx._extensions = None
    ctx.extra = None
    ctx._gc_mode = None
    ctx._objects = deque()
    ctx._screen = None
    ctx.fbo = None
    if ctx.version_code < require:
        raise ContextError(
            f"OpenGL {require // 100}.{require % 100 // 10} required, "
            f"got {ctx.version_code // 100}.{ctx.version_code % 100 // 10}"
        )
    return ctx


# --------------------------------------------------------------------------------------------
# Backends
# --------------------------------------------------------------------------------------------


def _create(backend: str) -> moderngl.Context:
    if backend == "egl":
        return moderngl.create_context(standalone=True, backend="egl", require=REQUIRED_GL)
    if backend == "glx":
        if not os.environ.get("DISPLAY"):
            raise ContextError("DISPLAY is not set")
        # glcontext's default backend on Linux is X11/GLX.
        return moderngl.create_context(standalone=True, require=REQUIRED_GL)
    if backend == "osmesa":
        loader = OSMesaLoader()
        try:
            return _context_from_loader(loader, REQUIRED_GL)
        except Exception:
            loader.release()
            raise
    raise _unknown_backend(backend)


def _unknown_backend(name: object) -> ValueError:
    return ValueError(
        f"unknown OpenGL backend {name!r}; accepted values: {', '.join(BACKENDS)}"
    )


def _check_name(name: str, origin: str) -> str:
    key = name.strip().lower()
    if key not in BACKENDS:
        raise ValueError(
            f"unknown OpenGL backend {name!r} (from {origin}); "
            f"accepted values: {', '.join(BACKENDS)}"
        )
    return key


def _version_error(exc: Exception) -> str:
    text = str(exc).strip() or type(exc).__name__
    return text.splitlines()[0] if text else text


def _current(ctx: moderngl.Context) -> moderngl.Context:
    """Make ``ctx`` the thread's current context and return it.

    Another library in the process (a GLFW window, wgpu's GL backend, a second moderngl
    context) may have made its own context current since; GL calls would then go to that one,
    or fail ("cannot create program"). Making ours current again is cheap when it already is.
    """
    ctx.mglo.__enter__()
    return ctx


class _CurrentEGLLoader:
    """GL entry points of whatever EGL context is current (a window's); creates nothing."""

    def __init__(self):
        name = ctypes.util.find_library("EGL")
        if not name:
            raise ContextError("libEGL not found; " + _INSTALL_HINT)
        self._egl = ctypes.CDLL(name)
        self._egl.eglGetProcAddress.restype = ctypes.c_void_p
        self._egl.eglGetProcAddress.argtypes = [ctypes.c_char_p]
        self._egl.eglGetCurrentContext.restype = ctypes.c_void_p
        if not self._egl.eglGetCurrentContext():
            raise ContextError("no EGL context is current on this thread")

    def load_opengl_function(self, name: str) -> int:
        return self._egl.eglGetProcAddress(name.encode("ascii")) or 0

    def __enter__(self):
        pass

    def __exit__(self, *args):
        pass

    def release(self) -> None:
        pass


def attach_current_egl(require: int = REQUIRED_GL) -> moderngl.Context:
    """A moderngl.Context for the EGL context current on this thread (a GLFW window made with
    ``CONTEXT_CREATION_API = EGL_CONTEXT_API``), with its default framebuffer as ``screen``.

    Windows use EGL rather than GLX because Mesa will not make a GLX context current in a
    process that has already initialised EGL (cellgl's headless context): ``BadAccess`` in
    ``X_GLXMakeCurrent``. With both on EGL they share the thread freely.
    """
    ctx = _context_from_loader(_CurrentEGLLoader(), require)
    ctx._screen = ctx.detect_framebuffer(0)
    ctx.fbo = ctx.detect_framebuffer()
    ctx.mglo.fbo = ctx.fbo.mglo
    return ctx


def get_context(backend: str | None = None) -> moderngl.Context:
    """Return the process-wide headless OpenGL 4.3+ context.

    Parameters
    ----------
    backend : {"egl", "glx", "osmesa"}, optional
        Force a backend. Default: ``$CELLGL_BACKEND`` if set, else the first of
        egl, glx (when ``DISPLAY`` is set), osmesa (when libOSMesa is found) that works.

    Returns
    -------
    moderngl.Context
        Cached: the same object for the same backend; made current on this thread.

    Raises
    ------
    ValueError
        Unknown backend name.
    ContextError
        No backend gave an OpenGL 4.3 context; the message lists each backend tried.
    """
    global _default_backend
    with _lock:
        if backend is None:
            env = os.environ.get("CELLGL_BACKEND", "").strip()
            if env:
                candidates = [_check_name(env, "CELLGL_BACKEND")]
            else:
                if _default_backend is not None:
                    return _current(_contexts[_default_backend])
                candidates = ["egl"]
                if os.environ.get("DISPLAY"):
                    candidates.append("glx")
                if ctypes.util.find_library("OSMesa"):
                    candidates.append("osmesa")
        else:
            if not isinstance(backend, str):
                raise _unknown_backend(backend)
            candidates = [_check_name(backend, "backend argument")]

        errors = []
        for name in candidates:
            if name in _contexts:
                ctx = _contexts[name]
            else:
                try:
                    ctx = _create(name)
                except Exception as exc:  # each backend fails in its own way
                    errors.append(f"  {name}: {_version_error(exc)}")
                    continue
                _contexts[name] = ctx
                _backend_of[id(ctx)] = name
            if backend is None and not os.environ.get("CELLGL_BACKEND", "").strip():
                _default_backend = name
            return _current(ctx)

        skipped = [b for b in BACKENDS if b not in candidates]
        note = ""
        if backend is None and not os.environ.get("CELLGL_BACKEND", "").strip() and skipped:
            reasons = {"glx": "DISPLAY not set", "osmesa": "libOSMesa not found"}
            note = "\n" + "\n".join(f"  {b}: skipped ({reasons.get(b, 'not tried')})"
                                    for b in skipped)
        raise ContextError(
            "could not create an OpenGL 4.3 context. Backends tried:\n"
            + "\n".join(errors) + note + "\n" + _INSTALL_HINT
        )


def backend_name(ctx: moderngl.Context | None = None) -> str | None:
    """Return the backend name a context made by :func:`get_context` came from."""
    ctx = ctx if ctx is not None else get_context()
    return _backend_of.get(id(ctx))


# --------------------------------------------------------------------------------------------
# Limits
# --------------------------------------------------------------------------------------------

_GL_MAX_COMPUTE_SHARED_MEMORY_SIZE = 0x8262


def _get_proc(backend: str | None, name: str) -> int:
    """Address of GL function ``name`` for the current context of ``backend`` (0 if unknown)."""
    bname = name.encode("ascii")
    try:
        if backend == "osmesa":
            lib = ctypes.CDLL(ctypes.util.find_library("OSMesa"))
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


def _get_integer(ctx: moderngl.Context, pname: int) -> int | None:
    addr = _get_proc(_backend_of.get(id(ctx)), "glGetIntegerv")
    if not addr:
        return None
    proto = ctypes.CFUNCTYPE(None, ctypes.c_uint, ctypes.POINTER(ctypes.c_int))
    value = ctypes.c_int(-1)
    proto(addr)(pname, ctypes.byref(value))
    # Querying an enum the driver does not know leaves GL_INVALID_ENUM behind: clear it.
    if ctx.error != "GL_NO_ERROR":
        return None
    return value.value if value.value >= 0 else None


def context_info(ctx: moderngl.Context | None = None) -> dict:
    """Describe a context: backend, driver strings and compute limits.

    Returns
    -------
    dict
        Keys ``backend``, ``GL_VENDOR``, ``GL_RENDERER``, ``GL_VERSION``, ``gl_version_code``,
        ``GL_MAX_COMPUTE_WORK_GROUP_COUNT`` (3-tuple), ``GL_MAX_COMPUTE_WORK_GROUP_SIZE``
        (3-tuple), ``GL_MAX_COMPUTE_WORK_GROUP_INVOCATIONS``, ``GL_MAX_SHADER_STORAGE_BLOCK_SIZE``
        (bytes), ``GL_MAX_COMPUTE_SHARED_MEMORY_SIZE`` (bytes, None if it cannot be queried).
    """
    ctx = ctx if ctx is not None else get_context()
    info = ctx.info
    return {
        "backend": _backend_of.get(id(ctx)),
        "GL_VENDOR": info.get("GL_VENDOR"),
        "GL_RENDERER": info.get("GL_RENDERER"),
        "GL_VERSION": info.get("GL_VERSION"),
        "gl_version_code": ctx.version_code,
        "GL_MAX_COMPUTE_WORK_GROUP_COUNT": tuple(info.get("GL_MAX_COMPUTE_WORK_GROUP_COUNT", ())),
        "GL_MAX_COMPUTE_WORK_GROUP_SIZE": tuple(info.get("GL_MAX_COMPUTE_WORK_GROUP_SIZE", ())),
        "GL_MAX_COMPUTE_WORK_GROUP_INVOCATIONS": info.get("GL_MAX_COMPUTE_WORK_GROUP_INVOCATIONS"),
        "GL_MAX_SHADER_STORAGE_BLOCK_SIZE": info.get("GL_MAX_SHADER_STORAGE_BLOCK_SIZE"),
        "GL_MAX_COMPUTE_SHARED_MEMORY_SIZE": _get_integer(ctx, _GL_MAX_COMPUTE_SHARED_MEMORY_SIZE),
    }


def check_gl_error(ctx: moderngl.Context | None = None) -> None:
    """Raise RuntimeError if the context has a pending GL error (reading it clears it)."""
    ctx = ctx if ctx is not None else get_context()
    err = ctx.error
    if err != "GL_NO_ERROR":
        raise RuntimeError(f"OpenGL error: {err}")


# --------------------------------------------------------------------------------------------
# Programs
# --------------------------------------------------------------------------------------------


def _defines_key(defines: Mapping | None) -> tuple:
    if not defines:
        return ()
    return tuple(sorted((str(k), repr(v)) for k, v in defines.items()))


def _compile_error(what: str, exc: Exception, src: glsl.Source) -> glsl.ShaderError:
    err = glsl.ShaderError(f"{what}: {glsl.map_error(str(exc), src).strip()}")
    err.sources = [src]
    return err


def compute_program(name: str, defines: Mapping | None = None, *,
                    ctx: moderngl.Context | None = None, files: Mapping[str, str] | None = None,
                    cache: bool = True) -> moderngl.ComputeShader:
    """Compile (once, cached) the compute shader ``shaders/<name>``.

    Parameters
    ----------
    name : str
        Entry file relative to :func:`cellgl.gl.glsl.shader_dir`, e.g. ``"cellular.comp"``.
    defines : mapping, optional
        ``#define``s placed after ``#version`` (see :func:`cellgl.gl.glsl.load`).
    ctx : moderngl.Context, optional
        Defaults to :func:`get_context`.
    files : mapping of str to str, optional
        Generated include files (see :func:`cellgl.glsl.load`).
    cache : bool
        False: compile a new program and do not keep it (the caller owns and releases it).

    Raises
    ------
    cellgl.gl.glsl.ShaderError
        Loading or compiling failed; driver line numbers are mapped to ``file:line``.
    """
    ctx = ctx if ctx is not None else get_context()
    key = ("compute", id(ctx), name, _defines_key(defines), tuple(sorted((files or {}).items())))
    with _lock:
        prog = _programs.get(key) if cache else None
        if prog is None:
            src = glsl.load(name, defines, files=files)
            try:
                prog = ctx.compute_shader(src.text)
            except moderngl.Error as exc:
                raise _compile_error(f"compiling {name}", exc, src) from None
            if cache:
                _programs[key] = prog
        return prog


def program(vertex: str, fragment: str, defines: Mapping | None = None, *,
            ctx: moderngl.Context | None = None) -> moderngl.Program:
    """Compile and link (once, cached) a vertex + fragment program from ``shaders/``.

    See :func:`compute_program` for ``defines``, ``ctx`` and errors.
    """
    ctx = ctx if ctx is not None else get_context()
    key = ("program", id(ctx), vertex, fragment, _defines_key(defines))
    with _lock:
        prog = _programs.get(key)
        if prog is None:
            vs = glsl.load(vertex, defines)
            fs = glsl.load(fragment, defines)
            try:
                prog = ctx.program(vertex_shader=vs.text, fragment_shader=fs.text)
            except moderngl.Error as exc:
                raise _program_error(vertex, fragment, exc, vs, fs) from None
            _programs[key] = prog
        return prog


def _program_error(vertex, fragment, exc, vs, fs) -> glsl.ShaderError:
    # moderngl's message names the stage ("vertex_shader" / "fragment_shader") before its log.
    text = str(exc)
    if "fragment_shader" in text and "vertex_shader" not in text:
        src = fs
    elif "vertex_shader" in text and "fragment_shader" not in text:
        src = vs
    else:
        src = None
    message = glsl.map_error(text, src) if src is not None else text
    err = glsl.ShaderError(f"compiling {vertex} + {fragment}: {message.strip()}")
    err.sources = [vs, fs]
    return err


def clear_program_cache() -> None:
    """Forget compiled programs (e.g. after editing shader files)."""
    with _lock:
        for prog in _programs.values():
            try:
                prog.release()
            except Exception:
                pass
        _programs.clear()
