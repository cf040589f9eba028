// Push constants of tool_map.comp; Rust twin: ToolMapPush in engine/optim/src/tool_params.rs
// (checked by tests/layout.rs).
#ifndef SA_TOOL_MAP_PUSH_GLSL
#define SA_TOOL_MAP_PUSH_GLSL
layout(push_constant) uniform Push {
    uint n_scratches;
    uint n_table;   // samples of the tool's curve (>= 2)
    uint mode;      // 0: depths -> scratches' (w, d, alpha); 1: dE/d(w, d) -> dE/dz
    uint pad0;
    float z_first;  // commanded depth where the tool first reaches the plate, mm
    float s_lo;     // sqrt(z_lo - z_first): the table's first abscissa
    float inv_ds;   // 1 / spacing of the table in s = sqrt(z - z_first)
    float alpha;    // the fixed roughness of every groove
} pc;
#endif
