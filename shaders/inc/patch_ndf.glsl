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

// Green's theorem over the boundary of F ∩ R without building the clipped polygon:
// ∂(F ∩ R) = (∂F inside R) ∪ (∂R inside F). Every footprint edge is clipped to R (Liang-Barsky)
// and R's two across-edges (v = 0 and v = len) are clipped to F (Cyrus-Beck); R's long edges
// (s = ±se) are vertical and contribute nothing. Both are walked counter-clockwise in (s, v).
// Each piece adds  -∫ D(s) (v(s) - vref) ds  to I and  -∫ (v - vref) ds  to the area;
// vref (the footprint centre's v) keeps the v values small, and drops out of the closed sum.
void add_segment(PairGeom G, vec2 a, vec2 b, float vref, inout float I, inout float A) {
    if (a.x == b.x) return;
    float lo = min(a.x, b.x), hi = max(a.x, b.x);
    float k = (b.y - a.y) / (b.x - a.x);
    // area: exact trapezoid of the whole segment
    float dA = 0.5 * (b.x - a.x) * (a.y + b.y - 2.0 * vref);
    A -= dA;
    float clo = max(lo, G.chi_lo), chi = min(hi, G.chi_hi);
    if (clo >= chi) return;
    float vlo = (a.y - vref) + k * (clo - a.x);
    float vhi = (a.y - vref) + k * (chi - a.x);
    float J = lin_integral(G, clo, chi, vlo, vhi);
    I += (b.x > a.x) ? -J : J;
}

// Footprint corners fp[4] in scratch-local (s, v) coordinates (s = 2u/w), ordered
// counter-clockwise in (s, v). Carved region: |s| <= se, 0 <= v <= len.
// Returns I = ∫ D dA and A = area over F ∩ R, in mm^2 (half_w = w/2 converts ds to du).
void patch_integral(vec2 fp[4], float se, float len, float half_w, PairGeom G, out float I, out float A) {
    I = 0.0; A = 0.0;
    float vref = clamp(0.25 * (fp[0].y + fp[1].y + fp[2].y + fp[3].y), 0.0, len);
    // Footprint edges clipped to the box [-se, se] x [0, len].
    for (int e = 0; e < 4; ++e) {
        vec2 a = fp[e], d = fp[(e + 1) & 3] - fp[e];
        float t0 = 0.0, t1 = 1.0;
        // s >= -se, s <= se, v >= 0, v <= len as p_i t <= q_i
        float ps[4] = float[](-d.x, d.x, -d.y, d.y);
        float qs[4] = float[](a.x + se, se - a.x, a.y, len - a.y);
        bool keep = true;
        for (int i = 0; i < 4; ++i) {
            float p = ps[i], q = qs[i];
            // An edge lying on R's across-edge line (v = 0 or v = len) is left to R's own edge
            // below, which counts a shared piece once (on s = ±se it contributes nothing anyway).
            if (p == 0.0) { if (q < 0.0 || (q == 0.0 && i >= 2)) keep = false; }
            else {
                float r = q / p;
                if (p < 0.0) t0 = max(t0, r); else t1 = min(t1, r);
            }
        }
        if (!keep || t0 >= t1) continue;
        vec2 pa = a + t0 * d, pb = a + t1 * d;
        // Snap to the box so pieces meet R's edges exactly.
        pa = clamp(pa, vec2(-se, 0.0), vec2(se, len));
        pb = clamp(pb, vec2(-se, 0.0), vec2(se, len));
        add_segment(G, pa, pb, vref, I, A);
    }
    // R's across-edges clipped to F: bottom (v = 0) walks +s, top (v = len) walks -s.
    for (int side = 0; side < 2; ++side) {
        vec2 a = (side == 0) ? vec2(-se, 0.0) : vec2(se, len);
        vec2 d = (side == 0) ? vec2(2.0 * se, 0.0) : vec2(-2.0 * se, 0.0);
        float t0 = 0.0, t1 = 1.0;
        bool keep = true;
        for (int e = 0; e < 4; ++e) {
            vec2 c = fp[e], f = fp[(e + 1) & 3] - fp[e];
            // inside F (CCW): cross(f, p - c) >= 0, p = a + t d
            float q = f.x * (a.y - c.y) - f.y * (a.x - c.x);   // value at t = 0
            float p = f.x * d.y - f.y * d.x;                   // slope in t
            // Collinear with a footprint edge: count the shared piece only when both boundaries
            // run the same way (interiors on the same side); opposite ways bound no area.
            if (p == 0.0) { if (q < 0.0 || (q == 0.0 && dot(f, d) < 0.0)) keep = false; }
            else {
                float r = -q / p;
                if (p > 0.0) t0 = max(t0, r); else t1 = min(t1, r);
            }
        }
        if (!keep || t0 >= t1) continue;
        add_segment(G, a + t0 * d, a + t1 * d, vref, I, A);
    }
    I *= half_w;
    A *= half_w;
}

#endif
