// Green's theorem on F ∩ R for integrators that reduce the patch integral to edge integrals:
//   ∬ D ds dv = -Σ_edges ∫_edge D(s) v(s) ds  over the boundary (counter-clockwise in (s, v)),
// v linear along each edge; vertical edges contribute nothing. Each edge integral is clipped to
// the chi+ range and handed to the includer's
//   R edge_integral(PairGeom G, R lo, R hi, R Vlo, R Vhi)  // ∫_lo^hi D(s) V(s) ds, V linear,
//                                                          // chi_lo <= lo < hi <= chi_hi
// Defines pair_integral (see patch_ndf.glsl): the fast path when it applies, else the boundary walk.
#ifndef SA_GREEN_GLSL
#define SA_GREEN_GLSL
#extension GL_EXT_control_flow_attributes : require

R edge_integral(PairGeom G, R lo, R hi, R Vlo, R Vhi);

// Green's theorem over the boundary of F ∩ R without building the clipped polygon:
// ∂(F ∩ R) = (∂F inside R) ∪ (∂R inside F). Every footprint edge is clipped to R (Liang-Barsky)
// and R's two across-edges (v = 0 and v = len) are clipped to F (Cyrus-Beck); R's long edges
// (s = ±se) are vertical and contribute nothing. Both are walked counter-clockwise in (s, v).
// Each piece adds  -∫ D(s) (v(s) - vref) ds  to I and  -∫ (v - vref) ds  to the area;
// vref (a point of the intersection, see ref_v) keeps the v values small and drops out of the
// closed sum.
void add_segment(PairGeom G, R as, R av, R bs, R bv, R vref, inout R I, inout R A) {
    if (val(as) == val(bs)) return;
    R ds = sub(bs, as);
    R k = dv(sub(bv, av), ds);
    A = sub(A, mul(mul(0.5, ds), sub(add(av, bv), mul(2.0, vref))));
#ifdef SA_ARCS
    if (val(g_arc_k) != 0.0) {  // an arc's chord (patch_ndf.glsl): - ∫ (-k s) (v - vref) ds
        R va = sub(av, vref), vb = sub(bv, vref);
        R sv = add(add(mul(as, va), mul(0.5, add(mul(as, sub(vb, va)), mul(ds, va)))), dv(mul(ds, sub(vb, va)), 3.0));
        A = add(A, mul(g_arc_k, mul(ds, sv)));
    }
#endif
    R lo = d_min(as, bs), hi = d_max(as, bs);
    R clo = d_max(lo, G.chi_lo), chi = d_min(hi, G.chi_hi);
    if (val(clo) >= val(chi)) return;
    R a0 = sub(av, vref);
    R vlo = add(a0, mul(k, sub(clo, as)));
    R vhi = add(a0, mul(k, sub(chi, as)));
    R J = edge_integral(G, clo, chi, vlo, vhi);
    I = (val(bs) > val(as)) ? sub(I, J) : add(I, J);
}

// A v on the boundary of F ∩ R (a vertex of the first footprint edge piece inside R, else R's
// own across-edge), from values only. The Green sum does not depend on vref, but its terms are
// D (v - vref) ds: with vref on the intersection they stay the size of the intersection, so a
// sliver at a footprint corner is not the difference of footprint-sized terms (float32).
float ref_v(R fs[4], R fv[4], float se, float len) {
    for (int e = 0; e < 4; ++e) {
        float as = val(fs[e]), av = val(fv[e]);
        float ds = val(fs[(e + 1) & 3]) - as, dvv = val(fv[(e + 1) & 3]) - av;
        float t0 = 0.0, t1 = 1.0;
        float ps[4] = float[](-ds, ds, -dvv, dvv);
        float qs[4] = float[](as + se, se - as, av, len - av);
        bool keep = true;
        for (int i = 0; i < 4; ++i) {
            if (ps[i] == 0.0) { if (qs[i] < 0.0) keep = false; }
            else if (ps[i] < 0.0) t0 = max(t0, qs[i] / ps[i]);
            else t1 = min(t1, qs[i] / ps[i]);
        }
        if (keep && t0 < t1) return clamp(av + t0 * dvv, 0.0, len);
    }
    // No footprint edge enters R: F contains an end of R, or F ∩ R is empty.
    float vc = 0.25 * (val(fv[0]) + val(fv[1]) + val(fv[2]) + val(fv[3]));
    return vc < 0.5 * len ? 0.0 : len;
}

