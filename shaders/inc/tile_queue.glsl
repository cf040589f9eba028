// The tile machinery of the shading kernels (driven by tile_loop.glsl): one workgroup of 16x16
// threads per 16x16-pixel tile; the tile's scratch list (sorted by scratch index, see bin.comp)
// streams through shared memory in chunks of CHUNK scratches. Per chunk:
//   1. scratch x 4x4-pixel-block tests (bounding box of the block's plate quad in the scratch
//      frame), by the thread that loads the scratch, give each block a mask of scratches that
//      may meet it (scratch data come from the per-scratch records, scratch_records.glsl);
//   2. every pixel tests its block's scratches (footprint bounding circle, then the footprint's
//      bounding box in the scratch frame) and keeps masks of overlapping ones, split into
//      likely fast-path pairs (strip crossing the footprint, see patch_fast) and the others;
//   3. an exclusive scan of the per-pixel counts gives each pair a queue slot: all fast pairs
//      first, then the others, each group in (pixel, scratch) order, so SIMD lanes that
//      integrate neighbouring queue entries take the same path;
//   4. the kernel integrates QCAP queue entries per round with all its threads.
// Everything is in a fixed order: results do not depend on thread timing. The loop that drives
// these steps is tile_loop.glsl.
//
// Include after inc/shade_bindings.glsl (the buffers and push constants) and a definition of QCAP.
#ifndef SA_TILE_QUEUE_GLSL
#define SA_TILE_QUEUE_GLSL
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "scratch_records.glsl"
#include "tiles.glsl"

const uint CHUNK = 64u;            // scratches per chunk: one bit each in two 32-bit words

// The tile lists through their R32_UINT texel view (`list_tex`, slot SA_BIND_LIST_TEX of
// inc/shade_bindings.glsl: the same buffer as `list`): chunk scratch k's index in the scene (its
// records: scratch_records.glsl) is a gather, where a load from `list` or from shared memory with
// a per-lane index is a scalar loop over the lanes on CPU drivers.
uint g_chunk = 0u;                 // the chunk's first tile-list entry (set by the tile loops)
// The backward's replay (grad.comp) takes a round's entries from two chunks in turn: those of the
// second are numbered k + CHUNK, and g_chunk_hi is its first entry.
uint g_chunk_hi = 0u;
uint chunk_scratch(uint k) { return texelFetch(list_tex, int((k < CHUNK ? g_chunk : g_chunk_hi - CHUNK) + k)).x; }
shared vec4 sh_blk01[16];          // plate-space corners of the tile's 4x4-pixel blocks
shared vec4 sh_blk23[16];
shared bool sh_blk_all[16];        // a block whose corner rays miss the plate: test every scratch
shared float sh_blk_margin[16];    // how far the block's part of the sheet may reach past its quad (bent sheets)
shared uint sh_blk_hits[32];       // per block, two words: chunk scratches that may meet it
shared uint sh_base[256];          // queue_slots: per subgroup, its packed counts; free after it
shared uint sh_queue[QCAP];        // (pixel << 8) | scratch-in-chunk

// Threads 0..15: plate quads of the 16 blocks; threads 0..31 clear the block masks (both
// visible after the chunk loop's first barrier). On a bent sheet (engine/docs/model.md section 10)
// a block's part of the sheet is not the quad of its corners' hits: the quad is grown by twice the
// largest distance of the edges' midpoints and the centre from where the corners put them (the
// map from image to sheet is smooth, so its bend over 4 pixels shows there), plus a float32 margin.
void setup_blocks(ViewGPU V, uvec2 t0, uint lid) {
    if (lid < 16u) {
        uvec2 b0 = t0 + 4u * uvec2(lid & 3u, lid >> 2);
        bool k0, k1, k2, k3;
        vec2 c0, c1, c2, c3;
        float margin = 0.0;
        if (bent(V)) {
            vec3 p;
            vec2 o = vec2(b0);
            c0 = sheet_hit(V, o, k0, p); c1 = sheet_hit(V, o + vec2(4.0, 0.0), k1, p);
            c2 = sheet_hit(V, o + vec2(4.0), k2, p); c3 = sheet_hit(V, o + vec2(0.0, 4.0), k3, p);
            bool km = true, k;
            vec2 m = sheet_hit(V, o + vec2(2.0, 0.0), k, p); km = km && k; margin = max(margin, distance(m, 0.5 * (c0 + c1)));
            m = sheet_hit(V, o + vec2(4.0, 2.0), k, p); km = km && k; margin = max(margin, distance(m, 0.5 * (c1 + c2)));
            m = sheet_hit(V, o + vec2(2.0, 4.0), k, p); km = km && k; margin = max(margin, distance(m, 0.5 * (c2 + c3)));
            m = sheet_hit(V, o + vec2(0.0, 2.0), k, p); km = km && k; margin = max(margin, distance(m, 0.5 * (c3 + c0)));
            m = sheet_hit(V, o + vec2(2.0), k, p); km = km && k; margin = max(margin, distance(m, 0.25 * (c0 + c1 + c2 + c3)));
            margin = 2.0 * margin + 1e-4 * (distance(c0, c2) + distance(c1, c3)) + 1e-5 * abs(V.right.w);
            k0 = k0 && km;
        } else {
            c0 = ray_hit(V, vec2(b0), k0); c1 = ray_hit(V, vec2(b0) + vec2(4.0, 0.0), k1);
            c2 = ray_hit(V, vec2(b0) + vec2(4.0), k2); c3 = ray_hit(V, vec2(b0) + vec2(0.0, 4.0), k3);
        }
        sh_blk01[lid] = vec4(c0, c1);
        sh_blk23[lid] = vec4(c2, c3);
        sh_blk_margin[lid] = margin;
        sh_blk_all[lid] = !(k0 && k1 && k2 && k3);
    }
    if (lid < 32u) sh_blk_hits[lid] = 0u;
}

