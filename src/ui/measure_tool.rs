//! The viewer's measure tool (issue 38's measure): points clicked on the terrain, the
//! great-circle distance along them, the distance along the terrain, the height difference
//! and, for three or more, the enclosed area; the terrain profile along the segments for the
//! panel's plot, and where it all lies on the screen to be drawn over the view. f64 and no
//! window type: the panel and the window draw what this computes.

use glam::DVec3;

use crate::geo::camera::Camera;
use crate::geo::sphere;
use crate::measure::{HeightField, ProbeHit, ProfilePoint, great_circle_profile};

/// Profile points per segment (both ends included).
pub const SEGMENT_SAMPLES: usize = 200;

/// A clicked point: the pick's answer there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeasuredPoint {
    pub hit: ProbeHit,
    /// Metres from the planet's centre, world frame.
    pub world_m: DVec3,
}

/// What the points add up to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Totals {
    pub points: usize,
    /// Along the great circles between consecutive points, on the sphere of radius R.
    pub great_circle_m: f64,
    /// Along the terrain (the profile's polyline at its heights).
    pub along_terrain_m: f64,
    /// The last point's height minus the first's.
    pub height_difference_m: f64,
    /// For three or more points: the area of the polygon they close, on the sphere.
    pub area_m2: Option<f64>,
}

/// The tool's points and the profile through them.
#[derive(Clone, Debug, Default)]
pub struct MeasureTool {
    /// Clicks add points while this is on.
    pub on: bool,
    points: Vec<MeasuredPoint>,
    /// The profile along every segment, distances from the first point.
    profile: Vec<ProfilePoint>,
    great_circle_m: f64,
    along_terrain_m: f64,
}

impl MeasureTool {
    /// Adds `point`, profiling the segment from the last one over `field` (the terrain
    /// function at full resolution, as `globe profile` does).
    pub fn add<H: HeightField + ?Sized>(&mut self, point: MeasuredPoint, field: &H) {
        if let Some(last) = self.points.last() {
            let from = (last.hit.lat_deg, last.hit.lon_deg);
            let to = (point.hit.lat_deg, point.hit.lon_deg);
            // The same place twice or antipodes add no segment (no one profile between them).
            if let Ok(p) = great_circle_profile(field, from, to, SEGMENT_SAMPLES) {
                let offset = self.great_circle_m;
                let skip = usize::from(!self.profile.is_empty());
                self.profile
                    .extend(p.points.iter().skip(skip).map(|q| ProfilePoint {
                        distance_m: q.distance_m + offset,
                        ..*q
                    }));
                self.great_circle_m += p.great_circle_m;
                self.along_terrain_m += p.along_terrain_m;
            }
        }
        self.points.push(point);
    }

    pub fn clear(&mut self) {
        let on = self.on;
        *self = Self {
            on,
            ..Self::default()
        };
    }

    pub fn points(&self) -> &[MeasuredPoint] {
        &self.points
    }

    pub fn profile(&self) -> &[ProfilePoint] {
        &self.profile
    }

    /// The totals, once there is a point.
    pub fn totals(&self, radius_m: f64) -> Option<Totals> {
        let (first, last) = (self.points.first()?, self.points.last()?);
        let corners: Vec<DVec3> = self.points.iter().map(|p| p.world_m.normalize()).collect();
        Some(Totals {
            points: self.points.len(),
            great_circle_m: self.great_circle_m,
            along_terrain_m: self.along_terrain_m,
            height_difference_m: last.hit.height_m - first.hit.height_m,
            area_m2: (corners.len() >= 3).then(|| sphere::polygon_area_m2(&corners, radius_m)),
        })
    }

    /// Where the profile (or the lone point) lies on a `width` × `height` view of `camera`, in
    /// pixels from the top-left corner; None for a point behind the eye.
    pub fn on_screen(
        &self,
        camera: &Camera,
        width: u32,
        height: u32,
        radius_m: f64,
    ) -> Vec<Option<(f64, f64)>> {
        let world = |p: &ProfilePoint| {
            let (phi, theta) = sphere::phi_theta_from_lat_lon_deg(p.lat_deg, p.lon_deg);
            sphere::ecef_m(phi, theta, p.height_m, radius_m)
        };
        let points: Vec<DVec3> = if self.profile.is_empty() {
            self.points.iter().map(|p| p.world_m).collect()
        } else {
            self.profile.iter().map(world).collect()
        };
        points
            .iter()
            .map(|&p| project_px(camera, p, width, height, radius_m))
            .collect()
    }

    /// The clicked points on the screen (as [`MeasureTool::on_screen`]).
    pub fn points_on_screen(
        &self,
        camera: &Camera,
        width: u32,
        height: u32,
        radius_m: f64,
    ) -> Vec<Option<(f64, f64)>> {
        (self.points.iter())
            .map(|p| project_px(camera, p.world_m, width, height, radius_m))
            .collect()
    }
}

