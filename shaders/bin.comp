#version 450
// Tile binning, deterministic. Scratches are split into groups of `group_size`; a thread owns
// group g in every view (n_bands = 0: CPU drivers, where threads are few and each does more), or
// group g in one band of tile rows of one view (n_bands > 0, a "part": GPUs, which need tens of
// thousands of threads). Pass COUNT: hist[t * n_groups + g] = number of (tile t, scratch of
// group g) pairs; a tile belongs to one part, so one thread writes each entry either way.
// After an exclusive scan of hist (tile-major), pass SCATTER re-enumerates in the same order and
// writes scratch indices to list[cursor[t * n_groups + g]++]: every tile's list is then sorted by
// scratch index, whatever the thread timing, so pixel sums are bit-reproducible.
// PAIRS (GPUs; `GpuScene::binning_mode`): group_size is 1, so a thread owns one (scratch,
// part), and there is no (tile, group) histogram. COUNT adds 1 to hist[t] per (tile t, scratch)
// pair and writes sbase as above; after the scans, the emission pass writes each pair at its
// scratch-major emission index e (today's `inv` order): the tile to list[e] and the scratch to
// inv[e], here scratch space. radix.comp then sorts the pairs by tile, stably, which is the
// order above (by tile, then scratch index), and writes the real list and inv.
// A tile is listed for a scratch when the projected carved rectangle (a convex quad in image
// space) meets the tile's image rectangle, grown by half a pixel against rounding (separating axes).
#extension GL_GOOGLE_include_directive : require
#include "inc/common.glsl"
#include "inc/limits.glsl"

layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Views { ViewGPU views[]; };
layout(std430, binding = 1) readonly buffer Scratches { ScratchGPU scr[]; };
layout(std430, binding = 2) buffer Hist { uint hist[]; };
layout(std430, binding = 3) buffer List { uint list[]; };
// Per (scratch, part): COUNT writes its number of entries; after a scan, SCATTER reads it as the
// first slot of those entries in `inv`, which maps them (in enumeration order: view, tile row,
// tile column, whatever the parts) to list positions.
// The backward pass uses it to add a scratch's per-tile partial gradients in a fixed order.
layout(std430, binding = 4) buffer ScratchBase { uint sbase[]; };
layout(std430, binding = 5) buffer Inverse { uint inv[]; };
layout(std430, binding = 6) buffer Stats { uint stats[]; };  // [5], [7] (inc/limits.glsl)

#include "inc/bin_push.glsl"

bool quad_meets_rect(vec2 q[4], float orient, vec2 lo, vec2 hi) {
    vec2 qmin = min(min(q[0], q[1]), min(q[2], q[3]));
    vec2 qmax = max(max(q[0], q[1]), max(q[2], q[3]));
    if (any(greaterThan(qmin, hi)) || any(lessThan(qmax, lo))) return false;
    for (int i = 0; i < 4; ++i) {
        vec2 a = q[i], b = q[(i + 1) & 3];
        vec2 nrm = orient * vec2(b.y - a.y, a.x - b.x);  // outward normal
        float m = max(max(dot(vec2(lo.x, lo.y) - a, nrm), dot(vec2(hi.x, lo.y) - a, nrm)),
                      max(dot(vec2(hi.x, hi.y) - a, nrm), dot(vec2(lo.x, hi.y) - a, nrm)));
        if (m < 0.0) continue;  // some tile corner inside this edge's half-plane
        if (min(min(dot(vec2(lo.x, lo.y) - a, nrm), dot(vec2(hi.x, lo.y) - a, nrm)),
                min(dot(vec2(hi.x, hi.y) - a, nrm), dot(vec2(lo.x, hi.y) - a, nrm))) > 0.0) return false;
    }
    return true;
}

