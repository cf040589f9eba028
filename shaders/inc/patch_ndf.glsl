// The per-(pixel, scratch) patch integral of MODEL.md section 5:
//   I = integral over F ∩ R of D(n(u) . h; alpha) dA,   A = area(F ∩ R).
//
// Method. In the scratch frame (u across, v along) the integrand depends on u only. With
// s = 2u/w the normal is n = ((1 - s^2) z - 2 s b) / (1 + s^2), so c = n . h = N(s) / P(s) with
// P = 1 + s^2, N = hz (1 - s^2) - 2 hb s. Writing x = beta c (beta = sqrt(1 - alpha^2)),
//   D = alpha^2 / (pi (1 - x^2)^2) = alpha^2 / (4 pi) [1/(1-x)^2 + 1/(1-x) + 1/(1+x)^2 + 1/(1+x)],
// and 1/(1-x) = P / Q1, 1/(1+x) = P / Q2 with the positive-definite quadratics
//   Q1 = (1 + beta hz) s^2 + 2 beta hb s + (1 - beta hz),  Q2 = (1 - beta hz) s^2 - 2 beta hb s + (1 + beta hz).
// Q1 carries the sharp GGX lobe: Q1 = A ((s - s0)^2 + g^2) with A = 1 + beta hz, s0 = -beta hb / A,
// g^2 = (alpha^2 + ht^2 (1 - alpha^2)) / A^2 (no cancellation: 1 - beta^2 rho^2 expanded).
// On the chi+ range (c > 0) 1/(1+x) lies in [1/2, 1] and is smooth.
//
// Green's theorem on the clipped polygon (CCW in (s, v)):  ∬ D ds dv = -Σ_edges ∫_edge D(s) v(s) ds,
// v linear along each edge; vertical edges contribute nothing. Each edge integral is clipped to the
// chi+ range (D jumps to 0 where c = 0, MODEL.md section 9) and evaluated as
//   * the Q1 part in closed form in y = s - s0 (atan / log / rational terms, with a series for the
//     far tail of the 1/(y^2+g^2)^2 term where atan and the rational part cancel), and
//   * the Q2 part with 5-point Gauss-Legendre (worst-case relative error 2.2e-5 of that part, found
//     by a sweep over alpha in [1e-3, 0.95], h up to 89 degrees from z, full-width intervals);
//   * intervals short against their distance to the lobe (dy < lam / 4, lam = max(g, |y|)) use
//     3-point Gauss on the whole D instead: the closed form's differences cancel there, and the
//     nearest pole is >= 3.5 half-lengths away, so the rule is accurate to ~(1/7)^6 = 8e-6.
#ifndef SA_PATCH_NDF_GLSL
#define SA_PATCH_NDF_GLSL

#include "common.glsl"

// Per-pair constants of the integrand (depend on h in the scratch frame and on alpha).
struct PairGeom {
    float alpha, beta, hb, ht, hz;
    float s0, g, g2;              // Q1 = A ((s - s0)^2 + g^2)
    float c0, c1, c2, c3, c4;     // P/Q1 + (P/Q1)^2 = c0 + (c1 y + c2)/(y^2+g^2) + (c3 y + c4)/(y^2+g^2)^2
    float chi_lo, chi_hi;         // c > 0 exactly on (chi_lo, chi_hi)
};

PairGeom pair_geom(float hb, float ht, float hz, float alpha) {
    PairGeom G;
    G.alpha = alpha; G.hb = hb; G.ht = ht; G.hz = hz;
    G.beta = sqrt(max(1.0 - alpha * alpha, 0.0));
    float A = 1.0 + G.beta * hz;
    float iA = 1.0 / A, iA2 = iA * iA;
    G.s0 = -G.beta * hb * iA;
    G.g2 = (alpha * alpha + ht * ht * (1.0 - alpha * alpha)) * iA2;
    G.g = sqrt(G.g2);
    float q = 1.0 + G.s0 * G.s0 - G.g2;
    float r = q * q - 4.0 * G.s0 * G.s0 * G.g2;
    G.c0 = iA + iA2;
    G.c1 = 2.0 * G.s0 * iA + 4.0 * G.s0 * iA2;
    G.c2 = q * iA + (2.0 * q + 4.0 * G.s0 * G.s0) * iA2;
    G.c3 = 4.0 * G.s0 * q * iA2;
    G.c4 = r * iA2;
    // Roots of N(s): s+ s- = -1; pick the cancellation-free form for the root near 0.
    float rho = sqrt(hb * hb + hz * hz);
    float sp = (hb >= 0.0) ? hz / (rho + hb) : (rho - hb) / hz;
    G.chi_hi = sp;
    G.chi_lo = -1.0 / sp;
    return G;
}

