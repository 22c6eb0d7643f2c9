"""The Blender extension (``cellgl blender-extension``, :mod:`cellgl.blender.addon`).

* the zip: layout, manifest, deterministic bytes, atomic write, Blender's own validator; built
  offline (the wheel fetcher is injected: wheels made from this venv's installed moderngl and
  glcontext, so no network);
* the add-on, installed from that zip by Blender's own ``extensions.package_install_files``
  operator (the ``bpy`` module, user resources in a temporary folder): every operator headless, a
  preset rendered by Cycles through the OSL branch and through the baked-image branch, each equal
  to ``cellgl bake`` (same IDs and cell colours, colour within 2/255); unregistering leaves
  nothing behind. The driver is tests/blender_addon_run.py, in a subprocess.

Slow: every exportable preset through both branches, and EEVEE (Mesa, headless). Without bpy the
Blender tests skip, unless CELLGL_REQUIRE_BLENDER is set (``.ci/run``).
"""
from __future__ import annotations

import base64
import csv
import hashlib
import importlib.metadata
import io
import json
import os
import platform
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from cellgl.blender import extension

from test_blender import _need_bpy

ROOT = Path(__file__).resolve().parents[1]
SIZE = 128


def _local_platform() -> str:
    machine = platform.machine().lower()
    plat = {("linux", "x86_64"): "linux-x64", ("win32", "amd64"): "windows-x64",
            ("darwin", "arm64"): "macos-arm64", ("darwin", "x86_64"): "macos-x64"}.get((sys.platform, machine))
    if plat is None:
        pytest.skip(f"no extension platform for {sys.platform} {machine}")
    return plat


def _installed_wheel(name: str, dest: Path, tag: str) -> Path:
    """A wheel of the installed distribution ``name`` (its files as installed): offline."""
    dist = importlib.metadata.distribution(name)
    ver = dist.version
    base = Path(dist.locate_file(""))
    stem = f"{dist.metadata['Name'].replace('-', '_')}-{ver}"
    out = dest / f"{stem}-{tag}.whl"
    records = []
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
        for f in sorted(dist.files, key=str):
            p = base / f
            rel = str(f).replace(os.sep, "/")
            if rel.startswith("..") or "__pycache__" in rel or not p.is_file() or rel.endswith(("RECORD", "INSTALLER",
                                                                                           "direct_url.json", "WHEEL")):
                continue
            data = p.read_bytes()
            z.writestr(rel, data)
            digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
            records.append((rel, f"sha256={digest}", str(len(data))))
        wheel = f"Wheel-Version: 1.0\nGenerator: cellgl-tests\nRoot-Is-Purelib: false\nTag: {tag}\n"
        z.writestr(f"{stem}.dist-info/WHEEL", wheel)
        records.append((f"{stem}.dist-info/WHEEL", "", ""))
        buf = io.StringIO()
        csv.writer(buf, lineterminator="\n").writerows(records + [(f"{stem}.dist-info/RECORD", "", "")])
        z.writestr(f"{stem}.dist-info/RECORD", buf.getvalue())
    return out


def offline_fetch(plat, tags, requirements, dest: Path):
    """The injected fetcher: this venv's moderngl, glcontext and platformdirs as wheels for ``plat``."""
    dest.mkdir(parents=True, exist_ok=True)
    tag = {"linux-x64": "cp311-cp311-manylinux_2_28_x86_64", "windows-x64": "cp311-cp311-win_amd64",
           "macos-arm64": "cp311-cp311-macosx_11_0_arm64", "macos-x64": "cp311-cp311-macosx_10_13_x86_64"}[plat]
    return [_installed_wheel(r.split(">")[0], dest, tag) for r in requirements]


@pytest.fixture(scope="module")
def zip_path(tmp_path_factory):
    out = tmp_path_factory.mktemp("ext") / "cellgl.zip"
    return extension.build_extension(out, platforms=[_local_platform()], fetch=offline_fetch,
                                     cache=out.parent / "cache")


