"""The OSL shader of a texture recipe: ``cellgl export PRESET --target osl``.

:func:`cellgl.export.translate.to_osl` turns the specialised library into OSL functions; this
module writes the ``shader`` block around them: the recipe's directly-read values as parameters
with defaults and slider metadata (label, min, max, help), the texture coordinate input and the
outputs a node network wires (Color, Fac, the basis values, the cell's colour, value and ID, a
bump Normal).

Coordinates. ``Vector`` (x, y, z) maps to cellgl's texture space (u, v, z) = (x, 1 - y, z): OSL
hosts put v = 0 at the bottom of an image, cellgl's bakes at the top row. With ``Vector`` from a
UV map spanning [0, 1]^2, the pixel centred at ``Vector`` gets what ``cellgl bake`` writes for
the pixel centred at (u, v); the pixel footprint comes from the derivatives of ``Vector`` (the
band limit of the octaves, like a bake's 1 / size). Unconnected, ``Vector`` is the object's
generated texture coordinates, as with Blender's own texture nodes (renderers without that
attribute: the surface's ``(u, v)``).
"""
from __future__ import annotations

import re

from cellgl.export import syntax as S
from cellgl.export.names import identifier
from cellgl.export.syntax import parsed_library
from cellgl.export.translate import to_osl
from cellgl.export.tree import walk

__all__ = ["EXPOSED_EXCLUDED", "TERM_SWITCHES", "exposed_params", "folded_code", "osl_shader"]

#: run-time values that are *not* shader parameters: the CPU derives other constants from them
#: in double precision (the split lattice origins, the Poisson table, the noise lattices) or they
#: are integers wider than OSL's int; re-export with ``--set`` to change them
EXPOSED_EXCLUDED = frozenset({
    "density", "offset_x", "offset_y", "offset_z", "time", "lacunarity", "noise_frequency",
    "warp_frequency", "seed", "fractal", "normal_convention", "ramp_mode",
})

#: weights and amounts that switch a term of the texture on (and the weights c1 .. c44 of the
#: distances and their products): at 0 in the recipe they are not sliders (the term's code folds away, as in every other target); re-export with ``--set`` to
#: turn one on
TERM_SWITCHES = frozenset({"c_noise", "c_edge", "c_smooth", "c_nsphere", "smoothness", "warp_amount",
                           "noise_color"})

#: the shader's outputs: (OSL type, name, default, what it is)
OUTPUTS = (
    ("color", "Color", "0", "the RGB `cellgl bake` writes (its alpha is 1)"),
    ("float", "Fac", "0", "the height in [0, 1] (the bake's height channel)"),
    ("float", "F1", "0", "distance to the nearest feature point, in cells (octave 0)"),
    ("float", "F2", "0", "... the second nearest"),
    ("float", "F3", "0", "... the third nearest"),
    ("float", "F4", "0", "... the fourth nearest"),
    ("float", "Value", "0", "the recipe's combination at octave 0, before its range mapping"),
    ("color", "CellColor", "0", "a random colour per cell (the ID's hash, 8 bits per channel)"),
    ("float", "CellValue", "0", "a random value per cell in [0, 1)"),
    ("float", "IDLow", "0", "the cell's 32-bit feature point ID: its low 16 bits (exact integer)"),
    ("float", "IDHigh", "0", "... and its high 16 bits"),
    ("normal", "Normal", "N", "the shading normal bumped by the height (strength: the recipe's bump)"),
)


