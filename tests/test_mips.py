"""Mip chains (cellgl.bake.mips, ``bake(..., mips=True)``, ``--mips``): every level rendered from the
recipe at its own size, level 0 the bake without mips, tileable seamless at every level."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

import cellgl
from cellgl.bake import core as B
from cellgl.bake import mips as M
from cellgl.io.spec import encoding_of
from cellgl.recipes import load_recipe


def test_mip_sizes_round_up_and_down_to_one_by_one():
    assert M.mip_sizes(1, 1) == [(1, 1)]
    assert M.mip_sizes(8, 2) == [(8, 2), (4, 1), (2, 1), (1, 1)]
    assert M.mip_sizes(37, 20) == [(37, 20), (19, 10), (10, 5), (5, 3), (3, 2), (2, 1), (1, 1)]
    # rounding down: Direct3D / Vulkan's max(1, floor(W / 2^k)), the chain DDS and KTX2 hold
    assert M.mip_sizes(37, 20, rounding="down") == [(37, 20), (18, 10), (9, 5), (4, 2), (2, 1), (1, 1)]
    assert M.mip_sizes(256, 256) == M.mip_sizes(256, 256, rounding="down")
    assert M.mip_sizes(4, 4, 8) == [(4, 4, 8), (2, 2, 4), (1, 1, 2), (1, 1, 1)]
    for w, h in [(1, 1), (2, 3), (37, 20), (1000, 1), (4096, 4096), (65536, 3)]:
        up = M.mip_sizes(w, h)
        assert up[-1] == (1, 1)
        for k, (a, b) in enumerate(up):
            assert (a, b) == (-(-w // 2 ** k), -(-h // 2 ** k))
        down = M.mip_sizes(w, h, rounding="down")
        assert down[-1] == (1, 1) and len(down) == max(w, h).bit_length()
    with pytest.raises(ValueError, match="rounding 'near'"):
        M.mip_sizes(4, 4, rounding="near")
    with pytest.raises(ValueError, match=r"mip level 3: accepted 0\.\.2"):
        M.level_size(4, 4, 3)


def test_level_paths_are_numbered_beside_level_0(tmp_path):
    assert M.level_path(tmp_path / "a.png", 0) == tmp_path / "a.png"
    assert M.level_path(tmp_path / "a.png", 3) == tmp_path / "a_mip3.png"


def _png(path) -> np.ndarray:
    with Image.open(path) as im:
        return np.asarray(im)


def test_each_level_is_the_render_at_its_size_bit_for_bit(ctx):
    recipe = load_recipe("flagstone")
    w, h = 37, 20
    for k, size, res in M.render_chain(recipe, w, h, channels=("color", "height"), samples=4, tile=16):
        ref = cellgl.render(recipe, size[0], size[1], channels=("color", "height"), samples=4)
        assert res["color"].shape == (size[1], size[0], 4)
        for c in ("color", "height"):
            assert np.array_equal(res[c], ref[c]), (k, c)


def test_bake_mips_writes_numbered_levels_level0_same_bits(ctx, tmp_path):
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    plain = B.bake("flagstone", tmp_path / "a" / "f.png", size=(37, 20), channels=("color", "height"),
                   progress=False, samples=4)
    chain = B.bake("flagstone", tmp_path / "b" / "f.png", size=(37, 20), channels=("color", "height"),
                   progress=False, samples=4, mips=True, tile=16)
    sizes = M.mip_sizes(37, 20)
    assert sorted(p.name for p in chain) == sorted(
        [f"f_{c}.png" for c in ("color", "height")]
        + [f"f_{c}_mip{k}.png" for c in ("color", "height") for k in range(1, len(sizes))])
    for p in plain:
        assert _png(p).tobytes() == _png(tmp_path / "b" / p.name).tobytes()
    recipe = load_recipe("flagstone")
    for k, (lw, lh) in enumerate(sizes):
        ref = cellgl.render(recipe, lw, lh, channels=("color", "height"), samples=4)
        for c in ("color", "height"):
            got = _png(M.level_path(tmp_path / "b" / f"f_{c}.png", k))
            want = encoding_of(c, ".png", 8).encode(ref[c])
            assert np.array_equal(got, want), (k, c)


def _seam_ratio(img: np.ndarray) -> float:
    """The mean jump across the wrap-around edges over the mean jump between neighbours inside."""
    img = img.astype(np.float64)
    inner = (np.abs(np.diff(img, axis=1)).mean() + np.abs(np.diff(img, axis=0)).mean()) / 2
    wrap = (np.abs(img[:, 0] - img[:, -1]).mean() + np.abs(img[0, :] - img[-1, :]).mean()) / 2
    return wrap / inner


def test_tileable_chain_is_seamless_at_every_level(ctx):
    t, _ = load_recipe("sea").replace(frequency=3.5).tileable()
    ratios = []
    for k, size, res in M.render_chain(t, 192, 192, channels=("height",)):
        img = res["height"]
        if img.std() < 1e-6:
            # a level whose texels span more than every octave: the band limit leaves the mean,
            # constant, as a prefilter should (never a seam)
            assert k >= 4, (k, size)
            continue
        ratios.append(_seam_ratio(img))
    assert len(ratios) == 4          # 192, 96, 48, 24 vary
    assert max(ratios) < 1.5, ratios
    # the test can fail: the same recipe not tileable has a seam
    plain = load_recipe("sea").replace(frequency=3.5)
    res = M.render_level(plain, 192, 192, 1, channels=("height",))
    assert _seam_ratio(res["height"]) > 2.0


def test_cli_mips_and_its_refusals(tmp_path):
    base = [sys.executable, "-m", "cellgl", "bake", "f1", "--mips", "-q"]
    p = subprocess.run(base + ["-o", str(tmp_path / "x.webp"), "--frames", "2"], capture_output=True, text=True)
    assert p.returncode != 0 and "--mips" in p.stderr and "--frames" in p.stderr
    assert not list(tmp_path.iterdir())
    with pytest.raises(B.BakeError, match="mips='yes'"):
        B.bake("f1", tmp_path / "y.png", size=4, mips="yes", progress=False)
    assert not list(tmp_path.iterdir())


def test_cli_mips_png(ctx, tmp_path):
    out = tmp_path / "f.png"
    p = subprocess.run([sys.executable, "-m", "cellgl", "bake", "f1", "-o", str(out), "--size", "8x3",
                        "--mips", "-q"], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    assert sorted(f.name for f in tmp_path.iterdir()) == ["f.png", "f_mip1.png", "f_mip2.png", "f_mip3.png"]
    assert [Image.open(tmp_path / n).size for n in ("f.png", "f_mip1.png", "f_mip2.png", "f_mip3.png")] \
        == [(8, 3), (4, 2), (2, 1), (1, 1)]


def test_each_level_is_the_same_texture_as_its_parent(ctx):
    """A level is a prefilter of the one above, not another picture: its texels follow the 2 x 2
    averages of its parent's (the band limit fades whole octaves, so coarse levels depart from a
    box filter: measured correlation 0.994 at 128^2, 0.95 at 64^2, 0.77 at 32^2; checked down to 64)."""
    recipe = load_recipe("flagstone")
    prev = None
    for k, size, res in M.render_chain(recipe, 256, 256, channels=("height",)):
        img = res["height"].astype(np.float64)
        if prev is not None and size[0] >= 64:
            box = prev.reshape(size[1], 2, size[0], 2).mean(axis=(1, 3))
            assert np.corrcoef(box.ravel(), img.ravel())[0, 1] > 0.93, k
            shifted = np.corrcoef(box[:, 2:].ravel(), img[:, :-2].ravel())[0, 1]
            assert shifted < 0.5, k          # the test can fail: a shifted picture does not pass
        prev = img
