"""The material channels (issue 45, item 4): ``roughness``, ``ao`` and ``metallic`` from the recipe's
``material`` section, computed by ``lib/texture_material.glsl`` and its NumPy twin
(:mod:`cellgl.texture.material`), in every texture preset, the API, the bake and the viewer's shader."""
from __future__ import annotations

import numpy as np
import pytest

import cellgl
from cellgl import texture
from cellgl.recipes import list_presets, load_recipe
from cellgl.texture import params as P
from cellgl.texture import shader
from cellgl.texture.recipe import Recipe, RecipeError
from compare import assert_render_matches

MAT = ("roughness", "ao", "metallic")
#: a material that uses every term
FULL = dict(roughness=0.4, roughness_cell=0.3, roughness_edge=0.4, roughness_cavity=0.2, edge_width=0.12,
            ao_edge=0.5, ao_cavity=0.3, metallic=0.2, metallic_cell=0.6)


def _recipes():
    from test_texture import RECIPES           # tests/ is on sys.path under pytest

    out = {k: r.replace(**FULL) for k, r in RECIPES.items()}
    out["flagstone"] = load_recipe("flagstone")
    out["smooth_cells"] = load_recipe("wobbly-cells").replace(**FULL)
    return out


def assert_material_matches_numpy(r, width=24, height=20, samples=1):
    """GPU against the NumPy twin within docs/exactness.md's texture bound (2e-4, as height),
    away from F1 = F2 ties (where the cell value flips with the ID: tests/test_texture.py)."""
    chs = MAT + ("F1", "F2")
    g = cellgl.render(r, width, height, channels=chs, samples=samples)
    n = cellgl.render(r, width, height, channels=chs, backend="numpy", samples=samples)
    for k in MAT:
        assert g[k].shape == (height, width) and g[k].dtype == np.float32, k
        assert 0.0 <= g[k].min() and g[k].max() <= 1.0, k
    assert_render_matches(g, n, MAT, atol=2e-4, mask_ties=True)


@pytest.mark.parametrize("name", list(_recipes()))
def test_gpu_matches_numpy(ctx, name):
    assert_material_matches_numpy(_recipes()[name])


def test_supersampled_gpu_matches_numpy(ctx):
    assert_material_matches_numpy(load_recipe("edge-tiles"), 16, 12, samples=4)


def test_numpy_twin_is_the_formula(ctx):
    """The channels are what the section says, from the texel's height, F1, F2 and cell value."""
    from cellgl.texture.reference import texture_at

    r = Recipe().replace(c1=-1.0, c2=1.0, range_hi=0.6, **FULL)
    pts = np.random.default_rng(3).uniform(0, 1, (64, 3))
    pts[:, 2] = 0.0
    o = texture_at(pts, r, 2)
    got = texture.evaluate(r, pts, MAT, backend="numpy")
    x = np.clip((o["F"][:, 1] - o["F"][:, 0]) / FULL["edge_width"], 0, 1)
    e = 1 - (3 * x * x - 2 * x ** 3)
    c = 1 - o["height"]
    k = o["cell"][:, 3] - 0.5
    want = {"roughness": 0.4 + 0.3 * k + 0.4 * e + 0.2 * c, "ao": 1 - 0.5 * e - 0.3 * c,
            "metallic": 0.2 + 0.6 * k}
    for name in MAT:
        np.testing.assert_allclose(got[name], np.clip(want[name], 0, 1), atol=1e-6, err_msg=name)
    assert e.max() > 0.5 and e.min() == 0.0      # the points reach into the grout and the stone


def test_deterministic_and_each_channel_alone_the_same_bits(ctx):
    r = load_recipe("flagstone")
    both = cellgl.render(r, 40, 30, channels=("color", "height") + MAT + ("F1",))
    again = cellgl.render(r, 40, 30, channels=("color", "height") + MAT + ("F1",))
    for k in both:
        assert np.array_equal(both[k], again[k]), k
    for k in MAT:
        assert np.array_equal(cellgl.render(r, 40, 30, channels=(k,))[k], both[k]), k
    # a recipe of F1 alone (CELL_N 1): asking for a material channel (CELL_N 2) changes no other bit
    f1 = load_recipe("f1")
    plain = cellgl.render(f1, 40, 30, channels=("color", "height", "F1", "id"))
    more = cellgl.render(f1, 40, 30, channels=("color", "height", "F1", "id", "roughness"))
    for k in plain:
        assert np.array_equal(plain[k], more[k]), k


