#version 450
// Forward renderer: one workgroup per 16x16 tile, one thread per pixel. The tile's scratch list
// (sorted by scratch index, see bin.comp) is streamed through shared memory; each pixel sums its
// patch integrals in list order, so the result does not depend on thread timing.
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

layout(push_constant) uniform Push {
    float half_plate;
    float alpha_s;
    float f0;
    uint n_views;
    uint n_groups;
    uint n_tiles;
    uint capacity;
    uint pad0;
} pc;

struct Prep { vec4 a; vec4 b; };  // a = p0.xy, t.xy; b = len, w, s_e, alpha
shared Prep sh[256];
shared uint sh_cand, sh_pairs;

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
    if (lid == 0u) { sh_cand = 0u; sh_pairs = 0u; }

    PixelSetup P = pixel_setup(V, ij, pc.half_plate, pc.alpha_s, pc.f0);
    bool live = inside && P.on_plate && P.scale > 0.0;
    float dp = 0.0, cov = 0.0;
    uint cand = 0u, pairs = 0u;

    uint start = offs[tile * pc.n_groups];
    uint end = min(offs[(tile + 1u) * pc.n_groups], pc.capacity);
    for (uint c0 = start; c0 < end; c0 += 256u) {
        barrier();
        if (c0 + lid < end) {
            ScratchGPU S = scr[list[c0 + lid]];
            vec2 d = S.ends.zw - S.ends.xy;
            float len = length(d);
            sh[lid].a = vec4(S.ends.xy, d / len);
            sh[lid].b = vec4(len, S.shape.x, carved_se(S.shape.x, S.shape.y), S.shape.z);
        }
        barrier();
        uint cnt = min(256u, end - c0);
        if (!live) continue;
        for (uint k = 0u; k < cnt; ++k) {
            Prep S = sh[k];
            vec2 p0 = S.a.xy, t = S.a.zw, b = vec2(-t.y, t.x);
            float len = S.b.x, w = S.b.y, se = S.b.z;
            float e = 0.5 * w * se;
            // Cheap reject with the footprint's bounding circle.
            vec2 q = P.centre - p0;
            float u = dot(q, b), v = dot(q, t);
            ++cand;
            if (abs(u) > e + P.radius || v < -P.radius || v > len + P.radius) continue;
            vec2 fl[4];
            float k2w = 2.0 / w;
            // The map to (s, v) = (2 (q-p0).b / w, (q-p0).t) has determinant -2/w < 0, so a
            // footprint that is counter-clockwise on the plate is clockwise in (s, v): reverse it.
            for (int c = 0; c < 4; ++c) {
                vec2 r = P.fp[P.ccw ? 3 - c : c] - p0;
                fl[c] = vec2(dot(r, b) * k2w, dot(r, t));
            }
            // Exact reject on the local bounding box.
            vec2 fmin = min(min(fl[0], fl[1]), min(fl[2], fl[3]));
            vec2 fmax = max(max(fl[0], fl[1]), max(fl[2], fl[3]));
            if (fmin.x >= se || fmax.x <= -se || fmin.y >= len || fmax.y <= 0.0) continue;
            PairGeom G = pair_geom(dot(P.h.xy, b), dot(P.h.xy, t), P.h.z, S.b.w);
            float I, A;
            patch_integral(fl, se, len, 0.5 * w, G, I, A);
            if (A > 0.0) { ++pairs; dp += I; cov += A; }
        }
    }
    if (live) {
        atomicAdd(sh_cand, cand);
        atomicAdd(sh_pairs, pairs);
    }
    barrier();
    if (lid == 0u) {
        atomicAdd(stats[0], sh_cand);
        atomicAdd(stats[1], sh_pairs);
        if (tile == 0u) stats[2] = offs[pc.n_tiles * pc.n_groups];  // total tile-list entries
    }
    if (!inside) return;
    float L = 0.0;
    if (live) {
        float c = min(1.0, cov * P.inv_sp);
        L = P.scale * (dp * P.inv_sp + (1.0 - c) * P.d_flat);
    }
    img[V.base.y + ij.y * V.dims.x + ij.x] = L;
}