def test_extension_zip_layout(zip_path):
    tomllib = pytest.importorskip("tomllib")          # Python 3.11+
    names = zipfile.ZipFile(zip_path).namelist()
    assert names[:2] == ["__init__.py", "blender_manifest.toml"]
    wheels = [n for n in names if n.startswith("wheels/")]
    assert {w.split("/")[1].split("-")[0] for w in wheels} == {"cellgl", "moderngl", "glcontext", "platformdirs"}
    m = tomllib.loads(zipfile.ZipFile(zip_path).read("blender_manifest.toml").decode())
    assert m["schema_version"] == "1.0.0" and m["id"] == "cellgl" and m["type"] == "add-on"
    assert m["blender_version_min"] == "4.2.0" and m["license"] == ["SPDX:MIT"]
    assert sorted(w[2:] for w in m["wheels"]) == sorted(wheels)
    assert m["platforms"] == [_local_platform()]
    assert set(m["permissions"]) == {"files", "clipboard"} and len(m["tagline"]) <= 64
    own = zipfile.ZipFile(io.BytesIO(zipfile.ZipFile(zip_path).read(
        next(w for w in wheels if "/cellgl-" in w))))
    inner = set(own.namelist())
    assert {"cellgl/blender/addon/__init__.py", "cellgl/blender/addon/ui.py", "cellgl/blender/bakejob.py",
            "cellgl/shaders/lib/texture.glsl"} <= inner
    init = zipfile.ZipFile(zip_path).read("__init__.py").decode()
    assert "def register" in init and "def unregister" in init


def test_extension_build_is_deterministic_and_atomic(zip_path, tmp_path):
    again = extension.build_extension(tmp_path / "again.zip", platforms=[_local_platform()], fetch=offline_fetch,
                                      cache=zip_path.parent / "cache")
    assert again.read_bytes() == zip_path.read_bytes()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["again.zip"]        # no temporary left
    with pytest.raises(ValueError, match="must end in .zip"):
        extension.build_extension(tmp_path / "x.tar", fetch=offline_fetch)
    with pytest.raises(ValueError, match="platform 'amiga' is unknown; accepted: linux-x64"):
        extension.build_extension(tmp_path / "x.zip", platforms=["amiga"], fetch=offline_fetch)

    def no_wheels(plat, tags, reqs, dest):
        return []

    with pytest.raises(RuntimeError, match="no wheel for moderngl>=5.10, glcontext>=3.0, platformdirs>=3 on"):
        extension.build_extension(tmp_path / "y.zip", platforms=[_local_platform()], fetch=no_wheels)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["again.zip"]


def test_extension_passes_blenders_validator(zip_path):
    _need_bpy()
    assert "Success" in extension.validate(zip_path)


def test_bake_job_imports_neither_pillow_nor_scipy():
    """Why the zip bundles no Pillow or SciPy wheel: the bake child does not import them."""
    code = ("import sys, json\nfrom cellgl.blender.bakejob import run_job\n"
            "a = run_job({'kind': 'recipe', 'recipe': 'flagstone', 'sets': ['seed=2'], 'size': 16})\n"
            "b = run_job({'kind': 'voronoi', 'size': 8, 'sockets': {'dimensions': 2, 'scale': 3.0}})\n"
            "print(json.dumps([sorted(a), sorted(b), 'scipy' in sys.modules, 'PIL' in sys.modules]))\n")
    proc = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    a, b, scipy, pil = json.loads(proc.stdout.strip().splitlines()[-1])
    assert a == ["cell", "color", "data", "normal"] and "distance" in b
    assert not scipy and not pil


def _drive(out: Path, args, timeout=900, zip_file=None) -> dict:
    env = dict(os.environ)
    env["BLENDER_USER_RESOURCES"] = str(out / "blender-user")        # the extension installs here
    cmd = [sys.executable, str(ROOT / "tests" / "blender_addon_run.py"), str(out), *map(str, args)]
    if zip_file is not None:
        cmd += ["--install", str(zip_file)]
    proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=timeout, env=env)
    assert proc.returncode == 0, (proc.stdout[-2000:], proc.stderr[-4000:])
    return json.loads((out / "report.json").read_text())


def _read_exr(path) -> np.ndarray:
    import OpenEXR

    ch = OpenEXR.File(str(path)).channels()
    key = "RGB" if "RGB" in ch else "RGBA"
    return np.array(ch[key].pixels, np.float32)[..., :3]


def _compare(out: Path, name: str, tags, size: int = SIZE) -> list[str]:
    """Each branch's render of ``name`` against ``cellgl bake``: colour within 2/255, the same IDs
    and cell colours; returns the failures."""
    import cellgl
    from cellgl.bake.core import bake
    from cellgl.io.spec import id_colors

    png = out / f"bake-{name}.png"
    bake(name, str(png), size=size, progress=False)
    want = np.asarray(Image.open(png).convert("RGB"), np.int16)
    ref = cellgl.render(name, size, size, channels=("id",))["id"].astype(np.int64)
    bad = []
    for tag in tags:
        got = np.asarray(Image.open(out / f"{name}.{tag}.png").convert("RGB"), np.int16)
        diff = int(np.abs(got - want).max())
        idf = _read_exr(out / f"{name}.{tag}.id.exr")
        ids = idf[..., 0].astype(np.int64) + 65536 * idf[..., 1].astype(np.int64)
        cell = np.round(_read_exr(out / f"{name}.{tag}.cell.exr") * 255).astype(np.int64)
        id_bad = int(np.count_nonzero(ids != ref))
        cell_bad = int(np.count_nonzero(np.any(cell != id_colors(ref.astype(np.uint32)), axis=-1)))
        if diff > 2 or id_bad or cell_bad or got.std() < 5:
            bad.append(f"{name} ({tag}): colour max diff {diff}/255, {id_bad} IDs and {cell_bad} cell colours "
                       f"differ, std {got.std():.1f}")
    return bad


