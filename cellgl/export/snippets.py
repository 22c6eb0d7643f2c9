"""Self-contained shader snippets of a recipe for game engines: ``cellgl export``.

A snippet is the ``shaders/lib`` code a bake runs, specialised for one recipe (compile-time
choices resolved, no directive or macro left), with every top-level name prefixed ``cellgl_``
(structs ``Cellgl``), the recipe's values baked in as constants (or declared as uniforms), and
the entry points

* ``vec4 cellgl_texture(vec2 uv)``: the RGBA ``cellgl bake`` writes for the pixel whose centre
  is ``uv`` in [0, 1]^2;
* ``vec4 cellgl_texture3(vec3 p)``: solid recipes only, object-space texturing.

Every target is printed from one syntax tree of the compiled GLSL (:mod:`cellgl.export.syntax`;
GLSL, GLSL ES, Godot and HLSL by :mod:`cellgl.export.printer`, WGSL and OSL by
:mod:`cellgl.export.translate`), never from a second copy of the maths.
"""
from __future__ import annotations

import json
import os
import re
import shlex
import textwrap
from dataclasses import dataclass, field

from cellgl._cache import Bounded
from cellgl._version import __version__
from cellgl.gl import glsl
from cellgl.export import compiler, translate
from cellgl.export.names import comment_text, identifier
from cellgl.export.printer import Hlsl, print_lines, print_target
from cellgl.export.syntax import Global, Unit, parse, parsed_library
from cellgl.export.translate.wgsl import Wgsl

__all__ = ["TARGETS", "REFUSED", "Program", "export", "export_program", "ExportError", "recipe_command",
           "command_for"]


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
    Target("osl", "osl", "Open Shading Language (Blender Cycles, Arnold, RenderMan, Houdini)", ".osl",
           "Save as cellgl_<name>.osl and load it as a shader (Blender: Script node, Cycles with Open "
           "Shading Language on; docs/engines.md): Vector in, Color, Fac, F1..F4, Value, CellColor, "
           "CellValue, IDLow/IDHigh and a bump Normal out."),
)}

#: target names that are refused, with the reason
REFUSED: dict[str, str] = dict.fromkeys(
    ("gles100", "webgl1", "webgl"),
    "GLSL ES 1.00 (WebGL1) has no 32-bit unsigned integers or bit operations, which cellgl's integer "
    "hashes need; it is refused rather than emitted in a form that cannot compile. Use --target gles "
    "(WebGL2 / GLSL ES 3.00).")


@dataclass
class Program:
    """What a snippet is made of, before specialisation (GLSL text using library names)."""

    files: list[str]            # library files (relative to the shader root) to resolve, dependencies first
    defines: dict               # the compile-time macros of the recipe
    params: str                 # GLSL declarations of the recipe's run-time values (constants or uniforms)
    entry: str                  # GLSL of the entry functions (``cell_texture`` ...), calling the library
    title: str = "recipe"       # the recipe's name
    recipe: dict | None = None  # its JSON-able dict (for the header)
    solid: bool = False         # whether ``cell_texture3`` exists
    #: ``[(glsl type, name, value)]`` of the uniforms when ``params`` declares them
    uniforms: list[tuple[str, str, object]] = field(default_factory=list)
    filtered: bool = False      # whether ``cellgl_texture_filtered`` (and ``cellgl_texture3_filtered``) exist
    kind: str = "cellular texture"
    command: str = ""
    signatures: tuple = ()
    entries: tuple = ()
    #: the target-specific tails (``shadertoy``: mainImage, ``godot``: fragment(), ``unity``: the
    #: Custom Function wrapper, HLSL); default: those of cellgl_texture
    tails: dict = field(default_factory=dict)


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


def library_code(prog: Program, fold: bool = True, tree: bool = False):
    """Specialised, prefixed GLSL of ``prog`` (library + params + entry); no directive left,
    only what the entry points reach (:mod:`cellgl.export.fold`); ``fold=False`` keeps the
    recipe's values as the named constants they are declared as; ``tree``: the compiled tree
    itself (to print, not to change). Cached per program: the targets of one recipe share it."""
    key = (tuple(prog.files), tuple(sorted((k, str(v)) for k, v in prog.defines.items())), prog.params,
           prog.entry, tuple(prog.entries), fold)
    unit = _CODE_CACHE.get(key)
    if unit is None:
        unit = compiled_unit(prog, fold)
        _CODE_CACHE.put(key, unit)
    return unit if tree else code_text(unit)


_CODE_CACHE = Bounded("compiled snippet units (cellgl.export.snippets.library_code)", 64)


