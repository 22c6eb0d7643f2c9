"""Command line of the Dask front end: ``cellgl sweep`` and the ``.zarr`` branch of
``cellgl bake`` (its arguments are declared by :mod:`cellgl.cli.bake`). docs/scale.md."""
from __future__ import annotations

import argparse
import errno

from cellgl.dask.blocks import DEFAULT_CHUNK, MAX_CHUNK, DaskError
from cellgl.dask.variations import sweep
from cellgl.dask.zarr_bake import bake_zarr
from cellgl.bake.request import DEFAULT_SIZE, int_arg
from cellgl.io.tempfiles import check_output_dir, env_seconds

__all__ = ["add_sweep_parser", "check_scheduler", "run_sweep", "run_zarr_bake"]


#: largest scheduler file read (Dask writes a few hundred bytes)
MAX_SCHEDULER_FILE = 1 << 20
#: how long a missing scheduler file is waited for (a scheduler started just before writes it a
#: few seconds later), in seconds: ``$CELLGL_SCHEDULER_WAIT``, 0..3600, default 20
SCHEDULER_WAIT_ENV, SCHEDULER_WAIT = "CELLGL_SCHEDULER_WAIT", 20.0


def _scheduler_wait() -> float:
    try:
        return env_seconds(SCHEDULER_WAIT_ENV, SCHEDULER_WAIT, 3600.0,
                           "how long to wait for a scheduler file's scheduler")
    except ValueError as exc:
        raise DaskError(str(exc)) from None


def check_scheduler(scheduler: str | None) -> None:
    """A ``--scheduler`` that names a scheduler file (``*.json``, as
    :func:`cellgl.dask.cluster.cluster_client` reads it) must be there, now, and hold the JSON
    object Dask writes (``{"address": "tcp://..."}``): Dask itself waits for a missing file for
    ever. DaskError naming the file and what is wrong otherwise."""
    import json
    import os
    import stat

    if scheduler is None or not str(scheduler).endswith(".json"):
        return
    import time

    what = f"--scheduler {scheduler}"
    wait = _scheduler_wait()
    deadline = time.monotonic() + wait
    while True:                  # a scheduler started just before (`dask scheduler ... &`) writes
        try:                     # its file a few seconds later: wait for it, not for ever
            st = os.stat(scheduler)
            break
        except OSError as exc:
            if exc.errno != errno.ENOENT or time.monotonic() >= deadline:
                raise DaskError(
                    f"{what}: {exc.strerror.lower() if exc.strerror else exc}"
                    f"{f' (waited {wait:g} s for it)' if exc.errno == errno.ENOENT and wait else ''}; "
                    "a scheduler file is written by a running scheduler (dask scheduler "
                    "--scheduler-file FILE): start it first, or give its address "
                    f"(tcp://host:8786); {SCHEDULER_WAIT_ENV} sets the wait") from None
            time.sleep(0.2)
    if not stat.S_ISREG(st.st_mode):
        raise DaskError(f"{what}: not a regular file; accepted: the JSON file a Dask scheduler "
                        "writes (--scheduler-file)")
    if st.st_size > MAX_SCHEDULER_FILE:
        raise DaskError(f"{what}: {st.st_size} bytes; a scheduler file holds a few hundred "
                        f"(accepted at most {MAX_SCHEDULER_FILE})")
    try:    # without waiting (a FIFO swapped in since the stat), and checked again once open
        fd = os.open(scheduler,
                     os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0))
        with os.fdopen(fd, "rb") as f:
            if not stat.S_ISREG(os.fstat(fd).st_mode):
                raise DaskError(f"{what}: not a regular file; accepted: the JSON file a Dask "
                                "scheduler writes (--scheduler-file)")
            info = json.loads(f.read(MAX_SCHEDULER_FILE + 1).decode("utf-8"))
    except OSError as exc:
        raise DaskError(f"{what}: cannot read it: {exc.strerror or exc}") from None
    except (UnicodeDecodeError, ValueError) as exc:
        raise DaskError(f"{what}: not a Dask scheduler file (not valid JSON: {exc})") from None
    except RecursionError:
        raise DaskError(f"{what}: not a Dask scheduler file (JSON nested too deeply)") from None
    address = info.get("address") if isinstance(info, dict) else None
    if not isinstance(address, str) or not address:
        raise DaskError(f"{what}: not a Dask scheduler file (no \"address\" string in it); "
                        "accepted: the JSON file a Dask scheduler writes (--scheduler-file)")


