// Reverse mode for one (pixel, scratch) pair: the backward kernel's contribution of the pair is
// the gradient of gI I + gA A (I, A: the pair's integral and area, patch_ndf.glsl) with respect
// to the scratch's 7 parameters. One float forward sweep of exactly what the forward kernel
// computes (pair_from_params, then patch_fast or the Green walk of patch_integral, green.glsl)
// and one hand-written reverse sweep give all 7 in one pass; the edge integrals' reverse sweep
// is edge_adj (integrators/closed_form_adjoint.glsl). The fast path's strip or the general
// walk's up to six boundary pieces are visited by one loop that is not unrolled, so edge_adj
// appears once in the kernel instead of once per piece (on CPU drivers a kernel's size costs
// time even where the code does not run).
//
// Ties and clamps are differentiated as the dual-number kernel does (d_min / d_max in
// real.glsl: the first argument on a tie); that kernel (Mode::BackwardDual) is the test oracle.
#ifndef SA_PAIR_ADJOINT_GLSL
#define SA_PAIR_ADJOINT_GLSL
#extension GL_EXT_control_flow_attributes : require

// The reverse sweep of pair_geom (patch_ndf.glsl): the adjoints aG of the pair constants pushed back to hb, ht and
// alpha (aG's own hb, ht and alpha entries, the direct uses, are included).
void geom_adj(PairGeom G, GAdj aG, out float a_hb, out float a_ht, out float a_alpha) {
    float hb = G.hb, ht = G.ht, hz = G.hz, alpha = G.alpha;
    float a2 = alpha * alpha;
    float beta = G.beta;
    float iA = 1.0 / (1.0 + beta * hz);
    float iA2 = iA * iA;
    float s0 = G.s0, g2 = G.g2, s0sq = s0 * s0;
    float q = (1.0 + s0sq) - g2;
    float r = q * q - 4.0 * (s0sq * g2);
    a_hb = aG.hb; a_ht = aG.ht; a_alpha = aG.alpha;
    float a_beta = aG.beta, a_s0 = aG.s0, a_g2 = aG.g2;
    // chi_hi = sp, chi_lo = -1/sp
    float sp = G.chi_hi;
    float a_sp = aG.chi_hi + aG.chi_lo / (sp * sp);
    float rho = sqrt(hb * hb + hz * hz);
    float a_rho;
    if (hb >= 0.0) {
        float k = -a_sp * sp / (rho + hb);
        a_rho = k;
        a_hb += k;
    } else {
        a_rho = a_sp / hz;
        a_hb -= a_sp / hz;
    }
    if (rho > 0.0) a_hb += a_rho * hb / rho;
    // c0..c4
    float a_iA = aG.c0 + aG.c1 * 2.0 * s0 + aG.c2 * q;
    float a_iA2 = aG.c0 + aG.c1 * 4.0 * s0 + aG.c2 * (2.0 * q + 4.0 * s0sq) + aG.c3 * 4.0 * s0 * q + aG.c4 * r;
    float a_r = aG.c4 * iA2;
    float a_q = aG.c3 * 4.0 * s0 * iA2 + aG.c2 * (iA + 2.0 * iA2) + a_r * 2.0 * q;
    a_s0 += aG.c3 * 4.0 * q * iA2 + aG.c1 * (2.0 * iA + 4.0 * iA2);
    float a_s0sq = aG.c2 * 4.0 * iA2 - a_r * 4.0 * g2 + a_q;
    a_g2 += -a_r * 4.0 * s0sq - a_q;
    a_s0 += a_s0sq * 2.0 * s0;
    // g = sqrt(g2)
    if (G.g > 0.0) a_g2 += aG.g * 0.5 / G.g;
    // g2 = (a2 + ht^2 (1 - a2)) iA2
    float num = a2 + (ht * ht) * (1.0 - a2);
    float a_num = a_g2 * iA2;
    a_iA2 += a_g2 * num;
    float a_a2 = a_num * (1.0 - ht * ht);
    a_ht += a_num * 2.0 * ht * (1.0 - a2);
    // s0 = -beta hb iA
    a_beta -= a_s0 * hb * iA;
    a_hb -= a_s0 * beta * iA;
    a_iA -= a_s0 * beta * hb;
    // iA2 = iA^2, iA = 1 / (1 + beta hz)
    a_iA += a_iA2 * 2.0 * iA;
    a_beta += -a_iA * iA * iA * hz;
    // beta = sqrt(1 - a2)
    if (beta > 0.0) a_a2 -= a_beta * 0.5 / beta;
    a_alpha += a_a2 * 2.0 * alpha;
}

