"""The extension's operators, Add menu, sidebar panel and settings (see docs/blender.md)."""
from __future__ import annotations

import hashlib

import bpy
from bpy.props import BoolProperty, EnumProperty, IntProperty, PointerProperty, StringProperty

from cellgl.blender.addon import groups, jobs

__all__ = ["CLASSES", "menu_draw", "on_depsgraph", "register_settings", "unregister_settings"]


def _target_items():
    from cellgl.export.snippets import TARGETS

    return [(k, t.title, t.title) for k, t in TARGETS.items()]


#: Copy Snippet's targets: a static list (Blender keeps no reference to dynamic enum strings)
TARGET_ITEMS = _target_items()


def _reexport(self, context):
    """Seed or tileable changed: the OSL node follows (the image at the next bake)."""
    tree = self.id_data
    if self.kind != "RECIPE" or not self.preset:
        return
    try:
        groups.set_osl(tree, groups.osl_text(self.preset, self.seed, self.tileable))
    except Exception as exc:           # noqa: BLE001 - shown in the panel, not a console traceback
        self.status = f"OSL export failed: {exc}"


class CELLGL_PG_settings(bpy.types.PropertyGroup):
    """A cellgl node group's settings (``node_tree.cellgl``)."""

    kind: StringProperty(name="Kind", default="")
    preset: StringProperty(name="Preset", description="the cellgl preset this group stands for")
    seed: IntProperty(name="Seed", description="the recipe's seed (its feature points)", default=0,
                      min=0, max=2**31 - 1, update=_reexport)
    size: IntProperty(name="Bake Size", description="side of the baked images, in pixels", default=1024,
                      min=16, max=16384)
    tileable: BoolProperty(name="Tileable", description="make the texture wrap around at its edges "
                           "(frequencies rounded to whole cells)", default=False, update=_reexport)
    rebake: BoolProperty(name="Re-bake on Change", description="bake the images again whenever a "
                         "parameter changes", default=False)
    target: EnumProperty(name="Target", description="the language of Copy Snippet", items=TARGET_ITEMS)
    voronoi: StringProperty(name="Voronoi", description="the replaced node's settings (JSON)")
    baked_hash: StringProperty(name="Baked", description="the values of the last bake")
    status: StringProperty(name="Status", default="")
    show_inactive: BoolProperty(name="Show Inactive", description="list the parameters that do nothing "
                                "at the current values (greyed)", default=True)


def _active_group(context):
    node = getattr(context, "active_node", None)
    if node is None and context.space_data is not None and getattr(context.space_data, "edit_tree", None):
        node = context.space_data.edit_tree.nodes.active
    if node is not None and node.bl_idname == "ShaderNodeGroup" and node.node_tree is not None \
            and node.node_tree.cellgl.kind:
        return node
    return None


def _values_hash(node) -> str:
    s = node.node_tree.cellgl
    values = groups.group_values(node) if s.kind == "RECIPE" else \
        [f"{k}={v!r}" for k, v in sorted(groups.voronoi_values(node).items())]
    text = "|".join(values + [str(s.size), str(s.tileable), s.voronoi])
    return hashlib.sha1(text.encode()).hexdigest()


def _job_for(node) -> dict:
    import json

    s = node.node_tree.cellgl
    if s.kind == "VORONOI":
        return {"kind": "voronoi", "size": s.size,
                "sockets": {**json.loads(s.voronoi), **groups.voronoi_values(node)}}
    return {"kind": "recipe", "recipe": s.preset, "sets": groups.group_values(node), "size": s.size,
            "tileable": s.tileable}


def bake_node(node, wait: bool) -> str:
    """Bake group node ``node``'s images (wait, or in the background); returns an error or ''."""
    tree = node.node_tree
    try:
        if wait or bpy.app.background:
            return jobs.run_sync(tree.name, _job_for(node), _values_hash(node))
        jobs.start(tree.name, _job_for(node), _values_hash(node))
    except Exception as exc:            # noqa: BLE001 - a report, never a console traceback
        return f"cellgl bake: {type(exc).__name__}: {exc}"
    return ""


