"""The snippet compiler's folding passes (:mod:`cellgl.export.compiler` runs them).

After :func:`cellgl.export.reach.scalarise` the recipe's values are plain constants in the code.
These passes evaluate what they make constant, on tokens of the library's own GLSL:

* conditions of ``if`` statements and ternaries (the branches not taken go), locals initialised
  with a constant and never assigned again;
* ``for`` loops with constant bounds: no iteration (removed), one iteration (the body, with the
  counter replaced by its value), an early ``if (i >= M) break;`` (the bound becomes M);
* a loop whose body is one statement guarded by ``k >= A && k < B`` runs over [A, B) only;
* locals holding 0, 1, an integer or a boolean for good, and elements of local arrays of
  literals, are written into the code.

Dead code and identities are :mod:`cellgl.export.simplify`'s. Each pass leaves code it does not
understand as it is.
"""
from __future__ import annotations

import re

from cellgl.export.reach import Item, _code_idx, _match, _stmt_end
from cellgl.export.simplify import (
    _arithmetic,
    _balanced,
    _bare_block,
    _copy_local,
    _dead_local,
    _dead_store,
    _forward_literal,
    _last_store,
    _loop_variable,
    _merge_declaration,
    _split_declarators,
    _store_into_next,
)
from cellgl.export.translate.tokens import Tok, tokenize

__all__ = ["constants", "fold"]


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


_PY_OPS = {"&&": " and ", "||": " or ", "!": " not ", "==": "==", "!=": "!=", "<": "<", ">": ">", "/": "/",
           "<=": "<=", ">=": ">=", "(": "(", ")": ")", "+": "+", "-": "-", "*": "*"}


def _evaluate(words: list[str], env: dict[str, str]):
    """The value of a condition of literals, known constants and operators, else None
    (``x || true`` is true and ``x && false`` false whatever x is)."""
    v = _evaluate_all(words, env)
    if v is not None:
        return v
    for op, absorb in (("||", True), ("&&", False)):
        parts, depth, start = [], 0, 0
        for m, s in enumerate(words):
            depth += s == "("
            depth -= s == ")"
            if s == op and depth == 0:
                parts.append(words[start:m])
                start = m + 1
        if parts:
            parts.append(words[start:])
            vals = [_evaluate(p, env) for p in parts]
            if any(x is not None and bool(x) == absorb for x in vals):
                return absorb
    if words[:1] == ["("] and words[-1:] == [")"] and _balanced(words[1:-1]):
        return _evaluate(words[1:-1], env)
    return None


def _evaluate_all(words: list[str], env: dict[str, str]):
    if "/" in words and any(isinstance(_literal(env.get(x, x)), int) for x in words):
        return None                      # integer division: leave it to the compiler
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
    impure = {it.name for it in items if it.kind == "function"
              and re.search(r"\b(out|inout)\b", "".join(t.text for t in it.toks).split("{", 1)[0])}
    out = []
    key = (tuple(sorted(env.items())), tuple(sorted(impure)))
    for it in items:
        if it.kind != "function":
            out.append(it)
            continue
        text = "".join(t.text for t in it.toks)
        done = _FOLDED.get((text, key))
        if done is not None:                  # the same function under the same constants
            out.append(it if done == text else Item(it.kind, it.name, tokenize(done), it.comment))
            continue
        toks = _fold_function(it.toks, env, impure)
        if len(_FOLDED) > 4096:
            _FOLDED.clear()
        _FOLDED[(text, key)] = "".join(t.text for t in toks)
        out.append(Item(it.kind, it.name, toks, it.comment))
    return out


#: ``{(function text, (constants, impure functions)): folded text}``: the driver's rounds (and a
#: process's exports) fold most functions again unchanged
_FOLDED: dict = {}


def _fold_function(toks: list[Tok], env: dict[str, str], impure: set[str]) -> list[Tok]:
    """One function's tokens, its constant conditions, loops and locals folded (to a fixed point
    of the steps below, at most 200 of them)."""
    for _ in range(200):
        local = dict(env)
        local.update(_local_constants(toks, env))
        new = _fold_once(toks, local)
        if new is None:
            new = _fold_loop(toks, local)
        if new is None:
            new = _substitute_locals(toks, env)
        if new is None:
            new = _dead_local(toks, impure)
        if new is None:
            new = _split_declarators(toks)
        if new is None:
            new = _dead_store(toks, impure)
        if new is None:
            new = _last_store(toks, impure)
        if new is None:
            new = _loop_range(toks, local)
        if new is None:
            new = _bare_block(toks)
        if new is None:
            new = _copy_local(toks, impure)
        if new is None:
            new = _merge_declaration(toks)
        if new is None:
            new = _forward_literal(toks)
        if new is None:
            new = _loop_variable(toks)
        if new is None:
            new = _store_into_next(toks, impure)
        if new is None:
            break
        toks = new
    return _arithmetic(toks)


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
            uses = [m for m in range(len(w)) if w[m] == w[n] and m != n and w[m - 1] != "."]   # (not o.w)
            if any((m + 1 < len(w) and w[m + 1] in _ASSIGN) or w[m - 1] in ("++", "--")
                   or _argument(w, m) for m in uses):
                continue
            found[w[n]] = _glsl_literal(v, w[n - 1])
    return found


