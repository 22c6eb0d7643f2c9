"""The snippet compiler (cellgl/export/reach.py, fold.py) and the basis-only snippets
(cellgl/export/basis.py): only what the entry points reach is emitted, constants folded, the
sizes stay small, and ``cellgl export --basis`` gives the values of ``cellgl.cellular`` (run on
the GPU: GLSL with ModernGL, WGSL / HLSL as wgpu compute shaders)."""
from __future__ import annotations

import re
import sys
from pathlib import Path

import numpy as np
import pytest

from cellgl.basis import core
from cellgl.export import compiler, reach
from cellgl.export import snippets as export
from cellgl.export.printer import print_glsl
from cellgl.export.basis import BASES, basis_export

sys.path.insert(0, str(Path(__file__).parent))
from test_export import (  # noqa: E402
    BASES as PROGRAM_BASES,
    PRESETS,
    basis_snippet,
    compile_snippet,
    glslang,
    render_snippet,
    run_snippet,
    snippet_code,
    wgsl_validate,
)

ROOT = Path(__file__).resolve().parents[1]

# --------------------------------------------------------------------------------------------
# the passes on small programs
# --------------------------------------------------------------------------------------------

_LIB = """
// The parameters.
struct P {
    float gain;
    int mode;
    float table[2];
};

const float k_gain = 2.0;
const int k_mode = 1;
const float k_table[2] = float[2](0.5, 0.25);
const float k_unused = 7.0;
uniform float k_also_unused;

P load()
{
    P t;
    t.gain = k_gain;
    t.mode = k_mode;
    for (int k = 0; k < 2; k++) {
        t.table[k] = k_table[k];
    }
    return t;
}

// Never called.
float unused(float x)
{
    return x * 3.0;
}

// Scales x.
float scale(float x, P t)
{
    float y = x;
    if (t.mode == 0) {
        y = unused(x);
    } else {
        y *= t.gain;
    }
    float dead = y * 5.0;
    for (int k = 0; k < 1; k++) {
        y += t.table[k];
    }
    return t.mode == 2 ? -y : y;
}

float entry(float x)
{
    return scale(x, load());
}
"""


def test_compiler_keeps_only_what_the_entry_reaches():
    out = compiler.compile_glsl(_LIB, ["entry", "scale"], structs=[("P", "load")])
    assert "entry" in out and "scale" in out
    for gone in ("unused", "k_unused", "k_also_unused", "struct P", "load()", "t.mode", "dead",
                 "k_mode", "y = unused"):
        assert gone not in out, gone
    # the constant condition is folded, the one-iteration loop unrolled, the table read folded
    assert "y *= k_gain;" in out
    assert "y += 0.5;" in out
    assert "?" not in out and "if" not in out
    assert "// Scales x." in out                      # the function keeps its comment


def test_compiler_output_computes_the_same(ctx):
    """The folded program gives the value of the original (run both on the GL context)."""
    full = _LIB.replace("\nfloat entry", "\nfloat entry_ref(float x)\n{\n    return scale(x, load());\n}\n"
                        "\nfloat entry")
    small = compiler.compile_glsl(_LIB, ["entry"], structs=[("P", "load")])
    for name in ("entry", "scale", "k_gain", "k_table"):
        small = re.sub(rf"\b{name}\b", name + "_new", small)
    both = full + "\n" + small
    got = render_snippet(ctx, both, 8, 4, call="vec4(entry_ref(uv.x * 9.0), entry_new(uv.x * 9.0), 0.0, 1.0)")
    np.testing.assert_array_equal(got[..., 0], got[..., 1])
    assert np.all(got[..., 0] > 0.0)