// Footprint corners (fs[i], fv[i]) in scratch-local (s, v) coordinates (s = 2u/w), ordered
// counter-clockwise in (s, v). Carved region: |s| <= se, 0 <= v <= len.
// Returns I = ∫ D dA and A = area over F ∩ R, in mm^2 (half_w = w/2 converts ds to du).
void patch_integral(R fs[4], R fv[4], R se, R len, R half_w, PairGeom G, out R I, out R A) {
    I = rc(0.0); A = rc(0.0);
    R vref = rc(ref_v(fs, fv, val(se), val(len)));
    // Footprint edges clipped to the box [-se, se] x [0, len].
    for (int e = 0; e < 4; ++e) {
        R as = fs[e], av = fv[e];
        R ds = sub(fs[(e + 1) & 3], as), dvv = sub(fv[(e + 1) & 3], av);
        R t0 = rc(0.0), t1 = rc(1.0);
        // s >= -se, s <= se, v >= 0, v <= len, each as p t <= q
        R ps[4] = R[](neg(ds), ds, neg(dvv), dvv);
        R qs[4] = R[](add(as, se), sub(se, as), av, sub(len, av));
        bool keep = true;
        for (int i = 0; i < 4; ++i) {
            float p = val(ps[i]), q = val(qs[i]);
            // An edge lying on R's across-edge line (v = 0 or v = len) is left to R's own edge
            // below, which counts a shared piece once (on s = ±se it contributes nothing anyway).
            if (p == 0.0) { if (q < 0.0 || (q == 0.0 && i >= 2)) keep = false; }
            else {
                R r = dv(qs[i], ps[i]);
                if (p < 0.0) t0 = d_max(t0, r); else t1 = d_min(t1, r);
            }
        }
        if (!keep || val(t0) >= val(t1)) continue;
        // Snap to the box so pieces meet R's edges exactly.
        R pas = d_min(d_max(add(as, mul(t0, ds)), neg(se)), se);
        R pav = d_min(d_max(add(av, mul(t0, dvv)), 0.0), len);
        R pbs = d_min(d_max(add(as, mul(t1, ds)), neg(se)), se);
        R pbv = d_min(d_max(add(av, mul(t1, dvv)), 0.0), len);
        add_segment(G, pas, pav, pbs, pbv, vref, I, A);
    }
    // R's across-edges clipped to F: bottom (v = 0) walks +s, top (v = len) walks -s.
    for (int side = 0; side < 2; ++side) {
        R as = (side == 0) ? neg(se) : se;
        R av = (side == 0) ? rc(0.0) : len;
        R ds = (side == 0) ? mul(2.0, se) : mul(-2.0, se);
        R t0 = rc(0.0), t1 = rc(1.0);
        bool keep = true;
        for (int e = 0; e < 4; ++e) {
            R cs = fs[e], cv = fv[e];
            R fds = sub(fs[(e + 1) & 3], cs), fdv = sub(fv[(e + 1) & 3], cv);
            // inside F (CCW): cross(f, p - c) >= 0 with p = a + t (ds, 0)
            R q = sub(mul(fds, sub(av, cv)), mul(fdv, sub(as, cs)));
            R p = neg(mul(fdv, ds));
            float pv = val(p), qv = val(q);
            // Collinear with a footprint edge: count the shared piece only when both boundaries
            // run the same way (interiors on the same side); opposite ways bound no area.
            if (pv == 0.0) { if (qv < 0.0 || (qv == 0.0 && val(fds) * val(ds) < 0.0)) keep = false; }
            else {
                R r = neg(dv(q, p));
                if (pv > 0.0) t0 = d_max(t0, r); else t1 = d_min(t1, r);
            }
        }
        if (!keep || val(t0) >= val(t1)) continue;
        add_segment(G, add(as, mul(t0, ds)), av, add(as, mul(t1, ds)), av, vref, I, A);
    }
    I = mul(I, half_w);
    A = mul(A, half_w);
}

