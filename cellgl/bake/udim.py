"""UDIM sets for ``cellgl bake --udim 1001-1012`` / ``--udims UxV`` (docs/bake.md, "Film pipelines").

Tile ``1001 + u + 10 v`` (``u`` in 0..9, ``v`` in 0..9: 1001..1100) holds the texture over
texture coordinates ``[u, u+1) x [v, v+1)`` as renderers read UDIMs (``v`` up, a file's top row
at the tile's top). cellgl's own uv has ``v = 0`` at an image's top row and the MaterialX node
reads cellgl at ``(u, 1 - v)`` (docs/materialx.md), so tile ``(u, v)`` is cellgl's uv window
``[u, u+1) x [-v, 1-v)``, rows top first, and tile 1001 is the plain bake.

Every tile is a tile of one virtual bake over the bounding rectangle of the set: the recipe with
``frequency`` times the columns, ``aspect`` times rows / columns and the offsets moved to the
rectangle's corner (:func:`window_recipe`), its pixels rendered by the same tiled
:func:`cellgl.recipes.render` as any bake. So the tiles equal crops of that one bake bit for bit
and are continuous across every shared edge.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

__all__ = ["UDIM_TOKEN", "UdimTile", "parse_udim", "parse_udims", "window_recipe", "tile_path",
           "tiles_for", "tile_origin", "bounds", "check_extent", "UdimError"]

UDIM_TOKEN = "<UDIM>"
FIRST, LAST = 1001, 1100


class UdimError(ValueError):
    """A bad UDIM request; the message names the value and what is accepted."""


@dataclass(frozen=True)
class UdimTile:
    number: int        #: 1001 + u + 10 v
    u: int
    v: int


def _tile(n: int) -> UdimTile:
    return UdimTile(n, (n - FIRST) % 10, (n - FIRST) // 10)


def parse_udim(text) -> list[UdimTile]:
    """``"1001-1012"``, ``"1001"`` or ``"1001,1002,1011"`` (ranges and numbers, comma-separated)
    -> the tiles in increasing order. Raises :class:`UdimError` for anything malformed or a number
    outside 1001..1100."""
    accepted = (f"accepted tile numbers {FIRST}..{LAST} as N, N-M or a comma list of them "
                f"(e.g. 1001-1012)")
    numbers: set[int] = set()
    parts = [p.strip() for p in str(text).split(",")]
    for part in parts:
        m = re.fullmatch(r"(\d+)(?:\s*-\s*(\d+))?", part)
        if not m:
            raise UdimError(f"--udim {text!r}: {part!r} is not a tile number or range; {accepted}")
        lo = int(m.group(1))
        hi = int(m.group(2)) if m.group(2) else lo
        for n in (lo, hi):
            if not FIRST <= n <= LAST:
                raise UdimError(f"--udim {text!r}: tile {n} is out of range; {accepted}")
        if hi < lo:
            raise UdimError(f"--udim {text!r}: range {lo}-{hi} runs backwards; {accepted}")
        numbers.update(range(lo, hi + 1))
    return [_tile(n) for n in sorted(numbers)]


def parse_udims(text) -> list[UdimTile]:
    """``"UxV"``: ``U`` columns (1..10) by ``V`` rows (1..10) from tile 1001."""
    m = re.fullmatch(r"\s*(\d+)\s*[xX*]\s*(\d+)\s*", str(text))
    if not m or not (1 <= int(m.group(1)) <= 10 and 1 <= int(m.group(2)) <= 10):
        raise UdimError(f"--udims {text!r}: accepted UxV with U columns and V rows in 1..10 "
                        f"(e.g. 4x2: tiles 1001-1004 and 1011-1014)")
    nu, nv = int(m.group(1)), int(m.group(2))
    return [_tile(FIRST + u + 10 * v) for v in range(nv) for u in range(nu)]


def bounds(tiles: list[UdimTile]) -> tuple[int, int, int, int]:
    """(u_min, v_min, columns, rows) of the rectangle the tiles span."""
    us, vs = [t.u for t in tiles], [t.v for t in tiles]
    return min(us), min(vs), max(us) - min(us) + 1, max(vs) - min(vs) + 1


def check_extent(tiles: list[UdimTile], w: int, h: int, max_side: int) -> None:
    """:class:`UdimError` unless the set's virtual bake (columns x ``w`` by rows x ``h``) fits
    ``max_side``, the largest side one render takes (nothing to check for no tiles)."""
    if not tiles:
        return
    _, _, cols, rows = bounds(tiles)
    for name, n, side in (("columns", cols, w), ("rows", rows, h)):
        if n * side > max_side:
            raise UdimError(f"--udim: {n} {name} of {side} px make a bake {n * side} px across; "
                            f"accepted at most {max_side} (tiles of at most {max_side // n} px "
                            f"for {n} {name})")


def tile_origin(tile: UdimTile, tiles: list[UdimTile], w: int, h: int) -> tuple[int, int]:
    """Pixel (x, y) of ``tile``'s top-left corner in the virtual bake of the whole rectangle
    (``columns * w`` by ``rows * h``, the top row band being the highest ``v``)."""
    u0, v0, _, rows = bounds(tiles)
    return (tile.u - u0) * w, (v0 + rows - 1 - tile.v) * h


#: parameters whose values are places in uv (not cells): a window cannot move them exactly
_UV_SPACE = {"density_map": "none", "cell_color": "ramp"}


def window_recipe(recipe, tiles: list[UdimTile]):
    """The recipe whose uv square shows cellgl's uv window of the whole rectangle of ``tiles``
    (see the module docstring). Raises :class:`UdimError` for a recipe that has no such window:
    a PUPs recipe, or uv-space maps (a density map, cell colours from an image), which are laid
    over one uv square."""
    if getattr(recipe, "kind", None) == "pups":
        raise UdimError(f"--udim: {recipe.name} is a PUPs recipe; UDIM sets are for cellular "
                        f"texture recipes (their basis spans uv without limit)")
    for name, plain in _UV_SPACE.items():
        if name in recipe.values and recipe.get(name) != plain:
            raise UdimError(f"--udim: {name} = {recipe.get(name)} is laid over one uv square and "
                            f"has no continuation across UDIM tiles; accepted {name} = {plain}")
    u0, v0, cols, rows = bounds(tiles)
    f, aspect = float(recipe.get("frequency")), float(recipe.get("aspect"))
    v_top = v0 + rows - 1
    try:
        return recipe.replace(frequency=f * cols, aspect=aspect * rows / cols,
                              offset_x=float(recipe.get("offset_x")) + u0 * f,
                              offset_y=float(recipe.get("offset_y")) - v_top * f * aspect)
    except ValueError as exc:
        raise UdimError(f"--udim: the set spans {cols}x{rows} tiles, so the bake over it needs "
                        f"frequency {f * cols:g}, aspect {aspect * rows / cols:g}: {exc}") from None


def tiles_for(path, udim=None, udims=None) -> list[UdimTile]:
    """The UDIM tiles ``bake(path, udim=, udims=)`` asks for (empty for one image), checked
    with the output path's token: :class:`UdimError` for a bad range, both or neither of the
    token and a range, or the token anywhere but once in the file name."""
    import os

    text = os.fspath(path)
    if udim is None and udims is None:
        if UDIM_TOKEN in text:
            raise UdimError(f"output {text!r} holds {UDIM_TOKEN} but no --udim/--udims was "
                            f"given; accepted: both, or neither")
        return []
    if udim is not None and udims is not None:
        raise UdimError(f"--udim {udim} and --udims {udims}: accepted one of them")
    tiles = parse_udim(udim) if udim is not None else parse_udims(udims)
    if os.path.basename(text).count(UDIM_TOKEN) != 1 or UDIM_TOKEN in os.path.dirname(text):
        raise UdimError(f"output {text!r}: a UDIM set needs the token {UDIM_TOKEN} once in the "
                        f"file name, e.g. wall.{UDIM_TOKEN}.exr")
    return tiles


def tile_path(path, number: int):
    """``path`` with :data:`UDIM_TOKEN` replaced by the tile number."""
    from pathlib import Path

    return Path(str(path).replace(UDIM_TOKEN, str(number)))
