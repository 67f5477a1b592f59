//! The reference: an f64 CPU ray caster over the terrain function, giving each pixel its true
//! hit (distance along the ray and surface point) or sky, for the same camera, viewport, pixel
//! centres and projection as the renderer (docs/design.md#measuring: coverage mismatches are
//! counted against it).
//!
//! The terrain is a [`HeightField`]: its height at a unit vector (for [`Terrain`]: the DEM's
//! finest level, bilinear, or the analytic planet, exactly) and conservative bounds over a cap
//! around a point: min/max heights (the DEM's min/max pyramid planes, the error-bounded paper's
//! h_min/h_max of eq. 2; the analytic planet's Lipschitz spread) and a bound on the slope.
//!
//! # March
//!
//! A ray from the eye `e` along the unit direction `d` (view space), with clearance
//! f(t) = |e + t·d| − R − h(u(t)) (positive above the terrain):
//!
//! 1. Skip to the shell R + h_max of the whole terrain (nothing above it); beyond the shell's far
//!    side the ray is sky, and where it reaches R + h_min it is certainly below the terrain.
//! 2. **Cap steps** (proven safe): with bounds [lo, hi] over a cap of angle α around the current
//!    point, the ray is advanced to where it leaves the cap or descends to R + hi, whichever
//!    comes first. The cap doubles after a step that left it and shrinks by 4 when the ray runs
//!    into its max (never below the DEM's finest pixel, where the bounds stop tightening).
//! 3. **Lipschitz steps** (proven safe): below a cap's max, with slope bound L in the cap, the
//!    clearance falls by at most max(0, −d·u) + L·R/r_min per metre of ray (u: the vertical
//!    where the step starts; along a line d·u only grows. r_min: the shell's floor), so a step
//!    of f over that rate that stays in the cap cannot cross the terrain.
//!    **Split steps** (proven safe) for a terrain made of octaves (procedural detail): split
//!    after octave k into the coarse part c_k (base and the first k octaves, evaluated) and the
//!    fine rest, at most A_k anywhere in the cap. The surface lies below c_k + A_k, whose slope
//!    is the coarse part's L_k, so a step of (r − R − c_k − A_k) over max(0, −d·u) + L_k·R/r_min
//!    is safe. The march takes the longest over every k (the whole terrain is k = n). With the
//!    default Hurst exponent (0.85) every octave adds about the same slope bound, so leaving
//!    out those finer than the ray's clearance roughly halves it for a ray a metre up.
//! 4. **Minimum step** (not proven): when the proven step is shorter than
//!    s_min = `min_step_px`·t/λ_ray (λ_ray: pixels per radian along that ray, the largest
//!    value across the pixel), the ray advances by s_min and checks the sign of f there.
//! 5. The first sign change is refined (regula falsi, Illinois variant, then bisection) until
//!    bracketed to `refine_px`·t/λ_ray (default 10⁻⁴ px), and the midpoint reported.
//!
//! # Guarantee
//!
//! Every step except the minimum step is proven not to cross the terrain, so the reported hit
//! is the first crossing of the ray, except that a crossing may be missed where the ray dips
//! below the terrain and comes out again within one minimum step: over an interval of the ray
//! shorter than s_min (a quarter of a pixel's footprint by default). Where the slope bound L
//! holds, the clearance changes by at most 1 + L·R/r_min ≈ 1 + L per metre, so such a sliver
//! rises at most (1 + L)·s_min/2 above the ray: (1 + L)·`min_step_px`/2 pixels. That is 0.36 px
//! for the analytic planet (L ≈ 1.85); for the embedded Earth L comes from the min/max planes
//! around the point: 0.16 px over the Alps (L ≈ 0.25), 0.2 px at the steepest 10′ relief
//! (Everest 0.4, the Mariana trench 0.58), but within a few pixels of a pole, where the
//! lat/lon cells narrow to metres, L ≈ 50 and the height bound is several pixels (ETOPO5's row
//! of pixel centres on each pole holds one value, so its terrain is continuous there and L is
//! bounded as next to the pole: `dem_bounds`). Where L is unknown (+∞: a regional DEM's edge,
//! a pole row of differing values) only the length bound holds, and the march falls back to
//! its minimum steps.
//!
//! With the eye inside the terrain (f(0) ≤ 0) every ray hits at distance 0.

use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use glam::{DMat3, DVec3};

use super::MeasureError;
use crate::dem::pyramid::Region;
use crate::geo::camera::{Camera, pixel_ray_view};
use crate::geo::sphere;
use crate::procedural::{Detail, MAX_OCTAVES};
use crate::terrain::dem::PoleEnd;
use crate::terrain::{AnalyticPlanet, Base, DemTerrain, Terrain};

/// Largest cap the march asks bounds for (≈ 320 km on Earth): larger caps over real relief
/// give bounds as loose as the global range, which the shell already uses.
const CAP_MAX_RAD: f64 = 0.05;
/// The first cap of every ray (≈ 40 km on Earth); the march adapts it from there.
const CAP_START_RAD: f64 = CAP_MAX_RAD / 8.0;
/// Margin of the terrain shell beyond the global height range, metres: the shell's spheres
/// are computed in floating point, and 1 m keeps them strictly outside the terrain.
const SHELL_MARGIN_M: f64 = 1.0;
/// Refinement steps at most (2⁻²⁰⁰ of the bracket is far below f64 resolution).
const BISECTION_STEPS_MAX: usize = 200;
/// Regula falsi steps before plain bisection takes over (it needs 4–8 on smooth terrain).
const ILLINOIS_STEPS_MAX: usize = 40;
/// How often a long cast reports its progress (and checks its time limit).
pub const PROGRESS_INTERVAL: Duration = Duration::from_millis(200);

/// Conservative bounds of a height field over a cap.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalBounds {
    pub min_m: f64,
    pub max_m: f64,
    /// Upper bound of |∇h| in the cap, metres per metre along the sphere of radius R;
    /// `f64::INFINITY` where none is known.
    pub slope_max: f64,
}

/// Split points of a terrain with detail: after 0..=[`MAX_OCTAVES`] octaves.
pub const SPLITS: usize = MAX_OCTAVES + 1;