def _argument(w: list[str], m: int) -> bool:
    """Whether w[m] stands alone as an argument of a call (it may be an out parameter)."""
    if m + 1 >= len(w) or w[m + 1] not in (")", ","):
        return False
    depth = 0
    for k in range(m - 1, -1, -1):
        if w[k] in (")", "]"):
            depth += 1
        elif w[k] in ("(", "["):
            if depth == 0:
                return w[k] == "(" and k > 0 and re.fullmatch(r"[A-Za-z_]\w*", w[k - 1]) is not None \
                    and w[k - 1] not in ("if", "while", "for", "return")
            depth -= 1
        elif w[k] in (";", "{", "}"):
            return False
    return False


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
        if s == "=" and ";" in w[n:]:
            end = w.index(";", n)           # a stored condition of literals: b = 3.0e38 >= 3.0e38;
            v = _evaluate_all(w[n + 1:end], env)
            if isinstance(v, bool) and end - n > 2:
                return tokenize("".join(t.text for t in toks[:code[n] + 1]) + (" true" if v else " false")
                    + "".join(t.text for t in toks[code[end]:]))
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
            return tokenize("".join(t.text for t in toks[:code[lo]]) + "(" + pick + ")"
                            + "".join(t.text for t in toks[code[hi - 1] + 1:]))
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




def _substitute_locals(toks: list[Tok], env: dict[str, str]) -> list[Tok] | None:
    """Write locals that hold 0, 1, an integer or a boolean for good into the code, and the
    elements of local arrays initialised with literals and never assigned (``lin[0]`` -> 1.0)."""
    code = _code_idx(toks)
    w = [toks[i].text for i in code]
    local = {k: v for k, v in _local_constants(toks, env).items()
             if v in ("true", "false") or re.fullmatch(r"-?\d+u?", v) or _literal(v) in (0, 1)}
    arrays = {}
    for n in range(1, len(w) - 6):
        if w[n - 1] in ("float", "int", "uint") and w[n + 1] == "[" and w[n + 3:n + 7] == ["]", "=", w[n - 1], "["]:
            end = w.index(";", n)
            vals = [x for x in w[n + 10:end - 1] if x != ","]
            if w[n + 9] == "(" and all(_literal(x) is not None for x in vals) \
                    and not any(w[m] == w[n] and w[m + 1] == "[" and _assigned_index(w, m) for m in range(end, len(w))):
                arrays[w[n]] = vals
    out = list(toks)
    changed = False
    for m in range(1, len(w)):
        decl = w[m - 1] in ("int", "uint", "float", "bool") or (m >= 2 and w[m - 1] == "," and False)
        if w[m] in local and not decl and w[m - 1] != ".":
            v = local[w[m]]
            out[code[m]] = Tok("num", f"({v})" if v.startswith("-") else v)
            changed = True
        elif w[m] in arrays and m + 3 < len(w) and w[m + 1] == "[" and w[m + 3] == "]" and w[m + 2].isdigit() \
                and w[m - 1] not in ("float", "int", "uint"):
            k = int(w[m + 2])
            if k < len(arrays[w[m]]):
                out[code[m]] = Tok("num", arrays[w[m]][k])
                for j in (1, 2, 3):
                    out[code[m + j]] = Tok("ws", "")
                changed = True
    return tokenize("".join(t.text for t in out)) if changed else None


def _assigned_index(w: list[str], m: int) -> bool:
    depth = 0
    for k in range(m + 1, len(w)):
        depth += w[k] == "["
        depth -= w[k] == "]"
        if depth == 0:
            return k + 1 < len(w) and w[k + 1] in _ASSIGN
    return False


