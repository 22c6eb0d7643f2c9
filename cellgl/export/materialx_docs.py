"""The files of ``cellgl export --target materialx -o DIR``, written as text (exporting needs
neither MaterialX nor USD; tests/test_materialx.py checks the files with both):

* the node library, definitions apart from implementations as MaterialX's own libraries keep
  them (:func:`library_documents`): ``cellgl_defs.mtlx``, every nodedef (the basis, each
  texture preset and its single-output variants), and ``cellgl_genglsl_impl.mtlx`` /
  ``cellgl_genosl_impl.mtlx``, their implementations, whose sources lie in ``genglsl/`` and
  ``genosl/`` next to them;
* ``cellgl_materials.mtlx``: two example materials per preset (``surfacematerial`` of an
  ``open_pbr_surface`` whose base colour is the node's colour, converted from sRGB, and whose
  normal is the node's normal through ``normalmap``; and the same reading the bake's maps:
  :mod:`cellgl.export.materialx_baked`), which includes the library;
* ``cellgl_materials.usda``: the same materials as UsdShade networks, each shader's
  ``info:id`` a nodedef name (as Houdini and Omniverse write MaterialX into USD).

Every name the export writes is unique (:func:`check_names`, else the export is refused), and
the set lands whole or not at all (:mod:`cellgl.export.materialx_files`).
"""
from __future__ import annotations

import re
from pathlib import Path
from xml.sax.saxutils import quoteattr

from cellgl.export.materialx import MxNode
from cellgl.export.materialx_files import (DEFS, IMPLS, LIBRARIES, MATERIALS, USD, check_dir, check_places,
                                           write_set)
from cellgl.export.snippets import ExportError

__all__ = ["export_materialx", "DEFS", "IMPLS", "LIBRARIES", "MATERIALS", "USD", "library_documents", "materials_document", "usd_stage",
           "set_files", "check_names", "write_set", "check_dir"]

_HEAD = '<?xml version="1.0"?>\n<materialx version="1.39">\n'


def _val(v, mxtype: str) -> str:
    if isinstance(v, (tuple, list)):
        return ", ".join(_val(x, "float") for x in v)
    if mxtype == "boolean":
        return "true" if v else "false"
    if mxtype == "integer":
        return str(int(v))
    r = repr(float(v))
    return r if any(c in r for c in ".en") else r + ".0"


def _attrs(**kw) -> str:
    return "".join(f" {k}={quoteattr(str(v))}" for k, v in kw.items() if v is not None)


def mx_version() -> str:
    """The nodedefs' ``version``: cellgl's version as MaterialX writes versions, ``major.minor``
    (two integers: MaterialX reads ``0.1.0`` as no version at all)."""
    from cellgl._version import __version__

    m = re.match(r"(\d+)\.(\d+)", __version__)
    if not m:
        raise ExportError(f"cellgl's version {__version__!r} has no major.minor for the nodedefs' version")
    return f"{int(m.group(1))}.{int(m.group(2))}"


def _nodedef(node: MxNode) -> list[str]:
    head = _attrs(name=node.nodedef, node=node.name, nodegroup=node.nodegroup, version=mx_version(),
                  isdefaultversion="true", doc=node.doc)
    out = [f"  <nodedef{head}>"]
    for i in node.inputs:
        a = dict(name=i.name, type=i.mxtype)
        if i.value is not None:
            a["value"] = _val(i.value, i.mxtype)
        if i.geomprop:
            a["defaultgeomprop"] = i.geomprop
        if i.uiname:
            a["uiname"] = i.uiname
        if i.uimin is not None:
            a["uimin"] = _val(i.uimin, i.mxtype)
        if i.uimax is not None:
            a["uimax"] = _val(i.uimax, i.mxtype)
        if i.uifolder:
            a["uifolder"] = i.uifolder
        if i.inactive:
            a["uiadvanced"] = "true"
        a["doc"] = i.doc
        out.append(f"    <input{_attrs(**a)} />")
    for name, mxtype, _, _, doc in node.outputs:
        out.append(f"    <output{_attrs(name=name, type=mxtype, doc=doc)} />")
    out.append("  </nodedef>")
    return out


