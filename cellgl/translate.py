"""Shader text surgery for the snippet exporter: specialise, prefix, translate.

Pure text, no GL. Three steps turn the resolved ``shaders/lib`` sources into a snippet:

1. :func:`specialise` -- a small C preprocessor for the subset the library uses
   (``#if``/``#elif``/``#else``/``#endif``, ``#ifdef``/``#ifndef``, object-like
   ``#define``/``#undef``, ``defined()``, integer expressions). Inactive branches are dropped and
   every macro name in the code is replaced by its value, so no directive and no macro is left.
2. :func:`prefix_names` -- every top-level name (function, struct, global constant) gets the
   ``cellgl_`` prefix (structs ``Cellgl``), so nothing unprefixed leaks into the user's shader.
3. :func:`to_hlsl` / :func:`to_wgsl` -- token-level translation of the specialised GLSL into
   another dialect; :func:`add_highp` pins GLSL ES declarations to ``highp``.

The translators cover the GLSL subset the library is written in (see DESIGN.md): scalars,
vectors, structs, fixed-size arrays, ``in``/``out``/``inout`` parameters, for/if/else, ternaries,
the built-ins in :data:`HLSL_FUNCS`. Anything else raises :class:`TranslateError` naming the
construct, instead of emitting text that would not compile.
"""
from __future__ import annotations

import re
from collections.abc import Mapping

__all__ = [
    "TranslateError",
    "tokenize",
    "specialise",
    "top_level_names",
    "prefix_names",
    "add_highp",
    "to_hlsl",
    "to_wgsl",
]


class TranslateError(ValueError):
    """The shader text uses a construct the exporter cannot specialise or translate."""


# --------------------------------------------------------------------------------------------
# tokens
# --------------------------------------------------------------------------------------------

_TOKEN_RE = re.compile(
    r"(?P<comment>//[^\n]*|/\*.*?\*/)"
    r"|(?P<ws>\s+)"
    r"|(?P<num>0[xX][0-9a-fA-F]+[uU]?|(?:\d+\.\d*|\.\d+)(?:[eE][+-]?\d+)?[fF]?|\d+[eE][+-]?\d+[fF]?"
    r"|\d+[uU]?)"
    r"|(?P<id>[A-Za-z_][A-Za-z0-9_]*)"
    r"|(?P<op><<=|>>=|\+\+|--|<<|>>|<=|>=|==|!=|&&|\|\||\^\^|[-+*/%&|^]=|[-+*/%<>=!~&|^?:;,.(){}\[\]])",
    re.S,
)


class Tok:
    __slots__ = ("kind", "text")

    def __init__(self, kind: str, text: str):
        self.kind = kind
        self.text = text

    def __repr__(self) -> str:
        return f"Tok({self.kind}, {self.text!r})"


def tokenize(text: str) -> list[Tok]:
    """Split GLSL text (no directives) into tokens: comment, ws, num, id, op."""
    out: list[Tok] = []
    pos = 0
    while pos < len(text):
        m = _TOKEN_RE.match(text, pos)
        if not m:
            line = text.count("\n", 0, pos) + 1
            raise TranslateError(f"line {line}: unexpected character {text[pos]!r}")
        out.append(Tok(m.lastgroup, m.group()))
        pos = m.end()
    return out


def _join(toks: list[Tok]) -> str:
    return "".join(t.text for t in toks)


def _code(toks: list[Tok]) -> list[int]:
    """Indices of the tokens that are code (not whitespace or comments)."""
    return [i for i, t in enumerate(toks) if t.kind not in ("ws", "comment")]


# --------------------------------------------------------------------------------------------
# 1. preprocessor subset
# --------------------------------------------------------------------------------------------

_DIRECTIVE_RE = re.compile(r"^\s*#\s*(\w*)\s*(.*?)\s*$")


def _strip_comment(s: str) -> str:
    s = re.sub(r"/\*.*?\*/", " ", s)
    return s.split("//", 1)[0].strip()


