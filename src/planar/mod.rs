//! Close-up LOD methods in a local tangent frame: geomipmapping with geomorphing ([`geomip`]),
//! the error-bounded projected grid ([`projgrid`]) and the geometry-image warping of its grid
//! ([`grid_warp`]).
//!
//! Every planar method places vertices on the plane tangent to the sphere at an anchor near the
//! viewer, in metres east (x) and north (y) of it, and maps a plane point to the sphere by the
//! gnomonic projection: u = normalise(a + e·x/R + n·y/R). That map is one deterministic
//! function of (x, y), so a vertex two patches share lands on the same point from both (no
//! crack), and it puts the sphere's curvature into every vertex exactly (the plane is only the
//! method's parameter space). Heights come from the same terrain function and streamed level
//! textures as the clipmap's (the vertex shader samples the finest filled level at the point).
//!
//! The f64 → f32 boundary is [`LocalFrame::view_basis`]: the anchor and its axes rotated into
//! view space (the viewer on +z̃) once per frame in f64; the GPU adds plane offsets of at most a
//! few kilometres to them, so nothing large cancels in f32 (docs/design.md#numerics).

pub mod geomip;
pub mod grid_warp;
pub mod projgrid;

use glam::{DMat3, DVec2, DVec3};

/// A tangent frame on the sphere: the anchor's unit vector and two unit axes spanning its
/// tangent plane (east-ish and north-ish: exactly east and north where the frame was first
/// made, carried along by projection when it moves, so it never depends on a meridian and
/// is defined at the poles).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalFrame {
    pub anchor: DVec3,
    pub east: DVec3,
    pub north: DVec3,
    pub radius_m: f64,
}

impl LocalFrame {
    /// The frame at unit vector `anchor` with east and north axes; at a pole (where east is
    /// undefined) the meridian φ = 0 gives them, as `geo::sphere` does.
    pub fn at(anchor: DVec3, radius_m: f64) -> Self {
        let anchor = anchor.normalize();
        let z = DVec3::Z;
        let east = z.cross(anchor);
        let east = if east.length_squared() < 1e-24 {
            DVec3::Y
        } else {
            east.normalize()
        };
        let north = anchor.cross(east);
        Self {
            anchor,
            east,
            north,
            radius_m,
        }
    }

    /// Unit vector of the plane point (x, y) metres from the anchor (gnomonic projection).
    pub fn unit_at(&self, p_m: DVec2) -> DVec3 {
        let r = self.radius_m;
        (self.anchor + self.east * (p_m.x / r) + self.north * (p_m.y / r)).normalize()
    }

    /// Plane coordinates of unit vector `u`, or `None` for the far hemisphere (the gnomonic
    /// projection's domain).
    pub fn plane_of(&self, u: DVec3) -> Option<DVec2> {
        let d = u.dot(self.anchor);
        if d <= 1e-9 {
            return None;
        }
        let r = self.radius_m;
        Some(DVec2::new(
            r * u.dot(self.east) / d,
            r * u.dot(self.north) / d,
        ))
    }

    /// The frame moved to the plane point `p_m`: the new anchor there, the axes carried over by
    /// projection onto its tangent plane (no meridian involved, so pole-safe), so a lattice of
    /// the old plane near `p_m` and the same lattice of the new plane nearly coincide.
    pub fn moved_to(&self, p_m: DVec2) -> Self {
        let anchor = self.unit_at(p_m);
        let east = (self.east - anchor * self.east.dot(anchor)).normalize();
        let north = anchor.cross(east);
        Self {
            anchor,
            east,
            north,
            radius_m: self.radius_m,
        }
    }

    /// Anchor, east and north in view space (`view_from_world` rotates world into view space):
    /// the per-frame f64 → f32 step of every planar method.
    pub fn view_basis(&self, view_from_world: &DMat3) -> [DVec3; 3] {
        [
            *view_from_world * self.anchor,
            *view_from_world * self.east,
            *view_from_world * self.north,
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geo::sphere;

    const R: f64 = 6_371_000.0;

    #[test]
    fn plane_round_trip_and_curvature() {
        for (phi, theta) in [
            (0.3, 0.8),
            (3.1, 1e-9),
            (-2.0, std::f64::consts::PI),
            (1.0, 1.57),
        ] {
            let f = LocalFrame::at(sphere::unit_vector(phi, theta), R);
            for p in [
                DVec2::new(0.0, 0.0),
                DVec2::new(12.5, -3.0),
                DVec2::new(-4000.0, 2500.0),
            ] {
                let u = f.unit_at(p);
                assert!((u.length() - 1.0).abs() < 1e-15);
                let back = f.plane_of(u).unwrap();
                assert!((back - p).length() < 1e-6, "{p} → {back}");
            }
            // Along an axis the great-circle distance is R·atan(x/R): curvature applied.
            let d =
                sphere::great_circle_distance_m(f.anchor, f.unit_at(DVec2::new(5000.0, 0.0)), R);
            assert!((d - R * (5000.0 / R).atan()).abs() < 1e-6);
        }
    }

    #[test]
    fn moved_frame_keeps_the_lattice() {
        // A lattice point 1 km east becomes the new anchor: points of both lattices 4 km
        // around it coincide to well under a millimetre (the re-anchoring does not pop).
        let f = LocalFrame::at(sphere::unit_vector(0.2, 0.7), R);
        let g = f.moved_to(DVec2::new(1024.0, 0.0));
        for p in [DVec2::new(2048.0, 2048.0), DVec2::new(-1024.0, -2048.0)] {
            let a = f.unit_at(p + DVec2::new(1024.0, 0.0));
            let b = g.unit_at(p);
            assert!(
                sphere::great_circle_distance_m(a, b, R) < 1e-3,
                "{}",
                (a - b).length() * R
            );
        }
    }
}
