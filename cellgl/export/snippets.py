"""Self-contained shader snippets of a recipe for game engines: ``cellgl export``.

A snippet is the ``shaders/lib`` code a bake runs, specialised for one recipe (compile-time
choices resolved, no directive or macro left), with every top-level name prefixed ``cellgl_``
(structs ``Cellgl``), the recipe's values baked in as constants (or declared as uniforms), and
the entry points

* ``vec4 cellgl_texture(vec2 uv)``: the RGBA ``cellgl bake`` writes for the pixel whose centre
  is ``uv`` in [0, 1]^2;
* ``vec4 cellgl_texture3(vec3 p)``: solid recipes only, object-space texturing.

GLSL ES, Godot, HLSL and WGSL are generated mechanically from the same specialised GLSL
(:mod:`cellgl.export.translate`), never from a second copy of the maths.
"""
from __future__ import annotations

import json
import textwrap
from dataclasses import dataclass, field

from cellgl._version import __version__
from cellgl.gl import glsl
from cellgl.export import translate

__all__ = ["TARGETS", "REFUSED", "Program", "export", "export_program", "ExportError"]


class ExportError(ValueError):
    """A recipe cannot be exported to the requested target."""


@dataclass(frozen=True)
class Target:
    name: str
    dialect: str          # glsl | gles | godot | hlsl | wgsl
    title: str
    suffix: str           # file name suffix suggested in the header
    how: str              # one paragraph: where to paste, how to call


TARGETS: dict[str, Target] = {t.name: t for t in (
    Target("glsl", "glsl", "GLSL 3.30 core / 4.x", ".glsl",
           "Paste after your #version line (330 or later) and call cellgl_texture(uv)."),
    Target("gles", "gles", "GLSL ES 3.00 (WebGL2, three.js)", ".glsl",
           "Paste after '#version 300 es' and your precision lines (three.js: into the "
           "fragmentShader of a ShaderMaterial/RawShaderMaterial) and call cellgl_texture(uv). "
           "Every declaration is highp: the hashes need 32-bit integers."),
    Target("shadertoy", "gles", "Shadertoy (GLSL ES 3.00 with mainImage)", ".glsl",
           "Paste the whole file into a Shadertoy 'Image' tab; mainImage shows the texture "
           "stretched over the viewport."),
    Target("godot", "godot", "Godot 4 shader (.gdshader)", ".gdshader",
           "Save as cellgl.gdshader and assign it to a ShaderMaterial (canvas_item: a Sprite2D / "
           "TextureRect shows the texture on its UV)."),
    Target("godotinc", "godot", "Godot 4 shader include (.gdshaderinc)", ".gdshaderinc",
           "Save as res://cellgl.gdshaderinc, then in any shader: #include \"res://cellgl.gdshaderinc\" "
           "and call cellgl_texture(UV)."),
    Target("hlsl", "hlsl", "HLSL (Unity Custom Function node, DirectX)", ".hlsl",
           "Unity Shader Graph: Custom Function node, Type File, Source this file, Name "
           "cellgl_texture (the node calls cellgl_texture_float(UV, out Out)). Elsewhere: "
           "include or paste and call cellgl_texture(uv)."),
    Target("unreal", "hlsl", "HLSL for Unreal (.ush, Custom node)", ".ush",
           "Save under your project's Shaders/ directory as cellgl.ush (mapped with "
           "AddShaderSourceDirectoryMapping), then in a Material Custom node: Include File Paths "
           "/Project/cellgl.ush, Code 'return cellgl_texture(UV);', input UV, output Float 4."),
    Target("wgsl", "wgsl", "WGSL (WebGPU)", ".wgsl",
           "Paste into your WGSL module and call cellgl_texture(uv) (f32 vectors). cellgl_texture (and "
           "cellgl_texture3, if present) uses fwidth, so it works only in fragment shaders; in compute "
           "or vertex shaders call cellgl_texture_filtered(uv, duv) and delete the file from the "
           "comment 'Fragment (pixel) shaders only' to the end."),
)}

#: target names that are refused, with the reason
REFUSED: dict[str, str] = {
    "gles100": "GLSL ES 1.00 (WebGL1) has no 32-bit unsigned integers or bit operations, which "
               "cellgl's integer hashes need; it is refused rather than emitted in a form that "
               "cannot compile. Use --target gles (WebGL2 / GLSL ES 3.00).",
}
REFUSED["webgl1"] = REFUSED["gles100"]
REFUSED["webgl"] = REFUSED["gles100"]