_INLINE = """
struct S {
    float acc;
    bool mode;
};

// Adds twice x to s.acc; last: what it added.
void add_twice(inout S s, float x, out float last)
{
    float t = x * 2.0;
    s.acc += t;
    last = t;
}

// v moved by k (the caller passes its v and stores the result in it).
vec2 bump(vec2 v, float k)
{
    v.x += k;
    v.y -= k;
    return v;
}

// A sum with a local and a loop variable named like the caller's.
float sum3(float a, float b)
{
    float t = a + b;
    for (int k = 0; k < 2; k++) {
        t += a * float(k);
    }
    return t;
}

float entry(float x)
{
    S s;
    s.acc = 1.0;
    s.mode = false;
    float last;
    add_twice(s, x, last);
    vec2 v = vec2(x, 1.0);
    v = bump(v, last);
    float t = 0.5;
    for (int k = 0; k < 3; k++) {
        t += float(k) * sum3(x, 1.0);
    }
    float u = sum3(t, v.x - v.y);
    if (s.mode) {
        u = -u;
    }
    return u + s.acc + last;
}
"""



def _assert_same_values(ctx, source: str, compiled: str, names, scale: float):
    """The compiled program's entry(x) gives the original's values, and they are not all 0: both
    run side by side in one fragment shader (the compiled names renamed *_new)."""
    small = compiled
    for name in names:
        small = re.sub(rf"\b{name}\b", name + "_new", small)
    full = source + "\nfloat entry_ref(float x)\n{\n    return entry(x);\n}\n"
    got = render_snippet(ctx, full + "\n" + small, 8, 4,
                         call=f"vec4(entry_ref(uv.x * {scale}), entry_new(uv.x * {scale}), 0.0, 1.0)")
    np.testing.assert_array_equal(got[..., 0], got[..., 1])
    assert np.all(got[..., 0] > 0.0)

def test_inlining_functions_called_once_keeps_the_values(ctx):
    """Functions called once become their bodies (out / inout arguments written in place, the
    body's locals renamed where the caller has the name, a field that holds one literal folded);
    the values stay those of the original program (both run on the GL context)."""
    out = compiler.compile_glsl(_INLINE, ["entry"])
    assert "add_twice" not in out and "bump" not in out          # called once: inlined
    assert "sum3(" in out                                         # called twice: kept
    assert "mode" not in out and "-u" not in out                  # always false: folded away
    _assert_same_values(ctx, _INLINE, out, ("entry", "S", "sum3"), 9.0)


_VOID = """
struct W {
    float best;
    bool stopped;
    bool on;
};

// Walks from x; returns whether it ran to the end (the entry never reads it).
bool walk(inout W w, float x)
{
    for (int k = 0; k < 4; k++) {
        if (w.best < 0.1 * float(k)) {
            w.stopped = true;
            return false;
        }
        w.best = min(w.best, abs(x - float(k)));
    }
    return !w.stopped;
}

// As walk, but its value is read once.
bool again(inout W w, float x)
{
    for (int k = 0; k < 2; k++) {
        w.best = min(w.best, abs(x + float(k)));
    }
    return w.best < 0.5;
}

// The square of a, through a local.
float sq(float a)
{
    float y = a * a;
    return y;
}

float entry(float x)
{
    W w;
    w.best = 9.0;
    w.stopped = false;
    w.on = 3.0e38 >= 3.0e38;
    walk(w, x);
    walk(w, x + 0.25);
    again(w, x);
    float s = sq(x) + sq(x + 1.0);
    if (again(w, x * 0.5) && w.on) {
        s += 1.0;
    }
    return w.best + s;
}
"""


def test_results_nobody_reads_become_void(ctx):
    """A function whose value every call throws away returns void (what only fed that value goes:
    the field w.stopped); one whose value a call reads keeps it; ``T y = a; return y;`` is
    ``return a;``; a stored condition of literals is folded. Same values as the original."""
    out = compiler.compile_glsl(_VOID, ["entry"])
    assert "void walk(inout W w, float x)" in out and "return false" not in out
    assert "stopped" not in out
    assert "bool again(" in out and "return w.best < 0.5;" in out
    assert "float y" not in out and ">=" not in out and ".on" not in out
    _assert_same_values(ctx, _VOID, out, ("entry", "W", "walk", "again"), 4.0)