@pytest.fixture(scope="module")
def installed_run(zip_path, tmp_path_factory):
    _need_bpy()
    out = tmp_path_factory.mktemp("addon")
    return out, _drive(out, [SIZE, "flagstone", "--all-ops"], zip_file=zip_path)


@pytest.mark.slow
def test_addon_installs_from_the_zip(installed_run):
    out, r = installed_run
    assert r["installed"]["module"] == "bl_ext.user_default.cellgl"
    # cellgl itself comes from the extension's wheel, in Blender's extension folder
    assert str(out / "blender-user" / "extensions") in r["installed"]["cellgl_file"]


@pytest.mark.slow
def test_addon_osl_and_image_branches_render_the_bake(installed_run):
    out, r = installed_run
    info = r["presets"]["flagstone"]
    assert info["add"] == info["bake"] == ["FINISHED"]
    assert info["outputs"] == ["Color", "Fac", "Normal", "Cell Color", "ID Low", "ID High"]
    assert "Frequency" in info["inputs"] and "Cell mix" in info["inputs"]
    meta = info["frequency_socket"]
    assert meta["min"] == pytest.approx(0.01) and meta["max"] == pytest.approx(4096.0)
    assert meta["default"] == pytest.approx(5.0) and "frequency" in meta["description"]
    assert not _compare(out, "flagstone", ("osl", "img"))


@pytest.mark.slow
def test_addon_operators_headless(installed_run):
    out, r = installed_run
    assert r["snippet_glsl"] == r["snippet_osl"] == ["FINISHED"]
    assert r["snippet_texts"]["glsl"].count("cellgl_texture") and "shader cellgl_flagstone" in r["snippet_texts"]["osl"]
    assert r["bake_command_text"] == ("cellgl bake flagstone -o flagstone.png --size 128 --set seed=3 "
                                      "--set frequency=7.0 --tileable")
    assert r["rebaked"]
    assert r["async_timer"] and r["async_status"] == "baked 96 x 96" and r["async_size"] == [96, 96]
    assert r["async_hash_ok"] and r["async_progress"][0] < 1.0
    from cellgl.texture import params

    # flagstone is Euclidean: its OSL shader folds Minkowski p away (no slider that does nothing);
    # an input the table calls inactive at the current values is greyed in the panel
    assert "Minkowski p" not in r["group_inputs"] and "Frequency" in r["group_inputs"]
    from cellgl.texture.presets import load_recipe

    dead = params.inactive(load_recipe("flagstone").values)
    assert "minkowski_p" in dead and "frequency" not in dead
    assert set(r["inactive"]) <= set(r["group_inputs"]) and "Frequency" not in r["inactive"]
    assert "cellgl bake failed" in r["error"] and "no-such-preset" in r["error"]
    assert "has no OSL export" in r["bad_preset"]
    assert r["voronoi"] == ["FINISHED"] and r["voronoi_linked"]
    assert r["voronoi_outputs"] == ["Distance", "Color", "Position", "W", "Radius"]
    for op, flags in r["undo_flags"].items():
        if op in ("cellgl.add_preset", "cellgl.bake_image", "cellgl.voronoi_exact"):
            assert flags == ["REGISTER", "UNDO"], op
    # the panel and the menus, drawn into a recording layout (the bpy module has no UI)
    panel = r["panel"]
    assert ["label", "Preset: flagstone", True] in panel
    assert ["operator", "cellgl.bake_image", None] in panel and ["prop", "rebake", True] in panel
    assert ["operator", "cellgl.copy_snippet", None] in panel
    assert ["operator", "cellgl.copy_bake_command", None] in panel
    assert ["prop", "Frequency", True] in panel
    if r["inactive"]:
        assert ["prop", "Minkowski p", False] in panel          # greyed
    assert r["add_hook"] == [["menu", "CELLGL_MT_add"]]
    assert [m[1] for m in r["add_menu"]] == ["CELLGL_MT_add_blender", "CELLGL_MT_add_qin_2000",
                                             "CELLGL_MT_add_textures", "CELLGL_MT_add_worley_basis"]
    assert r["family_menu"] == [["operator", "cellgl.add_preset", "blender-voronoi"]]
    assert r["menus"]["Qin 2000"][0] == "qin-cloud" and "flagstone" in r["menus"]["Textures"]
    assert sum(len(v) for v in r["menus"].values()) >= 25
    assert "cellgl flagstone Color" in r["packed"] and "cellgl flagstone Data" in r["packed"]
    # the Voronoi drop-in's Distance is cellgl.voronoi's at the pixel centres (y up)
    from cellgl.basis.voronoi import voronoi

    assert r["voronoi_inputs"] == ["Vector", "Scale", "Detail", "Roughness", "Lacunarity", "Randomness"]
    assert r["voronoi_rebake"] == ["FINISHED"]
    c = (np.arange(32) + 0.5) / 32
    x, y = np.meshgrid(c, 1.0 - c)
    pts = np.stack([x.ravel(), y.ravel()], 1).astype(np.float32)
    for scale, npy in ((4.0, "voronoi_distance.npy"), (6.0, "voronoi_distance6.npy")):
        want = voronoi(pts, dimensions=2, scale=scale).distance
        np.testing.assert_allclose(np.load(out / npy), want.reshape(32, 32), atol=1e-6)


