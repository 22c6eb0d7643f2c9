"""cellgl used as a hostile user would (issue 10): threads, fork, a misconfigured driver, a full
disk, signals and kills mid-bake, a bake failing half-way, and command lines that used to end in a
Python traceback. Each test failed (or hung, or crashed) before its fix."""

from __future__ import annotations

import errno
import multiprocessing
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from cellgl.gl import context

REPO = Path(__file__).resolve().parent.parent


def _python(code: str, timeout: float = 180, **env) -> subprocess.CompletedProcess:
    """``code`` in a fresh interpreter (its own GL context, signals, stdout)."""
    full_env = dict(os.environ, PYTHONPATH=str(REPO), **env)
    return subprocess.run([sys.executable, "-c", code], cwd=REPO, env=full_env,
                          capture_output=True, text=True, timeout=timeout)


def _cli(*args, timeout: float = 180, stdout=subprocess.PIPE) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "cellgl", *args], cwd=REPO, stdout=stdout,
                          stderr=subprocess.PIPE, text=True, timeout=timeout,
                          env=dict(os.environ, PYTHONPATH=str(REPO)))


def _height(seed: int = 0) -> np.ndarray:
    from cellgl import texture

    return texture.render("flagstone", 24, 16, channels=("height",) if seed == 0 else ("F1",))[
        "height" if seed == 0 else "F1"]


# --------------------------------------------------------------------------------------------
# threads
# --------------------------------------------------------------------------------------------