def specialised_code(prog: Program) -> str:
    """The library of ``prog`` with its compile-time choices resolved and names prefixed, its
    run-time values still the loader's named constants (the OSL target turns those into shader
    parameters, so it takes this code, not a constant-folded one)."""
    text = glsl.resolve_library(prog.files).text + "\n" + prog.params + "\n" + prog.entry
    text = text.replace("// begin lib/", "// ---- shaders/lib/").replace("// end lib/", "// ---- end of shaders/lib/")
    text = translate.specialise(text, prog.defines, name="snippet")
    text, _ = translate.prefix_names(text, overrides=_OVERRIDES)
    return _tidy(text)


def entry_points(prog: Program) -> list[str]:
    """The functions the reachability pass starts from: ``prog.entries``, or else those of
    :data:`ENTRY_POINTS` that the program's entry code defines."""
    return list(prog.entries) or [n for n in ENTRY_POINTS
                                  if re.search(rf"\b{n}\s*\(", prog.entry.replace("cell_", "cellgl_"))]


def compiled_unit(prog: Program, fold: bool = True, entries=None):
    """The compiled tree of ``prog`` (:func:`cellgl.export.compiler.compile_unit`; yours to
    change) for its entry points (or ``entries``): :func:`code_text` prints it as
    :func:`library_code` does."""
    # a texture keeps its search one function (benchmarks/bench_snippets.py --stub-search swaps
    # its body); a basis snippet is little more than the search, written into its entry point
    return compiler.compile_unit(specialised_code(prog), entries or entry_points(prog), structs=CONSTANT_STRUCTS,
                                 fold_constants=fold, keep=() if prog.entries else ("cellgl_search_budget",))


def code_text(unit) -> str:
    """The GLSL text of a compiled tree, as :func:`library_code` gives it."""
    return _tidy(print_lines(unit))


#: the functions a snippet may export (the reachability pass starts from those it defines)
ENTRY_POINTS = ("cellgl_texture", "cellgl_texture_filtered", "cellgl_texture3", "cellgl_texture3_filtered")
#: parameter structs that only ever hold their loader's values: scalarised away (reach.scalarise)
CONSTANT_STRUCTS = (("CellglTextureParams", "cellgl_texture_params_load"), ("CellglParams", "cellgl_params_load"),
                     ("CellglParams", "cellgl_tex_basis_"))


def _tidy(text: str) -> str:
    """``text`` without trailing spaces, blank lines at either end or two blank lines in a row."""
    out: list[str] = []
    for ln in text.split("\n"):
        if ln.rstrip() or out and out[-1]:
            out.append(ln.rstrip())
    return "\n".join(out).strip("\n") + "\n"


def _comment(text: str, mark: str = "//") -> str:
    return "\n".join(f"{mark} {ln}".rstrip() for ln in text.split("\n"))


def _header(prog: Program, target: Target, uniforms: bool, declared: set | None = None) -> str:
    """The comment block on top of a snippet; ``declared``: the code's global names (the
    uniforms listed are those of them)."""
    entry = list(prog.signatures) if prog.signatures else [
        "vec4 cellgl_texture(vec2 uv): the RGBA `cellgl bake` writes for the pixel centred at uv in "
        "[0,1]^2 (v = 0: top row)" + ("; fragment shaders (pixel size from fwidth(uv))" if prog.filtered else "")]
    if prog.filtered and not prog.signatures:
        entry.append("vec4 cellgl_texture_filtered(vec2 uv, vec2 duv): the same for a pixel of size duv "
                     "(a W x H bake: (1/W, 1/H)); any stage")
    if prog.solid and not prog.signatures:
        entry.append("vec4 cellgl_texture3(vec3 p): p = (u, v, z) in texture space (solid texturing; z = 0: "
                     "the image)")
        entry.append("vec4 cellgl_texture3_filtered(vec3 p, vec3 dp): the same for a pixel spanning dp; any stage")
    entry = [_signature(e, target.dialect) for e in entry]
    command = prog.command or f"cellgl export {prog.title}"
    if target.dialect == "osl" and prog.entries:
        from cellgl.export.osl import basis_signature

        entry = [basis_signature(prog)]
    elif target.dialect == "osl":
        entry = [f"shader {identifier(prog.title)}(point Vector, <the recipe's values>, output color Color, "
                 "output float Fac, ..., output normal Normal): Vector (x, y) in [0,1]^2 -> the RGB "
                 "`cellgl bake` writes for the pixel centred at (u, v) = (x, 1 - y)"]
    lines = [
        f"cellgl {__version__} {prog.kind} '{comment_text(prog.title)}' for {target.title}, exact (the same values as "
        + ("cellgl.cellular" if prog.signatures else "`cellgl bake`") + "). Regenerate (do not edit): "
        f"{comment_text(command)} --target {target.name}{' --uniforms' if uniforms else ''}",
        *("  " + e for e in entry),
        *textwrap.wrap(_how(target, prog), 116),
    ]
    if uniforms and prog.uniforms:
        lines += ["Uniforms (set them to these values to reproduce the recipe):"]
        for typ, name, value in prog.uniforms:
            if declared is None or f"cellgl_{name}" in declared:
                lines.append(f"  {typ} cellgl_{name} = {_fmt_value(value)}")
        if any(name == "origin_cell" for _, name, _ in prog.uniforms):
            lines += textwrap.wrap(
                "offset_x/offset_y/offset_z/time act only through the split origins origin_cell + "
                "origin_frac (and noise_cell + noise_frac), octave i = floor and rest of "
                "lacunarity^i * (offset_x, offset_y, offset_z, time) times dist_scale (times "
                "noise_frequency), computed in double precision: recompute them to animate "
                "(docs/engines.md).", 96)
    recipe = json.dumps(prog.recipe, separators=(",", ":")) if prog.recipe is not None else "{}"
    if not prog.signatures:                  # a basis snippet's command holds its parameters
        lines += ["Recipe: " + recipe]
    return _comment("\n".join(lines)) + "\n"


