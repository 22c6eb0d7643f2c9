"""Bakes for film pipelines (issue 46): scene-linear tagged float colour, UDIM sets.

The colour and UDIM plumbing runs against test_bake's stand-in renderer (no GL); the tests at the
end bake a real preset on the GPU (conftest's ``ctx``).
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from cellgl import cli
from cellgl.bake import core as B
from cellgl.bake import udim as U
from cellgl.io.colour import COLORSPACES, REC709_CHROMATICITIES, linear_to_srgb, srgb_to_linear
import test_bake
from test_bake import FakeRecipe, _fake_render, _read

fake = test_bake.fake     # a fixture: the tests take it as an argument

# --------------------------------------------------------------------------------------------
# colour
# --------------------------------------------------------------------------------------------


def test_srgb_transfer_is_the_exact_piecewise_function():
    c = np.array([0.0, 0.02, 0.04045, 0.5, 1.0])
    assert np.allclose(srgb_to_linear(c), [0.0, 0.02 / 12.92, 0.04045 / 12.92,
                                           ((0.5 + 0.055) / 1.055) ** 2.4, 1.0], rtol=0, atol=1e-15)
    x = np.linspace(0, 1, 1001)
    assert np.allclose(linear_to_srgb(srgb_to_linear(x)), x, atol=1e-12)


def test_exr_colour_is_linear_and_tagged_data_untouched(fake, tmp_path):
    pytest.importorskip("OpenEXR")
    ref = _fake_render([])(FakeRecipe(), 24, 18, channels=("color", "height"))
    lin = B.bake("fake", tmp_path / "lin.exr", size=(24, 18), channels="color,height", bit_depth=16,
                 progress=False)
    enc = B.bake("fake", tmp_path / "enc.exr", size=(24, 18), channels="color,height", bit_depth=16,
                 colorspace="srgb", progress=False)
    assert (lin.colorspace, enc.colorspace) == ("linear", "srgb")
    a, b = _read(lin[0]), _read(enc[0])
    rgb = np.clip(ref["color"][..., :3], 0, 1)
    want = srgb_to_linear(ref["color"][..., :3]).astype(np.float16)
    assert np.array_equal(np.stack([a[c] for c in "RGB"], -1), want)
    assert np.array_equal(np.stack([b[c] for c in "RGB"], -1), ref["color"][..., :3].astype(np.float16))
    assert not np.array_equal(want, rgb.astype(np.float16))          # the conversion did something
    assert np.array_equal(a["height"], b["height"])                 # data: as rendered, both
    assert np.array_equal(a["height"], ref["height"].astype(np.float16))

    import OpenEXR

    for path, space in ((lin[0], "linear"), (enc[0], "srgb")):
        h = OpenEXR.File(str(path)).header()
        assert h["oiio:ColorSpace"] == h["colorInteropID"] == COLORSPACES[space].interop_id
        assert np.allclose(h["chromaticities"], np.ravel(REC709_CHROMATICITIES), atol=1e-7)
        assert json.loads(h["cellgl"])["colorspace"] == {"color": COLORSPACES[space].interop_id}


def test_data_only_exr_has_no_colour_tag(fake, tmp_path):
    pytest.importorskip("OpenEXR")
    import OpenEXR

    got = B.bake("fake", tmp_path / "h.exr", size=(16, 16), channels="height,normal", progress=False)
    h = OpenEXR.File(str(got[0])).header()
    assert got.colorspace is None
    assert not {"oiio:ColorSpace", "colorInteropID", "chromaticities"} & set(h)
    assert "colorspace" not in json.loads(h["cellgl"])


def test_float_tiff_linear_integer_formats_srgb(fake, tmp_path):
    pytest.importorskip("tifffile")
    import tifffile

    ref = _fake_render([])(FakeRecipe(), 20, 16)["color"][..., :3]
    t = B.bake("fake", tmp_path / "a.tif", size=(20, 16), tile=16, progress=False)
    assert t.colorspace == "linear"
    assert np.array_equal(_read(t[0]), srgb_to_linear(ref).astype(np.float32))
    desc = json.loads(tifffile.TiffFile(t[0]).pages[0].description)
    assert desc["colorspace"] == {"color": "lin_rec709_scene"}
    t8 = B.bake("fake", tmp_path / "a8.tif", size=(20, 16), tile=16, bit_depth=8, progress=False)
    assert t8.colorspace == "srgb"
    n = B.bake("fake", tmp_path / "a.npy", size=(20, 16), progress=False)
    assert n.colorspace is None and np.array_equal(np.load(n[0]), ref)   # render()'s values


@pytest.mark.parametrize("argv, message", [
    (["-o", "a.png", "--colorspace", "linear"], "--colorspace linear: only for float files"),
    (["-o", "a.tif", "--depth", "16", "--colorspace", "srgb"], "only for float files"),
    (["-o", "a.npy", "--colorspace", "linear"], "only for float files"),
    (["-o", "a.exr", "--colorspace", "acescg"], "--colorspace 'acescg': unknown colour space; accepted linear, srgb"),
    (["-o", "a.<UDIM>.png", "--udim", "1001-1101"], "tile 1101 is out of range; accepted tile numbers 1001..1100"),
    (["-o", "a.<UDIM>.png", "--udim", "1000"], "tile 1000 is out of range"),
    (["-o", "a.<UDIM>.png", "--udim", "1001-"], "'1001-' is not a tile number or range"),
    (["-o", "a.<UDIM>.png", "--udim", "1012-1001"], "runs backwards"),
    (["-o", "a.<UDIM>.png", "--udims", "11x1"], "accepted UxV with U columns and V rows in 1..10"),
    (["-o", "a.png", "--udim", "1001-1002"], "needs the token <UDIM> once in the file name"),
    (["-o", "a.<UDIM>.png"], "holds <UDIM> but no --udim/--udims was given"),
    (["-o", "a.<UDIM>.png", "--udim", "1001", "--udims", "2x2"], "accepted one of them"),
    (["-o", "a.<UDIM>.npy", "--udim", "1001", "--size", "8x8x4"], "UDIM sets are of 2D images"),
    (["-o", "a.<UDIM>.png", "--udim", "1001", "--frames", "2"], "not with --frames or a .zarr output"),
    (["-o", "a.<UDIM>.png", "--udim", "1001-1010", "--size", "8192"],
     "10 columns of 8192 px make a bake 81920 px across; accepted at most 65536 (tiles of at most 6553 px"),
])
def test_cli_errors_before_any_work(fake, tmp_path, capsys, monkeypatch, argv, message):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["bake", "fake", *argv]) == 2
    assert message in capsys.readouterr().err
    assert not fake and not list(tmp_path.iterdir())                 # nothing rendered or written


# --------------------------------------------------------------------------------------------
# UDIM
# --------------------------------------------------------------------------------------------


def _udim_recipe(**kw):
    return FakeRecipe("fake", {"seed": 0, "tileable": False, "dimension": 2, "frequency": 4.0,
                               "aspect": 1.0, "offset_x": 0.0, "offset_y": 0.0, **kw})


def test_udim_parsing():
    assert [t.number for t in U.parse_udim("1001-1003, 1011")] == [1001, 1002, 1003, 1011]
    assert [(t.u, t.v) for t in U.parse_udim("1010,1011,1100")] == [(9, 0), (0, 1), (9, 9)]
    assert [t.number for t in U.parse_udims("2x3")] == [1001, 1002, 1011, 1012, 1021, 1022]


def test_window_recipe_covers_the_tiles_uv():
    r = U.window_recipe(_udim_recipe(frequency=3.0, aspect=2.0, offset_x=1.0, offset_y=5.0),
                        U.parse_udim("1012-1014,1022"))
    # columns u 1..3, rows v 1..2: cellgl uv [1, 4) x [-2, 0), cells u*3 + 1, v*3*2 + 5
    assert r.values["frequency"] == 9.0 and r.values["aspect"] == 2.0 * 2 / 3
    assert r.values["offset_x"] == 1.0 + 1 * 3.0 and r.values["offset_y"] == 5.0 - 2 * 3.0 * 2.0


def test_udim_tiles_are_crops_of_one_bake(fake, tmp_path, monkeypatch):
    """Every tile equals its crop of one bake over the set's rectangle, bit for bit; a tile the
    range skips (1003 of 1001-1002,1011-1013) is not written."""
    from cellgl import recipes

    monkeypatch.setattr(recipes, "load_recipe", lambda name: _udim_recipe())
    tiles = U.parse_udim("1001-1002,1011-1013")
    got = B.bake("fake", tmp_path / "t.<UDIM>.npy", size=(20, 12), udim="1001-1002,1011-1013",
                 tile=16, progress=False)
    assert got.udims == (1001, 1002, 1011, 1012, 1013)
    assert sorted(p.name for p in tmp_path.iterdir()) == [f"t.{n}.npy" for n in got.udims]
    whole = B.bake(U.window_recipe(_udim_recipe(), tiles), tmp_path / "whole.npy", size=(60, 24),
                   progress=False)
    big = np.load(whole[0])
    for t, p in zip(tiles, got):
        x, y = (t.u - 0) * 20, (1 - t.v) * 12                     # v = 1 is the top row band
        assert np.array_equal(np.load(p), big[y:y + 12, x:x + 20]), p.name


def test_udim_set_lands_whole(fake, tmp_path, monkeypatch):
    from cellgl import recipes

    monkeypatch.setattr(recipes, "load_recipe", lambda name: _udim_recipe())
    real = B._bake_one
    seen = []

    def failing(recipe, out, *a, **kw):
        seen.append(out.path.name)
        if len(seen) == 3:
            raise OSError(28, "No space left on device")
        return real(recipe, out, *a, **kw)

    monkeypatch.setattr(B, "_bake_one", failing)
    with pytest.raises(OSError):
        B.bake("fake", tmp_path / "t.<UDIM>.png", size=16, udims="2x2", progress=False)
    assert len(seen) == 3 and list(tmp_path.iterdir()) == []         # no tile, no temporary file


def test_udim_refuses_uv_space_maps(fake, tmp_path, monkeypatch):
    from cellgl import recipes

    monkeypatch.setattr(recipes, "load_recipe", lambda name: _udim_recipe(density_map="radial"))
    with pytest.raises(B.BakeError, match="density_map = radial is laid over one uv square"):
        B.bake("fake", tmp_path / "t.<UDIM>.png", size=16, udims="2x1", progress=False)
    assert not fake


# --------------------------------------------------------------------------------------------
# real recipes on the GPU
# --------------------------------------------------------------------------------------------


def test_gpu_exr_colour_is_srgb_to_linear_of_the_png(ctx, tmp_path):
    pytest.importorskip("OpenEXR")
    from test_io import _read_png_raw

    png = B.bake("flagstone", tmp_path / "a.png", size=48, bit_depth=16, progress=False)
    exr = B.bake("flagstone", tmp_path / "a.exr", size=48, bit_depth=16, progress=False)
    p = _read_png_raw(png[0])[0].astype(np.float64) / 65535
    e = _read(exr[0])
    lin = np.stack([e[c] for c in "RGB"], -1).astype(np.float64)
    want = srgb_to_linear(p)
    # half: 11 significant bits; the 16-bit PNG's rounding moves linear by at most 2.3 * 0.5/65535
    assert np.all(np.abs(lin - want) <= np.abs(want) * 2.0 ** -11 + 2e-5)
    assert np.ptp(lin) > 0.1


def test_gpu_openimageio_reads_the_colour_space(ctx, tmp_path):
    pytest.importorskip("OpenEXR")
    oiio = _oiio()
    for space in ("linear", "srgb"):
        (p,) = B.bake("flagstone", tmp_path / f"{space}.exr", size=16, colorspace=space,
                      channels="color,height", progress=False)
        inp = oiio.ImageInput.open(str(p))
        try:
            spec = inp.spec()
            name = spec.get_string_attribute("oiio:ColorSpace")
            assert name == COLORSPACES[space].interop_id
            assert oiio.ColorConfig().equivalent(name, COLORSPACES[space].ocio_name)
            assert np.allclose(spec.getattribute("chromaticities"), np.ravel(REC709_CHROMATICITIES))
            assert list(spec.channelnames) == ["R", "G", "B", "height"]
        finally:
            inp.close()


def test_gpu_udim_tile_1001_is_the_plain_bake_and_edges_join(ctx, tmp_path):
    """Tile 1001 shows uv [0, 1)^2 as the plain bake does (to float rounding of u f); the tiles of
    a 2x2 set join without a seam (the step across an edge is no bigger than steps inside)."""
    plain = np.load(B.bake("flagstone", tmp_path / "p.npy", size=48, channels="height",
                           progress=False)[0])
    got = B.bake("flagstone", tmp_path / "t.<UDIM>.npy", size=48, channels="height", udims="2x2",
                 progress=False)
    t = {n: np.load(p) for n, p in zip(got.udims, got)}
    assert np.mean(np.abs(t[1001] - plain) > 1e-4) < 0.01
    grid = np.block([[t[1011], t[1012]], [t[1001], t[1002]]])
    inner = np.abs(np.diff(grid, axis=1))
    seam = inner[:, 47]
    assert seam.mean() < 3 * np.delete(inner, 47, axis=1).mean()
    inner_v = np.abs(np.diff(grid, axis=0))
    assert inner_v[47].mean() < 3 * np.delete(inner_v, 47, axis=0).mean()


# --------------------------------------------------------------------------------------------
# tiled, mip-mapped textures (.tx, --tiled --mips)
# --------------------------------------------------------------------------------------------


def _oiio():
    """OpenImageIO, the reader the tests check against (the wheel or Blender's copy)."""
    from cellgl.io.tiled import openimageio

    oiio = openimageio()
    if oiio is None:
        pytest.skip("OpenImageIO is not installed (pip install openimageio, or bpy)")
    return oiio


def _oiio_levels(path):
    """(spec, [level arrays]) as OpenImageIO reads a file's MIP levels."""
    oiio = _oiio()
    inp = oiio.ImageInput.open(str(path))
    assert inp is not None, oiio.geterror()
    try:
        spec0, levels, k = inp.spec(), [], 0
        while inp.seek_subimage(0, k):
            s = inp.spec()
            assert (s.tile_width, s.tile_height) == (64, 64)
            levels.append(inp.read_image(s.format.basetype == oiio.HALF and "half" or "float"))
            k += 1
        assert not inp.seek_subimage(1, 0)              # one image, its levels
        return spec0, levels
    finally:
        inp.close()


@pytest.mark.parametrize("name, kw", [("t.tx", {}), ("t.tif", {"tiled": True, "mips": True}),
                                      ("t.exr", {"tiled": True, "mips": True, "bit_depth": 16})])
def test_gpu_tiled_mips_are_renders_at_each_size(ctx, tmp_path, name, kw):
    """Every level OpenImageIO reads is cellgl.render at that level's size (encoded: colour
    scene-linear), 64 x 64 tiles, the chain down to 1 x 1 rounding up."""
    pytest.importorskip("tifffile")
    pytest.importorskip("OpenEXR")
    from cellgl import recipes
    from cellgl.bake.mips import mip_sizes

    got = B.bake("flagstone", tmp_path / name, size=(80, 48), progress=False, **kw)
    spec, levels = _oiio_levels(got[0])
    assert got.colorspace == "linear"
    assert [lv.shape[:2] for lv in levels] == [(h, w) for w, h in mip_sizes(80, 48)]
    assert spec.get_string_attribute("textureformat") == "Plain Texture"
    half = name.endswith(".exr")
    for (w, h), lv in zip(mip_sizes(80, 48), levels):
        want = srgb_to_linear(recipes.render("flagstone", w, h)["color"][..., :3])
        want = want.astype(np.float16 if half else np.float32)
        assert np.array_equal(lv[..., :3].astype(want.dtype), want), (w, h)
    if half:
        assert spec.get_string_attribute("oiio:ColorSpace") == "lin_rec709_scene"


def test_gpu_tiled_exr_level0_equals_the_scanline_bake(ctx, tmp_path):
    pytest.importorskip("OpenEXR")
    t = B.bake("flagstone", tmp_path / "t.exr", size=(70, 40), tiled=True, colorspace="srgb",
               channels="color,height", progress=False)
    s = B.bake("flagstone", tmp_path / "s.exr", size=(70, 40), colorspace="srgb",
               channels="color,height", progress=False)
    spec, levels = _oiio_levels(t[0])
    assert len(levels) == 1 and list(spec.channelnames) == ["R", "G", "B", "height"]
    assert spec.get_string_attribute("oiio:ColorSpace") == "srgb_rec709_scene"
    ref = _read(s[0])
    assert np.array_equal(levels[0], np.stack([ref[c] for c in ("R", "G", "B", "height")], -1))


@pytest.mark.parametrize("argv, message", [
    (["-o", "a.png", "--tiled"], "--tiled with .png: accepted for .exr, .tif, .tiff, .tx"),
    (["-o", "a.tif", "--tiled", "--size", "8x8x4"], "tiled textures are 2D"),
    (["-o", "a.tx", "--size", "8x8x4"], "volumes are written to .npy or .tif only"),
    (["-o", "a.exr", "--tiled", "--channels", "color,id"], "a tiled EXR here holds float channels only"),
])
def test_tiled_errors(fake, tmp_path, capsys, monkeypatch, argv, message):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["bake", "fake", *argv]) == 2
    assert message in capsys.readouterr().err
    assert not fake and not list(tmp_path.iterdir())


