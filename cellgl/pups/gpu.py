"""PUPs on the GPU: the compute path (candidate grid, ``shaders/pups.comp``), the fragment path
and the raster path (each control point's support polygon drawn with additive blending)."""
from __future__ import annotations

import time

import numpy as np

from cellgl.basis.gpu import DRIVER_LOOP_LIMIT

from cellgl.pups.graph import PupsGraph
from cellgl.pups.pack import PupsPacked, candidate_stream
from cellgl.pups.points import PupsMode

# --------------------------------------------------------------------------------------------
# GPU driver
# --------------------------------------------------------------------------------------------

_LOCAL = (8, 8)


def _context():
    """The shared headless context (:func:`cellgl.gl.context.get_context`)."""
    from cellgl.gl.context import get_context

    return get_context()


def _cell_stream(packed: PupsPacked):
    """The candidate grid as one stream of uvec4 records, laid out for the shaders.

    Per grid cell: a header ``(first record, candidates, axis pairs per candidate, 0)``.
    Per listed candidate, ``2 + pairs`` records: ``(pos.x, pos.y, orient.x, orient.y)``,
    ``(value.r, value.g, value.b, label)`` and its masked-in axes, two per record, in axis
    order, padded with zero axes (factor exactly 1). ``pairs`` is the largest over the
    cell's candidates, so a work group inside one cell runs uniform loops with every load
    at a uniform address, and needs no indirection to the instance arrays.

    Returns
    -------
    cells : uint32 (rows * cols, 4)
    records : uint32 (R, 4)
    """
    if packed.stream is not None:
        return packed.stream
    offsets = packed.cell_offsets.astype(np.int64)
    items = packed.cell_items.astype(np.int64)
    n = items.size
    cnt = packed.axis_count[items]
    rep = np.repeat(np.arange(n), cnt)
    r = np.arange(rep.size) - (np.cumsum(cnt) - cnt)[rep]
    bit = (packed.cell_masks[rep] >> np.minimum(r, 31).astype(np.uint32)) & 1
    keep = (r >= 32) | bit.astype(bool)
    cell_of = np.repeat(np.arange(offsets.size - 1), np.diff(offsets))
    kept_pair = rep[keep]
    naxes = np.bincount(kept_pair, minlength=n)
    kept_slot = np.arange(kept_pair.size) - (np.cumsum(naxes) - naxes)[kept_pair]
    return candidate_stream(offsets, cell_of, np.arange(n) - offsets[cell_of], kept_pair, kept_slot,
                   (packed.axis_begin[items][rep] + r)[keep], n, packed.positions[items],
                   packed.orient[items], packed.values[items], packed.labels[items],
                   packed.axes_scaled)


#: invocations of one llvmpipe SIMD vector (AVX2: 8 x 32 bit; the bound assumes they all differ)
SIMD_LANES = 8


def loop_budget(packed: PupsPacked, group_cells: bool) -> int:
    """The most loop passes (llvmpipe's count, docs/exactness.md) one SIMD vector of pixels can
    spend in ``cell_pups_eval``: a grid cell of c candidates with p axis pairs runs c passes of
    the candidate loop, each with p + 1 of the axis loop, plus the exits: c (p + 2) + 1. A work
    group inside one grid cell (``group_cells``) runs it once for all its lanes; otherwise the
    lanes of a vector may lie in up to :data:`SIMD_LANES` different cells."""
    cells, _ = _cell_stream(packed)
    if not len(cells):
        return 0
    per = cells[:, 1].astype(np.int64) * (cells[:, 2].astype(np.int64) + 2) + 1
    return int(per.max()) * (1 if group_cells else SIMD_LANES)


def _check_budget(packed: PupsPacked, group_cells: bool) -> None:
    """Refuse a candidate grid whose loops the driver could cut (clear error, no wrong pixels)."""
    need = loop_budget(packed, group_cells)
    if need >= DRIVER_LOOP_LIMIT:
        raise ValueError(f"PUPs: a candidate-grid cell needs up to {need} loop passes per SIMD vector, "
                           f"past the driver's limit of {DRIVER_LOOP_LIMIT} (Mesa llvmpipe): lower the "
                           "point density or the support size (docs/exactness.md)")


