"""Step 3b, second half: the WGSL emitter over :mod:`cellgl.export.translate.wgsl_parser`'s tree."""
from __future__ import annotations

import re

from cellgl.export.printer import RELATIONAL
from cellgl.export.translate.tokens import TranslateError
from cellgl.export.translate.wgsl_parser import (
    _PREC_OF,
    WGSL_FUNCS,
    WGSL_RESERVED,
    WGSL_SCALARS,
    _Parser,
)


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
        out = [f"fn {self.name(name)}({', '.join(plist)}){rt} {{"] + prologue
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


def to_wgsl(text) -> str:
    """Translate specialised, prefixed GLSL (library subset; its text or its tree) into WGSL.

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
                "fn cellgl_mod(x: f32, y: f32) -> f32 { return x - y * floor(x / y); }\n" + body)
    return body.rstrip() + "\n"
