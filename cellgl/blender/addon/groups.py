"""The node groups of the Blender extension: one per added preset (or replaced Voronoi node).

A preset's group (``cellgl flagstone``) holds

* ``cellgl OSL``: a Script node with the recipe's OSL export (``cellgl export --target osl``),
  its inputs fed by the group's inputs (the exported parameters, with the parameter table's
  defaults, ranges and tooltips: :mod:`cellgl.texture.params`);
* ``cellgl Color`` / ``Data`` / ``Normal`` / ``Cell``: Image Texture nodes holding the bake of
  the same values (:mod:`cellgl.blender.bakejob`), packed into the ``.blend``;
* ``cellgl Is OSL``: a tiny Script node whose output is 1 where the renderer runs OSL (Cycles
  with Open Shading Language on the CPU or OptiX) and 0 elsewhere (EEVEE, Cycles' SVM on any
  device take a Script node's outputs as their socket defaults, 0 here);
* one Mix node per output: the OSL value where the Is OSL output is 1, the image's otherwise.

Outputs: Color, Fac (the height), Normal, Cell Color, ID Low and ID High (the cell's 32-bit ID,
16 bits each, exact integers), those the OSL shader declares.
"""
from __future__ import annotations

import bpy

__all__ = ["build_group", "set_osl", "group_values", "apply_bake", "build_voronoi_group",
           "apply_voronoi_bake", "family", "IS_OSL_SOURCE", "exportable_presets"]

#: the switch: 1 under OSL; elsewhere the renderer takes the socket default, 0
IS_OSL_SOURCE = ("shader cellgl_is_osl(output float IsOSL = 0.0)\n{\n    IsOSL = 1.0;\n}\n")

#: group outputs: (name, socket type, the OSL output, the image node and its channel)
OUTPUTS = (
    ("Color", "NodeSocketColor", "Color", ("Color", "Color")),
    ("Fac", "NodeSocketFloat", "Fac", ("Data", 0)),
    ("Normal", "NodeSocketVector", "Normal", ("Normal", "Normal")),
    ("Cell Color", "NodeSocketColor", "CellColor", ("Cell", "Color")),
    ("ID Low", "NodeSocketFloat", "IDLow", ("Data", 1)),
    ("ID High", "NodeSocketFloat", "IDHigh", ("Data", 2)),
)
_MIX_TYPE = {"NodeSocketColor": "RGBA", "NodeSocketFloat": "FLOAT", "NodeSocketVector": "VECTOR"}
_TOOLTIP = {"Fac": "the height in [0, 1]", "ID Low": "the cell's feature point ID: its low 16 bits",
            "ID High": "the cell's feature point ID: its high 16 bits",
            "Cell Color": "a random colour per cell (from its ID)",
            "Normal": "the shading normal bumped by the height", "Color": "the texture's colour"}

_FAMILIES = (("qin-", "Qin 2000"), ("blender-", "Blender"), ("worley-", "Worley Basis"))


def family(name: str) -> str:
    """The Add menu's submenu of preset ``name``."""
    if name in ("f1", "f2", "f3", "f4"):
        return "Worley Basis"
    for prefix, fam in _FAMILIES:
        if name.startswith(prefix):
            return fam
    return "Textures"


def exportable_presets() -> list[tuple[str, str]]:
    """``[(name, doc)]`` of the presets with an OSL export: not PUPs, not image-driven (the
    refusals of ``cellgl export --target osl``)."""
    from cellgl.recipes import list_presets, load_recipe

    out = []
    for name, doc in list_presets():
        r = load_recipe(name)
        if getattr(r, "kind", None) == "pups":
            continue
        if r.values["cell_color"] == "image" or r.values["density_map"] == "image":
            continue
        out.append((name, doc))
    return out


def osl_text(preset: str, seed: int, tileable: bool) -> str:
    from cellgl.blender.bakejob import recipe_for
    from cellgl.export.snippets import export

    return export(recipe_for(preset, [f"seed={int(seed)}"], tileable), "osl")