@dataclass
class Program:
    """What a snippet is made of, before specialisation (GLSL text using library names).

    files : library files (relative to the shader root) to resolve, dependencies first
    defines : the compile-time macros of the recipe
    params : GLSL declarations of the recipe's run-time values (constants or uniforms)
    entry : GLSL of the entry functions (``cell_texture`` ...), calling the library
    title : the recipe's name; recipe: its JSON-able dict (for the header)
    solid : whether ``cell_texture3`` exists
    uniforms : ``[(glsl type, name, value)]`` of the uniforms when ``params`` declares them
    filtered : whether ``cellgl_texture_filtered`` (and ``cellgl_texture3_filtered``) exist
    """

    files: list[str]
    defines: dict
    params: str
    entry: str
    title: str = "recipe"
    recipe: dict | None = None
    solid: bool = False
    uniforms: list[tuple[str, str, object]] = field(default_factory=list)
    filtered: bool = False


def check_target(target: str) -> Target:
    """Return the :class:`Target` named ``target``; clear errors for refused or unknown ones."""
    key = str(target).strip().lower()
    if key in REFUSED:
        raise ExportError(f"target {target!r} is not supported: {REFUSED[key]}")
    if key not in TARGETS:
        raise ExportError(f"unknown target {target!r}; expected one of: {', '.join(TARGETS)}")
    return TARGETS[key]


# --------------------------------------------------------------------------------------------
# pipeline
# --------------------------------------------------------------------------------------------


def library_code(prog: Program) -> str:
    """Specialised, prefixed GLSL of ``prog`` (library + params + entry); no directive left."""
    src = glsl.resolve_library(prog.files)
    text = src.text + "\n" + prog.params + "\n" + prog.entry
    text = text.replace("// begin lib/", "// ---- shaders/lib/").replace("// end lib/", "// ---- end of shaders/lib/")
    text = translate.specialise(text, prog.defines, name="snippet")
    text, _ = translate.prefix_names(text, overrides=_OVERRIDES)
    return _tidy(text)


def _tidy(text: str) -> str:
    lines = [ln.rstrip() for ln in text.split("\n")]
    out: list[str] = []
    for ln in lines:
        if not ln and (not out or not out[-1]):
            continue
        out.append(ln)
    return "\n".join(out).strip("\n") + "\n"


def _comment(text: str, mark: str = "//") -> str:
    return "\n".join(f"{mark} {ln}".rstrip() for ln in text.split("\n"))


def _header(prog: Program, target: Target, uniforms: bool) -> str:
    recipe = json.dumps(prog.recipe, indent=1, sort_keys=False) if prog.recipe is not None else "{}"
    entry = [
        "vec4 cellgl_texture(vec2 uv)   uv in [0,1]^2 -> the RGBA `cellgl bake` writes for the "
        "pixel centred at uv" + (" (fragment shaders: the pixel size from fwidth(uv))" if prog.filtered else ""),
    ]
    if prog.filtered:
        entry.append("vec4 cellgl_texture_filtered(vec2 uv, vec2 duv)   the same for a pixel of size duv in uv "
                     "(a W x H bake: (1/W, 1/H)); any stage")
    if prog.solid:
        entry.append("vec4 cellgl_texture3(vec3 p)   p = (u, v, z) in texture space (solid texturing; z = 0: the image)")
        entry.append("vec4 cellgl_texture3_filtered(vec3 p, vec3 dp)   the same for a pixel spanning dp; any stage")
    if target.dialect == "hlsl":
        entry = [e.replace("vec4", "float4").replace("vec3", "float3").replace("vec2", "float2") for e in entry]
    if target.dialect == "wgsl":
        entry = [e.replace("vec4 cellgl_texture(vec2 uv)", "fn cellgl_texture(uv: vec2<f32>) -> vec4<f32>")
                  .replace("vec4 cellgl_texture3(vec3 p)", "fn cellgl_texture3(p: vec3<f32>) -> vec4<f32>")
                  .replace("vec4 cellgl_texture_filtered(vec2 uv, vec2 duv)",
                           "fn cellgl_texture_filtered(uv: vec2<f32>, duv: vec2<f32>) -> vec4<f32>")
                  .replace("vec4 cellgl_texture3_filtered(vec3 p, vec3 dp)",
                           "fn cellgl_texture3_filtered(p: vec3<f32>, dp: vec3<f32>) -> vec4<f32>")
                 for e in entry]
    lines = [
        f"cellgl {__version__}: cellular texture '{prog.title}' for {target.title}.",
        f"Generated by `cellgl export {prog.title} --target {target.name}"
        f"{' --uniforms' if uniforms else ''}` from cellgl's shaders/lib; re-export instead of editing.",
        "",
        "Entry points:",
        *("  " + e for e in entry),
        "",
        *textwrap.wrap(target.how, 94),
    ]
    settings = ", ".join(f"{k}={v}" for k, v in prog.defines.items()
                         if k.startswith("CELL_") and not k.startswith(("CELL_METRIC_", "CELL_DIST_")))
    lines += ["", "Compile-time settings resolved in this code (comments may name them):",
              *textwrap.wrap(settings, 94)]
    if uniforms and prog.uniforms:
        lines += ["", "Uniforms (set them to these values to reproduce the recipe):"]
        for typ, name, value in prog.uniforms:
            lines.append(f"  {typ} cellgl_{name} = {_fmt_value(value)}")
        if any(name == "origin_cell" for _, name, _ in prog.uniforms):
            lines += [""] + textwrap.wrap(
                "offset_x/offset_y/offset_z/time act only through the split origins origin_cell + "
                "origin_frac (and noise_cell + noise_frac), octave i = floor and rest of "
                "lacunarity^i * (offset_x, offset_y, offset_z, time) times dist_scale (times "
                "noise_frequency), computed in double precision: recompute them to animate "
                "(docs/engines.md).", 94)
    lines += ["", "Recipe:", *recipe.split("\n")]
    return _comment("\n".join(lines)) + "\n"


