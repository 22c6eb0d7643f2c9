"""Recipes: JSON round trips, strict validation with clear errors, --set parsing, presets listing."""
from __future__ import annotations

import json

import pytest

from cellgl.texture import params
from cellgl.texture.recipe import Recipe, RecipeError
from cellgl.recipes import list_presets, load_recipe


def test_table_is_consistent():
    names = [p.name for p in params.PARAMS]
    assert len(names) == len(set(names))
    for p in params.PARAMS:
        assert p.doc and p.group in params.GROUPS
        if p.type in ("float", "int"):
            assert p.lo <= p.default <= p.hi, p.name
        if p.type == "enum":
            assert p.default in p.choices
    assert "| `c1 .. c8` |" in params.markdown_table()


def test_defaults_round_trip(tmp_path):
    r = Recipe()
    assert Recipe.from_dict(r.to_dict()) == r
    path = tmp_path / "r.json"
    r.save(path)
    assert Recipe.load(path) == r
    assert not list(tmp_path.glob(".*tmp"))      # atomic save leaves no temp file


@pytest.mark.parametrize("name", [n for n, _ in list_presets() if not n.startswith("pups-")])
def test_every_preset_round_trips(name, tmp_path):
    r = load_recipe(name)
    assert Recipe.from_dict(json.loads(json.dumps(r.to_dict()))) == r
    path = tmp_path / f"{name}.json"
    r.save(path)
    back = Recipe.load(path)
    assert back == r and back.variants == r.variants


def test_list_presets_has_every_paper_texture():
    names = {n for n, _ in list_presets()}
    want = {"f1", "f2", "f3", "f4", "veins", "polka", "flagstone", "crumple", "sea", "hide", "hull", "craters",
            "rock", "ice", "mountains", "worley-gallery", "qin-marble", "qin-wood", "qin-trunk", "qin-cloud",
            "qin-flame", "qin-wrinkle"}
    assert want <= names
    assert all(doc for _, doc in list_presets())
    assert len(load_recipe("worley-gallery").variants) == 20
    assert load_recipe("worley-gallery:9").get("linear")[:4] == [-1.0, -1.0, 2.0, 0.0]
    assert load_recipe("qin-wrinkle:0").get("octaves") == 1.0


def test_qin_coefficients():
    m = load_recipe("qin-marble")
    assert m.get("linear")[:4] == [-1.0, 1.0, -1.0, 1.0]
    assert m.get("products") == [[(-1.0) ** (i + j) for j in range(4)] for i in range(4)]
    assert len(m.ramp) == 13 and m.get("ramp_mode") == "spline"
    w = load_recipe("qin-wood")
    assert w.get("c1") == 1.0 and w.get("c11") == -1.0


@pytest.mark.parametrize("d, words", [
    ({"fractal": {"octaves": 12}}, ["fractal.octaves", "12", "[1.0, 8.0]"]),
    ({"basis": {"metric": "taxicab"}}, ["basis.metric", "taxicab", "euclidean, manhattan"]),
    ({"basis": {"dimension": 2.5}}, ["basis.dimension", "2.5", "integer"]),
    ({"basis": {"octaves": 3}}, ["basis.octaves", "belongs in 'fractal'"]),
    ({"fractl": {}}, ["fractl", "did you mean fractal"]),
    ({"mapping": {"invert": "yes"}}, ["mapping.invert", "true or false"]),
    ({"combination": {"linear": [1, "a"]}}, ["combination.linear[1]", "'a'"]),
    ({"combination": {"products": [[0, 0], [0, 0]]}}, ["combination.products", "4 x 4"]),
    ({"combination": {"linear": [1], "c1": 2}}, ["c1", "twice"]),
    ({"color": {"ramp": [[0.5, 1, 1, 1], [0.2, 0, 0, 0]]}}, ["color.ramp[1]", "must not decrease"]),
    ({"color": {"ramp_mode": "spline", "ramp": [[0, 0, 0, 0], [1, 1, 1, 1]]}}, ["color.ramp", "at least 4"]),
    ({"basis": {"min_points": 5, "max_points": 3}}, ["basis.min_points", "max_points"]),
    ({"combination": {"range_lo": 1, "range_hi": 0}}, ["combination.range_hi", "must exceed"]),
    ({"domain": {"tileable": True, "frequency": 4.5}}, ["domain.frequency", "4.5", "integer", "tileable"]),
    ({"domain": {"tileable": True, "frequency": 4}, "fractal": {"fractal": "sum", "lacunarity": 2.5}},
     ["fractal.lacunarity", "2.5"]),
    ({"basis": {"distribution": "worley1996"}}, ["basis.distribution", "dimension 3"]),
    ({"outputs": ["colour"]}, ["outputs", "colour", "color, height"]),
    ({"cellgl_recipe": 7}, ["cellgl_recipe", "7"]),
])
def test_bad_recipes_name_field_and_accepted(d, words):
    with pytest.raises(RecipeError) as exc:
        Recipe.from_dict(d)
    for w in words:
        assert w in str(exc.value), (w, str(exc.value))


