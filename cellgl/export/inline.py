"""Inlining and the parameter passes of the snippet compiler (:mod:`cellgl.export.compiler`'s
round), transforms of the syntax tree (:mod:`cellgl.export.tree`): short functions become their
expression (:func:`inline_short`), functions called once their body (:func:`inline_once`),
parameters never read, always given the same literal, or written for no caller go
(:func:`drop_unused_params`, :func:`constant_args`, :func:`drop_unused_outs`).

The values do not change: the statements run in the same order on the same values.
"""
from __future__ import annotations

import textwrap
from collections import Counter
from typing import Any

from cellgl.export import syntax as S
from cellgl.export.printer import expr_glsl, statement_glsl
from cellgl.export.reach import first_sentence
from cellgl.export.syntax import PRECEDENCE
from cellgl.export.tree import CHILD_FIELDS, EXPRESSIONS, Context, calls, clone, is_pure, root_name, transform, walk
from cellgl.export.tree import writes

__all__ = ["KEEP", "defined_once", "literal", "inline_short", "inline_once", "drop_unused_params", "constant_args", "drop_unused_outs",
           "substitute", "statement_lists", "call_sites", "names"]

#: a body of this many lines keeps its function's comment where it is inlined
_COMMENTED = 20
#: functions that stay functions where called once: the hash, the first thing a reader looks for
KEEP = ("cellgl_hash_u32",)
_VEC = {f"{p}vec{n}" for p in ("", "i", "u") for n in (2, 3, 4)}


# --------------------------------------------------------------------------------------------
# expressions: precedence, parentheses, substitution
# --------------------------------------------------------------------------------------------

def _prec(e) -> int:
    if isinstance(e, S.Binary):
        return 2 + PRECEDENCE[e.op]
    if isinstance(e, S.IncDec):
        return 30 if e.postfix else 20
    return {S.Assign: 0, S.Ternary: 1, S.Unary: 20}.get(type(e), 30)    # 30: postfix and primary


def _need(parent, slot: str) -> int:
    """The least precedence an expression in ``parent``'s field ``slot`` may have without
    parentheses (the tree's own grouping kept exactly; - -x would print as --x)."""
    if isinstance(parent, S.Binary):
        return 2 + PRECEDENCE[parent.op] + (slot != "left")
    if isinstance(parent, (S.Unary, S.IncDec)) or (isinstance(parent, (S.Member, S.Index)) and slot == "base"):
        return 30
    return (2 if slot == "cond" else 1) if isinstance(parent, S.Ternary) else 0


def parenthesise(node):
    """Wrap in parentheses every expression below ``node`` that its place needs grouped (after a
    substitution: the tree is the meaning, the parentheses only its printing)."""
    for name, many in CHILD_FIELDS[type(node)]:
        v = getattr(node, name)
        if many:
            for x in v:
                parenthesise(x)
        elif v is not None:
            parenthesise(v)
            if isinstance(v, EXPRESSIONS) and _prec(v) < _need(node, name):
                setattr(node, name, S.Paren(v))
    return node


def _bare(e):
    while isinstance(e, S.Paren):
        e = e.inner
    return e


def substitute(node, env: dict, rename: dict | None = None):
    """``node`` (changed in place; the new root returned) with each name of ``env`` replaced by a
    copy of its expression and each of ``rename`` renamed (declarations too)."""
    rename = rename or {}

    def sub(n):
        if isinstance(n, S.Name):
            if n.name in rename:
                return S.Name(rename[n.name])
            if n.name in env:
                return clone(_bare(env[n.name]))
        elif isinstance(n, S.Declarator) and n.name in rename:
            n.name = rename[n.name]
        return n

    return parenthesise(transform(node, sub))


def names(node) -> set[str]:
    """The variables named below ``node`` (read, written or declared)."""
    return {n.name for n in walk(node) if isinstance(n, (S.Name, S.Declarator, S.Param))} - {"true", "false"}


def _flat(e) -> bool:
    return not any(isinstance(n, (S.Call, S.Ctor, S.Paren)) for n in walk(e))


def _simple(e) -> bool:
    """A name, literal, field or element of one, or a call on such arguments."""
    if isinstance(e, (S.Member, S.Index)):
        return _simple(e.base) and not isinstance(e.base, (S.Call, S.Ctor)) \
            and (isinstance(e, S.Member) or _flat(e.index))
    return isinstance(e, (S.Name, S.Num)) or (isinstance(e, (S.Call, S.Ctor)) and all(_flat(a) for a in e.args))