def _compile(node, text: str, name: str) -> None:
    from cellgl.blender.runtime import compile_script_node

    old = node.script
    t = bpy.data.texts.new(name)
    t.write(text)
    node.script = t
    if old is not None and old.users == 0:
        bpy.data.texts.remove(old)
    compile_script_node(node)


def _param_name(identifier: str) -> str:
    from cellgl.texture.params import PARAMS_BY_NAME

    if identifier in PARAMS_BY_NAME:
        return identifier
    return identifier.rstrip("_")


def _new_input(tree, sock):
    """A group input mirroring Script input ``sock``, with the parameter table's metadata."""
    from cellgl.texture.params import PARAMS_BY_NAME

    p = PARAMS_BY_NAME.get(_param_name(sock.identifier))
    kind = {"bool": "NodeSocketBool", "int": "NodeSocketInt"}.get(p.type if p else "", "NodeSocketFloat")
    item = tree.interface.new_socket(sock.name, in_out="INPUT", socket_type=kind)
    if p is not None:
        item.description = f"{p.doc} ({p.range_text()}; recipe parameter {p.name})"[:1000]
        if p.type in ("float", "int"):
            item.min_value, item.max_value = p.lo, p.hi
    value = sock.default_value
    item.default_value = bool(value) if kind == "NodeSocketBool" else value
    return item


def set_osl(tree, text: str) -> None:
    """(Re)compile the group's OSL node from ``text`` and (re)build the group's inputs to
    match its parameters; values of inputs that stay are kept."""
    nodes, links = tree.nodes, tree.links
    script = nodes["cellgl OSL"]
    gin = nodes["Group Input"]
    for sockets in (script.inputs, script.outputs):
        for s in list(sockets):
            sockets.remove(s)
    _compile(script, text, f"{tree.name}.osl")
    old = {it.name: it for it in tree.interface.items_tree if it.item_type == "SOCKET" and it.in_out == "INPUT"}
    want = [s for s in script.inputs if s.identifier != "Vector"]
    for name, item in old.items():
        if name != "Vector" and name not in {s.name for s in want}:
            tree.interface.remove(item)
    for s in want:
        if s.name not in old:
            _new_input(tree, s)
    for s in want:
        links.new(gin.outputs[s.name], s)
    links.new(gin.outputs["Vector"], script.inputs["Vector"])
    _wire_outputs(tree)


def _image_node(tree, key: str, closest: bool, location):
    node = tree.nodes.new("ShaderNodeTexImage")
    node.name = node.label = f"cellgl {key}"
    node.interpolation = "Closest" if closest else "Linear"
    node.location = location
    tree.links.new(tree.nodes["Group Input"].outputs["Vector"], node.inputs["Vector"])
    return node


