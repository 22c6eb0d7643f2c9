"""The snippet compiler's constant folding, on the syntax tree: function passes ``(fn, facts) ->
changed`` that :func:`fold` runs (in :mod:`cellgl.export.compiler`'s round).

After :func:`cellgl.export.reach.scalarise` the recipe's values are global constants. These
passes evaluate what they make constant: the constants that decide the shape of the code
(booleans, integers, the floats 0.0 and 1.0) and the elements of constant arrays are written into
it, constant conditions choose their branch, loops with constant bounds are unrolled or bounded.

Values are evaluated as GLSL computes them (:mod:`cellgl.export.values`). Float arithmetic is
evaluated only to decide conditions; no float result is written into the code but the literals
0.0 and 1.0 a constant holds.
"""
from __future__ import annotations

from collections import Counter

from cellgl._cache import Bounded
from cellgl.export.translate.tokens import TranslateError  # noqa: F401  (first: the parser)
from cellgl.export import syntax as S
from cellgl.export.printer import expr_glsl, item_glsl
from cellgl.export.tree import Context, clone, is_pure, paren, scan, settle, transform, walk
from cellgl.export.tree import writes
from cellgl.export.values import COMPARE, convert, literal, shape, value

__all__ = ["fold", "Facts", "rewriting", "inline_constants", "array_elements", "constant_conditions",
           "local_constants", "constant_loops", "loop_ranges", "global_constants", "inline_constants_rule",
           "array_elements_rule", "constant_conditions_rule", "local_constants_rule", "constant_loops_rule"]

def global_constants(unit: S.Unit) -> tuple[dict, dict]:
    """``(env, arrays)``: ``env`` ``{name: value}`` of the global scalar constants initialised with
    a constant; ``arrays`` ``{name: (element nodes, their GLSL)}`` of the global constant arrays,
    and ``{name: type}`` of the global scalars and vectors no function writes (constants,
    uniforms) under the key None."""
    env: dict = {}
    arrays: dict = {None: {}}
    for it in unit.items:
        if isinstance(it, S.Global) and ("const" in it.quals or "uniform" in it.quals):
            for d in it.declarators:
                if d.size is not None and isinstance(d.init, S.ArrayCtor) and "const" in it.quals:
                    arrays[d.name] = (d.init.args, [expr_glsl(a) for a in d.init.args])
                elif d.size is None:
                    arrays[None][d.name] = it.type
                if "const" in it.quals and d.size is None and d.init is not None:
                    v = convert(it.type, value(d.init, env))
                    if v is not None and v[0] == it.type:
                        env[d.name] = v
    return env, arrays


class Facts:
    """What the passes know of one function, from one walk (:func:`cellgl.export.tree.scan`): its
    nodes in source order, ``order`` (``({id(node): position}, {id(node): the last position below
    it})``), blocks, ``declared`` (``{name: times declared}``, parameters included) and the names
    declared ``once``, ``types`` (``{name: type}``; arrays: None), the occurrences of each name
    (``occ``), the nodes inside loops, and ``constants``: ``({name: value}, {array: [element
    nodes]})``, the globals' ``genv`` not shadowed and the locals declared once with a constant
    (or an array of literals) never written after. A pass that changes the function makes a new
    one (a pass may go on after a change where the facts stay a superset of the truth)."""

    def __init__(self, fn: S.Function, genv: dict, garrays: dict, ctx: Context):
        self.fn, self.genv, self.garrays, self.ctx = fn, genv, garrays, ctx
        self.nodes, last, self.occ = scan(fn.body, ctx)
        pos = {id(n): k for k, n in enumerate(self.nodes)}
        self.order = pos, last
        self.params = {p.name: p for p in fn.params}
        self.types = {p.name: None if p.size is not None else p.type for p in fn.params}
        self.blocks, self.in_loops, decls, names = [], set(), [], [p.name for p in fn.params]
        for n in self.nodes:
            if type(n) is S.Block:
                self.blocks.append(n)
            elif type(n) is S.Decl:
                decls.append(n)
                for d in n.declarators:
                    names.append(d.name)
                    self.types[d.name] = None if d.size is not None else n.type
            elif type(n) in (S.For, S.While) and id(n) not in self.in_loops:
                self.in_loops.update(id(x) for x in self.nodes[pos[id(n)]:last[id(n)] + 1])
        self.declared = Counter(names)
        self.once = {k for k, v in self.declared.items() if v == 1}
        self.env = {k: v for k, v in genv.items() if k not in self.declared}
        self.constants = self.env, {}
        stored = {n for n, uses in self.occ.items() if any(role != "read" for _, role in uses)}
        for node in decls:
            for d in node.declarators:
                if d.name not in self.once or d.name in stored or d.init is None or d.name in self.params:
                    continue
                if d.size is None and node.type in ("int", "uint", "float", "bool"):
                    v = convert(node.type, value(d.init, self.env, ctx))
                    if v is not None and v[0] == node.type:
                        self.env[d.name] = v
                elif isinstance(d.init, S.ArrayCtor) and all(isinstance(a, S.Num) for a in d.init.args):
                    self.constants[1][d.name] = d.init.args


