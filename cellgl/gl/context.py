"""Headless OpenGL context (3.3 core and up) and shader program cache.

One context per backend per process. Every backend asks for the newest OpenGL core version
first and walks down :data:`cellgl.gl.versions.LADDER` (4.6, 4.5, 4.3, 4.1, 3.3): some drivers
(NVIDIA's) give exactly the version asked. The backends of each platform, in the order tried when
none is named (:mod:`cellgl.gl.platforms`):

``egl`` (Linux)
    glcontext's EGL backend (headless; Mesa llvmpipe or a GPU driver) on EGL device 0, or
    device ``N`` with ``CELLGL_DEVICE=N`` (:func:`cellgl.gl.platforms.egl_devices`).
``glx`` (Linux)
    glcontext's X11 backend, only when ``DISPLAY`` is set.
``wgl`` (Windows)
    Windows' own context API (glcontext's default backend there): the GPU driver's
    ``opengl32.dll``, or Mesa's llvmpipe build named by ``GLCONTEXT_WIN_LIBGL``.
``cgl`` (macOS)
    Apple's OpenGL (glcontext's default backend there): 4.1 core, no compute shaders.
``osmesa`` (everywhere)
    Mesa's off-screen library ``libOSMesa`` through a small ctypes loader, only when the library
    can be found.

The environment variable ``CELLGL_BACKEND`` forces one backend; a backend of another platform
(``CELLGL_BACKEND=wgl`` on Linux) is a :class:`ContextError` that names this platform's.
Which GPU path runs on the context (compute from OpenGL 4.3, fragment below it) is
:func:`cellgl.gl.path.gpu_path`'s decision.

Threads: one shared context per backend and process, and one lock. Every cellgl call that does
GL work holds the lock and has the context current on the calling thread for its duration, then
releases it from the thread, so calls from any number of threads are safe (they run one at a
time). :func:`get_context` called outside a cellgl call (your own moderngl work) leaves the
context current on your thread; wrap such work in ``with current() as ctx:`` when other threads
use cellgl meanwhile. A thread that finds the shared context held that way by another thread gets
a context of its own (its programs compile again) instead of failing.

fork: a child process forked after the parent used GL (``os.fork``, multiprocessing's ``fork``
start method) gets a fresh context on first use: the parent's, whose driver threads do not
exist in the child, is left untouched (using or releasing it would hang). See README, "Threads
and processes".
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import threading
from collections.abc import Mapping

import moderngl

from cellgl.gl import backends, glsl, moderngl_seam, osmesa, path, platforms, registry, shadercache, versions
from cellgl.gl.backends import ContextError
from cellgl.gl.osmesa import OSMesaLoader  # noqa: F401 - public here before it moved

__all__ = [
    "BACKENDS",
    "ContextError",
    "REQUIRED_GL",
    "check_gl_error",
    "compute_program",
    "context_info",
    "current",
    "get_context",
    "program",
]

#: Every accepted backend name (each platform has some of them: cellgl.gl.platforms).
BACKENDS = platforms.ALL_BACKENDS

#: Minimum OpenGL version, as moderngl's version code: 3.3 core runs the fragment path;
#: 4.3 adds compute shaders (cellgl.gl.path). The versions asked: cellgl.gl.versions.LADDER.
REQUIRED_GL = versions.MINIMUM


# What cellgl knows of each context (its backend, the thread it is current on, whether it is a
# thread's private one) is in the context's state (cellgl.gl.registry.ContextState); here only
# what belongs to the process: the shared context of each backend, the spare private ones.
_lock = threading.RLock()
_contexts: dict[str, moderngl.Context] = {}      # the shared context of each backend
_default_backend: str | None = None
#: thread-private contexts (see get_context) not in use: backend -> contexts, reused
_spare: dict[str, list] = {}
_tls = threading.local()   # depth (nesting of current()), guard, private: backend -> ctx
_pid = os.getpid()
#: displays opened in this process / in a process it was forked from (their threads are gone)
_opened: set[str] = set()
_tainted: set[str] = set()
#: GL state inherited through fork: kept alive, never released (releasing would hang)
_orphans: list = []
#: what a signal handler (the CLI's, for SIGTERM/SIGHUP) deferred because it fired inside a
#: cellgl call: called (it raises) on leaving the outermost one, never in the middle of GL work
deferred: list = []


# --------------------------------------------------------------------------------------------
# Backends
# --------------------------------------------------------------------------------------------


def _create(backend: str) -> moderngl.Context:
    """A new context of ``backend`` (:func:`cellgl.gl.backends.create`), current on this thread."""
    shadercache.prepare_environment()   # the drivers' shader disk caches, before a driver loads
    return backends.create(backend, _tainted, _opened)


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
    why = platforms.check_backend(key)
    if why:  # another platform's backend: one line naming the setting and the fix
        raise ContextError(f"{origin} {name!r}: {why}")
    return key


def _current(ctx: moderngl.Context) -> moderngl.Context:
    """Make ``ctx`` the thread's current context and return it.

    Another library in the process (a GLFW window, wgpu's GL backend, a second moderngl
    context) may have made its own context current since; GL calls would then go to that one,
    or fail ("cannot create program"). Making ours current again is cheap when it already is.
    """
    moderngl_seam.make_current(ctx)
    registry.held(ctx).thread = threading.get_ident()
    if getattr(_tls, "guard", None) is None:
        _tls.guard = _ThreadGuard()
    return ctx


def _release(ctx: moderngl.Context) -> None:
    """Make ``ctx`` current on no thread (so that another thread can make it current)."""
    moderngl_seam.release_current(ctx)
    st = registry.peek(ctx)
    if st is not None:
        st.thread = None


def _bound_here() -> list[tuple[moderngl.Context, registry.ContextState]]:
    """The contexts cellgl made current on this thread (and still holds so), with their states."""
    me = threading.get_ident()
    return [(ctx, st) for ctx, st in registry.states() if st.thread == me]


class _ThreadGuard:
    """Lives in a thread's locals; when the thread ends, releases the contexts still current
    on it (a context left current on a finished thread can never be made current again) and
    hands its private contexts back for reuse."""

    def __init__(self):
        self.pid, self.ident = os.getpid(), threading.get_ident()

    def __del__(self):
        if os.getpid() != self.pid:  # the copy in a forked child: its contexts are not ours
            return
        try:
            for ctx, st in registry.states():
                if st.thread == self.ident:
                    _release(ctx)
                    if st.private and st.backend is not None:
                        _spare.setdefault(st.backend, []).append(ctx)
        except Exception:  # noqa: BLE001 - interpreter shutdown
            pass


def _take(shared: moderngl.Context, name: str) -> moderngl.Context:
    """``shared`` made current on this thread, or this thread's private context of backend
    ``name`` when ``shared`` is current on another thread (held there outside cellgl calls:
    the caller holds the lock)."""
    private = getattr(_tls, "private", None)
    if private is None:
        private = _tls.private = {}
    if name in private:
        return _current(private[name])
    owner = registry.held(shared).thread
    if owner is None or owner == threading.get_ident():
        return _current(shared)
    spare = _spare.get(name)
    ctx = spare.pop() if spare else _create(name)
    st = registry.held(ctx)
    st.backend, st.private = name, True
    private[name] = ctx
    return _current(ctx)


def _after_fork_in_child() -> None:
    """In a forked child: forget the parent's GL state (keeping it alive: releasing it would
    wait for driver threads that do not exist here) and the lock (another thread may have held
    it at fork time); the next get_context() opens a display of its own."""
    global _lock, _tls, _default_backend, _pid
    if _pid == os.getpid():
        return
    _orphans.append((dict(_contexts), _spare.copy(), _tls))
    _tainted.update(_opened)
    _opened.clear()
    for table in (_contexts, _spare, osmesa.probed):
        table.clear()
    _default_backend = None   # (the contexts' states: cellgl.gl.registry forgets them itself)
    deferred.clear()
    _lock, _tls, _pid = threading.RLock(), threading.local(), os.getpid()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_after_fork_in_child)


@contextlib.contextmanager
def section():
    """Hold the lock; on leaving the outermost one, release from this thread the contexts made
    current during it (those current here before stay so)."""
    with _lock:
        depth = getattr(_tls, "depth", 0)
        before = [ctx for ctx, _ in _bound_here()] if depth == 0 else []
        _tls.depth = depth + 1
        try:
            yield
        finally:
            _tls.depth = depth
            if depth == 0:
                for ctx, st in _bound_here():
                    if not st.private and not any(ctx is b for b in before):
                        _release(ctx)
                if deferred and threading.current_thread() is threading.main_thread():
                    deferred.pop()()


path.set_guard(section)   # the known-answer checks (cellgl.gl.path) run holding the GL lock


@contextlib.contextmanager
def interruptible():
    """A stretch of a cellgl call without GL work (a file of its own read or written): a signal
    the CLI turns into an exception raises here at once, not deferred to the call's end."""
    depth = getattr(_tls, "depth", 0)
    _tls.depth = 0
    try:
        if deferred and threading.current_thread() is threading.main_thread():
            deferred.pop()()
        yield
    finally:
        _tls.depth = depth


