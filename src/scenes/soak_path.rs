//! The soak's random path: legs between waypoints drawn from a seed, in space, at aircraft
//! height, a few metres above the ground, at and around both poles and across the
//! antimeridian (`instruments::soak` flies it).

use glam::DVec3;
use serde::Serialize;

use super::SCENE_FOV_Y_DEG;
use crate::geo::camera::Camera;

/// Where a waypoint is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Place {
    /// 1 000–30 000 km up, looking down.
    Space,
    /// 300 m – 20 km above the ground, looking ahead and down.
    Aircraft,
    /// 1–100 m above the ground, looking at the horizon.
    Ground,
    /// Within 8° of a pole (a fifth of them on it), 10 m – 2 000 km up.
    Pole,
    /// Within 0.5° of the antimeridian, heading across it.
    Antimeridian,
}

impl Place {
    pub const ALL: [Place; 5] = [
        Place::Space,
        Place::Aircraft,
        Place::Ground,
        Place::Pole,
        Place::Antimeridian,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Place::Space => "space",
            Place::Aircraft => "aircraft",
            Place::Ground => "ground",
            Place::Pole => "pole",
            Place::Antimeridian => "antimeridian",
        }
    }
}

/// A view on the path: where, how high above the ground, which way.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Waypoint {
    pub place: Place,
    pub lat_deg: f64,
    pub lon_deg: f64,
    pub above_ground_m: f64,
    pub heading_deg: f64,
    pub pitch_deg: f64,
}

/// How long legs take on the soak's clock (seconds, drawn uniformly in each range).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LegSeconds {
    pub fly: (f64, f64),
    /// A jump's hold at its destination.
    pub hold: (f64, f64),
    /// Fraction of legs (after the first few) that jump.
    pub jump_fraction: f64,
}

impl Default for LegSeconds {
    fn default() -> Self {
        Self {
            fly: (8.0, 20.0),
            hold: (3.0, 6.0),
            jump_fraction: 0.25,
        }
    }
}

/// One leg of the path.
#[derive(Clone, Debug)]
pub struct Leg {
    pub from: Waypoint,
    pub to: Waypoint,
    /// Arrives at `to` at once and holds there, turning 30°.
    pub jump: bool,
    pub start_s: f64,
    pub seconds: f64,
    /// Great-circle length, metres.
    pub distance_m: f64,
    /// Terrain heights at `GROUND_SAMPLES + 1` even steps along the track (fly legs), or at
    /// `to` alone (jumps): read once when the path is made, so no frame reads the file.
    ground_m: Vec<f64>,
}

/// Terrain samples along a fly leg.
const GROUND_SAMPLES: usize = 64;
/// The climb over a fly leg's middle, as a fraction of its length: with the eased progress
/// the camera rises at least ~2 m per metre flown near either end, steeper than any terrain
/// at the data's resolution, so it stays above the ground between the samples.
const CLIMB: f64 = 0.7;

impl Leg {
    pub fn end_s(&self) -> f64 {
        self.start_s + self.seconds
    }

