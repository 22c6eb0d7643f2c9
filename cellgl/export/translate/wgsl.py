"""WGSL printed from :mod:`cellgl.export.syntax`'s tree: :class:`Wgsl`, the hooks of
:class:`cellgl.export.printer.Glsl` that WGSL spells differently."""
from __future__ import annotations

from cellgl.export.printer import RELATIONAL, Glsl
from cellgl.export import syntax as S
from cellgl.export.translate.tokens import TranslateError
from cellgl.export.tree import root_name, walk

WGSL_SCALARS = {"float": "f32", "int": "i32", "uint": "u32", "bool": "bool"}
WGSL_FUNCS = {"inversesqrt": "inverseSqrt", "dFdx": "dpdx", "dFdy": "dpdy",
              "floatBitsToUint": "bitcast<u32>", "floatBitsToInt": "bitcast<i32>",
              "uintBitsToFloat": "bitcast<f32>", "intBitsToFloat": "bitcast<f32>"}
#: WGSL keywords and reserved words that are legal GLSL identifiers
WGSL_RESERVED = frozenset("""
    alias const_assert continuing diagnostic enable fn let loop override requires var ptr array atomic
    sampler texture_2d f32 i32 u32 f16 vec2 vec3 vec4 mat2x2 mat3x3 mat4x4 bitcast select target type
    self super unless where with yield as async await become cast catch class co_await co_return
    co_yield coherent column_major common compile compile_fragment concept const_cast consteval
    constexpr constinit crate debugger decltype delete demote demote_to_helper do dynamic_cast enum
    explicit export extends extern external fallthrough filter final finally friend from fxgroup get
    goto groupshared highp impl implements import inline instanceof interface layout lowp macro
    macro_rules match mediump meta mod module move mut mutable namespace new nil noexcept noinline
    nointerpolation noperspective null nullptr of operator package packoffset partition pass patch
    pixelfragment precise precision premerge priv protected pub public readonly ref regardless register
    reinterpret_cast require resource restrict set shared sizeof smooth snorm static static_assert
    static_cast std subroutine template this thread_local throw trait try typedef typeid typename typeof
    union unorm unsafe unsized use using varying virtual volatile wgsl writeonly sample line point
""".split())


def _bare(e):
    while isinstance(e, S.Paren):
        e = e.inner
    return e


