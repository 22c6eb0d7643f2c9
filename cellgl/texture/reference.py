"""NumPy float64 twin of ``shaders/lib/texture.glsl`` and ``shaders/lib/noise.glsl``.

Function for function, the same names without the ``cell_`` prefix (``cell_texture`` ->
:func:`texture`, ``cell_noise`` -> :func:`noise`, ...), vectorised over samples, built on
:mod:`cellgl.basis.reference` (the same cells, hashes and feature points as the GPU).
``cellgl.evaluate(..., backend="numpy")`` and ``cellgl.render(..., backend="numpy")`` run this;
the tests compare every preset's GPU output against it.

Big coordinates are split exactly as on the GPU: :func:`lattice_origins` splits the origin
``(offset_x, offset_y, offset_z, time)`` per octave into an integer cell and a fraction (here
kept in float64; the GPU gets it as float32), and the functions add the small texture-space
part ``s`` to the fraction.
"""
from __future__ import annotations

import numpy as np

from cellgl.texture import domain
from cellgl.basis import reference as ref
from cellgl.basis.enums import Distribution, Metric
from cellgl.texture.antialias import feature_frequency, smoothscale
from cellgl.texture.material import MATERIAL_CHANNELS, material
from cellgl.texture.params import LINEAR
from cellgl.basis.reference import W96_DENSITY_ADJUSTMENT, add_u32, mul_u32, hash_u32, u16

M32 = 0xFFFFFFFF


# --------------------------------------------------------------------------- noise.glsl

def noise_gradient(c: np.ndarray, seed: int) -> np.ndarray:
    """``_cell_noise_gradient``: corner gradients (N, 4) in [-1, 1] for corners c (N, 4) int64."""
    c = c.astype(np.int64) & M32
    h = add_u32(add_u32(mul_u32(seed, 0x165667B1), 0x9E3779B9), mul_u32(c[:, 0], 0x8DA6B343))
    h = add_u32(h, mul_u32(c[:, 1], 0xD8163841))
    h = add_u32(h, mul_u32(c[:, 2], 0xCB1AB31F))
    h = add_u32(h, mul_u32(c[:, 3], 0x27D4EB2F))
    h = hash_u32(h)
    h2 = hash_u32(h ^ np.uint64(0x68E31DA4))
    g = np.stack([u16(h >> np.uint64(16)), u16(h & np.uint64(0xFFFF)),
                  u16(h2 >> np.uint64(16)), u16(h2 & np.uint64(0xFFFF))], axis=1)
    return g * 2.0 - 1.0


def noise_split(cell: np.ndarray, f: np.ndarray, period, seed: int, dim: int):
    """``cell_noise_split``: gradient noise at lattice position cell (N, 4) int64 + f (N, 4);
    returns (value (N,), gradient (N, 4))."""
    cell = np.array(np.broadcast_to(cell, np.shape(f)), dtype=np.int64)
    f = np.array(f, dtype=np.float64)
    cell[:, dim:] = 0
    f[:, dim:] = 0.0
    fl = np.floor(f)
    i0 = cell + fl.astype(np.int64)
    f = f - fl
    u = f * f * f * (f * (f * 6.0 - 15.0) + 10.0)
    du = 30.0 * f * f * (f - 1.0) ** 2
    value = np.zeros(len(f))
    grad = np.zeros_like(f)
    period = np.broadcast_to(np.asarray(period, dtype=np.int64), (4,)) if np.ndim(period) == 1 else period
    for k in range(1 << dim):
        o = np.array([k & 1, (k >> 1) & 1, (k >> 2) & 1, (k >> 3) & 1], dtype=np.int64)
        g = noise_gradient(ref.wrap(i0 + o, period), (seed & M32))
        g[:, dim:] = 0.0
        d = f - o
        s = (g * d).sum(axis=1)
        wa = np.where(o == 1, u, 1.0 - u)
        dwa = np.where(o == 1, du, -du)
        w = wa.prod(axis=1)
        dw = np.stack([dwa[:, a] * np.prod(np.delete(wa, a, axis=1), axis=1) for a in range(4)], axis=1)
        value += w * s
        grad += w[:, None] * g + s[:, None] * dw
    return value, grad


