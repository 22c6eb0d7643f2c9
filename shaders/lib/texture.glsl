// cellgl: textures from the cellular basis (Worley 1996, Qin 2000).
//
// One recipe (cellgl/texture/recipe.py) evaluated at a point of basis space:
//
//   value  v(x) = sum_i c_i F_i(x) + sum_{i,j<=4} c_ij F_i(x) F_j(x) + c_noise n(x)
//                 + c_edge E(x) + c_smooth S(x) + c_nsphere R(x)
//                 (Worley's linear combinations, Qin's generalized basis, the book's
//                 F1 F2 and F3^2 - F2^2, and gradient noise for comparison; distance to
//                 edge, smooth F1 and n-sphere radius: features.glsl)
//   basis  b(x) = clamp((v(x) - range_lo) / (range_hi - range_lo), 0, 1)
//                 (range measured once, empirically, as Worley did)
//   fractal G(x) = sum_i w_i b(L^i x) / sum_i w_i          (sum: Worley's G_n)
//              or sum_i w_i |0.5 - b(L^i x)| / (0.5 sum w_i)  (qin, Qin's eq. 6)
//              or the cube of that                          (qin_cube: Qin's wrinkle bump)
//              or b(min_i v(L^i x) / L^i)                   (min: Blender's edge fractal)
//                 with w_i = gain^i, L = lacunarity, i < octaves (the last octave
//                 weighted by the fractional part of octaves); octave i uses seed + 1013 i;
//                 each octave's term band-limited to the pixel footprint (below)
//   height h(x) = clamp(((invert ? 1 - G : G) - level_lo) / (level_hi - level_lo), 0, 1)
//   colour      = ramp(mix(h, cell value of the F1 ID, cell_mix) + noise_color * fbm(x))
//                 * mix(1, h, shade) * mix(1, lambert(normal), light)
//                 (cell_color image: mix(ramp(h + noise), image at the F1 point, cell_mix)
//                 instead; with smoothness > 0 the cell value and the point are the
//                 smooth-F1 blends)
//
// The gradient of h is analytic: dF_n/dx is the unit vector from the n-th feature
// point towards x (cell_metric_gradient), carried through the combination, the
// normalisation, the fractal sum and the window by the chain rule (zero where a
// clamp is active). The normal is normalize(-bump dh/dx, -bump dh/dy, 1) with x, y
// in basis units (cells); y follows the image rows (down), and the OpenGL
// convention flips it to +Y up.
//
// Texture space -> basis space: p = (u, v, z) with u, v in [0, 1] (v = 0 is the
// image's top row), x = (u f + offset_x, v f aspect + offset_y, z f + offset_z, time)
// with f = frequency. A W x H bake shows pixel (i, j) (row j from the top) at
// uv = ((i + 0.5) / W, (j + 0.5) / H).
//
// Big coordinates: x = O + s with the origin O = (offset_x, offset_y, offset_z,
// time), which may be large (10^6 cells), and s = (u f, v f aspect, z f, 0),
// which is small. Octave i samples lattices at scale k = L^i (times dist_scale
// for the basis, times noise_frequency for the noise); the CPU splits k O in
// float64 into an integer cell and a float32 fraction (t.origin_cell[i] +
// t.origin_frac[i] for the basis, t.noise_cell[i] + t.noise_frac[i] for the
// noise; tileable recipes wrap the cell by the period), and the shader adds
// only the small k s: cell = origin_cell + floor(origin_frac + k s), fraction
// = the rest. So a texture 10^6 cells from the origin is as sharp as at it.
//
// Stretched cells (CELL_ANISO): distances weight axis a by t.axis_scale[a]
// (cellgl/texture/domain.py: normalised 1 / stretch), exactly (cellular.glsl).
// Domain warp: the whole texture is evaluated at s + d(s), d = warp_amount
// (n_0, n_1, ...) fractal gradient noise (cell_texture_warp); the gradient
// follows by the chain rule. Loopable animation (CELL_ORBIT): the feature
// points orbit (points.glsl cell_orbit) at t.orbit_turn.
//
// Band limit (antialiasing; Qin's smoothscale). Qin's cloud (eq. 7) multiplies octave
// i by smoothscale(2^i x), a factor that "depends on the differential surface area" at
// the point, so that octaves finer than the pixel fade out instead of aliasing. cellgl's
// form: with the footprint r (the pixel's size in basis units: the bake knows it, a
// fragment shader takes it from derivatives, cell_texture(s, t) uses 0 = unfiltered) and
// t.feature_frequency (feature points per basis unit along a line: dist_scale
// density^(1/dim)), octave i spans w_i = antialias feature_frequency L^i r feature
// spacings per pixel, and its term fades towards the term's mean over the plane:
//
//   a_i = 1 - smoothstep(CELL_TEX_AA_LO, CELL_TEX_AA_HI, w_i)    (cell_texture_smoothscale)
//   term_i -> a_i term_i + (1 - a_i) t.octave_mean               (its gradient: a_i dterm_i)
//
// so the sum of weights, and with it the look of a large bake (every a_i = 1), is
// unchanged; an octave with a_i = 0 is not searched at all. The features of one octave are
// a Voronoi pattern about 1 / feature_frequency apart: w = 0.5 is two pixels per feature
// (the Nyquist limit of the pattern: kept), w = 1 one (gone). The thresholds were chosen
// by measurement (docs/antialias.md): fading from four pixels down lost more resolved
// detail than it removed aliasing. t.octave_mean is the mean of the octave's term, b or
// |0.5 - b|, measured once per recipe with the NumPy reference (cellgl/texture/reference.py,
// octave_mean).
//
// Requires: cellular.glsl, noise.glsl, texture_params.glsl (generated from the
// parameter table: struct CellTextureParams, CELL_TEX_* enums).
// Macros: those of cellular.glsl, plus CELL_PERIODIC for tileable recipes,
// CELL_DENSITY_MAP (a density map: the fields t.density_* of cellgl/texture/shader.py),
// CELL_ORBIT and CELL_ANISO (cellgl/texture/domain.py), those of features.glsl and
// CELL_TEX_CELL_IMAGE (cell_color image).

