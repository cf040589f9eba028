#version 450
// Layout check of the push-constant blocks (and LossSeg) that are not in test/layout.comp: reads
// them through the very headers the kernels include and writes every field back, in declaration
// order, as raw 32-bit words. A shader has one push-constant block, so each is compiled alone:
//   BIN      inc/bin_push.glsl      (bin.comp)           Rust: render::layout::BinPush
//   SCAN     inc/scan_push.glsl     (scan.comp)          Rust: render::layout::ScanPush
//   LOSS     inc/loss_push.glsl     (loss_*.comp)        Rust: optim::loss::{LossPush, LossSeg}
//   PRESENT  inc/present_push.glsl  (view_present.comp)  Rust: render::present::PresentPush
// LOSS also reads two LossSeg from binding 1 and writes them after the push constants.
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
#else
#error "define BIN, SCAN, LOSS or PRESENT"
#endif

uint o = 0u;
void put(float x) { words[o++] = floatBitsToUint(x); }
void put(uint x) { words[o++] = x; }
void put4(vec4 v) { put(v.x); put(v.y); put(v.z); put(v.w); }
void put4(uvec4 v) { put(v.x); put(v.y); put(v.z); put(v.w); }

void main() {
#if defined(BIN)
    put(pc.n_scratches); put(pc.n_views); put(pc.n_groups); put(pc.group_size); put(pc.capacity);
    put(pc.pad0); put(pc.pad1); put(pc.pad2);
#elif defined(SCAN)
    put(pc.n); put(pc.n_blocks); put(pc.pad0); put(pc.pad1);
#elif defined(LOSS)
    put(pc.n_views); put(pc.n_levels); put(pc.level); put(pc.n_blocks); put(pc.lvl_begin); put(pc.lvl_end);
    put(pc.lambda_p); put(pc.lambda_g); put(pc.g_c); put(pc.g_s); put(pc.n_segs); put(pc.pad);
    for (int k = 0; k < 2; ++k) {
        LossSeg S = segs[k];
        put(S.off); put(S.w); put(S.h); put(S.view); put(S.level); put(S.blk0); put(S.nblk); put(S.pad);
    }
#elif defined(PRESENT)
    put4(pc.dims); put4(pc.view_rect); put4(pc.tgt_rect); put4(pc.misc); put4(pc.params);
#endif
}
