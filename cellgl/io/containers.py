"""DDS and KTX2 containers of GPU textures: :func:`write_dds`, :func:`write_ktx2`, the formats
they hold (:data:`TEX_FORMATS`).

Written here, in Python, from the specifications: both containers are documented fixed
structures (a header, an index, the levels' bytes), no maintained Python writer fits (Pillow
writes DDS DXT1/3/5 and BC5 without mip levels, no DX10 formats; Khronos' ``pyktx`` has Windows
wheels only), and the tests check every field with a parser of their own written from the same
specifications, not from this code (tests/test_texfiles.py), and decode every level with
Pillow, imagecodecs and texture2ddecoder.

DDS (Microsoft, "DDS file layout", "DDS_HEADER", "DDS_HEADER_DXT10"): ``"DDS "``, the 124-byte
``DDS_HEADER`` and, for every format but the UNORM BC1/BC3 ones (written with the legacy
``DXT1``/``DXT5`` FourCC that every reader knows), the 20-byte ``DDS_HEADER_DXT10`` naming the
``DXGI_FORMAT`` (sRGB formats, BC4, BC5, BC7, R16, floats and ``R32_UINT`` exist only there).
Then level 0, level 1, ... each holding all its slices (a volume: ``TEXTURE3D``).

KTX 2.0 (Khronos, KTX File Format Specification 2.0, with the Khronos Data Format Specification
1.3 for the descriptor): the 12-byte identifier, the header (``vkFormat``, ``typeSize``, sizes,
``levelCount``, ``supercompressionScheme``), the index, the level index (largest level first),
the data format descriptor (one basic block: colour model, BT.709 primaries for colour and
unspecified for data, the transfer function, sRGB for colour and linear for data, block size,
bytes per plane, one sample per channel), the key/value data (``KTXwriter``, and ``cellgl``: how
the file was made) and the levels, smallest first, each aligned to ``lcm(texel block bytes, 4)``.
With ``zstd`` each level is compressed on its own (supercompression scheme 2, the ``zstandard``
package) and ``bytesPlane0`` is 0, as the specification asks of supercompressed files.

Level sizes are those both formats define: ``max(1, floor(W / 2^k))`` (``cellgl.bake.mips``'s
``rounding="down"``). Integers are little-endian.
"""
from __future__ import annotations

import math
import struct
from collections.abc import Sequence
from dataclasses import dataclass

__all__ = ["TexFormat", "TEX_FORMATS", "level_bytes", "write_dds", "write_ktx2", "KTX2_IDENTIFIER"]


@dataclass(frozen=True)
class TexFormat:
    """A texel format DDS and KTX2 can hold."""

    name: str             #: e.g. ``BC7_SRGB``
    dxgi: int             #: DXGI_FORMAT
    vk: int               #: VkFormat
    block: int            #: 4 for BCn (4 x 4 texel blocks), 1 for plain texels
    nbytes: int           #: bytes per block (BCn) or per texel
    srgb: bool            #: sRGB transfer (colour); False: linear (data)
    codec: str | None     #: the block encoder's name (cellgl.io.blocks), None for plain texels
    model: int            #: KHR_DF_MODEL_*
    samples: tuple        #: DFD samples: (channel|qualifiers, bitOffset, bitLength, lower, upper)
    fourcc: bytes | None = None   #: a legacy DDS FourCC, where one exists (no DX10 header then)
    type_size: int = 1    #: KTX2 typeSize

    @property
    def compressed(self) -> bool:
        return self.block > 1


_U32 = 0xFFFFFFFF
_FLOAT = 0x80 | 0x40          # KHR_DF_SAMPLE_DATATYPE_FLOAT | SIGNED
_LINEAR = 0x10                # KHR_DF_SAMPLE_DATATYPE_LINEAR (alpha of an sRGB format)
_F_MINUS1, _F_PLUS1 = 0xBF800000, 0x3F800000   # -1.0f, 1.0f: the sample range of a float channel
# KHR_DF_MODEL_*: RGBSDA 1, BC1A 128, BC3 130, BC4 131, BC5 132, BC7 134; channel ids: RGBSDA red
# 0, green 1, blue 2, alpha 15; BC3 colour 0, alpha 15; BC5 red 0, green 1


