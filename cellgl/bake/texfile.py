"""Tiled, mip-mapped texture bakes for film renderers: ``.tx`` and ``--tiled [--mips]`` ``.exr`` /
``.tif`` (docs/bake.md, "Film pipelines"; :func:`cellgl.bake.core.bake` hands them here).

The levels are cellgl's own, each rendered from the recipe at its level's size by the one mip
chain implementation, :mod:`cellgl.bake.mips` (never downsampled: no ``maketx`` /
``ImageBufAlgo.make_texture`` filtering), a UDIM tile's as its crop of the set's virtual bake;
:mod:`cellgl.io.tiled` lays them into the files.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from cellgl.io.tiled import write_exr_levels, write_tiff_levels

__all__ = ["write_texture"]

_RENDER_TILE = 2048                      #: largest side one render call gets (as the bake's MAX_TILE)


def _levels(recipe, w: int, h: int, mips: bool, channels, samples: int, window):
    """``(k, {channel: array})`` of every level (level 0 only without ``mips``), rendered by
    :mod:`cellgl.bake.mips`; a UDIM tile (``window`` = (tile, tiles)) is its crop of the set's
    virtual bake at the level's size."""
    from cellgl.bake import mips as mip_mod

    count = mip_mod.level_count(w, h) if mips else 1
    for k in range(count):
        if window is None:
            yield k, mip_mod.render_level(recipe, w, h, k, channels=channels, samples=samples)
            continue
        from cellgl.bake import udim as udim_mod

        t, tiles = window
        lw, lh = mip_mod.level_size(w, h, k)
        _, _, cols, rows = udim_mod.bounds(tiles)
        x0, y0 = udim_mod.tile_origin(t, tiles, lw, lh)
        yield k, _window(recipe, cols * lw, rows * lh, x0, y0, lw, lh, channels, samples)


def _window(recipe, fw, fh, x0, y0, w, h, channels, samples):
    """The ``w x h`` window at (x0, y0) of the ``fw x fh`` bake, in tiles of at most 2048."""
    from cellgl import recipes

    extra = {"samples": samples} if samples != 1 else {}
    out: dict[str, np.ndarray] = {}
    for ty in range(0, h, _RENDER_TILE):
        for tx in range(0, w, _RENDER_TILE):
            tw, th = min(_RENDER_TILE, w - tx), min(_RENDER_TILE, h - ty)
            res = recipes.render(recipe, fw, fh, channels=tuple(channels), x0=x0 + tx, y0=y0 + ty,
                                 tile_w=tw, tile_h=th, **extra)
            for name, a in res.items():
                if name not in out:
                    out[name] = np.empty((h, w) + a.shape[2:], a.dtype)
                out[name][ty:ty + th, tx:tx + tw] = a
    return out


def write_texture(tmp: Path, recipe, out, ext: str, size: tuple[int, int], *, mips: bool,
                  samples: int = 1, window=None, meta: str = "", progress: bool = False) -> None:
    """Render ``out`` (a :class:`cellgl.bake.core._Output`) level by level into the tiled file
    ``tmp`` (its temporary path; the bake moves it into place)."""
    from cellgl.io.progress import Progress

    w, h = size
    from cellgl.bake import mips as mip_mod

    bar = Progress(mip_mod.level_count(w, h) if mips else 1, f"baking {out.path.name}", progress,
                   unit="levels")
    wrap = "periodic,periodic" if recipe.get("tileable") else "clamp,clamp"
    levels = _levels(recipe, w, h, mips, out.channels, samples, window)
    with bar:
        write = write_exr_levels if ext == ".exr" else write_tiff_levels
        write(tmp, levels, out.encodings, meta, wrap, bar, mips)
