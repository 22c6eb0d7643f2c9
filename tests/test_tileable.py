"""`--tileable` makes any recipe seamless, rounding the periods it needs to whole cells."""
from __future__ import annotations

import os
import stat
import subprocess
import sys

import numpy as np

import cellgl
from cellgl.recipes import load_recipe


def test_tileable_rounds_periods_and_says_so():
    r = load_recipe("sea").replace(frequency=7.5, aspect=1.0)
    t, notes = r.tileable()
    assert t.get("tileable") is True
    assert t.get("frequency") == 8.0 and t.get("aspect") == 1.0
    assert notes == ["frequency 7.5 -> 8"]
    same, notes = load_recipe("flagstone").replace(frequency=4.0, aspect=1.0).tileable()
    assert notes == [] and same.get("frequency") == 4.0


def test_tileable_render_wraps_in_both_directions(ctx):
    t, _ = load_recipe("sea").replace(frequency=3.5).tileable()
    img = cellgl.render(t, 96, 96, channels=("height",))["height"].astype(np.float64)
    inner_x = np.abs(np.diff(img, axis=1)).mean()
    inner_y = np.abs(np.diff(img, axis=0)).mean()
    assert np.abs(img[:, 0] - img[:, -1]).mean() < 2.0 * inner_x
    assert np.abs(img[0, :] - img[-1, :]).mean() < 2.0 * inner_y


def test_cli_tileable_bakes_a_non_integer_preset(ctx, tmp_path):
    out = tmp_path / "sea.png"
    p = subprocess.run([sys.executable, "-m", "cellgl", "bake", "sea", "-o", str(out), "--size", "64",
                        "--tileable", "-q"], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    assert "tileable: aspect" in p.stderr
    assert out.exists()


def test_exported_snippet_file_has_normal_permissions(tmp_path):
    out = tmp_path / "f.glsl"
    p = subprocess.run([sys.executable, "-m", "cellgl", "export", "f1", "--target", "glsl", "-o", str(out)],
                       capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    umask = os.umask(0)
    os.umask(umask)
    assert stat.S_IMODE(out.stat().st_mode) == 0o666 & ~umask
    assert [f.name for f in tmp_path.iterdir()] == ["f.glsl"]
