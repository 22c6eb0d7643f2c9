"""cellgl.voronoi and distribution 'blender': against an independent brute force, GPU against
NumPy, and (with bpy, the [blender] extra) against Blender's own Voronoi node."""
from __future__ import annotations

import itertools
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import cellgl
from cellgl.basis import population as pop

F32 = np.float32


# --------------------------------------------------------------------------- brute force

def _window_points(coord, dim, randomness, R):
    """Blender's point of every cell within R cells of each sample's: (N, K, dim), cells (N, K, dim)."""
    base = np.floor(coord).astype(np.int64)
    offs = np.array(list(itertools.product(range(-R, R + 1), repeat=dim)), dtype=np.int64)
    cells = base[:, None, :] + offs[None, :, :]
    flat = cells.reshape(-1, dim)
    q = flat + pop.blender_point(flat, dim).astype(np.float64) * F32(randomness)
    return q.reshape(cells.shape), cells


def _dist(v, metric, exponent=0.5):
    a = np.abs(v)
    if metric == "manhattan":
        return a.sum(-1)
    if metric == "chebyshev":
        return a.max(-1)
    if metric == "minkowski":
        return (a ** exponent).sum(-1) ** (1.0 / exponent)
    return np.sqrt((a * a).sum(-1))


def brute_octave(coord, dim, feature, metric, randomness, R=3):
    """Distance of one octave by testing every point within R cells (R = 3 holds every point
    that can matter for randomness <= 1 in 2D and 3D: far more than a nearest point needs)."""
    q, _ = _window_points(coord, dim, randomness, R)
    v = q - coord[:, None, :]
    if feature in ("F1", "F2"):
        d = np.sort(_dist(v, metric), axis=1)
        return d[:, 0 if feature == "F1" else 1]
    d = _dist(v, "euclidean")
    i1 = np.argmin(d, axis=1)
    rows = np.arange(len(coord))
    v1 = v[rows, i1]
    e = v - v1[:, None, :]
    el = np.sqrt((e * e).sum(-1))
    with np.errstate(divide="ignore", invalid="ignore"):
        b = (0.5 * (v + v1[:, None, :]) * e).sum(-1) / el
    if feature == "distance_to_edge":
        return np.where(el > 0, b, np.inf).min(axis=1)
    return 0.5 * np.where(el > 0, el, np.inf).min(axis=1)      # n-sphere: from the F1 point


def brute_voronoi(points, dim, feature, metric, scale, detail, roughness, lacunarity, randomness):
    """The node's fractal sum (no normalize) over brute-force octaves, written out anew."""
    coord = points.astype(np.float64) * scale
    if feature == "n_sphere_radius":
        return brute_octave(coord, dim, feature, metric, randomness)
    n = int(math.ceil(detail)) + 1 if detail > 0 else 1
    frac = detail - math.floor(detail)
    total = np.full(len(coord), 8.0) if feature == "distance_to_edge" else np.zeros(len(coord))
    amp, s = 1.0, 1.0
    for i in range(n):
        d = brute_octave(coord * s, dim, feature, metric, randomness)
        weight = amp * (1.0 if i <= detail else frac)
        if detail == 0:
            return d
        if feature == "distance_to_edge":
            step = total + amp * (np.minimum(total, d / s) - total)
            total = total + (1.0 if i <= detail else frac) * (np.minimum(total, step) - total)
        else:
            total = total + weight * d
        s *= lacunarity
        amp *= roughness
    return total


# --------------------------------------------------------------------------- no Blender needed

@pytest.mark.parametrize("dim", [2, 3, 4])
def test_blender_distribution_gpu_equals_numpy_and_brute_force(ctx, dim):
    rng = np.random.default_rng(dim)
    pts = rng.uniform(-40, 40, (1500, dim))
    for metric in ("euclidean", "manhattan"):
        g = cellgl.cellular(pts, n=2, metric=metric, distribution="blender", jitter=0.9)
        r = cellgl.cellular(pts, n=2, metric=metric, distribution="blender", jitter=0.9, backend="numpy")
        assert g.exact.all() and r.exact.all()
        np.testing.assert_array_equal(g.id, r.id)
        np.testing.assert_allclose(g.F, r.F, atol=2e-6)
        cells = np.array(list(itertools.product(range(-43, 44), repeat=2)))
        if dim == 2:        # every point of the lattice around the samples, by feature_points
            fp = cellgl.feature_points(cells, distribution="blender", jitter=0.9)
            F, ids = cellgl.basis.reference.brute_force(pts, fp.positions, fp.ids, metric, 2)
            np.testing.assert_allclose(r.F, F, atol=1e-9)
            np.testing.assert_array_equal(r.id, ids)
        else:
            F = np.stack([brute_octave(pts, dim, f, metric, 0.9, R=2) for f in ("F1", "F2")], 1)
            np.testing.assert_allclose(r.F, F, atol=1e-6)


