// Which terrain draws may leave the water's shading out (render::water_cull, issue 14).
//
// A CPU rasteriser runs both sides of a branch, so every terrain fragment paid for the water's
// shading (four wave reads, Fresnel, glint) even where no water was in view: half of a plain
// frame over the Alps. The fragment shows water where the height it reads from the level's
// normal texture (w, filled by fill_normals.wgsl) lies below the water level; that height is a
// convex combination of texels of the level and, in the blend band, of the next coarser one.
// So a draw of level l shows no water when every texel its fragments may read, of its texture
// and of the coarser one's where its pipeline blends, lies at or above the level (with a margin
// for the filter's rounding): it is drawn by the pipeline without the water's code. What they
// may read is a box around the viewer's texel (render::water_cull::read_box): a level's rings
// lie within θ̃ = π·2^−l of the viewer, about a quarter of its texture's window. Nothing is
// read back: the draws' instance counts are written here, and each
// range is drawn twice by indirect draws, once per pipeline, one of them with no instance.
//
// cs_main: the minimum height of each 16 × 16 texel block a normal fill rewrote this frame.
// cs_draws: each level's minimum over the blocks its boxes touch, then the two instance counts
// of every range.
// Rust twin of the rule: render::water_cull::dry (tested against these counts).

// Rust twin: render::gpu_data::WaterCullParams (layout checked by tests/cpu/shader_contract.rs).
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
// Per level l: the texels of its own texture its fragments may read (x0, y0, width, height,
// toroidal), then those of level l − 1's texture at the same map offsets (the blend band).
@group(0) @binding(6) var<storage, read> boxes: array<vec4<u32>>;
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

// The lowest block minimum of `layer` over the blocks box b touches (toroidal).
fn box_min(layer: u32, b: vec4<u32>) -> f32 {
    let per_row = params.blocks_per_row;
    let size = per_row * params.block;
    let bx0 = b.x / params.block;
    let by0 = b.y / params.block;
    let nx = select(min((b.x + b.z - 1u) / params.block - bx0 + 1u, per_row), per_row, b.z >= size);
    let ny = select(min((b.y + b.w - 1u) / params.block - by0 + 1u, per_row), per_row, b.w >= size);
    let base = layer * per_row * per_row;
    var lo = 3.0e38;
    for (var j = 0u; j < ny; j++) {
        let row = base + ((by0 + j) % per_row) * per_row;
        for (var i = 0u; i < nx; i++) {
            lo = min(lo, block_min[row + (bx0 + i) % per_row]);
        }
    }
    return lo;
}

@compute @workgroup_size(64, 1, 1)
fn cs_draws(@builtin(local_invocation_index) i: u32) {
    // Bit 0: the level's own texels within reach lie above the water; bit 1: the coarser
    // level's at the same offsets.
    for (var l = i; l < MAX_LEVELS; l += 64u) {
        let own = box_min(l, boxes[2u * l]);
        var coarse = -3.0e38;
        if l > 0u {
            coarse = box_min(l - 1u, boxes[2u * l + 1u]);
        }
        level_dry[l] = select(0u, 1u, own >= params.dry_from_m) | select(0u, 2u, coarse >= params.dry_from_m);
    }
    workgroupBarrier();
    for (var d = i; d < params.draw_count; d += 64u) {
        let l = draw_levels[d] & 0xffffu;
        let blends = (draw_levels[d] >> 16u) != 0u;
        let dry = (level_dry[l] & 1u) != 0u && (!blends || l == 0u || (level_dry[l] & 2u) != 0u);
        args[d * 10u + 1u] = select(0u, 1u, dry);
        args[d * 10u + 6u] = select(1u, 0u, dry);
    }
}
