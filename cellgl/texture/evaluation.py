"""Evaluate cellular texture recipes on the GPU (``shaders/texture.comp``, ``texture.frag``) or
with the NumPy twin (:mod:`cellgl.texture.reference`).

:func:`evaluate` samples a recipe at arbitrary points, :func:`render` renders an image, a tile
of one or a volume (tiles are bit-identical to a one-pass render), :func:`render_fragment` runs
the viewer's fragment path offscreen, :func:`measure_range` measures a combination's range.
The shader text, macros and uniforms come from :mod:`cellgl.texture.shader`. Any recipe kind
(PUPs too) renders through :func:`cellgl.recipes.render`.
"""
from __future__ import annotations

import numpy as np

from cellgl.basis.arrays import real_array
from cellgl.gl.threads import gl_call
from cellgl.texture import antialias, dispatch
from cellgl.texture.presets import load_recipe
from cellgl.texture.recipe import CHANNELS, check_channels
from cellgl.texture.schema import check_tile, whole_number
from cellgl.texture.shader import defines, view_uniforms

__all__ = ["evaluate", "render", "render_fragment", "measure_range", "point_range", "check_points", "OUTPUTS",
           "MAX_SIDE", "POINT_LIMIT"]

#: largest image side :func:`render` takes. The shader puts a pixel at uv ``(x + 0.5) / W`` in
#: float32: pixel centres are exact below 2**23, and at 2**20 neighbouring pixels are still 16
#: float32 steps apart near uv = 1 (a 262144^2 heightfield is baked in tiles: cellgl.dask).
MAX_SIDE = 1 << 20
#: what :func:`evaluate` can return: the render channels plus the height gradient in texture
#: space (dh/du, dh/dv, dh/dz) and the raw combination value at octave 0
OUTPUTS = CHANNELS + ("grad", "value", "cloud")
#: what :func:`render` can return: the channels, and ``cloud`` (RGBA, :mod:`cellgl.texture.cloud`)
RENDER_CHANNELS = CHANNELS + ("cloud",)


def _backend(backend):
    if backend not in ("gpu", "numpy"):
        raise ValueError(f"unknown backend {backend!r}; accepted: gpu, numpy")


def _points(points) -> np.ndarray:
    pts = real_array("points", points, "of shape (N, 2) (u, v) or (N, 3) (u, v, z)")
    if pts.ndim != 2 or pts.shape[1] not in (2, 3) or len(pts) == 0:
        raise ValueError(f"points must have shape (N, 2) (u, v) or (N, 3) (u, v, z) with N >= 1, "
                         f"got shape {pts.shape}")
    if not np.all(np.isfinite(pts)):
        raise ValueError("points must be finite")
    if pts.shape[1] == 2:
        pts = np.concatenate([pts, np.zeros((len(pts), 1))], axis=1)
    return pts


def evaluate(recipe, points, outputs=("color",), backend: str = "gpu", *, filter_width=0.0) -> dict:
    """Evaluate a recipe at arbitrary texture-space points.

    Parameters
    ----------
    recipe : Recipe, preset name or recipe path
    points : array_like (N, 2) or (N, 3) float
        ``(u, v)`` on the image plane (``v = 0``: top row) or ``(u, v, z)`` for solid recipes
        (basis position ``(u f + offset_x, v f aspect + offset_y, z f + offset_z, time)``).
        Each basis coordinate must lie within +-2^30 cells, as :func:`cellgl.cellular` accepts
        (float64 then keeps 2^-22 of a cell): u in ``(-2^30 - offset_x) / f .. (2^30 -
        offset_x) / f``, and so on; further points raise ValueError naming the range
        (:func:`point_range`).
    outputs : sequence of str
        Any of ``color`` (N, 4) float32, ``height`` (N,) float32, ``normal`` (N, 3) float32
        in [0, 1] encoding, ``id`` (N,) uint32, ``F1``..``F4`` (N,) float32 (octave 0),
        ``grad`` (N, 3) float32 (dh/du, dh/dv, dh/dz, analytic), ``value`` (N,) float32 (the
        combination before normalisation, octave 0), ``cloud`` (N, 4) float32 (packed cloud
        noise, :mod:`cellgl.texture.cloud`).
    backend : {"gpu", "numpy"}
    filter_width : float or (du, dv) or (du, dv, dz)
        The footprint of every point in texture space (e.g. ``1 / W`` for the pixels of a
        W-wide image): fractal octaves finer than it fade to their mean (the recipe's
        ``antialias``, :mod:`cellgl.texture.antialias`). Default 0: point samples.

    Returns
    -------
    dict of output name -> ndarray
    """
    return _evaluate(recipe, points, outputs, backend, filter_width)


