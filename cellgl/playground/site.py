"""``cellgl playground -o DIR``: a static web page to try every texture preset in the browser.

The site is plain HTML + JavaScript with no server and no build step: it opens from
``file://`` (Chromium cannot ``fetch()`` local files, so every datum is a ``.js`` file loaded
with ``<script src>``) and from any static host. It holds

* ``index.html``, ``playground.js``, ``playground.css`` (``cellgl/playground/static``);
* ``data/site.js``: the parameter table (ranges, defaults, docs), every exportable preset (its
  values, ramp, a thumbnail rendered now, its variant) and the mean probe's sample points;
* ``variants/<id>.js``: one shader variant each (:mod:`cellgl.playground.variants`), loaded
  when the page needs it.

The page renders with WebGL2 (WebGPU for the WGSL snippet where the browser has it), runs
every run-time value through the exported snippet's ``cellgl_<name>`` uniforms, and computes
the derived ones (Poisson table, split origins, octave mean, ...) as the Python does; the
browser tests (``tests/test_playground.py``) hold the canvas to ``cellgl bake``.
"""
from __future__ import annotations

import base64
import io
import json
import math
from pathlib import Path

import numpy as np

from cellgl._version import __version__
from cellgl.basis.population import MAX_POINTS, W96_DENSITY_ADJUSTMENT
from cellgl.basis.reference import max_ring_default
from cellgl.export.compiler import collector_paused
from cellgl.io.spec import quantize
from cellgl.playground import variants as V
from cellgl.recipes import is_path, is_pups, list_presets, load_recipe, render
from cellgl.texture.schema import RecipeError
from cellgl import texture
from cellgl.texture import params as P

__all__ = ["build_site", "STATIC"]

STATIC = Path(__file__).resolve().parent / "static"
#: the mean probe's samples (cellgl.texture.reference.octave_mean: 4096 points, rng seed 20001)
MEAN_SAMPLES = 4096
MEAN_SEED = 20001
THUMB = 72

#: slider ranges where the schema's range is far wider than anyone drags (the number box next
#: to the slider still takes the whole schema range)
SOFT = {"offset_x": (-16.0, 16.0), "offset_y": (-16.0, 16.0), "offset_z": (-4.0, 4.0), "time": (0.0, 8.0),
        "orbit_phase": (0.0, 1.0), "range_lo": (-2.0, 2.0), "range_hi": (-2.0, 2.0), "seed": (0, 999),
        "density_start": (-1.0, 2.0), "density_end": (-1.0, 2.0), "density_center_x": (-0.5, 1.5),
        "density_center_y": (-0.5, 1.5), "density_radius": (0.01, 2.0), "frequency": (0.5, 64.0),
        "aspect": (0.1, 8.0), "bump": (0.0, 32.0), "minkowski_p": (0.25, 16.0), "level_lo": (-1.0, 2.0),
        "level_hi": (-1.0, 2.0), "c_noise": (-4.0, 4.0), "c_edge": (-8.0, 8.0), "c_smooth": (-8.0, 8.0),
        "c_nsphere": (-8.0, 8.0), "stretch_x": (0.25, 16.0), "stretch_y": (0.25, 16.0), "stretch_z": (0.25, 16.0),
        **{n: (-4.0, 4.0) for n in P.LINEAR + P.PRODUCTS}}

#: parameters the page cannot change for a recipe with a density map: the map's integer encoding
#: per octave (cellgl.basis.density) is computed by Python, for the preset's values only
DENSITY_FROZEN = ("density_map", "density_min", "density_max", "density_start", "density_end",
                  "density_center_x", "density_center_y", "density_radius", "frequency", "aspect",
                  "offset_x", "offset_y", "offset_z", "time", "lacunarity", "dimension", "tileable")


def _param_table() -> list[dict]:
    out = []
    for p in P.PARAMS:
        if p.group == "material":       # the page shows the colour; the material channels are bakes'
            continue
        d = {"name": p.name, "type": p.type, "default": p.default, "lo": p.lo, "hi": p.hi, "doc": p.doc,
             "group": p.group, "compile_time": p.compile_time, "derived": p.derived}
        if p.choices:
            d["choices"] = list(p.choices)
        if p.lo is not None:
            lo, hi = SOFT.get(p.name, (p.lo, p.hi))
            d["soft"] = [max(lo, p.lo), min(hi, p.hi)]
        out.append(d)
    return out