/// A terrain split, over a cap, into a coarse part the march evaluates and fine octaves it
/// only bounds, at every split point k (module docs, "Split steps").
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScaleSplit {
    /// Split points 0..=`count` are set (`count`: the octaves in all).
    pub count: usize,
    /// Bound of the fine part's |height| anywhere in the cap, metres.
    pub fine_m: [f64; SPLITS],
    /// Bound of the coarse part's |∇h| in the cap, metres per metre along the sphere.
    pub slope_max: [f64; SPLITS],
    /// The water level the surface is raised to, if any.
    pub water_level_m: Option<f64>,
}

/// A terrain function over a sphere, as the ray caster and the metric evaluate it (f64).
pub trait HeightField: Sync {
    /// Radius R of the sphere the heights are measured from, metres.
    fn radius_m(&self) -> f64;
    /// Height above the sphere at world unit vector `u_world`, metres.
    fn height_m(&self, u_world: DVec3) -> f64;
    /// Lowest and highest height anywhere.
    fn height_range_m(&self) -> (f64, f64);
    /// Bounds over every point within `angle_rad` (great-circle angle) of `u_world`.
    fn local_bounds(&self, u_world: DVec3, angle_rad: f64) -> LocalBounds;
    /// Cap angle below which [`HeightField::local_bounds`] gets no tighter (a DEM's finest
    /// pixel); 0 when it keeps tightening.
    fn finest_bound_angle_rad(&self) -> f64;

    /// The terrain function as geometry seen from a viewer above `viewer_u` (what the
    /// reference and the metric compare against): for a terrain with procedural detail, only
    /// the octaves geometry holds at that distance (`procedural` module docs). By default the
    /// same as [`HeightField::height_m`].
    fn height_seen_m(&self, u_world: DVec3, _viewer_u: DVec3) -> f64 {
        self.height_m(u_world)
    }

    /// Bounds of [`HeightField::height_seen_m`] over a cap.
    fn local_bounds_seen(&self, u_world: DVec3, angle_rad: f64, _viewer_u: DVec3) -> LocalBounds {
        self.local_bounds(u_world, angle_rad)
    }

    /// [`HeightField::local_bounds_seen`] and, for a terrain made of octaves, its
    /// [`ScaleSplit`] over the same cap (None: the march takes whole-terrain steps only).
    fn local_bounds_split_seen(
        &self,
        u_world: DVec3,
        angle_rad: f64,
        viewer_u: DVec3,
    ) -> (LocalBounds, Option<ScaleSplit>) {
        (self.local_bounds_seen(u_world, angle_rad, viewer_u), None)
    }

    /// [`HeightField::height_seen_m`] and, where the field splits ([`ScaleSplit`]), the coarse
    /// part's height of every split point k in `coarse_m[k]` (before the water).
    fn height_seen_split_m(
        &self,
        u_world: DVec3,
        viewer_u: DVec3,
        _coarse_m: &mut [f64; SPLITS],
    ) -> f64 {
        self.height_seen_m(u_world, viewer_u)
    }
}

impl HeightField for Terrain {
    fn radius_m(&self) -> f64 {
        Terrain::radius_m(self)
    }

    fn height_m(&self, u_world: DVec3) -> f64 {
        Terrain::height_m(self, u_world)
    }

    fn height_range_m(&self) -> (f64, f64) {
        Terrain::height_range_m(self)
    }

    fn local_bounds(&self, u_world: DVec3, angle_rad: f64) -> LocalBounds {
        let base = base_bounds(self, u_world, angle_rad);
        let ground = match self.detail() {
            None => base,
            Some(d) => {
                let lambda = d.lambda_full();
                let (b, slope) = d.bounds_near(u_world, angle_rad, lambda);
                LocalBounds {
                    min_m: base.min_m - b,
                    max_m: base.max_m + b,
                    slope_max: base.slope_max + slope,
                }
            }
        };
        with_water_bounds(ground, self.water_level_m())
    }

    fn height_seen_m(&self, u_world: DVec3, viewer_u: DVec3) -> f64 {
        self.height_for_viewer_m(u_world, viewer_u)
    }

    /// The detail's bounds for the octaves seen anywhere in the cap (λ at its point nearest
    /// the viewer), plus the slope of λ's own change with distance: where an octave fades in,
    /// ∂/∂s Σ w_k t_k = t_⌊λ⌋·∂λ/∂s with |∂λ/∂s| = 1/(s·ln r) (none where λ is clamped at n,
    /// within κ⁻¹ of the floor's cell of the viewer). |t_⌊λ(s)⌋|/s ≤ a_⌊λ(s)⌋·m/s is largest
    /// at the cap's nearest point (a_k/s_k grows as r^{k(1−H)} with H ≤ 1).
    fn local_bounds_seen(&self, u_world: DVec3, angle_rad: f64, viewer_u: DVec3) -> LocalBounds {
        self.local_bounds_split_seen(u_world, angle_rad, viewer_u).0
    }