    /// The camera at `u` ∈ [0, 1] of the leg.
    pub fn camera_at(&self, u: f64) -> Camera {
        let u = u.clamp(0.0, 1.0);
        let camera =
            |lat_deg: f64, lon_deg: f64, altitude_m: f64, heading: f64, pitch: f64| Camera {
                lat_deg,
                lon_deg,
                altitude_m,
                heading_deg: heading.rem_euclid(360.0),
                pitch_deg: pitch,
                roll_deg: 0.0,
                fov_y_deg: SCENE_FOV_Y_DEG,
            };
        let to = &self.to;
        let to_ground = *self.ground_m.last().expect("a leg has ground samples");
        if self.jump {
            return camera(
                to.lat_deg,
                to.lon_deg,
                to_ground + to.above_ground_m,
                to.heading_deg + 30.0 * u,
                to.pitch_deg,
            );
        }
        let from = &self.from;
        if u >= 1.0 {
            return camera(
                to.lat_deg,
                to.lon_deg,
                to_ground + to.above_ground_m,
                to.heading_deg,
                to.pitch_deg,
            );
        }
        let s = u * u * (3.0 - 2.0 * u);
        let (a, b) = (
            unit(from.lat_deg, from.lon_deg),
            unit(to.lat_deg, to.lon_deg),
        );
        let (lat, lon) = if u <= 0.0 {
            (from.lat_deg, from.lon_deg)
        } else {
            let d = slerp(a, b, s);
            let lat = d.z.clamp(-1.0, 1.0).asin().to_degrees();
            // On a pole the longitude is the destination's (any would do; this one is steady).
            let lon = if d.x.hypot(d.y) < 1e-12 {
                to.lon_deg
            } else {
                d.y.atan2(d.x).to_degrees()
            };
            (lat, lon)
        };
        // Between samples, the upper envelope (each sample's max with its neighbours,
        // interpolated): continuous, and above both samples around the camera. The ends keep
        // their own samples, so a leg ends exactly at its waypoint.
        let x = s * GROUND_SAMPLES as f64;
        let k = (x.floor() as usize).min(GROUND_SAMPLES - 1);
        let g = &self.ground_m;
        let envelope = |i: usize| {
            if i == 0 || i == GROUND_SAMPLES {
                g[i]
            } else {
                g[i - 1].max(g[i]).max(g[i + 1])
            }
        };
        let f = x - k as f64;
        let ground = envelope(k) + f * (envelope(k + 1) - envelope(k));
        let height = (from.above_ground_m.ln()
            + s * (to.above_ground_m.ln() - from.above_ground_m.ln()))
        .exp()
            + CLIMB * self.distance_m * (std::f64::consts::PI * s).sin();
        let turn = (to.heading_deg - from.heading_deg + 180.0).rem_euclid(360.0) - 180.0;
        camera(
            lat,
            lon,
            ground + height,
            from.heading_deg + s * turn,
            from.pitch_deg + s * (to.pitch_deg - from.pitch_deg),
        )
    }
}

fn unit(lat_deg: f64, lon_deg: f64) -> DVec3 {
    let (lat, lon) = (lat_deg.to_radians(), lon_deg.to_radians());
    DVec3::new(lat.cos() * lon.cos(), lat.cos() * lon.sin(), lat.sin())
}

/// Spherical interpolation of unit vectors (nearly equal ones: linear, normalised).
fn slerp(a: DVec3, b: DVec3, s: f64) -> DVec3 {
    let angle = a.angle_between(b);
    if angle < 1e-9 {
        return a.lerp(b, s).normalize();
    }
    ((a * ((1.0 - s) * angle).sin() + b * (s * angle).sin()) / angle.sin()).normalize()
}

/// A small seeded generator (splitmix64): the path is the same for a seed on every machine.
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut x = self.0;
        x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        x ^ (x >> 31)
    }

    fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    fn log_range(&mut self, lo: f64, hi: f64) -> f64 {
        self.range(lo.ln(), hi.ln()).exp()
    }

    /// A latitude uniform over the sphere's area between ±`max_deg`.
    fn latitude(&mut self, max_deg: f64) -> f64 {
        let z = max_deg.to_radians().sin();
        self.range(-z, z).asin().to_degrees()
    }

    fn sign(&mut self) -> f64 {
        if self.unit() < 0.5 { -1.0 } else { 1.0 }
    }
}

fn draw_waypoint(rng: &mut Rng, place: Place) -> Waypoint {
    let (lat, lon, above, heading, pitch) = match place {
        Place::Space => (
            rng.latitude(90.0),
            rng.range(-180.0, 180.0),
            rng.log_range(1.0e6, 3.0e7),
            rng.range(0.0, 360.0),
            -90.0,
        ),
        Place::Aircraft => (
            rng.latitude(70.0),
            rng.range(-180.0, 180.0),
            rng.log_range(300.0, 2.0e4),
            rng.range(0.0, 360.0),
            rng.range(-60.0, -10.0),
        ),
        Place::Ground => (
            rng.latitude(70.0),
            rng.range(-180.0, 180.0),
            rng.log_range(1.0, 100.0),
            rng.range(0.0, 360.0),
            rng.range(-15.0, 5.0),
        ),
        Place::Pole => {
            let sign = rng.sign();
            let lat = if rng.unit() < 0.2 {
                90.0
            } else {
                90.0 - 8.0 * rng.unit().powi(2)
            };
            (
                sign * lat,
                rng.range(-180.0, 180.0),
                rng.log_range(10.0, 2.0e6),
                rng.range(0.0, 360.0),
                rng.range(-90.0, -5.0),
            )
        }
        Place::Antimeridian => (
            rng.latitude(60.0),
            rng.sign() * (180.0 - rng.range(0.0, 0.5)),
            rng.log_range(5.0, 2.0e5),
            // East or west, within 30°: the view crosses the seam.
            if rng.unit() < 0.5 { 90.0 } else { 270.0 } + rng.range(-30.0, 30.0),
            rng.range(-60.0, 0.0),
        ),
    };
    Waypoint {
        place,
        lat_deg: lat,
        lon_deg: lon,
        above_ground_m: above,
        heading_deg: heading,
        pitch_deg: pitch,
    }
}

