//! f32 twins of `shaders/common/trig.wgsl`: the trigonometry every shader uses instead of the
//! WGSL builtins, line by line in the same order, so tests can measure what the GPU computes.
//!
//! Why not the builtins: Vulkan lets a driver's `sin`/`cos` be off by 2^-11 absolute and its
//! `atan2` by 4096 ulp, and real GPUs use that room. NVIDIA's `sin`/`cos` read the argument in
//! revolutions at a fixed 2^-22 step (7.5e-7 rad); the angular offset of a texel on the finest
//! levels is 1e-9 to 1e-6 rad, so its sine came out 0 or wrong by ~100 %. On an H200 that moved
//! the procedural detail by metres at `ground` (p99 ρ 32 px at 1920×1080) where lavapipe, whose
//! builtins are exact to rounding, showed 0.01 px. [`coarse_sin_f32`] is that hardware form, for
//! tests that show what a driver's builtin would do.

/// Twin of `atan2_precise`: atan2 with ~1 ulp relative error for small angles on every GPU
/// (lavapipe's builtin misses 1 cm at 1 km). Range reduction to |t| ≤ tan(π/12) via
/// atan t = π/6 + atan((√3t − 1)/(√3 + t)), then the odd Taylor series to t¹³.
#[allow(clippy::excessive_precision, clippy::approx_constant)]
pub fn atan2_precise_f32(y: f32, x: f32) -> f32 {
    let ax = x.abs();
    let ay = y.abs();
    let hi = ax.max(ay);
    if hi == 0.0 {
        return 0.0;
    }
    let mut t = ax.min(ay) / hi;
    let mut base = 0.0;
    if t > 0.26794919 {
        t = (1.7320508 * t - 1.0) / (1.7320508 + t);
        base = 0.52359878;
    }
    let t2 = t * t;
    let series = 1.0
        + t2 * (-0.33333334
            + t2 * (0.2
                + t2 * (-0.14285715 + t2 * (0.11111111 + t2 * (-0.09090909 + t2 * 0.07692308)))));
    let mut r = base + t * series;
    if ay > ax {
        r = 1.5707964 - r;
    }
    if x < 0.0 {
        r = 3.1415927 - r;
    }
    if y < 0.0 {
        r = -r;
    }
    r
}

/// Twin of `sin_kernel`: sin r for |r| ≤ π/4, the odd Taylor series to r⁹ (truncation < 3e-9
/// relative), so tiny angles keep every bit.
#[allow(clippy::excessive_precision)]
pub fn sin_kernel_f32(r: f32) -> f32 {
    let r2 = r * r;
    r + r * r2 * (-0.16666667 + r2 * (0.008333334 + r2 * (-0.0001984127 + r2 * 2.7557319e-6)))
}

/// Twin of `cos_kernel`: cos r for |r| ≤ π/4, the even Taylor series to r¹⁰.
#[allow(clippy::excessive_precision)]
pub fn cos_kernel_f32(r: f32) -> f32 {
    let r2 = r * r;
    1.0 + r2
        * (-0.5
            + r2 * (0.041666668 + r2 * (-0.0013888889 + r2 * (2.4801588e-5 + r2 * -2.7557319e-7))))
}

