"""cellgl on Dask: bakes and sweeps larger than one machine (``pip install 'cellgl[dask]'``).

* :func:`to_dask` - a lazy ``dask.array`` whose blocks are rendered by cellgl on whichever
  worker runs them, bit-identical to :func:`cellgl.render` of the same region.
* :func:`bake_zarr` - ``cellgl bake RECIPE -o out.zarr``: a resumable, chunk-by-chunk Zarr v3
  bake on a Dask cluster (a local one sized to the machine, or ``--scheduler ADDRESS``).
* :func:`sweep` - ``cellgl sweep RECIPE --set seed=0..9999 -o dir/``: one file per variation.

Dask, distributed and zarr are imported only when one of these runs, so ``import cellgl`` works
without the extra. See ``docs/scale.md``.
"""

from __future__ import annotations

__all__ = ["to_dask", "bake_zarr", "sweep", "DaskError"]

_WHERE = {"to_dask": "blocks", "DaskError": "blocks", "bake_zarr": "zarr_bake", "sweep": "variations"}


def __getattr__(name: str):
    if name in _WHERE:
        import importlib

        return getattr(importlib.import_module(f"{__name__}.{_WHERE[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
