"""exact=True never lies (issue 21; docs/exactness.md).

Every answer of :func:`cellgl.cellular` / :func:`cellgl.cellular_grid` flagged exact is checked
against a brute force written here: every feature point of a block of cells around the samples
(the point process itself from :func:`cellgl.feature_points`), then the n nearest by sorting all
distances, and the features by their definitions. The matrix covers dimensions x distributions x
metrics x n up to 8 x the feature walks (smooth up to the largest smoothness) x period x sample
magnitudes up to 5e8. Then the loop budget: a tiny ``CELL_LOOP_BUDGET`` makes the GPU flag
samples, which must come back exact after the fallback, never wrong; a huge one lets llvmpipe's
own limiter cut loops, which the canary must catch. And the two reproducers of the issue.
"""
from __future__ import annotations

import itertools

import numpy as np
import pytest

import cellgl
from cellgl.basis import core, gpu
from compare import (TOL, assert_F_within_bound, assert_ids_equal_but_ties, assert_never_wrong_while_exact,
                     assert_same_bits, near_ties)
from conftest import driver_loop_limit

METRICS = ("euclidean", "manhattan", "chebyshev", "minkowski")
DISTS = {
    "poisson": {},
    "sparse": dict(density=0.25, min_points=0),
    "jitter": dict(distribution="jitter", jitter=0.7),
    "worley1996": dict(distribution="worley1996"),
    "blender": dict(distribution="blender", jitter=0.8),
}
#: cells of margin around the sample box holding every point that can matter
REACH = {2: 9, 3: 8, 4: 7}
SPAN = 1.5          #: the samples fill [base, base + SPAN)^d


def _distances(diff: np.ndarray, metric: str, p: float = 3.0) -> np.ndarray:
    a = np.abs(diff)
    if metric == "euclidean":
        return np.sqrt((a * a).sum(-1))
    if metric == "manhattan":
        return a.sum(-1)
    if metric == "chebyshev":
        return a.max(-1)
    return (a ** p).sum(-1) ** (1.0 / p)


def _block(dim: int, base: float, kw: dict):
    """Every feature point within REACH cells of the sample box, relative to ``base`` (sample
    units), and the sample-unit distance from the box to the block's border."""
    scale = 0.398150 if kw.get("distribution") == "worley1996" else 1.0
    r = REACH[dim]
    lo = int(np.floor((base - r) * scale))
    hi = int(np.floor((base + SPAN + r) * scale))
    axes = [np.arange(lo, hi + 1)] * dim
    cells = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, dim)
    keep = {k: v for k, v in kw.items() if k not in ("metric", "minkowski_p")}
    fp = cellgl.feature_points(cells, **keep)
    return fp.positions - base, r - 1.0 / scale