/// The seeded random flight.
#[derive(Clone, Debug)]
pub struct SoakPath {
    legs: Vec<Leg>,
}

impl SoakPath {
    /// Legs from `space` until `seconds` are covered: the first four visit aircraft height,
    /// the ground, a pole and the antimeridian (the third jumps there), then places and jumps
    /// are drawn. `terrain_m(lat, lon)` is the ground height, read only here.
    pub fn new(
        seed: u64,
        seconds: f64,
        legs: &LegSeconds,
        radius_m: f64,
        terrain_m: impl Fn(f64, f64) -> f64,
    ) -> Self {
        let mut rng = Rng(seed ^ 0x50A4_50A4_50A4_50A4);
        let first = [
            Place::Aircraft,
            Place::Ground,
            Place::Pole,
            Place::Antimeridian,
        ];
        let mut from = draw_waypoint(&mut rng, Place::Space);
        let mut out: Vec<Leg> = Vec::new();
        let mut t = 0.0;
        while t < seconds || out.is_empty() {
            let i = out.len();
            let place = match first.get(i) {
                Some(&p) => p,
                None => Place::ALL[(rng.next_u64() % Place::ALL.len() as u64) as usize],
            };
            let to = draw_waypoint(&mut rng, place);
            let jump = i == 2 || (i >= first.len() && rng.unit() < legs.jump_fraction);
            let duration = if jump {
                rng.range(legs.hold.0, legs.hold.1)
            } else {
                rng.range(legs.fly.0, legs.fly.1)
            };
            let (a, b) = (
                unit(from.lat_deg, from.lon_deg),
                unit(to.lat_deg, to.lon_deg),
            );
            let ground_m = if jump {
                vec![terrain_m(to.lat_deg, to.lon_deg)]
            } else {
                (0..=GROUND_SAMPLES)
                    .map(|k| match k {
                        0 => terrain_m(from.lat_deg, from.lon_deg),
                        GROUND_SAMPLES => terrain_m(to.lat_deg, to.lon_deg),
                        _ => {
                            let d = slerp(a, b, k as f64 / GROUND_SAMPLES as f64);
                            let lat = d.z.clamp(-1.0, 1.0).asin().to_degrees();
                            terrain_m(lat, d.y.atan2(d.x).to_degrees())
                        }
                    })
                    .collect()
            };
            out.push(Leg {
                from,
                to,
                jump,
                start_s: t,
                seconds: duration,
                distance_m: a.angle_between(b) * radius_m,
                ground_m,
            });
            t += duration;
            // A jump's hold ends turned by 30°: the next leg starts from there.
            from = Waypoint {
                heading_deg: to.heading_deg + if jump { 30.0 } else { 0.0 },
                ..to
            };
        }
        Self { legs: out }
    }

    pub fn legs(&self) -> &[Leg] {
        &self.legs
    }

