"""Snippet export: the preprocessor subset, prefixing, every target through a real compiler,
and the GLSL / GLSL ES (ModernGL) and WGSL / HLSL (wgpu compute shaders on lavapipe) snippets
reproducing the GPU's numbers pixel for pixel.

Compilers: glslangValidator (Debian glslang-tools) for GLSL 3.30/4.30, GLSL ES 3.00 and HLSL
(-D, to SPIR-V); naga through the ``wgpu`` package (on Mesa lavapipe) for WGSL. A missing
glslangValidator skips unless CELLGL_REQUIRE_GPU is set (CI), where it fails; a missing wgpu or
Vulkan driver skips unless CELLGL_REQUIRE_WGSL is set (the WGSL and HLSL runs need both).
"""
from __future__ import annotations

import os
import re
import shutil
import subprocess

import numpy as np
import pytest

from cellgl.export import snippets as export
from cellgl.basis import core
from cellgl.export import translate
from cellgl.export.basis import _glsl_float
from tiers import quick_few

REQUIRE = os.environ.get("CELLGL_REQUIRE_GPU", "").strip().lower() in ("1", "true", "yes")
REQUIRE_WGSL = os.environ.get("CELLGL_REQUIRE_WGSL", "").strip().lower() in ("1", "true", "yes")
REQUIRE_BLENDER = os.environ.get("CELLGL_REQUIRE_BLENDER", "").strip().lower() in ("1", "true", "yes")
GLSLANG = shutil.which("glslangValidator")


def _missing(what: str, required: bool | None = None):
    if REQUIRE if required is None else required:
        pytest.fail(f"CELLGL_REQUIRE_GPU/_WGSL/_BLENDER=1 but {what} is missing", pytrace=False)
    pytest.skip(f"{what} is missing")


# --------------------------------------------------------------------------------------------
# the preprocessor subset
# --------------------------------------------------------------------------------------------


def test_specialise_branches_and_substitution():
    src = (
        "#if A == 2\n"
        "int a = A;\n"
        "#elif A > 2 && defined(B)\n"
        "int b = B;\n"
        "#else\n"
        "int c;\n"
        "#endif\n"
        "#ifdef B\n"
        "#if (B - 1) * 2 >= 4 || !C\n"
        "float x = float(B);  // B stays B in a comment\n"
        "#endif\n"
        "#endif\n"
        "#ifndef Z\n"
        "#define LOCAL (A < 4 ? A : 4)\n"
        "int n = LOCAL;\n"
        "#undef LOCAL\n"
        "int LOCALX = 1;\n"
        "#endif\n"
    )
    out = translate.specialise(src, {"A": 3, "B": 3, "C": 0})
    assert "#" not in out
    assert "int b = 3;" in out and "int a" not in out and "int c" not in out
    assert "float x = float(3);  // B stays B in a comment" in out
    assert "int n = 3;" in out and "int LOCALX = 1;" in out
    out = translate.specialise(src, {"A": 2})
    assert "int a = 2;" in out and "float x" not in out


@pytest.mark.parametrize("src, message", [
    ("#if UNKNOWN\n#endif\n", "undefined macro 'UNKNOWN'"),
    ("#if 1\n", "not closed"),
    ("#endif\n", "without #if"),
    ("#else\n", "without #if"),
    ("#if 1\n#else\n#else\n#endif\n", "after #else"),
    ("#define F(x) x\n", "function-like macro"),
    ('#include "a.glsl"\n', "#include cannot appear"),
    ("#version 330\n", "#version cannot appear"),
    ("#if 1 / 0\n#endif\n", "division by zero"),
])
def test_specialise_errors(src, message):
    with pytest.raises(translate.TranslateError, match=re.escape(message)):
        translate.specialise(src, {})


