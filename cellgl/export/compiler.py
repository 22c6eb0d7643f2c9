"""The snippet compiler: :func:`compile_glsl` turns the specialised, prefixed GLSL of a snippet
into the code its entry points need, and nothing else.

One tree (:mod:`cellgl.export.syntax`) through the whole compile: the parse of the text (cached
per process), the declarations the entry points reach, then :data:`ROUND`'s passes, repeated
until a round changes nothing (the fixed point, :func:`cellgl.export.tree.fixed_point`;
:data:`MAX_ROUNDS` rounds without one raise :class:`~cellgl.export.translate.tokens.TranslateError`):

1. :func:`cellgl.export.reach.scalarise` -- the recipe's parameter struct becomes its constants;
2. constants that decide the shape of the code (0, 1, integers, switches) are written into it, and
   elements of constant arrays read at a literal index (or at any index, when all are equal);
3. :func:`cellgl.export.fold.fold` -- constant conditions, loops, locals
   (:mod:`cellgl.export.simplify`: dead locals and stores, identities);
4. short functions inlined (a ``return`` of one expression, or straight-line stores substituted
   into one), and every function called once (:mod:`cellgl.export.inline`); parameters a function
   never reads dropped, and those every call passes the same literal written into the body;
   ``out`` parameters whose results every caller ignores turned into locals, and return values
   (:func:`cellgl.export.fields.void_results`); struct fields never
   read (or only copied into themselves) removed, those holding one literal everywhere folded
   (:mod:`cellgl.export.fields`);
5. :func:`cellgl.export.reach.reach` -- only what the entry points reach.

Then every declaration comes after what it uses, the comments are tidied
(:func:`cellgl.export.reach.tidy_comments`), and the tree is printed: GLSL of the same subset,
for the same translators. Passes not yet on the tree run on text through :func:`text_passes`.
"""
from __future__ import annotations

import re

from cellgl.export.fold import _literal, constants, fold
from cellgl.export.fields import constant_fields, void_results
from cellgl.export.inline import inline_once
from cellgl.export import syntax as S
from cellgl.export.printer import item_glsl, print_lines
from cellgl.export.reach import (
    Item,
    _call_args,
    _code_idx,
    _drop_fields,
    _drop_struct_args,
    _match,
    _names,
    _sig_end,
    _split_args,
    parse,
    reach,
    reached,
    scalarise,
    strip_body_comments,
    tidy_comments,
    unparse,
    uses,
)
from cellgl.export.simplify import _DECL_TYPES
from cellgl.export.tree import Context, clone, fixed_point, tree_pass
from cellgl.export.translate.tokens import Tok, tokenize

__all__ = ["compile_glsl", "compile_unit", "text_passes", "ROUND", "MAX_ROUNDS"]

#: rounds of the passes after which :func:`compile_glsl` gives up (it stops at the first round that
#: changes nothing, the fixed point; the library's presets settle in under 20)
MAX_ROUNDS = 64


def _array_elements(items: list[Item]) -> list[Item]:
    """``cellgl_origin_frac[0]`` -> ``vec4(0.0, 0.0, 0.0, 0.0)``: elements of global constant
    arrays read at a literal index, where the element is short."""
    arrays = {}
    for it in items:
        c = it.code()
        if it.kind == "variable" and c[:1] == ["const"] and len(c) > 8 and c[3] == "[" and c[6] == "=":
            toks, code = it.toks, _code_idx(it.toks)
            op = c.index("(", 7)
            cl = _match(toks, code, op)
            arrays[c[2]] = ["".join(t.text for t in toks[code[a]:code[b - 1] + 1]).strip()
                            for a, b in _split_args(toks, code, op, cl)]
    if not arrays:
        return items
    pat = re.compile(r"\b(" + "|".join(map(re.escape, arrays)) + r")\[([^\[\]=;]*)\]")

    def elem(m):
        vals = arrays[m.group(1)]
        if len(set(vals)) == 1 and re.fullmatch(r"[\w\s+\-*]*", m.group(2)) and "++" not in m.group(2) \
                and "--" not in m.group(2):
            return vals[0]                   # every element the same: any index reads it
        if not m.group(2).strip().isdigit():
            return m.group()
        k = int(m.group(2))
        return vals[k] if k < len(vals) and len(vals[k]) <= 40 else m.group()

    out = []
    for it in items:
        if it.kind == "function":
            it = Item(it.kind, it.name, tokenize(pat.sub(elem, "".join(t.text for t in it.toks))), it.comment)
        out.append(it)
    return out


