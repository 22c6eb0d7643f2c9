"""Any recipe, whatever its kind: load, list, render, evaluate (the public entry points).

Two kinds of recipe exist: cellular textures (:class:`cellgl.texture.recipe.Recipe`, rendered
by :mod:`cellgl.texture.evaluation`) and PUPs syntheses (:class:`cellgl.pups.recipe.PupsRecipe`,
rendered by :func:`cellgl.pups.recipe.render`). This module sits above both and picks one;
``cellgl.load_recipe``, ``cellgl.list_presets``, ``cellgl.render`` and ``cellgl.evaluate`` are
its functions, and the front ends (bake, export, viewer, CLI) use it.
"""
from __future__ import annotations

from pathlib import Path

from cellgl.pups import recipe as pups_recipe
from cellgl.pups.recipe import PupsRecipe
from cellgl.texture import recipe as cellular
from cellgl.texture import evaluation as cellular_render
from cellgl.texture.params import PARAMS
from cellgl.texture.recipe import Recipe
from cellgl.texture.schema import RecipeError, read_json

__all__ = ["load_recipe", "list_presets", "render", "evaluate", "is_pups", "is_path", "parameters",
           "max_side", "MAX_SIDE", "KINDS"]

#: the recipe kinds: cellular textures and PUPs syntheses
KINDS = ("cellular", "pups")

is_pups = pups_recipe.is_pups
#: whether a recipe argument names a file rather than a preset (any kind)
is_path = cellular.is_path
#: the largest image side :func:`render` takes, any kind (a cellular recipe's: 2^20; PUPs: 2^16)
MAX_SIDE = max(cellular_render.MAX_SIDE, pups_recipe.MAX_SIDE)


def list_presets(kind: str | None = None) -> list[tuple[str, str]]:
    """``[(name, one-line doc), ...]`` of every preset, sorted by name: the cellular recipes
    (``cellgl/presets/*.json``) and the PUPs presets (``pups-*``, :mod:`cellgl.pups.recipe`);
    ``kind="cellular"`` or ``"pups"``: those of one kind only."""
    if kind is not None and kind not in KINDS:
        raise ValueError(f"kind {kind!r}: unknown recipe kind; accepted: None (every kind), "
                         + ", ".join(KINDS))
    out = [] if kind == "pups" else cellular.list_presets()
    return sorted(out + ([] if kind == "cellular" else pups_recipe.pups_preset_names()))


def parameters(recipe) -> tuple:
    """The parameter table entries a recipe has (what a panel shows): every entry of
    :data:`cellgl.texture.params.PARAMS` for a cellular recipe, the entries of
    :data:`cellgl.pups.recipe.PUPS_PARAMS` its pattern uses for a PUPs one."""
    recipe = load_recipe(recipe)
    if is_pups(recipe):
        used = set(recipe.names())
        return tuple(p for p in pups_recipe.PUPS_PARAMS if p.name in used)
    return PARAMS


def max_side(recipe) -> int:
    """The largest image side :func:`render` takes for this recipe (its kind's limit)."""
    return pups_recipe.MAX_SIDE if is_pups(load_recipe(recipe)) else cellular_render.MAX_SIDE


def load_recipe(preset_or_path):
    """A preset by name (``"veins"``, ``"worley-gallery:3"`` for a variant, ``"pups-cow"``) or a
    recipe JSON file.

    Returns a :class:`~cellgl.texture.recipe.Recipe`, or a
    :class:`~cellgl.pups.recipe.PupsRecipe` for a PUPs preset or a JSON file with
    ``"kind": "pups"``. Raises :class:`~cellgl.texture.recipe.RecipeError` naming the known
    presets if neither matches.
    """
    if isinstance(preset_or_path, (Recipe, PupsRecipe)):
        return preset_or_path
    text = str(preset_or_path)
    if cellular.is_path(text):
        path = Path(text)
        return PupsRecipe.load(path) if _json_kind(path) == "pups" else Recipe.load(path)
    pups = pups_recipe.load_pups_preset(text)
    if pups is not None:
        return pups
    return cellular.load_recipe(text, known=[n for n, _ in list_presets()])


def _json_kind(path: Path):
    """The ``kind`` key of a recipe file (None: a cellular recipe, or unreadable: let
    :meth:`Recipe.load` report it)."""
    try:
        d = read_json(path)
    except RecipeError:
        return None
    return d.get("kind") if isinstance(d, dict) else None


