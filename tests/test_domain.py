"""Stretched cells, domain warp and loopable animation (issue 12, items 5-7): exact against
brute force, GPU against the NumPy twin, loops bit for bit, tileable warp, `bake --frames`."""
from __future__ import annotations

import itertools

import numpy as np
import pytest

import cellgl
from cellgl import cli, texture
from cellgl.basis import reference
from cellgl.bake.frames import bake_frames
from cellgl.recipes import load_recipe
from cellgl.texture.recipe import Recipe, RecipeError
from cellgl.texture.reference import texture_at
from test_texture import assert_gpu_matches_numpy      # tests/ is on sys.path under pytest


def _cells_around(pts: np.ndarray, margin: int) -> np.ndarray:
    lo = np.floor(pts.min(0)).astype(int) - margin
    hi = np.floor(pts.max(0)).astype(int) + margin
    return np.array(list(itertools.product(*[range(a, b + 1) for a, b in zip(lo, hi)])))


# ---------------------------------------------------------------------------- the basis

CASES = {   # dim, stretch, orbit radius, metric, density, n
    "stretch-2d": (2, (4.0, 0.5), 0.0, "euclidean", 1.0, 4),
    "stretch-2d-sparse": (2, (1.0, 8.0), 0.0, "euclidean", 0.3, 2),
    "stretch-3d-manhattan": (3, (0.5, 2.0, 1.0), 0.0, "manhattan", 2.0, 3),
    "orbit-2d": (2, None, 0.5, "euclidean", 2.0, 4),
    "both-3d-chebyshev": (3, (3.0, 1.0, 0.25), 0.3, "chebyshev", 1.5, 2),
}


@pytest.mark.parametrize("case", CASES)
def test_search_equals_brute_force_under_the_stretch(ctx, case):
    """F and the IDs are those of a brute-force search over feature_points under the weighted
    metric (stretched coordinates), on the GPU and in NumPy; delta is in sample units."""
    dim, stretch, radius, metric, density, n = CASES[case]
    rng = np.random.default_rng(7)
    pts = rng.uniform(-3.0, 3.0, (400, dim))
    kw = dict(stretch=stretch, orbit_radius=radius, orbit_phase=0.3, density=density, seed=11,
              metric=metric, min_points=0 if density < 1 else 1)
    fp = cellgl.feature_points(_cells_around(pts, 9 if density < 1 else 5), orbit_radius=radius, orbit_phase=0.3,
                               density=density, seed=11, min_points=kw["min_points"])
    w = np.array(reference.axis_scale(stretch or (1.0,) * dim, dim)[:dim])
    F, ids = reference.brute_force(pts * w, fp.positions * w, fp.ids, metric, n)
    pos = dict(zip(fp.ids.tolist(), fp.positions))
    for backend in ("numpy", "gpu"):
        r = cellgl.cellular(pts, n, outputs=("F", "id", "delta"), backend=backend, **kw)
        assert r.exact.all()
        np.testing.assert_allclose(r.F, F, rtol=1e-5, atol=1e-5, err_msg=backend)
        tie = np.abs(np.diff(F, axis=1, append=np.inf)) < 1e-5
        tie |= np.roll(tie, 1, axis=1)
        assert np.array_equal(r.id[~tie], ids[~tie]), backend
        nearest = np.array([pos[i] for i in r.id[:, 0].tolist()])
        np.testing.assert_allclose(r.delta[:, 0], nearest - pts, atol=2e-5, err_msg=backend)


