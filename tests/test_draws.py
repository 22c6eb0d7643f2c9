"""The runner is the only code that dispatches or draws (issue 47 item 2): its draws, the path
choices a pass states, the storage words' include, and that nothing above ``gl/`` calls GL."""
from __future__ import annotations

import ast
import re
from pathlib import Path

import numpy as np
import pytest

import cellgl
from cellgl.gl import dispatch, glsl, runner

ROOT = Path(__file__).resolve().parents[1]

#: what makes or binds a GL object, compiles a program or draws, on a moderngl context or object
_GL_CALLS = {"buffer", "texture", "program", "vertex_array", "simple_vertex_array", "framebuffer",
             "simple_framebuffer", "renderbuffer", "depth_renderbuffer", "compute_shader", "render", "run",
             "enable", "disable", "enable_only", "bind_to_storage_buffer"}
#: the viewer's window code: a GLFW window and its context, ImGui's backend (docs/viewer.md)
_WINDOW_CODE = {"viewer/app.py"}


def _raw_gl(path: Path) -> list[str]:
    """``import moderngl`` and calls ``<ctx or GL object>.<GL call>(...)`` in ``path``."""
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    out = []
    for node in ast.walk(tree):
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            names = [a.name for a in node.names] + ([node.module] if isinstance(node, ast.ImportFrom) else [])
            if any(n and n.split(".")[0] == "moderngl" for n in names):
                out.append(f"{path.relative_to(ROOT)}:{node.lineno} imports moderngl")
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr in _GL_CALLS:
            owner = node.func.value
            name = owner.attr if isinstance(owner, ast.Attribute) else getattr(owner, "id", "")
            if re.fullmatch(r"ctx|gl|vao|prog|fbo|tex|_?mglo", name):
                out.append(f"{path.relative_to(ROOT)}:{node.lineno} {name}.{node.func.attr}()")
    return out


def test_nothing_above_gl_calls_moderngl():
    """No module above ``gl/`` (the viewer's window code aside) imports moderngl or makes, binds
    or draws a GL object: the runner does (Runner.draw, Runner.target, Runner.image, run)."""
    files = [p for p in sorted((ROOT / "cellgl").rglob("*.py")) if "gl" not in p.relative_to(ROOT / "cellgl").parts[:1]]
    files += [p for p in sorted((ROOT / "viewer").rglob("*.py")) if p.relative_to(ROOT).as_posix() not in _WINDOW_CODE]
    bad = [hit for p in files for hit in _raw_gl(p)]
    assert not bad, "GL calls above gl/:\n" + "\n".join(bad)


def test_the_raw_gl_check_can_fail(tmp_path, monkeypatch):
    monkeypatch.setattr(__import__(__name__), "ROOT", tmp_path)
    p = tmp_path / "m.py"
    p.write_text("import moderngl\n\ndef f(ctx):\n    vao = ctx.vertex_array(None, [])\n    vao.render()\n")
    assert len(_raw_gl(p)) == 3


def test_the_texture_generator_knows_no_path():
    """The generated texture include reads storage words through shaders/storage.glsl, the one
    file that knows how each path holds them: no path macro in what cellgl.texture writes."""
    from cellgl.texture import shader

    texts = [t for t in shader.generated_files().values()]
    texts.append(shader.glsl_baked_uniforms_file("stained-glass"))
    for t in texts:
        assert "CELL_STORAGE_ROW_BITS" not in t and "std430" not in t
    assert "cell_storage_word_6(index)" in shader.glsl_baked_uniforms_file("stained-glass")
    knows = sorted(p.relative_to(glsl.shader_dir()).as_posix() for p in glsl.shader_dir().rglob("*.glsl")
                   if "#ifdef CELL_STORAGE_ROW_BITS" in p.read_text(encoding="utf-8"))
    assert knows == ["storage.glsl"], knows


def _paths(ctx):
    from cellgl.gl.path import has_compute

    return ("compute", "fragment") if has_compute(ctx) else ("fragment",)


