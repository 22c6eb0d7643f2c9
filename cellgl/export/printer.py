"""GLSL text of :mod:`cellgl.export.syntax`'s tree: :func:`print_glsl` (4-space indentation,
a block's brace on the line that opens it, except a function's; the comments where they were;
parentheses as written)."""
from __future__ import annotations

from cellgl.export.syntax import (
    ArrayCtor,
    Assign,
    Binary,
    Block,
    Call,
    Ctor,
    Decl,
    ExprStmt,
    For,
    Function,
    Global,
    If,
    IncDec,
    Index,
    Jump,
    Member,
    Name,
    Num,
    Paren,
    Return,
    Struct,
    Ternary,
    Unary,
    Unit,
    While,
)

__all__ = ["print_glsl", "print_lines", "expr_glsl", "statement_glsl", "item_glsl"]


# --------------------------------------------------------------------------------------------
# printer
# --------------------------------------------------------------------------------------------


def expr_glsl(e) -> str:
    """GLSL of an expression node."""
    if isinstance(e, Num):
        return e.text
    if isinstance(e, Name):
        return e.name
    if isinstance(e, Paren):
        return f"({expr_glsl(e.inner)})"
    if isinstance(e, (Call, Ctor)):
        return f"{e.func if isinstance(e, Call) else e.type}({', '.join(expr_glsl(a) for a in e.args)})"
    if isinstance(e, ArrayCtor):
        return f"{e.type}[{expr_glsl(e.size)}]({', '.join(expr_glsl(a) for a in e.args)})"
    if isinstance(e, Unary):
        return e.op + expr_glsl(e.operand)
    if isinstance(e, IncDec):
        return expr_glsl(e.operand) + e.op if e.postfix else e.op + expr_glsl(e.operand)
    if isinstance(e, Binary):
        return f"{expr_glsl(e.left)} {e.op} {expr_glsl(e.right)}"
    if isinstance(e, Assign):
        return f"{expr_glsl(e.target)} {e.op} {expr_glsl(e.value)}"
    if isinstance(e, Ternary):
        return f"{expr_glsl(e.cond)} ? {expr_glsl(e.then)} : {expr_glsl(e.other)}"
    if isinstance(e, Index):
        return f"{expr_glsl(e.base)}[{expr_glsl(e.index)}]"
    if isinstance(e, Member):
        return f"{expr_glsl(e.base)}.{e.name}"
    raise TypeError(f"not an expression node: {e!r}")


def _comments(com: list, ind: str) -> list[str]:
    out = []
    for c in com:
        out += [ind + ln.strip() if ln.strip() else "" for ln in c.split("\n")] if c else [""]
    return out


def _declarators(typ: str, decls: list) -> str:
    parts = []
    for d in decls:
        s = d.name + (f"[{expr_glsl(d.size)}]" if d.size is not None else "")
        parts.append(s + (f" = {expr_glsl(d.init)}" if d.init is not None else ""))
    return f"{typ} {', '.join(parts)}"


def _simple(s) -> str:
    if isinstance(s, Decl):
        return ("const " if s.const else "") + _declarators(s.type, s.declarators)
    return expr_glsl(s.expr)


def statement_glsl(s, ind: str = "") -> list[str]:
    """Lines of a statement node at indentation ``ind``."""
    out = _comments(s.comments, ind)
    trail = f"  {s.trail}" if getattr(s, "trail", "") else ""
    if isinstance(s, Block):
        return out + [ind + "{"] + [ln for x in s.body for ln in statement_glsl(x, ind + "    ")] + [ind + "}"]
    if isinstance(s, (Decl, ExprStmt)):
        return out + [ind + _simple(s) + ";" + trail]
    if isinstance(s, Return):
        return out + [ind + ("return;" if s.value is None else f"return {expr_glsl(s.value)};")]
    if isinstance(s, Jump):
        return out + [ind + s.kind + ";"]
    if isinstance(s, If):
        out += _head(f"if ({expr_glsl(s.cond)})", s.then, ind)
        other = s.other
        if other is None:
            return out
        closed = out[-1] == ind + "}"
        if closed and isinstance(other, If) and not other.comments:
            first, *rest = statement_glsl(other, ind)
            return out[:-1] + [f"{ind}}} else {first.lstrip()}"] + rest
        if closed and isinstance(other, Block) and not other.comments:
            return out[:-1] + [f"{ind}}} else {{"] + [ln for x in other.body for ln in statement_glsl(x, ind + "    ")] \
                + [ind + "}"]
        return out + [ind + "else"] + statement_glsl(other, ind + "    ")
    if isinstance(s, For):
        init = "" if s.init is None else _simple(s.init)
        cond = "" if s.cond is None else " " + expr_glsl(s.cond)
        step = "" if s.step is None else " " + expr_glsl(s.step)
        return out + _head(f"for ({init};{cond};{step})", s.body, ind)
    if isinstance(s, While):
        return out + _head(f"while ({expr_glsl(s.cond)})", s.body, ind)
    raise TypeError(f"not a statement node: {s!r}")


