"""The snippet compiler's simplification, on the syntax tree: function passes (:func:`cellgl.export.fold.fold`
runs them after the folding rules, in :mod:`cellgl.export.compiler`'s round) that use the def-use
facts of :class:`cellgl.export.fold.Facts`, and the identities that give the same value for every
IEEE-754 input (``x * 1.0``, ``x - 0.0``, ``mix(a, b, 0.0)``; not ``x + 0.0``: ``-0.0 + 0.0`` is
``+0.0``, nor ``x + 0.0 * y``: NaN for an infinite ``y``). Each pass says what it does.
"""
from __future__ import annotations

from bisect import bisect_left
from copy import copy

from cellgl.export import syntax as S
from cellgl.export.fold import (Facts, array_elements_rule, constant_conditions_rule, constant_loops_rule,
                                 inline_constants_rule, local_constants_rule, rewriting, rule)
from cellgl.export.printer import expr_glsl
from cellgl.export.tree import ATOMS, children, clone, is_pure, paren, root, transform, walk
from cellgl.export.values import value

__all__ = ["split_declarations", "dead_locals", "last_stores", "copies", "bare_blocks", "merge_declarations",
           "forward_literals", "loop_variables", "store_into_next", "identities", "parentheses", "SIMPLIFY",
           "EXPRESSIONS"]


def _store(s):
    """``(target, expression)`` of a statement that only stores (``x op= e;``, ``x++;``)."""
    if isinstance(s, S.ExprStmt):
        if isinstance(s.expr, S.Assign):
            return s.expr.target, s.expr
        if isinstance(s.expr, S.IncDec):
            return s.expr.operand, s.expr
    return None, None


def _pure_store(expr, ctx) -> bool:
    """Whether a store has no effect but the store: its value and indices have none."""
    return all(is_pure(x, ctx) for x in children(expr))


def _drop(body: list, s) -> None:
    """Remove the statement ``s`` from ``body``, its comments moving to the next statement."""
    k = next(i for i, x in enumerate(body) if x is s)
    if s.comments and k + 1 < len(body):
        body[k + 1].comments = s.comments + body[k + 1].comments
    del body[k]


def _single(s):
    """The declarator of a declaration of one name (no array), else None."""
    ok = isinstance(s, S.Decl) and len(s.declarators) == 1 and s.declarators[0].size is None
    return s.declarators[0] if ok else None


def split_declarations(fn: S.Function, facts: Facts) -> bool:
    """``vec4 a = x, b;`` -> ``vec4 a = x;`` and ``vec4 b;``."""
    changed = False
    for b in facts.blocks:
        out = []
        for s in b.body:
            if isinstance(s, S.Decl) and len(s.declarators) > 1:
                parts = [S.Decl(s.type, [d], s.const) for d in s.declarators]
                parts[0].comments, parts[-1].trail = s.comments, s.trail
                out += parts
                changed = True
            else:
                out.append(s)
        b.body[:] = out
    return changed


def dead_locals(fn: S.Function, facts: Facts) -> bool:
    """Remove a local that is never read (``T x = e;``, ``x = ...;``, ``x.y += ...;``,
    ``x[0] = ...;``): its declaration and the statements that store into it."""
    ctx = facts.ctx
    stores = {}                                   # id(root Name) -> (block, statement, expression)
    for b in facts.blocks:
        for s in b.body:
            t, e = _store(s)
            if root(t) is not None:
                stores[id(root(t))] = (b, s, e)
    changed = False                 # (the facts stay a superset: a read in a dropped store keeps a local)
    for b in facts.blocks:
        for s in list(b.body):
            if not (isinstance(s, S.Decl) and len(s.declarators) == 1):
                continue
            d = s.declarators[0]
            if d.name not in facts.once or d.name in facts.params or (d.init is not None and not is_pure(d.init, ctx)):
                continue
            uses = facts.occ.get(d.name, [])
            if all(role != "read" and id(n) in stores and _pure_store(stores[id(n)][2], ctx) for n, role in uses):
                for n, _ in uses:
                    sb, st, _ = stores[id(n)]
                    if any(x is st for x in sb.body):
                        _drop(sb.body, st)
                _drop(b.body, s)
                changed = True
    return changed


