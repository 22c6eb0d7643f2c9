"""GPU texture files, ``.dds`` and ``.ktx2``, from arrays: the format each channel takes, a level's
samples and blocks, the file (:func:`cellgl.bake.gputex.bake_texture` renders a recipe into them;
``cellgl bake -o X.dds``).

Per channel the format a pipeline expects, chosen by default or by ``compress`` (``--compress``),
refused where it makes no sense (:data:`CHOICES`): colour is sRGB (BC7, BC1 or BC3 blocks, or
plain ``R8G8B8A8_SRGB``), the data maps linear (``UNORM``/float): normals BC5 (red and green:
x and y; a reader rebuilds z), height and the masks (roughness, ao, metallic) BC4 (or plain
8/16-bit ``UNORM`` or float), ``F1``..``F4``
plain floats (``R32_SFLOAT``, 16-bit ``R16_SFLOAT``), ``id`` ``R32_UINT`` (never compressed). The
8- and 16-bit samples are the PNG bake's, bit for bit (cellgl.io.spec's encodings); the blocks
come from etcpak on every core (cellgl.io.blocks); the containers are cellgl.io.containers.

A file holds every mip level it is given (DDS and KTX2 define the chain with ``rounding="down"``,
:func:`cellgl.bake.mips.mip_sizes`), volumes as 3D textures (their levels halving the depth too)
and array layers. Nothing here knows of recipes or GL. See docs/bake.md ("GPU texture files").
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cellgl.io import blocks, containers
from cellgl.io.spec import BakeError, Encoding, accepted_list

__all__ = ["EXTS", "CHOICES", "COMPRESS", "MAX_SIDE_2D", "MAX_SIDE_3D", "TexOutput", "plan_outputs", "parse_compress",
           "texel_samples", "level_data", "memory_need", "packed_levels", "write_container"]

EXTS = (".dds", ".ktx2")
#: the --compress values
COMPRESS = ("bc1", "bc3", "bc4", "bc5", "bc7", "none")
#: largest side of a 2D texture and of a volume (Direct3D 11/12's limits, which every desktop GPU
#: meets; Vulkan and OpenGL devices advertise at least as much on desktop)
MAX_SIDE_2D, MAX_SIDE_3D = 16384, 2048

#: channel -> {compress: format or {bits: format}}; the first key is the default
CHOICES: dict[str, dict[str, object]] = {
    "color": {"bc7": "BC7_SRGB", "bc1": "BC1_SRGB", "bc3": "BC3_SRGB", "none": {8: "R8G8B8A8_SRGB"}},
    "normal": {"bc5": "BC5_UNORM", "bc7": "BC7_UNORM", "bc1": "BC1_UNORM", "bc3": "BC3_UNORM",
               "none": {8: "R8G8B8A8_UNORM"}},
    "height": {"bc4": "BC4_UNORM", "none": {16: "R16_UNORM", 8: "R8_UNORM", 32: "R32_SFLOAT"}},
    **{m: {"bc4": "BC4_UNORM", "none": {8: "R8_UNORM", 16: "R16_UNORM", 32: "R32_SFLOAT"}}
       for m in ("roughness", "ao", "metallic")},
    "id": {"none": {32: "R32_UINT"}},
    **{f: {"none": {32: "R32_SFLOAT", 16: "R16_SFLOAT"}} for f in ("F1", "F2", "F3", "F4")},
    # four noises (cellgl.texture.cloud), RGBA8 as the cloud renderers sample them; data, not sRGB
    "cloud": {"none": {8: "R8G8B8A8_UNORM"}},
}
_WHY_NOT = {"color": "colour has three channels (BC4 holds one, BC5 two)",
            "normal": "a normal needs two channels at least (BC4 holds one)",
            "height": "height is one channel: BC4, or plain samples",
            "roughness": "a mask is one channel: BC4, or plain samples",
            "id": "ids are exact uint32 values (R32_UINT); blocks would change them",
            "F1": "distances are floats (R32_SFLOAT/R16_SFLOAT); blocks hold 8-bit [0, 1] values",
            "cloud": "four independent noises: blocks would blur one into another (BC7 shares its endpoints)"}


@dataclass(frozen=True)
class TexOutput:
    path: Path
    channel: str
    fmt: containers.TexFormat


def parse_compress(compress, channels) -> dict[str, str]:
    """``compress`` (``None``, ``"bc7"`` for every channel, or ``"color=bc1,height=none"``) ->
    {channel: compress name}, each checked against :data:`CHOICES`."""
    out = {c: next(iter(CHOICES[c])) for c in channels}
    if compress is None:
        return out
    text = str(compress).strip().lower()
    parts = [p.strip() for p in text.split(",") if p.strip()]
    per = {}
    for p in parts:
        name, eq, value = p.rpartition("=")
        chan = next((c for c in channels if c.lower() == name), None) if eq else None
        if eq and chan is None:
            raise BakeError(f"--compress {compress!r}: {name!r} is not a channel of this bake; "
                            f"accepted {accepted_list(channels)}")
        if value not in COMPRESS:
            raise BakeError(f"--compress {value!r}: accepted {accepted_list(COMPRESS)}")
        for c in ([chan] if eq else channels):
            per[c] = value
    if not parts:
        raise BakeError(f"--compress {compress!r}: accepted {accepted_list(COMPRESS)}, "
                        f"or CHANNEL=VALUE,... (e.g. color=bc1,height=none)")
    for c, v in per.items():
        if v not in CHOICES[c]:
            why = _WHY_NOT.get("F1" if c.startswith("F") else "roughness" if c in ("ao", "metallic") else c, "")
            raise BakeError(f"--compress {v} for {c}: {why}; accepted for {c}: "
                            f"{accepted_list(CHOICES[c])} (default {next(iter(CHOICES[c]))}); "
                            f"per channel: --compress {c}=VALUE,...")
        out[c] = v
    return out


def _format(channel: str, choice: str, bits) -> containers.TexFormat:
    entry = CHOICES[channel][choice]
    if isinstance(entry, str):
        if bits is not None and bits != 8:
            raise BakeError(f"--depth {bits} for {channel} in {choice.upper()} blocks: blocks hold "
                            f"8-bit samples; accepted --depth 8 (or none), or --compress {channel}=none "
                            f"for plain samples")
        return containers.TEX_FORMATS[entry]
    if bits is None:
        bits = next(iter(entry))
    if bits not in entry:
        raise BakeError(f"--depth {bits} for plain {channel} samples: accepted {accepted_list(entry)} "
                        f"({', '.join(entry.values())})")
    return containers.TEX_FORMATS[entry[bits]]


def _bits(bit_depth):
    if bit_depth is None:
        return None
    try:
        bits = int(str(bit_depth).strip())
    except ValueError:
        bits = None
    if bits not in (8, 16, 32):
        raise BakeError(f"--depth {bit_depth}: accepted 8, 16 or 32 (bits of the plain samples of "
                        f".dds/.ktx2; the default is per channel)")
    return bits


def plan_outputs(path: Path, ext: str, channels, compress, bit_depth, supercompression, size) -> list[TexOutput]:
    """The files of a ``.dds``/``.ktx2`` bake and their formats; every refusal before any work."""
    w, h, d = size
    if supercompression not in (None, "zstd"):
        raise BakeError(f"supercompression {supercompression!r}: accepted 'zstd' (or none)")
    if supercompression and ext != ".ktx2":
        raise BakeError(f"--zstd: zstd supercompression is a KTX2 feature; {ext} files hold "
                        f"the blocks as they are (accepted with -o NAME.ktx2)")
    side = MAX_SIDE_3D if d is not None else MAX_SIDE_2D
    if max(w, h, d or 1) > side:
        raise BakeError(f"size {w}x{h}{'' if d is None else f'x{d}'} for {ext}: a "
                        f"{'volume' if d is not None else '2D'} texture's sides are at most {side} "
                        f"(the GPUs' limit); accepted 1..{side}")
    if supercompression:
        try:
            import zstandard  # noqa: F401
        except ImportError:
            raise BakeError("--zstd needs the 'zstandard' package: pip install zstandard") from None
    bits = _bits(bit_depth)
    per = parse_compress(compress, channels)
    fmts = {c: _format(c, per[c], bits) for c in channels}
    if any(f.compressed for f in fmts.values()) and not blocks.have_encoder():
        raise BakeError("block-compressed .dds/.ktx2 need the 'etcpak' package: pip install 'cellgl[gpu]' "
                        "(or --compress none)")
    if len(channels) == 1:
        return [TexOutput(path, channels[0], fmts[channels[0]])]
    return [TexOutput(path.with_name(f"{path.stem}_{c}{path.suffix}"), c, fmts[c]) for c in channels]


def texel_samples(fmt: containers.TexFormat, channel: str, a: np.ndarray) -> np.ndarray:
    """One tile of render() output as the format's samples (the PNG bake's 8/16-bit bits)."""
    if fmt.name == "R32_UINT":
        return np.asarray(a).astype(np.uint32, copy=False)
    if fmt.name in ("R32_SFLOAT", "R16_SFLOAT"):
        return np.asarray(a).astype(np.float32 if fmt.name == "R32_SFLOAT" else np.float16)
    bits = 16 if fmt.name == "R16_UNORM" else 8
    samples = 3 if channel in ("color", "normal") else 4 if channel == "cloud" else 1
    q = Encoding(channel, samples, np.dtype(np.uint8 if bits == 8 else np.uint16)).encode(a)
    if samples == 3 and (fmt.codec in ("bc3", "bc7") or not fmt.compressed):
        q = np.concatenate([q, np.full(q.shape[:-1] + (1,), 255, np.uint8)], axis=-1)   # opaque alpha
    return q


def level_data(out: TexOutput, a: np.ndarray, depth) -> bytes:
    """One level's bytes in the file: plain samples, or the blocks of each slice (every core)."""
    if not out.fmt.compressed:
        return np.ascontiguousarray(a).tobytes()
    slices = list(a) if depth is not None else [a]
    return b"".join(blocks.encode_levels(out.fmt.codec, slices, perceptual=out.fmt.srgb))