def _how(target: Target, prog: Program) -> str:
    """The target's paragraph on where to paste and what to call, for this program's entry."""
    if not prog.entries:
        return target.how
    if target.dialect == "osl":
        return (f"Save as cellgl_basis_{prog.title}.osl and load it as a shader (Blender: Script node, "
                "Cycles with Open Shading Language on; docs/engines.md).")
    entry = prog.entries[0]
    # a basis function has no fwidth: leave out what the texture's how says about it
    how = " ".join(x for x in re.split(r"(?<=\.) ", target.how)
                   if "fwidth" not in x and "Fragment (pixel)" not in x)
    how = how.replace("(canvas_item: a Sprite2D / TextureRect shows the texture on its UV)",
                      "(canvas_item; fragment() shows it, 8 cells per UV unit)")
    how = how.replace("mainImage shows the texture stretched over the viewport",
                      "mainImage shows it, 8 cells per screen height")
    how = re.sub(r"cellgl_texture\((uv|UV)\)", entry + "(p)", how)
    size = {"vec2": 2, "vec3": 3, "vec4": 4}.get(prog.signatures[0].split()[0], 1) if prog.signatures else 4
    how = how.replace("output Float 4", f"output Float {size}")
    return how.replace("cellgl_texture", entry).replace("input UV", "input p").replace("(UV, out Out)", "(p, out Out)")


def _signature(e: str, dialect: str) -> str:
    """An entry line ``TYPE name(TYPE a, ...): what`` in the target's spelling (its printer's types)."""
    if dialect == "hlsl":
        return re.sub(r"\b[iu]?vec[234]\b", lambda m: Hlsl.TYPES[m.group()], e)
    if dialect == "wgsl":
        m = re.match(r"(\w+) (\w+)\(([^)]*)\)(.*)$", e, re.S)
        if m:
            ret, name, args, rest = m.groups()
            typ = Wgsl(Unit([])).type
            params = ", ".join(f"{a.split()[1]}: {typ(a.split()[0])}" for a in args.split(",") if a.strip())
            return f"fn {name}({params}) -> {typ(ret)}{rest}"
    return e


def _fmt_value(v) -> str:
    if isinstance(v, (list, tuple)):
        return "(" + ", ".join(_fmt_value(x) for x in v) + ")"
    return str(v)       # a float's shortest round-trip digits (also a NumPy 2 float's, which repr would tag)


def recipe_command(recipe: str, sets=(), *, fold: bool = True) -> str:
    """``cellgl export RECIPE [--set NAME=VALUE ...] [--no-fold]`` (the target and
    ``--uniforms`` are added by the header), each word quoted for a POSIX shell."""
    words = ["cellgl", "export", str(recipe)]
    for s in sets:
        words += ["--set", str(s)]
    if not fold:
        words.append("--no-fold")
    return shlex.join(words)


def _set_text(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (list, tuple)):
        return json.dumps(value, separators=(",", ":"))
    return str(value)