// Fast path, the common pair: the carved strip crosses the footprint from side to side (no
// footprint corner strictly inside the strip) and neither scratch end enters it. Then
// F ∩ R = {|s| <= se, v_bot(s) <= v <= v_top(s)} with a linear chord v_top - v_bot, and
// I = (w/2) ∫ D(s) chord(s) ds over the chi+ part of [-se, se]: one closed-form integral instead
// of one per boundary piece. Returns false (and the caller takes patch_integral) when the pair
// is not of this kind, e.g. a corner exactly on a strip edge.
bool patch_fast(R fs[4], R fv[4], R se, R len, R half_w, PairGeom G, out R I, out R A) {
    I = rc(0.0); A = rc(0.0);
    float sev = val(se);
    R lo0 = rc(1e30), hi0 = rc(-1e30), lo1 = rc(1e30), hi1 = rc(-1e30);
    int n0 = 0, n1 = 0;
    for (int e = 0; e < 4; ++e) {
        R as = fs[e], av = fv[e], bs = fs[(e + 1) & 3], bv = fv[(e + 1) & 3];
        float a = val(as), b = val(bs);
        if (abs(a) < sev || a == b) return false;
        // edges strictly crossing the lines s = -se and s = +se
        if ((a < -sev) != (b < -sev) && a != -sev && b != -sev) {
            R v = add(av, mul(dv(sub(bv, av), sub(bs, as)), sub(neg(se), as)));
            lo0 = d_min(lo0, v); hi0 = d_max(hi0, v); ++n0;
        }
        if ((a > sev) != (b > sev) && a != sev && b != sev) {
            R v = add(av, mul(dv(sub(bv, av), sub(bs, as)), sub(se, as)));
            lo1 = d_min(lo1, v); hi1 = d_max(hi1, v); ++n1;
        }
    }
    if (!(n0 == 2 && n1 == 2 && val(lo0) > 0.0 && val(lo1) > 0.0 && val(hi0) < val(len) && val(hi1) < val(len))) return false;
    R c0 = sub(hi0, lo0), c1 = sub(hi1, lo1);
    A = mul(mul(se, add(c0, c1)), half_w);
#ifdef SA_ARCS
    // An arc's chord (patch_ndf.glsl): the area of (1 - k s) ds dv.
    if (val(g_arc_k) != 0.0) A = sub(A, mul(mul(g_arc_k, mul(sub(c1, c0), dv(mul(se, se), 3.0))), half_w));
#endif
    R clo = d_max(neg(se), G.chi_lo), chi = d_min(se, G.chi_hi);
    if (val(clo) < val(chi)) {
        R k = dv(sub(c1, c0), mul(2.0, se));
        I = mul(edge_integral(G, clo, chi, add(c0, mul(k, add(clo, se))), add(c0, mul(k, add(chi, se)))), half_w);
    }
    return true;
}

#ifndef SA_DUAL
// The float kernels' walk. On CPU drivers a GLSL `if` is a lane mask: where the lanes of a batch
// disagree both sides run, and a loop runs as long as any lane needs it (at least once). So the float walk is
// written for that: a fast-path pair's loop runs once, on its strip; a general pair's visits the
// six pieces in order, with one clip for both kinds (walk_piece) and the one edge_integral of the
// kernel (a kernel's size costs time even where its code does not run). Pairs of the general
// kind are few, and a lane of them makes its SIMD group run six times, so nothing is spent ahead
// of the loop on finding which pieces are empty. The loop tests at the bottom: a test at the top
// would run the body once more with every lane off. Pieces, arithmetic and order are
// patch_fast's and patch_integral's, so results are the same.

// Piece j's segment o + t d, t in [0, 1] ((os, ov) + t (ds, dvv)), and its four constraints
// p_i t <= q_i (strict_i: a constraint met with p_i = 0 and q_i = 0 drops the piece); fds, fdv:
// the footprint's edge vectors (fs.yzwx - fs, fv.yzwx - fv). Called by clip_piece.
void piece_setup(int j, vec4 fs, vec4 fv, float se, float len, vec4 fds, vec4 fdv, out float os, out float ov,
                 out float ds, out float dvv, out vec4 ps, out vec4 qs, out bvec4 strict) {
    bool edge = j < 4;
    vec4 me = vec4(equal(ivec4(0, 1, 2, 3), ivec4(j & 3))), me1 = vec4(equal(ivec4(0, 1, 2, 3), ivec4((j + 1) & 3)));
    float as0 = dot(me, fs), av0 = dot(me, fv);
    os = edge ? as0 : (j == 4 ? -se : se);
    ov = edge ? av0 : (j == 4 ? 0.0 : len);
    ds = edge ? dot(me1, fs) - as0 : (j == 4 ? 2.0 * se : -2.0 * se);
    dvv = edge ? dot(me1, fv) - av0 : 0.0;
    ps = edge ? vec4(-ds, ds, -dvv, dvv) : fdv * ds;
    qs = edge ? vec4(os + se, se - os, ov, len - ov) : fds * (ov - fv) - fdv * (os - fs);
    // A footprint edge lying on R's across-edge line is left to R's own edge (see
    // patch_integral); an across-edge collinear with a footprint edge counts only where both
    // boundaries run the same way.
    strict = edge ? bvec4(false, false, true, true) : lessThan(fds * ds, vec4(0.0));
}

