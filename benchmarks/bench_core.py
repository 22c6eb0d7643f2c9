#!/usr/bin/env python
"""Throughput benchmark: cellgl vs FastNoiseLite vs libvips worley.

Prints one table (samples per second, and ratios against the competitor
rows for the same dimension / number of features).  See benchmarks/README.md.

    python benchmarks/bench_core.py            # full run (1e6 points)
    python benchmarks/bench_core.py --quick    # smoke run (~seconds)
    python benchmarks/bench_core.py --markdown # emit a markdown table

Every library is optional: a missing or failing library produces rows marked
"error"/"skipped" and the rest of the table is still measured.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
import traceback
from dataclasses import dataclass, field

import numpy as np

# Run from a checkout without installing: make `import cellgl` find the repo.
_REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if _REPO not in sys.path:
    sys.path.insert(0, _REPO)

DOMAIN = 64.0  # random points are uniform in [0, DOMAIN)^d
VIPS_MEAN_POINTS = 5.0  # libvips worley: 1..9 (uniform) feature points per cell


# --------------------------------------------------------------------------- #
# timing / rows
# --------------------------------------------------------------------------- #
def best_time(fn, repeats: int, warmup=None) -> float:
    """Best wall time of `repeats` calls of fn(), after one warm-up call."""
    (warmup or fn)()
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def best_times(rows: dict, repeats: int) -> dict:
    """Best wall time of each of ``rows`` (name -> fn) over ``repeats`` rounds, the rows taken in
    turn within each round, so that a change of the machine's load falls on every row alike (a
    side-by-side comparison); warm-ups are the caller's."""
    best = {k: float("inf") for k in rows}
    for _ in range(repeats):
        for k, fn in rows.items():
            t0 = time.perf_counter()
            fn()
            best[k] = min(best[k], time.perf_counter() - t0)
    return best


def seconds_table(best: dict) -> str:
    """``best`` (name -> seconds) as a markdown table."""
    return "\n".join(["| what | seconds |", "| --- | ---: |"] + [f"| {k} | {v:.2f} |" for k, v in best.items()])


@dataclass
class Row:
    library: str
    backend: str
    dim: int
    n: int  # number of F values (1 = F1, 2 = F1..F2 / FNL Distance2, ...)
    distribution: str
    count: int  # samples per call
    kind: str = "points"  # "points" (scattered) or "grid"
    rate: float | None = None  # samples / s
    note: str = ""
    ratios: dict = field(default_factory=dict)


def run_row(row: Row, fn, repeats: int, warmup=None) -> Row:
    try:
        t = best_time(fn, repeats, warmup)
        row.rate = row.count / t
    except Exception as exc:  # keep going: one broken row must not kill the table
        row.note = f"error: {type(exc).__name__}: {exc}".splitlines()[0][:120]
        if os.environ.get("CELLGL_BENCH_TRACEBACK"):
            traceback.print_exc()
    return row


# --------------------------------------------------------------------------- #
# FastNoiseLite
# --------------------------------------------------------------------------- #
def fnl_rows(pts_by_dim, grid_coords, repeats):
    rows = []
    try:
        from pyfastnoiselite.pyfastnoiselite import (
            CellularDistanceFunction,
            CellularReturnType,
            FastNoiseLite,
            NoiseType,
        )
    except Exception as exc:
        for d in (2, 3):
            for n in (1, 2):
                rows.append(Row("FastNoiseLite", "cpu-1thread", d, n, "jitter(FNL)",
                                0, note=f"skipped: {exc}"))
        return rows

    def make(n):
        f = FastNoiseLite(0)
        f.noise_type = NoiseType.NoiseType_Cellular
        f.cellular_distance_function = CellularDistanceFunction.CellularDistanceFunction_Euclidean
        f.cellular_return_type = (CellularReturnType.CellularReturnType_Distance if n == 1
                                  else CellularReturnType.CellularReturnType_Distance2)
        f.cellular_jitter = 1.0
        f.frequency = 1.0  # default is 0.01 -- we want one feature cell per unit
        return f

    for d in (2, 3):  # FNL has no 4D noise
        # FNL wants a C-contiguous float32 (d, N) array; conversion is not timed
        # (cellgl's float64 -> float32 upload is timed; it is cheap either way).
        coords = np.ascontiguousarray(pts_by_dim[d].T, dtype=np.float32)
        for n in (1, 2):
            f = make(n)
            rows.append(run_row(
                Row("FastNoiseLite", "cpu-1thread", d, n, "jitter(FNL)", coords.shape[1]),
                lambda f=f, c=coords: f.gen_from_coords(c), repeats))
    if grid_coords is not None:
        f = make(1)
        rows.append(run_row(
            Row("FastNoiseLite", "cpu-1thread", 2, 1, "jitter(FNL)", grid_coords.shape[1],
                kind="grid"),
            lambda: f.gen_from_coords(grid_coords), repeats))
    return rows


