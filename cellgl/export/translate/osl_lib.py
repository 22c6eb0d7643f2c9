"""Helpers of the OSL translation (:mod:`cellgl.export.translate.osl`): the GLSL types OSL
lacks as structs, and the functions generated for them (operators, constructors, component
access, built-ins) and for unsigned 32-bit arithmetic on OSL's signed ``int``; each one is
generated once, when the translation first needs it."""
from __future__ import annotations

from collections.abc import Callable
from typing import Any

from cellgl.export.printer import RELATIONAL
from cellgl.export.translate.tokens import TranslateError
from cellgl.export.values import value

#: the component index of each swizzle letter; the components by index; the comparison operators
SWIZZLE = {"x": 0, "y": 1, "z": 2, "w": 3, "r": 0, "g": 1, "b": 2, "a": 3, "s": 0, "t": 1, "p": 2, "q": 3}
XYZW = "xyzw"
COMPARISONS = {"<", ">", "<=", ">=", "==", "!="}
#: component-wise built-ins (arguments of the first's type): OSL has each for scalars, by the same
#: name (``fract``: cellgl_fract)
_ELEMENTWISE = frozenset("""
    abs floor ceil sqrt exp log sign min max clamp pow round trunc sin cos fract mod mix step smoothstep
    inversesqrt exp2 log2 tan atan atan2""".split())
#: the geometric built-ins on scalars
_SCALAR_GEOMETRY = {"dot": "({} * {})", "normalize": "sign({})", "length": "abs({})",
                    "distance": "abs({} - {})"}
#: OSL keywords and global names that are legal GLSL identifiers
OSL_RESERVED = frozenset("""
    P I N Ng u v dPdu dPdv Ps time dtime dPdtime Ci color point vector normal matrix string closure
    output shader surface displacement volume illuminate illuminance emit public private class const
    export import extern friend inline template typedef union virtual cellgl_fract mod and or not lambda
    auto char double enum long short signed unsigned sizeof static switch case default goto mutable
    namespace new operator protected this throw try catch using volatile bool uint world object camera
    raster screen ndc common shader_type
""".split())


#: ``(component type, n)`` of each GLSL vector type; :func:`vec_type`: that of a type, or None
_VECS = {f"{k}vec{n}": (c, n) for k, c in (("", "float"), ("i", "int"), ("u", "uint"), ("b", "bool"))
         for n in (2, 3, 4)}
vec_type = _VECS.get


def vec_of(t: str) -> tuple[str, int]:
    """:func:`vec_type` of ``t``, a GLSL vector type."""
    v = _VECS.get(t)
    assert v is not None, t
    return v


def int_literal(v: int) -> str:
    """A 32-bit pattern as an OSL int literal (OSL's lexer has no unsigned or > 2^31 - 1)."""
    v &= 0xFFFFFFFF
    if v >= 0x80000000:
        v -= 1 << 32
    return f"({v})" if v < 0 else str(v)


def same_type(p, t) -> bool:
    """Whether an argument of GLSL type ``t`` matches a parameter of type ``p`` exactly (arrays:
    by element type), for overload resolution."""
    if isinstance(p, tuple) or isinstance(t, tuple):
        return isinstance(p, tuple) and isinstance(t, tuple) and same_type(p[0], t[0])
    return p == t


_OPNAME = {"+": "add", "-": "sub", "*": "mul", "/": "div", "%": "mod", "&": "and", "|": "or",
           "^": "xor", "<<": "shl", ">>": "shr", "<": "lt", ">": "gt", "<=": "le", ">=": "ge",
           "==": "eq", "!=": "ne"}