// Piece j's segment (piece_setup) clipped to t in [t0, t1] within [0, 1] by its constraints;
// false where a constraint with p_i = 0 drops it (t0 >= t1 is left to the caller). act: the
// constraints that set t0 and t1 (-1: the segment's own end) and pq their (p, q) pairs, which
// the reverse sweep (pair_adjoint.glsl) differentiates through; the forward ignores them (and
// its compiler drops them). One clip for both sweeps, so both clip the same floats.
bool clip_piece(int j, vec4 fs, vec4 fv, float se, float len, vec4 fds, vec4 fdv, out float os, out float ov,
                out float ds, out float dvv, out float t0, out float t1, out ivec2 act, out vec4 pq) {
    vec4 ps, qs;
    bvec4 strict;
    piece_setup(j, fs, fv, se, len, fds, fdv, os, ov, ds, dvv, ps, qs, strict);
    t0 = 0.0;
    t1 = 1.0;
    act = ivec2(-1);
    pq = vec4(1.0, 0.0, 1.0, 0.0);
    bool keep = true;
    for (int i = 0; i < 4; ++i) {
        float p = ps[i], q = qs[i];
        if (p == 0.0) { if (q < 0.0 || (q == 0.0 && strict[i])) keep = false; }
        else {
            float r = q / p;
            if (p < 0.0) {
                if (r > t0) { act.x = i; pq.xy = vec2(p, q); }
                t0 = max(t0, r);
            } else {
                if (r < t1) { act.y = i; pq.zw = vec2(p, q); }
                t1 = min(t1, r);
            }
        }
    }
    return keep;
}

// Piece j of patch_integral's walk (0-3: footprint edge j clipped to the carved rectangle, 4-5:
// the rectangle's bottom and top edges clipped to the footprint) as a segment (as, av) -> (bs, bv);
// false where the piece is empty. The footprint as vec4s (no local arrays: they become memory).
// Both kinds are one clip of a segment o + t d (t in [0, 1]) by four constraints p_i t <= q_i:
// Liang-Barsky against the rectangle's sides for a footprint edge, Cyrus-Beck against the
// footprint's edges for an across-edge (there p_i = fdv_i xd and q_i the edge's cross product,
// the same floats patch_integral computes, with p's sign flipped). One clip instead of one per
// kind: on CPU drivers both sides of an `if` run in a batch of mixed lanes, so a fast-path pair
// there would pay for both.
bool walk_piece(int j, vec4 fs, vec4 fv, float se, float len, out float as, out float av, out float bs, out float bv) {
    bool edge = j < 4;
    float os, ov, ds, dvv, t0, t1;
    ivec2 act;
    vec4 pq;
    bool keep = clip_piece(j, fs, fv, se, len, fs.yzwx - fs, fv.yzwx - fv, os, ov, ds, dvv, t0, t1, act, pq);
    as = os + t0 * ds;
    av = ov + t0 * dvv;
    bs = os + t1 * ds;
    bv = ov + t1 * dvv;
    if (edge) {  // snap to the box so pieces meet R's edges exactly
        as = min(max(as, -se), se);
        av = min(max(av, 0.0), len);
        bs = min(max(bs, -se), se);
        bv = min(max(bv, 0.0), len);
    }
    return keep && t0 < t1;
}

