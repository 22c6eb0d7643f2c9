"""The one OpenGL version ladder (cellgl.gl.versions), and what it gets from a driver that gives
exactly the version asked (NVIDIA's EGL does; the stand-in: tests/exact_driver.py)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from cellgl.gl import registry, versions

REPO = Path(__file__).resolve().parent.parent
TESTS = Path(__file__).resolve().parent

linux_only = pytest.mark.skipif(not sys.platform.startswith("linux"),
                                reason="the stand-in driver sits behind Mesa's EGL (Linux)")


def test_the_ladder():
    assert versions.LADDER == (460, 450, 430, 410, 330)
    assert versions.MINIMUM == versions.LADDER[-1] == 330
    assert [versions.label(c) for c in versions.LADDER] == ["4.6", "4.5", "4.3", "4.1", "3.3"]
    assert versions.major_minor(430) == (4, 3)


class _Ctx:
    def __init__(self, code):
        self.version_code = code


def test_climb_takes_the_first_rung_that_works():
    asked = []

    def make(code):
        asked.append(code)
        if code > 430:
            raise Exception(f"no {code}\nsecond line")
        return _Ctx(code)

    ctx, tried = versions.climb(make)
    assert asked == [460, 450, 430] and ctx.version_code == 430
    assert tried == [(460, "no 460"), (450, "no 450"), (430, None)]
    assert vars(ctx) == {"version_code": 430}          # nothing stuck on the context
    assert versions.describe(ctx).startswith("not climbed")
    registry.held(ctx).ladder = tried                  # as cellgl.gl.backends keeps it
    assert versions.describe(ctx) == "4.6 refused (no 460), 4.5 refused (no 450), 4.3 asked, got 4.3"


def test_climb_keeps_every_error_when_none_works():
    def make(code):
        raise RuntimeError(f"refused {code}")

    with pytest.raises(versions.LadderError) as info:
        versions.climb(make, "egl")
    assert str(info.value) == ("egl: 4.6 core: refused 460; 4.5 core: refused 450; 4.3 core: "
                               "refused 430; 4.1 core: refused 410; 3.3 core: refused 330")
    assert [c for c, _ in info.value.attempts] == list(versions.LADDER)


def test_describe_a_context_cellgl_did_not_make():
    assert versions.describe(_Ctx(450)).startswith("not climbed")


def _info(env: dict, *args) -> subprocess.CompletedProcess:
    """`cellgl info --json` in a child process with the stand-in driver installed."""
    code = ("import sys, exact_driver; exact_driver.install()\n"
            "from cellgl.cli import main\n"
            "sys.exit(main(['info', '--json', *sys.argv[1:]]))\n")
    full = dict(os.environ, PYTHONPATH=os.pathsep.join([str(REPO), str(TESTS)]), **env)
    for key in ("CELLGL_PATH", "CELLGL_BACKEND", "CELLGL_DEVICE", "MESA_GL_VERSION_OVERRIDE"):
        if key not in env:
            full.pop(key, None)
    return subprocess.run([sys.executable, "-c", code, *args], cwd=REPO, env=full,
                          capture_output=True, text=True, timeout=300)


@linux_only
@pytest.mark.parametrize("limit, code, path", [
    ("", 450, "compute"),           # Mesa's own limit: 4.6 refused by Mesa, 4.5 given
    ("4.3", 430, "compute"),        # exactly 4.3: still compute shaders
    ("4.1", 410, "fragment"),       # an older driver: 4.1 exactly (macOS's level)
    ("3.3", 330, "fragment"),
])
def test_exact_version_driver_gets_the_highest_it_has(limit, code, path):
    """Before the ladder cellgl asked EGL for 3.3 and such a driver gave exactly 3.3: the
    fragment path on every NVIDIA machine (issue 39)."""
    r = _info({"CELLGL_TEST_DRIVER_MAX": limit})
    if r.returncode != 0 and "could not create" in r.stderr:
        pytest.skip(f"no OpenGL context here: {r.stderr.strip()}")
    assert r.returncode == 0, r.stderr
    info = json.loads(r.stdout)
    assert info["backend"] == "egl"
    assert info["gl_version_code"] == code and info["path"] == path
    assert info["GL_VERSION"].startswith(f"{versions.label(code)}.0 exact-version stand-in")
    ladder = info["gl_ladder"]
    assert ladder.startswith("4.6 refused (eglCreateContext failed (0x3009))")
    assert ladder.endswith(f"{versions.label(code)} asked, got {versions.label(code)}")
    assert ladder.count("refused") == versions.LADDER.index(code)
    assert info["selfcheck"].startswith(f"{path}: passed (")     # the known-answer check ran


@linux_only
def test_info_names_the_device_and_refuses_a_bad_one():
    r = _info({"CELLGL_DEVICE": "0"})
    if r.returncode != 0 and "could not create" in r.stderr:
        pytest.skip(f"no OpenGL context here: {r.stderr.strip()}")
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["egl_device"].startswith("0 of ")

    r = _info({"CELLGL_DEVICE": "99"})
    assert r.returncode == 2
    assert r.stderr.startswith("cellgl: error: CELLGL_DEVICE=99 is not an EGL device of this "
                               "machine; accepted values: 0..")
    assert len(r.stderr.strip().splitlines()) == 1 and "Traceback" not in r.stderr


def test_the_viewer_window_climbs_the_same_ladder():
    app = pytest.importorskip("viewer.app", reason="the viewer extra (glfw, imgui-bundle)")
    assert app.WINDOW_VERSIONS == ((4, 6), (4, 5), (4, 3), (4, 1), (3, 3))


def test_the_osmesa_probe_climbs_the_same_ladder(monkeypatch):
    from cellgl.gl import osmesa

    seen = []

    def run(argv, **kw):
        seen.append(argv)
        return subprocess.CompletedProcess(argv, 0, b"", b"")

    monkeypatch.setattr(osmesa.ctypes.util, "find_library", lambda name: "/opt/libOSMesa.so")
    monkeypatch.setattr(osmesa.subprocess, "run", run)
    monkeypatch.setattr(osmesa, "probed", {})
    assert osmesa.probe() == "/opt/libOSMesa.so"
    assert seen[0][-2:] == ["/opt/libOSMesa.so", "460,450,430,410,330"]
    # and the probe's script reads the ladder from there
    assert "sys.argv[2].split" in osmesa._PROBE


@linux_only
def test_a_context_below_the_minimum_is_refused_and_released(ctx):
    import glcontext

    from cellgl.gl import backends, context

    inner = glcontext.get_backend_by_name("egl")(mode="standalone", glversion=330)
    released = []

    class Spy:
        def load_opengl_function(self, name):
            return inner.load_opengl_function(name)

        def __enter__(self):
            return inner.__enter__()

        def __exit__(self, *args):
            return inner.__exit__(*args)

        def release(self):
            released.append(True)
            inner.release()

    try:
        with pytest.raises(backends.ContextError, match=r"^OpenGL 9\.9 core required \(.*990.*\)$"):
            backends.context_from_loader(Spy(), 990)
        assert released == [True]
    finally:
        context.get_context()        # the session's context current again
