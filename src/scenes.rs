//! The named scenes of DESIGN.md, shared by the viewer's bookmarks, `globe render`, the tests,
//! the report and the benchmarks. Keep the numbers: other tools compare against the same views.

use crate::geo::camera::Camera;

/// Vertical field of view of every named scene (DESIGN.md).
pub const SCENE_FOV_Y_DEG: f64 = 60.0;

/// How a scene's camera height is given.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SceneHeight {
    /// Metres above the sphere of radius R.
    AboveSphere(f64),
    /// Metres above the terrain of the height source in use, at the scene's point.
    AboveTerrain(f64),
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scene {
    pub name: &'static str,
    pub lat_deg: f64,
    pub lon_deg: f64,
    pub height: SceneHeight,
    pub heading_deg: f64,
    /// Negative looks down; −90 looks at the planet's centre.
    pub pitch_deg: f64,
    pub stresses: &'static str,
}

pub const SCENES: [Scene; 6] = [
    Scene {
        name: "space",
        lat_deg: 45.65,
        lon_deg: 10.65,
        height: SceneHeight::AboveSphere(20_000_000.0),
        heading_deg: 0.0,
        pitch_deg: -90.0,
        stresses: "whole disk, coarsest levels only",
    },
    Scene {
        name: "aircraft",
        lat_deg: 45.65,
        lon_deg: 10.65,
        height: SceneHeight::AboveSphere(10_000.0),
        heading_deg: 315.0,
        pitch_deg: -20.0,
        stresses: "Alps to the horizon, many levels",
    },
    Scene {
        name: "ground",
        lat_deg: 45.65,
        lon_deg: 10.65,
        height: SceneHeight::AboveTerrain(2.0),
        heading_deg: 0.0,
        pitch_deg: -5.0,
        stresses: "finest levels, f32 limits, detail below data",
    },
    Scene {
        name: "north-pole",
        lat_deg: 90.0,
        lon_deg: 0.0,
        height: SceneHeight::AboveTerrain(100.0),
        heading_deg: 0.0,
        pitch_deg: -30.0,
        stresses: "the pole inside the view, seam meridian",
    },
    Scene {
        name: "antimeridian",
        lat_deg: 0.0,
        lon_deg: 180.0,
        height: SceneHeight::AboveSphere(1_000.0),
        heading_deg: 90.0,
        pitch_deg: -30.0,
        stresses: "φ wrap-around at ±180°",
    },
    Scene {
        name: "everest",
        lat_deg: 27.95,
        lon_deg: 86.90,
        height: SceneHeight::AboveSphere(9_000.0),
        heading_deg: 0.0,
        pitch_deg: -10.0,
        stresses: "steepest relief, horizon bound with mountains",
    },
];

impl Scene {
    pub fn by_name(name: &str) -> Option<&'static Scene> {
        SCENES.iter().find(|s| s.name == name)
    }

    /// The camera of this scene over a terrain whose height at (lat, lon) is `terrain_m`.
    pub fn camera(&self, terrain_m: impl Fn(f64, f64) -> f64) -> Camera {
        let altitude_m = match self.height {
            SceneHeight::AboveSphere(h) => h,
            SceneHeight::AboveTerrain(h) => terrain_m(self.lat_deg, self.lon_deg) + h,
        };
        Camera {
            lat_deg: self.lat_deg,
            lon_deg: self.lon_deg,
            altitude_m,
            heading_deg: self.heading_deg,
            pitch_deg: self.pitch_deg,
            roll_deg: 0.0,
            fov_y_deg: SCENE_FOV_Y_DEG,
        }
    }

    pub fn height_label(&self) -> String {
        match self.height {
            SceneHeight::AboveSphere(h) => format!("{h} m"),
            SceneHeight::AboveTerrain(h) => format!("{h} m above terrain"),
        }
    }
}

/// Lists the scenes for names in error messages.
pub fn scene_names() -> String {
    SCENES.iter().map(|s| s.name).collect::<Vec<_>>().join(", ")
}

/// The `flight` path (DESIGN.md): from `space` straight down to `ground` over Lake Garda. The
/// height above terrain falls exponentially (the same factor every frame: the image changes at
/// a steady rate from orbit to the last metres), passing through `aircraft`'s 10 km; heading and
/// pitch ease from space's (0°, −90°) through aircraft's (315°, −20°) to ground's (0°, −5°).
pub mod flight {
    use super::{SCENES, SceneHeight};
    use crate::geo::camera::Camera;

