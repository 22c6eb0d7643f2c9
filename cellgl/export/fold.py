"""The snippet compiler's folding passes, and :func:`compile_glsl`, the whole middle end.

After :func:`cellgl.export.reach.scalarise` the recipe's values are plain constants in the code.
These passes evaluate what they make constant, on tokens of the library's own GLSL:

* conditions of ``if`` statements and ternaries (the branches not taken go), locals initialised
  with a constant and never assigned again;
* ``for`` loops with constant bounds: no iteration (removed), one iteration (the body, with the
  counter replaced by its value), an early ``if (i >= M) break;`` (the bound becomes M);
* integer index arithmetic (``r.F[1 - 1]`` -> ``r.F[0]``), terms ``x += 0.0 * ...`` and
  ``x *= 1.0``, ``mix(a, b, 0.0)`` / ``mix(a, b, 1.0)``;
* small functions whose body is one ``return`` (``cellgl_wrap(c, period)`` without a period
  returns ``c``) are inlined where they are called.

Scalar constants whose value is 0, 1 or an integer are written into the code (they decide
branches and loop counts); other constants keep their names. Each pass leaves code it does not
understand as it is.
"""
from __future__ import annotations

import re

from cellgl.export.reach import (
    Item,
    _code_idx,
    _match,
    _split_args,
    parse,
    reach,
    scalarise,
    tidy_comments,
    unparse,
)
from cellgl.export.translate.tokens import Tok, tokenize

__all__ = ["compile_glsl", "constants", "fold"]


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


def _balanced(words: list[str]) -> bool:
    depth = 0
    for s in words:
        depth += s == "("
        depth -= s == ")"
        if depth < 0:
            return False
    return depth == 0


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
    for it in items:
        if it.kind != "function":
            out.append(it)
            continue
        toks = it.toks
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
                break
            toks = new
        toks = _arithmetic(toks)
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


def _top_comma(words: list[str]) -> bool:
    depth = 0
    for x in words:
        depth += x in ("(", "[")
        depth -= x in (")", "]")
        if x == "," and depth == 0:
            return True
    return False


def _assigned_index(w: list[str], m: int) -> bool:
    depth = 0
    for k in range(m + 1, len(w)):
        depth += w[k] == "["
        depth -= w[k] == "]"
        if depth == 0:
            return k + 1 < len(w) and w[k + 1] in _ASSIGN
    return False


def _dead_local(toks: list[Tok], impure: set[str]) -> list[Tok] | None:
    """Remove one ``TYPE x = expr;`` (or ``TYPE x;``) whose x is never used, expr calling no
    function with out parameters."""
    code = _code_idx(toks)
    w = [toks[i].text for i in code]
    types = {"int", "uint", "float", "bool", "vec2", "vec3", "vec4", "ivec4", "uvec4"}
    for n in range(2, len(w) - 2):
        if w[n - 1] in types and w[n - 2] in (";", "{", "}") and re.fullmatch(r"[A-Za-z_]\w*", w[n]) \
                and w[n + 1] in ("=", ";", "["):
            end = w.index(";", n)
            if w.count(w[n]) != 1 or _top_comma(w[n:end]) or any(x in impure for x in w[n:end]):
                continue
            start = code[n - 1]
            while start > 0 and toks[start - 1].kind == "ws" and "\n" not in toks[start - 1].text:
                start -= 1
            if start > 0 and toks[start - 1].kind == "ws":
                start -= 1
            return toks[:start] + toks[code[end] + 1:]
    return None


_DECL_TYPES = {"int", "uint", "float", "bool", "vec2", "vec3", "vec4", "ivec2", "ivec3", "ivec4", "uvec4"}


