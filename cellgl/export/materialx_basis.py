"""MaterialX nodes of the cellular basis: ``cellgl_cellular{2,3}d_<metric>_<distribution>``.

One node per dimension (2: ``position`` vector2, default UV0; 3: vector3, default Pobject, as
MaterialX's own ``worleynoise3d``), metric (euclidean, manhattan, chebyshev, minkowski) and
distribution (poisson, jitter): the metric and the distribution choose the search's code, so
each pair is its own node, compiled by the exporter as :mod:`cellgl.export.basis` compiles a
basis snippet. Their outputs, at ``position`` in cells (one cell per unit), equal
``cellgl.cellular(points, ...)`` with the same parameters:

* ``f1`` .. ``f4``: the distances to the four nearest feature points (F1..F4, n = 4);
* ``featurepoint``: the nearest feature point; ``cellcolor`` / ``cellvalue``: its cell's random
  colour and value (``cellgl.cellular``'s ``id`` through ``id_colors`` / the texture's cell
  value);
* Euclidean only: ``edge``, the exact distance to the border of the Voronoi cell, and
  ``nsphere``, half the distance from the nearest point to its own nearest neighbour.

Inputs: ``seed`` (integer; its 32 bits are the unsigned seed), ``jitter`` (jitter),
``density`` (poisson: mean points per cell; the Poisson table is computed in the shader in
float32, see :func:`float32_thresholds`), ``minkowski_p`` (minkowski). ``min_points`` and
``max_points`` (poisson) are fixed at 1 and 9 (Worley's): the search's code is specialised to
them.
"""
from __future__ import annotations

import math

from cellgl.export.materialx import MxInput, MxNode, compiled, private_globals, renamed, without_array_constructors

__all__ = ["basis_nodes", "basis_node", "BASIS_METRICS", "BASIS_DISTRIBUTIONS", "float32_thresholds"]

BASIS_METRICS = ("euclidean", "manhattan", "chebyshev", "minkowski")
BASIS_DISTRIBUTIONS = ("poisson", "jitter")
_VEC = {2: ("vec2", "vector2"), 3: ("vec3", "vector3")}

_PARAMS = """
// The basis parameters: the node's inputs (variables the node's function sets), and the
// Poisson table of density, computed here (float32; cellgl.basis.population in float64).
uniform uint cell_seed;
uniform float cell_jitter;
uniform float cell_density;
uniform float cell_minkowski_p;
uint cell_mx_threshold(float cdf)
{
    float x = min(cdf, 1.0) * 4294967296.0;
    return x >= 4294967296.0 ? 4294967295u : uint(x);
}
CellParams cell_params_load()
{
    CellParams q;
    q.seed = cell_seed;
    q.jitter = cell_jitter;
    q.min_points = 1;
    q.max_points = 9;
    float term = exp(-cell_density);
    float cdf = 0.0;
    for (int k = 0; k < CELL_MAX_POINTS; k++) {
        cdf += term;
        q.thresholds[k] = cell_mx_threshold(cdf);
        term *= cell_density / float(k + 1);
    }
    q.period = ivec4(0);
    q.minkowski_p = cell_minkowski_p;
    return q;
}
"""


def _entry(dim: int, euclid: bool) -> str:
    v = _VEC[dim][0]
    cell = "ivec4(ivec2(fl), 0, 0)" if dim == 2 else "ivec4(ivec3(fl), 0)"
    frac = "vec4(p - fl, 0.0, 0.0)" if dim == 2 else "vec4(p - fl, 0.0)"
    sw = "xy" if dim == 2 else "xyz"
    feats = ", out float edge, out float nsphere" if euclid else ""
    body = ("    CellFeatures x = cell_features(cell, f, q, r, 0.0);\n    edge = x.edge;\n"
            "    nsphere = x.nsphere;\n") if euclid else ""
    return f"""
void cell_mx_cellular({v} p, out float f1, out float f2, out float f3, out float f4, out {v} position,
                      out vec3 cellcolor, out float cellvalue{feats})
{{
    {v} fl = floor(p);
    ivec4 cell = {cell};
    vec4 f = {frac};
    CellParams q = cell_params_load();
    CellResult r = cell_search(cell, f, q);
    f1 = r.F[0];
    f2 = r.F[1];
    f3 = r.F[2];
    f4 = r.F[3];
    position = p + r.delta[0].{sw};
    cellcolor = cell_id_color(r.id[0]);
    cellvalue = cell_id_value(r.id[0]);
{body}}}
"""


