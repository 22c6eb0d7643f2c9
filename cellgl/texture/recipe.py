"""Texture recipes: one JSON-serialisable description of a texture.

A recipe holds a value for every parameter of the table in :mod:`cellgl.texture.params` (basis,
combination, fractal, domain, noise, mapping, colour), the colour ramp, and a name and
one-line doc. On disk it is JSON, one section per parameter group::

    {
      "cellgl_recipe": 1,
      "name": "veins", "doc": "F2 - F1 ...",
      "basis": {"dimension": 2, "distribution": "poisson", ...},
      "combination": {"linear": [-1, 1, 0, 0, 0, 0, 0, 0], "products": [[0, 0, 0, 0], ...],
                      "c_noise": 0.0, "range_lo": 0.0, "range_hi": 0.6},
      "fractal": {...}, "domain": {...}, "noise": {...}, "mapping": {...},
      "color": {"ramp_mode": "linear", "cell_mix": 0.0, "shade": 0.0,
                "ramp": [[0.0, 0, 0, 0], [1.0, 1, 1, 1]]},
      "outputs": ["color"]
    }

Sections and keys may be left out (the table's defaults apply), but a recipe that sets no value at
all (``{}``, ``{"name": "x"}``) is refused: ``Recipe()`` is the all-defaults recipe. Coefficients may also be given
one by one (``"c12": 1.0``). Reading is strict: an unknown key, a wrong type or a value out of
range raises :class:`RecipeError` naming the field path, the bad value and what is accepted.

A preset file may also hold ``"variants"``: a list of partial recipes (each with a ``name``)
applied over the base; ``load_recipe("worley-gallery:7")`` picks one.
"""
from __future__ import annotations

import json
import math
import numbers
import os
from pathlib import Path
from types import MappingProxyType

from cellgl.basis.reference import minkowski_floor, minkowski_message, sparse_message
from cellgl.texture import domain
from cellgl.texture.schema import check_name_doc, check_version
from cellgl.texture.schema import (CHANNELS, VERSION, RecipeError, coerce, value_error, suggest,  # noqa: F401
                                   check_channels, parse_value, read_json)
from cellgl.texture.params import (DEFAULT_RAMP, GROUPS, LINEAR, MAX_RAMP_KEYS, N_LINEAR, PARAMS, PARAMS_BY_NAME,
                     PRODUCTS, unqualified)

__all__ = ["Recipe", "RecipeError", "load_recipe", "list_presets", "preset_dir", "CHANNELS", "check_channels",
           "needed_n", "parse_set_value"]

_TOP_KEYS = ("cellgl_recipe", "name", "doc", "outputs", "variants") + GROUPS
_EXTRA = {"basis": ("density_image",), "combination": ("linear", "products"), "color": ("ramp", "cell_image")}


def _ramp(value, path: str) -> tuple:
    accepted = f"a list of 1..{MAX_RAMP_KEYS} keys [t, r, g, b], t ascending in [0, 1], r, g, b in [0, 1]"
    if not isinstance(value, (list, tuple)) or not 1 <= len(value) <= MAX_RAMP_KEYS:
        raise value_error(path, value, accepted, "expected a colour ramp, got")
    keys = []
    for k, key in enumerate(value):
        ok = isinstance(key, (list, tuple)) and len(key) == 4 and all(
            isinstance(c, numbers.Real) and not isinstance(c, bool) and math.isfinite(c) and 0.0 <= c <= 1.0
            for c in key)
        if not ok:
            raise value_error(f"{path}[{k}]", key, accepted, "bad ramp key")
        if keys and key[0] < keys[-1][0]:
            raise value_error(f"{path}[{k}]", key, accepted, "ramp positions must not decrease; key")
        keys.append(tuple(float(c) for c in key))
    return tuple(keys)


def _outputs(value, path: str) -> tuple:
    accepted = "a list of: " + ", ".join(CHANNELS)
    if isinstance(value, str):
        value = [value]
    if not isinstance(value, (list, tuple)) or not value:
        raise value_error(path, value, accepted, "expected a list of channels, got")
    for v in value:
        if v not in CHANNELS:
            raise value_error(path, v, accepted, "unknown channel")
    return tuple(value)