def last_stores(fn: S.Function, facts: Facts) -> bool:
    """Remove a store ``x op= ...;`` to a local (or an ``in`` parameter) that nothing reads
    afterwards, outside loops."""
    pos, last = facts.order
    changed = False                 # (the facts stay a superset: a read in a dropped store keeps a store)
    for b in facts.blocks:
        for s in list(b.body):
            t, e = _store(s)
            r = root(t)
            if r is None or r.name not in facts.types or id(s) in facts.in_loops \
                    or r.name in facts.params and facts.params[r.name].mode != "in":
                continue
            end = last[id(s)]
            if any(role in ("read", "update") and pos[id(n)] > end for n, role in facts.occ[r.name]) \
                    or not _pure_store(e, facts.ctx):
                continue
            _drop(b.body, s)
            changed = True
    return changed


def copies(fn: S.Function, facts: Facts) -> bool:
    """``float y = x;`` (``x`` a variable of the same type), with ``y`` never written again and
    ``x`` not after it: every ``y`` becomes ``x``."""
    pos, _ = facts.order
    for b in facts.blocks:
        for s in b.body:
            d = _single(s)
            if d is None or d.init is None:
                continue
            x = d.init
            while isinstance(x, S.Paren):
                x = x.inner
            if not isinstance(x, S.Name) or d.name not in facts.once or x.name == d.name or d.name in facts.params:
                continue
            typ = facts.types.get(x.name) if x.name in facts.declared else facts.garrays[None].get(x.name)
            if typ != s.type or (x.name in facts.declared and x.name not in facts.once):
                continue
            at = pos[id(s)]
            if x.name in facts.params and facts.params[x.name].mode == "in" and any(id(n) in facts.in_loops for n, _ in facts.occ.get(d.name, ())) \
                    and id(s) not in facts.in_loops:
                continue                     # (a parameter in a loop: its argument once inlined)
            if any(role != "read" for _, role in facts.occ.get(d.name, ())) or any(
                    role != "read" and pos[id(n)] > at for n, role in facts.occ.get(x.name, ())):
                continue
            name, old = x.name, d.name
            _drop(b.body, s)
            transform(fn.body, lambda n, name=name, old=old: S.Name(name) if isinstance(n, S.Name) and n.name == old
                      else n)
            return True
    return False


def bare_blocks(fn: S.Function, facts: Facts) -> bool:
    """``{ stmts }`` standing alone in a block -> ``stmts``, where no name it declares is used
    outside it (an empty one goes)."""
    pos, last = facts.order
    for b in facts.blocks:
        for k, s in enumerate(b.body):
            if not isinstance(s, S.Block):
                continue
            names = {d.name for x in s.body if isinstance(x, S.Decl) for d in x.declarators}
            lo, hi = pos[id(s)], last[id(s)]
            if any(not lo <= pos[id(n)] <= hi for name in names for n, _ in facts.occ.get(name, ())) \
                    or any(facts.declared.get(name, 0) > 1 for name in names):
                continue
            if s.body and s.comments:
                s.body[0].comments = s.comments + s.body[0].comments
            elif s.comments and k + 1 < len(b.body):
                b.body[k + 1].comments = s.comments + b.body[k + 1].comments
            b.body[k:k + 1] = s.body
            return True
    return False


def _mentions(node, name: str) -> bool:
    return any(isinstance(n, S.Name) and n.name == name for n in walk(node))


