"""``cellgl export --target materialx``, checked with the tools themselves: MaterialX's own
``validate()``, its GLSL and OSL shader generators (GenGlsl, GenOsl), its GLSL renderer
(RenderGlsl, under Xvfb: the node's colour against ``cellgl bake``), Blender's OSL compiler and
Cycles (GenOsl's shader against the bake), usd-core (the stage's materials, shader ids and typed
inputs), and the bad inputs' errors.

The default tier exports one preset (and one basis node); the slow tier every preset and every
basis node. Without MaterialX (or usd-core, or bpy) the tests that need it skip.
"""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from cellgl.export.materialx import exportable_presets, node_name, preset_node
from cellgl.export.materialx_docs import export_materialx

ROOT = Path(__file__).resolve().parents[1]
SIZE = 64
#: the presets the Cycles test renders (one per family: cell colours, a fractal, Qin's noise, a bump)
CYCLES_SET = ("flagstone", "f1", "qin-marble", "hammered")


def _mx():
    return pytest.importorskip("MaterialX")


def _stdlib():
    mx = _mx()
    lib = mx.createDocument()
    mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), lib)
    return lib


def _read(path):
    """The document at ``path`` (its xi:includes resolved) with the standard libraries imported."""
    mx = _mx()
    doc = mx.createDocument()
    mx.readFromXmlFile(doc, str(path))
    doc.importLibrary(_stdlib())
    return doc


def _context(gen, out):
    from MaterialX import PyMaterialXGenShader as mxg
    import MaterialX as mx

    ctx = mxg.GenContext(gen)
    ctx.registerSourceCodeSearchPath(mx.getDefaultDataSearchPath())
    ctx.registerSourceCodeSearchPath(mx.FilePath(str(out)))
    return ctx


def _output_graph(doc, nodedef, output, mxtype, values=()):
    """A node graph with one instance of ``nodedef`` and an output of its ``output`` (GenGlsl
    renders a graph's output)."""
    name = f"NG_{nodedef}_{output}"
    ng = doc.getNodeGraph(name) or doc.addNodeGraph(name)
    node = ng.getNode("n") or ng.addNodeInstance(doc.getNodeDef(nodedef), "n")
    for k, v in values:
        node.setInputValue(k, v)
    o = ng.getOutput("out") or ng.addOutput("out", mxtype)
    o.setNodeName("n")
    o.setOutputString(output)
    return o


@pytest.fixture(scope="module")
def one(tmp_path_factory):
    """The library of one preset (flagstone: colour, height, normal) and no basis nodes, with
    the maps of its baked material (SIZE x SIZE)."""
    _mx()
    out = tmp_path_factory.mktemp("mx-one")
    export_materialx(out, ["flagstone"], basis=False, bake_maps=SIZE)
    return out


@pytest.fixture(scope="module")
def full(tmp_path_factory):
    """``cellgl export --target materialx -o DIR``: every exportable preset and the basis."""
    _mx()
    out = tmp_path_factory.mktemp("mx-full") / "lib"
    from cellgl.cli import main

    assert main(["export", "--target", "materialx", "-o", str(out)]) == 0
    return out


def _check_documents(out):
    for name in ("cellgl_defs.mtlx", "cellgl_materials.mtlx"):
        doc = _read(out / name)
        ok, msg = doc.validate()
        assert ok, (name, msg)
    # definitions apart from implementations, one implementation document per target
    from xml.etree import ElementTree

    assert {e.tag for e in ElementTree.parse(out / "cellgl_defs.mtlx").getroot()} <= {"nodedef", "nodegraph"}
    for target in ("genglsl", "genosl"):
        impls = list(ElementTree.parse(out / f"cellgl_{target}_impl.mtlx").getroot())
        assert impls and {(e.tag, e.get("target")) for e in impls} == {("implementation", target)}
    return _read(out / "cellgl_materials.mtlx")


def _read_library(folder):
    """The node library of ``folder`` (its definitions and both implementation documents) in
    one document, with the standard libraries imported."""
    mx = _mx()
    doc = mx.createDocument()
    for name in ("cellgl_defs.mtlx", "cellgl_genglsl_impl.mtlx", "cellgl_genosl_impl.mtlx"):
        mx.readFromXmlFile(doc, str(Path(folder) / name))
    doc.importLibrary(_stdlib())
    return doc


def _check_library_matches_nodes(doc, nodes):
    from cellgl._version import __version__

    for n in nodes:
        nd = doc.getNodeDef(n.nodedef)
        assert nd is not None, n.nodedef
        # versioned with cellgl's version, major.minor as MaterialX reads versions; the default
        assert nd.getVersionString() == ".".join(__version__.split(".")[:2]) and nd.getDefaultVersion()
        assert nd.getVersionIntegers() == tuple(int(x) for x in __version__.split(".")[:2])
        assert [i.getName() for i in nd.getInputs()] == [i.name for i in n.inputs]
        assert [o.getName() for o in nd.getOutputs()] == [o[0] for o in n.outputs]
        for target in ("genglsl", "genosl"):
            assert doc.getImplementation(f"IM_{n.name}_{target}") is not None