// carved_se (common.glsl) in float and its partials in w and d.
float carved_se_grad(float w, float d, out float d_w, out float d_d) {
    float x = 2.0 * d / w;
    float u = exp(-x);
    // 1 - exp(-x) as carved_se computes it (series below x = 0.1)
    float om = x < 0.1 ? x * (1.0 - x * (0.5 - x * (1.0 / 6.0 - x * (1.0 / 24.0 - x * (1.0 / 120.0))))) : 1.0 - u;
    float se = sqrt(om);
    // d se / d x = exp(-x) / (2 se); x = 2d/w
    float k = se > 0.0 ? u / (2.0 * se) : 0.0;
    d_d = k * 2.0 / w;
    d_w = -k * x / w;
    return se;
}


// The pair's forward quantities that the reverse sweep needs.
struct PairF {
    float tx, ty, len, se, se_w, se_d, k2w, half_w;
    vec4 fs, fv;  // footprint corners in (s, v)
    vec4 rx, ry;  // corners relative to p0 on the plate
    PairGeom G;
};

PairF pair_f(vec4 E, vec4 S, vec2 fp[4], vec3 h) {
    PairF F;
    float dxs = E.z - E.x, dys = E.w - E.y;
    F.len = sqrt(dxs * dxs + dys * dys);
    F.tx = dxs / F.len;
    F.ty = dys / F.len;
    F.se = carved_se_grad(S.x, S.y, F.se_w, F.se_d);
    F.k2w = 2.0 / S.x;
    F.half_w = 0.5 * S.x;
    float bx = -F.ty, by = F.tx;
    for (int c = 0; c < 4; ++c) {
        float rx = fp[c].x - E.x, ry = fp[c].y - E.y;
        F.rx[c] = rx;
        F.ry[c] = ry;
        F.fs[c] = dot(vec2(rx, ry), vec2(bx, by)) * F.k2w;
        F.fv[c] = dot(vec2(rx, ry), vec2(F.tx, F.ty));
    }
    F.G = pair_geom(dot(h.xy, vec2(bx, by)), dot(h.xy, vec2(F.tx, F.ty)), h.z, S.z);
    return F;
}

// One-hot mask of component i of a vec4 (dynamic indices without local arrays).
vec4 onehot(int i) { return vec4(equal(ivec4(0, 1, 2, 3), ivec4(i))); }

// patch_fast (green.glsl), forward: whether the pair is a fast-path pair, and the strip's
// chords c0 (at s = -se) and c1 (at s = +se) with the edges that gave their ends.
struct FastRec {
    float c0, c1, clo, chi;
    int elo0, ehi0, elo1, ehi1;
};

bool fast_fwd(PairF F, out FastRec FR) {
    float se = F.se;
    float lo0 = 1e30, hi0 = -1e30, lo1 = 1e30, hi1 = -1e30;
    FR.elo0 = 0; FR.ehi0 = 0; FR.elo1 = 0; FR.ehi1 = 0;
    FR.c0 = 0.0; FR.c1 = 0.0; FR.clo = 0.0; FR.chi = 0.0;
    int n0 = 0, n1 = 0;
    for (int e = 0; e < 4; ++e) {
        float a = F.fs[e], b = F.fs[(e + 1) & 3];
        float av = F.fv[e], bv = F.fv[(e + 1) & 3];
        if (abs(a) < se || a == b) return false;
        if ((a < -se) != (b < -se) && a != -se && b != -se) {
            float v = av + ((bv - av) / (b - a)) * (-se - a);
            if (v < lo0) { lo0 = v; FR.elo0 = e; }
            if (v > hi0) { hi0 = v; FR.ehi0 = e; }
            ++n0;
        }
        if ((a > se) != (b > se) && a != se && b != se) {
            float v = av + ((bv - av) / (b - a)) * (se - a);
            if (v < lo1) { lo1 = v; FR.elo1 = e; }
            if (v > hi1) { hi1 = v; FR.ehi1 = e; }
            ++n1;
        }
    }
    if (!(n0 == 2 && n1 == 2 && lo0 > 0.0 && lo1 > 0.0 && hi0 < F.len && hi1 < F.len)) return false;
    FR.c0 = hi0 - lo0;
    FR.c1 = hi1 - lo1;
    FR.clo = max(-se, F.G.chi_lo);
    FR.chi = min(se, F.G.chi_hi);
    return true;
}

