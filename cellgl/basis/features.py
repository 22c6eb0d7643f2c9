"""Voronoi-cell features beyond F1..Fn: distance to edge, smooth F1, n-sphere radius, cell
position and colour. NumPy float64 twin of ``shaders/lib/features.glsl``, plus the output
bookkeeping of :func:`cellgl.cellular` and brute-force yardsticks for the tests.

Function for function as the GLSL (``cell_features`` -> :func:`features`, ``_cell_walk`` ->
:func:`_walk`, ``cell_id_color`` -> :func:`id_color`), vectorised over samples with the same
walk (rings of cells, each skipped when its nearest possible point is beyond the reach).

* ``edge``: the Euclidean distance from the sample to the border of its Voronoi cell, min over
  the other feature points of the distance to their bisector plane with the F1 point. A point
  at distance ``d`` gives a plane at least ``(d - F1) / 2`` away, so the walk reaches
  ``F1 + 2 E`` for the best plane ``E`` so far: exact, where a fixed 3^d window is not.
* ``smooth_F1``: ``-k log sum_j exp(-F_j / k)``, with the position, gradient and colour
  averaged with the same weights; points with ``F_j >= F1 + 16 k`` (weight below ``e^-16``)
  are left out.
* ``nsphere``: half the distance from the F1 point to its nearest other feature point.
"""
from __future__ import annotations

import functools
import itertools
from typing import Any

import numpy as np

from cellgl.basis import reference as ref
from cellgl.basis.enums import Distribution, Metric

#: outputs of :func:`cellgl.cellular` beyond F, delta, id, grad
OUTPUTS = ("edge", "edge_grad", "nsphere", "position", "color",
           "smooth_F1", "smooth_position", "smooth_grad", "smooth_color")
#: outputs that are Euclidean notions (a bisector plane, an inscribed ball)
EUCLIDEAN_ONLY = ("edge", "edge_grad", "nsphere")
SMOOTH_CUTOFF = 16.0        #: CELL_SMOOTH_CUTOFF: weights below e^-16 are left out
SMOOTHNESS_MAX = 0.25       #: largest smoothness k (cells): the walk then reaches F1 + 4
BIG = ref.BIG


def feature_max_ring(dim: int) -> int:
    """CELL_FEATURE_MAX_RING: rings a feature walk may visit before it reports inexact (on the GPU
    the loop budget, ``CELL_LOOP_BUDGET``, usually stops it first; docs/exactness.md)."""
    return {2: 24, 3: 12, 4: 7}[dim]


#: the walks, each run on its own on the GPU (a pass of its own, or apart in one pass after one
#: search: :func:`apart`), and the outputs each serves
FAMILIES = {"edge": ("edge", "edge_grad"), "nsphere": ("nsphere",),
            "smooth": ("smooth_F1", "smooth_position", "smooth_grad", "smooth_color")}
#: the fields of the GPU's per-sample feature record in their order, and their widths in floats
#: (``walks``: which of the search and the walks were exact, :data:`WALK_BITS`, in a pass apart)
FIELDS = (("edge", 1), ("edge_grad", 4), ("nsphere", 1), ("smooth_F", 1), ("smooth_delta", 4),
          ("smooth_grad", 4), ("smooth_attr", 4), ("walks", 1))
#: the bits of the ``walks`` field (``CELL_WALK_OK_*`` of shaders/lib/features.glsl; "canary": the
#: loop of shaders/cellular.comp that tells that the driver's own loop limit was not reached)
WALK_BITS = {"search": 1, "edge": 2, "nsphere": 4, "smooth": 8, "canary": 16}
_BASIS = ("F", "delta", "id", "grad")


def flags(outputs) -> dict:
    """Which walks the outputs need: ``{"edge", "smooth", "nsphere"}`` -> bool."""
    outs = set(outputs)
    return {"edge": bool(outs & {"edge", "edge_grad"}),
            "smooth": any(o.startswith("smooth_") for o in outs),
            "nsphere": "nsphere" in outs}


