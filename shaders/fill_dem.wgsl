// Fills a rectangle of a clipmap level texture from the GPU tile cache of a DEM pyramid
// (compute). Rust twin: terrain::dem::DemTerrain::sample_m (f64): bilinear between pixel
// centres, longitude wrapping (global grids) or sea level outside the extents (regional ones),
// rows clamped at the edges, and the pole caps (blend from the outermost row to its mean);
// the procedural detail (common/detail_fill.wgsl) is added on top.
//
// Pixel coordinates are linear in the grid indices within one job (the CPU splits rectangles
// at the poles, where rows fold back), so they are passed as an integer base, a fraction
// (an f32 and the rest below it) and a step. A texel's position in its pixel is that
// fraction plus a small offset, never summed in f32: a fraction's f32 step (6·10⁻⁸ of a
// pixel, a millimetre of a 10′ pixel) times the data's slope would put a rounding noise of
// a tenth of a millimetre into the levels a millimetre-high eye looks at. So the bilinear
// weights are split the same way: (b − a)·f_hi + (b − a)·Δ, the first the same for every
// texel of the pixel.

// Rust twin: render::gpu_data::DemFillParams (layout checked by tests/cpu/shader_contract.rs).
struct DemFillParams {
    base: vec2<i32>,        // integer (col, row) of the job's first grid point
    frac: vec2<f32>,        // its fractional (col, row)
    step: vec2<f32>,        // (d col / d gx, d row / d gy)
    slot0: vec2<u32>,       // texel of the first grid point (toroidal)
    extent: vec2<u32>,
    layer: u32,
    size: u32,
    page_base: u32,         // first page-table entry of the pyramid level
    tiles_x: u32,
    cols: i32,
    rows: i32,
    tile_size: i32,
    wraps: u32,
    // Pole caps: rows from the outermost row to the pole (0: no cap) and the pole's height.
    cap_north: vec2<f32>,
    cap_south: vec2<f32>,
    // metres − ref = offset + quantum · (code − code_ref), ref the level's reference height
    // (the texture holds h − ref: near the eye small numbers, whose f32 steps are fine; the
    // code nearest ref is taken off as an integer, so neither term is large there)
    decode: vec2<f32>,
    offset: vec2<u32>,      // the first texel, in grid steps from base + frac (the anchor)
    sea_m: f32,             // sea level − ref: outside a regional grid
    code_ref: i32,
    frac_lo: vec2<f32>,     // the anchor's fractional (col, row) below `frac`'s f32
    anchor_m: f32,          // the data at base + frac (f32 point) − ref, f64 on the CPU
    relative: u32,          // 1: texels add their change from the anchor (a block inside a pixel)
}

@group(0) @binding(0) var<uniform> params: DemFillParams;
@group(0) @binding(1) var out_heights: texture_storage_2d_array<r32float, write>;
@group(0) @binding(2) var tiles: texture_2d_array<i32>;
@group(0) @binding(3) var<storage, read> page: array<u32>;

// Height of pixel (col, row), both inside the level's grid.
fn pixel(col: i32, row: i32) -> f32 {
    let t = params.tile_size;
    let entry = params.page_base + u32(row / t) * params.tiles_x + u32(col / t);
    let slot = page[entry];
    if slot == NO_SLOT {
        // The CPU only dispatches jobs whose tiles are resident; this cannot show.
        return 0.0;
    }
    let code = textureLoad(tiles, vec2<i32>(col % t, row % t), i32(slot), 0).x;
    return params.decode.x + params.decode.y * f32(code - params.code_ref);
}

// The code of pixel (col, row): columns wrap, rows clamp (a relative job's rows are inside).
fn code_at(col: i32, row: i32) -> i32 {
    let c = wrap_col(col);
    let r = clamp(row, 0, params.rows - 1);
    let t = params.tile_size;
    let slot = page[params.page_base + u32(r / t) * params.tiles_x + u32(c / t)];
    if slot == NO_SLOT {
        return 0;
    }
    return textureLoad(tiles, vec2<i32>(c % t, r % t), i32(slot), 0).x;
}

// The codes around pixel cell: (c, r), (c+1, r), (c, r+1), (c+1, r+1).
fn code_corners(cell: vec2<i32>) -> vec4<i32> {
    return vec4<i32>(
        code_at(cell.x, cell.y),
        code_at(cell.x + 1, cell.y),
        code_at(cell.x, cell.y + 1),
        code_at(cell.x + 1, cell.y + 1),
    );
}

// ∂(bilinear)/∂f_a in codes at weights g: differences of integer codes, exact in f32.
fn code_slope(q: vec4<i32>, g: vec2<f32>, a: u32) -> f32 {
    if a == 0u {
        let lo = f32(q.y - q.x);
        let hi = f32(q.w - q.z);
        return lo + (hi - lo) * g.y;
    }
    let lo = f32(q.z - q.x);
    let hi = f32(q.w - q.y);
    return lo + (hi - lo) * g.x;
}