def noise(x: np.ndarray, period, seed: int, dim: int):
    """``cell_noise``: gradient noise at x (N, 4); returns (value (N,), gradient (N, 4))."""
    return noise_split(np.zeros(4, dtype=np.int64), x, period, seed, dim)


def noise_fractal_split(cell: np.ndarray, f: np.ndarray, period, seed: int, octaves: int, dim: int):
    """``cell_noise_fractal_split``: sum 0.5^i n(2^i (cell + f)) / sum 0.5^i, octave i at
    2^i cell + 2^i f; returns (value, gradient)."""
    f = np.asarray(f, dtype=np.float64)
    cell = np.asarray(cell, dtype=np.int64)
    value = np.zeros(len(f))
    grad = np.zeros((len(f), 4))
    amp, total, scale = 1.0, 0.0, 1.0
    period = np.asarray(period, dtype=np.int64)
    for i in range(octaves):
        v, g = noise_split(cell * int(scale), f * scale, period * int(scale), (seed + i) & M32, dim)
        value += amp * v
        grad += amp * scale * g
        total += amp
        amp *= 0.5
        scale *= 2.0
    return value / total, grad / total


def noise_fractal(x: np.ndarray, period, seed: int, octaves: int, dim: int):
    """``cell_noise_fractal``: sum 0.5^i n(2^i x) / sum 0.5^i; returns (value, gradient)."""
    return noise_fractal_split(np.zeros(4, dtype=np.int64), x, period, seed, octaves, dim)


# --------------------------------------------------------------------------- texture.glsl

#: most fractal octaves (cellgl.texture.MAX_OCTAVES, CELL_TEX_OCTAVES)
MAX_OCTAVES = 8


def texture_values(recipe, pan=(0.0, 0.0), mean: bool = True) -> dict:
    """The run-time values the GLSL reads (enums as names), plus derived ones (the split
    origins of :func:`lattice_origins`, the density map per octave of :func:`density_encodings`,
    the band limit's ``feature_frequency`` (:mod:`cellgl.texture.antialias`) and :func:`octave_mean`;
    ``mean=False``: 0 for the mean, which :func:`octave_mean` measures with this)."""
    v = dict(recipe.values)
    v["dist_scale"] = W96_DENSITY_ADJUSTMENT if v["distribution"] == "worley1996" else 1.0
    v["feature_frequency"] = feature_frequency(v)
    v.update(lattice_origins(v, pan))
    v["pan"] = (float(pan[0]), float(pan[1]))
    v["density_enc"] = density_encodings(recipe, pan, v)
    v["octave_mean"] = octave_mean(recipe) if mean else 0.0
    return v


def density_map(recipe):
    """The recipe's density map in texture-local basis units ``s = (u f, v f aspect, z f, 0)``
    (a :class:`cellgl.basis.density.DensityMap`), or None (``density_map = "none"``).

    ramp_x/ramp_y run from ``density_start`` to ``density_end`` in u (v); radial is centred at
    ``(density_center_x, density_center_y)`` in uv with radius ``density_radius`` in u units
    (isotropic in cells); an image covers the uv square (row 0 at v = 0).
    """
    from cellgl.basis.density import DensityMap

    v = recipe.values
    kind = v["density_map"]
    if kind == "none":
        return None
    f = float(v["frequency"])
    fa = f * float(v["aspect"])
    kw = dict(density_min=v["density_min"], density_max=v["density_max"])
    if kind in ("ramp_x", "ramp_y"):
        axis, k = (0, f) if kind == "ramp_x" else (1, fa)
        return DensityMap("ramp", **kw, axis=axis, start=v["density_start"] * k, end=v["density_end"] * k)
    if kind == "radial":
        return DensityMap("radial", **kw, center=(v["density_center_x"] * f, v["density_center_y"] * fa),
                          radius=v["density_radius"] * f)
    return DensityMap("image", **kw, image=recipe.density_pixels(), rect=(0.0, 0.0, f, fa))