def _thumb(r) -> str:
    from PIL import Image

    rgba = render(r, THUMB, THUMB)["color"]
    img = Image.fromarray(quantize(rgba[..., :3], 8), "RGB")
    buf = io.BytesIO()
    img.save(buf, "PNG", optimize=True)
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode()


def _mean_points() -> dict:
    """The probe points of cellgl.texture.reference.octave_mean, as float32 base64: ``plane``
    (2D: a 1000-cell square), ``solid`` (3D/4D: a 100-cell cube), ``uv`` (density maps)."""
    out = {}
    for name, side, k in (("plane", 1000.0, 2), ("solid", 100.0, 3), ("uv", 1.0, 2)):
        pts = np.zeros((MEAN_SAMPLES, 4), dtype=np.float32)
        pts[:, :k] = np.random.default_rng(MEAN_SEED).uniform(0.0, side, size=(MEAN_SAMPLES, k))
        out[name] = base64.b64encode(pts.tobytes()).decode()
    return out


def _preset_entry(r, source: str, thumbs: bool) -> dict:
    prog = V.texture_program(r, uniforms=True)
    vals = {k: v for k, v in r.values.items()}
    fixed = {}
    if r.values["density_map"] != "none":
        fixed = {n: v for _, n, v in prog.uniforms if n.startswith("density_")}
    return {"name": r.name, "source": source, "doc": r.doc, "values": vals, "ramp": [list(k) for k in r.ramp],
            "variant": V.variant_id(V.variant_key(prog.defines)), "fixed_uniforms": fixed,
            "octave_mean": float(dict((n, v) for _, n, v in prog.uniforms)["octave_mean"]),
            "thumb": _thumb(r) if thumbs else None}


def playground_presets() -> list[str]:
    """The presets the page shows: the cellular ones the snippet exporter takes."""
    return [n for n, _ in list_presets("cellular") if V.exportable(load_recipe(n)) is None]


def _check_names(names) -> None:
    """RecipeError for a ``--preset`` that is neither a recipe file nor a preset, naming the
    presets the page accepts (not the PUPs ones it refuses)."""
    from cellgl.texture.schema import suggest

    known = {n for n, _ in list_presets()}
    for name in names:
        if not is_path(name) and name.partition(":")[0] not in known:
            shown = repr(name) if len(name) <= 80 else f"{name[:60]!r}... ({len(name)} characters)"
            accepted = playground_presets()
            raise RecipeError(f"--preset {shown}: unknown preset{suggest(name, accepted)}; accepted: a recipe "
                              ".json file or one of: " + ", ".join(accepted))


def _js(name: str, obj) -> str:
    return f"{name}({json.dumps(obj, separators=(',', ':'))});\n"


