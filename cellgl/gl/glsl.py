"""Shader text: load files from ``shaders/``, resolve ``#include``, add ``#define``s.

Pure text, no OpenGL. A :class:`Source` keeps a line map so that a driver error such as
``0:123(45): error: ...`` can be reported as ``lib/cellular.glsl:45(45): error: ...``
(see :func:`map_error`).

Rules
-----
- ``#include "path"`` is relative to the directory of the including file.
- Each file is included at most once per :class:`Source`; later includes emit nothing, so an
  include cycle is harmless. A file holding the line ``#pragma cellgl include_each_time`` is the
  exception: a template (e.g. ``lib/ring_loop.glsl``, the ring loop of every walker, whose names
  its includer sets with ``#define`` before each ``#include``), its text emitted at every
  ``#include``. The marker line itself is not emitted (neither a driver nor the snippet
  exporter sees it); such a file including itself, directly or not, is an error.
- Each included file is wrapped in ``// begin <relpath>`` / ``// end <relpath>`` lines.
- Included (library) files must not contain ``#version``.
- ``#define KEY VALUE`` lines go immediately after the ``#version`` line of the entry file, or
  at the top when it has none.
- An entry file with a ``#version`` line whose resolved text uses ``CELL_PRECISE`` gets
  :data:`PRELUDE` right after that line (before the defines): it defines ``CELL_PRECISE`` as ``precise`` where the compiler has that qualifier
  (GLSL 4.00 and up, or ``GL_ARB_gpu_shader5``, which it then enables) and as nothing elsewhere.
  The shaders put ``CELL_PRECISE`` on the arithmetic whose rounding decides an answer
  (docs/exactness.md, "What the driver may round").
"""

from __future__ import annotations

import math
import numbers
import posixpath
import re
from collections.abc import Mapping
from pathlib import Path

__all__ = [
    "ShaderError",
    "Source",
    "shader_dir",
    "load",
    "resolve_library",
    "format_define",
    "lower_version",
    "map_error",
]

#: Pseudo file name used in the line map for generated ``#define`` lines.
DEFINES_FILE = "<defines>"
#: Pseudo file name used in the line map for the lines of :data:`PRELUDE`.
PRELUDE_FILE = "<prelude>"

#: Placed after the ``#version`` line of every entry shader. ``precise`` (GLSL 4.00, or
#: GL_ARB_gpu_shader5 in a 3.30 compiler that has it) makes the operations that compute a
#: variable happen in the order written, each rounded once, with the same precision everywhere
#: it appears: no fused multiply-add the source does not ask for, no reassociation. Without it
#: two compilations of the same code (a compute and a fragment entry, two walker variants) may
#: round differently. The macro is empty where no such qualifier exists (and in exported
#: snippets: cellgl/export/snippets.py), so the code is valid in every GLSL from 3.30.
PRELUDE = (
    "#if __VERSION__ < 400 && defined(GL_ARB_gpu_shader5)",
    "#extension GL_ARB_gpu_shader5 : enable",
    "#endif",
    "#if __VERSION__ >= 400 || defined(GL_ARB_gpu_shader5)",
    "#define CELL_PRECISE precise",
    "#else",
    "#define CELL_PRECISE",
    "#endif",
)

_INCLUDE_RE = re.compile(r'^\s*#\s*include\s+(?:"([^"]*)"|<([^>]*)>)\s*(?://.*)?$')
_INCLUDE_LOOSE_RE = re.compile(r"^\s*#\s*include\b")
_VERSION_RE = re.compile(r"^\s*#\s*version\b")
_EACH_TIME_RE = re.compile(r"^\s*#\s*pragma\s+cellgl\s+include_each_time\s*(?://.*)?$", re.M)
_IDENT_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_PRECISE_RE = re.compile(r"\bCELL_PRECISE\b")


class ShaderError(RuntimeError):
    """A shader could not be loaded, resolved or compiled."""

    #: the resolved sources that failed to compile (set where compiling failed)
    sources: list[Source]


class Source:
    """Resolved shader text with a map back to the original files.

    Attributes
    ----------
    text : str
        The resolved text, ending in a newline.
    line_map : list of (str, int)
        ``line_map[k - 1]`` is ``(file, line)`` for output line ``k`` (1-based): the file
        relative to the shader root (posix separators) and the 1-based line in that file.
        Generated ``#define`` lines map to ``("<defines>", i)``; begin/end marker lines map
        to the ``#include`` line that produced them.
    files : list of str
        Every file that contributed text, in order of first inclusion (entry file first).
    """

    __slots__ = ("text", "line_map", "files")

    def __init__(self, text: str, line_map: list[tuple[str, int]], files: list[str]):
        self.text = text
        self.line_map = line_map
        self.files = files

    def __repr__(self) -> str:
        return f"Source(files={self.files!r}, lines={len(self.line_map)})"

    def origin(self, line: int) -> tuple[str, int] | None:
        """Return ``(file, line)`` for 1-based output ``line``, or None if out of range."""
        if 1 <= line <= len(self.line_map):
            return self.line_map[line - 1]
        return None