// Step 1, by the thread that loads chunk scratch k (scene index si): its tests against the 16
// blocks, from its culling record (rec_cull_a, rec_cull_b: p0, t; len, w, s_e, alpha). The masks
// were cleared in queue_slots of the previous chunk (or before the loop).
void block_tests(uint k, uint si) {
    vec4 ca = rec_cull_a(si), cb = rec_cull_b(si);
    vec2 p0 = ca.xy, t = ca.zw, b = vec2(-t.y, t.x);
    float len = cb.x, e = 0.5 * cb.y * cb.z;
    for (uint blk = 0u; blk < 16u; ++blk) {
        bool hit = sh_blk_all[blk];
        if (!hit) {
            vec4 qa = sh_blk01[blk], qb = sh_blk23[blk];
            float mg = sh_blk_margin[blk];  // 0 on a flat plate
            vec4 us = vec4(dot(qa.xy - p0, b), dot(qa.zw - p0, b), dot(qb.xy - p0, b), dot(qb.zw - p0, b));
            vec4 vs = vec4(dot(qa.xy - p0, t), dot(qa.zw - p0, t), dot(qb.xy - p0, t), dot(qb.zw - p0, t));
            hit = !(min(min(us.x, us.y), min(us.z, us.w)) >= e + mg || max(max(us.x, us.y), max(us.z, us.w)) <= -e - mg ||
                    min(min(vs.x, vs.y), min(vs.z, vs.w)) >= len + mg || max(max(vs.x, vs.y), max(vs.z, vs.w)) <= -mg);
        }
        if (hit) atomicOr(sh_blk_hits[2u * blk + (k >> 5)], 1u << (k & 31u));
    }
}

#ifdef SA_CULL_PAIRS
// Modelling no more than the scene needs (the forward of the integrator `adaptive`): a pair whose
// contribution is provably negligible is not queued. Dropping pair k changes its pixel by at most
//   scale * b_k / S_P,   b_k = A_k * max(Dmax_k, D_flat),
// its own NDF integral (at most A_k Dmax_k, Dmax_k the largest D over the groove's arc of normals)
// and its share of the coverage, whose area goes back to the flat plate's term (at most
// A_k D_flat). A_k is bounded by the overlap of the footprint's bounding box in the scratch frame
// with the carved rectangle, and by S_P. A pixel drops pair k (in the order the kernel meets them)
// when the bounds dropped so far plus b_k stay within CULL_EPS times the NDF integrals it has
// kept so far (cull_kept): that sum is a lower bound of the pixel's D_P S_P, so culling moves
// every pixel by at most CULL_EPS of its value: 5e-4, half of engine/docs/model.md section 8's 1e-3, the
// closed form's own error (p99 below 4e-5 on the study's regimes) well inside the rest. Only the
// first pass of a tile culls (a later pass of a dense tile starts without the dropped sum).
const float CULL_EPS = 5e-4;
float cull_dropped = 0.0;   // this pixel: sum of the bounds b_k it dropped
uint cull_count = 0u;       // and how many pairs
float cull_kept();          // hook of the kernel: this pixel's sum of I_k over the pairs integrated so far

