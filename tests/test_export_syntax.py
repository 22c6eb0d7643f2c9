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


def test_a_comment_after_an_opening_brace_stays():
    src = "float f(float x) {\n    if (x > 1.0) {    // its window\n        x = 2.0;\n    }\n    return x;\n}\n"
    assert print_glsl(st.parse(src)) == ("float f(float x)\n{\n    if (x > 1.0) {\n        // its window\n"
                                         "        x = 2.0;\n    }\n    return x;\n}\n")