def run_zarr_bake(args: argparse.Namespace) -> int:
    """``cellgl bake ... -o out.zarr`` (called by :func:`cellgl.cli.bake.run_cli`)."""
    if args.depth not in (None, "32"):
        raise DaskError(f"--depth {args.depth}: a .zarr bake stores float32 (ids uint32), "
                        f"as rendered; accepted 32")
    if args.memory is not None:
        raise DaskError("--memory: not used by a .zarr bake; --tile N sets its chunk size")
    chunk = DEFAULT_CHUNK if args.tile is None else \
        int_arg("--tile", args.tile, 16, MAX_CHUNK)
    workers = None if args.workers is None else \
        int_arg("--workers", args.workers, 1, 1024)
    threads = int_arg("--threads", args.threads, 1, 256)
    check_scheduler(args.scheduler)
    check_output_dir(args.output)       # the one rule of every command's output (a .zarr is a folder)
    bake_zarr(args.recipe, args.output, size=args.size,
              channels=tuple(args.channels or ("color",)), chunk=chunk, sets=args.sets,
              tileable=args.tileable, scheduler=args.scheduler, workers=workers,
              threads=threads, progress=not args.quiet, colorspace=getattr(args, "colorspace", None))
    return 0



_EPILOG = """\
--set NAME=SPEC (repeatable): VALUE fixes a parameter; A..B or A..B:STEP sweeps whole numbers
  (both ends included); a|b|c sweeps alternatives. Every combination is baked, one file each,
  named <recipe>_<name><value>...<ext>; files already there are skipped (a rerun resumes).
examples:
  cellgl sweep flagstone --set seed=0..9999 -o flagstones/ --size 256
  cellgl sweep veins --set seed=0..99 --set metric='euclidean|manhattan' -o veins/ --format exr
  cellgl sweep rock --set seed=0..999 -o rocks/ --scheduler tcp://head:8786
"""


def add_sweep_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> argparse.ArgumentParser:
    """Declare ``cellgl sweep``'s arguments on a subparsers object."""
    p = sub.add_parser(
        "sweep", help="bake many variations of a recipe (--set seed=0..9999) on Dask",
        description="Bake one file per variation of a recipe, on a Dask cluster "
                    "(pip install 'cellgl[dask]'; see docs/scale.md).",
        epilog=_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("recipe", metavar="PRESET_OR_RECIPE",
                   help="a preset name (cellgl presets) or a recipe .json file")
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="output directory")
    p.add_argument("--set", dest="sets", action="append", default=[], metavar="NAME=SPEC",
                   help="fix or sweep a recipe parameter (repeatable; see below)")
    p.add_argument("--size", default=f"{DEFAULT_SIZE[0]}x{DEFAULT_SIZE[1]}",
                   metavar="W[xH]", help="pixels per file (default %(default)s)")
    p.add_argument("--channels", action="append", default=None, metavar="LIST",
                   help="as cellgl bake (default color)")
    p.add_argument("--format", default="png", metavar="EXT",
                   help="png (default), exr, tif or npy")
    p.add_argument("--depth", default=None, metavar="BITS", help="bits per sample, as cellgl bake")
    p.add_argument("--tileable", action="store_true", default=None,
                   help="make every variation wrap around at its edges")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="Dask scheduler address or scheduler file; default a local cluster")
    p.add_argument("--workers", default=None, metavar="N",
                   help="worker processes of the local cluster (default: one per core)")
    p.add_argument("--threads", default="1", metavar="N",
                   help="threads per local worker process (default 1)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar, no summary")
    return p


def run_sweep(args: argparse.Namespace) -> int:
    """``cellgl sweep ...``."""
    check_scheduler(args.scheduler)
    check_output_dir(args.output)       # the one rule of every command's output
    workers = None if args.workers is None else \
        int_arg("--workers", args.workers, 1, 1024)
    sweep(args.recipe, args.output, args.sets, size=args.size,
          channels=tuple(args.channels or ("color",)), fmt=args.format, bit_depth=args.depth,
          tileable=args.tileable, scheduler=args.scheduler, workers=workers,
          threads=int_arg("--threads", args.threads, 1, 256), progress=not args.quiet)
    return 0