def exposed_params(prog, code: str):
    """``[(Param, value)]`` of the values of ``prog`` (a texture :class:`Program`; ``code``: its
    specialised GLSL) that become OSL shader parameters: the run-time scalars the specialised
    code reads directly (a weight of F5 in a recipe computing F1..F2 would be a slider that does
    nothing)."""
    from cellgl.texture.params import PARAMS_BY_NAME

    n = int(prog.defines.get("CELL_N", 4))
    nodes = list(walk(parsed_library(code)))
    copies = {id(x.target) for x in nodes if isinstance(x, S.Assign) and isinstance(x.target, S.Member)
              and x.target.base == S.Name("t")
              and x.value == S.Name("cellgl_" + x.target.name)}       # the loader's t.x = cellgl_x
    used = {x.name for x in nodes if isinstance(x, S.Member) and id(x) not in copies}
    out = []
    for _typ, name, value in prog.uniforms:
        p = PARAMS_BY_NAME.get(name)
        m = re.fullmatch(r"c(\d)(\d)?", name)              # a weight of F_i or of F_i F_j
        if p is None or name in EXPOSED_EXCLUDED or p.type not in ("float", "int", "bool") \
                or isinstance(value, (list, tuple)) or name not in used \
                or ((name in TERM_SWITCHES or m) and value == 0) \
                or (m and any(int(d) > n for d in m.groups() if d)):
            continue
        out.append((p, value))
    return out


#: OSL standard-library names a parameter would shadow (oslc warns): such a parameter gets a
#: trailing underscore (its label stays the plain name)
_OSL_STD = frozenset({"bump", "displace", "noise", "mix", "step", "smoothstep", "clamp", "min", "max",
                      "area", "filterwidth", "transform", "length", "distance", "color", "point"})


def _pname(name: str) -> str:
    return name + "_" if name in _OSL_STD else name


def _lit(v, typ: str) -> str:
    if typ == "float":
        r = repr(float(v))
        return r if any(c in r for c in ".en") else r + ".0"
    return str(int(v))


def _quote(s: str) -> str:
    return s.replace("\\", "\\\\").replace('"', "'")


#: the GLSL function the shader block calls: everything the outputs read of the texture, so that
#: the snippet compiler folds the recipe into one entry point (the sliders stay its parameters)
_ENTRY = """
// What the OSL shader reads of the texture at p = (u, v, z) in texture space, band-limited to
// a pixel spanning dp: the texel, the cell's colour and ID (its 16-bit halves), and the
// height's gradient in texture units times the bump per cell.
void cell_osl_texture(vec3 p, vec3 dp, out vec3 color, out float height, out float F1, out float F2,
                      out float F3, out float F4, out float value, out vec3 cell_color, out float cell_value,
                      out float id_low, out float id_high, out vec3 grad)
{
    CellTextureParams t = cell_texture_params_load();
    CellTexel x = cell_texture_at_filtered(p, dp, t);
    color = x.color.rgb;
    height = x.height;
    F1 = x.F.x;
    F2 = x.F.y;
    F3 = x.F.z;
    F4 = x.F.w;
    value = x.value;
    cell_color = cell_id_color(x.id);
    cell_value = x.cell.w;
    id_low = float(x.id & 65535u);
    id_high = float(x.id >> 16);
    grad = cell_texture_grad_uvz(x, t) * (t.bump / t.frequency);
}
"""


def folded_code(prog, params, specialise, structs) -> tuple[str, list]:
    """The GLSL of ``prog`` for OSL, folded like every other target's but for the recipe values
    in ``params`` (``[(Param, value)]``, :func:`exposed_params`), which stay uniforms (the
    shader passes them in as its parameters); and those of ``params`` the folded code still reads.
    ``specialise``: the program's specialised GLSL (:func:`cellgl.export.snippets.specialised_code`),
    ``structs``: the parameter structs to scalarise."""
    from dataclasses import replace

    from cellgl.export import compiler

    sliders = {"cell_" + p.name for p, _ in params}
    lines = []
    for ln in prog.params.split("\n"):
        w = ln.split()
        if len(w) >= 4 and w[0] == "const" and w[2] in sliders and w[3] == "=":
            ln = f"uniform {w[1]} {w[2]};"            # not a constant for the compiler: not folded
        lines.append(ln)
    text = specialise(replace(prog, params="\n".join(lines), entry=prog.entry + _ENTRY))
    code = compiler.compile_glsl(text, ["cellgl_osl_texture"], structs=structs,
                                 keep=("cellgl_search_budget",))
    kept = {w[2].rstrip(";") for w in map(str.split, code.split("\n")) if len(w) == 3 and w[0] == "uniform"}
    return code, [(p, v) for p, v in params if "cellgl_" + p.name in kept]