@pytest.mark.parametrize("text, held", [("{}", "it is empty"), ('{"name": "x"}', "it holds only 'name'"),
                                        ('{"cellgl_recipe": 1, "basis": {}, "outputs": ["color"]}', "'basis'"),
                                        ('{"kind": "pups", "name": "x"}', "it holds only 'kind', 'name'")])
def test_a_recipe_file_that_sets_nothing_is_refused(tmp_path, capsys, text, held):
    """A mistyped or truncated file must not bake the default grey F1 and exit 0."""
    from cellgl.cli import main

    path = tmp_path / "empty.json"
    path.write_text(text)
    out = tmp_path / "out.png"
    assert main(["bake", str(path), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "empty.json" in err and "no" in err and "parameter set" in err and held in err, err
    assert not out.exists()
    assert "presets" in err                 # says where a whole recipe comes from
    with pytest.raises(RecipeError, match="no parameter set"):
        Recipe.from_dict({"name": "x"})
    assert Recipe.from_dict({"basis": {"seed": 3}}).get("seed") == 3    # one value is enough


def test_set_from_strings():
    r = Recipe().set_from_strings(["octaves=3.5", "fractal=qin", "seed=0x10", "tileable=true", "frequency=4",
                                  "linear=[0, 1]", "c12=-1", "ramp=[[0,0,0,0],[1,1,0,0]]"])
    assert r.get("octaves") == 3.5 and r.get("fractal") == "qin" and r.get("seed") == 16
    assert r.get("tileable") is True and r.get("linear")[:3] == [0.0, 1.0, 0.0] and r.get("c12") == -1.0
    assert r.ramp[-1] == (1.0, 1.0, 0.0, 0.0)
    with pytest.raises(RecipeError, match=r"octave.*did you mean octaves"):
        Recipe().set_from_strings(["octave=3"])
    with pytest.raises(RecipeError, match=r"gain=abc.*\[0.0, 1.0\]"):
        Recipe().set_from_strings(["gain=abc"])
    with pytest.raises(RecipeError, match="name=value"):
        Recipe().set_from_strings(["gain"])
    with pytest.raises(RecipeError, match=r"--set basis.density: out of range: 99"):
        Recipe().set_from_strings(["density=99"])


def test_load_recipe_errors(tmp_path):
    with pytest.raises(RecipeError, match="unknown preset 'flagston'.*did you mean flagstone"):
        load_recipe("flagston")
    with pytest.raises(RecipeError, match="no variant '99'"):
        load_recipe("worley-gallery:99")
    bad = tmp_path / "bad.json"
    bad.write_text("{nope")
    with pytest.raises(RecipeError, match="not valid JSON"):
        load_recipe(str(bad))
    bad.write_text('{"fractal": {"gain": 2}}')
    with pytest.raises(RecipeError, match=r"bad.json: fractal.gain"):
        load_recipe(str(bad))


def test_cli_presets(capsys):
    from cellgl.cli import main

    assert main(["presets"]) == 0
    out = capsys.readouterr().out
    assert "flagstone" in out and "Worley 1996 Fig. 2" in out
    assert main(["presets", "veins", "--set", "seed=3"]) == 0
    assert json.loads(capsys.readouterr().out)["basis"]["seed"] == 3
    assert main(["presets", "veins", "--set", "seed=-3"]) == 2
    assert "basis.seed" in capsys.readouterr().err


def test_docs_parameter_table_is_current():
    import importlib.util
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    spec = importlib.util.spec_from_file_location("make_params_table", root / "docs" / "make_params_table.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    text = (root / "docs" / "textures.md").read_text()
    assert mod.render(text) == text, "run: PYTHONPATH=. python docs/make_params_table.py"


@pytest.mark.parametrize("kind", ["f1", "pups-cow"])
def test_name_and_doc_have_a_sane_size(tmp_path, capsys, kind):
    """A 10 MB name gave a 31 MB snippet: names are one line of <= 64 characters, docs <= 4096
    characters, however the recipe arrives (a file, ``replace``, ``--set``)."""
    from cellgl.cli import main
    from cellgl.recipes import load_recipe
    from cellgl.texture.schema import MAX_DOC, MAX_NAME

    r = load_recipe(kind)
    assert r.replace(name="é" * MAX_NAME, doc="d" * MAX_DOC).name == "é" * MAX_NAME
    for kw, words in ((dict(name="n" * 10_000_000), ["name: 10000000 characters", "at most 64"]),
                      (dict(name="a\nb"), ["control character", "one line"]),
                      (dict(doc="d" * (MAX_DOC + 1)), ["doc: 4097 characters", "at most 4096"])):
        with pytest.raises(RecipeError) as exc:
            r.replace(**kw)
        assert all(w in str(exc.value) for w in words), str(exc.value)
        assert len(str(exc.value)) < 300
    d = json.loads(r.to_json())
    d["name"] = "x" * 100
    path = tmp_path / "long.json"
    path.write_text(json.dumps(d))
    assert main(["export", str(path), "--target", "gles"]) == 2
    assert "name: 100 characters" in capsys.readouterr().err


def test_recipes_answers_what_depends_on_the_kind():
    """What front ends used to take from one kind's module comes from cellgl.recipes (issue 42)."""
    from cellgl import recipes
    from cellgl.pups.recipe import PUPS_PARAMS
    from cellgl.texture.evaluation import MAX_SIDE

    every = list_presets()
    cellular, pups = list_presets("cellular"), list_presets("pups")
    assert sorted(cellular + pups) == every and cellular and pups
    assert all(n.startswith("pups-") for n, _ in pups) and not any(n.startswith("pups-") for n, _ in cellular)
    with pytest.raises(ValueError, match=r"kind 'texture'.*accepted: None \(every kind\), cellular, pups"):
        list_presets("texture")
    assert recipes.parameters("flagstone") is params.PARAMS
    cow = load_recipe("pups-cow")
    table = recipes.parameters(cow)
    assert table and set(p.name for p in table) == set(cow.names()) and set(table) <= set(PUPS_PARAMS)
    assert recipes.max_side("flagstone") == MAX_SIDE == recipes.MAX_SIDE == 1 << 20
    assert recipes.max_side(cow) == 1 << 16
    assert recipes.is_path("a/b.json") and not recipes.is_path("flagstone")


def test_the_recipe_rooms_keep_one_api():
    """texture/recipe.py's split (fields, recipe_json, recipe, presets) keeps the names users
    reach for, and with_variants gives a copy (the original keeps its variants)."""
    import cellgl.texture
    from cellgl.texture import presets, recipe_json

    assert cellgl.texture.Recipe is cellgl.Recipe is Recipe and cellgl.texture.RecipeError is RecipeError
    base = presets.load_recipe("worley-gallery")
    assert base.variants and presets.load_recipe("worley-gallery:1") == base.variants[1]
    bare = base.with_variants(())
    assert bare.variants == () and len(base.variants) > 1 and bare == base     # equality ignores variants
    again = Recipe.from_dict(json.loads(base.to_json()))
    assert again.variants == base.variants
    assert recipe_json.to_dict(base) == base.to_dict()
    assert recipe_json.set_changes(["basis.seed=5", "ramp=[[0, 1, 1, 1]]"]) == {"seed": 5, "ramp": [[0, 1, 1, 1]]}
