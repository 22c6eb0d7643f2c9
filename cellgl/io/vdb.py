"""OpenVDB volumes (``.vdb``): dense voxel arrays to sparse grids, written through OpenVDB's own
Python binding (the ``openvdb`` module), one grid per channel sample.

No binding is on PyPI that is maintained (``pyopenvdb`` stopped in 2020); the maintained ones
are OpenVDB's own nanobind module as distributions build it: Blender's (the ``bpy`` wheel bundles
``openvdb`` with its Python modules, the ``[blender]`` extra), Debian's ``python3-openvdb``, a
conda-forge ``openvdb``. :func:`binding` takes ``import openvdb`` where it works, else the one in
the installed ``bpy`` wheel, loaded alone from its file (importing ``bpy`` itself would start
Blender, seconds and hundreds of MB, to reach one extension module). Without either,
:func:`require` raises :class:`VdbUnavailable`, which callers turn into their one clear error
before any work.

What a file holds (:func:`write_vdb`):

* one grid per channel sample: ``FloatGrid`` for float samples, ``Int64Grid`` for ``uint32``
  ids (exact; a float grid would round ids above 2^24); a channel of several samples gets one
  grid per sample, named ``<channel>.<R|G|B|A>`` (``color.R``, ``normal.G``), a one-sample
  channel its own name (``height``, ``F1``);
* index ``(i, j, k)`` is column ``i``, row ``j``, slice ``k`` of the ``(D, H, W)`` volume, and
  the transform maps it to the voxel's centre in texture space, ``((i + 0.5) / W, (j + 0.5) / H,
  (k + 0.5) / D)``: voxel size ``(1 / W, 1 / H, 1 / D)``, the volume the unit cube (a tileable
  recipe repeats with period 1 along each axis);
* grid metadata: ``cellgl_channel`` and ``cellgl_sample`` (what the grid holds), ``colorspace``
  (the Color Interop Forum id, colour grids only; data grids carry none), and the file metadata
  ``creator`` = ``cellgl`` and ``cellgl`` = the caller's JSON (recipe, size, channels).

Voxels equal to the background (0) are stored inactive, as OpenVDB's dense-to-sparse copy does
at tolerance 0; reading back gives 0 there, so the dense array returns exactly.
"""
from __future__ import annotations

import glob
import importlib
import importlib.util
import os
import sys
from collections.abc import Iterable, Mapping
from pathlib import Path

import numpy as np

__all__ = ["VdbUnavailable", "binding", "have_vdb", "require", "grid_names", "write_vdb", "read_vdb", "SAMPLE_NAMES"]

#: names of a multi-sample channel's grids, by sample
SAMPLE_NAMES = ("R", "G", "B", "A")


class VdbUnavailable(ImportError):
    """No OpenVDB Python binding imports (see the module docstring for where one comes from)."""


_HOW = ("writing .vdb files needs OpenVDB's Python binding (the 'openvdb' module): install "
        "cellgl[blender] (the bpy wheel bundles it), or a distribution's build (Debian "
        "python3-openvdb, conda-forge openvdb) where `import openvdb` works")


def _bundled_path() -> str | None:
    """The ``openvdb`` extension module inside the installed ``bpy`` wheel, found without importing bpy."""
    try:
        spec = importlib.util.find_spec("bpy")
    except (ImportError, ValueError):
        return None
    if spec is None or not spec.submodule_search_locations:
        return None
    tag = f"python{sys.version_info[0]}.{sys.version_info[1]}"
    for root in spec.submodule_search_locations:
        hits = sorted(glob.glob(os.path.join(root, "*", "python", "lib", tag, "site-packages", "openvdb*.so")))
        if hits:
            return hits[-1]
    return None


def binding():
    """The ``openvdb`` module: ``import openvdb``, else the ``bpy`` wheel's (registered as
    ``openvdb`` so a later ``import openvdb`` gets the same one). Raises :class:`VdbUnavailable`."""
    if sys.modules.get("openvdb") is not None:
        return sys.modules["openvdb"]
    try:
        return importlib.import_module("openvdb")
    except ImportError:
        pass
    path = _bundled_path()
    if path is None:
        raise VdbUnavailable(_HOW)
    try:
        spec = importlib.util.spec_from_file_location("openvdb", path)
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
    except (ImportError, OSError) as exc:
        raise VdbUnavailable(f"{_HOW} ({path} would not load: {exc})") from None
    sys.modules["openvdb"] = mod
    return mod


def have_vdb() -> bool:
    """Whether :func:`binding` finds an OpenVDB binding."""
    try:
        binding()
    except VdbUnavailable:
        return False
    return True


def require():
    """:func:`binding`, for callers that check before any work (raises :class:`VdbUnavailable`)."""
    return binding()


