// A reference-style integrator (SA_INTEGRATOR_GAUSS_PANELS), for comparisons and tests, not for
// speed: the same Green's theorem walk as the default (green.glsl), but every edge integral
// ∫ D(s) V(s) ds is numeric, the sharp Q1 lobe included: 8-point Gauss-Legendre on panels
// graded geometrically towards the lobe centre s0. In y = s - s0 the panel boundaries are
//   0, ±g, ±2g, ±4g, ..., ±2^(GP_PANELS-2) g, then one last panel out to the interval's end,
// with g the lobe's half-width (Q1 = A (y^2 + g^2), patch_ndf.glsl).
//
// Error. The lobe's poles y = ±i g lie outside the Bernstein ellipses of parameter 5.8 of every
// panel [a, 2a] (a >= g) and 4.6 of [0, g], so the rule's error on the lobe is ~4.6^-16 (1e-11).
// g >= alpha / 2, and |y| <= 2 on the chi+ range, so for alpha >= 1e-3 the graded panels reach
// the ends of every interval (2^14 g > 2). What remains is float32: D is evaluated pointwise from
// s (ndf_at), and next to the peak of a sharp lobe the rounding of s moves |n x h| by a relative
// ~ulp(s) / g (2e-4 for alpha = 1e-3), which the closed form avoids by working in y. The measured
// error against the float64 reference is in tests/integrators.rs. Cost: up to 2 x GP_PANELS x 8
// evaluations of D per boundary piece, tens of times the closed form's.
#ifndef SA_INTEGRATOR_GAUSS_PANELS_GLSL
#define SA_INTEGRATOR_GAUSS_PANELS_GLSL

#define GP_PANELS 16   // panels on each side of s0

// ∫_a^b D(s) (V0 + k (s - s_ref)) ds with 8-point Gauss-Legendre.
R gauss8(PairGeom G, R a, R b, R V0, R k, R s_ref) {
    const float X[4] = float[](0.1834346424956498, 0.5255324099163290, 0.7966664774136267, 0.9602898564975363);
    const float W[4] = float[](0.3626837833783620, 0.3137066458778873, 0.2223810344533745, 0.1012285362903763);
    R mid = mul(0.5, add(a, b)), hw = mul(0.5, sub(b, a));
    R sum = rc(0.0);
    for (int i = 0; i < 4; ++i) {
        R sl = sub(mid, mul(hw, X[i])), sh = add(mid, mul(hw, X[i]));
        R fl = mul(ndf_at(G, sl), add(V0, mul(k, sub(sl, s_ref))));
        R fh = mul(ndf_at(G, sh), add(V0, mul(k, sub(sh, s_ref))));
        sum = add(sum, mul(W[i], add(fl, fh)));
    }
    return mul(sum, hw);
}

R edge_integral(PairGeom G, R lo, R hi, R Vlo, R Vhi) {
    R k = dv(sub(Vhi, Vlo), sub(hi, lo));
    R sum = rc(0.0);
    // Right of s0 (side 0), then left of it (side 1); panel j spans g m_j .. g m_(j+1) from s0,
    // m_0 = 0, m_j = 2^(j-1); the last one ends 4 away (|y| <= 2 covers every interval).
    for (int side = 0; side < 2; ++side) {
        float sgn = side == 0 ? 1.0 : -1.0;
        for (int j = 0; j < GP_PANELS; ++j) {
            R near = j == 0 ? G.s0 : add(G.s0, mul(G.g, sgn * exp2(float(j - 1))));
            R far = j == GP_PANELS - 1 ? add(G.s0, rc(4.0 * sgn)) : add(G.s0, mul(G.g, sgn * exp2(float(j))));
            R pa = side == 0 ? near : far, pb = side == 0 ? far : near;
            if (side == 0 ? val(pa) >= val(hi) : val(pb) <= val(lo)) break;
            R a = d_max(pa, lo), b = d_min(pb, hi);
            if (val(a) >= val(b)) continue;
            sum = add(sum, gauss8(G, a, b, Vlo, k, lo));
        }
    }
    return sum;
}

#include "green.glsl"

#endif
