"""The Blender extension's add-on (Blender 4.2+): Shader Editor > Add > cellgl, the cellgl
sidebar panel, GPU bakes in a process of their own (docs/blender.md).

Imports ``bpy``: load it inside Blender (the extension's ``__init__.py`` calls :func:`register`
and :func:`unregister`) or with the ``bpy`` module (the tests). ``cellgl blender-extension``
(:mod:`cellgl.blender.extension`) packs it with its wheels.
"""
from __future__ import annotations

import bpy

__all__ = ["register", "unregister"]


def _module():
    from cellgl.blender.addon import ui

    return ui


def register():
    """Register the classes, the settings on shader node trees, the menus and the handler."""
    from cellgl.blender.runtime import enable_osl_compiler

    ui = _module()
    enable_osl_compiler()
    for cls in ui.CLASSES:
        bpy.utils.register_class(cls)
    ui.register_settings()
    bpy.types.NODE_MT_add.append(ui.menu_draw)
    bpy.types.NODE_MT_context_menu.append(ui.context_menu_draw)
    if ui.on_depsgraph not in bpy.app.handlers.depsgraph_update_post:
        bpy.app.handlers.depsgraph_update_post.append(ui.on_depsgraph)


def unregister():
    """Undo :func:`register`: no class, menu entry, handler, timer or child process left."""
    from cellgl.blender.addon import jobs

    ui = _module()
    jobs.cancel_all()
    while ui.on_depsgraph in bpy.app.handlers.depsgraph_update_post:
        bpy.app.handlers.depsgraph_update_post.remove(ui.on_depsgraph)
    bpy.types.NODE_MT_context_menu.remove(ui.context_menu_draw)
    bpy.types.NODE_MT_add.remove(ui.menu_draw)
    ui.unregister_settings()
    for cls in reversed(ui.CLASSES):
        bpy.utils.unregister_class(cls)