def _cheap(e) -> bool:
    """An argument that may be written twice: a name, field, literal, or a short sum of those
    and of casts."""
    return (_simple(e) and _flat(e)) or len(expr_glsl(e)) <= 24 and all(
        isinstance(n, (S.Name, S.Num, S.Member, S.Paren)) or (isinstance(n, S.Binary) and n.op in "+-*")
        or (isinstance(n, S.Unary) and n.op in "+-") or (isinstance(n, S.Ctor) and n.type in ("float", "int", "uint"))
        for n in walk(e))


def literal(e, vectors: bool = True) -> bool:
    """A number (``0u``, ``-1.5``), ``true``/``false``, or (``vectors``) a vector of numbers
    (``vec4(0.0, 0.0, 0.0, 0.0)``)."""
    e = _bare(e)
    if isinstance(e, S.Ctor) and vectors:
        return e.type in _VEC and all(literal(a, False) and not isinstance(a, S.Name) for a in e.args)
    if isinstance(e, S.Unary) and e.op == "-":
        e = e.operand
    return isinstance(e, S.Num) or (isinstance(e, S.Name) and e.name in ("true", "false"))


# --------------------------------------------------------------------------------------------
# where calls are
# --------------------------------------------------------------------------------------------

def statement_lists(node):
    """``(list, statement)`` of every statement below ``node`` held in a block's list, outermost
    first."""
    return [(n.body, s) for n in walk(node) if isinstance(n, S.Block) for s in n.body]


def defined_once(unit: S.Unit) -> dict[str, S.Function]:
    """``{name: function}`` of the functions with a body and no other definition or prototype."""
    count = Counter(it.name for it in unit.items if isinstance(it, S.Function))
    return {it.name: it for it in unit.items if isinstance(it, S.Function) and it.body is not None
            and count[it.name] == 1}


def call_sites(unit: S.Unit) -> dict[str, list]:
    """``{name: [(function, call), ...]}``: every call in the bodies of ``unit``'s functions."""
    out: dict[str, list] = {}
    for f in unit.items:
        if isinstance(f, S.Function) and f.body is not None:
            for n in walk(f.body):
                if isinstance(n, S.Call):
                    out.setdefault(n.func, []).append((f, n))
    return out


# --------------------------------------------------------------------------------------------
# short functions: their expression at every call
# --------------------------------------------------------------------------------------------

def _short(unit: S.Unit, ctx: Context) -> dict:
    """``{name: (parameter names, expression)}`` of the functions short enough to inline."""
    sites = {k: len(v) for k, v in ctx.sites.items()}
    out = {}
    for it in unit.items:
        if not isinstance(it, S.Function) or it.body is None or it.name in ctx.entries:
            continue
        if any(p.mode != "in" or p.size is not None for p in it.params):
            continue
        expr = _forward(it.body.body, {p.name for p in it.params})
        if expr is None or it.name in calls(expr):
            continue
        n = len(expr_glsl(expr))
        if n > 72 or (n > 48 and sites.get(it.name, 0) > 1):
            continue                          # a long expression stays one function where it is used often
        out[it.name] = ([p.name for p in it.params], expr)
    return out


def _forward(body: list, params: set) -> object | None:
    """The returned expression of the straight-line ``body`` with every local and parameter
    store substituted forward (None: not straight-line)."""
    env: dict = {}
    for s in body:
        if any(isinstance(n, S.Ternary) for n in walk(s)):
            return None
        if isinstance(s, S.Return) and s is body[-1] and s.value is not None:
            return substitute(clone(s.value), env)
        if isinstance(s, S.Decl) and not s.const and len(s.declarators) == 1 and s.declarators[0].size is None \
                and s.declarators[0].init is not None:
            name, value = s.declarators[0].name, s.declarators[0].init
        elif isinstance(s, S.ExprStmt) and isinstance(s.expr, S.Assign) and s.expr.op == "=" \
                and isinstance(s.expr.target, S.Name) and (s.expr.target.name in params or s.expr.target.name in env):
            name, value = s.expr.target.name, s.expr.value
        else:
            return None
        env[name] = substitute(clone(value), env)
    return None


