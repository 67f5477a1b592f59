// Trigonometry with a precision the clipmap can rely on on every GPU.
//
// Vulkan lets a driver's sin and cos be off by 2^-11 in absolute terms and its atan2 by 4096
// ulp. Real GPUs use that room: NVIDIA's sin/cos take the argument in revolutions at a fixed
// 2^-22 step (7.5e-7 rad), so sin(d) of a texel's angular offset on the finest levels (1e-9 to
// 1e-6 rad) comes out 0 or off by ~100 % — on an H200 that moved the procedural detail by metres
// at `ground` (p99 ρ 32 px), while lavapipe, whose builtins are exact to rounding, showed 0.01 px.
// So every angle a fill or the map transform needs goes through these: polynomials only, no
// builtin trig, the same operations on every adapter.
//
// A function library: no entry points, no bindings. Rust twins in src/geo/trig.rs, line by line
// (named in each doc comment); tests/gpu_trig.rs runs these on the adapter against f64, also with
// the builtins made as coarse as NVIDIA's (`shader::with_coarse_builtin_trig`).

// atan2 with ~1 ulp relative error for small angles (where the clipmap needs it; lavapipe's
// builtin misses 1 cm at 1 km, tests/gpu/gpu_transform.rs). Range reduction to |t| ≤ tan(π/12)
// (atan t = π/6 + atan((√3t − 1)/(√3 + t))), then the odd Taylor series to t¹³ (truncation
// < 2e-10 relative). Rust twin: atan2_precise_f32.
fn atan2_precise(y: f32, x: f32) -> f32 {
    let ax = abs(x);
    let ay = abs(y);
    let hi = max(ax, ay);
    if hi == 0.0 {
        return 0.0;
    }
    var t = min(ax, ay) / hi;
    var base = 0.0;
    if t > 0.26794919 {
        t = (1.7320508 * t - 1.0) / (1.7320508 + t);
        base = 0.52359878;
    }
    let t2 = t * t;
    let series = 1.0 + t2 * (-0.33333334 + t2 * (0.2 + t2 * (-0.14285715 + t2 * (0.11111111 + t2 * (-0.09090909 + t2 * 0.07692308)))));
    var r = base + t * series;
    if ay > ax {
        r = 1.5707964 - r;
    }
    if x < 0.0 {
        r = 3.1415927 - r;
    }
    if y < 0.0 {
        r = -r;
    }
    return r;
}

// sin r for |r| ≤ π/4: the odd Taylor series to r⁹ (truncation < 3e-9 relative, below f32's
// 6e-8), so tiny angles keep every bit. Rust twin: sin_kernel_f32.
fn sin_kernel(r: f32) -> f32 {
    let r2 = r * r;
    return r + r * r2 * (-0.16666667 + r2 * (0.008333334 + r2 * (-0.0001984127 + r2 * 2.7557319e-6)));
}

// cos r for |r| ≤ π/4: the even Taylor series to r¹⁰ (truncation < 2e-10).
// Rust twin: cos_kernel_f32.
fn cos_kernel(r: f32) -> f32 {
    let r2 = r * r;
    return 1.0 + r2 * (-0.5 + r2 * (0.041666668 + r2 * (-0.0013888889 + r2 * (2.4801588e-5 + r2 * -2.7557319e-7))));
}

// (sin x, cos x): x = k·π/2 + r with π/2 in three parts (Cody–Waite; k·1.5703125 is exact for
// |k| < 2^16, i.e. |x| < 1e5), |r| ≤ π/4, then the kernels by quadrant. Relative error of a few
// ulp for |x| ≤ π/4 however small x is, absolute ≤ 1.2e-7 for |x| < 2000, 3e-11·|x| beyond.
// Rust twin: sin_cos_precise_f32.
fn sin_cos_precise(x: f32) -> vec2<f32> {
    let k = round(x * 0.63661977);
    let r = ((x - k * 1.5703125) - k * 4.8375130e-4) - k * 7.5497901e-8;
    let s = sin_kernel(r);
    let c = cos_kernel(r);
    let q = i32(k) & 3;
    if q == 0 {
        return vec2<f32>(s, c);
    }
    if q == 1 {
        return vec2<f32>(c, -s);
    }
    if q == 2 {
        return vec2<f32>(-s, -c);
    }
    return vec2<f32>(-c, s);
}

fn sin_precise(x: f32) -> f32 {
    return sin_cos_precise(x).x;
}

fn cos_precise(x: f32) -> f32 {
    return sin_cos_precise(x).y;
}
