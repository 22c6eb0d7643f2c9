"""Mip chains rendered level by level from the recipe (``bake(..., mips=True)``, ``--mips``).

Level ``k`` of a ``W x H`` (x ``D``) bake is ``ceil(W / 2^k) x ceil(H / 2^k)`` (x ``ceil(D /
2^k)``), down to 1 x 1 (x 1): :func:`mip_sizes` (``rounding="up"``, the default: no texel of
the texture is dropped; OpenEXR's ``ROUND_UP`` mip mode). DDS and KTX2 define their levels as
``max(1, floor(W / 2^k))`` (Direct3D, Vulkan and OpenGL do), so their files take
``rounding="down"``: for power-of-two sides the two chains are the same.

Every level is **rendered** from the recipe at its own size, never downsampled from level 0: the
bake's footprint (``1 / W`` of a ``W``-pixel side, cellgl.texture.antialias) is that level's, so
the band limit fades the octaves finer than a texel of that level, and ``--samples`` averages
the texel's own sub-pixels. A level is therefore a correct prefilter of the procedural
texture, and a tileable recipe (which repeats a whole number of cells over the image) stays
seamless at every level. :func:`render_level` renders a level tile by tile (tiles are
bit-identical to a one-pass ``render``), so level ``k`` equals
``cellgl.render(recipe, *mip_sizes(W, H)[k], channels=..., samples=...)`` bit for bit, and level 0
is the bake without mips.

Formats that hold levels (DDS, KTX2) put them in the file; the others (PNG, EXR, TIFF, NPY) get
numbered files beside level 0: ``<name><ext>`` is level 0, ``<name>_mip<k><ext>`` level ``k``
(:func:`level_path`). See docs/bake.md ("Mip chains").
"""
from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path

import numpy as np

__all__ = ["ROUNDINGS", "RENDER_TILE", "mip_sizes", "level_size", "level_count", "level_path", "render_level",
           "render_chain"]

#: the largest tile side one render call of :func:`render_level` gets (as the bake's MAX_TILE)
RENDER_TILE = 2048


ROUNDINGS = ("up", "down")


def _rounding(rounding: str) -> str:
    if rounding not in ROUNDINGS:
        raise ValueError(f"rounding {rounding!r}: accepted {', '.join(ROUNDINGS)}")
    return rounding


def level_count(width: int, height: int, depth: int | None = None, rounding: str = "up") -> int:
    """Levels of a full chain down to 1 x 1: ``ceil(log2(max side)) + 1`` rounding up,
    ``floor(log2(max side)) + 1`` rounding down (1 for a 1 x 1 image)."""
    side = max(int(width), int(height), int(depth or 1))
    if side < 1:
        raise ValueError(f"mip chain of a {width}x{height} image: sides must be >= 1")
    return (side - 1).bit_length() + 1 if _rounding(rounding) == "up" else side.bit_length()


def level_size(width: int, height: int, level: int, depth: int | None = None,
               rounding: str = "up") -> tuple[int, ...]:
    """``(ceil(W / 2^k), ceil(H / 2^k))`` (``max(1, floor(.))`` rounding down), with the
    depth's appended for a volume."""
    n = level_count(width, height, depth, rounding)
    if not isinstance(level, (int, np.integer)) or not 0 <= level < n:
        raise ValueError(f"mip level {level}: accepted 0..{n - 1}")
    d = 1 << int(level)
    sides = (width, height) + ((depth,) if depth is not None else ())
    if rounding == "up":
        return tuple(-(-int(s) // d) for s in sides)
    return tuple(max(1, int(s) // d) for s in sides)


def mip_sizes(width: int, height: int, depth: int | None = None,
              rounding: str = "up") -> list[tuple[int, ...]]:
    """The sizes of every level, level 0 first, down to 1 x 1 (x 1).

    >>> mip_sizes(5, 3)
    [(5, 3), (3, 2), (2, 1), (1, 1)]
    >>> mip_sizes(5, 3, rounding="down")
    [(5, 3), (2, 1), (1, 1)]
    """
    return [level_size(width, height, k, depth, rounding)
            for k in range(level_count(width, height, depth, rounding))]


def level_path(path: str | Path, level: int) -> Path:
    """Where a format without levels puts level ``k``: ``<stem>_mip<k><ext>`` (level 0: ``path``)."""
    path = Path(path)
    return path if level == 0 else path.with_name(f"{path.stem}_mip{level}{path.suffix}")


def _tiles(width: int, height: int, tile: int) -> Iterator[tuple[int, int, int, int]]:
    for y0 in range(0, height, tile):
        for x0 in range(0, width, tile):
            yield x0, y0, min(tile, width - x0), min(tile, height - y0)


def render_level(recipe, width: int, height: int, level: int, *, depth: int | None = None,
                 channels: Sequence[str] = ("color",), samples: int = 1, tile: int | None = None,
                 backend: str = "gpu", rounding: str = "up",
                 convert: Mapping[str, Callable[[np.ndarray], np.ndarray]] | None = None) -> dict[str, np.ndarray]:
    """Level ``level`` of the chain of a ``width x height`` (x ``depth``) bake, rendered from
    ``recipe`` at that level's size (:func:`level_size`) in tiles of ``tile`` pixels (default
    2048): ``{channel: array}`` as :func:`cellgl.render` gives them, the same bits.

    ``convert`` maps a channel to a function applied to each tile's array as it is rendered (an
    elementwise encoding, e.g. to the file's 8-bit samples), so only the converted level is held.

    ``recipe`` is what the bake renders (already made tileable, ``--set`` applied).
    """
    from cellgl import recipes

    size = level_size(width, height, level, depth, rounding)
    w, h = size[0], size[1]
    d = size[2] if depth is not None else None
    side = int(tile or RENDER_TILE)
    extra = {"samples": samples} if samples != 1 else {}
    convert = dict(convert or {})

    def converted(res):
        return {name: (convert[name](a) if name in convert else a) for name, a in res.items()}

    if w <= side and h <= side:
        return converted(recipes.render(recipe, w, h, channels=tuple(channels), depth=d, backend=backend,
                                        **extra))
    out: dict[str, np.ndarray] = {}
    for x0, y0, tw, th in _tiles(w, h, side):
        res = converted(recipes.render(recipe, w, h, channels=tuple(channels), x0=x0, y0=y0, tile_w=tw,
                                       tile_h=th, depth=d, backend=backend, **extra))
        for name, a in res.items():
            if name not in out:
                lead = a.shape[:1] if d is not None else ()
                out[name] = np.empty(lead + (h, w) + a.shape[len(lead) + 2:], a.dtype)
            if d is not None:
                out[name][:, y0:y0 + th, x0:x0 + tw] = a
            else:
                out[name][y0:y0 + th, x0:x0 + tw] = a
    return out


def render_chain(recipe, width: int, height: int, *, depth: int | None = None,
                 channels: Sequence[str] = ("color",), samples: int = 1, tile: int | None = None,
                 backend: str = "gpu", rounding: str = "up"
                 ) -> Iterator[tuple[int, tuple[int, ...], dict[str, np.ndarray]]]:
    """``(level, size, {channel: array})`` for every level, level 0 first (:func:`render_level`;
    one level in memory at a time)."""
    for k, size in enumerate(mip_sizes(width, height, depth, rounding)):
        yield k, size, render_level(recipe, width, height, k, depth=depth, channels=channels,
                                    samples=samples, tile=tile, backend=backend, rounding=rounding)
