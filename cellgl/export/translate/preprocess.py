"""Steps 1 and 2 of a snippet, on its text: :func:`specialise`, a small C preprocessor for the
subset the library uses (inactive branches are dropped and every macro replaced by its value),
and :func:`prefix_names`, which gives every top-level name the ``cellgl_`` prefix."""
from __future__ import annotations

import operator
import re
from collections.abc import Callable, Mapping
from functools import lru_cache

from cellgl.export import syntax as S
from cellgl.export.printer import expr_glsl
from cellgl.export.translate.tokens import TranslateError, split_tokens

# --------------------------------------------------------------------------------------------
# 1. preprocessor subset
# --------------------------------------------------------------------------------------------

_DIRECTIVE_RE = re.compile(r"^\s*#\s*(\w*)\s*(.*?)\s*$")


def _strip_comment(s: str) -> str:
    s = re.sub(r"/\*.*?\*/", " ", s)
    return s.split("//", 1)[0].strip()


def _value(text: str, where: str) -> int:
    """The value of the integer constant expression ``text`` of ``#if`` (C semantics, truncating
    division), read by :mod:`cellgl.export.syntax`'s parser."""
    def error(msg: str) -> TranslateError:
        return TranslateError(f"{where}: {msg} in #if expression {text!r}")

    def value(e) -> int:
        if isinstance(e, S.Paren):
            return value(e.inner)
        if isinstance(e, S.Num) and re.fullmatch(r"(0[xX][0-9a-fA-F]+|\d+)[uU]?", e.text):
            t = e.text.rstrip("uU")
            return int(t, 8) if re.fullmatch(r"0\d+", t) else int(t, 0)
        if isinstance(e, S.Unary) and e.op in _UNARY:
            return int(_UNARY[e.op](value(e.operand)))
        if isinstance(e, S.Ternary):
            return value(e.then) if value(e.cond) else value(e.other)
        if isinstance(e, S.Binary) and e.op in _BINARY:
            v, w = value(e.left), value(e.right)
            if e.op in ("/", "%") and w == 0:
                raise error("division by zero")
            return int(_BINARY[e.op](v, w))
        raise error(f"undefined macro {e.name!r}" if isinstance(e, S.Name) else f"unexpected {expr_glsl(e)!r}")
    tree = _parsed(text)
    if isinstance(tree, str):
        raise error(tree)
    return value(tree)


@lru_cache(maxsize=4096)
def _parsed(text: str):
    """The tree of the expression ``text``, or why it is none (cached: the same macros recur)."""
    try:
        (item,) = S.parse(f"const int v = {text};").items
        (d,) = item.declarators
        return d.init
    except TranslateError as e:
        return str(e)
    except ValueError:                                  # a declaration, more than one
        return "not one expression"


def _cdiv(v: int, w: int) -> int:
    """C's integer division: truncated toward zero."""
    return int(v / w) if (v < 0) != (w < 0) else v // w


_BINARY = {
    "||": lambda v, w: bool(v) or bool(w), "&&": lambda v, w: bool(v) and bool(w),
    "|": operator.or_, "^": operator.xor, "&": operator.and_, "==": operator.eq, "!=": operator.ne,
    "<": operator.lt, ">": operator.gt, "<=": operator.le, ">=": operator.ge, "<<": operator.lshift,
    ">>": operator.rshift, "+": operator.add, "-": operator.sub, "*": operator.mul, "/": _cdiv,
    "%": lambda v, w: v - w * _cdiv(v, w),
}
_UNARY: dict[str, Callable[[int], int]] = {"!": operator.not_, "-": operator.neg, "+": operator.pos, "~": operator.invert}


def _expand(tokens: list[str], macros: Mapping[str, str], where: str, depth: int = 0) -> list[str]:
    if depth > 32:
        raise TranslateError(f"{where}: macro expansion too deep (recursive #define?)")
    return [x for t in tokens
            for x in (_expand(_ptoks(macros[t]), macros, where, depth + 1) if t in macros else [t])]


def _ptoks(s: str) -> list[str]:
    return [t for k, t in split_tokens(s) if k not in ("ws", "comment")]


def _eval_if(expr: str, macros: Mapping[str, str], where: str) -> bool:
    text = " ".join(_ptoks(_strip_comment(expr)))       # defined X / defined(X) before expansion
    text = re.sub(r"\bdefined (?:\( (\w+) \)|(\w+))", lambda m: str(int((m[1] or m[2]) in macros)), text)
    if bad := re.search(r"\bdefined\b( \()?", text):
        raise TranslateError(f"{where}: malformed defined{'()' if bad[1] else ''} in {expr!r}")
    if not text:
        raise TranslateError(f"{where}: empty #if expression")
    return bool(_value(" ".join(_expand(text.split(), macros, where)), where))


