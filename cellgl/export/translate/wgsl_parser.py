"""The OSL emitter's view of :mod:`cellgl.export.syntax`'s typed tree (nested tuples:
``("binary", op, left, right)``, ...)."""
from __future__ import annotations

from cellgl.export import syntax as st
from cellgl.export.translate.tokens import TranslateError


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
    """The parse of ``text`` (:func:`cellgl.export.syntax.parse`) as the OSL emitter's tuples:
    ``unit()`` lists ``("struct", comments, name, [[comments, type, name, size, trail]])``,
    ``("gdecl", comments, qualifiers, type, declarators)`` and ``("func", comments, return type,
    name, [(mode, type, name, size)], statements)`` (prototypes left out: OSL needs
    none); ``structs`` names the structs."""

    def __init__(self, text: str):
        self.tree = st.parse(text)
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
