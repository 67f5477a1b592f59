//! The error-bounded projected grid on a sphere, CPU side in f64 (error-bounded-projective-grid.md
//! §3–4, infinite-landscapes-projected-grid.md §4.1 / Fig. 6). The GPU twin comes later.
//!
//! | step | what | source |
//! | --- | --- | --- |
//! | footprint | every render-camera ray's stretch inside the terrain shell [R + h_min, R + h_max], cut at the horizon bound θ̃max | Johanson's projector: never above the horizon, widened for the highest terrain (Fig. 3, Fig. 5) |
//! | projector | a polar patch around the nadir: column u → azimuth ψ, row v → central angle θ̃ | §4.1: artificial horizon, equal angular spacing |
//! | rows | θ̃(v) blends the projector's equal ray angles (the plain projected grid) with equal central angles (Fig. 6) | §4.1 |
//! | error | δ per cell from the caller's min/max bounds, ρ = λ·δ/d, normalised | eq. 2–4 |
//! | ray cast | where ρ > γ the fragment stage marches the pixel ray; [`ray_cast`] is its CPU twin | §4 "Rendering" |
//!
//! View space throughout: the planet's centre at the origin, the eye anywhere (the renderer puts
//! it on +z̃). Parameter coordinates (u, v) ∈ [0, 1]²: u runs left → right (ψ grows to the
//! camera's right), v runs far → near (v = 0 at the artificial horizon, the top of the screen
//! for a level camera). Grid vertices are (cols + 1) × (rows + 1), row-major, v outer.
//!
//! Why a polar patch and not a pinhole projector: a pinhole's rays cannot reach peaks behind the
//! base sphere's horizon without lifting it far above the camera (kilometres for 3000 m peaks seen
//! from 2 m), which starves the rows near the viewer. Parametrising the sphere by (ψ, θ̃) covers
//! any footprint, including the nadir (looking straight down), the backfiring cases (looking up)
//! and a camera inside the terrain shell, with no division that can vanish.

use std::f64::consts::PI;

use glam::{DMat3, DVec2, DVec3};

use crate::geo::camera::Camera;
use crate::geo::projection::{clip_from_camera, ndc_from_camera_point, ray_camera};
use crate::geo::visibility::theta_tilde_max;

mod error_buffer;

pub use error_buffer::{CellError, ErrorBuffer, RayHit, ray_cast};

/// Render-camera rays sampled per screen axis to find the footprint (odd, so the centre lines and
/// the corners, where ψ and θ̃ take their extremes, are sampled exactly).
pub const FOOTPRINT_SAMPLES: usize = 33;
/// Smallest share of the rows spread at equal central angle (§4.1): keeps θ̃(v) strictly monotone
/// and gives rows to peaks beyond the base sphere's horizon, which the ray-angle rows never reach.
pub const EQUAL_ANGLE_WEIGHT_MIN: f64 = 0.1;
/// Height above the base sphere, as a fraction of R, where equal central angles take half the
/// rows. The paper switches back to the plain grid "close to the surface" with no number; a
/// smooth blend avoids the switch's pop.
pub const EQUAL_ANGLE_HALF_HEIGHT_FRACTION: f64 = 0.1;
/// The projector's eye is at least this far above the base sphere (camera on or under it).
pub const PROJECTOR_CLEARANCE_M: f64 = 1e-3;
/// Floor of the eye-to-cell distance in eq. 3, so ρ stays finite for a camera touching a cell.
pub const MIN_DISTANCE_M: f64 = 1e-6;
/// Relative widening of a cell's bounding cap beyond its sampled boundary.
const CAP_MARGIN: f64 = 0.02;
/// The fragment stage's ray-march step, in pixels' footprint at the current distance: a
/// ridge narrower than a step can be stepped over, rising at most (1 + slope)·step/2 pixels.
pub const RAY_STEP_PX: f64 = 0.5;
/// Cells a projected grid may have (4 Mi: its cell index fits beside [`GRID_TAG`], its
/// buffers stay under 100 MB).
pub const MAX_GRID_CELLS: u64 = 1 << 22;
/// A projected-grid fragment's tag (shaders/planar.wgsl): this bit or'ed with its cell.
pub const GRID_TAG: u32 = 0x8000_0000;
/// The fragment stage's ray march: steps at most (each at least 1/this of the interval)…
pub const RAY_STEPS: u32 = 96;
/// …then bisection steps on the crossing (2⁻¹² of a step: well under a pixel's footprint).
pub const RAY_BISECTIONS: u32 = 12;
/// Bisection steps: 2⁻⁶⁴ of any bracket is below f64 resolution.
const BISECTION_STEPS: usize = 64;

/// A bad projected-grid setting, naming its flag.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ProjGridError {
    #[error("--grid {cols}x{rows}: the projected grid needs at least 1 column and 1 row")]
    Grid { cols: u32, rows: u32 },
    #[error("--grid {cols}x{rows}: the projected grid has at most {max} cells", max = MAX_GRID_CELLS)]
    TooLarge { cols: u32, rows: u32 },
    #[error("--gamma {0}: the error threshold γ is a screen-space error in pixels and must be > 0")]
    Gamma(f64),
    #[error("warped grid has {got} vertices; a {cols}x{rows} grid has {expected}")]
    WarpedVertices {
        cols: u32,
        rows: u32,
        expected: usize,
        got: usize,
    },
}

/// Settings of the projected grid (validated: [`ProjGridSettings::validate`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProjGridSettings {
    pub cols: u32,
    pub rows: u32,
    /// Error threshold γ in pixels: cells with ρ > γ are ray cast (eq. 4).
    pub gamma_px: f64,
    /// Non-uniform grid: warped by importance (`grid_warp`, `--warp`). Off by default: over
    /// real data with detail the uniform grid (equal angles in θ̃ already put rows closer
    /// near the viewer) erred less and covered the silhouettes better (docs/close-up.md#uniform-and-non-uniform-grids).
    pub warp: bool,
    /// Cells with ρ > γ ray cast in the fragment stage (`--ray-cast`).
    pub ray_cast: bool,
}

impl Default for ProjGridSettings {
    fn default() -> Self {
        Self {
            cols: 256,
            rows: 256,
            gamma_px: 1.0,
            warp: false,
            ray_cast: true,
        }
    }
}