def _edit_tree(context):
    space = context.space_data
    tree = getattr(space, "edit_tree", None) if space is not None else None
    if tree is None:
        obj = context.object
        mat = obj.active_material if obj is not None else None
        tree = mat.node_tree if mat is not None and mat.use_nodes else None
    return tree


class CELLGL_OT_add_preset(bpy.types.Operator):
    """Add a cellgl texture: a node group with the preset's parameters, OSL and a GPU bake"""

    bl_idname = "cellgl.add_preset"
    bl_label = "Add cellgl Texture"
    bl_options = {"REGISTER", "UNDO"}

    preset: StringProperty(name="Preset", description="the cellgl preset")
    bake: BoolProperty(name="Bake Image", description="bake the image branch now", default=True)

    def execute(self, context):
        tree = _edit_tree(context)
        if tree is None or tree.bl_idname != "ShaderNodeTree":
            self.report({"ERROR"}, "open a material's node tree in the Shader Editor first")
            return {"CANCELLED"}
        names = {n for n, _ in groups.exportable_presets()}
        if self.preset not in names:
            self.report({"ERROR"}, f"preset {self.preset!r} has no OSL export; accepted: {', '.join(sorted(names))}")
            return {"CANCELLED"}
        try:
            group = groups.build_group(self.preset)
        except Exception as exc:        # noqa: BLE001
            self.report({"ERROR"}, f"cellgl: {type(exc).__name__}: {exc}")
            return {"CANCELLED"}
        for n in tree.nodes:
            n.select = False
        node = tree.nodes.new("ShaderNodeGroup")
        node.node_tree = group
        node.label = f"cellgl {self.preset}"
        space = context.space_data
        loc = tuple(getattr(space, "cursor_location", (0.0, 0.0)))
        node.location = loc
        uv = tree.nodes.new("ShaderNodeTexCoord")
        uv.location = (loc[0] - 250, loc[1])
        uv.select = False
        tree.links.new(uv.outputs["UV"], node.inputs["Vector"])
        node.select = True
        tree.nodes.active = node
        if self.bake:
            err = bake_node(node, wait=False)
            if err:
                self.report({"ERROR"}, err)
                return {"CANCELLED"}
        return {"FINISHED"}


class CELLGL_OT_bake_image(bpy.types.Operator):
    """Bake the active cellgl node's images with cellgl on the GPU, in a process of its own"""

    bl_idname = "cellgl.bake_image"
    bl_label = "Bake Image"
    bl_options = {"REGISTER", "UNDO"}

    wait: BoolProperty(name="Wait", description="block until the bake is done", default=False,
                       options={"SKIP_SAVE"})

    @classmethod
    def poll(cls, context):
        return _active_group(context) is not None

    def execute(self, context):
        node = _active_group(context)
        err = bake_node(node, wait=self.wait)
        if err:
            self.report({"ERROR"}, err)
            return {"CANCELLED"}
        if self.wait or bpy.app.background:
            self.report({"INFO"}, node.node_tree.cellgl.status)
        return {"FINISHED"}


class _CopyText:
    """An operator that copies a text made from the active cellgl recipe node to the clipboard:
    ``make_text(node)`` makes it, ``done_message(node, text)`` reports it; errors become Blender reports."""

    error_prefix = "cellgl"

    @classmethod
    def poll(cls, context):
        node = _active_group(context)
        return node is not None and node.node_tree.cellgl.kind == "RECIPE"

    def execute(self, context):
        node = _active_group(context)
        try:
            text = self.make_text(node)
        except Exception as exc:        # noqa: BLE001
            self.report({"ERROR"}, f"{self.error_prefix}: {type(exc).__name__}: {exc}")
            return {"CANCELLED"}
        context.window_manager.clipboard = text
        self.report({"INFO"}, self.done_message(node, text))
        return {"FINISHED"}


