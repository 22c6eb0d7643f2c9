"""Voronoi-cell features in recipes: c_edge, c_smooth, c_nsphere, smoothness, fractal 'min', and
cell-attribute lookup (cell_color 'image'): GPU == NumPy, the viewer's fragment path, errors."""
from __future__ import annotations

import json

import numpy as np
import pytest

import cellgl
from cellgl import export
from cellgl.recipes import load_recipe
from cellgl.texture import images as cell_image
from cellgl.texture.presets import preset_dir
from cellgl.texture.recipe import Recipe, RecipeError
from compare import assert_close_but_share

IMAGE = str(preset_dir() / "images" / "sunset.png")

RECIPES = {
    "edge": dict(c1=0.0, c_edge=1.0, range_hi=0.5, bump=0.2),
    "edge-min": dict(c1=0.0, c_edge=1.0, range_hi=0.5, fractal="min", octaves=3.5),
    "edge-3d": dict(dimension=3, c1=-1.0, c2=1.0, c_edge=2.0, range_hi=1.0),
    "smooth": dict(c1=0.0, c_smooth=1.0, smoothness=0.1, cell_mix=0.6, range_lo=-0.3, range_hi=0.8),
    "smooth-manhattan": dict(metric="manhattan", c1=0.0, c_smooth=1.0, smoothness=0.2, range_hi=1.2),
    "smooth-zero": dict(c1=0.0, c_smooth=1.0, smoothness=0.0, cell_mix=0.5),
    "nsphere": dict(c1=1.0, c_nsphere=-1.0, range_lo=-0.1, range_hi=0.1),
    "w96": dict(dimension=3, distribution="worley1996", c1=0.0, c_edge=1.0, c_smooth=0.5, smoothness=0.05,
                cell_mix=0.3, range_hi=0.8),
    "image": dict(c1=0.0, c_edge=1.0, cell_color="image", cell_mix=1.0, shade=0.5, level_hi=0.2),
    "image-smooth-tiled": dict(c1=0.0, c_smooth=1.0, smoothness=0.08, cell_color="image", cell_mix=0.8,
                               tileable=True, frequency=5.0, fractal="sum", octaves=2.0),
}


def _recipe(name):
    kw = dict(RECIPES[name])
    return Recipe(kw, cell_image=IMAGE if kw.get("cell_color") == "image" else None)


@pytest.mark.parametrize("name", list(RECIPES))
def test_gpu_matches_reference(ctx, name):
    r = _recipe(name)
    pts = np.random.default_rng(2).uniform(-0.2, 1.2, (500, 3))
    outs = ("color", "height", "value", "grad", "id")
    g = cellgl.evaluate(r, pts, outputs=outs)
    n = cellgl.evaluate(r, pts, outputs=outs, backend="numpy")
    np.testing.assert_array_equal(g["id"], n["id"])
    for k in ("color", "height", "value"):
        np.testing.assert_allclose(g[k], n[k], atol=2e-5, err_msg=k)
    np.testing.assert_allclose(g["grad"], n["grad"], atol=2e-3, rtol=1e-4)


def test_features_change_the_texture():
    """Each term does something: the value is the feature's own number."""
    pts = np.random.default_rng(4).uniform(0, 1, (200, 2))
    base = dict(frequency=8.0, c1=0.0)
    api = cellgl.cellular(pts * 8.0, 1, outputs=("edge", "nsphere", "smooth_F1"), smoothness=0.1,
                          backend="numpy")
    for term, feat, extra in (("c_edge", api.edge, {}), ("c_nsphere", api.nsphere, {}),
                              ("c_smooth", api.smooth_F1, {"smoothness": 0.1})):
        r = Recipe(dict(base, **{term: 1.0}, **extra))
        v = cellgl.evaluate(r, pts, outputs=("value",), backend="numpy")["value"]
        np.testing.assert_allclose(v, feat, atol=1e-6, err_msg=term)


def test_fractal_min_is_the_least_octave():
    pts = np.random.default_rng(5).uniform(0, 1, (300, 2))
    kw = dict(c1=0.0, c_edge=1.0, range_lo=0.0, range_hi=1.0)
    one = cellgl.evaluate(Recipe(dict(kw, fractal="min", octaves=1.0)), pts, ("height",), backend="numpy")
    none = cellgl.evaluate(Recipe(kw), pts, ("height",), backend="numpy")
    np.testing.assert_allclose(one["height"], none["height"], atol=1e-7)
    three = cellgl.evaluate(Recipe(dict(kw, fractal="min", octaves=3.0)), pts, ("height",), backend="numpy")
    assert np.all(three["height"] <= none["height"] + 1e-7) and np.mean(three["height"] < none["height"] - 1e-3) > 0.3


def test_cell_colour_is_the_image_at_the_feature_point():
    """Cell-attribute lookup end to end: the colour of a sample is the image at the uv of the F1
    point that cellular() reports (the cell position output)."""
    f = 12.0
    r = Recipe(dict(c1=0.0, c_edge=1.0, frequency=f, cell_color="image", cell_mix=1.0), cell_image=IMAGE)
    pts = np.random.default_rng(6).uniform(0.05, 0.95, (300, 2))
    col = cellgl.evaluate(r, pts, ("color",))["color"][:, :3]
    pos = cellgl.cellular(pts * f, 1, outputs=("position",)).position
    want = cell_image.sample(cell_image.cell_pixels(IMAGE), pos / f, wrap=False)
    np.testing.assert_allclose(col, want, atol=2e-5)