def _one_liners(items: list[Item], keep) -> dict[str, tuple[list[str], str]]:
    """``{name: (parameter names, returned expression)}`` of the functions whose body is one short
    ``return`` (or straight-line stores to locals and parameters ending in one, substituted
    forward: ``x = abs(x); return x * x;`` -> ``x * x``)."""
    out = {}
    calls: dict[str, int] = {}
    for it in items:
        if it.kind == "function":
            for m in re.finditer(r"(?<![\w.])([A-Za-z_]\w*)\s*\(", "".join(t.text for t in it.toks)):
                calls[m.group(1)] = calls.get(m.group(1), 0) + 1
    for it in items:
        if it.kind != "function" or it.name in keep:
            continue
        toks, code = it.toks, _code_idx(it.toks)
        w = [toks[i].text for i in code]
        op = w.index("(")
        cl = _match(toks, code, op)
        if w[cl + 1] != "{" or w[-2:] != [";", "}"] or "return" not in w:
            continue
        params = [w[b - 1] for a, b in _split_args(toks, code, op, cl)]
        if any(set(w[a:b]) & {"out", "inout"} or w[b - 1] == "]" for a, b in _split_args(toks, code, op, cl)):
            continue
        expr = _forward(toks, code, w, cl + 2, params)
        if expr is None:
            continue
        ids = re.findall(r"\b[A-Za-z_]\w*\b", expr)
        if len(expr) > 72 or it.name in ids:
            continue
        if len(expr) > 48 and calls.get(it.name, 0) > 2:       # (its definition counts once)
            continue                          # a long expression stays one function where it is used often
        out[it.name] = (params, expr)
    return out


def _forward(toks, code, w, start: int, params: list[str]) -> str | None:
    """The returned expression of the straight-line body ``w[start:]`` with every local and
    parameter store substituted forward (None: not straight-line)."""
    env: dict[str, str] = {}
    k = start
    while k < len(w) - 1:
        end = w.index(";", k)
        stmt = w[k:end]
        if "{" in stmt or "}" in stmt or "?" in stmt:
            return None
        text = "".join(t.text for t in toks[code[k]:code[end]]).strip()
        if stmt[0] == "return":
            return _substitute(text[len("return"):].strip(), env)
        if len(stmt) > 2 and stmt[0] in _DECL_TYPES and stmt[2] == "=":
            name, rhs = stmt[1], text.split("=", 1)[1].strip()
        elif len(stmt) > 1 and stmt[0] in params + list(env) and stmt[1] == "=":
            name, rhs = stmt[0], text.split("=", 1)[1].strip()
        else:
            return None
        env[name] = _substitute(rhs, env)
        k = end + 1
    return None


def _substitute(expr: str, env: dict[str, str]) -> str:
    """``expr`` with the names of ``env`` replaced by their expressions (parenthesised where the
    neighbours need it: a product or a left operand of a sum goes in bare)."""
    toks = tokenize(expr)
    code = _code_idx(toks)
    out = []
    for j, i in enumerate(code):
        t = toks[i]
        if t.kind == "id" and t.text in env and (j == 0 or toks[code[j - 1]].text != "."):
            e = _strip_parens(env[t.text])
            left = toks[code[j - 1]].text if j else "("
            right = toks[code[j + 1]].text if j + 1 < len(code) else ")"
            top = _top_ops(e)
            bare = _simple(e) or (left in ("(", ",", "=") and right in (")", ",")) \
                or (not top - {"*", "/"} and left in ("(", ",", "=", "+") and right in (")", ",", "+", "-")) \
                or (not top - {"+", "-", "*", "/"} and left in ("(", ",", "=") and right in ("+", "-"))
            out.append((i, e if bare else f"({e})"))
    text = [t.text for t in toks]
    for i, e in out:
        text[i] = e
    return "".join(text).strip()


