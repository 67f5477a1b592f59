//! Geometry-image warping of the projected grid (geometry-image-warping.md §3): the grid's
//! parameter lines move so that vertex density follows an importance map, computed at low
//! resolution (§3.4: 128²) and upsampled bilinearly to the grid's size.
//!
//! Everything lives in the grid's parameter square [0,1]²; the caller samples the inputs of the
//! importance (§3.1) per cell of a low-resolution grid and knows the cameras.
//!
//! - Importance: I = min(Iv·Sf·Sb, Is) (§3.1), Iv = C/d. The two 1-D passes of Fig. 5 make the
//!   density along each axis proportional to I, so a separable I = f(x)·g(y) gets cells of
//!   area ∝ 1/I exactly: the warp delivers I as vertices per unit parameter *area*, which is
//!   therefore what I means here, what the surface bound Is is given in, and what
//!   [`quality`] compares.
//! - Warp (§3.3, Fig. 5): rows first, then columns on the row-distorted importance. Fig. 5
//!   box-filters each pixel's interval of the importance's running sum; on a vertex grid the
//!   same walk gives the interval ends (the inverse of the running sum), which keeps the
//!   boundary exactly on the square's edges.
//! - Guards (DESIGN.md "Numerics"): importance is clamped into [max/K, max] (K =
//!   [`WarpSettings::max_compression`]), so I_avg > 0 in every pass and no cell is more than K
//!   times narrower than uniform; NaN and negatives count as 0, +∞ as the limit of a huge
//!   value. Separate row and column passes can fold a grid (Fig. 5 does not check); where a
//!   low-resolution quad would be non-convex or thinner than half the guard's width, the
//!   column pass's variation across its vertex columns is damped toward the columns' mean
//!   (undamped, every quad is a trapezoid with horizontal sides, convex by construction).

use glam::DVec2;

/// Inputs of the importance of one low-resolution cell (§3.1): what the caller measured there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImportanceSample {
    /// Distance from the eye to the cell's surface point, metres: Iv = C/d (≤ 0 gives ∞).
    pub distance_m: f64,
    /// Fraction of the cell inside the view frustum, 0..1 (the paper's smoothed transition
    /// zone comes from partial cells).
    pub in_frustum: f64,
    /// Cosine between the surface normal and the direction to the eye (< 0: back-facing).
    pub facing_cos: f64,
    /// Is: the most vertices per unit parameter area the terrain can use there, or ∞.
    pub surface_limit: f64,
}

/// Importance I per low-resolution cell, row-major (row 0 at parameter y = 0).
#[derive(Clone, Debug, PartialEq)]
pub struct ImportanceMap {
    pub cols: usize,
    pub rows: usize,
    pub values: Vec<f64>,
}

/// The constants of §3.1 and the warp's guard.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WarpSettings {
    /// Size of the importance map the caller samples (§3.4 and §5: 128²).
    pub low_res_cols: usize,
    pub low_res_rows: usize,
    /// C of Iv = C/d: vertices per unit parameter area wanted 1 m from the eye. Only its ratio
    /// to the surface bounds Is matters (the warp is scale-free).
    pub view_constant: f64,
    /// Sf outside the frustum; the paper uses 0 (the guard still leaves those cells 1/K).
    pub outside_frustum_factor: f64,
    /// Sb of fully back-facing cells ("smoothly decreased", §3.1; the paper gives no value).
    pub backface_factor: f64,
    /// Sb falls from 1 at the silhouette (cos 0) to `backface_factor` at cos = −this, smoothly
    /// (smoothstep); 0.25 ≈ 14° behind the silhouette, a choice.
    pub backface_fade_cos: f64,
    /// K: the most a cell may be compressed in one pass (no low-resolution cell narrower than
    /// 1/K of uniform). 64 keeps the realistic map's whole in-frustum range (~25:1) unclamped.
    pub max_compression: f64,
}

impl Default for WarpSettings {
    fn default() -> Self {
        Self {
            low_res_cols: 128,
            low_res_rows: 128,
            view_constant: 1.0,
            outside_frustum_factor: 0.0,
            backface_factor: 0.0,
            backface_fade_cos: 0.25,
            max_compression: 64.0,
        }
    }
}

/// Above this K, the guaranteed widths (≥ 1/(n·K)) and quad corners (≥ 1/(n²·K²)) come near
/// f64 rounding of parameter positions.
const MAX_COMPRESSION_LIMIT: f64 = 1e4;

