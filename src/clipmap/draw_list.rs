//! What the clipmap draws this frame, given the levels chosen (`clipmap::selection`): the φ̃
//! sectors of the drawn levels inside the view frustum, merged into index ranges.
//!
//! Everything here is f64 on the CPU, in view space (planet centre at the origin, the viewer on
//! +z̃). The mesh is static in view space, so the bounding spheres of its sectors are computed
//! once per height range and only the frustum test runs per frame.

use std::ops::Range;

use glam::{DMat3, DVec3};

use super::density::DensityPlan;
use super::mesh::RingMesh;
use super::selection::LevelSelection;
use super::settings::level_outer_theta_rad;

/// A bounding sphere in view space (metres, planet centre at the origin).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    pub centre_m: DVec3,
    pub radius_m: f64,
}

/// A cone of directions from the planet's centre (unit axis, half-angle): the angular extent of
/// one mesh patch, independent of terrain heights, so it is computed once.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cone {
    pub axis: DVec3,
    pub half_angle_rad: f64,
}

impl Cone {
    /// The smallest sphere holding {r·u : u in the cone, r ∈ [r_lo, r_hi]}. Distance from a
    /// point on the axis grows with the angle and is convex in r, so the farthest points are
    /// the four extremes (r_lo or r_hi, on the axis or on the rim).
    pub fn bounding_sphere(&self, r_lo_m: f64, r_hi_m: f64) -> Sphere {
        let (sin_b, cos_b) = self.half_angle_rad.min(std::f64::consts::PI).sin_cos();
        let lo_along = r_lo_m * cos_b.min(1.0);
        let centre_along = 0.5 * (lo_along.min(r_lo_m) + r_hi_m);
        let far = |r: f64| {
            let rim = ((r * cos_b - centre_along).powi(2) + (r * sin_b).powi(2)).sqrt();
            rim.max((r - centre_along).abs())
        };
        Sphere {
            centre_m: self.axis * centre_along,
            radius_m: far(r_lo_m).max(far(r_hi_m)),
        }
    }
}

/// The direction cones of every (level, sector) band and cap of a mesh.
#[derive(Clone, Debug)]
pub struct SectorBounds {
    pub bands: Vec<Vec<Cone>>,
    pub caps: Vec<Vec<Cone>>,
}

impl SectorBounds {
    pub fn new(mesh: &RingMesh) -> Self {
        let levels = mesh.levels.len() as u32;
        let mut bands = Vec::new();
        let mut caps = Vec::new();
        for level in 0..levels {
            let outer = level_outer_theta_rad(level);
            let inner = 0.5 * outer;
            let phis: Vec<(f64, f64)> = (0..mesh.sectors)
                .map(|s| mesh.sector_phi_range_rad(s))
                .collect();
            bands.push(
                phis.iter()
                    .map(|phi| patch_cone(*phi, (inner, outer)))
                    .collect(),
            );
            caps.push(
                phis.iter()
                    .map(|phi| patch_cone(*phi, (0.0, inner)))
                    .collect(),
            );
        }
        Self { bands, caps }
    }
}

