"""PUPs texture synthesis: maths, generators, graph, exact candidate grid, GPU vs NumPy."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from cellgl import pups as P
from cellgl.pups import gpu as G
from cellgl.pups import reference as R
from cellgl.pups.presets import PUPS_PRESETS, build_pups
from compare import assert_close_but_share, assert_same_bits

ROOT = Path(__file__).resolve().parents[1]


def _graph(radius=0.1, seed=1, channels=1, periodic=True, axis_factor=1.0, orient=True):
    pos = P.poisson_disk(radius, seed=seed, periodic=periodic)
    rng = np.random.default_rng(seed + 100)
    vals = rng.random(len(pos)) if channels == 1 else rng.random((len(pos), 3))
    ori = P.random_orientations(len(pos), seed=seed + 200) if orient else None
    pts = P.pups_points(pos, vals, orientations=ori, periodic=periodic)
    return P.pups_graph(pts, axis_factor)


# ---------------------------------------------------------------------------------- maths


def test_axial_weight_endpoints_and_shape():
    p = np.array([-1.0, 0.0, 0.25, 0.5, 1.0, 2.0])
    a = R.cell_pups_axial(p)
    np.testing.assert_allclose(a, [1, 1, 0.84375, 0.5, 0, 0])
    # zero slope at both ends
    h = 1e-6
    assert abs(R.cell_pups_axial(h) - 1) < 1e-10 and R.cell_pups_axial(1 - h) < 1e-10


def test_orientation_shift_matches_equation_4():
    w = np.array([0.25, 0.25, 0.25])
    d = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0]])
    out = R.cell_pups_orient(w, d, np.array([1.0, 0.0]), 0.5)
    np.testing.assert_allclose(out, [0.25 ** 0.5, 0.25 ** (1 / 0.5), 0.25])
    assert R.cell_pups_orient(np.array([1.0]), np.zeros((1, 2)), np.array([1.0, 0]), 0.5)[0] == 1
    assert R.cell_pups_orient(np.array([0.0]), np.ones((1, 2)), np.array([1.0, 0]), 0.9)[0] == 0


def test_values_are_interpolated_at_control_points():
    g = _graph(orient=False)
    # at a control point its own weight is 1 and every neighbour's is 0 (axis factor 1)
    pts = g.points
    packed = P.pups_pack(g, 8, 8)
    w = np.zeros(len(packed.positions))
    c = pts.positions[5]
    for k in range(len(w)):
        a0, na = packed.axis_begin[k], packed.axis_count[k]
        w[k] = R.cell_pups_weight((c - packed.positions[k])[None], packed.axes_scaled[a0:a0 + na])[0]
    assert w[packed.point_index == 5].max() == 1.0
    assert np.sum(w) == 1.0


# ------------------------------------------------------------------------------ generators


def test_poisson_disk_deterministic_and_respects_radius():
    a = P.poisson_disk(0.08, seed=3)
    b = P.poisson_disk(0.08, seed=3)
    assert_same_bits(a, b, "two runs")
    assert not np.array_equal(a, P.poisson_disk(0.08, seed=4))
    d = a[:, None] - a[None]
    d -= 2.0 * np.round(d / 2.0)  # torus of side 2
    dist = np.hypot(d[..., 0], d[..., 1]) + np.eye(len(a)) * 9
    assert dist.min() >= 0.08
    assert len(a) > 300  # reasonably dense (maximal)


def test_poisson_disk_variable_density_grows_to_the_right():
    pos = P.poisson_disk_variable(0.03, 0.12, lambda xy: (xy[:, 0] + 1) / 2, seed=0)
    left = (pos[:, 0] < -0.5).sum()
    right = (pos[:, 0] > 0.5).sum()
    assert right > 4 * left
    np.testing.assert_array_equal(pos, P.poisson_disk_variable(
        0.03, 0.12, lambda xy: (xy[:, 0] + 1) / 2, seed=0))


def test_space_giraffe_construction():
    centres = P.poisson_disk(0.3, seed=2)
    pos, lab = P.space_giraffe(centres, n_range=(10, 20), seed=5)
    n = (len(pos) - len(centres)) // 2
    assert len(pos) == len(centres) + 2 * n
    assert lab[:len(centres)].all()
    assert 10 * len(centres) <= n <= 20 * len(centres)
    assert set(np.unique(lab)) == {0, 1}


def test_cluster_labels_sizes():
    g = _graph(0.08)
    lab = P.cluster_labels(g, sizes=(3, 4), seed=1)
    counts = np.bincount(lab)
    assert counts.max() <= 4 and np.mean(counts >= 3) > 0.8


def test_labels_from_image_and_ramp():
    pos = P.poisson_disk(0.05, seed=0)
    img = np.zeros((4, 4))
    img[:, 2:] = 1.0  # right half white
    lab = P.labels_from_image(pos, img, seed=0)
    assert (lab[pos[:, 0] > 0.01] == 1).all() and (lab[pos[:, 0] < -0.01] == 0).all()
    ramp = P.labels_by_ramp(pos, seed=0)
    assert ramp[pos[:, 0] > 0.5].mean() > 0.6 > 0.4 > ramp[pos[:, 0] < -0.5].mean()


# ----------------------------------------------------------------------------------- graph


def test_periodic_graph_is_symmetric_and_closed():
    g = _graph(0.1)
    owner = np.repeat(np.arange(len(g.points)), np.diff(g.offsets))
    fwd = {(int(i), int(j), round(ax, 9), round(ay, 9))
           for i, j, (ax, ay) in zip(owner, g.neighbours, g.axes)}
    back = {(j, i, round(-ax, 9) + 0.0, round(-ay, 9) + 0.0) for i, j, ax, ay in fwd}
    assert {(i, j, ax + 0.0, ay + 0.0) for i, j, ax, ay in fwd} == back
    assert np.isfinite(g.radius).all()


def test_support_can_exceed_longest_axis():
    """A disc of radius f * longest axis is not a safe support bound; the exact box is."""
    # centre point with neighbours at angles +-80 degrees and one behind: the corner between
    # the two front axes lies far beyond both axis ends
    pos = np.array([[0, 0], [0.17, 0.98], [0.17, -0.98], [-1, 0.05], [-1, -0.05],
                    [3, 3], [-3, 3], [3, -3], [-3, -3]], dtype=float) * 0.3
    pts = P.pups_points(pos, domain=(-1, -1, 1, 1), periodic=False)
    g = P.pups_graph(pts)
    longest = np.hypot(*g.axes[g.offsets[0]:g.offsets[1]].T).max()
    assert g.radius[0] > 1.5 * longest
    # brute force: weight of point 0 is positive beyond the longest axis
    packed = P.pups_pack(g, 400, 400)
    a0, na = packed.axis_begin[0], packed.axis_count[0]
    xs = np.linspace(-1, 1, 400)
    d = np.stack(np.meshgrid(xs, xs), -1) - pos[0]
    w = R.cell_pups_weight(d, packed.axes_scaled[a0:a0 + na])
    far = np.hypot(d[..., 0], d[..., 1])[w > 0].max()
    assert far > 1.2 * longest
    assert far <= g.radius[0] + 1e-9


@pytest.mark.parametrize("axis_factor,periodic", [(1.0, True), (2.0, True), (1.0, False)])
def test_candidate_grid_is_exact(axis_factor, periodic):
    """Every instance with a non-zero weight at a pixel is listed in that pixel's cell, and
    every axis that projects above 0 there is in the candidate's mask."""
    g = _graph(0.15, seed=7, periodic=periodic, axis_factor=axis_factor)
    w_, h_ = 90, 70
    pk = P.pups_pack(g, w_, h_, tile=8)
    ox, oy = pk.origin
    px, py = pk.pixel
    xs = ox + np.arange(w_) * px
    ys = oy + np.arange(h_) * py
    gw = pk.grid_shape[1]
    listed = {}
    for c in range(len(pk.cell_offsets) - 1):
        for k in range(pk.cell_offsets[c], pk.cell_offsets[c + 1]):
            listed[(c, int(pk.cell_items[k]))] = int(pk.cell_masks[k])
    checked = 0
    for k in range(len(pk.positions)):
        d = np.empty((h_, w_, 2))
        d[..., 0] = xs[None] - pk.positions[k, 0]
        d[..., 1] = ys[:, None] - pk.positions[k, 1]
        a0, na = pk.axis_begin[k], pk.axis_count[k]
        axes = pk.axes_scaled[a0:a0 + na]
        w = R.cell_pups_weight(d, axes)
        jj, ii = np.nonzero(w > 0)
        for j, i in zip(jj, ii):
            cell = (j // pk.tile) * gw + i // pk.tile
            assert (cell, k) in listed, f"instance {k} missing from cell {cell}"
            m = listed[(cell, k)]
            p = d[j, i] @ axes.T
            for r in np.nonzero(p > 0)[0]:
                assert m >> r & 1
            checked += 1
    assert checked > w_ * h_  # several weights per pixel on average


# --------------------------------------------------------------------------- GPU vs NumPy


@pytest.mark.parametrize("mode", ["interpolate", "weighted_sum"])
@pytest.mark.parametrize("channels", [1, 3])
def test_gpu_matches_reference(ctx, mode, channels):
    g = _graph(0.09, seed=2, channels=channels)
    a = P.pups_evaluate(g, 160, 120, mode=mode)
    b = P.pups_evaluate(g, 160, 120, mode=mode, backend="numpy")
    assert a.shape == b.shape == ((120, 160) if channels == 1 else (120, 160, 3))
    assert a.dtype == np.float32
    np.testing.assert_allclose(a, b, atol=2e-5)


@pytest.mark.parametrize("axis_factor,periodic", [(1.0, True), (2.0, True), (1.0, False)])
def test_gpu_labels_match_reference(ctx, axis_factor, periodic):
    g = _graph(0.08, seed=4, periodic=periodic, axis_factor=axis_factor)
    pts = g.points.replace(values=np.arange(len(g.points)) / len(g.points))
    g = P.pups_graph(pts, axis_factor)
    va, la = P.pups_evaluate(g, 150, 130, mode="label", return_labels=True)
    vb, lb = P.pups_evaluate(g, 150, 130, mode="label", return_labels=True, backend="numpy")
    diff = la != lb
    if diff.any():
        # allowed only where the two heaviest weights tie within float32 rounding
        assert diff.mean() < 1e-3
    np.testing.assert_allclose(va[~diff], vb[~diff], atol=1e-6)
    if not periodic:
        assert (lb >= -1).all()
    else:
        assert (lb >= 0).all()


def test_gpu_is_deterministic(ctx):
    g = _graph(0.07, seed=9)
    a = P.pups_evaluate(g, 128, 128)
    b = P.pups_evaluate(g, 128, 128)
    assert_same_bits(a, b, "two runs")


@pytest.mark.parametrize("periodic", [True, False])
@pytest.mark.parametrize("channels", [1, 3])
@pytest.mark.parametrize("mode", ["interpolate", "weighted_sum"])
def test_raster_matches_compute_and_reference(ctx, periodic, channels, mode):
    # method="raster" (support polygons, flat per-point inputs, additive blending) sums the
    # same float32 weights in the same order as the compute path: the same image, bit for bit
    g = _graph(0.08, seed=5, channels=channels, periodic=periodic)
    assert G.raster_applies(g, P.PupsMode[mode.upper()])
    r = P.pups_evaluate(g, 170, 130, mode=mode, method="raster")
    c = P.pups_evaluate(g, 170, 130, mode=mode, method="compute")
    n = P.pups_evaluate(g, 170, 130, mode=mode, backend="numpy")
    assert r.shape == c.shape and r.dtype == np.float32
    assert_same_bits(r, c, "raster vs compute")
    assert_same_bits(r, P.pups_evaluate(g, 170, 130, mode=mode), "the default")
    np.testing.assert_allclose(r, n, atol=2e-5)


def test_raster_falls_back_to_compute(ctx, monkeypatch):
    g = _graph(0.1, seed=6, axis_factor=2.0)
    c = P.pups_evaluate(g, 90, 70, method="compute")
    assert_same_bits(P.pups_evaluate(g, 90, 70, method="raster"), c, "raster")
    # more axes than the flat varyings hold: compute, silently
    monkeypatch.setattr(G, "_raster_pairs_limit", lambda ctx: 1)
    assert not G.raster_applies(g, P.PupsMode.INTERPOLATE)
    monkeypatch.setattr(G, "evaluate_raster", None)  # would fail if called
    assert_same_bits(P.pups_evaluate(g, 90, 70, method="raster"), c, "raster")
    assert_same_bits(P.pups_evaluate(g, 90, 70), c, "the default")
    # label mode: compute by default, raster refused
    assert not G.raster_applies(g, P.PupsMode.LABEL)
    P.pups_evaluate(g, 90, 70, mode="label")
    with pytest.raises(ValueError, match="method='raster'"):
        P.pups_evaluate(g, 90, 70, mode="label", method="raster")


def test_raster_pair_budget(ctx):
    # 4 floats per axis pair next to two vec4s; one attribute per pair next to three
    lim = G._raster_pairs_limit(ctx)
    comps = int(ctx.info.get("GL_MAX_VERTEX_OUTPUT_COMPONENTS") or 64)
    assert 4 <= lim <= (comps - 8) // 4
    g = _graph(0.1, seed=7)
    pk = P.pups_pack(g, 64, 48, grid=False)
    assert pk.stream is None and pk.cell_items.size == 0
    k, corners, nv = G._raster_polygons(pk)
    assert (nv >= 3).all() and corners.shape[0] == k.size


# ---------------------------------------------------------------------------------- tiling


@pytest.mark.parametrize("backend", ["numpy", "gpu"])
def test_periodic_textures_tile(backend, request):
    if backend == "gpu":
        request.getfixturevalue("ctx")
    g = _graph(0.12, seed=5)
    w_, h_ = 96, 64
    img = P.pups_evaluate(g, w_, h_, backend=backend).astype(np.float64)
    # shifting the periodic point set by half a period moves the seam into the middle:
    # the image must be the rolled original (the texture continues across the edges)
    pts = g.points
    for axis, n in ((0, w_), (1, h_)):
        shift = np.zeros(2)
        shift[axis] = 1.0  # half of the period 2
        moved = P.pups_graph(pts.replace(positions=pts.positions + shift), 1.0)
        img2 = P.pups_evaluate(moved, w_, h_, backend=backend).astype(np.float64)
        rolled = np.roll(img, -n // 2, axis=1 - axis)
        np.testing.assert_allclose(img2, rolled, atol=2e-5)
    # and the step across the edge looks like any other step between neighbouring pixels
    inner = np.abs(np.diff(img, axis=1)).max()
    assert np.abs(img[:, 0] - img[:, -1]).max() <= inner + 1e-6
    inner = np.abs(np.diff(img, axis=0)).max()
    assert np.abs(img[0] - img[-1]).max() <= inner + 1e-6


# --------------------------------------------------------------------------------- presets


FAST = ["pups-noise", "pups-cells", "pups-clusters", "pups-cow", "pups-giraffe", "pups-ramp",
        "pups-weight", "pups-progressive-cow", "pups-cells-outward"]


@pytest.mark.parametrize("name", FAST)
def test_presets_gpu_matches_numpy(ctx, name):
    a = P.pups_render(name, 64, 48, seed=1)
    b = P.pups_render(name, 64, 48, seed=1, backend="numpy")
    assert a.shape == b.shape and a.dtype == np.float32
    # label presets may differ at exact ties
    assert_close_but_share(a, b, 1e-4, share=0.001, rtol=1e-5, per_pixel=False, what=name)
    assert_same_bits(a, P.pups_render(name, 64, 48, seed=1), name)


def test_every_preset_is_json_and_renders(ctx):
    import json
    json.loads(json.dumps(PUPS_PRESETS))
    for name in PUPS_PRESETS:
        if name in ("pups-octaves", "pups-turbulence", "pups-multiscale-cells",
                    "pups-reference-image", "pups-reference-fine"):
            continue  # covered by the gallery; many points
        img = build_pups(name, 32, 32, seed=0)
        assert img.dtype == np.float32 and np.isfinite(img).all(), name
        assert img.min() >= -1e-6 and img.max() <= 1 + 1e-6, name
    assert set(P.pups_presets()) == set(PUPS_PRESETS)
    assert np.array_equal(P.pups_render("cow", 16, 16, backend="numpy"),
                          P.pups_render("pups-cow", 16, 16, backend="numpy"))


# ----------------------------------------------------------------------------------- errors


@pytest.mark.parametrize("call,match", [
    (lambda: P.poisson_disk(0), "radius"),
    (lambda: P.poisson_disk(-1), "radius"),
    (lambda: P.poisson_disk(5), "radius"),
    (lambda: P.poisson_disk_variable(0.1, 0.05, lambda xy: xy[:, 0]), "radius_max"),
    (lambda: P.pups_graph(P.pups_points(P.poisson_disk(0.2)), axis_factor=0), "axis_factor"),
    (lambda: P.pups_evaluate(_graph(0.2), 0, 10), "width"),
    (lambda: P.pups_evaluate(_graph(0.2), 10, 10, epsilon=1.0), "epsilon"),
    (lambda: P.pups_evaluate(_graph(0.2), 10, 10, backend="cuda"), "backend"),
    (lambda: P.pups_evaluate(_graph(0.2), 10, 10, mode="max"), "mode"),
    (lambda: P.pups_evaluate(_graph(0.2), 10, 10, method="vulkan"), "method"),
    (lambda: P.pups_points(np.zeros((5, 3))), "positions"),
    (lambda: P.pups_points(np.zeros((5, 2)), labels=-np.ones(5, int)), "labels"),
    (lambda: P.pups_points(np.zeros((5, 2)), orientations=np.full((5, 3), 2.0)), "orientation"),
    (lambda: P.pups_render("pups-nope", 8, 8), "unknown PUPs preset"),
    (lambda: P.pups_render({"kind": "noise", "bogus": 1}, 8, 8), "bogus"),
    (lambda: P.pups_render({"kind": "moo"}, 8, 8), "kind"),
    (lambda: P.pups_render("pups-noise", 8, 0), "height"),
])
def test_bad_input_raises_value_error(call, match):
    with pytest.raises(ValueError, match=match):
        call()


# --------------------------------------------------------------------------------- shaders


def test_library_follows_house_style():
    text = (ROOT / "shaders/lib/pups.glsl").read_text()
    code = re.sub(r"//.*", "", text)
    assert "#version" not in code and "void main" not in code
    assert not re.search(r"\buniform\b|\bbinding\b|\bbuffer\b", code)
    assert "__" not in code
    names = re.findall(r"^(?:float|u?int|bool|void|[ui]?vec\d|CellPupsAcc)\s+(\w+)\s*\(",
                       code, flags=re.M)
    names += re.findall(r"^struct\s+(\w+)", code, flags=re.M)
    assert names
    for n in names:
        assert n.startswith(("cell_pups_", "_cell_pups_", "CellPups")), n
    for m in re.findall(r"#\s*define\s+(\w+)", code):
        assert m.startswith("CELL_"), m


def test_mode_enum_matches_shader():
    comp = (ROOT / "shaders/pups.comp").read_text()
    assert "CELL_PUPS_MODE == 1" in comp and "CELL_PUPS_MODE == 2" in comp
    assert (P.PupsMode.INTERPOLATE, P.PupsMode.LABEL, P.PupsMode.WEIGHTED_SUM) == (0, 1, 2)
