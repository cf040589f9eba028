#version 450
// Directional derivatives of the pixel values (a Jacobian-vector product): for up to 7
// directions j in the space of every scratch's (w, d, alpha), given per scratch the tangents
// (dw/dθ_j, dd/dθ_j, dalpha/dθ_j), writes dL/dθ_j for every pixel. The tool calibration fits a
// few tool parameters that move every groove of the card at once; this gives the Jacobian
// columns of its least-squares fit from one pass of the engine, where finite differences need
// one render per parameter.
//
// Per pixel, L = scale (D_P + (1 - min(1, cov)) D_flat) with D_P = sum_k I_k / S_P and
// cov = sum_k A_k / S_P (the forward's coverage, cov_raw, read after the forward pass of the same
// submission), so dL/dθ = sum_k (gI dI_k/dθ + gA dA_k/dθ) with gI = scale / S_P and
// gA = -[cov < 1] gI D_flat. Per pair, the backward's reverse sweep (inc/pair_adjoint.glsl, the
// closed form's hand-written adjoint, through the clipping) gives g_k = gI dI_k/d(w, d, alpha) +
// gA dA_k/d(w, d, alpha) at once; each direction is then a dot product with the scratch's
// tangents. So any number of directions costs one reverse sweep per pair (7 per pass here).
// Work layout, order and passes are the forward's (inc/tile_loop.glsl); the per-pixel sums carry
// across passes in the output buffer. No atomics on floats: results are bit-reproducible.
//
// The build with SA_MOMENTS computes no derivatives: per pixel, the first moments of its light
// about the footprint's centre, in the render's pixels (engine/render/src/tangent.rs,
// `Renderer::moments`). Each pair adds the groove's light gI I_k times the offset of that
// light's centroid in F ∩ R_k from F's centre, and the plate light its area covers, gA A_k
// (negative), times the area's centroid's (inc/centroid.glsl); a blur applied to the image can
// then place each pixel's light where it falls within the pixel, to first order, instead of at
// its centre.
#extension GL_GOOGLE_include_directive : require
#ifndef SA_EDGE_ADJOINT
#error tangent.comp is built with SA_EDGE_ADJOINT (engine/render/src/kernels.rs)
#endif
#include "inc/common.glsl"
#include "inc/pixel.glsl"
#include "inc/patch_ndf.glsl"
#include "inc/pair_adjoint.glsl"

layout(local_size_x = 16, local_size_y = 16) in;
// Its bindings: inc/shade_bindings.glsl (reads per scratch the tangents of w, d and alpha and the
// forward's coverage; adds dL/dθ_j per pixel into the tangents, summed over the passes).
#define SA_SHADE_TANGENT
#include "inc/shade_bindings.glsl"

// Queue entries per round: 32 bytes of results each; 256 keeps the kernel within 32 KiB of
// shared memory.
const uint QCAP = 256u;
#include "inc/tile_loop.glsl"
#ifdef SA_MOMENTS
#include "inc/centroid.glsl"
#endif

shared vec4 sh_r[2u * QCAP];       // per entry: dL/dθ_j (0-3, 4-6)

// This pixel's sums.
vec4 acc0 = vec4(0.0), acc1 = vec4(0.0);

void chunk_begin(uint lid) {}
void chunk_end(uint lid, uint c0, uint cnt) {}

void pair_eval(uint i, uint px, uint k, bool fast) {
    vec2 fp[4];
    vec3 h;
    pixel_pair_data(px, fp, h);
    vec2 gp = sh_pv[px];  // gI, gA
#ifdef SA_MOMENTS
    uint sm = chunk_scratch(k);
    vec4 ca = rec_cull_a(sm), cb = rec_cull_b(sm);  // p0, t; len, w, s_e, alpha
    float I, A;
    pair_integrate(ca.x, ca.y, ca.z, ca.w, cb.x, cb.y, cb.z, cb.w, fp, h, fast, I, A);
    // The groove's light at its centroid, less the plate light its area covers at the area's.
    vec2 ml = vec2(0.0), ma = vec2(0.0);
    if (A > 0.0) covered_offsets(ca, cb, fp, h, ml, ma);
    sh_r[2u * i] = vec4(gp.x * I * ml + gp.y * A * ma, gp.x * I + gp.y * A, 0.0);
    sh_r[2u * i + 1u] = vec4(0.0);
#else
    vec4 d0;
    vec3 g;
    uint si = chunk_scratch(k);
    pair_adjoint(rec_ends(si), rec_shape(si), fp, h, gp.x, gp.y, fast, d0, g);
    uint b = 6u * si;
    // dL/dθ_j = g . (dw, dd, dalpha)/dθ_j
    sh_r[2u * i] = g.x * seeds[b] + g.y * seeds[b + 2u] + g.z * seeds[b + 4u];
    sh_r[2u * i + 1u] = g.x * seeds[b + 1u] + g.y * seeds[b + 3u] + g.z * seeds[b + 5u];
#endif
}

// (Tested at the bottom: see tile_loop in inc/tile_loop.glsl.)
void add_entries(uint lo, uint hi, uint r0) {
    uint j = lo;
    if (j < hi) do {
        acc0 += sh_r[2u * (j - r0)];
        acc1 += sh_r[2u * (j - r0) + 1u];
        ++j;
    } while (j < hi);
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

    PixelSetup P = pixel_from_record(V, ij);
    bool live = inside && P.on_plate && P.scale > 0.0;
    float gI = 0.0, gA = 0.0;
    if (live) {
        gI = P.scale * P.inv_sp;
        gA = cov_raw[pix] < 1.0 ? -gI * P.d_flat : 0.0;
    }
    store_pixel(lid, V, t0, vec2(gI, gA));
    if (begin > start && inside) {  // an earlier pass did the chunks before `begin`
#ifdef SA_MOMENTS
        acc0.xy = moment_load(pix);
#else
        acc0 = tang[2u * pix];
        acc1 = tang[2u * pix + 1u];
#endif
    }
    uint cand = 0u;
    tile_loop(begin, stop, V, t0, lid, live, P, cand);
    if (loop_limit_hit(pc.sentinel)) { atomicOr(stats[6], 1u); atomicOr(stats[5], 1u); }
    if (!inside) return;
#ifdef SA_MOMENTS
    // The tile's last pass: the moments from the plate's (x, y) into the render's pixels; two
    // floats per pixel (inc/centroid.glsl).
    if (stop >= end) acc0.xy = live ? plate_to_pixels(pix, acc0.xy) : vec2(0.0);
    moment_store(pix, acc0.xy);
    return;
#endif
    tang[2u * pix] = acc0;
    tang[2u * pix + 1u] = vec4(acc1.xyz, 0.0);
}