def test_scalarise_leaves_a_struct_written_elsewhere_alone():
    from cellgl.export.syntax import parse as parse_tree

    lib = _LIB.replace("    float y = x;", "    float y = x;\n    P other;\n    other.gain = 1.0;")
    unit = parse_tree(lib)
    before = print_glsl(unit)
    assert reach.scalarise_struct(unit, "P", "load") is False and print_glsl(unit) == before


# --------------------------------------------------------------------------------------------
# sizes: the limits of issue 18 and the table in docs/engines.md
# --------------------------------------------------------------------------------------------

#: lines of `cellgl export f1` (every target but OSL, whose texture shader keeps the recipe's
#: values as sliders: PRESET_LIMIT), of every preset in every target, of a basis snippet (the
#: edge basis included): issue 18's goals
# BASIS_LIMIT: README gives 119-151 lines with the default options (edge in 4D the largest)
F1_LIMIT, PRESET_LIMIT, BASIS_LIMIT = 200, 600, 155

#: the targets a --basis export exists for (OSL's basis shader: tests/test_blender.py)
FOLDED_TARGETS = [t for t in export.TARGETS if export.TARGETS[t].dialect != "osl"]


@pytest.mark.parametrize("target", FOLDED_TARGETS)
def test_f1_snippet_is_short(target):
    text = export.export("f1", target)
    lines = text.splitlines()
    assert len(lines) <= F1_LIMIT
    assert sum(ln.startswith("// Recipe: {") for ln in lines) == 1       # the recipe on one line
    code = snippet_code(text)
    code = "\n".join(ln.split("//")[0] for ln in code.splitlines())     # the code, not its comments
    for gone in ("noise", "warp", "w96", "density_thresholds", "orbit", "CellglTextureParams",
                 # arrays of equal entries, ramp keys past the two used, members of constant
                 # vectors, helpers that zero components, constant arguments, copies
                 "cellgl_origin_cell", "cellgl_origin_frac", "cellgl_ramp", ").w", ").rgb",
                 "cellgl_dims", "CellglParams", "0u +", "float term = ", "float index = "):
        assert gone not in code, gone
    assert not re.search(r"^\{", code, re.M)                 # braces open on their line


@pytest.mark.parametrize("target", list(export.TARGETS))
def test_every_preset_fits(target):
    sizes = {p: len(export.export(p, target).splitlines()) for p in PRESETS}
    worst = max(sizes, key=sizes.get)
    assert sizes[worst] <= PRESET_LIMIT, (worst, sizes[worst])


@pytest.mark.parametrize("target", FOLDED_TARGETS)
def test_every_basis_fits(target):
    for b in BASES:
        for dim in (2, 3, 4):
            n = len(basis_export(b, dim, target).splitlines())
            assert n <= BASIS_LIMIT, (b, dim, n)


def _snippet_table():
    """docs/make_snippet_table.py as a module, and docs/engines.md's table: (its text, its cells)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("make_snippet_table", ROOT / "docs" / "make_snippet_table.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    doc = Path(mod.DOC).read_text(encoding="utf-8")
    assert mod.BEGIN in doc and mod.END in doc, "docs/engines.md: the snippet-sizes markers are gone"
    text = doc.split(mod.BEGIN, 1)[1].split(mod.END, 1)[0].strip("\n")
    return mod, text, [[c.strip() for c in line.strip().strip("|").split("|")] for line in text.splitlines()]


def test_docs_table_has_every_target_and_snippet():
    """docs/engines.md's size table is make_snippet_table's layout, with a column per target and
    a row per snippet; test_docs_table_is_current checks the cells, a row each (together:
    ``python docs/make_snippet_table.py --check``)."""
    mod, text, cells = _snippet_table()
    targets = list(export.TARGETS)
    labels = [label for label, _ in mod.rows()]
    assert cells[0] == ["snippet"] + [f"`{t}`" for t in targets]
    assert [r[0] for r in cells[2:]] == labels
    assert mod.format_table(labels, targets, [r[1:] for r in cells[2:]]) == text


def _table_labels() -> list[str]:
    """The rows of docs/engines.md's size table (the parameters of test_docs_table_is_current:
    read at collection, so without running the table's script)."""
    text = (ROOT / "docs" / "engines.md").read_text(encoding="utf-8")
    if "<!-- snippet-sizes:begin -->" not in text:
        return []                    # test_docs_table_has_every_target_and_snippet says so
    body = text.split("<!-- snippet-sizes:begin -->", 1)[1].split("<!-- snippet-sizes:end -->", 1)[0]
    return [line.strip().strip("|").split("|")[0].strip() for line in body.strip().splitlines()[2:]]


