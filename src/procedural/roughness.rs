//! The data's local relief, the amplitude the detail is tied to (issue: "local roughness from
//! the pyramid"): a global grid of max − min of the terrain over each cell, from the DEM
//! pyramid's min/max planes (or the analytic planet's bounds), sampled bilinearly so the
//! amplitude, and with it the detail, is continuous everywhere.
//!
//! The grid's outermost rows hold their own mean, so the relief has one value at each pole.
//! The same f32 values go to the GPU (the fill reads them with the same bilinear rule).
//!
//! The editor paints on this map (infinite-landscapes-projected-grid.md §3: the base shape is
//! sketched, not only computed): a [`ReliefDab`] multiplies the relief of the cells under it,
//! so the detail's amplitude there follows (`Detail::amplitude_for_relief_m`).

use std::f64::consts::{PI, TAU};

use glam::DVec3;
use serde::{Deserialize, Serialize};

use crate::geo::sphere;

/// One dab of the relief brush: the cells whose centres lie within `radius_deg` (arc) of
/// (`lat_deg`, `lon_deg`) get their relief × `factor`^w, w = (1 − (d/r)²)² (1 at the centre,
/// fading smoothly to 0 at the edge).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReliefDab {
    pub lat_deg: f64,
    pub lon_deg: f64,
    pub radius_deg: f64,
    /// > 1 raises the relief (rougher detail), < 1 lowers it.
    pub factor: f64,
}

impl ReliefDab {
    /// Allowed brush radius, degrees of arc: at least a fifth of a default cell, at most a
    /// hemisphere's half.
    pub const RADIUS_DEG: (f64, f64) = (0.1, 45.0);
    /// Allowed factor per dab (0 flattens the relief; 10 is a decade per dab).
    pub const FACTOR: (f64, f64) = (0.0, 10.0);

    /// The first field outside its range: (field, value, allowed).
    pub fn out_of_range(&self) -> Option<(&'static str, f64, String)> {
        let checks = [
            ("relief_paint.lat_deg", self.lat_deg, (-90.0, 90.0)),
            ("relief_paint.lon_deg", self.lon_deg, (-360.0, 360.0)),
            ("relief_paint.radius_deg", self.radius_deg, Self::RADIUS_DEG),
            ("relief_paint.factor", self.factor, Self::FACTOR),
        ];
        checks
            .into_iter()
            .find(|(_, v, (lo, hi))| !(lo <= v && v <= hi))
            .map(|(field, v, (lo, hi))| (field, v, format!("[{lo}, {hi}]")))
    }
}

/// Relief per cell, rows north to south, columns from φ = 0 eastward.
#[derive(Clone, Debug, PartialEq)]
pub struct RoughnessMap {
    pub cols: u32,
    pub rows: u32,
    /// max − min of the terrain within each cell, metres.
    pub values: Vec<f32>,
    /// Largest |∇relief| (metres per metre) between row r and r + 1, for each r (the slope
    /// bound of the amplitude; rows near the poles are narrow east–west).
    row_slope: Vec<f64>,
    /// Lowest and highest relief of each row (a cap reaching a pole spans whole rows).
    row_range: Vec<(f64, f64)>,
    radius_m: f64,
}

impl RoughnessMap {
    /// Cell size of the default map: 0.5° (≈ 55 km): relief at the scale of a mountain range.
    pub const DEFAULT_CELL_DEG: f64 = 0.5;

    /// Relief over `cols × rows` cells (`rows = cols / 2`) from `bounds(u, angle)`, the lowest
    /// and highest terrain within `angle` of `u` (the pyramid's min/max planes for a DEM).
    pub fn of_bounds(cols: u32, radius_m: f64, bounds: impl Fn(DVec3, f64) -> (f64, f64)) -> Self {
        let rows = (cols / 2).max(2);
        let dphi = TAU / cols as f64;
        let dtheta = PI / rows as f64;
        let mut values = vec![0f32; (cols * rows) as usize];
        for r in 0..rows {
            let theta = (r as f64 + 0.5) * dtheta;
            for c in 0..cols {
                let phi = (c as f64 + 0.5) * dphi;
                let u = sphere::unit_vector(phi, theta);
                // A cap reaching the cell's corners at the equator (half a cell diagonal).
                let (lo, hi) = bounds(u, 0.75 * dtheta);
                values[(r * cols + c) as usize] = (hi - lo).max(0.0) as f32;
            }
        }
        Self::from_values(cols, rows, values, radius_m)
    }

