"""Context selection on each desktop platform (cellgl.gl.platforms), tested here on Linux by
patching ``sys.platform`` and glcontext's entry (``cellgl.gl.versions.glcontext_context``, which
calls glcontext's default backend: WGL on Windows, CGL on macOS), and the EGL device setting
(``CELLGL_DEVICE``)."""

from __future__ import annotations

import sys
import weakref

import pytest

from cellgl.gl import context, osmesa, platforms, registry, versions


class _FakeContext:
    """What moderngl.create_context returns, as far as get_context looks at it (a live context:
    an ``mglo`` that is no ``moderngl.InvalidObject``, cellgl.gl.moderngl_seam.released)."""

    def __init__(self, version_code: int):
        self.version_code = version_code
        self.mglo = object()

    def __enter__(self):
        return self

    def __exit__(self, *args):
        return None


@pytest.fixture
def clean_state(monkeypatch):
    """get_context's process state, fresh and restored afterwards (the session's context and
    its state stay untouched)."""
    for name, value in (("_contexts", {}), ("_opened", set()), ("_spare", {}),
                        ("_default_backend", None)):
        monkeypatch.setattr(context, name, value)
    monkeypatch.setattr(registry, "_states", weakref.WeakKeyDictionary())
    monkeypatch.delenv("CELLGL_BACKEND", raising=False)
    monkeypatch.delenv("CELLGL_PATH", raising=False)
    monkeypatch.delenv("CELLGL_DEVICE", raising=False)
    monkeypatch.delenv("GLCONTEXT_DEVICE_INDEX", raising=False)
    monkeypatch.setenv("CELLGL_SELFCHECK", "0")   # no known-answer check on stand-in contexts
    yield


def _native(monkeypatch, outcomes: dict):
    """Patch glcontext's entry: ``outcomes[version asked]`` is a version code to return, or an
    error text to raise (a version not listed raises "not this version"). Returns the list of
    calls (api, version asked, settings)."""
    calls = []

    def glcontext_context(api, code, **settings):
        calls.append((api, code, settings))
        out = outcomes.get(code, "not this version")
        if isinstance(out, str):
            raise Exception(out)  # glcontext raises bare Exception
        return _FakeContext(out)

    monkeypatch.setattr(versions, "glcontext_context", glcontext_context)
    return calls


def _no_osmesa(monkeypatch):
    monkeypatch.setattr(platforms, "osmesa_library", lambda: None)


def test_platform_tables():
    assert platforms.PLATFORM_BACKENDS["win32"][0] == "wgl"
    assert platforms.PLATFORM_BACKENDS["darwin"][0] == "cgl"
    assert platforms.PLATFORM_BACKENDS["linux"][:2] == ("egl", "glx")
    assert set(context.BACKENDS) == {b for v in platforms.PLATFORM_BACKENDS.values() for b in v}


@pytest.mark.parametrize("plat, key", [("win32", "win32"), ("cygwin", "linux"), ("darwin", "darwin"),
                                       ("linux", "linux"), ("freebsd14", "linux")])
def test_platform_key(monkeypatch, plat, key):
    monkeypatch.setattr(sys, "platform", plat)
    assert platforms.platform() == key


def test_windows_tries_wgl_first_and_lists_every_backend(monkeypatch, clean_state):
    monkeypatch.setattr(sys, "platform", "win32")
    _no_osmesa(monkeypatch)
    calls = _native(monkeypatch, {code: "wglCreateContextAttribsARB failed" for code in versions.LADDER})
    with pytest.raises(context.ContextError) as info:
        context.get_context()
    msg = str(info.value)
    lines = msg.splitlines()
    assert "on Windows" in lines[0]
    assert lines[1].startswith("  wgl: 4.6 core: wglCreateContextAttribsARB failed; 4.5 core:")
    assert lines[1].endswith("; 3.3 core: wglCreateContextAttribsARB failed")
    assert "  osmesa: skipped (libOSMesa not found)" in lines
    assert "GLCONTEXT_WIN_LIBGL" in msg and "opengl32.dll" in msg
    assert "apt-get" not in msg and "egl" not in msg.replace("GLCONTEXT", "")
    # glcontext's default backend (WGL on Windows), every rung of the ladder, newest first
    assert [c[1] for c in calls] == [460, 450, 430, 410, 330]
    assert all(c[0] == "native" and c[2] == {} for c in calls)


def test_windows_wgl_falls_back_to_33_core(monkeypatch, clean_state):
    monkeypatch.setattr(sys, "platform", "win32")
    _no_osmesa(monkeypatch)
    calls = _native(monkeypatch, {330: 330})
    ctx = context.get_context()
    assert ctx.version_code == 330
    assert context.backend_name(ctx) == "wgl"
    assert [c[1] for c in calls] == [460, 450, 430, 410, 330]
    assert context.get_context() is ctx  # cached
    assert versions.describe(ctx).startswith("4.6 refused (not this version), 4.5 refused")
    assert versions.describe(ctx).endswith("3.3 asked, got 3.3")


