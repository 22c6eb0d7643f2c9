"""Tiled, mip-mapped texture files for film renderers, from levels in memory: ``.tx`` and
``--tiled [--mips]`` ``.exr`` / ``.tif`` (docs/bake.md, "Film pipelines"; the bake renders the
levels, :mod:`cellgl.bake.texfile`). Nothing here knows of recipes or GL; this module lays the
levels it is given into the containers renderers read through OpenImageIO's texture system:

* ``.tx`` and ``.tif``: a tiled TIFF (64 x 64 tiles, zlib), level 0 the first page, level ``k``
  the next pages marked reduced-resolution (``NewSubfileType`` 1), Pixar's ``textureformat``
  "Plain Texture" and ``wrapmodes`` tags, as ``maketx`` writes them (written by ``tifffile``;
  OpenImageIO reads the pages as MIP levels): :func:`write_tiff_levels`.
* ``.exr``: a tiled OpenEXR file, ``MIPMAP_LEVELS`` with ``ROUND_UP`` (the chain of
  :func:`cellgl.bake.mips.mip_sizes`), written by OpenImageIO's ``ImageOutput``
  (``AppendMIPLevel``; the wheel or Blender's copy, :func:`openimageio`), every channel asked for
  in one file, colour tagged as in :mod:`cellgl.io.colour`: :func:`write_exr_levels`.

A level is held whole in memory while it is written (a 4096^2 RGB float .tx peaks at about 0.7
GiB with the render's own working memory), unlike the streamed single-level writers.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from cellgl.io.spec import BakeError, exr_names

__all__ = ["TILE", "TEXTURE_EXTS", "check_tiled", "openimageio", "write_tiff_levels", "write_exr_levels"]

TILE = 64                                #: tile side of every tiled texture file
TEXTURE_EXTS = (".exr", ".tif", ".tiff", ".tx")
#: an EXR attribute OpenImageIO 3.0 does not suppress, renamed in place to ``oiio:ColorSpace``
#: after writing (same length: nothing in the file moves)
_CS_STANDIN = b"cellgl:ColorSpc"
_CS_NAME = b"oiio:ColorSpace"
assert len(_CS_STANDIN) == len(_CS_NAME)


def openimageio():
    """The ``OpenImageIO`` module: an installed one (``pip install openimageio``), else the copy
    inside Blender's ``bpy`` wheel (the ``[blender]`` extra; its folder is appended to
    ``sys.path``, where Blender itself puts it), else None.

    One environment must not hold both the ``openimageio`` wheel and ``bpy``: the wheel's module
    shadows Blender's, and Blender's OSL script nodes then fail (``oslquery`` returns Blender's
    ``TypeDesc``, which the other module cannot convert; checked with bpy 4.5 and openimageio
    3.0.21). With ``bpy`` installed, cellgl uses Blender's copy.
    """
    import importlib.util
    import sys

    try:
        import OpenImageIO
        return OpenImageIO
    except ImportError:
        pass
    spec = importlib.util.find_spec("bpy")
    if spec is None or not spec.origin:
        return None
    base = Path(spec.origin).parent
    for folder in sorted(base.glob("*/python/lib/python3*/site-packages")):
        if (folder / "OpenImageIO").is_dir():
            if str(folder) not in sys.path:
                sys.path.append(str(folder))
            try:
                import OpenImageIO
                return OpenImageIO
            except ImportError:
                return None
    return None


def check_tiled(ext: str, tiled: bool, mips: bool, channels, depth_slices) -> tuple[bool, bool]:
    """``(tiled, mips)`` for an ``ext`` bake: a ``.tx`` is both; ``tiled`` only for .exr/.tif/.tx
    2D images; a tiled EXR holds no ``id`` (uint32 beside float colour). BakeError otherwise."""
    if ext == ".tx":
        tiled = mips = True
    if not tiled:
        return False, mips
    if ext not in TEXTURE_EXTS:
        raise BakeError(f"--tiled with {ext}: accepted for {', '.join(TEXTURE_EXTS)} "
                        f"(PNG and NPY have no tiles)")
    if depth_slices is not None:
        raise BakeError(f"--tiled / .tx with a volume (depth {depth_slices}): tiled textures "
                        f"are 2D; accepted --size WxH")
    if ext == ".exr" and "id" in channels:
        raise BakeError("--tiled .exr with --channels id: a tiled EXR here holds float "
                        "channels only; write ids to a .tif/.tx (uint32) or a scanline .exr")
    if ext == ".exr" and openimageio() is None:
        raise BakeError("a tiled .exr needs OpenImageIO: pip install openimageio (or Blender's "
                        "copy, pip install 'cellgl[blender]'; not both in one environment)")
    return True, mips


def _encoded(encodings, res):
    return {e.channel: e.encode(res[e.channel]) for e in encodings}


def write_tiff_levels(tmp, levels, encodings, meta: str, wrap: str, bar, mips: bool) -> None:
    """A tiled TIFF ``tmp`` of ``levels`` (``(k, {channel: array})`` in level order, each level's
    arrays as render() gives them, encoded by the one :class:`~cellgl.io.spec.Encoding` in
    ``encodings``): level 0 the first page, level ``k`` a reduced-resolution page; ``meta`` the
    description, ``wrap`` Pixar's wrapmodes, ``mips`` the "Plain Texture" tag; ``bar.step()`` a
    level."""
    import tifffile

    (e,) = encodings
    rgb = e.samples in (3, 4)
    tags = [(33302, "s", 0, "Plain Texture", True)] if mips else []      # Pixar textureformat
    tags.append((33303, "s", 0, wrap, True))                                # Pixar wrapmodes
    with tifffile.TiffWriter(os.fspath(tmp)) as tw:
        for k, res in levels:
            a = _encoded(encodings, res)[e.channel]
            tw.write(a, tile=(TILE, TILE), photometric="rgb" if rgb else "minisblack",
                     compression="zlib", subfiletype=1 if k else 0, metadata=None, extratags=tags,
                     description=meta if k == 0 else None)
            bar.step()


def write_exr_levels(tmp, levels, encodings, meta: str, wrap: str, bar, mips: bool) -> None:
    """A tiled OpenEXR ``tmp`` of ``levels`` (as :func:`write_tiff_levels`), every encoding's
    channels in one file, MIP levels rounded up, colour tagged (:mod:`cellgl.io.colour`); written
    by OpenImageIO (:func:`openimageio`)."""
    from cellgl.io.colour import COLORSPACES, REC709_CHROMATICITIES

    oiio = openimageio()

    names = [n for e in encodings for n in exr_names(e.channel)]
    half = all(e.dtype == np.float16 for e in encodings)
    space = next((e.colorspace for e in encodings if e.colorspace), None)
    o = oiio.ImageOutput.create(os.fspath(tmp))
    if o is None:
        raise OSError(f"OpenImageIO cannot write {tmp}: {oiio.geterror()}")
    try:
        for k, res in levels:
            enc = _encoded(encodings, res)
            planes = [enc[e.channel].reshape(enc[e.channel].shape[:2] + (-1,)) for e in encodings]
            data = np.ascontiguousarray(np.concatenate(planes, axis=-1))
            spec = oiio.ImageSpec(data.shape[1], data.shape[0], data.shape[2], "half" if half else "float")
            spec.channelnames = tuple(names)
            spec.tile_width = spec.tile_height = TILE
            spec.attribute("compression", "zip")
            if mips:        # OpenImageIO writes MIPMAP_LEVELS for a "Plain Texture", else ONE_LEVEL
                spec.attribute("textureformat", "Plain Texture")
            spec.attribute("wrapmodes", wrap)
            spec.attribute("openexr:roundingmode", 1)        # ROUND_UP: mips.mip_sizes's chain
            spec.attribute("cellgl", meta)
            if space is not None:
                spec.attribute("colorInteropID", COLORSPACES[space].interop_id)
                spec.attribute(_CS_STANDIN.decode(), COLORSPACES[space].interop_id)
                spec.attribute("chromaticities", oiio.TypeDesc("float[8]"),
                               tuple(float(c) for xy in REC709_CHROMATICITIES for c in xy))
            if not o.open(os.fspath(tmp), spec, "create" if k == 0 else "appendmiplevel") \
                    or not o.write_image(data.astype(np.float16 if half else np.float32, copy=False)):
                raise OSError(f"OpenImageIO: writing level {k} of {tmp}: {o.geterror()}")
            bar.step()
        if not o.close():
            raise OSError(f"OpenImageIO: closing {tmp}: {o.geterror()}")
    finally:
        del o       # OpenImageIO finishes a MIP-mapped EXR only when the output is destroyed
    if space is not None:
        _rename_attribute(tmp, _CS_STANDIN, _CS_NAME)


def _rename_attribute(path, old: bytes, new: bytes) -> None:
    """Rename header attribute ``old`` to ``new`` (same length) in place: an OpenEXR header is
    a run of ``name\\0 type\\0 size value`` (openexr.com, "OpenEXR File Layout")."""
    with open(path, "r+b") as f:
        head = f.read(1 << 20)
        at = head.find(old + b"\0string\0")
        if at < 0:
            raise ValueError(f"EXR {path}: attribute {old!r} not found")
        f.seek(at)
        f.write(new)