def _samples(dim: int, base: float, count: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Samples at ``base + u`` (float64, as a user passes them) and the same relative to base."""
    u = np.random.default_rng(seed).uniform(0.0, SPAN, (count, dim))
    x = base + u
    return x, x - base


def _brute(rel: np.ndarray, pts: np.ndarray, n: int, metric: str, k: float = 0.0) -> dict:
    """F1..Fn, edge, n-sphere radius and smooth F1 (smoothness k, no cut-off) by testing every
    point, per sample."""
    F, edge, nsphere, smooth = [], [], [], []
    for x in rel:
        diff = pts - x
        d = _distances(diff, metric)
        order = np.argsort(d)
        F.append(d[order[:n]])
        p1 = pts[order[0]]
        e = pts - p1
        el = np.sqrt((e * e).sum(-1))
        other = el > 0
        b = (((0.5 * (pts + p1) - x) * e).sum(-1)[other]) / el[other]
        edge.append(b.min())
        nsphere.append(0.5 * el[other].min())
        d1 = d[order[0]]
        smooth.append(d1 - k * np.log(np.exp(-(d - d1) / k).sum()) if k > 0 else d1)
    return dict(F=np.array(F), edge=np.array(edge), nsphere=np.array(nsphere), smooth_F1=np.array(smooth))


MAGNITUDES = (0.0, -30001.0, 499999999.0)


@pytest.mark.parametrize("base", MAGNITUDES, ids=["0", "-3e4", "5e8"])
@pytest.mark.parametrize("periodic", [False, True], ids=["free", "period"])
@pytest.mark.parametrize("dist", list(DISTS))
@pytest.mark.parametrize("dim", [2, 3, 4])
def test_basis_matrix(ctx, dim, dist, periodic, base):
    """F1..F8 of every metric, and grad/ids consistent with them, against the brute force."""
    if dist == "worley1996" and dim != 3:
        pytest.skip("worley1996 is 3D only")
    kw = dict(DISTS[dist])
    if periodic:
        kw["period"] = (5, 7, 3, 4)[:dim]
    x, rel = _samples(dim, base, 24, seed=dim)
    for metric in METRICS:
        mkw = dict(kw, metric=metric)
        pts, reach = _block(dim, base, mkw)
        want = _brute(rel, pts, 8, metric)
        n = 8 if metric != "chebyshev" else 3          # n below 8 too
        r = cellgl.cellular(x, n, outputs=("F",), **mkw)
        assert_never_wrong_while_exact(f"{dim}D {dist} {metric} period={periodic} base={base}", r.F, want["F"][:, :n], r.exact,
               reach=reach)


@pytest.mark.parametrize("metric", ["euclidean", "manhattan", "chebyshev"])
@pytest.mark.parametrize("dim", [2, 3, 4])
def test_reference_within_the_promised_bound(ctx, dim, metric):
    """The promise every conformant driver keeps (docs/exactness.md, "What is promised"): against
    the NumPy reference (float64), F within f_bound and IDs equal but at near-ties, at the origin
    and 10^6 cells away, periodic too (Poisson, jitter; n = 4)."""
    rng = np.random.default_rng(40 + dim)
    for base, kw in [(0.0, {}), (1e6 + 0.5, dict(distribution="jitter", jitter=0.9)),
                     (-3e4, dict(period=(5, 7, 3, 4)[:dim]))]:
        x = base + rng.uniform(-4.0, 4.0, (3000, dim))
        r = cellgl.cellular(x, 4, metric=metric, outputs=("F", "id"), **kw)
        ref = cellgl.cellular(x, 4, metric=metric, outputs=("F", "id"), backend="numpy", **kw)
        assert r.exact.all()
        assert_F_within_bound(r.F, ref.F, what=(base, kw))
        assert_ids_equal_but_ties(r.id, ref.id, near_ties(ref.F), (base, kw))


@pytest.mark.parametrize("smoothness", [0.05, 0.25])
@pytest.mark.parametrize("dist", ["poisson", "sparse", "jitter"])
@pytest.mark.parametrize("dim", [2, 3, 4])
def test_features_matrix(ctx, dim, dist, smoothness):
    """edge, n-sphere radius and smooth F1 (up to the largest smoothness), asked together, with a
    period and far from the origin, against the brute force."""
    base = 499999999.0 if dim == 2 else 12345.0
    kw = dict(DISTS[dist], period=(6, 5, 4, 3)[:dim] if dim != 3 else None)
    x, rel = _samples(dim, base, 16 if dim == 4 else 24, seed=10 + dim)
    pts, reach = _block(dim, base, kw)
    want = _brute(rel, pts, 1, "euclidean", smoothness)
    assert np.all(want["F"][:, 0] + 16 * smoothness < reach), "block too small for smooth F1"
    r = cellgl.cellular(x, 1, outputs=("edge", "nsphere", "smooth_F1"), smoothness=smoothness, **kw)
    name = f"{dim}D {dist} k={smoothness}"
    assert_never_wrong_while_exact(name + " edge", r.edge, want["edge"], r.exact)
    assert_never_wrong_while_exact(name + " nsphere", r.nsphere, want["nsphere"], r.exact)
    assert_never_wrong_while_exact(name + " smooth_F1", r.smooth_F1, want["smooth_F1"], r.exact)


@pytest.mark.parametrize("metric", ["manhattan", "minkowski"])
def test_smooth_other_metrics_at_the_largest_smoothness(ctx, metric):
    x, rel = _samples(3, 77.0, 16, seed=5)
    pts, reach = _block(3, 77.0, {})
    want = _brute(rel, pts, 1, metric, 0.25)
    r = cellgl.cellular(x, 1, metric=metric, outputs=("smooth_F1",), smoothness=0.25)
    assert_never_wrong_while_exact(f"smooth {metric}", r.smooth_F1, want["smooth_F1"], r.exact)


@pytest.mark.parametrize("dim", [2, 3, 4])
def test_stretch_and_density_map(ctx, dim):
    """Stretched cells (weighted distance, w_a = g / s_a with g the geometric mean of the s_a) and a
    density ramp (0.2 .. 12 points per cell, empty cells allowed), F1..F8, against the brute force."""
    base = 20000.0
    x, rel = _samples(dim, base, 24, seed=20 + dim)
    s = np.array([3.0, 0.5, 1.0, 2.0][:dim])
    w = np.exp(np.log(s).mean()) / s
    pts, reach = _block(dim, base, {})
    want = np.sort([_distances((pts - xi) * w, "euclidean") for xi in rel], axis=1)[:, :8]
    r = cellgl.cellular(x, 8, stretch=list(s), outputs=("F",))
    assert_never_wrong_while_exact(f"{dim}D stretch", r.F, want, r.exact, reach=reach * w.min())
    dm = cellgl.DensityMap("ramp", axis=0, start=base - 3, end=base + 3, density_min=0.2, density_max=12.0)
    kw = dict(density_map=dm, min_points=0, max_points=16)
    pts, reach = _block(dim, base, kw)
    want = _brute(rel, pts, 8, "euclidean")
    r = cellgl.cellular(x, 8, outputs=("F",), **kw)
    assert_never_wrong_while_exact(f"{dim}D density map", r.F, want["F"], r.exact, reach=reach)


def test_grid_matrix_far_and_periodic(ctx):
    """cellular_grid (positions made on the GPU) at 5e8 with a period, against the brute force."""
    base = 499999999.0
    g = cellgl.cellular_grid((5, 6), origin=(base, base), spacing=0.25, n=8, period=(5, 7),
                             outputs=("F", "edge"))
    ys, xs = np.mgrid[0:5, 0:6]
    rel = np.stack([xs.ravel() * 0.25, ys.ravel() * 0.25], 1)
    pts, reach = _block(2, base, dict(period=(5, 7)))
    want = _brute(rel, pts, 8, "euclidean")
    assert_never_wrong_while_exact("grid F", g.F.reshape(-1, 8), want["F"], g.exact.ravel(), reach=reach)
    assert_never_wrong_while_exact("grid edge", g.edge.ravel(), want["edge"], g.exact.ravel())


@pytest.mark.parametrize("dim", [2, 3, 4])
def test_grid_cell_cache_gives_the_same_bits(same_bits, monkeypatch, dim):
    """The workgroup-shared cell cache (CELLGL_CELL_CACHE=1, grids) answers with the same bits as
    hashing every cell: every distribution, periodic and far from the origin, fine and coarse
    spacings (a workgroup over a few cells and over many), a grid narrower than a workgroup."""
    dists = ["jitter", "poisson", "blender"] + (["worley1996"] if dim == 3 else [])
    for dist, (shape_x, spacing), (period, base) in itertools.product(
            dists, [(150, 0.05), (70, 0.2)], [(None, 0.0), ((5, 7, 6, 4)[:dim], 123456789.0)]):
        if dist == "blender" and period is not None:
            continue
        shape = (3,) * (dim - 1) + (shape_x,)
        kw = dict(origin=(base,) * dim, spacing=spacing, n=3, distribution=dist, period=period,
                  seed=0 if dist == "blender" else 5, outputs=("F", "delta", "id"))
        p = core.make_params(dim, distribution=dist, seed=kw["seed"])
        monkeypatch.setenv("CELLGL_CELL_CACHE", "1")
        fits = gpu.cell_cache_defines(p, spacing).get("CELL_SHARED_CELLS") == 1
        # fine spacing: on, but for 4D Poisson (27 cells a slot of x, 9 points each: over 32 KiB)
        assert fits or spacing > 0.1 or (dim == 4 and dist == "poisson"), (dist, spacing)
        on = cellgl.cellular_grid(shape, **kw)
        monkeypatch.setenv("CELLGL_CELL_CACHE", "0")
        assert gpu.cell_cache_defines(p, spacing) == {}
        off = cellgl.cellular_grid(shape, **kw)
        assert_same_bits(on, off, (dist, spacing, period), fields=("F", "delta", "id", "exact"))


@pytest.mark.parametrize("dim", [2, 3, 4])
def test_plain_walker_gives_the_same_bits(same_bits, monkeypatch, dim):
    """CELL_WALK_TUNED 0 (walk.glsl: the plain shapes, one ring loop per walker) answers with the
    same bits as the tuned shapes of the default: the search with every distribution, periodic
    too, and each feature walk alone (the edge and the n-sphere radius: the ring loop from ring 0;
    smooth F1 alone: its block of rings 0 and 1, window and ball rows against the ring loop).
    At k = 0.1: at 0.25 the plain smooth window (3D, 4D) spends enough loop passes to hit the
    budget where the ball does not, and a flagged sample is the NumPy fallback's (float64)."""
    x, _ = _samples(dim, 1000.0, 2000, seed=11)
    orig = gpu.defines_for
    cases = [(dist, outputs, period) for dist in ("poisson", "jitter", "blender")
             for outputs in (("F", "delta", "id"), ("edge",), ("nsphere",), ("smooth_F1",))
             for period in (None, (5, 7, 6, 4)[:dim]) if not (dist == "blender" and period)]
    for dist, outputs, period in cases:
        kw = dict(DISTS[dist], outputs=outputs, smoothness=0.1, period=period)
        got = {}
        for tuned in (1, 0):
            monkeypatch.setattr(gpu, "defines_for",
                                lambda *a, t=tuned, **k: {**orig(*a, **k), "CELL_WALK_TUNED": t})
            got[tuned] = cellgl.cellular(x, 3, **kw)
        assert_same_bits(got[1], got[0], (dist, period), fields=outputs + ("exact",))


# ------------------------------------------------------------------ the loop budget


def _with_budget(monkeypatch, budget: int) -> None:
    """Compile every cellular.comp of this test with CELL_LOOP_BUDGET = budget."""
    orig = gpu.defines_for
    monkeypatch.setattr(gpu, "defines_for", lambda *a, **k: {**orig(*a, **k), "CELL_LOOP_BUDGET": budget})


@pytest.mark.parametrize("outputs", [("F",), ("nsphere", "smooth_F1")])
def test_tiny_budget_flags_then_recomputes_never_wrong(ctx, monkeypatch, outputs):
    """With a budget of 40 loop iterations most searches stop early: the GPU flags them (never a
    wrong value flagged exact), and what reaches the user is the fallback's exact answer."""
    _with_budget(monkeypatch, 40)
    dim = 3
    x, rel = _samples(dim, 1000.0, 48, seed=3)
    pts, reach = _block(dim, 1000.0, {})
    want = _brute(rel, pts, 4, "euclidean", 0.1)
    p = core.make_params(dim)
    raw, exact = gpu.search_points(x, p, 4, core._gpu_outputs(outputs, p), 0.1)
    assert (~exact).mean() > 0.5, "a budget of 40 must stop most searches"
    if "F" in raw:
        ok = exact
        assert np.all(np.abs(raw["F"][ok] - want["F"][ok]) < TOL), "wrong while flagged exact"
    r = cellgl.cellular(x, 4, outputs=outputs, smoothness=0.1)
    if "F" in outputs:
        assert_never_wrong_while_exact("tiny budget F", r.F, want["F"], r.exact)
    else:
        assert_never_wrong_while_exact("tiny budget nsphere", r.nsphere, want["nsphere"], r.exact)
        assert_never_wrong_while_exact("tiny budget smooth", r.smooth_F1, want["smooth_F1"], r.exact)


def test_tiny_budget_on_a_grid(ctx, monkeypatch):
    """cellular_grid (positions made on the GPU) with a budget of 40: the flagged samples come back
    from the fallback at their grid positions, equal to the brute force."""
    _with_budget(monkeypatch, 40)
    base = 100000.0
    g = cellgl.cellular_grid((3, 4, 5), origin=(base + 0.3, base + 0.1, base + 0.7), spacing=0.3, n=4,
                             outputs=("F", "edge"))
    zs, ys, xs = np.mgrid[0:3, 0:4, 0:5]
    rel = np.stack([0.3 + 0.3 * xs.ravel(), 0.1 + 0.3 * ys.ravel(), 0.7 + 0.3 * zs.ravel()], 1)
    assert rel.max() <= SPAN
    pts, reach = _block(3, base, {})
    want = _brute(rel, pts, 4, "euclidean")
    assert_never_wrong_while_exact("tiny budget grid F", g.F.reshape(-1, 4), want["F"], g.exact.ravel(), reach=reach)
    assert_never_wrong_while_exact("tiny budget grid edge", g.edge.ravel(), want["edge"], g.exact.ravel())


def test_driver_cut_is_caught_by_the_canary(loop_limiter, monkeypatch):
    """With the budget lifted (10^6), 4D smooth F1 at k = 0.25 with up to 16 points a cell (Poisson
    8) spends more than the driver's 65535 loop passes in most SIMD vectors: the driver cuts loops
    silently, and the canary flags exactly those samples, whatever the compiler does with the
    canary (its length is read from storage). The cut really happens (it is checked), so a dead
    canary fails here; the samples left exact are right."""
    dim = 4
    kw = dict(density=8.0, max_points=16)
    x, rel = _samples(dim, 0.0, 64, seed=4)
    p = core.make_params(dim, **kw)
    own, driver, flagged = gpu.loop_probe(x, p, 1, ("smooth_F1",), 0.25, budget=10 ** 6)
    cut = driver >= gpu.DRIVER_LOOP_LIMIT - 3
    assert cut.any(), "this case must make the driver cut loops (or the test cannot fail)"
    np.testing.assert_array_equal(flagged, cut)
    assert np.all(own[~flagged] < gpu.DRIVER_LOOP_LIMIT)
    _with_budget(monkeypatch, 10 ** 6)
    raw, exact = gpu.search_points(x, p, 1, ("smooth_F1",), 0.25)
    assert not exact.all(), "the driver cut loops, and no sample was flagged: the canary is dead"
    np.testing.assert_array_equal(~exact, cut)
    pts, reach = _block(dim, 0.0, kw)
    want = _brute(rel[exact], pts, 1, "euclidean", 0.25)
    got = raw["features"][:, 0]          # the record of smooth_F1 alone: one column
    assert np.all(np.abs(got[exact] - want["smooth_F1"]) < TOL)


def test_default_budget_stays_inside_the_driver_limit(loop_limiter):
    """The heaviest paths at the default budget: no SIMD vector reaches llvmpipe's limit."""
    rng = np.random.default_rng(9)
    for dim, kw, outs, k, n in [(4, {}, ("smooth_F1",), 0.25, 1),
                                (4, dict(metric="minkowski", minkowski_p=0.25), ("F",), 0.0, 8),
                                (3, dict(metric="minkowski", minkowski_p=0.5), ("smooth_F1",), 0.25, 1)]:
        p = core.make_params(dim, **kw)
        own, driver, flagged = gpu.loop_probe(rng.uniform(-9, 9, (256, dim)), p, n, outs, k)
        assert own.max() <= 6144
        assert driver.max() < gpu.DRIVER_LOOP_LIMIT // 2, (dim, kw, outs, driver.max())


# ------------------------------------------------------------------ the reproducers


def test_reproducer_nsphere_with_smooth_is_the_same_as_alone(ctx):
    X = np.random.default_rng(1).uniform(-10, 10, (400, 4)).astype("float32")
    g = cellgl.cellular(X, 1, outputs=("nsphere", "smooth_F1"), smoothness=0.25)
    r = cellgl.cellular(X, 1, outputs=("nsphere",))
    assert g.exact.all() and r.exact.all()
    np.testing.assert_array_equal(g.nsphere, r.nsphere)
    s = cellgl.cellular(X, 1, outputs=("smooth_F1",), smoothness=0.25)
    np.testing.assert_array_equal(g.smooth_F1, s.smooth_F1)


@pytest.mark.parametrize("dist,period", [("jitter", (5, 7)), ("poisson", (4, 4))])
@pytest.mark.parametrize("mag", [1e8, 3e8, 2.0 ** 30 - 1])
def test_reproducer_period_far_from_the_origin(ctx, dist, period, mag):
    """With a period, a sample gives the same bits as its wrapped position, at every magnitude
    the API accepts (the float wrap lost cells past ~1e8)."""
    X = np.random.default_rng(0).uniform(-mag, mag, (2000, 2))
    a = cellgl.cellular(X, 2, distribution=dist, jitter=0.7, period=period, outputs=("F", "id"))
    b = cellgl.cellular(np.stack([X[:, 0] % period[0], X[:, 1] % period[1]], 1), 2, distribution=dist,
                        jitter=0.7, period=period, outputs=("F", "id"))
    assert_same_bits(a, b, mag, fields=("F", "id"))


@pytest.mark.parametrize("dim", [2, 3, 4])
def test_sparse_poisson_is_served_exactly(ctx, dim):
    """Sparse Poisson (density 0.25, no minimum): no sample flagged (13-16 % were, in 4D)."""
    X = np.random.default_rng(2).uniform(-50, 50, (3000, dim))
    r = cellgl.cellular(X, 4, density=0.25, min_points=0, outputs=("F",))
    assert r.exact.mean() == 1.0


# ------------------------------------------------------------------ textures and PUPs


@pytest.mark.parametrize("forced", ["", "fragment"])
def test_texture_past_the_driver_limit_is_refused_or_exact(ctx, monkeypatch, forced):
    """issue 50's reproducer: smooth F1 at k = 0.25, 8 octaves, 16 samples per pixel, far past
    65535 loop passes per SIMD vector. On a driver that cuts loops (llvmpipe; lavapipe under zink,
    where the canary was unrolled and 64 of 64 pixels came back wrong) it is refused with
    LoopLimitError; on one that cuts nothing its pixels are the NumPy reference's. Never wrong
    pixels, on the context's path and on the fragment path (its canary's length is a texel). A
    shipped smooth preset is served."""
    from cellgl.gl.path import has_compute
    from cellgl.texture.dispatch import LoopLimitError

    if forced and not has_compute(ctx):
        pytest.skip("the fragment path is this context's own: the case without CELLGL_PATH runs it")
    monkeypatch.setenv("CELLGL_PATH", forced)

    r = cellgl.load_recipe("f1").replace(smoothness=0.25, c_smooth=1.0, c1=0.0, octaves=8.0, fractal="sum")
    kw = dict(tile_w=16, tile_h=4, samples=16, channels=("height",))
    if driver_loop_limit(ctx) is not None:
        with pytest.raises(LoopLimitError, match="cut the loops") as e:
            cellgl.render(r, 4096, 4096, **kw)
        # the advice is the recipe's own (issue 48): what it has, nothing it has not
        assert ("Recipe 'f1' would need shorter searches: fewer fractal.octaves (it has 8); or less "
                "supersampling (it has 16 samples a pixel); or a smaller combination.smoothness (it has "
                "0.25) (docs/exactness.md)") in str(e.value), str(e.value)
    else:
        got = cellgl.render(r, 4096, 4096, **kw)["height"]
        want = cellgl.render(r, 4096, 4096, backend="numpy", **kw)["height"]
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-4)
    assert np.isfinite(cellgl.render(cellgl.load_recipe("hammered"), 16, 16)["color"]).all()


