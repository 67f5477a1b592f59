//! The geomipmapping part of a frame plan (`planar::geomip`): where the patch grid lies, which
//! patches are in the frustum, and each one's level and border levels.
//!
//! State carried from frame to frame ([`GeomipState`]): the tangent frame the lattice lives in
//! (moved only when the viewer has gone half the grid's reach from its anchor, by a whole
//! number of patches, so the lattice stays put on the ground), the finest spacing (a power of
//! two near a sixteenth of the height above the terrain, changed with a factor-of-two hysteresis)
//! and each patch's δ_k, computed once from the terrain function when the patch first comes
//! into view (for at most [`DELTA_BUDGET`] of CPU time per frame; until then a patch draws at
//! level 0, which has no error of its own, and the frame is not settled).

use std::collections::HashMap;

use glam::{DMat3, DVec2, DVec3};

use crate::clipmap::draw_list::Sphere;
use crate::geo::sphere;
use crate::planar::LocalFrame;
use crate::planar::geomip::{
    GeomipSettings, Patch, border_levels, continuous_level, patch_deltas, restrict_levels,
};

use super::{TerrainQuery, ViewPlan};

/// Finest spacing = this × the height above the terrain, rounded to a power of two.
pub const SPACING_PER_HEIGHT: f64 = 1.0 / 16.0;
/// Finest spacing limits, metres.
pub const MIN_SPACING_M: f64 = 1.0 / 64.0;
pub const MAX_SPACING_M: f64 = 4096.0;
/// The clipmap's cut is the planar square shrunk by this fraction of its side on every edge:
/// in the band between, both draw the same surface (their depths decide), so wherever the
/// planar edge lies below the clipmap's surface the clipmap still covers the step.
pub const PLANAR_OVERLAP: f64 = 1.0 / 32.0;
/// CPU time a frame spends measuring patches' δ at most (289 heights each with 17²; at least
/// [`MIN_PATCHES_PER_FRAME`] patches): a moving viewer's new patches never stall a frame.
pub const DELTA_BUDGET: std::time::Duration = std::time::Duration::from_millis(4);
pub const MIN_PATCHES_PER_FRAME: usize = 4;

/// What the geomipmapping mode keeps between frames.
#[derive(Debug, Default)]
pub struct GeomipState {
    frame: Option<LocalFrame>,
    spacing_m: f64,
    /// δ_k and the height range of each patch, by lattice corner (units of the finest spacing).
    cache: HashMap<[i64; 2], PatchData>,
}

#[derive(Clone, Debug)]
struct PatchData {
    deltas: Vec<f64>,
    lo_m: f64,
    hi_m: f64,
    /// The patch's nearest distance from the viewer (radians) when δ was measured: the detail
    /// the GPU draws there grows as the viewer comes closer, so δ is measured again once the
    /// distance has halved.
    arc_rad: f64,
}

/// What geomipmapping draws this frame.
#[derive(Clone, Debug, PartialEq)]
pub struct GeomipPlan {
    pub frame: LocalFrame,
    /// The finest lattice spacing, metres.
    pub spacing_m: f64,
    /// Patches in the frustum, with their levels.
    pub patches: Vec<Patch>,
    /// Which of `patches` lie on the grid's outer edge, per side (they carry a skirt there).
    pub outer_sides: Vec<[bool; 4]>,
    /// The grid's square on the plane (min and max corner, metres from the anchor): the
    /// clipmap draws outside it.
    pub square_m: [DVec2; 2],
    /// Patches in view whose δ is not computed yet (drawn at level 0): the frame is not settled.
    pub waiting: usize,
    /// The angle around the viewer inside the clipmap's cut (the clipmap need not draw the
    /// levels within it)…
    pub covered_rad: f64,
    /// …and the angle within which the cut lies (levels reaching inside it cut it out).
    pub cut_reach_rad: f64,
}