def density_encodings(recipe, pan=(0.0, 0.0), t: dict | None = None):
    """The density map of each octave as a :class:`cellgl.basis.density.DensityEncoding`, or None.

    Octave ``i`` samples the lattice ``L^i (O + s)`` (:func:`lattice_origins`, ``O`` with the
    pan), whose origin splits into the cell ``C_i`` and fraction ``r_i``. The map is encoded
    relative to ``C_i`` (``DensityMap.scaled(L^i, r_i / L^i - pan_s)``: lattice ``x - C_i``), so its
    integers stay small however far the origin is, and ``C_i`` is then added to each axis's
    window origin ``o`` (int64 here; the GPU gets it modulo 2^32, where ``c - o`` wraps to the
    same small difference). Raises ValueError if an octave's map is too large to encode.
    """
    from cellgl.basis.density import encode

    dm = density_map(recipe)
    if dm is None:
        return None
    t = t if t is not None else dict(recipe.values, **lattice_origins(recipe.values, pan))
    f = float(t["frequency"])
    pan_s = (float(pan[0]) * f, float(pan[1]) * f * float(t["aspect"]), _pan_z(pan) * f, 0.0)
    out = []
    for i in range(MAX_OCTAVES):
        k = float(t["lacunarity"]) ** i
        frac = t["origin_frac"][i]
        offset = tuple(float(frac[a]) / k - pan_s[a] for a in range(4))
        try:
            enc = encode(dm.scaled(k, offset), int(t["dimension"]))
        except ValueError as exc:
            raise ValueError(f"density map of octave {i} (lacunarity^{i} = {k:g}): {exc}") from None
        axes = enc.axes.copy()
        used = axes[:, 1] > 0
        axes[used, 0] += np.asarray(t["origin_cell"][i], dtype=np.int64)[used]
        object.__setattr__(enc, "axes", axes)
        out.append(enc)
    return out


def _pan_z(pan) -> float:
    return float(pan[2]) if len(pan) > 2 else 0.0


def _split(x: np.ndarray, period) -> tuple[np.ndarray, np.ndarray]:
    """float64 x (4,) -> (int64 cell wrapped by period where > 0, float64 fraction in [0, 1))."""
    fl = np.floor(x)
    cell = fl.astype(np.int64)
    period = np.asarray(period, dtype=np.int64)
    cell = np.where(period > 0, np.mod(cell, np.maximum(period, 1)), cell)
    return cell, x - fl


def lattice_origins(t: dict, pan=(0.0, 0.0), octaves: int = MAX_OCTAVES) -> dict:
    """The origin ``O = (offset_x, offset_y, offset_z, time)`` split per octave, in float64.

    The basis position of octave ``i`` is ``L^i (O + s)`` with ``L = lacunarity`` and ``s =
    (u f, v f aspect, z f, 0)`` small; the basis lattice samples it times ``dist_scale``, the
    noise lattice times ``noise_frequency``. Each ``k O`` is split into an integer cell (wrapped
    by the octave's period when tileable, so it stays small) and a fraction in [0, 1); the
    shader adds ``k s`` to the fraction. Axes past the dimension are 0.

    ``pan`` (du, dv) or (du, dv, dz) moves the view in texture space (the viewer's pan; the whole
    part of far points in :func:`cellgl.texture.evaluate`): ``O += (du f, dv f aspect, dz f, 0)``,
    so a pan far away is exact too. Many pans (G, 3) give each array a leading axis of G.

    The warp noise's lattice (octave 0 only, :mod:`cellgl.texture.domain`) samples ``O warp_frequency``.

    Returns ``{"origin_cell", "noise_cell": int64 (MAX_OCTAVES, 4), "origin_frac",
    "noise_frac": float64 (MAX_OCTAVES, 4), "warp_cell": int64 (4,), "warp_frac": float64 (4,)}``.
    """
    f, dim = t["frequency"], t["dimension"]
    p = np.asarray(pan, dtype=np.float64)          # (2,), (3,) or many: (G, 3) -> (G, ...) out
    pz = p[..., 2] if p.shape[-1] > 2 else np.zeros(p.shape[:-1])
    O = np.stack(np.broadcast_arrays(t["offset_x"] + p[..., 0] * f, t["offset_y"] + p[..., 1] * f * t["aspect"],
                                     t["offset_z"] + pz * f, np.float64(t["time"])), axis=-1)
    O[..., dim:] = 0.0
    ds = W96_DENSITY_ADJUSTMENT if t["distribution"] == "worley1996" else 1.0
    out = {k: [] for k in ("origin_cell", "origin_frac", "noise_cell", "noise_frac")}
    for i in range(octaves):                       # the first ``octaves`` only, where asked
        k = float(t["lacunarity"]) ** i
        per = texture_period(t, i)
        c, fr = _split(O * k * ds, per)
        out["origin_cell"].append(c)
        out["origin_frac"].append(fr)
        c, fr = _split(O * k * t["noise_frequency"], per * int(round(t["noise_frequency"])))
        out["noise_cell"].append(c)
        out["noise_frac"].append(fr)
    out = {k: np.stack(v, axis=-2) for k, v in out.items()}
    out["warp_cell"], out["warp_frac"] = _split(O * t["warp_frequency"],
                                                texture_period(t, 0) * int(round(t["warp_frequency"])))
    return out


