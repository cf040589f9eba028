// SA_INTEGRATOR_ADAPTIVE_QUADRATURE: the same Green's theorem walk as the default (green.glsl), every edge
// integral ∫ D(s) V(s) ds by globally adaptive quadrature: 5-point Gauss-Legendre on 4 equal
// panels, then the panel with a failing error estimate is bisected (estimate |G(left) + G(right)
// - G(panel)|, accepted below AQ_TOL x |running total| x the panel's share of the edge) until
// every panel passes, the stack (AQ_STACK panels) is full or AQ_EVALS rule evaluations are spent.
// What a careful generic integrator does without knowing where the GGX lobe is; for the
// speed-against-accuracy study (`scratchart study`), forward only. Its failure mode is the
// classic one: a lobe narrower than a panel that no node of the first panels sees is never
// refined (the estimate agrees with itself), and the evaluation budget runs out on long edges
// with a sharp lobe.
#ifndef SA_INTEGRATOR_ADAPTIVE_QUADRATURE_GLSL
#define SA_INTEGRATOR_ADAPTIVE_QUADRATURE_GLSL

#define AQ_STACK 16
#define AQ_EVALS 48
const float AQ_TOL = 1e-5;

// ∫_a^b D(s) (V0 + k (s - s_ref)) ds, 5-point Gauss-Legendre.
float aq_gl5(PairGeom G, float a, float b, float V0, float k, float s_ref) {
    const float X[2] = float[](0.5384693101056831, 0.9061798459386640);
    const float W[2] = float[](0.4786286704993665, 0.2369268850561891);
    float mid = 0.5 * (a + b), hw = 0.5 * (b - a);
    float sum = 0.5688888888888889 * ndf_at(G, mid) * (V0 + k * (mid - s_ref));
    for (int i = 0; i < 2; ++i) {
        float sl = mid - hw * X[i], sh = mid + hw * X[i];
        sum += W[i] * (ndf_at(G, sl) * (V0 + k * (sl - s_ref)) + ndf_at(G, sh) * (V0 + k * (sh - s_ref)));
    }
    return sum * hw;
}

float edge_integral(PairGeom G, float lo, float hi, float Vlo, float Vhi) {
    float k = (Vhi - Vlo) / (hi - lo);
    float sa[AQ_STACK], sb[AQ_STACK], sw[AQ_STACK];
    float total = 0.0, est = 0.0;
    int n = 0, evals = 0;
    for (int i = 0; i < 4; ++i) {
        float a = lo + (hi - lo) * (0.25 * float(i)), b = i == 3 ? hi : lo + (hi - lo) * (0.25 * float(i + 1));
        float w = aq_gl5(G, a, b, Vlo, k, lo);
        sa[n] = a; sb[n] = b; sw[n] = w;
        ++n;
        est += w;
    }
    evals = 4;
    while (n > 0) {
        --n;
        float a = sa[n], b = sb[n], w = sw[n];
        float m = 0.5 * (a + b);
        float l = aq_gl5(G, a, m, Vlo, k, lo), r = aq_gl5(G, m, b, Vlo, k, lo);
        evals += 2;
        est += l + r - w;
        bool ok = abs(l + r - w) <= AQ_TOL * abs(est) * (b - a) / (hi - lo);
        if (ok || n + 2 > AQ_STACK || evals + 2 > AQ_EVALS || m <= a || m >= b) {
            total += l + r;
        } else {
            sa[n] = a; sb[n] = m; sw[n] = l;
            sa[n + 1] = m; sb[n + 1] = b; sw[n + 1] = r;
            n += 2;
        }
    }
    return total;
}

#include "green.glsl"

#endif
