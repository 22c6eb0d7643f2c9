"""Snippets for other engines: :mod:`~cellgl.export.snippets` assembles a recipe's shader library
with its values for each target (GLSL, GLES, Shadertoy, Godot, HLSL, Unreal, WGSL);
:mod:`~cellgl.export.translate` rewrites the GLSL for the other languages."""
from __future__ import annotations

from cellgl.export import translate  # noqa: F401  (first: the passes import syntax, which translate's back ends import)
from cellgl.export.snippets import TARGETS, ExportError, export

__all__ = ["TARGETS", "ExportError", "export"]