def texture_local(p: np.ndarray, t: dict) -> np.ndarray:
    """``cell_texture_local``: texture space (N, 3) -> basis space relative to the origin (N, 4)."""
    f = t["frequency"]
    return np.stack([p[:, 0] * f, p[:, 1] * f * t["aspect"], p[:, 2] * f, np.zeros(len(p))], axis=1)


def texture_lattice(origin_cell: np.ndarray, origin_frac: np.ndarray, s: np.ndarray):
    """``cell_texture_lattice``: origin_cell + origin_frac + s (N, 4) as (int64 cell, fraction)."""
    q = origin_frac + s
    fl = np.floor(q)
    return origin_cell + fl.astype(np.int64), q - fl


def texture_period(t: dict, octave: int) -> np.ndarray:
    """``cell_texture_period``."""
    if not t["tileable"]:
        return np.zeros(4, dtype=np.int64)
    m = int(round(t["lacunarity"])) ** octave
    pz = int(round(t["frequency"])) * m if t["dimension"] >= 3 else 0      # solid: seamless in depth too
    return np.array([int(round(t["frequency"])) * m, int(round(t["frequency"] * t["aspect"])) * m, pz, 0],
                    dtype=np.int64)


def _basis(t: dict, octave: int) -> ref.Params:
    """``_cell_tex_basis``."""
    enc = t.get("density_enc")
    return ref.Params(density_map=None if enc is None else enc[octave],
                      dim=t["dimension"], metric=Metric[t["metric"].upper()],
                      distribution=Distribution[t["distribution"].upper()], density=t["density"],
                      jitter=t["jitter"], min_points=t["min_points"], max_points=t["max_points"],
                      minkowski_p=t["minkowski_p"], seed=(t["seed"] + 1013 * octave) & M32,
                      period=tuple(int(c) for c in texture_period(t, octave)),
                      axis_scale=domain.axis_scale(t), orbit_radius=float(t["orbit_radius"]),
                      orbit_turn=domain.orbit_turn(t["orbit_phase"]))