def _generate_all(doc, out, lang):
    from MaterialX import PyMaterialXGenShader as mxg

    if lang == "glsl":
        from MaterialX import PyMaterialXGenGlsl as g
        gen = g.GlslShaderGenerator.create()
    else:
        from MaterialX import PyMaterialXGenOsl as g
        gen = g.OslShaderGenerator.create()
    ctx = _context(gen, out)
    mats = [m for m in doc.getMaterialNodes()]
    assert mats
    procedural = 0
    for m in mats:
        shader = gen.generate(m.getName(), m, ctx)
        src = shader.getSourceCode(mxg.PIXEL_STAGE)
        if m.getName().endswith("_baked"):      # image nodes reading the maps, no cellgl code
            node = m.getName()[2:-len("_baked")]
            assert doc.getNode(m.getName()[:-len("_baked")]) is not None and "cellglmx_" not in src
            assert f"{node}_baked_color_file" in src, m.getName()
            continue
        node = m.getName()[2:]
        assert f"cellglmx_{node}(" in src, m.getName()     # the node's function is called
        procedural += 1
    assert len(mats) == 2 * procedural                      # M_<preset> and M_<preset>_baked
    return procedural


def test_one_preset_validates_and_generates_glsl_and_osl(one):
    doc = _check_documents(one)
    n = preset_node("flagstone")
    _check_library_matches_nodes(doc, [n])
    assert _generate_all(doc, one, "glsl") == 1
    assert _generate_all(doc, one, "osl") == 1
    nd = doc.getNodeDef("ND_cellgl_flagstone")
    # inputs from the parameter table: default, range, folder, doc; inactive ones marked
    shade = nd.getInput("shade")
    assert shade.getValueString() == "0.85" and shade.getAttribute("uimin") == "0.0"
    assert shade.getAttribute("uimax") == "1.0" and shade.getAttribute("uifolder") == "color"
    assert "colour *=" in shade.getAttribute("doc")
    jitter = nd.getInput("jitter")
    assert jitter.getAttribute("uiadvanced") == "true"
    assert "needs distribution jitter or blender" in jitter.getAttribute("doc")
    assert nd.getInput("invert").getType() == "boolean" and nd.getInput("noise_octaves").getType() == "integer"
    assert [o.getType() for o in nd.getOutputs()] == ["color3", "float", "vector3"]
    assert "density=3.0" in nd.getAttribute("doc")           # fixed at export, listed
    # the implementations are files next to the library
    assert (one / "genglsl" / "cellgl_flagstone.glsl").read_text().count("void cellglmx_flagstone(") == 1
    assert (one / "genosl" / "cellgl_flagstone.osl").read_text().count("void cellglmx_flagstone(") == 1


def test_single_output_variants_beside_the_multi_output_node(one):
    """Issue 46 item 5: hosts that mishandle multi-output nodes (Hydra, several DCCs) get one
    nodedef per output, ND_cellgl_<preset>_<type> of the same node, picked by the instance's
    type, with the multi-output node's inputs and defaults and one output `out` (a node graph
    around the multi-output node implements it, so GenGlsl and GenOsl call the node's code)."""
    from MaterialX import PyMaterialXGenShader as mxg
    from MaterialX import PyMaterialXGenGlsl as gg, PyMaterialXGenOsl as go

    doc = _read_library(one)
    assert doc.validate()[0]
    multi = doc.getNodeDef("ND_cellgl_flagstone")
    for mxtype, output in (("color3", "color"), ("float", "height"), ("vector3", "normal")):
        nd = doc.getNodeDef(f"ND_cellgl_flagstone_{mxtype}")
        assert nd is not None and nd.getNodeString() == "cellgl_flagstone" and nd.getDefaultVersion()
        assert [(o.getName(), o.getType()) for o in nd.getOutputs()] == [("out", mxtype)]
        assert [(i.getName(), i.getType(), i.getValueString()) for i in nd.getInputs()] == \
            [(i.getName(), i.getType(), i.getValueString()) for i in multi.getInputs()]
        ng = doc.getNodeGraph(f"NG_cellgl_flagstone_{mxtype}")
        assert ng.getNodeDef().getName() == nd.getName()
        assert ng.getOutput("out").getOutputString() == output
        node = doc.addNode("cellgl_flagstone", f"single_{mxtype}", mxtype)
        assert node.getNodeDef().getName() == nd.getName()          # chosen by the type
    for gen in (gg.GlslShaderGenerator.create(), go.OslShaderGenerator.create()):
        o = doc.addOutput(f"o_{gen.getTarget()}", "color3")
        o.setNodeName("single_color3")
        src = gen.generate("single", o, _context(gen, one)).getSourceCode(mxg.PIXEL_STAGE)
        assert "cellglmx_flagstone(" in src


def test_basis_node_validates_and_generates(tmp_path):
    from cellgl.export import materialx_docs as docs
    from cellgl.export.materialx_basis import basis_node

    nodes = [basis_node(2, "euclidean", "poisson")]
    docs.write_set({**docs.library_documents(nodes), **docs.code_files(nodes[0])}, tmp_path)
    doc = _read_library(tmp_path)
    assert doc.validate()[0]
    _check_library_matches_nodes(doc, nodes)
    for lang in ("glsl", "osl"):
        from MaterialX import PyMaterialXGenShader as mxg
        if lang == "glsl":
            from MaterialX import PyMaterialXGenGlsl as g
            gen = g.GlslShaderGenerator.create()
        else:
            from MaterialX import PyMaterialXGenOsl as g
            gen = g.OslShaderGenerator.create()
        o = _output_graph(doc, "ND_cellgl_cellular2d_euclidean_poisson", "edge", "float")
        src = gen.generate("edge", o, _context(gen, tmp_path)).getSourceCode(mxg.PIXEL_STAGE)
        assert "cellglmx_cellular2d_euclidean_poisson(" in src


#: a GLSL array constructor (``float[8](...)``): no syntax in Metal or Slang, into which GenMsl
#: and GenSlang pass a genglsl implementation's code
_ARRAY_CONSTRUCTOR = r"\b\w+\[\w*\]\s*\("


