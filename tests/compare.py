"""GPU against the NumPy reference, and one GPU answer against another: the comparisons the tests
make, in one place, with the bounds docs/exactness.md promises.

* :func:`f_bound`, :func:`near_ties`: the bound on a distance F and the samples whose IDs may swap
  ("What is promised"); :func:`assert_F_within_bound` and :func:`assert_ids_equal_but_ties` hold
  an answer to them.
* :func:`assert_never_wrong_while_exact`: the flagged-samples rule (no sample flagged exact is
  wrong; the fallback served every flagged one).
* :func:`assert_basis_matches`, :func:`assert_render_matches`: a basis result or a texture render
  against the reference, IDs exactly but at ties, values within a tolerance.
* :func:`assert_close_but_share`: under a share of the pixels off by a tolerance or more (a finer
  octave's near-ties, hard ramp steps, label ties).
* :func:`assert_same_bits`: two answers (arrays, dicts, tuples, results' fields) bit for bit.

A helper never loosens what its caller asks: each takes the tolerance the test states.
"""
from __future__ import annotations

import numpy as np

#: the float32 unit roundoff
U32 = 2.0 ** -24
#: "wrong while flagged exact": far above any rounding (f_bound), far below a wrong point
TOL = 2e-4
#: the texture tests' F1 = F2 tie (up to float32): where a texel's ID and cell value may swap
TIE_GAP = 1e-4


# ---------------------------------------------------------------- the promise (docs/exactness.md)


def f_bound(F, S=1.0):
    """docs/exactness.md, "What is promised": the largest |F_gpu - F_reference| a conformant driver
    may give for a Euclidean (or Manhattan, Chebyshev) distance F in cells, when the float32
    fraction the search starts from came from a float32 sum of magnitude S (1: a position split
    in float64, as cellular does; a texture's lattice sum at octave 0 otherwise: :func:`octave_sum`)."""
    return U32 * (18.0 * np.asarray(F, np.float64) + 2.0 * S + 4.0)


def near_ties(F_ref, S=1.0):
    """Samples (rows of the reference's F1..Fn) where two consecutive distances lie within twice
    f_bound of each other: there a conformant driver may order the two points either way, so
    their IDs may swap (docs/exactness.md)."""
    F_ref = np.asarray(F_ref, np.float64).reshape(len(F_ref), -1)
    if F_ref.shape[1] < 2:
        return np.zeros(len(F_ref), bool)
    gap = np.diff(F_ref, axis=1)
    return np.any(gap <= 2.0 * f_bound(F_ref[:, 1:], S), axis=1)


def octave_sum(recipe) -> float:
    """S of :func:`f_bound` for a texture's octave 0: ``1 + frequency * max(1, aspect)``."""
    return 1.0 + recipe.get("frequency") * max(1.0, recipe.get("aspect"))


def texture_near_ties(ref: dict, S: float) -> np.ndarray:
    """:func:`near_ties` of a texture's F1 and F2 channels, in the channels' shape."""
    F1 = np.asarray(ref["F1"])
    return near_ties(np.stack([F1.ravel(), np.asarray(ref["F2"]).ravel()], axis=1), S).reshape(F1.shape)


def id_ties(ref: dict, gap: float = TIE_GAP) -> np.ndarray:
    """The texture tests' ties: texels whose reference F1 and F2 lie within ``gap``."""
    return np.abs(ref["F2"] - ref["F1"]) < gap


def assert_F_within_bound(got_F, ref_F, S=1.0, what="") -> None:
    """Every distance within :func:`f_bound` of the reference's (float64)."""
    err = np.abs(np.asarray(got_F).astype(np.float64) - ref_F)
    bound = f_bound(ref_F, S)
    assert np.all(err <= bound), (what, float((err / bound).max()))


def assert_ids_equal_but_ties(got, ref, tie, what="") -> None:
    """IDs equal the reference's wherever ``tie`` (a mask over the leading axes) is False."""
    got, ref, tie = np.asarray(got), np.asarray(ref), np.asarray(tie, bool)
    assert np.array_equal(got[~tie], ref[~tie]), (what, int((got != ref)[~tie].sum()))


def assert_never_wrong_while_exact(name, got, want, exact, reach=None, tol=TOL) -> None:
    """The flagged-samples rule against a brute force ``want``: every sample exact (the fallback
    served the flagged ones) and none off by more than ``tol`` while flagged exact. ``reach``: the
    distance to the border of the brute force's block, which every wanted distance must be below
    (else the brute force itself missed points)."""
    assert exact.all(), f"{name}: {(~exact).sum()} samples flagged inexact"
    if reach is not None:        # the brute force itself must have seen every point that matters
        assert np.all((want.max(axis=-1) if want.ndim > 1 else want) < reach), f"{name}: block too small"
    err = np.abs(np.asarray(got, np.float64) - want)
    bad = (err > tol).reshape(len(err), -1).any(1) & exact
    assert not bad.any(), f"{name}: {bad.sum()} samples wrong while flagged exact (max error {err.max():.3g})"