def _evaluate(recipe, points, outputs, backend, filter_width, split_far: bool = True) -> dict:
    """:func:`evaluate`; ``split_far=False`` skips grouping far points by their whole part (one
    dispatch, positions in float32: only for statistics such as :func:`measure_range`, whose
    65,536 points spread over 10^6 unit squares would otherwise cost a dispatch each)."""
    recipe = load_recipe(recipe)
    outputs = check_channels(outputs, OUTPUTS)
    if "cloud" in outputs:      # four heights packed (cellgl.texture.cloud)
        from cellgl.texture import cloud

        return cloud.with_cloud(lambda r, chs: _evaluate(r, points, chs, backend, filter_width, split_far),
                                recipe, outputs, measure_range)
    _backend(backend)
    pts = _points(points)
    duvz = _filter_width(filter_width)
    check_points(recipe, pts)       # both backends: +-2^30 cells (the range in the recipe's uv)
    if backend == "numpy":
        from cellgl.texture import reference as texture_reference

        return texture_reference.evaluate(recipe, pts, outputs, duvz)

    filter_uniforms = {"u_filter_width": tuple(float(c) for c in duvz)}

    def run_points(local, **kw):
        p4 = np.zeros((len(local), 4), np.float32)
        p4[:, :3] = local
        return dispatch.run(recipe, outputs, len(local), filter_uniforms, grid=False, points=p4, footprint=duvz, **kw)

    # The shader adds the sample's texture position to the split origins in float32, which holds
    # only the first few cells exactly. So points go as their fraction, and the origins of their
    # whole part (u, v, z) are split in float64 as for a pan (as the viewer pans): a point at uv 1e9
    # is as exact as one at 0.5.
    whole = np.floor(pts)
    if not split_far or not whole.any():
        return run_points(pts)
    v = recipe.values
    if v["density_map"] == "none" and v["cell_color"] != "image":
        return _far_points(recipe, outputs, pts, whole, filter_uniforms, duvz)
    # A density map or cell image placed per pan: a pass per whole part (such recipes only)
    order = np.lexsort(whole.T[::-1])           # points of one whole part next to each other
    ws = whole[order]
    starts = np.flatnonzero(np.concatenate([[True], np.any(ws[1:] != ws[:-1], axis=1), [True]]))
    out = None
    for g in range(len(starts) - 1):
        idx = order[starts[g]:starts[g + 1]]
        key = ws[starts[g]]
        res = run_points(pts[idx] - key, pan=tuple(float(c) for c in key), pan_only=g > 0)
        if out is None:
            out = {k: np.empty((len(pts),) + a.shape[1:], a.dtype) for k, a in res.items()}
        for k, a in res.items():
            out[k][idx] = a
    assert out is not None                  # at least one group: pts is not empty here
    return out


#: points of one far-point pass (their group index, below this, is exact in the float32 row)
GROUP_POINTS = 1 << 22


def _far_points(recipe, outputs, pts, whole, filter_uniforms, duvz) -> dict:
    """Points spread over many whole parts in one pass per :data:`GROUP_POINTS`: each point's
    fraction and group index (its row's fourth component), and each group's origins split in
    float64 as a pan (:func:`cellgl.texture.shader.group_records`, ``shaders/lib/
    texture_groups.glsl``): the bits of a pass per whole part, without the passes."""
    from cellgl.texture.shader import group_records

    parts = []
    for a in range(0, len(pts), GROUP_POINTS):
        w = whole[a:a + GROUP_POINTS]
        order = np.lexsort(w.T[::-1])           # points of one whole part next to each other
        ws = w[order]
        first = np.concatenate([[True], np.any(ws[1:] != ws[:-1], axis=1)])
        p4 = np.empty((len(w), 4), np.float32)
        p4[:, :3] = pts[a:a + GROUP_POINTS] - w
        p4[order, 3] = np.cumsum(first) - 1     # each point's group
        keys = ws[first]
        parts.append(dispatch.run(recipe, outputs, len(w), filter_uniforms, grid=False, points=p4,
                                  groups=group_records(recipe, keys), footprint=duvz))
    if len(parts) == 1:
        return parts[0]
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


