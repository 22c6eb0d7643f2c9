"""The cellular basis (Worley 1996): feature points, F1..Fn, deltas, IDs and gradients.

Bottom to top: :mod:`~cellgl.basis.enums` (metric, distribution; the GLSL ``#define``s),
:mod:`~cellgl.basis.population` (integer hashes, population tables),
:mod:`~cellgl.basis.density` (spatially varying density maps),
:mod:`~cellgl.basis.reference` (the NumPy float64 twin of ``shaders/lib``),
:mod:`~cellgl.basis.gpu` (compute dispatch) and :mod:`~cellgl.basis.core` (the public API:
``cellular``, ``cellular_grid``, ``feature_points``).
"""

# the known-answer check of each context's GPU path, registered on import (issue 39)
from cellgl.basis import selfcheck as _selfcheck  # noqa: E402,F401
