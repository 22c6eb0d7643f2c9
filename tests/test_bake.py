"""cellgl bake: tiling equals one pass, every format and depth, volumes, errors, atomicity.

Most tests run the bake machinery against a stand-in for ``cellgl.texture.render`` (a cheap
deterministic function of the pixel coordinates), so they need no GL and check the tiling,
streaming and writing exactly. The tests at the end bake real presets on the GPU.
"""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest

from cellgl.bake import core as B
from cellgl import cli

# --------------------------------------------------------------------------------------------
# stand-in recipe module and renderer
# --------------------------------------------------------------------------------------------


class FakeRecipe:
    def __init__(self, name="fake", values=None):
        self.name, self.values = name, dict(values or {"seed": 0, "tileable": False, "dimension": 3})

    def set_from_strings(self, items):
        vals = dict(self.values)
        for item in items:
            k, _, v = item.partition("=")
            if k not in vals:
                raise ValueError(f"--set {k}: unknown parameter; accepted {', '.join(vals)}")
            vals[k] = int(v) if v.isdigit() else v
        return FakeRecipe(self.name, vals)

    def replace(self, **kw):
        return FakeRecipe(self.name, {**self.values, **kw})

    def tileable(self):
        return self.replace(tileable=True), []

    def get(self, name):
        return self.values[name]

    def to_dict(self):
        return {"name": self.name, **self.values}


def _fake_render(calls):
    def render(recipe, width, height, *, channels=("color",), x0=0, y0=0, tile_w=None,
               tile_h=None, depth=None, backend="gpu"):
        tw = width - x0 if tile_w is None else tile_w
        th = height - y0 if tile_h is None else tile_h
        calls.append((x0, y0, tw, th, depth))
        y, x = np.mgrid[y0:y0 + th, x0:x0 + tw].astype(np.float64)
        u, v = (x + 0.5) / width, (y + 0.5) / height
        seed = recipe.values.get("seed", 0)
        zs = [0.5] if depth is None else [(z + 0.5) / depth for z in range(depth)]
        out = {}
        for c in channels:
            per_z = []
            for w in zs:
                f = np.sin(u * 7.1 + v * 3.3 + w * 5 + seed) * 0.6 + 0.5  # spills out of [0, 1]
                if c == "color":
                    a = np.stack([u, v, f, np.ones_like(u)], -1)
                elif c == "normal":
                    a = np.stack([f, 1 - f, u], -1)
                elif c == "id":
                    a = ((x // 5).astype(np.uint32) * 7919 + (y // 3).astype(np.uint32) * 104729
                         + int(w * 1000))
                else:
                    a = f * (1 + int(c[1:]) if c.startswith("F") else 1)
                per_z.append(a)
            a = per_z[0] if depth is None else np.stack(per_z)
            out[c] = a if c == "id" else a.astype(np.float32)
        return out

    return render


@pytest.fixture
def fake(monkeypatch):
    """Replace cellgl.recipes.load_recipe / render (what the bake calls) by stand-ins; yields the
    list of render calls."""
    from cellgl import recipes
    from cellgl.texture.recipe import RecipeError

    calls: list = []

    def load_recipe(name):
        if name not in ("flagstone", "fake"):
            raise RecipeError(f"unknown preset {name!r}; accepted flagstone, fake")
        return FakeRecipe(name)

    monkeypatch.setattr(recipes, "load_recipe", load_recipe)
    monkeypatch.setattr(recipes, "render", _fake_render(calls))
    return calls


def _read(path):
    ext = os.path.splitext(str(path))[1]
    if ext == ".npy":
        return np.load(path)
    if ext in (".tif", ".tiff"):
        import tifffile

        return tifffile.imread(path)
    if ext == ".exr":
        import OpenEXR

        f = OpenEXR.File(str(path), separate_channels=True)
        return {k: c.pixels for k, c in f.channels().items()}
    from test_io import _read_png_raw

    return _read_png_raw(path)[0]


def _same(a, b):
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    return a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a, b)


# --------------------------------------------------------------------------------------------
# parsing
# --------------------------------------------------------------------------------------------


