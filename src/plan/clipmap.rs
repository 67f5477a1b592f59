//! The spherical clipmap's part of a frame plan (spherical-clipmaps.md): which levels are drawn
//! and why (eq. 6 with the mountain term, eq. 7–8), the map-space window each level texture
//! must hold and the rectangles to refill (§4.1, toroidal updates), which ring sectors lie in
//! the frustum, and which wanted levels still wait for data.
//!
//! Built in three steps around the renderer's fills, all f64 and free of wgpu:
//! [`ClipmapPlan::new`] (levels, windows) → the renderer fills what it can → [`ClipmapPlan::
//! limit_to_held`] (a level is drawn only when it and every coarser one hold their window) →
//! [`ClipmapPlan::cull`] (ring densities by projected size, then sectors).

use std::f64::consts::PI;

use crate::clipmap::density::{Density, DensityCap, DensityPlan, ScreenScale, detail_density_cap};
use crate::clipmap::draw_list::{Cone, DrawList, PlanarCut, SectorBounds};
use crate::clipmap::levels::{
    GridRect, LevelGrid, reference_depends_on_ground, reference_height_m,
};
use crate::clipmap::selection::{LevelSelection, LevelStatus};
use crate::clipmap::settings::level_outer_theta_rad;
use crate::clipmap::{ClipmapSettings, RingMesh};
use crate::geo::visibility;
use crate::procedural::Detail;

use super::{HeightSource, TerrainQuery, ViewPlan};

/// One level's update: the window its texture must hold and the rectangles that differ from
/// what it holds now (empty when nothing moved).
#[derive(Clone, Debug, PartialEq)]
pub struct LevelFill {
    pub grid: LevelGrid,
    pub rects: Vec<GridRect>,
    /// Not to be filled yet: the ground under the eye is still a coarser tile's and the
    /// level's reference height depends on it (`reference_height_m`), so a fill now would be
    /// rewritten once the camera's tile arrives. Its tiles are fetched all the same.
    pub defer: bool,
}

impl LevelFill {
    pub fn texels(&self) -> u64 {
        self.rects.iter().map(GridRect::texels).sum()
    }
}

/// What the clipmap draws and fills this frame.
#[derive(Clone, Debug, PartialEq)]
pub struct ClipmapPlan {
    /// Levels drawn, and why each other one is not.
    pub selection: LevelSelection,
    /// Windows of the drawn levels and of the level their outer rings blend into, coarse to
    /// fine.
    pub fills: Vec<LevelFill>,
    /// Index ranges of the sectors inside the frustum (empty until [`ClipmapPlan::cull`]).
    pub draw: DrawList,
    /// First level of the paper's trigonometric approximation (eq. 11, 14), or `None` where it
    /// is invalid (within π/48 of a pole, the paper's Fig. 12 range).
    pub approx_start_level: Option<u32>,
    /// The ring density of every drawn level (set by [`ClipmapPlan::cull`]).
    pub densities: DensityPlan,
    /// Test hook: changes each drawn level's density (given the mesh's coarsest) after the
    /// plan chose it (`tests/gpu/density.rs` compares a morphed density with the next one).
    pub density_map: Option<DensityMap>,
    /// The coarsest density each level may take (indexed by level; None: the mesh's coarsest
    /// everywhere). The renderer caps the levels whose textures hold detail geometry
    /// (`clipmap::density::detail_density_cap`).
    pub density_caps: Option<Vec<DensityCap>>,
    /// The angle around the viewer a planar LOD method covers wholly (0: none). Levels inside
    /// it are filled (the planar method samples them) but not drawn; the cap of the finest
    /// level drawn covers the hole, under the planar method's square.
    pub covered_rad: f64,
    /// The angle around the viewer within which a planar method's square reaches (0: none):
    /// levels reaching inside it draw with the pipelines that cut the square out.
    pub cut_rad: f64,
}

/// A change of each level's density: (level, chosen, the mesh's coarsest k) → drawn.
#[derive(Clone, Copy, Debug)]
pub struct DensityMap(pub fn(u32, Density, u32) -> Density);

impl PartialEq for DensityMap {
    fn eq(&self, other: &Self) -> bool {
        std::ptr::fn_addr_eq(self.0, other.0)
    }
}