    /// A map of given values (rows north to south); the outermost rows are set to their mean.
    pub fn from_values(cols: u32, rows: u32, mut values: Vec<f32>, radius_m: f64) -> Self {
        for r in [0, rows - 1] {
            let row = &mut values[(r * cols) as usize..((r + 1) * cols) as usize];
            let mean = row.iter().map(|&v| v as f64).sum::<f64>() / cols as f64;
            row.iter_mut().for_each(|v| *v = mean as f32);
        }
        let dphi = TAU / cols as f64;
        let dtheta = PI / rows as f64;
        let at = |r: u32, c: u32| values[(r * cols + c % cols) as usize] as f64;
        let row_slope = (0..rows)
            .map(|r| {
                let r1 = (r + 1).min(rows - 1);
                // East–west, in the band between the rows: (1 − t)·Δ_r + t·Δ_r1 over sin θ·dφ.
                // Each row's weight falls to 0 towards the other row, so each term is at most
                // π/2 × its row's difference over its own row's sin θ (sin θ ≥ 2θ/π): the
                // outermost rows (one value each) add nothing, whatever the poles' narrowing.
                let sin_of = |row: u32| ((row as f64 + 0.5) * dtheta).sin().max(1e-9);
                let (s0, s1) = (sin_of(r), sin_of(r1));
                let mut worst = 0f64;
                for c in 0..cols {
                    let d_ew = std::f64::consts::FRAC_PI_2
                        * ((at(r, c + 1) - at(r, c)).abs() / s0)
                            .max((at(r1, c + 1) - at(r1, c)).abs() / s1);
                    let d_ns = (at(r1, c) - at(r, c)).abs();
                    worst = worst.max(d_ew / dphi).max(d_ns / dtheta);
                }
                // Bilinear: each axis at most its largest difference over its spacing.
                worst * std::f64::consts::SQRT_2 / radius_m
            })
            .collect();
        let row_range = (0..rows)
            .map(|r| {
                (0..cols).fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), c| {
                    (lo.min(at(r, c)), hi.max(at(r, c)))
                })
            })
            .collect();
        Self {
            cols,
            rows,
            values,
            row_slope,
            row_range,
            radius_m,
        }
    }

    fn at(&self, r: i64, c: i64) -> f64 {
        let r = r.clamp(0, self.rows as i64 - 1);
        let c = c.rem_euclid(self.cols as i64);
        self.values[(r * self.cols as i64 + c) as usize] as f64
    }

    /// Relief at (φ, θ), bilinear between cell centres (columns wrap, rows clamp).
    pub fn relief_m(&self, phi: f64, theta: f64) -> f64 {
        let x = phi.rem_euclid(TAU) / TAU * self.cols as f64 - 0.5;
        let y = theta.clamp(0.0, PI) / PI * self.rows as f64 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (c, r) = (x0 as i64, y0 as i64);
        let top = self.at(r, c) + fx * (self.at(r, c + 1) - self.at(r, c));
        let bottom = self.at(r + 1, c) + fx * (self.at(r + 1, c + 1) - self.at(r + 1, c));
        top + fy * (bottom - top)
    }

    pub fn relief_at_m(&self, u: DVec3) -> f64 {
        let (phi, theta) = phi_theta_of_unit(u);
        self.relief_m(phi, theta)
    }

    /// Smallest and largest relief within `angle_rad` of `u` and the largest |∇relief| there
    /// (m per m).
    pub fn bounds_near(&self, u: DVec3, angle_rad: f64) -> (f64, f64, f64) {
        let (phi, theta) = phi_theta_of_unit(u);
        let dtheta = PI / self.rows as f64;
        let dphi = TAU / self.cols as f64;
        // Rows whose cells (and the bilinear band to the next row) can touch the cap.
        let r_lo = ((theta - angle_rad) / dtheta - 1.0).floor().max(0.0) as i64;
        let r_hi = (((theta + angle_rad) / dtheta + 1.0).ceil() as i64).min(self.rows as i64 - 1);
        // Columns: the cap's east–west half-width at its widest row (every column when the
        // cap reaches a pole).
        let sin_min = (theta - angle_rad).sin().min((theta + angle_rad).sin());
        let reaches_pole = theta - angle_rad <= 0.0 || theta + angle_rad >= PI;
        let span = if reaches_pole || sin_min <= 0.0 {
            self.cols as i64
        } else {
            ((angle_rad / sin_min) / dphi).ceil() as i64 + 1
        };
        let c0 = (phi.rem_euclid(TAU) / dphi).floor() as i64;
        let every_column = 2 * span + 1 >= self.cols as i64;
        let columns: Vec<i64> = if every_column {
            Vec::new()
        } else {
            (c0 - span..=c0 + span).collect()
        };
        let mut relief = 0f64;
        let mut relief_min = f64::INFINITY;
        let mut slope = 0f64;
        for r in r_lo..=r_hi {
            slope = slope.max(self.row_slope[r as usize]);
            if every_column {
                let (lo, hi) = self.row_range[r as usize];
                relief_min = relief_min.min(lo);
                relief = relief.max(hi);
                continue;
            }
            for &c in &columns {
                relief = relief.max(self.at(r, c));
                relief_min = relief_min.min(self.at(r, c));
            }
        }
        (relief_min.min(relief), relief, slope)
    }

    /// The map with `dabs` applied in order ([`ReliefDab`]): each cell's relief times the
    /// product of the dabs' factors there. The outermost rows are re-averaged
    /// ([`RoughnessMap::from_values`]).
    pub fn painted(&self, dabs: &[ReliefDab]) -> Self {
        let mut values = self.values.clone();
        let (cols, rows) = (self.cols as usize, self.rows as usize);
        let dphi = TAU / self.cols as f64;
        let dtheta = PI / self.rows as f64;
        for dab in dabs {
            let (phi_c, theta_c) = sphere::phi_theta_from_lat_lon_deg(dab.lat_deg, dab.lon_deg);
            let centre = sphere::unit_vector(phi_c, theta_c);
            let radius_rad = dab.radius_deg.to_radians();
            let cos_radius = radius_rad.cos();
            let ln_factor = dab.factor.max(0.0).ln();
            let r_lo = ((theta_c - radius_rad) / dtheta - 0.5).floor().max(0.0) as usize;
            let r_hi =
                (((theta_c + radius_rad) / dtheta - 0.5).ceil().max(0.0) as usize).min(rows - 1);
            // Columns: the cap's east–west half-width at its widest row, every column when
            // it reaches a pole (as `bounds_near`).
            let sin_min = (theta_c - radius_rad)
                .sin()
                .min((theta_c + radius_rad).sin());
            let reaches_pole = theta_c - radius_rad <= 0.0 || theta_c + radius_rad >= PI;
            let columns: Vec<usize> = if reaches_pole || radius_rad >= sin_min {
                (0..cols).collect()
            } else {
                let half = (radius_rad / sin_min).asin() / dphi + 1.0;
                let c0 = phi_c.rem_euclid(TAU) / dphi - 0.5;
                let (lo, hi) = ((c0 - half).floor() as i64, (c0 + half).ceil() as i64);
                if hi - lo + 1 >= cols as i64 {
                    (0..cols).collect()
                } else {
                    (lo..=hi)
                        .map(|c| c.rem_euclid(cols as i64) as usize)
                        .collect()
                }
            };
            for r in r_lo..=r_hi {
                let theta = (r as f64 + 0.5) * dtheta;
                for &c in &columns {
                    let u = sphere::unit_vector((c as f64 + 0.5) * dphi, theta);
                    let cos_d = u.dot(centre);
                    if cos_d <= cos_radius {
                        continue;
                    }
                    let d = cos_d.clamp(-1.0, 1.0).acos() / radius_rad;
                    let w = (1.0 - d * d).powi(2);
                    let v = &mut values[r * cols + c];
                    // factor^w (0^w = 0 for w > 0: a zero factor flattens).
                    *v = (*v as f64 * (w * ln_factor).exp()) as f32;
                }
            }
        }
        Self::from_values(self.cols, self.rows, values, self.radius_m)
    }

    /// The largest relief anywhere.
    pub fn max_relief_m(&self) -> f64 {
        self.values.iter().copied().fold(0f32, f32::max) as f64
    }

    /// Cell size along a meridian, metres.
    pub fn cell_m(&self) -> f64 {
        PI / self.rows as f64 * self.radius_m
    }
}