    /// The split's fine part: the octaves from k on, at most σ_max·Σ_{j≥k} w_j(λ_max)·a_j·(1 +
    /// g_h) anywhere in the cap (weights only fall with λ). Its coarse part's slope: the base's,
    /// |∇σ|·|Σ_{j<k}| + σ_max·|∇Σ_{j<k}|, and the fade of λ (as for the whole terrain).
    fn local_bounds_split_seen(
        &self,
        u_world: DVec3,
        angle_rad: f64,
        viewer_u: DVec3,
    ) -> (LocalBounds, Option<ScaleSplit>) {
        let base = base_bounds(self, u_world, angle_rad);
        let Some(d) = self.detail() else {
            return (with_water_bounds(base, self.water_level_m()), None);
        };
        let arc = sphere::great_circle_distance_m(u_world, viewer_u, 1.0);
        let r = d.radius_m();
        let arc_min_m = (arc - angle_rad).max(0.0) * r;
        let arc_max_m = (arc + angle_rad) * r;
        let lambda_hi = d.lambda_at_arc_m(arc_min_m);
        let lambda_lo = d.lambda_at_arc_m(arc_max_m);
        let relief = d.roughness().bounds_near(u_world, angle_rad);
        let (d_lo, d_hi, slope) = d.bounds_near_tight(u_world, angle_rad, lambda_hi, relief);
        let (_, relief_hi, relief_slope) = relief;
        let sigma_hi = d.amplitude_for_relief_m(relief_hi);
        let fade_slope = if lambda_lo >= d.lambda_full() || d.octave_count() == 0 {
            0.0
        } else {
            let p = d.params();
            let floor_cell = d.octaves().last().map_or(0.0, |o| o.cell_m);
            let s_eff = arc_min_m.max(floor_cell / p.geometry_cut);
            let k = (lambda_hi.floor() as usize).min(d.octave_count() - 1);
            sigma_hi * (1.0 + p.height_roughness) * d.octaves()[k].amplitude
                / (s_eff * p.lacunarity.ln())
        };
        let split = (d.octave_count() > 0 && base.slope_max.is_finite()).then(|| {
            let b = d.split_bounds(lambda_hi);
            let sigma_slope = d.params().roughness_gain * d.relief_scale() * relief_slope;
            let mut split = ScaleSplit {
                count: b.count,
                fine_m: [0.0; SPLITS],
                slope_max: [0.0; SPLITS],
                water_level_m: self.water_level_m(),
            };
            for k in 0..=b.count {
                split.fine_m[k] = sigma_hi * b.amplitude[k];
                split.slope_max[k] =
                    base.slope_max + sigma_hi * b.slope[k] + sigma_slope * b.coarse[k] + fade_slope;
            }
            split
        });
        let base = tighten(base, self.base_height_m(u_world), angle_rad * r);
        let ground = LocalBounds {
            min_m: base.min_m + d_lo,
            max_m: base.max_m + d_hi,
            slope_max: base.slope_max + slope + fade_slope,
        };
        (with_water_bounds(ground, self.water_level_m()), split)
    }

    /// Bit for bit [`Terrain::height_for_viewer_m`] (the same sums in the same order).
    fn height_seen_split_m(
        &self,
        u_world: DVec3,
        viewer_u: DVec3,
        coarse_m: &mut [f64; SPLITS],
    ) -> f64 {
        let Some(d) = self.detail() else {
            return self.height_seen_m(u_world, viewer_u);
        };
        let base = self.base_height_m(u_world);
        let arc = sphere::great_circle_distance_m(u_world, viewer_u, 1.0);
        let h = base + detail_prefixes_m(d, u_world, d.lambda_at_angle(arc), base, coarse_m);
        crate::terrain::with_water(h, self.water_level_m())
    }

    fn finest_bound_angle_rad(&self) -> f64 {
        if let Some(d) = self.detail() {
            // The detail's bounds tighten down to its floor, and the base's with them
            // (centre ± slope × radius).
            return d.params().floor_m / d.radius_m();
        }
        match self.base() {
            Base::Analytic(_) => 0.0,
            Base::Dem(d) => d.pyramid().grid(0).dlat_deg.to_radians(),
        }
    }
}

/// σ(u)·Σ_k w_k t_k, and base + σ(u)·Σ_{j<k} w_j t_j in `coarse_m[k]` for k = 0..=n.
fn detail_prefixes_m(
    d: &Detail,
    u: DVec3,
    lambda: f64,
    base_m: f64,
    coarse_m: &mut [f64; SPLITS],
) -> f64 {
    let n = d.octave_count();
    let sigma = d.amplitude_m(u);
    if sigma == 0.0 {
        coarse_m[..=n].fill(base_m);
        return 0.0;
    }
    let mut prefixes = [0.0; SPLITS];
    d.normalized_prefixes(u, lambda, &mut prefixes);
    for k in 0..=n {
        coarse_m[k] = base_m + sigma * prefixes[k];
    }
    sigma * prefixes[n]
}

/// Bounds of a field with slope bound L over a cap of radius ρ metres around a point of
/// height h: also within h ± L·ρ (tighter than min/max planes on caps smaller than a pixel).
fn tighten(b: LocalBounds, centre_m: f64, radius_m: f64) -> LocalBounds {
    if !b.slope_max.is_finite() {
        return b;
    }
    let spread = b.slope_max * radius_m * 1.000_001 + 1e-9;
    LocalBounds {
        min_m: b.min_m.max(centre_m - spread),
        max_m: b.max_m.min(centre_m + spread),
        slope_max: b.slope_max,
    }
}

/// Bounds of max(h, water) from those of h: min and max raised to the water level; the slope
/// bound holds unchanged (max of a field and a constant is no steeper than the field), and is
/// 0 where the whole cap lies under water (the surface is the flat sea there, whatever the
/// ground below: the open sea near a pole needs no slope bound of the sea floor).
fn with_water_bounds(b: LocalBounds, water_level_m: Option<f64>) -> LocalBounds {
    let (min_m, max_m) = crate::terrain::bounds_with_water((b.min_m, b.max_m), water_level_m);
    let under_water = water_level_m.is_some_and(|w| b.max_m <= w);
    LocalBounds {
        min_m,
        max_m,
        slope_max: if under_water { 0.0 } else { b.slope_max },
    }
}

fn base_bounds(t: &Terrain, u_world: DVec3, angle_rad: f64) -> LocalBounds {
    match t.base() {
        Base::Analytic(p) => analytic_bounds(p, u_world, angle_rad),
        Base::Dem(d) => dem_bounds(d, u_world, angle_rad),
    }
}

/// The analytic planet's bounds (its own Lipschitz spread) and slope: each scale's product of
/// sines has a gradient of at most 2·A·ω per radian of arc, i.e. 2·A·ω/R per metre.
fn analytic_bounds(p: &AnalyticPlanet, u_world: DVec3, angle_rad: f64) -> LocalBounds {
    let (min_m, max_m) = p.height_bounds_near_m(u_world, angle_rad);
    let slope_max = p
        .scales
        .iter()
        .map(|s| 2.0 * s.amplitude_m * s.omega / p.radius_m)
        .sum();
    LocalBounds {
        min_m,
        max_m,
        slope_max,
    }
}

