"""Drive the Blender extension's add-on headless with the ``bpy`` module (run by
tests/test_blender_addon.py in a subprocess: Blender's state stays out of the test process).

``python tests/blender_addon_run.py OUTDIR SIZE PRESET [PRESET ...] [--eevee] [--all-ops]``

Registers the add-on (the package on ``sys.path`` as the extension's wheels put it there), adds
each preset through its operator into the scene of :func:`cellgl.blender.scene.build_scene`, bakes
it, and renders the group's outputs through the OSL branch (Cycles, OSL on) and the image branch
(Cycles' SVM; EEVEE with ``--eevee``): ``NAME.osl.png`` / ``NAME.img.png`` (Color),
``NAME.osl.id.exr`` / ``NAME.img.id.exr`` (ID Low, ID High, Fac), ``NAME.osl.cell.exr`` /
``NAME.img.cell.exr`` (Cell Color). ``--all-ops`` runs every other operator and the unregister
checks; the facts go to ``OUTDIR/report.json``.
"""
from __future__ import annotations

import json
import os
import sys


def main(argv):
    out, size, rest = argv[0], int(argv[1]), argv[2:]
    eevee, all_ops = "--eevee" in rest, "--all-ops" in rest
    install = rest[rest.index("--install") + 1] if "--install" in rest else None
    presets = [a for a in rest if not a.startswith("--") and a != install]
    report = {"presets": {}}
    from cellgl.blender.runtime import import_bpy
    from cellgl.blender.scene import build_scene, render_scene

    bpy = import_bpy()
    scene = build_scene(presets[0], size)       # (factory settings: before the install)
    if install:
        # forget this tree's cellgl: the add-on and everything after import the extension's wheel
        for m in [m for m in sys.modules if m == "cellgl" or m.startswith("cellgl.")]:
            del sys.modules[m]
        addon = _install(bpy, install, report)
        report["installed"]["registered"] = hasattr(bpy.types, "CELLGL_OT_bake_image")
    else:
        import cellgl.blender.addon as module

        module.register()
        addon = module
    obj = bpy.data.objects["cellgl_plane"]
    bpy.context.view_layer.objects.active = obj
    tree = bpy.data.materials["cellgl"].node_tree
    emit = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeEmission")
    for name in presets:
        res = bpy.ops.cellgl.add_preset(preset=name, bake=False)
        node = tree.nodes.active
        node.node_tree.cellgl.size = size
        with bpy.context.temp_override(active_node=node):
            res2 = bpy.ops.cellgl.bake_image(wait=True)
        info = {"add": sorted(res), "bake": sorted(res2), "inputs": [s.name for s in node.inputs],
                "outputs": [s.name for s in node.outputs], "status": node.node_tree.cellgl.status}
        item = next((i for i in node.node_tree.interface.items_tree if i.name == "Frequency"), None)
        if item is not None:
            info["frequency_socket"] = {"min": item.min_value, "max": item.max_value,
                                        "default": item.default_value, "description": item.description}
        pack = tree.nodes.new("ShaderNodeCombineXYZ")
        for i, o in enumerate(("ID Low", "ID High", "Fac")):
            tree.links.new(node.outputs[o], pack.inputs[i])
        branches = [("osl", "CYCLES", True), ("img", "CYCLES", False)]
        if eevee:
            branches.append(("eevee", "BLENDER_EEVEE_NEXT", False))
        for tag, engine, osl in branches:
            scene.render.engine = engine
            scene.cycles.shading_system = osl
            if engine != "CYCLES":
                scene.eevee.taa_render_samples = 1
                scene.render.filter_size = 0.0      # one sample at the pixel centre, as Cycles
            tree.links.new(node.outputs["Color"], emit.inputs["Color"])
            render_scene(scene, os.path.join(out, f"{name}.{tag}.png"))
            render_scene(scene, os.path.join(out, f"{name}.{tag}.color.exr"))
            tree.links.new(pack.outputs[0], emit.inputs["Color"])
            render_scene(scene, os.path.join(out, f"{name}.{tag}.id.exr"))
            tree.links.new(node.outputs["Cell Color"], emit.inputs["Color"])
            render_scene(scene, os.path.join(out, f"{name}.{tag}.cell.exr"))
        scene.render.engine = "CYCLES"
        tree.nodes.remove(pack)
        report["presets"][name] = info
    if all_ops:
        report.update(_all_ops(bpy, addon, tree, out, size))
    with open(os.path.join(out, "report.json"), "w") as f:
        json.dump(report, f, indent=1)


class _Extension:
    """register/unregister of the installed extension, through Blender's add-on machinery."""

    def __init__(self, module):
        self.module = module

    def register(self):
        import addon_utils

        addon_utils.enable(self.module, default_set=True)

    def unregister(self):
        import addon_utils

        addon_utils.disable(self.module, default_set=True)