def test_gpu_udim_tx_set(ctx, tmp_path):
    """A UDIM set of .tx files: every tile mip-mapped, level k of each tile its crop of the
    set's bake at level k's size (power-of-two sides: the crops line up)."""
    pytest.importorskip("tifffile")
    from cellgl.bake import mips

    got = B.bake("flagstone", tmp_path / "w.<UDIM>.tx", size=32, udims="2x1", colorspace="srgb",
                 progress=False)
    assert [p.name for p in got] == ["w.1001.tx", "w.1002.tx"]
    whole = U.window_recipe(B.load_recipe_sets("flagstone", (), None), U.parse_udims("2x1"))
    for k in range(mips.level_count(32, 32)):
        lv = mips.render_level(whole, 64, 32, k)["color"][..., :3]
        s = 32 >> k
        for i, p in enumerate(got):
            assert np.array_equal(_oiio_levels(p)[1][k], lv[:, i * s:(i + 1) * s]), (p.name, k)


def test_udim_mips_are_crops_of_the_sets_levels(fake, tmp_path, monkeypatch):
    """--udim with --mips (numbered files): level k of each tile is its crop of level k of the
    set's bake (power-of-two sides)."""
    from cellgl import recipes

    monkeypatch.setattr(recipes, "load_recipe", lambda name: _udim_recipe())
    got = B.bake("fake", tmp_path / "t.<UDIM>.npy", size=16, udims="2x1", mips=True, progress=False)
    assert len(got) == 2 * 5
    whole = B.bake(U.window_recipe(_udim_recipe(), U.parse_udims("2x1")), tmp_path / "w.npy",
                   size=(32, 16), mips=True, progress=False)
    for k in range(5):
        big = np.load(whole[k])
        s = 16 >> k
        for i, n in enumerate((1001, 1002)):
            name = f"t.{n}.npy" if k == 0 else f"t.{n}_mip{k}.npy"
            assert np.array_equal(np.load(tmp_path / name), big[:, i * s:(i + 1) * s]), name


