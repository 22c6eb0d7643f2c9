"""Shader variants of the web playground: the compile-time ``#define`` sets the page can switch
between without Python, each exported by :mod:`cellgl.export` when the site is generated.

A variant is keyed by the compile-time macros of the exporter's :class:`~cellgl.export.snippets.
Program` (:data:`KEY_MACROS`); the page computes the same key from the current values
(``variantKey`` in ``static/playground.js``, held to :func:`variant_key` by the browser tests)
and loads ``variants/<id>.js``. Each preset ships its own variant and its neighbours: the
variants one compile-time choice away (another metric, distribution, ``n``, tiling, cell
feature, orbit or stretch), so every picker of a preset and most slider moves switch shaders
at once; a combination further away is named on the page with the ``cellgl`` command that
renders it.
"""
from __future__ import annotations

import hashlib
from dataclasses import replace
from typing import Any

from cellgl.export.reach import reached
from cellgl.export.snippets import ExportError, compiled_unit, entry_points, export_program, texture_program
from cellgl.recipes import load_recipe
from cellgl.texture.params import PARAMS_BY_NAME

__all__ = ["KEY_MACROS", "variant_key", "variant_id", "neighbours", "variant_texts", "PROBE_ENTRY"]

#: the macros that tell variants apart (the others follow from these or never change)
KEY_MACROS = ("CELL_DIM", "CELL_N", "CELL_METRIC", "CELL_DIST", "CELL_MAX_RING", "CELL_PERIODIC",
              "CELL_DENSITY_MAP", "CELL_ORBIT", "CELL_ANISO", "CELL_EDGE", "CELL_SMOOTH", "CELL_NSPHERE",
              "CELL_TEX_CELL_IMAGE")

#: the page's mean probe: octave 0's combination value at texture-space point p, its float bits
#: packed in RGBA8 (exact through any WebGL2 render target). The page averages it as
#: ``cellgl.texture.reference.octave_mean`` does, so the band limit fades to the same mean.
PROBE_ENTRY = """
// cellgl playground only: octave 0's combination value at texture-space point p (the mean
// probe of the band limit), its float bits as RGBA8.
vec4 cell_playground_probe(vec3 p)
{
    CellTextureParams t = cell_texture_params_load();
    vec4 g, F4, cell;
    uint id;
    float v = cell_texture_combination(cell_texture_local(p, t), t, 0, g, id, F4, cell);
    uint b = floatBitsToUint(v);
    return vec4(float(b & 255u), float((b >> 8) & 255u), float((b >> 16) & 255u), float(b >> 24)) / 255.0;
}
"""


def variant_key(defines: dict) -> str:
    """``"CELL_DIM=2,CELL_N=1,..."``: the key of a variant from a Program's defines."""
    return ",".join(f"{k}={int(defines[k])}" for k in KEY_MACROS)


def variant_id(key: str) -> str:
    """A short file-name-safe id of a key."""
    return hashlib.sha1(key.encode()).hexdigest()[:12]


def _tries(r):
    """Recipes one compile-time choice away from ``r`` (some may be refused)."""
    v = r.values
    out: list[dict[str, Any]] = []
    for m in PARAMS_BY_NAME["metric"].choices or ():       # (an enum always has its choices)
        out.append(dict(metric=m))
    for d in PARAMS_BY_NAME["distribution"].choices or ():
        out.append(dict(distribution=d, seed=0) if d == "blender" else dict(distribution=d))
    out.append(dict(tileable=not v["tileable"]))
    for n in range(1, 5):               # n = 1..4: zero the coefficients past n, make c_n count
        ch = {f"c{i}": 0.0 for i in range(n + 1, 9)}
        ch.update({f"c{i}{j}": 0.0 for i in range(1, 5) for j in range(1, 5) if max(i, j) > n})
        if v[f"c{n}"] == 0.0:
            ch[f"c{n}"] = 0.25
        out.append(ch)
    for c in ("c_edge", "c_nsphere"):
        out.append({c: 0.0 if v[c] != 0.0 else 0.5})
    out.append(dict(smoothness=0.0) if v["smoothness"] > 0 else dict(smoothness=0.05, c_smooth=v["c_smooth"] or 0.5))
    if v["smoothness"] > 0 and v["smoothness"] <= 0.25:
        out.append(dict(smooth="polynomial" if v["smooth"] == "exp" else "exp"))
    out.append(dict(orbit_radius=0.0 if v["orbit_radius"] > 0 else 0.25))
    aniso = any(v[f"stretch_{a}"] != 1.0 for a in "xyz")
    out.append(dict(stretch_x=1.0, stretch_y=1.0, stretch_z=1.0) if aniso else dict(stretch_x=2.0))
    return out


def neighbours(r) -> list:
    """``r`` and the recipes one compile-time choice away that the exporter accepts."""
    out = [r]
    for ch in _tries(r):
        try:
            out.append(r.replace(**ch))
        except ValueError:
            continue
    return out


def variant_texts(recipe) -> dict:
    """The texts of ``recipe``'s variant: ``live`` (GLSL ES with uniforms and the mean probe: what
    the page renders), ``gles``, ``godot``, ``hlsl`` (with uniforms: the page writes the current
    values in as constants) and ``wgsl`` (constants: the page rewrites their values); each
    without the exporter's header comment. Also ``uniforms``: ``[[glsl type, name], ...]``.

    One compile gives the first four: the probe is one more entry point of the live variant, and
    the others are that code reached from the texture's entry points only (what the probe alone
    needs goes); the WGSL keeps the recipe's values named (``fold=False``), a second compile.
    Each target is printed from the compiled tree itself (the text ``cellgl export`` would
    print and parse again gives the same snippets)."""
    r = load_recipe(recipe)
    prog = texture_program(r, uniforms=True)
    entries = entry_points(prog)
    live = replace(prog, entry=prog.entry + PROBE_ENTRY)
    unit = compiled_unit(live, entries=(*entries, "cellgl_playground_probe"))
    out: dict[str, object] = {"key": variant_key(prog.defines), "live": _body(export_program(live, "gles", uniforms=True, code=unit))}
    unit.items[:] = reached(unit.items, entries)
    for t in ("gles", "godot", "hlsl"):
        out[t] = _body(export_program(prog, t, uniforms=True, code=unit))
    # named constants (fold=False): the page writes the current values into them
    consts = texture_program(r)
    out["wgsl"] = _body(export_program(consts, "wgsl", fold=False, code=compiled_unit(consts, fold=False)))
    out["uniforms"] = [[t, n] for t, n, _ in prog.uniforms]
    return out


def _body(text: str) -> str:
    """A snippet without its header: the leading block of comment lines, up to a blank line."""
    lines = text.split("\n")
    i = 0
    while i < len(lines) and lines[i].startswith("//"):
        i += 1
    while i < len(lines) and not lines[i].strip():
        i += 1
    return "\n".join(lines[i:])


def exportable(r) -> str | None:
    """None if the exporter takes recipe ``r``, else its reason."""
    try:
        texture_program(r, uniforms=True)
    except ExportError as exc:
        return str(exc)
    return None