def _fmt_value(v) -> str:
    if isinstance(v, (list, tuple)):
        return "(" + ", ".join(_fmt_value(x) for x in v) + ")"
    if isinstance(v, float):
        return repr(v)
    return str(v)


def export_program(prog: Program, target: str = "glsl", *, uniforms: bool = False) -> str:
    """The snippet of ``prog`` for ``target`` (see :data:`TARGETS`)."""
    tgt = check_target(target)
    code = library_code(prog)
    head = _header(prog, tgt, uniforms)
    d = tgt.dialect
    if d == "glsl":
        body = code
    elif d == "gles":
        body = translate.add_highp(code)
        if tgt.name == "shadertoy":
            body += _SHADERTOY_MAIN
    elif d == "godot":
        body = _godot(code, tgt.name)
    elif d == "hlsl":
        body = translate.to_hlsl(code) + _UNITY_WRAPPER
        if tgt.name == "unreal":
            body = "#pragma once\n\n" + body
    elif d == "wgsl":
        body = translate.to_wgsl(code)
    else:  # pragma: no cover
        raise AssertionError(d)
    return head + "\n" + body


_SHADERTOY_MAIN = """
// Shadertoy entry: the texture stretched over the viewport, image row 0 at the top.
void mainImage(out vec4 fragColor, in vec2 fragCoord)
{
    vec2 uv = fragCoord / iResolution.xy;
    fragColor = cellgl_texture(vec2(uv.x, 1.0 - uv.y));
}
"""

_UNITY_WRAPPER = """
// Unity Shader Graph Custom Function node (Type: File, Name: cellgl_texture).
void cellgl_texture_float(float2 UV, out float4 Out)
{
    Out = cellgl_texture(UV);
}
"""


def _godot(code: str, name: str) -> str:
    # Godot compiles its shaders with highp defaults (precision highp float/int), so the code
    # needs no qualifiers.
    body = code
    if name == "godotinc":
        return body
    return (
        "shader_type canvas_item;\n\n" + body +
        "\nvoid fragment()\n{\n    COLOR = cellgl_texture(UV);\n}\n"
    )


# --------------------------------------------------------------------------------------------
# public API
# --------------------------------------------------------------------------------------------