@pytest.mark.slow
def test_gpu_blender_reads_the_exr_as_linear(ctx, tmp_path):
    """Blender (bpy, the [blender] extra) opens a cellgl EXR as "Linear Rec.709" by itself and
    its pixels are the file's: the colour reaches Cycles unchanged (docs/bake.md)."""
    import importlib.util
    import subprocess
    import sys

    pytest.importorskip("OpenEXR")
    if importlib.util.find_spec("bpy") is None:
        pytest.skip("bpy is not installed (pip install 'cellgl[blender]')")
    (p,) = B.bake("flagstone", tmp_path / "a.exr", size=(24, 16), progress=False)
    code = ("import bpy, json, sys; img = bpy.data.images.load(sys.argv[1]); "
            "print(json.dumps([img.colorspace_settings.name, list(img.size), list(img.pixels[:])]))")
    out = subprocess.run([sys.executable, "-c", code, str(p)], capture_output=True, text=True,
                         timeout=300, check=True).stdout.strip().splitlines()[-1]
    name, size, px = json.loads(out)
    assert name == "Linear Rec.709" and size == [24, 16]
    rgba = np.array(px, np.float32).reshape(16, 24, 4)[::-1]          # Blender's rows: bottom first
    e = _read(p)
    assert np.allclose(rgba[..., :3], np.stack([e[c] for c in "RGB"], -1), rtol=0, atol=1e-6)


