"""``cellgl export``: the command line of :mod:`cellgl.export.snippets` (recipes) and
:mod:`cellgl.export.basis` (``--basis``)."""
from __future__ import annotations

from cellgl.export.basis import BASES, BASIS_REFUSED, DEFAULTS, basis_export
from cellgl.export.snippets import TARGETS, ExportError, check_target, export, recipe_command

__all__ = ["add_parser", "run_cli"]


# --------------------------------------------------------------------------------------------
# command line: cellgl export PRESET_OR_RECIPE --target TARGET [-o FILE]
# --------------------------------------------------------------------------------------------


def add_parser(sub):
    """Declare ``cellgl export`` on the CLI's subparsers."""
    from cellgl.basis.enums import Distribution, Metric

    names = ", ".join(TARGETS)
    p = sub.add_parser(
        "export", help=f"write a self-contained shader snippet of a recipe ({names})",
        description="Export a recipe as a shader snippet whose cellgl_texture(uv) returns the "
        "pixels `cellgl bake` writes, for one of: " + "; ".join(
            f"{t.name}: {t.title}" for t in TARGETS.values()) + ". See docs/engines.md.")
    p.add_argument("recipe", metavar="PRESET_OR_RECIPE", nargs="?", default=None,
                   help="a preset name or a recipe JSON file (not with --basis)")
    b = p.add_argument_group("basis-only snippets (one function of the cellular basis, no texture)")
    b.add_argument("--basis", default=None, metavar="NAME",
                   help=", ".join(BASES) + ": e.g. --basis f1f2 --dim 3 gives "
                   "vec2 cellgl_f1f2(vec3 p), the values of cellgl.cellular")
    b.add_argument("--dim", type=int, default=2,
                   help="2, 3 or 4: the point type (default %(default)s)")
    dists = [d.name.lower() for d in Distribution if d not in BASIS_REFUSED]
    for name, typ, what in (
            ("metric", str, ", ".join(m.name.lower() for m in Metric)), ("distribution", str, ", ".join(dists)),
            ("density", float, "mean points per cell, poisson"),
            ("jitter", float, "spread of the points in [0, 1], jitter and blender"), ("seed", int, ""),
            ("min_points", int, "poisson"), ("max_points", int, "poisson"),
            ("minkowski_p", float, "exponent of the minkowski metric")):
        b.add_argument("--" + name.replace("_", "-"), type=typ, default=DEFAULTS[name],
                       metavar={"metric": "METRIC", "distribution": "NAME"}.get(name),
                       help=f"{what} (default %(default)s)".lstrip())
    p.add_argument("--target", "-t", default="glsl", metavar="TARGET",
                   help="one of: " + names + " (default glsl); or materialx: a MaterialX node library, "
                   "example materials and a USD stage, written to the directory -o DIR (every "
                   "exportable preset, or the one given; docs/materialx.md)")
    p.add_argument("-o", "--output", metavar="FILE", default=None,
                   help="write to FILE (atomically) instead of standard output (materialx: a directory)")
    p.add_argument("--bake-maps", dest="bake_maps", default=None, metavar="SIZE",
                   help="materialx: also bake the maps the M_<preset>_baked materials read (SIZE x SIZE "
                   "PNG, colour and normal) into DIR/textures/")
    p.add_argument("--udim", default=None, metavar="RANGE",
                   help="materialx: the baked materials read a UDIM set, <UDIM> in the maps' names "
                   "(e.g. 1001-1004, as cellgl bake --udim); with --bake-maps, a tile per number")
    p.add_argument("--uniforms", action="store_true",
                   help="declare the recipe's run-time values as cellgl_<name> uniforms instead of "
                   "constants")
    p.add_argument("--no-fold", dest="fold", action="store_false",
                   help="keep the recipe's values as named const declarations (to edit by hand) "
                   "instead of folding them into the code")
    p.add_argument("--set", dest="sets", action="append", default=[], metavar="NAME=VALUE",
                   help="override a recipe parameter (repeatable)")
    return p


def run_cli(args) -> int:
    """Run ``cellgl export``; returns the exit status."""
    import os
    import sys

    from cellgl.io.tempfiles import check_output

    if str(args.target).strip().lower() == "materialx":
        return _run_materialx(args)
    check_target(args.target)
    if getattr(args, "bake_maps", None) is not None or getattr(args, "udim", None) is not None:
        raise ExportError("--bake-maps and --udim are options of --target materialx (its baked materials)")
    if args.basis is None and args.recipe is None:
        raise ExportError("nothing to export: give a preset name (`cellgl presets` lists them), a "
                          "recipe .json file, or --basis NAME (one of: " + ", ".join(BASES) + ")")
    if args.basis is not None and args.recipe is not None:
        raise ExportError(f"give either {args.recipe!r} or --basis {args.basis}, not both")
    if args.basis is not None and (args.uniforms or args.sets):
        raise ExportError("--uniforms and --set apply to recipes, not to --basis snippets")
    if args.output is not None:  # before the work: a missing or read-only directory, a long name
        check_output(args.output)       # as given: -o '' is an empty name, not the current folder
        check_output(os.path.abspath(args.output))
    if args.basis is not None:
        text = basis_export(args.basis, args.dim, args.target, **{k: getattr(args, k) for k in DEFAULTS})
    else:
        from cellgl.recipes import load_recipe

        recipe = load_recipe(args.recipe)
        recipe = recipe.set_from_strings(list(args.sets)) if args.sets else recipe
        text = export(recipe, args.target, uniforms=args.uniforms, fold=args.fold,
                      command=recipe_command(args.recipe, args.sets, fold=args.fold))
    if args.output is None:
        sys.stdout.write(text)
        return 0
    from cellgl.io.formats import atomic_path

    with atomic_path(os.path.abspath(args.output)) as tmp:
        tmp.write_text(text, encoding="utf-8", newline="\n")
    return 0


def _run_materialx(args) -> int:
    """``cellgl export [PRESET_OR_RECIPE] --target materialx -o DIR``."""
    from cellgl.export.materialx_docs import export_materialx

    if args.output is None:
        raise ExportError("--target materialx writes a directory of files: give it with -o DIR")
    if args.basis is not None or args.uniforms or not args.fold:
        raise ExportError("--target materialx takes a preset or recipe (or none: every exportable preset), "
                          "not --basis, --uniforms or --no-fold (the basis nodes are always in the library)")
    recipes = None
    if args.recipe is not None:
        from cellgl.recipes import load_recipe
        from cellgl.texture.recipe import RecipeError

        try:
            recipe = load_recipe(args.recipe)
            recipes = [recipe.set_from_strings(list(args.sets)) if args.sets else recipe]
        except (RecipeError, OSError) as exc:
            raise ExportError(str(exc)) from None
    elif args.sets:
        raise ExportError("--set needs a preset or recipe to set it on")
    for path in export_materialx(args.output, recipes, bake_maps=args.bake_maps, udim=args.udim):
        print(path)
    return 0
