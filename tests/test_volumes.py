"""Volumes for film (issue 46 item 4): `--tileable` wraps a solid recipe along z, `.vdb` output
through OpenVDB's binding, the packed `cloud` channel."""
from __future__ import annotations

import sys

import numpy as np
import pytest

import test_bake
from cellgl import cli, texture
from cellgl.bake import core as B
from cellgl.io import vdb
from cellgl.recipes import load_recipe
from cellgl.texture import cloud
from cellgl.texture.recipe import Recipe

fake = test_bake.fake     # a fixture (the stand-in renderer): the tests take it as an argument

CHS = ("height", "F1", "F2", "id")


def _solid(**kw):
    r = Recipe().replace(dimension=3, frequency=3.0, offset_z=0.25, fractal="sum", octaves=2.0, c_noise=0.3,
                         **kw)
    return r.tileable()[0]


@pytest.mark.parametrize("backend", ["compute", "fragment", "numpy"])
def test_tileable_volume_repeats_in_depth_bit_for_bit(ctx, monkeypatch, backend):
    """Slice D (the volume moved one period, frequency cells, along z) is slice 0 again, and so
    on: the same bits on each GPU path and in the NumPy reference; without the wrap in z (the
    old behaviour) they differ."""
    from cellgl.gl.path import has_compute

    if backend == "compute" and not has_compute(ctx):
        pytest.skip("no compute path on this context (the fragment path runs)")
    if backend != "numpy":
        monkeypatch.setenv("CELLGL_PATH", backend)
        backend = "gpu"
    r = _solid(warp_amount=0.3)
    w, h, d = 8, 6, 4
    a = texture.render(r, w, h, channels=CHS, depth=d, backend=backend)
    b = texture.render(r.replace(offset_z=0.25 + 3.0), w, h, channels=CHS, depth=d, backend=backend)
    for k in CHS:
        assert a[k].shape[:3] == (d, h, w)
        assert np.array_equal(a[k], b[k]), k
    plain = r.replace(tileable=False)
    c = texture.render(plain, w, h, channels=("F1",), depth=d, backend=backend)
    e = texture.render(plain.replace(offset_z=0.25 + 3.0), w, h, channels=("F1",), depth=d, backend=backend)
    assert not np.array_equal(c["F1"], e["F1"])


