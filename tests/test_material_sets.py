"""Material sets of engine presets (issue 45, item 3): ``cellgl bake RECIPE --material ENGINE -o DIR``."""
from __future__ import annotations

import base64
import json
import os
import shlex
import subprocess
import sys

import numpy as np
import pytest

from cellgl.bake import material_sets as M
from cellgl.bake.core import bake
from cellgl.io.spec import BakeError

SIZE = (40, 28)


def _read(path) -> np.ndarray:
    """The samples of a PNG, 8- or 16-bit (tests/test_io.py's own decoder; Pillow reads 16-bit RGB as 8)."""
    from test_io import _read_png_raw           # tests/ is on sys.path under pytest

    return _read_png_raw(path)[0]


def _chunks(path) -> list[bytes]:
    """The chunk types of a PNG, in order."""
    import struct

    data, pos, out = open(path, "rb").read(), 8, []
    while pos < len(data):
        (n,) = struct.unpack(">I", data[pos:pos + 4])
        out.append(data[pos + 4:pos + 8])
        pos += 12 + n
    return out


def _alone(tmp_path, channel: str, bits: int, convention: str) -> np.ndarray:
    """The bake of one channel alone (what `cellgl bake --channels CHANNEL` writes)."""
    out = tmp_path / f"alone_{channel}_{bits}_{convention}.png"
    if not out.exists():
        bake("flagstone", out, size=SIZE, channels=[channel], bit_depth=bits, progress=False,
             sets=[f"normal_convention={convention}"])
    return _read(out)


@pytest.mark.parametrize("engine", list(M.ENGINES))
def test_packed_samples_equal_the_channels_baked_alone(ctx, tmp_path, engine):
    out = tmp_path / "set"
    paths = M.bake_material("flagstone", out, engine, size=SIZE, progress=False)
    eng = M.ENGINES[engine]
    manifest = json.loads((out / "manifest.json").read_text())
    assert [p.name for p in paths] == [f["file"] for f in manifest["files"]]
    assert sorted(os.listdir(out)) == sorted(p.name for p in paths)
    assert manifest["material"] == engine and manifest["normal_convention"] == eng.normal
    assert manifest["recipe"]["name"] == "flagstone" and "--material " + engine in manifest["command"]
    for m, entry in zip(eng.maps, manifest["files"]):
        a = _read(out / entry["file"])
        assert entry["bit_depth"] == m.bits and a.dtype == (np.uint8 if m.bits == 8 else np.uint16)
        assert entry["color_space"].startswith("sRGB" if m.srgb else "linear (data, not colour")
        assert (b"sRGB" in _chunks(out / entry["file"])) == m.srgb        # colour tagged, data maps not
        assert a.shape[:2] == (SIZE[1], SIZE[0])
        a = a.reshape(SIZE[1], SIZE[0], -1)
        assert a.shape[2] == m.samples() == len(entry["channels"])
        k = 0
        top = (1 << m.bits) - 1
        for s in m.layout:
            n = 3 if s in ("color", "normal") else 1
            got = a[..., k:k + n] if n > 1 else a[..., k]
            if s == "1":
                assert np.all(got == top)
            elif s.startswith("1-"):          # smoothness: exactly top - the roughness bake
                assert np.array_equal(got, top - _alone(tmp_path, s[2:], m.bits, eng.normal)), (engine, s)
            else:
                assert np.array_equal(got, _alone(tmp_path, s, m.bits, eng.normal)), (engine, s)
            k += n


def test_directx_normals_for_unreal_opengl_for_the_others(ctx, tmp_path):
    un = M.bake_material("flagstone", tmp_path / "u", "unreal", size=SIZE, progress=False)
    gl = M.bake_material("flagstone", tmp_path / "g", "godot", size=SIZE, progress=False)
    nu = _read(next(p for p in un if p.name.endswith("_N.png"))).astype(int)
    ng = _read(next(p for p in gl if p.name.endswith("_normal.png"))).astype(int)
    assert np.array_equal(nu[..., [0, 2]], ng[..., [0, 2]])
    assert np.abs(nu[..., 1] + ng[..., 1] - 255).max() <= 1         # green flipped
    assert np.abs(nu[..., 1] - ng[..., 1]).max() > 60


