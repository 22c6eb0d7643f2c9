"""The OSL export rendered by Blender's Cycles (bpy 4.5, the ``[blender]`` extra) against
``cellgl bake``: every exportable texture preset at 128 x 128, one sample at the pixel centre,
colour within 2/255 per channel, feature point IDs and cell colours identical; and the
``.blend`` of ``cellgl blender``, opened and rendered as is, giving the bake's PNG.

Blender runs in a subprocess (one for all presets: one scene, the Script node's text swapped per
preset), so its global state stays out of the test process. Without bpy these tests skip, unless
CELLGL_REQUIRE_BLENDER is set (``.ci/run``), where they fail.
"""
from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import cellgl
from cellgl.export.snippets import ExportError, export
from cellgl.io.spec import id_colors
from cellgl.recipes import load_recipe

REQUIRE = os.environ.get("CELLGL_REQUIRE_BLENDER", "").strip().lower() in ("1", "true", "yes")
SIZE = 128
ROOT = Path(__file__).resolve().parents[1]


def _need_bpy():
    if importlib.util.find_spec("bpy") is None:
        if REQUIRE:
            pytest.fail("CELLGL_REQUIRE_BLENDER=1 but bpy (the [blender] extra) is not installed",
                        pytrace=False)
        pytest.skip("bpy (the [blender] extra) is not installed")


def _read_exr(path) -> np.ndarray:
    import OpenEXR

    ch = OpenEXR.File(str(path)).channels()
    key = "RGB" if "RGB" in ch else "RGBA"
    return np.array(ch[key].pixels, np.float32)[..., :3]


def _python(code: str, timeout: float = 900) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                          timeout=timeout)


def exportable_presets() -> tuple[list[str], dict[str, str]]:
    ok, refused = [], {}
    for name, _ in cellgl.list_presets():
        try:
            export(name, "osl")
            ok.append(name)
        except ExportError as exc:
            refused[name] = str(exc)
    return ok, refused


def test_osl_refuses_pups_and_image_driven_presets_only():
    ok, refused = exportable_presets()
    for name, msg in refused.items():
        r = load_recipe(name)
        if getattr(r, "kind", None) == "pups":
            assert "PUPs recipes cannot be exported" in msg
        else:
            assert r.values["cell_color"] == "image" or r.values["density_map"] == "image", (name, msg)
            assert "cellgl bake" in msg
    assert len(ok) >= 25 and "f1" in ok and "stained-glass" in refused


@pytest.fixture(scope="module")
def cycles_renders(tmp_path_factory):
    _need_bpy()
    names, _ = exportable_presets()
    out = tmp_path_factory.mktemp("cycles")
    proc = _python("import sys\nfrom cellgl.blender.scene import render_outputs\n"
                   f"render_outputs({names!r}, {SIZE}, {str(out)!r})\n")
    assert proc.returncode == 0, proc.stderr[-4000:]
    return out, names


@pytest.mark.slow
def test_cycles_renders_every_exportable_preset_as_the_bake(cycles_renders, tmp_path):
    from cellgl.bake.core import bake

    out, names = cycles_renders
    bad = []
    for name in names:
        png = tmp_path / f"{name}.png"
        bake(name, str(png), size=SIZE)
        want = np.asarray(Image.open(png).convert("RGB"), np.int16)
        got = np.asarray(Image.open(out / f"{name}.png").convert("RGB"), np.int16)
        assert got.shape == want.shape == (SIZE, SIZE, 3), name
        diff = int(np.abs(got - want).max())

        ref = cellgl.render(name, SIZE, SIZE, channels=("id",))["id"].astype(np.int64)
        idf = _read_exr(out / f"{name}.id.exr")
        assert np.all(idf[..., :2] == np.round(idf[..., :2])), name        # exact integers
        ids = idf[..., 0].astype(np.int64) + 65536 * idf[..., 1].astype(np.int64)
        cell = np.round(_read_exr(out / f"{name}.cell.exr") * 255).astype(np.int64)
        id_bad = int(np.count_nonzero(ids != ref))
        cell_bad = int(np.count_nonzero(np.any(cell != id_colors(ref.astype(np.uint32)), axis=-1)))
        if diff > 2 or id_bad or cell_bad:
            bad.append(f"{name}: colour max diff {diff}/255, {id_bad} IDs and {cell_bad} cell colours differ")
    assert not bad, "\n".join(bad)


