#version 450
// Backward pass of forward.comp: gradients of a loss E with respect to every scratch's
// (x0, y0, x1, y1, w, d, alpha), given dE/dL per pixel.
//
// Per pixel, L = scale (D_P + (1 - min(1, cov)) D_flat) with D_P = sum_k I_k / S_P and
// cov = sum_k A_k / S_P, so for scratch k
//   dL/dθ = scale / S_P (dI_k/dθ - [cov < 1] D_flat dA_k/dθ).
// I_k and A_k and their derivatives come from the very code of the forward pass
// (inc/patch_ndf.glsl) evaluated with forward-mode dual numbers (inc/real.glsl): the clipping of
// footprint and carved rectangle moves with the endpoints, width and depth, and is differentiated
// with it.
//
// Work layout and order follow forward.comp (tiles, chunks of 64 scratches, block culling,
// in-workgroup queue). For each chunk, thread k < 64 adds scratch k's per-pair contributions in
// queue order and writes one partial gradient per tile-list entry; grad_reduce.comp then adds a
// scratch's partials in enumeration order. No float atomics: gradients are bit-reproducible.
#extension GL_GOOGLE_include_directive : require
#define SA_DUAL 1
#include "inc/common.glsl"
#include "inc/pixel.glsl"
#include "inc/patch_ndf.glsl"

layout(local_size_x = 16, local_size_y = 16) in;
layout(std430, binding = 0) readonly buffer Views { ViewGPU views[]; };
layout(std430, binding = 1) readonly buffer Scratches { ScratchGPU scr[]; };
layout(std430, binding = 2) readonly buffer Offsets { uint offs[]; };
layout(std430, binding = 3) readonly buffer List { uint list[]; };
layout(std430, binding = 4) readonly buffer DL { float dl[]; };          // dE/dL per pixel
layout(std430, binding = 5) readonly buffer Coverage { float cov_raw[]; };
layout(std430, binding = 6) writeonly buffer Partials { vec4 partial[]; };  // 2 per list entry

#include "inc/shade_push.glsl"

const uint CHUNK = 64u;
const uint QCAP = 256u;

shared vec4 sh_ends[CHUNK];        // raw scratch parameters
shared vec4 sh_shape[CHUNK];
shared vec4 sh_prep[CHUNK];        // len, e, unused, unused (culling)
shared vec4 sh_fp01[256];
shared vec4 sh_fp23[256];
shared vec4 sh_h[256];             // xyz half vector, w = coefficient of dI
shared float sh_ga[256];           // coefficient of dA
shared uint sh_base[256];
shared uint sh_total;
shared uint sh_queue[QCAP];
shared vec4 sh_c0[QCAP];           // per-pair contribution d/d(x0, y0, x1, y1)
shared vec4 sh_c1[QCAP];           // d/d(w, d, alpha), 0
shared vec4 sh_acc0[CHUNK];
shared vec4 sh_acc1[CHUNK];
shared vec4 sh_blk01[16];
shared vec4 sh_blk23[16];
shared bool sh_blk_all[16];
shared uint sh_blk_hits[32];