#include "features.glsl"
#include "noise.glsl"
#include "texture_params.glsl"
// CELL_PRECISE (metric.glsl) on the positions and sums that make a texel: the same bytes from
// the compute and the fragment entry on one driver (docs/exactness.md).

struct CellTexel {
    float height;   // h in [0, 1]
    vec4 grad;      // dh / d(basis position), per cell (components past CELL_DIM are 0)
    vec3 normal;    // unit tangent-space normal: x right, y up (opengl) or down (directx), z out
    vec4 color;     // rgba in [0, 1] (a = 1)
    uint id;        // ID of the nearest feature point (octave 0)
    vec4 F;         // F1..F4 at octave 0 (0 past CELL_N)
    float value;    // the combination v at octave 0, before normalisation
    vec4 cell;      // octave 0: (feature point - x) in basis units (xyz), cell value (w)
};

// Texture space (u, v, z) -> basis space relative to the origin (offset_x,
// offset_y, offset_z, time), which t carries split per octave: s = x - O.
vec4 cell_texture_local(vec3 p, CellTextureParams t)
{
    CELL_PRECISE vec4 s = vec4(p.x * t.frequency, p.y * t.frequency * t.aspect, p.z * t.frequency, 0.0);
    return s;
}

// The lattice point origin_cell + origin_frac + s as an integer cell and a
// fraction in [0, 1) (s small).
// (ivec4(fl) is in range: the CPU keeps |origin_frac + s| far below 2^31, texture/lattice.)
void cell_texture_lattice(ivec4 origin_cell, vec4 origin_frac, vec4 s, out ivec4 cell, out vec4 f)
{
    CELL_PRECISE vec4 q = origin_frac + s;
    vec4 fl = floor(q);
    cell = origin_cell + ivec4(fl);
    f = q - fl;
}

// Lattice period of octave `octave` (cells per repeat; z too for solid bases), 0 where not tileable.
ivec4 cell_texture_period(CellTextureParams t, int octave)
{
#if CELL_PERIODIC
    int m = 1;
    for (int i = 0; i < octave; i++) {
        m *= int(round(t.lacunarity));
    }
    int f = int(round(t.frequency)) * m;
    return ivec4(f, int(round(t.frequency * t.aspect)) * m, CELL_DIM >= 3 ? f : 0, 0);
#else
    return ivec4(0);
#endif
}

