"""Loopable animations: ``cellgl bake --frames N`` and :func:`bake_frames`.

A recipe whose feature points orbit (``orbit_radius > 0``, :mod:`cellgl.texture.domain`) loops: frame
``k`` of ``N`` is the recipe at ``orbit_phase + k / N``, and frame ``N`` would be frame 0 again,
bit for bit (the phase reaches the shaders as an integer turn modulo 2^32). The frames are
written as a numbered sequence ``<stem>_0000<ext> .. <stem>_<N-1><ext>`` (any format
:func:`cellgl.bake.core.bake` writes, every channel it writes) or, for ``.webp`` and ``.gif``, as
one animated file that loops forever (colour only; WebP lossless).

An animated file is written as its frames are rendered, one at a time (this module writes the
GIF89a blocks and the WebP RIFF chunks, each frame encoded by Pillow alone: Pillow's own
multi-frame writers hold every frame until the end), so memory does not grow with the number
of frames; sizes beyond the format (WebP sides <= 16383, GIF <= 65535) or one frame's encoding
beyond half the memory budget are refused before anything is rendered.

All or nothing: every frame is rendered into a temporary folder next to the output first; only
when all are done are they moved into place (a move that fails undoes the ones before it), and
an animated file is written to a temporary name and renamed.
"""
from __future__ import annotations

import errno
import io
import os
import struct
from pathlib import Path

import numpy as np

from cellgl.bake.request import ANIMATED, DEFAULT_BUDGET, parse_channels, parse_size
from cellgl.io.spec import BakeError, check_size, quantize
from cellgl.io.gpu_textures import EXTS as GPU_EXTS
from cellgl.io.tempfiles import check_output, commit_lock, human_size, naming_destination_in, scratch_dir

__all__ = ["bake_frames", "ANIMATED", "MAX_FRAMES", "frame_recipe"]

MAX_FRAMES = 10000          #: most frames of a sequence (four-digit numbers)
#: an animated file's frame delay: milliseconds per unit of the format (WebP ms, GIF cs)
DELAY_UNIT_MS = {".webp": 1, ".gif": 10}
#: browsers (Firefox, Chromium) play a frame delay of 10 ms or less at 100 ms (10 fps): the
#: highest rate a file can play at is the one whose delay is the shortest above that
MAX_FPS_OF = {".webp": 95, ".gif": 50}
MAX_FPS = max(MAX_FPS_OF.values())
DEFAULT_FPS = {".webp": 24.0, ".gif": 25.0}  #: a GIF cannot store 24 fps (4 cs: 25 fps)
#: an asked rate the file's delay misses by more than this (relative) is warned of
FPS_TOLERANCE = 0.01


def frame_recipe(recipe, k: int, frames: int):
    """Frame ``k`` of a loop of ``frames``: the recipe at ``orbit_phase + k / frames``."""
    return recipe.replace(orbit_phase=recipe.get("orbit_phase") + k / frames)


def frame_delay(ext: str, fps) -> tuple[int, float]:
    """The delay an animated ``ext`` file stores for ``fps`` (in its units: WebP milliseconds,
    GIF hundredths of a second, the nearest to ``1 / fps``) and the rate it plays at.

    Raises
    ------
    BakeError
        ``fps`` is not a number in 1..``MAX_FPS_OF[ext]``: a faster rate would need a delay of
        10 ms or less, which browsers play at 10 fps (a GIF's 0 or 1 cs, a WebP's <= 10 ms).
    """
    most = MAX_FPS_OF[ext]
    if isinstance(fps, bool) or not isinstance(fps, (int, float, np.number)) or not 1 <= fps <= most:
        why = ("a GIF stores each frame's delay in hundredths of a second and browsers play a delay "
               "under 2 (0.02 s) at 10 fps, so 50 fps is its fastest (rates 100/n: 50, 33.3, 25, 20, ...)"
               if ext == ".gif" else "browsers play a frame delay of 10 ms or less at 10 fps")
        raise BakeError(f"--fps {fps!r}: accepted for {ext} a number in 1..{most} ({why})")
    unit = DELAY_UNIT_MS[ext]
    delay = max(1, int(round(1000.0 / unit / float(fps))))
    return delay, 1000.0 / (unit * delay)