@pytest.mark.slow
def test_addon_unregister_leaves_nothing(installed_run):
    _, r = installed_run
    reg = r["footprint_registered"]
    assert "CELLGL_OT_bake_image" in reg["classes"] and reg["settings"] and reg["handlers"]
    assert len(reg["menu_entries"]) == 2
    empty = {"classes": [], "settings": False, "menu_entries": [], "handlers": [], "timer": False, "ops": False}
    assert r["footprint_unregistered"] == empty
    assert r["reregistered"] and r["footprint_final"] == empty


@pytest.mark.slow
def test_addon_every_preset_both_branches(tmp_path):
    """Every exportable preset, added and baked by the add-on (registered from this tree), rendered
    through both branches: each equal to ``cellgl bake``."""
    _need_bpy()
    code = "from cellgl.blender.addon.groups import exportable_presets\nprint(' '.join(n for n, _ in exportable_presets()))"
    names = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                           check=True, timeout=300).stdout.split()
    _drive(tmp_path, [64, *names], timeout=3600)
    bad = [b for n in names for b in _compare(tmp_path, n, ("osl", "img"), 64)]
    assert not bad, "\n".join(bad)


@pytest.mark.slow
def test_addon_eevee_renders_the_image_branch(tmp_path):
    """EEVEE (headless: Mesa's llvmpipe through EGL) takes the image branch. What it can show
    exactly: the cell colours (an 8-bit image read with Closest). Its film is half float, so the
    IDs and Fac come back to half precision; its Linear image lookups go through the GPU's
    texture filtering (mipmaps), so the colour is the bake filtered (veins at 64 x 64: up to
    59/255, median 13/255; with the Color node set to Closest EEVEE gives the bake within 1/255,
    measured once; Cycles' lookups of the Linear image are exact)."""
    _need_bpy()
    import cellgl
    from cellgl.bake.core import bake
    from cellgl.io.spec import id_colors

    _drive(tmp_path, [64, "veins", "--eevee"], timeout=1800)
    ref = cellgl.render("veins", 64, 64, channels=("id", "height"))
    ids = ref["id"].astype(np.uint32)
    cell = np.round(_read_exr(tmp_path / "veins.eevee.cell.exr") * 255).astype(np.int64)
    assert np.count_nonzero(np.any(cell != id_colors(ids), axis=-1)) == 0
    idf = _read_exr(tmp_path / "veins.eevee.id.exr").astype(np.float64)
    for got, want in ((idf[..., 0], ids & 0xFFFF), (idf[..., 1], ids >> 16)):
        assert np.all(np.abs(got - want) <= np.maximum(want, 1) * 2.0 ** -10)
    assert np.abs(idf[..., 2] - ref["height"]).max() < 4e-3
    bake("veins", str(tmp_path / "bake.png"), size=64, progress=False)
    want = np.asarray(Image.open(tmp_path / "bake.png").convert("RGB"), np.int16)
    got = np.asarray(Image.open(tmp_path / "veins.eevee.png").convert("RGB"), np.int16)
    assert np.median(np.abs(got - want).max(-1)) <= 20 and got.std() > 20
