"""Spatially varying feature density in the texture layer: ``basis.density_map`` (ramp_x, ramp_y,
radial, image) per octave, GPU == NumPy twin, tiles == one pass, the viewer's fragment path and
pan, the exported snippet, the map doing what it says, clear errors."""
from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image

from cellgl import texture
from cellgl.export import snippets as export
from cellgl.texture.recipe import Recipe, RecipeError
from cellgl.recipes import load_recipe
from compare import assert_close_but_share

# a small grayscale image: dense (white) top-left quarter, sparse elsewhere, a mid-grey band
IMG = np.zeros((6, 8), np.uint8)
IMG[:3, :4] = 255
IMG[4, :] = 128


@pytest.fixture(scope="module")
def image_path(tmp_path_factory):
    p = tmp_path_factory.mktemp("dens") / "map.png"
    Image.fromarray(IMG).save(p)
    return p


def _recipes(image_path) -> dict:
    veins = load_recipe("veins").replace(min_points=0, max_points=16)
    return {
        "ramp_x": veins.replace(density_map="ramp_x", density_min=0.3, density_max=9.0,
                                density_start=0.1, density_end=0.85),
        "ramp_y_fractal": load_recipe("veins").replace(
            density_map="ramp_y", density_start=1.2, density_end=-0.3, fractal="sum", octaves=3.0,
            lacunarity=2.3, offset_x=1e6 + 0.37, offset_y=-2.5e5),
        "radial_3d": load_recipe("flagstone").replace(density_map="radial", density_min=9.0,
                                                      density_max=0.4, density_center_x=0.3,
                                                      density_center_y=0.6, density_radius=0.4),
        "image": veins.replace(density_map="image", density_image=str(image_path), density_min=0.5,
                               density_max=10.0, aspect=0.75),
    }


@pytest.mark.parametrize("name", ["ramp_x", "ramp_y_fractal", "radial_3d", "image"])
def test_gpu_equals_numpy_and_tiles_equal_one_pass(ctx, image_path, name):
    r = _recipes(image_path)[name]
    ch = ("color", "id", "F1", "F2")
    g = texture.render(r, 40, 30, channels=ch)
    n = texture.render(r, 40, 30, channels=ch, backend="numpy")
    assert (g["id"] != n["id"]).mean() < 2e-3          # float32 ties only
    same = g["id"] == n["id"]
    np.testing.assert_allclose(g["F1"][same], n["F1"][same], rtol=2e-5, atol=2e-5)
    np.testing.assert_allclose(g["F2"][same], n["F2"][same], rtol=2e-5, atol=2e-5)
    assert_close_but_share(g["color"], n["color"], 2e-3, share=0.01)
    tile = texture.render(r, 40, 30, channels=("color", "id"), x0=7, y0=4, tile_w=21, tile_h=19)
    np.testing.assert_array_equal(tile["color"], g["color"][4:23, 7:28])
    np.testing.assert_array_equal(tile["id"], g["id"][4:23, 7:28])


def test_octaves_use_the_map_scaled_to_their_lattice(image_path):
    """Octave i's encoding is the uv map seen from the lattice lacunarity^i (O + s): the level of
    a cell follows the map at the cell centre's uv, in every octave."""
    from cellgl.basis import density
    from cellgl.texture import reference as texture_reference

    r = _recipes(image_path)["ramp_y_fractal"]
    t = texture_reference.texture_values(r)
    v = r.values
    fa = v["frequency"] * v["aspect"]
    for i in range(4):
        k = v["lacunarity"] ** i
        enc = t["density_enc"][i]
        cy = np.arange(-40, 40 * k) + t["origin_cell"][i][1]
        cells = np.zeros((len(cy), 4), np.int64)
        cells[:, 1] = cy
        cells[:, 0] = t["origin_cell"][i][0]
        lv = density.levels_reference(cells, enc)
        vv = ((cy + 0.5) / k - v["offset_y"]) / fa               # uv of the cell centre
        want = np.clip(np.floor(15 * (vv - 1.2) / (-0.3 - 1.2) + 0.5), 0, 15)
        assert (lv != want).mean() < 0.01 and np.abs(lv - want).max() <= 1


def test_small_cells_where_dense(ctx):
    r = load_recipe("density")
    F1 = texture.render(r, 96, 64, channels=("F1",))["F1"]
    assert F1[:, :16].mean() > 2.5 * F1[:, -16:].mean()     # ramp_x: sparse left, dense right
    ids = texture.render(r, 96, 64, channels=("id",))["id"]
    assert len(np.unique(ids[:, -32:])) > 3 * len(np.unique(ids[:, :32]))


def test_image_map_follows_the_image(ctx, image_path):
    r = _recipes(image_path)["image"]
    ids = texture.render(r, 64, 48, channels=("id",))["id"]
    dense = len(np.unique(ids[:24, :32]))          # white quarter
    sparse = len(np.unique(ids[24:, 32:]))         # black quarter (and the grey band)
    assert dense > 3 * sparse


