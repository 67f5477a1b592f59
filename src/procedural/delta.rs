//! The detail of a fill block relative to the block's reference point, for the levels the
//! eye sees from millimetres.
//!
//! A fill texel used to place every octave's lattice point as a fraction of its cell in f32:
//! steps of 6·10⁻⁸ cells, which on the coarse octaves (cells of kilometres) move the point by
//! half a millimetre, and S by up to 3.8 times that, so a level's heights carried a rounding
//! noise of ~0.15 mm (σ·a_k·4·10⁻⁷ summed over the octaves). A millimetre above the ground
//! that is a large part of the height the ground is seen from.
//!
//! So on a block small against an octave's cells ([`DELTA_CELLS_PER_EXTENT`]) the octave is
//! evaluated as a difference from the block's reference point: the CPU evaluates the chain
//! (eq. 1 with the warp of §2.2, and σ) there in f64; the GPU adds, per texel, the change of
//! each quantity, formed from small numbers only (Taylor polynomial of the fade, which is exact
//! since it has degree 5; path through a cell boundary; differences of the clamp, of the
//! warp's normalisation and of the bilinear relief). The block's value at the reference point,
//! σ_r·F_r (F_r: the δ octaves' sum), is what [`DeltaBlock::offset_m`] gives the fill to take
//! off its reference height in f64, so the level's texels hold small numbers near the eye.
//!
//! Rust twin of `shaders/common/detail_fill.wgsl` (`detail_texel` with `delta.x > 0`) and
//! `value_noise_delta` in `shaders/common/noise.wgsl`: the same operations in the same order.

use std::f64::consts::{PI, TAU};

use glam::DVec3;

use super::{
    Detail, DetailConstantsF32, DetailTexelF32, LevelOctaves, OctaveAnchorF32, RoughnessMap, noise,
    warp,
};

/// An octave is evaluated relative to the block's reference point when its cells are at least
/// this many block extents wide: the texel's offset, warp change included, then stays well
/// below one cell, so the path from the reference crosses at most one cell face per axis.
pub const DELTA_CELLS_PER_EXTENT: f64 = 16.0;

/// One relative octave's values at the block's reference point (f32, as the GPU gets them).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DeltaOctaveF32 {
    /// The warped reference point is cell + f_hi + f_lo (f_hi in the anchor's `frac`).
    pub f_lo: [f32; 3],
    /// S(reference) − S(cell + f_hi), evaluated in f64.
    pub corr: f32,
    /// 1 + g_h·clamp(Ĥ, −1, 1) at the reference.
    pub m_r: f32,
    /// Ĥ − clamp(Ĥ, −1, 1), −1 − clamp(Ĥ), 1 − clamp(Ĥ): the clamp's change is
    /// clamp(ΔĤ + e, lo, hi).
    pub e_h: f32,
    pub lo_h: f32,
    pub hi_h: f32,
    /// The warp's accumulated rotation vector and its length at the reference.
    pub v_r: [f32; 2],
    pub len_r: f32,
    /// S at the reference.
    pub s_r: f32,
}

/// How σ's relief changes over the block.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ReliefDeltaF32 {
    /// 0: constant over the block (inside a pole's outermost row, which holds one value);
    /// 1: bilinear from the reference's cell.
    pub mode: u32,
    /// The reference's relief coordinates (columns from φ = 0, rows from the north pole,
    /// between cell centres): cell + f_hi + f_lo.
    pub cell: [i32; 2],
    pub f_hi: [f32; 2],
    pub f_lo: [f32; 2],
    /// R(reference) − R(cell + f_hi), f64.
    pub corr: f32,
    /// Relief cells per radian of φ and of θ.
    pub scale: [f32; 2],
}