// The basis parameters of one octave.
CellParams _cell_tex_basis(CellTextureParams t, int octave)
{
    CellParams p;
    p.seed = t.seed + uint(octave) * 1013u;
    p.jitter = t.jitter;
    p.min_points = t.min_points;
    p.max_points = t.max_points;
    for (int k = 0; k < CELL_MAX_POINTS; k++) {
        p.thresholds[k] = t.thresholds[k];
    }
    p.period = cell_texture_period(t, octave);
#if CELL_ANISO
    p.axis_scale = t.axis_scale;
#endif
#if CELL_ORBIT
    p.orbit_radius = t.orbit_radius;
    p.orbit_turn = t.orbit_turn;
#endif
    p.minkowski_p = t.minkowski_p;
#if CELL_DENSITY_MAP != CELL_DMAP_NONE
    // The density map of this octave (cellgl/texture/shader.py density_encodings: the map
    // in uv, scaled to the octave's lattice, relative to its split origin).
    for (int k = 0; k < CELL_DENSITY_LEVELS * CELL_MAX_POINTS; k++) {
        p.density_thresholds[k] = t.density_thresholds[k];
    }
    for (int a = 0; a < 4; a++) {
        p.density_axis[a] = t.density_axis[octave * 4 + a];
    }
    p.density_info = t.density_info[octave];
#endif
    return p;
}

// The combination v for one octave at basis position L^octave (O + s) (s
// already scaled by lacunarity^octave: L^octave s), its gradient dv/dx, the
// nearest ID, F1..F4 and the cell (CellTexel.cell; at this octave's scale).
float cell_texture_combination(vec4 s, CellTextureParams t, int octave, out vec4 grad,
                               out uint id, out vec4 F4, out vec4 cell_out)
{
    s = cell_dims(s);
    CellParams p = _cell_tex_basis(t, octave);
    ivec4 cell;
    vec4 f;
    // a product, then the lattice's sum: no fused multiply-add
    CELL_PRECISE vec4 sd = s * t.dist_scale;
    cell_texture_lattice(t.origin_cell[octave], t.origin_frac[octave], sd, cell, f);
    cell = cell_dims_i(cell);
    f = cell_dims(f);
    CellResult r = cell_search(cell, f, p);

    float lin[8] = float[8](t.c1, t.c2, t.c3, t.c4, t.c5, t.c6, t.c7, t.c8);
    float prod[16] = float[16](t.c11, t.c12, t.c13, t.c14, t.c21, t.c22, t.c23, t.c24,
                               t.c31, t.c32, t.c33, t.c34, t.c41, t.c42, t.c43, t.c44);
    float F[CELL_N];
    vec4 dF[CELL_N];
    // grad, an out parameter, is precise through the entry's outputs (CELL_PRECISE there)
    CELL_PRECISE float v = 0.0;
    grad = vec4(0.0);
    F4 = vec4(0.0);
    for (int k = 0; k < CELL_N; k++) {
        F[k] = r.F[k] / t.dist_scale;
        dF[k] = cell_metric_gradient(r.delta[k], r.F[k], t.minkowski_p);
#if CELL_ANISO
        dF[k] *= t.axis_scale;      // r.delta is weighted: the chain rule
#endif
        v += lin[k] * F[k];
        grad += lin[k] * dF[k];
        if (k < 4) {
            F4[k] = F[k];
        }
    }
#define CELL_TEX_NP (CELL_N < 4 ? CELL_N : 4)
    for (int i = 0; i < CELL_TEX_NP; i++)
    for (int j = 0; j < CELL_TEX_NP; j++) {
        float c = prod[i * 4 + j];
        v += c * F[i] * F[j];
        grad += c * (F[i] * dF[j] + F[j] * dF[i]);
    }
#undef CELL_TEX_NP
#if CELL_EDGE || CELL_SMOOTH || CELL_NSPHERE
    CellFeatures x = cell_features(cell, f, p, r, t.smoothness * t.dist_scale);
    v += (t.c_edge * x.edge + t.c_smooth * x.smooth_F + t.c_nsphere * x.nsphere) / t.dist_scale;
    grad += t.c_edge * x.edge_grad + t.c_smooth * x.smooth_grad;
    cell_out = vec4(x.smooth_delta.xyz / t.dist_scale, x.smooth_attr.w);
#else
    v += t.c_smooth * F[0];          // smoothness 0: smooth F1 is F1
    grad += t.c_smooth * dF[0];
    cell_out = vec4(r.delta[0].xyz / t.dist_scale, cell_id_value(r.id[0]));
#endif
    if (t.c_noise != 0.0) {
        vec4 gn;
        ivec4 per = cell_texture_period(t, octave) * int(round(t.noise_frequency));
        v += t.c_noise * cell_noise_split(t.noise_cell[octave], t.noise_frac[octave] + s * t.noise_frequency,
                                          per, t.seed + 7919u + uint(octave), gn);
        grad += t.c_noise * t.noise_frequency * gn;
    }
    id = r.id[0];
    return v;
}

