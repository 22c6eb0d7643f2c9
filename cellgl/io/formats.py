"""Image and volume writers for ``cellgl bake``: PNG, OpenEXR, TIFF, NPY, all atomic and streaming.

Every writer takes its pixels as an iterator, so an image far larger than memory is written piece
by piece as it is rendered:

=========  ===================================  ==================================================
format     pieces                               stored as
=========  ===================================  ==================================================
``.png``   full-width bands of rows, top first  8 or 16 bit gray / RGB / RGBA (no extra package)
``.exr``   full-width bands of rows, top first  half or float channels, uint for ids (``OpenEXR``)
``.tif``   tiles in row-major order             tiled TIFF, uint8/uint16/float32/uint32
                                                (``tifffile``), volumes as one page per slice
``.npy``   ``(index, array)`` pieces, any order a ``.npy`` memory map (``numpy``)
=========  ===================================  ==================================================

Writes are atomic: the data goes to a temporary file in the destination's directory that replaces
the destination (``os.replace``) only once it is complete. On any error, ``KeyboardInterrupt``
included, the temporary file is removed and the destination is left as it was.
"""

from __future__ import annotations

import contextlib
import os
import struct
import zlib
from collections.abc import Iterable, Iterator, Mapping, Sequence
from pathlib import Path

import numpy as np

from cellgl.io.tempfiles import atomic_paths, reserve, scratch_path

__all__ = [
    "atomic_path",
    "scratch_path",
    "write_png",
    "write_exr",
    "write_tiff",
    "write_npy",
    "have_exr",
    "have_tiff",
]


# --------------------------------------------------------------------------------------------
# atomic files
# --------------------------------------------------------------------------------------------


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike, suffix: str | None = None) -> Iterator[Path]:
    """Yield a temporary path next to ``path``; on success move it onto ``path``.

    Parameters
    ----------
    path : str or PathLike
        The destination. Its directory must exist.
    suffix : str, optional
        Suffix of the temporary name (default: the destination's, so libraries that look at the
        extension see the right one).

    Yields
    ------
    pathlib.Path
        A fresh, empty file in the destination's directory, named
        ``.<stem>.cellgl-<pid>@<host>.<random>.part<ext>`` (at most 255 bytes; see
        :mod:`cellgl.io.tempfiles`). Write to it (by path) inside the ``with`` block.

    Notes
    -----
    On leaving the block normally the file is flushed to disk, given the usual permissions
    (``0o666`` less the umask) and renamed onto ``path`` with ``os.replace`` (atomic on POSIX
    and Windows). On any exception, ``KeyboardInterrupt`` included, it is deleted and the
    exception propagates; ``path`` is untouched. :func:`cellgl.io.tempfiles.atomic_paths` does
    the same for several files at once.
    """
    with atomic_paths([path], ext=suffix) as (tmp,):
        yield tmp


# --------------------------------------------------------------------------------------------
# PNG (written chunk by chunk with zlib: 16-bit RGB(A) and streaming, which Pillow cannot do)
# --------------------------------------------------------------------------------------------

_PNG_COLOR_TYPE = {1: 0, 2: 4, 3: 2, 4: 6}  # samples per pixel -> PNG colour type
_IDAT_SIZE = 1 << 20


def _chunk(tag: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data))