def _bc(name, dxgi, vk, nbytes, srgb, codec, model, samples, fourcc=None):
    return TexFormat(name, dxgi, vk, 4, nbytes, srgb, codec, model, samples, fourcc)


_BC1 = ((0, 0, 64, 0, _U32),)
_BC3 = ((15, 0, 64, 0, _U32), (0, 64, 64, 0, _U32))
_BC5 = ((0, 0, 64, 0, _U32), (1, 64, 64, 0, _U32))
_BC7 = ((0, 0, 128, 0, _U32),)


def _rgba8(alpha_flag):
    return ((0, 0, 8, 0, 255), (1, 8, 8, 0, 255), (2, 16, 8, 0, 255), (15 | alpha_flag, 24, 8, 0, 255))


TEX_FORMATS: dict[str, TexFormat] = {f.name: f for f in (
    _bc("BC1_UNORM", 71, 131, 8, False, "bc1", 128, _BC1, b"DXT1"),
    _bc("BC1_SRGB", 72, 132, 8, True, "bc1", 128, _BC1),
    _bc("BC3_UNORM", 77, 137, 16, False, "bc3", 130, _BC3, b"DXT5"),
    _bc("BC3_SRGB", 78, 138, 16, True, "bc3", 130, _BC3),
    _bc("BC4_UNORM", 80, 139, 8, False, "bc4", 131, _BC1),
    _bc("BC5_UNORM", 83, 141, 16, False, "bc5", 132, _BC5),
    _bc("BC7_UNORM", 98, 145, 16, False, "bc7", 134, _BC7),
    _bc("BC7_SRGB", 99, 146, 16, True, "bc7", 134, _BC7),
    TexFormat("R8G8B8A8_UNORM", 28, 37, 1, 4, False, None, 1, _rgba8(0)),
    TexFormat("R8G8B8A8_SRGB", 29, 43, 1, 4, True, None, 1, _rgba8(_LINEAR)),
    TexFormat("R8_UNORM", 61, 9, 1, 1, False, None, 1, ((0, 0, 8, 0, 255),)),
    TexFormat("R16_UNORM", 56, 70, 1, 2, False, None, 1, ((0, 0, 16, 0, 65535),), type_size=2),
    TexFormat("R16_SFLOAT", 54, 76, 1, 2, False, None, 1, ((_FLOAT, 0, 16, _F_MINUS1, _F_PLUS1),),
              type_size=2),
    TexFormat("R32_SFLOAT", 41, 100, 1, 4, False, None, 1, ((_FLOAT, 0, 32, _F_MINUS1, _F_PLUS1),),
              type_size=4),
    # an integer (not normalised) channel: sampleUpper is the value that means 1, so 1
    TexFormat("R32_UINT", 42, 98, 1, 4, False, None, 1, ((0, 0, 32, 0, 1),), type_size=4),
)}


