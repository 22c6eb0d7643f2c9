"""Voronoi-cell features (distance to edge, smooth F1, n-sphere radius, cell position and colour):
GPU vs NumPy reference vs brute force over feature_points, gradients, bad input."""
from __future__ import annotations

import itertools

import numpy as np
import pytest

import cellgl
from cellgl.basis import features
from cellgl.basis.core import make_params, split
from compare import assert_same_bits
from conftest import driver_loop_limit

ALL = features.OUTPUTS
EUCLID = ("edge", "edge_grad", "nsphere", "position", "color", "smooth_F1", "smooth_position",
          "smooth_grad", "smooth_color")
SMOOTH = ("position", "color", "smooth_F1", "smooth_position", "smooth_grad", "smooth_color")

GPU_CASES = [
    (2, "euclidean", dict(distribution="poisson"), EUCLID),
    (2, "euclidean", dict(distribution="poisson", density=0.4, min_points=0), EUCLID),   # big empty regions
    (3, "euclidean", dict(distribution="jitter", jitter=0.8), EUCLID),
    (3, "euclidean", dict(distribution="worley1996"), EUCLID),
    (4, "euclidean", dict(distribution="poisson", density=1.5), EUCLID),
    (2, "euclidean", dict(distribution="jitter", period=(5, 7)), EUCLID),
    (2, "manhattan", dict(distribution="poisson"), SMOOTH),
    (3, "minkowski", dict(distribution="poisson", minkowski_p=1.5), SMOOTH),
]


def _pts(dim, n=300, lo=-4.0, hi=4.0, seed=3):
    return np.random.default_rng(seed).uniform(lo, hi, (n, dim))


@pytest.mark.parametrize("dim,metric,kw,outs", GPU_CASES)
def test_gpu_matches_reference(ctx, dim, metric, kw, outs):
    pts = _pts(dim)
    g = cellgl.cellular(pts, 1, metric=metric, outputs=outs, smoothness=0.12, **kw)
    r = cellgl.cellular(pts, 1, metric=metric, outputs=outs, smoothness=0.12, backend="numpy", **kw)
    assert g.exact.all() and r.exact.all()
    for name in outs:
        a, b = getattr(g, name), getattr(r, name)
        assert a.shape == b.shape, name
        tol = 1e-6 if name == "position" else 2e-5
        # gradients and blended colours change fast only where a weight or the nearest plane
        # switches; compare them where the F1 point is the same
        np.testing.assert_allclose(a, b, atol=tol if "grad" not in name else 2e-4, rtol=2e-5, err_msg=name)
    assert g.position.dtype == np.float64 and g.edge is not None or "edge" not in outs


def _box_points(pts, kw, pad):
    """Every feature point in the cells covering pts, widened by pad cells."""
    dim = pts.shape[1]
    lo = np.floor(pts.min(0)).astype(int) - pad
    hi = np.floor(pts.max(0)).astype(int) + pad
    cells = np.array(list(itertools.product(*[range(lo[a], hi[a] + 1) for a in range(dim)])))
    return cellgl.feature_points(cells, **kw)


BRUTE = [
    (2, dict(distribution="poisson")),
    (2, dict(distribution="poisson", density=0.3, min_points=0)),     # sparse: cells empty, big Voronoi cells
    (2, dict(distribution="jitter", jitter=1.0)),
    (3, dict(distribution="poisson", density=0.8, min_points=0)),
    (3, dict(distribution="jitter", jitter=0.5)),
]


@pytest.mark.parametrize("dim,kw", BRUTE)
def test_exact_against_brute_force(dim, kw):
    pts = _pts(dim, n=150 if dim == 2 else 60, lo=-2.0, hi=2.0)
    r = cellgl.cellular(pts, 1, outputs=("edge", "nsphere", "smooth_F1", "position"), smoothness=0.1,
                        backend="numpy", **kw)
    assert r.exact.all()
    fp = _box_points(pts, kw, pad=9 if dim == 2 else 5)
    bf = features.brute_force(pts, fp.positions, smoothness=0.1)
    np.testing.assert_allclose(r.edge, bf["edge"], atol=1e-6)
    np.testing.assert_allclose(r.nsphere, bf["nsphere"], atol=1e-6)
    np.testing.assert_allclose(r.position, bf["position"], atol=1e-6)
    np.testing.assert_allclose(r.smooth_F1, bf["smooth_F1"], atol=1e-6)