// The image bounds of a carved rectangle rc (sheet coordinates) on a bent sheet: the corners of a
// world box holding the cylinder patch over rc's wrapped and along-axis ranges, projected, grown by
// half a pixel. ok = false when a corner is not in front of the camera (then every tile is tested).
bool bent_bounds(ViewGPU V, vec2 rc[4], out vec2 qmin, out vec2 qmax) {
    bool ax = bent_about_x(V);
    float rad = abs(V.right.w), s = sign(V.right.w);
    vec2 lo = min(min(rc[0], rc[1]), min(rc[2], rc[3])), hi = max(max(rc[0], rc[1]), max(rc[2], rc[3]));
    if (ax) { lo = lo.yx; hi = hi.yx; }  // (wrapped, along)
    float t0 = lo.x / rad, t1 = hi.x / rad;
    // a = rad sin(theta) over [t0, t1] (|theta| < 150 degrees: a quarter turn may lie inside)
    float a0 = rad * sin(t0), a1 = rad * sin(t1);
    float amin = min(a0, a1), amax = max(a0, a1);
    if (t0 < -0.5 * PI && t1 > -0.5 * PI) amin = -rad;
    if (t0 < 0.5 * PI && t1 > 0.5 * PI) amax = rad;
    // 1 - cos(theta): least at the theta nearest 0, most at the farthest
    float tn = (t0 <= 0.0 && t1 >= 0.0) ? 0.0 : min(abs(t0), abs(t1));
    float tf = max(abs(t0), abs(t1));
    float zc0 = -s * rad * (1.0 - cos(tn)), zc1 = -s * rad * (1.0 - cos(tf));
    float pad = 1e-5 * rad;  // float rounding of the box against the rays' hits
    vec3 bmin = vec3(amin, lo.y, min(zc0, zc1)) - pad, bmax = vec3(amax, hi.y, max(zc0, zc1)) + pad;
    qmin = vec2(1e30); qmax = vec2(-1e30);
    bool all_ok = true;
    for (int c = 0; c < 8; ++c) {
        vec3 H = vec3((c & 1) != 0 ? bmax.x : bmin.x, (c & 2) != 0 ? bmax.y : bmin.y, (c & 4) != 0 ? bmax.z : bmin.z);
        bool ok;
        vec2 q = project3(V, ax ? H.yxz : H, ok);
        all_ok = all_ok && ok;
        qmin = min(qmin, q); qmax = max(qmax, q);
    }
    qmin -= 0.5; qmax += 0.5;
    return all_ok;
}

