"""The snippet compiler's passes one by one (cellgl/export/), each on a small GLSL input with the
exact text it must give: beside the end-to-end tests (tests/test_export.py,
tests/test_export_compiler.py), which check that whole snippets compute what the bakes do."""
from __future__ import annotations

import pytest

from cellgl.export import compiler
from cellgl.export.fold import _local_constants, fold
from cellgl.export.reach import parse, unparse
from cellgl.export.simplify import _arithmetic
from cellgl.export.translate.tokens import TranslateError, tokenize


def _text(toks) -> str:
    return "".join(t.text for t in toks)


# --------------------------------------------------------------------------------------------
# identities: only those that hold for every IEEE-754 value
# --------------------------------------------------------------------------------------------

_IDENTITIES = """float f(float x, float y, vec4 s, ivec4 c) {
    x *= 1.0;
    x -= 0.0;
    x += 0.0;
    x += 0.0 * y;
    float a = x * 1.0 + y - 0.0;
    float b = x + 0.0;
    float m = mix(x, y, 0.0);
    float n = mix(x, y, 1.0);
    float k = mix(2.0, y, 1.0);
    vec4 q = vec4(0.0, 0.0, 0.0, 0.0) + s;
    ivec4 d = ivec4(0, 0, 0, 0) + c;
    float e = abs(x) * abs(x);
    return a + b + m + n + k + q.x + float(d.x) + e;
}
"""


def test_identities_hold_for_every_ieee754_value():
    """Rewritten: x * 1.0, x *= 1.0, x - 0.0, x -= 0.0, mix(a, b, 0.0), mix(2.0, b, 1.0) (a
    finite literal), |x| |x|, integer zero vectors added. Kept: x + 0.0 and x += 0.0 (-0.0 + 0.0
    is +0.0), x += 0.0 * y (NaN for an infinite y), mix(x, y, 1.0) (x * 0.0: NaN for an
    infinite x), a float zero vector added (-0.0 again)."""
    out = _text(_arithmetic(tokenize(_IDENTITIES)))
    assert out == """float f(float x, float y, vec4 s, ivec4 c) {
    x += 0.0;
    x += 0.0 * y;
    float a = x + y;
    float b = x + 0.0;
    float m = x;
    float n = mix(x, y, 1.0);
    float k = y;
    vec4 q = vec4(0.0, 0.0, 0.0, 0.0) + s;
    ivec4 d = c;
    float e = x * x;
    return a + b + m + n + k + q.x + float(d.x) + e;
}
"""


@pytest.mark.parametrize("x", [0.0, -0.0, 1.5, -2.25, float("inf"), float("-inf"), float("nan"), 5e-324])
def test_the_kept_forms_are_not_identities_but_the_rewritten_are(x):
    """The reason, in numbers (NumPy float32, as the GPU computes). (``mix(a, b, 0.0)`` -> ``a``
    is rewritten as issue 30 rules, the blend weight 0 selecting ``a``; GLSL's formula
    a (1 - t) + b t would give +0.0 for a = -0.0 and NaN for an infinite b.)"""
    np = pytest.importorskip("numpy")
    f = np.float32
    same = lambda a, b: np.array(a, np.float32).tobytes() == np.array(b, np.float32).tobytes() \
        or (np.isnan(a) and np.isnan(b))                       # noqa: E731
    with np.errstate(all="ignore"):
        assert same(f(x) * f(1.0), f(x)) and same(f(x) - f(0.0), f(x)) and same(f(x) / f(1.0), f(x))
        assert same(abs(f(x)) * abs(f(x)), f(x) * f(x))
    with np.errstate(all="ignore"):
        assert not same(f(-0.0) + f(0.0), f(-0.0))                      # x + 0.0
        assert not same(f(1.0) + f(0.0) * f(np.inf), f(1.0))            # x + 0.0 * y
        assert not same(f(np.inf) * f(0.0) + f(1.0) * f(1.0), f(1.0))   # mix(inf, 1, 1.0)


# --------------------------------------------------------------------------------------------
# constant folding of locals
# --------------------------------------------------------------------------------------------


def test_a_field_named_like_a_local_does_not_stop_its_folding():
    """``o.w`` passed to a call is a field read, not the local ``w`` (which may be an out
    argument): ``w`` = 1.0 for good is still a constant."""
    toks = tokenize("""void f(inout vec4 o) {
    float w = 1.0;
    o.x += w;
    o.y = g(o.w, 2.0);
}""")
    assert _local_constants(toks, {}) == {"w": "1.0"}
    assert _local_constants(tokenize("void f(inout vec4 o) {\n    float w = 1.0;\n    g(w);\n}"), {}) == {}


def test_fold_removes_the_branch_a_constant_condition_rules_out():
    items = parse("""const int k_mode = 1;
float f(float x) {
    if (k_mode == 0) {
        x = 2.0 * x;
    } else {
        x += 1.5;
    }
    return x;
}
""")
    out = unparse(fold(items, {"k_mode": "1"}))
    assert out == """const int k_mode = 1;

float f(float x) {
    x += 1.5;
    return x;
}
"""