def test_gpu_exact_against_brute_force_sparse(ctx):
    kw = dict(distribution="poisson", density=0.25, min_points=0)
    pts = _pts(2, n=200, lo=-3.0, hi=3.0, seed=11)
    g = cellgl.cellular(pts, 1, outputs=("edge", "nsphere"), **kw)
    bf = features.brute_force(pts, _box_points(pts, kw, pad=10).positions)
    assert g.exact.all()
    np.testing.assert_allclose(g.edge, bf["edge"], atol=2e-5, rtol=2e-5)
    np.testing.assert_allclose(g.nsphere, bf["nsphere"], atol=2e-5, rtol=2e-5)


def test_a_fixed_window_is_wrong_where_the_walk_is_exact():
    """Blender and Material Maker look for the nearest bisector in the 3^d cells around the
    sample; next to big cells that misses the nearest border. The walk does not."""
    kw = dict(distribution="poisson", density=0.3, min_points=0)
    pts = _pts(2, n=400, lo=-3.0, hi=3.0, seed=5)
    r = cellgl.cellular(pts, 1, outputs=("edge",), backend="numpy", **kw)
    fp = _box_points(pts, kw, pad=9)
    exact = features.brute_force(pts, fp.positions)["edge"]
    window = np.empty(len(pts))
    for i, x in enumerate(pts):
        own = np.all(np.abs(np.floor(fp.positions) - np.floor(x)) <= 1, axis=1)
        window[i] = features.brute_force(x[None], fp.positions[own])["edge"][0] if own.sum() > 1 else np.inf
    np.testing.assert_allclose(r.edge, exact, atol=1e-6)
    assert np.sum(np.abs(window - exact) > 1e-3) > 10