def test_other_programs_text_unchanged():
    """CELL_TEX_MATERIAL and the section's constants only in programs that write the channels."""
    r = load_recipe("flagstone")
    assert "CELL_TEX_MATERIAL" not in texture.defines(r, ("color", "height", "F4"))
    assert texture.defines(r, ("ao",))["CELL_TEX_MATERIAL"] == 1
    assert texture.defines(load_recipe("f1"), ("ao",))["CELL_N"] == 2      # the edge mask's F2
    assert "u_roughness =" not in shader.glsl_baked_uniforms_file(r)
    assert "roughness" not in texture.glsl_constant_block(r)
    assert "const float u_roughness = 0.55;" in shader.glsl_baked_uniforms_file(r, material=True)
    # the same constants without the section as with a default one
    assert texture.glsl_constant_block(Recipe()) == texture.glsl_constant_block(
        Recipe().replace(roughness=0.9, ao_cavity=1.0))


def test_every_texture_preset_has_a_material_and_grout_is_rougher_and_darker(ctx):
    names = [n for n, _ in list_presets(kind="cellular")]
    for name in names:
        from cellgl.texture.presets import preset_dir
        import json

        section = json.loads((preset_dir() / f"{name}.json").read_text()).get("material")
        assert section and set(section) == {p.name for p in P.PARAMS if p.group == "material"}, name
    r = load_recipe("flagstone")
    o = cellgl.render(r, 96, 96, channels=("height",) + MAT)
    grout, stone = o["height"] < 0.05, o["height"] > 0.95
    assert grout.mean() > 0.01 and stone.mean() > 0.3
    assert o["roughness"][grout].mean() > o["roughness"][stone].mean() + 0.2
    assert o["ao"][grout].mean() < o["ao"][stone].mean() - 0.3
    assert np.std(o["roughness"][stone]) > 0.02         # per-cell roughness from the cell value
    assert np.all(load_recipe("hammered").values["metallic"] == 1.0)
    assert np.all(cellgl.render("hammered", 16, 16, channels=("metallic",))["metallic"] == 1.0)


def test_parameters_are_checked_and_listed():
    with pytest.raises(RecipeError, match=r"material.roughness: out of range: 1.5; accepted: \[0.0, 1.0\]"):
        Recipe.from_dict({"material": {"roughness": 1.5}})
    with pytest.raises(RecipeError, match="unknown key .*belongs in 'material'"):
        Recipe.from_dict({"color": {"ao_edge": 0.5}})
    assert Recipe.from_dict({"material": {"metallic": 1}}).values["metallic"] == 1.0
    assert P.inactive({})["edge_width"] == "needs roughness_edge not 0 or ao_edge not 0"
    assert "edge_width" not in P.inactive({"ao_edge": 0.5})
    table = P.markdown_table()
    for p in P.PARAMS:
        if p.group == "material":
            assert f"| material | `{p.name}` |" in table, p.name
    assert Recipe().set_from_strings(["ao_cavity=0.25"]).values["ao_cavity"] == 0.25


def test_bad_channel_names_the_new_ones():
    with pytest.raises(ValueError, match="roughness, ao, metallic"):
        cellgl.render("flagstone", 8, 8, channels=("gloss",))


def test_viewer_shader_shows_the_channels(ctx):
    """The viewer's fragment entry (texture.frag, its channel selector's u_channel) equals the bake."""
    r = load_recipe("flagstone")
    for k in MAT:
        frag = texture.render_fragment(r, 32, 24, k)
        ref = cellgl.render(r, 32, 24, channels=(k,))[k]
        assert np.mean(np.abs(frag[..., 0] - ref) < 2e-3) > 0.98, k


def test_bake_writes_the_channels(ctx, tmp_path):
    from PIL import Image

    from cellgl.bake.core import bake

    paths = bake("flagstone", tmp_path / "f.png", size=(48, 32), channels=["roughness", "ao", "metallic"],
                 bit_depth=16)
    ref = cellgl.render("flagstone", 48, 32, channels=MAT)
    assert [p.name for p in paths] == ["f_roughness.png", "f_ao.png", "f_metallic.png"]
    for p, k in zip(paths, MAT):
        got = np.asarray(Image.open(p))
        assert got.shape == (32, 48)
        assert np.abs(got / 65535.0 - ref[k]).max() <= 0.5 / 65535 + 1e-7, k


def test_materialx_node_doc_does_not_list_the_material_section():
    """The MaterialX node makes colour and height; its doc's list of fixed values leaves the material
    section out (it is not the node's)."""
    from cellgl.export.materialx import preset_node

    node = preset_node(load_recipe("hammered"))
    assert "frequency" in node.doc or "seed" in node.doc
    assert "metallic" not in node.doc and "roughness" not in node.doc
    assert not any(i.name in {p.name for p in P.PARAMS if p.group == "material"} for i in node.inputs)
