"""Step 3c: translation of specialised GLSL (library subset) into Open Shading Language.

OSL has ``float``, ``int`` (signed 32-bit), triples and structs, but no 2- or 4-component
vectors, no unsigned integers, no ``bool`` and no file-scope variables. The translation is
type-directed: :class:`_Osl` walks :mod:`cellgl.export.syntax`'s tree, infers the GLSL type of every
expression, and

* maps every GLSL vector type to a struct of scalars (``vec4`` -> ``cellgl_vec4 {x, y, z, w}``,
  ``uvec2`` -> ``cellgl_uvec2``), with the operators, constructors, swizzles, component indexing
  and built-ins it uses generated as functions (one per type combination, only those used);
* keeps ``uint`` values as the same 32 bits in an ``int``: ``+ - * ^ & | << ~`` and ``==`` give
  the same bits on two's complement, while ``>>`` (logical), ``< <= > >=`` (unsigned order),
  ``/ %`` and the conversions to and from ``float`` go through helpers, so hashes, feature
  point positions and IDs are bit for bit those of the GLSL path;
* turns ``bool`` into ``int``, ``inout``/``out`` parameters into ``output`` ones (an input that
  the body assigns is copied into a local), array constructors into initialiser lists, and
  global constants into locals of the functions that read them (``params`` names the ones a
  caller passes instead: they become parameters of the functions that read them and of their
  callers).

Anything outside the subset raises :class:`TranslateError` naming the construct.
"""
from __future__ import annotations

from typing import Any

from cellgl.export import syntax as S
from cellgl.export.printer import Glsl, trail_comment
from cellgl.export.translate.osl_lib import (COMPARISONS, OSL_RESERVED, SWIZZLE, XYZW, OslLib, int_literal,
                                             same_type, vec_of, vec_type)
from cellgl.export.translate.tokens import TranslateError
from cellgl.export.translate.wgsl import assigned
from cellgl.export.tree import walk

__all__ = ["to_osl", "OSL_RESERVED"]