def texture_combination(s: np.ndarray, t: dict, octave: int, n: int):
    """``cell_texture_combination`` at L^octave (O + s) (s already scaled by L^octave):
    (value (N,), dv/dx (N, 4), id (N,), F1..F4 (N, 4), cell (N, 4): offset to the (smooth) F1
    point in basis units and the (smooth) cell value)."""
    dim = t["dimension"]
    s = np.array(s, dtype=np.float64)
    s[:, dim:] = 0.0
    p = _basis(t, octave)
    cell, fr = texture_lattice(t["origin_cell"][octave], t["origin_frac"][octave], s * t["dist_scale"])
    cell[:, dim:] = 0
    fr[:, dim:] = 0.0
    F, D, I, exact = ref.search(cell, fr, p, n)
    F = F / t["dist_scale"]
    dF = ref.metric_gradient(D, F * t["dist_scale"], p) * np.asarray(p.axis_scale)
    dF[..., dim:] = 0.0
    lin = [t[c] for c in LINEAR]
    v = np.zeros(len(s))
    grad = np.zeros((len(s), 4))
    F4 = np.zeros((len(s), 4))
    for k in range(n):
        v += lin[k] * F[:, k]
        grad += lin[k] * dF[:, k]
        if k < 4:
            F4[:, k] = F[:, k]
    npr = min(n, 4)
    for i in range(npr):
        for j in range(npr):
            c = t[f"c{i + 1}{j + 1}"]
            v += c * F[:, i] * F[:, j]
            grad += c * (F[:, i, None] * dF[:, j] + F[:, j, None] * dF[:, i])
    fl = texture_feature_flags(t)
    cell_out = np.zeros((len(s), 4))
    if any(fl.values()):
        from cellgl.basis.features import features

        names = ("edge",) * fl["edge"] + ("smooth_F1",) * fl["smooth"] + ("nsphere",) * fl["nsphere"]
        x = features(cell, fr, p, F * t["dist_scale"], D, I, exact, names, t["smoothness"] * t["dist_scale"],
                     smooth=t["smooth"])
        ds = t["dist_scale"]
        v += (t["c_edge"] * x["edge"] + t["c_smooth"] * x["smooth_F"] + t["c_nsphere"] * x["nsphere"]) / ds
        grad += t["c_edge"] * x["edge_grad"] + t["c_smooth"] * x["smooth_grad"]
        cell_out[:, :3] = x["smooth_delta"][:, :3] / ds
        cell_out[:, 3] = x["smooth_attr"][:, 3]
    else:
        from cellgl.basis.features import id_value

        v += t["c_smooth"] * F[:, 0]
        grad += t["c_smooth"] * dF[:, 0]
        cell_out[:, :3] = D[:, 0, :3] / t["dist_scale"]
        cell_out[:, 3] = id_value(I[:, 0])
    if t["c_noise"] != 0.0:
        per = texture_period(t, octave) * int(round(t["noise_frequency"]))
        nv, gn = noise_split(t["noise_cell"][octave], t["noise_frac"][octave] + s * t["noise_frequency"], per,
                             (t["seed"] + 7919 + octave) & M32, dim)
        v += t["c_noise"] * nv
        grad += t["c_noise"] * t["noise_frequency"] * gn
    return v, grad, I[:, 0], F4, cell_out


def texture_feature_flags(t: dict) -> dict:
    """The features walks of a recipe (``CELL_EDGE``, ``CELL_SMOOTH``, ``CELL_NSPHERE`` of
    :func:`cellgl.texture.defines`)."""
    return {"edge": t["c_edge"] != 0.0, "nsphere": t["c_nsphere"] != 0.0,
            "smooth": t["smoothness"] > 0.0 and (t["c_smooth"] != 0.0 or t["cell_mix"] != 0.0)}


def texture_ramp(x: np.ndarray, t: dict, ramp) -> np.ndarray:
    """``cell_texture_ramp``: colours (N, 3) at x (N,) in [0, 1]."""
    keys = np.asarray(ramp, dtype=np.float64)       # (n, 4): t, r, g, b
    n = len(keys)
    pos, col = keys[:, 0], keys[:, 1:]
    if t["ramp_mode"] == "spline" and n >= 4:
        spans = n - 3
        s = np.clip(x, 0.0, 1.0) * spans
        k = np.minimum(s.astype(np.int64), spans - 1)
        s = (s - k)[:, None]
        p0, p1, p2, p3 = col[k], col[k + 1], col[k + 2], col[k + 3]
        return 0.5 * ((((-p0 + 3 * p1 - 3 * p2 + p3) * s + (2 * p0 - 5 * p1 + 4 * p2 - p3)) * s
                       + (p2 - p0)) * s + 2 * p1)
    out = np.repeat(col[-1][None], len(x), axis=0)
    done = x <= pos[0]
    out[done] = col[0]
    for k in range(1, n):
        sel = ~done & (x <= pos[k])
        w = pos[k] - pos[k - 1]
        f = (x[sel] - pos[k - 1]) / w if w > 0 else np.ones(int(sel.sum()))
        out[sel] = col[k - 1] + (col[k] - col[k - 1]) * f[:, None]
        done |= sel
    return out


