"""The interactive viewer under X (Xvfb): window, ImGui input path, view modes, capture.

A display is needed: ``$DISPLAY`` if set, else an Xvfb this module starts. Without either
the tests skip, unless ``CELLGL_REQUIRE_GPU=1`` (``.ci/run``), which makes that a failure.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

import cellgl
from xvfb import some_display, unavailable

pytest.importorskip("imgui_bundle")
pytest.importorskip("glfw")

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SIZE = (704, 352)          # panel 360 px + a 344 x 352 view (unit square 344 px)



def _preset():
    from cellgl.recipes import list_presets

    names = [n for n, _ in list_presets()]
    return "flagstone" if "flagstone" in names else (names[0] if names else None)


PRESET = _preset()


@pytest.fixture(scope="module")
def display():
    """A usable X display: $DISPLAY, or an Xvfb started here (stopped afterwards)."""
    with some_display(export=True) as disp:
        yield disp


@pytest.fixture(scope="module")
def viewer(display):
    from cellgl.viewer.app import Viewer, ViewerOptions

    try:
        v = Viewer(ViewerOptions(recipe=PRESET, size=SIZE, hidden=True))
    except RuntimeError as exc:
        unavailable(f"no OpenGL window: {exc}")
    yield v
    v.close()


def _settle(v, frames=2):
    for _ in range(frames):
        v.frame()
    while v.renderer.needs_refine:
        v.frame()


def _view(v, img):
    x, y, w, h = v.view_rect
    return img[y:y + h, x:x + w]


def _reset(v, preset=PRESET):
    v.load(preset)
    v.set_mode("2d")
    v.panzoom.fitted = False
    v.channel = "color"
    _settle(v)


def _drag(v, name, frac0, frac1, steps=6):
    """Press on widget ``name`` at fraction frac0 of its width, drag to frac1, release."""
    v.scroll_to = name
    v.frame()
    v.frame()
    x0, y0, x1, y1 = v.widget_rects[name]
    assert 0 <= y0 and y1 <= v.size[1], f"widget {name} is not on screen: {v.widget_rects[name]}"
    y = (y0 + y1) / 2
    xa, xb = x0 + frac0 * (x1 - x0), x0 + frac1 * (x1 - x0)
    events = [(xa, y, False), (xa, y, True)]
    events += [(xa + (xb - xa) * k / steps, y, True) for k in range(1, steps + 1)]
    # release, then rest in the panel beside the widget (over the view the readout grows a line
    # and moves the panel under the next drag)
    events += [(xb, y, False), (v.view_rect[0] - 4, y, False)]
    scales = []
    for ev in events:
        v.script_mouse([ev])
        v.frame()
        scales.append(v.renderer.last_scale)
    return scales


# --------------------------------------------------------------------------------------------


def test_window_renders_texture(viewer):
    _reset(viewer)
    img = viewer.grab()
    assert img.shape == (SIZE[1], SIZE[0], 3)
    view = _view(viewer, img)
    assert view.std() > 10, "the view is flat: nothing rendered"
    assert viewer.ctx.error == "GL_NO_ERROR"


def test_view_matches_offscreen_render(viewer):
    """The 2D view's unit square equals cellgl.texture.render of the same recipe (8-bit)."""
    _reset(viewer)
    x, y, w, h = viewer.unit_square_rect()
    assert w == h == min(viewer.view_rect[2:])
    got = viewer.grab()[y:y + h, x:x + w].astype(int)
    ref = cellgl.render(viewer.model.recipe, w, h)["color"][..., :3]
    ref = np.round(np.clip(ref, 0, 1) * 255).astype(int)
    diff = np.abs(got - ref)
    # Pixel centres on a cell border may land on either side by a float ulp: allow a few.
    assert np.mean(diff.max(axis=-1) <= 2) > 0.995, f"max diff {diff.max()}, mean {diff.mean():.3f}"


def test_slider_drag_changes_recipe_and_frame(viewer):
    _reset(viewer)
    viewer.renderer.budget = 1e-4  # force the reduced-resolution preview while dragging
    before = viewer.grab()
    name = "jitter" if viewer.model.get("distribution") == "jitter" else "density"
    value0 = viewer.model.get(name)
    compiles0 = viewer.renderer.compiles
    v0 = viewer.model.version
    scales = _drag(viewer, name, 0.25, 0.75)
    try:
        assert viewer.model.get(name) != value0, f"dragging the {name} slider did not change it"
        assert viewer.model.version > v0
        assert max(scales) > 1, "no reduced-resolution preview while the slider was dragged"
        _settle(viewer)
        assert viewer.renderer.last_scale == 1, "not refined after the slider was released"
        after = viewer.grab()
        assert np.abs(_view(viewer, after).astype(int) - _view(viewer, before)).max() > 30
        # A uniform only: no shader was compiled.
        assert viewer.renderer.compiles == compiles0
    finally:
        viewer.renderer.budget = None