#: |basis position| (cells of octave 0's lattice) an evaluated point may reach: what
#: :func:`cellgl.cellular` accepts (``cellgl.basis.core.COORD_LIMIT``), where float64 still holds
#: 2^-22 of a cell and the cell index fits the GPU's int32
POINT_LIMIT = 2.0 ** 30


def point_range(recipe) -> np.ndarray:
    """The texture-space box :func:`evaluate` accepts, (3, 2) float64 (lo, hi) per axis u, v, z:
    ``offset + uv * frequency`` (v: ``* aspect``) within +-:data:`POINT_LIMIT` cells (z only in
    3D/4D; in 2D it is ignored and any finite value is accepted)."""
    v = recipe.values
    f = float(v["frequency"])
    out = np.empty((3, 2))
    for a, (off, k) in enumerate(((v["offset_x"], f), (v["offset_y"], f * float(v["aspect"])),
                                  (v["offset_z"], f))):
        out[a] = ((-POINT_LIMIT - off) / k, (POINT_LIMIT - off) / k)
    if int(v["dimension"]) < 3:
        out[2] = (-np.inf, np.inf)
    return out


def check_points(recipe, pts: np.ndarray) -> None:
    """ValueError for the first point outside :func:`point_range`, naming it, the accepted range
    in uv and where that comes from (the recipe's frequency and offset)."""
    box = point_range(recipe)
    p = np.asarray(pts, dtype=np.float64)[:, :3]
    bad = (p <= box[: p.shape[1], 0]) | (p >= box[: p.shape[1], 1])
    if not bad.any():
        return
    i, a = (int(x) for x in np.argwhere(bad)[0])
    v = recipe.values
    axis = "uvz"[a]
    off = ("offset_x", "offset_y", "offset_z")[a]
    scale = f"frequency {v['frequency']:g}" + (f" x aspect {v['aspect']:g}" if a == 1 else "")
    raise ValueError(f"points[{i}, {a}] ({axis}) = {p[i, a]!r} is beyond what the recipe can resolve: "
                     f"{off} + {axis} x {scale} must lie within +-2^30 cells (as cellgl.cellular "
                     f"accepts; float64 keeps 2^-22 of a cell there), so {axis} in "
                     f"({box[a, 0]:.10g}, {box[a, 1]:.10g}) for this recipe")


def _filter_width(fw) -> np.ndarray:
    """``filter_width`` as (du, dv, dz) float64, checked."""
    a = real_array("filter_width", fw, "(a number, (du, dv) or (du, dv, dz))")
    if a.ndim == 0:
        a = np.array([a, a, 0.0])
    elif a.shape in ((2,), (3,)):
        a = np.concatenate([a, np.zeros(3 - len(a))])
    else:
        raise ValueError(f"filter_width must be a number, (du, dv) or (du, dv, dz), got {fw!r}")
    if not np.all(np.isfinite(a)) or np.any(a < 0.0):
        raise ValueError(f"filter_width must be finite and >= 0, got {fw!r}")
    return a


def _shape_out(res: dict, lead: tuple) -> dict:
    out = {}
    for k, a in res.items():
        out[k] = a.reshape(lead + a.shape[1:])
    return out


