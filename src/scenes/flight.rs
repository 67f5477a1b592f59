//! The `flight` path (docs/design.md#scenes): from `space` straight down to `ground` over Lake Garda. The
//! height above terrain falls exponentially (the same factor every frame: the image changes at
//! a steady rate from orbit to the last metres), passing through `aircraft`'s 10 km; heading and
//! pitch ease from space's (0°, −90°) through aircraft's (315°, −20°) to ground's (0°, −5°).

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