/// Settings that cannot be used.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum WarpSettingsError {
    #[error("the low-resolution map must have at least one cell (got {cols}×{rows})")]
    EmptyMap { cols: usize, rows: usize },
    #[error("field `{field}` = {value} is outside its allowed range {allowed}")]
    Range {
        field: &'static str,
        value: f64,
        allowed: &'static str,
    },
}

impl WarpSettings {
    pub fn validate(&self) -> Result<(), WarpSettingsError> {
        if self.low_res_cols == 0 || self.low_res_rows == 0 {
            return Err(WarpSettingsError::EmptyMap {
                cols: self.low_res_cols,
                rows: self.low_res_rows,
            });
        }
        let positive = |v: f64| v > 0.0 && v.is_finite();
        let unit = |v: f64| (0.0..=1.0).contains(&v);
        let checks: [(&'static str, f64, bool, &'static str); 5] = [
            (
                "view_constant",
                self.view_constant,
                positive(self.view_constant),
                "(0, ∞)",
            ),
            (
                "outside_frustum_factor",
                self.outside_frustum_factor,
                unit(self.outside_frustum_factor),
                "[0, 1]",
            ),
            (
                "backface_factor",
                self.backface_factor,
                unit(self.backface_factor),
                "[0, 1]",
            ),
            (
                "backface_fade_cos",
                self.backface_fade_cos,
                positive(self.backface_fade_cos) && self.backface_fade_cos <= 1.0,
                "(0, 1]",
            ),
            (
                "max_compression",
                self.max_compression,
                (1.0..=MAX_COMPRESSION_LIMIT).contains(&self.max_compression),
                "[1, 1e4]",
            ),
        ];
        match checks.into_iter().find(|c| !c.2) {
            Some((field, value, _, allowed)) => Err(WarpSettingsError::Range {
                field,
                value,
                allowed,
            }),
            None => Ok(()),
        }
    }

    /// K as the warp uses it (out-of-range or NaN values fall back into [1, 1e4]).
    fn compression(&self) -> f64 {
        if self.max_compression >= 1.0 {
            self.max_compression.min(MAX_COMPRESSION_LIMIT)
        } else {
            1.0
        }
    }
}

/// I = min(Iv·Sf·Sb, Is) per cell (§3.1), `samples` row-major `cols`×`rows`. Values are the
/// paper's, unguarded (0 outside the frustum with the default settings): the guard belongs to
/// the warp, and [`quality`] measures against what was asked.
///
/// # Panics
/// If `samples.len() != cols * rows`.
pub fn importance(
    samples: &[ImportanceSample],
    cols: usize,
    rows: usize,
    settings: &WarpSettings,
) -> ImportanceMap {
    assert_eq!(samples.len(), cols * rows, "one sample per cell");
    let values = samples
        .iter()
        .map(|s| {
            let iv = if s.distance_m > 0.0 {
                settings.view_constant / s.distance_m
            } else {
                f64::INFINITY
            };
            let out = settings.outside_frustum_factor;
            let sf = out + (1.0 - out) * s.in_frustum.clamp(0.0, 1.0);
            let sb = if s.facing_cos >= 0.0 {
                1.0
            } else {
                let t = (1.0 + s.facing_cos / settings.backface_fade_cos).clamp(0.0, 1.0);
                let back = settings.backface_factor;
                back + (1.0 - back) * t * t * (3.0 - 2.0 * t)
            };
            let wanted = iv * sf * sb;
            // NaN-safe min: a NaN bound or product leaves the other.
            if wanted.is_nan() || s.surface_limit < wanted {
                s.surface_limit
            } else {
                wanted
            }
        })
        .collect();
    ImportanceMap { cols, rows, values }
}

/// The warped grid: (cols+1)×(rows+1) vertex positions in [0,1]², row-major (vertex (i, j) at
/// `vertices[j * (cols + 1) + i]`), boundary vertices exactly on the unit square's edges.
#[derive(Clone, Debug, PartialEq)]
pub struct WarpedGrid {
    pub cols: usize,
    pub rows: usize,
    pub vertices: Vec<DVec2>,
    /// Vertex columns of the low-resolution warp whose column pass the fold guard damped.
    pub damped_columns: usize,
}

impl WarpedGrid {
    pub fn vertex(&self, i: usize, j: usize) -> DVec2 {
        self.vertices[j * (self.cols + 1) + i]
    }

    /// Signed area of cell (i, j) (counter-clockwise positive: x right, y up).
    pub fn cell_area(&self, i: usize, j: usize) -> f64 {
        let p = [
            self.vertex(i, j),
            self.vertex(i + 1, j),
            self.vertex(i + 1, j + 1),
            self.vertex(i, j + 1),
        ];
        0.5 * (0..4).map(|k| p[k].perp_dot(p[(k + 1) % 4])).sum::<f64>()
    }
}

