"""What an output can hold: formats, size limits, channels, and how each channel is encoded in
each format (the writers of :mod:`cellgl.io` store them, :mod:`cellgl.bake`
renders recipes into them).

The files layer's vocabulary: it imports nothing of cellgl above :mod:`cellgl.io` and knows no
recipe or request (a channel is a name and a sample count), so the writers beside it use its
encodings and the bake above reads it; what a bake request may ask for (sizes, memory, ``--set``
items, animations) is :mod:`cellgl.bake.request`."""
from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

__all__ = ["BakeError", "CHANNELS", "FORMATS", "MAX_SIDE", "MAX_SLICES", "MAX_VOXELS", "id_colors", "Encoding",
           "accepted_list", "check_size", "encoding_of", "exr_names", "quantize"]


class BakeError(ValueError):
    """A bad bake request: the message names the value and what is accepted."""


# --------------------------------------------------------------------------------------------
# what can be baked, and how
# --------------------------------------------------------------------------------------------

#: Channels render() produces -> samples per pixel.
CHANNELS: dict[str, int] = {"color": 4, "height": 1, "normal": 3, "id": 1,
                            "F1": 1, "F2": 1, "F3": 1, "F4": 1, "roughness": 1, "ao": 1, "metallic": 1,
                            "cloud": 4}


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
    # a tiled, mip-mapped TIFF as maketx writes it (cellgl.io.tiled)
    ".tx": _Format("TIFF texture", (8, 16, 32), 32, False, "tile"),
    # GPU textures (cellgl.io.gpu_textures): the format is chosen per channel; --depth sets the bits of
    # plain (uncompressed) samples, its default per channel; mip levels and volumes in the file
    ".dds": _Format("DDS", (8, 16, 32), 8, True, "level"),
    ".ktx2": _Format("KTX2", (8, 16, 32), 8, True, "level"),
    # an OpenVDB volume, a float grid per sample (cellgl.io.vdb); volumes only
    ".vdb": _Format("OpenVDB", (32,), 32, True, "piece"),
}

MAX_SIDE = 65536          #: largest width or height
MAX_SLICES = 4096         #: largest volume depth (slices)
MAX_VOXELS = 2 ** 32      #: largest width * height * slices


def accepted_list(values: Iterable) -> str:
    """``values`` as an error message lists what is accepted: ``"a, b, c"``."""
    return ", ".join(str(v) for v in values)


def _whole(v) -> bool:
    """A whole number: a Python or NumPy integer, not a boolean (``True`` is not a size)."""
    return isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))


def check_size(w: int, h: int, d: int | None, what: str) -> None:
    for name, v in (("width", w), ("height", h)):
        if not _whole(v) or not 1 <= v <= MAX_SIDE:
            raise BakeError(f"{what}: {name} {v} is out of range; accepted 1..{MAX_SIDE}")
    if d is not None and (not _whole(d) or not 1 <= d <= MAX_SLICES):
        raise BakeError(f"{what}: depth {d} (volume slices) is out of range; "
                        f"accepted 1..{MAX_SLICES}")
    n = w * h * (d or 1)
    if n > MAX_VOXELS:
        raise BakeError(f"{what}: {n} pixels is too many; at most {MAX_VOXELS} (2**32)")


# --------------------------------------------------------------------------------------------
# per-channel encoding: render() output -> file samples
# --------------------------------------------------------------------------------------------


#: elements quantised at once by :func:`quantize` (its float64 block stays in the cache)
_QUANTIZE_BLOCK = 1 << 16