def test_genmsl_and_genslang_get_no_array_constructors(one, tmp_path):
    """Issue 46 item 5: the genglsl code had `float[16](...)`, which GenMsl and GenSlang copy
    into Metal and Slang shaders. Generated here (nothing compiles Metal or Slang here)."""
    import re

    from MaterialX import PyMaterialXGenShader as mxg
    g = {}
    for mod, cls in (("PyMaterialXGenMsl", "MslShaderGenerator"), ("PyMaterialXGenSlang", "SlangShaderGenerator")):
        g[mod] = getattr(pytest.importorskip(f"MaterialX.{mod}"), cls).create()
    doc = _read(one / "cellgl_materials.mtlx")
    from cellgl.export import materialx_docs as docs
    from cellgl.export.materialx_basis import basis_node

    nodes = [basis_node(2, "euclidean", "poisson")]
    docs.write_set({**docs.library_documents(nodes), **docs.code_files(nodes[0])}, tmp_path)
    basis = _read_library(tmp_path)
    for gen in g.values():
        m = doc.getMaterialNodes()[0]
        src = gen.generate(m.getName(), m, _context(gen, one)).getSourceCode(mxg.PIXEL_STAGE)
        assert "cellglmx_flagstone(" in src and "cellgl_flagstone_init_arrays();" in src
        assert not re.findall(_ARRAY_CONSTRUCTOR, src)
        o = _output_graph(basis, "ND_cellgl_cellular2d_euclidean_poisson", "f1", "float")
        src = gen.generate("f1", o, _context(gen, tmp_path)).getSourceCode(mxg.PIXEL_STAGE)
        assert "cellglmx_cellular2d_euclidean_poisson(" in src and not re.findall(_ARRAY_CONSTRUCTOR, src)


def test_array_constructors_become_element_by_element_values():
    from cellgl.export.materialx import without_array_constructors

    code = """const vec4 k_ramp[2] = vec4[2](vec4(0.5, 1.0, f(1, 2), 0.0), vec4(1.0));
float g(float x)
{
    if (x > 0.0) {
        float lin[3] = float[3](x,
            2.0 * x, min(x, 1.0));   // a comment, {
        return lin[2] + k_ramp[1].x;
    }
    return 0.0;
}
"""
    text, call = without_array_constructors(code, "k_init")
    assert call == "    k_init();"
    assert text.startswith("vec4 k_ramp[2];     // set by k_init()\n")
    assert "        float lin[3];\n        lin[0] = x;\n        lin[1] = 2.0 * x;\n        lin[2] = min(x, 1.0);   // a" in text
    assert text.endswith("void k_init()\n{\n    k_ramp[0] = vec4(0.5, 1.0, f(1, 2), 0.0);\n    k_ramp[1] = vec4(1.0);\n}\n")
    assert without_array_constructors("float a = 1.0;\n", "k_init") == ("float a = 1.0;\n", "")
    # what it does not know stays (a constructor of another size, one in a comment); the braces
    # before a later declaration still count
    odd = "void f()\n{\n    float b[2] = float[3](1.0, 2.0, 3.0);\n}\n// int c[1] = int[1](0);\nconst int d[1] = int[1](7);\n"
    text, call = without_array_constructors(odd, "k_init")
    assert "float b[2] = float[3](1.0, 2.0, 3.0);" in text and "// int c[1] = int[1](0);" in text
    assert "int d[1];     // set by k_init()" in text and "    d[0] = 7;" in text and call


def test_usd_stage_has_every_material_shader_and_typed_input(one):
    Usd = pytest.importorskip("pxr.Usd")

    stage = Usd.Stage.Open(str(one / "cellgl_materials.usda"))
    assert stage is not None
    _check_stage(stage, [preset_node("flagstone")])
    _validate_stage(stage)


def _validate_stage(stage, maps_missing=False):
    """usd-core's own validators (pxr.UsdValidation: every one registered, 30 in usd-core 26.11)
    find nothing, but that a shader's id is no node of usd-core's shader registry (Sdr) where
    it is a MaterialX nodedef: usd-core's wheel has no UsdMtlx plugin, so its registry knows
    none of them (_check_stage checks each is a nodedef of MaterialX's libraries or of
    cellgl_defs.mtlx). The stage's upAxis and metersPerUnit are USD's fallbacks, authored.
    ``maps_missing``: an export without --bake-maps, whose baked materials name maps nobody has
    baked yet: usd-core reports each (UnresolvableDependency, and InvalidFile for a normal map,
    whose file NormalMapTextureValidator opens), and those only are allowed. A <UDIM> normal
    map is InvalidFile too: that validator does not expand the token (it opens the name)."""
    V = pytest.importorskip("pxr.UsdValidation")
    from pxr import UsdGeom, UsdShade

    assert stage.HasAuthoredMetadata("upAxis") and stage.HasAuthoredMetadata("metersPerUnit")
    assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.y and UsdGeom.GetStageMetersPerUnit(stage) == 0.01
    validators = V.ValidationRegistry().GetOrLoadAllValidators()
    assert len(validators) >= 20
    lib = _stdlib()
    errors = []
    for e in V.ValidationContext(validators).Validate(stage):
        if e.GetName() == "MissingShaderIdInRegistry":
            prim = e.GetSites()[0].GetProperty().GetPrim()
            sid = UsdShade.Shader(prim).GetIdAttr().Get()
            if sid.startswith("ND_cellgl_") or lib.getNodeDef(sid) is not None:
                continue
        msg = e.GetMessage()
        if e.GetName() == "InvalidFile" and "_normal.<UDIM>.png@" in msg:
            continue
        if maps_missing and e.GetName() in ("UnresolvableDependency", "InvalidFile") and "/textures/cellgl_" in msg:
            continue
        errors.append((e.GetName(), e.GetMessage()))
    assert not errors, errors


