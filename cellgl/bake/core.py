"""Bake a recipe (or a preset) to an image or volume file: :func:`bake` (``cellgl bake``, whose
command line is :mod:`cellgl.cli.bake`).

The format comes from the extension (``.png``, ``.exr``, ``.tif``/``.tiff``, ``.npy``; GPU
textures ``.dds``/``.ktx2`` are :mod:`cellgl.bake.gputex`'s). Output
larger than one tile is rendered tile by tile and streamed to the file, so memory stays bounded;
every pixel is rendered at the same uv as in a one-pass bake, so the two give the same bits.
Files are written atomically (temporary file + ``os.replace``). See ``docs/bake.md``.
"""

from __future__ import annotations

import errno
import json
import math
import os
import shutil
import sys
import dataclasses
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cellgl.io import formats as cio
from cellgl.bake import gputex
from cellgl.bake import texfile
from cellgl.io import gpu_textures
from cellgl.io.tiled import check_tiled
from cellgl.bake import udim as udim_mod
from cellgl.io.colour import COLORSPACES, REC709_CHROMATICITIES, check_colorspace
from cellgl.io.progress import Progress  # noqa: F401 - bake's progress bar, also cellgl.bake.core.Progress
from cellgl.io.tempfiles import NAME_MAX, atomic_paths, check_output, human_size
from cellgl.texture import antialias

__all__ = ["bake", "Baked", "BakeError", "parse_size", "parse_channels", "FORMATS", "CHANNELS",
           "MAX_SIDE", "MAX_SLICES", "MAX_VOXELS"]


from cellgl.bake.request import (DEFAULT_BUDGET, DEFAULT_SIZE, MAX_TILE, RENDER_BYTES_PER_PIXEL,  # noqa: F401
                                 parse_sets, check_budget, parse_channels, parse_size, ANIMATED, accepted_outputs)
from cellgl.io.spec import (CHANNELS, FORMATS, MAX_SIDE, MAX_SLICES, MAX_VOXELS, BakeError,  # noqa: F401
                            accepted_list, check_size, Encoding, encoding_of, exr_names, id_colors)


# --------------------------------------------------------------------------------------------
# planning
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Output:
    path: Path
    channels: tuple[str, ...]
    encodings: tuple[Encoding, ...]
    size: tuple | None = None   #: (W, H, D or None) of a mip level (cellgl.bake.mips); None: the bake's


@dataclass(frozen=True)
class _Plan:
    width: int
    height: int
    slices: int | None
    tile_w: int
    tile_h: int
    samples: int = 1       #: per pixel (an n x n grid; cellgl.texture.antialias)
    #: this image is the window [ox, ox + width) x [oy, oy + height) of a larger virtual bake
    #: (full_w x full_h; a UDIM tile, cellgl.bake.udim): pixels rendered as that bake's
    origin: tuple[int, int] = (0, 0)
    full: tuple[int, int] | None = None

    def tiles(self) -> Iterator[tuple[int, int, int, int]]:
        """(x0, y0, w, h) row-major."""
        for y0 in range(0, self.height, self.tile_h):
            for x0 in range(0, self.width, self.tile_w):
                yield (x0, y0, min(self.tile_w, self.width - x0), min(self.tile_h, self.height - y0))

    @property
    def count(self) -> int:
        return math.ceil(self.width / self.tile_w) * math.ceil(self.height / self.tile_h)