def merge_declarations(fn: S.Function, facts: Facts) -> bool:
    """``T x; ... x = e;`` (x unused between, in the same block) -> ``... T x = e;``."""
    changed = False
    for b in facts.blocks:
        k = 0
        while k < len(b.body):
            s = b.body[k]
            d = _single(s)
            j = None if d is None or d.init is not None or s.const else \
                next((i for i in range(k + 1, len(b.body)) if _mentions(b.body[i], d.name)), None)
            t = b.body[j] if j is not None else None
            if isinstance(t, S.ExprStmt) and isinstance(t.expr, S.Assign) and t.expr.op == "=" \
                    and isinstance(t.expr.target, S.Name) and t.expr.target.name == d.name \
                    and not _mentions(t.expr.value, d.name):
                assert j is not None                    # (t is b.body[j])
                b.body[j] = S.Decl(s.type, [S.Declarator(d.name, None, t.expr.value)], False,
                                   s.comments + t.comments, t.trail)
                del b.body[k]
                changed = True
            else:
                k += 1
    return changed


def _path(e):
    """``['r', '.loops']`` of ``r.loops``; an index is ``'[]'`` (any element)."""
    if isinstance(e, S.Name):
        return [e.name]
    if isinstance(e, S.Member):
        p = _path(e.base)
        return None if p is None else p + ["." + e.name]
    if isinstance(e, S.Index):
        p = _path(e.base)
        return None if p is None else p + ["[]"]
    if isinstance(e, S.Paren):
        return _path(e.inner)
    return None


def _overlap(a, b) -> bool:
    n = min(len(a), len(b))
    return all(x == y or "[]" in (x, y) for x, y in zip(a[:n], b[:n]))


def _literal_store(s):
    """``(target path, literal)`` of ``x = LIT;``, ``x.f = LIT;`` or ``T x = LIT;``."""
    if isinstance(s, S.Decl) and len(s.declarators) == 1 and s.declarators[0].size is None:
        target, v = [s.declarators[0].name], s.declarators[0].init
    elif isinstance(s, S.ExprStmt) and isinstance(s.expr, S.Assign) and s.expr.op == "=":
        target, v = _path(s.expr.target), s.expr.value
        if target is None or "[]" in target:
            return None, None
    else:
        return None, None
    if isinstance(v, S.Num) or isinstance(v, S.Name) and v.name in ("true", "false"):
        return target, v
    return None, None


def _forward(e, target, lit) -> tuple[object, bool]:
    """``e`` with its reads of ``target`` (a path) replaced by ``lit`` (not below a member or an
    index of it)."""
    skip = {id(n.base) for n in walk(e) if isinstance(n, (S.Member, S.Index))}
    hits = []

    def sub(n):
        if isinstance(n, (S.Name, S.Member)) and id(n) not in skip and _path(n) == target:
            hits.append(n)
            return clone(lit)
        return n
    return transform(e, sub), bool(hits)


def forward_literals(fn: S.Function, facts: Facts) -> bool:
    """``x = 0; bool b = x > 9; if (!b) {`` -> ``bool b = 0 > 9; if (!b) {``: a literal just stored
    (``x`` a local or a field) read in its place by the next straight-line statements and
    ``if`` condition, up to anything that writes it."""
    ctx, changed = facts.ctx, False
    pos, last = facts.order
    at: dict = {}                   # {name: the sorted positions of its occurrences}
    pure: dict = {}                 # {id(statement): it has no effect but its store} (literals keep it)

    def effectless(t, e):
        if id(t) not in pure:
            pure[id(t)] = _pure_store(e, ctx) if e is not None else \
                all(d.init is None or is_pure(d.init, ctx) for d in t.declarators)
        return pure[id(t)]

    def forward(e, target, lit):
        # (only where the facts place an occurrence of the variable inside ``e``: the nodes this
        # pass put in are literals, and a node without a position is looked at)
        lo = pos.get(id(e))
        if lo is not None:
            if target[0] not in at:
                at[target[0]] = sorted(pos[id(n)] for n, _ in facts.occ[target[0]])
            where = at[target[0]]
            k = bisect_left(where, lo)
            if k == len(where) or where[k] > last[id(e)]:
                return e, False
        return _forward(e, target, lit)

    for b in facts.blocks:
        for k, s in enumerate(b.body):
            target, lit = _literal_store(s)
            if target is None or not any(role == "read" and pos[id(n)] > last[id(s)]
                                         for n, role in facts.occ.get(target[0], ())):
                continue
            for t in b.body[k + 1:]:
                if isinstance(t, S.If):
                    t.cond, hit = forward(t.cond, target, lit)
                    changed |= hit
                    break
                if isinstance(t, S.Decl) and all(d.size is None for d in t.declarators):
                    if not effectless(t, None):
                        break
                    for d in t.declarators:
                        if d.init is not None:
                            d.init, hit = forward(d.init, target, lit)
                            changed |= hit
                    if any(d.name == target[0] for d in t.declarators):
                        break
                    continue
                into, e = _store(t)
                path = _path(into) if into is not None else None
                if path is None or _overlap(path, target) or not effectless(t, e):
                    break
                if isinstance(e, S.Assign):
                    e.value, hit = forward(e.value, target, lit)
                    changed |= hit
    return changed