def test_prefix_names():
    src = ("struct CellThing { float a; };\n"
           "const int _cell_table[2] = int[2](1, 2);\n"
           "// cell_f() uses _cell_table\n"
           "float cell_f(CellThing t) { return t.a + float(_cell_table[1]); }\n"
           "float helper(float x) { return cell_f(CellThing(x)); }\n")
    out, mapping = translate.prefix_names(src)
    assert mapping == {"CellThing": "CellglThing", "_cell_table": "cellgl_table_",
                       "cell_f": "cellgl_f", "helper": "cellgl_helper"}
    assert "// cellgl_f() uses cellgl_table_" in out
    assert "t.a" in out                      # members and locals are left alone
    assert all(n.startswith(("cellgl_", "Cellgl")) for n in translate.top_level_names(out))


# --------------------------------------------------------------------------------------------
# targets, refusals, header
# --------------------------------------------------------------------------------------------

BASES = {
    "poisson": core.make_params(2),
    "jitter-manhattan": core.make_params(2, distribution="jitter", jitter=0.8, metric="manhattan"),
    "periodic-minkowski": core.make_params(2, metric="minkowski", minkowski_p=1.5, period=8, seed=7),
}


def basis_program(p, n: int = 4, frequency: float = 8.0) -> export.Program:
    """The machinery's own test program (the bare cellular basis, F1..F4 as RGBA): a program whose ``cellgl_texture(uv)`` returns ``(F1, F2, F3, F4)`` of the basis ``p``
    (a :class:`cellgl.basis.reference.Params`, 2D) at ``uv * frequency``."""
    from cellgl.basis.gpu import defines_for

    d = defines_for(p, n)
    thresholds = ", ".join(f"{int(t)}u" for t in p.thresholds)
    params = (
        "// The basis parameters of the recipe.\n"
        f"const CellParams cell_params = CellParams({int(p.seed)}u, {_glsl_float(p.jitter)}, "
        f"{int(p.min_points)}, {int(p.max_points)},\n"
        f"    uint[CELL_MAX_POINTS]({thresholds}),\n"
        f"    ivec4({', '.join(str(int(v)) for v in p.period)}), {_glsl_float(p.minkowski_p)});\n"
        f"const float cell_frequency = {_glsl_float(frequency)};\n"
    )
    entry = (
        "// F1..F4 of the basis at uv * cell_frequency.\n"
        "vec4 cellgl_texture(vec2 uv)\n"
        "{\n"
        "    vec2 pos = uv * cell_frequency;\n"
        "    vec2 fl = floor(pos);\n"
        "    CellResult r = cell_search(ivec4(ivec2(fl), 0, 0), vec4(pos - fl, 0.0, 0.0), cell_params);\n"
        "    return vec4(r.F[0], r.F[1], r.F[2], r.F[3]);\n"
        "}\n"
    )
    return export.Program(files=["lib/cellular.glsl"], defines=d, params=params, entry=entry,
                          title="basis", recipe={"basis": "F1..F4", "frequency": frequency})


def basis_snippet(name: str, target: str) -> str:
    return export.export_program(basis_program(BASES[name]), target)


@pytest.mark.parametrize("target", ["gles100", "webgl1", "WebGL"])
def test_webgl1_refused(target):
    with pytest.raises(export.ExportError, match="WebGL1.*integers"):
        export.check_target(target)


def test_unknown_target_names_the_accepted_ones():
    with pytest.raises(export.ExportError, match="expected one of: glsl, gles, shadertoy"):
        export.check_target("metal")


@pytest.mark.parametrize("target", list(export.TARGETS))
def test_snippet_is_self_contained(target):
    text = basis_snippet("periodic-minkowski", target)
    assert text.startswith("// cellgl ")
    assert "Recipe:" in text and "cellgl_texture" in text
    code = re.sub(r"//[^\n]*", "", text)
    directives = [ln for ln in code.splitlines() if ln.strip().startswith("#")]
    assert directives == (["#pragma once"] if target == "unreal" else [])
    assert "#version" not in code and "#include" not in code
    assert not re.search(r"\bCELL_\w+", code), "a macro leaked into the code"
    if export.TARGETS[target].dialect in ("glsl", "gles", "godot"):
        body = text if target != "godot" else text.replace("shader_type canvas_item;", "")
        for name in translate.top_level_names(re.sub(r"//[^\n]*", "", body)):
            assert name.startswith(("cellgl_", "Cellgl")) or name in ("mainImage", "fragment"), name


