"""How :func:`cellgl.cellular` and :func:`cellgl.cellular_grid` keep ``exact`` honest on the GPU
(docs/exactness.md): the basis and each feature walk on their own (one search, each walk after it
apart, or a pass of their own), the samples a pass
flagged (loop budget, driver's limit, ring cap) computed again by the NumPy reference, and a
warning for what is still open after that. Also the NumPy backend's search itself.
"""
from __future__ import annotations

import numpy as np

from cellgl.basis import features as _features
from cellgl.basis import reference
from cellgl.basis.enums import Distribution

__all__ = ["basis_outputs", "numpy_search", "gpu_passes", "fallback", "warn_inexact"]


def basis_outputs(outs, blender: bool = False) -> tuple[str, ...]:
    """The F1..Fn outputs the search must produce for ``outs`` (the features' position and
    colour come from the F1 offset and ID; Blender's colour from the F1 cell, found from both)."""
    need = set(outs)
    if "position" in need or ("color" in need and blender):
        need.add("delta")
    if "color" in need:
        need.add("id")
    return tuple(o for o in ("F", "delta", "id", "grad") if o in need) or ("F",)


def numpy_search(cells, fr, p, n, outputs, smoothness=0.0, positions=None,
                 smooth="exp") -> tuple[dict, np.ndarray]:
    """The NumPy backend (and the GPU's fallback): ``({output: array}, exact)`` for samples given
    as cells and fractions (lattice units), ``smoothness`` and ``positions`` in sample units."""
    F, D, I, exact = reference.search(cells, fr, p, n)
    out = {}
    inv = 1.0 / p.scale
    blender = p.distribution == Distribution.BLENDER
    basis = basis_outputs(outputs, blender)
    if "F" in basis:
        out["F"] = (F * inv).astype(np.float32)
    w = np.asarray(p.axis_scale[: p.dim])         # anisotropic: D is weighted
    if "delta" in basis:
        out["delta"] = (D[..., : p.dim] / w * inv).astype(np.float32)
    if "id" in basis:
        out["id"] = I
    if "grad" in basis:
        out["grad"] = (reference.metric_gradient(D[..., : p.dim], F, p) * w).astype(np.float32)
    if set(outputs) & set(_features.OUTPUTS):
        feats = _features.features(cells, fr, p, F, D, I, exact, outputs, smoothness * p.scale,
                                   smooth=smooth)
        exact = feats["exact"]
        _features.finish(out, feats, positions, p.scale, p.dim, outputs, blender)
    return out, exact


_BASIS_NAMES = ("F", "delta", "id", "grad", "position", "color")


def _plan(outs, p, n: int) -> list:
    """The GPU passes for ``outs``: a list of passes, each a list of (what it serves, its outputs),
    ``what`` being "basis" or a walk (edge, nsphere, smooth). The search of the basis and of every
    walk is one search where it is the same: F1 alone (n = 1, or no basis output asked); the basis
    with n > 1 searches further (and so spends more of the loop budget) than the walks need, so it
    keeps a pass of its own."""
    fams = [f for f, on in _features.flags(outs).items() if on]
    parts = []
    if set(outs) & set(_BASIS_NAMES) or not fams:
        parts.append(("basis", basis_outputs(outs, p.distribution == Distribution.BLENDER)))
    for fam in fams:
        parts.append((fam, tuple(o for o in outs if o in _features.FAMILIES[fam])))
    if parts[0][0] == "basis" and n > 1 and len(parts) > 2:
        return [parts[:1], parts[1:]]
    if parts[0][0] == "basis" and n > 1:
        return [[part] for part in parts]
    return [parts]


def _served(part: str) -> tuple:
    return _BASIS_NAMES if part == "basis" else _features.FAMILIES[part]


