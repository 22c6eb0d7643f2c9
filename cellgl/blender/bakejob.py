"""The bake behind the Blender extension's image nodes, run in a process of its own.

The add-on (:mod:`cellgl.blender.addon`) never renders in Blender's process: Blender owns a
GL/Vulkan/Metal context there, and cellgl's context (EGL on Linux) must not touch it. It starts
``python -m cellgl.blender.bakejob`` with Blender's own interpreter, writes the job as JSON on
its standard input and reads the arrays back from its standard output (an ``.npz`` stream:
nothing is written to disk). Progress goes to standard error as ``cellgl-progress F`` lines
(F in [0, 1]); an error as one ``cellgl-error MESSAGE`` line and exit status 1.

A job is ``{"kind": "recipe", "recipe": PRESET, "sets": ["name=value", ...], "size": N,
"tileable": bool}`` (arrays ``color`` (N, N, 4) uint8, ``data`` (N, N, 3) float32 = height,
ID low 16 bits, ID high 16 bits; ``normal`` and ``cell`` (N, N, 3) uint8) or ``{"kind":
"voronoi", "size": N, "sockets": {...}}`` (``cellgl.voronoi`` over the unit square: ``distance``,
``color``, ``position``, ``w``, ``radius``, float32). Row 0 is the top of the image, as in
``cellgl bake``; the add-on flips rows for Blender's bottom-up images.
"""
from __future__ import annotations

import io
import json
import sys

import numpy as np

__all__ = ["recipe_for", "bake_recipe", "bake_voronoi", "bake_command", "run_job", "main",
           "VORONOI_SOCKETS"]

#: bands a bake is rendered in (tiles are bit-identical to one pass): the progress steps
BANDS = 8

#: Blender's Voronoi Texture sockets and settings -> cellgl.voronoi keywords
VORONOI_SOCKETS = {"Scale": "scale", "Detail": "detail", "Roughness": "roughness",
                   "Lacunarity": "lacunarity", "Smoothness": "smoothness", "Exponent": "exponent",
                   "Randomness": "randomness", "W": "w"}


def _progress(f: float) -> None:
    print(f"cellgl-progress {f:.3f}", file=sys.stderr, flush=True)


def _check_size(size) -> int:
    if isinstance(size, bool) or not isinstance(size, int) or not 1 <= size <= 16384:
        raise ValueError(f"bake size {size!r} is out of range; accepted: an integer from 1 to 16384")
    return size


def recipe_for(preset: str, sets=(), tileable: bool = False):
    """The recipe a node group stands for: ``preset`` with the ``name=value`` overrides, made
    tileable (frequencies rounded, see :meth:`Recipe.tileable`) when asked."""
    from cellgl.recipes import load_recipe

    r = load_recipe(preset)
    if sets:
        r = r.set_from_strings(list(sets))
    if tileable:
        r, _ = r.tileable()
    return r


def bake_recipe(job: dict) -> dict:
    """The arrays of a ``recipe`` job (see the module)."""
    from cellgl.io.spec import id_colors, quantize
    from cellgl.recipes import render

    size = _check_size(job.get("size"))
    r = recipe_for(job["recipe"], job.get("sets", ()), bool(job.get("tileable")))
    chans = ("color", "height", "normal", "id")
    parts: dict[str, list[np.ndarray]] = {c: [] for c in chans}
    rows = -(-size // BANDS)
    _progress(0.0)
    for y0 in range(0, size, rows):
        th = min(rows, size - y0)
        out = render(r, size, size, channels=chans, y0=y0, tile_h=th)
        for c in chans:
            parts[c].append(out[c])
        _progress((y0 + th) / size)
    color, height, normal, ids = (np.concatenate(parts[c], axis=0) for c in chans)
    ids = ids.astype(np.uint32)

    def byte(a):
        return quantize(a, 8)          # as every 8-bit output of cellgl

    data = np.stack([height.astype(np.float32), (ids & 0xFFFF).astype(np.float32),
                     (ids >> 16).astype(np.float32)], axis=-1)
    return {"color": byte(color), "data": data, "normal": byte(normal),
            "cell": id_colors(ids).astype(np.uint8)}


def bake_voronoi(job: dict) -> dict:
    """The arrays of a ``voronoi`` job: ``cellgl.voronoi`` at the pixel centres of the unit
    square (y up, as Blender's UV), each socket's value from the job."""
    from cellgl.basis.voronoi import voronoi

    size = _check_size(job.get("size"))
    s = dict(job.get("sockets", {}))
    dims = int(s.pop("dimensions", 3))
    c = (np.arange(size) + 0.5) / size
    x, y = np.meshgrid(c, 1.0 - c)           # row 0 = top = y near 1
    z = float(s.pop("z", 0.0))
    pts = np.stack([x.ravel(), y.ravel(), np.full(x.size, z)], axis=1).astype(np.float32)
    if dims == 1:
        pts = np.full(x.size, float(s.pop("w", 0.0)), np.float32)
    elif dims == 2:
        pts = pts[:, :2]
    elif dims == 4:
        pts = np.concatenate([pts, np.full((x.size, 1), float(s.pop("w", 0.0)), np.float32)], axis=1)
    if dims != 1:
        s.pop("w", None)
    _progress(0.0)
    r = voronoi(pts, dimensions=dims, **s)
    _progress(1.0)
    out = {}
    for name in ("distance", "color", "position", "w", "radius"):
        a = getattr(r, name, None)
        if a is None:
            continue
        a = np.asarray(a, np.float32)
        out[name] = a.reshape((size, size) + a.shape[1:])
    return out


def bake_command(preset: str, sets=(), size: int = 1024, tileable: bool = False, output: str = "") -> str:
    """The ``cellgl bake`` command line that writes the same image (``Copy Bake Command``)."""
    import shlex

    out = output or f"{preset.replace(':', '-')}.png"
    words = ["cellgl", "bake", preset, "-o", out, "--size", str(size)]
    for s in sets:
        words += ["--set", s]
    if tileable:
        words.append("--tileable")
    return " ".join(shlex.quote(w) for w in words)


def run_job(job: dict) -> dict:
    """Run a job dict in this process (the add-on's fallback and the tests' reference)."""
    kind = job.get("kind")
    if kind == "recipe":
        return bake_recipe(job)
    if kind == "voronoi":
        return bake_voronoi(job)
    raise ValueError(f"job kind {kind!r} is unknown; accepted: recipe, voronoi")


def encode(arrays: dict) -> bytes:
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def decode(data: bytes) -> dict:
    with np.load(io.BytesIO(data), allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


def main() -> int:
    """``python -m cellgl.blender.bakejob``: a job on stdin, ``.npz`` on stdout."""
    try:
        job = json.loads(sys.stdin.read())
        data = encode(run_job(job))
    except Exception as exc:           # noqa: BLE001 - reported to the add-on, which shows it
        msg = " ".join(str(exc).split()) or type(exc).__name__
        print(f"cellgl-error {type(exc).__name__}: {msg}", file=sys.stderr, flush=True)
        return 1
    sys.stdout.buffer.write(data)
    sys.stdout.buffer.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