// patch_fast, reverse, seeded with aI = gI, aA = gA: J is the strip's edge integral (0 when
// clo >= chi) and a_lo .. a_Vhi what edge_adj returned for it.
void fast_rev(PairF F, FastRec FR, float gI, float gA, float J, float a_lo, float a_hi, float a_Vlo, float a_Vhi,
              inout vec4 a_fs, inout vec4 a_fv, inout float a_se, inout float a_half, inout GAdj aG) {
    float se = F.se, half_w = F.half_w, c0 = FR.c0, c1 = FR.c1, clo = FR.clo, chi = FR.chi;
    // A = se (c0 + c1) half_w
    a_se += gA * (c0 + c1) * half_w;
    float a_c0 = gA * se * half_w, a_c1 = a_c0;
    a_half += gA * se * (c0 + c1);
    if (clo < chi) {
        float k = (c1 - c0) / (2.0 * se);
        a_half += gI * J;
        // Vlo = c0 + k (clo + se), Vhi = c0 + k (chi + se), k = (c1 - c0) / (2 se)
        a_c0 += a_Vlo + a_Vhi;
        float a_k = a_Vlo * (clo + se) + a_Vhi * (chi + se);
        a_lo += a_Vlo * k;
        a_hi += a_Vhi * k;
        a_se += (a_Vlo + a_Vhi) * k;
        a_c1 += a_k / (2.0 * se);
        a_c0 -= a_k / (2.0 * se);
        a_se -= a_k * k / se;
        // clo = max(-se, chi_lo), chi = min(se, chi_hi)
        if (-se >= F.G.chi_lo) a_se -= a_lo; else aG.chi_lo += a_lo;
        if (se <= F.G.chi_hi) a_se += a_hi; else aG.chi_hi += a_hi;
    }
    // c0 = hi0 - lo0, c1 = hi1 - lo1: each crossing v = av + (bv - av) q, q = (S - a) / (b - a)
    for (int e = 0; e < 4; ++e) {
        int e1 = (e + 1) & 3;
        float av_s0 = (e == FR.ehi0 ? a_c0 : 0.0) - (e == FR.elo0 ? a_c0 : 0.0);
        float av_s1 = (e == FR.ehi1 ? a_c1 : 0.0) - (e == FR.elo1 ? a_c1 : 0.0);
        float a = F.fs[e], b = F.fs[e1];
        float av = F.fv[e], bv = F.fv[e1];
        float ib = 1.0 / (b - a);
        for (int side = 0; side < 2; ++side) {
            float a_v = side == 0 ? av_s0 : av_s1;
            if (a_v == 0.0) continue;
            float Sl = side == 0 ? -se : se;
            float q = (Sl - a) * ib;
            a_fv[e] += a_v * (1.0 - q);
            a_fv[e1] += a_v * q;
            float a_q = a_v * (bv - av);
            a_se += (side == 0 ? -a_q : a_q) * ib;
            a_fs[e] += a_q * (q - 1.0) * ib;
            a_fs[e1] -= a_q * q * ib;
        }
    }
}

// clamp as d_min(d_max(x, lo), hi) and which argument it returned: 0 x, 1 lo, 2 hi.
float clamp_which(float x, float lo, float hi, out int which) {
    float m = x;
    which = 0;
    if (!(x >= lo)) { m = lo; which = 1; }
    if (!(m <= hi)) { m = hi; which = 2; }
    return m;
}