class _Expr:
    """Integer constant expression of ``#if`` (C semantics, truncating division)."""

    _BIN = [
        ("||",), ("&&",), ("|",), ("^",), ("&",), ("==", "!="), ("<", ">", "<=", ">="),
        ("<<", ">>"), ("+", "-"), ("*", "/", "%"),
    ]

    def __init__(self, toks: list[str], where: str):
        self.toks = toks
        self.i = 0
        self.where = where

    def error(self, msg: str) -> TranslateError:
        return TranslateError(f"{self.where}: {msg} in #if expression {' '.join(self.toks)!r}")

    def peek(self) -> str | None:
        return self.toks[self.i] if self.i < len(self.toks) else None

    def take(self) -> str:
        t = self.peek()
        if t is None:
            raise self.error("unexpected end")
        self.i += 1
        return t

    def parse(self) -> int:
        v = self.ternary()
        if self.peek() is not None:
            raise self.error(f"unexpected {self.peek()!r}")
        return v

    def ternary(self) -> int:
        c = self.binary(0)
        if self.peek() == "?":
            self.take()
            a = self.ternary()
            if self.take() != ":":
                raise self.error("expected ':'")
            b = self.ternary()
            return a if c else b
        return c

    def binary(self, level: int) -> int:
        if level == len(self._BIN):
            return self.unary()
        v = self.binary(level + 1)
        while self.peek() in self._BIN[level]:
            op = self.take()
            w = self.binary(level + 1)
            if op in ("/", "%") and w == 0:
                raise self.error("division by zero")
            v = {
                "||": lambda: int(bool(v) or bool(w)), "&&": lambda: int(bool(v) and bool(w)),
                "|": lambda: v | w, "^": lambda: v ^ w, "&": lambda: v & w,
                "==": lambda: int(v == w), "!=": lambda: int(v != w), "<": lambda: int(v < w),
                ">": lambda: int(v > w), "<=": lambda: int(v <= w), ">=": lambda: int(v >= w),
                "<<": lambda: v << w, ">>": lambda: v >> w, "+": lambda: v + w, "-": lambda: v - w,
                "*": lambda: v * w,
                "/": lambda: int(v / w) if (v < 0) != (w < 0) else v // w,
                "%": lambda: v - w * (int(v / w) if (v < 0) != (w < 0) else v // w),
            }[op]()
        return v

    def unary(self) -> int:
        t = self.take()
        if t == "!":
            return int(not self.unary())
        if t == "-":
            return -self.unary()
        if t == "+":
            return self.unary()
        if t == "~":
            return ~self.unary()
        if t == "(":
            v = self.ternary()
            if self.take() != ")":
                raise self.error("expected ')'")
            return v
        m = re.fullmatch(r"(0[xX][0-9a-fA-F]+|\d+)[uU]?", t)
        if m:
            return int(m.group(1), 0) if not re.fullmatch(r"0\d+", m.group(1)) else int(m.group(1), 8)
        if re.fullmatch(r"[A-Za-z_]\w*", t):
            raise self.error(f"undefined macro {t!r}")
        raise self.error(f"unexpected {t!r}")


def _expand(tokens: list[str], macros: Mapping[str, str], where: str, depth: int = 0) -> list[str]:
    if depth > 32:
        raise TranslateError(f"{where}: macro expansion too deep (recursive #define?)")
    out: list[str] = []
    for t in tokens:
        if t in macros:
            out.extend(_expand(_ptoks(macros[t]), macros, where, depth + 1))
        else:
            out.append(t)
    return out


def _ptoks(s: str) -> list[str]:
    return [t.text for t in tokenize(s) if t.kind not in ("ws", "comment")]


def _eval_if(expr: str, macros: Mapping[str, str], where: str) -> bool:
    toks = _ptoks(_strip_comment(expr))
    resolved: list[str] = []
    i = 0
    while i < len(toks):           # defined X / defined(X) before expansion
        if toks[i] == "defined":
            if i + 1 < len(toks) and toks[i + 1] == "(":
                if i + 3 >= len(toks) or toks[i + 3] != ")":
                    raise TranslateError(f"{where}: malformed defined() in {expr!r}")
                name, i = toks[i + 2], i + 4
            elif i + 1 < len(toks):
                name, i = toks[i + 1], i + 2
            else:
                raise TranslateError(f"{where}: malformed defined in {expr!r}")
            resolved.append("1" if name in macros else "0")
        else:
            resolved.append(toks[i])
            i += 1
    if not resolved:
        raise TranslateError(f"{where}: empty #if expression")
    return bool(_Expr(_expand(resolved, macros, where), where).parse())


def specialise(text: str, defines: Mapping[str, object], *, name: str = "<shader>") -> str:
    """Evaluate the preprocessor directives of ``text`` with ``defines`` and substitute macros.

    Parameters
    ----------
    text : str
        GLSL source (includes already resolved), may contain directives.
    defines : mapping of str to int, float, bool or str
        The macros in force at the top (values as in :func:`cellgl.glsl.format_define`).
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
            if not active:
                stack.append([False, True, False, False])
            else:
                if kw == "if":
                    cond = _eval_if(rest, macros, where)
                else:
                    if not re.fullmatch(r"[A-Za-z_]\w*", rest):
                        raise TranslateError(f"{where}: #{kw} needs one macro name, got {rest!r}")
                    cond = (rest in macros) == (kw == "ifdef")
                stack.append([cond, cond, True, False])
            active = stack[-1][0]
        elif kw in ("elif", "else"):
            if not stack:
                raise TranslateError(f"{where}: #{kw} without #if")
            top = stack[-1]
            if top[3]:
                raise TranslateError(f"{where}: #{kw} after #else")
            if kw == "else":
                top[3] = True
                top[0] = top[2] and not top[1]
            else:
                top[0] = top[2] and not top[1] and _eval_if(rest, macros, where)
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
            macros = dict(macros)
            macros[m2.group(1)] = m2.group(3)
            chunks.append((macros, []))
        elif kw == "undef":
            macros = dict(macros)
            macros.pop(rest, None)
            chunks.append((macros, []))
        elif kw == "":
            continue                    # the null directive
        else:
            raise TranslateError(f"{where}: #{kw} cannot appear in an exported snippet")
    if stack:
        raise TranslateError(f"{name}: {len(stack)} #if block(s) not closed by #endif")

    # substitute macros in code (comments are prose and stay as written)
    out: list[str] = []
    for env, lines in chunks:
        if not lines:
            continue
        toks = tokenize("\n".join(lines))
        for t in toks:
            if t.kind == "id" and t.text in env:
                t.text = _macro_value(t.text, env, name)
        out.append(_join(toks))
    return "\n".join(out)


def _macro_value(key: str, env: Mapping[str, str], name: str) -> str:
    value = " ".join(_expand([key], env, name))
    if not re.search(r"[0-9a-fA-F][uU]\b", value):
        try:                            # an integer constant expression becomes its value
            value = str(_Expr(_ptoks(value), name).parse())
        except TranslateError:
            pass
    # a negative or compound value keeps its meaning next to any operator
    if value and re.fullmatch(r"[\w.]+", value) is None:
        value = f"({value})"
    return value


# --------------------------------------------------------------------------------------------
# 2. top-level names and the prefix
# --------------------------------------------------------------------------------------------

GLSL_TYPES = {
    "void", "bool", "int", "uint", "float",
    "vec2", "vec3", "vec4", "ivec2", "ivec3", "ivec4", "uvec2", "uvec3", "uvec4",
    "bvec2", "bvec3", "bvec4", "mat2", "mat3", "mat4",
}


def top_level_names(text: str) -> dict[str, str]:
    """Names declared at file scope: ``{name: 'function' | 'struct' | 'variable'}``."""
    toks = [t for t in tokenize(text) if t.kind not in ("ws", "comment")]
    names: dict[str, str] = {}
    depth = 0
    stmt: list[str] = []
    for t in toks:
        if t.text == "{":
            if depth == 0:
                _decl(stmt, names, brace=True)
                stmt = []
            depth += 1
            continue
        if t.text == "}":
            depth -= 1
            continue
        if depth:
            continue
        if t.text == ";":
            _decl(stmt, names, brace=False)
            stmt = []
            continue
        stmt.append(t.text)
    return names


_QUALIFIERS = {"const", "uniform", "highp", "mediump", "lowp", "in", "out", "inout", "flat",
               "precise", "invariant"}


def _decl(stmt: list[str], names: dict[str, str], brace: bool) -> None:
    s = [t for t in stmt if t not in _QUALIFIERS]
    if not s:
        return
    if s[0] == "struct":
        if len(s) >= 2:
            names[s[1]] = "struct"
        return
    if len(s) >= 3 and s[2] == "(" and brace:
        names[s[1]] = "function"
        return
    if len(s) >= 3 and s[2] == "(":
        names[s[1]] = "function"    # prototype
        return
    # variable(s): TYPE NAME [= ...] [, NAME ...]; TYPE NAME[N] = ...
    if len(s) >= 2 and re.fullmatch(r"[A-Za-z_]\w*", s[1]):
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
    toks = tokenize(text)
    word = re.compile(r"\b(" + "|".join(map(re.escape, mapping)) + r")\b") if mapping else None
    for t in toks:
        if t.kind == "id" and t.text in mapping:
            t.text = mapping[t.text]
        elif t.kind == "comment" and word is not None:
            t.text = word.sub(lambda m: mapping[m.group(1)], t.text)
    return _join(toks), mapping


# --------------------------------------------------------------------------------------------
# GLSL ES: highp everywhere
# --------------------------------------------------------------------------------------------

_PRECISION_TYPES = GLSL_TYPES - {"void", "bool", "bvec2", "bvec3", "bvec4"}


def add_highp(text: str) -> str:
    """Put ``highp`` before every declaration of a float/int/uint type (GLSL ES 3.00).

    The ES default int precision in fragment shaders is ``mediump`` (16 bits on some GPUs),
    which would break the 32-bit hashes; qualifying each declaration keeps the user's own
    ``precision`` statements untouched.
    """
    toks = tokenize(text)
    code = _code(toks)
    for n, i in enumerate(code):
        t = toks[i]
        if t.kind != "id" or t.text not in _PRECISION_TYPES:
            continue
        nxt = toks[code[n + 1]] if n + 1 < len(code) else None
        prv = toks[code[n - 1]].text if n else ""
        if nxt is not None and nxt.kind == "id" and prv not in ("highp", "mediump", "lowp"):
            t.text = "highp " + t.text
    return _join(toks)


# --------------------------------------------------------------------------------------------
# 3a. HLSL
# --------------------------------------------------------------------------------------------

HLSL_TYPES = {
    "vec2": "float2", "vec3": "float3", "vec4": "float4",
    "ivec2": "int2", "ivec3": "int3", "ivec4": "int4",
    "uvec2": "uint2", "uvec3": "uint3", "uvec4": "uint4",
    "bvec2": "bool2", "bvec3": "bool3", "bvec4": "bool4",
}
_VECTOR_TYPES = set(HLSL_TYPES)

#: GLSL built-in -> HLSL built-in (same arguments)
HLSL_FUNCS = {
    "fract": "frac", "mix": "lerp", "inversesqrt": "rsqrt", "dFdx": "ddx", "dFdy": "ddy",
    "floatBitsToUint": "asuint", "floatBitsToInt": "asint", "uintBitsToFloat": "asfloat",
    "intBitsToFloat": "asfloat",
}
#: GLSL component-wise relational function -> infix operator
RELATIONAL = {
    "lessThan": "<", "lessThanEqual": "<=", "greaterThan": ">", "greaterThanEqual": ">=",
    "equal": "==", "notEqual": "!=",
}
#: identifiers that are reserved in HLSL (or its effect syntax) but legal GLSL names
HLSL_RESERVED = {
    "point", "line", "lineadj", "triangle", "triangleadj", "sample", "linear", "centroid",
    "nointerpolation", "noperspective", "precise", "groupshared", "shared", "static", "unorm",
    "snorm", "packoffset", "register", "vector", "matrix", "half", "double", "dword", "string",
    "texture", "sampler", "compile", "pass", "technique", "row_major", "column_major", "export",
    "extern", "globallycoherent", "interface", "namespace", "class", "typedef", "volatile",
    "inline", "min16float", "min10float", "min16int", "min12int", "min16uint", "snorm", "cbuffer",
    "tbuffer", "Buffer", "asm", "template", "this", "unsigned", "auto", "catch", "char", "signed",
    "sizeof", "throw", "try", "union", "using", "virtual",
}
#: GLSL constructs with no mechanical translation here
_UNSUPPORTED = {
    "mat2", "mat3", "mat4", "sampler2D", "sampler3D", "texture", "texelFetch", "discard",
    "gl_FragCoord", "gl_FragColor",
}


def _match_paren(toks: list[Tok], code: list[int], n: int) -> tuple[int, list[int]]:
    """``code[n]`` is ``(``: return the position in ``code`` of its ``)`` and of top-level commas."""
    depth = 0
    commas: list[int] = []
    for m in range(n, len(code)):
        t = toks[code[m]].text
        if t in ("(", "[", "{"):
            depth += 1
        elif t in (")", "]", "}"):
            depth -= 1
            if depth == 0:
                return m, commas
        elif t == "," and depth == 1:
            commas.append(m)
    raise TranslateError("unbalanced parentheses")


def _line_of(toks: list[Tok], i: int) -> int:
    return sum(t.text.count("\n") for t in toks[:i]) + 1


def _hlsl_mod_helpers() -> str:
    lines = ["// GLSL mod(): x - y * floor(x / y) (HLSL's fmod truncates instead)."]
    for t in ("float", "float2", "float3", "float4"):
        lines.append(f"{t} cellgl_mod({t} x, {t} y) {{ return x - y * floor(x / y); }}")
        if t != "float":
            lines.append(f"{t} cellgl_mod({t} x, float y) {{ return x - y * floor(x / y); }}")
    return "\n".join(lines) + "\n\n"


def to_hlsl(text: str) -> str:
    """Translate specialised, prefixed GLSL (library subset) into HLSL (SM 4+/5, DXC and FXC).

    Vector types are renamed (``vec4`` -> ``float4``), one-argument vector constructors become
    casts (``vec4(x)`` -> ``((float4)(x))``, splat or conversion), array and struct constructors
    become initialiser lists, global ``const`` becomes ``static const``, relational functions
    become operators, ``mod`` gets a helper with GLSL's floor semantics and names reserved in
    HLSL are suffixed with ``_``.
    """
    toks = tokenize(text)
    code = _code(toks)
    structs = {n for n, k in top_level_names(text).items() if k == "struct"}
    depth = 0
    uses_mod = False
    n = 0
    while n < len(code):
        i = code[n]
        t = toks[i]
        nxt = toks[code[n + 1]].text if n + 1 < len(code) else ""
        if t.text == "{":
            depth += 1
        elif t.text == "}":
            depth -= 1
        if t.kind != "id":
            n += 1
            continue
        name = t.text
        if name in _UNSUPPORTED:
            raise TranslateError(
                f"line {_line_of(toks, i)}: {name!r} has no HLSL translation in cellgl's exporter")
        if name in ("highp", "mediump", "lowp"):
            t.text = ""
            if toks[i + 1].kind == "ws":
                toks[i + 1].text = ""
        elif name == "const" and depth == 0:
            t.text = "static const"
        elif (name in _VECTOR_TYPES or name in structs or name in GLSL_TYPES) and nxt == "[":
            # array constructor T[N](a, b, ...) -> {a, b, ...}; a declaration T[N] name is
            # not used by the library
            close_b = n + 1
            while toks[code[close_b]].text != "]":
                close_b += 1
            if close_b + 1 < len(code) and toks[code[close_b + 1]].text == "(":
                close, _ = _match_paren(toks, code, close_b + 1)
                for m in range(n, close_b + 1):
                    toks[code[m]].text = ""
                toks[code[close_b + 1]].text = "{"
                toks[code[close]].text = "}"
            elif name in HLSL_TYPES:
                t.text = HLSL_TYPES[name]
        elif name in structs and nxt == "(":
            close, _ = _match_paren(toks, code, n + 1)
            t.text = ""
            toks[code[n + 1]].text = "{"
            toks[code[close]].text = "}"
        elif name in HLSL_TYPES:
            if nxt == "(":
                close, commas = _match_paren(toks, code, n + 1)
                if not commas:
                    t.text = f"(({HLSL_TYPES[name]})"
                    toks[code[close]].text = "))"
                else:
                    t.text = HLSL_TYPES[name]
            else:
                t.text = HLSL_TYPES[name]
        elif name in RELATIONAL and nxt == "(":
            close, commas = _match_paren(toks, code, n + 1)
            if len(commas) != 1:
                raise TranslateError(f"line {_line_of(toks, i)}: {name} needs 2 arguments")
            t.text = ""
            toks[code[n + 1]].text = "(("
            toks[code[commas[0]]].text = f") {RELATIONAL[name]} ("
            toks[code[close]].text = "))"
        elif name == "atan" and nxt == "(":
            _, commas = _match_paren(toks, code, n + 1)
            if commas:
                t.text = "atan2"
        elif name == "mod" and nxt == "(":
            t.text = "cellgl_mod"
            uses_mod = True
        elif name in HLSL_FUNCS and nxt == "(":
            t.text = HLSL_FUNCS[name]
        elif name in HLSL_RESERVED:
            t.text = name + "_"
        n += 1
    out = _join(toks)
    if uses_mod:
        out = _hlsl_mod_helpers() + out
    return out


# --------------------------------------------------------------------------------------------
# 3b. WGSL: a small parser of the library subset, then an emitter
# --------------------------------------------------------------------------------------------

WGSL_SCALARS = {"float": "f32", "int": "i32", "uint": "u32", "bool": "bool"}
WGSL_FUNCS = {"inversesqrt": "inverseSqrt", "dFdx": "dpdx", "dFdy": "dpdy",
              "floatBitsToUint": "bitcast<u32>", "floatBitsToInt": "bitcast<i32>",
              "uintBitsToFloat": "bitcast<f32>", "intBitsToFloat": "bitcast<f32>"}
#: WGSL keywords and reserved words that are legal GLSL identifiers
WGSL_RESERVED = {
    "alias", "const_assert", "continuing", "diagnostic", "enable", "fn", "let", "loop", "override",
    "requires", "var", "ptr", "array", "atomic", "sampler", "texture_2d", "f32", "i32", "u32", "f16",
    "vec2", "vec3", "vec4", "mat2x2", "mat3x3", "mat4x4", "bitcast", "select", "target", "type",
    "self", "super", "unless", "where", "with", "yield", "as", "async", "await", "become", "cast",
    "catch", "class", "co_await", "co_return", "co_yield", "coherent", "column_major", "common",
    "compile", "compile_fragment", "concept", "const_cast", "consteval", "constexpr", "constinit",
    "crate", "debugger", "decltype", "delete", "demote", "demote_to_helper", "do", "dynamic_cast",
    "enum", "explicit", "export", "extends", "extern", "external", "fallthrough", "filter", "final",
    "finally", "friend", "from", "fxgroup", "get", "goto", "groupshared", "highp", "impl",
    "implements", "import", "inline", "instanceof", "interface", "layout", "lowp", "macro",
    "macro_rules", "match", "mediump", "meta", "mod", "module", "move", "mut", "mutable",
    "namespace", "new", "nil", "noexcept", "noinline", "nointerpolation", "noperspective", "null",
    "nullptr", "of", "operator", "package", "packoffset", "partition", "pass", "patch",
    "pixelfragment", "precise", "precision", "premerge", "priv", "protected", "pub", "public",
    "readonly", "ref", "regardless", "register", "reinterpret_cast", "require", "resource",
    "restrict", "self", "set", "shared", "sizeof", "smooth", "snorm", "static", "static_assert",
    "static_cast", "std", "subroutine", "template", "this", "thread_local", "throw", "trait", "try",
    "typedef", "typeid", "typename", "typeof", "union", "unorm", "unsafe", "unsized", "use",
    "using", "varying", "virtual", "volatile", "wgsl", "writeonly", "sample", "line", "point",
}

_ASSIGN_OPS = {"=", "+=", "-=", "*=", "/=", "%=", "&=", "|=", "^=", "<<=", ">>="}
_BINARY_PREC = [("||",), ("^^",), ("&&",), ("|",), ("^",), ("&",), ("==", "!="),
                ("<", ">", "<=", ">="), ("<<", ">>"), ("+", "-"), ("*", "/", "%")]
_PREC_OF = {op: level for level, ops in enumerate(_BINARY_PREC) for op in ops}


class _Parser:
    """Recursive descent over code tokens; comments are attached to the next statement."""

    def __init__(self, text: str):
        self.toks: list[tuple[str, str, list[str]]] = []   # (kind, text, comments before it)
        self.trail: dict[int, str] = {}     # token index -> comment on the rest of its line
        pending: list[str] = []
        newline = True
        for t in tokenize(text):
            if t.kind == "comment" and not newline and self.toks and t.text.startswith("//") \
                    and len(self.toks) - 1 not in self.trail:
                self.trail[len(self.toks) - 1] = t.text
                continue
            if t.kind != "ws":
                newline = False
            elif "\n" in t.text:
                newline = True
            if t.kind == "comment":
                pending.append(t.text)
            elif t.kind == "ws":
                if t.text.count("\n") >= 2 and pending and pending[-1] != "":
                    pending.append("")          # keep one blank line between comment blocks
            else:
                self.toks.append((t.kind, t.text, pending))
                pending = []
        self.trailing = pending
        self.i = 0
        self.structs: set[str] = set()
        self.line = 0

    # token helpers
    def peek(self, k: int = 0) -> str:
        j = self.i + k
        return self.toks[j][1] if j < len(self.toks) else ""

    def kind(self, k: int = 0) -> str:
        j = self.i + k
        return self.toks[j][0] if j < len(self.toks) else ""

    def comments(self) -> list[str]:
        return self.toks[self.i][2] if self.i < len(self.toks) else []

    def take(self, want: str | None = None) -> str:
        if self.i >= len(self.toks):
            raise TranslateError(f"unexpected end of shader text (expected {want!r})")
        t = self.toks[self.i][1]
        if want is not None and t != want:
            ctx = " ".join(x[1] for x in self.toks[max(0, self.i - 8): self.i + 4])
            raise TranslateError(f"WGSL translation: expected {want!r}, got {t!r} near: {ctx}")
        self.i += 1
        return t

    def is_type(self, k: int = 0) -> bool:
        t = self.peek(k)
        return t in GLSL_TYPES or t in self.structs

    # top level
    def unit(self) -> list:
        out = []
        while self.i < len(self.toks):
            com = self.comments()
            if self.peek() == "struct":
                self.take()
                name = self.take()
                self.structs.add(name)
                self.take("{")
                members = []
                while self.peek() != "}":
                    mcom = self.comments()
                    while self.peek() in ("highp", "mediump", "lowp"):
                        self.take()
                    typ = self.take()
                    while True:
                        mname = self.take()
                        size = self.array_size()
                        members.append([mcom, typ, mname, size, ""])
                        mcom = []
                        if self.peek() == ",":
                            self.take()
                            continue
                        break
                    self.take(";")
                    members[-1][4] = self.trail.get(self.i - 1, "")
                self.take("}")
                self.take(";")
                out.append(("struct", com, name, members))
                continue
            quals = []
            while self.peek() in ("const", "uniform", "highp", "mediump", "lowp"):
                quals.append(self.take())
            typ = self.take()
            if self.peek() == "[":
                raise TranslateError("WGSL translation: array types in 'T[N] name' form are not supported")
            name = self.take()
            if self.peek() == "(":
                self.take("(")
                params = []
                while self.peek() != ")":
                    mode = "in"
                    while self.peek() in ("in", "out", "inout", "const", "highp", "mediump", "lowp"):
                        q = self.take()
                        if q in ("out", "inout"):
                            mode = q
                    ptyp = self.take()
                    pname = self.take()
                    psize = self.array_size()
                    params.append((mode, ptyp, pname, psize))
                    if self.peek() == ",":
                        self.take()
                if params == [("in", "void", ")", None)]:
                    params = []
                self.take(")")
                if self.peek() == ";":
                    self.take()
                    continue                    # prototype: WGSL needs none
                body = self.block()
                out.append(("func", com, typ, name, params, body))
                continue
            decls = self.declarators(name)
            self.take(";")
            out.append(("gdecl", com, quals, typ, decls))
        return out

    def array_size(self):
        if self.peek() == "[":
            self.take("[")
            e = self.expr()
            self.take("]")
            return e
        return None

    def declarators(self, first: str) -> list:
        decls = []
        name = first
        while True:
            size = self.array_size()
            init = None
            if self.peek() == "=":
                self.take()
                init = self.assign_expr()
            decls.append((name, size, init))
            if self.peek() != ",":
                return decls
            self.take(",")
            name = self.take()

    # statements
    def block(self) -> list:
        self.take("{")
        out = []
        while self.peek() != "}":
            out.append(self.statement())
        self.take("}")
        return out

    def statement(self):
        com = self.comments()
        t = self.peek()
        if t == "{":
            return ("block", com, self.block())
        if t == "if":
            self.take()
            self.take("(")
            c = self.expr()
            self.take(")")
            a = self.statement()
            b = None
            if self.peek() == "else":
                self.take()
                b = self.statement()
            return ("if", com, c, a, b)
        if t == "for":
            self.take()
            self.take("(")
            init = None if self.peek() == ";" else self.simple_statement()
            self.take(";")
            cond = None if self.peek() == ";" else self.expr()
            self.take(";")
            step = None if self.peek() == ")" else self.expr()
            self.take(")")
            body = self.statement()
            return ("for", com, init, cond, step, body)
        if t == "while":
            self.take()
            self.take("(")
            c = self.expr()
            self.take(")")
            return ("while", com, c, self.statement())
        if t == "return":
            self.take()
            e = None if self.peek() == ";" else self.expr()
            self.take(";")
            return ("return", com, e)
        if t in ("break", "continue", "discard"):
            self.take()
            self.take(";")
            return (t, com)
        if t == ";":
            self.take()
            return ("block", com, [])
        s = self.simple_statement()
        self.take(";")
        trail = self.trail.get(self.i - 1)
        if trail:
            com = com + [("trail", trail)]
        return (s[0], com) + s[2:]

    def simple_statement(self):
        quals = []
        while self.peek() in ("const", "highp", "mediump", "lowp"):
            quals.append(self.take())
        if self.is_type() and self.kind(1) == "id":
            typ = self.take()
            name = self.take()
            return ("decl", [], "const" in quals, typ, self.declarators(name))
        return ("expr", [], self.expr())

    # expressions: nodes are tuples
    def expr(self):
        e = self.assign_expr()
        if self.peek() == ",":
            raise TranslateError("WGSL translation: the comma operator is not supported")
        return e

    def assign_expr(self):
        lhs = self.ternary()
        if self.peek() in _ASSIGN_OPS:
            op = self.take()
            return ("assign", op, lhs, self.assign_expr())
        return lhs

    def ternary(self):
        c = self.binary(0)
        if self.peek() == "?":
            self.take()
            a = self.assign_expr()
            self.take(":")
            b = self.assign_expr()
            return ("ternary", c, a, b)
        return c

    def binary(self, level: int):
        if level == len(_BINARY_PREC):
            return self.unary()
        e = self.binary(level + 1)
        while self.peek() in _BINARY_PREC[level]:
            op = self.take()
            e = ("binary", op, e, self.binary(level + 1))
        return e

    def unary(self):
        t = self.peek()
        if t in ("-", "+", "!", "~"):
            self.take()
            return ("unary", t, self.unary())
        if t in ("++", "--"):
            self.take()
            return ("preinc", t, self.unary())
        return self.postfix()

    def postfix(self):
        e = self.primary()
        while True:
            t = self.peek()
            if t == "[":
                self.take()
                idx = self.expr()
                self.take("]")
                e = ("index", e, idx)
            elif t == ".":
                self.take()
                e = ("member", e, self.take())
            elif t in ("++", "--"):
                self.take()
                e = ("postinc", t, e)
            else:
                return e

    def args(self) -> list:
        self.take("(")
        out = []
        while self.peek() != ")":
            out.append(self.assign_expr())
            if self.peek() == ",":
                self.take()
        self.take(")")
        return out

    def primary(self):
        k, t = self.kind(), self.peek()
        if k == "num":
            self.take()
            return ("num", t)
        if t == "(":
            self.take()
            e = self.expr()
            self.take(")")
            return ("paren", e)
        if k == "id":
            self.take()
            if self.peek() == "[" and (t in GLSL_TYPES or t in self.structs):
                self.take("[")
                size = self.expr()
                self.take("]")
                return ("arrctor", t, size, self.args())
            if self.peek() == "(":
                if t in GLSL_TYPES or t in self.structs:
                    return ("ctor", t, self.args())
                return ("call", t, self.args())
            return ("id", t)
        raise TranslateError(f"WGSL translation: unexpected {t!r}")


def _wgsl_type(t: str) -> str:
    if t in WGSL_SCALARS:
        return WGSL_SCALARS[t]
    m = re.fullmatch(r"([biu]?)vec([234])", t)
    if m:
        return f"vec{m.group(2)}<{ {'': 'f32', 'i': 'i32', 'u': 'u32', 'b': 'bool'}[m.group(1)] }>"
    if t.startswith("mat"):
        raise TranslateError(f"WGSL translation: matrix type {t!r} is not supported")
    return t


class _WgslEmitter:
    def __init__(self, unit: list, structs: set[str]):
        self.unit = unit
        self.structs = structs
        self.sigs = {f[3]: [p[0] for p in f[4]] for f in unit if f[0] == "func"}
        self.ptrs: set[str] = set()     # pointer parameters of the current function
        self.uses_mod = False

    def name(self, n: str) -> str:
        return n + "_" if n in WGSL_RESERVED else n

    def type_(self, t: str, size=None) -> str:
        base = _wgsl_type(t)
        return f"array<{base}, {self.e(size)}>" if size is not None else base

    # expressions
    def e(self, x, parent: int | None = None) -> str:
        k = x[0]
        if k == "num":
            t = x[1]
            if t[-1] in "fF" and not t.lower().startswith("0x"):
                t = t[:-1]
            return t
        if k == "id":
            n = self.name(x[1])
            if x[1] in self.ptrs:
                return f"(*{n})" if parent == 99 else f"*{n}"
            return n
        if k == "paren":
            return self.e(x[1])             # binary children are parenthesised as needed
        if k == "member":
            return f"{self.e(x[1], 99)}.{x[2]}"
        if k == "index":
            return f"{self.e(x[1], 99)}[{self.e(x[2])}]"
        if k == "unary":
            return f"{x[1]}{self.e(x[2], 99)}"
        if k in ("postinc", "preinc"):
            return f"{self.e(x[2])}{x[1]}"
        if k == "binary":
            op, lhs, rhs = x[1], x[2], x[3]
            if op == "^^":
                op = "!="
            a = self.operand(lhs, op)
            b = self.operand(rhs, op, right=True)
            if op in ("<<", ">>") and rhs[0] != "num":
                b = f"u32({self.e(rhs)})"
            return f"{a} {op} {b}"
        if k == "ternary":
            return f"select({self.e(x[3])}, {self.e(x[2])}, {self.e(x[1])})"
        if k == "assign":
            return f"{self.e(x[2])} {x[1]} {self.e(x[3])}"
        if k == "ctor":
            t, args = x[1], x[2]
            return f"{_wgsl_type(t)}({', '.join(self.e(a) for a in args)})"
        if k == "arrctor":
            return (f"array<{_wgsl_type(x[1])}, {self.e(x[2])}>("
                    + ", ".join(self.e(a) for a in x[3]) + ")")
        if k == "call":
            fn, args = x[1], x[2]
            if fn in RELATIONAL:
                return f"({self.operand(args[0], '<')} {RELATIONAL[fn]} {self.operand(args[1], '<', True)})"
            if fn == "atan" and len(args) == 2:
                fn = "atan2"
            elif fn == "mod":
                fn = "cellgl_mod"
                self.uses_mod = True
            elif fn in ("texture", "texelFetch"):
                raise TranslateError(f"WGSL translation: {fn}() is not supported")
            else:
                fn = WGSL_FUNCS.get(fn, self.name(fn))
            modes = self.sigs.get(x[1])
            out = []
            for n, a in enumerate(args):
                if modes and modes[n] in ("out", "inout"):
                    if a[0] != "id":
                        raise TranslateError(
                            f"WGSL translation: argument {n + 1} of {x[1]}() must be a variable")
                    out.append(self.name(a[1]) if a[1] in self.ptrs else "&" + self.name(a[1]))
                else:
                    out.append(self.e(a))
            return f"{fn}({', '.join(out)})"
        raise AssertionError(k)

    def operand(self, x, op: str, right: bool = False) -> str:
        s = self.e(x)
        if x[0] == "paren":
            x = x[1]
        if x[0] in ("binary", "assign"):
            same = x[0] == "binary" and _PREC_OF[x[1]] == _PREC_OF[op] and op in "+*" and not right
            if not same or x[1] != op:
                return f"({s})"
        if x[0] == "unary" and op in ("<<", ">>", "&", "|", "^"):
            return f"({s})"
        return s

    # statements
    def comments(self, com: list, ind: str) -> list[str]:
        out = []
        for c in com:
            if isinstance(c, tuple):
                continue                    # a trailing comment: see stmt()
            if c == "":
                if out:
                    out.append("")
                continue
            for ln in c.split("\n"):
                out.append(ind + ln.strip() if ln.strip() else "")
        return out

    def stmt(self, s, ind: str, mutated: set[str]) -> list[str]:
        k, com = s[0], s[1]
        out = self.comments(com, ind)
        trail = [c[1] for c in com if isinstance(c, tuple)]
        out += self._stmt(s, ind, mutated)
        if trail:
            out[-1] += "  " + trail[0]
        return out

    def _stmt(self, s, ind: str, mutated: set[str]) -> list[str]:
        k = s[0]
        out: list[str] = []
        if k == "block":
            out.append(ind + "{")
            for t in s[2]:
                out += self.stmt(t, ind + "    ", mutated)
            out.append(ind + "}")
        elif k == "decl":
            out += [ind + d for d in self.decl(s[2], s[3], s[4], mutated)]
        elif k == "expr":
            out.append(ind + self.e(s[2]) + ";")
        elif k == "return":
            out.append(ind + ("return;" if s[2] is None else f"return {self.e(s[2])};"))
        elif k in ("break", "continue", "discard"):
            out.append(ind + k + ";")
        elif k == "if":
            out.append(f"{ind}if ({self.e(s[2])}) {{")
            out += self.body(s[3], ind, mutated)
            els = s[4]
            while els is not None:
                if els[0] == "if" and not els[1]:
                    out.append(f"{ind}}} else if ({self.e(els[2])}) {{")
                    out += self.body(els[3], ind, mutated)
                    els = els[4]
                else:
                    out.append(ind + "} else {")
                    out += self.body(els, ind, mutated)
                    els = None
            out.append(ind + "}")
        elif k == "for":
            init = ""
            if s[2] is not None:
                if s[2][0] == "decl":
                    d = self.decl(s[2][2], s[2][3], s[2][4], mutated)
                    if len(d) != 1:
                        raise TranslateError("WGSL translation: one variable per for-loop initialiser")
                    init = d[0][:-1]
                else:
                    init = self.e(s[2][2])
            cond = "" if s[3] is None else self.e(s[3])
            step = "" if s[4] is None else self.e(s[4])
            out.append(f"{ind}for ({init}; {cond}; {step}) {{")
            out += self.body(s[5], ind, mutated)
            out.append(ind + "}")
        elif k == "while":
            out.append(f"{ind}while ({self.e(s[2])}) {{")
            out += self.body(s[3], ind, mutated)
            out.append(ind + "}")
        else:  # pragma: no cover
            raise AssertionError(k)
        return out

    def body(self, s, ind: str, mutated: set[str]) -> list[str]:
        inner = ind + "    "
        if s[0] == "block":
            out = self.comments(s[1], inner)
            for t in s[2]:
                out += self.stmt(t, inner, mutated)
            return out
        return self.stmt(s, inner, mutated)

    def decl(self, const: bool, typ: str, decls, mutated: set[str]) -> list[str]:
        out = []
        for name, size, init in decls:
            kw = "let" if const else "var"
            wt = self.type_(typ, size)
            if init is None:
                out.append(f"var {self.name(name)}: {wt};")
            else:
                out.append(f"{kw} {self.name(name)}: {wt} = {self.e(init)};")
        return out

    # top level
    def emit(self) -> str:
        out: list[str] = []
        for item in self.unit:
            k, com = item[0], item[1]
            out += self.comments(com, "")
            if k == "struct":
                out.append(f"struct {item[2]} {{")
                for mcom, typ, mname, size, trail in item[3]:
                    out += self.comments(mcom, "    ")
                    out.append(f"    {self.name(mname)}: {self.type_(typ, size)},"
                               + (f"  {trail}" if trail else ""))
                out.append("};")
            elif k == "gdecl":
                quals, typ, decls = item[2], item[3], item[4]
                for name, size, init in decls:
                    if "uniform" in quals:
                        raise TranslateError("WGSL translation: uniforms need bindings; "
                                             "export WGSL with constants (without --uniforms)")
                    if init is None:
                        raise TranslateError(f"WGSL translation: global {name!r} needs a value")
                    kw = "const" if "const" in quals else "var<private>"
                    out.append(f"{kw} {self.name(name)}: {self.type_(typ, size)} = {self.e(init)};")
            elif k == "func":
                out += self.func(item)
            out.append("")
        return "\n".join(out)

    def func(self, item) -> list[str]:
        _, _, ret, name, params, body = item
        self.ptrs = {p[2] for p in params if p[0] in ("out", "inout")}
        mutated = set()
        _find_mutated(body, mutated, self.sigs)
        plist, prologue = [], []
        for mode, typ, pname, size in params:
            wt = self.type_(typ, size)
            if mode in ("out", "inout"):
                plist.append(f"{self.name(pname)}: ptr<function, {wt}>")
            elif pname in mutated:
                plist.append(f"{self.name(pname)}_in: {wt}")
                prologue.append(f"    var {self.name(pname)}: {wt} = {self.name(pname)}_in;")
            else:
                plist.append(f"{self.name(pname)}: {wt}")
        rt = "" if ret == "void" else f" -> {self.type_(ret)}"
        out = [f"fn {self.name(name)}({', '.join(plist)}){rt}", "{"] + prologue
        for s in body:
            out += self.stmt(s, "    ", mutated)
        out.append("}")
        self.ptrs = set()
        return out


def _root_name(x):
    while x[0] in ("member", "index", "paren"):
        x = x[1]
    return x[1] if x[0] == "id" else None


def _find_mutated(node, out: set[str], sigs: dict) -> None:
    """Names assigned to (``x = ...``, ``x.y += ...``, ``x++``) or passed as out/inout."""
    if isinstance(node, list):
        for n in node:
            _find_mutated(n, out, sigs)
        return
    if not isinstance(node, tuple) or not node:
        return
    k = node[0]
    if k == "assign":
        r = _root_name(node[2])
        if r:
            out.add(r)
    elif k in ("postinc", "preinc"):
        r = _root_name(node[2])
        if r:
            out.add(r)
    elif k == "call" and node[1] in sigs:
        for mode, a in zip(sigs[node[1]], node[2]):
            if mode in ("out", "inout"):
                r = _root_name(a)
                if r:
                    out.add(r)
    for child in node[1:]:
        if isinstance(child, (tuple, list)):
            _find_mutated(child, out, sigs)


def to_wgsl(text: str) -> str:
    """Translate specialised, prefixed GLSL (library subset) into WGSL.

    Declarations become ``var``/``let``/``const`` with WGSL types, ``out``/``inout`` parameters
    become ``ptr<function, T>`` (callers pass ``&x``), parameters that the body assigns are
    copied into a ``var``, ternaries become ``select()`` (the library's ternaries have no side
    effects), brace-less loop bodies get braces, and binary operations inside others are
    parenthesised (WGSL does not allow mixing e.g. ``&&`` and ``||`` without them).
    """
    p = _Parser(text)
    unit = p.unit()
    em = _WgslEmitter(unit, p.structs)
    body = em.emit()
    if em.uses_mod:
        body = ("// GLSL mod(): x - y * floor(x / y).\n"
                "fn cellgl_mod(x: f32, y: f32) -> f32 { return x - y * floor(x / y); }\n\n" + body)
    return body.rstrip() + "\n"
