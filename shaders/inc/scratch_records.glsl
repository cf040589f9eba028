// The per-scratch records of scratch_records.comp, bound to the shading kernels as a uniform
// texel buffer (`recs`, slot SA_BIND_RECORDS of inc/shade_bindings.glsl): four
// RGBA32F texels per scratch, fetched by scene index; and the per-pixel records of
// pixel_records.comp after them. A texel fetch with a per-lane index is a
// vector gather on CPU drivers (llvmpipe), where a shared-memory or storage-buffer load with a
// per-lane index is a scalar loop over the lanes: the candidate tests and the pair integrals
// read a scratch's data through these, not through shared memory.
#ifndef SA_SCRATCH_RECORDS_GLSL
#define SA_SCRATCH_RECORDS_GLSL

#include "shade_bindings.glsl"

vec4 rec_ends(uint si) { return texelFetch(recs, int(4u * si)); }        // p0.xy, p1.xy (ScratchGPU.ends)
vec4 rec_shape(uint si) { return texelFetch(recs, int(4u * si + 1u)); }  // w, d, alpha, - (ScratchGPU.shape)
vec4 rec_cull_a(uint si) { return texelFetch(recs, int(4u * si + 2u)); } // p0.xy, unit direction t.xy
vec4 rec_cull_b(uint si) { return texelFetch(recs, int(4u * si + 3u)); } // len, w, s_e, alpha

// The per-pixel records of pixel_records.comp (`precs`, slot SA_BIND_PIXEL_RECORDS):
// SA_PIXEL_TEXELS (pixel.glsl) texels per pixel of the views' concatenated images: the footprint corners as the pair integrals take them, (h, d_flat), (centre, radius, inv_sp),
// (scale, on_plate, -, -).

// Pixel `pix` (its index in the concatenated images): footprint corners and half vector.
void pixel_record(uint pix, out vec2 fp[4], out vec3 h) {
    int b = int(SA_PIXEL_TEXELS * pix);
    vec4 a = texelFetch(precs, b), c = texelFetch(precs, b + 1);
    fp = vec2[](a.xy, a.zw, c.xy, c.zw);
    h = texelFetch(precs, b + 2).xyz;
}

#endif