// The pair's integral forward and reverse, one piece per iteration of a loop that is not unrolled,
// so that edge_adj appears once in the kernel: for a fast-path pair the strip (j = 6), else the
// Green walk of patch_integral (green.glsl): the four footprint edges clipped to the carved
// rectangle, then its two across-edges clipped to the footprint, both kinds by one clip of a
// segment o + t d by four constraints p_i t <= q_i (clip_piece in green.glsl, the forward walk's
// own) and one reverse. On CPU drivers both sides of an `if` run where a batch's lanes disagree,
// and a loop's body runs at least once: a fast-path pair pays for every line here, so the
// general pieces share their code, the loop tests at the bottom, and the strip's reverse
// (fast_rev) runs once after it.
void pieces_adj(PairF F, bool fast, FastRec FR, float gI, float gA, inout vec4 a_fs, inout vec4 a_fv, inout float a_se,
                inout float a_len, inout float a_half, inout GAdj aG) {
    float se = F.se, len = F.len;
    vec4 fs = F.fs, fv = F.fv;
    PairGeom G = F.G;
    // vref (ref_v in green.glsl) is found on the way, as the forward's walk finds it.
    float vref = 0.0;
    bool have_vref = fast;
    float Iraw = 0.0, Araw = 0.0;
    float aJ = gI * F.half_w, aA = gA * F.half_w;  // adjoints of the raw sums (before * half_w)
    // The strip's edge integral and its partials, for fast_rev after the loop.
    float Jf = 0.0, af_lo = 0.0, af_hi = 0.0, af_vlo = 0.0, af_vhi = 0.0;
    vec4 fds = fs.yzwx - fs, fdv = fv.yzwx - fv;  // footprint edges (across-edge clipping)
    int j = fast ? 6 : 0, jend = fast ? 7 : 6;
    [[dont_unroll]] do {
        bool is_fast = j == 6, edge = j < 4;
        int side = j - 4;
        // The edge integral of this iteration, set up by either kind of piece below.
        bool integ = false;
        float ilo = 0.0, ihi = 0.0, ivlo = 0.0, ivhi = 0.0, iseed = 0.0;
        // The piece: o + t d for t in [t0, t1], snapped to the box for a footprint edge.
        vec4 me = onehot(j & 3), me1 = onehot((j + 1) & 3);
        float os, ov, ds, dvv, t0, t1;
        ivec2 act;  // the constraints that set t0 and t1, and their (p, q): pq
        vec4 pq;
        bool keep = clip_piece(j, fs, fv, se, len, fds, fdv, os, ov, ds, dvv, t0, t1, act, pq);
        int wa_s = 0, wa_v = 0, wb_s = 0, wb_v = 0;
        float as = os + t0 * ds, av = ov + t0 * dvv, bs = os + t1 * ds, bv = ov + t1 * dvv;
        if (edge) {
            as = clamp_which(as, -se, se, wa_s);
            av = clamp_which(av, 0.0, len, wa_v);
            bs = clamp_which(bs, -se, se, wb_s);
            bv = clamp_which(bv, 0.0, len, wb_v);
        }
        bool inside = !is_fast && keep && t0 < t1;
        if (!have_vref && (inside || j == 4)) {
            float vc = 0.25 * (((fv.x + fv.y) + fv.z) + fv.w);
            vref = inside && edge ? av : (vc < 0.5 * len ? 0.0 : len);
            have_vref = true;
        }
        inside = inside && as != bs;
        // add_segment, forward.
        float dsg = 1.0, k = 0.0, sgn = 1.0, clo = 0.0, chi = 0.0;
        bool lo_a = true, hi_a = true, clo_c = true, chi_c = true;  // which arguments the min / max took
        float a_as = 0.0, a_bs = 0.0, a_av = 0.0, a_bv = 0.0;
        if (is_fast) {
            // The fast path's strip: one edge integral of the chord (fast_fwd, fast_rev).
            float k6 = (FR.c1 - FR.c0) / (2.0 * se);
            ilo = FR.clo;
            ihi = FR.chi;
            ivlo = FR.c0 + k6 * (FR.clo + se);
            ivhi = FR.c0 + k6 * (FR.chi + se);
            iseed = aJ;
            integ = FR.clo < FR.chi;
        } else {
            dsg = bs - as;
            k = (bv - av) / dsg;
            float vsum = av + bv - 2.0 * vref;
            if (inside) Araw -= 0.5 * dsg * vsum;
            a_as = 0.5 * vsum * aA;
            a_bs = -0.5 * vsum * aA;
            a_av = -0.5 * dsg * aA;
            a_bv = a_av;
            lo_a = as <= bs;
            hi_a = as >= bs;
            float lo = lo_a ? as : bs, hi = hi_a ? as : bs;
            clo_c = lo >= G.chi_lo;
            chi_c = hi <= G.chi_hi;
            clo = clo_c ? lo : G.chi_lo;
            chi = chi_c ? hi : G.chi_hi;
            integ = inside && clo < chi;
            float a0 = av - vref;
            sgn = bs > as ? -1.0 : 1.0;
            ilo = clo;
            ihi = chi;
            ivlo = a0 + k * (clo - as);
            ivhi = a0 + k * (chi - as);
            iseed = sgn * aJ;
        }
        // The one edge integral of the kernel's reverse sweep.
        float J = 0.0, a_ilo = 0.0, a_ihi = 0.0, a_ivlo = 0.0, a_ivhi = 0.0;
        if (integ) J = edge_adj(G, ilo, ihi, ivlo, ivhi, iseed, aG, a_ilo, a_ihi, a_ivlo, a_ivhi);
        if (is_fast) { Jf = J; af_lo = a_ilo; af_hi = a_ihi; af_vlo = a_ivlo; af_vhi = a_ivhi; }
        // add_segment, reverse.
        if (integ && !is_fast) {
            Iraw += sgn * J;
            a_av += a_ivlo + a_ivhi;
            float a_k = a_ivlo * (clo - as) + a_ivhi * (chi - as);
            float a_clo = a_ivlo * k + a_ilo, a_chi = a_ivhi * k + a_ihi;
            a_as -= (a_ivlo + a_ivhi) * k;
            a_bv += a_k / dsg;
            a_av -= a_k / dsg;
            a_bs -= a_k * k / dsg;
            a_as += a_k * k / dsg;
            // clo = d_max(lo, chi_lo), chi = d_min(hi, chi_hi); lo = d_min(as, bs), hi = d_max(as, bs)
            float a_lo = 0.0, a_hi = 0.0;
            if (clo_c) a_lo = a_clo; else aG.chi_lo += a_clo;
            if (chi_c) a_hi = a_chi; else aG.chi_hi += a_chi;
            if (lo_a) a_as += a_lo; else a_bs += a_lo;
            if (hi_a) a_as += a_hi; else a_bs += a_hi;
        }
        if (inside) {
            // The clipping's reverse: the snapped ends -> o, d, t0, t1.
            if (wa_s != 0) { a_se += wa_s == 1 ? -a_as : a_as; a_as = 0.0; }
            if (wa_v != 0) { if (wa_v == 2) a_len += a_av; a_av = 0.0; }
            if (wb_s != 0) { a_se += wb_s == 1 ? -a_bs : a_bs; a_bs = 0.0; }
            if (wb_v != 0) { if (wb_v == 2) a_len += a_bv; a_bv = 0.0; }
            float a_os = a_as + a_bs, a_ov = a_av + a_bv;
            float a_ds = a_as * t0 + a_bs * t1, a_dvv = a_av * t0 + a_bv * t1;
            float a_t0 = a_as * ds + a_av * dvv, a_t1 = a_bs * ds + a_bv * dvv;
            // t = q / p of the active constraints
            vec4 a_p = vec4(0.0), a_q = vec4(0.0);
            if (act.x >= 0) { a_q += onehot(act.x) * (a_t0 / pq.x); a_p -= onehot(act.x) * (a_t0 * pq.y / (pq.x * pq.x)); }
            if (act.y >= 0) { a_q += onehot(act.y) * (a_t1 / pq.z); a_p -= onehot(act.y) * (a_t1 * pq.w / (pq.z * pq.z)); }
            if (edge) {
                // p = (-ds, ds, -dvv, dvv), q = (os + se, se - os, ov, len - ov); os = fs[e], ds = fs[e1] - fs[e] (v likewise)
                a_ds += a_p.y - a_p.x;
                a_dvv += a_p.w - a_p.z;
                a_os += a_q.x - a_q.y;
                a_se += a_q.x + a_q.y;
                a_ov += a_q.z - a_q.w;
                a_len += a_q.w;
                a_fs += me * (a_os - a_ds) + me1 * a_ds;
                a_fv += me * (a_ov - a_dvv) + me1 * a_dvv;
            } else {
                // p = fdv ds, q = fds (ov - fv) - fdv (os - fs); fds = fs.yzwx - fs (fdv likewise);
                // os = -se or se, ov = 0 or len, ds = 2 se or -2 se
                vec4 a_fds = a_q * (ov - fv);
                vec4 a_fdv = a_p * ds - a_q * (os - fs);
                a_ds += dot(a_p, fdv);
                a_ov += dot(a_q, fds);
                a_os -= dot(a_q, fdv);
                a_fv -= a_q * fds;
                a_fs += a_q * fdv;
                a_fs += a_fds.wxyz - a_fds;
                a_fv += a_fdv.wxyz - a_fdv;
                a_se += side == 0 ? 2.0 * a_ds - a_os : a_os - 2.0 * a_ds;
                if (side == 1) a_len += a_ov;
            }
        }
        ++j;
    } while (j < jend);
    // The strip's reverse, once per pair.
    if (fast) fast_rev(F, FR, gI, gA, Jf, af_lo, af_hi, af_vlo, af_vhi, a_fs, a_fv, a_se, a_half, aG);
    else a_half += gI * Iraw + gA * Araw;
}

