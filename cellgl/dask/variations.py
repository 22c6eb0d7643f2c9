"""``cellgl sweep RECIPE --set seed=0..9999 -o dir/``: a batch of variations on a Dask cluster.

Each ``--set NAME=SPEC`` either fixes a parameter (``--set frequency=6``) or sweeps it:
``A..B`` (whole numbers, both ends included), ``A..B:STEP``, or alternatives ``a|b|c``. Several
swept parameters give every combination. Each variation is one task that bakes one file (PNG by
default; any ``cellgl bake`` format) with :func:`cellgl.bake.core.bake`, so it is written atomically;
a variation whose files all exist is skipped, so a rerun finishes an interrupted sweep.
``DIR/sweep.json`` records the request (recipe, sets, size, channels, format, cellgl version,
the files' colour space); a
rerun into the same directory must make the same request.
"""

from __future__ import annotations

import itertools
import json
import os
import re
import stat
import time
from dataclasses import dataclass
from pathlib import Path

from cellgl._version import __version__
from cellgl.bake import core as _bake
from cellgl.io import formats as cio
from cellgl.dask.blocks import DaskError, load, on_gl_thread, pair, require
from cellgl.dask.cluster import cluster_client, log, map_tasks

__all__ = ["sweep", "parse_sweep", "MAX_VARIATIONS"]

MAX_VARIATIONS = 10_000_000
MANIFEST = "sweep.json"
_RANGE = re.compile(r"^\s*(-?\d+)\s*\.\.\s*(-?\d+)\s*(?::\s*(\d+)\s*)?$")


@dataclass(frozen=True)
class _Axis:
    name: str
    values: tuple[str, ...]   # the --set value texts
    labels: tuple[str, ...]   # how each appears in file names
    swept: bool
    checks: tuple[str, ...]   # the values to try on the recipe up front (a range: its ends)


def _axis(spec: str) -> _Axis:
    name, eq, text = str(spec).partition("=")
    name, text = name.strip(), text.strip()
    if not eq or not name or not text:
        raise DaskError(f"--set {spec!r}: expected NAME=VALUE, NAME=A..B[:STEP] or "
                        f"NAME=a|b|c, e.g. --set seed=0..9999")
    m = _RANGE.match(text)
    if m:
        a, b, step = int(m[1]), int(m[2]), int(m[3] or 1)
        if b < a or step < 1:
            raise DaskError(f"--set {spec!r}: a range A..B[:STEP] needs A <= B and STEP >= 1")
        nums = range(a, b + 1, step)
        if len(nums) > MAX_VARIATIONS:
            raise DaskError(f"--set {spec!r}: {len(nums)} values; at most {MAX_VARIATIONS}")
        width = max(len(str(abs(a))), len(str(abs(b))))
        return _Axis(name, tuple(str(n) for n in nums),
                     tuple(("-" if n < 0 else "") + str(abs(n)).zfill(width) for n in nums), True,
                     (str(nums[0]), str(nums[-1])))
    if "|" in text:
        alts = tuple(t.strip() for t in text.split("|"))
        if not all(alts):
            raise DaskError(f"--set {spec!r}: an empty alternative between '|'")
        return _Axis(name, alts, tuple(re.sub(r"[^A-Za-z0-9.+-]+", "-", t) for t in alts), True,
                     alts)
    return _Axis(name, (text,), ("",), False, (text,))


def parse_sweep(sets) -> list[_Axis]:
    """The ``--set`` specs as axes; raises DaskError naming a bad spec or too many variations."""
    axes = [_axis(s) for s in sets]
    names = [a.name for a in axes]
    for n in names:
        if names.count(n) > 1:
            raise DaskError(f"--set {n}: given more than once")
    total = 1
    for a in axes:
        total *= len(a.values)
    if total > MAX_VARIATIONS:
        raise DaskError(f"--set: {total} variations in all; at most {MAX_VARIATIONS}")
    return axes


def _check_values(base, axes: list[_Axis]) -> None:
    """Apply each distinct value (a range: its two ends) alone, so a bad one fails up front."""
    for a in axes:
        for v in a.checks:
            base.set_from_strings([f"{a.name}={v}"])


def _variations(stem: str, axes: list[_Axis], ext: str):
    swept = [a for a in axes if a.swept]
    fixed = [f"{a.name}={a.values[0]}" for a in axes if not a.swept]
    for combo in itertools.product(*[range(len(a.values)) for a in swept]):
        parts = [f"{a.name}{a.labels[k]}" for a, k in zip(swept, combo)]
        name = "_".join([stem] + parts) + ext
        yield name, fixed + [f"{a.name}={a.values[k]}" for a, k in zip(swept, combo)]


@dataclass(frozen=True)
class _Job:
    base: object
    outdir: str
    size: tuple[int, int]
    channels: tuple[str, ...]
    bit_depth: object
    tileable: object


def _sweep_task(item, job: _Job) -> int:
    """Bake one variation unless its files are all there: 1 baked, 0 skipped."""
    name, sets = item
    path = Path(job.outdir) / name
    if all(p.exists() for p, _ in _bake.output_paths(path, job.channels)):
        return 0
    on_gl_thread(_bake.bake, job.base, path, size=job.size, channels=job.channels,
                 bit_depth=job.bit_depth, tileable=job.tileable, sets=sets, progress=False)
    return 1


