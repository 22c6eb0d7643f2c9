"""Command line interface: ``cellgl <command> ...`` (also ``python -m cellgl``).

Each subcommand is a pair of functions: one declares its arguments on the subparsers, one runs
it (``args -> int``); they live in this package's modules (``bake``, ``export``, ``presets``,
``dask``, ``voronoi``, ``blender``, ``playground``; ``info`` and ``view`` here), the command line's
floor above the library (tests/test_layers.py), and are registered in :func:`_commands`.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import signal
import sys
import threading
import warnings
from collections.abc import Callable, Sequence

from cellgl import _interrupt

__all__ = ["main", "build_parser"]

PROG = "cellgl"


# --------------------------------------------------------------------------------------------
# info
# --------------------------------------------------------------------------------------------


def _add_info(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    from cellgl.gl.platforms import ALL_BACKENDS

    p = sub.add_parser("info", help="show the OpenGL context: backend, GL version, which GPU path "
                       "runs (compute or fragment), renderer, compute limits")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--backend", choices=ALL_BACKENDS, default=None,
                   help="force a context backend (default: $CELLGL_BACKEND, else the platform's: "
                   "egl, glx, osmesa on Linux; wgl on Windows; cgl on macOS)")
    return p


def _fmt(value: object) -> str:
    """One line of text: control characters (a driver's string, a file's) written as escapes."""
    if isinstance(value, (tuple, list)):
        text = " ".join(str(v) for v in value) or "none"
    else:
        text = "unknown" if value is None else str(value)
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


def _cmd_info(args: argparse.Namespace) -> int:
    import cellgl.basis  # noqa: F401 - registers the known-answer check of the path (selfcheck)
    from cellgl.gl import context

    ctx = context.get_context(args.backend)
    from cellgl.gl import shadercache

    info = context.context_info(ctx)
    info["shader_cache"] = shadercache.summary()
    if args.json:
        print(json.dumps(info, indent=2))
    else:
        for key, value in info.items():
            print(f"{key}: {_fmt(value)}")
    return 1 if info["path"].startswith("none") else 0


# --------------------------------------------------------------------------------------------
# view (the interactive viewer lives in the viewer package; see docs/viewer.md)
# --------------------------------------------------------------------------------------------


def _add_view(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    from cellgl.viewer.cli import add_arguments

    return add_arguments(sub.add_parser(
        "view", help="interactive viewer (GLFW + Dear ImGui); --screenshot FILE for a headless capture"))


#: the modules of the [viewer] extra (pyproject.toml)
VIEWER_EXTRA = ("imgui_bundle", "glfw")


def _run_view(args: argparse.Namespace) -> int:
    """``cellgl view``; without the [viewer] extra, one line saying how to install it."""
    try:
        import cellgl.viewer.app  # noqa: F401 - the GUI's modules: fails without the extra
    except ModuleNotFoundError as exc:
        if (exc.name or "").partition(".")[0] not in VIEWER_EXTRA:
            raise
        raise ValueError(f"cellgl view needs the viewer extra (no module {exc.name!r}): "
                         "pip install 'cellgl[viewer]'") from None
    from cellgl.viewer import cli as viewer_cli

    return viewer_cli.run(args)


# --------------------------------------------------------------------------------------------
# registry and entry point
# --------------------------------------------------------------------------------------------


def _commands() -> dict[str, tuple[Callable, Callable[[argparse.Namespace], int]]]:
    """name -> (add its arguments to the subparsers, run it), in the order ``--help`` lists them.
    Each command's parser and runner is a module of this package (the command line's floor:
    tests/test_layers.py), imported here when the parser is built, so that ``import cellgl.cli``
    loads the standard library only; the commands' code is below, in the library: cellgl/bake/
    (docs/bake.md), viewer/ (docs/viewer.md), cellgl/export/ (docs/engines.md), cellgl/recipes.py
    (docs/textures.md), cellgl/dask/ (docs/scale.md), cellgl/basis/voronoi.py and cellgl/blender/
    (docs/blender.md), cellgl/playground/ (docs/playground.md)."""
    from cellgl.cli import bake, blender, dask, export, playground, presets, voronoi

    return {
        "info": (_add_info, _cmd_info),
        "bake": (bake.add_parser, bake.run_cli),
        "view": (_add_view, _run_view),
        "export": (export.add_parser, export.run_cli),
        "presets": (presets.add_parser, presets.run_cli),
        "sweep": (dask.add_sweep_parser, dask.run_sweep),
        "voronoi": (voronoi.add_parser, voronoi.run_cli),
        "blender": (blender.add_parser, blender.run_cli),
        "blender-extension": (blender.add_extension_parser, blender.run_extension_cli),
        "playground": (playground.add_parser, playground.run_cli),
    }


#: the commands :func:`build_parser` declares (filled from :func:`_commands` there; an entry set
#: before, by a test, is kept)
_COMMANDS: dict[str, tuple[Callable, Callable[[argparse.Namespace], int]]] = {}


class _Parser(argparse.ArgumentParser):
    """argparse's parser, but a help, version or usage text it cannot write is an error like any
    command's output (argparse drops an ``OSError`` of the write: ``cellgl --help > /dev/full``
    said nothing and exited 0). Every subcommand's parser is one too (``add_subparsers`` makes
    them of the parser's class)."""

    def _print_message(self, message, file=None):
        if message:
            (file or sys.stderr).write(message)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog=PROG, description="Cellular texture basis functions on the GPU."
    )
    from cellgl._version import __version__

    parser.add_argument("--version", action="version", version=f"{PROG} {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name, command in _commands().items():
        _COMMANDS.setdefault(name, command)
    for add, run in _COMMANDS.values():
        add(sub).set_defaults(_run=run)
    return parser


def _user_errors() -> tuple[type[BaseException], ...]:
    """ValueError and cellgl's GL errors (those of modules loaded: this imports nothing): no
    context, a shader that does not compile, a driver the known-answer check refuses (PathError:
    its message names the driver and what to do; not cellgl's fault, so not an internal error)."""
    errors: list[type[BaseException]] = [ValueError]
    for module, name in (("cellgl.gl.context", "ContextError"), ("cellgl.gl.glsl", "ShaderError"),
                         ("cellgl.gl.path", "PathError")):
        if module in sys.modules:
            errors.append(getattr(sys.modules[module], name))
    return tuple(errors)


class Terminated(BaseException):
    """SIGTERM or SIGHUP, raised in the main thread like KeyboardInterrupt for Ctrl-C, so that
    every ``with`` block unwinds: temporary files are deleted, outputs left as they were."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


#: the signals turned into an exception while a command runs (SIGINT: KeyboardInterrupt)
_UNWIND = ("SIGINT", "SIGTERM", "SIGHUP")


#: the signal received while the command runs (at most one: later ones are ignored)
_received: list[int] = []


def _raise(exc: BaseException):
    raise exc


def _on_signal(signum, frame):
    """The first of SIGINT/SIGTERM/SIGHUP raises (KeyboardInterrupt or :class:`Terminated`);
    later ones are ignored, so that a second Ctrl-C cannot cut the clean-up short."""
    for name in _UNWIND:
        sig = getattr(signal, name, None)
        if sig is not None:
            signal.signal(sig, signal.SIG_IGN)
    _received[:] = [signum]
    exc = KeyboardInterrupt() if signum == signal.SIGINT else Terminated(signum)
    _interrupt.pending[:] = [exc]    # raised again at the next tile or frame if this is swallowed
    gl = sys.modules.get("cellgl.gl.context")   # (maybe half imported: the signal came during it)
    if gl is not None and getattr(getattr(gl, "_tls", None), "depth", 0) > 0:
        # inside a GL call: raised as it returns (an exception in the middle of GL work has
        # been seen to crash the driver at exit)
        gl.deferred[:] = [lambda: _raise(exc)]
        return
    raise exc


@contextlib.contextmanager
def _signals_unwind():
    """SIGINT, SIGTERM and SIGHUP raise while the command runs (main thread only)."""
    old = {}
    if threading.current_thread() is threading.main_thread():
        for name in _UNWIND:
            sig = getattr(signal, name, None)
            if sig is not None and signal.getsignal(sig) is not signal.SIG_IGN:
                old[sig] = signal.signal(sig, _on_signal)
    try:
        yield
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)


def _leave(status: int):
    """Exit now with ``status``, output flushed, without the interpreter's teardown: after a
    signal it would release GL state (Mesa's threads) the signal may have interrupted, which
    has crashed in libpython (SIGSEGV, exit 139) at exit."""
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    os._exit(status)


def _warning_line(message, category, filename, lineno, file=None, line=None) -> None:
    """``warnings.showwarning`` of the command line: one ``cellgl: warning: ...`` line."""
    stream = sys.stderr if file is None else file
    with contextlib.suppress(Exception):
        stream.write(f"{PROG}: warning: {' '.join(str(message).split())}\n")


def _error(message: str, status: int = 2) -> int:
    try:
        print(f"{PROG}: error: {message}", file=sys.stderr)
    except OSError:
        pass
    return status


def _os_error(exc: OSError) -> str:
    what = exc.strerror or str(exc)
    if exc.filename is not None:
        return f"{exc.filename}: {what}"
    return f"cannot write to standard output: {what}"


def _quiet_stdout() -> None:
    """Point stdout at /dev/null so that the interpreter's final flush cannot fail again."""
    try:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    except (OSError, ValueError):
        pass


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit status (0 ok, 1 internal error, 2 usage or user
    error, 128 + N on signal N: 130 Ctrl-C, 143 SIGTERM, 129 SIGHUP). Never a traceback unless
    ``CELLGL_DEBUG=1``.

    As the program (``argv`` None: the ``cellgl`` command, ``python -m cellgl``) a signal ends
    the process with :func:`os._exit` once everything is unwound; called with a list (a test,
    another program) it returns the status instead."""
    program = argv is None
    _received.clear()
    with _signals_unwind(), warnings.catch_warnings():
        warnings.showwarning = _warning_line
        try:
            args = build_parser().parse_args(argv)
            status = int(args._run(args) or 0)
            sys.stdout.flush()  # a full disk or a closed pipe shows here, not at exit
        except SystemExit as exc:   # --help, --version, usage errors (argparse)
            if exc.code not in (0, None):
                raise
            try:                # what --help / --version wrote: a full disk shows here, not at exit
                sys.stdout.flush()
            except BaseException as flush_exc:  # noqa: BLE001 - as a command's own output
                status = _status(flush_exc)
            else:
                raise
        except BaseException as exc:  # noqa: BLE001 - every outcome is an exit status
            status = _status(exc)
    _interrupt.pending.clear()
    if _received:
        # A signal came: whatever it turned into (KeyboardInterrupt; an ImportError when it hit a
        # C extension's import; nothing, if some library swallowed it), the command stopped on
        # it. Unwound: temporary files are gone (a progress line says "interrupted").
        status = 128 + _received[0]
        return _leave(status) if program else status
    return status


def _status(exc: BaseException) -> int:
    """The exit status of a command that raised ``exc`` (its message printed)."""
    if _received or isinstance(exc, KeyboardInterrupt):
        _received[:] = _received or [signal.SIGINT]
        return 128 + _received[0]
    if isinstance(exc, Terminated):
        return 128 + exc.signum
    if isinstance(exc, _user_errors()):
        return _error(str(exc))
    if isinstance(exc, BrokenPipeError):
        # Output piped into e.g. `head`: stop quietly, as other command line tools do.
        _quiet_stdout()
        return 0
    if isinstance(exc, OSError):
        if exc.filename is None:
            _quiet_stdout()
        return _error(_os_error(exc))
    if isinstance(exc, RecursionError):
        return _error("input nested too deeply")
    if not isinstance(exc, Exception) or os.environ.get("CELLGL_DEBUG", "").strip() not in ("", "0"):
        raise exc
    # the last resort: a message, not a traceback
    return _error(f"internal error: {type(exc).__name__}: {exc} (CELLGL_DEBUG=1 shows "
                  "the traceback; please report it)", status=1)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
