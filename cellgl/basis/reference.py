"""NumPy float64 twin of ``shaders/lib/*.glsl``.

Function for function, the same names (without the ``cell_`` prefix) and the
same integer hashing, vectorised over samples. ``cellgl.cellular(...,
backend="numpy")`` runs this; the tests cross-check the GPU against it and
check it against a brute-force search over :func:`feature_points`.

All integer arithmetic is done on ``np.uint64`` arrays holding values below
2**32 and masked after every multiply/add, which is exactly uint32 wrapping.
"""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from cellgl.basis.density import DensityEncoding, levels_reference
from cellgl.basis.enums import Distribution, Metric
from cellgl.basis.population import (BIG, M32, MAX_POINTS, W96_DENSITY_ADJUSTMENT, add_u32, mul_u32, as_u32,  # noqa: F401
                                     blender_id, blender_point, hash_u32, poisson_thresholds, u16,
                                     worley1996_table)


@dataclass(frozen=True)
class Params:
    """Everything that defines the basis (the GLSL macros and ``CellParams``)."""

    dim: int
    metric: Metric = Metric.EUCLIDEAN
    distribution: Distribution = Distribution.POISSON
    density: float = 3.0
    jitter: float = 1.0
    min_points: int = 1
    max_points: int = 9
    minkowski_p: float = 3.0
    seed: int = 0
    period: tuple[int, int, int, int] = (0, 0, 0, 0)
    #: spatially varying density (:class:`cellgl.basis.density.DensityEncoding`), poisson only
    density_map: DensityEncoding | None = None
    #: loopable animation (CELL_ORBIT): radius of each point's circle in cells, [0, 0.5]
    orbit_radius: float = 0.0
    #: ... and the time as a fraction of the loop times 2^32, modulo 2^32 (:func:`orbit_turn`)
    orbit_turn: int = 0
    #: anisotropic distance (CELL_ANISO): the weight of each axis (1 past ``dim``;
    #: :func:`axis_scale` of a stretch)
    axis_scale: tuple[float, float, float, float] = (1.0, 1.0, 1.0, 1.0)

    @property
    def orbit(self) -> bool:
        """Whether the points orbit (CELL_ORBIT)."""
        return self.orbit_radius > 0.0

    @property
    def aniso(self) -> bool:
        """Whether the distance is anisotropic (CELL_ANISO)."""
        return any(s != 1.0 for s in self.axis_scale)

    @property
    def thresholds(self) -> np.ndarray:
        return poisson_thresholds(self.density)

    @property
    def scale(self) -> float:
        """Sample positions are multiplied by this before the search (and
        distances divided by it after): only worley1996 rescales."""
        return W96_DENSITY_ADJUSTMENT if self.distribution == Distribution.WORLEY1996 else 1.0


def axis_scale(stretch, dim: int) -> tuple[float, float, float, float]:
    """The per-axis distance weights of stretched cells: ``w_a = g / stretch_a`` with ``g`` the
    geometric mean of ``stretch[:dim]`` (so ``prod w = 1``: the cells keep their mean size, only
    their shape changes, and F keeps its distribution under a Poisson process); 1 past ``dim``."""
    s = [float(x) for x in stretch[:dim]]
    if all(x == 1.0 for x in s):
        return (1.0, 1.0, 1.0, 1.0)
    g = math.exp(sum(math.log(x) for x in s) / dim)
    w = [g / x for x in s] + [1.0] * (4 - dim)
    return (w[0], w[1], w[2], w[3])


def orbit_turn(phase: float) -> int:
    """The loop time ``phase`` (in loops: 0 and 1 are the same frame) as the uint32 the shaders
    take: ``round(phase * 2^32) mod 2^32``, computed exactly from the float64 value, so that
    ``phase`` and ``phase + 1`` give the same turn."""
    from fractions import Fraction

    return round(Fraction(float(phase)) * (1 << 32)) % (1 << 32)


