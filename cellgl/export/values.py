"""Constant values of GLSL expressions, computed as GLSL computes them: integers wrap at 32 bits,
floats are binary32 (each operation rounded to float32; a result that overflows is not a
value), booleans; and the literals that write them (:mod:`cellgl.export.fold`)."""
from __future__ import annotations

import math
import operator
import struct

from cellgl.export.translate.tokens import TranslateError  # noqa: F401  (first: the translators import the parser)
from cellgl.export import syntax as S
from cellgl.export.tree import Context, is_pure

__all__ = ["value", "convert", "literal", "shape", "COMPARE"]

_M32 = 1 << 32


# values: ("bool", b), ("int", i), ("uint", u), ("float", binary32 as a Python float)

def _f32(x: float):
    """``x`` rounded to binary32, or None where it overflows (GLSL gives inf: not folded)."""
    try:
        f = struct.unpack("f", struct.pack("f", x))[0]
    except OverflowError:
        return None
    return None if math.isinf(f) or math.isnan(f) else f


def _int(v: int) -> int:
    v &= _M32 - 1
    return v - _M32 if v >= 1 << 31 else v


def _num(text: str):
    t = text.lower()
    if t.startswith("0x"):
        return ("uint", int(t.rstrip("u"), 16) % _M32) if t.endswith("u") else ("int", _int(int(t, 16)))
    if t.endswith("u"):
        return "uint", int(t[:-1], 8 if len(t) > 2 and t[0] == "0" else 10) % _M32
    if "." in t or "e" in t:
        f = _f32(float(t.removesuffix("lf").removesuffix("f")))
        return None if f is None else ("float", f)
    return "int", _int(int(t, 8 if len(t) > 1 and t[0] == "0" else 10))


def value(e, env: dict, ctx: Context | None = None):
    """The value of the expression ``e`` of literals and the constants ``env`` (``{name:
    value}``), or None. ``x || true`` is true and ``x && false`` false where ``x`` has no
    effects (with ``ctx``: calls no function that writes its arguments)."""
    if isinstance(e, S.Num):
        return _num(e.text)
    if isinstance(e, S.Name):
        return ("bool", e.name == "true") if e.name in ("true", "false") else env.get(e.name)
    if isinstance(e, S.Paren):
        return value(e.inner, env, ctx)
    if isinstance(e, S.Unary):
        v = value(e.operand, env, ctx)
        if v is None:
            return None
        t, x = v
        if e.op == "!" and t == "bool":
            return "bool", not x
        if e.op == "-" and t in ("int", "uint", "float"):
            return t, (-x if t == "float" else _int(-x) if t == "int" else -x % _M32)
        if e.op == "~" and t in ("int", "uint"):
            return t, _int(~x) if t == "int" else ~x % _M32
        return v if e.op == "+" and t != "bool" else None
    if isinstance(e, S.Ternary):
        c = value(e.cond, env, ctx)
        return None if c is None or c[0] != "bool" else value(e.then if c[1] else e.other, env, ctx)
    if isinstance(e, S.Ctor) and len(e.args) == 1:
        return convert(e.type, value(e.args[0], env, ctx))
    if isinstance(e, S.Binary):
        return _binary(e, env, ctx)
    return None


def convert(typ: str, v):
    if v is None or typ not in ("int", "uint", "float", "bool"):
        return None
    t, x = v
    if typ == "bool":
        return "bool", bool(x)
    if typ == "float":
        return "float", (float(x) if t == "bool" else _f32(x))
    if t == "float":
        if math.isnan(x) or not (-2.0 ** 31 <= x < 2.0 ** 31) or (typ == "uint" and x < 0):
            return None                  # out of range: undefined in GLSL
        x = math.trunc(x)
    return typ, (_int(int(x)) if typ == "int" else int(x) % _M32)


COMPARE = {"<": operator.lt, ">": operator.gt, "<=": operator.le, ">=": operator.ge, "==": operator.eq,
            "!=": operator.ne}


def _binary(e, env, ctx):
    op = e.op
    a = value(e.left, env, ctx)
    if op in ("&&", "||"):
        absorb = op == "||"                      # true || x, false && x
        if a is not None and a[0] == "bool" and a[1] == absorb:
            return a
        b = value(e.right, env, ctx)
        if b is not None and b[0] == "bool" and b[1] == absorb and is_pure(e.left, ctx):
            return b
        return None if a is None or b is None else ("bool", a[1] or b[1] if absorb else a[1] and b[1])
    b = value(e.right, env, ctx)
    if a is None or b is None:
        return None
    (ta, x), (tb, y) = a, b
    if op in ("<<", ">>") and ta in ("int", "uint") and tb in ("int", "uint") and 0 <= y < 32:
        if op == "<<":
            return ta, _int(x << y) if ta == "int" else (x << y) % _M32
        return ta, x >> y
    if ta != tb:
        return None                              # no implicit conversions (GLSL ES)
    if op in COMPARE:
        return ("bool", COMPARE[op](x, y)) if ta != "bool" or op in ("==", "!=") else None
    if op == "^^" and ta == "bool":
        return "bool", x != y
    if ta == "bool":
        return None
    if ta == "float":
        f = _f32(_FLOAT_OPS[op](x, y)) if op in _FLOAT_OPS and not (op == "/" and y == 0.0) else None
        return None if f is None else ("float", f)
    if op in ("/", "%") and (y <= 0 or x < 0) or op not in _INT_OPS:
        return None                              # (negative or zero divisors: left to the compiler)
    r = _INT_OPS[op](x, y)
    return ta, (_int(r) if ta == "int" else r % _M32)


_FLOAT_OPS = {"+": operator.add, "-": operator.sub, "*": operator.mul, "/": operator.truediv}
_INT_OPS = {"+": operator.add, "-": operator.sub, "*": operator.mul, "&": operator.and_, "|": operator.or_,
            "^": operator.xor, "/": operator.floordiv, "%": operator.mod}


def literal(v):
    """The GLSL literal node of the value ``v`` (None: a float other than 0.0 and 1.0, which stay
    as written)."""
    t, x = v
    if t == "bool":
        return S.Name("true" if x else "false")
    if t == "uint":
        return S.Num(f"{x}u")
    if t == "int":
        return S.Num(str(x)) if x >= 0 else (S.Paren(S.Unary("-", S.Num(str(-x)))) if x > -2 ** 31 else None)
    if x in (0.0, 1.0) and math.copysign(1.0, x) > 0:
        return S.Num(f"{x:.1f}")
    return None


def shape(v) -> bool:
    """Whether a constant decides the shape of the code (written into it): a boolean, an
    integer, 0.0 or 1.0."""
    return v is not None and literal(v) is not None
