"""The snippet compiler's passes one by one (cellgl/export/), each on a small GLSL input with the
exact text it must give: beside the end-to-end tests (tests/test_export.py,
tests/test_export_compiler.py), which check that whole snippets compute what the bakes do."""
from __future__ import annotations

import pytest

from cellgl.export import compiler
from cellgl.export import fold as F
from cellgl.export import simplify as SP
from cellgl.export.printer import print_glsl
from cellgl.export.reach import parse, unparse
from cellgl.export.syntax import parse as parse_tree
from cellgl.export.translate.tokens import TranslateError
from cellgl.export.tree import Context
from cellgl.export.values import value


def _run(tree_pass, src: str, entries=("f",)) -> str:
    """The GLSL ``tree_pass`` makes of ``src`` (the pass must change it)."""
    unit = parse_tree(src)
    assert tree_pass(unit, Context(tuple(entries)).refresh(unit))
    return print_glsl(unit)


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
    assert _run(SP.identities, _IDENTITIES) == """float f(float x, float y, vec4 s, ivec4 c)
{
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
    """``o.w`` passed to a call is a field read, not the local ``w``: ``w`` = 1.0 for good is a
    constant; ``z`` passed to an ``inout`` parameter is not."""
    assert _run(F.local_constants, """void g(inout float v) {
    v += 1.0;
}
void f(inout vec4 o) {
    float w = 1.0;
    float z = 1.0;
    int n = 2 * 3;
    o.x += w + float(n);
    o.y = h(o.w, 2.0);
    g(z);
    o.z = z;
}
""").endswith("""void f(inout vec4 o)
{
    float w = 1.0;
    float z = 1.0;
    int n = 2 * 3;
    o.x += 1.0 + float(6);
    o.y = h(o.w, 2.0);
    g(z);
    o.z = z;
}
""")


def test_fold_removes_the_branch_a_constant_condition_rules_out():
    """The whole folding (the recipe's switch written in, the branch chosen, the dead local and
    the ternary gone)."""
    assert _run(compiler._fold, """const int k_mode = 1;
const float k_gain = 0.5;
float f(float x) {
    if (k_mode == 0) {
        x = 2.0 * x;
    } else {
        x += 1.5;
    }
    bool big = k_gain > 0.25 && x > 1.0;
    return k_mode == 1 ? x : (k_gain < 1.0 ? 0.0 : x);
}
""").endswith("""float f(float x)
{
    x += 1.5;
    return x;
}
""")


# --------------------------------------------------------------------------------------------
# the folding and simplification passes on the tree (cellgl/export/fold.py, simplify.py)
# --------------------------------------------------------------------------------------------

def test_values_are_computed_as_glsl_does():
    """32-bit integers wrap, floats are binary32 (2^24 + 1 rounds to 2^24), integer division of
    negatives and float overflow are left alone."""
    e = lambda text: value(parse_tree(f"bool b = {text};").items[0].declarators[0].init, {})   # noqa: E731
    assert e("2147483647 + 1") == ("int", -2147483648)
    assert e("0xffffffffu * 3u") == ("uint", 4294967293)
    assert e("16777217.0 == 16777216.0") == ("bool", True)
    assert e("0.1 + 0.2") == ("float", 0.30000001192092896)
    assert e("-7 / 2") is None and e("3.0e38 * 10.0") is None
    assert e("x && false") == ("bool", False) and e("g(x) && false") is None     # (g may have effects)


def test_constant_conditions_keep_the_branch_taken():
    assert _run(F.constant_conditions, """float f(float x, bool c) {
    bool qin = 0 == 2 || 0 == 3;
    float rest[8 + 1];
    if (true && c) {
        x = 1.0;
    } else if (3.0e38 >= 3.0e38) {
        x = 2.0;
    }
    return (0.5 < 0.25 ? x : 2.0) + rest[2 - 1];
}
""") == """float f(float x, bool c)
{
    bool qin = false;
    float rest[9];
    if (c) {
        x = 1.0;
    } else {
        x = 2.0;
    }
    return (2.0) + rest[1];
}
"""


def test_constant_loops_go_or_become_their_body():
    """No iteration: removed; one (an early ``if (i >= 1) break;`` bounding it): the body with
    the counter's value; two: kept."""
    assert _run(F.constant_loops, """float f(float x) {
    for (int k = 1 - 1; k > 0; k--) {
        x += 1.0;
    }
    for (int i = 0; i < 8; i++) {
        if (i >= 1) {
            break;
        }
        x *= float(i + 2);
    }
    for (int j = 0; j < 2; j++) {
        x += float(j);
    }
    return x;
}
""") == """float f(float x)
{
    {
        x *= float(0 + 2);
    }
    for (int j = 0; j < 2; j++) {
        x += float(j);
    }
    return x;
}
"""


