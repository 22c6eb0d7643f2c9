"""The snippet compiler: :func:`compile_glsl` turns the specialised, prefixed GLSL of a snippet
into the code its entry points need, and nothing else.

One tree (:mod:`cellgl.export.syntax`) through the whole compile: the parse of the text (cached
per process), the declarations the entry points reach, then :data:`ROUND`'s passes until they
settle (:func:`cellgl.export.tree.fixed_point`; :data:`MAX_ROUNDS` rounds without raise
:class:`~cellgl.export.translate.tokens.TranslateError`): the recipe's parameter structs become
constants (:mod:`cellgl.export.reach`), constants are folded and the code simplified
(:mod:`cellgl.export.fold`, :mod:`cellgl.export.simplify`), functions inlined and parameters
dropped (:mod:`cellgl.export.inline`), void results, dead and constant struct fields go
(:mod:`cellgl.export.fields`), and what the entry points do not reach.

Then every declaration comes after what it uses, the comments are tidied
(:func:`cellgl.export.reach.tidy_comments`) and the tree is printed, a statement on one line
where it fits. The output is GLSL of the same subset, for the same translators
(:mod:`cellgl.export.translate`).
"""
from __future__ import annotations

import gc
from contextlib import contextmanager

from cellgl.export import syntax as S
from cellgl.export.fields import constant_fields, dead_fields, void_results
from cellgl.export.fold import fold, loop_ranges
from cellgl.export.inline import constant_args, drop_unused_outs, drop_unused_params, inline_once, inline_short
from cellgl.export.printer import print_lines
from cellgl.export.reach import item_names, reach, reached, scalarise, strip_body_comments, tidy_comments, uses
from cellgl.export.simplify import EXPRESSIONS, SIMPLIFY
from cellgl.export.tree import Context, clone, fixed_point

__all__ = ["compile_glsl", "compile_unit", "ROUND", "MAX_ROUNDS"]

#: rounds of the passes after which :func:`compile_glsl` gives up (it stops at the first round that
#: changes nothing, the fixed point; the library's presets settle in under 20)
MAX_ROUNDS = 64


@contextmanager
def collector_paused():
    """The cyclic garbage collector off within, then (if it was on) on again after a pass over the
    youngest generation: the many nodes a compile holds set off full passes over the caches."""
    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()
            gc.collect(0)


@collector_paused()
def compile_unit(text: str, entries, structs=(), fold_constants: bool = True, keep=()) -> S.Unit:
    """The middle end on the tree: the declarations ``entries`` reach in ``text`` (its parse is
    cached per process, :func:`cellgl.export.syntax.parsed_library`; this copies only what is
    reached), then :data:`ROUND` to its fixed point, ``structs`` (``[(struct, loader)]``)
    scalarised, the functions named in ``keep`` not inlined. Returns the tree, every declaration
    after what it uses, its comments tidied."""
    unit = S.Unit([clone(it) for it in reached(S.parsed_library(text).items, entries)])
    strip_body_comments(unit)
    ctx = Context(tuple(entries), frozenset(set(keep) | {loader for _, loader in structs}),
                  structs=tuple(structs), fold_constants=fold_constants)
    fixed_point(unit, ROUND, ctx, MAX_ROUNDS)
    unit.items[:] = _ordered(unit.items)
    tidy_comments(unit)
    return unit


def compile_glsl(text: str, entries, structs=(), fold_constants: bool = True, keep=()) -> str:
    """:func:`compile_unit` printed as GLSL (:func:`cellgl.export.printer.print_lines`): no blank
    line between declarations (a declaration's comment sets it off), a statement broken only
    where it does not fit."""
    return print_lines(compile_unit(text, entries, structs, fold_constants, keep))


def _fold(unit, ctx):
    """The folding and simplification passes (:mod:`cellgl.export.fold`, :mod:`cellgl.export.simplify`)."""
    return fold(unit, ctx, [EXPRESSIONS, loop_ranges] + SIMPLIFY)


# one round of the passes, in order: each is ``(unit, ctx) -> changed`` (:mod:`cellgl.export.tree`)
ROUND = [
    scalarise,
    _fold,
    inline_short,
    inline_once,
    drop_unused_params,
    constant_args,
    drop_unused_outs,
    void_results,
    dead_fields,
    constant_fields,
    reach,
]


def _ordered(items: list) -> list:
    """Top-level nodes in their order, each moved after what it uses (the recipe's constants come
    after the library in the source, but the library now reads them)."""
    by_name: dict[str, list] = {}
    for it in items:
        for n in item_names(it):
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
                visit(dep)  # noqa: F821 (itself: `del visit` below breaks the cycle)
        busy.discard(id(it))
        done.add(id(it))
        out.append(it)

    for it in items:
        visit(it)
    del visit   # its cell refers to itself: break the cycle for reference counting
    return out
