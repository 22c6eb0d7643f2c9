"""The command line as a new user and a hostile tester met it (issues 10, 33, 42): options that meant
two things or did nothing, help text and error messages that named the wrong thing, a missing
extra, warnings, progress lines in logs, a scheduler file waited on for ever. Each test failed (or hung) before its fix."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import pytest

from cellgl import cli
from hostile import ENV, REPO
from hostile import cli as _cli
from hostile import main_refuses as _main_refuses
from hostile import python as _python
from hostile import refused as _refused


def test_version(capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["--version"])
    assert exc.value.code == 0
    from cellgl._version import __version__

    assert capsys.readouterr().out.strip() == f"cellgl {__version__}"


# --------------------------------------------------------------------------------------------
# item 12: options that did nothing are refused
# --------------------------------------------------------------------------------------------

def test_frames_with_zarr_is_refused(capsys, tmp_path):
    _main_refuses(capsys, ["bake", "caustics", "-o", tmp_path / "t.zarr", "--frames", "2", "--size", "16"],
                  "--frames 2", ".zarr", ".webp/.gif")
    assert not (tmp_path / "t.zarr").exists()


@pytest.mark.parametrize("out, extra", [("a.png", []), ("f.png", ["--frames", "2"])])
def test_fps_without_an_animation_is_refused(capsys, tmp_path, out, extra):
    _main_refuses(capsys, ["bake", "caustics", "-o", tmp_path / out, "--size", "16", "--fps", "12", *extra],
                  "--fps 12", "--frames N", ".webp")
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("extra", [[], ["--params"]])
def test_presets_set_without_a_name_is_refused(capsys, extra):
    _main_refuses(capsys, ["presets", "--set", "seed=1", *extra], "--set seed=1", "NAME")


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
# item 17: a log hears at once, and every few seconds
# --------------------------------------------------------------------------------------------

def test_progress_in_a_log_starts_at_once_and_keeps_coming():
    from cellgl.bake.core import Progress

    class Log:
        def __init__(self):
            self.lines = []

        def write(self, text):
            self.lines.append((time.perf_counter(), text))

        def flush(self):
            pass

        def isatty(self):
            return False

    log = Log()
    bar = Progress(100, "baking x.png", True, stream=log)
    bar.LOG_INTERVAL = 0.2
    with bar:
        assert [t for _, t in log.lines] == ["baking x.png: started, 100 tiles\n"]
        time.sleep(1.0)        # a slow first tile: no tenth done yet
        n = len(log.lines)
        assert n >= 3, log.lines
        assert all(t.startswith("baking x.png: 0/100 tiles, ") for _, t in log.lines[1:]), log.lines
        bar.step()
    time.sleep(0.5)
    assert len(log.lines) == n, "a line after the bar was closed"
    gaps = [b - a for (a, _), (b, _) in zip(log.lines, log.lines[1:n])]
    assert max(gaps) < 0.6, gaps


def test_ctrl_c_before_the_first_tenth_leaves_log_lines(ctx, tmp_path):
    p = subprocess.Popen([sys.executable, "-m", "cellgl", "bake", "f1", "-o", str(tmp_path / "a.png"),
                          "--size", "4096", "--tile", "16"], cwd=REPO, env=ENV,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    first = p.stderr.readline()          # at once, long before a tenth of 65536 tiles
    p.send_signal(signal.SIGINT)
    _, rest = p.communicate(timeout=120)
    assert first == "baking a.png: started, 65536 tiles\n", (first, rest)
    assert p.returncode == 130, rest
    assert rest.rstrip().splitlines()[-1].startswith("baking a.png: interrupted at "), rest
    assert os.listdir(tmp_path) == []


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


def test_unexpected_exception_is_a_message_not_a_traceback(tmp_path):
    code = """
import sys
from cellgl import cli, recipes
def boom(*a, **k): raise TypeError("something unforeseen")
recipes.load_recipe = boom
sys.exit(cli.main(["presets", "flagstone"]))
"""
    r = _python(code)
    assert r.returncode == 1 and "Traceback" not in r.stderr
    assert "cellgl: error: internal error: TypeError: something unforeseen" in r.stderr
    r = _python(code, CELLGL_DEBUG="1")
    assert r.returncode == 1 and "Traceback" in r.stderr


# --------------------------------------------------------------------------------------------
# item 6: a scheduler file that is not there is said at once
# --------------------------------------------------------------------------------------------

@pytest.mark.parametrize("case", ["missing", "not json", "no address", "fifo"])
def test_a_bad_scheduler_file_is_refused_at_once(tmp_path, case):
    pytest.importorskip("distributed")
    f = tmp_path / "sched.json"
    if case == "not json":
        f.write_text("{tcp://")
    elif case == "no address":
        f.write_text(json.dumps({"id": "Scheduler-1"}))
    elif case == "fifo":
        os.mkfifo(f)
    words = {"missing": "no such file", "not json": "not valid JSON", "no address": '"address"',
             "fifo": "not a regular file"}[case]
    for argv in (["bake", "mountains", "-o", tmp_path / "t.zarr", "--size", "64"],
                 ["sweep", "f1", "--set", "seed=0..1", "-o", tmp_path / "sw", "--size", "16"]):
        r = _cli(*argv, "--scheduler", f, timeout=60,     # it waited for ever
                 env={**ENV, "CELLGL_SCHEDULER_WAIT": "1"})
        _refused(r, f"--scheduler {f}", words)
    assert sorted(os.listdir(tmp_path)) == ([] if case == "missing" else ["sched.json"])


def test_a_scheduler_file_written_while_waiting_is_taken(tmp_path, monkeypatch):
    """`dask scheduler --scheduler-file F &` then `cellgl bake ... --scheduler F` at once
    (docs/scale.md): the file comes a few seconds later, and is waited for, within a bound."""
    import threading

    pytest.importorskip("distributed")
    from cellgl.cli import dask as dcli
    from cellgl.dask.blocks import DaskError

    f = tmp_path / "sched.json"
    later = threading.Timer(0.5, lambda: f.write_text(json.dumps({"address": "tcp://127.0.0.1:1"})))
    later.start()
    try:
        monkeypatch.setenv("CELLGL_SCHEDULER_WAIT", "30")
        dcli.check_scheduler(str(f))
    finally:
        later.cancel()
    monkeypatch.setenv("CELLGL_SCHEDULER_WAIT", "0.3")
    with pytest.raises(DaskError, match=r"no such file.*waited 0.3 s"):
        dcli.check_scheduler(str(tmp_path / "never.json"))
    for bad in ("-1", "nan", "4000", "soon"):
        monkeypatch.setenv("CELLGL_SCHEDULER_WAIT", bad)
        with pytest.raises(DaskError, match=r"CELLGL_SCHEDULER_WAIT=.*accepted seconds in 0..3600"):
            dcli.check_scheduler(str(f))


def test_every_option_with_a_default_says_it():
    import argparse

    parser = cli.build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    missing = [(name, a.option_strings) for name, p in sub.choices.items() for a in p._actions
               if a.default not in (None, False, [], argparse.SUPPRESS) and a.help
               and not isinstance(a, (argparse._StoreTrueAction, argparse._StoreFalseAction))
               and "default" not in a.help]
    assert missing == []