def build_group(preset: str, seed: int | None = None, size: int = 1024, tileable: bool = False):
    """A new node group for ``preset`` (OSL node compiled; images empty until baked); ``seed``
    defaults to the preset's."""
    if seed is None:
        from cellgl.recipes import load_recipe

        seed = int(load_recipe(preset).values["seed"])
    tree = bpy.data.node_groups.new(f"cellgl {preset}", "ShaderNodeTree")
    s = tree.cellgl
    s.kind, s.preset, s.seed, s.size, s.tileable = "RECIPE", preset, seed, size, tileable
    nodes = tree.nodes
    gin, gout = nodes.new("NodeGroupInput"), nodes.new("NodeGroupOutput")
    gin.location, gout.location = (-900, 0), (700, 0)
    vec = tree.interface.new_socket("Vector", in_out="INPUT", socket_type="NodeSocketVector")
    vec.hide_value = True
    vec.description = "texture coordinates: (0, 0)-(1, 1) spans the bake (connect a UV map)"
    for name, kind, _, _ in OUTPUTS:
        item = tree.interface.new_socket(name, in_out="OUTPUT", socket_type=kind)
        item.description = _TOOLTIP[name]
    script = nodes.new("ShaderNodeScript")
    script.name = script.label = "cellgl OSL"
    script.mode = "INTERNAL"
    script.location = (-500, 400)
    is_osl = nodes.new("ShaderNodeScript")
    is_osl.name = is_osl.label = "cellgl Is OSL"
    is_osl.mode = "INTERNAL"
    is_osl.location = (-100, 600)
    _compile(is_osl, IS_OSL_SOURCE, "cellgl_is_osl.osl")
    _image_node(tree, "Color", False, (-500, -100))
    _image_node(tree, "Data", True, (-500, -400))
    _image_node(tree, "Normal", False, (-500, -700))
    _image_node(tree, "Cell", True, (-500, -1000))
    sep = nodes.new("ShaderNodeSeparateColor")
    sep.name = "cellgl Data Split"
    sep.location = (-200, -400)
    tree.links.new(nodes["cellgl Data"].outputs["Color"], sep.inputs["Color"])
    nmap = nodes.new("ShaderNodeNormalMap")
    nmap.name = "cellgl Normal Map"
    nmap.location = (-200, -700)
    tree.links.new(nodes["cellgl Normal"].outputs["Color"], nmap.inputs["Color"])
    for i, (name, kind, _, _) in enumerate(OUTPUTS):
        mix = nodes.new("ShaderNodeMix")
        mix.name = f"cellgl Switch {name}"
        mix.data_type = _MIX_TYPE[kind]
        mix.clamp_factor = False
        for sock in mix.inputs:
            if sock.name == "Factor":
                sock.default_value = 0.0 if sock.type == "VALUE" else (0.0, 0.0, 0.0)
        mix.location = (300, 300 - 200 * i)
        tree.links.new(is_osl.outputs["IsOSL"], mix.inputs["Factor"])
    set_osl(tree, osl_text(preset, seed, tileable))
    return tree


def _mix_sockets(mix):
    """(A, B, Result) of a Mix node for its data type."""
    t = {"FLOAT": "VALUE"}.get(mix.data_type, mix.data_type)
    a = next(s for s in mix.inputs if s.name == "A" and s.type == t and s.enabled)
    b = next(s for s in mix.inputs if s.name == "B" and s.type == t and s.enabled)
    r = next(s for s in mix.outputs if s.type == t and s.enabled)
    return a, b, r


def _wire_outputs(tree) -> None:
    nodes, links = tree.nodes, tree.links
    script, gout = nodes["cellgl OSL"], nodes["Group Output"]
    have = {s.identifier for s in script.outputs}
    for name, _, osl_out, (img, chan) in OUTPUTS:
        mix = nodes[f"cellgl Switch {name}"]
        a, b, r = _mix_sockets(mix)
        if name == "Normal":
            links.new(nodes["cellgl Normal Map"].outputs["Normal"], a)
        elif isinstance(chan, int):
            links.new(nodes["cellgl Data Split"].outputs[chan], a)
        else:
            links.new(nodes[f"cellgl {img}"].outputs[chan], a)
        if osl_out in have:
            links.new(script.outputs[osl_out], b)
        links.new(r, gout.inputs[name])


def _float_text(v) -> str:
    """The shortest text of float32 ``v`` (a socket's value): 0.8, not 0.800000011920929."""
    import numpy as np

    return str(np.float32(v))


def group_values(node) -> list[str]:
    """``["name=value", ...]``: the parameters of group node ``node`` (its input sockets'
    values) as ``cellgl bake --set`` takes them, with the group's seed."""
    tree = node.node_tree
    script = tree.nodes["cellgl OSL"]
    by_name = {s.name: s.identifier for s in script.inputs}
    out = [f"seed={int(tree.cellgl.seed)}"]
    for sock in node.inputs:
        if sock.name == "Vector" or sock.name not in by_name:
            continue
        v = sock.default_value
        name = _param_name(by_name[sock.name])
        if isinstance(v, bool):
            text = "true" if v else "false"
        elif isinstance(v, int):
            text = str(v)
        else:
            text = _float_text(v)
        out.append(f"{name}={text}")
    return out