impl GeomipPlan {
    /// The square where the clipmap's fragments go ([`PLANAR_OVERLAP`] inside the grid's).
    pub fn cut_m(&self) -> [DVec2; 2] {
        let [lo, hi] = self.square_m;
        let band = (hi - lo) * PLANAR_OVERLAP;
        [lo + band, hi - band]
    }
}

impl GeomipState {
    /// Plans the patch grid around the viewer. Heights come from `query` (the tiles at hand
    /// while streaming).
    pub fn plan(
        &mut self,
        view: &ViewPlan,
        settings: &GeomipSettings,
        query: &dyn TerrainQuery,
    ) -> GeomipPlan {
        let radius = view.radius_m;
        let nadir = view.nadir();
        let cells = settings.patch_size - 1;
        let cols = settings.patches as usize;
        let spacing = self.spacing_for(view.height_above_terrain_m);
        let patch_m = cells as f64 * spacing;
        let reach_m = 0.5 * cols as f64 * patch_m;
        let frame = self.anchor(nadir, radius, patch_m, reach_m);

        // The grid: cols × cols patches around the viewer's patch.
        // The viewer on the plane (computed once: every patch's distance starts from it).
        let pv = frame.plane_of(nadir).unwrap_or_default();
        let v = pv / patch_m;
        let lattice = Lattice {
            frame,
            spacing,
            cells,
            cols,
            first: [
                v.x.floor() as i64 - cols as i64 / 2,
                v.y.floor() as i64 - cols as i64 / 2,
            ],
        };
        let sight = Sight::of(view, pv, patch_m);
        let (mut levels, visible, waiting) = self.levels(&lattice, &sight, settings, query);
        restrict_levels(&mut levels, cols);
        let (patches, outer_sides) = lattice.patches_in_view(&levels, &visible);
        let mut plan = GeomipPlan {
            frame,
            spacing_m: spacing,
            patches,
            outer_sides,
            square_m: lattice.square_m(),
            waiting,
            covered_rad: 0.0,
            cut_reach_rad: 0.0,
        };
        plan.set_cut_angles(pv, radius);
        plan
    }

    /// The finest spacing, kept while within a factor of two of the target (a power of two
    /// near [`SPACING_PER_HEIGHT`] × the height) so that small changes of height leave the
    /// lattice alone; a new spacing drops the anchor.
    fn spacing_for(&mut self, height_above_terrain_m: f64) -> f64 {
        let target = (SPACING_PER_HEIGHT * height_above_terrain_m.max(1e-3))
            .clamp(MIN_SPACING_M, MAX_SPACING_M);
        if !(self.spacing_m > 0.0 && target > 0.5 * self.spacing_m && target < 2.0 * self.spacing_m)
        {
            self.spacing_m = target.log2().round().exp2();
            self.frame = None;
        }
        self.spacing_m
    }

    /// The lattice's tangent frame, moved by whole patches once the viewer is half the reach
    /// away from its anchor, so the lattice stays put on the ground; a moved frame drops the
    /// cached δ (their corners name other patches now).
    fn anchor(&mut self, nadir: DVec3, radius: f64, patch_m: f64, reach_m: f64) -> LocalFrame {
        let frame = match self.frame {
            Some(f) => match f.plane_of(nadir) {
                Some(p) if p.x.abs().max(p.y.abs()) < 0.5 * reach_m => f,
                Some(p) => f.moved_to((p / patch_m).round() * patch_m),
                None => LocalFrame::at(nadir, radius),
            },
            None => LocalFrame::at(nadir, radius),
        };
        if self.frame != Some(frame) {
            self.cache.clear();
        }
        self.frame = Some(frame);
        frame
    }