def _loop_range(toks: list[Tok], env: dict[str, str]) -> list[Tok] | None:
    """``for (int k = 0; k < 16; k++) { x += (k >= 1 && k < 9 && c) ? 1 : 0; }`` -> the loop
    over 1 <= k < 9 with ``c`` alone: a body that is one statement guarded by bounds on k."""
    code = _code_idx(toks)
    w = [toks[i].text for i in code]
    for n in range(len(w) - 12):
        if w[n:n + 3] != ["for", "(", "int"]:
            continue
        cl = _match(toks, code, n + 1)
        var = w[n + 3]
        head = w[n + 2:cl]
        if len(head) != 11 or head[2] != "=" or head[4] != ";" or head[5:7] != [var, "<"] \
                or head[8] != ";" or head[9:] != [var, "++"]:
            continue
        lo, hi = _literal(head[3]), _literal(head[7])
        if not isinstance(lo, int) or not isinstance(hi, int) or w[cl + 1] != "{":
            continue
        body_end = _match(toks, code, cl + 1)
        body = w[cl + 2:body_end]
        scan = len(body) - 3
        if body[:2] == ["if", "("] and "else" not in body:
            icl = _match(toks, code, cl + 3) - (cl + 2)       # the guard of an if that is the whole body
            if body[icl + 1] != "{" or _match(toks, code, cl + 2 + icl + 1) != body_end - 1:
                continue
            scan = icl - 3
        elif body.count(";") != 1:
            continue
        new_lo, new_hi, drop = lo, hi, []
        for k in range(scan):
            seg = body[k:k + 4]
            if seg[0] in ("(", "&&") and seg[1] == var and seg[2] in (">=", "<") and isinstance(
                    _literal(env.get(seg[3], seg[3])), int) and body[k + 4] == "&&":
                v = _literal(env.get(seg[3], seg[3]))
                if seg[2] == ">=":
                    new_lo = max(new_lo, v)
                else:
                    new_hi = min(new_hi, v)
                drop.append(cl + 2 + k + 1)
        if not drop:
            continue
        out = list(toks)
        kill = set()
        for m in drop:                        # "k >= 1 &&" (the bound and its &&)
            kill.update(range(code[m], code[m + 3] + 1))
            j = code[m + 3] + 1
            while j < len(toks) and toks[j].kind == "ws":
                kill.add(j)
                j += 1
        out[code[n + 5]] = Tok("num", str(new_lo))
        out[code[n + 9]] = Tok("num", str(max(new_lo, new_hi)))
        return tokenize("".join(t.text for i, t in enumerate(out) if i not in kill))
    return None


# --------------------------------------------------------------------------------------------
# loops with constant bounds
# --------------------------------------------------------------------------------------------


def _fold_loop(toks: list[Tok], env: dict[str, str]) -> list[Tok] | None:
    code = _code_idx(toks)
    w = [toks[i].text for i in code]
    for n, s in enumerate(w):
        if s != "for" or w[n + 1] != "(":
            continue
        cl = _match(toks, code, n + 1)
        head = w[n + 2:cl]
        if head.count(";") != 2 or head[:1] != ["int"] or len(head) < 4 or head[2] != "=":
            continue
        s1 = head.index(";")
        s2 = head.index(";", s1 + 1)
        var = head[1]
        a = _evaluate(head[3:s1], env)
        cond, step = head[s1 + 1:s2], head[s2 + 1:]
        if a is None or len(cond) < 3 or cond[0] != var or step not in ([var, "++"], [var, "--"]):
            continue
        b = _evaluate(cond[2:], env)
        if b is None or not isinstance(a, int) or not isinstance(b, int):
            continue
        up = step[1] == "++"
        body_end = _stmt_end(toks, code, w, cl + 1)
        # an early exit `if (i >= M) { break; }` first in the body bounds the loop
        if up and cond[1] in ("<", "<=") and w[cl + 1] == "{" and w[cl + 2:cl + 6] == ["if", "(", var, ">="]:
            icl = _match(toks, code, cl + 3)
            m = _evaluate(w[cl + 6:icl], env)
            if isinstance(m, int) and w[icl + 1:icl + 5] == ["{", "break", ";", "}"]:
                b = min(b, m) if cond[1] == "<" else min(b, m - 1)
        count = {"<": b - a, "<=": b - a + 1}.get(cond[1]) if up else {">": a - b, ">=": a - b + 1}.get(cond[1])
        if count is None:
            continue
        if count <= 0:
            return _splice(toks, code, n, body_end, None)
        if count != 1:
            continue
        sub = list(toks)
        for m in range(cl + 1, body_end + 1):
            if w[m] == var and w[m - 1] != ".":
                sub[code[m]] = Tok("num", str(a))
        if w[cl + 1] == "{":
            return tokenize("".join(t.text for t in _splice(sub, code, n, body_end, (cl + 1, body_end))))
        before = "".join(t.text for t in sub[:code[n]])
        stmt = "".join(t.text for t in sub[code[cl + 1]:code[body_end] + 1])
        return tokenize(before + stmt + "".join(t.text for t in sub[code[body_end] + 1:]))
    return None


# --------------------------------------------------------------------------------------------
# one-line functions
# --------------------------------------------------------------------------------------------