def test_parse_size():
    assert B.parse_size("512") == (512, 512, None)
    assert B.parse_size("640x480") == (640, 480, None)
    assert B.parse_size("64X32x16") == (64, 32, 16)
    for bad, words in [("0x5", "width 0"), ("5x0", "height 0"), ("70000x5", "1..65536"),
                       ("abc", "expected W"), ("1x2x3x4", "expected W"), ("8x8x0", "depth 0"),
                       ("65536x65536x2", "too many"), ("", "expected W")]:
        with pytest.raises(B.BakeError, match=words):
            B.parse_size(bad)


def test_parse_channels():
    assert B.parse_channels(["color,height", "f1", "F1"]) == ("color", "height", "F1")
    with pytest.raises(B.BakeError, match="'rgb'.*accepted color, height, normal, id, F1"):
        B.parse_channels("rgb")


# --------------------------------------------------------------------------------------------
# tiled == one pass, every format and depth
# --------------------------------------------------------------------------------------------

CASES = [(".png", 8, "color"), (".png", 16, "color"), (".png", 16, "height"),
         (".png", 8, "id"), (".png", 8, "normal"), (".exr", 16, "color"),
         (".exr", 32, "id"), (".tif", 8, "height"), (".tif", 16, "color"),
         (".tif", 32, "F2"), (".tif", 32, "id"), (".npy", 32, "normal"), (".npy", 32, "id")]


@pytest.mark.parametrize("ext,bits,channel", CASES)
def test_tiled_equals_one_pass(fake, tmp_path, ext, bits, channel):
    if ext == ".exr":
        pytest.importorskip("OpenEXR")
    if ext == ".tif":
        pytest.importorskip("tifffile")
    size = (70, 37)  # not a multiple of the tile
    one = B.bake("fake", tmp_path / f"one{ext}", size=size, channels=[channel], bit_depth=bits,
                 progress=False)
    assert len(fake) == 1
    tiled = B.bake("fake", tmp_path / f"tiled{ext}", size=size, channels=[channel],
                   bit_depth=bits, tile=16, progress=False)
    assert len(fake) == 1 + 5 * 3
    a, b = _read(one[0]), _read(tiled[0])
    assert _same(a, b)
    assert sorted(os.listdir(tmp_path)) == sorted([f"one{ext}", f"tiled{ext}"])


def test_values_and_quantization(fake, tmp_path):
    ref = _fake_render([])(FakeRecipe(), 33, 20, channels=("color", "height", "id"))
    (p,) = B.bake("fake", tmp_path / "c.npy", size=(33, 20), progress=False)
    assert _same(np.load(p), ref["color"][..., :3])  # alpha (always 1) is not written
    (p,) = B.bake("fake", tmp_path / "h.png", size="33x20", channels="height", bit_depth=16,
                  progress=False)
    h = np.clip(ref["height"], 0, 1)
    assert np.array_equal(_read(p), np.floor(h.astype(np.float64) * 65535 + 0.5).astype(np.uint16))
    (p,) = B.bake("fake", tmp_path / "id.png", size=(33, 20), channels="id", progress=False)
    assert np.array_equal(_read(p), B.id_colors(ref["id"]))
    (p,) = B.bake("fake", tmp_path / "id.tif", size=(33, 20), channels="id", progress=False)
    assert _same(_read(p), ref["id"].astype(np.uint32))


def test_exr_holds_every_channel(fake, tmp_path):
    pytest.importorskip("OpenEXR")
    (p,) = B.bake("fake", tmp_path / "a.exr", size=(24, 18),
                  channels=["color", "height", "normal", "id", "F1"], bit_depth=16, tile=16,
                  progress=False)
    got = _read(p)
    assert set(got) == {"R", "G", "B", "height", "normal.R", "normal.G", "normal.B", "id",
                        "F1"}
    assert got["R"].dtype == np.float16 and got["id"].dtype == np.uint32
    ref = _fake_render([])(FakeRecipe(), 24, 18, channels=("normal",))["normal"]
    assert np.array_equal(got["normal.G"], ref[..., 1].astype(np.float16))