def inline_short(unit: S.Unit, ctx: Context) -> bool:
    """Short functions (not the entry points) become their expression at their calls."""
    small = _short(unit, ctx)
    if not small:
        return False
    changed = hit = False
    hidden: set = set()

    def at(n):
        nonlocal hit
        if not isinstance(n, S.Call) or n.func not in small:
            return n
        params, expr = small[n.func]
        if len(n.args) != len(params) or not all(is_pure(a, ctx) for a in n.args) \
                or (names(expr) - set(params)) & hidden:
            return n
        for p, a in zip(params, n.args):
            based = any(isinstance(x, (S.Member, S.Index)) and isinstance(_bare(x.base), S.Name)
                        and _bare(x.base).name == p for x in walk(expr))
            if based and not _simple(_bare(a)):
                return n                      # (a + b).xy: keep the call
            if sum(type(n) is S.Name and n.name == p for n in walk(expr)) > 1 and not _cheap(_bare(a)):
                return n                      # an argument the expression reads twice: compute it once
        hit = True
        return substitute(clone(expr), dict(zip(params, n.args)))

    callers = {id(g) for name in small for g, _ in ctx.sites.get(name, ())}
    for f in unit.items:
        if not isinstance(f, S.Function) or f.body is None or id(f) not in callers:
            continue
        hidden, hit = {n.name for n in walk(f) if type(n) in (S.Param, S.Declarator)}, True   # its own names
        while hit:                            # (an expression may call another short function)
            hit = False
            transform(f.body, at)
            if hit:
                parenthesise(f.body)
                changed = True
    return changed


# --------------------------------------------------------------------------------------------
# functions called once: their body in place of the call
# --------------------------------------------------------------------------------------------

def inline_once(unit: S.Unit, ctx: Context) -> bool:
    """Inline every function (not an entry, not kept) called exactly once, where that is safe: from
    a statement (``f(a);``, ``T v = f(a);``, ``v = f(a);``, ``return f(a);``, or any statement
    that may compute the call first into a local), with a body that returns only at its end. An
    ``out`` / ``inout`` parameter becomes its argument (a variable, or a field or element of one,
    that no other argument names); an ``in`` parameter becomes its argument where that is a name,
    field or literal, or read once outside loops, and a local copy otherwise (always where the
    body writes it: GLSL's ``in`` is a copy); the body's locals are renamed where the caller uses
    the name."""
    keep = set(ctx.entries) | set(ctx.keep) | set(KEEP)
    once, index, changed = defined_once(unit), ctx.sites, False
    failed: set = set()         # (callee, caller) that would not inline (until the caller changes)
    while True:
        for f in unit.items:
            sites: list[tuple[S.Function, S.Call]] = index.get(getattr(f, "name", None), [])
            if not (sites and isinstance(f, S.Function) and once.get(f.name) is f and f.name not in keep and len(sites) == 1
                    and sites[0][0] is not f and (id(f), id(sites[0][0])) not in failed):
                continue
            if not _inline_call(f, *sites[0], ctx):
                failed.add((id(f), id(sites[0][0])))    # (it reads only the two and the context)
                continue
            # (the context's facts stay a superset until the next pass refreshes them)
            caller, changed = sites[0][0], True
            unit.items[:] = [it for it in unit.items if it is not f]
            failed = {pair for pair in failed if id(caller) not in pair}
            index = {k: [(g, c) for g, c in v if g is not caller and g is not f] for k, v in index.items()}
            for n in walk(caller.body):
                if isinstance(n, S.Call):
                    index.setdefault(n.func, []).append((caller, n))
            break
        else:
            return changed


def _call_statement(lists: list, call: S.Call):
    """``(list, statement, form, target, type)`` of the statement the call makes up: ``f(...);``
    (form "stmt"), ``return f(...);``, ``T v = f(...);`` ("decl"), ``v = f(...);`` ("assign")."""
    for lst, s in lists:
        if isinstance(s, S.ExprStmt) and s.expr is call:
            return lst, s, "stmt", None, None
        if isinstance(s, S.Return) and s.value is call:
            return lst, s, "return", None, None
        if isinstance(s, S.Decl) and not s.const and len(s.declarators) == 1 and s.declarators[0].init is call \
                and s.declarators[0].size is None:
            return lst, s, "decl", s.declarators[0].name, s.type
        if isinstance(s, S.ExprStmt) and isinstance(s.expr, S.Assign) and s.expr.op == "=" \
                and s.expr.value is call and isinstance(s.expr.target, S.Name):
            return lst, s, "assign", s.expr.target.name, None
    return None