@pytest.mark.parametrize("gives, asked", [({460: 460}, [460]), ({430: 430}, [460, 450, 430])])
def test_windows_wgl_takes_the_first_rung_that_works(monkeypatch, clean_state, gives, asked):
    monkeypatch.setattr(sys, "platform", "win32")
    calls = _native(monkeypatch, gives)
    ctx = context.get_context()
    assert context.backend_name(ctx) == "wgl" and ctx.version_code == asked[-1]
    assert [c[1] for c in calls] == asked

    from cellgl.gl import path

    assert path.gpu_path(ctx) == "compute"


def test_macos_tries_cgl_first(monkeypatch, clean_state):
    monkeypatch.setattr(sys, "platform", "darwin")
    calls = _native(monkeypatch, {460: 410})
    ctx = context.get_context()
    assert context.backend_name(ctx) == "cgl" and ctx.version_code == 410
    # glcontext's darwin backend ignores the version and asks for GL4 core (4.1): the first rung
    # gives 4.1, accepted (every context from 3.3 up is); glcontext's default backend on macOS
    assert calls == [("native", 460, {})]

    from cellgl.gl import path

    assert path.gpu_path(ctx) == "fragment"


def test_macos_error_lists_cgl_and_osmesa(monkeypatch, clean_state):
    monkeypatch.setattr(sys, "platform", "darwin")
    monkeypatch.setattr(platforms, "osmesa_library", lambda: "/opt/mesa/libOSMesa.dylib")

    def probe():
        raise osmesa.OSMesaError("OSMesa (/opt/mesa/libOSMesa.dylib) could not create a core "
                                 "profile 4.3 context in a probe process")

    monkeypatch.setattr(osmesa, "probe", probe)
    _native(monkeypatch, {code: "cannot choose pixel format" for code in versions.LADDER})
    with pytest.raises(context.ContextError) as info:
        context.get_context()
    lines = str(info.value).splitlines()
    assert "on macOS" in lines[0]
    assert lines[1].startswith("  cgl: 4.6 core: cannot choose pixel format; 4.5 core: ")
    assert lines[2].startswith("  osmesa: OSMesa (/opt/mesa/libOSMesa.dylib)")
    assert "4.1 core" in str(info.value)


def test_linux_egl_climbs_the_ladder_on_the_chosen_device(monkeypatch, clean_state):
    calls = _native(monkeypatch, {450: 450})
    monkeypatch.setattr(platforms, "egl_devices", lambda: ["NVIDIA A", "NVIDIA B"])
    monkeypatch.setenv("CELLGL_DEVICE", "1")
    ctx = context.get_context()
    assert context.backend_name(ctx) == "egl" and ctx.version_code == 450
    assert calls == [("egl", 460, {"device_index": 1}), ("egl", 450, {"device_index": 1})]


@pytest.mark.parametrize("value, message", [
    ("2", r"CELLGL_DEVICE=2 is not an EGL device of this machine; accepted values: 0\.\.1 "
          r"\(0: NVIDIA A; 1: NVIDIA B\)"),
    ("-1", r"CELLGL_DEVICE='-1' is not an EGL device index; accepted values: 0\.\.1 \(0: NVIDIA A"),
    ("gpu1", r"CELLGL_DEVICE='gpu1' is not an EGL device index; accepted values: 0\.\.1"),
])
def test_bad_device_is_refused_naming_the_devices(monkeypatch, clean_state, value, message):
    calls = _native(monkeypatch, {450: 450})
    monkeypatch.setattr(platforms, "egl_devices", lambda: ["NVIDIA A", "NVIDIA B"])
    monkeypatch.setenv("CELLGL_DEVICE", value)
    with pytest.raises(ValueError, match=message):
        context.get_context()
    assert calls == []  # nothing was created


def test_device_needs_the_egl_backend(monkeypatch, clean_state):
    calls = _native(monkeypatch, {450: 450})
    monkeypatch.setenv("CELLGL_DEVICE", "0")
    monkeypatch.setenv("CELLGL_BACKEND", "osmesa")
    with pytest.raises(ValueError, match=r"^CELLGL_DEVICE=0 picks an EGL device, but "
                       r"the backend is osmesa on Linux: unset CELLGL_DEVICE or set CELLGL_BACKEND=egl$"):
        context.get_context()
    monkeypatch.setattr(sys, "platform", "win32")
    monkeypatch.delenv("CELLGL_BACKEND")
    with pytest.raises(ValueError, match=r"backend is wgl on Windows: unset CELLGL_DEVICE$"):
        context.get_context()
    assert calls == []