    /// Each patch's continuous level (-1 outside the frustum, 0 while its δ waits), whether
    /// it is in view, and how many in view wait. δ is measured for patches new in view (or
    /// come twice as close) within this frame's [`DELTA_BUDGET`], so no frame stalls.
    fn levels(
        &mut self,
        lattice: &Lattice,
        sight: &Sight,
        settings: &GeomipSettings,
        query: &dyn TerrainQuery,
    ) -> (Vec<f64>, Vec<bool>, usize) {
        let cols = lattice.cols;
        let mut levels = vec![-1.0; cols * cols];
        let mut visible = vec![false; cols * cols];
        let mut waiting = 0;
        let mut computed = 0;
        let started = std::time::Instant::now();
        for (i, level) in levels.iter_mut().enumerate() {
            let c = lattice.corner_of(i);
            let known = self.cache.get(&c).cloned();
            if !sight.sees(lattice, c, known.as_ref(), query) {
                continue;
            }
            visible[i] = true;
            // Nearest point of the patch to the eye: the viewer's plane position clamped into
            // the square (at the height in the patch's range nearest the eye's, below).
            let cells = lattice.cells as f64;
            let q = sight
                .pv
                .clamp(lattice.plane(c, 0.0, 0.0), lattice.plane(c, cells, cells));
            let nearest_u = lattice.frame.unit_at(q);
            let arc = sphere::great_circle_distance_m(nearest_u, sight.nadir, 1.0);
            let stale = known.as_ref().is_some_and(|d| arc < 0.5 * d.arc_rad);
            let data = match known {
                Some(d) if !stale => d,
                _ if computed < MIN_PATCHES_PER_FRAME || started.elapsed() < DELTA_BUDGET => {
                    computed += 1;
                    let d = measure_patch(lattice, c, settings.patch_size, sight.nadir, arc, query);
                    self.cache.insert(c, d.clone());
                    d
                }
                Some(d) => {
                    // Stale, over this frame's budget: its old δ until the next frame.
                    waiting += 1;
                    d
                }
                None => {
                    waiting += 1;
                    *level = 0.0;
                    continue;
                }
            };
            *level = sight.level(&data, nearest_u, settings.tau_px);
        }
        if !settings.geomorph {
            // Without geomorphing a level switches whole: no tween factors.
            for l in levels.iter_mut().filter(|l| **l >= 0.0) {
                *l = l.floor();
            }
        }
        (levels, visible, waiting)
    }
}

impl GeomipPlan {
    /// The angles the clipmap needs from the cut: the disc around the viewer it covers, and
    /// the reach of its farthest corner (`pv` the viewer on the plane).
    fn set_cut_angles(&mut self, pv: DVec2, radius: f64) {
        let [clo, chi] = self.cut_m();
        let inside = (pv - clo).min(chi - pv).min_element();
        self.covered_rad = inside.max(0.0) / radius;
        // The farthest corner of the cut, with a margin for the gnomonic map's stretch.
        let far = (pv - clo).abs().max((chi - pv).abs()).length();
        self.cut_reach_rad = 1.01 * far / radius;
    }
}

/// This frame's lattice: `cols` × `cols` patches of `cells` × `cells` cells of `spacing`
/// metres, the first at patch `first` of the tangent plane of `frame`.
struct Lattice {
    frame: LocalFrame,
    spacing: f64,
    cells: u32,
    cols: usize,
    first: [i64; 2],
}

impl Lattice {
    /// Patch `i`'s lattice corner (units of the finest spacing), row by row.
    fn corner_of(&self, i: usize) -> [i64; 2] {
        let (cols, cells) = (self.cols, self.cells);
        [
            (self.first[0] + (i % cols) as i64) * cells as i64,
            (self.first[1] + (i / cols) as i64) * cells as i64,
        ]
    }

    /// The point `(x, y)` cells from corner `c` on the plane, metres from the anchor.
    fn plane(&self, c: [i64; 2], x: f64, y: f64) -> DVec2 {
        let spacing = self.spacing;
        DVec2::new((c[0] as f64 + x) * spacing, (c[1] as f64 + y) * spacing)
    }

    /// The grid's square on the plane: min and max corner.
    fn square_m(&self) -> [DVec2; 2] {
        let (cols, cells) = (self.cols, self.cells as f64);
        [
            self.plane(self.corner_of(0), 0.0, 0.0),
            self.plane(self.corner_of(cols * cols - 1), cells, cells),
        ]
    }