def apart(outputs) -> bool:
    """Whether one GPU pass for ``outputs`` serves several of the basis (F, delta, id, grad) and
    the walks (edge, n-sphere, smooth): then one search, and each walk after it on its own
    (``CELL_WALKS_APART``), with the ``walks`` field in the record."""
    return sum(flags(outputs).values()) + bool(set(outputs) & set(_BASIS)) > 1


SMOOTH_MODES = ("exp", "polynomial")   #: smooth F1: log-sum-exp (exact), or Blender's polynomial fold


def layout(outputs) -> dict:
    """The GPU's per-sample feature record for these outputs (only what they need, so a pass
    writes and reads back no more): ``{field: first column}`` of :data:`FIELDS`, and
    ``"stride"``, the floats per sample (0: no walk)."""
    f = flags(outputs)
    extra = bool(set(outputs) & {"smooth_grad", "smooth_position", "smooth_color"})
    on = {"edge": f["edge"], "edge_grad": "edge_grad" in outputs, "nsphere": f["nsphere"],
          "smooth_F": f["smooth"], "smooth_delta": extra, "smooth_grad": extra, "smooth_attr": extra,
          "walks": apart(outputs)}
    out, col = {}, 0
    for name, width in FIELDS:
        if on[name]:
            out[name] = col
            col += width
    out["stride"] = col
    return out


def stride(outputs) -> int:
    """CELL_FEATURE_STRIDE: floats per sample in the GPU's feature record for ``outputs``."""
    return layout(outputs)["stride"]


def defines(outputs, dim: int, smooth: str = "exp") -> dict:
    """The macros of ``shaders/lib/features.glsl`` for these outputs (``CELL_SMOOTH`` 1: the
    exponential smooth minimum, 2: Blender's polynomial fold), ``CELL_WALKS_APART`` (:func:`apart`),
    and the record's layout (``CELL_FEATURE_STRIDE``, ``CELL_FO_<FIELD>``: a field's first column,
    -1 if not written)."""
    f = flags(outputs)
    mode = (2 if smooth == "polynomial" else 1) if f["smooth"] else 0
    extra = bool(set(outputs) & {"smooth_grad", "smooth_position", "smooth_color"})
    lay = layout(outputs)
    out = dict(CELL_EDGE=int(f["edge"]), CELL_SMOOTH=mode, CELL_NSPHERE=int(f["nsphere"]),
               CELL_SMOOTH_EXTRA=int(extra), CELL_FEATURE_MAX_RING=feature_max_ring(dim),
               CELL_FEATURE_STRIDE=lay["stride"], CELL_WALKS_APART=int(apart(outputs)))
    out.update({"CELL_FO_" + name.upper(): lay.get(name, -1) for name, _ in FIELDS})
    return out


# --------------------------------------------------------------------------- per ID

def id_color(ids) -> np.ndarray:
    """``cell_id_color``: the cell colour of each feature ID, float64 (..., 3) in [0, 1]."""
    h = ref.hash_u32(np.asarray(ids, dtype=np.uint64))
    return np.stack([((h >> np.uint64(s)) & np.uint64(255)).astype(np.float64) / 255.0 for s in (0, 8, 16)],
                    axis=-1)


def id_value(ids) -> np.ndarray:
    """``cell_id_value``: a value in [0, 1) per feature ID."""
    h = ref.hash_u32(np.asarray(ids, dtype=np.uint64) ^ np.uint64(0x2545F491))
    return (h >> np.uint64(8)).astype(np.float64) / 16777216.0


def id_attribute(ids) -> np.ndarray:
    """``cell_id_attribute``: (colour, value) per ID, (..., 4)."""
    return np.concatenate([id_color(ids), id_value(ids)[..., None]], axis=-1)


# --------------------------------------------------------------------------- the walks