def render(recipe, width: int, height: int, *, channels=("color",), x0: int = 0, y0: int = 0,
           tile_w: int | None = None, tile_h: int | None = None, depth: int | None = None,
           backend: str = "gpu", samples: int = 1) -> dict:
    """Render the sub-rectangle ``[x0, x0 + tile_w) x [y0, y0 + tile_h)`` of the full
    ``width x height`` image of any recipe (tiles are bit-identical to a one-pass render):
    :func:`cellgl.texture.evaluation.render` for a cellular recipe, :func:`cellgl.pups.recipe.render`
    for a PUPs one.

    Returns
    -------
    dict channel -> ndarray: ``color`` (H, W, 4) float32 in [0, 1]; ``height`` (H, W)
    float32; ``normal`` (H, W, 3) float32 in [0, 1] (green per ``normal_convention``);
    ``id`` (H, W) uint32; ``F1``..``F4`` (H, W) float32. Row 0 is the top of the image. With
    ``depth=D`` (3D/4D recipes) every array gains a leading axis of D slices along z. PUPs
    recipes give ``color`` and ``height``.
    """
    recipe = load_recipe(recipe)
    kw = dict(channels=channels, x0=x0, y0=y0, tile_w=tile_w, tile_h=tile_h, depth=depth, backend=backend)
    if is_pups(recipe):
        if samples != 1:
            raise ValueError(f"samples={samples!r}: supersampling is for cellular texture recipes; "
                             f"{recipe.name} is a PUPs recipe (accepted: 1)")
        return pups_recipe.render(recipe, width, height, **kw)
    return cellular_render.render(recipe, width, height, samples=samples, **kw)


def evaluate(recipe, points, outputs=("color",), backend: str = "gpu", *, filter_width=0.0) -> dict:
    """Evaluate a cellular recipe at arbitrary texture-space points: see
    :func:`cellgl.texture.evaluation.evaluate` for the arguments and outputs (PUPs recipes render
    images only: :func:`render`)."""
    recipe = load_recipe(recipe)
    if is_pups(recipe):
        raise ValueError(f"evaluate() at arbitrary points is not available for PUPs recipes "
                         f"({recipe.name}); use render() (channels: color, height)")
    return cellular_render.evaluate(recipe, points, outputs, backend, filter_width=filter_width)


# ---------------------------------------------------------------------- CLI: cellgl presets

def add_presets_parser(sub):
    """Declare ``cellgl presets [NAME] [--params] [--variants]``."""
    p = sub.add_parser("presets", help="list the texture presets (or show one recipe as JSON)")
    p.add_argument("name", nargs="?", help="show this preset's recipe JSON (NAME or NAME:VARIANT)")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="with NAME: change a parameter before printing (repeatable)")
    p.add_argument("--variants", action="store_true", help="also list each preset's variants")
    p.add_argument("--params", action="store_true", help="list the recipe parameters (name, type, range, doc)")
    return p


def run_presets_cli(args) -> int:
    """Run ``cellgl presets``."""
    if args.set and (args.params or not args.name):
        raise RecipeError(f"--set {args.set[0]}: changes the recipe printed for a preset; accepted "
                          "only with NAME (cellgl presets NAME --set ...), not with a listing")
    if args.params:
        for prm in PARAMS:
            print(f"{prm.name:18s} {prm.type:5s} {str(prm.default):10s} {prm.range_text():28s} {prm.doc}")
        print("\nPUPs recipes (pups-* presets; which patterns use each: docs/pups.md):")
        for prm in pups_recipe.PUPS_PARAMS:
            print(f"{prm.name:18s} {prm.type:5s} {str(prm.default):10s} {prm.range_text():28s} {prm.doc}")
        return 0
    if args.name:
        recipe = load_recipe(args.name).set_from_strings(args.set)
        print(recipe.to_json(), end="")
        return 0
    presets = list_presets()
    width = max((len(n) for n, _ in presets), default=0)
    for name, doc in presets:
        print(f"{name:{width}s}  {doc}")
        if args.variants:
            for k, v in enumerate(load_recipe(name).variants):
                print(f"{'':{width}s}    {name}:{k}  {v.doc}")
    return 0