/// A cone around the patch: the axis through its sampled directions, the half-angle to the
/// farthest sample plus half the largest gap between samples (no direction between samples is
/// farther from the axis than its nearest sample plus that).
fn patch_cone(phi: (f64, f64), theta: (f64, f64)) -> Cone {
    const N: usize = 9;
    let mut dirs = Vec::with_capacity(N * N);
    for a in 0..N {
        let ph = phi.0 + (phi.1 - phi.0) * a as f64 / (N - 1) as f64;
        for b in 0..N {
            let th = theta.0 + (theta.1 - theta.0) * b as f64 / (N - 1) as f64;
            dirs.push(DVec3::new(
                ph.cos() * th.sin(),
                ph.sin() * th.sin(),
                th.cos(),
            ));
        }
    }
    let sum: DVec3 = dirs.iter().copied().sum();
    let axis = if sum.length() > 1e-12 {
        sum.normalize()
    } else {
        DVec3::Z
    };
    let spread = dirs
        .iter()
        .map(|d| d.dot(axis).clamp(-1.0, 1.0).acos())
        .fold(0.0, f64::max);
    let gap = ((theta.1 - theta.0) / (N - 1) as f64)
        .max((phi.1 - phi.0) / (N - 1) as f64 * theta.1.sin());
    Cone {
        axis,
        half_angle_rad: spread + 0.5 * gap,
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

/// What a draw range's vertices need of the terrain shader.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Variant {
    /// Neither a blend into the coarser level nor a density morph.
    #[default]
    Plain,
    /// Some vertex blends into the coarser level.
    Blend,
    /// Some vertex morphs (with the blend: a morph target may blend).
    Morph,
}

/// What a planar LOD method near the viewer leaves to the clipmap.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlanarCut {
    /// The finest level drawn (those finer are filled, the planar method samples them, but lie
    /// wholly under its square).
    pub finest: u32,
    /// Levels whose inner edge lies within this angle of the viewer reach into the square: their
    /// ranges start at [`DrawList::first_cut`].
    pub cut_rad: f64,
}

impl PlanarCut {
    /// No planar method: every drawn level, nothing cut.
    pub const NONE: PlanarCut = PlanarCut {
        finest: u32::MAX,
        cut_rad: 0.0,
    };
}

/// Index ranges to draw and what was skipped.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DrawList {
    pub ranges: Vec<Range<u32>>,
    /// Per range: which shader variant it needs (the others leave out code that a CPU
    /// rasteriser runs even when no lane takes it).
    pub variants: Vec<Variant>,
    /// Per range: its level (the water cull decides per level which pipeline draws it).
    pub levels: Vec<u32>,
    /// The mesh's ranges drawn, unmerged, with their variants: which vertices the frame places
    /// (`clipmap::mesh::RangeVertices`, the vertex pre-pass) and with which variant.
    pub pieces: Vec<(Range<u32>, Variant)>,
    pub triangles: u64,
    pub sectors_drawn: u32,
    pub sectors_culled: u32,
    /// Ranges from this index on belong to levels a planar method's square reaches into: only
    /// they need the pipelines that cut the square out (a fragment discard costs the coarser
    /// levels' early depth test otherwise). `ranges.len()` when none do.
    pub first_cut: usize,
}