def test_blender_points_are_the_nodes_placement():
    """One point per cell, at the cell's corner plus Randomness times the hash (in [0, 1])."""
    cells = np.array([[0, 0], [-1, 5], [1000, -7]])
    fp = cellgl.feature_points(cells, distribution="blender", jitter=0.5)
    assert len(fp.positions) == 3
    off = fp.positions - cells
    np.testing.assert_allclose(off, pop.blender_point(cells, 2) * F32(0.5), atol=1e-7)
    assert np.all((off >= 0) & (off <= 0.5))
    # the lookup3 hash of the float bits: fixed values (a change of hash changes every texture)
    assert int(pop.jenkins_hash(pop.float_bits(0.0))) == int(pop.jenkins_hash(np.uint64(0)))
    assert pop.blender_id(np.array([[0, 0]]), 2)[0] != pop.blender_id(np.array([[0, 1]]), 2)[0]


@pytest.mark.parametrize("backend", ["gpu", "numpy"])
@pytest.mark.parametrize("dim", [2, 3])
def test_voronoi_equals_brute_force(ctx, backend, dim):
    rng = np.random.default_rng(10 + dim)
    pts = rng.uniform(-2, 2, (400, dim)).astype(F32)
    for feature, metric, detail in [("F1", "euclidean", 0.0), ("F2", "manhattan", 2.5),
                                    ("distance_to_edge", "euclidean", 2.5),
                                    ("n_sphere_radius", "euclidean", 0.0), ("F1", "manhattan", 1.0)]:
        r = cellgl.voronoi(pts, dimensions=dim, feature=feature, metric=metric, detail=detail,
                           randomness=0.85, backend=backend)
        want = brute_voronoi(pts, dim, feature, metric, 5.0, detail, 0.5, 2.0, 0.85)
        got = r.radius if feature == "n_sphere_radius" else r.distance
        assert r.exact.all()
        np.testing.assert_allclose(got, want, atol=2e-5, err_msg=f"{feature} {metric} {detail}")


@pytest.mark.parametrize("dim", [2, 3, 4])
def test_polynomial_smooth_gpu_equals_numpy(ctx, dim):
    rng = np.random.default_rng(20 + dim)
    pts = rng.uniform(-3, 3, (300 if dim < 4 else 60, dim)).astype(F32)
    kw = dict(dimensions=dim, feature="smooth_F1", detail=1.5 if dim < 4 else 0.0, smoothness=0.8,
              randomness=0.7)
    g = cellgl.voronoi(pts, **kw)
    r = cellgl.voronoi(pts, **kw, backend="numpy")
    np.testing.assert_allclose(g.distance, r.distance, atol=3e-6)
    np.testing.assert_allclose(g.color, r.color, atol=3e-6)
    np.testing.assert_allclose(g.position, r.position, atol=3e-6)
    # smooth F1 lies below F1 (the fold only lowers it), by at most ~k
    f1 = cellgl.voronoi(pts, **{**kw, "feature": "F1"}, backend="numpy")
    assert np.all(r.distance <= f1.distance + 1e-6)
    if dim == 4:
        return
    # gradient of the fold: finite differences
    s = cellgl.cellular(pts[:50].astype(np.float64) * 5, n=1, distribution="blender", jitter=0.7,
                        outputs=("smooth_F1", "smooth_grad"), smooth="polynomial", smoothness=0.8,
                        backend="numpy")
    h = 1e-5
    for a in range(dim):
        e = np.zeros(dim)
        e[a] = h
        up = cellgl.cellular(pts[:50] * 5 + e, n=1, distribution="blender", jitter=0.7, outputs=("smooth_F1",),
                             smooth="polynomial", smoothness=0.8, backend="numpy").smooth_F1
        dn = cellgl.cellular(pts[:50] * 5 - e, n=1, distribution="blender", jitter=0.7, outputs=("smooth_F1",),
                             smooth="polynomial", smoothness=0.8, backend="numpy").smooth_F1
        np.testing.assert_allclose(s.smooth_grad[:, a], (up.astype(np.float64) - dn) / (2 * h), atol=0.05)


