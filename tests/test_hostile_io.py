"""cellgl used as a hostile user would (issue 10): threads, fork, a misconfigured driver, a full
disk, signals and kills mid-bake, a bake failing half-way, and command lines that used to end in a
Python traceback. Each test failed (or hung, or crashed) before its fix."""

from __future__ import annotations

import errno
import json
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


def _cli(*args, timeout: float = 180, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "cellgl", *args], cwd=REPO, capture_output=True,
                          text=True, timeout=timeout, env=dict(os.environ, PYTHONPATH=str(REPO)),
                          **kw)


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
from cellgl.gl import context
from cellgl import texture
def h(): return texture.render("flagstone", 24, 16, channels=("height",))["height"]
res = []
t = threading.Thread(target=lambda: res.append(h())); t.start(); t.join()
want = res[0]
ts = [threading.Thread(target=lambda: res.append(h())) for _ in range(4)]
[t.start() for t in ts]; [t.join() for t in ts]
assert len(res) == 5 and all((r == want).all() for r in res), "threads disagree"
assert (h() == want).all()
assert not context._private, "calls alone should share the one context"
with context.current() as c:
    c.buffer(reserve=16).release()
ctx = context.get_context()            # held by the main thread outside a call
ts = [threading.Thread(target=lambda: res.append(h())) for _ in range(2)]
[t.start() for t in ts]; [t.join() for t in ts]
assert len(res) == 7 and all((r == want).all() for r in res), "fallback threads disagree"
assert context._private, "expected private contexts while the main thread holds the shared one"
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
    assert "cellgl: error: could not create an OpenGL 4.3 context" in r.stderr
    assert "GALLIUM_DRIVER=iris" in r.stderr
    assert "Traceback" not in r.stderr
