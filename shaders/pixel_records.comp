#version 450
// Per-pixel records for the shading kernels, once per render before them: five RGBA32F texels
// per pixel (its footprint corners, ordered counter-clockwise in the scratch frames as the pair
// integrals take them, its half vector, and the rest of its set-up that the kernels use), read
// through a uniform texel buffer (`precs`, see inc/scratch_records.glsl): by the pair integrals
// where a queue entry needs another pixel's data, and by every kernel for its own pixel, so the
// float64 set-up runs once per render instead of once per kernel. Written through a
// storage texel buffer, so its size is bounded by the device's texel count, not by its
// storage-buffer range. The last texel holds (scale, on the plate, corners counter-clockwise on
// the plate, -): inc/centroid.glsl undoes the reordering with the third. One workgroup per 16x16 tile, laid out as the shading kernels'.
#extension GL_GOOGLE_include_directive : require
#include "inc/common.glsl"
#include "inc/pixel.glsl"

layout(local_size_x = 16, local_size_y = 16) in;
layout(std430, binding = 0) readonly buffer Views { ViewGPU views[]; };
layout(std430, binding = 1) readonly buffer Views64 { ViewGPU64 views64[]; };  // float64 cameras
layout(std430, binding = 2) readonly buffer Lights { float intensity[]; };     // Phi per view
layout(binding = 3, rgba32f) uniform writeonly imageBuffer out_recs;
#include "inc/shade_push.glsl"
#include "inc/tiles.glsl"

void main() {
    uint tile = gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x;
    if (tile >= pc.n_tiles) return;
    uvec2 t0;
    uint vi = tile_view(tile, t0);
    ViewGPU V = views[vi];
    uvec2 ij = t0 + tile_pixel(gl_LocalInvocationIndex);
    if (ij.x >= V.dims.x || ij.y >= V.dims.y) return;
    PixelSetup P = pixel_setup(V, views64[vi], intensity[vi], ij, pc.half_plate, pc.alpha_s, pc.f0);
    // The map to (s, v) = (2 (q-p0).b / w, (q-p0).t) has determinant -2/w < 0: a footprint that
    // is counter-clockwise on the plate is clockwise in (s, v), so store it reversed.
    vec2 f0 = P.fp[P.ccw ? 3 : 0], f1 = P.fp[P.ccw ? 2 : 1], f2 = P.fp[P.ccw ? 1 : 2], f3 = P.fp[P.ccw ? 0 : 3];
    int b = int(SA_PIXEL_TEXELS * (V.base.y + ij.y * V.dims.x + ij.x));
    imageStore(out_recs, b, vec4(f0, f1));
    imageStore(out_recs, b + 1, vec4(f2, f3));
    imageStore(out_recs, b + 2, vec4(P.h, P.d_flat));
    imageStore(out_recs, b + 3, vec4(P.centre, P.radius, P.inv_sp));
    imageStore(out_recs, b + 4, vec4(P.scale, P.on_plate ? 1.0 : 0.0, P.ccw ? 1.0 : 0.0, 0.0));
}