def command_for(recipe, *, fold: bool = True) -> str:
    """The ``Regenerate (do not edit)`` command of the header of :func:`export`'s snippet of
    ``recipe``: a ``cellgl export`` command line that writes the same snippet, byte for byte (in
    the directory it was run from, for a recipe file given by a relative path). The command line
    passes what it was given (:func:`recipe_command`); from Python, a preset or file name as
    given, and a :class:`~cellgl.texture.recipe.Recipe` object as its preset plus one ``--set``
    per parameter that differs. A recipe object that no preset and ``--set`` list reproduces
    (another name, another ramp) gets ``cellgl export RECIPE.json``: the header's ``Recipe:``
    line saved as ``RECIPE.json`` makes that command write the same snippet."""
    from cellgl.recipes import load_recipe

    if isinstance(recipe, (str, os.PathLike)):
        return recipe_command(os.fspath(recipe), fold=fold)
    try:
        base = load_recipe(recipe.name)
    except (ValueError, OSError):
        base = None
    if base is not None and type(base) is type(recipe):
        sets = [f"{k}={_set_text(v)}" for k, v in recipe.values.items() if base.values[k] != v]
        try:
            same = base.set_from_strings(sets) == recipe if sets else base == recipe
        except ValueError:
            same = False
        if same:
            return recipe_command(recipe.name, sets, fold=fold)
    return recipe_command("RECIPE.json", fold=fold)     # the header's Recipe line, saved


@compiler.collector_paused()
def export_program(prog: Program, target: str = "glsl", *, uniforms: bool = False, fold: bool = True,
                   code=None) -> str:
    """The snippet of ``prog`` for ``target`` (see :data:`TARGETS`); ``fold=False``: the
    recipe's values stay named constants (see :func:`export`); ``code``: the compiled code to
    print (default: :func:`library_code`'s), as text or as :func:`compiled_unit`'s tree (printed
    as it is, without the parse of its text; the printers only read it)."""
    tgt = check_target(target)
    d = tgt.dialect
    tree = None if code is None or isinstance(code, str) else code
    if d == "osl":
        # OSL keeps a texture's run-time values as shader parameters (unfolded code); a basis
        # snippet has none, so it takes the folded code like every other target
        from cellgl.export.osl import osl_shader

        code = code_text(tree) if tree is not None else code if code is not None \
            else library_code(prog, fold) if prog.entries else specialised_code(prog)
        return _header(prog, tgt, uniforms) + "\n" + osl_shader(prog, code, specialised_code, CONSTANT_STRUCTS)
    # the one parse (none for a tree); the printers only read it
    unit = tree if tree is not None else library_code(prog, fold, True) if code is None else parsed_library(code)
    head = _header(prog, tgt, uniforms, {d.name for it in unit.items if isinstance(it, Global) for d in it.declarators})
    if d == "wgsl":
        return head + "\n" + translate.to_wgsl(unit)
    body = print_target(unit, d)
    if tgt.name in _TAILS:
        key, default, dialect = _TAILS[tgt.name]
        body += print_target(parse(prog.tails.get(key, default)), dialect)
    return head + "\n" + _FIRST_LINE.get(tgt.name, "") + body


_SHADERTOY_MAIN = """
// Shadertoy entry: the texture stretched over the viewport, image row 0 at the top.
void mainImage(out vec4 fragColor, in vec2 fragCoord)
{
    vec2 uv = fragCoord / iResolution.xy;
    fragColor = cellgl_texture(vec2(uv.x, 1.0 - uv.y));
}
"""

# GLSL, printed as HLSL
_UNITY_WRAPPER = """
// Unity Shader Graph Custom Function node (Type: File, Name: cellgl_texture).
void cellgl_texture_float(vec2 UV, out vec4 Out)
{
    Out = cellgl_texture(UV);
}
"""

# Godot compiles its shaders with highp defaults (precision highp float/int): no qualifiers
_GODOT_FRAGMENT = "\nvoid fragment()\n{\n    COLOR = cellgl_texture(UV);\n}\n"

#: the line a target's code starts with
_FIRST_LINE = {"godot": "shader_type canvas_item;\n", "unreal": "#pragma once\n"}
#: target -> (its key in Program.tails, the default tail, the dialect it is printed in)
_TAILS = {"shadertoy": ("shadertoy", _SHADERTOY_MAIN, "glsl"), "godot": ("godot", _GODOT_FRAGMENT, "glsl"),
          "hlsl": ("unity", _UNITY_WRAPPER, "hlsl")}


# --------------------------------------------------------------------------------------------
# public API
# --------------------------------------------------------------------------------------------