class _Layout:
    """A stand-in for Blender's UILayout (the bpy module draws no UI): records what a panel or
    menu draws, and whether it was greyed (``active = False``)."""

    def __init__(self, log):
        self.log, self.active, self.alert = log, True, False

    def _sub(self, *a, **k):
        sub = _Layout(self.log)
        sub.active = self.active
        return sub

    column = row = box = split = _sub

    def separator(self, *a, **k):
        pass

    def label(self, text="", **k):
        self.log.append(["label", text, self.active])

    def prop(self, data, attr, text=None, **k):
        self.log.append(["prop", text if text is not None else attr, self.active])

    def operator(self, idname, text=None, **k):
        self.log.append(["operator", idname, text])
        import types

        return types.SimpleNamespace()

    def menu(self, idname, **k):
        self.log.append(["menu", idname])


def _draw(cls, **context):
    import types

    log = []
    cls.draw(types.SimpleNamespace(layout=_Layout(log)), types.SimpleNamespace(**context))
    return log


def _install(bpy, zip_file, report):
    """Install the extension zip as Edit > Preferences > Get Extensions > Install from Disk does."""
    import addon_utils

    addon_utils.enable("bl_pkg", default_set=True)
    res = bpy.ops.extensions.package_install_files(filepath=zip_file, repo="user_default",
                                                   enable_on_install=True)
    import cellgl

    module = "bl_ext.user_default.cellgl"
    report["installed"] = {"result": sorted(res), "module": module if module in sys.modules else "",
                           "cellgl_file": cellgl.__file__}
    return _Extension(module)


