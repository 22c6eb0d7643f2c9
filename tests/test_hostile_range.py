"""Ranges and limits a hostile user pushed (issues 10, 33, 42, 48): far points, wide grids and
overflowing integers, values of the wrong type, Minkowski exponents near and below their floor,
huge density images, Blender's hash beyond 2^24 cells, renders past memory, booleans as sizes.
Used to give silently wrong answers, raw errors or minutes of work; each test failed before its
fix."""
from __future__ import annotations

import re
import struct
import warnings
import zlib

import numpy as np
import pytest

import cellgl
from cellgl.basis import gpu
from cellgl.gl import dispatch


# ---------------------------------------------------------------- 1. evaluate far out

@pytest.mark.parametrize("backend", ["numpy", "gpu"])
@pytest.mark.parametrize("x", [1e15, 1e20, 1e300, -1e300])
def test_evaluate_refuses_what_it_cannot_resolve(request, backend, x):
    """Far out both backends returned one F1 and ID for every point (and NumPy warned of an
    invalid cast); now they refuse, naming the point and the accepted range in uv."""
    if backend == "gpu":
        request.getfixturevalue("ctx")
    with warnings.catch_warnings():
        warnings.simplefilter("error")            # no NumPy cast warning on the way
        with pytest.raises(ValueError, match=r"points\[0, 0\] \(u\) = .* offset_x \+ u x frequency 8 "
                                             r"must lie within \+-2\^30 cells.*u in \(-134217728, 134217728\)"):
            cellgl.evaluate("f1", [[x, 0.5], [x + 0.01, 0.5]], outputs=("F1", "id"), backend=backend)


def test_evaluate_range_follows_frequency_aspect_and_offset():
    from cellgl.texture.presets import load_recipe
    from cellgl.texture.evaluation import point_range

    r = load_recipe("f1").replace(frequency=4.0, aspect=2.0, offset_x=1e8, dimension=3)
    box = point_range(r)
    assert box[0, 1] == (2 ** 30 - 1e8) / 4 and box[0, 0] == (-2 ** 30 - 1e8) / 4
    assert box[1, 1] == 2 ** 30 / 8 and box[2, 1] == (2 ** 30 - 0.5) / 4
    with pytest.raises(ValueError, match=r"points\[1, 1\] \(v\) = .*frequency 4 x aspect 2"):
        cellgl.evaluate(r, [[0.5, 0.5, 0.5], [0.5, 2 ** 27 + 1.0, 0.5]], backend="numpy")
    # inside the box (just): evaluated, no warning
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = cellgl.evaluate(r, [[box[0, 1] - 1.0, 0.5, 0.5]], ("F1",), backend="numpy")
    assert np.isfinite(out["F1"]).all()


def test_evaluate_2d_ignores_z_far_out():
    """A 2D recipe ignores z: any finite z is accepted (and changes nothing)."""
    a = cellgl.evaluate("f1", [[0.3, 0.4, 0.0]], ("F1", "id"), backend="numpy")
    b = cellgl.evaluate("f1", [[0.3, 0.4, 1e300]], ("F1", "id"), backend="numpy")
    assert a["id"][0] == b["id"][0] and a["F1"][0] == b["F1"][0]


# ---------------------------------------------------------------- 2. voronoi 1D: the 2D-4D range check

@pytest.mark.parametrize("x", [1e20, 1e300, -1e300])
def test_voronoi_1d_refuses_far_coordinates(x):
    """1D returned distance 4.9e20 at 1e20 and inf at 1e300, with overflow warnings."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match=r"w\[0, 0\] = .* times scale 5 is .* cells; accepted: within "
                                             r"\+-2\^30 cells, so \|w\| < 2.14748e\+08 at this scale"):
            cellgl.voronoi(None, dimensions=1, w=[x, 0.5])
        with pytest.raises(ValueError, match=r"points\[1, 0\] = .*accepted: within \+-2\^30 cells"):
            cellgl.voronoi([0.5, x], dimensions=1, backend="numpy")


@pytest.mark.filterwarnings("ignore:distribution 'blender' at")     # Blender's float hash far out
@pytest.mark.parametrize("dimensions", [1, 2, 3, 4])
def test_voronoi_range_is_the_same_in_every_dimension(dimensions):
    lim = 2.0 ** 30 / 5.0
    ok = np.full((1, dimensions), lim * 0.999)
    r = cellgl.voronoi(ok if dimensions > 1 else ok[:, 0], dimensions=dimensions, backend="numpy")
    assert np.isfinite(r.distance).all()
    with pytest.raises(ValueError, match=r"accepted: within \+-2\^30 cells"):
        cellgl.voronoi(ok * 1.002 if dimensions > 1 else ok[:, 0] * 1.002, dimensions=dimensions, backend="numpy")
    with pytest.raises(ValueError, match="must be finite"):
        cellgl.voronoi(np.full((1, dimensions), np.inf) if dimensions > 1 else [np.inf], dimensions=dimensions,
                       backend="numpy")


# ---------------------------------------------------------------- 3. voronoi --dimensions 1 --w X

def test_cli_voronoi_1d_honours_w(tmp_path):
    """--w changed nothing in 1D, where the help says W is the coordinate: now column c samples
    W = w + (c + 0.5) / width, so --w 0.5 shifts a 1D strip by half its width."""
    from cellgl.cli import main

    outs = {}
    for w in (0.0, 0.5, 3.0):
        out = tmp_path / f"w{w}.npy"
        assert main(["voronoi", "-o", str(out), "--size", "32x2", "--dimensions", "1", "--w", str(w),
                     "--backend", "numpy"]) == 0
        outs[w] = np.load(out)
    assert not np.array_equal(outs[0.0], outs[3.0])
    np.testing.assert_array_equal(outs[0.0][:, 16:], outs[0.5][:, :16])     # half a strip along
    direct = cellgl.voronoi(None, dimensions=1, w=3.0 + (np.arange(32) + 0.5) / 32)
    np.testing.assert_array_equal(outs[3.0][0], direct.distance)


# ---------------------------------------------------------------- 4. Minkowski p near its floor

def test_minkowski_floor_is_the_search_cap():
    """ln(d) / ln(R): a point anywhere in the sample's own cell is settled within R rings."""
    import math

    from cellgl.basis.reference import max_ring_default, minkowski_floor

    for d in (2, 3, 4):
        lo = minkowski_floor(d)
        assert d ** (1.0 / lo) <= max_ring_default(d) < d ** (1.0 / (lo - 0.001))
        assert lo == math.ceil(math.log(d) / math.log(max_ring_default(d)) * 1000) / 1000
    assert (minkowski_floor(3), minkowski_floor(4)) == (0.443, 0.713)