def test_one_file_per_channel_elsewhere(fake, tmp_path):
    paths = B.bake("fake", tmp_path / "t.png", size=16, channels="color,height,F3",
                   progress=False)
    assert [p.name for p in paths] == ["t_color.png", "t_height.png", "t_F3.png"]
    assert sorted(os.listdir(tmp_path)) == sorted(p.name for p in paths)


@pytest.mark.parametrize("ext", [".npy", ".tif"])
def test_volume_tiled_equals_one_pass(fake, tmp_path, ext):
    if ext == ".tif":
        pytest.importorskip("tifffile")
    one = B.bake("fake", tmp_path / f"one{ext}", size="40x20x3", channels="color",
                 progress=False)
    tiled = B.bake("fake", tmp_path / f"tiled{ext}", size="40x20x3", channels="color",
                   tile=16, progress=False)
    a, b = _read(one[0]), _read(tiled[0])
    assert a.shape == (3, 20, 40, 3) and _same(a, b)
    assert all(c[4] == 3 for c in fake)
    ref = _fake_render([])(FakeRecipe(), 40, 20, channels=("color",), depth=3)["color"][..., :3]
    if ext == ".tif":       # a float TIFF holds scene-linear colour (cellgl.io.colour)
        from cellgl.io.colour import srgb_to_linear

        ref = srgb_to_linear(ref).astype(np.float32)
    assert _same(a, ref)
    assert sorted(os.listdir(tmp_path)) == sorted([f"one{ext}", f"tiled{ext}"])  # no spool left


def test_memory_budget_bounds_tiles(fake, tmp_path):
    budget = 2 * 64 * 64 * (B.RENDER_BYTES_PER_PIXEL + 16 + 12)  # half of it: one 64x64 tile
    B.bake("fake", tmp_path / "a.npy", size=(200, 150), memory_budget=budget, progress=False)
    assert len(fake) == 4 * 3 and {(tw, th) for _, _, tw, th, _ in fake} >= {(64, 64)}
    fake.clear()
    B.bake("fake", tmp_path / "a.png", size=(4000, 60), memory_budget=budget, progress=False)
    for _, _, tw, th, _ in fake:  # a tile's render and a band of 8-bit RGB rows both fit
        assert tw * th * (B.RENDER_BYTES_PER_PIXEL + 16 + 3) <= budget // 2
        assert th * 4000 * 2 * 3 <= budget // 2
    assert max(th for *_, th, _ in fake) >= 16


def test_progress_bar(fake, tmp_path, capsys):
    assert cli.main(["bake", "fake", "-o", str(tmp_path / "a.png"), "--size", "40x40",
                     "--tile", "16"]) == 0
    err = capsys.readouterr().err
    assert "9/9 tiles" in err and "wrote" in err
    assert cli.main(["bake", "fake", "-o", str(tmp_path / "b.png"), "--size", "40x40",
                     "--tile", "16", "--quiet"]) == 0
    assert capsys.readouterr().err == ""


def test_set_and_tileable_reach_the_recipe(fake, tmp_path, monkeypatch):
    seen = []
    render = sys.modules["cellgl.recipes"].render

    def spy(recipe, *a, **kw):
        seen.append(recipe.values)
        return render(recipe, *a, **kw)

    monkeypatch.setattr(sys.modules["cellgl.recipes"], "render", spy)
    assert cli.main(["bake", "fake", "-o", str(tmp_path / "a.npy"), "--size", "8",
                     "--set", "seed=3", "--tileable", "-q"]) == 0
    assert seen[-1]["seed"] == 3 and seen[-1]["tileable"] is True


# --------------------------------------------------------------------------------------------
# errors: one line, exit 2, nothing written
# --------------------------------------------------------------------------------------------

