"""PUPs recipes: the PUPs presets as recipes that bake, preview and list like the others.

A :class:`PupsRecipe` is the recipe form of a parameter dict of
:data:`cellgl.pups.presets.PUPS_PRESETS`: a ``pattern`` (the preset *kind*) and the values
of the parameter table :data:`PUPS_PARAMS` that this pattern uses (same :class:`Param` type
as :data:`cellgl.texture.params.PARAMS`, so ``--set``, the viewer's sliders and the docs table are
generated from it). The table is derived from :data:`cellgl.pups.presets.KIND_DEFAULTS`
(which keys each kind has, and their defaults), not written per preset. On disk::

    {"cellgl_recipe": 1, "kind": "pups", "name": "pups-cow", "doc": "...",
     "pups": {"pattern": "cow", "seed": 0, "radius": 0.05, ...}, "outputs": ["color"]}

Rendering (:func:`render`, reached through :func:`cellgl.recipes.render`): one period of the
periodic point set (the preset domain ``[-1, 1]^2``) spans the *shorter* side of the image,
undistorted; a ``W x H`` image with ``max / min`` an integer tiles seamlessly. Work happens in
*pixel space* (point positions scaled to pixels), where the pixel centres the shader computes
(``origin + i * pixel`` with ``pixel = 1``) are exact in float32, so a tile renders the same
bits as the whole image.
"""
from __future__ import annotations

import copy
import json
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np

from cellgl._cache import Bounded
from cellgl.texture.params import Param
from cellgl.texture.schema import (VERSION, RecipeError, coerce, value_error, suggest, check_name_doc, check_version, parse_value,
                                   read_json)

__all__ = ["PupsRecipe", "PUPS_PARAMS", "PUPS_PARAMS_BY_NAME", "PUPS_CHANNELS", "PATTERNS",
           "is_pups", "pups_preset_names", "load_pups_preset", "render", "params_for", "MAX_SIDE",
           "markdown_table"]

#: what a PUPs recipe renders (``cellgl.render(channels=...)``)
PUPS_CHANNELS = ("color", "height")
#: patterns (the presets' kinds; ``multiscale-cells`` is written ``multiscale_cells``)
PATTERNS = ("noise", "octaves", "cells", "multiscale_cells", "cow", "giraffe", "refine", "weight",
            "graph")
#: smallest Poisson radius of any layer (about 4 / (1.5 r^2) = 100k points)
MIN_RADIUS = 0.005

PUPS_PARAMS: tuple[Param, ...] = (
    Param("pattern", "enum", "noise", None, None, "what the control points carry and how they are "
          "evaluated (the preset kinds of cellgl.pups.presets)", "pattern", choices=PATTERNS),
    Param("seed", "int", 0, 0, 2 ** 32 - 1, "seed of every random choice (points, values, labels, "
          "orientations)", "pattern"),
    Param("radius", "float", 0.06, MIN_RADIUS, 0.5, "Poisson-disk minimum distance between control "
          "points (domain [-1, 1]^2): smaller is denser, finer", "points"),
    Param("radius_max", "float", 0.0, 0.0, 1.0, "progressive density: 0 uniform; else the radius "
          "grows from radius (right edge) to radius_max (left edge)", "points"),
    Param("octaves", "int", 4, 1, 8, "layers at radius * 2^-i, amplitude 2^-i, normalised", "points"),
    Param("iterations", "int", 4, 1, 8, "refinement steps, density doubling each", "points"),
    Param("axis_factor", "float", 1.0, 0.1, 16.0, "axis-length factor f: 1 interpolates, > 1 longer "
          "overlapping axes, smoother", "weights"),
    Param("epsilon", "float", 0.5, 0.0, 0.99, "orientation strength (eq. 4), [0, 1)", "weights"),
    Param("orientation", "enum", "random", None, None, "orientation of every point: random (on the "
          "sphere), none, right, outward (from the centre), tilt", "weights",
          choices=("random", "none", "right", "outward", "tilt")),
    Param("tilt", "float", 0.0, 0.0, 180.0, "orientation tilt: degrees from the z-axis towards +x",
          "weights"),
    Param("fold", "bool", False, None, None, "fold each layer: 2 |T - 0.5| (turbulence)", "values"),
    Param("group", "enum", "point", None, None, "one label per point, or per cluster of graph "
          "neighbours", "values", choices=("point", "cluster")),
    Param("cluster_min", "int", 3, 1, 32, "smallest cluster (group cluster)", "values"),
    Param("cluster_max", "int", 4, 1, 32, "largest cluster (group cluster)", "values"),
    Param("labels", "enum", "random", None, None, "binary labels: random, by a ramp along x, or "
          "drawn from the reference image", "values", choices=("random", "ramp", "image")),
    Param("n_min", "int", 10, 3, 64, "space giraffe: fewest angles (point pairs) per spot", "values"),
    Param("n_max", "int", 20, 3, 64, "space giraffe: most angles per spot", "values"),
    Param("spot", "color", (0.36, 0.2, 0.08), None, None, "space giraffe: spot colour", "color"),
    Param("background", "color", (0.96, 0.86, 0.62), None, None, "space giraffe: background colour",
          "color"),
    Param("contours", "int", 0, 0, 64, "isolines of the weight (0: the weight itself)", "color"),
    Param("line_width", "float", 1.5, 0.5, 8.0, "graph edges: width in pixels", "color"),
)
PUPS_PARAMS_BY_NAME = {p.name: p for p in PUPS_PARAMS}
#: the recipe's string field (not a table parameter): reference image for labels / refine
IMAGE_DOC = "reference image: 'builtin:shapes' or a grayscale image file"

