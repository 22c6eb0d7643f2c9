// cellgl: Perlin-style gradient noise with integer hashing, and its analytic gradient.
//
// The complement the cellular papers use: fractal noise discoloration of
// flagstone cells (Worley), and the noise-based comparisons in Qin's figures.
//
// Each integer lattice corner c hashes (with the seed) to a gradient vector g
// whose components are uniform in [-1, 1] (the same cell_u16 values NumPy sees).
// The noise at x is the quintic-faded multilinear interpolation of the corner
// ramps dot(g, x - c):
//     n(x) = sum_c  prod_a w_a(c, x)  dot(g_c, x - c),
//     w_a = u(f_a) if c_a is the upper corner else 1 - u(f_a),
//     u(t) = t^3 (t (6 t - 15) + 10)        (Perlin 2002 fade; u' = 30 t^2 (t - 1)^2)
// n is 0 at every lattice point and roughly within [-1, 1].
//
// Big coordinates: the position is given as an integer lattice cell plus a float
// fraction (cell_noise_split, cell_noise_fractal_split), split on the CPU in
// float64, so the noise 10^6 cells from the origin is as sharp as at it;
// cell_noise / cell_noise_fractal take a float position (|x| up to ~10^4).
//
// Requires: hash.glsl, points.glsl (cell_wrap; included). Macros: CELL_DIM (2..4).
// Only the first CELL_DIM coordinates are used.

#include "hash.glsl"
#include "points.glsl"

// Gradient at lattice corner c: 4 components from two hashes of (c, seed), each
// 2 cell_u16(v) - 1 as one multiply-add (every step exact in float32: the same bits).
vec4 _cell_noise_gradient(ivec4 c, uint seed)
{
    uint h = seed * 0x165667b1u + 0x9e3779b9u + uint(c.x) * 0x8da6b343u + uint(c.y) * 0xd8163841u
           + uint(c.z) * 0xcb1ab31fu + uint(c.w) * 0x27d4eb2fu;
    h = cell_hash_u32(h);
    uint h2 = cell_hash_u32(h ^ 0x68e31da4u);
    vec4 v = vec4(float(int(h >> 16)), float(int(h & 0xffffu)), float(int(h2 >> 16)), float(int(h2 & 0xffffu)));
    return v * (1.0 / 32768.0) + (1.0 / 65536.0 - 1.0);
}

// Gradient noise at lattice position cell + f (f: any float offset, small); grad
// receives dn/dx (components past CELL_DIM are 0). period: lattice corners wrap
// with this period per axis where > 0 (only when CELL_PERIODIC), so the noise
// tiles over `period` lattice cells; keep `cell` wrapped (|cell| << 2^24).
float cell_noise_split(ivec4 cell, vec4 f, ivec4 period, uint seed, out vec4 grad)
{
    cell = cell_dims_i(cell);
    f = cell_dims(f);
    vec4 fl = floor(f);
    ivec4 i0 = cell + ivec4(fl);
    f -= fl;
    vec4 u = f * f * f * (f * (f * 6.0 - 15.0) + 10.0);
    vec4 du = 30.0 * f * f * (f - 1.0) * (f - 1.0);
    float value = 0.0;
    grad = vec4(0.0);
    for (int k = 0; k < (1 << CELL_DIM); k++) {
        ivec4 o = ivec4(k & 1, (k >> 1) & 1, (k >> 2) & 1, (k >> 3) & 1);
        vec4 g = _cell_noise_gradient(cell_wrap(i0 + o, period), seed);
        g = cell_dims(g);
        vec4 d = f - vec4(o);
        float s = dot(g, d);
        vec4 on = vec4(o);
        vec4 wa = mix(1.0 - u, u, on);            // per-axis weights (1 on unused axes)
        vec4 dwa = mix(-du, du, on);              // their derivatives
        float w = wa.x * wa.y * wa.z * wa.w;
        vec4 dw = vec4(dwa.x * wa.y * wa.z * wa.w, wa.x * dwa.y * wa.z * wa.w,
                       wa.x * wa.y * dwa.z * wa.w, wa.x * wa.y * wa.z * dwa.w);
        value += w * s;
        grad += w * g + s * dw;
    }
    return value;
}

// Gradient noise at a float position x (precise for |x| up to ~10^4).
float cell_noise(vec4 x, ivec4 period, uint seed, out vec4 grad)
{
    return cell_noise_split(ivec4(0), x, period, seed, grad);
}

// Fractal sum of cell_noise: sum 0.5^i n(2^i x) / sum 0.5^i over `octaves`
// octaves (seed + i for octave i) at x = cell + f; grad receives its gradient.
// Octave i is at 2^i cell + 2^i f: the integer part stays an integer (wrapping
// like the hash does) and 2^i f is exact in float32, so no octave loses precision.
float cell_noise_fractal_split(ivec4 cell, vec4 f, ivec4 period, uint seed, int octaves, out vec4 grad)
{
    float value = 0.0, amp = 1.0, total = 0.0, scale = 1.0;
    grad = vec4(0.0);
    for (int i = 0; i < octaves; i++) {
        vec4 g;
        value += amp * cell_noise_split(cell * int(scale), f * scale, period * int(scale), seed + uint(i), g);
        grad += amp * scale * g;
        total += amp;
        amp *= 0.5;
        scale *= 2.0;
    }
    grad /= total;
    return value / total;
}

// cell_noise_fractal_split at a float position x (precise for |x| up to ~10^4).
float cell_noise_fractal(vec4 x, ivec4 period, uint seed, int octaves, out vec4 grad)
{
    return cell_noise_fractal_split(ivec4(0), x, period, seed, octaves, grad);
}