def test_gltf_references_the_maps(ctx, tmp_path):
    paths = M.bake_material("flagstone", tmp_path / "g", "gltf", size=SIZE, progress=False)
    doc = json.loads((tmp_path / "g" / "flagstone.gltf").read_text())
    assert doc["asset"]["version"] == "2.0"
    mat = doc["materials"][0]
    uri = [im["uri"] for im in doc["images"]]
    tex = lambda slot: uri[doc["textures"][slot["index"]]["source"]]     # noqa: E731
    assert tex(mat["pbrMetallicRoughness"]["baseColorTexture"]) == "flagstone_baseColor.png"
    assert tex(mat["pbrMetallicRoughness"]["metallicRoughnessTexture"]) == "flagstone_occlusionRoughnessMetallic.png"
    assert tex(mat["occlusionTexture"]) == "flagstone_occlusionRoughnessMetallic.png"
    assert tex(mat["normalTexture"]) == "flagstone_normal.png"
    assert all((tmp_path / "g" / u).is_file() for u in uri)
    buf = base64.b64decode(doc["buffers"][0]["uri"].split(",", 1)[1])
    assert len(buf) == doc["buffers"][0]["byteLength"]
    for view in doc["bufferViews"]:
        assert view["byteOffset"] + view["byteLength"] <= len(buf) and view["byteOffset"] % 4 == 0
    pos = np.frombuffer(buf, np.float32, 12, doc["bufferViews"][0]["byteOffset"]).reshape(4, 3)
    uv = np.frombuffer(buf, np.float32, 8, doc["bufferViews"][3]["byteOffset"]).reshape(4, 2)
    top_left = np.argmin(uv.sum(axis=1))                    # uv (0, 0): the image's top-left pixel
    assert pos[top_left, 0] < 0 and pos[top_left, 1] > 0   # at the quad's top left (+Y up)
    assert [p.name for p in paths][-1] == "manifest.json"


def test_unknown_engine_lists_the_presets_and_writes_nothing(tmp_path):
    with pytest.raises(BakeError, match="--material 'unity': unknown engine preset; accepted: unreal, "
                                        "unity-hdrp, unity-urp, godot, gltf, blender"):
        M.bake_material("flagstone", tmp_path / "x", "unity", size=SIZE)
    with pytest.raises(BakeError, match="map format 'tga'; accepted: png"):
        M.bake_material("flagstone", tmp_path / "x", "gltf", size=SIZE, map_format="tga")
    with pytest.raises(BakeError, match="a material set is 2D maps"):
        M.bake_material("flagstone", tmp_path / "x", "gltf", size="8x8x8")
    with pytest.raises(BakeError, match="does not exist"):
        M.bake_material("flagstone", tmp_path / "no" / "x", "gltf", size=SIZE)
    assert os.listdir(tmp_path) == []


def test_pups_recipe_is_refused(tmp_path):
    from cellgl.recipes import list_presets

    pups = next(n for n, _ in list_presets() if n.startswith("pups-"))
    with pytest.raises(BakeError, match="PUPs recipe, which has no roughness"):
        M.bake_material(pups, tmp_path / "x", "gltf", size=SIZE)


@pytest.mark.parametrize("existing", [False, True])
def test_a_failure_leaves_the_folder_as_it_was(ctx, tmp_path, monkeypatch, existing):
    out = tmp_path / "set"
    if existing:
        out.mkdir()
        (out / "T_flagstone_BC.png").write_bytes(b"old")
    real = M.write_tiles
    calls = []

    def failing(tmp, tiles, *a, **k):
        calls.append(tmp)
        if len(calls) == 3:
            raise OSError(28, "No space left on device")
        return real(tmp, tiles, *a, **k)

    monkeypatch.setattr(M, "write_tiles", failing)
    with pytest.raises(OSError):
        M.bake_material("flagstone", out, "unreal", size=SIZE, progress=False)
    assert sorted(os.listdir(tmp_path)) == (["set"] if existing else [])     # no hidden folder left
    if existing:
        assert os.listdir(out) == ["T_flagstone_BC.png"] and (out / "T_flagstone_BC.png").read_bytes() == b"old"
    monkeypatch.setattr(M, "write_tiles", real)
    M.bake_material("flagstone", out, "unreal", size=SIZE, progress=False)
    assert (out / "T_flagstone_BC.png").read_bytes()[:4] == b"\x89PNG"
    assert sorted(os.listdir(tmp_path)) == ["set"]


