"""Texture engine: GPU vs NumPy twin, analytic normals vs finite differences, tiling, tiles,
fragment path, generated GLSL."""
from __future__ import annotations

import numpy as np
import pytest

from cellgl import texture
from cellgl.texture.recipe import Recipe
from cellgl.recipes import load_recipe
from cellgl.texture.reference import texture_at, texture_ramp
from compare import assert_close_but_share, assert_render_matches


def test_generated_glsl_is_current():
    for path, text in texture.generated_files().items():
        assert path.read_text() == text, f"{path} is stale: run `python -m cellgl.texture`"


def test_constant_block_matches_uniforms():
    r = load_recipe("flagstone")
    block = texture.glsl_constant_block(r)
    for name in texture.uniform_values(r):
        assert f" {name} = " in block or f" {name}[" in block
    assert "const float u_density = 3.0;" in block
    assert texture.glsl_params_from_uniforms("k_").count("k_") > 40


RECIPES = {
    "plain": Recipe(),
    "everything": Recipe().replace(fractal="sum", octaves=3.5, dimension=3, tileable=True, frequency=4.0,
                                   c_noise=0.3, noise_color=0.2, c2=1.0, c12=-1.0, range_hi=1.5, light=0.5,
                                   shade=0.5, cell_mix=0.3, ramp_mode="spline",
                                   ramp=[[0, 0, 0, 0], [0.3, 1, 0, 0], [0.6, 0, 1, 0], [1, 1, 1, 1]]),
    "qin_cube_manhattan": Recipe().replace(fractal="qin_cube", metric="manhattan", invert=True, level_lo=0.1,
                                           level_hi=0.8, normal_convention="directx"),
    "jitter_4d": Recipe().replace(dimension=4, distribution="jitter", jitter=0.8, time=0.3, c1=0.0, c3=1.0,
                                  range_lo=0.3, range_hi=1.2),
    "worley1996": Recipe().replace(dimension=3, distribution="worley1996", c1=-1.0, c2=1.0),
}


def assert_gpu_matches_numpy(r, width: int = 24, height: int = 20) -> None:
    """A render of recipe r on the GPU equals the NumPy twin's: IDs exactly except at F1 = F2
    ties, colour, height, normal, F1, F2 within 2e-4 (also used by tests/test_domain.py)."""
    chs = ("color", "height", "normal", "id", "F1", "F2")
    g = texture.render(r, width, height, channels=chs)
    n = texture.render(r, width, height, channels=chs, backend="numpy")
    assert g["color"].shape == (height, width, 4) and g["normal"].shape == (height, width, 3)
    assert g["id"].dtype == np.uint32
    assert_render_matches(g, n, ("color", "height", "normal", "F1", "F2"), atol=2e-4)


@pytest.mark.parametrize("name", RECIPES)
def test_gpu_matches_numpy(ctx, name):
    assert_gpu_matches_numpy(RECIPES[name])


def _fd(recipe, pts, eps=1e-6):
    """Central differences of the NumPy height in texture space."""
    out = np.zeros((len(pts), 3))
    for a in range(2):
        d = np.zeros(3)
        d[a] = eps
        hp = texture_at(pts + d, recipe, 4)["height"]        # float64: evaluate() rounds to float32
        hm = texture_at(pts - d, recipe, 4)["height"]
        out[:, a] = (hp - hm) / (2 * eps)
    return out


@pytest.mark.parametrize("name", ["f2", "qin-wood", "crumple", "qin-wrinkle", "hull", "flagstone"])
def test_analytic_gradient_matches_finite_differences(ctx, name):
    r = load_recipe(name).replace(c_noise=0.2) if name == "f2" else load_recipe(name)
    rng = np.random.default_rng(1)
    pts = np.concatenate([rng.uniform(0.05, 0.95, (300, 2)), np.zeros((300, 1))], axis=1)
    ref = texture.evaluate(r, pts, ("grad", "F1", "F2"), backend="numpy")
    gpu = texture.evaluate(r, pts, ("grad", "normal"))
    fd = _fd(r, pts)
    # Skip samples near a kink (Voronoi edges, clamps): there the derivative jumps.
    agree = np.all(np.abs(fd[:, :2] - ref["grad"][:, :2]) <= 1e-2 * (1 + np.abs(fd[:, :2])), axis=1)
    assert agree.mean() > 0.85, agree.mean()
    np.testing.assert_allclose(gpu["grad"], ref["grad"], rtol=1e-3, atol=2e-3 * np.abs(ref["grad"]).max())


def test_normal_map_conventions(ctx):
    """A height rising towards the top of the image tilts the normal down: OpenGL green < 0.5."""
    r = Recipe().replace(c_noise=1.0, c1=0.0, range_lo=-1.0, range_hi=1.0, bump=0.5)
    pts = np.random.default_rng(2).uniform(0.1, 0.9, (200, 2))
    out = texture.evaluate(r, pts, ("grad", "normal"))
    dx = r.get("bump") * out["grad"][:, :2] / r.get("frequency")      # per cell
    n = np.stack([-dx[:, 0], dx[:, 1], np.ones(len(pts))], axis=1)    # OpenGL: +y up = -rows
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    np.testing.assert_allclose(out["normal"], n * 0.5 + 0.5, atol=1e-4)
    dxn = texture.evaluate(r.replace(normal_convention="directx"), pts, ("normal",))["normal"]
    np.testing.assert_allclose(dxn[:, 1], 1.0 - out["normal"][:, 1], atol=1e-5)
    np.testing.assert_allclose(dxn[:, [0, 2]], out["normal"][:, [0, 2]], atol=1e-6)