class _Osl(OslLib, Glsl):
    """The translator: :class:`printer.Glsl`'s statements, with expressions, declarations and
    functions (and the scopes that type them) of its own."""

    def __init__(self, text: str, params=()):
        super().__init__(kr=True, blank=False)
        # prototypes left out: OSL needs none
        self.items = [it for it in S.parse(text).items if not (isinstance(it, S.Function) and it.body is None)]
        self.params = list(params)
        self.helpers: dict[str, str] = {}         # generated name -> code (in order)
        self.structs: dict[str, dict] = {}       # name -> {member: type}
        self.funcs: dict[str, list] = {}         # name -> [(param types, modes, return, osl name, params passed)]
        self.globals: dict[str, tuple] = {}      # name -> (type, its Declarator)
        self.scopes: list[dict] = []
        self.passed: dict[str, list] = {}        # function -> the parameters it takes (see params)

    # ------------------------------------------------------------------ types
    def lookup(self, name: str):
        for s in reversed(self.scopes):
            if name in s:
                return s[name]
        if name in self.globals:
            t, d = self.globals[name]
            return self.sized(t, d.size)[0]
        raise TranslateError(f"OSL translation: unknown name {name!r}")

    # ------------------------------------------------------------------ helpers
    def ex(self, x) -> tuple[str, Any]:     # (its type: a GLSL type name, or (element, size) of an array)
        if isinstance(x, S.Num):
            t, hexa = x.text, x.text.lower().startswith("0x")
            if hexa or t[-1] in "uU":
                return int_literal(int(t.rstrip("uU"), 16 if hexa else 10)), ("uint" if t[-1] in "uU" else "int")
            if "." in t or "e" in t.lower() or t[-1] in "fF":
                t = t.rstrip("fF")                 # .5 -> 0.5, 1. -> 1.0
                return ("0" if t.startswith(".") else "") + t + ("0" if t.endswith(".") else ""), "float"
            return t, "int"
        if isinstance(x, S.Name):
            if x.name in ("true", "false"):
                return ("1" if x.name == "true" else "0"), "bool"
            return self.name(x.name), self.lookup(x.name)
        if isinstance(x, S.Paren):
            s, t = self.ex(x.inner)
            return f"({s})", t
        if isinstance(x, S.Member):
            s, t = self.ex(x.base)
            struct, v = isinstance(t, str) and t in self.structs, vec_type(t)
            if not struct and not v:
                raise TranslateError(f"OSL translation: member {x.name!r} of a {t}")
            if struct or len(x.name) == 1:
                m, mt = (self.name(x.name), self.structs[t][x.name]) if struct else (XYZW[SWIZZLE[x.name]], vec_of(t)[0])
                if not isinstance(x.base.inner if isinstance(x.base, S.Paren) else x.base, (S.Call, S.Ctor)):
                    return f"{s}.{m}", mt
                # OSL has no member access on a call's result: a getter
                if isinstance(mt, tuple):
                    raise TranslateError(f"OSL translation: array member {x.name!r} of a call's result")
                name = self.gen(f"cellgl_member_{self.osl_type(t)}_{m}", mt, [(t, "a")], f"return a.{m};")
                return f"{name}({s})", mt
            idx = [SWIZZLE[c] for c in x.name]
            rt = t[:-1] + str(len(idx))
            name = self.gen(f"cellgl_swizzle_{t}_{''.join(XYZW[i] for i in idx)}", rt, [(t, "a")],
                            lambda: self.returns(rt, [f"a.{XYZW[i]}" for i in idx]))
            return f"{name}({s})", rt
        if isinstance(x, S.Index):
            s, t = self.ex(x.base)
            i, ti = self.ex(x.index)
            if isinstance(t, tuple):
                return f"{s}[{i}]", t[0]
            v = vec_type(t)
            if not v:
                raise TranslateError(f"OSL translation: indexing a {t}")
            return f"{self.vec_get(t)}({s}, {i})", v[0]
        if isinstance(x, S.Unary):
            s, t = self.ex(x.operand)
            if vec_type(t):
                if x.op != "-":
                    raise TranslateError(f"OSL translation: unary {x.op!r} on a {t}")
                name, rt = self.vec_binary("-", vec_of(t)[0], t)
                return f"{name}({'0' if vec_of(t)[0] != 'float' else '0.0'}, {s})", t
            return f"{x.op}{s}", t
        if isinstance(x, S.IncDec):
            s, t = self.ex(x.operand)
            return (f"{s}{x.op}" if x.postfix else f"{x.op}{s}"), t
        if isinstance(x, S.Binary):
            return self.binary(x.op, x.left, x.right)
        if isinstance(x, S.Ternary):
            c, (a, ta), (b, _) = self.ex(x.cond)[0], self.ex(x.then), self.ex(x.other)
            if ta in ("float", "int", "uint", "bool"):
                return f"({c} ? {a} : {b})", ta
            name = self.gen(f"cellgl_select_{self.osl_type(ta)}", ta, [("int", "c"), (ta, "a"), (ta, "b")],
                            "if (c) return a; return b;")
            return f"{name}({c}, {a}, {b})", ta
        if isinstance(x, S.Assign):
            return self.assign(x.op, x.target, x.value), None
        if isinstance(x, S.Ctor):
            return self.ctor(x.type, x.args)
        if isinstance(x, S.ArrayCtor):
            raise TranslateError("OSL translation: an array constructor outside a declaration")
        if isinstance(x, S.Call):
            return (self.user_call if x.func in self.funcs else self.call_builtin)(x.func, x.args)
        raise AssertionError(x)

    def binary(self, op, lhs, rhs):
        a, ta = self.ex(lhs)
        b, tb = self.ex(rhs)
        if op in ("&&", "||"):
            return f"({a} {op} {b})", "bool"
        if vec_type(ta) or vec_type(tb):
            # GLSL == / != on whole vectors: all components equal
            if op in ("==", "!=") and vec_type(ta) and vec_type(tb):
                name, rt = self.vec_binary("==", ta, tb)
                s = f"{self.any_all('all', rt)}({name}({a}, {b}))"
                return (s if op == "==" else f"!{s}"), "bool"
            if vec_type(ta) and vec_type(tb) and ta != tb:
                raise TranslateError(f"OSL translation: {ta} {op} {tb}")
            name, rt = self.vec_binary(op, ta, tb)
            return f"{name}({a}, {b})", rt
        t = ta
        if op not in ("<<", ">>") and "uint" in (ta, tb):
            t = "uint"
        elif op not in ("<<", ">>") and ta != tb and "float" in (ta, tb):
            a, b, t = self.conv(a, ta, "float"), self.conv(b, tb, "float"), "float"
        return self.scalar_op(op, a, b, t), ("bool" if op in COMPARISONS or op == "^^" else t)

    def assign(self, op, lhs, rhs) -> str:
        if isinstance(lhs, S.Paren):
            lhs = lhs.inner
        if isinstance(lhs, (S.Member, S.Index)):
            base, bt = self.ex(lhs.base)
            if isinstance(lhs, S.Member) and vec_type(bt) and len(lhs.name) > 1:
                raise TranslateError("OSL translation: assignment to a multi-component swizzle")
            if isinstance(lhs, S.Index) and vec_type(bt):        # a component of a vector
                idx, _ = self.ex(lhs.index)
                val = rhs if op == "=" else S.Binary(op[:-1], S.Index(lhs.base, lhs.index), S.Paren(rhs))
                v, tv = self.ex(val)
                return f"{self.vec_set(bt)}({base}, {idx}, {self.coerce(v, tv, vec_of(bt)[0])})"
        a, ta = self.ex(lhs)
        if op == "=":
            return f"{a} = {self.conv_to(rhs, ta)}"
        base_op = op[:-1]
        _, tb = self.ex(rhs)
        if vec_type(ta) or vec_type(tb) or (ta == "uint" and base_op in (">>", "/", "%", "<", ">")):
            return f"{a} = {self.binary(base_op, lhs, S.Paren(rhs))[0]}"
        return f"{a} {op} {self.ex(rhs)[0]}"

    # (another signature than Glsl.ctor(e): that hook is called by Glsl.expr only, which .expr replaces)
    def ctor(self, t: str, args: list):  # type: ignore[override]
        ev = [self.ex(a) for a in args]
        if t in ("float", "int", "uint", "bool"):
            if len(ev) != 1:
                raise TranslateError(f"OSL translation: {t}() with {len(ev)} arguments")
            s, st = ev[0]
            v = vec_type(st)
            if v:       # float(vec) takes the first component
                s, st = f"{s}.x", v[0]
            return self.conv(s, st, t), t
        if t in self.structs:
            return f"{t}({', '.join(s for s, _ in ev)})", t
        v = vec_type(t)
        if not v:
            raise TranslateError(f"OSL translation: constructor {t}()")
        types = [st for _, st in ev]

        def code():
            comps: list[tuple[str, Any]] = []
            for j, st in enumerate(types):
                sv = vec_type(st)
                comps += [(f"a{j}.{c}", sv[0]) for c in XYZW[:sv[1]]] if sv else [(f"a{j}", st)]
            comps = (comps * v[1] if len(comps) == 1 else comps)[:v[1]]
            if len(comps) != v[1]:
                raise TranslateError(f"OSL translation: {t}({', '.join(types)})")
            return self.returns(t, [self.conv(c, ct, v[0]) for c, ct in comps])
        name = self.gen(f"cellgl_make_{t}_" + "_".join(types), t, [(st, f"a{j}") for j, st in enumerate(types)],
                        code)
        return f"{name}({', '.join(s for s, _ in ev)})", t

    def user_call(self, fn: str, args: list):
        ev = [self.ex(a) for a in args]
        types = [t for _, t in ev]
        cands = self.funcs[fn]
        match = [c for c in cands if len(c[0]) == len(types) and all(same_type(p, t) for p, t in zip(c[0], types))]
        if not match and len(cands) != 1:
            raise TranslateError(f"OSL translation: no overload of {fn} for ({', '.join(map(str, types))})")
        ptypes, modes, ret, oname, extra = (match or cands)[0]
        ss = [self.coerce(s, t, p) if m == "in" else s for (s, t), p, m in zip(ev, ptypes, modes)] + extra
        return f"{oname}({', '.join(ss)})", ret

    def name(self, n: str) -> str:
        return n + "_" if n in OSL_RESERVED else n

    # ------------------------------------------------------------------ statements: printer.Glsl's, but for these
    def expr(self, e) -> str:
        return self.ex(e)[0]

    def statement(self, s, ind: str = "") -> list[str]:
        if isinstance(s, S.Decl):                # a struct with array members: several lines
            *first, last = self.decl(s.type, s.declarators)
            return self.comments(s.comments, ind) + [ind + ln for ln in first] + [ind + last + trail_comment(s)]
        if isinstance(s, S.Return) and s.value is not None:
            return self.comments(s.comments, ind) + [f"{ind}return {self.conv_to(s.value, self.ret)};"]
        self.scopes.append({})                   # a for-loop's variable
        out = super().statement(s, ind)
        self.scopes.pop()
        return out

    def simple(self, s) -> str:
        if isinstance(s, S.Decl):                # a for-loop's initialiser
            init = self.decl(s.type, s.declarators)
            if len(init) != 1:
                raise TranslateError("OSL translation: one variable per for-loop initialiser")
            return init[0][:-1]
        return super().simple(s)

    def body(self, block, ind: str) -> list[str]:
        """A block's statements but those after one that always leaves it (unreachable)."""
        end = next((k + 1 for k, x in enumerate(block.body) if _leaves(x)), None)
        self.scopes.append({})
        out = super().body(S.Block(block.body[:end]), ind)
        self.scopes.pop()
        return out

    def jump(self, kind: str) -> str:
        if kind not in ("break", "continue"):
            raise TranslateError(f"OSL translation: statement {kind!r}")
        return kind + ";"

    def decl_type(self, t: str) -> str:
        return self.osl_type(t)

    def array_name(self, x) -> str:
        return self.name(x.name) + self.sized("", x.size)[1]

    def decl(self, typ: str, decls) -> list[str]:
        out = []
        ot = self.osl_type(typ)
        for d in decls:
            n, init = self.name(d.name), d.init
            self.scopes[-1][d.name], arr = self.sized(typ, d.size)
            if arr and init is not None and not isinstance(init, S.ArrayCtor):
                raise TranslateError(f"OSL translation: array {d.name!r} initialised from an expression")
            if arr and init is not None:
                out.append(f"{ot} {n}{arr} = {{ {', '.join(self.conv_to(a, typ) for a in init.args)} }};")
            elif isinstance(init, S.Ctor) and init.type in self.structs \
                    and any(isinstance(a, S.ArrayCtor) for a in init.args):
                # a struct with array members: member by member (OSL has no array expressions)
                out.append(f"{ot} {n};")
                for (m, mt), a in zip(self.structs[typ].items(), init.args):
                    if isinstance(a, S.ArrayCtor):
                        for j, e in enumerate(a.args):
                            out.append(f"{n}.{self.name(m)}[{j}] = {self.conv_to(e, mt[0])};")
                    else:
                        out.append(f"{n}.{self.name(m)} = {self.conv_to(a, mt)};")
            elif init is None:
                out.append(f"{ot} {n}{arr};")
            else:
                out.append(f"{ot} {n} = {self.conv_to(init, typ)};")
        return out

    def conv_to(self, node, typ: str) -> str:
        return self.coerce(*self.ex(node), typ)

    # ------------------------------------------------------------------ top level
    def globals_used(self, node) -> set:
        out = set()
        for n in walk(node):
            if isinstance(n, S.Name) and n.name in self.globals:
                out.add(n.name)
            elif isinstance(n, S.Call) and n.func in self.passed:
                out.update(self.passed[n.func])        # the callee's parameters pass through
        return out

    def emit(self) -> str:
        funcs_out: list[str] = []
        for item in self.items:
            known = len(self.helpers)
            lines = self.item(item)                           # the helpers it needs go before it
            funcs_out += [c for n, c in list(self.helpers.items())[known:] if not n.startswith("struct ")]
            funcs_out += ["\n".join(lines)] if lines else []
        head = "\n".join(c for n, c in self.helpers.items() if n.startswith("struct "))
        # no blank line between functions (as GLSL)
        return head + "\n" + "\n".join(funcs_out) + "\n"

    def item(self, item) -> list[str]:
        if isinstance(item, S.Struct):
            self.structs[item.name] = {f.name: self.sized(f.type, f.size)[0] for f in item.fields}
            return super().item(item)
        if isinstance(item, S.Global):
            if "uniform" in item.quals and any(d.name not in self.params for d in item.declarators):
                raise TranslateError("OSL translation: uniforms (export OSL with constants; the "
                                     "shader's parameters are OSL's uniforms)")
            for d in item.declarators:
                if d.init is None and d.name not in self.params:
                    raise TranslateError(f"OSL translation: global {d.name!r} needs a value")
                self.globals[d.name] = (item.type, d)
            return []
        return self.function(item)

    def function(self, item) -> list[str]:
        """The lines of a function; its overloads are numbered, and it takes the ``params`` it reads."""
        used = self.globals_used(item.body)
        passed = self.passed[item.name] = [g for g in self.params if g in used]
        mutated = assigned(item.body, {n: c[0][1] for n, c in self.funcs.items()})
        overloads = self.funcs.setdefault(item.name, [])
        oname = self.name(item.name) if not overloads else f"{item.name}_{len(overloads)}"
        self.ret, scope, plist, prologue = item.ret, {}, [], []
        for p in item.params:
            ot, n = self.osl_type(p.type), self.name(p.name)
            scope[p.name], arr = self.sized(p.type, p.size)
            if p.mode in ("out", "inout"):
                plist.append(f"output {ot} {n}{arr}")
            elif p.name in mutated:
                if p.size is not None:
                    raise TranslateError(f"OSL translation: {item.name} assigns its array parameter {p.name!r}")
                plist.append(f"{ot} {n}_in")
                prologue.append(f"    {ot} {n} = {n}_in;")
            else:
                plist.append(f"{ot} {n}{arr}")
        plist += [f"{self.osl_type(self.globals[g][0])} {self.name(g)}" for g in passed]
        overloads.append(([scope[p.name] for p in item.params], [p.mode for p in item.params], item.ret, oname,
                          [self.name(g) for g in passed]))
        self.scopes = [scope]
        consts = [S.Decl(self.globals[g][0], [self.globals[g][1]])           # the constants it reads: locals
                  for g in sorted(used - set(passed), key=list(self.globals).index)]
        out = self.comments(item.comments, "") + [f"{self.osl_type(item.ret)} {oname}({', '.join(plist)}) {{"
                                                   + trail_comment(item.body)] + prologue
        out += self.body(S.Block(consts + item.body.body), "") + ["}"]
        self.scopes = []
        return out


def _leaves(s) -> bool:
    """Whether statement ``s`` always leaves its block (a return, break or continue; a block ending so)."""
    return isinstance(s, (S.Return, S.Jump)) or (isinstance(s, S.Block) and bool(s.body)
                                                 and _leaves(s.body[-1]))


def to_osl(text: str, *, params=(), passed: dict | None = None) -> str:
    """Translate specialised, prefixed GLSL (library subset) into OSL functions and structs.

    Parameters
    ----------
    text : str
        GLSL from :func:`cellgl.export.snippets.library_code`.
    params : sequence of str
        Global constants or uniforms that the caller supplies instead (the shader's parameters):
        each function that reads one gets it as an extra trailing parameter, in this order.
    passed : dict, optional
        Filled with ``{function: [the names of params it takes, in order]}`` (a function takes
        those it reads and those its callees take).

    Returns
    -------
    str
        OSL text (helpers first, then the library in its order); no ``shader`` block.
    """
    osl = _Osl(text, params)
    out = osl.emit()
    if passed is not None:
        passed.update(osl.passed)
    return out