def quantize(v: np.ndarray, bits: int) -> np.ndarray:
    """The one quantiser of every 8/16-bit output (PNG, TIFF, animated WebP/GIF): ``v`` as
    float32, clipped to [0, 1] (NaN 0, +inf 1, -inf 0), times ``top = 2**bits - 1``, rounded to
    the nearest integer: ``round(clip(v, 0, 1) * top)`` of the exact product.

    The product and the half added are computed in float64, where they are exact (a float32 has
    24 significant bits, ``top`` 16 at most): float32 arithmetic rounded the product and the sum,
    and sent some values just below a half up (113 of 12.6 million uniform samples at 8 bits,
    16,477 at 16). A tie cannot occur: ``(k + 0.5) / top`` is never a float32 (``top`` is odd).
    Worked in blocks of rows that stay in the cache: ``fmax``/``fmin`` clip and send NaN to 0
    (they return the number of a NaN and a number), and the conversion to the unsigned type
    truncates, which is floor for the values here (>= 0.5)."""
    top = float((1 << bits) - 1)
    a = np.asarray(v)
    if a.dtype != np.float32:
        a = a.astype(np.float32)                    # as the caller's values: float32 first
    out = np.empty(a.shape, np.uint8 if bits == 8 else np.uint16)
    if a.ndim == 0 or a.size == 0:
        a, out2 = a.reshape(1, -1), out.reshape(1, -1)
    else:
        out2 = out
    per_row = max(1, a[0].size)
    rows = max(1, _QUANTIZE_BLOCK // per_row)
    buf = np.empty(min(len(a), rows) * per_row, np.float64)
    for r0 in range(0, len(a), rows):
        src = a[r0:r0 + rows]
        q = buf[:src.size].reshape(src.shape)
        np.multiply(src, top, out=q, dtype=np.float64)     # exact
        q += 0.5                                           # exact for every v in [0, 1]
        np.fmax(q, 0.5, out=q)                             # NaN, -inf, v < 0: 0.5 -> 0
        np.fmin(q, top + 0.5, out=q)                       # +inf, v > 1: top
        out2[r0:r0 + rows] = q                      # truncation toward 0: floor, q >= 0.5
    return out


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
class Encoding:
    """How one channel is stored: sample count and dtype in the file."""

    channel: str
    samples: int
    dtype: np.dtype
    #: the colour space of ``color`` in the file (cellgl.io.colour.COLORSPACES); None for data
    #: channels (never converted, never tagged) and for .npy
    colorspace: str | None = None

    def encode(self, a: np.ndarray) -> np.ndarray:
        if self.channel == "color":
            a = np.asarray(a)[..., :3]
            if self.colorspace == "linear":
                from cellgl.io.colour import encode_linear

                return encode_linear(a, self.dtype)
        if self.channel == "id":
            if self.samples == 3:
                return id_colors(a)
            return np.asarray(a).astype(np.uint32, copy=False)
        if self.dtype == np.uint8 or self.dtype == np.uint16:
            return quantize(a, self.dtype.itemsize * 8)
        return np.asarray(a).astype(self.dtype, copy=False)


def encoding_of(channel: str, ext: str, bits: int, colorspace: str | None = None) -> Encoding:
    """How ``channel`` is stored in a ``ext`` file of ``bits`` bits per sample; ``colorspace``
    (already checked: :func:`cellgl.io.colour.check_colorspace`) applies to ``color`` only."""
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
            return Encoding(channel, 3, np.dtype(np.uint8))
        if ext in (".tif", ".tiff", ".tx") and bits != 32:
            raise BakeError(f"--channels id with {ext}: ids are uint32, so --depth must be 32 "
                            f"(got {bits})")
        return Encoding(channel, 1, np.dtype(np.uint32))
    space = colorspace if channel == "color" else None
    if fmt.stream == "band" and ext == ".exr":
        return Encoding(channel, samples, np.dtype(np.float16 if bits == 16 else np.float32), space)
    return Encoding(channel, samples, np.dtype({8: np.uint8, 16: np.uint16,
                                                32: np.float32}[bits]), space)


#: EXR channel names per cellgl channel.
_EXR_NAMES = {"color": ("R", "G", "B"), "normal": ("normal.R", "normal.G", "normal.B"),
              "cloud": ("cloud.R", "cloud.G", "cloud.B", "cloud.A")}


def exr_names(channel: str) -> tuple[str, ...]:
    """The EXR channel names of a channel's samples."""
    return _EXR_NAMES.get(channel, (channel,))

