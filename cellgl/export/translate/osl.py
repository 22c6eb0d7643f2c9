"""Step 3c: translation of specialised GLSL (library subset) into Open Shading Language.

OSL has ``float``, ``int`` (signed 32-bit), triples and structs, but no 2- or 4-component
vectors, no unsigned integers, no ``bool`` and no file-scope variables. The translation is
type-directed: :class:`_Osl` walks :mod:`wgsl_parser`'s tree, infers the GLSL type of every
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

import re

from cellgl.export.translate.osl_lib import _CMP, _SWZ, _XYZW, OSL_RESERVED, _int_lit, _OslLib, _same, _vec
from cellgl.export.translate.tokens import TranslateError
from cellgl.export.translate.wgsl_parser import _find_mutated, _Parser

__all__ = ["to_osl", "OSL_RESERVED"]

class _Osl(_OslLib):
    def __init__(self, text: str, params=(), drop=()):
        p = _Parser(text)
        self.unit = p.unit()
        self.params = list(params)
        self.helpers: dict[str, str] = {}         # generated name -> code (in order)
        self.vec_structs: set[str] = set()
        self.structs: dict[str, dict] = {}       # name -> {member: type}
        self.funcs: dict[str, list] = {}         # name -> [(param types, modes, return, osl name)]
        self.globals: dict[str, tuple] = {}      # name -> (type, size, init node)
        self.scopes: list[dict] = []
        self.drop = set(drop)
        self.passed: dict[str, list] = {}        # function -> the parameters it takes (see params)

    # ------------------------------------------------------------------ types
    def lookup(self, name: str):
        for s in reversed(self.scopes):
            if name in s:
                return s[name]
        if name in self.globals:
            t, size, _ = self.globals[name]
            return (t, size) if size is not None else t
        raise TranslateError(f"OSL translation: unknown name {name!r}")

    # ------------------------------------------------------------------ helpers
    def ex(self, x) -> tuple[str, object]:
        k = x[0]
        if k == "num":
            t = x[1]
            if t.lower().startswith("0x"):
                return _int_lit(int(t.rstrip("uU"), 16)), ("uint" if t[-1] in "uU" else "int")
            if t[-1] in "uU":
                return _int_lit(int(t[:-1])), "uint"
            if re.search(r"[.eE]", t) or t[-1] in "fF":
                t = t.rstrip("fF")
                if t.endswith("."):
                    t += "0"
                if t.startswith("."):
                    t = "0" + t
                return t, "float"
            return t, "int"
        if k == "id":
            if x[1] in ("true", "false"):
                return ("1" if x[1] == "true" else "0"), "bool"
            return self.name(x[1]), self.lookup(x[1])
        if k == "paren":
            s, t = self.ex(x[1])
            return f"({s})", t
        if k == "member":
            s, t = self.ex(x[1])
            base = x[1][1] if x[1][0] == "paren" else x[1]
            if base[0] in ("call", "ctor") and len(x[2]) == 1 or (isinstance(t, str) and t in self.structs
                                                                   and base[0] in ("call", "ctor")):
                # OSL has no member access on a call's result: a getter
                mt = self.structs[t][x[2]] if t in self.structs else _vec(t)[0]
                m = self.name(x[2]) if t in self.structs else _XYZW[_SWZ[x[2]]]
                ot = self.osl_type(t)
                if isinstance(mt, tuple):
                    raise TranslateError(f"OSL translation: array member {x[2]!r} of a call's result")
                name = f"cellgl_member_{ot}_{m}"
                self.helper(name, f"{self.osl_type(mt)} {name}({ot} a) {{ return a.{m}; }}")
                return f"{name}({s})", mt
            if isinstance(t, str) and t in self.structs:
                return f"{s}.{self.name(x[2])}", self.structs[t][x[2]]
            v = _vec(t)
            if not v:
                raise TranslateError(f"OSL translation: member {x[2]!r} of a {t}")
            idx = [_SWZ[c] for c in x[2]]
            if len(idx) == 1:
                return f"{s}.{_XYZW[idx[0]]}", v[0]
            rt = t[:-1] + str(len(idx))
            ort, ot = self.osl_type(rt), self.osl_type(t)
            name = f"cellgl_swizzle_{t}_{''.join(_XYZW[i] for i in idx)}"
            self.helper(name, lambda: f"{ort} {name}({ot} a) {{ return {ort}("
                        + ", ".join(f"a.{_XYZW[i]}" for i in idx) + "); }")
            return f"{name}({s})", rt
        if k == "index":
            s, t = self.ex(x[1])
            i, ti = self.ex(x[2])
            if isinstance(t, tuple):
                return f"{s}[{i}]", t[0]
            v = _vec(t)
            if not v:
                raise TranslateError(f"OSL translation: indexing a {t}")
            return f"{self.vec_get(t)}({s}, {i})", v[0]
        if k == "unary":
            s, t = self.ex(x[2])
            if _vec(t):
                if x[1] != "-":
                    raise TranslateError(f"OSL translation: unary {x[1]!r} on a {t}")
                name, rt = self.vec_binary("-", _vec(t)[0], t)
                return f"{name}({'0' if _vec(t)[0] != 'float' else '0.0'}, {s})", t
            return f"{x[1]}{s}", t
        if k in ("postinc", "preinc"):
            s, t = self.ex(x[2])
            return (f"{s}{x[1]}" if k == "postinc" else f"{x[1]}{s}"), t
        if k == "binary":
            return self.binary(x[1], x[2], x[3])
        if k == "ternary":
            c, _ = self.ex(x[1])
            a, ta = self.ex(x[2])
            b, tb = self.ex(x[3])
            if ta in ("float", "int", "uint", "bool"):
                return f"({c} ? {a} : {b})", ta
            ot = self.osl_type(ta)
            name = f"cellgl_select_{ot}"
            self.helper(name, f"{ot} {name}(int c, {ot} a, {ot} b) {{ if (c) return a; return b; }}")
            return f"{name}({c}, {a}, {b})", ta
        if k == "assign":
            return self.assign(x[1], x[2], x[3]), None
        if k == "ctor":
            return self.ctor(x[1], x[2])
        if k == "arrctor":
            raise TranslateError("OSL translation: an array constructor outside a declaration")
        if k == "call":
            return self.call(x[1], x[2])
        raise AssertionError(k)

    def binary(self, op, lhs, rhs):
        a, ta = self.ex(lhs)
        b, tb = self.ex(rhs)
        if op in ("&&", "||"):
            return f"({a} {op} {b})", "bool"
        if _vec(ta) or _vec(tb):
            # GLSL == / != on whole vectors: all components equal
            if op in ("==", "!=") and _vec(ta) and _vec(tb):
                name, rt = self.vec_binary("==", ta, tb)
                s = f"{self.any_all('all', rt)}({name}({a}, {b}))"
                return (s if op == "==" else f"!{s}"), "bool"
            if _vec(ta) and _vec(tb) and ta != tb:
                raise TranslateError(f"OSL translation: {ta} {op} {tb}")
            name, rt = self.vec_binary(op, ta, tb)
            return f"{name}({a}, {b})", rt
        t = ta
        if op in ("<<", ">>"):
            t = ta
        elif "uint" in (ta, tb):
            t = "uint"
        elif ta != tb and "float" in (ta, tb):
            a, b, t = self.conv(a, ta, "float"), self.conv(b, tb, "float"), "float"
        s = self.scalar_op(op, a, b, t)
        return s, ("bool" if op in _CMP or op == "^^" else t)

    def lvalue_is_vec_index(self, node):
        if node[0] == "index":
            _, t = self.ex(node[1])
            return _vec(t) is not None and not isinstance(t, tuple)
        return False

    def assign(self, op, lhs, rhs) -> str:
        if lhs[0] == "paren":
            lhs = lhs[1]
        if lhs[0] == "member":
            _, bt = self.ex(lhs[1])
            if _vec(bt) and len(lhs[2]) > 1:
                raise TranslateError("OSL translation: assignment to a multi-component swizzle")
        if self.lvalue_is_vec_index(lhs):
            base, bt = self.ex(lhs[1])
            idx, _ = self.ex(lhs[2])
            cur = ("index", lhs[1], lhs[2])
            val = rhs if op == "=" else ("binary", op[:-1], cur, ("paren", rhs))
            v, tv = self.ex(val)
            v = self.conv(v, tv, _vec(bt)[0]) if isinstance(tv, str) and not _vec(tv) else v
            return f"{self.vec_set(bt)}({base}, {idx}, {v})"
        a, ta = self.ex(lhs)
        if op == "=":
            b, tb = self.ex(rhs)
            if isinstance(ta, str) and isinstance(tb, str) and not _vec(ta) and not _vec(tb) and ta != tb \
                    and {ta, tb} != {"int", "uint"}:
                b = self.conv(b, tb, ta)
            return f"{a} = {b}"
        base_op = op[:-1]
        _, tb = self.ex(rhs)
        if _vec(ta) or _vec(tb) or (ta == "uint" and base_op in (">>", "/", "%", "<", ">")):
            b, _ = self.binary(base_op, lhs, ("paren", rhs))
            return f"{a} = {b}"
        b, _ = self.ex(rhs)
        return f"{a} {op} {b}"

    def ctor(self, t: str, args: list):
        ev = [self.ex(a) for a in args]
        if t in ("float", "int", "uint", "bool"):
            if len(ev) != 1:
                raise TranslateError(f"OSL translation: {t}() with {len(ev)} arguments")
            s, st = ev[0]
            v = _vec(st)
            if v:       # float(vec) takes the first component
                s, st = f"{s}.x", v[0]
            return self.conv(s, st, t), t
        if t in self.structs:
            return f"{t}({', '.join(s for s, _ in ev)})", t
        v = _vec(t)
        if not v:
            raise TranslateError(f"OSL translation: constructor {t}()")
        types = [st for _, st in ev]
        name = f"cellgl_make_{t}_" + "_".join(types)

        def code():
            comps = []
            for j, st in enumerate(types):
                sv = _vec(st)
                if sv:
                    comps += [(f"a{j}.{c}", sv[0]) for c in _XYZW[:sv[1]]]
                else:
                    comps.append((f"a{j}", st))
            if len(comps) == 1:
                comps = comps * v[1]
            comps = comps[:v[1]]
            if len(comps) != v[1]:
                raise TranslateError(f"OSL translation: {t}({', '.join(types)})")
            ot = self.osl_type(t)
            plist = ", ".join(f"{self.osl_type(st)} a{j}" for j, st in enumerate(types))
            return (f"{ot} {name}({plist}) {{ return {ot}("
                    + ", ".join(self.conv(c, ct, v[0]) for c, ct in comps) + "); }")
        self.helper(name, code)
        return f"{name}({', '.join(s for s, _ in ev)})", t

    def call(self, fn: str, args: list):
        if fn in self.funcs:
            return self.user_call(fn, args)
        return self.call_builtin(fn, args)

    def user_call(self, fn: str, args: list):
        ev = [self.ex(a) for a in args]
        types = [t for _, t in ev]
        cands = self.funcs[fn]
        for ptypes, modes, ret, oname, extra in cands:
            if len(ptypes) == len(types) and all(_same(p, t) for p, t in zip(ptypes, types)):
                break
        else:
            if len(cands) != 1:
                raise TranslateError(f"OSL translation: no overload of {fn} for ({', '.join(map(str, types))})")
            ptypes, modes, ret, oname, extra = cands[0]
        ss = []
        for (s, t), p, m in zip(ev, ptypes, modes):
            if m == "in" and isinstance(p, str) and isinstance(t, str) and not _vec(p) and not _vec(t) \
                    and p != t and {p, t} != {"int", "uint"} and p not in self.structs:
                s = self.conv(s, t, p)
            ss.append(s)
        ss += extra
        return f"{oname}({', '.join(ss)})", ret

    def name(self, n: str) -> str:
        return n + "_" if n in OSL_RESERVED else n

    # ------------------------------------------------------------------ statements
    def stmt(self, s, ind: str) -> list[str]:
        out = []
        for c in s[1]:
            if isinstance(c, tuple) or c == "":
                continue
            out += [ind + ln.strip() for ln in c.split("\n")]
        k = s[0]
        if k == "block":
            self.scopes.append({})
            out.append(ind + "{")
            for t in s[2]:
                out += self.stmt(t, ind + "    ")
            out.append(ind + "}")
            self.scopes.pop()
        elif k == "decl":
            out += [ind + d for d in self.decl(s[3], s[4])]
        elif k == "expr":
            e, _ = self.ex(s[2])
            out.append(ind + e + ";")
        elif k == "return":
            if s[2] is None:
                out.append(ind + "return;")
            else:
                e, t = self.ex(s[2])
                rt = self.ret
                if isinstance(t, str) and not _vec(t) and not _vec(rt) and rt not in self.structs \
                        and t != rt and {t, rt} != {"int", "uint"}:
                    e = self.conv(e, t, rt)
                out.append(ind + f"return {e};")
        elif k in ("break", "continue"):
            out.append(ind + k + ";")
        elif k == "if":
            c, _ = self.ex(s[2])
            out.append(f"{ind}if ({c})")
            out += self.body(s[3], ind)
            if s[4] is not None:
                out.append(ind + "else")
                out += self.body(s[4], ind)
        elif k == "for":
            self.scopes.append({})
            init = ""
            if s[2] is not None:
                if s[2][0] == "decl":
                    d = self.decl(s[2][3], s[2][4])
                    if len(d) != 1:
                        raise TranslateError("OSL translation: one variable per for-loop initialiser")
                    init = d[0][:-1]
                else:
                    init, _ = self.ex(s[2][2])
            cond = "" if s[3] is None else self.ex(s[3])[0]
            step = "" if s[4] is None else self.ex(s[4])[0]
            out.append(f"{ind}for ({init}; {cond}; {step})")
            out += self.body(s[5], ind)
            self.scopes.pop()
        elif k == "while":
            out.append(f"{ind}while ({self.ex(s[2])[0]})")
            out += self.body(s[3], ind)
        else:
            raise TranslateError(f"OSL translation: statement {k!r}")
        return out

    def body(self, s, ind: str) -> list[str]:
        if s[0] == "block":
            return self.stmt(s, ind)
        self.scopes.append({})
        out = [ind + "{"] + self.stmt(s, ind + "    ") + [ind + "}"]
        self.scopes.pop()
        return out

    def decl(self, typ: str, decls) -> list[str]:
        out = []
        ot = self.osl_type(typ)
        for name, size, init in decls:
            n = self.name(name)
            if size is not None:
                sz = self.size(size)
                self.scopes[-1][name] = (typ, sz)
                if init is None:
                    out.append(f"{ot} {n}[{sz}];")
                elif init[0] == "arrctor":
                    vals = [self.conv_to(a, typ) for a in init[3]]
                    out.append(f"{ot} {n}[{sz}] = {{ {', '.join(vals)} }};")
                else:
                    raise TranslateError(f"OSL translation: array {name!r} initialised from an expression")
                continue
            self.scopes[-1][name] = typ
            if init is not None and init[0] == "ctor" and init[1] in self.structs \
                    and any(a[0] == "arrctor" for a in init[2]):
                # a struct with array members: member by member (OSL has no array expressions)
                out.append(f"{ot} {n};")
                for (m, mt), a in zip(self.structs[typ].items(), init[2]):
                    if a[0] == "arrctor":
                        for j, e in enumerate(a[3]):
                            out.append(f"{n}.{self.name(m)}[{j}] = {self.conv_to(e, mt[0])};")
                    else:
                        out.append(f"{n}.{self.name(m)} = {self.conv_to(a, mt)};")
                continue
            if init is None:
                out.append(f"{ot} {n};")
            else:
                out.append(f"{ot} {n} = {self.conv_to(init, typ)};")
        return out

    def conv_to(self, node, typ: str) -> str:
        s, t = self.ex(node)
        if isinstance(t, str) and not _vec(t) and not _vec(typ) and typ not in self.structs and t != typ \
                and {t, typ} != {"int", "uint"}:
            s = self.conv(s, t, typ)
        return s

    # ------------------------------------------------------------------ top level
    def globals_used(self, node, out: set) -> None:
        if isinstance(node, list):
            for n in node:
                self.globals_used(n, out)
        elif isinstance(node, tuple) and node:
            if node[0] == "id" and node[1] in self.globals:
                out.add(node[1])
            elif node[0] == "call" and node[1] in self.passed:
                out.update(self.passed[node[1]])        # the callee's parameters pass through
            for c in node[1:]:
                if isinstance(c, (tuple, list)):
                    self.globals_used(c, out)

    def emit(self) -> str:
        funcs_out: list[str] = []
        overloads: dict[str, int] = {}
        for item in self.unit:
            before = len(funcs_out)
            known = set(self.helpers)
            self.emit_item(item, funcs_out, overloads)
            new = [c for n, c in self.helpers.items() if n not in known and not n.startswith("struct ")]
            funcs_out[before:before] = new
        head = "\n".join(c for n, c in self.helpers.items() if n.startswith("struct "))
        body = funcs_out[:1]
        for prev, c in zip(funcs_out, funcs_out[1:]):      # no blank line between functions (as GLSL)
            body.append("\n" + c)
        return _braces(head + "\n" + "".join(body) + "\n")


    def emit_item(self, item, funcs_out: list, overloads: dict) -> None:
        k = item[0]
        if k == "struct":
            members = {}
            lines = [f"struct {item[2]}", "{"]
            for mcom, typ, mname, size, trail in item[3]:
                ot = self.osl_type(typ)
                if size is not None:
                    sz = self.size(size)
                    members[mname] = (typ, sz)
                    lines.append(f"    {ot} {self.name(mname)}[{sz}];" + (f"  {trail}" if trail else ""))
                else:
                    members[mname] = typ
                    lines.append(f"    {ot} {self.name(mname)};" + (f"  {trail}" if trail else ""))
            lines.append("};")
            self.structs[item[2]] = members
            funcs_out.append("\n".join(self.comment_lines(item[1]) + lines))
        elif k == "gdecl":
            quals, typ, decls = item[2], item[3], item[4]
            if "uniform" in quals:
                raise TranslateError("OSL translation: uniforms (export OSL with constants; the "
                                     "shader's parameters are OSL's uniforms)")
            for name, size, init in decls:
                if init is None:
                    raise TranslateError(f"OSL translation: global {name!r} needs a value")
                self.globals[name] = (typ, self.size(size) if size is not None else None, init)
        elif k == "func":
            _, com, ret, name, params, body = item
            if name in self.drop:
                return
            used: set = set()
            self.globals_used(body, used)
            passed = [g for g in self.params if g in used]
            self.passed[name] = passed
            n = overloads.get(name, 0)
            overloads[name] = n + 1
            oname = self.name(name) if n == 0 else f"{name}_{n}"
            ptypes = [(t, s) if s is not None else t for _, t, _, s in params]
            self.funcs.setdefault(name, []).append(
                (ptypes, [m for m, _, _, _ in params], ret, oname, [self.name(g) for g in passed]))
            funcs_out.append("\n".join(self.comment_lines(com) + self.func(item, oname, passed, used)))

    def comment_lines(self, com) -> list[str]:
        out = []
        for c in com:
            if isinstance(c, tuple) or c == "":
                continue
            out += [ln.strip() for ln in c.split("\n")]
        return out

    def func(self, item, oname: str, passed: list, used: set) -> list[str]:
        _, _, ret, name, params, body = item
        self.ret = ret
        mutated: set = set()
        sigs = {n: [m for m in c[0][1]] for n, c in self.funcs.items()}
        _find_mutated(body, mutated, sigs)
        scope: dict = {}
        plist, prologue = [], []
        for mode, typ, pname, size in params:
            ot = self.osl_type(typ)
            arr = ""
            if size is not None:
                arr = f"[{self.size(size)}]"
                scope[pname] = (typ, self.size(size))
            else:
                scope[pname] = typ
            n = self.name(pname)
            if mode in ("out", "inout"):
                plist.append(f"output {ot} {n}{arr}")
            elif pname in mutated:
                if size is not None:
                    raise TranslateError(f"OSL translation: {name} assigns its array parameter {pname!r}")
                plist.append(f"{ot} {n}_in")
                prologue.append(f"    {ot} {n} = {n}_in;")
            else:
                plist.append(f"{ot} {n}{arr}")
        for g in passed:
            t, size, _ = self.globals[g]
            plist.append(f"{self.osl_type(t)} {self.name(g)}")
        self.scopes = [scope]
        for g in sorted(used - set(passed), key=list(self.globals).index):
            t, size, init = self.globals[g]
            self.scopes[0].pop(g, None)
            d = self.decl(t, [(g, ("num", size) if size is not None else None, init)])
            prologue += ["    " + ln for ln in d]
        out = [f"{self.osl_type(ret)} {oname}({', '.join(plist)})", "{"] + prologue
        for s in body:
            out += self.stmt(s, "    ")
        out.append("}")
        self.scopes = []
        return out


def to_osl(text: str, *, params=(), drop=(), passed: dict | None = None) -> str:
    """Translate specialised, prefixed GLSL (library subset) into OSL functions and structs.

    Parameters
    ----------
    text : str
        GLSL from :func:`cellgl.export.snippets.library_code`.
    params : sequence of str
        Global constants that the caller supplies instead (the shader's parameters): each
        function that reads one gets it as an extra trailing parameter, in this order.
    drop : sequence of str
        Functions to leave out (e.g. fragment-only entry points that use ``fwidth``).
    passed : dict, optional
        Filled with ``{function: [the names of params it takes, in order]}`` (a function takes
        those it reads and those its callees take).

    Returns
    -------
    str
        OSL text (helpers first, then the library in its order); no ``shader`` block.
    """
    osl = _Osl(text, params, drop)
    out = osl.emit()
    if passed is not None:
        passed.update(osl.passed)
    return out


def _braces(text: str) -> str:
    """A line holding only ``{`` joined to the statement or signature above it (as the other
    targets print their blocks)."""
    out: list[str] = []
    for ln in text.split("\n"):
        prev = out[-1] if out else ""
        if ln.strip() == "{" and prev.strip() and "//" not in prev \
                and len(prev) - len(prev.lstrip()) == len(ln) - len(ln.lstrip()):
            out[-1] = prev + " {"
        else:
            out.append(ln)
    return "\n".join(out)