def test_voronoi_other_distributions_and_1d():
    pts = np.random.default_rng(5).uniform(0, 3, (200, 2))
    r = cellgl.voronoi(pts, dimensions=2, feature="F1", distribution="poisson", density=2.0,
                       backend="numpy")
    c = cellgl.cellular(pts * 5.0, n=1, distribution="poisson", density=2.0, jitter=1.0, backend="numpy")
    np.testing.assert_allclose(r.distance, c.F[:, 0], atol=1e-6)
    x = np.linspace(-3, 3, 301)
    one = cellgl.voronoi(x, dimensions=1, feature="F1", backend="numpy")
    want = brute_octave(x[:, None] * 5.0, 1, "F1", "euclidean", 1.0)
    np.testing.assert_allclose(one.distance, want, atol=1e-6)
    assert one.position is None and one.w.shape == (301,)


def test_voronoi_refuses_bad_sockets():
    pts = np.zeros((2, 3))
    for kw, word in [({"detail": 16}, "detail"), ({"roughness": -0.1}, "roughness"),
                     ({"randomness": 1.5}, "randomness"), ({"smoothness": 2}, "smoothness"),
                     ({"feature": "F3"}, "feature"), ({"dimensions": 5}, "dimensions"),
                     ({"metric": "cosine"}, "metric"), ({"exponent": 0.0}, "exponent"),
                     ({"dimensions": 2, "points": np.zeros((2, 4))}, "columns"),
                     ({"dimensions": 1, "distribution": "poisson"}, "blender")]:
        args = {"points": pts, **kw}
        with pytest.raises(ValueError, match=word):
            cellgl.voronoi(**args, backend="numpy")
    with pytest.raises(ValueError, match="seed"):
        cellgl.cellular(pts, distribution="blender", seed=3, backend="numpy")


# --------------------------------------------------------------------------- against Blender

_FEATURES = {"F1": "F1", "F2": "F2", "smooth_F1": "SMOOTH_F1", "distance_to_edge": "DISTANCE_TO_EDGE",
             "n_sphere_radius": "N_SPHERE_RADIUS"}
_SOCKETS = dict(scale=4.0, roughness=0.6, lacunarity=2.0, randomness=0.9, smoothness=0.7)


def _cases():
    out = []
    for dim, feature, metric, detail in itertools.product((2, 3), _FEATURES, ("euclidean", "manhattan"),
                                                          (0.0, 2.5)):
        if feature == "n_sphere_radius" and detail:
            continue
        out.append(dict(dim=dim, feature=feature, metric=metric, detail=detail, normalize=detail > 0))
    # a few of the rest: 1D and 4D (W), Minkowski (exponent 0.5, the node's default), Chebyshev
    for dim, feature, metric, detail in [(1, "F1", "euclidean", 2.5), (1, "smooth_F1", "euclidean", 0.0),
                                         (1, "distance_to_edge", "euclidean", 1.5), (4, "F1", "euclidean", 0.0),
                                         (4, "smooth_F1", "euclidean", 0.0), (2, "F1", "minkowski", 0.0),
                                         (3, "F2", "chebyshev", 0.0)]:
        out.append(dict(dim=dim, feature=feature, metric=metric, detail=detail, normalize=False))
    return out


def _blender_python() -> str:
    """The interpreter that has bpy (the [blender] extra): $CELLGL_BLENDER_PYTHON (bpy 4.5 needs
    numpy < 2, so it may live in a venv of its own), else this one (skipped if bpy is missing)."""
    exe = os.environ.get("CELLGL_BLENDER_PYTHON", "").strip()
    if exe:
        return exe
    import importlib.util

    if importlib.util.find_spec("bpy") is None:        # found, not loaded: it runs in a subprocess
        if os.environ.get("CELLGL_REQUIRE_BLENDER", "").strip().lower() in ("1", "true", "yes"):
            pytest.fail("CELLGL_REQUIRE_BLENDER=1 but bpy is missing; install .[blender]", pytrace=False)
        pytest.skip("bpy (the [blender] extra) is not installed")
    return sys.executable


