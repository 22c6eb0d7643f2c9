"""The cellular basis: GPU vs NumPy reference vs brute force, invariants, bad input."""
from __future__ import annotations

import datetime
import itertools
from pathlib import Path

import numpy as np
import pytest

import cellgl
from cellgl.basis import reference
from compare import assert_basis_matches, assert_same_bits

#: The 256-entry population table of the reference program published with Worley's 1996 chapter
#: (a fact of the paper, row by row; see tests/data/README.md), kept with the tests.
W96_TABLE_FILE = Path(__file__).resolve().parent / "data" / "worley1996_population_table.txt"


def _w96_table() -> list[int]:
    return [int(v) for v in W96_TABLE_FILE.read_text().replace("\n", ",").split(",") if v.strip()]


METRICS = ["euclidean", "manhattan", "chebyshev", "minkowski"]
CASES = [(d, m, dist) for d in (2, 3, 4) for m in METRICS for dist in ("poisson", "jitter")] + [
    (3, m, "worley1996") for m in METRICS
]


def _pts(dim, n=800, lo=-6.0, hi=6.0, seed=1):
    return np.random.default_rng(seed).uniform(lo, hi, (n, dim))


@pytest.mark.parametrize("dim,metric,dist", CASES)
def test_gpu_matches_reference(ctx, dim, metric, dist):
    pts = _pts(dim)
    kw = dict(metric=metric, distribution=dist, outputs=("F", "delta", "id", "grad"))
    g = cellgl.cellular(pts, 4, **kw)
    r5 = cellgl.cellular(pts, 5, backend="numpy", **kw)
    r = cellgl.CellularResult(F=r5.F[:, :4], delta=r5.delta[:, :4], id=r5.id[:, :4], grad=r5.grad[:, :4],
                              exact=r5.exact)
    assert_basis_matches(g, r, F_next=r5.F[:, 4])
    # Deltas and gradients agree wherever the same point was found (ties may swap points).
    same = g.id == r.id
    np.testing.assert_allclose(g.delta[same], r.delta[same], atol=1e-5)
    np.testing.assert_allclose(g.grad[same], r.grad[same], atol=1e-4)
    assert g.exact.all() and r.exact.all()
    assert g.F.dtype == np.float32 and g.id.dtype == np.uint32 and g.delta.shape == (len(pts), 4, dim)


BRUTE = [
    (2, "euclidean", dict(distribution="poisson")),
    (2, "manhattan", dict(distribution="jitter", jitter=0.7)),
    (2, "euclidean", dict(distribution="poisson", density=0.6, min_points=0)),   # empty cells: rings >= 2
    (3, "chebyshev", dict(distribution="poisson", density=1.0, min_points=0)),
    (3, "minkowski", dict(distribution="jitter")),
    (3, "euclidean", dict(distribution="worley1996")),
    (4, "euclidean", dict(distribution="poisson", density=1.5)),
    (4, "manhattan", dict(distribution="jitter")),
]


@pytest.mark.parametrize("dim,metric,kw", BRUTE)
def test_reference_equals_brute_force(dim, metric, kw):
    """The pruned, ring-limited search returns exactly the n nearest of all feature points."""
    n = 8 if dim == 2 else 4
    pts = _pts(dim, n=300, lo=-2.0, hi=2.0, seed=dim)
    r = cellgl.cellular(pts, n, metric=metric, backend="numpy", outputs=("F", "id"), **kw)
    assert r.exact.all()
    reach = {2: 7, 3: 5, 4: 3}[dim]
    scale = reference.W96_DENSITY_ADJUSTMENT if kw.get("distribution") == "worley1996" else 1.0
    lo = int(np.floor(-2.0 * scale)) - reach
    hi = int(np.floor(2.0 * scale)) + reach
    cells = np.array(list(itertools.product(range(lo, hi + 1), repeat=dim)))
    fp = cellgl.feature_points(cells, **kw)
    F, ids = reference.brute_force(pts, fp.positions, fp.ids, metric, n)
    np.testing.assert_allclose(r.F, F, rtol=1e-6, atol=1e-6)
    mism = r.id != ids
    assert mism.sum() == 0, f"{mism.sum()} id mismatches vs brute force"


