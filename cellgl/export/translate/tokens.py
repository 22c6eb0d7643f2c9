"""Tokens of GLSL text (the lexer every translation step shares) and the error they raise."""
from __future__ import annotations

import os
import re

from cellgl._cache import Bounded


class TranslateError(ValueError):
    """The shader text uses a construct the exporter cannot specialise or translate."""


_TOKEN_RE = re.compile(
    r"(?P<comment>//[^\n]*|/\*.*?\*/)"
    r"|(?P<ws>\s+)"
    r"|(?P<num>0[xX][0-9a-fA-F]+[uU]?|(?:\d+\.\d*|\.\d+)(?:[eE][+-]?\d+)?[fF]?|\d+[eE][+-]?\d+[fF]?"
    r"|\d+[uU]?)"
    r"|(?P<id>[A-Za-z_][A-Za-z0-9_]*)"
    r"|(?P<op><<=|>>=|\+\+|--|<<|>>|<=|>=|==|!=|&&|\|\||\^\^|[-+*/%&|^]=|[-+*/%<>=!~&|^?:;,.(){}\[\]])",
    re.S,
)


def split_tokens(text: str) -> list[tuple[str, str]]:
    """Split GLSL text (no directives) into ``[(kind, text)]`` tokens, kind one of comment, ws,
    num, id, op; the split is remembered per text (shared: do not change it): the library's
    declarations are split again by every program that holds them."""
    split = _SPLITS.get(text)
    if split is None:
        split = [(m.lastgroup, m.group()) for m in _TOKEN_RE.finditer(text)]
        if sum(len(t) for _, t in split) != len(text):      # a character no token matches
            pos = len(os.path.commonprefix([text, "".join(t for _, t in split)]))
            raise TranslateError(f"line {text.count(chr(10), 0, pos) + 1}: unexpected character {text[pos]!r}")
        _SPLITS.put(text, split)
    return split


_SPLITS = Bounded("GLSL texts split into tokens (cellgl.export.translate.tokens)", 20000)


GLSL_TYPES = ({"void", "bool", "int", "uint", "float", "mat2", "mat3", "mat4"}
              | {f"{k}vec{n}" for k in ("", "i", "u", "b") for n in (2, 3, 4)})