def memory_need(outputs: list[TexOutput], chain) -> int:
    """Bytes a bake holds beyond the render of one tile: level 0's samples of every output (at
    most 4 a texel before block encoding) and every output's file bytes, all levels."""
    w, h = chain[0][:2]
    d = chain[0][2] if len(chain[0]) > 2 else 1
    need = 0
    for o in outputs:
        need += w * h * d * (4 if o.fmt.compressed else o.fmt.nbytes)
        need += sum(containers.level_bytes(o.fmt, *s) for s in chain)
    return need


def write_container(f, ext: str, fmt: containers.TexFormat, size, levels, *, supercompression=None,
                    metadata: str | None = None, layers=None) -> None:
    """Write ``levels`` (each level's bytes, :func:`packed_levels`) as a ``.dds`` or ``.ktx2``
    (``metadata``: the KTX2 ``cellgl`` key's JSON; DDS has no place for it)."""
    w, h, d = size
    if ext == ".dds":
        containers.write_dds(f, fmt, w, h, d, levels, layers=layers)
    else:
        containers.write_ktx2(f, fmt, w, h, d, levels, supercompression=supercompression, writer="cellgl",
                              metadata=None if metadata is None else metadata.encode() + b"\0", layers=layers)


def packed_levels(fmt: containers.TexFormat, images) -> list[bytes]:
    """The file bytes of each level of an image packed by the caller (a material set's map:
    ``(h, w)`` or ``(h, w, S)`` samples as they are, not render channels): uint8 samples for the
    block formats (BC4 keeps R, BC5 R and G, BC1/BC3/BC7 RGB(A), a missing alpha opaque; every
    level's blocks at once on every core, :func:`cellgl.io.blocks.encode_levels`), or exactly the
    plain format's samples (``R16_UNORM``: ``(h, w)`` uint16, ...) stored as they are."""
    images = list(images)
    if fmt.compressed:
        return blocks.encode_levels(fmt.codec, images, perceptual=fmt.srgb)
    want = {"R8_UNORM": (np.uint8, 1), "R16_UNORM": (np.uint16, 1), "R8G8B8A8_UNORM": (np.uint8, 4),
            "R8G8B8A8_SRGB": (np.uint8, 4), "R16_SFLOAT": (np.float16, 1), "R32_SFLOAT": (np.float32, 1),
            "R32_UINT": (np.uint32, 1)}[fmt.name]
    for a in images:
        n = a.shape[2] if a.ndim == 3 else 1
        if a.dtype != want[0] or n != want[1] or a.ndim not in (2, 3):
            raise ValueError(f"{fmt.name} holds {want[1]} {np.dtype(want[0])} sample(s) a texel; got {a.dtype} "
                             f"{a.shape}")
    return [np.ascontiguousarray(a).tobytes() for a in images]
