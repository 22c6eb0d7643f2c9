// cellgl: distance metrics.
//
// Distances are accumulated in "internal units" that are monotone in the
// true distance and cheap to compare (Euclidean: squared length; Minkowski:
// sum |x|^p), and converted to true distances only at the end.
//
// CELL_METRIC selects the metric at compile time (values from
// cellgl.basis.enums.Metric: CELL_METRIC_EUCLIDEAN, _MANHATTAN, _CHEBYSHEV, _MINKOWSKI).
//
// Macros: CELL_DIM (2..4), CELL_METRIC; CELL_PRECISE (the entry's prelude, cellgl/gl/glsl.py:
// `precise` where the compiler has it, else empty).
//
// Rounding (docs/exactness.md, "What the driver may round"): every value here decides an
// answer (the order of F1..Fn, the search's bounds, the outputs), so each is CELL_PRECISE: the
// operations happen as written, each rounded once (no fused multiply-add the source does not
// ask for, no reassociation), the same in every entry and walker compiled on one driver.
#ifndef CELL_PRECISE
#define CELL_PRECISE
#endif

// A CELL_DIM-dimensional value in a 4-vector: the components past CELL_DIM set
// to zero.
vec4 cell_dims(vec4 v)
{
#if CELL_DIM == 2
    return vec4(v.xy, 0.0, 0.0);
#elif CELL_DIM == 3
    return vec4(v.xyz, 0.0);
#else
    return v;
#endif
}

ivec4 cell_dims_i(ivec4 v)
{
#if CELL_DIM == 2
    return ivec4(v.xy, 0, 0);
#elif CELL_DIM == 3
    return ivec4(v.xyz, 0);
#else
    return v;
#endif
}

// Internal-unit length of a single axis component x.
float cell_metric_term(float x, float p)
{
    x = abs(x);
#if CELL_METRIC == CELL_METRIC_EUCLIDEAN
    CELL_PRECISE float t = x * x;
#elif CELL_METRIC == CELL_METRIC_MINKOWSKI
    // pow(0, p) is defined (p >= 0.25 > 0: cellgl.basis.core checks it)
    CELL_PRECISE float t = pow(x, p);
#else
    float t = x;
#endif
    return t;
}

// Fold one axis term into an accumulated internal length.
float cell_metric_add(float acc, float term)
{
#if CELL_METRIC == CELL_METRIC_CHEBYSHEV
    return max(acc, term);
#else
    CELL_PRECISE float sum = acc + term;
    return sum;
#endif
}

// Internal units -> true distance.
float cell_metric_finish(float acc, float p)
{
#if CELL_METRIC == CELL_METRIC_EUCLIDEAN
    CELL_PRECISE float F = sqrt(acc);
#elif CELL_METRIC == CELL_METRIC_MINKOWSKI
    CELL_PRECISE float F = pow(acc, 1.0 / p);      // acc >= 0, 1 / p > 0: defined
#else
    float F = acc;
#endif
    return F;
}

// Internal length of a CELL_DIM-dimensional vector (components past
// CELL_DIM are ignored).
float cell_metric_length(vec4 d, float p)
{
    CELL_PRECISE float acc = cell_metric_term(d.x, p);
    acc = cell_metric_add(acc, cell_metric_term(d.y, p));
#if CELL_DIM >= 3
    acc = cell_metric_add(acc, cell_metric_term(d.z, p));
#endif
#if CELL_DIM >= 4
    acc = cell_metric_add(acc, cell_metric_term(d.w, p));
#endif
    return acc;
}

// Gradient of F = |delta| with respect to the sample position, where
// delta = feature - sample and F is the true distance. Moving the sample
// towards the feature point shrinks F, hence the minus signs.
//   Euclidean:  -delta / F
//   Manhattan:  -sign(delta)
//   Chebyshev:  -sign(delta) on the axis of the largest |delta| only
//   Minkowski:  -sign(delta) |delta|^(p-1) / F^(p-1)
//               (0 on an axis where delta is 0: pow(0, y) is undefined for y <= 0, i.e. p <= 1;
//               0 is the limit for p > 1 and the subgradient's middle for p = 1, and for p < 1,
//               where the derivative is unbounded there, the one finite choice)
vec4 cell_metric_gradient(vec4 delta, float F, float p)
{
    delta = cell_dims(delta);
    if (F <= 0.0) {
        return vec4(0.0);
    }
#if CELL_METRIC == CELL_METRIC_EUCLIDEAN
    CELL_PRECISE vec4 g = -delta / F;
    return g;
#elif CELL_METRIC == CELL_METRIC_MANHATTAN
    return -sign(delta);
#elif CELL_METRIC == CELL_METRIC_CHEBYSHEV
    vec4 a = abs(delta);
    int k = 0;
    float best = a.x;
    if (a.y > best) { k = 1; best = a.y; }
    if (a.z > best) { k = 2; best = a.z; }
    if (a.w > best) { k = 3; }
    vec4 g = vec4(0.0);
    g[k] = -sign(delta[k]);
    return g;
#else
    // |delta_a| raised to p - 1 only where it is > 0 (the smallest normal float elsewhere, whose
    // power is finite for p - 1 >= -0.75, and then multiplied by 0): never 0 * inf.
    vec4 a = abs(delta);
    vec4 on = vec4(greaterThan(a, vec4(0.0)));
    CELL_PRECISE vec4 g = -sign(delta) * on * pow(max(a, vec4(1.17549435e-38)), vec4(p - 1.0)) / pow(F, p - 1.0);
    return g;
#endif
}