/// Two-pass warp (Fig. 5) of `map` with the default guard; see [`warp_with`].
pub fn warp(map: &ImportanceMap, out_cols: usize, out_rows: usize) -> WarpedGrid {
    warp_with(map, out_cols, out_rows, &WarpSettings::default())
}

/// Two-pass warp (Fig. 5): rows first, then columns, on the low-resolution map (with the guard
/// of `settings.max_compression`), then upsampled bilinearly in parameter space (§3.4) to
/// `out_cols`×`out_rows` cells. Bilinear upsampling keeps rows and columns strictly monotone and
/// convex quads convex, so the guard's guarantees carry over.
///
/// # Panics
/// If the map or the output grid is empty, or `map.values.len() != map.cols * map.rows`.
pub fn warp_with(
    map: &ImportanceMap,
    out_cols: usize,
    out_rows: usize,
    settings: &WarpSettings,
) -> WarpedGrid {
    let (cols, rows) = (map.cols, map.rows);
    assert!(
        cols > 0 && rows > 0 && out_cols > 0 && out_rows > 0,
        "empty grid"
    );
    assert_eq!(map.values.len(), cols * rows, "one value per cell");
    let k = settings.compression();
    let (low, damped_columns) = warp_low_res(&guarded(&map.values, k), cols, rows, k);
    let mut vertices = Vec::with_capacity((out_cols + 1) * (out_rows + 1));
    for b in 0..=out_rows {
        let (j, ft) = cell_of(b as f64 / out_rows as f64, rows);
        for a in 0..=out_cols {
            let (i, fs) = cell_of(a as f64 / out_cols as f64, cols);
            let at = |di: usize, dj: usize| low[(j + dj) * (cols + 1) + i + di];
            let bottom = at(0, 0) * (1.0 - fs) + at(1, 0) * fs;
            let top = at(0, 1) * (1.0 - fs) + at(1, 1) * fs;
            vertices.push(bottom * (1.0 - ft) + top * ft);
        }
    }
    pin_boundary(&mut vertices, out_cols, out_rows);
    WarpedGrid {
        cols: out_cols,
        rows: out_rows,
        vertices,
        damped_columns,
    }
}

/// The cell of `n` uniform cells holding u ∈ [0,1], and the fraction across it.
fn cell_of(u: f64, n: usize) -> (usize, f64) {
    let x = u * n as f64;
    let i = (x.floor() as usize).min(n - 1);
    (i, x - i as f64)
}

/// Puts the boundary vertices exactly on the square's edges (interpolation of 0s and 1s may
/// round by an ulp).
fn pin_boundary(v: &mut [DVec2], cols: usize, rows: usize) {
    for j in 0..=rows {
        v[j * (cols + 1)].x = 0.0;
        v[j * (cols + 1) + cols].x = 1.0;
    }
    for i in 0..=cols {
        v[i].y = 0.0;
        v[rows * (cols + 1) + i].y = 1.0;
    }
}

/// The map made safe for Fig. 5 (the guard): NaN and negatives → 0, everything scaled by the
/// largest finite value, +∞ → K (the limit of a huge value), then clamped into [max/K, max],
/// so each pass's running sum grows by ≥ max/K per cell (I_avg > 0) and no cell gets more than
/// K times its uniform share. An all-zero map becomes uniform.
fn guarded(values: &[f64], k: f64) -> Vec<f64> {
    let clean = |v: f64| if v > 0.0 { v } else { 0.0 };
    let top = values
        .iter()
        .map(|&v| clean(v))
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max);
    let scaled: Vec<f64> = values
        .iter()
        .map(|&v| match clean(v) {
            v if v.is_infinite() => k,
            v if top > 0.0 => v / top,
            _ => 0.0,
        })
        .collect();
    let max = scaled.iter().copied().fold(0.0, f64::max);
    if max == 0.0 {
        return vec![1.0; values.len()];
    }
    scaled.into_iter().map(|v| v.clamp(max / k, max)).collect()
}

