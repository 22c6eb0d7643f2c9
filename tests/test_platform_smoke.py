"""Platform smoke suite: what a user on Linux, Windows or macOS does first, end to end.

The CI workflow ``.github/workflows/platforms.yml`` runs this file on hosted Linux, Windows (Mesa
llvmpipe's ``opengl32.dll``) and macOS (Apple's OpenGL 4.1 core) runners; it runs here with the
rest of the suite, and under Mesa's 4.1 core / 3.3 core emulation with, e.g.::

    MESA_GL_VERSION_OVERRIDE=4.1FC MESA_GLSL_VERSION_OVERRIDE=410 \\
    MESA_EXTENSION_OVERRIDE=-GL_ARB_compute_shader pytest tests/test_platform_smoke.py

- the context is the platform's own (WGL, CGL, EGL) and `cellgl info` says which path runs;
- ``cellgl.cellular`` agrees with the NumPy reference;
- ``cellgl bake`` writes the same bytes twice, and the exported GLSL snippets reproduce the bake;
- the viewer's fragment program (``render_fragment``) runs without a display, and
  ``cellgl view --screenshot`` runs where a display exists (``$DISPLAY``, an Xvfb started here,
  or any Windows/macOS desktop session; ``CELLGL_SMOKE_VIEWER=1`` makes a missing one a failure).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import cellgl
from cellgl.gl import context, path, platforms
from test_export import render_snippet

REPO = Path(__file__).resolve().parent.parent


def _cli(*args, env=None, timeout=600) -> subprocess.CompletedProcess:
    full = dict(os.environ, PYTHONPATH=str(REPO), **(env or {}))
    return subprocess.run([sys.executable, "-m", "cellgl", *args], cwd=REPO, env=full,
                          capture_output=True, text=True, timeout=timeout)


def test_context_is_the_platforms_own(ctx):
    info = context.context_info(ctx)
    assert info["backend"] in platforms.platform_backends()
    if not os.environ.get("CELLGL_BACKEND") and platforms.platform() != "linux":
        assert info["backend"] == platforms.platform_backends()[0]   # wgl / cgl
    assert ctx.version_code >= context.REQUIRED_GL
    assert info["path"] == path.gpu_path(ctx) in path.PATHS
    if path.forced_path() is None:
        assert (info["path"] == "compute") == (ctx.version_code >= 430)


def test_cli_info(ctx):
    r = _cli("info")
    assert r.returncode == 0, r.stderr
    lines = dict(line.split(": ", 1) for line in r.stdout.splitlines())
    assert lines["backend"] == context.backend_name(ctx)
    assert lines["path"] == path.gpu_path(ctx)
    assert lines["GL_RENDERER"] and lines["GL_VERSION"]


def test_cellular_agrees_with_numpy(ctx):
    rng = np.random.default_rng(29)
    pts = rng.uniform(-40.0, 40.0, size=(512, 3))
    gpu = cellgl.cellular(pts, 3, outputs=("F", "id"), seed=7)
    ref = cellgl.cellular(pts, 3, outputs=("F", "id"), seed=7, backend="numpy")
    np.testing.assert_array_equal(gpu.id, ref.id)
    np.testing.assert_allclose(gpu.F, ref.F, rtol=1e-5, atol=1e-5)


def test_bake_writes_the_same_bytes_twice(ctx, tmp_path):
    from PIL import Image

    outs = []
    for k in range(2):
        out = tmp_path / f"flagstone{k}.png"
        r = _cli("bake", "flagstone", "-o", str(out), "--size", "64")
        assert r.returncode == 0, r.stderr
        outs.append(out.read_bytes())
    assert outs[0] == outs[1]
    img = np.asarray(Image.open(tmp_path / "flagstone0.png"))
    assert img.shape[:2] == (64, 64) and len(np.unique(img.reshape(-1, img.shape[-1]), axis=0)) > 16


@pytest.mark.parametrize("target", ["glsl", "gles"])
def test_snippet_reproduces_the_bake(ctx, target):
    from cellgl import texture
    from cellgl.export.snippets import export

    if target == "gles":
        pytest.importorskip("cellgl.export.translate")
    text = export("flagstone", target)
    code = text.split("\n\n", 1)[1]
    if target == "gles":   # GLSL ES 3.00 code compiles as desktop GLSL 3.30 minus its precision lines
        code = "\n".join(line for line in code.splitlines() if not line.startswith("precision "))
    W, H = 48, 32
    got = render_snippet(ctx, code, W, H)
    ref = texture.render("flagstone", W, H, channels=("color",))["color"]
    np.testing.assert_allclose(got, ref, rtol=0, atol=2e-5)


def test_viewer_program_runs_headless(ctx):
    """``shaders/texture.frag`` (the viewer's 2D view) at the context's GLSL version."""
    from cellgl.texture.evaluation import render_fragment

    img = render_fragment("stained-glass", 48, 48)
    assert img.shape == (48, 48, 4) and np.isfinite(img).all()
    assert len(np.unique(img[..., :3].reshape(-1, 3), axis=0)) > 8
    context.check_gl_error(ctx)


def _display():
    """A display for the viewer, as a context manager yielding env overrides or None."""
    import contextlib

    @contextlib.contextmanager
    def none_needed():
        yield {}

    if platforms.platform() != "linux" or os.environ.get("DISPLAY"):
        return none_needed()
    sys.path.insert(0, str(Path(__file__).parent))
    from xvfb import xvfb_display

    @contextlib.contextmanager
    def xvfb():
        with xvfb_display() as disp:
            yield None if disp is None else {"DISPLAY": disp}
    return xvfb()


def test_viewer_screenshot(tmp_path):
    pytest.importorskip("glfw")
    pytest.importorskip("imgui_bundle")
    from PIL import Image

    required = os.environ.get("CELLGL_SMOKE_VIEWER", "").strip() in ("1", "true", "yes")
    if platforms.platform() == "linux" and not os.environ.get("DISPLAY") and not shutil.which("Xvfb"):
        if required:
            pytest.fail("CELLGL_SMOKE_VIEWER=1 but no DISPLAY and no Xvfb", pytrace=False)
        pytest.skip("no display for the viewer")
    out = tmp_path / "view.png"
    with _display() as env:
        if env is None:
            pytest.skip("Xvfb did not start")
        r = _cli("view", "flagstone", "--no-panel", "--size", "96x96", "--screenshot", str(out),
                 env=env)
    if r.returncode != 0 and not required and "GLFW could not" in r.stderr:
        pytest.skip(f"no window here: {r.stderr.strip()}")
    assert r.returncode == 0, r.stderr
    img = np.asarray(Image.open(out).convert("RGB")).astype(np.float64) / 255.0
    assert img.shape == (96, 96, 3)
    assert len(np.unique(img.reshape(-1, 3), axis=0)) > 16
    # the flagstone texture (the unit square fills the view), not a cleared window
    from cellgl import texture

    bake = texture.render("flagstone", 96, 96, channels=("color",))["color"][..., :3]
    assert np.abs(img.mean(axis=(0, 1)) - bake.mean(axis=(0, 1))).max() < 0.05