def _image(value, path: str, kind: str, base=None):
    """An image path checked readable (:func:`cellgl.texture.images.resolve`), absolute, or None."""
    from cellgl.texture import images

    try:
        return images.resolve(value, path, kind, base)
    except images.ImageError as exc:
        raise RecipeError(str(exc)) from None


def density_pixels(file: str, path: str = "basis.density_image"):
    """The density image ``file`` as float64 (h, w) in [0, 1] (grayscale, row 0 at the top: v = 0),
    read with Pillow and cached by path and modification time; :class:`RecipeError` if unreadable."""
    from cellgl.texture import images

    try:
        return images.density_pixels(file, path)
    except images.ImageError as exc:
        raise RecipeError(str(exc)) from None


def _defaults() -> dict:
    return {p.name: p.default for p in PARAMS}


class Recipe:
    """A validated texture recipe (treat as immutable: :meth:`replace` returns a new one).

    Attributes
    ----------
    name, doc : str
    values : mapping of parameter name -> value (every name in :data:`cellgl.texture.params.PARAMS`)
    ramp : tuple of (t, r, g, b) keys
    outputs : tuple of channel names (the default channels of a bake)
    variants : tuple of Recipe (preset variants; usually empty)
    density_image : str or None
        Absolute path of the grayscale image of ``density_map = "image"`` (JSON:
        ``basis.density_image``, relative to the recipe file); kept, unused, under other maps.
    cell_image : str or None
        Absolute path of the RGB image of ``cell_color = "image"`` (JSON: ``color.cell_image``).
    """

    __slots__ = ("name", "doc", "_values", "ramp", "outputs", "_variants", "density_image", "cell_image")

    def __init__(self, values: dict | None = None, ramp=DEFAULT_RAMP, name: str = "custom", doc: str = "",
                 outputs=("color",), variants=(), density_image=None, cell_image=None):
        vals = _defaults()
        for k, v in (values or {}).items():
            if k not in PARAMS_BY_NAME:
                raise RecipeError(f"{k}: unknown parameter{suggest(k, PARAMS_BY_NAME)}")
            vals[k] = coerce(PARAMS_BY_NAME[k], v, f"{PARAMS_BY_NAME[k].group}.{k}")
        self.name, self.doc = check_name_doc(name, doc)
        self._values = vals
        self.ramp = _ramp(ramp, "color.ramp")
        self.outputs = _outputs(outputs, "outputs")
        self._variants = tuple(variants)
        self.density_image = _image(density_image, "basis.density_image", "density")
        self.cell_image = _image(cell_image, "color.cell_image", "cell")
        _check(self)

    # ------------------------------------------------------------------ access
    @property
    def values(self):
        return MappingProxyType(self._values)

    @property
    def variants(self) -> tuple:
        return self._variants

    def get(self, name: str):
        """The value of parameter ``name`` (or ``"ramp"``, ``"linear"``, ``"products"``)."""
        if name == "ramp":
            return self.ramp
        if name == "density_image":
            return self.density_image
        if name == "cell_image":
            return self.cell_image
        if name == "linear":
            return [self._values[c] for c in LINEAR]
        if name == "products":
            return [[self._values[f"c{i}{j}"] for j in range(1, 5)] for i in range(1, 5)]
        if name not in self._values:
            raise RecipeError(f"{name}: unknown parameter{suggest(name, PARAMS_BY_NAME)}")
        return self._values[name]

    def __getitem__(self, name):
        return self.get(name)

    def replace(self, **values) -> "Recipe":
        """A copy with some parameters changed (also ``ramp=``, ``name=``, ``doc=``, ``outputs=``,
        ``linear=``, ``products=``, ``density_image=``, ``cell_image=``); validated like
        :meth:`from_dict`."""
        vals = dict(self._values)
        ramp, name, doc, outputs = self.ramp, self.name, self.doc, self.outputs
        image, cimage = self.density_image, self.cell_image
        for k, v in values.items():
            if k == "ramp":
                ramp = v
            elif k == "density_image":
                image = v
            elif k == "cell_image":
                cimage = v
            elif k == "name":
                name = v
            elif k == "doc":
                doc = v
            elif k == "outputs":
                outputs = v
            elif k in ("linear", "products"):
                vals.update(_coefficients(k, v, f"combination.{k}"))
            else:
                vals[k] = v
        return Recipe(vals, ramp, name, doc, outputs, density_image=image, cell_image=cimage)

    def cell_pixels(self):
        """The cell image as uint8 (h, w, 3) RGB (row 0: v = 0), or None."""
        if self.cell_image is None:
            return None
        from cellgl.texture.images import cell_pixels

        return cell_pixels(self.cell_image)

    def density_pixels(self):
        """The density image as float64 (h, w) in [0, 1] (row 0: v = 0), or None."""
        return None if self.density_image is None else density_pixels(self.density_image)

    def tileable(self) -> tuple["Recipe", list[str]]:
        """This recipe made seamless: ``tileable`` on, with the periods it needs made integers.

        A tileable texture repeats every ``frequency`` cells across and ``frequency * aspect``
        down, every octave ``lacunarity`` times more, and its noise every ``noise_frequency``
        times more; each is rounded to the nearest positive integer. Returns the new recipe and
        a note per value changed (e.g. ``"frequency 7.5 -> 8"``), for the user to see.
        """
        v = self._values
        notes: list[str] = []
        changes: dict = {"tileable": True}

        def whole(name, x):
            n = max(1, round(x))
            if abs(x - n) > 1e-6:
                notes.append(f"{name} {x:g} -> {n}")
            return n

        freq = whole("frequency", v["frequency"])
        aspect = max(1, round(freq * v["aspect"])) / freq      # rows of cells must be whole too
        if abs(aspect - v["aspect"]) > 1e-9:
            notes.append(f"aspect {v['aspect']:g} -> {aspect:g}")
        changes["frequency"] = float(freq)
        changes["aspect"] = aspect
        if v["fractal"] != "none":
            changes["lacunarity"] = float(whole("lacunarity", v["lacunarity"]))
        if v["c_noise"] != 0.0 or v["noise_color"] != 0.0:
            changes["noise_frequency"] = float(whole("noise_frequency", v["noise_frequency"]))
        changes.update(domain.tileable_changes(v, notes))
        return self.replace(**changes), notes

    def set_from_strings(self, items) -> "Recipe":
        """Apply ``["name=value", ...]`` (the CLI's ``--set``); returns a new recipe.

        Values are parsed by the parameter's type: numbers, ``true``/``false``, enum names,
        colours as ``r,g,b``; ``ramp``, ``linear`` and ``products`` take JSON lists.
        """
        changes = {}
        for item in items:
            if not isinstance(item, str) or "=" not in item:
                raise RecipeError(f"--set {item!r}: expected name=value")
            name, text = (s.strip() for s in item.split("=", 1))
            try:
                name = unqualified(name, item)
            except ValueError as exc:
                raise RecipeError(str(exc)) from None
            changes[name] = parse_set_value(name, text)
        try:
            return self.replace(**changes)
        except RecipeError as exc:
            raise RecipeError(f"--set {exc}") from None

    # ------------------------------------------------------------------ JSON
    def to_dict(self) -> dict:
        """The JSON form (every parameter written out)."""
        d: dict = {"cellgl_recipe": VERSION, "name": self.name, "doc": self.doc}
        for group in GROUPS:
            g: dict = {}
            if group == "combination":
                g["linear"] = self.get("linear")
                g["products"] = self.get("products")
            for p in PARAMS:
                if p.group != group or p.name in LINEAR or p.name in PRODUCTS:
                    continue
                v = self._values[p.name]
                g[p.name] = list(v) if isinstance(v, tuple) else v
            if group == "color":
                g["ramp"] = [list(k) for k in self.ramp]
                if self.cell_image is not None:
                    g["cell_image"] = self.cell_image
            if group == "basis" and self.density_image is not None:
                g["density_image"] = self.density_image
            d[group] = g
        d["outputs"] = list(self.outputs)
        return d

    @classmethod
    def from_dict(cls, d, *, where: str = "recipe", base=None) -> "Recipe":
        """Validate a JSON-like dict (see the module doc); raises :class:`RecipeError`.
        ``base``: the folder relative paths (``basis.density_image``) start from (default: the
        working directory; :meth:`load`: the recipe file's folder)."""
        if not isinstance(d, dict):
            raise RecipeError(f"{where}: expected a JSON object, got {type(d).__name__}")
        for k in d:
            if k not in _TOP_KEYS:
                raise RecipeError(f"{where}: unknown key {k!r}{suggest(str(k), _TOP_KEYS)}; "
                                  f"accepted: {', '.join(_TOP_KEYS)}")
        check_version(d.get("cellgl_recipe", VERSION))
        folder = base
        values, ramp, image, cimage = _read_groups(d, folder)
        for k in ("name", "doc"):
            if k in d and not isinstance(d[k], str):
                raise value_error(k, d[k], "a string", "expected a string, got")
        outputs = _outputs(d.get("outputs", ["color"]), "outputs")
        variants = d.get("variants", [])
        if not values and ramp is None and image is None and cimage is None and not variants:
            _refuse_empty(d, where, GROUPS)
        base = cls(values, ramp if ramp is not None else DEFAULT_RAMP, d.get("name", "custom"),
                   d.get("doc", ""), outputs, density_image=image, cell_image=cimage)
        if not isinstance(variants, list):
            raise value_error("variants", variants, "a list of partial recipes", "expected a list, got")
        out = []
        for k, v in enumerate(variants):
            if not isinstance(v, dict):
                raise value_error(f"variants[{k}]", v, "a partial recipe object", "expected an object, got")
            bad = [key for key in v if key not in ("name", "doc") + GROUPS]
            if bad:
                raise RecipeError(f"variants[{k}]: unknown key {bad[0]!r}; accepted: name, doc, "
                                  + ", ".join(GROUPS))
            try:
                vals, vramp, vimage, vcimage = _read_groups(v, folder)
                merged = dict(base._values)
                merged.update(vals)
                out.append(cls(merged, vramp if vramp is not None else base.ramp,
                               v.get("name", f"{base.name}:{k}"), v.get("doc", base.doc), base.outputs,
                               density_image=vimage if vimage is not None else base.density_image,
                               cell_image=vcimage if vcimage is not None else base.cell_image))
            except RecipeError as exc:
                raise RecipeError(f"variants[{k}].{exc}") from None
        base._variants = tuple(out)
        return base

    def to_json(self, base=None) -> str:
        """The JSON text (with the variants); ``base``: a folder, image paths under it are
        written relative to it (as :meth:`save` does for the file's folder)."""
        d = self.to_dict()
        if self._variants:
            d["variants"] = [_variant_dict(self, v) for v in self._variants]
        if base is not None:
            for group, key in (("basis", "density_image"), ("color", "cell_image")):
                for g in [d] + d.get("variants", []):
                    if key in g.get(group, {}):
                        g[group][key] = _relative(g[group][key], base)
        return json.dumps(d, indent=2) + "\n"

    @classmethod
    def load(cls, path) -> "Recipe":
        """Read a recipe JSON file."""
        path = Path(path)
        d = read_json(path)
        try:
            return cls.from_dict(d, base=path.resolve().parent)
        except RecipeError as exc:
            raise RecipeError(f"{path}: {exc}") from None

    def save(self, path) -> None:
        """Write the recipe as JSON, atomically (temp file + os.replace)."""
        from cellgl.io.formats import atomic_path

        with atomic_path(path) as tmp:
            tmp.write_text(self.to_json(base=Path(path).resolve().parent))

    def __eq__(self, other):
        return isinstance(other, Recipe) and self.to_dict() == other.to_dict()

    def __hash__(self):
        return hash(json.dumps(self.to_dict(), sort_keys=True))

    def __repr__(self):
        return f"Recipe(name={self.name!r})"