def test_programs_get_the_paths_storage_layout(ctx, monkeypatch):
    """Runner.program adds the path's storage layout; context.program uses the defines as given."""
    from cellgl.gl import context

    for path in _paths(ctx):
        monkeypatch.setenv("CELLGL_PATH", path)
        got = runner.runner(ctx).path_defines()
        assert ("CELL_STORAGE_ROW_BITS" in got) == (path == "fragment"), (path, got)
        prog = runner.runner(ctx).program("fullscreen.vert", "viewer_blit.frag")
        assert prog is context.program("fullscreen.vert", "viewer_blit.frag", got, ctx=ctx)


def test_stained_glass_draws_the_same_on_both_paths(ctx, monkeypatch, same_bits):
    """The cell image's words (binding 6) reach texture.frag as a storage buffer or a texture, as
    shaders/storage.glsl has them: the same pixels both ways."""
    from cellgl.texture.evaluation import render_fragment

    got = {}
    for path in _paths(ctx):
        monkeypatch.setenv("CELLGL_PATH", path)
        got[path] = render_fragment("stained-glass", 24, 16)
    assert np.ptp(got[path][..., :3]) > 0.1
    assert len({g.tobytes() for g in got.values()}) == 1


# -------------------------------------------------------------------------------------- draws



def test_full_screen_draw_and_read_back(ctx):
    """A full-screen draw of viewer_blit over an image the runner uploaded, read back whole and in
    part; the target kept while its size stays, remade when it changes."""
    r = runner.runner(ctx)
    img = np.zeros((4, 8, 4), np.float32)
    img[..., 0] = np.arange(8) / 8.0
    img[..., 1] = np.arange(4)[:, None] / 4.0
    img[..., 3] = 1.0
    tex = r.image("test.src", img)
    t = r.target("test.full", (8, 4))
    d = runner.Draw("viewer_blit.vert", "viewer_blit.frag", t, clear=(0.5, 0.5, 0.5, 0.5),
                    uniforms={"u_offset": (0.0, 0.0), "u_scale": (1.0, 1.0), "u_grid": 0.0, "u_tex": 0},
                    textures={0: runner.Sampler(tex)})
    r.draw(d)
    out = r.read(t)
    assert out.shape == (4, 8, 4) and out.dtype == np.float32
    assert np.array_equal(out[..., :3], img[..., :3]) and np.all(out[..., 3] == 1.0)
    part = r.read(t, viewport=(2, 1, 3, 2))
    assert np.array_equal(part, out[1:3, 2:5])
    assert r.target("test.full", (8, 4)) is t
    t2 = r.target("test.full", (6, 4))
    assert t2 is not t and t2.size == (6, 4)
    d.viewport, d.clear, d.target = (0, 0, 3, 4), (0.25, 0.0, 0.0, 1.0), t2
    r.draw(d)                                        # cleared whole, drawn in the viewport only
    out = r.read(t2)
    assert np.all(out[:, 3:] == (0.25, 0.0, 0.0, 1.0))
    assert np.array_equal(out[:, :3, 1], img[:, :3, 1]) and np.all(out[:, :3, 0] != 0.25)
    for key in ("test.src", "test.full"):
        r.release(key)


def _pups_graph(radius, seed):
    from cellgl import pups as P

    pos = P.poisson_disk(radius, seed=seed, periodic=True)
    vals = np.random.default_rng(seed).random(len(pos))
    return P.pups_graph(P.pups_points(pos, vals, periodic=True), 1.0)


