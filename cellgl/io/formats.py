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
from typing import Any

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
    "usable_cores",
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


def _chunk(tag: bytes, data: bytes | bytearray) -> bytes:
    return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data))


#: bytes of filtered rows a deflate block holds (:class:`_Deflate`): fixed, so the file's bytes do
#: not depend on the machine's cores or on how the image came in bands
DEFLATE_BLOCK = 1 << 20
#: the deflate window: a block starts with the last this many bytes before it as its dictionary
_WINDOW = 32768
_ADLER_BASE = 65521


def _adler32_combine(a1: int, a2: int, len2: int) -> int:
    """The Adler-32 of A + B from Adler-32 ``a1`` of A, ``a2`` of B and B's length (RFC 1950: the
    low half is 1 + the sum of the bytes, the high half the sum of the low halves, mod 65521)."""
    s1a, s2a = a1 & 0xFFFF, a1 >> 16
    s1b, s2b = a2 & 0xFFFF, a2 >> 16
    s1 = (s1a + s1b - 1) % _ADLER_BASE
    s2 = (s2a + s2b + len2 * (s1a - 1)) % _ADLER_BASE
    return s1 | (s2 << 16)


def _deflate_block(data, zdict: bytes, level: int, last: bool) -> tuple[bytes, int, int]:
    """One raw deflate block of the stream: ``data`` compressed with the bytes before it as its
    dictionary, ended byte-aligned (a sync flush) or, ``last``, as the stream's final block."""
    c = (zlib.compressobj(level, zlib.DEFLATED, -15, 8, zlib.Z_DEFAULT_STRATEGY, zdict) if zdict
         else zlib.compressobj(level, zlib.DEFLATED, -15))
    out = c.compress(data) + c.flush(zlib.Z_FINISH if last else zlib.Z_SYNC_FLUSH)
    return out, zlib.adler32(data), len(data)


class _Deflate:
    """One zlib stream (RFC 1950, level 6) compressed on several threads: the input is cut into
    blocks of :data:`DEFLATE_BLOCK` bytes, each deflated on its own with the 32 KiB before it as
    its dictionary (so matches reach back across a cut as in one stream) and ended on a byte
    boundary; the blocks, in order, are one deflate stream, the checksum their Adler-32s combined.
    zlib releases the GIL: the blocks compress in parallel. An input of one block gives the bytes
    of ``zlib.compressobj(6)``; a longer one, bytes that depend only on the input."""

    def __init__(self, pool, in_flight: int, level: int = 6):
        from collections import deque

        self.pool, self.in_flight, self.level = pool, in_flight, level
        self.carry = bytearray()
        self.tail = b""
        self.adler = 1
        self.queue: deque = deque()
        self.header = True

    def _submit(self, data, last: bool) -> None:
        self.queue.append(self.pool.submit(_deflate_block, data, self.tail, self.level, last))
        self.tail = bytes(data[-_WINDOW:])

    def _ready(self, wait: int) -> bytearray:
        """The compressed blocks done, in order (waiting until at most ``wait`` are left)."""
        out = bytearray(b"\x78\x9c" if self.header else b"")
        self.header = False
        while self.queue and (self.queue[0].done() or len(self.queue) > wait):
            data, adler, n = self.queue.popleft().result()
            out += data
            self.adler = _adler32_combine(self.adler, adler, n)
        return out

    def compress(self, data) -> bytearray:
        """Take ``data``; return what is compressed so far (keeping at most ``in_flight`` blocks)."""
        carry = self.carry
        carry += data.reshape(-1).data if isinstance(data, np.ndarray) else data
        if len(carry) > DEFLATE_BLOCK:       # (strictly: the last block is never empty)
            cut = (len(carry) - 1) // DEFLATE_BLOCK * DEFLATE_BLOCK
            with memoryview(carry) as whole:  # one copy of the blocks (released before the del)
                blocks = memoryview(bytes(whole[:cut]))
            del carry[:cut]
            for k in range(0, cut, DEFLATE_BLOCK):
                self._submit(blocks[k:k + DEFLATE_BLOCK], False)
        return self._ready(self.in_flight)

    def flush(self) -> bytearray:
        """The rest of the stream: the last block, then the Adler-32."""
        self._submit(bytes(self.carry), True)
        self.carry = bytearray()
        return self._ready(0) + struct.pack(">I", self.adler)

    def cancel(self) -> None:
        for f in self.queue:
            f.cancel()


