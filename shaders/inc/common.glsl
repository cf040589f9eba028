// Shared structs and camera geometry (engine/docs/model.md sections 1-4).
// Every struct here has a #[repr(C)] twin in engine/render/src/layout.rs; a test checks they agree.
#ifndef SA_COMMON_GLSL
#define SA_COMMON_GLSL

#include "real.glsl"

#define PI 3.14159265358979323846
#define TILE 16u

// One view: camera basis, image size, light. std430, 16-byte rows.
struct ViewGPU {
    vec4 eye;    // xyz camera position; w = tan(fov_y / 2)
    vec4 fwd;    // xyz forward (unit); w = aspect W / H
    vec4 right;  // xyz right (unit); w unused (0): intensities have their own buffer
    vec4 up;     // xyz up' (unit); w = light kind: 0 point, 1 directional
    vec4 light;  // xyz point-light position, or unit direction towards a directional light
    uvec4 dims;  // W, H, tiles_x, tiles_y
    uvec4 base;  // first tile index, first pixel index (in the concatenated image buffer), 0, 0
};

// The camera of a view in float64, for the footprint and shading-point ray hits (the float32
// camera puts footprint corners ~1e-5 mm off, which matters for slivers under sharp lobes).
// Devices without shaderFloat64 get SA_NO_F64 and a same-size placeholder.
#ifndef SA_NO_F64
struct ViewGPU64 {
    dvec4 eye;    // xyz camera position; w = tan(fov_y / 2)
    dvec4 fwd;    // xyz forward; w = aspect W / H
    dvec4 right;  // xyz right
    dvec4 up;     // xyz up'
};

// Plate-plane hit of the ray through image point sp, in float64 (see ray_hit).
vec2 ray_hit64(ViewGPU64 v, uvec2 dims, dvec2 sp, out bool ok) {
    double kx = (2.0LF * sp.x / double(dims.x) - 1.0LF) * v.eye.w * v.fwd.w;
    double ky = (1.0LF - 2.0LF * sp.y / double(dims.y)) * v.eye.w;
    dvec3 d = v.fwd.xyz + kx * v.right.xyz + ky * v.up.xyz;
    ok = d.z < 0.0LF && v.eye.z > 0.0LF || d.z > 0.0LF && v.eye.z < 0.0LF;
    double s = -v.eye.z / (d.z != 0.0LF ? d.z : 1.0LF);
    return vec2(v.eye.xy + s * d.xy);
}
#else
struct ViewGPU64 { uvec4 pad[8]; };
#endif

// One scratch as the user gives it (engine/docs/model.md section 2).
struct ScratchGPU {
    vec4 ends;   // p0.x, p0.y, p1.x, p1.y (mm)
    vec4 shape;  // w, d, alpha, unused
};

// Image point (sx, sy) -> unnormalized ray direction (normalization does not move the hit).
vec3 ray_dir(ViewGPU v, vec2 sp) {
    float kx = (2.0 * sp.x / float(v.dims.x) - 1.0) * v.eye.w * v.fwd.w;
    float ky = (1.0 - 2.0 * sp.y / float(v.dims.y)) * v.eye.w;
    return v.fwd.xyz + kx * v.right.xyz + ky * v.up.xyz;
}

// Plate-plane hit of the ray through image point sp; ok = false when it misses (s <= 0 or dir.z = 0).
vec2 ray_hit(ViewGPU v, vec2 sp, out bool ok) {
    vec3 d = ray_dir(v, sp);
    float s = -v.eye.z / d.z;
    ok = d.z != 0.0 && s > 0.0 && !isinf(s);
    return v.eye.xy + s * d.xy;
}

// Plate point -> image point; ok = false when the point is not in front of the camera.
vec2 project(ViewGPU v, vec2 q, out bool ok) {
    vec3 d = vec3(q, 0.0) - v.eye.xyz;
    float z = dot(d, v.fwd.xyz);
    ok = z > 1e-6 * length(d);
    float kx = dot(d, v.right.xyz) / z;
    float ky = dot(d, v.up.xyz) / z;
    return vec2((kx / (v.eye.w * v.fwd.w) + 1.0) * 0.5 * float(v.dims.x),
                (1.0 - ky / v.eye.w) * 0.5 * float(v.dims.y));
}

// GGX point NDF (engine/docs/model.md section 3) of the macro normal z, with the stable denominator of
// section 9: alpha^2 c^2 + |z x h|^2 instead of (alpha^2 - 1) c^2 + 1.
float ggx_flat(vec3 h, float alpha) {
    if (h.z <= 0.0) return 0.0;
    float a2 = alpha * alpha;
    float den = a2 * h.z * h.z + dot(h.xy, h.xy);
    return a2 / (PI * den * den);
}

// Half-width of the carved region: e = (w/2) sqrt(1 - exp(-2d/w)); returns s_e = 2e/w. For small
// x = 2d/w, 1 - exp(-x) is its Taylor series to x^5 (relative truncation error x^5/720 <= 1.4e-8
// below x = 0.1), with no exp or log at all: CPU drivers' exp and log are not accurate enough
// near 1 for Kahan's expm1 trick (llvmpipe gave e for d/w = 3e-8 at any smaller d/w, found by
// tests/stability.rs). Above, 1 - exp(-x) loses at most a factor exp(-x)/(1 - exp(-x)) < 10 of
// exp's accuracy. Written over the scalar type R (real.glsl): binning and culling use it in
// float, the backward kernel differentiates it. In a dual build, `val(carved_se(rc(w), rc(d)))`
// is the float value: the value part of every dual operation used here is the float operation.
R carved_se(R w, R d) {
    R x = dv(mul(2.0, d), w);
    R one_minus;
    if (val(x) < 0.1) {
        R p = sub(1.0 / 24.0, mul(x, 1.0 / 120.0));
        p = sub(1.0 / 6.0, mul(x, p));
        p = sub(0.5, mul(x, p));
        p = sub(1.0, mul(x, p));
        one_minus = mul(x, p);
    } else {
        one_minus = sub(1.0, d_exp(neg(x)));
    }
    return d_sqrt(one_minus);
}

#endif