# --------------------------------------------------------------------------- #
# libvips
# --------------------------------------------------------------------------- #
def vips_rows(grid, cell_size, repeats):
    try:
        import pyvips
    except Exception as exc:
        return [Row("libvips worley", "cpu", 2, 1, "1-9/cell", grid * grid, kind="grid",
                    note=f"skipped: {exc}")]
    threads = pyvips.concurrency_get() if hasattr(pyvips, "concurrency_get") else "?"
    row = Row("libvips worley", f"cpu-{threads}thread", 2, 1, "1-9/cell", grid * grid,
              kind="grid", note=f"cell_size={cell_size}")
    kw = {"cell_size": cell_size, "seed": 0}
    try:
        pyvips.Image.worley(8, 8, **kw)
    except Exception:  # older libvips (< 8.13) has no `seed` argument
        kw.pop("seed")
    # .numpy() forces evaluation of the lazy pipeline (and copies to an array).
    return [run_row(row, lambda: pyvips.Image.worley(grid, grid, **kw).numpy(), repeats)]


# --------------------------------------------------------------------------- #
# cellgl
# --------------------------------------------------------------------------- #
def cellgl_rows(pts_by_dim, ref_pts_by_dim, grid, cell_size, repeats, ref_repeats,
                density, ns, dists, backends):
    rows = []
    try:
        import cellgl
        err = None
        missing = [f for f in ("cellular", "cellular_grid") if not hasattr(cellgl, f)]
        if missing:
            err = f"skipped: cellgl has no {', '.join(missing)}"
    except Exception as exc:
        cellgl, err = None, f"skipped: import cellgl failed: {type(exc).__name__}: {exc}"

    extra = {} if density is None else {"density": density}

    for backend in backends:
        src = pts_by_dim if backend == "gpu" else ref_pts_by_dim
        reps = repeats if backend == "gpu" else ref_repeats
        for d in (2, 3, 4):
            pts = src[d]
            for dist in dists:
                for n in ns:
                    row = Row("cellgl", backend, d, n, dist, len(pts))
                    if err:
                        row.note = err
                        rows.append(row)
                        continue

                    def call(p, n=n, dist=dist, backend=backend):
                        r = cellgl.cellular(p, n=n, distribution=dist, jitter=1.0, seed=0,
                                            outputs=("F",), backend=backend, **extra)
                        F = np.asarray(r.F)
                        if F.shape != (len(p), n):
                            raise RuntimeError(f"F has shape {F.shape}, want {(len(p), n)}")
                        return F

                    warm = pts[: min(len(pts), 4096)]
                    rows.append(run_row(row, lambda p=pts, call=call: call(p), reps,
                                        warmup=lambda w=warm, call=call: call(w)))

    # 2-D grid, F1, same pixel count as the libvips row.  One cellgl unit cell
    # is mapped onto one libvips cell (spacing = 1/cell_size) and, for the
    # poisson row, the mean feature count per cell is matched to libvips' 5.
    if grid and "gpu" in backends:
        for dist, kw in (("poisson", {"density": VIPS_MEAN_POINTS}), ("jitter", extra)):
            row = Row("cellgl", "gpu", 2, 1, dist, grid * grid, kind="grid",
                      note=f"spacing=1/{cell_size}"
                      + (f", density={kw['density']:g}" if "density" in kw else ""))
            if err:
                row.note = err
                rows.append(row)
                continue
            s = 1.0 / cell_size

            def gcall(shape, dist=dist, kw=kw, s=s):
                try:
                    r = cellgl.cellular_grid(shape, origin=(0.0, 0.0), spacing=(s, s), n=1,
                                             distribution=dist, jitter=1.0, seed=0,
                                             outputs=("F",), backend="gpu", **kw)
                except TypeError:
                    r = cellgl.cellular_grid(shape, origin=0.0, spacing=s, n=1,
                                             distribution=dist, jitter=1.0, seed=0,
                                             outputs=("F",), backend="gpu", **kw)
                F = np.asarray(r.F)
                if F.size != shape[0] * shape[1]:
                    raise RuntimeError(f"F has shape {F.shape} for grid {shape}")
                return F

            rows.append(run_row(row, lambda: gcall((grid, grid)), repeats,
                                warmup=lambda: gcall((64, 64))))
    return rows


# --------------------------------------------------------------------------- #
# output
# --------------------------------------------------------------------------- #
def add_ratios(rows):
    fnl = {(r.kind, r.dim, r.n): r.rate for r in rows
           if r.library == "FastNoiseLite" and r.rate}
    vips = {(r.dim, r.n): r.rate for r in rows if r.library == "libvips worley" and r.rate}
    for r in rows:
        if r.rate is None:
            continue
        base = fnl.get((r.kind, r.dim, r.n))
        if base:
            r.ratios["fnl"] = r.rate / base
        if r.kind == "grid" and (r.dim, r.n) in vips:
            r.ratios["vips"] = r.rate / vips[(r.dim, r.n)]


def fmt_rate(x):
    if x is None:
        return "-"
    for unit, div in (("G", 1e9), ("M", 1e6), ("k", 1e3)):
        if x >= div:
            return f"{x / div:.2f} {unit}"
    return f"{x:.0f}"


def fmt_count(c):
    if c >= 1e6 and c % 1e6 == 0:
        return f"{c / 1e6:g}e6"
    return str(c)