def usable_cores() -> int:
    """The CPUs this process may run on (its affinity where the OS has one; macOS and Windows:
    every CPU): the width of the PNG's deflate pool, of a local Dask cluster, of the exports'
    worker pool."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


def write_png(path: str | os.PathLike, bands: Iterable[np.ndarray], width: int, height: int,
              samples: int, bit_depth: int, *, text: Mapping[str, str] | None = None,
              srgb: bool = False) -> None:
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
    srgb : bool
        The samples are sRGB-encoded colour: an ``sRGB`` chunk (rendering intent perceptual) and,
        as the PNG specification recommends for readers that know only those, the matching
        ``gAMA`` (1/2.2) and ``cHRM`` (BT.709 primaries, D65). Without it (data: heights,
        normals, distances) the file has no colour chunk at all.

    Notes
    -----
    Every row uses PNG filter 2 ("up"), computed with NumPy per band; the stream is compressed
    with zlib level 6 in blocks of :data:`DEFLATE_BLOCK` filtered bytes on every core
    (:class:`_Deflate`: one zlib stream, each block with the 32 KiB before it as its dictionary)
    and written in ``IDAT`` chunks of 1 MiB (the last one shorter). The filter and the hand-off
    of a band run on a thread of their own while ``bands`` makes the next one (zlib and NumPy
    release the GIL): a bake's encoding overlaps its rendering. The bytes depend only on the
    pixels, never on the bands or the cores; an image of one block (about 1 MiB of rows) is byte
    for byte ``zlib.compressobj(6)``'s.
    """
    from concurrent.futures import ThreadPoolExecutor      # (on first use: not at `import cellgl`)

    if bit_depth not in (8, 16):
        raise ValueError(f"PNG bit depth {bit_depth}: accepted 8, 16")
    if samples not in _PNG_COLOR_TYPE:
        raise ValueError(f"PNG samples per pixel {samples}: accepted 1, 2, 3, 4")
    dtype = np.dtype(">u2") if bit_depth == 16 else np.dtype(np.uint8)
    row_bytes = width * samples * dtype.itemsize
    cores = usable_cores()
    state: dict[str, Any] = {"prev": np.zeros(row_bytes, np.uint8), "pending": bytearray()}
    rows_done = 0

    def encode(f, comp, band: np.ndarray) -> None:
        n = band.shape[0]
        raw = np.ascontiguousarray(band, dtype=dtype).view(np.uint8).reshape(n, row_bytes)
        filtered = np.empty((n, row_bytes + 1), np.uint8)
        filtered[:, 0] = 2  # "up": byte minus the byte above, mod 256
        np.subtract(raw[0], state["prev"], out=filtered[0, 1:])
        np.subtract(raw[1:], raw[:-1], out=filtered[1:, 1:])
        state["prev"] = raw[-1].copy()
        state["pending"] += comp.compress(filtered)
        _write_idat(f, state["pending"], final=False)

    with open(path, "wb") as f, ThreadPoolExecutor(1, thread_name_prefix="cellgl-png") as pool, \
            ThreadPoolExecutor(cores, thread_name_prefix="cellgl-deflate") as blocks:
        comp = _Deflate(blocks, 2 * cores)
        f.write(b"\x89PNG\r\n\x1a\n")
        f.write(_chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, bit_depth,
                                            _PNG_COLOR_TYPE[samples], 0, 0, 0)))
        if srgb:
            f.write(_SRGB_CHUNKS)
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
                busy = pool.submit(encode, f, comp, band)
            if busy is not None:
                busy.result()
            if rows_done != height:
                raise ValueError(f"PNG got {rows_done} rows, expected {height}")
            state["pending"] += comp.flush()
        except BaseException:
            if busy is not None:
                busy.cancel()
            comp.cancel()
            raise
        _write_idat(f, state["pending"], final=True)
        f.write(_chunk(b"IEND", b""))