def _visit(w: dict, rows, cells, f, o, p: ref.Params):
    """``_cell_walk_cell`` at offset o (4,), or one offset per row (len(rows), 4), for the given
    rows (a row may come more than once, with different offsets)."""
    o = np.broadcast_to(np.asarray(o, dtype=np.int64), (len(rows), 4))
    wc = ref.wrap(cells[rows] + o, p.period)
    state = ref.cell_seed(wc, p)
    state, count = ref.point_count(state, p, wc)
    base = o.astype(np.float64) - f[rows]
    blender = p.distribution == Distribution.BLENDER
    # point k of the cells that have one (a cell's stream steps by itself: the cells past their
    # last point are dropped), all handed to _point at once, point-major as the shader's loop
    at = np.arange(len(rows))
    parts = []
    for k in range(int(count.max(initial=0))):
        more = count[at] > k           # (worley1996 has empty cells)
        if not more.all():
            at, state = at[more], state[more]
            if blender:                 # (next_point reads the cells of Blender's points only)
                wc = wc[more]
        state, q, ids = ref.next_point(state, p, wc)
        parts.append((at, q, ids))
    if not parts:
        return
    at = np.concatenate([a for a, _, _ in parts])
    q = np.concatenate([b for _, b, _ in parts])
    ids = np.concatenate([c for _, _, c in parts])
    mine = _point(w, rows[at], base[at] + q, ids, p)
    if mine is not None:            # the F1 point's cell and place (the n-sphere walk's start)
        hit = at[mine]
        w["found"][rows[hit]] = True
        w["o1"][rows[hit]] = o[hit]
        w["q1"][rows[hit]] = q[mine]


def _reach(w: dict, rows, on: dict) -> np.ndarray:
    """``_cell_walk_reach`` (with its rounding margin) of the given rows."""
    if w["around"]:
        r = w["nn"][rows]
    else:
        F1 = w["F1"][rows]
        r = F1.copy()
        if on["edge"]:
            r = np.maximum(r, F1 + 2.0 * np.minimum(w["edge"][rows], 1e30))
        if on["smooth"]:
            r = np.maximum(r, F1 + SMOOTH_CUTOFF * w["k"])
    return r * 1.000001 + 1e-6


def _length(delta, p: ref.Params) -> np.ndarray:
    """:func:`cellgl.basis.reference.metric_length` of rows (M, 4), summed axis by axis (the
    same bits: at most four terms, left to right)."""
    t = ref.metric_term(delta[:, 0], p)
    for a in range(1, p.dim):
        u = ref.metric_term(delta[:, a], p)
        t = np.maximum(t, u) if p.metric == Metric.CHEBYSHEV else t + u
    return t


