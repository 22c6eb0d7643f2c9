"""Temporary files of cellgl's writers: named so a later run can tell its own stale ones, committed
all together or not at all, with their disk space reserved up front.

A temporary file lives next to its destination and is named
``.<stem>.cellgl-<pid>@<host>.<random>.<kind><ext>`` (``kind`` ``part`` for a file that becomes an
output, ``spool`` for scratch data; a folder ``.<stem>.cellgl-<pid>@<host>.<random>.frames`` holds
the frames of an animation until all are done, ``.<stem>.cellgl-<pid>@<host>.<random>.export`` a
MaterialX export's set of files until it is moved into place), never more than 255 bytes whatever the destination's name (the
stem is shortened). A process killed mid-write (SIGKILL, a power cut) cannot delete its own; the
next write into that directory on the same host removes those whose process is gone
(:func:`sweep_stale`). SIGTERM and SIGHUP are turned into an exception by the command line, so they
clean up like Ctrl-C does.
"""

from __future__ import annotations

import contextlib
import errno
import os
import re
import secrets
import shutil
import socket
from collections.abc import Iterator, Sequence
from pathlib import Path

__all__ = ["atomic_paths", "commit_lock", "scratch_path", "scratch_dir", "sweep_stale", "reserve", "temp_name", "human_size",
           "check_output", "check_output_dir", "default_mode", "naming_destination_in", "NAME_MAX",
           "lock_wait", "lock_holder", "LOCK_WAIT_ENV"]

NAME_MAX = 255  #: bytes in one file name on every common filesystem
_EXT_MAX = 32   #: longest extension kept on a temporary name
_HOST = re.sub(r"[^A-Za-z0-9-]", "-", socket.gethostname())[:40] or "host"
_TEMP = re.compile(r"^\..*\.cellgl-(\d+)@([A-Za-z0-9-]*)\.[0-9a-f]{8}\.(?:(?:part|spool)(?:\..*)?|frames|export)$")


def human_size(n: int) -> str:
    """``n`` bytes as ``"512 B"``, ``"4.0 MiB"``, ``"3.2 GiB"`` (never "0.0 GiB")."""
    size = float(n)
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if size < 1024 or unit == "TiB":
            return f"{int(size)} B" if unit == "B" else f"{size:.1f} {unit}"
        size /= 1024
    raise AssertionError


def _shorten(text: str, limit: int) -> str:
    """``text`` cut to at most ``limit`` bytes of UTF-8 (on a character boundary)."""
    raw = os.fsencode(text)
    if len(raw) <= limit:
        return text
    return raw[:max(0, limit)].decode("utf-8", "ignore") if limit > 0 else ""


def temp_name(dest: str | os.PathLike, kind: str = "part", ext: str | None = None) -> str:
    """A fresh temporary file name for ``dest`` (see the module doc), at most 255 bytes."""
    dest = Path(dest)
    ext = dest.suffix if ext is None else ext
    ext = ext if len(os.fsencode(ext)) <= _EXT_MAX else ""
    tag = f".cellgl-{os.getpid()}@{_HOST}.{secrets.token_hex(4)}.{kind}{ext}"
    stem = _shorten(dest.stem, NAME_MAX - 1 - len(os.fsencode(tag)))
    return f".{stem}{tag}"


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True  # someone else's process
    return True


def sweep_stale(directory: str | os.PathLike) -> list[Path]:
    """Remove cellgl's temporary files in ``directory`` left by processes of this host that no
    longer run (a bake killed with SIGKILL); returns the paths removed. Never raises."""
    removed: list[Path] = []
    try:
        entries = list(os.scandir(os.fspath(directory)))
    except OSError:
        return removed
    for entry in entries:
        m = _TEMP.match(entry.name) if entry.name.startswith(".") else None
        if not m or m.group(2) != _HOST or int(m.group(1)) == os.getpid():
            continue
        if not _alive(int(m.group(1))):
            with contextlib.suppress(OSError):
                if entry.is_dir(follow_symlinks=False):
                    shutil.rmtree(entry.path)
                else:
                    os.unlink(entry.path)
                removed.append(Path(entry.path))
    return removed


def _create(directory: Path, dest: Path, kind: str, ext: str | None = None) -> Path:
    for _ in range(100):
        tmp = directory / temp_name(dest, kind, ext)
        try:
            os.close(os.open(tmp, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o600))
        except FileExistsError:
            continue
        except OSError as exc:  # name the destination, not the temporary file
            raise OSError(exc.errno, f"cannot create a file there: {exc.strerror}",
                          str(dest)) from None
        return tmp
    raise FileExistsError(errno.EEXIST, "no free temporary name", str(directory))