def test_recompile_only_on_compile_time_change(viewer):
    _reset(viewer)
    c0 = viewer.renderer.compiles
    viewer.model.set("gain", 0.37)
    _settle(viewer)
    assert viewer.renderer.compiles == c0
    metric = viewer.model.get("metric")
    viewer.model.set("metric", "manhattan" if metric != "manhattan" else "euclidean")
    _settle(viewer)
    assert viewer.renderer.compiles == c0 + 1
    viewer.model.set("metric", metric)  # back: cached program, no compile
    _settle(viewer)
    assert viewer.renderer.compiles == c0 + 1


def test_pan_and_zoom_through_imgui_io(viewer):
    _reset(viewer)
    x, y, w, h = viewer.view_rect
    cx, cy = x + w / 2, y + h / 2
    o0 = viewer.panzoom.origin
    viewer.script_mouse([(cx, cy, False), (cx, cy, True), (cx + 20, cy + 10, True), (cx + 40, cy + 20, True),
                         (cx + 40, cy + 20, False)])
    for _ in range(5):
        viewer.frame()
    assert viewer.panzoom.origin == pytest.approx((o0[0] + 40, o0[1] + 20))
    _reset(viewer)


def test_readout_matches_shown_texture(viewer):
    """F1 / ID under the cursor equal the F1 / id channels of a render at that pixel."""
    _reset(viewer)
    x, y, w, h = viewer.unit_square_rect()
    px, py = 57, 101
    viewer.script_mouse([(x + px + 0.5, y + py + 0.5, False)])
    viewer.frame()
    r = viewer.readout
    assert r and "F" in r, r
    assert r["uv"] == pytest.approx(((px + 0.5) / w, (py + 0.5) / h))
    ref = cellgl.render(viewer.model.recipe, w, h, channels=("F1", "id"), x0=px, y0=py, tile_w=1, tile_h=1)
    assert r["F"][0] == pytest.approx(float(ref["F1"][0, 0]), abs=1e-4)
    assert r["id"] == int(ref["id"][0, 0])
    viewer.script_mouse([(5, 5, False)])
    viewer.frame()


def test_density_image_recipe_is_shown_as_baked(viewer, tmp_path):
    """A density-image recipe: the 2D view binds the image (the texture.frag hook) and shows the
    bake; the readout follows the map too."""
    import json

    import numpy as np
    from PIL import Image
    img = np.zeros((4, 4), np.uint8)
    img[:, 2:] = 255                                    # dense right half
    Image.fromarray(img).save(tmp_path / "map.png")
    d = {"name": "dimg", "basis": {"density_map": "image", "density_image": "map.png", "min_points": 0,
                                   "max_points": 16, "density_min": 0.4, "density_max": 10.0},
         "combination": {"linear": [-1, 1], "range_lo": 0.0, "range_hi": 0.6}}
    (tmp_path / "dimg.json").write_text(json.dumps(d))
    _reset(viewer, str(tmp_path / "dimg.json"))
    x, y, w, h = viewer.unit_square_rect()
    got = viewer.grab()[y:y + h, x:x + w].astype(np.float64) / 255.0     # before any other GL work
    ref = cellgl.render(viewer.model.recipe, w, h, channels=("color", "F1", "id"))
    close = np.all(np.abs(got - ref["color"][..., :3]) < 2.5 / 255, axis=-1)
    assert close.mean() > 0.97
    px, py = w - 20, h // 2                              # on the dense side
    viewer.script_mouse([(x + px + 0.5, y + py + 0.5, False)])
    viewer.frame()
    r = viewer.readout
    assert r["F"][0] == pytest.approx(float(ref["F1"][py, px]), abs=1e-4)
    assert r["id"] == int(ref["id"][py, px])
    viewer.script_mouse([(5, 5, False)])
    viewer.frame()
    _reset(viewer)