def orbit(f: np.ndarray, ids: np.ndarray, p: Params) -> np.ndarray:
    """``cell_orbit``: the points at f (N, 4) in their cells moved along their circles."""
    h = hash_u32(as_u32(ids) ^ np.uint64(0x3C6EF372))
    turn = np.where((h & np.uint64(1)) != 0, np.uint64(p.orbit_turn),
                    np.uint64((-p.orbit_turn) & 0xFFFFFFFF))
    a = (add_u32(h, turn) >> np.uint64(8)).astype(np.float64) * (2.0 * math.pi / 16777216.0)
    r = p.orbit_radius
    f = f.copy()
    f[:, 0] = 0.5 + (1.0 - 2.0 * r) * (f[:, 0] - 0.5) + r * np.cos(a)
    f[:, 1] = 0.5 + (1.0 - 2.0 * r) * (f[:, 1] - 0.5) + r * np.sin(a)
    return f


def wrap(cells: np.ndarray, period) -> np.ndarray:
    """``cell_wrap``: cells (..., 4) int64 onto the periodic lattice."""
    out = cells.copy()
    for a, m in enumerate(period):
        if m > 0:
            out[..., a] = np.mod(out[..., a], m)
    return out


def cell_seed(cells: np.ndarray, p: Params) -> np.ndarray:
    """``cell_cell_seed``: start of each cell's random stream. cells (N, 4) int64."""
    if p.distribution == Distribution.BLENDER:
        return blender_id(cells, p.dim)
    c = cells.astype(np.int64) & 0xFFFFFFFF
    if p.distribution == Distribution.WORLEY1996:
        h = add_u32(add_u32(mul_u32(c[:, 0], 702395077), mul_u32(c[:, 1], 915488749)), mul_u32(c[:, 2], 2120969693))
        return add_u32(h, mul_u32(p.seed, 2654435769))
    h = add_u32(mul_u32(p.seed, 0x27D4EB2F), add_u32(mul_u32(c[:, 0], 0x8DA6B343), mul_u32(c[:, 1], 0xD8163841)))
    for a, k in ((2, 0xCB1AB31F), (3, 0x165667B1))[: p.dim - 2]:
        h = add_u32(h, mul_u32(c[:, a], k))
    return hash_u32(h)


def _w96_step(state):
    return add_u32(mul_u32(state, 1402024253), 586950981)


def density_level(cells: np.ndarray, p: Params) -> np.ndarray:
    """``cell_density_level``: the density level (0..15) of each (wrapped) cell (N, 4) int64."""
    assert p.density_map is not None, "density_level needs Params.density_map"
    return levels_reference(cells, p.density_map)


def point_count(state: np.ndarray, p: Params, cells: np.ndarray | None = None):
    """``cell_point_count`` (``cell_point_count_at`` with a density map: ``cells`` (N, 4) int64,
    already wrapped, pick each cell's row of the threshold table); returns (new_state, count int64)."""
    if p.distribution == Distribution.WORLEY1996:
        count = worley1996_table()[(state >> np.uint64(24)).astype(np.int64)]
        return _w96_step(state), count
    if p.distribution in (Distribution.JITTER, Distribution.BLENDER):
        return state, np.ones(len(state), dtype=np.int64)
    u = state
    if p.density_map is not None:
        assert cells is not None, "a density map picks its rows by cell: pass cells"
        t = p.density_map.thresholds.astype(np.uint64)[density_level(cells, p)]     # (N, 16)
    else:
        t = p.thresholds.astype(np.uint64)[None, :]  # (loop order irrelevant: a count)
    count = np.full(len(state), p.min_points, dtype=np.int64)
    for k in range(p.min_points, p.max_points):
        count += (u >= t[:, k]).astype(np.int64)
    return state, count