@pytest.mark.parametrize("metric", ["euclidean", "manhattan"])
def test_gradients_match_finite_differences(metric):
    pts = _pts(2, n=200, seed=8)
    outs = ("smooth_F1", "smooth_grad") + (("edge", "edge_grad") if metric == "euclidean" else ())
    kw = dict(metric=metric, outputs=outs, smoothness=0.15, backend="numpy")
    r = cellgl.cellular(pts, 1, **kw)
    h = 1e-5
    for name in ("smooth_F1", "edge")[: len(outs) // 2]:
        fd = np.stack([(getattr(cellgl.cellular(pts + h * np.eye(2)[a], 1, **kw), name)
                        - getattr(cellgl.cellular(pts - h * np.eye(2)[a], 1, **kw), name)) / (2 * h)
                       for a in range(2)], axis=1)
        grad = getattr(r, "smooth_grad" if name == "smooth_F1" else "edge_grad")
        ok = np.all(np.abs(fd - grad) < 2e-2, axis=1)       # away from kinks (nearest plane switches)
        assert ok.mean() > 0.9, name


def test_smoothness_zero_is_the_hard_minimum_and_blends_grow_with_it():
    pts = _pts(2, n=200)
    r0 = cellgl.cellular(pts, 1, outputs=("F", "color") + SMOOTH, smoothness=0.0, backend="numpy")
    np.testing.assert_allclose(r0.smooth_F1, r0.F[:, 0], atol=1e-7)
    np.testing.assert_allclose(r0.smooth_color, r0.color, atol=1e-7)
    np.testing.assert_allclose(r0.smooth_position, r0.position, atol=1e-7)
    r1 = cellgl.cellular(pts, 1, outputs=("F",) + SMOOTH, smoothness=0.2, backend="numpy")
    assert np.all(r1.smooth_F1 <= r1.F[:, 0] + 1e-9)
    assert np.mean(r1.F[:, 0] - r1.smooth_F1) > 0.01


def test_edge_is_zero_on_the_border_and_position_is_the_nearest_point():
    r = cellgl.cellular(_pts(2, n=300), 2, outputs=("F", "delta", "edge", "position", "nsphere"), backend="numpy")
    # the edge distance never exceeds half the F1-F2 gap's bound (F2 - F1) / 2 <= E ... <= (F1 + F2) / 2
    F1, F2 = r.F[:, 0], r.F[:, 1]
    assert np.all(r.edge >= (F2 - F1) / 2 - 1e-6) and np.all(r.edge <= (F1 + F2) / 2 + 1e-6)
    # n-sphere: the ball around the F1 point inside its cell reaches no further than the sample's border
    assert np.all(r.nsphere <= F1 + r.edge + 1e-6)


def test_color_is_the_bake_id_false_colour():
    from cellgl.io.spec import id_colors

    r = cellgl.cellular(_pts(2, n=50), 1, outputs=("id", "color"), backend="numpy")
    np.testing.assert_array_equal(np.round(r.color * 255).astype(np.uint8), id_colors(r.id[:, 0]))


def test_grid_features_match_point_features(ctx):
    g = cellgl.cellular_grid((12, 16), origin=(0.1, 0.2), spacing=0.25, n=1,
                             outputs=("edge", "position", "smooth_position"))
    ys, xs = np.mgrid[0:12, 0:16]
    pts = np.stack([0.1 + 0.25 * xs, 0.2 + 0.25 * ys], axis=-1).reshape(-1, 2)
    p = cellgl.cellular(pts, 1, outputs=("edge", "position", "smooth_position"))
    np.testing.assert_allclose(g.edge.reshape(-1), p.edge, atol=1e-6)
    np.testing.assert_allclose(g.position.reshape(-1, 2), p.position, atol=1e-5)
    np.testing.assert_allclose(g.smooth_position.reshape(-1, 2), p.smooth_position, atol=1e-5)
    assert g.edge.shape == (12, 16) and g.position.shape == (12, 16, 2)


def test_walk_cap_is_reported_not_wrong():
    from cellgl.basis import reference

    kw = dict(distribution="poisson", density=0.05, min_points=0)
    pts = _pts(2, n=100, lo=-20, hi=20)
    p = make_params(2, **kw)
    cells, fr = split(pts)
    F, D, I, ex = reference.search(cells, fr, p, 1)
    out = features.features(cells, fr, p, F, D, I, ex, ("edge",), max_ring=1)
    full = features.features(cells, fr, p, F, D, I, ex, ("edge",), max_ring=40)
    assert not out["exact"].all()
    ok = out["exact"] & full["exact"]
    np.testing.assert_allclose(out["edge"][ok], full["edge"][ok])


@pytest.mark.parametrize("bad,match", [
    (dict(metric="manhattan", outputs=("edge",)), "needs metric 'euclidean'"),
    (dict(metric="chebyshev", outputs=("nsphere",)), "needs metric 'euclidean'"),
    (dict(outputs=("smooth_F1",), smoothness=0.5), r"smoothness must be a number in \[0, 0.25\]"),
    (dict(outputs=("smooth_F1",), smoothness=float("nan")), "smoothness"),
    (dict(outputs=("edges",)), "unknown output 'edges'"),
])
def test_bad_input(bad, match):
    with pytest.raises(ValueError, match=match):
        cellgl.cellular(_pts(2, n=4), 1, backend="numpy", **bad)


def test_fast_path_defines_are_unchanged():
    from cellgl.basis import gpu

    p = make_params(2)
    d = gpu.defines_for(p, 4, ("F", "delta", "id"))
    assert d["CELL_EDGE"] == d["CELL_SMOOTH"] == d["CELL_NSPHERE"] == 0
    d = gpu.defines_for(p, 1, ("F", "edge", "smooth_F1"))
    assert d["CELL_EDGE"] == d["CELL_SMOOTH"] == 1 and d["CELL_NSPHERE"] == 0


@pytest.mark.parametrize("dim", [2, 3, 4])
def test_one_search_for_the_basis_and_every_walk(ctx, monkeypatch, dim):
    """F + edge + n-sphere + smooth F1 (n = 1) is one GPU pass: one search, each walk after it on its
    own; every output has the bits, and the flag, it has when asked alone. With n > 1 the basis
    searches further than the walks need: it keeps its pass, the walks share one."""
    from cellgl.basis import gpu

    calls = []
    orig = gpu.search_points
    monkeypatch.setattr(gpu, "search_points", lambda *a, **k: calls.append(a[3]) or orig(*a, **k))
    X = _pts(dim, n=500, lo=-6.0, hi=6.0, seed=dim)
    outs = ("F", "id", "edge", "edge_grad", "nsphere", "smooth_F1", "smooth_grad")
    for n, passes in ((1, 1), (3, 2)):
        calls.clear()
        g = cellgl.cellular(X, n, outputs=outs, smoothness=0.1)
        assert len(calls) == passes, calls
        alone = {o: cellgl.cellular(X, n, outputs=(o,), smoothness=0.1) for o in outs}
        for o in outs:
            assert_same_bits(g, alone[o], o, fields=(o,))
        assert g.exact.all()


def test_a_pass_cut_by_the_driver_runs_again_walk_by_walk():
    """Where the canary of the pass apart says llvmpipe's own limit cut a loop (then no part's flag
    holds), the call runs again with each walk in a pass of its own."""
    from cellgl.basis import passes

    p = make_params(2)
    seen = []

    def run(outputs):
        seen.append(outputs)
        lay = features.layout(outputs)
        rec = np.zeros((4, lay["stride"]), np.float32)
        ok = np.ones(4, bool)
        if "walks" in lay:
            rec[:, lay["walks"]] = 31.0
            rec[2, lay["walks"]] = 15.0   # flagged, the canary cut short: the driver's limit
            ok[2] = False
        got = {"F": np.zeros((4, 1), np.float32)} if "F" in outputs else {}
        if lay["stride"]:
            got["features"] = rec
        return got, ok

    out, got = passes.gpu_passes(run, ("F", "edge", "smooth_F1"), 4, p, 1)
    assert seen[0] == ("F", "edge", "smooth_F1") and seen[1:] == [("F",), ("edge",), ("smooth_F1",)]
    assert len(got) == 3 and all(ok.all() for _, ok in got)


def test_the_walks_field_splits_the_flags_per_part():
    """A sample the edge walk left open is flagged for the edge only: its F and smooth F1 stay the
    GPU's (their bits do not depend on what else was asked)."""
    from cellgl.basis import passes

    p = make_params(2)

    def run(outputs):
        lay = features.layout(outputs)
        rec = np.zeros((3, lay["stride"]), np.float32)
        rec[:, lay["walks"]] = [31, 31 & ~features.WALK_BITS["edge"], features.WALK_BITS["canary"]]
        return {"F": np.zeros((3, 1), np.float32), "features": rec}, np.array([True, False, False])

    out, got = passes.gpu_passes(run, ("F", "edge", "smooth_F1"), 3, p, 1)
    flags = {names[0]: ok.tolist() for names, ok in got}
    assert flags == {"F": [True, True, False], "edge": [True, False, False], "smooth_F1": [True, True, False]}


@pytest.mark.parametrize("k", [0.0, 1e-30])
def test_smooth_f1_at_zero_and_tiny_smoothness_is_f1(ctx, k):
    """k = 0 (and a k so small that exp((F1 - d) / k) overflows for a d a rounding below F1) is the
    hard minimum: S = F1, finite, in every ring the walk reaches."""
    X = _pts(3, n=400, lo=-30.0, hi=30.0, seed=5)
    r = cellgl.cellular(X, 1, outputs=("F", "smooth_F1"), smoothness=k, density=0.3, min_points=0)
    assert np.isfinite(r.smooth_F1).all()
    np.testing.assert_array_equal(r.smooth_F1[r.exact], r.F[r.exact, 0])


def test_a_real_driver_cut_of_the_pass_apart_gives_the_bits_of_each_alone(ctx, monkeypatch):
    """With the loop budget lifted (10^6), 4D smooth F1 at k = 0.25 (Poisson 8, up to 16 points a
    cell) spends more than llvmpipe's 65535 loop passes per SIMD vector: the pass that runs every walk is cut by the driver, the
    canary flags it, and the call runs again walk by walk. Every output and flag is what each
    walk alone gives with the same budget (where the driver cuts nothing: the pass apart's)."""
    from cellgl.basis import gpu, passes

    orig_defines = gpu.defines_for
    monkeypatch.setattr(gpu, "defines_for", lambda *a, **k: {**orig_defines(*a, **k), "CELL_LOOP_BUDGET": 10 ** 6})
    seen = []
    orig = passes.gpu_passes
    monkeypatch.setattr(passes, "gpu_passes", lambda *a, **k: seen.append(k.get("apart", True)) or orig(*a, **k))
    X = np.random.default_rng(4).uniform(-9, 9, (64, 4))
    outs = ("edge", "nsphere", "smooth_F1")
    kw = dict(density=8.0, max_points=16, smoothness=0.25)      # 56 of 64 cut on llvmpipe (AVX2)
    g = cellgl.cellular(X, 1, outputs=outs, **kw)
    if driver_loop_limit(ctx) is not None:
        assert False in seen, "the pass apart was not cut by the driver's limit: the redo was not reached"
    for o in outs:
        a = cellgl.cellular(X, 1, outputs=(o,), **kw)
        assert_same_bits(g, a, o, fields=(o,))