// The bilinear data's change (codes) from pixel cell + f to cell + f + d, |d| < 1 per axis:
// along columns, then rows, each leg split at the pixel edge it crosses (the same path as
// procedural/delta.rs's relief). Only small numbers: a texel inside the anchor's pixel keeps
// micrometres where the pixel's own values lie hundreds of metres from the ground.
fn bilinear_delta(cell0: vec2<i32>, f: vec2<f32>, d: vec2<f32>) -> f32 {
    var cell = cell0;
    var g = f;
    var q = code_corners(cell);
    var dv = 0.0;
    for (var a = 0u; a < 2u; a++) {
        let da = d[a];
        let u = g[a] + da;
        if u >= 0.0 && u <= 1.0 {
            dv += code_slope(q, g, a) * da;
            g[a] = u;
        } else {
            let up = u > 1.0;
            let edge = select(0.0, 1.0, up);
            let d1 = edge - g[a];
            dv += code_slope(q, g, a) * d1;
            var step = vec2<i32>(0);
            step[a] = select(-1, 1, up);
            cell += step;
            q = code_corners(cell);
            let start = 1.0 - edge;
            g[a] = start;
            let d2 = da - d1;
            dv += code_slope(q, g, a) * d2;
            g[a] = start + d2;
        }
    }
    return dv;
}

fn wrap_col(c: i32) -> i32 {
    if params.wraps != 0u {
        return ((c % params.cols) + params.cols) % params.cols;
    }
    return clamp(c, 0, params.cols - 1);
}

// Bilinear along a row (columns c, c+1 with weight fc = fc_hi + fc_d, kept apart).
fn row_sample(row: i32, c: i32, fc_hi: f32, fc_d: f32) -> f32 {
    let r = clamp(row, 0, params.rows - 1);
    let a = pixel(wrap_col(c), r);
    if fc_hi == 0.0 && fc_d == 0.0 {
        return a;
    }
    let d = pixel(wrap_col(c + 1), r) - a;
    return (a + fc_hi * d) + fc_d * d;
}

@compute @workgroup_size(WORKGROUP_SIZE, WORKGROUP_SIZE, 1)
fn cs_main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.extent.x || id.y >= params.extent.y {
        return;
    }
    // Steps from the anchor block's corner: the same f32 sums whichever dispatch fills a texel.
    let k = id.xy + params.offset;
    // Position in pixels from base: frac + d, d small (see the top).
    let d = params.frac_lo + vec2<f32>(k) * params.step;
    let c_rel = params.frac.x + d.x;
    let r_rel = params.frac.y + d.y;
    let c_floor = floor(c_rel);
    let r_floor = floor(r_rel);
    let ci = params.base.x + i32(c_floor);
    let ri = params.base.y + i32(r_floor);
    let fc = c_rel - c_floor;
    let fr = r_rel - r_floor;
    // fc = fc_hi + fc_d with fc_hi exact (a pixel's own texels share it), likewise fr, where
    // the texel lies in the anchor's pixel or the next; farther (coarse levels, whose jobs
    // span many pixels and whose texels are seen from afar) the split would only cancel.
    var fc_hi = fc;
    var fc_d = 0.0;
    if abs(c_floor - floor(params.frac.x)) <= 1.0 {
        fc_hi = params.frac.x - c_floor;
        fc_d = d.x;
    }
    var fr_hi = fr;
    var fr_d = 0.0;
    if abs(r_floor - floor(params.frac.y)) <= 1.0 {
        fr_hi = params.frac.y - r_floor;
        fr_d = d.y;
    }
    var h = params.sea_m;
    var inside = true;
    if params.relative != 0u {
        // From the height at the anchor's f32 point (f64 on the CPU), the change to the texel.
        // (No early return: on llvmpipe one made the whole fill half again slower, taken or
        // not.)
        h = params.anchor_m + params.decode.y * bilinear_delta(params.base, params.frac, d);
        inside = false;
    } else if params.wraps == 0u {
        // Sea level outside a regional grid (its extents are the pixel edges).
        let c_abs = f32(ci) + fc;
        let r_abs = f32(ri) + fr;
        inside = c_abs >= -0.5 && c_abs <= f32(params.cols) - 0.5
            && r_abs >= -0.5 && r_abs <= f32(params.rows) - 0.5;
    }
    if inside {
        let north = f32(ri) + fr;                    // rows below the outermost northern one
        let south = f32(ri - (params.rows - 1)) + fr; // rows past the outermost southern one
        if params.cap_north.x > 0.0 && north < 0.0 {
            let t = clamp(-north / params.cap_north.x, 0.0, 1.0);
            let v = row_sample(0, ci, fc_hi, fc_d);
            h = v + (params.cap_north.y - v) * t;
        } else if params.cap_south.x > 0.0 && south > 0.0 {
            let t = clamp(south / params.cap_south.x, 0.0, 1.0);
            let v = row_sample(params.rows - 1, ci, fc_hi, fc_d);
            h = v + (params.cap_south.y - v) * t;
        } else if ri < 0 || ri >= params.rows - 1 || fr == 0.0 {
            h = row_sample(ri, ci, fc_hi, fc_d);
        } else {
            let top = row_sample(ri, ci, fc_hi, fc_d);
            let bottom = row_sample(ri + 1, ci, fc_hi, fc_d);
            let v = bottom - top;
            h = (top + fr_hi * v) + fr_d * v;
        }
    }
    let slot = (params.slot0 + id.xy) % vec2<u32>(params.size);
    h += detail_texel(k, slot, params.layer);
    textureStore(out_heights, slot, params.layer, vec4<f32>(h, 0.0, 0.0, 0.0));
}