def next_point(state: np.ndarray, p: Params, cells: np.ndarray | None = None):
    """``cell_next_point`` of the (wrapped) cells (N, 4) int64 whose streams are at ``state``:
    returns (new_state, position in cell (N, 4) float64, id uint32)."""
    n = len(state)
    f = np.zeros((n, 4), dtype=np.float64)
    if p.distribution == Distribution.BLENDER:      # the hash times Randomness, in float32
        f[:, : p.dim] = blender_point(cells, p.dim) * np.float32(p.jitter)
        return state, (orbit(f, state, p) if p.orbit else f), state.copy()
    if p.distribution == Distribution.WORLEY1996:
        ids = state.copy()
        for a in range(3):
            state = _w96_step(state)
            f[:, a] = (state.astype(np.float64) + 0.5) / 4294967296.0
        state = _w96_step(state)
        return state, (orbit(f, ids, p) if p.orbit else f), ids
    if p.distribution == Distribution.JITTER:
        u = state                                   # one point: the cell's hash itself
    else:
        state = add_u32(state, 0x9E3779B9)             # point k: avalanche of h + k 0x9e3779b9
        u = hash_u32(state)
    ids = hash_u32(u ^ np.uint64(0x5BD1E995))
    f[:, 0] = u16(u >> np.uint64(16))
    f[:, 1] = u16(u & np.uint64(0xFFFF))
    if p.dim >= 3:
        v = mul_u32(u ^ (u >> np.uint64(15)), 0x2C1B3C6D)
        v ^= v >> np.uint64(12)
        f[:, 2] = u16(v >> np.uint64(16))
        f[:, 3] = u16(v & np.uint64(0xFFFF))
    if p.distribution == Distribution.JITTER:
        f[:, : p.dim] = 0.5 + p.jitter * (f[:, : p.dim] - 0.5)
    return state, (orbit(f, ids, p) if p.orbit else f), ids


# --------------------------------------------------------------------------- metric.glsl

def metric_term(x, p: Params):
    x = np.abs(x)
    if p.metric == Metric.EUCLIDEAN:
        return x * x
    if p.metric == Metric.MINKOWSKI:
        return x ** p.minkowski_p
    return x


def metric_length(d: np.ndarray, p: Params) -> np.ndarray:
    """Internal-unit length over the first ``dim`` components of d (..., 4)."""
    t = metric_term(d[..., : p.dim], p)
    return t.max(axis=-1) if p.metric == Metric.CHEBYSHEV else t.sum(axis=-1)


def metric_finish(acc, p: Params):
    if p.metric == Metric.EUCLIDEAN:
        return np.sqrt(acc)
    if p.metric == Metric.MINKOWSKI:
        return acc ** (1.0 / p.minkowski_p)
    return acc


def metric_gradient(delta: np.ndarray, F: np.ndarray, p: Params) -> np.ndarray:
    """``cell_metric_gradient``: dF/dsample. delta (..., d), F (...)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        Fe = F[..., None]
        if p.metric == Metric.EUCLIDEAN:
            g = -delta / Fe
        elif p.metric == Metric.MANHATTAN:
            g = -np.sign(delta)
        elif p.metric == Metric.CHEBYSHEV:
            k = np.argmax(np.abs(delta), axis=-1)
            g = np.zeros_like(delta)
            sel = np.take_along_axis(delta, k[..., None], axis=-1)
            np.put_along_axis(g, k[..., None], -np.sign(sel), axis=-1)
        else:
            q = p.minkowski_p
            g = -np.sign(delta) * np.abs(delta) ** (q - 1.0) / Fe ** (q - 1.0)
    return np.where(Fe > 0, g, 0.0)


# --------------------------------------------------------------------------- cellular.glsl

def _block_offsets(dim: int):
    """Offsets of ring 1 in the GPU's loop order: 4D x outermost, -1..1; 2D and 3D nearest first
    (``_cell_ring1`` of cellular.glsl), on axes ranked by the sample's distance to their nearer
    face (:func:`_ring1_offsets` maps them onto the lattice): -1 is the step across the nearer
    face, and the order is that of the Euclidean box distances at the expected face distances of
    the ranked axes (1/6, 1/3 in 2D; 1/8, 1/4, 3/8 in 3D), ties by fewer far steps."""
    rng = [range(-1, 2)] * dim + [range(0, 1)] * (4 - dim)
    offs = [o for o in itertools.product(*rng) if any(o)]
    if dim <= 3:
        g = [(k + 1) / (2 * (dim + 1)) for k in range(dim)]       # dyadic: exact, so are ties

        def key(o):
            return (sum((g[a] if v < 0 else 1 - g[a]) ** 2 for a, v in enumerate(o[:dim]) if v),
                    sum(v == 1 for v in o))
        offs.sort(key=key)      # stable
    return offs


#: distributions whose ring 1 the GPU visits whole, in the table's own order (CELL_RING1_PRUNE 0)
_RING1_UNPRUNED = (Distribution.JITTER,)


def _ring1_offsets(f: np.ndarray, p: Params) -> np.ndarray:
    """Ring 1 per sample in the GPU's order, (len(block), N, 4) int64: :func:`_block_offsets`
    with rank k standing for the axis k-th nearest to its nearer face (ties: the lower axis
    first; stretched cells: axis k) and -1 for the step across that face (the nearer face is below where the float32
    fraction, as on the GPU, is under 0.5); the table as it is in 4D and for the distributions
    the GPU does not prune in ring 1 (CELL_RING1_PRUNE)."""
    block = np.asarray(_block_offsets(p.dim), dtype=np.int64)
    n = len(f)
    if p.dim > 3 or p.distribution in _RING1_UNPRUNED:
        return np.broadcast_to(block[:, None, :], (len(block), n, 4))
    f32 = f[:, : p.dim].astype(np.float32)
    g = np.minimum(f32, np.float32(1.0) - f32)
    if p.aniso:             # stretched cells: the axes as they are
        rank = np.broadcast_to(np.arange(p.dim), (n, p.dim))
    elif p.dim == 2:
        c = (g[:, 1] < g[:, 0]).astype(np.int64)
        rank = np.stack([c, 1 - c], axis=1)
    else:
        cx, cy, cz = ((g[:, 1] < g[:, 0]).astype(np.int64), (g[:, 2] < g[:, 0]).astype(np.int64),
                      (g[:, 2] < g[:, 1]).astype(np.int64))
        rank = np.stack([cx + cy, 1 - cx + cz, 2 - cy - cz], axis=1)
    side = np.where(f32 < 0.5, 1, -1).astype(np.int64)
    out = np.zeros((len(block), n, 4), dtype=np.int64)
    out[:, :, : p.dim] = block[:, rank] * side           # block[t, rank[i, a]]: axis a's step
    return out


def _ring_offsets(ring: int, dim: int):
    """All offsets of a ring >= 2 in the GPU's loop order (before windowing)."""
    rng = [range(-ring, ring + 1)] * dim + [range(0, 1)] * (4 - dim)
    return [o for o in itertools.product(*rng) if max(abs(v) for v in o) == ring]