def test_a_guarded_loop_runs_over_its_guard():
    assert _run(F.loop_ranges, """int f(uint u) {
    int count = 1;
    for (int k = 0; k < 16; k++) {
        count += (k >= 1 && k < 9 && u >= 100u) ? 1 : 0;
    }
    return count;
}
""") == """int f(uint u)
{
    int count = 1;
    for (int k = 1; k < 9; k++) {
        count += (u >= 100u) ? 1 : 0;
    }
    return count;
}
"""


def test_elements_of_constant_arrays_are_read_in_place():
    """At a literal index; at any index where all are equal."""
    assert _run(F.array_elements, """const vec4 k_frac[3] = vec4[3](vec4(0.0), vec4(0.0), vec4(0.0));
const int k_steps[3] = int[3](1, 4, 9);
vec4 f(int i) {
    return k_frac[i] + float(k_steps[1] + k_steps[i]);
}
""").endswith("""vec4 f(int i)
{
    return vec4(0.0) + float(4 + k_steps[i]);
}
""")


def test_the_recipes_switches_are_written_into_the_code():
    """Booleans, integers, 0.0 and 1.0; other floats keep their names."""
    assert _run(F.inline_constants, """const int k_mode = 2;
const float k_one = 1.0;
const float k_gain = 0.5;
float f(float x) {
    return k_mode == 2 ? x * k_one : x * k_gain;
}
""").endswith("""float f(float x)
{
    return 2 == 2 ? x * 1.0 : x * k_gain;
}
""")


def test_a_local_only_written_goes():
    assert _run(SP.dead_locals, """float f(float a) {
    float b = a * 2.0;
    float c = a + 1.0;
    c = a - 1.0;
    return b;
}
""") == """float f(float a)
{
    float b = a * 2.0;
    return b;
}
"""


def test_a_store_nothing_reads_afterwards_goes():
    """Not inside a loop (the next pass reads it)."""
    assert _run(SP.last_stores, """float f(float a) {
    float b = a * 2.0;
    float r = b;
    for (int k = 0; k < 3; k++) {
        r += b;
        b *= 2.0;
    }
    a = 0.0;
    return r;
}
""") == """float f(float a)
{
    float b = a * 2.0;
    float r = b;
    for (int k = 0; k < 3; k++) {
        r += b;
        b *= 2.0;
    }
    return r;
}
"""


def test_a_copy_is_its_source():
    """``t = s`` stays: ``s`` is written after it."""
    assert _run(SP.copies, """float f(float a, inout float s) {
    float b = a;
    float t = s;
    s = 2.0;
    return b * b + t;
}
""") == """float f(float a, inout float s)
{
    float t = s;
    s = 2.0;
    return a * a + t;
}
"""
    assert _run(SP.copies, """uniform int k_count;
int f(int a) {
    int n = k_count;
    return a + n;
}
""").endswith("""int f(int a)
{
    return a + k_count;
}
""")


def test_a_copy_of_a_parameter_read_in_a_loop_stays():
    """(Inlined, the argument's expression would be computed in every pass of the loop.)"""
    unit = parse_tree("""float f(float r) {
    float s = r;
    float t = 0.0;
    for (int k = 0; k < 4; k++) {
        t += s * float(k);
    }
    return t;
}
""")
    assert not SP.copies(unit, Context(("f",)).refresh(unit))


def test_a_bare_block_is_spliced_where_its_names_are_free():
    assert _run(SP.bare_blocks, """float f(float a) {
    {
        float b = a * 2.0;
        a += b;
    }
    {
        float c = a;
        a += c;
    }
    float c = 1.0;
    return a + c;
}
""") == """float f(float a)
{
    float b = a * 2.0;
    a += b;
    {
        float c = a;
        a += c;
    }
    float c = 1.0;
    return a + c;
}
"""


def test_a_declaration_merges_with_its_first_store():
    assert _run(SP.merge_declarations, """float f(float a) {
    float b;
    float c = a;
    b = c * 2.0;
    vec4 v;
    v.x = 1.0;
    return b + v.x;
}
""") == """float f(float a)
{
    float c = a;
    float b = c * 2.0;
    vec4 v;
    v.x = 1.0;
    return b + v.x;
}
"""