impl ProjGridSettings {
    pub fn validate(&self) -> Result<(), ProjGridError> {
        if self.cols == 0 || self.rows == 0 {
            return Err(ProjGridError::Grid {
                cols: self.cols,
                rows: self.rows,
            });
        }
        if u64::from(self.cols) * u64::from(self.rows) > MAX_GRID_CELLS {
            return Err(ProjGridError::TooLarge {
                cols: self.cols,
                rows: self.rows,
            });
        }
        if !(self.gamma_px > 0.0 && self.gamma_px.is_finite()) {
            return Err(ProjGridError::Gamma(self.gamma_px));
        }
        Ok(())
    }

    fn vertex_count(&self) -> usize {
        (self.cols as usize + 1) * (self.rows as usize + 1)
    }

    /// `--grid COLSxROWS` (also `×` or `X`): the columns and rows, not yet validated.
    pub fn parse_grid(s: &str) -> Result<(u32, u32), String> {
        let bad = || format!("{s:?}: expected COLSxROWS, two whole numbers such as 512x256");
        let (c, r) = s.split_once(['x', 'X', '×']).ok_or_else(bad)?;
        Ok((
            c.trim().parse().map_err(|_| bad())?,
            r.trim().parse().map_err(|_| bad())?,
        ))
    }
}

/// The render camera as plain numbers (the layer below `plan`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderView {
    /// Eye in view space, metres (planet centre at the origin).
    pub eye_m: DVec3,
    /// Camera axes in view space, columns right, up, back (the camera looks down −back).
    pub view_from_camera: DMat3,
    pub fov_y_rad: f64,
    pub width_px: u32,
    pub height_px: u32,
    pub radius_m: f64,
}

impl RenderView {
    pub fn from_camera(camera: &Camera, width_px: u32, height_px: u32, radius_m: f64) -> Self {
        Self {
            eye_m: camera.eye_view_at_radius_m(radius_m),
            view_from_camera: camera.view_from_camera(),
            fov_y_rad: camera.fov_y_rad(),
            width_px,
            height_px,
            radius_m,
        }
    }

    pub fn aspect(&self) -> f64 {
        f64::from(self.width_px.max(1)) / f64::from(self.height_px.max(1))
    }

    /// λ of eq. 3: pixels per radian at the image centre, the focal length (H/2)/tan(fov_y/2),
    /// as `measure::metric` uses (the paper's w/φ).
    pub fn pixels_per_radian(&self) -> f64 {
        crate::geo::projection::focal_length_px(self.height_px, self.fov_y_rad)
    }

    /// Unit view-space ray through the screen point (x, y) in pixels (row 0 at the top; pixel
    /// centres at +0.5).
    pub fn pixel_ray(&self, x_px: f64, y_px: f64) -> DVec3 {
        let ndc_x = 2.0 * x_px / f64::from(self.width_px.max(1)) - 1.0;
        let ndc_y = 1.0 - 2.0 * y_px / f64::from(self.height_px.max(1));
        self.view_from_camera * ray_camera(self.fov_y_rad, self.aspect(), ndc_x, ndc_y)
    }

    /// Screen position in pixels of a point given as its offset from the eye, through the
    /// renderer's projection; `None` behind the camera.
    pub fn to_pixel(&self, offset_from_eye_m: DVec3) -> Option<DVec2> {
        let camera = self.view_from_camera.transpose() * offset_from_eye_m;
        if camera.z >= 0.0 {
            return None;
        }
        let clip_from = clip_from_camera(self.fov_y_rad, self.aspect(), 1.0);
        let ndc = ndc_from_camera_point(&clip_from, camera);
        Some(DVec2::new(
            0.5 * (ndc.x + 1.0) * f64::from(self.width_px),
            0.5 * (1.0 - ndc.y) * f64::from(self.height_px),
        ))
    }
}

/// Lowest and highest terrain near the viewer, metres above R (the max pyramid's top levels).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeightBounds {
    pub min_m: f64,
    pub max_m: f64,
}

/// What bounds the terrain inside one cell: heights, and a bound on its slope (metres per
/// metre along the ground; ∞ when none is known) that tightens them around the cell's corners.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CellBounds {
    pub min_m: f64,
    pub max_m: f64,
    pub slope: f64,
}

/// A ray against the sphere of one radius.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereHit {
    pub unit: DVec3,
    /// From the ray's origin to the point, metres.
    pub offset_m: DVec3,
    pub distance_m: f64,
    /// The ray missed: the point is the horizon in the ray's vertical plane (never NaN).
    pub missed: bool,
}

/// Roots of |o + t·d|² = r² as (c, b, disc) with c = |o|² − r², b = o·d; the near root is
/// c/(−b + √disc), free of cancellation for an origin a millimetre above the sphere.
fn sphere_terms(origin_m: DVec3, dir: DVec3, radius_m: f64) -> (f64, f64, f64) {
    let r_o = origin_m.length();
    let c = (r_o - radius_m) * (r_o + radius_m);
    let b = origin_m.dot(dir);
    (c, b, b * b - c)
}

/// First intersection of the ray (origin, unit `dir`) with the sphere of `radius_m`; a ray that
/// misses (or points away) is clamped to the horizon point in its azimuth.
pub fn intersect_sphere(origin_m: DVec3, dir: DVec3, radius_m: f64) -> SphereHit {
    let (c, b, disc) = sphere_terms(origin_m, dir, radius_m);
    let t = if c <= 0.0 {
        Some(-b + disc.max(0.0).sqrt())
    } else if b < 0.0 && disc >= 0.0 {
        Some(c / (-b + disc.sqrt()))
    } else {
        None
    };
    let (offset_m, missed) = match t {
        Some(t) => (dir * t, false),
        None => {
            // Horizon in the plane of the nadir and `dir`: cos β = R/r_o from the nadir.
            let r_o = origin_m.length().max(radius_m);
            let n = origin_m / r_o;
            let h = (dir - n * dir.dot(n))
                .try_normalize()
                .unwrap_or(n.any_orthonormal_vector());
            let beta = (c.max(0.0).sqrt()).atan2(radius_m);
            let p = n * (radius_m * beta.cos()) + h * (radius_m * beta.sin());
            (p - origin_m, true)
        }
    };
    let point = origin_m + offset_m;
    SphereHit {
        unit: point.try_normalize().unwrap_or(DVec3::Z),
        offset_m,
        distance_m: offset_m.length(),
        missed,
    }
}

/// One grid vertex on the base sphere R + h_base.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridPoint {
    pub uv: DVec2,
    pub unit: DVec3,
    /// From the render eye, metres (the f64 → f32 boundary: small near the viewer).
    pub offset_from_eye_m: DVec3,
    pub distance_m: f64,
    /// Behind the base sphere's horizon from the eye: only peaks there can be seen.
    pub beyond_horizon: bool,
}

