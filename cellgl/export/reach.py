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
from dataclasses import dataclass, field

from cellgl.export.translate.tokens import Tok, tokenize

__all__ = ["Item", "parse", "scalarise", "fold", "reach", "compile_glsl", "unparse"]

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
        return {t.text for t in self.toks if t.kind == "id"} - {self.name}

    def text(self) -> str:
        return "".join(t.text for t in self.comment) + "".join(t.text for t in self.toks)


# --------------------------------------------------------------------------------------------
# parsing into top-level items
# --------------------------------------------------------------------------------------------


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


def unparse(items: list[Item]) -> str:
    """The text of ``items``, one blank line between declarations (consecutive one-line
    variables stay together)."""
    out: list[str] = []
    prev = None
    for it in items:
        body = it.text().strip("\n")
        one_line = it.kind == "variable" and "\n" not in "".join(t.text for t in it.toks).strip()
        if out:
            out.append("\n" if (one_line and prev) else "\n\n")
        out.append(body)
        prev = one_line
    return "".join(out) + "\n"


# --------------------------------------------------------------------------------------------
# token helpers
# --------------------------------------------------------------------------------------------


def _code_idx(toks: list[Tok]) -> list[int]:
    return [i for i, t in enumerate(toks) if t.kind not in ("ws", "comment")]


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


# --------------------------------------------------------------------------------------------
# 1. constant parameter structs -> the loader's names
# --------------------------------------------------------------------------------------------

_LOADER_RE = re.compile(r"\b(\w+)\.(\w+)(\s*\[\s*\w+\s*\])?\s*=\s*([A-Za-z_]\w*)(\s*\[\s*\w+\s*\])?\s*;")


def scalarise(items: list[Item], struct: str, loader: str) -> list[Item]:
    """Replace the struct ``struct`` by the names its loader function ``loader`` fills it from.

    Applies only when every value of the struct is the loader's result: no other function
    declares a local of that type or takes it as ``out``/``inout``, and every field a function
    reads is one the loader sets from a plain name (``t.f = name;`` or ``t.f[k] = name[k];``).
    Otherwise ``items`` are returned unchanged.
    """
    load = next((it for it in items if it.kind == "function" and it.name == loader), None)
    if load is None:
        return items
    fields: dict[str, str] = {}
    for m in _LOADER_RE.finditer("".join(t.text for t in load.toks if t.kind != "comment")):
        fields[m.group(2)] = m.group(4)
    # functions taking the struct: name -> (parameter index, parameter name)
    takes: dict[str, tuple[int, str]] = {}
    for it in items:
        if it.kind not in ("function", "prototype") or it.name == loader:
            continue
        toks, code = it.toks, _code_idx(it.toks)
        op = next(n for n, i in enumerate(code) if toks[i].text == "(")
        cl = _match(toks, code, op)
        for k, (a, b) in enumerate(_split_args(toks, code, op, cl)):
            words = [toks[code[m]].text for m in range(a, b)]
            if struct in words:
                if set(words) & {"out", "inout"} or len(words) != 2 + ("in" in words) + ("const" in words):
                    return items
                takes[it.name] = (k, words[-1])
        # a local of the struct type (other than the parameter) may hold another value
        body = [toks[i].text for i in code[cl + 1:]]
        if struct in body:
            return items
    out = []
    for it in items:
        if it.name == loader and it.kind == "function":
            out.append(it)
            continue
        toks = list(it.toks)
        pname = takes.get(it.name, (None, None))[1]
        if pname is not None:
            toks = _replace_fields(toks, pname, fields)
            if toks is None:
                return items
        toks = _drop_struct_args(toks, takes, loader, skip_sig=it.name in takes)
        if toks is None:
            return items
        if pname is not None and any(t.kind == "id" and t.text == pname for t in toks[_sig_end(toks):]):
            return items                          # still used whole: cannot drop it
        out.append(Item(it.kind, it.name, toks, it.comment))
    return out


def _sig_end(toks: list[Tok]) -> int:
    code = _code_idx(toks)
    op = next(n for n, i in enumerate(code) if toks[i].text == "(")
    return code[_match(toks, code, op)] + 1


def _replace_fields(toks: list[Tok], pname: str, fields: dict[str, str]) -> list[Tok] | None:
    code = _code_idx(toks)
    out = list(toks)
    drop: set[int] = set()
    for n, i in enumerate(code[:-2]):
        if toks[i].text == pname and toks[code[n + 1]].text == ".":
            f = toks[code[n + 2]].text
            if f not in fields:
                return None
            out[i] = Tok("id", fields[f])
            drop.update((code[n + 1], code[n + 2]))
    return [t for k, t in enumerate(out) if k not in drop]


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
# 2. constant folding of conditions
# --------------------------------------------------------------------------------------------

