"""Shader text of :mod:`cellgl.export.syntax`'s tree: GLSL and the dialects printed like it.

:class:`Glsl` prints GLSL (4-space indentation, a block's brace on the line that opens it, the
comments where they were, parentheses as written); its hooks (:meth:`Glsl.type`,
:meth:`Glsl.decl_type`, :meth:`Glsl.name`, :meth:`Glsl.call`, :meth:`Glsl.ctor`, ...) are where a
dialect differs: :class:`Gles` pins declarations to ``highp``, :class:`Hlsl` spells types,
built-ins, constructors and ``mod`` the HLSL way. Godot's shading language reads the library's
GLSL subset as it is (its float and int defaults are highp), so Godot prints as :class:`Glsl`.
:func:`print_target` prints a snippet's code for a target dialect; :func:`print_glsl` the
compiler's text (an item per paragraph, a function's brace on its own line).
"""
from __future__ import annotations

from cellgl.export import syntax as S
from cellgl.export.syntax import PRECEDENCE
from cellgl.export.translate.tokens import GLSL_TYPES, TranslateError

__all__ = ["Glsl", "Gles", "Hlsl", "print_glsl", "print_target", "print_lines", "expr_glsl", "statement_glsl", "item_glsl",
           "RELATIONAL", "operand", "trail_comment"]

#: GLSL's component-wise relational functions and the infix operator each is (HLSL, WGSL, OSL)
RELATIONAL = {"lessThan": "<", "lessThanEqual": "<=", "greaterThan": ">", "greaterThanEqual": ">=",
              "equal": "==", "notEqual": "!="}


def operand(e, text: str, op: str) -> str:
    """``text`` (the printed ``e``) as an operand of the binary operator ``op``: in parentheses
    where ``e`` binds no tighter than ``op`` (an assignment, a ternary, a looser operator)."""
    if isinstance(e, (S.Assign, S.Ternary)) or (isinstance(e, S.Binary) and PRECEDENCE[e.op] <= PRECEDENCE[op]):
        return f"({text})"
    return text


