// Push constants of tool_map.comp; Rust twin: ToolMapPush in engine/optim/src/tool_params.rs
// (checked by tests/layout.rs).
#ifndef SA_TOOL_MAP_PUSH_GLSL
#define SA_TOOL_MAP_PUSH_GLSL
layout(push_constant) uniform Push {
    uint n_scratches;
    uint n_table;   // samples of the tool's curve (>= 2)
    uint mode;      // 0: depths -> scratches' (w, d, alpha); 1: dE/d(w, d) -> dE/dz
    uint seed;      // the perturbed carving's seed (design --robust; unused where sigma_z = sigma_xy = 0)
    float z_first;  // commanded depth where the tool first reaches the plate, mm
    float s_lo;     // sqrt(z_lo - z_first): the table's first abscissa
    float inv_ds;   // 1 / spacing of the table in s = sqrt(z - z_first)
    float alpha;    // the fixed roughness of every groove
    float sigma_z;  // design --robust: the depth error of a carving, mm (1 sigma); 0: none
    float sigma_xy; // design --robust: the endpoints' error, mm (1 sigma, per axis); 0: none
    uint pad0;
    uint pad1;
} pc;
#endif