def _strip_parens(e: str) -> str:
    while e.startswith("(") and e.endswith(")"):
        toks = tokenize(e)
        code = _code_idx(toks)
        if _match(toks, code, 0) != len(code) - 1:
            break
        e = e[1:-1].strip()
    return e


def _top_ops(e: str) -> set[str]:
    toks = tokenize(e)
    depth, ops = 0, set()
    for t in toks:
        if t.text in "([":
            depth += 1
        elif t.text in ")]":
            depth -= 1
        elif depth == 0 and t.kind == "op" and t.text not in (".",):
            ops.add(t.text)
    return ops


def _inline(items: list[Item], keep) -> list[Item]:
    small = _one_liners(items, keep)
    if not small:
        return items
    out = []
    for it in items:
        toks = it.toks
        if it.kind == "function":
            for _ in range(50):
                new = _inline_once(toks, small, it.name)
                if new is None:
                    break
                toks = new
        out.append(Item(it.kind, it.name, toks, it.comment))
    return out


def _simple(arg: str) -> bool:
    return re.fullmatch(r"[\w.]+(\[[^\[\]]*\])*[\w.]*|\w+\([^()]*\)", arg.strip()) is not None


def _cheap(arg: str) -> bool:
    """An argument that may be written twice: a name, field, literal, or a short sum of those
    and of casts."""
    return _simple(arg) and "(" not in arg or (len(arg) <= 24 and re.fullmatch(r"[\w.\s+\-*()]*", arg) is not None
                                               and set(re.findall(r"(\w+)\s*\(", arg)) <= {"float", "int", "uint"})


def _inline_once(toks: list[Tok], small: dict, own: str) -> list[Tok] | None:
    code = _code_idx(toks)
    w = [toks[i].text for i in code]
    first_call = w.index("(") - 1 if "(" in w else -1
    for n in range(len(w) - 1):
        if w[n] in small and w[n + 1] == "(" and n != first_call and (n == 0 or w[n - 1] != "."):
            params, expr = small[w[n]]
            cl = _match(toks, code, n + 1)
            args = ["".join(t.text for t in toks[code[a]:code[b - 1] + 1]).strip()
                    for a, b in _split_args(toks, code, n + 1, cl)]
            if len(args) != len(params):
                return None
            if any(not _simple(a) and re.search(rf"\b{p}\s*\.", expr) for p, a in zip(params, args)):
                continue                      # (a + b).xy: keep the call (translators drop such parentheses)
            if any(len(re.findall(rf"\b{p}\b", expr)) > 1 and not _cheap(a) for p, a in zip(params, args)):
                continue                      # an argument the expression reads twice: compute it once
            env = {p: (a if _simple(a) else f"({a})") for p, a in zip(params, args)}
            body = re.sub(r"\b[A-Za-z_]\w*\b", lambda m: env.get(m.group(), m.group()), expr)
            if not _simple(body):
                body = f"({body})"
            return tokenize("".join(t.text for t in toks[:code[n]]) + body
                            + "".join(t.text for t in toks[code[cl] + 1:]))
    return None


def _inline_constants(items: list[Item], env: dict[str, str]) -> list[Item]:
    """Write the constants that decide code shape (0, 1, integers, booleans) into the code."""
    pick = {k: v for k, v in env.items()
            if v in ("true", "false") or re.fullmatch(r"-?\d+u?", v) or _literal(v) in (0, 1)}
    out = []
    for it in items:
        if it.kind != "function":
            out.append(it)
            continue
        text = "".join((f"({pick[t.text]})" if pick[t.text].startswith("-") else pick[t.text])
                       if t.kind == "id" and t.text in pick else t.text for t in it.toks)
        out.append(Item(it.kind, it.name, tokenize(text), it.comment))
    return out