// b_k of the pair (see above), with 1% slack for float32 rounding. hb, hz: the half vector
// across the scratch and along the plate normal; se: carved half-width in s = 2u/w units.
float cull_bound(float area, float hb, float hz, float se, float alpha, float d_flat) {
    // n(theta) . h = hz cos(theta) - hb sin(theta) over |theta| <= theta_e = 2 atan(se): its
    // largest value c is |h in the (b, z) plane| when that direction lies within theta_e of z,
    // else the value at the nearer end of the arc. D grows with c on c > 0: D = alpha^2 /
    // (pi (1 - beta^2 c^2)^2), beta^2 = 1 - alpha^2, so only c^2 is needed (no square root).
    float ip = 1.0 / (1.0 + se * se);
    float ce = (1.0 - se * se) * ip, sn = 2.0 * se * ip;
    hb = abs(hb);
    float ca = hz * ce + hb * sn;
    bool inside = hb * ce - hz * sn <= 0.0;
    float c2 = inside ? hb * hb + hz * hz : ca * ca;
    float a2 = alpha * alpha;
    float den = max(1.0 - (1.0 - a2) * c2, a2 * a2);  // >= alpha^2 (c <= 1) up to rounding
    float dmax = (inside || ca > 0.0) ? a2 / (PI * den * den) : 0.0;
    return 1.01 * area * max(dmax, d_flat);
}
#endif

#if defined(SA_STORE_PAIRS) || defined(SA_REPLAY)
// The pair store (binding `pstore`, written by the forward with SA_STORE_PAIRS, read by the
// backward's replay, tile_loop.glsl): words [0, 2 capacity) hold per chunk, at 2 c0 (c0: the
// chunk's first tile-list entry), the base of its entries (STORE_MISSING: not stored) and
// nfast | total << 16 (both at most 256 x 64 = 16384); the entries, each (pixel << 8) | scratch
// as in sh_queue, follow from word 2 capacity, each chunk's contiguous and in queue order.
// Bases come from a counter (stats[13]: the entries every chunk needed, so the host can grow the
// store); where a chunk's entries land depends on timing, what the backward reads does not.
const uint STORE_MISSING = 0xFFFFFFFFu;
const uint STAT_STORE_NEEDED = 13u;
const uint STAT_STORE_FLAGS = 14u;  // bit 0: replay found a chunk not stored; bit 1: counter wrapped
#endif

#ifdef SA_STORE_PAIRS
shared uint sh_store_base;         // this chunk's first entry in the store, or STORE_MISSING

// Thread 0, once per chunk after queue_slots: a place for the chunk's `total` entries, if the
// store (pc.store_cap entries; 0: no store, and no counting: a render for display pays nothing)
// has room.
void store_chunk(uint c0, uint nfast, uint total) {
    sh_store_base = STORE_MISSING;
    if (pc.store_cap == 0u) return;
    uint b = atomicAdd(stats[STAT_STORE_NEEDED], total);
    bool wrapped = b + total < b;
    if (wrapped) atomicOr(stats[STAT_STORE_FLAGS], 2u);
    if (!wrapped && b + total <= pc.store_cap) sh_store_base = b;
    pstore[2u * c0] = sh_store_base;
    pstore[2u * c0 + 1u] = nfast | (total << 16);
}
#endif