void main() {
    uint tile = gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x;
    if (tile >= pc.n_tiles) return;
    uint vi = 0u;
    for (uint v = 1u; v < pc.n_views; ++v) if (tile >= views[v].base.x) vi = v;
    ViewGPU V = views[vi];
    uint lt = tile - V.base.x;
    uvec2 ij = uvec2((lt % V.dims.z) * TILE, (lt / V.dims.z) * TILE) + gl_LocalInvocationID.xy;
    bool inside = ij.x < V.dims.x && ij.y < V.dims.y;
    uint lid = gl_LocalInvocationIndex;

    PixelSetup P = pixel_setup(V, ij, pc.half_plate, pc.alpha_s, pc.f0);
    bool live = inside && P.on_plate && P.scale > 0.0;
    float gI = 0.0, gA = 0.0;
    if (live) {
        uint pix = V.base.y + ij.y * V.dims.x + ij.x;
        float g = dl[pix] * P.scale * P.inv_sp;
        gI = g;
        gA = cov_raw[pix] < 1.0 ? -g * P.d_flat : 0.0;
        live = g != 0.0;
    }
    vec2 f0 = P.fp[P.ccw ? 3 : 0], f1 = P.fp[P.ccw ? 2 : 1], f2 = P.fp[P.ccw ? 1 : 2], f3 = P.fp[P.ccw ? 0 : 3];
    sh_fp01[lid] = vec4(f0, f1);
    sh_fp23[lid] = vec4(f2, f3);
    sh_h[lid] = vec4(P.h, gI);
    sh_ga[lid] = gA;
    if (lid < 16u) {
        uvec2 b0 = uvec2((lt % V.dims.z) * TILE, (lt / V.dims.z) * TILE) + 4u * uvec2(lid & 3u, lid >> 2);
        bool k0, k1, k2, k3;
        vec2 c0 = ray_hit(V, vec2(b0), k0), c1 = ray_hit(V, vec2(b0) + vec2(4.0, 0.0), k1);
        vec2 c2 = ray_hit(V, vec2(b0) + vec2(4.0), k2), c3 = ray_hit(V, vec2(b0) + vec2(0.0, 4.0), k3);
        sh_blk01[lid] = vec4(c0, c1);
        sh_blk23[lid] = vec4(c2, c3);
        sh_blk_all[lid] = !(k0 && k1 && k2 && k3);
    }
    uint myblk = (gl_LocalInvocationID.x >> 2) + 4u * (gl_LocalInvocationID.y >> 2);

    uint start = offs[tile * pc.n_groups];
    uint end = min(offs[(tile + 1u) * pc.n_groups], pc.capacity);
    for (uint c0 = start; c0 < end; c0 += CHUNK) {
        barrier();
        if (lid < CHUNK) {
            sh_acc0[lid] = vec4(0.0);
            sh_acc1[lid] = vec4(0.0);
            if (c0 + lid < end) {
                ScratchGPU S = scr[list[c0 + lid]];
                sh_ends[lid] = S.ends;
                sh_shape[lid] = S.shape;
                float len = length(S.ends.zw - S.ends.xy);
                sh_prep[lid] = vec4(len, 0.5 * S.shape.x * carved_se(S.shape.x, S.shape.y), 0.0, 0.0);
            }
        }
        if (lid < 32u) sh_blk_hits[lid] = 0u;
        barrier();
        uint cnt = min(CHUNK, end - c0);
        {
            uint k = lid & 63u;
            for (uint bb = 0u; bb < 4u; ++bb) {
                uint blk = 4u * (lid >> 6) + bb;
                if (k >= cnt) break;
                bool hit = sh_blk_all[blk];
                if (!hit) {
                    vec2 p0 = sh_ends[k].xy, t = (sh_ends[k].zw - p0) / sh_prep[k].x, b = vec2(-t.y, t.x);
                    float e = sh_prep[k].y, len = sh_prep[k].x;
                    vec4 qa = sh_blk01[blk], qb = sh_blk23[blk];
                    vec4 us = vec4(dot(qa.xy - p0, b), dot(qa.zw - p0, b), dot(qb.xy - p0, b), dot(qb.zw - p0, b));
                    vec4 vs = vec4(dot(qa.xy - p0, t), dot(qa.zw - p0, t), dot(qb.xy - p0, t), dot(qb.zw - p0, t));
                    hit = !(min(min(us.x, us.y), min(us.z, us.w)) >= e || max(max(us.x, us.y), max(us.z, us.w)) <= -e ||
                            min(min(vs.x, vs.y), min(vs.z, vs.w)) >= len || max(max(vs.x, vs.y), max(vs.z, vs.w)) <= 0.0);
                }
                if (hit) atomicOr(sh_blk_hits[2u * blk + (k >> 5)], 1u << (k & 31u));
            }
        }
        barrier();
        uvec2 mask = uvec2(0u), fmask = uvec2(0u);
        if (live) {
            uvec2 bm2 = uvec2(sh_blk_hits[2u * myblk], sh_blk_hits[2u * myblk + 1u]);
            for (uint wd = 0u; wd < 2u; ++wd) {
            uint bm = bm2[wd];
            while (bm != 0u) {
                uint k = uint(findLSB(bm)) + 32u * wd;
                bm &= bm - 1u;
                vec2 p0 = sh_ends[k].xy, t = (sh_ends[k].zw - p0) / sh_prep[k].x, b = vec2(-t.y, t.x);
                float e = sh_prep[k].y, len = sh_prep[k].x;
                vec2 q = P.centre - p0;
                float u = dot(q, b), v = dot(q, t);
                if (abs(u) > e + P.radius || v < -P.radius || v > len + P.radius) continue;
                float umin = 1e30, umax = -1e30, vmin = 1e30, vmax = -1e30, uabs = 1e30;
                for (int c = 0; c < 4; ++c) {
                    vec2 r = P.fp[c] - p0;
                    float uu = dot(r, b), vv = dot(r, t);
                    umin = min(umin, uu); umax = max(umax, uu); vmin = min(vmin, vv); vmax = max(vmax, vv);
                    uabs = min(uabs, abs(uu));
                }
                if (umin >= e || umax <= -e || vmin >= len || vmax <= 0.0) continue;
                // likely fast-path pair (see patch_fast): queued apart so SIMD lanes agree
                if (uabs > e && vmin > 0.0 && vmax < len) fmask[wd] |= 1u << (k & 31u); else mask[wd] |= 1u << (k & 31u);
            }
            }
        }
        // Queue: all fast-path pairs first, then the others; each group in (pixel, scratch) order.
        // Both counts are scanned at once, packed in 16-bit halves (at most 256 x 64 = 16384 each).
        sh_base[lid] = uint(bitCount(fmask.x) + bitCount(fmask.y)) | (uint(bitCount(mask.x) + bitCount(mask.y)) << 16);
        barrier();
        if (lid == 0u) {
            uint run = 0u;
            for (uint i = 0u; i < 256u; ++i) { uint c = sh_base[i]; sh_base[i] = run; run += c; }
            sh_total = run;
        }
        barrier();
        uint nfast = sh_total & 0xFFFFu;
        uint total = nfast + (sh_total >> 16);
        uint fbase = sh_base[lid] & 0xFFFFu;
        uint gbase = nfast + (sh_base[lid] >> 16);
        for (uint r0 = 0u; r0 < total; r0 += QCAP) {
            uint idx = fbase;
            for (uint wd = 0u; wd < 2u; ++wd) {
                uint m = fmask[wd];
                while (m != 0u) {
                    uint k = uint(findLSB(m)) + 32u * wd;
                    m &= m - 1u;
                    if (idx >= r0 && idx < r0 + QCAP) sh_queue[idx - r0] = (lid << 8) | k;
                    ++idx;
                }
            }
            idx = gbase;
            for (uint wd = 0u; wd < 2u; ++wd) {
                uint m = mask[wd];
                while (m != 0u) {
                    uint k = uint(findLSB(m)) + 32u * wd;
                    m &= m - 1u;
                    if (idx >= r0 && idx < r0 + QCAP) sh_queue[idx - r0] = (lid << 8) | k;
                    ++idx;
                }
            }
            barrier();
            uint n = min(QCAP, total - r0);
            for (uint i = lid; i < n; i += 256u) {
                uint qe = sh_queue[i];
                uint px = qe >> 8, k = qe & 255u;
                vec4 E = sh_ends[k], S = sh_shape[k];
                vec4 fa = sh_fp01[px], fb = sh_fp23[px];
                vec2 fp[4] = vec2[](fa.xy, fa.zw, fb.xy, fb.zw);
                vec4 hh = sh_h[px];
                Dual I, A;
                pair_from_params(seed(E.x, 0), seed(E.y, 1), seed(E.z, 2), seed(E.w, 3), seed(S.x, 4), seed(S.y, 5), seed(S.z, 6),
                                 fp, hh.xyz, r0 + i < nfast, I, A);
                float ga = sh_ga[px];
                sh_c0[i] = hh.w * I.g0 + ga * A.g0;
                sh_c1[i] = vec4(hh.w * I.g1 + ga * A.g1, 0.0);
            }
            barrier();
            // scratch k's contributions of this round, in queue order
            if (lid < cnt) {
                vec4 a0 = sh_acc0[lid], a1 = sh_acc1[lid];
                for (uint i = 0u; i < n; ++i) {
                    if ((sh_queue[i] & 255u) == lid) { a0 += sh_c0[i]; a1 += sh_c1[i]; }
                }
                sh_acc0[lid] = a0;
                sh_acc1[lid] = a1;
            }
            barrier();
        }
        if (lid < cnt) {
            partial[2u * (c0 + lid)] = sh_acc0[lid];
            partial[2u * (c0 + lid) + 1u] = sh_acc1[lid];
        }
    }
}
