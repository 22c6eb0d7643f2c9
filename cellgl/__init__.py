"""cellgl: cellular texture basis functions (Worley, Qin, PUPs) on the GPU."""
from __future__ import annotations

from cellgl._version import __version__

from cellgl.basis.core import CellularResult, FeaturePoints, cellular, cellular_grid, feature_points
from cellgl.basis.density import DensityMap
from cellgl.basis.enums import Distribution, Metric
from cellgl.basis.voronoi import VoronoiResult, voronoi
from cellgl.recipes import evaluate, list_presets, load_recipe, render
from cellgl.texture.recipe import Recipe, RecipeError


def __getattr__(name: str):
    # cellgl.to_dask loads cellgl.dask (and dask itself) only when first used
    if name == "to_dask":
        from cellgl.dask import to_dask

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
    "voronoi",
    "VoronoiResult",
]