def default_mode(base: int = 0o666) -> int:
    """``base`` less the process's umask: the mode a new file (0o666) or folder (0o777) gets."""
    umask = os.umask(0)
    os.umask(umask)
    return base & ~umask


#: how long a commit waits for another process's lock on its output folder, in seconds:
#: ``$CELLGL_LOCK_WAIT``, 0..86400, default 60 (cellgl holds it for milliseconds, the renames)
LOCK_WAIT_ENV, LOCK_WAIT = "CELLGL_LOCK_WAIT", 60.0
#: how often a waiting commit tries the lock again, in seconds
_LOCK_POLL = 0.05


def env_seconds(name: str, default: float, top: float, what: str) -> float:
    """``$name`` as seconds in 0..``top`` (unset or empty: ``default``); ValueError naming the
    value, the accepted range, ``what`` it sets and the default otherwise (NaN and inf fail)."""
    import math

    text = os.environ.get(name, "").strip()
    if not text:
        return default
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not 0.0 <= value <= top:                         # NaN fails too
        raise ValueError(f"{name}={text!r}: accepted seconds in 0..{top:g} ({what}; default {default:g})")
    return value


def lock_wait() -> float:
    """``$CELLGL_LOCK_WAIT`` checked (seconds in 0..86400; unset or empty: :data:`LOCK_WAIT`);
    ValueError naming the value otherwise. :func:`check_output` asks it before a command's work."""
    return env_seconds(LOCK_WAIT_ENV, LOCK_WAIT, 86400.0,
                       "how long a write waits for another process's lock on its output folder")


def lock_holder(fd: int) -> str:
    """Who holds a ``flock`` on the file open as ``fd``: ``"process 1234 (flock)"`` from Linux's
    ``/proc/locks`` (read at most 1 MiB) and ``/proc/<pid>/comm``; ``"another process"`` where
    that is not known (another OS, another PID namespace)."""
    try:
        st = os.fstat(fd)
        key = f"{os.major(st.st_dev):02x}:{os.minor(st.st_dev):02x}:{st.st_ino}"
        with open("/proc/locks", "rb") as f:
            text = f.read(1 << 20).decode("ascii", "replace")
    except (OSError, ValueError, AttributeError):
        return "another process"
    for line in text.splitlines():
        fields = line.split()
        if len(fields) >= 6 and fields[1] == "FLOCK" and fields[5] == key and fields[4].isdigit():
            pid = int(fields[4])
            if pid <= 0 or pid == os.getpid():
                break
            try:
                with open(f"/proc/{pid}/comm", "rb") as f:
                    comm = f.read(64).decode("utf-8", "replace").strip()
            except OSError:
                comm = ""
            comm = "".join(c for c in comm if c.isprintable())
            return f"process {pid}" + (f" ({comm})" if comm else "")
    return "another process"


def _lock(fd: int, directory: str, fcntl) -> None:
    """``flock(fd, LOCK_EX)``, waiting at most :func:`lock_wait` seconds for another holder (said
    once, as a warning naming it); TimeoutError naming the folder and the holder after that."""
    import time
    import warnings

    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        return
    except BlockingIOError:
        pass
    except OSError:                                 # a filesystem without locks
        return
    wait = lock_wait()
    who = lock_holder(fd)
    warnings.warn(f"waiting for the lock on folder {directory!r}, held by {who}; giving up after "
                  f"{wait:g} s (${LOCK_WAIT_ENV})", UserWarning, stacklevel=4)
    deadline = time.monotonic() + wait
    while True:
        time.sleep(min(_LOCK_POLL, max(0.0, deadline - time.monotonic())))
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return
        except BlockingIOError:
            if time.monotonic() >= deadline:
                break
        except OSError:
            return
    raise TimeoutError(errno.ETIMEDOUT, f"{lock_holder(fd)} has held the lock on this folder for "
                       f"{wait:g} s, so nothing was written; run again when it is done, or set "
                       f"{LOCK_WAIT_ENV}=SECONDS (0..86400) to wait longer", directory)