# preset-dict key -> table names (pairs are split into two ints)
_PAIRS = {"cluster_sizes": ("cluster_min", "cluster_max"), "n_range": ("n_min", "n_max")}
_DOC_KEYS = ("figure", "description")


def _kind(pattern: str) -> str:
    return pattern.replace("_", "-")


def params_for(pattern: str) -> tuple[str, ...]:
    """Table names used by ``pattern`` (plus ``"image"`` where it reads one), in table order."""
    from cellgl.pups.presets import KIND_DEFAULTS

    keys = set(KIND_DEFAULTS[_kind(pattern)])
    names = {"pattern", "seed"}
    for k in keys:
        names.update(_PAIRS.get(k, (k,)))
    out = tuple(p.name for p in PUPS_PARAMS if p.name in names)
    return out + (("image",) if "image" in keys else ())


def _from_preset_dict(d: dict) -> dict:
    """Recipe values (table names) from a preset dict (``kind`` + parameters)."""
    from cellgl.pups.presets import KIND_DEFAULTS

    kind = d["kind"]
    full = copy.deepcopy(KIND_DEFAULTS[kind])
    full.update({k: v for k, v in d.items() if k not in _DOC_KEYS + ("kind",)})
    out = {"pattern": kind.replace("-", "_")}
    for k, v in full.items():
        if k in _PAIRS:
            out[_PAIRS[k][0]], out[_PAIRS[k][1]] = v
        elif k == "radius_max":
            out[k] = 0.0 if v is None else v
        else:
            out[k] = v
    return out


def _to_preset_dict(values: dict) -> dict:
    """The parameter dict :func:`cellgl.pups.presets.build_scene` takes."""
    pattern = values["pattern"]
    d: dict[str, Any] = {"kind": _kind(pattern)}
    for name in params_for(pattern):
        if name in ("pattern", "seed", "image"):
            continue
        v = values[name]
        if name == "radius_max":
            v = None if v == 0.0 else v
        elif isinstance(v, tuple):
            v = list(v)
        d[name] = v
    for key, (lo, hi) in _PAIRS.items():
        if lo in d:
            d[key] = [d.pop(lo), d.pop(hi)]
    return d


def is_pups(recipe) -> bool:
    """Whether ``recipe`` is a :class:`PupsRecipe`."""
    return isinstance(recipe, PupsRecipe)