# --------------------------------------------------------------------------------------------
# real compilers
# --------------------------------------------------------------------------------------------

_GLSL_MAIN = "out vec4 cellgl_out;\nvoid main() { cellgl_out = cellgl_texture(gl_FragCoord.xy / 64.0); }\n"


def glslang(tmp_path, name: str, text: str, *args: str) -> None:
    if GLSLANG is None:
        _missing("glslangValidator (Debian glslang-tools)")
    path = tmp_path / name
    path.write_text(text)
    out = ["-o", str(tmp_path / (name + ".spv"))] if "-V" in args else []
    res = subprocess.run([GLSLANG, *args, *out, str(path)], capture_output=True,
                         text=True, timeout=120)
    assert res.returncode == 0, res.stdout + res.stderr


def compile_snippet(tmp_path, target: str, text: str) -> None:
    """Compile ``text`` (a snippet for ``target``) in a minimal shader of its dialect."""
    d = export.TARGETS[target].dialect
    if target == "glsl":
        for version in ("330 core", "430"):
            glslang(tmp_path, f"glsl{version[:3]}.frag", f"#version {version}\n{text}{_GLSL_MAIN}")
    elif target == "shadertoy":
        prelude = ("#version 300 es\nprecision mediump float;\nuniform vec3 iResolution;\n"
                   "out vec4 cellgl_out;\n")
        glslang(tmp_path, "st.frag",
                prelude + text + "void main() { mainImage(cellgl_out, gl_FragCoord.xy); }\n")
    elif d in ("gles", "godot"):
        # Godot's language is GLSL ES 3.00 plus its own header and fragment(); the code between
        # is checked as GLSL ES (Godot itself is not available to the tests).
        body = text.replace("shader_type canvas_item;", "")
        body = re.sub(r"void fragment\(\)\s*\{\n    COLOR = cellgl_texture\(UV\);\n\}\n", "", body)
        # Godot declares highp defaults; the gles snippet must work with mediump defaults.
        prec = ("precision highp float;\nprecision highp int;\n" if d == "godot"
                else "precision mediump float;\n")
        glslang(tmp_path, f"{target}.frag", "#version 300 es\n" + prec + body + _GLSL_MAIN)
    elif d == "hlsl":
        # the Unity wrapper (hlsl; Unreal's .ush has none)
        wrap = "cellgl_texture_float(pos.xy / 64.0, c)" if target == "hlsl" else "c = cellgl_texture(pos.xy / 64.0)"
        main = ("float4 main(float4 pos : SV_Position) : SV_Target\n"
                f"{{\n    float4 c;\n    {wrap};\n"
                "    return c + cellgl_texture(pos.yx / 64.0);\n}\n")
        glslang(tmp_path, f"{target}.hlsl", text + main, "-D", "-V", "-e", "main", "-S", "frag")
    elif d == "wgsl":
        wgsl_validate(text + "\n@fragment\nfn cellgl_main(@builtin(position) pos: vec4<f32>) "
                      "-> @location(0) vec4<f32>\n{\n    return cellgl_texture(pos.xy / 64.0);\n}\n")
    elif d == "osl":
        # Cycles' OSL compiler (bpy, the [blender] extra); renders: tests/test_blender.py
        try:
            from cellgl.blender import osl_compile
            from cellgl.blender.runtime import BlenderMissing

            osl_compile(text)
        except BlenderMissing:
            _missing("bpy (the [blender] extra, Cycles' OSL compiler)", REQUIRE_BLENDER)
    else:  # pragma: no cover
        raise AssertionError(target)


_WGPU_DEVICE = []