@pytest.mark.parametrize("name", ["flagstone", "crumple", "qin-cloud", "veins"])
def test_tileable_continues_across_both_edges(ctx, name):
    r = load_recipe(name).replace(tileable=True)
    if r.get("noise_color") or r.get("c_noise"):
        r = r.replace(noise_frequency=float(round(r.get("noise_frequency"))) or 1.0)
    W = 64
    img = texture.render(r, W, W, channels=("color", "height"))
    # The texture is a function of uv with period 1: the point one pixel past the right edge
    # (u = 1 + 0.5 / W) equals pixel 0, so the wrap-around difference is an ordinary neighbour step.
    pts_r = np.stack([np.full(W, 1.0 + 0.5 / W), (np.arange(W) + 0.5) / W], axis=1)
    pts_b = np.stack([(np.arange(W) + 0.5) / W, np.full(W, 1.0 + 0.5 / W)], axis=1)
    # filter_width: the bake's pixel, so that the points get its band limit.
    right = texture.evaluate(r, pts_r, ("color",), filter_width=1.0 / W)["color"]
    below = texture.evaluate(r, pts_b, ("color",), filter_width=1.0 / W)["color"]
    np.testing.assert_allclose(right, img["color"][:, 0], atol=2e-3)
    np.testing.assert_allclose(below, img["color"][0, :], atol=2e-3)
    h = img["height"]
    inner = np.abs(np.diff(h, axis=1)).mean()
    assert np.abs(h[:, 0] - h[:, -1]).mean() < 3 * inner + 1e-3
    assert np.abs(h[0, :] - h[-1, :]).mean() < 3 * inner + 1e-3


def test_tiles_are_bit_identical(ctx):
    r = load_recipe("hide")
    full = texture.render(r, 40, 30, channels=("color", "normal", "id"))
    for x0, y0, tw, th in ((0, 0, 17, 11), (17, 11, 23, 19), (5, 20, 30, 10)):
        t = texture.render(r, 40, 30, channels=("color", "normal", "id"), x0=x0, y0=y0, tile_w=tw, tile_h=th)
        for k in t:
            assert np.array_equal(t[k], full[k][y0:y0 + th, x0:x0 + tw]), k


def test_volume_slices(ctx):
    r = load_recipe("qin-marble")
    vol = texture.render(r, 16, 12, depth=3, channels=("color", "height"))
    assert vol["color"].shape == (3, 12, 16, 4) and vol["height"].shape == (3, 12, 16)
    z1 = texture.evaluate(r, np.array([[(3 + 0.5) / 16, (4 + 0.5) / 12, 1.5 / 3]]), ("color",))["color"][0]
    np.testing.assert_allclose(vol["color"][1, 4, 3], z1, atol=1e-6)
    with pytest.raises(ValueError, match="depth.*dimension 3 or 4"):
        texture.render(Recipe(), 8, 8, depth=2)


def test_fragment_matches_compute(ctx):
    r = load_recipe("flagstone")
    frag = texture.render_fragment(r, 32, 24)
    comp = texture.render(r, 32, 24)["color"]
    assert_close_but_share(frag, comp, 2e-3, share=0.02)      # all but pixels on an exact cell edge


def test_blue_marble_spline_is_renderman_catmull_rom():
    """Qin's 13-key spline: passes through keys 2..12 at t = (k - 1) / 10 (RenderMan spline)."""
    r = load_recipe("qin-marble")
    t = {"ramp_mode": "spline"}
    x = np.arange(11) / 10.0
    got = texture_ramp(x, t, r.ramp)
    want = np.array([k[1:] for k in r.ramp[1:12]])
    np.testing.assert_allclose(got, want, atol=1e-12)
    lin = texture_ramp(np.array([0.0, 0.125, 1.0]), {"ramp_mode": "linear"},
                       [(0.0, 0, 0, 0), (0.25, 1, 1, 1), (1.0, 0, 0, 0)])
    np.testing.assert_allclose(lin, [[0, 0, 0], [0.5, 0.5, 0.5], [0, 0, 0]])


def test_measure_range_is_deterministic(ctx):
    a = texture.measure_range("veins", samples=4096)
    b = texture.measure_range("veins", samples=4096, backend="numpy")
    assert a[0] < 0.02 and 0.4 < a[1] < 0.8
    np.testing.assert_allclose(a, b, atol=1e-4)


def test_bad_arguments():
    with pytest.raises(ValueError, match="unknown channel 'colour'"):
        texture.render(Recipe(), 8, 8, channels=("colour",))
    with pytest.raises(ValueError, match="points must have shape"):
        texture.evaluate(Recipe(), np.zeros((3, 5)))
    with pytest.raises(ValueError, match=r"tile_w must be an integer in \[1, 4\], got 5"):
        texture.render(Recipe(), 8, 8, x0=4, tile_w=5)      # past the 8x8 image's right edge
    with pytest.raises(ValueError, match="backend"):
        texture.render(Recipe(), 8, 8, backend="cuda")


@pytest.mark.parametrize("asked", [("F1",), ("F2",), ("F3",), ("F1", "F4"), ("id", "F2")])
def test_f_channels_asked_alone_are_those_asked_with_all(ctx, asked):
    """Only F1..F_k up to the last one asked is written and read back (one float a sample for F1
    alone, on both paths): the values are those of a render asking for all four, bit for bit."""
    r = RECIPES["everything"]
    every = texture.render(r, 24, 20, channels=("F1", "F2", "F3", "F4", "id"))
    got = texture.render(r, 24, 20, channels=asked)
    assert set(got) == set(asked)
    for k in asked:
        assert got[k].shape == (20, 24) and got[k].flags.c_contiguous
        assert np.array_equal(got[k], every[k]), k