def gpu_passes(run, outs, N: int, p, n: int = 1, apart: bool = True) -> tuple[dict, list]:
    """The GPU dispatches for ``outs``: one search for the basis outputs (F, delta, id, grad, and
    what position and colour need) and every feature walk (edge, n-sphere, smooth) where the
    search is the same (:func:`_plan`), each walk after it on its own with the loop budget
    (``CELL_LOOP_BUDGET``) from where the search left it, as in a pass of its own. So a sample
    gets the same bits, and the same exact flag, whatever else was asked with it: the pass's
    record says which of the search and the walks were exact (the ``walks`` field). Where llvmpipe's
    own loop limit cut such a pass (its canary, also in the field: then no part's flag holds), the
    call runs again with each walk in a pass of its own (``apart=False``, the way before), where
    each has the driver's whole limit to itself.
    ``run(outputs)`` dispatches one pass and returns ``({name: array}, exact)``; the walks' records,
    unpacked (:func:`cellgl.basis.features.unpack`), are merged into ``"features"``.
    Returns the outputs and, per part, (the output names it serves, its exact flags)."""
    plan = _plan(outs, p, n)
    if not apart:
        plan = [[part] for parts in plan for part in parts]
    out, passes, feats = {}, [], {}
    for parts in plan:
        wanted = tuple(o for _, names in parts for o in names)
        got, ok = run(wanted)
        rec = got.pop("features", None)
        if parts[0][0] == "basis":
            out.update(got)
        if rec is not None:
            # each pass's record holds only its own fields: views into it, no copies
            feats.update({k: v for k, v in _features.unpack(rec, wanted, p.dim).items() if k != "walks"})
        if len(parts) == 1:
            passes.append((_served(parts[0][0]), ok))
            continue
        bad = np.nonzero(~ok)[0]
        mask = np.full(len(ok), 31, dtype=np.int64)
        if len(bad):
            mask[bad] = rec[bad, _features.layout(wanted)["walks"]].astype(np.int64)
            if np.any((mask[bad] & _features.WALK_BITS["canary"]) == 0):
                # llvmpipe's limit cut a loop somewhere in the invocation: no part's flag holds
                return gpu_passes(run, outs, N, p, n, apart=False)
        search = (mask & _features.WALK_BITS["search"]) != 0
        for part, _ in parts:
            if part == "basis":
                passes.append((_BASIS_NAMES, search))
            else:       # (a walk's bit is off after an inexact search, as alone; not the polynomial fold's)
                passes.append((_served(part), (mask & _features.WALK_BITS[part]) != 0))
    if feats or any(_features.flags(outs).values()):
        out["features"] = feats
    return out, passes


#: the fallback searches at most this many samples at once (memory of the vectorised reference)
_FALLBACK_CHUNK = 1 << 16


def fallback(out: dict, passes: list, where, p, n, outs, smoothness, smooth="exp") -> np.ndarray:
    """Search the samples a GPU pass flagged inexact (its loop budget, the driver's limit or the
    ring cap reached) again with the NumPy reference, which has no loop budget and goes up to
    :func:`cellgl.basis.reference.max_ring_default` rings, and put its answer for that pass's
    outputs only in their place in ``out`` (finished outputs, flat sample axis): the other passes'
    bits stay the GPU's. ``where(rows)`` gives the rows' (cells, fractions, positions). Returns the
    exact flags; a sample still inexact (points too sparse for every ring the reference searches)
    stays flagged."""
    exact = np.ones(len(passes[0][1]), dtype=bool)
    for names, ok in passes:
        ok = ok.copy()
        rows_all = np.nonzero(~ok)[0]
        pass_outs = tuple(o for o in outs if o in names)
        for first in range(0, len(rows_all), _FALLBACK_CHUNK):
            rows = rows_all[first:first + _FALLBACK_CHUNK]
            cells, fr, positions = where(rows)
            ref_out, ok_rows = numpy_search(cells, fr, p, n, pass_outs or ("F",), smoothness, positions, smooth)
            for name, arr in ref_out.items():
                if name in out and name in names:
                    out[name][rows] = arr
            ok[rows] = ok_rows
        exact &= ok
    return exact


def warn_inexact(exact: np.ndarray, p) -> None:
    """The one thing the library cannot fix by searching further: a warning naming the limit."""
    left = int(np.size(exact) - np.count_nonzero(exact))
    if left:
        import warnings

        warnings.warn(f"{left} of {np.size(exact)} samples could not be computed exactly: their nearest "
                      f"feature points may lie beyond {reference.max_ring_default(p.dim, p.axis_scale)} "
                      "rings of cells, the most the search visits (points too sparse: raise density "
                      "or min_points; minkowski_p below 1 also reaches far). They are flagged False in "
                      ".exact (docs/exactness.md)", RuntimeWarning, stacklevel=3)
