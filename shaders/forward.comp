#version 450
// Forward renderer: one workgroup per 16x16 tile, one thread per pixel.
//
// The tile's scratch list (sorted by scratch index, see bin.comp) is streamed through shared
// memory in chunks of 64. Per chunk:
//   1. every pixel tests the 64 scratches (footprint bounding circle, then the footprint's
//      bounding box in the scratch frame) and keeps a 64-bit mask of overlapping ones;
//   2. an exclusive scan of the mask counts gives each (pixel, scratch) pair a queue slot, in
//      (pixel, scratch) order;
//   3. all 256 threads integrate queue entries side by side (no idle SIMD lanes, unlike a
//      per-pixel loop where a thin scratch touches a few pixels of the tile);
//   4. every pixel adds its own results in a fixed order (its fast-path pairs, then the others,
//      each in scratch order).
// The sums therefore do not depend on thread timing: renders are bit-reproducible.
#extension GL_GOOGLE_include_directive : require
#include "inc/common.glsl"
#include "inc/pixel.glsl"
#include "inc/patch_ndf.glsl"

layout(local_size_x = 16, local_size_y = 16) in;
layout(std430, binding = 0) readonly buffer Views { ViewGPU views[]; };
layout(std430, binding = 1) readonly buffer Scratches { ScratchGPU scr[]; };
layout(std430, binding = 2) readonly buffer Offsets { uint offs[]; };  // scanned hist, n_tiles * n_groups + 1
layout(std430, binding = 3) readonly buffer List { uint list[]; };
layout(std430, binding = 4) writeonly buffer Image { float img[]; };  // L of every view, concatenated
layout(std430, binding = 5) buffer Stats { uint stats[]; };            // [0] candidates tested, [1] overlapping pairs, [2] list entries
layout(std430, binding = 6) writeonly buffer Coverage { float cov_raw[]; };  // sum_k area(F ∩ R_k) / S_P, for the backward pass

#include "inc/shade_push.glsl"

const uint CHUNK = 64u;   // scratches per chunk (one mask bit each, two 32-bit words)
const uint QCAP = 512u;   // queue entries integrated per round

struct Prep { vec4 a; vec4 b; };  // a = p0.xy, t.xy; b = len, w, s_e, alpha
shared Prep sh_s[CHUNK];
shared vec4 sh_fp01[256];          // pixel footprint corners, ordered CCW in scratch (s, v) frames
shared vec4 sh_fp23[256];
shared vec4 sh_h[256];             // half vector (xyz)
shared uint sh_base[256];          // exclusive scan of per-pixel pair counts
shared uint sh_total;
shared uint sh_queue[QCAP];        // (pixel << 8) | scratch-in-chunk
shared vec2 sh_res[QCAP];          // (I, A)
shared uint sh_pairs;
shared vec4 sh_blk01[16];          // plate-space corners of the 4x4-pixel blocks of the tile
shared vec4 sh_blk23[16];
shared bool sh_blk_all[16];        // a block whose corner rays miss the plate: test every scratch
shared uint sh_blk_hits[32];       // per block: scratches of the chunk that may meet it (2 words)

