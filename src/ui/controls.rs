//! Camera controls in f64, free of any window or GPU type so they can be tested directly.
//!
//! Every function takes the terrain height as `terrain(lat_deg, lon_deg) -> metres` and leaves
//! the camera valid: latitude in [−90, 90], longitude in (−180, 180], heading in [0, 360), pitch
//! in [−90, 90], altitude between terrain + [`MIN_CLEARANCE_M`] and [`MAX_ALTITUDE_M`], every
//! field finite. Non-finite inputs are ignored.
//!
//! Motion over the ground follows great circles, so flying across a pole works: latitude reaches
//! exactly ±90 and continues down the other side, with longitude and heading turned by 180°.
//! Speeds are proportional to the height above terrain, so the same gestures work from
//! 20 000 km out to a millimetre above the ground.

use glam::DVec3;

use crate::geo::camera::Camera;

/// The camera never gets closer to the terrain than this.
pub const MIN_CLEARANCE_M: f64 = 0.001;
/// The camera never gets farther from the sphere than this (the planet is then ~18° across).
pub const MAX_ALTITUDE_M: f64 = 4.0e7;
/// Height above terrain is multiplied by this per wheel notch towards the ground.
pub const ZOOM_STEP: f64 = 0.85;
/// Horizontal flying speed in heights above terrain per second (before the cap below).
pub const FLY_SPEED_PER_S: f64 = 1.0;
/// Horizontal flying speed is capped at this fraction of the radius per second.
pub const FLY_SPEED_CAP_RADII_PER_S: f64 = 0.25;
/// Climb/descent: the height above terrain changes by e^(±rate·dt).
pub const CLIMB_RATE_PER_S: f64 = 1.0;
/// Turn rate of the arrow keys.
pub const TURN_DEG_PER_S: f64 = 60.0;
/// Pitch rate of the arrow keys.
pub const PITCH_DEG_PER_S: f64 = 45.0;
/// Speed factor while Shift is held.
pub const BOOST: f64 = 5.0;

/// Wraps a longitude to (−180, 180]; non-finite becomes 0.
pub fn wrap_lon_deg(lon_deg: f64) -> f64 {
    if !lon_deg.is_finite() {
        return 0.0;
    }
    if lon_deg > -180.0 && lon_deg <= 180.0 {
        return lon_deg; // already in range: keep it exactly
    }
    let w = lon_deg.rem_euclid(360.0);
    if w > 180.0 { w - 360.0 } else { w }
}

/// Clamps a latitude to [−90, 90] (the poles themselves are allowed); NaN becomes 0.
pub fn clamp_lat_deg(lat_deg: f64) -> f64 {
    if lat_deg.is_nan() {
        0.0
    } else {
        lat_deg.clamp(-90.0, 90.0)
    }
}

/// Wraps a heading to [0, 360); non-finite becomes 0.
pub fn wrap_heading_deg(heading_deg: f64) -> f64 {
    if !heading_deg.is_finite() {
        return 0.0;
    }
    let w = heading_deg.rem_euclid(360.0);
    if w >= 360.0 { 0.0 } else { w }
}

/// Height of the camera above the terrain under it.
pub fn height_above_terrain_m(camera: &Camera, terrain: impl Fn(f64, f64) -> f64) -> f64 {
    camera.altitude_m - terrain(camera.lat_deg, camera.lon_deg)
}

/// Brings every field of the camera back into its valid range (see the module comment).
pub fn normalize(camera: &mut Camera, terrain: impl Fn(f64, f64) -> f64) {
    camera.lat_deg = clamp_lat_deg(camera.lat_deg);
    camera.lon_deg = wrap_lon_deg(camera.lon_deg);
    camera.heading_deg = wrap_heading_deg(camera.heading_deg);
    camera.pitch_deg = if camera.pitch_deg.is_nan() {
        0.0
    } else {
        camera.pitch_deg.clamp(-90.0, 90.0)
    };
    if !camera.roll_deg.is_finite() {
        camera.roll_deg = 0.0;
    }
    if !(camera.fov_y_deg.is_finite() && camera.fov_y_deg > 1.0 && camera.fov_y_deg < 170.0) {
        camera.fov_y_deg = crate::scenes::SCENE_FOV_Y_DEG;
    }
    let ground = terrain(camera.lat_deg, camera.lon_deg);
    let low = ground + MIN_CLEARANCE_M;
    let high = MAX_ALTITUDE_M.max(low);
    camera.altitude_m = if camera.altitude_m.is_nan() {
        high
    } else {
        camera.altitude_m.clamp(low, high)
    };
}