def render(recipe, width: int, height: int, *, channels=("color",), x0: int = 0, y0: int = 0,
           tile_w: int | None = None, tile_h: int | None = None, depth: int | None = None,
           backend: str = "gpu", samples: int = 1) -> dict:
    """Render the sub-rectangle ``[x0, x0 + tile_w) x [y0, y0 + tile_h)`` of the full
    ``width x height`` image of a recipe (tiles are bit-identical to a one-pass render).

    Each pixel is band-limited to its footprint (the recipe's ``antialias``) and, with
    ``samples = n^2`` (1, 4, 9, ..., 64), averaged over the centres of an n x n grid of
    sub-pixels (colour, height, normal, roughness, ao, metallic; ``id``, ``F1``..``F4`` from the
    pixel centre); see
    :mod:`cellgl.texture.antialias`.

    Returns
    -------
    dict channel -> ndarray: ``color`` (H, W, 4) float32 in [0, 1]; ``height`` (H, W)
    float32; ``normal`` (H, W, 3) float32 in [0, 1] (green per ``normal_convention``);
    ``id`` (H, W) uint32; ``F1``..``F4`` (H, W) float32; ``roughness``, ``ao``, ``metallic``
    (H, W) float32 in [0, 1] (the recipe's ``material`` section, :mod:`cellgl.texture.material`);
    ``cloud`` (H, W, 4) float32 in [0, 1], packed cloud noise from the recipe's basis and domain
    (:mod:`cellgl.texture.cloud`). Row 0 is the top of the image. With
    ``depth=D`` (3D/4D recipes) every array gains a leading axis of D slices along z.
    """
    recipe = load_recipe(recipe)
    channels = check_channels(channels, RENDER_CHANNELS)
    if "cloud" in channels:     # four heights packed (cellgl.texture.cloud)
        from cellgl.texture import cloud

        return cloud.with_cloud(lambda r, chs: render(r, width, height, channels=chs, x0=x0, y0=y0, tile_w=tile_w,
                                                      tile_h=tile_h, depth=depth, backend=backend, samples=samples),
                                recipe, channels, measure_range)
    _backend(backend)
    n_sub = antialias.grid_side(samples)
    tw, th = check_tile(width, height, x0, y0, tile_w, tile_h, max_side=MAX_SIDE)
    if depth is not None:
        if recipe.get("dimension") < 3:
            raise ValueError("depth (a volume) needs a solid recipe: basis.dimension 3 or 4, got 2")
        whole_number("depth", depth, 1, 4096)
    D = depth or 1
    if backend == "numpy":
        from cellgl.texture import reference as texture_reference

        u = (x0 + np.arange(tw) + 0.5) / width
        v = (y0 + np.arange(th) + 0.5) / height
        z = (np.arange(D) + 0.5) / D if depth else np.zeros(1)
        Z, V, U = np.meshgrid(z, v, u, indexing="ij")
        pts = np.stack([U.ravel(), V.ravel(), Z.ravel()], axis=1)
        duvz = np.array([1.0 / width, 1.0 / height, 0.0])     # slices: band-limited in the image plane
        res = texture_reference.evaluate(recipe, pts, channels, duvz)
        if n_sub > 1:
            res.update(_supersample_reference(recipe, pts, channels, duvz, samples))
    else:
        setup = {"u_size": (width, height), "u_origin": (x0, y0), "u_tile": (tw, th), "u_depth": int(depth or 0)}
        # every pixel's footprint (sub-pixels: smaller): where no octave fades at it, the octave
        # mean is never read and not measured (antialias.fades)
        res = dispatch.run(recipe, channels, tw * th * D, setup, grid=True, supersample=n_sub,
                           footprint=(1.0 / width, 1.0 / height, 0.0))
    lead = (D, th, tw) if depth else (th, tw)
    return _shape_out(res, lead)


def _supersample_reference(recipe, pts, channels, duvz, samples) -> dict:
    """NumPy twin of texture.comp's supersampling: the averaged channels at pixel centres ``pts``."""
    from cellgl.texture import reference as texture_reference

    avg = [c for c in channels if c in ("color", "height", "normal", "roughness", "ao", "metallic")]
    if not avg:
        return {}
    n = antialias.grid_side(samples)
    sub = np.array([duvz[0] / n, duvz[1] / n, duvz[2]])
    acc: dict = {}
    for off in antialias.subsample_offsets(samples):
        p = pts + np.array([off[0] * duvz[0], off[1] * duvz[1], 0.0])
        o = texture_reference.evaluate(recipe, p, [c for c in avg if c != "normal"] + ["normal"], sub)
        for c in avg:
            x = o[c].astype(np.float64)
            acc[c] = acc.get(c, 0.0) + (x * 2.0 - 1.0 if c == "normal" else x)
    out = {c: (a / samples).astype(np.float32) for c, a in acc.items() if c != "normal"}
    if "normal" in acc:
        nrm = acc["normal"] / np.linalg.norm(acc["normal"], axis=1, keepdims=True)
        out["normal"] = (nrm * 0.5 + 0.5).astype(np.float32)
    return out


