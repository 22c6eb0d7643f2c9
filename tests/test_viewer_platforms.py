"""The viewer on OpenGL 4.3+, Apple's 4.1 core (no compute shaders) and 3.3 core: the same pixels.

Mesa emulates the smaller contexts here (``MESA_GL_VERSION_OVERRIDE=4.1FC`` and friends, as on
a Mac; ``3.3FC``). Each configuration runs in a child process under a display (``$DISPLAY`` or
an Xvfb started here) and captures the viewer's own rendering of several views (2D texture,
3x3 tiles, the 3D object, a cell image and a density image, which read storage buffers from
GLSL 4.30 and integer textures below it) with the panel hidden. Nothing here calls compute:
a hidden capture makes no readout, so these screenshots check the viewer alone.

The value under the cursor and the bake / snippet buttons call the public API, which runs on the
fragment path without compute shaders: :func:`test_readout_and_actions_match_gl43` compares them
across the same configurations (it skips, naming why, in a tree whose compute entry points have
no fragment path yet, unless ``CELLGL_REQUIRE_GPU=1``).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from tiers import quick_few
from xvfb import require_gpu, some_display, xvfb_display

pytest.importorskip("imgui_bundle")
pytest.importorskip("glfw")

REPO = Path(__file__).resolve().parent.parent
SUNSET = REPO / "cellgl" / "presets" / "images" / "sunset.png"

#: name -> (preset, mode, --set assignments)
CASES = {
    "flagstone-2d": ("flagstone", "2d", []),
    "flagstone-tiled": ("flagstone", "tiled", []),
    "flagstone-3d": ("flagstone", "3d", []),
    "stained-glass": ("stained-glass", "2d", []),
    "density-image": ("flagstone", "2d", [("density_image", str(SUNSET)), ("density_map", "image"),
                                          ("min_points", "0")]),
}

#: GL configurations: name -> Mesa environment (empty: the context as it comes, 4.3 or later)
CONFIGS = {
    "native": {},
    # the context as it comes, with the fragment path forced: storage words from textures at 430
    "fragment": {"CELLGL_PATH": "fragment"},
    "4.1core": {"MESA_GL_VERSION_OVERRIDE": "4.1FC", "MESA_GLSL_VERSION_OVERRIDE": "410",
                "MESA_EXTENSION_OVERRIDE": "-GL_ARB_compute_shader"},
    "3.3core": {"MESA_GL_VERSION_OVERRIDE": "3.3FC", "MESA_GLSL_VERSION_OVERRIDE": "330",
                "MESA_EXTENSION_OVERRIDE": "-GL_ARB_compute_shader"},
}

_CHILD = r"""
import json, sys
from cellgl.viewer.app import Viewer, ViewerOptions
out, cases = sys.argv[1], json.loads(sys.argv[2])
report = {}
for name, (preset, mode, sets) in cases.items():
    v = Viewer(ViewerOptions(recipe=preset, mode=mode, size=(96, 96), sets=sets, panel=False,
                             hidden=True))
    try:
        v.capture(f"{out}/{name}.png", frames=2)
        report[name] = {"gl": v.ctx.version_code, "status": v.status}
    finally:
        v.close()
