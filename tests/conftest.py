"""The one place the test suite makes an OpenGL context.

``ctx`` is session-scoped. Where no OpenGL 3.3 core context can be made the GPU tests skip, unless
``CELLGL_REQUIRE_GPU=1`` (set by ``.ci/run``), which turns the skip into a failure. Every test
that uses ``ctx`` has the GL error state checked before and after it.
"""

from __future__ import annotations

import os
import subprocess

import pytest

from xvfb import require_gpu


def pytest_collection_modifyitems(config, items):
    for item in items:
        if "ctx" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.gpu)


@pytest.fixture(scope="session")
def ctx():
    """The process-wide cellgl context (cellgl.gl.context.get_context())."""
    from cellgl.gl import context

    try:
        gl = context.get_context()
    except (context.ContextError, ValueError) as exc:
        if require_gpu():
            pytest.fail(f"CELLGL_REQUIRE_GPU=1 but no OpenGL 3.3 core context: {exc}", pytrace=False)
        pytest.skip(f"no OpenGL 3.3 core context: {exc}")
    _check_paths(gl)
    return gl


def _check_paths(gl) -> None:
    """The known-answer check of each path of the context (cellgl.basis.selfcheck) runs now, not
    on the first use inside some test that patches the GPU code. A path that fails it raises its
    PathError in the tests that use it."""
    import os

    import cellgl.basis  # noqa: F401 - registers the check
    from cellgl.gl import path

    saved = os.environ.get("CELLGL_PATH")
    try:
        for forced in ("", "fragment") if path.has_compute(gl) else ("",):
            os.environ["CELLGL_PATH"] = forced
            try:
                path.gpu_path(gl)
            except path.PathError:
                pass
    finally:
        if saved is None:
            os.environ.pop("CELLGL_PATH", None)
        else:
            os.environ["CELLGL_PATH"] = saved


@pytest.fixture(autouse=True)
def _gl_error_check(request):
    """Around every test that uses ``ctx``: no GL error before, none after."""
    if "ctx" not in request.fixturenames:
        yield
        return
    gl = request.getfixturevalue("ctx")
    from cellgl.gl import context

    context.get_context()       # current again, whatever another library made current since
    before = gl.error
    assert before == "GL_NO_ERROR", f"GL error pending before the test: {before}"
    yield
    after = gl.error
    assert after == "GL_NO_ERROR", f"test left a GL error behind: {after}"


@pytest.fixture
def compute(ctx):
    """The session context, for a test that needs compute shaders (OpenGL 4.3): skips, saying
    why, on a 3.3-4.2 context (softpipe, zink capped at 4.1, a Mac), where cellgl runs its
    fragment path."""
    from cellgl.gl.path import has_compute

    if not has_compute(ctx):
        pytest.skip(f"this OpenGL {ctx.version_code // 100}.{ctx.version_code % 100 // 10} context "
                    f"({_renderer(ctx)!r}) has no compute shaders (OpenGL 4.3): cellgl runs its "
                    "fragment path here")
    return ctx


def _renderer(gl) -> str:
    return str(gl.info.get("GL_RENDERER", ""))


#: passes of the loop that :func:`driver_loop_limit` runs: past any known limiter (llvmpipe's and
#: lavapipe's 65535), a few milliseconds where nothing cuts it
_LIMIT_PROBE_PASSES = 1 << 17


def driver_loop_limit(gl) -> int | None:
    """How many passes this driver lets one loop of a fragment shader run, measured, not guessed
    from the renderer's name (zink over lavapipe, OSMesa and the stand-in driver are llvmpipe
    underneath, softpipe is not): a loop of 2^17 passes whose length is read from a texel (no
    compiler can fold it and unroll the loop) counts its passes into a 1 x 1 integer target.
    ``None``: the loop ran whole, the driver cuts nothing. Measured once per context."""
    import numpy as np

    key = ("cellgl_loop_limit", id(gl))
    if key not in _MEASURED:
        vs = "#version 330 core\nvoid main() { gl_Position = vec4(vec2(gl_VertexID & 1, gl_VertexID >> 1) * 4.0 - 1.0, 0.0, 1.0); }\n"
        fs = ("#version 330 core\nuniform usampler2D u_n;\nout int o;\nvoid main() {\n"
              "    int n = int(texelFetch(u_n, ivec2(0, 0), 0).r);\n    int c = 0;\n"
              "    for (int k = 0; k < n; k++) { c += 1; }\n    o = c;\n}\n")
        prog = gl.program(vertex_shader=vs, fragment_shader=fs)
        tex = gl.texture((1, 1), 1, np.array([_LIMIT_PROBE_PASSES], np.uint32).tobytes(), dtype="u4")
        tex.filter = (0x2600, 0x2600)               # GL_NEAREST: an integer texture is complete only so
        target = gl.texture((1, 1), 1, dtype="i4")
        fbo = gl.framebuffer(color_attachments=[target])
        vao = gl.vertex_array(prog, [])
        try:
            fbo.use()
            fbo.viewport = (0, 0, 1, 1)
            tex.use(0)
            prog["u_n"].value = 0
            vao.render(mode=gl.TRIANGLES, vertices=3)
            ran = int(np.frombuffer(fbo.read(components=1, dtype="i4"), np.int32)[0])
        finally:
            for o in (vao, tex, prog):
                o.release()
        # the framebuffer is kept (1 x 1, one per context): releasing the bound framebuffer makes
        # moderngl bind the one bound before it, which cellgl's runner may have released since
        _MEASURED[key] = None if ran >= _LIMIT_PROBE_PASSES else ran
        _MEASURED[("cellgl_loop_limit_fbo", id(gl))] = (fbo, target)
    return _MEASURED[key]


