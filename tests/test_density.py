"""Spatially varying feature density: exact integer levels (GPU == NumPy on every cell), the
search stays exact (brute force), the map does what it says, bad input, the texture layer."""
from __future__ import annotations

import itertools

import numpy as np
import pytest

import cellgl
from cellgl.basis import core
from cellgl.basis import density
from cellgl.basis import gpu
from cellgl.basis import reference

IMG = np.random.default_rng(0).uniform(0.0, 1.0, (7, 13))
MAPS = {
    "ramp_x": cellgl.DensityMap("ramp", 0.3, 10.0, axis=0, start=-6.2, end=17.9),
    "ramp_y_down": cellgl.DensityMap("ramp", 0.3, 10.0, axis=1, start=13.3, end=-7.1),
    "ramp_z": cellgl.DensityMap("ramp", 1.0, 6.0, axis=2, start=-3.0, end=3.0),
    "radial": cellgl.DensityMap("radial", 0.5, 12.0, center=(3.3, -2.2), radius=7.5),
    "radial_small": cellgl.DensityMap("radial", 0.5, 12.0, center=(0.3, -0.2, 0.7), radius=2.5),
    "image": cellgl.DensityMap("image", 0.5, 12.0, image=IMG, rect=(-3.3, -4.0, 11.7, 9.1)),
}


def _cells(dim, n=30000, lo=-40, hi=40, seed=1):
    c = np.random.default_rng(seed).integers(lo, hi, (n, 4))
    c[:, dim:] = 0
    return c


def _ref_counts(c, p):
    wc = reference.wrap(c, p.period)
    _, count = reference.point_count(reference.cell_seed(wc, p), p, wc)
    return count, reference.density_level(wc, p)


# ramp_z and radial_small need a third axis
_CASES = [(name, dim) for dim in (2, 3, 4) for name in MAPS
          if not (dim == 2 and name in ("ramp_z", "radial_small"))]


@pytest.mark.parametrize("name,dim", _CASES)
def test_gpu_counts_equal_reference_on_every_cell(ctx, name, dim):
    dm = MAPS[name]
    for kw in (dict(min_points=0, max_points=16), dict(), dict(period=[24] * dim)):
        p = core.make_params(dim, density_map=dm, **kw)
        # dense block around the map plus scattered far cells
        block = np.array(list(itertools.product(range(-12, 22), range(-12, 22)) if dim == 2 else
                              itertools.product(range(-8, 16), range(-8, 16), range(-4, 4))))
        c = np.zeros((len(block), 4), np.int64)
        c[:, : block.shape[1]] = block
        # far cells too (periodic: cell_wrap's contract is |c| < 2^24, the search wraps first)
        far = 2 ** 23 if "period" in kw else 2 ** 29
        c = np.concatenate([c, _cells(dim), _cells(dim, 2000, -far, far, seed=5)])
        gc, gl = gpu.cell_counts(c, p)
        rc, rl = _ref_counts(c, p)
        np.testing.assert_array_equal(gl, rl)
        np.testing.assert_array_equal(gc, rc)
        assert len(np.unique(rl)) >= 2


def _math_level(centres, dm):
    """The map's definition in float64 (the integer encoding rounds it to 2^-shift)."""
    if dm.kind == "ramp":
        v = (centres[:, dm.axis] - dm.start) / (dm.end - dm.start)
    elif dm.kind == "radial":
        k = len(dm.center)
        v = np.linalg.norm(centres[:, :k] - np.array(dm.center), axis=1) / dm.radius
    else:
        x0, y0, x1, y1 = dm.rect
        h, w = dm.image.shape
        tx = np.clip(np.floor((centres[:, 0] - x0) / (x1 - x0) * w), 0, w - 1).astype(int)
        ty = np.clip(np.floor((centres[:, 1] - y0) / (y1 - y0) * h), 0, h - 1).astype(int)
        v = dm.image[ty, tx]
    return np.clip(np.floor(np.clip(v, 0, 1) * 15 + 0.5), 0, 15).astype(int)


