"""``cellgl presets``: list the presets of every recipe kind, print one recipe as JSON, or list the
recipe parameters (docs/textures.md). The kinds come through :mod:`cellgl.recipes`."""
from __future__ import annotations

__all__ = ["add_parser", "run_cli"]


def add_parser(sub):
    """Declare ``cellgl presets [NAME] [--params] [--variants]``."""
    p = sub.add_parser("presets", help="list the texture presets (or show one recipe as JSON)")
    p.add_argument("name", nargs="?", help="show this preset's recipe JSON (NAME or NAME:VARIANT)")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="with NAME: change a parameter before printing (repeatable)")
    p.add_argument("--variants", action="store_true", help="also list each preset's variants")
    p.add_argument("--params", action="store_true", help="list the recipe parameters (name, type, range, doc)")
    return p


def run_cli(args) -> int:
    """Run ``cellgl presets``."""
    from cellgl.recipes import RecipeError, list_presets, load_recipe, parameter_tables

    if args.set and (args.params or not args.name):
        raise RecipeError(f"--set {args.set[0]}: changes the recipe printed for a preset; accepted "
                          "only with NAME (cellgl presets NAME --set ...), not with a listing")
    if args.params:
        tables = parameter_tables()
        for prm in tables["cellular"]:
            print(f"{prm.name:18s} {prm.type:5s} {str(prm.default):10s} {prm.range_text():28s} {prm.doc}")
        print("\nPUPs recipes (pups-* presets; which patterns use each: docs/pups.md):")
        for prm in tables["pups"]:
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
