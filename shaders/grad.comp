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
// of its entries, see round_accumulate; on GPUs masks, and two threads per scratch with
// SA_WALK_SPLIT: kernels::Walk) and writes one partial gradient per tile-list entry;
// grad_reduce.comp then adds a scratch's partials in enumeration order. No float atomics:
// gradients are bit-reproducible on each build.
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

#if defined(SA_WALK_SPLIT) && !defined(SA_PARALLEL_LINKS)
#undef SA_WALK_SPLIT  // a variant of the masks' walk only
#endif
#ifdef SA_PARALLEL_LINKS
// Entry i's contribution: [2i] d/d(x0, y0, x1, y1), [2i + 1] d/d(w, d, alpha, kappa) (kappa: an
// arc's chord, the dual build with SA_ARCS; else 0).
shared vec4 sh_c[2u * QCAP];
#ifdef SA_WALK_SPLIT
#extension GL_KHR_shader_subgroup_shuffle : require
#endif
#else
shared vec4 sh_c0[QCAP];           // per-pair contribution d/d(x0, y0, x1, y1)
shared vec4 sh_c1[QCAP];           // d/d(w, d, alpha); w (bits): the chunk scratch, then the list link
#ifdef SA_ARCS
shared float sh_ck[QCAP];          // d/d(kappa) of an arc's chord (the dual build with SA_ARCS)
#endif
#endif
// Scratches a round can hold: one chunk's in the search; in the replay the end of one chunk and
// the start of the next, the second's scratches numbered k + CHUNK (chunk_scratch).
#ifdef SA_REPLAY
const uint NK = 2u * CHUNK;
#else
const uint NK = CHUNK;
#endif
#ifdef SA_PARALLEL_LINKS
// Per scratch of the round, a bit for each of its entries (MW words of 32 entries): set by the
// thread that evaluates the entry (pair_eval), read and cleared by the scratch's thread.
const uint MW = QCAP / 32u;
shared uint sh_mask[NK * MW];
#else
shared uint sh_head[NK];           // per scratch of the round: its first entry in the round
const uint LIST_END = 0xFFFFFFFFu;  // the end of a scratch's list (sh_head, the links)
#endif
// Thread k < NK: scratch k's contributions so far (private: only thread k touches them). With
// SA_WALK_SPLIT threads 2k and 2k + 1 each hold a share of scratch k's (see round_walk).
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
    float ck = 0.0;  // d/d(kappa): the dual build with SA_ARCS
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
    ck = g.x == 0.0 ? 0.0 : r1k.w;
#else
    r1 = g.x * I.g1 + g.y * A.g1;
#endif
#endif
#if defined(SA_REPLAY) || defined(SA_WALK_SPLIT)
    // A pixel with a zero seed (gI = 0, so gA = 0) has no pairs in tile_loop's queue; here it
    // adds exact zeros, so sums (and bits) are the same (never -0: a sum that starts at +0 and
    // adds +0 stays +0). The split walk's search queues them too, as the forward did: its shares
    // follow the entries' places in the chunk's queue, so they must be the forward's (the
    // replay's) places.
    if (g.x == 0.0) { r0 = vec4(0.0); r1 = vec3(0.0); ck = 0.0; }
#endif
#ifdef SA_PARALLEL_LINKS
    sh_c[2u * i] = r0;
    sh_c[2u * i + 1u] = vec4(r1, ck);
    atomicOr(sh_mask[k * MW + (i >> 5)], 1u << (i & 31u));
#else
    sh_c0[i] = r0;
    sh_c1[i] = vec4(r1, uintBitsToFloat(k));  // w: the chunk scratch, replaced by the list link
#ifdef SA_ARCS
    sh_ck[i] = ck;
#endif
#endif
}

