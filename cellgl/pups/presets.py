"""PUPs presets: the textures of the paper's figures, as plain JSON-able data.

:data:`PUPS_PRESETS` maps a preset name to a parameter dict (``kind`` plus that kind's
parameters; ``figure`` and ``description`` are documentation only). :func:`build_pups` turns a
name or such a dict into an image. Distances are in domain units on ``[-1, 1]^2`` as in the
paper (the octave radii ``0.1 * 2^-i`` are the paper's numbers). Every point set is periodic,
so every texture built from one tiles (the progressive and ramp ones tile too, with a visible
jump in density or tone at the seam).

Kinds and their parameters (defaults in :data:`KIND_DEFAULTS`):

``noise``       random intensities at Poisson-disk points; ``fold`` applies ``2|T - 0.5|``
``octaves``     ``sum_i 2^-i T_i`` over ``octaves`` densities (radius ``radius * 2^-i``),
                normalised by ``sum_i 2^-i``; ``fold`` folds each octave first (turbulence)
``cells``       one label per point (``group="point"``) or clusters of 3-4 graph neighbours
                (``group="cluster"``), a random gray per label
``multiscale-cells``  cells at ``octaves`` densities summed like ``octaves``
``cow``         binary labels, random (``labels="random"``), by an x ramp (``"ramp"``) or from
                a reference image (``"image"``); ``radius_max`` > ``radius`` makes the density
                grow to the right (progressive)
``giraffe``     space giraffe: Poisson cell centres, spots of inner/outer point pairs
``refine``      iterative refinement: labels drawn from the previous image, intensity
                interpolation, density doubling each iteration
``weight``      the raw weight of the control point nearest the centre (fig. 1, 3);
                ``contours`` > 0 draws that many isolines
``graph``       the Delaunay graph drawn as lines (fig. 2)

Common parameters: ``radius`` (Poisson minimum distance), ``axis_factor``, ``epsilon``,
``orientation`` (``"random"``: uniform on the sphere, ``"none"``, ``"right"``, ``"outward"``:
away from the centre, or ``"tilt"`` with ``tilt`` degrees from the z-axis towards +x).
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from cellgl.pups.generators import sample_map, cluster_labels, labels_by_ramp, labels_from_image, poisson_disk, poisson_disk_variable, random_orientations, space_giraffe
from cellgl.pups.graph import pups_graph
from cellgl.pups.points import DEFAULT_DOMAIN, check_size, pups_points
from cellgl.pups.synthesis import pups_evaluate

__all__ = ["PUPS_PRESETS", "KIND_DEFAULTS", "build_pups", "build_scene", "evaluate_scene",
           "PupsScene", "PupsLayer", "reference_image", "REFINE_WORKING_SIZE", "pups_presets", "pups_render"]

_COMMON: dict[str, Any] = {"radius": 0.06, "axis_factor": 1.0, "epsilon": 0.5, "orientation": "random",
           "tilt": 0.0}

KIND_DEFAULTS: dict[str, dict[str, Any]] = {
    "noise": {**_COMMON, "radius": 0.1, "fold": False},
    "octaves": {**_COMMON, "radius": 0.1, "octaves": 4, "fold": False},
    "cells": {**_COMMON, "group": "point", "cluster_sizes": [3, 4]},
    "multiscale-cells": {**_COMMON, "radius": 0.16, "octaves": 4},
    "cow": {**_COMMON, "radius": 0.05, "radius_max": None, "labels": "random",
            "image": "builtin:shapes"},
    "giraffe": {**_COMMON, "radius": 0.16, "radius_max": None, "n_range": [10, 20],
                "spot": [0.36, 0.2, 0.08], "background": [0.96, 0.86, 0.62]},
    "refine": {**_COMMON, "radius": 0.08, "iterations": 4, "image": "builtin:shapes"},
    "weight": {**_COMMON, "radius": 0.4, "orientation": "none", "contours": 0},
    "graph": {**_COMMON, "radius": 0.12, "line_width": 1.5},
}

PUPS_PRESETS: dict[str, dict[str, Any]] = {
    "pups-weight": {"kind": "weight", "figure": "1a",
                    "description": "Weight of one control point (brighter: more weight)."},
    "pups-weight-isolines": {"kind": "weight", "contours": 10, "figure": "1b",
                             "description": "Isovalues of one control point's weight."},
    "pups-graph": {"kind": "graph", "figure": "2",
                   "description": "The Delaunay triangulation of a Poisson-disk point set."},
    "pups-orientation-weight": {"kind": "weight", "orientation": "tilt", "tilt": 80.0,
                                "epsilon": 0.5, "contours": 10, "figure": "3",
                                "description": "A point's weight shifted by an orientation "
                                               "tilted 80 degrees from z towards +x."},
    "pups-noise": {"kind": "noise", "figure": "7 (top)",
                   "description": "Random intensities at Poisson-disk points (one octave)."},
    "pups-noise-folded": {"kind": "noise", "fold": True, "figure": "7 (bottom)",
                          "description": "One octave folded: 2|T - 0.5|."},
    "pups-noise-long-axes": {"kind": "noise", "axis_factor": 2.0, "figure": "4b",
                             "description": "Same points as pups-noise, axes twice as long: "
                                            "smoother, approximating."},
    "pups-octaves": {"kind": "octaves", "figure": "6",
                     "description": "Multiscale noise: sum over 4 densities, weights 2^-i."},
    "pups-turbulence": {"kind": "octaves", "fold": True, "figure": "8",
                        "description": "Turbulence: sum of folded octaves."},
    "pups-cells": {"kind": "cells", "figure": "9a, 5a",
                   "description": "One label per point: organic Voronoi-like cells."},
    "pups-cells-right": {"kind": "cells", "orientation": "right", "epsilon": 0.9,
                         "figure": "5b", "description": "Cells with every orientation "
                                                       "pointing right."},
    "pups-cells-outward": {"kind": "cells", "orientation": "outward", "epsilon": 0.9,
                           "figure": "5c", "description": "Cells with orientations pointing "
                                                         "away from the centre."},
    "pups-clusters": {"kind": "cells", "group": "cluster", "figure": "9b",
                      "description": "Clusters of 3-4 points per label."},
    "pups-multiscale-cells": {"kind": "multiscale-cells", "figure": "10",
                              "description": "Four layers of cells of increasing density, "
                                             "amplitude 2^-i."},
    "pups-cow": {"kind": "cow", "figure": "11",
                 "description": "Random binary labels: cow pattern."},
    "pups-giraffe": {"kind": "giraffe", "figure": "12",
                     "description": "Space giraffe: spots of inner/outer point pairs."},
    "pups-reference-image": {"kind": "cow", "labels": "image", "radius": 0.012,
                             "figure": "13a", "description": "The built-in reference image "
                                                              "seen through very dense points."},
    "pups-reference": {"kind": "cow", "labels": "image", "radius": 0.04, "figure": "13c",
                       "description": "Labels drawn from a grayscale reference image."},
    "pups-reference-coarse": {"kind": "cow", "labels": "image", "radius": 0.08,
                              "figure": "13b", "description": "As pups-reference, sparser "
                                                              "points: larger features."},
    "pups-reference-fine": {"kind": "cow", "labels": "image", "radius": 0.02, "figure": "13d",
                            "description": "As pups-reference, denser points."},
    "pups-refine": {"kind": "refine", "figure": "14",
                    "description": "Iterative refinement, density doubling: fractal "
                                   "boundaries."},
    "pups-progressive-cow": {"kind": "cow", "radius": 0.025, "radius_max": 0.12,
                             "figure": "15", "description": "Cow pattern, point density "
                                                            "increasing to the right."},
    "pups-progressive-giraffe": {"kind": "giraffe", "radius": 0.08, "radius_max": 0.3,
                                 "figure": "16", "description": "Space giraffe, density "
                                                                "increasing to the right."},
    "pups-ramp": {"kind": "cow", "labels": "ramp", "radius": 0.035, "figure": "17",
                  "description": "Black/white labels with probability ramping along x."},
}

_DOC_KEYS = ("kind", "figure", "description")


# --------------------------------------------------------------------------------------------


#: the largest side of a reference image file (labels sample it per point: more detail is unused)
MAX_REFERENCE_SIDE = 4096


def reference_image(name="builtin:shapes", size=256):
    """A grayscale reference image for label assignment, values in [0, 1].

    Parameters
    ----------
    name : str
        ``"builtin:shapes"`` (a disc, a ring and a wavy band with soft edges: gray only near
        boundaries) or a path to an image file (converted to grayscale; sides up to
        :data:`MAX_REFERENCE_SIDE`, checked from the header before the image is decoded).
    size : int
        Side of the built-in image in pixels.

    Returns
    -------
    numpy.ndarray of float64, shape (H, W)
    """
    if name == "builtin:shapes":
        t = (np.arange(size) + 0.5) / size * 2 - 1
        x, y = np.meshgrid(t, t)
        soft = 0.06

        def s(d):  # inside when d < 0, smooth edge of width ~soft
            return np.clip(0.5 - d / (2 * soft), 0, 1)

        disc = s(np.hypot(x + 0.35, y + 0.3) - 0.45)
        ring = s(np.abs(np.hypot(x - 0.45, y - 0.45) - 0.3) - 0.1)
        band = s(np.abs(y - 0.55 - 0.15 * np.sin(5 * x)) - 0.08) * (x < 0.05)
        return np.clip(np.maximum(np.maximum(disc, ring), band), 0, 1)
    if isinstance(name, str) and name.startswith("builtin:"):
        raise ValueError(f"unknown built-in reference image {name!r}; accepted: 'builtin:shapes'")
    from PIL import Image
    img = None
    try:
        with Image.open(name) as im:
            # the header gives the size: a huge image is refused before it is decoded
            w, h = im.size
            if 1 <= w <= MAX_REFERENCE_SIDE and 1 <= h <= MAX_REFERENCE_SIDE:
                img = im.convert("L")
    except Exception as e:  # noqa: BLE001 - Pillow raises many kinds (OSError, DecompressionBombError)
        raise ValueError(f"cannot read reference image {name!r}: {e}") from None
    if img is None:
        raise ValueError(f"reference image {name!r} is {w}x{h}; accepted: sides 1..{MAX_REFERENCE_SIDE} "
                         f"(scale it down first)")
    return np.asarray(img, dtype=np.float64) / 255.0


def _params(preset_or_params):
    if isinstance(preset_or_params, str):
        name = preset_or_params
        if name not in PUPS_PRESETS and f"pups-{name}" in PUPS_PRESETS:
            name = f"pups-{name}"
        if name not in PUPS_PRESETS:
            raise ValueError(f"unknown PUPs preset {preset_or_params!r}; accepted: "
                             f"{', '.join(sorted(PUPS_PRESETS))}")
        params = copy.deepcopy(PUPS_PRESETS[name])
    elif isinstance(preset_or_params, dict):
        params = copy.deepcopy(preset_or_params)
    else:
        raise ValueError(f"preset must be a name or a dict, got {type(preset_or_params).__name__}")
    kind = params.get("kind")
    if kind not in KIND_DEFAULTS:
        raise ValueError(f"unknown PUPs kind {kind!r}; accepted: {', '.join(KIND_DEFAULTS)}")
    unknown = set(params) - set(KIND_DEFAULTS[kind]) - set(_DOC_KEYS)
    if unknown:
        raise ValueError(f"unknown parameter(s) {sorted(unknown)} for kind {kind!r}; accepted: "
                         f"{sorted(KIND_DEFAULTS[kind])}")
    out = copy.deepcopy(KIND_DEFAULTS[kind])
    out.update({k: v for k, v in params.items() if k not in ("figure", "description")})
    return out


def _stream(seed, k):
    return np.random.default_rng([int(seed), k])


def _orientations(p, pos, seed):
    n = pos.shape[0]
    o = p["orientation"]
    if o == "random":
        return random_orientations(n, seed=_stream(seed, 99))
    if o == "none":
        return np.zeros((n, 3))
    if o == "right":
        return np.tile([1.0, 0.0, 0.0], (n, 1))
    if o == "outward":
        r = np.hypot(pos[:, 0], pos[:, 1])
        xy = np.divide(pos, r[:, None], out=np.zeros_like(pos), where=r[:, None] > 0)
        return np.c_[xy, np.zeros(n)]
    if o == "tilt":
        t = math.radians(float(p["tilt"]))
        return np.tile([math.sin(t), 0.0, math.cos(t)], (n, 1))
    raise ValueError(f"orientation must be one of 'random', 'none', 'right', 'outward', "
                     f"'tilt', got {o!r}")


def _poisson(p, seed, k, radius=None):
    r = p["radius"] if radius is None else radius
    rmax = p.get("radius_max")
    if rmax is not None and radius is None:
        return poisson_disk_variable(r, rmax, lambda xy: (xy[:, 0] + 1) / 2,
                                       seed=_stream(seed, k))
    return poisson_disk(r, seed=_stream(seed, k))


#: side of the square image the ``refine`` kind's intermediate iterations are evaluated at
#: (their labels are drawn from it), whatever the output size, so that the result does not
#: depend on the output resolution and can be rendered tile by tile
REFINE_WORKING_SIZE = 512


@dataclass(frozen=True, eq=False)
class PupsLayer:
    """One PUPs evaluation of a scene: a graph, how to evaluate it, and its weight.

    Attributes
    ----------
    graph : cellgl.pups.PupsGraph
        On the preset domain ``[-1, 1]^2`` (periodic).
    mode : str
        ``interpolate``, ``label`` or ``weighted_sum``.
    epsilon : float
    amplitude : float
        Weight in the normalised sum over layers.
    fold : bool
        ``2 |T - 0.5|`` before summing.
    """

    graph: object
    mode: str
    epsilon: float
    amplitude: float = 1.0
    fold: bool = False


@dataclass(frozen=True, eq=False)
class PupsScene:
    """Everything of a preset that does not depend on the image size: point sets and graphs.

    ``layers`` are evaluated and combined by :func:`evaluate_scene`; ``lines`` (kind
    ``graph``) holds the positions and the graph to draw instead.
    """

    params: dict
    layers: tuple
    contours: int = 0
    lines: tuple | None = None

    @property
    def channels(self) -> int:
        """1 (intensity) or 3 (RGB)."""
        if self.lines is not None:
            return 1
        return self.layers[0].graph.points.channels


def _graph(p, pos, values, labels, seed, axis_factor=None):
    pts = pups_points(pos, values, labels, _orientations(p, pos, seed))
    return pups_graph(pts, p["axis_factor"] if axis_factor is None else axis_factor)


def _noise_graph(p, radius, seed, k):
    pos = poisson_disk(radius, seed=_stream(seed, k))
    vals = _stream(seed, k + 1000).random(pos.shape[0])
    return _graph(p, pos, vals, None, seed + k)


def _cells_graph(p, radius, seed, k):
    pos = poisson_disk(radius, seed=_stream(seed, k))
    pts = pups_points(pos, orientations=_orientations(p, pos, seed + k))
    g = pups_graph(pts, p["axis_factor"])
    if p.get("group", "point") == "cluster":
        labels = cluster_labels(g, sizes=p["cluster_sizes"], seed=_stream(seed, k + 2000))
    elif p.get("group", "point") == "point":
        labels = np.arange(pos.shape[0], dtype=np.int32)
    else:
        raise ValueError(f"group must be 'point' or 'cluster', got {p['group']!r}")
    gray = _stream(seed, k + 1000).random(int(labels.max()) + 1)
    return pups_graph(pts.replace(values=gray[labels], labels=labels), p["axis_factor"])


def _sample_image(img, pos):
    return sample_map(img, pos, DEFAULT_DOMAIN)


def build_scene(preset_or_params, *, seed=0, backend="gpu") -> PupsScene:
    """The point sets and graphs of a preset name or parameter dict (no image yet).

    Parameters
    ----------
    preset_or_params : str or dict
        As :func:`build_pups`.
    seed : int
        Seed of every random choice.
    backend : {"gpu", "numpy"}
        Only the ``refine`` kind evaluates anything here (its intermediate iterations, at
        :data:`REFINE_WORKING_SIZE` squared).

    Returns
    -------
    PupsScene
    """
    p = _params(preset_or_params)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be an integer >= 0, got {seed!r}")
    seed = int(seed)
    kind = p["kind"]
    eps = p["epsilon"]
    if kind == "noise":
        return PupsScene(p, (PupsLayer(_noise_graph(p, p["radius"], seed, 0), "interpolate", eps,
                                       fold=bool(p["fold"])),))
    if kind in ("octaves", "multiscale-cells"):
        n = int(p["octaves"])
        if not 1 <= n <= 8:
            raise ValueError(f"octaves must be in [1, 8], got {p['octaves']!r}")
        layers = []
        for i in range(n):
            r = p["radius"] * 2.0 ** -i
            if kind == "octaves":
                layers.append(PupsLayer(_noise_graph(p, r, seed, 10 * i), "interpolate", eps,
                                        2.0 ** -i, bool(p["fold"])))
            else:
                layers.append(PupsLayer(_cells_graph(p, r, seed, 10 * i), "label", eps, 2.0 ** -i))
        return PupsScene(p, tuple(layers))
    if kind == "cells":
        return PupsScene(p, (PupsLayer(_cells_graph(p, p["radius"], seed, 0), "label", eps),))
    if kind == "cow":
        pos = _poisson(p, seed, 0)
        if p["labels"] == "random":
            labels = (_stream(seed, 1).random(pos.shape[0]) < 0.5).astype(np.int32)
        elif p["labels"] == "ramp":
            labels = labels_by_ramp(pos, seed=_stream(seed, 1))
        elif p["labels"] == "image":
            labels = labels_from_image(pos, reference_image(p["image"]), seed=_stream(seed, 1))
        else:
            raise ValueError(f"labels must be 'random', 'ramp' or 'image', got {p['labels']!r}")
        g = _graph(p, pos, labels.astype(np.float64), labels, seed)
        return PupsScene(p, (PupsLayer(g, "label", eps),))
    if kind == "giraffe":
        centres = _poisson(p, seed, 0)
        pos, labels = space_giraffe(centres, n_range=p["n_range"], seed=_stream(seed, 1))
        colours = np.array([p["background"], p["spot"]], dtype=np.float64)
        return PupsScene(p, (PupsLayer(_graph(p, pos, colours[labels], labels, seed), "label",
                                       eps),))
    if kind == "refine":
        n = int(p["iterations"])
        if not 1 <= n <= 8:
            raise ValueError(f"iterations must be in [1, 8], got {p['iterations']!r}")
        img = reference_image(p["image"])
        s = REFINE_WORKING_SIZE
        for i in range(n):
            pos = poisson_disk(p["radius"] * 2.0 ** (-i / 2), seed=_stream(seed, 10 * i))
            inten = _sample_image(img, pos)
            labels = (_stream(seed, 10 * i + 1).random(pos.shape[0]) < inten).astype(np.int32)
            g = _graph(p, pos, labels.astype(np.float64), labels, seed + i)
            if i < n - 1:
                img = pups_evaluate(g, s, s, mode="interpolate", epsilon=eps,
                                      backend=backend).astype(np.float64)
        return PupsScene(p, (PupsLayer(g, "interpolate", eps),))
    if kind == "weight":
        pos = _poisson(p, seed, 0)
        c = int(np.argmin(np.hypot(pos[:, 0], pos[:, 1])))
        pos = pos - pos[c]  # put that point at the centre (the set is periodic)
        vals = np.zeros(pos.shape[0])
        vals[c] = 1.0
        return PupsScene(p, (PupsLayer(_graph(p, pos, vals, None, seed), "weighted_sum", eps),),
                         contours=int(p["contours"]))
    if kind == "graph":
        pos = _poisson(p, seed, 0)
        return PupsScene(p, (), lines=(pos, pups_graph(pups_points(pos))))
    raise AssertionError(kind)


def evaluate_scene(scene: PupsScene, evaluate_layer, draw_lines=None) -> np.ndarray:
    """Combine a scene's layers into an image.

    Parameters
    ----------
    scene : PupsScene
    evaluate_layer : callable
        ``evaluate_layer(layer) -> float32 (h, w) or (h, w, 3)``: one layer on the pixel grid
        wanted (:func:`build_pups`: the whole image with :func:`cellgl.pups.pups_evaluate`;
        :mod:`cellgl.pups.recipe`: one tile of it). Per pixel, the combination below depends
        only on the layers' values at that pixel.
    draw_lines : callable, optional
        ``draw_lines(positions, graph, params) -> float32 (h, w)`` for the ``graph`` kind.

    Returns
    -------
    numpy.ndarray of float32, shape (h, w) or (h, w, 3)
    """
    if scene.lines is not None:
        return draw_lines(*scene.lines, scene.params)
    layers = scene.layers
    if len(layers) == 1 and layers[0].amplitude == 1.0:
        t = evaluate_layer(layers[0])
        if layers[0].fold:
            t = 2 * np.abs(t - 0.5)
        if scene.contours > 0 or layers[0].mode == "weighted_sum":
            wt = t.astype(np.float64)
            k = scene.contours
            if k > 0:
                band = np.abs(np.mod(wt * k + 0.5, 1.0) - 0.5)
                lines = (band < 0.04) & (wt * k > 0.5)
                wt = np.where(lines, 1.0, 0.35 * wt)
            return wt.astype(np.float32)
        return np.ascontiguousarray(t, dtype=np.float32)
    acc = None
    for layer in layers:
        t = evaluate_layer(layer)
        if layer.fold:
            t = 2 * np.abs(t - 0.5)
        if acc is None:
            acc = np.zeros(t.shape, dtype=np.float64)
        acc += t * layer.amplitude
    return (acc / sum(layer.amplitude for layer in layers)).astype(np.float32)


def build_pups(preset_or_params, width, height, *, seed=0, backend="gpu"):
    """Build the image of a preset name or parameter dict.

    Parameters
    ----------
    preset_or_params : str or dict
        A key of :data:`PUPS_PRESETS` (the ``pups-`` prefix may be left out) or a dict with a
        ``kind`` and that kind's parameters (see the module docstring).
    width, height : int
        Image size in pixels, each in [1, 16384]. The domain ``[-1, 1]^2`` is stretched over
        the image.
    seed : int
        Seed of every random choice.
    backend : {"gpu", "numpy"}

    Returns
    -------
    numpy.ndarray of float32, shape (height, width) or (height, width, 3)
    """
    p = _params(preset_or_params)
    w, h = check_size(width, height)
    scene = build_scene(p, seed=seed, backend=backend)

    def layer(lay):
        return pups_evaluate(lay.graph, w, h, mode=lay.mode, epsilon=lay.epsilon,
                               backend=backend)

    return evaluate_scene(scene, layer, lambda pos, g, prm: draw_graph(prm, w, h, pos=pos, graph=g))


#: samples of line (and point) footprints scattered per pass of :func:`draw_graph` (bounds its
#: working memory to a few hundred MB whatever the number of edges)
_DRAW_CHUNK = 1 << 21


def draw_graph(p, w, h, *, pos, graph, scale=None, region=None):
    """Rasterise the Delaunay edges (anti-aliased lines) and the points, white on black.

    ``scale``: pixels per domain unit ``(sx, sy)``, default ``(w / 2, h / 2)`` (the domain
    stretched over the image). ``region``: ``(x0, y0, tw, th)``, the pixels to return; every
    pixel gets the same value as in the whole image.

    Each edge is sampled every half pixel (``n = int(2 * max(|dx|, |dy|)) + 2`` samples at
    ``linspace(0, 1, n)``), each sample lights the 5 x 5 pixels around it by its distance to them
    (``clip(line_width / 2 + 0.5 - d, 0, 1) * 0.8``), each point the pixels within 4 of it
    (``clip(3.5 - d, 0, 1)``); a pixel keeps the largest. All edges at once, in chunks of
    :data:`_DRAW_CHUNK` samples (a maximum does not depend on the order the values come in).
    """
    g = graph
    owner = np.repeat(np.arange(len(pos)), np.diff(g.offsets))
    a = pos[owner]
    b = a + g.axes
    sx, sy = (w / 2.0, h / 2.0) if scale is None else scale
    a = (a + 1) * [sx, sy] - 0.5
    b = (b + 1) * [sx, sy] - 0.5
    ox, oy, w, h = (0, 0, w, h) if region is None else region
    flat = np.zeros(h * w)
    lw = float(p["line_width"])
    # positions in whole-image pixels; only integer pixel indices are shifted to the region
    d = b - a
    # an edge none of whose samples comes within 3 pixels of the region is left out; a sample is
    # a + d t rounded, monotone in t, so the extremes are the ends a (t = 0) and a + d (t = 1)
    e = a + d
    lo, hi = np.minimum(a, e), np.maximum(a, e)
    near = ~((hi[:, 0] < ox - 3) | (lo[:, 0] > ox + w + 2) | (hi[:, 1] < oy - 3) | (lo[:, 1] > oy + h + 2))
    a, d = a[near], d[near]
    n = (np.maximum(np.abs(d[:, 0]), np.abs(d[:, 1])) * 2).astype(np.int64) + 2
    ends = np.cumsum(n)
    e0 = 0
    while e0 < len(n):          # whole edges per chunk, about _DRAW_CHUNK samples
        e1 = max(e0 + 1, int(np.searchsorted(ends, ends[e0] - n[e0] + _DRAW_CHUNK, side="right")))
        _draw_edges(flat, a[e0:e1], d[e0:e1], n[e0:e1], lw, ox, oy, w, h)
        e0 = e1
    _draw_points(flat, (pos + 1) * [sx, sy] - 0.5, ox, oy, w, h)
    return flat.reshape(h, w).astype(np.float32)


def _draw_edges(flat, a, d, n, lw, ox, oy, w, h):
    """The line samples of edges from ``a`` (E, 2) along ``d`` (E, 2), ``n`` (E,) samples each,
    scattered into ``flat`` (the region, row-major) by their maximum."""
    edge = np.repeat(np.arange(len(n)), n)
    first = np.cumsum(n) - n
    k = np.arange(int(n.sum())) - first[edge]
    t = k * (1.0 / (n - 1))[edge]               # np.linspace(0, 1, n): k * (1 / (n - 1)), the last 1
    t[first + n - 1] = 1.0
    xs = a[edge, 0] + d[edge, 0] * t
    ys = a[edge, 1] + d[edge, 1] * t
    rx = np.round(xs).astype(np.int64)
    ry = np.round(ys).astype(np.int64)
    reach = lw / 2 + 0.5          # a pixel |dx| - 0.5 or more from every sample gets clip(<= 0) = 0
    for dx in range(-2, 3):
        for dy in range(-2, 3):
            if max(abs(dx), abs(dy)) - 0.5 >= reach:
                continue
            ix = rx + dx
            iy = ry + dy
            v = np.clip(lw / 2 + 0.5 - np.hypot(ix - xs, iy - ys), 0, 1)
            ok = (ix >= ox) & (ix < ox + w) & (iy >= oy) & (iy < oy + h) & (v > 0)
            np.maximum.at(flat, (iy[ok] - oy) * w + (ix[ok] - ox), v[ok] * 0.8)


def _draw_points(flat, xy, ox, oy, w, h):
    """Each point lights the pixels ``[int(max(x - 4, ox)), int(min(x + 5, ox + w)))`` (and so in
    y) by ``clip(3.5 - d, 0, 1)``, kept by their maximum in ``flat``."""
    step = max(256, _DRAW_CHUNK // 100)
    for s in range(0, len(xy), step):
        x, y = xy[s:s + step, 0], xy[s:s + step, 1]
        x0 = np.maximum(x - 4, ox).astype(np.int64)       # int(): towards zero, as astype
        x1 = np.minimum(x + 5, ox + w).astype(np.int64)
        y0 = np.maximum(y - 4, oy).astype(np.int64)
        y1 = np.minimum(y + 5, oy + h).astype(np.int64)
        use = (x1 > x0) & (y1 > y0)
        x, y, x0, x1, y0, y1 = x[use], y[use], x0[use], x1[use], y0[use], y1[use]
        for j in range(10):                    # a window is at most 9 pixels a side
            px = x0 + j
            for i in range(10):
                py = y0 + i
                ok = (px < x1) & (py < y1)
                v = np.clip(3.5 - np.hypot(px[ok] - x[ok], py[ok] - y[ok]), 0, 1)
                np.maximum.at(flat, (py[ok] - oy) * w + (px[ok] - ox), v)


def pups_presets():
    """Names of the built-in PUPs presets.

    Returns
    -------
    list of str
    """
    return sorted(PUPS_PRESETS)


def pups_render(preset_or_params, width, height, *, seed=0, backend="gpu") -> np.ndarray:
    """Render a PUPs preset (by name) or a parameter dict to an image.

    Parameters
    ----------
    preset_or_params : str or dict
        A name from :func:`pups_presets` (``"pups-cow"``; the ``pups-`` prefix is optional) or
        a JSON-able parameter dict as in :data:`cellgl.pups.presets.PUPS_PRESETS`.
    width, height : int
        Image size in pixels, each in [1, 16384].
    seed : int
        Seed for every random choice; same seed, same bits.
    backend : {"gpu", "numpy"}

    Returns
    -------
    numpy.ndarray of float32, shape (height, width) or (height, width, 3)
        Values in [0, 1] for the built-in presets.
    """
    return build_pups(preset_or_params, width, height, seed=seed, backend=backend)