def test_tileable_volume_is_seamless_across_its_depth(ctx):
    """Half a period on: the second half of the volume followed by the first (the wrap from
    slice D - 1 to slice 0 in the middle) within float32 rounding of the lattice fraction."""
    r = _solid()
    d = 8
    a = texture.render(r, 8, 8, channels=("F1", "height"), depth=d)
    b = texture.render(r.replace(offset_z=0.25 + 1.5), 8, 8, channels=("F1", "height"), depth=d)
    for k in ("F1", "height"):
        np.testing.assert_allclose(b[k], np.roll(a[k], -d // 2, axis=0), atol=2e-5, err_msg=k)


@pytest.mark.parametrize("path", ["compute", "fragment"])
def test_tileable_volume_gpu_matches_numpy(ctx, monkeypatch, path):
    """Within the texture test's bound (tests/test_texture.py::assert_gpu_matches_numpy), 4D too,
    on either GPU path."""
    from cellgl.gl.path import has_compute

    if path == "compute" and not has_compute(ctx):
        pytest.skip("no compute path on this context (the fragment path runs)")
    monkeypatch.setenv("CELLGL_PATH", path)
    for r in (_solid(warp_amount=0.3), _solid().replace(dimension=4, time=0.7)):
        g = texture.render(r, 8, 6, channels=CHS, depth=4)
        n = texture.render(r, 8, 6, channels=CHS, depth=4, backend="numpy")
        tie = np.abs(n["F2"] - n["F1"]) < 1e-4
        assert np.array_equal(g["id"][~tie], n["id"][~tie])
        for k in ("height", "F1", "F2"):
            np.testing.assert_allclose(g[k], n[k], atol=2e-4, err_msg=k)


def test_flat_recipes_keep_their_period():
    """A 2D recipe's lattice has no z period (nothing changes for images of flat recipes)."""
    from cellgl.texture.reference import texture_period, texture_values

    assert texture_period(texture_values(load_recipe("f1").tileable()[0]), 1).tolist()[2:] == [0, 0]
    t = texture_values(load_recipe("f1").replace(dimension=3, frequency=5.0).tileable()[0])
    assert texture_period(t, 1).tolist() == [10, 10, 10, 0]


# --------------------------------------------------------------------------------------------
# OpenVDB output (cellgl.io.vdb)
# --------------------------------------------------------------------------------------------

needs_vdb = pytest.mark.skipif(not vdb.have_vdb(), reason="no OpenVDB binding (cellgl[blender])")


@needs_vdb
def test_vdb_tiles_land_where_the_npy_has_them(fake, tmp_path):
    """Tiles of 16 x 16 (3 x 2 of them, the last cut) in any grid: the read-back grids equal the
    .npy bake of each channel, bit for bit; ids exact in 64-bit integer grids."""
    out = B.bake("fake", tmp_path / "v.vdb", size="40x24x3", channels=("height", "normal", "id", "color"),
                 tile=16, progress=False)
    assert [p.name for p in out] == ["v.vdb"] and out.colorspace == "linear"
    grids, meta, gmeta = vdb.read_vdb(tmp_path / "v.vdb")
    assert sorted(grids) == ["color.B", "color.G", "color.R", "height", "id", "normal.B", "normal.G", "normal.R"]
    for c in ("height", "normal", "id", "color"):
        B.bake("fake", tmp_path / f"n_{c}.npy", size="40x24x3", channels=(c,), tile=16, progress=False)
        want = np.load(tmp_path / f"n_{c}.npy")
        if c == "color":
            from cellgl.io.colour import encode_linear

            want = encode_linear(want[..., :3], np.float32)
        got = np.stack([grids[n] for n in vdb.grid_names(c, 1 if want.ndim == 3 else want.shape[-1])], axis=-1)
        assert np.array_equal(got, want.reshape(got.shape)), c
    assert grids["id"].dtype == np.int64
    assert meta["creator"] == "cellgl" and '"size": [40, 24, 3]' in meta["cellgl"]
    assert gmeta["color.G"]["colorspace"] == "lin_rec709_scene" and gmeta["color.G"]["cellgl_sample"] == "G"
    assert "colorspace" not in gmeta["height"] and gmeta["normal.B"]["cellgl_channel"] == "normal"


@needs_vdb
def test_vdb_transform_maps_voxels_to_texture_space(tmp_path):
    vdb.write_vdb(tmp_path / "t.vdb", (4, 2, 8), {"height": (1, np.float32)},
                  [(0, 0, {"height": np.ones((8, 2, 4), np.float32)})], metadata='{"size": [4, 2, 8]}')
    (g,), _ = vdb.binding().readAll(str(tmp_path / "t.vdb"))
    assert g.transform.indexToWorld((0, 0, 0)) == pytest.approx((0.125, 0.25, 0.0625))
    assert g.transform.indexToWorld((3, 1, 7)) == pytest.approx((0.875, 0.75, 0.9375))
    assert g.transform.voxelSize() == pytest.approx((0.25, 0.5, 0.125))


@pytest.mark.parametrize("argv, message", [
    (["-o", "a.vdb", "--size", "16x16"], "a .vdb holds a volume, not a 16x16 image: accepted --size WxHxD"),
    (["-o", "a.vdb", "--size", "8x8x4", "--depth", "16"], "--depth 16: .vdb accepts 32 bits"),
    (["-o", "a.vdb", "--size", "8x8x4", "--colorspace", "rec2020"], "--colorspace 'rec2020': unknown"),
])
def test_vdb_errors_before_any_work(fake, tmp_path, capsys, monkeypatch, argv, message):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["bake", "fake", *argv]) == 2
    assert message in capsys.readouterr().err
    assert not fake and not list(tmp_path.iterdir())


def test_vdb_without_the_binding_is_one_clear_error(fake, tmp_path, capsys, monkeypatch):
    """No `import openvdb` and no bpy wheel to take it from: the bake says what to install."""
    monkeypatch.setitem(sys.modules, "openvdb", None)          # import openvdb fails
    monkeypatch.setattr(vdb, "_bundled_path", lambda: None)
    monkeypatch.chdir(tmp_path)
    assert cli.main(["bake", "fake", "-o", "a.vdb", "--size", "8x8x4"]) == 2
    err = capsys.readouterr().err
    assert "writing .vdb files needs OpenVDB's Python binding" in err and "cellgl[blender]" in err
    assert not fake and not list(tmp_path.iterdir())
    assert not vdb.have_vdb()


@needs_vdb
def test_gpu_vdb_reads_back_as_the_numpy_bake(ctx, tmp_path):
    """A tileable solid recipe baked to .vdb on the GPU, read back by the OpenVDB binding: the
    .npy bake's bits, and the NumPy reference's values within the texture bound (2e-4)."""
    sets = ["dimension=3", "frequency=3", "fractal=sum", "octaves=2"]
    B.bake("f1", tmp_path / "f.vdb", size="12x8x6", channels=("F1", "height"), sets=sets, tileable=True,
           progress=False)
    grids, _, _ = vdb.read_vdb(tmp_path / "f.vdb")
    r = B.load_recipe_sets("f1", sets, True)
    ref = texture.render(r, 12, 8, channels=("F1", "height"), depth=6, backend="numpy")
    for c in ("F1", "height"):
        B.bake("f1", tmp_path / f"f_{c}.npy", size="12x8x6", channels=(c,), sets=sets, tileable=True,
               progress=False)
        assert np.array_equal(grids[c], np.load(tmp_path / f"f_{c}.npy")), c
        np.testing.assert_allclose(grids[c], ref[c], atol=2e-4, err_msg=c)


# --------------------------------------------------------------------------------------------
# the cloud channel (cellgl.texture.cloud)
# --------------------------------------------------------------------------------------------

CLOUD_BASE = Recipe().replace(dimension=3, frequency=2.0, distribution="jitter", seed=7, tileable=True)


def test_cloud_packs_perlin_worley_and_three_worley_octaves():
    """R = W(1) + P (1 - W(1)), G/B/A the Worley fBm heights at f, 2f, 4f (NumPy path)."""
    p, w1, w2, w4 = cloud.cloud_recipes(CLOUD_BASE, texture.measure_range)
    assert [r.get("frequency") for r in (p, w1, w2, w4)] == [2.0, 2.0, 4.0, 8.0]
    assert w1.get("invert") and w1.get("fractal") == "sum" and p.get("c_noise") == 1.0 and p.get("c1") == 0.0
    assert all(r.get("tileable") and r.get("distribution") == "jitter" for r in (p, w1, w2, w4))
    got = texture.render(CLOUD_BASE, 10, 8, depth=3, channels=("cloud", "F1"), backend="numpy")
    assert list(got) == ["cloud", "F1"] and got["cloud"].shape == (3, 8, 10, 4)
    assert got["cloud"].dtype == np.float32
    h = [texture.render(r, 10, 8, depth=3, channels=("height",), backend="numpy")["height"].astype(np.float64)
         for r in (p, w1, w2, w4)]
    want = np.stack([h[1] + h[0] * (1 - h[1]), h[1], h[2], h[3]], axis=-1).astype(np.float32)
    assert np.array_equal(got["cloud"], want)
    assert 0.0 <= got["cloud"].min() and got["cloud"].max() <= 1.0
    assert np.all(got["cloud"][..., 0] >= got["cloud"][..., 1])        # Perlin remapped onto [W, 1]


def test_cloud_gpu_matches_numpy_and_tiles(ctx):
    g = texture.render(CLOUD_BASE, 12, 10, depth=4, channels=("cloud",))["cloud"]
    n = texture.render(CLOUD_BASE, 12, 10, depth=4, channels=("cloud",), backend="numpy")["cloud"]
    np.testing.assert_allclose(g, n, atol=4e-4)     # R: the heights' 2e-4 twice
    half = texture.render(CLOUD_BASE, 12, 10, depth=4, channels=("cloud",), x0=6, y0=5, tile_w=6, tile_h=5)
    assert np.array_equal(half["cloud"], g[:, 5:, 6:])
    pts = np.array([[0.1, 0.2, 0.3], [0.7, 0.05, 0.9]])
    for shift in ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)):    # period 1 along u, v and z
        a = texture.evaluate(CLOUD_BASE, pts, ("cloud",))["cloud"]
        b = texture.evaluate(CLOUD_BASE, pts + np.array(shift), ("cloud",))["cloud"]
        np.testing.assert_allclose(a, b, atol=1e-5, err_msg=str(shift))