/// Wheel zoom: the height above terrain is multiplied by [`ZOOM_STEP`]^`notches` (positive
/// notches move towards the ground).
pub fn zoom(camera: &mut Camera, notches: f64, terrain: impl Fn(f64, f64) -> f64) {
    if !notches.is_finite() {
        return;
    }
    normalize(camera, &terrain);
    let ground = terrain(camera.lat_deg, camera.lon_deg);
    let height = camera.altitude_m - ground;
    // Clamped exponent: 0.85^±5000 is already far outside [1 mm, 40 000 km].
    let factor = ZOOM_STEP.powf(notches.clamp(-5000.0, 5000.0));
    camera.altitude_m = ground + height * factor;
    normalize(camera, &terrain);
}

/// Look around by dragging: the scene follows the pointer, so a drag of the full viewport height
/// turns the view by the vertical field of view. `dx_px` right, `dy_px` down.
pub fn look_drag(camera: &mut Camera, dx_px: f64, dy_px: f64, viewport_height_px: f64) {
    if !(dx_px.is_finite() && dy_px.is_finite()) {
        return;
    }
    let deg_per_px = camera.fov_y_deg / viewport_height_px.max(1.0);
    turn(camera, -dx_px * deg_per_px, dy_px * deg_per_px);
}

/// Turns the view: heading clockwise by `dheading_deg`, pitch up by `dpitch_deg`.
pub fn turn(camera: &mut Camera, dheading_deg: f64, dpitch_deg: f64) {
    if !(dheading_deg.is_finite() && dpitch_deg.is_finite()) {
        return;
    }
    camera.heading_deg = wrap_heading_deg(camera.heading_deg + dheading_deg);
    camera.pitch_deg = (camera.pitch_deg + dpitch_deg).clamp(-90.0, 90.0);
}

/// Move over the ground by dragging: the ground follows the pointer at the point below the
/// camera (one pixel = height above terrain × pixel angle). `dx_px` right, `dy_px` down.
pub fn pan_drag(
    camera: &mut Camera,
    dx_px: f64,
    dy_px: f64,
    viewport_height_px: f64,
    radius_m: f64,
    terrain: impl Fn(f64, f64) -> f64,
) {
    if !(dx_px.is_finite() && dy_px.is_finite()) {
        return;
    }
    normalize(camera, &terrain);
    let height = height_above_terrain_m(camera, &terrain);
    let metres_per_px = height * camera.fov_y_rad() / viewport_height_px.max(1.0);
    // Dragging the ground down (towards the viewer) moves the camera forward.
    move_over_ground(
        camera,
        dy_px * metres_per_px,
        -dx_px * metres_per_px,
        radius_m,
        terrain,
    );
}

/// Local frame at (lat, lon): the unit position, east and north. At a pole east and north are
/// the limits along the meridian `lon`, as in [`Camera`].
fn local_frame(lat_deg: f64, lon_deg: f64) -> (DVec3, DVec3, DVec3) {
    let (sin_lat, cos_lat) = lat_deg.to_radians().sin_cos();
    let (sin_lon, cos_lon) = lon_deg.to_radians().sin_cos();
    let position = DVec3::new(cos_lat * cos_lon, cos_lat * sin_lon, sin_lat);
    let east = DVec3::new(-sin_lon, cos_lon, 0.0);
    let north = DVec3::new(-sin_lat * cos_lon, -sin_lat * sin_lon, cos_lat);
    (position, east, north)
}