# --------------------------------------------------------------------------------------------
# the pass driver: a fixed point, or an error
# --------------------------------------------------------------------------------------------


def test_the_driver_stops_at_the_fixed_point():
    src = "float g(float x) {\n    return x * 2.0;\n}\nfloat entry(float x) {\n    return g(x) - 0.0;\n}\n"
    out = compiler.compile_glsl(src, ["entry"])
    assert compiler.compile_glsl(out, ["entry"]) == out          # a second run changes nothing
    assert out == "float entry(float x)\n{\n    return x * 2.0;\n}\n"


def test_the_driver_raises_when_the_passes_do_not_settle(monkeypatch):
    """A pass that changes the tree every round (here: one that adds a declaration each time)
    makes the driver raise, naming its round limit and the pass."""
    import itertools

    from cellgl.export.syntax import parse as parse_tree
    from cellgl.export.tree import tree_pass
    rounds = itertools.count()

    @tree_pass
    def growing(unit, ctx):
        unit.items += parse_tree(f"const float k_{next(rounds)} = 1.0;\n").items
        return True
    monkeypatch.setattr(compiler, "ROUND", compiler.ROUND + [growing])
    with pytest.raises(TranslateError, match=f"did not settle in {compiler.MAX_ROUNDS} rounds.*growing"):
        compiler.compile_glsl("float entry(float x) {\n    return x;\n}\n", ["entry"])


# --------------------------------------------------------------------------------------------
# reachability, scalarising, parameters, inlining, void results, dead stores
# --------------------------------------------------------------------------------------------

_PARAMS = """float f(float x, float y, int k)
{
    return x * float(k);
}
float entry(float a)
{
    return f(a, 2.0, 3) + f(a * a, 1.0, 3);
}
"""


def test_parameters_never_read_go_and_constant_arguments_move_in():
    dropped = compiler._drop_unused_params(parse(_PARAMS), {"entry"})
    assert unparse(dropped) == """float f(float x, int k)
{
    return x * float(k);
}

float entry(float a)
{
    return f(a, 3) + f(a * a, 3);
}
"""
    assert unparse(compiler._constant_args(dropped, {"entry"})) == """float f(float x)
{
    return x * float(3);
}

float entry(float a)
{
    return f(a) + f(a * a);
}
"""


def test_a_function_called_once_is_inlined():
    from cellgl.export.inline import inline_once

    src = """void g(inout float v, float x)
{
    v += x;
    v *= 0.5;
}
float entry(float a)
{
    float v = a;
    g(v, 3.0);
    return v;
}
"""
    assert unparse(inline_once(parse(src), {"entry"})) == """float entry(float a)
{
    float v = a;
    v += 3.0;
    v *= 0.5;
    return v;
}
"""


def test_a_result_no_call_reads_becomes_void():
    from cellgl.export.fields import void_results

    items = parse("""float h(inout float w, float x)
{
    w = w + x;
    return w * 2.0;
}
float entry(float a)
{
    float w = a;
    h(w, 1.0);
    h(w, 2.0);
    return w;
}
""")
    out = unparse(void_results(items, {"entry"}, compiler._impure_functions(items)))
    assert out.startswith("void h(inout float w, float x)\n{\n    w = w + x;\n}\n")


def test_a_local_only_written_goes():
    from cellgl.export.simplify import _dead_store

    toks = tokenize("float entry(float a)\n{\n    float b = a * 2.0;\n    float c = a + 1.0;\n"
                    "    c = a - 1.0;\n    return b;\n}\n")
    assert _text(_dead_store(toks, set())) == "float entry(float a)\n{\n    float b = a * 2.0;\n    return b;\n}\n"


# --------------------------------------------------------------------------------------------
# reachability, parameter structs, comments, order and lines (reach.py, compiler.py's driver)
# --------------------------------------------------------------------------------------------

_STRUCT = """struct P {
    float gain;
    int mode;
};
const float k_gain = 2.0;
const int k_mode = 1;
P load()
{
    P t;
    t.gain = k_gain;
    t.mode = k_mode;
    return t;
}
float scale(float x, P t)
{
    return x * t.gain + float(t.mode);
}
float unused(float x)
{
    return x;
}
float entry(float x)
{
    return scale(x, load());
}
"""


def _tree_pass(fn, text, **ctx):
    from cellgl.export.printer import print_glsl
    from cellgl.export.syntax import parse as parse_tree
    from cellgl.export.tree import Context

    unit = parse_tree(text)
    changed = fn(unit, Context(**ctx).refresh(unit))
    return changed, print_glsl(unit)


def test_reach_keeps_what_the_entry_uses():
    from cellgl.export.reach import reach

    changed, out = _tree_pass(reach, _STRUCT, entries=("scale",))
    assert changed and out == """struct P {
    float gain;
    int mode;
};

float scale(float x, P t)
{
    return x * t.gain + float(t.mode);
}
"""
    assert _tree_pass(reach, out, entries=("scale",)) == (False, out)


