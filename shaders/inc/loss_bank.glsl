// The design loss (engine/docs/model.md section 7): display transform, 3x3 Gaussian blur, image pyramid and
// the fixed feature bank whose Gram matrices stand in for the paper's VGG-19 features.
// Shared by loss_fwd.comp (values) and loss_bwd.comp (dE/dL). Include after loss_bindings.glsl.
//
// Pyramid ("pyr") layout: level-major. Level 0 of every view, in the layout of the renderer's image
// buffer (view v's pixels from views[v].base.y); then level 1 of every view; then level 2. Level s+1
// of a W x H level is floor(W/2) x floor(H/2) (at least 1 x 1): pixel (x, y) is the mean of the 2x2
// block (2x, 2y) .. (2x+1, 2y+1), clamped to the level below (only matters for 1-pixel levels); an
// odd last row or column is not pooled.
//
// Feature bank phi, per level (3 levels = scales 1, 1/2, 1/4), on the display value I:
//   5 linear 3x3 filters with clamp-to-edge borders:
//     k0 low-pass [1 2 1]^T [1 2 1] / 16
//     k1 d/dx Sobel [-1 0 1; -2 0 2; -1 0 1] / 8      k2 d/dy: its transpose
//     k3 diagonal   [0 1 2; -1 0 1; -2 -1 0] / 8      k4 antidiagonal [-2 -1 0; -1 0 1; 0 1 2] / 8
//   9 channels: c0 = k0 (not rectified; I >= 0 makes it >= 0), and for each derivative k (1..4) its
//   two half-wave rectifications relu(+k), relu(-k) (c1..c8), so the Gram matrix sees the sign of
//   edges (dark-to-bright vs bright-to-dark) and their co-occurrence, like rectified CNN features.
//   Gram(phi) = (1 / N_s) sum_p c_i(p) c_j(p), 9 x 9 per (view, level), N_s pixels of the level.
//   Only its 45 unique entries are stored; the Frobenius norm counts off-diagonal entries twice.
#ifndef SA_LOSS_BANK_GLSL
#define SA_LOSS_BANK_GLSL

#define NCH 9u        // channels per pixel
#define NPRE 5u       // linear filter responses per pixel
#define NGRAM 45u     // unique Gram entries (upper triangle, row-major)
#define NPART 46u     // per block: 45 Gram partial sums + the sum of squared blurred differences
#define BLOCK 256u    // pixels per reduction block

// The segment that holds pyramid pixel i (segments are sorted by offset).
uint seg_of(uint i) {
    uint s = 0u, k = 1u;
    if (k < pc.n_segs) do {  // tested at the bottom (see loss_bwd.comp)
        if (i >= segs[k].off) s = k;
    } while (++k < pc.n_segs);
    return s;
}

// 1D filter taps, index o + 1 for o in {-1, 0, 1}.
const float SMOOTH[3] = float[3](0.25, 0.5, 0.25);
const float DERIV[3] = float[3](-0.5, 0.0, 0.5);

// Weight of tap (ox, oy) (each in -1..1) of linear filter k (see the header comment).
float bank_w(uint k, int ox, int oy) {
    if (k == 0u) return SMOOTH[ox + 1] * SMOOTH[oy + 1];
    if (k == 1u) return DERIV[ox + 1] * SMOOTH[oy + 1];
    if (k == 2u) return SMOOTH[ox + 1] * DERIV[oy + 1];
    // Diagonals: +1 toward (+x, -y) resp. (+x, +y), with weights 2 at the far corner, 1 next to it.
    // (oy grows downwards: row 0 is the top row.)
    int a = (k == 3u) ? ox - oy : ox + oy;  // -2..2 along the filter's direction
    if (a == 0) return 0.0;
    float mag = (abs(a) == 2) ? 2.0 : 1.0;
    return sign(float(a)) * mag / 8.0;
}

// Channels from the 5 linear responses.
void channels(float pre[NPRE], out float c[NCH]) {
    c[0] = pre[0];
    for (uint k = 1u; k < NPRE; ++k) {
        c[2u * k - 1u] = max(pre[k], 0.0);
        c[2u * k] = max(-pre[k], 0.0);
    }
}

// Index of Gram entry (i, j), i <= j, in the 45-entry upper triangle.
uint gram_idx(uint i, uint j) {
    return i * NCH - (i * (i + 1u)) / 2u + j;
}

int clampi(int x, int n) { return clamp(x, 0, n - 1); }

// Display value I = L^(1/2.2) (engine/docs/model.md section 5); L < 0 (never produced) is treated as 0.
// A NaN render stays NaN (so the loss flags it) instead of being read as 0.
float display(float L) { return L > 0.0 ? pow(L, 1.0 / 2.2) : (isnan(L) ? L : 0.0); }

// dI/dL taken at max(L, 1e-4): the true slope is infinite at L = 0 (engine/docs/model.md section 8 allows this).
float display_slope(float L) { return (1.0 / 2.2) * pow(max(L, 1e-4), 1.0 / 2.2 - 1.0); }

#endif
