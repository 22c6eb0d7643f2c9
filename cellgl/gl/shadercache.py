"""cellgl's cache folder (the known-answer check's records) and the drivers' shader disk caches:
left as the drivers set them up, unless asked, or unless one would crash.

cellgl compiles a program per variant (the macros of a call: dimension, metric, distribution,
outputs, ...). The first call of a variant in a process pays the driver's compiler (0.3-0.9 s on
NVIDIA's, 0.1-1 s on llvmpipe's). Every common driver keeps compiled programs on disk by itself,
keyed by the driver's own build and the program's source, and checks each entry when it reads it:

* Mesa (llvmpipe, radeonsi, iris, ...): ``MESA_SHADER_CACHE_DIR`` (default
  ``$XDG_CACHE_HOME/mesa_shader_cache``, else ``~/.cache/mesa_shader_cache``), off with
  ``MESA_SHADER_CACHE_DISABLE=true``; entries keyed by the driver's build id and the shader's
  SHA-1, with a CRC.
* NVIDIA: ``__GL_SHADER_DISK_CACHE`` (on by default), ``__GL_SHADER_DISK_CACHE_PATH`` (default
  ``~/.nv/GLCache``, or under ``$XDG_CACHE_HOME``); keyed by driver version and source.

So "compiled once per driver" needs nothing of cellgl where the home folder is writable (measured:
docs/performance.md), and cellgl changes no variable of its process by default. Two exceptions:

* ``CELLGL_DRIVER_SHADER_CACHE=1`` (opt-in; for homes that are not writable: containers, batch
  nodes) points both drivers' caches into cellgl's folder, where the user has not set the
  driver's own variable. Each place is checked first: a file or a dangling link where a folder
  should be, too little free space, a folder that cannot be made: that driver keeps its default,
  with a note (:func:`notes`, shown by ``cellgl info``); never an error.
* Mesa maps its cache index into memory: on a full disk the first write to it ends the process
  with SIGBUS, whoever chose the folder. So where Mesa's cache folder (its default or the one
  set) has less than :data:`MIN_FREE` free, ``MESA_SHADER_CACHE_DISABLE=true`` is set (unless the
  user set it), with a note: a full disk costs compile time, never the process.

cellgl's own folder (:func:`cache_dir`) is ``$CELLGL_SHADER_CACHE_DIR``, else the OS's per-user
cache folder from platformdirs (Linux: ``$XDG_CACHE_HOME/cellgl`` or ``~/.cache/cellgl``; macOS:
``~/Library/Caches/cellgl``; Windows: ``%LOCALAPPDATA%\\cellgl\\Cache``) plus ``shaders``, else a
folder of this user under the temporary directory (made 0700, used only when owned by this user
and not a link). cellgl makes its own folders and at most the one folder above them (the
platform's cache folder, ``~/.cache``): never a folder whose parent is missing, so never a home
folder (``HOME=/nonexistent``). ``CELLGL_SHADER_CACHE=0``: no folder at all (no records).

Why not program binaries (``glGetProgramBinary``/``glProgramBinary``) kept by cellgl: moderngl 5
creates and introspects its programs from source only (``Context.program``; no way to hand it a
linked GL program), so a binary would skip the compile but not give a moderngl program. The
drivers' caches give the same effect, with the drivers' own keys and checks.
"""
from __future__ import annotations

import os
import shutil
import stat
import sys
import tempfile
from pathlib import Path

__all__ = ["cache_dir", "prepare_environment", "notes", "settings", "MIN_FREE"]

ENV_SWITCH = "CELLGL_SHADER_CACHE"        #: "0": no cellgl cache folder (no records)
ENV_DIR = "CELLGL_SHADER_CACHE_DIR"       #: where cellgl's folder goes (default: see cache_dir)
ENV_DRIVERS = "CELLGL_DRIVER_SHADER_CACHE"   #: "1": point the drivers' caches into it (opt-in)

#: the free bytes a driver's cache folder must have (Mesa's index alone maps 1.3 MB; a cache
#: grows to its entries); below this Mesa's disk cache is switched off
MIN_FREE = 64 << 20

_prepared: dict = {}
_notes: list[str] = []