def test_a_literal_just_stored_is_read_in_place():
    """Up to the store that changes it (``r.loops += 1``) and the first ``if``."""
    assert _run(SP.forward_literals, """struct R {
    int loops;
    float F;
};
bool f(R r, int x) {
    r.loops = 0;
    x = 3;
    bool b = x > 9 && r.loops < 2;
    r.F = float(r.loops);
    r.loops += 1;
    int y = r.loops;
    if (x == 3) {
        return b;
    }
    return false;
}
""").endswith("""bool f(R r, int x)
{
    r.loops = 0;
    x = 3;
    bool b = 3 > 9 && 0 < 2;
    r.F = float(0);
    r.loops += 1;
    int y = r.loops;
    if (3 == 3) {
        return b;
    }
    return false;
}
""")


def test_a_loop_counter_declared_before_moves_into_the_loop():
    """Not where it is read after the loop."""
    assert _run(SP.loop_variables, """float f(float a) {
    int i = 2;
    float s = 0.0;
    for (; i <= 9; i++) {
        s += a;
    }
    int j = 0;
    for (; j < 3; j++) {
        s += a;
    }
    return s + float(j);
}
""") == """float f(float a)
{
    float s = 0.0;
    for (int i = 2; i <= 9; i++) {
        s += a;
    }
    int j = 0;
    for (; j < 3; j++) {
        s += a;
    }
    return s + float(j);
}
"""


def test_a_store_moves_into_the_next_statement():
    assert _run(SP.store_into_next, """float f(float a, float b) {
    float y = a + b;
    y = abs(y) * 2.0;
    return y;
}
""") == """float f(float a, float b)
{
    float y = abs((a + b)) * 2.0;
    return y;
}
"""
    assert _run(SP.store_into_next, """float f(float a, float b) {
    float z = a * b;
    return z;
}
""") == """float f(float a, float b)
{
    return a * b;
}
"""


def test_parentheses_that_change_nothing_go():
    assert _run(SP.parentheses, """float f(float a, float b) {
    float y = (a * b) + (b);
    float z = (a - b) * (a / b) - (a + b);
    bool c = ((a + b) < y);
    return (y + z) * g((a * b));
}
""") == """float f(float a, float b)
{
    float y = a * b + b;
    float z = (a - b) * (a / b) - (a + b);
    bool c = a + b < y;
    return (y + z) * g(a * b);
}
"""


def test_declarations_split_one_per_name():
    assert _run(SP.split_declarations, """float f(float a) {
    // two at once
    vec4 p = vec4(a), q;
    q = p;
    return q.x;
}
""") == """float f(float a)
{
    // two at once
    vec4 p = vec4(a);
    vec4 q;
    q = p;
    return q.x;
}
"""


# --------------------------------------------------------------------------------------------
# the pass driver: a fixed point, or an error
# --------------------------------------------------------------------------------------------


def test_the_driver_stops_at_the_fixed_point():
    src = "float g(float x) {\n    return x * 2.0;\n}\nfloat entry(float x) {\n    return g(x) - 0.0;\n}\n"
    out = compiler.compile_glsl(src, ["entry"])
    assert compiler.compile_glsl(out, ["entry"]) == out          # a second run changes nothing
    assert out == "float entry(float x) {\n    return x * 2.0;\n}\n"


def test_the_driver_raises_when_the_passes_do_not_settle(monkeypatch):
    """A pass that changes the code every round (here: a stand-in for reachability that adds a
    declaration each time) makes the driver raise, naming its round limit."""
    import itertools

    from cellgl.export import reach as reach_mod
    rounds = itertools.count()

    def growing(items, entries):
        return reach_mod.reach(items, entries) + parse(f"const float k_{next(rounds)} = 1.0;\n")
    monkeypatch.setattr(compiler, "reach", growing)
    with pytest.raises(TranslateError, match=f"did not settle in {compiler.MAX_ROUNDS} rounds"):
        compiler.compile_glsl("float entry(float x) {\n    return x;\n}\n", ["entry"])


# --------------------------------------------------------------------------------------------
# reachability, scalarising, parameters, inlining, void results, dead stores
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


def test_reach_keeps_what_the_entry_uses():
    from cellgl.export.reach import reach

    kept = reach(parse(_STRUCT), ["entry"])
    assert [it.name for it in kept] == ["P", "k_gain", "k_mode", "load", "scale", "entry"]


def test_scalarise_reads_the_loaders_values_directly():
    from cellgl.export.reach import reach, scalarise

    out = unparse(scalarise(reach(parse(_STRUCT), ["entry"]), "P", "load"))
    assert out.endswith("""float scale(float x)
{
    return x * k_gain + float(k_mode);
}

float entry(float x)
{
    return scale(x);
}
""")


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