def texture_cell_value(ids: np.ndarray) -> np.ndarray:
    """``cell_texture_cell_value``: a value in [0, 1) per feature ID."""
    h = hash_u32(np.asarray(ids, dtype=np.uint64) ^ np.uint64(0x2545F491))
    return (h >> np.uint64(8)).astype(np.float64) / 16777216.0


def texture_warp(s: np.ndarray, t: dict):
    """``cell_texture_warp``: the warped positions (N, 4) and the rows j (4, N, 4) of the warp's
    Jacobian minus the identity."""
    dim = t["dimension"]
    per = texture_period(t, 0) * int(round(t["warp_frequency"]))
    x = t["warp_frac"] + s * t["warp_frequency"]
    d = np.zeros_like(s)
    j = np.zeros((4,) + s.shape)
    for a in range(dim):
        seed = (t["seed"] + domain.WARP_SEED + domain.WARP_SEED_STEP * a) & M32
        v, g = noise_fractal_split(t["warp_cell"], x, per, seed, t["warp_octaves"], dim)
        d[:, a] = t["warp_amount"] * v
        j[a] = t["warp_amount"] * t["warp_frequency"] * g
    return s + d, j


def texture_footprint(duvz, t: dict) -> np.ndarray:
    """``cell_texture_footprint``: a pixel spanning ``duvz`` ((3,) or (N, 3)) in texture space,
    in basis units."""
    f = t["frequency"]
    return np.max(np.abs(np.asarray(duvz, dtype=np.float64)) * np.array([f, f * t["aspect"], f]), axis=-1)