def _rate_note(ext: str, fps, frames: int) -> str | None:
    """A warning when the rate ``ext`` can store misses ``fps`` by more than ``FPS_TOLERANCE``."""
    delay, real = frame_delay(ext, fps)
    if abs(real - fps) <= FPS_TOLERANCE * fps:
        return None
    what = f"{delay} cs ({delay * 10} ms)" if ext == ".gif" else f"{delay} ms"
    exact = ("rates a GIF stores exactly: 100/n, e.g. 50, 25, 20, 12.5, 10" if ext == ".gif"
             else "rates a WebP stores exactly: 1000/n, e.g. 50, 40, 25, 20")
    return (f"--fps {fps:g}: an animated {ext} stores a delay of {what} a frame, so it plays at "
            f"{real:.4g} fps (the {frames} frames last {frames / real:.4g} s, not "
            f"{frames / fps:.4g} s); {exact}")


def _check(frames, fps, recipe, ext, channels):
    if isinstance(frames, bool) or not isinstance(frames, (int, np.integer)) or not 1 <= frames <= MAX_FRAMES:
        raise BakeError(f"--frames {frames!r}: accepted a whole number in 1..{MAX_FRAMES}")
    if ext in ANIMATED:
        frame_delay(ext, fps)
    elif isinstance(fps, bool) or not isinstance(fps, (int, float, np.number)) or not 1 <= fps <= MAX_FPS:
        raise BakeError(f"--fps {fps!r}: accepted a number in 1..{MAX_FPS}")
    if getattr(recipe, "kind", None) == "pups":
        raise BakeError(f"--frames: {recipe.name} is a PUPs recipe, which has no orbit animation; "
                        "accepted: a cellular recipe with basis.orbit_radius > 0")
    if recipe.get("orbit_radius") <= 0.0:
        raise BakeError(f"--frames {frames}: recipe {recipe.name!r} does not move (basis.orbit_radius is 0); "
                        "accepted: basis.orbit_radius in (0, 0.5], e.g. --set orbit_radius=0.25")
    if ext in ANIMATED and tuple(channels) != ("color",):
        raise BakeError(f"--frames to {ext}: an animated {ext} holds the colour only, got channels "
                        f"{','.join(channels)}; accepted: --channels color, or a numbered sequence "
                        "(.png, .exr, .tif, .npy)")


def bake_frames(recipe_or_name, path, frames: int, *, fps: float | None = None, size=(256, 256),
                channels=("color",), bit_depth=None, tileable=None, sets=(), progress=False,
                **bake_kw) -> list[Path]:
    """Bake a loop of ``frames`` frames of an orbiting recipe.

    Parameters
    ----------
    recipe_or_name : Recipe, preset name or recipe JSON path
        Its ``orbit_radius`` must be > 0 (else nothing moves).
    path : str or PathLike
        ``name.webp`` / ``name.gif``: one animated, endlessly looping file (colour only).
        ``name.dds`` / ``name.ktx2``: one array texture, a layer per frame (per channel
        ``name_<channel>.dds`` when several are asked for; ``mips``, ``compress`` in ``bake_kw``).
        Otherwise (``.png``, ``.exr``, ``.tif``, ``.npy``) the sequence ``name_0000.png`` ..
        (per channel ``name_0000_<channel>.png`` when several are asked for).
    frames : int in 1..10000
    fps : float, optional
        Frames per second of an animated file: 1..95 for ``.webp`` (default 24), 1..50 for
        ``.gif`` (default 25). The file stores a delay per frame (WebP in milliseconds, GIF in
        hundredths of a second), the nearest to ``1 / fps``; where the rate that plays misses
        ``fps`` by more than 1% (GIF 24 fps: 4 cs, 25 fps) a ``UserWarning`` says the real rate.
        Faster rates are refused: browsers play a delay of 10 ms or less at 10 fps.
    size, channels, bit_depth, tileable, sets, bake_kw :
        as :func:`cellgl.bake.core.bake` (``size`` default 256 x 256).

    Returns
    -------
    list of pathlib.Path
        The files written, in frame order.

    Raises
    ------
    cellgl.io.spec.BakeError
        Bad frame count, fps, extension or channels, or a recipe that does not move. Nothing
        is written.
    """
    from cellgl.bake.core import check_path, load_recipe_sets, Progress, bake

    path = Path(os.fspath(path))
    ext = path.suffix.lower()
    channels = parse_channels(channels)
    parent = path.parent if str(path.parent) else Path(".")
    if ext not in ANIMATED:
        check_path(path)                     # names the accepted extensions
    else:
        try:
            check_output(path)                # the one rule of every command's output
        except ValueError as exc:
            raise BakeError(str(exc)) from None
    recipe = load_recipe_sets(recipe_or_name, sets, tileable)
    if fps is None:
        fps = DEFAULT_FPS.get(ext, 24.0)
    _check(frames, fps, recipe, ext, channels)
    if ext in ANIMATED:
        w, h = _animated_size(path, size, bake_kw.get("memory_budget", DEFAULT_BUDGET))
        note = _rate_note(ext, fps, frames)
        if note:
            import warnings

            warnings.warn(note, UserWarning, stacklevel=2)
    if ext in GPU_EXTS:     # one array texture, a layer per frame (cellgl.bake.gputex)
        return bake(recipe, path, size=size, channels=channels, bit_depth=bit_depth, progress=progress,
                    layers=[frame_recipe(recipe, k, frames) for k in range(frames)], **bake_kw)
    bar = Progress(frames, f"baking {path.name}", progress, unit="frames")
    # the folder is swept by a later bake if this one is killed
    with scratch_dir(path) as tmp, bar:
        if ext in ANIMATED:
            return [_animated(recipe, path, tmp, frames, fps, (w, h), bake_kw, bar)]
        names = []
        for k in range(frames):
            target = tmp / f"{path.stem}_{k:04d}{path.suffix}"
            try:
                names += bake(frame_recipe(recipe, k, frames), target, size=size, channels=channels,
                              bit_depth=bit_depth, progress=progress and frames == 1, **bake_kw)
            except (BakeError, OSError) as exc:     # name the frame's file, not the hidden folder
                raise naming_destination_in(exc, tmp, parent) from None
            bar.step()
        return _move_all(names, parent)