@contextlib.contextmanager
def commit_lock(directories) -> Iterator[None]:
    """Hold an exclusive lock on each of ``directories`` (``flock`` on the directory itself: no
    lock file is left behind) while the block runs: two writers that commit sets of files into
    the same folder (``<stem>_color.png``, ``<stem>_F1.png``, ...) rename one whole set after the
    other, never interleaved, so the last writer's set is the one that stays, complete. Held
    only for the renames (milliseconds). While another process holds it (another cellgl's
    commit, or anything that ``flock``s the folder) a ``UserWarning`` says that it waits and for
    whom; after ``$CELLGL_LOCK_WAIT`` seconds (default 60) it gives up with TimeoutError naming
    the folder and the holder. Where the platform or the filesystem has no ``flock`` (Windows)
    the block runs unlocked."""
    try:
        import fcntl
    except ImportError:         # pragma: no cover - Windows
        yield
        return
    fds = []
    try:
        for d in sorted({os.path.abspath(str(d) or ".") for d in directories}):
            try:
                fd = os.open(d, os.O_RDONLY)
            except OSError:
                continue
            fds.append(fd)
            _lock(fd, d, fcntl)
        yield
    finally:
        for fd in fds:
            os.close(fd)        # releases the lock


@contextlib.contextmanager
def atomic_paths(paths: Sequence[str | os.PathLike], ext: str | None = None) -> Iterator[list[Path]]:
    """Yield one temporary path beside each destination; on success move them all onto their
    destinations, on any exception (``KeyboardInterrupt`` and the CLI's SIGTERM/SIGHUP
    included) delete them all and leave every destination as it was.

    Every file is complete and flushed to disk before the first rename, so the destinations
    change together (a crash between two renames, a narrow window, is the only way to see some
    new and some old). Stale temporary files of dead processes in those directories are
    removed first (:func:`sweep_stale`). ``ext``: the temporary names' extension (default: each
    destination's, so libraries that look at it see the right one).
    """
    dests = [Path(p) for p in paths]
    for d in {p.parent for p in dests}:
        sweep_stale(d if str(d) else ".")
    tmps: list[Path] = []
    try:
        for d in dests:
            tmps.append(_create(d.parent, d, "part", ext))
        yield list(tmps)
        for t in tmps:
            with open(t, "rb+") as f:
                os.fsync(f.fileno())
            os.chmod(t, default_mode())
        with commit_lock(d.parent for d in dests):
            for t, d in zip(tmps, dests):
                os.replace(t, d)
    except BaseException as exc:
        for t in tmps:
            with contextlib.suppress(OSError):
                t.unlink()
        named = _naming_destination(exc, tmps, dests) if isinstance(exc, OSError) else None
        if named is not None:
            raise named from None
        raise


def _naming_destination(exc: OSError, tmps: Sequence[Path], dests: Sequence[Path]) -> OSError | None:
    """``exc`` (a write that failed: a full disk, a file size limit) naming the output the user
    gave instead of its hidden temporary file, and naming it at all where the library said no
    file (a bare ``write``); None where there is nothing to change."""
    text, name = exc.strerror or str(exc), exc.filename
    for t, d in zip(tmps, dests):
        if name is not None and os.fspath(name) in (str(t), t.name):
            name = str(d)
        for form in (str(t), t.name):
            text = text.replace(form, str(d))
    if name is None and len(dests) == 1:
        name = str(dests[0])
    if name == exc.filename and text == (exc.strerror or str(exc)):
        return None
    return OSError(exc.errno, text, name)


def naming_destination_in(exc: BaseException, tmp: Path, dest: Path) -> BaseException:
    """``exc`` (raised while writing into the hidden folder ``tmp``, which becomes or fills
    ``dest``) with every mention of ``tmp`` replaced by ``dest``: the error names the output
    the user gave, never the temporary folder."""
    def fix(text):
        if text is None:
            return None
        text = str(text)
        text = text.replace(str(tmp) + os.sep, "" if str(dest) == "." else str(dest) + os.sep)
        return text.replace(str(tmp), str(dest))

    if isinstance(exc, OSError):
        return OSError(exc.errno, fix(exc.strerror or str(exc)), fix(exc.filename))
    return type(exc)(fix(str(exc)))


@contextlib.contextmanager
def scratch_path(directory: str | os.PathLike, suffix: str = "") -> Iterator[Path]:
    """Yield a fresh hidden temporary file in ``directory``; it is deleted on leaving, always."""
    directory = Path(directory)
    tmp = _create(directory, directory / "scratch", "spool", suffix)
    try:
        yield tmp
    finally:
        with contextlib.suppress(OSError):
            os.unlink(tmp)


