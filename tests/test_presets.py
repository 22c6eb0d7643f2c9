"""Every preset (and every variant) on a small grid agrees with the NumPy reference."""
from __future__ import annotations

import pytest

from cellgl import texture
from cellgl.recipes import list_presets, load_recipe
from compare import assert_close_but_share, assert_render_matches

NAMES = [n for n, _ in list_presets() if not n.startswith("pups-")]  # PUPs: test_pups_recipe.py
VARIANTS = [f"{n}:{k}" for n in NAMES for k in range(len(load_recipe(n).variants))]


def _compare(recipe, size=32):
    chs = ("color", "height", "normal", "id", "F1", "F2")
    g = texture.render(recipe, size, size, channels=chs)
    n = texture.render(recipe, size, size, channels=chs, backend="numpy")
    # IDs are discontinuous: exact except at true ties (F1 == F2 up to float32).
    assert_render_matches(g, n, ("F1", "F2"), atol=1e-5)
    # Colour, height and normal may jump where a hard ramp step or a clamp is crossed, or at a
    # Voronoi edge of some octave (the normal): float32 positions can land on the other side.
    for k in ("color", "height", "normal"):
        assert_close_but_share(g[k], n[k], 2e-3, share=0.01, what=k)
    return g


@pytest.mark.parametrize("name", NAMES)
def test_preset_matches_reference(ctx, name):
    g = _compare(load_recipe(name))
    c = g["color"][..., :3]
    assert c.std() > 0.005 or name == "crumple", "flat image"       # every preset shows something


@pytest.mark.parametrize("name", VARIANTS)
def test_variant_matches_reference(ctx, name):
    _compare(load_recipe(name), size=16)


@pytest.mark.parametrize("name", ["veins", "qin-wood", "hull"])
def test_stored_range_is_the_measured_one(ctx, name):
    r = load_recipe(name)
    lo, hi = texture.measure_range(r)
    assert abs(lo - r.get("range_lo")) < 1e-3 and abs(hi - r.get("range_hi")) < 1e-3


def test_presets_use_their_ranges(ctx):
    """Normalised by the stored range, the combination fills [0, 1] (Worley's renormalisation)."""
    r = load_recipe("qin-marble").replace(fractal="none")
    h = texture.render(r, 64, 64, channels=("height",))["height"]
    assert h.min() < 0.05 and h.max() > 0.9
