"""What the middle end's passes share: walking and rewriting :mod:`cellgl.export.syntax` trees,
def-use facts (what a statement reads, writes and calls), the module's function table, and the
driver that runs passes to a fixed point.

A pass is a function ``pass_(unit: Unit, ctx: Context) -> bool``: it changes the tree in place
and returns whether it changed anything. :func:`fixed_point` runs a list of passes until they
settle (:func:`settle`), or raises after ``max_rounds`` rounds.
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields

from cellgl.export import syntax as S
from cellgl.export.translate.tokens import TranslateError

__all__ = ["children", "walk", "transform", "root", "root_name", "writes", "calls", "Context", "fixed_point",
           "settle", "clone", "EXPRESSIONS", "STATEMENTS", "OUT_BUILTINS", "ATOMS", "is_pure", "scan",
           "paren", "CHILD_FIELDS"]

#: expression node classes
EXPRESSIONS = (S.Num, S.Name, S.Call, S.Ctor, S.ArrayCtor, S.Unary, S.IncDec, S.Binary, S.Assign,
               S.Ternary, S.Index, S.Member, S.Paren)
#: statement node classes
STATEMENTS = (S.Block, S.Decl, S.ExprStmt, S.If, S.For, S.While, S.Return, S.Jump)

_NODE_TYPES = EXPRESSIONS + STATEMENTS + (S.Declarator, S.Unit, S.Struct, S.Field, S.Function,
                                          S.Param, S.Global)
_NODE_SET = frozenset(_NODE_TYPES)
#: ``(field, holds a list)`` of each node class's fields that may hold nodes, in source order (not
#: its names, operators, flags, qualifiers and comments)
CHILD_FIELDS: dict[type, tuple] = {
    t: tuple((f.name, f.type == "list") for f in fields(t) if f.type not in ("str", "bool")
             and f.name not in ("comments", "trail", "trailing", "quals")) for t in _NODE_TYPES}


def children(node) -> list:
    """The direct child nodes of ``node``, in source order."""
    out = []
    for name, many in CHILD_FIELDS[type(node)]:
        v = getattr(node, name)
        if many:
            out += v
        elif v is not None:
            out.append(v)
    return out


def _walk(n, add):
    add(n)
    for name, many in CHILD_FIELDS[type(n)]:
        v = getattr(n, name)
        if many:
            for x in v:
                _walk(x, add)
        elif v is not None:
            _walk(v, add)


def walk(node) -> list:
    """``node`` and every node below it, pre-order (parents before children)."""
    out: list = []
    _walk(node, out.append)
    return out


def transform(node, fn):
    """Rewrite the tree below ``node`` bottom-up: each child ``c`` is replaced by ``fn(c)``
    (``fn`` returns ``c`` itself to keep it; in a list, ``None`` deletes it and a Python list
    splices several nodes in; a list of statements (or ``[]``) for an ``if``'s branch or a loop's
    body becomes a block there, an empty ``else`` goes). Returns ``fn(node)``."""
    for name, many in CHILD_FIELDS[type(node)]:
        v = getattr(node, name)
        if many:
            out, same = [], True
            for x in v:
                y = transform(x, fn)
                same = same and y is x
                if type(y) is list:
                    out.extend(y)
                elif y is not None:
                    out.append(y)
            if not same:
                v[:] = out
        elif v is not None:
            y = transform(v, fn)
            if type(y) is list:
                y = None if not y and name == "other" else y[0] if len(y) == 1 and isinstance(y[0], S.Block) \
                    else S.Block(y)
            if y is not v:
                setattr(node, name, y)
    return fn(node)


def clone(node):
    """A deep copy of ``node`` (comments included)."""
    t = type(node)
    new = object.__new__(t)     # (the node classes are plain dataclasses: no __new__ of their own)
    d = new.__dict__
    for k, v in node.__dict__.items():
        if type(v) is list:
            d[k] = [clone(x) if type(x) in _NODE_SET else x for x in v]
        elif type(v) in _NODE_SET:
            d[k] = clone(v)
        else:
            d[k] = v
    return new


def root(e):
    """The Name node of the variable an lvalue stores into: ``a`` of ``a``, ``a.x``, ``a[i].y``,
    ``(a)`` (None: not a variable)."""
    while isinstance(e, (S.Index, S.Member, S.Paren)):
        e = e.inner if isinstance(e, S.Paren) else e.base
    return e if isinstance(e, S.Name) else None


def root_name(e) -> str | None:
    """The name of :func:`root`'s variable."""
    r = root(e)
    return None if r is None else r.name