# --------------------------------------------------------------------------------------------
# passes
# --------------------------------------------------------------------------------------------

def rule(*types):
    """Marks a maker of a node rule (:func:`rewriting`) for the node classes ``types``."""
    def mark(make):
        make.types = frozenset(types)
        return make
    return mark


def rewriting(*makers):
    """The function pass of the node rules ``makers`` make of a function's facts (``maker(facts)``:
    a rule ``node -> node`` for :func:`cellgl.export.tree.transform`, or None where it has nothing
    to do; ``maker.types``: the node classes it rewrites, :func:`rule`): one walk, bottom-up, each
    node through every rule for its class in turn."""
    def fpass(fn: S.Function, facts: Facts) -> bool:
        rules = [(make.types, r) for make in makers if (r := make(facts)) is not None]
        some = frozenset().union(*(types for types, _ in rules))
        changed = False

        def each(n):
            nonlocal changed
            if type(n) not in some:
                return n
            m = n
            for types, rule in rules:
                if type(m) in types:
                    m = rule(m)
            changed = changed or m is not n
            return m
        transform(fn.body, each)
        return changed
    fpass.__name__ = "_".join(m.__name__.lstrip("_") for m in makers)
    fpass.__doc__ = "\n\n".join(m.__doc__ for m in makers)
    return fpass


@rule(S.Name)
def inline_constants_rule(facts: Facts):
    """Write the recipe's constants that decide the shape of the code (booleans, integers, 0.0,
    1.0) into it: ``cellgl_fractal == 0`` -> ``0 == 0``."""
    pick = {k: literal(v) for k, v in facts.genv.items() if shape(v) and k not in facts.declared and k in facts.occ}
    return (lambda n: clone(pick[n.name]) if n.name in pick else n) if pick else None


@rule(S.Index)
def array_elements_rule(facts: Facts):
    """``cellgl_origin_frac[0]`` -> ``vec4(0.0, 0.0, 0.0, 0.0)``: elements of global constant
    arrays read at a literal index where the element is short, or at any index (without
    effects or calls) where all elements are the same."""
    arrays = {k: v for k, v in facts.garrays.items() if k is not None and k not in facts.declared and k in facts.occ}

    def sub(n):
        if type(n.base) is S.Name and n.base.name in arrays:
            args, texts = arrays[n.base.name]
            if len(set(texts)) == 1 and not any(isinstance(x, (S.Call, S.Assign, S.IncDec)) for x in walk(n.index)):
                return paren(clone(args[0]))
            k = value(n.index, {})
            if k is not None and k[0] in ("int", "uint") and 0 <= k[1] < len(args) and len(texts[k[1]]) <= 40:
                return paren(clone(args[k[1]]))
        return n
    return sub if arrays else None