def loop_variables(fn: S.Function, facts: Facts) -> bool:
    """``int i = 2; ... for (; i <= 9; i++) {...}`` with ``i`` unused after the loop (nor between)
    -> ``... for (int i = 2; i <= 9; i++) {...}``."""
    pos, last = facts.order
    for b in facts.blocks:
        for k, f in enumerate(b.body):
            if not isinstance(f, S.For) or f.init is not None:
                continue
            names = {n.name for part in (f.cond, f.step) if part is not None for n in walk(part)
                     if isinstance(n, S.Name)}
            for j in range(k - 1, -1, -1):
                s = b.body[j]
                d = _single(s)
                if d is None or d.name not in names or d.init is None:
                    continue
                if d.name in facts.once and not any(_mentions(t, d.name) for t in b.body[j + 1:k]) \
                        and not any(pos[id(n)] > last[id(f)] for n, _ in facts.occ.get(d.name, ())):
                    del b.body[j]
                    if s.comments:
                        f.comments = s.comments + f.comments
                    s.comments, s.trail = [], ""
                    f.init = s
                    return True
                break
    return False


def store_into_next(fn: S.Function, facts: Facts) -> bool:
    """``T y = a; y = f(y);`` (y read once there) -> ``T y = f(a);``; ``T y = a; return y;`` ->
    ``return a;``."""
    ctx = facts.ctx
    for b in facts.blocks:
        for k in range(len(b.body) - 1):
            s, t = b.body[k], b.body[k + 1]
            d = _single(s)
            if d is None or d.init is None:
                continue
            y, a = d.name, d.init
            if isinstance(t, S.Return) and isinstance(t.value, S.Name) and t.value.name == y:
                if len(facts.occ.get(y, ())) == 1 and y in facts.once:
                    t.value = a
                    t.comments = s.comments + t.comments
                    del b.body[k]
                    return True
                continue
            if not (isinstance(t, S.ExprStmt) and isinstance(t.expr, S.Assign) and t.expr.op == "="
                    and isinstance(t.expr.target, S.Name) and t.expr.target.name == y):
                continue
            v = t.expr.value
            uses = [n for n in walk(v) if isinstance(n, S.Name) and n.name == y]
            if len(uses) != 1 or _mentions(a, y) or not is_pure(a, ctx) or not is_pure(v, ctx):
                continue
            if not isinstance(a, ATOMS) and any(isinstance(p, (S.Member, S.Index)) and p.base is uses[0]
                                                for p in walk(v)):
                continue                     # (a + b).xy: kept
            d.init = transform(v, lambda n, a=a, uses=uses: paren(a) if n is uses[0] else n)
            s.trail = t.trail or s.trail
            if t.comments:
                s.comments = s.comments + t.comments
            del b.body[k + 1]
            return True
    return False


