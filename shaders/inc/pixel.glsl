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
    vec3 X3, pc;  // the shading point in the world; (corners' world points, unused)
#ifndef SA_NO_F64
    dvec2 f = dvec2(ij);
    uvec2 dims = V.dims.xy;
    P.fp[0] = sheet_hit64(V64, dims, f, ok0, pc);
    P.fp[1] = sheet_hit64(V64, dims, f + dvec2(1.0LF, 0.0LF), ok1, pc);
    P.fp[2] = sheet_hit64(V64, dims, f + dvec2(1.0LF, 1.0LF), ok2, pc);
    P.fp[3] = sheet_hit64(V64, dims, f + dvec2(0.0LF, 1.0LF), ok3, pc);
    vec2 X = sheet_hit64(V64, dims, f + dvec2(0.5LF), okc, X3);
#else
    vec2 f = vec2(ij);
    P.fp[0] = sheet_hit(V, f, ok0, pc);
    P.fp[1] = sheet_hit(V, f + vec2(1.0, 0.0), ok1, pc);
    P.fp[2] = sheet_hit(V, f + vec2(1.0, 1.0), ok2, pc);
    P.fp[3] = sheet_hit(V, f + vec2(0.0, 1.0), ok3, pc);
    vec2 X = sheet_hit(V, f + vec2(0.5), okc, X3);
#endif
    if (!(ok0 && ok1 && ok2 && ok3 && okc)) return P;
    if (abs(X.x) > half_plate || abs(X.y) > half_plate) return P;
    vec3 wo = normalize(V.eye.xyz - X3);
    // A concave sheet's raised edge may hide X: then the pixel sees the sheet's back (off the plate).
    if (bent(V) && sheet_blocks(V, X3, wo, length(V.eye.xyz - X3), half_plate)) return P;
    P.on_plate = true;
    // Footprint area relative to its first corner (keeps the products small).
    vec2 a = P.fp[1] - P.fp[0], b = P.fp[2] - P.fp[0], c = P.fp[3] - P.fp[0];
    float sp2 = (a.x * b.y - b.x * a.y) + (b.x * c.y - c.x * b.y);
    P.ccw = sp2 > 0.0;
    float sp = 0.5 * abs(sp2);
    P.inv_sp = 1.0 / sp;
    P.centre = 0.25 * (P.fp[0] + P.fp[1] + P.fp[2] + P.fp[3]);
    for (int k = 0; k < 4; ++k) P.radius = max(P.radius, length(P.fp[k] - P.centre));
    vec3 wi;
    float E, reach;
    if (V.up.w == 0.0) {
        vec3 d = V.light.xyz - X3;
        float r2 = dot(d, d);
        wi = d * inversesqrt(r2);
        E = 1.0 / r2;
        reach = sqrt(r2);
    } else {
        wi = V.light.xyz;
        E = 1.0;
        reach = uintBitsToFloat(0x7f800000u);  // infinity
    }
    // The surface frame at X (the world axes on a flat plate): the scratches' NDFs see h in it.
    vec3 tx, ty, n;
    surface_frame(V, X3, tx, ty, n);
    bool curved = bent(V);
    if (curved && sheet_blocks(V, X3, wi, reach, half_plate)) E = 0.0;  // shaded by the sheet's edge
    P.e_irr = E;
    float cos_i = curved ? dot(wi, n) : wi.z, cos_o = curved ? dot(wo, n) : wo.z;
    if (cos_i <= 0.0 || cos_o <= 0.0) { P.scale = 0.0; return P; }
    vec3 hw = normalize(wi + wo);
    P.h = curved ? vec3(dot(hw, tx), dot(hw, ty), dot(hw, n)) : hw;
    float fr = f0 + (1.0 - f0) * pow(1.0 - clamp(dot(wo, hw), 0.0, 1.0), 5.0);
    P.scale = phi * E * fr / (4.0 * cos_o);
    P.d_flat = ggx_flat(P.h, alpha_s);
    return P;
}
#endif