def _in_threads(fn, n: int = 4) -> list:
    out: list = [None] * n

    def run(i):
        try:
            out[i] = fn()
        except Exception as exc:  # noqa: BLE001 - reported by the assertion
            out[i] = exc

    threads = [threading.Thread(target=run, args=(i,)) for i in range(n)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(300)
    return out


def test_every_thread_gets_a_working_context(ctx):
    """Only the first thread that used cellgl worked ("cannot create buffer" elsewhere). Here
    the main thread holds the context outside any cellgl call (the test fixture's
    get_context()), so the other threads get private ones."""
    from cellgl.basis import core

    want = _height()
    pts = np.random.default_rng(1).random((100, 2)) * 4
    want_f = core.cellular(pts).F
    got = _in_threads(lambda: (_height(), core.cellular(pts).F))
    for res in got:
        assert not isinstance(res, Exception), repr(res)
        np.testing.assert_array_equal(res[0], want)
        np.testing.assert_array_equal(res[1], want_f)
    assert ctx.buffer(reserve=16).size == 16  # still current and usable here


def test_threads_share_one_context_in_a_fresh_process():
    """Threads that only make cellgl calls share the process's one context (no private
    ones), also after the thread that made it has ended; a thread holding it outside a call
    (get_context()) makes the others fall back to private contexts, still correct."""
    code = """
import threading, numpy as np
from cellgl.gl import context, registry
from cellgl import texture
def h(): return texture.render("flagstone", 24, 16, channels=("height",))["height"]
res = []
t = threading.Thread(target=lambda: res.append(h())); t.start(); t.join()
want = res[0]
ts = [threading.Thread(target=lambda: res.append(h())) for _ in range(4)]
[t.start() for t in ts]; [t.join() for t in ts]
assert len(res) == 5 and all((r == want).all() for r in res), "threads disagree"
assert (h() == want).all()
assert not any(st.private for _, st in registry.states()), "calls alone should share the one context"
with context.current() as c:
    c.buffer(reserve=16).release()
ctx = context.get_context()            # held by the main thread outside a call
ts = [threading.Thread(target=lambda: res.append(h())) for _ in range(2)]
[t.start() for t in ts]; [t.join() for t in ts]
assert len(res) == 7 and all((r == want).all() for r in res), "fallback threads disagree"
assert any(st.private for _, st in registry.states()), "expected private contexts while the main thread holds the shared one"
ctx.buffer(reserve=16).release()
print("ok")
"""
    r = _python(code)
    assert r.returncode == 0 and r.stdout.strip() == "ok", r.stderr[-2000:]


# --------------------------------------------------------------------------------------------
# fork
# --------------------------------------------------------------------------------------------


def _fork_child(q, exhaust: bool):
    try:
        if exhaust:  # as if every display had been used by an ancestor
            context._tainted.update({"egl", "egl-surfaceless", "glx", "osmesa"})
        q.put(("ok", _height().tobytes()))
    except Exception as exc:  # noqa: BLE001 - sent to the parent
        q.put(("error", f"{type(exc).__name__}: {exc}"))


def _run_forked(exhaust: bool = False):
    mp = multiprocessing.get_context("fork")
    q = mp.Queue()
    p = mp.Process(target=_fork_child, args=(q, exhaust))
    p.start()
    p.join(120)
    if p.is_alive():
        p.kill()
        p.join()
        pytest.fail("the forked child hung in its first GL call")
    assert p.exitcode == 0, p.exitcode
    return q.get(timeout=10)


def test_forked_child_gets_a_fresh_context(ctx):
    """A child forked after the parent used GL hung forever in prog.run (the driver's threads
    are not in the child); it now opens a display of its own and renders the same bits."""
    want = _height()
    kind, value = _run_forked()
    assert kind == "ok", value
    assert value == want.tobytes()
    np.testing.assert_array_equal(_height(), want)  # the parent is unaffected


def test_forked_child_without_a_fresh_display_gets_a_clear_error(ctx):
    _height()
    kind, value = _run_forked(exhaust=True)
    assert kind == "error"
    assert "ContextError" in value and "forked" in value and "spawn" in value


# --------------------------------------------------------------------------------------------
# a misconfigured driver
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("backend", ["", "osmesa"])
def test_misconfigured_driver_is_an_error_not_a_segfault(backend):
    """GALLIUM_DRIVER=iris on a machine without that GPU made libOSMesa segfault (exit 139)
    in the fallback; the OSMesa probe runs in a child process now."""
    env = dict(os.environ, PYTHONPATH=str(REPO), GALLIUM_DRIVER="iris", CELLGL_BACKEND=backend)
    r = subprocess.run([sys.executable, "-m", "cellgl", "info"], cwd=REPO, env=env,
                       capture_output=True, text=True, timeout=180)
    if r.returncode == 0:
        pytest.skip("this machine has a GPU the iris driver runs")
    assert r.returncode == 2, (r.returncode, r.stderr[-1000:])
    assert "cellgl: error: could not create an OpenGL context" in r.stderr
    assert "GALLIUM_DRIVER=iris" in r.stderr
    assert "Traceback" not in r.stderr


# --------------------------------------------------------------------------------------------
# a full disk
# --------------------------------------------------------------------------------------------


def _bake(path, **kw):
    from cellgl.io import bake as B

    kw.setdefault("size", (32, 32))
    kw.setdefault("progress", False)
    return B.bake("flagstone", path, **kw)


def test_npy_bake_reserves_its_space_and_reports_enospc(ctx, tmp_path, monkeypatch):
    """The .npy memory map wrote into a sparse file: a disk filling up mid-bake was a SIGBUS
    (exit 135, no message). Its blocks are reserved first; ENOSPC is a message naming the file
    and the size needed, and nothing is left behind."""
    from cellgl.io.spec import BakeError

    calls = []

    def full(fd, offset, length):
        calls.append(length)
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(os, "posix_fallocate", full)
    with pytest.raises(BakeError) as info:
        _bake(tmp_path / "vol.npy", channels=("F1",))
    msg = str(info.value)
    assert str(tmp_path / "vol.npy") in msg and "No space left on device" in msg
    assert "needs 4.1 KiB" in msg, msg          # 32 * 32 float32 + the 128-byte header
    assert calls == [32 * 32 * 4 + 128]
    assert os.listdir(tmp_path) == []


def test_free_space_check_gives_a_readable_size(ctx, tmp_path, monkeypatch):
    """The up-front check said "needs about 0.0 GiB" for anything under 50 MiB."""
    import shutil

    from cellgl.io.spec import BakeError

    monkeypatch.setattr(shutil, "disk_usage", lambda p: shutil._ntuple_diskusage(1 << 20, 1 << 20, 1000))
    with pytest.raises(BakeError, match=r"needs about 16\.0 KiB, 1000 B free"):
        _bake(tmp_path / "a.npy", size=(64, 64), channels=("F1",))
    assert os.listdir(tmp_path) == []


@pytest.fixture
def tiny_tmpfs(tmpfs):
    """A 64 KiB tmpfs (root only; skipped elsewhere)."""
    return tmpfs("64k", "tiny")


def test_npy_bake_on_a_really_full_disk(tiny_tmpfs):
    """The real thing: a 256 KiB .npy on a 64 KiB tmpfs, the free-space check fooled (as when
    another process fills the disk during the bake): an error, not a SIGBUS."""
    code = f"""
import shutil, sys
shutil.disk_usage = lambda p: shutil._ntuple_diskusage(1 << 40, 0, 1 << 40)
from cellgl import cli
sys.exit(cli.main(["bake", "flagstone", "-o", {str(tiny_tmpfs / "big.npy")!r}, "--size", "256x256",
                   "--channels", "F1", "-q"]))
"""
    r = _python(code)
    assert r.returncode == 2, (r.returncode, r.stderr[-1500:])
    assert "cellgl: error: cannot write" in r.stderr and "No space left on device" in r.stderr
    assert "needs 256.1 KiB" in r.stderr
    assert os.listdir(tiny_tmpfs) == []


# --------------------------------------------------------------------------------------------
# signals and kills mid-bake
# --------------------------------------------------------------------------------------------

_SLOW = {"npy": ["--size", "4096x2048", "--tile", "64", "--channels", "F1"],
         "tif": ["--size", "256x256x128", "--tile", "16", "--channels", "F1", "--set", "dimension=3"]}


def _terminal_signals():
    """In the child: SIGINT, SIGTERM and SIGHUP as a terminal gives them (under `nohup` or as a
    background job they are inherited ignored, and cellgl leaves an ignored signal ignored)."""
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, signal.SIG_DFL)


