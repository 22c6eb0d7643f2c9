"""PUPs presets as recipes: table, JSON, --set, errors, render dispatch, tiles, bake, listing,
export refusal."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

import cellgl

from cellgl.pups import recipe as R
from cellgl.pups.presets import PUPS_PRESETS, _params, build_pups
from cellgl.texture.recipe import RecipeError
from cellgl.recipes import list_presets, load_recipe

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test_every_preset_round_trips(tmp_path):
    for name in PUPS_PRESETS:
        r = load_recipe(name)
        assert isinstance(r, R.PupsRecipe) and r.kind == "pups"
        assert R.PupsRecipe.from_dict(json.loads(r.to_json())) == r
        assert _params(r.preset_params()) == _params(name), name  # same build parameters
        path = tmp_path / f"{name}.json"
        r.save(path)
        assert load_recipe(str(path)) == r


@pytest.mark.parametrize("name", ["flagstone", "pups-cells"])
def test_a_saved_recipe_of_either_kind_lands_whole_with_the_usual_permissions(tmp_path, name):
    """Both recipe kinds save through the one atomic writer: the file is renamed into place,
    readable as any file the user makes (0o666 less the umask; the PUPs save made it 0o600),
    nothing else left beside it."""
    old = os.umask(0o022)
    try:
        load_recipe(name).save(tmp_path / "r.json")
    finally:
        os.umask(old)
    assert os.stat(tmp_path / "r.json").st_mode & 0o777 == 0o644
    assert os.listdir(tmp_path) == ["r.json"]
    assert load_recipe(str(tmp_path / "r.json")) == load_recipe(name)


def test_table_is_derived_from_the_kinds():
    from cellgl.pups.presets import KIND_DEFAULTS

    for kind, keys in KIND_DEFAULTS.items():
        names = set(R.params_for(kind.replace("-", "_")))
        for k in keys:
            assert k in names or any(k == pair for pair in ("cluster_sizes", "n_range")), (kind, k)
    assert all(p.name in {n for k in R.PATTERNS for n in R.params_for(k)} for p in R.PUPS_PARAMS)


def test_set_replace_and_errors():
    r = load_recipe("pups-cow").set_from_strings(["seed=3", "radius=0.08", "labels=ramp"])
    assert (r["seed"], r["radius"], r["labels"]) == (3, 0.08, "ramp")
    assert r.replace(epsilon=0.2)["epsilon"] == 0.2
    with pytest.raises(RecipeError, match=r"pups.radius: out of range: 5.0; accepted: \[0.005, 0.5\]"):
        r.set_from_strings(["radius=5"])
    with pytest.raises(RecipeError, match="not a parameter of pattern 'cow'"):
        r.set_from_strings(["fold=true"])
    with pytest.raises(RecipeError, match="unknown PUPs parameter"):
        r.set_from_strings(["frequency=3"])
    with pytest.raises(RecipeError, match="radius_max"):
        r.replace(radius_max=0.01)
    with pytest.raises(RecipeError, match="octaves"):
        load_recipe("pups-octaves").replace(octaves=8)
    with pytest.raises(RecipeError, match="pups.labels: unknown choice"):
        R.PupsRecipe.from_dict({"kind": "pups", "pups": {"pattern": "cow", "labels": "x"}})
    with pytest.raises(RecipeError, match="unknown key 'basis'"):
        R.PupsRecipe.from_dict({"kind": "pups", "basis": {}})
    g = r.replace(pattern="giraffe")
    assert g["pattern"] == "giraffe" and g["seed"] == 3 and "labels" not in g.values


def test_presets_listed():
    names = dict(list_presets())
    assert set(PUPS_PRESETS) <= set(names) and "flagstone" in names
    assert names["pups-cow"].startswith("PUPs fig. 11")


def test_render_dispatch_channels(ctx):
    import cellgl

    r = load_recipe("pups-giraffe")
    out = cellgl.render(r, 40, 40, channels=("color", "height"))
    assert out["color"].shape == (40, 40, 4) and out["color"].dtype == np.float32
    assert np.all(out["color"][..., 3] == 1) and out["height"].shape == (40, 40)
    ref = build_pups("pups-giraffe", 40, 40)                 # square: the same image
    assert np.abs(out["color"][..., :3] - ref).max() < 1e-4
    with pytest.raises(ValueError, match="accepted: color, height"):
        cellgl.render(r, 8, 8, channels=("normal",))
    with pytest.raises(ValueError, match="2D"):
        cellgl.render(r, 8, 8, depth=4)
    with pytest.raises(ValueError, match="PUPs"):
        cellgl.evaluate(r, [[0.5, 0.5]])


@pytest.mark.parametrize("name", ["pups-cow", "pups-noise-folded", "pups-octaves",
                                  "pups-weight-isolines", "pups-graph", "pups-giraffe"])
def test_tiles_equal_one_pass(ctx, name):
    r = load_recipe(name)
    W, H = 100, 70
    full = cellgl.render(r, W, H, channels=("color", "height"))
    for x0, y0, tw, th in [(0, 0, 48, 32), (48, 32, 52, 38), (16, 48, 80, 22)]:
        t = cellgl.render(r, W, H, channels=("color", "height"), x0=x0, y0=y0, tile_w=tw, tile_h=th)
        for c in ("color", "height"):
            assert t[c].tobytes() == full[c][y0:y0 + th, x0:x0 + tw].tobytes(), (name, c)


def test_numpy_backend_agrees(ctx):
    r = load_recipe("pups-noise")
    a = cellgl.render(r, 48, 48)["color"]
    b = cellgl.render(r, 48, 48, backend="numpy")["color"]
    assert np.abs(a - b).max() < 1e-4


def _cli(*args, cwd):
    env = dict(os.environ, PYTHONPATH=ROOT)
    return subprocess.run([sys.executable, "-m", "cellgl", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)


def test_bake_cli(ctx, tmp_path):
    from PIL import Image

    r = _cli("bake", "pups-cow", "-o", "cow.png", "--size", "64", "--set", "seed=3", "-q", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    r = _cli("bake", "pups-cow", "-o", "cow_t.png", "--size", "64", "--set", "seed=3", "--tile", "16",
             "--tileable", "-q", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    a = np.asarray(Image.open(tmp_path / "cow.png"))
    assert np.array_equal(a, np.asarray(Image.open(tmp_path / "cow_t.png")))
    assert set(np.unique(a)) == {0, 255}       # binary labels
    ref = cellgl.render(load_recipe("pups-cow").replace(seed=3), 64, 64)["color"][..., :3]
    assert np.array_equal(a, np.round(ref * 255).astype(np.uint8))
    r = _cli("bake", "pups-cow", "-o", "x.png", "--channels", "normal", cwd=tmp_path)
    assert r.returncode == 2 and "accepted: color, height" in r.stderr


def test_presets_cli_and_export_refusal(tmp_path):
    r = _cli("presets", cwd=tmp_path)
    assert r.returncode == 0 and "pups-cow" in r.stdout and "flagstone" in r.stdout
    r = _cli("presets", "pups-cow", "--set", "seed=5", cwd=tmp_path)
    assert json.loads(r.stdout)["pups"]["seed"] == 5
    r = _cli("export", "pups-cow", "--target", "glsl", cwd=tmp_path)
    assert r.returncode == 2 and "cannot be exported" in r.stderr and "cellgl bake" in r.stderr