class PupsRecipe:
    """A validated PUPs recipe (immutable: :meth:`replace` returns a new one).

    Attributes
    ----------
    kind : str
        ``"pups"`` (cellular recipes, :class:`cellgl.texture.recipe.Recipe`, have no ``kind``).
    name, doc : str
    values : mapping of table name -> value, for the names of :meth:`names` (the pattern's)
    image : str or None
        Reference image of patterns that read one (``cow`` with ``labels=image``, ``refine``).
    outputs : tuple of channel names
    """

    kind = "pups"
    variants = ()
    ramp = ()

    __slots__ = ("name", "doc", "_values", "image", "outputs")

    def __init__(self, values: dict | None = None, name: str = "custom", doc: str = "",
                 outputs=("color",), image: str | None = None):
        values = dict(values or {})
        pattern = coerce(PUPS_PARAMS_BY_NAME["pattern"], values.get("pattern", "noise"),
                         "pups.pattern")
        from cellgl.pups.presets import KIND_DEFAULTS

        vals = _from_preset_dict({"kind": _kind(pattern)})
        vals["seed"] = 0
        used = params_for(pattern)
        for k, v in values.items():
            if k == "image":
                image = v
                continue
            if k not in PUPS_PARAMS_BY_NAME:
                raise RecipeError(f"pups.{k}: unknown parameter{suggest(k, PUPS_PARAMS_BY_NAME)}; "
                                  f"accepted for pattern {pattern!r}: {', '.join(used)}")
            if k not in used:
                raise RecipeError(f"pups.{k}: not a parameter of pattern {pattern!r}; accepted: "
                                  f"{', '.join(used)}")
            vals[k] = coerce(PUPS_PARAMS_BY_NAME[k], v, f"pups.{k}")
        vals["pattern"] = pattern
        for k in used:
            if k != "image":
                vals[k] = coerce(PUPS_PARAMS_BY_NAME[k], vals[k], f"pups.{k}")
        if "image" in used:
            image = KIND_DEFAULTS[_kind(pattern)]["image"] if image is None else image
            if not isinstance(image, str) or not image:
                raise value_error("pups.image", image, IMAGE_DOC, "expected a string, got")
        else:
            if image is not None:
                raise RecipeError(f"pups.image: not a parameter of pattern {pattern!r}; accepted: "
                                  f"{', '.join(used)}")
        self._values = {k: vals[k] for k in used if k != "image"}
        self.image = image
        self.name, self.doc = check_name_doc(name, doc)
        if isinstance(outputs, str):
            outputs = [outputs]
        if not isinstance(outputs, (list, tuple)) or not outputs:
            raise value_error("outputs", outputs, "a list of: " + ", ".join(PUPS_CHANNELS),
                              "expected a list of channels, got")
        for c in outputs:
            if c not in PUPS_CHANNELS:
                raise value_error("outputs", c, "a list of: " + ", ".join(PUPS_CHANNELS),
                                  "unknown channel (PUPs recipes render color and height)")
        self.outputs = tuple(outputs)
        self._check()

    def _check(self):
        v = self._values
        if v.get("radius_max", 0.0) and v["radius_max"] <= v["radius"]:
            raise RecipeError(f"pups.radius_max: {v['radius_max']!r} must exceed pups.radius "
                              f"({v['radius']!r}); accepted: 0 (uniform) or > radius")
        for lo, hi in _PAIRS.values():
            if lo in v and v[lo] > v[hi]:
                raise RecipeError(f"pups.{lo}: {v[lo]} exceeds pups.{hi} ({v[hi]}); "
                                  f"accepted: {lo} <= {hi}")
        if "octaves" in v:
            smallest = v["radius"] * 2.0 ** -(v["octaves"] - 1)
            if smallest < MIN_RADIUS:
                raise RecipeError(f"pups.octaves: {v['octaves']} octaves from radius {v['radius']!r} "
                                  f"reach radius {smallest:.4g}; accepted: radius * 2^-(octaves - 1) "
                                  f">= {MIN_RADIUS}")
        if "iterations" in v:
            smallest = v["radius"] * 2.0 ** (-(v["iterations"] - 1) / 2)
            if smallest < MIN_RADIUS:
                raise RecipeError(f"pups.iterations: {v['iterations']} iterations from radius "
                                  f"{v['radius']!r} reach radius {smallest:.4g}; accepted: "
                                  f"radius * 2^-((iterations - 1) / 2) >= {MIN_RADIUS}")

    # ------------------------------------------------------------------ access
    @property
    def values(self):
        return MappingProxyType(self._values)

    def names(self) -> tuple[str, ...]:
        """The table names this recipe's pattern uses (``params_for(pattern)`` less ``image``)."""
        return tuple(self._values)

    def get(self, name: str):
        """The value of parameter ``name`` (or ``"image"``)."""
        if name == "image" and self.image is not None:
            return self.image
        if name not in self._values:
            raise RecipeError(f"pups.{name}: not a parameter of pattern {self._values['pattern']!r}"
                              f"{suggest(name, self._values)}; accepted: "
                              f"{', '.join(params_for(self._values['pattern']))}")
        return self._values[name]

    def __getitem__(self, name):
        return self.get(name)

    def replace(self, **values) -> PupsRecipe:
        """A copy with some values changed (also ``name=``, ``doc=``, ``outputs=``, ``image=``).

        Changing ``pattern`` keeps the values the new pattern shares and takes the new
        pattern's defaults for the rest.
        """
        values.pop("tileable", None)  # always periodic (see tileable()): nothing to change
        name = values.pop("name", self.name)
        doc = values.pop("doc", self.doc)
        outputs = values.pop("outputs", self.outputs)
        vals = dict(self._values)
        if self.image is not None:
            vals["image"] = self.image
        if "pattern" in values:
            pattern = coerce(PUPS_PARAMS_BY_NAME["pattern"], values["pattern"], "pups.pattern")
            used = params_for(pattern)
            vals = {k: v for k, v in vals.items() if k in used}
        vals.update(values)
        return PupsRecipe(vals, name, doc, outputs)

    def set_from_strings(self, items) -> PupsRecipe:
        """Apply ``["name=value", ...]`` (the CLI's ``--set``); returns a new recipe."""
        from cellgl.texture.recipe_json import parse_set_value

        changes = {}
        for item in items:
            if not isinstance(item, str) or "=" not in item:
                raise RecipeError(f"--set {item!r}: expected name=value")
            name, text = (s.strip() for s in item.split("=", 1))
            if name in ("image", "name", "doc"):
                changes[name] = text
                continue
            if name == "outputs":
                changes[name] = parse_set_value(name, text)
                continue
            p = PUPS_PARAMS_BY_NAME.get(name)
            if p is None:
                raise RecipeError(f"--set {name}={text}: unknown PUPs parameter"
                                  f"{suggest(name, PUPS_PARAMS_BY_NAME)}; accepted for pattern "
                                  f"{self._values['pattern']!r}: "
                                  f"{', '.join(params_for(self._values['pattern']))}")
            changes[name] = parse_value(p, name, text)
        try:
            return self.replace(**changes)
        except RecipeError as exc:
            raise RecipeError(f"--set {exc}") from None

    def tileable(self) -> tuple[PupsRecipe, list[str]]:
        """PUPs point sets are periodic: the recipe already tiles (no change, no notes).

        A ``W x H`` render is seamless when ``max(W, H) / min(W, H)`` is an integer (one
        period spans the shorter side)."""
        return self, []

    # ------------------------------------------------------------------ JSON
    def to_dict(self) -> dict:
        """The JSON form (every parameter of the pattern written out)."""
        g = {k: (list(v) if isinstance(v, tuple) else v) for k, v in self._values.items()}
        if self.image is not None:
            g["image"] = self.image
        return {"cellgl_recipe": VERSION, "kind": "pups", "name": self.name, "doc": self.doc,
                "pups": g, "outputs": list(self.outputs)}

    @classmethod
    def from_dict(cls, d, *, where: str = "recipe") -> PupsRecipe:
        """Validate a JSON-like dict (see the module doc); raises :class:`RecipeError`."""
        if not isinstance(d, dict):
            raise RecipeError(f"{where}: expected a JSON object, got {type(d).__name__}")
        keys = ("cellgl_recipe", "kind", "name", "doc", "pups", "outputs")
        for k in d:
            if k not in keys:
                raise RecipeError(f"{where}: unknown key {k!r}{suggest(str(k), keys)}; "
                                  f"accepted in a PUPs recipe: {', '.join(keys)}")
        if d.get("kind") != "pups":
            raise value_error("kind", d.get("kind"), "'pups'", "not a PUPs recipe:")
        check_version(d.get("cellgl_recipe", VERSION))
        for k in ("name", "doc"):
            if k in d and not isinstance(d[k], str):
                raise value_error(k, d[k], "a string", "expected a string, got")
        g = d.get("pups", {})
        if not isinstance(g, dict):
            raise value_error("pups", g, "a JSON object", "expected an object, got")
        if not g:
            held = ", ".join(repr(k) for k in d)
            raise RecipeError(f"{where}: no PUPs parameter set (it holds only {held}); accepted: a "
                              "'pups' section with at least its 'pattern' (`cellgl presets pups-cow` prints a "
                              "whole recipe to start from)")
        return cls(g, d.get("name", "custom"), d.get("doc", ""), d.get("outputs", ["color"]))

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), indent=2) + "\n"

    @classmethod
    def load(cls, path) -> PupsRecipe:
        """Read a PUPs recipe JSON file; a relative ``pups.image`` is relative to the file's
        folder (as ``color.cell_image`` of a cellular recipe), stored absolute."""
        path = Path(path)
        d = read_json(path)
        g = d.get("pups") if isinstance(d, dict) else None
        image = g.get("image") if isinstance(g, dict) else None
        if isinstance(d, dict) and isinstance(g, dict) and isinstance(image, str) and image.strip() \
                and not image.startswith("builtin:") and not Path(image).expanduser().is_absolute():
            d = {**d, "pups": {**g, "image": str(path.resolve().parent / Path(image).expanduser())}}
        try:
            return cls.from_dict(d)
        except RecipeError as exc:
            raise RecipeError(f"{path}: {exc}") from None

    def save(self, path) -> None:
        """Write the recipe as JSON, atomically (as a texture recipe's save:
        :func:`cellgl.io.formats.atomic_path`)."""
        from cellgl.io.formats import atomic_path

        with atomic_path(path) as tmp:
            tmp.write_text(self.to_json())

    def preset_params(self) -> dict:
        """The parameter dict of :mod:`cellgl.pups.presets` (``kind`` + parameters)."""
        d = _to_preset_dict(self._values)
        if self.image is not None:
            d["image"] = self.image
        return d

    def __eq__(self, other):
        return isinstance(other, PupsRecipe) and self.to_dict() == other.to_dict()

    def __hash__(self):
        return hash(json.dumps(self.to_dict(), sort_keys=True))

    def __repr__(self):
        return f"PupsRecipe(name={self.name!r}, pattern={self._values['pattern']!r})"


