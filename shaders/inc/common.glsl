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
    vec4 right;  // xyz right (unit); w = the plate's signed bend radius: 0 flat, +R convex, -R concave
    vec4 up;     // xyz up' (unit); w = light kind: 0 point, 1 directional
    vec4 light;  // xyz point-light position, or unit direction towards a directional light;
                 // w = the bend's axis: 0 about the sheet's y (its x wraps), 1 about its x
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
    dvec4 right;  // xyz right; w = the signed bend radius (as ViewGPU's)
    dvec4 up;     // xyz up'; w = the bend's axis (as ViewGPU's light.w)
};

// atan2(y, x) in float64 (GLSL has no float64 trigonometry) for |atan2| <= 150 degrees (a bent
// sheet spans at most 300): theta/2 = atan(y / (r + x)), halved three times more by
// tan(a/2) = t / (1 + sqrt(1 + t^2)), so |t| <= tan(150/16 degrees) = 0.165, where the Taylor
// series to t^21 leaves 0.165^23 / 23 < 1e-19.
double atan2_64(double y, double x) {
    double t = y / (sqrt(x * x + y * y) + x);
    for (int k = 0; k < 3; ++k) t = t / (1.0LF + sqrt(1.0LF + t * t));
    double t2 = t * t;
    double p = 1.0LF / 21.0LF;
    for (int n = 9; n >= 0; --n) p = 1.0LF / double(2 * n + 1) - t2 * p;
    return 16.0LF * t * p;
}

// Hit of the ray o + t d on a bent sheet's scratched face (engine/docs/model.md section 10): the
// cylinder of signed radius rs (+R convex, -R concave) about an axis parallel to the sheet's y
// (about_x false) or x, extended past the sheet; a convex sheet's near root when the eye is
// outside, a concave sheet's far root. Returns sheet coordinates; p is the world point.
vec2 cylinder_hit64(dvec3 o, dvec3 d, double rs, bool about_x, out dvec3 p, out bool ok) {
    double rad = abs(rs), s = rs > 0.0LF ? 1.0LF : -1.0LF;
    dvec3 O = about_x ? o.yxz : o, D = about_x ? d.yxz : d;  // (a, b, z): a wraps, b along the axis
    double oz = O.z + s * rad;                                   // z - c, the axis at c = -s rad
    double A = D.x * D.x + D.z * D.z;
    double B = O.x * D.x + oz * D.z;
    double C = O.x * O.x + oz * oz - rad * rad;
    double disc = B * B - A * C;
    double q = -(B + (B >= 0.0LF ? 1.0LF : -1.0LF) * sqrt(max(disc, 0.0LF)));
    double r1 = q / (A > 0.0LF ? A : 1.0LF), r2 = C / (q != 0.0LF ? q : 1.0LF);
    double t1 = min(r1, r2), t2 = max(r1, r2);
    double t = s > 0.0LF ? t1 : t2;
    ok = A > 0.0LF && disc >= 0.0LF && q != 0.0LF && t > 0.0LF;
    if (!ok) t = 0.0LF;
    dvec3 H = O + t * D;
    p = about_x ? H.yxz : H;
    double th = atan2_64(H.x / rad, s * (H.z + s * rad) / rad);
    vec2 wa = vec2(rad * th, H.y);  // (wrapped, along)
    return about_x ? wa.yx : wa;
}

// Plate hit of the ray through image point sp, in float64 (see ray_hit): the plane z = 0, or a
// bent sheet's surface (then in sheet coordinates); p is the world point.
vec2 sheet_hit64(ViewGPU64 v, uvec2 dims, dvec2 sp, out bool ok, out vec3 p) {
    double kx = (2.0LF * sp.x / double(dims.x) - 1.0LF) * v.eye.w * v.fwd.w;
    double ky = (1.0LF - 2.0LF * sp.y / double(dims.y)) * v.eye.w;
    dvec3 d = v.fwd.xyz + kx * v.right.xyz + ky * v.up.xyz;
    if (v.right.w != 0.0LF) {
        dvec3 pd;
        vec2 uv = cylinder_hit64(v.eye.xyz, d, v.right.w, v.up.w != 0.0LF, pd, ok);
        p = vec3(pd);
        return uv;
    }
    ok = d.z < 0.0LF && v.eye.z > 0.0LF || d.z > 0.0LF && v.eye.z < 0.0LF;
    double s = -v.eye.z / (d.z != 0.0LF ? d.z : 1.0LF);
    vec2 hit = vec2(v.eye.xy + s * d.xy);
    p = vec3(hit, 0.0);
    return hit;
}
#else
struct ViewGPU64 { uvec4 pad[8]; };
#endif

