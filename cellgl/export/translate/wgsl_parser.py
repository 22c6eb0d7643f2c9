"""Step 3b, first half: the WGSL and OSL emitters' view of :mod:`cellgl.export.syntax`'s typed
tree (nested tuples: ``("binary", op, left, right)``, ...), and WGSL's names."""
from __future__ import annotations

from cellgl.export import syntax as st
from cellgl.export.translate.tokens import TranslateError

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

_PREC_OF = st.PRECEDENCE


def _e(x):
    """The tuple of an expression node."""
    if x is None:
        return None
    if isinstance(x, st.Num):
        return ("num", x.text)
    if isinstance(x, st.Name):
        return ("id", x.name)
    if isinstance(x, st.Paren):
        return ("paren", _e(x.inner))
    if isinstance(x, st.Member):
        return ("member", _e(x.base), x.name)
    if isinstance(x, st.Index):
        return ("index", _e(x.base), _e(x.index))
    if isinstance(x, st.Unary):
        return ("unary", x.op, _e(x.operand))
    if isinstance(x, st.IncDec):
        return ("postinc" if x.postfix else "preinc", x.op, _e(x.operand))
    if isinstance(x, st.Binary):
        return ("binary", x.op, _e(x.left), _e(x.right))
    if isinstance(x, st.Assign):
        return ("assign", x.op, _e(x.target), _e(x.value))
    if isinstance(x, st.Ternary):
        return ("ternary", _e(x.cond), _e(x.then), _e(x.other))
    if isinstance(x, st.Ctor):
        return ("ctor", x.type, [_e(a) for a in x.args])
    if isinstance(x, st.ArrayCtor):
        return ("arrctor", x.type, _e(x.size), [_e(a) for a in x.args])
    if isinstance(x, st.Call):
        return ("call", x.func, [_e(a) for a in x.args])
    raise TranslateError(f"unexpected node {x!r}")


def _decls(ds) -> list:
    return [(d.name, _e(d.size), _e(d.init)) for d in ds]


def _s(s):
    """The tuple of a statement node (comments first, a trailing one as ``("trail", text)``)."""
    com = list(s.comments)
    if isinstance(s, st.Block):
        return ("block", com, [_s(x) for x in s.body])
    if isinstance(s, st.If):
        return ("if", com, _e(s.cond), _s(s.then), None if s.other is None else _s(s.other))
    if isinstance(s, st.For):
        return ("for", com, None if s.init is None else _s(s.init), _e(s.cond), _e(s.step), _s(s.body))
    if isinstance(s, st.While):
        return ("while", com, _e(s.cond), _s(s.body))
    if isinstance(s, st.Return):
        return ("return", com, _e(s.value))
    if isinstance(s, st.Jump):
        return (s.kind, com)
    if s.trail:
        com.append(("trail", s.trail))
    if isinstance(s, st.Decl):
        return ("decl", com, s.const, s.type, _decls(s.declarators))
    return ("expr", com, _e(s.expr))


class _Parser:
    """The parse of ``text`` (:func:`cellgl.export.syntax.parse`; or ``text`` is a tree) as the
    emitters' tuples:
    ``unit()`` lists ``("struct", comments, name, [[comments, type, name, size, trail]])``,
    ``("gdecl", comments, qualifiers, type, declarators)`` and ``("func", comments, return type,
    name, [(mode, type, name, size)], statements)`` (prototypes left out: WGSL and OSL need
    none); ``structs`` names the structs."""

    def __init__(self, text):
        self.tree = text if isinstance(text, st.Unit) else st.parse(text)
        self.structs = {it.name for it in self.tree.items if isinstance(it, st.Struct)}

    def unit(self) -> list:
        out = []
        for it in self.tree.items:
            com = list(it.comments)
            if isinstance(it, st.Struct):
                out.append(("struct", com, it.name,
                            [[f.comments, f.type, f.name, _e(f.size), f.trail] for f in it.fields]))
            elif isinstance(it, st.Global):
                out.append(("gdecl", com, list(it.quals), it.type, _decls(it.declarators)))
            elif it.body is not None:
                params = [(p.mode, p.type, p.name, _e(p.size)) for p in it.params]
                out.append(("func", com, it.ret, it.name, params, [_s(x) for x in it.body.body]))
        return out