def _head(head: str, body, ind: str) -> list[str]:
    if isinstance(body, Block) and not body.comments:
        return [f"{ind}{head} {{"] + [ln for x in body.body for ln in statement_glsl(x, ind + "    ")] + [ind + "}"]
    return [ind + head] + statement_glsl(body, ind + "    ")


def item_glsl(it) -> list[str]:
    """Lines of a top-level node."""
    out = _comments(it.comments, "")
    if isinstance(it, Struct):
        out.append(f"struct {it.name} {{")
        for f in it.fields:
            size = f"[{expr_glsl(f.size)}]" if f.size is not None else ""
            out += _comments(f.comments, "    ")
            out.append(f"    {f.type} {f.name}{size};" + (f"  {f.trail}" if f.trail else ""))
        return out + ["};"]
    if isinstance(it, Global):
        return out + [" ".join(it.quals + [_declarators(it.type, it.declarators)]) + ";"]
    if isinstance(it, Function):
        params = ", ".join((("const " if p.const else "") + (p.mode + " " if p.mode != "in" else "")
                            + f"{p.type} {p.name}" + (f"[{expr_glsl(p.size)}]" if p.size is not None else ""))
                           for p in it.params)
        sig = f"{it.ret} {it.name}({params})"
        if it.body is None:
            return out + [sig + ";"]
        return out + [sig, "{"] + [ln for x in it.body.body for ln in statement_glsl(x, "    ")] + ["}"]
    raise TypeError(f"not a top-level node: {it!r}")


def print_glsl(unit: Unit) -> str:
    """GLSL text of a tree: its items one blank line apart."""
    parts = ["\n".join(item_glsl(it)) for it in unit.items]
    if unit.trailing:
        parts.append("\n".join(_comments(unit.trailing, "")))
    return "\n\n".join(parts) + "\n"


def print_lines(unit: Unit, width: int = 120) -> str:
    """GLSL text of a compiled tree: :func:`item_glsl` of its items, one after another (no blank
    line); a statement or signature longer than ``width`` broken (:func:`_wrap`; a global's
    initialiser, a table of values, stays on its line)."""
    out = []
    for it in unit.items:
        for line in item_glsl(it):
            out += [line] if isinstance(it, Global) else _wrap(line, width)
    return "".join(ln + "\n" for ln in out)


def _wrap(line: str, width: int) -> list[str]:
    """A printed line as lines of at most ``width`` columns where it can be: broken after a comma
    inside brackets (the rest aligned after the bracket) or before a binary ``&&``, ``||``, ``+``
    or ``-`` (the rest indented 4 more columns), in the outermost brackets that leave a break
    that fits, as late as fits (or wherever gives fewer lines); a comment line stays whole."""
    if len(line) <= width or "//" in line:
        return [line]
    ind = len(line) - len(line.lstrip())
    cuts = []                                  # (where the rest starts, its column, bracket depth)
    opens: list[int] = []
    for k, ch in enumerate(line):
        if ch in "([":
            opens.append(k)
        elif ch in ")]" and opens:
            opens.pop()
        elif ch == "," and line[k + 1:k + 2] == " ":
            cuts.append((k + 2, opens[-1] + 1 if opens else ind + 4, len(opens)))
        elif ch == " " and line[k + 1:k + 4] in ("&& ", "|| ") or line[k:k + 3] in (" + ", " - "):
            cuts.append((k + 1, ind + 4, len(opens) + 1))
    shallow, late = _fill(line, cuts, width, ind, True), _fill(line, cuts, width, ind, False)
    return shallow if len(shallow) <= len(late) else late


def _fill(line: str, cuts: list, width: int, ind: int, shallow: bool) -> list[str]:
    """``line`` broken at ``cuts`` as late as fits, at the outermost depth that has a break that
    fits (not ``shallow``: or one deeper)."""
    out, start, prefix = [], 0, 0
    while len(line) - start + prefix > width:
        fit = [c for c in cuts if start < c[0] and c[0] - start + prefix <= width + 1]
        if not fit:
            break
        depth = min(c[2] for c in fit) + (0 if shallow else 1)
        cut, col, _ = [c for c in fit if c[2] <= depth][-1]
        out.append(" " * prefix + line[start:cut].strip() if out else line[:cut].rstrip())
        if len(out) == 1:
            prefix = col if ind < col <= width // 2 else ind + 8
        start = cut
    out.append(" " * prefix + line[start:].strip() if out else line)
    return out