def test_device_and_glcontexts_own_setting_must_agree(monkeypatch, clean_state):
    monkeypatch.setenv("CELLGL_DEVICE", "1")
    monkeypatch.setenv("GLCONTEXT_DEVICE_INDEX", "0")
    with pytest.raises(ValueError, match="name different EGL devices; unset one of them"):
        platforms.device_setting()


@pytest.mark.parametrize("value, message", [
    ("5", r"^GLCONTEXT_DEVICE_INDEX=5 is not an EGL device of this machine; accepted values: "
          r"0\.\.1 \(0: NVIDIA A; 1: NVIDIA B\)$"),
    ("x", r"^GLCONTEXT_DEVICE_INDEX='x' is not an EGL device index; accepted values: 0\.\.1"),
    (" ", r"^GLCONTEXT_DEVICE_INDEX=' ' is not an EGL device index"),
])
def test_glcontexts_device_setting_is_checked_as_cellgls(monkeypatch, clean_state, value, message):
    """glcontext's own GLCONTEXT_DEVICE_INDEX (issue 48, item 8): a device that is not there, or
    not a number, is refused in one line, never a silent fall back to OSMesa."""
    calls = _native(monkeypatch, {450: 450})
    monkeypatch.setattr(platforms, "egl_devices", lambda: ["NVIDIA A", "NVIDIA B"])
    monkeypatch.setenv("GLCONTEXT_DEVICE_INDEX", value)
    with pytest.raises(ValueError, match=message):
        context.get_context()
    assert calls == []


def test_glcontexts_device_setting_picks_the_device_and_only_egl(monkeypatch, clean_state):
    calls = _native(monkeypatch, {450: 450})
    monkeypatch.setattr(platforms, "egl_devices", lambda: ["NVIDIA A", "NVIDIA B"])
    monkeypatch.setenv("GLCONTEXT_DEVICE_INDEX", "1")
    ctx = context.get_context()
    assert context.backend_name(ctx) == "egl"
    assert calls[-1] == ("egl", 450, {"device_index": 1})
    assert platforms.device_line(platforms.device_setting()) == "1 of 2: NVIDIA B"
    monkeypatch.setenv("CELLGL_BACKEND", "osmesa")
    with pytest.raises(ValueError, match=r"^GLCONTEXT_DEVICE_INDEX=1 picks an EGL device, but the "
                       r"backend is osmesa on Linux: unset GLCONTEXT_DEVICE_INDEX or set "):
        context.get_context()


def test_glcontexts_version_setting_is_refused(monkeypatch, clean_state):
    """GLCONTEXT_GLVERSION would make every rung of the ladder ask one version on glcontext's
    backends only (the ladder would report versions never asked): refused in one line."""
    calls = _native(monkeypatch, {450: 450})
    monkeypatch.setenv("GLCONTEXT_GLVERSION", "460")
    with pytest.raises(ValueError, match=r"^GLCONTEXT_GLVERSION='460' is set: .*; unset it$"):
        context.get_context()
    assert calls == []


@pytest.mark.parametrize("name", ["GLCONTEXT_LINUX_LIBEGL", "GLCONTEXT_LINUX_LIBGL"])
def test_a_glcontext_library_that_fails_is_no_silent_osmesa(monkeypatch, clean_state, name):
    """One of glcontext's library settings that does not load: egl failed and cellgl ran on
    OSMesa, on the CPU, without a word; now the error names the setting (issue 48, item 8's
    neighbours)."""
    calls = _native(monkeypatch, {})                   # every version: "not this version"
    monkeypatch.setattr(platforms, "osmesa_library", lambda: "/usr/lib/libOSMesa.so.8")
    monkeypatch.setattr(osmesa, "probe", lambda: pytest.fail("OSMesa was tried"))
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.setenv(name, "/nonexistent/lib.so")
    with pytest.raises(context.ContextError) as info:
        context.get_context()
    assert f"  osmesa: skipped ({name}=/nonexistent/lib.so is set: glcontext's backends only)" \
        in str(info.value).splitlines()
    assert {api for api, *_ in calls} == {"egl"}


def test_egl_devices_lists_this_machine():
    devices = platforms.egl_devices()
    if devices is None:
        pytest.skip("libEGL cannot list devices here")
    assert all(isinstance(d, str) and d for d in devices)


