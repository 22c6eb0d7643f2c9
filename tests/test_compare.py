"""The comparison helpers (tests/compare.py) catch what they are for: each is shown failing on
an answer one step off, and passing on the same answer."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

import compare as C


def _fails(fn, *args, **kw):
    with pytest.raises(AssertionError):
        fn(*args, **kw)


def test_same_bits_sees_one_ulp_a_sign_of_zero_a_dtype_and_a_missing_field():
    a = np.linspace(0.0, 1.0, 50, dtype=np.float32)
    C.assert_same_bits(a, a.copy())
    _fails(C.assert_same_bits, a, np.nextafter(a, np.float32(2.0)))
    z = np.zeros(3, np.float32)
    _fails(C.assert_same_bits, z, -z)                      # equal values, other bits
    _fails(C.assert_same_bits, a, a.astype(np.float64))
    _fails(C.assert_same_bits, a, a[:-1])
    C.assert_same_bits({"x": a, "b": b"\x00\x01"}, {"x": a.copy(), "b": b"\x00\x01"})
    _fails(C.assert_same_bits, {"x": a}, {"x": a, "y": a})
    _fails(C.assert_same_bits, {"b": b"\x00\x01"}, {"b": b"\x00\x02"})
    C.assert_same_bits((a, z), (a, z))
    _fails(C.assert_same_bits, (a, z), (a, z + 1))
    r, s = SimpleNamespace(F=a, id=None), SimpleNamespace(F=a.copy(), id=None)
    C.assert_same_bits(r, s, fields=("F", "id"))           # a field None in both is skipped
    _fails(C.assert_same_bits, r, SimpleNamespace(F=a, id=np.zeros(3)), fields=("F", "id"))


def test_the_bound_and_near_ties_are_the_documented_ones():
    F = np.array([[1.0, 1.0 + 30 * C.U32, 2.0], [1.0, 1.5, 2.0]])
    # eps(F) = u (18 F + 2 S + 4): at F = 1, S = 1, 24 u; a gap of 2 eps is a near-tie
    assert C.f_bound(1.0) == 24 * C.U32
    assert C.near_ties(F).tolist() == [True, False]
    assert not C.near_ties(F[:, :1]).any()                 # one distance: no tie
    C.assert_F_within_bound(np.float32(1.0) + np.float32(2 ** -23), np.array([1.0]))   # 2 u < 24 u
    _fails(C.assert_F_within_bound, np.array([1.0 + 25 * C.U32]), np.array([1.0]))
    ref = {"F1": np.array([[1.0, 1.0]]), "F2": np.array([[1.0 + 40 * C.U32, 1.5]])}
    assert C.texture_near_ties(ref, 1.0).tolist() == [[True, False]]
    rec = SimpleNamespace(get={"frequency": 4.0, "aspect": 2.0}.get)
    assert C.octave_sum(rec) == 9.0


def test_ids_may_differ_only_at_ties():
    ids = np.arange(6, dtype=np.uint32)
    other = ids.copy()
    other[2] = 99
    tie = np.zeros(6, bool)
    _fails(C.assert_ids_equal_but_ties, other, ids, tie)
    tie[2] = True
    C.assert_ids_equal_but_ties(other, ids, tie)


def test_never_wrong_while_exact():
    want = np.array([1.0, 2.0, 3.0])
    exact = np.ones(3, bool)
    C.assert_never_wrong_while_exact("ok", want + 1e-5, want, exact)
    _fails(C.assert_never_wrong_while_exact, "wrong", want + [0, 3e-4, 0], want, exact)
    _fails(C.assert_never_wrong_while_exact, "flagged", want, want, np.array([True, False, True]))
    _fails(C.assert_never_wrong_while_exact, "reach", want, want, exact, reach=2.5)


def test_basis_ids_swap_only_at_ties():
    F = np.array([[1.0, 1.00001, 2.0], [1.0, 1.5, 2.0]], np.float32)
    ids = np.array([[1, 2, 3], [4, 5, 6]], np.uint32)
    swapped = ids.copy()
    swapped[0, :2] = [2, 1]                                # F1 = F2 to 1e-5: a tie
    C.assert_basis_matches(SimpleNamespace(F=F, id=swapped), SimpleNamespace(F=F, id=ids))
    swapped = ids.copy()
    swapped[1, :2] = [5, 4]                                # 0.5 apart: wrong
    _fails(C.assert_basis_matches, SimpleNamespace(F=F, id=swapped), SimpleNamespace(F=F, id=ids))
    _fails(C.assert_basis_matches, SimpleNamespace(F=F + 1e-4, id=ids), SimpleNamespace(F=F, id=ids))


def test_render_matches_masks_only_the_ties_it_is_told():
    n = {"F1": np.array([[0.2, 0.5]]), "F2": np.array([[0.20001, 0.9]]), "height": np.array([[0.1, 0.1]]),
         "id": np.array([[1, 2]], np.uint32)}
    g = dict(n, height=np.array([[0.3, 0.1]]), id=np.array([[7, 2]], np.uint32))
    _fails(C.assert_render_matches, g, n, ("height",), atol=2e-4)       # the tie texel's height is off
    tie = C.assert_render_matches(g, n, ("height",), atol=2e-4, mask_ties=True)
    assert tie.tolist() == [[True, False]]
    _fails(C.assert_render_matches, dict(g, id=np.array([[7, 3]], np.uint32)), n, ("height",), atol=2e-4,
           mask_ties=True)


def test_close_but_share_counts_pixels_nan_and_the_boundary():
    want = np.zeros((10, 10, 3))
    got = want.copy()
    got[0, 0, 1] = 1.0                                     # one pixel of 100 off: 1 %
    C.assert_close_but_share(got, want, 2e-3, share=0.02)
    _fails(C.assert_close_but_share, got, want, 2e-3, share=0.01)            # under 1 %: strict
    C.assert_close_but_share(got, want, 2e-3, share=0.005, per_pixel=False)  # 1 element of 300
    got[0, 1, 0] = np.nan
    _fails(C.assert_close_but_share, got, want, 2e-3, share=0.02)            # NaN counts as off
    tie = np.zeros((10, 10), bool)
    tie[0, :2] = True
    C.assert_close_but_share(got, want, 2e-3, share=0.001, tie=tie)
    _fails(C.assert_close_but_share, want + 2e-3, want, 2e-3, share=0.5)     # at the tolerance: off
