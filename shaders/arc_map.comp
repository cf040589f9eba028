#version 450
// Arc scratches on the device (engine/docs/model.md section 11, engine/render/src/arcs.rs): the
// scene's scratches (`arcs`, shape.w = bulge) and the chords the kernels render (`chords`,
// shape.w = the chord's area weight k).
//   mode 0 (one thread per chord): chord j of its arc's n, endpoints at fractions j/n and
//          (j+1)/n along the arc (the arc's own ends exact), w, d, alpha as the arc's, k;
//   mode 1 (one thread per arc): the arc's dE/d(x0, y0, x1, y1, w, d, alpha, bulge) from its
//          chords' dE/d(x0, y0, x1, y1, w, d, alpha, kappa), in chord order (bit-reproducible).
// The chord's endpoint at fraction t, in complex numbers: P = p0 + (p1 - p0) g, g = rho e^{i a},
// rho = sin(theta t / 2) / sin(theta / 2), a = theta (t - 1) / 2, theta = 4 atan(bulge); its
// curvature kappa = 2 k / w = 2 sin(theta / 2) / |p1 - p0|. The float64 twins:
// scratchart_model::arc::point_and_jacobian and chord_weight_and_gradient.
#extension GL_GOOGLE_include_directive : require
#include "inc/common.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Arcs { ScratchGPU arc[]; };
layout(std430, binding = 1) buffer Chords { ScratchGPU chord[]; };
layout(std430, binding = 2) readonly buffer ChordOf { uvec2 chord_of[]; };     // (arc, j | n << 16)
layout(std430, binding = 3) readonly buffer ArcChords { uvec2 arc_chords[]; }; // (first chord, n)
layout(std430, binding = 4) readonly buffer ChordGrad { vec4 cg[]; };          // 2 per chord
layout(std430, binding = 5) buffer ArcGrad { vec4 ag[]; };                     // 2 per arc
layout(push_constant) uniform Push {
    uint n;     // chords (mode 0) or arcs (mode 1)
    uint mode;
    uint pad0, pad1;
} pc;

// g(t) and dg/dtheta for sweep theta.
void arc_g(float theta, float t, out vec2 g, out vec2 dg) {
    float rho, drho;
    if (abs(theta) < 1e-3) {
        rho = t * (1.0 + (1.0 - t * t) * theta * theta / 24.0);
        drho = t * (1.0 - t * t) * theta / 12.0;
    } else {
        float sh = sin(0.5 * theta), ch = cos(0.5 * theta);
        float st = sin(0.5 * theta * t), ct = cos(0.5 * theta * t);
        rho = st / sh;
        drho = (0.5 * t * ct * sh - 0.5 * st * ch) / (sh * sh);
    }
    float a = 0.5 * theta * (t - 1.0), da = 0.5 * (t - 1.0);
    vec2 e = vec2(cos(a), sin(a));
    g = rho * e;
    dg = vec2(drho * e.x - rho * da * e.y, drho * e.y + rho * da * e.x);
}

vec2 cmul(vec2 a, vec2 b) { return vec2(a.x * b.x - a.y * b.y, a.x * b.y + a.y * b.x); }

void main() {
    uint i = (gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x) * 64u + gl_LocalInvocationID.x;
    if (i >= pc.n) return;
    if (pc.mode == 0u) {
        uvec2 co = chord_of[i];
        ScratchGPU A = arc[co.x];
        uint j = co.y & 0xFFFFu, n = co.y >> 16;
        float bulge = A.shape.w;
        vec2 p0 = A.ends.xy, p1 = A.ends.zw, c = p1 - p0;
        float theta = 4.0 * atan(bulge);
        vec2 g, dg;
        arc_g(theta, float(j) / float(n), g, dg);
        vec2 a = j == 0u ? p0 : p0 + cmul(c, g);
        arc_g(theta, float(j + 1u) / float(n), g, dg);
        vec2 b = j + 1u == n ? p1 : p0 + cmul(c, g);
        float len = length(c);
        float k = (bulge != 0.0 && len > 0.0) ? A.shape.x * sin(0.5 * theta) / len : 0.0;
        chord[i].ends = vec4(a, b);
        chord[i].shape = vec4(A.shape.xyz, k);
        return;
    }
    uvec2 ac = arc_chords[i];
    ScratchGPU A = arc[i];
    float bulge = A.shape.w;
    vec2 p0 = A.ends.xy, p1 = A.ends.zw, c = p1 - p0;
    float theta = 4.0 * atan(bulge);
    float dtheta = 4.0 / (1.0 + bulge * bulge);
    float len = length(c);
    // dkappa/d(x0, y0, x1, y1) and dkappa/dbulge (kappa = 2 sin(theta / 2) / len).
    vec4 dk_e = vec4(0.0);
    float dk_b = 0.0;
    if (len > 0.0) {  // at bulge 0 too: a straight scratch of n > 1 chords can bend
        float kap = 2.0 * sin(0.5 * theta) / len;
        vec2 dl = c / len;  // d len / d p1 (and minus it for p0)
        dk_e = -kap / len * vec4(-dl, dl);
        dk_b = cos(0.5 * theta) / len * dtheta;
    }
    vec4 e = vec4(0.0);     // dE/d(x0, y0, x1, y1)
    vec4 s = vec4(0.0);     // dE/d(w, d, alpha), dE/dbulge
    uint n = ac.y;
    for (uint j = 0u; j < n; ++j) {
        vec4 g0 = cg[2u * (ac.x + j)], g1 = cg[2u * (ac.x + j) + 1u];
        for (int end = 0; end < 2; ++end) {
            vec2 gp = end == 0 ? g0.xy : g0.zw;  // dE/d(this chord end)
            vec2 g, dg;
            arc_g(theta, float(j + uint(end)) / float(n), g, dg);
            // P = p0 + c g: dP/dp1 = multiplication by g, dP/dp0 = 1 - that, dP/dtheta = c dg.
            vec2 gt = vec2(gp.x * g.x + gp.y * g.y, -gp.x * g.y + gp.y * g.x);  // gp^T G
            e.xy += gp - gt;
            e.zw += gt;
            s.w += dot(gp, cmul(c, dg)) * dtheta;
        }
        s.xyz += g1.xyz;
        e += g1.w * dk_e;
        s.w += g1.w * dk_b;
    }
    ag[2u * i] = e;
    ag[2u * i + 1u] = s;
}
