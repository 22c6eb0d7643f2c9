"""The preset recipes: the folder of their JSON files (package data ``cellgl/presets``), listing
them, and loading a recipe by preset name, variant or file (:func:`load_recipe`).

Any recipe kind (PUPs too) loads and lists through :mod:`cellgl.recipes`; this module is the
cellular kind's own.
"""
from __future__ import annotations

import json
import os
from pathlib import Path

from cellgl.texture.recipe import Recipe
from cellgl.texture.schema import RecipeError, suggest

__all__ = ["preset_dir", "list_presets", "load_recipe", "is_path"]


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
