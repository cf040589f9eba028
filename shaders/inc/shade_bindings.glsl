// The one binding layout of the shading kernels (forward.comp, grad.comp, tangent.comp), declared
// once: a slot holds the same buffer in every kernel. Rust twin: the table `SLOTS` in
// engine/render/src/bindings.rs, which builds every shading dispatch's buffer list (its tests
// check that the numbers here are the table's and that no kernel numbers a binding itself).
//
// A kernel defines its role before including this: SA_SHADE_FORWARD, SA_SHADE_BACKWARD or
// SA_SHADE_TANGENT. It sees the slots its role uses, with the access its role has; the host binds
// a placeholder to the others. Storage buffers come first, then the texel buffers (the Vulkan
// layer's convention: engine/vulkan/src/pipeline.rs).
#ifndef SA_SHADE_BINDINGS_GLSL
#define SA_SHADE_BINDINGS_GLSL

#if defined(SA_SHADE_FORWARD) + defined(SA_SHADE_BACKWARD) + defined(SA_SHADE_TANGENT) != 1
#error define exactly one of SA_SHADE_FORWARD, SA_SHADE_BACKWARD, SA_SHADE_TANGENT before inc/shade_bindings.glsl
#endif

#include "common.glsl"
#include "shade_push.glsl"

// Storage buffers of every role.
#define SA_BIND_VIEWS 0          // the views (ViewGPU)
#define SA_BIND_OFFSETS 1        // the scanned histogram of bin.comp: n_tiles * n_groups + 1
#define SA_BIND_LIST 2           // the tile lists (scene indices)
#define SA_BIND_STATS 3          // render counters and flags (inc/limits.glsl)
#define SA_BIND_COVERAGE 4       // sum_k area(F ∩ R_k) / S_P per pixel: the forward writes it, the others read it
#define SA_BIND_PAIR_STORE 5     // the forward's queues (inc/tile_queue.glsl), replayed by the backward
// Storage buffers of one role each.
#define SA_BIND_IMAGE 6          // forward: L of every view, concatenated
#define SA_BIND_CARRY 7          // forward: per pixel between passes, sum I, sum A, pairs, candidates
#define SA_BIND_DL 8             // backward: dE/dL per pixel
#define SA_BIND_PARTIALS 9       // backward: 2 vec4 partial gradients per tile-list entry
#define SA_BIND_SEEDS 10         // tangent: per scratch 6 vec4, the tangents of w (0-3, 4-6), d, alpha
#define SA_BIND_TANGENTS 11      // tangent: per pixel 2 vec4, dL/dθ_j (0-3, 4-6), summed over passes
// Uniform texel buffers: per-lane gathers (inc/scratch_records.glsl, inc/tile_queue.glsl).
#define SA_BIND_RECORDS 12       // 4 RGBA32F texels per scratch (scratch_records.comp)
#define SA_BIND_PIXEL_RECORDS 13 // SA_PIXEL_TEXELS RGBA32F texels per pixel (pixel_records.comp)
#define SA_BIND_LIST_TEX 14      // the tile lists again, R32_UINT
#define SA_BIND_STORE_TEX 15     // the pair store again, R32_UINT
#define SA_SHADE_SLOTS 16

layout(std430, binding = SA_BIND_VIEWS) readonly buffer Views { ViewGPU views[]; };
layout(std430, binding = SA_BIND_OFFSETS) readonly buffer Offsets { uint offs[]; };
layout(std430, binding = SA_BIND_LIST) readonly buffer List { uint list[]; };
layout(std430, binding = SA_BIND_STATS) buffer Stats { uint stats[]; };

#if defined(SA_SHADE_FORWARD)
layout(std430, binding = SA_BIND_COVERAGE) writeonly buffer Coverage { float cov_raw[]; };
layout(std430, binding = SA_BIND_PAIR_STORE) writeonly buffer PairStore { uint pstore[]; };
layout(std430, binding = SA_BIND_IMAGE) writeonly buffer Image { float img[]; };
layout(std430, binding = SA_BIND_CARRY) buffer Carry { vec4 carry[]; };
#elif defined(SA_SHADE_BACKWARD)
layout(std430, binding = SA_BIND_COVERAGE) readonly buffer Coverage { float cov_raw[]; };
layout(std430, binding = SA_BIND_PAIR_STORE) readonly buffer PairStore { uint pstore[]; };
layout(std430, binding = SA_BIND_DL) readonly buffer DL { float dl[]; };
layout(std430, binding = SA_BIND_PARTIALS) writeonly buffer Partials { vec4 partial[]; };
layout(binding = SA_BIND_STORE_TEX) uniform usamplerBuffer store_tex;
#else
layout(std430, binding = SA_BIND_COVERAGE) readonly buffer Coverage { float cov_raw[]; };
layout(std430, binding = SA_BIND_SEEDS) readonly buffer Seeds { vec4 seeds[]; };
layout(std430, binding = SA_BIND_TANGENTS) buffer Tangents { vec4 tang[]; };
#endif

layout(binding = SA_BIND_RECORDS) uniform samplerBuffer recs;
layout(binding = SA_BIND_PIXEL_RECORDS) uniform samplerBuffer precs;
layout(binding = SA_BIND_LIST_TEX) uniform usamplerBuffer list_tex;

#endif