def _split_declarators(toks: list[Tok]) -> list[Tok] | None:
    """``vec4 a = x, b;`` -> ``vec4 a = x;`` and ``vec4 b;`` on their own lines."""
    code = _code_idx(toks)
    w = [toks[i].text for i in code]
    for n in range(1, len(w) - 2):
        if w[n] in _DECL_TYPES and w[n - 1] in (";", "{", "}") and re.fullmatch(r"[A-Za-z_]\w*", w[n + 1]) \
                and w[n + 2] in ("=", ","):
            end = _stmt_end(toks, code, w, n)
            parts, depth, start = [], 0, n + 1
            for m in range(n + 1, end):
                depth += w[m] in ("(", "[")
                depth -= w[m] in (")", "]")
                if w[m] == "," and depth == 0:
                    parts.append((start, m))
                    start = m + 1
            if not parts:
                continue
            parts.append((start, end))
            ind = toks[code[n] - 1].text.rsplit("\n", 1)[-1] if toks[code[n] - 1].kind == "ws" else ""
            text = f"\n{ind}".join(w[n] + " " + "".join(toks[i].text for i in range(code[a], code[b - 1] + 1)).strip()
                                   + ";" for a, b in parts)
            return tokenize("".join(t.text for t in toks[:code[n]]) + text
                            + "".join(t.text for t in toks[code[end] + 1:]))
    return None


_STORE = {"=", "+=", "-=", "*=", "/="}


def _dead_store(toks: list[Tok], impure: set[str]) -> list[Tok] | None:
    """Remove a local that is only ever written (``x = ...;``, ``x.y += ...;``, ``x[0] = ...;``),
    with its declaration and those statements (their right-hand sides call nothing with out
    parameters)."""
    code = _code_idx(toks)
    w = [toks[i].text for i in code]
    for n in range(2, len(w) - 2):
        if not (w[n - 1] in _DECL_TYPES | {"CellglTexel"} and w[n - 2] in (";", "{", "}")
                and re.fullmatch(r"[A-Za-z_]\w*", w[n]) and w[n + 1] in ("=", ";", "[")):
            continue
        name = w[n]
        decl_end = _stmt_end(toks, code, w, n - 1)
        if any(x in impure for x in w[n:decl_end]):
            continue
        spans = [(n - 1, decl_end)]
        ok = True
        m = decl_end + 1
        while m < len(w):
            if w[m] != name or w[m - 1] == ".":
                m += 1
                continue
            if w[m - 1] not in (";", "{", "}"):
                ok = False
                break
            k = m + 1
            while k < len(w) and (w[k] == "." or w[k - 1] == "." or w[k] == "["):
                k = _match(toks, code, k) + 1 if w[k] == "[" else k + 1
            end = _stmt_end(toks, code, w, m)
            if k >= len(w) or w[k] not in _STORE or any(x in impure for x in w[m:end]):
                ok = False
                break
            spans.append((m, end))
            m = end + 1
        if not ok:
            continue
        out = list(toks)
        kill = set()
        for a, b in spans:
            start = code[a]
            while start > 0 and toks[start - 1].kind == "ws" and "\n" not in toks[start - 1].text:
                start -= 1
            if start > 0 and toks[start - 1].kind == "ws":
                start -= 1
            kill.update(range(start, code[b] + 1))
        return [t for i, t in enumerate(out) if i not in kill]
    return None


def _loop_bodies(toks, code, w) -> set[int]:
    """Code positions of the '{' that open loop bodies."""
    out = set()
    for n, x in enumerate(w):
        if x in ("for", "while") and n + 1 < len(w) and w[n + 1] == "(":
            cl = _match(toks, code, n + 1)
            if cl + 1 < len(w) and w[cl + 1] == "{":
                out.add(cl + 1)
            elif cl + 1 < len(w) and w[cl + 1] in ("for",):
                out |= {cl + 1}
    return out


def _in_loop(toks, code, w, m, loops) -> bool:
    depth = 0
    for k in range(m - 1, -1, -1):
        if w[k] == "}":
            depth += 1
        elif w[k] == "{":
            if depth == 0:
                if k in loops:
                    return True
            else:
                depth -= 1
        elif w[k] == "for" and depth == 0:
            return True                       # the body of a for without braces
    return False


