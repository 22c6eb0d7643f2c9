"""Basis-only snippets: ``cellgl export --basis f1f2 --dim 3`` gives ``vec2 cellgl_f1f2(vec3 p)``.

One function of the cellular basis at a point ``p`` in cells (one cell per unit, as
:func:`cellgl.cellular`), in the style of the small noise libraries: no texture, no colour, the
exact search of ``shaders/lib/cellular.glsl`` specialised to the parameters (metric,
distribution, density, jitter, seed, ...) and cut down to what the function reaches
(:mod:`cellgl.export.fold`). The values equal ``cellgl.cellular(points, ...)`` with the same
parameters.

The functions, their GLSL result types and what they return: :data:`BASES` (``--basis f1f2
--dim 3``: ``vec2 cellgl_f1f2(vec3 p)``, (F1, F2)).
"""
from __future__ import annotations

from cellgl.basis.enums import Distribution, Metric
from cellgl.export.snippets import ExportError, Program, check_target, export_program

__all__ = ["BASES", "basis_export", "basis_program"]

#: basis name -> (number of F's searched, GLSL return type, what it returns)
BASES: dict[str, tuple[int, str, str]] = {
    "f1": (1, "float", "F1, the distance to the nearest feature point"),
    "f1f2": (2, "vec2", "(F1, F2), the distances to the two nearest feature points"),
    "f1f2f3": (3, "vec3", "(F1, F2, F3)"),
    "f1f2f3f4": (4, "vec4", "(F1, F2, F3, F4)"),
    "edge": (1, "float", "the distance to the edge of p's Voronoi cell (Euclidean)"),
    "cellid": (1, "uint", "the ID of the nearest feature point (cellgl.cellular's id[..., 0])"),
}

#: the parameters of a basis snippet and their defaults (cellgl.cellular's; the command line's)
DEFAULTS = dict(metric="euclidean", distribution="poisson", density=3.0, jitter=1.0, seed=0,
                min_points=1, max_points=9, minkowski_p=3.0)
#: distributions a basis snippet cannot express (see basis_program's refusal)
BASIS_REFUSED = (Distribution.WORLEY1996,)
_VEC = {2: "vec2", 3: "vec3", 4: "vec4"}
_CELL = {2: "ivec4(ivec2(fl), 0, 0)", 3: "ivec4(ivec3(fl), 0)", 4: "ivec4(fl)"}
_FRAC = {2: "vec4(p - fl, 0.0, 0.0)", 3: "vec4(p - fl, 0.0)", 4: "p - fl"}
_RET = {"f1": "r.F[0]", "f1f2": "vec2(r.F[0], r.F[1])", "f1f2f3": "vec3(r.F[0], r.F[1], r.F[2])",
        "f1f2f3f4": "vec4(r.F[0], r.F[1], r.F[2], r.F[3])", "cellid": "r.id[0]",
        "edge": "cell_edge_alone(cell, f, P)"}


def _glsl_float(v: float) -> str:
    r = repr(float(v))
    return r if ("." in r or "e" in r or "n" in r) else r + ".0"