def test_gpu_equals_brute_force_sparse(ctx):
    """GPU mismatch count against brute force on a sparse Poisson process (empty cells, n=4)."""
    pts = _pts(2, n=2000, lo=-3.0, hi=3.0, seed=7)
    kw = dict(distribution="poisson", density=0.5, min_points=0)
    g = cellgl.cellular(pts, 4, outputs=("F", "id"), **kw)
    cells = np.array(list(itertools.product(range(-12, 12), repeat=2)))
    fp = cellgl.feature_points(cells, **kw)
    F, ids = reference.brute_force(pts, fp.positions, fp.ids, "euclidean", 4)
    ok = g.exact
    assert ok.mean() > 0.99
    np.testing.assert_allclose(g.F[ok], F[ok], rtol=2e-5, atol=2e-6)
    assert (g.id[ok] != ids[ok]).sum() == 0


def test_ring1_order_is_the_references():
    """The GPU's nearest-first ring 1 table (shaders/lib/cellular.glsl) is the order the NumPy
    reference visits: it decides which of two equal distances comes first. Hex digit k of an
    entry is the step on the axis of rank k: 8 for -1 (across the nearer face), 5 for 0, 2 for +1;
    its low two bits hold the step + 1, its high two the flipped step + 1."""
    import re

    text = (Path(__file__).resolve().parents[1] / "shaders" / "lib" / "cellular.glsl").read_text()
    for dim, count in ((2, 8), (3, 26)):
        m = re.search(r"const int _cell_ring1\[%d\] = int\[%d\]\((.*?)\);" % (count, count), text, re.S)
        codes = [int(v, 16) for v in re.findall(r"0x([0-9a-f]+)", m.group(1))]
        assert len(codes) == count
        table = [tuple(((c >> (4 * k)) & 3) - 1 for k in range(dim)) + (0,) * (4 - dim) for c in codes]
        flipped = [tuple(((c >> (4 * k + 2)) & 3) - 1 for k in range(3)) for c in codes]
        assert all(fl == tuple(-v for v in o[:3]) for fl, o in zip(flipped, table))
        assert all(c >> (4 * dim) == (0x5 if dim == 2 else 0) for c in codes)
        assert table == reference._block_offsets(dim)
        # every neighbour once, the near faces of the nearest axes first
        assert len(set(table)) == count and all(any(o) for o in table)
        assert table[:2] == [tuple(-1 if b == a else 0 for b in range(4)) for a in range(2)]


def test_ring1_order_follows_the_sample():
    """Per sample the reference visits ring 1 on axes ranked by the distance to their nearer face
    (ties: the lower axis first), each step -1 across that face: the first cells are the nearest."""
    from cellgl.basis import core

    p = core.make_params(3)
    f = np.array([[0.9, 0.2, 0.45, 0.0], [0.3, 0.3, 0.3, 0.0], [0.5, 0.5, 0.1, 0.0]])
    offs = reference._ring1_offsets(f, p)
    np.testing.assert_array_equal(offs[:3, 0], [[1, 0, 0, 0], [0, -1, 0, 0], [1, -1, 0, 0]])
    np.testing.assert_array_equal(offs[:3, 1], [[-1, 0, 0, 0], [0, -1, 0, 0], [-1, -1, 0, 0]])
    np.testing.assert_array_equal(offs[:3, 2], [[0, 0, -1, 0], [1, 0, 0, 0], [1, 0, -1, 0]])
    box = reference._box_distance(offs, np.broadcast_to(f, offs.shape), p)
    assert np.all(np.diff(box[:3], axis=0) >= 0)                 # the near faces, nearest first
    for i in range(3):                  # every neighbour once
        assert len(set(map(tuple, offs[:, i]))) == 26 and offs[:, i].any(axis=1).all()


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("dist", ["jitter", "poisson"])
def test_equal_distances_in_the_references_order(ctx, dim, dist):
    """Samples on cell faces and centres with points at the cell centres (jitter 0) or, for
    poisson, samples on the faces of a point process: many distances tie exactly; the GPU lists
    the tied points in the reference's order (same IDs in the same places)."""
    rng = np.random.default_rng(11)
    pts = np.round(rng.uniform(-6.0, 6.0, (3000, dim)) * 2.0) / 2.0
    kw = dict(distribution=dist, jitter=0.0) if dist == "jitter" else dict(distribution=dist)
    g = cellgl.cellular(pts, 3, outputs=("F", "id"), **kw)
    r = cellgl.cellular(pts, 3, outputs=("F", "id"), backend="numpy", **kw)
    np.testing.assert_allclose(g.F, r.F, rtol=1e-6, atol=1e-6)
    if dist == "jitter":
        assert (np.diff(g.F, axis=1) == 0).any(axis=1).mean() > 0.5      # ties are the common case
    assert (g.id != r.id).sum() == 0