/// One row (or column) of Fig. 5 on `w.len()` = n uniform cells of [0,1] (every w > 0): the
/// n+1 ends of the target cells, target cell k holding the k-th n-th of the running sum of
/// importance, and each target cell's mean importance (the distorted importance the next pass
/// reads). A target cell spans ≥ I_avg/(n·max w), so with the guard ≥ 1/(n·K).
fn warp_1d(w: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let n = w.len();
    let nf = n as f64;
    let total: f64 = w.iter().sum();
    let mut ends = Vec::with_capacity(n + 1);
    ends.push(0.0);
    let (mut i, mut below) = (0, 0.0);
    for k in 1..n {
        let level = total * k as f64 / nf;
        while i + 1 < n && below + w[i] <= level {
            below += w[i];
            i += 1;
        }
        let frac = ((level - below) / w[i]).clamp(0.0, 1.0);
        ends.push((i as f64 + frac) / nf);
    }
    ends.push(1.0);
    // ∫ I over a target cell is total/n² (I = w_i on a cell of width 1/n).
    let means = ends
        .windows(2)
        .map(|e| total / (nf * nf * (e[1] - e[0])))
        .collect();
    (ends, means)
}

/// The low-resolution warp: (cols+1)×(rows+1) vertices and the number of damped columns.
fn warp_low_res(w: &[f64], cols: usize, rows: usize, k: f64) -> (Vec<DVec2>, usize) {
    // Pass 1: x ends per cell row; the distorted importance per (row, target column).
    let (mut xs, mut distorted) = (Vec::with_capacity(rows), Vec::with_capacity(rows));
    for row in w.chunks(cols) {
        let (ends, means) = warp_1d(row);
        xs.push(ends);
        distorted.push(means);
    }
    // Pass 2: y ends per target column, on the distorted importance.
    let cell_ys: Vec<Vec<f64>> = (0..cols)
        .map(|c| warp_1d(&distorted.iter().map(|r| r[c]).collect::<Vec<_>>()).0)
        .collect();
    // A vertex column takes the mean of its two cell columns' ends.
    let ys: Vec<Vec<f64>> = (0..=cols)
        .map(|i| {
            let (a, b) = (&cell_ys[i.saturating_sub(1)], &cell_ys[i.min(cols - 1)]);
            a.iter().zip(b).map(|(a, b)| 0.5 * (a + b)).collect()
        })
        .collect();
    let mean_y: Vec<f64> = (0..=rows)
        .map(|l| ys.iter().map(|c| c[l]).sum::<f64>() / (cols + 1) as f64)
        .collect();
    // x of vertex column i at height y: pass 1's rows hold at their centres, linear between.
    let x_at = |i: usize, y: f64| {
        let (j, f) = cell_of((y - 0.5 / rows as f64).max(0.0), rows);
        if j + 1 >= rows {
            xs[rows - 1][i]
        } else {
            xs[j][i] * (1.0 - f) + xs[j + 1][i] * f
        }
    };
    let (min_gap, min_corner) = (
        0.5 / (cols as f64 * k),
        0.25 / ((cols * rows) as f64 * k * k),
    );
    let mut damping = vec![1.0f64; cols + 1];
    let mut grid = vec![DVec2::ZERO; (cols + 1) * (rows + 1)];
    for round in 0..=64 {
        if round == 64 {
            damping.fill(0.0); // the undamped-by-construction grid passes every check
        }
        for l in 0..=rows {
            for (i, &d) in damping.iter().enumerate() {
                let y = mean_y[l] + d * (ys[i][l] - mean_y[l]);
                grid[l * (cols + 1) + i] = DVec2::new(x_at(i, y), y);
            }
        }
        pin_boundary(&mut grid, cols, rows);
        let mut bad = vec![false; cols + 1];
        for l in 0..rows {
            for i in 0..cols {
                let at = |di: usize, dj: usize| grid[(l + dj) * (cols + 1) + i + di];
                let p = [at(0, 0), at(1, 0), at(1, 1), at(0, 1)];
                let thin = p[1].x - p[0].x < min_gap || p[2].x - p[3].x < min_gap;
                let concave = (0..4)
                    .any(|c| (p[(c + 1) % 4] - p[c]).perp_dot(p[(c + 3) % 4] - p[c]) < min_corner);
                if thin || concave {
                    bad[i] = true;
                    bad[i + 1] = true;
                }
            }
        }
        if !bad.contains(&true) {
            break;
        }
        for (d, _) in damping.iter_mut().zip(&bad).filter(|(_, b)| **b) {
            *d = if *d < 1e-6 { 0.0 } else { 0.5 * *d };
        }
    }
    (grid, damping.iter().filter(|&&d| d < 1.0).count())
}