@pytest.mark.parametrize("name", list(MAPS))
def test_levels_follow_the_definition(name):
    dm = MAPS[name]
    dim = 3
    c = _cells(dim, 20000)
    lv = reference.density_level(c, core.make_params(dim, density_map=dm))
    want = _math_level(c[:, :dim] + 0.5, dm)
    # fixed point: only cells whose centre lies within rounding of a level boundary may differ
    assert (lv != want).mean() < 2e-3
    assert np.abs(lv - want).max() <= 1


def test_level_densities_are_geometric():
    dm = cellgl.DensityMap("ramp", 0.5, 8.0, start=0, end=1)
    d = dm.level_densities()
    assert d[0] == pytest.approx(0.5) and d[15] == pytest.approx(8.0)
    np.testing.assert_allclose(d[1:] / d[:-1], (8.0 / 0.5) ** (1 / 15))
    enc = density.encode(dm, 2)
    for L in (0, 7, 15):
        np.testing.assert_array_equal(enc.thresholds[L], reference.poisson_thresholds(d[L]))


def test_count_statistics_follow_the_map():
    """Mean points per cell in each level band matches that level's (clamped) Poisson mean."""
    dm = cellgl.DensityMap("ramp", 0.5, 8.0, axis=0, start=0.0, end=160.0)
    cells = np.array(list(itertools.product(range(0, 160), range(0, 400))))
    fp = cellgl.feature_points(cells, density_map=dm, min_points=0, max_points=16)
    per_cell = np.bincount(fp.cell_index, minlength=len(cells)).reshape(160, 400)
    for x in (5, 80, 154):
        L = int(np.floor(15 * (x + 0.5) / 160 + 0.5))
        lam = dm.level_densities()[L]
        assert per_cell[x].mean() == pytest.approx(lam, rel=0.12)


BRUTE = [
    (2, "euclidean", dict(density_map=MAPS["ramp_x"], min_points=0)),
    (2, "manhattan", dict(density_map=MAPS["radial"])),
    (2, "euclidean", dict(density_map=MAPS["image"], min_points=0)),
    (3, "euclidean", dict(density_map=MAPS["radial_small"], min_points=0)),
    (3, "chebyshev", dict(density_map=MAPS["ramp_z"])),
]


def _brute(points, fp_pos, fp_ids, metric, n):
    d = np.abs(fp_pos[None, :, :] - points[:, None, :])
    dist = {"euclidean": lambda a: np.sqrt((a * a).sum(-1)), "manhattan": lambda a: a.sum(-1),
            "chebyshev": lambda a: a.max(-1)}[metric](d)
    order = np.argsort(dist, axis=1, kind="stable")[:, :n]
    return np.take_along_axis(dist, order, 1), fp_ids[order]


@pytest.mark.parametrize("dim,metric,kw", BRUTE)
def test_search_with_varying_density_equals_brute_force(ctx, dim, metric, kw):
    """Dense and sparse regions side by side: the pruned search (GPU and reference) returns
    exactly the n nearest of all feature points."""
    n = 6 if dim == 2 else 4
    lo, hi = (-8.0, 18.0) if dim == 2 else (-3.0, 4.0)
    pts = np.random.default_rng(dim).uniform(lo, hi, (500, dim))
    r = cellgl.cellular(pts, n, metric=metric, backend="numpy", outputs=("F", "id"), **kw)
    g = cellgl.cellular(pts, n, metric=metric, outputs=("F", "id"), **kw)
    assert r.exact.all() and g.exact.all()
    reach = 7 if dim == 2 else 5
    cells = np.array(list(itertools.product(range(int(lo) - reach, int(hi) + reach + 1), repeat=dim)))
    fp = cellgl.feature_points(cells, **kw)
    F, ids = _brute(pts, fp.positions, fp.ids, metric, n)
    np.testing.assert_allclose(r.F, F, rtol=1e-6, atol=1e-6)
    assert (r.id != ids).sum() == 0
    np.testing.assert_allclose(g.F, F, rtol=2e-5, atol=2e-6)
    assert (g.id != ids).sum() <= 2      # float32 ties only


