"""A recipe's name as it appears in exported code: an identifier every target accepts, and text
safe inside a ``//`` comment.

:func:`identifier` is the one place a name becomes code (the OSL ``shader cellgl_<name>``). Its
result is ``cellgl_`` followed by ASCII letters, digits and single underscores, at
most :data:`IDENT_MAX` characters. The ``cellgl_`` prefix is what makes it valid in every target
(GLSL 3.30/4.x and ES 3.00, Shadertoy, Godot, HLSL, Unreal, WGSL, OSL): it starts with a
letter, is no keyword or reserved word of any of them (none begins ``cellgl_``), never begins
``gl_`` and never holds ``__`` (both reserved in GLSL). How the name is spelled in ASCII:

* Latin letters lose their accents (NFKD: ``été`` -> ``ete``, ``ﬁ`` -> ``fi``);
* any other character (CJK, Cyrillic, ...) is its code point, ``u`` and hex (``中`` -> ``u4e2d``),
  so different names stay different;
* everything else (spaces, punctuation) is one ``_``; an empty result is ``recipe``;
* a name too long is cut and ends with 8 hex digits of its SHA-256, so it stays unique.
"""
from __future__ import annotations

import hashlib
import re
import unicodedata

__all__ = ["identifier", "comment_text", "IDENT_MAX"]

IDENT_MAX = 63        #: longest identifier (GLSL ES guarantees 1024, some tools truncate at 63)
PREFIX = "cellgl_"


def _ascii(name: str) -> str:
    out = []
    for ch in unicodedata.normalize("NFKD", name):
        if ch.isascii():
            out.append(ch if ch.isalnum() else "_")
        elif unicodedata.combining(ch):
            continue                                  # an accent of the letter before
        elif ch.isalnum():
            out.append(f"_u{ord(ch):x}_")
        else:
            out.append("_")
    return re.sub(r"_+", "_", "".join(out)).strip("_")


def identifier(name: str) -> str:
    """``cellgl_<name in ASCII>``: a valid identifier, not a keyword, in every export target."""
    body = _ascii(str(name)) or "recipe"
    ident = PREFIX + body
    if len(ident) > IDENT_MAX:
        digest = hashlib.sha256(str(name).encode("utf-8", "surrogatepass")).hexdigest()[:8]
        ident = ident[:IDENT_MAX - 9].rstrip("_") + "_" + digest
    return ident


def comment_text(text: str) -> str:
    """``text`` on one line (control characters and line or paragraph separators as spaces), so
    that a name cannot end a ``//`` comment and put code in the snippet."""
    return "".join(" " if unicodedata.category(c) in ("Cc", "Zl", "Zp") else c for c in str(text))
