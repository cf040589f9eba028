#version 450
// Directional derivatives of the pixel values (a Jacobian-vector product, forward mode): for up to
// 7 directions j in the space of every scratch's (w, d, alpha), given per scratch the tangents
// (dw/dθ_j, dd/dθ_j, dalpha/dθ_j), writes dL/dθ_j for every pixel. The tool calibration fits a few
// tool parameters that move every groove of the card at once; this gives the Jacobian columns of
// its least-squares fit from one pass of the engine, where finite differences need one render per
// parameter.
//
// The pair integral is the forward's own code in dual numbers (SA_DUAL, inc/real.glsl), its 7
// partials used as the 7 directions: each scratch's w, d and alpha enter as dual numbers whose
// partials are their tangents (the endpoints are constants). Per pixel, with the forward's
// coverage (cov_raw, read after the forward pass of the same submission),
//   dL/dθ = scale / S_P (sum_k dI_k/dθ - [cov < 1] D_flat sum_k dA_k/dθ)
// (see grad.comp). Work layout, order and passes are the forward's (inc/tile_loop.glsl); the
// per-pixel sums carry across passes in the output buffer, which the last pass overwrites with
// dL/dθ. No atomics on floats: results are bit-reproducible.
#extension GL_GOOGLE_include_directive : require
#ifndef SA_DUAL
#error tangent.comp is built with SA_DUAL (engine/src/render/kernels.rs)
#endif
#include "inc/common.glsl"
#include "inc/pixel.glsl"
#include "inc/patch_ndf.glsl"

layout(local_size_x = 16, local_size_y = 16) in;
layout(std430, binding = 0) readonly buffer Views { ViewGPU views[]; };
layout(std430, binding = 1) readonly buffer Scratches { ScratchGPU scr[]; };
layout(std430, binding = 2) readonly buffer Offsets { uint offs[]; };
layout(std430, binding = 3) readonly buffer List { uint list[]; };
// Per scratch 6 vec4: the tangents of w (directions 0-3, 4-6), of d, of alpha.
layout(std430, binding = 4) readonly buffer Seeds { vec4 seeds[]; };
layout(std430, binding = 5) readonly buffer Coverage { float cov_raw[]; };
// Per pixel 4 vec4: between passes sum dI (0-3, 4-6) and sum dA (0-3, 4-6); after the last pass
// dL/dθ (0-3, 4-6) in the first two.
layout(std430, binding = 6) buffer Tangents { vec4 tang[]; };
layout(std430, binding = 7) readonly buffer Views64 { ViewGPU64 views64[]; };
layout(std430, binding = 8) readonly buffer Lights { float intensity[]; };
layout(std430, binding = 9) buffer Stats { uint stats[]; };  // [5], [6] (inc/limits.glsl)

#include "inc/shade_push.glsl"

// Queue entries per round: 64 bytes of results each; 128 keeps the kernel within 32 KiB of
// shared memory.
const uint QCAP = 128u;
#include "inc/tile_loop.glsl"

shared vec4 sh_ends[CHUNK];
shared vec4 sh_shape[CHUNK];
shared uint sh_idx[CHUNK];
shared vec4 sh_r[4u * QCAP];       // per entry: dI (0-3, 4-6), dA (0-3, 4-6)

// This pixel's sums.
vec4 dI0 = vec4(0.0), dI1 = vec4(0.0), dA0 = vec4(0.0), dA1 = vec4(0.0);

void chunk_begin(uint lid) {}
void chunk_end(uint lid, uint c0, uint cnt) {}

void scratch_loaded(uint k, uint index, ScratchGPU S) {
    sh_ends[k] = S.ends;
    sh_shape[k] = S.shape;
    sh_idx[k] = index;
}

