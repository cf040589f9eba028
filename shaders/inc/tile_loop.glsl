// The tile loop of the shading kernels (forward.comp, grad.comp): one workgroup of 16x16
// threads per 16x16-pixel tile, the tile's scratch list streamed in chunks, and per chunk the
// pair queue integrated in rounds of QCAP entries (the machinery is in tile_queue.glsl).
//
// A kernel keeps only its role's bindings (inc/shade_bindings.glsl), its per-pair work and its outputs; it plugs them in through
// hooks with fixed names (GLSL has no function pointers), declared here and defined by the kernel
// after including this file:
//   chunk_begin(lid)          every thread, at the start of a chunk (after its first barrier):
//                             per-chunk state, e.g. clearing per-scratch accumulators
//   pair_eval(i, px, k, fast) queue entry i of the round (pixel px of the tile, chunk scratch k,
//                             whose scene index is chunk_scratch(k) and whose data are its records,
//                             scratch_records.glsl; fast: queued as a likely fast-path pair):
//                             integrate, keep result i
//   round_accumulate(lid, r0, n, cnt, fmask, fbase, gmask, gbase)
//                             every thread, after the round's results are all written: fold
//                             them in, in a fixed order (r0: first queue slot of the round,
//                             n: entries in it, cnt: scratches in the chunk, the masks and bases
//                             of this pixel's entries from queue_slots)
//   chunk_end(lid, c0, cnt)   every thread, after the chunk's last round (c0: its first
//                             tile-list entry)
// Call tile_loop from uniform control flow (it has barriers) after store_pixel.
//
// Include after inc/shade_bindings.glsl (every buffer, texel buffer and push constant the loop
// reads) and a definition of QCAP. The backward's replay of the
// forward's queues is grad.comp's own loop (replay_stream).
#ifndef SA_TILE_LOOP_GLSL
#define SA_TILE_LOOP_GLSL

#include "pixel.glsl"
#include "tile_queue.glsl"
#include "limits.glsl"

shared vec2 sh_pv[256];            // the kernel's two per-pixel values (store_pixel)
// This tile's first pixel in the views' concatenated images, and its view's row length: the
// index of a tile pixel's record (pixel_records.comp, scratch_records.glsl).
uint g_tile_pix = 0u, g_row = 0u;

void chunk_begin(uint lid);
void pair_eval(uint i, uint px, uint k, bool fast);
void round_accumulate(uint lid, uint r0, uint n, uint cnt, uvec2 fmask, uint fbase, uvec2 gmask, uint gbase);
void chunk_end(uint lid, uint c0, uint cnt);

// The tile (view V, first pixel t0) and this pixel's two values for the kernel's pair_eval (pv,
// read as sh_pv[px]: the backward's gI and gA). Call before tile_loop (or grad.comp's replay).
void store_pixel(uint lid, ViewGPU V, uvec2 t0, vec2 pv) {
    g_tile_pix = V.base.y + t0.y * V.dims.x + t0.x;
    g_row = V.dims.x;
    sh_pv[lid] = pv;
}

// The set-up of tile pixel ij of view V as pixel_records.comp computed it: the fields the
// shading kernels use (fp in the pair integrals' order; e_irr and ccw are not kept). A pixel of
// a partial tile outside the view reads its view's last pixel's record: such a pixel is never
// live and writes nothing.
PixelSetup pixel_from_record(ViewGPU V, uvec2 ij) {
    PixelSetup P;
    uint pix = V.base.y + min(ij.y, V.dims.y - 1u) * V.dims.x + min(ij.x, V.dims.x - 1u);
    pixel_record(pix, P.fp, P.h);
    int b = int(SA_PIXEL_TEXELS * pix);
    vec4 cr = texelFetch(precs, b + 3), so = texelFetch(precs, b + 4);
    P.d_flat = texelFetch(precs, b + 2).w;
    P.centre = cr.xy;
    P.radius = cr.z;
    P.inv_sp = cr.w;
    P.scale = so.x;
    P.on_plate = so.y != 0.0;
    P.ccw = false;
    P.e_irr = 0.0;
    return P;
}