class OslLib:
    """The generated-helper half of the translator (mixed into its tree walker)."""

    helpers: dict
    structs: dict
    ex: Callable[[Any], tuple[str, Any]]        #: the tree walker's expression translator

    def osl_type(self, t: str) -> str:
        v = vec_type(t)
        if v and "struct cellgl_" + t not in self.helpers:
            fields = " ".join(f"{self.osl_type(v[0])} {c};" for c in XYZW[:v[1]])
            self.helpers["struct cellgl_" + t] = f"struct cellgl_{t} {{ {fields} }};"
        # uint keeps its 32 bits in an int, bool is an int
        return "cellgl_" + t if v else t if t in self.structs else {"uint": "int", "bool": "int"}.get(t, t)

    def helper(self, name: str, code) -> str:
        if name not in self.helpers:
            self.helpers[name] = code() if callable(code) else code
        return name

    def gen(self, name: str, ret: str, params, body) -> str:
        """:meth:`helper` ``name``: a one-line function returning GLSL type ``ret``, of ``params``
        (``[(GLSL type, name)]``), whose body is ``body`` (or ``body()``, made when first needed)."""
        def code():
            text = body() if callable(body) else body
            plist = ", ".join(f"{self.osl_type(t)} {n}" for t, n in params)
            return f"{self.osl_type(ret)} {name}({plist}) {{ {text} }}"
        return self.helper(name, code)

    def returns(self, t: str, parts) -> str:
        """The statement returning the vector of GLSL type ``t`` made of ``parts``."""
        return f"return {self.osl_type(t)}({', '.join(parts)});"

    def conv(self, expr: str, src: str, dst: str) -> str:
        """Scalar conversion of ``expr`` (OSL text of GLSL type ``src``) to GLSL type ``dst``."""
        if src == dst or (src in ("int", "uint") and dst in ("int", "uint")):
            return expr
        if dst == "float":
            return f"{self.u2f()}({expr})" if src == "uint" else f"float({expr})"
        if dst == "bool":
            return f"({expr} != 0)"
        if src == "bool":
            return expr
        if dst == "int":
            return f"int({expr})"
        if dst == "uint":
            return f"{self.f2u()}({expr})"
        raise TranslateError(f"OSL translation: no conversion from {src} to {dst}")

    def coerce(self, expr: str, src, dst) -> str:
        """:meth:`conv` to a scalar type ``dst`` from a non-vector ``src``, else ``expr`` as it is
        (vectors, arrays and structs are never converted implicitly; a struct to a scalar raises)."""
        if all(isinstance(t, str) and not vec_type(t) for t in (src, dst)) and dst not in self.structs:
            return self.conv(expr, src, dst)
        return expr

    def u2f(self) -> str:
        return self.helper("cellgl_u2f", (
            "// float(uint): the top 24 bits exactly, then one rounding with the low 8.\n"
            "float cellgl_u2f(int a) { return float((a >> 8) & 16777215) * 256.0 + float(a & 255); }"))

    def f2u(self) -> str:
        return self.helper("cellgl_f2u", (
            "// uint(float) for 0 <= x < 2^32.\n"
            "int cellgl_f2u(float x) { return x >= 2147483648.0 ? int(x - 2147483648.0) ^ (1 << 31) : int(x); }"))

    def float_bits(self) -> str:
        """``floatBitsToUint`` (OSL has no bit casts): the IEEE 754 fields of a finite float
        computed exactly (powers of two multiply and divide exactly; log2 only guesses the
        exponent, which is then corrected). -0.0 gives the bits of +0.0."""
        return self.helper("cellgl_float_bits", (
            "// 2^e, exactly (binary powering of 2 or 1/2), |e| < 256.\n"
            "float cellgl_pow2(int e) {\n"
            "    float b = e < 0 ? 0.5 : 2.0;\n"
            "    int n = abs(e);\n"
            "    float p = 1.0;\n"
            "    for (int i = 0; i < 8; i++) {\n"
            "        if ((n >> i) & 1)\n"
            "            p *= b;\n"
            "        b *= b;\n"
            "    }\n"
            "    return p;\n}\n\n"
            "// floatBitsToUint(x) for finite x: sign, biased exponent, mantissa.\n"
            "int cellgl_float_bits(float x) {\n"
            "    if (x == 0.0)\n"
            "        return 0;\n"
            "    int s = x < 0.0 ? (1 << 31) : 0;\n"
            "    float a = abs(x);\n"
            "    int e = clamp(int(floor(log2(a))), -149, 127);\n"
            "    float p = cellgl_pow2(e);\n"
            "    if (p > a) {\n"
            "        e -= 1;\n"
            "        p = cellgl_pow2(e);\n"
            "    } else if (e < 127 && p * 2.0 <= a) {\n"
            "        e += 1;\n"
            "        p = cellgl_pow2(e);\n"
            "    }\n"
            "    if (e < -126)           // subnormal: a = m 2^-149\n"
            "        return s | int(a * cellgl_pow2(126) * 8388608.0);\n"
            "    return s | ((e + 127) << 23) | int((a / p - 1.0) * 8388608.0);\n}"))

    def scalar_op(self, op: str, a: str, b: str, t: str) -> str:
        """``a op b`` for scalars of GLSL type ``t`` (both operands already of that type)."""
        if t == "uint":
            if op == ">>":
                name = self.helper("cellgl_srl", (
                    "// uint >>: a logical right shift of the int's bits.\n"
                    "int cellgl_srl(int a, int s) { return s == 0 ? a : (a >> s) & ((1 << (32 - s)) - 1); }"))
                return f"{name}({a}, {b})"
            if op in ("<", ">", "<=", ">="):
                return f"(({a}) ^ (1 << 31)) {op} (({b}) ^ (1 << 31))"
            if op in ("/", "%"):
                self.helper("cellgl_udiv", (
                    "// uint / and %, by long division on the int's bits.\n"
                    "int cellgl_udiv(int a, int b) {\n"
                    "    if (b < 0)          // b >= 2^31: the quotient is 0 or 1\n"
                    "        return (a ^ (1 << 31)) >= (b ^ (1 << 31)) ? 1 : 0;\n"
                    "    int q = 0; int r = 0;\n"
                    "    for (int i = 31; i >= 0; i--) {\n"
                    "        r = (r << 1) | ((a >> i) & 1);\n"
                    "        if ((r ^ (1 << 31)) >= (b ^ (1 << 31))) { r -= b; q |= 1 << i; }\n"
                    "    }\n    return q;\n}\n"
                    "int cellgl_umod(int a, int b) { return a - cellgl_udiv(a, b) * b; }"))
                return f"{'cellgl_udiv' if op == '/' else 'cellgl_umod'}({a}, {b})"
        if op == "^^":
            return f"(({a}) != ({b}))"
        return f"({a} {op} {b})"

    def vec_binary(self, op: str, ta: str, tb: str) -> tuple[str, str]:
        """Name and result type of the generated component-wise ``op`` on ``ta``, ``tb``."""
        va, vb = vec_type(ta), vec_type(tb)
        comp, n = va or vec_of(tb)
        rt = ("b" if op in COMPARISONS else {"float": "", "int": "i", "uint": "u", "bool": "b"}[comp]) + f"vec{n}"
        name = f"cellgl_{_OPNAME[op]}_{ta}_{tb}"
        self.gen(name, rt, [(ta, "a"), (tb, "b")], lambda: self.returns(rt, [
            self.scalar_op(op, f"a.{c}" if va else "a", f"b.{c}" if vb else "b", comp) for c in XYZW[:n]]))
        return name, rt

    # ------------------------------------------------------------------ expressions

    def sized(self, t: str, size) -> tuple:
        """The type of a name of GLSL type ``t`` and array size ``size`` (None: not an array) as
        the scopes hold it (an array: ``(t, size)``), and the ``[size]`` its declaration ends with
        (an integer constant expression, folded: OSL wants a literal)."""
        if size is None:
            return t, ""
        v = value(size, {})
        if v is None or v[0] not in ("int", "uint"):
            raise TranslateError("OSL translation: an array size that is not an integer constant")
        return (t, str(v[1])), f"[{v[1]}]"

    def vec_get(self, t: str) -> str:
        comp, n = vec_of(t)
        body = " ".join(f"if (i == {j}) return a.{c};" for j, c in enumerate(XYZW[:n - 1]))
        return self.gen(f"cellgl_get_{t}", comp, [(t, "a"), ("int", "i")], f"{body} return a.{XYZW[n - 1]};")

    def vec_set(self, t: str) -> str:
        comp, n = vec_of(t)
        ot, oc = self.osl_type(t), self.osl_type(comp)
        name = f"cellgl_set_{t}"
        body = " else ".join(f"if (i == {j}) a.{c} = x;" for j, c in enumerate(XYZW[:n - 1]))
        return self.helper(name, f"void {name}(output {ot} a, int i, {oc} x) {{ {body} else a.{XYZW[n - 1]} = x; }}")

    def any_all(self, fn: str, bt: str) -> str:
        j = " || " if fn == "any" else " && "
        return self.gen(f"cellgl_{fn}_{bt}", "int", [(bt, "a")],
                        f"return {j.join(f'a.{c}' for c in XYZW[:vec_of(bt)[1]])};")

    def call_builtin(self, fn: str, args: list):
        ev = [self.ex(a) for a in args]
        types = [t for _, t in ev]
        ss = [s for s, _ in ev]
        if fn in RELATIONAL:
            name, rt = self.vec_binary(RELATIONAL[fn], types[0], types[1])
            return f"{name}({ss[0]}, {ss[1]})", rt
        if fn in ("any", "all"):
            return f"{self.any_all(fn, types[0])}({ss[0]})", "bool"
        if fn in ("dot", "length", "distance", "normalize"):
            t = types[0]
            v = vec_type(t)
            if not v:
                return _SCALAR_GEOMETRY[fn].format(*ss), "float"
            dot = self.gen(f"cellgl_dot_{t}", "float", [(t, "a"), (t, "b")],
                           "return " + " + ".join(f"a.{c} * b.{c}" for c in XYZW[:v[1]]) + ";")
            if fn == "dot":
                return f"{dot}({ss[0]}, {ss[1]})", "float"
            if fn == "length":
                return f"sqrt({dot}({ss[0]}, {ss[0]}))", "float"
            if fn == "distance":
                sub, _ = self.vec_binary("-", t, t)
                name = self.gen(f"cellgl_distance_{t}", "float", [(t, "a"), (t, "b")],
                                f"{self.osl_type(t)} d = {sub}(a, b); return sqrt({dot}(d, d));")
                return f"{name}({ss[0]}, {ss[1]})", "float"
            mul, _ = self.vec_binary("*", t, "float")
            name = self.gen(f"cellgl_normalize_{t}", t, [(t, "a")], f"return {mul}(a, 1.0 / sqrt({dot}(a, a)));")
            return f"{name}({ss[0]})", t
        if fn in ("floatBitsToUint", "floatBitsToInt"):
            self.float_bits()
            t = types[0]
            v = vec_type(t)
            if not v:
                return f"cellgl_float_bits({ss[0]})", "uint" if fn.endswith("Uint") else "int"
            rt = ("u" if fn.endswith("Uint") else "i") + f"vec{v[1]}"
            name = self.gen(f"cellgl_{fn}_{t}", rt, [(t, "a")],
                            self.returns(rt, [f"cellgl_float_bits(a.{c})" for c in XYZW[:v[1]]]))
            return f"{name}({ss[0]})", rt
        if fn == "fract":
            self.helper("cellgl_fract", "float cellgl_fract(float x) { return x - floor(x); }")
        if fn == "atan" and len(ss) == 2:
            fn = "atan2"
        if fn in _ELEMENTWISE:
            osl = "cellgl_fract" if fn == "fract" else fn
            vt = next((t for t in types if vec_type(t)), None)
            if vt is None:
                rt = types[-1] if fn in ("step", "smoothstep") else types[0]
                if rt == "uint" and fn in ("min", "max", "clamp"):
                    raise TranslateError(f"OSL translation: {fn}() of uint")
                if "float" in types:
                    ss = [self.conv(s, t, "float") for s, t in zip(ss, types)]
                    rt = "float"
                return f"{osl}({', '.join(ss)})", rt
            name = self.gen(f"cellgl_{fn}_" + "_".join(types), vt, [(t, f"a{j}") for j, t in enumerate(types)],
                            lambda: self.returns(vt, [f"{osl}(" + ", ".join(f"a{j}.{c}" if vec_type(t) else f"a{j}"
                                                                           for j, t in enumerate(types)) + ")"
                                                      for c in XYZW[:vec_of(vt)[1]]]))
            return f"{name}({', '.join(ss)})", vt
        raise TranslateError(f"OSL translation: function {fn!r} has no OSL translation")
