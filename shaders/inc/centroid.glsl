// Where a pair's light falls within its pixel (tangent.comp's SA_MOMENTS build): the centroids
// of the groove's light in F ∩ R (the footprint clipped to the carved rectangle) and of its
// area, as offsets from the footprint's centre on the plate; and the map of such offsets into the
// render's pixels. The light's centroid matters: a V-groove under one lamp lights one wall, a
// quarter of its width off its middle, which is a sizeable part of a pixel when the groove is
// (against a render 6 times finer, the area's centroid alone left 65 to 69% of the moments).
#ifndef SA_CENTROID_GLSL
#define SA_CENTROID_GLSL

// The centroid of the convex polygon p[0..n) (n >= 3; either orientation), or `fallback` for a
// polygon of no area.
vec2 polygon_centroid(vec2 p[8], int n, vec2 fallback) {
    float a2 = 0.0;
    vec2 c = vec2(0.0);
    for (int i = 0; i < n; ++i) {
        vec2 q = p[i], r = p[i + 1 < n ? i + 1 : 0];
        float x = q.x * r.y - r.x * q.y;
        a2 += x;
        c += (q + r) * x;
    }
    return abs(a2) > 0.0 ? c / (3.0 * a2) : fallback;
}

// The chord of the convex polygon p[0..n) on the line s = x: its length and its middle's v.
vec2 polygon_chord(vec2 p[8], int n, float x) {
    float lo = 3.4e38, hi = -3.4e38;
    for (int i = 0; i < n; ++i) {
        vec2 a = p[i], z = p[i + 1 < n ? i + 1 : 0];
        if ((a.x <= x) != (z.x <= x)) {
            float v = mix(a.y, z.y, (x - a.x) / (z.x - a.x));
            lo = min(lo, v);
            hi = max(hi, v);
        }
    }
    return hi > lo ? vec2(hi - lo, 0.5 * (hi + lo)) : vec2(0.0);
}

// The light-weighted centroid (s, v) of the clipped polygon p[0..n): the integrals over s of
// D(s) l(s) (1, s, v_mid(s)), l the chord, on (lo, hi) (its s-range within the chi+ range), by
// 2-point Gauss-Legendre on panels graded from the lobe's centre s0 (0, g, 2g, 4g, 8g, 16g, then
// the range's end: gauss_panels.glsl's grading, shorter); `fallback` where no light falls.
vec2 light_centroid(PairGeom G, vec2 p[8], int n, float lo, float hi, vec2 fallback) {
    const float X = 0.5773502691896257;
    vec3 sum = vec3(0.0);
    for (int side = 0; side < 2; ++side) {
        float sgn = side == 0 ? 1.0 : -1.0;
        for (int j = 0; j < 6; ++j) {
            float near = G.s0 + (j == 0 ? 0.0 : sgn * G.g * exp2(float(j - 1)));
            float far = j == 5 ? (side == 0 ? hi : lo) : G.s0 + sgn * G.g * exp2(float(j));
            float a = max(min(near, far), lo), b = min(max(near, far), hi);
            if (!(a < b)) continue;
            float mid = 0.5 * (a + b), hw = 0.5 * (b - a);
            for (int q = 0; q < 2; ++q) {
                float x = mid + hw * (q == 0 ? -X : X);
                vec2 ch = polygon_chord(p, n, x);
                float f = hw * ndf_at(G, x) * ch.x;
                sum += f * vec3(1.0, x, ch.y);
            }
        }
    }
    return sum.x > 0.0 ? sum.yz / sum.x : fallback;
}

// The footprint `fp` (plate corners) clipped to scratch (ca, cb) (its culling record: p0, t;
// len, w, s_e, alpha) in the scratch's (s, v) frame by Sutherland-Hodgman (a quadrilateral
// against four half-planes: at most 8 corners); the offsets from the footprint's centre, on the
// plate (mm), of the centroid of the groove's light there (`light`, for half vector h) and of
// its area (`area`).
void covered_offsets(vec4 ca, vec4 cb, vec2 fp[4], vec3 h, out vec2 light, out vec2 area) {
    vec2 t = ca.zw, b = vec2(-ca.w, ca.z);
    float k2w = 2.0 / cb.y, se = cb.z, len = cb.x;
    vec2 p[8], q[8];
    vec2 centre = vec2(0.0);
    for (int c = 0; c < 4; ++c) {
        vec2 r = fp[c] - ca.xy;
        p[c] = vec2(dot(r, b) * k2w, dot(r, t));
        centre += 0.25 * p[c];
    }
    int n = 4;
    for (int e = 0; e < 4 && n > 0; ++e) {
        // Inside: sign * coordinate <= limit.
        int axis = e / 2;
        float sg = (e % 2 == 0) ? 1.0 : -1.0;
        float lim = axis == 0 ? se : (e == 2 ? len : 0.0);
        int m = 0;
        for (int i = 0; i < n; ++i) {
            vec2 a = p[i], z = p[i + 1 < n ? i + 1 : 0];
            float da = sg * a[axis] - lim, dz = sg * z[axis] - lim;
            if (da <= 0.0) q[m++] = a;
            if ((da <= 0.0) != (dz <= 0.0)) q[m++] = mix(a, z, da / (da - dz));
        }
        n = m;
        for (int i = 0; i < 8; ++i) p[i] = q[i];
    }
    light = vec2(0.0);
    area = vec2(0.0);
    if (n < 3) return;
    vec2 ac = polygon_centroid(p, n, centre);
    float lo = 3.4e38, hi = -3.4e38;
    for (int i = 0; i < n; ++i) {
        lo = min(lo, p[i].x);
        hi = max(hi, p[i].x);
    }
    PairGeom G = pair_geom(dot(h.xy, b), dot(h.xy, t), h.z, cb.w);
    vec2 lc = light_centroid(G, p, n, max(lo, G.chi_lo), min(hi, G.chi_hi), ac);
    vec2 d = lc - centre;
    light = d.y * t + (d.x / k2w) * b;
    d = ac - centre;
    area = d.y * t + (d.x / k2w) * b;
}

// A plate offset (or a moment: light times offset) at pixel `pix` in the render's pixels (x right,
// y down): the footprint's corners as the pixel's record keeps them (reversed where they are
// counter-clockwise on the plate, pixel_records.comp), their mean edges along x and y, and the
// 2x2 system of the locally affine map.
vec2 plate_to_pixels(uint pix, vec2 m) {
    vec2 f[4];
    vec3 h;
    pixel_record(pix, f, h);
    bool ccw = texelFetch(precs, int(SA_PIXEL_TEXELS * pix) + 4).z != 0.0;
    vec2 ex = 0.5 * (f[1] - f[0] + f[2] - f[3]);
    vec2 ey = (ccw ? -0.5 : 0.5) * (f[3] - f[0] + f[2] - f[1]);
    float det = ex.x * ey.y - ex.y * ey.x;
    if (det == 0.0) return vec2(0.0);
    return vec2(m.x * ey.y - m.y * ey.x, ex.x * m.y - ex.y * m.x) / det;
}

// Each pixel's two moments, two pixels to a vec4 of the output (8 bytes a pixel: the image's
// range, twice over, rather than the tangents' 32); between passes they carry there as they are.
vec2 moment_load(uint pix) {
    vec4 q = tang[pix >> 1u];
    return (pix & 1u) == 0u ? q.xy : q.zw;
}

void moment_store(uint pix, vec2 m) {
    uint c = 2u * (pix & 1u);
    tang[pix >> 1u][c] = m.x;
    tang[pix >> 1u][c + 1u] = m.y;
}

#endif