# ---------------------------------------------------------------------- presets

def pups_preset_names() -> list[tuple[str, str]]:
    """``[(name, one-line doc), ...]`` of the PUPs presets, sorted by name."""
    from cellgl.pups.presets import PUPS_PRESETS

    return [(n, f"PUPs fig. {d.get('figure', '?')}: {d.get('description', '')}")
            for n, d in sorted(PUPS_PRESETS.items())]


def load_pups_preset(name: str) -> PupsRecipe | None:
    """The PUPs preset ``name`` as a recipe, or None if there is none of that name."""
    from cellgl.pups.presets import PUPS_PRESETS

    d = PUPS_PRESETS.get(name)
    if d is None:
        return None
    vals = _from_preset_dict(d)
    image = vals.pop("image", None)
    doc = f"PUPs fig. {d.get('figure', '?')}: {d.get('description', '')}"
    return PupsRecipe(vals, name=name, doc=doc, image=image)


# ---------------------------------------------------------------------- rendering

_SCENES = Bounded("PUPs scenes by (recipe json, seed, backend) (cellgl.pups.recipe)", 4)
#: (id(graph), period) -> scaled layer data (each holds its graph: the id is not reused meanwhile)
_SCALED = Bounded("PUPs layers scaled to a period (cellgl.pups.recipe)", 4)