def _fold_expr(n, env, ctx):
    """The expression node ``n`` with its constant parts folded (its children are already)."""
    if isinstance(n, S.Ternary):
        c = value(n.cond, env, ctx)
        if c is not None and c[0] == "bool" and is_pure(n.cond, ctx):
            return paren(n.then if c[1] else n.other)
        if expr_glsl(n.then) == expr_glsl(n.other) and is_pure(n.cond, ctx):
            return paren(n.then)
    elif isinstance(n, S.Binary) and n.op in ("&&", "||", "^^") + tuple(COMPARE) or \
            isinstance(n, S.Unary) and n.op == "!":
        v = value(n, env, ctx)
        if v is not None and v[0] == "bool" and is_pure(n, ctx):
            return literal(v)
        if isinstance(n, S.Binary) and n.op in ("&&", "||"):    # true && x -> x, false || x -> x
            for a, b in ((n.left, n.right), (n.right, n.left)):
                if value(a, env, ctx) == ("bool", n.op == "&&"):
                    return paren(b)
    elif isinstance(n, S.Index) and not isinstance(n.index, S.Num):
        v = value(n.index, env, ctx)
        if v is not None and v[0] in ("int", "uint") and v[1] >= 0:
            return S.Index(n.base, literal(v))
    elif isinstance(n, (S.Declarator, S.ArrayCtor)) and n.size is not None and not isinstance(n.size, S.Num):
        v = value(n.size, env, ctx)
        if v is not None and v[0] in ("int", "uint") and v[1] > 0:
            n.size = literal(v)
            return clone(n)
    return n


@rule(S.If, S.While, S.Ternary, S.Binary, S.Unary, S.Index, S.Declarator, S.ArrayCtor)
def constant_conditions_rule(facts: Facts):
    """Remove the branches of ``if`` statements and ternaries whose condition is constant, fold
    conditions of literals (``3.0e38 >= 3.0e38`` -> ``true``), ``true && x`` -> ``x``, and
    integer indices and array sizes (``rest[8 + 1]`` -> ``rest[9]``)."""
    env, ctx = facts.env, facts.ctx

    def fold(n):
        if isinstance(n, S.If):
            c = value(n.cond, env, ctx)
            return _chosen(n, n.then if c[1] else n.other) if c is not None and c[0] == "bool" \
                and is_pure(n.cond, ctx) else n
        if isinstance(n, S.While) and value(n.cond, env, ctx) == ("bool", False):
            return []
        return _fold_expr(n, env, ctx)
    return fold


def _chosen(stmt, kept):
    """What replaces the statement ``stmt`` by its part ``kept`` (a block's statements, spliced
    unless it declares names; nothing for None), keeping ``stmt``'s comments."""
    if kept is None:
        out = []
    elif isinstance(kept, S.Block) and not any(isinstance(s, S.Decl) for s in kept.body):
        out = list(kept.body)
    else:
        out = [kept]
    if out and stmt.comments:
        out[0].comments = stmt.comments + out[0].comments
    return out


@rule(S.Name, S.Index)
def local_constants_rule(facts: Facts):
    """Write locals that hold a boolean, an integer, 0.0 or 1.0 for good into the code, and the
    elements of local arrays of literals never written (``lin[0]`` -> ``1.0``)."""
    env, arrays = facts.constants
    pick = {k: literal(v) for k, v in env.items() if k not in facts.genv and shape(v)
            and (v[0] != "uint" or v[1] in (0, 1))       # (other unsigned values: hash constants, named)
            and any(role == "read" for _, role in facts.occ.get(k, ()))}
    arrays = {k: v for k, v in arrays.items() if any(role == "read" for _, role in facts.occ.get(k, ()))}

    def sub(n):
        if type(n) is S.Name and n.name in pick:
            return clone(pick[n.name])
        if type(n) is S.Index and type(n.base) is S.Name and n.base.name in arrays:
            k = value(n.index, env, facts.ctx)
            if k is not None and k[0] in ("int", "uint") and 0 <= k[1] < len(arrays[n.base.name]):
                return clone(arrays[n.base.name][k[1]])
        return n
    return sub if pick or arrays else None


inline_constants, array_elements = rewriting(inline_constants_rule), rewriting(array_elements_rule)
constant_conditions, local_constants = rewriting(constant_conditions_rule), rewriting(local_constants_rule)


