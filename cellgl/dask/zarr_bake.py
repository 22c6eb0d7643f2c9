"""``cellgl bake RECIPE -o out.zarr``: a resumable Zarr v3 bake on a Dask cluster.

Layout of ``out.zarr`` (a Zarr v3 group):

``<channel>``
    one array per channel, ``(H, W)`` or ``(H, W, S)`` (``color`` RGBA, ``normal`` xyz),
    float32 (``id``: uint32), chunks of ``chunk x chunk`` pixels: exactly what
    :func:`cellgl.render` gives for the whole image.
``chunk_checksums``
    ``(rows, cols)`` uint64, one element (and one stored chunk) per image chunk: a checksum of
    that chunk's data in every channel, written after the data. 0 means not written yet.
attributes ``cellgl``
    generator, cellgl version, the recipe (JSON form), size, channels, chunk and, with
    ``color``, ``colorspace`` ``{"color": id}``.

Colour, as every float file of cellgl (:mod:`cellgl.io.colour`): the ``color`` array's RGB is
scene-linear Rec.709 by default (the exact sRGB decoding of the render's sRGB-encoded colour,
rounded to float32 once; alpha as rendered), or sRGB-encoded with ``colorspace="srgb"``, and
the array's attributes say which: ``colorInteropID`` (``lin_rec709_scene`` /
``srgb_rec709_scene``), ``colorspace`` (OCIO's name) and ``chromaticities`` (Rec.709 primaries,
D65 white). Data arrays (height, normal, id, F1..F4, ...) are as rendered and carry no colour
attribute. (:func:`cellgl.to_dask` is an array of :func:`cellgl.render`'s values, sRGB-encoded.)

Each chunk is one task: the worker renders it, writes it into every channel array, then writes
its checksum. A rerun of the same bake finds the group, checks that it was made by the same
request (recipe, size, channels, chunk, cellgl version), reads each chunk that has a checksum
back, and re-renders only the chunks that are missing or whose data does not match.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from cellgl._version import __version__
from cellgl.bake import core as _bake
from cellgl.dask.blocks import (DEFAULT_CHUNK, MAX_CHUNK, MAX_SIDE, DaskError, Layout, dtype, load, pair,
                     render_block, require, samples)
from cellgl.dask.cluster import cluster_client, log, map_tasks
from cellgl.io.colour import COLORSPACES, REC709_CHROMATICITIES, check_colorspace, encode_linear

__all__ = ["bake_zarr", "checksum", "CHECKSUMS"]

CHECKSUMS = "chunk_checksums"   #: name of the per-chunk checksum array in the group
#: working memory of one render per pixel beyond its outputs (cellgl.io.spec, measured on llvmpipe)
_RENDER_BYTES = _bake.RENDER_BYTES_PER_PIXEL


def checksum(arrays: dict[str, np.ndarray]) -> int:
    """64-bit BLAKE2b of a chunk's channels (names, shapes, dtypes, bytes); never 0."""
    h = hashlib.blake2b(digest_size=8)
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(f"{name}:{a.dtype.str}:{a.shape};".encode())
        h.update(memoryview(a).cast("B"))
    return int.from_bytes(h.digest(), "little") | 1


