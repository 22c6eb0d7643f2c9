"""The snippet compiler's middle end: fold the recipe into the code, keep only what it reaches.

Input: the specialised, prefixed GLSL of a snippet (no directive, no macro left; see
:mod:`cellgl.export.translate`). Output: GLSL text of the same kind, shorter, for the same
translators. Four passes over the top-level declarations (:func:`parse`):

1. :func:`scalarise` -- a parameter struct that only ever holds the values of its loader
   (``cellgl_texture_params_load``: ``t.seed = cellgl_seed; ...``) disappears: every ``t.field``
   becomes the constant (or uniform) the loader reads, and the struct parameter is dropped from
   every signature and every call.
2. :func:`fold` -- conditions that are constant once the recipe's scalar constants are known
   (``if (cellgl_fractal == 4)``, ``cellgl_c_noise != 0.0 ? ... : ...``, locals initialised with
   such a value and never assigned again) are evaluated; the branches not taken are removed.
3. :func:`reach` -- from the entry points over the names each declaration uses (functions,
   prototypes, constants, uniforms, structs): only what is reached is kept.
4. Comments: a declaration keeps the comment block right above it (the library explains each
   function there); file banners and comments not attached to a kept declaration go.

Everything here is text in, text out; a construct a pass does not understand leaves the code as it
was (the pass is skipped), so the result is always the library's own code, only less of it.
"""
from __future__ import annotations

import re
import textwrap
from dataclasses import dataclass, field

from cellgl.export.translate.tokens import Tok, tokenize

__all__ = ["Item", "parse", "scalarise", "reach", "tidy_comments", "unparse"]

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


# --------------------------------------------------------------------------------------------
# parsing into top-level items
# --------------------------------------------------------------------------------------------


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
    if len(s) >= 2 and re.fullmatch(r"[A-Za-z_]\w*", s[1]):
        return Item("variable", s[1], list(toks), comment)
    return Item("other", "", list(toks), comment)


def tidy_comments(items: list[Item], width: int = 120) -> list[Item]:
    """A declaration keeps the first sentence of the comment right above it, wrapped to
    ``width`` columns (a sentence longer than two lines: up to its first colon or semicolon);
    blank lines inside function bodies go (the library's comment lines there went before the
    passes, :func:`strip_body_comments`; those left are inlined functions' own)."""
    out = []
    for it in items:
        text = first_sentence("".join(t.text for t in it.comment), width) if it.comment else ""
        comment = tokenize("\n".join("// " + ln for ln in textwrap.wrap(text, width - 3)) + "\n") if text else []
        toks = it.toks
        if it.kind == "function":
            toks = strip_body_comments(toks, keep=True)
        out.append(Item(it.kind, it.name, toks, comment))
    return out


def strip_body_comments(toks, keep: bool = False):
    """A function's tokens without blank lines and (``keep=False``) comment lines."""
    lines = "".join(t.text for t in toks).split("\n")
    body = [ln for ln in lines if ln.strip() and (keep or not ln.strip().startswith("//"))]
    return toks if len(body) == len(lines) else tokenize("\n".join(body))


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


# --------------------------------------------------------------------------------------------
# token helpers
# --------------------------------------------------------------------------------------------


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


# --------------------------------------------------------------------------------------------
# 1. constant parameter structs -> the loader's names
# --------------------------------------------------------------------------------------------

_ASSIGN_RE = re.compile(r"^\s*(\w+)\.(\w+)\s*=\s*([^;]*);\s*$")
_COPY_RE = re.compile(r"^\s*(\w+)\.(\w+)\s*\[\s*(\w+)\s*\]\s*=\s*([A-Za-z_]\w*)\s*\[\s*\3\s*\]\s*;\s*$")
_TYPE_WORDS = {"int", "uint", "float", "bool", "vec2", "vec3", "vec4", "ivec2", "ivec3", "ivec4", "uvec2",
               "uvec3", "uvec4", "true", "false"}


def _loader_fields(load: Item, globals_: set[str]) -> dict[str, tuple[str, list[int]]]:
    """``{field: (value text, loader lines)}`` of the fields the loader sets from globals and
    literals only (``p.f = cellgl_f;``, ``p.f = ivec4(0);``, ``p.f[k] = cellgl_f[k];`` in a loop)."""
    lines = "".join(t.text for t in load.toks).split("\n")
    out: dict[str, tuple[str, list[int]]] = {}
    for n, ln in enumerate(lines):
        m = _COPY_RE.match(ln)
        if m and m.group(4) in globals_ and n > 0 and lines[n - 1].strip().startswith("for") \
                and n + 1 < len(lines) and lines[n + 1].strip() == "}":
            out[m.group(2)] = (m.group(4), [n - 1, n, n + 1])
            continue
        m = _ASSIGN_RE.match(ln)
        if m:
            ids = set(re.findall(r"\b[A-Za-z_]\w*\b", m.group(3)))
            if ids <= globals_ | _TYPE_WORDS:
                rhs = m.group(3).strip()
                if not re.fullmatch(r"[\w.]+", rhs) and not re.fullmatch(r"\w+\([^()]*\)", rhs):
                    rhs = f"({rhs})"
                out[m.group(2)] = (rhs, [n])
    return out