def _relative(file: str, base) -> str:
    """``file`` relative to the folder ``base`` when it lies under it (posix separators)."""
    try:
        return Path(file).resolve().relative_to(Path(base).resolve()).as_posix()
    except ValueError:
        return file


def _variant_dict(base: Recipe, v: Recipe) -> dict:
    """The partial dict of variant v: the groups' values that differ from base."""
    full, ref = v.to_dict(), base.to_dict()
    out = {"name": v.name, "doc": v.doc}
    for group in GROUPS:
        diff = {k: val for k, val in full[group].items() if ref[group].get(k) != val}
        if diff:
            out[group] = diff
    return out


def _coefficients(key: str, value, path: str) -> dict:
    out = {}
    if key == "linear":
        if not isinstance(value, (list, tuple)) or not 1 <= len(value) <= N_LINEAR:
            raise value_error(path, value, f"a list of 1..{N_LINEAR} numbers (weights of F1..F{N_LINEAR})",
                              "expected a list, got")
        for i, c in enumerate(value):
            out[LINEAR[i]] = coerce(PARAMS_BY_NAME[LINEAR[i]], c, f"{path}[{i}]")
        for name in LINEAR[len(value):]:
            out[name] = 0.0
        return out
    accepted = "a 4 x 4 list of numbers (weights of F_i F_j)"
    if not isinstance(value, (list, tuple)) or len(value) != 4:
        raise value_error(path, value, accepted, "expected 4 rows, got")
    for i, row in enumerate(value):
        if not isinstance(row, (list, tuple)) or len(row) != 4:
            raise value_error(f"{path}[{i}]", row, accepted, "expected 4 numbers, got")
        for j, c in enumerate(row):
            name = f"c{i + 1}{j + 1}"
            out[name] = coerce(PARAMS_BY_NAME[name], c, f"{path}[{i}][{j}]")
    return out