void main() {
    uint id = gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    uint n_parts = pc.n_bands == 0u ? 1u : pc.n_views * pc.n_bands;
    if (id >= pc.n_groups * n_parts) return;
    uint g = id % pc.n_groups, part = id / pc.n_groups;
    // This thread's views and band (n_bands = 0: every view, every row).
    uint v_lo = 0u, v_hi = pc.n_views, band = 0u;
    if (pc.n_bands != 0u) {
        v_lo = part / pc.n_bands;
        v_hi = v_lo + 1u;
        band = part % pc.n_bands;
    }
    uint k0 = g * pc.group_size;
    uint k1 = min(k0 + pc.group_size, pc.n_scratches);
    // The loops test at the bottom, behind an `if` for the first test: on CPU drivers a loop that
    // tests at the top runs its body once more with every lane off.
#ifdef COUNT
    uint tests = 0u;  // tile tests of this thread: its serial work (stats[15])
#endif
    uint k = k0;
    if (k < k1) do {
        uint nk = 0u;
#ifndef COUNT
        uint sb = sbase[k * n_parts + part];
#endif
        ScratchGPU S = scr[k];
        vec2 p0 = S.ends.xy, p1 = S.ends.zw;
        vec2 d01 = p1 - p0;
        float l01 = length(d01);
        if (l01 <= 0.0) continue;  // shorter than float32 resolves here: overlaps nothing
        vec2 t = d01 / l01;
        vec2 b = vec2(-t.y, t.x);
        float e = 0.5 * S.shape.x * carved_se(S.shape.x, S.shape.y);
        vec2 rc[4] = vec2[](p0 - e * b, p1 - e * b, p1 + e * b, p0 + e * b);
        uint vi = v_lo;
        if (vi < v_hi) do {
            ViewGPU V = views[vi];
            // The band's tile rows, [r_lo, r_hi): contiguous, so the enumeration order is the
            // same with or without bands.
            // (Rows and columns of tiles in the image; the view's tiles are its window's: base.zw
            // its first column and row, dims.zw its size.)
            uint r_lo = V.base.w, r_hi = V.base.w + V.dims.w;
            if (pc.n_bands != 0u) {
                r_lo = V.base.w + (band * V.dims.w) / pc.n_bands;
                r_hi = V.base.w + ((band + 1u) * V.dims.w) / pc.n_bands;
            }
            vec2 q[4];
            bool all_ok = true;
            vec2 qmin, qmax;
            if (bent(V)) {
                // On a bent sheet the rectangle's image is curved: its box's, no separating axes.
                all_ok = bent_bounds(V, rc, qmin, qmax);
            } else {
                for (int c = 0; c < 4; ++c) {
                    bool ok;
                    q[c] = project(V, rc[c], ok);
                    all_ok = all_ok && ok;
                }
                qmin = min(min(q[0], q[1]), min(q[2], q[3])) - 0.5;
                qmax = max(max(q[0], q[1]), max(q[2], q[3])) + 0.5;
            }
            uint tx0 = V.base.z, ty0 = V.base.w, tx1 = V.base.z + V.dims.z - 1u, ty1 = V.base.w + V.dims.w - 1u;
            float orient = 0.0;  // 0: no separating-axis test (conservative)
            if (all_ok) {
                if (qmax.x < 0.0 || qmax.y < 0.0 || qmin.x > float(V.dims.x) || qmin.y > float(V.dims.y)) continue;
                tx0 = max(uint(max(qmin.x, 0.0)) / TILE, tx0);
                ty0 = max(uint(max(qmin.y, 0.0)) / TILE, ty0);
                tx1 = min(uint(min(qmax.x, float(V.dims.x))) / TILE, tx1);
                ty1 = min(uint(min(qmax.y, float(V.dims.y))) / TILE, ty1);
                float a2 = 0.0;
                for (int c = 0; c < 4; ++c) a2 += (q[c].x - q[(c + 1) & 3].x) * (q[c].y + q[(c + 1) & 3].y);
                orient = a2 > 0.0 ? 1.0 : -1.0;  // CCW (a2 > 0): outward normal of a->b is (dy, -dx)
                if (a2 == 0.0 || bent(V)) orient = 0.0;
            }
            if (r_hi <= r_lo) continue;  // more bands than tile rows
            ty0 = max(ty0, r_lo);
            ty1 = min(ty1, r_hi - 1u);
            uint ty = ty0;
            if (ty <= ty1) do {
                uint tx = tx0;
                if (tx <= tx1) do {
#ifdef COUNT
                    ++tests;
#endif
                    if (orient != 0.0) {
                        vec2 lo = vec2(float(tx * TILE), float(ty * TILE)) - 0.5;
                        vec2 hi = vec2(float((tx + 1u) * TILE), float((ty + 1u) * TILE)) + 0.5;
                        if (!quad_meets_rect(q, orient, lo, hi)) continue;
                    }
                    uint tile = V.base.x + (ty - V.base.w) * V.dims.z + (tx - V.base.z);
#if defined(PAIRS) && defined(COUNT)
                    atomicAdd(hist[tile], 1u);  // a sum of ones: the same whatever the order
#elif defined(PAIRS)
                    // Emission e = sb + nk, scratch-major: list <- the tile (the sort's key),
                    // inv <- the scratch (radix.comp's FINAL reads both back).
                    if (sb + nk < pc.capacity) { list[sb + nk] = tile; inv[sb + nk] = k; }
#elif defined(COUNT)
                    hist[tile * pc.n_groups + g] += 1u;
#else
                    uint slot = tile * pc.n_groups + g;
                    uint pos = hist[slot];
                    hist[slot] = pos + 1u;
                    if (pos < pc.capacity) list[pos] = k;
                    if (sb + nk < pc.capacity) inv[sb + nk] = pos;
#endif
                    ++nk;
                } while (++tx <= tx1);
            } while (++ty <= ty1);
        } while (++vi < v_hi);
#ifdef COUNT
        sbase[k * n_parts + part] = nk;
#endif
    } while (++k < k1);
    // A thread walks the tiles of its group's scratches in every view: with long scratches over
    // large views that can exceed a device's loop limit; the host then uses smaller groups.
#ifdef COUNT
    atomicMax(stats[15], tests);
#endif
    if (loop_limit_hit(pc.sentinel)) { atomicOr(stats[7], 1u); atomicOr(stats[5], 1u); }
}
