"""Bake a recipe (or a preset) to an image or volume file: ``cellgl bake`` and :func:`bake`.

The format comes from the extension (``.png``, ``.exr``, ``.tif``/``.tiff``, ``.npy``). Output
larger than one tile is rendered tile by tile and streamed to the file, so memory stays bounded;
every pixel is rendered at the same uv as in a one-pass bake, so the two give the same bits.
Files are written atomically (temporary file + ``os.replace``). See ``docs/bake.md``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import sys
import time
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import io as cio

__all__ = ["bake", "BakeError", "parse_size", "parse_channels", "FORMATS", "CHANNELS",
           "MAX_SIDE", "MAX_SLICES", "MAX_VOXELS"]


class BakeError(ValueError):
    """A bad bake request: the message names the value and what is accepted."""


# --------------------------------------------------------------------------------------------
# what can be baked, and how
# --------------------------------------------------------------------------------------------

#: Channels render() produces -> samples per pixel.
CHANNELS: dict[str, int] = {"color": 4, "height": 1, "normal": 3, "id": 1,
                            "F1": 1, "F2": 1, "F3": 1, "F4": 1}


@dataclass(frozen=True)
class _Format:
    name: str
    depths: tuple[int, ...]
    default_depth: int
    volume: bool
    #: "band" (full-width rows, top first), "tile" (row-major tiles), "piece" (any order)
    stream: str


#: Extension -> format. ``--depth`` (bits per sample) must be one of ``depths``.
FORMATS: dict[str, _Format] = {
    ".png": _Format("PNG", (8, 16), 8, False, "band"),
    ".exr": _Format("OpenEXR", (16, 32), 32, False, "band"),
    ".tif": _Format("TIFF", (8, 16, 32), 32, True, "tile"),
    ".tiff": _Format("TIFF", (8, 16, 32), 32, True, "tile"),
    ".npy": _Format("NumPy", (32,), 32, True, "piece"),
}

MAX_SIDE = 65536          #: largest width or height
MAX_SLICES = 4096         #: largest volume depth (slices)
MAX_VOXELS = 2 ** 32      #: largest width * height * slices
MAX_TILE = 2048           #: largest tile side one render pass gets
DEFAULT_SIZE = (512, 512)
DEFAULT_BUDGET = 256 << 20  #: bytes of working memory a bake aims to stay within
#: working memory of render() per pixel beyond its outputs, for one channel (GPU buffers and
#: read-back on llvmpipe, measured: about 230 bytes); half as much again per extra channel
RENDER_BYTES_PER_PIXEL = 256


def _accepted(values: Iterable) -> str:
    return ", ".join(str(v) for v in values)


def parse_size(text: str) -> tuple[int, int, int | None]:
    """Parse ``W``, ``WxH`` or ``WxHxD`` into ``(W, H, D or None)``.

    Raises
    ------
    BakeError
        Malformed text, or a side outside 1..MAX_SIDE, slices outside 1..MAX_SLICES, or more
        than MAX_VOXELS in all.
    """
    parts = str(text).strip().lower().replace("*", "x").split("x")
    try:
        nums = [int(p) for p in parts]
    except ValueError:
        nums = []
    if not 1 <= len(nums) <= 3:
        raise BakeError(f"--size {text!r}: expected W, WxH or WxHxD with whole numbers, "
                        f"e.g. 512, 1024x512 or 64x64x16")
    w, h, d = nums[0], (nums[1] if len(nums) > 1 else nums[0]), (nums[2] if len(nums) > 2 else None)
    _check_size(w, h, d, f"--size {text}")
    return w, h, d


def _check_size(w: int, h: int, d: int | None, what: str) -> None:
    for name, v in (("width", w), ("height", h)):
        if not isinstance(v, (int, np.integer)) or not 1 <= v <= MAX_SIDE:
            raise BakeError(f"{what}: {name} {v} is out of range; accepted 1..{MAX_SIDE}")
    if d is not None and (not isinstance(d, (int, np.integer)) or not 1 <= d <= MAX_SLICES):
        raise BakeError(f"{what}: depth {d} (volume slices) is out of range; "
                        f"accepted 1..{MAX_SLICES}")
    n = w * h * (d or 1)
    if n > MAX_VOXELS:
        raise BakeError(f"{what}: {n} pixels is too many; at most {MAX_VOXELS} (2**32)")


def parse_channels(values: str | Iterable[str]) -> tuple[str, ...]:
    """Normalise channel names (comma lists allowed, ``f1`` == ``F1``); reject unknown ones."""
    if isinstance(values, str):
        values = [values]
    out: list[str] = []
    lookup = {c.lower(): c for c in CHANNELS}
    for v in values:
        for part in str(v).split(","):
            part = part.strip()
            if not part:
                continue
            name = lookup.get(part.lower())
            if name is None:
                raise BakeError(f"--channels {part!r}: unknown channel; accepted "
                                f"{_accepted(CHANNELS)}")
            if name not in out:
                out.append(name)
    if not out:
        raise BakeError(f"--channels: no channel given; accepted {_accepted(CHANNELS)}")
    return tuple(out)


def _parse_sets(sets: Iterable[str]) -> list[str]:
    out = []
    for s in sets:
        name, eq, value = str(s).partition("=")
        if not eq or not name.strip() or not value.strip():
            raise BakeError(f"--set {s!r}: expected NAME=VALUE, e.g. --set seed=7")
        out.append(f"{name.strip()}={value.strip()}")
    return out


# --------------------------------------------------------------------------------------------
# per-channel encoding: render() output -> file samples
# --------------------------------------------------------------------------------------------


def _quantize(v: np.ndarray, bits: int) -> np.ndarray:
    top = (1 << bits) - 1
    v = np.nan_to_num(np.asarray(v, np.float32), nan=0.0, posinf=1.0, neginf=0.0)
    q = np.floor(np.clip(v, 0.0, 1.0) * np.float32(top) + np.float32(0.5))
    return q.astype(np.uint8 if bits == 8 else np.uint16)


def id_colors(ids: np.ndarray) -> np.ndarray:
    """False colour for cell ids: ``(..., 3)`` uint8 from an integer hash of each id.

    The same id always gets the same colour, so a tiled bake matches a one-pass one.
    """
    x = np.asarray(ids).astype(np.uint32, copy=True)
    with np.errstate(over="ignore"):
        x ^= x >> np.uint32(16)
        x *= np.uint32(0x7FEB352D)
        x ^= x >> np.uint32(15)
        x *= np.uint32(0x846CA68B)
        x ^= x >> np.uint32(16)
    return np.stack([(x >> np.uint32(s)) & np.uint32(255) for s in (0, 8, 16)],
                    axis=-1).astype(np.uint8)


@dataclass(frozen=True)
class _Encoding:
    """How one channel is stored: sample count and dtype in the file."""

    channel: str
    samples: int
    dtype: np.dtype

    def encode(self, a: np.ndarray) -> np.ndarray:
        if self.channel == "color":
            a = np.asarray(a)[..., :3]
        if self.channel == "id":
            if self.samples == 3:
                return id_colors(a)
            return np.asarray(a).astype(np.uint32, copy=False)
        if self.dtype == np.uint8 or self.dtype == np.uint16:
            return _quantize(a, self.dtype.itemsize * 8)
        return np.asarray(a).astype(self.dtype, copy=False)


def _encoding(channel: str, ext: str, bits: int) -> _Encoding:
    fmt = FORMATS[ext]
    samples = CHANNELS[channel]
    if channel == "color":
        samples = 3  # render() gives RGBA with alpha always 1: files get RGB
    if channel == "id":
        if ext == ".png":
            if bits != 8:
                raise BakeError(f"--channels id with .png: ids are written as an 8-bit false-"
                                f"colour preview, so --depth must be 8 (got {bits}); for raw "
                                f"uint32 ids use .tif, .exr or .npy")
            return _Encoding(channel, 3, np.dtype(np.uint8))
        if ext in (".tif", ".tiff") and bits != 32:
            raise BakeError(f"--channels id with {ext}: ids are uint32, so --depth must be 32 "
                            f"(got {bits})")
        return _Encoding(channel, 1, np.dtype(np.uint32))
    if fmt.stream == "band" and ext == ".exr":
        return _Encoding(channel, samples, np.dtype(np.float16 if bits == 16 else np.float32))
    return _Encoding(channel, samples, np.dtype({8: np.uint8, 16: np.uint16,
                                                 32: np.float32}[bits]))


#: EXR channel names per cellgl channel.
_EXR_NAMES = {"color": ("R", "G", "B"), "normal": ("normal.R", "normal.G", "normal.B")}


def _exr_names(channel: str) -> tuple[str, ...]:
    return _EXR_NAMES.get(channel, (channel,))


# --------------------------------------------------------------------------------------------
# planning
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Output:
    path: Path
    channels: tuple[str, ...]
    encodings: tuple[_Encoding, ...]


@dataclass(frozen=True)
class _Plan:
    width: int
    height: int
    slices: int | None
    tile_w: int
    tile_h: int

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


def _plan(width, height, slices, ext, channels, tile, budget, file_bytes) -> _Plan:
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


def _output_paths(path: Path, channels: tuple[str, ...]) -> list[tuple[Path, tuple[str, ...]]]:
    ext = path.suffix.lower()
    if ext == ".exr" or len(channels) == 1:
        return [(path, channels)]
    return [(path.with_name(f"{path.stem}_{c}{path.suffix}"), (c,)) for c in channels]


# --------------------------------------------------------------------------------------------
# progress
# --------------------------------------------------------------------------------------------


class _Progress:
    def __init__(self, total: int, label: str, enabled: bool, stream=None):
        self.total, self.label, self.done = total, label, 0
        self.enabled = enabled and total > 1
        self.stream = stream or sys.stderr
        self.t0 = time.perf_counter()
        self.last = -1.0

    def step(self) -> None:
        self.done += 1
        if not self.enabled:
            return
        now = time.perf_counter()
        if self.done < self.total and now - self.last < 0.25:
            return  # redraw at most four times a second, and always at the end
        self.last = now
        width = 30
        fill = width * self.done // self.total
        secs = time.perf_counter() - self.t0
        eta = secs / self.done * (self.total - self.done)
        self.stream.write(f"\r{self.label} [{'#' * fill}{'.' * (width - fill)}] "
                          f"{self.done}/{self.total} tiles, {secs:.0f} s, eta {eta:.0f} s ")
        self.stream.flush()

    def close(self) -> None:
        if self.enabled and self.done:
            self.stream.write("\n")
            self.stream.flush()


# --------------------------------------------------------------------------------------------
# the bake
# --------------------------------------------------------------------------------------------


def _load(recipe_or_name, sets, tileable):
    from . import recipe as rmod

    if isinstance(recipe_or_name, (str, os.PathLike)):
        recipe = rmod.load_recipe(str(recipe_or_name))
    else:
        recipe = recipe_or_name
    sets = _parse_sets(sets)
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


def _check_bits(ext: str, bit_depth) -> int:
    fmt = FORMATS[ext]
    if bit_depth is None:
        return fmt.default_depth
    try:
        bits = int(bit_depth)
    except (TypeError, ValueError):
        bits = None
    if bits not in fmt.depths or str(bit_depth).strip() != str(bits):
        raise BakeError(f"--depth {bit_depth}: {ext} accepts {_accepted(fmt.depths)} bits "
                        f"(8|16|32 overall: .png 8/16, .tif 8/16/32, .exr 16/32, .npy 32)")
    return bits


def _check_path(path) -> tuple[Path, str]:
    path = Path(os.fspath(path))
    ext = path.suffix.lower()
    if ext not in FORMATS:
        raise BakeError(f"output {str(path)!r}: unknown extension {ext or '(none)'!r}; "
                        f"accepted {_accepted(FORMATS)}")
    if path.is_dir():
        raise BakeError(f"output {str(path)!r} is a directory; give a file name")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise BakeError(f"output directory {str(parent)!r} does not exist")
    if not os.access(parent, os.W_OK):
        raise BakeError(f"output directory {str(parent)!r} is not writable")
    return path, ext


def _check_tile(tile) -> int | None:
    if tile is None:
        return None
    if not isinstance(tile, (int, np.integer)) or not 16 <= tile <= 8192 or tile % 16:
        raise BakeError(f"--tile {tile}: accepted multiples of 16 in 16..8192")
    return int(tile)


def bake(recipe_or_name, path, *, size=DEFAULT_SIZE, depth_slices=None, channels=("color",),
         bit_depth=None, tileable=None, sets=(), tile=None, progress=True,
         memory_budget=DEFAULT_BUDGET) -> list[Path]:
    """Render a recipe to a file, tile by tile, atomically.

    Parameters
    ----------
    recipe_or_name : Recipe or str or PathLike
        A :class:`cellgl.recipe.Recipe`, a preset name (``cellgl presets``) or a recipe JSON path.
    path : str or PathLike
        Output file; the extension picks the format: ``.png``, ``.exr``, ``.tif``/``.tiff``,
        ``.npy``. Its directory must exist.
    size : int or (int, int) or str
        ``W``, ``(W, H)`` or ``"WxH[xD]"``; sides 1..65536.
    depth_slices : int, optional
        Bake a volume of this many slices, shape ``(D, H, W[, S])`` (``.npy`` and ``.tif`` only).
    channels : sequence of str
        Any of ``color`` (RGB), ``height``, ``normal`` (RGB), ``id``, ``F1``..``F4``. An ``.exr``
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
    progress : bool
        Draw a progress bar on stderr when there is more than one tile.
    memory_budget : int
        Bytes of working memory the bake aims to stay within beyond the process's baseline
        (render of one tile, plus one band of rows for PNG/EXR); sets the tile size.

    Returns
    -------
    list of pathlib.Path
        The files written.

    Raises
    ------
    BakeError (a ValueError)
        Bad extension, size, depth, channel, tile or ``--set``; the message names the value and
        what is accepted. Nothing is written.
    cellgl.recipe.RecipeError
        Unknown preset or bad recipe value.
    """
    path, ext = _check_path(path)
    fmt = FORMATS[ext]
    if isinstance(size, str):
        w, h, d = parse_size(size)
        depth_slices = depth_slices if depth_slices is not None else d
    else:
        w, h = (size, size) if isinstance(size, (int, np.integer)) else tuple(size)
        _check_size(w, h, None, f"size {w}x{h}")
    if depth_slices is not None:
        _check_size(w, h, depth_slices, f"size {w}x{h}x{depth_slices}")
        if not fmt.volume:
            raise BakeError(f"volume bake ({w}x{h}x{depth_slices}) to {ext}: volumes are "
                            f"written to .npy or .tif only")
    channels = parse_channels(channels)
    bits = _check_bits(ext, bit_depth)
    tile = _check_tile(tile)
    outputs = []
    for p, chs in _output_paths(path, channels):
        outputs.append(_Output(p, chs, tuple(_encoding(c, ext, bits) for c in chs)))
    if ext == ".exr" and not cio.have_exr():
        raise BakeError("writing .exr files needs the 'OpenEXR' package: "
                        "pip install 'cellgl[exr]'")
    if ext in (".tif", ".tiff") and not cio.have_tiff():
        raise BakeError("writing .tif files needs the 'tifffile' package: "
                        "pip install 'cellgl[tiff]'")
    recipe = _load(recipe_or_name, sets, tileable)
    if depth_slices is not None and recipe.get("dimension") < 3:
        raise BakeError(f"volume bake ({w}x{h}x{depth_slices}) needs a solid recipe: "
                        f"basis.dimension 3 or 4, got {recipe.get('dimension')} "
                        f"(try --set dimension=3)")
    _check_disk(path.parent, w, h, depth_slices, outputs, ext)

    written = []
    for out in outputs:
        file_bytes = sum(e.samples * e.dtype.itemsize for e in out.encodings)
        plan = _plan(w, h, depth_slices, ext, out.channels, tile, memory_budget, file_bytes)
        _bake_one(recipe, out, ext, plan, progress)
        written.append(out.path)
    return written


def _check_disk(directory: Path, w, h, d, outputs, ext) -> None:
    # Uncompressed formats (and the volume TIFF spool) need their full size on disk.
    if ext not in (".npy", ".tif", ".tiff"):
        return
    need = 0
    for out in outputs:
        px = w * h * (d or 1)
        per = sum(e.samples * e.dtype.itemsize for e in out.encodings)
        need += px * per * (2 if (ext != ".npy" and d) else (1 if ext == ".npy" else 0))
    try:
        free = shutil.disk_usage(directory).free
    except OSError:
        return
    if need > free:
        raise BakeError(f"not enough disk space in {str(directory)!r}: the bake needs about "
                        f"{need / 2**30:.1f} GiB, {free / 2**30:.1f} GiB free")


def _render_tiles(recipe, out: _Output, plan: _Plan, bar: _Progress) -> Iterator[tuple]:
    """Yield (x0, y0, {channel: encoded array}) row-major; arrays (h, w[, S]) or (D, h, w[, S])."""
    from . import texture

    for x0, y0, tw, th in plan.tiles():
        res = texture.render(recipe, plan.width, plan.height, channels=out.channels,
                             x0=x0, y0=y0, tile_w=tw, tile_h=th, depth=plan.slices)
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
    return json.dumps({"generator": "cellgl", "recipe": rec, "size": size,
                       "channels": list(out.channels)}, sort_keys=True, default=str)


def _bake_one(recipe, out: _Output, ext: str, plan: _Plan, progress: bool) -> None:
    bar = _Progress(plan.count, f"baking {out.path.name}", progress)
    meta = _meta(recipe, out, plan)
    try:
        with cio.atomic_path(out.path) as tmp:
            tiles = _render_tiles(recipe, out, plan, bar)
            if ext == ".png":
                (e,) = out.encodings
                cio.write_png(tmp, (b[e.channel] for b in _bands(tiles, plan)), plan.width,
                              plan.height, e.samples, e.dtype.itemsize * 8,
                              text={"Software": "cellgl", "cellgl": meta})
            elif ext == ".exr":
                _write_exr(tmp, tiles, out, plan, meta)
            elif ext == ".npy":
                (e,) = out.encodings
                cio.write_npy(tmp, _npy_pieces(tiles, e, plan), _shape(e, plan), e.dtype)
            else:
                _write_tiff(tmp, tiles, out, plan, meta)
    finally:
        bar.close()


def _shape(e: _Encoding, plan: _Plan) -> tuple[int, ...]:
    lead = (plan.slices,) if plan.slices else ()
    return lead + (plan.height, plan.width) + ((e.samples,) if e.samples > 1 else ())


def _npy_pieces(tiles, e: _Encoding, plan: _Plan):
    for x0, y0, enc in tiles:
        a = enc[e.channel]
        lead = (slice(None),) if plan.slices else ()
        th, tw = a.shape[len(lead):len(lead) + 2]
        yield lead + (slice(y0, y0 + th), slice(x0, x0 + tw)), a


def _write_exr(tmp, tiles, out: _Output, plan: _Plan, meta: str) -> None:
    dtypes = {}
    for e in out.encodings:
        for name in _exr_names(e.channel):
            dtypes[name] = e.dtype

    def split(band):
        res = {}
        for e in out.encodings:
            a = band[e.channel]
            names = _exr_names(e.channel)
            if len(names) == 1:
                res[names[0]] = a
            else:
                for i, name in enumerate(names):
                    res[name] = a[..., i]
        return res

    cio.write_exr(tmp, (split(b) for b in _bands(tiles, plan)), plan.width, plan.height,
                  dtypes, attributes={"cellgl": meta})


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
    with cio.scratch_path(out.path.parent, suffix=".spool.npy") as spool:
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
# command line: cellgl bake
# --------------------------------------------------------------------------------------------

_EPILOG = """\
formats (from the extension) and --depth (bits per sample):
  .png  8 (default) or 16     .exr  16 (half) or 32 (float, default)
  .tif  8, 16 or 32 (float, default; tiled)     .npy  32 (float32)