def export(recipe, target: str = "glsl", *, uniforms: bool = False) -> str:
    """Export ``recipe`` as a self-contained shader snippet.

    Parameters
    ----------
    recipe : cellgl.texture.recipe.Recipe, str or path
        A recipe, a preset name or a recipe JSON file.
    target : str
        One of :data:`TARGETS` (``glsl``, ``gles``, ``shadertoy``, ``godot``, ``godotinc``,
        ``hlsl``, ``unreal``, ``wgsl``). ``gles100``/``webgl1`` are refused with the reason.
    uniforms : bool
        Declare the recipe's run-time values as ``cellgl_<name>`` uniforms instead of baking
        them in as constants.

    Returns
    -------
    str
        The snippet text.

    Raises
    ------
    ExportError
        Unknown or refused target, or a recipe the target cannot express.
    """
    tgt = check_target(target)
    if uniforms and tgt.dialect == "wgsl":
        raise ExportError("--uniforms is not supported for WGSL (uniforms need a bind group "
                          "layout of your renderer); export WGSL with constants")
    prog = texture_program(recipe, uniforms=uniforms)
    return export_program(prog, target, uniforms=uniforms)


def _refuse_pups(r) -> None:
    if getattr(r, "kind", None) == "pups":
        raise ExportError(f"{r.name}: PUPs recipes cannot be exported as shader snippets (a "
                          "snippet would need the control points, their Delaunay axes and the "
                          "candidate grid as buffers); bake it to an image instead: cellgl bake "
                          f"{r.name} -o {r.name}.png")


def _refuse_density_image(r) -> None:
    if r.values["density_map"] == "image":
        raise ExportError(f"{r.name}: basis.density_map 'image' cannot be exported as a shader snippet "
                          "(the snippet would need the density image's levels as a storage buffer or "
                          "texture, which the engines bind differently); use density_map ramp_x, ramp_y "
                          f"or radial (exported as constants), or bake it: cellgl bake {r.name} -o "
                          f"{r.name}.png")


def _refuse_cell_image(r) -> None:
    if r.values["cell_color"] == "image":
        raise ExportError(f"{r.name}: color.cell_color 'image' cannot be exported as a shader snippet (the "
                          "snippet would need the cell image as a storage buffer or texture, which the "
                          "engines bind differently); sample your own texture at the cell's feature point, "
                          f"or bake it: cellgl bake {r.name} -o {r.name}.png")


#: lib name -> exported name, where the default prefix would collide with an entry point
_OVERRIDES = {"cell_texture": "cellgl_texture_basis", "cell_texture_filtered": "cellgl_texture_basis_filtered"}


def texture_program(recipe, *, uniforms: bool = False) -> Program:
    """The :class:`Program` of a texture recipe: ``shaders/lib/texture.glsl`` with the recipe's
    defines, its values as ``cell_<name>`` constants (or uniforms) read by the generated loader,
    and the entry points ``cellgl_texture_filtered(uv, duv)`` (= ``cell_texture_uv``, what the
    bake runs), ``cellgl_texture(uv)`` (the same with ``duv = fwidth(uv)``) and, for solid
    recipes, ``cellgl_texture3(p)`` / ``cellgl_texture3_filtered(p, dp)``."""
    from cellgl.recipes import load_recipe
    from cellgl.texture import shader as texture

    r = load_recipe(recipe)
    _refuse_pups(r)
    _refuse_density_image(r)
    _refuse_cell_image(r)
    defines = texture.defines(r)
    solid = int(r.values["dimension"]) >= 3
    vals = texture.uniform_values(r)
    if uniforms:
        params = ("// The recipe's run-time values (set them from the header's table).\n"
                  + texture.glsl_uniform_block(prefix="cell_"))
    else:
        params = ("// The recipe's run-time values.\n"
                  + texture.glsl_constant_block(r, prefix="cell_"))
    params += "\n// All of them in the library's parameter struct.\n"
    params += texture.glsl_params_from_uniforms(prefix="cell_", function="cell_texture_params_load")
    entry = (
        "// The RGBA `cellgl bake` writes for the pixel whose centre is uv (v = 0: top row) and\n"
        "// whose size in uv is duv (a W x H bake: (1/W, 1/H)): fractal octaves finer than the\n"
        "// pixel fade out (band limit); duv = (0, 0): point samples. Any shader stage.\n"
        "vec4 cellgl_texture_filtered(vec2 uv, vec2 duv)\n"
        "{\n"
        "    return cell_texture_uv(uv, duv, cell_texture_params_load());\n"
        "}\n"
    )
    if solid:
        entry += (
            "\n// Solid texturing: the texture at p = (u, v, z) in texture space (object space\n"
            "// scaled so that 1 unit = the image width; z = 0 is the image plane), band-limited\n"
            "// to a pixel spanning dp in texture space (0: point samples). Any shader stage.\n"
            "vec4 cellgl_texture3_filtered(vec3 p, vec3 dp)\n"
            "{\n"
            "    return cell_texture_at_filtered(p, dp, cell_texture_params_load()).color;\n"
            "}\n"
        )
    # Last, so that a compute or vertex shader (no derivatives there) can drop them.
    entry += (
        "\n// Fragment (pixel) shaders only, the pixel's size from derivatives: delete from here\n"
        "// to the end in other stages, which have no fwidth.\n"
        "vec4 cellgl_texture(vec2 uv)\n"
        "{\n"
        "    return cellgl_texture_filtered(uv, fwidth(uv));\n"
        "}\n"
    )
    if solid:
        entry += (
            "\nvec4 cellgl_texture3(vec3 p)\n"
            "{\n"
            "    return cellgl_texture3_filtered(p, fwidth(p));\n"
            "}\n"
        )
    # every uniform the values fill, the density map's included: a header line without its type
    # would leave a client that reads `type name = value` with that uniform at 0
    decl_types = {n: t for t, n, _ in texture._uniform_decls("") + texture._uniform_decls("", True)}
    ulist = [(decl_types[k[2:]] + (f"[{len(v)}]" if isinstance(v, (list, tuple)) else ""), k[2:], v)
             for k, v in vals.items()]
    return Program(files=["lib/texture.glsl"], defines=defines, params=params, entry=entry,
                   title=r.name, recipe=r.to_dict(), solid=solid, uniforms=ulist, filtered=True)


