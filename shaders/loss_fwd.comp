#version 450
// Forward passes of the design loss (engine/docs/model.md section 7; definitions in inc/loss_bank.glsl).
// One pass per compile-time define, recorded in this order by engine/optim/src/loss/mod.rs:
//   DISPLAY  level-0 pyramid = I = L^(1/2.2) of the render
//   POOL     level `level` of the pyramid from the level below (2x2 mean)
//   FEAT     5 filter responses at every pyramid pixel; at level 0 also B = g * (I - T)
//   PARTIAL  per block of <= 256 pixels of one segment: 45 Gram sums and sum B^2, in pixel order
//   GRAM     per segment: its blocks' partial sums in block order, divided by the pixel count
//   XPART    (with cross-talk pairs) per pair (v, k) and block of <= 256 pixels of view v:
//            sum B_v u_vk in pixel order (inc/loss_push.glsl XPair)
//   XSUM     per pair: c_vk = its blocks' partial sums in block order
//   FINAL    per view: pixel loss lambda_p (mean B^2 + sum_k c_vk^2 / N_v) and Gram loss
//            lambda_g sum_s ||G - G_T||^2; outv[2 n_views] = their total (views in order)
// Every sum runs in a fixed order, so the loss is bit-reproducible (no float atomics).
#extension GL_GOOGLE_include_directive : require
#include "inc/loss_bindings.glsl"
#include "inc/loss_bank.glsl"

#if defined(PARTIAL)
shared float sh_c[BLOCK * NCH];
shared float sh_b[BLOCK];
#endif