/// Moves the camera `forward_m` along its heading and `right_m` to its right along a great
/// circle on the sphere of radius `radius_m`, keeping its height above terrain. The heading is
/// carried along the path (parallel transport), so crossing a pole turns it by 180°.
pub fn move_over_ground(
    camera: &mut Camera,
    forward_m: f64,
    right_m: f64,
    radius_m: f64,
    terrain: impl Fn(f64, f64) -> f64,
) {
    if !(forward_m.is_finite() && right_m.is_finite() && radius_m.is_finite() && radius_m > 0.0) {
        return;
    }
    normalize(camera, &terrain);
    // Scaled so that huge finite steps neither overflow nor lose their direction.
    let scale = forward_m.abs().max(right_m.abs());
    if scale == 0.0 {
        return;
    }
    let (f, r) = (forward_m / scale, right_m / scale);
    let norm = f.hypot(r);
    let distance_m = scale * norm;
    let height = height_above_terrain_m(camera, &terrain);
    let (p, east, north) = local_frame(camera.lat_deg, camera.lon_deg);
    let (sin_h, cos_h) = camera.heading_deg.to_radians().sin_cos();
    let forward = east * sin_h + north * cos_h;
    let right = east * cos_h - north * sin_h;
    let t = (forward * f + right * r) / norm;
    let b = p.cross(t);
    // One trip around the planet at most per step.
    let angle = (distance_m / radius_m).min(std::f64::consts::PI);
    let (sin_a, cos_a) = angle.sin_cos();
    let p_new = (p * cos_a + t * sin_a).normalize();
    let t_new = t * cos_a - p * sin_a;
    let forward_new = t_new * forward.dot(t) + b * forward.dot(b);

    camera.lat_deg = p_new.z.clamp(-1.0, 1.0).asin().to_degrees();
    // Exactly at a pole the longitude is undefined: keep the old meridian.
    if p_new.x.hypot(p_new.y) > 1e-15 {
        camera.lon_deg = p_new.y.atan2(p_new.x).to_degrees();
    }
    let (_, east_new, north_new) = local_frame(camera.lat_deg, camera.lon_deg);
    let heading = forward_new
        .dot(east_new)
        .atan2(forward_new.dot(north_new))
        .to_degrees();
    if heading.is_finite() {
        camera.heading_deg = heading;
    }
    camera.altitude_m = terrain(clamp_lat_deg(camera.lat_deg), camera.lon_deg) + height;
    normalize(camera, terrain);
}

/// Held keys of the keyboard fly mode, each axis in [−1, 1].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FlyInput {
    /// +1 forward (W), −1 back (S).
    pub forward: f64,
    /// +1 right (D), −1 left (A).
    pub right: f64,
    /// +1 up (E), −1 down (Q).
    pub up: f64,
    /// +1 turn right (→), −1 left (←).
    pub turn: f64,
    /// +1 pitch up (↑), −1 down (↓).
    pub pitch: f64,
    /// Shift: [`BOOST`] × faster movement.
    pub boost: bool,
}

impl FlyInput {
    pub fn is_idle(&self) -> bool {
        self.forward == 0.0
            && self.right == 0.0
            && self.up == 0.0
            && self.turn == 0.0
            && self.pitch == 0.0
    }
}

/// Horizontal flying speed at `height_m` above terrain on a planet of radius `radius_m`.
pub fn fly_speed_m_per_s(height_m: f64, radius_m: f64) -> f64 {
    FLY_SPEED_PER_S * height_m.min(FLY_SPEED_CAP_RADII_PER_S * radius_m)
}

