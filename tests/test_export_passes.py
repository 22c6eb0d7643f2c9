"""The snippet compiler's passes one by one (cellgl/export/), each on a small GLSL input with the
exact text it must give: beside the end-to-end tests (tests/test_export.py,
tests/test_export_compiler.py), which check that whole snippets compute what the bakes do."""
from __future__ import annotations

import pytest

from cellgl.export import compiler
from cellgl.export import fold as F
from cellgl.export import simplify as SP
from cellgl.export.printer import print_glsl
from cellgl.export.syntax import parse as parse_tree
from cellgl.export.translate.tokens import TranslateError
from cellgl.export.tree import Context
from cellgl.export.values import value


def _once(function_pass, unit, entries=("f",)) -> bool:
    """One run of ``function_pass`` (``(fn, facts) -> changed``) on each function of ``unit``."""
    ctx = Context(tuple(entries)).refresh(unit)
    genv, garrays = F.global_constants(unit)
    return any([function_pass(fn, F.Facts(fn, genv, garrays, ctx)) for fn in list(ctx.functions.values())])


def _run(function_pass, src: str, entries=("f",)) -> str:
    """The GLSL one run of ``function_pass`` makes of ``src`` (it must change it; ``compiler._fold``:
    the compiler's passes to their fixed point)."""
    unit = parse_tree(src)
    if function_pass is compiler._fold:
        assert function_pass(unit, Context(tuple(entries)).refresh(unit))
    else:
        assert _once(function_pass, unit, entries)
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
    assert not _once(SP.copies, unit)


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
    assert out == "float entry(float x)\n{\n    return x * 2.0;\n}\n"


def test_the_driver_raises_when_the_passes_do_not_settle(monkeypatch):
    """A pass that changes the tree every round (here: one that adds a declaration each time)
    makes the driver raise, naming its round limit and the pass."""
    import itertools

    from cellgl.export.syntax import parse as parse_tree
    rounds = itertools.count()

    def growing(unit, ctx):
        unit.items += parse_tree(f"const float k_{next(rounds)} = 1.0;\n").items
        return True
    monkeypatch.setattr(compiler, "ROUND", compiler.ROUND + [growing])
    with pytest.raises(TranslateError, match=f"did not settle in {compiler.MAX_ROUNDS} rounds.*growing"):
        compiler.compile_glsl("float entry(float x) {\n    return x;\n}\n", ["entry"])


# --------------------------------------------------------------------------------------------
# inlining, parameters, results and fields: tree passes (cellgl/export/inline.py, fields.py)
# --------------------------------------------------------------------------------------------

def _tree_pass(p, src: str, entries=("entry",), **kw) -> str:
    from cellgl.export.printer import print_glsl
    from cellgl.export.syntax import parse as parse_tree
    from cellgl.export.tree import Context

    unit = parse_tree(src)
    ctx = Context(tuple(entries), **kw).refresh(unit)
    p(unit, ctx)
    return print_glsl(unit)


def test_short_functions_become_their_expression():
    """Straight-line stores substituted forward; parentheses only where the grouping needs them;
    an argument read twice is written twice only when cheap."""
    from cellgl.export.inline import inline_short

    out = _tree_pass(inline_short, """float sq(float x) { x = abs(x); return x * x; }
float half_(float a, float b) { float t = a + b; return t * 0.5 - a; }
float entry(float a, float b) { return sq(a + b) * 2.0 - half_(a * b, b) + sq(sin(a) * cos(b) + a); }
""")
    assert out.endswith("""float entry(float a, float b)
{
    return abs(a + b) * abs(a + b) * 2.0 - ((a * b + b) * 0.5 - a * b) + sq(sin(a) * cos(b) + a);
}
""")


def test_parameters_never_read_go_and_constant_arguments_move_in():
    from cellgl.export.inline import constant_args, drop_unused_params

    src = """float f(float x, float y, int k, vec2 v)
{
    return x * float(k) - v.x;
}
float entry(float a)
{
    return f(a, 2.0, 3, vec2(-1.0, 2.0)) + f(a * a, 1.0, 3, vec2(-1.0, 2.0));
}
"""
    dropped = _tree_pass(drop_unused_params, src)
    assert dropped == """float f(float x, int k, vec2 v)
{
    return x * float(k) - v.x;
}

float entry(float a)
{
    return f(a, 3, vec2(-1.0, 2.0)) + f(a * a, 3, vec2(-1.0, 2.0));
}
"""
    assert _tree_pass(constant_args, dropped) == """float f(float x)
{
    return x * float(3) - vec2(-1.0, 2.0).x;
}

float entry(float a)
{
    return f(a) + f(a * a);
}
"""


def test_an_argument_with_effects_is_not_dropped():
    from cellgl.export.inline import drop_unused_params

    src = """float g(inout float w)
{
    w += 1.0;
    return w;
}

float f(float x, float y)
{
    return x;
}

float entry(float a)
{
    float w = a;
    return f(a, g(w)) + w;
}
"""
    assert _tree_pass(drop_unused_params, src) == src