def basis_program(basis: str, dim: int = 2, *, metric="euclidean", distribution="poisson", density=3.0,
                  jitter=1.0, min_points=1, max_points=9, minkowski_p=3.0, seed=0) -> Program:
    """The :class:`~cellgl.export.snippets.Program` of one basis function (see :data:`BASES`)."""
    from cellgl.basis.core import make_params
    from cellgl.basis.features import defines as feature_defines
    from cellgl.basis.gpu import defines_for

    key = str(basis).strip().lower()
    if key not in BASES:
        raise ExportError(f"unknown basis {basis!r}; expected one of: {', '.join(BASES)}")
    if dim not in (2, 3, 4) or isinstance(dim, bool):
        raise ExportError(f"dim must be 2, 3 or 4, got {dim!r}")
    dim = int(dim)
    p = make_params(dim, metric=metric, distribution=distribution, density=density, jitter=jitter,
                    min_points=min_points, max_points=max_points, minkowski_p=minkowski_p, seed=seed)
    if p.distribution in BASIS_REFUSED:
        raise ExportError("distribution 'worley1996' cannot be exported as a basis snippet (its "
                          "positions are rescaled in double precision first); use poisson or jitter")
    if key == "edge" and p.metric != Metric.EUCLIDEAN:
        raise ExportError(f"basis 'edge' is Euclidean only, got metric {p.metric.name.lower()!r}")
    n, ret, what = BASES[key]
    defines = defines_for(p, n)
    defines.update(feature_defines(("edge",) if key == "edge" else (), dim))
    defines["CELL_EDGE_ALONE"] = int(key == "edge")      # features.glsl: the edge without cell_search
    thresholds = ", ".join(f"{int(t)}u" for t in p.thresholds)
    params = (
        "// The basis parameters.\n"
        f"const uint cell_seed = {int(p.seed)}u;\n"
        f"const float cell_jitter = {_glsl_float(p.jitter)};\n"
        f"const int cell_min_points = {int(p.min_points)};\n"
        f"const int cell_max_points = {int(p.max_points)};\n"
        f"const uint cell_thresholds[{len(p.thresholds)}] = uint[{len(p.thresholds)}]({thresholds});\n"
        f"const float cell_minkowski_p = {_glsl_float(p.minkowski_p)};\n"
        "CellParams cell_params_load()\n{\n    CellParams q;\n    q.seed = cell_seed;\n"
        "    q.jitter = cell_jitter;\n    q.min_points = cell_min_points;\n"
        "    q.max_points = cell_max_points;\n"
        f"    for (int k = 0; k < {len(p.thresholds)}; k++) {{\n"
        "        q.thresholds[k] = cell_thresholds[k];\n    }\n"
        "    q.period = ivec4(0);\n    q.minkowski_p = cell_minkowski_p;\n    return q;\n}\n"
    )
    vec = _VEC[dim]
    name = f"cell_{key}"
    entry = (
        f"// {what[0].upper() + what[1:]}, at p in cells.\n"
        f"{ret} {name}({vec} p)\n{{\n"
        f"    {vec} fl = floor(p);\n"
        f"    ivec4 cell = {_CELL[dim]};\n"
        f"    vec4 f = {_FRAC[dim]};\n"
        + ("" if key == "edge" else "    CellResult r = cell_search(cell, f, cell_params_load());\n")
        + f"    return {_RET[key].replace('P', 'cell_params_load()')};\n}}\n"
    )
    options = {k: getattr(p, k) for k in DEFAULTS} | dict(metric=p.metric.name.lower(),
                                                         distribution=p.distribution.name.lower())
    command = f"cellgl export --basis {key} --dim {dim}" + "".join(
        f" --{k.replace('_', '-')} {v}" for k, v in options.items() if v != DEFAULTS[k])
    files = ["lib/features.glsl"] if key == "edge" else ["lib/cellular.glsl"]
    return Program(files=files, defines=defines, params=params, entry=entry, title=key,
                   recipe=dict(basis=key, dim=dim, **options), kind="cellular basis",
                   command=command, signatures=(f"{ret} cellgl_{key}({vec} p): {what}; p in cells",),
                   entries=(f"cellgl_{key}",), tails=_tails(key, dim, ret))


def _tails(key: str, dim: int, ret: str) -> dict:
    """Shadertoy mainImage, Godot fragment() and the Unity Custom Function wrapper (GLSL, printed
    in the target's dialect)."""
    show = {"float": "v", "vec2": "v.y - v.x", "vec3": "v.x", "vec4": "v.x",
            "uint": "float(v & 255u) / 255.0"}[ret]
    at = {2: "uv", 3: "vec3(uv, T)", 4: "vec4(uv, T, 0.0)"}[dim]    # uv: 8 cells per unit
    return {
        "shadertoy": ("// Shadertoy entry: 8 cells per screen height.\n"
                      "void mainImage(out vec4 fragColor, in vec2 fragCoord) {\n"
                      f"    {ret} v = cellgl_{key}({at.replace('uv', 'fragCoord / iResolution.y * 8.0').replace('T', '0.25 * iTime')});\n"
                      f"    fragColor = vec4(vec3({show}), 1.0);\n}}\n"),
        "godot": ("void fragment() {\n"
                  f"    {ret} v = cellgl_{key}({at.replace('uv', 'UV * 8.0').replace('T', '0.25 * TIME')});\n"
                  f"    COLOR = vec4(vec3({show}), 1.0);\n}}\n"),
        "unity": (f"// Unity Shader Graph Custom Function node (Type: File, Name: cellgl_{key}).\n"
                  f"void cellgl_{key}_float(vec{dim} P, out {ret} Out)\n{{\n"
                  f"    Out = cellgl_{key}(P);\n}}\n"),
    }


def basis_export(basis: str, dim: int = 2, target: str = "glsl", **params) -> str:
    """The snippet of one basis function for ``target``.

    Parameters
    ----------
    basis : str
        One of :data:`BASES`: ``f1``, ``f1f2``, ``f1f2f3``, ``f1f2f3f4``, ``edge``, ``cellid``.
    dim : int
        2, 3 or 4: the function takes a ``vec2``, ``vec3`` or ``vec4`` in cells.
    target : str
        As :func:`cellgl.export.snippets.export`.
    **params
        ``metric``, ``distribution`` (poisson or jitter), ``density``, ``jitter``, ``seed``,
        ``min_points``, ``max_points``, ``minkowski_p``, as :func:`cellgl.cellular`.
    """
    check_target(target)
    return export_program(basis_program(basis, dim, **params), target)
