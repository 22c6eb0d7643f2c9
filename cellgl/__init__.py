"""cellgl: cellular texture basis functions (Worley, Qin, PUPs) on the GPU."""
from __future__ import annotations

__version__ = "0.1.0"

from .core import CellularResult, FeaturePoints, cellular, cellular_grid, feature_points
from .density import DensityMap
from .enums import Distribution, Metric
from .recipe import Recipe, RecipeError, list_presets, load_recipe
from .texture import evaluate, render


def __getattr__(name: str):
    # cellgl.to_dask loads cellgl.dask (and dask itself) only when first used
    if name == "to_dask":
        from .dask import to_dask

        return to_dask
    raise AttributeError(f"module 'cellgl' has no attribute {name!r}")

__all__ = [
    "CellularResult",
    "DensityMap",
    "Distribution",
    "FeaturePoints",
    "Metric",
    "Recipe",
    "RecipeError",
    "__version__",
    "cellular",
    "cellular_grid",
    "evaluate",
    "feature_points",
    "list_presets",
    "load_recipe",
    "render",
    "to_dask",
]
