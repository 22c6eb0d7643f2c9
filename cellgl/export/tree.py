"""What the middle end's passes share: walking and rewriting :mod:`cellgl.export.syntax` trees,
def-use facts (what a statement reads, writes and calls), the module's function table, and the
driver that runs passes to a fixed point.

A pass is a function ``pass_(unit: Unit, ctx: Context) -> bool``: it changes the tree in place
and returns whether it changed anything. :func:`fixed_point` runs a list of passes round after
round until a round changes nothing, or raises after ``max_rounds``.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, field, fields

from cellgl.export import syntax as S
from cellgl.export.translate.tokens import TranslateError

__all__ = ["tree_pass", "children", "walk", "transform", "root_name", "reads", "writes", "calls", "Context",
           "fixed_point", "clone", "EXPRESSIONS", "STATEMENTS", "ASSIGN_OPS"]

#: expression node classes
EXPRESSIONS = (S.Num, S.Name, S.Call, S.Ctor, S.ArrayCtor, S.Unary, S.IncDec, S.Binary, S.Assign,
               S.Ternary, S.Index, S.Member, S.Paren)
#: statement node classes
STATEMENTS = (S.Block, S.Decl, S.ExprStmt, S.If, S.For, S.While, S.Return, S.Jump)
#: the assignment operators
ASSIGN_OPS = ("=", "+=", "-=", "*=", "/=", "%=", "&=", "|=", "^=", "<<=", ">>=")

_NODE_TYPES = EXPRESSIONS + STATEMENTS + (S.Declarator, S.Unit, S.Struct, S.Field, S.Function,
                                          S.Param, S.Global)
_SKIP = {"comments", "trail", "trailing"}
_NODE_SET = frozenset(_NODE_TYPES)
#: the fields of each node class that may hold nodes (not its names, operators and flags)
_CHILD_FIELDS: dict[type, tuple[str, ...]] = {
    t: tuple(f.name for f in fields(t) if f.name not in _SKIP and f.type not in ("str", "bool")) for t in _NODE_TYPES}


def tree_pass(fn):
    """Mark ``fn`` as a tree pass ``(unit, ctx) -> changed`` (the driver's round mixes them with
    the text passes not yet moved)."""
    fn.tree_pass = True
    return fn


def children(node):
    """The direct child nodes of ``node``, in source order."""
    for name in _CHILD_FIELDS.get(type(node), ()):
        v = getattr(node, name)
        if type(v) is list:
            for x in v:
                if type(x) in _NODE_SET:
                    yield x
        elif type(v) in _NODE_SET:
            yield v


def walk(node):
    """``node`` and every node below it, pre-order (parents before children)."""
    stack = [node]
    while stack:
        n = stack.pop()
        yield n
        kids = []
        for name in _CHILD_FIELDS.get(type(n), ()):
            v = getattr(n, name)
            if type(v) is list:
                kids += [x for x in v if type(x) in _NODE_SET]
            elif type(v) in _NODE_SET:
                kids.append(v)
        kids.reverse()
        stack += kids


def transform(node, fn):
    """Rewrite the tree below ``node`` bottom-up: each child ``c`` is replaced by ``fn(c)``
    (``fn`` returns ``c`` itself to keep it; in a list, ``None`` deletes it and a Python list
    splices several nodes in). Returns ``fn(node)``."""
    for name in _CHILD_FIELDS.get(type(node), ()):
        v = getattr(node, name)
        if isinstance(v, list):
            out = []
            for x in v:
                if not isinstance(x, _NODE_TYPES):
                    out.append(x)
                    continue
                y = transform(x, fn)
                if y is None:
                    continue
                if isinstance(y, list):
                    out.extend(y)
                else:
                    out.append(y)
            v[:] = out
        elif isinstance(v, _NODE_TYPES):
            setattr(node, name, transform(v, fn))
    return fn(node)


def clone(node):
    """A deep copy of ``node`` (comments included)."""
    t = type(node)
    if t not in _NODE_SET:
        return copy.deepcopy(node)
    new = t.__new__(t)
    d = new.__dict__
    for k, v in node.__dict__.items():
        if type(v) is list:
            d[k] = [clone(x) if type(x) in _NODE_SET else x for x in v]
        elif type(v) in _NODE_SET:
            d[k] = clone(v)
        else:
            d[k] = v
    return new


def root_name(e) -> str | None:
    """The variable an lvalue stores into: ``a`` of ``a``, ``a.x``, ``a[i].y``, ``(a)``."""
    while isinstance(e, (S.Index, S.Member, S.Paren)):
        e = e.inner if isinstance(e, S.Paren) else e.base
    return e.name if isinstance(e, S.Name) else None


def calls(node) -> set[str]:
    """The functions (not constructors) called anywhere below ``node``."""
    return {n.func for n in walk(node) if isinstance(n, S.Call)}


@dataclass
class Context:
    """What the passes know of the module: its entry points, the functions they must keep, the
    functions by name, and which functions have effects beyond their return value (they write
    an ``out``/``inout`` parameter or a global, or call one that does). Rebuilt with
    :meth:`refresh` after a pass changes the set of functions or their signatures."""

    entries: tuple = ()
    keep: frozenset = frozenset()
    structs: tuple = ()                                # ((struct, loader), ...) to scalarise
    fold_constants: bool = True                        # False: the recipe's values stay named constants
    functions: dict = field(default_factory=dict)      # name -> Function with a body
    globals_: set = field(default_factory=set)
    impure: set = field(default_factory=set)

    def refresh(self, unit: S.Unit) -> "Context":
        self.functions = {it.name: it for it in unit.items if isinstance(it, S.Function) and it.body is not None}
        self.globals_ = {d.name for it in unit.items if isinstance(it, S.Global) for d in it.declarators}
        direct, called = set(), {}
        for f in self.functions.values():
            called[f.name] = calls(f.body)
            if any(p.mode != "in" for p in f.params) or writes(f.body, self) & self.globals_:
                direct.add(f.name)
        impure, grew = set(direct), True
        while grew:
            grew = False
            for name, c in called.items():
                if name not in impure and c & impure:
                    impure.add(name)
                    grew = True
        self.impure = impure
        return self

    def out_positions(self, func: str) -> list[int]:
        """Indices of ``func``'s ``out``/``inout`` parameters (none for built-ins)."""
        f = self.functions.get(func)
        return [] if f is None else [k for k, p in enumerate(f.params) if p.mode != "in"]