def _cached(cache: Bounded, key, make):
    value = cache.get(key)
    if value is None:
        value = make()
        cache.put(key, value)
    return value


def _scene(recipe: PupsRecipe, backend: str):
    from cellgl.pups.presets import build_scene

    key = (json.dumps(recipe.preset_params(), sort_keys=True), recipe.get("seed"), backend)
    return _cached(_SCENES, key, lambda: build_scene(recipe.preset_params(),
                                                     seed=recipe.get("seed"), backend=backend))


class _Scaled:
    """One layer's graph in pixel space (period ``S`` pixels): positions, boxes, axes."""

    def __init__(self, graph, period: int):
        pts = graph.points
        x0, y0, x1, y1 = pts.domain
        s = period / (x1 - x0)
        self.period = period
        self.graph = graph
        self.pos = (pts.positions - [x0, y0]) * s
        self.bbox = (graph.bbox - [x0, y0, x0, y0]) * s
        self.axes = graph.axes * s
        self.radius = graph.radius * s
        self.count = np.diff(graph.offsets)

    def region(self, x0, y0, tw, th):
        """A non-periodic graph of the instances (point + period shift) that reach the region,
        ordered by shift (``(0, 0)`` first, then row by row) and point index: the same order
        for every region, so sums run in the same order in a tile and in the whole image."""
        from cellgl.pups.graph import PupsGraph
        from cellgl.pups.points import PupsPoints

        S = float(self.period)
        b = self.bbox
        lo_x, hi_x = x0 - 1.0, x0 + tw + 1.0
        lo_y, hi_y = y0 - 1.0, y0 + th + 1.0
        ax0 = np.ceil((lo_x - b[:, 2]) / S).astype(np.int64)
        ax1 = np.floor((hi_x - b[:, 0]) / S).astype(np.int64)
        ay0 = np.ceil((lo_y - b[:, 3]) / S).astype(np.int64)
        ay1 = np.floor((hi_y - b[:, 1]) / S).astype(np.int64)
        shifts = [(0, 0)] + sorted({(a, c) for a in range(int(ax0.min()), int(ax1.max()) + 1)
                                    for c in range(int(ay0.min()), int(ay1.max()) + 1)} - {(0, 0)},
                                   key=lambda t: (t[1], t[0]))
        idx, sh = [], []
        for a, c in shifts:
            sel = np.nonzero((ax0 <= a) & (a <= ax1) & (ay0 <= c) & (c <= ay1))[0]
            if sel.size:
                idx.append(sel)
                sh.append(np.broadcast_to(np.array([a * S, c * S]), (sel.size, 2)))
        if not idx:
            return None
        k = np.concatenate(idx)
        shift = np.concatenate(sh)
        pts = self.graph.points
        pos = self.pos[k] + shift
        cnt = self.count[k]
        offsets = np.concatenate([[0], np.cumsum(cnt)]).astype(np.int64)
        rows = np.concatenate([np.arange(self.graph.offsets[i], self.graph.offsets[i + 1])
                               for i in k])
        # PupsPoints is built directly: instances lie outside the region's domain, and
        # pups_pack only maps the domain to pixels (pixel = 1, origin = x0 + 0.5, exact)
        sub = PupsPoints(pos, pts.values[k], pts.labels[k], pts.orientations[k],
                         (float(x0), float(y0), float(x0 + tw), float(y0 + th)), False)
        return PupsGraph(sub, self.graph.axis_factor, offsets, self.graph.neighbours[rows],
                         self.axes[rows], self.bbox[k] + np.c_[shift, shift], self.radius[k])


