// Which terrain draws may leave the water's shading out (render::water_cull, issue 14).
//
// A CPU rasteriser runs both sides of a branch, so every terrain fragment paid for the water's
// shading (four wave reads, Fresnel, glint) even where no water was in view: half of a plain
// frame over the Alps. The fragment shows water where the height it reads from the level's
// normal texture (w, filled by fill_normals.wgsl) lies below the water level; that height is a
// convex combination of texels of the level and, in the blend band, of the next coarser one.
// So a draw of level l shows no water when every texel of its texture, and of the coarser
// one's where its pipeline blends, lies at or above the level (with a margin for the filter's rounding): it is drawn by the pipeline without the
// water's code. Nothing is read back: the draws' instance counts are written here, and each
// range is drawn twice by indirect draws, once per pipeline, one of them with no instance.
//
// cs_main: the minimum height of each 16 × 16 texel block a normal fill rewrote this frame.
// cs_draws: each level's minimum over its blocks, then the two instance counts of every range.
// Rust twin of the rule: render::water_cull::dry (tested against these counts).

// Rust twin: render::gpu_data::WaterCullParams (layout checked by tests/shader_contract.rs).
struct WaterCullParams {
    // A level is dry when its lowest texel is at least this (water level + margin).
    dry_from_m: f32,
    block: u32,
    blocks_per_row: u32,
    job_count: u32,
    draw_count: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> params: WaterCullParams;
@group(0) @binding(1) var normals: texture_2d_array<f32>;
// Per level (layer), the lowest height of each block, row by row.
@group(0) @binding(2) var<storage, read_write> block_min: array<f32>;
// Blocks to recompute: layer << 16 | block index.
@group(0) @binding(3) var<storage, read> jobs: array<u32>;
// Per draw range, its level, plus 1 << 16 where its pipeline blends in the next coarser level.
@group(0) @binding(4) var<storage, read> draw_levels: array<u32>;
// Per draw range, two DrawIndexedIndirect argument blocks of 5 words: the dry pipeline's,
// then the water pipeline's; word 1 is the instance count.
@group(0) @binding(5) var<storage, read_write> args: array<u32>;

@compute @workgroup_size(64, 1, 1)
fn cs_main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.job_count {
        return;
    }
    let job = jobs[id.x];
    let layer = job >> 16u;
    let b = job & 0xffffu;
    let x0 = (b % params.blocks_per_row) * params.block;
    let y0 = (b / params.blocks_per_row) * params.block;
    var lo = 3.0e38;
    for (var y = 0u; y < params.block; y++) {
        for (var x = 0u; x < params.block; x++) {
            lo = min(lo, textureLoad(normals, vec2<u32>(x0 + x, y0 + y), layer, 0).w);
        }
    }
    block_min[layer * params.blocks_per_row * params.blocks_per_row + b] = lo;
}

var<workgroup> level_dry: array<u32, MAX_LEVELS>;

@compute @workgroup_size(64, 1, 1)
fn cs_draws(@builtin(local_invocation_index) i: u32) {
    let blocks = params.blocks_per_row * params.blocks_per_row;
    for (var l = i; l < MAX_LEVELS; l += 64u) {
        var lo = 3.0e38;
        for (var b = 0u; b < blocks; b++) {
            lo = min(lo, block_min[l * blocks + b]);
        }
        level_dry[l] = select(0u, 1u, lo >= params.dry_from_m);
    }
    workgroupBarrier();
    for (var d = i; d < params.draw_count; d += 64u) {
        let l = draw_levels[d] & 0xffffu;
        let blends = (draw_levels[d] >> 16u) != 0u;
        let dry = level_dry[l] == 1u && (!blends || l == 0u || level_dry[l - 1u] == 1u);
        args[d * 10u + 1u] = select(0u, 1u, dry);
        args[d * 10u + 6u] = select(1u, 0u, dry);
    }
}
