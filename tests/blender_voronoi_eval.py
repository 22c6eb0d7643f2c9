"""Evaluate Blender's Voronoi Texture node at given points (run in its own interpreter with bpy).

    python tests/blender_voronoi_eval.py IN.npz OUT.npz

IN holds ``points`` (N, d) float32 and ``cases`` (a JSON list of {dim, feature, metric, sockets,
normalize}); OUT gets, per case i, arrays ``i/Distance``, ``i/Color``, ``i/Position``, ``i/W``,
``i/Radius`` (those the feature has). The node runs in Geometry Nodes on a mesh whose vertices are
the points (W from a float attribute), its outputs stored as named attributes and read back.
"""
import json
import sys

import bpy
import numpy as np

_STORE = {"Distance": ("FLOAT", "value", 1), "Color": ("FLOAT_COLOR", "color", 4),
          "Position": ("FLOAT_VECTOR", "vector", 3), "W": ("FLOAT", "value", 1),
          "Radius": ("FLOAT", "value", 1)}


def evaluate(points: np.ndarray, dim: int, feature: str, metric: str, sockets: dict, normalize: bool):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    co = np.zeros((len(points), 3), np.float32)
    if dim > 1:
        co[:, : min(dim, 3)] = points[:, : min(dim, 3)]
    mesh = bpy.data.meshes.new("samples")
    mesh.vertices.add(len(co))
    mesh.vertices.foreach_set("co", co.ravel())
    obj = bpy.data.objects.new("samples", mesh)
    bpy.context.scene.collection.objects.link(obj)
    if dim in (1, 4):
        mesh.attributes.new("w_in", "FLOAT", "POINT").data.foreach_set(
            "value", np.ascontiguousarray(points[:, -1], np.float32))
    tree = bpy.data.node_groups.new("voronoi", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    nodes, links = tree.nodes, tree.links
    node = nodes.new("ShaderNodeTexVoronoi")
    node.voronoi_dimensions = f"{dim}D"
    node.feature = feature
    node.distance = metric
    node.normalize = normalize
    for name, value in sockets.items():
        socket = node.inputs.get(name)      # the node offers only the sockets its feature uses
        if socket is not None:
            socket.default_value = value
    if dim > 1:
        links.new(nodes.new("GeometryNodeInputPosition").outputs[0], node.inputs["Vector"])
    if dim in (1, 4):
        attr = nodes.new("GeometryNodeInputNamedAttribute")
        attr.data_type = "FLOAT"
        attr.inputs["Name"].default_value = "w_in"
        links.new(attr.outputs["Attribute"], node.inputs["W"])
    geometry = nodes.new("NodeGroupInput").outputs[0]
    for name, (kind, _, _) in _STORE.items():
        socket = node.outputs.get(name)
        if socket is None or not socket.enabled:
            continue
        store = nodes.new("GeometryNodeStoreNamedAttribute")
        store.data_type = kind
        store.inputs["Name"].default_value = "out_" + name
        links.new(geometry, store.inputs["Geometry"])
        links.new(socket, store.inputs["Value"])
        geometry = store.outputs["Geometry"]
    links.new(geometry, nodes.new("NodeGroupOutput").inputs[0])
    obj.modifiers.new("voronoi", "NODES").node_group = tree
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    out = {}
    for name, (_, field, width) in _STORE.items():
        attr = evaluated.attributes.get("out_" + name)
        if attr is not None:
            arr = np.empty(len(co) * width, np.float32)
            attr.data.foreach_get(field, arr)
            out[name] = arr.reshape(len(co), width) if width > 1 else arr
    return out


def main(src: str, dst: str) -> None:
    data = np.load(src)
    points = data["points"]
    result = {}
    for i, case in enumerate(json.loads(str(data["cases"]))):
        pts = points[:, : case["dim"]]
        for name, arr in evaluate(pts, case["dim"], case["feature"], case["metric"], case["sockets"],
                                  case["normalize"]).items():
            result[f"{i}/{name}"] = arr
    np.savez(dst, **result)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
