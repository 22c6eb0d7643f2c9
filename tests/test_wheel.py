"""The wheel ships the shaders: build it, install it in a clean venv, resolve shaders from there."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
SHADER_SUFFIXES = (".comp", ".frag", ".vert", ".glsl")

pytestmark = pytest.mark.slow


def _run(cmd, cwd, timeout=600, env=None, check=True):
    r = subprocess.run([str(c) for c in cmd], cwd=cwd, capture_output=True, text=True,
                       timeout=timeout, env=env)
    if check and r.returncode != 0:
        pytest.fail(f"{' '.join(map(str, cmd))} failed ({r.returncode}):\n{r.stdout}\n{r.stderr}")
    return r


def _source_shaders() -> list[str]:
    root = REPO / "shaders"
    return sorted(p.relative_to(root).as_posix() for p in root.rglob("*")
                  if p.is_file() and p.suffix in SHADER_SUFFIXES)


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    tmp = tmp_path_factory.mktemp("wheel")
    # Build from a copy: an in-tree build writes build/ and *.egg-info into the shared checkout.
    src = tmp / "src"
    shutil.copytree(REPO, src, ignore=shutil.ignore_patterns(
        ".git", ".venv", "build", "dist", "*.egg-info", "__pycache__", ".pytest_cache", "out"))
    dist = tmp / "dist"
    _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q",
          "-w", dist, src], cwd=tmp)
    wheels = list(dist.glob("cellgl-*.whl"))
    assert len(wheels) == 1, wheels
    return wheels[0]


def test_wheel_contains_shaders(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    assert "cellgl/gl/glsl.py" in names and "cellgl/gl/context.py" in names
    expected = _source_shaders()
    missing = [rel for rel in expected if f"cellgl/shaders/{rel}" not in names]
    assert not missing, f"shader files missing from the wheel: {missing}"
    if any(rel.startswith("lib/") for rel in expected):
        assert any(n.startswith("cellgl/shaders/lib/") and n.endswith(".glsl") for n in names)
    if any(rel.endswith(".comp") for rel in expected):
        assert any(n.startswith("cellgl/shaders/") and n.endswith(".comp") for n in names)


def test_wheel_ships_the_licence(wheel):
    """The MIT text itself (pyproject's license-files), not only the SPDX name in the metadata."""
    z = zipfile.ZipFile(wheel)
    lic = [n for n in z.namelist() if n.endswith(".dist-info/licenses/LICENSE")]
    assert len(lic) == 1, [n for n in z.namelist() if "dist-info" in n]
    assert z.read(lic[0]) == (REPO / "LICENSE").read_bytes()
    meta = next(n for n in z.namelist() if n.endswith(".dist-info/METADATA"))
    text = z.read(meta).decode()
    assert "License-Expression: MIT" in text and "License-File: LICENSE" in text


def test_wheel_ships_the_preset_images(wheel):
    """A preset's image (stained-glass's cell image) comes with it."""
    names = set(zipfile.ZipFile(wheel).namelist())
    folder = Path(__file__).resolve().parents[1] / "cellgl" / "presets" / "images"
    images = sorted(p.name for p in folder.glob("*.png"))
    assert images and all(f"cellgl/presets/images/{n}" in names for n in images)


def test_wheel_ships_the_octave_means(wheel):
    """The presets' octave means (cellgl.texture.means): without them every preset's render
    would measure its mean with NumPy again."""
    z = zipfile.ZipFile(wheel)
    table = REPO / "cellgl" / "texture" / "octave_means.json"
    assert z.read("cellgl/texture/octave_means.json") == table.read_bytes()


def test_wheel_installs_the_viewer_inside_cellgl(wheel):
    """The source folder viewer/ is the package cellgl.viewer: no top-level `viewer` in
    site-packages, where another package of that name would collide (issue 42)."""
    names = set(zipfile.ZipFile(wheel).namelist())
    expected = sorted(p.name for p in (REPO / "viewer").glob("*.py"))
    assert expected and all(f"cellgl/viewer/{n}" in names for n in expected), \
        sorted(n for n in names if "viewer" in n)
    tops = {n.split("/")[0] for n in names}
    assert tops == {"cellgl", next(t for t in tops if t.endswith(".dist-info"))}, tops


@pytest.fixture(scope="module")
def installed(wheel, tmp_path_factory) -> Path:
    """A clean venv with the wheel installed (shared by the tests below); returns the venv."""
    tmp = tmp_path_factory.mktemp("installed")
    venv = tmp / "venv"
    _run([sys.executable, "-m", "venv", venv], cwd=tmp, timeout=300)
    _run([venv / "bin" / "python", "-m", "pip", "install", "-q", "--disable-pip-version-check",
          wheel], cwd=tmp, timeout=600)
    return venv


def test_installed_wheel_resolves_shaders(installed, tmp_path):
    venv = installed
    py = venv / "bin" / "python"

    # Run from outside the repo with a clean environment, so only site-packages can answer.
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    code = (
        "import cellgl.gl.glsl as g\n"
        "print(g.shader_dir())\n"
        "for p in sorted(g.shader_dir().glob('*.comp')):\n"
        "    src = g.load(p.name)\n"
        "    assert '#include' not in src.text, p\n"
        "    print('resolved', p.name, len(src.files))\n"
    )
    r = _run([py, "-c", code], cwd=outside, env=env)
    lines = r.stdout.splitlines()
    shader_dir = Path(lines[0])
    assert "site-packages" in shader_dir.parts, shader_dir
    assert REPO not in shader_dir.parents
    assert shader_dir.is_dir()
    expected = _source_shaders()
    found = sorted(p.relative_to(shader_dir).as_posix() for p in shader_dir.rglob("*")
                   if p.is_file() and p.suffix in SHADER_SUFFIXES)
    assert found == expected
    assert len([x for x in lines if x.startswith("resolved ")]) == \
        len([x for x in expected if "/" not in x and x.endswith(".comp")])

    # The viewer is cellgl.viewer (its arguments import without the [viewer] extra's GUI
    # libraries), and there is no top-level `viewer`.
    code = ("import importlib.util, cellgl.viewer.cli as c\n"
            "print(c.__file__)\n"
            "print(importlib.util.find_spec('viewer'))\n")
    r = _run([py, "-c", code], cwd=outside, env=env)
    viewer_cli, top_viewer = r.stdout.splitlines()
    assert Path(viewer_cli).parent == shader_dir.parent / "viewer", viewer_cli
    assert top_viewer == "None"
    r = _run([venv / "bin" / "cellgl", "view", "--help"], cwd=outside, env=env)
    assert "--screenshot" in r.stdout

    # The console script works from the installed wheel too (needs a GL 4.3 context).
    r = _run([venv / "bin" / "cellgl", "info"], cwd=outside, env=env, check=False)
    if r.returncode != 0:
        if os.environ.get("CELLGL_REQUIRE_GPU") == "1":
            pytest.fail(f"cellgl info failed from the installed wheel:\n{r.stderr}")
        pytest.skip(f"no GL context for `cellgl info`: {r.stderr.strip()}")
    assert "GL_RENDERER: " in r.stdout


def test_installed_wheel_bakes_a_preset(installed, tmp_path):
    """README's first command, `cellgl bake flagstone -o flagstone.png`, from the wheel alone."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    r = _run([installed / "bin" / "cellgl", "bake", "flagstone", "-o", "flagstone.png",
              "--size", "48x32", "--quiet"], cwd=outside, env=env, check=False)
    if r.returncode != 0 and "context" in r.stderr.lower() and \
            os.environ.get("CELLGL_REQUIRE_GPU") != "1":
        pytest.skip(f"no GL context for `cellgl bake`: {r.stderr.strip()}")
    assert r.returncode == 0, r.stderr
    assert sorted(p.name for p in outside.iterdir()) == ["flagstone.png"]
    import numpy as np
    from PIL import Image

    with Image.open(outside / "flagstone.png") as im:
        assert im.size == (48, 32) and im.mode == "RGB"
        pixels = np.asarray(im).reshape(-1, 3)
    assert len(np.unique(pixels, axis=0)) > 16  # a texture, not a flat fill
