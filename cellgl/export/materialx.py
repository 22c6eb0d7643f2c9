"""MaterialX nodes of cellgl: ``cellgl export --target materialx -o DIR``.

A MaterialX custom node is a nodedef (its typed inputs and outputs) plus one implementation per
shading language: a function in a source file that MaterialX's shader generators paste into the
shaders they write (``genglsl``: ``void NAME(inputs..., out outputs...)`` in a ``.glsl`` file;
``genosl``: the same in OSL). This module makes those parts for

* every exportable texture preset (:func:`preset_node`): the node ``cellgl_<name>`` (``-`` in a
  preset's name becomes ``_``) with a ``texcoord`` (UV0) and a ``footprint`` input, the
  recipe's run-time values as inputs, and the outputs ``color`` (color3), ``height`` (float)
  and, where the preset gives a normal map, ``normal`` (vector3: the tangent-space normal
  encoded as the bake's normal map, ``0.5 n + 0.5``, OpenGL green);
* the cellular basis (:mod:`cellgl.export.materialx_basis`).

The code is the exporter's (:mod:`cellgl.export.compiler`), folded for the recipe as every
other target is, except for the values that are node inputs: those stay variables (the OSL
target's sliders, :func:`cellgl.export.osl.exposed_params`). GLSL is printed by the exporter's
GLSL printer, OSL by its OSL translator (:func:`cellgl.export.translate.to_osl`), from the one
compiled tree. Every top-level name of a node's code carries the node's name, so that any number
of cellgl nodes can share one shader (an export where two nodes' names would still meet is
refused: :func:`cellgl.export.materialx_docs.check_names`). The GLSL has no array constructor
(:func:`without_array_constructors`), so MaterialX's GenMsl and GenSlang can take it.

Coordinates: MaterialX's ``texcoord`` has v = 0 at the bottom of an image; cellgl's bakes have
v = 0 at the top row. The node evaluates cellgl at ``(u, 1 - v)``, so the node at ``texcoord``
equals a ``cellgl bake`` image read by MaterialX's ``image`` node at the same ``texcoord``.

The documents themselves (the node library, the example materials, the USD stage) are written
by :mod:`cellgl.export.materialx_docs` (:func:`~cellgl.export.materialx_docs.export_materialx`).
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field, replace

from cellgl.export.snippets import ExportError

__all__ = ["MxInput", "MxNode", "preset_node", "node_name", "valid_name", "exportable_presets",
           "TEXTURE_OUTPUTS", "MX_TYPES"]

#: a valid MaterialX element name (MaterialX's own createValidName keeps [A-Za-z0-9_])
_MX_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
#: a recipe name the exporter accepts: letters, digits, ``_`` and ``-`` (which becomes ``_``)
_RECIPE_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_-]*")

#: cellgl parameter type -> (MaterialX type, GLSL type, OSL type)
MX_TYPES = {"float": ("float", "float", "float"), "int": ("integer", "int", "int"),
            "bool": ("boolean", "bool", "int")}

#: a texture node's outputs, in their order: (name, MaterialX type, GLSL type, OSL type, doc)
TEXTURE_OUTPUTS = (
    ("color", "color3", "vec3", "color", "the RGB `cellgl bake` writes (sRGB-encoded as the bake's PNG)"),
    ("height", "float", "float", "float", "the height in [0, 1] (the bake's height channel)"),
    ("normal", "vector3", "vec3", "vector", "tangent-space normal encoded as the bake's normal map, 0.5 n + 0.5 "
     "(OpenGL: +Y up; MaterialX's normalmap node decodes it)"),
)


def valid_name(name: str) -> bool:
    """Whether ``name`` is a valid MaterialX element name."""
    return bool(_MX_NAME.fullmatch(str(name)))


def node_name(recipe_name: str) -> str:
    """The MaterialX node name of a recipe: ``cellgl_<name>``, ``-`` as ``_``.

    Raises
    ------
    ExportError
        The name has a character other than ASCII letters, digits, ``_`` and ``-``, or does
        not start with a letter: it would not be a valid MaterialX name.
    """
    text = str(recipe_name)
    if not _RECIPE_NAME.fullmatch(text) or "__" in text.replace("-", "_"):
        raise ExportError(f"recipe name {text!r} is not a valid MaterialX name: accepted, a letter "
                          "followed by ASCII letters, digits, '_' and '-' (which becomes '_'), no '__'; "
                          "rename the recipe (its \"name\" field)")
    return "cellgl_" + text.replace("-", "_")


@dataclass
class MxInput:
    """One input of a nodedef."""

    name: str
    mxtype: str                 # MaterialX type
    value: object = None        # default (None: none, a geomprop gives it)
    doc: str = ""
    uimin: object = None
    uimax: object = None
    uifolder: str | None = None
    uiname: str | None = None
    geomprop: str | None = None  # defaultgeomprop
    inactive: str | None = None  # why the input changes nothing (the viewer greys it out)
    glsl: str = ""              # the implementation's parameter type, GLSL
    osl: str = ""               # ... OSL
    var: str | None = None      # the code's variable it sets (None: read by the wrapper itself)


@dataclass
class MxNode:
    """A node: its nodedef, and the implementation sources with their function name."""

    name: str                   # node name (cellgl_flagstone)
    nodegroup: str
    doc: str
    inputs: list[MxInput]
    outputs: list[tuple[str, str, str, str, str]]      # (name, mxtype, glsl, osl, doc)
    glsl: str = ""
    osl: str = ""
    example: dict = field(default_factory=dict)         # what the example material needs

    @property
    def nodedef(self) -> str:
        return "ND_" + self.name

    @property
    def function(self) -> str:
        # not mx_cellgl_...: MaterialX's GLSL syntax rewrites "gl_" anywhere in a function
        # name (reserved names start with it) and then refuses the name as invalid
        return "cellglmx" + self.name[len("cellgl"):]


def exportable_presets() -> tuple[list[str], dict[str, str]]:
    """``(names, {name: why not})`` of the presets: a PUPs preset, or one driven by an image
    (``density_map`` or ``cell_color`` image), is refused with the reason the snippets give."""
    from cellgl.recipes import list_presets, load_recipe
    from cellgl.export.snippets import refuse

    ok, refused = [], {}
    for name, _ in list_presets():
        try:
            refuse(load_recipe(name))
            ok.append(name)
        except ExportError as exc:
            refused[name] = str(exc)
    return ok, refused


# ------------------------------------------------------------------------------ texture presets

#: the GLSL entry the node's code is compiled for: the texel at uv (cellgl's v = 0 at the top),
#: band-limited to duv, as the bake computes it (cell_texture_uv), and the outputs a node gives
_ENTRY = """
void cell_mx_texture(vec2 uv, vec2 duv, out vec3 color, out float height, out vec3 normal)
{
    CellTextureParams t = cell_texture_params_load();
    CellTexel x = cell_texture_at_filtered(vec3(uv, 0.0), vec3(duv, 0.0), t);
    color = x.color.rgb;
    height = x.height;
    normal = x.normal * 0.5 + 0.5;
}
"""

_FOOTPRINT_DOC = ("pixel size in uv for the band limit of the octaves: (1/W, 1/H) gives what a W x H "
                  "`cellgl bake` writes; (0, 0): point samples")
_TEXCOORD_DOC = "texture coordinates: [0, 1]^2 spans the bake (v = 0 at the bottom, MaterialX's convention)"


def _params_with_vars(prog, names: set) -> str:
    """The program's constant block with the constants of ``names`` turned into uniforms: not
    constants for the compiler, so not folded (they stay variables the wrapper sets)."""
    lines = []
    for ln in prog.params.split("\n"):
        w = ln.split()
        if len(w) >= 4 and w[0] == "const" and w[2] in names and w[3] == "=":
            ln = f"uniform {w[1]} {w[2]};"
        lines.append(ln)
    return "\n".join(lines)


def compiled(prog, entry_glsl: str, entry: str, live: set) -> tuple[str, list[str]]:
    """The compiled GLSL of ``prog`` plus ``entry_glsl`` for the entry ``entry`` (library names,
    ``cell_...``), folded but for the values ``live`` (``cell_<name>``); and the variables
    (``cellgl_<name>``) the folded code still reads."""
    from cellgl.export import compiler, snippets

    text = snippets.specialised_code(replace(prog, params=_params_with_vars(prog, live),
                                             entry=prog.entry + entry_glsl))
    code = compiler.compile_glsl(text, [entry.replace("cell_", "cellgl_", 1)], structs=snippets.CONSTANT_STRUCTS,
                                 keep=("cellgl_search_budget",))
    kept = [w[2].rstrip(";") for w in map(str.split, code.split("\n")) if len(w) == 3 and w[0] == "uniform"]
    return code, kept


def renamed(code: str, name: str) -> str:
    """``code`` with every ``cellgl_`` / ``Cellgl`` name carrying the node's ``name``
    (``cellgl_flagstone``), so that the code of two nodes can share a shader."""
    body = name[len("cellgl_"):]
    camel = "".join(w[:1].upper() + w[1:] for w in body.split("_"))
    code = re.sub(r"\bcellgl_(?=\w)", name + "_", code)
    return re.sub(r"\bCellgl(?=\w)", "Cellgl" + camel, code)


def _wrapper_glsl(node: MxNode, entry: str, vars_: list[str], first: str = "") -> str:
    """The node's GLSL function: run ``first`` (the arrays' values), set the code's variables
    from the inputs, then call ``entry``."""
    args = [f"{i.glsl} in_{i.name}" for i in node.inputs] + [f"out {o[2]} out_{o[0]}" for o in node.outputs]
    lines = [f"// MaterialX implementation of {node.nodedef} (genglsl).",
             f"void {node.function}({', '.join(args)})", "{"] + ([first] if first else [])
    for i in node.inputs:
        if i.var is not None and i.var in vars_:
            val = f"(in_{i.name} ? 1 : 0)" if i.glsl == "bool" else f"in_{i.name}"
            lines.append(f"    {renamed(i.var, node.name)} = {val};")
    outs = {o[0] for o in node.outputs}
    locs = [f"    {t} {n};" for n, t in (("color", "vec3"), ("height", "float"), ("normal", "vec3")) if n not in outs]
    lines += locs
    call = ", ".join(f"out_{n}" if n in outs else n for n in ("color", "height", "normal"))
    lines.append(f"    {entry}(vec2(in_texcoord.x, 1.0 - in_texcoord.y), in_footprint, {call});")
    lines.append("}")
    return "\n".join(lines) + "\n"


def _wrapper_osl(node: MxNode, entry: str, passed: list[str]) -> str:
    """The node's OSL function: convert the types (the translated code's vectors are structs),
    pass the inputs the code reads, call ``entry``."""
    args = [f"{i.osl} in_{i.name}" for i in node.inputs] + [f"output {o[3]} out_{o[0]}" for o in node.outputs]
    n = node.name
    outs = {o[0] for o in node.outputs}
    by_var = {i.var: i for i in node.inputs if i.var is not None}
    extra = []
    for g in passed:
        i = by_var[g]
        extra.append(f"in_{i.name}")
    lines = [f"// MaterialX implementation of {node.nodedef} (genosl).",
             f"void {node.function}({', '.join(args)})", "{",
             f"    {n}_vec3 c;", "    float h;", f"    {n}_vec3 nn;",
             f"    {entry}({n}_vec2(in_texcoord.x, 1.0 - in_texcoord.y), {n}_vec2(in_footprint.x, in_footprint.y), "
             f"c, h, nn{''.join(', ' + e for e in extra)});"]
    if "color" in outs:
        lines.append("    out_color = color(c.x, c.y, c.z);")
    if "height" in outs:
        lines.append("    out_height = h;")
    if "normal" in outs:
        lines.append("    out_normal = vector(nn.x, nn.y, nn.z);")
    lines.append("}")
    return "\n".join(lines) + "\n"


def _uirange(p):
    if p.type == "bool":
        return None, None
    return p.lo, p.hi


def preset_node(recipe) -> MxNode:
    """The :class:`MxNode` of a texture recipe (a preset name, a JSON file or a recipe).

    Inputs: ``texcoord`` (vector2, UV0), ``footprint`` (vector2), then the recipe's run-time
    values that are inputs: those the folded code reads (the OSL export's sliders,
    :func:`cellgl.export.osl.exposed_params`), with ``doc``, ``uimin`` / ``uimax`` and
    ``uifolder`` (the parameter's group) from the parameter table, and the scalar ones that
    change nothing with the recipe's values (:func:`cellgl.texture.params.inactive`), marked as
    the viewer marks them: ``uiadvanced`` and a doc that says what turns them on. The rest of
    the recipe is fixed at export (the nodedef's doc lists it)."""
    from cellgl.export import snippets
    from cellgl.export.osl import EXPOSED_EXCLUDED, exposed_params
    from cellgl.export.translate import to_osl
    from cellgl.recipes import load_recipe
    from cellgl.texture.params import PARAMS, inactive

    r = load_recipe(recipe)
    name = node_name(r.name)
    prog = snippets.texture_program(r)          # refuses PUPs and image-driven recipes
    exposed = exposed_params(prog, snippets.specialised_code(prog))
    code, kept = compiled(prog, _ENTRY, "cell_mx_texture", {"cell_" + p.name for p, _ in exposed})
    live = {k[len("cellgl_"):] for k in kept}
    off = inactive(r)
    inputs = [MxInput("texcoord", "vector2", None, _TEXCOORD_DOC, geomprop="UV0", glsl="vec2", osl="vector2"),
              MxInput("footprint", "vector2", (0.0, 0.0), _FOOTPRINT_DOC, uimin=(0.0, 0.0), glsl="vec2",
                      osl="vector2")]
    fixed = []
    for p in PARAMS:
        if p.group == "material":       # the roughness / ao / metallic channels: not this node's outputs
            continue
        v = r.values[p.name]
        if p.compile_time or p.derived:
            if p.name not in off:
                fixed.append(f"{p.name}={v}")
            continue
        if p.name in live or (p.name in off and p.name not in EXPOSED_EXCLUDED and p.type in MX_TYPES):
            mx, gl, osl = MX_TYPES[p.type]
            lo, hi = _uirange(p)
            why = off.get(p.name) if p.name not in live else None
            doc = p.doc + (f" (inactive in this recipe: it {why}; the viewer greys it out)" if why else "")
            inputs.append(MxInput(p.name, mx, v, doc, lo, hi, p.group, p.name.replace("_", " ").capitalize(),
                                  inactive=why, glsl=gl, osl=osl, var="cellgl_" + p.name if p.name in live else None))
        elif p.name not in off and not (re.fullmatch(r"c\d+", p.name) and v == 0):
            fixed.append(f"{p.name}={v}")
    # colour and height always (every texture has a height; two outputs keep every node a
    # multi-output node, connected by output name), the normal where the preset gives one
    outs = [o for o in TEXTURE_OUTPUTS if o[0] != "normal" or o[0] in r.outputs]
    node = MxNode(name, "texture2d", _node_doc(r, fixed), inputs, outs,
                  example={"recipe": r.name, "outputs": [o[0] for o in outs], "recipe_obj": r})
    entry = "cellgl_mx_texture"
    glsl, first = without_array_constructors(private_globals(renamed(code, name)), name + "_init_arrays")
    node.glsl = (_library_head(r, "GLSL") + glsl + "\n" + _wrapper_glsl(node, renamed(entry, name), kept, first))
    passed: dict = {}
    osl = to_osl(code, params=kept, passed=passed)
    node.osl = (_library_head(r, "OSL") + renamed(osl, name) + "\n"
                + _wrapper_osl(node, renamed(entry, name), passed.get(entry, [])))
    return node


_ARRAY_DECL = re.compile(r"(?:const\s+)?(\w+)\s+(\w+)\[(\w+)\]\s*=\s*(\w+)\[(\w+)\]\(")


def _close(code: str, i: int) -> int:
    """The index of the ``)`` that closes the ``(`` just before ``code[i]``."""
    depth = 1
    while depth:
        c = code[i]
        depth += (c == "(") - (c == ")")
        i += 1
    return i - 1


def _split_args(text: str) -> list[str]:
    """``text`` split at its top-level commas, each part stripped."""
    out, depth, start = [], 0, 0
    for k, c in enumerate(text):
        depth += (c in "([") - (c in ")]")
        if c == "," and depth == 0:
            out.append(text[start:k].strip())
            start = k + 1
    out.append(text[start:].strip())
    return out


def without_array_constructors(code: str, init: str) -> tuple[str, str]:
    """``code`` with no GLSL array constructor (``float[8](a, b, ...)``), which MaterialX's
    GenMsl and GenSlang pass through into Metal and Slang, where it is no syntax: a local
    array declared with one is declared alone and set element by element; a global constant
    one becomes a private global set by the function ``init``, which the result appends. Also
    returns the statement that calls ``init`` ("" where there is none), which the node's
    function runs first. The values are the same, so are the results."""
    out, pos, counted, depth, sets = [], 0, 0, 0, []
    for m in _ARRAY_DECL.finditer(code):
        if m.start() < pos or "//" in code[code.rfind("\n", 0, m.start()) + 1:m.start()]:
            continue                        # inside a rewritten declaration, or a comment
        between = re.sub(r"//[^\n]*", "", code[counted:m.start()])
        depth += between.count("{") - between.count("}")
        counted = m.start()
        typ, name, n, typ2, n2 = m.groups()
        end = _close(code, m.end())
        if typ2 != typ or n2 != n or not code[end + 1:].lstrip().startswith(";"):
            continue                        # not a declaration this pass knows: left as it is
        args = _split_args(code[m.end():end])
        semi = code.index(";", end)
        out.append(code[pos:m.start()])
        if depth == 0:
            out.append(f"{typ} {name}[{n}];     // set by {init}()")
            sets += [f"    {name}[{k}] = {a};" for k, a in enumerate(args)]
        else:
            indent = code[code.rfind("\n", 0, m.start()) + 1:m.start()]
            out.append(f"{typ} {name}[{n}];" + "".join(f"\n{indent}{name}[{k}] = {a};" for k, a in enumerate(args)))
        pos = counted = semi + 1
    out.append(code[pos:])
    text = "".join(out)
    if not sets:
        return text, ""
    text += (f"\n// the values of the global arrays (GenMsl and GenSlang take no array constructor)\n"
             f"void {init}()\n{{\n" + "\n".join(sets) + "\n}\n")
    return text, f"    {init}();"


def private_globals(code: str) -> str:
    """The code's ``uniform`` variables (the node's inputs) as private globals, which the node's
    function sets before it calls the code: a MaterialX source file declares no uniforms."""
    return re.sub(r"^uniform (\w+) (\w+);$", r"\1 \2;     // set by the node's function from its input",
                  code, flags=re.M)


def _library_head(r, lang: str) -> str:
    from cellgl._version import __version__

    return (f"// cellgl {__version__}: MaterialX node cellgl_{r.name.replace('-', '_')} ({lang}), the recipe "
            f"{r.name!r} compiled by `cellgl export --target materialx` (do not edit; re-export instead).\n")


def _node_doc(r, fixed: list[str]) -> str:
    doc = str(getattr(r, "doc", "") or "")
    return (f"cellgl texture '{r.name}'" + (f": {doc}" if doc else "") + ". Fixed at export (re-export with "
            "`cellgl export RECIPE --set NAME=VALUE --target materialx` to change): "
            + ", ".join(fixed) + ", the colour ramp; every other weight c_i, c_ij is 0.")

