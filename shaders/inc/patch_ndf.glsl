// The per-(pixel, scratch) patch integral (written over the scalar type R of real.glsl, so the
// backward kernel differentiates exactly this code with dual numbers) of MODEL.md section 5:
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
#include "real.glsl"

// Per-pair constants of the integrand (depend on h in the scratch frame and on alpha).
struct PairGeom {
    R alpha, beta, hb, ht, hz;
    R s0, g, g2;              // Q1 = A ((s - s0)^2 + g^2)
    R c0, c1, c2, c3, c4;     // P/Q1 + (P/Q1)^2 = c0 + (c1 y + c2)/(y^2+g^2) + (c3 y + c4)/(y^2+g^2)^2
    R chi_lo, chi_hi;         // c > 0 exactly on (chi_lo, chi_hi)
};

PairGeom pair_geom(R hb, R ht, float hz, R alpha) {
    PairGeom G;
    G.alpha = alpha; G.hb = hb; G.ht = ht; G.hz = rc(hz);
    R a2 = mul(alpha, alpha);
    G.beta = d_sqrt(d_max(sub(1.0, a2), 0.0));
    R A = add(1.0, mul(G.beta, hz));
    R iA = dv(1.0, A);
    R iA2 = mul(iA, iA);
    G.s0 = neg(mul(mul(G.beta, hb), iA));
    G.g2 = mul(add(a2, mul(mul(ht, ht), sub(1.0, a2))), iA2);
    G.g = d_sqrt(G.g2);
    R s0sq = mul(G.s0, G.s0);
    R q = sub(add(1.0, s0sq), G.g2);
    R r = sub(mul(q, q), mul(4.0, mul(s0sq, G.g2)));
    G.c0 = add(iA, iA2);
    G.c1 = add(mul(2.0, mul(G.s0, iA)), mul(4.0, mul(G.s0, iA2)));
    G.c2 = add(mul(q, iA), mul(add(mul(2.0, q), mul(4.0, s0sq)), iA2));
    G.c3 = mul(4.0, mul(mul(G.s0, q), iA2));
    G.c4 = mul(r, iA2);
    // Roots of N(s): s+ s- = -1; pick the cancellation-free form for the root near 0.
    R rho = d_sqrt(add(mul(hb, hb), hz * hz));
    R sp = (val(hb) >= 0.0) ? dv(hz, add(rho, hb)) : dv(sub(rho, hb), hz);
    G.chi_hi = sp;
    G.chi_lo = neg(dv(1.0, sp));
    return G;
}

// D(n(s) . h; alpha) with |n x h|^2 = ht^2 + m^2 computed directly (MODEL.md section 9).
R ndf_at(PairGeom G, R s) {
    R s2 = mul(s, s);
    R iP = dv(1.0, add(1.0, s2));
    R c = mul(sub(mul(G.hz, sub(1.0, s2)), mul(mul(2.0, s), G.hb)), iP);
    R m = mul(add(mul(mul(2.0, s), G.hz), mul(sub(1.0, s2), G.hb)), iP);
    R a2 = mul(G.alpha, G.alpha);
    R den = add(add(mul(a2, mul(c, c)), mul(G.ht, G.ht)), mul(m, m));
    return dv(a2, mul(PI, mul(den, den)));
}

// Far-tail form of F(x) = atan(x) + x/(1+x^2) for x >= 4: F = pi/2 - T(x), T = atan(1/x) - x/(1+x^2).
R tail_T(R x) {
    R z = dv(1.0, mul(x, x));
    R p = sub(10.0 / 11.0, mul(z, 12.0 / 13.0));
    p = sub(8.0 / 9.0, mul(z, p));
    p = sub(6.0 / 7.0, mul(z, p));
    p = sub(4.0 / 5.0, mul(z, p));
    p = sub(2.0 / 3.0, mul(z, p));
    return mul(dv(z, x), p);
}

