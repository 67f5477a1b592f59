//! The auxiliary function S of eq. 1 (infinite-landscapes-projected-grid.md §2.1): value noise
//! over a 3-D integer lattice, sampled on the sphere (docs/design.md#detail-on-a-sphere).
//!
//! - **3-D, not (φ, θ)**: a lattice in map space converges at the poles and is cut at the
//!   antimeridian; one over ECEF space has neither and is isotropic by construction.
//! - **Integer hash**: lattice values come from `pcg3d` (Jarzynski & Olano 2020) on the cell's
//!   integer indices, never from `sin`, so every GPU and the CPU agree bit for bit on them.
//!   The value is a 24-bit integer scaled by 2⁻²³, exact in f32 and f64.
//! - **Quintic fade** 6t⁵ − 15t⁴ + 10t³ between lattice values: C² and band-limited enough
//!   that octave k holds (almost) no energy at wavelengths below its cell.
//!
//! Twins: [`value_noise`] (f64, the reference) and [`value_noise_f32`] (f32, the same
//! operations in the same order as `shaders/common/detail.wgsl`).

/// Largest |∂S/∂x| along one lattice axis, per cell: the fade's slope (15/8) times the
/// largest difference of two lattice values (2).
pub const AXIS_SLOPE_MAX: f64 = 3.75;

/// Bound of |∇S| per cell, proven by interval subdivision of the cell
/// (`tests::gradient_bound_holds_over_every_cell_and_lattice`): 3.8, against the
/// √3 · [`AXIS_SLOPE_MAX`] ≈ 6.50 of bounding each axis on its own. The axes cannot all be
/// steep at once (an x-edge difference of 2 everywhere makes the y- and z-edges flat), and the
/// largest |∇S| is 3.75 = [`AXIS_SLOPE_MAX`], taken mid-cell along one axis.
pub const GRADIENT_MAX: f64 = 3.8;

/// pcg3d: a 3 × u32 → 3 × u32 hash with good avalanche (Jarzynski & Olano, JCGT 2020).
pub fn pcg3d(mut x: u32, mut y: u32, mut z: u32) -> [u32; 3] {
    x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
    y = y.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
    z = z.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
    x = x.wrapping_add(y.wrapping_mul(z));
    y = y.wrapping_add(z.wrapping_mul(x));
    z = z.wrapping_add(x.wrapping_mul(y));
    x ^= x >> 16;
    y ^= y >> 16;
    z ^= z >> 16;
    x = x.wrapping_add(y.wrapping_mul(z));
    y = y.wrapping_add(z.wrapping_mul(x));
    z = z.wrapping_add(x.wrapping_mul(y));
    [x, y, z]
}

/// The lattice value at integer cell `c` of the octave with hash seed `seed`, in [−1, 1):
/// a 24-bit integer times 2⁻²³ minus 1 (exact in f32).
pub fn lattice_value(c: [i32; 3], seed: u32) -> f32 {
    let h = pcg3d(
        c[0] as u32 ^ seed,
        c[1] as u32,
        (c[2] as u32).wrapping_add(seed),
    );
    (h[0] >> 8) as f32 * (1.0 / 8_388_608.0) - 1.0
}

/// The quintic fade and its derivative.
pub fn fade(t: f64) -> f64 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

fn fade_f32(t: f32) -> f32 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

/// S at the point `cell + frac` of the lattice (f64): `cell` integer, `frac` in [0, 1)³.
pub fn value_noise(cell: [i32; 3], frac: [f64; 3], seed: u32) -> f64 {
    let w = [fade(frac[0]), fade(frac[1]), fade(frac[2])];
    // Wrapping, as the GPU's i32 arithmetic does.
    let v = |dx: i32, dy: i32, dz: i32| {
        let c = [
            cell[0].wrapping_add(dx),
            cell[1].wrapping_add(dy),
            cell[2].wrapping_add(dz),
        ];
        lattice_value(c, seed) as f64
    };
    let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
    let x00 = lerp(v(0, 0, 0), v(1, 0, 0), w[0]);
    let x10 = lerp(v(0, 1, 0), v(1, 1, 0), w[0]);
    let x01 = lerp(v(0, 0, 1), v(1, 0, 1), w[0]);
    let x11 = lerp(v(0, 1, 1), v(1, 1, 1), w[0]);
    lerp(lerp(x00, x10, w[1]), lerp(x01, x11, w[1]), w[2])
}

/// The f32 twin of [`value_noise`], operation for operation as the WGSL.
pub fn value_noise_f32(cell: [i32; 3], frac: [f32; 3], seed: u32) -> f32 {
    let w = [fade_f32(frac[0]), fade_f32(frac[1]), fade_f32(frac[2])];
    let v =
        |dx: i32, dy: i32, dz: i32| lattice_value([cell[0] + dx, cell[1] + dy, cell[2] + dz], seed);
    let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
    let x00 = lerp(v(0, 0, 0), v(1, 0, 0), w[0]);
    let x10 = lerp(v(0, 1, 0), v(1, 1, 0), w[0]);
    let x01 = lerp(v(0, 0, 1), v(1, 0, 1), w[0]);
    let x11 = lerp(v(0, 1, 1), v(1, 1, 1), w[0]);
    lerp(lerp(x00, x10, w[1]), lerp(x01, x11, w[1]), w[2])
}