@pytest.mark.slow
def test_blend_file_renders_as_is_to_the_bake(tmp_path):
    _need_bpy()
    blend = tmp_path / "f4.blend"
    proc = subprocess.run([sys.executable, "-m", "cellgl", "blender", "f4", "-o", str(blend), "--size", "48"],
                          cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-4000:]
    assert blend.stat().st_size > 10000
    assert not list(tmp_path.glob("*.part*")) and not list(tmp_path.glob("*.blend1"))
    png = tmp_path / "render.png"
    # a fresh Blender: open the file and render it without changing anything but the path
    proc = _python("import bpy\nfrom cellgl.blender import import_bpy\nimport_bpy()\n"
                   f"bpy.ops.wm.open_mainfile(filepath={str(blend)!r})\n"
                   f"bpy.context.scene.render.filepath = {str(png)!r}\n"
                   "bpy.ops.render.render(write_still=True)\n", timeout=600)
    assert proc.returncode == 0, proc.stderr[-4000:]
    want = tmp_path / "bake.png"
    subprocess.run([sys.executable, "-m", "cellgl", "bake", "f4", "--size", "48", "-o", str(want)],
                   cwd=ROOT, check=True, capture_output=True, timeout=600)
    a = np.asarray(Image.open(png).convert("RGB"), np.int16)
    b = np.asarray(Image.open(want).convert("RGB"), np.int16)
    assert a.shape == b.shape == (48, 48, 3)
    assert np.abs(a - b).max() <= 2
    assert a.std() > 10          # a texture, not a flat colour


def test_cli_blender_refuses_clearly(tmp_path):
    for args, words in ((["pups-cow", "-o", str(tmp_path / "x.blend")], "PUPs recipes cannot be exported"),
                        (["f1", "-o", str(tmp_path / "x.png")], "must end in .blend"),
                        (["f1", "-o", str(tmp_path / "x.blend"), "--size", "0"], "size 0 is out of range")):
        if "must end" in words or "size 0" in words:
            _need_bpy()
        proc = subprocess.run([sys.executable, "-m", "cellgl", "blender", *args], cwd=ROOT,
                              capture_output=True, text=True, timeout=600)
        assert proc.returncode != 0
        assert words in proc.stderr and "Traceback" not in proc.stderr, proc.stderr[-2000:]
    assert not list(tmp_path.iterdir())


def test_missing_bpy_names_the_extra():
    proc = _python("import sys\nsys.modules['bpy'] = None\nfrom cellgl.blender import import_bpy\n"
                   "try:\n    import_bpy()\nexcept ImportError as e:\n    print(e)\n")
    assert proc.returncode == 0, proc.stderr
    assert "pip install 'cellgl[blender]'" in proc.stdout


@pytest.mark.slow
def test_osl_export_compiles_in_cycles():
    """Every exportable preset's OSL compiles with Cycles' own OSL compiler and the Script node
    gets the parameters and outputs the export declares."""
    _need_bpy()
    names, _ = exportable_presets()
    code = (
        "import json\nfrom cellgl.blender import import_bpy, osl_compile, compile_script_node\n"
        "from cellgl.export.snippets import export\n"
        "bpy = import_bpy()\n"
        f"for n in {names!r}:\n"
        "    osl_compile(export(n, 'osl'))\n"
        "mat = bpy.data.materials.new('m'); mat.use_nodes = True\n"
        "node = mat.node_tree.nodes.new('ShaderNodeScript'); node.mode = 'INTERNAL'\n"
        "node.script = bpy.data.texts.new('t.osl'); node.script.write(export('flagstone', 'osl'))\n"
        "compile_script_node(node)\n"
        "print(json.dumps({'in': {s.identifier: [s.name, getattr(s, 'default_value', None) if s.identifier != 'Vector' "
        "else None] for s in node.inputs}, 'out': [s.identifier for s in node.outputs]}))\n")
    proc = _python(code)
    assert proc.returncode == 0, proc.stderr[-4000:]
    import json

    info = json.loads(proc.stdout.strip().splitlines()[-1])
    assert info["out"] == ["Color", "Fac", "F1", "F2", "F3", "F4", "Value", "CellColor", "CellValue",
                           "IDLow", "IDHigh", "Normal"]
    r = load_recipe("flagstone")
    assert info["in"]["frequency"][0] == "Frequency"
    assert info["in"]["frequency"][1] == pytest.approx(r.values["frequency"])
    assert info["in"]["cell_mix"][1] == pytest.approx(r.values["cell_mix"])
    assert "P" not in info["in"] and "Vector" in info["in"]