def test_cap_is_reported_not_silent(ctx):
    """A very sparse process outruns the search cap: those samples say so (flag and warning), on
    both backends."""
    pts = _pts(2, n=400, lo=-20, hi=20, seed=3)
    kw = dict(distribution="poisson", density=0.0002, min_points=0, outputs=("F", "id"))
    with pytest.warns(RuntimeWarning, match="could not be computed exactly"):
        g = cellgl.cellular(pts, 4, **kw)
    with pytest.warns(RuntimeWarning, match="could not be computed exactly"):
        r = cellgl.cellular(pts, 4, backend="numpy", **kw)
    assert (~r.exact).sum() > 0
    np.testing.assert_array_equal(g.exact, r.exact)


@pytest.mark.parametrize("metric", METRICS)
def test_invariants(ctx, metric):
    pts = _pts(3, n=2000)
    r = cellgl.cellular(pts, 8, metric=metric, outputs=("F", "delta"))
    assert np.all(np.diff(r.F, axis=1) >= 0), "F1 <= F2 <= ... <= Fn"
    a = np.abs(r.delta.astype(np.float64))
    norm = {"euclidean": np.sqrt((a * a).sum(-1)), "manhattan": a.sum(-1), "chebyshev": a.max(-1),
            "minkowski": (a ** 3).sum(-1) ** (1 / 3)}[metric]
    np.testing.assert_allclose(norm, r.F, rtol=1e-5, atol=1e-6)


def test_f1_is_zero_at_feature_points(ctx):
    fp = cellgl.feature_points(np.array([[0, 0, 0], [3, -2, 5], [-7, 1, 2]]))
    r = cellgl.cellular(fp.positions, 1, outputs=("F", "id"))
    assert np.all(r.F[:, 0] < 1e-6)
    np.testing.assert_array_equal(r.id[:, 0], fp.ids)


def test_f1_is_1_lipschitz(ctx):
    t = np.linspace(0, 10, 20001)
    line = np.stack([t, 0.3 * t + 0.1, -0.2 * t], axis=1)
    F = cellgl.cellular(line, 4, outputs=("F",)).F.astype(np.float64)
    step = np.linalg.norm(line[1] - line[0])
    assert np.all(np.abs(np.diff(F, axis=0)) <= step * 1.001 + 1e-6)


@pytest.mark.parametrize("dim", [2, 3])
def test_periodic_wrap(ctx, dim):
    period = [4, 6, 5][:dim]
    pts = _pts(dim, n=500, lo=0, hi=8)
    shift = np.array(period) * np.array([1, -2, 3][:dim])
    a = cellgl.cellular(pts, 4, period=period, outputs=("F", "id"))
    b = cellgl.cellular(pts + shift, 4, period=period, outputs=("F", "id"))
    np.testing.assert_allclose(a.F, b.F, atol=1e-5)
    np.testing.assert_array_equal(a.id, b.id)
    r = cellgl.cellular(pts, 4, period=period, outputs=("F", "id"), backend="numpy")
    assert_basis_matches(a, r)


