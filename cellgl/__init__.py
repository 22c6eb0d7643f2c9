"""cellgl: cellular texture basis functions (Worley, Qin, PUPs) on the GPU.

The public names load on first use (PEP 562), so that ``import cellgl.cli`` -- the ``cellgl``
command -- starts with the standard library only: a Ctrl-C while it starts is handled as one
during a command (exit 130, no traceback), and ``cellgl --help`` is quick.
"""
from __future__ import annotations

import importlib
import importlib.util

from cellgl._version import __version__

TYPE_CHECKING = False   # (not typing's: importing typing would slow the command's start)


class _SourceViewer:
    """Finds ``cellgl.viewer`` in a source checkout (a meta path finder).

    The viewer's code is the repository's top-level ``viewer/`` folder; the wheel installs it as
    ``cellgl/viewer`` (pyproject.toml's package-dir), an editable install maps it there. Run from
    the source itself (``PYTHONPATH=.``, pytest) ``cellgl/`` has no ``viewer``: this finder gives
    ``cellgl.viewer`` the sibling folder, so the one name works everywhere."""

    def __init__(self, folder: str):
        self.folder = folder

    def find_spec(self, fullname, path=None, target=None):
        if fullname != "cellgl.viewer":
            return None
        return importlib.util.spec_from_file_location(
            fullname, self.folder + "/__init__.py", submodule_search_locations=[self.folder])


def _source_viewer() -> None:
    import os
    import sys

    here = os.path.dirname(os.path.abspath(__file__))
    root = os.path.dirname(here)
    folder = os.path.join(root, "viewer")
    source = not os.path.isdir(os.path.join(here, "viewer")) and os.path.isfile(os.path.join(root, "pyproject.toml")) \
        and os.path.isfile(os.path.join(folder, "__init__.py"))
    if source and not any(isinstance(f, _SourceViewer) for f in sys.meta_path):
        sys.meta_path.insert(0, _SourceViewer(folder))


_source_viewer()

#: public name -> the module that defines it
_EXPORTS = {
    "CellularResult": "cellgl.basis.core",
    "FeaturePoints": "cellgl.basis.core",
    "cellular": "cellgl.basis.core",
    "cellular_grid": "cellgl.basis.core",
    "feature_points": "cellgl.basis.core",
    "DensityMap": "cellgl.basis.density",
    "Distribution": "cellgl.basis.enums",
    "Metric": "cellgl.basis.enums",
    "VoronoiResult": "cellgl.basis.voronoi",
    "voronoi": "cellgl.basis.voronoi",
    "evaluate": "cellgl.recipes",
    "list_presets": "cellgl.recipes",
    "load_recipe": "cellgl.recipes",
    "render": "cellgl.recipes",
    "Recipe": "cellgl.texture.recipe",
    "RecipeError": "cellgl.texture.recipe",
    "to_dask": "cellgl.dask",
}

if TYPE_CHECKING:  # pragma: no cover - for type checkers and editors
    from cellgl.basis.core import CellularResult, FeaturePoints, cellular, cellular_grid, feature_points
    from cellgl.basis.density import DensityMap
    from cellgl.basis.enums import Distribution, Metric
    from cellgl.basis.voronoi import VoronoiResult, voronoi
    from cellgl.dask import to_dask
    from cellgl.recipes import evaluate, list_presets, load_recipe, render
    from cellgl.texture.recipe import Recipe, RecipeError


def __getattr__(name: str):
    # The first public name used loads what this package used to import eagerly (so that
    # cellgl.basis.core, cellgl.texture, ... are bound as before); cellgl.dask stays optional.
    if name.startswith("_"):     # private: a submodule being imported, or nothing
        raise AttributeError(f"module 'cellgl' has no attribute {name!r}")
    for export, module in _EXPORTS.items():
        if export != "to_dask" and export not in globals():
            globals()[export] = getattr(importlib.import_module(module), export)
    if name in globals():
        return globals()[name]
    if name == "to_dask":
        return importlib.import_module("cellgl.dask").to_dask
    if importlib.util.find_spec(f"cellgl.{name}") is not None:
        return importlib.import_module(f"cellgl.{name}")
    raise AttributeError(f"module 'cellgl' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))


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