@contextlib.contextmanager
def current(backend: str | None = None):
    """``with current() as ctx:``: the context (as :func:`get_context`) current on this thread,
    with the process's GL lock held, for GL work of your own while other threads use cellgl.
    On leaving, it is released from the thread again (unless it was current here before)."""
    with section():
        yield get_context(backend)


def window_api() -> str:
    """``"egl"`` or ``"native"``: the context API for a window (the viewer's) in this process.

    EGL on Linux when cellgl's headless context is (or will be) EGL: Mesa will not make a GLX
    context current in a process that has already initialised EGL (``BadAccess`` in
    ``X_GLXMakeCurrent``); with both on EGL they share the thread freely. Everywhere else the
    platform's own API (GLX, WGL, NSGL): Windows has no EGL without ANGLE, macOS none at all.
    """
    if platforms.platform() != "linux":
        return "native"
    name = _default_backend or os.environ.get("CELLGL_BACKEND", "").strip().lower() or "egl"
    return "egl" if name == "egl" else "native"


def attach_current(require: int = REQUIRED_GL, api: str = "native") -> moderngl.Context:
    """A moderngl.Context for the context current on this thread (a GLFW window's), with its
    default framebuffer as ``screen``. ``api``: ``"egl"`` for a window made with
    ``CONTEXT_CREATION_API = EGL_CONTEXT_API`` (see :func:`window_api`), ``"native"`` for one
    of the platform's own API (glcontext's default backend detects it)."""
    if api == "egl":
        return attach_current_egl(require)
    import glcontext

    try:   # glcontext's default backend, detecting the current context
        loader = glcontext.default_backend()(mode="detect", glversion=require)
    except Exception as exc:  # noqa: BLE001 - glcontext raises bare Exception
        raise ContextError(f"could not attach to the OpenGL context current on this thread: {exc}") from None
    return backends.context_from_loader(loader, require, standalone=False)


