"""PUPs packing: the instances (points and periodic copies) whose support reaches the image, their
pixel boxes and the uniform grid of candidate lists the compute shader walks."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from cellgl.pups.graph import PupsGraph
from cellgl.pups.points import check_size

# --------------------------------------------------------------------------------------------
# packing: instances, pixel boxes and the candidate grid
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class PupsPacked:
    """Everything an evaluation of one image needs, as flat arrays (GPU and NumPy alike).

    An *instance* is a control point or one of its periodic copies whose support reaches the
    image. Instances are ordered by copy, then by point index.

    Attributes
    ----------
    point_index : int64 (K,)
        Control point of each instance.
    positions : float64 (K, 2)
    orient : float64 (K, 2)
        xy part of the orientation.
    values : float64 (K, C)
    labels : int32 (K,)
    axis_begin, axis_count : int64 (K,)
        The instance's axes in ``axes_scaled``.
    axes_scaled : float64 (M, 2)
        ``axis / (f |axis|^2)``.
    pixel_box : int64 (K, 4)
        ``(i0, j0, i1, j1)`` inclusive pixel range that may see a non-zero weight (one pixel of
        slack each side); empty when ``i1 < i0``.
    origin, pixel : (float, float)
        Domain position of the centre of pixel (0, 0), and the pixel size.
    width, height, tile : int
        Image size and candidate-grid cell size in pixels.
    grid_shape : (int, int)
        ``(rows, cols)`` of the candidate grid.
    cell_offsets : uint32 (rows * cols + 1,)
    cell_items : uint32 (L,)
        Instances listed per grid cell, in increasing index order.
    cell_masks : uint32 (L,)
        Per listed instance, bit r set when axis r can project above 0 somewhere in the cell;
        the other axes give a factor of exactly 1 there and are skipped. All bits set for a
        point with more than 32 axes (every axis is then visited).
    stream : (uint32 (rows * cols, 4), uint32 (R, 4))
        The same grid as the shaders read it: per cell a header, per candidate its
        position, orientation, value, label and masked-in axes inline (see
        :func:`_cell_stream`).
    """

    point_index: np.ndarray
    positions: np.ndarray
    orient: np.ndarray
    values: np.ndarray
    labels: np.ndarray
    axis_begin: np.ndarray
    axis_count: np.ndarray
    axes_scaled: np.ndarray
    pixel_box: np.ndarray
    origin: tuple
    pixel: tuple
    width: int
    height: int
    tile: int
    grid_shape: tuple
    cell_offsets: np.ndarray
    cell_items: np.ndarray
    cell_masks: np.ndarray
    timings: dict = field(default_factory=dict)
    stream: tuple = None


def pups_pack(graph: PupsGraph, width, height, *, tile=None, grid=True) -> PupsPacked:
    """Lay out a graph for evaluation on a ``width`` x ``height`` pixel grid.

    Parameters
    ----------
    graph : PupsGraph
    width, height : int
        Image size in pixels, each in [1, 16384].
    tile : int, optional
        Candidate-grid cell size in pixels, in [1, 1024]; default: about half the mean point
        spacing.
    grid : bool
        Build the candidate grid and stream (the compute and fragment paths need them; the
        raster path does not). Without it ``cell_offsets`` lists no item, ``grid_shape`` is
        ``(0, 0)`` and ``stream`` is None.

    Returns
    -------
    PupsPacked
    """
    width, height = check_size(width, height)
    pts = graph.points
    x0, y0, x1, y1 = pts.domain
    px, py = (x1 - x0) / width, (y1 - y0) / height
    n = len(pts)
    bbox = graph.bbox
    if pts.periodic:
        wd, hd = x1 - x0, y1 - y0
        sx0 = np.ceil((x0 - bbox[:, 2]) / wd).astype(np.int64)
        sx1 = np.floor((x1 - bbox[:, 0]) / wd).astype(np.int64)
        sy0 = np.ceil((y0 - bbox[:, 3]) / hd).astype(np.int64)
        sy1 = np.floor((y1 - bbox[:, 1]) / hd).astype(np.int64)
        reach = int(max(np.abs(np.r_[sx0, sx1, sy0, sy1]).max(), 0))
        shifts = [(0, 0)] + [(a, b) for b in range(-reach, reach + 1)
                             for a in range(-reach, reach + 1) if (a, b) != (0, 0)]
        idx, sh = [], []
        for a, b in shifts:
            sel = np.nonzero((sx0 <= a) & (a <= sx1) & (sy0 <= b) & (b <= sy1))[0]
            idx.append(sel)
            sh.append(np.tile([a * wd, b * hd], (sel.size, 1)))
        point_index = np.concatenate(idx)
        shift = np.concatenate(sh)
    else:
        point_index = np.arange(n)
        shift = np.zeros((n, 2))
    positions = pts.positions[point_index] + shift
    ibox = bbox[point_index] + np.c_[shift, shift]
    ox, oy = x0 + 0.5 * px, y0 + 0.5 * py
    i0 = np.clip(np.ceil((ibox[:, 0] - ox) / px) - 1, 0, width).astype(np.int64)
    i1 = np.clip(np.floor((ibox[:, 2] - ox) / px) + 1, -1, width - 1).astype(np.int64)
    j0 = np.clip(np.ceil((ibox[:, 1] - oy) / py) - 1, 0, height).astype(np.int64)
    j1 = np.clip(np.floor((ibox[:, 3] - oy) / py) + 1, -1, height - 1).astype(np.int64)
    pixel_box = np.c_[i0, j0, i1, j1]
    if tile is None:
        # about half the mean spacing, a multiple of the 8 x 8 workgroup so that a workgroup
        # shares one candidate list
        spacing = math.sqrt(width * height / max(n, 1))
        tile = int(min(64, max(8, 8 * round(spacing / 16))))
    else:
        if isinstance(tile, bool) or not isinstance(tile, (int, np.integer)) or not 1 <= tile <= 1024:
            raise ValueError(f"tile must be an integer in [1, 1024], got {tile!r}")
        tile = int(tile)
    f = graph.axis_factor
    axes_scaled = graph.axes / (f * (graph.axes ** 2).sum(1))[:, None]
    axis_begin = graph.offsets[point_index]
    axis_count = np.diff(graph.offsets)[point_index]
    orient = pts.orientations[point_index, :2]
    values = pts.values[point_index]
    labels = pts.labels[point_index]
    if not grid:
        none = np.zeros(0, dtype=np.uint32)
        return PupsPacked(
            point_index=point_index, positions=positions, orient=orient, values=values,
            labels=labels, axis_begin=axis_begin, axis_count=axis_count,
            axes_scaled=axes_scaled, pixel_box=pixel_box, origin=(ox, oy), pixel=(px, py),
            width=width, height=height, tile=tile, grid_shape=(0, 0),
            cell_offsets=np.zeros(1, dtype=np.uint32), cell_items=none, cell_masks=none)
    gw, gh = -(-width // tile), -(-height // tile)
    nonempty = (i1 >= i0) & (j1 >= j0)
    k = np.nonzero(nonempty)[0]
    c0, c1 = i0[k] // tile, i1[k] // tile
    r0, r1 = j0[k] // tile, j1[k] // tile
    ncx, ncy = c1 - c0 + 1, r1 - r0 + 1
    cnt = ncx * ncy
    inst = np.repeat(k, cnt)
    local = np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt)
    rep_ncx = np.repeat(ncx, cnt)
    cell = (np.repeat(r0, cnt) + local // rep_ncx) * gw + np.repeat(c0, cnt) + local % rep_ncx
    sep, mask, kpair, kslot, kaxis = _cull(inst, cell, gw, tile, width, height, positions, axis_begin,
                                           axis_count, axes_scaled, (ox, oy), (px, py))
    keep = ~sep
    inst, cell, mask = inst[keep], cell[keep], mask[keep]
    row_ok = keep[kpair]
    kpair, kslot, kaxis = (np.cumsum(keep) - 1)[kpair[row_ok]], kslot[row_ok], kaxis[row_ok]
    order = np.argsort(cell * (point_index.size + 1) + inst, kind="stable")
    items = inst[order].astype(np.uint32)
    masks = mask[order]
    counts = np.bincount(cell, minlength=gw * gh)
    cell_offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.uint32)
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    cell_sorted = cell[order]
    slot = np.arange(order.size) - cell_offsets[cell_sorted].astype(np.int64)
    si = inst[order]
    stream = candidate_stream(cell_offsets, cell_sorted, slot, rank[kpair], kslot, kaxis, inst.size,
                              positions[si], orient[si], values[si], labels[si], axes_scaled)
    return PupsPacked(
        point_index=point_index, positions=positions,
        orient=orient, values=values,
        labels=labels, axis_begin=axis_begin,
        axis_count=axis_count, axes_scaled=axes_scaled,
        pixel_box=pixel_box, origin=(ox, oy), pixel=(px, py), width=width, height=height,
        tile=tile, grid_shape=(gh, gw), cell_offsets=cell_offsets, cell_items=items,
        cell_masks=masks, stream=stream)


def _cull(inst, cell, gw, tile, width, height, positions, axis_begin, axis_count,
          axes_scaled, origin, pixel):
    """Cull (instance, grid cell) pairs and find the axes that matter in each cell.

    The support polygon and the rectangle of the cell's pixel centres are convex, so (with
    the box overlap already known) they are disjoint exactly when one of the polygon's edge
    lines separates them (separating axis theorem): some axis has ``p >= 1`` at all four
    corners. An axis with ``p <= 0`` at all four corners gives the factor 1 everywhere in the
    cell and is left out of the pair's mask. Margins of 1e-4 keep float32 rounding on the
    safe side. One vectorised pass per axis rank (pairs sorted by axis count, so the pairs
    with an axis of rank r are a prefix).

    Returns
    -------
    separated : bool (L,)
    mask : uint32 (L,)
    kept_pair, kept_slot, kept_axis : int64 (A,)
        The axes that matter (the masked-in ones, or every axis of a point with more than
        32), as (pair, rank among the pair's kept axes in axis order, index into
        ``axes_scaled``).
    """
    if inst.size == 0:
        z = np.zeros(0, dtype=np.int64)
        return np.zeros(0, dtype=bool), np.zeros(0, dtype=np.uint32), z, z, z
    # pairs sorted by axis count (descending): the pairs that have an axis r are a prefix
    cnt_all = axis_count[inst]
    perm = np.argsort(-cnt_all, kind="stable")
    inst_p, cell_p = inst[perm], cell[perm]
    cnt = cnt_all[perm]
    beg = axis_begin[inst_p]
    cx, cy = cell_p % gw, cell_p // gw
    i0 = cx * tile
    i1 = np.minimum(i0 + tile, width) - 1
    j0 = cy * tile
    j1 = np.minimum(j0 + tile, height) - 1
    x0 = i0 * pixel[0] + origin[0] - positions[inst_p, 0]
    x1 = i1 * pixel[0] + origin[0] - positions[inst_p, 0]
    y0 = j0 * pixel[1] + origin[1] - positions[inst_p, 1]
    y1 = j1 * pixel[1] + origin[1] - positions[inst_p, 1]
    n = inst.size
    sep = np.zeros(n, dtype=bool)
    mask = np.zeros(n, dtype=np.uint32)
    many = cnt > 32
    nkept = np.zeros(n, dtype=np.int64)
    kp, ks, ka = [], [], []
    dmax = int(cnt[0])
    for r in range(dmax):
        m = int(np.searchsorted(-cnt, -r, side="left"))  # pairs with cnt > r: cnt[:m]
        a = axes_scaled[beg[:m] + r]
        ax, ay = a[:, 0], a[:, 1]
        # a linear function over a rectangle: extremes at corners (x0 <= x1, y0 <= y1)
        xa0, xa1, ya0, ya1 = x0[:m] * ax, x1[:m] * ax, y0[:m] * ay, y1[:m] * ay
        pmin = np.minimum(xa0, xa1) + np.minimum(ya0, ya1)
        pmax = np.maximum(xa0, xa1) + np.maximum(ya0, ya1)
        sep[:m] |= pmin >= 1.0 + 1e-4
        live = pmax > -1e-4
        if r < 32:
            mask[:m] |= live.astype(np.uint32) << np.uint32(r)
        idx = np.flatnonzero(live | many[:m])
        kp.append(idx)
        ks.append(nkept[idx])
        ka.append(beg[idx] + r)
        nkept[idx] += 1
    mask[many] = np.uint32(0xFFFFFFFF)
    inv = np.empty_like(perm)
    inv[perm] = np.arange(n)
    kp = perm[np.concatenate(kp)] if kp else np.zeros(0, dtype=np.int64)
    return (sep[inv], mask[inv], kp, np.concatenate(ks) if ks else kp,
            np.concatenate(ka) if ka else kp)


def candidate_stream(cell_offsets, cell_of, slot, kept_pair, kept_slot, kept_axis, npairs_total, pos,
                     orient, values, labels, axes_scaled):
    """Build the shaders' candidate stream (see :func:`cellgl.pups.gpu._cell_stream`).

    Pairs in list order (by cell, then instance). ``cell_of`` / ``slot``: grid cell and
    index within that cell's list of each pair;
    ``kept_pair`` / ``kept_slot`` / ``kept_axis``: the pairs' axes, with their rank in the
    pair's list; ``pos`` .. ``labels``: per pair.
    """
    offsets = cell_offsets.astype(np.int64)
    ncell = offsets.size - 1
    n = npairs_total
    ncand = np.diff(offsets)
    pairs = np.zeros(ncell, dtype=np.int64)
    if n:
        naxes = np.bincount(kept_pair, minlength=n)
        nonempty = ncand > 0
        pairs[nonempty] = np.maximum.reduceat((naxes + 1) // 2, offsets[:-1][nonempty])
    per = 2 + pairs  # records per candidate, per cell
    cell_begin = np.concatenate([[0], np.cumsum(ncand * per)])
    base = cell_begin[cell_of] + slot * per[cell_of]
    rec = np.zeros((max(int(cell_begin[-1]), 1), 4), dtype="<u4")
    head = np.zeros((n, 8), dtype="<f4")
    head[:, 0:2] = pos
    head[:, 2:4] = orient
    head[:, 4:4 + values.shape[1]] = values
    head.view("<u4")[:, 7] = labels.astype("<i4").view("<u4")
    # scatter whole records (16 bytes as one complex128) and whole axes (8 bytes as uint64)
    rec16 = rec.view(np.complex128).reshape(-1)
    head16 = head.view(np.complex128)
    rec16[base] = head16[:, 0]
    rec16[base + 1] = head16[:, 1]
    ax = np.ascontiguousarray(axes_scaled[kept_axis], dtype="<f4").view(np.uint64).reshape(-1)
    rec.view(np.uint64).reshape(-1)[2 * (base[kept_pair] + 2) + kept_slot] = ax
    cells = np.zeros((max(ncell, 1), 4), dtype="<u4")
    cells[:ncell, 0] = cell_begin[:-1]
    cells[:ncell, 1] = ncand
    cells[:ncell, 2] = pairs
    return cells, rec