/// The projected grid's vertices, (cols + 1) × (rows + 1), row-major.
#[derive(Clone, Debug, PartialEq)]
pub struct ProjectedGrid {
    pub cols: u32,
    pub rows: u32,
    pub points: Vec<GridPoint>,
}

impl ProjectedGrid {
    /// Vertex indices of cell (i, j): (i, j), (i+1, j), (i, j+1), (i+1, j+1).
    pub fn cell_vertices(&self, i: u32, j: u32) -> [usize; 4] {
        let w = self.cols as usize + 1;
        let k = j as usize * w + i as usize;
        [k, k + 1, k + w, k + w + 1]
    }
}

/// The projector: the render camera's terrain footprint as a (ψ, θ̃) patch around the nadir, and
/// the row spacing that maps v to θ̃.
#[derive(Clone, Debug, PartialEq)]
pub struct Projector {
    eye_m: DVec3,
    nadir: DVec3,
    forward_h: DVec3,
    right_h: DVec3,
    radius_m: f64,
    base_m: f64,
    psi_rad: [f64; 2],
    theta_rad: [f64; 2],
    theta_max_rad: f64,
    horizon_rad: f64,
    projector_radius_m: f64,
    tangent_rad: f64,
    s_rad: [f64; 2],
    equal_angle_weight: f64,
    sees_terrain: bool,
}

/// A render ray's stretch inside the terrain shell: azimuth (none for a vertical ray) and the
/// central angles where it enters and where it reaches the lowest terrain (or leaves).
struct RayFootprint {
    psi_rad: Option<f64>,
    theta_in_rad: f64,
    theta_out_rad: f64,
}

impl Projector {
    /// The projector for `view` over terrain within `bounds` (grid vertices on R + min_m).
    pub fn new(view: &RenderView, bounds: HeightBounds) -> Self {
        let e = view.eye_m;
        let r_e = e.length();
        let nadir = e / r_e;
        let r = view.radius_m;
        let (min_m, max_m) = (bounds.min_m, bounds.max_m.max(bounds.min_m));
        let theta_max_rad = theta_tilde_max(r, r_e - r, min_m, max_m);
        let axes = view.view_from_camera;
        let (right, up, forward) = (axes.x_axis, axes.y_axis, -axes.z_axis);
        // Forward on the ground; straight down it is the camera's up, straight up its down.
        let mut forward_h = forward - nadir * forward.dot(nadir);
        if forward_h.length_squared() < 1e-20 {
            forward_h = up * -forward.dot(nadir).signum();
            forward_h -= nadir * forward_h.dot(nadir);
        }
        let forward_h = forward_h
            .try_normalize()
            .unwrap_or(nadir.any_orthonormal_vector());
        let right_h = forward_h.cross(nadir);

        let tan_y = (0.5 * view.fov_y_rad).tan();
        let tan_x = tan_y * view.aspect();
        let n = FOOTPRINT_SAMPLES;
        let dirs: Vec<DVec3> = (0..n * n)
            .map(|k| {
                let x = 2.0 * (k % n) as f64 / (n - 1) as f64 - 1.0;
                let y = 2.0 * (k / n) as f64 / (n - 1) as f64 - 1.0;
                (right * (x * tan_x) + up * (y * tan_y) + forward).normalize()
            })
            .collect();
        let footprints: Vec<Option<RayFootprint>> = dirs
            .iter()
            .map(|&d| {
                let (theta_in, theta_out) = shell_footprint(e, d, r + min_m, r + max_m)?;
                let h = d - nadir * d.dot(nadir);
                (theta_in <= theta_max_rad).then(|| RayFootprint {
                    psi_rad: (h.length() > 1e-12).then(|| h.dot(right_h).atan2(h.dot(forward_h))),
                    theta_in_rad: theta_in,
                    theta_out_rad: theta_out.min(theta_max_rad),
                })
            })
            .collect();
        // Rays on both sides of the floor's limb: one between them grazes it and sees to θ̃max.
        let misses_floor = |&d: &DVec3| {
            let (c, b, disc) = sphere_terms(e, d, r + min_m);
            c > 0.0 && (b >= 0.0 || disc < 0.0)
        };
        let sees_limb = dirs.iter().any(misses_floor) && !dirs.iter().all(misses_floor);
        let in_view = |dir: DVec3| {
            let c = axes.transpose() * dir;
            c.z < 0.0 && c.x.abs() <= -c.z * tan_x && c.y.abs() <= -c.z * tan_y
        };
        let inside_shell = r_e <= r + max_m;
        let vertical_in_view = in_view(-nadir) || (inside_shell && in_view(nadir));

        let r_b = r + min_m;
        let horizon_rad = horizon_angle(r_b, r_e);
        let sees_terrain = footprints.iter().any(Option::is_some);
        let (psi_rad, theta_rad) = if sees_terrain {
            let psi = extent(&footprints, n, |f| f.psi_rad);
            let t_in = extent(&footprints, n, |f| Some(f.theta_in_rad));
            let t_out = extent(&footprints, n, |f| Some(f.theta_out_rad));
            let far = if sees_limb {
                theta_max_rad
            } else {
                t_out[1].min(theta_max_rad)
            };
            let full = vertical_in_view || psi[0] <= -PI || psi[1] >= PI || psi[0] > psi[1];
            let near = if full { 0.0 } else { t_in[0].max(0.0) };
            let psi = if full { [-PI, PI] } else { psi };
            (psi, [near.min(far), far])
        } else {
            let theta = horizon_rad.min(theta_max_rad);
            ([0.0, 0.0], [theta, theta])
        };

        let projector_radius_m = r_e.max(r_b + PROJECTOR_CLEARANCE_M);
        let tangent_rad = horizon_angle(r_b, projector_radius_m);
        let height_m = (r_e - r_b).max(0.0);
        let mut p = Self {
            eye_m: e,
            nadir,
            forward_h,
            right_h,
            radius_m: r,
            base_m: min_m,
            psi_rad,
            theta_rad,
            theta_max_rad,
            horizon_rad,
            projector_radius_m,
            tangent_rad,
            s_rad: [0.0; 2],
            equal_angle_weight: 1.0,
            sees_terrain,
        };
        p.s_rad = [p.ray_angle(theta_rad[0]), p.ray_angle(theta_rad[1])];
        if p.s_rad[1] - p.s_rad[0] > 1e-15 {
            let half = EQUAL_ANGLE_HALF_HEIGHT_FRACTION * r;
            p.equal_angle_weight = EQUAL_ANGLE_WEIGHT_MIN
                + (1.0 - EQUAL_ANGLE_WEIGHT_MIN) * height_m / (height_m + half);
        }
        p
    }

