"""The seam between the GPU paths (issue 39, item 2; docs/architecture.md, "The seam"): one runner per
context and path, one program cache and one registry of every GPU object of a context (dropped with
the context and at fork, nothing leaking), passes that never branch on the path, tiles that keep the
bits, integers in integer targets."""
from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
import pytest

import cellgl
from cellgl.gl import context, dispatch, moderngl_seam, registry, runner

ROOT = Path(__file__).resolve().parents[1]


def test_one_runner_per_context_and_path(ctx):
    from cellgl.gl.path import gpu_path

    r = runner.runner()
    assert r is runner.runner(ctx) and r.ctx is ctx
    assert r.path == gpu_path(ctx)
    assert registry.held(ctx).runners[r.path] is r


def test_the_layers_above_never_ask_for_the_path():
    """basis/, texture/ and pups/ describe passes; only cellgl/gl/ knows there are two paths."""
    bad = []
    for path in sorted((ROOT / "cellgl").rglob("*.py")):
        rel = path.relative_to(ROOT).as_posix()
        if rel.startswith("cellgl/gl/"):
            continue
        for k, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if re.search(r"gpu_path\(|path\(ctx\) ==|\.path == |has_compute\(", line):
                bad.append(f"{rel}:{k}: {line.strip()}")
    assert not bad, "\n".join(bad)


def test_no_table_by_context_id_and_nothing_stuck_on_moderngl_objects():
    """Everything cellgl knows of a context lives in its state (gl/registry.py, reached from the
    context object), never in a table keyed by id(ctx) (an id is reused once a context is gone)
    nor in attributes set on moderngl's objects; moderngl's internals (``mglo``) are touched only
    by gl/moderngl_seam.py."""
    bad = []
    for path in sorted((ROOT / "cellgl").rglob("*.py")):
        rel = path.relative_to(ROOT).as_posix()
        for k, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if re.search(r"\bid\(ctx\)|\._cellgl_|\bctx\._\w+\s*=[^=]", line) or \
                    (rel != "cellgl/gl/moderngl_seam.py" and re.search(r"\bmglo\b", line)):
                bad.append(f"{rel}:{k}: {line.strip()}")
    assert not bad, "\n".join(bad)


def test_one_program_cache(ctx):
    """Compute entries, fragment entries and vertex + fragment programs share the context's cache."""
    x = np.random.default_rng(0).uniform(-3, 3, (50, 2))
    cellgl.cellular(x, 1)
    cellgl.render("flagstone", 8, 8)
    programs = registry.held(ctx).programs
    kinds = {k[0] for k in programs}
    assert kinds & {"compute", "fragment"}, kinds
    n = len(programs)
    cellgl.cellular(x, 1)                                  # cached: nothing new
    assert len(programs) == n
    from cellgl.texture.evaluation import render_fragment

    render_fragment("flagstone", 8, 8)                     # the viewer's vertex + fragment program
    assert any(k[0] == "program" for k in programs)


class _Obj:
    def __init__(self, log, name):
        self.log, self.name = log, name

    def release(self):
        self.log.append(self.name)


def test_least_recently_used_programs_go_with_their_vertex_arrays(ctx):
    """A program made per recipe (a bake's) is kept among its group's last few; an older one is
    released together with its vertex array (none left behind)."""
    log = []
    for k in range(5):
        registry.cached(ctx, ("test-lru", k), lambda k=k: (_Obj(log, f"p{k}"), _Obj(log, f"v{k}")),
                        lru=("test.group", 3))
    registry.cached(ctx, ("test-lru", 2), lambda: pytest.fail("cached"), lru=("test.group", 3))
    registry.cached(ctx, ("test-lru", 5), lambda: (_Obj(log, "p5"), _Obj(log, "v5")), lru=("test.group", 3))
    assert log == ["v0", "p0", "v1", "p1", "v3", "p3"]
    held = registry.held(ctx)
    assert sorted(k[1] for k in held.programs if k[0] == "test-lru") == [2, 4, 5]
    for k in (2, 4, 5):
        held.programs.pop(("test-lru", k))
    held.groups.pop("test.group")


def test_baked_texture_programs_stay_bounded(ctx):
    from cellgl.texture import dispatch as texture_dispatch

    held = registry.held(ctx)
    for seed in range(texture_dispatch.MAX_BAKED + 3):
        cellgl.render(cellgl.load_recipe("flagstone").replace(seed=seed), 4, 4)
    assert len(held.groups["texture.baked"]) == texture_dispatch.MAX_BAKED
    assert sum(1 for k in held.groups["texture.baked"] if k in held.programs) == texture_dispatch.MAX_BAKED