def grid_names(channel: str, samples: int) -> tuple[str, ...]:
    """The grid names of a channel of ``samples`` samples (``height``; ``color.R``, ...)."""
    if samples == 1:
        return (channel,)
    if not 1 <= samples <= len(SAMPLE_NAMES):
        raise ValueError(f"channel {channel!r} of {samples} samples: a .vdb grid set takes 1..4 per channel")
    return tuple(f"{channel}.{SAMPLE_NAMES[i]}" for i in range(samples))


def _transform(vdb, size):
    w, h, d = size
    return vdb.createLinearTransform([[1.0 / w, 0.0, 0.0, 0.0], [0.0, 1.0 / h, 0.0, 0.0],
                                      [0.0, 0.0, 1.0 / d, 0.0], [0.5 / w, 0.5 / h, 0.5 / d, 1.0]])


def write_vdb(path: str | os.PathLike, size: tuple[int, int, int], channels: Mapping[str, tuple[int, np.dtype]],
              pieces: Iterable[tuple[int, int, Mapping[str, np.ndarray]]], *, metadata: str = "",
              colorspaces: Mapping[str, str] | None = None) -> None:
    """Write a volume to ``path`` (the caller makes it atomic: cellgl bakes pass a temporary file).

    Parameters
    ----------
    path : str or PathLike
        The file to write (any name; OpenVDB does not look at the extension).
    size : (W, H, D)
        The whole volume's extent in voxels.
    channels : {channel: (samples, dtype)}
        Each channel's sample count (1..4) and dtype: float32, or uint32 (ids).
    pieces : iterable of (x0, y0, {channel: array})
        Columns of the volume: arrays ``(D, h, w)`` or ``(D, h, w, samples)`` placed at column
        ``x0``, row ``y0``; any order, together covering ``W x H``.
    metadata : str
        The file's ``cellgl`` metadata (JSON text).
    colorspaces : {channel: str}, optional
        The colour-space id of each colour channel, stored on its grids.

    Raises
    ------
    VdbUnavailable
        No OpenVDB binding.
    ValueError
        A piece of the wrong shape, or a dtype other than float32 / uint32.
    """
    vdb = binding()
    w, h, d = (int(x) for x in size)
    spaces = dict(colorspaces or {})
    grids: dict[str, list] = {}
    for ch, (samples, dtype) in channels.items():
        dtype = np.dtype(dtype)
        if dtype not in (np.dtype(np.float32), np.dtype(np.uint32)):
            raise ValueError(f"channel {ch!r}: dtype {dtype} is not stored in .vdb; accepted float32, uint32")
        made = []
        for i, name in enumerate(grid_names(ch, samples)):
            g = vdb.FloatGrid() if dtype == np.float32 else vdb.Int64Grid()
            g.name = name
            g.transform = _transform(vdb, (w, h, d))
            g["cellgl_channel"] = ch
            g["cellgl_sample"] = SAMPLE_NAMES[i] if samples > 1 else ""
            if ch in spaces:
                g["colorspace"] = spaces[ch]
            made.append(g)
        grids[ch] = made
    for x0, y0, arrays in pieces:
        for ch, made in grids.items():
            a = np.asarray(arrays[ch])
            if a.ndim == 3:
                a = a[..., None]
            if a.ndim != 4 or a.shape[0] != d or a.shape[3] != len(made) or x0 + a.shape[2] > w or y0 + a.shape[1] > h:
                raise ValueError(f"channel {ch!r}: piece of shape {a.shape} at ({x0}, {y0}) does not fit a "
                                 f"{w}x{h}x{d} volume of {len(made)} samples")
            for s, g in enumerate(made):
                col = a[..., s].transpose(2, 1, 0)          # (D, h, w) -> index order (i, j, k)
                col = np.ascontiguousarray(col, np.float32 if isinstance(g, vdb.FloatGrid) else np.int64)
                g.copyFromArray(col, (int(x0), int(y0), 0))
    vdb.write(os.fspath(path), grids=[g for made in grids.values() for g in made],
              metadata={"creator": "cellgl", "cellgl": metadata})


def read_vdb(path: str | os.PathLike) -> tuple[dict[str, np.ndarray], dict, dict[str, dict]]:
    """Read a ``.vdb`` back with the binding: ``({grid name: (D, H, W) array}, file metadata,
    {grid name: grid metadata})``, the arrays over the index box ``[0, W) x [0, H) x [0, D)``
    stated by the file's ``cellgl`` size (float32, or int64 for integer grids)."""
    import json

    vdb = binding()
    grids, meta = vdb.readAll(os.fspath(Path(path)))
    w, h, d = json.loads(meta["cellgl"])["size"]
    out, gmeta = {}, {}
    for g in grids:
        a = np.zeros((w, h, d), np.float32 if isinstance(g, vdb.FloatGrid) else np.int64)
        g.copyToArray(a, (0, 0, 0))
        out[g.name] = a.transpose(2, 1, 0).copy()
        gmeta[g.name] = dict(g.metadata)
    return out, dict(meta), gmeta
