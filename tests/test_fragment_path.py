"""The fragment path (issue 29; docs/fragment-path.md): where compute shaders are missing, every GPU
entry point runs the same ``shaders/lib`` code in fragment programs, with the same bits.

Two kinds of test:

* **Same bits, in this process.** ``CELLGL_PATH=fragment`` forces the fragment path on the session
  context; each case runs on both paths and the bytes must be equal (cellular outputs over every
  dimension, distribution, metric, feature and period; texture presets; PUPs; bake files). These
  need a context with compute shaders to compare with (they skip without one).
* **Real contexts without compute.** Mesa emulates Apple's OpenGL 4.1 core and a plain 3.3 core
  context with compute shaders removed; a child process makes one (no ``CELLGL_PATH``: the
  context chooses) and runs the brute-force exactness matrix on it, or writes renders whose bytes
  this process compares with the compute path's.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import cellgl
from cellgl.basis import core, gpu
from compare import assert_same_bits

ROOT = Path(__file__).resolve().parents[1]

#: Mesa's emulation of a context without compute shaders (docs/fragment-path.md)
EMULATED = {
    "gl41": {"MESA_GL_VERSION_OVERRIDE": "4.1FC", "MESA_GLSL_VERSION_OVERRIDE": "410",
             "MESA_EXTENSION_OVERRIDE": "-GL_ARB_compute_shader"},
    "gl33": {"MESA_GL_VERSION_OVERRIDE": "3.3FC", "MESA_GLSL_VERSION_OVERRIDE": "330",
             "MESA_EXTENSION_OVERRIDE": "-GL_ARB_compute_shader"},
}
#: 3.3 core without GL_ARB_gpu_shader5: no `precise` (CELL_PRECISE empty), the weakest promise
#: (docs/exactness.md): the reference's bounds hold, bit-identity with the compute path is not promised
PLAIN = {"gl33-plain": {"MESA_GL_VERSION_OVERRIDE": "3.3FC", "MESA_GLSL_VERSION_OVERRIDE": "330",
                        "MESA_EXTENSION_OVERRIDE": "-GL_ARB_compute_shader -GL_ARB_gpu_shader5"}}

FIELDS = ("F", "delta", "id", "exact", "grad", "edge", "edge_grad", "nsphere", "position", "color",
          "smooth_F1", "smooth_position", "smooth_grad", "smooth_color")
BASIS = ("F", "delta", "id", "grad")
FEATURES = ("edge", "edge_grad", "nsphere", "position", "color", "smooth_F1", "smooth_position",
            "smooth_grad", "smooth_color")


@pytest.fixture
def both_paths(compute, same_bits):
    """The session context, with compute shaders and `precise` in the fragment entries too: the
    two paths must then give the same bits (docs/exactness.md; conftest.same_bits skips elsewhere)."""
    return compute


@pytest.fixture
def mesa(ctx):
    """The emulated contexts are Mesa's (MESA_GL_VERSION_OVERRIDE and friends): another driver
    ignores those variables and gives its own context, so the tests that need them skip there."""
    version = str(ctx.info.get("GL_VERSION", ""))
    if "Mesa" not in version:
        pytest.skip(f"Mesa's context emulation (MESA_GL_VERSION_OVERRIDE) is not available on {version!r}")
    return ctx


def _both(monkeypatch, fn):
    """``fn()`` on the compute path, then on the fragment path."""
    out = []
    for path in ("compute", "fragment"):
        monkeypatch.setenv("CELLGL_PATH", path)
        out.append(fn())
    monkeypatch.delenv("CELLGL_PATH")
    return out


# (dim, keywords, outputs, n): every dimension, distribution, metric, feature, and period,
# stretch, orbit, density maps, far positions, n = 1 and 8 (several draws: more outputs than
# draw buffers)
CASES = [
    (2, dict(metric="euclidean", period=(5, 7)), BASIS + FEATURES, 4),
    (2, dict(metric="manhattan", distribution="jitter", jitter=0.7), BASIS, 3),
    (2, dict(metric="chebyshev", density=0.25, min_points=0), BASIS, 2),
    (2, dict(metric="minkowski", minkowski_p=0.5, distribution="blender", jitter=0.8), BASIS, 4),
    (3, dict(metric="euclidean", distribution="worley1996"), BASIS + FEATURES, 3),
    (3, dict(metric="minkowski", period=(4, 4, 3)), BASIS + ("smooth_F1",), 4),
    (3, dict(metric="chebyshev", distribution="jitter"), BASIS, 1),
    (3, dict(metric="euclidean", stretch=(2.0, 0.5, 1.0)), BASIS, 2),
    (4, dict(metric="euclidean", period=(6, 5, 4, 3)), BASIS + FEATURES, 8),
    (4, dict(metric="manhattan", distribution="blender"), BASIS + ("smooth_F1",), 2),
    (2, dict(orbit_radius=0.3, orbit_phase=0.2), BASIS, 2),
    (2, dict(density_map=cellgl.DensityMap("radial", 0.5, 12.0, center=(3.3, -2.2), radius=7.5)), BASIS, 2),
    (3, dict(density_map=cellgl.DensityMap("ramp", 0.3, 10.0, axis=0, start=-6.2, end=17.9)), BASIS, 2),
    (2, dict(density_map=cellgl.DensityMap("image", 0.5, 9.0,
                                           image=np.random.default_rng(3).uniform(0, 1, (37, 23)))),
     BASIS + ("edge",), 2),
]


@pytest.mark.parametrize("case", range(len(CASES)))
def test_cellular_same_bits(both_paths, monkeypatch, case):
    dim, kw, outputs, n = CASES[case]
    x = np.random.default_rng(case).uniform(-20.0, 20.0, (300, dim))
    x[:8] += 5e8 if dim == 2 else 3e4                # far from the origin too
    a, b = _both(monkeypatch, lambda: cellgl.cellular(x, n, outputs=outputs, **kw))
    assert_same_bits(a, b, f"case {case}", fields=FIELDS)


def test_polynomial_smooth_and_grids_same_bits(both_paths, monkeypatch):
    x = np.random.default_rng(5).uniform(-9.0, 9.0, (200, 3))
    a, b = _both(monkeypatch, lambda: cellgl.cellular(x, 1, outputs=("smooth_F1",), smooth="polynomial"))
    assert_same_bits(a, b, "polynomial smooth", fields=FIELDS)
    a, b = _both(monkeypatch, lambda: cellgl.cellular_grid(
        (7, 5, 4, 3), origin=(1e5, -3.3, 2.0, 9.0), spacing=0.37, n=4, outputs=BASIS + FEATURES))
    assert_same_bits(a, b, "4D grid", fields=FIELDS)
    a, b = _both(monkeypatch, lambda: cellgl.cellular_grid(
        (1500, 3), origin=(499999999.0, 0.5), spacing=0.013, n=2, period=(5, 7)))
    assert_same_bits(a, b, "2D grid, wide rows, far, periodic", fields=FIELDS)


def test_loop_probe_same_counts(compute, loop_limiter, monkeypatch):
    """The measurement build (gpu.loop_probe) on both paths: the search's own count and the flags
    are the same code's; the driver's count is what its limiter left (no limiter: skipped)."""
    x = np.random.default_rng(6).uniform(-9.0, 9.0, (256, 4))
    p = core.make_params(4)
    a, b = _both(monkeypatch, lambda: gpu.loop_probe(x, p, 1, ("smooth_F1",), 0.25))
    # the search's own count is the same code; the driver's count depends on how the samples
    # share SIMD vectors (a work group of 64 or a fragment tile), so only its cut is compared
    for _own, driver, _flagged in (a, b):
        assert not np.any(driver >= gpu.DRIVER_LOOP_LIMIT - 3), "the default budget keeps inside the driver's"
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[2], b[2])


def test_voronoi_same_bits(both_paths, monkeypatch):
    v = np.random.default_rng(6).uniform(-9.0, 9.0, (300, 3))
    for feature in ("F2", "smooth_F1", "distance_to_edge", "n_sphere_radius"):
        a, b = _both(monkeypatch, lambda feature=feature: cellgl.voronoi(v, 3, feature, detail=1.5))
        assert_same_bits(a, b, feature, fields=("distance", "color", "position", "w", "radius", "exact"))


def test_driver_cut_is_caught_on_the_fragment_path(compute, loop_limiter, monkeypatch):
    """The budget lifted: the driver's limiter cuts the loops of the heaviest vectors, the fragment
    entry's canary flags exactly those, and what reaches the user is exact (the NumPy recompute)."""
    x = np.random.default_rng(7).uniform(-9.0, 9.0, (64, 3))
    p = core.make_params(3, metric="minkowski", minkowski_p=0.25)
    monkeypatch.setenv("CELLGL_PATH", "fragment")
    own, driver, flagged = gpu.loop_probe(x, p, 1, ("smooth_F1",), 0.25, budget=10 ** 6)
    cut = driver >= gpu.DRIVER_LOOP_LIMIT - 3
    np.testing.assert_array_equal(flagged, cut)
    assert cut.any(), "this case must make the driver cut loops"
    orig = gpu.defines_for
    monkeypatch.setattr(gpu, "defines_for", lambda *a, **k: {**orig(*a, **k), "CELL_LOOP_BUDGET": 10 ** 6})
    kw = dict(metric="minkowski", minkowski_p=0.25, outputs=("smooth_F1",), smoothness=0.25)
    with pytest.warns(RuntimeWarning, match="could not be computed exactly"):
        got = cellgl.cellular(x, 1, **kw)          # minkowski_p 0.25 reaches past the ring cap
    with pytest.warns(RuntimeWarning, match="could not be computed exactly"):
        want = cellgl.cellular(x, 1, backend="numpy", **kw)
    np.testing.assert_array_equal(got.exact, want.exact)
    ok = got.exact
    assert ok.sum() > len(x) // 4
    np.testing.assert_allclose(got.smooth_F1[ok], want.smooth_F1[ok], atol=2e-4)