_MEASURED: dict = {}


@pytest.fixture
def loop_limiter(ctx):
    """For the tests of a driver's own loop limiter (llvmpipe's, and lavapipe's under zink: 65535
    loop passes per SIMD vector, then every loop runs once: docs/exactness.md) and of the probe
    that measures it. The driver is recognised by what it does (:func:`driver_loop_limit`), not by
    its name. A driver that cuts no loop skips, saying why: nothing is cut there, so there is
    nothing to catch (the cut tests that need no limiter hold everywhere)."""
    from cellgl.basis import gpu

    limit = driver_loop_limit(ctx)
    if limit is None:
        pytest.skip(f"the driver here ({_renderer(ctx)!r}) ran a loop of {_LIMIT_PROBE_PASSES} passes "
                    "whole: it has no loop limiter, so there is no cut to catch")
    if abs(limit - gpu.DRIVER_LOOP_LIMIT) > 4:
        pytest.skip(f"the driver here ({_renderer(ctx)!r}) cuts loops after {limit} passes, not the "
                    f"{gpu.DRIVER_LOOP_LIMIT} these tests (and gpu.loop_probe's count) are written for")
    return ctx


def precise_in_fragment_entries(gl) -> bool:
    """Whether the fragment entries (``#version 330 core``) get ``precise`` on this context: GLSL
    4.00 or GL_ARB_gpu_shader5 (cellgl.gl.glsl.PRELUDE). The compute entries (``#version 430``)
    always have it."""
    from cellgl.gl import glsl

    key = ("cellgl_precise", id(gl))
    if key not in _PRECISE:
        vs = "#version 330 core\nin vec2 p;\nvoid main() { gl_Position = vec4(p, 0.0, 1.0); }\n"
        fs = "\n".join(["#version 330 core", *glsl.PRELUDE,
                        "#if !(__VERSION__ >= 400 || defined(GL_ARB_gpu_shader5))",
                        "#error no precise qualifier",
                        "#endif",
                        "out vec4 o;", "void main() { CELL_PRECISE float x = 1.0; o = vec4(x); }", ""])
        try:
            gl.program(vertex_shader=vs, fragment_shader=fs).release()
            _PRECISE[key] = True
        except Exception:          # moderngl.Error: the #error line
            _PRECISE[key] = False
    return _PRECISE[key]


_PRECISE: dict = {}


@pytest.fixture
def same_bits(ctx):
    """For a test that compares the two paths (or two walkers) bit for bit: docs/exactness.md
    promises that only where ``precise`` holds in every entry compiled (GLSL 4.00+, or
    GL_ARB_gpu_shader5 for the ``#version 330 core`` fragment entries). Skips elsewhere."""
    if not precise_in_fragment_entries(ctx):
        pytest.skip(f"no `precise` in the fragment entries on {_renderer(ctx)!r} (GLSL 3.30 without "
                    "GL_ARB_gpu_shader5): bit-identity between entries is not promised there")
    return ctx


@pytest.fixture
def tmpfs(tmp_path):
    """``tmpfs(size, name)``: a fresh tmpfs of ``size`` (mount's ``size=``, e.g. ``"64k"``) at
    ``tmp_path / name``, unmounted after the test: a real full disk. Root only; skipped elsewhere
    or where the mount is refused."""
    mounted = []

    def mount(size: str, name: str = "tmpfs"):
        if os.geteuid() != 0:
            pytest.skip("mounting a tmpfs needs root")
        mnt = tmp_path / name
        mnt.mkdir()
        r = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(mnt)],
                           capture_output=True, text=True)
        if r.returncode != 0:
            pytest.skip(f"cannot mount a tmpfs here: {r.stderr.strip()}")
        mounted.append(mnt)
        return mnt

    try:
        yield mount
    finally:
        for mnt in mounted:
            subprocess.run(["umount", "-l", str(mnt)], capture_output=True)
