// Fills a rectangle of a clipmap level texture from the analytic test planet (compute).
// Rust twin: terrain::analytic::AnalyticPlanet::height_band_limited_m (f64); the procedural
// detail (common/detail_fill.wgsl) is added on top.
//
// Each wave's phase ω·(u·a) is far too large for f32, so it is evaluated relative to the
// rectangle's first grid point u_r: the CPU gives sin/cos of the phase there, the GPU adds
// ω·(Δu·a) with Δu built from small angle offsets without cancellation.

// Rust twin: terrain::analytic::WaveParams.
struct Wave {
    omega_a: vec4<f32>,   // ω·a, w = band-limited amplitude (m)
    omega_b: vec4<f32>,   // ω·b
    phases: vec4<f32>,    // sin α_a, cos α_a, sin α_b, cos α_b at u_r
}

// Rust twin: render::gpu_data::FillParams (layout checked by tests/cpu/shader_contract.rs).
struct FillParams {
    // sin θr, cos θr, sin φr, cos φr of the reference grid point.
    ref_trig: vec4<f32>,
    // dφ, dθ of the level (radians).
    spacing: vec4<f32>,
    slot0: vec2<u32>,
    extent: vec2<u32>,
    layer: u32,
    size: u32,
    offset: vec2<u32>,  // the first texel, in grid steps from the reference point (the anchor)
    ref_m: f32,         // the level's reference height: the texture holds h − ref_m
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
    waves: array<Wave, ANALYTIC_SCALES>,
}

@group(0) @binding(0) var<uniform> params: FillParams;
@group(0) @binding(1) var out_heights: texture_storage_2d_array<r32float, write>;

@compute @workgroup_size(WORKGROUP_SIZE, WORKGROUP_SIZE, 1)
fn cs_main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.extent.x || id.y >= params.extent.y {
        return;
    }
    let k = id.xy + params.offset;
    let du = delta_unit_from(params.ref_trig, f32(k.x) * params.spacing.x, f32(k.y) * params.spacing.y);
    var h = 0.0;
    for (var k = 0u; k < ANALYTIC_SCALES; k++) {
        let w = params.waves[k];
        if w.omega_a.w == 0.0 {
            continue;
        }
        let ba = dot(w.omega_a.xyz, du);
        let bb = dot(w.omega_b.xyz, du);
        // sin(α + β) = sin α cos β + cos α sin β; β is small near the anchor (trig.wgsl).
        let sca = sin_cos_precise(ba);
        let scb = sin_cos_precise(bb);
        let sa = w.phases.x * sca.y + w.phases.y * sca.x;
        let sb = w.phases.z * scb.y + w.phases.w * scb.x;
        h += w.omega_a.w * sa * sb;
    }
    let slot = (params.slot0 + id.xy) % vec2<u32>(params.size);
    h = (h - params.ref_m) + detail_texel(k, slot, params.layer);
    textureStore(out_heights, slot, params.layer, vec4<f32>(h, 0.0, 0.0, 0.0));
}