// Tile pixel px's footprint corners, ordered as the pair integrals take them, and half vector:
// its record (pixel_records.comp).
void pixel_pair_data(uint px, out vec2 fp[4], out vec3 h) {
    uvec2 q = tile_pixel(px);
    pixel_record(g_tile_pix + q.y * g_row + q.x, fp, h);
}

// The tile's list: [start, end) of `list` (clamped to the list's capacity; an overflowing render
// is redone by the host) and its true length in chunks.
void tile_list(uint tile, out uint start, out uint end, out uint n_chunks) {
    start = offs[tile * pc.n_groups];
    uint true_end = offs[(tile + 1u) * pc.n_groups];
    n_chunks = (true_end - start + CHUNK - 1u) / CHUNK;
    end = min(true_end, pc.capacity);
}

// The chunks of a tile's list [start, end) that pass `pass` handles: [begin, stop).
// Returns false when the pass has nothing to do for the tile.
bool pass_range(uint start, uint end, uint pass, uint chunks_per_pass, out uint begin, out uint stop) {
    uint n_chunks = (end - start + CHUNK - 1u) / CHUNK;
    uint first = pass * chunks_per_pass;  // chunks_per_pass is 0xFFFFFFFF (one pass) or small
    if (pass > 0u && (chunks_per_pass == 0xFFFFFFFFu || first >= n_chunks)) {
        begin = end;
        stop = end;
        return false;
    }
    begin = start + first * CHUNK;
    uint last = chunks_per_pass == 0xFFFFFFFFu ? n_chunks : min(n_chunks, first + chunks_per_pass);
    stop = min(end, start + last * CHUNK);
    return true;
}

// The chunk loop and the queue rounds over the entries [begin, end) of the tile's scratch list
// (this pass's share, see pass_range); cand counts this pixel's candidates (for the counters).
// Every loop here tests at the bottom, behind an `if` for the first test: on CPU drivers a loop
// that tests at the top runs its body once more with every lane off (a whole pair integral per
// round, a whole round per chunk, a whole chunk per tile), while an `if` that no lane of the
// batch enters is jumped over.
void tile_loop(uint begin, uint end, ViewGPU V, uvec2 t0, uint lid, bool live, PixelSetup P, inout uint cand) {
    setup_blocks(V, t0, lid);
    uint myblk = lid >> 4;  // tile_pixel's block of this thread
    uint c0 = begin;
    if (c0 < end) do {
        g_chunk = c0;
        barrier();
        chunk_begin(lid);
        if (lid < CHUNK && c0 + lid < end) block_tests(lid, list[c0 + lid]);
        barrier();
        uint cnt = min(CHUNK, end - c0);
        uvec2 fmask, gmask;
        pixel_masks(live, myblk, P, fmask, gmask, cand);
        uint nfast, total, fbase, gbase;
        queue_slots(lid, fmask, gmask, nfast, total, fbase, gbase);
#ifdef SA_STORE_PAIRS
        if (lid == 0u) store_chunk(c0, nfast, total);  // sh_store_base: seen after the round's barrier
#endif
        uint r0 = 0u;
        if (r0 < total) do {
            enqueue(lid, fmask, fbase, r0);
            enqueue(lid, gmask, gbase, r0);
            barrier();
            uint n = min(QCAP, total - r0);
            uint i = lid;
            if (i < n) do {
                uint e = sh_queue[i];
#ifdef SA_STORE_PAIRS
                if (sh_store_base != STORE_MISSING) pstore[2u * pc.capacity + sh_store_base + r0 + i] = e;
#endif
                pair_eval(i, e >> 8, e & 255u, r0 + i < nfast);
                i += 256u;
            } while (i < n);
            barrier();
            round_accumulate(lid, r0, n, cnt, fmask, fbase, gmask, gbase);
            // Another round overwrites the queue and the results; after the last one the next
            // chunk's first barrier is enough.
            if (r0 + QCAP < total) barrier();
            r0 += QCAP;
        } while (r0 < total);
        chunk_end(lid, c0, cnt);
        c0 += CHUNK;
    } while (c0 < end);
}


#endif