def export(recipe, target: str = "glsl", *, uniforms: bool = False, fold: bool = True,
           command: str | None = None) -> str:
    """Export ``recipe`` as a self-contained shader snippet.

    Parameters
    ----------
    recipe : cellgl.texture.recipe.Recipe, str or path
        A recipe, a preset name or a recipe JSON file.
    target : str
        One of :data:`TARGETS`; ``gles100``/``webgl1`` are refused with the reason.
    uniforms : bool
        Declare the recipe's run-time values as ``cellgl_<name>`` uniforms instead of baking
        them in as constants.
    fold : bool
        True (the default): the recipe's values are folded into the code, which keeps only what
        they use. False: they stay named ``const cellgl_<name>`` declarations at the top of the
        code (still only what the entry points reach), to edit by hand; the same pixels.
    command : str, optional
        The header's "Regenerate" command up to ``--target`` (the CLI passes what it was given;
        default: derived from ``recipe`` by :func:`command_for`).

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
    if uniforms and tgt.dialect == "osl":
        raise ExportError("--uniforms is not supported for OSL: the shader's parameters are already "
                          "its run-time values; export OSL with constants")
    if uniforms and tgt.dialect == "wgsl":
        raise ExportError("--uniforms is not supported for WGSL (uniforms need a bind group "
                          "layout of your renderer); export WGSL with constants")
    prog = texture_program(recipe, uniforms=uniforms)
    prog.command = command if command is not None else command_for(recipe, fold=fold)
    return export_program(prog, target, uniforms=uniforms, fold=fold)


def refuse(r) -> None:
    """Refuse a recipe no snippet can express: PUPs, and images the engines would bind as buffers."""
    if getattr(r, "kind", None) == "pups":
        raise ExportError(f"{r.name}: PUPs recipes cannot be exported as shader snippets (a "
                          "snippet would need the control points, their Delaunay axes and the "
                          "candidate grid as buffers); bake it to an image instead: cellgl bake "
                          f"{r.name} -o {r.name}.png")
    if r.values["density_map"] == "image":
        raise ExportError(f"{r.name}: basis.density_map 'image' cannot be exported as a shader snippet "
                          "(the snippet would need the density image's levels as a storage buffer or "
                          "texture, which the engines bind differently); use density_map ramp_x, ramp_y "
                          f"or radial (exported as constants), or bake it: cellgl bake {r.name} -o "
                          f"{r.name}.png")
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
    refuse(r)
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
    # the fragment-only entries last, so that a compute or vertex shader (no derivatives there) can drop them
    entry = _ENTRY + _ENTRY3 * solid + _FRAGMENT_ENTRY + _FRAGMENT_ENTRY3 * solid
    # every uniform the values fill, the density map's included: a header line without its type
    # would leave a client that reads `type name = value` with that uniform at 0
    # (the declared type: a vec4 value is a tuple too, but only a declared array is an array)
    decl = {n: (t, bool(arr)) for t, n, arr in texture.uniform_decls("") + texture.uniform_decls("", True)}
    ulist = [(decl[k[2:]][0] + (f"[{len(v)}]" if decl[k[2:]][1] else ""), k[2:], v) for k, v in vals.items()]
    return Program(files=["lib/texture.glsl"], defines=defines, params=params, entry=entry,
                   title=r.name, recipe=r.to_dict(), solid=solid, uniforms=ulist, filtered=True)


_ENTRY = """// The RGBA `cellgl bake` writes for the pixel whose centre is uv (v = 0: top row) and
// whose size in uv is duv (a W x H bake: (1/W, 1/H)): fractal octaves finer than the
// pixel fade out (band limit); duv = (0, 0): point samples. Any shader stage.
vec4 cellgl_texture_filtered(vec2 uv, vec2 duv)
{
    return cell_texture_uv(uv, duv, cell_texture_params_load());
}
"""

_ENTRY3 = """
// Solid texturing: the texture at p = (u, v, z) in texture space (object space
// scaled so that 1 unit = the image width; z = 0 is the image plane), band-limited
// to a pixel spanning dp in texture space (0: point samples). Any shader stage.
vec4 cellgl_texture3_filtered(vec3 p, vec3 dp)
{
    return cell_texture_at_filtered(p, dp, cell_texture_params_load()).color;
}
"""

_FRAGMENT_ENTRY = """
// Fragment (pixel) shaders only, the pixel's size from derivatives: delete from here
// to the end in other stages, which have no fwidth.
vec4 cellgl_texture(vec2 uv)
{
    return cellgl_texture_filtered(uv, fwidth(uv));
}
"""

_FRAGMENT_ENTRY3 = """
vec4 cellgl_texture3(vec3 p)
{
    return cellgl_texture3_filtered(p, fwidth(p));
}
"""
