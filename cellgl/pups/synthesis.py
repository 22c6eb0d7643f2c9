"""PUPs texture synthesis on the GPU.

After *Partition of unity parametrics for texture synthesis*: values stored at scattered 2D
control points are interpolated with partition-of-unity weights built on a Delaunay graph.

Pipeline
--------
1. Control points (:class:`PupsPoints`): positions, a value (scalar or RGB), an integer label
   and an orientation (a unit vector in R^3; only its xy part shifts weights). Generators:
   :func:`poisson_disk`, :func:`poisson_disk_variable`, :func:`space_giraffe`,
   :func:`cluster_labels`, :func:`labels_from_image`, :func:`labels_by_ramp`,
   :func:`random_orientations`.
2. Graph (:func:`pups_graph`): Delaunay triangulation (``scipy.spatial``); each point's axes are
   its edges. Periodic point sets are triangulated with their 8 copies around the domain, so
   the graph, and therefore the texture, wraps seamlessly.
3. Support: the weight of a point vanishes beyond the end of any axis, so its support is the
   convex polygon ``{u : (u - c).a <= f |a|^2}`` for its axes ``a`` (``f`` = axis-length
   factor). Its bounding box is computed exactly (feet of the axes and the corners between
   consecutive axes). Note that the corners may lie further than ``f`` times the longest
   axis, so a disc of that radius is *not* a safe bound.
4. Evaluation (:func:`pups_evaluate`): the points (and the periodic copies whose support
   reaches the domain) go to the GPU with their axes (CSR) and a uniform grid of candidate
   lists (a point is listed in every grid cell its support box touches). The compute shader
   ``shaders/pups.comp`` evaluates ``shaders/lib/pups.glsl``; ``backend="numpy"`` runs the
   float64 twin in :mod:`cellgl.pups.reference`.

The domain defaults to ``[-1, 1]^2`` as in the paper; pixel ``(i, j)`` (row ``j`` from the top)
samples ``x = x0 + (i + 0.5) (x1 - x0) / width``, ``y = y0 + (j + 0.5) (y1 - y0) / height``.
"""

from __future__ import annotations

import time

import numpy as np

from cellgl.gl.threads import gl_call
from cellgl.pups import gpu
from cellgl.pups.graph import PupsGraph
from cellgl.pups.pack import pups_pack
from cellgl.pups.points import PupsMode, check_epsilon
from cellgl.pups.reference import evaluate_reference

__all__ = ["pups_evaluate"]


# --------------------------------------------------------------------------------------------
# evaluation
# --------------------------------------------------------------------------------------------


@gl_call
def pups_evaluate(graph: PupsGraph, width, height, *, mode="interpolate", epsilon=0.5,
                  backend="gpu", tile=None, return_labels=False, timings=None,
                  method=None):
    """Evaluate a PUPs texture on a pixel grid covering the points' domain.

    Parameters
    ----------
    graph : PupsGraph
        From :func:`pups_graph`.
    width, height : int
        Image size in pixels, each in [1, 16384].
    mode : {"interpolate", "label", "weighted_sum"} or PupsMode
        ``interpolate``: weighted mean of the values (eq. 3); ``label``: the value of the
        heaviest point (cellular textures); ``weighted_sum``: sum of value * weight without
        normalising (with one-hot values it shows one point's weight, fig. 1).
    epsilon : float
        Orientation strength in [0, 1) (paper default 0.5).
    backend : {"gpu", "numpy"}
        Compute shader (float32) or the float64 reference.
    tile : int, optional
        Candidate-grid cell size in pixels (see :func:`pups_pack`).
    return_labels : bool
        Also return the label image (mode ``label`` only).
    timings : dict, optional
        Filled with stage times in seconds (``pack``, ``upload``, ``gpu``, ``readback``).
    method : {None, "raster", "compute"}
        GPU path (backend ``gpu``). ``compute``: the compute shader over candidate lists
        (``shaders/pups.comp``). ``raster`` (modes ``interpolate`` and ``weighted_sum``):
        each point's support polygon drawn as triangles, its data and axes passed as flat
        vertex outputs, weighted per fragment and summed by additive blending
        (``shaders/pups_raster.*``); same maths, same summation order, the same image. A set
        with more axes per point than the varying budget (:func:`_raster_pairs_limit`: 26
        axes on llvmpipe) falls back to ``compute``. Default None: ``raster`` where it
        applies, else ``compute`` (mode ``label``).

    Returns
    -------
    image : numpy.ndarray of float32, shape (height, width) or (height, width, 3)
        Per the values' channel count; 0 where no weight is non-zero.
    labels : numpy.ndarray of int32, shape (height, width)
        Only with ``return_labels``; -1 where no weight is non-zero.
    """
    if not isinstance(graph, PupsGraph):
        raise ValueError(f"graph must be a PupsGraph, got {type(graph).__name__}")
    mode = _parse_mode(mode)
    epsilon = check_epsilon(epsilon)
    if backend not in ("gpu", "numpy"):
        raise ValueError(f"backend must be 'gpu' or 'numpy', got {backend!r}")
    if return_labels and mode != PupsMode.LABEL:
        raise ValueError("return_labels needs mode='label'")
    if method not in (None, "compute", "raster"):
        raise ValueError(f"method must be None, 'compute' or 'raster', got {method!r}")
    if method == "raster" and mode == PupsMode.LABEL:
        raise ValueError("method='raster' supports modes 'interpolate' and 'weighted_sum'")
    timings = {} if timings is None else timings
    t0 = time.perf_counter()
    raster = backend == "gpu" and method != "compute" and gpu.raster_applies(graph, mode)
    packed = pups_pack(graph, width, height, tile=tile, grid=not raster)
    timings["grid"] = time.perf_counter() - t0
    if raster:
        vals, labs = gpu.evaluate_raster(packed, mode, epsilon, timings)
    elif backend == "gpu":
        vals, labs = gpu.evaluate_gpu(packed, mode, epsilon, timings)
    else:
        t1 = time.perf_counter()
        value, best, label, wsum = evaluate_reference(packed, packed.width, packed.height,
                                                      epsilon)
        vals = {PupsMode.INTERPOLATE: value, PupsMode.LABEL: best,
                PupsMode.WEIGHTED_SUM: wsum}[mode].astype(np.float32)
        labs = label
        timings["reference"] = time.perf_counter() - t1
    img = vals[..., 0] if vals.shape[-1] == 1 else vals
    img = np.ascontiguousarray(img, dtype=np.float32)
    if return_labels:
        return img, np.ascontiguousarray(labs, dtype=np.int32)
    return img


def _parse_mode(mode):
    if isinstance(mode, PupsMode):
        return mode
    if isinstance(mode, str) and mode.upper() in PupsMode.__members__:
        return PupsMode[mode.upper()]
    if isinstance(mode, (int, np.integer)) and not isinstance(mode, bool) and int(mode) in (0, 1, 2):
        return PupsMode(int(mode))
    raise ValueError(f"mode must be one of 'interpolate', 'label', 'weighted_sum', got {mode!r}")