def test_an_out_parameter_no_caller_reads_becomes_a_local():
    from cellgl.export.inline import drop_unused_outs

    assert _tree_pass(drop_unused_outs, """void g(float x, out float y, out float z)
{
    y = x * 2.0;
    z = x + 1.0;
}
float entry(float a)
{
    float u, w;
    g(a, u, w);
    return w;
}
""") == """void g(float x, out float z)
{
    float y;
    y = x * 2.0;
    z = x + 1.0;
}

float entry(float a)
{
    float u, w;
    g(a, w);
    return w;
}
"""


def test_a_function_called_once_is_inlined():
    """An inout parameter writes its argument in place; an in parameter the body writes is a
    copy (the caller's v does not change); the body's locals that clash are renamed; a short
    argument read once goes in place."""
    from cellgl.export.inline import inline_once

    out = _tree_pass(inline_once, """void g(inout float v, float x)
{
    v += x;
    v *= 0.5;
}
float h(float t, vec2 q, float s)
{
    float v = t * t;
    t += q.x;
    return v + t * s;
}
float entry(float a)
{
    float v = a;
    g(v, 3.0);
    float t = h(v, vec2(a, 1.0), a * 2.0);
    return v + t;
}
""")
    assert out == """float entry(float a)
{
    float v = a;
    v += 3.0;
    v *= 0.5;
    float t2 = v;
    vec2 q = vec2(a, 1.0);
    float v2 = t2 * t2;
    t2 += q.x;
    float t = v2 + t2 * (a * 2.0);
    return v + t;
}
"""


def test_inlining_refuses_an_early_return_and_a_shared_out_argument():
    from cellgl.export.inline import inline_once

    src = """float h(float x)
{
    if (x > 1.0) {
        return 1.0;
    }
    return x;
}

void g(inout float v, inout float w)
{
    v += w;
    w *= 2.0;
}

float entry(float a)
{
    float b = a;
    g(b, b);
    return h(b);
}
"""
    assert _tree_pass(inline_once, src) == src


def test_a_result_no_call_reads_becomes_void():
    from cellgl.export.fields import void_results

    out = _tree_pass(void_results, """float h(inout float w, float x)
{
    w = w + x;
    if (w > 1.0) {
        return 1.0;
    }
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
    assert out.startswith("void h(inout float w, float x)\n{\n    w = w + x;\n    if (w > 1.0) {\n        return;\n    }\n}\n")


def test_fields_never_read_go():
    """F is read only by the stores to F; g.x is a vector's, not the struct's."""
    from cellgl.export.fields import dead_fields

    out = _tree_pass(dead_fields, """struct R {
    float F[2];
    vec2 g;
    float x;
};
void step(inout R r, vec2 p)
{
    r.F[1] = r.F[0];
    r.F[0] = p.x;
    r.g = p;
    r.x = 3.0;
}
vec2 entry(vec2 p)
{
    R r;
    step(r, p);
    vec2 g = p;
    return r.g + g.x;
}
""")
    assert out.startswith("""struct R {
    vec2 g;
};

void step(inout R r, vec2 p)
{
    r.g = p;
}
""")


def test_a_field_holding_one_literal_is_folded():
    from cellgl.export.fields import constant_fields

    out = _tree_pass(constant_fields, """struct R {
    bool hit;
    float d;
};
void step(inout R r, float x)
{
    if (!r.hit) {
        r.d = x;
    }
}
float entry(float x)
{
    R r;
    r.hit = false;
    r.d = 1.0;
    step(r, x);
    return r.d;
}
""")
    assert out == """struct R {
    float d;
};

void step(inout R r, float x)
{
    if (!false) {
        r.d = x;
    }
}

float entry(float x)
{
    R r;
    r.d = 1.0;
    step(r, x);
    return r.d;
}
"""


def test_a_call_inside_an_expression_is_computed_first_and_inlined():
    """Called once inside a statement's expression: a local named for the function (or the body's
    returned local) takes its value just before the statement; not under && (which may skip it)."""
    from cellgl.export.inline import inline_once

    out = _tree_pass(inline_once, """vec4 cellgl_noise_gradient_(ivec4 c)
{
    vec4 v = vec4(c);
    return v * 0.5 + 1.0;
}
float cellgl_twice(float x)
{
    float y = x + x;
    return y;
}
float cellgl_skipped(float x)
{
    float y = x * x;
    return y;
}
float entry(ivec4 c, float a)
{
    vec4 g = vec4(cellgl_noise_gradient_(c).xyz, 0.0);
    bool b = a > 0.0 && cellgl_skipped(a) > 1.0;
    return g.x * cellgl_twice(a) + float(b);
}
""")
    assert out.endswith("""float entry(ivec4 c, float a)
{
    vec4 v = vec4(c);
    vec4 gradient = v * 0.5 + 1.0;
    vec4 g = vec4(gradient.xyz, 0.0);
    bool b = a > 0.0 && cellgl_skipped(a) > 1.0;
    float y = a + a;
    return g.x * y + float(b);
}
""")


def test_inlining_refuses_a_body_reading_a_global_the_caller_hides():
    from cellgl.export.inline import inline_once, inline_short

    src = """const float k = 2.0;