/// (φ, θ) of a unit vector.
pub fn phi_theta_of_unit(u: DVec3) -> (f64, f64) {
    let (phi, theta, _) = sphere::phi_theta_height_from_ecef_m(u, 1.0);
    (phi, theta)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The dab's column window misses no cell the brute-force scan over every column paints:
    /// at the equator, near a pole, across the antimeridian, large and small brushes.
    #[test]
    fn painted_matches_a_scan_of_every_cell() {
        let (cols, rows) = (144, 72);
        let values: Vec<f32> = (0..cols * rows).map(|i| 100.0 + (i % 13) as f32).collect();
        let map = RoughnessMap::from_values(cols, rows, values, 6.371e6);
        for (lat, lon, radius) in [
            (0.0, 0.0, 3.0),
            (80.0, 30.0, 6.0),
            (-60.0, 179.5, 4.0),
            (10.0, -179.0, 40.0),
            (89.0, 0.0, 0.5),
        ] {
            let dab = ReliefDab {
                lat_deg: lat,
                lon_deg: lon,
                radius_deg: radius,
                factor: 2.0,
            };
            let painted = map.painted(&[dab]);
            let (phi_c, theta_c) = sphere::phi_theta_from_lat_lon_deg(lat, lon);
            let centre = sphere::unit_vector(phi_c, theta_c);
            let mut inside = 0;
            // Inner rows only: the outermost rows are re-averaged by `from_values`.
            for r in 1..rows - 1 {
                for c in 0..cols {
                    let u = sphere::unit_vector(
                        (c as f64 + 0.5) * TAU / cols as f64,
                        (r as f64 + 0.5) * PI / rows as f64,
                    );
                    let d = u.dot(centre).clamp(-1.0, 1.0).acos() / radius.to_radians();
                    let i = (r * cols + c) as usize;
                    let expected = if d < 1.0 {
                        inside += 1;
                        map.values[i] as f64 * 2f64.powf((1.0 - d * d).powi(2))
                    } else {
                        map.values[i] as f64
                    };
                    let got = painted.values[i] as f64;
                    assert!(
                        (got - expected).abs() <= 1e-4 * expected,
                        "dab {lat},{lon} r {radius}: cell {r},{c}: {got} vs {expected}"
                    );
                }
            }
            assert!(
                inside > 0 || radius < 1.0,
                "dab {lat},{lon} covers no cell centre"
            );
        }
    }
}