_UINT_GLSL = """
uint hash(uint x)
{
    x ^= x >> 16;
    x *= 0x7feb352du;
    x ^= x >> 15;
    x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}

uint mixed(uint k)
{
    uint a = hash(k);
    uint b = (hash(k ^ 0x5bd1e995u) >> (k % 31u)) | 1u;
    uint r = a / b;
    r ^= (a % b) * 0x9e3779b9u;
    r ^= a < b ? 0xdeadbeefu : 0u;
    r ^= b >= 0x80000000u ? 0x12345678u : 0u;
    r ^= uint(float(a) * 0.5);
    r += uint(float(a >> 1)) >> 3;
    r ^= floatBitsToUint(float(int(k) - 500) * 0.37);
    r ^= floatBitsToUint(float(a) * 1.5e-30) * 3u;
    return r;
}
"""


def _uint_reference(k: np.ndarray) -> np.ndarray:
    u = np.uint32

    def h(x):
        x = x.astype(np.uint32)
        with np.errstate(over="ignore"):
            x ^= x >> u(16)
            x *= u(0x7FEB352D)
            x ^= x >> u(15)
            x *= u(0x846CA68B)
            x ^= x >> u(16)
        return x

    k = k.astype(np.uint32)
    a = h(k)
    b = (h(k ^ u(0x5BD1E995)) >> (k % u(31))) | u(1)
    with np.errstate(over="ignore"):
        r = a // b
        r ^= (a % b) * u(0x9E3779B9)
        r ^= np.where(a < b, u(0xDEADBEEF), u(0))
        r ^= np.where(b >= u(0x80000000), u(0x12345678), u(0))
        r ^= (a.astype(np.float32) * np.float32(0.5)).astype(np.uint32)
        r += (a >> u(1)).astype(np.float32).astype(np.uint32) >> u(3)
        r ^= ((k.astype(np.int64) - 500).astype(np.float32) * np.float32(0.37)).view(np.uint32)
        r ^= (a.astype(np.float32) * np.float32(1.5e-30)).view(np.uint32) * u(3)
    return r


@pytest.mark.slow
def test_osl_unsigned_arithmetic_is_bit_exact(tmp_path):
    """The uint emulation on OSL's int (logical >>, unsigned < and >=, / and %, uint <-> float,
    floatBitsToUint, wrapping *): a GLSL function of the library's dialect, translated and run by Cycles per
    pixel, against NumPy's uint32 (the bits the GLSL path gives)."""
    _need_bpy()
    from cellgl.export.translate import to_osl

    n = 32
    shader = to_osl(_UINT_GLSL) + (
        "shader t(point Vector = point(0), output color Color = 0)\n{\n"
        f"    int k = int(floor(Vector[0] * {n})) + {n} * int(floor((1.0 - Vector[1]) * {n}));\n"
        "    int r = mixed(k * 7919 + 13);\n"
        "    Color = color(float(r & 65535), float((r >> 16) & 65535), 0.0);\n}\n")
    out = tmp_path / "uint.exr"
    proc = _python("from cellgl.blender.scene import build_scene, set_script, render_scene\n"
                   f"scene = build_scene('f1', {n})\nset_script(scene, {shader!r})\n"
                   f"render_scene(scene, {str(out)!r})\n")
    assert proc.returncode == 0, proc.stderr[-4000:]
    px = _read_exr(out)
    got = px[..., 0].astype(np.int64) + 65536 * px[..., 1].astype(np.int64)
    k = np.arange(n * n).reshape(n, n) * 7919 + 13
    want = _uint_reference(k).astype(np.int64)
    assert np.count_nonzero(got != want) == 0, np.argwhere(got != want)[:5]


