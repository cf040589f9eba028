// The reverse sweep of closed_form.glsl's edge integral (SA_EDGE_ADJOINT): edge_adj recomputes
// the integral with the same float arithmetic and returns its partial derivatives with respect
// to the interval's ends, the end values of V and the pair constants (s0, g, g2, c0..c4, alpha,
// beta, hb, ht; hz is a per-pixel constant), scaled by the caller's adjoint. The backward kernel
// (grad.comp) runs it inside the whole pair's reverse sweep (inc/pair_adjoint.glsl).
//
// The partials are those of the mathematical function the forward evaluates: for the far-tail
// branch (tail_T) and the two atan forms the derivative is taken of F(x) = atan x + x/(1+x^2)
// (F' = 2/(1+x^2)^2) and of atan itself, so every branch has the same, exact, derivative.
#ifndef SA_CLOSED_FORM_ADJOINT_GLSL
#define SA_CLOSED_FORM_ADJOINT_GLSL
#ifdef SA_DUAL
#error the reverse sweep runs in float kernels only (R = float): build without SA_DUAL
#endif
#define SA_HAS_EDGE_ADJ  // grad.comp can then run in reverse mode (inc/pair_adjoint.glsl)

// D(n(s) . h; alpha) as ndf_at (patch_ndf.glsl) and its partials in s, hb, ht, alpha.
float ndf_partials(float s, float hz, float hb, float ht, float alpha, out float d_s, out float d_hb, out float d_ht,
                   out float d_alpha) {
    float s2 = s * s;
    float iP = 1.0 / (1.0 + s2);
    float c = (hz * (1.0 - s2) - 2.0 * s * hb) * iP;
    float m = (2.0 * s * hz + (1.0 - s2) * hb) * iP;
    float a2 = alpha * alpha;
    float den = a2 * c * c + ht * ht + m * m;
    float q = 1.0 / (PI * den * den);
    float N = a2 * q;
    float a_den = -2.0 * N / den;
    float a_c = a_den * 2.0 * a2 * c;
    float a_m = a_den * 2.0 * m;
    d_s = a_c * (-2.0 * s * hz - 2.0 * hb - 2.0 * s * c) * iP + a_m * (2.0 * hz - 2.0 * s * hb - 2.0 * s * m) * iP;
    d_hb = (a_c * (-2.0 * s) + a_m * (1.0 - s2)) * iP;
    d_ht = a_den * 2.0 * ht;
    d_alpha = (q + a_den * c * c) * 2.0 * alpha;
    return N;
}

// Adjoints of the pair constants of PairGeom (patch_ndf.glsl).
struct GAdj {
    float alpha, beta, hb, ht;
    float s0, g, g2;
    float c0, c1, c2, c3, c4;
    float chi_lo, chi_hi;
};

GAdj gadj_zero() { return GAdj(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0); }

