"""The texture parameter table: every scalar parameter of a recipe, declared once.

Each :class:`Param` has a name, a type, a default, a range (or choices), a one-line doc and a
group (the section of the recipe JSON it lives in). Everything else is generated from this
table: the recipe schema check (:mod:`cellgl.texture.recipe`), the ``u_<name>`` uniforms and the
``CellTextureParams`` struct of the shaders (:mod:`cellgl.texture`), the snippet constants,
the viewer's sliders, the CLI's ``--set name=value`` and the table in ``docs/textures.md``.

Structured parts of a recipe have their own validation in :mod:`cellgl.texture.recipe`:

* the colour ramp (``color.ramp``: 1..16 keys ``[t, r, g, b]``);
* the coefficients: each one *also* has a table entry so that sliders and ``--set`` work
  uniformly: ``c1`` .. ``c8`` are Worley's linear weights (``sum c_i F_i``) and ``c11`` ..
  ``c44`` Qin's product weights (``sum_{i,j<=4} c_ij F_i F_j``, all 16 ordered pairs, so
  ``c12`` and ``c21`` both multiply ``F1 F2``). In recipe JSON they are written compactly as
  ``combination.linear`` (8 numbers) and ``combination.products`` (4 x 4).

``compile_time`` parameters change the shader's code (they become ``#define``s); the others
are uniforms (``u_<name>``) that a viewer may change every frame, except the ``derived`` ones,
which the CPU turns into derived uniform arrays (the density map's ``density_*``: its integer
encoding per octave, :mod:`cellgl.basis.density`; ``orbit_phase``: the integer ``u_orbit_turn``;
``stretch_*``: the weights ``u_axis_scale``) and which have no uniform of their own.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

__all__ = ["Param", "PARAMS", "PARAMS_BY_NAME", "GROUPS", "LINEAR", "PRODUCTS", "N_LINEAR",
           "MAX_RAMP_KEYS", "FRACTAL_MODES", "RAMP_MODES", "DENSITY_MAPS", "ACTIVE_WHEN", "inactive",
           "MATERIAL_CHANNELS"]

N_LINEAR = 8            #: linear coefficients c1..c8 (F1..F8)
N_PRODUCT = 4           #: product coefficients c_ij for i, j <= 4
MAX_RAMP_KEYS = 16      #: keys in a colour ramp

#: fractal modes, in their GLSL integer order (CELL_TEX_FRACTAL_*)
FRACTAL_MODES = ("none", "sum", "qin", "qin_cube", "min")
#: colour-ramp interpolation, in GLSL order (CELL_TEX_RAMP_*)
RAMP_MODES = ("linear", "spline")
NORMAL_CONVENTIONS = ("opengl", "directx")
DISTRIBUTIONS = ("poisson", "jitter", "worley1996", "blender")
#: smooth F1: log-sum-exp over every point, or Blender's polynomial fold (cellgl.basis.features)
SMOOTH_MODES = ("exp", "polynomial")
#: spatially varying feature density (cellgl.basis.density): the map of a texture, in uv
DENSITY_MAPS = ("none", "ramp_x", "ramp_y", "radial", "image")
METRICS = ("euclidean", "manhattan", "chebyshev", "minkowski")
#: where the per-cell colour comes from (cell_mix): the ramp at the cell value, or an image
CELL_COLORS = ("ramp", "image")

#: recipe JSON sections, in order
GROUPS = ("basis", "combination", "fractal", "domain", "noise", "mapping", "color", "material")
#: the channels of the material section (cellgl.texture.schema.CHANNELS; lib/texture_material.glsl)
MATERIAL_CHANNELS = ("roughness", "ao", "metallic")


@dataclass(frozen=True)
class Param:
    """One scalar parameter of a texture recipe.

    type is "float", "int", "bool", "enum" or "color" (an RGB triple in [0, 1]).
    ``lo``/``hi`` bound numbers (inclusive); ``choices`` names the values of an enum
    (stored as the name, passed to GLSL as the index). ``glsl`` overrides the GLSL type.
    """

    name: str
    type: str
    default: object
    lo: float | None
    hi: float | None
    doc: str
    group: str
    choices: tuple[str, ...] | None = None
    compile_time: bool = False
    glsl: str | None = None
    derived: bool = False

    @property
    def glsl_type(self) -> str:
        if self.glsl:
            return self.glsl
        return {"float": "float", "int": "int", "bool": "int", "enum": "int", "color": "vec3"}[self.type]

    def range_text(self) -> str:
        """The accepted values, as error messages and docs print them."""
        if self.type == "enum":
            return "one of: " + ", ".join(self.choices)
        if self.type == "bool":
            return "true or false"
        if self.type == "color":
            return "[r, g, b] with each in [0, 1]"
        return f"[{_num(self.lo)}, {_num(self.hi)}]"


def _num(v) -> str:
    if isinstance(v, float) and v.is_integer() and abs(v) < 1e15:
        return str(int(v)) if abs(v) >= 1e4 else repr(v)
    return repr(v)


def _coef(name: str, doc: str, default: float = 0.0) -> Param:
    return Param(name, "float", default, -64.0, 64.0, doc, "combination")


LINEAR = tuple(f"c{i}" for i in range(1, N_LINEAR + 1))
PRODUCTS = tuple(f"c{i}{j}" for i in range(1, N_PRODUCT + 1) for j in range(1, N_PRODUCT + 1))

PARAMS: tuple[Param, ...] = (
    # ---- basis: where the feature points are and how distance is measured
    Param("dimension", "int", 2, 2, 4, "dimension of the basis: 2 (image plane), 3 (solid: uv plus z), "
          "4 (solid plus time)", "basis", compile_time=True),
    Param("distribution", "enum", "poisson", None, None, "feature points: poisson (Worley: Poisson count per "
          "cell), jitter (one per cell), worley1996 (the book's program, 3D only), blender (Blender's Voronoi "
          "node: its hash, one point per cell, jitter as Randomness; seed 0)", "basis",
          choices=DISTRIBUTIONS, compile_time=True),
    Param("metric", "enum", "euclidean", None, None, "distance metric (manhattan: Worley's ship-hull "
          "channels)", "basis", choices=METRICS, compile_time=True),
    Param("minkowski_p", "float", 3.0, 0.25, 64.0, "exponent of the minkowski metric", "basis"),
    Param("density", "float", 3.0, 0.05, 16.0, "mean feature points per cell (poisson; "
          "unused with a density_map)", "basis"),
    Param("density_map", "enum", "none", None, None, "spatially varying density (poisson): none; ramp_x, "
          "ramp_y (density_min at density_start to density_max at density_end along u or v); radial "
          "(density_min at the centre, density_max at density_radius); image (basis.density_image, "
          "grayscale over the uv square: black density_min, white density_max)", "basis",
          choices=DENSITY_MAPS, compile_time=True),
    Param("density_min", "float", 0.5, 0.05, 16.0, "density map: mean points per cell where the map is 0 "
          "(16 geometric levels between it and density_max)", "basis", derived=True),
    Param("density_max", "float", 8.0, 0.05, 16.0, "density map: mean points per cell where the map is 1",
          "basis", derived=True),
    Param("density_start", "float", 0.0, -100.0, 100.0, "ramp_x/ramp_y: u (or v) where the map is 0",
          "basis", derived=True),
    Param("density_end", "float", 1.0, -100.0, 100.0, "ramp_x/ramp_y: u (or v) where the map is 1",
          "basis", derived=True),
    Param("density_center_x", "float", 0.5, -100.0, 100.0, "radial: u of the centre", "basis", derived=True),
    Param("density_center_y", "float", 0.5, -100.0, 100.0, "radial: v of the centre", "basis", derived=True),
    Param("density_radius", "float", 0.5, 0.001, 100.0, "radial: distance (in u units) where the map "
          "reaches 1", "basis", derived=True),
    Param("jitter", "float", 1.0, 0.0, 1.0, "displacement of the point from the cell centre (jitter); "
          "Blender's Randomness (blender)", "basis"),
    Param("min_points", "int", 1, 0, 16, "poisson: fewest points per cell (Worley: 1)", "basis"),
    Param("max_points", "int", 9, 1, 16, "poisson: most points per cell (Worley: 9)", "basis"),
    Param("seed", "int", 0, 0, 2 ** 32 - 1, "random seed of the feature points and the noise", "basis",
          glsl="uint"),
    *(Param(f"stretch_{a}", "float", 1.0, 1.0 / 16.0, 16.0, f"relative length of the cells along {a} "
            f"(stretched cells: the distance weights axes by 1 / stretch, normalised; exact)"
            f"{' (3D and 4D bases)' if a == 'z' else ''}", "basis", derived=True)
      for a in "xyz"),
    Param("orbit_radius", "float", 0.0, 0.0, 0.5, "loopable animation: each feature point circles in "
          "its cell (x, y) with this radius in cells, once per loop", "basis"),
    Param("orbit_phase", "float", 0.0, -1e9, 1e9, "animation time in loops (orbit_phase + 1 is the same "
          "frame, bit for bit); `cellgl bake --frames N` steps it by 1/N", "basis", derived=True),
    # ---- combination: value = sum c_i F_i + sum c_ij F_i F_j + c_noise * noise
    *(_coef(n, f"weight of F{n[1:]} (Worley's linear combination)", 1.0 if n == "c1" else 0.0) for n in LINEAR),
    *(_coef(n, f"weight of F{n[1]} F{n[2]} (Qin's product terms)") for n in PRODUCTS),
    Param("c_noise", "float", 0.0, -64.0, 64.0, "weight of gradient noise at the same position (Qin's "
          "noise comparisons)", "combination"),
    Param("c_edge", "float", 0.0, -64.0, 64.0, "weight of the distance to the cell's border (exact, "
          "Euclidean metric only; Blender's Distance to Edge)", "combination"),
    Param("c_smooth", "float", 0.0, -64.0, 64.0, "weight of smooth F1 (-k log sum exp(-F_j / k), k = "
          "smoothness)", "combination"),
    Param("c_nsphere", "float", 0.0, -64.0, 64.0, "weight of the n-sphere radius: half the distance from "
          "the F1 point to its nearest other point (Euclidean metric only)", "combination"),
    Param("smoothness", "float", 0.0, 0.0, 1.0, "k of smooth F1, in cells (0: F1 itself; at most 0.25 with "
          "smooth exp); with cell_mix the cell value and the cell_image position blend the same way",
          "combination"),
    Param("smooth", "enum", "exp", None, None, "smooth F1: exp (-k log sum exp(-F_j / k) over every point, "
          "exact) or polynomial (Blender's Voronoi node: its running polynomial smooth minimum over the "
          "5^d cells around the sample's, k = smoothness / 2)", "combination", choices=SMOOTH_MODES,
          compile_time=True),
    Param("range_lo", "float", 0.0, -1e6, 1e6, "value mapped to 0 (measured: 0.5th percentile; "
          "see cellgl.texture.measure_range)", "combination"),
    Param("range_hi", "float", 1.0, -1e6, 1e6, "value mapped to 1 (measured: 99.5th percentile)",
          "combination"),
    # ---- fractal: G = sum w_i b(lacunarity^i x), w_i = gain^i
    Param("fractal", "enum", "none", None, None, "none; sum (Worley: sum gain^i b(lac^i x)); qin (sum gain^i "
          "|0.5 - b(lac^i x)|); qin_cube (its cube, Qin's wrinkle bump); normalised to [0, 1]; min (Blender's "
          "distance-to-edge fractal: min_i v(lac^i x) / lac^i, then normalised; gain unused)", "fractal",
          choices=FRACTAL_MODES),
    Param("octaves", "float", 6.0, 1.0, 8.0, "number of octaves (terms; fractional: the last is faded in). "
          "Worley's i = 0..5 is 6", "fractal"),
    Param("lacunarity", "float", 2.0, 1.0, 4.0, "frequency ratio between octaves (integer when tileable)",
          "fractal"),
    Param("gain", "float", 0.5, 0.0, 1.0, "amplitude ratio between octaves", "fractal"),
    Param("antialias", "float", 1.0, 0.0, 4.0, "band limit (Qin's smoothscale): each octave fades to its "
          "mean as its features shrink from 2 to 1 pixel apart, times antialias (0: off, point samples)",
          "fractal"),
    # ---- domain: texture coordinates -> basis space
    Param("frequency", "float", 8.0, 0.01, 4096.0, "cells across the texture (u in [0, 1]); the period "
          "when tileable (then an integer)", "domain"),
    Param("aspect", "float", 1.0, 0.01, 100.0, "cells along v per cell along u (frequency * aspect: "
          "an integer when tileable)", "domain"),
    Param("offset_x", "float", 0.0, -1e9, 1e9, "shift of the basis along x, in cells", "domain"),
    Param("offset_y", "float", 0.0, -1e9, 1e9, "shift of the basis along y, in cells", "domain"),
    Param("offset_z", "float", 0.5, -1e9, 1e9, "z of the image plane in cells (3D and 4D bases)", "domain"),
    Param("time", "float", 0.0, -1e9, 1e9, "4th coordinate in cells (4D bases: animation)", "domain"),
    Param("tileable", "bool", False, None, None, "seamless in u and v (and in z for basis.dimension 3 "
          "and 4: a volume tiles in depth): the basis (and noise) repeat every frequency cells", "domain", compile_time=True),
    Param("warp_amount", "float", 0.0, 0.0, 8.0, "domain warp: the sample moves by up to about this many "
          "cells along each axis, by fractal gradient noise, before the basis", "domain"),
    Param("warp_frequency", "float", 1.0, 0.01, 64.0, "domain warp: noise lattice cells per basis cell "
          "(an integer when tileable)", "domain"),
    Param("warp_octaves", "int", 3, 1, 8, "domain warp: octaves of the warp noise (gain 0.5, "
          "lacunarity 2)", "domain"),
    # ---- noise: Perlin-style integer-hashed gradient noise
    Param("noise_frequency", "float", 1.0, 0.01, 64.0, "noise lattice cells per basis cell (an integer "
          "when tileable)", "noise"),
    Param("noise_octaves", "int", 4, 1, 8, "octaves of the discoloration noise (gain 0.5, lacunarity 2)",
          "noise"),
    Param("noise_color", "float", 0.0, -4.0, 4.0, "fractal-noise discoloration: added to the ramp index",
          "noise"),
    # ---- mapping: normalised value -> height, bump, lighting
    Param("invert", "bool", False, None, None, "height = 1 - G", "mapping"),
    Param("level_lo", "float", 0.0, -4.0, 4.0, "height window: G at level_lo -> 0 ...", "mapping"),
    Param("level_hi", "float", 1.0, -4.0, 4.0, "... and at level_hi -> 1 (clamped)", "mapping"),
    Param("bump", "float", 1.0, 0.0, 256.0, "normal-map strength: height units per cell", "mapping"),
    Param("normal_convention", "enum", "opengl", None, None, "normal-map green: opengl (+Y up) or directx "
          "(+Y down)", "mapping", choices=NORMAL_CONVENTIONS),
    Param("light", "float", 0.0, 0.0, 1.0, "preview lighting of the colour by the bump normal "
          "(light from the top left)", "mapping"),
    # ---- colour
    Param("ramp_mode", "enum", "linear", None, None, "linear (keys at their t) or spline (RenderMan "
          "Catmull-Rom through evenly spaced keys, as Qin; t ignored, >= 4 keys)", "color",
          choices=RAMP_MODES),
    Param("cell_mix", "float", 0.0, 0.0, 1.0, "ramp index = mix(height, cell value from the F1 feature "
          "ID, cell_mix): 1 = a constant colour per cell (flagstones)", "color"),
    Param("cell_color", "enum", "ramp", None, None, "the per-cell colour of cell_mix: ramp (at the cell "
          "value) or image (color.cell_image sampled at the cell's feature point: mosaic, stained glass; "
          "colour = mix(ramp(height), image, cell_mix))", "color", choices=CELL_COLORS, compile_time=True),
    Param("shade", "float", 0.0, 0.0, 1.0, "colour *= mix(1, height, shade) (grout of flagstones)", "color"),
    # ---- material: the roughness, ao and metallic channels (lib/texture_material.glsl), from the
    # cell value k (as cell_mix's: the F1 ID), the edge mask e = 1 - smoothstep(0, edge_width,
    # F2 - F1) (octave 0) and the cavity c = 1 - height; each clamped to [0, 1]
    Param("roughness", "float", 0.5, 0.0, 1.0, "roughness channel: roughness + roughness_cell (k - 0.5) "
          "+ roughness_edge e + roughness_cavity c (the stone faces' roughness)", "material"),
    Param("roughness_cell", "float", 0.0, -1.0, 1.0, "roughness per cell: times (cell value - 0.5)",
          "material"),
    Param("roughness_edge", "float", 0.0, -1.0, 1.0, "roughness at cell borders (grout): times the edge "
          "mask", "material"),
    Param("roughness_cavity", "float", 0.0, -1.0, 1.0, "roughness in cavities: times 1 - height",
          "material"),
    Param("edge_width", "float", 0.1, 0.001, 4.0, "edge mask 1 - smoothstep(0, edge_width, F2 - F1): "
          "1 on a cell border, 0 from edge_width cells (F2 - F1 at octave 0) inside", "material"),
    Param("ao_edge", "float", 0.0, 0.0, 1.0, "ambient occlusion channel: 1 - ao_edge e - ao_cavity c "
          "(darker in the grout ...)", "material"),
    Param("ao_cavity", "float", 0.0, 0.0, 1.0, "... and in the cavities of the height)", "material"),
    Param("metallic", "float", 0.0, 0.0, 1.0, "metallic channel: metallic + metallic_cell (k - 0.5) "
          "(a constant unless metallic_cell is set)", "material"),
    Param("metallic_cell", "float", 0.0, -1.0, 1.0, "metallic per cell: times (cell value - 0.5)",
          "material"),
)

PARAMS_BY_NAME: dict[str, Param] = {p.name: p for p in PARAMS}
assert len(PARAMS_BY_NAME) == len(PARAMS)
assert all(p.group in GROUPS for p in PARAMS)

#: the uniform a derived parameter reaches the shader through (default: the density map's)
_DERIVED_UNIFORM = {"orbit_phase": "u_orbit_turn", "stretch_x": "u_axis_scale", "stretch_y": "u_axis_scale",
                    "stretch_z": "u_axis_scale"}

# ---- when a parameter takes effect (the viewer, the playground and the Blender panel grey out
# the others, as Blender's node hides its Exponent socket unless the metric is Minkowski)

def _in(name: str, *values) -> tuple:
    return ((name, "in", values),)


def _nonzero(*names: str) -> tuple:
    return tuple((n, "!=", 0) for n in names)


#: name -> the requirements under which the parameter changes the texture. Each requirement is a
#: tuple of alternatives ``(name, op, value)``, one of which must hold (``op``: ``"in"`` (a
#: tuple of values), ``"not in"``, ``"!="``, ``">"`` or ``">="``); every requirement must hold.
#: A parameter not named here always takes effect. Every ``c_i`` and ``c_ij`` does: a non-zero
#: one raises ``CELL_N`` itself (:func:`cellgl.texture.recipe.needed_n`). The page ships this
#: table as data (``cellgl.playground``), so the rules are written once.
ACTIVE_WHEN: dict[str, tuple] = {
    "minkowski_p": (_in("metric", "minkowski"),),
    "density": (_in("distribution", "poisson"), _in("density_map", "none")),
    "density_map": (_in("distribution", "poisson"),),
    **{n: (_in("distribution", "poisson"), (("density_map", "not in", ("none",)),))
       for n in ("density_min", "density_max")},
    **{n: (_in("distribution", "poisson"), _in("density_map", "ramp_x", "ramp_y"))
       for n in ("density_start", "density_end")},
    **{n: (_in("distribution", "poisson"), _in("density_map", "radial"))
       for n in ("density_center_x", "density_center_y", "density_radius")},
    "jitter": (_in("distribution", "jitter", "blender"),),
    "min_points": (_in("distribution", "poisson"),),
    "max_points": (_in("distribution", "poisson"),),
    "seed": ((("distribution", "not in", ("blender",)),),),
    "stretch_z": ((("dimension", ">=", 3),),),
    "orbit_phase": ((("orbit_radius", ">", 0),),),
    "c_edge": (_in("metric", "euclidean"),),
    "c_nsphere": (_in("metric", "euclidean"),),
    "smoothness": (_nonzero("c_smooth", "cell_mix"),),
    "smooth": (_nonzero("c_smooth", "cell_mix"), (("smoothness", ">", 0),)),
    "octaves": ((("fractal", "not in", ("none",)),),),
    "lacunarity": ((("fractal", "not in", ("none",)),),),
    "gain": (_in("fractal", "sum", "qin", "qin_cube"),),
    "offset_z": ((("dimension", ">=", 3),),),
    "time": (_in("dimension", 4),),
    "warp_frequency": (_nonzero("warp_amount"),),
    "warp_octaves": (_nonzero("warp_amount"),),
    "noise_frequency": (_nonzero("c_noise", "noise_color"),),
    "noise_octaves": (_nonzero("noise_color"),),
    "cell_color": ((("cell_mix", ">", 0),),),
    "edge_width": (_nonzero("roughness_edge", "ao_edge"),),
}


def _holds(v, name: str, op: str, arg) -> bool:
    x = v[name] if name in v else PARAMS_BY_NAME[name].default
    if op == "in":
        return x in arg
    if op == "not in":
        return x not in arg
    if op == "!=":
        return x != arg
    if op == ">":
        return x > arg
    if op == ">=":
        return x >= arg
    raise ValueError(f"ACTIVE_WHEN: unknown operator {op!r}; accepted: in, not in, !=, >, >=")


def _say(name: str, op: str, arg) -> str:
    if op == "in":
        return f"{name} {' or '.join(str(a) for a in arg)}"
    if op == "not in":
        return f"{name} other than {' or '.join(str(a) for a in arg)}"
    if op == "!=" and arg == 0:
        return f"{name} not 0"
    if op == ">=":
        return f"{name} {arg} or more"
    return f"{name} {op} {arg}"


def inactive(values) -> dict[str, str]:
    """The parameters that change nothing with these values, each with what turns it on.

    Parameters
    ----------
    values : mapping or Recipe
        Parameter values by name (a recipe's ``values``, or a recipe itself); names left out
        take their table default.

    Returns
    -------
    dict
        ``{name: reason}`` for every inactive parameter, in table order; ``reason`` reads
        ``"needs metric minkowski"``: the requirements of :data:`ACTIVE_WHEN` that do not
        hold, joined by ", and".
    """
    v = values if isinstance(values, Mapping) else values.values
    out = {}
    for name, reqs in ACTIVE_WHEN.items():
        unmet = [req for req in reqs if not any(_holds(v, *alt) for alt in req)]
        if unmet:
            out[name] = "needs " + ", and ".join(" or ".join(_say(*alt) for alt in req) for req in unmet)
    return {p.name: out[p.name] for p in PARAMS if p.name in out}


#: the default ramp: black to white
DEFAULT_RAMP = ((0.0, 0.0, 0.0, 0.0), (1.0, 1.0, 1.0, 1.0))


def markdown_table() -> str:
    """The parameter table as Markdown (``docs/textures.md`` embeds it)."""
    lines = ["| group | name | type | default | accepted | shader | doc |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    for p in PARAMS:
        if p.name in PRODUCTS[1:] or p.name in LINEAR[1:]:
            continue
        name = p.name
        doc = p.doc
        if p.name == "c1":
            name, doc = "c1 .. c8", "weights of F1 .. F8 (Worley's linear combination); JSON: combination.linear"
        elif p.name == "c11":
            name, doc = "c11 .. c44", ("weights of F_i F_j, all 16 ordered pairs (Qin); JSON: "
                                       "combination.products (4 x 4)")
        default = str(p.default).lower() if isinstance(p.default, bool) else p.default
        kind = "#define" if p.compile_time else (_DERIVED_UNIFORM.get(p.name, "u_density_*") if p.derived
                                                 else f"u_{p.name}")
        if p.group == "material":
            kind += " (with CELL_TEX_MATERIAL)"
        doc = doc.replace("|", "\\|")
        lines.append(f"| {p.group} | `{name}` | {p.type} | `{default}` | {p.range_text()} | {kind} | {doc} |")
    return "\n".join(lines) + "\n"


def unqualified(name: str, item: str) -> str:
    """``basis.seed`` -> ``seed``: ``--set`` takes the qualified names the errors use too."""
    group, dot, short = name.rpartition(".")
    if not dot or group not in GROUPS:
        return name
    p = PARAMS_BY_NAME.get(short)
    owner = p.group if p is not None else ("color" if short == "ramp" else
                                           "combination" if short in ("linear", "products") else None)
    if owner is not None and owner != group:
        raise ValueError(f"--set {item!r}: {short} is in {owner}, not {group}; accepted: "
                         f"{owner}.{short} or {short}")
    return short