    /// Whether any terrain within the bounds can be on screen (looking up, it may not).
    pub fn sees_terrain(&self) -> bool {
        self.sees_terrain
    }
    /// Azimuth range around the nadir, radians from the camera's forward, positive to the right.
    pub fn psi_range_rad(&self) -> [f64; 2] {
        self.psi_rad
    }
    /// Central-angle range from the nadir: near (v = 1) and far (v = 0, the artificial horizon).
    pub fn theta_range_rad(&self) -> [f64; 2] {
        self.theta_rad
    }
    /// θ̃max: the lowest terrain's horizon plus the reach of the highest peaks behind it.
    pub fn theta_max_rad(&self) -> f64 {
        self.theta_max_rad
    }
    /// Height of the grid's base sphere above R (the lowest terrain).
    pub fn base_m(&self) -> f64 {
        self.base_m
    }
    /// Share of the rows spread at equal central angle (§4.1).
    pub fn equal_angle_weight(&self) -> f64 {
        self.equal_angle_weight
    }

    /// Angle at the projector eye between the nadir and the base-sphere point at θ̃, frozen at the
    /// projector's horizon (beyond it the ray angle turns back). 1 − cos is 2·sin²(θ̃/2).
    fn ray_angle(&self, theta_rad: f64) -> f64 {
        let t = theta_rad.min(self.tangent_rad);
        let r_b = self.radius_m + self.base_m;
        let drop = (self.projector_radius_m - r_b) + 2.0 * r_b * (0.5 * t).sin().powi(2);
        (r_b * t.sin()).atan2(drop)
    }

    /// g(θ̃) ∈ [0, 1], near → far: (1 − w)·(equal ray angles) + w·(equal central angles).
    fn row_coordinate(&self, theta_rad: f64) -> f64 {
        let [near, far] = self.theta_rad;
        if far - near <= 0.0 {
            return 0.0;
        }
        let w = self.equal_angle_weight;
        let equal_angle = (theta_rad - near) / (far - near);
        let [s_near, s_far] = self.s_rad;
        if w >= 1.0 {
            return equal_angle;
        }
        let ray = (self.ray_angle(theta_rad) - s_near) / (s_far - s_near);
        (1.0 - w) * ray + w * equal_angle
    }

