"""Step 3a: token-level translation of specialised GLSL to HLSL."""
from __future__ import annotations

from cellgl.export.translate.names import top_level_names
from cellgl.export.translate.tokens import (
    GLSL_TYPES,
    Tok,
    TranslateError,
    _code,
    _join,
    tokenize,
)

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
    return "\n".join(lines) + "\n"


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