def compile_unit(text: str, entries, structs=(), fold_constants: bool = True, keep=()) -> S.Unit:
    """The middle end on the tree: what ``entries`` reach in ``text`` (parsed once per process,
    :func:`cellgl.export.syntax.parsed_library`; only that is copied), then :data:`ROUND` to its
    fixed point: scalarise ``structs`` (``[(struct, loader)]``), fold, inline (but ``keep``) ...
    Returns the tree, every declaration after what it uses, its comments tidied."""
    unit = S.Unit([clone(it) for it in reached(S.parsed_library(text).items, entries)])
    strip_body_comments(unit)
    ctx = Context(tuple(entries), frozenset(set(keep) | {loader for _, loader in structs}),
                  structs=tuple(structs), fold_constants=fold_constants)
    fixed_point(unit, ROUND, ctx, MAX_ROUNDS)
    unit.items[:] = _ordered(unit.items)
    tidy_comments(unit)
    return unit


def compile_glsl(text: str, entries, structs=(), fold_constants: bool = True, keep=()) -> str:
    """:func:`compile_unit` printed (:func:`cellgl.export.printer.print_lines`): no blank line
    between declarations, each statement on one line where it fits."""
    return print_lines(compile_unit(text, entries, structs, fold_constants, keep))


def text_passes(*passes):
    """The text passes ``passes`` (``(items, ctx) -> items``) as one tree pass: the bridge from
    the tree to :mod:`cellgl.export.reach`'s top-level text items and back, while passes move to
    the tree (it goes with the last of them). Changed: the text changed."""

    settled: list = [None]            # the text (and context) these passes last left as it was

    @tree_pass
    def bridged(unit: S.Unit, ctx: Context) -> bool:
        texts = ["\n".join(item_glsl(it)) for it in unit.items]
        printed = "\n\n".join(texts) + "\n"
        key = (printed, ctx.entries, ctx.keep, ctx.structs, ctx.fold_constants)
        if settled[0] == key:
            return False                  # (the passes are functions of their input)
        items = [it for it in parse(printed) if it.kind != "other"]
        before = unparse(items)
        for p in passes:
            items = p(items, ctx)
        if unparse(items) == before:
            settled[0] = key
            return False
        # a declaration the passes left as it was keeps its node; the others are parsed anew
        structs, reuse = [it.name for it in items if it.kind == "struct"], dict(zip(texts, unit.items))
        unit.items[:] = [x for it in items for x in ([reuse.pop(it.text().strip("\n"))] if it.text().strip("\n")
                                                     in reuse else S.parse(it.text(), structs).items)]
        return True

    bridged.__name__ = "+".join(getattr(p, "__name__", "pass") for p in passes)
    return bridged


# one round of the passes, in order: a tree pass (marked by :func:`cellgl.export.tree.tree_pass`)
# is ``(unit, ctx) -> changed``; the text passes not yet moved run through :func:`text_passes`


def _fold(items, ctx):
    if not ctx.fold_constants:
        return items
    env = constants(items)
    return fold(_array_elements(_inline_constants(items, env)), env)


ROUND = [
    scalarise,
    text_passes(
        _fold,
        lambda items, ctx: _inline(items, set(ctx.entries)),
        lambda items, ctx: inline_once(items, set(ctx.entries) | ctx.keep),
        lambda items, ctx: _drop_unused_params(items, set(ctx.entries)),
        lambda items, ctx: _constant_args(items, set(ctx.entries)),
        lambda items, ctx: _drop_unused_outs(items, set(ctx.entries)),
        lambda items, ctx: void_results(items, set(ctx.entries), _impure_functions(items)),
        lambda items, ctx: _dead_fields(items),
        lambda items, ctx: constant_fields(items) if ctx.fold_constants else items,
    ),
    reach,
]