// D(n(s) . h; alpha) with |n x h|^2 = ht^2 + m^2 computed directly (MODEL.md section 9).
float ndf_at(PairGeom G, float s) {
    float P = 1.0 + s * s;
    float c = (G.hz * (1.0 - s * s) - 2.0 * s * G.hb) / P;
    float m = (2.0 * s * G.hz + (1.0 - s * s) * G.hb) / P;
    float a2 = G.alpha * G.alpha;
    float den = a2 * c * c + G.ht * G.ht + m * m;
    return a2 / (PI * den * den);
}

// Far-tail form of F(x) = atan(x) + x/(1+x^2) for x >= 4: F = pi/2 - T(x), T = atan(1/x) - x/(1+x^2).
float tail_T(float x) {
    float z = 1.0 / (x * x);
    return (z / x) * (2.0 / 3.0 - z * (4.0 / 5.0 - z * (6.0 / 7.0 - z * (8.0 / 9.0 - z * (10.0 / 11.0 - z * (12.0 / 13.0))))));
}

// ∫_lo^hi D(s) V(s) ds with V linear, V(lo) = Vlo, V(hi) = Vhi, chi_lo <= lo < hi <= chi_hi.
float lin_integral(PairGeom G, float lo, float hi, float Vlo, float Vhi) {
    float dy = hi - lo;
    float yl = lo - G.s0, yh = hi - G.s0;
    float mid = 0.5 * (lo + hi), hw = 0.5 * dy;
    float Vm = 0.5 * (Vlo + Vhi), dV = 0.5 * (Vhi - Vlo);
    float lam = max(G.g, max(abs(yl), abs(yh)));
    if (dy < 0.25 * lam) {
        const float X3 = 0.7745966692414834;
        float r = (8.0 / 9.0) * ndf_at(G, mid) * Vm
                + (5.0 / 9.0) * (ndf_at(G, mid - X3 * hw) * (Vm - X3 * dV) + ndf_at(G, mid + X3 * hw) * (Vm + X3 * dV));
        return r * hw;
    }
    // Q1 part, closed form.
    float g = G.g, g2 = G.g2;
    float xl = yl / g, xh = yh / g;
    float datan = (xl * xh > 0.0) ? atan((xh - xl) / (1.0 + xl * xh)) : (atan(xh) - atan(xl));
    float ql = yl * yl + g2, qh = yh * yh + g2;
    float B0 = dy, B1 = hw * (yh + yl);
    float K0 = datan / g;
    float K1 = 0.5 * log(qh / ql);
    float K2 = B0 - g2 * K0;
    float dF;
    if (xl >= 4.0) dF = tail_T(xl) - tail_T(xh);
    else if (xh <= -4.0) dF = tail_T(-xh) - tail_T(-xl);
    else dF = datan + (xh - xl) * (1.0 - xl * xh) / ((1.0 + xl * xl) * (1.0 + xh * xh));
    float M0 = dF / (2.0 * g * g2);
    float M1 = hw * (yh + yl) / (ql * qh);
    float M2 = K0 - g2 * M0;
    float S  = G.c0 * B0 + G.c1 * K1 + G.c2 * K0 + G.c3 * M1 + G.c4 * M0;
    float YS = G.c0 * B1 + G.c1 * K2 + G.c2 * K1 + G.c3 * M2 + G.c4 * M1;
    float J1 = Vlo * S + ((Vhi - Vlo) / dy) * (YS - yl * S);
    // Q2 part: 5-point Gauss-Legendre of 1/(1+x) + 1/(1+x)^2 (smooth on the chi+ range).
    const float GX[5] = float[](-0.9061798459386640, -0.5384693101056831, 0.0, 0.5384693101056831, 0.9061798459386640);
    const float GW[5] = float[](0.2369268850561891, 0.4786286704993665, 0.5688888888888889, 0.4786286704993665, 0.2369268850561891);
    float J2 = 0.0;
    for (int k = 0; k < 5; ++k) {
        float s = mid + hw * GX[k];
        float P = 1.0 + s * s;
        float c = (G.hz * (1.0 - s * s) - 2.0 * s * G.hb) / P;
        float t = 1.0 / (1.0 + G.beta * c);
        J2 += GW[k] * (t + t * t) * (Vm + GX[k] * dV);
    }
    J2 *= hw;
    return G.alpha * G.alpha * (0.25 / PI) * (J1 + J2);
}