    /// The patches in view with their (restricted) levels and border levels, and which of
    /// their sides lie on the grid's outer edge (they carry a skirt there).
    fn patches_in_view(&self, levels: &[f64], visible: &[bool]) -> (Vec<Patch>, Vec<[bool; 4]>) {
        let cols = self.cols;
        let borders = border_levels(levels, cols);
        let mut patches = Vec::new();
        let mut outer_sides = Vec::new();
        for i in (0..cols * cols).filter(|&i| visible[i]) {
            patches.push(Patch {
                corner: self.corner_of(i),
                level: levels[i],
                sides: borders[i],
            });
            let (x, y) = (i % cols, i / cols);
            outer_sides.push([y == 0, x + 1 == cols, y + 1 == cols, x == 0]);
        }
        (patches, outer_sides)
    }
}

/// What every patch's culling and level take from the view, worked out once a frame.
struct Sight {
    frustum: crate::clipmap::draw_list::Frustum,
    view_from_world: DMat3,
    eye_world: DVec3,
    /// The focal length, pixels.
    lambda: f64,
    altitude_m: f64,
    radius: f64,
    nadir: DVec3,
    /// The viewer on the plane.
    pv: DVec2,
    patch_m: f64,
    half_diag: f64,
}

impl Sight {
    fn of(view: &ViewPlan, pv: DVec2, patch_m: f64) -> Self {
        let radius = view.radius_m;
        let nadir = view.nadir();
        let world_from_view = view.camera.view_frame().world_from_view;
        Self {
            frustum: view.frustum(),
            view_from_world: world_from_view.transpose(),
            eye_world: nadir * (radius + view.camera.altitude_m),
            lambda: crate::geo::projection::focal_length_px(view.height_px, view.fov_y_rad),
            altitude_m: view.camera.altitude_m,
            radius,
            nadir,
            pv,
            patch_m,
            half_diag: patch_m * std::f64::consts::FRAC_1_SQRT_2,
        }
    }

    /// Whether patch `c`'s bounding sphere meets the frustum: its heights from `known` once
    /// measured, from `query`'s bounds near it before.
    fn sees(
        &self,
        lattice: &Lattice,
        c: [i64; 2],
        known: Option<&PatchData>,
        query: &dyn TerrainQuery,
    ) -> bool {
        let (radius, half_diag) = (self.radius, self.half_diag);
        let half = 0.5 * lattice.cells as f64;
        let centre = lattice.frame.unit_at(lattice.plane(c, half, half));
        let (lo, hi) = match known {
            Some(d) => (d.lo_m, d.hi_m),
            None => query.height_bounds_near_m(centre, half_diag / radius),
        };
        let bound = Sphere {
            centre_m: self.view_from_world * (centre * (radius + 0.5 * (lo + hi))),
            radius_m: half_diag + 0.5 * (hi - lo) + 1e-3 * self.patch_m,
        };
        self.frustum.intersects(&bound)
    }

    /// The continuous level of a patch with `data`, from its nearest point to the eye
    /// (`nearest_u`, at the height in the patch's range nearest the eye's).
    fn level(&self, data: &PatchData, nearest_u: DVec3, tau_px: f64) -> f64 {
        let h = self.altitude_m.clamp(data.lo_m, data.hi_m);
        let nearest = nearest_u * (self.radius + h);
        continuous_level(
            &data.deltas,
            (nearest - self.eye_world).length(),
            self.lambda,
            tau_px,
        )
    }
}

