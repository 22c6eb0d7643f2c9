"""Command line of ``cellgl bake`` (docs/bake.md): arguments, then :func:`cellgl.bake.core.bake`."""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

from cellgl.bake.core import bake
from cellgl.bake.request import ANIMATED, DEFAULT_BUDGET, DISTRIBUTED, DEFAULT_SIZE, accepted_outputs, int_arg
from cellgl.io.spec import FORMATS, BakeError, accepted_list
from cellgl.texture.antialias import MAX_SAMPLES

__all__ = ["add_parser", "run_cli"]


_EPILOG = """\
formats (from the extension) and --depth (bits per sample):
  .png  8 (default) or 16     .exr  16 (half) or 32 (float, default)
  .tif  8, 16 or 32 (float, default; tiled)     .npy  32 (float32)
  .tx   as .tif, tiled and mip-mapped (every level rendered) for film renderers
  .dds, .ktx2  GPU textures, a format per channel (--compress; --depth: plain samples' bits)
  .vdb  OpenVDB volume (--size WxHxD), a float grid per sample (needs OpenVDB's binding)
colour: float files hold scene-linear Rec.709 (--colorspace srgb: sRGB-encoded), tagged;
  integer formats sRGB-encoded.
channels: color (RGB), height, normal (RGB), id (uint32; false colour in .png), F1..F4,
  roughness, ao, metallic (the recipe's material section), cloud (RGBA cloud noise:
  Perlin-Worley, Worley fBm at 1, 2, 4 x frequency).
  An .exr holds every channel asked for; other formats write <stem>_<channel><ext> each.
material sets (--material ENGINE -o DIR): the maps of an engine's standard material, packed as it
  expects, with manifest.json: unreal, unity-hdrp, unity-urp, godot, gltf (+ a .gltf), blender;
  PNG, or --map-format dds|ktx2 (BC7 sRGB colour, BC5 normal, BC7 packed maps, BC4, R16 height).
examples:
  cellgl bake flagstone -o flagstone.png
  cellgl bake flagstone -o flagstone.exr --size 2048 --channels color,height,normal
  cellgl bake crumple -o crumple.png --size 256 --samples 4
  cellgl bake flagstone -o f.dds --size 1024 --mips --channels color,normal   # BC7 sRGB, BC5
  cellgl bake flagstone -o f.ktx2 --size 1024 --mips --zstd --compress bc1
  cellgl bake my_recipe.json -o big.tif --size 16384x16384 --tileable
  cellgl bake flagstone -o vol.npy --size 64x64x64 --channels F1
  cellgl bake flagstone -o 'wall.<UDIM>.tx' --udim 1001-1012 --size 1024
  cellgl bake flagstone --material unreal -o flagstone_unreal --size 2048
  cellgl bake flagstone --material unreal -o unreal_dds --size 2048 --map-format dds --mips
  cellgl bake mountains -o terrain.zarr --size 262144 --channels height   # Dask, resumable
"""