def shader_dir() -> Path:
    """Return the directory holding the shader files.

    In an installed wheel the shaders are the package ``cellgl.shaders`` (next to this file);
    in a source checkout they are the repository's top-level ``shaders/``.
    """
    package = Path(__file__).resolve().parent.parent   # cellgl/
    installed = package / "shaders"
    if installed.is_dir():
        return installed
    return package.parent / "shaders"


def format_define(key: str, value: object) -> str:
    """Return the ``#define`` line for ``key`` and ``value``.

    bool -> ``1``/``0``; integers -> decimal; floats -> ``repr`` (round-trips float64);
    str -> as is; None -> no value.
    """
    if not isinstance(key, str) or not _IDENT_RE.match(key):
        raise ValueError(f"invalid #define name {key!r}: expected a C identifier")
    if value is None:
        return f"#define {key}"
    if isinstance(value, bool) or getattr(getattr(value, "dtype", None), "kind", "") == "b":
        text = "1" if value else "0"
    elif isinstance(value, numbers.Integral):
        text = str(int(value))
    elif isinstance(value, numbers.Real):
        f = float(value)
        if not math.isfinite(f):
            raise ValueError(f"#define {key}: value {value!r} is not finite")
        text = repr(f)
    elif isinstance(value, str):
        if "\n" in value:
            raise ValueError(f"#define {key}: value must be a single line, got {value!r}")
        text = value
    else:
        raise ValueError(
            f"#define {key}: unsupported value {value!r} of type {type(value).__name__}; "
            "expected bool, int, float, str or None"
        )
    return f"#define {key} {text}".rstrip()


class _Resolver:
    def __init__(self, root: Path, files: Mapping[str, str] | None = None):
        self.root = root
        self.virtual = dict(files or {})
        self.seen: set[str] = set()
        self.open: list[str] = []          # the files being included, outermost first
        self.files: list[str] = []
        self.lines: list[str] = []
        self.line_map: list[tuple[str, int]] = []

    def _read(self, rel: str, where: str | None) -> str:
        if rel in self.virtual:
            return self.virtual[rel]
        path = self.root / rel
        try:
            return path.read_text(encoding="utf-8")
        except FileNotFoundError:
            raise ShaderError(
                f"{where}: included file {rel!r} not found (looked for {path})"
                if where
                else f"shader file {rel!r} not found in {self.root}"
            ) from None
        except OSError as exc:
            raise ShaderError(f"cannot read shader file {path}: {exc}") from exc

    def add(self, rel: str, *, is_library: bool, where: str | None, at: tuple[str, int] | None,
            markers: bool) -> None:
        rel = posixpath.normpath(rel)
        if rel in self.seen:
            return
        text = self._read(rel, where)
        each_time = _EACH_TIME_RE.search(text) is not None
        if each_time and rel in self.open:
            raise ShaderError(f"{where}: {rel!r} (#pragma cellgl include_each_time) includes itself")
        if not each_time:
            self.seen.add(rel)
        if rel not in self.files:
            self.files.append(rel)
        self.open.append(rel)
        mark_at = at if at is not None else (rel, 0)
        if markers:
            self.lines.append(f"// begin {rel}")
            self.line_map.append(mark_at)
        for num, line in enumerate(text.splitlines(), start=1):
            m = _INCLUDE_RE.match(line)
            if m:
                target = m.group(1) if m.group(1) is not None else m.group(2)
                if not target:
                    raise ShaderError(f"{rel}:{num}: empty #include path")
                child = posixpath.normpath(posixpath.join(posixpath.dirname(rel), target))
                if child.startswith("../") or child == "..":
                    raise ShaderError(
                        f"{rel}:{num}: #include {target!r} points outside the shader directory"
                    )
                self.add(child, is_library=True, where=f"{rel}:{num}", at=(rel, num), markers=True)
                continue
            if _INCLUDE_LOOSE_RE.match(line):
                raise ShaderError(f'{rel}:{num}: malformed #include, expected #include "path"')
            if each_time and _EACH_TIME_RE.match(line):
                continue
            if is_library and _VERSION_RE.match(line):
                raise ShaderError(
                    f"{rel}:{num}: library files must not contain #version "
                    "(only entry shaders declare it)"
                )
            self.lines.append(line)
            self.line_map.append((rel, num))
        if markers:
            self.lines.append(f"// end {rel}")
            self.line_map.append(mark_at)
        self.open.pop()

    def source(self) -> Source:
        return Source("\n".join(self.lines) + "\n", self.line_map, self.files)