    /// The leg at soak time `t_s` and the camera there.
    pub fn camera(&self, t_s: f64) -> (usize, Camera) {
        let i = self
            .legs
            .partition_point(|l| l.end_s() <= t_s)
            .min(self.legs.len() - 1);
        let leg = &self.legs[i];
        (i, leg.camera_at((t_s - leg.start_s) / leg.seconds))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const R: f64 = 6_371_000.0;

    /// Smooth relief on the sphere (a function of the unit vector: one value at a pole).
    fn terrain(lat: f64, lon: f64) -> f64 {
        let u = unit(lat, lon);
        1000.0 * (3.0 * u.x).sin() * (2.0 * u.y + u.z).cos()
    }

    fn path(seed: u64, seconds: f64) -> SoakPath {
        SoakPath::new(seed, seconds, &LegSeconds::default(), R, terrain)
    }

    #[test]
    fn the_path_is_the_seeds_and_covers_every_place_and_a_jump() {
        let a = path(7, 600.0);
        let b = path(7, 600.0);
        let c = path(8, 600.0);
        assert_eq!(a.legs().len(), b.legs().len());
        for (x, y) in a.legs().iter().zip(b.legs()) {
            assert_eq!(x.to, y.to);
            assert_eq!(x.seconds, y.seconds);
        }
        assert_ne!(a.legs()[0].to, c.legs()[0].to);
        let legs = a.legs();
        assert!(legs.last().unwrap().end_s() >= 600.0);
        for p in Place::ALL {
            assert!(legs.iter().any(|l| l.to.place == p), "{p:?} never visited");
        }
        assert!(legs[2].jump);
        assert!(legs.iter().filter(|l| l.jump).count() >= 3);
        assert!(legs.iter().any(|l| l.to.lat_deg.abs() == 90.0), "on a pole");
        for l in legs {
            if l.to.place == Place::Antimeridian {
                assert!(l.to.lon_deg.abs() >= 179.5);
            }
        }
    }

    #[test]
    fn legs_are_continuous_and_end_at_their_waypoints_above_the_ground() {
        let p = path(3, 900.0);
        for (i, leg) in p.legs().iter().enumerate() {
            let end = leg.camera_at(1.0);
            assert!((end.lat_deg - leg.to.lat_deg).abs() < 1e-12);
            let above = end.altitude_m - terrain(leg.to.lat_deg, leg.to.lon_deg);
            assert!(
                (above - leg.to.above_ground_m).abs() < 1e-6 * above.max(1.0),
                "leg {i}: {above} m above, {:?}",
                leg.to
            );
            if let Some(next) = p.legs().get(i + 1) {
                // The next leg starts where this one ended (a jump jumps within its own leg).
                let start = next.camera_at(0.0);
                if !next.jump {
                    assert!(
                        (start.altitude_m - end.altitude_m).abs()
                            < 1e-6 * end.altitude_m.abs().max(1.0),
                        "leg {i}: {end:?} then {start:?}"
                    );
                    assert!((start.lat_deg - end.lat_deg).abs() < 1e-9);
                    let dh = (start.heading_deg - end.heading_deg).rem_euclid(360.0);
                    assert!(dh.min(360.0 - dh) < 1e-9, "heading {dh}");
                }
            }
            // Along a fly leg: small steps move the camera little, and it stays above the
            // terrain under it.
            if !leg.jump {
                let n = 2000;
                for k in 0..n {
                    let (c0, c1) = (
                        leg.camera_at(k as f64 / n as f64),
                        leg.camera_at((k + 1) as f64 / n as f64),
                    );
                    let (u0, u1) = (unit(c0.lat_deg, c0.lon_deg), unit(c1.lat_deg, c1.lon_deg));
                    let step = u0.angle_between(u1) * R;
                    assert!(
                        step <= 2.0 * leg.distance_m / n as f64 + 1e-6,
                        "step {step}"
                    );
                    let above = c0.altitude_m - terrain(c0.lat_deg, c0.lon_deg);
                    assert!(above > 0.5, "leg {i} at {k}/{n}: {above} m above, {leg:?}");
                }
            }
        }
    }

    #[test]
    fn camera_picks_the_leg_by_time() {
        let p = path(5, 120.0);
        let l1 = &p.legs()[1];
        let (i, c) = p.camera(l1.start_s + 0.5 * l1.seconds);
        assert_eq!(i, 1);
        let want = l1.camera_at(0.5);
        assert!((c.altitude_m - want.altitude_m).abs() < 1e-6 * want.altitude_m);
        assert!((c.lat_deg - want.lat_deg).abs() < 1e-9);
        let (last, _) = p.camera(1e9);
        assert_eq!(last, p.legs().len() - 1);
    }
}