def add_parser(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Declare ``cellgl bake``'s arguments on a subparsers object."""
    p = sub.add_parser(
        "bake", help=f"render a preset or recipe to {'/'.join(FORMATS)} (an animated "
                     f"{'/'.join(ANIMATED)} with --frames, or {'/'.join(DISTRIBUTED)} on Dask)",
        description="Render a preset or recipe JSON to an image or volume file.",
        epilog=_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("recipe", metavar="PRESET_OR_RECIPE",
                   help="a preset name (cellgl presets) or a recipe .json file")
    p.add_argument("-o", "--output", required=True, metavar="FILE",
                   help=f"output file: {accepted_outputs()}")
    p.add_argument("--size", default=f"{DEFAULT_SIZE[0]}x{DEFAULT_SIZE[1]}", metavar="W[xH[xD]]",
                   help="pixels (default %(default)s); a third number bakes a volume of D slices")
    p.add_argument("--set", dest="sets", action="append", default=[], metavar="NAME=VALUE",
                   help="override a recipe parameter (repeatable)")
    p.add_argument("--tileable", action="store_true", default=None,
                   help="make the texture wrap around at its edges (a volume in depth too)")
    p.add_argument("--channels", action="append", default=None, metavar="LIST",
                   help="comma-separated: color, height, normal, id, F1..F4, roughness, ao, metallic, "
                        "cloud (default color)")
    p.add_argument("--material", default=None, metavar="ENGINE",
                   help="bake the material set of an engine preset into the folder -o DIR: unreal, "
                        "unity-hdrp, unity-urp, godot, gltf, blender (cellgl/bake/material_sets.py)")
    p.add_argument("--map-format", default=None, metavar="NAME",
                   help="with --material: the maps' format: png (the default), dds or ktx2 (each map one GPU "
                        "texture file, with --mips its levels inside; not for gltf)")
    p.add_argument("--depth", default=None, metavar="BITS",
                   help="bits per sample: 8|16|32 (default per format, see below)")
    p.add_argument("--samples", default="1", metavar="N",
                   help="samples per pixel: 1 (default), 4, 9, 16, ... 64 (an n x n grid averaged: "
                        "smooth edges; band-limited fractals need none)")
    p.add_argument("--tile", default=None, metavar="N",
                   help="advanced: render N x N tiles (multiple of 16) instead of a size chosen "
                        "from --memory")
    p.add_argument("--memory", default=None, metavar="MB",
                   help=f"advanced: MB of working memory to stay within; sets the tile size "
                        f"(default {DEFAULT_BUDGET >> 20})")
    p.add_argument("--frames", default=None, metavar="N",
                   help="a loop of N frames of an orbiting recipe (orbit_phase + k/N): FILE_0000.png "
                        ".. FILE_<N-1>.png, one animated .webp/.gif, or one .dds/.ktx2 array texture "
                        "(cellgl/bake/frames.py)")
    p.add_argument("--fps", default=None, metavar="FPS",
                   help="frames per second of an animated file (with --frames): .webp 1..95 "
                        "(default 24), .gif 1..50 (default 25; it stores 100/n exactly)")
    p.add_argument("--colorspace", default=None, metavar="NAME",
                   help="colour of a float file (.exr, 32-bit .tif, .vdb, .zarr): linear (default; scene-linear "
                        "Rec.709, tagged lin_rec709_scene) or srgb (sRGB-encoded, tagged); integer "
                        "formats are always sRGB-encoded")
    p.add_argument("--udim", default=None, metavar="RANGE",
                   help="a UDIM set: tiles such as 1001-1012 (1001..1100; -o holds <UDIM>, e.g. "
                        "'wall.<UDIM>.exr', quoted); tile 1001+u+10v is uv [u,u+1)x[v,v+1), --size each")
    p.add_argument("--udims", default=None, metavar="UxV",
                   help="a UDIM set of U columns by V rows from 1001 (as --udim)")
    p.add_argument("--mips", action="store_true",
                   help="also write the mip chain, each level rendered at its own size (never "
                        "downsampled): in the file for .dds/.ktx2, else FILE_mip1.png .. (1x1)")
    p.add_argument("--compress", default=None, metavar="FORMAT",
                   help=".dds/.ktx2: bc1|bc3|bc4|bc5|bc7|none for every channel, or per channel "
                        "color=bc1,height=none (default: color bc7 sRGB, normal bc5, height bc4; "
                        "F1..F4 float, id R32_UINT, never compressed)")
    p.add_argument("--zstd", action="store_true",
                   help=".ktx2: zstd supercompression of every level")
    p.add_argument("--tiled", action="store_true",
                   help="a tiled .exr/.tif (64x64 tiles); with --mips the levels go inside it, as "
                        "in a .tx (always tiled and mip-mapped)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar, no summary")
    g = p.add_argument_group("distributed (.zarr output; needs pip install 'cellgl[dask]', "
                             "see docs/scale.md)")
    g.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="Dask scheduler address (tcp://host:8786) or scheduler file (.json); "
                        "default: a local cluster sized to the machine")
    g.add_argument("--workers", default=None, metavar="N",
                   help="worker processes of the local cluster (default: one per core)")
    g.add_argument("--threads", default="1", metavar="N",
                   help="threads per local worker process (default 1)")
    return p


def run_cli(args: argparse.Namespace) -> int:
    """Run ``cellgl bake`` from parsed arguments; errors are raised as BakeError (ValueError)."""
    if not args.output:     # -o '': the one rule's message, not "'.': unknown extension"
        from cellgl.io.tempfiles import check_output

        try:
            check_output(args.output)
        except ValueError as exc:
            raise BakeError(str(exc)) from None
    ext = Path(args.output).suffix.lower()
    if args.frames is not None and ext == ".zarr":
        raise BakeError(f"--frames {args.frames}: a .zarr bake writes one image; accepted for "
                        f"--frames: an animated {'/'.join(ANIMATED)} or a numbered {', '.join(FORMATS)} sequence")
    if args.fps is not None and (args.frames is None or ext not in ANIMATED):
        raise BakeError(f"--fps {args.fps}: only for an animated file (--frames N -o NAME.webp "
                        f"or NAME.gif); a numbered sequence or a single image has no frame rate")
    if args.material is not None:
        return _run_material(args)
    if args.map_format is not None:
        raise BakeError(f"--map-format {args.map_format}: only with --material ENGINE")
    for flag, value in (("--udim", args.udim), ("--udims", args.udims), ("--colorspace", args.colorspace),
                        ("--tiled", args.tiled or None)):
        if value is not None and (args.frames is not None or (ext == ".zarr" and flag != "--colorspace")):
            raise BakeError(f"{flag} {value}: only for a single bake to {', '.join(FORMATS)}; "
                            f"not with --frames or a .zarr output")
    if getattr(args, "mips", False) and ((args.frames is not None and ext not in (".dds", ".ktx2"))
                                         or ext == ".zarr"):
        raise BakeError(f"--mips: for a single bake (.png, .exr, .tif, .npy: numbered files; "
                        f".dds, .ktx2: in the file, also an array of --frames); not with "
                        f"{'--frames to ' + ext if args.frames is not None else '.zarr'}")
    if ext == ".zarr":
        from cellgl.cli.dask import run_zarr_bake

        return run_zarr_bake(args)
    for flag, value in (("--scheduler", args.scheduler), ("--workers", args.workers),
                        ("--threads", None if args.threads == "1" else args.threads)):
        if value is not None:
            raise BakeError(f"{flag} {value}: only for a distributed .zarr bake "
                            f"(-o NAME.zarr); accepted outputs here: {accepted_list((*FORMATS, *ANIMATED))}")
    budget = DEFAULT_BUDGET if args.memory is None else \
        int_arg("--memory", args.memory, 1, 1 << 20) << 20
    tile = None if args.tile is None else int_arg("--tile", args.tile, 16, 8192)
    samples = int_arg("--samples", args.samples, 1, MAX_SAMPLES)
    t0 = time.perf_counter()
    try:
        if args.frames is not None:
            return _run_frames(args, tile, budget, t0)
        paths = bake(args.recipe, args.output, size=args.size,
                     channels=tuple(args.channels or ("color",)), bit_depth=args.depth,
                     tileable=args.tileable, sets=args.sets, tile=tile, samples=samples,
                     progress=not args.quiet, memory_budget=budget, mips=args.mips,
                     colorspace=args.colorspace, udim=args.udim, udims=args.udims, tiled=args.tiled,
                     compress=args.compress, supercompression="zstd" if args.zstd else None)
    except OSError as exc:
        where = f" {exc.filename}" if exc.filename else ""
        raise BakeError(f"cannot write{where}: {exc.strerror or exc}") from None
    if not args.quiet:
        secs = time.perf_counter() - t0
        for p in paths:
            print(f"wrote {p} ({os.path.getsize(p) / 1024:.0f} KiB, {secs:.1f} s)",
                  file=sys.stderr)
        if paths.colorspace:
            from cellgl.io.colour import COLORSPACES

            cs = COLORSPACES[paths.colorspace]
            print(f"colour: {cs.ocio_name} ({cs.interop_id})", file=sys.stderr)
    return 0


def _texture_kw(args: argparse.Namespace) -> dict:
    """--mips, --compress, --zstd for a loop baked as one .dds/.ktx2 array texture (bake refuses
    --compress/--zstd for the other formats)."""
    kw = {}
    if args.mips:
        kw["mips"] = True
    if args.compress is not None:
        kw["compress"] = args.compress
    if args.zstd:
        kw["supercompression"] = "zstd"
    return kw


def _run_frames(args: argparse.Namespace, tile, budget: int, t0: float) -> int:
    """``cellgl bake --frames N``: a loop (cellgl.bake.frames.bake_frames)."""
    from cellgl.bake.frames import ANIMATED, MAX_FPS, MAX_FPS_OF, MAX_FRAMES, bake_frames, frame_delay

    ext = Path(args.output).suffix.lower()
    try:
        fps = None if args.fps is None else float(args.fps)
    except ValueError:
        raise BakeError(f"--fps {args.fps!r}: accepted a number in 1..{MAX_FPS_OF.get(ext, MAX_FPS)}") from None
    paths = bake_frames(args.recipe, args.output, int_arg("--frames", args.frames, 1, MAX_FRAMES), fps=fps,
                        size=args.size, channels=tuple(args.channels or ("color",)), bit_depth=args.depth,
                        tileable=args.tileable, sets=args.sets, tile=tile, progress=not args.quiet,
                        memory_budget=budget, **_texture_kw(args))
    if not args.quiet:
        total = sum(os.path.getsize(p) for p in paths)
        rate = ""
        if ext in ANIMATED:
            from cellgl.bake.frames import DEFAULT_FPS

            delay, real = frame_delay(ext, DEFAULT_FPS[ext] if fps is None else fps)
            rate = f", {real:.4g} fps: {delay} {'cs' if ext == '.gif' else 'ms'} a frame"
        print(f"wrote {len(paths)} file(s): {paths[0]}{' .. ' + str(paths[-1]) if len(paths) > 1 else ''} "
              f"({total / 1024:.0f} KiB, {time.perf_counter() - t0:.1f} s{rate})", file=sys.stderr)
    return 0


def _run_material(args: argparse.Namespace) -> int:
    """``cellgl bake --material ENGINE -o DIR``: a material set (cellgl.bake.material_sets)."""
    from cellgl.bake.material_sets import bake_material

    for flag, value in (("--channels", args.channels), ("--depth", args.depth), ("--frames", args.frames),
                        ("--fps", args.fps), ("--tile", args.tile), ("--scheduler", args.scheduler),
                        ("--workers", args.workers), ("--threads", None if args.threads == "1" else args.threads),
                        ("--udim", getattr(args, "udim", None)), ("--udims", getattr(args, "udims", None)),
                        ("--colorspace", getattr(args, "colorspace", None)),
                        ("--tiled", getattr(args, "tiled", None) or None),
                        ("--compress", getattr(args, "compress", None))):
        if value is not None:
            raise BakeError(f"{flag} {value if not isinstance(value, list) else ','.join(value)}: not with "
                            f"--material (the engine preset chooses the maps, their channels and bit depths)")
    budget = DEFAULT_BUDGET if args.memory is None else int_arg("--memory", args.memory, 1, 1 << 20) << 20
    t0 = time.perf_counter()
    try:
        paths = bake_material(args.recipe, args.output, args.material, size=args.size, tileable=args.tileable,
                              sets=args.sets, samples=int_arg("--samples", args.samples, 1, MAX_SAMPLES),
                              map_format=args.map_format or "png", mips=bool(getattr(args, "mips", False)),
                              supercompression="zstd" if getattr(args, "zstd", False) else None,
                              progress=not args.quiet, memory_budget=budget)
    except OSError as exc:
        where = f" {exc.filename}" if exc.filename else ""
        raise BakeError(f"cannot write{where}: {exc.strerror or exc}") from None
    if not args.quiet:
        total = sum(os.path.getsize(p) for p in paths)
        print(f"wrote {len(paths)} files into {args.output}: {', '.join(p.name for p in paths)} "
              f"({total / 1024:.0f} KiB, {time.perf_counter() - t0:.1f} s)", file=sys.stderr)
    return 0