def _root(root: str | Path | None) -> Path:
    return Path(root) if root is not None else shader_dir()


def load(name: str, defines: Mapping[str, object] | None = None, *,
         root: str | Path | None = None, files: Mapping[str, str] | None = None) -> Source:
    """Load entry shader ``name`` (relative to ``root``, default :func:`shader_dir`).

    Parameters
    ----------
    name : str
        Path relative to the shader root, e.g. ``"cellular.comp"``.
    defines : mapping of str to bool, int, float, str or None, optional
        Emitted as ``#define`` lines right after ``#version`` and :data:`PRELUDE` (see
        :func:`format_define`).
    root : path, optional
        Shader root directory; defaults to :func:`shader_dir`.
    files : mapping of str to str, optional
        Generated files: ``{relative path: text}`` read instead of (or in the absence of) the
        file of that path under the root (e.g. a recipe's values as constants).

    Returns
    -------
    Source

    Raises
    ------
    ShaderError
        Missing file or include, a ``#version`` in an included file, a malformed include.
    """
    resolver = _Resolver(_root(root), files)
    resolver.add(name, is_library=False, where=None, at=None, markers=False)
    src = resolver.source()
    lines = src.text.splitlines()
    version_at = next((i for i, line in enumerate(lines) if _VERSION_RE.match(line)), None)
    insert_at = 0 if version_at is None else version_at + 1
    uses = version_at is not None and _PRECISE_RE.search(src.text) is not None
    added = [(line, (PRELUDE_FILE, i + 1)) for i, line in enumerate(PRELUDE)] if uses else []
    added += [(format_define(k, v), (DEFINES_FILE, i + 1)) for i, (k, v) in enumerate((defines or {}).items())]
    if added:
        lines[insert_at:insert_at] = [text for text, _ in added]
        line_map = list(src.line_map)
        line_map[insert_at:insert_at] = [where for _, where in added]
        src = Source("\n".join(lines) + "\n", line_map, src.files)
    return src


def lower_version(src: Source, version: int) -> Source:
    """``src`` with its ``#version N`` line (the first) set to ``version`` where N is higher
    (a program compiled for the context's GLSL: ``__VERSION__`` tells the shader which)."""
    head, _, rest = src.text.partition("\n")
    parts = head.split()
    if parts[:1] == ["#version"] and len(parts) > 1 and parts[1].isdigit() and int(parts[1]) > version:
        src = Source(f"#version {version}\n{rest}", src.line_map, src.files)
    return src


def resolve_library(paths: list[str], *, root: str | Path | None = None) -> Source:
    """Concatenate and resolve library files (no ``#version`` anywhere).

    Each file in ``paths`` (relative to the shader root) and everything it includes appears once,
    wrapped in begin/end markers. Used by the snippet exporter.
    """
    if isinstance(paths, (str, bytes)):
        raise TypeError("resolve_library expects a list of paths, not a single string")
    resolver = _Resolver(_root(root))
    for rel in paths:
        resolver.add(rel, is_library=True, where=None, at=None, markers=True)
    return resolver.source()


# Mesa:     0:123(45): error: ...           glslang/AMD: ERROR: 0:123: ...
_COLON_RE = re.compile(
    r"^(?P<pre>[ \t]*(?:(?:ERROR|WARNING|INFO|error|warning):[ \t]*)?)"
    r"(?P<str>\d+):(?P<line>\d+)(?P<col>\(\d+\))?(?=:)",
    re.MULTILINE,
)
# NVIDIA:   0(123) : error C1008: ...
_PAREN_RE = re.compile(r"^(?P<pre>[ \t]*)(?P<str>\d+)\((?P<line>\d+)\)(?=[ \t]*:)", re.MULTILINE)


def map_error(message: str, source: Source) -> str:
    """Rewrite driver line references in ``message`` to ``file:line`` using ``source``.

    Handles Mesa (``0:123(45): error: ...``), NVIDIA (``0(123) : error C1008: ...``) and
    glslang/AMD (``ERROR: 0:123: ...``). References to lines outside ``source`` are left alone.
    """

    def where(m: re.Match) -> str | None:
        origin = source.origin(int(m.group("line")))
        if origin is None:
            return None
        return f"{origin[0]}:{origin[1]}"

    def sub_colon(m: re.Match) -> str:
        loc = where(m)
        if loc is None:
            return m.group(0)
        return f"{m.group('pre')}{loc}{m.group('col') or ''}"

    def sub_paren(m: re.Match) -> str:
        loc = where(m)
        if loc is None:
            return m.group(0)
        return f"{m.group('pre')}{loc}"

    message = _COLON_RE.sub(sub_colon, message)
    return _PAREN_RE.sub(sub_paren, message)
