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