def wgpu_device():
    """The wgpu device on the first adapter (Mesa lavapipe here), made once per session."""
    try:
        import wgpu
    except ImportError:
        # Until .ci/setup installs wgpu (test extra) and mesa-vulkan-drivers, CI skips here;
        # CELLGL_REQUIRE_WGSL=1 turns the skip into a failure.
        _missing("the wgpu package (naga validates WGSL)", REQUIRE_WGSL)
    if not _WGPU_DEVICE:
        try:
            adapter = wgpu.gpu.request_adapter_sync(power_preference="low-power")
            _WGPU_DEVICE.append(adapter.request_device_sync())
        except Exception as exc:  # no Vulkan driver (Debian: mesa-vulkan-drivers)
            _missing(f"a wgpu adapter ({exc})", REQUIRE_WGSL)
    return _WGPU_DEVICE[0]


def wgsl_validate(text: str) -> None:
    wgpu_device().create_shader_module(code=text)   # raises with naga's message if invalid


# (a basis snippet compiling in every target: tests/test_export_compiler.py,
# test_basis_snippet_compiles, for these programs and the named basis functions alike)


# --------------------------------------------------------------------------------------------
# same numbers: render the snippet with ModernGL, compare with the GPU basis / the bake
# --------------------------------------------------------------------------------------------

_VERT = """#version 330 core
void main()
{
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
"""


def render_snippet(ctx, body: str, width: int, height: int, call: str = "cellgl_texture(uv)",
                   uniforms: dict | None = None) -> np.ndarray:
    """``call`` (default ``cellgl_texture(uv)``) of ``body`` at every pixel centre ``uv``, rows
    top to bottom (bake order); ``uniforms``: name -> value set on the program first."""
    frag = ("#version 330 core\n" + body +
            "uniform vec2 size;\nout vec4 cellgl_out;\n"
            f"void main() {{ vec2 uv = gl_FragCoord.xy / size; cellgl_out = {call}; }}\n")
    prog = ctx.program(vertex_shader=_VERT, fragment_shader=frag)
    prog["size"].value = (float(width), float(height))
    for name, value in (uniforms or {}).items():
        if name in prog:  # the compiler drops uniforms the code never reads
            prog[name].value = value
    key = (id(ctx), width, height)
    if key not in _TARGETS:          # kept for the session: releasing a bound FBO upsets moderngl
        tex = ctx.texture((width, height), 4, dtype="f4")
        _TARGETS[key] = (ctx.framebuffer(color_attachments=[tex]), tex)
    fbo = _TARGETS[key][0]
    vao = ctx.vertex_array(prog, [])
    try:
        fbo.use()
        fbo.viewport = (0, 0, width, height)
        fbo.clear()
        vao.render(mode=ctx.TRIANGLES, vertices=3)
        # FBO row k has gl_FragCoord.y = k + 0.5, i.e. v = (k + 0.5) / H: the bake's row k.
        data = np.frombuffer(fbo.read(components=4, dtype="f4"), dtype=np.float32)
        return data.reshape(height, width, 4).copy()
    finally:
        vao.release()
        prog.release()


_TARGETS: dict = {}


def snippet_code(text: str) -> str:
    """The code part of a snippet (everything after the header comment)."""
    return text.split("\n\n", 1)[1]


@pytest.mark.parametrize("target", ["glsl", "gles"])
@pytest.mark.parametrize("basis", list(BASES))
def test_basis_snippet_reproduces_the_gpu(ctx, basis, target):
    W, H, freq = 64, 48, 8.0
    p = BASES[basis]
    text = basis_snippet(basis, target)
    got = render_snippet(ctx, snippet_code(text), W, H)
    kw = dict(metric=p.metric.name.lower(), distribution=p.distribution.name.lower(),
              jitter=p.jitter, minkowski_p=p.minkowski_p, seed=p.seed,
              period=p.period[:2] if any(p.period) else None)
    ref = core.cellular_grid((H, W), origin=(0.5 * freq / W, 0.5 * freq / H),
                             spacing=(freq / W, freq / H), n=4, outputs=("F",), **kw)
    np.testing.assert_allclose(got, ref.F, rtol=2e-5, atol=2e-5)