// ∫_lo^hi D(s) V(s) ds with V linear, V(lo) = Vlo, V(hi) = Vhi, chi_lo <= lo < hi <= chi_hi.
R lin_integral(PairGeom G, R lo, R hi, R Vlo, R Vhi) {
    R dy = sub(hi, lo);
    R yl = sub(lo, G.s0), yh = sub(hi, G.s0);
    R mid = mul(0.5, add(lo, hi)), hw = mul(0.5, dy);
    R Vm = mul(0.5, add(Vlo, Vhi)), dV = mul(0.5, sub(Vhi, Vlo));
    float lam = max(val(G.g), max(abs(val(yl)), abs(val(yh))));
    if (val(dy) < 0.25 * lam) {
        const float X3 = 0.7745966692414834;
        R r = mul(8.0 / 9.0, mul(ndf_at(G, mid), Vm));
        R side = add(mul(ndf_at(G, sub(mid, mul(X3, hw))), sub(Vm, mul(X3, dV))),
                     mul(ndf_at(G, add(mid, mul(X3, hw))), add(Vm, mul(X3, dV))));
        return mul(add(r, mul(5.0 / 9.0, side)), hw);
    }
    // Q1 part, closed form.
    R g = G.g, g2 = G.g2;
    R xl = dv(yl, g), xh = dv(yh, g);
    R datan = (val(xl) * val(xh) > 0.0) ? d_atan(dv(sub(xh, xl), add(1.0, mul(xl, xh))))
                                        : sub(d_atan(xh), d_atan(xl));
    R ql = add(mul(yl, yl), g2), qh = add(mul(yh, yh), g2);
    R B0 = dy, B1 = mul(hw, add(yh, yl));
    R K0 = dv(datan, g);
    R K1 = mul(0.5, d_log(dv(qh, ql)));
    R K2 = sub(B0, mul(g2, K0));
    R dF;
    if (val(xl) >= 4.0) dF = sub(tail_T(xl), tail_T(xh));
    else if (val(xh) <= -4.0) dF = sub(tail_T(neg(xh)), tail_T(neg(xl)));
    else dF = add(datan, dv(mul(sub(xh, xl), sub(1.0, mul(xl, xh))), mul(add(1.0, mul(xl, xl)), add(1.0, mul(xh, xh)))));
    R M0 = dv(dF, mul(2.0, mul(g, g2)));
    R M1 = dv(mul(hw, add(yh, yl)), mul(ql, qh));
    R M2 = sub(K0, mul(g2, M0));
    R S = add(add(add(mul(G.c0, B0), mul(G.c1, K1)), add(mul(G.c2, K0), mul(G.c3, M1))), mul(G.c4, M0));
    R YS = add(add(add(mul(G.c0, B1), mul(G.c1, K2)), add(mul(G.c2, K1), mul(G.c3, M2))), mul(G.c4, M1));
    R J1 = add(mul(Vlo, S), mul(dv(sub(Vhi, Vlo), dy), sub(YS, mul(yl, S))));
    // Q2 part: 5-point Gauss-Legendre of 1/(1+x) + 1/(1+x)^2 (smooth on the chi+ range).
    const float GX[5] = float[](-0.9061798459386640, -0.5384693101056831, 0.0, 0.5384693101056831, 0.9061798459386640);
    const float GW[5] = float[](0.2369268850561891, 0.4786286704993665, 0.5688888888888889, 0.4786286704993665, 0.2369268850561891);
    R J2 = rc(0.0);
    for (int k = 0; k < 5; ++k) {
        R s = add(mid, mul(hw, GX[k]));
        R s2 = mul(s, s);
        R c = dv(sub(mul(G.hz, sub(1.0, s2)), mul(mul(2.0, s), G.hb)), add(1.0, s2));
        R t = dv(1.0, add(1.0, mul(G.beta, c)));
        J2 = add(J2, mul(GW[k], mul(add(t, mul(t, t)), add(Vm, mul(GX[k], dV)))));
    }
    J2 = mul(J2, hw);
    return mul(mul(mul(G.alpha, G.alpha), 0.25 / PI), add(J1, J2));
}