impl DrawList {
    /// Visible sectors of the drawn levels up to `finest` plus the cap of the finest one;
    /// adjacent index ranges are merged into one draw call (no frustum: nothing culled, for
    /// tests). `radius_range_m(level)` bounds the distance from the planet's centre of the
    /// terrain within that level's outer ring. `planar`: what a planar method near the viewer
    /// leaves to the clipmap ([`PlanarCut::NONE`]: everything).
    pub fn build(
        mesh: &RingMesh,
        bounds: &SectorBounds,
        selection: &LevelSelection,
        densities: &DensityPlan,
        frustum: Option<&Frustum>,
        radius_range_m: impl Fn(u32) -> (f64, f64),
        planar: PlanarCut,
    ) -> Self {
        let PlanarCut { finest, cut_rad } = planar;
        let mut list = DrawList::default();
        let mut first_cut = None;
        // `count`: the part that stands for its sector in the drawn/culled counts.
        let push = |list: &mut DrawList,
                    range: &Range<u32>,
                    sphere: &Sphere,
                    count: bool,
                    variant: Variant,
                    level: u32| {
            if frustum.is_some_and(|f| !f.intersects(sphere)) {
                list.sectors_culled += count as u32;
                return;
            }
            list.sectors_drawn += count as u32;
            list.triangles += ((range.end - range.start) / 3) as u64;
            list.pieces.push((range.clone(), variant));
            match list.ranges.last_mut() {
                Some(last)
                    if last.end == range.start
                        && list.variants.last() == Some(&variant)
                        && list.levels.last() == Some(&level) =>
                {
                    last.end = range.end
                }
                _ => {
                    list.ranges.push(range.clone());
                    list.variants.push(variant);
                    list.levels.push(level);
                }
            }
        };
        let finest = finest.min(selection.finest);
        for level in selection.drawn_levels().filter(|&l| l <= finest) {
            if first_cut.is_none() && 0.5 * level_outer_theta_rad(level) < cut_rad {
                // From here on no range merges with one before.
                first_cut = Some(list.ranges.len());
                list.ranges.push(0..0);
                list.variants.push(Variant::Plain);
                list.levels.push(level);
            }
            let (lo, hi) = radius_range_m(level);
            let d = densities.levels[level as usize];
            let r = &mesh.levels[level as usize][d.body.k as usize];
            // The body's vertices lie strictly inside the level; an edge row's also on its
            // edge ring.
            let body_morph = d.body.morph > 0.0;
            let variant = |morph: bool, blend: bool| match (morph, blend) {
                (true, _) => Variant::Morph,
                (false, true) => Variant::Blend,
                (false, false) => Variant::Plain,
            };
            let parts = [
                (&r.body, variant(body_morph, false)),
                (&r.body_blend, variant(body_morph, true)),
                (
                    &r.outer[(d.outer.k - d.body.k) as usize],
                    variant(body_morph || d.outer.morph > 0.0, true),
                ),
                (
                    &r.inner[(d.inner.k - d.body.k) as usize],
                    variant(body_morph || d.inner.morph > 0.0, r.inner_blends),
                ),
            ];
            // Part by part, so each part's sectors merge into few draw calls. A sector counts
            // once in the drawn/culled figures.
            for (i, (part, v)) in parts.iter().enumerate() {
                for (sector, (range, cone)) in
                    part.iter().zip(&bounds.bands[level as usize]).enumerate()
                {
                    // The sector's first part that has triangles stands for it.
                    let first = parts[..i].iter().all(|(p, _)| p[sector].is_empty());
                    if !range.is_empty() {
                        push(
                            &mut list,
                            range,
                            &cone.bounding_sphere(lo, hi),
                            first,
                            *v,
                            level,
                        );
                    }
                }
            }
        }
        let f = finest as usize;
        let (lo, hi) = radius_range_m(finest);
        let d = densities.levels[f];
        let cap = if d.inner.morph > 0.0 {
            Variant::Morph
        } else {
            Variant::Plain
        };
        for (range, cone) in mesh.levels[f][d.body.k as usize]
            .cap
            .iter()
            .zip(&bounds.caps[f])
        {
            push(
                &mut list,
                range,
                &cone.bounding_sphere(lo, hi),
                true,
                cap,
                finest,
            );
        }
        list.first_cut = first_cut.unwrap_or(list.ranges.len());
        list
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The cone sphere holds every point of the shell sector it bounds.
    #[test]
    fn cone_spheres_hold_their_patches() {
        for (phi, theta) in [
            ((0.0, 0.2), (0.5, 1.0)),
            ((1.0, 1.2), (0.0, 0.01)),
            ((3.0, 3.2), (1.5, 3.1)),
        ] {
            let cone = patch_cone(phi, theta);
            let sphere = cone.bounding_sphere(6.36e6, 6.38e6);
            for a in 0..40 {
                for b in 0..40 {
                    let ph = phi.0 + (phi.1 - phi.0) * a as f64 / 39.0;
                    let th = theta.0 + (theta.1 - theta.0) * b as f64 / 39.0;
                    for r in [6.36e6, 6.37e6, 6.38e6] {
                        let p = DVec3::new(ph.cos() * th.sin(), ph.sin() * th.sin(), th.cos()) * r;
                        assert!((p - sphere.centre_m).length() <= sphere.radius_m * (1.0 + 1e-12));
                    }
                }
            }
        }
    }
}