def _round16_up(n: int) -> int:
    return max(16, -(-n // 16) * 16)


def plan_tiles(width, height, slices, ext, channels, tile, budget, file_bytes) -> _Plan:
    """Tile size so that rendering one tile, and (PNG/EXR) holding one band, fit ``budget``.

    Half the budget is for the render of one tile (``RENDER_BYTES_PER_PIXEL`` of working memory
    plus the float32 result and its encoded copy, per pixel and slice); for PNG and EXR, which
    stream full-width bands of rows, the other half holds the band (encoded, twice while the
    tiles of a band are joined).
    """
    d = slices or 1
    overhead = RENDER_BYTES_PER_PIXEL * (1 + len(channels)) // 2  # grows with the channels
    render_px = (overhead + sum(CHANNELS[c] * 4 for c in channels) + file_bytes) * d
    half = max(1, budget // 2)
    side = min(MAX_TILE, max(16, math.isqrt(half // render_px) // 16 * 16))
    stream = FORMATS[ext].stream
    if tile is not None:
        tw = th = tile
    elif stream == "band":
        rows = max(1, half // max(1, width * 2 * file_bytes * d))
        th = min(height, side, rows if rows < 16 else rows // 16 * 16)
        tw = min(width, MAX_TILE, max(side, half // (th * render_px) // 16 * 16))
    else:
        tw, th = min(side, _round16_up(width)), min(side, _round16_up(height))
    if stream == "tile":
        tw, th = _round16_up(tw), _round16_up(th)  # TIFF tiles are multiples of 16
    return _Plan(width, height, slices, tw, th)


def output_paths(path: Path, channels: tuple[str, ...]) -> list[tuple[Path, tuple[str, ...]]]:
    ext = path.suffix.lower()
    if ext in (".exr", ".vdb") or len(channels) == 1:
        return [(path, channels)]
    return [(path.with_name(f"{path.stem}_{c}{path.suffix}"), (c,)) for c in channels]


# --------------------------------------------------------------------------------------------
# the bake
# --------------------------------------------------------------------------------------------


def load_recipe_sets(recipe_or_name, sets, tileable):
    from cellgl import recipes

    if isinstance(recipe_or_name, (str, os.PathLike)):
        recipe = recipes.load_recipe(str(recipe_or_name))
    else:
        recipe = recipe_or_name
    sets = parse_sets(sets)
    if sets:
        recipe = recipe.set_from_strings(sets)
    if tileable:
        recipe, notes = recipe.tileable()
        for note in notes:
            print(f"cellgl: tileable: {note} (the texture repeats every whole number of cells)",
                  file=sys.stderr)
    elif tileable is not None:
        recipe = recipe.replace(tileable=False)
    return recipe


def check_bits(ext: str, bit_depth) -> int:
    fmt = FORMATS[ext]
    if bit_depth is None:
        return fmt.default_depth
    try:
        bits = int(bit_depth)
    except (TypeError, ValueError):
        bits = None
    if bits not in fmt.depths or str(bit_depth).strip() != str(bits):
        raise BakeError(f"--depth {bit_depth}: {ext} accepts {accepted_list(fmt.depths)} bits "
                        f"(8|16|32 overall: .png 8/16, .tif 8/16/32, .exr 16/32, .npy 32, .vdb 32)")
    return bits


def check_path(path) -> tuple[Path, str]:
    path = Path(os.fspath(path))
    ext = path.suffix.lower()
    if ext not in FORMATS:
        animated = (f" (an animated {'/'.join(ANIMATED)} needs --frames N: "
                    "cellgl.bake.frames.bake_frames from Python)" if ext in ANIMATED else "")
        raise BakeError(f"output {str(path)!r}: unknown extension {ext or '(none)'!r}{animated}; "
                        f"accepted {accepted_outputs()}")
    _check_name(path)
    try:
        check_output(path)      # the one rule of every command's output (cellgl.io.tempfiles)
    except ValueError as exc:
        raise BakeError(str(exc)) from None
    return path, ext


def _check_name(path: Path) -> None:
    n = len(os.fsencode(path.name))
    if n > NAME_MAX:
        raise BakeError(f"output file name {path.name[:40]!r}... is {n} bytes long; "
                        f"accepted at most {NAME_MAX}")


def _check_tile(tile) -> int | None:
    if tile is None:
        return None
    if isinstance(tile, bool) or not isinstance(tile, (int, np.integer)) or not 16 <= tile <= 8192 or tile % 16:
        raise BakeError(f"--tile {tile}: accepted multiples of 16 in 16..8192")
    return int(tile)


class Baked(list):
    """What :func:`bake` returns: the list of files written, plus ``colorspace``, the colour
    space of the ``color`` channel in them (``"linear"``: scene-linear Rec.709, ``"srgb"``:
    sRGB-encoded, None: no colour channel or ``.npy``) and ``udims``, the UDIM tile numbers
    (empty for a single image)."""

    colorspace: str | None = None
    udims: tuple[int, ...] = ()


def bake(recipe_or_name, path, *, size=DEFAULT_SIZE, depth_slices=None, channels=("color",),
         bit_depth=None, tileable=None, sets=(), tile=None, samples=1, progress=True,
         memory_budget=DEFAULT_BUDGET, mips=False, colorspace=None, udim=None, udims=None,
         tiled=False, compress=None, supercompression=None, layers=None) -> Baked:
    """Render a recipe to a file, tile by tile, atomically.

    Parameters
    ----------
    recipe_or_name : Recipe or str or PathLike
        A :class:`cellgl.texture.recipe.Recipe`, a preset name (``cellgl presets``) or a recipe JSON path.
    path : str or PathLike
        Output file; the extension picks the format: ``.png``, ``.exr``, ``.tif``/``.tiff``,
        ``.npy``. Its directory must exist.
    size : int or (int, int) or str
        ``W``, ``(W, H)`` or ``"WxH[xD]"``; sides 1..65536.
    depth_slices : int, optional
        Bake a volume of this many slices, shape ``(D, H, W[, S])`` (``.npy`` and ``.tif`` only).
    channels : sequence of str
        Any of ``color`` (RGB), ``height``, ``normal`` (RGB), ``id``, ``F1``..``F4``, ``roughness``,
        ``ao``, ``metallic`` (the recipe's ``material`` section). An ``.exr``
        holds them all; other formats write one file per channel, ``<stem>_<channel><ext>``,
        when more than one is asked for.
    bit_depth : {8, 16, 32}, optional
        Bits per sample: ``.png`` 8 (default) or 16; ``.tif`` 8, 16 or 32 (float, default);
        ``.exr`` 16 (half) or 32 (float, default); ``.npy`` 32. 8/16 bits store values clamped
        to [0, 1].
    tileable : bool, optional
        Override the recipe's ``tileable`` (the texture then wraps at its edges).
    sets : sequence of str
        ``"name=value"`` recipe overrides (as ``--set``).
    tile : int, optional
        Render tiles of ``tile x tile`` pixels (multiple of 16) instead of a size chosen from
        ``memory_budget``.
    samples : int
        Samples per pixel, a square (1, 4, 9, ..., 64): colour, height and normal averaged over
        an n x n grid of sub-pixels (stratified, deterministic; :mod:`cellgl.texture.antialias`).
    progress : bool
        Draw a progress bar on stderr when there is more than one tile.
    memory_budget : int
        Bytes of working memory the bake aims to stay within beyond the process's baseline
        (render of one tile, plus one band of rows for PNG/EXR); sets the tile size.
    mips : bool
        Also write the mip chain, every level rendered from the recipe at its own size
        (:mod:`cellgl.bake.mips`): level ``k`` of a ``.png``/``.exr``/``.tif``/``.npy`` bake is
        the file ``<stem>_mip<k><ext>`` beside level 0 (the file without ``mips``, the same
        bits), ``ceil(W / 2^k) x ceil(H / 2^k)``, down to 1 x 1; ``.dds``/``.ktx2`` hold the
        levels in the file (``max(1, floor(W / 2^k))``, as those formats define them).
    colorspace : {"linear", "srgb"}, optional
        The colour space of ``color`` in a float file (``.exr``, 32-bit ``.tif``): ``linear``
        (default; scene-linear Rec.709, tagged) or ``srgb`` (sRGB-encoded, tagged). Integer
        formats are always sRGB-encoded and refuse it (:mod:`cellgl.io.colour`).
    udim, udims : str, optional
        A UDIM set: ``udim="1001-1012"`` (numbers, ranges, comma lists in 1001..1100) or
        ``udims="4x2"`` (columns x rows from 1001); ``path`` holds the token ``<UDIM>``. Tile
        ``1001 + u + 10 v`` is the texture over ``[u, u+1) x [v, v+1)``, ``size`` pixels each
        (:mod:`cellgl.bake.udim`); the set lands whole.
    tiled : bool
        Write a tiled file (64 x 64 tiles) of an ``.exr`` or ``.tif``; with ``mips`` its levels
        go inside it (OpenEXR MIPMAP_LEVELS, TIFF reduced-resolution pages) instead of numbered
        files. A ``.tx`` is always tiled and mip-mapped (:mod:`cellgl.bake.texfile`).
    compress : str, optional
        ``.dds``/``.ktx2`` only: the block format, ``bc1``, ``bc3``, ``bc4``, ``bc5``, ``bc7`` or
        ``none`` for every channel, or per channel ``"color=bc1,height=none"``; default per
        channel (colour BC7 sRGB, normal BC5, height and masks BC4; F1..F4 and id are never
        compressed). Refused where the channel cannot use it (:data:`cellgl.io.gpu_textures.CHOICES`).
    supercompression : {None, "zstd"}
        ``.ktx2`` only: zstd supercompression of every level.
    layers : sequence of Recipe, optional
        ``.dds``/``.ktx2`` only: an array texture, one 2D layer per recipe, rendered as given
        (``recipe_or_name`` is checked as usual; ``cellgl.bake.frames.bake_frames`` passes a loop's frames).

    Returns
    -------
    Baked (a list of pathlib.Path)
        The files written, with ``.colorspace`` and ``.udims``.

    Raises
    ------
    BakeError (a ValueError)
        Bad extension, size, depth, channel, tile or ``--set``; the message names the value and
        what is accepted. Nothing is written.
    cellgl.texture.recipe.RecipeError
        Unknown preset or bad recipe value.
    """
    template = path
    try:
        set_tiles = udim_mod.tiles_for(path, udim, udims)
    except ValueError as exc:
        raise BakeError(str(exc)) from None
    if set_tiles:
        path = udim_mod.tile_path(os.fspath(path), set_tiles[0].number)
    path, ext = check_path(path)
    fmt = FORMATS[ext]
    if isinstance(size, str):
        w, h, d = parse_size(size)
        depth_slices = depth_slices if depth_slices is not None else d
    else:
        w, h = (size, size) if isinstance(size, (int, np.integer)) else tuple(size)
        check_size(w, h, None, f"size {w}x{h}")
    if depth_slices is not None:
        check_size(w, h, depth_slices, f"size {w}x{h}x{depth_slices}")
        if not fmt.volume:
            raise BakeError(f"volume bake ({w}x{h}x{depth_slices}) to {ext}: volumes are "
                            f"written to .npy or .tif only, and to .vdb (OpenVDB)")
    if ext == ".vdb":           # before any work: a volume, and the binding (cellgl.io.vdb)
        _check_vdb(w, h, depth_slices)
    channels = parse_channels(channels)
    texture = ext in gpu_textures.EXTS
    if texture:     # GPU textures: a format per channel, every refusal now (cellgl.io.gpu_textures)
        tex_outputs = gpu_textures.plan_outputs(path, ext, channels, compress, bit_depth, supercompression,
                                          (w, h, depth_slices))
        if layers is not None and (depth_slices is not None or not 1 <= len(layers) <= 2048):
            raise BakeError(f"an array texture of {len(layers)} layers{' of volumes' if depth_slices else ''}: "
                            f"accepted 1..2048 layers of 2D textures (no API has arrays of 3D textures)")
        for flag, value in (("--udim", set_tiles), ("--tiled", tiled), ("--colorspace", colorspace)):
            if value:
                raise BakeError(f"{flag} with {ext}: a GPU texture file is one 2D or 3D texture (its "
                                f"colour always an sRGB format); accepted for .exr/.tif (and .png for --udim)")
        bits = 8
    elif compress is not None or supercompression is not None or layers is not None:
        flag = "--compress" if compress is not None else "--zstd" if supercompression is not None else "layers"
        raise BakeError(f"{flag}: only for GPU texture files (-o NAME.dds or NAME.ktx2); {ext} "
                        f"holds plain samples")
    else:
        bits = check_bits(ext, bit_depth)
    try:
        space = check_colorspace(colorspace, ext, bits)
    except ValueError as exc:
        raise BakeError(str(exc)) from None
    if set_tiles and depth_slices is not None:
        raise BakeError(f"--udim with a volume ({w}x{h}x{depth_slices}): UDIM sets are of 2D "
                        f"images; accepted --size WxH")
    try:
        udim_mod.check_extent(set_tiles, w, h, MAX_SIDE)
    except ValueError as exc:
        raise BakeError(str(exc)) from None
    tile = _check_tile(tile)
    try:
        samples = antialias.check_samples(samples)
    except ValueError as exc:
        raise BakeError(f"--samples: {exc}") from None
    if not isinstance(mips, bool) or not isinstance(tiled, bool):
        raise BakeError(f"mips={mips!r}, tiled={tiled!r}: accepted True or False")
    tiled, mips = check_tiled(ext, tiled, mips, channels, depth_slices)
    outputs = []      # (UDIM tile or None, output)
    for t in ([] if texture else (set_tiles or [None])):
        where = path if t is None else udim_mod.tile_path(os.fspath(template), t.number)
        level0 = [_Output(p, chs, tuple(encoding_of(c, ext, bits, space) for c in chs))
                  for p, chs in output_paths(Path(where), channels)]
        outputs += [(t, o) for o in (_mip_outputs(level0, w, h, depth_slices) if mips and not tiled else level0)]
    if ext == ".exr" and not cio.have_exr():
        raise BakeError("writing .exr files needs the 'OpenEXR' package: "
                        "pip install 'cellgl[exr]'")
    if ext in (".tif", ".tiff", ".tx") and not cio.have_tiff():
        raise BakeError("writing .tif files needs the 'tifffile' package: "
                        "pip install 'cellgl[tiff]'")
    memory_budget = check_budget(memory_budget)          # as --memory (issue 42 item 12)
    recipe = load_recipe_sets(recipe_or_name, sets, tileable)
    if samples != 1 and getattr(recipe, "kind", None) == "pups":
        raise BakeError(f"--samples {samples}: supersampling is for texture recipes; "
                        f"{recipe.name} is a PUPs recipe (accepted: 1)")
    if depth_slices is not None and getattr(recipe, "kind", None) == "pups":
        raise BakeError(f"volume bake ({w}x{h}x{depth_slices}): {recipe.name} is a PUPs recipe, which makes "
                        f"2D images only; accepted: --size WxH, or a cellular recipe with basis.dimension 3 or 4")
    if depth_slices is not None and recipe.get("dimension") < 3:
        raise BakeError(f"volume bake ({w}x{h}x{depth_slices}) needs a solid recipe: "
                        f"basis.dimension 3 or 4, got {recipe.get('dimension')} "
                        f"(try --set dimension=3)")
    if texture:
        for o in tex_outputs:
            _check_name(o.path)
        done = Baked(gputex.bake_texture(
            recipe, tex_outputs, ext, (w, h, depth_slices), samples=samples, tile=tile, budget=memory_budget,
            mip_chain=mips, supercompression=supercompression, layers=layers,
            progress=lambda total, label, unit: Progress(total, label, progress, unit=unit),
            meta=lambda c: _meta(recipe, _Output(path, (c,), (encoding_of(c, ".png", 8, space),)),
                                 _Plan(w, h, depth_slices, 1, 1))))
        done.colorspace = space if "color" in channels else None
        return done
    if set_tiles:
        try:
            recipe = udim_mod.window_recipe(recipe, set_tiles)
        except ValueError as exc:
            raise BakeError(str(exc)) from None
    for _, out in outputs:
        _check_name(out.path)
    _check_disk(path.parent, w, h, depth_slices, [out for _, out in outputs], ext)

    # All the files land together, or none does (a UDIM set too): each is rendered to its
    # temporary file and they are renamed onto the outputs only once every one is complete.
    with atomic_paths([out.path for _, out in outputs]) as tmps:
        for (t, out), tmp in zip(outputs, tmps):
            file_bytes = sum(e.samples * e.dtype.itemsize for e in out.encodings)
            ow, oh, od = out.size or (w, h, depth_slices)
            if tiled:
                window = None if t is None else (t, set_tiles)
                texfile.write_texture(tmp, recipe, out, ext, (w, h), mips=mips, samples=samples,
                                      window=window, meta=_meta(recipe, out, _Plan(w, h, None, w, h)),
                                      progress=progress)
                continue
            plan = dataclasses.replace(plan_tiles(ow, oh, od, ext, out.channels, tile, memory_budget,
                                                  file_bytes), samples=samples)
            if t is not None:
                _, _, cols, rows = udim_mod.bounds(set_tiles)
                plan = dataclasses.replace(plan, full=(cols * ow, rows * oh),
                                           origin=udim_mod.tile_origin(t, set_tiles, ow, oh))
            _bake_one(recipe, out, ext, plan, progress, tmp)
    done = Baked(out.path for _, out in outputs)
    done.colorspace = space if "color" in channels else None
    done.udims = tuple(t.number for t in set_tiles)
    return done


def _mip_outputs(outputs: list[_Output], w: int, h: int, d: int | None) -> list[_Output]:
    """``outputs`` (level 0) followed by every further level's numbered file, per output."""
    from cellgl.bake.mips import level_path, mip_sizes

    sizes = mip_sizes(w, h, d)
    out = list(outputs)
    for o in outputs:
        for k, size in enumerate(sizes[1:], 1):
            out.append(dataclasses.replace(o, path=level_path(o.path, k),
                                           size=(size[0], size[1], size[2] if d is not None else None)))
    return out


def _check_disk(directory: Path, w, h, d, outputs, ext) -> None:
    # Uncompressed formats (and the volume TIFF spool) need their full size on disk.
    if ext not in (".npy", ".tif", ".tiff"):
        return
    need = 0
    for out in outputs:
        ow, oh, od = out.size or (w, h, d)
        px = ow * oh * (od or 1)
        per = sum(e.samples * e.dtype.itemsize for e in out.encodings)
        need += px * per * (2 if (ext != ".npy" and d) else (1 if ext == ".npy" else 0))
    try:
        free = shutil.disk_usage(directory).free
    except OSError:
        return
    if need > free:
        raise BakeError(f"not enough disk space in {str(directory)!r}: the bake needs about "
                        f"{human_size(need)}, {human_size(free)} free")


def _render_tiles(recipe, out: _Output, plan: _Plan, bar: Progress) -> Iterator[tuple]:
    """Yield (x0, y0, {channel: encoded array}) row-major; arrays (h, w[, S]) or (D, h, w[, S])."""
    from cellgl import recipes

    extra = {"samples": plan.samples} if plan.samples != 1 else {}
    full_w, full_h = plan.full or (plan.width, plan.height)
    ox, oy = plan.origin
    for x0, y0, tw, th in plan.tiles():
        res = recipes.render(recipe, full_w, full_h, channels=out.channels,
                             x0=ox + x0, y0=oy + y0, tile_w=tw, tile_h=th, depth=plan.slices, **extra)
        enc = {}
        for e in out.encodings:
            a = e.encode(res[e.channel])
            lead = (plan.slices,) if plan.slices else ()
            expect = lead + (th, tw) + ((e.samples,) if e.samples > 1 else ())
            if a.shape != expect:
                raise RuntimeError(f"render() gave {e.channel} of shape {a.shape}, "
                                   f"expected {expect}")
            enc[e.channel] = a
        bar.step()
        yield x0, y0, enc


def _bands(tiles: Iterator[tuple], plan: _Plan) -> Iterator[dict]:
    """Group row-major tiles into full-width bands: {channel: (rows, W[, S])}."""
    per_row = math.ceil(plan.width / plan.tile_w)
    row: list[dict] = []
    for _, _, enc in tiles:
        row.append(enc)
        if len(row) == per_row:
            yield {k: (np.concatenate([t[k] for t in row], axis=1) if per_row > 1 else row[0][k])
                   for k in row[0]}
            row = []


def _meta(recipe, out: _Output, plan: _Plan) -> str:
    try:
        rec = recipe.to_dict()
    except Exception:  # noqa: BLE001 - metadata is best effort
        rec = None
    size = [plan.width, plan.height] + ([plan.slices] if plan.slices else [])
    meta = {"generator": "cellgl", "recipe": rec, "size": size, "channels": list(out.channels)}
    spaces = {e.channel: COLORSPACES[e.colorspace].interop_id for e in out.encodings if e.colorspace}
    if spaces:
        meta["colorspace"] = spaces     # data channels: never colour, never listed
    if plan.full is not None:
        meta["window"] = {"origin": list(plan.origin), "of": list(plan.full)}   # a UDIM tile
    return json.dumps(meta, sort_keys=True, default=str)


def _bake_one(recipe, out: _Output, ext: str, plan: _Plan, progress: bool, tmp: Path) -> None:
    """Render ``out`` into ``tmp``, its temporary file (see :func:`bake`)."""
    bar = Progress(plan.count, f"baking {out.path.name}", progress)
    meta = _meta(recipe, out, plan)
    tiles = _render_tiles(recipe, out, plan, bar)
    with bar:
        _write(tmp, tiles, out, ext, plan, meta)


def _write(tmp: Path, tiles, out: _Output, ext: str, plan: _Plan, meta: str) -> None:
    try:
        if ext == ".png":
            (e,) = out.encodings
            cio.write_png(tmp, (b[e.channel] for b in _bands(tiles, plan)), plan.width,
                          plan.height, e.samples, e.dtype.itemsize * 8,
                          text={"Software": "cellgl", "cellgl": meta}, srgb=e.channel == "color")
        elif ext == ".exr":
            _write_exr(tmp, tiles, out, plan, meta)
        elif ext == ".vdb":     # a grid per sample (cellgl.io.vdb)
            from cellgl.io import vdb
            vdb.write_vdb(tmp, (plan.width, plan.height, plan.slices), {e.channel: (e.samples, e.dtype) for e in
                          out.encodings}, tiles, metadata=meta, colorspaces={e.channel: COLORSPACES[
                              e.colorspace].interop_id for e in out.encodings if e.colorspace})
        elif ext == ".npy":
            (e,) = out.encodings
            cio.write_npy(tmp, _npy_pieces(tiles, e, plan), _shape(e, plan), e.dtype)
        else:
            _write_tiff(tmp, tiles, out, plan, meta)
    except OSError as exc:
        if exc.errno in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG):
            raise BakeError(f"cannot write {out.path}: {exc.strerror}") from None
        raise


def _shape(e: Encoding, plan: _Plan) -> tuple[int, ...]:
    lead = (plan.slices,) if plan.slices else ()
    return lead + (plan.height, plan.width) + ((e.samples,) if e.samples > 1 else ())


def _npy_pieces(tiles, e: Encoding, plan: _Plan):
    for x0, y0, enc in tiles:
        a = enc[e.channel]
        lead = (slice(None),) if plan.slices else ()
        th, tw = a.shape[len(lead):len(lead) + 2]
        yield lead + (slice(y0, y0 + th), slice(x0, x0 + tw)), a


def _write_exr(tmp, tiles, out: _Output, plan: _Plan, meta: str) -> None:
    dtypes = {}
    for e in out.encodings:
        for name in exr_names(e.channel):
            dtypes[name] = e.dtype

    def split(band):
        res = {}
        for e in out.encodings:
            a = band[e.channel]
            names = exr_names(e.channel)
            if len(names) == 1:
                res[names[0]] = a
            else:
                for i, name in enumerate(names):
                    res[name] = a[..., i]
        return res

    attributes, chroma = {"cellgl": meta}, None
    space = next((e.colorspace for e in out.encodings if e.colorspace), None)
    if space is not None:       # the colour channels' space; the data channels are not colour
        attributes["oiio:ColorSpace"] = attributes["colorInteropID"] = COLORSPACES[space].interop_id
        chroma = REC709_CHROMATICITIES
    cio.write_exr(tmp, (split(b) for b in _bands(tiles, plan)), plan.width, plan.height,
                  dtypes, attributes=attributes, chromaticities=chroma)


def _check_vdb(w, h, d) -> None:
    from cellgl.io import vdb

    if d is None:
        raise BakeError(f"a .vdb holds a volume, not a {w}x{h} image: accepted --size WxHxD "
                        f"(a solid recipe); 2D bakes go to .exr, .tif, .png or .npy")
    try:
        vdb.require()
    except vdb.VdbUnavailable as exc:
        raise BakeError(str(exc)) from None


def _write_tiff(tmp, tiles, out: _Output, plan: _Plan, meta: str) -> None:
    (e,) = out.encodings
    shape = _shape(e, plan)
    rgb = e.samples in (3, 4)
    if not plan.slices:
        cio.write_tiff(tmp, (enc[e.channel] for _, _, enc in tiles), shape, e.dtype,
                       (plan.tile_h, plan.tile_w), rgb=rgb, description=meta)
        return
    # A volume is rendered as (D, h, w) columns but TIFF wants page after page: spool the
    # columns to a memory-mapped .npy next to the output (deleted afterwards), then stream pages.
    with cio.scratch_path(out.path.parent, suffix=".npy") as spool:
        cio.write_npy(spool, _npy_pieces(tiles, e, plan), shape, e.dtype)
        vol = np.load(spool, mmap_mode="r")
        page = _Plan(plan.width, plan.height, None, plan.tile_w, plan.tile_h)
        page_tiles = (vol[z, y:y + th, x:x + tw]
                      for z in range(plan.slices) for x, y, tw, th in page.tiles())
        try:
            cio.write_tiff(tmp, page_tiles, shape, e.dtype, (plan.tile_h, plan.tile_w),
                           rgb=rgb, description=meta)
        finally:
            del vol, page_tiles


# --------------------------------------------------------------------------------------------
# for writers of sets of maps (cellgl.bake.material_sets): one file through the per-format writer
# --------------------------------------------------------------------------------------------

#: what one output file holds (its path, channels and their encodings)
Output = _Output
#: ``write_tiles(tmp, tiles, out, ext, plan, meta)``: write the tiles ``(x0, y0, {name: encoded})``
#: of ``out`` into ``tmp`` with the writer of format ``ext``, as :func:`bake` does
write_tiles = _write
