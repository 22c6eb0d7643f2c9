"""Antialiasing: band-limited fractal octaves (Qin's smoothscale) and supersampled renders.

The GPU agrees with the NumPy reference with the band limit active, supersampling is a box
filter of a finer render, a bake large enough that no octave fades is bit-identical to a
point-sampled one, tiles stay bit-identical, and the error against a filtered reference falls.
"""
from __future__ import annotations

import re

import numpy as np
import pytest

from cellgl import texture
from cellgl.gl import glsl
from cellgl.bake import core as bake
from cellgl.texture import antialias
from cellgl.texture import dispatch as texture_dispatch
from cellgl.texture import reference as texture_reference
from cellgl.texture.presets import load_recipe
from compare import (assert_close_but_share, assert_F_within_bound, assert_ids_equal_but_ties, octave_sum,
                     texture_near_ties)

CHANNELS = ("color", "height", "normal")


def test_glsl_thresholds_are_the_python_ones():
    text = (glsl.shader_dir() / "lib" / "texture.glsl").read_text()
    lo = float(re.search(r"#define CELL_TEX_AA_LO ([0-9.]+)", text).group(1))
    hi = float(re.search(r"#define CELL_TEX_AA_HI ([0-9.]+)", text).group(1))
    assert (lo, hi) == (antialias.AA_LO, antialias.AA_HI)
    assert antialias.smoothscale([0.0, lo, hi, 2 * hi]).tolist() == [1.0, 1.0, 0.0, 0.0]


@pytest.mark.parametrize("name", ["crumple", "qin-wrinkle", "craters"])
def test_band_limited_render_matches_reference(ctx, name):
    # 24 x 20 pixels: the finer octaves are partly and fully faded.
    r = load_recipe(name)
    gpu = texture.render(r, 24, 20, channels=CHANNELS + ("id", "F1", "F2"))
    ref = texture.render(r, 24, 20, channels=CHANNELS + ("id", "F1", "F2"), backend="numpy")
    S = octave_sum(r)
    tie = texture_near_ties(ref, S)
    assert tie.mean() < 0.02
    assert_F_within_bound(gpu["F1"], ref["F1"], S)
    # a finer octave's or a sub-sample's near-ties, which the outputs do not show: 1 % of pixels
    for c in CHANNELS:
        assert_close_but_share(gpu[c].astype(np.float64), ref[c], 2e-5, share=0.01, tie=tie, what=c)
    assert_ids_equal_but_ties(gpu["id"], ref["id"], tie)
    # ... and the band limit did something here.
    off = texture.render(r.replace(antialias=0.0), 24, 20)["color"]
    assert np.abs(off - gpu["color"]).max() > 0.05


@pytest.mark.parametrize("name", ["qin-cloud", "flagstone"])
def test_supersampled_render_matches_reference(ctx, name):
    r = load_recipe(name)
    gpu = texture.render(r, 20, 16, channels=CHANNELS, samples=4)
    ref = texture.render(r, 20, 16, channels=CHANNELS, samples=4, backend="numpy")
    for c in CHANNELS:
        assert_close_but_share(gpu[c].astype(np.float64), ref[c], 2e-5, share=0.01, what=c)


def test_supersampling_is_a_box_filter_of_a_finer_render(ctx):
    # The 3 x 3 sub-pixel centres of a W-pixel render are the pixel centres of a 3W render,
    # band-limited alike: the average of each 3 x 3 block.
    r = load_recipe("rock")
    W, H = 16, 12
    ss = texture.render(r, W, H, channels=("color", "height", "F1"), samples=9)
    fine = texture.render(r, 3 * W, 3 * H, channels=("color", "height"))
    box = fine["color"].reshape(H, 3, W, 3, 4).mean(axis=(1, 3))
    np.testing.assert_allclose(ss["color"], box, atol=2e-5)
    np.testing.assert_allclose(ss["height"], fine["height"].reshape(H, 3, W, 3).mean(axis=(1, 3)), atol=2e-5)
    # Per-pixel quantities come from the pixel centre, as without supersampling.
    np.testing.assert_array_equal(ss["F1"], texture.render(r, W, H, channels=("F1",))["F1"])


