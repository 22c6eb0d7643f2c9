"""Distributed bake throughput: a Zarr bake on local Dask clusters of 1 and 2 worker processes.

Usage: python benchmarks/bench_dask.py [--size 4096] [--chunk 512] [--preset f1]
       [--channels height] [--repeat 2] [--configs inproc,1x1,2x1,1x2] [--markdown]

Configs (measured in one run, interleaved repeat by repeat; best time reported):
  inproc   cellgl.bake.bake to .npy in this process, tiles of --chunk (no Dask, no Zarr): the
           baseline a single process gets
  PxT      cellgl.dask.bake_zarr on a LocalCluster of P worker processes x T threads each
           (spawned), started before timing and warmed up (shaders compiled) by a small bake;
           the time covers render, compression and writing every chunk and its checksum
Mpx/s = pixels / best time. "x 1x1" = throughput relative to the 1-worker cluster.
"""

from __future__ import annotations

import argparse
import logging
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import dask  # noqa: E402
import distributed  # noqa: E402

from cellgl.bake import core as cbake  # noqa: E402
from cellgl.dask import bake_zarr  # noqa: E402


logging.getLogger("distributed").setLevel(logging.ERROR)


def load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def start(procs: int, threads: int):
    with dask.config.set({"distributed.worker.multiprocessing-method": "spawn"}):
        return distributed.LocalCluster(n_workers=procs, threads_per_worker=threads,
                                        processes=True, dashboard_address=":0",
                                        silence_logs=40)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=4096)
    ap.add_argument("--chunk", type=int, default=512)
    ap.add_argument("--preset", default="f1")
    ap.add_argument("--channels", default="height")
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--configs", default="inproc,1x1,2x1,1x2")
    ap.add_argument("--markdown", action="store_true")
    args = ap.parse_args(argv)
    configs = [c.strip() for c in args.configs.split(",") if c.strip()]
    channels = args.channels.split(",")
    tmp = Path(tempfile.mkdtemp(prefix="cellgl-bench-dask-"))
    print(f"cellgl Zarr bake: {args.preset} {args.size}^2 {args.channels}, chunks "
          f"{args.chunk}^2, {os.cpu_count()} CPUs, load before: {load()}", file=sys.stderr)
    clusters, best, started = {}, {c: float("inf") for c in configs}, {}
    try:
        for c in configs:
            if c == "inproc":
                continue
            p, t = (int(v) for v in c.split("x"))
            t0 = time.perf_counter()
            clusters[c] = start(p, t)
            started[c] = time.perf_counter() - t0
            bake_zarr(args.preset, tmp / f"warm-{c}.zarr", size=args.chunk * 2,
                      channels=channels, chunk=args.chunk, progress=False,
                      scheduler=clusters[c].scheduler_address)
        cbake.bake(args.preset, tmp / "warm.npy", size=64, channels=channels[:1],
                   progress=False)
        for r in range(args.repeat):
            for c in configs:
                t0 = time.perf_counter()
                if c == "inproc":
                    cbake.bake(args.preset, tmp / "inproc.npy", size=args.size,
                               channels=channels[:1], tile=args.chunk, progress=False)
                else:
                    out = tmp / f"{c}-{r}.zarr"
                    bake_zarr(args.preset, out, size=args.size, channels=channels,
                              chunk=args.chunk, progress=False,
                              scheduler=clusters[c].scheduler_address)
                    shutil.rmtree(out)
                best[c] = min(best[c], time.perf_counter() - t0)
    finally:
        for cl in clusters.values():
            cl.close()
        shutil.rmtree(tmp, ignore_errors=True)
    px = args.size * args.size
    base = best.get("1x1")
    rows = [("config", "cluster start s", "best s", "Mpx/s", "x 1x1")]
    for c in configs:
        ratio = f"{base / best[c]:.2f}" if base else "-"
        rows.append((c, f"{started[c]:.1f}" if c in started else "-", f"{best[c]:.2f}",
                     f"{px / best[c] / 1e6:.1f}", ratio))
    if args.markdown:
        print("| " + " | ".join(rows[0]) + " |")
        print("|" + " --- |" * len(rows[0]))
        for row in rows[1:]:
            print("| " + " | ".join(row) + " |")
    else:
        for row in rows:
            print("  ".join(f"{v:>15}" for v in row))
    print(f"load after: {load()}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