#: texture presets whose pixels are compared in the default run (one per kind of entry: a density
#: image, a cell image, 3D, features, supersampling); the slow test covers every preset
QUICK_PRESETS = ("flagstone", "density", "stained-glass", "qin-marble", "edge-cracks")
RENDER_CHANNELS = ("color", "height", "normal", "id", "F1", "F4")


def _texture_case(monkeypatch, name):
    pts = np.random.default_rng(2).uniform(-3.0, 3.0, (200, 3))

    def run():
        res = dict(cellgl.render(name, 40, 24, channels=RENDER_CHANNELS))
        res.update({"ss_" + k: v for k, v in cellgl.render(name, 16, 12, samples=4).items()})
        ev = cellgl.evaluate(name, pts, outputs=("color", "grad", "value", "F2", "id"), filter_width=0.01)
        res.update({"ev_" + k: v for k, v in ev.items()})
        return res
    a, b = _both(monkeypatch, run)
    assert_same_bits(a, b, name)


@pytest.mark.parametrize("name", QUICK_PRESETS)
def test_texture_presets_same_bits(both_paths, monkeypatch, name):
    _texture_case(monkeypatch, name)


@pytest.mark.slow
def test_every_texture_preset_same_bits(both_paths, monkeypatch):
    for name, _ in cellgl.list_presets():
        if not name.startswith("pups-"):
            _texture_case(monkeypatch, name)