// Step 2: this pixel's overlapping scratches of the chunk (fmask: likely fast path, gmask: the
// others). `fp` are the footprint corners on the plate, `centre`/`radius` its bounding circle
// (from P; P's half vector, flat-plate NDF and footprint area serve the culling of `adaptive`).
void pixel_masks(bool live, uint myblk, PixelSetup P, out uvec2 fmask, out uvec2 gmask, inout uint cand) {
    fmask = uvec2(0u);
    gmask = uvec2(0u);
    if (!live) return;
    vec2 fp[4] = P.fp;
    vec2 centre = P.centre;
    float radius = P.radius;
#ifdef SA_CULL_PAIRS
    float budget = pc.pass == 0u ? CULL_EPS * cull_kept() : 0.0;
    float sp = 1.0 / P.inv_sp;
#endif
    uvec2 bm2 = uvec2(sh_blk_hits[2u * myblk], sh_blk_hits[2u * myblk + 1u]);
    cand += uint(bitCount(bm2.x) + bitCount(bm2.y));
    // One loop over both words, tested at the bottom (see tile_loop): scratch order as before.
    uvec2 bm = bm2;
    if ((bm.x | bm.y) != 0u) do {
        uint k;
        if (bm.x != 0u) { k = uint(findLSB(bm.x)); bm.x &= bm.x - 1u; }
        else { k = uint(findLSB(bm.y)) + 32u; bm.y &= bm.y - 1u; }
        uint wd = k >> 5;
        uint si = chunk_scratch(k);
        vec4 ca = rec_cull_a(si), cb = rec_cull_b(si);
        vec2 p0 = ca.xy, t = ca.zw, b = vec2(-t.y, t.x);
        float len = cb.x, e = 0.5 * cb.y * cb.z;
        if (len <= 0.0) continue;
        vec2 q = centre - p0;
        float u = dot(q, b), v = dot(q, t);
        if (abs(u) > e + radius || v < -radius || v > len + radius) continue;
        float umin = 1e30, umax = -1e30, vmin = 1e30, vmax = -1e30, uabs = 1e30;
        for (int c = 0; c < 4; ++c) {
            vec2 r = fp[c] - p0;
            float uu = dot(r, b), vv = dot(r, t);
            umin = min(umin, uu); umax = max(umax, uu); vmin = min(vmin, vv); vmax = max(vmax, vv);
            uabs = min(uabs, abs(uu));
        }
        if (umin >= e || umax <= -e || vmin >= len || vmax <= 0.0) continue;
#ifdef SA_CULL_PAIRS
        if (budget > 0.0) {
            float area = min(sp, (min(umax, e) - max(umin, -e)) * (min(vmax, len) - max(vmin, 0.0)));
            float bk = cull_bound(area, dot(P.h.xy, b), P.h.z, cb.z, cb.w, P.d_flat);
            if (cull_dropped + bk <= budget) {
                cull_dropped += bk;
                ++cull_count;
                continue;
            }
        }
#endif
        if (uabs > e && vmin > 0.0 && vmax < len) fmask[wd] |= 1u << (k & 31u);
        else gmask[wd] |= 1u << (k & 31u);
    } while ((bm.x | bm.y) != 0u);
}

// Step 3: queue slots. Both counts are scanned at once, packed in 16-bit halves (at most
// 256 x 64 = 16384 each, so no carry crosses the halves): a scan within each subgroup, one
// barrier, then each subgroup adds the totals of the subgroups before it. Integer sums: the
// slots do not depend on the subgroup size or on timing. Contains a barrier: call from uniform
// control flow.
void queue_slots(uint lid, uvec2 fmask, uvec2 gmask, out uint nfast, out uint total, out uint fbase, out uint gbase) {
    uint c = uint(bitCount(fmask.x) + bitCount(fmask.y)) | (uint(bitCount(gmask.x) + bitCount(gmask.y)) << 16);
    uint incl = subgroupInclusiveAdd(c);
    if (gl_SubgroupInvocationID == gl_SubgroupSize - 1u) sh_base[gl_SubgroupID] = incl;
    // Every pixel has read the block masks (pixel_masks, before the barrier below): clear them
    // for the next chunk here, so that chunk needs no extra barrier before its block tests.
    if (lid >= 224u) sh_blk_hits[lid - 224u] = 0u;
    barrier();
    uint before = 0u, all = 0u;
    for (uint sg = gl_SubgroupInvocationID; sg < gl_NumSubgroups; sg += gl_SubgroupSize) {
        uint v = sh_base[sg];
        all += v;
        if (sg < gl_SubgroupID) before += v;
    }
    before = subgroupAdd(before);
    all = subgroupAdd(all);
    uint base = before + incl - c;
    nfast = all & 0xFFFFu;
    total = nfast + (all >> 16);
    fbase = base & 0xFFFFu;
    gbase = nfast + (base >> 16);
}

// Step 4 (each round): this pixel's queue entries that fall in [r0, r0 + QCAP). Its entries of
// one kind are the slots [base, base + count) in scratch order; the entries of earlier rounds are
// dropped from the mask first (cheap bit clears), so a round stores only its own entries instead
// of testing all of them (on CPU drivers a store under a false condition costs as much as one
// that happens).
void enqueue(uint lid, uvec2 mask, uint base, uint r0) {
    uint count = uint(bitCount(mask.x) + bitCount(mask.y));
    uint lo = max(base, r0), hi = min(base + count, r0 + QCAP);
    if (lo >= hi) return;
    uint m0 = mask.x, m1 = mask.y;
    // Both loops test at the bottom (see tile_loop).
    uint s = lo - base;
    if (s > 0u) do {
        if (m0 != 0u) m0 &= m0 - 1u;
        else m1 &= m1 - 1u;
        --s;
    } while (s > 0u);
    uint idx = lo;
    do {
        uint k;
        if (m0 != 0u) { k = uint(findLSB(m0)); m0 &= m0 - 1u; }
        else { k = uint(findLSB(m1)) + 32u; m1 &= m1 - 1u; }
        sh_queue[idx - r0] = (lid << 8) | k;
        ++idx;
    } while (idx < hi);
}

#endif