def _ordered(items: list) -> list:
    """Top-level nodes in their order, each moved after what it uses (the recipe's constants come
    after the library in the source, but the library now reads them)."""
    by_name: dict[str, list] = {}
    for it in items:
        for n in _names(it):
            by_name.setdefault(n, []).append(it)
    pos = {id(it): k for k, it in enumerate(items)}
    out, done, busy = [], set(), set()

    def visit(it):
        if id(it) in done or id(it) in busy:
            return
        busy.add(id(it))
        used = [n for n in uses(it) if n in by_name]
        for u in sorted(used, key=lambda n: min(pos[id(x)] for x in by_name[n])):
            for dep in by_name[u]:
                visit(dep)
        busy.discard(id(it))
        done.add(id(it))
        out.append(it)

    for it in items:
        visit(it)
    return out


def _params(it: Item):
    toks, code = it.toks, _code_idx(it.toks)
    w = [toks[i].text for i in code]
    op = w.index("(")
    cl = _match(toks, code, op)
    return [w[a:b] for a, b in _split_args(toks, code, op, cl)], w[cl + 1:]


def _impure_functions(items: list[Item]) -> set[str]:
    """The functions with an ``out`` or ``inout`` parameter (a call to them writes its arguments)."""
    return {it.name for it in items if it.kind == "function"
            and re.search(r"\b(out|inout)\b", "".join(t.text for t in it.toks).split("{", 1)[0])}


def _rewritable(items: list[Item], keep):
    """``(item, params, body)`` of every function whose signature a pass may change: defined once
    (no overloads) and not an entry point in ``keep``."""
    count: dict[str, int] = {}
    for it in items:
        count[it.name] = count.get(it.name, 0) + 1
    for it in items:
        if it.kind == "function" and it.name not in keep and count[it.name] == 1:
            yield (it, *_params(it))


def _drop_unused_params(items: list[Item], keep) -> list[Item]:
    """Drop the parameters a function never reads (its callers' arguments with them)."""

    impure = _impure_functions(items)
    for it, params, body in _rewritable(items, keep):
        for k, words in enumerate(params):
            if not words or words[-1] in body or set(words) & {"out", "inout"} or words[-1] == "]":
                continue
            takes = {it.name: (k, words[-1])}
            new = []
            for x in items:
                if x is not it and it.name not in x.uses():
                    new.append(x)                 # no call of it here
                    continue
                toks = _drop_struct_args(x.toks, takes, "", skip_sig=x is it)
                if toks is None or (x.kind == "function" and _impure_arg(x, toks, impure)):
                    break
                new.append(Item(x.kind, x.name, toks, x.comment))
            else:
                return _drop_unused_params(new, keep)
    return items


_CONST_ARG = re.compile(r"-?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?u?|[iu]?vec[234]\(\s*-?[\d.]+u?(?:\s*,\s*-?[\d.]+u?)*\s*\)")