def evaluate_gpu(packed: PupsPacked, mode: PupsMode, epsilon: float, timings: dict):
    """PUPs over the pixel grid (``shaders/pups.comp`` / ``pups_samples.frag``) on the context's
    runner (:mod:`cellgl.gl.runner`): the candidate grid as records (storage buffers or RGBA32UI
    textures), the values in a float output, the labels (mode ``label``) in an int one. Where the
    grid cells are whole work groups the pass asks to group them (``CELL_PUPS_GROUP_CELLS``: a
    group stays in one grid cell); the runner does where its path runs work groups. Otherwise the
    lanes of a SIMD vector may lie in different cells: the loop budget is checked for whichever
    layout runs (:func:`_check_budget`)."""
    from cellgl.gl import runner as R

    t0 = time.perf_counter()
    r = R.runner(_context())
    c = packed.values.shape[1]
    w, h = packed.width, packed.height
    labels = mode == PupsMode.LABEL
    can_group = packed.tile % _LOCAL[0] == 0 and packed.tile % _LOCAL[1] == 0
    defines = {"CELL_PUPS_CHANNELS": c, "CELL_PUPS_MODE": int(mode)}
    cells, rec = _cell_stream(packed)
    t1 = time.perf_counter()
    vals = np.empty((h, w, c), np.float32)
    labs = np.empty((h, w), np.int32) if labels else None
    outputs = [R.Output("values", 2, vals.reshape(w * h, c))]
    if labs is not None:
        outputs.append(R.Output("labels", 3, labs.reshape(w * h, 1)))
    uniforms = {"u_size": (w, h), "u_origin": packed.origin, "u_pixel": packed.pixel, "u_tile": packed.tile,
                "u_grid_w": packed.grid_shape[1], "u_epsilon": epsilon, "u_tile_groups": packed.tile // _LOCAL[0]}
    p = R.Pass("pups.comp", "pups_samples.frag", defines, w * h,
               R.Image(w, h, _LOCAL, _LOCAL[1], group_align=packed.tile if can_group else None), outputs,
               uniforms=uniforms, cost=max(1, loop_budget(packed, False) // SIMD_LANES),
               group_defines={"CELL_PUPS_GROUP_CELLS": 1} if can_group else None,
               check=lambda grouped: _check_budget(packed, grouped))
    r.bind_records(cells, 0)
    r.bind_records(rec, 1)
    t2 = time.perf_counter()
    r.run(p)          # (checks the loop budget first, also of an empty image)
    t3 = time.perf_counter()
    timings.update(pack=t1 - t0, upload=t2 - t1, gpu=t3 - t2, readback=0.0)
    return vals, labs


def _raster_polygons(packed: PupsPacked):
    """Convex polygons to rasterise for :func:`evaluate_raster`, in pixel units.

    Per instance with a non-empty pixel box: the intersection of its axes' half-planes
    ``d.a <= 1`` (``a`` pre-scaled), each pushed out by one pixel, with its pixel box (pixel
    edges), so every pixel centre where the weight can be non-zero lies well inside. Found as
    the feasible pairwise intersections of the boundary lines, sorted by angle.

    Returns
    -------
    k : int64 (K',)
        The instances drawn, increasing (the compute path's summation order).
    corners : float64 (K', V, 2)
        Polygon vertices in order (pixel units, pixel (i, j) centred at (i + .5, j + .5)),
        padded by repeating the last one.
    count : int64 (K',)
        Vertices per polygon (0: empty).
    """
    box = packed.pixel_box
    k = np.flatnonzero((box[:, 2] >= box[:, 0]) & (box[:, 3] >= box[:, 1]))
    if k.size == 0:
        return k, np.zeros((0, 3, 2)), np.zeros(0, dtype=np.int64)
    (ox, oy), (px, py) = packed.origin, packed.pixel
    c = packed.positions[k]
    n = k.size
    cnt = packed.axis_count[k]
    d = int(cnt.max())
    # lines nrm . x <= hh in coordinates relative to the point (domain units); 4 box sides
    # first, then the axes (padding repeats a box side)
    nrm = np.zeros((n, d + 4, 2))
    hh = np.zeros((n, d + 4))
    ex0 = ox + (box[k, 0] - 0.5) * px - c[:, 0]
    ey0 = oy + (box[k, 1] - 0.5) * py - c[:, 1]
    ex1 = ox + (box[k, 2] + 0.5) * px - c[:, 0]
    ey1 = oy + (box[k, 3] + 0.5) * py - c[:, 1]
    nrm[:, 0] = (-1, 0)
    hh[:, 0] = -ex0
    nrm[:, 1] = (0, -1)
    hh[:, 1] = -ey0
    nrm[:, 2] = (1, 0)
    hh[:, 2] = ex1
    nrm[:, 3] = (0, 1)
    hh[:, 3] = ey1
    r = np.arange(d)
    valid = r[None] < cnt[:, None]
    ai = packed.axis_begin[k][:, None] + np.minimum(r[None], np.maximum(cnt[:, None] - 1, 0))
    a = packed.axes_scaled[ai]
    margin = max(px, py)
    nrm[:, 4:] = np.where(valid[..., None], a, nrm[:, 0:1])
    hh[:, 4:] = np.where(valid, 1.0 + margin * np.hypot(a[..., 0], a[..., 1]), hh[:, 0:1])
    # unit normals, so the tolerance below is in domain units
    ln = np.hypot(nrm[..., 0], nrm[..., 1])
    nrm /= ln[..., None]
    hh /= ln
    i, j = np.triu_indices(d + 4, 1)
    n1, n2 = nrm[:, i], nrm[:, j]
    det = n1[..., 0] * n2[..., 1] - n1[..., 1] * n2[..., 0]
    ok = np.abs(det) > 1e-12
    sd = np.where(ok, det, 1.0)
    vx = (hh[:, i] * n2[..., 1] - hh[:, j] * n1[..., 1]) / sd
    vy = (n1[..., 0] * hh[:, j] - n2[..., 0] * hh[:, i]) / sd
    slack = 1e-9 * (1.0 + np.abs(hh).max(axis=1))
    feas = ok.copy()
    lim = hh + slack[:, None]
    for q in range(d + 4):  # inside every half-plane (a loop: small arrays, no big temporary)
        feas &= nrm[:, q, 0:1] * vx + nrm[:, q, 1:2] * vy <= lim[:, q:q + 1]
    nf = feas.sum(1)
    cx = np.where(feas, vx, 0).sum(1) / np.maximum(nf, 1)
    cy = np.where(feas, vy, 0).sum(1) / np.maximum(nf, 1)
    ang = np.where(feas, np.arctan2(vy - cy[:, None], vx - cx[:, None]), np.inf)
    order = np.argsort(ang, axis=1, kind="stable")
    vmax = max(int(nf.max()), 3)
    order = order[:, :vmax]
    last = np.take_along_axis(order, np.maximum(nf - 1, 0)[:, None], 1)
    order = np.where(np.arange(vmax)[None] < nf[:, None], order, last)
    corners = np.empty((n, vmax, 2))
    corners[..., 0] = (np.take_along_axis(vx, order, 1) + c[:, 0:1] - ox) / px + 0.5
    corners[..., 1] = (np.take_along_axis(vy, order, 1) + c[:, 1:2] - oy) / py + 0.5
    return k, corners, nf


def _raster_pairs_limit(ctx):
    """Largest axis-pair count the raster path can pass as flat vertex outputs: 4 floats per
    pair next to the point and value vec4s (GL_MAX_VERTEX_OUTPUT_COMPONENTS, 128 on most
    drivers), and one vertex attribute per pair next to the corner, point and value
    (GL_MAX_VERTEX_ATTRIBS, 16: 13 pairs, 26 axes)."""
    comps = int(ctx.info.get("GL_MAX_VERTEX_OUTPUT_COMPONENTS") or 64)
    attribs = int(ctx.info.get("GL_MAX_VERTEX_ATTRIBS") or 16)
    return max(0, min((comps - 8) // 4, attribs - 3))


def raster_applies(graph: PupsGraph, mode: PupsMode) -> bool:
    """Whether :func:`evaluate_raster` can evaluate ``graph``: modes ``interpolate`` and
    ``weighted_sum``, every axis list within the varying budget (else: compute)."""
    if mode == PupsMode.LABEL:
        return False
    cnt = np.diff(graph.offsets)
    d = int(cnt.max()) if cnt.size else 0
    return (d + 1) // 2 <= _raster_pairs_limit(_context())


def evaluate_raster(packed: PupsPacked, mode: PupsMode, epsilon: float, timings: dict):
    """Rasterised evaluation (``method="raster"``): per instance the triangles of a convex
    polygon around its support (:func:`_raster_polygons`), one indexed draw in instance order;
    each vertex carries its instance's position, orientation, value, label and pre-scaled
    axes (zero-padded to ``CELL_PUPS_RASTER_PAIRS`` pairs), passed on as ``flat`` outputs, so
    ``shaders/pups_raster.frag`` reads no buffer. It writes ``(w * value, w)`` and additive
    blending sums them into an RGBA32F target in instance order (the compute path's order);
    the division (interpolate) is done here. Modes ``interpolate`` and ``weighted_sum``, at
    most :func:`_raster_pairs_limit` axis pairs per point (see :func:`raster_applies`).
    """
    from cellgl.gl import runner as R

    t0 = time.perf_counter()
    ctx = _context()
    w, h = packed.width, packed.height
    k, corners, nv = _raster_polygons(packed)
    pairs = (int(packed.axis_count[k].max()) + 1) // 2 if k.size else 0
    if pairs > _raster_pairs_limit(ctx):
        raise ValueError("too many axes per point for method='raster'")
    # the polygons' vertices, each with its instance's data; fan triangles (0, v, v + 1)
    n = k.size
    vmax = corners.shape[1]
    keep = np.arange(vmax)[None] < nv[:, None]
    vinst = np.repeat(np.arange(n), nv)
    nf = 10 + 4 * pairs
    vert = np.zeros((vinst.size, nf), dtype="<f4")
    vert[:, 0:2] = corners[keep]
    kk = k[vinst]
    vert[:, 2:4] = packed.positions[kk]
    vert[:, 4:6] = packed.orient[kk]
    vert[:, 6:6 + packed.values.shape[1]] = packed.values[kk]
    vert[:, 9] = packed.labels[kk]
    if pairs:
        cnt = packed.axis_count[k]
        r = np.arange(2 * pairs)
        valid = r[None] < cnt[:, None]
        ai = packed.axis_begin[k][:, None] + np.minimum(r[None], np.maximum(cnt[:, None] - 1, 0))
        ax = np.where(valid[..., None], packed.axes_scaled[np.minimum(ai, max(
            packed.axes_scaled.shape[0] - 1, 0))], 0.0).astype("<f4").reshape(n, 4 * pairs)
        vert[:, 10:] = ax[vinst]
    ntri = np.maximum(nv - 2, 0)
    first = np.cumsum(nv) - nv
    tri_inst = np.repeat(np.arange(n), ntri)
    tri_v = np.arange(tri_inst.size) - np.repeat(np.cumsum(ntri) - ntri, ntri) + 1
    base = first[tri_inst]
    idx = np.stack([base, base + tri_v, base + tri_v + 1], axis=1).astype("<u4").reshape(-1)
    t1 = time.perf_counter()
    run = R.runner(ctx)
    target = run.target("pups.raster", (w, h))
    fmt = "2f 4f 4f" + (f" {4 * pairs}f" if pairs else "")
    names = ("in_corner", "in_point", "in_value") + (("in_axes",) if pairs else ())
    draw = R.Draw("pups_raster.vert", "pups_raster.frag", target, {"CELL_PUPS_RASTER_PAIRS": pairs},
                  uniforms={"u_size": (w, h), "u_origin": packed.origin, "u_pixel": packed.pixel,
                            "u_epsilon": epsilon},
                  vertices=R.Vertices(vert, fmt, names, idx, key="pups.raster"),
                  clear=(0.0, 0.0, 0.0, 0.0), blend="add")
    t2 = time.perf_counter()
    run.draw(draw)
    run.finish()
    t3 = time.perf_counter()
    # into the target's kept array: reading into pages already mapped saves ~10 ms at 1000^2
    acc = run.read(target)
    c = packed.values.shape[1]
    if mode == PupsMode.WEIGHTED_SUM:
        vals = acc[..., :c].copy()
    else:
        # sum(w T) / sum(w) as the compute path divides (float32), 0 where no weight
        wsum = acc[..., 3:4]
        with np.errstate(divide="ignore", invalid="ignore"):
            vals = acc[..., :c] / wsum
        vals[wsum[..., 0] == 0] = 0
    t4 = time.perf_counter()
    timings.update(pack=t1 - t0, upload=t2 - t1, gpu=t3 - t2, readback=t4 - t3)
    return vals, None
