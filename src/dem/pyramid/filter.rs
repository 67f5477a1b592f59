//! The two filters of the builder, both streaming row by row:
//!
//! * [`Level0`]: the source rows as they are (avg) and the min/max of each pixel's 3 × 3
//!   neighbourhood — the bilinear surface over a pixel's footprint is a convex combination of
//!   those nine centres, so min/max bound the interpolated terrain, not just the samples.
//! * [`Downsampler`]: level L+1 from level L with the area-weighted, isotropically widened box
//!   kernel described in the module documentation of [`crate::dem::pyramid`].
//!
//! Rows travel as exact `f32` values; quantisation happens only when a row is stored, so
//! rounding never accumulates from level to level.

use std::collections::VecDeque;

use super::format::{Extents, LevelGeom, ceil_i64, floor_i64};

/// One row of a level, unquantised: the filtered height and conservative bounds, metres.
#[derive(Clone, Debug, Default)]
pub(crate) struct Row {
    pub avg: Vec<f32>,
    pub min: Vec<f32>,
    pub max: Vec<f32>,
}

/// Horizontal 3-wide min and max of `v` (wrapping or clamped at the ends).
fn horizontal3(v: &[f32], wraps: bool) -> (Vec<f32>, Vec<f32>) {
    let n = v.len();
    let mut mn = Vec::with_capacity(n);
    let mut mx = Vec::with_capacity(n);
    for j in 0..n {
        let l = match j {
            0 if wraps => n - 1,
            0 => 0,
            _ => j - 1,
        };
        let r = match j + 1 {
            k if k < n => k,
            _ if wraps => 0,
            _ => n - 1,
        };
        mn.push(v[l].min(v[j]).min(v[r]));
        mx.push(v[l].max(v[j]).max(v[r]));
    }
    (mn, mx)
}

/// Level 0: turns source rows into pyramid rows once the row below has arrived.
pub(crate) struct Level0 {
    wraps: bool,
    /// The last (up to) two rows: values and their horizontal 3-min/max.
    window: VecDeque<(Vec<f32>, Vec<f32>, Vec<f32>)>,
    /// Rows pushed so far.
    pushed: usize,
}

impl Level0 {
    pub fn new(wraps: bool) -> Self {
        Self {
            wraps,
            window: VecDeque::with_capacity(3),
            pushed: 0,
        }
    }

    /// Takes source row `pushed` (already cleaned of NaN); returns the previous row, complete.
    pub fn push(&mut self, values: Vec<f32>) -> Option<Row> {
        let (hmin, hmax) = horizontal3(&values, self.wraps);
        self.window.push_back((values, hmin, hmax));
        self.pushed += 1;
        match self.window.len() {
            // Row 0 waits for row 1.
            1 => None,
            2 if self.pushed == 2 => Some(self.emit(0, 1)),
            _ => {
                let row = self.emit(1, 2);
                self.window.pop_front();
                Some(row)
            }
        }
    }

    /// After the last source row: the last row, with only the row above as a neighbour.
    pub fn finish(&mut self) -> Option<Row> {
        let n = self.window.len();
        (n > 0).then(|| self.emit(n - 1, n - 1))
    }

    /// Row `centre` of the window, neighbours from `centre − 1` (if any) to `below`.
    fn emit(&self, centre: usize, below: usize) -> Row {
        let lo = centre.saturating_sub(1);
        let avg = self.window[centre].0.clone();
        let mut min = self.window[lo].1.clone();
        let mut max = self.window[lo].2.clone();
        for k in lo + 1..=below {
            let (_, hmin, hmax) = &self.window[k];
            for (m, &h) in min.iter_mut().zip(hmin) {
                *m = m.min(h);
            }
            for (m, &h) in max.iter_mut().zip(hmax) {
                *m = m.max(h);
            }
        }
        Row { avg, min, max }
    }
}

/// A coarse row being accumulated.
struct Acc {
    row: usize,
    num: Vec<f64>,
    den: Vec<f64>,
    min: Vec<f32>,
    max: Vec<f32>,
}

