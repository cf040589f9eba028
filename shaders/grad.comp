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
// Work layout and order follow forward.comp (inc/tile_queue.glsl). For each chunk, thread k < 64
// adds scratch k's per-pair contributions in queue order and writes one partial gradient per
// tile-list entry; grad_reduce.comp then adds a scratch's partials in enumeration order. No
// float atomics: gradients are bit-reproducible.
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
layout(std430, binding = 7) readonly buffer Views64 { ViewGPU64 views64[]; };  // float64 cameras
layout(std430, binding = 8) readonly buffer Lights { float intensity[]; };     // Phi per view

#include "inc/shade_push.glsl"

// Queue entries per round: 256 fits 32 KiB of shared memory (lavapipe's limit); the host passes
// GRAD_QCAP = 512 on devices with at least 48 KiB (fewer rounds and barriers per chunk).
#ifndef GRAD_QCAP
#define GRAD_QCAP 256
#endif
const uint QCAP = GRAD_QCAP;
#include "inc/tile_queue.glsl"

shared vec4 sh_ends[CHUNK];        // raw scratch parameters
shared vec4 sh_shape[CHUNK];
shared vec4 sh_fp01[256];
shared vec4 sh_fp23[256];
shared vec4 sh_h[256];             // xyz half vector, w = coefficient of dI
shared float sh_ga[256];           // coefficient of dA
shared vec4 sh_c0[QCAP];           // per-pair contribution d/d(x0, y0, x1, y1)
shared vec4 sh_c1[QCAP];           // d/d(w, d, alpha), 0
shared vec4 sh_acc0[CHUNK];
shared vec4 sh_acc1[CHUNK];

void main() {
    uint tile = gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x;
    if (tile >= pc.n_tiles) return;
    uvec2 t0;
    uint vi = tile_view(tile, t0);
    ViewGPU V = views[vi];
    uvec2 ij = t0 + gl_LocalInvocationID.xy;
    bool inside = ij.x < V.dims.x && ij.y < V.dims.y;
    uint lid = gl_LocalInvocationIndex;

    PixelSetup P = pixel_setup(V, views64[vi], intensity[vi], ij, pc.half_plate, pc.alpha_s, pc.f0);
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
    setup_blocks(V, t0, lid);
    uint myblk = (gl_LocalInvocationID.x >> 2) + 4u * (gl_LocalInvocationID.y >> 2);

    uint cand = 0u;
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
                load_cull(lid, S);
                block_tests(lid);
            }
        }
        barrier();
        uint cnt = min(CHUNK, end - c0);
        uvec2 fmask, gmask;
        pixel_masks(live, myblk, P.fp, P.centre, P.radius, fmask, gmask, cand);
        uint nfast, total, fbase, gbase;
        queue_slots(lid, fmask, gmask, nfast, total, fbase, gbase);
        for (uint r0 = 0u; r0 < total; r0 += QCAP) {
            enqueue(lid, fmask, fbase, r0);
            enqueue(lid, gmask, gbase, r0);
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
            // Another round overwrites the queue and contributions; after the last one the next
            // chunk's first barrier is enough (sh_acc is written and read by the same thread).
            if (r0 + QCAP < total) barrier();
        }
        if (lid < cnt) {
            partial[2u * (c0 + lid)] = sh_acc0[lid];
            partial[2u * (c0 + lid) + 1u] = sh_acc1[lid];
        }
    }
}
