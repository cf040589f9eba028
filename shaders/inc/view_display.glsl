// Display mapping of engine/docs/model.md section 5, for the viewer's present pass:
// I = L^(1/2.2), byte = round(255 min(1, I)); L <= 0 or NaN gives 0 (as `io::display_byte`).
// float32 pow can put a value that is within ~1e-6 of a rounding boundary one level away from the
// engine's float64 `display_byte`; the viewer tests allow that one level.
#ifndef SA_VIEW_DISPLAY_GLSL
#define SA_VIEW_DISPLAY_GLSL

// A display value I in [0, 1] -> byte.
uint display_byte_of(float i) {
    if (!(i > 0.0)) return 0u;
    return uint(floor(255.0 * min(i, 1.0) + 0.5));
}

// A linear value L -> byte.
uint display_byte(float l) {
    if (!(l > 0.0)) return 0u;
    return display_byte_of(pow(l, 1.0 / 2.2));
}

#endif