def test_raster_draws_keep_their_buffers(ctx):
    """PUPs' raster path draws through Runner.draw: the vertex and index buffers and the vertex
    array are kept on the context (a second draw with fewer vertices reuses them), and the image
    is the compute path's, bit for bit."""
    from cellgl import pups as P
    from cellgl.gl import registry

    objs = registry.held(ctx).objects
    g = _pups_graph(0.08, 3)
    big = P.pups_evaluate(g, 64, 48, method="raster")
    kept = objs[("vertices", "pups.raster")][1]
    small = P.pups_evaluate(g, 40, 30, method="raster")      # the same polygons, fewer pixels
    assert objs[("vertices", "pups.raster")][1] is kept
    assert small.tobytes() == P.pups_evaluate(g, 40, 30, method="compute").tobytes()
    assert big.shape[:2] == (48, 64) and small.shape[:2] == (30, 40)


def _f1(monkeypatch):
    monkeypatch.setenv("CELLGL_PATH", "fragment")       # a pass that draws
    return cellgl.render("flagstone", 16, 8, channels=("F1",))["F1"].tobytes()


def test_a_draw_names_a_blend_it_does_not_know(ctx, monkeypatch):
    """Refused before any GL state changed: a pass drawn after it is not blended."""
    before = _f1(monkeypatch)
    r = runner.runner(ctx)
    t = r.target("test.blend", (4, 4))
    r.draw(runner.Draw("viewer_blit.vert", "viewer_blit.frag", t, blend="add"))    # (ONE, ONE) set
    with pytest.raises(ValueError, match="unknown blend 'max'; accepted: 'add' or None"):
        r.draw(runner.Draw("viewer_blit.vert", "viewer_blit.frag", t, blend="max"))
    r.release("test.blend")
    assert _f1(monkeypatch) == before


def test_a_pass_runs_with_no_blend_left_by_a_draw(ctx, monkeypatch):
    """A fragment-path pass draws with blending and depth test off, whatever was left on."""
    before = _f1(monkeypatch)
    ctx.enable(ctx.BLEND)
    ctx.blend_func = ctx.ONE, ctx.ONE
    try:
        assert _f1(monkeypatch) == before
    finally:
        ctx.disable(ctx.BLEND)


def test_uniform_arrays_are_cut_to_what_the_compiler_kept(ctx):
    """set_uniform writes a NumPy array whole, cut to the elements the program has (a matrix whole)."""
    prog = ctx.program(vertex_shader="#version 330 core\nuniform mat4 m; uniform vec4 a[2];\n"
                                     "void main() { gl_Position = m * a[1]; }\n",
                       fragment_shader="#version 330 core\nout vec4 c; void main() { c = vec4(1.0); }\n")
    m = np.arange(16, dtype=np.float32).reshape(4, 4)
    runner.set_uniforms(prog, {"m": m, "a": np.arange(12, dtype=np.float32).reshape(3, 4), "gone": 1.0})
    assert np.array_equal(np.frombuffer(prog["m"].read(), np.float32), m.reshape(-1))
    assert np.array_equal(np.frombuffer(prog["a"].read(), np.float32), np.arange(8, dtype=np.float32))
    prog.release()


# ------------------------------------------------------------------------------- path choices

def test_a_pass_asks_to_group_and_the_runner_decides(ctx, monkeypatch):
    """PUPs asks to keep work groups inside grid cells (Pass.group_defines, Image.group_align);
    the compute runner does, the fragment runner has no work groups: each tells the pass's check
    which layout runs, and PUPs checks its loop budget for that one."""
    from cellgl import pups as P
    from cellgl.pups import gpu as G

    seen = []
    real = G._check_budget
    monkeypatch.setattr(G, "_check_budget", lambda packed, grouped: seen.append(grouped) or real(packed, grouped))
    g = _pups_graph(0.1, 2)
    for path in _paths(ctx):
        monkeypatch.setenv("CELLGL_PATH", path)
        seen.clear()
        P.pups_evaluate(g, 32, 32, method="compute")
        assert seen == [path == "compute"], (path, seen)
        p = dispatch.Pass("pups.comp", "pups_samples.frag", {}, 0, dispatch.Image(8, 8), [])
        assert not runner.runner(ctx).grouped(p)                     # not asked: never
        p.group_defines = {}
        assert runner.runner(ctx).grouped(p) == (path == "compute")