def _program(dim: int, metric: str, distribution: str):
    from cellgl.basis.core import make_params
    from cellgl.basis.features import defines as feature_defines
    from cellgl.basis.gpu import defines_for
    from cellgl.export.snippets import Program

    p = make_params(dim, metric=metric, distribution=distribution)
    euclid = metric == "euclidean"
    defines = defines_for(p, 4)
    defines.update(feature_defines(("edge", "nsphere") if euclid else (), dim))
    defines["CELL_EDGE_ALONE"] = 0
    return Program(files=["lib/features.glsl"], defines=defines, params=_PARAMS, entry="",
                   title=f"cellular{dim}d", kind="cellular basis", entries=("cellgl_mx_cellular",))


def basis_node(dim: int, metric: str, distribution: str) -> MxNode:
    """The node ``cellgl_cellular{dim}d_{metric}_{distribution}`` (see the module's doc)."""
    from cellgl.export.translate import to_osl
    from cellgl.texture.params import PARAMS_BY_NAME as P

    vg, vm = _VEC[dim]
    name = f"cellgl_cellular{dim}d_{metric}_{distribution}"
    euclid = metric == "euclidean"
    inputs = [MxInput("position", vm, None, "the sample point in cells (one cell per unit)",
                      geomprop="UV0" if dim == 2 else "Pobject", glsl=vg, osl="vector2" if dim == 2 else "vector")]

    def add(pname, mxtype, value, glsl, osl, var, lo=None, hi=None):
        inputs.append(MxInput(pname, mxtype, value, P[pname].doc, lo if lo is not None else P[pname].lo,
                              hi if hi is not None else P[pname].hi, "basis", pname.replace("_", " ").capitalize(),
                              glsl=glsl, osl=osl, var=var))

    if distribution == "poisson":
        add("density", "float", 3.0, "float", "float", "cellgl_density")
    else:
        add("jitter", "float", 1.0, "float", "float", "cellgl_jitter")
    if metric == "minkowski":
        add("minkowski_p", "float", 3.0, "float", "float", "cellgl_minkowski_p")
    add("seed", "integer", 0, "int", "int", "cellgl_seed", lo=0, hi=2 ** 31 - 1)
    inputs[-1].doc += " (an integer input: its 32 bits are the unsigned seed, so negative values reach 2^31 .. 2^32 - 1)"
    outs = [(f"f{k}", "float", "float", "float", f"F{k}, the distance to the {k}{'st' if k == 1 else 'nd' if k == 2 else 'rd' if k == 3 else 'th'} nearest feature point")
            for k in range(1, 5)]
    outs += [("featurepoint", vm, vg, "vector2" if dim == 2 else "vector", "the nearest feature point, in cells"),
             ("cellcolor", "color3", "vec3", "color", "random colour of the nearest point's cell (cellgl's id_colors)"),
             ("cellvalue", "float", "float", "float", "random value in [0, 1) of the nearest point's cell")]
    if euclid:
        outs += [("edge", "float", "float", "float", "distance to the border of the Voronoi cell (exact)"),
                 ("nsphere", "float", "float", "float", "n-sphere radius: half the distance from the nearest point "
                  "to its nearest other point")]
    doc = (f"cellgl's cellular basis, {dim}D, {metric} metric, {distribution} feature points: exact F1..F4 (every "
           "point that can be nearer is visited, not a fixed window) and the nearest cell's features, at position in "
           "cells; equal to cellgl.cellular with the same parameters (min_points 1, max_points 9)")
    node = MxNode(name, "procedural2d" if dim == 2 else "procedural3d", doc, inputs, outs)
    prog = _program(dim, metric, distribution)
    live = {"cell_seed", "cell_jitter", "cell_density", "cell_minkowski_p"}
    code, kept = compiled(prog, _entry(dim, euclid), "cell_mx_cellular", live)
    entry = renamed("cellgl_mx_cellular", name)
    # GLSL
    args = [f"{i.glsl} in_{i.name}" for i in inputs] + [f"out {o[2]} out_{o[0]}" for o in outs]
    glsl, first = without_array_constructors(private_globals(renamed(code, name)), name + "_init_arrays")
    sets = [first] if first else []
    for i in inputs:
        if i.var in kept:
            val = f"uint(in_{i.name})" if i.name == "seed" else f"in_{i.name}"
            sets.append(f"    {renamed(i.var, name)} = {val};")
    call = ", ".join(["in_position"] + [f"out_{o[0]}" for o in outs])
    node.glsl = (f"// cellgl: MaterialX node {name} (GLSL), compiled by `cellgl export --target materialx`.\n"
                 + glsl + f"\n// MaterialX implementation of {node.nodedef} "
                 f"(genglsl).\nvoid {node.function}({', '.join(args)})\n{{\n" + "\n".join(sets)
                 + f"\n    {entry}({call});\n}}\n")
    # OSL: vectors are the translation's structs; the variables are passed as parameters
    passed: dict = {}
    osl = to_osl(code, params=kept, passed=passed)
    by_var = {i.var: i for i in inputs if i.var}
    oargs = [f"{i.osl} in_{i.name}" for i in inputs] + [f"output {o[3]} out_{o[0]}" for o in outs]
    s = f"{name}_vec{dim}"
    pos_in = f"{s}(in_position.x, in_position.y)" if dim == 2 else f"{s}(in_position[0], in_position[1], in_position[2])"
    locs = [f"    {s} pos;", f"    {name}_vec3 cc;"]
    callargs = [pos_in] + [("pos" if o[0] == "featurepoint" else "cc" if o[0] == "cellcolor" else f"out_{o[0]}")
                           for o in outs] + [f"in_{by_var[g].name}" for g in passed.get("cellgl_mx_cellular", [])]
    pos_out = "vector2(pos.x, pos.y)" if dim == 2 else "vector(pos.x, pos.y, pos.z)"
    node.osl = (f"// cellgl: MaterialX node {name} (OSL), compiled by `cellgl export --target materialx`.\n"
                + renamed(osl, name) + f"\n// MaterialX implementation of {node.nodedef} (genosl).\n"
                f"void {node.function}({', '.join(oargs)})\n{{\n" + "\n".join(locs)
                + f"\n    {entry}({', '.join(callargs)});\n    out_featurepoint = {pos_out};\n"
                "    out_cellcolor = color(cc.x, cc.y, cc.z);\n}\n")
    return node


def basis_nodes() -> list[MxNode]:
    """Every basis node: 2D and 3D, each metric, each distribution."""
    return [basis_node(d, m, t) for d in (2, 3) for m in BASIS_METRICS for t in BASIS_DISTRIBUTIONS]


def float32_thresholds(density: float):
    """The Poisson table the basis nodes compute in the shader, emulated in NumPy float32 (the
    shader's arithmetic, up to its ``exp``): compare with
    :func:`cellgl.basis.population.poisson_thresholds` (float64)."""
    import numpy as np

    f = np.float32
    d = f(density)
    term, cdf, out = f(math.exp(-float(d))), f(0.0), []
    for k in range(16):
        cdf = f(cdf + term)
        x = f(min(cdf, f(1.0)) * f(4294967296.0))
        out.append(4294967295 if x >= 4294967296.0 else int(x))
        term = f(term * f(d / f(k + 1)))
    return np.array(out, np.uint64)