_LIT_RE = re.compile(r"(0[xX][0-9a-fA-F]+|\d+)[uU]?|(\d+\.\d*|\.\d+|\d+)([eE][+-]?\d+)?[fF]?")


def constants(items: list[Item]) -> dict[str, str]:
    """``{name: literal}`` of the global scalar constants initialised with a literal."""
    env = {}
    for it in items:
        if it.kind != "variable":
            continue
        c = it.code()
        if c[:1] == ["const"] and len(c) >= 6 and c[3] == "=" and c[-1] == ";":
            val = "".join(c[4:-1]).strip("()")
            if _literal(val) is not None or val in ("true", "false"):
                env[c[2]] = val
    return env


def _literal(s: str):
    neg = s.startswith("-")
    body = s[1:] if neg else s
    m = _LIT_RE.fullmatch(body)
    if not m:
        return None
    if m.group(1):
        v = int(m.group(1), 0)
    else:
        v = float(body.rstrip("fF"))
    return -v if neg else v


_PY_OPS = {"&&": " and ", "||": " or ", "!": " not ", "==": "==", "!=": "!=", "<": "<", ">": ">",
           "<=": "<=", ">=": ">=", "(": "(", ")": ")", "+": "+", "-": "-", "*": "*"}


def _evaluate(words: list[str], env: dict[str, str]):
    """The value of a condition of literals, known constants and operators, else None."""
    py = []
    for w in words:
        if w in env:
            w = env[w]
        if w in ("true", "false"):
            py.append(" True " if w == "true" else " False ")
        elif w in _PY_OPS:
            py.append(_PY_OPS[w])
        else:
            v = _literal(w)
            if v is None:
                return None
            py.append(repr(v))
    try:
        return eval("".join(py), {"__builtins__": {}}, {})  # noqa: S307 - literals/operators only
    except Exception:
        return None


def fold(items: list[Item], env: dict[str, str]) -> list[Item]:
    """Remove the branches of ``if`` statements and ternaries whose condition is constant."""
    out = []
    for it in items:
        if it.kind != "function":
            out.append(it)
            continue
        toks = it.toks
        for _ in range(50):
            local = dict(env)
            local.update(_local_constants(toks, env))
            new = _fold_once(toks, local)
            if new is None:
                break
            toks = new
        out.append(Item(it.kind, it.name, toks, it.comment))
    return out


_ASSIGN = {"=", "+=", "-=", "*=", "/=", "%=", "<<=", ">>=", "&=", "|=", "^=", "++", "--"}


def _local_constants(toks: list[Tok], env: dict[str, str]) -> dict[str, str]:
    """Locals ``TYPE x = <constant>;`` never assigned, incremented or passed anywhere after."""
    code = _code_idx(toks)
    w = [toks[i].text for i in code]
    found = {}
    for n in range(1, len(w) - 3):
        if w[n - 1] in ("int", "uint", "float", "bool") and re.fullmatch(r"[A-Za-z_]\w*", w[n]) \
                and w[n + 1] == "=" and (n < 2 or w[n - 2] in (";", "{", "}")):
            end = w.index(";", n)
            v = _evaluate(w[n + 2:end], env)
            if v is None or w.count(w[n]) < 1:
                continue
            uses = [m for m in range(len(w)) if w[m] == w[n] and m != n]
            if any((m + 1 < len(w) and w[m + 1] in _ASSIGN) or w[m - 1] in ("++", "--")
                   or w[m - 1] in ("(", ",") and m + 1 < len(w) and w[m + 1] in (")", ",")
                   for m in uses):
                continue
            found[w[n]] = _glsl_literal(v, w[n - 1])
    return found


def _glsl_literal(v, typ: str) -> str:
    if typ == "bool" or isinstance(v, bool):
        return "true" if v else "false"
    if typ == "float":
        return repr(float(v))
    if typ == "uint":
        return f"{int(v)}u"
    return str(int(v))