# --------------------------------------------------------------------------------------------
# texture recipes: every preset to every target; the snippets reproduce the bake
# --------------------------------------------------------------------------------------------


def _presets() -> list[str]:
    from cellgl.recipes import list_presets, load_recipe

    return [name for name, _ in list_presets()                       # pups and cell images: refused
            if not name.startswith("pups-") and load_recipe(name).values["cell_color"] != "image"]


PRESETS = _presets()
#: a spread of features for the GLSL ES renders (fractal modes, metrics, splines, noise, 3D; domain
#: warp, stretched cells and orbiting points: caustics, wood-grain)
#: every target's sweep in the default tier (tests/tiers.py): 2D and 3D, fractal, density map, warp
QUICK_PRESETS = [p for p in ("f1", "flagstone", "qin-marble", "density", "caustics") if p in PRESETS]
GLES_PRESETS = [p for p in ("flagstone", "hull", "qin-marble", "qin-wrinkle", "craters", "worley-gallery",
                            "edge-cracks", "hammered", "caustics", "wood-grain")
                if p in PRESETS]


@pytest.mark.parametrize("target", list(export.TARGETS))
@pytest.mark.parametrize("preset", quick_few(PRESETS, QUICK_PRESETS))
def test_preset_compiles(tmp_path, preset, target):
    text = export.export(preset, target)
    assert f"cellular texture '{preset}'" in text
    compile_snippet(tmp_path, target, text)


def test_glsl_snippet_without_its_fragment_tail_compiles_as_a_compute_shader(tmp_path):
    # GLSL has no fwidth outside fragment shaders: the fwidth entry points come last, after a
    # marker, so a compute shader keeps everything before it and calls the _filtered entries.
    text = snippet_code(export.export("qin-wrinkle", "glsl"))
    head, tail = text.split("// Fragment (pixel) shaders only", 1)
    assert "fwidth(uv)" in tail and "fwidth(p)" in tail
    main = ("layout(local_size_x = 8) in;\nlayout(std430, binding = 0) buffer Out { vec4 cellgl_out[]; };\n"
            "void main() { uint i = gl_GlobalInvocationID.x; vec2 uv = vec2(float(i) / 64.0, 0.5);\n"
            "    cellgl_out[i] = cellgl_texture_filtered(uv, vec2(1.0 / 64.0))\n"
            "        + cellgl_texture3_filtered(vec3(uv, 0.25), vec3(1.0 / 64.0, 1.0 / 64.0, 0.0)); }\n")
    glslang(tmp_path, "compute.comp", "#version 430\n" + head + main)


@pytest.mark.parametrize("target", ["glsl", "gles", "hlsl", "godot"])
def test_uniforms_variant_compiles(tmp_path, target):
    text = export.export("flagstone", target, uniforms=True)
    code = re.sub(r"//[^\n]*", "", text)
    assert re.search(r"uniform (highp )?float cellgl_frequency;", code)
    compile_snippet(tmp_path, target, text)


def header_uniforms(text: str) -> dict:
    """What a client that reads the header's ``type name = value`` lines gets: name -> value
    (lines it cannot read as that, e.g. without a type, are skipped as a client would)."""
    import ast

    out = {}
    for m in re.finditer(r"^//   ([a-z]+[0-9]?(?:\[\d+\])?) (cellgl_\w+) = (.+)$", text, re.M):
        typ, name, value = m.groups()
        v = ast.literal_eval(value)
        out[name] = list(v) if typ.endswith("]") else v
    return out


@pytest.mark.parametrize("preset", ["density", "flagstone"])
def test_uniforms_header_reproduces_the_bake(ctx, preset):
    """Every uniform in the --uniforms header carries its type (the density map's three
    arrays had none: set from the header they stayed 0 and the image was wrong)."""
    W, H = 48, 32
    text = export.export(preset, "glsl", uniforms=True)
    code = snippet_code(text)
    declared = set(re.findall(r"^uniform \w+ (cellgl_\w+)", code, re.M))
    values = header_uniforms(text)
    assert declared <= set(values), sorted(declared - set(values))
    got = render_snippet(ctx, code, W, H, uniforms=values)
    np.testing.assert_allclose(got, _bake(preset, W, H), atol=2e-6)