// Keeps the part of polygon p (n vertices, (s, v)) where sgn * (p[axis] - bound) <= 0.
void clip_half(inout vec2 p[8], inout int n, int axis, float bound, float sgn) {
    vec2 o[8];
    int m = 0;
    for (int i = 0; i < n; ++i) {
        vec2 a = p[i];
        vec2 b = p[(i + 1 == n) ? 0 : i + 1];
        float da = sgn * (a[axis] - bound), db = sgn * (b[axis] - bound);
        if (da <= 0.0 && m < 8) o[m++] = a;
        if (((da < 0.0 && db > 0.0) || (da > 0.0 && db < 0.0)) && m < 8) {
            vec2 x = a + (da / (da - db)) * (b - a);
            x[axis] = bound;  // exactly on the clip line, so the edge along it is exactly vertical/horizontal
            o[m++] = x;
        }
    }
    n = m;
    for (int i = 0; i < 8; ++i) p[i] = o[i];
}

// Footprint corners fp[4] in scratch-local (s, v) coordinates (s = 2u/w). Carved region:
// |s| <= se, 0 <= v <= len. Returns I (∫ D dA) and A (area), both in mm^2 (times half_w = w/2).
void patch_integral(vec2 fp[4], float se, float len, float half_w, PairGeom G, out float I, out float A) {
    vec2 p[8];
    for (int i = 0; i < 4; ++i) p[i] = fp[i];
    for (int i = 4; i < 8; ++i) p[i] = vec2(0.0);
    int n = 4;
    clip_half(p, n, 0, se, 1.0);
    clip_half(p, n, 0, -se, -1.0);
    clip_half(p, n, 1, len, 1.0);
    clip_half(p, n, 1, 0.0, -1.0);
    I = 0.0; A = 0.0;
    if (n < 3) return;
    // Shoelace (signed) and a reference v so that v values stay small (the constant drops out).
    float vref = p[0].y;
    float area2 = 0.0;
    for (int i = 0; i < n; ++i) {
        vec2 a = p[i], b = p[(i + 1 == n) ? 0 : i + 1];
        area2 += (a.x - b.x) * (a.y + b.y - 2.0 * vref);
    }
    // area2 = 2 * signed area (CCW positive) in (s, v)
    if (area2 == 0.0) return;
    float sum = 0.0;
    for (int i = 0; i < n; ++i) {
        vec2 a = p[i], b = p[(i + 1 == n) ? 0 : i + 1];
        if (a.x == b.x) continue;
        float lo = min(a.x, b.x), hi = max(a.x, b.x);
        float clo = max(lo, G.chi_lo), chi = min(hi, G.chi_hi);
        if (clo >= chi) continue;
        // v(s) on the edge, relative to vref
        float k = (b.y - a.y) / (b.x - a.x);
        float vlo = (a.y - vref) + k * (clo - a.x);
        float vhi = (a.y - vref) + k * (chi - a.x);
        float J = lin_integral(G, clo, chi, vlo, vhi);
        sum += (b.x > a.x) ? -J : J;
    }
    float orient = area2 > 0.0 ? 1.0 : -1.0;
    I = orient * sum * half_w;
    A = 0.5 * abs(area2) * half_w;
}

#endif
