"""The snippet compiler's passes on what is kept: reachability, the parameter structs, comments.

Tree passes (:func:`cellgl.export.tree.tree_pass`) over the :mod:`cellgl.export.syntax` tree of
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
from dataclasses import dataclass, field

from cellgl.export.translate.tokens import Tok, tokenize   # (first: translate imports syntax)
from cellgl.export import syntax as S
from cellgl.export.tree import clone, transform, tree_pass, walk

__all__ = ["reach", "reached", "uses", "scalarise", "scalarise_struct", "strip_body_comments", "tidy_comments",
           "first_sentence", "Item", "parse", "unparse"]


# --------------------------------------------------------------------------------------------
# reachability
# --------------------------------------------------------------------------------------------


def uses(node) -> set[str]:
    """The top-level names ``node`` refers to: variables, called functions, types (its own name
    included, for a function)."""
    out = set()
    for n in walk(node):
        t = type(n)
        if t is S.Name:
            out.add(n.name)
        elif t is S.Call:
            out.add(n.func)
        elif t in (S.Ctor, S.ArrayCtor, S.Decl, S.Global, S.Field, S.Param):
            out.add(n.type)
        elif t is S.Function:
            out.add(n.ret)
    return out


def _names(item) -> list[str]:
    if isinstance(item, S.Global):
        return [d.name for d in item.declarators]
    return [item.name]


def reached(items: list, entries) -> list:
    """The top-level nodes of ``items`` reached from the names ``entries`` (in their order)."""
    by_name: dict[str, list] = {}
    for it in items:
        for n in _names(it):
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
    return [it for it in items if any(n in seen for n in _names(it))]


@tree_pass
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


def _atomic(e) -> bool:
    return isinstance(e, (S.Name, S.Num, S.Member, S.Call, S.Ctor, S.ArrayCtor, S.Index, S.Paren))


def _loader_fields(load: S.Function, constants: set[str]) -> dict[str, tuple[object, object]]:
    """``{field: (value, loader statement)}`` of the fields the loader sets from globals and
    literals only: ``p.f = cellgl_f;``, ``p.f = ivec4(0);``, and the copy of a global array
    ``for (int k = 0; ...) { p.f[k] = cellgl_f[k]; }``."""
    out = {}
    for st in load.body.body:
        if isinstance(st, S.For) and isinstance(st.init, S.Decl) and len(st.init.declarators) == 1:
            body = st.body.body if isinstance(st.body, S.Block) else [st.body]
            k = st.init.declarators[0].name
            e = body[0].expr if len(body) == 1 and isinstance(body[0], S.ExprStmt) else None
            if isinstance(e, S.Assign) and e.op == "=" and isinstance(e.target, S.Index) \
                    and isinstance(e.target.base, S.Member) and isinstance(e.target.base.base, S.Name) \
                    and e.target.index == S.Name(k) and isinstance(e.value, S.Index) \
                    and isinstance(e.value.base, S.Name) and e.value.base.name in constants \
                    and e.value.index == S.Name(k):
                out[e.target.base.name] = (S.Name(e.value.base.name), st)
            continue
        e = st.expr if isinstance(st, S.ExprStmt) else None
        if isinstance(e, S.Assign) and e.op == "=" and isinstance(e.target, S.Member) \
                and isinstance(e.target.base, S.Name):
            if all(n.name in constants for n in walk(e.value) if isinstance(n, S.Name)) \
                    and not any(isinstance(n, S.Call) for n in walk(e.value)):
                out[e.target.name] = (e.value if _atomic(e.value) else S.Paren(e.value), st)
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
        if f is not load and f.body is not None:
            names = holders[id(f)]
            transform(f.body, lambda e: clone(fields[e.name][0]) if _is_field(e, names, fields) else e)
    if complete:
        for f in funcs:
            if f.name in takes:
                del f.params[takes[f.name]]
            if f is load or f.body is None:
                continue
            for n in walk(f.body):
                if isinstance(n, S.Call) and n.func in takes:
                    del n.args[takes[n.func]]
            names = holders[id(f)]
            transform(f.body, lambda s: None if isinstance(s, S.Decl) and s.type == struct
                      and all(d.name in names for d in s.declarators) else s)
    else:
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
                gone.add(id(n.base))
        if any(isinstance(n, S.Name) and n.name in names and id(n) not in gone for n in walk(f.body)):
            return False                               # still used whole: cannot drop it
    return True


@tree_pass
def scalarise(unit: S.Unit, ctx) -> bool:
    """:func:`scalarise_struct` of every ``(struct, loader)`` of ``ctx.structs``."""
    changed = False
    for struct, loader in ctx.structs:
        changed = scalarise_struct(unit, struct, loader) or changed
    return changed


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




# --------------------------------------------------------------------------------------------
# the text bridge: top-level items of GLSL text and token helpers, for the passes not yet on the
# tree (cellgl.export.compiler.text_passes); this section goes with the last of them
# --------------------------------------------------------------------------------------------

_QUALIFIERS = {"const", "uniform", "highp", "mediump", "lowp", "flat", "precise", "invariant"}


@dataclass
class Item:
    """One top-level declaration: ``kind`` function | prototype | struct | variable | other."""

    kind: str
    name: str
    toks: list[Tok]                       # the declaration's code (comments inside kept)
    comment: list[Tok] = field(default_factory=list)   # the comment block right above it

    def code(self) -> list[str]:
        return [t.text for t in self.toks if t.kind not in ("ws", "comment")]

    def uses(self) -> set[str]:
        key = (id(self.toks), len(self.toks))
        cached = self.__dict__.get("_uses")
        if cached is None or cached[0] != key or cached[2] is not self.toks:
            cached = (key, {t.text for t in self.toks if t.kind == "id"} - {self.name}, self.toks)
            self.__dict__["_uses"] = cached
        return cached[1]

    def text(self) -> str:
        return "".join(t.text for t in self.comment) + "".join(t.text for t in self.toks)


def _line_start(toks: list, start: int) -> int:
    """Token index ``start`` moved back over the indentation before it and the line break before
    that, so that cutting from there removes a whole statement line."""
    while start > 0 and toks[start - 1].kind == "ws" and "\n" not in toks[start - 1].text:
        start -= 1
    if start > 0 and toks[start - 1].kind == "ws":
        start -= 1
    return start


def parse(text: str) -> list[Item]:
    """Split GLSL text into its top-level declarations (each with its leading comment block)."""
    toks = tokenize(text)
    items: list[Item] = []
    pending: list[Tok] = []     # comments (and the newlines between them) since the last item
    cur: list[Tok] = []
    depth = 0
    for t in toks:
        if not cur:
            if t.kind == "comment":
                pending.append(t)
                continue
            if t.kind == "ws":
                if t.text.count("\n") >= 2:
                    pending = []                      # a blank line detaches a comment
                elif pending:
                    pending.append(t)
                continue
        cur.append(t)
        if t.text == "{":
            depth += 1
        elif t.text == "}":
            depth -= 1
            if depth == 0 and _first(cur) != "struct":
                items.append(_item(cur, pending))
                cur, pending = [], []
        elif t.text == ";" and depth == 0:
            items.append(_item(cur, pending))
            cur, pending = [], []
    if any(t.kind not in ("ws", "comment") for t in cur):
        items.append(_item(cur, pending))
    return items


def _first(toks: list[Tok]) -> str:
    for t in toks:
        if t.kind not in ("ws", "comment"):
            return t.text
    return ""


def _item(toks: list[Tok], comment: list[Tok]) -> Item:
    code = [t.text for t in toks if t.kind not in ("ws", "comment")]
    s = [c for c in code if c not in _QUALIFIERS]
    comment = list(comment)
    while comment and comment[-1].kind == "ws":
        comment.pop()
    if comment:
        comment.append(Tok("ws", "\n"))
    if s and s[0] == "struct":
        return Item("struct", s[1], list(toks), comment)
    if len(s) >= 3 and s[2] == "(":
        return Item("function" if code[-1] == "}" else "prototype", s[1], list(toks), comment)
    if len(s) >= 2 and s[1].isidentifier():
        return Item("variable", s[1], list(toks), comment)
    return Item("other", "", list(toks), comment)


def unparse(items: list[Item], blank: bool = True) -> str:
    """The text of ``items``, one blank line between declarations (consecutive one-line
    variables stay together); ``blank=False``: none (a declaration's comment line sets it off)."""
    out: list[str] = []
    prev = None
    for it in items:
        body = it.text().strip("\n")
        one_line = it.kind == "variable" and "\n" not in "".join(t.text for t in it.toks).strip()
        if out:
            out.append("\n" if (one_line and prev) or not blank else "\n\n")
        out.append(body)
        prev = one_line
    return "".join(out) + "\n"


def _code_idx(toks: list[Tok]) -> list[int]:
    """Indices of the code tokens of ``toks`` (remembered per list: the passes scan the same
    unchanged functions again and again; a list is never changed in place once scanned)."""
    hit = _CODE_IDX.get(id(toks))
    if hit is not None and hit[0] is toks and hit[1] == len(toks):
        return hit[2]
    code = [i for i, t in enumerate(toks) if t.kind not in ("ws", "comment")]
    if len(_CODE_IDX) > 1000:
        _CODE_IDX.clear()
    _CODE_IDX[id(toks)] = (toks, len(toks), code)        # (the list is held: its id is not reused)
    return code


_CODE_IDX: dict[int, tuple] = {}


def _match(toks: list[Tok], code: list[int], n: int) -> int:
    """Position in ``code`` of the bracket closing the one at position ``n``."""
    opens, closes = "([{", ")]}"
    depth = 0
    for m in range(n, len(code)):
        s = toks[code[m]].text
        if s in opens:
            depth += 1
        elif s in closes:
            depth -= 1
            if depth == 0:
                return m
    raise ValueError("unbalanced brackets")


def _split_args(toks: list[Tok], code: list[int], lo: int, hi: int) -> list[tuple[int, int]]:
    """Code positions [start, end) of the comma-separated arguments between ``lo`` (the '(')
    and ``hi`` (its ')')."""
    args, depth, start = [], 0, lo + 1
    for m in range(lo + 1, hi):
        s = toks[code[m]].text
        if s in "([{":
            depth += 1
        elif s in ")]}":
            depth -= 1
        elif s == "," and depth == 0:
            args.append((start, m))
            start = m + 1
    if start < hi:
        args.append((start, hi))
    return args


def _call_args(toks: list[Tok], code: list[int], names) -> list[tuple[str, int, int, int]]:
    """``(function, k, start, end)`` for argument k of every call to a function in ``names``:
    code positions [start, end) of the argument (``code``: the code tokens of ``toks``)."""
    w = [toks[i].text for i in code]
    out = []
    for n in range(len(w) - 1):
        if w[n] in names and w[n + 1] == "(":
            cl = _match(toks, code, n + 1)
            out += [(w[n], k, a, b) for k, (a, b) in enumerate(_split_args(toks, code, n + 1, cl))]
    return out


def _stmt_end(toks, code, w, n) -> int:
    """Code position of the last token of the statement starting at ``n``."""
    if w[n] == "{":
        return _match(toks, code, n)
    if w[n] in ("for", "while") or w[n] == "if":
        cl = _match(toks, code, n + 1)
        end = _stmt_end(toks, code, w, cl + 1)
        if w[n] == "if" and end + 1 < len(w) and w[end + 1] == "else":
            end = _stmt_end(toks, code, w, end + 2)
        return end
    depth = 0
    for m in range(n, len(w)):
        if w[m] in "([":
            depth += 1
        elif w[m] in ")]":
            depth -= 1
        elif w[m] == ";" and depth == 0:
            return m
    return len(w) - 1


def _drop_fields(it: Item, fields: set[str]) -> Item:
    text = "".join(t.text for t in it.toks).split("\n")
    drop = set()
    for n in range(len(text) - 1, -1, -1):
        m = re.match(r"^\s*\w+\s+(\w+)\s*(\[\s*\w+\s*\])?\s*;", text[n])
        if m and m.group(1) in fields:
            drop.add(n)
        elif text[n].strip().startswith("//") and n + 1 in drop:
            drop.add(n)
    return Item(it.kind, it.name, tokenize("\n".join(ln for n, ln in enumerate(text) if n not in drop)),
                it.comment)


def _sig_end(toks: list[Tok]) -> int:
    code = _code_idx(toks)
    op = next(n for n, i in enumerate(code) if toks[i].text == "(")
    return code[_match(toks, code, op)] + 1


def _drop_struct_args(toks: list[Tok], takes: dict, loader: str, skip_sig: bool) -> list[Tok] | None:
    """Remove the struct parameter from the signature (``skip_sig``) and the struct argument
    from every call of a function in ``takes``."""
    code = _code_idx(toks)
    kill: set[int] = set()
    first = True
    for n, i in enumerate(code):
        name = toks[i].text
        if toks[i].kind != "id" or n + 1 >= len(code) or toks[code[n + 1]].text != "(":
            continue
        is_sig = first and skip_sig
        if name in takes or is_sig:
            if is_sig and name not in takes:
                first = False
                continue
            k = takes[name][0]
            lo = n + 1
            hi = _match(toks, code, lo)
            args = _split_args(toks, code, lo, hi)
            if k >= len(args):
                return None
            a, b = args[k]
            # with its comma: the one after it, or (last argument) the one before it
            if k + 1 < len(args):
                span = range(code[a], code[args[k + 1][0]])
            elif k > 0:
                span = range(code[args[k - 1][1]], code[b - 1] + 1)
            else:
                span = range(code[a], code[b - 1] + 1)
            kill.update(span)
        first = False
    return [t for k, t in enumerate(toks) if k not in kill]
