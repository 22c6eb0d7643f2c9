"""The octave mean carried for the presets (cellgl/texture/octave_means.json) and measured once per
process for any other basis (cellgl.texture.means); the one bounded cache policy (cellgl._cache)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from cellgl import _cache
from cellgl.texture import means
from cellgl.texture import reference as texture_reference
from cellgl.texture.params import PARAMS
from cellgl.texture.presets import load_recipe
from cellgl.texture.recipe import RecipeError


@pytest.fixture
def counted(monkeypatch):
    """The recipes the NumPy measurement runs for (the process cache emptied first)."""
    calls = []
    real = texture_reference.measure_mean

    def count(recipe):
        calls.append(recipe)
        return real(recipe)

    monkeypatch.setattr(texture_reference, "measure_mean", count)
    means._MEASURED.clear()
    yield calls
    means._MEASURED.clear()


def test_the_table_holds_every_preset_measured_now():
    """Every preset and variant measured again gives the stored bits (a change to the reference
    that moves a mean fails here: rewrite the table with python -m cellgl.texture)."""
    stored = json.loads(means.TABLE.read_text())
    assert stored["samples"] == means.SAMPLES and stored["rng_seed"] == means.RNG_SEED
    assert "octave mean" in stored["about"]
    now = json.loads(means.table_text(means.table(texture_reference.measure_mean)))
    moved = sorted(", ".join(e["presets"]) for d, e in now["means"].items() if stored["means"].get(d) != e)
    gone = sorted(", ".join(e["presets"]) for d, e in stored["means"].items() if d not in now["means"])
    assert not moved and not gone, (f"cellgl/texture/octave_means.json is out of date (new or moved: "
                                    f"{moved}; no longer a preset's: {gone}): run python -m cellgl.texture")
    assert now == stored


def test_a_preset_runs_no_numpy_measurement(counted):
    names = []
    for name, r in means._recipes():
        m = texture_reference.octave_mean(r)
        assert m == means._carried()[means.key_digest(means.mean_key(r))]
        names.append(name)
    assert counted == [] and len(names) >= 31


def test_a_preset_with_values_outside_the_basis_changed_still_runs_no_measurement(counted):
    """--set frequency/octaves/gain/lacunarity/antialias/colours: the same basis, the same key."""
    r = load_recipe("qin-cloud")
    changed = r.replace(frequency=11.0, octaves=3.0, gain=0.6, lacunarity=2.5, antialias=2.0,
                        offset_x=1e5, bump=0.3, fractal="sum")
    assert texture_reference.octave_mean(changed) == texture_reference.octave_mean(r)
    assert counted == []


def test_a_changed_seed_is_measured_once_with_the_bits_of_a_fresh_measurement(counted):
    base = load_recipe("qin-cloud")
    r = base.replace(seed=5)                    # what --set seed=5 makes: another key
    assert means.key_digest(means.mean_key(r)) not in means._carried()
    first = texture_reference.octave_mean(r)
    assert len(counted) == 1
    assert texture_reference.octave_mean(r) == first and texture_reference.octave_mean(base.replace(seed=5)) == first
    assert len(counted) == 1
    assert first == texture_reference.measure_mean(r)
    assert first != texture_reference.octave_mean(base)


@pytest.mark.parametrize("content", ["other samples", "not json", "a list", "no means", "missing"])
def test_a_stale_or_broken_table_is_not_read(counted, monkeypatch, tmp_path, content):
    """A table written with other measurement constants, or no table at all, is ignored: the
    mean is measured (the same bits), never an error."""
    table = tmp_path / "octave_means.json"
    doc = json.loads(means.TABLE.read_text())
    doc["samples"] = means.SAMPLES // 2
    text = {"other samples": json.dumps(doc), "not json": "{\"samples\": 40", "a list": "[1, 2]",
            "no means": json.dumps({"samples": means.SAMPLES, "rng_seed": means.RNG_SEED})}
    if content != "missing":
        table.write_text(text[content])
    monkeypatch.setattr(means, "TABLE", table)
    monkeypatch.setattr(means, "_TABLE", {})
    monkeypatch.setattr(means, "_TABLE_READ", [])
    assert texture_reference.octave_mean(load_recipe("f1")) == 0.37648868560791016
    assert len(counted) == 1


def _other(p, v):
    """Another value of parameter ``p`` (current value ``v``), or None."""
    if p.type == "bool":
        return not v
    if p.type == "enum":
        return next(c for c in p.choices if c != v)
    if p.type == "color":
        return [1.0 - c for c in v]
    if p.type == "int":
        return int(v) + 1 if v + 1 <= p.hi else int(v) - 1
    step = 0.37 * (p.hi - p.lo) if p.hi - p.lo < 8 else 1.3
    return v + step if v + step <= p.hi else v - step


@pytest.mark.parametrize("preset", ["f1", "density"])
def test_the_key_names_every_value_the_measurement_reads(preset):
    """Change each parameter outside the key in turn: the measured mean does not move (else a
    process would keep the first recipe's mean for the second: the noise frequency, with noise
    in the combination, was missing; fails before)."""
    base = load_recipe(preset).replace(c_noise=0.4)
    key = means.mean_key(base)
    m0 = texture_reference.measure_mean(base)
    moved = []
    for p in PARAMS:
        other = _other(p, base.values[p.name])
        try:
            r = base.replace(**{p.name: other})
        except RecipeError:
            continue
        if means.mean_key(r) == key and texture_reference.measure_mean(r) != m0:
            moved.append(p.name)
    assert moved == []


def test_a_render_of_a_fading_preset_measures_nothing(ctx, counted):
    import cellgl
    from cellgl.texture import antialias

    r = load_recipe("qin-cloud")
    assert antialias.fades(r.values, (1 / 64, 1 / 64, 0.0))
    img = cellgl.render(r, 64, 64)["color"]
    assert counted == [] and np.isfinite(img).all()


def test_bounded_drops_the_least_recently_used():
    c = _cache.Bounded("test entries", 2)
    c.put("a", 1)
    c.put("b", 2)
    assert c.get("a") == 1                     # a is now the most recent
    c.put("c", 3)
    assert "b" not in c and c.get("a") == 1 and c.get("c") == 3 and len(c) == 2
    assert c.get("b", "none") == "none"
    assert c in _cache.caches() and means._MEASURED in _cache.caches()
    _cache.clear()
    assert len(c) == 0
    with pytest.raises(ValueError, match="size must be an int >= 1, got 0"):
        _cache.Bounded("nothing", 0)


def test_density_images_of_the_same_bytes_and_other_sizes_are_other_keys(counted, tmp_path):
    """A 2 x 8 and a 4 x 4 density image of the same pixel bytes place points differently; the
    key names the size too (it named only the bytes: the second kept the first's mean; fails
    before)."""
    from PIL import Image

    px = (np.arange(16, dtype=np.uint8) * 17)
    recipes = []
    for shape in ((2, 8), (4, 4)):
        path = tmp_path / f"d{shape[0]}x{shape[1]}.png"
        Image.fromarray(px.reshape(shape)).save(path)
        recipes.append(load_recipe("veins").replace(density_map="image", density_image=str(path),
                                                    density_min=0.5, density_max=10.0))
    a, b = recipes
    assert a.density_pixels().tobytes() == b.density_pixels().tobytes()
    assert means.mean_key(a) != means.mean_key(b)
    assert texture_reference.octave_mean(a) != texture_reference.octave_mean(b)
    assert counted == [a, b]


def test_the_process_caches_are_one_bounded_policy():
    from cellgl.export import fold, snippets
    from cellgl.export.translate import tokens
    from cellgl.pups import recipe as pups_recipe
    from cellgl.texture import images

    kept = (means._MEASURED, fold._FOLDED, snippets._CODE_CACHE, tokens._SPLITS, pups_recipe._SCENES,
            pups_recipe._SCALED, images._IMAGES)
    for c in kept:
        assert isinstance(c, _cache.Bounded) and c in _cache.caches() and c.size >= 4, c


def test_the_rewritten_table_lands_whole_with_the_usual_permissions(tmp_path, monkeypatch):
    """``python -m cellgl.texture`` rewrites the packaged table: it lands by rename, readable as
    any file the user makes (0o666 less the umask; a bare mkstemp left it 0o600), nothing else
    left in the folder."""
    import os

    monkeypatch.setattr(means, "TABLE", tmp_path / "octave_means.json")
    old = os.umask(0o022)
    try:
        path = means.write_table(lambda r: 0.5)
    finally:
        os.umask(old)
    assert os.stat(path).st_mode & 0o777 == 0o644
    assert os.listdir(tmp_path) == ["octave_means.json"]
    assert json.loads(path.read_text())["samples"] == means.SAMPLES