def calls(node) -> set[str]:
    """The functions (not constructors) called anywhere below ``node``."""
    return {n.func for n in walk(node) if isinstance(n, S.Call)}


@dataclass
class Context:
    """What the passes know of the module: its entry points, the functions they must keep, the
    functions by name, and which functions have effects beyond their return value (they write
    an ``out``/``inout`` parameter or a global, or call one that does), and where each function is
    called. Rebuilt with :meth:`refresh` after a pass changes the tree (the driver does)."""

    entries: tuple = ()
    keep: frozenset = frozenset()
    structs: tuple = ()                                # ((struct, loader), ...) to scalarise
    fold_constants: bool = True                        # False: the recipe's values stay named constants
    functions: dict = field(default_factory=dict)      # name -> Function with a body
    globals_: set = field(default_factory=set)
    impure: set = field(default_factory=set)
    sites: dict = field(default_factory=dict)          # name -> [(Function, Call), ...]: every call

    def refresh(self, unit: S.Unit) -> Context:
        bodies = [it for it in unit.items if isinstance(it, S.Function) and it.body is not None]
        self.functions = {f.name: f for f in bodies}
        self.globals_ = {d.name for it in unit.items if isinstance(it, S.Global) for d in it.declarators}
        direct, called, self.sites = set(), {}, {}
        for f in bodies:
            nodes, calls_ = walk(f.body), []
            for n in nodes:
                if type(n) is S.Call:
                    self.sites.setdefault(n.func, []).append((f, n))
                    calls_.append(n.func)
            if self.functions[f.name] is not f:
                continue                               # (an overload: the table holds the last)
            called[f.name] = set(calls_)
            if any(p.mode != "in" for p in f.params) or writes(nodes, self) & self.globals_:
                direct.add(f.name)
        self.impure = direct                       # and, to a fixed point, what calls one of them
        while grown := {name for name, c in called.items() if name not in self.impure and c & self.impure}:
            self.impure |= grown
        return self

    def out_positions(self, func: str) -> list[int]:
        """Indices of ``func``'s ``out``/``inout`` parameters (none for built-ins)."""
        f = self.functions.get(func)
        return [] if f is None else [k for k, p in enumerate(f.params) if p.mode != "in"]


def writes(node, ctx: Context | None = None) -> set[str]:
    """The variables stored into anywhere below ``node`` (or in the list of nodes :func:`walk`
    gave): assignment targets, ``++``/``--`` operands, declared names, and (with ``ctx``) the
    arguments passed to ``out``/``inout`` parameters of the module's functions."""
    out: set[str | None] = set()
    for n in node if type(node) is list else walk(node):
        t = type(n)
        if t is S.Assign:
            out.add(root_name(n.target))
        elif t is S.IncDec:
            out.add(root_name(n.operand))
        elif t is S.Declarator:
            out.add(n.name)
        elif t is S.Call and ctx is not None:
            for k in ctx.out_positions(n.func):
                if k < len(n.args):
                    out.add(root_name(n.args[k]))
    return {name for name in out if name is not None}


def settle(passes, apply, max_rounds: int, failure: str) -> bool:
    """``apply(p) -> changed`` for each pass of ``passes`` in turn, round after round, until every
    pass has run once since the last change (from there on they would see the same tree and facts
    again); whether any changed. Raises :class:`TranslateError` with ``failure`` and the passes
    still changing after ``max_rounds`` rounds (a pass undoes another)."""
    recent: list[str] = []
    quiet, changed = 0, False
    for run in range(max_rounds * len(passes)):
        p = passes[run % len(passes)]
        if apply(p):
            changed, quiet, recent = True, 0, (recent + [getattr(p, "__name__", repr(p))])[-len(passes):]
        else:
            quiet += 1
            if quiet == len(passes):
                return changed
    raise TranslateError(f"{failure} (still changing: {', '.join(recent)}): a pass undoes another")