def _fold_once(toks: list[Tok], env: dict[str, str]) -> list[Tok] | None:
    code = _code_idx(toks)
    w = [toks[i].text for i in code]
    for n, s in enumerate(w):
        if s == "if" and n + 1 < len(w) and w[n + 1] == "(":
            cl = _match(toks, code, n + 1)
            v = _evaluate(w[n + 2:cl], env)
            if v is None or w[cl + 1] != "{":
                continue
            then_end = _match(toks, code, cl + 1)
            keep: tuple[int, int] | None     # code positions of the kept part, brackets included
            end = then_end
            else_part = None
            if then_end + 1 < len(w) and w[then_end + 1] == "else":
                if w[then_end + 2] == "{":
                    e_end = _match(toks, code, then_end + 2)
                    else_part = (then_end + 2, e_end)
                    end = e_end
                elif w[then_end + 2] == "if":
                    e_end = _if_chain_end(toks, code, w, then_end + 2)
                    else_part = (then_end + 2, e_end)
                    end = e_end
                else:
                    continue
            keep = (cl + 1, then_end) if v else else_part
            return _splice(toks, code, n, end, keep)
        if s == "?":
            lo = _ternary_start(w, n)
            v = _evaluate(w[lo:n], env)
            if v is None:
                continue
            colon, hi = _ternary_parts(w, n)
            if colon is None:
                continue
            a = "".join(toks[code[m]].text + " " for m in range(n + 1, colon)).strip()
            b = "".join(toks[code[m]].text + " " for m in range(colon + 1, hi)).strip()
            pick = _respace(a if v else b)
            new = toks[:code[lo]] + [Tok("id", "(" + pick + ")")] + toks[code[hi - 1] + 1:]
            return new
    return None


def _respace(s: str) -> str:
    s = re.sub(r"\s*([(\[.])\s*", r"\1", s)
    s = re.sub(r"\s*([)\]])", r"\1", s)
    return s.replace(" ,", ",")


def _if_chain_end(toks, code, w, n) -> int:
    cl = _match(toks, code, n + 1)
    end = _match(toks, code, cl + 1)
    if end + 1 < len(w) and w[end + 1] == "else":
        if w[end + 2] == "{":
            return _match(toks, code, end + 2)
        return _if_chain_end(toks, code, w, end + 2)
    return end


def _ternary_start(w: list[str], q: int) -> int:
    depth = 0
    for m in range(q - 1, -1, -1):
        s = w[m]
        if s in ")]":
            depth += 1
        elif s in "([":
            if depth == 0:
                return m + 1
            depth -= 1
        elif depth == 0 and (s in (",", ";", "{", "}", "return", "?", ":") or s in _ASSIGN):
            return m + 1
    return 0


def _ternary_parts(w: list[str], q: int):
    depth, nest, colon = 0, 0, None
    for m in range(q + 1, len(w)):
        s = w[m]
        if s in "([":
            depth += 1
        elif s in ")]":
            if depth == 0:
                return (colon, m) if colon is not None else (None, None)
            depth -= 1
        elif depth == 0 and s == "?":
            nest += 1
        elif depth == 0 and s == ":":
            if nest:
                nest -= 1
            elif colon is None:
                colon = m
            else:
                return colon, m
        elif depth == 0 and s in (",", ";"):
            return (colon, m) if colon is not None else (None, None)
    return None, None


def _splice(toks, code, start, end, keep) -> list[Tok]:
    """Replace code positions start..end (a whole if statement) by the inside of ``keep``
    (a braced block, dedented one level; kept as a block when it declares a name) or nothing."""
    before = toks[:code[start]]
    after = toks[code[end] + 1:]
    if keep is None:
        # drop the statement and the indentation/newline in front of it
        while before and before[-1].kind == "ws" and "\n" not in before[-1].text:
            before.pop()
        if before and before[-1].kind == "ws":
            before[-1] = Tok("ws", before[-1].text.rsplit("\n", 1)[0])
            if not before[-1].text:
                before.pop()
        return before + after
    a, b = keep
    if toks[code[a]].text != "{":           # an else-if chain: keep it as it is
        return before + toks[code[a]:code[b] + 1] + after
    inner = toks[code[a] + 1:code[b]]
    words = [t.text for t in inner if t.kind not in ("ws", "comment")]
    declares = any(words[k] in ("int", "uint", "float", "bool", "vec2", "vec3", "vec4", "ivec4", "uvec4")
                   and k + 1 < len(words) and re.fullmatch(r"[A-Za-z_]\w*", words[k + 1])
                   for k in range(len(words)))
    if declares:
        return before + toks[code[a]:code[b] + 1] + after
    if start > 0 and toks[code[start - 1]].text == "else":   # `else if (true) {A}` -> `else {A}`
        return before + toks[code[a]:code[b] + 1] + after
    text = "".join(t.text for t in inner)
    text = re.sub(r"\n    ", "\n", text).strip()
    if not text:
        return _splice(toks, code, start, end, None)
    return before + tokenize(text) + after


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


# --------------------------------------------------------------------------------------------
# the whole middle end
# --------------------------------------------------------------------------------------------


def compile_glsl(text: str, entries, structs=(), fold_constants: bool = True) -> str:
    """Scalarise ``structs`` (``[(struct, loader)]``), fold, and keep what ``entries`` reach."""
    items = [it for it in parse(text) if it.kind != "other"]
    for struct, loader in structs:
        items = scalarise(items, struct, loader)
    items = reach(items, entries)
    if fold_constants:
        items = fold(items, constants(items))
        items = reach(items, entries)
    return unparse(items)
