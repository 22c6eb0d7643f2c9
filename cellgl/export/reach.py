"""The snippet compiler's passes on what is kept: reachability, the parameter structs, comments.

Tree passes (``(unit, ctx) -> changed``, :mod:`cellgl.export.tree`) over the :mod:`cellgl.export.syntax` tree of
the specialised, prefixed GLSL of a snippet (see :mod:`cellgl.export.compiler`):

1. :func:`scalarise` -- a parameter struct that only ever holds the values of its loader
   (``cellgl_texture_params_load``: ``t.seed = cellgl_seed; ...``) disappears: every ``t.field``
   reads the constant (or uniform) the loader stores, and the struct parameter leaves every
   signature and every call; fields the loader computes from anything else keep the struct;
2. :func:`reach` -- from the entry points over the names each declaration uses (functions,
   prototypes, constants, uniforms, structs): only what is reached is kept;
3. comments: :func:`strip_body_comments` before the passes (a declaration keeps the comment block
   right above it; function bodies lose theirs), :func:`tidy_comments` after them (that block's
   first sentence, wrapped).

A construct a pass does not understand leaves the tree as it was (the pass reports no change),
so the result is always the library's own code, only less of it.
"""
from __future__ import annotations

import re
import textwrap

from cellgl.export import syntax as S
from cellgl.export.tree import calls, clone, paren, transform, walk

__all__ = ["reach", "reached", "uses", "scalarise", "scalarise_struct", "strip_body_comments", "tidy_comments",
           "first_sentence", "item_names"]


# --------------------------------------------------------------------------------------------
# reachability
# --------------------------------------------------------------------------------------------


#: the field of each node class that names what it refers to: a variable, a function, a type
_USED = {S.Name: "name", S.Call: "func", S.Function: "ret", **dict.fromkeys(
    (S.Ctor, S.ArrayCtor, S.Decl, S.Global, S.Field, S.Param), "type")}


def uses(node) -> set[str]:
    """The top-level names ``node`` refers to: variables, called functions, types (its own name
    included, for a function)."""
    return {getattr(n, _USED[type(n)]) for n in walk(node) if type(n) in _USED}


def item_names(item) -> list[str]:
    """The top-level names a tree item defines (a global's declarators, a function's or struct's name)."""
    if isinstance(item, S.Global):
        return [d.name for d in item.declarators]
    return [item.name]


def reached(items: list, entries) -> list:
    """The top-level nodes of ``items`` reached from the names ``entries`` (in their order)."""
    by_name: dict[str, list] = {}
    for it in items:
        for n in item_names(it):
            by_name.setdefault(n, []).append(it)
    seen: set[str] = set()
    todo = [e for e in entries if e in by_name]
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        seen.add(name)
        for it in by_name[name]:
            todo.extend(u for u in uses(it) if u in by_name and u not in seen)
    return [it for it in items if any(n in seen for n in item_names(it))]


def reach(unit: S.Unit, ctx) -> bool:
    """Keep only the declarations the entry points ``ctx.entries`` reach."""
    kept = reached(unit.items, ctx.entries)
    if len(kept) == len(unit.items):
        return False
    unit.items[:] = kept
    return True


# --------------------------------------------------------------------------------------------
# constant parameter structs -> the loader's values
# --------------------------------------------------------------------------------------------


def _loader_fields(load: S.Function, constants: set[str]) -> dict[str, tuple[object, object]]:
    """``{field: (value, loader statement)}`` of the fields the loader sets from globals and
    literals only: ``p.f = cellgl_f;``, ``p.f = ivec4(0);``, and the copy of a global array
    ``for (int k = 0; ...) { p.f[k] = cellgl_f[k]; }``."""
    out: dict[str, tuple[object, object]] = {}
    assert load.body is not None                # (scalarise_struct picks a loader with a body)
    for st in load.body.body:
        match st:
            case S.For(init=S.Decl(declarators=[S.Declarator(name=k)]),
                       body=S.Block(body=[S.ExprStmt(expr=e)]) | S.ExprStmt(expr=e)):
                match e:
                    case S.Assign("=", S.Index(S.Member(S.Name(), f), S.Name(i)), S.Index(S.Name(c), S.Name(j))) \
                            if i == j == k and c in constants:
                        out[f] = (S.Name(c), st)
            case S.ExprStmt(expr=S.Assign("=", S.Member(S.Name(), f), value)):
                if all(n.name in constants for n in walk(value) if isinstance(n, S.Name)) and not calls(value):
                    out[f] = (paren(value), st)
    return out


def _is_field(e, holders: set[str], fields) -> bool:
    return isinstance(e, S.Member) and isinstance(e.base, S.Name) and e.base.name in holders and e.name in fields