// The colour ramp at x in [0, 1]: linear between keys at their positions
// (ramp[k].w), or Qin's RenderMan spline (uniform Catmull-Rom; the first and
// last keys only steer the ends).
vec3 cell_texture_ramp(float x, CellTextureParams t)
{
    // n and k clamped: every index in range whatever the uniform (or a NaN x) holds
    int n = t.ramp_count < 1 ? 1 : (t.ramp_count > CELL_TEX_RAMP_KEYS ? CELL_TEX_RAMP_KEYS : t.ramp_count);
    if (t.ramp_mode == CELL_TEX_RAMP_SPLINE && n >= 4) {
        int spans = n - 3;
        float s = clamp(x, 0.0, 1.0) * float(spans);
        int k = clamp(int(s), 0, spans - 1);
        s -= float(k);
        vec3 p0 = t.ramp[k].rgb, p1 = t.ramp[k + 1].rgb, p2 = t.ramp[k + 2].rgb, p3 = t.ramp[k + 3].rgb;
        return 0.5 * ((((-p0 + 3.0 * p1 - 3.0 * p2 + p3) * s + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3)) * s
                       + (p2 - p0)) * s + 2.0 * p1);
    }
    if (x <= t.ramp[0].w) {
        return t.ramp[0].rgb;
    }
    for (int k = 1; k < CELL_TEX_RAMP_KEYS; k++) {
        if (k < n && x <= t.ramp[k].w) {
            float w = t.ramp[k].w - t.ramp[k - 1].w;
            float f = w > 0.0 ? (x - t.ramp[k - 1].w) / w : 1.0;
            return mix(t.ramp[k - 1].rgb, t.ramp[k].rgb, f);
        }
    }
    return t.ramp[n - 1].rgb;
}

// A value in [0, 1) constant over the Voronoi cell of feature point `id`.
float cell_texture_cell_value(uint id)
{
    return cell_id_value(id);
}

// Domain warp: s + warp_amount (n_0, n_1, ...), n_a the fractal gradient noise
// (warp_octaves, seed + 31337 + 101 a) at the warp lattice position
// warp_frequency (O + s), carried split as t.warp_cell + t.warp_frac + s
// warp_frequency (repeating with the texture when tileable). j0..j3 receive the
// rows of the warp's Jacobian minus the identity: ja = d(displacement_a)/ds.
vec4 cell_texture_warp(vec4 s, CellTextureParams t, out vec4 j0, out vec4 j1, out vec4 j2, out vec4 j3)
{
    ivec4 per = cell_texture_period(t, 0) * int(round(t.warp_frequency));
    vec4 x = t.warp_frac + s * t.warp_frequency;
    vec4 d = vec4(0.0);
    vec4 g;
    float k = t.warp_amount * t.warp_frequency;
    d.x = t.warp_amount * cell_noise_fractal_split(t.warp_cell, x, per, t.seed + 31337u, t.warp_octaves, g);
    j0 = k * g;
    d.y = t.warp_amount * cell_noise_fractal_split(t.warp_cell, x, per, t.seed + 31438u, t.warp_octaves, g);
    j1 = k * g;
    j2 = vec4(0.0);
    j3 = vec4(0.0);
#if CELL_DIM >= 3
    d.z = t.warp_amount * cell_noise_fractal_split(t.warp_cell, x, per, t.seed + 31539u, t.warp_octaves, g);
    j2 = k * g;
#endif
#if CELL_DIM >= 4
    d.w = t.warp_amount * cell_noise_fractal_split(t.warp_cell, x, per, t.seed + 31640u, t.warp_octaves, g);
    j3 = k * g;
#endif
    return s + d;
}

#include "texture_image.glsl"
#include "texture_material.glsl"

// The band-limit factor a of an octave whose features are w feature spacings per pixel
// (see the header): 1 while they are two pixels apart or more, 0 from one pixel down.
#define CELL_TEX_AA_LO 0.5
#define CELL_TEX_AA_HI 1.0
float cell_texture_smoothscale(float w)
{
    return 1.0 - smoothstep(CELL_TEX_AA_LO, CELL_TEX_AA_HI, w);
}

