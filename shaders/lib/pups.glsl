// cellgl: partition-of-unity parametrics (PUPs) texture synthesis.
//
// After "PUPs texture synthesis": scattered control points carry a value, a
// label and an orientation; a Delaunay graph gives each point its axes (the
// edges to its neighbours). At a position u the weight of control point c is
//
//     W_c(u) = prod_r A(p_r),    A(p) = (1 - p)^2 (1 + 2p)             (1, 2)
//
// where p_r is the projection of (u - c) onto axis r as a fraction of the axis
// length (times the axis-length factor), clamped to [0, 1]. Points behind an
// axis project to 0 (A = 1); points beyond its end project to 1 (A = 0), so
// the support of c is the convex polygon cut out by its axes.
//
// An orientation v (the xy part of a unit vector in R^3) shifts the weight:
// eta = (u - c).v / |u - c|, K = epsilon * eta and
//
//     w' = w^(1 - K)          if K >= 0                                 (4)
//     w' = w^(1 / (1 + K))    otherwise
//
// The texture is sum(T_c W_c) / sum(W_c) (3); a label texture takes the label
// of the heaviest point (the first in candidate order on an exact tie).
//
// NumPy twin: cellgl/pups/reference.py (same function names, float64).
//
// Axes are passed pre-scaled: axis_scaled = axis / (factor * |axis|^2), so the
// normalised projection is a single dot product.
//
// Optional: define CELL_PUPS_FETCH before including this file to get
// cell_pups_eval(), which walks a candidate list. The including shader must
// then define the three fetch functions declared below (they read its
// buffers); this file itself declares no buffers, uniforms or bindings.
//
// CELL_PRECISE (`precise` where the compiler has it, cellgl/gl/glsl.py; docs/exactness.md) on the
// weights and sums: rounded as written, the same in the compute and the fragment entries.
#ifndef CELL_PRECISE
#define CELL_PRECISE
#endif

// Axial weight (1): the cubic Hermite falloff from 1 at p = 0 to 0 at p = 1,
// with zero slope at both ends. p is clamped to [0, 1].
float cell_pups_axial(float p)
{
    p = clamp(p, 0.0, 1.0);
    float q = 1.0 - p;
    CELL_PRECISE float a = q * q * (1.0 + 2.0 * p);
    return a;
}

// Normalised projection of d = u - c on a pre-scaled axis, clamped to [0, 1].
float cell_pups_project(vec2 d, vec2 axis_scaled)
{
    CELL_PRECISE float p = d.x * axis_scaled.x + d.y * axis_scaled.y;
    return clamp(p, 0.0, 1.0);
}

// One factor of the product (2). Returns false once the weight is zero
// (u lies beyond the end of this axis), so the caller can stop early.
bool cell_pups_axis_step(inout float w, vec2 d, vec2 axis_scaled)
{
    CELL_PRECISE float p = d.x * axis_scaled.x + d.y * axis_scaled.y;
    if (p >= 1.0) {
        w = 0.0;
        return false;
    }
    if (p > 0.0) {
        float q = 1.0 - p;
        CELL_PRECISE float a = q * q * (1.0 + 2.0 * p);
        w *= a;
    }
    return true;
}

// Orientation shift (4). v is the xy part of the orientation (|v| <= 1);
// eta = 0 at u = c (where w = 1 anyway). epsilon in [0, 1).
float cell_pups_orient(float w, vec2 d, vec2 v, float epsilon)
{
    CELL_PRECISE float len = sqrt(d.x * d.x + d.y * d.y);
    CELL_PRECISE float eta = len > 0.0 ? (d.x * v.x + d.y * v.y) / len : 0.0;
    CELL_PRECISE float k = epsilon * eta;
    CELL_PRECISE float e = k >= 0.0 ? 1.0 - k : 1.0 / (1.0 + k);      // 1 + k > 0: epsilon < 1
    CELL_PRECISE float o = w > 0.0 ? pow(w, e) : 0.0;                  // pow(0, e) avoided
    return o;
}

// Running sums over the candidate points of one pixel.
struct CellPupsAcc {
    vec4 sum;     // sum of value * weight
    float wsum;   // sum of weights
    float wmax;   // largest weight so far
    int label;    // label of the heaviest point (-1: none)
    vec4 best;    // value of the heaviest point
};

CellPupsAcc cell_pups_acc_init()
{
    return CellPupsAcc(vec4(0.0), 0.0, 0.0, -1, vec4(0.0));
}

void cell_pups_acc_add(inout CellPupsAcc acc, float w, vec4 value, int label)
{
    CELL_PRECISE vec4 sum = acc.sum + w * value;
    CELL_PRECISE float wsum = acc.wsum + w;
    acc.sum = sum;
    acc.wsum = wsum;
    if (w > acc.wmax) {
        acc.wmax = w;
        acc.label = label;
        acc.best = value;
    }
}

// Interpolated value (3); 0 where no point has weight (outside every support).
vec4 cell_pups_acc_value(CellPupsAcc acc)
{
    CELL_PRECISE vec4 v = acc.wsum > 0.0 ? acc.sum / acc.wsum : vec4(0.0);
    return v;
}

#ifdef CELL_PUPS_FETCH
// Provided by the including shader (it owns the buffer): cell_pups_fetch(k) returns
// record k of the candidate stream (cellgl.pups._cell_stream). A grid cell is described by
// cell = (first record, candidates, axis pairs per candidate, 0); each candidate takes
// 2 + pairs records:
//   (pos.x, pos.y, orient.x, orient.y) as float bits,
//   (value.r, value.g, value.b) as float bits, label,
//   pairs x (axis.x, axis.y, axis'.x, axis'.y): the pre-scaled axes that can project above
//   0 in the cell (the others give exactly 1 there), zero-padded (factor 1).
uvec4 cell_pups_fetch(uint k);

// Weight and accumulate every candidate of a grid cell at position u.
//
// Written for SIMD lanes that share the cell (a work group inside one grid cell): the loop
// bounds come from the cell alone and there is no early exit and no branch on the weight,
// so the loops are uniform and every load has a uniform address. The result is the same
// as stopping at the first zero factor: a factor of 0 keeps the product at 0, a factor of
// 1 (padding, p <= 0) changes nothing, and a zero weight adds exactly nothing.
CellPupsAcc cell_pups_eval(vec2 u, uvec4 cell, float epsilon)
{
    CellPupsAcc acc = cell_pups_acc_init();
    uint per = 2u + cell.z;
    uint end = cell.x + cell.y * per;
    for (uint k = cell.x; k < end; k += per) {
        uvec4 head = cell_pups_fetch(k);
        uvec4 attr = cell_pups_fetch(k + 1u);
        CELL_PRECISE vec2 d = u - uintBitsToFloat(head.xy);
        CELL_PRECISE float w = 1.0;
        for (uint j = k + 2u; j < k + per; ++j) {
            vec4 a = uintBitsToFloat(cell_pups_fetch(j));
            CELL_PRECISE float p0 = d.x * a.x + d.y * a.y;
            CELL_PRECISE float p1 = d.x * a.z + d.y * a.w;
            w *= cell_pups_axial(p0);
            w *= cell_pups_axial(p1);
        }
        cell_pups_acc_add(acc, cell_pups_orient(w, d, uintBitsToFloat(head.zw), epsilon),
                          vec4(uintBitsToFloat(attr.xyz), 0.0), int(attr.w));
    }
    return acc;
}
#endif
