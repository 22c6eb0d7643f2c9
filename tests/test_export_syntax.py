"""The typed syntax tree of the snippet compiler (cellgl/export/syntax.py): the nodes of a small
program, comments on their nodes, the GLSL printer, and parse(print(tree)) == tree on every
preset's code."""
from __future__ import annotations

import pytest

from cellgl.export import snippets, syntax as st
from cellgl.export.printer import print_glsl
from cellgl.export.translate.tokens import TranslateError

_SRC = """// A pair.
struct P {
    float a;     // the first
    vec2 b[2];
};

const float k = 2.0;
uniform int u_mode;

float f(float x);

// Scales x,
// twice.
float f(float x)
{
    // the factor
    float y = x * k, z;
    if (u_mode == 0) {
        y += 1.0;  // one more
    } else if (u_mode == 1) {
        y = -y;
    } else {
        return (y);
    }
    for (int i = 0; i < 2; i++)
        y *= 0.5;
    return u_mode > 1 ? y : float[2](y, x)[1];
}
"""


def test_the_tree_is_typed_and_keeps_comments():
    unit = st.parse(_SRC)
    struct, const, uniform, proto, func = unit.items
    assert struct == st.Struct("P", [st.Field("float", "a", None, [], "// the first"),
                                     st.Field("vec2", "b", st.Num("2"))], ["// A pair."])
    assert const == st.Global(["const"], "float", [st.Declarator("k", None, st.Num("2.0"))])
    assert uniform.quals == ["uniform"] and proto.body is None
    assert func.comments == ["// Scales x,", "// twice."]
    assert func.params == [st.Param("in", "float", "x")]
    decl, branch, loop, ret = func.body.body
    assert decl == st.Decl("float", [st.Declarator("y", None, st.Binary("*", st.Name("x"), st.Name("k"))),
                                     st.Declarator("z")], comments=["// the factor"])
    assert branch.then.body[0].trail == "// one more"
    assert isinstance(branch.other, st.If) and isinstance(branch.other.other, st.Block)
    assert branch.other.other.body[0] == st.Return(st.Paren(st.Name("y")))
    assert loop.step == st.IncDec("++", st.Name("i"), True)
    assert ret.value.other == st.Index(st.ArrayCtor("float", st.Num("2"), [st.Name("y"), st.Name("x")]),
                                       st.Num("1"))


def test_the_node_classes_come_from_one_table():
    # each dataclass is the module's name for it, with its fields in source order and fresh lists
    assert len(st.NODE_CLASSES) == 28 and all(getattr(st, c.__name__) is c for c in st.NODE_CLASSES)
    assert st.Num.__module__ == "cellgl.export.syntax" and st.Param.__match_args__ == (
        "mode", "type", "name", "size", "const")
    a, b = st.Decl("float", []), st.Decl("float", [])
    assert a == b and a.comments is not b.comments and (a.const, a.trail, a.same_line) == (False, "", False)
    assert st.Function("void", "f", [], None) == st.Function("void", "f", [], None, [])


def test_the_printer_writes_glsl_back():
    assert print_glsl(st.parse(_SRC)) == """// A pair.
struct P {
    float a;  // the first
    vec2 b[2];
};

const float k = 2.0;

uniform int u_mode;

float f(float x);

// Scales x,
// twice.
float f(float x)
{
    // the factor
    float y = x * k, z;
    if (u_mode == 0) {
        y += 1.0;  // one more
    } else if (u_mode == 1) {
        y = -y;
    } else {
        return (y);
    }
    for (int i = 0; i < 2; i++)
        y *= 0.5;
    return u_mode > 1 ? y : float[2](y, x)[1];
}
"""


def test_errors_name_the_construct():
    with pytest.raises(TranslateError, match="comma operator"):
        st.parse("void f() { int a = 1; a = 1, a = 2; }")
    with pytest.raises(TranslateError, match="expected ';'"):
        st.parse("float f() { return 1.0 }")


@pytest.mark.parametrize("name", ["f1", "flagstone", "hammered", "edge-cracks", "wood-grain", "caustics"])
def test_print_then_parse_is_the_same_tree(name):
    prog = snippets.texture_program(name)
    for text in (snippets.specialised_code(prog), snippets.library_code(prog)):
        tree = st.parse(text)
        assert st.parse(print_glsl(tree)) == tree


def test_the_parse_of_a_library_text_is_cached():
    prog = snippets.texture_program("f1")
    text = snippets.specialised_code(prog)
    assert st.parsed_library(text) is st.parsed_library(text)
    assert st.parsed_library(text) == st.parse(text)