// The footprint r of a pixel (or sample) that spans duvz in texture space, in basis units:
// the largest of its sides after the domain's scale (frequency, frequency aspect, frequency).
float cell_texture_footprint(vec3 duvz, CellTextureParams t)
{
    vec3 d = abs(duvz) * vec3(t.frequency, t.frequency * t.aspect, t.frequency);
    return max(d.x, max(d.y, d.z));
}

// The fractal of the octaves at basis position s (after the warp), band-limited to
// a pixel of footprint r basis units: G in [0, 1] before the levels, its gradient
// dG; octave 0's ID, F1..F4, value and cell go into o.
float _cell_texture_octaves(vec4 s, float r, CellTextureParams t, inout CellTexel o, out vec4 dG)
{
    int octaves = t.fractal == CELL_TEX_FRACTAL_NONE ? 1 : int(ceil(t.octaves));
    bool qin = t.fractal == CELL_TEX_FRACTAL_QIN || t.fractal == CELL_TEX_FRACTAL_QIN_CUBE;
    float inv_range = 1.0 / (t.range_hi - t.range_lo);
    CELL_PRECISE float G = 0.0, total = 0.0, amp = 1.0, scale = 1.0;
    dG = vec4(0.0);
    // Feature spacings per pixel at octave 0 (times L^i at octave i).
    float spacings = t.antialias * t.feature_frequency * r;
    for (int i = 0; i < CELL_TEX_OCTAVES; i++) {
        if (i >= octaves) {
            break;
        }
        float w = amp;
        if (t.fractal != CELL_TEX_FRACTAL_NONE) {
            w *= min(t.octaves - float(i), 1.0);
        }
        float a = cell_texture_smoothscale(spacings * scale);
        // Octave 0 is always searched: the ID and F1..F4 outputs come from it.
        if (a > 0.0 || i == 0) {
            vec4 g, F4, cell;
            uint id;
            float v = cell_texture_combination(s * scale, t, i, g, id, F4, cell);
            if (i == 0) {
                o.value = v;
                o.id = id;
                o.F = F4;
                o.cell = cell;
            }
            if (t.fractal == CELL_TEX_FRACTAL_MIN) {
                // Blender's distance-to-edge fractal: the least v(L^i x) / L^i, normalised
                // after the loop; octave i > 0 fades in by the fraction of octaves and a.
                float vm = v / scale;
                if (i == 0 || vm < G) {
                    float fade = i == 0 ? 1.0 : min(t.octaves - float(i), 1.0) * a;
                    G = mix(G, vm, fade);
                    dG = mix(dG, g, fade);
                }
                scale *= t.lacunarity;
                continue;
            }
            CELL_PRECISE float b = (v - t.range_lo) * inv_range;
            CELL_PRECISE vec4 db = g * (inv_range * scale);
            if (b < 0.0 || b > 1.0) {
                b = clamp(b, 0.0, 1.0);
                db = vec4(0.0);
            }
            float term = b;
            if (qin) {
                float dev = 0.5 - b;
                term = abs(dev);
                db = -sign(dev) * db;
            }
            G += w * (a * term + (1.0 - a) * t.octave_mean);
            dG += (w * a) * db;
        } else if (t.fractal != CELL_TEX_FRACTAL_MIN) {
            G += w * t.octave_mean;
        }
        total += qin ? 0.5 * w : w;
        amp *= t.gain;
        scale *= t.lacunarity;
    }
    if (t.fractal == CELL_TEX_FRACTAL_MIN) {
        G = (G - t.range_lo) * inv_range;
        dG *= inv_range;
        if (G < 0.0 || G > 1.0) {
            G = clamp(G, 0.0, 1.0);
            dG = vec4(0.0);
        }
    } else {
        G /= total;
        dG /= total;
    }
    return G;
}

