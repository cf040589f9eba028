// SA_INTEGRATOR_AVERAGE: the cheap "average" approximation the speed-against-accuracy study
// (`scratchart study`) measures: the GGX integral over the clipped s-range of F ∩ R times the
// clipped area fraction,
//   I ≈ A * (1 / (s_hi - s_lo)) ∫_{s_lo}^{s_hi} D(s) ds,   A = area(F ∩ R),
// which is exact when the intersection's v-extent does not vary with s (a strip crossing a
// square footprint at right angles) and wrong by the correlation of D with the chord otherwise.
// A is exact (the Green walk's area); the 1D integral is the closed form's edge integral with
// V = 1. Float only (forward kernels and the study); it has no backward.
#ifndef SA_INTEGRATOR_AVERAGE_GLSL
#define SA_INTEGRATOR_AVERAGE_GLSL
#ifdef SA_DUAL
#error the average approximation has no backward (forward kernels and the study only)
#endif

// The closed form's edge_integral and green.glsl's walk helpers, without its pair_integral.
#define pair_integral pair_integral_closed_form
#include "closed_form.glsl"
#undef pair_integral

void pair_integral(R fs[4], R fv[4], R se, R len, R half_w, PairGeom G, bool try_fast, out R I, out R A) {
    vec4 f4 = vec4(fs[0], fs[1], fs[2], fs[3]), v4 = vec4(fv[0], fv[1], fv[2], fv[3]);
    float vref = ref_v(fs, fv, se, len);
    float area = 0.0, slo = 1e30, shi = -1e30;
    for (int j = 0; j < 6; ++j) {
        float as, av, bs, bv;
        if (!walk_piece(j, f4, v4, se, len, as, av, bs, bv)) continue;
        area -= 0.5 * (bs - as) * (av + bv - 2.0 * vref);
        slo = min(slo, min(as, bs));
        shi = max(shi, max(as, bs));
    }
    A = area * half_w;
    I = 0.0;
    float lo = max(slo, G.chi_lo), hi = min(shi, G.chi_hi);
    if (area > 0.0 && shi > slo && lo < hi) I = area * edge_integral(G, lo, hi, 1.0, 1.0) / (shi - slo) * half_w;
}

#endif
