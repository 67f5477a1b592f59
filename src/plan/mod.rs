//! One frame, planned in f64 before anything reaches the GPU.
//!
//! A frame is decided in two layers:
//!
//! | layer | what it decides | where |
//! | --- | --- | --- |
//! | [`ViewPlan`] | what every LOD method shares: the viewer in map space (φv, θv), the ground under the camera and where that height came from, near plane, projection, sun, sky | here |
//! | a LOD method's plan | what that method draws and fills: for the spherical clipmap ([`ClipmapPlan`]) the levels and why, each level's texture window and the texels to refill, the ring sectors inside the frustum, the levels waiting for data | [`clipmap`] |
//!
//! A frame's plan is one of each. Nothing here touches wgpu: tests build plans on a machine with no
//! adapter. `render::gpu_data` is the one step that turns a plan into f32 GPU data, and the
//! renderer only executes it (fills, uploads, draws). Every LOD method is a [`LodMethod`]
//! ([`lod`]): a close-up method (geomipmapping, the projected grid) adds its own plan beside
//! `clipmap`, built from the same [`ViewPlan`] and [`TerrainQuery`], and tells the clipmap how
//! far its reach extends.
//!
//! Conventions: angles in radians unless the name says `_deg`; lengths in metres; view space
//! has the planet's centre at the origin and the viewer on +z̃ (spherical-clipmaps.md §3).

pub mod clipmap;
pub mod geomip;
pub mod lod;
pub mod projgrid;

use std::f64::consts::TAU;

use glam::{DMat3, DMat4, DVec3};

use crate::geo::camera::Camera;
use crate::geo::{projection, sphere};
use crate::look::Sun;
use crate::planar::projgrid::CellBounds;
use crate::terrain::Terrain;
use crate::terrain::at_hand::TilesAtHand;

pub use clipmap::{ClipmapPlan, LevelFill};
pub use geomip::{GeomipPlan, GeomipState};
pub use lod::{CloseUpPlan, LodMethod};
pub use projgrid::ProjGridPlan;

/// Which LOD method draws the ground near the viewer (`--mode`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LodMode {
    /// The spherical clipmap alone.
    #[default]
    Clipmap,
    /// Geomipmapping with geomorphing near the viewer, the clipmap beyond.
    Geomip,
    /// The error-bounded projected grid over the whole view (the clipmap's levels still fill
    /// the textures it samples, but draw nothing).
    Projgrid,
    /// Geomipmapping below [`AUTO_ON_BELOW_M`] above the terrain, the clipmap alone above
    /// [`AUTO_OFF_ABOVE_M`] (between the two the previous frame's choice holds).
    Auto,
}

/// `auto` switches to geomipmapping below this height above the terrain…
pub const AUTO_ON_BELOW_M: f64 = 1000.0;
/// …and back to the clipmap alone above this one.
pub const AUTO_OFF_ABOVE_M: f64 = 1500.0;

impl LodMode {
    /// The name `--mode` takes.
    pub fn name(self) -> &'static str {
        match self {
            LodMode::Clipmap => "clipmap",
            LodMode::Geomip => "geomip",
            LodMode::Projgrid => "projgrid",
            LodMode::Auto => "auto",
        }
    }

    /// Whether a planar method draws this frame, given the height above the terrain and
    /// whether one drew the frame before (`auto`'s hysteresis).
    pub fn planar(self, height_above_terrain_m: f64, was_planar: bool) -> bool {
        match self {
            LodMode::Clipmap => false,
            LodMode::Geomip | LodMode::Projgrid => true,
            LodMode::Auto if was_planar => height_above_terrain_m <= AUTO_OFF_ABOVE_M,
            LodMode::Auto => height_above_terrain_m < AUTO_ON_BELOW_M,
        }
    }
}

/// The LOD methods' settings.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LodSettings {
    pub mode: LodMode,
    pub geomip: crate::planar::geomip::GeomipSettings,
    pub projgrid: crate::planar::projgrid::ProjGridSettings,
}

/// Where a height the plan used came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HeightSource {
    /// The terrain function itself (the analytic planet, or a DEM sampled directly).
    Exact,
    /// The finest streamed tiles that cover the point.
    Tiles,
    /// Streamed tiles of a coarser level than the point's own, which has not arrived yet: the
    /// frame is not settled until it has.
    CoarserTiles,
}

