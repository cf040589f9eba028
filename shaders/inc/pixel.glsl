// Per-pixel quantities of engine/docs/model.md sections 4-5 shared by the forward and backward kernels.
#ifndef SA_PIXEL_GLSL
#define SA_PIXEL_GLSL
#include "common.glsl"

// Texels per pixel of pixel_records.comp's records (inc/scratch_records.glsl reads them).
#define SA_PIXEL_TEXELS 5u

struct PixelSetup {
    bool on_plate;     // engine/docs/model.md section 4; off-plate pixels are exactly 0 with no gradient
    vec2 fp[4];        // footprint corners on the plate: (i,j), (i+1,j), (i+1,j+1), (i,j+1)
    vec2 centre;       // centroid of the corners (for culling only)
    float radius;      // max distance centroid -> corner (for culling only)
    float inv_sp;      // 1 / area(F)
    bool ccw;          // footprint corners counter-clockwise on the plate (x, y)
    vec3 h;            // half vector
    float scale;       // E Fr / (4 cos_o): L = scale * (D_P + (1 - cov) D_flat)
    float d_flat;      // D(h . z; alpha_s)
    float e_irr;       // E / Phi (so dL/dPhi = L / Phi)
};

PixelSetup pixel_setup(ViewGPU V, ViewGPU64 V64, float phi, uvec2 ij, float half_plate, float alpha_s, float f0) {
    PixelSetup P;
    P.on_plate = false;
    P.ccw = true;
    P.scale = 0.0; P.d_flat = 0.0; P.inv_sp = 0.0; P.radius = 0.0; P.e_irr = 0.0;
    P.h = vec3(0.0, 0.0, 1.0); P.centre = vec2(0.0);
    bool ok0, ok1, ok2, ok3, okc;
#ifndef SA_NO_F64
    dvec2 f = dvec2(ij);
    uvec2 dims = V.dims.xy;
    P.fp[0] = ray_hit64(V64, dims, f, ok0);
    P.fp[1] = ray_hit64(V64, dims, f + dvec2(1.0LF, 0.0LF), ok1);
    P.fp[2] = ray_hit64(V64, dims, f + dvec2(1.0LF, 1.0LF), ok2);
    P.fp[3] = ray_hit64(V64, dims, f + dvec2(0.0LF, 1.0LF), ok3);
    vec2 X = ray_hit64(V64, dims, f + dvec2(0.5LF), okc);
#else
    vec2 f = vec2(ij);
    P.fp[0] = ray_hit(V, f, ok0);
    P.fp[1] = ray_hit(V, f + vec2(1.0, 0.0), ok1);
    P.fp[2] = ray_hit(V, f + vec2(1.0, 1.0), ok2);
    P.fp[3] = ray_hit(V, f + vec2(0.0, 1.0), ok3);
    vec2 X = ray_hit(V, f + vec2(0.5), okc);
#endif
    if (!(ok0 && ok1 && ok2 && ok3 && okc)) return P;
    if (abs(X.x) > half_plate || abs(X.y) > half_plate) return P;
    P.on_plate = true;
    // Footprint area relative to its first corner (keeps the products small).
    vec2 a = P.fp[1] - P.fp[0], b = P.fp[2] - P.fp[0], c = P.fp[3] - P.fp[0];
    float sp2 = (a.x * b.y - b.x * a.y) + (b.x * c.y - c.x * b.y);
    P.ccw = sp2 > 0.0;
    float sp = 0.5 * abs(sp2);
    P.inv_sp = 1.0 / sp;
    P.centre = 0.25 * (P.fp[0] + P.fp[1] + P.fp[2] + P.fp[3]);
    for (int k = 0; k < 4; ++k) P.radius = max(P.radius, length(P.fp[k] - P.centre));
    vec3 X3 = vec3(X, 0.0);
    vec3 wo = normalize(V.eye.xyz - X3);
    vec3 wi;
    float E;
    if (V.up.w == 0.0) {
        vec3 d = V.light.xyz - X3;
        float r2 = dot(d, d);
        wi = d * inversesqrt(r2);
        E = 1.0 / r2;
    } else {
        wi = V.light.xyz;
        E = 1.0;
    }
    P.e_irr = E;
    float cos_i = wi.z, cos_o = wo.z;
    if (cos_i <= 0.0 || cos_o <= 0.0) { P.scale = 0.0; return P; }
    P.h = normalize(wi + wo);
    float fr = f0 + (1.0 - f0) * pow(1.0 - clamp(dot(wo, P.h), 0.0, 1.0), 5.0);
    P.scale = phi * E * fr / (4.0 * cos_o);
    P.d_flat = ggx_flat(P.h, alpha_s);
    return P;
}
#endif
