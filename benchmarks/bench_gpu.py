#!/usr/bin/env python
"""cellgl on the GPU it runs on: every row of issue 40's table, end to end (float64 in, NumPy out)
and, where the context has timer queries, the GPU's own time for the same dispatches.

    python benchmarks/bench_gpu.py --out DIR            # full sizes (4096^2 grids, 4e6 points)
    python benchmarks/bench_gpu.py --quick --out DIR    # the smoke run: small sizes, < 60 s on llvmpipe
    python benchmarks/bench_gpu.py --fnl --out DIR      # and FastNoiseLite on every core, side by side

Writes DIR/bench_gpu.md (the table) and DIR/bench_gpu.jsonl (one JSON object per row); prints the
table. Rows:

* ``grid``: ``cellular_grid`` S^2 (a 3D slice, and 2D), F1+F2, jitter and poisson, ``outputs=("F",)``;
* ``points``: ``cellular`` on N scattered 3D points, F1+F2 jitter;
* ``features``: F + edge + n-sphere + smooth F1 (n = 1) asked together, and each alone;
* ``render``: ``cellgl.render("flagstone", S, S)`` colour; ``bake``: ``cellgl bake flagstone --size S``
  (PNG), the whole process;
* ``snippet``: the exported ``--basis f1`` jitter snippet in a fragment shader, GPU time, against a
  compact approximate 3x3 jitter F1 written here (one point per cell, 9 cells, no exactness);
* ``compile``: the first call of a shader variant in a fresh process, less its second call: cold
  (an empty shader cache), warm (the same cache again), and with every disk cache off.

Columns: ``rate`` end to end (median of ``--repeats`` after a warm-up call); ``gpu rate``: the
samples over the GPU's own time of the dispatches and draws of one call (``GL_TIME_ELAPSED``
queries around each ``ComputeShader.run`` and ``VertexArray.render``: the kernels alone, no
transfers; n/a on llvmpipe, whose queries end before its threads run the work), and ``of gpu``: the
end-to-end rate as a share of it (the goal: >= 80%);
``x FNL``: over FastNoiseLite (pyfastnoiselite, Cellular, Distance2, jitter 1) on the same
coordinates on every core (one process per core), same run.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

_REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if _REPO not in sys.path:
    sys.path.insert(0, _REPO)


# ------------------------------------------------------------------ timing

class GpuTimer:
    """Sum of the GPU's own time (``GL_TIME_ELAPSED``) of every compute dispatch and draw made
    inside ``with GpuTimer():`` on this thread; ``seconds`` None where the context has no timer
    queries. A query brackets each dispatch alone: the time the GPU spent on it, not on uploads,
    read-backs or waiting for the host."""

    def __init__(self):
        self.seconds = None
        self._queries = []

    @staticmethod
    def usable() -> bool:
        """Whether the context's timer queries time its work: not llvmpipe's, whose queries end
        before its threads have run the dispatch or rasterised the draw (they read ~0)."""
        from cellgl.gl import context

        return "llvmpipe" not in str(context.get_context().info.get("GL_RENDERER", "")).lower()

    def __enter__(self):
        import moderngl

        self._orig = (moderngl.ComputeShader.run, moderngl.VertexArray.render)
        queries = self._queries
        run, render = self._orig

        def timed(orig):
            def call(obj, *a, **k):
                try:
                    q = obj.ctx.query(time=True)
                except Exception:  # noqa: BLE001 - no timer queries: no GPU time
                    queries.append(None)
                    return orig(obj, *a, **k)
                with q:
                    res = orig(obj, *a, **k)
                queries.append(q)
                return res
            return call

        moderngl.ComputeShader.run = timed(run)
        moderngl.VertexArray.render = timed(render)
        return self

    def __exit__(self, *exc):
        import moderngl

        moderngl.ComputeShader.run, moderngl.VertexArray.render = self._orig
        if self._queries and None not in self._queries:
            self.seconds = sum(q.elapsed for q in self._queries) / 1e9
        self._queries.clear()
        return False


def timed(fn, repeats: int) -> dict:
    """Warm-up call (its time: ``first_s``), then ``repeats`` timed calls, then one call under
    :class:`GpuTimer`."""
    t0 = time.perf_counter()
    fn()
    first = time.perf_counter() - t0
    ts = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t0)
    gpu = None
    if GpuTimer.usable():
        with GpuTimer() as g:
            fn()
        gpu = g.seconds
    return dict(median_s=statistics.median(ts), best_s=min(ts), first_s=first, gpu_s=gpu)


# ------------------------------------------------------------------ FastNoiseLite

_FNL = None


def _fnl_chunk(bounds):
    from pyfastnoiselite.pyfastnoiselite import (CellularDistanceFunction, CellularReturnType,
                                                 FastNoiseLite, NoiseType)
    f = FastNoiseLite(0)
    f.noise_type = NoiseType.NoiseType_Cellular
    f.cellular_distance_function = CellularDistanceFunction.CellularDistanceFunction_Euclidean
    f.cellular_return_type = CellularReturnType.CellularReturnType_Distance2
    f.cellular_jitter = 1.0
    f.frequency = 1.0
    a, b = bounds
    return float(np.sum(f.gen_from_coords(np.ascontiguousarray(_FNL[:, a:b]))))


def fnl_rate(dim: int, S: int, repeats: int) -> dict:
    """FastNoiseLite on the S^2 grid's coordinates (as the grid rows), every core, one process each."""
    import multiprocessing as mp

    global _FNL
    N, h = S * S, 1.0 / 64
    yy, xx = np.meshgrid(0.5 * h + h * np.arange(S), 0.5 * h + h * np.arange(S), indexing="ij")
    _FNL = np.stack([xx.ravel(), yy.ravel()] + ([np.full(N, 0.37)] if dim == 3 else [])).astype(np.float32)
    P = os.cpu_count() or 1
    chunks = [(i * N // (4 * P), (i + 1) * N // (4 * P)) for i in range(4 * P)]
    with mp.get_context("fork").Pool(P) as pool:
        pool.map(_fnl_chunk, chunks[:P])
        ts = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            pool.map(_fnl_chunk, chunks)
            ts.append(time.perf_counter() - t0)
    t0 = time.perf_counter()
    _fnl_chunk((0, N // 8))
    one = (time.perf_counter() - t0) * 8
    return dict(processes=P, median_s=statistics.median(ts), Msps=N / statistics.median(ts) / 1e6,
                one_thread_Msps=N / one / 1e6)


# ------------------------------------------------------------------ rows

def rows_grid(S, repeats, fnl):
    import cellgl

    out = []
    for dim in (3, 2):
        shape = (1, S, S) if dim == 3 else (S, S)
        origin = (0.5 / 64, 0.5 / 64, 0.37)[:dim]
        ref = fnl_rate(dim, S, repeats) if fnl else None
        for dist in ("jitter", "poisson"):
            def call():
                return np.asarray(cellgl.cellular_grid(shape, origin=origin, spacing=1 / 64, n=2,
                                                       distribution=dist, outputs=("F",)).F)
            r = timed(call, repeats)
            out.append(dict(row="grid", what=f"cellular_grid {S}^2, {dim}D F1+F2 {dist}", samples=S * S,
                            fnl=ref, **r))
    return out


def rows_points(N, repeats):
    import cellgl

    pts = np.random.default_rng(0).uniform(0.0, 64.0, (N, 3))
    r = timed(lambda: np.asarray(cellgl.cellular(pts, 2, distribution="jitter", outputs=("F",)).F), repeats)
    return [dict(row="points", what=f"cellular, {N:.0e} scattered 3D points, F1+F2 jitter", samples=N, **r)]


def rows_features(S, repeats):
    import cellgl

    out = []
    kinds = [("F + edge + nsphere + smooth F1, one call", ("F", "edge", "nsphere", "smooth_F1")),
             ("F alone", ("F",)), ("edge alone", ("edge",)), ("nsphere alone", ("nsphere",)),
             ("smooth F1 alone (k 0.1)", ("smooth_F1",))]
    alone = 0.0
    for label, outs in kinds:
        def call(outs=outs):
            r = cellgl.cellular_grid((1, S, S), origin=(0.01, 0.01, 0.37), spacing=1 / 64, n=1,
                                     outputs=outs, smoothness=0.1)
            return [np.asarray(getattr(r, o)) for o in outs]
        r = timed(call, repeats)
        if len(outs) == 1:
            alone += r["median_s"]
        out.append(dict(row="features", what=f"grid {S}^2 3D: {label}", samples=S * S, **r))
    out[0]["vs_each_alone"] = alone / out[0]["median_s"]
    return out


def rows_render(S, repeats):
    import cellgl

    r = timed(lambda: cellgl.render("flagstone", S, S, channels=("color",))["color"], repeats)
    return [dict(row="render", what=f'render("flagstone", {S}, {S}) colour', samples=S * S, **r)]


def rows_bake(S, repeats):
    with tempfile.TemporaryDirectory(prefix="cellgl-bench-") as folder:     # gone afterwards
        return _rows_bake(S, repeats, os.path.join(folder, "flagstone.png"))


def _rows_bake(S, repeats, out_png):
    cmd = [sys.executable, "-m", "cellgl", "bake", "flagstone", "--size", str(S), "-o", out_png, "-q"]
    env = dict(os.environ, PYTHONPATH=_REPO + os.pathsep + os.environ.get("PYTHONPATH", ""))
    ts = []
    for _ in range(max(1, repeats)):
        t0 = time.perf_counter()
        p = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=600)
        ts.append(time.perf_counter() - t0)
        if p.returncode:
            return [dict(row="bake", what=f"cellgl bake flagstone --size {S}", error=p.stderr[-300:])]
    return [dict(row="bake", what=f"cellgl bake flagstone --size {S} (PNG, whole process)", samples=S * S,
                 median_s=statistics.median(ts), best_s=min(ts), first_s=None, gpu_s=None)]


def rows_snippet(S, repeats):
    from cellgl.export.basis import basis_export
    from cellgl.gl import context

    ctx = context.get_context()
    snippet = basis_export("f1", 2, "glsl", distribution="jitter").split("\n\n", 1)[1]
    # the comparison and the full-screen pass are bench_snippets.py's (one compact 3x3 F1 for both)
    from bench_snippets import COMPACT, VERT, frag_shader

    shaders = [("compact approximate 3x3 jitter F1 (bench_snippets.py)",
                frag_shader(COMPACT, "vec4(vec3(bench_f1(uv * 8.0)), 1.0)")),
               ("exported --basis f1 jitter snippet", frag_shader(snippet, "vec4(vec3(cellgl_f1(uv * 8.0)), 1.0)"))]
    tex = ctx.texture((S, S), 4)
    fbo = ctx.framebuffer(color_attachments=[tex])
    out = []
    for label, frag in shaders:
        prog = ctx.program(vertex_shader=VERT, fragment_shader=frag)
        prog["size"].value = (float(S), float(S))
        vao = ctx.vertex_array(prog, [])

        def draw():
            fbo.use()
            vao.render(mode=ctx.TRIANGLES, vertices=3)
            ctx.finish()
        r = timed(draw, repeats)
        out.append(dict(row="snippet", what=f"{label}, {S}^2", samples=S * S, **r))
        vao.release()
        prog.release()
    fbo.release()
    tex.release()
    if out[0]["gpu_s"] and out[1]["gpu_s"]:
        out[1]["vs_compact"] = out[0]["gpu_s"] / out[1]["gpu_s"]
    return out


_COMPILE = r"""
import json, sys, time
import numpy as np
try:
    from cellgl.gl import shadercache
    shadercache.prepare_environment()
except ImportError:
    pass
import cellgl
from cellgl.gl import context
context.get_context()
cellgl.cellular(np.zeros((4, 2)), 1, outputs=("F",))     # imports, first-use checks: not the variant's cost
x = np.random.default_rng(0).uniform(-9, 9, (64, 3))
call = lambda: cellgl.cellular(x, 3, metric="manhattan", distribution="poisson", density=2.5, outputs=("F", "id"))
t0 = time.perf_counter(); call(); t1 = time.perf_counter(); call(); t2 = time.perf_counter()
print(json.dumps(dict(first=t1 - t0, second=t2 - t1)))
"""


def rows_compile():
    """First call of one variant in a fresh process, less its second call: the drivers' own
    disk caches as they are by default (cellgl sets nothing), in an empty cache folder of their
    own (XDG_CACHE_HOME; NVIDIA's may keep to ~/.nv), then warm, then every cache off."""
    with tempfile.TemporaryDirectory(prefix="cellgl-shader-cache-") as cache:     # gone afterwards
        return _rows_compile(cache)


def _rows_compile(cache):
    base = {k: v for k, v in os.environ.items()
            if not k.startswith(("MESA_SHADER_CACHE", "__GL_SHADER_DISK_CACHE", "CELLGL_SHADER_CACHE",
                                 "CELLGL_DRIVER_SHADER_CACHE", "XDG_CACHE_HOME"))}
    base["PYTHONPATH"] = _REPO + os.pathsep + os.environ.get("PYTHONPATH", "")
    runs = [("cold (empty cache)", dict(base, XDG_CACHE_HOME=cache)),
            ("warm (the same cache, a new process)", dict(base, XDG_CACHE_HOME=cache)),
            ("every disk cache off", dict(base, XDG_CACHE_HOME=cache, CELLGL_SHADER_CACHE="0",
                                           MESA_SHADER_CACHE_DISABLE="true", __GL_SHADER_DISK_CACHE="0"))]
    out = []
    for label, env in runs:
        p = subprocess.run([sys.executable, "-c", _COMPILE], capture_output=True, text=True, env=env, timeout=300)
        try:
            t = json.loads(p.stdout.strip().splitlines()[-1])
        except (ValueError, IndexError):
            out.append(dict(row="compile", what=f"first call of a variant: {label}", error=p.stderr[-300:]))
            continue
        out.append(dict(row="compile", what=f"first call of a variant: {label}", compile_s=t["first"] - t["second"],
                        first_s=t["first"], median_s=t["second"]))
    return out


# ------------------------------------------------------------------ table

def _fmt(row) -> str:
    if "error" in row:
        return f"| {row['what']} | error: {row['error'].strip().splitlines()[-1][:80] if row['error'].strip() else '?'} | | | | |"
    if row["row"] == "compile":
        return f"| {row['what']} | {row['compile_s'] * 1e3:.0f} ms compile (first call {row['first_s'] * 1e3:.0f} ms) | | | | |"
    n, t, g = row.get("samples"), row["median_s"], row.get("gpu_s")
    rate = f"{n / t / 1e6:,.1f} M/s ({t * 1e3:.1f} ms)" if row["row"] != "bake" else f"{t:.2f} s ({n / t / 1e6:,.1f} Mpx/s)"
    grate = f"{n / g / 1e6:,.1f} M/s" if g else "n/a"
    share = f"{g / t:.0%}" if g else ""
    extra = []
    if row.get("fnl"):
        f = row["fnl"]
        extra.append(f"{(n / t / 1e6) / f['Msps']:.2f}x FNL ({f['Msps']:.1f} M/s on {f['processes']} cores, "
                     f"{f['one_thread_Msps']:.1f} on one)")
    if "vs_each_alone" in row:
        extra.append(f"{row['vs_each_alone']:.2f}x the four alone")
    if "vs_compact" in row:
        extra.append(f"{row['vs_compact']:.2f}x the compact 3x3 (GPU time)")
    first = f"{row['first_s'] * 1e3:.0f} ms" if row.get("first_s") else ""
    return f"| {row['what']} | {rate} | {grate} | {share} | {first} | {'; '.join(extra)} |"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", metavar="DIR", default=None, help="write DIR/bench_gpu.md and DIR/bench_gpu.jsonl")
    ap.add_argument("--quick", action="store_true", help="small sizes: the smoke run (< 60 s on llvmpipe)")
    ap.add_argument("--fnl", action="store_true", help="FastNoiseLite on every core beside the grid rows")
    ap.add_argument("--repeats", type=int, default=None, help="timed calls per row (default 5; --quick 2)")
    ap.add_argument("--only", default="", help="comma-separated row kinds: grid,points,features,render,bake,"
                    "snippet,compile (default all)")
    args = ap.parse_args(argv)
    q = args.quick
    reps = args.repeats or (2 if q else 5)
    sizes = dict(grid=512 if q else 4096, points=1 << 17 if q else 4_000_000, features=128 if q else 2048,
                 render=256 if q else 2048, bake=512 if q else 4096, snippet=512 if q else 4096)
    fnl = args.fnl
    if fnl:
        try:
            import pyfastnoiselite  # noqa: F401
        except ImportError:
            print("pyfastnoiselite is not installed (pip install 'cellgl[bench]'): no FastNoiseLite rows",
                  file=sys.stderr)
            fnl = False
    from cellgl.gl import context

    ctx = context.get_context()
    try:
        from cellgl.gl.path import gpu_path

        path = gpu_path(ctx)
    except Exception as exc:  # noqa: BLE001 - the table without the path's name
        path = f"? ({type(exc).__name__})"
    head = dict(row="info", renderer=ctx.info.get("GL_RENDERER"), version=ctx.info.get("GL_VERSION"),
                path=path, quick=q, repeats=reps, cores=os.cpu_count(), load=os.getloadavg()[0])
    plan = [("grid", lambda: rows_grid(sizes["grid"], reps, fnl)),
            ("points", lambda: rows_points(sizes["points"], reps)),
            ("features", lambda: rows_features(sizes["features"], reps)),
            ("render", lambda: rows_render(sizes["render"], reps)),
            ("bake", lambda: rows_bake(sizes["bake"], 1 if q else 3)),
            ("snippet", lambda: rows_snippet(sizes["snippet"], reps)),
            ("compile", rows_compile)]
    only = {s for s in args.only.split(",") if s}
    rows = []
    for name, fn in plan:
        if only and name not in only:
            continue
        t0 = time.perf_counter()
        try:
            got = fn()
        except Exception as exc:  # noqa: BLE001 - one row failing leaves the others measured
            got = [dict(row=name, what=name, error=f"{type(exc).__name__}: {exc}")]
        for r in got:
            r["section_s"] = time.perf_counter() - t0
        rows += got
    lines = [f"cellgl GPU benchmark: {head['renderer']} ({head['version']}), {head['path']} path, "
             f"{head['cores']} cores, load {head['load']:.1f}; median of {reps}{' (--quick)' if q else ''}",
             "", "| what | rate (end to end) | gpu rate | of gpu | first call | beside |",
             "| --- | ---: | ---: | ---: | ---: | --- |"]
    lines += [_fmt(r) for r in rows]
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        os.makedirs(args.out, exist_ok=True)
        with open(os.path.join(args.out, "bench_gpu.md"), "w", encoding="utf-8") as f:
            f.write(text)
        with open(os.path.join(args.out, "bench_gpu.jsonl"), "w", encoding="utf-8") as f:
            for r in [head] + rows:
                f.write(json.dumps(r, default=float) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
