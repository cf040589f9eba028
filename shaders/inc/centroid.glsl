// Where a pair's light falls within its pixel (tangent.comp's SA_MOMENTS build): the centroid of
// F ∩ R (the footprint clipped to the carved rectangle), as an offset from the footprint's
// centre on the plate; and the map of such offsets into the render's pixels. The area's centroid
// stands for the light's: across a groove narrower than the pixel the two differ by less than
// the groove's half width, along it only where the footprint's edge crosses it obliquely.
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

// The footprint `fp` (plate corners) clipped to scratch (ca, cb) (its culling record: p0, t;
// len, w, s_e, alpha) in the scratch's (s, v) frame by Sutherland-Hodgman (a quadrilateral
// against four half-planes: at most 8 corners), then the offset of its centroid from the
// footprint's centre, on the plate (mm).
vec2 covered_offset(vec4 ca, vec4 cb, vec2 fp[4]) {
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
    if (n < 3) return vec2(0.0);
    vec2 d = polygon_centroid(p, n, centre) - centre;
    return d.y * t + (d.x / k2w) * b;
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

#endif
