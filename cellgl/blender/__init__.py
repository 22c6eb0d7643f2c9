"""Blender front end: the OSL export as a Script node in a ``.blend`` scene (``cellgl blender``).

The only part of cellgl that imports ``bpy`` (Blender as a Python module, the ``[blender]``
extra: ``pip install "cellgl[blender]"``), lazily: ``import cellgl`` never loads Blender.

* :func:`import_bpy` -- ``bpy`` with its OSL compiler usable outside Blender's UI (the Cycles
  add-on enabled, ``oslquery`` on ``sys.path``); :func:`compile_script_node` compiles a Script
  node's internal text the way Blender's UI does.
* :func:`write_blend` -- a scene whose render is ``cellgl bake``'s image (see
  :mod:`cellgl.blender.scene` for the mapping).
"""
from __future__ import annotations

__all__ = ["import_bpy", "compile_script_node", "osl_compile", "write_blend", "build_scene", "set_recipe",
           "render_scene", "render_outputs", "set_script"]


def __getattr__(name):
    if name in ("import_bpy", "compile_script_node", "osl_compile"):
        from cellgl.blender import runtime

        return getattr(runtime, name)
    if name in ("write_blend", "build_scene", "render_scene", "render_outputs",
                "set_recipe", "set_script"):
        from cellgl.blender import scene

        return getattr(scene, name)
    raise AttributeError(f"module 'cellgl.blender' has no attribute {name!r}")