class CELLGL_OT_copy_snippet(_CopyText, bpy.types.Operator):
    """Copy the texture with the node's values as shader code for the chosen target"""

    bl_idname = "cellgl.copy_snippet"
    bl_label = "Copy Snippet"
    error_prefix = "cellgl export"

    def make_text(self, node):
        return groups.snippet_text(node, node.node_tree.cellgl.target)

    def done_message(self, node, text):
        return f"copied the {node.node_tree.cellgl.target} snippet ({len(text.splitlines())} lines)"


class CELLGL_OT_copy_bake_command(_CopyText, bpy.types.Operator):
    """Copy the cellgl bake command line that writes this texture with the node's values"""

    bl_idname = "cellgl.copy_bake_command"
    bl_label = "Copy Bake Command"

    def make_text(self, node):
        return groups.bake_command_text(node)

    def done_message(self, node, text):
        return text


class CELLGL_OT_voronoi_exact(bpy.types.Operator):
    """Add cellgl's exact Voronoi (baked images) as a drop-in for the active Voronoi Texture node:
    same outputs, its links moved over"""

    bl_idname = "cellgl.voronoi_exact"
    bl_label = "Exact Voronoi (cellgl)"
    bl_options = {"REGISTER", "UNDO"}

    size: IntProperty(name="Bake Size", default=1024, min=16, max=16384)
    replace: BoolProperty(name="Remove Original", description="remove the Voronoi node (else keep it, "
                          "unlinked, for comparison)", default=False)

    @classmethod
    def poll(cls, context):
        tree = _edit_tree(context)
        node = tree.nodes.active if tree is not None else None
        return node is not None and node.bl_idname == "ShaderNodeTexVoronoi"

    def execute(self, context):
        tree = _edit_tree(context)
        vor = tree.nodes.active
        group = groups.build_voronoi_group(vor, self.size)
        node = tree.nodes.new("ShaderNodeGroup")
        node.node_tree = group
        node.label = "cellgl Voronoi"
        node.location = (vor.location.x, vor.location.y - 50)
        vin = vor.inputs["Vector"]
        if vin.is_linked:
            tree.links.new(vin.links[0].from_socket, node.inputs["Vector"])
        else:
            uv = tree.nodes.new("ShaderNodeTexCoord")
            uv.location = (vor.location.x - 250, vor.location.y - 50)
            tree.links.new(uv.outputs["UV"], node.inputs["Vector"])
        for out in vor.outputs:
            for link in list(out.links):
                if out.name in node.outputs:
                    tree.links.new(node.outputs[out.name], link.to_socket)
        if self.replace:
            tree.nodes.remove(vor)
        tree.nodes.active = node
        err = bake_node(node, wait=False)
        if err:
            self.report({"ERROR"}, err)
            return {"CANCELLED"}
        return {"FINISHED"}


# ------------------------------------------------------------------------------ Add menu

def _menu_class(fam: str, names: list[str]):
    ident = "CELLGL_MT_add_" + "".join(c if c.isalnum() else "_" for c in fam.lower())

    def draw(self, _context):
        for n in names:
            op = self.layout.operator(CELLGL_OT_add_preset.bl_idname, text=n)
            op.preset = n

    return type(ident, (bpy.types.Menu,), {"bl_idname": ident, "bl_label": fam, "draw": draw})


def _family_menus():
    fams: dict[str, list[str]] = {}
    for n, _ in groups.exportable_presets():
        fams.setdefault(groups.family(n), []).append(n)
    return [_menu_class(f, fams[f]) for f in sorted(fams)]


FAMILY_MENUS = _family_menus()


class CELLGL_MT_add(bpy.types.Menu):
    bl_idname = "CELLGL_MT_add"
    bl_label = "cellgl"

    def draw(self, _context):
        for m in FAMILY_MENUS:
            self.layout.menu(m.bl_idname)


def menu_draw(self, context):
    """Shader Editor > Add: the cellgl submenu."""
    if getattr(context.space_data, "tree_type", "") == "ShaderNodeTree":
        self.layout.separator()
        self.layout.menu(CELLGL_MT_add.bl_idname)


def context_menu_draw(self, context):
    if CELLGL_OT_voronoi_exact.poll(context):
        self.layout.operator(CELLGL_OT_voronoi_exact.bl_idname)


