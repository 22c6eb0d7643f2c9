"""Any recipe, whatever its kind: load, list, render, evaluate (the public entry points).

Two kinds of recipe exist: cellular textures (:class:`cellgl.texture.recipe.Recipe`, rendered
by :mod:`cellgl.texture.evaluation`) and PUPs syntheses (:class:`cellgl.pups.recipe.PupsRecipe`,
rendered by :func:`cellgl.pups.recipe.render`). This module sits above both and picks one;
``cellgl.load_recipe``, ``cellgl.list_presets``, ``cellgl.render`` and ``cellgl.evaluate`` are
its functions, and the front ends (bake, export, viewer, CLI) use it.
"""
from __future__ import annotations

import json
from pathlib import Path

from cellgl.pups import recipe as pups_recipe
from cellgl.pups.recipe import PupsRecipe
from cellgl.texture import presets as cellular
from cellgl.texture import evaluation as cellular_render
from cellgl.texture.params import PARAMS
from cellgl.texture.recipe import Recipe
from cellgl.texture.schema import RecipeError, read_json

__all__ = ["load_recipe", "list_presets", "render", "evaluate", "is_pups", "is_path", "parameters",
           "max_side", "MAX_SIDE", "KINDS", "check_memory", "memory_bytes"]

#: the recipe kinds: cellular textures and PUPs syntheses
KINDS = ("cellular", "pups")

is_pups = pups_recipe.is_pups
#: whether a recipe argument names a file rather than a preset (any kind)
is_path = cellular.is_path
#: the largest image side :func:`render` takes, any kind (a cellular recipe's: 2^20; PUPs: 2^16)
MAX_SIDE = max(cellular_render.MAX_SIDE, pups_recipe.MAX_SIDE)


def list_presets(kind: str | None = None) -> list[tuple[str, str]]:
    """``[(name, one-line doc), ...]`` of every preset, sorted by name: the cellular recipes
    (``cellgl/presets/*.json``) and the PUPs presets (``pups-*``, :mod:`cellgl.pups.recipe`);
    ``kind="cellular"`` or ``"pups"``: those of one kind only."""
    if kind is not None and kind not in KINDS:
        raise ValueError(f"kind {kind!r}: unknown recipe kind; accepted: None (every kind), "
                         + ", ".join(KINDS))
    out = [] if kind == "pups" else cellular.list_presets()
    return sorted(out + ([] if kind == "cellular" else pups_recipe.pups_preset_names()))


def parameters(recipe) -> tuple:
    """The parameter table entries a recipe has (what a panel shows): every entry of
    :data:`cellgl.texture.params.PARAMS` for a cellular recipe, the entries of
    :data:`cellgl.pups.recipe.PUPS_PARAMS` its pattern uses for a PUPs one."""
    recipe = load_recipe(recipe)
    if is_pups(recipe):
        used = set(recipe.names())
        return tuple(p for p in pups_recipe.PUPS_PARAMS if p.name in used)
    return PARAMS


def max_side(recipe) -> int:
    """The largest image side :func:`render` takes for this recipe (its kind's limit)."""
    return pups_recipe.MAX_SIDE if is_pups(load_recipe(recipe)) else cellular_render.MAX_SIDE


def load_recipe(preset_or_path):
    """A preset by name (``"veins"``, ``"worley-gallery:3"`` for a variant, ``"pups-cow"``) or a
    recipe JSON file.

    Returns a :class:`~cellgl.texture.recipe.Recipe`, or a
    :class:`~cellgl.pups.recipe.PupsRecipe` for a PUPs preset or a JSON file with
    ``"kind": "pups"``. Raises :class:`~cellgl.texture.recipe.RecipeError` naming the known
    presets if neither matches.
    """
    if isinstance(preset_or_path, (Recipe, PupsRecipe)):
        return preset_or_path
    text = str(preset_or_path)
    if cellular.is_path(text):
        path = Path(text)
        kind = _json_kind(path)
        if kind is not _NO_KIND and kind != "pups":
            shown = json.dumps(kind)
            shown = shown if len(shown) <= 60 else f"{shown[:40]}... ({len(shown)} characters)"
            raise RecipeError(f"{path}: kind: unknown recipe kind {shown}; accepted: \"pups\" (a PUPs "
                              "synthesis), or no \"kind\" key for a cellular texture recipe")
        return PupsRecipe.load(path) if kind == "pups" else Recipe.load(path)
    pups = pups_recipe.load_pups_preset(text)
    if pups is not None:
        return pups
    return cellular.load_recipe(text, known=lambda: [n for n, _ in list_presets()])


