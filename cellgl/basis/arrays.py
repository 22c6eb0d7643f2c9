"""Input arrays as float64, refusing what is not a real number (issue 10): shared by the basis
entry points, :class:`cellgl.basis.density.DensityMap` images and :func:`cellgl.texture.evaluate`."""
from __future__ import annotations

import numbers

import numpy as np

__all__ = ["real_array", "refuse_masked"]

#: dtype kinds accepted as numbers: signed and unsigned integers, floats (and object arrays of
#: Python numbers, converted); bool, complex, datetime, strings are refused, never cast
_REAL_KINDS = "iuf"


def refuse_masked(name: str, value) -> None:
    """A NumPy masked array with masked entries has no value there: refuse it (its hidden data
    would otherwise be used as if it were valid)."""
    if np.ma.isMaskedArray(value) and np.ma.getmaskarray(value).any():
        i = tuple(int(k) for k in np.argwhere(np.ma.getmaskarray(value))[0])
        raise ValueError(f"{name} is a masked array with masked entries (first at {list(i)}); pass the "
                         f"values to use (e.g. .filled(...)) or only the unmasked rows")


def _not_real(v) -> bool:
    return isinstance(v, (bool, np.bool_)) or not isinstance(v, (numbers.Real, np.integer, np.floating))


def real_array(name: str, value, expected: str, copy: bool = True) -> np.ndarray:
    """``value`` as a float64 array, refusing what is not a real number (bool, complex, datetime,
    timedelta, strings, bytes, records, masked entries) with a ValueError naming ``name``, the
    dtype found and ``expected`` (the accepted shape), instead of a silent cast or a raw TypeError.
    ``copy=False``: a float64 ndarray comes back as it is (the caller must not write to it)."""
    refuse_masked(name, value)
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a numeric array {expected}: {exc}") from None
    if arr.dtype.kind == "O":
        items = arr.ravel().tolist()
        k = next((k for k, v in enumerate(items) if _not_real(v)), None)
        if k is not None:
            bad = items[k]
            raise ValueError(f"{name} must hold real numbers {expected}; got {type(bad).__name__} {bad!r}")
    elif arr.dtype.kind not in _REAL_KINDS:
        raise ValueError(f"{name} must hold real numbers (integers or floats) {expected}; got dtype "
                         f"{arr.dtype} (bool, complex, datetime and text are not numbers here)")
    try:
        return arr.astype(np.float64, copy=copy)
    except (TypeError, ValueError, OverflowError) as exc:
        raise ValueError(f"{name} must be a numeric array {expected}: {exc}") from None