/// How well a warped grid meets the importance (the paper's Fig. 6).
///
/// Per output cell c: the demanded share is the importance over the cell, I(centroid)·A_c,
/// divided by the mean of that over all cells (Σ I·A / N ≈ ∫ I / N: the grid's vertex budget
/// spread as the importance asks); the obtained share is one cell. The share ratio
/// ρ_c = N·I_c·A_c / Σ I·A is 1 where the cell got exactly its share of the vertices, < 1 where
/// it got more. The paper's band [0.5, 1] (obtained between 1× and 2× demanded) needs a
/// scale for the demand, which a scale-free importance does not fix: the ratio is σ·ρ with the
/// σ that puts the most cells into [0.5, 1]; `fraction_in_range` is thus the largest fraction
/// of cells whose shares lie within one factor of 2, and the band holds ρ ∈ [0.5/σ, 1/σ].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WarpQuality {
    pub fraction_in_range: f64,
    /// Extremes and median of σ·ρ over all cells (0 where nothing was asked, ∞ for ∞).
    pub min_ratio: f64,
    pub max_ratio: f64,
    pub median_ratio: f64,
    /// σ (1 when no cell asked for anything).
    pub share_scale: f64,
}

/// Demanded / obtained resolution per output cell of `grid` against `map` (see
/// [`WarpQuality`]). The demand is the map's value at the cell's centroid, unguarded (NaN and
/// negatives as 0).
pub fn quality(map: &ImportanceMap, grid: &WarpedGrid) -> WarpQuality {
    let mut demand = Vec::with_capacity(grid.cols * grid.rows);
    for j in 0..grid.rows {
        for i in 0..grid.cols {
            let c = (grid.vertex(i, j)
                + grid.vertex(i + 1, j)
                + grid.vertex(i + 1, j + 1)
                + grid.vertex(i, j + 1))
                * 0.25;
            let (ci, _) = cell_of(c.x.clamp(0.0, 1.0), map.cols);
            let (cj, _) = cell_of(c.y.clamp(0.0, 1.0), map.rows);
            let v = map.values[cj * map.cols + ci];
            let asked = if v > 0.0 { v } else { 0.0 };
            demand.push(asked * grid.cell_area(i, j).max(0.0));
        }
    }
    let n = demand.len() as f64;
    let total: f64 = demand.iter().filter(|d| d.is_finite()).sum();
    let mut shares: Vec<f64> = demand
        .iter()
        .map(|&d| match d {
            d if d.is_infinite() => f64::INFINITY,
            d if total > 0.0 => n * d / total,
            _ => 0.0,
        })
        .collect();
    shares.sort_by(f64::total_cmp);
    // Widest run of positive finite shares within a factor of 2 (two pointers over sorted).
    let (mut best, mut top, mut lo) = (0, f64::NAN, 0);
    for hi in 0..shares.len() {
        let s = shares[hi];
        if !(s > 0.0 && s.is_finite()) {
            continue;
        }
        while !(shares[lo] > 0.0) || shares[lo] < 0.5 * s * (1.0 - 1e-12) {
            lo += 1;
        }
        if hi + 1 - lo > best {
            (best, top) = (hi + 1 - lo, s);
        }
    }
    let sigma = if best > 0 { 1.0 / top } else { 1.0 };
    WarpQuality {
        fraction_in_range: best as f64 / n,
        min_ratio: sigma * shares[0],
        max_ratio: sigma * shares[shares.len() - 1],
        median_ratio: sigma * shares[shares.len() / 2],
        share_scale: sigma,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Finite, inside the square, boundary on its edges, rows and columns strictly monotone,
    /// and every cell at least the guard's area: the low-resolution quads' corners are
    /// ≥ 0.25/(c·r·K²) and a bilinear patch's Jacobian is smallest at a corner, so an output
    /// cell keeps ≥ 0.25/K² of the uniform cell's area.
    fn check_grid(g: &WarpedGrid, k: f64) {
        assert_eq!(g.vertices.len(), (g.cols + 1) * (g.rows + 1));
        for j in 0..=g.rows {
            for i in 0..=g.cols {
                let p = g.vertex(i, j);
                assert!(p.is_finite() && p.cmpge(DVec2::ZERO).all() && p.cmple(DVec2::ONE).all());
                assert_eq!(
                    (i == 0, i == g.cols),
                    (p.x == 0.0, p.x == 1.0),
                    "{i},{j}: {p}"
                );
                assert_eq!(
                    (j == 0, j == g.rows),
                    (p.y == 0.0, p.y == 1.0),
                    "{i},{j}: {p}"
                );
                if i > 0 {
                    assert!(p.x > g.vertex(i - 1, j).x, "row {j} folds at {i}");
                }
                if j > 0 {
                    assert!(p.y > g.vertex(i, j - 1).y, "column {i} folds at {j}");
                }
                if i < g.cols && j < g.rows {
                    let rel = g.cell_area(i, j) * (g.cols * g.rows) as f64;
                    assert!(rel >= 0.25 / (k * k), "cell {i},{j}: {rel} of uniform");
                }
            }
        }
    }

    fn map(cols: usize, rows: usize, values: Vec<f64>) -> ImportanceMap {
        ImportanceMap { cols, rows, values }
    }

    fn assert_uniform(g: &WarpedGrid) {
        for j in 0..=g.rows {
            for i in 0..=g.cols {
                let want = DVec2::new(i as f64 / g.cols as f64, j as f64 / g.rows as f64);
                assert!(
                    (g.vertex(i, j) - want).abs().max_element() < 1e-12,
                    "{i},{j}"
                );
            }
        }
    }

    /// Running share of importance `w` (uniform cells of [0,1]) below x: the forward map the
    /// warp must invert.
    fn running_share(w: &[f64], x: f64) -> f64 {
        let n = w.len() as f64;
        let below: f64 = w
            .iter()
            .enumerate()
            .map(|(i, v)| v * (x * n - i as f64).clamp(0.0, 1.0))
            .sum();
        below / w.iter().sum::<f64>()
    }

    #[test]
    fn uniform_importance_gives_uniform_grid() {
        let m = map(7, 5, vec![3.7; 35]);
        for (oc, or) in [(7, 5), (13, 11), (3, 2), (1, 1)] {
            let g = warp(&m, oc, or);
            assert_uniform(&g);
            assert_eq!(g.damped_columns, 0);
        }
    }

    #[test]
    fn one_dimensional_maps_invert_the_running_share() {
        // N×1 and 1×N: vertex k lies where the (guarded) importance's running share is k/N.
        // Zero cells count as max/K, ∞ as K·(largest finite) with the rest raised to ≥ 1/K of
        // it, and a huge value behaves as its limit ∞.
        let k = WarpSettings::default().max_compression;
        let cases: [(Vec<f64>, Vec<f64>); 4] = [
            (
                vec![1.0, 3.0, 0.5, 2.0, 8.0, 1.0],
                vec![1.0, 3.0, 0.5, 2.0, 8.0, 1.0],
            ),
            (
                vec![0.0, 0.0, 2.0, 2.0, f64::NAN, -1.0],
                vec![2.0 / k, 2.0 / k, 2.0, 2.0, 2.0 / k, 2.0 / k],
            ),
            (vec![1.0, f64::INFINITY, 0.5, 1.0], vec![1.0, k, 1.0, 1.0]),
            (vec![1.0, 1e300, 0.5, 1.0], vec![1.0, k, 1.0, 1.0]),
        ];
        for (values, guarded) in cases {
            let n = values.len();
            for transpose in [false, true] {
                let (c, r) = if transpose { (1, n) } else { (n, 1) };
                let g = warp(&map(c, r, values.clone()), c, r);
                check_grid(&g, k);
                for idx in 0..=n {
                    let p = if transpose {
                        g.vertex(0, idx)
                    } else {
                        g.vertex(idx, 0)
                    };
                    let (along, across) = if transpose { (p.y, p.x) } else { (p.x, p.y) };
                    assert!((running_share(&guarded, along) - idx as f64 / n as f64).abs() < 1e-12);
                    assert!(across == 0.0);
                }
                // Finer and coarser output: still monotone, and within one low-res span of the
                // exact inverse (interpolation stays between the knots it interpolates).
                let span = (0..n)
                    .map(|i| {
                        if transpose {
                            g.vertex(0, i + 1).y - g.vertex(0, i).y
                        } else {
                            g.vertex(i + 1, 0).x - g.vertex(i, 0).x
                        }
                    })
                    .fold(0.0, f64::max);
                for out in [2, 3, 5 * n + 1] {
                    let (oc, or) = if transpose { (1, out) } else { (out, 1) };
                    let h = warp(&map(c, r, values.clone()), oc, or);
                    check_grid(&h, k);
                    for a in 0..=out {
                        let p = if transpose {
                            h.vertex(0, a).y
                        } else {
                            h.vertex(a, 0).x
                        };
                        let s = a as f64 / out as f64;
                        let exact = (0..=100_000)
                            .map(|q| q as f64 / 1e5)
                            .find(|&x| running_share(&guarded, x) >= s - 1e-12)
                            .unwrap();
                        assert!((p - exact).abs() <= span + 1e-5, "{out}: {p} vs {exact}");
                    }
                }
            }
        }
    }

    #[test]
    fn degenerate_importance_gives_uniform_grid() {
        // I → 0, all zero, all NaN, all ∞, 1×1: I_avg would be 0 or ∞ in Fig. 5.
        for v in [1e-300, 5e-324, 0.0, f64::NAN, f64::INFINITY, -3.0, 1e300] {
            assert_uniform(&warp(&map(6, 4, vec![v; 24]), 9, 5));
            assert_uniform(&warp(&map(1, 1, vec![v]), 4, 3));
        }
    }

    #[test]
    fn fold_guard_damps_a_folding_map() {
        // The bottom rows want their vertices on the left, the top rows on the right, and
        // neighbouring columns disagree about where in y: undamped, the column pass moves
        // neighbouring vertices to heights where the row pass put very different x.
        let (c, r) = (8, 8);
        let values = (0..c * r)
            .map(|n| {
                let (i, j) = (n % c, n / c);
                let row = if (i < 2) == (j < 4) { 1000.0 } else { 1.0 };
                row * if i % 2 == 0 && j % 4 == 1 {
                    1000.0
                } else {
                    1.0
                }
            })
            .collect();
        let settings = WarpSettings {
            max_compression: 1e4,
            ..Default::default()
        };
        let g = warp_with(&map(c, r, values), 40, 40, &settings);
        assert!(g.damped_columns > 0);
        check_grid(&g, 1e4);
    }

    fn stiff_value() -> impl Strategy<Value = f64> {
        prop_oneof![
            4 => (-30.0..30.0f64).prop_map(|e| 10f64.powf(e)),
            1 => Just(0.0),
            1 => Just(f64::INFINITY),
            1 => Just(f64::NAN),
            1 => Just(-1.0),
            1 => Just(f64::MAX),
        ]
    }

    proptest! {
        #[test]
        fn random_stiff_maps_never_fold(
            (c, r, values) in (1usize..10, 1usize..10).prop_flat_map(|(c, r)| {
                (Just(c), Just(r), proptest::collection::vec(stiff_value(), c * r))
            }),
            oc in 1usize..30,
            or in 1usize..30,
            k in prop_oneof![Just(1.0), Just(4.0), Just(64.0), Just(1e4)],
        ) {
            let settings = WarpSettings { max_compression: k, ..Default::default() };
            check_grid(&warp_with(&map(c, r, values), oc, or, &settings), k);
        }
    }

    /// A camera 30 m above a plane looking 20° down (view 60°×80°), the projector's grid
    /// 1.5°–60° below the horizon and 100° wide: distance grows toward the horizon, the
    /// projector's margins lie outside the frustum, a back-facing slope patch (with a
    /// silhouette fade around it) and a smooth lake whose surface bound caps the importance.
    fn camera_samples(cols: usize, rows: usize) -> Vec<ImportanceSample> {
        let (h_m, pitch) = (30.0, 20f64.to_radians());
        let (half_v, half_h) = (30f64.to_radians(), 40f64.to_radians());
        let (dep_near, dep_far, width) =
            (60f64.to_radians(), 1.5f64.to_radians(), 100f64.to_radians());
        let (d_dep, d_az) = ((dep_near - dep_far) / rows as f64, width / cols as f64);
        let ramp = |x: f64| x.clamp(0.0, 1.0);
        let mut out = Vec::with_capacity(cols * rows);
        for j in 0..rows {
            for i in 0..cols {
                let (u, v) = (
                    (i as f64 + 0.5) / cols as f64,
                    (j as f64 + 0.5) / rows as f64,
                );
                let dep = dep_near + (dep_far - dep_near) * v;
                let az = (u - 0.5) * width;
                let ahead_m = h_m / dep.tan();
                let side_m = ahead_m * az.tan();
                let distance_m = (h_m * h_m + ahead_m * ahead_m + side_m * side_m).sqrt();
                let in_frustum = ramp((pitch + half_v - dep) / d_dep + 0.5)
                    * ramp((half_h - az.abs()) / d_az + 0.5);
                let in_patch =
                    |m: f64| (0.55 - m..0.7 + m).contains(&u) && (0.6 - m..0.75 + m).contains(&v);
                let facing_cos = if in_patch(0.0) {
                    -0.5
                } else if in_patch(1.5 / cols as f64) {
                    -0.1
                } else {
                    h_m / distance_m
                };
                let lake = u < 0.3 && (0.1..0.3).contains(&v);
                let surface_limit = if lake { 1.0 / 80.0 } else { f64::INFINITY };
                out.push(ImportanceSample {
                    distance_m,
                    in_frustum,
                    facing_cos,
                    surface_limit,
                });
            }
        }
        out
    }

    #[test]
    fn realistic_map_meets_the_demand() {
        let settings = WarpSettings {
            low_res_cols: 64,
            low_res_rows: 64,
            ..Default::default()
        };
        settings.validate().unwrap();
        let (c, r) = (settings.low_res_cols, settings.low_res_rows);
        let m = importance(&camera_samples(c, r), c, r, &settings);
        let g = warp_with(&m, 256, 256, &settings);
        check_grid(&g, settings.max_compression);
        let q = quality(&m, &g);
        let flat = quality(&m, &warp(&map(c, r, vec![1.0; c * r]), 256, 256));
        println!(
            "realistic map {c}×{r} → 256²: warped: {:.1} % of cells in [0.5, 1] (shares {:.3}–{:.3} of fair), ratio min {:.3} median {:.3} max {:.3}, {} damped columns; uniform grid: {:.1} %",
            100.0 * q.fraction_in_range,
            0.5 / q.share_scale,
            1.0 / q.share_scale,
            q.min_ratio,
            q.median_ratio,
            q.max_ratio,
            g.damped_columns,
            100.0 * flat.fraction_in_range,
        );
        assert!(q.fraction_in_range >= 0.9, "{q:?}");
        assert!(flat.fraction_in_range < 0.6, "{flat:?}");
        // The band sits around the fair share: the band [0.5, 1] holds shares within a factor
        // 2 that contain 1 (no hiding a starved grid behind the free scale).
        assert!(q.share_scale <= 1.0 && q.share_scale >= 0.5, "{q:?}");
    }

    #[test]
    fn importance_follows_the_paper() {
        let s = WarpSettings {
            view_constant: 10.0,
            backface_factor: 0.2,
            ..Default::default()
        };
        let at = |distance_m, in_frustum, facing_cos, surface_limit| {
            importance(
                &[ImportanceSample {
                    distance_m,
                    in_frustum,
                    facing_cos,
                    surface_limit,
                }],
                1,
                1,
                &s,
            )
            .values[0]
        };
        let inf = f64::INFINITY;
        assert_eq!(at(5.0, 1.0, 0.7, inf), 2.0); // Iv = C/d
        assert_eq!(at(5.0, 1.0, 0.0, inf), 2.0); // silhouette: Sb = 1
        assert_eq!(at(5.0, 0.0, 0.7, inf), 0.0); // outside: Sf = 0
        assert_eq!(at(5.0, 0.25, 0.7, inf), 0.5); // transition zone
        assert_eq!(at(5.0, 1.0, -0.25, inf), 0.4); // back-facing: Sb = 0.2
        assert!((at(5.0, 1.0, -0.125, inf) - 1.2).abs() < 1e-15); // halfway through the fade
        assert_eq!(at(5.0, 1.0, 0.7, 0.3), 0.3); // Is bounds it
        assert_eq!(at(0.0, 1.0, 0.7, 7.0), 7.0); // at the eye: Iv = ∞, Is bounds it
        assert_eq!(at(5.0, 1.0, 0.7, f64::NAN), 2.0);
    }

    #[test]
    fn settings_are_validated() {
        assert_eq!(WarpSettings::default().validate(), Ok(()));
        let bad = |s: WarpSettings| match s.validate() {
            Err(WarpSettingsError::Range { field, .. }) => field,
            other => panic!("{other:?}"),
        };
        let d = WarpSettings::default();
        assert_eq!(
            bad(WarpSettings {
                max_compression: 0.5,
                ..d
            }),
            "max_compression"
        );
        assert_eq!(
            bad(WarpSettings {
                max_compression: f64::NAN,
                ..d
            }),
            "max_compression"
        );
        assert_eq!(
            bad(WarpSettings {
                view_constant: 0.0,
                ..d
            }),
            "view_constant"
        );
        assert_eq!(
            bad(WarpSettings {
                backface_factor: 1.5,
                ..d
            }),
            "backface_factor"
        );
        assert_eq!(
            bad(WarpSettings {
                backface_fade_cos: 0.0,
                ..d
            }),
            "backface_fade_cos"
        );
        assert_eq!(
            bad(WarpSettings {
                outside_frustum_factor: -0.1,
                ..d
            }),
            "outside_frustum_factor"
        );
        assert!(matches!(
            WarpSettings {
                low_res_rows: 0,
                ..d
            }
            .validate(),
            Err(WarpSettingsError::EmptyMap { .. })
        ));
    }
}
