#version 450
// Layout check of the push-constant blocks (and LossSeg) that are not in test/layout.comp: reads
// them through the very headers the kernels include and writes every field back, in declaration
// order, as raw 32-bit words. A shader has one push-constant block, so each is compiled alone:
//   BIN      inc/bin_push.glsl      (bin.comp)           Rust: render::layout::BinPush
//   SCAN     inc/scan_push.glsl     (scan.comp)          Rust: render::layout::ScanPush
//   LOSS     inc/loss_push.glsl     (loss_*.comp)        Rust: optim::loss::{LossPush, LossSeg}
//   PRESENT  inc/present_push.glsl  (view_present.comp)  Rust: render::present::PresentPush
//   REDUCE   inc/reduce_push.glsl   (grad_reduce.comp)   Rust: render::layout::ReducePush
//   ADAM     inc/adam_push.glsl     (adam.comp)          Rust: optim::adam::{AdamPush, AdamGroupGpu}
//   PROJECT  inc/project_push.glsl  (scratch_project.comp) Rust: optim::scene_params::ProjectPush
//   CHECK    inc/check_push.glsl    (check_loss.comp)    Rust: optim::check::CheckPush
//   TOOLMAP  inc/tool_map_push.glsl (tool_map.comp)      Rust: optim::tool_params::ToolMapPush
//   RADIX    inc/radix_push.glsl    (radix.comp)         Rust: render::layout::RadixPush
// LOSS (ADAM) also reads two LossSeg (AdamGroupGPU) from binding 1 and writes them after the
// push constants.
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 1) in;
layout(std430, binding = 0) writeonly buffer Out { uint words[]; };
#if defined(BIN)
#include "inc/bin_push.glsl"
#elif defined(SCAN)
#include "inc/scan_push.glsl"
#elif defined(LOSS)
#include "inc/loss_push.glsl"
layout(std430, binding = 1) readonly buffer Segs { LossSeg segs[]; };
#elif defined(PRESENT)
#include "inc/present_push.glsl"
#elif defined(REDUCE)
#include "inc/reduce_push.glsl"
#elif defined(ADAM)
#include "inc/adam_push.glsl"
layout(std430, binding = 1) readonly buffer Groups { AdamGroupGPU groups[]; };
#elif defined(PROJECT)
#include "inc/project_push.glsl"
#elif defined(CHECK)
#include "inc/check_push.glsl"
#elif defined(TOOLMAP)
#include "inc/tool_map_push.glsl"
#elif defined(RADIX)
#include "inc/radix_push.glsl"
#else
#error "define BIN, SCAN, LOSS, PRESENT, REDUCE, ADAM, PROJECT, CHECK, TOOLMAP or RADIX"
#endif

uint o = 0u;
void put(float x) { words[o++] = floatBitsToUint(x); }
void put(uint x) { words[o++] = x; }
void put4(vec4 v) { put(v.x); put(v.y); put(v.z); put(v.w); }
void put4(uvec4 v) { put(v.x); put(v.y); put(v.z); put(v.w); }

void main() {
#if defined(BIN)
    put(pc.n_scratches); put(pc.n_views); put(pc.n_groups); put(pc.group_size); put(pc.capacity);
    put(pc.sentinel); put(pc.n_bands); put(pc.pad2);
#elif defined(SCAN)
    put(pc.n); put(pc.n_blocks); put(pc.flag_index); put(pc.pad1);
#elif defined(LOSS)
    put(pc.n_views); put(pc.n_levels); put(pc.level); put(pc.n_blocks); put(pc.lvl_begin); put(pc.lvl_end);
    put(pc.lambda_p); put(pc.lambda_g); put(pc.g_c); put(pc.g_s); put(pc.n_segs); put(pc.n_pairs);
    for (int k = 0; k < 2; ++k) {
        LossSeg S = segs[k];
        put(S.off); put(S.w); put(S.h); put(S.view); put(S.level); put(S.blk0); put(S.nblk); put(S.weight);
    }
#elif defined(PRESENT)
    put4(pc.dims); put4(pc.view_rect); put4(pc.tgt_rect); put4(pc.misc); put4(pc.params);
#elif defined(REDUCE)
    put(pc.n_scratches); put(pc.capacity); put(pc.n_parts); put(pc.pad1);
#elif defined(ADAM)
    put(pc.n); put(pc.stride); put(pc.check_objective); put(pc.objective_index); put(pc.capacity);
    put(pc.beta1); put(pc.beta2); put(pc.eps); put(pc.bc1); put(pc.bc2); put(pc.loss_limit); put(pc.pad0);
    for (int k = 0; k < 2; ++k) { put4(groups[k].lr_lo_hi); put4(groups[k].mode_frozen); }
#elif defined(PROJECT)
    put(pc.n_scratches); put(pc.half_plate); put(pc.min_len); put(pc.pad0);
#elif defined(CHECK)
    put(pc.n_views); put(pc.n_pixels); put(pc.pad0); put(pc.pad1);
#elif defined(TOOLMAP)
    put(pc.n_scratches); put(pc.n_table); put(pc.mode); put(pc.seed);
    put(pc.z_first); put(pc.s_lo); put(pc.inv_ds); put(pc.alpha);
    put(pc.sigma_z); put(pc.sigma_xy); put(pc.pad0); put(pc.pad1);
#elif defined(RADIX)
    put(pc.n_blocks); put(pc.shift); put(pc.total_index); put(pc.capacity); put(pc.first);
    put(pc.pad0); put(pc.pad1); put(pc.pad2);
#endif
}