def _implementation(node: MxNode, target: str) -> str:
    ext = {"genglsl": "glsl", "genosl": "osl"}[target]
    a = _attrs(name=f"IM_{node.name}_{target}", nodedef=node.nodedef, file=f"{target}/{node.name}.{ext}",
               function=node.function, target=target)
    return f"  <implementation{a} />"


def single_outputs(node: MxNode) -> list[tuple[str, str, str]]:
    """``(nodedef, nodegraph, output)`` of the single-output variants of a texture node: one
    per output, the nodedef ``ND_<node>_<type>`` of the same node (``cellgl_flagstone``, type
    ``color3`` / ``float`` / ``vector3``: the types differ, so MaterialX picks the variant by the
    instance's type) with one output ``out``, implemented by a node graph around the
    multi-output node (so every target's code is the multi-output node's). The basis nodes have
    none (their outputs share types)."""
    if not node.example:
        return []
    return [(f"ND_{node.name}_{mxtype}", f"NG_{node.name}_{mxtype}", name) for name, mxtype, *_ in node.outputs]


def _single_output(node: MxNode) -> list[str]:
    out = []
    types = {o[0]: (o[1], o[4]) for o in node.outputs}
    for nd, ng, output in single_outputs(node):
        mxtype, doc = types[output]
        head = _attrs(name=nd, node=node.name, nodegroup=node.nodegroup, version=mx_version(),
                      isdefaultversion="true", doc=f"the {output} output alone of {node.nodedef} (a single-output "
                      "node, for hosts that mishandle multi-output ones): " + node.doc)
        out.append(f"  <nodedef{head}>")
        for line in _nodedef(node)[1:]:
            if line.startswith("    <input"):
                out.append(line)
        out += [f"    <output{_attrs(name='out', type=mxtype, doc=doc)} />", "  </nodedef>",
                f"  <nodegraph{_attrs(name=ng, nodedef=nd)}>",
                f"    <{node.name} name=\"multi\" type=\"multioutput\">"]
        out += [f"      <input{_attrs(name=i.name, type=i.mxtype, interfacename=i.name)} />" for i in node.inputs]
        out += [f"    </{node.name}>", f"    <output{_attrs(name='out', type=mxtype, nodename='multi', output=output)} />",
                "  </nodegraph>"]
    return out


def library_documents(nodes: list[MxNode]) -> dict[str, str]:
    """The node library of ``nodes``, as MaterialX's own libraries keep theirs: ``{name: text}``
    of ``cellgl_defs.mtlx`` (the nodedefs, and the texture nodes' single-output variants with
    the node graphs that implement them: :func:`single_outputs`) and one implementation document
    per target, ``cellgl_genglsl_impl.mtlx`` and ``cellgl_genosl_impl.mtlx`` (their code in
    ``genglsl/`` and ``genosl/``). A document that reads all three (as the materials'
    ``xi:include`` do) has the whole library."""
    from cellgl._version import __version__

    # no "--" in an XML comment (so not "--target")
    head = f"  <!-- cellgl {__version__} node library, written by cellgl export with the target materialx: "
    defs = [_HEAD.rstrip("\n"), head + "the definitions (their implementations: " + ", ".join(IMPLS.values())
            + "). -->"]
    for n in nodes:
        defs += _nodedef(n) + _single_output(n)
    out = {DEFS: "\n".join(defs) + "\n</materialx>\n"}
    for target, name in IMPLS.items():
        lines = [_HEAD.rstrip("\n"), head + f"the {target} implementations of the nodedefs of {DEFS}, their code in "
                 f"{target}/. -->"] + [_implementation(n, target) for n in nodes]
        out[name] = "\n".join(lines) + "\n</materialx>\n"
    return out


def _ex(node: MxNode) -> str:
    return node.name[len("cellgl_"):]