def attach_current_egl(require: int = REQUIRED_GL) -> moderngl.Context:
    """As :func:`attach_current` for the EGL context current on this thread."""
    try:
        loader = platforms.CurrentEGLLoader()
    except RuntimeError as exc:
        raise ContextError(str(exc)) from None
    return backends.context_from_loader(loader, require, standalone=False)


def get_context(backend: str | None = None) -> moderngl.Context:
    """Return the process-wide headless OpenGL context (3.3 core or later).

    Parameters
    ----------
    backend : {"egl", "glx", "osmesa", "wgl", "cgl"}, optional
        Force a backend. Default: ``$CELLGL_BACKEND`` if set, else the first that works of
        the platform's: egl, glx (when ``DISPLAY`` is set), osmesa (when libOSMesa is found)
        on Linux; wgl, osmesa on Windows; cgl, osmesa on macOS.

    Returns
    -------
    moderngl.Context
        Cached: the same object for the same backend (per process: a forked child gets its
        own); made current on this thread, where it stays current until the thread ends or
        a cellgl call on it finishes that did not find it current. Safe from any thread; a
        thread that finds the shared context current on another (outside cellgl calls) gets a
        private one. See :func:`current` for GL work of your own beside other threads.

    Raises
    ------
    ValueError
        Unknown backend name.
    ContextError
        No backend gave an OpenGL 3.3 core context (or the named backend is another
        platform's); the message lists each backend tried, with why it failed.
    """
    global _default_backend
    if _pid != os.getpid():  # forked by a path that skipped the at-fork hook
        _after_fork_in_child()
    with _lock:
        if backend is None:
            env = os.environ.get("CELLGL_BACKEND", "").strip()
            if env:
                candidates = [_check_name(env, "CELLGL_BACKEND")]
            else:
                if _default_backend is not None:
                    return _take(_contexts[_default_backend], _default_backend)
                candidates = [b for b in platforms.platform_backends() if _available(b)]
        else:
            if not isinstance(backend, str):
                raise _unknown_backend(backend)
            candidates = [_check_name(backend, "backend argument")]

        shadercache.prepare_environment()   # before a driver loads; a bad setting: one line
        versions.check_settings()
        candidates = platforms.device_backends(
            candidates, backend is not None or bool(os.environ.get("CELLGL_BACKEND", "").strip()))
        errors = []
        for name in candidates:
            if name in _contexts:
                ctx = _contexts[name]
            else:
                try:
                    ctx = _create(name)
                except Exception as exc:  # each backend fails in its own way
                    errors.append(f"  {name}: {versions.first_line(exc)}")
                    continue
                _contexts[name] = ctx
                registry.held(ctx).backend = name
                _current(ctx)  # created current on this thread
            if backend is None and not os.environ.get("CELLGL_BACKEND", "").strip():
                _default_backend = name
            return _take(ctx, name)

        skipped = [b for b in platforms.platform_backends() if b not in candidates]
        note = ""
        if backend is None and not os.environ.get("CELLGL_BACKEND", "").strip() and skipped:
            reasons = platforms.skip_reasons()
            note = "\n" + "\n".join(f"  {b}: skipped ({reasons.get(b, 'not tried')})"
                                    for b in skipped)
        settings = [f"{k}={os.environ[k]}" for k in osmesa.DRIVER_ENV if k in os.environ]
        if settings:
            note += ("\n  driver settings in the environment: " + ", ".join(settings)
                     + " (unset them to let Mesa choose, or set GALLIUM_DRIVER=llvmpipe)")
        raise ContextError(
            f"could not create an OpenGL context on {platforms.platform_name()}. Backends tried:\n"
            + "\n".join(errors) + note + "\n" + platforms.install_hint()
        )