def _counter(loop: S.For, env, ctx):
    """``(v, A, op, B, ++ or --)`` of ``for (int v = A; v op B; v++)`` with A and B constant."""
    init, cond, step = loop.init, loop.cond, loop.step
    if not (isinstance(init, S.Decl) and init.type == "int" and len(init.declarators) == 1
            and isinstance(cond, S.Binary) and isinstance(cond.left, S.Name) and isinstance(step, S.IncDec)
            and isinstance(step.operand, S.Name) and init.declarators[0].size is None):
        return None
    var = init.declarators[0].name
    a, b = value(init.declarators[0].init, env, ctx), value(cond.right, env, ctx)
    if cond.left.name != var or step.operand.name != var or a is None or b is None or a[0] != "int" or b[0] != "int":
        return None
    return var, a[1], cond.op, b[1], step.op


def _loop_bounds(loop: S.For, env, ctx):
    """``(var, first, count, early)`` of a loop with a constant counter (:func:`_counter`): the
    iterations it runs (bounded by an ``if (v >= M) break;`` first in the body: ``early``)."""
    counter = _counter(loop, env, ctx)
    if counter is None:
        return None
    var, a, op, b, step = counter
    up, early = step == "++", None
    body = loop.body.body if isinstance(loop.body, S.Block) else [loop.body]
    if up and op in ("<", "<=") and body and isinstance(body[0], S.If) and body[0].other is None:
        first = body[0]
        jump = first.then.body if isinstance(first.then, S.Block) else [first.then]
        c = first.cond
        if isinstance(c, S.Binary) and c.op == ">=" and isinstance(c.left, S.Name) and c.left.name == var \
                and len(jump) == 1 and isinstance(jump[0], S.Jump) and jump[0].kind == "break":
            m = value(c.right, env, ctx)
            if m is not None and m[0] == "int":
                b, early = (min(b, m[1]) if op == "<" else min(b, m[1] - 1)), first
    count = ({"<": b - a, "<=": b - a + 1} if up else {">": a - b, ">=": a - b + 1}).get(op)
    return None if count is None else (var, a, count, early)


def _jumps(node) -> bool:
    """Whether ``node`` has a ``break`` or ``continue`` of the loop it is in (not of a nested loop)."""
    if isinstance(node, S.Jump):
        return node.kind in ("break", "continue")
    if isinstance(node, S.Block):
        return any(_jumps(s) for s in node.body)
    if isinstance(node, S.If):
        return _jumps(node.then) or (node.other is not None and _jumps(node.other))
    return False


@rule(S.For)
def constant_loops_rule(facts: Facts):
    """``for`` loops with constant bounds: no iteration -> removed; one -> its body (a block),
    the counter replaced by its first value."""
    env, ctx = facts.env, facts.ctx

    def unroll(n):
        bounds = _loop_bounds(n, env, ctx)
        if bounds is None:
            return n
        var, first, count, early = bounds
        if count <= 0:
            return _chosen(n, None)
        body = n.body if isinstance(n.body, S.Block) else S.Block([n.body])
        body = S.Block([s for s in body.body if s is not early], n.comments + body.comments)
        if count != 1 or var in writes(body, ctx) or _jumps(body):
            return n
        lit = literal(("int", first))
        return [transform(body, lambda x: clone(lit) if isinstance(x, S.Name) and x.name == var else x)]
    return unroll if any(type(n) is S.For for n in facts.nodes) else None


constant_loops = rewriting(constant_loops_rule)


def _conjuncts(e) -> list:
    return _conjuncts(e.left) + _conjuncts(e.right) if isinstance(e, S.Binary) and e.op == "&&" else [e]


