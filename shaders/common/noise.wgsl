// The auxiliary function S of eq. 1 (infinite-landscapes-projected-grid.md §2.1): value noise
// over a 3-D integer lattice with an integer hash (never `sin`: GPUs differ there).
// Rust twins: procedural::noise::{pcg3d, lattice_value, value_noise_f32}.

// Rust twin: render::gpu_data::DetailOctaveParams.
struct DetailOctave {
    // Rows of M = Q·R/L (xyz) and the anchor's remainder (w).
    m0: vec4<f32>,
    m1: vec4<f32>,
    m2: vec4<f32>,
    // Anchor cell (xyz) and the octave's hash seed (w, bit pattern).
    cell: vec4<i32>,
}

// pcg3d (Jarzynski & Olano 2020).
fn pcg3d(v_in: vec3<u32>) -> vec3<u32> {
    var v = v_in * 1664525u + 1013904223u;
    v.x += v.y * v.z;
    v.y += v.z * v.x;
    v.z += v.x * v.y;
    v ^= v >> vec3<u32>(16u);
    v.x += v.y * v.z;
    v.y += v.z * v.x;
    v.z += v.x * v.y;
    return v;
}

// Lattice value of cell c in [−1, 1): 24 hash bits times 2⁻²³, exact in f32.
fn lattice_value(c: vec3<i32>, seed: u32) -> f32 {
    let h = pcg3d(vec3<u32>(bitcast<u32>(c.x) ^ seed, bitcast<u32>(c.y), bitcast<u32>(c.z) + seed));
    return f32(h.x >> 8u) * (1.0 / 8388608.0) - 1.0;
}

// The lattice values at the 8 corners of cell, x fastest: v000, v100, v010, v110, v001, …
fn lattice_corners(cell: vec3<i32>, seed: u32) -> array<f32, 8> {
    return array<f32, 8>(
        lattice_value(cell, seed),
        lattice_value(cell + vec3<i32>(1, 0, 0), seed),
        lattice_value(cell + vec3<i32>(0, 1, 0), seed),
        lattice_value(cell + vec3<i32>(1, 1, 0), seed),
        lattice_value(cell + vec3<i32>(0, 0, 1), seed),
        lattice_value(cell + vec3<i32>(1, 0, 1), seed),
        lattice_value(cell + vec3<i32>(0, 1, 1), seed),
        lattice_value(cell + vec3<i32>(1, 1, 1), seed),
    );
}

fn fade(t: f32) -> f32 {
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
}

// S at cell + f (f in [0, 1)³): quintic-faded trilinear interpolation of the lattice values.
fn value_noise(cell: vec3<i32>, f: vec3<f32>, seed: u32) -> f32 {
    let w = vec3<f32>(fade(f.x), fade(f.y), fade(f.z));
    let v = lattice_corners(cell, seed);
    let v000 = v[0];
    let v100 = v[1];
    let v010 = v[2];
    let v110 = v[3];
    let v001 = v[4];
    let v101 = v[5];
    let v011 = v[6];
    let v111 = v[7];
    let x00 = v000 + (v100 - v000) * w.x;
    let x10 = v010 + (v110 - v010) * w.x;
    let x01 = v001 + (v101 - v001) * w.x;
    let x11 = v011 + (v111 - v011) * w.x;
    let y0 = x00 + (x10 - x00) * w.y;
    let y1 = x01 + (x11 - x01) * w.y;
    return y0 + (y1 - y0) * w.z;
}

// sin(a + d) − sin a and cos(a + d) − cos a without cancellation: −2 sin²(d/2) terms.
// The sines are trig.wgsl's: d is a texel's angular offset, down to 1e-9 rad on the finest
// levels, where a driver's builtin sin may return 0 (trig.wgsl).
fn delta_sin(s: f32, c: f32, d: f32) -> f32 {
    let h = sin_precise(0.5 * d);
    return -2.0 * s * h * h + c * sin_precise(d);
}
fn delta_cos(s: f32, c: f32, d: f32) -> f32 {
    let h = sin_precise(0.5 * d);
    return -2.0 * c * h * h - s * sin_precise(d);
}

// u(θr + dθ, φr + dφ) − u(θr, φr), u = (sin θ cos φ, sin θ sin φ, cos θ); ref_trig holds
// sin θr, cos θr, sin φr, cos φr.
fn delta_unit_from(ref_trig: vec4<f32>, dphi: f32, dtheta: f32) -> vec3<f32> {
    let st = ref_trig.x;
    let ct = ref_trig.y;
    let sp = ref_trig.z;
    let cp = ref_trig.w;
    let d_st = delta_sin(st, ct, dtheta);
    let d_ct = delta_cos(st, ct, dtheta);
    let d_sp = delta_sin(sp, cp, dphi);
    let d_cp = delta_cos(sp, cp, dphi);
    return vec3<f32>(
        st * d_cp + d_st * cp + d_st * d_cp,
        st * d_sp + d_st * sp + d_st * d_sp,
        d_ct,
    );
}