def _flag(name: str) -> bool:
    """``name`` is "1" (on) or "0"/unset/empty (off); anything else is a ValueError."""
    raw = os.environ.get(name, "").strip()
    if raw not in ("", "0", "1"):
        raise ValueError(f"{name}={os.environ[name]!r} is not a switch; accepted values: 0, 1")
    return raw == "1"


def settings() -> None:
    """Check cellgl's cache variables (ValueError naming the value and the accepted ones)."""
    _flag(ENV_SWITCH)
    _flag(ENV_DRIVERS)


def _note(text: str) -> None:
    if text not in _notes:
        _notes.append(text)


def notes() -> list[str]:
    """What this process skipped or switched off about the caches, and why (for ``cellgl info``)."""
    return list(_notes)


def _free(place: Path) -> int | None:
    """Free bytes on the file system of ``place`` (its nearest existing ancestor), None unknown."""
    for folder in (place, *place.parents):
        try:
            return shutil.disk_usage(folder).free
        except OSError:
            continue
    return None


def _folder(folder: Path, owned: bool = False) -> str | None:
    """None when ``folder`` is (or was just made as) a writable folder, else why not. Only the
    folder itself is made: never its parent (``owned``: made 0700, and refused unless it is
    this user's and not a link, as in a shared temporary directory)."""
    try:
        if not os.path.lexists(folder):
            if not folder.parent.is_dir():
                return f"its parent {str(folder.parent)!r} does not exist"
            folder.mkdir(mode=0o700 if owned else 0o777)
        st = os.lstat(folder)
        if stat.S_ISLNK(st.st_mode):
            if owned:
                return "it is a link in a shared folder"
            if not os.path.exists(folder):
                return "it is a link to nothing"
            st = os.stat(folder)
        if not stat.S_ISDIR(st.st_mode):
            return "it is not a folder"
        if owned and hasattr(os, "getuid") and st.st_uid != os.getuid():
            return "another user owns it"
        fd, probe = tempfile.mkstemp(prefix=".cellgl-probe-", dir=folder)   # a new name: no
        os.close(fd)                                                          # FIFO waited on
        os.unlink(probe)
        return None
    except OSError as exc:
        return exc.strerror or type(exc).__name__


def _make(folder: Path, base: Path, owned: bool = False) -> str | None:
    """Make ``folder`` (under ``base``) level by level from ``base``, whose parent must exist."""
    chain = [base, *reversed([p for p in folder.parents if base in p.parents])]
    if folder != base:
        chain.append(folder)
    for level in chain:
        why = _folder(level, owned)
        if why:
            return f"{str(level)!r}: {why}"
    return None


def _places() -> list[tuple[Path, Path, bool]]:
    """(folder, the highest folder cellgl may make, owned) in the order tried."""
    named = os.environ.get(ENV_DIR)
    if named:
        folder = Path(named).expanduser()
        return [(folder, folder, False)]
    places = []
    try:
        import platformdirs     # a dependency; missing (a broken install): a note, not a failure

        base = Path(platformdirs.user_cache_dir())
        app = Path(platformdirs.user_cache_dir("cellgl", appauthor=False))
        places.append((app / "shaders", base, False))
    except ImportError:
        _note("the OS's cache folder skipped: platformdirs is not installed "
              "(pip install platformdirs)")
    except (RuntimeError, KeyError, OSError):            # no home folder at all
        pass
    user = os.getuid() if hasattr(os, "getuid") else os.environ.get("USERNAME", "user")
    tmp = Path(tempfile.gettempdir()) / f"cellgl-{user}"
    places.append((tmp / "shaders", tmp, True))
    return places


def cache_dir() -> Path | None:
    """cellgl's writable cache folder (made if missing, never its parents' parents), or None
    where none is usable (each place skipped is a note) or ``CELLGL_SHADER_CACHE=0``.

    Raises
    ------
    ValueError
        ``CELLGL_SHADER_CACHE`` is neither 0 nor 1.
    """
    _flag(ENV_SWITCH)
    if os.environ.get(ENV_SWITCH, "").strip() == "0":
        return None
    for folder, base, owned in _places():
        why = _make(folder, base, owned)
        if why is None:
            return folder
        _note(f"cache folder {str(folder)!r} skipped ({why})")
    return None