// patch_fast's test and chords in float: the strip crosses the footprint from side to side;
// c0 and c1 are its chords at s = -se and s = +se.
bool fast_strip(vec4 fs, vec4 fv, float se, float len, out float c0, out float c1) {
    float lo0 = 1e30, hi0 = -1e30, lo1 = 1e30, hi1 = -1e30;
    int n0 = 0, n1 = 0;
    c0 = 0.0; c1 = 0.0;
    bool ok = true;
    for (int e = 0; e < 4; ++e) {
        float a = fs[e], b = fs[(e + 1) & 3], av = fv[e], bv = fv[(e + 1) & 3];
        if (abs(a) < se || a == b) ok = false;
        if ((a < -se) != (b < -se) && a != -se && b != -se) {
            float v = av + ((bv - av) / (b - a)) * (-se - a);
            lo0 = min(lo0, v); hi0 = max(hi0, v); ++n0;
        }
        if ((a > se) != (b > se) && a != se && b != se) {
            float v = av + ((bv - av) / (b - a)) * (se - a);
            lo1 = min(lo1, v); hi1 = max(hi1, v); ++n1;
        }
    }
    if (!(ok && n0 == 2 && n1 == 2 && lo0 > 0.0 && lo1 > 0.0 && hi0 < len && hi1 < len)) return false;
    c0 = hi0 - lo0;
    c1 = hi1 - lo1;
    return true;
}

void patch_walk(R fs_[4], R fv_[4], R se, R len, R half_w, PairGeom G, bool try_fast, out R I, out R A) {
    I = 0.0;
    A = 0.0;
    vec4 fs = vec4(fs_[0], fs_[1], fs_[2], fs_[3]), fv = vec4(fv_[0], fv_[1], fv_[2], fv_[3]);
    float c0, c1;
    bool fast = try_fast && fast_strip(fs, fv, se, len, c0, c1);
    // vref (ref_v) is found on the way: the first footprint edge with a piece inside R gives it
    // before its piece is added, else R's own v at the first across-edge.
    float vref = 0.0;
    bool have_vref = fast;
    if (fast) A = se * (c0 + c1);
#ifdef SA_ARCS
    // An arc's chord (g_arc_k, patch_ndf.glsl): the area of (1 - k s) ds dv.
    if (fast && g_arc_k != 0.0) A = A - g_arc_k * (c1 - c0) * se * se / 3.0;
#endif
    int j = fast ? 6 : 0, jend = fast ? 7 : 6;
    [[dont_unroll]] do {
        // This piece's edge integral: (lo, hi, V(lo), V(hi)) and the sign it enters I with.
        float lo, hi, vlo, vhi, sgn = 1.0;
        bool integ;
        if (j == 6) {  // the strip: V is the chord, linear from c0 at -se to c1 at +se
            float k = (c1 - c0) / (2.0 * se);
            lo = max(-se, G.chi_lo);
            hi = min(se, G.chi_hi);
            vlo = c0 + k * (lo + se);
            vhi = c0 + k * (hi + se);
            integ = lo < hi;
        } else {  // add_segment of one walk piece
            float as, av, bs, bv;
            bool inside = walk_piece(j, fs, fv, se, len, as, av, bs, bv);
            if (!have_vref && (inside || j == 4)) {
                float vc = 0.25 * (((fv.x + fv.y) + fv.z) + fv.w);
                vref = inside && j < 4 ? av : (vc < 0.5 * len ? 0.0 : len);
                have_vref = true;
            }
            inside = inside && as != bs;
            float ds = bs - as;
            float k = (bv - av) / ds;
            if (inside) A = A - 0.5 * ds * (av + bv - 2.0 * vref);
#ifdef SA_ARCS
            if (inside && g_arc_k != 0.0) {  // - ∫ (-k s) (v - vref) ds along the piece
                float va = av - vref, vb = bv - vref;
                float sv = as * va + 0.5 * (as * (vb - va) + ds * va) + ds * (vb - va) / 3.0;
                A = A + g_arc_k * ds * sv;
            }
#endif
            lo = max(min(as, bs), G.chi_lo);
            hi = min(max(as, bs), G.chi_hi);
            float a0 = av - vref;
            vlo = a0 + k * (lo - as);
            vhi = a0 + k * (hi - as);
            sgn = bs > as ? -1.0 : 1.0;
            integ = inside && lo < hi;
        }
        if (integ) I = I + sgn * edge_integral(G, lo, hi, vlo, vhi);
        ++j;
    } while (j < jend);
    I = I * half_w;
    A = A * half_w;
}
#endif

void pair_integral(R fs[4], R fv[4], R se, R len, R half_w, PairGeom G, bool try_fast, out R I, out R A) {
#ifndef SA_DUAL
    patch_walk(fs, fv, se, len, half_w, G, try_fast, I, A);
#else
    if (try_fast && patch_fast(fs, fv, se, len, half_w, G, I, A)) return;
    patch_integral(fs, fv, se, len, half_w, G, I, A);
#endif
}

#endif