/// The terrain questions a frame plan asks, answered either by the terrain function
/// ([`Terrain`]) or, while streaming, by the tiles at hand ([`TilesAtHand`]), so the render
/// thread never waits for the file.
pub trait TerrainQuery {
    fn radius_m(&self) -> f64;
    /// Lowest and highest terrain anywhere (the horizon bound, eq. 6).
    fn height_range_m(&self) -> (f64, f64);
    /// The height under the camera and where it came from.
    fn ground_m(&self, lat_deg: f64, lon_deg: f64) -> (f64, HeightSource);
    /// Heights bounding the terrain within `angle_rad` of the unit vector `u` (culling).
    fn height_bounds_near_m(&self, u: DVec3, angle_rad: f64) -> (f64, f64);
    /// The height the GPU draws at unit vector `u`, `arc_rad` from the viewer: the detail's
    /// octaves limited by the geometry rule λ(θ̃) there (what a close-up method's δ measures).
    fn height_drawn_m(&self, u: DVec3, arc_rad: f64) -> f64;
    /// What bounds the drawn terrain in a close-up cell: a cap of `angle_rad` around `u` whose
    /// nearest point is `arc_rad` from the viewer. By default the culling bounds, no slope.
    fn cell_bounds_m(&self, u: DVec3, angle_rad: f64, _arc_rad: f64) -> CellBounds {
        let (min_m, max_m) = self.height_bounds_near_m(u, angle_rad);
        CellBounds {
            min_m,
            max_m,
            slope: f64::INFINITY,
        }
    }
}

/// [`TerrainQuery::cell_bounds_m`] over a DEM whose nodes in the drawn cap span
/// `dem_range_m`, plus the detail drawn there: the DEM's slope bound, and the detail's
/// amplitude and slope for the octaves the nearest point draws (one more for the levels' blend;
/// ×1.5 for the textures' bilinear resampling).
pub(crate) fn dem_cell_bounds(
    dem: &crate::terrain::DemTerrain,
    detail: Option<&crate::procedural::Detail>,
    water_level_m: Option<f64>,
    (u, angle_rad, arc_rad): (DVec3, f64, f64),
    dem_range_m: (f64, f64),
) -> CellBounds {
    let (lo, hi) = dem_range_m;
    let mut slope = dem.slope_bound(u, angle_rad, hi - lo);
    let mut amplitude = 0.0;
    if let Some(d) = detail {
        let lambda = (d.lambda_at_angle(arc_rad) + 1.0).min(d.lambda_full());
        let (a, s) = d.bounds_near(u, angle_rad, lambda);
        amplitude = a;
        slope += 1.5 * s;
    }
    let (min_m, max_m) =
        crate::terrain::bounds_with_water((lo - amplitude, hi + amplitude), water_level_m);
    CellBounds {
        min_m,
        max_m,
        slope,
    }
}

impl TerrainQuery for Terrain {
    fn radius_m(&self) -> f64 {
        Terrain::radius_m(self)
    }
    fn height_range_m(&self) -> (f64, f64) {
        Terrain::height_range_m(self)
    }
    fn ground_m(&self, lat_deg: f64, lon_deg: f64) -> (f64, HeightSource) {
        (
            self.height_at_lat_lon_m(lat_deg, lon_deg),
            HeightSource::Exact,
        )
    }
    fn height_bounds_near_m(&self, u: DVec3, angle_rad: f64) -> (f64, f64) {
        Terrain::height_bounds_near_m(self, u, angle_rad)
    }
    fn cell_bounds_m(&self, u: DVec3, angle_rad: f64, arc_rad: f64) -> CellBounds {
        let Some(dem) = self.dem() else {
            let (min_m, max_m) = self.height_bounds_near_m(u, angle_rad);
            return CellBounds {
                min_m,
                max_m,
                slope: f64::INFINITY,
            };
        };
        let cap = dem.drawn_cap_rad(angle_rad, arc_rad);
        let range = dem.height_bounds_near_m(u, cap);
        dem_cell_bounds(
            dem,
            self.detail().map(|d| d.as_ref()),
            self.water_level_m(),
            (u, cap, arc_rad),
            range,
        )
    }
    fn height_drawn_m(&self, u: DVec3, arc_rad: f64) -> f64 {
        let base = self.base_height_m(u);
        let detail = self
            .detail()
            .map_or(0.0, |d| d.height_m(u, d.lambda_at_angle(arc_rad)));
        crate::terrain::with_water(base + detail, self.water_level_m())
    }
}

/// The frame plan's terrain questions, answered from the tiles at hand (never the file).
impl TerrainQuery for TilesAtHand {
    fn radius_m(&self) -> f64 {
        self.dem().radius_m()
    }
    fn height_range_m(&self) -> (f64, f64) {
        TilesAtHand::height_range_m(self)
    }
    fn ground_m(&self, lat_deg: f64, lon_deg: f64) -> (f64, HeightSource) {
        let (h, fell_back) = TilesAtHand::ground_m(self, lat_deg, lon_deg);
        let source = if fell_back {
            HeightSource::CoarserTiles
        } else {
            HeightSource::Tiles
        };
        (h, source)
    }
    fn height_drawn_m(&self, u: DVec3, arc_rad: f64) -> f64 {
        TilesAtHand::height_drawn_m(self, u, arc_rad)
    }
    fn cell_bounds_m(&self, u: DVec3, angle_rad: f64, arc_rad: f64) -> CellBounds {
        let cap = self.dem().drawn_cap_rad(angle_rad, arc_rad);
        let range = self.dem_bounds_near_m(u, cap);
        dem_cell_bounds(
            self.dem(),
            self.detail().map(|d| d.as_ref()),
            self.water_level_m(),
            (u, cap, arc_rad),
            range,
        )
    }
    fn height_bounds_near_m(&self, u: DVec3, angle_rad: f64) -> (f64, f64) {
        TilesAtHand::height_bounds_near_m(self, u, angle_rad)
    }
}