def _hoist_site(lists: list, call: S.Call, f: S.Function, ctx: Context):
    """``(list, statement, "hoist", None, type)`` where ``call`` sits inside the expression of a
    statement that may compute it first, into a local: evaluated every time the statement is
    (not under ``&&``, ``||`` or ``?:``), and nothing else in the statement stores anything or
    reads what the call writes."""
    for lst, s in lists:
        if not isinstance(s, (S.ExprStmt, S.Return)) and not (isinstance(s, S.Decl) and len(s.declarators) == 1):
            continue
        if not any(n is call for n in walk(s)):
            continue
        maybe = [x for n in walk(s) for x in ([n.then, n.other] if isinstance(n, S.Ternary) else [n.right]
                                              if isinstance(n, S.Binary) and n.op in ("&&", "||") else [])]
        if any(n is call for x in maybe for n in walk(x)):
            return None                       # evaluated only sometimes
        inside = {id(n) for n in walk(call)}
        rest = [n for n in walk(s) if id(n) not in inside]
        top = s.expr if isinstance(s, S.ExprStmt) and isinstance(s.expr, S.Assign) else None
        outs = {root_name(call.args[k]) for k in ctx.out_positions(call.func) if k < len(call.args)}
        if any((isinstance(n, (S.Assign, S.IncDec)) and n is not top) or (isinstance(n, S.Call) and n.func in ctx.impure)
               for n in rest) or outs & {n.name for n in rest if isinstance(n, S.Name)} \
                or (isinstance(s, S.Decl) and s.declarators[0].name in names(call)):
            return None
        return lst, s, "hoist", None, f.ret
    return None


def _lvalue(e) -> bool:
    """A variable, or a field or element (at a name or literal) of one."""
    while isinstance(e, (S.Member, S.Index)):
        if isinstance(e, S.Index) and not isinstance(e.index, (S.Name, S.Num)):
            return False
        e = e.base
    return isinstance(e, S.Name)


def _loop_vars(nodes: list) -> set[str]:
    """The names declared in ``nodes`` (a :func:`walk`) only as ``for`` loops' variables."""
    inits = {id(n.init) for n in nodes if isinstance(n, S.For)}
    decls = [(id(s) in inits, d.name) for s in nodes if isinstance(s, S.Decl) for d in s.declarators]
    return {n for loop, n in decls if loop} - {n for loop, n in decls if not loop}