/// A DEM's bounds from the pyramid's min/max planes, over the cap widened by one finest-cell
/// diagonal so that they also hold at every corner of every finest cell touching the cap.
///
/// The terrain is bilinear in (lat, lon) between pixel centres, so within a cell each partial
/// derivative is a convex combination of corner differences, each at most max − min: the
/// slope is at most (max − min)/R · hypot(1/Δlat, 1/(cos lat·Δlon)) with the highest latitude
/// of the cells. Towards a pole ([`PoleEnd`]):
///
/// - a [`PoleEnd::Cap`] (the outermost row short of the pole, blended linearly over the gap
///   to the row's mean): there Δlat becomes the gap, and the cap is widened to reach the pole
///   so that the bounds hold for that mean too; cos lat ≥ cos(row lat) as below.
/// - a [`PoleEnd::ConstantRow`] (ETOPO5): between the pole row's value c and the next row's
///   bilinear g(lon), at colatitude x ≤ Δlat, h = c + (x/Δlat)·(g − c). Its gradient is
///   (g − c)/(R·Δlat) along the meridian and (x/Δlat)·g′/(R·sin x) across it; x/sin x grows
///   with x, so (x/Δlat)/sin x ≤ 1/sin Δlat = 1/cos(next row's latitude). The formula holds
///   with that latitude as the highest, and the cap, reaching the pole, reads both rows.
/// - [`PoleEnd::Open`]: no bound.
fn dem_bounds(d: &DemTerrain, u_world: DVec3, angle_rad: f64) -> LocalBounds {
    let pyramid = d.pyramid();
    let g = pyramid.grid(0);
    let (phi, theta, _) = sphere::phi_theta_height_from_ecef_m(u_world, 1.0);
    let (lat_deg, lon_deg) = sphere::lat_lon_deg_from_phi_theta(phi, theta);
    let diagonal_deg = g.dlat_deg.hypot(g.dlon_deg);
    let mut radius_deg = angle_rad.to_degrees() + diagonal_deg;
    // Per pole (north, south): the outermost row's |latitude| and how the terrain ends there.
    let rows_lat_deg = [g.lat0_deg, -g.lat_of_row((g.rows - 1) as f64)];
    let ends = d.pole_ends();
    // The cap's extent towards each pole, as a latitude on that side (beyond 90: past it).
    let extent_deg = |radius: f64| [lat_deg + radius, radius - lat_deg];
    let reaches = |radius: f64| {
        let e = extent_deg(radius);
        [e[0] > rows_lat_deg[0], e[1] > rows_lat_deg[1]]
    };
    for (pole, reached) in reaches(radius_deg).into_iter().enumerate() {
        if reached && matches!(ends[pole], PoleEnd::Cap(_)) {
            radius_deg = radius_deg.max(90.0 - extent_deg(0.0)[pole] + diagonal_deg);
        }
    }
    let level = pyramid.level_for_spacing(radius_deg / 4.0);
    let region = Region::Cap {
        lat_deg,
        lon_deg,
        radius_rad: radius_deg.to_radians(),
    };
    let Some(b) = pyramid.min_max_in(region, level) else {
        // Wholly outside the data: sea level, flat.
        return LocalBounds {
            min_m: 0.0,
            max_m: 0.0,
            slope_max: 0.0,
        };
    };
    if !b.complete {
        // Partly outside: the data's edge steps to sea level, no slope bound.
        return LocalBounds {
            min_m: b.min_m.min(0.0),
            max_m: b.max_m.max(0.0),
            slope_max: f64::INFINITY,
        };
    }
    // The highest latitude the formula needs on each side, and Δlat (a pole cap's gap).
    let mut dlat_deg = g.dlat_deg;
    let mut top_lat_deg = 0.0f64;
    let extent = extent_deg(radius_deg);
    for (pole, reached) in reaches(radius_deg).into_iter().enumerate() {
        let top = if !reached {
            extent[pole]
        } else {
            match ends[pole] {
                PoleEnd::Cap(c) => {
                    // In the blend zone (1 − t)/cos lat ≤ 1/cos(row lat) (to 1e-6 for a gap ≤ 1°).
                    dlat_deg = dlat_deg.min(90.0 - rows_lat_deg[pole]);
                    c.row_lat_deg.abs()
                }
                PoleEnd::ConstantRow { .. } => 90.0 - g.dlat_deg,
                PoleEnd::Open => {
                    // A grid ending short of a pole, or a pole row of differing values.
                    return LocalBounds {
                        min_m: b.min_m,
                        max_m: b.max_m,
                        slope_max: f64::INFINITY,
                    };
                }
            }
        };
        top_lat_deg = top_lat_deg.max(top);
    }
    let cos_top = top_lat_deg.to_radians().cos();
    let r = d.radius_m();
    let slope_max = 1.000_01 * (b.max_m - b.min_m) / r
        * (1.0 / dlat_deg.to_radians()).hypot(1.0 / (cos_top * g.dlon_deg.to_radians()));
    LocalBounds {
        min_m: b.min_m,
        max_m: b.max_m,
        slope_max,
    }
}

/// A sphere of constant height: the geometric core's test case (the first hit is the
/// closed-form ray–sphere intersection).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConstantHeight {
    pub radius_m: f64,
    pub height_m: f64,
}

impl HeightField for ConstantHeight {
    fn radius_m(&self) -> f64 {
        self.radius_m
    }

    fn height_m(&self, _u_world: DVec3) -> f64 {
        self.height_m
    }

    fn height_range_m(&self) -> (f64, f64) {
        (self.height_m, self.height_m)
    }

    fn local_bounds(&self, _u_world: DVec3, _angle_rad: f64) -> LocalBounds {
        LocalBounds {
            min_m: self.height_m,
            max_m: self.height_m,
            slope_max: 0.0,
        }
    }

    fn finest_bound_angle_rad(&self) -> f64 {
        0.0
    }
}

/// Accuracy and threads of the ray caster.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayCastOptions {
    /// The unproven step s_min, in pixels at the step's distance (see the module's guarantee).
    pub min_step_px: f64,
    /// Refinement stops once the crossing is bracketed to this many pixels.
    pub refine_px: f64,
    /// Worker threads for [`RayCaster::cast`]; 0: one per available core.
    pub threads: usize,
}