def _last_store(toks: list[Tok], impure: set[str]) -> list[Tok] | None:
    """Remove a store ``x op= ...;`` to a local after which x is never read (outside loops)."""
    code = _code_idx(toks)
    w = [toks[i].text for i in code]
    loops = None
    op = w.index("(") if "(" in w else 0
    cl = _match(toks, code, op) if op else 0
    params = set(w[op:cl])
    for m in range(cl + 1, len(w) - 2):
        if w[m - 1] in (";", "{", "}") and re.fullmatch(r"[A-Za-z_]\w*", w[m]) and w[m + 1] in _STORE \
                and w[m] not in params and w[m + 1] != "=":
            end = _stmt_end(toks, code, w, m)
            if w[m] in w[end + 1:] or any(x in impure for x in w[m:end]):
                continue
            if loops is None:
                loops = _loop_bodies(toks, code, w)
            if _in_loop(toks, code, w, m, loops):
                continue
            start = code[m]
            while start > 0 and toks[start - 1].kind == "ws" and "\n" not in toks[start - 1].text:
                start -= 1
            if start > 0 and toks[start - 1].kind == "ws":
                start -= 1
            return toks[:start] + toks[code[end] + 1:]
    return None


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
        if body.count(";") != 1:
            continue
        new_lo, new_hi, drop = lo, hi, []
        for k in range(len(body) - 3):
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


def _array_elements(items: list[Item]) -> list[Item]:
    """``cellgl_origin_frac[0]`` -> ``vec4(0.0, 0.0, 0.0, 0.0)``: elements of global constant
    arrays read at a literal index, where the element is short."""
    arrays = {}
    for it in items:
        c = it.code()
        if it.kind == "variable" and c[:1] == ["const"] and len(c) > 8 and c[3] == "[" and c[6] == "=":
            toks, code = it.toks, _code_idx(it.toks)
            op = c.index("(", 7)
            cl = _match(toks, code, op)
            arrays[c[2]] = ["".join(t.text for t in toks[code[a]:code[b - 1] + 1]).strip()
                            for a, b in _split_args(toks, code, op, cl)]
    if not arrays:
        return items
    pat = re.compile(r"\b(" + "|".join(map(re.escape, arrays)) + r")\[(\d+)\]")

    def elem(m):
        vals = arrays[m.group(1)]
        k = int(m.group(2))
        return vals[k] if k < len(vals) and len(vals[k]) <= 40 else m.group()

    out = []
    for it in items:
        if it.kind == "function":
            it = Item(it.kind, it.name, tokenize(pat.sub(elem, "".join(t.text for t in it.toks))), it.comment)
        out.append(it)
    return out


# --------------------------------------------------------------------------------------------
# loops with constant bounds
# --------------------------------------------------------------------------------------------


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
# arithmetic identities
# --------------------------------------------------------------------------------------------

_ZERO = r"(?:0\.0|0\.|0)"
_ONE = r"(?:1\.0|1\.|1)"


def _arithmetic(toks: list[Tok]) -> list[Tok]:
    text = "".join(t.text for t in toks)
    for _ in range(10):
        old = text
        # integer arithmetic in an index
        text = re.sub(r"\[\s*(\d+(?:\s*[-+*]\s*\d+)+)\s*\]",
                      lambda m: f"[{eval(m.group(1), {'__builtins__': {}}, {})}]", text)
        # statements that add zero or multiply by one
        text = re.sub(rf"\n[ \t]*[\w.\[\]]+\s*[-+]=\s*{_ZERO}\s*\*([^;{{}}]*);[^\n]*(?=\n)",
                      lambda m: m.group() if _top_sum(m.group(1)) else "", text)
        text = re.sub(rf"\n[ \t]*[\w.\[\]]+\s*[-+]=\s*\(?{_ZERO}\)?\s*;[^\n]*(?=\n)", "", text)
        text = re.sub(rf"\n[ \t]*[\w.\[\]]+\s*[*/]=\s*\(?{_ONE}\)?\s*;[^\n]*(?=\n)", "", text)
        text = _mix(text)
        text = re.sub(r"\n[ \t]*\{\s*\}[ \t]*(?=\n)", "", text)          # an empty block
        text = re.sub(r"\n[ \t]*if \((?:[^;{}()]|\([^;{}()]*\))*\) \{\s*\}[ \t]*(?=\n)", "", text)
        # x * 1.0, x / 1.0, x - 0.0, x + 0.0 (floats: the same value; the snippet compiles as GLSL
        # ES, which has no implicit int -> float, so x is a float)
        text = re.sub(r"(?<=[\w)\]])\s*[*/]\s*1\.0(?![\w.(\[])", "", text)
        text = re.sub(r"(?<=[(=,+\-])(\s*)1\.0\s*\*\s*(?=[\w(])", r"\1", text)
        text = re.sub(r"(?<=[\w)\]])\s*[-+]\s*0\.0(?=\s*[),;+\-]|\s*$)", "", text)
        if text == old:
            break
    return tokenize(text)