/// One frame of keyboard flying over `dt_s` seconds.
pub fn fly(
    camera: &mut Camera,
    input: &FlyInput,
    dt_s: f64,
    radius_m: f64,
    terrain: impl Fn(f64, f64) -> f64,
) {
    if input.is_idle() || !(dt_s.is_finite() && dt_s > 0.0) {
        return;
    }
    // A stalled frame should not throw the camera across the planet.
    let dt_s = dt_s.min(0.25);
    let boost = if input.boost { BOOST } else { 1.0 };
    let axis = |v: f64| {
        if v.is_finite() {
            v.clamp(-1.0, 1.0)
        } else {
            0.0
        }
    };
    turn(
        camera,
        axis(input.turn) * TURN_DEG_PER_S * dt_s,
        axis(input.pitch) * PITCH_DEG_PER_S * dt_s,
    );
    normalize(camera, &terrain);
    let height = height_above_terrain_m(camera, &terrain);
    let step_m = fly_speed_m_per_s(height, radius_m) * boost * dt_s;
    move_over_ground(
        camera,
        axis(input.forward) * step_m,
        axis(input.right) * step_m,
        radius_m,
        &terrain,
    );
    let up = axis(input.up);
    if up != 0.0 {
        let ground = terrain(camera.lat_deg, camera.lon_deg);
        let height = camera.altitude_m - ground;
        camera.altitude_m = ground + height * (up * CLIMB_RATE_PER_S * boost * dt_s).exp();
        normalize(camera, &terrain);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const R: f64 = crate::geo::EARTH_RADIUS_M;

    fn camera(lat_deg: f64, lon_deg: f64, altitude_m: f64) -> Camera {
        Camera {
            lat_deg,
            lon_deg,
            altitude_m,
            heading_deg: 0.0,
            pitch_deg: -30.0,
            roll_deg: 0.0,
            fov_y_deg: 60.0,
        }
    }

    /// A bumpy terrain, so clearance checks are not trivially about a flat sphere.
    fn bumpy(lat_deg: f64, lon_deg: f64) -> f64 {
        1000.0 + 800.0 * (lat_deg.to_radians() * 7.0).sin() * (lon_deg.to_radians() * 5.0).cos()
    }

    fn assert_valid(c: &Camera, terrain: impl Fn(f64, f64) -> f64) {
        for v in [
            c.lat_deg,
            c.lon_deg,
            c.altitude_m,
            c.heading_deg,
            c.pitch_deg,
            c.roll_deg,
            c.fov_y_deg,
        ] {
            assert!(v.is_finite(), "{c:?}");
        }
        assert!((-90.0..=90.0).contains(&c.lat_deg), "{c:?}");
        assert!(c.lon_deg > -180.0 && c.lon_deg <= 180.0, "{c:?}");
        assert!((0.0..360.0).contains(&c.heading_deg), "{c:?}");
        assert!((-90.0..=90.0).contains(&c.pitch_deg), "{c:?}");
        let clearance = c.altitude_m - terrain(c.lat_deg, c.lon_deg);
        assert!(
            clearance >= MIN_CLEARANCE_M * (1.0 - 1e-9),
            "{clearance} {c:?}"
        );
        assert!(c.altitude_m <= MAX_ALTITUDE_M.max(terrain(c.lat_deg, c.lon_deg) + 1.0));
    }

    #[test]
    fn lon_wraps_into_half_open_range() {
        assert_eq!(wrap_lon_deg(180.0), 180.0);
        assert_eq!(wrap_lon_deg(-180.0), 180.0);
        assert_eq!(wrap_lon_deg(190.0), -170.0);
        assert_eq!(wrap_lon_deg(-190.0), 170.0);
        assert_eq!(wrap_lon_deg(720.0 + 10.0), 10.0);
        assert_eq!(wrap_lon_deg(-1e-300), -1e-300);
        assert_eq!(wrap_lon_deg(f64::NAN), 0.0);
        assert_eq!(wrap_lon_deg(f64::INFINITY), 0.0);
        for lon in [-1e12, -540.0, -179.999, 0.0, 359.999, 1e15] {
            let w = wrap_lon_deg(lon);
            assert!(w > -180.0 && w <= 180.0, "{lon} → {w}");
        }
    }

    #[test]
    fn lat_clamps_at_the_poles() {
        assert_eq!(clamp_lat_deg(95.0), 90.0);
        assert_eq!(clamp_lat_deg(-1e9), -90.0);
        assert_eq!(clamp_lat_deg(90.0), 90.0);
        assert_eq!(clamp_lat_deg(f64::NAN), 0.0);
        let mut c = camera(123.0, 0.0, 100.0);
        normalize(&mut c, |_, _| 0.0);
        assert_eq!(c.lat_deg, 90.0);
    }

    #[test]
    fn zoom_never_goes_below_terrain_plus_a_millimetre() {
        let mut c = camera(45.0, 10.0, 2.0e7);
        for _ in 0..2000 {
            zoom(&mut c, 3.0, bumpy);
            assert_valid(&c, bumpy);
        }
        let clearance = height_above_terrain_m(&c, bumpy);
        assert!((clearance - MIN_CLEARANCE_M).abs() < 1e-6, "{clearance}");
        // An absurd wheel delta in either direction stays in range.
        zoom(&mut c, 1e300, bumpy);
        assert_valid(&c, bumpy);
        zoom(&mut c, -1e300, bumpy);
        assert_valid(&c, bumpy);
        assert_eq!(c.altitude_m, MAX_ALTITUDE_M);
        zoom(&mut c, f64::NAN, bumpy);
        assert_valid(&c, bumpy);
    }

    #[test]
    fn zoom_is_proportional_to_height_and_reversible() {
        let mut c = camera(10.0, 20.0, 0.0);
        c.altitude_m = bumpy(10.0, 20.0) + 1000.0;
        zoom(&mut c, 1.0, bumpy);
        assert!((height_above_terrain_m(&c, bumpy) - 850.0).abs() < 1e-6);
        zoom(&mut c, -1.0, bumpy);
        assert!((height_above_terrain_m(&c, bumpy) - 1000.0).abs() < 1e-6);
        // From 2e7 m to 1 m in a finite number of notches, smoothly.
        let mut c = camera(0.0, 0.0, 2.0e7);
        let mut notches = 0;
        while height_above_terrain_m(&c, |_, _| 0.0) > 1.0 {
            let before = c.altitude_m;
            zoom(&mut c, 1.0, |_, _| 0.0);
            assert!(c.altitude_m < before && c.altitude_m >= 0.85 * before - 1e-9);
            notches += 1;
        }
        assert!(notches < 120, "{notches}");
    }

    #[test]
    fn moving_east_across_the_antimeridian_wraps_lon() {
        let mut c = camera(0.0, 179.9, 1000.0);
        c.heading_deg = 90.0;
        let step = 0.2f64.to_radians() * R;
        move_over_ground(&mut c, step, 0.0, R, |_, _| 0.0);
        assert!((c.lon_deg - (-179.9)).abs() < 1e-9, "{c:?}");
        assert!(c.lat_deg.abs() < 1e-9);
        assert!((c.heading_deg - 90.0).abs() < 1e-9);
        assert!((c.altitude_m - 1000.0).abs() < 1e-6);
        // And back west.
        c.heading_deg = 270.0;
        move_over_ground(&mut c, step, 0.0, R, |_, _| 0.0);
        assert!((c.lon_deg - 179.9).abs() < 1e-9, "{c:?}");
    }

    #[test]
    fn flying_north_crosses_the_pole() {
        let mut c = camera(89.0, 30.0, 5000.0);
        let step = 0.25f64.to_radians() * R;
        let mut max_lat: f64 = -90.0;
        for _ in 0..8 {
            move_over_ground(&mut c, step, 0.0, R, bumpy);
            assert_valid(&c, bumpy);
            max_lat = max_lat.max(c.lat_deg);
        }
        // 2° north from 89°: over the pole to 89° on the opposite meridian, heading south.
        assert!((max_lat - 90.0).abs() < 1e-6, "{max_lat}");
        assert!((c.lat_deg - 89.0).abs() < 1e-6, "{c:?}");
        assert!((c.lon_deg - (-150.0)).abs() < 1e-6, "{c:?}");
        assert!((c.heading_deg - 180.0).abs() < 1e-6, "{c:?}");
        // Height above terrain is kept while moving.
        assert!((height_above_terrain_m(&c, bumpy) - (5000.0 - bumpy(89.0, 30.0))).abs() < 1e-6);
    }

    #[test]
    fn moves_at_and_near_the_pole_stay_finite() {
        for heading in [0.0, 45.0, 90.0, 180.0, 270.0] {
            for lat in [90.0, -90.0, 89.999_999_999, -89.999_999_999] {
                let mut c = camera(lat, 0.0, 100.0);
                c.heading_deg = heading;
                move_over_ground(&mut c, 0.0, 10.0, R, bumpy);
                assert_valid(&c, bumpy);
                move_over_ground(&mut c, 10.0, -3.0, R, bumpy);
                assert_valid(&c, bumpy);
                pan_drag(&mut c, 50.0, -20.0, 800.0, R, bumpy);
                assert_valid(&c, bumpy);
            }
        }
    }

    #[test]
    fn extreme_inputs_give_finite_cameras() {
        let huge = [
            1e300,
            -1e300,
            f64::MAX,
            f64::MIN,
            f64::INFINITY,
            f64::NAN,
            0.0,
        ];
        for &a in &huge {
            for &b in &huge {
                let mut c = camera(45.0, 10.0, 10_000.0);
                look_drag(&mut c, a, b, 800.0);
                assert_valid(&c, bumpy);
                pan_drag(&mut c, a, b, 800.0, R, bumpy);
                assert_valid(&c, bumpy);
                move_over_ground(&mut c, a, b, R, bumpy);
                assert_valid(&c, bumpy);
                zoom(&mut c, a, bumpy);
                assert_valid(&c, bumpy);
                let input = FlyInput {
                    forward: a,
                    right: b,
                    up: a,
                    turn: b,
                    pitch: a,
                    boost: true,
                };
                fly(&mut c, &input, 1.0, R, bumpy);
                assert_valid(&c, bumpy);
                fly(&mut c, &input, b, R, bumpy);
                assert_valid(&c, bumpy);
            }
        }
        // A camera that arrives broken is repaired.
        let mut c = Camera {
            lat_deg: f64::NAN,
            lon_deg: f64::INFINITY,
            altitude_m: f64::NAN,
            heading_deg: f64::NEG_INFINITY,
            pitch_deg: f64::NAN,
            roll_deg: f64::NAN,
            fov_y_deg: 0.0,
        };
        normalize(&mut c, bumpy);
        assert_valid(&c, bumpy);
    }

    #[test]
    fn look_drag_turns_and_clamps_pitch() {
        let mut c = camera(0.0, 0.0, 100.0);
        c.heading_deg = 10.0;
        c.pitch_deg = 0.0;
        // Dragging right by a full viewport height turns left by the field of view.
        look_drag(&mut c, 800.0, 0.0, 800.0);
        assert!((c.heading_deg - 310.0).abs() < 1e-9, "{c:?}");
        look_drag(&mut c, 0.0, 1e6, 800.0);
        assert_eq!(c.pitch_deg, 90.0);
        look_drag(&mut c, 0.0, -1e6, 800.0);
        assert_eq!(c.pitch_deg, -90.0);
    }

    #[test]
    fn pan_speed_is_proportional_to_height() {
        let flat = |_: f64, _: f64| 0.0;
        let moved = |altitude_m: f64| {
            let mut c = camera(0.0, 0.0, altitude_m);
            pan_drag(&mut c, 0.0, 100.0, 1000.0, R, flat);
            c.lat_deg.to_radians() * R
        };
        let a = moved(10.0);
        let b = moved(1000.0);
        assert!(a > 0.0, "dragging down moves forward (north at heading 0)");
        assert!((b / a - 100.0).abs() < 1e-6, "{a} {b}");
        // 100 px of 1000 px at 60° field of view: 100 m · π/3 / 10.
        assert!((b - 1000.0 * std::f64::consts::FRAC_PI_3 / 10.0).abs() < 1e-6);
    }

    #[test]
    fn fly_moves_along_heading_and_climbs() {
        let flat = |_: f64, _: f64| 0.0;
        let mut c = camera(0.0, 0.0, 100.0);
        c.heading_deg = 90.0;
        let input = FlyInput {
            forward: 1.0,
            ..Default::default()
        };
        fly(&mut c, &input, 0.1, R, flat);
        // 100 m above terrain at 1 height/s for 0.1 s: 10 m east.
        assert!((c.lon_deg.to_radians() * R - 10.0).abs() < 1e-6, "{c:?}");
        assert!(c.lat_deg.abs() < 1e-12);
        let up = FlyInput {
            up: 1.0,
            ..Default::default()
        };
        fly(&mut c, &up, 0.1, R, flat);
        assert!((c.altitude_m - 100.0 * 0.1f64.exp()).abs() < 1e-9);
        let down = FlyInput {
            up: -1.0,
            boost: true,
            ..Default::default()
        };
        for _ in 0..10_000 {
            fly(&mut c, &down, 0.25, R, flat);
        }
        assert!((c.altitude_m - MIN_CLEARANCE_M).abs() < 1e-12);
    }
}