/// The world point `p_world_m` on a `width` × `height` view of `camera`: pixel coordinates
/// from the top-left corner (pixel (x, y)'s centre at (x + ½, y + ½), as
/// [`crate::geo::camera::pixel_ray_view`] casts it); None behind the eye.
pub fn project_px(
    camera: &Camera,
    p_world_m: DVec3,
    width: u32,
    height: u32,
    radius_m: f64,
) -> Option<(f64, f64)> {
    let frame = camera.view_frame();
    let rel = frame.world_from_view.transpose() * p_world_m - camera.eye_view_at_radius_m(radius_m);
    let c = camera.view_from_camera().transpose() * rel;
    if c.z >= 0.0 {
        return None;
    }
    let f = crate::geo::projection::focal_length_px(height, camera.fov_y_rad());
    Some((
        0.5 * f64::from(width) + f * c.x / -c.z,
        0.5 * f64::from(height) - f * c.y / -c.z,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measure::ConstantHeight;
    use crate::terrain::Terrain;
    use crate::ui::pick::{PickRequest, pick};

    fn field() -> ConstantHeight {
        ConstantHeight {
            radius_m: crate::geo::EARTH_RADIUS_M,
            height_m: 100.0,
        }
    }

    fn point(lat: f64, lon: f64, h: f64) -> MeasuredPoint {
        let r = crate::geo::EARTH_RADIUS_M;
        let (phi, theta) = sphere::phi_theta_from_lat_lon_deg(lat, lon);
        MeasuredPoint {
            hit: ProbeHit {
                lat_deg: lat,
                lon_deg: lon,
                height_m: h,
                distance_m: 0.0,
            },
            world_m: sphere::ecef_m(phi, theta, h, r),
        }
    }

    /// Three corners of the octant: two quarter great circles, the terrain at 100 m makes the
    /// path longer by the ratio (R + 100)/R (to the chords' sagitta), the area is 4πR²/8;
    /// Escape's clear empties it.
    #[test]
    fn an_octant_measured() {
        let r = crate::geo::EARTH_RADIUS_M;
        let mut tool = MeasureTool::default();
        for (lat, lon) in [(0.0, 0.0), (0.0, 90.0), (90.0, 0.0)] {
            tool.add(point(lat, lon, 100.0), &field());
        }
        let t = tool.totals(r).unwrap();
        assert_eq!(t.points, 3);
        assert!(
            (t.great_circle_m - r * std::f64::consts::PI).abs() < 1e-6,
            "{t:?}"
        );
        let quarter = std::f64::consts::FRAC_PI_2;
        let n = (SEGMENT_SAMPLES - 1) as f64;
        let chords = 2.0 * n * 2.0 * (r + 100.0) * (quarter / (2.0 * n)).sin();
        assert!((t.along_terrain_m - chords).abs() < 1e-6, "{t:?}");
        assert!((t.area_m2.unwrap() / (std::f64::consts::PI * r * r / 2.0) - 1.0).abs() < 1e-12);
        assert_eq!(tool.profile().len(), 2 * SEGMENT_SAMPLES - 1);
        let last = tool.profile().last().unwrap();
        assert!((last.distance_m - t.great_circle_m).abs() < 1e-6);
        tool.on = true;
        tool.clear();
        assert!(tool.on && tool.totals(r).is_none() && tool.profile().is_empty());
    }

    /// A point picked through a pixel projects back onto that pixel's centre.
    #[test]
    fn a_picked_point_projects_onto_its_pixel() {
        let terrain = Terrain::analytic_earth();
        let camera = Camera {
            lat_deg: 46.0,
            lon_deg: 8.0,
            altitude_m: 12_000.0,
            heading_deg: 30.0,
            pitch_deg: -35.0,
            roll_deg: 5.0,
            fov_y_deg: 60.0,
        };
        for (x, y) in [(10, 300), (320, 200), (630, 399)] {
            let r = PickRequest {
                camera,
                width: 640,
                height: 400,
                x,
                y,
            };
            let (_, world) = pick(&terrain, &r).hit.expect("terrain under the pixel");
            let (px, py) = project_px(&camera, world, 640, 400, terrain.radius_m()).unwrap();
            assert!((px - (f64::from(x) + 0.5)).abs() < 1e-3, "{px} vs {x}");
            assert!((py - (f64::from(y) + 0.5)).abs() < 1e-3, "{py} vs {y}");
        }
        let behind = point(46.0, 8.0, -1000.0);
        let up = Camera {
            pitch_deg: 60.0,
            ..camera
        };
        assert_eq!(
            project_px(&up, behind.world_m, 640, 400, terrain.radius_m()),
            None
        );
    }
}