def _check_stage(stage, nodes):
    from pxr import Sdf, UsdShade

    lib = _stdlib()
    want = {"float": Sdf.ValueTypeNames.Float, "integer": Sdf.ValueTypeNames.Int,
            "boolean": Sdf.ValueTypeNames.Bool, "vector2": Sdf.ValueTypeNames.Float2}
    for n in nodes:
        e = n.name[len("cellgl_"):]
        mat = UsdShade.Material(stage.GetPrimAtPath(f"/cellgl/Materials/M_{e}"))
        assert mat, e
        surf = mat.GetSurfaceOutput("mtlx")
        src = surf.GetConnectedSources()[0][0]
        shader = UsdShade.Shader(src.source.GetPrim())
        assert shader.GetIdAttr().Get() == "ND_open_pbr_surface_surfaceshader"
        tex = UsdShade.Shader(stage.GetPrimAtPath(f"/cellgl/Materials/M_{e}/{e}_texture"))
        assert tex.GetIdAttr().Get() == n.nodedef
        for i in n.inputs:
            if i.value is None:
                continue
            inp = tex.GetInput(i.name)
            assert inp, (e, i.name)
            assert inp.GetTypeName() == want[i.mxtype], (e, i.name)
            got = inp.Get()
            assert np.allclose(np.asarray(got, float), np.asarray(i.value, float)), (e, i.name, got, i.value)
        # every other shader's id is a nodedef of MaterialX's libraries
        for prim in mat.GetPrim().GetChildren():
            sid = UsdShade.Shader(prim).GetIdAttr().Get()
            assert sid == n.nodedef or lib.getNodeDef(sid) is not None, sid
        base = UsdShade.Shader(stage.GetPrimAtPath(f"/cellgl/Materials/M_{e}/{e}_surface")).GetInput("base_color")
        assert base.GetConnectedSources()[0][0].source.GetPath().name == f"{e}_linear"


# ------------------------------------------------------------------------------ baked materials


def _png(path):
    from PIL import Image

    return np.asarray(Image.open(path).convert("RGB"), np.int16)


def _color_managed(gen):
    from MaterialX import PyMaterialXGenShader as mxg

    cms = mxg.DefaultColorManagementSystem.create(gen.getTarget())
    cms.loadLibrary(_stdlib())
    gen.setColorManagementSystem(cms)
    return gen


def test_baked_material_reads_the_bakes_maps_with_their_colour_spaces(one, tmp_path):
    """Issue 46 item 5: M_<preset>_baked beside M_<preset>, for renderers that do not run a node
    library's code: MaterialX image nodes and a UsdPreviewSurface network reading the maps the
    export baked (--bake-maps: the colour sRGB-encoded and tagged so, the normal map raw)."""
    from MaterialX import PyMaterialXGenShader as mxg
    from MaterialX import PyMaterialXGenGlsl as gg, PyMaterialXGenOsl as go

    doc = _read(one / "cellgl_materials.mtlx")
    assert doc.validate()[0] and doc.getColorSpace() == "lin_rec709"
    color = doc.getNode("flagstone_baked_color").getInput("file")
    normal = doc.getNode("flagstone_baked_normal").getInput("file")
    assert color.getValueString() == "textures/cellgl_flagstone_color.png" and color.getColorSpace() == "srgb_texture"
    assert normal.getValueString() == "textures/cellgl_flagstone_normal.png" and normal.getColorSpace() == ""
    # the maps are the bake's, at the size asked for
    from cellgl.bake.core import bake

    assert np.array_equal(_png(one / "textures" / "cellgl_flagstone_color.png"), _bake("flagstone", tmp_path))
    bake("flagstone", str(tmp_path / "n.png"), size=SIZE, channels=("normal",), progress=False)
    assert np.array_equal(_png(one / "textures" / "cellgl_flagstone_normal.png"), _png(tmp_path / "n.png"))
    # with colour management the generators convert the colour from sRGB, not the normal map
    for gen in (gg.GlslShaderGenerator.create(), go.OslShaderGenerator.create()):
        m = doc.getNode("M_flagstone_baked")
        src = _color_managed(gen).generate("baked", m, _context(gen, one)).getSourceCode(mxg.PIXEL_STAGE)
        assert "NG_srgb_texture_to_lin_rec709_color3(flagstone_baked_color_out" in src
        assert "flagstone_baked_normal_out_cm" not in src and "cellglmx_" not in src
    Usd = pytest.importorskip("pxr.Usd")
    from pxr import UsdShade

    stage = Usd.Stage.Open(str(one / "cellgl_materials.usda"))
    mat = UsdShade.Material(stage.GetPrimAtPath("/cellgl/Materials/M_flagstone_baked"))
    surf = mat.GetSurfaceOutput().GetConnectedSources()[0][0].source
    assert UsdShade.Shader(surf.GetPrim()).GetIdAttr().Get() == "UsdPreviewSurface"
    for c, space in (("color", "sRGB"), ("normal", "raw")):
        tex = UsdShade.Shader(stage.GetPrimAtPath(f"/cellgl/Materials/M_flagstone_baked/flagstone_{c}"))
        assert tex.GetIdAttr().Get() == "UsdUVTexture" and tex.GetInput("sourceColorSpace").Get() == space
        assert Path(tex.GetInput("file").Get().resolvedPath) == one / "textures" / f"cellgl_flagstone_{c}.png"
    _validate_stage(stage)          # the maps exist: nothing to report


