// The default integrator (SA_INTEGRATOR_CLOSED_FORM): Green's theorem on the clipped polygon
// (green.glsl), each edge integral ∫ D(s) V(s) ds (V linear) evaluated as
//   * the Q1 part (see patch_ndf.glsl) in closed form in y = s - s0 (atan / log / rational terms,
//     with a series for the far tail of the 1/(y^2+g^2)^2 term where atan and the rational part
//     cancel), and
//   * the Q2 part with 5-point Gauss-Legendre (worst-case relative error 2.2e-5 of that part, found
//     by a sweep over alpha in [1e-3, 0.95], h up to 89 degrees from z, full-width intervals);
//   * intervals short against their distance to the lobe (dy < lam / 4, lam = max(g, |y|)) use
//     3-point Gauss on the whole D instead: the closed form's differences cancel there, and the
//     nearest pole is >= 3.5 half-lengths away, so the rule is accurate to ~(1/7)^6 = 8e-6.
#ifndef SA_INTEGRATOR_CLOSED_FORM_GLSL
#define SA_INTEGRATOR_CLOSED_FORM_GLSL

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

// SA_EDGE_ADJOINT: the reverse sweep of the edge integral (edge_adj) for the backward kernel.
#ifdef SA_EDGE_ADJOINT
#include "closed_form_adjoint.glsl"
#endif

// A term at s of a Gauss rule, weighted by an arc chord's 1 - k s (g_arc_k, patch_ndf.glsl) in the
// build with SA_ARCS (exactly the term where k = 0); the term itself in every other build.
#ifdef SA_ARCS
#define SA_ARC_W(x, s) mul(x, sub(1.0, mul(g_arc_k, s)))
#else
#define SA_ARC_W(x, s) (x)
#endif

// ∫_lo^hi D(s) V(s) ds with V linear, V(lo) = Vlo, V(hi) = Vhi, chi_lo <= lo < hi <= chi_hi.
R edge_integral(PairGeom G, R lo, R hi, R Vlo, R Vhi) {
    R dy = sub(hi, lo);
    R yl = sub(lo, G.s0), yh = sub(hi, G.s0);
    R mid = mul(0.5, add(lo, hi)), hw = mul(0.5, dy);
    R Vm = mul(0.5, add(Vlo, Vhi)), dV = mul(0.5, sub(Vhi, Vlo));
    float lam = max(val(G.g), max(abs(val(yl)), abs(val(yh))));
    if (val(dy) < 0.25 * lam) {
        const float X3 = 0.7745966692414834;
        R r = SA_ARC_W(mul(8.0 / 9.0, mul(ndf_at(G, mid), Vm)), mid);
        R sl = sub(mid, mul(X3, hw)), sh = add(mid, mul(X3, hw));
        R side = add(SA_ARC_W(mul(ndf_at(G, sl), sub(Vm, mul(X3, dV))), sl),
                     SA_ARC_W(mul(ndf_at(G, sh), add(Vm, mul(X3, dV))), sh));
        return mul(add(r, mul(5.0 / 9.0, side)), hw);
    }
    // Q1 part, closed form.
    R g = G.g, g2 = G.g2;
    R xl = dv(yl, g), xh = dv(yh, g);
    // Two atans, not three (both sides of a condition run on CPU drivers): atan of the
    // difference quotient where xl, xh have one sign, else atan(xh) - atan(xl).
    bool same = val(xl) * val(xh) > 0.0;
    R at1 = d_atan(same ? dv(sub(xh, xl), add(1.0, mul(xl, xh))) : xh);
    R datan = same ? at1 : sub(at1, d_atan(xl));
    R ql = add(mul(yl, yl), g2), qh = add(mul(yh, yh), g2);
    R B0 = dy, B1 = mul(hw, add(yh, yl));
    R K0 = dv(datan, g);
    R K1 = mul(0.5, d_log(dv(qh, ql)));
    R K2 = sub(B0, mul(g2, K0));
    // The far tail on either side (xl >= 4, or xh <= -4 mirrored) with two tail_T, not four.
    bool tail_pos = val(xl) >= 4.0;
    R dT = sub(tail_T(tail_pos ? xl : neg(xh)), tail_T(tail_pos ? xh : neg(xl)));
    R dF = (tail_pos || val(xh) <= -4.0) ? dT
         : add(datan, dv(mul(sub(xh, xl), sub(1.0, mul(xl, xh))), mul(add(1.0, mul(xl, xl)), add(1.0, mul(xh, xh)))));
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
        J2 = add(J2, SA_ARC_W(mul(GW[k], mul(add(t, mul(t, t)), add(Vm, mul(GX[k], dV)))), s));
    }
    J2 = mul(J2, hw);
#ifdef SA_ARCS
    if (val(g_arc_k) != 0.0) {
        // An arc's chord: ∫ D V (1 - k s) ds with s = y + s0, so J1 takes (1 - k s0) J1 - k ∫ Q1 y V
        // dy, which needs the Q1 part's second moment Y2S = ∫ y^2 (...) dy (y^2 / (y^2 + g^2) =
        // 1 - g^2 / (y^2 + g^2), and so on); the Q2 part's nodes are weighted in its loop above.
        R B2 = dv(sub(mul(yh, mul(yh, yh)), mul(yl, mul(yl, yl))), 3.0);
        R Y2S = add(add(add(mul(G.c0, B2), mul(G.c1, sub(B1, mul(g2, K1)))), add(mul(G.c2, K2), mul(G.c3, sub(K1, mul(g2, M1))))),
                    mul(G.c4, M2));
        R JY = add(mul(Vlo, YS), mul(dv(sub(Vhi, Vlo), dy), sub(Y2S, mul(yl, YS))));
        J1 = sub(mul(sub(1.0, mul(g_arc_k, G.s0)), J1), mul(g_arc_k, JY));
    }
#endif
    return mul(mul(mul(G.alpha, G.alpha), 0.25 / PI), add(J1, J2));
}

#include "green.glsl"

#endif
