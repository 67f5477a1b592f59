//! What the clipmap draws this frame: the visible levels (spherical-clipmaps.md §4.5, eq. 5–8)
//! and the φ̃ sectors inside the view frustum.
//!
//! Everything here is f64 on the CPU, in view space (planet centre at the origin, the viewer on
//! +z̃). The mesh is static in view space, so the bounding spheres of its sectors are computed
//! once per height range and only the frustum test runs per frame.

use std::ops::Range;

use glam::{DMat3, DVec3};

use super::mesh::RingMesh;
use super::settings::level_outer_theta_rad;

/// Why a level is or is not drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LevelStatus {
    Drawn,
    /// All of the level lies beyond θ̃max (eq. 6 with the mountain safety term): hidden by the
    /// planet's curvature.
    BeyondHorizon,
    /// The whole level lies inside θ̃min (eq. 8): it would cover less than one pixel below the
    /// viewer, so the cap of the next coarser level stands in for it.
    SubPixel,
}

impl LevelStatus {
    pub fn label(self) -> &'static str {
        match self {
            Self::Drawn => "drawn",
            Self::BeyondHorizon => "beyond horizon (θ̃ > θ̃max)",
            Self::SubPixel => "sub-pixel (θ̃ < θ̃min)",
        }
    }
}

/// The levels drawn this frame: `coarsest..=finest`, with the bounds that chose them.
#[derive(Clone, Debug, PartialEq)]
pub struct LevelSelection {
    pub coarsest: u32,
    pub finest: u32,
    pub theta_max_rad: f64,
    pub theta_min_rad: f64,
    pub status: Vec<LevelStatus>,
}

impl LevelSelection {
    /// Level i is drawn iff its inner edge 2^−(i+1)π lies inside θ̃max and its outer edge
    /// 2^−iπ lies outside θ̃min. The finest level is always at least the coarsest, so a
    /// camera far out still draws one level and its cap.
    pub fn new(levels: u32, theta_max_rad: f64, theta_min_rad: f64) -> Self {
        let mut status = Vec::with_capacity(levels as usize);
        for i in 0..levels {
            let outer = level_outer_theta_rad(i);
            let inner = 0.5 * outer;
            status.push(if inner >= theta_max_rad {
                LevelStatus::BeyondHorizon
            } else if outer < theta_min_rad {
                LevelStatus::SubPixel
            } else {
                LevelStatus::Drawn
            });
        }
        let coarsest = status.iter().position(|s| *s == LevelStatus::Drawn);
        let finest = status.iter().rposition(|s| *s == LevelStatus::Drawn);
        let (coarsest, finest) = match (coarsest, finest) {
            (Some(c), Some(f)) => (c as u32, f as u32),
            _ => {
                // Degenerate bounds (θ̃min beyond θ̃max, only at absurd zoom-outs): draw the
                // level at the horizon so the planet never disappears.
                let c = status
                    .iter()
                    .position(|s| *s != LevelStatus::BeyondHorizon)
                    .unwrap_or(0) as u32;
                let c = c.saturating_sub(1).min(levels - 1);
                status[c as usize] = LevelStatus::Drawn;
                (c, c)
            }
        };
        Self {
            coarsest,
            finest,
            theta_max_rad,
            theta_min_rad,
            status,
        }
    }

    pub fn drawn_levels(&self) -> Range<u32> {
        self.coarsest..self.finest + 1
    }
}

/// A bounding sphere in view space (metres, planet centre at the origin).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    pub centre_m: DVec3,
    pub radius_m: f64,
}

/// Bounding spheres of every (level, sector) band and cap for a terrain height range.
#[derive(Clone, Debug)]
pub struct SectorBounds {
    pub bands: Vec<Vec<Sphere>>,
    pub caps: Vec<Vec<Sphere>>,
    pub radius_m: f64,
    pub height_range_m: (f64, f64),
}

impl SectorBounds {
    pub fn new(mesh: &RingMesh, radius_m: f64, min_height_m: f64, max_height_m: f64) -> Self {
        let levels = mesh.bands.len() as u32;
        let r = (radius_m + min_height_m, radius_m + max_height_m);
        let mut bands = Vec::new();
        let mut caps = Vec::new();
        for level in 0..levels {
            let outer = level_outer_theta_rad(level);
            let inner = 0.5 * outer;
            let mut b = Vec::new();
            let mut c = Vec::new();
            for s in 0..mesh.sectors {
                let phi = mesh.sector_phi_range_rad(s);
                b.push(patch_bound(phi, (inner, outer), r));
                c.push(patch_bound(phi, (0.0, inner), r));
            }
            bands.push(b);
            caps.push(c);
        }
        Self {
            bands,
            caps,
            radius_m,
            height_range_m: (min_height_m, max_height_m),
        }
    }
}