#: the most bytes of a sweep manifest read (one is a few KiB): a longer file is not this sweep's
MAX_MANIFEST = 1 << 20


def _check_manifest(outdir: Path, request: dict) -> bool:
    """Whether ``outdir`` already holds this sweep's manifest; raises if it holds another."""
    file = outdir / MANIFEST
    if not os.path.lexists(file):
        return False
    old = None       # anything but this sweep's manifest (not a regular file, too long, too deep)
    try:
        fd = os.open(file, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0))
        with os.fdopen(fd, "rb") as f:
            if stat.S_ISREG(os.fstat(fd).st_mode):
                old = json.loads(f.read(MAX_MANIFEST + 1).decode("utf-8"))
    except (OSError, ValueError, RecursionError):
        pass
    if old != request:
        differ = [k for k in request if not isinstance(old, dict) or old.get(k) != request[k]]
        raise DaskError(f"{str(outdir)!r} holds another sweep ({MANIFEST}: not the same "
                        f"{', '.join(differ) or 'request'}); use an empty directory")
    return True


def sweep(recipe_or_name, outdir, sets, *, size=_bake.DEFAULT_SIZE, channels=("color",),
          fmt="png", bit_depth=None, tileable=None, scheduler=None, workers=None, threads=1,
          progress=True) -> dict:
    """Bake every variation of a recipe that ``sets`` describes, one file each, on Dask.

    Parameters
    ----------
    recipe_or_name : Recipe or str or PathLike
        The base recipe, preset name or recipe JSON file.
    outdir : str or PathLike
        Directory for the files (made if missing; its parent must exist). Files are named
        ``<recipe>_<name><value>...<ext>``, e.g. ``flagstone_seed0042.png``.
    sets : sequence of str
        ``NAME=VALUE`` (fixed), ``NAME=A..B[:STEP]`` (whole numbers, inclusive) or
        ``NAME=a|b|c``; every combination of the swept ones is baked.
    size, channels, bit_depth, tileable
        As :func:`cellgl.bake.core.bake` (size at most 65536 a side).
    fmt : str
        ``png`` (default), ``exr``, ``tif`` or ``npy``.
    scheduler, workers, threads
        The cluster, as :func:`cellgl.dask.bake_zarr`.

    Returns
    -------
    dict
        ``outdir``, ``variations``, ``baked``, ``skipped`` (already there), ``seconds``.
    """
    require("distributed")
    ext = "." + str(fmt).lower().lstrip(".")
    if ext not in _bake.FORMATS:
        raise DaskError(f"--format {fmt!r}: accepted {', '.join(e[1:] for e in _bake.FORMATS)}")
    outdir = Path(os.fspath(outdir))
    if outdir.exists() and not outdir.is_dir():
        raise DaskError(f"output {str(outdir)!r} is a file; give a directory")
    if not (outdir.parent if str(outdir.parent) else Path(".")).is_dir():
        raise DaskError(f"output directory {str(outdir.parent)!r} does not exist")
    if isinstance(size, str):
        w, h, d = _bake.parse_size(size)
    else:
        (w, h), d = pair("size", size, "W, (W, H) or 'WxH'"), None
    _bake.check_size(w, h, d, f"size {size}")
    if d is not None:
        raise DaskError(f"--size {size}: a sweep bakes images, not volumes")
    channels = _bake.parse_channels(channels)
    base = load(recipe_or_name)
    axes = parse_sweep(sets)
    _check_values(base, axes)
    stem = re.sub(r"[^A-Za-z0-9.+-]+", "-", str(getattr(base, "name", "") or "recipe"))
    items = list(_variations(stem, axes, ext))
    job = _Job(base, str(outdir.resolve()), (w, h), channels, bit_depth, tileable)
    bits = _bake.check_bits(ext, bit_depth)
    from cellgl.io.colour import COLORSPACES, default_colorspace

    space = default_colorspace(ext, bits) if "color" in channels else None
    request = {"generator": "cellgl", "version": __version__, "recipe": base.to_dict(),
               "sets": list(sets), "size": [w, h], "channels": list(channels),
               "format": ext[1:], "depth": bit_depth, "tileable": tileable,
               "variations": len(items),
               # the colour channel's space in the files (cellgl.io.colour); None: no colour, .npy
               "colorspace": COLORSPACES[space].interop_id if space else None}
    have = _check_manifest(outdir, request)
    t0 = time.perf_counter()
    bar = _bake.Progress(len(items), f"sweep {outdir.name}", progress, unit="files")
    with bar:   # the line ends; "interrupted" after Ctrl-C
        with cluster_client(scheduler, workers, threads) as client:
            if not have:   # only once there is a cluster to fill it
                outdir.mkdir(exist_ok=True)
                with cio.atomic_path(outdir / MANIFEST) as tmp:
                    tmp.write_text(json.dumps(request, indent=1, sort_keys=True) + "\n")
            done = map_tasks(client, _sweep_task, items, job, on_done=lambda _: bar.step(),
                             key="cellgl-sweep")
    secs = time.perf_counter() - t0
    baked = int(sum(done))
    log(f"sweep {outdir}: {len(items)} variations ({baked} baked, {len(items) - baked} "
        f"already there), {secs:.1f} s", not progress)
    return {"outdir": outdir, "variations": len(items), "baked": baked,
            "skipped": len(items) - baked, "seconds": secs}


