"""Bakes: recipes rendered into files, over the writers of :mod:`cellgl.io` (the front end of
``cellgl bake``, whose command line is :mod:`cellgl.cli.bake`; docs/bake.md).

:mod:`~cellgl.bake.core` bakes one image or volume file per channel tile by tile (:func:`bake`);
:mod:`~cellgl.bake.mips` renders mip chains level by level, :mod:`~cellgl.bake.texfile` renders them
into tiled ``.tx``/``.exr``/``.tif`` files, :mod:`~cellgl.bake.gputex` into ``.dds``/``.ktx2`` (the
writers: :mod:`cellgl.io.tiled`, :mod:`cellgl.io.gpu_textures`);
:mod:`~cellgl.bake.udim` bakes UDIM sets, :mod:`~cellgl.bake.frames` loopable animations,
:mod:`~cellgl.bake.material_sets` an engine's material maps. Until 0.2.0 they lived in
:mod:`cellgl.io` (CHANGELOG.md lists each old path).
"""
from __future__ import annotations

from cellgl.bake.core import Baked, bake
from cellgl.io.spec import BakeError

__all__ = ["bake", "Baked", "BakeError"]