impl Default for RayCastOptions {
    fn default() -> Self {
        Self {
            min_step_px: 0.25,
            refine_px: 1e-4,
            threads: 0,
        }
    }
}

/// What one ray sees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RayHit {
    Sky,
    Terrain {
        /// Metres from the eye along the unit ray.
        distance_m: f64,
        /// The surface point in view space (planet centre at the origin).
        point_view_m: DVec3,
    },
}

impl RayHit {
    pub fn distance_m(&self) -> Option<f64> {
        match self {
            RayHit::Sky => None,
            RayHit::Terrain { distance_m, .. } => Some(*distance_m),
        }
    }
}

/// One pixel of a [`ReferenceImage`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ReferencePixel {
    /// Not in the [`PixelSet`] that was cast.
    NotCast,
    Sky,
    Terrain {
        /// Metres from the eye along the pixel's unit ray.
        distance_m: f64,
    },
}

/// Which pixels to cast (a subset keeps tests and large frames fast).
#[derive(Clone, Debug, PartialEq)]
pub enum PixelSet {
    All,
    /// Pixels whose x and y are both multiples of k (k ≥ 1).
    Every(u32),
    /// These pixels (each must lie inside the viewport).
    List(Vec<(u32, u32)>),
}

impl PixelSet {
    /// The pixels of a `width` × `height` viewport, row by row.
    pub fn pixels(&self, width: u32, height: u32) -> Vec<(u32, u32)> {
        match self {
            PixelSet::All => PixelSet::Every(1).pixels(width, height),
            PixelSet::Every(k) => {
                let k = (*k).max(1) as usize;
                (0..height)
                    .step_by(k)
                    .flat_map(|y| (0..width).step_by(k).map(move |x| (x, y)))
                    .collect()
            }
            PixelSet::List(list) => list.clone(),
        }
    }
}

/// The reference of a `width` × `height` viewport, row-major from the top-left.
#[derive(Clone, Debug, PartialEq)]
pub struct ReferenceImage {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<ReferencePixel>,
    /// March steps of the whole cast ([`RayCaster::cast_ray_counted`]).
    pub steps: u64,
}

impl ReferenceImage {
    pub fn pixel(&self, x: u32, y: u32) -> ReferencePixel {
        self.pixels[(y * self.width + x) as usize]
    }

    /// Pixels cast (terrain or sky).
    pub fn cast_count(&self) -> usize {
        self.pixels
            .iter()
            .filter(|p| **p != ReferencePixel::NotCast)
            .count()
    }

    /// Pixels whose ray hits the terrain.
    pub fn terrain_count(&self) -> usize {
        self.pixels
            .iter()
            .filter(|p| matches!(p, ReferencePixel::Terrain { .. }))
            .count()
    }
}

/// The ray caster for one camera and viewport.
pub struct RayCaster<'a, H: HeightField + ?Sized> {
    field: &'a H,
    camera: Camera,
    width: u32,
    height: u32,
    options: RayCastOptions,
    eye_view_m: DVec3,
    /// Rows of camera_from_view (the transpose of the rotation view_from_camera).
    camera_from_view: DMat3,
    world_from_view: DMat3,
    /// The viewer's direction in world space (view space +z).
    viewer_u: DVec3,
    /// Focal length in pixels: pixels per radian at the image centre.
    focal_px: f64,
    radius_m: f64,
    shell_top_m: f64,
    shell_bottom_m: f64,
}

impl<'a, H: HeightField + ?Sized> RayCaster<'a, H> {
    /// A caster for `camera` (altitude above `field`'s sphere) and a `width` × `height`
    /// viewport, with the default [`RayCastOptions`].
    pub fn new(field: &'a H, camera: &Camera, width: u32, height: u32) -> Self {
        let radius_m = field.radius_m();
        let (lo_m, hi_m) = field.height_range_m();
        Self {
            field,
            camera: *camera,
            width,
            height,
            options: RayCastOptions::default(),
            eye_view_m: camera.eye_view_at_radius_m(radius_m),
            camera_from_view: camera.view_from_camera().transpose(),
            world_from_view: camera.view_frame().world_from_view,
            viewer_u: camera.view_frame().world_from_view * DVec3::Z,
            focal_px: crate::geo::projection::focal_length_px(height, camera.fov_y_rad()),
            radius_m,
            shell_top_m: radius_m + hi_m + SHELL_MARGIN_M,
            shell_bottom_m: (radius_m + lo_m - SHELL_MARGIN_M).max(0.0),
        }
    }

    pub fn with_options(mut self, options: RayCastOptions) -> Self {
        self.options = options;
        self
    }

    pub fn eye_view_m(&self) -> DVec3 {
        self.eye_view_m
    }

    /// The unit ray through the centre of pixel (x, y), view space (as the renderer's
    /// projection: [`pixel_ray_view`]).
    pub fn pixel_ray_view(&self, x: u32, y: u32) -> DVec3 {
        pixel_ray_view(&self.camera, x, y, self.width, self.height)
    }

    /// Pixels per radian at direction `d_view`: the focal length over cos² of the angle off
    /// the axis (the radial pixel pitch there, the finest across the pixel).
    fn pixels_per_radian_along(&self, d_view: DVec3) -> f64 {
        let cos_off_axis = -(self.camera_from_view * d_view).z;
        if cos_off_axis > 0.0 {
            self.focal_px / (cos_off_axis * cos_off_axis)
        } else {
            self.focal_px
        }
    }

    pub fn cast_pixel(&self, x: u32, y: u32) -> RayHit {
        self.cast_ray(self.pixel_ray_view(x, y))
    }

    /// The first hit along `direction_view` (normalised here) from the eye.
    pub fn cast_ray(&self, direction_view: DVec3) -> RayHit {
        self.cast_ray_counted(direction_view).0
    }

