// Tiles of the shading kernels and of pixel_records.comp: 16x16 pixels per workgroup, the
// views' tiles numbered one view after the other. Include after the buffer binding `views` and
// the push constants `pc` (ShadePush).
#ifndef SA_TILES_GLSL
#define SA_TILES_GLSL

// The tile pixel of thread lid, block by block: lid bits 0-1 are x and bits 2-3 are y within a
// 4x4-pixel block, bits 4-7 the block (4 x 4 blocks). So neighbouring threads (a SIMD batch on a
// CPU, most of a GPU subgroup) share a block and its candidate list, and the per-pixel candidate
// loops of a batch run no longer than their block needs.
uvec2 tile_pixel(uint lid) {
    return uvec2((lid & 3u) | ((lid >> 2) & 12u), ((lid >> 2) & 3u) | ((lid >> 4) & 12u));
}

// The view that holds `tile`, and the tile's first pixel. A view's tiles are those of its window
// (base.zw its first tile's column and row in the image, dims.zw the window's tiles across and
// down; the whole image unless a render asked for less: `render::layout::TileWindow`).
uint tile_view(uint tile, out uvec2 t0) {
    uint vi = 0u;
    for (uint v = 1u; v < pc.n_views; ++v) if (tile >= views[v].base.x) vi = v;
    uint lt = tile - views[vi].base.x;
    t0 = uvec2((lt % views[vi].dims.z + views[vi].base.z) * TILE, (lt / views[vi].dims.z + views[vi].base.w) * TILE);
    return vi;
}

#endif
