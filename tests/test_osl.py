"""The OSL translator and the OSL export's text: types OSL lacks become structs and helpers,
unsigned arithmetic is emulated on int, the shader exposes the recipe's values with slider
metadata. (Compilation and renders in Blender's Cycles: tests/test_blender.py.)"""
from __future__ import annotations

import re

import pytest

from cellgl.export import translate
from cellgl.export.snippets import ExportError, export
from cellgl.recipes import load_recipe
from cellgl.texture.params import PARAMS_BY_NAME


def test_unsigned_operations_are_emulated():
    glsl = (
        "uint f(uint x, uint y)\n{\n"
        "    x ^= x >> 16;\n"
        "    x *= 0x846ca68bu;\n"
        "    bool lt = x < y;\n"
        "    float g = float(x);\n"
        "    uint q = x / y;\n"
        "    return lt ? q % y : uint(g);\n"
        "}\n"
    )
    osl = translate.to_osl(glsl)
    body = osl[osl.index("int f("):]
    assert "cellgl_srl(x, 16)" in body                  # logical shift
    assert "(-2073254261)" in body                       # 0x846ca68b as the same 32 bits
    assert "((x) ^ (1 << 31)) < ((y) ^ (1 << 31))" in body
    assert "cellgl_u2f(x)" in body and "cellgl_udiv(x, y)" in body and "cellgl_umod(q, y)" in body
    assert "cellgl_f2u(g)" in body
    assert not re.search(r"\b(uint|bool)\b", re.sub(r"//[^\n]*", "", osl))
    # the input x is assigned: copied into a local (OSL inputs are read-only)
    assert "int f(int x_in, int y)" in osl and "int x = x_in;" in osl


def test_vectors_become_structs_with_generated_operations():
    glsl = (
        "vec4 g(vec4 a, ivec4 c, inout vec2 o)\n{\n"
        "    vec4 b = a * 2.0 + vec4(c);\n"
        "    o = b.xy;\n"
        "    b[1] = -a.w;\n"
        "    return floor(b) - mix(a, b, 0.5);\n"
        "}\n"
    )
    osl = translate.to_osl(glsl)
    assert "struct cellgl_vec4 { float x; float y; float z; float w; };" in osl
    assert "struct cellgl_ivec4 { int x; int y; int z; int w; };" in osl
    assert "output cellgl_vec2 o" in osl
    for helper in ("cellgl_mul_vec4_float", "cellgl_add_vec4_vec4", "cellgl_make_vec4_ivec4",
                   "cellgl_swizzle_vec4_xy", "cellgl_set_vec4", "cellgl_floor_vec4",
                   "cellgl_mix_vec4_vec4_float", "cellgl_sub_vec4_vec4"):
        assert re.search(rf"\b{helper}\(", osl), helper
    assert not re.search(r"\b[iub]?vec[234]\b", osl.replace("cellgl_", "X"))


def test_unsupported_constructs_are_named():
    with pytest.raises(translate.TranslateError, match="dFdx"):
        translate.to_osl("vec2 f(vec2 uv) { return dFdx(uv); }\n")
    with pytest.raises(translate.TranslateError, match="swizzle"):
        translate.to_osl("void f(inout vec4 a) { a.xy = vec2(1.0); }\n")


def test_statements_printed_as_glsl_and_unreachable_ones_left_out():
    """OSL's statements are printer.Glsl's (``} else {``, a trailing comment kept); statements
    after one that always leaves the block (here a block ending in a return) are left out."""
    glsl = ("float f(float x)\n{\n    float y = x * 2.0;  // twice\n"
            "    if (x > 0.0) {\n        y += 1.0;\n    } else {\n        y -= 1.0;\n    }\n"
            "    {\n        return y;\n    }\n    y = 3.0;\n    return y;\n}\n")
    assert translate.to_osl(glsl) == (
        "\nfloat f(float x) {\n    float y = (x * 2.0);  // twice\n"
        "    if ((x > 0.0)) {\n        y += 1.0;\n    } else {\n        y -= 1.0;\n    }\n"
        "    {\n        return y;\n    }\n}\n")


def test_osl_export_declares_parameters_outputs_and_coordinates():
    text = export("flagstone", "osl")
    r = load_recipe("flagstone")
    head = text[text.index("shader cellgl_flagstone("):]
    assert "point Vector = point(0, 0, 0)" in head
    assert '!isconnected(Vector) && !getattribute("geom:generated", q0)' in head   # generated coords
    assert "q0 = point(u, v, 0);" in head
    m = re.search(r"float frequency = ([0-9.e+-]+) \[\[ (.*?) \]\]", head)
    assert m and float(m.group(1)) == pytest.approx(r.values["frequency"])
    p = PARAMS_BY_NAME["frequency"]
    assert 'string label = "Frequency"' in m.group(2)
    assert f"float min = {float(p.lo)!r}" in m.group(2) and f"float max = {float(p.hi)!r}" in m.group(2)
    assert re.search(r"int invert = 0 \[\[.*string widget = \"checkBox\"", head)
    for out in ("output color Color", "output float Fac", "output float F1", "output float F4",
                "output color CellColor", "output float IDLow", "output float IDHigh",
                "output normal Normal = N"):
        assert out in head, out
    # no parameter shadows OSL's globals; values derived on the CPU stay constants
    params = re.findall(r"^\s+(?:output )?\w+ (\w+) = ", head, re.M)
    assert "P" not in params and "N" not in params and "time" not in params
    assert "density" not in params and "offset_x" not in params and "seed" not in params


def test_osl_refusals():
    with pytest.raises(ExportError, match="PUPs"):
        export("pups-cow", "osl")
    with pytest.raises(ExportError, match="image"):
        export("stained-glass", "osl")
    with pytest.raises(ExportError, match="uniforms"):
        export("f1", "osl", uniforms=True)


def test_osl_is_folded_but_for_exactly_its_sliders():
    """The OSL shader is folded like the other targets (only what the outputs reach, the recipe's
    other values written in), and its parameters are exactly the recipe values the folded code
    still reads: every slider is read (passed down to the functions that use it), and a value
    that is not a slider is no function's parameter."""
    from cellgl.export import osl, snippets

    for name in ("flagstone", "edge-cracks", "f1"):
        text = export(name, "osl")
        head = text[text.index("\nshader cellgl_"):]
        body = text[text.index("\nstruct "):text.index("\nshader cellgl_")]
        sliders = re.findall(r"^    (?:float|int) (\w+) = [^\[\n]*\[\[", head, re.M)
        prog = snippets.texture_program(name)
        exposed = osl.exposed_params(prog, snippets.specialised_code(prog))
        _, kept = osl.folded_code(prog, exposed, snippets.specialised_code, snippets.CONSTANT_STRUCTS)
        assert [osl._pname(p.name) for p, _ in kept] == sliders
        for s in sliders:
            assert re.search(rf"\bcellgl_{s.rstrip('_')}\b", body), (name, s)       # each one is read
        for _typ, pname, _ in prog.uniforms:
            if pname not in [p.name for p, _ in kept]:      # folded in, or a named constant
                assert not re.search(rf"[(,] *(?:float|int) cellgl_{pname}\b", body), (name, pname)
        assert "cellgl_texture_params_load" not in body and "CellglTextureParams" not in body
    # a term switched off in the recipe is no slider (its code folds away)
    flag = export("flagstone", "osl")
    code = flag[flag.index("\nstruct "):]
    assert "warp_amount" not in code and "c_noise" not in code