/// What every LOD method of a frame shares (f64).
#[derive(Clone, Debug, PartialEq)]
pub struct ViewPlan {
    pub camera: Camera,
    pub width_px: u32,
    pub height_px: u32,
    pub radius_m: f64,
    /// The viewer's longitude in [0, 2π) and colatitude θv (map space).
    pub phi_v_rad: f64,
    pub theta_v_rad: f64,
    /// Terrain height under the camera and where it came from.
    pub ground_m: f64,
    pub ground_source: HeightSource,
    pub height_above_terrain_m: f64,
    pub near_m: f64,
    pub aspect: f64,
    pub fov_y_rad: f64,
    /// Camera axes in view space (columns: right, up, back), and its inverse rotation.
    pub camera_from_view: DMat3,
    /// Projection (reversed-Z, infinite far plane) times the view-to-camera rotation: view-space
    /// offsets from the eye to clip space.
    pub clip_from_view: DMat4,
    /// Unit vector to the sun in view space.
    pub sun_view: DVec3,
    /// Linear RGB background: sky blue near the ground, black in space.
    pub sky_linear: [f64; 3],
}

impl ViewPlan {
    pub fn new(camera: &Camera, width_px: u32, height_px: u32, query: &dyn TerrainQuery) -> Self {
        let radius_m = query.radius_m();
        let frame = camera.view_frame();
        let (ground_m, ground_source) = query.ground_m(camera.lat_deg, camera.lon_deg);
        let height_above_terrain_m = camera.altitude_m - ground_m;
        let near_m = projection::near_plane_m(height_above_terrain_m);
        let aspect = width_px as f64 / height_px.max(1) as f64;
        let camera_from_view = camera.view_from_camera().transpose();
        let clip_from_view =
            camera.clip_from_camera(aspect, near_m) * DMat4::from_mat3(camera_from_view);
        // The fixed sun unless the look says otherwise ([`ViewPlan::with_sun`]).
        let sun_view = Sun::Fixed.view_direction(frame.world_from_view);
        Self {
            camera: *camera,
            width_px,
            height_px,
            radius_m,
            phi_v_rad: frame.phi_v.rem_euclid(TAU),
            theta_v_rad: frame.theta_v,
            ground_m,
            ground_source,
            height_above_terrain_m,
            near_m,
            aspect,
            fov_y_rad: camera.fov_y_rad(),
            camera_from_view,
            clip_from_view,
            sun_view,
            sky_linear: sky_colour(camera.altitude_m),
        }
    }

    /// The same view lit by `sun` (the fixed sun in every viewer's sky, or the real one at a
    /// moment: `look::sun`).
    pub fn with_sun(self, sun: Sun) -> Self {
        Self {
            sun_view: sun.view_direction(self.camera.view_frame().world_from_view),
            ..self
        }
    }

    /// The eye in view space.
    pub fn eye_view_m(&self) -> DVec3 {
        DVec3::new(0.0, 0.0, self.radius_m + self.camera.altitude_m)
    }

    /// The view frustum (culling).
    pub fn frustum(&self) -> crate::clipmap::draw_list::Frustum {
        crate::clipmap::draw_list::Frustum::new(
            self.camera_from_view,
            self.eye_view_m(),
            self.fov_y_rad,
            self.aspect,
            self.near_m,
        )
    }

    /// The viewer's unit vector in world space (the nadir).
    pub fn nadir(&self) -> DVec3 {
        sphere::unit_vector(self.phi_v_rad, self.theta_v_rad)
    }
}

/// Background: blue sky low down, fading to black between 10 km and 1000 km.
fn sky_colour(altitude_m: f64) -> [f64; 3] {
    let t = ((altitude_m.max(1.0).log10() - 4.0) / 2.0).clamp(0.0, 1.0);
    let low = [0.30, 0.50, 0.80];
    let high = [0.002, 0.002, 0.006];
    std::array::from_fn(|i| low[i] + (high[i] - low[i]) * t)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `auto` switches on below 1 000 m, off above 1 500 m, and holds its choice in between,
    /// so a camera hovering near one threshold does not flip the method every frame.
    #[test]
    fn auto_mode_has_hysteresis() {
        let descend = [3000.0, 1200.0, 999.0, 1200.0, 1499.0, 1501.0, 1200.0];
        let mut on = false;
        let seen: Vec<bool> = descend
            .iter()
            .map(|&h| {
                on = LodMode::Auto.planar(h, on);
                on
            })
            .collect();
        assert_eq!(seen, [false, false, true, true, true, false, false]);
        assert!(LodMode::Geomip.planar(1e7, false) && !LodMode::Clipmap.planar(0.0, true));
        assert_eq!(LodMode::Auto.name(), "auto");
    }
}