// Green's theorem over the boundary of F ∩ R without building the clipped polygon:
// ∂(F ∩ R) = (∂F inside R) ∪ (∂R inside F). Every footprint edge is clipped to R (Liang-Barsky)
// and R's two across-edges (v = 0 and v = len) are clipped to F (Cyrus-Beck); R's long edges
// (s = ±se) are vertical and contribute nothing. Both are walked counter-clockwise in (s, v).
// Each piece adds  -∫ D(s) (v(s) - vref) ds  to I and  -∫ (v - vref) ds  to the area;
// vref (a point of the intersection, see ref_v) keeps the v values small and drops out of the
// closed sum.
void add_segment(PairGeom G, R as, R av, R bs, R bv, R vref, inout R I, inout R A) {
    if (val(as) == val(bs)) return;
    R ds = sub(bs, as);
    R k = dv(sub(bv, av), ds);
    A = sub(A, mul(mul(0.5, ds), sub(add(av, bv), mul(2.0, vref))));
    R lo = d_min(as, bs), hi = d_max(as, bs);
    R clo = d_max(lo, G.chi_lo), chi = d_min(hi, G.chi_hi);
    if (val(clo) >= val(chi)) return;
    R a0 = sub(av, vref);
    R vlo = add(a0, mul(k, sub(clo, as)));
    R vhi = add(a0, mul(k, sub(chi, as)));
    R J = lin_integral(G, clo, chi, vlo, vhi);
    I = (val(bs) > val(as)) ? sub(I, J) : add(I, J);
}

// Footprint corners (fs[i], fv[i]) in scratch-local (s, v) coordinates (s = 2u/w), ordered
// counter-clockwise in (s, v). Carved region: |s| <= se, 0 <= v <= len.
// Returns I = ∫ D dA and A = area over F ∩ R, in mm^2 (half_w = w/2 converts ds to du).
// A v on the boundary of F ∩ R (a vertex of the first footprint edge piece inside R, else R's
// own across-edge), from values only. The Green sum does not depend on vref, but its terms are
// D (v - vref) ds: with vref on the intersection they stay the size of the intersection, so a
// sliver at a footprint corner is not the difference of footprint-sized terms (float32).
float ref_v(R fs[4], R fv[4], float se, float len) {
    for (int e = 0; e < 4; ++e) {
        float as = val(fs[e]), av = val(fv[e]);
        float ds = val(fs[(e + 1) & 3]) - as, dvv = val(fv[(e + 1) & 3]) - av;
        float t0 = 0.0, t1 = 1.0;
        float ps[4] = float[](-ds, ds, -dvv, dvv);
        float qs[4] = float[](as + se, se - as, av, len - av);
        bool keep = true;
        for (int i = 0; i < 4; ++i) {
            if (ps[i] == 0.0) { if (qs[i] < 0.0) keep = false; }
            else if (ps[i] < 0.0) t0 = max(t0, qs[i] / ps[i]);
            else t1 = min(t1, qs[i] / ps[i]);
        }
        if (keep && t0 < t1) return clamp(av + t0 * dvv, 0.0, len);
    }
    // No footprint edge enters R: F contains an end of R, or F ∩ R is empty.
    float vc = 0.25 * (val(fv[0]) + val(fv[1]) + val(fv[2]) + val(fv[3]));
    return vc < 0.5 * len ? 0.0 : len;
}