def test_baked_material_of_a_udim_set(tmp_path):
    """--udim: the baked materials read <UDIM> names; --bake-maps bakes one map per tile, as
    `cellgl bake --udim` does (tile 1001 is the plain bake)."""
    out = tmp_path / "mx"
    export_materialx(out, ["flagstone"], basis=False, bake_maps=16, udim="1001-1002,1011")
    tiles = sorted(p.name for p in (out / "textures").iterdir())
    assert tiles == [f"cellgl_flagstone_{c}.{k}.png" for c in ("color", "normal") for k in (1001, 1002, 1011)]
    from xml.etree import ElementTree

    ElementTree.parse(out / "cellgl_materials.mtlx")            # well-formed: the token's < escaped
    doc = _read(out / "cellgl_materials.mtlx")
    assert doc.validate()[0]
    assert doc.getNode("flagstone_baked_color").getInputValue("file") == "textures/cellgl_flagstone_color.<UDIM>.png"
    assert np.array_equal(_png(out / "textures" / "cellgl_flagstone_color.1001.png"), _bake("flagstone", tmp_path, 16))
    assert not np.array_equal(_png(out / "textures" / "cellgl_flagstone_color.1002.png"),
                              _png(out / "textures" / "cellgl_flagstone_color.1001.png"))
    Usd = pytest.importorskip("pxr.Usd")
    stage = Usd.Stage.Open(str(out / "cellgl_materials.usda"))
    from pxr import UsdShade

    tex = UsdShade.Shader(stage.GetPrimAtPath("/cellgl/Materials/M_flagstone_baked/flagstone_color"))
    assert tex.GetInput("file").Get().path == "./textures/cellgl_flagstone_color.<UDIM>.png"
    _validate_stage(stage)