@pytest.mark.slow
def test_gpu_blender_reads_a_tx_as_its_level_0(ctx, tmp_path):
    """What Blender (Cycles' image loader) does with a .tx, as docs/bake.md says: a plain TIFF,
    level 0 only, taken for sRGB; set to "Linear Rec.709" its pixels are the file's."""
    import importlib.util
    import subprocess
    import sys

    pytest.importorskip("tifffile")
    if importlib.util.find_spec("bpy") is None:
        pytest.skip("bpy is not installed (pip install 'cellgl[blender]')")
    (p,) = B.bake("flagstone", tmp_path / "a.tx", size=(24, 16), progress=False)
    code = ("import bpy, json, sys; img = bpy.data.images.load(sys.argv[1]); "
            "first = [img.file_format, img.colorspace_settings.name, list(img.size)]; "
            "img.colorspace_settings.name = 'Linear Rec.709'; img.reload(); "
            "print(json.dumps(first + [list(img.pixels[:])]))")
    out = subprocess.run([sys.executable, "-c", code, str(p)], capture_output=True, text=True,
                         timeout=300, check=True).stdout.strip().splitlines()[-1]
    fmt, name, size, px = json.loads(out)
    assert (fmt, name, size) == ("TIFF", "sRGB", [24, 16])
    rgba = np.array(px, np.float32).reshape(16, 24, 4)[::-1]
    assert np.allclose(rgba[..., :3], _oiio_levels(p)[1][0], rtol=0, atol=1e-6)


def test_gpu_udim_tiles_are_crops_of_one_bake_bit_for_bit(ctx, tmp_path):
    B.bake("flagstone", tmp_path / "t.<UDIM>.npy", size=(40, 24), udim="1001,1002,1012",
                 channels="color,height", tile=16, progress=False)
    whole = B.bake(U.window_recipe(B.load_recipe_sets("flagstone", (), None), U.parse_udim("1001,1002,1012")),
                   tmp_path / "whole.npy", size=(80, 48), channels="color,height", progress=False)
    for ch, w in zip(("color", "height"), whole):
        big = np.load(w)
        for n, (x, y) in ((1001, (0, 24)), (1002, (40, 24)), (1012, (40, 0))):
            tile = np.load(tmp_path / f"t.{n}_{ch}.npy")
            assert np.array_equal(tile, big[y:y + 24, x:x + 40]), (n, ch)
    assert not (tmp_path / "t.1011_color.npy").exists()