def render(rows, markdown):
    head = ["library", "backend", "dim", "n", "distribution", "input", "samples", "samples/s",
            "x FNL", "x vips", "note"]
    body = []
    for r in rows:
        body.append([
            r.library, r.backend, f"{r.dim}D", str(r.n), r.distribution,
            "grid" if r.kind == "grid" else "points", fmt_count(r.count), fmt_rate(r.rate),
            f"{r.ratios['fnl']:.2f}" if "fnl" in r.ratios else "-",
            f"{r.ratios['vips']:.2f}" if "vips" in r.ratios else "-",
            r.note,
        ])
    if markdown:
        out = ["| " + " | ".join(head) + " |",
               "|" + "|".join("---:" if h in ("dim", "n", "samples", "samples/s", "x FNL", "x vips")
                              else "---" for h in head) + "|"]
        out += ["| " + " | ".join(c.replace("|", "/") for c in b) + " |" for b in body]
        return "\n".join(out)
    w = [max(len(h), *(len(b[i]) for b in body)) if body else len(h) for i, h in enumerate(head)]

    def line(cells):
        return "  ".join(c.ljust(w[i]) for i, c in enumerate(cells)).rstrip()
    return "\n".join([line(head), line(["-" * x for x in w])] + [line(b) for b in body])


def environment():
    info = [f"python {platform.python_version()}", f"numpy {np.__version__}",
            f"cpus {os.cpu_count()}"]
    try:
        import importlib.metadata as md
        info.append(f"pyfastnoiselite {md.version('pyfastnoiselite')}")
    except Exception:
        pass
    try:
        import pyvips
        info.append(f"libvips {pyvips.version(0)}.{pyvips.version(1)}.{pyvips.version(2)}")
    except Exception:
        pass
    try:
        import moderngl
        try:
            ctx = moderngl.create_standalone_context(require=430)
        except Exception:  # headless: no X display
            ctx = moderngl.create_standalone_context(require=430, backend="egl")
        info.append(f"GL {ctx.info.get('GL_RENDERER', '?')}")
        ctx.release()
    except Exception as exc:
        info.append(f"GL unavailable ({type(exc).__name__})")
    return ", ".join(info)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=float, default=None,
                    help="random points for the GPU and FastNoiseLite rows (default 1e6)")
    ap.add_argument("--ref-points", type=float, default=None,
                    help="random points for the NumPy reference rows (default 2e4)")
    ap.add_argument("--grid", type=int, default=None,
                    help="side of the square 2-D grid for libvips / grid rows (default 2048)")
    ap.add_argument("--cell-size", type=int, default=64,
                    help="libvips worley cell_size in pixels (default 64)")
    ap.add_argument("--repeats", type=int, default=None, help="timed repeats (best of; default 5)")
    ap.add_argument("--density", type=float, default=None,
                    help="cellgl density for the scattered-point rows (default: library default)")
    ap.add_argument("--no-numpy", action="store_true", help="skip the NumPy reference rows")
    ap.add_argument("--quick", action="store_true",
                    help="small sizes and 2 repeats: a smoke run, not a measurement")
    ap.add_argument("--markdown", action="store_true", help="emit a markdown table")
    args = ap.parse_args(argv)

    q = args.quick
    N = int(args.points or (1e5 if q else 1e6))
    N_ref = int(args.ref_points or (2e3 if q else 2e4))
    grid = args.grid or (512 if q else 2048)
    repeats = args.repeats or (2 if q else 5)
    ref_repeats = min(repeats, 2 if q else 3)

    rng = np.random.default_rng(12345)
    pts = {d: rng.random((N, d)) * DOMAIN for d in (2, 3, 4)}
    ref = {d: p[:N_ref] for d, p in pts.items()} if N_ref <= N else \
        {d: rng.random((N_ref, d)) * DOMAIN for d in (2, 3, 4)}
    # pixel centres of the grid, in FNL units (1 unit = one libvips cell)
    yy, xx = np.meshgrid(np.arange(grid, dtype=np.float32), np.arange(grid, dtype=np.float32),
                         indexing="ij")
    grid_coords = np.ascontiguousarray(
        np.stack([(xx.ravel() + 0.5) / args.cell_size, (yy.ravel() + 0.5) / args.cell_size]))
    del xx, yy

    print(f"# {environment()}", flush=True)
    print(f"# points={N} ref_points={N_ref} grid={grid}x{grid} cell_size={args.cell_size} "
          f"repeats={repeats} (best of, after one warm-up)", flush=True)

    rows = []
    rows += fnl_rows(pts, grid_coords, repeats)
    rows += vips_rows(grid, args.cell_size, repeats)
    backends = ["gpu"] + ([] if args.no_numpy else ["numpy"])
    rows += cellgl_rows(pts, ref, grid, args.cell_size, repeats, ref_repeats, args.density,
                        ns=(1, 2, 4), dists=("jitter", "poisson"), backends=backends)
    add_ratios(rows)
    print(render(rows, args.markdown))
    return 0


if __name__ == "__main__":
    sys.exit(main())
