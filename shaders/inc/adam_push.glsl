// Push constants and the learning-rate group record of adam.comp; Rust twins: AdamPush and
// AdamGroupGpu in engine/optim/src/adam.rs (checked by tests/layout.rs).
#ifndef SA_ADAM_PUSH_GLSL
#define SA_ADAM_PUSH_GLSL
struct AdamGroupGPU {
    vec4 lr_lo_hi;     // learning rate (already scaled by the rollback factor), lower, upper bound, 0
    uvec4 mode_frozen; // x: 1 = logarithmic space; y: 1 = frozen; z, w unused
};
layout(push_constant) uniform Push {
    uint n;               // floats in the block
    uint stride;          // element i is in group i % stride
    uint check_objective; // CHECK also tests the objective and the render (one block per step)
    uint objective_index; // where the objective's total is in objv[]
    uint capacity;        // tile-list capacity of the render
    float beta1;
    float beta2;
    float eps;
    float bc1;            // 1 - beta1^t
    float bc2;            // 1 - beta2^t
    float loss_limit;     // an objective above this (10x the best so far) is an exploding step
    uint pad0;
} pc;
#endif