// ∫_lo^hi D(s) V(s) ds exactly as closed_form.glsl's edge_integral computes it in float, and the
// reverse sweep: with aJ the adjoint of the result, adds aJ ∂J/∂x to aG for the pair constants
// and returns those of the ends and of V in a_lo, a_hi, a_Vlo, a_Vhi.
float edge_adj(PairGeom G, float lo, float hi, float Vlo, float Vhi, float aJ, inout GAdj aG, out float a_lo,
               out float a_hi, out float a_Vlo, out float a_Vhi) {
    float s0 = G.s0, g = G.g, g2 = G.g2, alpha = G.alpha, hb = G.hb, ht = G.ht, hz = G.hz;
    float dy = hi - lo;
    float yl = lo - s0, yh = hi - s0;
    float mid = 0.5 * (lo + hi), hw = 0.5 * dy;
    float Vm = 0.5 * (Vlo + Vhi), dV = 0.5 * (Vhi - Vlo);
    float lam = max(g, max(abs(yl), abs(yh)));
    // Adjoints of the inputs (seed aJ).
    float a_mid = 0.0, a_hw = 0.0, a_Vm = 0.0, a_dV = 0.0;
    float a_hb = 0.0, a_ht = 0.0, a_alpha = 0.0;
    a_lo = 0.0; a_hi = 0.0; a_Vlo = 0.0; a_Vhi = 0.0;
    float J;
    if (dy < 0.25 * lam) {
        // 3-point Gauss on the whole D.
        const float X3 = 0.7745966692414834;
        float nm_s, nm_hb, nm_ht, nm_al, np_s, np_hb, np_ht, np_al, nq_s, nq_hb, nq_ht, nq_al;
        float nm = ndf_partials(mid, hz, hb, ht, alpha, nm_s, nm_hb, nm_ht, nm_al);
        float nq = ndf_partials(mid - X3 * hw, hz, hb, ht, alpha, nq_s, nq_hb, nq_ht, nq_al);
        float np = ndf_partials(mid + X3 * hw, hz, hb, ht, alpha, np_s, np_hb, np_ht, np_al);
        float Vq = Vm - X3 * dV, Vp = Vm + X3 * dV;
        float r = (8.0 / 9.0) * (nm * Vm);
        float side = nq * Vq + np * Vp;
        float sum = r + (5.0 / 9.0) * side;
        J = sum * hw;
        a_hw = aJ * sum;
        float a_sum = aJ * hw;
        float a_nm = a_sum * (8.0 / 9.0) * Vm;
        float a_nq = a_sum * (5.0 / 9.0) * Vq, a_np = a_sum * (5.0 / 9.0) * Vp;
        a_Vm = a_sum * ((8.0 / 9.0) * nm + (5.0 / 9.0) * (nq + np));
        a_dV = a_sum * (5.0 / 9.0) * X3 * (np - nq);
        a_mid = a_nm * nm_s + a_nq * nq_s + a_np * np_s;
        a_hw += X3 * (a_np * np_s - a_nq * nq_s);
        a_hb = a_nm * nm_hb + a_nq * nq_hb + a_np * np_hb;
        a_ht = a_nm * nm_ht + a_nq * nq_ht + a_np * np_ht;
        a_alpha = a_nm * nm_al + a_nq * nq_al + a_np * np_al;
    } else {
        float c0 = G.c0, c1 = G.c1, c2 = G.c2, c3 = G.c3, c4 = G.c4, beta = G.beta;
        // Forward sweep: the Q1 part in closed form (closed_form.glsl's edge_integral in float).
        float xl = yl / g, xh = yh / g;
        bool same = xl * xh > 0.0;  // two atans, not three (see closed_form.glsl)
        float at1 = atan(same ? (xh - xl) / (1.0 + xl * xh) : xh);
        float datan = same ? at1 : at1 - atan(xl);
        float ql = yl * yl + g2, qh = yh * yh + g2;
        float B0 = dy, B1 = hw * (yh + yl);
        float K0 = datan / g;
        float K1 = 0.5 * log(qh / ql);
        float K2 = B0 - g2 * K0;
        float pl = 1.0 + xl * xl, ph = 1.0 + xh * xh;
        bool tail_pos = xl >= 4.0;  // two tail_T, not four
        float dT = tail_T(tail_pos ? xl : -xh) - tail_T(tail_pos ? xh : -xl);
        float dF = (tail_pos || xh <= -4.0) ? dT : datan + ((xh - xl) * (1.0 - xl * xh)) / (pl * ph);
        float M0 = dF / (2.0 * (g * g2));
        float M1 = (hw * (yh + yl)) / (ql * qh);
        float M2 = K0 - g2 * M0;
        float S = ((c0 * B0 + c1 * K1) + (c2 * K0 + c3 * M1)) + c4 * M0;
        float YS = ((c0 * B1 + c1 * K2) + (c2 * K1 + c3 * M2)) + c4 * M1;
        float kV = (Vhi - Vlo) / dy;
        float Y = YS - yl * S;
        float J1 = Vlo * S + kV * Y;
        float pre = alpha * alpha * (0.25 / PI);
        // The Q2 part: 5-point Gauss-Legendre of t + t^2, t = 1 / (1 + beta c), with its reverse
        // sweep in the same loop (its adjoint seed, pre hw per unit of the sum, is known already).
        const float GX[5] = float[](-0.9061798459386640, -0.5384693101056831, 0.0, 0.5384693101056831, 0.9061798459386640);
        const float GW[5] = float[](0.2369268850561891, 0.4786286704993665, 0.5688888888888889, 0.4786286704993665, 0.2369268850561891);
        float sum2 = 0.0, a_beta = 0.0;
        float apre = aJ * pre;  // the adjoint of J1 and of J2
        float a_sum2 = apre * hw;
        for (int k = 0; k < 5; ++k) {
            float s = mid + hw * GX[k];
            float s2 = s * s;
            float iP = 1.0 / (1.0 + s2);
            float c = (hz * (1.0 - s2) - 2.0 * s * hb) / (1.0 + s2);
            float t = 1.0 / (1.0 + beta * c);
            float fk = t + t * t;
            float Wk = Vm + GX[k] * dV;
            sum2 += GW[k] * (fk * Wk);
            float wk = a_sum2 * GW[k];
            a_Vm += wk * fk;
            a_dV += wk * GX[k] * fk;
            float a_t = wk * Wk * (1.0 + 2.0 * t);
            float tt = t * t;
            a_beta -= a_t * tt * c;
            float a_c = -a_t * tt * beta;
            float a_s = a_c * (-2.0 * s * hz - 2.0 * hb - 2.0 * s * c) * iP;
            a_hb += a_c * (-2.0 * s) * iP;
            a_mid += a_s;
            a_hw += a_s * GX[k];
        }
        float J2 = sum2 * hw;
        J = pre * (J1 + J2);

        // Reverse sweep of the rest (every adjoint below carries the factor apre).
        a_alpha = aJ * (J1 + J2) * (0.5 / PI) * alpha;
        float a_J1 = apre;
        a_hw += apre * sum2;
        // J1 = Vlo S + kV (YS - yl S)
        a_Vlo = a_J1 * S;
        float a_S = a_J1 * Vlo;
        float a_kV = a_J1 * Y;
        float a_YS = a_J1 * kV;
        float a_yl = -a_YS * S;
        a_S -= a_YS * yl;
        a_Vhi += a_kV / dy;
        a_Vlo -= a_kV / dy;
        float a_dy = -a_kV * kV / dy;
        // S and YS
        float a_c0 = a_S * B0 + a_YS * B1;
        float a_c1 = a_S * K1 + a_YS * K2;
        float a_c2 = a_S * K0 + a_YS * K1;
        float a_c3 = a_S * M1 + a_YS * M2;
        float a_c4 = a_S * M0 + a_YS * M1;
        float a_B0 = a_S * c0, a_B1 = a_YS * c0;
        float a_K1 = a_S * c1 + a_YS * c2;
        float a_K2 = a_YS * c1;
        float a_K0 = a_S * c2;
        float a_M1 = a_S * c3 + a_YS * c4;
        float a_M2 = a_YS * c3;
        float a_M0 = a_S * c4;
        // M2 = K0 - g2 M0
        a_K0 += a_M2;
        float a_g2 = -a_M2 * M0;
        a_M0 -= a_M2 * g2;
        // M1 = hw (yh + yl) / (ql qh)
        float iq = 1.0 / (ql * qh);
        a_hw += a_M1 * (yh + yl) * iq;
        float a_yh = a_M1 * hw * iq;
        a_yl += a_M1 * hw * iq;
        float a_ql = -a_M1 * M1 / ql, a_qh = -a_M1 * M1 / qh;
        // M0 = dF / (2 g g2), dF = F(xh) - F(xl)
        float a_dF = a_M0 / (2.0 * (g * g2));
        float a_g = -a_M0 * M0 / g;
        a_g2 -= a_M0 * M0 / g2;
        float a_xh = a_dF * 2.0 / (ph * ph), a_xl = -a_dF * 2.0 / (pl * pl);
        // K2 = B0 - g2 K0
        a_B0 += a_K2;
        a_g2 -= a_K2 * K0;
        a_K0 -= a_K2 * g2;
        // K1 = log(qh / ql) / 2
        a_qh += 0.5 * a_K1 / qh;
        a_ql -= 0.5 * a_K1 / ql;
        // K0 = datan / g, datan = atan(xh) - atan(xl)
        float a_datan = a_K0 / g;
        a_g -= a_K0 * K0 / g;
        a_xh += a_datan / ph;
        a_xl -= a_datan / pl;
        // B1 = hw (yh + yl), B0 = dy
        a_hw += a_B1 * (yh + yl);
        a_yh += a_B1 * hw;
        a_yl += a_B1 * hw;
        a_dy += a_B0;
        // ql = yl^2 + g2, qh = yh^2 + g2
        a_yl += 2.0 * yl * a_ql;
        a_yh += 2.0 * yh * a_qh;
        a_g2 += a_ql + a_qh;
        // xl = yl / g, xh = yh / g
        a_yl += a_xl / g;
        a_yh += a_xh / g;
        a_g -= (a_xl * xl + a_xh * xh) / g;
        // yl = lo - s0, yh = hi - s0, dy = hi - lo: folded below with mid and hw.
        a_lo = a_yl - a_dy;
        a_hi = a_yh + a_dy;
        aG.s0 -= a_yl + a_yh;
        aG.g += a_g;
        aG.g2 += a_g2;
        aG.c0 += a_c0;
        aG.c1 += a_c1;
        aG.c2 += a_c2;
        aG.c3 += a_c3;
        aG.c4 += a_c4;
        aG.beta += a_beta;
    }
    // mid = (lo + hi)/2, hw = (hi - lo)/2, Vm = (Vlo + Vhi)/2, dV = (Vhi - Vlo)/2
    a_lo += 0.5 * (a_mid - a_hw);
    a_hi += 0.5 * (a_mid + a_hw);
    a_Vlo += 0.5 * (a_Vm - a_dV);
    a_Vhi += 0.5 * (a_Vm + a_dV);
    aG.hb += a_hb;
    aG.ht += a_ht;
    aG.alpha += a_alpha;
    return J;
}

#endif