def _insert(F, D, I, d, delta, ids, at=None):
    """``_cell_insert`` for a batch: merge one candidate per row (``at``: the rows, distinct;
    default all, in order), keeping the existing entry first on equal distances (stable sort).
    Only the rows whose candidate is nearer than their n-th are sorted: the others would keep
    their entries as they are."""
    n = F.shape[1]
    keep = d < F[:, -1] if at is None else d < F[at, -1]
    rows = np.nonzero(keep)[0] if at is None else at[keep]
    if len(rows) == 0:
        return
    d, delta, ids = d[keep], delta[keep], ids[keep]
    allF = np.concatenate([F[rows], d[:, None]], axis=1)
    order = np.argsort(allF, axis=1, kind="stable")[:, :n]
    F[rows] = np.take_along_axis(allF, order, axis=1)
    allD = np.concatenate([D[rows], delta[:, None, :]], axis=1)
    D[rows] = np.take_along_axis(allD, order[:, :, None], axis=1)
    allI = np.concatenate([I[rows], ids[:, None]], axis=1)
    I[rows] = np.take_along_axis(allI, order, axis=1)


def _visit(F, D, I, cells, f, o, p: Params):
    """``_cell_visit`` for the rows given (all arrays already subset)."""
    wc = wrap(cells + o, p.period)
    state = cell_seed(wc, p)
    state, count = point_count(state, p, wc)
    base = o.astype(np.float64) - f
    at = np.arange(len(count))
    for k in range(int(count.max(initial=0))):
        more = count[at] > k        # the cells past their last point are dropped (their streams
        if not more.all():          # step by themselves; only Blender's points read the cell)
            at, state = at[more], state[more]
            if p.distribution == Distribution.BLENDER:
                wc = wc[more]
        state, q, ids = next_point(state, p, wc)
        delta = (base[at] + q) * np.asarray(p.axis_scale)
        _insert(F, D, I, metric_length(delta, p), delta, ids, at)


def max_ring_default(dim: int, axis_scale=(1.0,)) -> int:
    """CELL_MAX_RING: rings searched before a result is marked inexact (times the ratio of the
    largest to the smallest axis weight, rounded up, for anisotropic distances: at most 64).
    On the GPU the loop budget (``CELL_LOOP_BUDGET``) usually stops a search first; the flagged
    samples are then searched again here, up to these rings (docs/exactness.md)."""
    ratio = max(axis_scale[:dim]) / min(axis_scale[:dim])
    return min(64, {2: 24, 3: 12, 4: 7}[dim] * math.ceil(ratio - 1e-9))