def _top_sum(expr: str) -> bool:
    """Whether ``expr`` has a + or - outside parentheses (then 0.0 * expr is not all of it)."""
    depth = 0
    for ch in re.sub(r"[eE][-+]\d", "", expr):
        depth += ch in "(["
        depth -= ch in ")]"
        if ch in "+-" and depth == 0:
            return True
    return False


def _mix(text: str) -> str:
    """``mix(a, b, 0.0)`` -> ``(a)``, ``mix(a, b, 1.0)`` -> ``(b)``."""
    toks = tokenize(text)
    code = _code_idx(toks)
    w = [toks[i].text for i in code]
    for n in range(len(w) - 1):
        if w[n] == "mix" and w[n + 1] == "(" and (n == 0 or w[n - 1] != "."):
            cl = _match(toks, code, n + 1)
            args = _split_args(toks, code, n + 1, cl)
            if len(args) != 3:
                continue
            t = "".join(w[args[2][0]:args[2][1]])
            pick = 0 if re.fullmatch(_ZERO, t) else 1 if re.fullmatch(_ONE, t) else None
            if pick is None:
                continue
            a, b = args[pick]
            inner = "".join(t2.text for t2 in toks[code[a]:code[b - 1] + 1])
            return _mix("".join(x.text for x in toks[:code[n]]) + "(" + inner.strip() + ")"
                        + "".join(x.text for x in toks[code[cl] + 1:]))
    return text


# --------------------------------------------------------------------------------------------
# one-line functions
# --------------------------------------------------------------------------------------------


def _one_liners(items: list[Item], keep) -> dict[str, tuple[list[str], str]]:
    """``{name: (parameter names, returned expression)}`` of the functions whose body is one short
    ``return`` using each parameter at most once."""
    out = {}
    for it in items:
        if it.kind != "function" or it.name in keep:
            continue
        toks, code = it.toks, _code_idx(it.toks)
        w = [toks[i].text for i in code]
        op = w.index("(")
        cl = _match(toks, code, op)
        if w[cl + 1:cl + 3] != ["{", "return"] or w[-2:] != [";", "}"] or w.count(";") != 1:
            continue
        params = [w[b - 1] for a, b in _split_args(toks, code, op, cl)]
        expr = "".join(t.text for t in toks[code[cl + 3]:code[len(w) - 2]]).strip()
        ids = re.findall(r"\b[A-Za-z_]\w*\b", expr)
        if len(expr) > 72 or any(ids.count(p) > 1 for p in params) or it.name in ids:
            continue
        out[it.name] = (params, expr)
    return out


def _inline(items: list[Item], keep) -> list[Item]:
    small = _one_liners(items, keep)
    if not small:
        return items
    out = []
    for it in items:
        toks = it.toks
        if it.kind == "function":
            for _ in range(50):
                new = _inline_once(toks, small, it.name)
                if new is None:
                    break
                toks = new
        out.append(Item(it.kind, it.name, toks, it.comment))
    return out


def _simple(arg: str) -> bool:
    return re.fullmatch(r"[\w.]+(\[[^\[\]]*\])*[\w.]*|\w+\([^()]*\)", arg.strip()) is not None


def _inline_once(toks: list[Tok], small: dict, own: str) -> list[Tok] | None:
    code = _code_idx(toks)
    w = [toks[i].text for i in code]
    first_call = w.index("(") - 1 if "(" in w else -1
    for n in range(len(w) - 1):
        if w[n] in small and w[n + 1] == "(" and n != first_call and (n == 0 or w[n - 1] != "."):
            params, expr = small[w[n]]
            cl = _match(toks, code, n + 1)
            args = ["".join(t.text for t in toks[code[a]:code[b - 1] + 1]).strip()
                    for a, b in _split_args(toks, code, n + 1, cl)]
            if len(args) != len(params):
                return None
            env = {p: (a if _simple(a) else f"({a})") for p, a in zip(params, args)}
            body = re.sub(r"\b[A-Za-z_]\w*\b", lambda m: env.get(m.group(), m.group()), expr)
            if not _simple(body):
                body = f"({body})"
            return tokenize("".join(t.text for t in toks[:code[n]]) + body
                            + "".join(t.text for t in toks[code[cl] + 1:]))
    return None