/// A conservative sphere around the patch: samples on a 9×9 grid at both radii, then grown by
/// the largest arc sagitta between neighbouring samples.
fn patch_bound(phi: (f64, f64), theta: (f64, f64), radius: (f64, f64)) -> Sphere {
    const N: usize = 9;
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    let mut points = Vec::with_capacity(N * N * 2);
    for a in 0..N {
        let ph = phi.0 + (phi.1 - phi.0) * a as f64 / (N - 1) as f64;
        for b in 0..N {
            let th = theta.0 + (theta.1 - theta.0) * b as f64 / (N - 1) as f64;
            let dir = DVec3::new(ph.cos() * th.sin(), ph.sin() * th.sin(), th.cos());
            for rad in [radius.0, radius.1] {
                let p = dir * rad;
                lo = lo.min(p);
                hi = hi.max(p);
                points.push(p);
            }
        }
    }
    let centre = 0.5 * (lo + hi);
    let spread = points
        .iter()
        .map(|p| (*p - centre).length())
        .fold(0.0, f64::max);
    let step = ((theta.1 - theta.0) / (N - 1) as f64)
        .max((phi.1 - phi.0) / (N - 1) as f64 * theta.1.sin());
    let sagitta = radius.1 * (1.0 - (0.5 * step.min(std::f64::consts::PI)).cos());
    Sphere {
        centre_m: centre,
        radius_m: spread + sagitta,
    }
}

/// The view frustum as inward planes in camera space (camera looks down −z, infinite far).
#[derive(Clone, Copy, Debug)]
pub struct Frustum {
    /// Unit inward normals; a point p is inside when n·p ≥ d for every plane (n, d).
    planes: [(DVec3, f64); 5],
    camera_from_view: DMat3,
    eye_view_m: DVec3,
}

impl Frustum {
    /// `camera_from_view` rotates view-space directions into camera space; `eye_view_m` is the
    /// eye in view space.
    pub fn new(
        camera_from_view: DMat3,
        eye_view_m: DVec3,
        fov_y_rad: f64,
        aspect: f64,
        near_m: f64,
    ) -> Self {
        let ty = (0.5 * fov_y_rad).tan();
        let tx = ty * aspect;
        let side = |n: DVec3| (n.normalize(), 0.0);
        let planes = [
            side(DVec3::new(1.0, 0.0, -tx)),
            side(DVec3::new(-1.0, 0.0, -tx)),
            side(DVec3::new(0.0, 1.0, -ty)),
            side(DVec3::new(0.0, -1.0, -ty)),
            (DVec3::new(0.0, 0.0, -1.0), near_m),
        ];
        Self {
            planes,
            camera_from_view,
            eye_view_m,
        }
    }

    /// False only when the sphere lies wholly outside one plane.
    pub fn intersects(&self, sphere: &Sphere) -> bool {
        let c = self.camera_from_view * (sphere.centre_m - self.eye_view_m);
        self.planes
            .iter()
            .all(|(n, d)| n.dot(c) - d >= -sphere.radius_m)
    }
}

/// Index ranges to draw and what was skipped.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DrawList {
    pub ranges: Vec<Range<u32>>,
    pub triangles: u64,
    pub sectors_drawn: u32,
    pub sectors_culled: u32,
}

impl DrawList {
    /// Visible sectors of the drawn levels plus the cap of the finest one; adjacent index
    /// ranges are merged into one draw call.
    pub fn build(
        mesh: &RingMesh,
        bounds: &SectorBounds,
        selection: &LevelSelection,
        frustum: &Frustum,
    ) -> Self {
        let mut list = DrawList::default();
        let push = |list: &mut DrawList, range: &Range<u32>, sphere: &Sphere| {
            if !frustum.intersects(sphere) {
                list.sectors_culled += 1;
                return;
            }
            list.sectors_drawn += 1;
            list.triangles += ((range.end - range.start) / 3) as u64;
            match list.ranges.last_mut() {
                Some(last) if last.end == range.start => last.end = range.end,
                _ => list.ranges.push(range.clone()),
            }
        };
        for level in selection.drawn_levels() {
            for (range, sphere) in mesh.bands[level as usize]
                .iter()
                .zip(&bounds.bands[level as usize])
            {
                push(&mut list, range, sphere);
            }
        }
        let f = selection.finest as usize;
        for (range, sphere) in mesh.caps[f].iter().zip(&bounds.caps[f]) {
            push(&mut list, range, sphere);
        }
        list
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn selection_is_contiguous_and_respects_bounds() {
        let sel = LevelSelection::new(30, 0.06, 1e-8);
        for i in 0..30 {
            let drawn = sel.status[i as usize] == LevelStatus::Drawn;
            assert_eq!(drawn, sel.drawn_levels().contains(&i));
        }
        assert_eq!(sel.status[0], LevelStatus::BeyondHorizon);
        assert!(level_outer_theta_rad(sel.coarsest) * 0.5 < 0.06);
        assert!(level_outer_theta_rad(sel.coarsest - 1) * 0.5 >= 0.06);
    }
}