def test_large_bake_is_unchanged_bit_for_bit(ctx):
    # hide: 7 cells, 3 octaves; at 128 pixels octave 2 has ~4.5 pixels per feature: nothing fades.
    r = load_recipe("hide")
    on = texture.render(r, 128, 96, channels=CHANNELS)
    off = texture.render(r.replace(antialias=0.0), 128, 96, channels=CHANNELS)
    for c in CHANNELS:
        np.testing.assert_array_equal(on[c], off[c])


def test_tiles_are_bit_identical_with_band_limit_and_supersampling(ctx):
    r = load_recipe("crumple")
    kw = dict(channels=("color", "normal"), samples=4)
    full = texture.render(r, 40, 24, **kw)
    for x0, y0, tw, th in ((0, 0, 16, 24), (16, 0, 24, 10), (16, 10, 24, 14)):
        tile = texture.render(r, 40, 24, x0=x0, y0=y0, tile_w=tw, tile_h=th, **kw)
        for c in kw["channels"]:
            np.testing.assert_array_equal(tile[c], full[c][y0:y0 + th, x0:x0 + tw])


def test_error_against_a_filtered_reference_falls(ctx):
    # crumple at 32^2 against a 256^2 render box-filtered to 32^2: the point-sampled render is
    # speckled (bump-lit creases finer than a pixel).
    r = load_recipe("crumple")
    target = texture.render(r, 256, 256)["color"].reshape(32, 8, 32, 8, 4).mean(axis=(1, 3))

    def rms(img):
        return float(np.sqrt(np.mean((img - target) ** 2)))

    point = rms(texture.render(r.replace(antialias=0.0), 32, 32)["color"])
    band = rms(texture.render(r, 32, 32)["color"])
    both = rms(texture.render(r, 32, 32, samples=4)["color"])
    assert band < point / 1.2
    assert both < point / 2


def test_evaluate_filter_width_matches_reference_and_render(ctx):
    r = load_recipe("qin-wrinkle")
    W = 20
    u = (np.arange(W) + 0.5) / W
    pts = np.stack([u, np.full(W, 0.5 / W)], axis=1)
    gpu = texture.evaluate(r, pts, ("color", "grad"), filter_width=1.0 / W)
    ref = texture.evaluate(r, pts, ("color", "grad"), backend="numpy", filter_width=(1.0 / W, 1.0 / W))
    np.testing.assert_allclose(gpu["color"], ref["color"], atol=2e-5)
    np.testing.assert_allclose(gpu["grad"], ref["grad"], rtol=1e-4, atol=1e-3)
    row = texture.render(r, W, W)["color"][0]
    np.testing.assert_allclose(gpu["color"], row, atol=2e-5)


def test_viewer_fragment_path_is_band_limited_like_the_bake(ctx):
    # texture.frag takes the footprint from fwidth(uv): the same pixels as the bake's.
    r = load_recipe("crumple")
    frag = texture.render_fragment(r, 32, 24)
    comp = texture.render(r, 32, 24)["color"]
    assert_close_but_share(frag, comp, 2e-3, share=0.02)


def test_baked_program_matches_the_uniform_program(ctx):
    r = load_recipe("qin-marble")
    baked = texture.render(r, 24, 16, channels=CHANNELS + ("id",))
    texture_dispatch.BAKE_CONSTANTS = False
    try:
        uni = texture.render(r, 24, 16, channels=CHANNELS + ("id",))
    finally:
        texture_dispatch.BAKE_CONSTANTS = True
    for c in CHANNELS:
        np.testing.assert_allclose(baked[c], uni[c], atol=2e-5, err_msg=c)
    np.testing.assert_array_equal(baked["id"], uni["id"])