def test_libraries_with_other_structs_share_the_declarations_that_name_none():
    twice = "float twice(float x)\n{\n    return 2.0 * x;\n}\n"
    uses = "A make(float x)\n{\n    return A(x);\n}\n"
    a = st.parsed_library("struct A\n{\n    float v;\n};\n" + twice + uses)
    b = st.parsed_library("struct A\n{\n    float v;\n};\nstruct B\n{\n    float v;\n};\n" + twice + uses)
    assert a.items[1] is b.items[2]                    # twice: parsed once
    assert a.items[2] is b.items[3] and isinstance(b.items[3].body.body[0].value, st.Ctor)
    c = st.parsed_library("struct C\n{\n    float v;\n};\n" + twice + uses)
    # A is no struct in c's library: its call parsed as one
    assert c.items[1] is a.items[1] and isinstance(c.items[2].body.body[0].value, st.Call)


# --------------------------------------------------------------------------------------------
# the target printers (cellgl/export/printer.py): one test per dialect hook, exact text
# --------------------------------------------------------------------------------------------

from cellgl.export.printer import Gles, Glsl, Hlsl, print_target  # noqa: E402

_TARGET_SRC = """// Pairs.
struct P {
    float a;     // the first
    uvec2 b[2];
};
const float k = 2.0;
uniform int u_mode;
// Sums.
float f(float x, out vec2 y)
{  // in one pass
    bool done = false;
    int n = 2; uint m = 3u;
    for (int i = 0; i < 2; i++)
    for (int j = 0; j < 2; j++) {
        x += float(i * j);
    }
    y = vec2(x);
    return x;
}
"""


def test_glsl_snippet_layout_keeps_the_library_s():
    # a function's brace on its signature line, no blank line between items, statements the
    # library pairs on one line stay paired, a loop nest stays one level, the comment after a
    # brace stays there
    assert print_target(st.parse(_TARGET_SRC), "glsl") == """// Pairs.
struct P {
    float a;  // the first
    uvec2 b[2];
};
const float k = 2.0;
uniform int u_mode;
// Sums.
float f(float x, out vec2 y) {  // in one pass
    bool done = false;
    int n = 2; uint m = 3u;
    for (int i = 0; i < 2; i++)
    for (int j = 0; j < 2; j++) {
        x += float(i * j);
    }
    y = vec2(x);
    return x;
}
"""
    assert print_target(st.parse(_TARGET_SRC), "godot") == print_target(st.parse(_TARGET_SRC), "glsl")


def test_gles_declarations_are_highp():
    # Gles.decl_type: members, globals, results, parameters, locals and loop counters of float,
    # int and uint types; not bool, not constructors
    assert Gles(kr=True, blank=False).unit(st.parse(_TARGET_SRC)) == """// Pairs.
struct P {
    highp float a;  // the first
    highp uvec2 b[2];
};
const highp float k = 2.0;
uniform highp int u_mode;
// Sums.
highp float f(highp float x, out highp vec2 y) {  // in one pass
    bool done = false;
    highp int n = 2; highp uint m = 3u;
    for (highp int i = 0; i < 2; i++)
    for (highp int j = 0; j < 2; j++) {
        x += float(i * j);
    }
    y = vec2(x);
    return x;
}
"""


def _hlsl_expr(src: str) -> str:
    (fn,) = st.parse(f"void f(vec4 a, vec4 b, float x) {{ x = {src}; }}").items
    return Hlsl().expr(fn.body.body[0].expr.value)


def test_hlsl_types_and_static_const():
    # Hlsl.type / decl_type, Hlsl.quals: vector types renamed everywhere, global const static
    assert print_target(st.parse(_TARGET_SRC), "hlsl").splitlines()[3:10] == [
        "    uint2 b[2];", "};", "static const float k = 2.0;", "uniform int u_mode;", "// Sums.",
        "float f(float x, out float2 y) {  // in one pass", "    bool done = false;"]


def test_hlsl_one_argument_vector_constructors_are_casts():
    # Hlsl.ctor: a splat or a conversion is a cast; more arguments stay a constructor
    assert _hlsl_expr("vec4(x)") == "((float4)(x))"
    assert _hlsl_expr("ivec2(a.xy)") == "((int2)(a.xy))"
    assert _hlsl_expr("vec3(a.xy, 1.0)") == "float3(a.xy, 1.0)"
    assert _hlsl_expr("uint(x)") == "uint(x)"


def test_hlsl_struct_and_array_constructors_are_initialiser_lists():
    # Hlsl.ctor (a struct) and Hlsl.array_ctor
    unit = st.parse("struct R { float d; };\nvoid f(float t) {\n float w[2] = float[2](t, 1.0);\n R r = R(w[0]);\n}")
    assert print_target(unit, "hlsl") == ("struct R {\n    float d;\n};\nvoid f(float t) {\n"
                                          "    float w[2] = {t, 1.0};\n    R r = {w[0]};\n}\n")