@pytest.mark.parametrize("label", _table_labels(), ids=lambda label: label.strip("`"))
def test_docs_table_is_current(label):
    """One row of docs/engines.md's size table is what ``cellgl export`` writes now (after a
    change: ``python docs/make_snippet_table.py``); a row the table no longer needs, or lacks,
    fails test_docs_table_has_every_target_and_snippet."""
    mod, _, cells = _snippet_table()
    make = dict(mod.rows()).get(label)
    if make is None:
        pytest.fail(f"docs/engines.md's size table has a row {label!r} that cellgl no longer exports: "
                    "run python docs/make_snippet_table.py")
    got = next(r[1:] for r in cells[2:] if r[0] == label)
    assert got == mod.row(make, [t.strip("`") for t in cells[0][1:]]), \
        f"docs/engines.md's row {label} is out of date: run python docs/make_snippet_table.py"


# --------------------------------------------------------------------------------------------
# basis-only snippets: exact, in every target
# --------------------------------------------------------------------------------------------

#: (basis, dim, parameters) rendered with GLSL and compared with cellgl.cellular
CASES = [
    ("f1", 2, {}),
    ("f1f2", 3, dict(distribution="jitter", jitter=0.8, seed=7)),
    ("f1f2f3", 2, dict(metric="manhattan", density=2.0, seed=11)),
    ("f1f2f3f4", 2, dict(metric="minkowski", minkowski_p=1.5, density=4.5, max_points=12)),
    ("f1f2", 4, dict(distribution="jitter", metric="chebyshev")),
    ("edge", 2, dict(seed=3)),
    ("edge", 3, dict(distribution="jitter", jitter=0.9, seed=5)),
    ("edge", 4, dict(density=2.0, max_points=6)),
    ("cellid", 3, dict(density=1.5, min_points=0)),
]

_VEC = {2: "vec2", 3: "vec3", 4: "vec4"}
_HLSL = {"vec2": "float2", "vec3": "float3", "vec4": "float4"}


def _points(W: int, H: int, dim: int) -> np.ndarray:
    """The sample of pixel (x, y): (x + 0.5) / 4 - 3, (y + 0.5) / 4 + 5, then 0.375, -2.125:
    exact in float32, as the shader computes them."""
    ys, xs = np.mgrid[0:H, 0:W]
    cols = [(xs + 0.5) / 4.0 - 3.0, (ys + 0.5) / 4.0 + 5.0, np.full(xs.shape, 0.375),
            np.full(xs.shape, -2.125)][:dim]
    return np.stack(cols, axis=-1).reshape(-1, dim)


def _point_expr(dim: int, vec: str = "vec") -> str:
    base = {2: "{v}2((uv * SIZE) / 4.0 + {v}2(-3.0, 5.0))",
            3: "{v}3((uv * SIZE) / 4.0 + {v}2(-3.0, 5.0), 0.375)",
            4: "{v}4((uv * SIZE) / 4.0 + {v}2(-3.0, 5.0), 0.375, -2.125)"}[dim]
    return base.format(v=vec)


