"""Volumes that tile in depth (issue 46 item 4): `--tileable` wraps a solid recipe along z."""
from __future__ import annotations

import numpy as np
import pytest

from cellgl import texture
from cellgl.recipes import load_recipe
from cellgl.texture.recipe import Recipe

CHS = ("height", "F1", "F2", "id")


def _solid(**kw):
    r = Recipe().replace(dimension=3, frequency=3.0, offset_z=0.25, fractal="sum", octaves=2.0, c_noise=0.3,
                         **kw)
    return r.tileable()[0]


@pytest.mark.parametrize("backend", ["gpu", "numpy"])
def test_tileable_volume_repeats_in_depth_bit_for_bit(ctx, backend):
    """Slice D (the volume moved one period, frequency cells, along z) is slice 0 again, and so
    on: the same bits on either path; without the wrap in z (the old behaviour) they differ."""
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


def test_tileable_volume_gpu_matches_numpy(ctx):
    """Within the texture test's bound (tests/test_texture.py::assert_gpu_matches_numpy), 4D too."""
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