def write_png(path: str | os.PathLike, bands: Iterable[np.ndarray], width: int, height: int,
              samples: int, bit_depth: int, *, text: Mapping[str, str] | None = None) -> None:
    """Write a PNG from full-width bands of rows, never holding more than two bands.

    Parameters
    ----------
    path : str or PathLike
        File to write (not atomic by itself: use :func:`atomic_path`).
    bands : iterable of ndarray
        Row bands from top to bottom, each ``(rows, width)`` for gray or ``(rows, width, samples)``,
        dtype ``uint8`` for ``bit_depth=8``, ``uint16`` for 16. Their rows must add up to
        ``height``. A band is read after the next one is asked for: each must be an array of its
        own (not one buffer filled again).
    width, height : int
        Image size in pixels (1 .. 2**31 - 1).
    samples : {1, 2, 3, 4}
        Gray, gray + alpha, RGB, RGBA.
    bit_depth : {8, 16}
    text : mapping of str to str, optional
        ``tEXt`` chunks (keyword -> Latin-1 text), e.g. the recipe as JSON.

    Notes
    -----
    Every row uses PNG filter 2 ("up"), computed with NumPy per band; the stream is compressed
    with zlib level 6 and flushed into ``IDAT`` chunks of about 1 MiB. The filter, the compression
    and the writing of a band run on a thread of their own while ``bands`` makes the next one
    (zlib and NumPy release the GIL): a bake's encoding overlaps its rendering. One zlib stream,
    band after band, in order: the same bytes as encoding after rendering.
    """
    from concurrent.futures import ThreadPoolExecutor      # (on first use: not at `import cellgl`)

    if bit_depth not in (8, 16):
        raise ValueError(f"PNG bit depth {bit_depth}: accepted 8, 16")
    if samples not in _PNG_COLOR_TYPE:
        raise ValueError(f"PNG samples per pixel {samples}: accepted 1, 2, 3, 4")
    dtype = np.dtype(">u2") if bit_depth == 16 else np.dtype(np.uint8)
    row_bytes = width * samples * dtype.itemsize
    comp = zlib.compressobj(6)
    state = {"prev": np.zeros(row_bytes, np.uint8), "pending": bytearray()}
    rows_done = 0

    def encode(f, band: np.ndarray) -> None:
        n = band.shape[0]
        raw = np.ascontiguousarray(band, dtype=dtype).view(np.uint8).reshape(n, row_bytes)
        filtered = np.empty((n, row_bytes + 1), np.uint8)
        filtered[:, 0] = 2  # "up": byte minus the byte above, mod 256
        np.subtract(raw[0], state["prev"], out=filtered[0, 1:])
        np.subtract(raw[1:], raw[:-1], out=filtered[1:, 1:])
        state["prev"] = raw[-1].copy()
        pending = state["pending"]
        pending += comp.compress(filtered)
        if len(pending) >= _IDAT_SIZE:
            f.write(_chunk(b"IDAT", bytes(pending)))
            pending.clear()

    with open(path, "wb") as f, ThreadPoolExecutor(1, thread_name_prefix="cellgl-png") as pool:
        f.write(b"\x89PNG\r\n\x1a\n")
        f.write(_chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, bit_depth,
                                            _PNG_COLOR_TYPE[samples], 0, 0, 0)))
        for key, value in (text or {}).items():
            f.write(_chunk(b"tEXt", key.encode("latin-1") + b"\0" + value.encode("latin-1")))
        busy = None
        try:
            for band in bands:          # (the next band is made here while the last one encodes)
                band = np.asarray(band)
                n = band.shape[0]
                if band.ndim < 2 or band.shape[1] != width or band.size != n * width * samples:
                    raise ValueError(f"PNG band of shape {band.shape}: expected ({n}, {width}"
                                     f"{'' if samples == 1 else f', {samples}'})")
                rows_done += n
                if busy is not None:
                    busy.result()
                busy = pool.submit(encode, f, band)
            if busy is not None:
                busy.result()
        except BaseException:
            if busy is not None:
                busy.cancel()
            raise
        if rows_done != height:
            raise ValueError(f"PNG got {rows_done} rows, expected {height}")
        pending = state["pending"]
        pending += comp.flush()
        f.write(_chunk(b"IDAT", bytes(pending)))
        f.write(_chunk(b"IEND", b""))


# --------------------------------------------------------------------------------------------
# OpenEXR
# --------------------------------------------------------------------------------------------


def have_exr() -> bool:
    """Whether the ``OpenEXR`` package (``pip install OpenEXR``, extra ``cellgl[exr]``) imports."""
    try:
        import OpenEXR  # noqa: F401
    except ImportError:
        return False
    return True


def _require(module: str, extra: str, ext: str):
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise ValueError(f"writing {ext} files needs the '{module}' package: "
                         f"pip install 'cellgl[{extra}]' (or pip install {module})") from exc


#: EXR pixel types by NumPy dtype.
_EXR_TYPES = {np.dtype(np.float16): "HALF", np.dtype(np.float32): "FLOAT",
              np.dtype(np.uint32): "UINT"}


def write_exr(path: str | os.PathLike, bands: Iterable[Mapping[str, np.ndarray]], width: int,
              height: int, channels: Mapping[str, np.dtype | str], *,
              attributes: Mapping[str, str] | None = None) -> None:
    """Write a ZIP-compressed scanline OpenEXR file band by band.

    Parameters
    ----------
    path : str or PathLike
        File to write (use :func:`atomic_path` for atomicity).
    bands : iterable of dict
        Row bands from top to bottom: channel name -> ``(rows, width)`` array of that channel's
        dtype.
    width, height : int
    channels : mapping of str to dtype
        Channel name -> ``float16`` (HALF), ``float32`` (FLOAT) or ``uint32`` (UINT).
    attributes : mapping of str to str, optional
        Extra string attributes in the header (e.g. ``cellgl_recipe``).

    Notes
    -----
    Streams through the ``OpenEXR.OutputFile`` scanline API where the installed ``OpenEXR``
    still has it (3.x does); otherwise the bands are gathered and written with ``OpenEXR.File``.
    """
    OpenEXR = _require("OpenEXR", "exr", ".exr")
    chans = {name: np.dtype(dt) for name, dt in channels.items()}
    for name, dt in chans.items():
        if dt not in _EXR_TYPES:
            raise ValueError(f"EXR channel {name!r} dtype {dt}: accepted float16, float32, uint32")
    attributes = dict(attributes or {})
    rows_done = 0

    def checked(band):
        nonlocal rows_done
        out = {}
        n = None
        for name, dt in chans.items():
            a = np.ascontiguousarray(band[name], dtype=dt)
            if a.ndim != 2 or a.shape[1] != width or (n is not None and a.shape[0] != n):
                raise ValueError(f"EXR band for {name!r} has shape {a.shape}, "
                                 f"expected (rows, {width})")
            n = a.shape[0]
            out[name] = a
        rows_done += n
        return n, out

    if hasattr(OpenEXR, "OutputFile") and hasattr(OpenEXR, "Header"):
        import Imath

        header = OpenEXR.Header(width, height)
        header["channels"] = {
            name: Imath.Channel(Imath.PixelType(getattr(Imath.PixelType, _EXR_TYPES[dt])))
            for name, dt in chans.items()}
        header["compression"] = Imath.Compression(Imath.Compression.ZIP_COMPRESSION)
        for key, value in attributes.items():
            header[key] = value.encode("utf-8")
        out = OpenEXR.OutputFile(str(path), header)
        try:
            for band in bands:
                n, arrays = checked(band)
                out.writePixels({k: a.tobytes() for k, a in arrays.items()}, n)
        finally:
            out.close()
    else:  # pragma: no cover - a future OpenEXR without the old API
        parts = {name: [] for name in chans}
        for band in bands:
            _, arrays = checked(band)
            for k, a in arrays.items():
                parts[k].append(a)
        header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
        header.update(attributes)
        data = {k: np.concatenate(v) if v else np.zeros((0, width), chans[k])
                for k, v in parts.items()}
        with OpenEXR.File(header, data) as f:
            f.write(str(path))
    if rows_done != height:
        raise ValueError(f"EXR got {rows_done} rows, expected {height}")


