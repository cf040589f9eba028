#version 450
// Backward pass of forward.comp: gradients of a loss E with respect to every scratch's
// (x0, y0, x1, y1, w, d, alpha), given dE/dL per pixel. Two builds (engine/render/src/kernels.rs):
//   SA_EDGE_ADJOINT (Mode::Backward, the default): reverse mode, inc/pair_adjoint.glsl;
//   SA_DUAL (Mode::BackwardDual, and integrators without an adjoint): forward-mode dual numbers
//   through the forward's own code, the test oracle of the first.
//
// Per pixel, L = scale (D_P + (1 - min(1, cov)) D_flat) with D_P = sum_k I_k / S_P and
// cov = sum_k A_k / S_P, so for scratch k
//   dL/dθ = scale / S_P (dI_k/dθ - [cov < 1] D_flat dA_k/dθ).
// Only gI dI_k/dθ + gA dA_k/dθ is needed (gI = dE/dL scale / S_P, gA = -[cov < 1] gI D_flat), a
// scalar per pair: reverse mode gets all 7 derivatives from one forward and one reverse sweep of
// the pair (the clipping of footprint and carved rectangle moves with the endpoints, width and
// depth, and is differentiated with it); dual numbers carry 7 tangents through every operation.
//
// Work layout and order are forward.comp's (the tile loop of inc/tile_loop.glsl). With SA_REPLAY
// (the default once a scene's forward stores its queues, see KernelSet::replay) the pairs are
// not searched again: replay_stream walks the queues the forward stored, in the same order (a
// scratch's entries in the same order: rounds may hold the end of one chunk and the start of the
// next), so the gradients are bit-identical to the search's (tests/replay.rs). For each
// chunk, thread k < 64 adds scratch k's per-pair contributions in queue order (a per-round list
// of its entries, see round_accumulate) and writes one
// partial gradient per tile-list entry; grad_reduce.comp then adds a scratch's partials in
// enumeration order. No float atomics: gradients are bit-reproducible.
#extension GL_GOOGLE_include_directive : require
#if !defined(SA_DUAL) && !defined(SA_EDGE_ADJOINT)
#error grad.comp needs SA_EDGE_ADJOINT (reverse mode) or SA_DUAL (dual numbers), see engine/render/src/kernels.rs
#endif
#include "inc/common.glsl"
#include "inc/pixel.glsl"
#include "inc/patch_ndf.glsl"
// Reverse mode where the integrator has an adjoint edge integral (closed form), else dual numbers.
#if defined(SA_HAS_EDGE_ADJ) && !defined(SA_DUAL)
#define SA_REVERSE
#include "inc/pair_adjoint.glsl"
#elif !defined(SA_DUAL)
#error this integrator has no reverse-mode edge integral: build grad.comp with SA_DUAL
#endif

layout(local_size_x = 16, local_size_y = 16) in;
// Its bindings: inc/shade_bindings.glsl (reads dE/dL, the forward's coverage and, with SA_REPLAY,
// the forward's stored queues, replayed instead of searching the pairs again: replay_stream
// below; writes 2 partial gradients per tile-list entry).
#define SA_SHADE_BACKWARD
#include "inc/shade_bindings.glsl"

// Queue entries per round: 256 fits 32 KiB of shared memory (lavapipe's limit); the host passes
// GRAD_QCAP = 512 on devices with at least 48 KiB (fewer rounds and barriers per chunk).
#ifndef GRAD_QCAP
#define GRAD_QCAP 256
#endif
const uint QCAP = GRAD_QCAP;
#include "inc/tile_loop.glsl"

shared vec4 sh_c0[QCAP];           // per-pair contribution d/d(x0, y0, x1, y1)
shared vec4 sh_c1[QCAP];           // d/d(w, d, alpha); w (bits): the chunk scratch, then the list link
#ifdef SA_ARCS
shared float sh_ck[QCAP];          // d/d(kappa) of an arc's chord (the dual build with SA_ARCS)
#endif
// Scratches a round can hold: one chunk's in the search; in the replay the end of one chunk and
// the start of the next, the second's scratches numbered k + CHUNK (chunk_scratch).
#ifdef SA_REPLAY
const uint NK = 2u * CHUNK;
#else
const uint NK = CHUNK;
#endif
shared uint sh_head[NK];           // per scratch of the round: its first entry in the round
#ifdef SA_PARALLEL_LINKS
shared uint sh_tail[NK];           // per scratch of the round: its last entry (where it has one)
#endif
const uint LIST_END = 0xFFFFFFFFu;  // the end of a scratch's list (sh_head, the links)
// Thread k < NK: scratch k's contributions so far (private: only thread k touches them).
vec4 acc0 = vec4(0.0), acc1 = vec4(0.0);