def _start_bake(directory: Path, fmt: str) -> subprocess.Popen:
    """A bake that takes seconds, started once its temporary files exist."""
    argv = [sys.executable, "-m", "cellgl", "bake", "flagstone", "-o", str(directory / f"out.{fmt}"),
            "-q", *_SLOW[fmt]]
    p = subprocess.Popen(argv, cwd=REPO, env=dict(os.environ, PYTHONPATH=str(REPO)),
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         preexec_fn=_terminal_signals)
    want = "spool" if fmt == "tif" else "part"
    deadline = time.monotonic() + 120
    while not any(want in n for n in os.listdir(directory)):
        if p.poll() is not None or time.monotonic() > deadline:
            p.kill()
            pytest.fail(f"the bake ended or stalled before writing: {p.communicate()[1][-1000:]}")
        time.sleep(0.05)
    time.sleep(0.3)
    assert p.poll() is None, "the bake finished before the signal: make it slower"
    return p


@pytest.mark.parametrize("sig, fmt", [(signal.SIGTERM, "npy"), (signal.SIGHUP, "tif")])
def test_term_and_hup_clean_up_like_ctrl_c(ctx, tmp_path, sig, fmt):
    """SIGTERM and SIGHUP left the .part file (and a volume's spool, 768 MiB at 512^3)."""
    p = _start_bake(tmp_path, fmt)
    p.send_signal(sig)
    _, err = p.communicate(timeout=120)
    assert p.returncode == 128 + sig, (p.returncode, err[-1000:])
    assert "Traceback" not in err
    assert os.listdir(tmp_path) == []


def test_a_later_bake_removes_what_a_killed_one_left(ctx, tmp_path):
    """SIGKILL cannot be caught: the temporary names carry pid and host, and the next bake in
    that directory removes those of processes that are gone (and nothing else)."""
    p = _start_bake(tmp_path, "tif")
    p.kill()
    p.communicate(timeout=60)
    left = sorted(os.listdir(tmp_path))
    assert any("spool" in n for n in left) and any(".part" in n for n in left), left
    other = tmp_path / ".out.cellgl-1@elsewhere.0123abcd.part.tif"  # another host's bake
    other.write_bytes(b"")
    (tmp_path / "mine.txt").write_text("kept")
    _bake(tmp_path / "small.png", size=(16, 16))
    assert sorted(os.listdir(tmp_path)) == sorted([other.name, "mine.txt", "small.png"])


def test_temporary_names_fit_in_255_bytes_whatever_the_output_name(ctx, tmp_path):
    """A 250-byte output name made a temporary name over 255 bytes (ENAMETOOLONG)."""
    name = "é" * 122 + ".png"   # 248 bytes of UTF-8
    assert len(os.fsencode(name)) == 248
    (out,) = _bake(tmp_path / name, size=(16, 16))
    assert out.name == name and os.listdir(tmp_path) == [name]
    from cellgl.io.tempfiles import temp_name

    for n in (name, "x" * 255, "a.png", "b" * 200 + "." + "e" * 50):
        tmp = temp_name(tmp_path / n)
        assert len(os.fsencode(tmp)) <= 255 and tmp.startswith("."), tmp
    from cellgl.io.spec import BakeError

    with pytest.raises(BakeError, match="is 256 bytes long; accepted at most 255"):
        _bake(tmp_path / ("y" * 252 + ".png"))


# --------------------------------------------------------------------------------------------
# several files land together or not at all
# --------------------------------------------------------------------------------------------