void main() {
    uint tile = gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x;
    if (tile >= pc.n_tiles) return;  // uniform across the workgroup
    uint vi = 0u;
    for (uint v = 1u; v < pc.n_views; ++v) if (tile >= views[v].base.x) vi = v;
    ViewGPU V = views[vi];
    uint lt = tile - V.base.x;
    uvec2 ij = uvec2((lt % V.dims.z) * TILE, (lt / V.dims.z) * TILE) + gl_LocalInvocationID.xy;
    bool inside = ij.x < V.dims.x && ij.y < V.dims.y;
    uint lid = gl_LocalInvocationIndex;
    if (lid == 0u) sh_pairs = 0u;

    PixelSetup P = pixel_setup(V, ij, pc.half_plate, pc.alpha_s, pc.f0);
    bool live = inside && P.on_plate && P.scale > 0.0;
    // The map to (s, v) = (2 (q-p0).b / w, (q-p0).t) has determinant -2/w < 0: a footprint that
    // is counter-clockwise on the plate is clockwise in (s, v), so store it reversed.
    vec2 f0 = P.fp[P.ccw ? 3 : 0], f1 = P.fp[P.ccw ? 2 : 1], f2 = P.fp[P.ccw ? 1 : 2], f3 = P.fp[P.ccw ? 0 : 3];
    sh_fp01[lid] = vec4(f0, f1);
    sh_fp23[lid] = vec4(f2, f3);
    sh_h[lid] = vec4(P.h, 0.0);

    // Blocks of 4x4 pixels: their plate quads give a cheap second culling level.
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

    float dp = 0.0, cov = 0.0;
    uint cand = 0u, pairs = 0u;
    uint start = offs[tile * pc.n_groups];
    uint end = min(offs[(tile + 1u) * pc.n_groups], pc.capacity);
    for (uint c0 = start; c0 < end; c0 += CHUNK) {
        barrier();
        if (lid < CHUNK && c0 + lid < end) {
            ScratchGPU S = scr[list[c0 + lid]];
            vec2 d = S.ends.zw - S.ends.xy;
            float len = length(d);
            sh_s[lid].a = vec4(S.ends.xy, d / len);
            sh_s[lid].b = vec4(len, S.shape.x, carved_se(S.shape.x, S.shape.y), S.shape.z);
        }
        if (lid < 32u) sh_blk_hits[lid] = 0u;
        barrier();
        uint cnt = min(CHUNK, end - c0);
        // 0. scratch x block tests: bounding box of the block's plate quad in the scratch frame
        {
            uint k = lid & 63u;
            for (uint bb = 0u; bb < 4u; ++bb) {
                uint blk = 4u * (lid >> 6) + bb;
                if (k >= cnt) break;
                bool hit = sh_blk_all[blk];
                if (!hit) {
                    Prep S = sh_s[k];
                    vec2 p0 = S.a.xy, t = S.a.zw, b = vec2(-t.y, t.x);
                    float e = 0.5 * S.b.y * S.b.z, len = S.b.x;
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
        // 1. candidate tests
        uvec2 mask = uvec2(0u), fmask = uvec2(0u);
        if (live) {
            uvec2 bm2 = uvec2(sh_blk_hits[2u * myblk], sh_blk_hits[2u * myblk + 1u]);
            cand += uint(bitCount(bm2.x) + bitCount(bm2.y));
            for (uint wd = 0u; wd < 2u; ++wd) {
            uint bm = bm2[wd];
            while (bm != 0u) {
                uint k = uint(findLSB(bm)) + 32u * wd;
                bm &= bm - 1u;
                Prep S = sh_s[k];
                vec2 p0 = S.a.xy, t = S.a.zw, b = vec2(-t.y, t.x);
                float len = S.b.x, se = S.b.z;
                float e = 0.5 * S.b.y * se;
                vec2 q = P.centre - p0;
                float u = dot(q, b), v = dot(q, t);
                if (abs(u) > e + P.radius || v < -P.radius || v > len + P.radius) continue;
                // exact reject on the footprint's bounding box in the scratch frame
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
        // 2. queue slots
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
            // enqueue my pairs that fall in [r0, r0 + QCAP)
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
            // 3. integrate side by side
            uint n = min(QCAP, total - r0);
            for (uint i = lid; i < n; i += 256u) {
                uint e = sh_queue[i];
                uint px = e >> 8, k = e & 255u;
                Prep S = sh_s[k];
                vec2 p0 = S.a.xy, t = S.a.zw, b = vec2(-t.y, t.x);
                float len = S.b.x, w = S.b.y, se = S.b.z;
                float k2w = 2.0 / w;
                vec4 fa = sh_fp01[px], fb = sh_fp23[px];
                float fs[4] = float[](dot(fa.xy - p0, b) * k2w, dot(fa.zw - p0, b) * k2w, dot(fb.xy - p0, b) * k2w, dot(fb.zw - p0, b) * k2w);
                float fv[4] = float[](dot(fa.xy - p0, t), dot(fa.zw - p0, t), dot(fb.xy - p0, t), dot(fb.zw - p0, t));
                vec3 h = sh_h[px].xyz;
                PairGeom G = pair_geom(dot(h.xy, b), dot(h.xy, t), h.z, S.b.w);
                float I, A;
                if (!(r0 + i < nfast && patch_fast(fs, fv, se, len, 0.5 * w, G, I, A)))
                    patch_integral(fs, fv, se, len, 0.5 * w, G, I, A);
                sh_res[i] = vec2(I, A);
            }
            barrier();
            // 4. my results, in scratch order
            // (fast entries first, then the others: a fixed order)
            uint lo = max(fbase, r0), hi = min(fbase + uint(bitCount(fmask.x) + bitCount(fmask.y)), r0 + QCAP);
            for (uint j = lo; j < hi; ++j) {
                vec2 ra = sh_res[j - r0];
                if (ra.y > 0.0) { ++pairs; dp += ra.x; cov += ra.y; }
            }
            lo = max(gbase, r0); hi = min(gbase + uint(bitCount(mask.x) + bitCount(mask.y)), r0 + QCAP);
            for (uint j = lo; j < hi; ++j) {
                vec2 ra = sh_res[j - r0];
                if (ra.y > 0.0) { ++pairs; dp += ra.x; cov += ra.y; }
            }
            barrier();
        }
    }
    if (live) {
        atomicAdd(sh_pairs, pairs);
    }
    barrier();
    if (lid == 0u) {
        atomicAdd(stats[1], sh_pairs);
        if (tile == 0u) stats[2] = offs[pc.n_tiles * pc.n_groups];  // total tile-list entries
    }
    // candidates: one atomic per live thread would serialize; reduce through sh_base
    sh_base[lid] = live ? cand : 0u;
    barrier();
    if (lid == 0u) {
        uint s = 0u;
        for (uint i = 0u; i < 256u; ++i) s += sh_base[i];
        atomicAdd(stats[0], s);
    }
    if (!inside) return;
    float L = 0.0;
    cov_raw[V.base.y + ij.y * V.dims.x + ij.x] = live ? cov * P.inv_sp : 0.0;
    if (live) {
        float c = min(1.0, cov * P.inv_sp);
        L = P.scale * (dp * P.inv_sp + (1.0 - c) * P.d_flat);
    }
    img[V.base.y + ij.y * V.dims.x + ij.x] = L;
}