@pytest.mark.parametrize("mode", ["2d", "3d", "tiled", "anim"])
def test_view_modes(viewer, mode, tmp_path):
    _reset(viewer)
    viewer.set_mode(mode)
    if mode == "anim":
        viewer.playing = False
        viewer.model.set("time", 0.0)
    _settle(viewer)
    img = viewer.grab()
    view = _view(viewer, img)
    assert view.std() > 10
    if mode == "anim":
        viewer.model.set("time", 0.5)
        _settle(viewer)
        assert np.abs(_view(viewer, viewer.grab()).astype(int) - view).max() > 30, "time did not animate"
    if mode == "3d":
        # The readout under the centre of the object is a basis value.
        x, y, w, h = viewer.view_rect
        viewer.script_mouse([(x + w / 2, y + h / 2, False)])
        viewer.frame()
        assert viewer.readout and len(viewer.readout["F"]) == 4
    path = viewer.screenshot(str(tmp_path / f"{mode}.png"))
    assert os.path.getsize(path) > 1000
    assert viewer.ctx.error == "GL_NO_ERROR"
    _reset(viewer)


def test_screenshot_never_creates_a_folder(viewer, tmp_path):
    """The panel's screenshot (viewer.screenshot) follows the rule of every command's output: a
    missing folder is named, not created; nothing is left behind."""
    target = tmp_path / "missing" / "x.png"
    with pytest.raises(ValueError, match="missing"):
        viewer.screenshot(str(target))
    assert not (tmp_path / "missing").exists()
    path = viewer.screenshot(str(tmp_path / "x.png"))
    assert os.listdir(tmp_path) == ["x.png"] and os.path.getsize(path) > 1000


def test_saved_recipe_bakes_identically(viewer, tmp_path):
    """Edit, save from the viewer, bake with `cellgl bake`: the bake equals the view."""
    from PIL import Image

    from cellgl.viewer import actions

    _reset(viewer)
    viewer.model.set("seed", 4242)
    _settle(viewer)
    x, y, w, h = viewer.unit_square_rect()
    shown = viewer.grab()[y:y + h, x:x + w].astype(int)
    path = actions.save_recipe(viewer, str(tmp_path / "edited.json"))
    out = tmp_path / "edited.png"
    env = dict(os.environ, PYTHONPATH=ROOT)
    subprocess.run([sys.executable, "-m", "cellgl", "bake", path, "-o", str(out), "--size", f"{w}x{h}"],
                   check=True, env=env, cwd=str(tmp_path), capture_output=True, timeout=300)
    baked = np.asarray(Image.open(out).convert("RGB")).astype(int)
    assert baked.shape == shown.shape
    assert np.mean(np.abs(baked - shown).max(axis=-1) <= 2) > 0.995
    from cellgl.recipes import load_recipe

    assert load_recipe(path) == viewer.model.recipe


