"""Context creation, limits, compute program cache, compile error mapping, `cellgl info`."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import uuid
from pathlib import Path

import numpy as np
import pytest

from cellgl.gl import context
from cellgl.gl import glsl, moderngl_seam, platforms, registry, versions

REPO = Path(__file__).resolve().parent.parent


def _pythonpath() -> str:
    """The checkout first, then what the test process had (a stand-in driver: tests/standin)."""
    return os.pathsep.join(p for p in (str(REPO), os.environ.get("PYTHONPATH", "")) if p)

TINY = """#version 430
layout(local_size_x = 64) in;
layout(std430, binding = 0) buffer Out { uint values[]; };
#include "lib/tiny.glsl"
void main() {
    uint i = gl_GlobalInvocationID.x;
    values[i] = tiny_square(i) + uint(CELL_OFFSET);
}
"""

TINY_LIB = """// a library file: no #version, no main
uint tiny_square(uint x) {
    return x * x;
}
"""

BROKEN_LIB = """// line 1
float broken() {
    return undeclared_thing;
}
"""


@pytest.fixture
def shader_root(tmp_path, monkeypatch):
    """A temporary shader dir in place of shaders/; entry names are unique (cache keys)."""
    (tmp_path / "lib").mkdir()
    (tmp_path / "lib" / "tiny.glsl").write_text(TINY_LIB)
    (tmp_path / "lib" / "broken.glsl").write_text(BROKEN_LIB)
    monkeypatch.setattr(glsl, "shader_dir", lambda: tmp_path)
    return tmp_path


def _unique(root: Path, suffix: str, text: str) -> str:
    name = f"t_{uuid.uuid4().hex[:8]}{suffix}"
    (root / name).write_text(text)
    return name


def test_context_is_core_33_or_newer(ctx):
    """cellgl needs OpenGL 3.3 core (docs/platforms.md); 4.3 only for the compute path, which the
    tests that need it ask for (the ``compute`` fixture skips elsewhere, saying why)."""
    assert ctx.version_code >= 330
    assert context.get_context() is ctx
    from cellgl.gl import path

    info = ctx.info
    enough = ctx.version_code >= 430 and min(
        info["GL_MAX_SHADER_STORAGE_BUFFER_BINDINGS"],
        info["GL_MAX_COMPUTE_SHADER_STORAGE_BLOCKS"]) >= path.storage_bindings_needed()
    assert path.has_compute(ctx) == enough


class _Limits:
    """A stand-in context: a version and the two shader-storage limits (nothing else is read)."""

    def __init__(self, version_code, bindings, blocks):
        self.version_code = version_code
        self.info = {"GL_MAX_SHADER_STORAGE_BUFFER_BINDINGS": bindings,
                     "GL_MAX_COMPUTE_SHADER_STORAGE_BLOCKS": blocks}


def test_storage_bindings_needed_is_the_highest_binding_of_the_shaders():
    import re

    from cellgl.gl import path
    from cellgl.gl.glsl import shader_dir

    found = [int(b) for f in shader_dir().rglob("*") if f.suffix in (".comp", ".glsl")
             for b in re.findall(r"binding\s*=\s*(\d+)\s*\)\s*(?:readonly\s+|writeonly\s+)?buffer",
                                 f.read_text())]
    assert found and path.storage_bindings_needed() == max(found) + 1
    assert path.storage_bindings_needed() > 8         # past OpenGL 4.3's guaranteed minimum


@pytest.mark.parametrize("bindings, blocks", [(8, 8), (80, 8), (8, 80)])
def test_a_context_at_the_storage_minimum_runs_the_fragment_path(monkeypatch, bindings, blocks):
    """OpenGL 4.3 guarantees 8 shader-storage bindings and 8 blocks in a compute shader; cellgl's
    compute entries use more, so such a conformant context must not be sent down the compute
    path (its programs would fail to link): the fragment path, and a forced compute refused
    naming the limit."""
    from cellgl.gl import path

    small = _Limits(460, bindings, blocks)
    assert not path.has_compute(small)
    why = path.compute_missing(small)
    assert "8" in why and str(path.storage_bindings_needed()) in why and "fragment path" in why
    monkeypatch.setenv("CELLGL_PATH", "compute")
    with pytest.raises(ValueError, match=r"CELLGL_PATH=compute, but this OpenGL 4\.6 context offers GL_MAX_"):
        path.gpu_path(small)
    with pytest.raises(ValueError, match="GL_MAX_"):
        path.set_path(small, "compute", "test")
    assert path.has_compute(_Limits(460, 96, 96))
    assert path.compute_missing(_Limits(410, 96, 96)) == \
        "this OpenGL 4.1 context has no compute shaders (OpenGL 4.3)"


def test_context_info_keys(ctx):
    info = context.context_info(ctx)
    for key in ("backend", "GL_VENDOR", "GL_RENDERER", "GL_VERSION", "gl_version_code",
                "GL_MAX_COMPUTE_WORK_GROUP_COUNT", "GL_MAX_COMPUTE_WORK_GROUP_SIZE",
                "GL_MAX_COMPUTE_WORK_GROUP_INVOCATIONS", "GL_MAX_SHADER_STORAGE_BLOCK_SIZE",
                "GL_MAX_COMPUTE_SHARED_MEMORY_SIZE", "gl_ladder", "egl_device", "selfcheck"):
        assert key in info, key
    # the ladder's newest rung first: a driver that gives exactly the version asked (NVIDIA's)
    # gives its highest (tests/test_versions.py)
    assert info["gl_ladder"].endswith(f"asked, got {ctx.version_code // 100}.{ctx.version_code % 100 // 10}")
    assert info["backend"] in context.BACKENDS
    from cellgl.gl import path

    if not path.has_compute(ctx):          # a 3.3-4.2 context (softpipe, a Mac): no compute limits
        assert info["GL_MAX_COMPUTE_WORK_GROUP_COUNT"] == ()
        assert info["GL_MAX_COMPUTE_WORK_GROUP_INVOCATIONS"] is None
        return
    assert len(info["GL_MAX_COMPUTE_WORK_GROUP_COUNT"]) == 3
    assert min(info["GL_MAX_COMPUTE_WORK_GROUP_SIZE"]) >= 64  # GL 4.3 minimum
    assert info["GL_MAX_COMPUTE_WORK_GROUP_INVOCATIONS"] >= 1024
    assert info["GL_MAX_SHADER_STORAGE_BLOCK_SIZE"] >= 1 << 24
    shared = info["GL_MAX_COMPUTE_SHARED_MEMORY_SIZE"]
    assert shared is None or shared >= 32768


def test_compute_program_runs_and_is_cached(compute, shader_root):
    ctx = compute
    name = _unique(shader_root, ".comp", TINY)
    prog = context.compute_program(name, {"CELL_OFFSET": 7})
    assert context.compute_program(name, {"CELL_OFFSET": 7}) is prog
    other = context.compute_program(name, {"CELL_OFFSET": 1})
    assert other is not prog

    n = 256
    buf = ctx.buffer(reserve=n * 4)
    try:
        buf.bind_to_storage_buffer(0)
        prog.run(n // 64)
        got = np.frombuffer(buf.read(), dtype=np.uint32)
    finally:
        buf.release()
    expect = np.arange(n, dtype=np.uint32) ** 2 + 7
    np.testing.assert_array_equal(got, expect)
    context.check_gl_error(ctx)


def test_compile_error_maps_to_file_and_line(compute, shader_root):
    name = _unique(shader_root, ".comp",
                   '#version 430\nlayout(local_size_x = 1) in;\n#include "lib/broken.glsl"\n'
                   "void main() {}\n")
    with pytest.raises(glsl.ShaderError) as info:
        context.compute_program(name)
    msg = str(info.value)
    assert name in msg
    # Mesa says "lib/broken.glsl:3(12): error: ..."; other drivers use other shapes, but the
    # mapped reference always reads file:line.
    assert "lib/broken.glsl:3" in msg, msg


def test_program_vertex_fragment(ctx, shader_root):
    vs = _unique(shader_root, ".vert",
                 "#version 430\nin vec2 pos;\nvoid main() { gl_Position = vec4(pos, 0.0, 1.0); }\n")
    fs = _unique(shader_root, ".frag",
                 "#version 430\nout vec4 color;\nvoid main() { color = vec4(CELL_RED, 0.0, 0.0, 1.0); }\n")
    prog = context.program(vs, fs, {"CELL_RED": 0.5})
    assert context.program(vs, fs, {"CELL_RED": 0.5}) is prog
    bad = _unique(shader_root, ".frag",
                  '#version 430\nout vec4 color;\n#include "lib/broken.glsl"\nvoid main() {}\n')
    with pytest.raises(glsl.ShaderError, match=r"lib/broken\.glsl:3"):
        context.program(vs, bad)


def test_check_gl_error_raises(ctx):
    import ctypes

    context.check_gl_error(ctx)
    addr = platforms.get_proc(context.backend_name(ctx), "glEnable")
    assert addr, "glEnable not found"
    ctypes.CFUNCTYPE(None, ctypes.c_uint)(addr)(0xFFFF)  # GL_INVALID_ENUM
    with pytest.raises(RuntimeError, match="GL_INVALID_ENUM"):
        context.check_gl_error(ctx)
    context.check_gl_error(ctx)  # reading the error cleared it


def test_unknown_backend_is_a_value_error():
    with pytest.raises(ValueError, match=r"'vulkan'.*egl, glx, osmesa"):
        context.get_context("vulkan")


def test_unknown_backend_from_env(monkeypatch):
    monkeypatch.setenv("CELLGL_BACKEND", "metal")
    with pytest.raises(ValueError, match=r"CELLGL_BACKEND.*egl, glx, osmesa"):
        context.get_context()


def _python(code: str, **env) -> subprocess.CompletedProcess:
    full_env = dict(os.environ, PYTHONPATH=_pythonpath(), **env)
    return subprocess.run([sys.executable, "-c", code], cwd=REPO, env=full_env,
                          capture_output=True, text=True, timeout=120)


def test_glx_without_display_is_a_clear_context_error():
    # In a fresh process so the session context is untouched.
    r = _python("import cellgl.gl.context as c; c.get_context('glx')", DISPLAY="")
    assert r.returncode != 0
    assert "ContextError" in r.stderr and "DISPLAY" in r.stderr
    assert "libegl-mesa0" in r.stderr and "4.3" in r.stderr and "3.3" in r.stderr


@pytest.mark.skipif(not __import__("ctypes.util").util.find_library("OSMesa"),
                    reason="libOSMesa not installed")
def test_osmesa_backend_runs_compute():
    # OSMesa makes its own context current: keep it out of the test process.
    code = (
        "import json, numpy as np, cellgl.gl.context as c\n"
        "ctx = c.get_context()\n"
        "ok = None\n"
        "if ctx.version_code >= 430:\n"
        "    cs = ctx.compute_shader('#version 430\\nlayout(local_size_x=8) in;\\n"
        "layout(std430, binding=0) buffer B { uint v[]; };\\n"
        "void main() { v[gl_GlobalInvocationID.x] = gl_GlobalInvocationID.x * 3u; }')\n"
        "    buf = ctx.buffer(reserve=64 * 4); buf.bind_to_storage_buffer(0); cs.run(8)\n"
        "    ok = bool((np.frombuffer(buf.read(), np.uint32) == np.arange(64) * 3).all())\n"
        "print(json.dumps(dict(c.context_info(ctx), ok=ok, error=ctx.error)))\n"
    )
    r = _python(code, CELLGL_BACKEND="osmesa")
    assert r.returncode == 0, r.stderr
    info = json.loads(r.stdout)
    assert info["backend"] == "osmesa"
    assert info["gl_ladder"].startswith("4.6 ")   # OSMesa climbs the same ladder
    if info["gl_version_code"] < 430:              # OSMesa over softpipe (GALLIUM_DRIVER): 3.3
        pytest.skip(f"OSMesa gives OpenGL {info['GL_VERSION']} ({info['GL_RENDERER']}) here: no "
                    "compute shaders to run (its fragment path is the other tests')")
    assert info["gl_ladder"].startswith("4.6 ")   # OSMesa climbs the same ladder
    assert info["ok"] and info["error"] == "GL_NO_ERROR"


def test_cli_info_prints_renderer(ctx):
    expected = context.context_info(ctx)
    env = dict(os.environ, PYTHONPATH=_pythonpath(), CELLGL_BACKEND=expected["backend"])
    r = subprocess.run([sys.executable, "-m", "cellgl", "info"], cwd=REPO, env=env,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    lines = dict(line.split(": ", 1) for line in r.stdout.splitlines())
    assert lines["GL_RENDERER"] == expected["GL_RENDERER"]
    assert lines["GL_VERSION"] == expected["GL_VERSION"]
    assert lines["backend"] == expected["backend"]
    from cellgl.gl import path

    assert lines["path"] == expected["path"] == path.gpu_path(ctx)  # CELLGL_PATH may force one
    assert list(lines)[:2] == ["backend", "path"]

    r = subprocess.run([sys.executable, "-m", "cellgl", "info", "--json"], cwd=REPO, env=env,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["GL_RENDERER"] == expected["GL_RENDERER"]


def test_cli_error_is_one_line_exit_2():
    env = dict(os.environ, PYTHONPATH=_pythonpath(), CELLGL_BACKEND="nonsense")
    r = subprocess.run([sys.executable, "-m", "cellgl", "info"], cwd=REPO, env=env,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2
    assert r.stderr.startswith("cellgl: error: ")
    assert "Traceback" not in r.stderr


def test_a_driver_the_check_refuses_is_a_clear_error(ctx, monkeypatch, capsys, tmp_path):
    """A driver whose every path fails the known-answer check (softpipe with its rasteriser off,
    SOFTPIPE_DEBUG=no_rast, in docs/platforms.md's table) is the driver's fault, not cellgl's:
    the command line prints PathError's message (the driver, what differed, what to do) as one
    line, exit status 2, never "internal error" (issue 50)."""
    from cellgl import cli
    from cellgl.gl import path

    msg = ("cellgl's known-answer check failed on this driver (Mesa / softpipe / 3.3): the "
           "fragment path: ...; this OpenGL 3.3 context has no other path")

    def refuse(*args, **kwargs):
        raise path.PathError(msg)
    monkeypatch.setattr(path, "gpu_path", refuse)
    out = tmp_path / "f.png"
    assert cli.main(["bake", "flagstone", "--size", "16", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err == f"cellgl: error: {msg}\n", err
    assert not out.exists()


def test_context_survives_another_library_taking_current(ctx):
    """wgpu's GL backend, a GLFW window or another moderngl context may make their own context
    current; cellgl's API calls must still work (they used to fail with 'cannot create program')."""
    import moderngl
    import numpy as np

    import cellgl
    from cellgl.gl import context

    pts = np.random.default_rng(0).uniform(0, 8, (500, 3))
    want = cellgl.cellular(pts, 2, outputs=("F",)).F
    other = moderngl.create_context(standalone=True, backend="egl", require=330)
    try:
        moderngl_seam.make_current(other)
        got = cellgl.cellular(pts, 2, outputs=("F",)).F
        assert got.tobytes() == want.tobytes()
        prog = context.get_context().program(
            vertex_shader="#version 330\nvoid main() { gl_Position = vec4(0.0); }",
            fragment_shader="#version 330\nout vec4 o;\nvoid main() { o = vec4(1.0); }")
        prog.release()
    finally:
        other.release()
        context.get_context()


# --------------------------------------------------------------------------------------------
# one state per context; what cellgl needs of moderngl beyond its public API
# --------------------------------------------------------------------------------------------


def test_one_state_holds_what_cellgl_knows_of_a_context(ctx):
    st = registry.held(ctx)
    assert registry.held(ctx) is st and registry.peek(ctx) is st and st.ctx is ctx
    assert st.backend == context.backend_name(ctx) in context.BACKENDS
    assert st.ladder and st.ladder[-1] == (st.ladder[-1][0], None)   # the rung that gave it
    assert not st.private
    from cellgl.gl import path

    path.gpu_path(ctx)
    assert st.path.results                          # the known-answer check's record
    with context.current() as c:
        assert c is ctx and st.thread is not None
    # nothing stuck on moderngl's object; its user slot (extra) left to the user
    assert ctx.extra is None and not [k for k in vars(ctx) if "cellgl" in k]


def test_moderngl_still_has_what_the_seam_uses(ctx, monkeypatch):
    """cellgl.gl.moderngl_seam is the one place that uses moderngl beyond its public API: this
    fails when a moderngl release drops what it relies on."""
    import moderngl

    assert moderngl_seam.missing(ctx) == []
    other = context._create(context.backend_name(ctx) or "egl")
    assert not moderngl_seam.released(other)
    other.release()
    assert moderngl_seam.released(other)            # how a released context is recognised
    context.get_context()                           # the session's context current again
    monkeypatch.delattr(moderngl._store, "default_context")
    assert moderngl_seam.missing(ctx) == ["_store.default_context"]   # the check can fail


def test_cellgl_leaves_the_default_moderngl_context_alone(ctx, monkeypatch):
    """moderngl.create_context makes each new context moderngl's default (what a later plain
    moderngl.create_context() returns instead of the caller's window): cellgl's stay out of it."""
    import moderngl

    mine = object()
    monkeypatch.setattr(moderngl._store, "default_context", mine)
    other = context._create(context.backend_name(ctx) or "egl")
    try:
        assert moderngl._store.default_context is mine
        assert versions.describe(other).endswith(f"got {versions.label(other.version_code)}")
    finally:
        other.release()
        context.get_context()


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="an EGL context to attach to")
def test_attach_to_the_current_egl_context(ctx):
    """The viewer's path: a moderngl context over the EGL context current on this thread (a
    window's), its default framebuffer as screen; not climbed, no backend of cellgl's."""
    import glcontext
    import moderngl

    if context.backend_name(ctx) != "egl":
        pytest.skip("the session's context is not EGL")
    before = moderngl._store.default_context
    window = glcontext.get_backend_by_name("egl")(mode="standalone", glversion=330)
    try:
        window.__enter__()
        w = context.attach_current(context.REQUIRED_GL, "egl")
        assert w.version_code >= 330 and w.screen is not None and w.fbo is not None
        assert versions.describe(w).startswith("not climbed")
        assert context.backend_name(w) is None
        assert moderngl._store.default_context is before
    finally:
        window.release()
        context.get_context()
