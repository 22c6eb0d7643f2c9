"""Struct fields and results nothing needs (:mod:`cellgl.export.compiler`), transforms of the
syntax tree (:mod:`cellgl.export.tree`):

- :func:`void_results`: a function whose every call is a statement of its own (``f(x);``: its
  value thrown away) returns ``void``: its ``return`` statements lose their value, so what only
  fed that value (a struct field, a local) is dead for the other passes;
- :func:`dead_fields`: a struct field that is stored (``o.f = ...;``) but never read (or read only
  by the stores to it: ``r.F[1] = r.F[0];``) goes, with its stores;
- :func:`constant_fields`: a struct made in one place only (one local of its type, no
  constructor call), whose field ``f`` is stored once, ``x.f = false;`` right where the local is
  made (in the same block, not in a branch or a loop), holds that literal wherever the struct
  goes: every ``v.f`` of a variable of that type reads it. The reads become the literal (the
  constant folding then drops the branches it decides) and the field goes.
"""
from __future__ import annotations

from cellgl.export import syntax as S
from cellgl.export.inline import call_sites, defined_once, literal, parenthesise, statement_lists
from cellgl.export.tree import Context, calls, clone, transform, walk, writes

__all__ = ["void_results", "dead_fields", "constant_fields"]


def _functions(unit: S.Unit):
    return [it for it in unit.items if isinstance(it, S.Function) and it.body is not None]


def _types(unit: S.Unit, fn: S.Function) -> dict[str, set]:
    """name -> the types it is declared with in ``fn`` (parameters, locals) and at the top level."""
    top = [(d.name, it.type) for it in unit.items if isinstance(it, S.Global) for d in it.declarators]
    local = [(p.name, p.type) for p in fn.params] + [
        (d.name, n.type) for n in walk(fn.body) if isinstance(n, S.Decl) for d in n.declarators]
    out: dict[str, set] = {}
    for scope in (top, local):                  # a local name hides a global one
        types: dict[str, set] = {}
        for name, t in scope:
            types.setdefault(name, set()).add(t)
        out.update(types)
    return out


def _of(member: S.Member, struct: str, types: dict) -> bool | None:
    """Whether ``member``'s base is a variable of type ``struct`` (True), surely not (False), or
    unknown (None)."""
    base = member.base
    while isinstance(base, (S.Index, S.Paren)):
        base = base.inner if isinstance(base, S.Paren) else base.base
    if not isinstance(base, S.Name) or base.name not in types:
        return None
    t = types[base.name]
    return True if t == {struct} else (False if struct not in t else None)


# --------------------------------------------------------------------------------------------
# results no caller reads
# --------------------------------------------------------------------------------------------

def void_results(unit: S.Unit, ctx: Context) -> bool:
    """``T f(...)`` -> ``void f(...)`` where every call of ``f`` (not an entry point, defined
    once, called at least once) is a statement ``f(...);`` and its returned values store nothing
    (no assignment, no call to a function with effects)."""
    once, changed = defined_once(unit), False
    index = call_sites(unit)
    alone = {id(s.expr): g for g in _functions(unit) for _, s in statement_lists(g.body) if isinstance(s, S.ExprStmt)}
    for f in _functions(unit):
        if f.ret == "void" or f.name in ctx.entries or f.name not in once:
            continue
        sites = index.get(f.name, [])
        rets = [n for n in walk(f.body) if isinstance(n, S.Return)]
        if not sites or not all(alone.get(id(c), f) is not f for _, c in sites) or any(
                any(isinstance(n, (S.Assign, S.IncDec)) or (isinstance(n, S.Call) and n.func in ctx.impure)
                    for n in walk(r.value)) for r in rets if r.value is not None):
            continue
        f.ret = "void"
        for r in rets:
            r.value = None
        if f.body.body and isinstance(f.body.body[-1], S.Return):
            f.body.body.pop()                          # the last statement
        changed = True
    return changed


# --------------------------------------------------------------------------------------------
# fields never read
# --------------------------------------------------------------------------------------------

def _effects_unused(fn: S.Function, s, ctx: Context) -> bool:
    """Whether the calls in the store ``s`` change only locals of ``fn`` that nothing reads after
    it (and ``s`` is not in a loop): then the statement can go whole."""
    if any(isinstance(n, (S.For, S.While)) and any(x is s for x in walk(n)) for n in walk(fn.body)):
        return False
    order = [n for n in walk(fn.body)]
    at = next(k for k, n in enumerate(order) if n is s)
    inside = {id(n) for n in walk(s)}
    after = {n.name for n in order[at:] if isinstance(n, S.Name) and id(n) not in inside}
    local = {d.name for n in order[:at] if isinstance(n, S.Decl) for d in n.declarators}
    for c in walk(s):
        if not isinstance(c, S.Call) or c.func not in ctx.impure:
            continue
        g, outs = ctx.functions.get(c.func), ctx.out_positions(c.func)
        if g is None or not outs or calls(g.body) & ctx.impure or writes(g.body) & ctx.globals_:
            return False
        for k in outs:
            a = c.args[k] if k < len(c.args) else None
            if not isinstance(a, S.Name) or a.name not in local or a.name in after:
                return False
    return True


def _facts(funcs):
    """``(members, stores, ctors)``: field name -> ``[(function, Member)]`` of every field access,
    field name -> ``[(function, list, statement, v)]`` of the statements ``v.f = ...;`` and
    ``v.f[i] = ...;``, and the types constructed."""
    members: dict[str, list] = {}
    stores: dict[str, list] = {}
    ctors = set()
    for f in funcs:
        for n in walk(f.body):
            if isinstance(n, S.Member):
                members.setdefault(n.name, []).append((f, n))
            elif isinstance(n, S.Ctor):
                ctors.add(n.type)
        for lst, s in statement_lists(f.body):
            match s:
                case S.ExprStmt(expr=S.Assign("=", S.Member(S.Name(v), name)
                                              | S.Index(S.Member(S.Name(v), name)))):
                    stores.setdefault(name, []).append((f, lst, s, v))
    return members, stores, ctors