def test_cli_screenshot(display, tmp_path):
    out = tmp_path / "shot.png"
    env = dict(os.environ, PYTHONPATH=ROOT)
    preset = [PRESET] if PRESET else []
    r = subprocess.run([sys.executable, "-m", "cellgl", "view", *preset, "--screenshot", str(out),
                        "--frames", "2", "--size", "512x384", "--set", "seed=7", "--mode", "tiled"],
                       env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    from PIL import Image

    im = Image.open(out)
    assert im.size == (512, 384)
    r = subprocess.run([sys.executable, "-m", "cellgl", "view", *preset, "--screenshot", str(out),
                        "--set", "no_such_param=1"], env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 2 and "no_such_param" in r.stderr


def test_no_display_is_one_clear_error():
    """Without a display: one `cellgl view: error:` line with GLFW's reason, no GLFWError warning."""
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env["PYTHONPATH"] = ROOT
    r = subprocess.run([sys.executable, "-m", "cellgl", "view", "flagstone"], env=env, capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 2, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, r.stderr
    assert lines[0].startswith("cellgl view: error: GLFW could not initialise (") and "DISPLAY" in lines[0]
    assert "xvfb-run" in lines[0]


def test_pups_preset_view_matches_bake(viewer):
    """A PUPs preset from the picker: the 2D view's unit square is the bake of that size;
    3D / 4D are refused with a message; the panel shows the PUPs table's widgets."""
    assert "pups-cow" in viewer.model.presets()
    _reset(viewer, "pups-cow")
    assert viewer.model.is_pups
    assert {p.name for p in viewer.model.params} >= {"seed", "radius", "epsilon", "labels"}
    _settle(viewer)
    assert any(k in viewer.widget_rects for k in ("radius", "seed")), sorted(viewer.widget_rects)[:20]
    x, y, w, h = viewer.unit_square_rect()
    got = viewer.grab()[y:y + h, x:x + w].astype(int)
    ref = cellgl.render(viewer.model.recipe, w, h)["color"][..., :3]
    ref = np.round(np.clip(ref, 0, 1) * 255).astype(int)
    assert np.mean(np.abs(got - ref).max(axis=-1) <= 2) > 0.999
    viewer.set_mode("3d")
    assert viewer.mode == "2d" and "not available for PUPs" in viewer.status
    viewer.set_mode("tiled")
    _settle(viewer)
    assert _view(viewer, viewer.grab()).std() > 10
    assert viewer.ctx.error == "GL_NO_ERROR"
    _reset(viewer)


@pytest.mark.parametrize("preset", ["wobbly-cells", "wood-grain", "caustics"])
def test_warped_stretched_orbiting_readout_and_view(viewer, preset):
    """Domain warp, stretched cells, orbiting points: the view is the bake and the readout
    under the cursor is the basis value the texture shows there (warped position, weighted
    distance, moved points)."""
    _reset(viewer, preset)
    x, y, w, h = viewer.unit_square_rect()
    px, py = 41, 77
    viewer.script_mouse([(x + px + 0.5, y + py + 0.5, False)])
    viewer.frame()
    r = viewer.readout
    ref = cellgl.render(viewer.model.recipe, w, h, channels=("F1", "id"), x0=px, y0=py, tile_w=1, tile_h=1)
    assert r["F"][0] == pytest.approx(float(ref["F1"][0, 0]), abs=1e-4)
    assert r["id"] == int(ref["id"][0, 0])
    viewer.script_mouse([(5, 5, False)])
    viewer.frame()
    _reset(viewer)


def test_anim_mode_loops_orbiting_points(viewer):
    """A recipe with orbit_radius > 0 animates its loop (orbit_phase), staying in its dimension."""
    _reset(viewer, "caustics")
    viewer.set_mode("anim")
    assert viewer.model.get("dimension") == 2 and "orbit" in viewer.status
    viewer.playing = False
    _settle(viewer)
    first = _view(viewer, viewer.grab()).astype(int)
    viewer.playing = True
    for _ in range(8):
        viewer.frame()
    viewer.playing = False
    assert 0.0 < viewer.model.get("orbit_phase") < 1.0
    _settle(viewer)
    assert np.abs(_view(viewer, viewer.grab()).astype(int) - first).max() > 30, "the points did not move"
    _reset(viewer)


def test_inactive_parameters_are_greyed_out(viewer):
    """A slider that changes nothing (cellgl.texture.params.inactive) is greyed out and takes no
    input, as Blender's node hides its Exponent socket unless the metric is Minkowski."""
    from cellgl.texture.params import inactive

    _reset(viewer)
    viewer.model.set("metric", "euclidean")
    _settle(viewer)
    assert viewer.inactive_widgets == inactive(viewer.model.recipe)
    assert viewer.inactive_widgets["minkowski_p"] == "needs metric minkowski"
    for name in ("c_edge", "c_smooth", "c_nsphere", "smoothness"):   # the whole combination is shown
        assert name in viewer.widget_rects, name
    p0, v0 = viewer.model.get("minkowski_p"), viewer.model.version
    _drag(viewer, "minkowski_p", 0.25, 0.75)
    assert viewer.model.get("minkowski_p") == p0 and viewer.model.version == v0, "a greyed slider moved"
    viewer.model.set("metric", "minkowski")
    _settle(viewer)
    assert "minkowski_p" not in viewer.inactive_widgets
    _drag(viewer, "minkowski_p", 0.25, 0.75)
    assert viewer.model.get("minkowski_p") != p0, "the live slider did not move"
    _reset(viewer)


def test_material_channels_are_shown_as_baked(viewer):
    """The channel combo's roughness / ao / metallic equal the bake's channel (8-bit)."""
    _reset(viewer)
    x, y, w, h = viewer.unit_square_rect()
    for channel in ("roughness", "ao"):
        viewer.channel = channel
        _settle(viewer)
        got = viewer.grab()[y:y + h, x:x + w].astype(int)
        ref = cellgl.render(viewer.model.recipe, w, h, channels=(channel,))[channel]
        ref = np.round(np.clip(ref, 0, 1) * 255).astype(int)
        diff = np.abs(got - ref[..., None]).max(axis=-1)
        assert np.mean(diff <= 2) > 0.99, (channel, diff.max())
    viewer.channel = "color"
    assert viewer.ctx.error == "GL_NO_ERROR"
