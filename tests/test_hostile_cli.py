"""The command line as a new user and a hostile tester met it (issue 33): Ctrl-C at any moment,
a missing extra, warnings, progress lines in logs, options that meant two things, help text
and error messages that named the wrong thing. Each test failed before its fix."""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from cellgl import cli

REPO = Path(__file__).resolve().parent.parent
ENV = dict(os.environ, PYTHONPATH=str(REPO))


def _cli(*args, cwd=REPO, timeout: float = 300) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "cellgl", *args], cwd=cwd, capture_output=True,
                          text=True, timeout=timeout, env=ENV)


# --------------------------------------------------------------------------------------------
# 1. Ctrl-C during a frames bake: exit 130, nothing left behind, every time
# --------------------------------------------------------------------------------------------

#: 1024^2: the bake lasts well past the latest signal (3 s) on a quiet 2-core machine (5.3 s
#: measured; 256^2 had got down to 1.5 s, so most signals came after the last frame)
_FRAMES = ["bake", "caustics", "--frames", "48", "-o", "sub/fr.png", "--size", "1024"]


def _default_sigint():
    """In the child: SIGINT as a terminal gives it (a background job inherits it ignored)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _interrupt_frames(tmp: Path, delay: float) -> tuple[int, str, list[str]]:
    """Start the frames bake in ``tmp``, send SIGINT after ``delay`` s; (status, stderr, what
    is left in the output folder)."""
    (tmp / "sub").mkdir(exist_ok=True)
    p = subprocess.Popen([sys.executable, "-m", "cellgl", *_FRAMES], cwd=tmp, env=ENV,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         preexec_fn=_default_sigint)
    time.sleep(delay)
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=300)
    return p.returncode, err, sorted(os.listdir(tmp / "sub"))


_STARTUP = 0.4     #: seconds the interpreter is given to reach cellgl's code (measured: < 0.1)


def _interrupt_loop(tmp_path: Path, runs: int, seed: int) -> None:
    rng = random.Random(seed)
    statuses = []
    for i in range(runs):
        # from cellgl's first line (its imports, the parser) to well into the frames; a bake
        # that finished before the signal must have written all 48 frames and nothing else.
        # (The first ~50-100 ms are the interpreter's own start-up, its site import, before any
        # cellgl code runs: a Ctrl-C there is Python's, "Fatal Python error: init_import_site".)
        delay = rng.choice([rng.uniform(_STARTUP, 0.8), rng.uniform(0.8, 3.0)])
        d = tmp_path / f"run{i}"
        d.mkdir()
        status, err, left = _interrupt_frames(d, delay)
        statuses.append(status)
        assert "Traceback" not in err, (i, delay, err[-2000:])
        if status in (0, -signal.SIGINT):
            # done before the signal, or the signal landed as the process ended, after every
            # frame was written (a shell reports a death by SIGINT as 130 too): the whole output
            assert len(left) == 48 and not any(n.startswith(".") for n in left), (i, delay, left)
            continue
        assert status == 130, (i, delay, status, err[-2000:])
        assert left == [], (i, delay, left)
    assert statuses.count(130) >= runs // 2, statuses      # most signals came mid-bake


def test_ctrl_c_in_a_frames_bake_exits_130_and_leaves_nothing(ctx, tmp_path):
    """It exited 139 (a segfault in libpython at exit) in 3 of 80 tries, and left
    .fr.*.frames/ with finished frames and a 0-byte .part.png; during start-up, a traceback."""
    _interrupt_loop(tmp_path, 4, seed=33)


@pytest.mark.slow
def test_ctrl_c_in_a_frames_bake_fifty_times(ctx, tmp_path):
    _interrupt_loop(tmp_path, 50, seed=3301)


def test_a_later_bake_sweeps_the_frames_folder_of_a_killed_one(ctx, tmp_path):
    """SIGKILL leaves the frames folder; it carries pid and host, so the next bake removes it."""
    sub = tmp_path / "sub"
    sub.mkdir()
    p = subprocess.Popen([sys.executable, "-m", "cellgl", *_FRAMES], cwd=tmp_path, env=ENV,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120
    while not any(n.endswith(".frames") for n in os.listdir(sub)):
        assert p.poll() is None and time.monotonic() < deadline, "the bake ended before its folder"
        time.sleep(0.05)
    time.sleep(0.5)
    p.kill()
    p.communicate(timeout=60)
    (stale,) = [n for n in os.listdir(sub) if n.endswith(".frames")]
    assert stale.startswith(".fr.cellgl-")
    r = _cli("bake", "caustics", "--frames", "2", "-o", "sub/fr.png", "--size", "16", "-q",
             cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert sorted(os.listdir(sub)) == ["fr_0000.png", "fr_0001.png"]


def test_in_process_main_returns_130_on_ctrl_c(monkeypatch, tmp_path):
    """Called from Python (a list of arguments) main returns the status; only the program
    leaves with os._exit."""
    def interrupted(args):
        raise KeyboardInterrupt

    monkeypatch.setitem(cli._COMMANDS, "info", (cli._add_info, interrupted))
    assert cli.main(["info"]) == 130


def test_a_swallowed_ctrl_c_still_stops_the_bake(monkeypatch):
    """A Ctrl-C that hit a C extension's import was printed by it and swallowed: the bake went
    on to the end (exit 130 then, the outputs complete). The next tile or frame raises it again."""
    from cellgl.bake.core import Progress

    steps = []

    def swallowing(args):
        try:
            signal.raise_signal(signal.SIGINT)       # the CLI's handler raises KeyboardInterrupt
            time.sleep(0.01)
        except KeyboardInterrupt:
            pass                                     # ... which something swallows
        bar = Progress(10, "baking x.png", False)
        for _ in range(10):
            bar.step()
            steps.append(1)
        return 0

    monkeypatch.setitem(cli._COMMANDS, "info", (cli._add_info, swallowing))
    # Ctrl-C as a terminal gives it: a background job (or `nohup ... &`) inherits SIGINT ignored,
    # and cellgl leaves an ignored signal ignored
    was = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        assert cli.main(["info"]) == 130
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler   # restored
    finally:
        signal.signal(signal.SIGINT, was)
    assert steps == []
    from cellgl import _interrupt

    assert _interrupt.pending == []                  # nothing left for a later bake


# --------------------------------------------------------------------------------------------
# 3. cellgl view without the [viewer] extra
# --------------------------------------------------------------------------------------------


def test_view_without_the_viewer_extra_names_it():
    code = ("import sys; sys.modules['imgui_bundle'] = None\n"
            "from cellgl.cli import main; sys.exit(main(['view']))")
    r = subprocess.run([sys.executable, "-c", code], cwd=REPO, env=ENV, capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 2, r.stderr
    assert r.stderr.count("\n") == 1 and "pip install 'cellgl[viewer]'" in r.stderr, r.stderr
    assert "internal error" not in r.stderr


# --------------------------------------------------------------------------------------------
# 10. warnings as one cellgl: warning: line
# --------------------------------------------------------------------------------------------


def test_warnings_are_one_line(ctx, tmp_path):
    r = _cli("voronoi", "-o", str(tmp_path / "v.png"), "--size", "8", "--dimensions", "4",
             "--metric", "minkowski", "--exponent", "0.25", "--feature", "F2", "--allow-inexact")
    assert r.returncode == 0, r.stderr
    lines = r.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("cellgl: warning: "), r.stderr
    assert "could not be computed exactly" in lines[0] and ".py" not in lines[0]


# --------------------------------------------------------------------------------------------
# 11. progress: plain lines off a terminal, "interrupted" on Ctrl-C
# --------------------------------------------------------------------------------------------


class _Stream:
    def __init__(self, tty: bool):
        self.text, self.tty = "", tty

    def write(self, s):
        self.text += s

    def flush(self):
        pass

    def isatty(self):
        return self.tty


def test_progress_off_a_terminal_is_plain_lines():
    from cellgl.bake.core import Progress

    s = _Stream(tty=False)
    with Progress(40, "baking x.png", True, stream=s) as bar:
        for _ in range(40):
            bar.step()
    assert "\r" not in s.text
    lines = s.text.splitlines()
    assert lines[0] == "baking x.png: started, 40 tiles", lines      # at once (issue 42)
    assert len(lines) == 11 and lines[-1].startswith("baking x.png: 40/40 tiles"), lines


@pytest.mark.parametrize("tty", [True, False])
def test_progress_says_interrupted(tty):
    from cellgl.bake.core import Progress

    s = _Stream(tty=tty)
    with pytest.raises(KeyboardInterrupt):
        with Progress(40, "baking x.png", True, stream=s) as bar:
            for _ in range(20):
                bar.step()
            raise KeyboardInterrupt
    assert s.text.endswith("interrupted\n") or s.text.endswith("interrupted at 20/40 tiles\n"), s.text
    if tty:
        assert s.text.count("\n") == 1
    else:
        assert "\r" not in s.text


def test_quiet_progress_writes_nothing():
    from cellgl.bake.core import Progress

    s = _Stream(tty=False)
    with pytest.raises(KeyboardInterrupt):
        with Progress(40, "baking x.png", False, stream=s) as bar:
            bar.step()
            raise KeyboardInterrupt
    assert s.text == ""


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
# 7. one meaning per option name; 8. plain help with every default and accepted value
# --------------------------------------------------------------------------------------------


def _help(*argv) -> str:
    r = _cli(*argv, "--help")
    assert r.returncode == 0, r.stderr
    return r.stdout


def test_voronoi_output_is_the_file_and_size_takes_wxh(ctx, tmp_path):
    """`cellgl voronoi --output v.png` was refused (the socket), `--size 128x64` too."""
    r = _cli("voronoi", "--output", str(tmp_path / "v.png"), "--size", "12x8", "--socket", "color",
             "--dimensions", "2")
    assert r.returncode == 0, r.stderr
    from PIL import Image

    with Image.open(tmp_path / "v.png") as im:
        assert im.size == (12, 8) and im.mode == "RGB"
    for argv in (["--size", "0x8"], ["--size", "8x8x8"], ["--size", "ax8"]):
        r = _cli("voronoi", "-o", str(tmp_path / "w.png"), *argv)
        assert r.returncode == 2 and "accepted W or WxH" in r.stderr, r.stderr


def test_an_option_name_means_one_thing_across_subcommands():
    """--output is where the output goes (a file; a folder for sweep) wherever it exists; a socket
    or anything else has its own name."""
    parser = cli.build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    for name, p in sub.choices.items():
        for a in p._actions:
            if "--output" in a.option_strings:
                assert "-o" in a.option_strings and a.metavar in ("FILE", "FILE.blend", "FILE.zip", "DIR"), (name, a)


def test_help_is_plain_text_with_defaults_and_every_accepted_value():
    from cellgl.basis.enums import Distribution, Metric
    from cellgl.basis.voronoi import FEATURES
    from cellgl.export.snippets import TARGETS

    top = _help()
    for t in TARGETS:
        assert t in top, t                     # osl, unreal, shadertoy were missing
    v = _help("voronoi")
    assert "``" not in v and ":func:" not in v and ":mod:" not in v
    assert "1, 2, 3 or 4 (default 3)" in v     # --dimensions
    for word in [m.name.lower() for m in Metric] + [d.name.lower() for d in Distribution] + list(FEATURES):
        assert word in v, word
    assert "0..15" in v and "0..1000" in v      # detail, lacunarity: the ranges voronoi() checks
    e = " ".join(_help("export").split())
    assert "blender" in e.split("--distribution NAME", 2)[-1].split("--density")[0]
    for t in TARGETS:
        assert t in e
    for text in (top, v, e):
        assert "``" not in text and ":func:" not in text


# --------------------------------------------------------------------------------------------
# 9. error messages that name the right thing
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("argv, needle", [
    (["--detail", "15", "--lacunarity", "1000"], "detail 15 x lacunarity 1000"),
    (["--w", "nan", "--dimensions", "4"], "--w nan: accepted a finite number"),
    (["--scale", "inf"], "--scale inf: accepted a finite number"),
])
def test_voronoi_cli_errors_name_the_option(ctx, tmp_path, argv, needle):
    r = _cli("voronoi", "-o", str(tmp_path / "v.png"), "--size", "8", *argv)
    assert r.returncode == 2 and needle in r.stderr and r.stderr.count("\n") == 1, r.stderr
    assert not (tmp_path / "v.png").exists()


def test_voronoi_output_directory_is_named(tmp_path):
    """It named the hidden temporary file; bake says the output is a directory."""
    r = _cli("voronoi", "-o", str(tmp_path) + "/", "--size", "8")
    assert r.returncode == 2 and f"output '{tmp_path}' is a directory" in r.stderr, r.stderr
    assert os.listdir(tmp_path) == []


def test_voronoi_api_errors():
    import numpy as np

    import cellgl

    pts = np.zeros((2, 3))
    with pytest.raises(ValueError, match=r"w must be a number or have shape \(2,\)"):
        cellgl.voronoi(pts, dimensions=4, w=np.zeros(3), backend="numpy")
    with pytest.raises(ValueError, match=r"w must be finite; w\[1\] is nan"):
        cellgl.voronoi(pts, dimensions=4, w=[0.0, float("nan")], backend="numpy")
    with pytest.raises(TypeError, match=r"voronoi\(\) got an unexpected keyword argument 'foo'"):
        cellgl.voronoi(pts, foo=1, backend="numpy")
    with pytest.raises(ValueError, match="detail 3 x lacunarity 1000"):
        cellgl.voronoi(pts + 1e3, detail=3, lacunarity=1000, backend="numpy")
    r = cellgl.voronoi(pts, dimensions=4, w=np.array([0.25, 0.5]), backend="numpy")
    assert r.distance.shape == (2,)


def test_set_takes_the_qualified_name_the_errors_use(capsys):
    from cellgl.recipes import load_recipe

    r = load_recipe("flagstone")
    assert r.set_from_strings(["basis.seed=2"]) == r.set_from_strings(["seed=2"])
    with pytest.raises(ValueError, match="seed is in basis, not color"):
        r.set_from_strings(["color.seed=2"])
    with pytest.raises(ValueError, match=r"basis\.density"):
        r.set_from_strings(["basis.density=-1"])


def test_export_without_an_argument_says_what_to_give(capsys):
    assert cli.main(["export"]) == 2
    err = capsys.readouterr().err
    assert "nothing to export" in err and "not both" not in err and "cellgl presets" in err


# --------------------------------------------------------------------------------------------
# 4. distribution="blender" beyond 2^24 cells: Blender's hash repeats; a warning, and jitter
# --------------------------------------------------------------------------------------------


def _image_colours(x0: float, distribution: str) -> int:
    import warnings

    import numpy as np

    import cellgl

    u = (np.arange(64) + 0.5) / 64 * 8.0
    pts = np.stack(np.meshgrid(x0 + u, u), -1).reshape(-1, 2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        r = cellgl.voronoi(pts, dimensions=2, distribution=distribution, backend="numpy")
    return len(np.unique(r.color, axis=0))


def test_blender_points_repeat_far_out_and_warn(ctx):
    import numpy as np

    import cellgl
    from cellgl.basis.population import BLENDER_HASH_LIMIT

    near, far = _image_colours(0.0, "blender"), _image_colours(1e7, "blender")
    assert near > 3 * far                    # the repeat is real (and Blender's): the warning's reason
    assert _image_colours(1e7, "jitter") > near / 2              # the exact alternative does not
    inside = np.array([[BLENDER_HASH_LIMIT / 5 - 1.0, 0.5, 0.5]])   # Scale 5: just inside
    with __import__("warnings").catch_warnings():
        __import__("warnings").simplefilter("error", RuntimeWarning)
        cellgl.voronoi(inside, backend="numpy")
        cellgl.voronoi(inside * 50, distribution="jitter", backend="numpy")
    for pts, dims in ((inside * 2, 3), (np.array([1e7]), 1)):
        with pytest.warns(RuntimeWarning, match=r"beyond 2\^24 .* distribution 'jitter'"):
            cellgl.voronoi(pts, dimensions=dims, backend="numpy")
    with pytest.warns(RuntimeWarning, match=r"beyond 2\^24"):
        cellgl.cellular(np.array([[2.0 ** 25, 0.5]]), n=1, distribution="blender", backend="numpy")
    with pytest.warns(RuntimeWarning, match=r"beyond 2\^24"):
        cellgl.cellular_grid((2, 2), origin=(2.0 ** 25, 0.0), n=1, distribution="blender",
                             backend="numpy")


def test_every_option_with_a_default_says_it():
    import argparse

    parser = cli.build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    missing = [(name, a.option_strings) for name, p in sub.choices.items() for a in p._actions
               if a.default not in (None, False, [], argparse.SUPPRESS) and a.help
               and not isinstance(a, (argparse._StoreTrueAction, argparse._StoreFalseAction))
               and "default" not in a.help]
    assert missing == []