#: what :func:`_json_kind` returns for a file without a ``kind`` key
_NO_KIND = object()


def _json_kind(path: Path):
    """The ``kind`` key of a recipe file (:data:`_NO_KIND`: none, a cellular recipe, or unreadable:
    let :meth:`Recipe.load` report it)."""
    try:
        d = read_json(path)
    except RecipeError:
        return _NO_KIND
    return d.get("kind", _NO_KIND) if isinstance(d, dict) else _NO_KIND


def render(recipe, width: int, height: int, *, channels=("color",), x0: int = 0, y0: int = 0,
           tile_w: int | None = None, tile_h: int | None = None, depth: int | None = None,
           backend: str = "gpu", samples: int = 1) -> dict:
    """Render the sub-rectangle ``[x0, x0 + tile_w) x [y0, y0 + tile_h)`` of the full
    ``width x height`` image of any recipe (tiles are bit-identical to a one-pass render):
    :func:`cellgl.texture.evaluation.render` for a cellular recipe, :func:`cellgl.pups.recipe.render`
    for a PUPs one.

    Returns
    -------
    dict channel -> ndarray: ``color`` (H, W, 4) float32 in [0, 1]; ``height`` (H, W)
    float32; ``normal`` (H, W, 3) float32 in [0, 1] (green per ``normal_convention``);
    ``id`` (H, W) uint32; ``F1``..``F4`` (H, W) float32; ``roughness``, ``ao``, ``metallic``
    (H, W) float32; ``cloud`` (H, W, 4) float32 (packed cloud noise, :mod:`cellgl.texture.cloud`).
    Row 0 is the top of the image. With
    ``depth=D`` (3D/4D recipes) every array gains a leading axis of D slices along z. PUPs
    recipes give ``color`` and ``height``.

    A tile that would need more than half the machine's memory (:func:`check_memory`) raises
    ValueError up front, saying how to tile it (tiles, ``cellgl.bake.core.bake``, ``cellgl.to_dask``).
    """
    recipe = load_recipe(recipe)
    check_memory(recipe, width, height, channels, x0=x0, y0=y0, tile_w=tile_w, tile_h=tile_h, depth=depth,
                 backend=backend)
    kw = dict(channels=channels, x0=x0, y0=y0, tile_w=tile_w, tile_h=tile_h, depth=depth, backend=backend)
    if is_pups(recipe):
        if samples != 1:
            raise ValueError(f"samples={samples!r}: supersampling is for cellular texture recipes; "
                             f"{recipe.name} is a PUPs recipe (accepted: 1)")
        return pups_recipe.render(recipe, width, height, **kw)
    return cellular_render.render(recipe, width, height, samples=samples, **kw)


#: bytes of each channel's result, per pixel (float32; id uint32)
_RESULT_BYTES = {"color": 16, "height": 4, "normal": 12, "id": 4, "F1": 4, "F2": 4, "F3": 4, "F4": 4, "cloud": 16}
#: working bytes per pixel beyond the result (tracemalloc peaks at 128^2, llvmpipe, 2026-11-28):
#: the NumPy path holds float64 intermediates for every pixel (f1 860, flagstone 2520), PUPs
#: about 1000; the GPU path's: :func:`gpu_peak`
_WORK_BYTES = {"numpy": 2600, "pups": 1000}


def gpu_peak(channels, pixels: int) -> int:
    """Bytes the GPU path of a cellular render of ``pixels`` holds at its peak, the result
    included. :func:`cellgl.texture.dispatch.run` reads each output block back whole, one row a
    pixel (colour RGBA 16 bytes; height and normal share one 16-byte block, cut out into copies of
    4 and 12; id 4; F1..Fk k floats, each F a copy of its column when k > 1), and the GL storage
    buffers hold a chunk of each block and the canary's 4 bytes a sample, at most
    ``CHUNK_BYTES`` a buffer. Measured (ru_maxrss, llvmpipe, flagstone, 2026-12-07): height 40
    bytes a pixel at 2048^2, 25 at 4096^2 (this gives 40 and 28); normal 37 at 3072^2 (42)."""
    from cellgl.gl.dispatch import CHUNK_BYTES

    host, gl, buffers = gpu_bytes(channels)
    return pixels * host + min(pixels * gl, buffers * CHUNK_BYTES)


