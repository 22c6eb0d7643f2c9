"""The images a recipe refers to: the density image (``basis.density_image``, grayscale) and the
cell image (``color.cell_image``, RGB), read with Pillow and cached; and cell-attribute lookup.

Cell-attribute lookup: a recipe with ``color.cell_color = "image"`` colours each Voronoi cell by
sampling the cell image at its feature point. The image covers the texture's uv square, row 0 at
``v = 0`` (the top); each cell's colour is the image at the uv of its feature point (the smooth-F1
blended position when ``smoothness > 0``), bilinear between texel centres, clamped at the edges
(wrapped when the recipe is tileable). The shaders read it as packed RGBA8 words from a storage
buffer (:data:`BINDING`); :func:`sample` is the NumPy twin of ``cell_texture_image`` in
``shaders/lib/texture.glsl``.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from cellgl._cache import Bounded

__all__ = ["BINDING", "MAX_SIDE", "ImageError", "resolve", "density_pixels", "cell_pixels", "pack", "sample",
           "bind"]

BINDING = 6          #: storage buffer of the packed cell image (texture.comp and texture.frag)
MAX_SIDE = 4096      #: largest side of a density or cell image (cellgl.basis.density.MAX_IMAGE_SIDE)
#: decoded images by (file, modification time, size, kind) (cellgl._cache's policy)
_IMAGES = Bounded("decoded density and cell images (cellgl.texture.images)", 8)


class _TooLarge(Exception):
    """An image whose header gives a side past :data:`MAX_SIDE`."""


class ImageError(ValueError):
    """An image cannot be read or is unusable (the recipe reports it as a RecipeError)."""


#: per kind: (what the message calls it, the accepted file)
_KINDS = {"density": ("density image", "the path of a grayscale image (PNG, ...), relative to the recipe file"),
          "cell": ("cell image", "the path of an RGB image (PNG, ...), relative to the recipe file")}


def resolve(value, path: str, kind: str, base=None):
    """An image path (str or os.PathLike, relative to ``base`` or the working directory) checked
    readable as a ``kind`` (``"density"`` or ``"cell"``) image; returned absolute (None stays None).
    Raises :class:`ImageError` naming ``path`` (the recipe field)."""
    if value is None:
        return None
    if not isinstance(value, (str, os.PathLike)) or not str(value).strip():
        raise ImageError(f"{path}: expected a file path, got {value!r}; accepted: {_KINDS[kind][1]}")
    p = Path(value).expanduser()
    if not p.is_absolute():
        p = Path(base or ".") / p
    p = str(p.resolve())
    (density_pixels if kind == "density" else cell_pixels)(p, path)
    return p


def _read(file: str, path: str, kind: str, convert):
    """``convert(PIL image)`` of ``file``, cached by path, modification time and kind."""
    what = _KINDS[kind][0]
    try:
        st = os.stat(file)
    except OSError as exc:
        raise ImageError(f"{path}: cannot read {what} {file!r}: {exc.strerror or exc}") from None
    key = (file, st.st_mtime_ns, st.st_size, kind)
    img = _IMAGES.get(key)
    if img is None:
        size = None
        try:
            from PIL import Image

            with Image.open(file) as im:
                # the header gives the size: a huge image is refused before it is decoded
                size = im.size
                if not (1 <= size[0] <= MAX_SIDE and 1 <= size[1] <= MAX_SIDE):
                    raise _TooLarge
                im.load()
                a = convert(im)
        except ImportError:
            raise ImageError(f"{path}: reading a {what} needs Pillow (pip install pillow)") from None
        except _TooLarge:
            raise ImageError(f"{path}: {what} {file!r} is {size[0]}x{size[1]}; accepted: "
                             f"sides 1..{MAX_SIDE}") from None
        except Exception as exc:  # noqa: BLE001 - Pillow raises many kinds
            raise ImageError(f"{path}: cannot read {what} {file!r} as an image: {exc}") from None
        a.setflags(write=False)
        _IMAGES.put(key, a)
        img = a
    return img


def _gray(im) -> np.ndarray:
    if im.mode in ("I;16", "I;16B", "I;16L", "I"):
        a = np.asarray(im, dtype=np.float64) / (65535.0 if im.mode.startswith("I;16") else
                                                 max(1.0, float(np.asarray(im).max())))
    else:
        a = np.asarray(im.convert("L"), dtype=np.float64) / 255.0
    return np.clip(a, 0.0, 1.0)


def density_pixels(file: str, path: str = "basis.density_image") -> np.ndarray:
    """The density image ``file`` as float64 (h, w) in [0, 1] (grayscale, row 0 at the top: v = 0)."""
    return _read(file, path, "density", _gray)


def cell_pixels(file: str, path: str = "color.cell_image") -> np.ndarray:
    """The cell image ``file`` as uint8 (h, w, 3) RGB, row 0 at the top."""
    return _read(file, path, "cell", lambda im: np.asarray(im.convert("RGB"), dtype=np.uint8))


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
    from cellgl.basis.gpu import bind_storage

    bind_storage(pack(img), BINDING, ctx)
