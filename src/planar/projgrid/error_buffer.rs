//! The a-priori error of each grid cell (error-bounded-projective-grid.md eq. 2–4: δ from the
//! cell's height bounds, ρ = λ·δ/d) gathered into the buffer the fragment stage reads, and
//! [`ray_cast`], the CPU twin of the march the fragment stage makes where ρ exceeds γ (§4
//! "Rendering").

use super::*;

/// One cell's error (eq. 2–4) and the bounds the fragment stage's ray cast uses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CellError {
    /// Object-space error δ, metres (eq. 2 over the cell).
    pub delta_m: f64,
    /// Screen-space error ρ, pixels (eq. 3).
    pub rho_px: f64,
    pub min_m: f64,
    pub max_m: f64,
    /// The cell's footprint: a cap of `radius_rad` around `centre` (unit vector).
    pub centre: DVec3,
    pub radius_rad: f64,
    /// Nearest distance from the eye to the cell's volume (cap × [min, max]), metres.
    pub distance_min_m: f64,
}

/// Per-cell ρ of one frame: what the GPU rasterises into its error buffer (Fig. 7).
#[derive(Clone, Debug, PartialEq)]
pub struct ErrorBuffer {
    pub cols: u32,
    pub rows: u32,
    pub gamma_px: f64,
    pub cells: Vec<CellError>,
}

impl ErrorBuffer {
    /// Errors of every cell. `height(unit)` is the height a vertex gets (the avg pyramid);
    /// `bounds(unit, angle)` bounds the terrain within `angle` of `unit` (the min/max pyramids).
    ///
    /// δ generalises eq. 2 from one h_avg to a cell whose mesh surface lies between its corner
    /// heights: δ = max(h_max − min corner, max corner − h_min), the largest vertical gap between
    /// the mesh and any terrain inside the cell. ρ uses the nearest point of the cell's volume,
    /// so it bounds the paper's ‖p − e‖ form from above.
    pub fn compute(
        projector: &Projector,
        grid: &ProjectedGrid,
        view: &RenderView,
        gamma_px: f64,
        height: &dyn Fn(DVec3) -> f64,
        bounds: &dyn Fn(DVec3, f64) -> (f64, f64),
    ) -> Self {
        let point = |uv| projector.point(uv);
        let bounds = |u, angle, _arc| {
            let (min_m, max_m) = bounds(u, angle);
            CellBounds {
                min_m,
                max_m,
                slope: f64::INFINITY,
            }
        };
        Self::compute_with(projector, grid, view, gamma_px, height, &bounds, &point)
    }

    /// [`ErrorBuffer::compute`] with the grid's map from (u, v) to a point given (a frame's
    /// plan passes [`ThetaTable::point`], the grid's own), and `bounds(centre, angle, arc)`
    /// bounding the terrain in a cap of `angle` whose nearest point is `arc` from the nadir.
    ///
    /// A finite slope bound S tightens the heights to [corner min − S·s, corner max + S·s],
    /// s the farthest any point of the cell lies from its nearest corner. Split along a
    /// diagonal, that is at most a triangle's longest side over √3, and every side lies
    /// within the cap's diameter: s ≤ 2·radius/√3 (about the cap's radius itself):
    /// a cell metres across under a DEM pixel kilometres across then bounds the terrain by
    /// what it can rise over metres, not by the pixel's whole relief.
    pub fn compute_with(
        projector: &Projector,
        grid: &ProjectedGrid,
        view: &RenderView,
        gamma_px: f64,
        height: &dyn Fn(DVec3) -> f64,
        bounds: &dyn Fn(DVec3, f64, f64) -> CellBounds,
        point: &dyn Fn(DVec2) -> GridPoint,
    ) -> Self {
        let lambda = view.pixels_per_radian();
        let heights: Vec<f64> = grid.points.iter().map(|p| height(p.unit)).collect();
        let e = view.eye_m;
        let (r, r_e) = (view.radius_m, e.length());
        // The boundary of each cell: its corners and three points along each edge. Edges are
        // shared by two cells, so their points are computed once per edge.
        let (cols, rows) = (grid.cols as usize, grid.rows as usize);
        let w = cols + 1;
        let along = |a: usize, b: usize| {
            let (pa, pb) = (grid.points[a].uv, grid.points[b].uv);
            [1.0, 2.0, 3.0].map(|s| point(pa.lerp(pb, s / 4.0)).unit)
        };
        let across: Vec<[DVec3; 3]> = (0..=rows)
            .flat_map(|j| (0..cols).map(move |i| (j, i)))
            .map(|(j, i)| along(j * w + i, j * w + i + 1))
            .collect();
        let down: Vec<[DVec3; 3]> = (0..rows)
            .flat_map(|j| (0..w).map(move |i| (j, i)))
            .map(|(j, i)| along(j * w + i, (j + 1) * w + i))
            .collect();
        // Angles from squared chords: exact for the smallest cells, one asin per cell.
        let chord_angle = |c2: f64| 2.0 * (0.5 * c2.sqrt()).min(1.0).asin();
        let mut cells = Vec::with_capacity(cols * rows);
        for j in 0..grid.rows {
            for i in 0..grid.cols {
                let k = grid.cell_vertices(i, j);
                let corners = k.map(|k| grid.points[k].uv);
                let mid = 0.25 * corners.iter().sum::<DVec2>();
                let centre = point(mid).unit;
                let (iu, ju) = (i as usize, j as usize);
                let edges = [
                    &across[ju * cols + iu],
                    &across[(ju + 1) * cols + iu],
                    &down[ju * w + iu],
                    &down[ju * w + iu + 1],
                ];
                let samples = (k.iter().map(|&k| grid.points[k].unit))
                    .chain(edges.into_iter().flatten().copied());
                let (mut far_c2, mut near_c2) = (0.0f64, f64::INFINITY);
                for q in samples {
                    far_c2 = far_c2.max(q.distance_squared(centre));
                    near_c2 = near_c2.min(q.distance_squared(projector.nadir));
                }
                let (radius_rad, theta_min) = (chord_angle(far_c2), chord_angle(near_c2));
                let radius_rad = radius_rad * (1.0 + CAP_MARGIN);
                let hs = k.map(|k| heights[k]);
                let corner_min = hs.iter().copied().fold(f64::INFINITY, f64::min);
                let corner_max = hs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                let b = bounds(centre, radius_rad, theta_min);
                let (mut b_min, mut b_max) = (b.min_m, b.max_m);
                if b.slope.is_finite() {
                    let reach_m = 2.0 / 3f64.sqrt() * radius_rad * (r + b_max.max(0.0));
                    b_min = b_min.max(corner_min - b.slope * reach_m);
                    b_max = b_max.min(corner_max + b.slope * reach_m);
                }
                let (min_m, max_m) = (b_min.min(corner_min), b_max.max(corner_max));
                let delta_m = (max_m - corner_min).max(corner_max - min_m);
                // Nearest point of the cell's volume: the eye is on the nadir, so distance grows
                // with the central angle from it, least on the cell's boundary.
                let b = theta_min;
                let r_star = (r_e * b.cos()).clamp(r + min_m, r + max_m);
                let d2 = (r_e - r_star).powi(2) + 4.0 * r_e * r_star * (0.5 * b).sin().powi(2);
                let distance_min_m = d2.sqrt().max(MIN_DISTANCE_M);
                cells.push(CellError {
                    delta_m,
                    rho_px: lambda * delta_m / distance_min_m,
                    min_m,
                    max_m,
                    centre,
                    radius_rad,
                    distance_min_m,
                });
            }
        }
        Self {
            cols: grid.cols,
            rows: grid.rows,
            gamma_px,
            cells,
        }
    }

