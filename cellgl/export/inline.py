"""Inlining of the functions a snippet calls once (:mod:`cellgl.export.compiler`'s pass 4).

A function called from one statement -- ``f(a, b);``, ``T v = f(a, b);``, ``v = f(a, b);`` or
``return f(a, b);`` -- whose body returns only at its end, becomes that body in place of the
call:

- an ``out`` / ``inout`` parameter becomes its argument (a variable, or a field or element of
  one, that no other argument names: GLSL copies in and out, the inlined code writes in place);
- an ``in`` parameter the body never writes becomes its argument where the argument is a name,
  a literal or a field (a local copy otherwise); one the body writes gets a local copy, except
  in ``v = f(v, ...)`` returning that parameter, where the body works on ``v`` itself;
- the body's locals are renamed where the caller uses the name;
- ``T v = f(...)`` returning a local of the body declares ``v`` where the body declared it.

The values do not change: the statements run in the same order on the same values.
"""
from __future__ import annotations

import re
import textwrap

from cellgl.export.reach import Item, _call_args, _code_idx, _match, _split_args, first_sentence
from cellgl.export.translate.tokens import GLSL_TYPES, tokenize

__all__ = ["inline_once"]

_STARTS = (";", "{", "}")
#: a body of this many lines keeps its function's comment where it is inlined
_COMMENTED = 20
#: functions that stay functions where called once: the hash, the first thing a reader looks for
KEEP = ("cellgl_hash_u32",)
_ASSIGN = r"(?:[-+*/%&|^]|<<|>>)?=(?!=)|\+\+|--"


def _text(toks) -> str:
    return "".join(t.text for t in toks)


def _is_type(word: str) -> bool:
    return word in GLSL_TYPES or word.startswith("Cellgl")


def _calls(items: list[Item]) -> dict[str, list]:
    """{function name: [(item, code position) of every call]}."""
    names = {it.name for it in items if it.kind == "function"}
    out: dict[str, list] = {}
    for x in items:
        if x.kind != "function":
            continue
        toks, code = x.toks, _code_idx(x.toks)
        w = [toks[i].text for i in code]
        first = w.index("(") - 1 if "(" in w else -1
        for m in range(len(w) - 1):
            if w[m] in names and w[m + 1] == "(" and (m == 0 or w[m - 1] != ".") and m != first:
                out.setdefault(w[m], []).append((x, m))
    return out


def inline_once(items: list[Item], keep) -> list[Item]:
    """Inline every function (not in ``keep``) called exactly once, where that is safe."""
    count: dict[str, int] = {}
    for it in items:
        count[it.name] = count.get(it.name, 0) + 1
    impure = _out_positions(items)
    calls = _calls(items)
    for f in items:
        if f.kind != "function" or f.name in keep or f.name in KEEP or count[f.name] != 1:
            continue
        sites = calls.get(f.name, [])
        if len(sites) != 1 or sites[0][0] is f:
            continue
        x, m = sites[0]
        toks = _inline_call(f, x, m, impure)
        if toks is None:
            continue
        new = [Item(x.kind, x.name, toks, x.comment) if it is x else it for it in items if it is not f]
        return inline_once(new, keep)
    return items


def _written(body: str, name: str, outs: dict[str, set[int]]) -> bool:
    """Whether ``body`` assigns ``name`` (or a field or element of it) or passes it to an ``out``
    / ``inout`` parameter (``outs``: function -> positions of those)."""
    if re.search(rf"(\+\+|--)\s*\b{name}\b|(?<![\w.]){name}\s*(\.\s*\w+|\[[^\]]*\])*\s*({_ASSIGN})", body):
        return True
    toks = tokenize(body)
    code = _code_idx(toks)
    w = [toks[i].text for i in code]
    return any(k in outs[fn] and name in w[a:b] for fn, k, a, b in _call_args(toks, code, outs))


def _out_positions(items: list[Item]) -> dict[str, set[int]]:
    out = {}
    for it in items:
        if it.kind != "function":
            continue
        toks, code = it.toks, _code_idx(it.toks)
        w = [toks[i].text for i in code]
        op = w.index("(")
        pos = {k for k, (a, b) in enumerate(_split_args(toks, code, op, _match(toks, code, op)))
               if w[a] in ("out", "inout")}
        if pos:
            out[it.name] = pos
    return out