impl ClipmapPlan {
    /// Levels by the visibility bounds and the windows they need. `held[level]` is the window
    /// each level texture holds now (`None`: never filled). `keep_spans`: a level keeps its
    /// held φ span while that still fits (hysteresis for a moving camera, so that a span
    /// change does not rewrite a level back and forth); without it every level takes its
    /// ideal span, as a renderer with no past would (a camera at rest: the settled view is
    /// then the same whatever the path to it).
    pub fn new(
        view: &ViewPlan,
        settings: &ClipmapSettings,
        held: &[Option<LevelGrid>],
        height_range_m: (f64, f64),
        draw_all_levels: bool,
        keep_spans: bool,
    ) -> Self {
        let (hmin, hmax) = height_range_m;
        let theta_max =
            visibility::theta_tilde_max(view.radius_m, view.camera.altitude_m, hmin, hmax);
        let theta_min = visibility::theta_tilde_min(
            view.radius_m,
            view.height_above_terrain_m,
            view.fov_y_rad,
            view.height_px,
        );
        let mut selection = LevelSelection::new(settings.levels, theta_max, theta_min);
        if draw_all_levels {
            selection.coarsest = 0;
            selection.finest = settings.levels - 1;
        }
        let first = selection.coarsest.saturating_sub(1);
        let provisional = view.ground_source == HeightSource::CoarserTiles;
        let fills = (first..=selection.finest)
            .map(|level| {
                let old = held[level as usize];
                let kept = old.as_ref().filter(|_| keep_spans);
                // While the ground is a coarser tile's, a level keeps the reference it holds
                // (at rest too) and one that has none waits for the camera's tile.
                let held_ref = if provisional { old.as_ref() } else { kept }.map(|g| g.ref_m);
                let ref_m = reference_height_m(
                    level,
                    view.radius_m,
                    view.ground_m,
                    view.height_above_terrain_m,
                    height_range_m,
                    held_ref,
                );
                let defer = provisional
                    && old.is_none_or(|o| o.ref_m != ref_m)
                    && reference_depends_on_ground(level, view.radius_m, height_range_m);
                let grid = LevelGrid::for_viewer(
                    level,
                    settings.texture_size,
                    view.phi_v_rad,
                    view.theta_v_rad,
                    kept,
                )
                .with_reference(ref_m);
                LevelFill {
                    grid,
                    rects: grid.dirty_since(old.as_ref()),
                    defer,
                }
            })
            .collect();
        let theta_v = view.theta_v_rad;
        let approx_ok = theta_v > PI / 48.0 && theta_v < 47.0 * PI / 48.0;
        Self {
            selection,
            fills,
            draw: DrawList::default(),
            approx_start_level: approx_ok.then_some(settings.approx_start_level),
            densities: DensityPlan::full(settings.levels),
            density_map: None,
            density_caps: None,
            covered_rad: 0.0,
            cut_rad: 0.0,
        }
    }

    /// Before the fills: neither draws nor fills a level whose whole disk around the nadir lies
    /// outside the view frustum. The levels are nested, so every finer one lies outside too,
    /// and the cap of the finest level in view covers the rest. A walker looking ahead fills
    /// none of the centimetre levels under its feet; a camera a millimetre above the ground,
    /// whose whole view they are, gets as many as the pixel bound asks for (with the detail
    /// on, the finest level's cap is a flat fan: at 1 mm it must be a fraction of a
    /// millimetre wide, 10 levels finer than a walker's).
    ///
    /// The disk's heights are bounded by the ground under the eye and the drawn terrain's
    /// slope bound over the disk (`TerrainQuery::cell_bounds_m`; the DEM's and the detail's),
    /// within the culling bounds: the detail's amplitude bound alone (hundreds of metres)
    /// would reach every eye.
    pub fn limit_to_view(&mut self, view: &ViewPlan, query: &dyn TerrainQuery) {
        let frustum = view.frustum();
        let nadir = view.nadir();
        let sel = &mut self.selection;
        let mut finest = sel.finest;
        while finest > sel.coarsest {
            let angle = level_outer_theta_rad(finest);
            let b = query.cell_bounds_m(nadir, angle, 0.0);
            let (mut lo, mut hi) = (b.min_m, b.max_m);
            if view.ground_source != HeightSource::CoarserTiles && b.slope.is_finite() {
                let reach = b.slope * angle * view.radius_m;
                lo = lo.max(view.ground_m - reach);
                hi = hi.min(view.ground_m + reach);
            }
            let cone = Cone {
                axis: glam::DVec3::Z,
                half_angle_rad: angle,
            };
            let sphere = cone.bounding_sphere(view.radius_m + lo, view.radius_m + hi.max(lo));
            if frustum.intersects(&sphere) {
                break;
            }
            finest -= 1;
        }
        for level in finest + 1..=sel.finest {
            sel.status[level as usize] = LevelStatus::OutOfView;
        }
        sel.finest = finest;
        self.fills.retain(|f| f.grid.level <= finest);
    }

    /// After the fills: draws down to the last level that, like every coarser drawn level and
    /// the level they blend into, holds its window; the wanted levels beyond it wait (the next
    /// coarser level's cap covers them, never garbage).
    pub fn limit_to_held(&mut self, held: &[Option<LevelGrid>]) {
        let holds = |level: u32| {
            self.fills
                .iter()
                .find(|f| f.grid.level == level)
                .is_some_and(|f| held[level as usize] == Some(f.grid))
        };
        let first = self.selection.coarsest.saturating_sub(1);
        let mut ready_finest = None;
        if (first..self.selection.coarsest).all(holds) {
            for level in self.selection.drawn_levels() {
                if !holds(level) {
                    break;
                }
                ready_finest = Some(level);
            }
        }
        self.selection.limit_to_ready(ready_finest);
    }

