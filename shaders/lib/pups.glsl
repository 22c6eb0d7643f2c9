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
// NumPy twin: cellgl/pups_reference.py (same function names, float64).
//
// Axes are passed pre-scaled: axis_scaled = axis / (factor * |axis|^2), so the
// normalised projection is a single dot product.
//
// Optional: define CELL_PUPS_FETCH before including this file to get
// cell_pups_eval(), which walks a candidate list. The including shader must
// then define the three fetch functions declared below (they read its
// buffers); this file itself declares no buffers, uniforms or bindings.

// Axial weight (1): the cubic Hermite falloff from 1 at p = 0 to 0 at p = 1,
// with zero slope at both ends. p is clamped to [0, 1].
float cell_pups_axial(float p)
{
    p = clamp(p, 0.0, 1.0);
    float q = 1.0 - p;
    return q * q * (1.0 + 2.0 * p);
}

// Normalised projection of d = u - c on a pre-scaled axis, clamped to [0, 1].
float cell_pups_project(vec2 d, vec2 axis_scaled)
{
    return clamp(dot(d, axis_scaled), 0.0, 1.0);
}

// One factor of the product (2). Returns false once the weight is zero
// (u lies beyond the end of this axis), so the caller can stop early.
bool cell_pups_axis_step(inout float w, vec2 d, vec2 axis_scaled)
{
    float p = dot(d, axis_scaled);
    if (p >= 1.0) {
        w = 0.0;
        return false;
    }
    if (p > 0.0) {
        float q = 1.0 - p;
        w *= q * q * (1.0 + 2.0 * p);
    }
    return true;
}

// Orientation shift (4). v is the xy part of the orientation (|v| <= 1);
// eta = 0 at u = c (where w = 1 anyway). epsilon in [0, 1).
float cell_pups_orient(float w, vec2 d, vec2 v, float epsilon)
{
    float len = length(d);
    float eta = len > 0.0 ? dot(d, v) / len : 0.0;
    float k = epsilon * eta;
    float e = k >= 0.0 ? 1.0 - k : 1.0 / (1.0 + k);
    return w > 0.0 ? pow(w, e) : 0.0;
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
    acc.sum += w * value;
    acc.wsum += w;
    if (w > acc.wmax) {
        acc.wmax = w;
        acc.label = label;
        acc.best = value;
    }
}

// Interpolated value (3); 0 where no point has weight (outside every support).
vec4 cell_pups_acc_value(CellPupsAcc acc)
{
    return acc.wsum > 0.0 ? acc.sum / acc.wsum : vec4(0.0);
}

#ifdef CELL_PUPS_FETCH
// Provided by the including shader (it owns the buffers):
//   cell_pups_fetch_candidate(k): (point index, axis mask, floatBitsToUint(pos.x),
//       floatBitsToUint(pos.y)) of candidate k. Bit r of the mask is set when axis r may
//       project above 0 somewhere in the grid cell (the others give exactly 1 there).
//   cell_pups_fetch_axis(a): pre-scaled axis a; point i owns axes [i * stride, i * stride +
//       stride), padded with zero axes (factor 1).
//   cell_pups_fetch_attributes(i, ...): orientation, label, value of point i.
uvec4 cell_pups_fetch_candidate(uint k);
vec2 cell_pups_fetch_axis(uint a);
void cell_pups_fetch_attributes(uint i, out vec2 orient, out int label, out vec4 value);

// Weight and accumulate every candidate k in [begin, end) at position u. With more than
// 32 axes per point (stride > 32) the masks cannot hold them and every axis is visited.
CellPupsAcc cell_pups_eval(vec2 u, uint begin, uint end, uint stride, float epsilon)
{
    CellPupsAcc acc = cell_pups_acc_init();
    for (uint k = begin; k < end; ++k) {
        uvec4 cand = cell_pups_fetch_candidate(k);
        vec2 d = u - uintBitsToFloat(cand.zw);
        uint a0 = cand.x * stride;
        float w = 1.0;
        if (stride > 32u) {
            for (uint a = a0; a < a0 + stride; ++a) {
                if (!cell_pups_axis_step(w, d, cell_pups_fetch_axis(a))) {
                    break;
                }
            }
        } else {
            uint mask = cand.y;
            while (mask != 0u) {
                int r = findLSB(mask);
                mask &= mask - 1u;
                if (!cell_pups_axis_step(w, d, cell_pups_fetch_axis(a0 + uint(r)))) {
                    break;
                }
            }
        }
        if (w > 0.0) {
            // attributes only for the few candidates that carry weight here
            vec2 orient;
            int label;
            vec4 value;
            cell_pups_fetch_attributes(cand.x, orient, label, value);
            cell_pups_acc_add(acc, cell_pups_orient(w, d, orient, epsilon), value, label);
        }
    }
    return acc;
}
#endif