def test_stretch_weights_keep_cell_area_and_shape_the_cells(ctx):
    """prod w = 1 (F keeps its distribution), and stretch_x = 4 makes cells longer along x."""
    w = reference.axis_scale((4.0, 1.0), 2)
    assert w[:2] == pytest.approx((0.5, 2.0)) and w[2:] == (1.0, 1.0)
    assert reference.axis_scale((1.0, 1.0, 1.0), 3) == (1.0,) * 4
    g = cellgl.cellular_grid((128, 128), spacing=1 / 16, n=1, stretch=(4.0, 1.0), outputs=("id",)).id[..., 0]
    along_x = np.mean(g[:, 1:] != g[:, :-1])        # cell boundaries crossed stepping along x
    along_y = np.mean(g[1:, :] != g[:-1, :])
    assert along_y > 2.5 * along_x
    plain = cellgl.cellular(np.random.default_rng(0).uniform(0, 50, (4000, 2)), 1, outputs=("F",)).F
    stretched = cellgl.cellular(np.random.default_rng(0).uniform(0, 50, (4000, 2)), 1, stretch=(4.0, 1.0),
                                outputs=("F",)).F
    assert abs(np.median(stretched) / np.median(plain) - 1.0) < 0.1


def test_grad_is_the_gradient_of_the_weighted_distance(ctx):
    pts = np.random.default_rng(3).uniform(0, 5, (200, 2))
    kw = dict(stretch=(3.0, 0.5), n=1)
    r = cellgl.cellular(pts, outputs=("F", "grad"), backend="numpy", **kw)
    e = 1e-3                                        # F is float32: a wide step
    fx = (cellgl.cellular(pts + [e, 0], outputs=("F",), backend="numpy", **kw).F
          - cellgl.cellular(pts - [e, 0], outputs=("F",), backend="numpy", **kw).F)[:, 0] / (2 * e)
    ok = np.abs(fx - r.grad[:, 0, 0]) < 2e-3        # a sample near a cell boundary may differ
    assert ok.mean() > 0.97
    g = cellgl.cellular(pts, outputs=("grad",), **kw)
    np.testing.assert_allclose(g.grad, r.grad, atol=1e-4)


def test_orbiting_points_stay_in_their_cells_and_loop():
    cells = _cells_around(np.zeros((1, 2)), 3)
    for phase in (0.0, 0.25, 0.7):
        fp = cellgl.feature_points(cells, orbit_radius=0.5, orbit_phase=phase, density=4.0)
        inside = fp.positions - cells[fp.cell_index]
        assert inside.min() >= 0.0 and inside.max() <= 1.0
    a = cellgl.feature_points(cells, orbit_radius=0.3, orbit_phase=0.2).positions
    b = cellgl.feature_points(cells, orbit_radius=0.3, orbit_phase=1.2).positions
    c = cellgl.feature_points(cells, orbit_radius=0.3, orbit_phase=0.45).positions
    assert np.array_equal(a, b) and np.abs(a - c).max() > 0.1
    still = cellgl.feature_points(cells).positions
    d = np.linalg.norm(a - cellgl.feature_points(cells, orbit_radius=0.3, orbit_phase=0.7).positions, axis=1)
    assert d.max() <= 0.6 + 1e-9 and np.abs(still - a).max() > 0       # on a circle of radius 0.3
    assert reference.orbit_turn(1.0) == 0 and reference.orbit_turn(0.5) == 1 << 31
    assert reference.orbit_turn(-0.25) == 3 << 30


def test_orbit_loop_is_bit_exact_on_the_gpu(ctx):
    kw = dict(n=2, spacing=0.07, orbit_radius=0.25, density=2.0)
    a = cellgl.cellular_grid((40, 40), orbit_phase=0.125, **kw)
    b = cellgl.cellular_grid((40, 40), orbit_phase=3.125, **kw)
    assert np.array_equal(a.F, b.F) and np.array_equal(a.id, b.id)
    r = load_recipe("caustics")
    frames = [texture.render(r.replace(orbit_phase=k / 4), 24, 16)["color"] for k in (0, 1, 4)]
    assert np.array_equal(frames[0], frames[2]) and not np.array_equal(frames[0], frames[1])