def test_pups_loop_budget_is_known_before_the_dispatch(ctx, monkeypatch):
    """PUPs: the loop passes of a candidate grid are computed on the CPU; a grid past the driver's
    limit is refused with a clear error."""
    from cellgl.pups import gpu as pups_gpu

    seen = []
    orig = pups_gpu._check_budget
    monkeypatch.setattr(pups_gpu, "_check_budget", lambda packed, g: seen.append(
        pups_gpu.loop_budget(packed, g)) or orig(packed, g))
    cellgl.render("pups-giraffe", 64, 64)
    assert seen and 0 < max(seen) < pups_gpu.DRIVER_LOOP_LIMIT
    monkeypatch.setattr(pups_gpu, "DRIVER_LOOP_LIMIT", max(seen))
    with pytest.raises(ValueError, match="past the driver's limit"):
        cellgl.render("pups-giraffe", 64, 64)


@pytest.mark.parametrize("target", ["glsl", "hlsl", "wgsl"])
def test_snippets_carry_and_document_the_bound(target):
    """Exported snippets stop their searches at the same bound and say so in a comment."""
    from cellgl.export import export

    text = export("f1", target)
    assert "6144" in text
    assert "LOOP_BUDGET" in text and "llvmpipe" in text


@pytest.mark.parametrize("p", [0.5, 1.0])
def test_minkowski_gradient_is_finite_where_an_offset_is_zero(ctx, p):
    """grad of a Minkowski F with p <= 1 where a component of the offset is exactly 0: pow(0, p - 1)
    is undefined in GLSL (an infinity on llvmpipe, then 0 * inf = NaN); that axis gets 0, the
    others their value (lib/metric.glsl)."""
    x = np.array([[3.5, 0.25], [-7.5, 0.9], [0.1, 2.5]])       # jitter 0: points at the cell centres
    r = cellgl.cellular(x, 1, metric="minkowski", minkowski_p=p, distribution="jitter", jitter=0.0,
                        outputs=("F", "delta", "grad"))
    assert np.isfinite(r.grad).all()
    zero = r.delta[:, 0, :] == 0.0
    assert zero.any(axis=1).all()
    assert np.all(r.grad[:, 0, :][zero] == 0.0)
    assert np.all(r.grad[:, 0, :][~zero] != 0.0)
