//! The projected grid's part of a frame plan (`planar::projgrid`, error-bounded-projective-grid.md):
//! the grid of view directions the GPU places on the terrain, and the error buffer saying which
//! cells the fragment stage ray casts.
//!
//! Each frame, in f64:
//! 1. the projector: the camera's terrain footprint as a (ψ, θ̃) patch around the nadir, over the
//!    terrain's bounds within the horizon (the min/max pyramid's, widened by the detail's);
//! 2. the grid's parameters: uniform, or warped by importance (geometry-image-warping.md §3):
//!    the error buffer of a low-resolution uniform grid gives each of its cells ρ (eq. 3), and
//!    I = ρ (the paper's Iv = C/d with C = λ·δ per cell: vertices go where the mesh errs, not
//!    merely where it is near), warped in two passes and upsampled to the grid's size;
//! 3. the error buffer of the grid itself (eq. 2–4): δ from the cell's corner heights and the
//!    terrain's bounds inside it, ρ = λ·δ/d; cells with ρ > γ carry their bounds to the GPU.
//!
//! The f64 → f32 step of a vertex is its view direction as (p̃x, p̃y, 1 − cos θ̃, θ̃), as the ring
//! mesh's: small numbers near the viewer keep their precision.

use glam::{DMat3, DVec2, DVec3};

use crate::geo::visibility::theta_tilde_max;
use crate::planar::grid_warp::{self, ImportanceSample, WarpSettings};
use crate::planar::projgrid::{
    ErrorBuffer, HeightBounds, ProjGridSettings, ProjectedGrid, Projector, RenderView, ThetaTable,
};

use super::{TerrainQuery, ViewPlan};

/// The low-resolution grid whose errors drive the warp (§3.4 warps at 128²; never finer than
/// the grid itself).
pub const WARP_GRID_MAX: u32 = 128;
/// δ below this counts as this (a flat cell still gets the warp's floor of vertices).
const DELTA_FLOOR_M: f64 = 1e-3;
/// Margin added to a ray-cast cell's bounds (f32 on the GPU, the level textures' rounding).
const BOUNDS_MARGIN_M: f64 = 0.5;

/// What the projected grid draws this frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ProjGridPlan {
    pub cols: u32,
    pub rows: u32,
    /// Per vertex, row-major ((cols + 1) × (rows + 1), v = 0 the far row): p̃x, p̃y, 1 − cos θ̃, θ̃.
    pub vertices: Vec<[f32; 4]>,
    /// Per cell: (min, max) of the terrain inside it when it is ray cast (min > max when not),
    /// the normalised error of eq. 4, 0.
    pub cells: Vec<[f32; 4]>,
    /// Cells with ρ > γ (ray cast when the setting is on).
    pub cells_above_gamma: usize,
    /// Largest and mean ρ of the cells (eq. 3, the a-priori bound), pixels.
    pub max_rho_px: f64,
    pub mean_rho_px: f64,
    /// Any terrain in view (looking up from high above, none: nothing is drawn).
    pub sees_terrain: bool,
}

impl ProjGridPlan {
    pub fn triangles(&self) -> u64 {
        if self.sees_terrain {
            2 * u64::from(self.cols) * u64::from(self.rows)
        } else {
            0
        }
    }
}

/// The camera of `view` as the projector sees it (view space: the eye on +z̃).
pub fn render_view(view: &ViewPlan) -> RenderView {
    RenderView {
        eye_m: view.eye_view_m(),
        view_from_camera: view.camera_from_view.transpose(),
        fov_y_rad: view.fov_y_rad,
        width_px: view.width_px,
        height_px: view.height_px,
        radius_m: view.radius_m,
    }
}