def test_deterministic_and_seeded(ctx):
    pts = _pts(3, n=3000)
    a = cellgl.cellular(pts, 4)
    b = cellgl.cellular(pts, 4)
    assert_same_bits(a, b, "two runs", fields=("F", "id", "delta"))
    c = cellgl.cellular(pts, 4, seed=12345)
    assert np.mean(c.id == a.id) < 0.01


@pytest.mark.parametrize("where", ["points-1e6", "grid-1e4"])
def test_far_from_origin_is_as_accurate(ctx, where):
    """The basis far out, one place for both entry points (the texture far out:
    tests/test_texture_precision.py; exact search bounds far out: tests/test_exactness.py).
    points: 10^6 cells out, float32 positions would be off by ~0.06; split positions are exact.
    grid: samples 1e4 cells from the grid origin (float32 positions erred by 7e-4 there)."""
    if where == "points-1e6":
        pts = _pts(3, n=1000, lo=0, hi=4) + 1e6
        g = cellgl.cellular(pts, 2, outputs=("F", "id"))
        r = cellgl.cellular(pts, 2, outputs=("F", "id"), backend="numpy")
        assert_basis_matches(g, r)
        return
    n_x = 30000
    r = cellgl.cellular_grid((1, n_x), spacing=(0.3711, 1.0), n=2, outputs=("F",))
    idx = np.arange(n_x - 50, n_x)
    ref = cellgl.cellular(np.stack([idx * 0.3711, np.zeros(len(idx))], axis=1), 2, backend="numpy")
    np.testing.assert_allclose(r.F[0, idx], ref.F, atol=3e-6)


def test_grid_matches_points(ctx):
    shape = (17, 23)
    origin, spacing = (-1.25, 3.5), (0.11, 0.07)
    g = cellgl.cellular_grid(shape, origin=origin, spacing=spacing, n=3, outputs=("F", "id"))
    ys, xs = np.mgrid[0:shape[0], 0:shape[1]]
    pts = np.stack([origin[0] + spacing[0] * xs, origin[1] + spacing[1] * ys], -1).reshape(-1, 2)
    p = cellgl.cellular(pts, 3, outputs=("F", "id"))
    assert g.F.shape == shape + (3,)
    np.testing.assert_allclose(g.F.reshape(-1, 3), p.F, atol=2e-5)
    r = cellgl.cellular_grid(shape, origin=origin, spacing=spacing, n=3, outputs=("F", "id"), backend="numpy")
    assert_basis_matches(g, r)
    v = cellgl.cellular_grid((4, 5, 6), spacing=0.3, n=2, outputs=("F",))
    assert v.F.shape == (4, 5, 6, 2)


def _w96_by_hand(cx, cy, cz):
    """Feature points of one cube, straight from the published description."""
    table = _w96_table()
    M = 2 ** 32
    seed = (702395077 * (cx % M) + 915488749 * (cy % M) + 2120969693 * (cz % M)) % M
    count = table[seed >> 24]
    seed = (1402024253 * seed + 586950981) % M
    pts = []
    for _ in range(count):
        pid = seed
        f = []
        for _ in range(3):
            seed = (1402024253 * seed + 586950981) % M
            f.append((seed + 0.5) / M)
        seed = (1402024253 * seed + 586950981) % M
        pts.append(((cx + f[0], cy + f[1], cz + f[2]), pid))
    return pts


def test_worley1996_points_by_hand():
    cubes = [(0, 0, 0), (1, -1, 2), (-3, 5, -7), (12, 0, -1)]
    fp = cellgl.feature_points(np.array(cubes), distribution="worley1996")
    expect = [pt for c in cubes for pt in _w96_by_hand(*c)]
    assert len(expect) == len(fp.ids) > 0
    for (pos, pid), got_pos, got_id in zip(expect, fp.positions, fp.ids):
        assert got_id == pid
        np.testing.assert_allclose(got_pos * reference.W96_DENSITY_ADJUSTMENT, pos, rtol=0, atol=1e-12)


def test_worley1996_table_matches_the_paper():
    vals = _w96_table()
    assert len(vals) == 256
    assert list(reference.worley1996_table()) == vals
    assert abs(np.mean(vals) - 2.598) < 0.01


