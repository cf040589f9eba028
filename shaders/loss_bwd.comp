#version 450
// Backward passes of the design loss: dE/dL per pixel into `dl` (the renderer's backward reads it).
// Recorded after loss_fwd.comp's passes (which leave the filter responses in `pre`, B = g*(I-T) in
// `bbuf` and the Gram matrices in `gram`), in this order:
//   PRE_GRAD    at every pyramid pixel: dE/d(filter response), written over `pre` in place.
//               With R = 2 lambda_g (G - G_T) (9 x 9, symmetric), dE/dc_k(p) = (2 / N_s) sum_j R_kj c_j(p),
//               then through the half-wave rectifiers.
//   XGRAD       (with cross-talk pairs) at every level-0 pixel of view v: B_v += sum_k c_vk u_vk,
//               in place, so that LEVEL_GRAD's pixel term carries the cross-talk term's gradient
//               (d/dB of c_vk^2 is 2 c_vk u_vk; recorded once per forward).
//   LEVEL_GRAD  once per level, coarsest first: dE/dX at each pixel of the level = the transposed
//               clamp-to-edge filters applied to those gradients + 1/4 of the gradient of the
//               pooled pixel above it; at level 0 plus the pixel term's
//               (2 lambda_p / N_v) g^T B, then times dI/dL (taken at max(L, 1e-4)) into `dl`.
// Each output is computed by its own thread from a fixed set of inputs: no atomics, reproducible.
#extension GL_GOOGLE_include_directive : require
#include "inc/loss_bindings.glsl"
#include "inc/loss_bank.glsl"

// Full symmetric R_ij of segment sg.
float rmat(uint sg, uint i, uint j) {
    uint e = i <= j ? gram_idx(i, j) : gram_idx(j, i);
    return 2.0 * pc.lambda_g * segs[sg].weight * (gram[sg * NPART + e] - gramT[sg * NPART + e]);
}

void main() {
#if defined(PRE_GRAD)
    uint i = flat_id();
    if (i >= pc.lvl_end) return;
    uint sg = seg_of(i);
    LossSeg S = segs[sg];
    float r[NPRE];
    for (uint k = 0u; k < NPRE; ++k) r[k] = pre[i * NPRE + k];
    float c[NCH];
    channels(r, c);
    float scale = 2.0 / float(S.w * S.h);
    float dc[NCH];
    for (uint a = 0u; a < NCH; ++a) {
        float acc = 0.0;
        for (uint b = 0u; b < NCH; ++b) acc += rmat(sg, a, b) * c[b];
        dc[a] = scale * acc;
    }
    pre[i * NPRE] = dc[0];
    for (uint k = 1u; k < NPRE; ++k) {
        float gk = 0.0;
        if (r[k] > 0.0) gk = dc[2u * k - 1u];
        else if (r[k] < 0.0) gk = -dc[2u * k];
        pre[i * NPRE + k] = gk;
    }
#elif defined(XGRAD)
    uint i = flat_id();
    if (i >= pc.lvl_end) return;  // level 0's pixels
    uint v = seg_of(i);           // a level-0 segment: the coarser levels lie after level 0
    LossSeg V = segs[v];
    uint li = i - V.off;
    if (li >= V.w * V.h) return;
    float add = 0.0;
    for (uint p = 0u; p < pc.n_pairs; ++p) {
        XPair P = xpairs[p];
        if (P.v == v) add += xc[p] * (xmask[i] * (tpyr[segs[P.k].off + li] - P.mu) * P.s);
    }
    bbuf[i] += add;
#elif defined(LEVEL_GRAD)
    uint i = pc.lvl_begin + flat_id();
    if (i >= pc.lvl_end) return;
    uint sg = seg_of(i);
    LossSeg S = segs[sg];
    int x = int((i - S.off) % S.w), y = int((i - S.off) / S.w);
    int W = int(S.w), H = int(S.h);
    float g1[3] = float[3](pc.g_s, pc.g_c, pc.g_s);
    float pix_scale = 2.0 * pc.lambda_p * S.weight / float(S.w * S.h);
    float acc = 0.0, accp = 0.0;
    // Output pixel p reads input clamp(p + o); collect every (p, o) that reads this pixel. Per axis
    // these are p = x - o for the three offsets, plus at a border the output on the border
    // reading past it (clamp-to-edge): at most four (p, o) per axis, listed in (p, o) order and
    // packed in 4 bits as (p - x + 1) * 4 + (o + 1). Looping over the two short lists, instead of testing all 81
    // combinations of the 3 x 3 outputs and offsets, is the same sum in the same order inside the
    // image (on CPU drivers a skipped combination cost as much as a used one).
    // The loops test at the bottom (every pixel is read by at least one tap per axis): on CPU
    // drivers a loop that tests at the top runs its body once more with every lane off.
    uint tx = 0u, nx = 0u, ty = 0u, ny = 0u;
    int px = max(x - 1, 0), px_end = min(x + 1, W - 1);
    do {
        for (int ox = -1; ox <= 1; ++ox)
            if (clampi(px + ox, W) == x) { tx |= uint((px - x + 1) * 4 + ox + 1) << (nx * 4u); ++nx; }
    } while (++px <= px_end);
    int py = max(y - 1, 0), py_end = min(y + 1, H - 1);
    do {
        for (int oy = -1; oy <= 1; ++oy)
            if (clampi(py + oy, H) == y) { ty |= uint((py - y + 1) * 4 + oy + 1) << (ny * 4u); ++ny; }
    } while (++py <= py_end);
    uint b = 0u;
    do {
        uint ey = (ty >> (b * 4u)) & 15u;
        int qy = y - 1 + int(ey >> 2), oy = int(ey & 3u) - 1;
        uint a = 0u;
        do {
            uint ex = (tx >> (a * 4u)) & 15u;
            int qx = x - 1 + int(ex >> 2), ox = int(ex & 3u) - 1;
            uint p = S.off + uint(qy) * S.w + uint(qx);
            for (uint k = 0u; k < NPRE; ++k) acc += bank_w(k, ox, oy) * pre[p * NPRE + k];
            if (S.level == 0u) accp += g1[ox + 1] * g1[oy + 1] * bbuf[p];
        } while (++a < nx);
    } while (++b < ny);
    if (S.level + 1u < pc.n_levels) {
        LossSeg U = segs[sg + pc.n_views];  // same view, level above
        uint ux = uint(x) / 2u, uy = uint(y) / 2u;
        if (ux < U.w && uy < U.h) {
            float gu = gx[U.off + uy * U.w + ux];
            // Taps of the 2x2 mean of pixel (ux, uy) that land here (several when the level is 1 wide).
            uint hits = 0u;
            for (uint b = 0u; b < 2u; ++b)
                for (uint a = 0u; a < 2u; ++a)
                    if (clampi(int(2u * ux + a), W) == x && clampi(int(2u * uy + b), H) == y) ++hits;
            acc += 0.25 * float(hits) * gu;
        }
    }
    if (S.level == 0u) {
        dl[i] = (acc + pix_scale * accp) * display_slope(img[i]);
    } else {
        gx[i] = acc;
    }
#endif
}