def test_blender_imports_the_baked_material_and_not_the_procedural_one(one):
    """Blender's USD importer (bpy 4.5) makes M_<preset>_baked a Principled BSDF reading the
    colour map as sRGB and the normal map as Non-Color through a Normal Map node; the
    procedural M_<preset> (a MaterialX network of cellgl nodes) it does not import at all."""
    _need_bpy()
    code = ("import bpy, json\n"
            f"bpy.ops.wm.usd_import(filepath={str(one / 'cellgl_materials.usda')!r}, import_all_materials=True)\n"
            "out = {}\n"
            "for m in bpy.data.materials:\n"
            "    if m.use_nodes:\n"
            "        out[m.name] = {'images': {n.image.filepath: n.image.colorspace_settings.name for n in m.node_tree.nodes"
            " if n.type == 'TEX_IMAGE' and n.image}, 'links': sorted(f'{l.from_node.type}>{l.to_node.type}:{l.to_socket.name}'"
            " for l in m.node_tree.links)}\n"
            "print('RESULT' + json.dumps(out))\n")
    proc = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=600)
    line = [ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT")]
    assert proc.returncode == 0 and line, (proc.stdout[-2000:], proc.stderr[-2000:])
    mats = json.loads(line[0][len("RESULT"):])
    assert "M_flagstone" not in mats
    baked = mats["M_flagstone_baked"]
    assert baked["images"] == {str(one / "textures" / "cellgl_flagstone_color.png"): "sRGB",
                               str(one / "textures" / "cellgl_flagstone_normal.png"): "Non-Color"}
    assert {"TEX_IMAGE>BSDF_PRINCIPLED:Base Color", "TEX_IMAGE>NORMAL_MAP:Color",
            "NORMAL_MAP>BSDF_PRINCIPLED:Normal"} <= set(baked["links"])


# ------------------------------------------------------------------------------ bad input


def _cli(args, capsys):
    from cellgl.cli import main

    rc = main(["export", "--target", "materialx", *args])
    return rc, capsys.readouterr().err


def test_bad_input_gets_one_clear_error(tmp_path, capsys):
    rc, err = _cli(["no-such-preset", "-o", str(tmp_path / "a")], capsys)
    assert rc == 2 and "unknown preset 'no-such-preset'" in err and "flagstone" in err
    assert not (tmp_path / "a").exists()
    f = tmp_path / "file.txt"
    f.write_text("keep")
    rc, err = _cli(["flagstone", "-o", str(f)], capsys)
    assert rc == 2 and "is a file" in err and "give a directory" in err
    assert f.read_text() == "keep"
    rc, err = _cli(["flagstone"], capsys)
    assert rc == 2 and "-o DIR" in err
    rc, err = _cli(["flagstone", "-o", str(tmp_path / "missing" / "dir")], capsys)
    assert rc == 2 and "does not exist" in err
    rc, err = _cli(["pups-cow", "-o", str(tmp_path / "b")], capsys)
    assert rc == 2 and "PUPs recipes cannot be exported" in err and not (tmp_path / "b").exists()
    rc, err = _cli(["stained-glass", "-o", str(tmp_path / "b")], capsys)
    assert rc == 2 and "cell_color 'image'" in err and not (tmp_path / "b").exists()
    # a recipe whose name is not a valid MaterialX name
    from cellgl.recipes import load_recipe

    d = load_recipe("f1").to_dict()
    for bad in ("my stone!", "1st", "a__b", "été"):
        d["name"] = bad
        path = tmp_path / "bad.json"
        path.write_text(json.dumps(d))
        rc, err = _cli([str(path), "-o", str(tmp_path / "c")], capsys)
        assert rc == 2 and f"recipe name {bad!r} is not a valid MaterialX name" in err, err
        assert "accepted" in err and not (tmp_path / "c").exists()
    d["name"] = "my-stone_2"
    path.write_text(json.dumps(d))
    assert node_name("my-stone_2") == "cellgl_my_stone_2"


def test_exportable_presets_leave_out_pups_and_images_only():
    from cellgl.recipes import load_recipe

    ok, refused = exportable_presets()
    assert len(ok) >= 25 and "flagstone" in ok
    for name, why in refused.items():
        r = load_recipe(name)
        assert getattr(r, "kind", None) == "pups" or "image" in why, (name, why)


def test_float32_poisson_table_is_close_to_the_float64_one():
    """The basis nodes compute the Poisson table of their density input in float32: a cell's
    count differs from cellgl's only if its 32-bit hash falls between the two tables' entries."""
    from cellgl.basis.population import poisson_thresholds
    from cellgl.export.materialx_basis import float32_thresholds

    worst = 0
    for d in np.linspace(0.05, 16.0, 320):
        a = poisson_thresholds(float(d)).astype(np.int64)
        b = float32_thresholds(float(d)).astype(np.int64)
        worst = max(worst, int(np.abs(a - b).sum()))
    # the chance that one cell's count differs: worst / 2^32
    assert worst / 2.0 ** 32 < 1e-5, worst


# ------------------------------------------------------------------------------ the slow tier


@pytest.mark.slow
def test_every_preset_and_basis_node_validates_and_generates(full):
    from cellgl.export.materialx_basis import basis_nodes

    doc = _check_documents(full)
    names, _ = exportable_presets()
    nodes = [preset_node(n) for n in names]
    _check_library_matches_nodes(doc, nodes + basis_nodes())
    assert _generate_all(doc, full, "glsl") == len(names)
    assert _generate_all(doc, full, "osl") == len(names)


@pytest.mark.slow
def test_usd_stage_of_every_preset(full):
    Usd = pytest.importorskip("pxr.Usd")
    stage = Usd.Stage.Open(str(full / "cellgl_materials.usda"))
    names, _ = exportable_presets()
    _check_stage(stage, [preset_node(n) for n in names])
    _validate_stage(stage, maps_missing=True)


def _render_script(out, names, size, kind="preset"):
    """Python code that renders the colour output of each node with RenderGlsl (texture space:
    a flat quad over [0, 1]^2) and saves it as .npy."""
    return f"""
import ctypes, numpy as np, MaterialX as mx
from MaterialX import PyMaterialXGenGlsl as g, PyMaterialXGenShader as mxg
from MaterialX import PyMaterialXRender as mxr, PyMaterialXRenderGlsl as rg
sys_out = {str(out)!r}
lib = mx.createDocument()
mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), lib)
doc = mx.createDocument()
for name in ("cellgl_defs.mtlx", "cellgl_genglsl_impl.mtlx", "cellgl_genosl_impl.mtlx"):
    mx.readFromXmlFile(doc, sys_out + "/" + name)
doc.importLibrary(lib)
gen = g.GlslShaderGenerator.create()
ctx = mxg.GenContext(gen)
ctx.registerSourceCodeSearchPath(mx.getDefaultDataSearchPath())
ctx.registerSourceCodeSearchPath(mx.FilePath(sys_out))
r = rg.GlslRenderer.create({size}, {size}, mxr.BaseType.FLOAT)
r.initialize()
r.setImageHandler(rg.GLTextureHandler.create(mxr.StbImageLoader.create()))
for nd, output, typ, vals in {names!r}:
    ng = doc.addNodeGraph(mx.createValidName("NG_" + nd + "_" + output))
    n = ng.addNodeInstance(doc.getNodeDef(nd), "n")
    for k, v in vals:
        if k == "position_scale":           # position = texcoord * v (cells across the quad)
            tc = ng.addNode("texcoord", "tc", "vector2")
            mul = ng.addNode("multiply", "mul", "vector2")
            mul.setConnectedNode("in1", tc)
            mul.setInputValue("in2", float(v))
            n.setConnectedNode("position", mul)
        elif k == "position_scale3":        # position = (texcoord * v[0], v[1])
            tc = ng.addNode("texcoord", "tc", "vector2")
            mul = ng.addNode("multiply", "mul", "vector2")
            mul.setConnectedNode("in1", tc)
            mul.setInputValue("in2", float(v[0]))
            sep = ng.addNode("separate2", "sep", "multioutput")
            sep.setConnectedNode("in", mul)
            pos = ng.addNode("combine3", "pos", "vector3")
            for i, o in (("in1", "outx"), ("in2", "outy")):
                pos.addInput(i, "float").setConnectedNode(sep)
                pos.getInput(i).setOutputString(o)
            pos.setInputValue("in3", float(v[1]))
            n.setConnectedNode("position", pos)
        else:
            n.setInputValue(k, mx.Vector2(*v) if isinstance(v, tuple) else v)
    o = ng.addOutput("out", typ)
    o.setNodeName("n")
    o.setOutputString(output)
    shader = gen.generate(ng.getName(), o, ctx)
    r.createProgram(shader)
    r.validateInputs()
    r.renderTextureSpace(mx.Vector2(0, 0), mx.Vector2(1, 1))
    img = r.captureImage(None)
    buf = (ctypes.c_float * (img.getHeight() * img.getWidth() * img.getChannelCount())).from_address(
        img.getResourceBuffer())
    a = np.ctypeslib.as_array(buf).reshape(img.getHeight(), img.getWidth(), img.getChannelCount()).copy()
    np.save(sys_out + "/" + ng.getName() + ".npy", a[::-1])     # row 0 at the top, as the bake
print("rendered")
"""


def _run_under_xvfb(code):
    from tests.xvfb import some_display

    with some_display() as disp:
        env = dict(__import__("os").environ, DISPLAY=disp)
        return subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                              timeout=1800, env=env)