/// Plans the frame's projected grid.
pub fn plan(
    view: &ViewPlan,
    settings: &ProjGridSettings,
    query: &dyn TerrainQuery,
) -> ProjGridPlan {
    let rv = render_view(view);
    let r = view.radius_m;
    let world_from_view: DMat3 = view.camera.view_frame().world_from_view;
    let (lo, hi) = query.height_range_m();
    let reach = theta_tilde_max(r, view.camera.altitude_m, lo, hi);
    let (min_m, max_m) = query.height_bounds_near_m(view.nadir(), reach);
    let projector = Projector::new(&rv, HeightBounds { min_m, max_m });
    let mut plan = ProjGridPlan {
        cols: settings.cols,
        rows: settings.rows,
        sees_terrain: projector.sees_terrain(),
        ..Default::default()
    };
    if !plan.sees_terrain {
        return plan;
    }
    let table = ThetaTable::new(&projector);
    let point = |uv: DVec2| table.point(&projector, uv);
    let to_world = |u: DVec3| world_from_view * u;
    let arc = |u: DVec3| u.truncate().length().atan2(u.z);
    let height = |u: DVec3| query.height_drawn_m(to_world(u), arc(u));
    let bounds = |u: DVec3, angle: f64, arc: f64| query.cell_bounds_m(to_world(u), angle, arc);
    let grid_of = |cols: u32, rows: u32, uv: &[DVec2]| ProjectedGrid {
        cols,
        rows,
        points: uv.iter().map(|&p| point(p)).collect(),
    };

    let uv = if settings.warp {
        let (lc, lr) = (
            settings.cols.min(WARP_GRID_MAX),
            settings.rows.min(WARP_GRID_MAX),
        );
        let low = grid_of(lc, lr, &uniform_uv(lc, lr));
        let eb = ErrorBuffer::compute_with(
            &projector,
            &low,
            &rv,
            settings.gamma_px,
            &height,
            &bounds,
            &point,
        );
        let samples: Vec<ImportanceSample> = eb
            .cells
            .iter()
            .map(|c| ImportanceSample {
                distance_m: c.distance_min_m / c.delta_m.max(DELTA_FLOOR_M),
                in_frustum: 1.0,
                facing_cos: 1.0,
                surface_limit: f64::INFINITY,
            })
            .collect();
        let ws = WarpSettings {
            low_res_cols: lc as usize,
            low_res_rows: lr as usize,
            view_constant: rv.pixels_per_radian(),
            ..WarpSettings::default()
        };
        let map = grid_warp::importance(&samples, lc as usize, lr as usize, &ws);
        grid_warp::warp_with(&map, settings.cols as usize, settings.rows as usize, &ws).vertices
    } else {
        uniform_uv(settings.cols, settings.rows)
    };
    let grid = grid_of(settings.cols, settings.rows, &uv);
    let eb = ErrorBuffer::compute_with(
        &projector,
        &grid,
        &rv,
        settings.gamma_px,
        &height,
        &bounds,
        &point,
    );

    plan.vertices = grid
        .points
        .iter()
        .map(|p| {
            let u = p.unit;
            let theta = arc(u);
            let omc = 2.0 * (0.5 * theta).sin().powi(2);
            [u.x as f32, u.y as f32, omc as f32, theta as f32]
        })
        .collect();
    let mut sum = 0.0;
    plan.cells = (0..eb.cells.len())
        .map(|k| {
            let c = &eb.cells[k];
            sum += c.rho_px;
            plan.max_rho_px = plan.max_rho_px.max(c.rho_px);
            let norm = eb.normalised(k) as f32;
            if eb.needs_ray_cast(k) {
                plan.cells_above_gamma += 1;
                if settings.ray_cast {
                    let lo = (c.min_m - BOUNDS_MARGIN_M) as f32;
                    let hi = (c.max_m + BOUNDS_MARGIN_M) as f32;
                    return [lo, hi, norm, 0.0];
                }
            }
            [1.0, 0.0, norm, 0.0]
        })
        .collect();
    plan.mean_rho_px = sum / eb.cells.len().max(1) as f64;
    plan
}

/// The uniform grid's parameters, (cols + 1) × (rows + 1), row-major.
fn uniform_uv(cols: u32, rows: u32) -> Vec<DVec2> {
    (0..=rows)
        .flat_map(|j| {
            (0..=cols).map(move |i| {
                DVec2::new(
                    f64::from(i) / f64::from(cols),
                    f64::from(j) / f64::from(rows),
                )
            })
        })
        .collect()
}

/// The grid's triangle list: each cell (i, j) as (a, b, c) and (a, c, d) from its first vertex
/// a = (i, j), so a flat value from the first vertex names the cell.
pub fn grid_indices(cols: u32, rows: u32) -> Vec<u32> {
    let w = cols + 1;
    let mut out = Vec::with_capacity(6 * (cols * rows) as usize);
    for j in 0..rows {
        for i in 0..cols {
            let a = j * w + i;
            let (b, c, d) = (a + 1, a + w + 1, a + w);
            out.extend_from_slice(&[a, b, c, a, c, d]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geo::camera::Camera;
    use crate::terrain::Terrain;

    /// The plan's grid covers the view with cells whose first vertex is the cell's own, its
    /// vertices are unit directions, and a warped grid puts more cells where ρ is high than
    /// the uniform grid does (the warp's purpose), lowering the worst cell's ρ.
    #[test]
    fn warped_grid_lowers_the_worst_cells_error() {
        let terrain = Terrain::analytic_earth();
        let ground = terrain.height_at_lat_lon_m(45.65, 10.65);
        let camera = Camera {
            lat_deg: 45.65,
            lon_deg: 10.65,
            altitude_m: ground + 300.0,
            heading_deg: 45.0,
            pitch_deg: -20.0,
            roll_deg: 0.0,
            fov_y_deg: 60.0,
        };
        let view = ViewPlan::new(&camera, 320, 200, &terrain);
        let s = ProjGridSettings {
            cols: 64,
            rows: 48,
            warp: false,
            ..ProjGridSettings::default()
        };
        let uniform = plan(&view, &s, &terrain);
        let warped = plan(&view, &ProjGridSettings { warp: true, ..s }, &terrain);
        for p in [&uniform, &warped] {
            assert!(p.sees_terrain);
            assert_eq!(p.vertices.len(), 65 * 49);
            assert_eq!(p.cells.len(), 64 * 48);
            for v in &p.vertices {
                let len2 = v[0] * v[0] + v[1] * v[1] + (1.0 - v[2]) * (1.0 - v[2]);
                assert!((len2 - 1.0).abs() < 1e-5, "{v:?}");
            }
        }
        assert!(
            warped.max_rho_px < uniform.max_rho_px,
            "warp {} px, uniform {} px",
            warped.max_rho_px,
            uniform.max_rho_px
        );
        let idx = grid_indices(3, 2);
        assert_eq!(idx.len(), 36);
        assert_eq!(&idx[..6], &[0, 1, 5, 0, 5, 4]);
        assert_eq!(idx[6 * 4], 4 + 1, "cell (0, 1) starts at its first vertex");
    }
}