class Glsl:
    """GLSL text of a tree. ``kr``: a function's opening brace on its signature line (the
    snippets) rather than on its own line; ``blank``: a blank line between top-level items."""

    def __init__(self, *, kr: bool = False, blank: bool = True):
        self.kr = kr
        self.blank = blank

    # ---------------------------------------------------------------- hooks
    def type(self, t: str) -> str:
        """A type where it is used (constructors, casts)."""
        return t

    def decl_type(self, t: str) -> str:
        """A type where it declares something (variables, parameters, members, results)."""
        return self.type(t)

    def name(self, n: str) -> str:
        """A declared or referenced name."""
        return n

    def quals(self, quals: list) -> list:
        """The qualifiers of a global (``const``, ``uniform``)."""
        return quals

    def call(self, e: S.Call) -> str:
        return f"{self.name(e.func)}({self.args(e.args)})"

    def ctor(self, e: S.Ctor) -> str:
        return f"{self.type(e.type)}({self.args(e.args)})"

    def array_ctor(self, e: S.ArrayCtor) -> str:
        return f"{self.type(e.type)}[{self.expr(e.size)}]({self.args(e.args)})"

    def jump(self, kind: str) -> str:
        return kind + ";"

    def prelude(self) -> list[str]:
        """Lines before the first item, known once the items are printed (HLSL's helpers)."""
        return []

    # ---------------------------------------------------------------- expressions
    def args(self, args: list) -> str:
        return ", ".join(self.expr(a) for a in args)

    def expr(self, e) -> str:
        """The text of an expression node."""
        show = _EXPR.get(type(e))
        if show is None:
            raise TypeError(f"not an expression node: {e!r}")
        return show(self, e)

    # ---------------------------------------------------------------- statements
    @staticmethod
    def comments(com: list, ind: str) -> list[str]:
        out: list[str] = []
        for c in com:
            out += [ind + ln.strip() if ln.strip() else "" for ln in c.split("\n")] if c else [""]
        return out

    def array_name(self, x) -> str:
        """The name of a declarator, parameter or member, and its array size."""
        return self.name(x.name) + (f"[{self.expr(x.size)}]" if x.size is not None else "")

    def declarators(self, typ: str, decls: list) -> str:
        parts = [self.array_name(d) + (f" = {self.expr(d.init)}" if d.init is not None else "")
                 for d in decls]
        return f"{self.decl_type(typ)} {', '.join(parts)}"

    def simple(self, s) -> str:
        if isinstance(s, S.Decl):
            return ("const " if s.const else "") + self.declarators(s.type, s.declarators)
        return self.expr(s.expr)

    def statement(self, s, ind: str = "") -> list[str]:
        """Lines of a statement node at indentation ``ind``."""
        out = self.comments(s.comments, ind)
        if isinstance(s, S.Block):
            return out + [ind + "{" + trail_comment(s)] + self.body(s, ind) + [ind + "}"]
        if isinstance(s, (S.Decl, S.ExprStmt)):
            return out + [ind + self.simple(s) + ";" + trail_comment(s)]
        if isinstance(s, S.Return):
            return out + [ind + ("return;" if s.value is None else f"return {self.expr(s.value)};")]
        if isinstance(s, S.Jump):
            return out + [ind + self.jump(s.kind)]
        if isinstance(s, S.If):
            out += self.head(f"if ({self.expr(s.cond)})", s.then, ind)
            other = s.other
            if other is None:
                return out
            if out[-1] == ind + "}" and isinstance(other, (S.If, S.Block)) and not other.comments:
                first, *rest = self.statement(other, ind)          # } else if (...) {, } else {
                return out[:-1] + [f"{ind}}} else {first.lstrip()}"] + rest
            return out + [ind + "else"] + self.statement(other, ind + "    ")
        if isinstance(s, S.For):
            init = "" if s.init is None else self.simple(s.init)
            cond = "" if s.cond is None else " " + self.expr(s.cond)
            step = "" if s.step is None else " " + self.expr(s.step)
            return out + self.head(f"for ({init};{cond};{step})", s.body, ind)
        if isinstance(s, S.While):
            return out + self.head(f"while ({self.expr(s.cond)})", s.body, ind)
        raise TypeError(f"not a statement node: {s!r}")

    def body(self, block: S.Block, ind: str) -> list[str]:
        """The lines of a block's statements (a statement written on the line of the one before
        it stays there, as the library pairs short ones)."""
        out: list[str] = []
        prev = None
        for x in block.body:
            lines = self.statement(x, ind + "    ")
            if getattr(x, "same_line", False) and not x.comments and isinstance(prev, (S.Decl, S.ExprStmt)) \
                    and not prev.trail:
                out[-1:] = [out[-1] + " " + lines[0].lstrip()] + lines[1:]
            else:
                out += lines
            prev = x
        return out

    def head(self, head: str, body, ind: str) -> list[str]:
        if isinstance(body, S.Block) and not body.comments:
            return [f"{ind}{head} {{" + trail_comment(body)] + self.body(body, ind) + [ind + "}"]
        if isinstance(body, (S.For, S.While)) and not body.comments:       # a loop nest: one level
            return [ind + head] + self.statement(body, ind)
        return [ind + head] + self.statement(body, ind + "    ")

    # ---------------------------------------------------------------- top level
    def param(self, p) -> str:
        return (("const " if p.const else "") + (p.mode + " " if p.mode != "in" else "")
                + f"{self.decl_type(p.type)} {self.array_name(p)}")

    def item(self, it) -> list[str]:
        """Lines of a top-level node."""
        out = self.comments(it.comments, "")
        if isinstance(it, S.Struct):
            out.append(f"struct {self.name(it.name)} {{")
            for f in it.fields:
                out += self.comments(f.comments, "    ")
                out.append(f"    {self.decl_type(f.type)} {self.array_name(f)};" + trail_comment(f))
            return out + ["};"]
        if isinstance(it, S.Global):
            return out + [" ".join(self.quals(it.quals) + [self.declarators(it.type, it.declarators)]) + ";"]
        if isinstance(it, S.Function):
            sig = f"{self.decl_type(it.ret)} {self.name(it.name)}({', '.join(self.param(p) for p in it.params)})"
            if it.body is None:
                return out + [sig + ";"]
            opening = [sig + " {" + trail_comment(it.body)] if self.kr else [sig, "{" + trail_comment(it.body)]
            return out + opening + self.body(it.body, "") + ["}"]
        raise TypeError(f"not a top-level node: {it!r}")

    def unit(self, unit: S.Unit) -> str:
        """The text of a tree: its items (one blank line apart if ``blank``), then the comments
        after the last."""
        parts = ["\n".join(lines) for lines in map(self.item, unit.items) if lines]
        if unit.trailing:
            parts.append("\n".join(self.comments(unit.trailing, "")))
        text = ("\n\n" if self.blank else "\n").join(parts) + "\n"
        pre = self.prelude()
        return "\n".join(pre) + "\n" + text if pre else text