def osl_shader(prog, code: str, specialise=None, structs=()) -> str:
    """The OSL text of texture program ``prog``: its GLSL (``code``: the specialised library)
    folded for the recipe but for the sliders (:func:`folded_code`, with ``specialise`` and
    ``structs``), translated, plus the ``shader`` block."""
    if prog.entries:
        return _basis_function_shader(prog, code)
    if not prog.filtered:
        return to_osl(code) + "\n" + _shader("cellgl_basis", _BASIS_PARAMS, _BASIS_BODY)
    glsl, params = folded_code(prog, exposed_params(prog, code), specialise, structs)
    passed: dict = {}
    lib = to_osl(glsl, params=["cellgl_" + p.name for p, _ in params], passed=passed)
    ins = [_VECTOR.format("Texture coordinate: (x, y) in [0, 1]^2 spans the bake, z the solid depth "
                          "(unconnected: generated coordinates)")]
    for p, value in params:
        typ = "float" if p.type == "float" else "int"
        lo, hi = (0, 1) if p.type == "bool" else (p.lo, p.hi)
        meta = [f'string label = "{p.name.replace("_", " ").capitalize()}"', f"{typ} min = {_lit(lo, typ)}",
                f"{typ} max = {_lit(hi, typ)}", f'string help = "{_quote(p.doc)}"']
        if p.type == "bool":
            meta.append('string widget = "checkBox"')
        ins.append(f"{typ} {_pname(p.name)} = {_lit(value, typ)} [[ {', '.join(meta)} ]]")
    outs = [f'output {typ} {name} = {default} [[ string help = "{_quote(doc)}" ]]'
            for typ, name, default, doc in OUTPUTS]
    args = [_LOCALS.get(name, name) for _, name, _, _ in OUTPUTS]
    args += [_pname(g[len("cellgl_"):]) for g in passed["cellgl_osl_texture"]]
    body = _TEXTURE_BODY.format(z="q[2]" if prog.solid else "0.0", dz="dq[2]" if prog.solid else "0.0",
                                args=", ".join(args))
    return lib + "\n" + _shader(identifier(prog.title), ins + outs, body)


def _shader(name: str, params: list, body: str) -> str:
    """The ``shader`` block ``name`` of ``params`` (one a line) and ``body`` (its lines indented)."""
    return f"shader {name}(\n    " + ",\n    ".join(params) + "\n)\n{\n" + body + "\n}\n"


#: the ``Vector`` input of a shader (its help text: ``{}``)
_VECTOR = 'point Vector = point(0, 0, 0) [[ string label = "Vector", string help = "{}" ]]'
#: the shader's locals that its outputs are passed as (the rest: the outputs themselves)
_LOCALS = {"Color": "c", "CellColor": "cc", "Normal": "g"}
#: the body of a texture's shader
_TEXTURE_BODY = """\
    point q0 = Vector;
    // unconnected: generated coordinates (Cycles), else the surface's (u, v)
    if (!isconnected(Vector) && !getattribute("geom:generated", q0))
        q0 = point(u, v, 0);
    // cellgl's texture space: v = 0 at the top row of a bake
    vector q = vector(q0[0], 1.0 - q0[1], q0[2]);
    // the pixel's extent along each axis (Cycles' two differentials: the pixel's diagonals)
    vector ddx = Dx(q);
    vector ddy = Dy(q);
    vector dq = vector(hypot(ddx[0], ddy[0]), hypot(ddx[1], ddy[1]), hypot(ddx[2], ddy[2]));
    cellgl_vec3 c;
    cellgl_vec3 cc;
    cellgl_vec3 g;
    cellgl_osl_texture(cellgl_vec3(q[0], q[1], {z}), cellgl_vec3(dq[0], dq[1], {dz}), {args});
    Color = color(c.x, c.y, c.z);
    CellColor = color(cc.x, cc.y, cc.z);
    // bump: the height's gradient g (texture units) on the pixel, and the surface gradient
    vector guv = vector(g.x, g.y, g.z);
    float hx = dot(guv, ddx);
    float hy = dot(guv, ddy);
    vector dpdx = Dx(P);
    vector dpdy = Dy(P);
    vector r1 = cross(dpdy, N);
    vector r2 = cross(N, dpdx);
    float det = dot(dpdx, r1);
    vector sg = (det < 0.0 ? -1.0 : 1.0) * (hx * r1 + hy * r2);
    Normal = det == 0.0 ? N : normalize(abs(det) * N - sg);"""

