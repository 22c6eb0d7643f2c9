"""Struct fields that hold one literal for the whole program, and results no caller reads
(:mod:`cellgl.export.compiler`).

A struct made in one place only (one local of its type, no constructor call), whose field ``f``
is stored once, ``x.f = false;`` right where the local is made (not in a branch or a loop),
holds that literal wherever the struct goes: every ``v.f`` of a variable of that type reads it.
The reads become the literal (the constant folding then drops the branches it decides) and the
field goes.

A function whose every call is a statement of its own (``f(x);``: its value thrown away) returns
``void`` (:func:`void_results`): its ``return`` statements lose their value, so what only fed that
value (a struct field, a local) is dead for the other passes.
"""
from __future__ import annotations

import re

from cellgl.export.reach import Item, _code_idx, _drop_fields, _match
from cellgl.export.translate.tokens import tokenize

__all__ = ["constant_fields", "void_results"]

_LIT = r"(?:true|false|-?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?u?)"


def _text(it: Item) -> str:
    return "".join(t.text for t in it.toks if t.kind != "comment")


def constant_fields(items: list[Item]) -> list[Item]:
    """Fold the fields of one-literal structs (module docstring), one field at a time, until none
    is left."""
    texts: dict[int, tuple] = {}
    while True:
        new = _constant_field(items, texts)
        if new is None:
            return items
        items = new


def _constant_field(items: list[Item], texts: dict[int, tuple]) -> list[Item] | None:
    """``items`` with one constant field folded (None: there is none); ``texts`` caches the
    comment-free text of the items by identity (unchanged items are kept as they are)."""
    funcs = [it for it in items if it.kind == "function"]
    for it in funcs:
        if texts.get(id(it), (None,))[0] is not it:      # (the item is held: its id is not reused)
            texts[id(it)] = (it, _text(it))
    text_of = {id(it): texts[id(it)][1] for it in funcs}
    for st in [it for it in items if it.kind == "struct"]:
        body = _text(st)
        fields = re.findall(r"\b(\w+)\s*;", body)
        name = st.name
        locals_ = [(it, m) for it in funcs for m in re.finditer(rf"(?<=[;{{}}])\s*{name}\s+(\w+)\s*;", text_of[id(it)])]
        if len(locals_) != 1 or any(re.search(rf"\b{name}\s*\(", text_of[id(it)]) for it in funcs):
            continue
        home, decl = locals_[0]
        var = decl.group(1)
        stores: dict[str, list] = {}
        for it in funcs:
            for m in re.finditer(r"(?<![\w.])\w+\s*\.\s*(\w+)\s*(?:\[[^\]]*\])?\s*(?:[-+*/%&|^]|<<|>>)?=(?!=)",
                                 text_of[id(it)]):
                stores.setdefault(m.group(1), []).append(it)
        for f in fields:
            if len(stores.get(f, ())) != 1 or stores[f][0] is not home:
                continue
            text = text_of[id(home)]
            m = re.search(rf"(?<=[;{{}}])(\s*){var}\s*\.\s*{f}\s*=\s*({_LIT})\s*;", text)
            if not m or m.start() < decl.end() or _depth(text, decl.end()) != _depth(text, m.start()):
                continue
            lit = m.group(2)
            new = []
            for it in items:
                if it.kind == "struct" and it is st:
                    new.append(_drop_fields(it, {f}))
                    continue
                if it.kind != "function":
                    new.append(it)
                    continue
                t = "".join(x.text for x in it.toks)
                if it is home:
                    t = re.sub(rf"\n[ \t]*{var}\s*\.\s*{f}\s*=\s*{re.escape(lit)}\s*;[^\n]*", "", t, count=1)
                holders = set(re.findall(rf"\b{name}\s+(\w+)", t))
                if holders:
                    t = re.sub(rf"(?<![\w.])({'|'.join(sorted(holders))})\s*\.\s*{f}\b", lit, t)
                new.append(it if t == "".join(x.text for x in it.toks) else Item(it.kind, it.name, tokenize(t), it.comment))
            return new
    return None


def _depth(text: str, at: int) -> int:
    return text.count("{", 0, at) - text.count("}", 0, at)


def void_results(items: list[Item], keep, impure: set[str]) -> list[Item]:
    """``T f(...)`` -> ``void f(...)`` where every call of ``f`` (not in ``keep``, defined once,
    called at least once) is a statement ``f(...);`` and its returned values write nothing (no
    store, no call to a function in ``impure``, those that write their arguments)."""
    funcs = [it for it in items if it.kind == "function"]
    for f in funcs:
        sig = f.code()
        if sig[0] == "void" or sig[1] != f.name or f.name in keep or sum(x.name == f.name for x in items) != 1:
            continue
        calls, alone = 0, True
        for x in funcs:
            toks, code = x.toks, _code_idx(x.toks)
            w = [toks[i].text for i in code]
            for m in range(len(w) - 1):
                if w[m] != f.name or w[m + 1] != "(" or (m and w[m - 1] == ".") or (x is f and m == 1):
                    continue
                calls += 1
                alone = alone and x is not f and m > 0 and w[m - 1] in (";", "{", "}") \
                    and w[:m].count("(") == w[:m].count(")") and w[_match(toks, code, m + 1) + 1] == ";"
        body = _text(f).split("{", 1)[1]
        values = re.findall(r"\breturn\b([^;]*);", body)
        if not calls or not alone or any(re.search(r"\+\+|--|(?<![=!<>])=(?!=)", v) for v in values) \
                or any(re.search(rf"\b{g}\s*\(", v) for v in values for g in impure):
            continue
        t = "".join(x.text for x in f.toks)
        head, rest = t.split(f.name, 1)
        rest = re.sub(r"\breturn\b[^;]*;", "return;", rest)
        rest = re.sub(r"\n[ \t]*return;[^\n]*(?=\n\}\s*$)", "", rest)      # the last statement
        new = Item(f.kind, f.name, tokenize(head.replace(sig[0], "void", 1) + f.name + rest), f.comment)
        return void_results([new if it is f else it for it in items], keep, impure)
    return items