def test_bad_basis_arguments():
    with pytest.raises(ValueError, match=r"stretch must be in \[0.00390625, 256"):
        cellgl.cellular(np.zeros((1, 2)), stretch=(0.0, 1.0))
    with pytest.raises(ValueError, match="sequence of 2 numbers"):
        cellgl.cellular(np.zeros((1, 2)), stretch=(1.0, 2.0, 3.0))
    with pytest.raises(ValueError, match=r"orbit_radius must be in \[0.0, 0.5\]"):
        cellgl.cellular(np.zeros((1, 2)), orbit_radius=0.6)
    with pytest.raises(ValueError, match="orbit_phase"):
        cellgl.feature_points(np.zeros((1, 2), int), orbit_phase=float("nan"))
    with pytest.raises(ValueError, match="outputs edge are not available with stretched cells"):
        cellgl.cellular(np.zeros((1, 2)), stretch=(2.0, 1.0), outputs=("F", "edge"), backend="numpy")
    with pytest.raises(RecipeError, match="combination.c_edge: the cell features"):
        Recipe().replace(stretch_x=2.0, c_edge=1.0)


# ---------------------------------------------------------------------------- textures

RECIPES = {
    "warp": Recipe().replace(warp_amount=0.6, warp_frequency=0.7, warp_octaves=2, c1=-1.0, c2=1.0),
    "warp-3d-tileable": Recipe().replace(dimension=3, tileable=True, frequency=4.0, warp_amount=0.4,
                                         warp_frequency=2.0, noise_color=0.3, fractal="sum", octaves=2.0),
    "stretch-fractal": Recipe().replace(stretch_x=6.0, stretch_y=0.5, fractal="sum", octaves=3.0, light=0.5),
    "orbit-jitter": Recipe().replace(distribution="jitter", orbit_radius=0.4, orbit_phase=0.3),
    "all-far": Recipe().replace(dimension=3, warp_amount=0.3, stretch_z=3.0, orbit_radius=0.2,
                                orbit_phase=0.9, offset_x=1e6 + 0.25, offset_y=-3e5, light=0.5),
}


@pytest.mark.parametrize("name", RECIPES)
def test_texture_gpu_matches_numpy(ctx, name):
    assert_gpu_matches_numpy(RECIPES[name])


@pytest.mark.parametrize("name", ["warp", "stretch-fractal"])
def test_warped_and_stretched_gradients_match_finite_differences(name):
    """The analytic height gradient carries the warp's Jacobian and the axis weights."""
    r = RECIPES[name].replace(light=0.0)
    pts = np.random.default_rng(5).uniform(0, 1, (300, 3))
    pts[:, 2] = 0.0
    t = texture_at(pts, r, 2)
    f = r.get("frequency")
    eps = 1e-6
    for a in range(2):
        d = np.zeros(3)
        d[a] = eps
        fd = (texture_at(pts + d, r, 2)["height"] - texture_at(pts - d, r, 2)["height"]) / (2 * eps)
        analytic = t["grad"][:, a] * f
        ok = np.abs(fd - analytic) <= 1e-3 * np.maximum(1.0, np.abs(fd))
        assert ok.mean() > 0.95, (a, ok.mean())


def test_tileable_warp_is_seamless(ctx):
    r = RECIPES["warp-3d-tileable"]
    rng = np.random.default_rng(2)
    uv = np.concatenate([rng.uniform(0, 1, (200, 2)), np.full((200, 1), 0.4)], axis=1)
    base = texture.evaluate(r, uv, ("color", "height"))
    for shift in ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-1.0, 2.0, 0.0]):
        moved = texture.evaluate(r, uv + shift, ("color", "height"))
        for k in base:
            np.testing.assert_allclose(moved[k], base[k], atol=2e-4, err_msg=f"{k} {shift}")


