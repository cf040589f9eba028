#version 450
// The pair search's sort (binning mode PAIRS, `GpuScene::binning_mode`): a stable least
// significant digit radix sort of the (tile, emission index) pairs that bin.comp emitted in
// scratch-major order, 8 bits of the tile index per pass, then the tile lists written from it.
// A stable sort by tile of pairs emitted scratch by scratch lists every tile's scratches in
// increasing index: the same lists, in the same order, as the group binning's histogram gives.
// Every step is deterministic: the counts are sums of ones, the rank of a pair within its block
// is a count of the earlier pairs with its digit.
//
// The pairs are cut into blocks of 256 (one workgroup each); n = min(total, capacity) where
// total is the last word of the scanned per-(scratch, part) counts.
//   HIST:    digits[d * n_blocks + b] = pairs of block b whose digit is d (then a scan, in
//            place: digit-major, so the scan gives each (digit, block) its first output slot).
//   SCATTER: each pair to digits[d * n_blocks + b] + its rank among the block's pairs with
//            digit d. The first pass takes the emission index as the value.
//   FINAL:   for sorted position p holding emission index e: list[p] = the scratch of e,
//            inv[e] = p.
// The largest serial loop of a thread is the rank count: at most 46 steps (see SCATTER).
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 256) in;
// HIST/SCATTER: 0 keys in, 1 values in, 2 digit counts, 3 keys out, 4 values out.
// FINAL: 1 sorted values, 0 the scratch of each emission index (bin.comp's `inv` scratch),
// 3 the tile lists, 4 the entry inverse map.
layout(std430, binding = 0) buffer A { uint keys_in[]; };
layout(std430, binding = 1) buffer B { uint vals_in[]; };
layout(std430, binding = 2) buffer Digits { uint digits[]; };
layout(std430, binding = 3) buffer C { uint keys_out[]; };
layout(std430, binding = 4) buffer D { uint vals_out[]; };
layout(std430, binding = 5) readonly buffer Total { uint sbase[]; };

#include "inc/radix_push.glsl"

shared uint sh[256];
#ifdef SCATTER
shared uint per_row[16 * 256];
#endif

void main() {
    uint lid = gl_LocalInvocationID.x;
    uint b = gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x;
    if (b >= pc.n_blocks) return;  // the whole workgroup: no barrier is skipped by part of it
    uint n = min(sbase[pc.total_index], pc.capacity);
    uint i = b * 256u + lid;
#if defined(HIST)
    sh[lid] = 0u;
    barrier();
    if (i < n) atomicAdd(sh[(keys_in[i] >> pc.shift) & 255u], 1u);
    barrier();
    digits[lid * pc.n_blocks + b] = sh[lid];
#elif defined(SCATTER)
    // The rank of a pair among the block's earlier pairs with its digit, in two levels: the
    // block's 256 pairs are 16 rows of 16; per_row[q][d] counts row q's pairs with digit d
    // (sums of ones); a pair adds the earlier rows' counts and the equal digits before it in its
    // own row. At most 16 + 15 + 15 steps.
    uint key = i < n ? keys_in[i] : 0u;
    uint d = i < n ? (key >> pc.shift) & 255u : 0xFFFFFFFFu;
    uint row = lid >> 4u;
    for (uint q = 0u; q < 16u; ++q) per_row[q * 256u + lid] = 0u;
    sh[lid] = d;
    barrier();
    if (i < n) atomicAdd(per_row[row * 256u + d], 1u);
    barrier();
    if (i < n) {
        uint r = 0u;
        for (uint q = 0u; q < row; ++q) r += per_row[q * 256u + d];
        for (uint j = row * 16u; j < lid; ++j) r += sh[j] == d ? 1u : 0u;
        uint pos = digits[d * pc.n_blocks + b] + r;
        keys_out[pos] = key;
        vals_out[pos] = pc.first != 0u ? i : vals_in[i];
    }
#elif defined(FINAL)
    if (i < n) {
        uint e = vals_in[i];
        keys_out[i] = keys_in[e];
        vals_out[e] = i;
    }
#endif
}