/// Builds level L+1 (coarse) from the rows of level L (fine), row by row.
pub(crate) struct Downsampler {
    fine: LevelGeom,
    coarse: LevelGeom,
    ext: Extents,
    wraps: bool,
    pending: VecDeque<Acc>,
    /// Per coarse column, for the current fine row: ∫avg dlon (fine-pixel units), the window
    /// length, min and max.
    sum: Vec<f64>,
    len: Vec<f64>,
    min: Vec<f32>,
    max: Vec<f32>,
    prefix: Vec<f64>,
    dq_min: VecDeque<isize>,
    dq_max: VecDeque<isize>,
    /// Statistics: longitude passes (one per fine row and coarse row it overlaps) whose window
    /// was widened beyond the footprint, and widened to the full row.
    pub widened_passes: usize,
    pub full_circle_passes: usize,
}

impl Downsampler {
    pub fn new(fine: LevelGeom, coarse: LevelGeom, ext: Extents, wraps: bool) -> Self {
        let m = coarse.cols;
        Self {
            fine,
            coarse,
            ext,
            wraps,
            pending: VecDeque::with_capacity(3),
            sum: vec![0.0; m],
            len: vec![0.0; m],
            min: vec![0.0; m],
            max: vec![0.0; m],
            prefix: Vec::with_capacity(fine.cols + 1),
            dq_min: VecDeque::new(),
            dq_max: VecDeque::new(),
            widened_passes: 0,
            full_circle_passes: 0,
        }
    }

    /// Bytes this stage holds (for the memory bound).
    pub fn buffer_bytes(&self) -> usize {
        let m = self.coarse.cols;
        // sum, len (f64), min, max (f32), prefix (f64), and up to two pending rows.
        m * (8 + 8 + 4 + 4) + (self.fine.cols + 1) * 8 + 2 * m * (8 + 8 + 4 + 4)
    }

    /// Latitude of a fine-row boundary given in units of 1/(rows_f·rows_c) of the extent.
    fn lat_at(&self, units: usize) -> f64 {
        let denom = (self.fine.rows * self.coarse.rows) as f64;
        let h = self.ext.north_deg - self.ext.south_deg;
        (self.ext.north_deg - units as f64 / denom * h).clamp(-90.0, 90.0)
    }

    /// The mean of cos(latitude) over coarse row `cr`'s footprint (its part on the sphere):
    /// (sin top − sin bottom) / (top − bottom). Zero only for a degenerate footprint.
    fn mean_cos(&self, cr: usize) -> f64 {
        let g = &self.coarse.grid;
        let top = (g.lat0_deg + 0.5 * g.dlat_deg - cr as f64 * g.dlat_deg).clamp(-90.0, 90.0);
        let bottom = (top - g.dlat_deg).clamp(-90.0, 90.0);
        let d = (top - bottom).to_radians();
        if d <= 0.0 {
            0.0
        } else {
            (top.to_radians().sin() - bottom.to_radians().sin()) / d
        }
    }