@pytest.mark.parametrize("preset", ["f1", "flagstone", "hammered"])
def test_uniforms_header_types_are_the_declared_types(preset):
    """The header's type of each uniform is the type the snippet declares it with (vec4 values
    such as axis_scale were listed as vec4[4], ivec4 warp_cell as ivec4[4])."""
    text = export.export(preset, "glsl", uniforms=True)
    code = snippet_code(text)
    declared = {n: t + (f"[{a}]" if a else "")
                for t, n, a in re.findall(r"^uniform (\w+) (cellgl_\w+)(?:\[(\d+)\])?;", code, re.M)}
    listed = dict((n, t) for t, n in re.findall(r"^//   ([a-z]+[0-9]?(?:\[\d+\])?) (cellgl_\w+) = ", text, re.M))
    assert declared, text[:400]
    for name, typ in declared.items():
        assert listed.get(name) == typ, (name, listed.get(name), typ)
    assert listed["cellgl_warp_cell"] == "ivec4" and listed["cellgl_ramp"] == "vec4[16]"
    types = {n: t for t, n, _ in export.texture_program(preset).uniforms}
    assert (types["axis_scale"], types["warp_cell"], types["origin_cell"]) == ("vec4", "ivec4", "ivec4[8]")


def test_wgsl_uniforms_refused():
    with pytest.raises(export.ExportError, match="--uniforms is not supported for WGSL"):
        export.export("flagstone", "wgsl", uniforms=True)


def _bake(preset: str, W: int, H: int, **kw) -> np.ndarray:
    from cellgl import texture

    return texture.render(preset, W, H, channels=("color",), **kw)["color"]


@pytest.mark.parametrize("preset", quick_few(PRESETS, QUICK_PRESETS))
def test_glsl_snippet_reproduces_the_bake(ctx, preset):
    W, H = 64, 48
    got = render_snippet(ctx, snippet_code(export.export(preset, "glsl")), W, H)
    np.testing.assert_allclose(got, _bake(preset, W, H), rtol=0, atol=2e-5)


@pytest.mark.parametrize("preset", quick_few(GLES_PRESETS, ("flagstone", "qin-marble", "caustics")))
def test_gles_snippet_reproduces_the_bake(ctx, preset):
    # Desktop GL cannot run GLSL ES: the ES snippet's code (compiled as ES 3.00 by
    # test_preset_compiles) is rendered unchanged in a #version 330 shader.
    W, H = 64, 48
    got = render_snippet(ctx, snippet_code(export.export(preset, "gles")), W, H)
    np.testing.assert_allclose(got, _bake(preset, W, H), rtol=0, atol=2e-5)


def test_solid_entry_reproduces_a_volume_slice(ctx):
    from cellgl.recipes import load_recipe

    solid = next(p for p in GLES_PRESETS if load_recipe(p).values["dimension"] >= 3)
    W, H, D = 32, 24, 4
    body = snippet_code(export.export(solid, "glsl"))
    got = render_snippet(ctx, body, W, H, call="cellgl_texture3(vec3(uv, 0.625))")   # slice 2 of 4
    np.testing.assert_allclose(got, _bake(solid, W, H, depth=D)[2], rtol=0, atol=2e-5)


# WGSL and HLSL cannot run in OpenGL: they run as wgpu compute shaders on the Vulkan adapter
# (Mesa lavapipe), one invocation per pixel centre, writing vec4<f32> to a storage buffer. WGSL
# goes in as text (naga's WGSL frontend); HLSL is compiled to SPIR-V by glslangValidator -D and
# goes in as SPIR-V (naga's SPIR-V frontend). -Od: glslang's optimiser fuses a * b + c into
# fma() (e.g. the Euclidean x*x + y*y + z*z), which is allowed but is not what the bake's GL
# driver computes; it moves the F-values by an ulp and the bump-mapped presets' colours by up
# to about 2e-5. Unoptimised, the HLSL snippet gives the WGSL snippet's numbers.