def _mesa_dir() -> Path | None:
    """The folder Mesa's disk cache writes to (Mesa's own rule), None when it has no home."""
    if os.environ.get("MESA_SHADER_CACHE_DIR"):
        return Path(os.environ["MESA_SHADER_CACHE_DIR"])
    if os.environ.get("XDG_CACHE_HOME"):
        return Path(os.environ["XDG_CACHE_HOME"]) / "mesa_shader_cache"
    home = os.environ.get("HOME")
    return Path(home) / ".cache" / "mesa_shader_cache" if home else None


def _mesa_cache_off() -> bool:
    return os.environ.get("MESA_SHADER_CACHE_DISABLE", "").strip().lower() in ("1", "true", "yes")


def _space(place: Path) -> str | None:
    free = _free(place)
    if free is not None and free < MIN_FREE:
        return f"{free >> 20} MiB free there, {MIN_FREE >> 20} MiB needed"
    return None


def _point_drivers(folder: Path, done: dict) -> None:
    """``CELLGL_DRIVER_SHADER_CACHE=1``: each driver's cache into ``folder``, where usable."""
    drivers = [("Mesa", "MESA_SHADER_CACHE_DIR", "mesa", {})]
    if os.environ.get("__GL_SHADER_DISK_CACHE", "").strip() != "0":
        drivers.append(("NVIDIA", "__GL_SHADER_DISK_CACHE_PATH", "nvidia",
                        {"__GL_SHADER_DISK_CACHE": "1"}))
    for name, var, sub, extra in drivers:
        if var in os.environ or (name == "Mesa" and _mesa_cache_off()):
            continue                                  # the user's own choice
        place = folder / sub
        why = _folder(place) or _space(place)
        if why:
            _note(f"{name}'s shader cache left at its default: {str(place)!r} skipped ({why})")
            continue
        for k, v in {var: str(place), **extra}.items():
            if k not in os.environ:
                os.environ[k] = done[k] = v


def prepare_environment() -> dict:
    """Before the first OpenGL context of the process (a driver reads its variables when it
    loads): switch Mesa's disk cache off where its folder's disk is (nearly) full, and with
    ``CELLGL_DRIVER_SHADER_CACHE=1`` point the drivers' caches into :func:`cache_dir`. Sets only
    what is unset; once per process; never raises for a place it cannot use (a note instead).
    Returns the variables it set (empty by default).

    Raises
    ------
    ValueError
        ``CELLGL_SHADER_CACHE`` or ``CELLGL_DRIVER_SHADER_CACHE`` is neither 0 nor 1.
    """
    if "set" in _prepared:
        return dict(_prepared["set"])
    settings()
    done: dict = {}
    if _flag(ENV_DRIVERS):
        folder = cache_dir()
        if folder is None:
            _note("CELLGL_DRIVER_SHADER_CACHE=1, but there is no usable cellgl cache folder: the "
                  "drivers' caches stay at their defaults")
        else:
            _point_drivers(folder, done)
    mesa = _mesa_dir()
    if mesa is not None and not _mesa_cache_off() and sys.platform not in ("win32", "darwin"):
        why = _space(mesa)
        if why:
            os.environ["MESA_SHADER_CACHE_DISABLE"] = done["MESA_SHADER_CACHE_DISABLE"] = "true"
            done.pop("MESA_SHADER_CACHE_DIR", None)
            _note(f"Mesa's shader disk cache switched off: {str(mesa)!r} has {why} (Mesa would "
                  "end the process with SIGBUS on a full disk); each process compiles again")
    _prepared["set"] = done
    return dict(done)


def summary() -> str:
    """One line for ``cellgl info``: cellgl's folder, what was set, what was skipped."""
    try:
        folder = cache_dir()
    except ValueError as exc:
        return str(exc)
    off = os.environ.get(ENV_SWITCH, "").strip() == "0"
    head = (f"records in {str(folder)!r}" if folder is not None
            else "no records (CELLGL_SHADER_CACHE=0)" if off
            else "no records (no usable cache folder)")
    done = _prepared.get("set") or {}
    drivers = (", ".join(f"{k}={v}" for k, v in done.items()) if done
               else "the drivers' own caches, as they are")
    return "; ".join([head, drivers, *notes()])
