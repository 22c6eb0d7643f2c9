"""A cellular recipe on disk and on the command line: the JSON form (:func:`to_dict`,
:func:`from_dict`, :func:`to_json`, :func:`load`, :func:`save`) and the ``--set name=value``
text (:func:`set_changes`, :func:`parse_set_value`).

On disk a recipe is JSON, one section per parameter group::

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
range raises :class:`~cellgl.texture.schema.RecipeError` naming the field path, the bad value and what is accepted.

A preset file may also hold ``"variants"``: a list of partial recipes (each with a ``name``)
applied over the base; ``load_recipe("worley-gallery:7")`` (:mod:`cellgl.texture.presets`) picks one.

Each value goes through :func:`cellgl.texture.schema.coerce`, the structured fields through
:mod:`cellgl.texture.fields`.

The functions take the recipe class (``cls``) or a recipe rather than importing
:class:`~cellgl.texture.recipe.Recipe`, whose methods (``Recipe.load``, ``recipe.save``, ...) call
them: the model sits above its persistence.
"""
from __future__ import annotations

import json
from pathlib import Path

from cellgl.texture.fields import check_image, check_outputs, check_ramp, coefficients
from cellgl.texture.params import DEFAULT_RAMP, GROUPS, LINEAR, PARAMS, PARAMS_BY_NAME, PRODUCTS, unqualified
from cellgl.texture.schema import VERSION, RecipeError, check_version, coerce, parse_value, read_json, suggest, value_error

__all__ = ["TOP_KEYS", "to_dict", "from_dict", "to_json", "load", "save", "set_changes", "parse_set_value"]

#: the keys of a recipe file's top level
TOP_KEYS = ("cellgl_recipe", "name", "doc", "outputs", "variants") + GROUPS
#: the keys of a section beyond its parameters
EXTRA = {"basis": ("density_image",), "combination": ("linear", "products"), "color": ("ramp", "cell_image")}


def to_dict(recipe) -> dict:
    """The JSON form of ``recipe`` (every parameter written out; no variants)."""
    d: dict = {"cellgl_recipe": VERSION, "name": recipe.name, "doc": recipe.doc}
    for group in GROUPS:
        g: dict = {}
        if group == "combination":
            g["linear"] = recipe.get("linear")
            g["products"] = recipe.get("products")
        for p in PARAMS:
            if p.group != group or p.name in LINEAR or p.name in PRODUCTS:
                continue
            v = recipe.values[p.name]
            g[p.name] = list(v) if isinstance(v, tuple) else v
        if group == "color":
            g["ramp"] = [list(k) for k in recipe.ramp]
            if recipe.cell_image is not None:
                g["cell_image"] = recipe.cell_image
        if group == "basis" and recipe.density_image is not None:
            g["density_image"] = recipe.density_image
        d[group] = g
    d["outputs"] = list(recipe.outputs)
    return d


def from_dict(cls, d, *, where: str = "recipe", base=None):
    """A ``cls`` (:class:`~cellgl.texture.recipe.Recipe`) from a JSON-like dict (the format: the module doc);
    raises :class:`RecipeError`.
    ``base``: the folder relative paths (``basis.density_image``) start from (default: the
    working directory; :func:`load`: the recipe file's folder)."""
    if not isinstance(d, dict):
        raise RecipeError(f"{where}: expected a JSON object, got {type(d).__name__}")
    for k in d:
        if k not in TOP_KEYS:
            raise RecipeError(f"{where}: unknown key {k!r}{suggest(str(k), TOP_KEYS)}; "
                              f"accepted: {', '.join(TOP_KEYS)}")
    check_version(d.get("cellgl_recipe", VERSION))
    folder = base
    values, ramp, image, cimage = _read_groups(d, folder)
    for k in ("name", "doc"):
        if k in d and not isinstance(d[k], str):
            raise value_error(k, d[k], "a string", "expected a string, got")
    outputs = check_outputs(d.get("outputs", ["color"]), "outputs")
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
            merged = dict(base.values)
            merged.update(vals)
            out.append(cls(merged, vramp if vramp is not None else base.ramp,
                           v.get("name", f"{base.name}:{k}"), v.get("doc", base.doc), base.outputs,
                           density_image=vimage if vimage is not None else base.density_image,
                           cell_image=vcimage if vcimage is not None else base.cell_image))
        except RecipeError as exc:
            raise RecipeError(f"variants[{k}].{exc}") from None
    return base.with_variants(out)


def to_json(recipe, base=None) -> str:
    """The JSON text of ``recipe`` (with its variants); ``base``: a folder, image paths under it are
    written relative to it (as :func:`save` does for the file's folder)."""
    d = to_dict(recipe)
    if recipe.variants:
        d["variants"] = [_variant_dict(recipe, v) for v in recipe.variants]
    if base is not None:
        for group, key in (("basis", "density_image"), ("color", "cell_image")):
            for g in [d] + d.get("variants", []):
                if key in g.get(group, {}):
                    g[group][key] = _relative(g[group][key], base)
    return json.dumps(d, indent=2) + "\n"


def load(cls, path):
    """Read a recipe JSON file as a ``cls`` (:class:`~cellgl.texture.recipe.Recipe`)."""
    path = Path(path)
    d = read_json(path)
    try:
        return from_dict(cls, d, base=path.resolve().parent)
    except RecipeError as exc:
        raise RecipeError(f"{path}: {exc}") from None


def save(recipe, path) -> None:
    """Write ``recipe`` as JSON, atomically (temp file + os.replace)."""
    from cellgl.io.formats import atomic_path

    with atomic_path(path) as tmp:
        tmp.write_text(to_json(recipe, base=Path(path).resolve().parent))


def _relative(file: str, base) -> str:
    """``file`` relative to the folder ``base`` when it lies under it (posix separators)."""
    try:
        return Path(file).resolve().relative_to(Path(base).resolve()).as_posix()
    except ValueError:
        return file


def _variant_dict(base, v) -> dict:
    """The partial dict of variant v: the groups' values that differ from base."""
    full, ref = to_dict(v), to_dict(base)
    out = {"name": v.name, "doc": v.doc}
    for group in GROUPS:
        diff = {k: val for k, val in full[group].items() if ref[group].get(k) != val}
        if diff:
            out[group] = diff
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
        names = [p.name for p in PARAMS if p.group == group] + list(EXTRA.get(group, ()))
        for k, v in g.items():
            path = f"{group}.{k}"
            if k in EXTRA.get(group, ()):
                if k == "ramp":
                    ramp = check_ramp(v, path)
                elif k == "density_image":
                    image = check_image(v, path, "density", base)
                elif k == "cell_image":
                    cimage = check_image(v, path, "cell", base)
                else:
                    coefs = coefficients(k, v, path)
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


def set_changes(items) -> dict:
    """The changes ``["name=value", ...]`` (the CLI's ``--set``) ask for: ``{name: value}``, each
    value parsed by :func:`parse_set_value` (checked when a recipe takes it: ``Recipe.replace``).

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
    return changes


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