    /// [`RayCaster::cast_ray`] and the march steps it took: the loop's iterations and the
    /// refinement's, each one terrain evaluation or bounds query (the march's cost, free of
    /// the machine's speed).
    pub fn cast_ray_counted(&self, direction_view: DVec3) -> (RayHit, u64) {
        let d = direction_view.normalize();
        let pixels_per_rad = self.pixels_per_radian_along(d);
        let mut steps = 0;
        let hit = match self.march(d, pixels_per_rad, &mut steps) {
            Some(distance_m) => RayHit::Terrain {
                distance_m,
                point_view_m: self.eye_view_m + distance_m * d,
            },
            None => RayHit::Sky,
        };
        (hit, steps)
    }

    /// Casts `pixels` on [`RayCastOptions::threads`] threads; results in the same order.
    pub fn cast_pixels(&self, pixels: &[(u32, u32)]) -> Vec<RayHit> {
        match self.cast_pixels_watched(pixels, None, &mut |_, _| {}) {
            Ok((hits, _)) => hits,
            Err(_) => unreachable!("a cast without a time limit runs to the end"),
        }
    }

    /// [`RayCaster::cast_pixels`] with the march steps in all, `progress(pixels done, pixels)`
    /// called on this thread about every [`PROGRESS_INTERVAL`], and a time limit: past
    /// `deadline` the workers stop and the pixels done so far are returned as the error.
    fn cast_pixels_watched(
        &self,
        pixels: &[(u32, u32)],
        deadline: Option<Instant>,
        progress: &mut dyn FnMut(usize, usize),
    ) -> Result<(Vec<RayHit>, u64), usize> {
        // A chunk of a row at 1080p: small enough to balance two cores over a horizon band.
        const CHUNK: usize = 256;
        let threads = match self.options.threads {
            0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
            n => n,
        };
        let next = AtomicUsize::new(0);
        let done = AtomicUsize::new(0);
        let stop = AtomicBool::new(false);
        let steps = AtomicU64::new(0);
        let (finished, results) = mpsc::channel::<Vec<(usize, Vec<RayHit>)>>();
        let work = || {
            let mut out = Vec::new();
            loop {
                let chunk = next.fetch_add(1, Ordering::Relaxed);
                let start = chunk * CHUNK;
                if start >= pixels.len() || stop.load(Ordering::Relaxed) {
                    break;
                }
                let part = &pixels[start..(start + CHUNK).min(pixels.len())];
                let mut hits = Vec::with_capacity(part.len());
                let mut chunk_steps = 0;
                for &(x, y) in part {
                    // Checked per pixel: one pixel costs at most milliseconds, a chunk more.
                    if stop.load(Ordering::Relaxed) || deadline.is_some_and(|d| Instant::now() >= d)
                    {
                        stop.store(true, Ordering::Relaxed);
                        break;
                    }
                    let (hit, n) = self.cast_ray_counted(self.pixel_ray_view(x, y));
                    hits.push(hit);
                    chunk_steps += n;
                }
                steps.fetch_add(chunk_steps, Ordering::Relaxed);
                done.fetch_add(hits.len(), Ordering::Relaxed);
                out.push((chunk, hits));
            }
            // The receiver outlives the workers (same scope).
            let _ = finished.send(out);
        };
        let workers = threads.max(1);
        // Told at once, so that a display's clock starts with the cast.
        progress(0, pixels.len());
        let mut chunks: Vec<(usize, Vec<RayHit>)> = std::thread::scope(|s| {
            let handles: Vec<_> = (0..workers).map(|_| s.spawn(work)).collect();
            // This thread watches: progress, the deadline; the workers send when they end.
            let mut all = Vec::new();
            let mut ended = 0;
            while ended < workers {
                match results.recv_timeout(PROGRESS_INTERVAL) {
                    Ok(out) => {
                        all.extend(out);
                        ended += 1;
                    }
                    // A worker panicked (its sender dropped unsent): join re-raises it below.
                    Err(mpsc::RecvTimeoutError::Disconnected) => break,
                    Err(mpsc::RecvTimeoutError::Timeout) => {}
                }
                if deadline.is_some_and(|d| Instant::now() >= d) {
                    stop.store(true, Ordering::Relaxed);
                }
                progress(done.load(Ordering::Relaxed), pixels.len());
            }
            for h in handles {
                if let Err(p) = h.join() {
                    std::panic::resume_unwind(p);
                }
            }
            all
        });
        let done = done.load(Ordering::Relaxed);
        if done < pixels.len() {
            return Err(done);
        }
        chunks.sort_by_key(|(chunk, _)| *chunk);
        let hits = chunks.into_iter().flat_map(|(_, hits)| hits).collect();
        Ok((hits, steps.load(Ordering::Relaxed)))
    }

    /// The reference image of `set` (pixels outside it are [`ReferencePixel::NotCast`]).
    ///
    /// # Panics
    /// If a listed pixel lies outside the viewport.
    pub fn cast(&self, set: &PixelSet) -> ReferenceImage {
        match self.cast_within(set, None, |_, _| {}) {
            Ok(image) => image,
            Err(_) => unreachable!("a cast without a time limit runs to the end"),
        }
    }

    /// [`RayCaster::cast`] within `time_limit` (None: none), reporting `progress(pixels
    /// done, pixels)` about every [`PROGRESS_INTERVAL`] on this thread. A cast still running at
    /// the limit stops and is [`MeasureError::TimedOut`].
    ///
    /// # Panics
    /// If a listed pixel lies outside the viewport.
    pub fn cast_within(
        &self,
        set: &PixelSet,
        time_limit: Option<Duration>,
        mut progress: impl FnMut(usize, usize),
    ) -> Result<ReferenceImage, MeasureError> {
        let list = set.pixels(self.width, self.height);
        if let Some((x, y)) = list
            .iter()
            .find(|(x, y)| *x >= self.width || *y >= self.height)
        {
            panic!(
                "pixel ({x}, {y}) outside the {}×{} viewport",
                self.width, self.height
            );
        }
        let started = Instant::now();
        let deadline = time_limit.map(|limit| started + limit);
        let (hits, steps) = self
            .cast_pixels_watched(&list, deadline, &mut progress)
            .map_err(|done| MeasureError::TimedOut {
                limit_s: time_limit.map_or(0.0, |l| l.as_secs_f64()),
                done,
                total: list.len(),
            })?;
        let mut pixels = vec![ReferencePixel::NotCast; self.width as usize * self.height as usize];
        for (&(x, y), hit) in list.iter().zip(hits) {
            pixels[(y * self.width + x) as usize] = match hit {
                RayHit::Sky => ReferencePixel::Sky,
                RayHit::Terrain { distance_m, .. } => ReferencePixel::Terrain { distance_m },
            };
        }
        Ok(ReferenceImage {
            width: self.width,
            height: self.height,
            pixels,
            steps,
        })
    }