channels: color (RGB), height, normal (RGB), id (uint32; false colour in .png), F1..F4.
  An .exr holds every channel asked for; other formats write <stem>_<channel><ext> each.
examples:
  cellgl bake flagstone -o flagstone.png
  cellgl bake flagstone -o flagstone.exr --size 2048 --channels color,height,normal
  cellgl bake my_recipe.json -o big.tif --size 16384x16384 --tileable
  cellgl bake flagstone -o vol.npy --size 64x64x64 --channels F1
"""


def add_parser(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Declare ``cellgl bake``'s arguments on a subparsers object."""
    p = sub.add_parser(
        "bake", help="render a preset or recipe to .png/.exr/.tif/.npy",
        description="Render a preset or recipe JSON to an image or volume file.",
        epilog=_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("recipe", metavar="PRESET_OR_RECIPE",
                   help="a preset name (cellgl presets) or a recipe .json file")
    p.add_argument("-o", "--output", required=True, metavar="FILE",
                   help="output file: .png, .exr, .tif/.tiff or .npy")
    p.add_argument("--size", default=f"{DEFAULT_SIZE[0]}x{DEFAULT_SIZE[1]}", metavar="W[xH[xD]]",
                   help="pixels (default %(default)s); a third number bakes a volume of D slices")
    p.add_argument("--set", dest="sets", action="append", default=[], metavar="NAME=VALUE",
                   help="override a recipe parameter (repeatable)")
    p.add_argument("--tileable", action="store_true", default=None,
                   help="make the texture wrap around at its edges")
    p.add_argument("--channels", action="append", default=None, metavar="LIST",
                   help="comma-separated: color, height, normal, id, F1..F4 (default color)")
    p.add_argument("--depth", default=None, metavar="BITS",
                   help="bits per sample: 8|16|32 (default per format, see below)")
    p.add_argument("--tile", default=None, metavar="N",
                   help="advanced: render N x N tiles (multiple of 16) instead of a size chosen "
                        "from --memory")
    p.add_argument("--memory", default=None, metavar="MB",
                   help=f"advanced: MB of working memory to stay within; sets the tile size "
                        f"(default {DEFAULT_BUDGET >> 20})")
    p.add_argument("--frames", default=None, metavar="N",
                   help="a loop of N frames of an orbiting recipe (orbit_phase + k/N): FILE_0000.png "
                        ".. FILE_<N-1>.png, or one animated .webp/.gif (cellgl/frames.py)")
    p.add_argument("--fps", default="24", metavar="FPS",
                   help="frames per second of an animated .webp/.gif (default %(default)s)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar, no summary")
    return p


def _int_arg(flag: str, text, lo: int, hi: int) -> int:
    try:
        v = int(str(text).strip())
    except ValueError:
        raise BakeError(f"{flag} {text!r}: expected a whole number in {lo}..{hi}") from None
    if not lo <= v <= hi:
        raise BakeError(f"{flag} {v}: out of range; accepted {lo}..{hi}")
    return v


def run_cli(args: argparse.Namespace) -> int:
    """Run ``cellgl bake`` from parsed arguments; errors are raised as BakeError (ValueError)."""
    budget = DEFAULT_BUDGET if args.memory is None else \
        _int_arg("--memory", args.memory, 1, 1 << 20) << 20
    tile = None if args.tile is None else _int_arg("--tile", args.tile, 16, 8192)
    t0 = time.perf_counter()
    try:
        if getattr(args, "frames", None) is not None:
            from .frames import MAX_FPS, MAX_FRAMES, bake_frames

            try:
                fps = float(args.fps)
            except ValueError:
                raise BakeError(f"--fps {args.fps!r}: accepted a number in 1..{MAX_FPS}") from None
            paths = bake_frames(args.recipe, args.output, _int_arg("--frames", args.frames, 1, MAX_FRAMES),
                                fps=fps, size=args.size, channels=tuple(args.channels or ("color",)),
                                bit_depth=args.depth, tileable=args.tileable, sets=args.sets, tile=tile,
                                progress=not args.quiet, memory_budget=budget)
        else:
            paths = bake(args.recipe, args.output, size=args.size,
                         channels=tuple(args.channels or ("color",)), bit_depth=args.depth,
                         tileable=args.tileable, sets=args.sets, tile=tile,
                         progress=not args.quiet, memory_budget=budget)
    except OSError as exc:
        where = f" {exc.filename}" if exc.filename else ""
        raise BakeError(f"cannot write{where}: {exc.strerror or exc}") from None
    if not args.quiet:
        secs = time.perf_counter() - t0
        for p in paths:
            print(f"wrote {p} ({os.path.getsize(p) / 1024:.0f} KiB, {secs:.1f} s)",
                  file=sys.stderr)
    return 0