/// Splits a lattice coordinate into its cell and fraction (f64).
pub fn split(x: [f64; 3]) -> ([i32; 3], [f64; 3]) {
    let f = x.map(f64::floor);
    (
        [f[0] as i32, f[1] as i32, f[2] as i32],
        [x[0] - f[0], x[1] - f[1], x[2] - f[2]],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lattice_values_cover_the_range_with_zero_mean() {
        let n = 20_000;
        let mut sum = 0.0;
        let (mut lo, mut hi) = (f64::MAX, f64::MIN);
        for i in 0..n {
            let v = lattice_value([i, -3 * i, 7 * i + 1], 12345) as f64;
            sum += v;
            lo = lo.min(v);
            hi = hi.max(v);
        }
        assert!((sum / n as f64).abs() < 0.02, "mean {}", sum / n as f64);
        assert!(lo < -0.99 && hi > 0.99 && hi < 1.0, "range {lo} … {hi}");
    }

    #[test]
    fn noise_interpolates_the_lattice_and_is_continuous_across_cells() {
        let seed = 7;
        for c in [[0, 0, 0], [-5, 12, 300_000_000], [i32::MAX - 2, -1, 4]] {
            assert_eq!(
                value_noise(c, [0.0; 3], seed),
                lattice_value(c, seed) as f64
            );
            let next = [c[0] + 1, c[1], c[2]];
            let left = value_noise(c, [1.0 - 1e-12, 0.3, 0.6], seed);
            let right = value_noise(next, [0.0, 0.3, 0.6], seed);
            assert!((left - right).abs() < 1e-9, "{left} vs {right}");
        }
    }

    /// |∇S| ≤ [`GRADIENT_MAX`] everywhere, for every set of lattice values in [−1, 1]: a
    /// computer-assisted proof. At a point, ∇S is linear in the eight corner values, so its
    /// norm is largest at a corner of [−1, 1]⁸ (±v alike: 128 sign patterns). Over a box of
    /// the cell, ∂S/∂x = fade′(x)·D_x, where D_x is bilinear in (fade(y), fade(z)) and so
    /// takes its extremes at the box's corners (fade is increasing), and fade′ is largest at
    /// ½ or the box's end nearest it. Boxes whose bound exceeds the target are halved along
    /// their longest side; the target is 10⁻³ under the constant, far above rounding.
    #[test]
    fn gradient_bound_holds_over_every_cell_and_lattice() {
        fn fade_slope(t: f64) -> f64 {
            30.0 * t * t * (t - 1.0) * (t - 1.0)
        }
        let target = GRADIENT_MAX - 1e-3;
        let patterns: Vec<[f64; 8]> = (0..128u32)
            .map(|bits| std::array::from_fn(|i| if bits >> i & 1 == 1 { 1.0 } else { -1.0 }))
            .collect();
        let bound = |b: &[[f64; 2]; 3]| -> f64 {
            let slope = b.map(|[lo, hi]| fade_slope(0.5f64.clamp(lo, hi)));
            let w = b.map(|[lo, hi]| [fade(lo), fade(hi)]);
            let mut worst: f64 = 0.0;
            for v in &patterns {
                let value = |c: [usize; 3]| v[c[0] * 4 + c[1] * 2 + c[2]];
                let mut sum = 0.0;
                for axis in 0..3 {
                    let (a, b2) = ((axis + 1) % 3, (axis + 2) % 3);
                    let mut d_max: f64 = 0.0;
                    for &wa in &w[a] {
                        for &wb in &w[b2] {
                            let mut d = 0.0;
                            for j in 0..2 {
                                for k in 0..2 {
                                    let weight = (if j == 1 { wa } else { 1.0 - wa })
                                        * (if k == 1 { wb } else { 1.0 - wb });
                                    let mut c = [0usize; 3];
                                    c[a] = j;
                                    c[b2] = k;
                                    c[axis] = 1;
                                    let high = value(c);
                                    c[axis] = 0;
                                    d += weight * (high - value(c));
                                }
                            }
                            d_max = d_max.max(d.abs());
                        }
                    }
                    sum += (slope[axis] * d_max).powi(2);
                }
                worst = worst.max(sum.sqrt());
            }
            worst
        };
        let mut boxes = vec![[[0.0, 1.0]; 3]];
        let (mut proven, mut tightest) = (0, 0.0f64);
        while let Some(b) = boxes.pop() {
            let got = bound(&b);
            if got <= target {
                proven += 1;
                tightest = tightest.max(got);
                continue;
            }
            let widths = b.map(|[lo, hi]| hi - lo);
            let axis = (0..3)
                .max_by(|&i, &j| widths[i].total_cmp(&widths[j]))
                .unwrap();
            assert!(
                widths[axis] > 1e-4,
                "no proof for the box {b:?}: bound {got}"
            );
            let [lo, hi] = b[axis];
            let mid = 0.5 * (lo + hi);
            for part in [[lo, mid], [mid, hi]] {
                let mut half = b;
                half[axis] = part;
                boxes.push(half);
            }
        }
        eprintln!("|∇S| ≤ {tightest:.4} over {proven} boxes");
        // The constant is near the true maximum (3.75, mid-cell with x-edges of 2): the
        // subdivision could not prove much less.
        assert!(tightest > 3.75);
    }

    #[test]
    fn slope_stays_within_the_stated_bound() {
        let seed = 99;
        let mut worst: f64 = 0.0;
        let h = 1e-6;
        for i in 0..4000 {
            let t = i as f64 * 0.618_033_988_7;
            let frac = [t.fract(), (t * 1.7).fract(), (t * 2.3).fract()];
            let cell = [i % 17, i % 5 - 2, i % 11];
            for axis in 0..3 {
                let mut f2 = frac;
                f2[axis] = (f2[axis] + h).min(1.0);
                let d = (value_noise(cell, f2, seed) - value_noise(cell, frac, seed))
                    / (f2[axis] - frac[axis]).max(1e-300);
                worst = worst.max(d.abs());
            }
        }
        assert!(worst <= AXIS_SLOPE_MAX, "{worst}");
        assert!(worst > 1.0, "the bound is not vacuous: {worst}");
    }
}
