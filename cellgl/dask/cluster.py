"""The Dask cluster a bake or sweep runs on, and running many small tasks on it with a progress bar.

Without a scheduler address, a ``LocalCluster`` of worker *processes* is started, sized to the
machine. Worker processes are started with ``spawn`` (never ``fork``), so none inherits the
parent's GL context; each makes its own on its first render.
"""

from __future__ import annotations

import contextlib
import os
import sys
import uuid
from collections.abc import Callable, Iterable, Iterator

from cellgl.dask.blocks import DaskError, require

__all__ = ["cluster_client", "default_workers", "map_tasks", "memory_bytes"]

#: a worker process's memory once it has rendered (measured: 160 MB on llvmpipe), plus headroom
WORKER_BASE_BYTES = 300 << 20


def memory_bytes() -> int:
    """Physical memory of this machine in bytes (0 when it cannot be read)."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return 0


def default_workers(per_task_bytes: int) -> int:
    """Worker processes for a local cluster: one per core, fewer if memory would not hold
    that many workers each rendering one block of ``per_task_bytes``."""
    from cellgl.io.formats import usable_cores

    n = usable_cores()
    mem = memory_bytes()
    if mem:
        n = min(n, max(1, mem // 2 // (WORKER_BASE_BYTES + per_task_bytes)))
    return n


@contextlib.contextmanager
def cluster_client(scheduler: str | None = None, workers: int | None = None,
                   threads: int = 1, per_task_bytes: int = 0) -> Iterator[object]:
    """Yield a ``distributed.Client``: to ``scheduler`` (``tcp://host:8786``, a scheduler file
    path ending in ``.json``) or to a fresh local cluster of ``workers`` processes with
    ``threads`` threads each (default: :func:`default_workers`). Closed on leaving."""
    distributed = require("distributed")
    dask = require("dask")
    if scheduler is not None:
        if workers is not None:
            raise DaskError(f"--workers {workers}: only for a local cluster; with --scheduler "
                            f"the cluster's own workers run the bake")
        kw = ({"scheduler_file": scheduler} if str(scheduler).endswith(".json")
              else {"address": scheduler})
        try:
            client = distributed.Client(**kw)   # waits distributed.comm.timeouts.connect
        except (OSError, TimeoutError) as exc:
            raise DaskError(f"--scheduler {scheduler!r}: cannot connect ({exc})") from None
        with client:
            yield client
        return
    n = default_workers(per_task_bytes) if workers is None else workers
    if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= 1024:
        raise DaskError(f"--workers {workers!r}: expected a whole number in 1..1024")
    with dask.config.set({"distributed.worker.multiprocessing-method": "spawn"}):
        cluster = distributed.LocalCluster(n_workers=n, threads_per_worker=threads,
                                           processes=True, dashboard_address=":0",  # a free port
                                           silence_logs=40)  # logging.ERROR
    with cluster, distributed.Client(cluster) as client:
        yield client


#: tasks kept submitted per worker thread: enough to keep every thread busy, few enough that a
#: 65536-chunk bake starts at once (the scheduler spends a few ms per task it holds)
IN_FLIGHT_PER_THREAD = 4
MIN_IN_FLIGHT = 64


def map_tasks(client, fn: Callable, items: Iterable, *args, on_done: Callable | None = None,
              key: str = "cellgl") -> list:
    """Run ``fn(item, *args)`` for each item on the cluster; return the results in item order.

    ``args`` are sent to the workers once (scattered), not once per task. Tasks are submitted
    as a moving window (a few per worker thread, re-sized as workers come and go), not all at
    once. ``on_done(result)`` is called as each task finishes (a progress bar). On the first
    failure the tasks still submitted are cancelled and the exception propagates.
    """
    distributed = require("distributed")
    items = list(items)
    shared = [client.scatter(a, broadcast=True, hash=False) for a in args]
    run = uuid.uuid4().hex[:12]
    results: list = [None] * len(items)
    index: dict = {}
    pending = distributed.as_completed()
    nxt = 0

    def window() -> int:
        threads = sum(client.nthreads().values())
        return max(MIN_IN_FLIGHT, IN_FLIGHT_PER_THREAD * threads)

    def top_up(limit: int) -> None:
        nonlocal nxt
        while nxt < len(items) and pending.count() < limit:
            fut = client.submit(fn, items[nxt], *shared, key=f"{key}-{run}-{nxt}")
            index[fut.key] = nxt
            pending.add(fut)
            nxt += 1

    limit = window()
    top_up(limit)
    try:
        for done, fut in enumerate(pending, 1):
            res = fut.result()  # raises the task's exception here
            results[index.pop(fut.key)] = res
            if on_done is not None:
                on_done(res)
            if done % MIN_IN_FLIGHT == 0:
                limit = window()
            top_up(limit)
    except BaseException:
        client.cancel(list(pending.futures))
        raise
    return results


def log(message: str, quiet: bool) -> None:
    if not quiet:
        print(f"cellgl: {message}", file=sys.stderr)