    /// θ̃ of row coordinate v (v = 0 far, 1 near), by bisection on the monotone g.
    pub fn theta_of_v(&self, v: f64) -> f64 {
        let target = 1.0 - v.clamp(0.0, 1.0);
        let [mut lo, mut hi] = self.theta_rad;
        for _ in 0..BISECTION_STEPS {
            let mid = 0.5 * (lo + hi);
            if self.row_coordinate(mid) < target {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    }

    /// The grid vertex at (u, v).
    pub fn point(&self, uv: DVec2) -> GridPoint {
        self.point_at(uv, self.theta_of_v(uv.y))
    }

    /// The vertex at column u and central angle θ̃ (row v's θ̃ already solved, or looked up:
    /// [`ThetaTable`]).
    pub fn point_at(&self, uv: DVec2, theta_rad: f64) -> GridPoint {
        let [p0, p1] = self.psi_rad;
        let psi = p0 + uv.x.clamp(0.0, 1.0) * (p1 - p0);
        let h = self.forward_h * psi.cos() + self.right_h * psi.sin();
        let (sin_t, cos_t) = theta_rad.sin_cos();
        let r_b = self.radius_m + self.base_m;
        // r_b·unit − e, with r_b·cos θ̃ − r_e = (r_b − r_e) − 2·r_b·sin²(θ̃/2).
        let along = (r_b - self.eye_m.length()) - 2.0 * r_b * (0.5 * theta_rad).sin().powi(2);
        let offset = self.nadir * along + h * (r_b * sin_t);
        GridPoint {
            uv,
            unit: (self.nadir * cos_t + h * sin_t).normalize(),
            offset_from_eye_m: offset,
            distance_m: offset.length(),
            beyond_horizon: theta_rad > self.horizon_rad,
        }
    }

    /// (u, v) of a unit vector: inverse of [`Projector::point`]; outside [0, 1]² where the
    /// point is outside the grid.
    pub fn param_of(&self, unit: DVec3) -> DVec2 {
        let dn = unit.dot(self.nadir);
        let h = unit - self.nadir * dn;
        let theta = h.length().atan2(dn);
        let psi = h.dot(self.right_h).atan2(h.dot(self.forward_h));
        let [p0, p1] = self.psi_rad;
        let u = if p1 > p0 {
            (psi - p0) / (p1 - p0)
        } else if (psi - p0).abs() < 1e-12 {
            0.5
        } else {
            f64::INFINITY
        };
        let [near, far] = self.theta_rad;
        let v = if theta < near {
            1.0 + (near - theta)
        } else if theta > far {
            far - theta
        } else {
            1.0 - self.row_coordinate(theta)
        };
        DVec2::new(u, v)
    }

    /// The uniform grid of `settings` (θ̃ solved once per row).
    pub fn grid(&self, settings: &ProjGridSettings) -> Result<ProjectedGrid, ProjGridError> {
        settings.validate()?;
        let (cols, rows) = (settings.cols, settings.rows);
        let mut points = Vec::with_capacity(settings.vertex_count());
        for j in 0..=rows {
            let v = f64::from(j) / f64::from(rows);
            let theta = self.theta_of_v(v);
            for i in 0..=cols {
                points.push(self.point_at(DVec2::new(f64::from(i) / f64::from(cols), v), theta));
            }
        }
        Ok(ProjectedGrid { cols, rows, points })
    }

    /// A grid warped in parameter space (`grid_warp`'s output): (cols + 1) × (rows + 1) (u, v).
    pub fn grid_warped(
        &self,
        settings: &ProjGridSettings,
        uv: &[DVec2],
    ) -> Result<ProjectedGrid, ProjGridError> {
        settings.validate()?;
        if uv.len() != settings.vertex_count() {
            return Err(ProjGridError::WarpedVertices {
                cols: settings.cols,
                rows: settings.rows,
                expected: settings.vertex_count(),
                got: uv.len(),
            });
        }
        Ok(ProjectedGrid {
            cols: settings.cols,
            rows: settings.rows,
            points: uv.iter().map(|&p| self.point(p)).collect(),
        })
    }
}

/// θ̃(v) tabulated at [`ThetaTable::SAMPLES`] + 1 rows and interpolated linearly: a frame's
/// grid and error buffer look θ̃ up instead of solving it by bisection per point (the table's
/// error, ~1e-8 of the range, moves vertices along the ground, never off it).
#[derive(Clone, Debug)]
pub struct ThetaTable {
    theta_rad: Vec<f64>,
}

impl ThetaTable {
    pub const SAMPLES: usize = 4096;

    pub fn new(projector: &Projector) -> Self {
        let n = Self::SAMPLES;
        Self {
            theta_rad: (0..=n)
                .map(|k| projector.theta_of_v(k as f64 / n as f64))
                .collect(),
        }
    }

    pub fn theta_of_v(&self, v: f64) -> f64 {
        let n = Self::SAMPLES;
        let x = v.clamp(0.0, 1.0) * n as f64;
        let k = (x.floor() as usize).min(n - 1);
        let f = x - k as f64;
        self.theta_rad[k] + f * (self.theta_rad[k + 1] - self.theta_rad[k])
    }

    /// The grid point at (u, v), θ̃ from the table.
    pub fn point(&self, projector: &Projector, uv: DVec2) -> GridPoint {
        projector.point_at(uv, self.theta_of_v(uv.y))
    }
}

/// Angle between two unit vectors, accurate when small.
#[cfg(test)]
fn angle(a: DVec3, b: DVec3) -> f64 {
    a.cross(b).length().atan2(a.dot(b))
}

/// Central angle from the point below a viewer at radius `r_v` to its horizon on radius `r_b`
/// (0 at or below it), as atan2 so a millimetre's height stays accurate.
fn horizon_angle(r_b: f64, r_v: f64) -> f64 {
    ((r_v - r_b).max(0.0) * (r_v + r_b)).sqrt().atan2(r_b)
}

/// Distances along the ray (eye, unit d) where it enters the shell [r_lo, r_hi] and where it
/// reaches r_lo (or leaves r_hi); `None` if it never enters. An eye under r_lo is in the terrain.
fn shell_interval(e: DVec3, d: DVec3, r_lo: f64, r_hi: f64) -> Option<(f64, f64)> {
    let (c_hi, b, disc_hi) = sphere_terms(e, d, r_hi);
    if c_hi > 0.0 && (b >= 0.0 || disc_hi < 0.0) {
        return None;
    }
    let sq = disc_hi.max(0.0).sqrt();
    let t_in = if c_hi > 0.0 { c_hi / (-b + sq) } else { 0.0 };
    let (c_lo, _, disc_lo) = sphere_terms(e, d, r_lo);
    let t_out = if c_lo <= 0.0 {
        t_in
    } else if b < 0.0 && disc_lo >= 0.0 {
        c_lo / (-b + disc_lo.sqrt())
    } else {
        -b + sq
    };
    Some((t_in, t_out))
}

/// Central angles from the nadir of the ray's shell interval (monotone in t).
fn shell_footprint(e: DVec3, d: DVec3, r_lo: f64, r_hi: f64) -> Option<(f64, f64)> {
    let (t_in, t_out) = shell_interval(e, d, r_lo, r_hi)?;
    let r_e = e.length();
    let (dn, dh) = (d.dot(e) / r_e, (d - e * (d.dot(e) / (r_e * r_e))).length());
    let theta = |t: f64| (t * dh).atan2(r_e + t * dn);
    Some((theta(t_in), theta(t_out)))
}

/// [min, max] of `f` over the sampled rays, each widened by its largest step to a lattice
/// neighbour (the extreme between samples is at most that far).
fn extent(
    samples: &[Option<RayFootprint>],
    n: usize,
    f: impl Fn(&RayFootprint) -> Option<f64>,
) -> [f64; 2] {
    let value = |k: usize| samples[k].as_ref().and_then(&f);
    let mut best = [(f64::INFINITY, 0), (f64::NEG_INFINITY, 0)];
    for k in 0..samples.len() {
        if let Some(x) = value(k) {
            if x < best[0].0 {
                best[0] = (x, k);
            }
            if x > best[1].0 {
                best[1] = (x, k);
            }
        }
    }
    let step = |k: usize| {
        let (i, j) = (k % n, k / n);
        let mut s: f64 = 0.0;
        for (di, dj) in [(-1, 0), (1, 0), (0, -1), (0, 1)] {
            let (a, b) = (i as i64 + di, j as i64 + dj);
            if (0..n as i64).contains(&a)
                && (0..n as i64).contains(&b)
                && let (Some(x), Some(y)) = (value(k), value(b as usize * n + a as usize))
            {
                s = s.max((x - y).abs());
            }
        }
        s
    };
    [best[0].0 - step(best[0].1), best[1].0 + step(best[1].1)]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geo::EARTH_RADIUS_M as R;

    const W: u32 = 64;
    const H: u32 = 40;
    const FLAT: HeightBounds = hb(0.0, 0.0);

    const fn hb(min_m: f64, max_m: f64) -> HeightBounds {
        HeightBounds { min_m, max_m }
    }
    const GRID: ProjGridSettings = ProjGridSettings {
        cols: 48,
        rows: 32,
        gamma_px: 1.0,
        warp: false,
        ray_cast: true,
    };

    #[test]
    fn the_grid_flag_parses_cols_by_rows_and_names_what_it_expected() {
        let parse = ProjGridSettings::parse_grid;
        assert_eq!(parse("512x256"), Ok((512, 256)));
        assert_eq!(parse("64 × 32"), Ok((64, 32)));
        assert_eq!(parse("8X4"), Ok((8, 4)));
        for bad in ["512", "x", "512x", "ax4", "-1x4", "1.5x2"] {
            let e = parse(bad).unwrap_err();
            assert!(e.contains("expected COLSxROWS"), "{bad:?}: {e}");
        }
        // Parsed is not valid: the settings still refuse an empty grid.
        let (cols, rows) = parse("0x16").unwrap();
        let grid = ProjGridSettings {
            cols,
            rows,
            ..Default::default()
        };
        assert!(grid.validate().is_err());
    }

    fn camera(lat_deg: f64, altitude_m: f64, pitch_deg: f64) -> Camera {
        Camera {
            lat_deg,
            lon_deg: 10.65,
            altitude_m,
            heading_deg: 315.0,
            pitch_deg,
            roll_deg: 0.0,
            fov_y_deg: 60.0,
        }
    }

    fn view(lat_deg: f64, altitude_m: f64, pitch_deg: f64) -> RenderView {
        RenderView::from_camera(&camera(lat_deg, altitude_m, pitch_deg), W, H, R)
    }

    /// Egg-box hills between `lo` and `hi` over the tangent coordinates (R·w.x, R·w.y) of
    /// `frame`·w, with their Lipschitz bounds over a cap (the min/max pyramid's stand-in).
    struct Hills {
        lo: f64,
        hi: f64,
        wavelength_m: f64,
        frame: DMat3,
    }

    impl Hills {
        fn height(&self, w: DVec3) -> f64 {
            let p = self.frame * w * (R * TAU_OVER / self.wavelength_m);
            let mid = 0.5 * (self.lo + self.hi);
            mid + 0.5 * (self.hi - self.lo) * p.x.sin() * p.y.cos()
        }
        fn bounds(&self, w: DVec3, angle_rad: f64) -> (f64, f64) {
            let slope = 0.5 * (self.hi - self.lo) * TAU_OVER / self.wavelength_m * 2f64.sqrt();
            let h = self.height(w);
            let spread = slope * R * angle_rad;
            ((h - spread).max(self.lo), (h + spread).min(self.hi))
        }
    }
    const TAU_OVER: f64 = 2.0 * PI;

    fn hills(bounds: HeightBounds) -> Hills {
        Hills {
            lo: bounds.min_m,
            hi: bounds.max_m,
            wavelength_m: 120.0,
            frame: DMat3::IDENTITY,
        }
    }

    fn in_triangle(p: DVec2, a: DVec2, b: DVec2, c: DVec2) -> bool {
        let eps = 1e-12 * ((b - a).length() + (c - b).length() + (a - c).length()).powi(2);
        let d = [
            (b - a).perp_dot(p - a),
            (c - b).perp_dot(p - b),
            (a - c).perp_dot(p - c),
        ];
        !(d.iter().any(|&x| x < -eps) && d.iter().any(|&x| x > eps))
    }

    /// (pixels whose centre ray hits the base sphere, those no projected cell covers, cells
    /// with all four corners on screen).
    fn screen_holes(view: &RenderView, grid: &ProjectedGrid, base_m: f64) -> (usize, usize, usize) {
        let px: Vec<Option<DVec2>> = grid
            .points
            .iter()
            .map(|p| view.to_pixel(p.offset_from_eye_m))
            .collect();
        let mut covered = vec![false; (W * H) as usize];
        let mut on_screen = 0;
        for j in 0..grid.rows {
            for i in 0..grid.cols {
                let Some(c) = grid
                    .cell_vertices(i, j)
                    .iter()
                    .map(|&k| px[k])
                    .collect::<Option<Vec<_>>>()
                else {
                    continue;
                };
                let lo = c.iter().fold(DVec2::INFINITY, |a, &b| a.min(b));
                let hi = c.iter().fold(DVec2::NEG_INFINITY, |a, &b| a.max(b));
                let screen = DVec2::new(f64::from(W), f64::from(H));
                if lo.cmpge(DVec2::ZERO).all() && hi.cmple(screen).all() {
                    on_screen += 1;
                }
                let first = (lo - 0.5).ceil().max(DVec2::ZERO);
                let last = (hi - 0.5).floor().min(screen - 1.0);
                for y in first.y as u32..=last.y.max(-1.0) as u32 {
                    for x in first.x as u32..=last.x.max(-1.0) as u32 {
                        let p = DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5);
                        if in_triangle(p, c[0], c[1], c[3]) || in_triangle(p, c[0], c[3], c[2]) {
                            covered[(y * W + x) as usize] = true;
                        }
                    }
                }
            }
        }
        let (mut seen, mut holes) = (0, 0);
        for y in 0..H {
            for x in 0..W {
                let d = view.pixel_ray(f64::from(x) + 0.5, f64::from(y) + 0.5);
                if !intersect_sphere(view.eye_m, d, R + base_m).missed {
                    seen += 1;
                    holes += usize::from(!covered[(y * W + x) as usize]);
                }
            }
        }
        (seen, holes, on_screen)
    }

    /// Points of every pixel ray inside the shell, in front of the lowest terrain and within
    /// θ̃max (where terrain can be seen), and those outside the grid's parameter square.
    fn footprint_misses(view: &RenderView, p: &Projector, b: HeightBounds) -> (usize, usize) {
        let e = view.eye_m;
        let theta_max = theta_tilde_max(R, e.length() - R, b.min_m, b.max_m);
        let (mut checked, mut misses) = (0, 0);
        for y in 0..H {
            for x in 0..W {
                let d = view.pixel_ray(f64::from(x) + 0.5, f64::from(y) + 0.5);
                for k in 0..=600 {
                    let q = e + d * (1e-4 * 1e12f64.powf(f64::from(k) / 600.0));
                    let r = q.length();
                    if r < R + b.min_m {
                        break;
                    }
                    let u = q / r;
                    if r > R + b.max_m || angle(u, e.normalize()) > theta_max {
                        continue;
                    }
                    checked += 1;
                    let uv = p.param_of(u);
                    let inside = uv.cmpge(DVec2::splat(-1e-9)).all()
                        && uv.cmple(DVec2::splat(1.0 + 1e-9)).all();
                    misses += usize::from(!inside);
                }
            }
        }
        (checked, misses)
    }

    #[test]
    fn settings_name_their_flags() {
        let bad_grid = ProjGridSettings { cols: 0, ..GRID };
        let err = bad_grid.validate().unwrap_err();
        assert_eq!(err, ProjGridError::Grid { cols: 0, rows: 32 });
        assert!(err.to_string().starts_with("--grid 0x32"), "{err}");
        assert!(ProjGridSettings { rows: 0, ..GRID }.validate().is_err());
        for gamma_px in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let err = ProjGridSettings { gamma_px, ..GRID }
                .validate()
                .unwrap_err();
            assert!(err.to_string().starts_with("--gamma"), "{err}");
        }
        assert!(
            ProjGridSettings {
                cols: 1,
                rows: 1,
                gamma_px: 0.01,
                ..GRID
            }
            .validate()
            .is_ok()
        );
        let p = Projector::new(&view(45.0, 30.0, -20.0), FLAT);
        let err = p.grid_warped(&GRID, &[DVec2::ZERO; 3]).unwrap_err();
        assert!(matches!(
            err,
            ProjGridError::WarpedVertices {
                expected: 1617,
                got: 3,
                ..
            }
        ));
    }