def loop_ranges(fn: S.Function, facts: Facts) -> bool:
    """``for (int k = 0; k < 16; k++) { x += (k >= 1 && k < 9 && c) ? 1 : 0; }`` -> the loop over
    1 <= k < 9 with ``c`` alone: a body that is one statement guarded by bounds on k (an ``if``
    without ``else``, or an integer sum of ``guard ? e : 0``)."""
    env, ctx = facts.env, facts.ctx
    changed = False
    for loop in [n for n in facts.nodes if isinstance(n, S.For)]:
        counter = _counter(loop, env, ctx)
        if counter is None or counter[2] != "<" or counter[4] != "++":
            continue
        var, lo, _, hi, _ = counter
        body = loop.body.body if isinstance(loop.body, S.Block) else [loop.body]
        if len(body) != 1 or var in writes(loop.body, ctx):
            continue
        s, holder = body[0], None
        if isinstance(s, S.If) and s.other is None:
            holder = s
        elif isinstance(s, S.ExprStmt) and isinstance(s.expr, S.Assign) and s.expr.op == "+=":
            t = s.expr.value.inner if isinstance(s.expr.value, S.Paren) else s.expr.value
            if isinstance(t, S.Ternary) and isinstance(t.other, S.Num) and t.other.text in ("0", "0u"):
                holder = t
        if holder is None:
            continue
        c = holder.cond
        parts = _conjuncts(c.inner if isinstance(c, S.Paren) else c)
        new_lo, new_hi, rest = lo, hi, []
        for p in parts:
            v = value(p.right, env, ctx) if isinstance(p, S.Binary) else None
            if isinstance(p, S.Binary) and p.op in (">=", "<") and isinstance(p.left, S.Name) \
                    and p.left.name == var and v is not None and v[0] == "int":
                new_lo, new_hi = (max(new_lo, v[1]), new_hi) if p.op == ">=" else (new_lo, min(new_hi, v[1]))
            else:
                rest.append(p)
        if not rest or len(rest) == len(parts):
            continue
        e = rest[0]
        for p in rest[1:]:
            e = S.Binary("&&", e, p)
        holder.cond = S.Paren(e) if isinstance(c, S.Paren) else e
        loop.init.declarators[0].init = literal(("int", new_lo))
        loop.cond.right = literal(("int", max(new_lo, new_hi)))
        changed = True
    return changed


def fold(unit: S.Unit, ctx: Context, passes) -> bool:
    """The function passes ``passes`` (``(fn, facts) -> changed``; the compiler's: the rules of
    :data:`cellgl.export.simplify.EXPRESSIONS`, the loops', :data:`cellgl.export.simplify.SIMPLIFY`),
    function by function, until they settle (:func:`cellgl.export.tree.settle`; they change no
    signature, so ``ctx`` stays true) or :data:`MAX_ROUNDS` rounds. Nothing with ``ctx.fold_constants``
    false (the recipe's values stay as they are). A function folded before with the same text,
    the same values of the globals it names and the same facts of the functions it calls is not
    folded again (:data:`_FOLDED`)."""
    if not ctx.fold_constants:
        return False
    genv, garrays = global_constants(unit)
    changed = False
    for fn in list(ctx.functions.values()):
        # what the passes read besides the function: the globals it names (their values, elements,
        # types), and whether the functions it calls have effects and which parameters they write
        nodes = walk(fn.body)
        used = sorted({n.name for n in nodes if type(n) is S.Name})
        callees = sorted({n.func for n in nodes if type(n) is S.Call})
        key = (tuple(p.__name__ for p in passes), tuple((k, genv.get(k), garrays[None].get(k)) for k in used),
               tuple((k, tuple(garrays[k][1])) for k in used if k in garrays),
               tuple((c, c in ctx.impure, c in ctx.functions and tuple(p.mode for p in ctx.functions[c].params))
                     for c in callees))
        text = "\n".join(item_glsl(fn))
        key = (text,) + key
        hit = _FOLDED.get(key, _MISSING)
        if hit is _MISSING:
            facts = [Facts(fn, genv, garrays, ctx)]

            def apply(p, fn=fn, facts=facts):         # this iteration's function (bound now)
                if p(fn, facts[0]):
                    facts[0] = Facts(fn, genv, garrays, ctx)       # (the facts of the changed body)
                    return True
                return False
            folded = settle(passes, apply, MAX_ROUNDS, f"the folding passes did not settle on {fn.name} in "
                            f"{MAX_ROUNDS} rounds")
            body = clone(fn.body) if folded else None
            hit = None if body is None or "\n".join(item_glsl(fn)) == text else body
            _FOLDED.put(key, hit)
            changed = changed or hit is not None
        elif hit is not None:
            fn.body = clone(hit)
            changed = True
    return changed


#: ``{(function text, passes, what it reads of the globals and callees): folded body (None:
#: unchanged)}``: the driver's rounds, and a process's exports, fold most functions again unchanged
#: (bounded: cellgl._cache's policy)
_FOLDED = Bounded("folded function bodies (cellgl.export.fold)", 4096)
_MISSING = object()

#: rounds of the passes on one function after which :func:`fold` gives up
MAX_ROUNDS = 64