def test_multi_channel_bake_is_all_or_nothing(ctx, tmp_path, monkeypatch):
    """A bake failing on its second channel left the first channel's file."""
    recipes = sys.modules["cellgl.recipes"]
    render = recipes.render

    def failing(*a, **kw):
        if "height" in kw.get("channels", ()):
            raise RuntimeError("the GPU fell over")
        return render(*a, **kw)

    monkeypatch.setattr(recipes, "render", failing)
    old = tmp_path / "tex_color.png"
    old.write_bytes(b"previous")
    with pytest.raises(RuntimeError, match="fell over"):
        _bake(tmp_path / "tex.png", channels=("color", "height"))
    assert sorted(os.listdir(tmp_path)) == ["tex_color.png"]
    assert old.read_bytes() == b"previous"
    monkeypatch.setattr(recipes, "render", render)
    paths = _bake(tmp_path / "tex.png", channels=("color", "height"))
    assert sorted(p.name for p in paths) == sorted(os.listdir(tmp_path))


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


def _assert_clean_error(r: subprocess.CompletedProcess, *needles: str) -> None:
    assert r.returncode == 2, (r.returncode, r.stderr[-1500:])
    assert "Traceback" not in r.stderr, r.stderr[-1500:]
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("cellgl: error: "), r.stderr[-1500:]
    for n in needles:
        assert n in lines[0], (n, lines[0][:500])


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


def test_hostile_names_and_paths(tmp_path):
    long = "a" * 300
    _assert_clean_error(_cli("presets", long), "unknown preset", "(300 characters)")
    _assert_clean_error(_cli("bake", long, "-o", str(tmp_path / "x.png")), "unknown preset")
    _assert_clean_error(_cli("export", "flagstone", "-o", str(tmp_path / "no" / "dir" / "x.glsl")),
                        "does not exist")
    _assert_clean_error(_cli("export", "flagstone", "-o", str(tmp_path)), "is a directory")
    _assert_clean_error(_cli("export", "flagstone", "-o", str(tmp_path / (long + ".glsl"))),
                        "bytes long; accepted at most 255")
    _assert_clean_error(_cli("bake", "flagstone", "-o", str(tmp_path / (long + ".png"))),
                        "bytes long; accepted at most 255")
    assert os.listdir(tmp_path) == []


def test_export_to_a_read_only_directory(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    if os.geteuid() == 0:  # root writes through permissions: use a read-only mount
        r = subprocess.run(["mount", "-t", "tmpfs", "-o", "ro,size=16k", "tmpfs", str(ro)],
                           capture_output=True, text=True)
        if r.returncode != 0:
            pytest.skip(f"cannot mount a read-only tmpfs: {r.stderr.strip()}")
    else:
        ro.chmod(0o555)
    try:
        _assert_clean_error(_cli("export", "flagstone", "-o", str(ro / "x.glsl")), "not writable")
    finally:
        if os.geteuid() == 0:
            subprocess.run(["umount", "-l", str(ro)], capture_output=True)
        ro.chmod(0o755)


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="no /dev/full")
@pytest.mark.parametrize("argv", [["presets"], ["presets", "flagstone"], ["presets", "--params"],
                                  ["export", "flagstone"]])
def test_full_stdout(argv):
    with open("/dev/full", "w") as full:
        r = _cli(*argv, stdout=full)
    _assert_clean_error(r, "cannot write to standard output: No space left on device")


def _help_commands() -> list[list[str]]:
    from cellgl.cli import build_parser

    sub = next(a for a in build_parser()._actions if a.dest == "command")
    return [["--help"], ["--version"]] + [[name, "--help"] for name in sub.choices]


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="no /dev/full")
def test_help_and_version_to_a_full_stdout_are_an_error():
    """Issue 48: `cellgl --help > /dev/full` (and --version, every subcommand's --help) exited 0
    with nothing said (argparse drops the write's OSError): the failed write is reported, exit 2,
    as every command's output is."""
    cmds = _help_commands()
    assert len(cmds) > 10 and ["export", "--help"] in cmds
    for argv in cmds:
        with open("/dev/full", "w") as full:
            r = _cli(*argv, stdout=full)
        _assert_clean_error(r, "cannot write to standard output: No space left on device")
        assert _cli(*argv).returncode == 0, argv


def test_help_whose_flush_fails_is_an_error(monkeypatch, capsys):
    """The same where the write is buffered and the flush fails (a file on a full disk): the flush
    happens before the exit, and its error is reported."""
    import errno
    import io

    from cellgl import cli

    class Full(io.StringIO):
        def flush(self):
            if self.getvalue():
                raise OSError(errno.ENOSPC, "No space left on device")

    for argv in (["--version"], ["bake", "--help"]):
        monkeypatch.setattr(sys, "stdout", Full())
        assert cli.main(argv) == 2
        assert capsys.readouterr().err == "cellgl: error: cannot write to standard output: No space left on device\n"
    monkeypatch.setattr(sys, "stdout", io.StringIO())
    with pytest.raises(SystemExit) as e:
        cli.main(["--version"])
    assert e.value.code == 0 and sys.stdout.getvalue().startswith("cellgl ")


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
