"""cellgl: cellular texture basis functions (Worley, Qin, PUPs) on the GPU."""
from __future__ import annotations

__version__ = "0.1.0"

from .core import CellularResult, FeaturePoints, cellular, cellular_grid, feature_points
from .enums import Distribution, Metric

__all__ = [
    "CellularResult",
    "Distribution",
    "FeaturePoints",
    "Metric",
    "__version__",
    "cellular",
    "cellular_grid",
    "feature_points",
]
