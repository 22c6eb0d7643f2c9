"""cellgl on Dask (cellgl/dask/): to_dask, the resumable Zarr bake, the sweep.

The cluster tests share one LocalCluster of 2 worker processes (spawned, one thread each) and
bake through its address, as ``--scheduler`` does; the kill test runs the real command line.
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import cellgl
from cellgl.bake import core as cbake
from cellgl import texture
from compare import assert_render_matches
from test_texture import RECIPES as TEXTURE_RECIPES     # tests/ is on sys.path under pytest

dask = pytest.importorskip("dask", reason="the cellgl[dask] extra is not installed")
distributed = pytest.importorskip("distributed")
zarr = pytest.importorskip("zarr")

from cellgl.dask import DaskError, bake_zarr, sweep, to_dask  # noqa: E402
from cellgl.dask.zarr_bake import CHECKSUMS  # noqa: E402
from cellgl.io.colour import encode_linear  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
BIG = 4096          # the bake: 4096^2 float32 heights, 64 MiB
CHUNK = 512         # 64 chunks of 512^2 (about 0.1 s each on llvmpipe)


@pytest.fixture(scope="module")
def cluster():
    """2 worker processes x 1 thread, spawned; yields the scheduler address."""
    with dask.config.set({"distributed.worker.multiprocessing-method": "spawn"}):
        with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                      dashboard_address=":0", silence_logs=40) as c:
            yield c.scheduler_address


@pytest.fixture(scope="module")
def big_ref(ctx):
    """The in-process render of the whole 4096^2 f1 heightfield."""
    return cellgl.render("f1", BIG, BIG, channels=("height",))["height"]


# --------------------------------------------------------------------------------------------
# to_dask
# --------------------------------------------------------------------------------------------


def test_to_dask_is_render_in_blocks(ctx):
    # odd sizes: partial blocks at the right and bottom edges
    a = to_dask("flagstone", (150, 260), chunks=(64, 100), channels="height")
    assert a.shape == (150, 260) and a.dtype == np.float32 and a.chunks == ((64, 64, 22),
                                                                           (100, 100, 60))
    ref = cellgl.render("flagstone", 260, 150, channels=("height",))
    assert np.array_equal(a.compute(scheduler="sync"), ref["height"])
    # several channels: one render per block, one array per channel
    d = to_dask("flagstone", (150, 260), chunks=64, channels=("color", "id"))
    assert d["color"].shape == (150, 260, 4) and d["id"].dtype == np.uint32
    color, ids = dask.compute(d["color"], d["id"], scheduler="sync")
    both = cellgl.render("flagstone", 260, 150, channels=("color", "id"))   # the same channels
    assert np.array_equal(color, both["color"]) and np.array_equal(ids, both["id"])
    # a region of the lazy array is the same region of the render
    assert np.array_equal(a[70:90, 95:130].compute(scheduler="sync"), ref["height"][70:90, 95:130])


@pytest.mark.slow
def test_to_dask_on_worker_processes(cluster, ctx):
    a = to_dask("polka", (600, 700), chunks=256, channels="normal", sets=["seed=3"])
    with distributed.Client(cluster) as client:
        got = client.compute(a).result()
    ref = cellgl.render(cellgl.load_recipe("polka").set_from_strings(["seed=3"]), 700, 600,
                        channels=("normal",))["normal"]
    assert got.shape == (600, 700, 3) and np.array_equal(got, ref)


def test_several_threads_share_one_gl_thread(ctx):
    """A worker with 3 threads renders every block on its one GL thread, so all are right."""
    a = to_dask("f1", (256, 384), chunks=64, channels="height")
    with dask.config.set({"distributed.worker.multiprocessing-method": "spawn"}):
        with distributed.LocalCluster(n_workers=1, threads_per_worker=3, processes=True,
                                      dashboard_address=":0", silence_logs=40) as c, \
                distributed.Client(c) as client:
            got = client.compute(a).result()
    assert np.array_equal(got, cellgl.render("f1", 384, 256, channels=("height",))["height"])


@pytest.mark.parametrize("kwargs, words", [
    ({"shape": 0}, "height 0 is out of range; accepted a whole number in 1..1048576"),
    ({"shape": (10, 2 ** 20 + 1)}, "width 1048577 is out of range"),
    ({"shape": 64, "chunks": 5000}, "chunk rows 5000 is out of range; accepted a whole number "
                                    "in 1..4096"),
    ({"shape": 64, "chunks": (1, 2, 3)}, "chunks (1, 2, 3): expected N or (rows, cols)"),
    ({"shape": 64, "channels": "heigth"}, "unknown channel; accepted color, height"),
])
def test_to_dask_bad_input(kwargs, words):
    with pytest.raises(ValueError) as exc:
        to_dask("f1", **kwargs)
    assert words in str(exc.value)


def test_render_far_tile_of_a_262144_image(ctx):
    """The last pixels of a 262144^2 image (the issue's terrain) match the float64 reference:
    float32 uv still separates the pixels there."""
    r, W = TEXTURE_RECIPES["everything"], 262144
    chs = ("color", "height", "id", "F1", "F2")
    kw = dict(channels=chs, x0=W - 24, y0=W - 20, tile_w=24, tile_h=20)
    g = texture.render(r, W, W, **kw)
    n = texture.render(r, W, W, backend="numpy", **kw)
    assert_render_matches(g, n, ("color", "height", "F1", "F2"), atol=2e-4)
    assert np.ptp(g["height"]) > 0   # not one flat value smeared over the tile


def test_import_cellgl_stays_light():
    code = ("import sys, cellgl; assert 'dask' not in sys.modules and 'zarr' not in sys.modules;"
            "f = cellgl.to_dask; assert 'dask' not in sys.modules; print(f.__module__)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "cellgl.dask.blocks"


@pytest.mark.slow
def test_map_tasks_keeps_order_and_raises(cluster, monkeypatch):
    import math

    from cellgl.dask import cluster as dcluster

    monkeypatch.setattr(dcluster, "MIN_IN_FLIGHT", 3)    # a window smaller than the work
    monkeypatch.setattr(dcluster, "IN_FLIGHT_PER_THREAD", 1)
    seen = []
    with distributed.Client(cluster) as client:
        squares = [float(k * k) for k in range(40)]
        assert dcluster.map_tasks(client, math.sqrt, squares, on_done=seen.append) == \
            [float(k) for k in range(40)]
        assert sorted(seen) == [float(k) for k in range(40)]
        with pytest.raises(ValueError, match="math domain error"):
            dcluster.map_tasks(client, math.sqrt, [4.0, 9.0, -1.0, 16.0] * 5)


# --------------------------------------------------------------------------------------------
# the Zarr bake
# --------------------------------------------------------------------------------------------


def _bake_cmd(out: Path, *extra) -> list[str]:
    return [sys.executable, "-m", "cellgl", "bake", "f1", "-o", str(out), "--size", str(BIG),
            "--channels", "height", "--tile", str(CHUNK), *extra]


def _chunk_files(store: Path) -> dict[str, bytes]:
    return {str(p.relative_to(store)): p.read_bytes()
            for p in sorted((store / "height").rglob("*")) if p.is_file()}


@pytest.mark.slow
def test_zarr_bake_on_two_workers_equals_render(cluster, big_ref, tmp_path):
    out = tmp_path / "f1.zarr"
    res = bake_zarr("f1", out, size=BIG, channels=["height"], chunk=CHUNK, scheduler=cluster,
                    progress=False)
    assert (res["chunks"], res["rendered"], res["kept"]) == (64, 64, 0)
    g = zarr.open_group(str(out), mode="r")
    assert g.metadata.zarr_format == 3
    meta = g.attrs["cellgl"]
    assert meta["version"] == cellgl.__version__ and meta["size"] == [BIG, BIG]
    assert cellgl.Recipe.from_dict(meta["recipe"]).to_dict() == \
        cellgl.load_recipe("f1").to_dict()
    h = g["height"]
    assert h.shape == (BIG, BIG) and h.chunks == (CHUNK, CHUNK) and h.dtype == np.float32
    data = h[:]
    assert np.array_equal(data, big_ref)
    # seamless: the step across a chunk edge is no bigger than steps inside chunks
    edge = np.abs(np.diff(data, axis=1)[:, CHUNK - 1::CHUNK]).max()
    inside = np.abs(np.diff(data, axis=1)).max()
    assert edge <= inside
    assert (g[CHECKSUMS][:] != 0).all()


@pytest.mark.slow
def test_zarr_bake_killed_and_rerun(big_ref, tmp_path):
    """SIGKILL a real `cellgl bake ... .zarr` mid-run; the rerun renders only what is missing
    or damaged and ends with the same bytes as an uninterrupted bake."""
    out = tmp_path / "k.zarr"
    proc = subprocess.Popen(_bake_cmd(out, "--workers", "2", "-q"), cwd=ROOT,
                            start_new_session=True, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    t0 = time.monotonic()
    try:
        while time.monotonic() - t0 < 120 and proc.poll() is None:
            marks = list((out / CHECKSUMS).rglob("c/*/*")) if out.exists() else []
            if len(marks) >= 8:
                break
            time.sleep(0.05)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)   # the bake and its worker processes
        proc.wait()
    written = len(list((out / CHECKSUMS).rglob("c/*/*")))
    assert 8 <= written < 64, f"{written} chunks before the kill: adjust the test's timing"

    rerun = subprocess.run(_bake_cmd(out, "--workers", "2"), cwd=ROOT, capture_output=True,
                           text=True, timeout=300)
    assert rerun.returncode == 0, rerun.stderr
    assert "resuming" in rerun.stderr
    kept = int(rerun.stderr.split(" rendered, ")[1].split(" already")[0])
    assert kept >= written - 2   # chunks being written at the kill may be re-rendered
    assert np.array_equal(zarr.open_group(str(out), mode="r")["height"][:], big_ref)

    # a damaged chunk is found by its checksum and rendered again, alone
    files = _chunk_files(out)
    victim = out / sorted(files)[5]
    victim.write_bytes(files[sorted(files)[5]][:100])
    again = subprocess.run(_bake_cmd(out, "--workers", "1"), cwd=ROOT, capture_output=True,
                           text=True, timeout=300)
    assert again.returncode == 0, again.stderr
    assert "(1 rendered, 63 already done and verified)" in again.stderr
    assert _chunk_files(out) == files


@pytest.mark.slow
def test_zarr_bake_partial_chunks_and_channels(cluster, tmp_path, ctx):
    out = tmp_path / "p.zarr"
    bake_zarr("flagstone", out, size="100x70", channels="color,id", chunk=32, scheduler=cluster,
              sets=["seed=5"], tileable=True, progress=False)
    g = zarr.open_group(str(out), mode="r")
    recipe, _ = cellgl.load_recipe("flagstone").set_from_strings(["seed=5"]).tileable()
    ref = cellgl.render(recipe, 100, 70, channels=("color", "id"))
    assert g["color"].shape == (70, 100, 4) and g["color"].chunks == (32, 32, 4)
    lin = encode_linear(ref["color"][..., :3], np.float32)      # colour scene-linear (issue 46)
    assert np.array_equal(g["color"][..., :3], lin) and np.array_equal(g["color"][..., 3], ref["color"][..., 3])
    assert np.array_equal(g["id"][:], ref["id"])
    assert g["id"].dtype == np.uint32 and g[CHECKSUMS].shape == (3, 4)
    assert g.attrs["cellgl"]["recipe"]["domain"]["tileable"] is True


def test_zarr_colour_is_linear_and_tagged_data_untouched(tmp_path, ctx):
    """As the EXR (issue 46 item 1): colour RGB scene-linear Rec.709 by default, the array tagged
    with its colour space; alpha and the data arrays as rendered, untagged; ``srgb`` keeps the
    encoding and says so; a resume in the other space is another bake."""
    out = tmp_path / "c.zarr"
    bake_zarr("flagstone", out, size="40x24", channels="color,height", chunk=16, workers=1, progress=False)
    g = zarr.open_group(str(out), mode="r")
    ref = cellgl.render("flagstone", 40, 24, channels=("color", "height"))
    assert np.array_equal(g["color"][..., :3], encode_linear(ref["color"][..., :3], np.float32))
    assert np.array_equal(g["color"][..., 3], ref["color"][..., 3])
    assert np.array_equal(g["height"][:], ref["height"])
    attrs = dict(g["color"].attrs)
    assert attrs["colorInteropID"] == "lin_rec709_scene" and attrs["colorspace"] == "Linear Rec.709 (sRGB)"
    assert attrs["chromaticities"]["white"] == [0.3127, 0.3290]
    assert "colorInteropID" not in g["height"].attrs and "colorspace" not in g["height"].attrs
    assert g.attrs["cellgl"]["colorspace"] == {"color": "lin_rec709_scene"}
    with pytest.raises(DaskError, match=r"not the same colorspace"):
        bake_zarr("flagstone", out, size="40x24", channels="color,height", chunk=16, workers=1,
                  progress=False, colorspace="srgb")
    s = tmp_path / "s.zarr"
    bake_zarr("flagstone", s, size="40x24", channels="color", chunk=16, workers=1, progress=False,
              colorspace="srgb")
    g = zarr.open_group(str(s), mode="r")
    assert np.array_equal(g["color"][:], ref["color"])
    assert g["color"].attrs["colorInteropID"] == "srgb_rec709_scene"
    assert g.attrs["cellgl"]["colorspace"] == {"color": "srgb_rec709_scene"}


def test_zarr_bake_refuses_another_request(tmp_path):
    out = tmp_path / "a.zarr"
    bake_zarr("f1", out, size=64, channels=["height"], chunk=32, workers=1, progress=False)
    with pytest.raises(DaskError, match=r"holds a different bake \(not the same recipe, size\)"):
        bake_zarr("polka", out, size=96, channels=["height"], chunk=32, workers=1,
                  progress=False)
    (tmp_path / "x.zarr").mkdir()
    with pytest.raises(DaskError, match="exists and is not a Zarr group|not made by cellgl"):
        bake_zarr("f1", tmp_path / "x.zarr", size=64, chunk=32, workers=1, progress=False)


@pytest.mark.parametrize("args, words", [
    (["--size", "2000000"], "width 2000000 is out of range; accepted 1..1048576"),
    (["--size", "64x64x4"], "expected W or WxH with whole numbers for a .zarr bake"),
    (["--tile", "8"], "--tile 8: out of range; accepted 16..4096"),
    (["--depth", "16"], "--depth 16: a .zarr bake stores float32"),
    (["--memory", "64"], "--memory: not used by a .zarr bake"),
    (["--workers", "0"], "--workers 0: out of range; accepted 1..1024"),
    (["--colorspace", "acescg"], "--colorspace 'acescg': unknown colour space; accepted linear, srgb"),
])
def test_zarr_bake_cli_errors(tmp_path, capsys, args, words):
    from cellgl.cli import main

    assert main(["bake", "f1", "-o", str(tmp_path / "e.zarr"), *args]) == 2
    assert words in capsys.readouterr().err
    assert not (tmp_path / "e.zarr").exists()


def test_unreachable_scheduler_writes_nothing(tmp_path):
    with pytest.raises(DaskError, match=r"--scheduler 'tcp://127.0.0.1:9': cannot connect"), \
            dask.config.set({"distributed.comm.timeouts.connect": "2s"}):
        bake_zarr("f1", tmp_path / "n.zarr", size=64, scheduler="tcp://127.0.0.1:9",
                  progress=False)
    assert not list(tmp_path.iterdir())


def test_scheduler_flag_needs_zarr(tmp_path, capsys):
    from cellgl.cli import main

    assert main(["bake", "f1", "-o", str(tmp_path / "e.png"), "--scheduler", "tcp://x:1"]) == 2
    assert "--scheduler tcp://x:1: only for a distributed .zarr bake" in capsys.readouterr().err


# --------------------------------------------------------------------------------------------
# the sweep
# --------------------------------------------------------------------------------------------


@pytest.mark.slow
def test_sweep_bakes_each_variation(cluster, tmp_path, ctx):
    out = tmp_path / "sw"
    sets = ["seed=8..11", "metric=euclidean|manhattan", "frequency=6"]
    res = sweep("polka", out, sets, size=48, scheduler=cluster, progress=False)
    assert (res["variations"], res["baked"]) == (8, 8)
    names = sorted(p.name for p in out.glob("*.png"))
    assert names[0] == "polka_seed08_metriceuclidean.png" and len(names) == 8
    for name, seed, metric in (("polka_seed08_metricmanhattan.png", 8, "manhattan"),
                               ("polka_seed11_metriceuclidean.png", 11, "euclidean")):
        ref = tmp_path / name
        cbake.bake("polka", ref, size=48, progress=False,
                   sets=[f"seed={seed}", f"metric={metric}", "frequency=6"])
        assert (out / name).read_bytes() == ref.read_bytes()
    manifest = json.loads((out / "sweep.json").read_text())
    assert manifest["variations"] == 8
    assert manifest["colorspace"] == "srgb_rec709_scene"      # PNG colour: sRGB-encoded, said so
    # a rerun skips what is there and bakes what is missing
    (out / names[3]).unlink()
    again = sweep("polka", out, sets, size=48, scheduler=cluster, progress=False)
    assert (again["baked"], again["skipped"]) == (1, 7)
    with pytest.raises(DaskError, match="holds another sweep"):
        sweep("polka", out, ["seed=0..3"], size=48, scheduler=cluster, progress=False)


@pytest.mark.parametrize("sets, words", [     # --set specs, or other keyword arguments
    (["seed=5..2"], "a range A..B[:STEP] needs A <= B"),
    (["seed"], "expected NAME=VALUE, NAME=A..B[:STEP] or NAME=a|b|c"),
    (["seed=1|"], "an empty alternative"),
    (["seed=0..3", "seed=4"], "--set seed: given more than once"),
    (["seed=0..9999", "density=1|2|3", "octaves=0..999"], "at most 10000000"),
    (["seed=0..2**40"], "cannot parse"),
    (["jitter=0..5"], "out of range"),
    ({"size": 0}, "width 0 is out of range; accepted 1..65536"),
    ({"size": (64, 70000)}, "height 70000 is out of range"),
    ({"size": "64x64x4"}, "a sweep bakes images, not volumes"),
    ({"fmt": "jpg"}, "--format 'jpg': accepted png, exr, tif, tiff, npy"),
])
def test_sweep_bad_input(tmp_path, sets, words):
    kw = sets if isinstance(sets, dict) else {}
    sets = ["seed=0..1"] if kw else sets
    with pytest.raises(ValueError) as exc:
        sweep("polka", tmp_path / "s", sets, workers=1, progress=False, **kw)
    assert words in str(exc.value)
    assert not (tmp_path / "s").exists()