fn fade_slope(t: f32) -> f32 {
    let s = t * (t - 1.0);
    return 30.0 * s * s;
}

// S and its gradient in lattice units at cell + f (the bump's octaves): (value, ∂S/∂x_i).
fn value_noise_grad(cell: vec3<i32>, f: vec3<f32>, seed: u32) -> vec4<f32> {
    let w = vec3<f32>(fade(f.x), fade(f.y), fade(f.z));
    let dw = vec3<f32>(fade_slope(f.x), fade_slope(f.y), fade_slope(f.z));
    let v = lattice_corners(cell, seed);
    let v000 = v[0];
    let v100 = v[1];
    let v010 = v[2];
    let v110 = v[3];
    let v001 = v[4];
    let v101 = v[5];
    let v011 = v[6];
    let v111 = v[7];
    let k1 = v100 - v000;
    let k2 = v010 - v000;
    let k3 = v001 - v000;
    let k4 = v000 - v100 - v010 + v110;
    let k5 = v000 - v010 - v001 + v011;
    let k6 = v000 - v100 - v001 + v101;
    let k7 = -v000 + v100 + v010 - v110 + v001 - v101 - v011 + v111;
    let value = v000 + k1 * w.x + k2 * w.y + k3 * w.z + k4 * w.x * w.y + k5 * w.y * w.z
        + k6 * w.z * w.x + k7 * w.x * w.y * w.z;
    let grad = dw * vec3<f32>(
        k1 + k4 * w.y + k6 * w.z + k7 * w.y * w.z,
        k2 + k5 * w.z + k4 * w.x + k7 * w.z * w.x,
        k3 + k6 * w.x + k5 * w.y + k7 * w.x * w.y,
    );
    return vec4<f32>(value, grad);
}

// w(t + d) − w(t) for the fade, as its Taylor polynomial in d: exact (w has degree 5), and a
// small d keeps its relative precision (procedural/delta.rs). Rust twin: delta::fade_delta_f32.
fn fade_delta(t: f32, d: f32) -> f32 {
    let w1 = 30.0 * t * t * (t - 1.0) * (t - 1.0);
    let w2 = t * (60.0 * t * t - 90.0 * t + 30.0);
    let w3 = 60.0 * t * t - 60.0 * t + 10.0;
    let w4 = 30.0 * t - 15.0;
    return d * (w1 + d * (w2 + d * (w3 + d * (w4 + d * 6.0))));
}

// ∂S/∂w_axis in a cell: the corners' differences along the axis, interpolated over the other
// two axes' weights. Rust twin: delta::leg_slope.
fn leg_slope(v: array<f32, 8>, w: vec3<f32>, axis: u32) -> f32 {
    var d: vec4<f32>;
    var s: f32;
    var t: f32;
    if axis == 0u {
        d = vec4<f32>(v[1] - v[0], v[3] - v[2], v[5] - v[4], v[7] - v[6]);
        s = w.y;
        t = w.z;
    } else if axis == 1u {
        d = vec4<f32>(v[2] - v[0], v[3] - v[1], v[6] - v[4], v[7] - v[5]);
        s = w.x;
        t = w.z;
    } else {
        d = vec4<f32>(v[4] - v[0], v[5] - v[1], v[6] - v[2], v[7] - v[3]);
        s = w.x;
        t = w.y;
    }
    let a = d.x + (d.y - d.x) * s;
    let b = d.z + (d.w - d.z) * s;
    return a + (b - a) * t;
}

// S(cell + f + d) − S(cell + f), |d| < 1 per axis, from small numbers only: along x, then y,
// then z, each leg within one cell or split at the face it crosses (one call site of the
// lattice hash: a CPU rasteriser compiles every inlined copy into each texel's code).
// Rust twin: delta::value_noise_delta_f32.
fn value_noise_delta(cell0: vec3<i32>, f: vec3<f32>, d: vec3<f32>, seed: u32) -> f32 {
    var cell = cell0;
    var g = f;
    var v: array<f32, 8>;
    var stale = true;
    var ds = 0.0;
    for (var a = 0u; a < 3u; a++) {
        var rest = d[a];
        for (var seg = 0u; seg < 2u; seg++) {
            if stale {
                v = lattice_corners(cell, seed);
                stale = false;
            }
            let w = vec3<f32>(fade(g.x), fade(g.y), fade(g.z));
            let u = g[a] + rest;
            if (u >= 0.0 && u <= 1.0) || seg == 1u {
                ds += leg_slope(v, w, a) * fade_delta(g[a], rest);
                g[a] = u;
                break;
            }
            let up = u > 1.0;
            let edge = select(0.0, 1.0, up);
            let d1 = edge - g[a];
            ds += leg_slope(v, w, a) * fade_delta(g[a], d1);
            var step = vec3<i32>(0);
            step[a] = select(-1, 1, up);
            cell += step;
            stale = true;
            g[a] = 1.0 - edge;
            rest = rest - d1;
        }
    }
    return ds;
}
