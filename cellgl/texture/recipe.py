"""Texture recipes: one description of a cellular texture, validated (the model).

A :class:`Recipe` holds a value for every parameter of the table in :mod:`cellgl.texture.params`
(basis, combination, fractal, domain, noise, mapping, colour), the colour ramp, the output
channels, the images it refers to, and a name and one-line doc; preset files add variants. Making
one checks every value (:func:`cellgl.texture.schema.coerce`), every structured field and the
constraints between fields (:mod:`cellgl.texture.fields`), so a recipe that exists is valid;
:class:`RecipeError` names the field path, the bad value and what is accepted.

The rooms around it: its JSON form and the ``--set`` text are :mod:`cellgl.texture.recipe_json`
(``Recipe.load``, ``recipe.save``, ``Recipe.from_dict`` call it), the preset folder and
:func:`~cellgl.texture.presets.load_recipe` are :mod:`cellgl.texture.presets`.
"""
from __future__ import annotations

import copy
import json
from types import MappingProxyType

from cellgl.texture import domain, recipe_json
from cellgl.texture.fields import check_fields, check_image, check_outputs, check_ramp, coefficients, density_pixels
from cellgl.texture.params import DEFAULT_RAMP, LINEAR, PARAMS, PARAMS_BY_NAME
from cellgl.texture.schema import CHANNELS, RecipeError, check_channels, check_name_doc, coerce, suggest

__all__ = ["Recipe", "RecipeError", "CHANNELS", "check_channels", "needed_n"]


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
        vals = {p.name: p.default for p in PARAMS}
        for k, v in (values or {}).items():
            if k not in PARAMS_BY_NAME:
                raise RecipeError(f"{k}: unknown parameter{suggest(k, PARAMS_BY_NAME)}")
            vals[k] = coerce(PARAMS_BY_NAME[k], v, f"{PARAMS_BY_NAME[k].group}.{k}")
        self.name, self.doc = check_name_doc(name, doc)
        self._values = vals
        self.ramp = check_ramp(ramp, "color.ramp")
        self.outputs = check_outputs(outputs, "outputs")
        self._variants = tuple(variants)
        self.density_image = check_image(density_image, "basis.density_image", "density")
        self.cell_image = check_image(cell_image, "color.cell_image", "cell")
        check_fields(vals, self.ramp, self.cell_image, self.density_image)

    # ------------------------------------------------------------------ access
    @property
    def values(self):
        return MappingProxyType(self._values)

    @property
    def variants(self) -> tuple:
        return self._variants

    def with_variants(self, variants) -> Recipe:
        """A copy of this recipe holding ``variants`` (recipes) as its preset variants."""
        out = copy.copy(self)
        out._variants = tuple(variants)
        return out

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

    def replace(self, **values) -> Recipe:
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
                vals.update(coefficients(k, v, f"combination.{k}"))
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

    def tileable(self) -> tuple[Recipe, list[str]]:
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

    def set_from_strings(self, items) -> Recipe:
        """Apply ``["name=value", ...]`` (the CLI's ``--set``); returns a new recipe.

        Values are parsed by the parameter's type: numbers, ``true``/``false``, enum names,
        colours as ``r,g,b``; ``ramp``, ``linear`` and ``products`` take JSON lists
        (:func:`cellgl.texture.recipe_json.set_changes`).
        """
        changes = recipe_json.set_changes(items)
        try:
            return self.replace(**changes)
        except RecipeError as exc:
            raise RecipeError(f"--set {exc}") from None

    # ------------------------------------------------------------------ JSON (cellgl.texture.recipe_json)
    def to_dict(self) -> dict:
        """The JSON form (every parameter written out)."""
        return recipe_json.to_dict(self)

    @classmethod
    def from_dict(cls, d, *, where: str = "recipe", base=None) -> Recipe:
        """Validate a JSON-like dict (the format: :mod:`cellgl.texture.recipe_json`); raises
        :class:`RecipeError`. ``base``: the folder relative paths (``basis.density_image``) start
        from (default: the working directory; :meth:`load`: the recipe file's folder)."""
        return recipe_json.from_dict(cls, d, where=where, base=base)

    def to_json(self, base=None) -> str:
        """The JSON text (with the variants); ``base``: a folder, image paths under it are
        written relative to it (as :meth:`save` does for the file's folder)."""
        return recipe_json.to_json(self, base)

    @classmethod
    def load(cls, path) -> Recipe:
        """Read a recipe JSON file."""
        return recipe_json.load(cls, path)

    def save(self, path) -> None:
        """Write the recipe as JSON, atomically (temp file + os.replace)."""
        recipe_json.save(self, path)

    def __eq__(self, other):
        return isinstance(other, Recipe) and self.to_dict() == other.to_dict()

    def __hash__(self):
        return hash(json.dumps(self.to_dict(), sort_keys=True))

    def __repr__(self):
        return f"Recipe(name={self.name!r})"


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