# --------------------------------------------------------------------------------------------
# TIFF
# --------------------------------------------------------------------------------------------


def have_tiff() -> bool:
    """Whether ``tifffile`` (``pip install tifffile``, extra ``cellgl[tiff]``) imports."""
    try:
        import tifffile  # noqa: F401
    except ImportError:
        return False
    return True


def write_tiff(path: str | os.PathLike, tiles: Iterable[np.ndarray], shape: Sequence[int],
               dtype: np.dtype | str, tile: tuple[int, int], *, rgb: bool = False,
               description: str | None = None) -> None:
    """Write a zlib-compressed tiled TIFF from tiles produced in row-major order.

    Parameters
    ----------
    path : str or PathLike
        File to write (use :func:`atomic_path` for atomicity).
    tiles : iterable of ndarray
        The tiles of each page in row-major order (left to right, then top to bottom), pages one
        after the other. Tiles on the right and bottom edges may be cut to the image.
    shape : tuple of int
        ``(H, W)`` gray, ``(H, W, S)`` with ``rgb=True`` and ``S`` in 3, 4 for RGB(A), or a volume
        ``(D, H, W)`` / ``(D, H, W, S)`` written as ``D`` pages.
    dtype : dtype
        ``uint8``, ``uint16``, ``uint32`` or ``float32``.
    tile : (int, int)
        Tile height and width, multiples of 16.
    rgb : bool
        The last axis holds RGB or RGBA samples (alpha stored as unassociated alpha).
    description : str, optional
        ImageDescription tag (e.g. the recipe as JSON).
    """
    tifffile = _require("tifffile", "tiff", ".tif")
    th, tw = tile
    if th % 16 or tw % 16 or th <= 0 or tw <= 0:
        raise ValueError(f"TIFF tile {th}x{tw}: both sides must be positive multiples of 16")
    shape = tuple(int(s) for s in shape)
    kwargs = dict(photometric="rgb" if rgb else "minisblack", compression="zlib",
                  metadata=None)
    if rgb and shape[-1] == 4:
        kwargs["extrasamples"] = ("unassalpha",)
    if description is not None:
        kwargs["description"] = description
    tifffile.imwrite(str(path), data=iter(tiles), shape=shape, dtype=np.dtype(dtype),
                     tile=(th, tw), **kwargs)


# --------------------------------------------------------------------------------------------
# NPY
# --------------------------------------------------------------------------------------------


def write_npy(path: str | os.PathLike, pieces: Iterable[tuple[tuple, np.ndarray]],
              shape: Sequence[int], dtype: np.dtype | str) -> None:
    """Write a ``.npy`` array piece by piece through a memory map.

    Parameters
    ----------
    path : str or PathLike
        File to write (use :func:`atomic_path` for atomicity).
    pieces : iterable of (index, ndarray)
        ``out[index] = array`` for each piece, in any order; ``index`` is a tuple of slices.
    shape : tuple of int
    dtype : dtype
    """
    mm = np.lib.format.open_memmap(str(path), mode="w+", dtype=np.dtype(dtype),
                                   shape=tuple(int(s) for s in shape))
    try:
        # The map's file is sparse: on a disk that fills up, a write into it is a SIGBUS (no
        # message, no cleanup). Reserve its blocks first: a full disk is then an OSError here.
        reserve(path, mm.offset + mm.nbytes)
        for index, piece in pieces:
            mm[index] = piece
        mm.flush()
    finally:
        del mm