def _inline_call(f: S.Function, caller: S.Function, call: S.Call, ctx: Context) -> bool:
    if any(isinstance(n, S.Jump) and n.kind == "discard" for n in walk(f.body)) \
            or any(p.size is not None for p in f.params) or len(call.args) != len(f.params):
        return False
    assert f.body is not None               # (inline_once picks functions with a body)
    body = list(f.body.body)
    rets = [n for n in walk(f.body) if isinstance(n, S.Return)]
    ret: Any = None                         # the returned expression (a node), if any
    if f.ret == "void":
        if body and isinstance(body[-1], S.Return) and body[-1].value is None:
            body = body[:-1]
            rets = rets[:-1]
        if rets:
            return False
    else:
        if len(rets) != 1 or not body or body[-1] is not rets[0] or rets[0].value is None:
            return False
        ret, body = clone(rets[0].value), body[:-1]
    everything = walk(caller)                 # (the caller, its parameters and its body)
    lists = [(n.body, s) for n in everything if type(n) is S.Block for s in n.body]   # (statement_lists)
    site = _call_statement(lists, call) or _hoist_site(lists, call, f, ctx)
    if site is None:
        return False
    lst, stmt, form, target, typ = site
    hoist = form == "hoist"
    if hoist:
        # T v = f(...) before the statement, which reads v: the body's returned local v, or a
        # local named for the function (cellgl_noise_gradient_: gradient)
        own = isinstance(ret, S.Name) and any(isinstance(s, S.Decl) and any(d.name == ret.name for d in s.declarators)
                                               for s in body)
        form, target = "decl", ret.name if own else [w for w in f.name.split("_") if w][-1]
    if (form != "stmt" and ret is None) or (form == "stmt" and ret is not None and calls(ret)):
        return False
    body = [clone(s) for s in body]
    block = S.Block(body)
    params = [p.name for p in f.params]
    declared = {n.name for n in walk(block) if isinstance(n, S.Declarator)}
    if declared & set(params):
        return False                          # a local shadowing a parameter
    caller_declared = {n.name for n in everything if type(n) in (S.Param, S.Declarator)}
    caller_names = {n.name for n in everything if type(n) is S.Name} - {"true", "false"} | caller_declared \
        | {n.func for n in everything if type(n) is S.Call}
    body_ids = names(block) | (names(ret) if ret is not None else set()) | calls(block)
    if (body_ids - declared - set(params)) & caller_declared:
        return False                          # the body reads a global the caller hides with a local
    if hoist:
        k, stem = 2, target
        while target in caller_names or target in ctx.functions or (target in body_ids and not own):
            target, k = f"{stem}{k}", k + 1
    written = writes(block, ctx)
    # what the body (and the returned value) does with each name: reads, reads as a field's or
    # element's base, reads inside a loop
    inner = walk(block) + (walk(ret) if ret is not None else [])
    reads = Counter(n.name for n in inner if type(n) is S.Name)
    based = {x.base.name for x in inner if isinstance(x, (S.Member, S.Index)) and isinstance(x.base, S.Name)}
    looped = {n.name for x in walk(block) if isinstance(x, (S.For, S.While))
              for n in walk(x) if type(n) is S.Name}
    args = call.args
    out_bases = {root_name(a) for p, a in zip(f.params, args) if p.mode != "in"}
    subst: dict = {}
    prelude = []
    for p, a in zip(f.params, args):
        if p.mode != "in":
            if not _lvalue(a) or sum(root_name(a) in names(b) for b in args) != 1:
                return False                  # not a variable, or the same variable in two arguments
            subst[p.name] = a
            continue
        arg_ids = names(a)
        if p.name in written:
            if form == "assign" and isinstance(a, S.Name) and a.name == target and isinstance(ret, S.Name) \
                    and ret.name == p.name and target not in out_bases and sum(target in names(b) for b in args) == 1:
                subst[p.name] = a
                continue
            prelude.append((p, a))
            declared.add(p.name)
            continue
        b = _bare(a)
        simple = _lvalue(b) and all(isinstance(x, (S.Name, S.Member)) for x in walk(b)) or isinstance(b, S.Num) \
            or (isinstance(b, S.Unary) and b.op == "-" and isinstance(b.operand, S.Num))
        if (simple or (reads[p.name] <= 1 and p.name not in based and p.name not in looped
                       and not calls(a) & set(ctx.functions))) \
                and not (arg_ids & out_bases) \
                and not (arg_ids & written & ctx.globals_):
            subst[p.name] = a
        else:
            prelude.append((p, a))
            declared.add(p.name)
    rename: dict[str, str] = {}
    if hoist and own and not (ret.name in declared and _decl_type(body, ret.name, prelude) == typ):
        return False
    if form == "decl" and isinstance(ret, S.Name) and ret.name in declared and _decl_type(body, ret.name, prelude) == typ \
            and sum(type(n) is S.Declarator and n.name == target for n in everything) == (not hoist) \
            and not any(target in names(a) for a in args):
        rename[ret.name] = target
        ret = None
        caller_names.discard(target)
    # a loop's variable of the body clashes only with the arguments it reads, or a loop of the
    # caller's around the call
    arg_names = {n for a in subst.values() for n in names(a)}
    taken = caller_names | body_ids | arg_names
    loop_vars = _loop_vars(walk(block)) - {p.name for p, _ in prelude} - (caller_declared - _loop_vars(everything))
    outer_loops: set[str] | None = None     # (computed at the first loop variable that needs it)
    for d in sorted(declared):
        if d in rename:
            continue
        if d in loop_vars and d not in arg_names and outer_loops is None:
            outer_loops = {v.name for n in everything if isinstance(n, S.For) and isinstance(n.init, S.Decl)
                           and any(x is stmt for x in walk(n.body)) for v in n.init.declarators}
        if d in caller_names and not (d in loop_vars and d not in arg_names and d not in (outer_loops or ())):
            k = 2
            while f"{d}{k}" in taken:
                k += 1
            rename[d] = f"{d}{k}"
            taken.add(rename[d])
    if form == "decl" and target in (body_ids - set(rename)) and not any(
            isinstance(a, S.Name) and a.name == target for a in subst.values()):
        return False
    new: list = [S.Decl(p.type, [S.Declarator(rename.get(p.name, p.name), init=clone(_bare(a)))]) for p, a in prelude]
    new += substitute(block, subst, rename).body
    if ret is not None:
        r = substitute(S.Return(ret), subst, rename).value
        if form == "decl":
            new.append(S.Decl(typ, [S.Declarator(target, init=r)]))
        elif form == "assign" and not (isinstance(r, S.Name) and r.name == target):
            new.append(S.ExprStmt(S.Assign("=", S.Name(target), r)))
        elif form == "return":
            new.append(S.Return(r))
    if new:
        head = [] if hoist else list(stmt.comments)
        if f.comments and sum(not ln.lstrip().startswith("//") for s in body
                              for ln in statement_glsl(s)) >= _COMMENTED:
            # a long body keeps the first sentence of its function's comment
            text = first_sentence("\n".join(c for c in f.comments if c), 116)
            head.append("\n".join("// " + ln for ln in textwrap.wrap(text, 113)))
        new[0].comments = head + list(new[0].comments)
        if not hoist and getattr(stmt, "trail", None) and hasattr(new[-1], "trail") and not new[-1].trail:
            new[-1].trail = stmt.trail
    k = next(i for i, s in enumerate(lst) if s is stmt)
    if hoist:
        lst[k:k] = new
        transform(stmt, lambda n: S.Name(target) if n is call else n)
    else:
        lst[k:k + 1] = new
    return True