def _run_blender(tmp, points, cases) -> list[dict]:
    """Blender's node (tests/blender_voronoi_eval.py, in its own interpreter) for each case."""
    np.savez(tmp / "in.npz", points=points, cases=json.dumps(cases))
    script = Path(__file__).with_name("blender_voronoi_eval.py")
    subprocess.run([_blender_python(), str(script), str(tmp / "in.npz"), str(tmp / "out.npz")], check=True,
                   capture_output=True, timeout=600)
    got = np.load(tmp / "out.npz")
    return [{k.split("/")[1]: got[k] for k in got.files if k.split("/")[0] == str(i)} for i in range(len(cases))]


@pytest.fixture(scope="module")
def blender_outputs(tmp_path_factory):
    pts = np.random.default_rng(7).uniform(-2.5, 2.5, (1500, 4)).astype(F32)
    cases = _cases()
    bl = [dict(dim=c["dim"], feature=_FEATURES[c["feature"]], metric=c["metric"].upper().replace("SHEV", "CHEV"),
               normalize=c["normalize"],
               sockets={"Scale": _SOCKETS["scale"], "Detail": c["detail"], "Roughness": _SOCKETS["roughness"],
                        "Lacunarity": _SOCKETS["lacunarity"], "Randomness": _SOCKETS["randomness"],
                        "Smoothness": _SOCKETS["smoothness"]}) for c in cases]
    return pts, cases, _run_blender(tmp_path_factory.mktemp("blender"), pts, bl)


def test_distance_to_edge_exact_where_blenders_window_is_not(ctx, tmp_path):
    """The node's distance to edge looks for borders among the 3^d cells around the sample's only;
    about 2 in 10^4 samples (randomness 1) have a nearer border beyond them. cellgl finds it."""
    pts = np.random.default_rng(11).uniform(-40, 40, (40000, 3)).astype(F32)
    cases = [dict(dim=d, feature="DISTANCE_TO_EDGE", metric="EUCLIDEAN", normalize=False,
                  sockets={"Scale": 1.0, "Randomness": 1.0}) for d in (2, 3)]
    for d, bl in zip((2, 3), _run_blender(tmp_path, pts, cases)):
        r = cellgl.voronoi(pts[:, :d], dimensions=d, feature="distance_to_edge", scale=1.0, randomness=1.0)
        theirs = bl["Distance"]
        bad = np.abs(r.distance - theirs) > 1e-5
        assert 0 < bad.sum() < 40, (d, bad.sum())          # measured: 9 (2D) and 6 (3D) of 40,000
        want = brute_octave(pts[bad, :d].astype(np.float64), d, "distance_to_edge", "euclidean", 1.0)
        np.testing.assert_allclose(r.distance[bad], want, atol=1e-6)
        assert np.all(theirs[bad] > want + 1e-5)            # the node missed the nearest border