def _move_all(files: list[Path], parent: Path) -> list[Path]:
    """Move the finished frames into ``parent``; if one move fails, move back those done."""
    done = []
    try:
        with commit_lock([parent]):     # a concurrent bake of the same names: one set after the other
            for f in files:
                dest = parent / f.name
                os.replace(f, dest)
                done.append((f, dest))
    except BaseException:
        for f, dest in reversed(done):
            try:
                os.replace(dest, f)
            except OSError:
                pass
        raise
    return [d for _, d in done]


#: largest side of an animated file (WebP stores width - 1 in 14 bits; GIF in 16 bits)
ANIMATED_MAX_SIDE = {".webp": 16383, ".gif": 65535}
#: memory per pixel of the frame being encoded, beyond its render (measured with Pillow 13: the
#: RGB frame, its copy as an image, and the encoder: WebP lossless 12-18 bytes, GIF 5-8 bytes)
ANIMATED_BYTES_PER_PIXEL = {".webp": 24, ".gif": 16}


def _animated_size(path: Path, size, budget: int) -> tuple[int, int]:
    """The frame size of an animated file, checked against the format's largest side and
    against ``budget`` (one whole frame is encoded at a time; half the budget is for it, the
    other half for the render of its tiles), before anything is rendered."""
    ext = path.suffix.lower()
    if isinstance(size, str):
        w, h, d = parse_size(size)
        if d is not None:
            raise BakeError(f"--frames to {ext}: a volume size ({size}) cannot be animated; "
                            "accepted: WxH")
    else:
        w, h = (size, size) if isinstance(size, (int, np.integer)) else tuple(size)
        check_size(w, h, None, f"size {w}x{h}")
    most = ANIMATED_MAX_SIDE[ext]
    if max(w, h) > most:
        raise BakeError(f"--size {w}x{h}: an animated {ext} has sides of at most {most} pixels; "
                        f"accepted: 1..{most}, or a numbered sequence (-o NAME.png)")
    need = w * h * ANIMATED_BYTES_PER_PIXEL[ext]
    if need > budget // 2:
        raise BakeError(f"--size {w}x{h}: encoding one {ext} frame of that size takes about "
                        f"{human_size(need)}, more than half of --memory {budget >> 20} (MB); "
                        f"accepted: --memory {-(-2 * need // (1 << 20))} or more, a smaller --size, "
                        "or a numbered sequence (-o NAME.png), which is rendered tile by tile")
    return int(w), int(h)


def _frame_rgb(recipe, w: int, h: int, plan) -> np.ndarray:
    """The colour of ``recipe`` at ``w x h`` as uint8 (h, w, 3), rendered tile by tile as
    ``plan`` says (the same bits as a one-pass render), quantised as every 8-bit output is
    (:func:`cellgl.io.spec.quantize`): a lossless WebP frame holds the 8-bit PNG frame's bits."""
    from cellgl import recipes

    out = np.empty((h, w, 3), np.uint8)
    for x0, y0, tw, th in plan.tiles():
        rgb = recipes.render(recipe, w, h, channels=("color",), x0=x0, y0=y0, tile_w=tw,
                             tile_h=th)["color"][..., :3]
        out[y0:y0 + th, x0:x0 + tw] = quantize(rgb, 8)     # the PNG frames' bits
    return out