    #[test]
    fn sphere_hits_and_horizon_clamp() {
        for h in [100.0, 1e-3] {
            let e = DVec3::new(0.0, 0.0, R + h);
            let down = intersect_sphere(e, -DVec3::Z, R);
            assert!(
                !down.missed && (down.distance_m - h).abs() < 1e-8,
                "{down:?}"
            );
            // Level and straight up: both miss and clamp to the horizon, sqrt(2Rh + h²) away.
            for dir in [DVec3::X, DVec3::new(0.3, 0.1, 1.0).normalize()] {
                let hit = intersect_sphere(e, dir, R);
                let tangent = (h * (2.0 * R + h)).sqrt();
                assert!(hit.missed && hit.offset_m.is_finite(), "{hit:?}");
                assert!((hit.distance_m - tangent).abs() < 1e-6 * tangent, "{hit:?}");
                assert!(((e + hit.offset_m).length() - R).abs() < 1e-6);
                assert!(hit.offset_m.dot(e + hit.offset_m).abs() < 1e-3 * tangent * R);
            }
        }
        // From inside the sphere every ray hits (the exit).
        let inside = intersect_sphere(DVec3::new(0.0, 0.0, R - 10.0), DVec3::Z, R);
        assert!(!inside.missed && (inside.distance_m - 10.0).abs() < 1e-8);
    }