void main() {
#if defined(DISPLAY)
    uint i = flat_id();
    if (i >= pc.lvl_end) return;
    pyr[i] = display(img[i]);
#elif defined(POOL)
    uint i = pc.lvl_begin + flat_id();
    if (i >= pc.lvl_end) return;
    LossSeg S = segs[seg_of(i)];
    LossSeg D = segs[seg_of(i) - pc.n_views];  // same view, level below
    uint x = (i - S.off) % S.w, y = (i - S.off) / S.w;
    float acc = 0.0;
    for (uint b = 0u; b < 2u; ++b)
        for (uint a = 0u; a < 2u; ++a) {
            int sx = clampi(int(2u * x + a), int(D.w)), sy = clampi(int(2u * y + b), int(D.h));
            acc += pyr[D.off + uint(sy) * D.w + uint(sx)];
        }
    pyr[i] = 0.25 * acc;
#elif defined(FEAT)
    uint i = flat_id();
    if (i >= pc.lvl_end) return;
    LossSeg S = segs[seg_of(i)];
    int x = int((i - S.off) % S.w), y = int((i - S.off) / S.w);
    float r[NPRE] = float[NPRE](0.0, 0.0, 0.0, 0.0, 0.0);
    float bsum = 0.0;
    float g1[3] = float[3](pc.g_s, pc.g_c, pc.g_s);
    for (int oy = -1; oy <= 1; ++oy)
        for (int ox = -1; ox <= 1; ++ox) {
            uint c = S.off + uint(clampi(y + oy, int(S.h))) * S.w + uint(clampi(x + ox, int(S.w)));
            float X = pyr[c];
            for (uint k = 0u; k < NPRE; ++k) r[k] += bank_w(k, ox, oy) * X;
            if (S.level == 0u) bsum += g1[ox + 1] * g1[oy + 1] * (X - tpyr[c]);
        }
    for (uint k = 0u; k < NPRE; ++k) pre[i * NPRE + k] = r[k];
    if (S.level == 0u) bbuf[i] = bsum;
#elif defined(PARTIAL)
    uint blk = gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x;
    if (blk >= pc.n_blocks) return;  // uniform across the workgroup
    uvec4 B = blocks[blk];
    uint lid = gl_LocalInvocationID.x;
    bool lvl0 = segs[B.x].level == 0u;
    if (lid < B.z) {
        uint i = B.y + lid;
        float r[NPRE];
        for (uint k = 0u; k < NPRE; ++k) r[k] = pre[i * NPRE + k];
        float c[NCH];
        channels(r, c);
        for (uint k = 0u; k < NCH; ++k) sh_c[lid * NCH + k] = c[k];
        float b = lvl0 ? bbuf[i] : 0.0;
        sh_b[lid] = b * b;
    }
    barrier();
    if (lid < NGRAM) {
        // Entry lid -> (ci, cj), ci <= cj.
        uint ci = 0u, rest = lid;
        while (rest >= NCH - ci) { rest -= NCH - ci; ++ci; }
        uint cj = ci + rest;
        float acc = 0.0;
        for (uint p = 0u; p < B.z; ++p) acc += sh_c[p * NCH + ci] * sh_c[p * NCH + cj];
        part[blk * NPART + lid] = acc;
    } else if (lid == NGRAM) {
        float acc = 0.0;
        for (uint p = 0u; p < B.z; ++p) acc += sh_b[p];
        part[blk * NPART + lid] = acc;
    }
#elif defined(GRAM)
    uint t = flat_id();
    if (t >= pc.n_segs * NPART) return;
    uint s = t / NPART, e = t % NPART;
    LossSeg S = segs[s];
    float acc = 0.0;
    for (uint b = 0u; b < S.nblk; ++b) acc += part[(S.blk0 + b) * NPART + e];
    gram[t] = acc / float(S.w * S.h);
#elif defined(XPART)
    uint t = flat_id();
    if (t >= pc.lvl_end) return;  // lvl_end: the number of partial sums
    uint p = 0u;
    for (uint q = 1u; q < pc.n_pairs; ++q)
        if (t >= xpairs[q].part0) p = q;
    XPair P = xpairs[p];
    LossSeg V = segs[P.v];
    uint ko = segs[P.k].off;
    uint i0 = (t - P.part0) * BLOCK, i1 = min(i0 + BLOCK, V.w * V.h);
    float acc = 0.0;
    for (uint i = i0; i < i1; ++i) acc += bbuf[V.off + i] * (xmask[V.off + i] * (tpyr[ko + i] - P.mu) * P.s);
    xpart[t] = acc;
#elif defined(XSUM)
    uint p = flat_id();
    if (p >= pc.n_pairs) return;
    XPair P = xpairs[p];
    float acc = 0.0;
    for (uint b = 0u; b < segs[P.v].nblk; ++b) acc += xpart[P.part0 + b];
    xc[p] = acc;
#elif defined(FINAL)
    // One workgroup; thread v handles view v, thread 0 then adds the views in order.
    uint v = gl_LocalInvocationID.x;
    for (uint vv = v; vv < pc.n_views; vv += 256u) {
        float lp = pc.lambda_p * segs[vv].weight * gram[vv * NPART + NGRAM];
        if (pc.n_pairs > 0u) {
            float xs = 0.0;
            for (uint p = 0u; p < pc.n_pairs; ++p)
                if (xpairs[p].v == vv) xs += xc[p] * xc[p];
            lp += pc.lambda_p * segs[vv].weight * (xs / float(segs[vv].w * segs[vv].h));
        }
        float lg = 0.0;
        for (uint s = 0u; s < pc.n_levels; ++s) {
            uint sg = s * pc.n_views + vv;
            uint e = 0u;
            for (uint ci = 0u; ci < NCH; ++ci)
                for (uint cj = ci; cj < NCH; ++cj, ++e) {
                    float d = gram[sg * NPART + e] - gramT[sg * NPART + e];
                    lg += (ci == cj ? 1.0 : 2.0) * segs[sg].weight * d * d;
                }
        }
        outv[2u * vv] = lp;
        outv[2u * vv + 1u] = pc.lambda_g * lg;
    }
    memoryBarrierBuffer();
    barrier();
    if (v == 0u) {
        float tot = 0.0;
        for (uint vv = 0u; vv < pc.n_views; ++vv) tot += outv[2u * vv] + outv[2u * vv + 1u];
        outv[2u * pc.n_views] = tot;
    }
#endif
}
