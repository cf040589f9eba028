#version 450
// Exclusive prefix sum of data[0..n), in place, deterministic (fixed association order).
// Pass REDUCE: block sums of 4096 elements. Pass SUMS: exclusive scan of the block sums by one
// workgroup. Pass APPLY: each block scans its elements and adds its block offset.
// A total of 2^32 or more would wrap: every addition is checked, and a wrap sets
// stats[pc.flag_index] (see inc/limits.glsl), which the host turns into an error.
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 256) in;
layout(std430, binding = 0) buffer Data { uint data[]; };
layout(std430, binding = 1) buffer Sums { uint sums[]; };
layout(std430, binding = 2) buffer Stats { uint stats[]; };
#include "inc/scan_push.glsl"

bool wrapped = false;
uint add(uint a, uint b) {
    uint s = a + b;
    wrapped = wrapped || s < a;
    return s;
}

const uint PER_THREAD = 16u;
const uint BLOCK = 256u * PER_THREAD;
shared uint part[256];

void scan_part() {  // exclusive scan of part[] by thread 0 (256 adds; keeps the order fixed)
    barrier();
    if (gl_LocalInvocationID.x == 0u) {
        uint run = 0u;
        for (uint i = 0u; i < 256u; ++i) { uint v = part[i]; part[i] = run; run = add(run, v); }
    }
    barrier();
}

void main() {
    uint lid = gl_LocalInvocationID.x;
#if defined(SUMS)
    uint per = (pc.n_blocks + 255u) / 256u;
    uint b0 = lid * per;
    uint acc = 0u;
    for (uint i = 0u; i < per; ++i) if (b0 + i < pc.n_blocks) acc = add(acc, sums[b0 + i]);
    part[lid] = acc;
    scan_part();
    uint run = part[lid];
    for (uint i = 0u; i < per; ++i) if (b0 + i < pc.n_blocks) { uint v = sums[b0 + i]; sums[b0 + i] = run; run = add(run, v); }
    if (wrapped) atomicOr(stats[pc.flag_index], 1u);
#else
    uint blk = gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x;
    if (blk >= pc.n_blocks) return;
    uint base = blk * BLOCK + lid * PER_THREAD;
    uint acc = 0u;
    for (uint i = 0u; i < PER_THREAD; ++i) if (base + i < pc.n) acc = add(acc, data[base + i]);
    part[lid] = acc;
#if defined(REDUCE)
    barrier();
    if (lid == 0u) {
        uint s = 0u;
        for (uint i = 0u; i < 256u; ++i) s = add(s, part[i]);
        sums[blk] = s;
    }
    if (wrapped) atomicOr(stats[pc.flag_index], 1u);
#else
    scan_part();
    uint run = sums[blk] + part[lid];
    for (uint i = 0u; i < PER_THREAD; ++i) if (base + i < pc.n) { uint v = data[base + i]; data[base + i] = run; run += v; }
#endif
#endif
}
