"""The command line as a new user and a hostile tester met it (issue 42, third round): options that
were silently ignored, messages that named the wrong thing, commands that created missing folders
(or found them missing only after the work), a scheduler file waited on for ever, recipe names
that hid text, a pups image found from the wrong folder, logs that stayed empty. Each test failed
(or hung) before its fix."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from cellgl import cli

REPO = Path(__file__).resolve().parent.parent
ENV = dict(os.environ, PYTHONPATH=str(REPO))


def _cli(*args, cwd=REPO, timeout: float = 300, env=None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "cellgl", *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, timeout=timeout, env=env or ENV)


def _refused(r: subprocess.CompletedProcess, *words: str) -> None:
    assert r.returncode == 2, (r.returncode, r.stdout[-1000:], r.stderr[-2000:])
    assert "Traceback" not in r.stderr and "internal error" not in r.stderr, r.stderr[-2000:]
    assert all(w in r.stderr for w in words), r.stderr


def _main_refuses(capsys, argv, *words: str) -> str:
    assert cli.main([str(a) for a in argv]) == 2
    err = capsys.readouterr().err
    assert "internal error" not in err and all(w in err for w in words), err
    return err


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
# item 13 (command line): messages that named the wrong thing
# --------------------------------------------------------------------------------------------

def test_output_under_a_regular_file_names_the_file(capsys, tmp_path):
    (tmp_path / "afile").write_text("x")
    err = _main_refuses(capsys, ["bake", "f1", "-o", tmp_path / "afile" / "a.png", "--size", "16"],
                        f"'{tmp_path / 'afile'}' is a file, not a directory")
    assert "does not exist" not in err


@pytest.mark.parametrize("ext", [".webp", ".gif"])
def test_an_animated_extension_without_frames_names_frames(capsys, tmp_path, ext):
    _main_refuses(capsys, ["bake", "caustics", "-o", tmp_path / f"a{ext}", "--size", "16"],
                  f"unknown extension '{ext}'", "--frames N")


# --------------------------------------------------------------------------------------------
# item 14: one output rule for every command, checked before the work
# --------------------------------------------------------------------------------------------

#: every command that writes, as (argv before the output, the output's name, argv after)
_WRITERS = {
    "bake": (["bake", "f1", "-o"], "a.png", ["--size", "16"]),
    "frames": (["bake", "caustics", "--frames", "2", "-o"], "a.gif", ["--size", "16"]),
    "export": (["export", "f1", "-o"], "a.glsl", []),
    "voronoi": (["voronoi", "--size", "16", "-o"], "a.png", []),
    "playground": (["playground", "--preset", "f1", "--no-thumbnails", "-j", "1", "-o"], "site", []),
    "view": (["view", "flagstone", "--screenshot"], "a.png", []),
    "blender-extension": (["blender-extension", "-o"], "a.zip", []),
    "zarr": (["bake", "f1", "-o"], "t.zarr", ["--size", "16"]),
    "sweep": (["sweep", "f1", "--set", "seed=0..1", "--size", "16", "-o"], "sw", []),
}


@pytest.mark.parametrize("command", list(_WRITERS))
@pytest.mark.parametrize("case", ["missing", "file"])
def test_every_command_refuses_a_missing_or_file_parent(tmp_path, command, case):
    before, name, after = _WRITERS[command]
    if command == "view":
        for module in cli.VIEWER_EXTRA:     # without them: the message says how to install them
            pytest.importorskip(module)
    if command in ("zarr", "sweep"):
        pytest.importorskip("distributed")
    (tmp_path / "afile").write_text("x")
    parent = tmp_path / "nothere" / "deeper" if case == "missing" else tmp_path / "afile"
    env = {k: v for k, v in ENV.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    r = _cli(*before, parent / name, *after, env=env, timeout=120)
    why = f"output directory '{parent}' does not exist" if case == "missing" \
        else f"'{parent}' is a file, not a directory"
    _refused(r, why)
    assert sorted(os.listdir(tmp_path)) == ["afile"], "a folder was created"


def test_blender_extension_checks_its_folder_before_building(monkeypatch, capsys, tmp_path):
    """A read-only folder was found only after 3.6 s of building the wheel."""
    from cellgl.blender import extension

    def built(*_):
        raise AssertionError("the build started before the output folder was checked")

    monkeypatch.setattr(extension, "cellgl_wheel", built)
    real = os.access
    monkeypatch.setattr(os, "access", lambda p, mode, **kw: False if Path(p) == tmp_path and mode == os.W_OK
                        else real(p, mode, **kw))
    _main_refuses(capsys, ["blender-extension", "-o", tmp_path / "x.zip"], "is not writable")


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