def fixed_point(unit: S.Unit, passes, ctx: Context, max_rounds: int = 64) -> bool:
    """Run the tree passes ``passes`` over ``unit`` (:func:`settle`), ``ctx`` refreshed after a
    pass that changed the tree."""
    stale = True

    def apply(p):
        nonlocal stale
        if stale:
            ctx.refresh(unit)
        stale = bool(p(unit, ctx))
        return stale
    return settle(passes, apply, max_rounds, f"the snippet compiler did not settle in {max_rounds} rounds of "
                  f"its passes (entry points {', '.join(ctx.entries)})")


# --------------------------------------------------------------------------------------------
# small helpers of the passes: effects, occurrences with their roles, rewriting statements
# --------------------------------------------------------------------------------------------

#: built-in functions with ``out`` parameters: ``{name: {position: mode}}``
OUT_BUILTINS = {"modf": {1: "out"}, "frexp": {1: "out"}, "uaddCarry": {2: "out"}, "usubBorrow": {2: "out"},
                "umulExtended": {2: "out", 3: "out"}, "imulExtended": {2: "out", 3: "out"}}
#: nodes that never need parentheses around them
ATOMS = (S.Num, S.Name, S.Call, S.Ctor, S.ArrayCtor, S.Member, S.Index, S.Paren)


def _out_modes(call, ctx) -> dict:
    f = ctx.functions.get(call.func) if ctx is not None else None
    if f is not None:
        return {k: p.mode for k, p in enumerate(f.params) if p.mode != "in"}
    return OUT_BUILTINS.get(call.func, {})


def is_pure(node, ctx: Context | None) -> bool:
    """Whether evaluating ``node`` changes nothing: no assignment, ``++``/``--``, nor call of a
    function that writes its arguments or globals (without ``ctx``: of any function)."""
    for n in walk(node):
        if isinstance(n, (S.Assign, S.IncDec)):
            return False
        if isinstance(n, S.Call) and (ctx is None or n.func in OUT_BUILTINS or n.func in ctx.impure):
            return False
    return True


def _scan(n, role, nodes, last, occ, ctx):
    """:func:`scan` below ``n``, read (``role`` None) or stored into (``role``)."""
    nodes.append(n)
    t = type(n)
    if t is S.Name:
        occ.setdefault(n.name, []).append((n, role or "read"))
    elif role and t is S.Paren:
        _scan(n.inner, role, nodes, last, occ, ctx)
    elif role and (t is S.Member or t is S.Index):
        _scan(n.base, "part" if role == "store" else role, nodes, last, occ, ctx)
        if t is S.Index:
            _scan(n.index, None, nodes, last, occ, ctx)
    elif t is S.Assign:
        _scan(n.target, "store" if n.op == "=" else "update", nodes, last, occ, ctx)
        _scan(n.value, None, nodes, last, occ, ctx)
    elif t is S.IncDec:
        _scan(n.operand, "update", nodes, last, occ, ctx)
    elif t is S.Call:
        modes = _out_modes(n, ctx)
        for k, a in enumerate(n.args):
            _scan(a, {"out": "store", "inout": "update"}.get(modes.get(k, "in")), nodes, last, occ, ctx)
    else:
        for c in children(n):
            _scan(c, None, nodes, last, occ, ctx)
    last[id(n)] = len(nodes) - 1


def scan(root, ctx: Context | None = None) -> tuple[list, dict, dict]:
    """The def-use facts of the tree below ``root``, from one walk: ``(nodes, last, occ)``:
    ``nodes`` as :func:`walk` lists them; ``last`` ``{id(node): the position in nodes of the last
    node below it}``; ``occ`` ``{name: [(Name node, role), ...]}`` of every variable named, in
    source order, ``role`` one of ``"read"``; ``"store"`` (``x = ...``, or an ``out``
    argument); ``"part"`` (a store to part of it: ``x.y = ...``, ``x[i] = ...``); ``"update"``
    (read and written: ``x += ...``, ``x++``, an ``inout`` argument, ``x.y += ...``)."""
    nodes: list = []
    last: dict = {}
    occ: dict = {}
    _scan(root, None, nodes, last, occ, ctx)
    return nodes, last, occ


def paren(e):
    """``e``, in parentheses unless it is an atom (a name, literal, call, member or index)."""
    return e if isinstance(e, ATOMS) else S.Paren(e)
