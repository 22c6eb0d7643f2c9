"""Struct fields that hold one literal for the whole program (:mod:`cellgl.export.compiler`).

A struct made in one place only (one local of its type, no constructor call), whose field ``f``
is stored once, ``x.f = false;`` right where the local is made (not in a branch or a loop),
holds that literal wherever the struct goes: every ``v.f`` of a variable of that type reads it.
The reads become the literal (the constant folding then drops the branches it decides) and the
field goes.
"""
from __future__ import annotations

import re

from cellgl.export.reach import Item, _drop_fields
from cellgl.export.translate.tokens import tokenize

__all__ = ["constant_fields"]

_LIT = r"(?:true|false|-?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?u?)"


def _text(it: Item) -> str:
    return "".join(t.text for t in it.toks if t.kind != "comment")


def constant_fields(items: list[Item]) -> list[Item]:
    funcs = [it for it in items if it.kind == "function"]
    texts = {id(it): _text(it) for it in funcs}
    for st in [it for it in items if it.kind == "struct"]:
        body = _text(st)
        fields = re.findall(r"\b(\w+)\s*;", body)
        name = st.name
        locals_ = [(it, m) for it in funcs for m in re.finditer(rf"(?<=[;{{}}])\s*{name}\s+(\w+)\s*;", texts[id(it)])]
        if len(locals_) != 1 or any(re.search(rf"\b{name}\s*\(", texts[id(it)]) for it in funcs):
            continue
        home, decl = locals_[0]
        var = decl.group(1)
        stores: dict[str, list] = {}
        for it in funcs:
            for m in re.finditer(r"(?<![\w.])\w+\s*\.\s*(\w+)\s*(?:\[[^\]]*\])?\s*(?:[-+*/%&|^]|<<|>>)?=(?!=)",
                                 texts[id(it)]):
                stores.setdefault(m.group(1), []).append(it)
        for f in fields:
            if len(stores.get(f, ())) != 1 or stores[f][0] is not home:
                continue
            text = texts[id(home)]
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
                new.append(Item(it.kind, it.name, tokenize(t), it.comment))
            return constant_fields(new)
    return items


def _depth(text: str, at: int) -> int:
    return text.count("{", 0, at) - text.count("}", 0, at)