def _render_glsl(out, jobs, size=SIZE):
    proc = _run_under_xvfb(_render_script(out, jobs, size))
    assert proc.returncode == 0 and "rendered" in proc.stdout, proc.stderr[-4000:]
    import MaterialX as mx

    return {(nd, o): np.load(out / (mx.createValidName(f"NG_{nd}_{o}") + ".npy")) for nd, o, _, _ in jobs}


def _bake(name, tmp_path, size=SIZE):
    from PIL import Image

    from cellgl.bake.core import bake

    png = tmp_path / f"{name}.png"
    bake(name, str(png), size=size)
    return np.asarray(Image.open(png).convert("RGB"), np.int16)


def _diff255(got, want):
    return int(np.abs(np.round(np.clip(got[..., :3], 0, 1) * 255).astype(np.int16) - want).max())


def test_renderglsl_renders_the_bake(one, tmp_path):
    """RenderGlsl renders the node's colour (a flat quad, the texture space) as `cellgl bake`
    writes it: within 2/255 per channel (footprint 1/64: the bake's band limit at 64 x 64)."""
    fp = [("footprint", (1 / SIZE, 1 / SIZE))]
    got = _render_glsl(one, [("ND_cellgl_flagstone", "color", "color3", fp),
                             ("ND_cellgl_flagstone_color3", "out", "color3", fp)])
    want = _bake("flagstone", tmp_path)
    assert _diff255(got["ND_cellgl_flagstone", "color"], want) <= 2
    # the single-output variant (issue 46 item 5) renders the same colour
    assert _diff255(got["ND_cellgl_flagstone_color3", "out"], want) <= 2


@pytest.mark.slow
def test_renderglsl_renders_every_preset_as_the_bake(full, tmp_path):
    names, _ = exportable_presets()
    jobs = [(f"ND_{node_name(n)}", "color", "color3", [("footprint", (1 / SIZE, 1 / SIZE))]) for n in names]
    got = _render_glsl(full, jobs)
    bad = {n: d for n in names if (d := _diff255(got[f"ND_{node_name(n)}", "color"], _bake(n, tmp_path))) > 2}
    assert not bad, bad


@pytest.mark.slow
def test_renderglsl_basis_nodes_equal_cellular(full):
    """The 2D basis nodes (and two 3D ones, on the plane z = 0.3) rendered by RenderGlsl against
    cellgl.cellular at the pixel centres (8 cells across): F1..F4, the cell colour and (Euclidean)
    the edge and the n-sphere radius."""
    import cellgl
    from cellgl.export.materialx_basis import BASIS_DISTRIBUTIONS, BASIS_METRICS

    jobs, cases = [], []
    combos = [(2, m, dist) for m in BASIS_METRICS for dist in BASIS_DISTRIBUTIONS]
    combos += [(3, "euclidean", "poisson"), (3, "minkowski", "jitter")]
    for dim, m, dist in combos:
        if True:
            nd = f"ND_cellgl_cellular{dim}d_{m}_{dist}"
            # position = 8 uv (3D: z = 0.3): the graph's input is a texcoord times 8
            vals = [("position_scale", 8.0) if dim == 2 else ("position_scale3", (8.0, 0.3)), ("seed", 7)]
            vals += [("jitter", 0.75)] if dist == "jitter" else [("density", 2.5)]
            outs = ["f1", "f2", "f3", "f4", "cellcolor"] + (["edge", "nsphere"] if m == "euclidean" else [])
            for o in outs:
                jobs.append((nd, o, "color3" if o == "cellcolor" else "float", vals))
            cases.append((nd, dim, m, dist, dict(vals), outs))
    got = _render_glsl(full, [(nd, o, t, v) for nd, o, t, v in jobs], size=32)
    u = (np.arange(32) + 0.5) / 32
    uu, vv = np.meshgrid(u, u)
    pts2 = 8.0 * np.stack([uu, 1.0 - vv], -1).reshape(-1, 2)     # row 0 at the top: v = 1 - y
    for nd, dim, m, dist, vals, _outs in cases:
        pts = pts2 if dim == 2 else np.concatenate([pts2, np.full((len(pts2), 1), 0.3)], 1)
        kw = dict(metric=m, distribution=dist, seed=vals["seed"])
        kw.update(jitter=vals["jitter"]) if dist == "jitter" else kw.update(density=vals["density"])
        euclid = m == "euclidean"
        res = cellgl.cellular(pts, n=4, outputs=("F", "id") + (("edge", "nsphere") if euclid else ()), **kw)
        F = np.asarray(res.F).reshape(32, 32, -1)
        for k in range(4):
            assert np.allclose(got[nd, f"f{k + 1}"][..., 0], F[..., k], atol=2e-5), (nd, k)
        from cellgl.io.spec import id_colors

        if euclid:
            for o in ("edge", "nsphere"):
                want = np.asarray(getattr(res, o)).reshape(32, 32)
                assert np.allclose(got[nd, o][..., 0], want, atol=2e-5), (nd, o)
        ids = np.asarray(res.id)[..., 0].reshape(32, 32).astype(np.uint32)
        assert np.array_equal(np.round(got[nd, "cellcolor"][..., :3] * 255).astype(int),
                              id_colors(ids).astype(int)), nd


# ------------------------------------------------------------------------------ GenOsl in Cycles