void pair_eval(uint i, uint px, uint k, bool fast) {
    vec4 E = sh_ends[k], S = sh_shape[k];
    uint b = 6u * sh_idx[k];
    vec2 fp[4];
    pixel_footprint(px, fp);
    Dual w = Dual(S.x, seeds[b], seeds[b + 1u].xyz);
    Dual d = Dual(S.y, seeds[b + 2u], seeds[b + 3u].xyz);
    Dual a = Dual(S.z, seeds[b + 4u], seeds[b + 5u].xyz);
    Dual I, A;
    pair_from_params(rc(E.x), rc(E.y), rc(E.z), rc(E.w), w, d, a, fp, sh_h[px].xyz, fast, I, A);
    sh_r[4u * i] = I.g0;
    sh_r[4u * i + 1u] = vec4(I.g1, 0.0);
    sh_r[4u * i + 2u] = A.g0;
    sh_r[4u * i + 3u] = vec4(A.g1, 0.0);
}

void add_entries(uint lo, uint hi, uint r0) {
    for (uint j = lo; j < hi; ++j) {
        uint e = 4u * (j - r0);
        dI0 += sh_r[e];
        dI1 += sh_r[e + 1u];
        dA0 += sh_r[e + 2u];
        dA1 += sh_r[e + 3u];
    }
}

// My results: fast entries, then the others (the forward's order).
void round_accumulate(uint lid, uint r0, uint n, uint cnt, uvec2 fmask, uint fbase, uvec2 gmask, uint gbase) {
    add_entries(max(fbase, r0), min(fbase + uint(bitCount(fmask.x) + bitCount(fmask.y)), r0 + QCAP), r0);
    add_entries(max(gbase, r0), min(gbase + uint(bitCount(gmask.x) + bitCount(gmask.y)), r0 + QCAP), r0);
}

void main() {
    uint tile = gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x;
    if (tile >= pc.n_tiles) return;
    uint start, end, n_chunks, begin, stop;
    tile_list(tile, start, end, n_chunks);
    // Pass 0 runs for every tile (it writes even an empty tile's pixels); later passes only for
    // tiles with chunks left. Uniform across the workgroup.
    if (!pass_range(start, end, pc.pass, pc.chunks_per_pass, begin, stop)) return;
    if (pc.pass == 0u && gl_LocalInvocationIndex == 0u) {
        uint covered = pc.chunks_per_pass == 0xFFFFFFFFu ? 0xFFFFFFFFu : pc.chunks_per_pass * pc.n_passes;
        if (n_chunks > covered) atomicOr(stats[5], 1u);
    }
    uvec2 t0;
    uint vi = tile_view(tile, t0);
    ViewGPU V = views[vi];
    uvec2 ij = t0 + tile_pixel(gl_LocalInvocationIndex);
    bool inside = ij.x < V.dims.x && ij.y < V.dims.y;
    uint lid = gl_LocalInvocationIndex;
    uint pix = V.base.y + ij.y * V.dims.x + ij.x;

    PixelSetup P = pixel_setup(V, views64[vi], intensity[vi], ij, pc.half_plate, pc.alpha_s, pc.f0);
    bool live = inside && P.on_plate && P.scale > 0.0;
    store_pixel(lid, P, 0.0);
    if (begin > start && inside) {  // an earlier pass did the chunks before `begin`
        dI0 = tang[4u * pix];
        dI1 = tang[4u * pix + 1u];
        dA0 = tang[4u * pix + 2u];
        dA1 = tang[4u * pix + 3u];
    }
    uint cand = 0u;
    tile_loop(begin, stop, V, t0, lid, live, P, cand);
    if (loop_limit_hit(pc.sentinel)) { atomicOr(stats[6], 1u); atomicOr(stats[5], 1u); }
    if (!inside) return;
    if (stop < end) {  // a later pass goes on from here (uniform)
        tang[4u * pix] = dI0;
        tang[4u * pix + 1u] = dI1;
        tang[4u * pix + 2u] = dA0;
        tang[4u * pix + 3u] = dA1;
        return;
    }
    vec4 g0 = vec4(0.0), g1 = vec4(0.0);
    if (live) {
        float fa = cov_raw[pix] < 1.0 ? P.d_flat : 0.0;
        g0 = P.scale * P.inv_sp * (dI0 - fa * dA0);
        g1 = P.scale * P.inv_sp * (dI1 - fa * dA1);
    }
    tang[4u * pix] = g0;
    tang[4u * pix + 1u] = vec4(g1.xyz, 0.0);
}
