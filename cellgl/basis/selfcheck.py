"""The known-answer check of a GPU path, run on the first use of each context (issue 39).

cellgl has been verified on the drivers named in docs/platforms.md; a user on another one must
never get silently wrong answers. So the first time a path (compute or fragment) is used on a
context, :func:`check` evaluates a few hundred samples on it (:data:`CASES`: 3D Poisson Euclidean
F1..F4 and 2D jitter Manhattan F1..F2, with their IDs, near the origin and around 1e5 cells), and compares them with the NumPy reference
(:mod:`cellgl.basis.reference`) within the promise of docs/exactness.md: every ID equal except
at a near tie (:data:`TIE_EPS`), every F within the bound :func:`eps`. A path that fails
is replaced by the other one with one warning naming the driver (:mod:`cellgl.gl.path`); when
both fail, every GPU call raises :class:`cellgl.gl.path.PathError`.

A pass is recorded on disk (:func:`record_path`: in the shader cache's folder,
:mod:`cellgl.gl.shadercache`), keyed by the driver (GL_VENDOR, GL_RENDERER, GL_VERSION), the path,
cellgl's version and the bytes of every shader and every module of ``cellgl/gl`` and
``cellgl/basis``; a later process on the same driver and code skips the check. A failure is never
recorded; an unreadable or foreign record counts as none, whatever the file is (:func:`_recorded`:
a regular file of at most :data:`RECORD_MAX` bytes, read without waiting and outside the GL
section's signal deferral; its time stamp checked before `cellgl info` shows it).
``CELLGL_SHADER_CACHE=0`` keeps no records (every process checks).

Cost: two shader variants, the first of which (3D, Poisson, Euclidean, n = 4, F, delta, id) is
the one ``cellgl.cellular`` compiles by default, and 288 samples: the GPU takes milliseconds,
the NumPy reference about 0.2 s (llvmpipe machine, 2 cores), compiling what it has to. ``CELLGL_SELFCHECK=0`` turns it off. `cellgl info` shows what it found.

Importing :mod:`cellgl.basis` (and so :mod:`cellgl.texture`, :mod:`cellgl.pups`) registers it.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import stat
import tempfile
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from cellgl.gl import path as _path

__all__ = ["CASES", "U", "S", "TIE_EPS", "eps", "check", "compare", "record_key", "record_path"]

#: float32's unit roundoff
U = 2.0 ** -24
#: the magnitude of the float32 sum a sample's fraction was cut from (docs/exactness.md, "The
#: bound"): 1, since ``cellular`` splits positions into cell and fraction in float64
S = 1.0
#: two reference distances F_k < F_k+1 closer than TIE_EPS eps(F_k+1) are a near tie: a
#: conformant driver may order the two points either way, so their IDs may swap
TIE_EPS = 2.0


def eps(F):
    """What docs/exactness.md promises, and so what the check holds F to: ``|F_gpu - F_ref| <=
    eps(F) = U (18 F + 2 S + 4)`` (Euclidean, in cells; Manhattan and Chebyshev stay inside it;
    the cases use scale 1, so cells are sample units). At F = 1 that is 24 float32 ULPs, 1.4e-6."""
    return U * (18.0 * np.abs(np.asarray(F, np.float64)) + 2.0 * S + 4.0)

#: (name, dimension, keyword arguments of cellgl.cellular, n, outputs, samples near the origin,
#: samples far from it (around 1e5 cells, where the float64 split of the position matters))
CASES: tuple[tuple[str, int, dict[str, Any], int, tuple[str, ...], int, int], ...] = (
    ("3D poisson euclidean", 3, dict(distribution="poisson", metric="euclidean"), 4,
     ("F", "delta", "id"), 128, 32),
    ("2D jitter manhattan", 2, dict(distribution="jitter", metric="manhattan", jitter=0.8, seed=39),
     2, ("F", "id"), 96, 32),
)


def _samples(dim: int, near: int, far: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    out = rng.uniform(-8.0, 8.0, (near + far, dim))
    out[near:] += rng.choice([-1.0, 1.0], (far, dim)) * 1.0e5
    return out


def gpu_cellular(points, n, **kw):
    """The answer of the path under check (``cellgl.cellular`` on the GPU; tests replace it)."""
    from cellgl.basis.core import cellular

    return cellular(points, n, backend="gpu", **kw)


def gpu_flags(points, n, outputs, **kw) -> np.ndarray:
    """The path's own exact flags for the samples, before the NumPy fallback replaces what it
    flagged (the same entry and variant as :func:`gpu_cellular`'s). The check's cases are easy (the
    default density, n <= 4): a conformant driver flags none of them. A path whose flags (or
    searches) are broken must not pass on the fallback's answers: softpipe with its rasteriser
    off (``SOFTPIPE_DEBUG=no_rast``) writes nothing, and where the flag target's stale memory said
    "inexact" everywhere the fallback's answers passed the check (issue 50)."""
    from cellgl.basis import core, gpu

    return gpu.search_points(points, core.make_params(points.shape[1], **kw), n, outputs)[1]


def reference_cellular(points, n, **kw):
    """The NumPy reference's answer."""
    from cellgl.basis.core import cellular

    return cellular(points, n, backend="numpy", **kw)


def compare(name: str, got, ref, n: int) -> str | None:
    """None when ``got`` (F, id of n neighbours) keeps the promise against ``ref`` (n + 1
    neighbours, so that a tie with the first one left out counts), else what differed."""
    F, G = ref.F[:, :n].astype(np.float64), np.asarray(got.F, dtype=np.float64)
    bound = eps(F)
    bad_F = ~(np.abs(G - F) <= bound)      # NaN counts as bad
    R = ref.F.astype(np.float64)
    tie = np.diff(R, axis=1) < TIE_EPS * eps(R[:, 1:])     # (F_k, F_k+1) a near tie, k < n + 1
    near = np.zeros(F.shape, bool)
    near[:, 1:] |= tie[:, :n - 1]                           # with the one before
    near |= tie[:, :n]                                      # with the one after (F_n+1 included)
    bad_id = (np.asarray(got.id) != ref.id[:, :n]) & ~near
    problems = []
    if bad_id.any():
        row = int(np.argmax(bad_id.any(axis=1)))
        problems.append(f"{int(bad_id.any(axis=1).sum())} of {len(F)} samples with other feature "
                        f"point IDs away from ties (first: sample {row}, IDs "
                        f"{np.asarray(got.id)[row].tolist()} vs {ref.id[row, :n].tolist()})")
    if bad_F.any():
        with np.errstate(invalid="ignore", over="ignore"):
            times = np.abs(G - F) / bound
        worst = "NaN" if np.isnan(G[bad_F]).any() else f"{np.nanmax(times[bad_F]):.3g}"
        problems.append(f"F off the reference at {int(bad_F.any(axis=1).sum())} of {len(F)} "
                        f"samples (up to {worst} times the bound eps(F) = 2^-24 (18 F + 6) of "
                        "docs/exactness.md)")
    return f"{name}: {'; '.join(problems)}" if problems else None


def run_cases() -> tuple[str | None, int]:
    """Every case on the current path: (what differed or None, samples checked)."""
    count = 0
    for i, (name, dim, kw, n, outputs, near, far) in enumerate(CASES):
        pts = _samples(dim, near, far, seed=1000 + i)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")     # inexact-sample warnings: the answer is what counts
            got = gpu_cellular(pts, n, outputs=outputs, **kw)
            ref = reference_cellular(pts, n + 1, outputs=("F", "id"), **kw)
            exact = gpu_flags(pts, n, outputs, **kw)
        what = compare(name, got, ref, n)
        if not exact.all():
            what = (f"{what}; " if what else f"{name}: ") + (
                f"the GPU flagged {int(np.size(exact) - np.count_nonzero(exact))} of {len(pts)} "
                "samples, which it must search exactly (its flags or its searches are broken; "
                "the NumPy fallback's answers for them do not count)")
        count += len(pts)
        if what:
            return what, count
    return None, count


_code_digest: list = []


def _code() -> str:
    """A digest of what decides the GPU's answers: every shader file and every module of
    ``cellgl/gl`` and ``cellgl/basis`` (read once per process)."""
    if not _code_digest:
        from cellgl.gl import glsl

        h = hashlib.sha256()
        here = Path(__file__).resolve().parent
        files = [f for f in sorted(glsl.shader_dir().rglob("*")) if f.is_file()]
        files += sorted(here.glob("*.py")) + sorted((here.parent / "gl").glob("*.py"))
        for f in files:
            h.update(f.name.encode() + b"\0" + f.read_bytes() + b"\0")
        _code_digest.append(h.hexdigest())
    return _code_digest[0]


def record_key(ctx, path: str) -> dict:
    """What a recorded pass holds and must match: the driver's strings, the path, cellgl's
    version, the digest of its GPU code and of the check itself."""
    from cellgl._version import __version__

    info = ctx.info
    return {"vendor": info.get("GL_VENDOR"), "renderer": info.get("GL_RENDERER"),
            "version": info.get("GL_VERSION"), "path": path, "cellgl": __version__,
            "code": _code(), "check": repr((CASES, U, S, TIE_EPS))}


def record_path(key: dict) -> Path | None:
    """The file a pass of ``key`` is recorded in, or None where records are off (no writable
    cache folder, or ``CELLGL_SHADER_CACHE=0``)."""
    from cellgl.gl import shadercache

    try:
        folder = shadercache.cache_dir()
    except ValueError:                       # a bad CELLGL_SHADER_CACHE: get_context says so
        return None
    if folder is None:
        return None
    name = hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:32]
    return folder / "selfcheck" / f"{name}.json"