def test_recipe_rules_and_tileable_rounding():
    r = Recipe().replace(warp_amount=0.5, warp_frequency=1.3)
    with pytest.raises(RecipeError, match=r"domain.warp_frequency: 1.3 must be a positive integer"):
        r.replace(tileable=True)
    t, notes = r.tileable()
    assert t.get("warp_frequency") == 1.0 and "warp_frequency 1.3 -> 1" in notes
    assert Recipe().replace(warp_frequency=1.3, tileable=True).get("tileable")    # no warp: no rule
    with pytest.raises(RecipeError, match=r"basis.stretch_x: out of range: 20.0; accepted: \[0.0625, 16.0\]"):
        Recipe().replace(stretch_x=20.0)
    with pytest.raises(RecipeError, match="basis.orbit_radius"):
        Recipe().set_from_strings(["orbit_radius=0.7"])
    # compile-time switches follow the values; a 2D recipe ignores stretch_z
    assert texture.defines(Recipe())["CELL_ANISO"] == 0 and texture.defines(Recipe())["CELL_ORBIT"] == 0
    assert texture.defines(Recipe().replace(stretch_z=2.0))["CELL_ANISO"] == 0
    assert texture.defines(Recipe().replace(stretch_y=2.0, orbit_radius=0.1))["CELL_ANISO"] == 1
    vals = texture.uniform_values(Recipe().replace(orbit_phase=0.25, stretch_x=4.0))
    assert vals["u_orbit_turn"] == 1 << 30 and vals["u_axis_scale"] == pytest.approx((0.5, 2.0, 1.0, 1.0))


# ---------------------------------------------------------------------------- bake --frames

def test_frames_sequence_and_animation(ctx, tmp_path):
    from PIL import Image, ImageSequence

    files = bake_frames("caustics", tmp_path / "c.png", 3, size=(16, 12))
    assert [f.name for f in files] == ["c_0000.png", "c_0001.png", "c_0002.png"]
    first = np.asarray(Image.open(files[0]))
    expect = texture.render(load_recipe("caustics"), 16, 12)["color"][..., :3]
    assert np.abs(first[..., :3] / 255.0 - expect).max() <= 0.5 / 255 + 1e-6
    assert not np.array_equal(first, np.asarray(Image.open(files[1])))
    for ext in (".webp", ".gif"):
        (out,) = bake_frames("caustics", tmp_path / f"c{ext}", 4, size=(16, 12), fps=10)
        with Image.open(out) as im:
            frames = [np.asarray(f.convert("RGB")) for f in ImageSequence.Iterator(im)]
            assert len(frames) == 4 and im.info.get("loop") == 0
        if ext == ".webp":       # lossless: frame 0 is the bake's first frame
            assert np.array_equal(frames[0], first[..., :3])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.gif", "c.webp", "c_0000.png", "c_0001.png",
                                                          "c_0002.png"]


def test_frames_are_all_or_nothing(ctx, tmp_path, monkeypatch):
    import cellgl.recipes as T

    real, calls = T.render, []

    def flaky(recipe, *a, **kw):
        calls.append(1)
        if len(calls) == 3:
            raise RuntimeError("GPU lost")
        return real(recipe, *a, **kw)

    monkeypatch.setattr(T, "render", flaky)
    for name in ("s.png", "s.webp"):
        calls.clear()
        with pytest.raises(RuntimeError, match="GPU lost"):
            bake_frames("caustics", tmp_path / name, 4, size=(8, 8))
    assert list(tmp_path.iterdir()) == []


def test_frames_errors(tmp_path, capsys):
    def run(*argv):
        return cli.main(["bake", *argv])

    assert run("veins", "-o", str(tmp_path / "v.png"), "--frames", "4") != 0
    assert "does not move (basis.orbit_radius is 0)" in capsys.readouterr().err
    assert run("caustics", "-o", str(tmp_path / "v.png"), "--frames", "0") != 0
    assert "--frames 0: out of range; accepted 1..10000" in capsys.readouterr().err
    assert run("caustics", "-o", str(tmp_path / "v.gif"), "--frames", "2", "--channels", "height") != 0
    assert "holds the colour only" in capsys.readouterr().err
    assert run("caustics", "-o", str(tmp_path / "v.webp"), "--frames", "2", "--fps", "500") != 0
    assert "--fps 500.0: accepted for .webp a number in 1..95" in capsys.readouterr().err
    assert run("caustics", "-o", str(tmp_path / "v.bmp"), "--frames", "2") != 0
    assert "unknown extension '.bmp'" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []
