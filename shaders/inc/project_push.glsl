// Push constants of scratch_project.comp; Rust twin: ProjectPush in
// engine/optim/src/scene_params.rs (checked by tests/layout.rs).
#ifndef SA_PROJECT_PUSH_GLSL
#define SA_PROJECT_PUSH_GLSL
layout(push_constant) uniform Push {
    uint n_scratches;
    float half_plate;  // mm
    float min_len;     // shortest allowed scratch, mm
    uint pad0;
} pc;
#endif