def materials_document(nodes: list[MxNode], udim: str | None = None) -> str:
    """``cellgl_materials.mtlx``: two example materials per texture node of ``nodes``: the
    procedural ``M_<preset>`` and ``M_<preset>_baked``, which reads the bake's maps (``<UDIM>``
    in their names with ``udim``: :mod:`cellgl.export.materialx_baked`). The document's colour
    space is ``lin_rec709`` (the images' ``srgb_texture`` converts to it)."""
    from cellgl.export.materialx_baked import mtlx_lines

    lines = [_HEAD.rstrip("\n")] + [f'  <xi:include href="{name}" />' for name in LIBRARIES]
    for n in nodes:
        if not n.example:
            continue
        e = _ex(n)
        lines.append(f'  <{n.name} name="{e}_texture" type="multioutput" />')
        lines += [f'  <srgb_texture_to_lin_rec709 name="{e}_linear" type="color3">',
                  f'    <input name="in" type="color3" nodename="{e}_texture" output="color" />',
                  "  </srgb_texture_to_lin_rec709>"]
        normal = "normal" in n.example["outputs"]
        if normal:
            lines += [f'  <normalmap name="{e}_normalmap" type="vector3">',
                      f'    <input name="in" type="vector3" nodename="{e}_texture" output="normal" />',
                      "  </normalmap>"]
        lines += [f'  <open_pbr_surface name="{e}_surface" type="surfaceshader">',
                  f'    <input name="base_color" type="color3" nodename="{e}_linear" />',
                  '    <input name="specular_roughness" type="float" value="0.5" />']
        if normal:
            lines.append(f'    <input name="geometry_normal" type="vector3" nodename="{e}_normalmap" />')
        lines += ["  </open_pbr_surface>",
                  f'  <surfacematerial name="M_{e}" type="material">',
                  f'    <input name="surfaceshader" type="surfaceshader" nodename="{e}_surface" />',
                  "  </surfacematerial>"]
        lines += mtlx_lines(n, udim)
    return "\n".join(lines).replace('<materialx version="1.39">',
                                    '<materialx version="1.39" colorspace="lin_rec709" '
                                    'xmlns:xi="http://www.w3.org/2001/XInclude">') \
        + "\n</materialx>\n"


#: MaterialX type -> USD Sdf value type name (UsdMtlx's mapping)
_USD_TYPES = {"float": "float", "integer": "int", "boolean": "bool", "vector2": "float2", "vector3": "float3",
              "color3": "color3f", "surfaceshader": "token", "material": "token"}


def _usd_val(v, mxtype: str) -> str:
    if isinstance(v, (tuple, list)):
        return "(" + ", ".join(_val(x, "float") for x in v) + ")"
    if mxtype == "boolean":
        return "true" if v else "false"
    return _val(v, mxtype)