@pytest.mark.parametrize("backend", ["gpu", "numpy"])
def test_voronoi_equals_blenders_node(ctx, blender_outputs, backend):
    """Equal to Blender's node to 1e-5 at the same float32 points, except where Blender's fixed
    window misses the true nearest point: there cellgl equals the brute force and Blender does not."""
    pts, cases, blender = blender_outputs
    misses = []
    for case, bl in zip(cases, blender):
        dim, feature, metric, detail = case["dim"], case["feature"], case["metric"], case["detail"]
        r = cellgl.voronoi(pts[:, :dim], dimensions=dim, feature=feature, metric=metric, detail=detail,
                           normalize=case["normalize"], backend=backend, **_SOCKETS)
        assert r.exact.all()
        mine = {"Distance": r.distance, "Color": r.color, "Position": r.position, "Radius": r.radius,
                "W": r.w}
        bad = np.zeros(len(pts), bool)
        for name, arr in mine.items():
            if arr is None:
                assert name not in bl or name in ("Position", "W")
                continue
            theirs = bl[name][:, :3] if name == "Color" else bl[name]
            if name == "Position":
                theirs = theirs[:, :min(dim, 3)]
            err = np.abs(arr.reshape(len(pts), -1) - theirs.reshape(len(pts), -1)).max(axis=1)
            bad |= err > 1e-5
        label = f"{dim}D {feature} {metric} detail {detail}"
        if feature in ("smooth_F1",):
            assert not bad.any(), f"{label}: {bad.sum()} samples differ from Blender"
            continue
        assert bad.mean() < 0.02, f"{label}: {bad.sum()} of {len(pts)} samples differ from Blender"
        if bad.any():
            misses.append((label, int(bad.sum())))
            p = pts[bad, :dim]
            want = brute_voronoi(p, dim, feature, metric, _SOCKETS["scale"], detail, _SOCKETS["roughness"],
                                 _SOCKETS["lacunarity"], _SOCKETS["randomness"])
            if case["normalize"]:
                raw = cellgl.voronoi(p, dimensions=dim, feature=feature, metric=metric, detail=detail,
                                     backend="numpy", **_SOCKETS)
                got, theirs = raw.distance, None
            else:
                got = r.radius[bad] if feature == "n_sphere_radius" else r.distance[bad]
                theirs = bl["Radius" if feature == "n_sphere_radius" else "Distance"][bad]
            np.testing.assert_allclose(got, want, atol=1e-5, err_msg=label)
            if theirs is not None and feature in ("F1", "F2"):
                # Blender's window missed a nearer point: its distance is larger somewhere
                assert np.all(theirs >= want - 1e-5) and np.any(theirs > want + 1e-5), label
    # the known misses of the node's 3^d window (Manhattan F1/F2) are among them
    assert any("manhattan" in m[0] for m in misses), misses


def test_cli_voronoi(ctx, tmp_path, capsys):
    from cellgl.cli import main

    out = tmp_path / "d.npy"
    assert main(["voronoi", "-o", str(out), "--size", "16x8", "--dimensions", "2", "--feature", "F2",
                 "--detail", "1.5", "--backend", "numpy"]) == 0
    img = np.load(out)
    assert img.shape == (8, 16)
    u, v = (np.arange(16) + 0.5) / 16, 1 - (np.arange(8) + 0.5) / 8
    pts = np.stack(np.meshgrid(u, v), -1).reshape(-1, 2)
    want = cellgl.voronoi(pts, dimensions=2, feature="F2", detail=1.5, backend="numpy").distance
    np.testing.assert_array_equal(img.ravel(), want)
    png = tmp_path / "c.png"
    assert main(["voronoi", "-o", str(png), "--size", "8", "--socket", "color"]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert main(["voronoi", "-o", str(tmp_path / "x.png"), "--dimensions", "1", "--socket", "position"]) == 2
    assert "has no such output" in capsys.readouterr().err
    assert not (tmp_path / "x.png").exists()


@pytest.mark.parametrize("backend", ["gpu", "numpy"])
def test_blender_color_output_is_the_nodes(ctx, backend):
    """cellgl.cellular's ``color`` with distribution 'blender': Blender's colour of the F1 cell,
    also on a grid and where the points sit on their cell's corner (randomness 0)."""
    pts = np.random.default_rng(8).uniform(-9, 9, (500, 3))
    for jitter in (1.0, 0.0):
        r = cellgl.cellular(pts, n=1, distribution="blender", jitter=jitter, outputs=("color",),
                            backend=backend)
        q, c = _window_points(pts, 3, jitter, 2)
        d = np.sqrt(((q - pts[:, None, :]) ** 2).sum(-1))
        near = np.argmin(d, axis=1)
        cells = c[np.arange(len(pts)), near]
        np.testing.assert_array_equal(r.color, pop.blender_color(cells, 3))
    g = cellgl.cellular_grid((6, 7), spacing=0.37, n=1, distribution="blender", outputs=("color",),
                             backend=backend)
    ys, xs = np.mgrid[0:6, 0:7]
    p2 = np.stack([xs.ravel() * 0.37, ys.ravel() * 0.37], 1)
    want = cellgl.cellular(p2, n=1, distribution="blender", outputs=("color",), backend="numpy").color
    np.testing.assert_array_equal(g.color.reshape(-1, 3), want)