def _animated(recipe, path: Path, tmp: Path, frames: int, fps: float, size, bake_kw, bar) -> Path:
    """Render and encode one frame at a time, appending each to the file as it comes: memory
    holds one frame, whatever the number of frames."""
    from cellgl.bake.core import plan_tiles

    w, h = size
    budget = bake_kw.get("memory_budget", DEFAULT_BUDGET)
    plan = plan_tiles(w, h, None, ".png", ("color",), bake_kw.get("tile"), budget // 2, 3)
    ext = path.suffix.lower()
    delay, _ = frame_delay(ext, fps)
    duration = delay * DELAY_UNIT_MS[ext]          # ms (a GIF's: whole hundredths)
    part = tmp / f"{path.stem}{path.suffix}"

    def images():
        for k in range(frames):
            yield _frame_rgb(frame_recipe(recipe, k, frames), w, h, plan)
            bar.step()

    try:
        with open(part, "wb") as f:
            (_write_webp if ext == ".webp" else _write_gif)(f, images(), w, h, duration)
    except OSError as exc:
        if exc.errno in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG):
            raise BakeError(f"cannot write {path}: {exc.strerror}") from None
        raise
    os.replace(part, path)
    return path


def _write_gif(f, frames, w: int, h: int, duration: int) -> None:
    """An endlessly looping GIF89a of the uint8 RGB ``frames``, each with its own palette
    (Pillow's adaptive one, as its GIF writer makes) and shown ``duration`` ms (a multiple of
    10: Pillow stores ``duration // 10`` hundredths), written frame by frame."""
    from PIL import GifImagePlugin, Image

    f.write(b"GIF89a" + struct.pack("<HHBBB", w, h, 0, 0, 0))   # no global colour table
    f.write(b"!\xff\x0bNETSCAPE2.0\x03\x01" + struct.pack("<H", 0) + b"\x00")  # loop for ever
    for rgb in frames:
        im = Image.fromarray(rgb, "RGB").convert("P", palette=Image.Palette.ADAPTIVE)
        for chunk in GifImagePlugin.getdata(im, (0, 0), duration=duration, disposal=1,
                                            include_color_table=True):
            f.write(chunk)
    f.write(b";")


def _riff_chunks(data: bytes) -> dict[bytes, bytes]:
    """The chunks of a RIFF WEBP file, ``{fourcc: chunk with its header and padding}``."""
    if data[:4] != b"RIFF" or data[8:12] != b"WEBP":
        raise RuntimeError("Pillow did not write a RIFF WEBP file")
    chunks, i = {}, 12
    while i + 8 <= len(data):
        n = struct.unpack("<I", data[i + 4:i + 8])[0]
        end = i + 8 + n + (n & 1)
        chunks[data[i:i + 4]] = data[i:end]
        i = end
    return chunks


#: largest RIFF file (its size field has 32 bits)
_RIFF_MAX = (1 << 32) - 2


def _write_webp(f, frames, w: int, h: int, duration: int) -> None:
    """An endlessly looping animated lossless WebP of the uint8 RGB ``frames``, shown
    ``duration`` ms each, written frame by frame: each frame is encoded alone (Pillow,
    lossless) and its bitstream wrapped in an ANMF chunk (the WebP container spec)."""
    from PIL import Image

    def u24(n: int) -> bytes:
        return struct.pack("<I", n)[:3]

    f.write(b"RIFF\0\0\0\0WEBP")                    # size patched at the end
    f.write(b"VP8X" + struct.pack("<I", 10) + bytes([0x02, 0, 0, 0]) + u24(w - 1) + u24(h - 1))
    f.write(b"ANIM" + struct.pack("<I", 6) + struct.pack("<IH", 0xFFFFFFFF, 0))  # white, forever
    size = 4 + 18 + 14
    for rgb in frames:
        buf = io.BytesIO()
        Image.fromarray(rgb, "RGB").save(buf, "WEBP", lossless=True, exact=True)
        bits = _riff_chunks(buf.getvalue()).get(b"VP8L")
        if bits is None:
            raise RuntimeError("Pillow's lossless WebP frame holds no VP8L bitstream")
        # offset 0, 0; the frame's size; no blending (bit 1), no disposal
        head = u24(0) + u24(0) + u24(w - 1) + u24(h - 1) + u24(min(duration, (1 << 24) - 1)) + b"\x02"
        payload = len(head) + len(bits)
        size += 8 + payload
        if size > _RIFF_MAX:
            raise BakeError("the animation passes the 4 GiB a WebP file can hold; accepted: "
                            "fewer --frames, a smaller --size, or a .gif")
        f.write(b"ANMF" + struct.pack("<I", payload) + head + bits)
    f.seek(4)
    f.write(struct.pack("<I", size))