def usd_stage(nodes: list[MxNode], udim: str | None = None) -> str:
    """``cellgl_materials.usda``: the example materials as UsdShade networks under
    ``/cellgl/Materials`` (each shader's ``info:id`` a nodedef; typed inputs, connections).
    The stage's ``upAxis`` and ``metersPerUnit`` are USD's own fallbacks (Y, 0.01), authored
    because USD's validators ask for them: the materials hold no lengths, so the stage means
    what it meant without them. Each ``M_<preset>_baked`` is a ``UsdPreviewSurface`` network
    reading the bake's maps (:func:`cellgl.export.materialx_baked.usd_lines`)."""
    from cellgl._version import __version__
    from cellgl.export.materialx_baked import usd_lines

    out = ["#usda 1.0", "(", f'    doc = "cellgl {__version__}: the example materials of cellgl_materials.mtlx '
           'as UsdShade networks (info:id: MaterialX nodedefs; cellgl_defs.mtlx defines the cellgl_* ones)"',
           '    defaultPrim = "cellgl"', "    metersPerUnit = 0.01", '    upAxis = "Y"', ")", "",
           'def Scope "cellgl"', "{", '    def Scope "Materials"', "    {"]
    for n in nodes:
        if not n.example:
            continue
        e = _ex(n)
        path = f"/cellgl/Materials/M_{e}"
        normal = "normal" in n.example["outputs"]
        out += [f'        def Material "M_{e}"', "        {",
                f"            token outputs:mtlx:surface.connect = <{path}/{e}_surface.outputs:out>", "",
                f'            def Shader "{e}_texture"', "            {",
                f'                uniform token info:id = "{n.nodedef}"']
        for i in n.inputs:
            if i.value is None:
                continue
            out.append(f"                {_USD_TYPES[i.mxtype]} inputs:{i.name} = {_usd_val(i.value, i.mxtype)}")
        for name, mxtype, _, _, _ in n.outputs:
            out.append(f"                {_USD_TYPES[mxtype]} outputs:{name}")
        out += ["            }", "", f'            def Shader "{e}_linear"', "            {",
                '                uniform token info:id = "ND_srgb_texture_to_lin_rec709_color3"',
                f"                color3f inputs:in.connect = <{path}/{e}_texture.outputs:color>",
                "                color3f outputs:out", "            }", ""]
        if normal:
            out += [f'            def Shader "{e}_normalmap"', "            {",
                    '                uniform token info:id = "ND_normalmap_float"',
                    f"                float3 inputs:in.connect = <{path}/{e}_texture.outputs:normal>",
                    "                float3 outputs:out", "            }", ""]
        out += [f'            def Shader "{e}_surface"', "            {",
                '                uniform token info:id = "ND_open_pbr_surface_surfaceshader"',
                f"                color3f inputs:base_color.connect = <{path}/{e}_linear.outputs:out>",
                "                float inputs:specular_roughness = 0.5"]
        if normal:
            out.append(f"                float3 inputs:geometry_normal.connect = <{path}/{e}_normalmap.outputs:out>")
        out += ["                token outputs:out", "            }", "        }", ""]
        out += usd_lines(n, udim)
    out += ["    }", "}", ""]
    return "\n".join(out)


# ------------------------------------------------------------------------------ the export


def export_materialx(outdir, recipes=None, *, basis: bool = True, bake_maps=None, udim=None) -> list:
    """Write the MaterialX node library, the example materials and their USD stage to
    ``outdir`` (this module's files).

    Parameters
    ----------
    outdir : str or path
        A directory (created in an existing parent; an existing file is refused).
    recipes : list, optional
        Presets, recipe files or recipes (default: every exportable preset, see
        :func:`exportable_presets`). A PUPs or image-driven recipe, an unknown preset or a name
        that is not a valid MaterialX name is refused with :class:`ExportError`.
    basis : bool
        Include the cellular basis nodes (:mod:`cellgl.export.materialx_basis`).
    bake_maps : int, optional
        Also bake the maps the ``M_<preset>_baked`` materials read, ``bake_maps`` pixels square
        (1..65536; a tile each in a UDIM set), into ``textures/`` of the set
        (:mod:`cellgl.export.materialx_baked`). Without it the materials name the files and
        ``cellgl bake`` writes them.
    udim : str, optional
        A UDIM range as ``cellgl bake --udim`` takes it (``"1001-1004"``): the baked materials
        read ``<UDIM>`` file names, and ``bake_maps`` bakes each tile.

    Returns
    -------
    list of pathlib.Path
        The files written. Every node is compiled and every name checked unique
        (:func:`check_names`) before the first file is written; the set lands whole or not at
        all, replacing the previous set of ``outdir`` (:mod:`cellgl.export.materialx_files`).
    """
    from cellgl.export.materialx import exportable_presets, preset_node
    from cellgl.recipes import load_recipe
    from cellgl.texture.recipe import RecipeError

    from cellgl.export.materialx_baked import bake_maps as bake, check_options

    check_places(check_dir(outdir))     # before the work: a file where genosl/ goes
    size, udim = check_options(bake_maps, udim)
    names = exportable_presets()[0] if recipes is None else list(recipes)
    nodes = []
    for rec in names:
        try:
            r = load_recipe(rec)
        except (RecipeError, OSError) as exc:
            raise ExportError(str(exc)) from None
        nodes.append(preset_node(r))
    if basis:
        from cellgl.export.materialx_basis import basis_nodes

        nodes = basis_nodes() + nodes
    if not nodes:
        raise ExportError("nothing to export: no recipe given and basis=False")
    files: dict[str, str | Path] = dict(set_files(nodes, udim))      # the names checked before the bake
    if size is None:
        return write_set(files, outdir)
    import tempfile

    with tempfile.TemporaryDirectory(prefix="cellgl-maps-") as tmp:
        files.update(bake(nodes, size, udim, tmp))
        return write_set(files, outdir)