@gl_call
def render_fragment(recipe, width: int, height: int, channel: str = "color", *,
                    view=(0.0, 0.0, 1.0, 1.0)) -> np.ndarray:
    """The viewer's path: ``shaders/texture.frag`` over a ``width x height`` RGBA32F target,
    read back with row 0 at the top (for tests; the viewer draws to its window instead).

    ``view`` (u0, v0, du, dv): the target shows ``uv = (u0, v0) + (s, t) * (du, dv)``, ``s, t``
    in [0, 1] (:func:`cellgl.texture.shader.view_uniforms`: the pan goes into the split origins). Fragment uniforms
    besides the recipe's: ``u_view`` (vec4: uv = xy + (v_uv.x, 1 - v_uv.y) * zw) and
    ``u_channel`` (index into :data:`cellgl.texture.recipe.CHANNELS`).
    """
    from cellgl.gl import context, runner

    recipe = load_recipe(recipe)
    ctx = context.get_context()
    r = runner.runner(ctx)
    uniforms = view_uniforms(recipe, view[:2], view[2:], ctx=ctx)
    uniforms["u_channel"] = CHANNELS.index(channel)
    target = r.target("texture.render_fragment", (width, height))
    r.draw(runner.Draw("fullscreen.vert", "texture.frag", target, defines(recipe, (channel,)), uniforms=uniforms))
    return r.read(target)[::-1].copy()


# ------------------------------------------------------------------------------ normalisation

def measure_range(recipe, samples: int = 65536, *, lo_pct: float = 0.5, hi_pct: float = 99.5,
                  seed: int = 12345, backend: str = "gpu") -> tuple[float, float]:
    """Measure the range of the recipe's combination (Worley: "empirically determining the range
    of values that the combination returns").

    Evaluates the raw combination (one octave, no tiling) at ``samples`` deterministic random
    points spread over a 1000-cell region and returns its ``lo_pct``/``hi_pct`` percentiles
    ``(range_lo, range_hi)`` (widened if degenerate). Store them in the recipe with
    ``recipe.replace(range_lo=lo, range_hi=hi)``.

    With a density map the cell size varies over the texture, so the points are spread over the
    texture's own uv square instead (frequency, aspect and the map as the recipe has them).
    """
    recipe = load_recipe(recipe)
    samples = whole_number("samples", samples, 2, 1 << 24)      # (a range needs two)
    rng = np.random.default_rng(whole_number("seed", seed, 0, (1 << 63) - 1))
    dim = recipe.get("dimension")
    if recipe.values["density_map"] != "none":
        probe = recipe.replace(fractal="none")
        pts = rng.uniform(0.0, 1.0, size=(samples, 3))
        pts[:, 2] = 0.0
    else:
        probe = recipe.replace(tileable=False, fractal="none", frequency=1.0, aspect=1.0,
                               offset_x=0.0, offset_y=0.0, offset_z=0.0)
        pts = rng.uniform(0.0, 1000.0 if dim == 2 else 100.0, size=(samples, 3))
    if dim == 2:
        pts[:, 2] = 0.0
    # float32 positions up to 1000 cells (one dispatch): ample for percentiles, and the stored ranges
    # of the presets were measured so
    val = _evaluate(probe, pts, ("value",), backend, 0.0, split_far=False)["value"].astype(np.float64)
    lo, hi = np.percentile(val, [lo_pct, hi_pct])
    if not hi > lo:
        lo, hi = lo - 0.5, hi + 0.5
    return float(round(lo, 6)), float(round(hi, 6))
