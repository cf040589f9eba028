#version 450
// Forward renderer: pixel values L of MODEL.md section 5 for every view. One workgroup per 16x16
// tile, one thread per pixel; the tile machinery (chunks, block culling, the pair queue) is in
// inc/tile_queue.glsl. Queue entries are integrated by all threads side by side, then every pixel
// adds its own results in a fixed order (its fast-path pairs, then the others, each in scratch
// order), so renders are bit-reproducible.
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
layout(std430, binding = 7) readonly buffer Views64 { ViewGPU64 views64[]; };  // float64 cameras
layout(std430, binding = 8) readonly buffer Lights { float intensity[]; };     // Phi per view

#include "inc/shade_push.glsl"

const uint QCAP = 512u;   // queue entries integrated per round
#include "inc/tile_queue.glsl"

shared vec4 sh_fp01[256];          // pixel footprint corners, ordered CCW in scratch (s, v) frames
shared vec4 sh_fp23[256];
shared vec4 sh_h[256];             // half vector (xyz)
shared vec2 sh_res[QCAP];          // (I, A)
shared uint sh_pairs;

void main() {
    uint tile = gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x;
    if (tile >= pc.n_tiles) return;  // uniform across the workgroup
    uvec2 t0;
    uint vi = tile_view(tile, t0);
    ViewGPU V = views[vi];
    uvec2 ij = t0 + gl_LocalInvocationID.xy;
    bool inside = ij.x < V.dims.x && ij.y < V.dims.y;
    uint lid = gl_LocalInvocationIndex;
    if (lid == 0u) sh_pairs = 0u;

    PixelSetup P = pixel_setup(V, views64[vi], intensity[vi], ij, pc.half_plate, pc.alpha_s, pc.f0);
    bool live = inside && P.on_plate && P.scale > 0.0;
    // The map to (s, v) = (2 (q-p0).b / w, (q-p0).t) has determinant -2/w < 0: a footprint that
    // is counter-clockwise on the plate is clockwise in (s, v), so store it reversed.
    vec2 f0 = P.fp[P.ccw ? 3 : 0], f1 = P.fp[P.ccw ? 2 : 1], f2 = P.fp[P.ccw ? 1 : 2], f3 = P.fp[P.ccw ? 0 : 3];
    sh_fp01[lid] = vec4(f0, f1);
    sh_fp23[lid] = vec4(f2, f3);
    sh_h[lid] = vec4(P.h, 0.0);
    setup_blocks(V, t0, lid);
    uint myblk = (gl_LocalInvocationID.x >> 2) + 4u * (gl_LocalInvocationID.y >> 2);

    float dp = 0.0, cov = 0.0;
    uint cand = 0u, pairs = 0u;
    uint start = offs[tile * pc.n_groups];
    uint end = min(offs[(tile + 1u) * pc.n_groups], pc.capacity);
    for (uint c0 = start; c0 < end; c0 += CHUNK) {
        barrier();
        if (lid < CHUNK && c0 + lid < end) {
            load_cull(lid, scr[list[c0 + lid]]);
            block_tests(lid);
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
                uint e = sh_queue[i];
                uint px = e >> 8, k = e & 255u;
                vec4 ca = sh_cull_a[k], cb = sh_cull_b[k];
                vec2 p0 = ca.xy, t = ca.zw, b = vec2(-t.y, t.x);
                float len = cb.x, w = cb.y, se = cb.z;
                float k2w = 2.0 / w;
                vec4 fa = sh_fp01[px], fb = sh_fp23[px];
                float fs[4] = float[](dot(fa.xy - p0, b) * k2w, dot(fa.zw - p0, b) * k2w, dot(fb.xy - p0, b) * k2w, dot(fb.zw - p0, b) * k2w);
                float fv[4] = float[](dot(fa.xy - p0, t), dot(fa.zw - p0, t), dot(fb.xy - p0, t), dot(fb.zw - p0, t));
                vec3 h = sh_h[px].xyz;
                PairGeom G = pair_geom(dot(h.xy, b), dot(h.xy, t), h.z, cb.w);
                float I, A;
                if (!(r0 + i < nfast && patch_fast(fs, fv, se, len, 0.5 * w, G, I, A)))
                    patch_integral(fs, fv, se, len, 0.5 * w, G, I, A);
                sh_res[i] = vec2(I, A);
            }
            barrier();
            // my results: fast entries, then the others (a fixed order)
            uint lo = max(fbase, r0), hi = min(fbase + uint(bitCount(fmask.x) + bitCount(fmask.y)), r0 + QCAP);
            for (uint j = lo; j < hi; ++j) {
                vec2 ra = sh_res[j - r0];
                if (ra.y > 0.0) { ++pairs; dp += ra.x; cov += ra.y; }
            }
            lo = max(gbase, r0); hi = min(gbase + uint(bitCount(gmask.x) + bitCount(gmask.y)), r0 + QCAP);
            for (uint j = lo; j < hi; ++j) {
                vec2 ra = sh_res[j - r0];
                if (ra.y > 0.0) { ++pairs; dp += ra.x; cov += ra.y; }
            }
            // Another round overwrites the queue and results; after the last one the next
            // chunk's first barrier is enough.
            if (r0 + QCAP < total) barrier();
        }
    }
    if (live) atomicAdd(sh_pairs, pairs);
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