def scalarise_struct(unit: S.Unit, struct: str, loader: str) -> bool:
    """Replace the fields of the struct ``struct`` by the values its loader ``loader`` sets them
    to; returns whether the tree changed.

    Applies when every value of the struct comes straight from the loader: parameters (not
    ``out``/``inout``) and locals ``S p = loader(...);``. A field the loader sets from globals and
    literals only is read as that value everywhere and leaves the struct and the loader; when no
    field is left, the struct parameter is dropped from every signature and call (and the struct
    and its loader are no longer reached). Otherwise the tree is left as it was.
    """
    funcs = [it for it in unit.items if isinstance(it, S.Function)]
    load = next((f for f in funcs if f.name == loader and f.body is not None), None)
    sdef = next((it for it in unit.items if isinstance(it, S.Struct) and it.name == struct), None)
    if load is None or sdef is None:
        return False
    assert load.body is not None                # (picked with a body)
    constants = {d.name for it in unit.items if isinstance(it, S.Global) for d in it.declarators} | {"true", "false"}
    fields = _loader_fields(load, constants)
    if not fields:
        return False
    complete = {f.name for f in sdef.fields} <= set(fields)
    takes: dict[str, int] = {}                 # function -> index of its struct parameter
    holders: dict[int, set[str]] = {}          # id(function) -> names of the struct's values in it
    for f in funcs:
        if f is load:
            continue
        names = set()
        for k, p in enumerate(f.params):
            if p.type == struct:
                if p.mode != "in" or p.size is not None:
                    return False
                takes[f.name] = k
                names.add(p.name)
        for n in walk(f.body) if f.body is not None else ():
            if isinstance(n, S.Decl) and n.type == struct:
                for d in n.declarators:
                    if not (isinstance(d.init, S.Call) and d.init.func == loader) or d.size is not None:
                        return False                   # a local that may hold another value
                    names.add(d.name)
            elif isinstance(n, S.Ctor) and n.type == struct:
                return False
            elif isinstance(n, S.Assign) and _is_field(n.target, names, fields) \
                    or isinstance(n, S.IncDec) and _is_field(n.operand, names, fields):
                return False                           # a field stored into outside the loader
        holders[id(f)] = names
    if complete and not _droppable(funcs, load, takes, holders):
        return False
    for f in funcs:
        if complete and f.name in takes:
            del f.params[takes[f.name]]
        if f is load or f.body is None:
            continue
        names = holders[id(f)]
        transform(f.body, lambda e, names=names: clone(fields[e.name][0]) if _is_field(e, names, fields) else e)
        if complete:
            for n in walk(f.body):
                if isinstance(n, S.Call) and n.func in takes:
                    del n.args[takes[n.func]]
            transform(f.body, lambda s, names=names: None if isinstance(s, S.Decl) and s.type == struct
                      and all(d.name in names for d in s.declarators) else s)
    if not complete:
        sdef.fields[:] = [x for x in sdef.fields if x.name not in fields]
        gone = {id(st) for _, st in fields.values()}
        load.body.body[:] = [st for st in load.body.body if id(st) not in gone]
    return True


def _droppable(funcs, load, takes: dict, holders: dict) -> bool:
    """Whether, once every field is read from the loader, the struct's values are used only as
    the arguments that go with the struct parameters (and every such call has one)."""
    for f in funcs:
        if f is load or f.body is None:
            continue
        names = holders[id(f)]
        gone = set()
        for n in walk(f.body):
            if isinstance(n, S.Call) and n.func in takes:
                k = takes[n.func]
                if k >= len(n.args):
                    return False
                gone |= {id(x) for x in walk(n.args[k])}
            elif isinstance(n, S.Member) and isinstance(n.base, S.Name) and n.base.name in names:
                gone.add(id(n.base))                   # (a walk visits a node before its children)
            elif isinstance(n, S.Name) and n.name in names and id(n) not in gone:
                return False                           # still used whole: cannot drop it
    return True


def scalarise(unit: S.Unit, ctx) -> bool:
    """:func:`scalarise_struct` of every ``(struct, loader)`` of ``ctx.structs`` (each one: a list)."""
    return any([scalarise_struct(unit, struct, loader) for struct, loader in ctx.structs])


# --------------------------------------------------------------------------------------------
# comments
# --------------------------------------------------------------------------------------------


def _attached(comments: list) -> list:
    """The comment block right above a declaration (a blank line detaches what is above it)."""
    k = len(comments)
    while k > 0 and comments[k - 1] != "":
        k -= 1
    return comments[k:]


def strip_body_comments(unit: S.Unit) -> None:
    """Before the passes: a declaration keeps the comment block right above it (file banners go),
    function bodies keep no comment lines (a comment after a statement on its line stays)."""
    unit.trailing = []
    for it in unit.items:
        it.comments = _attached(it.comments)
        if isinstance(it, S.Function) and it.body is not None:
            for n in walk(it.body):
                if getattr(n, "comments", None):
                    n.comments = []


def tidy_comments(unit: S.Unit, width: int = 120) -> None:
    """After the passes: a declaration keeps the first sentence of its comment, wrapped to
    ``width`` columns (a sentence longer than two lines: up to its first colon or semicolon);
    comments in function bodies (those inlined functions brought) lose their blank lines."""
    for it in unit.items:
        text = first_sentence("\n".join(_attached(it.comments)), width)
        it.comments = ["// " + ln for ln in textwrap.wrap(text, width - 3)] if text else []
        if isinstance(it, S.Function) and it.body is not None:
            for n in walk(it.body):
                if "" in getattr(n, "comments", ()):
                    n.comments = [c for c in n.comments if c != ""]


def first_sentence(comment: str, width: int) -> str:
    """The first sentence of a ``//`` comment block (a sentence longer than two lines: up to its
    first colon or semicolon)."""
    com = [ln.strip()[2:].strip() for ln in comment.split("\n") if ln.strip().startswith("//")]
    text = " ".join(x for x in com if x)
    m = re.search(r"(?<!\b[A-Z])(?<!\be\.g)(?<!\bi\.e)\.(?=\s+[A-Z`(]|\s+[a-z]+_\w+|\s*$)", text)
    text = text[:m.end()] if m else text
    if len(text) > 2 * (width - 3):
        cut = _clause_end(text)
        text = text[:cut].rstrip(" ,") + "." if 0 < cut < 2 * (width - 3) else text
    return text


def _clause_end(text: str) -> int:
    """Where the first clause of ``text`` ends: its first colon or semicolon outside
    parentheses (0: none)."""
    depth = 0
    for k, ch in enumerate(text):
        depth += ch in "(["
        depth -= ch in ")]"
        if ch in ":;" and depth == 0 and text[k + 1:k + 2] == " ":
            return k
    return 0