def build_site(out_dir, presets=None, *, thumbs: bool = True, neighbours: bool = True, log=None,
               jobs: int | None = None) -> dict:
    """Write the playground site into ``out_dir`` (created in an existing folder; files replaced
    atomically).

    Parameters
    ----------
    out_dir : str or path
    presets : list of str, optional
        Preset names or recipe JSON files (default: every cellular preset; PUPs presets are not
        exportable). The page's commands name them as given.
    thumbs : bool
        Render a thumbnail of each preset.
    neighbours : bool
        Ship the variants one compile-time choice away from each preset (else only its own).
    jobs : int, optional
        Processes exporting the variants (default: the CPUs available,
        :func:`cellgl.io.formats.usable_cores`; 1: in this process). The files are the same
        whatever the number.

    Returns
    -------
    dict: ``{"presets": [names], "refused": {name: reason}, "variants": count}``.
    """
    from cellgl.io.formats import atomic_path
    from cellgl.io.tempfiles import check_output_dir

    out = check_output_dir(out_dir)     # a missing parent folder is refused, never created
    if presets is None:
        names = [n for n, _ in list_presets()]
    else:
        names = list(dict.fromkeys(str(n) for n in presets))     # a name given twice: once
        _check_names(names)
    refused, recipes, sources = {}, {}, {}
    for name in names:
        r = load_recipe(name)
        if r.name in sources:
            raise RecipeError(f"--preset {name!r}: its recipe is named {r.name!r}, as is --preset "
                              f"{sources[r.name]!r}'s; the page tells presets apart by name (rename one)")
        sources[r.name] = name
        if is_pups(r):
            refused[name] = "PUPs recipe: a snippet would need the control points and their Delaunay axes as buffers"
            continue
        why = V.exportable(r)
        if why:
            refused[name] = why.split(": ", 1)[-1].split(";")[0]
            continue
        recipes[name] = r
    if not recipes:
        raise ValueError("no preset to show: " + "; ".join(f"{n}: {why}" for n, why in refused.items())
                         + " (accepted: cellular texture presets, `cellgl presets`)")
    todo = {}           # variant key -> the first recipe that needs it (its defines: no export yet)
    for r in recipes.values():
        for n in (V.neighbours(r) if neighbours else [r]):
            todo.setdefault(V.variant_key(texture.defines(n)), n)
    (out / "variants").mkdir(parents=True, exist_ok=True)
    (out / "data").mkdir(parents=True, exist_ok=True)
    vids = {}
    with _Exports(list(todo.items()), jobs) as results:
        # the thumbnails (GL) here while the worker processes export the variants
        entries = []
        for name, r in recipes.items():
            entries.append(_preset_entry(r, str(name), thumbs))
            if log:
                log(f"preset {name}")
        for key, texts in results:
            if texts is None:               # the exporter refuses this neighbour: not shipped
                continue
            vid = vids[key] = V.variant_id(key)
            texts["id"] = vid
            _write(out / "variants" / f"{vid}.js", _js("cellglVariant", texts), atomic_path)
        if log:
            log(f"{len(vids)} shader variants")
    site = {"version": __version__, "params": _param_table(), "presets": entries, "refused": refused,
            "variants": vids, "key_macros": list(V.KEY_MACROS), "density_frozen": list(DENSITY_FROZEN),
            "active_when": P.ACTIVE_WHEN,
            "consts": {"max_points": MAX_POINTS, "w96": W96_DENSITY_ADJUSTMENT,
                       "max_octaves": int(math.ceil(P.PARAMS_BY_NAME["octaves"].hi)),
                       "ramp_keys": P.MAX_RAMP_KEYS, "mean_samples": MEAN_SAMPLES,
                       # CELL_MAX_RING of isotropic cells per dimension (the page scales it by
                       # the stretch ratio as cellgl.basis.reference.max_ring_default does)
                       "max_ring": {d: max_ring_default(d) for d in (2, 3, 4)}},
            "mean_points": _mean_points()}
    _write(out / "data" / "site.js", _js("cellglSite", site), atomic_path)
    for f in ("index.html", "playground.js", "playground.css"):
        _write(out / f, (STATIC / f).read_text(encoding="utf-8"), atomic_path)
    return {"presets": [e["name"] for e in entries], "refused": refused, "variants": len(vids)}


def _variant(item):
    """``(key, variant texts)`` of one ``(key, recipe)``; texts None if the exporter refuses it
    (a worker process's job). The cyclic garbage collector is off meanwhile
    (:func:`cellgl.export.compiler.collector_paused`): one pass over what this export made, after it."""
    key, r = item
    try:
        with collector_paused():
            return key, V.variant_texts(r)
    except ValueError:
        return key, None


class _Exports:
    """The variants' exports, in ``todo``'s order: in ``jobs`` worker processes (started with
    ``spawn``, so no GL context crosses a fork; the exporter needs none), or here for one."""

    def __init__(self, todo, jobs):
        from cellgl.io.formats import usable_cores

        self.items = list(todo)
        self.jobs = max(1, min(int(jobs or usable_cores()), len(self.items)))
        self.pool = None

    def __enter__(self):
        if self.jobs == 1:
            return map(_variant, self.items)
        import multiprocessing

        self.pool = multiprocessing.get_context("spawn").Pool(self.jobs)
        return self.pool.imap(_variant, self.items, chunksize=1)

    def __exit__(self, *exc):
        if self.pool is not None:
            (self.pool.close if exc[0] is None else self.pool.terminate)()
            self.pool.join()
        return False


def _write(path: Path, text: str, atomic_path) -> None:
    with atomic_path(path) as tmp:
        Path(tmp).write_text(text, encoding="utf-8", newline="\n")