def test_pups_same_bits(both_paths, monkeypatch):
    from cellgl import pups as P

    a, b = _both(monkeypatch, lambda: cellgl.render("pups-cow", 96, 80, channels=("color", "height")))
    assert_same_bits(a, b, "pups-cow")
    pos = P.poisson_disk(0.09, seed=2, periodic=True)
    rng = np.random.default_rng(102)
    pts = P.pups_points(pos, rng.random((len(pos), 3)),
                        orientations=P.random_orientations(len(pos), seed=202), periodic=True)
    g = P.pups_graph(pts, 1.0)
    for mode, method in (("interpolate", "compute"), ("label", "compute"), ("weighted_sum", "raster")):
        a, b = _both(monkeypatch, lambda mode=mode, method=method: P.pups_evaluate(
            g, 161, 117, mode=mode, method=method, return_labels=mode == "label"))
        assert_same_bits(a, b, (mode, method))


def test_bake_bytes_equal(both_paths, monkeypatch, tmp_path):
    from cellgl.bake.core import bake

    def run(path):
        out = tmp_path / path
        out.mkdir()
        files = bake("flagstone", out / "f.png", size=(96, 64), channels=("color", "height"), tile=32,
                     progress=False)
        files += bake("pups-cells", out / "p.exr", size=(64, 48), progress=False)
        return {f.name: f.read_bytes() for f in files}
    a, b = _both(monkeypatch, lambda: run(os.environ["CELLGL_PATH"]))
    assert_same_bits(a, b, "bake files")


def test_to_dask_blocks_same_bits(both_paths, monkeypatch):
    pytest.importorskip("dask")
    from cellgl.dask import to_dask

    a, b = _both(monkeypatch, lambda: np.asarray(to_dask("veins", (40, 56), chunks=24).compute()))
    assert_same_bits(a, b, "dask blocks")