def _expected(basis: str, dim: int, kw: dict, W: int, H: int) -> np.ndarray:
    n = BASES[basis][0]
    outputs = {"edge": ("edge",), "cellid": ("id",)}.get(basis, ("F",))
    r = core.cellular(_points(W, H, dim), n=n, outputs=outputs, **kw)
    if basis == "edge":
        return r.edge.reshape(H, W, 1)
    if basis == "cellid":
        return r.id[:, 0].reshape(H, W, 1).astype(np.uint64)
    return r.F.reshape(H, W, n)


def _glsl_call(basis: str, dim: int) -> str:
    ret = BASES[basis][1]
    p = _point_expr(dim).replace("SIZE", "size")
    v = f"cellgl_{basis}({p})"
    return {"float": f"vec4({v}, 0.0, 0.0, 0.0)", "vec2": f"vec4({v}, 0.0, 0.0)",
            "vec3": f"vec4({v}, 0.0)", "vec4": v,
            "uint": f"vec4(float({v} >> 16), float({v} & 0xffffu), 0.0, 0.0)"}[ret]


def _decode(got: np.ndarray, basis: str) -> np.ndarray:
    n = BASES[basis][0]
    if basis == "cellid":
        return (got[..., 0].astype(np.uint64) << 16 | got[..., 1].astype(np.uint64))[..., None]
    return got[..., :n]


@pytest.mark.parametrize("basis, dim, kw", CASES, ids=[f"{b}-{d}d" for b, d, _ in CASES])
def test_basis_snippet_matches_cellular(ctx, basis, dim, kw):
    W, H = 40, 24
    text = basis_export(basis, dim, "glsl", **kw)
    ret = BASES[basis][1]
    assert f"{ret} cellgl_{basis}({_VEC[dim]} p)" in text
    got = _decode(render_snippet(ctx, snippet_code(text), W, H, call=_glsl_call(basis, dim)), basis)
    want = _expected(basis, dim, kw, W, H)
    if basis == "cellid":
        np.testing.assert_array_equal(got, want)
    else:
        np.testing.assert_allclose(got, want, rtol=0, atol=2e-6)


@pytest.mark.parametrize("target", ["wgsl", "hlsl"])
@pytest.mark.parametrize("basis, dim, kw", [CASES[1], CASES[5]], ids=["f1f2-3d", "edge-2d"])
def test_basis_snippet_matches_cellular_in_wgsl_hlsl(tmp_path, target, basis, dim, kw):
    W, H = 24, 16
    text = basis_export(basis, dim, target, **kw)
    if target == "wgsl":
        vec = "vec"
        p = _point_expr(dim, "vec").replace("vec2(", "vec2<f32>(").replace("vec3(", "vec3<f32>(") \
            .replace("vec4(", "vec4<f32>(").replace("SIZE", f"vec2<f32>({W}.0, {H}.0)")
        n = BASES[basis][0]
        v = f"cellgl_{basis}({p})"
        call = {1: f"vec4<f32>({v}, 0.0, 0.0, 0.0)", 2: f"vec4<f32>({v}, 0.0, 0.0)"}[n]
    else:
        vec = "float"
        p = _point_expr(dim, vec).replace("SIZE", f"float2({W}.0, {H}.0)")
        n = BASES[basis][0]
        v = f"cellgl_{basis}({p})"
        call = {1: f"float4({v}, 0.0, 0.0, 0.0)", 2: f"float4({v}, 0.0, 0.0)"}[n]
    got = run_snippet(tmp_path, target, text, W, H, call=call)[..., :n]
    np.testing.assert_allclose(got, _expected(basis, dim, kw, W, H), rtol=0, atol=2e-6)


