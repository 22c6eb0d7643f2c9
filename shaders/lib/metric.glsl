// cellgl: distance metrics.
//
// Distances are accumulated in "internal units" that are monotone in the
// true distance and cheap to compare (Euclidean: squared length; Minkowski:
// sum |x|^p), and converted to true distances only at the end.
//
// CELL_METRIC selects the metric at compile time (values from
// cellgl.basis.enums.Metric: CELL_METRIC_EUCLIDEAN, _MANHATTAN, _CHEBYSHEV, _MINKOWSKI).
//
// Macros: CELL_DIM (2..4), CELL_METRIC.

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
    return x * x;
#elif CELL_METRIC == CELL_METRIC_MINKOWSKI
    return pow(x, p);
#else
    return x;
#endif
}

// Fold one axis term into an accumulated internal length.
float cell_metric_add(float acc, float term)
{
#if CELL_METRIC == CELL_METRIC_CHEBYSHEV
    return max(acc, term);
#else
    return acc + term;
#endif
}

// Internal units -> true distance.
float cell_metric_finish(float acc, float p)
{
#if CELL_METRIC == CELL_METRIC_EUCLIDEAN
    return sqrt(acc);
#elif CELL_METRIC == CELL_METRIC_MINKOWSKI
    return pow(acc, 1.0 / p);
#else
    return acc;
#endif
}

// Internal length of a CELL_DIM-dimensional vector (components past
// CELL_DIM are ignored).
float cell_metric_length(vec4 d, float p)
{
    float acc = cell_metric_term(d.x, p);
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
vec4 cell_metric_gradient(vec4 delta, float F, float p)
{
    delta = cell_dims(delta);
    if (F <= 0.0) {
        return vec4(0.0);
    }
#if CELL_METRIC == CELL_METRIC_EUCLIDEAN
    return -delta / F;
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
    return -sign(delta) * pow(abs(delta), vec4(p - 1.0)) / pow(F, p - 1.0);
#endif
}