ERRORS = [
    (["-o", "{d}/a.jpg"], "unknown extension '.jpg'; accepted .png, .exr, .tif, .tiff, .npy, .tx, .dds, "
                          ".ktx2, .vdb (an image, or with --frames N a numbered sequence); .webp, .gif (one "
                          "animated file, with --frames N); .zarr (a folder baked on Dask)"),
    (["-o", "{d}/a"], "unknown extension '(none)'"),
    (["-o", "{d}/a.png", "--channels", "albedo"], "'albedo': unknown channel; accepted color"),
    (["-o", "{d}/a.png", "--size", "0x5"], "width 0 is out of range; accepted 1..65536"),
    (["-o", "{d}/a.png", "--size", "100000"], "width 100000 is out of range; accepted 1..65536"),
    (["-o", "{d}/a.png", "--size", "big"], "--size 'big': expected W, WxH or WxHxD"),
    (["-o", "{d}/a.png", "--depth", "12"], "--depth 12: .png accepts 8, 16 bits"),
    (["-o", "{d}/a.exr", "--depth", "8"], "--depth 8: .exr accepts 16, 32 bits"),
    (["-o", "{d}/a.npy", "--depth", "16"], "--depth 16: .npy accepts 32 bits"),
    (["-o", "{d}/a.png", "--depth", "x"], "--depth x: .png accepts 8, 16 bits"),
    (["-o", "{d}/a.png", "--set", "seed"], "--set 'seed': expected NAME=VALUE"),
    (["-o", "{d}/a.png", "--set", "=3"], "--set '=3': expected NAME=VALUE"),
    (["-o", "{d}/a.png", "--set", "nope=3"], "nope: unknown parameter"),
    (["-o", "{d}/a.png", "--channels", "id", "--depth", "16"], "8-bit false-colour"),
    (["-o", "{d}/a.tif", "--channels", "id", "--depth", "16"], "ids are uint32"),
    (["-o", "{d}/a.png", "--size", "8x8x8"], "volumes are written to .npy or .tif only"),
    (["-o", "{d}/a.npy", "--size", "8x8x8", "--set", "dimension=2"], "needs a solid recipe"),
    (["-o", "{d}/a.tif", "--tile", "50"], "--tile 50: accepted multiples of 16 in 16..8192"),
    (["-o", "{d}/a.tif", "--tile", "lots"], "--tile 'lots': expected a whole number"),
    (["-o", "{d}/nodir/a.png"], "does not exist"),
    (["-o", "{d}"], "unknown extension"),
]


def test_the_unknown_extension_error_lists_every_extension_bake_accepts(tmp_path):
    """Issue 48: `-o a.jpg` listed .png .exr .tif .tiff .npy, not .zarr, .webp, .gif: the list
    comes from one place (spec.FORMATS, ANIMATED, DISTRIBUTED), the help's too."""
    from cellgl.bake import request
    from cellgl.io import spec
    from cellgl.cli.bake import add_parser
    import argparse

    every = [*spec.FORMATS, *request.ANIMATED, *request.DISTRIBUTED]
    assert {".png", ".exr", ".tif", ".tiff", ".npy", ".webp", ".gif", ".zarr"} <= set(every)
    for out in ("a.jpg", "a", "a.PNGX"):
        with pytest.raises(spec.BakeError) as e:
            B.bake("flagstone", tmp_path / out, size=8, progress=False)
        for ext in every:
            assert f"{ext}," in str(e.value) or f"{ext} (" in str(e.value), (ext, str(e.value))
    sub = argparse.ArgumentParser().add_subparsers()
    helps = {a.dest: a.help for a in add_parser(sub)._actions}
    assert request.accepted_outputs() in helps["output"]


@pytest.mark.parametrize("argv,message", ERRORS)
def test_cli_errors(fake, tmp_path, capsys, argv, message):
    argv = ["bake", "fake"] + [a.format(d=tmp_path) for a in argv]
    assert cli.main(argv) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err.startswith("cellgl: error: ") and err.count("\n") == 1, err
    assert message in err, err
    assert "Traceback" not in err
    assert os.listdir(tmp_path) == []
    assert fake == []  # rejected before rendering anything


def test_unknown_preset(fake, tmp_path, capsys):
    assert cli.main(["bake", "nosuch", "-o", str(tmp_path / "a.png")]) == 2
    err = capsys.readouterr().err
    assert "unknown preset 'nosuch'" in err and err.count("\n") == 1