def minkowski_floor(dim: int) -> float:
    """The least ``minkowski_p`` at which every sample's F1 can be settled within the search cap
    (:func:`max_ring_default`, R rings) with a point in every cell: that point lies at most
    ``dim^(1/p)`` away (a whole cell along every axis), and the search proves a distance once
    ``R + m >= F`` (m >= 0 the sample's distance to its cell's nearest face), so every sample is
    settled iff ``dim^(1/p) <= R``: ``p >= ln(dim) / ln(R)``, rounded up to 3 decimals (2D 0.219,
    3D 0.443, 4D 0.713; 1D has no exponent). Below it how many samples the cap leaves open depends
    on where the points fell (at 0.25 in 4D nearly all; see docs/exactness.md): recipes refuse
    it, ``cellgl.voronoi`` unless ``allow_inexact``, ``cellgl.cellular`` flags them."""
    if dim <= 1:
        return 0.0
    return math.ceil(math.log(dim) / math.log(max_ring_default(dim)) * 1000.0) / 1000.0


def minkowski_message(name: str, p: float, dim: int, dim_name: str) -> str:
    """The error for a Minkowski exponent below :func:`minkowski_floor`: names the value, the
    dimension, the accepted range and why."""
    def lo(d):                  # the parameter's own floor is 0.25 (Blender's Exponent)
        return max(minkowski_floor(d), 0.25)

    rings = max_ring_default(dim)
    return (f"{name}: {p:g} with {dim_name} {dim} cannot be exact: at that exponent a point in the "
            f"sample's own cell can lie {dim}^(1/{p:g}) = {dim ** (1.0 / p):.4g} cells away, beyond the "
            f"{rings} rings of cells the search visits in {dim}D; accepted: [{lo(dim):g}, 64] in {dim}D "
            f"(" + ", ".join(f"[{lo(d):g}, 64] in {d}D" for d in (2, 3, 4) if d != dim)
            + ")")


#: the largest share of samples a recipe may leave with no point the search can prove nearest
#: (:func:`sparse_message`): one in a million
SPARSE_RISK = 1e-6


def _reach(metric: str, p: float, dim: int) -> float:
    """How many cells away (in the metric) a point one cell away along every axis lies."""
    return {"euclidean": math.sqrt(dim), "manhattan": float(dim), "chebyshev": 1.0}.get(metric) \
        or dim ** (1.0 / p)


def sparse_message(v) -> str | None:
    """Why a texture recipe's sparse Poisson cells (``min_points`` 0, no density map) cannot be
    exact, or None. :func:`minkowski_floor` counts on a point in the sample's own cell; with
    ``min_points`` 0 a cell is empty with chance ``exp(-density)``, so the F1 point may lie in
    ring ``k`` of cells around it, up to ``reach (k + 1)`` away (``reach`` = dim^(1/p), or dim,
    sqrt(dim), 1), and the search proves it only while that is within its ``R`` rings
    (:func:`max_ring_default`): the sample is left unproven (a texture has no fallback: its value
    may be wrong) when the ``(2k + 1)^dim`` cells within ring ``k = floor(R / reach) - 1`` are all
    empty, chance ``exp(-density (2k + 1)^dim)``. Refused above :data:`SPARSE_RISK`."""
    if v["distribution"] != "poisson" or v["min_points"] > 0 or v["density_map"] != "none":
        return None
    dim, density, metric, p = v["dimension"], v["density"], v["metric"], v["minkowski_p"]
    rings, reach = max_ring_default(dim), _reach(metric, p, dim)
    k = math.floor(rings / reach + 1e-12) - 1
    risk = 1.0 if k < 0 else math.exp(-density * (2 * k + 1) ** dim)
    if risk <= SPARSE_RISK:
        return None
    need = -math.log(SPARSE_RISK) / density          # cells that must hold a point, at this density
    k_need = max(0, math.ceil(((need ** (1.0 / dim)) - 1.0) / 2.0 - 1e-12))
    ways = ["basis.min_points 1 (a point in every cell)"]
    if k >= 0 and -math.log(SPARSE_RISK) / (2 * k + 1) ** dim <= 16.0:
        ways.append(f"basis.density {math.ceil(-math.log(SPARSE_RISK) / (2 * k + 1) ** dim * 1000) / 1000:g} "
                    "or more")
    if metric == "minkowski" and rings / (k_need + 1) > 1.0:
        p_need = math.ceil(math.log(dim) / math.log(rings / (k_need + 1)) * 1000) / 1000
        if p_need <= 64.0:
            ways.append(f"basis.minkowski_p {p_need:g} or more at this density")
    what = f"metric {metric}" + (f" (minkowski_p {p:g})" if metric == "minkowski" else "")
    return (f"basis.min_points: 0 with basis.density {density:g}, {what} in {dim}D cannot be exact: "
            f"cells may be empty, a point k rings of cells away can lie {reach:.3g} (k + 1) cells away, "
            f"and the search visits {rings} rings, so it proves only points within {max(k, 0)} ring(s) "
            f"of the sample's cell; about {risk:.2g} of the samples have none there (at most "
            f"{SPARSE_RISK:g} accepted); accepted: " + ", or ".join(ways))