// The gradient of gI I + gA A for one pair: d0 = d/d(x0, y0, x1, y1), d1 = d/d(w, d, alpha).
// E = (x0, y0, x1, y1), S = (w, d, alpha, -); fp the footprint corners as pixel_records.comp stores them,
// h the half vector; try_fast as for pair_integral (patch_ndf.glsl).
void pair_adjoint(vec4 E, vec4 S, vec2 fp[4], vec3 h, float gI, float gA, bool try_fast, out vec4 d0, out vec3 d1) {
    PairF F = pair_f(E, S, fp, h);
    GAdj aG = gadj_zero();
    vec4 a_fs = vec4(0.0), a_fv = vec4(0.0);
    float a_se = 0.0, a_len = 0.0, a_half = 0.0;
    FastRec FR;
    bool fast = try_fast && fast_fwd(F, FR);
    pieces_adj(F, fast, FR, gI, gA, a_fs, a_fv, a_se, a_len, a_half, aG);
    float a_hb, a_ht, a_alpha;
    geom_adj(F.G, aG, a_hb, a_ht, a_alpha);
    // fs = (r . b) 2/w, fv = r . t, r = fp - p0; hb = h . b, ht = h . t; b = (-ty, tx)
    float tx = F.tx, ty = F.ty, bx = -ty, by = tx;
    vec4 as = a_fs * F.k2w;
    float a_x0 = -dot(as, vec4(bx)) - dot(a_fv, vec4(tx));
    float a_y0 = -dot(as, vec4(by)) - dot(a_fv, vec4(ty));
    float a_bx = a_hb * h.x + dot(as, F.rx), a_by = a_hb * h.y + dot(as, F.ry);
    float a_tx = a_ht * h.x + dot(a_fv, F.rx), a_ty = a_ht * h.y + dot(a_fv, F.ry);
    float a_k2w = dot(a_fs, F.fs) / F.k2w;
    a_ty -= a_bx;
    a_tx += a_by;
    // t = (x1 - x0, y1 - y0) / len, len = |(x1 - x0, y1 - y0)|
    float tdot = a_tx * tx + a_ty * ty;
    float a_dx = (a_tx - tx * tdot) / F.len + a_len * tx, a_dy = (a_ty - ty * tdot) / F.len + a_len * ty;
    d0 = vec4(a_x0 - a_dx, a_y0 - a_dy, a_dx, a_dy);
    // w: k2w = 2/w, half_w = w/2, se(w, d); d: se; alpha
    float w = S.x;
    d1 = vec3(-a_k2w * F.k2w / w + 0.5 * a_half + a_se * F.se_w, a_se * F.se_d, a_alpha);
}

#endif