/// A fill block's detail relative to its reference point.
#[derive(Clone, Debug, PartialEq)]
pub struct DeltaBlock {
    /// Octaves evaluated relative to the reference (a prefix of the whole ones); 0: none.
    pub count: usize,
    /// Every held octave's lattice: for the relative ones the warped reference point's cell
    /// and f_hi, for the others the unwarped one (as [`Detail::anchors`]).
    pub anchors: Vec<OctaveAnchorF32>,
    pub octaves: Vec<DeltaOctaveF32>,
    /// Ĥ and the warp's vector after the relative octaves, and their sum F_r (units of σ).
    pub h_end: f32,
    pub v_end: [f32; 2],
    pub f_r: f32,
    /// σ at the reference, and (e, −σ_r, cap − σ_r, gain): σ's change is
    /// clamp(gain·ΔR + e, −σ_r, cap − σ_r).
    pub sigma_r: f32,
    pub sigma: [f32; 4],
    pub relief: ReliefDeltaF32,
    /// σ_r·F_r in metres (f64): the texels hold the detail less this.
    pub offset_m: f64,
}

/// The relief map's bilinear value at continuous coordinates (x, y) between cell centres:
/// columns wrap, rows clamp (the WGSL `relief_at`'s).
fn relief_xy(map: &RoughnessMap, x: f64, y: f64) -> f64 {
    let (cols, rows) = (map.cols as i64, map.rows as i64);
    let y = y.clamp(-0.5, rows as f64 - 0.5);
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let at = |r: i64, c: i64| {
        let r = r.clamp(0, rows - 1);
        map.values[(r * cols + c.rem_euclid(cols)) as usize] as f64
    };
    let (c, r) = (x0 as i64, y0 as i64);
    let top = at(r, c) + fx * (at(r, c + 1) - at(r, c));
    let bottom = at(r + 1, c) + fx * (at(r + 1, c + 1) - at(r + 1, c));
    top + fy * (bottom - top)
}

/// f as (hi, lo) with hi an f32 in [0, 1) and hi + lo = f to f64 precision.
fn split_fraction(f: f64) -> (f32, f32) {
    let mut hi = f as f32;
    if hi >= 1.0 {
        hi = 1.0 - f32::EPSILON / 2.0;
    }
    (hi, (f - hi as f64) as f32)
}