def gpu_bytes(channels) -> tuple[int, int, int]:
    """:func:`gpu_peak`'s parts: bytes a pixel on the host (blocks read back and channels cut
    out of them), bytes a pixel in GL storage buffers, and how many buffers."""
    c = set(channels)
    blocks, copies, buffers = [], 0, 1                  # (the canary's flag buffer)
    if "color" in c:
        blocks.append(16)
    if c & {"height", "normal"}:
        blocks.append(16)
        copies += 4 * ("height" in c) + 12 * ("normal" in c)
    if "id" in c:
        blocks.append(4)
    fs = [int(x[1]) for x in c if x in ("F1", "F2", "F3", "F4")]
    if fs:
        blocks.append(4 * max(fs))
        copies += 4 * len(fs) if max(fs) > 1 else 0
    if "cloud" in c:        # four height renders, one at a time (one block), kept; packed in float64
        blocks.append(16)
        copies += 4 * 4 + 5 * 8 * 4 + 16
    return sum(blocks) + copies, sum(blocks) + 4, len(blocks) + buffers
#: share of the machine's memory one render() may ask for
MEMORY_SHARE = 0.5


def memory_bytes() -> int:
    """Physical memory of this machine in bytes (0 when it cannot be read: then nothing is refused)."""
    import os

    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return 0


def check_memory(recipe, width, height, channels=("color",), *, x0=0, y0=0, tile_w=None, tile_h=None,
                 depth=None, backend="gpu") -> None:
    """ValueError if :func:`render` of this tile would need more than :data:`MEMORY_SHARE` of the
    machine's memory (an estimate: the result plus the path's working memory), naming the size and
    how to tile it instead (as ``cellgl bake`` tiles to ``--memory``). Arguments of the wrong type
    are left to :func:`render`'s own checks."""
    import numbers

    ints = (width, height, x0, y0) + tuple(v for v in (tile_w, tile_h, depth) if v is not None)
    if not all(isinstance(v, numbers.Integral) and not isinstance(v, bool) for v in ints):
        return
    chans = (channels,) if isinstance(channels, str) else channels
    try:
        per_px = sum(_RESULT_BYTES[c] for c in chans)
    except (KeyError, TypeError):
        return
    tw = width - x0 if tile_w is None else tile_w
    th = height - y0 if tile_h is None else tile_h
    pixels = max(0, tw) * max(0, th) * (depth or 1)
    if not is_pups(recipe) and backend != "numpy":
        need = gpu_peak(chans, pixels)
    else:
        need = pixels * (per_px + _WORK_BYTES["pups" if is_pups(recipe) else "numpy"])
    mem = memory_bytes()
    if not mem or need <= mem * MEMORY_SHARE:
        return
    gib = 1 << 30
    tile = f"{tw}x{th}" + (f"x{depth}" if depth else "")
    whole = "" if (tw, th) == (width, height) else f" (a tile of the {width}x{height} image)"
    ways = ["render it in tiles (x0, y0, tile_w, tile_h: each tile equals those pixels of the whole render)"]
    if width <= 65536 and height <= 65536 and width * height <= 1 << 32 and not depth:   # cellgl.io.spec's limits
        ways.append(f"bake it to a file tile by tile within a memory budget (cellgl.bake.core.bake(recipe, "
                    f"'big.tif', size=({width}, {height})), or `cellgl bake NAME -o big.tif --size "
                    f"{width}x{height}`)")
    ways.append(f"take it as a lazy array rendered block by block: cellgl.to_dask(recipe, ({height}, {width}))")
    raise ValueError(
        f"render {tile}{whole} of {recipe.name!r} ({', '.join(chans)}, backend {backend}) needs about "
        f"{need / gib:.3g} GiB (about {need / max(1, pixels):.0f} bytes a pixel), more than {MEMORY_SHARE:.0%} of this "
        f"machine's {mem / gib:.3g} GiB; " + "; or ".join(ways))


def evaluate(recipe, points, outputs=("color",), backend: str = "gpu", *, filter_width=0.0) -> dict:
    """Evaluate a cellular recipe at arbitrary texture-space points: see
    :func:`cellgl.texture.evaluation.evaluate` for the arguments and outputs (PUPs recipes render
    images only: :func:`render`)."""
    recipe = load_recipe(recipe)
    if is_pups(recipe):
        raise ValueError(f"evaluate() at arbitrary points is not available for PUPs recipes "
                         f"({recipe.name}); use render() (channels: color, height)")
    return cellular_render.evaluate(recipe, points, outputs, backend, filter_width=filter_width)


def parameter_tables() -> dict[str, tuple]:
    """The parameter table of each recipe kind: ``{"cellular": PARAMS, "pups": PUPS_PARAMS}``
    (``cellgl presets --params``; one recipe's own rows: :func:`parameters`)."""
    return {"cellular": PARAMS, "pups": pups_recipe.PUPS_PARAMS}