def _parse_size(size) -> tuple[int, int]:
    if isinstance(size, str):
        parts = size.strip().lower().replace("*", "x").split("x")
        try:
            nums = [int(p) for p in parts]
        except ValueError:
            nums = []
        if len(nums) not in (1, 2):
            raise DaskError(f"--size {size!r}: expected W or WxH with whole numbers for a .zarr "
                            f"bake (no volumes), e.g. 262144 or 8192x4096")
        w, h = nums[0], nums[-1]
    else:
        w, h = pair("size", size, "W, (W, H) or 'WxH'")
    for name, v in (("width", w), ("height", h)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 1 <= v <= MAX_SIDE:
            raise DaskError(f"size: {name} {v!r} is out of range; accepted 1..{MAX_SIDE}")
    return int(w), int(h)


def _meta(layout: Layout, chunk: int, space: str | None) -> dict:
    meta = {"generator": "cellgl", "version": __version__, "recipe": layout.recipe.to_dict(),
            "size": [layout.width, layout.height], "channels": list(layout.channels),
            "chunk": chunk}
    if space is not None and "color" in layout.channels:
        meta["colorspace"] = {"color": COLORSPACES[space].interop_id}
    return meta


def _colour_attributes(interop_id: str) -> dict:
    """The ``color`` array's attributes: what its RGB holds (as the EXR's header says it)."""
    cs = next(c for c in COLORSPACES.values() if c.interop_id == interop_id)
    r, g, b, w = REC709_CHROMATICITIES
    return {"colorInteropID": cs.interop_id, "colorspace": cs.ocio_name,
            "chromaticities": {"red": r, "green": g, "blue": b, "white": w}}


def _encode(res: dict, meta_json: str) -> dict:
    """A rendered chunk as the group stores it: ``color``'s RGB decoded to linear where the
    bake's colour space is linear (alpha as rendered); every other channel as rendered."""
    space = json.loads(meta_json).get("colorspace", {}).get("color")
    if "color" in res and space == COLORSPACES["linear"].interop_id:
        c = np.array(res["color"], dtype=np.float32)
        c[..., :3] = encode_linear(c[..., :3], np.float32)
        res = {**res, "color": c}
    return res


def _create(path: Path, layout: Layout, meta: dict) -> None:
    """Make the empty group next to ``path`` and move it into place (never half-made)."""
    zarr = require("zarr")
    tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".part", dir=path.parent))
    try:
        root = zarr.open_group(str(tmp), mode="w", zarr_format=3, attributes={"cellgl": meta})
        for c in layout.channels:
            shape = layout.shape(c)
            chunks = (layout.chunk_h, layout.chunk_w) + shape[2:]
            spaces = meta.get("colorspace", {})
            root.create_array(c, shape=shape, chunks=chunks, dtype=dtype(c), fill_value=0,
                              dimension_names=("y", "x", "sample")[:len(shape)],
                              attributes=_colour_attributes(spaces[c]) if c in spaces else None)
        root.create_array(CHECKSUMS, shape=layout.grid, chunks=(1, 1), dtype=np.uint64,
                          fill_value=0, compressors=None, dimension_names=("row", "col"))
        os.rename(tmp, path)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def _check_existing(path: Path, meta: dict) -> None:
    zarr = require("zarr")
    try:
        old = dict(zarr.open_group(str(path), mode="r").attrs).get("cellgl")
    except Exception as exc:  # noqa: BLE001 - not a zarr group at all
        raise DaskError(f"output {str(path)!r} exists and is not a Zarr group ({exc}); "
                        f"remove it or choose another path") from None
    if not isinstance(old, dict):
        raise DaskError(f"output {str(path)!r} exists and was not made by cellgl; remove it or "
                        f"choose another path")
    differ = [k for k in meta if json.dumps(old.get(k), sort_keys=True)
              != json.dumps(meta[k], sort_keys=True)]
    if differ:
        raise DaskError(f"output {str(path)!r} holds a different bake (not the same "
                        f"{', '.join(differ)}), so it cannot be resumed; remove it or choose "
                        f"another path")


@functools.lru_cache(maxsize=4)
def _open(path: str, meta_json: str) -> dict:
    """The group's arrays by name, opened once per worker process and bake."""
    zarr = require("zarr")
    root = zarr.open_group(path, mode="r+")
    if json.dumps(root.attrs.get("cellgl"), sort_keys=True) != meta_json:
        raise RuntimeError(f"{path} changed while baking (its cellgl attributes differ)")
    return dict(root.arrays())


def _chunk_task(ij, layout: Layout, path: str, meta_json: str) -> int:
    """Bake chunk ``ij`` unless it is already there and checks out: 1 rendered, 0 kept."""
    i, j = ij
    root = _open(path, meta_json)
    sums = root[CHECKSUMS]
    y0, x0, h, w = layout.block(i, j)
    where = (slice(y0, y0 + h), slice(x0, x0 + w))
    try:
        recorded = int(sums[i, j])
        if recorded and checksum({c: root[c][where] for c in layout.channels}) == recorded:
            return 0
    except Exception:  # noqa: BLE001 - a damaged chunk or checksum file: render it again
        pass
    res = _encode(render_block(layout, i, j), meta_json)
    for c in layout.channels:
        root[c][where] = res[c]
    sums[i, j] = np.uint64(checksum(res))
    return 1