def texture(s: np.ndarray, recipe, n: int | None = None, t: dict | None = None, r=0.0) -> dict:
    """``cell_texture_filtered``: the texture at basis positions O + s, s (N, 4) small
    (:func:`texture_local`) and the origin O = (offset_x, offset_y, offset_z, time) split in ``t``
    (default ``texture_values(recipe)``), band-limited to the footprint ``r`` (scalar or (N,), basis units).

    Returns a dict with height (N,), grad (N, 4), normal (N, 3), color (N, 4), id (N,),
    F (N, 4), value (N,), as the GLSL ``CellTexel``.
    """
    from cellgl.texture.recipe import needed_n

    t = t if t is not None else texture_values(recipe)
    n = n or needed_n(recipe)
    N = len(s)
    j = None
    if t["warp_amount"] != 0.0:
        s, j = texture_warp(np.asarray(s, dtype=np.float64), t)
    fractal = t["fractal"]
    octaves = 1 if fractal == "none" else int(np.ceil(t["octaves"]))
    qin = fractal in ("qin", "qin_cube")
    inv_range = 1.0 / (t["range_hi"] - t["range_lo"])
    G = np.zeros(N)
    dG = np.zeros((N, 4))
    total, amp, scale = 0.0, 1.0, 1.0
    o: dict = {}
    spacings = t["antialias"] * t["feature_frequency"] * np.broadcast_to(np.asarray(r, dtype=np.float64), (N,))
    for i in range(min(octaves, MAX_OCTAVES)):
        w = amp
        if fractal != "none":
            w *= min(t["octaves"] - i, 1.0)
        a = smoothscale(spacings * scale)
        if i == 0 or np.any(a > 0.0):
            v, g, ids, F4, cell = texture_combination(s * scale, t, i, n)
            if i == 0:
                o.update(value=v, id=ids, F=F4, cell=cell)
            if fractal == "min":
                # Blender's distance-to-edge fractal: the least v(L^i x) / L^i, normalised below;
                # octave i > 0 fades in by the fraction of octaves and its band limit a
                vm = v / scale
                if i == 0:
                    G, dG = vm, g
                else:
                    fade = min(t["octaves"] - i, 1.0) * a
                    take = vm < G
                    G = np.where(take, G + (vm - G) * fade, G)
                    dG = np.where(take[:, None], dG + (g - dG) * fade[:, None], dG)
                scale *= t["lacunarity"]
                continue
            b = (v - t["range_lo"]) * inv_range
            db = g * (inv_range * scale)
            out = (b < 0.0) | (b > 1.0)
            b = np.clip(b, 0.0, 1.0)
            db[out] = 0.0
            term = b
            if qin:
                dev = 0.5 - b
                term = np.abs(dev)
                db = -np.sign(dev)[:, None] * db
            G += w * (a * term + (1.0 - a) * t["octave_mean"])
            dG += (w * a)[:, None] * db
        elif fractal != "min":
            G += w * t["octave_mean"]
        total += 0.5 * w if qin else w
        amp *= t["gain"]
        scale *= t["lacunarity"]
    if fractal == "min":
        G = (G - t["range_lo"]) * inv_range
        dG = dG * inv_range
        out = (G < 0.0) | (G > 1.0)
        G = np.clip(G, 0.0, 1.0)
        dG[out] = 0.0
    else:
        G /= total
        dG /= total
    if fractal == "qin_cube":
        dG *= 3.0 * (G * G)[:, None]
        G = G ** 3
    if t["invert"]:
        G = 1.0 - G
        dG = -dG
    lw = 1.0 / (t["level_hi"] - t["level_lo"])
    h = (G - t["level_lo"]) * lw
    dh = dG * lw
    out = (h < 0.0) | (h > 1.0)
    h = np.clip(h, 0.0, 1.0)
    dh[out] = 0.0
    if j is not None:
        dh = dh + sum(dh[:, a, None] * j[a] for a in range(4))
    o["height"] = h
    o["grad"] = dh
    nrm = np.stack([-t["bump"] * dh[:, 0], -t["bump"] * dh[:, 1], np.ones(N)], axis=1)
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    image = t["cell_color"] == "image"
    index = h if image else h + (o["cell"][:, 3] - h) * t["cell_mix"]
    if t["noise_color"] != 0.0:
        per = texture_period(t, 0) * int(round(t["noise_frequency"]))
        nv, _ = noise_fractal_split(t["noise_cell"][0], t["noise_frac"][0] + s * t["noise_frequency"], per,
                                    (t["seed"] + 104729) & M32, t["noise_octaves"], t["dimension"])
        index = index + t["noise_color"] * nv
    rgb = texture_ramp(np.clip(index, 0.0, 1.0), t, recipe.ramp)
    if image:
        from cellgl.texture.images import sample

        pt = s + o["cell"]
        uv = np.stack([t["pan"][0] + pt[:, 0] / t["frequency"],
                       t["pan"][1] + pt[:, 1] / (t["frequency"] * t["aspect"])], axis=1)
        rgb = rgb + (sample(recipe.cell_pixels(), uv, bool(t["tileable"])) - rgb) * t["cell_mix"]
    rgb = rgb * (1.0 + (h - 1.0) * t["shade"])[:, None]
    L = np.array([-1.0, -1.0, 1.5])
    L /= np.linalg.norm(L)
    lam = np.clip(nrm @ L / L[2], 0.0, 2.0)
    rgb = rgb * (1.0 + (lam - 1.0) * t["light"])[:, None]
    o["color"] = np.concatenate([np.clip(rgb, 0.0, 1.0), np.ones((N, 1))], axis=1)
    if t["normal_convention"] == "opengl":
        nrm[:, 1] = -nrm[:, 1]
    o["normal"] = nrm
    return o


