"""A Blender scene that renders a recipe's OSL export as ``cellgl bake`` would: ``cellgl blender``.

The mapping (what makes "render the file as is at N x N" give the bake's image):

* a plane spanning x, y in [0, 1] at z = 0, UV = (x, y), its material an OSL Script node (the
  export, as internal text) fed by the UV map; the node's Color goes to an Emission shader of
  strength 1, so the rendered value of a pixel is the shader's Color there;
* an orthographic camera at (0.5, 0.5, 1) looking down -z with ortho scale 1 (less
  :data:`CYCLES_SAMPLE_OFFSET` / N, see there): the frame is the plane, and pixel (column i,
  row j from the top) of an N x N render is centred at x = (i + 0.5) / N, y = 1 - (j + 0.5) / N,
  which the shader maps to the bake's uv = ((i + 0.5) / N, (j + 0.5) / N);
* Cycles on the CPU with OSL, 1 sample, a box pixel filter of the smallest width (0.01 px), no
  denoising, no bounces; the view transform ``Raw`` (Blender's default AgX, or Standard's sRGB
  curve, would change the colours: the bake's 8-bit values are the shader's values times 255)
  and 8-bit PNG output at the bake's default size (or ``size``).
"""
from __future__ import annotations

import contextlib
import os
import sys

from cellgl.blender.runtime import compile_script_node, import_bpy

__all__ = ["build_scene", "write_blend", "render_scene", "render_outputs", "set_recipe", "set_script",
           "CYCLES_SAMPLE_OFFSET"]

#: where Cycles 4.5 puts the first (only) sample of a pixel with a box filter of width 0.01,
#: right of and above the pixel centre, in pixels (measured: rendering P; about 0.5 / 1023, half a
#: step of its 1024-entry filter table). Without the correction, a pixel whose centre lies within
#: ~4e-6 of a cell border in uv may take the neighbour's ID: 0 to 3 pixels in 128 x 128.
CYCLES_SAMPLE_OFFSET = 0.0004886


def osl_text(recipe) -> tuple[str, str]:
    from cellgl.export.snippets import export
    from cellgl.recipes import load_recipe

    r = load_recipe(recipe)
    return r.name, export(r, "osl")


def _check_size(size) -> int:
    if size is None:
        from cellgl.bake.request import DEFAULT_SIZE

        return DEFAULT_SIZE[0]
    if isinstance(size, bool) or not isinstance(size, int) or not 1 <= size <= 16384:
        raise ValueError(f"size {size!r} is out of range; accepted: an integer from 1 to 16384")
    return size


def build_scene(recipe, size: int | None = None):
    """Replace the open Blender file by the scene of ``recipe`` (see the module's mapping).

    Parameters
    ----------
    recipe : Recipe, str or path
        A texture recipe, a preset name or a recipe JSON file (PUPs recipes and image-driven
        ones are refused, as by ``cellgl export``).
    size : int, optional
        Render resolution N (N x N); default: the bake's default width.

    Returns
    -------
    bpy.types.Scene
    """
    size = _check_size(size)
    bpy = import_bpy()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    cy = scene.cycles
    cy.device = "CPU"
    cy.shading_system = True
    cy.samples = 1
    cy.use_adaptive_sampling = False
    cy.use_denoising = False
    cy.pixel_filter_type = "BOX"
    cy.filter_width = 0.01
    cy.max_bounces = 0
    cy.seed = 0
    scene.render.resolution_x = scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = False
    scene.view_settings.view_transform = "Raw"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGB"
    scene.render.image_settings.color_depth = "8"

    mesh = bpy.data.meshes.new("cellgl_plane")
    mesh.from_pydata([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], [], [(0, 1, 2, 3)])
    uv = mesh.uv_layers.new(name="UVMap")
    for loop in mesh.loops:
        x, y, _ = mesh.vertices[loop.vertex_index].co
        uv.data[loop.index].uv = (x, y)
    plane = bpy.data.objects.new("cellgl_plane", mesh)
    scene.collection.objects.link(plane)

    cam_data = bpy.data.cameras.new("cellgl_camera")
    cam_data.type = "ORTHO"
    cam_data.ortho_scale = 1.0
    cam_data.clip_start = 0.01
    cam_data.clip_end = 10.0
    cam = bpy.data.objects.new("cellgl_camera", cam_data)
    # Cycles puts the first sample CYCLES_SAMPLE_OFFSET px right of and above the pixel centre
    # (its box filter table read at 0.5): the camera moves back by that much
    cam.location = (0.5 - CYCLES_SAMPLE_OFFSET / size, 0.5 - CYCLES_SAMPLE_OFFSET / size, 1.0)
    scene.collection.objects.link(cam)
    scene.camera = cam

    mat = bpy.data.materials.new("cellgl")
    mat.use_nodes = True
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    nodes.clear()
    coords = nodes.new("ShaderNodeTexCoord")
    script = nodes.new("ShaderNodeScript")
    script.name = "cellgl"
    script.mode = "INTERNAL"
    emit = nodes.new("ShaderNodeEmission")
    out = nodes.new("ShaderNodeOutputMaterial")
    coords.location, script.location, emit.location, out.location = (-500, 0), (-250, 0), (100, 0), (300, 0)
    mesh.materials.append(mat)
    set_recipe(scene, recipe)
    links.new(emit.outputs["Emission"], out.inputs["Surface"])
    return scene