def test_cloud_channel_is_data_of_four_named_samples():
    """Four samples a voxel, never a colour space: EXR channels and VDB grids cloud.R..A."""
    from cellgl.io import spec

    assert spec.CHANNELS["cloud"] == 4 and spec.exr_names("cloud") == ("cloud.R", "cloud.G", "cloud.B", "cloud.A")
    assert spec.encoding_of("cloud", ".exr", 32, "linear").colorspace is None
    assert vdb.grid_names("cloud", 4) == ("cloud.R", "cloud.G", "cloud.B", "cloud.A")


@needs_vdb
def test_gpu_cloud_volume_bakes_to_vdb_and_tif_alike(ctx, tmp_path):
    sets = ["dimension=3", "distribution=jitter", "frequency=2"]
    kw = dict(size="16x12x4", channels=("cloud",), sets=sets, tileable=True, progress=False)
    out = B.bake("f1", tmp_path / "c.vdb", **kw)
    assert out.colorspace is None
    B.bake("f1", tmp_path / "c.tif", **kw)
    import tifffile

    tif = tifffile.imread(tmp_path / "c.tif")
    grids, _, gmeta = vdb.read_vdb(tmp_path / "c.vdb")
    assert tif.shape == (4, 12, 16, 4)
    assert np.array_equal(np.stack([grids[f"cloud.{s}"] for s in "RGBA"], axis=-1), tif)
    assert all("colorspace" not in m for m in gmeta.values())
    ref = texture.render(B.load_recipe_sets("f1", sets, True), 16, 12, depth=4, channels=("cloud",),
                         backend="numpy")["cloud"]
    np.testing.assert_allclose(tif, ref, atol=4e-4)


