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

_FRAMES = ["bake", "caustics", "--frames", "48", "-o", "sub/fr.png", "--size", "256"]


def _interrupt_frames(tmp: Path, delay: float) -> tuple[int, str, list[str]]:
    """Start the frames bake in ``tmp``, send SIGINT after ``delay`` s; (status, stderr, what
    is left in the output folder)."""
    (tmp / "sub").mkdir(exist_ok=True)
    p = subprocess.Popen([sys.executable, "-m", "cellgl", *_FRAMES], cwd=tmp, env=ENV,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(delay)
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=300)
    return p.returncode, err, sorted(os.listdir(tmp / "sub"))


def _interrupt_loop(tmp_path: Path, runs: int, seed: int) -> None:
    rng = random.Random(seed)
    for i in range(runs):
        # from the interpreter's start (imports) to well into the frames; a bake that finished
        # before the signal must have written all 48 frames and nothing else
        delay = rng.choice([rng.uniform(0.0, 0.6), rng.uniform(0.6, 3.0)])
        d = tmp_path / f"run{i}"
        d.mkdir()
        status, err, left = _interrupt_frames(d, delay)
        assert "Traceback" not in err, (i, delay, err[-2000:])
        if status == 0:
            assert len(left) == 48 and not any(n.startswith(".") for n in left), (i, delay, left)
            continue
        assert status == 130, (i, delay, status, err[-2000:])
        assert left == [], (i, delay, left)


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
             "--metric", "minkowski", "--exponent", "0.25", "--feature", "F2")
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
    from cellgl.io.bake import _Progress

    s = _Stream(tty=False)
    with _Progress(40, "baking x.png", True, stream=s) as bar:
        for _ in range(40):
            bar.step()
    assert "\r" not in s.text
    lines = s.text.splitlines()
    assert len(lines) == 10 and lines[-1].startswith("baking x.png: 40/40 tiles"), lines


@pytest.mark.parametrize("tty", [True, False])
def test_progress_says_interrupted(tty):
    from cellgl.io.bake import _Progress

    s = _Stream(tty=tty)
    with pytest.raises(KeyboardInterrupt):
        with _Progress(40, "baking x.png", True, stream=s) as bar:
            for _ in range(20):
                bar.step()
            raise KeyboardInterrupt
    assert s.text.endswith("interrupted\n") or s.text.endswith("interrupted at 20/40 tiles\n"), s.text
    if tty:
        assert s.text.count("\n") == 1
    else:
        assert "\r" not in s.text


def test_quiet_progress_writes_nothing():
    from cellgl.io.bake import _Progress

    s = _Stream(tty=False)
    with pytest.raises(KeyboardInterrupt):
        with _Progress(40, "baking x.png", False, stream=s) as bar:
            bar.step()
            raise KeyboardInterrupt
    assert s.text == ""
