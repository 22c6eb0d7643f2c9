"""Recipe files and names as a hostile user wrote them (issues 10, 33, 42): huge numbers, deep
nesting, Latin-1, devices and FIFOs, unprintable names and docs, names that must become identifiers
in every export target and a Regenerate command that makes the same snippet again, a pups image
beside the recipe. Each test failed (or hung) before its fix."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from hostile import ENV, REPO
from hostile import cli as _cli
from hostile import main_refuses as _main_refuses
from hostile import one_line_error as _assert_clean_error
from hostile import refused as _refused


# --------------------------------------------------------------------------------------------
# the command line: an error message, never a traceback
# --------------------------------------------------------------------------------------------


def _recipe_files(d: Path) -> dict[str, Path]:
    files = {
        "huge_int.json": '{"basis": {"seed": ' + "9" * 5000 + "}}",
        "huge_float.json": '{"basis": {"density": ' + "9" * 400 + "}}",
        "deep.json": "[" * 100000 + "]" * 100000,
        "deep_value.json": '{"basis": ' + "[" * 100000 + "]" * 100000 + "}",
    }
    out = {}
    for name, text in files.items():
        out[name] = d / name
        out[name].write_text(text)
    out["latin1.json"] = d / "latin1.json"
    out["latin1.json"].write_bytes('{"name": "café"}'.encode("latin-1"))
    return out


@pytest.mark.parametrize("name, needle", [
    ("huge_int.json", "integer literal of 5000 digits"),
    ("huge_float.json", "integer literal of 400 digits"),
    ("deep.json", "nested too deeply"),
    ("deep_value.json", "nested too deeply"),
    ("latin1.json", "not UTF-8 text (byte 0xe9"),
])
@pytest.mark.parametrize("command", ["bake", "export"])
def test_hostile_recipe_files(tmp_path, name, needle, command):
    path = _recipe_files(tmp_path)[name]
    extra = ["-o", str(tmp_path / "out.png"), "--size", "8"] if command == "bake" else []
    _assert_clean_error(_cli(command, str(path), *extra), str(path), needle)


def test_huge_numbers_in_recipe_values_and_set():
    """A float parameter given an integer beyond float range raised OverflowError; an integer
    of 5000 digits made the error message itself fail (no repr past 4300 digits)."""
    from cellgl.texture.recipe import Recipe, RecipeError

    with pytest.raises(RecipeError, match=r"basis\.density: out of range: <an integer of about 401"):
        Recipe().replace(density=10 ** 400)
    with pytest.raises(RecipeError, match=r"basis\.seed: out of range: <an integer of about 5001"):
        Recipe().replace(seed=10 ** 5000)
    with pytest.raises(RecipeError, match=r"cannot parse .*\(5000 characters\)"):
        Recipe().set_from_strings(["seed=" + "9" * 5000])


# --------------------------------------------------------------------------------------------
# item 8: a recipe "file" that never ends, or never starts
# --------------------------------------------------------------------------------------------

def _limit_memory():
    import resource

    resource.setrlimit(resource.RLIMIT_AS, (3 << 30, 3 << 30))    # it read /dev/zero until MemoryError


@pytest.mark.parametrize("case", ["/dev/zero", "fifo", "big"])
def test_a_recipe_is_read_only_from_a_small_regular_file(tmp_path, case):
    from cellgl.texture.schema import MAX_RECIPE_BYTES

    if case == "fifo":
        src = tmp_path / "r.json"
        os.mkfifo(src)                                   # no writer: open() blocked for ever
        words = ("not a regular file",)
    elif case == "big":
        src = tmp_path / "r.json"
        src.write_bytes(b"{" + b" " * MAX_RECIPE_BYTES + b"}")
        words = ("larger than 1024 KiB", f"at most {MAX_RECIPE_BYTES} bytes")
    else:
        src = Path(case)
        words = ("not a regular file",)
    r = subprocess.run([sys.executable, "-m", "cellgl", "bake", str(src), "-o", str(tmp_path / "a.png"),
                        "--size", "16"], cwd=REPO, env=ENV, capture_output=True, text=True, timeout=60,
                       preexec_fn=_limit_memory)
    _refused(r, f"recipe '{src}'", *words)
    assert sorted(os.listdir(tmp_path)) == ([] if case == "/dev/zero" else ["r.json"])


# --------------------------------------------------------------------------------------------
# 2. any recipe name becomes a valid identifier in every export target
# --------------------------------------------------------------------------------------------

NAMES = ["été", "中文纹理", "Текстура", "float", "shader", "return", "3d-cells", "gl_Position",
         "a__b", "__", "", "x" * 300, "naïve café\nvoid main() {}", "struct", "fn", "let"]

#: keywords and reserved words of the targets a name could collide with (a sample of each)
KEYWORDS = {"float", "int", "uint", "bool", "void", "return", "if", "else", "for", "while",
            "struct", "in", "out", "inout", "uniform", "const", "shader", "surface", "volume",
            "displacement", "color", "point", "normal", "vector", "matrix", "string", "closure",
            "output", "fn", "let", "var", "loop", "switch", "texture", "sampler", "half",
            "precision", "highp", "discard", "break", "continue", "true", "false", "main"}


@pytest.mark.parametrize("name", NAMES)
def test_a_recipe_name_becomes_a_valid_identifier(name):
    import re

    from cellgl.export.names import IDENT_MAX, identifier

    ident = identifier(name)
    assert re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", ident), ident
    assert "__" not in ident and not ident.startswith("gl_") and len(ident) <= IDENT_MAX
    assert ident.lower() not in KEYWORDS
    assert identifier(name) == ident                         # the same name, the same identifier


def test_different_scripts_stay_different():
    from cellgl.export.names import identifier

    assert identifier("été") == "cellgl_ete"
    assert len({identifier(n) for n in ("中文", "中国", "Текстура", "Текстуры", "x" * 300, "x" * 301)}) == 6


def _named(name: str):
    from cellgl.recipes import load_recipe

    r = load_recipe("flagstone")
    r.name = name
    return r


@pytest.mark.parametrize("target", ["glsl", "gles", "shadertoy", "godot", "godotinc", "hlsl",
                                    "unreal", "wgsl", "osl"])
def test_snippets_of_hostile_names_compile(tmp_path, target):
    """`shader cellgl_été(` (OSL) compiled nowhere; a newline in a name ended the header's
    comment and put the rest in the code."""
    from test_export import compile_snippet

    from cellgl.export import export

    for name in ("été", "中文", "float", "7up\nvoid x() {}"):
        text = export(_named(name), target)
        assert all("void x() {}" not in line or line.lstrip().startswith(("//", "#")) for line in
                   text.splitlines()), name
        compile_snippet(tmp_path, target, text)


def test_blender_scene_of_a_recipe_named_ete(tmp_path):
    """`cellgl blender recipe.json` with "name": "été" ended in an OSL compilation failure."""
    pytest.importorskip("bpy")
    import json

    from cellgl.recipes import load_recipe

    d = load_recipe("flagstone").to_dict()
    d["name"] = "été"
    (tmp_path / "recipe.json").write_text(json.dumps(d))
    r = _cli("blender", "recipe.json", "-o", "scene.blend", "--size", "16", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "scene.blend").stat().st_size > 0


# --------------------------------------------------------------------------------------------
# 5. the header's Regenerate command writes the same snippet, byte for byte
# --------------------------------------------------------------------------------------------


def _regenerate(text: str, cwd: Path) -> str:
    import shlex

    first = text.splitlines()[0]
    command = first.split("Regenerate (do not edit): ", 1)[1]
    words = shlex.split(command)
    assert words[:2] == ["cellgl", "export"], command
    r = _cli(*words[1:], cwd=cwd)
    assert r.returncode == 0, (command, r.stderr)
    return r.stdout


@pytest.mark.parametrize("argv", [
    ["flagstone", "--target", "gles"],
    ["flagstone", "--set", "seed=7", "--set", "basis.density=2.5", "--target", "gles"],
    ["flagstone", "--set", "seed=7", "--uniforms"],
    ["flagstone", "--no-fold", "--target", "hlsl"],
    ["my recipe.json", "--target", "wgsl"],
    ["my recipe.json", "--set", "seed=3", "--target", "osl"],
    ["--basis", "f1f2", "--dim", "3", "--metric", "manhattan", "--seed", "5", "--density", "2.0"],
    ["--basis", "edge", "--distribution", "jitter", "--jitter", "0.5", "--target", "wgsl"],
])
def test_regenerate_command_reproduces_the_snippet(tmp_path, argv):
    """`cellgl export flagstone --set seed=7 --target gles` said `... flagstone --target gles`
    (seed 0), and a recipe file's path was dropped."""
    import json

    from cellgl.recipes import load_recipe

    d = load_recipe("flagstone").to_dict()
    d["name"] = "mine"
    d["basis"]["seed"] = 11
    (tmp_path / "my recipe.json").write_text(json.dumps(d))
    r = _cli("export", *argv, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert _regenerate(r.stdout, tmp_path) == r.stdout


def test_regenerate_command_of_a_recipe_object(tmp_path):
    """From Python: a preset changed in code gets its --set list; any other recipe object gets
    RECIPE.json, the header's Recipe line saved."""
    import json

    from cellgl.export import export
    from cellgl.recipes import load_recipe

    r = load_recipe("flagstone").replace(seed=7, jitter=0.5)
    text = export(r, "gles")
    assert "--set seed=7" in text.splitlines()[0]
    assert _regenerate(text, tmp_path) == text
    other = _named("été")
    text = export(other, "glsl")
    recipe_line = next(line for line in text.splitlines() if line.startswith("// Recipe: "))
    (tmp_path / "RECIPE.json").write_text(recipe_line[len("// Recipe: "):])
    assert json.loads((tmp_path / "RECIPE.json").read_text())["name"] == "été"
    assert _regenerate(text, tmp_path) == text


# --------------------------------------------------------------------------------------------
# item 16: names and docs hold only printable characters, however the recipe arrives
# --------------------------------------------------------------------------------------------

@pytest.mark.parametrize("key, char", [("name", "\u202e"), ("doc", "\u202e"), ("doc", "\u200b"),
                                       ("name", "\u2066"), ("doc", "\n")])
def test_unprintable_names_and_docs_are_refused(capsys, tmp_path, key, char):
    from cellgl.recipes import load_recipe
    from cellgl.texture.schema import RecipeError

    for preset in ("f1", "pups-cow"):
        r = load_recipe(preset)
        d = json.loads(r.to_json())
        d[key] = f"evil{char}txt.exe"
        path = tmp_path / f"{preset}.json"
        path.write_text(json.dumps(d))
        _main_refuses(capsys, ["export", path, "--target", "glsl", "-o", tmp_path / "x.glsl"],
                      f"{key}: ", f"U+{ord(char):04X}", "printable")
        with pytest.raises(RecipeError, match=f"U\\+{ord(char):04X}"):
            r.replace(**{key: f"a{char}b"})
    assert not (tmp_path / "x.glsl").exists()


# --------------------------------------------------------------------------------------------
# item 15: a pups recipe's image is found next to the recipe
# --------------------------------------------------------------------------------------------

def test_pups_image_resolves_against_the_recipe_folder(ctx, tmp_path):
    import numpy as np
    from PIL import Image

    from cellgl.recipes import load_recipe

    sub = tmp_path / "recipes"
    sub.mkdir()
    y, x = np.mgrid[0:64, 0:64]
    Image.fromarray(np.where((x - 32) ** 2 + (y - 32) ** 2 < 300, 255, 0).astype(np.uint8), "L").save(sub / "one.png")
    d = json.loads(load_recipe("pups-reference").to_json())
    d["pups"]["image"] = "one.png"
    (sub / "r.json").write_text(json.dumps(d))
    elsewhere = tmp_path / "cwd"
    elsewhere.mkdir()
    r = _cli("bake", sub / "r.json", "-o", tmp_path / "r.png", "--size", "32", "-q", cwd=elsewhere)
    assert r.returncode == 0, r.stderr[-2000:]
    rec = load_recipe(str(sub / "r.json"))
    assert rec.image == str((sub / "one.png").resolve())
    assert rec.to_dict()["pups"]["image"] == str((sub / "one.png").resolve())