# ---------------------------------------------------------------- against the reference


def assert_basis_matches(a, b, rtol=2e-5, atol=2e-6, F_next=None, tie_gap=1e-4) -> None:
    """A basis result ``a`` against the reference's ``b``: F to float32 tolerance; IDs exactly
    except where two distances tie (within ``tie_gap``). ``F_next`` (N,) is the reference's
    F_{n+1}, so a tie between F_n and the first point left out also counts as a tie."""
    np.testing.assert_allclose(a.F, b.F, rtol=rtol, atol=atol)
    diff = a.id != b.id
    if diff.any():
        F = b.F.astype(np.float64)
        nxt = np.full(len(F), 1e9) if F_next is None else F_next.astype(np.float64)
        gaps = np.minimum(np.abs(np.diff(F, axis=1, prepend=-1.0)),
                          np.abs(np.diff(F, axis=1, append=nxt[:, None])))
        assert np.all(gaps[diff] < tie_gap), f"{diff.sum()} ID mismatches away from ties"


def assert_render_matches(g: dict, n: dict, channels, atol: float, rtol: float = 0.0,
                          mask_ties: bool = False) -> np.ndarray:
    """A render (or evaluate) ``g`` against the reference's ``n``: the IDs (where both have them)
    exactly except at F1 = F2 ties (:func:`id_ties`), each of ``channels`` within ``atol`` (and
    ``rtol``) everywhere, or off the ties with ``mask_ties``. Returns the tie mask."""
    tie = id_ties(n) if "F1" in n and "F2" in n else np.zeros(np.shape(n[channels[0]])[:2], bool)
    if "id" in g and "id" in n:
        assert_ids_equal_but_ties(g["id"], n["id"], tie, "id")
    for k in channels:
        a, b = (g[k][~tie], n[k][~tie]) if mask_ties else (g[k], n[k])
        np.testing.assert_allclose(a, b, atol=atol, rtol=rtol, err_msg=k)
    return tie


def assert_close_but_share(got, want, atol: float, share: float, tie=None, rtol: float = 0.0,
                           per_pixel: bool | None = None, what="") -> None:
    """Fewer than ``share`` of the samples differ from ``want`` by ``atol + rtol |want|`` or more
    (NaN counts as differing), those under ``tie`` left out. A sample is a pixel (its channels,
    the last axis, together) where ``per_pixel`` (default: for 3-axis arrays), else an element.
    Both comparisons are strict, so the rule is at least as strict as a test's own ``<=`` form."""
    got, want = np.asarray(got), np.asarray(want)
    d = np.abs(got - want)
    ok = d < atol + rtol * np.abs(want)
    if per_pixel if per_pixel is not None else ok.ndim == 3:
        ok = ok.reshape(ok.shape[0], ok.shape[1], -1).all(axis=-1)
    bad = ~ok
    if tie is not None:
        bad &= ~np.asarray(tie, bool)
    assert bad.mean() < share, (what, float(bad.mean()), float(np.nanmax(d)) if d.size else 0.0)


# ---------------------------------------------------------------- bit for bit


def assert_same_bits(a, b, what="", fields=None) -> None:
    """``a`` and ``b`` bit for bit: arrays (shape, dtype and bytes), bytes, dicts (the same keys),
    tuples and lists, or the named ``fields`` of two results (a field None in both is skipped)."""
    if fields is not None:
        for name in fields:
            x, y = getattr(a, name, None), getattr(b, name, None)
            if x is None and y is None:
                continue
            assert_same_bits(x, y, f"{what}: {name}")
        return
    if isinstance(a, dict) or isinstance(b, dict):
        assert isinstance(a, dict) and isinstance(b, dict) and a.keys() == b.keys(), \
            (what, sorted(a) if isinstance(a, dict) else a, sorted(b) if isinstance(b, dict) else b)
        for k in a:
            assert_same_bits(a[k], b[k], f"{what}: {k}")
        return
    if isinstance(a, (tuple, list)) or isinstance(b, (tuple, list)):
        assert type(a) is type(b) and len(a) == len(b), (what, a, b)
        for i, (x, y) in enumerate(zip(a, b)):
            assert_same_bits(x, y, f"{what}[{i}]")
        return
    if isinstance(a, (bytes, bytearray)) or isinstance(b, (bytes, bytearray)):
        assert a == b, f"{what} differs"
        return
    x, y = np.asarray(a), np.asarray(b)
    assert x.shape == y.shape and x.dtype == y.dtype, f"{what}: {x.shape} {x.dtype} vs {y.shape} {y.dtype}"
    if x.tobytes() != y.tobytes():
        where = np.argwhere(x != y)[:4].tolist() if x.ndim else []
        raise AssertionError(f"{what} differs at {where}")
