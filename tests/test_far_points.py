"""``cellgl.evaluate`` at points spread over many whole uv cells: one pass, the bits of a pass per cell.

Each point goes to the GPU as its fraction and the index of its whole part's group; each group's
origins are split in float64 as for a pan (cellgl.texture.shader.group_records, shaders/lib/
texture_groups.glsl). Before, evaluate ran a pass and a read-back per whole part (20,000 points
over 8,630 cells: 640x the time of one cell, benchmarks/bench_evaluate.py).
"""
from __future__ import annotations

import numpy as np
import pytest

import cellgl
from cellgl.texture import dispatch, shader
from cellgl.texture.recipe import Recipe
from cellgl.recipes import load_recipe
from test_texture import RECIPES as TEXTURE_RECIPES     # tests/ is on sys.path under pytest

RECIPES = {
    "plain": TEXTURE_RECIPES["plain"],
    "everything": TEXTURE_RECIPES["everything"],       # 3D, tileable, 3.5 octaves, noise
    "jitter_4d": TEXTURE_RECIPES["jitter_4d"],
    "qin_noise_warp": Recipe().replace(fractal="qin", octaves=5.0, lacunarity=1.9, c_noise=0.5,
                                       noise_frequency=1.7, noise_color=0.3, warp_amount=0.3,
                                       offset_x=1e5 + 0.3),
    "crumple": load_recipe("crumple"),
}
CHS = ("color", "height", "normal", "id", "F1", "F2", "grad", "value")


def _paths(ctx):
    from cellgl.gl.path import has_compute

    return ("compute", "fragment") if has_compute(ctx) else ("fragment",)


@pytest.mark.parametrize("name", RECIPES)
def test_spread_points_run_in_one_pass_with_the_bits_of_a_pass_per_cell(ctx, monkeypatch, name):
    r = RECIPES[name]
    rng = np.random.default_rng(11)
    pts = np.concatenate([rng.uniform(-40.0, 40.0, size=(400, 3)), rng.uniform(0.0, 1.0, size=(20, 3)),
                          1e4 + rng.uniform(0.0, 2.0, size=(30, 3))])
    fw = (0.002, 0.003, 0.0)
    run = dispatch.run
    for path in _paths(ctx):
        monkeypatch.setenv("CELLGL_PATH", path)
        calls = []
        monkeypatch.setattr(dispatch, "run", lambda *a, calls=calls, **k: calls.append(k) or run(*a, **k))
        got = cellgl.evaluate(r, pts, CHS, filter_width=fw)
        monkeypatch.setattr(dispatch, "run", run)
        assert len(calls) == 1 and calls[0]["groups"] is not None, (path, len(calls))
        # the reference: a pass per whole part, panned by it (as evaluate ran them before)
        whole = np.floor(pts)
        keys = np.unique(whole, axis=0)
        assert len(keys) > 300
        for key in keys[::37]:
            idx = np.flatnonzero(np.all(whole == key, axis=1))
            p4 = np.zeros((len(idx), 4), np.float32)
            p4[:, :3] = pts[idx] - key

            def set_filter(prog):
                if "u_filter_width" in prog:
                    prog["u_filter_width"].value = fw
            want = run(r, CHS, len(idx), set_filter, grid=False, points=p4, pan=tuple(float(c) for c in key))
            for c in CHS:
                assert got[c][idx].tobytes() == want[c].tobytes(), (path, key, c)


def test_group_records_are_the_pan_split():
    """Each group's records are lattice_origins at its whole part, octave by octave (those a
    sample reads: one without a fractal), fractions as their float32 bits."""
    r = RECIPES["everything"]
    keys = np.array([[3.0, -7.0, 2.0], [1e6, 5.0, -1.0]])
    n = shader.group_octaves(r)
    assert n == 4 and shader.group_octaves(Recipe()) == 1
    rec = shader.group_records(r, keys).reshape(len(keys), 4 * n + 2, 4)
    for g, key in enumerate(keys):
        o = shader.lattice_origins(r, tuple(key))
        for i in range(n):
            assert np.array_equal(rec[g, 4 * i].view(np.int32), o["origin_cell"][i])
            assert np.array_equal(rec[g, 4 * i + 1].view(np.float32), o["origin_frac"][i])
            assert np.array_equal(rec[g, 4 * i + 2].view(np.int32), o["noise_cell"][i])
            assert np.array_equal(rec[g, 4 * i + 3].view(np.float32), o["noise_frac"][i])
        assert np.array_equal(rec[g, 4 * n].view(np.int32), o["warp_cell"])
        assert np.array_equal(rec[g, 4 * n + 1].view(np.float32), o["warp_frac"])