/// Patch `c`'s δ_k and height range from its `n` × `n` heights as drawn, measured at `arc`
/// (radians) from the viewer: the terrain function is asked once per patch, not per frame.
fn measure_patch(
    lattice: &Lattice,
    c: [i64; 2],
    n: u32,
    nadir: DVec3,
    arc: f64,
    query: &dyn TerrainQuery,
) -> PatchData {
    let heights: Vec<f64> = (0..n * n)
        .map(|v| {
            let u = lattice
                .frame
                .unit_at(lattice.plane(c, (v % n) as f64, (v / n) as f64));
            query.height_drawn_m(u, sphere::great_circle_distance_m(u, nadir, 1.0))
        })
        .collect();
    let (lo, hi) = heights
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &h| (a.min(h), b.max(h)));
    PatchData {
        deltas: patch_deltas(n, &heights),
        lo_m: lo,
        hi_m: hi,
        arc_rad: arc,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geo::camera::Camera;
    use crate::terrain::Terrain;

    fn camera(height_m: f64, pitch_deg: f64) -> Camera {
        Camera {
            lat_deg: 45.65,
            lon_deg: 10.65,
            altitude_m: height_m,
            heading_deg: 0.0,
            pitch_deg,
            roll_deg: 0.0,
            fov_y_deg: 60.0,
        }
    }

    fn radius_of(view: &ViewPlan) -> f64 {
        view.radius_m
    }

    #[test]
    fn grid_follows_the_viewer_and_levels_grow_with_distance() {
        let terrain = Terrain::analytic_earth();
        let settings = GeomipSettings {
            patches: 8,
            ..Default::default()
        };
        let mut state = GeomipState::default();
        let ground = terrain.height_at_lat_lon_m(45.65, 10.65);
        let cam = camera(ground + 40.0, -20.0);
        let view = ViewPlan::new(&cam, 640, 400, &terrain);
        // As a settling frame does: plan until every patch in view has its δ (a frame measures
        // them within its CPU budget).
        let mut plan = state.plan(&view, &settings, &terrain);
        for _ in 0..1000 {
            if plan.waiting == 0 {
                break;
            }
            plan = state.plan(&view, &settings, &terrain);
        }
        assert_eq!(plan.spacing_m, 2.0, "a sixteenth of 40 m, a power of two");
        assert!(
            !plan.patches.is_empty() && plan.patches.len() < 64,
            "culled: {}",
            plan.patches.len()
        );
        assert_eq!(plan.waiting, 0);
        // The clipmap may leave out a disc of at least a third of the square's side.
        let side = plan.square_m[1].x - plan.square_m[0].x;
        assert!(
            plan.covered_rad * radius_of(&view) > side / 3.0,
            "{}",
            plan.covered_rad
        );
        // The viewer lies inside the square.
        let p = plan.frame.plane_of(view.nadir()).unwrap();
        assert!(p.cmpgt(plan.square_m[0]).all() && p.cmplt(plan.square_m[1]).all());
        // Nearest patches at the finest levels, the far ones coarser.
        let by_dist = |patch: &Patch| {
            let c = DVec2::new(patch.corner[0] as f64 + 8.0, patch.corner[1] as f64 + 8.0)
                * plan.spacing_m;
            (c - p).length()
        };
        let near = plan
            .patches
            .iter()
            .min_by(|a, b| by_dist(a).total_cmp(&by_dist(b)))
            .unwrap();
        let far = plan
            .patches
            .iter()
            .max_by(|a, b| by_dist(a).total_cmp(&by_dist(b)))
            .unwrap();
        assert!(near.level <= far.level, "{} vs {}", near.level, far.level);
        // A small move keeps the anchor (and the lattice); a long one moves it by whole patches.
        let moved = ViewPlan::new(
            &Camera {
                lat_deg: 45.6503,
                ..cam
            },
            640,
            400,
            &terrain,
        );
        assert_eq!(state.plan(&moved, &settings, &terrain).frame, plan.frame);
        let far_cam = Camera {
            lat_deg: 45.66,
            altitude_m: terrain.height_at_lat_lon_m(45.66, 10.65) + 40.0,
            ..cam
        };
        let far_view = ViewPlan::new(&far_cam, 640, 400, &terrain);
        let replanned = state.plan(&far_view, &settings, &terrain);
        assert_ne!(replanned.frame, plan.frame);
        let shift = plan.frame.plane_of(replanned.frame.anchor).unwrap() / (16.0 * plan.spacing_m);
        assert!(
            (shift - shift.round()).length() < 1e-6,
            "whole patches: {shift}"
        );
    }
}
