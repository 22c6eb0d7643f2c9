"""A shader variant compiled once per driver, not once per process: the drivers' own disk caches,
pointed at a writable per-user cellgl folder before the first context is made.

cellgl compiles a program per variant (the macros of a call: dimension, metric, distribution,
outputs, ...). The first call of a variant in a process pays the driver's compiler (0.3-0.9 s on
NVIDIA's, 0.1-1 s on llvmpipe's). Every common driver keeps compiled programs on disk, keyed by the
driver's own build and the program's source, and checks each entry when it reads it:

* Mesa (llvmpipe, radeonsi, iris, ...): ``MESA_SHADER_CACHE_DIR`` (default
  ``$XDG_CACHE_HOME/mesa_shader_cache``), off with ``MESA_SHADER_CACHE_DISABLE=true``; entries are
  keyed by the driver's build id and the shader's SHA-1 and carry a CRC, so a driver update or a
  damaged file is a miss, never a wrong program.
* NVIDIA: ``__GL_SHADER_DISK_CACHE`` (1: on), ``__GL_SHADER_DISK_CACHE_PATH`` (default
  ``~/.nv/GLCache``), ``__GL_SHADER_DISK_CACHE_SKIP_CLEANUP``; keyed by driver version and source.

Those defaults fail quietly where the home folder is not writable (containers, CI runners, batch
nodes: then every process compiles again). :func:`prepare_environment` points both at
``$CELLGL_SHADER_CACHE_DIR`` (default ``$XDG_CACHE_HOME/cellgl/shaders``, else
``~/.cache/cellgl/shaders``, else a folder of this user under the temporary directory) where that
folder is writable, and only where the user has not set the driver's variable already.
``CELLGL_SHADER_CACHE=0`` leaves the environment as it is (the drivers' own defaults).

Why not program binaries (``glGetProgramBinary``/``glProgramBinary``) kept by cellgl: moderngl 5
creates and introspects its programs from source only (``Context.program``; no way to hand it a
linked GL program), so a binary would skip the compile but not give a moderngl program. The
drivers' caches give the same effect, with the drivers' own keys and checks.
"""
from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

__all__ = ["cache_dir", "prepare_environment"]

ENV_SWITCH = "CELLGL_SHADER_CACHE"        #: "0": leave the drivers' caches as they are
ENV_DIR = "CELLGL_SHADER_CACHE_DIR"       #: where the caches go (default: see cache_dir)

_prepared: dict = {}


def _writable(folder: Path) -> bool:
    try:
        folder.mkdir(parents=True, exist_ok=True)
        probe = folder / f".cellgl-probe-{os.getpid()}"
        probe.write_bytes(b"")
        probe.unlink()
        return True
    except OSError:
        return False


def cache_dir() -> Path | None:
    """The writable folder the drivers' caches go to (made if missing), or None where none is
    writable (or ``CELLGL_SHADER_CACHE=0``)."""
    if os.environ.get(ENV_SWITCH, "1") == "0":
        return None
    named = os.environ.get(ENV_DIR)
    if named:
        folder = Path(named).expanduser()
        return folder if _writable(folder) else None
    places = []
    if os.environ.get("XDG_CACHE_HOME"):
        places.append(Path(os.environ["XDG_CACHE_HOME"]) / "cellgl" / "shaders")
    if sys.platform == "win32" and os.environ.get("LOCALAPPDATA"):
        places.append(Path(os.environ["LOCALAPPDATA"]) / "cellgl" / "shaders")
    try:
        places.append(Path.home() / ".cache" / "cellgl" / "shaders")
    except RuntimeError:            # no home folder
        pass
    uid = os.getuid() if hasattr(os, "getuid") else os.environ.get("USERNAME", "user")
    places.append(Path(tempfile.gettempdir()) / f"cellgl-{uid}" / "shaders")
    for folder in places:
        if _writable(folder):
            return folder
    return None


def prepare_environment() -> dict:
    """Point the drivers' shader disk caches at :func:`cache_dir` (call before the first OpenGL
    context of the process: a driver reads its variables when it loads). Sets only what is unset;
    once per process. Returns the variables it set (empty where it set none)."""
    if "set" in _prepared:
        return dict(_prepared["set"])
    folder = cache_dir()
    done = {}
    if folder is not None:
        want = {
            # Mesa: its own subfolder (it adds a folder per cache version itself)
            "MESA_SHADER_CACHE_DIR": str(folder / "mesa"),
            # NVIDIA: on, here, and not trimmed by the driver behind cellgl's back
            "__GL_SHADER_DISK_CACHE": "1",
            "__GL_SHADER_DISK_CACHE_PATH": str(folder / "nvidia"),
            "__GL_SHADER_DISK_CACHE_SKIP_CLEANUP": "1",
        }
        if os.environ.get("__GL_SHADER_DISK_CACHE") == "0":
            # the user turned NVIDIA's cache off: leave every NVIDIA variable alone
            want = {k: v for k, v in want.items() if not k.startswith("__GL_")}
        if os.environ.get("MESA_SHADER_CACHE_DISABLE", "").lower() in ("1", "true", "yes"):
            want.pop("MESA_SHADER_CACHE_DIR")
        for name, value in want.items():
            if name not in os.environ:
                if name.endswith("_PATH") or name.endswith("_DIR"):
                    Path(value).mkdir(parents=True, exist_ok=True)
                os.environ[name] = value
                done[name] = value
    _prepared["set"] = done
    return dict(done)