    pub const NAME: &str = "flight";

    /// The camera at `t` ∈ [0, 1] along the path (0: `space`, 1: `ground`), over a terrain
    /// whose height at (lat, lon) is `terrain_m`.
    pub fn camera(t: f64, terrain_m: impl Fn(f64, f64) -> f64) -> Camera {
        let [space, aircraft, ground] = [&SCENES[0], &SCENES[1], &SCENES[2]];
        let t = t.clamp(0.0, 1.0);
        let ground_m = terrain_m(ground.lat_deg, ground.lon_deg);
        let above = |h: SceneHeight| match h {
            SceneHeight::AboveSphere(a) => (a - ground_m).max(1e-3),
            SceneHeight::AboveTerrain(a) => a,
        };
        let (h0, ha, h1) = (
            above(space.height),
            above(aircraft.height),
            above(ground.height),
        );
        let height = (h0.ln() + t * (h1.ln() - h0.ln())).exp();
        // Where the path passes the aircraft's height: the heading/pitch keyframe.
        let ta = (h0 / ha).ln() / (h0 / h1).ln();
        let smooth = |x: f64| x * x * (3.0 - 2.0 * x);
        // Headings unwrapped: 0 → −45 (= 315) → 0.
        let (heading, pitch) = if t <= ta {
            let u = smooth(t / ta);
            (
                (aircraft.heading_deg - 360.0) * u,
                space.pitch_deg + (aircraft.pitch_deg - space.pitch_deg) * u,
            )
        } else {
            let u = smooth((t - ta) / (1.0 - ta));
            (
                (aircraft.heading_deg - 360.0) * (1.0 - u),
                aircraft.pitch_deg + (ground.pitch_deg - aircraft.pitch_deg) * u,
            )
        };
        Camera {
            lat_deg: ground.lat_deg,
            lon_deg: ground.lon_deg,
            altitude_m: ground_m + height,
            heading_deg: heading.rem_euclid(360.0),
            pitch_deg: pitch,
            roll_deg: 0.0,
            fov_y_deg: super::SCENE_FOV_Y_DEG,
        }
    }

    /// The camera of frame `i` of `frames` (the first is `space`, the last `ground`).
    pub fn frame_camera(i: usize, frames: usize, terrain_m: impl Fn(f64, f64) -> f64) -> Camera {
        let t = if frames <= 1 {
            1.0
        } else {
            i as f64 / (frames - 1) as f64
        };
        camera(t, terrain_m)
    }

    #[cfg(test)]
    mod tests {
        use super::*;

        #[test]
        fn starts_at_space_passes_aircraft_and_ends_at_ground() {
            let terrain = |_: f64, _: f64| 65.0;
            let start = camera(0.0, terrain);
            let space = SCENES[0].camera(terrain);
            assert!((start.altitude_m - space.altitude_m).abs() < 1e-6 * space.altitude_m);
            assert_eq!(start.pitch_deg, -90.0);
            let end = camera(1.0, terrain);
            let ground = SCENES[2].camera(terrain);
            assert!((end.altitude_m - ground.altitude_m).abs() < 1e-9);
            assert!((end.pitch_deg - ground.pitch_deg).abs() < 1e-12);
            assert!(end.heading_deg.abs() < 1e-9 || (end.heading_deg - 360.0).abs() < 1e-9);
            // Exponential: equal steps in t divide the height above terrain by equal factors.
            let h = |t: f64| camera(t, terrain).altitude_m - 65.0;
            let (r1, r2) = (h(0.2) / h(0.3), h(0.7) / h(0.8));
            assert!((r1 / r2 - 1.0).abs() < 1e-9);
            // Somewhere on the way the camera is the aircraft's.
            let air = SCENES[1].camera(terrain);
            let ta = ((20_000_000.0 - 65.0) / (10_000.0 - 65.0f64)).ln()
                / ((20_000_000.0 - 65.0) / 2.0f64).ln();
            let c = camera(ta, terrain);
            assert!((c.altitude_m - air.altitude_m).abs() < 1e-6);
            assert!((c.heading_deg - air.heading_deg).abs() < 1e-9);
            assert!((c.pitch_deg - air.pitch_deg).abs() < 1e-9);
        }
    }
}