void patch_integral(R fs[4], R fv[4], R se, R len, R half_w, PairGeom G, out R I, out R A) {
    I = rc(0.0); A = rc(0.0);
    R vref = rc(ref_v(fs, fv, val(se), val(len)));
    // Footprint edges clipped to the box [-se, se] x [0, len].
    for (int e = 0; e < 4; ++e) {
        R as = fs[e], av = fv[e];
        R ds = sub(fs[(e + 1) & 3], as), dvv = sub(fv[(e + 1) & 3], av);
        R t0 = rc(0.0), t1 = rc(1.0);
        // s >= -se, s <= se, v >= 0, v <= len, each as p t <= q
        R ps[4] = R[](neg(ds), ds, neg(dvv), dvv);
        R qs[4] = R[](add(as, se), sub(se, as), av, sub(len, av));
        bool keep = true;
        for (int i = 0; i < 4; ++i) {
            float p = val(ps[i]), q = val(qs[i]);
            // An edge lying on R's across-edge line (v = 0 or v = len) is left to R's own edge
            // below, which counts a shared piece once (on s = ±se it contributes nothing anyway).
            if (p == 0.0) { if (q < 0.0 || (q == 0.0 && i >= 2)) keep = false; }
            else {
                R r = dv(qs[i], ps[i]);
                if (p < 0.0) t0 = d_max(t0, r); else t1 = d_min(t1, r);
            }
        }
        if (!keep || val(t0) >= val(t1)) continue;
        // Snap to the box so pieces meet R's edges exactly.
        R pas = d_min(d_max(add(as, mul(t0, ds)), neg(se)), se);
        R pav = d_min(d_max(add(av, mul(t0, dvv)), 0.0), len);
        R pbs = d_min(d_max(add(as, mul(t1, ds)), neg(se)), se);
        R pbv = d_min(d_max(add(av, mul(t1, dvv)), 0.0), len);
        add_segment(G, pas, pav, pbs, pbv, vref, I, A);
    }
    // R's across-edges clipped to F: bottom (v = 0) walks +s, top (v = len) walks -s.
    for (int side = 0; side < 2; ++side) {
        R as = (side == 0) ? neg(se) : se;
        R av = (side == 0) ? rc(0.0) : len;
        R ds = (side == 0) ? mul(2.0, se) : mul(-2.0, se);
        R t0 = rc(0.0), t1 = rc(1.0);
        bool keep = true;
        for (int e = 0; e < 4; ++e) {
            R cs = fs[e], cv = fv[e];
            R fds = sub(fs[(e + 1) & 3], cs), fdv = sub(fv[(e + 1) & 3], cv);
            // inside F (CCW): cross(f, p - c) >= 0 with p = a + t (ds, 0)
            R q = sub(mul(fds, sub(av, cv)), mul(fdv, sub(as, cs)));
            R p = neg(mul(fdv, ds));
            float pv = val(p), qv = val(q);
            // Collinear with a footprint edge: count the shared piece only when both boundaries
            // run the same way (interiors on the same side); opposite ways bound no area.
            if (pv == 0.0) { if (qv < 0.0 || (qv == 0.0 && val(fds) * val(ds) < 0.0)) keep = false; }
            else {
                R r = neg(dv(q, p));
                if (pv > 0.0) t0 = d_max(t0, r); else t1 = d_min(t1, r);
            }
        }
        if (!keep || val(t0) >= val(t1)) continue;
        add_segment(G, add(as, mul(t0, ds)), av, add(as, mul(t1, ds)), av, vref, I, A);
    }
    I = mul(I, half_w);
    A = mul(A, half_w);
}

