// The per-(pixel, scratch) patch integral of engine/docs/model.md section 5,
//   I = integral over F ∩ R of D(n(u) . h; alpha) dA,   A = area(F ∩ R),
// and the one pair set-up of the shading kernels. Written over the scalar type R of real.glsl:
// forward.comp runs it in float, grad.comp differentiates exactly this code with dual numbers.
//
// The integrand. In the scratch frame (u across, v along) it depends on u only. With s = 2u/w the
// normal is n = ((1 - s^2) z - 2 s b) / (1 + s^2), so c = n . h = N(s) / P(s) with P = 1 + s^2,
// N = hz (1 - s^2) - 2 hb s. Writing x = beta c (beta = sqrt(1 - alpha^2)),
//   D = alpha^2 / (pi (1 - x^2)^2) = alpha^2 / (4 pi) [1/(1-x)^2 + 1/(1-x) + 1/(1+x)^2 + 1/(1+x)],
// and 1/(1-x) = P / Q1, 1/(1+x) = P / Q2 with the positive-definite quadratics
//   Q1 = (1 + beta hz) s^2 + 2 beta hb s + (1 - beta hz),  Q2 = (1 - beta hz) s^2 - 2 beta hb s + (1 + beta hz).
// Q1 carries the sharp GGX lobe: Q1 = A ((s - s0)^2 + g^2) with A = 1 + beta hz, s0 = -beta hb / A,
// g^2 = (alpha^2 + ht^2 (1 - alpha^2)) / A^2 (no cancellation: 1 - beta^2 rho^2 expanded).
// On the chi+ range (c > 0) 1/(1+x) lies in [1/2, 1] and is smooth. D jumps to 0 where c = 0
// (engine/docs/model.md section 9): every integrator integrates over the chi+ range only.
//
// The integrator. The kernels compile with one SA_INTEGRATOR_* define (engine/render/src/kernels.rs)
// that picks a file of inc/integrators/; it defines
//   void pair_integral(R fs[4], R fv[4], R se, R len, R half_w, PairGeom G, bool try_fast, out R I, out R A)
// over the footprint corners (fs, fv) in scratch-local (s, v) coordinates (counter-clockwise in
// (s, v)) and the carved rectangle |s| <= se, 0 <= v <= len; half_w = w/2 converts ds to du.
// try_fast says the pair was queued as a likely fast-path pair (tile_queue.glsl); an integrator
// may ignore it. Without a define the default, SA_INTEGRATOR_CLOSED_FORM, is used.
#ifndef SA_PATCH_NDF_GLSL
#define SA_PATCH_NDF_GLSL

#include "common.glsl"
#include "real.glsl"

// The area weight of an arc's chord (engine/docs/model.md section 11, engine/render/src/arcs.rs):
// the pair integral is of D (1 - k s) dA, k = sign(bulge) w / (2 r) in s units (the annulus's
// rho / r against the chord's rectangle); 0 for a straight scratch. The forward sets it per pair
// (ScratchGPU.shape.w); the gradient and tangent kernels leave it 0 (arcs are not
// differentiated). Only the closed-form integrator's float walk applies it, and only in the build
// with SA_ARCS (engine/render/src/lib.rs builds it for scenes with arcs): without it the kernel
// has no trace of arcs. The dual-number backward (grad.comp with SA_DUAL and SA_ARCS) makes it a
// dual number, k = kappa w / 2 with kappa = 2 k / w the chord's signed curvature, so that its
// derivatives carry k's through w and give dE/dkappa (the 8th partial).
#if defined(SA_DUAL) && defined(SA_ARCS)
Dual g_arc_k = Dual(0.0, vec4(0.0), vec4(0.0));
#else
float g_arc_k = 0.0;
#endif

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

// D(n(s) . h; alpha) with |n x h|^2 = ht^2 + m^2 computed directly (engine/docs/model.md section 9).
R ndf_at(PairGeom G, R s) {
    R s2 = mul(s, s);
    R iP = dv(1.0, add(1.0, s2));
    R c = mul(sub(mul(G.hz, sub(1.0, s2)), mul(mul(2.0, s), G.hb)), iP);
    R m = mul(add(mul(mul(2.0, s), G.hz), mul(sub(1.0, s2), G.hb)), iP);
    R a2 = mul(G.alpha, G.alpha);
    R den = add(add(mul(a2, mul(c, c)), mul(G.ht, G.ht)), mul(m, m));
    return dv(a2, mul(PI, mul(den, den)));
}

#if defined(SA_INTEGRATOR_GAUSS_PANELS)
#include "integrators/gauss_panels.glsl"
#elif defined(SA_INTEGRATOR_GAUSS_LEGENDRE)
#include "integrators/gauss_legendre.glsl"
#elif defined(SA_INTEGRATOR_AVERAGE)
#include "integrators/average.glsl"
#elif defined(SA_INTEGRATOR_ADAPTIVE_QUADRATURE)
#include "integrators/adaptive_quadrature.glsl"
#elif defined(SA_INTEGRATOR_MONTE_CARLO)
#include "integrators/monte_carlo.glsl"
#else
#include "integrators/closed_form.glsl"
#endif

// The pair set-up, one for both kernels: footprint corners and half vector into the scratch
// frame, then the integrator. The frame is the scratch's origin (x0, y0), unit axis (tx, ty) and
// length; w its width parameter, se the carved half-width in s units (carved_se). fp are the
// footprint corners on the plate, ordered so that they are counter-clockwise in (s, v), h the
// half vector (both per-pixel constants).
// The forward kernel passes its culling record (scratch_records.comp: float axis and
// length); the backward kernel passes dual numbers built from the raw parameters
// (pair_from_params). dot2 is GLSL's dot in float and a sum of two products in dual numbers, so
// each kernel performs the float operations it performed when it had its own copy of this code.
void pair_integrate(R x0, R y0, R tx, R ty, R len, R w, R se, R alpha, vec2 fp[4], vec3 h, bool try_fast,
                    out R I, out R A) {
    R bx = neg(ty), by = tx;
    R k2w = dv(2.0, w);
    R fs[4], fv[4];
    for (int c = 0; c < 4; ++c) {
        R rx = sub(fp[c].x, x0), ry = sub(fp[c].y, y0);
        fs[c] = mul(dot2(rx, ry, bx, by), k2w);
        fv[c] = dot2(rx, ry, tx, ty);
    }
    PairGeom G = pair_geom(dot2(h.x, h.y, bx, by), dot2(h.x, h.y, tx, ty), h.z, alpha);
    pair_integral(fs, fv, se, len, mul(0.5, w), G, try_fast, I, A);
}

// The whole pair from the raw scratch parameters (the backward kernel seeds them as dual
// numbers): the scratch frame, then pair_integrate.
void pair_from_params(R x0, R y0, R x1, R y1, R w, R d, R alpha, vec2 fp[4], vec3 h, bool try_fast, out R I, out R A) {
    R dx = sub(x1, x0), dy = sub(y1, y0);
    R len = d_sqrt(add(mul(dx, dx), mul(dy, dy)));
    R tx = dv(dx, len), ty = dv(dy, len);
    pair_integrate(x0, y0, tx, ty, len, w, carved_se(w, d), alpha, fp, h, try_fast, I, A);
}

#endif
