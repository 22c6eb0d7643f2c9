"""docs/architecture.md's pictures of the layers and the seam are what docs/make_architecture.py
draws from the code now (issue 47 item 8): they cannot drift from the import graph that
tests/test_layers.py holds, and each check here is shown able to fail."""
from __future__ import annotations

import importlib.util
import re
import subprocess
import sys
from collections import Counter
from pathlib import Path

import test_layers as TL        # tests/ is on sys.path under pytest; the generator imports the same module

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "architecture.md"


def _generator():
    spec = importlib.util.spec_from_file_location("make_architecture", ROOT / "docs" / "make_architecture.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


MA = _generator()


def _arrows(block: list[str]) -> dict[tuple[int, int], tuple[str, int]]:
    """The layers picture's arrows: (from, to) layer numbers -> (arrow, count)."""
    out = {}
    for line in block:
        m = re.fullmatch(r"  L(\d+) (-->|-\.->)\|(\d+)(?: up)?\| L(\d+)", line)
        if m:
            out[(int(m.group(1)), int(m.group(4)))] = (m.group(2), int(m.group(3)))
    return out


def test_the_doc_shows_the_picture_of_the_code_as_it_is():
    text = DOC.read_text()
    assert MA.BEGIN in text and MA.END in text, "docs/architecture.md lost its picture markers"
    assert MA.render(text) == text, f"docs/architecture.md's pictures are stale: run {MA.REFRESH}"


def test_the_staleness_check_can_fail(monkeypatch):
    """A made-up upward import changes the picture (a red dotted arrow) and so fails the check."""
    text = DOC.read_text()
    monkeypatch.setitem(TL.GRAPH, "cellgl.basis.core", TL.GRAPH["cellgl.basis.core"] | {"cellgl.texture.recipe"})
    new = MA.render(text)
    assert new != text
    basis, texture = TL._layer("cellgl.basis.core") + 1, TL._layer("cellgl.texture.recipe") + 1
    assert f"  L{basis} -.->|1 up| L{texture}" in new
    assert "1 of them run up the layers (red, dotted)" in new
    assert re.search(r"  linkStyle \d+ stroke:#d00", new)


def test_the_arrows_count_the_imports_between_layers():
    """Counted here from GRAPH on its own: one arrow per pair of layers, labelled with the number
    of module-to-module imports between them; each layer a subgraph, every module in one room."""
    want = Counter((TL._layer(m) + 1, TL._layer(d) + 1) for m, deps in TL.GRAPH.items() for d in deps
                   if TL._layer(m) != TL._layer(d))
    block = MA.layers_picture()
    assert {k: n for k, (_, n) in _arrows(block).items()} == dict(want)
    titles = re.findall(r'^  subgraph L(\d+)\["\d+ · ([^:]+): (\d+) modules?', "\n".join(block), re.M)
    assert [(int(i), name) for i, name, _ in titles] == [(i + 1, name) for i, (name, _) in
                                                          reversed(list(enumerate(TL.LAYERS)))]
    assert sum(int(n) for *_, n in titles) == len(TL.MODULES)
    rooms: list[str] = sum((ms for i in range(len(TL.LAYERS)) for _, ms in MA._rooms(i)), [])
    assert sorted(rooms) == sorted(TL.MODULES)


def test_the_seam_shows_every_import_into_gl_and_the_runner_of_each_path():
    block, _ = MA.seam_picture()
    text = "\n".join(block)
    gl = MA.gl_layer()
    want = {(m, d) for m, deps in TL.GRAPH.items() for d in deps if TL._layer(d) == gl < TL._layer(m)}
    got = set(re.findall(r"^  (m_\w+) --> (m_\w+)$", text, re.M))
    assert {(MA._id(m), MA._id(d)) for m, d in want} <= got
    assert f"{MA._id(MA.SEAM)}[[" in text and f"class {MA._id(MA.SEAM)} seam" in text
    paths = {path for _, _, path in MA.runner_classes()}
    assert paths == {"compute", "fragment"}, \
        f"the runner classes (subclasses of Runner in gl/, with a class attribute path) give {paths}"
    for m, cls, path in MA.runner_classes():
        assert f"-.->|{path}| {MA._id(m)}_{cls}" in text


def test_the_runner_classes_are_found_wherever_they_live_in_gl(tmp_path, monkeypatch):
    """A path's runner moved into a module of its own (``gl/compute.py``) is drawn from there,
    with what that module imports in gl/."""
    src = tmp_path / "compute.py"
    src.write_text("from cellgl.gl import runner as R\n"
                   "class ComputeRunner(R.Runner):\n    path = 'compute'\n"
                   "class Helper:\n    path = 'not a runner'\n")
    monkeypatch.setitem(TL.MODULES, "cellgl.gl.compute", src)
    monkeypatch.setitem(TL.GRAPH, "cellgl.gl.compute", {"cellgl.gl.dispatch", "cellgl.gl.registry"})
    monkeypatch.setitem(TL.GRAPH, MA.SEAM, TL.GRAPH[MA.SEAM] | {"cellgl.gl.compute"})
    assert ("cellgl.gl.compute", "ComputeRunner", "compute") in MA.runner_classes()
    assert not any(cls == "Helper" for _, cls, _ in MA.runner_classes())
    text = "\n".join(MA.seam_picture()[0])
    assert 'm_cellgl_gl_compute_ComputeRunner(["ComputeRunner<br>gl.compute: compute path"])' in text
    assert "m_cellgl_gl_runner --> m_cellgl_gl_compute" in text
    assert "m_cellgl_gl_compute --> m_cellgl_gl_registry" in text


def test_a_module_that_talks_to_moderngl_is_found(tmp_path, monkeypatch):
    """What counts as talking to moderngl: importing it, calling or setting a member of a
    moderngl context on a name ending in ``ctx``; not a member moderngl's context lacks."""
    src = tmp_path / "m.py"
    src.write_text("def f(self, ctx, prog):\n"
                   "    import moderngl\n"
                   "    vao = ctx.vertex_array(prog, [])\n"
                   "    self.ctx.viewport = (0, 0, 1, 1)\n"
                   "    ctx.blend_func = moderngl.ONE, moderngl.ONE\n"
                   "    ctx.out_positions()\n"            # the exporter's compile context: no GL
                   "    other.buffer(b'')\n")
    monkeypatch.setitem(TL.MODULES, "cellgl.pups.fake", src)
    assert MA.moderngl_uses("cellgl.pups.fake") == ["ctx.blend_func", "ctx.vertex_array", "ctx.viewport",
                                                    "import moderngl"]
    monkeypatch.setitem(TL.GRAPH, "cellgl.pups.fake", {"cellgl.gl.runner"})
    block, direct = MA.seam_picture()
    assert "cellgl.pups.fake" in direct
    assert re.search(rf"^  class .*\b{MA._id('cellgl.pups.fake')}\b.* direct$", "\n".join(block), re.M)
    clean = tmp_path / "clean.py"
    clean.write_text("from cellgl.gl import runner\ndef f(p):\n    return runner.runner().run(p)\n")
    monkeypatch.setitem(TL.MODULES, "cellgl.pups.fake", clean)
    assert MA.moderngl_uses("cellgl.pups.fake") == []


def test_the_picture_is_the_same_bytes_whatever_the_order_of_the_graph(monkeypatch):
    first = MA.pictures()
    for m in list(TL.GRAPH):
        monkeypatch.setitem(TL.GRAPH, m, set(sorted(TL.GRAPH[m], reverse=True)))
    reordered = dict(reversed(list(TL.GRAPH.items())))
    monkeypatch.setattr(TL, "GRAPH", reordered)
    assert MA.pictures() == first


def test_the_one_command_rewrites_and_checks(tmp_path, monkeypatch):
    """``python docs/make_architecture.py`` rewrites a stale copy; ``--check`` says it is stale
    (exit 1) and leaves the file alone."""
    stale = tmp_path / "architecture.md"
    text = DOC.read_text()
    head, _, rest = text.partition(MA.BEGIN)
    stale.write_text(head + MA.BEGIN + "an old picture\n" + MA.END + rest.partition(MA.END)[2])
    monkeypatch.setattr(MA, "DOC", stale)
    before = stale.read_text()
    assert MA.main(["--check"]) == 1 and stale.read_text() == before
    assert MA.main([]) == 0 and stale.read_text() == text
    assert MA.main(["--check"]) == 0


def test_the_command_runs_from_the_clone():
    r = subprocess.run([sys.executable, "docs/make_architecture.py", "--check"], cwd=ROOT, capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 0, r.stderr