#: the most bytes a record may have (one is about 700): a longer file is no record
RECORD_MAX = 16384
#: what a record's ``passed`` holds (anything else, a forged line or escape, is no record)
_STAMP = re.compile(r"[0-9]{4}-[0-9]{2}-[0-9]{2} [0-9]{2}:[0-9]{2}:[0-9]{2}")


def _read_record(where: Path) -> bytes | None:
    """The bytes of the record file ``where``, or None unless it is a regular file (not a link,
    a FIFO, a device) of at most :data:`RECORD_MAX` bytes: opened without following a link and
    without waiting (a FIFO), read at most that much."""
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOFOLLOW", 0) | \
        getattr(os, "O_NOCTTY", 0) | getattr(os, "O_BINARY", 0)
    try:
        fd = os.open(where, flags)
    except OSError:                          # none yet, a link, unreadable
        return None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode) or st.st_size > RECORD_MAX:
            return None
        data = os.read(fd, RECORD_MAX + 1)
    except OSError:
        return None
    finally:
        os.close(fd)
    return data if len(data) <= RECORD_MAX else None


def _recorded(key: dict) -> str | None:
    """When ``key``'s pass was recorded (its record read back and equal), else None: any file
    that is not such a record (unreadable, not a regular file, too long, not JSON, nested too
    deep, another key, a ``passed`` that is not a time stamp) counts as none. No signal waits
    for the read (:func:`cellgl.gl.context.interruptible`)."""
    from cellgl.gl import context

    with context.interruptible():
        where = record_path(key)
        data = _read_record(where) if where is not None else None
    if data is None:
        return None
    try:
        rec = json.loads(data.decode("utf-8"))
    except (ValueError, RecursionError):     # not UTF-8, not JSON, too deep: check again
        return None
    if isinstance(rec, dict) and rec.get("key") == key and isinstance(rec.get("passed"), str) \
            and _STAMP.fullmatch(rec["passed"]):
        return rec["passed"]
    return None


