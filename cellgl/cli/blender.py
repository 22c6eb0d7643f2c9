"""``cellgl blender`` (a ``.blend`` scene rendering a recipe's OSL export in Cycles; docs/engines.md)
and ``cellgl blender-extension`` (the Blender extension zip; docs/blender.md). Blender loads only
when a command runs (:mod:`cellgl.blender`)."""
from __future__ import annotations

__all__ = ["add_parser", "run_cli", "add_extension_parser", "run_extension_cli"]


def add_parser(sub):
    """Declare ``cellgl blender`` on the CLI's subparsers."""
    p = sub.add_parser(
        "blender", help="write a Blender scene (.blend) rendering a recipe's OSL export in Cycles",
        description="Write a .blend whose render (as is, N x N) is the image `cellgl bake RECIPE "
        "--size N` writes: a plane with the OSL export in a Script node, an orthographic camera. "
        "Needs the [blender] extra (bpy 4.5). See docs/engines.md.")
    p.add_argument("recipe", metavar="PRESET_OR_RECIPE", help="a preset name or a recipe JSON file")
    p.add_argument("-o", "--output", metavar="FILE.blend", required=True, help="the .blend to write")
    p.add_argument("--size", type=int, default=None, metavar="N",
                   help="render resolution N x N (default: the bake's default, 512)")
    p.add_argument("--set", dest="sets", action="append", default=[], metavar="NAME=VALUE",
                   help="override a recipe parameter (repeatable)")
    return p


def run_cli(args) -> int:
    """Run ``cellgl blender``; returns the exit status."""
    from cellgl.blender.runtime import BlenderMissing
    from cellgl.blender.scene import osl_text, write_blend
    from cellgl.recipes import load_recipe

    r = load_recipe(args.recipe)
    if args.sets:
        r = r.set_from_strings(list(args.sets))
    osl_text(r)                    # refusals (PUPs, image-driven recipes) before Blender loads
    try:
        write_blend(r, args.output, size=args.size)
    except BlenderMissing as exc:
        raise ValueError(str(exc)) from None
    return 0


def add_extension_parser(sub):
    """Declare ``cellgl blender-extension``."""
    from cellgl.blender.extension import PLATFORMS

    p = sub.add_parser(
        "blender-extension", help="build the Blender extension zip (Blender 4.2+)",
        description="Build the Blender extension (Shader Editor > Add > cellgl, a sidebar panel, GPU "
        "bakes): blender_manifest.toml, the add-on and the wheels it needs for each platform, fetched "
        "with pip download (network). Install it in Blender: Edit > Preferences > Get Extensions > "
        "Install from Disk. See docs/blender.md.")
    p.add_argument("-o", "--output", metavar="FILE.zip", required=True, help="the zip to write")
    p.add_argument("--platform", dest="platforms", action="append", choices=list(PLATFORMS),
                   help="a platform to bundle wheels for (repeatable; default: all four)")
    p.add_argument("--cache", metavar="DIR", help="keep the downloaded wheels here (per platform) "
                   "and reuse them")
    p.add_argument("--validate", action="store_true",
                   help="then run Blender's extension validator on the zip (needs the bpy module)")
    return p


def run_extension_cli(args) -> int:
    """Run ``cellgl blender-extension``; returns the exit status."""
    from cellgl.blender.extension import PLATFORMS, build_extension, validate

    try:
        path = build_extension(args.output, platforms=args.platforms or tuple(PLATFORMS), cache=args.cache)
    except RuntimeError as exc:
        raise ValueError(str(exc)) from None
    size = path.stat().st_size / 2**20
    print(f"wrote {path} ({size:.1f} MiB)")
    if args.validate:
        try:
            print(validate(path))
        except RuntimeError as exc:
            raise ValueError(str(exc)) from None
    return 0