def test_forced_fragment_draws_in_tiles(both_paths, monkeypatch):
    """More samples than one draw's tile: every tile is drawn (none left at the clear value)."""
    from cellgl.gl import dispatch

    monkeypatch.setenv("CELLGL_TILE_SAMPLES", str(4 * dispatch.WIDTH))
    x = np.random.default_rng(8).uniform(-50.0, 50.0, (10 * dispatch.WIDTH + 77, 2))
    a, b = _both(monkeypatch, lambda: cellgl.cellular(x, 2, outputs=("F", "id")))
    assert_same_bits(a, b, "tiled draws", fields=FIELDS)


# ------------------------------------------------------------------ contexts without compute

def _child(env_name: str, args: list[str], timeout: int = 900) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k != "CELLGL_PATH"}
    env.update({**EMULATED, **PLAIN}[env_name], CELLGL_REQUIRE_GPU="1")
    return subprocess.run([sys.executable] + args, cwd=ROOT, env=env, capture_output=True, text=True,
                          timeout=timeout)


_PROBE = """
import json, sys, cellgl
sys.path.insert(0, "tests")
from conftest import precise_in_fragment_entries
from cellgl.gl import context, runner
ctx = context.get_context()
print(json.dumps({"version": ctx.version_code, "path": runner.runner(ctx).path,
                  "precise": precise_in_fragment_entries(ctx)}))
"""


@pytest.mark.parametrize("env_name", list(EMULATED) + list(PLAIN))
def test_emulated_context_runs_the_fragment_path(mesa, env_name):
    """Each emulated context runs the fragment path; `precise` is there but where
    GL_ARB_gpu_shader5 was taken away (the prelude then leaves CELL_PRECISE empty, and the
    fragment entries still compile)."""
    r = _child(env_name, ["-c", _PROBE])
    assert r.returncode == 0, r.stderr[-3000:]
    info = json.loads(r.stdout.strip().splitlines()[-1])
    assert info == {"version": 410 if env_name == "gl41" else 330, "path": "fragment",
                    "precise": env_name != "gl33-plain"}


#: the exactness matrix's subset for the default run (every dimension, metric, the distributions,
#: features, period, far samples, the loop budget), in parts that `pytest -n` can spread; the
#: slow test runs a larger one
QUICK_MATRIX = {
    "basis": ("basis_matrix and (2-poisson-period-5e8 or 3-worley1996-free-0 or 4-jitter-period-0 "
              "or 2-blender-free-0 or 3-sparse-period-5e8)"),
    "walks": "(features_matrix and 3-poisson-0.25) or tiny_budget_on_a_grid or (promised_bound and 3-euclidean)",
    "reproducer": "reproducer_nsphere",
}
FULL_MATRIX = ("(basis_matrix and (free-0 or period-5e8)) or (features_matrix and 0.25) or stretch_and_density "
               "or grid_matrix or tiny_budget or reproducer_nsphere or sparse_poisson")


def _matrix(env_name: str, selection: str) -> None:
    r = _child(env_name, ["-m", "pytest", "-q", "-p", "no:cacheprovider", str(ROOT / "tests" / "test_exactness.py"),
                          "-k", selection])
    tail = (r.stdout + r.stderr)[-3000:]
    assert r.returncode == 0, tail
    assert " passed" in tail and "failed" not in tail, tail


@pytest.mark.parametrize("part", list(QUICK_MATRIX))
@pytest.mark.parametrize("env_name", ["gl41", "gl33-plain", pytest.param("gl33", marks=pytest.mark.slow)])
def test_exactness_matrix_without_compute(mesa, env_name, part):
    """The brute-force matrix (and the reference's bound) on contexts without compute shaders,
    one of them without `precise`: the promise against the reference holds on every driver."""
    _matrix(env_name, QUICK_MATRIX[part])


@pytest.mark.slow
@pytest.mark.parametrize("env_name", list(EMULATED))
def test_full_exactness_matrix_without_compute(mesa, env_name):
    _matrix(env_name, FULL_MATRIX)


_RENDERS = """
import sys, numpy as np, cellgl
from cellgl.bake.core import bake
out = {}
for name in sys.argv[2:]:
    chans = ("color", "height") if name.startswith("pups-") else %r
    for k, v in cellgl.render(name, 40, 24, channels=chans).items():
        out[name + "/" + k] = v
files = bake("flagstone", sys.argv[1] + "/f.png", size=(96, 64), channels=("color", "height"), tile=32,
             progress=False)
for f in files:
    out["bake/" + f.name] = np.frombuffer(f.read_bytes(), np.uint8)
x = np.random.default_rng(0).uniform(-20, 20, (500, 3))
r = cellgl.cellular(x, 4, outputs=%r)
for k in %r:
    out["cellular/" + k] = getattr(r, k)
np.savez(sys.argv[1] + "/out.npz", **out)
""" % (RENDER_CHANNELS, BASIS + FEATURES, FIELDS)