    /// Pushes fine row `r` (rows must come in order 0, 1, …); completed coarse rows are
    /// appended to `out` as (coarse row, row).
    pub fn push(&mut self, r: usize, row: &Row, out: &mut Vec<(usize, Row)>) {
        self.prefix.resize(row.avg.len() + 1, 0.0);
        let mut total = 0.0f64;
        for (p, &v) in self.prefix[1..].iter_mut().zip(&row.avg) {
            total += v as f64;
            *p = total;
        }
        let nr = self.fine.rows;
        let mr = self.coarse.rows;
        // Coarse rows overlapping fine row r, in exact integer units of 1/(nr·mr) of the extent.
        let r_lo = r * mr / nr;
        let r_hi = ((r + 1) * mr).div_ceil(nr) - 1;
        for cr in r_lo..=r_hi.min(mr - 1) {
            let top = (r * mr).max(cr * nr);
            let bottom = ((r + 1) * mr).min((cr + 1) * nr);
            if bottom <= top {
                continue;
            }
            // Area of the overlap band per radian of longitude: Δ sin(latitude).
            let w = self.lat_at(top).to_radians().sin() - self.lat_at(bottom).to_radians().sin();
            self.longitude_pass(cr, row);
            let pos = self.acc_for(cr);
            let acc = &mut self.pending[pos];
            for ((num, den), (&s, &l)) in acc
                .num
                .iter_mut()
                .zip(&mut acc.den)
                .zip(self.sum.iter().zip(&self.len))
            {
                *num += w * s;
                *den += w * l;
            }
            for ((lo, hi), (&l, &h)) in acc
                .min
                .iter_mut()
                .zip(&mut acc.max)
                .zip(self.min.iter().zip(&self.max))
            {
                *lo = lo.min(l);
                *hi = hi.max(h);
            }
        }
        // Emit the coarse rows whose last overlapping fine row is r.
        while let Some(front) = self.pending.front() {
            let last_fine = ((front.row + 1) * nr).div_ceil(mr) - 1;
            if last_fine > r {
                break;
            }
            let acc = self.pending.pop_front().expect("front exists");
            out.push((acc.row, finish(acc)));
        }
    }

    /// Position in `pending` of the accumulator of coarse row `cr` (created if new).
    fn acc_for(&mut self, cr: usize) -> usize {
        match self.pending.iter().position(|a| a.row == cr) {
            Some(p) => p,
            None => {
                let m = self.coarse.cols;
                self.pending.push_back(Acc {
                    row: cr,
                    num: vec![0.0; m],
                    den: vec![0.0; m],
                    min: vec![f32::INFINITY; m],
                    max: vec![f32::NEG_INFINITY; m],
                });
                self.pending.len() - 1
            }
        }
    }