# ------------------------------------------------------------------------------ panel

class CELLGL_PT_texture(bpy.types.Panel):
    bl_idname = "CELLGL_PT_texture"
    bl_label = "cellgl"
    bl_space_type = "NODE_EDITOR"
    bl_region_type = "UI"
    bl_category = "cellgl"

    @classmethod
    def poll(cls, context):
        return getattr(context.space_data, "tree_type", "") == "ShaderNodeTree"

    def draw(self, context):
        layout = self.layout
        node = _active_group(context)
        if node is None:
            if CELLGL_OT_voronoi_exact.poll(context):
                layout.operator(CELLGL_OT_voronoi_exact.bl_idname)
            else:
                layout.label(text="Select a cellgl node (Add > cellgl)")
            return
        s = node.node_tree.cellgl
        col = layout.column()
        if s.kind == "RECIPE":
            col.label(text=f"Preset: {s.preset}")
            col.prop(s, "seed")
            inactive = groups.inactive_inputs(node)
            if inactive:
                col.prop(s, "show_inactive")
            box = col.box()
            for sock in node.inputs:
                if sock.name == "Vector" or sock.is_linked or not hasattr(sock, "default_value"):
                    continue
                if sock.name in inactive and not s.show_inactive:
                    continue
                row = box.row()
                row.active = sock.name not in inactive
                row.prop(sock, "default_value", text=sock.name)
        else:
            col.label(text="Exact Voronoi (cellgl.voronoi)")
            box = col.box()
            for sock in node.inputs:
                if sock.name != "Vector" and not sock.is_linked and hasattr(sock, "default_value"):
                    box.prop(sock, "default_value", text=sock.name)
        col.separator()
        col.prop(s, "size")
        if s.kind == "RECIPE":
            col.prop(s, "tileable")
        job = jobs.JOBS.get(node.node_tree.name)
        row = col.row(align=True)
        if job is not None:
            row.label(text=f"Baking... {100 * job.progress:.0f} %", icon="TIME")
        else:
            row.operator(CELLGL_OT_bake_image.bl_idname, icon="RENDER_STILL")
        col.prop(s, "rebake")
        if s.status:
            r = col.row()
            r.alert = "failed" in s.status
            r.label(text=s.status)
        if s.kind == "RECIPE":
            col.separator()
            row = col.row(align=True)
            row.prop(s, "target", text="")
            row.operator(CELLGL_OT_copy_snippet.bl_idname, icon="COPYDOWN")
            col.operator(CELLGL_OT_copy_bake_command.bl_idname, icon="CONSOLE")


# ------------------------------------------------------------------------------ re-bake on change

@bpy.app.handlers.persistent
def on_depsgraph(scene, depsgraph=None):
    """depsgraph_update_post: re-bake the groups whose values changed (Re-bake on Change;
    headless the bake waits)."""
    for mat in bpy.data.materials:
        tree = mat.node_tree
        if tree is None:
            continue
        for node in tree.nodes:
            if node.bl_idname != "ShaderNodeGroup" or node.node_tree is None:
                continue
            s = node.node_tree.cellgl
            if not s.kind or not s.rebake or node.node_tree.name in jobs.JOBS:
                continue
            try:
                h = _values_hash(node)
            except (KeyError, AttributeError):
                continue
            if h != s.baked_hash and jobs.FAILED.get(node.node_tree.name) != h:
                err = bake_node(node, wait=False)
                if err:
                    s.status = err


CLASSES = [CELLGL_PG_settings, CELLGL_OT_add_preset, CELLGL_OT_bake_image, CELLGL_OT_copy_snippet,
           CELLGL_OT_copy_bake_command, CELLGL_OT_voronoi_exact, *FAMILY_MENUS, CELLGL_MT_add,
           CELLGL_PT_texture]


def register_settings():
    bpy.types.ShaderNodeTree.cellgl = PointerProperty(type=CELLGL_PG_settings)


def unregister_settings():
    del bpy.types.ShaderNodeTree.cellgl