def test_a_released_context_drops_its_entry(ctx):
    """A context released by its owner (the viewer's window) leaves no entry behind; drop()
    releases what cellgl held on a live one (under every backend: CELLGL_BACKEND=osmesa too)."""
    # a second context of the session's backend, made as cellgl makes it (glcontext has no
    # OSMesa backend: cellgl loads OSMesa itself)
    other = context._create(context.backend_name(ctx) or "egl")
    try:
        r = runner.runner(other)
        r.bind_words(np.arange(10, dtype=np.uint32), 7)
        assert registry.held(other).objects
    finally:
        other.release()
    registry.held(ctx)                                     # the next call sweeps
    assert registry.peek(other) is None
    another = context._create(context.backend_name(ctx) or "egl")
    try:
        runner.runner(another).bind_words(np.arange(10, dtype=np.uint32), 7)
        (_, obj), = registry.held(another).objects.values()
        runner.drop(another)
        assert registry.peek(another) is None
        assert moderngl_seam.released(obj)                         # released
    finally:
        another.release()


def test_a_render_target_is_kept_in_its_contexts_state_only(ctx):
    """A runner keeps its render targets in its own context's state (Runner.target): kept while
    the size stays, remade (the old ones released) on a new size, never another context's."""
    other = context._create(context.backend_name(ctx) or "egl")    # current here; released below
    try:
        t = runner.runner(other).target("test.targets", (4, 2))
        assert runner.runner(other).target("test.targets", (4, 2)) is t       # kept while the size stays
        assert t.fbo.ctx is other and all(x.ctx is other for x in t.textures)
        assert ("target", "test.targets") not in registry.held(ctx).objects
        t2 = runner.runner(other).target("test.targets", (8, 2))
        assert t2 is not t and t2.size == (8, 2)                             # a new size: new objects
        assert moderngl_seam.released(t.fbo) and moderngl_seam.released(t.textures[0])
    finally:
        other.release()
        context.get_context()