def _all_ops(bpy, addon, tree, out, size):
    """Every other operator, the error path, the undo flags and unregistering."""
    import types

    import numpy as np

    from cellgl.blender.addon import groups, ui

    r = {}
    node = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeGroup")
    s = node.node_tree.cellgl
    r["inactive"] = groups.inactive_inputs(node)
    r["group_inputs"] = [sock.name for sock in node.inputs]
    space = types.SimpleNamespace(tree_type="ShaderNodeTree", edit_tree=tree)
    r["panel"] = _draw(ui.CELLGL_PT_texture, active_node=node, space_data=space)
    r["add_menu"] = _draw(ui.CELLGL_MT_add, space_data=space)
    r["family_menu"] = _draw(ui.FAMILY_MENUS[0], space_data=space)
    hook = []
    ui.menu_draw(types.SimpleNamespace(layout=_Layout(hook)), types.SimpleNamespace(space_data=space))
    r["add_hook"] = hook
    r["snippet_texts"] = {}
    for target in ("glsl", "osl", "hlsl"):
        s.target = target
        with bpy.context.temp_override(active_node=node):
            r[f"snippet_{target}"] = sorted(bpy.ops.cellgl.copy_snippet())
        r["snippet_texts"][target] = groups.snippet_text(node, target)
    sock = next(x for x in node.inputs if x.name == "Frequency")
    sock.default_value = 7.0
    s.seed = 3
    s.tileable = True
    with bpy.context.temp_override(active_node=node):
        r["bake_command"] = sorted(bpy.ops.cellgl.copy_bake_command())
    r["bake_command_text"] = groups.bake_command_text(node)
    # re-bake on change: the handler bakes when a value changes (headless: it waits)
    s.rebake = True
    before = s.baked_hash
    sock.default_value = 6.0
    ui.on_depsgraph(bpy.context.scene)
    r["rebaked"] = s.baked_hash != before and s.baked_hash == ui._values_hash(node)
    s.rebake = False
    # the UI's path: the bake in the background, the timer polled by hand (headless Blender runs
    # no timers), its progress seen, the result loaded; a failing one shows its message
    import time

    from cellgl.blender.addon import jobs

    seen = []
    s.size = 96
    jobs.start(node.node_tree.name, ui._job_for(node), ui._values_hash(node))
    r["async_timer"] = bpy.app.timers.is_registered(jobs.poll)
    t0 = time.time()
    while jobs.JOBS and time.time() - t0 < 300:
        seen.append(round(next(iter(jobs.JOBS.values())).progress, 3))
        time.sleep(0.05)
        jobs.poll()
    r["async_progress"] = sorted(set(seen))
    r["async_status"] = s.status
    r["async_size"] = list(bpy.data.images[f"{node.node_tree.name} Color"].size)
    r["async_hash_ok"] = s.baked_hash == ui._values_hash(node)
    s.size = size
    # errors are reports, not tracebacks
    preset = s.preset
    s.preset = "no-such-preset"
    try:
        with bpy.context.temp_override(active_node=node):
            bpy.ops.cellgl.bake_image(wait=True)
        r["error"] = ""
    except RuntimeError as exc:
        r["error"] = str(exc)
    s.preset = preset
    r["bad_preset"] = ""
    try:
        bpy.ops.cellgl.add_preset(preset="pups-cow")
    except RuntimeError as exc:
        r["bad_preset"] = str(exc)
    # the Voronoi drop-in
    vor = tree.nodes.new("ShaderNodeTexVoronoi")
    vor.voronoi_dimensions = "2D"
    vor.inputs["Scale"].default_value = 4.0
    emit = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeEmission")
    tree.links.new(vor.outputs["Distance"], emit.inputs["Strength"])
    tree.nodes.active = vor
    r["voronoi"] = sorted(bpy.ops.cellgl.voronoi_exact(size=32))
    vnode = tree.nodes.active
    r["voronoi_outputs"] = [x.name for x in vnode.outputs]
    r["voronoi_linked"] = emit.inputs["Strength"].links[0].from_node == vnode
    img = bpy.data.images[f"{vnode.node_tree.name} distance"]
    px = np.empty(32 * 32 * 4, np.float32)
    img.pixels.foreach_get(px)
    np.save(os.path.join(out, "voronoi_distance.npy"), px.reshape(32, 32, 4)[::-1, :, 0])
    r["voronoi_inputs"] = [x.name for x in vnode.inputs]
    vnode.inputs["Scale"].default_value = 6.0          # the group's sockets act at the next bake
    with bpy.context.temp_override(active_node=vnode):
        r["voronoi_rebake"] = sorted(bpy.ops.cellgl.bake_image(wait=True))
    img = bpy.data.images[f"{vnode.node_tree.name} distance"]
    img.pixels.foreach_get(px)
    np.save(os.path.join(out, "voronoi_distance6.npy"), px.reshape(32, 32, 4)[::-1, :, 0])
    emit.inputs["Strength"].default_value = 1.0
    for link in list(emit.inputs["Strength"].links):
        tree.links.remove(link)
    r["undo_flags"] = {c.bl_idname: sorted(getattr(c, "bl_options", ())) for c in ui.CLASSES
                       if c.__name__.startswith("CELLGL_OT")}
    r["menus"] = {m.bl_label: [] for m in ui.FAMILY_MENUS}
    for fam in ui.FAMILY_MENUS:
        r["menus"][fam.bl_label] = [n for n, _ in groups.exportable_presets() if groups.family(n) == fam.bl_label]
    # the packed images survive a save and reload
    bpy.context.preferences.filepaths.save_version = 0
    blend = os.path.join(out, "saved.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend, copy=True)
    r["packed"] = sorted(i.name for i in bpy.data.images if i.packed_file is not None)
    before = _footprint(bpy)
    addon.unregister()
    r["footprint_registered"] = before
    r["footprint_unregistered"] = _footprint(bpy)
    addon.register()                  # and again: registering twice in a session works
    r["reregistered"] = hasattr(bpy.types, "CELLGL_OT_bake_image")
    addon.unregister()
    r["footprint_final"] = _footprint(bpy)
    return r


def _footprint(bpy):
    """What the add-on leaves in Blender: classes, settings, menu entries, handlers, timers."""
    from cellgl.blender.addon import jobs

    draw_funcs = []
    for menu in (bpy.types.NODE_MT_add, bpy.types.NODE_MT_context_menu):
        for f in getattr(menu.draw, "_draw_funcs", []):
            draw_funcs.append(f"{getattr(f, '__module__', '')}.{getattr(f, '__name__', '')}")
    return {"classes": sorted(n for n in dir(bpy.types) if n.startswith("CELLGL_")),
            "settings": hasattr(bpy.types.ShaderNodeTree, "cellgl"),
            "menu_entries": sorted(f for f in draw_funcs if "cellgl" in f),
            "handlers": sorted(f"{h.__module__}.{h.__name__}" for lst in
                               (bpy.app.handlers.depsgraph_update_post, bpy.app.handlers.load_post)
                               for h in lst if "cellgl" in getattr(h, "__module__", "")),
            "timer": bpy.app.timers.is_registered(jobs.poll),
            "ops": hasattr(bpy.ops.cellgl, "bake_image") and "bake_image" in dir(bpy.ops.cellgl)}


if __name__ == "__main__":
    try:
        main(sys.argv[1:])
    except BaseException:
        import traceback

        traceback.print_exc()
        sys.stderr.flush()
        os._exit(1)
    sys.stdout.flush()
    os._exit(0)      # Blender's module prints leak reports at interpreter exit; the work is done