def _box_distance(o: np.ndarray, f: np.ndarray, p: Params) -> np.ndarray:
    g = np.where(o > 0, o - f, np.where(o < 0, -o - 1 + f, 0.0))
    return metric_length(g * np.asarray(p.axis_scale), p)


def _ring_bound(rings: float, m: np.ndarray, ma: np.ndarray, p: Params) -> np.ndarray:
    """``_cell_ring_bound``: internal-unit lower bound on the distance to any point beyond
    ``rings`` full rings; m (N,) the nearest face distance, ma (N, 4) the weighted per-axis ones."""
    if not p.aniso:
        return metric_term(rings + m, p)
    st = np.asarray(p.axis_scale)
    return np.min(metric_term(st[None, : p.dim] * rings + ma[:, : p.dim], p), axis=1)


def search(cells: np.ndarray, f: np.ndarray, p: Params, n: int, max_ring: int | None = None):
    """``cell_search``: the n nearest feature points of each sample.

    Parameters
    ----------
    cells : (N, 4) int64 -- integer cell of each sample (unused axes 0)
    f : (N, 4) float64 -- fraction within the cell, in [0, 1)
    p : Params
    n : int -- how many neighbours

    Returns
    -------
    F (N, n) float64, delta (N, n, 4) float64, id (N, n) uint32, exact (N,) bool
    """
    if max_ring is None:
        max_ring = max_ring_default(p.dim, p.axis_scale)
    N = len(cells)
    F = np.full((N, n), BIG)
    D = np.zeros((N, n, 4))
    I = np.zeros((N, n), dtype=np.uint64)

    def visit(rows, o):
        """Visit offset o (4,) or (len(rows), 4) for the given rows, pruned."""
        o = np.broadcast_to(np.asarray(o, dtype=np.int64), (len(rows), 4))
        keep = _box_distance(o, f[rows], p) < F[rows, -1]
        rows, o = rows[keep], o[keep]
        if len(rows) == 0:
            return
        sF, sD, sI = F[rows], D[rows], I[rows]
        _visit(sF, sD, sI, cells[rows], f[rows], o, p)
        F[rows], D[rows], I[rows] = sF, sD, sI

    every = np.arange(N)
    visit(every, (0, 0, 0, 0))
    for o in _ring1_offsets(f, p):
        visit(every, o)

    fd = f[:, : p.dim]
    m = np.minimum(fd, 1.0 - fd).min(axis=1)
    ma = np.minimum(f, 1.0 - f) * np.asarray(p.axis_scale)
    exact = np.zeros(N, dtype=bool)
    active = np.ones(N, dtype=bool)
    for ring in range(2, max_ring + 1):
        done = active & (_ring_bound(ring - 1, m, ma, p) >= F[:, -1])
        exact |= done
        active &= ~done
        rows = np.nonzero(active)[0]
        if len(rows) == 0:
            break
        Fr = F[rows, -1]
        reach = np.where(Fr < BIG, metric_finish(Fr, p) * 1.000001 + 1e-6, ring + 2.0)
        if p.aniso:     # the window per axis in lattice units (no point found yet: the whole ring)
            fa = f[rows]
            hi = np.zeros((len(rows), 4), dtype=np.int64)
            lo = np.zeros((len(rows), 4), dtype=np.int64)
            for a in range(p.dim):
                ra = np.where(Fr < BIG, reach / p.axis_scale[a], reach)
                hi[:, a] = np.minimum(ring, np.ceil(ra + fa[:, a]).astype(np.int64) - 1)
                lo[:, a] = -np.minimum(ring, np.ceil(ra + 1.0 - fa[:, a]).astype(np.int64) - 1)
        else:
            lo, hi = ring_window(ring, reach, f[rows], p.dim)
        for o in _ring_offsets(ring, p.dim):
            ov = np.asarray(o)
            inside = np.all((ov >= lo) & (ov <= hi), axis=1)
            visit(rows[inside], o)
    else:
        rows = np.nonzero(active)[0]
        exact[rows] = _ring_bound(max_ring, m[rows], ma[rows], p) >= F[rows, -1]
    return metric_finish(F, p), D, I.astype(np.uint32), exact