@contextlib.contextmanager
def scratch_dir(dest: str | os.PathLike, kind: str = "frames") -> Iterator[Path]:
    """Yield a fresh hidden folder beside ``dest`` (named as the module doc says, so that a later
    run sweeps it if this process is killed); it is deleted with its contents on leaving,
    always. Stale temporary files and folders of dead processes there are removed first."""
    dest = Path(dest)
    parent = dest.parent if str(dest.parent) else Path(".")
    sweep_stale(parent)
    for _ in range(100):
        tmp = parent / temp_name(dest, kind, "")
        try:
            os.mkdir(tmp, 0o700)
        except FileExistsError:
            continue
        except OSError as exc:
            raise OSError(exc.errno, f"cannot create a folder there: {exc.strerror}",
                          str(dest)) from None
        break
    else:
        raise FileExistsError(errno.EEXIST, "no free temporary name", str(parent))
    try:
        yield tmp
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def reserve(path: str | os.PathLike, nbytes: int) -> None:
    """Give ``path`` (an existing file) ``nbytes`` of real disk blocks now, so that writing
    through a memory map later cannot hit a full disk (SIGBUS, no message).

    Raises
    ------
    OSError
        ``ENOSPC``: the message names the file, the space needed and the space free.
    """
    if not hasattr(os, "posix_fallocate") or nbytes <= 0:
        return
    fd = os.open(path, os.O_RDWR)
    try:
        os.posix_fallocate(fd, 0, int(nbytes))
    except OSError as exc:
        if exc.errno in (errno.EOPNOTSUPP, errno.EINVAL, errno.ENOSYS):
            return  # the filesystem cannot reserve: the memory map writes as before
        if exc.errno in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG):
            try:
                free = f", {human_size(shutil.disk_usage(Path(path).parent).free)} free"
            except OSError:
                free = ""
            raise OSError(exc.errno, f"{os.strerror(exc.errno)} (the file needs "
                                     f"{human_size(nbytes)}{free})", str(path)) from None
        raise
    finally:
        os.close(fd)


def _folder_problem(folder: Path) -> str | None:
    """Why ``folder`` cannot receive a new file (None: it can): it or one of its parents is a
    file, it does not exist, or it is not writable."""
    for above in (folder, *folder.parents):
        if above.exists() or above.is_symlink():
            if not above.is_dir():
                return f"{str(above)!r} is a file, not a directory"
            break
    if not folder.is_dir():
        return f"output directory {str(folder)!r} does not exist (it is not created; make it first)"
    if not os.access(folder, os.W_OK):
        return f"output directory {str(folder)!r} is not writable"
    return None


def _not_empty(path, what: str) -> None:
    """An empty output name (``-o ''``) is refused, never read as the current folder."""
    if not os.fspath(path):
        raise ValueError(f"output '' is an empty name; give {what}")


def check_output(path: str | os.PathLike) -> Path:
    """``path`` as a destination a writer can create, else ValueError saying why (directory
    missing, a file where a directory should be, not writable, a directory given, a name
    longer than 255 bytes). Every command checks its output with this (or
    :func:`check_output_dir`) before its work starts: a missing folder is never created."""
    _not_empty(path, "a file name")
    path = Path(os.fspath(path))
    parent = path.parent if str(path.parent) else Path(".")
    lock_wait()                 # a bad $CELLGL_LOCK_WAIT is refused before the work, not after
    if len(os.fsencode(path.name)) > NAME_MAX:
        raise ValueError(f"output file name {path.name[:40]!r}... is {len(os.fsencode(path.name))} "
                         f"bytes long; accepted at most {NAME_MAX}")
    if path.is_dir():
        raise ValueError(f"output {str(path)!r} is a directory; give a file name")
    why = _folder_problem(parent)
    if why:
        raise ValueError(f"output {str(path)!r}: {why}")
    return path


def check_output_dir(path: str | os.PathLike) -> Path:
    """``path`` as an output directory a command may fill: an existing directory, or a new one
    (created by the command) in an existing, writable directory; ValueError otherwise."""
    _not_empty(path, "a directory name")
    path = Path(os.fspath(path))
    lock_wait()
    if path.is_dir():
        why = None if os.access(path, os.W_OK) else f"output directory {str(path)!r} is not writable"
    elif path.exists() or path.is_symlink():
        why = f"{str(path)!r} exists and is not a directory"
    else:
        if len(os.fsencode(path.name)) > NAME_MAX:
            raise ValueError(f"output directory name {path.name[:40]!r}... is "
                             f"{len(os.fsencode(path.name))} bytes long; accepted at most {NAME_MAX}")
        why = _folder_problem(path.parent if str(path.parent) else Path("."))
    if why:
        raise ValueError(f"output {str(path)!r}: {why}")
    return path