impl Detail {
    /// The relative form of the block whose texels lie at (φ_r + i·dφ, θ_r + j·dθ) for
    /// 0 ≤ i·dφ ≤ `extent_rad`[0], 0 ≤ j·dθ ≤ `extent_rad`[1] (rows unfolded past a pole),
    /// holding `octaves`. No octave is relative where the block is not small against the
    /// first octave's cells, or where σ's relief could not be followed relatively (a block
    /// reaching from a pole's outermost row into the next).
    pub fn delta_block(
        &self,
        phi_r: f64,
        theta_r: f64,
        extent_rad: [f64; 2],
        octaves: LevelOctaves,
    ) -> DeltaBlock {
        let u_ref = crate::geo::sphere::unit_vector(phi_r, theta_r);
        let count = (octaves.full + octaves.partial) as usize;
        let mut block = DeltaBlock {
            count: 0,
            anchors: self.anchors(u_ref, count),
            octaves: Vec::new(),
            h_end: 0.0,
            v_end: [1.0, 0.0],
            f_r: 0.0,
            sigma_r: 0.0,
            sigma: [0.0; 4],
            relief: ReliefDeltaF32::default(),
            offset_m: 0.0,
        };
        // The block's size on the ground bounds |Δu|·R: its θ side plus its φ side at the
        // widest row (near a pole a φ step is short).
        let (t0, t1) = (theta_r, theta_r + extent_rad[1]);
        let sin_max = if t0 <= 0.5 * PI && t1 >= 0.5 * PI {
            1.0
        } else {
            t0.sin().abs().max(t1.sin().abs())
        };
        let extent_m = (extent_rad[1] + sin_max * extent_rad[0]) * self.radius_m;
        let relative = self
            .octaves
            .iter()
            .take(octaves.full as usize)
            .take_while(|o| o.cell_m >= DELTA_CELLS_PER_EXTENT * extent_m)
            .count();
        if relative == 0 {
            return block;
        }
        let Some(relief) = self.relief_delta(phi_r, theta_r, extent_rad) else {
            return block;
        };

        // The chain at the reference point in f64 (Detail::weighted_octaves).
        let p = &self.params;
        let r0 = p.r0_roughness();
        let position = u_ref * self.radius_m;
        let mut state = warp::WarpState::start();
        let mut h_all = 0f64;
        let mut f_r = 0f64;
        for (k, o) in self.octaves.iter().enumerate().take(relative) {
            let d = state.displacement(&p.warp, r0);
            let x = o.rotation * position / o.cell_m + DVec3::new(d[0], d[1], 0.0);
            let (cell, frac) = noise::split(x.to_array());
            let split = frac.map(split_fraction);
            let f_hi = split.map(|s| s.0);
            let s_r = noise::value_noise(cell, frac, o.seed);
            let s_hi = noise::value_noise(cell, f_hi.map(f64::from), o.seed);
            let c = h_all.clamp(-1.0, 1.0);
            let m = 1.0 + p.height_roughness * c;
            let len = (state.v[0] * state.v[0] + state.v[1] * state.v[1]).sqrt();
            block.anchors[k].frac = f_hi;
            block.anchors[k].cell = cell;
            block.octaves.push(DeltaOctaveF32 {
                f_lo: split.map(|s| s.1),
                corr: (s_r - s_hi) as f32,
                m_r: m as f32,
                e_h: (h_all - c) as f32,
                lo_h: (-1.0 - c) as f32,
                hi_h: (1.0 - c) as f32,
                v_r: [state.v[0] as f32, state.v[1] as f32],
                len_r: len as f32,
                s_r: s_r as f32,
            });
            let t = o.amplitude * m * s_r;
            h_all += t;
            f_r += t;
            state.advance(&p.warp, r0, h_all);
        }
        let (floor, cap) = (p.amplitude_min_m, p.amplitude_max_m);
        let gain = p.roughness_gain * self.relief_scale;
        let (cols, rows) = (self.roughness.cols as f64, self.roughness.rows as f64);
        let x_r = phi_r.rem_euclid(TAU) / TAU * cols - 0.5;
        let y_r = theta_r / PI * rows - 0.5;
        let raw = floor + gain * relief_xy(&self.roughness, x_r, y_r);
        let sigma_r = raw.clamp(0.0, cap);
        block.count = relative;
        block.h_end = h_all as f32;
        block.v_end = [state.v[0] as f32, state.v[1] as f32];
        block.f_r = f_r as f32;
        block.sigma_r = sigma_r as f32;
        block.sigma = [
            (raw - sigma_r) as f32,
            -sigma_r as f32,
            (cap - sigma_r) as f32,
            gain as f32,
        ];
        block.relief = relief;
        block.offset_m = sigma_r * f_r;
        block
    }

    /// How the relief changes over the block, or None where neither relative form holds.
    fn relief_delta(
        &self,
        phi_r: f64,
        theta_r: f64,
        extent_rad: [f64; 2],
    ) -> Option<ReliefDeltaF32> {
        let map = &self.roughness;
        let (cols, rows) = (map.cols as f64, map.rows as f64);
        let scale = [cols / TAU, rows / PI];
        let x_r = phi_r.rem_euclid(TAU) * scale[0] - 0.5;
        let y_r = theta_r * scale[1] - 0.5;
        let y_end = (theta_r + extent_rad[1]) * scale[1] - 0.5;
        let small = extent_rad[0] * scale[0] <= 0.5 && extent_rad[1] * scale[1] <= 0.5;
        if small && y_r > 0.0 && y_end < rows - 1.0 {
            let (cx, cy) = (x_r.floor(), y_r.floor());
            let (fx, fy) = (split_fraction(x_r - cx), split_fraction(y_r - cy));
            let at_hi = relief_xy(map, cx + fx.0 as f64, cy + fy.0 as f64);
            return Some(ReliefDeltaF32 {
                mode: 1,
                cell: [cx as i32, cy as i32],
                f_hi: [fx.0, fy.0],
                f_lo: [fx.1, fy.1],
                corr: (relief_xy(map, x_r, y_r) - at_hi) as f32,
                scale: scale.map(|s| s as f32),
            });
        }
        // Wholly within half a row of a pole (folded across it): the outermost row, one value.
        let half_row = 0.5 * PI / rows;
        let theta_end = theta_r + extent_rad[1];
        let north = theta_r >= -half_row && theta_end <= half_row;
        let south = theta_r >= PI - half_row && theta_end <= PI + half_row;
        (north || south).then(|| ReliefDeltaF32 {
            scale: scale.map(|s| s as f32),
            ..Default::default()
        })
    }
}