def group_values_defaults(node) -> list[str]:
    """:func:`group_values` at the preset's own values (what ``cellgl bake PRESET`` uses)."""
    from cellgl.recipes import load_recipe

    tree = node.node_tree
    r = load_recipe(tree.cellgl.preset)
    script = tree.nodes["cellgl OSL"]
    out = [f"seed={int(r.values['seed'])}"]
    for sock in script.inputs:
        name = _param_name(sock.identifier)
        if sock.identifier == "Vector" or name not in r.values:
            continue
        v = r.values[name]
        text = ("true" if v else "false") if isinstance(v, bool) else (str(v) if isinstance(v, int)
                                                                      else _float_text(v))
        out.append(f"{name}={text}")
    return out


def snippet_text(node, target: str) -> str:
    """The node's texture (preset, seed, values, tileable) as a ``target`` snippet (Copy Snippet)."""
    from cellgl.blender.bakejob import recipe_for
    from cellgl.export.snippets import export

    s = node.node_tree.cellgl
    return export(recipe_for(s.preset, group_values(node), s.tileable), target)


def bake_command_text(node) -> str:
    """``cellgl bake`` with the values that differ from the preset's (Copy Bake Command)."""
    from cellgl.blender.bakejob import bake_command

    s = node.node_tree.cellgl
    defaults = set(group_values_defaults(node))
    sets = [v for v in group_values(node) if v not in defaults]
    return bake_command(s.preset, sets, s.size, s.tileable)


def inactive_inputs(node) -> dict[str, str]:
    """``{input name: what turns it on}`` for the group node's inputs that do nothing at its
    current values (greyed in the panel): :func:`cellgl.texture.params.inactive`, the parameter
    table's one derivation, where this cellgl has it (else none)."""
    from cellgl.texture import params

    derive = getattr(params, "inactive", None)
    if derive is None:
        return {}
    from cellgl.blender.bakejob import recipe_for

    s = node.node_tree.cellgl
    try:
        dead = dict(derive(recipe_for(s.preset, group_values(node), s.tileable)))
    except Exception:                  # noqa: BLE001 - greying is a hint, never an error
        return {}
    script = node.node_tree.nodes["cellgl OSL"]
    return {sock.name: dead[_param_name(sock.identifier)] for sock in script.inputs
            if _param_name(sock.identifier) in dead}


def _image(tree, key: str, arr, is_float: bool):
    """Put array ``arr`` (H, W, C; row 0 on top) into the group's ``key`` image, packed."""
    import numpy as np

    h, w = arr.shape[:2]
    name = f"{tree.name} {key}"
    img = bpy.data.images.get(name)
    if img is None or img.size[0] != w or img.size[1] != h or img.is_float != is_float:
        if img is not None:
            bpy.data.images.remove(img)
        img = bpy.data.images.new(name, w, h, alpha=True, float_buffer=is_float)
    img.colorspace_settings.is_data = True
    img.colorspace_settings.name = "Non-Color"
    if is_float:
        img.use_half_precision = False     # EEVEE's GPU texture: IDs up to 65535 need float32
    rgba = np.ones((h, w, 4), np.float32)
    a = arr.astype(np.float32) / (1.0 if is_float else 255.0)
    rgba[..., :a.shape[-1]] = a
    img.pixels.foreach_set(np.ascontiguousarray(rgba[::-1]).ravel())
    img.update()
    img.pack()
    node = tree.nodes[f"cellgl {key}"]
    node.image = img
    node.extension = "REPEAT" if tree.cellgl.tileable else "EXTEND"
    return img


def apply_bake(tree, arrays: dict, values_hash: str = "") -> None:
    """Load a recipe bake's arrays (:func:`cellgl.blender.bakejob.bake_recipe`) into the group."""
    _image(tree, "Color", arrays["color"], False)
    _image(tree, "Data", arrays["data"], True)
    _image(tree, "Normal", arrays["normal"], False)
    _image(tree, "Cell", arrays["cell"], False)
    tree.cellgl.baked_hash = values_hash


# ---------------------------------------------------------------- Voronoi drop-in

