#version 450
// Forward renderer: pixel values L of engine/docs/model.md section 5 for every view. One workgroup per 16x16
// tile, one thread per pixel; the tile loop (chunks, block culling, the pair queue) is
// inc/tile_loop.glsl, the pair integral inc/patch_ndf.glsl. Queue entries are integrated by all
// threads side by side, then every pixel adds its own results in a fixed order (its fast-path
// pairs, then the others, each in scratch order), so renders are bit-reproducible.
#extension GL_GOOGLE_include_directive : require
#include "inc/common.glsl"
#include "inc/pixel.glsl"
#include "inc/patch_ndf.glsl"

layout(local_size_x = 16, local_size_y = 16) in;
// Its bindings: inc/shade_bindings.glsl (writes the image, the coverage, the carry between
// passes and, with SA_STORE_PAIRS, the queue of every chunk for the backward to replay).
#define SA_SHADE_FORWARD
#include "inc/shade_bindings.glsl"
#define SA_STORE_PAIRS

// Queue entries integrated per round. 1024 (about 28 KiB of shared memory in all, within
// lavapipe's 32 KiB) holds a typical chunk's pairs in one round: fewer barriers and queue passes
// than 512 (M forward ~10% faster on lavapipe, examples/ab_kernels).
const uint QCAP = 1024u;
#include "inc/tile_loop.glsl"

shared vec2 sh_res[QCAP];          // (I, A)
shared uint sh_pairs;

// This pixel's sums over its pairs (sum_k I_k, sum_k A_k, overlapping pairs).
float dp = 0.0, cov = 0.0;
uint pairs = 0u;

#ifdef SA_CULL_PAIRS
float cull_kept() { return dp; }
shared uint sh_culled;
#endif

void chunk_begin(uint lid) {}
void chunk_end(uint lid, uint c0, uint cnt) {}

void pair_eval(uint i, uint px, uint k, bool fast) {
    uint si = chunk_scratch(k);
    vec4 ca = rec_cull_a(si), cb = rec_cull_b(si);  // p0, t; len, w, s_e, alpha
    vec2 fp[4];
    vec3 h;
    pixel_pair_data(px, fp, h);
#ifdef SA_ARCS
    g_arc_k = rec_shape(si).w;  // an arc's chord weight (patch_ndf.glsl), 0 for a straight scratch
#endif
    float I, A;
    pair_integrate(ca.x, ca.y, ca.z, ca.w, cb.x, cb.y, cb.z, cb.w, fp, h, fast, I, A);
    sh_res[i] = vec2(I, A);
}

// My results of slots [lo, hi) (a loop tested at the bottom, see tile_loop.glsl).
void add_results(uint lo, uint hi, uint r0) {
    uint j = lo;
    if (j < hi) do {
        vec2 ra = sh_res[j - r0];
        if (ra.y > 0.0) { ++pairs; dp += ra.x; cov += ra.y; }
        ++j;
    } while (j < hi);
}

// My results: fast entries, then the others (a fixed order).
void round_accumulate(uint lid, uint r0, uint n, uint cnt, uvec2 fmask, uint fbase, uvec2 gmask, uint gbase) {
    add_results(max(fbase, r0), min(fbase + uint(bitCount(fmask.x) + bitCount(fmask.y)), r0 + QCAP), r0);
    add_results(max(gbase, r0), min(gbase + uint(bitCount(gmask.x) + bitCount(gmask.y)), r0 + QCAP), r0);
}

void main() {
    uint tile = gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x;
    if (tile >= pc.n_tiles) return;  // uniform across the workgroup
    uint start, end, n_chunks, begin, stop;
    tile_list(tile, start, end, n_chunks);
    // Pass 0 runs for every tile (it writes even an empty tile's pixels); later passes only for
    // tiles with chunks left. Uniform across the workgroup.
    if (!pass_range(start, end, pc.pass, pc.chunks_per_pass, begin, stop)) return;
    uint lid = gl_LocalInvocationIndex;
    if (pc.pass == 0u && lid == 0u) {
        atomicMax(stats[4], n_chunks);
        uint covered = pc.chunks_per_pass == 0xFFFFFFFFu ? 0xFFFFFFFFu : pc.chunks_per_pass * pc.n_passes;
        if (n_chunks > covered) atomicOr(stats[5], 1u);
        if (tile == 0u) {
            stats[2] = offs[pc.n_tiles * pc.n_groups];  // total tile-list entries
            if (stats[2] > pc.capacity) atomicOr(stats[5], 1u);
        }
    }
    uvec2 t0;
    uint vi = tile_view(tile, t0);
    ViewGPU V = views[vi];
    uvec2 ij = t0 + tile_pixel(gl_LocalInvocationIndex);
    bool inside = ij.x < V.dims.x && ij.y < V.dims.y;
    uint pix = V.base.y + ij.y * V.dims.x + ij.x;
    if (lid == 0u) sh_pairs = 0u;
#ifdef SA_CULL_PAIRS
    if (lid == 0u) sh_culled = 0u;
#endif

    PixelSetup P = pixel_from_record(V, ij);
    bool live = inside && P.on_plate && P.scale > 0.0;
    store_pixel(lid, V, t0, vec2(0.0));
    uint cand = 0u;
    if (begin > start && inside) {  // an earlier pass did the chunks before `begin`
        vec4 c = carry[pix];
        dp = c.x;
        cov = c.y;
        pairs = floatBitsToUint(c.z);
        cand = floatBitsToUint(c.w);
    }
    tile_loop(begin, stop, V, t0, lid, live, P, cand);
    if (stop < end) {  // a later pass goes on from here (uniform)
        if (inside) carry[pix] = vec4(dp, cov, uintBitsToFloat(pairs), uintBitsToFloat(cand));
        if (loop_limit_hit(pc.sentinel)) { atomicOr(stats[3], 1u); atomicOr(stats[5], 1u); }
        return;
    }

    if (live) atomicAdd(sh_pairs, pairs);
#ifdef SA_CULL_PAIRS
    if (cull_count > 0u) atomicAdd(sh_culled, cull_count);
#endif
    barrier();
    if (lid == 0u) {  // 64-bit counters: a carry into the high word (inc/limits.glsl)
        uint old = atomicAdd(stats[1], sh_pairs);
        if (old + sh_pairs < old) atomicAdd(stats[10], 1u);
#ifdef SA_CULL_PAIRS
        old = atomicAdd(stats[11], sh_culled);
        if (old + sh_culled < old) atomicAdd(stats[12], 1u);
#endif
    }
    // candidates: one atomic per live thread would serialize; reduce through sh_base
    sh_base[lid] = live ? cand : 0u;
    barrier();
    if (lid == 0u) {
        uint s = 0u;
        for (uint i = 0u; i < 256u; ++i) s += sh_base[i];  // <= 256 x 64 x chunks: no wrap
        uint old = atomicAdd(stats[0], s);
        if (old + s < old) atomicAdd(stats[8], 1u);
    }
    if (loop_limit_hit(pc.sentinel)) { atomicOr(stats[3], 1u); atomicOr(stats[5], 1u); }
    if (!inside) return;
    float L = 0.0;
    cov_raw[pix] = live ? cov * P.inv_sp : 0.0;
    if (live) {
        float c = min(1.0, cov * P.inv_sp);
        L = P.scale * (dp * P.inv_sp + (1.0 - c) * P.d_flat);
    }
    img[pix] = L;
}