def test_the_mesa_software_device_names_the_driver_that_runs(monkeypatch):
    """Mesa's software EGL device runs llvmpipe, softpipe or zink, as GALLIUM_DRIVER picks: the
    device line names the renderer that runs, never llvmpipe by default (issue 50: softpipe and
    zink were reported as llvmpipe)."""
    monkeypatch.setattr(platforms, "egl_devices", lambda: ["NVIDIA CUDA device", platforms.MESA_SOFTWARE])
    assert platforms.device_line(1, "softpipe") == "1 of 2: Mesa software renderer (softpipe)"
    assert platforms.device_line(1, "zink (llvmpipe (LLVM 15.0.6, 256 bits))").endswith(
        "Mesa software renderer (zink (llvmpipe (LLVM 15.0.6, 256 bits)))")
    assert platforms.device_line(0, "NVIDIA H200/PCIe/SSE2") == "0 of 2: NVIDIA CUDA device"
    assert "llvmpipe" not in platforms.device_line(1)


def test_info_names_the_renderer_on_mesas_software_device(ctx):
    from cellgl.gl import context

    line = context.context_info(ctx)["egl_device"]
    if platforms.MESA_SOFTWARE in line:
        assert line.endswith(f"{platforms.MESA_SOFTWARE} ({ctx.info['GL_RENDERER']})"), line


@pytest.mark.parametrize("plat, name, own", [("darwin", "wgl", "cgl"), ("darwin", "egl", "cgl"),
                                             ("win32", "cgl", "wgl"), ("linux", "wgl", "egl")])
def test_another_platforms_backend_is_a_clear_error(monkeypatch, clean_state, plat, name, own):
    monkeypatch.setattr(sys, "platform", plat)
    calls = _native(monkeypatch, {})
    monkeypatch.setenv("CELLGL_BACKEND", name)
    with pytest.raises(context.ContextError) as info:
        context.get_context()
    msg = str(info.value)
    assert msg.startswith(f"CELLGL_BACKEND {name!r}: {name} is the ") and own in msg
    assert "\n" not in msg  # one line: the setting and the fix
    assert calls == []  # nothing was created
    with pytest.raises(context.ContextError, match=f"backend argument '{name}': {name} is the "):
        context.get_context(name)


def test_unknown_names_still_value_errors():
    with pytest.raises(ValueError, match=r"'metal'.*egl, glx, osmesa, wgl, cgl"):
        context.get_context("metal")


@pytest.mark.parametrize("plat, env, api", [("darwin", None, "native"), ("win32", None, "native"),
                                            ("linux", None, "egl"), ("linux", "egl", "egl"),
                                            ("linux", "glx", "native"), ("linux", "osmesa", "native")])
def test_window_api(monkeypatch, clean_state, plat, env, api):
    monkeypatch.setattr(sys, "platform", plat)
    if env:
        monkeypatch.setenv("CELLGL_BACKEND", env)
    assert context.window_api() == api


def test_window_api_follows_the_context_made(monkeypatch, clean_state):
    monkeypatch.setattr(context, "_default_backend", "glx")
    assert context.window_api() == "native"


@pytest.mark.parametrize("code, version", [(460, 430), (430, 430), (420, 420), (410, 410),
                                           (400, 400), (330, 330)])
def test_glsl_version(code, version):
    assert context.glsl_version(_FakeContext(code)) == version


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="Mesa's emulation runs on Linux")
def test_cli_info_on_a_41_core_context_runs_the_fragment_path():
    """`cellgl info` under Mesa's emulation of a Mac (4.1 core, no compute shaders)."""
    import os
    import subprocess
    from pathlib import Path

    repo = Path(__file__).resolve().parent.parent
    env = dict(os.environ, PYTHONPATH=str(repo), MESA_GL_VERSION_OVERRIDE="4.1FC",
               MESA_GLSL_VERSION_OVERRIDE="410", MESA_EXTENSION_OVERRIDE="-GL_ARB_compute_shader")
    env.pop("CELLGL_PATH", None)
    r = subprocess.run([sys.executable, "-m", "cellgl", "info"], cwd=repo, env=env,
                       capture_output=True, text=True, timeout=120)
    if r.returncode != 0 and "could not create" in r.stderr:
        pytest.skip(f"no OpenGL context here: {r.stderr.strip()}")
    assert r.returncode == 0, r.stderr
    lines = dict(line.split(": ", 1) for line in r.stdout.splitlines())
    assert lines["path"] == "fragment"
    assert lines["GL_VERSION"].startswith("4.1 (Core Profile)")
    assert lines["GL_MAX_COMPUTE_WORK_GROUP_SIZE"] == "none"


def test_lower_version_keeps_the_line_map():
    from cellgl.gl import glsl

    src = glsl.load("viewer_blit.frag")
    low = glsl.lower_version(src, 410)
    assert low.text.splitlines()[0] == "#version 410"
    assert low.text.splitlines()[1:] == src.text.splitlines()[1:]
    assert low.line_map == src.line_map
    assert glsl.lower_version(low, 430).text == low.text       # never raised
    assert glsl.lower_version(src, 430).text == src.text