#: the shader of a program whose ``cellgl_texture(vec2 uv)`` returns four values (the bare
#: basis: F1..F4), with no parameters: outputs F1..F4 at uv = (x, 1 - y) of ``Vector``
_BASIS_PARAMS = ["point Vector = point(0, 0, 0)"] + [f"output float F{k} = 0" for k in range(1, 5)]
_BASIS_BODY = """\
    point q0 = Vector;
    if (!isconnected(Vector))
        getattribute("geom:generated", q0);
    cellgl_vec4 f = cellgl_texture(cellgl_vec2(q0[0], 1.0 - q0[1]));
    F1 = f.x;
    F2 = f.y;
    F3 = f.z;
    F4 = f.w;"""


def _basis_outputs(prog) -> list[str]:
    """A basis function's outputs, from its key and GLSL return type (``vecN``: F1 .. FN)."""
    key, ret = prog.recipe["basis"], _basis_return(prog)
    if key == "cellid":
        return ["IDLow", "IDHigh"]
    if ret == "float":
        return ["Distance" if key == "edge" else "F1"]
    return ["F1", "F2", "F3", "F4"][:int(ret[-1])]


def _basis_return(prog) -> str:
    m = re.match(r"\s*(\w+)", prog.signatures[0])
    assert m is not None, prog.signatures[0]            # a signature starts with its return type
    return m.group(1)


def basis_signature(prog) -> str:
    """The header's line for the shader of a basis snippet."""
    key, dim = prog.recipe["basis"], int(prog.recipe["dim"])
    outs = ", ".join(f"output float {o}" for o in _basis_outputs(prog))
    return (f"shader cellgl_basis_{key}(point Vector{', float W' if dim == 4 else ''}, {outs}): "
            f"{prog.signatures[0].split(': ', 1)[1].split('; ')[0]}, at Vector"
            f"{' (with W)' if dim == 4 else ''} in cells"
            + ("; the ID in two exact 16-bit halves" if key == "cellid" else ""))


def _basis_function_shader(prog, code: str) -> str:
    """The shader of a basis snippet (``cellgl export --basis f1f2 --dim 3 --target osl``):
    ``Vector`` in cells (unconnected: the object's generated coordinates; a 4D basis adds ``W``),
    outputs F1.. (``f1``..``f1f2f3f4``), ``Distance`` (``edge``) or ``CellID`` (``cellid``: the
    nearest feature point's 32-bit ID as ``IDLow`` / ``IDHigh``, 16 bits each, exact)."""
    key, dim = prog.recipe["basis"], int(prog.recipe["dim"])
    fn, ret, outs = prog.entries[0], _basis_return(prog), _basis_outputs(prog)
    call = f"{fn}(cellgl_vec{dim}({', '.join(['q[0]', 'q[1]', 'q[2]', 'W'][:dim])}))"
    ins = [_VECTOR.format("The sample point in cells (unconnected: generated coordinates)")]
    if dim == 4:
        ins.append('float W = 0 [[ string label = "W", string help = "The fourth coordinate, in cells" ]]')
    if key == "cellid":
        body = [f"int id = {call};", "IDLow = float(id & 65535);", "IDHigh = float((id >> 16) & 65535);"]
    elif ret == "float":
        body = [f"{outs[0]} = {call};"]
    else:
        body = [f"cellgl_{ret} f = {call};"] + [f"{o} = f.{'xyzw'[k]};" for k, o in enumerate(outs)]
    body = ["point q = Vector;", 'if (!isconnected(Vector) && !getattribute("geom:generated", q))',
            "    q = P;"] + body
    outs = [f"output float {o} = 0" for o in outs]
    return to_osl(code) + "\n" + _shader(f"cellgl_basis_{key}", ins + outs, "    " + "\n    ".join(body))