def ring_window(ring: int, reach: np.ndarray, f: np.ndarray, dim: int):
    """``cell_ring_window``: the offsets lo, hi (N, 4) int64 of ring ``ring`` a point within true
    distance ``reach`` (N,) of samples at fractions f (N, 4) can lie in."""
    lo = np.zeros((len(f), 4), dtype=np.int64)
    hi = np.zeros((len(f), 4), dtype=np.int64)
    for a in range(dim):
        hi[:, a] = np.minimum(ring, np.ceil(reach + f[:, a]).astype(np.int64) - 1)
        lo[:, a] = -np.minimum(ring, np.ceil(reach + 1.0 - f[:, a]).astype(np.int64) - 1)
    return lo, hi


def distances(points: np.ndarray, positions: np.ndarray, metric, minkowski_p: float = 3.0) -> np.ndarray:
    """(N, K) distances from every sample (N, d) to every position (K, d), float64."""
    a = np.abs(positions[None, :, :] - points[:, None, :])
    metric = Metric[metric.upper()] if isinstance(metric, str) else metric
    if metric == Metric.EUCLIDEAN:
        return np.sqrt((a * a).sum(-1))
    if metric == Metric.MANHATTAN:
        return a.sum(-1)
    if metric == Metric.CHEBYSHEV:
        return a.max(-1)
    return (a ** minkowski_p).sum(-1) ** (1.0 / minkowski_p)


def brute_force(points: np.ndarray, positions: np.ndarray, ids: np.ndarray, metric, n: int,
                minkowski_p: float = 3.0):
    """The n nearest of the given feature points to each sample, by testing every one.

    The yardstick for :func:`search` (tests, ``benchmarks/exactness.py``): points (N, d),
    positions (K, d), ids (K,) -> F (N, n) float64 ascending, ids (N, n) uint32; equal
    distances keep the order of ``positions``.
    """
    dist = distances(points, positions, metric, minkowski_p)
    order = np.argsort(dist, axis=1, kind="stable")[:, :n]
    return np.take_along_axis(dist, order, 1), ids[order]


def feature_points(cells: np.ndarray, p: Params):
    """Every feature point in the given cells.

    cells (M, d) int64 -> positions (K, d) float64 in the cells' lattice,
    ids (K,) uint32, cell index (K,) int64. Periodic wrapping applies to the
    hashing, not to the returned positions.
    """
    M = len(cells)
    c4 = np.zeros((M, 4), dtype=np.int64)
    c4[:, : p.dim] = cells
    wc = wrap(c4, p.period)
    state = cell_seed(wc, p)
    state, count = point_count(state, p, wc)
    pos, ids, which = [], [], []
    for k in range(int(count.max(initial=0))):
        state, q, idk = next_point(state, p, wc)
        has = np.nonzero(k < count)[0]
        pos.append(c4[has, : p.dim] + q[has, : p.dim])
        ids.append(idk[has])
        which.append(has)
    if not pos:
        return np.zeros((0, p.dim)), np.zeros(0, np.uint32), np.zeros(0, np.int64)
    rows = np.concatenate(which)
    order = np.lexsort((np.concatenate([np.full(len(h), k) for k, h in enumerate(pos)]), rows))
    return (np.concatenate(pos)[order], np.concatenate(ids)[order].astype(np.uint32), rows[order])
