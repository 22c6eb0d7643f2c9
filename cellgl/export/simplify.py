"""Statement-level simplification for the snippet compiler (:mod:`cellgl.export.compiler`).

Inside one function: dead locals (declared, never read), dead stores (a local only ever
written; the last store to a local that is not read again), declarations split one per line,
and arithmetic identities that hold exactly in float arithmetic (``x * 1.0``, ``x - 0.0``,
``x += 0.0 * y;``, ``mix(a, b, 0.0)``, ``vec4(0.0) + v``), members of literal vectors
(``vec4(0.0, 0.0, 0.0, 1.0).w``), unsigned literal products, copies (``float y = x;``) and the
bare blocks an unrolled loop leaves. A right-hand side that calls a function with ``out``
parameters is never removed.
"""
from __future__ import annotations

import re

from cellgl.export.reach import _code_idx, _line_start, _match, _split_args, _stmt_end
from cellgl.export.translate.tokens import Tok, tokenize

__all__ = []


def _top_comma(words: list[str]) -> bool:
    depth = 0
    for x in words:
        depth += x in ("(", "[")
        depth -= x in (")", "]")
        if x == "," and depth == 0:
            return True
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
            start = _line_start(toks, start)
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


def _copy_local(toks: list[Tok], impure: set[str]) -> list[Tok] | None:
    """``float y = (x);`` with x a local or parameter, neither x nor y assigned afterwards (nor
    passed to a function with out parameters) -> every y becomes x."""
    code = _code_idx(toks)
    w = [toks[i].text for i in code]
    for n in range(2, len(w) - 3):
        if not (w[n - 1] in _DECL_TYPES and w[n - 2] in (";", "{", "}") and w[n + 1] == "="):
            continue
        end = w.index(";", n)
        src = [x for x in w[n + 2:end] if x not in "()"]
        if len(src) != 1 or not re.fullmatch(r"[A-Za-z_]\w*", src[0]) or w[n + 2:end].count("(") != w[n + 2:end].count(")"):
            continue
        x, y = src[0], w[n]
        if w.count(y) < 2 or any(f in impure for f in w[end:]) or any(w[k] in (x, y) and (k + 1 < len(w) and w[k + 1] in _ASSIGN_OPS or w[k - 1] in ("++", "--", "."))
                                 for k in range(end + 1, len(w))):
            continue
        if any(w[k] in (x, y) and w[k + 1] in ("[", ".") and _assigned(toks, code, w, k) for k in range(end + 1, len(w) - 1)):
            continue
        start = code[n - 1]
        start = _line_start(toks, start)
        rest = [Tok("id", x) if t.kind == "id" and t.text == y and toks[code[end] + 1 + j - 1].text != "." else t
                for j, t in enumerate(toks[code[end] + 1:])]
        return toks[:start] + rest
    return None


_ASSIGN_OPS = {"=", "+=", "-=", "*=", "/=", "%=", "<<=", ">>=", "&=", "|=", "^=", "++", "--"}


def _assigned(toks, code, w, k) -> bool:
    """Whether ``w[k]`` followed by an index or a field is the target of an assignment."""
    while k + 1 < len(w) and w[k + 1] in ("[", "."):
        k = _match(toks, code, k + 1) if w[k + 1] == "[" else k + 2
    return k + 1 < len(w) and w[k + 1] in _ASSIGN_OPS


def _bare_block(toks: list[Tok]) -> list[Tok] | None:
    """``{ stmts }`` standing alone (what an unrolled loop leaves) -> ``stmts``, one indent
    less, when no name it declares is used outside it."""
    code = _code_idx(toks)
    w = [toks[i].text for i in code]
    for n in range(1, len(w) - 1):
        if w[n] != "{" or w[n - 1] not in (";", "{", "}"):
            continue
        m = _match(toks, code, n)
        depth, declared = 0, set()
        for k in range(n + 1, m):
            depth += w[k] == "{"
            depth -= w[k] == "}"
            if depth == 0 and (w[k] in _DECL_TYPES or w[k].startswith("Cellgl")) and w[k - 1] in (";", "{", "}") \
                    and re.fullmatch(r"[A-Za-z_]\w*", w[k + 1]):
                declared.add(w[k + 1])
        if any(x in declared for x in w[:n] + w[m + 1:]):
            continue
        before = "".join(t.text for t in toks[:code[n]])
        inner = "".join(t.text for t in toks[code[n] + 1:code[m]])
        after = "".join(t.text for t in toks[code[m] + 1:])
        before = re.sub(r"\n[ \t]*$", "", before)
        inner = re.sub(r"\n[ \t]*$", "", inner.replace("\n    ", "\n"))
        return tokenize(before + inner + after)
    return None