def scalarise(items: list[Item], struct: str, loader: str) -> list[Item]:
    """Replace the fields of the struct ``struct`` by the values its loader ``loader`` sets them to.

    Applies when every value of the struct comes straight from the loader: parameters (not
    ``out``/``inout``) and locals ``S p = loader(...);``. A field the loader sets from globals and
    literals only is read as that value everywhere and leaves the struct and the loader; when no
    field is left, the struct parameter is dropped from every signature and call, and the struct
    and its loader are no longer reached. Otherwise ``items`` are returned unchanged.
    """
    load = next((it for it in items if it.kind == "function" and it.name == loader), None)
    sdef = next((it for it in items if it.kind == "struct" and it.name == struct), None)
    if load is None or sdef is None:
        return items
    globals_ = {it.name for it in items if it.kind == "variable"}
    fields = _loader_fields(load, globals_)
    sfields = set(re.findall(r"\b(\w+)\s*(?:\[\s*\w+\s*\])?\s*;", "".join(
        t.text for t in sdef.toks if t.kind != "comment")))
    complete = sfields <= set(fields)
    takes: dict[str, tuple[int, str]] = {}      # function -> (parameter index, parameter name)
    holders: dict[str, set[str]] = {}           # function -> names of the struct's values in it
    for it in items:
        if it.kind not in ("function", "prototype") or it.name == loader:
            continue
        toks, code = it.toks, _code_idx(it.toks)
        w = [toks[i].text for i in code]
        op = w.index("(")
        cl = _match(toks, code, op)
        names = set()
        for k, (a, b) in enumerate(_split_args(toks, code, op, cl)):
            words = w[a:b]
            if struct in words:
                if set(words) & {"out", "inout"} or len(words) != 2 + ("in" in words) + ("const" in words):
                    return items
                takes[it.name] = (k, words[-1])
                names.add(words[-1])
        for n in range(cl + 1, len(w)):
            if w[n] == struct:
                if not (n + 3 < len(w) and w[n + 2] == "=" and w[n + 3] == loader):
                    return items               # a local that may hold another value
                names.add(w[n + 1])
        holders[it.name] = names
    out = []
    for it in items:
        if it.kind == "function" and it.name == loader:
            out.append(it if complete else _drop_lines(it, [n for _, ln in fields.values() for n in ln]))
            continue
        if it.kind == "struct" and it.name == struct:
            out.append(it if complete else _drop_fields(it, set(fields)))
            continue
        toks = list(it.toks)
        for pname in holders.get(it.name, ()):
            toks = _replace_fields(toks, pname, fields)
        if complete:
            toks = _drop_struct_args(toks, takes, loader, skip_sig=it.name in takes)
            if toks is None:
                return items
            for pname in holders.get(it.name, ()):
                toks = _drop_local(toks, struct, pname)
                if any(t.kind == "id" and t.text == pname for t in toks[_sig_end(toks):]):
                    return items                      # still used whole: cannot drop it
        out.append(Item(it.kind, it.name, toks, it.comment))
    return out


def _drop_lines(it: Item, lines: list[int]) -> Item:
    text = "".join(t.text for t in it.toks).split("\n")
    keep = "\n".join(ln for n, ln in enumerate(text) if n not in set(lines))
    return Item(it.kind, it.name, tokenize(keep), it.comment)


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


def _drop_local(toks: list[Tok], struct: str, pname: str) -> list[Tok]:
    """Remove ``struct pname = ...;`` when ``pname`` is not used anywhere else."""
    code = _code_idx(toks)
    w = [toks[i].text for i in code]
    for n in range(len(w) - 2):
        if w[n] == struct and w[n + 1] == pname and w[n + 2] == "=":
            if w.count(pname) > 1:
                return toks
            end = w.index(";", n)
            start = code[n]
            start = _line_start(toks, start)
            return toks[:start] + toks[code[end] + 1:]
    return toks


def _sig_end(toks: list[Tok]) -> int:
    code = _code_idx(toks)
    op = next(n for n, i in enumerate(code) if toks[i].text == "(")
    return code[_match(toks, code, op)] + 1


def _replace_fields(toks: list[Tok], pname: str, fields: dict) -> list[Tok]:
    code = _code_idx(toks)
    out = list(toks)
    drop: set[int] = set()
    for n, i in enumerate(code[:-2]):
        if toks[i].text == pname and toks[code[n + 1]].text == ".":
            f = toks[code[n + 2]].text
            if f not in fields:
                continue
            out[i] = Tok("id", fields[f][0])
            drop.update((code[n + 1], code[n + 2]))
    return tokenize("".join(t.text for k, t in enumerate(out) if k not in drop))


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


# --------------------------------------------------------------------------------------------
# 3. reachability
# --------------------------------------------------------------------------------------------


def reach(items: list[Item], entries) -> list[Item]:
    """The items reached from the names ``entries`` (in their original order)."""
    by_name: dict[str, list[Item]] = {}
    for it in items:
        if it.name:
            by_name.setdefault(it.name, []).append(it)
    seen: set[str] = set()
    todo = [e for e in entries if e in by_name]
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        seen.add(name)
        for it in by_name[name]:
            todo.extend(u for u in it.uses() if u in by_name and u not in seen)
    return [it for it in items if it.name in seen]