// The colour and normal of the texel o at basis position s (after the warp) whose
// height is h, its gradient dh.
void _cell_texture_shade(inout CellTexel o, vec4 s, float h, vec4 dh, CellTextureParams t)
{
    // Normal, y down (image rows) first.
    CELL_PRECISE vec3 n = normalize(vec3(-t.bump * dh.x, -t.bump * dh.y, 1.0));

#if CELL_TEX_CELL_IMAGE
    CELL_PRECISE float index = h;
#else
    CELL_PRECISE float index = mix(h, o.cell.w, t.cell_mix);
#endif
    if (t.noise_color != 0.0) {
        vec4 gn;
        ivec4 per = cell_texture_period(t, 0) * int(round(t.noise_frequency));
        index += t.noise_color * cell_noise_fractal_split(t.noise_cell[0], t.noise_frac[0] + s * t.noise_frequency,
                                                          per, t.seed + 104729u, t.noise_octaves, gn);
    }
    CELL_PRECISE vec3 rgb = cell_texture_ramp(clamp(index, 0.0, 1.0), t);
#if CELL_TEX_CELL_IMAGE
    // The feature point's uv: the sample's (s / (f, f aspect), plus the view's pan)
    // plus its offset.
    vec4 pt = s + o.cell;
    vec2 uv = t.cell_image_info.xy + vec2(pt.x / t.frequency, pt.y / (t.frequency * t.aspect));
    rgb = mix(rgb, cell_texture_image(uv, t), t.cell_mix);
#endif
    rgb *= mix(1.0, h, t.shade);
    // Preview lighting from the top left, normalised so that a flat surface keeps its colour.
    vec3 L = normalize(vec3(-1.0, -1.0, 1.5));
    float lambert = clamp(dot(n, L) / L.z, 0.0, 2.0);
    rgb *= mix(1.0, lambert, t.light);
    o.color = vec4(clamp(rgb, vec3(0.0), vec3(1.0)), 1.0);
    o.normal = t.normal_convention == CELL_TEX_NORMAL_OPENGL ? vec3(n.x, -n.y, n.z) : n;
}

// The texture at basis position O + s: O = (offset_x, offset_y, offset_z, time),
// carried split in t; s small (cell_texture_local); band-limited to a pixel of
// footprint r basis units (cell_texture_footprint; 0: no band limit).
CellTexel cell_texture_filtered(vec4 s, float r, CellTextureParams t)
{
    CellTexel o;
    vec4 wj0 = vec4(0.0), wj1 = vec4(0.0), wj2 = vec4(0.0), wj3 = vec4(0.0);
    if (t.warp_amount != 0.0) {
        s = cell_texture_warp(s, t, wj0, wj1, wj2, wj3);
    }
    vec4 dG;
    float G = _cell_texture_octaves(s, r, t, o, dG);
    if (t.fractal == CELL_TEX_FRACTAL_QIN_CUBE) {
        dG *= 3.0 * G * G;
        G = G * G * G;
    }
    if (t.invert != 0) {
        G = 1.0 - G;
        dG = -dG;
    }
    float lw = 1.0 / (t.level_hi - t.level_lo);
    CELL_PRECISE float h = (G - t.level_lo) * lw;
    CELL_PRECISE vec4 dh = dG * lw;
    if (h < 0.0 || h > 1.0) {
        h = clamp(h, 0.0, 1.0);
        dh = vec4(0.0);
    }
    // Through the warp: dh/ds = (I + J)^T dh/ds' (J = 0 without one).
    dh += dh.x * wj0 + dh.y * wj1 + dh.z * wj2 + dh.w * wj3;
    o.height = h;
    o.grad = dh;
    _cell_texture_shade(o, s, h, dh, t);
    return o;
}

// The texture at O + s without a band limit (a point sample).
CellTexel cell_texture(vec4 s, CellTextureParams t)
{
    return cell_texture_filtered(s, 0.0, t);
}

// The texture at texture-space point p = (u, v, z): uv on the image plane, or
// object-space (x, y, z) for solid recipes; band-limited to a pixel spanning duvz in
// texture space (e.g. (1 / W, 1 / H, 0) for a W x H bake, fwidth(p) in a fragment
// shader; 0: a point sample).
CellTexel cell_texture_at_filtered(vec3 p, vec3 duvz, CellTextureParams t)
{
    return cell_texture_filtered(cell_texture_local(p, t), cell_texture_footprint(duvz, t), t);
}

// The texture at texture-space point p, unfiltered.
CellTexel cell_texture_at(vec3 p, CellTextureParams t)
{
    return cell_texture(cell_texture_local(p, t), t);
}

// The RGBA a bake writes for the pixel whose centre is uv (v = 0: top row) and whose
// size is duv in uv (a W x H bake: (1 / W, 1 / H)).
vec4 cell_texture_uv(vec2 uv, vec2 duv, CellTextureParams t)
{
    return cell_texture_at_filtered(vec3(uv, 0.0), vec3(duv, 0.0), t).color;
}

// dh/d(u, v, z): the height gradient in texture space.
vec3 cell_texture_grad_uvz(CellTexel x, CellTextureParams t)
{
    return x.grad.xyz * vec3(t.frequency, t.frequency * t.aspect, t.frequency);
}