void chunk_begin(uint lid) {
    acc0 = vec4(0.0);
    acc1 = vec4(0.0);
}

void pair_eval(uint i, uint px, uint k, bool fast) {
    uint si = chunk_scratch(k);
    vec4 E = rec_ends(si), S = rec_shape(si);  // raw scratch parameters
    vec2 fp[4];
    vec3 h;
    pixel_pair_data(px, fp, h);
    vec2 g = sh_pv[px];  // gI, gA: coefficients of dI and dA
    vec4 r0;
    vec3 r1;
#ifdef SA_REVERSE
    pair_adjoint(E, S, fp, h, g.x, g.y, fast, r0, r1);
#else
    Dual I, A;
#ifdef SA_ARCS
    // k = kappa w / 2 (patch_ndf.glsl): its derivative through w, and d/dkappa as the 8th partial.
    g_arc_k = mul(seed(2.0 * S.w / S.x, 7), mul(0.5, seed(S.x, 4)));
#endif
    pair_from_params(seed(E.x, 0), seed(E.y, 1), seed(E.z, 2), seed(E.w, 3), seed(S.x, 4), seed(S.y, 5), seed(S.z, 6),
                     fp, h, fast, I, A);
    r0 = g.x * I.g0 + g.y * A.g0;
#ifdef SA_ARCS
    vec4 r1k = g.x * I.g1 + g.y * A.g1;
    r1 = r1k.xyz;
    sh_ck[i] = g.x == 0.0 ? 0.0 : r1k.w;
#else
    r1 = g.x * I.g1 + g.y * A.g1;
#endif
#endif
#ifdef SA_REPLAY
    // A pixel with a zero seed (gI = 0, so gA = 0) has no pairs in tile_loop's queue; here it
    // adds exact zeros, so sums (and bits) are the same (never -0: a sum that starts at +0 and
    // adds +0 stays +0).
    if (g.x == 0.0) { r0 = vec4(0.0); r1 = vec3(0.0); }
#endif
    sh_c0[i] = r0;
    sh_c1[i] = vec4(r1, uintBitsToFloat(k));  // w: the chunk scratch, replaced by the list link
}

#ifdef SA_PARALLEL_LINKS
// The chunk scratch of the round's entry i (pair_eval left it in the 4th float of sh_c1).
uint entry_scratch(uint i) { return floatBitsToUint(sh_c1[i].w); }

// link_lists's successor of entry i: the next entry of its scratch, or LIST_END after its last.
uint successor(uint i) {
    uint kk = entry_scratch(i);
    if (i == sh_tail[kk]) return LIST_END;
    uint j = i + 1u;
    while (entry_scratch(j) != kk) ++j;  // ends: a later entry of kk exists
    return j;
}