def test_interrupt_leaves_nothing_behind(fake, tmp_path, monkeypatch, capsys):
    dest = tmp_path / "keep.tif"
    dest.write_bytes(b"previous")
    render = sys.modules["cellgl.recipes"].render

    def flaky(*a, **kw):
        if len(fake) == 3:
            raise KeyboardInterrupt
        return render(*a, **kw)

    monkeypatch.setattr(sys.modules["cellgl.recipes"], "render", flaky)
    for name in ("keep.tif", "new.png", "vol.tif", "vol.npy"):
        fake.clear()
        size = "48x48x2" if name.startswith("vol") else "48x48"
        argv = ["bake", "fake", "-o", str(tmp_path / name), "--size", size, "--tile", "16", "-q"]
        assert cli.main(argv) == 130
        assert sorted(os.listdir(tmp_path)) == ["keep.tif"], name
        assert dest.read_bytes() == b"previous"


# --------------------------------------------------------------------------------------------
# end to end on the GPU: the real cellgl.texture.render
# --------------------------------------------------------------------------------------------


def _recipe(**kw):
    from cellgl.texture.recipe import Recipe

    return Recipe().replace(**kw)


def test_gpu_tiled_equals_one_pass(ctx, tmp_path):
    r = _recipe(octaves=2.0)
    chans = ["color", "height", "normal", "id", "F1", "F4"]
    one = B.bake(r, tmp_path / "one.npy", size=(90, 50), channels=chans, progress=False)
    tiled = B.bake(r, tmp_path / "tiled.npy", size=(90, 50), channels=chans, tile=32,
                   progress=False)
    for a, b in zip(one, tiled):
        A, Bt = np.load(a), np.load(b)
        assert _same(A, Bt), a.name
        assert np.ptp(A.astype(np.float64)) > 0, a.name  # not a flat fill


def test_gpu_formats(ctx, tmp_path):
    r = _recipe(octaves=2.0)
    ref = np.load(B.bake(r, tmp_path / "ref.npy", size=(40, 24), progress=False)[0])
    want8 = np.floor(np.clip(ref.astype(np.float64), 0, 1) * 255 + 0.5).astype(np.uint8)
    from PIL import Image

    (p,) = B.bake(r, tmp_path / "a.png", size=(40, 24), progress=False)
    assert np.array_equal(np.asarray(Image.open(p)), want8)
    (p,) = B.bake(r, tmp_path / "a16.png", size=(40, 24), bit_depth=16, progress=False)
    assert np.array_equal(_read(p), np.floor(np.clip(ref.astype(np.float64), 0, 1) * 65535 + 0.5)
                          .astype(np.uint16))
    if cio_has("tifffile"):
        from cellgl.io.colour import srgb_to_linear

        (p,) = B.bake(r, tmp_path / "a.tif", size=(40, 24), tile=16, progress=False)
        assert _same(_read(p), srgb_to_linear(ref).astype(np.float32))    # float: scene-linear
        (p,) = B.bake(r, tmp_path / "s.tif", size=(40, 24), tile=16, colorspace="srgb", progress=False)
        assert _same(_read(p), ref)
    if cio_has("OpenEXR"):
        from cellgl.io.colour import srgb_to_linear

        (p,) = B.bake(r, tmp_path / "a.exr", size=(40, 24), bit_depth=16, colorspace="srgb", progress=False)
        got = _read(p)
        assert np.array_equal(np.stack([got[c] for c in "RGB"], -1), ref.astype(np.float16))
        (p,) = B.bake(r, tmp_path / "l.exr", size=(40, 24), bit_depth=16, progress=False)
        got = _read(p)
        assert np.array_equal(np.stack([got[c] for c in "RGB"], -1), srgb_to_linear(ref).astype(np.float16))


def cio_has(module):
    import importlib.util

    return importlib.util.find_spec(module) is not None


def test_gpu_volume(ctx, tmp_path):
    r = _recipe(dimension=3, octaves=1.0)
    (p,) = B.bake(r, tmp_path / "v.npy", size="24x16x6", channels="F1", tile=16, progress=False)
    v = np.load(p)
    assert v.shape == (6, 16, 24) and v.dtype == np.float32
    assert np.abs(np.diff(v, axis=0)).mean() > 0  # slices differ