def _decl_type(body: list, name: str, prelude: list) -> str | None:
    for p, _ in prelude:
        if p.name == name:
            return p.type
    for s in body:
        if isinstance(s, S.Decl) and any(d.name == name and d.size is None for d in s.declarators):
            return s.type
    return None


# --------------------------------------------------------------------------------------------
# parameters
# --------------------------------------------------------------------------------------------

def _each_param(unit: S.Unit, ctx: Context, drop) -> bool:
    """Call ``drop(f, k, sites)`` for each parameter ``k`` of each function ``f`` whose signature
    may change (defined once, not an entry point; ``sites``: its calls elsewhere, each with an
    argument per parameter); where it returns True, the parameter and its arguments go."""
    index, changed = ctx.sites, False
    for f in defined_once(unit).values():
        if f.name in ctx.entries:
            continue
        sites = index.get(f.name, [])
        if any(len(c.args) != len(f.params) for _, c in sites):
            continue
        k = 0
        while k < len(f.params):
            if f.params[k].size is None and drop(f, k, [(g, c) for g, c in sites if g is not f]):
                del f.params[k]
                for _, c in sites:
                    del c.args[k]
                changed = True
            else:
                k += 1
    return changed


def drop_unused_params(unit: S.Unit, ctx: Context) -> bool:
    """Drop the parameters a function never reads (its callers' arguments with them)."""
    read: dict = {}                  # (a function's names: its body stays while its parameters go)

    def unread(f, k, sites):
        if id(f) not in read:
            read[id(f)] = names(f.body)
        return f.params[k].mode == "in" and f.params[k].name not in read[id(f)] \
            and all(is_pure(c.args[k], ctx) for _, c in sites)
    return _each_param(unit, ctx, unread)


def constant_args(unit: S.Unit, ctx: Context) -> bool:
    """A parameter that every call passes the same literal (``0u``, ``vec4(0.0, 0.0, 0.0, 0.0)``)
    becomes that literal in the body, and the argument goes."""

    def drop(f, k, sites):
        p = f.params[k]
        if p.mode != "in" or not sites or not literal(sites[0][1].args[k]) \
                or len({expr_glsl(_bare(c.args[k])) for _, c in sites}) != 1 or p.name in writes(f.body, ctx):
            return False
        f.body = substitute(f.body, {p.name: _bare(sites[0][1].args[k])})
        return True

    return _each_param(unit, ctx, drop)


def drop_unused_outs(unit: S.Unit, ctx: Context) -> bool:
    """An ``out`` parameter whose argument is, at every call, a local used nowhere else becomes a
    local of the function (whose stores the dead-store pass then removes)."""

    def drop(f, k, sites):
        p = f.params[k]
        if p.mode != "out" or not sites or not all(_lone_local(g, c.args[k]) for g, c in sites):
            return False
        f.body.body.insert(0, S.Decl(p.type, [S.Declarator(p.name)]))
        return True

    return _each_param(unit, ctx, drop)


def _lone_local(fn: S.Function, arg) -> bool:
    """Whether ``arg`` is a local of ``fn`` named only where it is declared and here."""
    if not isinstance(arg, S.Name):
        return False
    decls = [d for s in walk(fn.body) if isinstance(s, S.Decl) for d in s.declarators if d.name == arg.name]
    return len(decls) == 1 and decls[0].init is None and decls[0].size is None \
        and sum(isinstance(n, (S.Name, S.Declarator, S.Param)) and n.name == arg.name for n in walk(fn)) == 2