def specialise(text: str, defines: Mapping[str, object], *, name: str = "<shader>") -> str:
    """Evaluate the preprocessor directives of ``text`` with ``defines`` and substitute macros.

    Parameters
    ----------
    text : str
        GLSL source (includes already resolved), may contain directives.
    defines : mapping of str to int, float, bool or str
        The macros in force at the top (values as in :func:`cellgl.gl.glsl.format_define`).
    name : str
        Used in error messages.

    Returns
    -------
    str
        The text with inactive branches and every directive line removed and every macro in code
        replaced by its (fully expanded) value. Comments are kept unchanged.

    Raises
    ------
    TranslateError
        Unbalanced conditionals, an undefined macro in an ``#if``, a function-like macro,
        ``#include``/``#version``/``#error``/``#pragma``/``#extension`` and other directives.
    """
    macros: dict[str, str] = {}
    for k, v in defines.items():
        if isinstance(v, bool):
            v = int(v)
        macros[str(k)] = "" if v is None else (repr(float(v)) if isinstance(v, float) else str(v))

    # join continuation lines
    raw = text.replace("\\\n", "")
    # output chunks: (macros in force, lines); a #define/#undef starts a new chunk
    chunks: list[tuple[dict[str, str], list[str]]] = [(macros, [])]
    # stack of [active_now, any_branch_taken, parent_active, seen_else]
    stack: list[list[bool]] = []
    active = True
    for num, line in enumerate(raw.split("\n"), start=1):
        where = f"{name}:{num}"
        m = _DIRECTIVE_RE.match(line) if line.lstrip().startswith("#") else None
        if m is None:
            if active:
                chunks[-1][1].append(line)
            continue
        kw, rest = m.group(1), _strip_comment(m.group(2))
        if kw in ("if", "ifdef", "ifndef"):
            if active and kw != "if" and not re.fullmatch(r"[A-Za-z_]\w*", rest):
                raise TranslateError(f"{where}: #{kw} needs one macro name, got {rest!r}")
            cond = active and (_eval_if(rest, macros, where) if kw == "if"
                               else (rest in macros) == (kw == "ifdef"))
            stack.append([cond, cond or not active, active, False])   # (inactive parent: none will be taken)
            active = cond
        elif kw in ("elif", "else"):
            if not stack:
                raise TranslateError(f"{where}: #{kw} without #if")
            top = stack[-1]
            if top[3]:
                raise TranslateError(f"{where}: #{kw} after #else")
            top[3] = kw == "else"
            top[0] = top[2] and not top[1] and (kw == "else" or _eval_if(rest, macros, where))
            top[1] = top[1] or top[0]
            active = top[0]
        elif kw == "endif":
            if not stack:
                raise TranslateError(f"{where}: #endif without #if")
            stack.pop()
            active = stack[-1][0] if stack else True
        elif not active:
            continue
        elif kw == "define":
            m2 = re.match(r"([A-Za-z_]\w*)(\(?)\s*(.*)$", rest)
            if not m2:
                raise TranslateError(f"{where}: malformed #define {rest!r}")
            if m2.group(2):
                raise TranslateError(
                    f"{where}: function-like macro {m2.group(1)!r} is not supported in exported "
                    "snippets; write a function instead")
            macros = {**macros, m2.group(1): m2.group(3)}
            chunks.append((macros, []))
        elif kw == "undef":
            macros = {k: v for k, v in macros.items() if k != rest}
            chunks.append((macros, []))
        elif kw == "":
            continue                    # the null directive
        else:
            raise TranslateError(f"{where}: #{kw} cannot appear in an exported snippet")
    if stack:
        raise TranslateError(f"{name}: {len(stack)} #if block(s) not closed by #endif")

    # substitute macros in code (comments are prose and stay as written)
    return "\n".join("".join(_macro_value(t, env, name) if k == "id" and t in env else t
                             for k, t in split_tokens("\n".join(lines))) for env, lines in chunks if lines)


def _macro_value(key: str, env: Mapping[str, str], name: str) -> str:
    value = " ".join(_expand([key], env, name))
    if not re.search(r"[0-9a-fA-F][uU]\b", value):
        try:                            # an integer constant expression becomes its value
            value = str(_value(value, name))
        except TranslateError:
            pass
    # a negative or compound value keeps its meaning next to any operator
    if value and re.fullmatch(r"[\w.]+", value) is None:
        value = f"({value})"
    return value


# --------------------------------------------------------------------------------------------
# 2. top-level names and the prefix
# --------------------------------------------------------------------------------------------


def top_level_names(text: str) -> dict[str, str]:
    """Names declared at file scope: ``{name: 'function' | 'struct' | 'variable'}``, read from
    :func:`cellgl.export.syntax.parsed_library`'s tree (each declaration parsed once per process)."""
    names: dict[str, str] = {}
    for it in S.parsed_library(text).items:
        if isinstance(it, S.Global):
            names.update(dict.fromkeys((d.name for d in it.declarators), "variable"))
        else:
            names[it.name] = "struct" if isinstance(it, S.Struct) else "function"
    return names


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


def prefix_names(text: str, *, overrides: Mapping[str, str] | None = None) -> tuple[str, dict[str, str]]:
    """Rename every top-level name with :func:`prefixed` (code and comments alike).

    ``overrides`` gives explicit new names (e.g. to keep a library function clear of an entry
    point's name: WGSL has no overloading).

    Returns the new text and the ``{old: new}`` map. Raises :class:`TranslateError` when two
    names would collide.
    """
    decls = top_level_names(text)
    mapping = {n: (overrides or {}).get(n) or prefixed(n, k) for n, k in decls.items()}
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