@pytest.mark.parametrize("samples", [0, 2, 3, 65, 81, 2.0, True, "4"])
def test_bad_samples_are_refused(samples):
    with pytest.raises(ValueError, match="samples must be a square"):
        texture.render("f1", 8, 8, samples=samples)


@pytest.mark.parametrize("fw", [-0.1, float("nan"), float("inf"), (0.1, 0.1, 0.1, 0.1), "x", True, 1j])
def test_bad_filter_width_is_refused(fw):
    with pytest.raises(ValueError, match="filter_width"):
        texture.evaluate("f1", [[0.5, 0.5]], filter_width=fw)


def test_bake_samples(ctx, tmp_path):
    out = tmp_path / "c.npy"
    bake.bake("crumple", out, size=(24, 16), samples=4, progress=False)
    ref = texture.render("crumple", 24, 16, samples=4)["color"][..., :3]
    np.testing.assert_array_equal(np.load(out), ref)
    with pytest.raises(bake.BakeError, match="--samples: samples must be a square"):
        bake.bake("crumple", tmp_path / "d.npy", size=8, samples=5, progress=False)
    assert not (tmp_path / "d.npy").exists()


def test_octave_mean_is_the_mean_of_the_term(ctx):
    # The mean the band limit fades to: the octave's term over a large region, measured on the GPU.
    for name in ("crumple", "qin-wrinkle"):
        r = load_recipe(name)
        probe = r.replace(fractal="none", frequency=64.0, antialias=0.0)
        val = texture.evaluate(probe, np.random.default_rng(3).uniform(0, 1, (20000, 2)), ("value",))["value"]
        b = np.clip((val - r.get("range_lo")) / (r.get("range_hi") - r.get("range_lo")), 0, 1)
        term = np.abs(0.5 - b) if r.get("fractal") in ("qin", "qin_cube") else b
        assert abs(texture_reference.octave_mean(r) - term.mean()) < 0.02


def test_a_render_that_fades_no_octave_measures_no_octave_mean(ctx, monkeypatch):
    """The octave mean (NumPy, 4096 points) is measured only for a pass whose footprint fades an
    octave: f1 at 64^2 (8 features across 64 pixels) and evaluate's point samples never read it,
    and give the bits they gave with the mean measured; a fractal at 64^2 still measures it."""
    import cellgl

    calls = []
    real = texture_reference.measure_mean
    r = load_recipe("f1").replace(seed=424242)             # a basis no earlier test measured
    pts = np.random.default_rng(1).uniform(-2.0, 2.0, (100, 2))

    def counted(recipe):
        calls.append(recipe.name)
        return real(recipe)

    monkeypatch.setattr(texture_reference, "measure_mean", counted)
    img = cellgl.render(r, 64, 64, channels=("color", "height", "normal"))
    ev = cellgl.evaluate(r, pts, ("color", "grad"))
    assert calls == []
    assert not antialias.fades(r.values, (1 / 64, 1 / 64, 0.0))
    assert antialias.fades(r.values, (1 / 4, 1 / 4, 0.0))
    # the same bits as with the mean measured (every a_i = 1: term + 0 * mean)
    monkeypatch.setattr(antialias, "fades", lambda values, duvz: True)
    texture.shader._baked_uniforms_file.cache_clear()
    img2 = cellgl.render(r, 64, 64, channels=("color", "height", "normal"))
    ev2 = cellgl.evaluate(r, pts, ("color", "grad"))
    assert len(calls) == 1
    for a, b in ((img, img2), (ev, ev2)):
        for k in a:
            assert a[k].tobytes() == b[k].tobytes(), k
    monkeypatch.undo()
    monkeypatch.setattr(texture_reference, "measure_mean", counted)
    fractal = load_recipe("qin-cloud").replace(seed=424243)
    assert antialias.fades(fractal.values, (1 / 64, 1 / 64, 0.0))
    cellgl.render(fractal, 64, 64)
    assert len(calls) == 2