// One scratch as the user gives it (engine/docs/model.md section 2).
struct ScratchGPU {
    vec4 ends;   // p0.x, p0.y, p1.x, p1.y (mm)
    vec4 shape;  // w, d, alpha, an arc chord's area weight k (patch_ndf.glsl; 0: straight)
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

// The bend of a view's plate (engine/docs/model.md section 10): R and s = +1 convex, -1 concave.
bool bent(ViewGPU v) { return v.right.w != 0.0; }
bool bent_about_x(ViewGPU v) { return v.light.w != 0.0; }

// [sheet_hit64] in float32 (devices without shaderFloat64).
vec2 sheet_hit(ViewGPU v, vec2 sp, out bool ok, out vec3 p) {
    if (!bent(v)) {
        vec2 hit = ray_hit(v, sp, ok);
        p = vec3(hit, 0.0);
        return hit;
    }
    bool ax = bent_about_x(v);
    float rad = abs(v.right.w), s = sign(v.right.w);
    vec3 d = ray_dir(v, sp);
    vec3 O = ax ? v.eye.yxz : v.eye.xyz, D = ax ? d.yxz : d;
    float oz = O.z + s * rad;
    float A = D.x * D.x + D.z * D.z;
    float B = O.x * D.x + oz * D.z;
    float C = O.x * O.x + oz * oz - rad * rad;
    float disc = B * B - A * C;
    float q = -(B + (B >= 0.0 ? 1.0 : -1.0) * sqrt(max(disc, 0.0)));
    float r1 = q / (A > 0.0 ? A : 1.0), r2 = C / (q != 0.0 ? q : 1.0);
    float t = s > 0.0 ? min(r1, r2) : max(r1, r2);
    ok = A > 0.0 && disc >= 0.0 && q != 0.0 && t > 0.0;
    if (!ok) t = 0.0;
    vec3 H = O + t * D;
    p = ax ? H.yxz : H;
    vec2 wa = vec2(rad * atan(H.x, s * (H.z + s * rad)), H.y);
    return ax ? wa.yx : wa;
}

// The surface frame at world point p of a bent sheet: unit tangents along the sheet's x and y and
// the scratched face's normal (tx x ty = n); the world axes on a flat plate.
void surface_frame(ViewGPU v, vec3 p, out vec3 tx, out vec3 ty, out vec3 n) {
    tx = vec3(1.0, 0.0, 0.0); ty = vec3(0.0, 1.0, 0.0); n = vec3(0.0, 0.0, 1.0);
    if (!bent(v)) return;
    bool ax = bent_about_x(v);
    float rad = abs(v.right.w), s = sign(v.right.w);
    vec3 H = ax ? p.yxz : p;
    float sn = H.x / rad, cs = s * (H.z + s * rad) / rad;
    vec3 nn = vec3(s * sn, 0.0, cs), tw = vec3(cs, 0.0, -s * sn), ta = vec3(0.0, 1.0, 0.0);
    n = ax ? nn.yxz : nn;
    tx = ax ? ta.yxz : tw;
    ty = ax ? tw.yxz : ta;
}

// Whether a concave sheet (half side half_plate) blocks the ray leaving its surface point p along
// unit d before distance max_t: its raised edges hide its inside from a low eye and shade it from
// a low lamp. Flat and convex sheets never block a ray leaving their scratched face.
bool sheet_blocks(ViewGPU v, vec3 p, vec3 d, float max_t, float half_plate) {
    if (!(v.right.w < 0.0)) return false;
    bool ax = bent_about_x(v);
    float rad = -v.right.w;  // s = -1: the axis at z = rad
    vec3 X = ax ? p.yxz : p, D = ax ? d.yxz : d;
    float A = D.x * D.x + D.z * D.z;
    if (!(A > 0.0)) return false;
    float t = -2.0 * (X.x * D.x + (X.z - rad) * D.z) / A;  // the other root (p is on the cylinder)
    if (!(t > 1e-3) || !(t < max_t)) return false;
    vec3 H = X + t * D;
    vec2 wa = vec2(rad * atan(H.x, rad - H.z), H.y);
    return abs(wa.x) <= half_plate && abs(wa.y) <= half_plate;
}

// The world point of sheet point q: (q, 0) on a flat plate.
vec3 sheet_to_world(ViewGPU v, vec2 q) {
    if (!bent(v)) return vec3(q, 0.0);
    bool ax = bent_about_x(v);
    float rad = abs(v.right.w), s = sign(v.right.w);
    vec2 wa = ax ? q.yx : q;
    float th = wa.x / rad, sh = sin(0.5 * th);
    vec3 H = vec3(rad * sin(th), wa.y, -2.0 * s * rad * sh * sh);  // z = c + s rad cos(theta)
    return ax ? H.yxz : H;
}

// World point -> image point; ok = false when the point is not in front of the camera.
vec2 project3(ViewGPU v, vec3 q, out bool ok) {
    vec3 d = q - v.eye.xyz;
    float z = dot(d, v.fwd.xyz);
    ok = z > 1e-6 * length(d);
    float kx = dot(d, v.right.xyz) / z;
    float ky = dot(d, v.up.xyz) / z;
    return vec2((kx / (v.eye.w * v.fwd.w) + 1.0) * 0.5 * float(v.dims.x),
                (1.0 - ky / v.eye.w) * 0.5 * float(v.dims.y));
}

// Flat-plate point -> image point; ok = false when the point is not in front of the camera.
vec2 project(ViewGPU v, vec2 q, out bool ok) {
    return project3(v, vec3(q, 0.0), ok);
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