def bake_zarr(recipe_or_name, path, *, size=_bake.DEFAULT_SIZE, channels=("color",),
              chunk=DEFAULT_CHUNK, sets=(), tileable=None, scheduler=None, workers=None,
              threads=1, progress=True, colorspace=None) -> dict:
    """Bake a recipe to a Zarr v3 group on a Dask cluster, chunk by chunk, resumably.

    Parameters
    ----------
    recipe_or_name : Recipe or str or PathLike
        A recipe, preset name or recipe JSON file.
    path : str or PathLike
        The ``.zarr`` directory to make (its parent must exist), or one a previous run of the
        same bake left, to finish it.
    size : int or (int, int) or str
        ``W``, ``(W, H)`` or ``"WxH"``; sides 1..2**20 (1048576).
    channels : sequence of str
        As ``cellgl bake --channels``; each becomes an array of the group (``color`` is RGBA).
    chunk : int
        Chunk side in pixels, 16..4096 (default 1024); one chunk is one task and one render.
    sets, tileable
        Recipe overrides, as :func:`cellgl.bake.core.bake`.
    scheduler : str, optional
        A Dask scheduler address (``tcp://host:8786``) or scheduler file (``*.json``). Its
        workers must import cellgl and reach ``path`` (a shared file system). Default: a local
        cluster of ``workers`` processes (default one per core, fewer if memory is short) with
        ``threads`` threads each.
    progress : bool
        Progress bar and summary on stderr.
    colorspace : {"linear", "srgb"}, optional
        The ``color`` array's RGB: scene-linear Rec.709 (default) or sRGB-encoded, tagged
        either way (as ``cellgl bake --colorspace`` for float files; module docstring).

    Returns
    -------
    dict
        ``path``, ``chunks`` (total), ``rendered``, ``kept`` (already there and verified),
        ``seconds``.
    """
    require("zarr")
    require("distributed")
    path = Path(os.fspath(path))
    if path.suffix.lower() != ".zarr":
        raise DaskError(f"output {str(path)!r}: a Zarr bake goes to a directory named *.zarr")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise DaskError(f"output directory {str(parent)!r} does not exist")
    if isinstance(chunk, bool) or not isinstance(chunk, (int, np.integer)) \
            or not 16 <= chunk <= MAX_CHUNK:
        raise DaskError(f"chunk {chunk!r} is out of range; accepted a whole number in "
                        f"16..{MAX_CHUNK}")
    w, h = _parse_size(size)
    try:
        space = check_colorspace(colorspace, ".zarr", 32)
    except ValueError as exc:
        raise DaskError(str(exc)) from None
    layout = Layout.make(load(recipe_or_name, sets, tileable), (h, w), chunk, channels)
    meta = _meta(layout, int(chunk), space)
    t0 = time.perf_counter()
    resume = path.exists()
    if resume:
        _check_existing(path, meta)
    per_task = layout.chunk_w * layout.chunk_h * (
        _RENDER_BYTES * (1 + len(layout.channels)) // 2
        + 8 * sum(samples(c) for c in layout.channels))
    blocks = layout.blocks()
    bar = _bake.Progress(len(blocks), f"baking {path.name}", progress, unit="chunks")
    with bar:   # the line ends; "interrupted" after Ctrl-C
        with cluster_client(scheduler, workers, threads, per_task) as client:
            if resume:
                log(f"{path} exists: resuming (chunks already written are checked, not "
                    f"re-rendered)", not progress)
            else:
                _create(path, layout, meta)   # only once there is a cluster to fill it
            done = map_tasks(client, _chunk_task, blocks, layout, str(path.resolve()),
                             json.dumps(meta, sort_keys=True), on_done=lambda _: bar.step(),
                             key="cellgl-zarr-chunk")
    secs = time.perf_counter() - t0
    rendered = int(sum(done))
    summary = {"path": path, "chunks": len(blocks), "rendered": rendered,
               "kept": len(blocks) - rendered, "seconds": secs}
    log(f"wrote {path}: {w}x{h}, {len(blocks)} chunks ({rendered} rendered, "
        f"{len(blocks) - rendered} already done and verified), {secs:.1f} s", not progress)
    return summary

