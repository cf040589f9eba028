// Scalar type R for code shared by the forward and backward kernels: `float` by default, or a
// forward-mode dual number (value + 7 partial derivatives) when SA_DUAL is defined.
//
// GLSL has no operator overloading, so shared code is written with add/sub/mul/dv/neg and the
// d_* functions; the float versions are trivial and inlined by every driver, so the forward
// kernel pays nothing for sharing its source with the backward one.
// Dual partials are ordered like a scratch row: x0, y0, x1, y1, w, d, alpha.
#ifndef SA_REAL_GLSL
#define SA_REAL_GLSL

float add(float a, float b) { return a + b; }
float sub(float a, float b) { return a - b; }
float mul(float a, float b) { return a * b; }
float dv(float a, float b) { return a / b; }
float neg(float a) { return -a; }
float val(float a) { return a; }
float d_sqrt(float a) { return sqrt(a); }
float d_atan(float a) { return atan(a); }
float d_log(float a) { return log(a); }
float d_exp(float a) { return exp(a); }
float d_min(float a, float b) { return min(a, b); }
float d_max(float a, float b) { return max(a, b); }
float d_abs(float a) { return abs(a); }
float fma3(float a, float b, float c) { return a * b + c; }
// a . b of 2-vectors given by components. The float version is GLSL's dot (the forward kernel's
// arithmetic), the dual one the sum of two products.
float dot2(float ax, float ay, float bx, float by) { return dot(vec2(ax, ay), vec2(bx, by)); }

#ifdef SA_DUAL
// With SA_ARCS an 8th partial: d/d(kappa), an arc chord's curvature (inc/patch_ndf.glsl).
#ifdef SA_ARCS
#define SA_G1 vec4
#else
#define SA_G1 vec3
#endif
struct Dual {
    float v;   // value
    vec4 g0;   // d/d(x0, y0, x1, y1)
    SA_G1 g1;  // d/d(w, d, alpha[, kappa])
};
#define R Dual
Dual rc(float a) { return Dual(a, vec4(0.0), SA_G1(0.0)); }
Dual seed(float a, int k) {
    Dual r = rc(a);
    if (k < 4) r.g0[k] = 1.0; else r.g1[k - 4] = 1.0;
    return r;
}
float val(Dual a) { return a.v; }
Dual add(Dual a, Dual b) { return Dual(a.v + b.v, a.g0 + b.g0, a.g1 + b.g1); }
Dual add(Dual a, float b) { return Dual(a.v + b, a.g0, a.g1); }
Dual add(float a, Dual b) { return Dual(a + b.v, b.g0, b.g1); }
Dual sub(Dual a, Dual b) { return Dual(a.v - b.v, a.g0 - b.g0, a.g1 - b.g1); }
Dual sub(Dual a, float b) { return Dual(a.v - b, a.g0, a.g1); }
Dual sub(float a, Dual b) { return Dual(a - b.v, -b.g0, -b.g1); }
Dual mul(Dual a, Dual b) { return Dual(a.v * b.v, a.g0 * b.v + b.g0 * a.v, a.g1 * b.v + b.g1 * a.v); }
Dual mul(Dual a, float b) { return Dual(a.v * b, a.g0 * b, a.g1 * b); }
Dual mul(float a, Dual b) { return Dual(a * b.v, a * b.g0, a * b.g1); }
Dual dv(Dual a, Dual b) {
    float q = a.v / b.v, ib = 1.0 / b.v;
    return Dual(q, (a.g0 - q * b.g0) * ib, (a.g1 - q * b.g1) * ib);
}
Dual dv(Dual a, float b) { float ib = 1.0 / b; return Dual(a.v * ib, a.g0 * ib, a.g1 * ib); }
Dual dv(float a, Dual b) {
    float q = a / b.v, s = -q / b.v;
    return Dual(q, s * b.g0, s * b.g1);
}
Dual neg(Dual a) { return Dual(-a.v, -a.g0, -a.g1); }
Dual chain(Dual a, float f, float df) { return Dual(f, a.g0 * df, a.g1 * df); }
Dual d_sqrt(Dual a) { float r = sqrt(a.v); return chain(a, r, r > 0.0 ? 0.5 / r : 0.0); }
Dual d_atan(Dual a) { return chain(a, atan(a.v), 1.0 / (1.0 + a.v * a.v)); }
Dual d_log(Dual a) { return chain(a, log(a.v), 1.0 / a.v); }
Dual d_exp(Dual a) { float e = exp(a.v); return chain(a, e, e); }
Dual d_min(Dual a, Dual b) { return a.v <= b.v ? a : b; }
Dual d_min(Dual a, float b) { return a.v <= b ? a : rc(b); }
Dual d_min(float a, Dual b) { return a <= b.v ? rc(a) : b; }
Dual d_max(Dual a, Dual b) { return a.v >= b.v ? a : b; }
Dual d_max(Dual a, float b) { return a.v >= b ? a : rc(b); }
Dual d_max(float a, Dual b) { return a >= b.v ? rc(a) : b; }
Dual d_abs(Dual a) { return a.v < 0.0 ? neg(a) : a; }
Dual fma3(Dual a, Dual b, Dual c) { return add(mul(a, b), c); }
Dual fma3(Dual a, float b, Dual c) { return add(mul(a, b), c); }
Dual fma3(float a, Dual b, Dual c) { return add(mul(a, b), c); }
Dual dot2(Dual ax, Dual ay, Dual bx, Dual by) { return add(mul(ax, bx), mul(ay, by)); }
Dual dot2(float ax, float ay, Dual bx, Dual by) { return add(mul(ax, bx), mul(ay, by)); }
#else
#define R float
float rc(float a) { return a; }
#endif

#endif