def writes(node, ctx: Context | None = None) -> set[str]:
    """The variables stored into anywhere below ``node``: assignment targets, ``++``/``--``
    operands, declared names, and (with ``ctx``) the arguments passed to ``out``/``inout``
    parameters of the module's functions."""
    out = set()
    for n in walk(node):
        if isinstance(n, S.Assign):
            out.add(root_name(n.target))
        elif isinstance(n, S.IncDec):
            out.add(root_name(n.operand))
        elif isinstance(n, S.Declarator):
            out.add(n.name)
        elif ctx is not None and isinstance(n, S.Call):
            for k in ctx.out_positions(n.func):
                if k < len(n.args):
                    out.add(root_name(n.args[k]))
    out.discard(None)
    return out


def reads(node, ctx: Context | None = None) -> set[str]:
    """The variables read anywhere below ``node``: every name, except the target of a plain
    ``=`` whose target is the bare name (``a = ...`` does not read ``a``; ``a.x = ...`` and
    ``a += ...`` do) and, with ``ctx``, a bare name passed to an ``out`` parameter."""
    skip = set()
    for n in walk(node):
        if isinstance(n, S.Assign) and n.op == "=" and isinstance(n.target, S.Name):
            skip.add(id(n.target))
        elif ctx is not None and isinstance(n, S.Call):
            f = ctx.functions.get(n.func)
            if f is not None:
                for p, a in zip(f.params, n.args):
                    if p.mode == "out" and isinstance(a, S.Name):
                        skip.add(id(a))
    return {n.name for n in walk(node) if isinstance(n, S.Name) and id(n) not in skip}


def fixed_point(unit: S.Unit, passes, ctx: Context, max_rounds: int = 64) -> int:
    """Run ``passes`` over ``unit`` round after round until a whole round changes nothing;
    return the number of rounds. Raises :class:`TranslateError` naming the passes still
    changing the tree after ``max_rounds`` rounds (a pass undoes another)."""
    stale = True
    for rounds in range(1, max_rounds + 1):
        changed = []
        for p in passes:
            if stale:                     # (a pass that changed nothing left the facts true)
                ctx.refresh(unit)
            stale = bool(p(unit, ctx))
            if stale:
                changed.append(getattr(p, "__name__", repr(p)))
        if not changed:
            return rounds
    raise TranslateError(f"the snippet compiler did not settle in {max_rounds} rounds of its passes "
                         f"(entry points {', '.join(ctx.entries)}; still changing: {', '.join(changed)}): "
                         "a pass undoes another")