def test_worley1996_F1_by_hand(ctx):
    """F1 at a sample = distance to the nearest hand-generated point, divided back by the scale."""
    s = reference.W96_DENSITY_ADJUSTMENT
    sample = np.array([[0.7, 1.3, -0.4]])
    q = sample[0] * s
    pts = [pt for c in itertools.product(range(-3, 4), repeat=3) for pt in _w96_by_hand(*c)]
    d = sorted((np.linalg.norm(np.array(p) - q), pid) for p, pid in pts)
    g = cellgl.cellular(sample, 2, distribution="worley1996", outputs=("F", "id"))
    np.testing.assert_allclose(g.F[0], [d[0][0] / s, d[1][0] / s], rtol=1e-5)
    assert list(g.id[0]) == [d[0][1], d[1][1]]


def test_poisson_population_statistics():
    cells = np.array(list(itertools.product(range(60), range(60))))
    for density, lo, hi in ((3.0, 1, 9), (2.0, 0, 16)):
        fp = cellgl.feature_points(cells, density=density, min_points=lo, max_points=hi)
        counts = np.bincount(fp.cell_index, minlength=len(cells))
        assert counts.min() >= lo and counts.max() <= hi
        if lo == 0:
            assert abs(counts.mean() - density) < 0.1
            assert abs(np.mean(counts == 0) - np.exp(-density)) < 0.02