#ifdef SA_PARALLEL_LINKS
// GPUs: no lists. Each entry's bit in its scratch's mask (set by pair_eval, seen after the
// round's barrier) orders a scratch's entries as the queue does, so scratch k's thread walks
// them in the order thread 0's lists give (the same sums, so the same bits: tests/replay.rs),
// and clears its words for the next round. Until 2026-11-30 every thread linked the lists, by
// atomicMin/atomicMax of each scratch's ends and a scan to each entry's successor: 40% of the
// backward on an H200 (engine/BENCHMARKS.md).
void mask_clear(uint lid) {
    for (uint w = lid; w < NK * MW; w += 256u) sh_mask[w] = 0u;
}

// Adds the entries of mask m (word w of the round) to acc0/acc1, in queue order.
void walk_bits(uint w, uint m) {
    if (m != 0u) do {
        uint i = 32u * w + uint(findLSB(m));
        m &= m - 1u;
        acc0 += sh_c[2u * i];
        acc1 += sh_c[2u * i + 1u];
    } while (m != 0u);
}

#ifdef SA_WALK_SPLIT
// Word w of the round holds run w + off of its chunk's queue (32 entries each), off for the
// scratches k < CHUNK and for k >= CHUNK (the replay's second chunk).
int g_off_lo = 0, g_off_hi = 0;
#endif

// Scratch k's entries of the round (its n places), in queue order, by thread k, which clears its
// mask words for the next round. With SA_WALK_SPLIT (kernels::Walk::Split, GPUs' default)
// threads 2k and 2k + 1 share scratch k's: each takes the words of the even or of the odd runs
// of 32 of the chunk's queue (counted from the chunk's start, not the round's, so the search and
// the replay give the same shares and the same bits), so the longest scratch's walk is about
// halved; the shares are added when the chunk closes (split_total), in another order than the
// CPU build's sums.
void round_walk(uint lid, uint n) {
    uint nw = (n + 31u) / 32u;
#ifdef SA_WALK_SPLIT
    if (lid < 2u * NK) {  // whole subgroups: NK is 64 or 128
        uint kk = lid >> 1;
        int off = kk < CHUNK ? g_off_lo : g_off_hi;
        for (uint w = uint((int(lid & 1u) - off) & 1); w < nw; w += 2u) {
            uint m = sh_mask[kk * MW + w];
            if (m != 0u) sh_mask[kk * MW + w] = 0u;
            walk_bits(w, m);
        }
    }
#else
    if (lid < NK) {
        for (uint w = 0u; w < nw; ++w) {
            uint m = sh_mask[lid * MW + w];
            if (m != 0u) sh_mask[lid * MW + w] = 0u;
            walk_bits(w, m);
        }
    }
#endif
}

#ifdef SA_WALK_SPLIT
// The two shares of scratch lid / 2 added (the same sum in both threads: a + b = b + a).
void split_total() {
    vec4 o0 = subgroupShuffleXor(acc0, 1u), o1 = subgroupShuffleXor(acc1, 1u);
    acc0 += o0;
    acc1 += o1;
}
#endif
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
// the round's entries linked into a list per scratch in queue order (link_lists; on GPUs the
// masks of round_walk instead), thread k then walks only its own entries, instead of every
// thread testing every entry. The loops test at
// the bottom: on CPU drivers one that tests at the top runs its body once more with every lane
// off.
void round_accumulate(uint lid, uint r0, uint n, uint cnt, uvec2 fmask, uint fbase, uvec2 gmask, uint gbase) {
#if defined(SA_DIAG_NO_ACCUM) || defined(SA_DIAG_NO_WALK)
    // Timing builds (kernels::grad_diagnostics, wrong gradients): one entry read per thread
    // keeps the stores of pair_eval alive.
#if !defined(SA_DIAG_NO_ACCUM) && !defined(SA_PARALLEL_LINKS)
    link_lists(lid, n);
    barrier();
#endif
#ifdef SA_PARALLEL_LINKS
    if (lid < NK && lid < n) { acc0 += sh_c[2u * lid]; acc1 += sh_c[2u * lid + 1u]; }
#else
    if (lid < NK && lid < n) { acc0 += sh_c0[lid]; acc1 += vec4(sh_c1[lid].xyz, 0.0); }
#endif
#elif defined(SA_PARALLEL_LINKS)
#if defined(SA_WALK_SPLIT) && !defined(SA_REPLAY)
    g_off_lo = int(r0 >> 5);  // the search's rounds hold one chunk, from its entry r0
#endif
    round_walk(lid, n);
#else
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
#endif
}