    #[test]
    fn rows_blend_toward_equal_angles_and_invert() {
        let mut last_weight = 0.0;
        for (altitude_m, pitch_deg) in [(2.0, -20.0), (30.0, -20.0), (1e4, -20.0), (2e7, -80.0)] {
            let v = view(45.0, altitude_m, pitch_deg);
            let p = Projector::new(&v, hb(0.0, 3000.0));
            let w = p.equal_angle_weight();
            assert!(
                w > last_weight && w >= EQUAL_ANGLE_WEIGHT_MIN,
                "{altitude_m}: {w}"
            );
            last_weight = w;
            // θ̃(v) strictly falls from the horizon (v = 0) to the near edge (v = 1).
            let thetas: Vec<f64> = (0..=64)
                .map(|k| p.theta_of_v(f64::from(k) / 64.0))
                .collect();
            assert!(
                thetas.windows(2).all(|t| t[1] < t[0]),
                "{altitude_m}: {thetas:?}"
            );
            for uv in [
                DVec2::new(0.1, 0.2),
                DVec2::new(0.5, 0.97),
                DVec2::new(0.93, 0.01),
            ] {
                let back = p.param_of(p.point(uv).unit);
                assert!((back - uv).length() < 1e-7, "{altitude_m}: {uv} → {back}");
            }
        }
        assert!(
            last_weight > 0.9,
            "from 20 000 km rows are nearly equal-angle: {last_weight}"
        );
        // A warped parameter grid lands on the same surface points.
        let p = Projector::new(&view(45.0, 30.0, -20.0), FLAT);
        let s = ProjGridSettings {
            cols: 4,
            rows: 3,
            ..GRID
        };
        let uv: Vec<DVec2> = (0..20)
            .map(|k| {
                DVec2::new(
                    (f64::from(k % 5) / 4.0).powi(2),
                    (f64::from(k / 5) / 3.0).sqrt(),
                )
            })
            .collect();
        let g = p.grid_warped(&s, &uv).unwrap();
        for (q, &uv) in g.points.iter().zip(&uv) {
            assert!((q.unit - p.point(uv).unit).length() < 1e-15);
        }
    }

    #[test]
    fn grid_has_no_hole_on_screen() {
        for (altitude_m, pitch_deg) in [(2.0, -5.0), (30.0, -20.0), (1e4, -20.0)] {
            let v = view(45.65, altitude_m, pitch_deg);
            let p = Projector::new(&v, FLAT);
            let grid = p.grid(&GRID).unwrap();
            let (seen, holes, on_screen) = screen_holes(&v, &grid, 0.0);
            println!(
                "{altitude_m} m, {pitch_deg}°: {seen} sphere pixels, {holes} holes, {on_screen}/{} cells on screen",
                GRID.cols * GRID.rows
            );
            assert!(seen > 500, "{seen}");
            assert_eq!(holes, 0, "{altitude_m} m, {pitch_deg}°");
        }
    }

    /// docs/design.md#stiff-cases: (name, latitude, altitude, pitch, relief near the viewer).
    #[rustfmt::skip]
    const BACKFIRING: [(&str, f64, f64, f64, HeightBounds); 8] = [
        ("up +30°", 45.65, 10.0, 30.0, hb(0.0, 500.0)),
        ("up +89°", 45.65, 10.0, 89.0, hb(0.0, 500.0)),
        ("down −90°", 45.65, 1000.0, -90.0, hb(0.0, 500.0)),
        ("valley −5°", 45.65, 500.0, -5.0, hb(0.0, 3000.0)),
        ("valley +30°", 45.65, 500.0, 30.0, hb(0.0, 3000.0)),
        ("limb 100 km", 45.65, 1e5, -10.0, hb(-500.0, 8848.0)),
        ("1 mm", 45.65, 1e-3, -5.0, hb(-1.0, 0.0)),
        ("north pole", 90.0, 100.0, -30.0, hb(0.0, 500.0)),
    ];

    #[test]
    fn backfiring_cases_stay_finite_and_covered() {
        for (name, lat, altitude_m, pitch_deg, relief) in BACKFIRING {
            let v = view(lat, altitude_m, pitch_deg);
            let mut terrain = hills(relief);
            if lat == 90.0 {
                // World-fixed hills, so the pole's own frame is exercised.
                terrain.frame = camera(lat, altitude_m, pitch_deg)
                    .view_frame()
                    .world_from_view;
            }
            for b in [FLAT, relief] {
                let p = Projector::new(&v, b);
                let grid = p.grid(&GRID).unwrap();
                for q in &grid.points {
                    assert!(
                        q.unit.is_finite() && q.offset_from_eye_m.is_finite(),
                        "{name}"
                    );
                    assert!(q.distance_m.is_finite(), "{name}");
                }
                let (checked, misses) = footprint_misses(&v, &p, b);
                assert_eq!(
                    misses, 0,
                    "{name} {b:?}: {misses}/{checked} footprint points off grid"
                );
                if b == FLAT {
                    let (seen, holes, _) = screen_holes(&v, &grid, 0.0);
                    assert_eq!(holes, 0, "{name}: {holes}/{seen} pixels uncovered");
                    assert_eq!(p.sees_terrain(), seen > 0 || checked > 0, "{name}");
                    continue;
                }
                let eb =
                    ErrorBuffer::compute(&p, &grid, &v, 1.0, &|w| terrain.height(w), &|w, a| {
                        terrain.bounds(w, a)
                    });
                let range = b.max_m - b.min_m;
                for c in &eb.cells {
                    assert!(
                        c.rho_px.is_finite() && c.delta_m <= range + 1e-9,
                        "{name}: {c:?}"
                    );
                }
                println!(
                    "{name}: {checked} footprint points covered, {:.1} % cells above γ",
                    100.0 * eb.fraction_above_gamma()
                );
                if name == "down −90°" {
                    // The apex row's cells have zero area; their error stays within the bound
                    // of the whole relief seen from above it.
                    let bound = v.pixels_per_radian() * range / (altitude_m - b.max_m);
                    assert!(eb.cells.iter().all(|c| c.rho_px <= bound * (1.0 + 1e-9)));
                    let apex = grid.cell_vertices(0, GRID.rows - 1);
                    let d = grid.points[apex[2]].unit - grid.points[apex[3]].unit;
                    assert!(d.length() < 1e-12, "apex row collapses to the nadir");
                }
            }
        }
    }

