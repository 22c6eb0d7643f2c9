"""The one place the test suite makes an OpenGL context.

``ctx`` is session-scoped. Where no OpenGL 3.3 core context can be made the GPU tests skip, unless
``CELLGL_REQUIRE_GPU=1`` (set by ``.ci/run``), which turns the skip into a failure. Every test
that uses ``ctx`` has the GL error state checked before and after it.
"""

from __future__ import annotations

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


def _renderer(gl) -> str:
    return str(gl.info.get("GL_RENDERER", ""))


@pytest.fixture
def llvmpipe(ctx):
    """For the tests of Mesa llvmpipe's own loop limiter (65535 loop passes per SIMD vector, then
    every loop runs once: docs/exactness.md) and of the probe that measures it: elsewhere they
    skip, saying why. No other driver has that limiter: nothing is cut there (so nothing to
    catch), and the probe's loop of 2^30 passes would run in full."""
    renderer = _renderer(ctx)
    if "llvmpipe" not in renderer.lower():
        pytest.skip(f"tests llvmpipe's loop limiter, which the driver here ({renderer!r}) does not have: "
                    "its loops are never cut, and the probe loop would run all its 2^30 passes")
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