def test_command_line(ctx, tmp_path):
    run = [sys.executable, "-m", "cellgl", "bake", "flagstone", "--material", "unreal", "-o", str(tmp_path / "u"),
           "--size", "24x16", "-q"]
    proc = subprocess.run(run, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    manifest = json.loads((tmp_path / "u" / "manifest.json").read_text())
    assert manifest["command"] == f"cellgl bake flagstone --material unreal -o {tmp_path / 'u'} --size 24x16"
    assert {f["file"] for f in manifest["files"]} == set(os.listdir(tmp_path / "u"))
    # the manifest's command remakes the same maps (into another folder here)
    words = shlex.split(manifest["command"].replace(str(tmp_path / "u"), str(tmp_path / "again")))
    assert words[:2] == ["cellgl", "bake"]
    again = subprocess.run([sys.executable, "-m", "cellgl", *words[1:], "-q"], capture_output=True, text=True,
                           timeout=300)
    assert again.returncode == 0, again.stderr
    for f in manifest["files"]:
        if f["file"].endswith(".png"):
            assert (tmp_path / "again" / f["file"]).read_bytes() == (tmp_path / "u" / f["file"]).read_bytes()
    bad = subprocess.run(run[:-1] + ["--channels", "color"], capture_output=True, text=True, timeout=300)
    assert bad.returncode != 0 and "--channels color: not with --material" in bad.stderr
    bad = subprocess.run(run[:6] + ["nope"] + run[7:], capture_output=True, text=True, timeout=300)
    assert bad.returncode != 0 and "unknown engine preset; accepted: unreal, unity-hdrp" in bad.stderr


_BLENDER_IMPORT = '''
import json, sys
import bpy
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=sys.argv[-1])
mat = next(m for m in bpy.data.materials if m.use_nodes and any(n.type == "BSDF_PRINCIPLED" for n in m.node_tree.nodes))
bsdf = next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED")

def source(sock):
    """The image file feeding socket sock, and the nodes between (walking the links back)."""
    for link in sock.links:
        n = link.from_node
        if n.type == "TEX_IMAGE":
            return [n.image.filepath.replace("\\\\", "/").split("/")[-1], n.image.colorspace_settings.name]
        for inp in n.inputs:
            got = source(inp)
            if got:
                return got + [n.type + ":" + link.from_socket.name]
    return None

out = {k: source(bsdf.inputs[k]) for k in ("Base Color", "Roughness", "Metallic", "Normal")}
for n in mat.node_tree.nodes:           # the importer's glTF Material Output group holds the occlusion
    if n.type == "GROUP" and "Occlusion" in n.inputs:
        out["Occlusion"] = source(n.inputs["Occlusion"])
print("RESULT " + json.dumps(out))
'''


@pytest.mark.slow
def test_blender_imports_the_gltf_with_every_texture_on_its_socket(ctx, tmp_path):
    """Blender's own glTF importer (bpy, the [blender] extra) connects each map to the right input."""
    import importlib.util

    if importlib.util.find_spec("bpy") is None:
        if os.environ.get("CELLGL_REQUIRE_BLENDER", "").strip().lower() in ("1", "true", "yes"):
            pytest.fail("CELLGL_REQUIRE_BLENDER=1 but bpy (the [blender] extra) is not installed", pytrace=False)
        pytest.skip("bpy (the [blender] extra) is not installed")
    M.bake_material("flagstone", tmp_path / "g", "gltf", size=SIZE, progress=False)
    proc = subprocess.run([sys.executable, "-c", _BLENDER_IMPORT, str(tmp_path / "g" / "flagstone.gltf")],
                          capture_output=True, text=True, timeout=600)
    line = next((ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT ")), None)
    assert proc.returncode == 0 and line, (proc.stdout[-2000:], proc.stderr[-2000:])
    got = json.loads(line[len("RESULT "):])
    orm = "flagstone_occlusionRoughnessMetallic.png"
    assert got == {"Base Color": ["flagstone_baseColor.png", "sRGB"],
                   "Roughness": [orm, "Non-Color", "SEPARATE_COLOR:Green"],
                   "Metallic": [orm, "Non-Color", "SEPARATE_COLOR:Blue"],
                   "Normal": ["flagstone_normal.png", "Non-Color", "NORMAL_MAP:Normal"],
                   "Occlusion": [orm, "Non-Color", "SEPARATE_COLOR:Red"]}, got


def test_a_recipe_object_is_named_by_the_sets_recipe_json(ctx, tmp_path):
    from cellgl.recipes import load_recipe

    r = load_recipe("hull").set_from_strings(["seed=7"])
    M.bake_material(r, tmp_path / "h", "godot", size=(16, 16), progress=False)
    manifest = json.loads((tmp_path / "h" / "manifest.json").read_text())
    assert manifest["command"].startswith(f"cellgl bake {tmp_path / 'h' / 'recipe.json'} --material godot ")
    assert load_recipe(str(tmp_path / "h" / "recipe.json")) == r
    assert manifest["recipe"] == r.to_dict()


def test_mips_are_each_level_rendered_at_its_size(ctx, tmp_path):
    """--mips: every map's level k is the set baked at ceil(W / 2^k) x ceil(H / 2^k) (rendered, not
    downsampled), as <map>_mip<k>.png; level 0 is the set without mips; the manifest lists them."""
    from cellgl.bake.mips import mip_sizes

    paths = M.bake_material("flagstone", tmp_path / "m", "unreal", size=(20, 12), mips=True, progress=False)
    plain = M.bake_material("flagstone", tmp_path / "p", "unreal", size=(20, 12), progress=False)
    manifest = json.loads((tmp_path / "m" / "manifest.json").read_text())
    sizes = mip_sizes(20, 12)
    assert len(paths) == 4 * len(sizes) + 2 and sorted(os.listdir(tmp_path / "m")) == sorted(p.name for p in paths)
    assert "--mips" in manifest["command"]
    for entry in manifest["files"][:4]:
        assert [lv["size"] for lv in entry["mips"]] == [list(s) for s in sizes]
        for lv in entry["mips"]:
            got = _read(tmp_path / "m" / lv["file"])
            if lv["level"] == 0:
                assert lv["file"] == entry["file"]
                assert np.array_equal(got, _read(tmp_path / "p" / entry["file"]))
            elif lv["level"] in (1, 3):
                w, h = lv["size"]
                ref = M.bake_material("flagstone", tmp_path / f"l{w}x{h}", "unreal", size=(w, h), progress=False)
                assert np.array_equal(got, _read(next(p for p in ref if p.name == entry["file"])))
            assert got.shape[:2] == (lv["size"][1], lv["size"][0])
    assert {p.name for p in plain} <= {p.name for p in paths}


def _gltf_validator():
    """Khronos' glTF-Validator (npm, installed by .ci/setup into .venv/gltf-validator) and node, or None."""
    import shutil
    from pathlib import Path

    mod = Path(__file__).resolve().parents[1] / ".venv" / "gltf-validator" / "node_modules" / "gltf-validator"
    node = shutil.which("node")
    return (node, mod) if node and (mod / "index.js").is_file() else None


@pytest.mark.slow
@pytest.mark.parametrize("mips", [False, True])
def test_khronos_gltf_validator_reports_no_issue(ctx, tmp_path, mips):
    """The .gltf and the maps it references pass Khronos' glTF-Validator with no error, warning,
    info or hint (at power-of-two sides: other sides get the validator's IMAGE_NPOT_DIMENSIONS info)."""
    found = _gltf_validator()
    if found is None:
        pytest.skip("glTF-Validator (npm gltf-validator, .venv/gltf-validator) or node is not installed")
    node, mod = found
    M.bake_material("flagstone", tmp_path / "g", "gltf", size=(32, 16), mips=mips, progress=False)
    script = os.path.join(os.path.dirname(__file__), "gltf_validate.js")
    proc = subprocess.run([node, script, str(mod), str(tmp_path / "g" / "flagstone.gltf")], capture_output=True,
                          text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    report = json.loads(proc.stdout)
    issues = report["issues"]
    assert (issues["numErrors"], issues["numWarnings"], issues["numInfos"], issues["numHints"]) == (0, 0, 0, 0), \
        issues["messages"]
    images = [r for r in report["info"]["resources"] if r["pointer"].startswith("/images/")]
    assert [r["uri"] for r in images] == ["flagstone_baseColor.png", "flagstone_occlusionRoughnessMetallic.png",
                                          "flagstone_normal.png"]
    assert all(r["image"]["width"] == 32 and r["image"]["height"] == 16 for r in images)
