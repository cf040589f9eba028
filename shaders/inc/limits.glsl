// Capacities of the kernels and how they are checked, so that nothing is dropped quietly.
//
// The render counters `stats[]` (host-visible, cleared before every render):
//   [0] candidates tested   [1] overlapping pairs   [2] tile-list entries (binning's true total)
//   [3] the forward kernel hit the device's loop limit
//   [4] most chunks of CHUNK scratches in one tile's list (the true count)
//   [5] the render (or its gradient) is incomplete, for any of the reasons here: Adam refuses
//       such a step and the host redoes the submission after adapting (engine/render/src/scene.rs)
//   [6] the backward kernel hit the device's loop limit
//   [7] binning hit the device's loop limit
//   [8] high word of [0], [9] the (tile, scratch) entries passed 2^32 - 1 (scan.comp), [10] high
//       word of [1]: the 64-bit counters are (hi << 32) | lo
//   [11] pairs the forward of the integrator `adaptive` dropped by their bound (SA_CULL_PAIRS in
//       tile_queue.glsl), [12] its high word
//   [13] queue entries the forward's chunks needed in the pair store (SA_STORE_PAIRS in
//       tile_queue.glsl; counted while the scene has a store), [14] pair-store flags: bit 0 the backward's replay met a chunk that
//       was not stored (it also sets [5]), bit 1 the counter [13] wrapped
//   [15] the most tile tests one binning thread made (bin.comp's COUNT pass): its serial loop
//
// The loop limit: Mesa's llvmpipe (lavapipe) ends every loop of a shader invocation once the
// invocation has run 65535 loop iterations in all (LP_MAX_TGSI_LOOP_ITERATIONS, counted per
// SIMD vector over every loop), silently: a tile with a few hundred chunks loses all its pairs.
// Other drivers have no such counter but have watchdogs; the same mechanism bounds the work of
// one dispatch there. The shaders cannot read the counter, but they can see that it ran out:
// `loop_limit_hit` runs a loop of `pc.sentinel` = 2 iterations (a push constant, so the
// compiler cannot unroll it); with the counter exhausted it stops after one. Called last, it
// tells whether any loop of the invocation was cut short. The host then splits the work (more
// passes of fewer chunks per tile, smaller binning groups) and redoes it; results do not depend
// on the split (every sum keeps its order), so they are the same as in one pass.
#ifndef SA_LIMITS_GLSL
#define SA_LIMITS_GLSL

bool loop_limit_hit(uint two) {
    uint s = 0u;
    for (uint i = 0u; i < two; ++i) ++s;
    return s != two;
}

#endif