def _loop_only(toks, name: str, m: int) -> bool:
    """Whether every use of ``name`` in the function ``toks`` is inside a ``for (T name ...)``
    loop that does not contain code position ``m``."""
    from cellgl.export.reach import _stmt_end

    code = _code_idx(toks)
    w = [toks[i].text for i in code]
    spans = []
    for n in range(len(w) - 3):
        if w[n] == "for" and w[n + 1] == "(" and w[n + 3] == name:
            spans.append((n, _stmt_end(toks, code, w, n)))
    if any(a <= m <= b for a, b in spans):
        return False
    return all(any(a <= k <= b for a, b in spans) for k in range(len(w)) if w[k] == name)


def _inline_call(f: Item, x: Item, m: int, impure: set[str]):
    ftoks, fcode = f.toks, _code_idx(f.toks)
    fw = [ftoks[i].text for i in fcode]
    op = fw.index("(")
    cl = _match(ftoks, fcode, op)
    if fw[cl + 1] != "{" or "discard" in fw or op != 2:
        return None
    ret_type = fw[0]
    params = [fw[a:b] for a, b in _split_args(ftoks, fcode, op, cl)]
    if params == [["void"]]:
        params = []
    if any(len(p) < 2 or p[-1] == "]" or not re.fullmatch(r"[A-Za-z_]\w*", p[-1]) for p in params):
        return None
    body_toks = ftoks[fcode[cl + 1] + 1:fcode[-1]]
    bcode = _code_idx(body_toks)
    bw = [body_toks[i].text for i in bcode]
    # one return, the last statement (a void function: none)
    ret_expr = None
    nret = bw.count("return")
    if ret_type == "void":
        if bw[-2:] == ["return", ";"]:
            body_toks, bcode, bw = body_toks[:bcode[-2]], bcode[:-2], bw[:-2]
            nret -= 1
        if nret:
            return None
    else:
        if nret != 1 or ";" not in bw or bw[-1] != ";":
            return None
        k = len(bw) - 2
        depth = 0
        while k >= 0 and not (bw[k] == "return" and depth == 0):
            depth += bw[k] in ")]"
            depth -= bw[k] in "(["
            k -= 1
        if k < 0 or (k > 0 and bw[k - 1] not in _STARTS) or _block_depth(bw, k) != 0:
            return None
        ret_expr = _text(body_toks[bcode[k] + 1:bcode[-1]]).strip()
        body_toks = body_toks[:bcode[k]]
    # the call statement in the caller
    toks, code = x.toks, _code_idx(x.toks)
    w = [toks[i].text for i in code]
    ccl = _match(toks, code, m + 1)
    if ccl + 1 >= len(w) or w[ccl + 1] != ";":
        return None
    form, target, typ = None, None, None
    if w[m - 1] in _STARTS:
        form, start = "stmt", m
    elif w[m - 1] == "return" and w[m - 2] in _STARTS:
        form, start = "return", m - 1
    elif w[m - 1] == "=" and re.fullmatch(r"[A-Za-z_]\w*", w[m - 2]):
        if _is_type(w[m - 3]) and w[m - 4] in _STARTS:
            form, start, target, typ = "decl", m - 3, w[m - 2], w[m - 3]
        elif w[m - 3] in _STARTS:
            form, start, target = "assign", m - 2, w[m - 2]
    if form is None or (form != "stmt" and ret_expr is None):
        return None
    if form == "stmt" and ret_expr and re.search(r"\b\w+\s*\(", ret_expr):
        return None
    args = [_text(toks[code[a]:code[b - 1] + 1]).strip() for a, b in _split_args(toks, code, m + 1, ccl)]
    if len(args) != len(params):
        return None
    caller_names = {t.text for t in toks if t.kind == "id"}
    body = _text(body_toks)
    body_ids = {t.text for t in body_toks if t.kind == "id"}
    # the body's own declarations (locals, loop variables)
    declared = set()
    for k in range(1, len(bw) - 1):
        if _is_type(bw[k - 1]) and re.fullmatch(r"[A-Za-z_]\w*", bw[k]) and bw[k + 1] in ("=", ";", "[", ",") \
                and (k < 2 or bw[k - 2] in _STARTS + ("(", "const")):
            declared.add(bw[k])
    subst: dict[str, str] = {}
    prelude: list[str] = []
    out_bases = set()
    for p, a in zip(params, args):
        if p[0] in ("out", "inout"):
            mm = re.fullmatch(r"([A-Za-z_]\w*)(?:\s*\.\s*\w+|\s*\[\s*\w+\s*\])*", a)
            if not mm:
                return None
            out_bases.add(mm.group(1))
    for p, a in zip(params, args):
        qual = p[0] if p[0] in ("in", "out", "inout") else "in"
        pname, ptype = p[-1], p[-2]
        if qual != "in":
            base = re.match(r"\w+", a).group()
            if sum(re.search(rf"\b{base}\b", b2) is not None for b2 in args) != 1:
                return None                  # the same variable in two arguments
            subst[pname] = a
            continue
        arg_ids = set(re.findall(r"\b[A-Za-z_]\w*\b", a))
        if _written(body, pname, impure):
            if form == "assign" and a == target and ret_expr == pname and target not in out_bases \
                    and sum(re.search(rf"\b{target}\b", b2) is not None for b2 in args) == 1:
                subst[pname] = target
                ret_expr = target
                continue
            prelude.append((ptype, pname, a))
            declared.add(pname)
            continue
        simple = re.fullmatch(r"[A-Za-z_]\w*(\s*\.\s*[A-Za-z_]\w*)*|-?\d+(\.\d*)?([eE][-+]?\d+)?u?", a)
        uses = len(re.findall(rf"(?<![\w.]){pname}\b", body + " " + (ret_expr or "")))
        if (simple or (uses <= 1 and not re.search(rf"(?<![\w.]){pname}\s*[.\[]", body + (ret_expr or "")))) \
                and not (arg_ids & out_bases):
            subst[pname] = a if simple else f"({a})"
        else:
            prelude.append((ptype, pname, a))
            declared.add(pname)
    rename: dict[str, str] = {}
    if form == "decl" and ret_expr in declared and _decl_type(bw, ret_expr, prelude) == typ:
        rename[ret_expr] = target
        ret_expr = None
        caller_names.discard(target)
    taken = caller_names | body_ids | set(subst.values())
    for d in sorted(declared):
        if d in rename:
            continue
        if d in caller_names and not (_loop_var(bw, d) and _loop_only(toks, d, m)):
            k = 2
            while f"{d}{k}" in taken:
                k += 1
            rename[d] = f"{d}{k}"
            taken.add(rename[d])
    if form == "decl" and target in (body_ids - set(rename)) and target not in subst.values():
        return None

    def sub(text: str) -> str:
        ts = tokenize(text)
        outs = []
        prev = ""
        for t in ts:
            if t.kind == "id" and prev != ".":
                outs.append(rename.get(t.text) or subst.get(t.text, t.text))
            else:
                outs.append(t.text)
            if t.kind not in ("ws", "comment"):
                prev = t.text
        return "".join(outs)

    lines = [f"{t} {rename.get(p, p)} = {a};" for t, p, a in prelude]
    if f.comment and body.count("\n") >= _COMMENTED:
        # a long body keeps the first sentence of its function's comment
        lines[:0] = ["// " + ln for ln in textwrap.wrap(first_sentence(_text(f.comment), 116), 113)]
    for ln in sub(body).split("\n"):
        if not ln.strip() or ln.strip().startswith("//"):
            continue
        lines.append(ln[4:] if ln.startswith("    ") else ln.lstrip())
    if ret_expr is not None:
        r = sub(ret_expr)
        if form == "decl":
            lines.append(f"{typ} {target} = {r};")
        elif form == "assign" and r != target:
            lines.append(f"{target} = {r};")
        elif form == "return":
            lines.append(f"return {r};")
    before = _text(toks[:code[start]])
    indent = before.rsplit("\n", 1)[-1] if "\n" in before else ""
    if indent.strip():
        return None
    after = _text(toks[code[ccl + 1] + 1:])
    if not lines:
        before = before[:len(before) - len(indent)].rstrip(" \t")
        if before.endswith("\n"):
            before = before[:-1]
        return tokenize(before + after)
    return tokenize(before + ("\n" + indent).join(lines) + after)


def _block_depth(w: list[str], k: int) -> int:
    return sum((x == "{") - (x == "}") for x in w[:k])


def _loop_var(bw: list[str], name: str) -> bool:
    """Whether ``name`` is declared only as a ``for`` loop's variable in the body ``bw``."""
    decls = [k for k in range(2, len(bw)) if bw[k] == name and _is_type(bw[k - 1])]
    return bool(decls) and all(bw[k - 2] == "(" and k > 2 and bw[k - 3] == "for" for k in decls)


def _decl_type(bw: list[str], name: str, prelude: list) -> str | None:
    for t, p, _ in prelude:
        if p == name:
            return t
    for k in range(1, len(bw) - 1):
        if bw[k] == name and _is_type(bw[k - 1]) and (k < 2 or bw[k - 2] in _STARTS) and _block_depth(bw, k) == 0:
            return bw[k - 1]
    return None