    #[test]
    fn error_buffer_follows_eq_2_to_4() {
        let v = view(45.65, 30.0, -20.0);
        let b = hb(0.0, 20.0);
        let p = Projector::new(&v, b);
        let grid = p
            .grid(&ProjGridSettings {
                cols: 8,
                rows: 16,
                ..GRID
            })
            .unwrap();
        // Every vertex at 10 m, bounds [0, 20] everywhere: δ = max(20 − 10, 10 − 0) (eq. 2).
        let eb = ErrorBuffer::compute(&p, &grid, &v, 20.0, &|_| 10.0, &|_, _| (0.0, 20.0));
        let lambda = v.pixels_per_radian();
        let mut above = 0;
        for (k, c) in eb.cells.iter().enumerate() {
            assert_eq!(c.delta_m, 10.0);
            assert!((c.rho_px - lambda * 10.0 / c.distance_min_m).abs() < 1e-9 * c.rho_px);
            // The nearest distance bounds the paper's ‖p − e‖ from below (eq. 3).
            let centre_m = c.centre * (R + 10.0) - v.eye_m;
            assert!(
                c.distance_min_m <= centre_m.length() * (1.0 + 1e-12),
                "{c:?}"
            );
            let expected = if c.rho_px < 20.0 {
                0.0
            } else {
                1.0 - 20.0 / c.rho_px
            };
            assert_eq!(eb.normalised(k), expected);
            above += usize::from(eb.needs_ray_cast(k));
        }
        // Far rows (v = 0, the first) are further away: ρ grows toward the viewer.
        let rho = |j: u32| eb.cells[(j * 8 + 4) as usize].rho_px;
        assert!((1..16).all(|j| rho(j) > rho(j - 1)));
        assert!(above > 0 && above < eb.cells.len(), "{above}");
        assert_eq!(
            eb.fraction_above_gamma(),
            above as f64 / eb.cells.len() as f64
        );
        // Exact bounds (a flat 10 m plain) leave nothing to ray cast.
        let flat = ErrorBuffer::compute(&p, &grid, &v, 1.0, &|_| 10.0, &|_, _| (10.0, 10.0));
        assert!(flat.cells.iter().all(|c| c.delta_m == 0.0));
        assert_eq!(flat.fraction_above_gamma(), 0.0);
    }

    #[test]
    fn ray_cast_stays_within_gamma_where_rho_exceeds_it() {
        let v = view(45.65, 50.0, -20.0);
        let b = hb(0.0, 20.0);
        let terrain = hills(b);
        let gamma_px = 1.0;
        let p = Projector::new(&v, b);
        let s = ProjGridSettings {
            cols: 32,
            rows: 20,
            ..GRID
        };
        let grid = p.grid(&s).unwrap();
        let height = |w: DVec3| terrain.height(w);
        let eb = ErrorBuffer::compute(&p, &grid, &v, gamma_px, &height, &|w, a| {
            terrain.bounds(w, a)
        });
        let lambda = v.pixels_per_radian();
        let clearance = |t: f64, d: DVec3| {
            let q = v.eye_m + d * t;
            (q.length() - R) - terrain.height(q.normalize())
        };
        let (mut tested, mut grazing, mut worst_cast_px, mut worst_mesh_px) =
            (0, 0, 0.0f64, 0.0f64);
        for (k, c) in eb.cells.iter().enumerate() {
            let target = c.centre * (R + terrain.height(c.centre)) - v.eye_m;
            if !eb.needs_ray_cast(k) || v.to_pixel(target).is_none() {
                continue;
            }
            let d = target.normalize();
            // Only pixels whose true first hit is in this cell are its own (a nearer hill's
            // cell wins the depth test elsewhere): the reference marches 1/100 px steps.
            let truth = ray_cast(&v, d, (b.min_m, b.max_m), 0.01, &height).unwrap();
            if angle(truth.unit, c.centre) > c.radius_rad {
                continue;
            }
            // The cast's stretch: from the cell's max down to its min (or to the hit). No hit
            // means the ray grazes the cell and the fragment is discarded.
            let (t0, t1) = shell_interval(v.eye_m, d, R + c.min_m, R + c.max_m).unwrap();
            let hit = ray_cast(&v, d, (c.min_m, c.max_m), 0.5 * gamma_px, &height);
            let t_end = hit.map_or(t1, |h| h.t_m);
            // Screen-space error: terrain poking above the ray before the hit (or anywhere on
            // the stretch without one) and the vertical miss at the hit, in pixels (eq. 3).
            let mut err = hit.map_or(0.0, |h| lambda * clearance(h.t_m, d).abs() / h.t_m);
            for i in 0..400 {
                let t = t0 + (t_end - t0) * f64::from(i) / 400.0;
                err = err.max(lambda * (-clearance(t, d)).max(0.0) / t.max(1e-9));
            }
            grazing += usize::from(hit.is_none());
            worst_cast_px = worst_cast_px.max(err);
            let mean = grid
                .cell_vertices(k as u32 % 32, k as u32 / 32)
                .iter()
                .map(|&i| terrain.height(grid.points[i].unit))
                .sum::<f64>()
                / 4.0;
            let mesh_px = lambda * (terrain.height(c.centre) - mean).abs() / target.length();
            worst_mesh_px = worst_mesh_px.max(mesh_px);
            tested += 1;
        }
        println!(
            "{:.1} % cells above γ, {tested} cast ({grazing} grazing): worst cast {worst_cast_px:.3} px, worst mesh {worst_mesh_px:.1} px",
            100.0 * eb.fraction_above_gamma()
        );
        assert!(tested >= 20, "{tested}");
        assert!(
            worst_mesh_px > gamma_px,
            "the flagged cells' mesh is off by more than γ"
        );
        assert!(worst_cast_px <= gamma_px, "{worst_cast_px}");
    }
}