def _have_bpy() -> bool:
    import importlib.util

    return importlib.util.find_spec("bpy") is not None


@needs_vdb
@pytest.mark.skipif(not _have_bpy(), reason="Blender's bpy (cellgl[blender]) is not installed")
def test_blender_reads_the_vdb_grids_and_transform(tmp_path):
    """Blender's own volume reader (a Volume datablock on the file, in a child process) finds
    every grid as a float grid with the texture-space transform the file states."""
    import json
    import subprocess

    vdb.write_vdb(tmp_path / "b.vdb", (16, 8, 4), {"F1": (1, np.float32), "color": (3, np.float32)},
                  [(0, 0, {"F1": np.full((4, 8, 16), 0.5, np.float32),
                           "color": np.full((4, 8, 16, 3), 0.25, np.float32)})],
                  metadata='{"size": [16, 8, 4]}', colorspaces={"color": "lin_rec709_scene"})
    script = ("import bpy, json, sys\n"
              "v = bpy.data.volumes.new('v'); v.filepath = sys.argv[1]\n"
              "assert v.grids.load(), v.grids.error_message\n"
              "print(json.dumps({g.name: [g.data_type, g.load(), [list(r) for r in g.matrix_object]] "
              "for g in v.grids}))\n")
    p = subprocess.run([sys.executable, "-c", script, str(tmp_path / "b.vdb")], capture_output=True,
                       text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    grids = json.loads(p.stdout.strip().splitlines()[-1])
    assert sorted(grids) == ["F1", "color.B", "color.G", "color.R"]
    want = [[1 / 16, 0, 0, 0.5 / 16], [0, 1 / 8, 0, 0.5 / 8], [0, 0, 1 / 4, 0.5 / 4], [0, 0, 0, 1]]
    for name, (kind, loaded, matrix) in grids.items():
        assert kind == "FLOAT" and loaded, name
        np.testing.assert_allclose(matrix, want, atol=1e-7, err_msg=name)


@pytest.mark.parametrize("sets, message", [
    (["distribution=worley1996"], "domain.tileable: not available with basis.distribution 'worley1996'"),
    (["density_map=ramp_x"], "domain.tileable: not available with basis.density_map 'ramp_x'"),
])
def test_tileable_volume_of_a_recipe_that_cannot_repeat_is_refused(tmp_path, capsys, sets, message):
    """A volume that could not be periodic in depth (nor in x, y): one error, nothing written."""
    argv = ["bake", "f1", "-o", str(tmp_path / "v.vdb"), "--size", "8x8x4", "--tileable", "--set", "dimension=3"]
    for s in sets:
        argv += ["--set", s]
    assert cli.main(argv) == 2
    assert message in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("ext", [".dds", ".ktx2"])
def test_gpu_cloud_3d_texture_is_rgba8_of_the_npy(ctx, tmp_path, ext):
    """The packed noise as cloud renderers load it: a 3D R8G8B8A8_UNORM texture (data, not sRGB)
    whose voxels are the .npy bake's four samples quantised as every 8-bit file's."""
    from test_texfiles import DXGI, decode, read

    from cellgl.io.spec import quantize

    kw = dict(size="8x6x4", channels=("cloud",), sets=["dimension=3", "frequency=2"], tileable=True, progress=False)
    B.bake("f1", tmp_path / f"c{ext}", **kw)
    B.bake("f1", tmp_path / "c.npy", **kw)
    f = read(tmp_path / f"c{ext}")
    assert DXGI[f["dxgi"]][0] == "R8G8B8A8_UNORM" and f["depth"] == 4
    (size, blob), = f["levels"]
    assert np.array_equal(decode(f["dxgi"], size, blob), quantize(np.load(tmp_path / "c.npy"), 8))
