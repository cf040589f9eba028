#version 450
// Views that share a lamp share its intensity (`--exposure fixed`): before Adam, every view of a
// lamp gets the lamp's gradient in log space, sum over its views of Phi_u dE/dPhi_u, written back
// as dE/dPhi_v = that sum / Phi_v. Adam's log-space step (the same gradient, the same moments)
// then moves every view of the lamp by one factor, and their ratios (the exposures) stay.
// One thread per lamp; the lamps' views are disjoint, so no two threads touch one value.
// groups: [offsets of the n_lamps + 1 lamps into the member list, then the member view indices].
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Lights { float intensity[]; };  // Phi per view
layout(std430, binding = 1) buffer GradLight { float grad_light[]; };
layout(std430, binding = 2) readonly buffer Groups { uint groups[]; };
layout(push_constant) uniform Push { uint n_lamps; };

void main() {
    uint g = gl_GlobalInvocationID.x;
    if (g >= n_lamps) return;
    uint first = groups[g], last = groups[g + 1u], members = n_lamps + 1u;
    float s = 0.0;
    for (uint k = first; k < last; ++k) {
        uint v = groups[members + k];
        s += intensity[v] * grad_light[v];
    }
    for (uint k = first; k < last; ++k) {
        uint v = groups[members + k];
        grad_light[v] = s / intensity[v];
    }
}