def _inline_includes(src: str, root: Path, seen=None) -> str:
    """``src`` with its ``#include "x"`` lines replaced by the files (MaterialX's genosl include
    folder): Cycles' compiler (``_cycles.osl_compile``) takes one file and no include path.
    Their ``#pragma once`` lines go (each file is inlined once): the compiler in bpy 4.5
    crashes (SIGSEGV) on that directive, even in a shader that has nothing else."""
    import re

    seen = set() if seen is None else seen

    def one(m):
        name = m.group(1)
        if name in seen:
            return ""
        seen.add(name)
        text = re.sub(r"^#pragma once[^\n]*$", "", (root / name).read_text(), flags=re.M)
        return _inline_includes(text, root, seen)

    return re.sub(r'^#include "([^"]+)"[^\n]*$', one, src, flags=re.M)


def _genosl_for_cycles(out, nodedef, footprint):
    """GenOsl's shader of ``nodedef``'s colour output, made a Script node for the project's Cycles
    scene (cellgl.blender.scene.set_script): includes inlined, its UV0 read from a ``point Vector``
    input (Cycles' ``u``, ``v`` globals are the triangle's, not a UV map), the output named
    ``Color``. The node's code is GenOsl's, untouched."""
    import re

    import MaterialX as mx
    from MaterialX import PyMaterialXGenOsl as g
    from MaterialX import PyMaterialXGenShader as mxg

    doc = _read_library(out)
    gen = g.OslShaderGenerator.create()
    o = _output_graph(doc, nodedef, "color", "color3", [("footprint", mx.Vector2(*footprint))])
    src = gen.generate("cellgl_mx", o, _context(gen, out)).getSourceCode(mxg.PIXEL_STAGE)
    inc = Path(mx.getDefaultDataSearchPath().find("libraries/stdlib/genosl/include/mx_funcs.h").asString()).parent
    src = _inline_includes(src, inc)
    head, sep, body = src.partition("\nshader ")
    assert sep, "no shader block"
    assert "vector2(u,v)" in body, "GenOsl's UV0 is no longer vector2(u,v): adapt the test"
    body = body.replace("vector2(u,v)", "vector2(Vector[0], Vector[1])")
    body = re.sub(r"\]\]\n\(\n", "]]\n(\n    point Vector = point(0, 0, 0),\n", body, count=1)
    body = body.replace("output color out = ", "output color Color = ")
    body = re.sub(r"^    out = ", "    Color = ", body, flags=re.M)
    return head + sep + body


def _need_bpy():
    import importlib.util
    import os

    if importlib.util.find_spec("bpy") is None:
        if os.environ.get("CELLGL_REQUIRE_BLENDER", "").strip().lower() in ("1", "true", "yes"):
            pytest.fail("CELLGL_REQUIRE_BLENDER=1 but bpy (the [blender] extra) is not installed", pytrace=False)
        pytest.skip("bpy (the [blender] extra) is not installed")


def _cycles(texts: dict, outdir: Path, size: int = SIZE):
    """Compile each OSL text with Cycles' compiler and render it in the project's scene (a flat
    quad under an orthographic camera, one sample at each pixel centre) to ``outdir/NAME.png``."""
    (outdir / "texts.json").write_text(json.dumps(texts))
    code = ("import json, sys\nfrom cellgl.blender import osl_compile\n"
            "from cellgl.blender.scene import build_scene, set_script, render_scene\n"
            f"texts = json.load(open({str(outdir / 'texts.json')!r}))\n"
            "for t in texts.values():\n    osl_compile(t)\n"
            f"scene = build_scene('f1', {size})\n"
            "for name, t in texts.items():\n"
            "    set_script(scene, t, name)\n"
            f"    render_scene(scene, {str(outdir)!r} + '/' + name + '.png')\n"
            "print('rendered')\n")
    proc = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=1800)
    assert proc.returncode == 0 and "rendered" in proc.stdout, (proc.stdout[-2000:], proc.stderr[-4000:])


def test_genosl_compiles_and_renders_in_cycles_as_the_bake(one, tmp_path):
    _need_bpy()
    from PIL import Image

    texts = {"flagstone": _genosl_for_cycles(one, "ND_cellgl_flagstone", (1 / SIZE, 1 / SIZE))}
    _cycles(texts, tmp_path)
    got = np.asarray(Image.open(tmp_path / "flagstone.png").convert("RGB"), np.int16)
    assert int(np.abs(got - _bake("flagstone", tmp_path)).max()) <= 2


@pytest.mark.slow
def test_genosl_renders_a_representative_set_in_cycles(full, tmp_path):
    _need_bpy()
    from PIL import Image

    texts = {n: _genosl_for_cycles(full, f"ND_{node_name(n)}", (1 / SIZE, 1 / SIZE)) for n in CYCLES_SET}
    _cycles(texts, tmp_path)
    bad = {}
    for n in CYCLES_SET:
        got = np.asarray(Image.open(tmp_path / f"{n}.png").convert("RGB"), np.int16)
        d = int(np.abs(got - _bake(n, tmp_path)).max())
        if d > 2:
            bad[n] = d
    assert not bad, bad


def test_set_values_are_the_inputs_defaults_and_the_fixed_values():
    """A recipe changed with --set exports its values: an input's default, or (a value fixed at
    export) the nodedef's doc."""
    from cellgl.recipes import load_recipe

    r = load_recipe("flagstone").set_from_strings(["shade=0.5", "density=5"])
    n = preset_node(r)
    assert {i.name: i.value for i in n.inputs}["shade"] == 0.5
    assert "density=5.0" in n.doc and "density" not in {i.name for i in n.inputs}
    assert "cellgl_flagstone_density" not in n.glsl       # folded: no variable for it