// The lists of link_lists below built by every thread at once (GPUs, where thread 0 alone walking
// the round left the others waiting): each scratch's first and last entries by atomicMin and
// atomicMax (whose results do not depend on the order they run in), each entry's successor by a
// scan forward to the next entry of its scratch. The same lists, so the same sums and bits
// (tests/replay.rs).
void link_lists(uint lid, uint n) {
    if (lid < NK) { sh_head[lid] = LIST_END; sh_tail[lid] = 0u; }
    barrier();
    uint i = lid;
    if (i < n) do {
        atomicMin(sh_head[entry_scratch(i)], i);
        atomicMax(sh_tail[entry_scratch(i)], i);
        i += 256u;
    } while (i < n);
    barrier();
    // Every successor is found before any link replaces a scratch that a scan reads.
    uint nx[QCAP / 256u];
    for (uint r = 0u; r < QCAP / 256u; ++r) nx[r] = lid + 256u * r < n ? successor(lid + 256u * r) : LIST_END;
    barrier();
    for (uint r = 0u; r < QCAP / 256u; ++r) {
        if (lid + 256u * r < n) sh_c1[lid + 256u * r].w = uintBitsToFloat(nx[r]);
    }
}
#else
// Thread 0 links each scratch's entries into a list in queue order (one pass over the round,
// backwards; the link replaces the chunk scratch pair_eval left in the 4th float of sh_c1).
void link_lists(uint lid, uint n) {
    if (lid == 0u) {
        uint k = 0u;
        do { sh_head[k] = LIST_END; ++k; } while (k < NK);
        uint i = n;
        if (i > 0u) do {
            --i;
            uint kk = floatBitsToUint(sh_c1[i].w);
            sh_c1[i].w = uintBitsToFloat(sh_head[kk]);
            sh_head[kk] = i;
        } while (i > 0u);
    }
}
#endif

// Scratch k's contributions of this round, in queue order, into thread k's private acc0/acc1:
// the round's entries linked into a list per scratch in queue order (link_lists), thread k then
// walks only its own entries, instead of every thread testing every entry. The loops test at
// the bottom: on CPU drivers one that tests at the top runs its body once more with every lane
// off.
void round_accumulate(uint lid, uint r0, uint n, uint cnt, uvec2 fmask, uint fbase, uvec2 gmask, uint gbase) {
    link_lists(lid, n);
    barrier();
    if (lid < NK) {  // a scratch with no entries has an empty list
        uint i = sh_head[lid];
        if (i != LIST_END) do {
            vec4 c1 = sh_c1[i];
            acc0 += sh_c0[i];
#ifdef SA_ARCS
            acc1 += vec4(c1.xyz, sh_ck[i]);
#else
            acc1 += vec4(c1.xyz, 0.0);
#endif
            i = floatBitsToUint(c1.w);
        } while (i != LIST_END);
    }
}

void chunk_end(uint lid, uint c0, uint cnt) {
    if (lid < cnt) {
        partial[2u * (c0 + lid)] = acc0;
        partial[2u * (c0 + lid) + 1u] = acc1;
    }
}

#ifdef SA_REPLAY

// The stored record of the chunk at tile-list entry c0: where its entries start, how many, how
// many of them fast. A chunk the forward could not store counts as empty and marks the pass
// incomplete (stats[5], and bit 0 of stats[14]): the host then grows the store and redoes it.
uint chunk_record(uint c0, out uint base, out uint nfast) {
    base = pstore[2u * c0];
    uint packed = pstore[2u * c0 + 1u];
    nfast = packed & 0xFFFFu;
    if (base == STORE_MISSING) {  // uniform: every thread read the same words
        if (gl_LocalInvocationIndex == 0u) { atomicOr(stats[5], 1u); atomicOr(stats[STAT_STORE_FLAGS], 1u); }
        return 0u;
    }
    return packed >> 16;
}

// Chunk c0 of the pass [begin, end) is done: its scratches' threads (CHUNK of them, the even or
// the odd chunks' half of threads 0..NK) write its partial gradients and start afresh.
void close_chunk(uint lid, uint begin, uint end, uint c0) {
    uint par = ((c0 - begin) / CHUNK) & 1u, k = lid & (CHUNK - 1u);
    if (lid < NK && (lid / CHUNK) == par) {
        if (k < min(CHUNK, end - c0)) {
            partial[2u * (c0 + k)] = acc0;
            partial[2u * (c0 + k) + 1u] = acc1;
        }
        acc0 = vec4(0.0);
        acc1 = vec4(0.0);
    }
}

// Closes chunk ca of [begin, end) if its `total` entries are all done (pa of them) and every empty
// chunk after it, and reads the record of the chunk the stream goes on with (ca >= end: none
// left). Tested at the bottom, behind an `if` (see tile_loop in inc/tile_loop.glsl).
void close_done(uint lid, uint begin, uint end, inout uint ca, inout uint pa, inout uint total, inout uint base,
                inout uint nfast) {
    if (pa >= total) do {
        close_chunk(lid, begin, end, ca);
        ca += CHUNK;
        pa = 0u;
        if (ca < end) total = chunk_record(ca, base, nfast);
    } while (ca < end && pa >= total);
}