def test_scalarise_reads_the_loaders_values_directly():
    from cellgl.export.reach import scalarise

    changed, out = _tree_pass(scalarise, _STRUCT, structs=(("P", "load"),))
    assert changed and out.endswith("""float scale(float x)
{
    return x * k_gain + float(k_mode);
}

float unused(float x)
{
    return x;
}

float entry(float x)
{
    return scale(x);
}
""")


def test_scalarise_keeps_the_fields_the_loader_computes():
    """A field the loader computes from its parameter stays in the struct (and the loader); the
    others are read as the constants (an expression in parentheses) and leave both."""
    from cellgl.export.reach import scalarise

    src = _STRUCT.replace("t.mode = k_mode;", "t.mode = k_mode + m;").replace("P load()", "P load(int m)") \
        .replace("load()", "load(2)").replace("const int k_mode", "const float k_off = 0.5;\nconst int k_mode") \
        .replace("t.gain = k_gain;", "t.gain = k_gain * k_off;")
    changed, out = _tree_pass(scalarise, src, structs=(("P", "load"),))
    assert changed and out.startswith("""struct P {
    int mode;
};

const float k_gain = 2.0;

const float k_off = 0.5;

const int k_mode = 1;

P load(int m)
{
    P t;
    t.mode = k_mode + m;
    return t;
}

float scale(float x, P t)
{
    return x * (k_gain * k_off) + float(t.mode);
}
""")
    assert _tree_pass(scalarise, out, structs=(("P", "load"),)) == (False, out)


def test_scalarise_leaves_a_struct_stored_into_elsewhere_alone():
    from cellgl.export.reach import scalarise

    src = _STRUCT.replace("    return x * t.gain", "    t.gain = 1.0;\n    return x * t.gain")
    assert _tree_pass(scalarise, src, structs=(("P", "load"),))[0] is False
    src = _STRUCT.replace("    return scale(x, load());", "    P q;\n    return scale(x, q);")
    assert _tree_pass(scalarise, src, structs=(("P", "load"),))[0] is False


def test_comments_a_declaration_keeps_the_first_sentence_of_its_own():
    from cellgl.export.printer import print_glsl
    from cellgl.export.reach import strip_body_comments, tidy_comments
    from cellgl.export.syntax import parse as parse_tree

    unit = parse_tree("""// ---- a file banner

// Scale x by the gain (e.g. 2). Then more words
// that the snippet does not need.
float scale(float x)
{
    // a comment line in the body
    float y = x * 2.0;  // after the statement

    return y;
}
// trailing
""")
    strip_body_comments(unit)
    assert print_glsl(unit) == """// Scale x by the gain (e.g. 2). Then more words
// that the snippet does not need.
float scale(float x)
{
    float y = x * 2.0;  // after the statement
    return y;
}
"""
    tidy_comments(unit, width=30)
    assert print_glsl(unit).startswith("// Scale x by the gain (e.g.\n// 2).\nfloat scale(float x)\n")


def test_first_sentence_stops_at_a_clause_when_the_sentence_is_long():
    from cellgl.export.reach import first_sentence

    assert first_sentence("// The cell of p. Its id.", 120) == "The cell of p."
    long = "// The cell: " + "word " * 60 + "end."
    assert first_sentence(long, 40) == "The cell."


def test_ordered_puts_each_declaration_after_what_it_uses():
    from cellgl.export.printer import print_lines
    from cellgl.export.syntax import parse as parse_tree

    unit = parse_tree("float f(float x)\n{\n    return x * k;\n}\nconst float k = g;\nconst float g = 2.0;\n"
                      "float h()\n{\n    return f(k);\n}\n")
    assert print_lines(type(unit)(compiler._ordered(unit.items))) == (
        "const float g = 2.0;\nconst float k = g;\nfloat f(float x)\n{\n    return x * k;\n}\n"
        "float h()\n{\n    return f(k);\n}\n")


def test_a_statement_longer_than_the_width_is_broken_where_it_reads_well():
    from cellgl.export.printer import _wrap as wrap
    assert wrap("    x = f(aaaa, bbbb);", 30) == ["    x = f(aaaa, bbbb);"]
    assert wrap("    x = f(aaaa, bbbb, cccc);", 24) == ["    x = f(aaaa, bbbb,", "          cccc);"]
    assert wrap("    if (aaaa && bbbbbb && cccc) {", 26) == ["    if (aaaa && bbbbbb", "        && cccc) {"]
    assert wrap("    x = 1.0;  // a long comment past the width", 20) == ["    x = 1.0;  // a long comment past the width"]


def test_text_passes_run_on_the_tree_through_the_bridge():
    from cellgl.export.reach import Item
    from cellgl.export.syntax import parse as parse_tree
    from cellgl.export.tree import Context

    def rename(items, ctx):
        return [Item(it.kind, it.name, [t if t.text != "g" else type(t)("id", "h") for t in it.toks], it.comment)
                for it in items]

    unit = parse_tree("float g(float x)\n{\n    return x;\n}\nfloat entry(float x)\n{\n    return g(x);\n}\n")
    bridged = compiler.text_passes(rename)
    assert bridged.tree_pass and bridged(unit, Context()) is True
    assert [it.name for it in unit.items] == ["h", "entry"]
    assert bridged(unit, Context()) is False