VORONOI_OUTPUTS = (("Distance", "NodeSocketFloat", "distance"), ("Color", "NodeSocketColor", "color"),
                   ("Position", "NodeSocketVector", "position"), ("W", "NodeSocketFloat", "w"),
                   ("Radius", "NodeSocketFloat", "radius"))


def voronoi_settings(node) -> dict:
    """cellgl.voronoi keywords from a Voronoi Texture node's settings (its enums and checkbox;
    the socket values are the group's inputs: :func:`voronoi_values`)."""
    feature = {"F1": "F1", "F2": "F2", "SMOOTH_F1": "smooth_F1", "DISTANCE_TO_EDGE": "distance_to_edge",
               "N_SPHERE_RADIUS": "n_sphere_radius"}[node.feature]
    metric = {"EUCLIDEAN": "euclidean", "MANHATTAN": "manhattan", "CHEBYCHEV": "chebyshev",
              "MINKOWSKI": "minkowski"}[node.distance]
    return {"dimensions": int(node.voronoi_dimensions[0]), "feature": feature, "metric": metric,
            "normalize": bool(node.normalize)}


def voronoi_values(node) -> dict:
    """cellgl.voronoi keywords from the socket values of ``node`` (the Voronoi Texture node, or
    the drop-in group node, whose inputs have the same names)."""
    from cellgl.blender.bakejob import VORONOI_SOCKETS

    return {VORONOI_SOCKETS[x.name]: float(x.default_value) for x in node.inputs
            if x.name in VORONOI_SOCKETS and getattr(x, "enabled", True)}


def build_voronoi_group(vor, size: int):
    """A group standing in for Voronoi Texture node ``vor``: its value sockets as inputs (their
    values, ranges and tooltips; baked, so they act at the next bake), its outputs read from
    baked float images."""
    import json

    from cellgl.blender.bakejob import VORONOI_SOCKETS

    tree = bpy.data.node_groups.new("cellgl Voronoi", "ShaderNodeTree")
    s = tree.cellgl
    s.kind, s.preset, s.size = "VORONOI", "voronoi", size
    s.voronoi = json.dumps(voronoi_settings(vor), sort_keys=True)
    gin, gout = tree.nodes.new("NodeGroupInput"), tree.nodes.new("NodeGroupOutput")
    gin.location, gout.location = (-600, 0), (400, 0)
    vec = tree.interface.new_socket("Vector", in_out="INPUT", socket_type="NodeSocketVector")
    vec.hide_value = True
    vec.description = "texture coordinates: (0, 0)-(1, 1) spans the bake (connect a UV map)"
    for sock in vor.inputs:
        if sock.name not in VORONOI_SOCKETS or not sock.enabled:
            continue
        item = tree.interface.new_socket(sock.name, in_out="INPUT", socket_type="NodeSocketFloat")
        prop = sock.bl_rna.properties["default_value"]
        item.min_value, item.max_value = prop.hard_min, prop.hard_max
        item.default_value = sock.default_value
        item.description = f"the Voronoi node's {sock.name} (baked: changes act at the next bake)"
    for i, (name, kind, key) in enumerate(VORONOI_OUTPUTS):
        tree.interface.new_socket(name, in_out="OUTPUT", socket_type=kind)
        node = _image_node(tree, key, True, (-300, 300 - 300 * i))
        out = node.outputs["Color"]
        if kind == "NodeSocketFloat":
            sep = tree.nodes.new("ShaderNodeSeparateColor")
            sep.location = (0, 300 - 300 * i)
            tree.links.new(out, sep.inputs["Color"])
            out = sep.outputs[0]
        tree.links.new(out, gout.inputs[name])
    return tree


def apply_voronoi_bake(tree, arrays: dict) -> None:
    import numpy as np

    n = tree.cellgl.size
    for _, _, key in VORONOI_OUTPUTS:
        a = arrays.get(key)
        a = np.zeros((n, n, 1), np.float32) if a is None else a
        a = a[..., None] if a.ndim == 2 else a
        pad = np.zeros(a.shape[:2] + (3,), np.float32)      # 2D positions: z = 0
        pad[..., :min(3, a.shape[-1])] = a[..., :3]
        _image(tree, key, pad, True)
