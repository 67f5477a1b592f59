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
//! - Guards (docs/design.md#numerics): importance is clamped into [max/K, max] (K =
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
    #[error("field `{field}` = {value} is outside [{min}, {max}]")]
    Range {
        field: &'static str,
        value: f64,
        min: f64,
        max: f64,
    },
}

impl WarpSettings {
    pub fn validate(&self) -> Result<(), WarpSettingsError> {
        let check = |field, value: f64, min, max| match (min..=max).contains(&value) {
            true => Ok(()),
            false => Err(WarpSettingsError::Range {
                field,
                value,
                min,
                max,
            }),
        };
        let tiny = f64::MIN_POSITIVE;
        check("low_res_cols", self.low_res_cols as f64, 1.0, f64::MAX)?;
        check("low_res_rows", self.low_res_rows as f64, 1.0, f64::MAX)?;
        check("view_constant", self.view_constant, tiny, f64::MAX)?;
        check(
            "outside_frustum_factor",
            self.outside_frustum_factor,
            0.0,
            1.0,
        )?;
        check("backface_factor", self.backface_factor, 0.0, 1.0)?;
        check("backface_fade_cos", self.backface_fade_cos, tiny, 1.0)?;
        check(
            "max_compression",
            self.max_compression,
            1.0,
            MAX_COMPRESSION_LIMIT,
        )
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

    /// The corners of cell (i, j), counter-clockwise (x right, y up).
    pub fn corners(&self, i: usize, j: usize) -> [DVec2; 4] {
        let v = |di, dj| self.vertex(i + di, j + dj);
        [v(0, 0), v(1, 0), v(1, 1), v(0, 1)]
    }

    /// Signed area of cell (i, j) (counter-clockwise positive).
    pub fn cell_area(&self, i: usize, j: usize) -> f64 {
        let p = self.corners(i, j);
        0.5 * (0..4).map(|k| p[k].perp_dot(p[(k + 1) % 4])).sum::<f64>()
    }

    /// Puts the boundary vertices exactly on the square's edges (interpolating 0s and 1s may
    /// round by an ulp).
    fn pin_boundary(&mut self) {
        let (cols, rows, v) = (self.cols, self.rows, &mut self.vertices);
        for j in 0..=rows {
            (v[j * (cols + 1)].x, v[j * (cols + 1) + cols].x) = (0.0, 1.0);
        }
        for i in 0..=cols {
            (v[i].y, v[rows * (cols + 1) + i].y) = (0.0, 1.0);
        }
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
    let k = match settings.max_compression {
        m if m >= 1.0 => m.min(MAX_COMPRESSION_LIMIT),
        _ => 1.0, // also NaN
    };
    let low = warp_low_res(&guarded(&map.values, k), cols, rows, k);
    let mut vertices = Vec::with_capacity((out_cols + 1) * (out_rows + 1));
    for b in 0..=out_rows {
        let (j, ft) = cell_of(b as f64 / out_rows as f64, rows);
        for a in 0..=out_cols {
            let (i, fs) = cell_of(a as f64 / out_cols as f64, cols);
            let [p00, p10, p11, p01] = low.corners(i, j);
            let (bottom, top) = (p00 * (1.0 - fs) + p10 * fs, p01 * (1.0 - fs) + p11 * fs);
            vertices.push(bottom * (1.0 - ft) + top * ft);
        }
    }
    let mut grid = WarpedGrid {
        cols: out_cols,
        rows: out_rows,
        vertices,
        ..low
    };
    grid.pin_boundary();
    grid
}

/// The cell of `n` uniform cells holding u ∈ [0,1], and the fraction across it.
fn cell_of(u: f64, n: usize) -> (usize, f64) {
    let x = u * n as f64;
    let i = (x.floor() as usize).min(n - 1);
    (i, x - i as f64)
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

/// The low-resolution warp of the guarded map `w`.
fn warp_low_res(w: &[f64], cols: usize, rows: usize, k: f64) -> WarpedGrid {
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
    let vertices = vec![DVec2::ZERO; (cols + 1) * (rows + 1)];
    let mut grid = WarpedGrid {
        cols,
        rows,
        vertices,
        damped_columns: 0,
    };
    for round in 0..=64 {
        if round == 64 {
            damping.fill(0.0); // the undamped-by-construction grid passes every check
        }
        for l in 0..=rows {
            for (i, &d) in damping.iter().enumerate() {
                let y = mean_y[l] + d * (ys[i][l] - mean_y[l]);
                grid.vertices[l * (cols + 1) + i] = DVec2::new(x_at(i, y), y);
            }
        }
        grid.pin_boundary();
        let mut bad = vec![false; cols + 1];
        for l in 0..rows {
            for i in 0..cols {
                let p = grid.corners(i, l);
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
    grid.damped_columns = damping.iter().filter(|&&d| d < 1.0).count();
    grid
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
            let c = grid.corners(i, j).iter().sum::<DVec2>() * 0.25;
            let (ci, _) = cell_of(c.x.clamp(0.0, 1.0), map.cols);
            let (cj, _) = cell_of(c.y.clamp(0.0, 1.0), map.rows);
            let v = map.values[cj * map.cols + ci];
            let area = grid.cell_area(i, j);
            demand.push(if v > 0.0 && area > 0.0 { v * area } else { 0.0 });
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
        while shares[lo] < 0.5 * s * (1.0 - 1e-12) {
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

    /// Finite, inside the square, boundary exactly on its edges, rows and columns strictly
    /// monotone, and every cell at least the guard's area: low-resolution corners are
    /// ≥ 0.25/(c·r·K²) and a bilinear patch's Jacobian is least at a corner, so an output cell
    /// keeps ≥ 0.25/K² of the uniform cell's area.
    fn check_grid(g: &WarpedGrid, k: f64) {
        assert_eq!(g.vertices.len(), (g.cols + 1) * (g.rows + 1));
        for j in 0..=g.rows {
            for i in 0..=g.cols {
                let p = g.vertex(i, j);
                assert!(p.is_finite() && p.cmpge(DVec2::ZERO).all() && p.cmple(DVec2::ONE).all());
                let edges = ((i == 0, i == g.cols), (j == 0, j == g.rows));
                let on = ((p.x == 0.0, p.x == 1.0), (p.y == 0.0, p.y == 1.0));
                assert_eq!(edges, on, "{i},{j}: {p}");
                assert!(i == 0 || p.x > g.vertex(i - 1, j).x, "row {j} folds at {i}");
                assert!(
                    j == 0 || p.y > g.vertex(i, j - 1).y,
                    "col. {i} folds at {j}"
                );
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

    fn with_k(k: f64) -> WarpSettings {
        WarpSettings {
            max_compression: k,
            ..Default::default()
        }
    }

    /// The share of importance `w` (uniform cells of [0,1]) below x: what the warp inverts.
    fn running_share(w: &[f64], x: f64) -> f64 {
        let n = w.len() as f64;
        let cell = |(i, v): (usize, &f64)| v * (x * n - i as f64).clamp(0.0, 1.0);
        w.iter().enumerate().map(cell).sum::<f64>() / w.iter().sum::<f64>()
    }

    #[test]
    fn uniform_or_degenerate_importance_gives_uniform_grid() {
        // I → 0, 0, NaN, ∞, negative, huge everywhere, 1×1: I_avg 0, ∞ or NaN in Fig. 5.
        let stiff = [1e-300, 5e-324, 0.0, f64::NAN].into_iter();
        for v in stiff.chain([f64::INFINITY, -3.0, 1e300, 3.7]) {
            let sizes = [(7, 5, 7, 5), (7, 5, 13, 11), (6, 4, 3, 2), (1, 1, 4, 3)];
            for (c, r, oc, or) in sizes {
                let g = warp(&map(c, r, vec![v; c * r]), oc, or);
                assert_eq!(g.damped_columns, 0);
                for (n, p) in g.vertices.iter().enumerate() {
                    let (i, j) = ((n % (oc + 1)) as f64, (n / (oc + 1)) as f64);
                    let want = DVec2::new(i / oc as f64, j / or as f64);
                    assert!((*p - want).abs().max_element() < 1e-12, "{v}: {p}");
                }
            }
        }
    }

    /// Warp of the 1-row map `values` (or its 1-column transpose) to `out` cells: each vertex
    /// as (along, across).
    fn warp_line(values: &[f64], transpose: bool, out: usize) -> Vec<DVec2> {
        let swap = |(a, b)| if transpose { (b, a) } else { (a, b) };
        let ((c, r), (oc, or)) = (swap((values.len(), 1)), swap((out, 1)));
        let g = warp(&map(c, r, values.to_vec()), oc, or);
        check_grid(&g, WarpSettings::default().max_compression);
        let at = |(i, j)| g.vertex(i, j);
        let along = |p: DVec2| if transpose { DVec2::new(p.y, p.x) } else { p };
        (0..=out).map(|a| along(at(swap((a, 0))))).collect()
    }

    #[test]
    fn one_dimensional_maps_invert_the_running_share() {
        // N×1 and 1×N: vertex k lies where the guarded importance's running share is k/N.
        // Zero, NaN and negative cells count as max/K; ∞ as K·(largest finite), the rest raised
        // to ≥ 1/K of it; a huge value as its limit ∞.
        let (k, inf) = (WarpSettings::default().max_compression, f64::INFINITY);
        let cases = [
            (
                vec![1.0, 3.0, 0.5, 2.0, 8.0, 1.0],
                vec![1.0, 3.0, 0.5, 2.0, 8.0, 1.0],
            ),
            (
                vec![0.0, 0.0, 2.0, 2.0, f64::NAN, -1.0],
                vec![2.0 / k, 2.0 / k, 2.0, 2.0, 2.0 / k, 2.0 / k],
            ),
            (vec![1.0, inf, 0.5, 1.0], vec![1.0, k, 1.0, 1.0]),
            (vec![1.0, 1e300, 0.5, 1.0], vec![1.0, k, 1.0, 1.0]),
        ];
        for ((values, guarded), transpose) in cases.iter().flat_map(|c| [(c, false), (c, true)]) {
            let n = values.len();
            let knots = warp_line(values, transpose, n);
            for (a, p) in knots.iter().enumerate() {
                assert!((running_share(guarded, p.x) - a as f64 / n as f64).abs() < 1e-12);
                assert_eq!(p.y, 0.0);
            }
            // Coarser and finer output: within one low-resolution span of the exact inverse
            // (interpolation stays between the knots it interpolates).
            let span = knots
                .windows(2)
                .map(|w| w[1].x - w[0].x)
                .fold(0.0, f64::max);
            for out in [2, 3, 5 * n + 1] {
                for (a, p) in warp_line(values, transpose, out).iter().enumerate() {
                    let (mut lo, mut hi) = (0.0, 1.0);
                    for _ in 0..60 {
                        let mid = 0.5 * (lo + hi);
                        if running_share(guarded, mid) < a as f64 / out as f64 {
                            lo = mid;
                        } else {
                            hi = mid;
                        }
                    }
                    assert!((p.x - lo).abs() <= span + 1e-12, "{out}: {} vs {lo}", p.x);
                }
            }
        }
    }

    #[test]
    fn fold_guard_damps_a_folding_map() {
        // Bottom rows want their vertices left, top rows right, and neighbouring columns
        // disagree about heights: undamped, the column pass moves neighbouring vertices to
        // heights where the row pass put very different x (this map folds without the guard).
        let values = (0..64)
            .map(|n| {
                let (i, j) = (n % 8, n / 8);
                let row = [1.0, 1000.0][((i < 2) == (j < 4)) as usize];
                row * [1.0, 1000.0][(i % 2 == 0 && j % 4 == 1) as usize]
            })
            .collect();
        let g = warp_with(&map(8, 8, values), 40, 40, &with_k(1e4));
        assert!(g.damped_columns > 0);
        check_grid(&g, 1e4);
    }

    fn stiff_value() -> impl Strategy<Value = f64> {
        prop_oneof![
            4 => (-30.0..30.0f64).prop_map(|e| 10f64.powf(e)),
            1 => prop_oneof![Just(0.0), Just(f64::INFINITY), Just(f64::NAN), Just(-1.0)],
            1 => Just(f64::MAX),
        ]
    }

    proptest! {
        #[test]
        fn random_stiff_maps_never_fold(
            (c, r, values) in (1usize..10, 1usize..10).prop_flat_map(|(c, r)| {
                (Just(c), Just(r), proptest::collection::vec(stiff_value(), c * r))
            }),
            (oc, or) in (1usize..30, 1usize..30),
            k in prop_oneof![Just(1.0), Just(4.0), Just(64.0), Just(1e4)],
        ) {
            check_grid(&warp_with(&map(c, r, values), oc, or, &with_k(k)), k);
        }
    }

    fn sample(
        distance_m: f64,
        in_frustum: f64,
        facing_cos: f64,
        surface_limit: f64,
    ) -> ImportanceSample {
        ImportanceSample {
            distance_m,
            in_frustum,
            facing_cos,
            surface_limit,
        }
    }

    /// A camera 30 m above a plane looking 20° down (view 60° high, 80° wide), the projector's
    /// grid 60°–1.5° below the horizon and 100° wide: distance grows toward the horizon, the
    /// grid's margins lie outside the frustum (partial cells at its edges), a back-facing slope
    /// patch with a silhouette fade around it, and a smooth lake whose Is caps the importance.
    fn camera_samples(cols: usize, rows: usize) -> Vec<ImportanceSample> {
        let (h_m, deg) = (30.0, 1f64.to_radians());
        let (near, far, width) = (60.0 * deg, 1.5 * deg, 100.0 * deg);
        let (d_dep, d_az) = ((near - far) / rows as f64, width / cols as f64);
        let mut out = Vec::with_capacity(cols * rows);
        for j in 0..rows {
            for i in 0..cols {
                let (u, v) = (
                    (i as f64 + 0.5) / cols as f64,
                    (j as f64 + 0.5) / rows as f64,
                );
                let (dep, az) = (near + (far - near) * v, (u - 0.5) * width);
                let ahead_m = h_m / dep.tan();
                let distance_m = h_m.hypot(ahead_m).hypot(ahead_m * az.tan());
                let in_frustum = ((50.0 * deg - dep) / d_dep + 0.5).clamp(0.0, 1.0)
                    * ((40.0 * deg - az.abs()) / d_az + 0.5).clamp(0.0, 1.0);
                let patch =
                    |m: f64| (0.55 - m..0.7 + m).contains(&u) && (0.6 - m..0.75 + m).contains(&v);
                let facing_cos = match (patch(0.0), patch(1.5 / cols as f64)) {
                    (true, _) => -0.5,
                    (_, true) => -0.1,
                    _ => h_m / distance_m,
                };
                let lake = u < 0.3 && (0.1..0.3).contains(&v);
                let surface_limit = if lake { 1.0 / 80.0 } else { f64::INFINITY };
                out.push(sample(distance_m, in_frustum, facing_cos, surface_limit));
            }
        }
        out
    }

    #[test]
    fn realistic_map_meets_the_demand() {
        for (n, out) in [(64, 256), (128, 512)] {
            let settings = WarpSettings {
                low_res_cols: n,
                low_res_rows: n,
                ..Default::default()
            };
            settings.validate().unwrap();
            let m = importance(&camera_samples(n, n), n, n, &settings);
            let g = warp_with(&m, out, out, &settings);
            check_grid(&g, settings.max_compression);
            let q = quality(&m, &g);
            let flat = quality(&m, &warp(&map(n, n, vec![1.0; n * n]), out, out));
            println!(
                "camera map {n}² → {out}²: {:.1} % of cells in [0.5, 1] (uniform grid {:.1} %), \
                 shares {:.3}–{:.3} of fair in the band, {} of {} columns damped; {q:?}",
                100.0 * q.fraction_in_range,
                100.0 * flat.fraction_in_range,
                0.5 / q.share_scale,
                1.0 / q.share_scale,
                g.damped_columns,
                n + 1,
            );
            assert!(q.fraction_in_range >= 0.9, "{q:?}");
            assert!(flat.fraction_in_range < 0.6, "{flat:?}");
            // The band holds the fair share (1): the free scale hides no starved grid.
            assert!((0.5..=1.0).contains(&q.share_scale), "{q:?}");
        }
    }

    #[test]
    fn importance_follows_the_paper() {
        let s = WarpSettings {
            view_constant: 10.0,
            backface_factor: 0.2,
            ..Default::default()
        };
        let at = |d, f, c, l| importance(&[sample(d, f, c, l)], 1, 1, &s).values[0];
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
        let field = |edit: fn(&mut WarpSettings)| {
            let mut s = WarpSettings::default();
            edit(&mut s);
            match s.validate() {
                Err(WarpSettingsError::Range { field, .. }) => field,
                other => panic!("{other:?}"),
            }
        };
        assert_eq!(field(|s| s.max_compression = 0.5), "max_compression");
        assert_eq!(field(|s| s.max_compression = f64::NAN), "max_compression");
        assert_eq!(field(|s| s.view_constant = 0.0), "view_constant");
        assert_eq!(field(|s| s.backface_factor = 1.5), "backface_factor");
        assert_eq!(field(|s| s.backface_fade_cos = 0.0), "backface_fade_cos");
        let outside = field(|s| s.outside_frustum_factor = -0.1);
        assert_eq!(outside, "outside_frustum_factor");
        assert_eq!(field(|s| s.low_res_rows = 0), "low_res_rows");
    }
}
