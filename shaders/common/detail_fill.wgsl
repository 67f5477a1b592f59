// The procedural detail of a fill job (procedural/mod.rs, eq. 1 with §2.2's warping): every
// octave the level holds, evaluated once per texel. The whole octaves are returned (added to
// the level's heights), the partial ones stored apart so the vertex weights them by its λ.
// Rust twin: procedural::detail_texel_f32; layout twins in render::gpu_data.
//
// Lattice coordinates are never formed in world f32: the CPU gives each octave's anchor cell
// (integers) and the small remainder at the job's first grid point; a texel adds M·Δu with
// Δu its unit-vector offset from that point (tens of cells at most, band-limited).

// Rust twin: render::gpu_data::DetailFillParams.
struct DetailFillParams {
    ref_trig: vec4<f32>,    // sin θr, cos θr, sin φr, cos φr of the first grid point
    ref_angles: vec4<f32>,  // φr, θr, dφ, dθ (radians)
    warp: vec4<f32>,        // lever (cells), t = c3/R_0 (xy → yz), g_h
    warp2: vec4<f32>,       // c1·R_0 (xy), c2 (zw)
    sigma: vec4<f32>,       // amplitude floor, gain·(L_0/cell)^H, cap (m)
    counts: vec4<u32>,      // whole octaves, partial octaves, relief map columns, rows
    amplitudes: array<vec4<f32>, DETAIL_AMPLITUDE_VECS>,
    octaves: array<DetailOctave, MAX_OCTAVES>,
}

@group(1) @binding(0) var<uniform> detail: DetailFillParams;
@group(1) @binding(1) var<storage, read> relief: array<f32>;
@group(1) @binding(2) var out_partials: texture_storage_2d_array<rgba16float, write>;

// The relief map at (φ, θ): bilinear between cell centres, columns wrap, rows clamp.
// Rust twin: procedural::roughness::RoughnessMap::relief_m.
fn relief_at(phi: f32, theta: f32) -> f32 {
    let dims = vec2<i32>(detail.counts.zw);
    let x = fract(phi * 0.15915494309) * f32(dims.x) - 0.5;
    let y = clamp(theta, 0.0, 3.14159265359) * 0.31830988618 * f32(dims.y) - 0.5;
    let x0 = floor(x);
    let y0 = floor(y);
    let fx = x - x0;
    let fy = y - y0;
    let c0 = ((i32(x0) % dims.x) + dims.x) % dims.x;
    let c1 = (c0 + 1) % dims.x;
    let r0 = clamp(i32(y0), 0, dims.y - 1);
    let r1 = clamp(i32(y0) + 1, 0, dims.y - 1);
    let a = relief[r0 * dims.x + c0];
    let b = relief[r0 * dims.x + c1];
    let c = relief[r1 * dims.x + c0];
    let d = relief[r1 * dims.x + c1];
    let top = a + fx * (b - a);
    let bottom = c + fx * (d - c);
    return top + fy * (bottom - top);
}

fn octave_amplitude(k: u32) -> f32 {
    return detail.amplitudes[k / 4u][k % 4u];
}

// The detail of the job's texel `id` (written to `slot` of `layer`): returns σ·Σ of the
// whole octaves in metres and stores σ·t_k of the partial ones.
fn detail_texel(id: vec2<u32>, slot: vec2<u32>, layer: u32) -> f32 {
    let count = detail.counts.x + detail.counts.y;
    if count == 0u {
        textureStore(out_partials, slot, layer, vec4<f32>(0.0));
        return 0.0;
    }
    let dphi = f32(id.x) * detail.ref_angles.z;
    let dtheta = f32(id.y) * detail.ref_angles.w;
    let du = delta_unit_from(detail.ref_trig, dphi, dtheta);
    // σ from the relief at the texel's (φ, θ), folded back across a pole.
    var phi = detail.ref_angles.x + dphi;
    var theta = detail.ref_angles.y + dtheta;
    if theta < 0.0 {
        theta = -theta;
        phi += 3.14159265359;
    } else if theta > 3.14159265359 {
        theta = 6.28318530718 - theta;
        phi += 3.14159265359;
    }
    let sigma = clamp(detail.sigma.x + detail.sigma.y * relief_at(phi, theta), 0.0, detail.sigma.z);
    var v = vec2<f32>(1.0, 0.0);
    var h_all = 0.0;
    var full = 0.0;
    var parts = vec4<f32>(0.0);
    for (var k = 0u; k < count; k++) {
        let o = detail.octaves[k];
        let n = max(sqrt(v.x * v.x + v.y * v.y), 0.5);
        let dw = detail.warp.x * vec2<f32>(v.x / n - 1.0, v.y / n) + detail.warp.yz;
        var x = vec3<f32>(
            o.m0.w + (o.m0.x * du.x + o.m0.y * du.y + o.m0.z * du.z),
            o.m1.w + (o.m1.x * du.x + o.m1.y * du.y + o.m1.z * du.z),
            o.m2.w + (o.m2.x * du.x + o.m2.y * du.y + o.m2.z * du.z),
        );
        x = vec3<f32>(x.x + dw.x, x.y + dw.y, x.z);
        let fl = floor(x);
        let s = value_noise(o.cell.xyz + vec3<i32>(fl), x - fl, bitcast<u32>(o.cell.w));
        let m = 1.0 + detail.warp.w * clamp(h_all, -1.0, 1.0);
        let t = octave_amplitude(k) * m * s;
        h_all += t;
        if k < detail.counts.x {
            full += t;
        } else {
            parts[k - detail.counts.x] = sigma * t;
        }
        v += detail.warp2.xy * h_all + detail.warp2.zw;
    }
    textureStore(out_partials, slot, layer, parts);
    return sigma * full;
}