def _point(w: dict, rows, delta, ids, p: ref.Params):
    """``_cell_walk_point`` for candidates of the given rows (several candidates of one row
    allowed: minima are taken with ``np.minimum.at``, the smooth terms kept for :func:`_sums`).
    Returns which candidates are the row's F1 point (None for the n-sphere walk)."""
    on = w["on"]
    delta[:, p.dim:] = 0.0          # (the caller's own array)
    if w["around"] or on["edge"]:
        e = delta - w["d1"][rows]
        e2 = (e * e).sum(axis=1)
        mine = (ids == w["id1"][rows]) & (e2 < 1e-10)
    else:                           # the distance to the F1 point only where the ID is F1's
        mine = ids == w["id1"][rows]
        at = np.nonzero(mine)[0]
        e = delta[at] - w["d1"][rows[at]]
        mine[at] = (e * e).sum(axis=1) < 1e-10
    if w["around"]:
        np.minimum.at(w["nn"], rows, np.where(mine, np.inf, np.sqrt(e2)))
        return None
    if on["edge"]:
        ok = ~mine & (e2 > 0.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / np.sqrt(e2)
            b = (0.5 * (delta + w["d1"][rows]) * e).sum(axis=1) * inv
        # the nearest plane of each row among its candidates, then against the best so far
        cand = np.nonzero(ok)[0]
        cand = cand[np.lexsort((b[cand], rows[cand]))]
        first = np.ones(len(cand), dtype=bool)
        first[1:] = rows[cand][1:] != rows[cand][:-1]
        cand = cand[first]
        better = cand[b[cand] < w["edge"][rows[cand]]]
        r = rows[better]
        w["edge"][r] = b[better]
        w["edge_n"][r] = e[better] * inv[better, None]
    if on["smooth"]:
        F1 = w["F1"][rows]
        d = np.where(mine, F1, ref.metric_finish(_length(delta, p), p))
        k = w["k"]
        take = np.nonzero(mine | ((k > 0.0) & (d < F1 + SMOOTH_CUTOFF * k)))[0]
        if not len(take):
            return mine
        # the offsets and gradients over the basis' axes only (the others' terms are 0)
        r, dl, dd, mt = rows[take], delta[take, : p.dim], d[take], mine[take]
        with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
            wt = np.where(mt, 1.0, np.exp((F1[take] - dd) / k) if k > 0 else 0.0)
        g = ref.metric_gradient(dl, dd, p)
        # the weighted terms, summed per row by _sums in this order (the walk reads no sum)
        w["terms"].append((r, wt, wt[:, None] * dl, wt[:, None] * g, wt[:, None] * id_attribute(ids[take])))
    return mine


def _sums(w: dict) -> None:
    """Sum the smooth walk's terms into ``wsum``, ``wdelta``, ``wgrad``, ``wattr``, each row's
    in the order of the walk (as ``np.add.at`` one candidate after another: same bits)."""
    terms = w.pop("terms", [])
    if not terms:
        return
    N = len(w["wsum"])
    r = np.concatenate([t[0] for t in terms])
    for i, name in enumerate(("wsum", "wdelta", "wgrad", "wattr"), 1):
        a = np.concatenate([t[i] for t in terms])
        if a.ndim == 1:
            w[name] = w[name] + np.bincount(r, weights=a, minlength=N)
        else:                       # (the columns past the basis' axes: sums of 0)
            s = np.zeros_like(w[name])
            for c in range(a.shape[1]):
                s[:, c] = np.bincount(r, weights=a[:, c], minlength=N)
            w[name] = w[name] + s


@functools.lru_cache(maxsize=64)
def _offsets(ring: int, dim: int) -> np.ndarray:
    """The cell offsets (K, 4) of ring ``ring`` (Chebyshev), in the shader's order."""
    rng = [range(-ring, ring + 1)] * dim + [range(0, 1)] * (4 - dim)
    out = np.array([o for o in itertools.product(*rng) if max(abs(v) for v in o) == ring], dtype=np.int64)
    out.flags.writeable = False
    return out


def _box_terms(ring: int, f, p: ref.Params) -> list:
    """Per axis, the metric term (R, 2 ring + 1) of the gap from samples at fractions f (R, 4)
    to the cells at offsets -ring..ring along it: the terms
    :func:`cellgl.basis.reference._box_distance` sums (the same bits)."""
    v = np.arange(-ring, ring + 1)
    out = []
    for a in range(p.dim):
        fa = f[:, a, None]
        g = np.where(v > 0, v - fa, np.where(v < 0, -v - 1 + fa, 0.0))
        out.append(ref.metric_term(g * p.axis_scale[a], p))
    return out


_PAIRS = 1 << 22    #: (sample, offset) pairs tested at once by the vectorised walk


def _walk(w: dict, cells, f, p: ref.Params, max_ring: int) -> np.ndarray:
    """``_cell_walk`` for every row; returns whether each finished within ``max_ring`` rings."""
    N = len(cells)
    on = w["on"]
    fd = f[:, : p.dim]
    m = np.minimum(fd, 1.0 - fd).min(axis=1)
    every = np.arange(N)
    _visit(w, every, cells, f, np.zeros(4, dtype=np.int64), p)
    done = np.zeros(N, dtype=bool)
    for ring in range(1, max_ring + 1):
        done |= (ring - 1) + m >= _reach(w, every, on)
        rows = np.nonzero(~done)[0]
        if len(rows) == 0:
            return np.ones(N, dtype=bool)
        reach = _reach(w, rows, on)
        lo, hi = ref.ring_window(ring, np.minimum(reach, ring + 2.0), f[rows], p.dim)
        term = ref.metric_term(reach, p)
        # All (sample, cell) pairs of the ring at once, with the reach at the start of the ring
        # (the shader's shrinks as it goes: visiting more is always safe, and every sum and
        # minimum is over points, each taken or not by its own distance).
        offs = _offsets(ring, p.dim)
        step = max(1, _PAIRS // len(offs))
        for c in range(0, len(rows), step):
            rs = rows[c:c + step]
            inside = np.ones((len(rs), len(offs)), dtype=bool)
            for a in range(p.dim):          # (the other axes' offsets and window are 0)
                inside &= (offs[:, a] >= lo[c:c + step, a, None]) & (offs[:, a] <= hi[c:c + step, a, None])
            ri, ki = np.nonzero(inside)
            # the distance to each pair's cell, its axes' terms summed left to right (_length)
            box = None
            for a, t in enumerate(_box_terms(ring, f[rs], p)):
                u = t[ri, offs[ki, a] + ring]
                box = u if box is None else (np.maximum(box, u) if p.metric == Metric.CHEBYSHEV else box + u)
            near = np.nonzero(box < term[c + ri])[0]
            if len(near):
                _visit(w, rs[ri[near]], cells, f, offs[ki[near]], p)
    return max_ring + m >= _reach(w, every, on)


def _smoothstep(t):
    t = np.clip(t, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def poly_smooth(cells, f, p: ref.Params, smoothness: float) -> dict:
    """``_cell_poly_smooth``: smooth F1 as Blender's Voronoi node folds it, over the 5^d block of
    cells around each sample's, in the node's order (x fastest), with k = smoothness / 2.

    Returns ``{"smooth_F": (N,), "smooth_delta", "smooth_grad", "smooth_attr": (N, 4)}``
    (lattice units; the attribute is the folded cell colour and cell value).
    """
    from cellgl.basis.population import blender_color
    from cellgl.basis.enums import Distribution

    N = len(cells)
    k = 0.5 * float(smoothness)
    s = np.full(N, 8.0)
    gs = np.zeros((N, 4))
    pos = np.zeros((N, 4))
    col = np.zeros((N, 4))          # colour and cell value
    span = range(-2, 3)
    axes = [span if a < p.dim else range(0, 1) for a in range(4)]
    for ow, oz, oy, ox in itertools.product(*reversed(axes)):       # w outermost, x fastest
        o = np.array([ox, oy, oz, ow], dtype=np.int64)
        wc = ref.wrap(cells + o, p.period)
        state = ref.cell_seed(wc, p)
        state, count = ref.point_count(state, p, wc)
        for j in range(int(count.max(initial=0))):
            state, q, ids = ref.next_point(state, p, wc)
            has = j < count
            q = o + q
            q[:, p.dim:] = 0.0
            delta = q - f
            d = ref.metric_finish(ref.metric_length(delta, p), p)
            gd = np.zeros((N, 4))
            gd[:, : p.dim] = ref.metric_gradient(delta[:, : p.dim], d, p)
            if k > 0:
                t = 0.5 + 0.5 * (s - d) / k
                h = _smoothstep(t)
                dh = np.where((t > 0) & (t < 1), 6.0 * t * (1.0 - t), 0.0) * 0.5 / k
            else:
                h = (d < s).astype(np.float64)
                dh = np.zeros(N)
            h = np.where(has, h, 0.0)
            dh = np.where(has, dh, 0.0)
            c0 = k * h * (1.0 - h)
            gh = dh[:, None] * (gs - gd)
            gs = (1.0 - h[:, None]) * gs + h[:, None] * gd + ((d - s) - k * (1.0 - 2.0 * h))[:, None] * gh
            s = s + h * (d - s) - c0
            c1 = (c0 / (1.0 + 3.0 * k))[:, None]
            if p.distribution == Distribution.BLENDER:
                cc = np.concatenate([blender_color(wc, p.dim), id_value(ids)[:, None]], axis=1)
            else:
                cc = id_attribute(ids)
            col = col + h[:, None] * (cc - col) - c1
            pos = pos + h[:, None] * (q - pos) - c1
    delta = pos - f
    delta[:, p.dim:] = 0.0
    return dict(smooth_F=s, smooth_delta=delta, smooth_grad=gs, smooth_attr=col)


def features(cells, f, p: ref.Params, F, D, I, exact, outputs, smoothness: float = 0.0,
             max_ring: int | None = None, smooth: str = "exp") -> dict:
    """``cell_features``: the walks the ``outputs`` need, for samples (cells (N, 4) int64,
    fractions f (N, 4)) whose :func:`cellgl.reference.search` result is F, D, I, exact
    (``smooth="polynomial"``: smooth F1 from :func:`poly_smooth` instead of the walk).

    Returns ``{"edge", "nsphere", "smooth_F": (N,), "edge_grad", "smooth_delta", "smooth_grad",
    "smooth_attr": (N, 4), "exact": (N,) bool}`` in lattice units (``smoothness`` too).
    """
    on = flags(outputs)
    poly = on["smooth"] and smooth == "polynomial"
    if poly:
        on["smooth"] = False
    max_ring = max_ring or feature_max_ring(p.dim)
    N = len(cells)
    d1 = np.array(D[:, 0], dtype=np.float64)
    d1[:, p.dim:] = 0.0
    w: dict[str, Any] = dict(on=on, around=False, d1=d1, id1=np.asarray(I[:, 0]).astype(np.uint64),
             F1=np.asarray(F[:, 0], dtype=np.float64), k=float(smoothness),
             edge=np.full(N, BIG), edge_n=np.zeros((N, 4)), wsum=np.zeros(N), wdelta=np.zeros((N, 4)),
             wgrad=np.zeros((N, 4)), wattr=np.zeros((N, 4)), found=np.zeros(N, dtype=bool),
             o1=np.zeros((N, 4), dtype=np.int64), q1=np.zeros((N, 4)), nn=np.full(N, BIG), terms=[])
    ok = np.asarray(exact, dtype=bool) & _walk(w, cells, f, p, max_ring)
    _sums(w)
    g1 = np.zeros((N, 4))
    g1[:, : p.dim] = ref.metric_gradient(d1[:, : p.dim], w["F1"], p)
    out = dict(edge=np.maximum(w["edge"], 0.0), edge_grad=-w["edge_n"], smooth_F=w["F1"].copy(),
               smooth_delta=d1.copy(), smooth_grad=g1, smooth_attr=id_attribute(w["id1"]),
               nsphere=np.zeros(N))
    if on["smooth"]:
        s = w["wsum"] > 0
        inv = 1.0 / w["wsum"][s]
        out["smooth_F"][s] = w["F1"][s] - w["k"] * np.log(w["wsum"][s])
        for name in ("delta", "grad", "attr"):
            out["smooth_" + name][s] = w["w" + name][s] * inv[:, None]
    if poly:
        out.update(poly_smooth(cells, f, p, smoothness))
    if on["nsphere"]:
        v = dict(w, around=True, d1=np.zeros((N, 4)), nn=np.full(N, BIG))
        rows = np.nonzero(w["found"])[0]
        ok &= w["found"]
        if len(rows):
            sub = {k: (a[rows] if isinstance(a, np.ndarray) and a.shape[:1] == (N,) else a) for k, a in v.items()}
            ok[rows] &= _walk(sub, cells[rows] + w["o1"][rows], w["q1"][rows], p, max_ring)
            out["nsphere"][rows] = 0.5 * sub["nn"]
    out["exact"] = ok
    return out


def unpack(raw: np.ndarray, outputs, dim: int) -> dict:
    """The GPU's per-sample record (N, :func:`stride`) float32 of a pass for ``outputs``, as
    :func:`features` names it (views of ``raw``, no copies)."""
    out = {}
    for name, col in layout(outputs).items():
        if name != "stride":
            width = dict(FIELDS)[name]
            out[name] = raw[:, col] if width == 1 else raw[:, col:col + (dim if name != "smooth_attr" else 4)]
    return out


SMOOTHNESS_MAX_POLY = 1.0  #: largest smoothness of the polynomial fold (the node's socket range)


def check(outputs, metric, smoothness, smooth: str = "exp") -> float:
    """Validate the feature outputs against the metric and the smoothness (and the smooth mode);
    returns the smoothness as float."""
    import math
    import numbers

    metric = Metric[metric.upper()] if isinstance(metric, str) else Metric(metric)
    bad = [o for o in outputs if o in EUCLIDEAN_ONLY]
    if bad and metric != Metric.EUCLIDEAN:
        raise ValueError(f"output {bad[0]!r} needs metric 'euclidean' (the distance to a bisector plane "
                         f"and the inscribed ball are Euclidean notions, as in Blender), got "
                         f"{metric.name.lower()!r}")
    if smooth not in SMOOTH_MODES:
        raise ValueError(f"unknown smooth {smooth!r}; expected one of: {', '.join(SMOOTH_MODES)}")
    top = SMOOTHNESS_MAX_POLY if smooth == "polynomial" else SMOOTHNESS_MAX
    if isinstance(smoothness, bool) or not isinstance(smoothness, numbers.Real) \
            or not math.isfinite(smoothness) or not 0.0 <= float(smoothness) <= top:
        raise ValueError(f"smoothness must be a number in [0, {top}] (cells) with smooth={smooth!r}, "
                         f"got {smoothness!r}")
    return float(smoothness)


def finish(out: dict, feats: dict, positions: np.ndarray, scale: float, dim: int, want,
           blender: bool = False) -> None:
    """Fill ``out`` with the requested feature outputs (sample units) from the walk's result
    ``feats`` (lattice units, or the GPU's already scaled record when ``scale`` is 1), the
    sample positions (N, d) float64 and the F1 offsets ``out["delta"]`` and IDs ``out["id"]``
    (``blender``: distribution 'blender', whose ``color`` is Blender's colour of the F1 cell)."""
    inv = 1.0 / scale
    f32 = np.float32

    def scaled(a):
        # x * 1.0 is x: the GPU's float32 record is taken as it is (no copy when contiguous)
        return np.ascontiguousarray(a, f32) if inv == 1.0 else (np.asarray(a, np.float64) * inv).astype(f32)

    if "edge" in want:
        out["edge"] = scaled(feats["edge"])
    if "edge_grad" in want:
        out["edge_grad"] = np.asarray(feats["edge_grad"][:, :dim]).astype(f32)
    if "nsphere" in want:
        out["nsphere"] = scaled(feats["nsphere"])
    if "smooth_F1" in want:
        out["smooth_F1"] = scaled(feats["smooth_F"])
    if "smooth_grad" in want:
        out["smooth_grad"] = np.asarray(feats["smooth_grad"][:, :dim]).astype(f32)
    if "smooth_position" in want:
        out["smooth_position"] = positions + np.asarray(feats["smooth_delta"][:, :dim], np.float64) * inv
    if "smooth_color" in want:
        out["smooth_color"] = np.asarray(feats["smooth_attr"][:, :3]).astype(f32)
    if "position" in want:
        out["position"] = positions + np.asarray(out["delta"][:, 0, :dim], np.float64)
    if "color" in want and blender:
        from cellgl.basis.population import blender_color, blender_owner_cells

        at = positions + np.asarray(out["delta"][:, 0, :dim], np.float64)
        out["color"] = blender_color(blender_owner_cells(at, out["id"][:, 0], dim), dim).astype(f32)
    elif "color" in want:
        out["color"] = id_color(out["id"][:, 0]).astype(f32)


# --------------------------------------------------------------------------- brute force

def brute_force(points: np.ndarray, positions: np.ndarray, smoothness: float = 0.1,
                minkowski_p: float = 3.0, metric="euclidean") -> dict:
    """The features by testing every given feature point (the yardstick for the tests).

    points (N, d), positions (K, d) (every feature point that can matter) -> ``edge``,
    ``nsphere`` (Euclidean), ``smooth_F1`` (no cut-off: every point), ``position`` (N, d) of
    the nearest point; float64.
    """
    diff = positions[None, :, :] - points[:, None, :]
    d = ref.distances(points, positions, metric, minkowski_p)
    near = np.argmin(d, axis=1)
    F1 = d[np.arange(len(points)), near]
    p1 = positions[near]
    e = positions[None, :, :] - p1[:, None, :]                       # pj - p1
    el = np.sqrt((e * e).sum(-1))
    with np.errstate(divide="ignore", invalid="ignore"):
        b = ((0.5 * (diff + (p1 - points)[:, None, :])) * e).sum(-1) / el
    b[el == 0] = np.inf
    nn = np.where(el == 0, np.inf, el).min(axis=1)
    k = smoothness
    s = F1 - k * np.log(np.exp(-(d - F1[:, None]) / k).sum(axis=1)) if k > 0 else F1
    return dict(edge=b.min(axis=1), nsphere=0.5 * nn, smooth_F1=s, position=p1, F1=F1)