@pytest.mark.parametrize("env_name", list(EMULATED))
def test_renders_without_compute_equal_the_compute_path(both_paths, mesa, monkeypatch, tmp_path, env_name):
    """Presets (a cellular and a PUPs one), a bake's file bytes and cellular's outputs made in a
    context without compute shaders equal this process's compute path."""
    names = ["flagstone", "pups-cells"]
    r = _child(env_name, ["-c", _RENDERS, str(tmp_path)] + names)
    assert r.returncode == 0, r.stderr[-3000:]
    got = dict(np.load(tmp_path / "out.npz"))
    monkeypatch.setenv("CELLGL_PATH", "compute")
    (tmp_path / "c").mkdir()
    want = {}
    for name in names:
        chans = ("color", "height") if name.startswith("pups-") else RENDER_CHANNELS
        for k, v in cellgl.render(name, 40, 24, channels=chans).items():
            want[name + "/" + k] = v
    from cellgl.bake.core import bake
    for f in bake("flagstone", tmp_path / "c" / "f.png", size=(96, 64), channels=("color", "height"), tile=32,
                  progress=False):
        want["bake/" + f.name] = np.frombuffer(f.read_bytes(), np.uint8)
    x = np.random.default_rng(0).uniform(-20, 20, (500, 3))
    res = cellgl.cellular(x, 4, outputs=BASIS + FEATURES)
    for k in FIELDS:
        want["cellular/" + k] = getattr(res, k)
    assert sorted(got) == sorted(want)
    for k in want:
        assert_same_bits(np.asarray(want[k]), got[k], k)


def test_cell_counts_same_bits(compute, monkeypatch):
    """gpu.cell_counts (the density tests' GPU twin) on both paths, with a density image."""
    dm = cellgl.DensityMap("image", 0.5, 12.0, image=np.random.default_rng(4).uniform(0, 1, (19, 31)),
                           rect=(-3.3, -4.0, 11.7, 9.1))
    p = core.make_params(2, density_map=dm, min_points=0, max_points=16)
    cells = np.zeros((3000, 4), np.int64)
    cells[:, :2] = np.random.default_rng(5).integers(-40, 40, (3000, 2))
    a, b = _both(monkeypatch, lambda: gpu.cell_counts(cells, p))
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)
    assert len(np.unique(a[1])) >= 2


def test_outputs_past_the_draw_buffers_take_several_draws(ctx):
    """4D F1..F8 with delta, id, gradient and a feature record in one pass needs 25 four-channel
    targets: with 8 draw buffers (one for the exact flag) that is 4 draws, each slot in exactly
    one. (``cellular`` runs the feature walks as passes of their own: CASES[8]'s basis pass has 20
    targets, 3 draws, compared bit for bit above.)"""
    from cellgl.basis import features
    from cellgl.gl import dispatch

    outs = core._gpu_outputs(BASIS + FEATURES, core.make_params(4))
    size = {"F": 8, "id": 8, "delta": 32, "grad": 32, "features": features.stride(outs)}
    layout = [(name, "u" if name == "id" else "f", size[name]) for name in gpu._buffers(outs)]
    all_slots = dispatch.slots(layout)
    per = dispatch.draw_buffers(ctx) - 1
    passes = [all_slots[i:i + per] for i in range(0, len(all_slots), per)]
    slots = [s for p in passes for s in p]
    assert len(passes) == -(-len(slots) // per) >= 2
    assert all(len(p) <= per for p in passes)
    assert sum(k for *_, k in slots) == sum(n for *_, n in layout)


@pytest.mark.parametrize("name", ("flagstone", "hammered"))
def test_material_channels_same_bits(both_paths, monkeypatch, name):
    """roughness, ao and metallic (CELL_TEX_MATERIAL, the entries' material output) are the same
    bits on both paths, alone, beside other channels and supersampled."""
    def run():
        res = dict(cellgl.render(name, 40, 24, channels=("roughness", "ao", "metallic", "color", "F1")))
        res.update({"ss_" + k: v for k, v in cellgl.render(name, 16, 12, channels=("ao", "roughness"),
                                                            samples=4).items()})
        res["alone"] = cellgl.render(name, 40, 24, channels=("metallic",))["metallic"]
        return res
    a, b = _both(monkeypatch, run)
    assert_same_bits(a, b, name)