@pytest.mark.slow
def test_osl_basis_snippets_compile_and_give_cellulars_values(tmp_path):
    """``cellgl export --basis ... --target osl``: every basis and dimension compiles with Cycles'
    compiler; the shader's sockets are Vector (+ W in 4D) in and the basis values out; rendered by
    Cycles, F1, F2 (3D) and the cell ID halves (2D) are those of ``cellgl.cellular``."""
    _need_bpy()
    import json

    from cellgl import cellular

    n, S, z = 24, 4.0, 0.37
    wrap = {        # a shader around the exported functions that writes them into Color
        ("f1f2", 3): "\nshader t(point Vector = point(0), output color Color = 0)\n{\n"
        f"    cellgl_vec2 f = cellgl_f1f2(cellgl_vec3(Vector[0] * {S}, Vector[1] * {S}, {z}));\n"
        "    Color = color(f.x, f.y, 0.0);\n}\n",
        ("cellid", 2): "\nshader t(point Vector = point(0), output color Color = 0)\n{\n"
        f"    int id = cellgl_cellid(cellgl_vec2(Vector[0] * {S}, Vector[1] * {S}));\n"
        "    Color = color(float(id & 65535), float((id >> 16) & 65535), 0.0);\n}\n",
    }
    code = ("import json\nfrom cellgl.blender import import_bpy, osl_compile, compile_script_node\n"
            "from cellgl.blender.scene import build_scene, set_script, render_scene\n"
            "from cellgl.export.basis import BASES, basis_export\n"
            "texts = {(b, d): basis_export(b, d, 'osl') for b in BASES for d in (2, 3, 4)}\n"
            "for t in texts.values():\n    osl_compile(t)\n"
            f"scene = build_scene('f1', {n})\n"
            + "".join(f"t = texts[{k!r}]\nset_script(scene, t[:t.index('\\nshader cellgl_basis_')] + {w!r})\n"
                      f"render_scene(scene, {str(tmp_path / (k[0] + '.exr'))!r})\n" for k, w in wrap.items())
            + "bpy = import_bpy()\nmat = bpy.data.materials.new('m'); mat.use_nodes = True\nout = {}\n"
            "for b, d in [('f1f2f3', 3), ('edge', 2), ('cellid', 4)]:\n"
            "    node = mat.node_tree.nodes.new('ShaderNodeScript'); node.mode = 'INTERNAL'\n"
            "    node.script = bpy.data.texts.new(b); node.script.write(texts[b, d])\n"
            "    compile_script_node(node)\n"
            "    out[f'{b}{d}'] = [[s.identifier for s in node.inputs], [s.identifier for s in node.outputs]]\n"
            "print(json.dumps(out))\n")
    proc = _python(code)
    assert proc.returncode == 0, proc.stderr[-4000:]
    sockets = json.loads(proc.stdout.strip().splitlines()[-1])
    assert sockets == {"f1f2f33": [["Vector"], ["F1", "F2", "F3"]], "edge2": [["Vector"], ["Distance"]],
                       "cellid4": [["Vector", "W"], ["IDLow", "IDHigh"]]}
    c = (np.arange(n) + 0.5) / n
    x, y = np.meshgrid(c * S, (1.0 - c) * S)               # EXR row 0 = top = Vector y near 1
    px = _read_exr(tmp_path / "f1f2.exr")
    want = cellular(np.stack([x.ravel(), y.ravel(), np.full(x.size, z)], 1), 2).F.reshape(n, n, 2)
    np.testing.assert_allclose(px[..., :2], want, atol=1e-4)
    px = _read_exr(tmp_path / "cellid.exr")
    got = px[..., 0].astype(np.int64) + 65536 * px[..., 1].astype(np.int64)
    ids = cellular(np.stack([x.ravel(), y.ravel()], 1), 1).id[:, 0].reshape(n, n).astype(np.int64)
    assert np.mean(got == ids) > 0.98, np.mean(got == ids)     # (a sample on a cell border may flip)
