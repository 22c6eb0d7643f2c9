"""Loopable animations: ``cellgl bake --frames N`` and :func:`bake_frames`.

A recipe whose feature points orbit (``orbit_radius > 0``, :mod:`cellgl.texture.domain`) loops: frame
``k`` of ``N`` is the recipe at ``orbit_phase + k / N``, and frame ``N`` would be frame 0 again,
bit for bit (the phase reaches the shaders as an integer turn modulo 2^32). The frames are
written as a numbered sequence ``<stem>_0000<ext> .. <stem>_<N-1><ext>`` (any format
:func:`cellgl.io.bake.bake` writes, every channel it writes) or, for ``.webp`` and ``.gif``, as
one animated file that loops forever (Pillow; colour only; WebP lossless).

All or nothing: every frame is rendered into a temporary folder next to the output first; only
when all are done are they moved into place (a move that fails undoes the ones before it), and
an animated file is written to a temporary name and renamed.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from cellgl.io.spec import BakeError, check_size, parse_channels, parse_size
from cellgl.io.tempfiles import scratch_dir

__all__ = ["bake_frames", "ANIMATED", "MAX_FRAMES", "frame_recipe"]

#: extensions written as one animated file
ANIMATED = (".webp", ".gif")
MAX_FRAMES = 10000          #: most frames of a sequence (four-digit numbers)
MAX_FPS = 120


def frame_recipe(recipe, k: int, frames: int):
    """Frame ``k`` of a loop of ``frames``: the recipe at ``orbit_phase + k / frames``."""
    return recipe.replace(orbit_phase=recipe.get("orbit_phase") + k / frames)


def _check(frames, fps, recipe, ext, channels):
    if isinstance(frames, bool) or not isinstance(frames, (int, np.integer)) or not 1 <= frames <= MAX_FRAMES:
        raise BakeError(f"--frames {frames!r}: accepted a whole number in 1..{MAX_FRAMES}")
    if isinstance(fps, bool) or not isinstance(fps, (int, float, np.number)) or not 1 <= fps <= MAX_FPS:
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


def bake_frames(recipe_or_name, path, frames: int, *, fps: float = 24.0, size=(256, 256),
                channels=("color",), bit_depth=None, tileable=None, sets=(), progress=False,
                **bake_kw) -> list[Path]:
    """Bake a loop of ``frames`` frames of an orbiting recipe.

    Parameters
    ----------
    recipe_or_name : Recipe, preset name or recipe JSON path
        Its ``orbit_radius`` must be > 0 (else nothing moves).
    path : str or PathLike
        ``name.webp`` / ``name.gif``: one animated, endlessly looping file (colour only).
        Otherwise (``.png``, ``.exr``, ``.tif``, ``.npy``) the sequence ``name_0000.png`` ..
        (per channel ``name_0000_<channel>.png`` when several are asked for).
    frames : int in 1..10000
    fps : float in [1, 120]
        Frames per second of an animated file.
    size, channels, bit_depth, tileable, sets, bake_kw :
        as :func:`cellgl.io.bake.bake` (``size`` default 256 x 256).

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
    from cellgl.io.bake import _check_path, _load, _Progress, bake

    path = Path(os.fspath(path))
    ext = path.suffix.lower()
    channels = parse_channels(channels)
    parent = path.parent if str(path.parent) else Path(".")
    if ext not in ANIMATED:
        _check_path(path)                     # names the accepted extensions
    elif not parent.is_dir():
        raise BakeError(f"output directory {str(parent)!r} does not exist")
    recipe = _load(recipe_or_name, sets, tileable)
    _check(frames, fps, recipe, ext, channels)
    bar = _Progress(frames, f"baking {path.name}", progress, unit="frames")
    # the folder is swept by a later bake if this one is killed
    with scratch_dir(path) as tmp, bar:
        if ext in ANIMATED:
            return [_animated(recipe, path, tmp, frames, fps, size, bar)]
        names = []
        for k in range(frames):
            target = tmp / f"{path.stem}_{k:04d}{path.suffix}"
            names += bake(frame_recipe(recipe, k, frames), target, size=size, channels=channels,
                          bit_depth=bit_depth, progress=progress and frames == 1, **bake_kw)
            bar.step()
        return _move_all(names, parent)


def _move_all(files: list[Path], parent: Path) -> list[Path]:
    """Move the finished frames into ``parent``; if one move fails, move back those done."""
    done = []
    try:
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


def _animated(recipe, path: Path, tmp: Path, frames: int, fps: float, size, bar) -> Path:
    from PIL import Image

    from cellgl import recipes

    if isinstance(size, str):
        w, h, d = parse_size(size)
        if d is not None:
            raise BakeError(f"--frames to {path.suffix}: a volume size ({size}) cannot be animated; "
                            "accepted: WxH")
    else:
        w, h = (size, size) if isinstance(size, (int, np.integer)) else tuple(size)
        check_size(w, h, None, f"size {w}x{h}")
    images = []
    for k in range(frames):
        rgb = recipes.render(frame_recipe(recipe, k, frames), w, h, channels=("color",))["color"][..., :3]
        images.append(Image.fromarray(np.round(np.clip(rgb, 0.0, 1.0) * 255.0).astype(np.uint8), "RGB"))
        bar.step()
    duration = int(round(1000.0 / fps))
    part = tmp / f"{path.stem}{path.suffix}"
    kw = dict(save_all=True, append_images=images[1:], duration=duration, loop=0)
    if path.suffix.lower() == ".webp":
        kw.update(lossless=True)
    else:
        kw.update(disposal=1)
    try:
        images[0].save(part, **kw)
    except (OSError, KeyError, ValueError) as exc:
        raise BakeError(f"cannot write {path.suffix} animation with Pillow: {exc}") from None
    os.replace(part, path)
    return path