def test_recipe_refuses_minkowski_below_the_floor():
    """bake ran 32 s, then blamed the driver and advised fewer octaves; now the recipe is refused."""
    from cellgl.texture.presets import load_recipe
    from cellgl.texture.schema import RecipeError

    r = load_recipe("f1")
    with pytest.raises(RecipeError, match=r"--set basis.minkowski_p: 0.25 with basis.dimension 4 cannot be "
                                          r"exact.*accepted: \[0.713, 64\] in 4D \(\[0.25, 64\] in 2D, "
                                          r"\[0.443, 64\] in 3D\)"):
        r.set_from_strings(["metric=minkowski", "minkowski_p=0.25", "dimension=4"])
    with pytest.raises(RecipeError, match=r"0.44 with basis.dimension 3"):
        r.replace(metric="minkowski", minkowski_p=0.44, dimension=3)
    r.replace(metric="minkowski", minkowski_p=0.443, dimension=3)
    r.replace(metric="minkowski", minkowski_p=0.25, dimension=2)
    r.replace(metric="euclidean", minkowski_p=0.25, dimension=4)        # inactive: no metric minkowski


def test_minkowski_at_the_floor_is_exact():
    """At the floor every sample is settled: a point in every cell (Blender's, Poisson's minimum 1)."""
    rng = np.random.default_rng(4)
    for d, n in ((3, 3000), (4, 400)):
        pts = rng.uniform(-100, 100, (n, d))
        pts[: n // 2] = np.floor(pts[: n // 2]) + 1e-3        # near a corner: the worst place
        r = cellgl.voronoi(pts, dimensions=d, metric="minkowski", exponent=0.713 if d == 4 else 0.443,
                           feature="F2", backend="numpy")
        assert r.exact.all()


def test_voronoi_refuses_minkowski_below_the_floor(tmp_path, capsys):
    from cellgl.cli import main

    with pytest.raises(ValueError, match=r"exponent: 0.25 with dimensions 4 cannot be exact.*"
                                         r"accepted: \[0.713, 64\] in 4D.*allow_inexact=True"):
        cellgl.voronoi(np.zeros((4, 4)), dimensions=4, metric="minkowski", exponent=0.25)
    out = tmp_path / "a.png"
    assert main(["voronoi", "-o", str(out), "--metric", "minkowski", "--exponent", "0.25", "--dimensions", "4",
                 "--size", "64"]) == 2
    err = capsys.readouterr().err
    assert "--exponent: 0.25 with --dimensions 4 cannot be exact" in err and "--allow-inexact" in err
    assert not out.exists()
    with pytest.raises(ValueError, match=r"exponent: 0.3 with dimensions 3"):    # smooth F1 searches F1 too
        cellgl.voronoi(np.zeros((4, 3)), dimensions=3, metric="minkowski", exponent=0.3, feature="smooth_F1")
    # distance to edge and n-sphere radius are Euclidean whatever the metric (as the node)
    cellgl.voronoi(np.zeros((4, 3)), dimensions=3, metric="minkowski", exponent=0.25,
                   feature="distance_to_edge", backend="numpy")


def test_voronoi_cli_never_writes_inexact_without_asking(tmp_path, capsys, monkeypatch):
    """The CLI wrote the PNG with exit 0 and a warning that every sample was inexact."""
    from cellgl.cli import main

    out = tmp_path / "a.npy"
    args = ["voronoi", "-o", str(out), "--metric", "minkowski", "--exponent", "0.25", "--dimensions", "3",
            "--size", "6x4", "--backend", "numpy", "--scale", "50"]
    assert main(args + ["--allow-inexact"]) == 0           # asked for: written, with the warning
    assert "cellgl: warning: 14 of 24 samples could not be computed exactly" in capsys.readouterr().err
    assert out.exists()
    out.unlink()
    real = cellgl.voronoi

    def capped(*a, **k):          # a case above the floor the search still cannot settle
        r = real(*a, **k)
        r.exact[1] = False
        return r
    monkeypatch.setattr(cellgl, "voronoi", capped)
    assert main(args[:6] + ["0.5"] + args[7:]) == 2
    assert "1 of 24 samples could not be computed exactly" in capsys.readouterr().err
    assert not out.exists()


# ---------------------------------------------------------------- 9. render() against memory

def test_render_refuses_what_memory_cannot_hold(monkeypatch):
    """render(r, 100000, 100000) raised a raw MemoryError (149 GiB); now it is refused up front,
    saying how to tile."""
    from cellgl import recipes

    monkeypatch.setattr(recipes, "memory_bytes", lambda: 16 << 30)
    with pytest.raises(ValueError, match=r"render 100000x100000 of 'f1' \(color, backend gpu\) needs about "
                                         r"149 GiB \(about 16 bytes a pixel\), more than 50% of this machine's "
                                         r"16 GiB; render it in tiles .*cellgl.to_dask\(recipe, "
                                         r"\(100000, 100000\)\)") as e:
        cellgl.render("f1", 100000, 100000)
    assert "cellgl.bake.core.bake" not in str(e.value)          # past bake's 65536 a side
    with pytest.raises(ValueError, match=r"needs about 26.9 GiB \(about 32 bytes a pixel\).*cellgl.bake.core.bake\(recipe, 'big.tif', "
                                         r"size=\(30000, 30000\)\)"):
        cellgl.render("f1", 30000, 30000, channels=("F1", "F2", "F3", "F4"))
    with pytest.raises(ValueError, match=r"render 2048x1024x4 \(a tile of the 30000x30000 image\).*backend numpy"):
        cellgl.render("flagstone", 30000, 30000, tile_w=2048, tile_h=1024, depth=4, backend="numpy")
    with pytest.raises(ValueError, match=r"of 'pups-cow' \(color, backend gpu\) needs about"):
        cellgl.render("pups-cow", 65536, 65536)


def test_render_counts_the_gpu_paths_real_peak(monkeypatch):
    """Issue 48: the guard counted 4 bytes a pixel for height (12 for normal) with no working
    memory: render(r, 46341, 46341, channels=("height",)) passed it, then raised MemoryError for
    32 GiB (the peak is 20 bytes a pixel read back, plus the GL buffers). Now one error, before
    anything is allocated."""
    from cellgl import recipes
    from cellgl.texture import evaluation

    def never(*a, **k):
        raise AssertionError("render() went on past the memory guard")

    monkeypatch.setattr(evaluation, "render", never)
    monkeypatch.setattr(recipes, "memory_bytes", lambda: 64 << 30)
    for chans, gib, per_px in ((("height",), "40", 20), (("normal",), "56", 28),
                               (("height", "normal"), "64", 32)):
        with pytest.raises(ValueError, match=rf"render 46341x46341 of 'flagstone' \({', '.join(chans)}, backend "
                                             rf"gpu\) needs about {gib}\.\d GiB \(about {per_px} bytes a pixel\), "
                                             r"more than 50% of this machine's 64 GiB"):
            recipes.render("flagstone", 46341, 46341, channels=chans)
    monkeypatch.setattr(recipes, "memory_bytes", lambda: 12 << 30)
    with pytest.raises(ValueError, match=r"about 20 bytes a pixel"):
        cellgl.render("flagstone", 20000, 20000, channels=("height",))    # 8 GB: 1.6 GB of results


def test_the_gpu_peak_is_what_render_holds(ctx):
    """gpu_bytes()'s host bytes a pixel are what the GPU path allocates per pixel (tracemalloc's
    peak at two sizes, its fixed part taken out), for every kind of channel set."""
    import tracemalloc

    from cellgl import recipes

    def peak(w, h, chans):
        recipes.render("flagstone", w, h, channels=chans)          # compiled, its buffers made
        tracemalloc.start()
        try:
            recipes.render("flagstone", w, h, channels=chans)
            return tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()

    for chans in (("color",), ("height",), ("normal",), ("id",), ("F1", "F3"),
                  ("color", "height", "normal", "id", "F1", "F2", "F3", "F4")):
        # (both above the 1 MiB of fixed work the path also holds for a moment)
        slope = (peak(960, 480, chans) - peak(640, 480, chans)) / ((960 - 640) * 480)
        host, gl, buffers = recipes.gpu_bytes(chans)
        assert abs(slope - host) < 1.0, (chans, slope, host)
        assert gl >= 8 and buffers >= 2


def test_render_tiles_within_memory_are_rendered(monkeypatch, ctx):
    from cellgl import recipes

    # 4096 pixels of colour: 16 bytes each read back, 20 in the GL buffers (its block, the canary)
    monkeypatch.setattr(recipes, "memory_bytes", lambda: 4096 * 36 * 2)
    cellgl.render("f1", 100000, 100000, tile_w=64, tile_h=64)
    with pytest.raises(ValueError, match="needs about"):
        cellgl.render("f1", 100000, 100000, tile_w=64, tile_h=65)
    monkeypatch.setattr(recipes, "memory_bytes", lambda: 0)                      # unknown: not refused
    cellgl.render("f1", 8, 8)


# ---------------------------------------------------------------- 12, 13: the API's own messages

@pytest.mark.parametrize("budget", [-1, 0, (1 << 20) - 1, True, 2.5e8, (1 << 40) + 1])
def test_bake_memory_budget_is_checked_as_memory_is(tmp_path, budget):
    """bake(..., memory_budget=-1) was accepted and split a 16x16 bake into 16 tiles."""
    from cellgl.bake.core import bake

    with pytest.raises(ValueError, match=r"memory_budget .*: accepted a whole number of bytes in "
                                         r"1048576..1099511627776 \(1 MiB..1 TiB; the command line's --memory"):
        bake("f1", tmp_path / "a.png", size=16, memory_budget=budget)
    assert not list(tmp_path.iterdir())


def test_bake_sets_as_a_string_is_named(tmp_path):
    """bake(sets="seed=3") said "--set 's'" (the string read letter by letter)."""
    from cellgl.bake.core import bake

    with pytest.raises(ValueError, match=r"sets='seed=3': expected a list of NAME=VALUE strings, e.g. "
                                         r"sets=\['seed=3'\]"):
        bake("f1", tmp_path / "a.png", size=16, sets="seed=3")
    with pytest.raises(ValueError, match=r"sets=5: expected a list"):
        bake("f1", tmp_path / "a.png", size=16, sets=5)


def test_variant_of_a_preset_without_variants():
    """'cellgl presets flagstone:bogus' said "accepted: 0..-1"."""
    with pytest.raises(cellgl.RecipeError, match=r"preset 'flagstone' has no variant 'bogus'; it has no variants; "
                                                 r"accepted: 'flagstone' alone"):
        cellgl.load_recipe("flagstone:bogus")
    with pytest.raises(cellgl.RecipeError, match=r"no variant 'bogus'; accepted: 0..19 or worley-gallery:0, "):
        cellgl.load_recipe("worley-gallery:bogus")


def test_pups_volume_bake_names_pups(tmp_path):
    """'bake pups-cow --size 16x16x4' blamed pups.dimension, which the user never set."""
    from cellgl.bake.core import bake

    with pytest.raises(ValueError, match=r"volume bake \(16x16x4\): pups-cow is a PUPs recipe, which makes 2D "
                                         r"images only; accepted: --size WxH") as e:
        bake("pups-cow", tmp_path / "v.npy", size="16x16x4")
    assert "dimension" not in str(e.value).split("accepted")[0]


@pytest.mark.parametrize("kind", ['"bogus"', "null", "3"])
def test_unknown_recipe_kind_is_named(tmp_path, kind):
    """A recipe with "kind": "bogus" said "unknown key 'kind'"."""
    p = tmp_path / "k.json"
    p.write_text('{"kind": %s, "basis": {"seed": 3}}' % kind)
    with pytest.raises(cellgl.RecipeError, match=r"k.json: kind: unknown recipe kind %s; accepted: \"pups\"" % kind):
        cellgl.load_recipe(str(p))


@pytest.mark.parametrize("preset, name", [("f1", "frequency"), ("pups-cow", "radius")])
def test_set_beyond_float_range_is_not_inf(preset, name):
    """--set frequency=<5,000 nines> said "out of range: inf"."""
    text = "9" * 5000
    with pytest.raises(cellgl.RecipeError, match=r"--set %s=9{60}\.\.\. \(5000 characters\): out of range "
                                                 r"\(beyond any float, not just the parameter.s\)" % name):
        cellgl.load_recipe(preset).set_from_strings([f"{name}={text}"])
    with pytest.raises(cellgl.RecipeError, match=r"1e400: out of range"):
        cellgl.load_recipe(preset).set_from_strings([f"{name}=1e400"])


# ---------------------------------------------------------------- 10. the graph pattern's lines, vectorised

def _draw_graph_per_edge(p, w, h, *, pos, graph, scale=None, region=None):
    """cellgl.pups.presets.draw_graph as it was (one edge and one point at a time): the reference
    the vectorised drawing must equal bit for bit."""
    g = graph
    owner = np.repeat(np.arange(len(pos)), np.diff(g.offsets))
    a = pos[owner]
    b = a + g.axes
    sx, sy = (w / 2.0, h / 2.0) if scale is None else scale
    a = (a + 1) * [sx, sy] - 0.5
    b = (b + 1) * [sx, sy] - 0.5
    ox, oy, w, h = (0, 0, w, h) if region is None else region
    img = np.zeros((h, w))
    lw = float(p["line_width"])
    for (ax, ay), (bx, by) in zip(a, b):
        n = int(max(abs(bx - ax), abs(by - ay)) * 2) + 2
        t = np.linspace(0, 1, n)
        xs, ys = ax + (bx - ax) * t, ay + (by - ay) * t
        if xs.max() < ox - 3 or xs.min() > ox + w + 2 or ys.max() < oy - 3 or ys.min() > oy + h + 2:
            continue
        for dx in range(-2, 3):
            for dy in range(-2, 3):
                ix = np.round(xs).astype(int) + dx
                iy = np.round(ys).astype(int) + dy
                d = np.hypot(ix - xs, iy - ys)
                v = np.clip(lw / 2 + 0.5 - d, 0, 1)
                ok = (ix >= ox) & (ix < ox + w) & (iy >= oy) & (iy < oy + h)
                np.maximum.at(img, (iy[ok] - oy, ix[ok] - ox), v[ok] * 0.8)
    yy, xx = np.mgrid[oy:oy + h, ox:ox + w]
    for x, y in (pos + 1) * [sx, sy] - 0.5:
        x0, x1 = int(max(x - 4, ox)), int(min(x + 5, ox + w))
        y0, y1 = int(max(y - 4, oy)), int(min(y + 5, oy + h))
        if x1 <= x0 or y1 <= y0:
            continue
        sl = (slice(y0 - oy, y1 - oy), slice(x0 - ox, x1 - ox))
        d = np.hypot(xx[sl] - x, yy[sl] - y)
        img[sl] = np.maximum(img[sl], np.clip(3.5 - d, 0, 1))
    return img.astype(np.float32)


@pytest.mark.parametrize("sets, size", [(["radius=0.08", "line_width=0.5"], 48),
                                        pytest.param(["radius=0.06"], 64, marks=pytest.mark.slow),
                                        pytest.param(["radius=0.05", "line_width=4.5"], 80, marks=pytest.mark.slow)])
def test_graph_lines_vectorised_are_the_same_bits(monkeypatch, sets, size):
    """pups-graph at radius 0.005 took over 180 s in a per-edge Python loop; the vectorised drawing
    gives the same bits, for the whole image and for tiles (also small chunks)."""
    from cellgl.pups import presets

    seen = []
    monkeypatch.setattr(presets, "draw_graph", lambda p, w, h, **kw: seen.append((p, w, h, kw)) or
                        np.zeros((kw["region"][3], kw["region"][2]), np.float32))
    r = cellgl.load_recipe("pups-graph").set_from_strings(sets)
    cellgl.render(r, size, size, backend="numpy")
    cellgl.render(r, size, size, x0=size // 3, y0=5, tile_w=size // 2, tile_h=size // 4, backend="numpy")
    monkeypatch.undo()
    assert len(seen) == 2
    for p, w, h, kw in seen:
        want = _draw_graph_per_edge(p, w, h, **kw)
        assert want.any()
        for chunk in (presets._DRAW_CHUNK, 97):
            monkeypatch.setattr(presets, "_DRAW_CHUNK", chunk)
            got = presets.draw_graph(p, w, h, **kw)
            assert got.dtype == want.dtype and got.shape == want.shape
            assert np.array_equal(got.view(np.uint32), want.view(np.uint32))


# ---------------------------------------------------------------- issue 48, item 21: booleans

@pytest.mark.parametrize("recipe", ["flagstone", "pups-cow"])
@pytest.mark.parametrize("args, kw, name", [
    ((True, 4), {}, "width"), ((4, True), {}, "height"), ((8, 8), {"x0": True}, "x0"),
    ((8, 8), {"y0": np.True_}, "y0"), ((8, 8), {"tile_w": True}, "tile_w"),
    ((8, 8), {"tile_h": True}, "tile_h"), ((8, 8), {"x0": 1.0}, "x0"), ((8.0, 8), {}, "width"),
    ((8, 8), {"x0": 8}, "x0"), ((8, 8), {"x0": 4, "tile_w": 5}, "tile_w")])
def test_render_refuses_booleans_and_non_integers_as_sizes(recipe, args, kw, name):
    """Issue 48: render(r, True, 4) rendered a 1-pixel-wide image (True is 1 to Python). Every
    size and offset of every recipe kind's render is a whole number, not a boolean."""
    with pytest.raises(ValueError, match=rf"^{name} must be an integer in \[\d+, \d+\], got "):
        cellgl.render(recipe, *args, **kw)


def test_booleans_are_not_sizes_counts_or_versions_anywhere(tmp_path):
    """The same for a volume's depth, bake's size, slices and tile, measure_range's samples."""
    from cellgl import texture
    from cellgl.bake.core import bake
    from cellgl.io.spec import BakeError

    with pytest.raises(ValueError, match=r"^depth must be an integer in \[1, 4096\], got True"):
        cellgl.render(cellgl.load_recipe("flagstone").replace(dimension=3), 8, 8, depth=True)
    for kw, words in (({"size": True}, "width True is out of range"),
                      ({"size": (8, np.True_)}, "height True is out of range"),
                      ({"size": 8, "depth_slices": True}, "depth True (volume slices) is out of range"),
                      ({"size": 16, "tile": True}, "--tile True: accepted multiples of 16")):
        with pytest.raises(BakeError, match=re.escape(words)):
            bake("flagstone", tmp_path / "a.npy", progress=False, **kw)
    with pytest.raises(ValueError, match=r"samples must be an integer in \[2, 16777216\], got True"):
        texture.measure_range("veins", samples=True)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("change, words", [
    ({"cellgl_recipe": True}, "cellgl_recipe: unsupported recipe version True; accepted: the whole number 1"),
    ({"cellgl_recipe": 1.0}, "cellgl_recipe: unsupported recipe version 1.0"),
    ({"cellgl_recipe": 2}, "cellgl_recipe: unsupported recipe version 2"),
    ({"name": ""}, "name: empty name ''; accepted: one line of 1..64 printable characters, not blank"),
    ({"name": "   "}, "name: empty name '   '")])
@pytest.mark.parametrize("preset", ["flagstone", "pups-cow"])
def test_recipe_versions_are_whole_numbers_and_names_are_not_empty(tmp_path, preset, change, words):
    """Issue 48: a recipe file with "cellgl_recipe": true (or "name": "") was accepted."""
    import json

    from cellgl.texture.schema import RecipeError

    d = cellgl.load_recipe(preset).to_dict()
    d.update(change)
    f = tmp_path / "r.json"
    f.write_text(json.dumps(d))
    with pytest.raises(RecipeError) as e:
        cellgl.load_recipe(str(f))
    assert words in str(e.value), str(e.value)
    if "name" in change:
        with pytest.raises(RecipeError, match="empty name"):
            cellgl.load_recipe(preset).replace(name=change["name"])
    d.update(cellgl_recipe=1, name="ok")
    f.write_text(json.dumps(d))
    assert cellgl.load_recipe(str(f)).name == "ok"


# ---------------------------------------------------------------- issue 48, item 18: the loop-cut advice

def test_a_sparse_recipe_the_search_cannot_prove_is_refused_when_checked():
    """Issue 48: --set metric=minkowski --set minkowski_p=0.5 --set density=0.05 --set min_points=0
    passed the Minkowski floor (which counts on a point in every cell), then was refused at bake
    time with advice that did not fit. Its own cell is empty for 95% of the samples, and a point a
    ring away can lie 18 cells off, beyond the 12 rings searched: refused when checked, saying
    why and what would do."""
    import math

    from cellgl.basis.reference import SPARSE_RISK, sparse_message
    from cellgl.texture.schema import RecipeError

    base = cellgl.load_recipe("flagstone")
    with pytest.raises(RecipeError) as e:
        base.set_from_strings(["metric=minkowski", "minkowski_p=0.5", "density=0.05", "min_points=0"])
    msg = str(e.value)
    for w in ("basis.min_points: 0 with basis.density 0.05, metric minkowski (minkowski_p 0.5) in 3D cannot "
              "be exact", "about 0.95 of the samples", "accepted: basis.min_points 1 (a point in every cell), "
              "or basis.density 13.816 or more, or basis.minkowski_p 1 or more at this density"):
        assert w in msg, msg
    # each way out it names is accepted; a point in every cell, or a denser or Euclidean basis, too
    for ok in (dict(min_points=1), dict(minkowski_p=1.0), dict(density=13.816),
               dict(metric="euclidean")):
        base.replace(**{**dict(metric="minkowski", minkowski_p=0.5, density=0.05, min_points=0), **ok})
    # the rule: refused exactly where exp(-density (2k + 1)^dim) passes SPARSE_RISK
    for dim, metric, p, density, refused in ((2, "euclidean", 3.0, 0.05, False), (4, "euclidean", 3.0, 0.05, False),
                                             (3, "manhattan", 3.0, 0.05, False), (4, "manhattan", 3.0, 3.0, True),
                                             (4, "chebyshev", 3.0, 0.05, False), (2, "minkowski", 0.5, 0.115, False),
                                             (2, "minkowski", 0.5, 0.1, True), (3, "minkowski", 0.75, 0.05, True)):
        v = dict(distribution="poisson", min_points=0, density_map="none", dimension=dim, metric=metric,
                 minkowski_p=p, density=density)
        assert (sparse_message(v) is not None) == refused, v
    assert math.exp(-0.115 * 11 ** 2) <= SPARSE_RISK < math.exp(-0.114 * 11 ** 2)
    assert sparse_message(dict(v, min_points=1)) is None and sparse_message(dict(v, distribution="jitter")) is None


def test_the_loop_cut_advice_names_what_the_recipe_has():
    """The driver-cut error advised "fewer octaves, less supersampling or a smaller smoothness" for
    a recipe that has none of those: the advice lists only what applies."""
    from types import SimpleNamespace

    from cellgl.texture.dispatch import lighter

    minkowski = cellgl.load_recipe("flagstone").replace(metric="minkowski", minkowski_p=0.5, density=0.05)
    ways = "; ".join(lighter(minkowski))
    assert "a larger basis.minkowski_p (it has 0.5: a point k cells away along every axis lies 3^(1/0.5) k = 9 k" in ways
    assert all(w not in ways for w in ("octaves", "supersampling", "smoothness", "min_points")), ways
    sparse = SimpleNamespace(values=dict(cellgl.load_recipe("f1").values, min_points=0, density=0.3))
    assert "basis.min_points 1 or more, or a larger basis.density (it has min_points 0 and density 0.3" in \
        "; ".join(lighter(sparse))
    assert lighter(cellgl.load_recipe("flagstone")) == []
    heavy = cellgl.load_recipe("f1").replace(smoothness=0.25, c_smooth=1.0, octaves=8.0, fractal="sum",
                                             dimension=4)
    ways = "; ".join(lighter(heavy, 4))
    for w in ("fewer fractal.octaves (it has 8)", "less supersampling (it has 16 samples a pixel)",
              "a smaller combination.smoothness (it has 0.25)", "a smaller basis.dimension"):
        assert w in ways, ways
    assert "minkowski" not in ways and "min_points" not in ways
    # inactive settings are no lever: octaves without a fractal, min_points with jitter
    assert lighter(cellgl.load_recipe("f1").replace(octaves=8.0, fractal="none", distribution="jitter",
                                                    min_points=0)) == []


@pytest.mark.parametrize("preset", ["flagstone", "pups-cow"])
@pytest.mark.parametrize("key, value", [("name", True), ("name", 5), ("doc", None), ("name", "")])
def test_names_and_docs_are_strings_in_python_too(preset, key, value):
    """Recipe(name=True) / .replace(name=5) were made strings ('True', '5') without a word."""
    from cellgl.texture.schema import RecipeError

    with pytest.raises(RecipeError, match=rf"^{key}: "):
        cellgl.load_recipe(preset).replace(**{key: value})


# --------------------------------------------------------------------------------------------
# 4. distribution="blender" beyond 2^24 cells: Blender's hash repeats; a warning, and jitter
# --------------------------------------------------------------------------------------------


def _image_colours(x0: float, distribution: str) -> int:
    import warnings

    import numpy as np

    import cellgl

    u = (np.arange(64) + 0.5) / 64 * 8.0
    pts = np.stack(np.meshgrid(x0 + u, u), -1).reshape(-1, 2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        r = cellgl.voronoi(pts, dimensions=2, distribution=distribution, backend="numpy")
    return len(np.unique(r.color, axis=0))


def test_blender_points_repeat_far_out_and_warn(ctx):
    import numpy as np

    import cellgl
    from cellgl.basis.population import BLENDER_HASH_LIMIT

    near, far = _image_colours(0.0, "blender"), _image_colours(1e7, "blender")
    assert near > 3 * far                    # the repeat is real (and Blender's): the warning's reason
    assert _image_colours(1e7, "jitter") > near / 2              # the exact alternative does not
    inside = np.array([[BLENDER_HASH_LIMIT / 5 - 1.0, 0.5, 0.5]])   # Scale 5: just inside
    with __import__("warnings").catch_warnings():
        __import__("warnings").simplefilter("error", RuntimeWarning)
        cellgl.voronoi(inside, backend="numpy")
        cellgl.voronoi(inside * 50, distribution="jitter", backend="numpy")
    for pts, dims in ((inside * 2, 3), (np.array([1e7]), 1)):
        with pytest.warns(RuntimeWarning, match=r"beyond 2\^24 .* distribution 'jitter'"):
            cellgl.voronoi(pts, dimensions=dims, backend="numpy")
    with pytest.warns(RuntimeWarning, match=r"beyond 2\^24"):
        cellgl.cellular(np.array([[2.0 ** 25, 0.5]]), n=1, distribution="blender", backend="numpy")
    with pytest.warns(RuntimeWarning, match=r"beyond 2\^24"):
        cellgl.cellular_grid((2, 2), origin=(2.0 ** 25, 0.0), n=1, distribution="blender",
                             backend="numpy")


def _brute(pts, n=1, **kw):
    return cellgl.cellular(pts, n, backend="numpy", outputs=("F", "id"), **kw)


# ---------------------------------------------------------------- 1. rows past 65535 work groups

def test_grid_slabs_stay_within_the_group_limit(monkeypatch):
    """Every dispatch of a grid wider than one dispatch covers its samples once, contiguously."""
    monkeypatch.setattr(dispatch, "MAX_GROUPS", 3)
    step = 3 * dispatch.LOCAL_SIZE
    X, Y = step * 2 + 17, 3
    seen = np.zeros(X * Y, int)
    for (x0, y0, _z0, _w, cols, rows), start, groups in dispatch.grid_slabs(X, Y, 1, 1, step):
        assert max(groups) <= 3 and cols <= step
        assert start == (y0 * X + x0)
        seen[start:start + cols * rows * groups[2]] += 1
    assert (seen == 1).all()


def test_narrow_group_limit_grid_equals_reference(ctx, monkeypatch):
    """With the group limit forced small, a grid split into column runs equals the reference."""
    monkeypatch.setattr(dispatch, "MAX_GROUPS", 2)       # 128 samples per dispatch
    r = cellgl.cellular_grid((3, 300), origin=(0.5, 2.0), spacing=(0.05, 0.3), n=2, outputs=("F", "id"))
    ref = cellgl.cellular_grid((3, 300), origin=(0.5, 2.0), spacing=(0.05, 0.3), n=2, outputs=("F", "id"),
                               backend="numpy")
    np.testing.assert_allclose(r.F, ref.F, atol=2e-6)
    assert (r.id == ref.id).mean() > 0.999
    assert r.exact.all()


def test_row_wider_than_4194240_samples(ctx):
    """A real row past LOCAL_SIZE * 65535 samples: written everywhere, equal to the reference."""
    W = 64 * 65535 + 100
    r = cellgl.cellular_grid((1, W), spacing=(0.001, 1.0), n=1, outputs=("F", "id"))
    assert (r.F > 0).all(), "unwritten (zero) distances"
    idx = np.array([0, W // 2, W - 101, W - 100, W - 1])
    ref = _brute(np.stack([idx * 0.001, np.zeros(len(idx))], axis=1))
    np.testing.assert_allclose(r.F[0, idx, 0], ref.F[:, 0], atol=2e-6)
    assert (r.id[0, idx, 0] == ref.id[:, 0]).all()


# ---------------------------------------------------------------- 3. grid positions far from the origin
# (tests/test_core.py, test_far_from_origin_is_as_accurate[grid-1e4])


def test_feature_points_uint_cells_work():
    a = cellgl.feature_points(np.array([[3, 4], [5, 6]], dtype=np.uint64))
    b = cellgl.feature_points(np.array([[3, 4], [5, 6]], dtype=np.int32))
    assert np.array_equal(a.positions, b.positions) and np.array_equal(a.ids, b.ids)


# ---------------------------------------------------------------- 11. wrong types get ValueError
# (in tests/test_core.py's table of bad input, test_bad_input_is_a_clear_error)


# ---------------------------------------------------------------- 13. Minkowski p < 1: the true bound

#: the smallest minkowski_p (per dimension) at which no sample reaches the search cap, with a point
#: in every cell, density >= 1 and any n <= 8 (README "Exactness"); measured over 40,000 random
#: samples per distribution (poisson min_points=1, jitter 0.25..1, worley1996)
MINKOWSKI_EXACT_FROM = {2: 0.4, 3: 0.6, 4: 0.85}


@pytest.mark.parametrize("dim", [2, 3, 4])
@pytest.mark.parametrize("dist", [{}, {"distribution": "jitter", "jitter": 0.5}])
def test_minkowski_exact_bound(ctx, dim, dist):
    """At the documented bound every sample is exact. (The bound first documented, 0.8 in 4D,
    held for the Poisson default but not for jitter 0.5: 5 of these 20,000 samples were capped.)"""
    rng = np.random.default_rng(12)
    pts = rng.uniform(-1e4, 1e4, (20000 if dim == 4 and dist else 3000, dim))
    r = cellgl.cellular(pts, 8, metric="minkowski", minkowski_p=MINKOWSKI_EXACT_FROM[dim], density=1.0,
                        outputs=("F",), **dist)
    assert r.exact.all(), f"{(~r.exact).sum()} capped samples at the documented bound"


@pytest.mark.parametrize("dim", [3, 4])
def test_minkowski_below_the_bound_is_flagged_not_wrong(ctx, dim):
    """Below the bound the cap is reached: the flag says so for most samples (it is not silent)."""
    rng = np.random.default_rng(7)
    pts = rng.uniform(0.0, 100.0, (500, dim))
    with pytest.warns(RuntimeWarning, match="minkowski_p below 1"):
        r = cellgl.cellular(pts, 4, metric="minkowski", minkowski_p=0.25, density=1.0, outputs=("F",))
    assert (~r.exact).mean() > 0.9


# ---------------------------------------------------------------- 14. density image size from the header

def _png_header_only(path, w, h):
    """A PNG whose header says w x h (no pixel data): opening it costs nothing, decoding fails."""
    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0))
                     + chunk(b"IEND", b""))


def _density_image(path):
    from cellgl.texture import recipe as R

    return R.density_pixels(path)


def _pups_reference_image(path):
    from cellgl.pups.presets import reference_image

    return reference_image(path)


@pytest.mark.parametrize("load,w,h,match", [
    (_density_image, 10000, 10000, r"density image .* is 10000x10000; accepted: sides 1..4096"),
    (_pups_reference_image, 10000, 300, r"reference image .* is 10000x300; accepted: sides 1..4096"),
])
def test_huge_image_is_refused_from_its_header(tmp_path, monkeypatch, load, w, h, match):
    """The size comes from the header: a 10000^2 image was decoded whole (1.1 GB) first."""
    from PIL import Image

    path = tmp_path / "huge.png"
    _png_header_only(path, w, h)

    def no_decode(self, *a, **k):
        raise AssertionError("the image was decoded")

    monkeypatch.setattr(Image.Image, "load", no_decode)
    with pytest.raises(ValueError, match=match):       # RecipeError is a ValueError
        load(str(path))


# ---------------------------------------------------------------- 2. evaluate far from [0, 1] uv
# (tests/test_texture_precision.py, test_evaluate_far_away)


# ---------------------------------------------------------------- 1. every basis dispatch within the limit

def test_cell_counts_dispatches_stay_within_the_group_limit(ctx, monkeypatch):
    """gpu.cell_counts (the density tests' GPU twin) splits its cells as the search does: each
    dispatch within the group limit, the counts equal to one unsplit call."""
    import moderngl

    from cellgl.basis import core, reference
    from cellgl.gl.path import gpu_path

    if gpu_path(ctx) != "compute":
        pytest.skip("counts compute dispatches; the fragment path draws (tests/test_fragment_path.py)")
    p = core.make_params(2, density=2.0)
    cells = np.zeros((300, 4), np.int64)
    cells[:, 0] = np.arange(300) - 150
    cells[:, 1] = np.arange(300) * 7 % 31
    whole = gpu.cell_counts(cells, p)
    groups = []
    real_run = moderngl.ComputeShader.run
    monkeypatch.setattr(moderngl.ComputeShader, "run",
                        lambda self, group_x=1, *a, **k: (groups.append(group_x), real_run(self, group_x, *a, **k)))
    monkeypatch.setattr(dispatch, "MAX_GROUPS", 2)
    split = gpu.cell_counts(cells, p)
    assert len(groups) == 3 and max(groups) <= 2
    np.testing.assert_array_equal(split[0], whole[0])
    _, ref = reference.point_count(reference.cell_seed(cells, p), p, cells)
    np.testing.assert_array_equal(split[0], ref)


# ---------------------------------------------------------------- 11. more values of the wrong type

def test_masked_entries_are_refused():
    """A masked entry has no value: its hidden data was used as a coordinate."""
    pts = np.ma.masked_array([[0.5, 0.5], [9.0, 0.25]], mask=[[0, 0], [1, 0]])
    with pytest.raises(ValueError, match=r"points is a masked array with masked entries \(first at \[1, 0\]\)"):
        cellgl.cellular(pts, 1, backend="numpy")
    with pytest.raises(ValueError, match="points is a masked array"):
        cellgl.evaluate("f1", pts, backend="numpy")
    with pytest.raises(ValueError, match="cells is a masked array"):
        cellgl.feature_points(np.ma.masked_array([[1, 2]], mask=[[1, 0]]))
    # nothing masked: the values are used
    ok = cellgl.cellular(np.ma.masked_array([[0.5, 0.5]], mask=False), 1, backend="numpy")
    assert ok.F[0, 0] == cellgl.cellular([[0.5, 0.5]], 1, backend="numpy").F[0, 0]


# ---------------------------------------------------------------- 7. sample positions as texels

@pytest.mark.parametrize("dim", [2, 3, 4])
def test_positions_across_texture_rows_equal_the_reference(ctx, dim):
    """The float64 positions reach the shader as the words of a texture 4096 texels wide (d / 2
    texels per sample, 3D a texel and a half): an odd count crossing rows, far from the origin
    (float32 positions would be cells off there), Fortran-ordered and float32 input all equal the
    NumPy reference."""
    rng = np.random.default_rng(dim)
    N = 2 * 4096 + 3 if dim != 3 else 4096 + 1367        # 3D: 1.5 N texels, past a row
    pts = 1e6 + 0.5 + rng.uniform(-40.0, 40.0, (N, dim))
    pts[::2] *= -1.0
    for given in (pts, np.asfortranarray(pts), pts.astype(np.float32)):
        r = cellgl.cellular(given, 2, distribution="jitter", outputs=("F", "id"))
        ref = _brute(np.asarray(given, np.float64), n=2, distribution="jitter")
        assert (r.id == ref.id).mean() > 0.999
        np.testing.assert_allclose(r.F, ref.F, atol=3e-6)
        assert r.exact.all()


def test_points_in_small_chunks_equal_one_dispatch(ctx, monkeypatch):
    """Chunks of one call share the sample texture (each smaller than the last or not): split into
    chunks of 128 samples, the bits equal one dispatch's."""
    pts = np.random.default_rng(5).uniform(-9.0, 9.0, (1001, 3))
    whole = cellgl.cellular(pts, 3, outputs=("F", "delta", "id"))
    monkeypatch.setattr(dispatch, "MAX_GROUPS", 2)             # 128 samples per dispatch
    parts = cellgl.cellular(pts, 3, outputs=("F", "delta", "id"))
    for name in ("F", "delta", "id"):
        assert getattr(parts, name).tobytes() == getattr(whole, name).tobytes(), name


@pytest.mark.parametrize("dim", [2, 3, 4])
@pytest.mark.parametrize("bad,match", [(np.nan, r"finite.*nan"), (-np.inf, r"finite.*-inf"),
                                       (2.0 ** 30, r"within \+-2\^30 cells; got 1073741824\.0"),
                                       (-1e300, r"within \+-2\^30 cells; got -1e\+300")])
def test_bad_coordinate_anywhere_is_named(ctx, dim, bad, match):
    """The shader checks the coordinates (no pass over the points before the dispatch): a bad one
    in the last sample, in a later row of the sample texture or beside another still raises,
    naming the first bad entry; the largest coordinate accepted passes."""
    pts = np.random.default_rng(1).uniform(-5.0, 5.0, (9000, dim))
    for rows in ([8999], [6000, 8000], [4096 * 2 // dim + 1]):
        bent = pts.copy()
        for k, row in enumerate(rows):
            bent[row, (row + k) % dim] = bad
        col = rows[0] % dim
        with pytest.raises(ValueError, match=match) as err:
            cellgl.cellular(bent, 2, distribution="jitter", outputs=("F",))
        assert f"[{rows[0]}, {col}]" in str(err.value)
    edge = pts.copy()
    edge[-1, -1] = np.nextafter(2.0 ** 30, 0.0)
    r = cellgl.cellular(edge, 2, distribution="jitter", outputs=("F",))
    assert r.exact.all()


@pytest.mark.parametrize("bad,match", [(np.nan, r"finite.*nan"), (np.inf, r"finite.*inf"),
                                       (2.0 ** 30, r"within \+-2\^30 cells; got 1073741824\.0"),
                                       (-1e300, r"within \+-2\^30 cells; got -1e\+300")])
def test_bad_coordinate_is_caught_before_the_upload(monkeypatch, bad, match):
    """The check runs on the CPU before anything reaches the GPU (issue 39): a driver compiling with
    fast-math semantics need not honour the shader's comparisons with NaN or its range guard. A
    stand-in GPU search that flags nothing (such a driver) must never be reached."""
    def never(*a, **k):
        raise AssertionError("bad coordinates reached the GPU search")

    monkeypatch.setattr(gpu, "search_points", never)
    pts = np.random.default_rng(2).uniform(-5.0, 5.0, (300, 3))
    pts[123, 1] = bad
    with pytest.raises(ValueError, match=match) as err:
        cellgl.cellular(pts, 2, distribution="jitter", outputs=("F",))
    assert "[123, 1]" in str(err.value)
    far = np.random.default_rng(3).uniform(-5.0, 5.0, (300, 3))     # worley1996 scales by 0.398150: 2^30 cells lie further out
    far[7, 2] = np.nextafter(2.0 ** 30 / 0.398150, np.inf) * 1.000001
    with pytest.raises(ValueError, match=r"within \+-2\^30 cells; got .* at \[7, 2\]"):
        cellgl.cellular(far, 2, distribution="worley1996", outputs=("F",))