/// w(t + d) − w(t) for the quintic fade w (noise.rs), as its Taylor polynomial in d: exact
/// (w has degree 5), and small d keep their relative precision.
pub fn fade_delta_f32(t: f32, d: f32) -> f32 {
    let w1 = 30.0 * t * t * (t - 1.0) * (t - 1.0);
    let w2 = t * (60.0 * t * t - 90.0 * t + 30.0);
    let w3 = 60.0 * t * t - 60.0 * t + 10.0;
    let w4 = 30.0 * t - 15.0;
    d * (w1 + d * (w2 + d * (w3 + d * (w4 + d * 6.0))))
}

fn fade_f32(t: f32) -> f32 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

fn lattice_corners(cell: [i32; 3], seed: u32) -> [f32; 8] {
    let v = |dx: i32, dy: i32, dz: i32| {
        noise::lattice_value(
            [
                cell[0].wrapping_add(dx),
                cell[1].wrapping_add(dy),
                cell[2].wrapping_add(dz),
            ],
            seed,
        )
    };
    [
        v(0, 0, 0),
        v(1, 0, 0),
        v(0, 1, 0),
        v(1, 1, 0),
        v(0, 0, 1),
        v(1, 0, 1),
        v(0, 1, 1),
        v(1, 1, 1),
    ]
}

/// ∂S/∂w_axis in a cell: the corners' differences along the axis, interpolated over the
/// other two axes' weights.
fn leg_slope(v: &[f32; 8], w: [f32; 3], axis: usize) -> f32 {
    let (d, s, t) = match axis {
        0 => (
            [v[1] - v[0], v[3] - v[2], v[5] - v[4], v[7] - v[6]],
            w[1],
            w[2],
        ),
        1 => (
            [v[2] - v[0], v[3] - v[1], v[6] - v[4], v[7] - v[5]],
            w[0],
            w[2],
        ),
        _ => (
            [v[4] - v[0], v[5] - v[1], v[6] - v[2], v[7] - v[3]],
            w[0],
            w[1],
        ),
    };
    let a = d[0] + (d[1] - d[0]) * s;
    let b = d[2] + (d[3] - d[2]) * s;
    a + (b - a) * t
}

/// S(cell + f + d) − S(cell + f), |d| < 1 per axis, from small numbers only: along x, then
/// y, then z, each leg within one cell or split at the cell face it crosses.
pub fn value_noise_delta_f32(cell: [i32; 3], f: [f32; 3], d: [f32; 3], seed: u32) -> f32 {
    let mut cell = cell;
    let mut g = f;
    let mut v = [0f32; 8];
    let mut stale = true;
    let mut ds = 0f32;
    for a in 0..3 {
        let mut rest = d[a];
        for seg in 0..2 {
            if stale {
                v = lattice_corners(cell, seed);
                stale = false;
            }
            let w = g.map(fade_f32);
            let u = g[a] + rest;
            if (0.0..=1.0).contains(&u) || seg == 1 {
                ds += leg_slope(&v, w, a) * fade_delta_f32(g[a], rest);
                g[a] = u;
                break;
            }
            let up = u > 1.0;
            let edge = if up { 1.0 } else { 0.0 };
            let d1 = edge - g[a];
            ds += leg_slope(&v, w, a) * fade_delta_f32(g[a], d1);
            cell[a] = cell[a].wrapping_add(if up { 1 } else { -1 });
            stale = true;
            g[a] = 1.0 - edge;
            rest -= d1;
        }
    }
    ds
}