def _num(e, texts) -> bool:
    return isinstance(e, S.Num) and e.text in texts


_ZERO, _ONE = ("0.0", "0.", "0"), ("1.0", "1.", "1")


def _identity(n, ctx):
    """The node ``n`` rewritten by an identity (``n`` itself if none applies)."""
    if isinstance(n, S.Binary):
        if n.op in ("*", "/") and _num(n.right, ("1.0",)) or n.op == "-" and _num(n.right, ("0.0",)):
            return n.left
        if n.op == "*" and _num(n.left, ("1.0",)):
            return n.right
        if n.op == "*" and isinstance(n.left, S.Call) and isinstance(n.right, S.Call) \
                and n.left.func == n.right.func == "abs" and len(n.left.args) == 1 \
                and expr_glsl(n.left) == expr_glsl(n.right) and is_pure(n.left, ctx):
            return S.Binary("*", paren(n.left.args[0]), paren(clone(n.left.args[0])))
        if n.op in ("*", "+", "-") and all(isinstance(x, S.Num) and x.text.lower().endswith("u")
                                           for x in (n.left, n.right)):
            v = value(n, {})
            return n if v is None else S.Num(f"{v[1]}u")
        if n.op == "+" and isinstance(n.left, S.Num) and n.left.text == "0u":
            return n.right
        if n.op == "+" and isinstance(n.left, S.Ctor) and n.left.type[:-1] in ("ivec", "uvec") \
                and all(_num(a, ("0", "0u")) for a in n.left.args):
            return n.right
    elif isinstance(n, S.Call) and n.func == "mix" and len(n.args) == 3:
        if _num(n.args[2], _ZERO[:2]):
            return paren(n.args[0])
        if _num(n.args[2], _ONE[:2]) and isinstance(n.args[0], S.Num):
            return paren(n.args[1])
    elif isinstance(n, S.Member) and isinstance(n.base, S.Ctor) and n.base.type[:-1] in ("vec", "ivec") \
            and n.base.args and all(isinstance(a, S.Num) for a in n.base.args):
        size, args = int(n.base.type[-1]), [a.text for a in n.base.args]
        args = args * size if len(args) == 1 else args
        comps = [("xyzw".find(c) if c in "xyzw" else "rgba".find(c)) for c in n.name]
        if len(args) != size or any(c < 0 or c >= size for c in comps):
            return n
        picked = [args[c] for c in comps]
        if len(picked) == 1:
            return S.Num(picked[0])
        typ = n.base.type[:-1] + str(len(picked))
        return S.Ctor(typ, [S.Num(picked[0])] if len(set(picked)) == 1 else [S.Num(p) for p in picked])
    elif isinstance(n, S.Ctor) and n.type == "uint" and len(n.args) == 1 and isinstance(n.args[0], S.Num) \
            and n.args[0].text.isdigit():
        return S.Num(str(int(n.args[0].text)) + "u")
    elif isinstance(n, S.ExprStmt) and isinstance(n.expr, S.Assign):
        e = n.expr
        if (e.op == "-=" and _num(e.value, _ZERO) or e.op in ("*=", "/=") and _num(e.value, _ONE)
                or e.op == "=" and expr_glsl(e.target) == expr_glsl(e.value)) and is_pure(e.target, ctx):
            return []
    elif isinstance(n, S.If):
        if n.other is not None and _empty(n.other) or isinstance(n.other, S.If) and n.other.other is None \
                and _empty(n.other.then) and is_pure(n.other.cond, ctx):
            return S.If(n.cond, n.then, None, n.comments)
        if n.other is None and _empty(n.then) and is_pure(n.cond, ctx):
            return []
    return n


def _empty(s) -> bool:
    return isinstance(s, S.Block) and not s.body


