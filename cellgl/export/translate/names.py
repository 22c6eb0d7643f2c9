"""Step 2 of a snippet: :func:`prefix_names` gives every top-level name the ``cellgl_`` prefix."""
from __future__ import annotations

import re
from collections.abc import Mapping

from cellgl.export.translate.tokens import TranslateError, split_tokens


def top_level_names(text: str) -> dict[str, str]:
    """Names declared at file scope: ``{name: 'function' | 'struct' | 'variable'}``."""
    names: dict[str, str] = {}
    depth, stmt = 0, []
    for kind, t in split_tokens(text):
        if kind in ("ws", "comment"):
            continue
        if depth == 0 and t in ("{", ";"):
            _decl(stmt, names)
            stmt = []
        elif depth == 0 and t != "}":
            stmt.append(t)
        depth += (t == "{") - (t == "}")
    return names


_QUALIFIERS = {"const", "uniform", "highp", "mediump", "lowp", "in", "out", "inout", "flat",
               "precise", "invariant"}


def _decl(stmt: list[str], names: dict[str, str]) -> None:
    s = [t for t in stmt if t not in _QUALIFIERS]
    if len(s) < 2:
        return
    if s[0] == "struct":
        names[s[1]] = "struct"
    elif len(s) >= 3 and s[2] == "(":
        names[s[1]] = "function"        # a definition or a prototype
    elif re.fullmatch(r"[A-Za-z_]\w*", s[1]):
        # variable(s): TYPE NAME [= ...] [, NAME ...]; TYPE NAME[N] = ...
        names[s[1]] = "variable"
        depth = 0
        for i, t in enumerate(s[2:], start=2):
            if t in "([":
                depth += 1
            elif t in ")]":
                depth -= 1
            elif t == "," and depth == 0 and i + 1 < len(s):
                names[s[i + 1]] = "variable"


def prefixed(name: str, kind: str) -> str:
    """The exported spelling of a library name.

    ``cell_x`` -> ``cellgl_x``; private ``_cell_x`` -> ``cellgl_x_``; struct ``CellX`` ->
    ``CellglX``; anything else gets ``cellgl_`` (``Cellgl`` for structs) in front.
    """
    if kind == "struct":
        if name.startswith("Cellgl"):
            return name
        if name.startswith("Cell"):
            return "Cellgl" + name[4:]
        return "Cellgl" + name[:1].upper() + name[1:]
    if name.startswith("cellgl_"):
        return name
    if name.startswith("_cell_"):
        return "cellgl_" + name[6:] + "_"
    if name.startswith("cell_"):
        return "cellgl_" + name[5:]
    if name.startswith("_"):
        return "cellgl_" + name.lstrip("_") + "_"
    return "cellgl_" + name


def prefix_names(text: str, *, keep: set[str] = frozenset(),
                 overrides: Mapping[str, str] | None = None) -> tuple[str, dict[str, str]]:
    """Rename every top-level name with :func:`prefixed` (code and comments alike).

    ``overrides`` gives explicit new names (e.g. to keep a library function clear of an entry
    point's name: WGSL has no overloading).

    Returns the new text and the ``{old: new}`` map. Raises :class:`TranslateError` when two
    names would collide.
    """
    decls = top_level_names(text)
    mapping = {n: prefixed(n, k) for n, k in decls.items() if n not in keep}
    for old, new in (overrides or {}).items():
        if old in mapping:
            mapping[old] = new
    mapping = {a: b for a, b in mapping.items() if a != b}
    seen: dict[str, str] = {}
    for old, new in mapping.items():
        if new in seen or (new in decls and new not in mapping):
            raise TranslateError(f"prefixing {old!r} gives {new!r}, which is taken")
        seen[new] = old
    word = re.compile(r"\b(" + "|".join(map(re.escape, mapping)) + r")\b") if mapping else None
    out = []
    for kind, t in split_tokens(text):
        if kind == "id":
            t = mapping.get(t, t)
        elif kind == "comment" and word is not None:
            t = word.sub(lambda m: mapping[m.group(1)], t)
        out.append(t)
    return "".join(out), mapping
