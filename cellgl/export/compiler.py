"""The snippet compiler: :func:`compile_glsl` turns the specialised, prefixed GLSL of a snippet
into the code its entry points need, and nothing else.

Passes, repeated until the text stops changing (the fixed point; :data:`MAX_ROUNDS` rounds
without one raise :class:`~cellgl.export.translate.tokens.TranslateError`):

1. :func:`cellgl.export.reach.scalarise` -- the recipe's parameter struct becomes its constants;
2. :func:`cellgl.export.fold.fold` (on the syntax tree, to its own fixed point) -- constants that
   decide the shape of the code (0, 1, integers, switches) written into it, elements of constant
   arrays, constant conditions, loops, locals (:mod:`cellgl.export.fold`); dead locals and stores,
   copies, identities (:mod:`cellgl.export.simplify`);
3. short functions inlined (a ``return`` of one expression, or straight-line stores substituted
   into one), and every function called once, also from inside an expression
   (:mod:`cellgl.export.inline`: transforms of the syntax tree, as are the rest of 3); parameters a function
   never reads dropped, and those every call passes the same literal written into the body;
   ``out`` parameters whose results every caller ignores turned into locals, and return values
   (:func:`cellgl.export.fields.void_results`); struct fields never
   read (or only copied into themselves) removed, those holding one literal everywhere folded
   (:mod:`cellgl.export.fields`);
4. :func:`cellgl.export.reach.reach` -- only what the entry points reach.

Then every declaration comes after what it uses, the comments are tidied
(:func:`cellgl.export.reach.tidy_comments`) and statements the library splits over lines are
joined where they fit. The output is GLSL of the same subset, for the same
translators (:mod:`cellgl.export.translate`).
"""
from __future__ import annotations

import re

from cellgl.export.fold import fold
from cellgl.export.fields import constant_fields, dead_fields, void_results
from cellgl.export.inline import constant_args, drop_unused_outs, drop_unused_params, inline_once, inline_short
from cellgl.export.reach import (
    Item,
    _code_idx,
    _match,
    _split_args,
    parse,
    reach,
    scalarise,
    strip_body_comments,
    tidy_comments,
    unparse,
)
from cellgl.export.printer import print_glsl
from cellgl.export.syntax import parse as parse_tree
from cellgl.export.tree import Context
from cellgl.export.translate.tokens import TranslateError, tokenize

__all__ = ["compile_glsl", "MAX_ROUNDS"]

#: rounds of the passes after which :func:`compile_glsl` gives up (it stops at the first round that
#: changes nothing, the fixed point; the library's presets settle in under 20)
MAX_ROUNDS = 64


def compile_glsl(text: str, entries, structs=(), fold_constants: bool = True, keep=()) -> str:
    """The middle end: keep what ``entries`` reach, scalarise ``structs`` (``[(struct,
    loader)]``, see :func:`cellgl.export.reach.scalarise`), fold constants, inline one-liners
    and functions called once (but those named in ``keep``), repeat until nothing changes."""
    items = reach([it for it in parse(text) if it.kind != "other"], entries)
    items = [Item(it.kind, it.name, strip_body_comments(it.toks), it.comment) if it.kind == "function" else it
             for it in items]
    ctx = Context(tuple(entries), frozenset(set(keep) | {loader for _, loader in structs}),
                  structs=tuple(structs), fold_constants=fold_constants)
    for _ in range(MAX_ROUNDS):
        before = unparse(items)
        k = 0
        while k < len(ROUND):
            if getattr(ROUND[k], "tree_pass", False):
                group = []
                while k < len(ROUND) and getattr(ROUND[k], "tree_pass", False):
                    group.append(ROUND[k])
                    k += 1
                items = on_tree(items, group, ctx)
            else:
                items = ROUND[k](items, ctx)
                k += 1
        if unparse(items) == before:
            break
    else:
        raise TranslateError(f"the snippet compiler did not settle in {MAX_ROUNDS} rounds of its passes "
                             f"(entry points {', '.join(entries)}): a pass undoes another")
    return _join_lines(unparse(tidy_comments(_ordered(items)), blank=False))


def on_tree(items: list[Item], passes, ctx: Context) -> list[Item]:
    """Run the tree passes ``passes`` (see :mod:`cellgl.export.tree`) in order on the text items
    of the driver: the bridge while passes move from text to the tree."""
    unit = parse_tree(unparse(items))
    changed = False
    for p in passes:
        ctx.refresh(unit)
        changed = p(unit, ctx) or changed
    if not changed:
        return items
    return [it for it in parse(print_glsl(unit)) if it.kind != "other"]


# one round of the passes, in order: a text pass is ``(items, ctx) -> items``, a tree pass (marked
# by :func:`cellgl.export.tree.tree_pass`) is ``(unit, ctx) -> changed``; consecutive tree passes
# share one parse


def _scalarise(items, ctx):
    for struct, loader in ctx.structs:
        items = scalarise(items, struct, loader)
    return items


ROUND = [
    _scalarise,
    fold,
    inline_short,
    inline_once,
    drop_unused_params,
    constant_args,
    drop_unused_outs,
    void_results,
    dead_fields,
    constant_fields,
    lambda items, ctx: reach(items, ctx.entries),
]


def _join_lines(text: str, width: int = 110) -> str:
    """A statement the library splits over lines on one line where it fits in ``width``
    columns."""
    lines = text.split("\n")
    out: list[str] = []
    k = 0
    while k < len(lines):
        ln = lines[k]
        s = ln.strip()
        header = re.match(r"(for|if|while|else)\b", s) and s.endswith(")") and s.count("(") == s.count(")")
        if not s or "//" in s or s.endswith((";", "{", "}")) or header or s.startswith("#"):
            out.append(ln)
            k += 1
            continue
        j, joined = k, ln.rstrip()
        while j + 1 < len(lines) and not joined.endswith((";", "{")) and "//" not in lines[j + 1]:
            j += 1
            joined += " " + lines[j].strip()
        if joined.endswith((";", "{")) and len(joined) <= width:
            out.append(joined)
            k = j + 1
        else:
            out.append(ln)
            k += 1
    return "\n".join(out)


def _ordered(items: list[Item]) -> list[Item]:
    """Items in their order, each moved after what it uses (the recipe's constants come after
    the library in the source, but the library now reads them)."""
    by_name = {}
    for it in items:
        by_name.setdefault(it.name, []).append(it)
    out, done, busy = [], set(), set()

    def visit(it):
        if id(it) in done or id(it) in busy:
            return
        busy.add(id(it))
        for u in sorted(it.uses(), key=lambda n: min(items.index(x) for x in by_name[n]) if n in by_name else 0):
            for dep in by_name.get(u, ()):
                visit(dep)
        busy.discard(id(it))
        done.add(id(it))
        out.append(it)

    for it in items:
        visit(it)
    return out