/// The relief map's four values around cell (c, r): (c, r), (c+1, r), (c, r+1), (c+1, r+1).
fn relief_corners(map: &RoughnessMap, cell: [i32; 2]) -> [f32; 4] {
    let (cols, rows) = (map.cols as i32, map.rows as i32);
    let at = |c: i32, r: i32| {
        let r = r.clamp(0, rows - 1);
        map.values[(r * cols + c.rem_euclid(cols)) as usize]
    };
    let (c, r) = (cell[0], cell[1]);
    [at(c, r), at(c + 1, r), at(c, r + 1), at(c + 1, r + 1)]
}

/// R(cell + f + d) − R(cell + f) of the bilinear relief, |d| < 1 per axis (as
/// [`value_noise_delta_f32`], linear weights).
pub fn relief_delta_f32(map: &RoughnessMap, cell: [i32; 2], f: [f32; 2], d: [f32; 2]) -> f32 {
    let mut cell = cell;
    let mut g = f;
    let mut q = relief_corners(map, cell);
    let slope = |q: &[f32; 4], g: [f32; 2], a: usize| {
        if a == 0 {
            let (lo, hi) = (q[1] - q[0], q[3] - q[2]);
            lo + (hi - lo) * g[1]
        } else {
            let (lo, hi) = (q[2] - q[0], q[3] - q[1]);
            lo + (hi - lo) * g[0]
        }
    };
    let mut dr = 0f32;
    for a in 0..2 {
        let da = d[a];
        let u = g[a] + da;
        if (0.0..=1.0).contains(&u) {
            dr += slope(&q, g, a) * da;
            g[a] = u;
        } else {
            let up = u > 1.0;
            let edge = if up { 1.0 } else { 0.0 };
            let d1 = edge - g[a];
            dr += slope(&q, g, a) * d1;
            cell[a] += if up { 1 } else { -1 };
            q = relief_corners(map, cell);
            let start = 1.0 - edge;
            g[a] = start;
            let d2 = da - d1;
            dr += slope(&q, g, a) * d2;
            g[a] = start + d2;
        }
    }
    dr
}

