// Push constants of the shading kernels (forward.comp, grad.comp); Rust twin: ShadePush in
// engine/src/render/layout.rs (checked by tests/layout.rs through test/layout.comp).
#ifndef SA_SHADE_PUSH_GLSL
#define SA_SHADE_PUSH_GLSL
layout(push_constant) uniform Push {
    float half_plate;  // plate half-size (mm)
    float alpha_s;     // plate roughness
    float f0;          // Schlick f0
    uint n_views;
    uint n_groups;     // binning groups (hist is n_tiles x n_groups)
    uint n_tiles;      // tiles of all views
    uint capacity;     // tile-list capacity
    uint pad0;
} pc;
#endif