def run_compute(code, entry: str, width: int, height: int) -> np.ndarray:
    """Dispatch ``entry`` of ``code`` (WGSL text or SPIR-V bytes) over width x height; binding 0
    of group 0 is the vec4<f32> result buffer. Rows top to bottom (bake order)."""
    import wgpu

    dev = wgpu_device()
    module = dev.create_shader_module(code=code)
    pipeline = dev.create_compute_pipeline(layout="auto",
                                           compute={"module": module, "entry_point": entry})
    buf = dev.create_buffer(size=width * height * 16,
                            usage=wgpu.BufferUsage.STORAGE | wgpu.BufferUsage.COPY_SRC)
    group = dev.create_bind_group(layout=pipeline.get_bind_group_layout(0),
                                  entries=[{"binding": 0, "resource": {"buffer": buf}}])
    enc = dev.create_command_encoder()
    cpass = enc.begin_compute_pass()
    cpass.set_pipeline(pipeline)
    cpass.set_bind_group(0, group)
    cpass.dispatch_workgroups((width + 7) // 8, (height + 7) // 8, 1)
    cpass.end()
    dev.queue.submit([enc.finish()])
    data = np.frombuffer(dev.queue.read_buffer(buf), dtype=np.float32)
    return data.reshape(height, width, 4).copy()


def run_snippet(tmp_path, target: str, text: str, width: int, height: int,
                call: str | None = None) -> np.ndarray:
    """``call`` of the wgsl / hlsl snippet ``text`` at every pixel centre ``uv`` (invocation
    (x, y) is pixel (x, y), uv = ((x + 0.5) / W, (y + 0.5) / H)), rows top to bottom. Default:
    ``cellgl_texture_filtered(uv, (1 / W, 1 / H))``, the bake's pixel (a compute shader has no
    derivatives for ``cellgl_texture(uv)``)."""
    if call is None:
        vec2 = "vec2<f32>" if target == "wgsl" else "float2"
        call = f"cellgl_texture_filtered(uv, {vec2}(1.0 / {width}.0, 1.0 / {height}.0))"
    code = snippet_code(text)
    if target == "wgsl":
        wgpu_device()     # skip before compiling anything when there is no adapter
        main = ("\n@group(0) @binding(0) var<storage, read_write> cellgl_result: array<vec4<f32>>;\n"
                "@compute @workgroup_size(8, 8)\n"
                "fn cellgl_main(@builtin(global_invocation_id) id: vec3<u32>)\n{\n"
                f"    if (id.x >= {width}u || id.y >= {height}u) {{ return; }}\n"
                f"    let uv = (vec2<f32>(id.xy) + vec2<f32>(0.5)) / vec2<f32>({width}.0, {height}.0);\n"
                f"    cellgl_result[id.y * {width}u + id.x] = {call};\n}}\n")
        return run_compute(code + main, "cellgl_main", width, height)
    assert target == "hlsl", target
    wgpu_device()
    main = ("\nRWStructuredBuffer<float4> cellgl_result : register(u0);\n"
            "[numthreads(8, 8, 1)]\n"
            "void main(uint3 id : SV_DispatchThreadID)\n{\n"
            f"    if (id.x >= {width}u || id.y >= {height}u) return;\n"
            f"    float2 uv = (float2(id.xy) + 0.5) / float2({width}.0, {height}.0);\n"
            f"    cellgl_result[id.y * {width}u + id.x] = {call};\n}}\n")
    glslang(tmp_path, "run.hlsl", code + main,
            "-D", "-V", "-S", "comp", "-e", "main", "--target-env", "vulkan1.1", "-Od")
    spirv = (tmp_path / "run.hlsl.spv").read_bytes()
    return run_compute(spirv, "main", width, height)


#: the GLSL ES spread (density: ~75 s to compile on lavapipe, left to the GLSL test)
RUN_PRESETS = GLES_PRESETS


@pytest.mark.parametrize("target", ["wgsl", "hlsl"])
@pytest.mark.parametrize("preset", quick_few(RUN_PRESETS, ("flagstone", "qin-marble")))
def test_wgsl_hlsl_snippet_reproduces_the_bake(tmp_path, preset, target):
    W, H = 32, 24
    got = run_snippet(tmp_path, target, export.export(preset, target), W, H)
    np.testing.assert_allclose(got, _bake(preset, W, H), rtol=0, atol=2e-5)


@pytest.mark.parametrize("target", ["wgsl", "hlsl"])
def test_wgsl_hlsl_solid_entry_reproduces_a_volume_slice(tmp_path, target):
    from cellgl.recipes import load_recipe

    solid = next(p for p in RUN_PRESETS if load_recipe(p).values["dimension"] >= 3)
    W, H, D = 32, 24, 4
    vec3 = "vec3<f32>" if target == "wgsl" else "float3"
    got = run_snippet(tmp_path, target, export.export(solid, target), W, H,       # slice 2 of 4
                      call=f"cellgl_texture3_filtered({vec3}(uv, 0.625), {vec3}(1.0 / {W}.0, 1.0 / {H}.0, 0.0))")
    np.testing.assert_allclose(got, _bake(solid, W, H, depth=D)[2], rtol=0, atol=2e-5)


def test_two_dimensional_recipes_have_no_solid_entry():
    from cellgl.recipes import load_recipe

    flat = [p for p in PRESETS if load_recipe(p).values["dimension"] == 2]
    for p in flat[:1]:
        assert "cellgl_texture3" not in export.export(p, "glsl")


def test_wgsl_header_says_cellgl_texture_is_for_fragment_shaders():
    """WGSL allows fwidth only in fragment shaders: the header says so, not only the file's end."""
    text = export.export("flagstone", "wgsl")
    header = text[:text.index("\nfn ")]
    words = " ".join(ln.lstrip("/ ") for ln in header.splitlines()[:16])
    assert "uses fwidth, so it works only in fragment shaders" in words, words
    assert "cellgl_texture_filtered(uv, duv)" in words
    assert "// Fragment (pixel) shaders only" in text[len(header):]     # the block the header names


# --------------------------------------------------------------------------------------------
# command line
# --------------------------------------------------------------------------------------------


def test_cli_export(tmp_path, capsys):
    from cellgl.cli import main

    out = tmp_path / "flag.gdshader"
    assert main(["export", "flagstone", "--target", "godot", "-o", str(out)]) == 0
    text = out.read_text()
    assert text.startswith("// cellgl ") and "shader_type canvas_item;" in text
    assert [p.name for p in tmp_path.iterdir()] == ["flag.gdshader"]      # no temp file left
    assert main(["export", "flagstone", "--set", "frequency=3"]) == 0
    assert "const float cellgl_frequency = 3.0;" in capsys.readouterr().out
    assert main(["export", "flagstone", "--target", "webgl1"]) == 2
    assert "WebGL1" in capsys.readouterr().err
    assert main(["export", "flagstone", "--target", "nope"]) == 2
    assert "expected one of: glsl, gles" in capsys.readouterr().err


@pytest.mark.parametrize("preset", ["flagstone", "qin-marble", "blender-voronoi"])
def test_unfolded_snippet_keeps_named_constants_and_the_bake(ctx, preset):
    """``fold=False`` (``cellgl export --no-fold``): the recipe's values stay named constants a
    user can edit, only reached code is emitted, and the pixels are the bake's."""
    text = export.export(preset, "glsl", fold=False)
    assert re.search(r"^const float cellgl_frequency = ", text, re.M)
    # only what the entry points reach: far less than the whole specialised library
    whole = export.specialised_code(export.texture_program(preset))
    assert len(snippet_code(text).splitlines()) < 0.8 * len(whole.splitlines())
    W, H = 64, 48
    got = render_snippet(ctx, snippet_code(text), W, H)
    np.testing.assert_allclose(got, _bake(preset, W, H), rtol=0, atol=2e-5)