float scaled(float x)
{
    float y = x * k;
    return y;
}

float entry(float a)
{
    float k = a;
    float r = scaled(a);
    return r + k;
}
"""
    assert _tree_pass(inline_once, src) == src
    assert _tree_pass(inline_short, src) == src


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


def _core_pass(fn, text, **ctx):
    from cellgl.export.printer import print_glsl
    from cellgl.export.syntax import parse as parse_tree
    from cellgl.export.tree import Context

    unit = parse_tree(text)
    changed = fn(unit, Context(**ctx).refresh(unit))
    return changed, print_glsl(unit)


def test_reach_keeps_what_the_entry_uses():
    from cellgl.export.reach import reach

    changed, out = _core_pass(reach, _STRUCT, entries=("scale",))
    assert changed and out == """struct P {
    float gain;
    int mode;
};

float scale(float x, P t)
{
    return x * t.gain + float(t.mode);
}
"""
    assert _core_pass(reach, out, entries=("scale",)) == (False, out)


def test_scalarise_reads_the_loaders_values_directly():
    from cellgl.export.reach import scalarise

    changed, out = _core_pass(scalarise, _STRUCT, structs=(("P", "load"),))
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
    changed, out = _core_pass(scalarise, src, structs=(("P", "load"),))
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
    assert _core_pass(scalarise, out, structs=(("P", "load"),)) == (False, out)


def test_scalarise_leaves_a_struct_stored_into_elsewhere_alone():
    from cellgl.export.reach import scalarise

    src = _STRUCT.replace("    return x * t.gain", "    t.gain = 1.0;\n    return x * t.gain")
    assert _core_pass(scalarise, src, structs=(("P", "load"),))[0] is False
    src = _STRUCT.replace("    return scale(x, load());", "    P q;\n    return scale(x, q);")
    assert _core_pass(scalarise, src, structs=(("P", "load"),))[0] is False


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


# --------------------------------------------------------------------------------------------
# what the passes share (cellgl/export/tree.py): walking, rewriting, the fold cache's key
# --------------------------------------------------------------------------------------------

def test_walk_is_pre_order_and_transform_replaces_bottom_up():
    from cellgl.export import syntax as S
    from cellgl.export.tree import children, root_name, transform, walk

    unit = parse_tree("float f(float x)\n{\n    float a[2];\n    a[0] = x * (1.0 + x);\n"
                      "    return a[0];\n}\n")
    body = unit.items[0].body
    kinds = [type(n).__name__ for n in walk(body.body[1])]
    assert kinds == ["ExprStmt", "Assign", "Index", "Name", "Num", "Binary", "Name", "Paren", "Binary", "Num",
                     "Name"]
    assert [type(n).__name__ for n in children(body.body[1].expr)] == ["Index", "Binary"]
    assert root_name(body.body[1].expr.target) == "a"
    text = print_glsl(unit)
    assert transform(body, lambda n: n) is body and print_glsl(unit) == text
    transform(body, lambda n: S.Name("y") if isinstance(n, S.Name) and n.name == "x" else n)
    assert print_glsl(unit) == text.replace("a[0] = x * (1.0 + x);", "a[0] = y * (1.0 + y);") != text
    # a statement turned into a list of statements in a branch's place becomes a block
    unit = parse_tree("void g(float x)\n{\n    if (x > 0.0)\n        x = 1.0;\n}\n")
    transform(unit.items[0].body, lambda n: [n, n] if isinstance(n, S.ExprStmt) else n)
    assert print_glsl(unit) == "void g(float x)\n{\n    if (x > 0.0) {\n        x = 1.0;\n        x = 1.0;\n    }\n}\n"


def test_a_function_is_folded_again_only_when_what_it_reads_changed():
    """fold's cache (fold._FOLDED) keys a function on its text and on the values of the globals
    it names: a constant it does not name changes nothing; one it names gives its own fold."""
    src = ("const int k_mode = {0};\nconst int k_other = {1};\n"
           "int f(int x)\n{{\n    if (k_mode == 0)\n        x += 2;\n    return x;\n}}\n")
    outs = []
    for mode, other in ((0, 1), (0, 7), (1, 7)):
        unit = parse_tree(src.format(mode, other))
        compiler._fold(unit, Context(("f",)).refresh(unit))
        outs.append(print_glsl(unit).split("int f", 1)[1])
    assert outs[0] == outs[1] == "(int x)\n{\n    x += 2;\n    return x;\n}\n"
    assert outs[2] == "(int x)\n{\n    return x;\n}\n"