def test_hlsl_built_ins():
    # Hlsl.call: relational functions are operators (operands in parentheses only where they
    # bind looser), two-argument atan is atan2, renamed built-ins
    assert _hlsl_expr("float(lessThan(a + b, vec4(0.5)))") == "float((a + b < ((float4)(0.5))))"
    assert _hlsl_expr("float(equal(a == b ? a : b, a))") == "float(((a == b ? a : b) == a))"
    assert _hlsl_expr("atan(a.y, a.x) + atan(x)") == "atan2(a.y, a.x) + atan(x)"
    assert _hlsl_expr("fract(x) + mix(x, a.x, 0.5) + inversesqrt(x) + dFdx(x)") == \
        "frac(x) + lerp(x, a.x, 0.5) + rsqrt(x) + ddx(x)"


def test_hlsl_mod_has_glsl_floor_semantics():
    # Hlsl.call + Hlsl.prelude: mod is cellgl_mod, x - y * floor(x / y), defined before the code
    out = print_target(st.parse("float f(float x) { return mod(x, 2.0); }"), "hlsl").splitlines()
    assert out[0] == "// GLSL mod(): x - y * floor(x / y) (HLSL's fmod truncates instead)."
    assert out[1] == "float cellgl_mod(float x, float y) { return x - y * floor(x / y); }"
    assert out[-3:] == ["float f(float x) {", "    return cellgl_mod(x, 2.0);", "}"]
    assert "cellgl_mod" not in print_target(st.parse("float f(float x) { return x; }"), "hlsl")


def test_hlsl_reserved_names_and_what_has_no_translation():
    # Hlsl.name: names HLSL reserves get a _; Hlsl._check: what it cannot express is an error
    assert print_target(st.parse("float f(float sample) { return sample; }"), "hlsl") == \
        "float f(float sample_) {\n    return sample_;\n}\n"
    for src, what in (("void f() { discard; }", "discard"), ("void f(mat2 m) { }", "mat2"),
                      ("vec4 f() { return gl_FragCoord; }", "gl_FragCoord")):
        with pytest.raises(TranslateError, match=what):
            print_target(st.parse(src), "hlsl")
    with pytest.raises(TranslateError, match="lessThan needs 2 arguments"):
        _hlsl_expr("float(lessThan(a))")


def test_the_printers_keep_the_tree():
    # print_target reads the tree only: the same text twice, the tree unchanged
    unit = st.parse(_TARGET_SRC)
    before = st.parse(_TARGET_SRC)
    assert print_target(unit, "hlsl") == print_target(unit, "hlsl") and unit == before
    assert Glsl().unit(unit) == print_glsl(unit)


def test_wgsl_printer_hooks():
    # Wgsl (translate/wgsl.py): WGSL types and declarations, out/inout parameters as pointers
    # (callers pass them on or take &x), an assigned parameter copied into a var, operands of
    # mixed operators parenthesised, shift counts u32, loop bodies braced, ternaries as select,
    # mod as a helper, the comments kept
    from cellgl.export.translate.wgsl import to_wgsl

    src = """struct P {
    float a;  // the first
};
const float k = 2.0;
void g(inout vec2 y, float s) {
    y.x += s;
}
// Sums.
float f(float x, out vec2 y) {
    x *= k;  // scaled
    y = vec2(x);
    g(y, x);
    bool b = x > 1.0 && x < 2.0 || x == 0.0;
    uint h = 3u << uint(x) >> 2u;
    for (int i = 0; i < 2; i++)
        x += float(i);
    return b ? -(x + 1.0) : mod(x, 2.0);
}
"""
    assert to_wgsl(st.parse(src)) == """// GLSL mod(): x - y * floor(x / y).
fn cellgl_mod(x: f32, y: f32) -> f32 { return x - y * floor(x / y); }
struct P {
    a: f32,  // the first
};
const k: f32 = 2.0;
fn g(y: ptr<function, vec2<f32>>, s: f32) {
    (*y).x += s;
}
// Sums.
fn f(x_in: f32, y: ptr<function, vec2<f32>>) -> f32 {
    var x: f32 = x_in;
    x *= k;  // scaled
    *y = vec2<f32>(x);
    g(y, x);
    var b: bool = ((x > 1.0) && (x < 2.0)) || (x == 0.0);
    var h: u32 = (3u << u32(u32(x))) >> 2u;
    for (var i: i32 = 0; i < 2; i++) {
        x += f32(i);
    }
    return select(cellgl_mod(x, 2.0), -(x + 1.0), b);
}
"""
    with pytest.raises(TranslateError, match="uniforms need bindings"):
        to_wgsl(st.parse("uniform float u;"))


def test_the_tree_keeps_the_library_s_layout_marks():
    # the comment after a block's brace is its trail; a statement on the line of the one before
    # it is same_line (not one after a brace or an else)
    (fn,) = st.parse("void f(int a) {  // one\n    a += 1; a -= 2;\n    if (a > 0) { a = 0; } else a = 1;\n}\n").items
    assert fn.body.trail == "// one"
    first, second, branch = fn.body.body
    assert (first.same_line, second.same_line) == (False, True)
    assert branch.then.body[0].same_line is False and branch.other.same_line is False