#: sRGB (intent 0, perceptual), gAMA 45455 (1/2.2) and cHRM of sRGB: PNG 3rd edition, 11.3.2
_SRGB_CHUNKS = (_chunk(b"sRGB", b"\0") + _chunk(b"gAMA", struct.pack(">I", 45455))
                + _chunk(b"cHRM", struct.pack(">8I", 31270, 32900, 64000, 33000, 30000, 60000, 15000, 6000)))


def _write_idat(f, pending: bytearray, final: bool) -> None:
    """Write ``pending`` (and take it out) as IDAT chunks of exactly :data:`_IDAT_SIZE` bytes,
    and, ``final``, the rest: the chunks depend only on the stream."""
    done = len(pending) if final else len(pending) // _IDAT_SIZE * _IDAT_SIZE
    for k in range(0, done, _IDAT_SIZE):
        f.write(_chunk(b"IDAT", pending[k:min(k + _IDAT_SIZE, done)]))
    del pending[:done]


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
              attributes: Mapping[str, str] | None = None,
              chromaticities: Sequence[tuple[float, float]] | None = None) -> None:
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
    chromaticities : four (x, y) pairs, optional
        The standard ``chromaticities`` attribute: CIE xy of red, green, blue and white.

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
        assert n is not None        # chans is not empty (OpenEXR refuses a header without channels)
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
        if chromaticities is not None:  # a placeholder the size of the attribute (see _patch_chromaticities)
            header["chromaticities"] = _CHROMA_PLACEHOLDER
        out = OpenEXR.OutputFile(str(path), header)
        try:
            for band in bands:
                n, arrays = checked(band)
                out.writePixels({k: a.tobytes() for k, a in arrays.items()}, n)
        finally:
            out.close()
        if chromaticities is not None:
            _patch_chromaticities(path, chromaticities)
    else:  # pragma: no cover - a future OpenEXR without the old API
        parts: dict[str, list[np.ndarray]] = {name: [] for name in chans}
        for band in bands:
            _, arrays = checked(band)
            for k, a in arrays.items():
                parts[k].append(a)
        header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
        header.update(attributes)
        if chromaticities is not None:
            header["chromaticities"] = tuple(float(c) for xy in chromaticities for c in xy)
        data = {k: np.concatenate(v) if v else np.zeros((0, width), chans[k])
                for k, v in parts.items()}
        with OpenEXR.File(header, data) as f:
            f.write(str(path))
    if rows_done != height:
        raise ValueError(f"EXR got {rows_done} rows, expected {height}")


#: a string attribute exactly as long as a ``chromaticities`` one (OpenEXR's file layout: name,
#: type name, int32 size, value; "string" + 4 + 40 bytes = "chromaticities" + 4 + 32 bytes)
_CHROMA_PLACEHOLDER = b"cellgl-chromaticities-placeholder-000000"
_CHROMA_STRING = b"chromaticities\0string\0" + struct.pack("<i", 40) + _CHROMA_PLACEHOLDER


def _patch_chromaticities(path, chromaticities) -> None:
    """Turn the placeholder string attribute ``chromaticities`` into the standard attribute of
    type ``chromaticities`` (8 float32: red, green, blue, white xy), in place.

    The legacy ``OpenEXR.OutputFile`` API, the one that streams scanlines, writes zeros for an
    ``Imath.Chromaticities`` (OpenEXR 3.5); the header is a documented fixed layout
    (openexr.com, "OpenEXR File Layout") and both attributes are 51 bytes after the name, so
    nothing else in the file moves. Checked by OpenEXR's and OpenImageIO's readers in the tests.
    """
    with open(path, "r+b") as f:
        head = f.read(1 << 20)
        at = head.find(_CHROMA_STRING)
        if at < 0 or head.find(_CHROMA_STRING, at + 1) >= 0:
            raise ValueError(f"EXR {path}: the chromaticities placeholder was not found once")
        values = [float(c) for xy in chromaticities for c in xy]
        f.seek(at + len(b"chromaticities\0"))
        f.write(b"chromaticities\0" + struct.pack("<i", 32) + struct.pack("<8f", *values))


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
    kwargs: dict[str, Any] = dict(photometric="rgb" if rgb else "minisblack", compression="zlib",
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
