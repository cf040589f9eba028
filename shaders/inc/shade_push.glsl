// Push constants of the shading kernels (forward.comp, grad.comp); Rust twin: ShadePush in
// engine/render/src/layout.rs (checked by tests/layout.rs through test/layout.comp).
#ifndef SA_SHADE_PUSH_GLSL
#define SA_SHADE_PUSH_GLSL
layout(push_constant) uniform Push {
    float half_plate;      // plate half-size (mm)
    float alpha_s;         // plate roughness
    float f0;              // Schlick f0
    uint n_views;
    uint n_groups;         // binning groups (hist is n_tiles x n_groups)
    uint n_tiles;          // tiles of all views
    uint capacity;         // tile-list capacity
    uint chunks_per_pass;  // chunks of a tile's list one pass handles (see inc/limits.glsl)
    uint pass;             // this pass: chunks [pass * chunks_per_pass, ...) of every tile
    uint n_passes;         // passes recorded (a tile with more chunks marks the render incomplete)
    uint sentinel;         // 2 (see loop_limit_hit in inc/limits.glsl)
    uint store_cap;        // entries the pair store holds (0: no store; see tile_queue.glsl)
} pc;
#endif