def _main(target: str, basis: str, dim: int) -> str:
    d = export.TARGETS[target].dialect
    ret = BASES[basis][1]
    if target == "unreal":                    # no Unity wrapper: call the function alone
        pt = f"float{dim}"
        sel = "" if ret in ("float", "uint") else ".x"
        return (f"float4 main(float4 pos : SV_Position) : SV_Target\n{{\n"
                f"    float v = (float)(cellgl_{basis}(({pt})(pos.y / 8.0)){sel});\n"
                "    return float4(v, v, v, 1.0);\n}\n")
    if d == "hlsl":
        pt = f"float{dim}"
        rt = _HLSL.get(ret, ret)
        return (f"float4 main(float4 pos : SV_Position) : SV_Target\n{{\n    {rt} o;\n"
                f"    cellgl_{basis}_float(({pt})(pos.x / 8.0), o);\n"
                f"    float v = (float)(cellgl_{basis}(({pt})(pos.y / 8.0)) + o);\n"
                "    return float4(v, v, v, 1.0);\n}\n"
                if ret in ("float", "uint") else
                f"float4 main(float4 pos : SV_Position) : SV_Target\n{{\n    {rt} o;\n"
                f"    cellgl_{basis}_float(({pt})(pos.x / 8.0), o);\n"
                f"    return float4(cellgl_{basis}(({pt})(pos.y / 8.0)).x + o.x, 0.0, 0.0, 1.0);\n}}\n")
    if d == "wgsl":
        return ("\n@fragment\nfn cellgl_main(@builtin(position) pos: vec4<f32>) -> @location(0) vec4<f32>\n{\n"
                f"    let v = cellgl_{basis}(vec{dim}<f32>(pos.x / 8.0));\n"
                "    return vec4<f32>(f32(" + ("v" if ret in ("float", "uint") else "v.x") + "));\n}\n")
    x = "v" if ret in ("float", "uint") else "v.x"
    return (f"out vec4 cellgl_out;\nvoid main() {{ {ret} v = cellgl_{basis}({_VEC[dim]}(gl_FragCoord.x / 8.0)); "
            f"cellgl_out = vec4(float({x})); }}\n")


def test_basis_snippet_for_osl_is_a_shader_of_the_basis_alone():
    """OSL basis exports (compiled and rendered in tests/test_blender.py): the folded code of the
    basis, no texture machinery, a shader with Vector (and W in 4D) in and the basis out."""
    text = basis_export("f1f2", 4, "osl")
    assert re.search(r"^shader cellgl_basis_f1f2\(\n    point Vector = .*\n    float W = 0 .*\n"
                     r"    output float F1 = 0,\n    output float F2 = 0\n\)", text, re.M), text[-800:]
    assert "cellgl_f1f2(cellgl_vec4(q[0], q[1], q[2], W))" in text
    code = re.sub(r"//[^\n]*", "", text)
    for gone in ("cellgl_texture", "CellglTextureParams", "noise", "cellgl_dims("):
        assert gone not in code, gone
    assert len(text.splitlines()) < len(export.export("f1", "osl").splitlines()) / 2   # (f1: folded too)
    assert "shader cellgl_basis_cellid(point Vector, output float IDLow, output float IDHigh)" \
        in basis_export("cellid", 2, "osl")


#: every basis snippet and target: the named basis functions (``cellgl export --basis``: every
#: target but OSL, whose basis shader tests/test_blender.py compiles) and the machinery's bare
#: programs of tests/test_export.py (``basis_program``: every target)
BASIS_SNIPPETS = ([("function", b, t) for b in BASES for t in FOLDED_TARGETS]
                  + [("program", b, t) for b in PROGRAM_BASES for t in export.TARGETS])