class Wgsl(Glsl):
    """WGSL: declarations ``var``/``let``/``const`` with WGSL types, ``out``/``inout`` parameters
    ``ptr<function, T>`` (callers pass ``&x``), parameters that the body assigns copied into a
    ``var``, ternaries as ``select()`` (the library's ternaries have no side effects), every
    loop and branch body braced, and a binary operation inside another parenthesised (WGSL does
    not allow mixing e.g. ``&&`` and ``||`` without them)."""

    def __init__(self, unit: S.Unit):
        super().__init__(kr=True, blank=False)
        self.modes = {f.name: [p.mode for p in f.params] for f in unit.items if isinstance(f, S.Function)}
        self.ptrs: set[str] = set()                 # the pointer parameters of the function printed
        self.uses_mod = False

    def type(self, t: str, size=None) -> str:
        if t.startswith("mat"):
            raise TranslateError(f"WGSL translation: matrix type {t!r} is not supported")
        base = WGSL_SCALARS.get(t, t)
        if t[:-1].endswith("vec") and t[-1] in "234":
            base = f"vec{t[-1]}<{ {'': 'f32', 'i': 'i32', 'u': 'u32', 'b': 'bool'}[t[:-4]] }>"
        return f"array<{base}, {self.expr(size)}>" if size is not None else base

    def name(self, n: str) -> str:
        return n + "_" if n in WGSL_RESERVED else n

    # expressions
    def tight(self, e) -> str:
        """``e`` as the base of ``.``, ``[]`` or a unary operator."""
        b = _bare(e)
        s = self.expr(b)
        wrap = isinstance(b, (S.Binary, S.Ternary, S.Assign)) or isinstance(b, S.Name) and b.name in self.ptrs
        return f"({s})" if wrap else s

    def operand(self, e, op: str, right: bool = False) -> str:
        e = _bare(e)
        s = self.expr(e)
        chain = isinstance(e, S.Binary) and e.op == op and op in "+*" and not right     # a + b + c
        if isinstance(e, (S.Binary, S.Assign)) and not chain:
            return f"({s})"
        return f"({s})" if isinstance(e, S.Unary) and op in ("<<", ">>", "&", "|", "^") else s

    def expr(self, e) -> str:
        if isinstance(e, S.Num):
            return e.text[:-1] if e.text[-1] in "fF" and not e.text.lower().startswith("0x") else e.text
        if isinstance(e, S.Name):
            return ("*" if e.name in self.ptrs else "") + self.name(e.name)
        if isinstance(e, S.Paren):
            return self.expr(e.inner)                  # operands are parenthesised as needed
        if isinstance(e, S.Member):
            return f"{self.tight(e.base)}.{self.name(e.name)}"
        if isinstance(e, S.Index):
            return f"{self.tight(e.base)}[{self.expr(e.index)}]"
        if isinstance(e, S.Unary):
            return e.op + self.tight(e.operand)
        if isinstance(e, S.IncDec):
            return self.expr(e.operand) + e.op       # statements only in WGSL
        if isinstance(e, S.Binary):
            op = "!=" if e.op == "^^" else e.op
            b = self.operand(e.right, op, True)
            if op in ("<<", ">>") and not isinstance(_bare(e.right), S.Num):
                b = f"u32({self.expr(e.right)})"
            return f"{self.operand(e.left, op)} {op} {b}"
        if isinstance(e, S.Ternary):
            return f"select({self.expr(e.other)}, {self.expr(e.then)}, {self.expr(e.cond)})"
        return super().expr(e)

    def array_ctor(self, e: S.ArrayCtor) -> str:
        return f"array<{self.type(e.type)}, {self.expr(e.size)}>({self.args(e.args)})"

    def call(self, e: S.Call) -> str:
        f, args = e.func, e.args
        if f in RELATIONAL:
            return f"({self.operand(args[0], '<')} {RELATIONAL[f]} {self.operand(args[1], '<', True)})"
        if f == "atan" and len(args) == 2:
            f = "atan2"
        elif f == "mod":
            f, self.uses_mod = "cellgl_mod", True
        elif f in ("texture", "texelFetch"):
            raise TranslateError(f"WGSL translation: {f}() is not supported")
        else:
            f = WGSL_FUNCS.get(f, self.name(f))
        out = []
        for n, (a, mode) in enumerate(zip(args, self.modes.get(e.func, ["in"] * len(args)))):
            if mode == "in":
                out.append(self.expr(a))
            elif not isinstance(_bare(a), S.Name):
                raise TranslateError(f"WGSL translation: argument {n + 1} of {e.func}() must be a variable")
            else:
                out.append(self.name(_bare(a).name) if _bare(a).name in self.ptrs else "&" + self.name(_bare(a).name))
        return f"{f}({', '.join(out)})"

    # statements
    def decls(self, s: S.Decl) -> list[str]:
        return [f"var {self.name(d.name)}: {self.type(s.type, d.size)};" if d.init is None else
                f"{'let' if s.const else 'var'} {self.name(d.name)}: {self.type(s.type, d.size)} = {self.expr(d.init)};"
                for d in s.declarators]

    def simple(self, s) -> str:
        if isinstance(s, S.Decl):                       # a for-loop's initialiser
            if len(s.declarators) != 1:
                raise TranslateError("WGSL translation: one variable per for-loop initialiser")
            return self.decls(s)[0][:-1]
        return self.expr(s.expr)

    def head(self, head: str, body, ind: str) -> list[str]:
        """Every loop and branch body braced, a statement or a block (its comments inside)."""
        if isinstance(body, S.Block):
            inner = self.comments(body.comments, ind + "    ") + self.body(body, ind)
        else:
            inner = self.statement(body, ind + "    ")
        return [f"{ind}{head} {{" + _trail(body)] + inner + [ind + "}"]

    def statement(self, s, ind: str = "") -> list[str]:
        if isinstance(s, S.Decl):                       # one declaration per variable
            lines = [ind + d for d in self.decls(s)]
            trail = f"  {s.trail}" if s.trail else ""
            return self.comments(s.comments, ind) + lines[:-1] + [lines[-1] + trail]
        if isinstance(s, S.For):                        # "; ; " where GLSL has ";;"
            parts = ("" if x is None else f(x)
                     for x, f in ((s.init, self.simple), (s.cond, self.expr), (s.step, self.expr)))
            return self.comments(s.comments, ind) + self.head(f"for ({'; '.join(parts)})", s.body, ind)
        other = getattr(s, "other", None)
        if other is not None and (other.comments or not isinstance(other, (S.If, S.Block))):
            # an else GLSL writes without braces (or one with comments): "} else {", as every body
            first = super().statement(S.If(s.cond, s.then, None, s.comments), ind)
            return first[:-1] + self.head("} else", other, ind)
        return super().statement(s, ind)

    # top level
    def item(self, it) -> list[str]:
        out = self.comments(it.comments, "")
        if isinstance(it, S.Struct):
            out.append(f"struct {it.name} {{")
            for f in it.fields:
                out += self.comments(f.comments, "    ")
                out.append(f"    {self.name(f.name)}: {self.type(f.type, f.size)}," + (f"  {f.trail}" if f.trail else ""))
            return out + ["};"]
        if isinstance(it, S.Global):
            for d in it.declarators:
                if "uniform" in it.quals:
                    raise TranslateError("WGSL translation: uniforms need bindings; "
                                         "export WGSL with constants (without --uniforms)")
                if d.init is None:
                    raise TranslateError(f"WGSL translation: global {d.name!r} needs a value")
                kw = "const" if "const" in it.quals else "var<private>"
                out.append(f"{kw} {self.name(d.name)}: {self.type(it.type, d.size)} = {self.expr(d.init)};")
            return out
        if it.body is None:
            return []                                   # a prototype: WGSL needs none
        self.ptrs = {p.name for p in it.params if p.mode != "in"}
        mutated = assigned(it.body, self.modes)
        plist, prologue = [], []
        for p in it.params:
            t = self.type(p.type, p.size)
            if p.mode != "in":
                plist.append(f"{self.name(p.name)}: ptr<function, {t}>")
            elif p.name in mutated:
                plist.append(f"{self.name(p.name)}_in: {t}")
                prologue.append(f"    var {self.name(p.name)}: {t} = {self.name(p.name)}_in;")
            else:
                plist.append(f"{self.name(p.name)}: {t}")
        rt = "" if it.ret == "void" else f" -> {self.type(it.ret)}"
        out += [f"fn {self.name(it.name)}({', '.join(plist)}){rt} {{" + _trail(it.body)] + prologue + self.body(it.body, "")
        self.ptrs = set()
        return out + ["}"]

    def prelude(self) -> list[str]:
        return ["// GLSL mod(): x - y * floor(x / y).",
                "fn cellgl_mod(x: f32, y: f32) -> f32 { return x - y * floor(x / y); }"] if self.uses_mod else []


def assigned(body, modes: dict) -> set:
    """The variables ``body`` assigns, increments or passes as an ``out``/``inout`` argument
    (``modes``: the parameter modes of each function it may call)."""
    return ({root_name(n.target if isinstance(n, S.Assign) else n.operand)
             for n in walk(body) if isinstance(n, (S.Assign, S.IncDec))}
            | {root_name(a) for n in walk(body) if isinstance(n, S.Call)
               for a, m in zip(n.args, modes.get(n.func, ())) if m != "in"})


def _trail(block) -> str:
    return f"  {block.trail}" if isinstance(block, S.Block) and block.trail else ""


def to_wgsl(code) -> str:
    """WGSL of specialised, prefixed GLSL (library subset): its tree, or its text."""
    unit = code if isinstance(code, S.Unit) else S.parse(code)
    return Wgsl(unit).unit(unit)
