// The procedural detail of a fill job (procedural/mod.rs, eq. 1 with §2.2's warping): every
// octave the level holds, evaluated once per texel. The whole octaves are returned (added to
// the level's heights), the partial ones stored apart so the vertex weights them by its λ.
// Rust twin: procedural::detail_texel_f32; layout twins in render::gpu_data.
//
// Lattice coordinates are never formed in world f32: the CPU gives each octave's anchor cell
// (integers) and the small remainder at the job's first grid point; a texel adds M·Δu with
// Δu its unit-vector offset from that point (tens of cells at most, band-limited).
//
// On a block small against the coarse octaves' cells (`delta.x` of them, procedural/delta.rs)
// those are evaluated as differences from the block's reference point, whose values the CPU
// gives in f64: a remainder's f32 steps (6·10⁻⁸ of a cell, half a millimetre on kilometre
// cells) would otherwise move the heights a millimetre-high eye looks at. The texel then
// returns the detail less its value at the reference, σ_r·F_r, which the fill's reference
// height already holds.

// Rust twin: render::gpu_data::DeltaOctaveParams.
struct DeltaOctave {
    lo: vec4<f32>,        // the reference's remainder below f32 (xyz), S(ref) − S(cell + m.w) (w)
    chain: vec4<f32>,     // 1 + g_h·clamp(Ĥ), Ĥ − clamp(Ĥ), −1 − clamp(Ĥ), 1 − clamp(Ĥ)
    warp_ref: vec4<f32>,  // the warp's vector (xy) and its length (z), S (w) at the reference
}