def _refuse_empty(d: dict, where: str, sections) -> None:
    """A recipe that sets no parameter is a mistake (a mistyped or truncated file), not a request
    for the defaults (those are ``Recipe()``): refuse it, naming what it holds."""
    held = f"it holds only {', '.join(repr(k) for k in d)}" if d else "it is empty"
    raise RecipeError(f"{where}: no parameter set ({held}); accepted: at least one "
                      f"value in one of the sections {', '.join(sections)} (`cellgl presets flagstone` "
                      "prints a whole recipe to start from)")


def _read_groups(d: dict, base=None):
    values: dict = {}
    ramp = image = cimage = None
    for group in GROUPS:
        if group not in d:
            continue
        g = d[group]
        if not isinstance(g, dict):
            raise value_error(group, g, "a JSON object", "expected an object, got")
        names = [p.name for p in PARAMS if p.group == group] + list(_EXTRA.get(group, ()))
        for k, v in g.items():
            path = f"{group}.{k}"
            if k in _EXTRA.get(group, ()):
                if k == "ramp":
                    ramp = _ramp(v, path)
                elif k == "density_image":
                    image = _image(v, path, "density", base)
                elif k == "cell_image":
                    cimage = _image(v, path, "cell", base)
                else:
                    coefs = _coefficients(k, v, path)
                    clash = [c for c in coefs if c in g]
                    if clash:
                        raise RecipeError(f"{path}: {clash[0]} is given twice (here and as {group}.{clash[0]})")
                    values.update(coefs)
                continue
            p = PARAMS_BY_NAME.get(k)
            if p is None or p.group != group:
                where = f" (it belongs in '{p.group}')" if p is not None else suggest(str(k), names)
                raise RecipeError(f"{path}: unknown key{where}; accepted in {group}: "
                                  + ", ".join(n for n in names if n not in PRODUCTS[1:] and n not in LINEAR[1:])
                                  .replace("c1,", "c1..c8,").replace("c11,", "c11..c44,"))
            values[k] = coerce(p, v, path)
    return values, ramp, image, cimage