def _constant_args(items: list[Item], keep) -> list[Item]:
    """A parameter that every call passes the same literal (``0u``, ``vec4(0.0, 0.0, 0.0, 0.0)``)
    becomes that literal in the body, and the argument goes."""
    impure = _impure_functions(items)
    for it, params, body in _rewritable(items, keep):
        for k, words in enumerate(params):
            if len(words) != 2 or words[0] in ("out", "inout"):
                continue
            name = words[1]
            text = " ".join(body)
            if re.search(rf"(\+\+|--)\s*{name}\b|\b{name}\s*(\.\s*\w+|\[[^\]]*\])?\s*([-+*/]?=(?!=)|\+\+|--)", text) \
                    or any(re.search(rf"\b{f}\s*\([^;]*[(,]\s*{name}\s*[,)]", text) for f in impure if f in body):
                continue
            seen = set()
            for x in items:
                if x.kind != "function" or (x is not it and it.name not in x.uses()):
                    continue
                toks, code = x.toks, _code_idx(x.toks)
                w = [toks[i].text for i in code]
                for m in range(2 if x is it else 0, len(w) - 1):
                    if w[m] == it.name and w[m + 1] == "(" and (m == 0 or w[m - 1] != "."):
                        cl = _match(toks, code, m + 1)
                        args = _split_args(toks, code, m + 1, cl)
                        a, b = args[k] if k < len(args) else (0, 0)
                        seen.add("".join(t.text for t in toks[code[a]:code[b - 1] + 1]).strip() if b else None)
            if len(seen) != 1 or None in seen or not _CONST_ARG.fullmatch(next(iter(seen))):
                continue
            value = next(iter(seen))
            value = f"({value})" if value.startswith("-") else value
            takes = {it.name: (k, name)}
            new = []
            for x in items:
                if x is not it and it.name not in x.uses():
                    new.append(x)                 # no call of it here
                    continue
                toks = _drop_struct_args(x.toks, takes, "", skip_sig=x is it)
                if toks is None:
                    break
                if x is it:
                    head = "".join(t.text for t in toks[:_sig_end(toks)])
                    rest = tokenize("".join(t.text for t in toks[_sig_end(toks):]))
                    rest = "".join(value if t.kind == "id" and t.text == name and (j == 0 or rest[j - 1].text != ".")
                                   else t.text for j, t in enumerate(rest))
                    toks = tokenize(head + rest)
                new.append(Item(x.kind, x.name, toks, x.comment))
            else:
                return _constant_args(new, keep)
    return items


def _drop_unused_outs(items: list[Item], keep) -> list[Item]:
    """An ``out`` parameter whose argument is, at every call, a local used nowhere else becomes a
    local of the function (whose stores the dead-store pass then removes)."""

    for it, params, _ in _rewritable(items, keep):
        for k, words in enumerate(params):
            if words[:1] != ["out"] or len(words) != 3:
                continue
            calls_ok, n_calls = True, 0
            for x in items:
                if x.kind != "function" or x is it:
                    continue
                toks, code = x.toks, _code_idx(x.toks)
                w = [toks[i].text for i in code]
                for m in range(len(w) - 1):
                    if w[m] == it.name and w[m + 1] == "(":
                        n_calls += 1
                        cl = _match(toks, code, m + 1)
                        args = _split_args(toks, code, m + 1, cl)
                        a, b = args[k]
                        if b - a != 1 or w.count(w[a]) != 2 or w[_decl_at(w, w[a])] not in _DECL_TYPES:
                            calls_ok = False
            if not calls_ok or not n_calls:
                continue
            takes = {it.name: (k, words[-1])}
            new = []
            for x in items:
                toks = _drop_struct_args(x.toks, takes, "", skip_sig=x is it)
                if x is it:
                    text = "".join(t.text for t in toks)
                    text = text.replace("{", "{\n    " + words[1] + " " + words[2] + ";", 1)
                    toks = tokenize(text)
                new.append(Item(x.kind, x.name, toks, x.comment))
            return _drop_unused_outs(new, keep)
    return items


def _decl_at(w: list[str], name: str) -> int:
    return next((m - 1 for m in range(1, len(w)) if w[m] == name), 0)


def _impure_arg(x: Item, toks: list[Tok], impure: set[str]) -> bool:
    """Whether dropping arguments removed a call to a function with out parameters."""
    before = [t.text for t in x.toks if t.kind == "id"]
    after = [t.text for t in toks if t.kind == "id"]
    return any(before.count(f) != after.count(f) for f in impure)