/// Twin of `sin_cos_precise`: (sin x, cos x) from x = k·π/2 + r, π/2 in three parts
/// (Cody–Waite: k·1.5703125 is exact for |k| < 2^16, |x| < 1e5), |r| ≤ π/4, then the kernels by
/// quadrant. A few ulp relative for |x| ≤ π/4 however small x is; ≤ 1.2e-7 absolute for
/// |x| < 2000, 3e-11·|x| beyond (k·C2 no longer exact).
#[allow(clippy::excessive_precision, clippy::approx_constant)]
pub fn sin_cos_precise_f32(x: f32) -> (f32, f32) {
    let k = (x * 0.63661977).round_ties_even();
    let r = ((x - k * 1.5703125) - k * 4.8375130e-4) - k * 7.5497901e-8;
    let s = sin_kernel_f32(r);
    let c = cos_kernel_f32(r);
    match (k as i32) & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// Twin of `sin_precise`.
pub fn sin_precise_f32(x: f32) -> f32 {
    sin_cos_precise_f32(x).0
}

/// Twin of `cos_precise`.
pub fn cos_precise_f32(x: f32) -> f32 {
    sin_cos_precise_f32(x).1
}

/// Step of the argument, in revolutions, of NVIDIA's hardware sine and cosine (2^-22).
pub const COARSE_TRIG_STEP_REV: f32 = 1.0 / 4_194_304.0;

/// A driver's builtin `sin` as coarse as NVIDIA's: the argument rounded to 2^-22 revolutions
/// (7.5e-7 rad), then exact. Twin of `coarse_sin` in [`crate::render::shader::with_coarse_builtin_trig`].
pub fn coarse_sin_f32(x: f32) -> f32 {
    let turns = (x * std::f32::consts::FRAC_1_PI * 0.5 / COARSE_TRIG_STEP_REV).round_ties_even();
    (turns * COARSE_TRIG_STEP_REV * std::f32::consts::TAU).sin()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Arguments from 1e-12 rad to 1e4 rad, both signs, plus the quadrant edges.
    fn arguments() -> Vec<f32> {
        let mut xs = Vec::new();
        let mut x = 1e-12f64;
        while x < 1e4 {
            for m in [1.0, 1.37, 2.9, 5.3, 7.77] {
                xs.push((x * m) as f32);
                xs.push(-(x * m) as f32);
            }
            x *= 10.0;
        }
        for k in -8..=8 {
            let edge = k as f64 * std::f64::consts::FRAC_PI_4;
            for d in [-1e-6, -1e-3, 0.0, 1e-3, 1e-6] {
                xs.push((edge + d) as f32);
            }
        }
        xs
    }

    #[test]
    fn small_angles_keep_their_relative_precision() {
        // |x| ≤ π/4: relative error ≤ 2 ulp (2.4e-7), down to 1e-12 rad.
        for x in arguments().into_iter().filter(|x| x.abs() <= 0.785) {
            let want = (x as f64).sin();
            let got = sin_precise_f32(x) as f64;
            let rel = ((got - want) / want).abs();
            assert!(
                x == 0.0 || rel <= 2.4e-7,
                "sin({x:e}) = {got:e}, want {want:e}"
            );
            let c = cos_precise_f32(x) as f64;
            assert!((c - (x as f64).cos()).abs() <= 1.2e-7, "cos({x:e}) = {c:e}");
        }
    }

    #[test]
    fn large_arguments_stay_within_an_ulp_or_two() {
        // The f32 argument is exact; the result is compared with the f64 function of it:
        // 1.2e-7 while k·C2 is exact (|x| < 2000), then k·C2's rounding, 3e-11·|x|.
        for x in arguments() {
            let (s, c) = sin_cos_precise_f32(x);
            let xs = x as f64;
            let tol = 1.2e-7 + 3e-11 * xs.abs();
            assert!((s as f64 - xs.sin()).abs() <= tol, "sin({x}) = {s}");
            assert!((c as f64 - xs.cos()).abs() <= tol, "cos({x}) = {c}");
        }
    }

    #[test]
    fn a_coarse_hardware_sine_loses_tiny_angles() {
        // What the precise forms are for: the hardware step swallows a fine level's texel.
        let d = 3e-8f32;
        assert_eq!(coarse_sin_f32(d), 0.0);
        assert!((sin_precise_f32(d) - d).abs() <= d * 1.2e-7);
        // And it is right to 1e-6 for ordinary angles (so it models a working driver).
        assert!((coarse_sin_f32(1.0) as f64 - 1f64.sin()).abs() < 1e-6);
    }
}