/// The f32 twin of the fill's relative detail (`detail_texel` with `delta.x > 0`): the texel
/// at Δu (unit-vector offset), (dφ, dθ) from the block's reference point. Returns σ·Σ of the
/// whole octaves less [`DeltaBlock::offset_m`], and σ·t_k of the partial ones.
#[allow(clippy::too_many_arguments)] // the WGSL's inputs, one for one
pub fn delta_texel_f32(
    block: &DeltaBlock,
    amplitudes: &[f32],
    c: &DetailConstantsF32,
    map: &RoughnessMap,
    du: [f32; 3],
    dphi: f32,
    dtheta: f32,
    octaves: LevelOctaves,
) -> DetailTexelF32 {
    let mut out = DetailTexelF32::default();
    // σ's change.
    let mut d_relief = 0f32;
    if block.relief.mode == 1 {
        let r = &block.relief;
        let d = [
            dphi * r.scale[0] + r.f_lo[0],
            dtheta * r.scale[1] + r.f_lo[1],
        ];
        d_relief = relief_delta_f32(map, r.cell, r.f_hi, d) - r.corr;
    }
    let s = block.sigma;
    let d_sigma = (s[3] * d_relief + s[0]).clamp(s[1], s[2]);
    // The relative octaves.
    let mut dh = 0f32;
    let mut dv = [0f32; 2];
    let mut df = 0f32;
    for ((a, o), &amplitude) in block.anchors.iter().zip(&block.octaves).zip(amplitudes) {
        let v = [o.v_r[0] + dv[0], o.v_r[1] + dv[1]];
        let len = (v[0] * v[0] + v[1] * v[1]).sqrt();
        let n_r = o.len_r.max(warp::NORMALIZE_FLOOR as f32);
        let n = len.max(warp::NORMALIZE_FLOOR as f32);
        let sum = len + o.len_r;
        let d_len = if sum > 0.0 {
            (2.0 * (o.v_r[0] * dv[0] + o.v_r[1] * dv[1]) + (dv[0] * dv[0] + dv[1] * dv[1])) / sum
        } else {
            0.0
        };
        let d_n = (d_len + (o.len_r - n_r)).max(warp::NORMALIZE_FLOOR as f32 - n_r);
        let inv = 1.0 / (n * n_r);
        let dq = [
            (dv[0] * n_r - o.v_r[0] * d_n) * inv,
            (dv[1] * n_r - o.v_r[1] * d_n) * inv,
        ];
        let mut d = [0f32; 3];
        for (i, di) in d.iter_mut().enumerate() {
            let row = a.m[i];
            *di = o.f_lo[i] + (row[0] * du[0] + row[1] * du[1] + row[2] * du[2]);
        }
        d[0] += c.lever * dq[0];
        d[1] += c.lever * dq[1];
        let d_s = value_noise_delta_f32(a.cell, a.frac, d, a.seed) - o.corr;
        let d_m = c.height_roughness * (dh + o.e_h).clamp(o.lo_h, o.hi_h);
        let d_t = amplitude * (o.m_r * d_s + d_m * (o.s_r + d_s));
        dh += d_t;
        df += d_t;
        dv[0] += c.c1r0[0] * dh;
        dv[1] += c.c1r0[1] * dh;
    }
    // The rest as `detail_texel_f32`, from the chain's state after the relative octaves.
    let state = warp::WarpStateF32 {
        v: [block.v_end[0] + dv[0], block.v_end[1] + dv[1]],
    };
    let sigma = block.sigma_r + d_sigma;
    let chain = (block.count, state, block.h_end + dh);
    let full = super::direct_octaves_f32(
        &block.anchors,
        amplitudes,
        c,
        du,
        sigma,
        octaves,
        chain,
        &mut out,
    );
    out.full_m = block.sigma_r * (df + full) + d_sigma * (block.f_r + df + full);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fade's Taylor form gives the same difference as two evaluations where those are
    /// exact enough, and keeps the relative precision of tiny steps.
    #[test]
    fn fade_delta_is_the_difference_of_fades() {
        let fade = |t: f64| t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
        for &t in &[0.0f32, 0.1, 0.37, 0.5, 0.93, 1.0] {
            for &d in &[-0.3f32, -1e-3, 1e-7, 1e-3, 0.25] {
                let exact = fade(t as f64 + d as f64) - fade(t as f64);
                let got = fade_delta_f32(t, d) as f64;
                assert!(
                    (got - exact).abs() <= 2e-6 * d.abs() as f64 + 1e-13,
                    "t {t} d {d}: {got} vs {exact}"
                );
            }
        }
    }

    /// The path through cell faces gives S's difference (f64 reference) for offsets that cross
    /// faces on every axis, to the relative precision of the offset.
    #[test]
    fn value_noise_delta_matches_the_difference() {
        let seed = 0x1234_5678;
        for (f, d) in [
            ([0.2f32, 0.7, 0.5], [1e-6f32, -2e-6, 3e-7]),
            ([0.9999, 0.00001, 0.5], [2e-4, -3e-5, 0.0]),
            ([0.95, 0.03, 0.999], [0.1, -0.2, 0.01]),
            ([0.5, 0.5, 0.5], [-0.6, 0.45, -0.3]),
        ] {
            let cell = [17, -3, 1024];
            let s = |x: [f64; 3]| {
                let (c, fr) = noise::split([
                    cell[0] as f64 + x[0],
                    cell[1] as f64 + x[1],
                    cell[2] as f64 + x[2],
                ]);
                noise::value_noise(c, fr, seed)
            };
            let f64_of = |a: [f32; 3]| a.map(f64::from);
            let end = [
                f[0] as f64 + d[0] as f64,
                f[1] as f64 + d[1] as f64,
                f[2] as f64 + d[2] as f64,
            ];
            let exact = s(end) - s(f64_of(f));
            let got = value_noise_delta_f32(cell, f, d, seed) as f64;
            let size = d.iter().map(|x| x.abs()).fold(0f32, f32::max) as f64;
            assert!(
                (got - exact).abs() <= 1e-5 * size + 1e-13,
                "f {f:?} d {d:?}: {got} vs {exact}"
            );
        }
    }
}
