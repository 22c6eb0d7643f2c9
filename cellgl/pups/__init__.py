"""PUPs texture synthesis: partition-of-unity interpolation over scattered control points.

After *Partition of unity parametrics for texture synthesis*. The pipeline, one module a step:

1. :mod:`cellgl.pups.points` / :mod:`cellgl.pups.generators`: control points and their values,
   labels and orientations (Poisson-disk sets, space giraffe, labels from images or ramps);
2. :mod:`cellgl.pups.graph`: the Delaunay graph, each point's axes and its exact support box;
3. :mod:`cellgl.pups.pack`: the instances that reach the image and the candidate grid;
4. :mod:`cellgl.pups.gpu` (compute, fragment and raster paths) and :mod:`cellgl.pups.reference`
   (the NumPy float64 twin), driven by :func:`cellgl.pups.synthesis.pups_evaluate`;
5. :mod:`cellgl.pups.presets` (one per figure of the paper) and :mod:`cellgl.pups.recipe` (the
   presets as recipes that bake, preview and list like cellular ones).

This package re-exports the public functions of those modules.
"""
from __future__ import annotations

from cellgl.basis import selfcheck as _selfcheck  # noqa: F401 - the GPU path's known-answer check
from cellgl.pups.generators import (cluster_labels, labels_by_ramp, labels_from_image, poisson_disk,
                                    poisson_disk_variable, random_orientations, space_giraffe)
from cellgl.pups.graph import PupsGraph, pups_graph
from cellgl.pups.pack import PupsPacked, pups_pack
from cellgl.pups.points import DEFAULT_DOMAIN, PupsMode, PupsPoints, pups_points
from cellgl.pups.presets import pups_presets, pups_render
from cellgl.pups.synthesis import pups_evaluate

__all__ = ["PupsMode", "PupsPoints", "PupsGraph", "PupsPacked", "DEFAULT_DOMAIN", "pups_points", "poisson_disk",
           "poisson_disk_variable", "space_giraffe", "cluster_labels", "labels_from_image", "labels_by_ramp",
           "random_orientations", "pups_graph", "pups_pack", "pups_evaluate", "pups_render", "pups_presets"]