@pytest.mark.parametrize("kind, basis, target", BASIS_SNIPPETS, ids=["-".join(c) for c in BASIS_SNIPPETS])
def test_basis_snippet_compiles(tmp_path, kind, basis, target):
    if kind == "program":
        compile_snippet(tmp_path, target, basis_snippet(basis, target))
        return
    dim = 3
    text = basis_export(basis, dim, target)
    d = export.TARGETS[target].dialect
    if target == "glsl":
        glslang(tmp_path, "b.frag", "#version 330 core\n" + text + _main(target, basis, dim))
    elif target == "shadertoy":
        glslang(tmp_path, "st.frag", "#version 300 es\nprecision mediump float;\nuniform vec3 iResolution;\n"
                "uniform float iTime;\nout vec4 cellgl_out;\n" + text
                + "void main() { mainImage(cellgl_out, gl_FragCoord.xy); }\n")
    elif d in ("gles", "godot"):
        body = text.replace("shader_type canvas_item;", "")
        body = re.sub(r"\nvoid fragment\(\)\s*\{.*?\n\}\n", "\n", body, flags=re.S)
        if target == "godot":
            assert "void fragment()" in text and "TIME" in text
        glslang(tmp_path, f"{target}.frag", "#version 300 es\nprecision highp float;\nprecision highp int;\n"
                + body + _main("glsl", basis, dim))
    elif d == "hlsl":
        glslang(tmp_path, f"{target}.hlsl", text + _main(target, basis, dim), "-D", "-V", "-e", "main", "-S", "frag")
    else:
        wgsl_validate(text + _main(target, basis, dim))


# --------------------------------------------------------------------------------------------
# command line
# --------------------------------------------------------------------------------------------


def test_cli_basis(capsys):
    from cellgl.cli import main

    assert main(["export", "--basis", "f1f2", "--dim", "3"]) == 0
    out = capsys.readouterr().out
    assert "vec2 cellgl_f1f2(vec3 p)" in out
    assert "cellgl export --basis f1f2 --dim 3 --target glsl" in out
    assert main(["export", "--basis", "f1", "--distribution", "jitter", "--seed", "9", "-t", "wgsl"]) == 0
    out = capsys.readouterr().out
    assert "fn cellgl_f1(p: vec2<f32>) -> f32" in out and "--distribution jitter --seed 9" in out
    for args, msg in ((["--basis", "f5"], "unknown basis 'f5'"), (["--basis", "f1", "--dim", "5"], "dim must be"),
                      (["--basis", "edge", "--metric", "manhattan"], "Euclidean only"),
                      (["--basis", "f1", "--distribution", "worley1996", "--dim", "3"], "worley1996"),
                      (["--basis", "f1", "--density", "99"], "density must be in"),
                      (["f1", "--basis", "f1"], "not both"), ([], "nothing to export")):
        assert main(["export", *args]) == 2
        assert msg in capsys.readouterr().err


# --------------------------------------------------------------------------------------------
# recipe variations the presets do not cover: the folded code still gives the bake's pixels
# --------------------------------------------------------------------------------------------

VARIATIONS = [
    ("f1", ["fractal=sum", "octaves=3.5"]),
    ("f1", ["fractal=qin_cube", "octaves=2", "light=0.5"]),
    ("f1", ["fractal=min", "octaves=3"]),
    ("f1", ["tileable=true", "frequency=4"]),
    ("f1", ["tileable=true", "frequency=2", "dimension=3"]),      # the lattice wraps in z too
    ("f1", ["density_map=radial"]),
    ("f1", ["stretch_x=2.0"]),
    ("f1", ["orbit_radius=0.2", "distribution=jitter"]),
    ("f1", ["noise_color=0.3", "warp_amount=0.3"]),
    ("f1", ["smoothness=0.2", "c_smooth=1.0", "c1=0.0"]),
    ("f1", ["metric=minkowski", "minkowski_p=1.5", "dimension=3"]),
    ("f1", ["dimension=4", "metric=chebyshev"]),
]


@pytest.mark.parametrize("preset, sets", VARIATIONS, ids=[" ".join(s) for _, s in VARIATIONS])
def test_recipe_variation_reproduces_the_bake(ctx, preset, sets):
    from cellgl import texture
    from cellgl.recipes import load_recipe

    W, H = 32, 24
    r = load_recipe(preset).set_from_strings(sets)
    got = render_snippet(ctx, snippet_code(export.export(r, "glsl")), W, H)
    want = texture.render(r, W, H, channels=("color",))["color"]
    np.testing.assert_allclose(got, want, rtol=0, atol=2e-5)