def test_grid_matches_reference(ctx):
    kw = dict(density_map=MAPS["radial"], n=2, outputs=("F", "id"))
    g = cellgl.cellular_grid((40, 50), origin=(-6, -12), spacing=0.37, **kw)
    r = cellgl.cellular_grid((40, 50), origin=(-6, -12), spacing=0.37, backend="numpy", **kw)
    np.testing.assert_allclose(g.F, r.F, rtol=2e-5, atol=2e-6)
    assert (g.id != r.id).mean() < 1e-3


def test_small_cells_where_dense():
    """F1 is smaller on the dense side of a ramp."""
    dm = cellgl.DensityMap("ramp", 0.25, 12.0, axis=0, start=0, end=40)
    pts = np.random.default_rng(3).uniform(0, 40, (4000, 2))
    F1 = cellgl.cellular(pts, 1, density_map=dm, min_points=0, backend="numpy", outputs=("F",)).F[:, 0]
    assert F1[pts[:, 0] < 6].mean() > 3 * F1[pts[:, 0] > 34].mean()


def test_default_path_unchanged(ctx):
    """No map: the shader has no density code (the macro is 0) and the results are as before."""
    from cellgl.basis import gpu

    p = core.make_params(2)
    assert gpu.defines_for(p, 4)["CELL_DENSITY_MAP"] == 0
    pts = np.random.default_rng(0).uniform(-5, 5, (300, 2))
    a = cellgl.cellular(pts, 3, outputs=("F", "id"))
    b = cellgl.cellular(pts, 3, outputs=("F", "id"), backend="numpy")
    np.testing.assert_array_equal(a.id, b.id)


@pytest.mark.parametrize("call,match", [
    (lambda: cellgl.DensityMap("wave"), r"kind 'wave'.*ramp, radial, image"),
    (lambda: cellgl.DensityMap("ramp", 0.0, 3.0), r"density_min must be in \(0.0, 16.0\], got 0.0"),
    (lambda: cellgl.DensityMap("ramp", 1.0, 17.0), r"density_max must be in"),
    (lambda: cellgl.DensityMap("ramp", start=2, end=2), r"start and end must differ"),
    (lambda: cellgl.DensityMap("ramp", axis=5), r"axis must be an integer in \[0, 3\], got 5"),
    (lambda: cellgl.DensityMap("radial", radius=0), r"radius must be in"),
    (lambda: cellgl.DensityMap("radial", center=(1, 2, 3, 4, 5)), r"center must have 1..4"),
    (lambda: cellgl.DensityMap("image"), r"image must have shape \(h, w\)"),
    (lambda: cellgl.DensityMap("image", image=np.full((4, 4), 1.5)), r"values must be finite and in \[0, 1\]"),
    (lambda: cellgl.DensityMap("image", image=np.zeros((4, 4)), rect=(0, 0, -1, 1)), r"x0 < x1"),
    (lambda: cellgl.cellular(np.zeros((2, 2)), density_map=cellgl.DensityMap("ramp", axis=2)),
     r"axis must be in \[0, 1\] for 2D points, got 2"),
    (lambda: cellgl.cellular(np.zeros((2, 2)), distribution="jitter", density_map=MAPS["radial"]),
     r"needs distribution 'poisson', got 'jitter'"),
    (lambda: cellgl.cellular(np.zeros((2, 2)), density_map="ramp"), r"cellgl.DensityMap, got str"),
    (lambda: cellgl.feature_points(np.zeros((2, 2), int), density_map=MAPS["radial_small"]),
     r"at most 2 coordinates"),
])
def test_bad_input_is_a_clear_error(call, match):
    with pytest.raises(ValueError, match=match):
        call()