    /// Eq. 4: 0 where ρ < γ, else 1 − γ/ρ (the value the error buffer stores).
    pub fn normalised(&self, cell: usize) -> f64 {
        let rho = self.cells[cell].rho_px;
        if rho < self.gamma_px {
            0.0
        } else {
            1.0 - self.gamma_px / rho
        }
    }

    /// Whether the fragment stage ray casts this cell's pixels (ρ > γ).
    pub fn needs_ray_cast(&self, cell: usize) -> bool {
        self.cells[cell].rho_px > self.gamma_px
    }

    /// Fraction of cells with ρ > γ.
    pub fn fraction_above_gamma(&self) -> f64 {
        let n = (0..self.cells.len())
            .filter(|&c| self.needs_ray_cast(c))
            .count();
        n as f64 / self.cells.len().max(1) as f64
    }
}

/// A ray-cast surface hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayHit {
    /// Distance along the ray to the hit, metres.
    pub t_m: f64,
    /// Where the bounded march began (the ray's entry below the cell's max height).
    pub t_start_m: f64,
    pub unit: DVec3,
    pub height_m: f64,
}

/// CPU twin of the fragment stage's ray cast (§4 "Rendering"): march the pixel ray from the eye
/// through the height field between the cell's bounds (`min_m`, `max_m`), in steps of `step_px` pixels'
/// footprint (step_px·t/λ), and refine the first sign change of the clearance by bisection.
///
/// The march starts where the ray descends below R + max_m (nothing above can be hit) and ends
/// where it reaches R + min_m (it must have hit by then). A ridge thinner than one step can be
/// stepped over; on terrain of slope L it rises at most (1 + L)·step_px/2 pixels above the ray.
/// `None`: the ray grazes the cell without a hit, and the fragment is discarded.
pub fn ray_cast(
    view: &RenderView,
    dir: DVec3,
    (min_m, max_m): (f64, f64),
    step_px: f64,
    height: &dyn Fn(DVec3) -> f64,
) -> Option<RayHit> {
    let (eye_m, radius_m) = (view.eye_m, view.radius_m);
    let (t_start_m, t_end) = shell_interval(eye_m, dir, radius_m + min_m, radius_m + max_m)?;
    let clearance = |t: f64| {
        let p = eye_m + dir * t;
        let len = p.length();
        (len - radius_m) - height(p / len)
    };
    let hit = |t: f64| {
        let p = eye_m + dir * t;
        let unit = p.normalize();
        RayHit {
            t_m: t,
            t_start_m,
            unit,
            height_m: height(unit),
        }
    };
    if clearance(t_start_m) <= 0.0 {
        return Some(hit(t_start_m));
    }
    let per_m = step_px / view.pixels_per_radian();
    // Below a millimetre the footprint step would stall at t = 0.
    let mut a = t_start_m;
    while a < t_end {
        let mut z = (a + per_m * a.max(1e-3)).min(t_end);
        if clearance(z) <= 0.0 {
            for _ in 0..BISECTION_STEPS {
                let m = 0.5 * (a + z);
                if clearance(m) > 0.0 {
                    a = m;
                } else {
                    z = m;
                }
            }
            return Some(hit(0.5 * (a + z)));
        }
        a = z;
    }
    None
}