def _dead_store(toks: list[Tok], impure: set[str]) -> list[Tok] | None:
    """Remove a local that is only ever written (``x = ...;``, ``x.y += ...;``, ``x[0] = ...;``),
    with its declaration and those statements (their right-hand sides call nothing with out
    parameters)."""
    code = _code_idx(toks)
    w = [toks[i].text for i in code]
    for n in range(2, len(w) - 2):
        if not ((w[n - 1] in _DECL_TYPES or w[n - 1].startswith("Cellgl")) and w[n - 2] in (";", "{", "}")
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
            start = _line_start(toks, start)
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
            start = _line_start(toks, start)
            return toks[:start] + toks[code[end] + 1:]
    return None


_ZERO = r"(?:0\.0|0\.|0)"


_ONE = r"(?:1\.0|1\.|1)"


def _arithmetic(toks: list[Tok]) -> list[Tok]:
    text = "".join(t.text for t in toks)
    for _ in range(10):
        old = text
        # integer arithmetic in an index
        text = re.sub(r"\[\s*(\d+(?:\s*[-+*]\s*\d+)+)\s*\]",
                      lambda m: f"[{eval(m.group(1), {'__builtins__': {}}, {})}]", text)
        # statements that subtract zero or multiply by one (x - 0.0 == x for every x, -0.0 and
        # NaN included; x + 0.0 is not: -0.0 + 0.0 is +0.0, and 0.0 * y is NaN for an infinite y)
        text = re.sub(rf"\n[ \t]*[\w.\[\]]+\s*-=\s*\(?{_ZERO}\)?\s*;[^\n]*(?=\n)", "", text)
        text = re.sub(rf"\n[ \t]*[\w.\[\]]+\s*[*/]=\s*\(?{_ONE}\)?\s*;[^\n]*(?=\n)", "", text)
        text = _mix(text)
        text = re.sub(r"\n[ \t]*\{\s*\}[ \t]*(?=\n)", "", text)          # an empty block
        text = re.sub(r"\n[ \t]*if \((?:[^;{}()]|\([^;{}()]*\))*\) \{\s*\}[ \t]*(?=\n)", "", text)
        # x * 1.0, x / 1.0, x - 0.0 (floats: the same value for every x; the snippet compiles as
        # GLSL ES, which has no implicit int -> float, so x is a float)
        text = re.sub(r"(?<=[\w)\]])\s*[*/]\s*1\.0(?![\w.(\[])", "", text)
        text = re.sub(r"(?<=[(=,+\-])(\s*)1\.0\s*\*\s*(?=[\w(])", r"\1", text)
        text = re.sub(r"(?<=[\w)\]])\s*-\s*0\.0(?=\s*[),;+\-]|\s*$)", "", text)
        text = _LITERAL_VEC.sub(_member, text)
        # |x| * |x| = x * x exactly
        text = re.sub(rf"\babs\(({_BAL})\) \* abs\(\1\)",
                      lambda m: (f"{m.group(1)} * {m.group(1)}" if re.fullmatch(r"[\w.\[\]]+", m.group(1))
                                 else f"({_unwrap(m.group(1))}) * ({_unwrap(m.group(1))})"), text)
        # a product in a sum needs no parentheses
        text = re.sub(r"(?:(?<=[-+(=,] )|(?<=\())\(([\w.\[\]]+ \* [\w.\[\]]+)\)(?=\s*[-+);,])", r"\1", text)
        text = _redundant_parens(text)
        # a comparison of integer literals (sums of them)
        text = re.sub(r"(?<=[=(!] )(\(?)(-?\d+(?: [-+*] \d+)*) (<=|>=|<|>|==|!=) (-?\d+(?: [-+*] \d+)*)\)?(?=\s*[;),&|])",
                      lambda m: m.group() if m.group(1) and not m.group().endswith(")") else
                      str(eval(f"{m.group(2)} {m.group(3)} {m.group(4)}", {"__builtins__": {}}, {})).lower(), text)
        # unsigned literals: uint(0) -> 0u, 0u * 1013u -> 0u, (0u + x) -> (x), (0u) -> 0u
        text = re.sub(r"\buint\((\d+)\)", r"\1u", text)
        text = re.sub(r"(?<![\w.*/%\s])(\s*)\b(\d+)u\s*\*\s*(\d+)u\b(?!\s*[*/%])",
                      lambda m: f"{m.group(1)}{int(m.group(2)) * int(m.group(3)) % 2 ** 32}u", text)
        text = re.sub(r"(?<![/%]\s)(?<![/%])\b0u\s*\*\s*(?:0x[0-9a-fA-F]+|\d+)u\b", "0u", text)
        text = re.sub(r"(?<=[(=,])(\s*)0u\s*\+\s*", r"\1", text)
        text = re.sub(r"(?<![\w\]])\((\d+u?|\d+\.\d+)\)", r"\1", text)
        # an integer zero vector added: ivec4(0, 0, 0, 0) + c -> c (integers: exact)
        text = re.sub(rf"(?<=[(=,])(\s*)\(?{_ZERO_IVEC}\)?\s*\+\s*", r"\1", text)
        # an empty last branch of an if chain (conditions without side effects)
        text = re.sub(r"\}\s*else(?: if \((?:[^;{}()=]|[<>!=]=|\([^;{}()]*\))*\))? \{\s*\}(?!\s*else)", "}", text)
        text = re.sub(r"\n[ \t]*(\w+)\s*=\s*\(*\1\)*\s*;[^\n]*(?=\n)", "", text)   # x = x;
        if text == old:
            break
    return tokenize(text)


_BAL = r"(?:[^()]|\((?:[^()]|\([^()]*\))*\))+"


def _unwrap(e: str) -> str:
    while e.startswith("(") and e.endswith(")") and re.fullmatch(rf"\(({_BAL})\)", e) \
            and _balanced(e[1:-1]):
        e = e[1:-1]
    return e


def _balanced(e) -> bool:
    """Whether the parentheses among ``e`` (a string, or a list of words) pair up in order."""
    depth = 0
    for ch in e:
        depth += ch == "("
        depth -= ch == ")"
        if depth < 0:
            return False
    return depth == 0


def _redundant_parens(text: str) -> str:
    """``((e))`` -> ``(e)``, ``f((e))`` -> ``f(e)``, ``x = (e);`` -> ``x = e;``, ``return (e);``."""
    if not re.search(r"[(=,]\s*\(|\breturn\s*\(", text):
        return text
    toks = tokenize(text)
    code = _code_idx(toks)
    w = [toks[i].text for i in code]
    drop: set[int] = set()
    for n in range(len(w) - 1):
        if w[n] != "(":
            continue
        cl = _match(toks, code, n)
        if w[n + 1] == "(" and _match(toks, code, n + 1) == cl - 1:
            drop |= {code[n + 1], code[cl - 1]}
        elif n > 0 and w[n - 1] in ("=", "return") and cl + 1 < len(w) and w[cl + 1] == ";" \
                and "?" not in w[n:cl] and "," not in _top_level_ops(" ".join(w[n + 1:cl])):
            drop |= {code[n], code[cl]}
        elif n > 0 and w[n - 1] in ("(", "=", ",", "return") and cl + 1 < len(w) \
                and w[cl + 1] in ("+", "-", "<", ">", "<=", ">=", "==", "!=") \
                and not _top_level_ops("".join(w[n + 1:cl])) - {"+", "-", "*", "/"}:
            drop |= {code[n], code[cl]}           # (a + b) + c, (a * b) >= c: arithmetic on the left
    if not drop:
        return text
    return "".join(t.text for i, t in enumerate(toks) if i not in drop)


_NUM = r"-?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?u?"
_ZERO_IVEC = r"\b[iu]vec[234]\(\s*0u?(?:\s*,\s*0u?)*\s*\)"
_LITERAL_VEC = re.compile(rf"\b(i?vec[234])\(\s*({_NUM}(?:\s*,\s*{_NUM})*)\s*\)\.([xyzw]+|[rgba]+)\b(?!\s*\()")


def _member(m: re.Match) -> str:
    """``vec4(0.0, 0.0, 0.0, 1.0).w`` -> ``1.0``; ``vec4(1.0).rgb`` -> ``vec3(1.0)``."""
    args = [a.strip() for a in m.group(2).split(",")]
    size = int(m.group(1)[-1])
    if len(args) == 1:
        args = args * size
    if len(args) != size:
        return m.group()
    picked = [args["xyzw".find(c) if c in "xyzw" else "rgba".find(c)] for c in m.group(3)]
    if len(picked) == 1:
        return picked[0]
    typ = m.group(1)[:-1] + str(len(picked))
    return f"{typ}({picked[0]})" if len(set(picked)) == 1 else f"{typ}({', '.join(picked)})"


def _mix(text: str) -> str:
    """``mix(a, b, 0.0)`` -> ``(a)``; ``mix(a, b, 1.0)`` -> ``(b)`` only where ``a`` is a
    literal (``a * 0.0`` is NaN for an infinite ``a``)."""
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
            if pick == 1 and not re.fullmatch(_NUM, "".join(w[args[0][0]:args[0][1]])):
                continue
            if pick is None:
                continue
            a, b = args[pick]
            inner = "".join(t2.text for t2 in toks[code[a]:code[b - 1] + 1])
            return _mix("".join(x.text for x in toks[:code[n]]) + "(" + inner.strip() + ")"
                        + "".join(x.text for x in toks[code[cl] + 1:]))
    return text


def _merge_declaration(toks: list[Tok]) -> list[Tok] | None:
    """``T x; ... x = e;`` (x unused between, in the same block) -> ``... T x = e;``."""
    code = _code_idx(toks)
    w = [toks[i].text for i in code]
    for n in range(2, len(w) - 2):
        if not ((w[n - 1] in _DECL_TYPES or w[n - 1].startswith("Cellgl")) and w[n - 2] in (";", "{", "}")
                and re.fullmatch(r"[A-Za-z_]\w*", w[n]) and w[n + 1] == ";"):
            continue
        depth, k = 0, n + 2
        while k < len(w) and w[k] != w[n] and depth >= 0:
            depth += (w[k] == "{") - (w[k] == "}")
            k += 1
        if k + 1 >= len(w) or depth != 0 or w[k - 1] not in (";", "{", "}") or w[k + 1] != "=":
            continue
        end = _stmt_end(toks, code, w, k)
        if w[n] in w[k + 2:end]:
            continue
        start = _line_start(toks, code[n - 1])
        return (toks[:start] + toks[code[n + 1] + 1:code[k]] + [Tok("id", w[n - 1]), Tok("ws", " ")]
                + toks[code[k]:])
    return None


_LIT = re.compile(r"-?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?u?|true|false")


def _forward_literal(toks: list[Tok]) -> list[Tok] | None:
    """``x = 0; bool b = x > 9; if (!b) {`` -> ``bool b = 0 > 9; if (!b) {``: a literal just
    stored (``x`` a local or a field) read by the next straight-line statements or ``if``
    condition, before anything writes it."""
    code = _code_idx(toks)
    w = [toks[i].text for i in code]
    for n in range(1, len(w) - 4):
        if w[n - 1] not in (";", "{", "}") and not (w[n - 1] in _DECL_TYPES and w[n - 2] in (";", "{", "}")):
            continue
        k = n + 1
        target = [w[n]]
        while k + 1 < len(w) and w[k] == ".":
            target += [".", w[k + 1]]
            k += 2
        if not re.fullmatch(r"[A-Za-z_]\w*", w[n]) or w[k] != "=" or k + 2 >= len(w) or w[k + 2] != ";" \
                or not _LIT.fullmatch(w[k + 1]):
            continue
        lit, s = w[k + 1], k + 3
        while s < len(w) and w[s] not in ("}",):
            if w[s] == "if" and w[s + 1] == "(":
                lo, hi = s + 2, _match(toks, code, s + 1)
            else:
                if w[s] in ("for", "while", "{", "return", "else", "do", "break", "continue"):
                    break
                end = _stmt_end(toks, code, w, s)
                eq = next((j for j in range(s, end) if w[j] in _ASSIGN_OPS), None)
                if eq is None or "{" in w[s:end] or any(re.fullmatch(r"\w+", x) and x not in _DECL_TYPES
                                                        and j + 1 < end and w[j + 1] == "(" and x not in _PURE
                                                        for j, x in enumerate(w[s:end], s)):
                    break
                if w[s:s + len(target)] == target and w[s + len(target)] in _ASSIGN_OPS:
                    break
                lo, hi = eq + 1, end
            hits = [j for j in range(lo, hi - len(target) + 1) if w[j:j + len(target)] == target
                    and (j == 0 or w[j - 1] != ".") and (j + len(target) >= len(w) or w[j + len(target)] not in (".", "["))]
            if any(w[j + len(target)] in _ASSIGN_OPS for j in hits):
                break
            if hits:
                j = hits[0]
                return toks[:code[j]] + [Tok("num", lit)] + toks[code[j + len(target) - 1] + 1:]
            if w[s] == "if":
                break
            s = hi + 1
    return None


_PURE = {"abs", "min", "max", "floor", "sqrt", "clamp", "mix", "float", "int", "uint", "vec2", "vec3", "vec4",
         "ivec2", "ivec3", "ivec4", "uvec4", "dot", "length", "ceil", "fract", "sign", "step", "smoothstep",
         "any", "all", "notEqual", "equal", "pow", "exp", "log", "inversesqrt"}


def _loop_variable(toks: list[Tok]) -> list[Tok] | None:
    """``int i = 2; ... for (; i <= 9; i++) {...}`` with i unused after the loop (nor between)
    -> ``... for (int i = 2; i <= 9; i++) {...}``."""
    code = _code_idx(toks)
    w = [toks[i].text for i in code]
    for f in range(len(w) - 3):
        if w[f] != "for" or w[f + 1] != "(" or w[f + 2] != ";":
            continue
        cl = _match(toks, code, f + 1)
        end = _stmt_end(toks, code, w, f)
        names = {x for x in w[f + 3:cl] if re.fullmatch(r"[A-Za-z_]\w*", x)}
        for n in range(f - 1, 1, -1):
            if w[n] in ("{", "}"):
                break
            if w[n - 1] in _DECL_TYPES and w[n - 2] in (";", "{", "}") and w[n] in names and w[n + 1] == "=":
                x, d_end = w[n], w.index(";", n)
                if x in w[d_end + 1:f] or x in w[end + 1:]:
                    break
                decl = "".join(t.text for t in toks[code[n - 1]:code[d_end]]).strip()
                start = _line_start(toks, code[n - 1])
                return (toks[:start] + toks[code[d_end] + 1:code[f + 1] + 1] + tokenize(decl)
                        + toks[code[f + 2]:])
    return None


def _store_into_next(toks: list[Tok], impure: set[str]) -> list[Tok] | None:
    """``T y = a; y = f(y);`` (y read once there) -> ``T y = f(a);`` (a a name, or y read
    without a field or index); ``T y = a; return y;`` -> ``return a;``."""
    code = _code_idx(toks)
    w = [toks[i].text for i in code]
    for n in range(2, len(w) - 6):
        if not (w[n - 1] in _DECL_TYPES and w[n - 2] in (";", "{", "}") and re.fullmatch(r"[A-Za-z_]\w*", w[n])
                and w[n + 1] == "="):
            continue
        end = _stmt_end(toks, code, w, n)
        y = w[n]
        if w[end + 1:end + 4] == ["return", y, ";"] and "," not in _top_level_ops(" ".join(w[n + 2:end])):
            a = "".join(t.text for t in toks[code[n + 2]:code[end]]).strip()      # T y = a; return y;
            return toks[:code[n - 1]] + tokenize(f"return {a};") + toks[code[end + 3] + 1:]
        if end + 3 >= len(w) or w[end + 1] != y or w[end + 2] != "=" or y in w[n + 2:end]:
            continue
        end2 = _stmt_end(toks, code, w, end + 1)
        rhs = w[end + 3:end2]
        if rhs.count(y) != 1 or any(x in impure for x in w[n:end2]):
            continue
        k = end + 3 + rhs.index(y)
        a = _unwrap("".join(t.text for t in toks[code[n + 2]:code[end]]).strip())
        simple = re.fullmatch(r"[A-Za-z_]\w*|[\w.]+\([^()]*\)", a) is not None
        if not simple and (w[k + 1] in (".", "[") or k > 0 and w[k - 1] == "."):
            continue
        top = _top_level_ops(a)
        left, right = w[k - 1], w[k + 1]
        bare = simple or (left in ("(", ",", "=") and right in (")", ",", ";")) \
            or (not top - {"*", "/"} and left in ("(", ",", "=", "+") and right in (")", ",", ";", "+", "-")) \
            or (not top - {"+", "-", "*", "/"} and left in ("(", ",", "=") and right in ("+", "-"))
        rhs_text = ("".join(t.text for t in toks[code[end + 3]:code[k]]) + (a if bare else f"({a})")
                    + "".join(t.text for t in toks[code[k] + 1:code[end2]]))
        start = _line_start(toks, code[end + 1])
        return toks[:code[n + 2]] + tokenize(rhs_text.strip()) + toks[code[end]:start] + toks[code[end2] + 1:]
    return None


def _top_level_ops(e: str) -> set[str]:
    depth, ops = 0, set()
    for t in tokenize(e):
        if t.text in "([":
            depth += 1
        elif t.text in ")]":
            depth -= 1
        elif depth == 0 and t.kind == "op" and t.text != ".":
            ops.add(t.text)
    return ops
