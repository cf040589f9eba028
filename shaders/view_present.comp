#version 450
// Viewer present pass: linear L (the engine's image buffer, one view at the internal resolution)
// -> display bytes in the swapchain-sized output buffer, copied to the swapchain image by the
// host. Upscales the internal image to its destination rectangle (bilinear on L, or nearest),
// applies the exposure and the display mapping of engine/docs/model.md section 5, and optionally draws a
// target image (already display values in [0, 1]) beside it. Pixels outside both rectangles get
// the background grey.
//
// The output is gray, so R = G = B and the packing does not depend on whether the swapchain is
// RGBA or BGRA; alpha is 255.
// Push constants: inc/present_push.glsl.
#extension GL_GOOGLE_include_directive : require
#include "inc/view_display.glsl"

layout(local_size_x = 16, local_size_y = 16) in;
layout(std430, binding = 0) readonly buffer Image { float img[]; };    // L of every view (engine layout)
layout(std430, binding = 1) readonly buffer Target { float tgt[]; };   // target display values, tgt_w x tgt_h
layout(std430, binding = 2) writeonly buffer Out { uint outp[]; };     // packed RGBA8, out_w x out_h

#include "inc/present_push.glsl"

float fetch_l(uvec2 p) {
    return img[pc.misc.x + p.y * pc.dims.z + p.x];
}

// Source coordinate of output pixel `d` in a rectangle of size `rw` x `rh` sampling an image of
// `sw` x `sh` pixels (pixel centres aligned: equal sizes give the identity exactly).
vec2 src_coord(uvec2 d, uvec2 rsize, uvec2 ssize) {
    return (vec2(d) + 0.5) * vec2(ssize) / vec2(rsize) - 0.5;
}

float sample_l(uvec2 d) {
    uvec2 rsize = pc.view_rect.zw;
    uvec2 ssize = pc.dims.zw;
    if (rsize == ssize) return fetch_l(d);
    vec2 s = src_coord(d, rsize, ssize);
    vec2 hi = vec2(ssize) - 1.0;
    if ((pc.misc.w & 1u) != 0u) return fetch_l(uvec2(clamp(floor(s + 0.5), vec2(0.0), hi)));
    s = clamp(s, vec2(0.0), hi);
    uvec2 p0 = uvec2(floor(s));
    uvec2 p1 = min(p0 + 1u, ssize - 1u);
    vec2 f = s - vec2(p0);
    float a = mix(fetch_l(p0), fetch_l(uvec2(p1.x, p0.y)), f.x);
    float b = mix(fetch_l(uvec2(p0.x, p1.y)), fetch_l(p1), f.x);
    return mix(a, b, f.y);
}

float sample_target(uvec2 d) {
    uvec2 ssize = pc.misc.yz;
    vec2 s = clamp(src_coord(d, pc.tgt_rect.zw, ssize), vec2(0.0), vec2(ssize) - 1.0);
    uvec2 p0 = uvec2(floor(s));
    uvec2 p1 = min(p0 + 1u, ssize - 1u);
    vec2 f = s - vec2(p0);
    float a = mix(tgt[p0.y * ssize.x + p0.x], tgt[p0.y * ssize.x + p1.x], f.x);
    float b = mix(tgt[p1.y * ssize.x + p0.x], tgt[p1.y * ssize.x + p1.x], f.x);
    return mix(a, b, f.y);
}

bool inside(uvec2 p, uvec4 r) {
    return p.x >= r.x && p.y >= r.y && p.x - r.x < r.z && p.y - r.y < r.w;
}

void main() {
    uvec2 p = gl_GlobalInvocationID.xy;
    if (p.x >= pc.dims.x || p.y >= pc.dims.y) return;
    uint v = display_byte_of(pc.params.y);
    if (inside(p, pc.view_rect)) {
        v = display_byte(sample_l(p - pc.view_rect.xy) * pc.params.x);
    } else if (pc.tgt_rect.z > 0u && inside(p, pc.tgt_rect)) {
        v = display_byte_of(sample_target(p - pc.tgt_rect.xy));
    }
    outp[p.y * pc.dims.x + p.x] = v | (v << 8) | (v << 16) | (255u << 24);
}