def test_viewer_fragment_path_matches_the_bake(ctx):
    for name in ("stained-glass", "hammered", "edge-cracks"):
        r = load_recipe(name)
        frag = cellgl.texture.render_fragment(r, 40, 32)
        bake = cellgl.render(r, 40, 32)["color"]
        np.testing.assert_allclose(frag, bake, atol=2e-5, err_msg=name)


def test_viewer_pan_keeps_the_image_in_place(ctx):
    """The pan goes into the split origins; the cell image stays on the texture's uv square."""
    r = load_recipe("stained-glass")
    full = cellgl.render(r, 64, 64)["color"]
    part = cellgl.texture.render_fragment(r, 32, 32, view=(0.5, 0.25, 0.5, 0.5))
    np.testing.assert_allclose(part, full[16:48, 32:64], atol=2e-5)


def test_recipe_errors(tmp_path):
    with pytest.raises(RecipeError, match="c_edge.*needs basis.metric 'euclidean'"):
        Recipe(dict(metric="manhattan", c_edge=1.0))
    with pytest.raises(RecipeError, match="c_nsphere.*euclidean"):
        Recipe(dict(metric="chebyshev", c_nsphere=1.0))
    with pytest.raises(RecipeError, match="cell_color: 'image' needs color.cell_image"):
        Recipe(dict(cell_color="image"))
    with pytest.raises(RecipeError, match="color.cell_image: cannot read cell image"):
        Recipe(dict(cell_color="image"), cell_image=str(tmp_path / "missing.png"))
    (tmp_path / "bad.png").write_text("not an image")
    with pytest.raises(RecipeError, match="as an image"):
        Recipe.from_dict({"color": {"cell_color": "image", "cell_image": "bad.png"}}, base=tmp_path)
    with pytest.raises(RecipeError, match=r"smoothness: 0.5 exceeds 0.25 with combination.smooth 'exp'.*"
                                          r"accepted: \[0, 0.25\], or smooth 'polynomial' for up to 1"):
        Recipe(dict(smoothness=0.5))
    assert Recipe(dict(smoothness=0.5, smooth="polynomial")).get("smoothness") == 0.5
    with pytest.raises(RecipeError, match=r"smoothness: out of range: 1.5; accepted: \[0.0, 1.0\]"):
        Recipe(dict(smoothness=1.5, smooth="polynomial"))
    with pytest.raises(RecipeError, match="unknown choice 'maximum'"):
        Recipe(dict(fractal="maximum"))


def test_cell_image_path_is_saved_relative_and_reloads(tmp_path):
    import shutil

    (tmp_path / "img").mkdir()
    shutil.copy(IMAGE, tmp_path / "img" / "pic.png")
    r = load_recipe("stained-glass").replace(cell_image=str(tmp_path / "img" / "pic.png"))
    r.save(tmp_path / "glass.json")
    d = json.loads((tmp_path / "glass.json").read_text())
    assert d["color"]["cell_image"] == "img/pic.png"
    again = Recipe.load(tmp_path / "glass.json")
    assert again.cell_image == str((tmp_path / "img" / "pic.png").resolve())
    assert load_recipe("stained-glass").cell_image.endswith("presets/images/sunset.png")


def test_cell_image_export_is_refused():
    with pytest.raises(export.ExportError, match="cell_color 'image' cannot be exported"):
        export.export("stained-glass", "glsl")


def test_sample_is_bilinear_between_texel_centres():
    img = np.zeros((2, 2, 3), np.uint8)
    img[0, 1] = 255                     # top right texel white
    uv = np.array([[0.25, 0.25], [0.75, 0.25], [0.5, 0.25], [1.2, 0.25], [0.5, 0.5]])
    got = cell_image.sample(img, uv, wrap=False)[:, 0]
    np.testing.assert_allclose(got, [0.0, 1.0, 0.5, 1.0, 0.25])
    wrapped = cell_image.sample(img, np.array([[1.0, 0.25]]), wrap=True)[:, 0]
    np.testing.assert_allclose(wrapped, [0.5])          # between the last texel and the first again


def test_bake_binds_its_own_cell_image(ctx):
    """Whatever is bound at the cell image's binding before (another program's buffer), a bake
    binds the recipe's image: the colours are the picture's, as the NumPy path gives them."""
    stray = ctx.buffer(np.zeros(64, np.uint32).tobytes())
    stray.bind_to_storage_buffer(cell_image.BINDING)
    try:
        r = load_recipe("stained-glass")
        g = cellgl.render(r, 24, 24)["color"]
        n = cellgl.render(r, 24, 24, backend="numpy")["color"]
        assert_close_but_share(g, n, 2e-3, share=0.02)
    finally:
        stray.release()


def test_fractal_min_band_limited_matches_reference(ctx):
    """With a footprint, octaves finer than a pixel fade out of the min (GPU == NumPy)."""
    r = _recipe("edge-min")
    pts = np.random.default_rng(9).uniform(0, 1, (400, 2))
    g = cellgl.evaluate(r, pts, ("height", "grad"), filter_width=0.02)
    n = cellgl.evaluate(r, pts, ("height", "grad"), backend="numpy", filter_width=0.02)
    np.testing.assert_allclose(g["height"], n["height"], atol=2e-5)
    sharp = cellgl.evaluate(r, pts, ("height",), backend="numpy")["height"]
    assert np.all(n["height"] >= sharp - 1e-6) and np.mean(n["height"] > sharp + 1e-3) > 0.1