def parse_set_value(name: str, text: str):
    """Parse a ``--set`` value for parameter ``name``."""
    if name in ("density_image", "cell_image"):
        return text
    if name in ("ramp", "linear", "products", "outputs"):
        try:
            return json.loads(text)
        except json.JSONDecodeError:
            if name == "outputs":
                return [s.strip() for s in text.split(",")]
            raise RecipeError(f"--set {name}={text}: expected a JSON list") from None
    p = PARAMS_BY_NAME.get(name)
    if p is None:
        raise RecipeError(f"--set {name}={text}: unknown parameter{suggest(name, PARAMS_BY_NAME)}; "
                          "see docs/textures.md or `cellgl presets --params`")
    return parse_value(p, name, text)


def _check(r: Recipe) -> None:
    """Constraints between fields."""
    v = r._values
    if v["min_points"] > v["max_points"]:
        raise RecipeError(f"basis.min_points: {v['min_points']} exceeds basis.max_points "
                          f"({v['max_points']}); accepted: min_points <= max_points")
    if v["distribution"] == "worley1996" and v["dimension"] != 3:
        raise RecipeError(f"basis.distribution: 'worley1996' needs basis.dimension 3, got "
                          f"{v['dimension']}; accepted: poisson, jitter for dimension 2 and 4")
    if v["distribution"] == "blender" and v["seed"] != 0:
        raise RecipeError(f"basis.seed: {v['seed']!r} with basis.distribution 'blender' (Blender's points "
                          "have no seed; move the texture with domain.offset_x/offset_y instead); "
                          "accepted: seed 0")
    if v["metric"] == "minkowski" and v["minkowski_p"] < minkowski_floor(v["dimension"]):
        raise RecipeError(minkowski_message("basis.minkowski_p", v["minkowski_p"], v["dimension"], "basis.dimension"))
    if why := sparse_message(v):           # min_points 0: the sample's own cell may be empty
        raise RecipeError(why)
    if v["smooth"] == "exp" and v["smoothness"] > 0.25:
        raise RecipeError(f"combination.smoothness: {v['smoothness']!r} exceeds 0.25 with combination.smooth "
                          "'exp' (its walk reaches F1 + 16 smoothness); accepted: [0, 0.25], or smooth "
                          "'polynomial' for up to 1")
    if not v["range_hi"] > v["range_lo"]:
        raise RecipeError(f"combination.range_hi: {v['range_hi']} must exceed combination.range_lo "
                          f"({v['range_lo']})")
    if not v["level_hi"] > v["level_lo"]:
        raise RecipeError(f"mapping.level_hi: {v['level_hi']} must exceed mapping.level_lo ({v['level_lo']})")
    if v["ramp_mode"] == "spline" and len(r.ramp) < 4:
        raise RecipeError(f"color.ramp: spline mode needs at least 4 keys, got {len(r.ramp)}; "
                          "accepted: 4..16 keys, or color.ramp_mode 'linear'")
    for term in ("c_edge", "c_nsphere"):
        if v[term] != 0.0 and v["metric"] != "euclidean":
            raise RecipeError(f"combination.{term}: {v[term]!r} needs basis.metric 'euclidean' (the distance "
                              f"to a bisector plane and the inscribed ball are Euclidean), got {v['metric']!r}; "
                              f"accepted: {term} 0 with other metrics")
    if v["cell_color"] == "image" and r.cell_image is None:
        raise RecipeError("color.cell_color: 'image' needs color.cell_image (the path of an RGB image, "
                          "relative to the recipe file)")
    dmap = v["density_map"]
    if dmap != "none":
        if v["distribution"] != "poisson":
            raise RecipeError(f"basis.density_map: {dmap!r} needs basis.distribution 'poisson' (a Poisson "
                              f"count per cell), got {v['distribution']!r}; accepted: density_map 'none' "
                              "with jitter or worley1996")
        if dmap == "image" and r.density_image is None:
            raise RecipeError("basis.density_map: 'image' needs basis.density_image (the path of a "
                              "grayscale image, relative to the recipe file)")
        if dmap.startswith("ramp") and v["density_start"] == v["density_end"]:
            raise RecipeError(f"basis.density_end: {v['density_end']!r} must differ from "
                              f"basis.density_start ({v['density_start']!r}) (the ramp runs between them)")
        if v["tileable"]:
            raise RecipeError(f"domain.tileable: not available with basis.density_map {dmap!r} (the map "
                              "does not repeat, so neither would the texture); accepted: tileable false, "
                              "or density_map 'none'")
    if v["tileable"]:
        if v["distribution"] == "worley1996":
            raise RecipeError("domain.tileable: not available with basis.distribution 'worley1996' "
                              "(its lattice is scaled); accepted: poisson, jitter")

        def integral(path, x):
            if abs(x - round(x)) > 1e-6 or round(x) < 1:
                raise RecipeError(f"{path}: {x!r} must be a positive integer when domain.tileable is true "
                                  "(the texture repeats every that many cells)")
        integral("domain.frequency", v["frequency"])
        integral("domain.frequency * domain.aspect", v["frequency"] * v["aspect"])
        if v["fractal"] != "none":
            integral("fractal.lacunarity", v["lacunarity"])
        if v["c_noise"] != 0.0 or v["noise_color"] != 0.0:
            integral("noise.noise_frequency", v["noise_frequency"])
    domain.check(v)