@pytest.mark.parametrize("call,match", [
    (lambda: cellgl.cellular([[np.nan, 0.0]]), r"finite.*nan"),
    (lambda: cellgl.cellular([[np.inf, 0.0, 1.0]]), r"finite.*inf"),
    (lambda: cellgl.cellular(np.zeros((3, 2)), n=0), r"n must be in \[1, 8\]"),
    (lambda: cellgl.cellular(np.zeros((3, 2)), n=9), r"n must be in \[1, 8\]"),
    (lambda: cellgl.cellular(np.zeros((3, 2)), metric="cosine"), r"unknown metric 'cosine'.*euclidean"),
    (lambda: cellgl.cellular(np.zeros((3, 2)), distribution="blue"), r"unknown distribution.*poisson"),
    (lambda: cellgl.cellular(np.zeros((3, 2)), backend="cuda"), r"unknown backend.*gpu"),
    (lambda: cellgl.cellular(np.zeros((3, 2)), outputs=("F", "normal")), r"unknown output 'normal'"),
    (lambda: cellgl.cellular(np.zeros(3)), r"shape \(N, d\)"),
    (lambda: cellgl.cellular(np.zeros((3, 5))), r"shape \(N, d\)"),
    (lambda: cellgl.cellular(np.zeros((0, 3))), r"empty"),
    (lambda: cellgl.cellular(np.zeros((3, 2)), distribution="worley1996"), r"3D only"),
    (lambda: cellgl.cellular(np.zeros((3, 2)), density=0), r"density must be in \(0"),
    (lambda: cellgl.cellular(np.zeros((3, 2)), min_points=5, max_points=2), r"min_points \(5\)"),
    (lambda: cellgl.cellular(np.zeros((3, 2)), max_points=17), r"max_points must be in \[1, 16\]"),
    (lambda: cellgl.cellular(np.zeros((3, 2)), jitter=1.5), r"jitter must be in \[0"),
    # period: one place for every bad period (range, length, type, text)
    (lambda: cellgl.cellular(np.zeros((3, 2)), period=[-1, 2]), r"period must be in"),
    (lambda: cellgl.cellular(np.zeros((3, 2)), period=[1, 2, 3]), r"sequence of 2"),
    *((lambda bad=bad: cellgl.cellular([[0.5, 0.5]], 1, period=bad), r"period must be")
      for bad in (2.5, "4", [1.5, 2], object())),
    *((lambda bad=bad: cellgl.cellular([[0.5, 0.5]], 1, period=bad),
       r"period must be an integer or a sequence of 2 integers.*'22'") for bad in ("22", b"22")),
    # points and cells of the wrong type
    *((lambda bad=bad: cellgl.cellular(bad, 1), r"points must hold real numbers") for bad in (
        np.array([[1 + 2j, 0.5]]),                                      # complex: was cast silently
        np.array([[True, False]]),                                      # bool
        np.array([[np.datetime64("2020-01-01"), np.datetime64("2020-01-02")]]),
        [[datetime.date(2020, 1, 1), 0.5]], [["1", "2"]])),
    (lambda: cellgl.evaluate("f1", np.array([[0.5 + 1j, 0.5]])), r"points must hold real numbers"),
    *((lambda bad=bad: cellgl.feature_points(bad), r"cells must hold") for bad in (
        [["a", "b"]], np.array([[1.5, 2.0]]), np.array([[True, False]]), [[np.nan, 0.0]])),
    *((lambda c=c: cellgl.feature_points(np.array([[c, 0]], dtype=np.asarray(c).dtype if isinstance(
        c, np.generic) else None)), r"cells must lie within \+-2\^30")
      for c in (np.uint64(2 ** 63), np.int64(-2 ** 63), np.uint64(2 ** 64 - 1), 2 ** 40)),
    *((lambda bad=bad: cellgl.cellular([[0.5, 0.5]], 1, outputs=bad), r"outputs must") for bad in (None, 3)),
    *((lambda bad=bad: cellgl.evaluate("f1", [[0.5, 0.5]], bad), "channels must be a name or a sequence of names")
      for bad in (None, 3, object())),
    *((lambda bad=bad: cellgl.render("f1", 4, 4, channels=bad, backend="numpy"),
       "channels must be a name or a sequence of names") for bad in (None, 3, object())),
    *((lambda i=i, r=r: cellgl.DensityMap("image", 0.5, 4.0, image=i, rect=r),
       r"(image must hold real numbers|rect must be a finite number|rect must be \(x0, y0, x1, y1\))") for i, r in (
        (np.full((2, 2), 0.5 + 0.5j), (0, 0, 1, 1)),      # complex: the imaginary part was dropped
        (np.array([[True, False]]), (0, 0, 1, 1)),        # bool: cast to 0/1
        (np.full((2, 2), 0.5), (0, 0, True, 1)),
        (np.full((2, 2), 0.5), ((0, 0), (1, 1))))),
    (lambda: cellgl.cellular([[3e9, 0.0]]), r"2\^30"),
    (lambda: cellgl.cellular([["a", "b"]]), r"points must hold real numbers"),
    (lambda: cellgl.cellular_grid((0, 4)), r"positive ints"),
    (lambda: cellgl.cellular_grid((4,)), r"2..4"),
    *((lambda bad=bad: cellgl.cellular_grid(bad, backend="numpy"), "shape must be a tuple of 2..4 positive ints")
      for bad in ((2.5, 4), (4.0, 4), (True, 4), "ab", 7)),
    (lambda: cellgl.cellular_grid((2, 2), origin=(1j, 0.0), backend="numpy"), "origin must hold real numbers"),
    (lambda: cellgl.cellular_grid((4, 4), spacing=(1, -1)), r"spacing must be > 0"),
    (lambda: cellgl.cellular_grid((4, 4), origin=(0, np.nan)), r"origin must be finite"),
    (lambda: cellgl.feature_points(np.zeros((2, 5), int)), r"shape \(M, d\)"),
    (lambda: cellgl.feature_points(np.array([[0.5, 1.0]])), r"integers"),
])
def test_bad_input_is_a_clear_error(call, match):
    with pytest.raises(ValueError, match=match):
        call()


@pytest.mark.parametrize("shape", [(7, 33, 70), (3, 5, 33, 170)])
def test_grid_in_slabs_equals_one_pass(ctx, monkeypatch, shape):
    """A grid too big for one dispatch is run in slabs of rows/layers; the bits do not change."""
    kw = dict(spacing=0.21, n=2, outputs=("F", "id"))
    one = cellgl.cellular_grid(shape, **kw)
    monkeypatch.setenv("CELLGL_TILE_SAMPLES", "64")
    many = cellgl.cellular_grid(shape, **kw)
    assert_same_bits(one, many, "slabs", fields=("F", "id"))