void chunk_end(uint lid, uint c0, uint cnt) {
#ifdef SA_WALK_SPLIT
    if (lid < 2u * NK) split_total();
    if (lid < 2u * cnt) partial[2u * c0 + lid] = (lid & 1u) == 0u ? acc0 : acc1;  // scratch lid / 2
#else
    if (lid < cnt) {
        partial[2u * (c0 + lid)] = acc0;
        partial[2u * (c0 + lid) + 1u] = acc1;
    }
#endif
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
    uint par = ((c0 - begin) / CHUNK) & 1u;
#ifdef SA_WALK_SPLIT
    uint kk = lid >> 1, k = kk & (CHUNK - 1u);  // thread lid: a share of scratch kk
    if ((kk / CHUNK) == par) {
        split_total();
        if (k < min(CHUNK, end - c0)) partial[2u * (c0 + k) + (lid & 1u)] = (lid & 1u) == 0u ? acc0 : acc1;
        acc0 = vec4(0.0);
        acc1 = vec4(0.0);
    }
#else
    uint k = lid & (CHUNK - 1u);
    if (lid < NK && (lid / CHUNK) == par) {
        if (k < min(CHUNK, end - c0)) {
            partial[2u * (c0 + k)] = acc0;
            partial[2u * (c0 + k) + 1u] = acc1;
        }
        acc0 = vec4(0.0);
        acc1 = vec4(0.0);
    }
#endif
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
#ifdef SA_WALK_SPLIT
        // The split walk shares a scratch's entries by runs of 32 of its chunk's queue: each
        // chunk's entries go where the round's words are those runs (chunk ca's entry pa at
        // place pa % 32, chunk cb's first at a word's start; the places between hold nothing).
        uint sa = pa & 31u;
#else
        uint sa = 0u;
#endif
        uint na = min(QCAP - sa, total_a - pa);
#ifdef SA_WALK_SPLIT
        uint pb = (sa + na + 31u) & ~31u;
#else
        uint pb = na;
#endif
        uint cb = ca + CHUNK, base_b = 0u, fast_b = 0u, nb = 0u;
        if (pa + na == total_a && pb < QCAP && cb < end) nb = min(QCAP - pb, chunk_record(cb, base_b, fast_b));
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
            pair_eval(in_a ? sa + i : pb + (i - na), e >> 8, k, idx < (in_a ? fast_a : fast_b));
            i += 256u;
        } while (i < n);
        barrier();
#ifdef SA_WALK_SPLIT
        // Word w of the round is run w + off of its chunk: chunk ca's off is pa / 32, cb's -pb / 32.
        g_off_lo = odd ? -int(pb >> 5) : int(pa >> 5);
        g_off_hi = odd ? int(pa >> 5) : -int(pb >> 5);
#endif
        round_accumulate(lid, 0u, nb > 0u ? pb + nb : sa + na, NK, uvec2(0u), 0u, uvec2(0u), 0u);
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
#ifndef SA_WALK_SPLIT
        live = g != 0.0;  // (the split walk queues what the forward queued: see pair_eval)
#endif
    }
    store_pixel(lid, V, t0, vec2(gI, gA));
#ifdef SA_PARALLEL_LINKS
    mask_clear(lid);  // seen after the first round's barrier
#endif
#ifdef SA_REPLAY
    replay_stream(begin, stop, lid);
#else
    uint cand = 0u;
    tile_loop(begin, stop, V, t0, lid, live, P, cand);
#endif
    if (loop_limit_hit(pc.sentinel)) { atomicOr(stats[6], 1u); atomicOr(stats[5], 1u); }
}
