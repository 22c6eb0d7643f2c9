"""Cell-attribute lookup: colour each Voronoi cell by sampling an image at its feature point.

A recipe with ``color.cell_color = "image"`` names an RGB image (``color.cell_image``, relative
to the recipe file) that covers the texture's uv square, row 0 at ``v = 0`` (the top). Each
cell's colour is the image at the uv of its feature point (the smooth-F1 blended position when
``smoothness > 0``), bilinear between texel centres, clamped at the edges (wrapped when the
recipe is tileable). The shaders read it as packed RGBA8 words from a storage buffer
(:data:`BINDING`); :func:`sample` is the NumPy twin of ``cell_texture_image`` in
``shaders/lib/texture.glsl``.
"""
from __future__ import annotations

import os

import numpy as np

__all__ = ["BINDING", "MAX_SIDE", "pixels", "pack", "sample"]

BINDING = 6          #: storage buffer of the packed image (texture.comp and texture.frag)
MAX_SIDE = 4096      #: largest side of a cell image
_cache: dict = {}


def pixels(file: str, path: str = "color.cell_image") -> np.ndarray:
    """The image ``file`` as uint8 (h, w, 3) RGB, row 0 at the top, read with Pillow and cached
    by path and modification time. Raises :class:`cellgl.recipe.RecipeError` naming ``path``
    (the recipe field) if it cannot be read or is too large."""
    from .recipe import RecipeError

    try:
        st = os.stat(file)
    except OSError as exc:
        raise RecipeError(f"{path}: cannot read cell image {file!r}: {exc.strerror or exc}") from None
    key = (file, st.st_mtime_ns, st.st_size)
    img = _cache.get(key)
    if img is None:
        try:
            from PIL import Image

            with Image.open(file) as im:
                im.load()
                a = np.asarray(im.convert("RGB"), dtype=np.uint8)
        except ImportError:
            raise RecipeError(f"{path}: reading a cell image needs Pillow (pip install pillow)") from None
        except Exception as exc:  # noqa: BLE001 - Pillow raises many kinds
            raise RecipeError(f"{path}: cannot read cell image {file!r} as an image: {exc}") from None
        if not (1 <= a.shape[0] <= MAX_SIDE and 1 <= a.shape[1] <= MAX_SIDE):
            raise RecipeError(f"{path}: cell image {file!r} is {a.shape[1]}x{a.shape[0]}; accepted: sides "
                              f"1..{MAX_SIDE}")
        a.setflags(write=False)
        _cache.clear()
        img = _cache[key] = a
    return img


def pack(img: np.ndarray) -> np.ndarray:
    """uint8 (h, w, 3) -> uint32 (h * w,) words r | g << 8 | b << 16, row-major (the buffer)."""
    a = np.asarray(img, dtype=np.uint32)
    return np.ascontiguousarray((a[..., 0] | (a[..., 1] << 8) | (a[..., 2] << 16)).ravel())


def sample(img: np.ndarray, uv: np.ndarray, wrap: bool) -> np.ndarray:
    """``cell_texture_image``: bilinear RGB (N, 3) in [0, 1] of ``img`` (h, w, 3) uint8 at uv (N, 2);
    texel (i, j) is centred at ((i + 0.5) / w, (j + 0.5) / h); edges clamp, or wrap if ``wrap``."""
    h, w = img.shape[:2]
    size = np.array([w, h], dtype=np.float64)
    uv = np.asarray(uv, dtype=np.float64)
    if wrap:
        uv = uv - np.floor(uv)
    x = uv * size - 0.5
    x0 = np.floor(x)
    fr = x - x0
    x0 = x0.astype(np.int64)
    out = np.zeros((len(uv), 3))
    for dy in (0, 1):
        for dx in (0, 1):
            c = x0 + np.array([dx, dy])
            if wrap:
                c = np.mod(c, [w, h])
            else:
                c = np.clip(c, 0, [w - 1, h - 1])
            wt = np.where(dx, fr[:, 0], 1.0 - fr[:, 0]) * np.where(dy, fr[:, 1], 1.0 - fr[:, 1])
            out += wt[:, None] * img[c[:, 1], c[:, 0]].astype(np.float64)
    return out / 255.0



def bind(img: np.ndarray, ctx=None) -> None:
    """Upload (cached by content, one buffer per context) and bind the packed image to storage
    buffer :data:`BINDING` of ``ctx`` (default: cellgl's context; the viewer passes its window's)."""
    from .gpu import bind_storage

    bind_storage(pack(img), BINDING, ctx)