# ---------------------------------------------------------------------- presets

def preset_dir() -> Path:
    """The folder holding the preset JSON files (package data ``cellgl/presets``)."""
    return Path(__file__).resolve().parent.parent / "presets"


def list_presets() -> list[tuple[str, str]]:
    """``[(name, one-line doc), ...]`` of the cellular presets (``cellgl/presets/*.json``), sorted
    by name (:func:`cellgl.recipes.list_presets` adds the PUPs presets)."""
    out = []
    for path in sorted(preset_dir().glob("*.json")):
        try:
            doc = json.loads(path.read_text()).get("doc", "")
        except (OSError, json.JSONDecodeError):
            doc = "(unreadable)"
        out.append((path.stem, doc))
    return out


def load_recipe(preset_or_path, known=None):
    """A cellular recipe: a :class:`Recipe`, a preset by name (``"veins"``,
    ``"worley-gallery:3"`` for a variant) or a recipe JSON file.

    Any recipe kind (PUPs too) loads through :func:`cellgl.recipes.load_recipe`, which passes the
    names of every preset through ``known`` (a function returning them, called only for the
    error: listing reads every file). Raises :class:`RecipeError` naming them if neither matches.
    """
    if isinstance(preset_or_path, Recipe):
        return preset_or_path
    text = str(preset_or_path)
    path = Path(text)
    if is_path(text):
        return Recipe.load(path)
    name, _, variant = text.partition(":")
    file = preset_dir() / f"{name}.json"
    if not _is_file(file):
        names = known() if known is not None else [n for n, _ in list_presets()]
        shown = repr(text) if len(text) <= 80 else f"{text[:60]!r}... ({len(text)} characters)"
        raise RecipeError(f"unknown preset {shown}{suggest(name, names)}; accepted: a recipe .json "
                          "file or one of: " + ", ".join(names))
    recipe = Recipe.load(file)
    if not variant:
        return recipe
    vs = recipe.variants
    for k, v in enumerate(vs):
        if variant == str(k) or variant == v.name or f"{name}:{variant}" == v.name:
            return v
    raise RecipeError(f"preset {name!r} has no variant {variant!r}; " + (f"accepted: 0..{len(vs) - 1} or " + ", ".join(
        v.name for v in vs) if vs else f"it has no variants; accepted: {name!r} alone (`cellgl presets --variants`)"))


def is_path(text: str) -> bool:
    """Whether a recipe argument names a file (``.json``, a path separator, or an existing file)
    rather than a preset."""
    return Path(text).suffix == ".json" or os.sep in text or _is_file(Path(text))


def _is_file(path: Path) -> bool:
    try:
        return path.is_file()
    except OSError:  # a name too long for the filesystem, ...: not a file we can read
        return False


def needed_n(recipe: Recipe) -> int:
    """The largest n with F_n in the combination (1 if none)."""
    v = recipe.values
    n = 1
    for i, name in enumerate(LINEAR, 1):
        if v[name] != 0.0:
            n = max(n, i)
    for i in range(1, 5):
        for j in range(1, 5):
            if v[f"c{i}{j}"] != 0.0:
                n = max(n, i, j)
    return n
