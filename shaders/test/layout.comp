#version 450
// Layout check: reads the shared structs and push constants through their GLSL declarations and
// writes every field back, in declaration order, as raw 32-bit words. The Rust test fills the
// #[repr(C)] twins with distinct values and expects them back in the same order.
#extension GL_GOOGLE_include_directive : require
#include "inc/common.glsl"
layout(local_size_x = 1) in;
layout(std430, binding = 0) readonly buffer Views { ViewGPU views[]; };
layout(std430, binding = 1) readonly buffer Scratches { ScratchGPU scr[]; };
layout(std430, binding = 2) writeonly buffer Out { uint words[]; };
layout(std430, binding = 3) readonly buffer Views64 { ViewGPU64 views64[]; };
#include "inc/shade_push.glsl"

uint o = 0u;
void put(float x) { words[o++] = floatBitsToUint(x); }
void put(uint x) { words[o++] = x; }
void put4(vec4 v) { put(v.x); put(v.y); put(v.z); put(v.w); }
void put4(uvec4 v) { put(v.x); put(v.y); put(v.z); put(v.w); }
void putd(double x) { uvec2 u = unpackDouble2x32(x); put(u.x); put(u.y); }
void put4d(dvec4 v) { putd(v.x); putd(v.y); putd(v.z); putd(v.w); }

void main() {
    for (int k = 0; k < 2; ++k) {
        ViewGPU V = views[k];
        put4(V.eye); put4(V.fwd); put4(V.right); put4(V.up); put4(V.light); put4(V.dims); put4(V.base);
    }
    for (int k = 0; k < 2; ++k) { put4(scr[k].ends); put4(scr[k].shape); }
    for (int k = 0; k < 2; ++k) { put4d(views64[k].eye); put4d(views64[k].fwd); put4d(views64[k].right); put4d(views64[k].up); }
    put(pc.half_plate); put(pc.alpha_s); put(pc.f0); put(pc.n_views); put(pc.n_groups); put(pc.n_tiles); put(pc.capacity); put(pc.chunks_per_pass); put(pc.pass); put(pc.n_passes); put(pc.sentinel); put(pc.store_cap);
}