def set_files(nodes: list[MxNode], udim: str | None = None) -> dict[str, str]:
    """``{relative path: text}``: every file of the export of ``nodes`` but the baked maps,
    their names checked (:func:`check_names`)."""
    check_names(nodes)
    files = {**library_documents(nodes), MATERIALS: materials_document(nodes, udim),
             USD: usd_stage(nodes, udim)}
    for n in nodes:
        files.update(code_files(n))
    return files


def code_files(node: MxNode) -> dict[str, str]:
    """The implementations' source files of ``node``, by their path in the set."""
    return {f"genglsl/{node.name}.glsl": node.glsl, f"genosl/{node.name}.osl": node.osl}


#: the prefixes of the names in MaterialX's standard library (1.39: nodedefs, nodegraphs,
#: implementations, unit definitions; tests/test_materialx_files.py checks the list is whole)
MX_LIBRARY_PREFIXES = ("ND", "NG", "IM", "IMP", "IMPL", "UD")
#: a top-level name of a node's code: every one carries the node's name (materialx.renamed)
_CODE_NAME = re.compile(r"\b(?:cellgl|Cellgl)\w+")


def _written_names(node: MxNode):
    """``(kind, key, name)`` of every name the export writes for ``node``: the elements of both
    documents (one namespace: the materials include the library), its code files (compared
    without case: macOS and Windows file systems ignore it) and its code's top-level names
    (any number of nodes share one shader)."""
    from xml.etree import ElementTree

    for doc in (*library_documents([node]).values(), materials_document([node])):
        for el in ElementTree.fromstring(doc):
            if el.get("name"):
                yield "MaterialX element", el.get("name"), el.get("name")
    from cellgl.export.materialx_baked import maps

    for rel in [*code_files(node), *(maps(node).values() if node.example else ())]:
        yield "file", rel.lower(), rel
    for code in (node.glsl, node.osl):
        for name in set(_CODE_NAME.findall(re.sub(r"//[^\n]*", "", code))):
            yield "shader code name", name, name


def check_names(nodes: list[MxNode]) -> None:
    """Refuse (:class:`ExportError`) an export in which two nodes would write the same name:
    a recipe named as a basis node (``cellular2d-euclidean-poisson``), two recipes whose names
    differ only by ``-`` / ``_`` or by case, a recipe whose material's names are another's
    (``M`` and ``texture``: both give ``M_texture``) or whose code's names are another's
    (``stone`` and ``stone-abs``: ``cellgl_stone_abs_vec3``), and a recipe whose materials'
    names could be those of MaterialX's standard library (``ND-lama``: ``ND_lama_surface``)."""
    seen: dict[tuple[str, str], tuple[int, str]] = {}
    for k, n in enumerate(nodes):
        who = f"recipe {n.example['recipe']!r}" if n.example else f"the basis node {n.name!r}"
        head = _ex(n).split("_")[0]
        if n.example and head in MX_LIBRARY_PREFIXES:
            raise ExportError(f"{who}: its materials' names would start with {head + '_'!r}, as the names of "
                              "MaterialX's standard library do (" + ", ".join(p + "_" for p in MX_LIBRARY_PREFIXES)
                              + f"), and could be one of them ({_ex(n)}_surface); rename the recipe")
        for kind, key, name in _written_names(n):
            j, other = seen.setdefault((kind, key), (k, who))
            if j != k:
                raise ExportError(f"{other} and {who} would both write the {kind} {name!r} (every name of the "
                                  "export must be unique); rename the recipe (its \"name\" field, or export it "
                                  "alone)")