@pytest.mark.skipif(not hasattr(os, "fork"), reason="no fork on this platform")
def test_a_forked_child_starts_with_an_empty_registry(ctx):
    cellgl.cellular(np.zeros((4, 2)), 1)
    assert registry.states()
    pid = os.fork()
    if pid == 0:                                            # the child: never touch the parent's GL
        ok = not registry.states() and registry._orphans and registry.peek(ctx) is None
        os._exit(0 if ok else 1)
    _, status = os.waitpid(pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0
    assert registry.peek(ctx) is not None                   # the parent's states stay


def test_integer_outputs_travel_in_integer_targets():
    """The fragment path's targets: each output in targets of its own kind (an int label never in a
    float target), packed tight (R for one component, RG for two, RGBA for three or four)."""
    layout = [("values", "f", 3), ("labels", "i", 1), ("id", "u", 6), ("count", "i", 2)]
    s = dispatch.slots(layout)
    assert s == [("values", "f", 0, 3), ("labels", "i", 0, 1), ("id", "u", 0, 4), ("id", "u", 4, 2),
                 ("count", "i", 0, 2)]
    d = dispatch.pass_defines(dispatch.Flag("exact", 6), s)
    decl = d["CELL_FRAG_DECL"]
    assert "layout(location = 0) out uint o_exact;" in decl
    assert "layout(location = 1) out vec4 o_1;" in decl
    assert "layout(location = 2) out int o_2;" in decl
    assert "layout(location = 4) out uvec2 o_4;" in decl
    assert "layout(location = 5) out ivec2 o_5;" in decl
    assert "intBitsToFloat" not in (ROOT / "shaders" / "pups_samples.frag").read_text()


def test_labels_come_back_exactly_on_the_fragment_path(ctx, monkeypatch):
    """PUPs labels (-1 where no point, small integers: a NaN and denormals as float bits) are the
    compute path's and the reference's, through an integer target."""
    from cellgl import pups as P

    pos = P.poisson_disk(0.2, seed=3, periodic=False)
    rng = np.random.default_rng(4)
    pts = P.pups_points(pos, rng.random((len(pos), 3)), orientations=P.random_orientations(len(pos), seed=5))
    g = P.pups_graph(pts, 0.3)                              # supports that leave gaps: -1 there
    monkeypatch.setenv("CELLGL_PATH", "fragment")
    _, labs = P.pups_evaluate(g, 67, 45, mode="label", return_labels=True)
    _, ref = P.pups_evaluate(g, 67, 45, mode="label", return_labels=True, backend="numpy")
    assert labs.dtype == np.int32 and (labs == -1).any() and (labs >= 0).any()
    np.testing.assert_array_equal(labs, ref)


def test_tile_size_knob_is_checked(monkeypatch):
    monkeypatch.setenv("CELLGL_TILE_SAMPLES", "0")
    with pytest.raises(ValueError, match=r"CELLGL_TILE_SAMPLES='0' must be a positive integer"):
        dispatch.tile_samples(10)
    monkeypatch.setenv("CELLGL_TILE_SAMPLES", "lots")
    with pytest.raises(ValueError, match="CELLGL_TILE_SAMPLES='lots'"):
        dispatch.tile_samples(10)
    monkeypatch.setenv("CELLGL_TILE_SAMPLES", "100")
    assert dispatch.tile_samples(10) == 100


def test_tiles_keep_every_dispatch_under_the_watchdog_bound(monkeypatch):
    """A tile's work (samples x the worst loop passes of one) stays within DISPATCH_SECONDS at the
    slow GPU's rate, down to the smallest tile."""
    monkeypatch.delenv("CELLGL_TILE_SAMPLES", raising=False)
    budget = dispatch.SLOW_PASSES_PER_S * dispatch.DISPATCH_SECONDS
    for cost in (1, 64, 6144, 2 * 6144 + (1 << 17), 10 ** 5):
        n = dispatch.tile_samples(cost)
        assert 1024 <= n <= dispatch.MAX_TILE and n % 1024 == 0
        assert n * cost <= budget or n == 1024


@pytest.mark.parametrize("path", ["compute", "fragment"])
def test_tiny_tiles_give_the_same_bits(ctx, monkeypatch, path):
    """Every entry (the basis on points and grids, cell counts, a texture, PUPs) in tiles of 64
    samples gives the bits of the default tiles, on both paths."""
    from cellgl.gl.path import has_compute

    if path == "compute" and not has_compute(ctx):
        pytest.skip("no compute shaders on this context")
    from cellgl import pups as P
    from cellgl.basis import core, gpu

    monkeypatch.setenv("CELLGL_PATH", path)
    x = np.random.default_rng(1).uniform(-9.0, 9.0, (1500, 3))
    cells = np.zeros((700, 4), np.int64)
    cells[:, :2] = np.random.default_rng(2).integers(-30, 30, (700, 2))
    pos = P.poisson_disk(0.15, seed=2, periodic=True)
    g = P.pups_graph(P.pups_points(pos, np.random.default_rng(3).random((len(pos), 3)), periodic=True), 1.0)

    def run():
        r = cellgl.cellular(x, 3, outputs=("F", "id", "delta", "edge"))
        grid = cellgl.cellular_grid((41, 23, 3), spacing=0.29, n=2, outputs=("F", "id"))
        grid4 = cellgl.cellular_grid((3, 2, 2, 40), spacing=0.7, n=1, outputs=("F",))   # many short slabs
        counts = gpu.cell_counts(cells, core.make_params(2, density=1.5))
        tex = cellgl.render("flagstone", 37, 29, channels=("color", "id", "F1"))
        vals, labs = P.pups_evaluate(g, 83, 51, mode="label", return_labels=True)
        return [r.F, r.id, r.delta, r.edge, r.exact, grid.F, grid.id, grid4.F, counts[0], counts[1],
                tex["color"], tex["id"], tex["F1"], vals, labs]

    want = run()
    monkeypatch.setenv("CELLGL_TILE_SAMPLES", "64")
    got = run()
    for k, (a, b) in enumerate(zip(want, got)):
        assert a.tobytes() == b.tobytes(), k


def test_loop_probe_is_bounded(ctx):
    """The probe's counting loop is PROBE_PASSES long (past llvmpipe's limiter, not 2^30): a GPU
    without a limiter cannot hang on it; its budget is checked."""
    from cellgl.basis import core, gpu

    assert gpu.DRIVER_LOOP_LIMIT < gpu.PROBE_PASSES <= 1 << 20
    p = core.make_params(2)
    with pytest.raises(ValueError, match=r"budget must be in \[1, 2\^20\], got 1073741824"):
        gpu.loop_probe(np.zeros((4, 2)), p, 1, ("F",), budget=1 << 30)
    own, driver, flagged = gpu.loop_probe(np.random.default_rng(0).uniform(-5, 5, (64, 2)), p, 1, ("F",))
    assert (own > 0).all() and not flagged.any()


class _FakeCtx:
    def __init__(self, **info):
        self.info = info


def test_only_gpus_get_watchdog_tiles(monkeypatch):
    """A renderer on the CPU (llvmpipe) has no watchdog to reset it: its tiles are as large as
    memory asks; a GPU's are the watchdog's."""
    monkeypatch.delenv("CELLGL_TILE_SAMPLES", raising=False)
    assert not dispatch.has_watchdog(_FakeCtx(GL_RENDERER="llvmpipe (LLVM 15.0.6, 256 bits)"))
    assert dispatch.has_watchdog(_FakeCtx(GL_RENDERER="NVIDIA H200/PCIe/SSE2"))
    assert dispatch.tile_samples(6144, watchdog=False) == dispatch.MAX_TILE
    assert dispatch.tile_samples(6144) * 6144 <= dispatch.SLOW_PASSES_PER_S * dispatch.DISPATCH_SECONDS


def test_a_dispatch_stays_within_the_contexts_storage_block(ctx, monkeypatch):
    """The outputs of one dispatch fit GL_MAX_SHADER_STORAGE_BLOCK_SIZE (GL 4.3 guarantees 16 MiB);
    a chunk read back at once may hold several dispatches (ranges of one buffer)."""
    from cellgl.gl.path import has_compute

    if not has_compute(ctx):
        pytest.skip("no compute shaders on this context")
    monkeypatch.setenv("CELLGL_PATH", "compute")
    r = runner.runner(ctx)
    monkeypatch.setattr(r, "block_bytes", lambda: 1 << 16)        # 64 KiB: 2048 samples of F1..F8
    monkeypatch.setattr(r, "watchdog", False)
    seen = []
    real = r._dispatch
    monkeypatch.setattr(r, "_dispatch", lambda p, prog, chunk, stride: (seen.append(chunk[-1][1]),
                                                                       real(p, prog, chunk, stride)))
    x = np.random.default_rng(3).uniform(-9.0, 9.0, (10000, 2))
    got = cellgl.cellular(x, 8, outputs=("F",))
    assert max(seen) * 8 * 4 <= 1 << 16 and sum(seen) == 10000
    monkeypatch.undo()
    want = cellgl.cellular(x, 8, outputs=("F",))
    assert got.F.tobytes() == want.F.tobytes()


def test_work_group_defines_stay_off_the_fragment_path(ctx, monkeypatch):
    """The compute path's work-group cell cache (CELLGL_CELL_CACHE=1) is a pass's group define:
    the fragment path, which has no work groups, leaves it out (it would not link there)."""
    monkeypatch.setenv("CELLGL_PATH", "fragment")
    kw = dict(spacing=0.05, n=2, distribution="jitter", outputs=("F", "id"))
    off = cellgl.cellular_grid((150, 3), **kw)
    monkeypatch.setenv("CELLGL_CELL_CACHE", "1")
    on = cellgl.cellular_grid((150, 3), **kw)
    assert on.F.tobytes() == off.F.tobytes() and on.id.tobytes() == off.id.tobytes()


@pytest.mark.parametrize("rows", [1, 4])
def test_storage_words_are_matched_by_their_bytes_not_a_hash(ctx, monkeypatch, rows):
    """Storage words were kept by (hash(raw), len(raw)): two contents of one length whose hashes
    collide reused the stale buffer, a silently wrong answer (issue 48, item 23). Every hash made
    to collide here: the second upload must still be the one bound."""
    monkeypatch.setattr(runner, "hash", lambda raw: 0, raising=False)
    r = runner.runner(ctx)
    a = np.arange(12 * rows, dtype=np.uint32)
    a = a.reshape(-1, rows) if rows > 1 else a
    b = a[::-1].copy()
    bind = r.bind_records if rows > 1 else r.bind_words
    objs = r.held.objects
    try:
        with context.current():
            bind(a, 7)
            bind(b, 7)
            got = np.frombuffer(objs[("words", 7)][1].read(), np.uint32)[:b.size]
        assert (got == b.reshape(-1)).all()
    finally:
        registry.release_object(objs.pop(("words", 7), (None, None))[1])