# --------------------------------------------------------------------------------------------
# the whole middle end
# --------------------------------------------------------------------------------------------


def _inline_constants(items: list[Item], env: dict[str, str]) -> list[Item]:
    """Write the constants that decide code shape (0, 1, integers, booleans) into the code."""
    pick = {k: v for k, v in env.items()
            if v in ("true", "false") or re.fullmatch(r"-?\d+u?", v) or _literal(v) in (0, 1)}
    out = []
    for it in items:
        if it.kind != "function":
            out.append(it)
            continue
        text = "".join((f"({pick[t.text]})" if pick[t.text].startswith("-") else pick[t.text])
                       if t.kind == "id" and t.text in pick else t.text for t in it.toks)
        out.append(Item(it.kind, it.name, tokenize(text), it.comment))
    return out


def compile_glsl(text: str, entries, structs=(), fold_constants: bool = True) -> str:
    """The middle end: keep what ``entries`` reach, scalarise ``structs`` (``[(struct,
    loader)]``, see :func:`cellgl.export.reach.scalarise`), fold constants, inline one-liners,
    repeat until nothing changes."""
    items = reach([it for it in parse(text) if it.kind != "other"], entries)
    for _ in range(8):
        before = unparse(items)
        for struct, loader in structs:
            items = scalarise(items, struct, loader)
        if fold_constants:
            env = constants(items)
            items = _inline_constants(items, env)
            items = _array_elements(items)
            items = fold(items, env)
        items = _inline(items, set(entries))
        items = _drop_unused_params(items, set(entries))
        items = _drop_unused_outs(items, set(entries))
        items = _dead_fields(items)
        items = reach(items, entries)
        if unparse(items) == before:
            break
    return unparse(tidy_comments(_ordered(items)))


def _params(it: Item):
    toks, code = it.toks, _code_idx(it.toks)
    w = [toks[i].text for i in code]
    op = w.index("(")
    cl = _match(toks, code, op)
    return [w[a:b] for a, b in _split_args(toks, code, op, cl)], w[cl + 1:]


def _drop_unused_params(items: list[Item], keep) -> list[Item]:
    """Drop the parameters a function never reads (its callers' arguments with them)."""
    from cellgl.export.reach import _drop_struct_args

    impure = {it.name for it in items if it.kind == "function"
              and re.search(r"\b(out|inout)\b", "".join(t.text for t in it.toks).split("{", 1)[0])}
    for it in items:
        if it.kind != "function" or it.name in keep or sum(x.name == it.name for x in items) != 1:
            continue
        params, body = _params(it)
        for k, words in enumerate(params):
            if not words or words[-1] in body or set(words) & {"out", "inout"} or words[-1] == "]":
                continue
            takes = {it.name: (k, words[-1])}
            new = []
            for x in items:
                toks = _drop_struct_args(x.toks, takes, "", skip_sig=x is it)
                if toks is None or (x.kind == "function" and _impure_arg(x, toks, impure)):
                    break
                new.append(Item(x.kind, x.name, toks, x.comment))
            else:
                return _drop_unused_params(new, keep)
    return items


def _drop_unused_outs(items: list[Item], keep) -> list[Item]:
    """An ``out`` parameter whose argument is, at every call, a local used nowhere else becomes a
    local of the function (whose stores the dead-store pass then removes)."""
    from cellgl.export.reach import _drop_struct_args

    for it in items:
        if it.kind != "function" or it.name in keep or sum(x.name == it.name for x in items) != 1:
            continue
        params, _ = _params(it)
        for k, words in enumerate(params):
            if words[:1] != ["out"] or len(words) != 3:
                continue
            calls_ok, n_calls = True, 0
            for x in items:
                if x.kind != "function" or x is it:
                    continue
                toks, code = x.toks, _code_idx(x.toks)
                w = [toks[i].text for i in code]
                for m in range(len(w) - 1):
                    if w[m] == it.name and w[m + 1] == "(":
                        n_calls += 1
                        cl = _match(toks, code, m + 1)
                        args = _split_args(toks, code, m + 1, cl)
                        a, b = args[k]
                        if b - a != 1 or w.count(w[a]) != 2 or w[_decl_at(w, w[a])] not in _DECL_TYPES:
                            calls_ok = False
            if not calls_ok or not n_calls:
                continue
            takes = {it.name: (k, words[-1])}
            new = []
            for x in items:
                toks = _drop_struct_args(x.toks, takes, "", skip_sig=x is it)
                if x is it:
                    text = "".join(t.text for t in toks)
                    text = text.replace("{", "{\n    " + words[1] + " " + words[2] + ";", 1)
                    toks = tokenize(text)
                new.append(Item(x.kind, x.name, toks, x.comment))
            return _drop_unused_outs(new, keep)
    return items