def _available(backend: str) -> bool:
    """Whether a backend of this platform is worth trying when none is named."""
    if backend == "glx":
        return bool(os.environ.get("DISPLAY"))
    if backend == "osmesa":
        return platforms.osmesa_library() is not None
    return True


def computes_on(ctx: moderngl.Context) -> bool:
    """Whether cellgl's own calls on this thread (those that take no context: the basis, the
    textures) run on ``ctx``, as :func:`get_context` would answer, without making a context."""
    name = os.environ.get("CELLGL_BACKEND", "").strip().lower() or _default_backend
    private = getattr(_tls, "private", None) or {}
    return name is not None and (ctx is private.get(name) or ctx is _contexts.get(name))


def backend_name(ctx: moderngl.Context | None = None) -> str | None:
    """Return the backend name a context made by :func:`get_context` came from."""
    st = registry.peek(ctx if ctx is not None else get_context())
    return st.backend if st is not None else None


# --------------------------------------------------------------------------------------------
# Limits
# --------------------------------------------------------------------------------------------

_GL_MAX_COMPUTE_SHARED_MEMORY_SIZE = 0x8262


def get_integer(ctx: moderngl.Context, pname: int) -> int | None:
    addr = platforms.get_proc(backend_name(ctx), "glGetIntegerv")
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
        Keys ``backend``, ``path`` (the GPU path that runs: ``compute`` or ``fragment``,
        :func:`cellgl.gl.path.gpu_path`), ``GL_VENDOR``, ``GL_RENDERER``, ``GL_VERSION``, ``gl_version_code``,
        ``gl_ladder`` (the versions asked and refused, :func:`cellgl.gl.versions.describe`),
        ``egl_device`` (the EGL device in use, ``CELLGL_DEVICE``), ``selfcheck``
        (the known-answer check of the path, :func:`cellgl.gl.path.check_summary`),
        ``GL_MAX_COMPUTE_WORK_GROUP_COUNT`` (3-tuple), ``GL_MAX_COMPUTE_WORK_GROUP_SIZE``
        (3-tuple), ``GL_MAX_COMPUTE_WORK_GROUP_INVOCATIONS``, ``GL_MAX_SHADER_STORAGE_BLOCK_SIZE``
        (bytes), ``GL_MAX_COMPUTE_SHARED_MEMORY_SIZE`` (bytes, None if it cannot be queried).
    """
    with section():  # a cellgl call: from any thread, leaving no context held there
        return _info(ctx if ctx is not None else get_context())


def _info(ctx: moderngl.Context) -> dict:
    info = ctx.info
    return {
        "backend": backend_name(ctx),
        "path": _path_or_why(ctx),
        "GL_VENDOR": info.get("GL_VENDOR"),
        "GL_RENDERER": info.get("GL_RENDERER"),
        "GL_VERSION": info.get("GL_VERSION"),
        "gl_version_code": ctx.version_code,
        "gl_ladder": versions.describe(ctx),
        "egl_device": _device_info(ctx),
        "selfcheck": path.check_summary(ctx),
        "GL_MAX_COMPUTE_WORK_GROUP_COUNT": tuple(info.get("GL_MAX_COMPUTE_WORK_GROUP_COUNT", ())),
        "GL_MAX_COMPUTE_WORK_GROUP_SIZE": tuple(info.get("GL_MAX_COMPUTE_WORK_GROUP_SIZE", ())),
        "GL_MAX_COMPUTE_WORK_GROUP_INVOCATIONS": info.get("GL_MAX_COMPUTE_WORK_GROUP_INVOCATIONS"),
        "GL_MAX_SHADER_STORAGE_BLOCK_SIZE": info.get("GL_MAX_SHADER_STORAGE_BLOCK_SIZE"),
        "GL_MAX_COMPUTE_SHARED_MEMORY_SIZE": get_integer(ctx, _GL_MAX_COMPUTE_SHARED_MEMORY_SIZE),
    }


def _path_or_why(ctx: moderngl.Context) -> str:
    try:
        return path.gpu_path(ctx)
    except path.PathError:   # the selfcheck entry says why
        return "none (no path passes the known-answer check)"


def _device_info(ctx: moderngl.Context) -> str:
    backend = backend_name(ctx)
    if backend != "egl" or "egl-surfaceless" in _opened:
        return f"n/a (the {backend or 'attached'} context has no device choice)"
    return platforms.device_line(platforms.device_setting() or 0, ctx.info.get("GL_RENDERER"))


def check_gl_error(ctx: moderngl.Context | None = None) -> None:
    """Raise RuntimeError if the context has a pending GL error (reading it clears it)."""
    ctx = ctx if ctx is not None else get_context()
    err = ctx.error
    if err != "GL_NO_ERROR":
        raise RuntimeError(f"OpenGL error: {err}")


# --------------------------------------------------------------------------------------------
# Programs
# --------------------------------------------------------------------------------------------


def _compile_error(what: str, exc: Exception, src: glsl.Source) -> glsl.ShaderError:
    err = glsl.ShaderError(f"{what}: {glsl.map_error(str(exc), src).strip()}")
    err.sources = [src]
    return err


def compute_program(name: str, defines: Mapping | None = None, *,
                    ctx: moderngl.Context | None = None, files: Mapping[str, str] | None = None,
                    cache: bool = True, lru: tuple | None = None) -> moderngl.ComputeShader:
    """Compile (once, cached) the compute shader ``shaders/<name>``.

    The cache is the context's one program cache (:mod:`cellgl.gl.registry`: dropped with the
    context and in a forked child).

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
    lru : (str, int), optional
        Keep it among the last ``int`` programs of the named group only (older ones released).

    Raises
    ------
    cellgl.gl.glsl.ShaderError
        Loading or compiling failed; driver line numbers are mapped to ``file:line``.
    """
    ctx = ctx if ctx is not None else get_context()

    def make():
        src = glsl.load(name, defines, files=files)
        try:
            return ctx.compute_shader(src.text), None
        except moderngl.Error as exc:
            raise _compile_error(f"compiling {name}", exc, src) from None
    if not cache:
        return make()[0]
    with _lock:
        return registry.cached(ctx, registry.program_key("compute", name, defines=defines, files=files),
                               make, lru)[0]


def program(vertex: str, fragment: str, defines: Mapping | None = None, *,
            ctx: moderngl.Context | None = None) -> moderngl.Program:
    """Compile and link (once, cached) a vertex + fragment program from ``shaders/``.

    See :func:`compute_program` for ``defines``, ``ctx`` and errors. The files' ``#version``
    is lowered to :func:`glsl_version` of ``ctx``. The ``#define``s are used as given: what a
    GPU path adds (the storage words' layout) is the runner's
    (:meth:`cellgl.gl.runner.Runner.program`, which draws with them).
    """
    return program_entry(vertex, fragment, defines, ctx=ctx)[0]


def program_entry(vertex: str, fragment: str, defines: Mapping | None = None, *,
                  ctx: moderngl.Context | None = None) -> tuple:
    """``(program, vertex array)``: :func:`program` and an empty vertex array of it (a
    full-screen draw's: ``gl_VertexID`` only), made and kept together in the context's cache."""
    ctx = ctx if ctx is not None else get_context()

    def make():
        version = glsl_version(ctx)
        vs = glsl.lower_version(glsl.load(vertex, defines), version)
        fs = glsl.lower_version(glsl.load(fragment, defines), version)
        try:
            prog = ctx.program(vertex_shader=vs.text, fragment_shader=fs.text)
        except moderngl.Error as exc:
            raise _program_error(vertex, fragment, exc, vs, fs) from None
        return prog, ctx.vertex_array(prog, [])
    with _lock:
        return registry.cached(ctx, registry.program_key("program", vertex, fragment, defines=defines), make)


def glsl_version(ctx: moderngl.Context) -> int:
    """The GLSL ``#version`` of vertex/fragment programs on ``ctx``: the shaders' own 430 from
    OpenGL 4.3, else the context's (410 on macOS, 330 on OpenGL 3.3 core)."""
    code = ctx.version_code
    return next(v for v in (430, 420, 410, 400, 330) if code >= v or v == 330)


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
