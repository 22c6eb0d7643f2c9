"""Step 3b, first half: a parser of the GLSL subset the library uses, into a small tree the
WGSL emitter walks."""
from __future__ import annotations

from cellgl.export.translate.tokens import GLSL_TYPES, TranslateError, tokenize

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