def texture_at(p: np.ndarray, recipe, n: int | None = None, pan=(0.0, 0.0), duvz=(0.0, 0.0, 0.0)) -> dict:
    """``cell_texture_at_filtered``: the texture at texture-space points p (N, 3) (plus ``pan``
    in uv), band-limited to pixels spanning ``duvz`` ((3,) or (N, 3); 0: point samples)."""
    t = texture_values(recipe, pan)
    return texture(texture_local(np.asarray(p, dtype=np.float64), t), recipe, n, t, texture_footprint(duvz, t))


def evaluate(recipe, pts: np.ndarray, outputs, duvz=(0.0, 0.0, 0.0)) -> dict:
    """The NumPy backend of :func:`cellgl.texture.evaluate` (pts (N, 3) texture space; ``duvz``:
    the footprint of each point in texture space, as its ``filter_width``; the caller checks
    them: :func:`cellgl.texture.evaluation.check_points`)."""
    from cellgl.texture.recipe import needed_n

    n = needed_n(recipe)
    for c in outputs:
        if c in ("F1", "F2", "F3", "F4"):
            n = max(n, int(c[1]))
    mat = [c for c in outputs if c in MATERIAL_CHANNELS]
    n = max(n, 2) if mat else n             # the edge mask reads F2 - F1 (shader.defines)
    o = texture_at(pts, recipe, n, duvz=duvz)
    t = texture_values(recipe)
    res = {c: a.astype(np.float32) for c, a in material(o, t).items() if c in mat} if mat else {}
    for c in outputs:
        if c == "color":
            res[c] = o["color"].astype(np.float32)
        elif c == "height":
            res[c] = o["height"].astype(np.float32)
        elif c == "normal":
            res[c] = (o["normal"] * 0.5 + 0.5).astype(np.float32)
        elif c == "id":
            res[c] = o["id"].astype(np.uint32)
        elif c in ("F1", "F2", "F3", "F4"):
            res[c] = o["F"][:, int(c[1]) - 1].astype(np.float32)
        elif c == "grad":
            f = t["frequency"]
            res[c] = (o["grad"][:, :3] * np.array([f, f * t["aspect"], f])).astype(np.float32)
        elif c == "value":
            res[c] = o["value"].astype(np.float32)
    return res


# --------------------------------------------------------------------------- band limit

def octave_mean(recipe) -> float:
    """The octave mean of ``recipe``: :func:`cellgl.texture.means.octave_mean` (carried for the
    presets, else measured once per process with :func:`measure_mean`)."""
    from cellgl.texture.means import octave_mean as mean

    return mean(recipe, measure_mean)


def measure_mean(recipe) -> float:
    """The octave mean measured: this reference at :data:`cellgl.texture.means.SAMPLES` fixed
    points, rounded to float32 (what defines the mean; :mod:`cellgl.texture.means` keeps it)."""
    from cellgl.texture.means import RNG_SEED, SAMPLES as _MEAN_SAMPLES
    from cellgl.texture.recipe import needed_n

    v = recipe.values
    rng = np.random.default_rng(RNG_SEED)
    dim = int(v["dimension"])
    pts = np.zeros((_MEAN_SAMPLES, 3))
    if v["density_map"] != "none":
        probe = recipe.replace(fractal="none")
        pts[:, :2] = rng.uniform(0.0, 1.0, size=(_MEAN_SAMPLES, 2))
    else:
        probe = recipe.replace(tileable=False, fractal="none", frequency=1.0, aspect=1.0,
                               offset_x=0.0, offset_y=0.0, offset_z=0.0, time=0.0)
        side = 1000.0 if dim == 2 else 100.0
        pts[:, : min(dim, 3)] = rng.uniform(0.0, side, size=(_MEAN_SAMPLES, min(dim, 3)))
    t = texture_values(probe, mean=False)
    s = texture_local(pts, t)
    val = texture_combination(s, t, 0, needed_n(probe))[0]
    b = np.clip((val - v["range_lo"]) / (v["range_hi"] - v["range_lo"]), 0.0, 1.0)
    term = np.abs(0.5 - b) if v["fractal"] in ("qin", "qin_cube") else b
    return float(np.float32(term.mean()))