// Fast path, the common pair: the carved strip crosses the footprint from side to side (no
// footprint corner strictly inside the strip) and neither scratch end enters it. Then
// F ∩ R = {|s| <= se, v_bot(s) <= v <= v_top(s)} with a linear chord v_top - v_bot, and
// I = (w/2) ∫ D(s) chord(s) ds over the chi+ part of [-se, se]: one closed-form integral instead
// of one per boundary piece. Returns false (and the caller takes patch_integral) when the pair
// is not of this kind, e.g. a corner exactly on a strip edge.
bool patch_fast(R fs[4], R fv[4], R se, R len, R half_w, PairGeom G, out R I, out R A) {
    I = rc(0.0); A = rc(0.0);
    float sev = val(se);
    R lo0 = rc(1e30), hi0 = rc(-1e30), lo1 = rc(1e30), hi1 = rc(-1e30);
    int n0 = 0, n1 = 0;
    for (int e = 0; e < 4; ++e) {
        R as = fs[e], av = fv[e], bs = fs[(e + 1) & 3], bv = fv[(e + 1) & 3];
        float a = val(as), b = val(bs);
        if (abs(a) < sev || a == b) return false;
        // edges strictly crossing the lines s = -se and s = +se
        if ((a < -sev) != (b < -sev) && a != -sev && b != -sev) {
            R v = add(av, mul(dv(sub(bv, av), sub(bs, as)), sub(neg(se), as)));
            lo0 = d_min(lo0, v); hi0 = d_max(hi0, v); ++n0;
        }
        if ((a > sev) != (b > sev) && a != sev && b != sev) {
            R v = add(av, mul(dv(sub(bv, av), sub(bs, as)), sub(se, as)));
            lo1 = d_min(lo1, v); hi1 = d_max(hi1, v); ++n1;
        }
    }
    if (!(n0 == 2 && n1 == 2 && val(lo0) > 0.0 && val(lo1) > 0.0 && val(hi0) < val(len) && val(hi1) < val(len))) return false;
    R c0 = sub(hi0, lo0), c1 = sub(hi1, lo1);
    A = mul(mul(se, add(c0, c1)), half_w);
    R clo = d_max(neg(se), G.chi_lo), chi = d_min(se, G.chi_hi);
    if (val(clo) < val(chi)) {
        R k = dv(sub(c1, c0), mul(2.0, se));
        I = mul(lin_integral(G, clo, chi, add(c0, mul(k, add(clo, se))), add(c0, mul(k, add(chi, se)))), half_w);
    }
    return true;
}

// The carved half-width in s units, s_e = 2e/w = sqrt(1 - exp(-2d/w)), with 1 - exp(-x) free of
// cancellation for small x (Kahan's expm1 trick).
R carved_se_r(R w, R d) {
    R x = dv(mul(2.0, d), w);
    R u = d_exp(neg(x));
    R one_minus = (val(u) == 1.0) ? x : dv(mul(sub(1.0, u), x), neg(d_log(u)));
    return d_sqrt(one_minus);
}

// The whole pair from the raw scratch parameters: footprint corners fp (plate, ordered so that
// they are counter-clockwise in the scratch frame) and half vector h are per-pixel constants.
void pair_from_params(R x0, R y0, R x1, R y1, R w, R d, R alpha, vec2 fp[4], vec3 h, bool try_fast, out R I, out R A) {
    R dx = sub(x1, x0), dy = sub(y1, y0);
    R len = d_sqrt(add(mul(dx, dx), mul(dy, dy)));
    R tx = dv(dx, len), ty = dv(dy, len);
    R bx = neg(ty), by = tx;
    R k2w = dv(2.0, w);
    R fs[4], fv[4];
    for (int c = 0; c < 4; ++c) {
        R rx = sub(fp[c].x, x0), ry = sub(fp[c].y, y0);
        fs[c] = mul(add(mul(rx, bx), mul(ry, by)), k2w);
        fv[c] = add(mul(rx, tx), mul(ry, ty));
    }
    R hb = add(mul(h.x, bx), mul(h.y, by));
    R ht = add(mul(h.x, tx), mul(h.y, ty));
    PairGeom G = pair_geom(hb, ht, h.z, alpha);
    R se = carved_se_r(w, d);
    if (!(try_fast && patch_fast(fs, fv, se, len, mul(0.5, w), G, I, A))) patch_integral(fs, fv, se, len, mul(0.5, w), G, I, A);
}

#endif