print(json.dumps(report))
"""


@pytest.fixture(scope="module")
def display():
    with some_display() as disp:
        yield disp


def _run_child(args, env) -> subprocess.CompletedProcess:
    """``python -c ARGS...`` under ``env``; once more on a fresh Xvfb when the display went away
    (on a shared machine another process's X server can take or drop a display number)."""
    def run(env):
        return subprocess.run([sys.executable, "-c", *args], cwd=REPO, env=env,
                              capture_output=True, text=True, timeout=600)

    r = run(env)
    if r.returncode != 0 and "Failed to open display" in r.stderr and not os.environ.get("DISPLAY"):
        with xvfb_display() as disp:
            if disp is not None:
                r = run({**env, "DISPLAY": disp})
    return r


def _env(display: str, config: str) -> dict:
    env = dict(os.environ, DISPLAY=display, PYTHONPATH=str(REPO))
    for key in ("CELLGL_PATH", "CELLGL_BACKEND"):
        env.pop(key, None)
    env.update(CONFIGS[config])
    return env


def _once_each(run):
    """``get(*configs)``: ``run(config)`` for each configuration, once per module, the missing
    ones at once (a test that needs the native context and another waits for one child's time)."""
    cache: dict = {}

    def get(*configs):
        missing = [c for c in configs if c not in cache]
        if missing:
            with ThreadPoolExecutor(len(missing)) as pool:
                cache.update(zip(missing, pool.map(run, missing)))
        return [cache[c] for c in configs]
    return get


@pytest.fixture(scope="module")
def shots(display, tmp_path_factory):
    """``shots(*configs)``: per configuration, {case: (H, W, 3) uint8 screenshot} and the child's
    report."""
    from PIL import Image

    def run(config):
        out = tmp_path_factory.mktemp(config.replace(".", "_"))
        r = _run_child([_CHILD, str(out), json.dumps(CASES)], _env(display, config))
        assert r.returncode == 0, f"{config}: {r.stderr[-3000:]}"
        report = json.loads(r.stdout.strip().splitlines()[-1])
        return {name: np.asarray(Image.open(out / f"{name}.png").convert("RGB")) for name in CASES}, report
    return _once_each(run)


#: the configurations compared with the native context; the default tier runs the one furthest
#: from it (3.3 core: no storage buffers in GLSL, no compute), the slow tier every one
OTHERS = quick_few(["fragment", "4.1core", "3.3core"], ["3.3core"])
GL = {"native": None, "fragment": None, "4.1core": 410, "3.3core": 330}


@pytest.mark.parametrize("config", quick_few(list(CONFIGS), ["native", "3.3core"]))
def test_contexts_are_the_ones_emulated(shots, config):
    [(_, report)] = shots(config)
    if GL[config] is None:
        assert all(r["gl"] >= 430 for r in report.values())
    else:
        assert all(r["gl"] == GL[config] for r in report.values())


@pytest.mark.parametrize("config", OTHERS)
@pytest.mark.parametrize("case", list(CASES))
def test_same_pixels_as_on_gl43(shots, config, case):
    (native, _), (images, _) = shots("native", config)
    ref, got = native[case], images[case]
    assert ref.shape == got.shape == (96, 96, 3)
    # a real picture, not a cleared target
    assert len(np.unique(ref.reshape(-1, 3), axis=0)) > 8, case
    diff = np.abs(ref.astype(int) - got.astype(int))
    assert diff.max() == 0, f"{case} on {config}: {np.count_nonzero(diff.any(-1))} pixels differ"


_ACTIONS_CHILD = r"""
import json, sys
from cellgl.viewer import actions
from cellgl.viewer.app import Viewer, ViewerOptions
out = sys.argv[1]
v = Viewer(ViewerOptions(recipe="flagstone", size=(96, 96), panel=False, hidden=True))
try:
    v.frame()
    report = {"uv": [v.model.readout_uv(u, t) for u, t in ((0.3, 0.4), (0.71, 0.05), (0.5, 0.99))],
              "object": v.model.readout_object((0.2, -0.5, 0.8))}
    report["bake"] = [str(p) for p in actions.bake(v, f"{out}/bake.png", size=32)]
    actions.save_snippet(v, f"{out}/snippet.glsl")
    v.set_mode("3d")
    v.frame()
    report["pos"] = v.renderer.object_position_at(48, 48).tolist()
finally:
    v.close()
print(json.dumps(report))
"""

#: what a compute entry point says on a context without compute shaders in a tree without the
#: fragment path (issue 29, part 2)
_NO_FRAGMENT_PATH = ".comp: cannot create shader"


@pytest.fixture(scope="module")
def actions(display, tmp_path_factory):
    """``actions(*configs)``: per configuration, the readouts, bake bytes, snippet and 3D position
    the viewer's child gives, or the reason to skip it."""
    def run(config):
        out = tmp_path_factory.mktemp("actions_" + config.replace(".", "_"))
        r = _run_child([_ACTIONS_CHILD, str(out)], _env(display, config))
        if r.returncode != 0 and config != "native" and _NO_FRAGMENT_PATH in r.stderr and not require_gpu():
            return (f"{config}: the compute entry points have no fragment path in this tree "
                    f"({r.stderr.strip().splitlines()[-1]})")
        assert r.returncode == 0, f"{config}: {r.stderr[-3000:]}"
        report = json.loads(r.stdout.strip().splitlines()[-1])
        report["bake_bytes"] = (out / "bake.png").read_bytes()
        report["snippet"] = (out / "snippet.glsl").read_text()
        return report
    return _once_each(run)


@pytest.mark.parametrize("config", OTHERS)
def test_readout_and_actions_match_gl43(actions, config):
    ref, got = actions("native", config)
    if isinstance(got, str):
        pytest.skip(got)
    assert ref["uv"][0]["F"] and ref["uv"][0]["id"] is not None
    assert got["uv"] == ref["uv"], config          # the same bits: F, id
    assert got["object"] == ref["object"], config
    assert got["bake_bytes"] == ref["bake_bytes"], config
    assert got["snippet"] == ref["snippet"], config
    assert got["pos"] == ref["pos"], config