#: how :meth:`Glsl.expr` prints each expression node (the hooks where a dialect differs)
_EXPR = {
    S.Num: lambda p, e: e.text,
    S.Name: lambda p, e: p.name(e.name),
    S.Paren: lambda p, e: f"({p.expr(e.inner)})",
    S.Call: lambda p, e: p.call(e),
    S.Ctor: lambda p, e: p.ctor(e),
    S.ArrayCtor: lambda p, e: p.array_ctor(e),
    S.Unary: lambda p, e: e.op + p.expr(e.operand),
    S.IncDec: lambda p, e: p.expr(e.operand) + e.op if e.postfix else e.op + p.expr(e.operand),
    S.Binary: lambda p, e: f"{p.expr(e.left)} {e.op} {p.expr(e.right)}",
    S.Assign: lambda p, e: f"{p.expr(e.target)} {e.op} {p.expr(e.value)}",
    S.Ternary: lambda p, e: f"{p.expr(e.cond)} ? {p.expr(e.then)} : {p.expr(e.other)}",
    S.Index: lambda p, e: f"{p.expr(e.base)}[{p.expr(e.index)}]",
    S.Member: lambda p, e: f"{p.expr(e.base)}.{p.name(e.name)}",
}


def trail_comment(node) -> str:
    """The ``//`` comment on the rest of a node's line (a statement's, a member's, after a block's brace)."""
    return f"  {node.trail}" if getattr(node, "trail", "") else ""


#: the GLSL types a GLSL ES declaration pins to highp
_PRECISION_TYPES = GLSL_TYPES - {"void", "bool", "bvec2", "bvec3", "bvec4"}


class Gles(Glsl):
    """GLSL ES 3.00: every float, int and uint declaration ``highp`` (the default int precision
    of ES fragment shaders is mediump, 16 bits on some GPUs, which would break the 32-bit hashes;
    qualifying each declaration leaves the user's own ``precision`` statements alone)."""

    def decl_type(self, t: str) -> str:
        return f"highp {t}" if t in _PRECISION_TYPES else t


class Hlsl(Glsl):
    """HLSL (SM 4+/5, DXC and FXC): vector types renamed (``vec4`` -> ``float4``), one-argument
    vector constructors as casts (``vec4(x)`` -> ``((float4)(x))``: splat or conversion), array
    and struct constructors as initialiser lists, global ``const`` as ``static const``,
    relational functions as operators, ``mod`` as a helper with GLSL's floor semantics (HLSL's
    ``fmod`` truncates), built-ins renamed (:data:`FUNCS`), names HLSL reserves suffixed ``_``;
    what has no translation (:data:`UNSUPPORTED`) raises :class:`TranslateError`."""

    TYPES = {f"{g}vec{n}": f"{h}{n}" for g, h in (("", "float"), ("i", "int"), ("u", "uint"), ("b", "bool"))
             for n in (2, 3, 4)}
    #: GLSL built-in -> HLSL built-in (same arguments)
    FUNCS = {"fract": "frac", "mix": "lerp", "inversesqrt": "rsqrt", "dFdx": "ddx", "dFdy": "ddy",
             "floatBitsToUint": "asuint", "floatBitsToInt": "asint", "uintBitsToFloat": "asfloat",
             "intBitsToFloat": "asfloat"}
    #: identifiers HLSL (or its effect syntax) reserves that are legal GLSL names
    RESERVED = frozenset("""
        point line lineadj triangle triangleadj sample linear centroid nointerpolation noperspective
        precise groupshared shared static unorm snorm packoffset register vector matrix half double
        dword string sampler compile pass technique row_major column_major export extern
        globallycoherent interface namespace class typedef volatile inline min16float min10float
        min16int min12int min16uint cbuffer tbuffer Buffer asm template this unsigned auto catch char
        signed sizeof throw try union using virtual
    """.split())
    #: GLSL constructs with no mechanical translation here
    UNSUPPORTED = {"mat2", "mat3", "mat4", "sampler2D", "sampler3D", "texture", "texelFetch", "discard",
                   "gl_FragCoord", "gl_FragColor"}

    def __init__(self):
        super().__init__(kr=True, blank=False)
        self.uses_mod = False

    def _check(self, n: str) -> str:
        if n in self.UNSUPPORTED:
            raise TranslateError(f"{n!r} has no HLSL translation in cellgl's exporter")
        return n

    def type(self, t: str) -> str:
        return self.TYPES.get(self._check(t), t)

    def name(self, n: str) -> str:
        return n + "_" if self._check(n) in self.RESERVED else n

    def quals(self, quals: list) -> list:
        return ["static const" if q == "const" else q for q in quals]

    def jump(self, kind: str) -> str:
        return self._check(kind) + ";"

    def call(self, e: S.Call) -> str:
        f, args = self._check(e.func), e.args
        if f in RELATIONAL:
            if len(args) != 2:
                raise TranslateError(f"{f} needs 2 arguments, got {len(args)}")
            a, b = (operand(x, self.expr(x), RELATIONAL[f]) for x in args)
            return f"({a} {RELATIONAL[f]} {b})"
        if f == "atan" and len(args) == 2:
            f = "atan2"
        elif f == "mod":
            f, self.uses_mod = "cellgl_mod", True
        else:
            f = self.FUNCS.get(f, self.name(f))
        return f"{f}({self.args(args)})"

    def ctor(self, e: S.Ctor) -> str:
        if e.type not in GLSL_TYPES:                    # a struct: an initialiser list
            return "{" + self.args(e.args) + "}"
        if e.type in self.TYPES and len(e.args) == 1:   # a splat or a conversion: a cast
            return f"(({self.type(e.type)})({self.expr(e.args[0])}))"
        return super().ctor(e)

    def array_ctor(self, e: S.ArrayCtor) -> str:
        return "{" + self.args(e.args) + "}"

    def prelude(self) -> list[str]:
        if not self.uses_mod:
            return []
        return ["// GLSL mod(): x - y * floor(x / y) (HLSL's fmod truncates instead)."] + [
            f"{t} cellgl_mod({t} x, {y} y) {{ return x - y * floor(x / y); }}"       # y: a vector, or a float
            for t in ("float", "float2", "float3", "float4") for y in dict.fromkeys((t, "float"))]