@rule(S.Binary, S.Call, S.Member, S.Ctor, S.ExprStmt, S.If)
def _identities(facts: Facts):
    """Rewrite what gives the same value for every IEEE-754 input: ``x * 1.0``, ``1.0 * x``,
    ``x / 1.0``, ``x - 0.0``, statements ``x -= 0.0;``, ``x *= 1.0;``, ``x = x;``,
    ``mix(a, b, 0.0)`` -> ``a``, ``mix(2.0, b, 1.0)`` -> ``b`` (a finite literal), ``abs(x) *
    abs(x)`` -> ``x * x``, ``vec4(0.0, 0.0, 0.0, 1.0).w`` -> ``1.0``, ``uint(3)`` -> ``3u``,
    products and sums of unsigned literals, ``0u + x`` and ``ivec4(0, 0, 0, 0) + x`` -> ``x``,
    empty blocks and branches (with conditions without effects)."""
    return lambda n: _identity(n, facts.ctx)


identities = rewriting(_identities)
_ARITH = {"+": 9, "-": 9, "*": 10, "/": 10}
#: ``{node class: ((field, whole: any expression stands there bare but a ternary or an assignment),
#: ...)}``: the places whose parentheses :func:`parentheses` looks at (besides arguments)
_PLACES = {S.Index: (("index", True), ("base", False)), S.Member: (("base", False),),
           S.Declarator: (("init", True),), S.Assign: (("value", True),), S.Return: (("value", True),),
           S.If: (("cond", True),), S.While: (("cond", True),), S.ExprStmt: (("expr", True),),
           S.Paren: (("inner", False),), S.Unary: (("operand", False),), S.IncDec: (("operand", False),),
           S.Ternary: (("cond", False), ("then", False), ("other", False)),
           S.Binary: (("left", False), ("right", False))}
_COMPARISONS = ("<", ">", "<=", ">=", "==", "!=")


@rule(*_PLACES, S.Call, S.Ctor, S.ArrayCtor)
def _parentheses(facts: Facts):
    """Drop parentheses that change nothing: around an atom, around a whole argument, index,
    initialiser, stored value, returned value or condition (not a ternary), and around
    arithmetic inside arithmetic or a comparison where precedence keeps the order
    (``(a * b) + c``, ``(a + b) - c``, ``(a + b) < c``)."""
    def bare(p, top=False):
        while isinstance(p, S.Paren) and (isinstance(p.inner, ATOMS) or top and not isinstance(
                p.inner, (S.Ternary, S.Assign))):
            dropped.append(p)
            p = p.inner
        return p

    def fix(n):
        dropped.clear()
        if isinstance(n, (S.Call, S.Ctor, S.ArrayCtor)):
            n.args = [bare(a, True) for a in n.args]
        for name, top in _PLACES.get(type(n), ()):
            setattr(n, name, bare(getattr(n, name), top))
        if isinstance(n, S.Binary) and (n.op in _ARITH or n.op in _COMPARISONS):
            level = _ARITH.get(n.op, 0)
            for side in ("left", "right"):
                p = getattr(n, side)
                if isinstance(p, S.Paren) and isinstance(p.inner, S.Binary) and p.inner.op in _ARITH:
                    inner = _ARITH[p.inner.op]
                    if inner > level or (inner == level and side == "left"):
                        setattr(n, side, p.inner)     # (a regrouping is not reported as a change)
        return copy(n) if dropped else n              # (a new node: the walk reports the change)
    dropped: list = []
    return fix


parentheses = rewriting(_parentheses)
#: one walk for the rules on single nodes: the constants written in, constant conditions and loops,
#: the identities, the parentheses (:mod:`cellgl.export.fold`'s rules and this module's)
EXPRESSIONS = rewriting(inline_constants_rule, array_elements_rule, local_constants_rule, constant_conditions_rule,
                        constant_loops_rule, _identities, _parentheses)


#: the simplification passes, in the order of the driver's round (after :data:`EXPRESSIONS`)
SIMPLIFY = [split_declarations, dead_locals, last_stores, copies, bare_blocks, merge_declarations,
            forward_literals, loop_variables, store_into_next]