    /// The sectors of the drawn levels inside the view frustum (every sector when
    /// `draw_all_sectors`), bounded by the terrain's local height range around the nadir.
    pub fn cull(
        &mut self,
        view: &ViewPlan,
        settings: &ClipmapSettings,
        mesh: &RingMesh,
        bounds: &SectorBounds,
        query: &dyn TerrainQuery,
        draw_all_sectors: bool,
    ) {
        let scale = screen_scale(view);
        let caps = self.density_caps.as_deref();
        let cap = |l: u32| {
            let mesh_cap = DensityCap::at_most(mesh.max_density);
            caps.and_then(|c| c.get(l as usize))
                .map_or(mesh_cap, |&c| mesh_cap.min(c))
        };
        self.densities = DensityPlan::new(&scale, &self.selection, settings, cap);
        if let Some(map) = self.density_map {
            let body: Vec<Density> = self
                .selection
                .drawn_levels()
                .map(|l| (map.0)(l, self.densities.levels[l as usize].body, cap(l).k))
                .collect();
            self.densities.set_drawn(&self.selection, &body);
        }
        if !self.selection.any_drawn() {
            self.draw = DrawList::default();
            return;
        }
        let frustum = view.frustum();
        let nadir = view.nadir();
        let radius_range_m = |level: u32| {
            let (lo, hi) = query.height_bounds_near_m(nadir, level_outer_theta_rad(level));
            (view.radius_m + lo, view.radius_m + hi)
        };
        // The finest level a planar method leaves to the clipmap: at least the coarsest.
        let mut finest = self.selection.finest;
        while finest > self.selection.coarsest && level_outer_theta_rad(finest) <= self.covered_rad
        {
            finest -= 1;
        }
        self.draw = DrawList::build(
            mesh,
            bounds,
            &self.selection,
            &self.densities,
            (!draw_all_sectors).then_some(&frustum),
            radius_range_m,
            PlanarCut {
                finest,
                cut_rad: self.cut_rad,
            },
        );
    }

    /// Levels wanted but waiting for data.
    pub fn waiting(&self) -> Vec<u32> {
        self.selection.waiting()
    }

    /// Texels the plan asks to refill.
    pub fn texels_to_fill(&self) -> u64 {
        self.fills.iter().map(LevelFill::texels).sum()
    }
}

/// What the density rule needs to know of a view to size its levels on screen.
pub fn screen_scale(view: &ViewPlan) -> ScreenScale {
    ScreenScale {
        radius_m: view.radius_m,
        altitude_m: view.camera.altitude_m,
        ground_m: view.camera.altitude_m - view.height_above_terrain_m,
        focal_px: crate::geo::projection::focal_length_px(view.height_px, view.fov_y_rad),
    }
}

/// How large on screen a level's finest geometric detail octave may be and still lie between
/// vertices coarser than the detail allows: twice this (half a pixel, against the 1 px p99 the
/// default keeps) holds the level at `detail_density_cap`, each halving below it frees one
/// density more ([`detail_density_caps`]).
pub const DETAIL_OCTAVE_VISIBLE_PX: f64 = 0.25;

/// The coarsest density of every level (indexed by level) over `detail`. A level's finest
/// geometric octave, at its largest amplitude σ_max·(1 + g_h)·a_k over the level's nearest
/// distance, spans `px` pixels. From 2·[`DETAIL_OCTAVE_VISIBLE_PX`] up it could show between
/// the vertices, and the level keeps enough vertices per octave cell
/// (`clipmap::density::detail_density_cap`); each halving of `px` below that allows one
/// density more, morphing continuously toward it, up to the mesh's coarsest (every level seen
/// from space).
pub fn detail_density_caps(
    detail: &Detail,
    settings: &ClipmapSettings,
    max_k: u32,
    scale: &ScreenScale,
) -> Vec<DensityCap> {
    let params = detail.params();
    let cap = detail_density_cap(settings, params.geometry_cut, max_k);
    let sigma_m = params.amplitude_max_m * (1.0 + params.height_roughness);
    let blend = settings.blend_fraction as f64;
    let free = DensityCap::at_most(max_k);
    (0..settings.levels)
        .map(|l| {
            let o = detail.level_octaves(l, blend);
            let end = (o.full + o.partial) as usize;
            let Some(finest) = end.checked_sub(1).and_then(|k| detail.octaves().get(k)) else {
                return free;
            };
            // The level's nearest point: its inner edge (θ̃ grows outward).
            let inner = level_outer_theta_rad(l) * 0.5;
            let px =
                sigma_m * finest.amplitude * scale.focal_px / scale.distance_m(inner).max(1e-9);
            let c = cap as f64 + (1.0 + (DETAIL_OCTAVE_VISIBLE_PX / px).log2()).max(0.0);
            if !c.is_finite() || c >= max_k as f64 {
                return free;
            }
            DensityCap {
                k: c.floor() as u32,
                morph: c.fract() as f32,
            }
        })
        .collect()
}