def _drop(lst: list, s) -> None:
    lst[:] = [x for x in lst if x is not s]


def dead_fields(unit: S.Unit, ctx: Context) -> bool:
    """Remove the struct fields that are stored but never read, and those stores."""
    structs = [it for it in unit.items if isinstance(it, S.Struct)]
    if not structs:
        return False
    funcs = _functions(unit)
    exposed = {t for f in funcs if f.name in ctx.entries for t in [f.ret] + [p.type for p in f.params]}
    members, stores, ctors = _facts(funcs)
    types = {id(f): _types(unit, f) for f in funcs}
    changed, gone = False, set()
    for st in structs:
        if st.name in exposed or st.name in ctors:
            continue
        holders = {id(f): {k for k, v in types[id(f)].items() if st.name in v} for f in funcs}
        if not any(holders.values()):
            continue
        dead = []
        for fd in st.fields:
            if fd.name in gone:
                continue
            mine = [(f, lst, s) for f, lst, s, v in stores.get(fd.name, ()) if v in holders[id(f)]]
            ok = all(not any(isinstance(n, S.Call) and n.func in ctx.impure for n in walk(s))
                     or _effects_unused(f, s, ctx) for f, _, s in mine)
            own = {id(n) for _, _, s in mine for n in walk(s)}
            ok = ok and all(id(n) in own or _of(n, st.name, types[id(f)]) is False
                            for f, n in members.get(fd.name, ()))
            if ok and mine:
                dead.append((fd, mine))
        if not dead or len(dead) == len(st.fields):
            continue
        for fd, mine in dead:
            gone.add(fd.name)
            _drop(st.fields, fd)
            for _, lst, s in mine:
                _drop(lst, s)
        changed = True
    return changed


# --------------------------------------------------------------------------------------------
# fields holding one literal
# --------------------------------------------------------------------------------------------

def _stored_fields(funcs, ctx: Context) -> dict[str, int]:
    """field name -> how many stores reach a field of that name (assignments, ``++``, ``out``
    arguments)."""
    out: dict[str, int] = {}
    for f in funcs:
        for n in walk(f.body):
            if isinstance(n, S.Assign):
                targets = [n.target]
            elif isinstance(n, S.IncDec):
                targets = [n.operand]
            elif isinstance(n, S.Call):
                targets = [n.args[k] for k in ctx.out_positions(n.func) if k < len(n.args)]
            else:
                continue
            for t in targets:
                for x in walk(t):
                    if isinstance(x, S.Member):
                        out[x.name] = out.get(x.name, 0) + 1
    return out


def constant_fields(unit: S.Unit, ctx: Context) -> bool:
    """Fold the fields of one-literal structs (module docstring)."""
    structs = [it for it in unit.items if isinstance(it, S.Struct)]
    if not ctx.fold_constants or not structs:
        return False
    funcs = _functions(unit)
    members, _, ctors = _facts(funcs)
    stored = _stored_fields(funcs, ctx)
    # a struct the entry points take or give, or a global holds, has values from outside
    outside = {t for f in funcs if f.name in ctx.entries for t in [f.ret] + [p.type for p in f.params]} \
        | {it.type for it in unit.items if isinstance(it, S.Global)}
    types: dict[int, dict] = {}
    changed, gone = False, set()
    # (the statement lists and declarations stay: the loop drops stores and fields, rewrites reads)
    decls = [(f, lst, s) for f in funcs for lst, s in statement_lists(f.body) if isinstance(s, S.Decl)
             and len(s.declarators) == 1 and s.declarators[0].init is None and s.declarators[0].size is None]
    for st in structs:
        made = [(f, lst, s) for f, lst, s in decls if s.type == st.name]
        if len(made) != 1 or st.name in ctors or st.name in outside:
            continue
        home, lst, decl = made[0]
        var = decl.declarators[0].name
        for fd in list(st.fields):
            if fd.size is not None or stored.get(fd.name, 0) != 1 or fd.name in gone:
                continue
            at = next(k for k, x in enumerate(lst) if x is decl)
            store = next((s for s in lst[at + 1:] if isinstance(s, S.ExprStmt) and isinstance(s.expr, S.Assign)
                          and s.expr.op == "=" and isinstance(s.expr.target, S.Member)
                          and s.expr.target.name == fd.name and isinstance(s.expr.target.base, S.Name)
                          and s.expr.target.base.name == var and literal(s.expr.value, False)), None)
            if store is None:
                continue
            assert isinstance(store.expr, S.Assign)     # (picked above: an assignment)
            reads: dict[int, tuple[S.Function, set[int]]] = {}
            ok = True
            for f, n in members.get(fd.name, ()):
                if n is store.expr.target:
                    continue
                if id(f) not in types:
                    types[id(f)] = _types(unit, f)
                kind = _of(n, st.name, types[id(f)])
                if kind and isinstance(n.base, S.Name):
                    reads.setdefault(id(f), (f, set()))[1].add(id(n))
                elif kind is not False:
                    ok = False
            if not ok:
                continue
            value = store.expr.value
            _drop(lst, store)
            _drop(st.fields, fd)
            gone.add(fd.name)
            for f, ids in reads.values():
                f.body = parenthesise(transform(f.body, lambda n, ids=ids, value=value: clone(value) if id(n) in ids else n))
            changed = True
    return changed