def test_viewer_fragment_path_and_pan(ctx, image_path):
    """texture.frag (the viewer) binds the image and reads the map per octave; a pan moves the
    view over the map (the map stays on the texture)."""
    for name in ("image", "ramp_y_fractal"):
        r = _recipes(image_path)[name]
        frag = texture.render_fragment(r, 32, 24)
        comp = texture.render(r, 32, 24)["color"]
        assert_close_but_share(frag, comp, 2e-3, share=0.02, what=name)
        u0, v0, du, dv = 0.31, -0.17, 0.7, 0.9
        frag = texture.render_fragment(r, 32, 24, view=(u0, v0, du, dv))
        uu, vv = np.meshgrid(u0 + (np.arange(32) + 0.5) / 32 * du, v0 + (np.arange(24) + 0.5) / 24 * dv)
        ref = texture.evaluate(r, np.stack([uu.ravel(), vv.ravel()], 1), ("color",), backend="numpy",
                               filter_width=(du / 32, dv / 24))["color"].reshape(24, 32, 4)
        assert_close_but_share(frag, ref, 2e-3, share=0.03, what=name)


def test_default_recipes_have_no_density_code():
    r = load_recipe("veins")
    assert texture.defines(r)["CELL_DENSITY_MAP"] == 0
    assert not any(k.startswith("u_density_") for k in texture.uniform_values(r))
    code = "\n".join(ln for ln in export.export(r, "glsl").split("\n") if not ln.startswith("//"))
    assert "density_axis" not in code and "density_thresholds" not in code


def test_radial_snippet_reproduces_the_bake(ctx, image_path):
    from test_export import render_snippet, snippet_code

    r = _recipes(image_path)["radial_3d"].replace(name="radial")
    got = render_snippet(ctx, snippet_code(export.export(r, "glsl")), 48, 32)
    want = texture.render(r, 48, 32)["color"]
    np.testing.assert_allclose(got, want, rtol=0, atol=2e-5)


def test_json_round_trip_with_a_relative_image(tmp_path):
    (tmp_path / "maps").mkdir()
    Image.fromarray(IMG).save(tmp_path / "maps" / "m.png")
    d = {"name": "img", "basis": {"density_map": "image", "density_image": "maps/m.png"}}
    (tmp_path / "r.json").write_text(json.dumps(d))
    r = load_recipe(str(tmp_path / "r.json"))
    assert r.density_image == str((tmp_path / "maps" / "m.png").resolve())
    np.testing.assert_allclose(r.density_pixels(), IMG / 255.0)
    r2 = Recipe.from_dict(json.loads(r.to_json()))
    assert r2 == r
    r3 = load_recipe("veins").set_from_strings([f"density_image={tmp_path / 'maps' / 'm.png'}",
                                                 "density_map=image"])
    assert r3.density_image == r.density_image


@pytest.mark.parametrize("change,match", [
    (dict(density_map="ramp_x", distribution="jitter"), r"density_map: 'ramp_x' needs basis.distribution 'poisson'"),
    (dict(density_map="image"), r"'image' needs basis.density_image"),
    (dict(density_map="ramp_y", density_start=0.4, density_end=0.4), r"density_end: 0.4 must differ"),
    (dict(density_map="radial", tileable=True), r"domain.tileable: not available with basis.density_map"),
    (dict(density_map="radial", density_radius=0.0), r"density_radius: out of range"),
    (dict(density_min=0.0), r"basis.density_min: out of range: 0.0; accepted: \[0.05, 16.0\]"),
    (dict(density_map="wave"), r"unknown choice 'wave'.*ramp_x, ramp_y, radial, image"),
    (dict(density_image="/nonexistent/map.png"), r"cannot read density image '/nonexistent/map.png'"),
    (dict(density_image=3), r"expected a file path"),
])
def test_bad_parameters_are_clear_errors(change, match):
    with pytest.raises(RecipeError, match=match):
        load_recipe("veins").replace(**change)


def test_bad_image_files(tmp_path):
    bad = tmp_path / "not.png"
    bad.write_text("hello")
    with pytest.raises(RecipeError, match=r"basis.density_image: cannot read density image .* as an image"):
        Recipe.from_dict({"basis": {"density_map": "image", "density_image": str(bad)}})
    (tmp_path / "r.json").write_text(json.dumps({"basis": {"density_image": "missing.png"}}))
    with pytest.raises(RecipeError, match=r"r.json: basis.density_image: cannot read density image"):
        load_recipe(str(tmp_path / "r.json"))


def test_tileable_and_export_refusals(image_path):
    r = load_recipe("density")
    with pytest.raises(RecipeError, match="tileable: not available with basis.density_map 'ramp_x'"):
        r.tileable()
    img = _recipes(image_path)["image"]
    for target in ("glsl", "wgsl"):
        with pytest.raises(export.ExportError, match="density_map 'image' cannot be exported.*storage buffer"):
            export.export(img, target)


def test_map_too_large_to_encode_is_a_clear_error():
    r = load_recipe("veins").replace(density_map="ramp_x", density_start=-100.0, density_end=100.0,
                                     frequency=4096.0, fractal="sum", lacunarity=4.0, octaves=8.0)
    with pytest.raises(RecipeError, match=r"density_map: density map of octave \d"):
        texture.uniform_values(r)
