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