def set_recipe(scene, recipe) -> None:
    """Put ``recipe``'s OSL export into the scene's Script node (recompiled, outputs rewired),
    keeping everything else: one scene renders many recipes."""
    name, text = osl_text(recipe)
    set_script(scene, text, name)


def set_script(scene, text: str, name: str = "shader") -> None:
    """Put OSL source ``text`` into the scene's Script node (see :func:`set_recipe`): any shader
    with a point input ``Vector`` and a color output ``Color``."""
    bpy = import_bpy()
    mat = bpy.data.materials["cellgl"]
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    script = nodes["cellgl"]
    old = script.script
    new = bpy.data.texts.new(f"cellgl_{name}.osl")
    new.write(text)             # before the assignment, which compiles the text it gets
    script.script = new
    if old is not None:
        bpy.data.texts.remove(old)
    # a socket that survives a recompile keeps its value: the previous recipe's parameters
    for sockets in (script.inputs, script.outputs):
        for sock in list(sockets):
            sockets.remove(sock)
    compile_script_node(script)
    coords = next(n for n in nodes if n.bl_idname == "ShaderNodeTexCoord")
    links.new(coords.outputs["UV"], script.inputs["Vector"])
    emit = next(n for n in nodes if n.bl_idname == "ShaderNodeEmission")
    links.new(script.outputs["Color"], emit.inputs["Color"])
    emit.inputs["Strength"].default_value = 1.0
    scene["cellgl_recipe"] = name
    mat.node_tree.update_tag()
    mat.update_tag()


def write_blend(recipe, path, *, size: int | None = None) -> str:
    """Write the scene of ``recipe`` (see :func:`build_scene`) to the ``.blend`` file ``path``,
    atomically; returns the path."""
    from cellgl.io.formats import atomic_path
    from cellgl.io.tempfiles import check_output

    path = os.path.abspath(os.fspath(path))
    if not path.endswith(".blend"):
        raise ValueError(f"output {path!r} must end in .blend")
    check_output(path)
    _check_size(size)
    bpy = import_bpy()
    build_scene(recipe, size)
    bpy.context.preferences.filepaths.save_version = 0     # no .blend1 beside the temporary file
    with atomic_path(path) as tmp, _quiet():
        bpy.ops.wm.save_as_mainfile(filepath=str(tmp), compress=True, copy=True)
    return path


@contextlib.contextmanager
def _quiet():
    """Blender's own messages on standard output (``Info: Saved ...``) silenced."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
        yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)


def render_scene(scene, path: str) -> str:
    """Render ``scene`` to ``path``: PNG as set up, or (``.exr``) a float32 EXR."""
    bpy = import_bpy()
    settings = scene.render.image_settings
    fmt = settings.file_format
    if path.endswith(".exr"):
        settings.file_format = "OPEN_EXR"
        settings.color_depth = "32"
        settings.exr_codec = "ZIP"
    scene.render.filepath = path
    try:
        bpy.ops.render.render(write_still=True, scene=scene.name)
    finally:
        settings.file_format = fmt
        if fmt == "PNG":
            settings.color_depth = "8"
    return path


def render_outputs(recipes, size: int, outdir) -> list[str]:
    """Render each recipe of ``recipes`` in one scene (built once, the Script node's text swapped
    per recipe) into ``outdir``: ``NAME.png``, the render as is (what the ``.blend`` gives);
    ``NAME.id.exr``, float RGB = (IDLow, IDHigh, Fac); ``NAME.cell.exr``, float RGB = CellColor.
    Returns the recipe names, in order.

    The ID is ``IDLow + 65536 * IDHigh`` (both exact integers in float32).
    """
    from cellgl.recipes import load_recipe

    bpy = import_bpy()
    outdir = os.path.abspath(os.fspath(outdir))
    recipes = [load_recipe(r) for r in recipes]
    if not recipes:
        return []
    scene = build_scene(recipes[0], size)
    tree = bpy.data.materials["cellgl"].node_tree
    nodes, links = tree.nodes, tree.links
    names = []
    for k, r in enumerate(recipes):
        if k:
            set_recipe(scene, r)
        script = nodes["cellgl"]
        emit = next(n for n in nodes if n.bl_idname == "ShaderNodeEmission")
        render_scene(scene, os.path.join(outdir, f"{r.name}.png"))
        pack = nodes.new("ShaderNodeCombineXYZ")
        for i, out in enumerate(("IDLow", "IDHigh", "Fac")):
            links.new(script.outputs[out], pack.inputs[i])
        links.new(pack.outputs[0], emit.inputs["Color"])
        render_scene(scene, os.path.join(outdir, f"{r.name}.id.exr"))
        nodes.remove(pack)
        links.new(script.outputs["CellColor"], emit.inputs["Color"])
        render_scene(scene, os.path.join(outdir, f"{r.name}.cell.exr"))
        links.new(script.outputs["Color"], emit.inputs["Color"])
        names.append(r.name)
    return names