def _seam_ratio(h):
    """Wrap-around difference over typical neighbour difference, worst of the two axes."""
    h = h.astype(np.float64)
    rx = np.abs(h[:, 0] - h[:, -1]).mean() / np.abs(np.diff(h, axis=1)).mean()
    ry = np.abs(h[0] - h[-1]).mean() / np.abs(np.diff(h, axis=0)).mean()
    return max(rx, ry)


def test_gpu_tileable_continues_across_both_edges(ctx, tmp_path):
    r = _recipe(octaves=3.0)
    seamless = B.bake(r, tmp_path / "t.npy", size=(96, 64), channels="height", tileable=True,
                      progress=False)[0]
    plain = B.bake(r, tmp_path / "p.npy", size=(96, 64), channels="height", tileable=False,
                   progress=False)[0]
    assert _seam_ratio(np.load(seamless)) < 1.5
    assert _seam_ratio(np.load(plain)) > 2.0


def test_gpu_preset_from_cli(ctx, tmp_path, capsys):
    from cellgl.recipes import list_presets

    names = [n for n, _ in list_presets()]
    if "flagstone" not in names:
        pytest.skip(f"no flagstone preset yet (presets: {names})")
    out = tmp_path / "flagstone.png"
    assert cli.main(["bake", "flagstone", "-o", str(out), "--size", "64x48", "-q"]) == 0
    from PIL import Image

    with Image.open(out) as im:
        assert im.size == (64, 48) and im.mode == "RGB"
        assert len(np.unique(np.asarray(im).reshape(-1, 3), axis=0)) > 16
    assert os.listdir(tmp_path) == ["flagstone.png"]


def _nearest(x, top):
    """round(clip(x, 0, 1) * top) of the exact product, in Python fractions (NaN 0, -inf 0,
    +inf top): what an 8/16-bit sample holds."""
    from fractions import Fraction

    out = []
    for v in np.asarray(x, np.float32).reshape(-1).tolist():
        if v != v:
            v = 0.0
        p = Fraction(min(max(v, 0.0), 1.0)) * top
        k = int(p)                                  # p >= 0: floor
        out.append(k + (p - k >= Fraction(1, 2)))
    return np.array(out).reshape(np.shape(x))


@pytest.mark.parametrize("bits", [8, 16])
def test_quantization_in_blocks_rounds_the_clipped_value_to_nearest(bits, monkeypatch):
    """8/16-bit files hold round(clip(v, 0, 1) * top) of the exact product, NaN as 0, +inf as
    top, -inf as 0, whatever the shape or the blocks the quantiser works in: every value just
    below a half rounds down (float32's floor(v * top + 0.5) sent some up) and the nearest
    float32 to each half."""
    from cellgl.io import spec

    top = (1 << bits) - 1
    rng = np.random.default_rng(bits)
    v = rng.normal(0.5, 0.45, (37, 29, 4)).astype(np.float32)
    k = np.arange(top + 1, dtype=np.float32)
    edges = np.concatenate([(k + 0.5) / top, np.nextafter((k + 0.5) / top, np.float32(0)),
                            np.nextafter((k + 0.5) / top, np.float32(1)),
                            [np.nan, np.inf, -np.inf, -0.0, 0.0, 1.0, -1e30, 1e30]]).astype(np.float32)
    v.reshape(-1)[:min(v.size, edges.size)] = edges[:v.size]
    dtype = np.uint8 if bits == 8 else np.uint16

    for block in (1, 7, 1 << 16):
        monkeypatch.setattr(spec, "_QUANTIZE_BLOCK", block)
        for x in (v, v[..., :3], v[:, :, 0], np.float64(0.3), v[:0]):
            got = spec.quantize(x, bits)
            assert got.dtype == dtype and got.shape == np.shape(x)
            assert np.array_equal(got, _nearest(x, top)), (block, np.shape(x))
    big = np.concatenate([edges, rng.normal(0.5, 0.5, 300).astype(np.float32)])   # every half
    assert np.array_equal(spec.quantize(big, bits), _nearest(big, top))
    # the flagstone-like case of issue 48: many values, none a sample above the nearest integer
    many = rng.random(200_000, dtype=np.float32)
    q = spec.quantize(many, bits).astype(np.float64)
    assert np.abs(q - many.astype(np.float64) * top).max() <= 0.5