# --------------------------------------------------------------------------------------------
# the bare cellular basis (F1..F4 as RGBA): the machinery's own test program
# --------------------------------------------------------------------------------------------


def _glsl_float(v: float) -> str:
    r = repr(float(v))
    return r if ("." in r or "e" in r or "n" in r) else r + ".0"


def basis_program(p, n: int = 4, frequency: float = 8.0) -> Program:
    """A program whose ``cellgl_texture(uv)`` returns ``(F1, F2, F3, F4)`` of the basis ``p``
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
    return Program(files=["lib/cellular.glsl"], defines=d, params=params, entry=entry,
                   title="basis", recipe={"basis": "F1..F4", "frequency": frequency})


# --------------------------------------------------------------------------------------------
# command line: cellgl export PRESET_OR_RECIPE --target TARGET [-o FILE]
# --------------------------------------------------------------------------------------------


def add_parser(sub):
    """Declare ``cellgl export`` on the CLI's subparsers."""
    p = sub.add_parser(
        "export", help="write a self-contained shader snippet of a recipe (GLSL, GLSL ES, "
        "Godot, HLSL, WGSL)",
        description="Export a recipe as a shader snippet whose cellgl_texture(uv) returns the "
        "pixels `cellgl bake` writes. See docs/engines.md.")
    p.add_argument("recipe", metavar="PRESET_OR_RECIPE", help="a preset name or a recipe JSON file")
    p.add_argument("--target", "-t", default="glsl", metavar="TARGET",
                   help="one of: " + ", ".join(TARGETS) + " (default glsl)")
    p.add_argument("-o", "--output", metavar="FILE", default=None,
                   help="write to FILE (atomically) instead of standard output")
    p.add_argument("--uniforms", action="store_true",
                   help="declare the recipe's run-time values as cellgl_<name> uniforms instead of "
                   "constants")
    p.add_argument("--set", dest="sets", action="append", default=[], metavar="NAME=VALUE",
                   help="override a recipe parameter (repeatable)")
    return p


def run_cli(args) -> int:
    """Run ``cellgl export``; returns the exit status."""
    import os
    import sys

    from cellgl.io.tempfiles import check_output

    check_target(args.target)
    if args.output is not None:  # before the work: a missing or read-only directory, a long name
        check_output(os.path.abspath(args.output))
    recipe = _load(args.recipe, args.sets)
    text = export(recipe, args.target, uniforms=args.uniforms)
    if args.output is None:
        sys.stdout.write(text)
        return 0
    from cellgl.io.formats import atomic_path

    with atomic_path(os.path.abspath(args.output)) as tmp:
        with open(tmp, "w", encoding="utf-8", newline="\n") as f:
            f.write(text)
    return 0


def _load(recipe, sets=()):
    from cellgl.recipes import load_recipe

    r = load_recipe(recipe)
    if sets:
        r = r.set_from_strings(list(sets))
    return r