def level_bytes(fmt: TexFormat, width: int, height: int, depth: int = 1) -> int:
    """Bytes of one level: whole blocks (or texels) of every slice."""
    b = fmt.block
    return (-(-width // b)) * (-(-height // b)) * fmt.nbytes * depth


def _check_levels(fmt: TexFormat, width: int, height: int, depth: int | None, levels: Sequence[bytes],
                  layers: int | None = None) -> None:
    d = depth or 1
    if not levels:
        raise ValueError("a texture needs at least one level")
    if layers is not None and (depth is not None or not 1 <= layers <= 2048):
        raise ValueError(f"an array of {layers} layers{' of volumes' if depth is not None else ''}: "
                         f"accepted 1..2048 layers of 2D textures (no API has 3D texture arrays)")
    if len(levels) > max(width, height, d).bit_length():
        raise ValueError(f"{len(levels)} levels for a {width}x{height}x{d} texture: at most "
                         f"{max(width, height, d).bit_length()}")
    for k, data in enumerate(levels):
        w, h, z = max(1, width >> k), max(1, height >> k), max(1, d >> k)
        want = level_bytes(fmt, w, h, z) * (layers or 1)
        if len(data) != want:
            raise ValueError(f"level {k} ({w}x{h}x{z}{f', {layers} layers' if layers else ''}) of {fmt.name}: "
                             f"{len(data)} bytes, expected {want}")


# --------------------------------------------------------------------------------------------
# DDS
# --------------------------------------------------------------------------------------------

_DDSD_CAPS, _DDSD_HEIGHT, _DDSD_WIDTH, _DDSD_PITCH = 0x1, 0x2, 0x4, 0x8
_DDSD_PIXELFORMAT, _DDSD_MIPMAPCOUNT, _DDSD_LINEARSIZE, _DDSD_DEPTH = 0x1000, 0x20000, 0x80000, 0x800000
_DDSCAPS_COMPLEX, _DDSCAPS_TEXTURE, _DDSCAPS_MIPMAP = 0x8, 0x1000, 0x400000
_DDSCAPS2_VOLUME = 0x200000
_DDPF_FOURCC = 0x4
_DIMENSION_2D, _DIMENSION_3D = 3, 4


def dds_bytes_header(fmt: TexFormat, width: int, height: int, depth: int | None, nlevels: int,
                     layers: int | None = None) -> bytes:
    """``"DDS "``, DDS_HEADER and (unless a legacy FourCC, never for an array) DDS_HEADER_DXT10."""
    flags = _DDSD_CAPS | _DDSD_HEIGHT | _DDSD_WIDTH | _DDSD_PIXELFORMAT
    flags |= _DDSD_LINEARSIZE if fmt.compressed else _DDSD_PITCH
    caps, caps2 = _DDSCAPS_TEXTURE, 0
    if nlevels > 1:
        flags |= _DDSD_MIPMAPCOUNT
        caps |= _DDSCAPS_COMPLEX | _DDSCAPS_MIPMAP
    if depth is not None:
        flags |= _DDSD_DEPTH
        caps |= _DDSCAPS_COMPLEX
        caps2 |= _DDSCAPS2_VOLUME
    pitch = level_bytes(fmt, width, height) if fmt.compressed else width * fmt.nbytes
    legacy = fmt.fourcc if layers is None else None     # an array needs the DX10 header's arraySize
    fourcc = legacy or b"DX10"
    pixelformat = struct.pack("<II4s5I", 32, _DDPF_FOURCC, fourcc, 0, 0, 0, 0, 0)
    header = struct.pack("<7I44x", 124, flags, height, width, pitch, depth or 0, nlevels) + pixelformat \
        + struct.pack("<4I4x", caps, caps2, 0, 0)
    assert len(header) == 124
    out = b"DDS " + header
    if legacy is None:
        out += struct.pack("<5I", fmt.dxgi, _DIMENSION_3D if depth is not None else _DIMENSION_2D, 0,
                           layers or 1, 0)
    return out


def write_dds(f, fmt: TexFormat, width: int, height: int, depth: int | None, levels: Sequence[bytes],
              layers: int | None = None) -> None:
    """Write a DDS texture to the open binary file ``f``: ``levels[k]`` is level ``k``'s bytes
    (every slice of a volume, ``depth`` not None), sized as :func:`level_bytes`. An array of
    ``layers`` 2D textures: ``levels[k]`` holds every layer's level ``k``, layer after layer; the
    file stores each layer's whole chain in turn (DDS's order)."""
    _check_levels(fmt, width, height, depth, levels, layers)
    f.write(dds_bytes_header(fmt, width, height, depth, len(levels), layers))
    for a in range(layers or 1):
        for data in levels:
            per = len(data) // (layers or 1)
            f.write(data[a * per:(a + 1) * per])


# --------------------------------------------------------------------------------------------
# KTX2
# --------------------------------------------------------------------------------------------

KTX2_IDENTIFIER = b"\xabKTX 20\xbb\r\n\x1a\n"
_SUPERCOMPRESSION = {None: 0, "zstd": 2}
_PRIMARIES_BT709, _PRIMARIES_UNSPECIFIED = 1, 0
_TRANSFER_LINEAR, _TRANSFER_SRGB = 1, 2


def ktx2_dfd(fmt: TexFormat, supercompressed: bool) -> bytes:
    """The data format descriptor: dfdTotalSize and one basic descriptor block."""
    nsamples = len(fmt.samples)
    size = 24 + 16 * nsamples
    dims = (fmt.block - 1, fmt.block - 1, 0, 0)
    plane0 = 0 if supercompressed else fmt.nbytes
    block = struct.pack("<IHH4B4B8B", 0, 2, size, fmt.model,
                        _PRIMARIES_BT709 if fmt.srgb else _PRIMARIES_UNSPECIFIED,
                        _TRANSFER_SRGB if fmt.srgb else _TRANSFER_LINEAR, 0, *dims, plane0, 0, 0, 0, 0, 0, 0, 0)
    for channel, offset, length, lower, upper in fmt.samples:
        block += struct.pack("<HBB4BII", offset, length - 1, channel, 0, 0, 0, 0, lower, upper)
    return struct.pack("<I", 4 + len(block)) + block


def _kvd(pairs: dict[str, bytes]) -> bytes:
    out = b""
    for key in sorted(pairs, key=lambda k: k.encode()):
        entry = key.encode() + b"\0" + pairs[key]
        out += struct.pack("<I", len(entry)) + entry + b"\0" * (-len(entry) % 4)
    return out


def write_ktx2(f, fmt: TexFormat, width: int, height: int, depth: int | None, levels: Sequence[bytes], *,
               supercompression: str | None = None, zstd_level: int = 19, writer: str = "cellgl",
               metadata: bytes | None = None, layers: int | None = None) -> None:
    """Write a KTX2 texture to the open binary file ``f`` (levels as :func:`write_dds`; an array's
    level holds its layers one after the other, as KTX2 stores them); ``supercompression="zstd"``
    compresses each level with zstd at ``zstd_level``."""
    if supercompression not in _SUPERCOMPRESSION:
        raise ValueError(f"supercompression {supercompression!r}: accepted None or 'zstd'")
    _check_levels(fmt, width, height, depth, levels, layers)
    stored = list(levels)
    if supercompression == "zstd":
        import zstandard

        comp = zstandard.ZstdCompressor(level=zstd_level)
        stored = [comp.compress(bytes(d)) for d in levels]
    n = len(levels)
    dfd = ktx2_dfd(fmt, supercompression is not None)
    kv = {"KTXwriter": writer.encode() + b"\0"}
    if metadata is not None:
        kv["cellgl"] = metadata
    kvd = _kvd(kv)
    dfd_off = 12 + 36 + 32 + 24 * n
    kvd_off = dfd_off + len(dfd)
    end = kvd_off + len(kvd)
    align = 1 if supercompression else math.lcm(fmt.nbytes, 4)
    offsets = [0] * n
    for k in reversed(range(n)):          # smallest level first in the file
        end += -end % align
        offsets[k] = end
        end += len(stored[k])
    head = KTX2_IDENTIFIER + struct.pack("<9I", fmt.vk, fmt.type_size, width, height, depth or 0, layers or 0, 1, n,
                                         _SUPERCOMPRESSION[supercompression])
    head += struct.pack("<4I2Q", dfd_off, len(dfd), kvd_off if kvd else 0, len(kvd), 0, 0)
    for k in range(n):
        head += struct.pack("<3Q", offsets[k], len(stored[k]), len(levels[k]))
    f.write(head + dfd + kvd)
    pos = kvd_off + len(kvd)
    for k in reversed(range(n)):
        f.write(b"\0" * (offsets[k] - pos))
        f.write(stored[k])
        pos = offsets[k] + len(stored[k])


def file_size_hint(fmt: TexFormat, width: int, height: int, depth: int | None, nlevels: int) -> int:
    """About the bytes of an uncompressed-container file (for the disk-space check)."""
    return sum(level_bytes(fmt, max(1, width >> k), max(1, height >> k), max(1, (depth or 1) >> k))
               for k in range(nlevels)) + 4096