def period_px(width: int, height: int) -> int:
    """Pixels per period of the point set: the shorter side of the image."""
    return min(int(width), int(height))


#: the largest image side :func:`render` takes
MAX_SIDE = 1 << 16


def render(recipe: PupsRecipe, width: int, height: int, *, channels=("color",), x0: int = 0,
           y0: int = 0, tile_w: int | None = None, tile_h: int | None = None, depth=None,
           backend: str = "gpu") -> dict:
    """Render (a tile of) a PUPs recipe; :func:`cellgl.recipes.render` calls this.

    Parameters
    ----------
    recipe : PupsRecipe
    width, height : int
        The whole image, 1..65536 each. One period of the point set spans ``min(width,
        height)`` pixels.
    channels : sequence of str
        ``color`` (H, W, 4) float32, grey for scalar patterns, RGBA with alpha 1; ``height``
        (H, W) float32: the scalar value (for RGB patterns its Rec. 709 luma).
    x0, y0, tile_w, tile_h : int
        The sub-rectangle; its pixels are bit-identical to those of a one-pass render.
    depth : None
        PUPs textures are 2D: a volume is refused.
    backend : {"gpu", "numpy"}

    Returns
    -------
    dict channel -> ndarray (row 0 at the top)
    """
    from cellgl.pups.synthesis import pups_evaluate
    from cellgl.pups.presets import draw_graph, evaluate_scene

    from cellgl.texture.schema import check_channels, check_tile

    channels = check_channels(channels, PUPS_CHANNELS, "channel {!r} is not available for PUPs recipes")
    if depth is not None:
        raise ValueError("depth (a volume) is not available for PUPs recipes: they are 2D")
    if backend not in ("gpu", "numpy"):
        raise ValueError(f"unknown backend {backend!r}; accepted: gpu, numpy")
    tw, th = check_tile(width, height, x0, y0, tile_w, tile_h, max_side=MAX_SIDE)
    if tw > 16384 or th > 16384:
        raise ValueError(f"a PUPs render pass is at most 16384 x 16384 pixels, got {tw}x{th}; "
                         "render it in tiles (cellgl bake does)")
    scene = _scene(recipe, backend)
    S = period_px(width, height)

    def layer(lay):
        sc = _cached(_SCALED, (id(lay.graph), S), lambda: _Scaled(lay.graph, S))
        g = sc.region(x0, y0, tw, th)
        c = lay.graph.points.channels
        if g is None:
            return np.zeros((th, tw) if c == 1 else (th, tw, c), np.float32)
        return pups_evaluate(g, tw, th, mode=lay.mode, epsilon=lay.epsilon, backend=backend)

    def lines(pos, graph, prm):
        return draw_graph(prm, width, height, pos=pos, graph=graph, scale=(S / 2.0, S / 2.0),
                           region=(x0, y0, tw, th))

    img = evaluate_scene(scene, layer, lines)
    out = {}
    for c in channels:
        if c == "color":
            rgba = np.ones((th, tw, 4), np.float32)
            rgba[..., :3] = img[..., None] if img.ndim == 2 else img
            out[c] = rgba
        else:
            out[c] = img if img.ndim == 2 else np.ascontiguousarray(
                img @ np.array([0.2126, 0.7152, 0.0722], np.float32), dtype=np.float32)
    return out


def markdown_table() -> str:
    """The PUPs parameter table as Markdown (``docs/pups.md`` embeds it)."""
    from cellgl.pups.presets import KIND_DEFAULTS

    lines = ["| group | name | type | default | accepted | patterns | doc |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    for p in PUPS_PARAMS:
        used = [k for k in PATTERNS if p.name in params_for(k)]
        pats = "all" if len(used) == len(PATTERNS) else ", ".join(used)
        default = str(p.default).lower() if isinstance(p.default, bool) else p.default
        if isinstance(default, tuple):
            default = list(default)
        lines.append(f"| {p.group} | `{p.name}` | {p.type} | `{default}` | {p.range_text()} | "
                     f"{pats} | {p.doc.replace('|', chr(92) + '|')} |")
    pats = ", ".join(k for k in PATTERNS if "image" in params_for(k))
    lines.append(f"| values | `image` | string | `builtin:shapes` | a path or builtin:shapes | "
                 f"{pats} | {IMAGE_DOC} |")
    assert KIND_DEFAULTS  # the table's defaults per pattern come from KIND_DEFAULTS
    return "\n".join(lines) + "\n"