    /// Clearance of view-space point `p` above the terrain: |p| − R − h(p/|p|).
    fn clearance_m(&self, p: DVec3) -> f64 {
        let r = p.length();
        r - self.radius_m
            - self
                .field
                .height_seen_m(self.world_from_view * (p / r), self.viewer_u)
    }

    /// [`RayCaster::clearance_m`], with the coarse heights of every split at `p`.
    fn clearance_split_m(&self, p: DVec3, coarse_m: &mut [f64; SPLITS]) -> f64 {
        let r = p.length();
        r - self.radius_m
            - self.field.height_seen_split_m(
                self.world_from_view * (p / r),
                self.viewer_u,
                coarse_m,
            )
    }

    /// The distance to the first crossing along the unit ray `d`, or None (sky). See the
    /// module documentation for the steps and the guarantee.
    fn march(&self, d: DVec3, pixels_per_rad: f64, steps: &mut u64) -> Option<f64> {
        let e = self.eye_view_m;
        if self.clearance_m(e) <= 0.0 {
            return Some(0.0);
        }
        let (t_enter, t_exit) = ray_sphere(e, d, self.shell_top_m)?;
        if t_exit <= 0.0 {
            return None;
        }
        // Below the shell's floor the ray is under the terrain: a crossing lies before it.
        let t_floor = ray_sphere(e, d, self.shell_bottom_m)
            .map(|(near, _)| near)
            .filter(|&near| near >= 0.0 && near < t_exit);
        let t_end = t_floor.unwrap_or(t_exit);
        let step_per_m = self.options.min_step_px / pixels_per_rad;
        let s_min = |t: f64| (step_per_m * t).max(4.0 * f64::EPSILON * (e.length() + t));
        let finest_rad = self.field.finest_bound_angle_rad();
        let ground_per_ray_m = self.radius_m / self.shell_bottom_m;

        let mut t = t_enter.max(0.0);
        let mut alpha = CAP_START_RAD;
        let mut cap: Option<Cap> = None;
        // The clearance where the last step landed, with the coarse heights of every split
        // there (so that a step's end is not evaluated twice).
        let mut landed: Option<(f64, f64)> = None;
        let mut coarse_m = [0.0; SPLITS];
        loop {
            *steps += 1;
            if t >= t_end {
                return t_floor.map(|_| t_end);
            }
            let p = e + t * d;
            let r = p.length();
            let u = p / r;
            let alpha_min = finest_rad.max(s_min(t) / r);
            let c = match cap {
                Some(c) if t < c.end_t => c,
                _ => {
                    let a = alpha.clamp(alpha_min, CAP_MAX_RAD);
                    let (bounds, split) = self.field.local_bounds_split_seen(
                        self.world_from_view * u,
                        a,
                        self.viewer_u,
                    );
                    let c = Cap {
                        alpha_rad: a,
                        end_t: t + cap_exit_m(u, r, d, a),
                        bounds,
                        split,
                    };
                    cap = Some(c);
                    c
                }
            };
            // Cap step: above the cap's max, to its edge or down to the max.
            let top_m = self.radius_m + c.bounds.max_m;
            if r > top_m {
                let to_top = descent_to_sphere_m(p, r, d, top_m);
                let t_next = (t + to_top).min(c.end_t).min(t_end);
                if t_next > t {
                    let left_cap = c.end_t <= t + to_top;
                    alpha = if left_cap {
                        c.alpha_rad * 2.0
                    } else {
                        c.alpha_rad / 4.0
                    };
                    t = t_next;
                    cap = None;
                    continue;
                }
            }
            let f = match landed {
                Some((landed_t, f)) if landed_t == t => f,
                _ => self.clearance_split_m(p, &mut coarse_m),
            };
            landed = Some((t, f));
            if f <= 0.0 {
                return Some(t);
            }
            // A cap much wider than a Lipschitz step can reach: try a smaller one first.
            let alpha_fit = alpha_min.max(2.0 * f / self.shell_bottom_m);
            if c.alpha_rad > 2.0 * alpha_fit {
                // Straight to the fitting cap: each bounds query costs a pyramid and a relief
                // lookup, and a rough surface's tight bounds only come with a small cap.
                alpha = alpha_fit;
                cap = None;
                continue;
            }
            // Lipschitz step within the cap, or the minimum step. The clearance falls at most
            // at −dr/ds + L·R/r_min per metre, and dr/ds only grows along a line (r is convex).
            let descent = (-d.dot(u)).max(0.0);
            let mut safe = f / (descent + c.bounds.slope_max * ground_per_ray_m);
            if let Some(split) = &c.split {
                // Split steps: the coarse part evaluated here, the fine part by its bound.
                for (k, &coarse_k) in coarse_m.iter().enumerate().take(split.count + 1) {
                    let mut top_m = coarse_k + split.fine_m[k];
                    if let Some(w) = split.water_level_m {
                        top_m = top_m.max(w);
                    }
                    let f_k = r - self.radius_m - top_m;
                    if f_k > 0.0 {
                        let falls_per_m = descent + split.slope_max[k] * ground_per_ray_m;
                        safe = safe.max(f_k / falls_per_m);
                    }
                }
            }
            let safe = safe.min(c.end_t - t);
            let t_next = (t + safe.max(s_min(t))).min(t_end);
            let f_next = self.clearance_split_m(e + t_next * d, &mut coarse_m);
            if f_next <= 0.0 {
                return Some(self.refine(d, (t, f), (t_next, f_next), pixels_per_rad, steps));
            }
            landed = Some((t_next, f_next));
            t = t_next;
            if t >= c.end_t {
                alpha = 2.0 * alpha_min.max(2.0 * f_next / self.shell_bottom_m);
                cap = None;
            }
        }
    }

