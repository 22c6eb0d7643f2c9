"""Colour spaces of baked files: which one each file holds, the sRGB transfer function, and the
names pipelines read (docs/bake.md, "Film pipelines").

A texture's ``color`` comes out of :func:`cellgl.recipes.render` sRGB-encoded (the ramps are
authored as display colours). Integer display formats (PNG, 8/16-bit TIFF) store it so. Float
formats (EXR, 32-bit TIFF) store scene-linear Rec.709 by default (``colorspace="linear"``): the
exact piecewise sRGB decoding of IEC 61966-2-1 (``c / 12.92`` below 0.04045, else
``((c + 0.055) / 1.055) ** 2.4``), in float64, then rounded to the file's type once. ``"srgb"``
keeps the encoded values. Data channels (height, normal, id, F1..F4) are never converted and
never tagged as colour.

Names: the colour-space attribute holds the Color Interop Forum id (``lin_rec709_scene``,
``srgb_rec709_scene``), which OpenImageIO 3 and OCIO 2.4's built-in configs resolve to
"Linear Rec.709 (sRGB)" / "sRGB Encoded Rec.709 (sRGB)"; EXR files carry it as
``oiio:ColorSpace`` (OpenImageIO's attribute) and ``colorInteropID`` (the Forum's proposal for
OpenEXR) beside the standard ``chromaticities`` (Rec.709 primaries, D65 white).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["COLORSPACES", "ColourSpace", "REC709_CHROMATICITIES", "check_colorspace",
           "srgb_to_linear", "encode_linear", "linear_to_srgb", "default_colorspace"]


@dataclass(frozen=True)
class ColourSpace:
    name: str          #: cellgl's name (``--colorspace``)
    interop_id: str    #: Color Interop Forum id (OpenImageIO 3, OCIO 2.4 aliases)
    ocio_name: str     #: the colour space's name in OCIO's built-in configs
    linear: bool


COLORSPACES: dict[str, ColourSpace] = {
    "linear": ColourSpace("linear", "lin_rec709_scene", "Linear Rec.709 (sRGB)", True),
    "srgb": ColourSpace("srgb", "srgb_rec709_scene", "sRGB Encoded Rec.709 (sRGB)", False),
}

#: CIE xy of the Rec.709 / sRGB primaries (red, green, blue) and the D65 white point
REC709_CHROMATICITIES = ((0.64, 0.33), (0.30, 0.60), (0.15, 0.06), (0.3127, 0.3290))


def float_format(ext: str, bits: int) -> bool:
    """Whether an ``ext`` file of ``bits`` bits per sample stores floats (colour: a choice)."""
    return ext in (".exr", ".vdb", ".zarr") or (ext in (".tif", ".tiff", ".tx") and bits == 32)


def default_colorspace(ext: str, bits: int) -> str | None:
    """``"linear"`` for float formats, ``"srgb"`` for integer display formats, None for .npy
    (an array of render()'s values: sRGB-encoded, stated in docs/bake.md)."""
    if ext == ".npy":
        return None
    return "linear" if float_format(ext, bits) else "srgb"


def check_colorspace(value, ext: str, bits: int) -> str | None:
    """The colour space a bake writes: ``value`` (``--colorspace``) checked against the format.

    Raises ValueError naming the value and what is accepted: an unknown name, or a colour space
    asked of an integer format (where only sRGB-encoded means anything) or of ``.npy``.
    """
    if value is None:
        return default_colorspace(ext, bits)
    name = str(value).strip().lower()
    if name not in COLORSPACES:
        raise ValueError(f"--colorspace {value!r}: unknown colour space; accepted "
                         f"{', '.join(COLORSPACES)}")
    if not float_format(ext, bits):
        what = ".npy (render()'s values as they are)" if ext == ".npy" else \
            f"{ext} at {bits} bits (an integer display format: always sRGB-encoded)"
        raise ValueError(f"--colorspace {value}: only for float files (.exr, 32-bit .tif, .vdb, .zarr); "
                         f"{what} takes no --colorspace")
    return name


def srgb_to_linear(c: np.ndarray) -> np.ndarray:
    """IEC 61966-2-1 sRGB decoding, exact piecewise form, in float64."""
    c = np.asarray(c, dtype=np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((np.maximum(c, 0.04045) + 0.055) / 1.055) ** 2.4)


#: elements decoded at once by :func:`encode_linear` (its float64 temporaries stay small)
_BLOCK = 1 << 18


def encode_linear(c: np.ndarray, dtype) -> np.ndarray:
    """:func:`srgb_to_linear` of ``c`` rounded once to ``dtype``, a block of rows at a time (the
    float64 work of a 4096^2 level would otherwise be several GB)."""
    a = np.asarray(c)
    out = np.empty(a.shape, dtype)
    if a.ndim == 0 or a.size == 0:
        out[...] = srgb_to_linear(a)
        return out
    rows = max(1, _BLOCK // max(1, a[0].size))
    for r0 in range(0, len(a), rows):
        out[r0:r0 + rows] = srgb_to_linear(a[r0:r0 + rows])
    return out


def linear_to_srgb(c: np.ndarray) -> np.ndarray:
    """The inverse of :func:`srgb_to_linear` (float64)."""
    c = np.asarray(c, dtype=np.float64)
    return np.where(c <= 0.0031308, c * 12.92, 1.055 * np.maximum(c, 0.0031308) ** (1 / 2.4) - 0.055)