// Rust twin: render::gpu_data::DetailFillParams.
struct DetailFillParams {
    ref_trig: vec4<f32>,    // sin θr, cos θr, sin φr, cos φr of the first grid point
    ref_angles: vec4<f32>,  // φr, θr, dφ, dθ (radians)
    warp: vec4<f32>,        // lever (cells), t = c3/R_0 (xy → yz), g_h
    warp2: vec4<f32>,       // c1·R_0 (xy), c2 (zw)
    sigma: vec4<f32>,       // amplitude floor, gain·(L_0/cell)^H, cap (m)
    counts: vec4<u32>,      // whole octaves, partial octaves, relief map columns, rows
    delta: vec4<u32>,       // relative octaves, relief mode (0 constant, 1 bilinear), relief cell
    delta_end: vec4<f32>,   // Ĥ, the warp's vector after the relative octaves; their sum F_r
    delta_sigma: vec4<f32>, // σ_raw − σ_r, −σ_r, cap − σ_r, gain at the reference
    relief_ref: vec4<f32>,  // the reference's relief remainder: f32 part (xy), below it (zw)
    relief_ref2: vec4<f32>, // relief cells per radian of φ, θ; R(ref) − R(cell + xy); σ_r
    amplitudes: array<vec4<f32>, DETAIL_AMPLITUDE_VECS>,
    octaves: array<DetailOctave, MAX_OCTAVES>,
    deltas: array<DeltaOctave, MAX_OCTAVES>,
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

fn relief_value(c: i32, r: i32) -> f32 {
    let dims = vec2<i32>(detail.counts.zw);
    return relief[clamp(r, 0, dims.y - 1) * dims.x + ((c % dims.x) + dims.x) % dims.x];
}

// The relief at the four centres around cell: (c, r), (c+1, r), (c, r+1), (c+1, r+1).
fn relief_corners(cell: vec2<i32>) -> vec4<f32> {
    return vec4<f32>(
        relief_value(cell.x, cell.y),
        relief_value(cell.x + 1, cell.y),
        relief_value(cell.x, cell.y + 1),
        relief_value(cell.x + 1, cell.y + 1),
    );
}

fn relief_slope(q: vec4<f32>, g: vec2<f32>, a: u32) -> f32 {
    if a == 0u {
        let lo = q.y - q.x;
        let hi = q.w - q.z;
        return lo + (hi - lo) * g.y;
    }
    let lo = q.z - q.x;
    let hi = q.w - q.y;
    return lo + (hi - lo) * g.x;
}

// R(cell + f + d) − R(cell + f) of the bilinear relief, |d| < 1 per axis, as
// value_noise_delta. Rust twin: delta::relief_delta_f32.
fn relief_delta(cell0: vec2<i32>, f: vec2<f32>, d: vec2<f32>) -> f32 {
    var cell = cell0;
    var g = f;
    var q = relief_corners(cell);
    var dr = 0.0;
    for (var a = 0u; a < 2u; a++) {
        let da = d[a];
        let u = g[a] + da;
        if u >= 0.0 && u <= 1.0 {
            dr += relief_slope(q, g, a) * da;
            g[a] = u;
        } else {
            let up = u > 1.0;
            let edge = select(0.0, 1.0, up);
            let d1 = edge - g[a];
            dr += relief_slope(q, g, a) * d1;
            var step = vec2<i32>(0);
            step[a] = select(-1, 1, up);
            cell += step;
            q = relief_corners(cell);
            let start = 1.0 - edge;
            g[a] = start;
            let d2 = da - d1;
            dr += relief_slope(q, g, a) * d2;
            g[a] = start + d2;
        }
    }
    return dr;
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
    var v = vec2<f32>(1.0, 0.0);
    var h_all = 0.0;
    var sigma = 0.0;
    var d_sigma = 0.0;
    var df = 0.0;
    let relative = detail.delta.x;
    if relative > 0u {
        // σ's change from the reference (Rust twin: delta::delta_texel_f32).
        var d_relief = 0.0;
        if detail.delta.y == 1u {
            let cell = vec2<i32>(bitcast<i32>(detail.delta.z), bitcast<i32>(detail.delta.w));
            let d = vec2<f32>(
                dphi * detail.relief_ref2.x + detail.relief_ref.z,
                dtheta * detail.relief_ref2.y + detail.relief_ref.w,
            );
            d_relief = relief_delta(cell, detail.relief_ref.xy, d) - detail.relief_ref2.z;
        }
        let s = detail.delta_sigma;
        d_sigma = clamp(s.w * d_relief + s.x, s.y, s.z);
        // The relative octaves: each quantity of the chain as its change from the reference.
        var dh = 0.0;
        var dv = vec2<f32>(0.0);
        for (var k = 0u; k < relative; k++) {
            let o = detail.octaves[k];
            let q = detail.deltas[k];
            let v_r = q.warp_ref.xy;
            let len_r = q.warp_ref.z;
            let vk = v_r + dv;
            let len = sqrt(vk.x * vk.x + vk.y * vk.y);
            let n_r = max(len_r, 0.5);
            let n = max(len, 0.5);
            let sum = len + len_r;
            var d_len = 0.0;
            if sum > 0.0 {
                d_len = (2.0 * (v_r.x * dv.x + v_r.y * dv.y) + (dv.x * dv.x + dv.y * dv.y)) / sum;
            }
            let d_n = max(d_len + (len_r - n_r), 0.5 - n_r);
            let inv = 1.0 / (n * n_r);
            let dq = vec2<f32>((dv.x * n_r - v_r.x * d_n) * inv, (dv.y * n_r - v_r.y * d_n) * inv);
            var d = vec3<f32>(
                q.lo.x + (o.m0.x * du.x + o.m0.y * du.y + o.m0.z * du.z),
                q.lo.y + (o.m1.x * du.x + o.m1.y * du.y + o.m1.z * du.z),
                q.lo.z + (o.m2.x * du.x + o.m2.y * du.y + o.m2.z * du.z),
            );
            d = vec3<f32>(d.x + detail.warp.x * dq.x, d.y + detail.warp.x * dq.y, d.z);
            let f = vec3<f32>(o.m0.w, o.m1.w, o.m2.w);
            let d_s = value_noise_delta(o.cell.xyz, f, d, bitcast<u32>(o.cell.w)) - q.lo.w;
            let d_m = detail.warp.w * clamp(dh + q.chain.y, q.chain.z, q.chain.w);
            let d_t = octave_amplitude(k) * (q.chain.x * d_s + d_m * (q.warp_ref.w + d_s));
            dh += d_t;
            df += d_t;
            dv += detail.warp2.xy * dh;
        }
        v = detail.delta_end.yz + dv;
        h_all = detail.delta_end.x + dh;
        sigma = detail.relief_ref2.w + d_sigma;
    } else {
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
        sigma = clamp(detail.sigma.x + detail.sigma.y * relief_at(phi, theta), 0.0, detail.sigma.z);
    }
    var full = 0.0;
    var parts = vec4<f32>(0.0);
    for (var k = relative; k < count; k++) {
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
    if relative > 0u {
        return detail.relief_ref2.w * (df + full) + d_sigma * (detail.delta_end.w + df + full);
    }
    return sigma * full;
}
