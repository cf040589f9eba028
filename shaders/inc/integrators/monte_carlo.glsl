// SA_INTEGRATOR_MONTE_CARLO: what a generic renderer does, for the speed-against-accuracy study
// (`scratchart study`): SA_MC_POINTS points (a square number: 16, 64 or 256) stratified over the
// footprint, one per cell of a sqrt(N) x sqrt(N) grid in the footprint's bilinear parameters,
// jittered by a hash of the pair (deterministic), each weighted by the map's Jacobian:
//   I ≈ Σ_i |J_i| / N * D(s_i) [p_i in R],   A ≈ Σ_i |J_i| / N [p_i in R].
// The error falls like N^(-3/4) for a smooth integrand over a stratified grid and like N^(-1/2)
// per cell that the carved rectangle's edge or a sharp lobe cuts. Float only; no backward.
#ifndef SA_INTEGRATOR_MONTE_CARLO_GLSL
#define SA_INTEGRATOR_MONTE_CARLO_GLSL
#ifdef SA_DUAL
#error the Monte Carlo integrator has no backward (forward kernels and the study only)
#endif
#ifndef SA_MC_POINTS
#define SA_MC_POINTS 64
#endif

uint mc_hash(uint x) {
    x ^= x >> 16; x *= 0x7feb352du;
    x ^= x >> 15; x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}

void pair_integral(R fs[4], R fv[4], R se, R len, R half_w, PairGeom G, bool try_fast, out R I, out R A) {
    const int M = int(sqrt(float(SA_MC_POINTS)) + 0.5);
    vec2 c0 = vec2(fs[0], fv[0]), c1 = vec2(fs[1], fv[1]), c2 = vec2(fs[2], fv[2]), c3 = vec2(fs[3], fv[3]);
    uint seed = mc_hash(floatBitsToUint(fs[0]) ^ mc_hash(floatBitsToUint(fv[0]) ^ mc_hash(floatBitsToUint(se))));
    float isum = 0.0, asum = 0.0;
    for (int a = 0; a < M; ++a) {
        for (int b = 0; b < M; ++b) {
            uint hsh = mc_hash(seed ^ uint(a * M + b) * 0x9e3779b9u);
            float u = (float(a) + float(hsh & 0xFFFFu) / 65536.0) / float(M);
            float w = (float(b) + float(hsh >> 16) / 65536.0) / float(M);
            vec2 p = (1.0 - u) * (1.0 - w) * c0 + u * (1.0 - w) * c1 + u * w * c2 + (1.0 - u) * w * c3;
            vec2 du = (1.0 - w) * (c1 - c0) + w * (c2 - c3), dw = (1.0 - u) * (c3 - c0) + u * (c2 - c1);
            float jac = abs(du.x * dw.y - du.y * dw.x);
            if (abs(p.x) > se || p.y < 0.0 || p.y > len) continue;
            asum += jac;
            float s2 = p.x * p.x;
            float c = (G.hz * (1.0 - s2) - 2.0 * p.x * G.hb) / (1.0 + s2);
            if (c > 0.0) isum += jac * ndf_at(G, p.x);
        }
    }
    float inv = 1.0 / float(M * M);
    I = isum * inv * half_w;
    A = asum * inv * half_w;
}

#endif