#: the printer of each snippet dialect (Godot: GLSL's; see the module's text)
DIALECTS = {"glsl": lambda: Glsl(kr=True, blank=False), "godot": lambda: Glsl(kr=True, blank=False),
            "gles": lambda: Gles(kr=True, blank=False), "hlsl": Hlsl}


def print_target(unit: S.Unit, dialect: str) -> str:
    """The snippet text of ``unit`` in ``dialect`` (``glsl``, ``gles``, ``godot``, ``hlsl``):
    items one after the other, a function's brace on its signature line."""
    return DIALECTS[dialect]().unit(unit)


_GLSL = Glsl()
#: GLSL of an expression node; the lines of a statement node (at an indentation); of a top-level node; the
#: text of a tree (its items one blank line apart, a function's brace on its own line)
expr_glsl, statement_glsl, item_glsl, print_glsl = _GLSL.expr, _GLSL.statement, _GLSL.item, _GLSL.unit


def print_lines(unit: S.Unit, width: int = 120) -> str:
    """GLSL text of a compiled tree: :func:`item_glsl` of its items, one after another (no blank
    line); a statement or signature longer than ``width`` broken (:func:`_wrap`; a global's
    initialiser, a table of values, stays on its line)."""
    out = []
    for it in unit.items:
        for line in item_glsl(it):
            out += [line] if isinstance(it, S.Global) else _wrap(line, width)
    return "".join(ln + "\n" for ln in out)


def _wrap(line: str, width: int) -> list[str]:
    """A printed line as lines of at most ``width`` columns where it can be: broken after a comma
    inside brackets (the rest aligned after the bracket) or before a binary ``&&``, ``||``, ``+``
    or ``-`` (the rest indented 4 more columns), in the outermost brackets that leave a break
    that fits, as late as fits (or wherever gives fewer lines); a comment line stays whole."""
    if len(line) <= width or "//" in line:
        return [line]
    ind = len(line) - len(line.lstrip())
    cuts = []                                  # (where the rest starts, its column, bracket depth)
    opens: list[int] = []
    for k, ch in enumerate(line):
        if ch in "([":
            opens.append(k)
        elif ch in ")]" and opens:
            opens.pop()
        elif ch == "," and line[k + 1:k + 2] == " ":
            cuts.append((k + 2, opens[-1] + 1 if opens else ind + 4, len(opens)))
        elif ch == " " and line[k + 1:k + 4] in ("&& ", "|| ") or line[k:k + 3] in (" + ", " - "):
            cuts.append((k + 1, ind + 4, len(opens) + 1))
    shallow, late = _fill(line, cuts, width, ind, True), _fill(line, cuts, width, ind, False)
    return shallow if len(shallow) <= len(late) else late


def _fill(line: str, cuts: list, width: int, ind: int, shallow: bool) -> list[str]:
    """``line`` broken at ``cuts`` as late as fits, at the outermost depth that has a break that
    fits (not ``shallow``: or one deeper)."""
    out: list[str] = []
    start, prefix = 0, 0
    while len(line) - start + prefix > width:
        fit = [c for c in cuts if start < c[0] and c[0] - start + prefix <= width + 1]
        if not fit:
            break
        depth = min(c[2] for c in fit) + (0 if shallow else 1)
        cut, col, _ = [c for c in fit if c[2] <= depth][-1]
        out.append(" " * prefix + line[start:cut].strip() if out else line[:cut].rstrip())
        if len(out) == 1:
            prefix = col if ind < col <= width // 2 else ind + 8
        start = cut
    out.append(" " * prefix + line[start:].strip() if out else line)
    return out
