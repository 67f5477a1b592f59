//! Domain warping (infinite-landscapes-projected-grid.md §2.2, the update of r and t): each
//! octave's domain is moved by a roughness- and height-dependent rotation and translation, so
//! the multifractal loses the homogeneous look of plain rescale-and-add.
//!
//! The paper rotates the planar domain about its origin by the unit vector r_i, updated per
//! octave as r_{i+1} = c1·R_i + c2 + r_i (renormalized), with R_i = R_0·H_i the height-
//! dependent roughness (R_0 = 1/(r·H)), and translates it by t_{i+1} = c3·H_i/R_i.
//!
//! On a sphere there is no origin to rotate about: a rotation about the planet's centre moves a
//! point by R·Δφ (millions of cells), and one about the point itself moves nothing. What the
//! rotation does in the paper's small domain is move a point by |x|·(r_i − r_0), a bounded
//! displacement whose direction turns with roughness. We keep exactly that with a fixed lever
//! |x| = `lever_cells` (in the octave's own cells), along the octave's rotated lattice axes:
//! D_i = lever·(r_i − r_0) + t_i. Two deliberate departures, both for a provable slope bound
//! (the reference ray caster's safe step):
//! - r_i accumulates the paper's increments un-normalized and is normalized once when used
//!   (`v / max(|v|, ½)`), so a derivative grows by at most 2× instead of 2× per octave;
//! - t_i = c3·H_i/R_i is the constant c3/R_0 (R_i = R_0·H_i); it is applied as that constant,
//!   a fixed shift of each octave's lattice (where H_i = 0 the paper's quotient is undefined).

use serde::{Deserialize, Serialize};

/// The warping vectors (the paper's Fig. 3 values by default) and the lever.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct WarpParams {
    /// c1: rotation per unit of roughness.
    pub c1: [f64; 2],
    /// c2: constant rotation per octave.
    pub c2: [f64; 2],
    /// c3: translation (in cells, times r·H).
    pub c3: [f64; 2],
    /// The lever |x| in cells: how far the rotation moves a point. 0 turns warping off.
    pub lever_cells: f64,
}

impl Default for WarpParams {
    fn default() -> Self {
        Self {
            c1: [0.35, 0.16],
            c2: [-0.07, 0.13],
            c3: [0.11, 0.17],
            lever_cells: 0.5,
        }
    }
}

/// Smallest length the accumulated rotation vector is normalized by.
pub const NORMALIZE_FLOOR: f64 = 0.5;

/// The warp state between octaves: the accumulated (un-normalized) rotation vector.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WarpState {
    pub v: [f64; 2],
}

impl WarpState {
    /// r_0 = (1, 0).
    pub fn start() -> Self {
        Self { v: [1.0, 0.0] }
    }

    /// Displacement of the next octave's domain in its own cells (along its lattice x, y).
    pub fn displacement(&self, p: &WarpParams, r0_roughness: f64) -> [f64; 2] {
        let len = (self.v[0] * self.v[0] + self.v[1] * self.v[1]).sqrt();
        let n = len.max(NORMALIZE_FLOOR);
        let t = [p.c3[0] / r0_roughness, p.c3[1] / r0_roughness];
        [
            p.lever_cells * (self.v[0] / n - 1.0) + t[0],
            p.lever_cells * (self.v[1] / n) + t[1],
        ]
    }

    /// After an octave: v += c1·R_i + c2 with R_i = R_0·H_i (`h` the accumulated height in
    /// units of the first octave's amplitude).
    pub fn advance(&mut self, p: &WarpParams, r0_roughness: f64, h: f64) {
        let rough = r0_roughness * h;
        self.v[0] += p.c1[0] * rough + p.c2[0];
        self.v[1] += p.c1[1] * rough + p.c2[1];
    }
}

/// The f32 twin of [`WarpState`], operation for operation as `shaders/common/detail.wgsl`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WarpStateF32 {
    pub v: [f32; 2],
}

impl WarpStateF32 {
    pub fn start() -> Self {
        Self { v: [1.0, 0.0] }
    }

    /// `lever`, `t` (= c3/R_0) as the GPU gets them.
    pub fn displacement(&self, lever: f32, t: [f32; 2]) -> [f32; 2] {
        let len = (self.v[0] * self.v[0] + self.v[1] * self.v[1]).sqrt();
        let n = len.max(NORMALIZE_FLOOR as f32);
        [
            lever * (self.v[0] / n - 1.0) + t[0],
            lever * (self.v[1] / n) + t[1],
        ]
    }

    /// `c1r0` = c1·R_0, `c2` as the GPU gets them.
    pub fn advance(&mut self, c1r0: [f32; 2], c2: [f32; 2], h: f32) {
        self.v[0] += c1r0[0] * h + c2[0];
        self.v[1] += c1r0[1] * h + c2[1];
    }
}