    /// For every coarse column of coarse row `cr`: the integral of `row.avg` over the column's
    /// longitude window (in fine-pixel units, pixels as constant cells), the window's length,
    /// and min/max over the fine pixels that overlap the window with positive length. Needs
    /// `self.prefix` of this row.
    fn longitude_pass(&mut self, cr: usize, row: &Row) {
        let n = self.fine.cols;
        let m = self.coarse.cols;
        // Isotropic width: the coarse row's latitude spacing measured on the ground, as
        // longitude at the row's mean cos(latitude).
        let cbar = self.mean_cos(cr);
        let width_deg = if cbar > 0.0 {
            self.coarse.grid.dlat_deg / cbar
        } else {
            f64::INFINITY
        };
        let footprint_u = n as f64 / m as f64;
        let width_u = width_deg / self.fine.grid.dlon_deg;
        if width_u <= footprint_u {
            // The plain footprint: fine columns ⌊C·n/m⌋ … ⌈(C+1)·n/m⌉ − 1, exact integers.
            for c in 0..m {
                let j_lo = c * n / m;
                let j_hi = ((c + 1) * n).div_ceil(m) - 1;
                let (a, b) = ((c * n) as f64 / m as f64, ((c + 1) * n) as f64 / m as f64);
                self.sum[c] = cumulative(&self.prefix, row, b) - cumulative(&self.prefix, row, a);
                self.len[c] = b - a;
                let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
                for j in j_lo..=j_hi.min(n - 1) {
                    lo = lo.min(row.min[j]);
                    hi = hi.max(row.max[j]);
                }
                self.min[c] = lo;
                self.max[c] = hi;
            }
            return;
        }
        self.widened_passes += 1;
        if width_u >= n as f64 {
            // Capped at the full circle (or the full row of a regional grid).
            self.full_circle_passes += 1;
            let total = self.prefix[n];
            let lo = row.min.iter().copied().fold(f32::INFINITY, f32::min);
            let hi = row.max.iter().copied().fold(f32::NEG_INFINITY, f32::max);
            self.sum.fill(total);
            self.len.fill(n as f64);
            self.min.fill(lo);
            self.max.fill(hi);
            return;
        }
        // Widened: a window of width_u fine pixels centred on each coarse centre. Min/max by a
        // direct scan for narrow windows, else with two monotone deques, over (for wrapping
        // grids, extended) column indices.
        let (dq_min, dq_max) = (&mut self.dq_min, &mut self.dq_max);
        dq_min.clear();
        dq_max.clear();
        let mut next: isize = isize::MIN;
        // Windows are narrower than the row, so an extended index lies in [−n, 2n).
        let ni = n as isize;
        let at = |j: isize| {
            (if j < 0 {
                j + ni
            } else if j >= ni {
                j - ni
            } else {
                j
            }) as usize
        };
        let direct = width_u <= 14.0;
        for c in 0..m {
            let centre = (c as f64 + 0.5) * footprint_u;
            let (mut a, mut b) = (centre - 0.5 * width_u, centre + 0.5 * width_u);
            if !self.wraps {
                a = a.max(0.0);
                b = b.min(n as f64);
            }
            self.sum[c] = cumulative(&self.prefix, row, b) - cumulative(&self.prefix, row, a);
            self.len[c] = b - a;
            let j_lo = floor_i64(a) as isize;
            let j_hi = ceil_i64(b) as isize - 1;
            if direct {
                let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
                if j_lo >= 0 && j_hi < ni {
                    let range = j_lo as usize..=j_hi as usize;
                    for (&l, &h) in row.min[range.clone()].iter().zip(&row.max[range]) {
                        lo = lo.min(l);
                        hi = hi.max(h);
                    }
                } else {
                    for j in j_lo..=j_hi {
                        lo = lo.min(row.min[at(j)]);
                        hi = hi.max(row.max[at(j)]);
                    }
                }
                self.min[c] = lo;
                self.max[c] = hi;
                continue;
            }
            if next == isize::MIN {
                next = j_lo;
            }
            while next <= j_hi {
                let v = row.min[at(next)];
                while dq_min.back().is_some_and(|&k| row.min[at(k)] >= v) {
                    dq_min.pop_back();
                }
                dq_min.push_back(next);
                let v = row.max[at(next)];
                while dq_max.back().is_some_and(|&k| row.max[at(k)] <= v) {
                    dq_max.pop_back();
                }
                dq_max.push_back(next);
                next += 1;
            }
            while dq_min.front().is_some_and(|&k| k < j_lo) {
                dq_min.pop_front();
            }
            while dq_max.front().is_some_and(|&k| k < j_lo) {
                dq_max.pop_front();
            }
            self.min[c] = row.min[at(*dq_min.front().expect("window is not empty"))];
            self.max[c] = row.max[at(*dq_max.front().expect("window is not empty"))];
        }
    }
}

/// ∫ of the piecewise-constant row from 0 to `u` (fine-pixel units, pixel j on [j, j+1]),
/// given its prefix sums; for wrapping grids `u` may lie outside [0, n] (whole turns add the
/// row's total).
fn cumulative(prefix: &[f64], row: &Row, u: f64) -> f64 {
    let n = row.avg.len();
    let nf = n as f64;
    let (mut v, mut turns) = (u, 0.0);
    while v < 0.0 {
        v += nf;
        turns -= 1.0;
    }
    while v >= nf {
        v -= nf;
        turns += 1.0;
    }
    let k = (v as usize).min(n - 1);
    let within = prefix[k] + (v - k as f64) * row.avg[k] as f64;
    turns * prefix[n] + within
}

fn finish(acc: Acc) -> Row {
    let mut avg = Vec::with_capacity(acc.num.len());
    for c in 0..acc.num.len() {
        let a = if acc.den[c] > 0.0 {
            (acc.num[c] / acc.den[c]) as f32
        } else {
            0.5 * (acc.min[c] + acc.max[c])
        };
        // A weighted mean lies within the bounds; the clamp only absorbs f32 rounding.
        avg.push(a.clamp(acc.min[c], acc.max[c]));
    }
    Row {
        avg,
        min: acc.min,
        max: acc.max,
    }
}