// The replay of the forward's queues over the chunks [begin, end) of a tile's list, as one stream:
// a round takes QCAP entries, the rest of one chunk and then the start of the next, so the
// rounds stay full (on CPU drivers every SIMD group runs a round's code, full or not). Each
// scratch's entries are visited in the forward's order, chunk by chunk, so its sum is the one
// a chunk-by-chunk walk gives. Pixels whose seed is zero are in the forward's queue but not in
// tile_loop's (their pairs add exact zeros: pair_eval's job).
void replay_stream(uint begin, uint end, uint lid) {
    // A wrapped counter gave later chunks bases that overlap earlier ones: nothing is trusted.
    if (lid == 0u && (stats[STAT_STORE_FLAGS] & 2u) != 0u) atomicOr(stats[5], 1u);
    uint ca = begin, pa = 0u;  // the chunk being replayed and its entries done
    uint base_a, fast_a, total_a = chunk_record(ca, base_a, fast_a);
    close_done(lid, begin, end, ca, pa, total_a, base_a, fast_a);  // empty chunks at the start
    if (ca < end) do {  // tested at the bottom (see tile_loop)
        uint na = min(QCAP, total_a - pa);
        uint cb = ca + CHUNK, base_b = 0u, fast_b = 0u, nb = 0u;
        if (na < QCAP && cb < end) nb = min(QCAP - na, chunk_record(cb, base_b, fast_b));
        bool odd = (((ca - begin) / CHUNK) & 1u) != 0u;
        g_chunk = odd ? cb : ca;
        g_chunk_hi = odd ? ca : cb;
        uint n = na + nb;
        barrier();  // the previous round's walk is done with the shared arrays
        uint i = lid;
        if (i < n) do {
            bool in_a = i < na;
            uint idx = in_a ? pa + i : i - na;
            uint e = texelFetch(store_tex, int(2u * pc.capacity + (in_a ? base_a : base_b) + idx)).x;
            uint k = (e & 255u) + ((in_a != odd) ? 0u : CHUNK);  // the odd chunk's scratches: k + CHUNK
            pair_eval(i, e >> 8, k, idx < (in_a ? fast_a : fast_b));
            i += 256u;
        } while (i < n);
        barrier();
        round_accumulate(lid, 0u, n, NK, uvec2(0u), 0u, uvec2(0u), 0u);
        pa += na;
        if (nb > 0u) {  // chunk ca ended within the round: go on with cb
            close_chunk(lid, begin, end, ca);
            ca = cb;
            pa = nb;
            total_a = chunk_record(ca, base_a, fast_a);
        }
        close_done(lid, begin, end, ca, pa, total_a, base_a, fast_a);
    } while (ca < end);
}
#endif

void main() {
    uint tile = gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x;
    if (tile >= pc.n_tiles) return;
    uint start, end, n_chunks, begin, stop;
    tile_list(tile, start, end, n_chunks);
    // Each pass writes the partial gradients of its chunks; nothing carries over.
    if (!pass_range(start, end, pc.pass, pc.chunks_per_pass, begin, stop) || begin == end) return;
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

    PixelSetup P = pixel_from_record(V, ij);
    bool live = inside && P.on_plate && P.scale > 0.0;
    float gI = 0.0, gA = 0.0;
    if (live) {
        uint pix = V.base.y + ij.y * V.dims.x + ij.x;
        float g = dl[pix] * P.scale * P.inv_sp;
        gI = g;
        gA = cov_raw[pix] < 1.0 ? -g * P.d_flat : 0.0;
        live = g != 0.0;
    }
    store_pixel(lid, V, t0, vec2(gI, gA));
#ifdef SA_REPLAY
    replay_stream(begin, stop, lid);
#else
    uint cand = 0u;
    tile_loop(begin, stop, V, t0, lid, live, P, cand);
#endif
    if (loop_limit_hit(pc.sentinel)) { atomicOr(stats[6], 1u); atomicOr(stats[5], 1u); }
}