def _decl_at(w: list[str], name: str) -> int:
    return next((m - 1 for m in range(1, len(w)) if w[m] == name), 0)


def _impure_arg(x: Item, toks: list[Tok], impure: set[str]) -> bool:
    """Whether dropping arguments removed a call to a function with out parameters."""
    before = [t.text for t in x.toks if t.kind == "id"]
    after = [t.text for t in toks if t.kind == "id"]
    return any(before.count(f) != after.count(f) for f in impure)


def _dead_fields(items: list[Item]) -> list[Item]:
    """Remove struct fields that are written (``o.f = ...;``) but never read, and those writes."""
    code = "\n".join("".join(t.text for t in it.toks if t.kind != "comment") for it in items)
    impure = {it.name for it in items if it.kind == "function"
              and re.search(r"\b(out|inout)\b", "".join(t.text for t in it.toks).split("{", 1)[0])}
    out = items
    for st in [it for it in items if it.kind == "struct"]:
        body = "".join(t.text for t in st.toks if t.kind != "comment")
        fields = re.findall(r"\b(\w+)\s*(?:\[\s*\w+\s*\])?\s*;", body)
        holders = set(re.findall(rf"\b{st.name}\s+(\w+)\s*[;,)=]", code))
        dead = set()
        if not holders:
            continue
        names = "|".join(sorted(holders))
        others = {v for t, v in re.findall(r"\b(Cellgl\w+)\s+(\w+)\b", code) if t != st.name} - holders
        access = {}                          # field -> [(base, is a store)]
        for m in re.finditer(r"\.([A-Za-z_]\w*)", code):
            if m.group(1) not in fields:
                continue
            base = re.search(r"(\w*)\s*$", code[max(0, m.start() - 40):m.start()]).group(1)
            store = re.match(r"(?:\s*\[[^\]]*\])?\s*=(?!=)", code[m.end():m.end() + 40]) is not None
            access.setdefault(m.group(1), []).append((base, store))
        for f in fields:
            reads = [b for b, store in access.get(f, ()) if not store and b not in others]
            stores = re.findall(rf"(?<![\w.])(?:{names})\.{f}(?:\s*\[[^\]]*\])?\s*=(?!=)[^;]*;", code) \
                if f in access else []
            writes = len(stores)
            if any(re.search(rf"\b{g}\b", x) for x in stores for g in impure):
                continue
            if writes and not reads:
                dead.add(f)
        if not dead or len(dead) == len(fields):
            continue
        from cellgl.export.reach import _drop_fields

        new = []
        for it in out:
            if it is st:
                new.append(_drop_fields(it, dead))
            elif it.kind == "function":
                t = "".join(x.text for x in it.toks)
                for f in dead:
                    t = re.sub(rf"\n[ \t]*(?:{'|'.join(holders)})\.{f}(?:\s*\[[^\]]*\])?\s*=[^;]*;[^\n]*(?=\n)", "", t)
                new.append(Item(it.kind, it.name, tokenize(t), it.comment))
            else:
                new.append(it)
        out = new
    return out


def _ordered(items: list[Item]) -> list[Item]:
    """Items in their order, each moved after what it uses (the recipe's constants come after
    the library in the source, but the library now reads them)."""
    by_name = {}
    for it in items:
        by_name.setdefault(it.name, []).append(it)
    out, done, busy = [], set(), set()

    def visit(it):
        if id(it) in done or id(it) in busy:
            return
        busy.add(id(it))
        for u in sorted(it.uses(), key=lambda n: min(items.index(x) for x in by_name[n]) if n in by_name else 0):
            for dep in by_name.get(u, ()):
                visit(dep)
        busy.discard(id(it))
        done.add(id(it))
        out.append(it)

    for it in items:
        visit(it)
    return out