def _dead_fields(items: list[Item]) -> list[Item]:
    """Remove struct fields that are written (``o.f = ...;``) but never read, and those writes."""
    code = "\n".join("".join(t.text for t in it.toks if t.kind != "comment") for it in items)
    impure = _impure_functions(items)
    out = items
    for st in [it for it in items if it.kind == "struct"]:
        body = "".join(t.text for t in st.toks if t.kind != "comment")
        fields = re.findall(r"\b(\w+)\s*(?:\[\s*\w+\s*\])?\s*;", body)
        holders = set(re.findall(rf"\b{st.name}\s+(\w+)\s*[;,)=]", code))
        dead = set()
        if not holders:
            continue
        names = "|".join(sorted(holders))
        others = {v for t, v in re.findall(r"\b(Cellgl\w+)\s+(\w+)\b", code) if t != st.name} - holders
        access = {}                          # field -> [(base, is a store)]
        for m in re.finditer(r"\.([A-Za-z_]\w*)", code):
            if m.group(1) not in fields:
                continue
            base = re.search(r"(\w*)\s*$", code[max(0, m.start() - 40):m.start()]).group(1)
            store = re.match(r"(?:\s*\[[^\]]*\])?\s*=(?!=)", code[m.end():m.end() + 40]) is not None
            access.setdefault(m.group(1), []).append((base, store))
        for f in fields:
            reads = [b for b, store in access.get(f, ()) if not store and b not in others]
            stores = re.findall(rf"(?<![\w.])(?:{names})\.{f}(?:\s*\[[^\]]*\])?\s*=(?!=)[^;]*;", code) \
                if f in access else []
            writes = len(stores)
            if any(re.search(rf"\b{g}\b", x) for x in stores for g in impure) \
                    and not all(_effects_unused(items, x, impure) for x in stores):
                continue
            # reads that only feed stores to the same field (r.F[1] = r.F[0]) keep nothing alive
            own = sum(len(re.findall(rf"(?<![\w.])(?:{names})\.{f}\b", x)) - 1 for x in stores)
            if writes and len(reads) <= own:
                dead.add(f)
        if not dead or len(dead) == len(fields):
            continue

        new = []
        for it in out:
            if it is st:
                new.append(_drop_fields(it, dead))
            elif it.kind == "function":
                t = "".join(x.text for x in it.toks)
                for f in dead:
                    t = re.sub(rf"\n[ \t]*(?:{'|'.join(holders)})\.{f}(?:\s*\[[^\]]*\])?\s*=[^;]*;[^\n]*(?=\n)", "", t)
                new.append(Item(it.kind, it.name, tokenize(t), it.comment))
            else:
                new.append(it)
        out = new
    return out


def _effects_unused(items: list[Item], store: str, impure: set[str]) -> bool:
    """Whether the calls in ``store`` (a statement ``o.f = ...;``) only change locals of the
    function it is in that nothing reads after it: then the statement can go whole."""
    sigs = {it.name: _params(it)[0] for it in items if it.kind == "function" and it.name in impure}
    for it in items:
        if it.kind != "function":
            continue
        text = "".join(t.text for t in it.toks if t.kind != "comment")
        at = text.find(store)
        if at < 0:
            continue
        before, after = text[:at], text[at + len(store):]
        toks = tokenize(store)
        code = _code_idx(toks)
        w = [toks[i].text for i in code]
        for fn, k, a, b in _call_args(toks, code, sigs):
            if k >= len(sigs[fn]) or not set(sigs[fn][k]) & {"out", "inout"}:
                continue
            name = w[a]
            if b - a != 1 or not re.search(rf"\b\w+\s+{name}\s*;", before) \
                    or re.search(rf"\b{name}\b", after) or _in_a_loop(before):
                return False
        return True
    return False


def _in_a_loop(before: str) -> bool:
    """Whether the end of ``before`` (a function's text) is inside a loop body."""
    depth, k = 0, len(before)
    while k > 0:
        k -= 1
        if before[k] == "}":
            depth += 1
        elif before[k] == "{":
            if depth == 0:
                head = before[:k].rstrip()
                if head.endswith(")") and re.search(r"\b(for|while)\s*\([^{};]*(;[^{};]*){0,2}\)$", head):
                    return True
            else:
                depth -= 1
    return False