def _record(key: dict) -> None:
    """Record a pass of ``key`` (written whole or not at all; a folder that refuses it is no
    error: the next process checks again)."""
    from cellgl.gl import context

    with context.interruptible():
        where = record_path(key)
        if where is None:
            return
        tmp = None
        try:
            where.parent.mkdir(exist_ok=True)
            fd, tmp = tempfile.mkstemp(prefix=f".{where.name}.", suffix=".tmp", dir=where.parent)
            with os.fdopen(fd, "w", encoding="utf-8") as f:
                f.write(json.dumps({"key": key, "passed": time.strftime("%Y-%m-%d %H:%M:%S")}))
            os.replace(tmp, where)
        except OSError:
            try:
                if tmp is not None:
                    os.unlink(tmp)
            except OSError:
                pass


def check(ctx, path: str) -> str | None:
    """The hook of :func:`cellgl.gl.path.on_first_use`: None when ``path`` gives the reference's
    answers on ``ctx``, else what differed. A context cellgl did not make (a window's) or one
    that is not this thread's cellgl context is not checked (the basis runs on the latter)."""
    from cellgl.gl import context

    if not context.computes_on(ctx) or context.get_context() is not ctx:
        _path.note(ctx, path, "not checked (not the context cellgl computes on)")
        return None
    key = record_key(ctx, path)
    when = _recorded(key) if gpu_cellular is _GPU_CELLULAR else None    # tests replace it
    if when is not None:
        _path.note(ctx, path, f"passed (recorded {when} for this driver and cellgl's GPU code)")
        return None
    started = time.perf_counter()
    what, count = run_cases()
    if what is None:
        _path.note(ctx, path, f"passed ({len(CASES)} cases, {count} samples against the NumPy "
                              f"reference, {time.perf_counter() - started:.2f} s)")
        if gpu_cellular is _GPU_CELLULAR:
            _record(key)
    return what


#: the real GPU answer: a record is read or written only for it (a test that replaces
#: gpu_cellular checks its stand-in every time)
_GPU_CELLULAR = gpu_cellular

_path.on_first_use(check)