    /// The crossing in [a, b] (clearance f_a > 0, f_b ≤ 0), bracketed to `refine_px` by the
    /// Illinois variant of regula falsi (superlinear, both ends converge), falling back to
    /// bisection should it stall. Returns the bracket's midpoint.
    fn refine(
        &self,
        d: DVec3,
        (mut a, mut f_a): (f64, f64),
        (mut b, mut f_b): (f64, f64),
        pixels_per_rad: f64,
        steps: &mut u64,
    ) -> f64 {
        let e = self.eye_view_m;
        let mut last_side = 0i8;
        for step in 0..BISECTION_STEPS_MAX {
            *steps += 1;
            let tolerance_m = (self.options.refine_px * b / pixels_per_rad)
                .max(4.0 * f64::EPSILON * (e.length() + b));
            if b - a <= tolerance_m {
                break;
            }
            let secant = (a * f_b - b * f_a) / (f_b - f_a);
            let m = if step < ILLINOIS_STEPS_MAX && secant > a && secant < b {
                secant
            } else {
                0.5 * (a + b)
            };
            let f_m = self.clearance_m(e + m * d);
            if f_m > 0.0 {
                (a, f_a) = (m, f_m);
                if last_side == 1 {
                    f_b *= 0.5;
                }
                last_side = 1;
            } else {
                (b, f_b) = (m, f_m);
                if last_side == -1 {
                    f_a *= 0.5;
                }
                last_side = -1;
            }
        }
        0.5 * (a + b)
    }
}

/// The cap the march holds bounds for: valid for the ray while t < `end_t`.
#[derive(Clone, Copy, Debug)]
struct Cap {
    alpha_rad: f64,
    end_t: f64,
    bounds: LocalBounds,
    split: Option<ScaleSplit>,
}

/// Both distances where the line o + t·d (unit d) meets the sphere of `radius_m` about the
/// origin, nearer first, or None if it misses. Cancellation-free: the discriminant is
/// (ρ − q)(ρ + q) with q the line's distance from the centre, and the nearer root comes
/// from the product of the roots.
fn ray_sphere(o: DVec3, d: DVec3, radius_m: f64) -> Option<(f64, f64)> {
    let b = o.dot(d);
    let q = (o - b * d).length();
    if q > radius_m {
        return None;
    }
    let h = ((radius_m - q) * (radius_m + q)).sqrt();
    let r = o.length();
    let c = (r - radius_m) * (r + radius_m);
    // One root without cancellation (−b and ∓h of the same sign), the other from c.
    let (one, other) = if b < 0.0 {
        let far = -b + h;
        (far, c / far)
    } else {
        let near = -b - h;
        (near, if near != 0.0 { c / near } else { 0.0 })
    };
    let (near, far) = (one.min(other), one.max(other));
    Some((near, far))
}

/// How far the ray from `p` (|p| = r > ρ) along unit `d` goes before it first reaches the
/// sphere of radius ρ = `radius_m`; +∞ if never.
fn descent_to_sphere_m(p: DVec3, r: f64, d: DVec3, radius_m: f64) -> f64 {
    let b = p.dot(d);
    if b >= 0.0 {
        return f64::INFINITY;
    }
    let q = (p - b * d).length();
    if q > radius_m {
        return f64::INFINITY;
    }
    let h = ((radius_m - q) * (radius_m + q)).sqrt();
    (r - radius_m) * (r + radius_m) / (-b + h)
}

/// How far the ray from p = r·u along unit `d` goes before it leaves the cap of angle α
/// around u: the angle it subtends is atan(s·d⊥ / (r + s·d‖)), which grows monotonically.
fn cap_exit_m(u: DVec3, r: f64, d: DVec3, alpha_rad: f64) -> f64 {
    let along = d.dot(u);
    let across = (d - along * u).length();
    let tan_alpha = alpha_rad.tan();
    let denominator = across - tan_alpha * along;
    if denominator <= 0.0 {
        f64::INFINITY
    } else {
        r * tan_alpha / denominator
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ray_sphere_roots_are_accurate() {
        let radius = 6.371e6;
        // From 1 mm above the surface straight down: the near root is 1 mm.
        let o = DVec3::new(0.0, 0.0, radius + 1e-3);
        let (near, far) = ray_sphere(o, DVec3::NEG_Z, radius).unwrap();
        assert!((near - 1e-3).abs() < 1e-9, "{near}");
        assert!((far - (2.0 * radius + 1e-3)).abs() < 1e-6);
        // From inside: one root behind.
        let (near, far) = ray_sphere(DVec3::ZERO, DVec3::X, radius).unwrap();
        assert_eq!((near, far), (-radius, radius));
        // A miss.
        assert!(ray_sphere(DVec3::new(0.0, 0.0, 2.0 * radius), DVec3::X, radius).is_none());
    }

    #[test]
    fn cap_exit_subtends_the_cap_angle() {
        let u = DVec3::Z;
        let r = 6.4e6;
        let d = DVec3::new(0.6, 0.0, -0.8);
        let alpha = 1e-3;
        let s = cap_exit_m(u, r, d, alpha);
        let q = r * u + s * d;
        let angle = u.cross(q).length().atan2(u.dot(q));
        assert!((angle - alpha).abs() < 1e-12, "{angle}");
        // Going up and out at a steep angle never leaves a wide cap.
        assert!(cap_exit_m(u, r, DVec3::new(0.1, 0.0, 0.995).normalize(), 0.3).is_infinite());
    }

    #[test]
    fn descent_reaches_the_sphere() {
        let p = DVec3::new(0.0, 0.0, 6.38e6);
        let d = DVec3::new(0.3, 0.0, -1.0).normalize();
        let s = descent_to_sphere_m(p, p.length(), d, 6.371e6);
        assert!(((p + s * d).length() - 6.371e6).abs() < 1e-6);
        assert!(descent_to_sphere_m(p, p.length(), -d, 6.371e6).is_infinite());
    }
}
