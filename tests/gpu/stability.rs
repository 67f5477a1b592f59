//! The numerical stability suite (issue 5 item 7; `docs/design.md#numerics`): property tests over
//! cameras anywhere on the sphere, the poles and the antimeridian exactly included, altitudes
//! from 1 mm to 10⁹ m above the terrain (log-uniform), every heading and pitch including
//! straight up and straight down.
//!
//! Exact edge values (±90°, ±180°, 0, a millimetre from a pole) are mixed into the continuous
//! ranges with `prop_oneof!`, since a uniform draw would never hit them. Runs are deterministic:
//! the seed is fixed unless `PROPTEST_RNG_SEED` is set, and every property prints its case count
//! and seed (`cargo test --test gpu -- stability:: --nocapture`). A failure reports the minimised
//! case and the seed that reproduces it.
//!
//! `tests/cpu/geo_math.rs` checks the same functions on fixed grids and on the 60-digit reference
//! vectors; `tests/gpu/render_scenes.rs` renders a fixed set of extreme cameras. This file is the
//! randomised generalisation: random viewers (poles included), random ring points, random moves.

use crate::common;

use std::cell::{Cell, RefCell};
use std::f64::consts::{PI, TAU};
use std::fmt::Debug;
use std::path::PathBuf;
use std::sync::OnceLock;

use glam::{DMat3, DMat4, DVec2, DVec3, Vec3, Vec4};
use globe::clipmap::density::{Density, DensityPlan};
use globe::clipmap::draw_list::PlanarCut;
use globe::clipmap::draw_list::{DrawList, Frustum, SectorBounds};
use globe::clipmap::selection::{LevelSelection, LevelStatus};
use globe::clipmap::settings::level_outer_theta_rad;
use globe::clipmap::{ClipmapSettings, RingMesh};
use globe::dem::pyramid::{Pyramid, PyramidBuilder, Region};
use globe::dem::{DemError, GeoGrid, RasterSource};
use globe::geo::camera::{Camera, pixel_ray_view};
use globe::geo::map_transform::{
    self, Stretch, TransformUniformsF32, approx_f32, blended_f32, direct_f32, exact_f64, stable_f32,
};
use globe::geo::projection::{camera_from_clip, near_plane_m};
use globe::geo::sphere::{
    great_circle_distance_m, lat_lon_deg_from_phi_theta, phi_theta_height_from_ecef_m, unit_vector,
    wrap_angle_rad,
};
use globe::geo::{EARTH_RADIUS_M, theta_tilde_max, theta_tilde_min};
use globe::plan::clipmap::DensityMap;
use globe::render::formats::DEPTH_FORMAT;
use globe::render::{GpuContext, TerrainRenderer};
use globe::terrain::{DemTerrain, Terrain};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed, TestCaseError, TestRunner};

// ---------------------------------------------------------------------------------------------
// Running properties

/// The seed used unless `PROPTEST_RNG_SEED` says otherwise ("globe" in ASCII).
const DEFAULT_SEED: u64 = 0x67_6c6f_6265;

/// Runs `test` on `cases` values of `strategy` with a fixed seed and no regression files,
/// panics with the minimised failing value and the seed, and prints the case count.
fn check<S>(
    name: &str,
    cases: u32,
    strategy: S,
    test: impl Fn(S::Value) -> Result<(), TestCaseError>,
) -> u32
where
    S: Strategy,
    S::Value: Debug,
{
    let mut config = Config::with_cases(cases);
    config.failure_persistence = None;
    let seed = match config.rng_seed {
        RngSeed::Fixed(seed) => seed,
        RngSeed::Random => DEFAULT_SEED,
    };
    config.rng_seed = RngSeed::Fixed(seed);
    let mut runner = TestRunner::new(config);
    if let Err(e) = runner.run(&strategy, test) {
        panic!("{name}: {e}\nreproduce with PROPTEST_RNG_SEED={seed}");
    }
    eprintln!("{name}: {cases} cases passed (PROPTEST_RNG_SEED={seed})");
    cases
}

/// A running maximum with the value that produced it, for the printed figures.
#[derive(Default)]
struct Worst {
    value: Cell<f64>,
    what: RefCell<String>,
}

impl Worst {
    fn note(&self, value: f64, what: impl FnOnce() -> String) {
        if value > self.value.get() {
            self.value.set(value);
            *self.what.borrow_mut() = what();
        }
    }
    fn get(&self) -> f64 {
        self.value.get()
    }
}

// ---------------------------------------------------------------------------------------------
// Generators

/// One millimetre on the ground, in degrees of arc.
fn mm_deg() -> f64 {
    (1e-3 / EARTH_RADIUS_M).to_degrees()
}

/// Latitudes: uniform, both poles and the equator exactly, within 3 mm of either pole, and at
/// log-uniform distances from a pole (1e-12° … 1°).
fn lat_deg() -> impl Strategy<Value = f64> {
    let mm = mm_deg();
    prop_oneof![
        4 => -90.0..=90.0f64,
        1 => Just(90.0),
        1 => Just(-90.0),
        1 => Just(0.0),
        1 => (0.0..=3.0f64).prop_map(move |k| 90.0 - k * mm),
        1 => (0.0..=3.0f64).prop_map(move |k| -90.0 + k * mm),
        1 => (-12.0..=0.0f64).prop_map(|e| 90.0 - 10f64.powf(e)),
    ]
}

/// Longitudes: uniform, ±180° and 0 exactly, within 3 mm of the antimeridian on either side,
/// and values outside (−180, 180] that the camera must wrap.
fn lon_deg() -> impl Strategy<Value = f64> {
    let mm = mm_deg();
    prop_oneof![
        4 => -180.0..=180.0f64,
        1 => Just(180.0),
        1 => Just(-180.0),
        1 => Just(0.0),
        1 => (0.0..=3.0f64).prop_map(move |k| 180.0 - k * mm),
        1 => (0.0..=3.0f64).prop_map(move |k| -180.0 + k * mm),
        1 => prop_oneof![Just(540.0), Just(-360.0), Just(359.999_999)],
    ]
}

/// Height above the terrain: log-uniform from 1 mm to 10⁹ m, both ends exactly.
fn above_terrain_m() -> impl Strategy<Value = f64> {
    prop_oneof![
        6 => (-3.0..=9.0f64).prop_map(|e| 10f64.powf(e)),
        1 => Just(1e-3),
        1 => Just(1e9),
    ]
}

/// Heading: every direction, the compass points exactly (360 as well as 0).
fn heading_deg() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => 0.0..360.0f64,
        1 => prop_oneof![Just(0.0), Just(90.0), Just(180.0), Just(270.0), Just(360.0)],
    ]
}

/// Pitch: every elevation, straight down, straight up and level exactly.
fn pitch_deg() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => -90.0..=90.0f64,
        1 => Just(-90.0),
        1 => Just(90.0),
        1 => Just(0.0),
    ]
}

fn roll_deg() -> impl Strategy<Value = f64> {
    prop_oneof![3 => Just(0.0), 1 => -180.0..=180.0f64]
}

/// Terrain height under the camera: sea level, Earth's extremes, anything between.
fn ground_m() -> impl Strategy<Value = f64> {
    prop_oneof![
        2 => Just(0.0),
        1 => Just(EARTH_TERRAIN_MIN_M),
        1 => Just(EARTH_TERRAIN_MAX_M),
        2 => EARTH_TERRAIN_MIN_M..=EARTH_TERRAIN_MAX_M,
    ]
}

/// Earth's lowest and highest terrain in metres (Challenger Deep, Everest).
const EARTH_TERRAIN_MIN_M: f64 = -10_994.0;
const EARTH_TERRAIN_MAX_M: f64 = 8_849.0;

/// A camera and the terrain height under it.
#[derive(Clone, Copy, Debug)]
struct Viewer {
    camera: Camera,
    ground_m: f64,
}

impl Viewer {
    fn above_m(&self) -> f64 {
        self.camera.altitude_m - self.ground_m
    }
}

fn viewer() -> impl Strategy<Value = Viewer> {
    (
        (lat_deg(), lon_deg(), above_terrain_m(), ground_m()),
        (heading_deg(), pitch_deg(), roll_deg()),
        prop_oneof![3 => Just(60.0), 1 => 1.0..=120.0f64],
    )
        .prop_map(
            |((lat, lon, above, ground), (heading, pitch, roll), fov)| Viewer {
                camera: Camera {
                    lat_deg: lat,
                    lon_deg: lon,
                    altitude_m: ground + above,
                    heading_deg: heading,
                    pitch_deg: pitch,
                    roll_deg: roll,
                    fov_y_deg: fov,
                },
                ground_m: ground,
            },
        )
}

/// Viewer colatitudes θv: uniform, both poles exactly, half a millimetre from either (so a
/// 1 mm step crosses it), and log-uniform distances from either pole down to 1e-16 rad.
fn theta_v_rad() -> impl Strategy<Value = f64> {
    let half_mm = 0.5e-3 / EARTH_RADIUS_M;
    prop_oneof![
        4 => 0.0..=PI,
        1 => Just(0.0),
        1 => Just(PI),
        1 => Just(PI / 2.0),
        1 => Just(half_mm),
        1 => Just(PI - half_mm),
        1 => (-16.0..=-1.0f64).prop_map(|e| 10f64.powf(e)),
        1 => (-16.0..=-1.0f64).prop_map(|e| PI - 10f64.powf(e)),
    ]
}

/// Viewer longitudes φv: uniform, the antimeridian from both sides, 0.
fn phi_v_rad() -> impl Strategy<Value = f64> {
    prop_oneof![
        3 => -PI..=PI,
        1 => Just(PI),
        1 => Just(0.0),
        1 => (0.0..=3.0f64).prop_map(|k| PI - k * 1e-3 / EARTH_RADIUS_M),
    ]
}

/// A ring-mesh vertex: p̃ of eq. 2 at ground distance `distance_m` from the viewer, with the
/// seam meridian (φ̃ = 0, π: p̃y = 0 exactly, both seam copies) and the centre included.
#[derive(Clone, Copy, Debug)]
struct RingPoint {
    distance_m: f64,
    p_tilde: DVec3,
    seam_side: f32,
}

fn ring_point(min_m: f64, max_m: f64) -> impl Strategy<Value = RingPoint> {
    (
        prop_oneof![
            8 => (min_m.log10()..=max_m.log10()).prop_map(|e| 10f64.powf(e)),
            1 => Just(min_m),
            1 => Just(max_m),
        ],
        prop_oneof![
            4 => 0.0..TAU,
            1 => Just(0.0),
            1 => Just(PI),
            1 => Just(PI / 2.0),
            1 => Just(1.5 * PI),
        ],
        prop_oneof![Just(1.0f32), Just(-1.0f32)],
    )
        .prop_map(|(distance_m, phi_tilde, seam)| {
            let theta_tilde = distance_m / EARTH_RADIUS_M;
            let on_seam = phi_tilde == 0.0 || phi_tilde == PI;
            let p_tilde = if on_seam {
                let x = theta_tilde.sin() * if phi_tilde == 0.0 { 1.0 } else { -1.0 };
                DVec3::new(x, 0.0, theta_tilde.cos())
            } else {
                map_transform::p_tilde(phi_tilde, theta_tilde)
            };
            RingPoint {
                distance_m,
                p_tilde,
                seam_side: if on_seam { seam } else { 0.0 },
            }
        })
}

// ---------------------------------------------------------------------------------------------
// Shared geometry

/// The default clipmap mesh and its sector bounds, built once.
fn mesh() -> &'static (ClipmapSettings, RingMesh, SectorBounds) {
    static MESH: OnceLock<(ClipmapSettings, RingMesh, SectorBounds)> = OnceLock::new();
    MESH.get_or_init(|| {
        let settings = ClipmapSettings::default();
        let mesh = RingMesh::build(&settings);
        let bounds = SectorBounds::new(&mesh);
        (settings, mesh, bounds)
    })
}

/// Largest entry of |a − b|.
fn max_abs_diff(a: &DMat3, b: &DMat3) -> f64 {
    a.to_cols_array()
        .iter()
        .zip(b.to_cols_array())
        .fold(0.0, |m, (x, y)| m.max((x - y).abs()))
}

fn is_rotation(m: &DMat3) -> bool {
    m.is_finite()
        && max_abs_diff(&(m.transpose() * *m), &DMat3::IDENTITY) < 1e-12
        && (m.determinant() - 1.0).abs() < 1e-12
}

/// A map position (φ, θ) as a world unit vector: θ outside [0, π] (across a pole) and φ
/// outside (−π, π] (across the antimeridian) give the right point, so ground distances
/// between map positions need no wrap logic.
fn map_point(phi_rad: f64, theta_rad: f64) -> DVec3 {
    unit_vector(phi_rad, theta_rad)
}

/// Absolute map position of a ring point for a viewer, f64 reference.
fn map_f64(phi_v: f64, theta_v: f64, p: DVec3) -> DVec3 {
    let (dphi, dtheta) = exact_f64(theta_v, p);
    map_point(phi_v + dphi, theta_v + dtheta)
}

/// Absolute map position of a ring point for a viewer, the f32 stable form (the GPU's twin),
/// with p̃ rounded once from f64 as the mesh stores it.
fn map_f32(phi_v: f64, theta_v: f64, p: &RingPoint) -> DVec3 {
    let u = TransformUniformsF32::from_theta_v(theta_v, Stretch::Exact);
    let (dphi, dtheta) = stable_f32(&u, p.p_tilde.as_vec3(), p.seam_side);
    map_point(phi_v + f64::from(dphi), theta_v + f64::from(dtheta))
}

/// The bound of `docs/design.md#numerics` for the stable f32 form on the ground (metres) at `distance_m` from the
/// viewer: ≤ 3e-7 m within 2 m, ≤ 0.2 mm within 1 km, about 1 cm at 64 km.
fn stable_bound_m(distance_m: f64) -> f64 {
    if distance_m <= 2.0 {
        3e-7
    } else if distance_m <= 1_000.0 {
        2e-4
    } else {
        1e-2
    }
}

const BANDS: [(&str, f64); 3] = [("≤ 2 m", 2.0), ("≤ 1 km", 1_000.0), ("≤ 64 km", 64_000.0)];

fn band_of(distance_m: f64) -> usize {
    BANDS
        .iter()
        .position(|(_, limit)| distance_m <= *limit)
        .unwrap_or(BANDS.len() - 1)
}

// ---------------------------------------------------------------------------------------------
// 1. Finite output everywhere

/// Every camera the viewer can be given yields finite frames, matrices, uniforms, map-transform
/// results (f64 and every f32 form, seam copies included), visibility bounds, level selection and
/// draw list. A single NaN here becomes a black frame or a lost GPU device, so there is no
/// "rare" camera: the poles, the antimeridian, 1 mm and 10⁹ m, straight up and down are all
/// everyday views of a globe.
#[test]
fn every_camera_gives_finite_frames_transforms_bounds_and_selection() {
    let (settings, mesh, bounds) = mesh();
    let levels = settings.levels;
    let drawn_levels_seen = Cell::new(0u64);
    let cases = check(
        "finite output",
        4000,
        (viewer(), prop::collection::vec(ring_point(1e-3, 2.0e7), 6)),
        |(v, points)| {
            let c = v.camera;
            let frame = c.view_frame();
            prop_assert!(frame.phi_v.is_finite() && frame.phi_v > -PI && frame.phi_v <= PI);
            prop_assert!((0.0..=PI).contains(&frame.theta_v));
            prop_assert!(is_rotation(&frame.world_from_view), "{frame:?}");
            prop_assert!(is_rotation(&c.view_from_camera()));
            prop_assert!(is_rotation(&c.world_from_camera()));
            prop_assert!(c.eye_world_m().is_finite() && c.eye_view_m().is_finite());

            // Projection: near plane from the height above terrain, both matrices, pixel rays.
            let near_m = near_plane_m(v.above_m());
            prop_assert!(near_m > 0.0 && near_m.is_finite());
            for (w, h) in [(1920u32, 1080u32), (64, 36)] {
                let aspect = f64::from(w) / f64::from(h);
                let clip = c.clip_from_camera(aspect, near_m);
                let inverse = camera_from_clip(c.fov_y_rad(), aspect, near_m);
                prop_assert!(clip.is_finite() && inverse.is_finite());
                let round_trip = (clip * inverse - DMat4::IDENTITY)
                    .to_cols_array()
                    .iter()
                    .fold(0.0f64, |m, x| m.max(x.abs()));
                prop_assert!(round_trip < 1e-9, "clip·inverse off by {round_trip}");
                for (px, py) in [(0, 0), (w - 1, h - 1), (w / 2, h / 2), (0, h - 1)] {
                    let ray = pixel_ray_view(&c, px, py, w, h);
                    prop_assert!(ray.is_finite() && (ray.length() - 1.0).abs() < 1e-12);
                }
            }

            // Map transform: uniforms, f64 and every f32 form at ring points out to the antipode.
            for stretch in [Stretch::Exact, Stretch::Paper] {
                let u = TransformUniformsF32::from_theta_v(frame.theta_v, stretch);
                let fields: [f32; 8] = bytemuck::cast(u);
                prop_assert!(fields.iter().all(|f| f.is_finite()), "{u:?}");
                for p in &points {
                    let (dphi, dtheta) = exact_f64(frame.theta_v, p.p_tilde);
                    prop_assert!(dphi.is_finite() && dtheta.is_finite(), "{p:?}");
                    prop_assert!(dtheta.abs() <= PI + 1e-12 && dphi.abs() <= PI);
                    let p32 = p.p_tilde.as_vec3();
                    let forms = [
                        direct_f32(&u, p32, p.seam_side),
                        stable_f32(&u, p32, p.seam_side),
                        approx_f32(&u, p32),
                        blended_f32(0.0, &u, p32, p.seam_side),
                        blended_f32(0.5, &u, p32, p.seam_side),
                        blended_f32(1.0, &u, p32, p.seam_side),
                    ];
                    for (i, (dphi, dtheta)) in forms.iter().enumerate() {
                        prop_assert!(
                            dphi.is_finite() && dtheta.is_finite(),
                            "form {i} at {p:?}: ({dphi}, {dtheta})"
                        );
                    }
                }
            }

            // Visibility bounds (eq. 6–8) and the level selection they drive.
            let theta_max = theta_tilde_max(
                EARTH_RADIUS_M,
                c.altitude_m,
                EARTH_TERRAIN_MIN_M,
                EARTH_TERRAIN_MAX_M,
            );
            prop_assert!(theta_max.is_finite() && (0.0..=PI).contains(&theta_max));
            for pixels_y in [1080, 36] {
                let theta_min =
                    theta_tilde_min(EARTH_RADIUS_M, v.above_m(), c.fov_y_rad(), pixels_y);
                prop_assert!(theta_min.is_finite() && theta_min > 0.0);
                let sel = LevelSelection::new(levels, theta_max, theta_min);
                prop_assert!(sel.coarsest <= sel.finest && sel.finest < levels, "{sel:?}");
                prop_assert!(sel.any_drawn());
                for (i, s) in sel.status.iter().enumerate() {
                    let drawn = sel.drawn_levels().contains(&(i as u32));
                    prop_assert_eq!(*s == LevelStatus::Drawn, drawn, "{:?}", sel);
                }
                drawn_levels_seen.set(drawn_levels_seen.get() + sel.drawn_levels().len() as u64);

                // The sector list for that selection: every sector drawn or culled, once.
                let camera_from_view = c.view_from_camera().transpose();
                let frustum = Frustum::new(
                    camera_from_view,
                    c.eye_view_m(),
                    c.fov_y_rad(),
                    16.0 / 9.0,
                    near_m,
                );
                // Mixed densities: every drawn level at a different one, edges shared.
                let mut densities = DensityPlan::full(settings.levels);
                let body: Vec<Density> = sel
                    .drawn_levels()
                    .map(|l| Density {
                        k: (l * 7 + (c.altitude_m.to_bits() as u32 & 7)) % (mesh.max_density + 1),
                        morph: 0.0,
                    })
                    .collect();
                densities.set_drawn(&sel, &body);
                let list = DrawList::build(
                    mesh,
                    bounds,
                    &sel,
                    &densities,
                    Some(&frustum),
                    |_| {
                        (
                            EARTH_RADIUS_M + EARTH_TERRAIN_MIN_M,
                            EARTH_RADIUS_M + EARTH_TERRAIN_MAX_M,
                        )
                    },
                    PlanarCut::NONE,
                );
                let sectors = (sel.drawn_levels().len() as u32 + 1) * settings.sectors;
                prop_assert_eq!(list.sectors_drawn + list.sectors_culled, sectors);
                let most = sel.drawn_levels().len() as u64 * settings.triangles_per_level()
                    + settings.triangles_per_cap();
                prop_assert!(list.triangles <= most);
            }
            Ok(())
        },
    );
    eprintln!(
        "finite output: {cases} cameras × 6 ring points × 2 stretches × 7 transform forms; \
         {} drawn levels selected in all",
        drawn_levels_seen.get()
    );
}

// ---------------------------------------------------------------------------------------------
// 2. Continuity of the image under a 1 mm move

const IMAGE_W: f64 = 1920.0;
const IMAGE_H: f64 = 1080.0;
/// Most a point `distance_m` away can move in the 1920×1080 image (pixels) when the eye moves by
/// `motion_m` (the orientation kept), anywhere within 1.1× the image: with u = f·X/z,
/// |δu| ≤ (f·ε/z)·(1 + |X/z|) and z ≥ d/√(1 + tan²h + tan²v).
fn parallax_bound_px(camera: &Camera, distance_m: f64, motion_m: f64) -> f64 {
    let tan_v = 1.1 * (0.5 * camera.fov_y_rad()).tan();
    let tan_h = tan_v * IMAGE_W / IMAGE_H;
    let focal_px = 0.5 * IMAGE_H / (0.5 * camera.fov_y_rad()).tan();
    let spread = (1.0 + tan_h).hypot(1.0 + tan_v) * (1.0 + tan_h * tan_h + tan_v * tan_v).sqrt();
    focal_px * spread * motion_m / distance_m
}

/// Points whose parallax alone may move them by 0.1 px under a 1 mm move are left out of the
/// 0.1 px property (≈ 37 m for a 60° view, ≈ 880 m for a 1° telephoto).
fn continuity_applies(camera: &Camera, distance_m: f64) -> bool {
    parallax_bound_px(camera, distance_m, 1e-3) <= 0.1
}

/// (east, north, up) unit vectors at (lat, lon), from the library's own view frame (at a pole:
/// the limits along the meridian `lon`).
fn enu_world(lat_deg: f64, lon_deg: f64) -> [DVec3; 3] {
    let frame = Camera {
        lat_deg,
        lon_deg,
        altitude_m: 0.0,
        heading_deg: 0.0,
        pitch_deg: 0.0,
        roll_deg: 0.0,
        fov_y_deg: 60.0,
    }
    .view_frame()
    .world_from_view;
    [frame.y_axis, -frame.x_axis, frame.z_axis]
}

/// The camera parameters (latitude, longitude, altitude, heading, pitch, roll) of a pose given
/// as an eye position and a world-from-camera rotation: what a navigation controller does after
/// moving the eye. Across the antimeridian the longitude wraps, over a pole it jumps by 180°
/// and the heading with it; looking straight up or down, roll is folded into the heading.
fn camera_at_pose(eye_world_m: DVec3, world_from_camera: DMat3, fov_y_deg: f64) -> Camera {
    let (phi, theta, altitude_m) = phi_theta_height_from_ecef_m(eye_world_m, EARTH_RADIUS_M);
    let (lat_deg, lon_deg) = lat_lon_deg_from_phi_theta(phi, theta);
    let [east, north, up] = enu_world(lat_deg, lon_deg);
    let to_enu = |v: DVec3| DVec3::new(v.dot(east), v.dot(north), v.dot(up));
    let forward = to_enu(-world_from_camera.z_axis);
    let right = to_enu(world_from_camera.x_axis);
    let horizontal = forward.x.hypot(forward.y);
    let pitch = forward.z.atan2(horizontal);
    let (heading, roll) = if horizontal > 1e-12 {
        let heading = forward.x.atan2(forward.y);
        let (sin_h, cos_h) = heading.sin_cos();
        let (sin_p, cos_p) = pitch.sin_cos();
        let right_unrolled = DVec3::new(cos_h, -sin_h, 0.0);
        let up_unrolled = DVec3::new(-sin_h * sin_p, -cos_h * sin_p, cos_p);
        (
            heading,
            (-right.dot(up_unrolled)).atan2(right.dot(right_unrolled)),
        )
    } else {
        ((-right.y).atan2(right.x), 0.0)
    };
    Camera {
        lat_deg,
        lon_deg,
        altitude_m,
        heading_deg: heading.to_degrees(),
        pitch_deg: pitch.to_degrees(),
        roll_deg: roll.to_degrees(),
        fov_y_deg,
    }
}

/// Pixel position of a world point for a pose (eye, rotation) in a 1920×1080 image, f64; None
/// behind the near plane or well outside the image.
fn pixel_of_pose(
    eye_world_m: DVec3,
    world_from_camera: &DMat3,
    fov_y_rad: f64,
    near_m: f64,
    point_world_m: DVec3,
) -> Option<DVec2> {
    let p = world_from_camera.transpose() * (point_world_m - eye_world_m);
    if p.z > -near_m {
        return None;
    }
    let clip = globe::geo::clip_from_camera(fov_y_rad, IMAGE_W / IMAGE_H, near_m);
    let ndc = clip.project_point3(p);
    (ndc.x.abs() <= 1.1 && ndc.y.abs() <= 1.1)
        .then(|| DVec2::new((ndc.x + 1.0) * 0.5 * IMAGE_W, (1.0 - ndc.y) * 0.5 * IMAGE_H))
}

fn pixel_of(camera: &Camera, near_m: f64, point_world_m: DVec3) -> Option<DVec2> {
    pixel_of_pose(
        camera.eye_world_m(),
        &camera.world_from_camera(),
        camera.fov_y_rad(),
        near_m,
        point_world_m,
    )
}

/// Terrain points the camera sees: where a 7×7 grid of pixel rays meets the ground sphere
/// (radius R + ground), and ground points 25 m … 1000 km away along the heading and 20° either
/// side of it.
fn visible_ground_points(v: &Viewer, near_m: f64) -> Vec<DVec3> {
    let c = &v.camera;
    let eye = c.eye_world_m();
    let radius_m = EARTH_RADIUS_M + v.ground_m;
    let world_from_view = c.view_frame().world_from_view;
    let mut points = Vec::new();
    for j in 0..7 {
        for i in 0..7 {
            let px = (i * (IMAGE_W as u32 - 1)) / 6;
            let py = (j * (IMAGE_H as u32 - 1)) / 6;
            let ray = world_from_view * pixel_ray_view(c, px, py, IMAGE_W as u32, IMAGE_H as u32);
            // |eye + t·ray| = radius: nearest root.
            let b = eye.dot(ray);
            let disc = b * b - (eye.length_squared() - radius_m * radius_m);
            if disc >= 0.0 {
                let t = -b - disc.sqrt();
                if t > 0.0 {
                    points.push(eye + t * ray);
                }
            }
        }
    }
    let [east, north, up] = enu_world(c.lat_deg, c.lon_deg);
    for distance_m in [25.0, 100.0, 1e3, 1e4, 1e5, 1e6] {
        let angle = distance_m / radius_m;
        for azimuth_deg in [-20.0, 0.0, 20.0] {
            let (sin_a, cos_a) = (c.heading_deg + azimuth_deg).to_radians().sin_cos();
            let along = sin_a * east + cos_a * north;
            points.push(radius_m * (angle.cos() * up + angle.sin() * along));
        }
    }
    points.retain(|p| pixel_of(c, near_m, *p).is_some());
    points
}

/// Directions of the 1 mm move in the camera's local (east, north, up) frame.
fn move_direction_enu() -> impl Strategy<Value = DVec3> {
    prop_oneof![
        1 => Just(DVec3::Y),
        1 => Just(-DVec3::Y),
        1 => Just(DVec3::X),
        1 => Just(-DVec3::X),
        1 => Just(DVec3::Z),
        1 => Just(-DVec3::Z),
        4 => (-1.0..=1.0f64, -1.0..=1.0f64, -1.0..=1.0f64)
            .prop_filter("a direction", |(x, y, z)| x * x + y * y + z * z > 1e-3)
            .prop_map(|(x, y, z)| DVec3::new(x, y, z).normalize()),
    ]
}

/// A 1 mm move of the eye in any direction — across the antimeridian, over a pole, up, down —
/// with the orientation kept, expressed again as camera parameters, moves every terrain point
/// the camera sees by < 0.1 px (wherever parallax alone keeps it under that), and the image from
/// the new parameters is the image of the moved pose within 1e-3 px. A jump here (a flipped
/// heading convention at a pole, a longitude that does not wrap) is a visible snap of the whole
/// view.
#[test]
fn a_millimetre_move_moves_the_image_by_less_than_a_tenth_of_a_pixel() {
    let worst_shift = Worst::default();
    let worst_param = Worst::default();
    let pairs = Cell::new(0u64);
    let cameras_with_points = Cell::new(0u64);
    let cases = check(
        "continuity (f64 camera)",
        4000,
        (viewer(), move_direction_enu()),
        |(v, direction_enu)| {
            let c = v.camera;
            let near_m = near_plane_m(v.above_m());
            let [east, north, up] = enu_world(c.lat_deg, c.lon_deg);
            let step =
                1e-3 * (direction_enu.x * east + direction_enu.y * north + direction_enu.z * up);
            let world_from_camera = c.world_from_camera();
            let moved_eye = c.eye_world_m() + step;
            let moved = camera_at_pose(moved_eye, world_from_camera, c.fov_y_deg);
            // The parameters really describe the moved pose.
            let orientation_error = max_abs_diff(&moved.world_from_camera(), &world_from_camera);
            prop_assert!(
                orientation_error < 1e-9,
                "{moved:?}: orientation off by {orientation_error}"
            );
            let eye_error = (moved.eye_world_m() - moved_eye).length();
            prop_assert!(
                eye_error < 1e-6 + 1e-15 * moved_eye.length(),
                "eye off by {eye_error} m"
            );

            let points = visible_ground_points(&v, near_m);
            if !points.is_empty() {
                cameras_with_points.set(cameras_with_points.get() + 1);
            }
            for p in points {
                let distance_m = (p - c.eye_world_m()).length();
                let (Some(before), Some(after), Some(pose)) = (
                    pixel_of(&c, near_m, p),
                    pixel_of(&moved, near_m, p),
                    pixel_of_pose(moved_eye, &world_from_camera, c.fov_y_rad(), near_m, p),
                ) else {
                    continue;
                };
                if continuity_applies(&c, distance_m) {
                    let param_error_px = (after - pose).length();
                    prop_assert!(
                        param_error_px < 1e-3,
                        "{moved:?} projects {p} {param_error_px} px away from the moved pose"
                    );
                    worst_param.note(param_error_px, || format!("{c:?} → {moved:?}"));
                    let shift_px = (after - before).length();
                    prop_assert!(
                        shift_px < 0.1,
                        "point {distance_m:.1} m away moved {shift_px} px ({c:?} → {moved:?})"
                    );
                    worst_shift.note(shift_px, || format!("{distance_m:.1} m away, {c:?}"));
                    pairs.set(pairs.get() + 1);
                }
            }
            Ok(())
        },
    );
    eprintln!(
        "continuity (f64 camera): {cases} moves, {} with visible ground, {} point checks; \
         max shift {:.4} px ({}); parameters vs pose max {:.2e} px",
        cameras_with_points.get(),
        pairs.get(),
        worst_shift.get(),
        worst_shift.what.borrow(),
        worst_param.get()
    );
}

/// Screen position of a ring vertex of height `height_m` as the vertex shader computes it, in
/// f32 (`shaders/terrain.wgsl` `vs_main`): rel = (r·p̃x, r·p̃y, ((h − h_eye,hi) − h_eye,lo) −
/// r·(1 − cos θ̃)), r = R + h, the eye height split into an f32 and the f64 remainder, clip = clip_from_view·rel, with every input rounded to f32 as the uniforms and
/// the vertex buffer carry it. Returns the pixel (1920×1080) and rel.z, or None behind the
/// camera or outside the image.
fn vertex_pixel_f32(v: &Viewer, p: &RingPoint, height_m: f64, near_m: f64) -> Option<(DVec2, f32)> {
    let c = &v.camera;
    let clip_from_view = c.clip_from_camera(IMAGE_W / IMAGE_H, near_m)
        * DMat4::from_mat3(c.view_from_camera().transpose());
    let clip_from_view = clip_from_view.as_mat4();
    let theta_tilde = p.distance_m / EARTH_RADIUS_M;
    let p32 = p.p_tilde.as_vec3();
    let one_minus_cos = map_transform::one_minus_cos(theta_tilde) as f32;
    let h = height_m as f32;
    let r = EARTH_RADIUS_M as f32 + h;
    let eye_hi = c.altitude_m as f32;
    let eye_lo = (c.altitude_m - f64::from(eye_hi)) as f32;
    let rel = Vec3::new(
        r * p32.x,
        r * p32.y,
        ((h - eye_hi) - eye_lo) - r * one_minus_cos,
    );
    let clip: Vec4 = clip_from_view * rel.extend(1.0);
    if clip.w <= 0.0 {
        return None;
    }
    let (x, y) = (
        f64::from(clip.x) / f64::from(clip.w),
        f64::from(clip.y) / f64::from(clip.w),
    );
    (x.abs() <= 1.1 && y.abs() <= 1.1).then(|| {
        (
            DVec2::new((x + 1.0) * 0.5 * IMAGE_W, (1.0 - y) * 0.5 * IMAGE_H),
            rel.z,
        )
    })
}

/// The same vertex in f64 (the geometry the f32 path approximates).
fn vertex_pixel_f64(v: &Viewer, p: &RingPoint, height_m: f64, near_m: f64) -> Option<DVec2> {
    let c = &v.camera;
    let r = EARTH_RADIUS_M + height_m;
    let point_view = r * p.p_tilde;
    let point_camera = c.view_from_camera().transpose() * (point_view - c.eye_view_m());
    if point_camera.z > -near_m {
        return None;
    }
    let ndc = c
        .clip_from_camera(IMAGE_W / IMAGE_H, near_m)
        .project_point3(point_camera);
    (ndc.x.abs() <= 1.1 && ndc.y.abs() <= 1.1)
        .then(|| DVec2::new((ndc.x + 1.0) * 0.5 * IMAGE_W, (1.0 - ndc.y) * 0.5 * IMAGE_H))
}

/// The vertex shader's f32 position (its Rust twin here) follows a 1 mm climb or descent of the
/// camera as the f64 geometry does: where parallax keeps the motion under 0.1 px (≥ 37 m in a
/// 60° view) the f32 image moves by < 0.1 px and within 0.05 px of the f64 motion. (A horizontal
/// move over level ground leaves every f32 vertex input unchanged: the mesh is fixed in view
/// space.) Nearer vertices are held to what explains their error: the roundings of rel.z (the
/// eye height reaches the shader as an f32 plus its f64 remainder, so a 1 mm climb is not lost
/// in one ulp of the altitude, ≈ 1 mm at Everest's height, as it was before that split); the
/// error must stay within 0.05 px plus the parallax of those roundings.
#[test]
fn f32_vertex_positions_follow_a_millimetre_climb() {
    let worst_far = Worst::default();
    let worst_near = Worst::default();
    let worst_near_ratio = Worst::default();
    let checks = Cell::new(0u64);
    let cases = check(
        "continuity (f32 vertex twin)",
        3000,
        (
            viewer(),
            prop::collection::vec(ring_point(1.0, 1.0e6), 16),
            prop_oneof![Just(1e-3), Just(-1e-3)],
        ),
        |(v, points, climb_m)| {
            let near_m = near_plane_m(v.above_m());
            let mut moved = v;
            moved.camera.altitude_m += climb_m;
            let near_moved_m = near_plane_m(moved.above_m());
            for p in &points {
                let h = v.ground_m;
                let (Some((a32, rel_z)), Some((b32, _)), Some(a64), Some(b64)) = (
                    vertex_pixel_f32(&v, p, h, near_m),
                    vertex_pixel_f32(&moved, p, h, near_moved_m),
                    vertex_pixel_f64(&v, p, h, near_m),
                    vertex_pixel_f64(&moved, p, h, near_moved_m),
                ) else {
                    continue;
                };
                let distance_m = (EARTH_RADIUS_M + h) * p.p_tilde - v.camera.eye_view_m();
                let distance_m = distance_m.length();
                let shift_px = (b32 - a32).length();
                let error_px = ((b32 - a32) - (b64 - a64)).length();
                checks.set(checks.get() + 1);
                let what = || format!("{distance_m:.2} m away, {v:?}, climb {climb_m} m");
                if continuity_applies(&v.camera, distance_m) {
                    prop_assert!(shift_px < 0.1, "moved {shift_px} px: {}", what());
                    prop_assert!(
                        error_px < 0.05,
                        "f32 motion off by {error_px} px: {}",
                        what()
                    );
                    worst_far.note(error_px, what);
                } else {
                    prop_assert!(
                        error_px < 0.05,
                        "f32 motion off by {error_px} px: {}",
                        what()
                    );
                    let steps_m = 3.0 * ulp_f32(rel_z);
                    let explained_px = 0.05 + parallax_bound_px(&v.camera, distance_m, steps_m);
                    prop_assert!(
                        error_px <= explained_px,
                        "f32 motion off by {error_px} px > {explained_px} px: {}",
                        what()
                    );
                    worst_near.note(error_px, what);
                    worst_near_ratio.note(error_px / explained_px, what);
                }
            }
            Ok(())
        },
    );
    eprintln!(
        "continuity (f32 vertex twin): {cases} climbs, {} vertex checks; |f32 − f64 motion| max \
         {:.4} px where parallax < 0.1 px ({}); nearer max {:.4} px ({}), at most {:.2} of the \
         rounding bound",
        checks.get(),
        worst_far.get(),
        worst_far.what.borrow(),
        worst_near.get(),
        worst_near.what.borrow(),
        worst_near_ratio.get()
    );
}

/// What an absolute map position (φ, θ) in f64 resolves on the ground: one ulp of θ ≈ π is
/// 4.4e-16 rad, 2.8e-9 m; a few of them (two map positions and their distance).
const MAP_RESOLUTION_M: f64 = 1e-8;

/// How the viewer moves 1 mm in map space for the f32 map-transform continuity property.
#[derive(Clone, Copy, Debug)]
enum MapMove {
    /// Along the meridian, towards the south pole (+1) or the north pole (−1); over a pole the
    /// longitude jumps by π and the view frame turns by π about the vertical.
    Meridian(f64),
    /// Along the parallel, east (+1) or west (−1): across the antimeridian when φv is near π.
    Parallel(f64),
}

/// The stable f32 map transform is continuous as the viewer moves 1 mm (over a pole, across the
/// antimeridian, off a pole exactly): the map position a fixed mesh vertex samples moves as the
/// f64 reference's does, within twice the bound of `docs/design.md#numerics` for its distance. Over a pole the view
/// frame turns by π, so vertex p̃ continues as the vertex turned by π (the ring mesh is symmetric
/// under that turn, so the rendered surface is the same set of vertices).
#[test]
fn f32_map_transform_is_continuous_over_poles_and_the_antimeridian() {
    let worst = Worst::default();
    let crossings = Cell::new((0u64, 0u64));
    let delta = 1e-3 / EARTH_RADIUS_M;
    let cases = check(
        "continuity (f32 map transform)",
        10000,
        (
            phi_v_rad(),
            theta_v_rad(),
            ring_point(1e-3, 64_000.0),
            prop_oneof![
                Just(MapMove::Meridian(1.0)),
                Just(MapMove::Meridian(-1.0)),
                Just(MapMove::Parallel(1.0)),
                Just(MapMove::Parallel(-1.0)),
            ],
        ),
        |(phi_v, theta_v, p, step)| {
            let mut after = p;
            let (phi_moved, theta_moved, rotation_m) = match step {
                MapMove::Meridian(sign) => {
                    let t = theta_v + sign * delta;
                    if (0.0..=PI).contains(&t) {
                        (phi_v, t, 0.0)
                    } else {
                        // Over the pole: the same world point seen from the other meridian.
                        after.p_tilde = DVec3::new(-p.p_tilde.x, -p.p_tilde.y, p.p_tilde.z);
                        if p.seam_side != 0.0 {
                            after.p_tilde.y = 0.0;
                            after.seam_side = -p.seam_side;
                        }
                        let t = if t < 0.0 { -t } else { TAU - t };
                        let (a, b) = crossings.get();
                        crossings.set((a + 1, b));
                        (wrap_angle_rad(phi_v + PI), t, 0.0)
                    }
                }
                MapMove::Parallel(sign) => {
                    // An east move is a translation of the frame only away from the poles; at a
                    // pole it is a turn. The frame turns by Δφ·cos θv about the vertical.
                    if theta_v.sin() < 1e-3 {
                        return Ok(());
                    }
                    let dphi = sign * delta / theta_v.sin();
                    let moved = phi_v + dphi;
                    if moved.abs() > PI {
                        let (a, b) = crossings.get();
                        crossings.set((a, b + 1));
                    }
                    (
                        wrap_angle_rad(moved),
                        theta_v,
                        (dphi * theta_v.cos()).abs() * p.distance_m,
                    )
                }
            };
            let before64 = map_f64(phi_v, theta_v, p.p_tilde);
            let after64 = map_f64(phi_moved, theta_moved, after.p_tilde);
            let before32 = map_f32(phi_v, theta_v, &p);
            let after32 = map_f32(phi_moved, theta_moved, &after);
            let moved64_m = great_circle_distance_m(before64, after64, EARTH_RADIUS_M);
            prop_assert!(
                moved64_m <= 1e-3 + rotation_m * 1.001 + MAP_RESOLUTION_M,
                "f64 reference moved {moved64_m} m"
            );
            let before_err = great_circle_distance_m(before32, before64, EARTH_RADIUS_M);
            let after_err = great_circle_distance_m(after32, after64, EARTH_RADIUS_M);
            let moved32_m = great_circle_distance_m(before32, after32, EARTH_RADIUS_M);
            let mismatch_m = (moved32_m - moved64_m).abs();
            let bound = 2.0 * stable_bound_m(p.distance_m);
            prop_assert!(
                mismatch_m <= bound,
                "vertex {p:?}: f32 moved {moved32_m} m, f64 {moved64_m} m (errors {before_err}, {after_err})"
            );
            worst.note(mismatch_m / bound, || {
                format!(
                    "{mismatch_m:.2e} m at {:.3} m, θv {theta_v:e}, {step:?}",
                    p.distance_m
                )
            });
            Ok(())
        },
    );
    let (over_pole, over_antimeridian) = crossings.get();
    eprintln!(
        "continuity (f32 map transform): {cases} moves ({over_pole} over a pole, \
         {over_antimeridian} across the antimeridian); worst |f32 − f64 motion| / bound {:.3} ({})",
        worst.get(),
        worst.what.borrow()
    );
}

// ---------------------------------------------------------------------------------------------
// 3. Error bounds of the stable f32 map transform

/// Spacing of f32 values at |x| (one unit in the last place).
fn ulp_f32(x: f32) -> f64 {
    let x = x.abs().max(f32::MIN_POSITIVE);
    f64::from(x.next_up() - x)
}

/// The stable f32 form's ground error against the f64 reference for random viewers (poles
/// exactly, 1e-16 rad from them, anywhere between) and random ring points out to 64 km (seam
/// copies included), checked against `bound(distance, resolution)` where `resolution` is one ulp
/// of the f32 outputs on the ground (R·ulp(Δθ) + R·sin θ·ulp(Δφ)). Prints the worst error per
/// distance band.
fn stable_error_property(name: &str, cases: u32, bound: impl Fn(f64, f64) -> f64) -> u32 {
    let worst: [Worst; 3] = Default::default();
    let ratio: [Worst; 3] = Default::default();
    let counts: [Cell<u64>; 3] = Default::default();
    let cases = check(
        name,
        cases,
        (phi_v_rad(), theta_v_rad(), ring_point(1e-3, 64_000.0)),
        |(phi_v, theta_v, p)| {
            let u = TransformUniformsF32::from_theta_v(theta_v, Stretch::Exact);
            let (dphi, dtheta) = stable_f32(&u, p.p_tilde.as_vec3(), p.seam_side);
            let got = map_point(phi_v + f64::from(dphi), theta_v + f64::from(dtheta));
            let want = map_f64(phi_v, theta_v, p.p_tilde);
            let error_m = great_circle_distance_m(got, want, EARTH_RADIUS_M);
            let theta = theta_v + f64::from(dtheta);
            let resolution_m =
                EARTH_RADIUS_M * (ulp_f32(dtheta) + theta.sin().abs() * ulp_f32(dphi));
            let limit_m = bound(p.distance_m, resolution_m);
            prop_assert!(
                error_m <= limit_m,
                "θv = {theta_v:e}, {p:?}: {error_m:e} m > {limit_m:e} m \
                 (f32 output resolution {resolution_m:e} m)"
            );
            let band = band_of(p.distance_m);
            counts[band].set(counts[band].get() + 1);
            let what = || {
                format!(
                    "θv {theta_v:e}, {:.4} m, resolution {resolution_m:.1e} m",
                    p.distance_m
                )
            };
            worst[band].note(error_m, what);
            ratio[band].note(error_m / stable_bound_m(p.distance_m), what);
            Ok(())
        },
    );
    for (i, (band, limit)) in BANDS.iter().enumerate() {
        eprintln!(
            "{name} {band}: max {:.2e} m over {} points, {:.2} × DESIGN's {:.0e} m \
             (worst at {}; worst ratio at {})",
            worst[i].get(),
            counts[i].get(),
            ratio[i].get(),
            stable_bound_m(*limit),
            worst[i].what.borrow(),
            ratio[i].what.borrow(),
        );
    }
    cases
}

/// The bounds of `docs/design.md#numerics` for the stable f32 form, as stated: ≤ 3e-7 m within 2 m, ≤ 0.2 mm
/// within 1 km, ≤ 1 cm out to 64 km, for random viewers and ring points. `geo_math.rs` checks the
/// reference vectors and a fixed sweep against 1 cm; this is the generalisation.
///
/// Ignored: the stated numbers are exceeded by about one ulp of the f32 output near the poles.
/// Minimised with PROPTEST_RNG_SEED=444200870501: θv = 3.1415926535113123 (0.5 mm from the
/// south pole), φv = 0, p̃ = (0.007015244514938548, −0.006183440139394935, 0.9999562747502704)
/// (59.6 km away) is off by 1.049e-2 m > 1e-2 m. Over 20 000 cases the worst are 3.04e-7 m at
/// 1.7 m (θv = 1.8e-9), 2.07e-4 m at 887 m (θv = 0) and 1.71e-2 m at 64 km (θv = 1.2e-9): at a
/// pole Δφ spans (−π, π], and one f32 ulp of it is 2.4e-7 rad, 0.24 mm on the ground at 1 km and
/// 1.5 cm at 64 km, whatever the form. The property that holds (bound + one output ulp) is
/// `stable_f32_form_is_within_the_design_bounds_plus_output_resolution`.
#[test]
#[ignore = "the f32 bounds of docs/design.md#numerics are exceeded by one output ulp near the poles (see doc)"]
fn stable_f32_form_meets_the_design_bounds_for_random_viewers() {
    stable_error_property("stable f32 vs DESIGN bounds", 20000, |distance_m, _| {
        stable_bound_m(distance_m)
    });
}

/// The stable f32 form is within the bound of `docs/design.md#numerics` plus one ulp of its own f32 output on the
/// ground for random viewers, poles included: the form adds no error of its own beyond what any
/// f32 result of that size must carry. (At a pole Δφ spans (−π, π], so one ulp of Δφ is
/// 2.4e-7 rad: 0.24 mm on the ground at 1 km, 1.5 cm at 64 km.)
#[test]
fn stable_f32_form_is_within_the_design_bounds_plus_output_resolution() {
    stable_error_property(
        "stable f32 vs DESIGN bounds + 1 ulp",
        20000,
        |distance_m, resolution_m| stable_bound_m(distance_m) + resolution_m,
    );
}

// ---------------------------------------------------------------------------------------------
// 4. Data extremes in the pyramid

/// A raster held in memory (NaN = no data).
#[derive(Clone, Debug)]
struct MemRaster {
    grid: GeoGrid,
    values: Vec<f32>,
}

impl RasterSource for MemRaster {
    fn grid(&self) -> GeoGrid {
        self.grid
    }
    fn read_row(&self, row: usize, out: &mut [f32]) -> Result<(), DemError> {
        let cols = self.grid.cols;
        out.copy_from_slice(&self.values[row * cols..(row + 1) * cols]);
        Ok(())
    }
    fn describe(&self) -> String {
        format!("in-memory {} × {}", self.grid.cols, self.grid.rows)
    }
}

fn tmp_path(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("stability-tests");
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir.join(name)
}

/// Heights of the i16 extremes, no data, sea level and anything else a 16-bit DEM holds (never
/// −9999, so that a −9999 read back can only be a leaked no-data sentinel).
fn raster_value() -> impl Strategy<Value = f32> {
    prop_oneof![
        1 => Just(-32768.0f32),
        1 => Just(32767.0f32),
        1 => Just(f32::NAN),
        1 => Just(0.0f32),
        2 => (-32767i16..=32767).prop_map(|v| if v == -9999 { -9998.0 } else { f32::from(v) }),
    ]
}

/// Small rasters: 1×1, 2×1, 1×2, 3×2, global or a regional box anywhere (the poles and the
/// antimeridian included).
fn small_raster() -> impl Strategy<Value = MemRaster> {
    let shape = prop_oneof![
        Just((1usize, 1usize)),
        Just((2, 1)),
        Just((1, 2)),
        Just((3, 2))
    ];
    let extent = prop_oneof![
        Just(None),
        (-180.0..=180.0f64, -90.0..=90.0f64, -4.0..=1.0f64).prop_map(Some),
    ];
    (shape, extent).prop_flat_map(|((cols, rows), extent)| {
        let grid = match extent {
            None => GeoGrid::global(cols, rows),
            Some((lon0, lat0, log_spacing)) => {
                let d = 10f64.powf(log_spacing);
                // Keep every row centre on the sphere.
                let lat0 = lat0.clamp(-90.0 + d * (rows - 1) as f64, 90.0);
                GeoGrid {
                    cols,
                    rows,
                    lon0_deg: lon0,
                    lat0_deg: lat0,
                    dlon_deg: d,
                    dlat_deg: d,
                }
            }
        };
        prop::collection::vec(raster_value(), cols * rows)
            .prop_map(move |values| MemRaster { grid, values })
    })
}

/// Points to sample: the poles, the antimeridian from both sides, the raster's own pixel centres
/// and corners, and points outside a regional raster.
fn sample_points(grid: &GeoGrid) -> Vec<(f64, f64)> {
    let mut points = vec![
        (90.0, 0.0),
        (-90.0, 123.0),
        (0.0, 180.0),
        (0.0, -180.0),
        (45.0, 179.999_999),
        (-45.0, -179.999_999),
        (12.3, 45.6),
        (-89.999_999, -10.0),
    ];
    for r in 0..grid.rows {
        for c in 0..grid.cols {
            let (lat, lon) = (grid.lat_of_row(r as f64), grid.lon_of_col(c as f64));
            points.push((lat, lon));
            points.push((
                (lat + 0.5 * grid.dlat_deg).min(90.0),
                lon - 0.5 * grid.dlon_deg,
            ));
            points.push((
                (lat - 0.3 * grid.dlat_deg).max(-90.0),
                lon + 0.7 * grid.dlon_deg,
            ));
        }
    }
    points
}

/// Builds `raster` with the default encoding and, when that refuses −32768 (outside the ±32767
/// codes of a 1 m quantum), with a 2 m quantum. Returns the pyramid path and the quantum, or the
/// error of the default build.
fn build_extreme(
    raster: &MemRaster,
    name: &str,
) -> Result<(PathBuf, f64, Option<String>), TestCaseError> {
    let path = tmp_path(name);
    let mut refused = None;
    let quantum_m = match PyramidBuilder::new().tile_size(4).build(raster, &path) {
        Ok(_) => 1.0,
        Err(e) => {
            let message = e.to_string();
            let has_min = raster.values.contains(&-32768.0);
            prop_assert!(
                has_min,
                "build failed without −32768 in the data: {message}"
            );
            prop_assert!(
                message.contains("row")
                    && message.contains("column")
                    && message.contains("-32768")
                    && message.contains("quantum"),
                "unclear error: {message}"
            );
            let mut partial = path.clone().into_os_string();
            partial.push(".partial");
            prop_assert!(!path.exists() && !PathBuf::from(partial).exists());
            refused = Some(message);
            PyramidBuilder::new()
                .tile_size(4)
                .encoding(2.0, 0.0)
                .build(raster, &path)
                .map_err(|e| TestCaseError::fail(format!("2 m quantum: {e}")))?;
            2.0
        }
    };
    Ok((path, quantum_m, refused))
}

/// Pyramids built from tiny rasters (1×1, 2×1, 1×2, 3×2; global or regional anywhere) of the
/// i16 extremes, no data and ordinary heights either build, or fail with an error naming the
/// pixel and the remedy (−32768 with a 1 m quantum); what they build samples finite heights
/// within the data's range (no data read as sea level: never NaN, never −9999) at every level,
/// at the poles and across the antimeridian, through the pyramid and through the terrain
/// function (with its pole caps), and culling bounds that hold those samples.
#[test]
fn tiny_and_extreme_rasters_build_or_fail_clearly_and_sample_within_range() {
    let refused = Cell::new(0u64);
    let samples = Cell::new(0u64);
    let counter = Cell::new(0u64);
    let cases = check("data extremes", 300, small_raster(), |raster| {
        counter.set(counter.get() + 1);
        let name = format!("extreme-{}-{}.gpyr", std::process::id(), counter.get());
        let (path, quantum_m, error) = build_extreme(&raster, &name)?;
        if error.is_some() {
            refused.set(refused.get() + 1);
        }
        // Integer heights at a 1 m quantum are stored exactly; a 2 m quantum rounds the
        // average to the nearest code (≤ 1 m).
        let slack_m = if quantum_m == 1.0 {
            0.0
        } else {
            0.5 * quantum_m
        };
        let data = raster
            .values
            .iter()
            .map(|v| if v.is_nan() { 0.0 } else { f64::from(*v) });
        let lo = data.clone().fold(f64::INFINITY, f64::min) - slack_m;
        let hi = data.fold(f64::NEG_INFINITY, f64::max) + slack_m;
        let pyramid = Pyramid::open(&path).map_err(|e| TestCaseError::fail(e.to_string()))?;
        let terrain = DemTerrain::open(&path, EARTH_RADIUS_M)
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
        let in_range =
            |h: f64, lo: f64, hi: f64| h.is_finite() && h != -9999.0 && h >= lo && h <= hi;
        for level in 0..pyramid.level_count() {
            for &(lat, lon) in &sample_points(&raster.grid) {
                if let Some(h) = pyramid.sample(lat, lon, level) {
                    prop_assert!(
                        in_range(h, lo, hi),
                        "level {level} at ({lat}, {lon}): {h} m"
                    );
                }
                // The terrain function: sea level outside the data.
                let h = terrain.sample_m(lat, lon, level);
                prop_assert!(
                    in_range(h, lo.min(0.0), hi.max(0.0)),
                    "terrain level {level} at ({lat}, {lon}): {h} m"
                );
                let region = Region::Cap {
                    lat_deg: lat,
                    lon_deg: lon,
                    radius_rad: 1e-3,
                };
                if let Some(b) = pyramid.min_max_in(region, level) {
                    prop_assert!(b.min_m.is_finite() && b.max_m.is_finite() && b.min_m <= b.max_m);
                    if let Some(h) = pyramid.sample(lat, lon, level) {
                        prop_assert!(b.min_m <= h && h <= b.max_m, "{h} outside {b:?}");
                    }
                }
                samples.set(samples.get() + 1);
            }
        }
        let (range_lo, range_hi) = terrain.height_range_m();
        prop_assert!(range_lo.is_finite() && range_hi.is_finite() && range_lo <= range_hi);
        drop(pyramid);
        drop(terrain);
        std::fs::remove_file(&path).ok();
        Ok(())
    });
    eprintln!(
        "data extremes: {cases} rasters, {} refused −32768 at a 1 m quantum (built at 2 m), \
         {} samples in range",
        refused.get(),
        samples.get()
    );
}

/// The named cases of the data-extremes item, one by one: i16 extremes, an all-no-data raster,
/// 1×1 and 2×1 rasters.
#[test]
fn named_data_extremes() {
    // 32767 fits the default 1 m quantum exactly; −32768 does not and the error says how to fix it.
    let high = MemRaster {
        grid: GeoGrid::global(2, 1),
        values: vec![32767.0, 0.0],
    };
    let path = tmp_path("named-high.gpyr");
    PyramidBuilder::new()
        .build(&high, &path)
        .expect("32767 m fits");
    let pyramid = Pyramid::open(&path).unwrap();
    let at_pixel = pyramid.sample(0.0, -90.0, 0);
    eprintln!("32767 m: built, sample at the pixel centre {at_pixel:?}");
    assert_eq!(at_pixel, Some(32767.0));
    drop(pyramid);

    let low = MemRaster {
        grid: GeoGrid::global(1, 1),
        values: vec![-32768.0],
    };
    let error = PyramidBuilder::new()
        .build(&low, &path)
        .expect_err("−32768 m is outside the 1 m quantum's codes");
    eprintln!("−32768 m at 1 m: {error}");
    assert!(error.to_string().contains("quantum"));
    // An offset that holds it builds, and reads it back exactly.
    PyramidBuilder::new()
        .encoding(1.0, -1.0)
        .build(&low, &path)
        .expect("offset −1 m holds −32768 m");
    let terrain = DemTerrain::open(&path, EARTH_RADIUS_M).unwrap();
    for (lat, lon) in [(0.0, 0.0), (90.0, 0.0), (-90.0, 77.0), (10.0, 180.0)] {
        assert_eq!(terrain.sample_m(lat, lon, 0), -32768.0, "({lat}, {lon})");
    }
    eprintln!("−32768 m at 1 m with offset −1 m: built, reads −32768 m everywhere");
    drop(terrain);

    // All no data: sea level everywhere, counted, and the terrain's range is [0, 0].
    let empty = MemRaster {
        grid: GeoGrid::global(3, 2),
        values: vec![f32::NAN; 6],
    };
    let report = PyramidBuilder::new().build(&empty, &path).unwrap();
    assert_eq!(report.nan_count, 6);
    let terrain = DemTerrain::open(&path, EARTH_RADIUS_M).unwrap();
    assert_eq!(terrain.height_range_m(), (0.0, 0.0));
    for (lat, lon) in [(0.0, 0.0), (90.0, 0.0), (-90.0, 0.0), (33.0, -180.0)] {
        assert_eq!(terrain.height_at_m(lat, lon), 0.0);
    }
    eprintln!(
        "all no data: {} no-data pixels, heights 0 m everywhere",
        report.nan_count
    );
    let error = PyramidBuilder::new()
        .nan_policy(globe::dem::pyramid::NanPolicy::Reject)
        .build(&empty, &path)
        .expect_err("reject policy");
    assert!(error.to_string().contains("NaN"));
    drop(terrain);

    // 1×1 and 2×1: one level, one tile; sampling interpolates within the values.
    for (cols, values) in [(1, vec![1234.0f32]), (2, vec![-5.0, 7.0])] {
        let raster = MemRaster {
            grid: GeoGrid::global(cols, 1),
            values: values.clone(),
        };
        let report = PyramidBuilder::new().build(&raster, &path).unwrap();
        let terrain = DemTerrain::open(&path, EARTH_RADIUS_M).unwrap();
        let (lo, hi) = values
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(f64::from(*v)), b.max(f64::from(*v)))
            });
        let mut seen = (f64::INFINITY, f64::NEG_INFINITY);
        for i in 0..=72 {
            for j in 0..=36 {
                let h = terrain.height_at_m(-90.0 + 5.0 * j as f64, -180.0 + 5.0 * i as f64);
                assert!(h.is_finite() && h >= lo && h <= hi, "{cols}×1: {h}");
                seen = (seen.0.min(h), seen.1.max(h));
            }
        }
        eprintln!(
            "{cols}×1: {} level(s), {} tile(s); heights {:.1} … {:.1} m (data {lo} … {hi} m)",
            report.levels, report.tiles, seen.0, seen.1
        );
    }
    std::fs::remove_file(&path).ok();
}

// ---------------------------------------------------------------------------------------------
// 5. GPU render properties

const RENDER_W: u32 = 64;
const RENDER_H: u32 = 36;

/// Colour as rendered (linear RGBA f32, so a NaN would survive) and reversed-Z depth.
struct FloatFrame {
    rgba: Vec<[f32; 4]>,
    depth: Vec<f32>,
    info: globe::render::FrameInfo,
}

impl FloatFrame {
    fn depth_at(&self, x: u32, y: u32) -> f32 {
        self.depth[(y * RENDER_W + x) as usize]
    }
}

const FLOAT_COLOR: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;

fn read_texture(
    ctx: &GpuContext,
    texture: &wgpu::Texture,
    aspect: wgpu::TextureAspect,
    bytes_per_texel: u32,
) -> Vec<u8> {
    let row = RENDER_W * bytes_per_texel;
    let padded =
        row.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let buffer = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("stability readback"),
        size: u64::from(padded * RENDER_H),
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    encoder.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo {
            texture,
            mip_level: 0,
            origin: wgpu::Origin3d::ZERO,
            aspect,
        },
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded),
                rows_per_image: Some(RENDER_H),
            },
        },
        wgpu::Extent3d {
            width: RENDER_W,
            height: RENDER_H,
            depth_or_array_layers: 1,
        },
    );
    ctx.queue.submit([encoder.finish()]);
    let (tx, rx) = std::sync::mpsc::channel();
    buffer.map_async(wgpu::MapMode::Read, .., move |r| {
        let _ = tx.send(r);
    });
    ctx.wait_idle().unwrap();
    rx.recv().unwrap().unwrap();
    let data = buffer.get_mapped_range(..).unwrap();
    let mut out = Vec::with_capacity((row * RENDER_H) as usize);
    for y in 0..RENDER_H as usize {
        let at = y * padded as usize;
        out.extend_from_slice(&data[at..at + row as usize]);
    }
    out
}

/// Renders `camera` into a 64×36 float colour target and a depth target.
fn render_float(ctx: &GpuContext, r: &mut TerrainRenderer, camera: &Camera) -> FloatFrame {
    let make = |label, format| {
        ctx.device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d {
                width: RENDER_W,
                height: RENDER_H,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        })
    };
    let color = make("stability colour", FLOAT_COLOR);
    let depth = make("stability depth", DEPTH_FORMAT);
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    let info = r.prepare(&ctx.queue, &mut encoder, camera, RENDER_W, RENDER_H);
    r.encode_pass(
        &mut encoder,
        &info,
        &color.create_view(&Default::default()),
        &depth.create_view(&Default::default()),
        wgpu::StoreOp::Store,
        None,
    );
    ctx.queue.submit([encoder.finish()]);
    let colour_bytes = read_texture(ctx, &color, wgpu::TextureAspect::All, 16);
    let depth_bytes = read_texture(ctx, &depth, wgpu::TextureAspect::DepthOnly, 4);
    let floats = |bytes: &[u8]| -> Vec<f32> {
        bytes
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect()
    };
    let rgba = floats(&colour_bytes)
        .chunks_exact(4)
        .map(|c| [c[0], c[1], c[2], c[3]])
        .collect();
    FloatFrame {
        rgba,
        depth: floats(&depth_bytes),
        info,
    }
}

/// What the geometry alone says about a pixel: its ray must meet the rendered surface when it
/// reaches the sphere below every mesh chord of the lowest terrain, and must see sky when it
/// misses the sphere of the highest terrain (both with a pixel of margin).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Certain {
    Ground,
    Sky,
    Either,
}

/// Closest approach of the ray from `eye` along unit `ray` to the planet's centre, and the
/// distance along the ray where it happens.
fn closest_approach(eye: DVec3, ray: DVec3) -> (f64, f64) {
    let t = -eye.dot(ray);
    ((eye + t.max(0.0) * ray).length(), t)
}

fn classify_pixels(r: &TerrainRenderer, camera: &Camera) -> Vec<Certain> {
    let radius_m = r.terrain.radius_m();
    let (h_min, h_max) = r.terrain.height_range_m();
    // The mesh's flat triangles sag below the sphere by at most R·(1 − cos(half the largest
    // triangle's diagonal)): level 0's outermost ring steps θ̃ by π·(1 − 2^(−1/m)) and φ̃ by 2π/n.
    let s = &r.settings;
    let ring_step = level_outer_theta_rad(0) * (1.0 - (-1.0 / f64::from(s.rings_per_level)).exp2());
    let phi_step = TAU / f64::from(s.phi_steps);
    let sag_m = (radius_m + h_max) * map_transform::one_minus_cos(0.5 * ring_step.hypot(phi_step));
    let ground_radius_m = radius_m + h_min - sag_m;
    let sky_radius_m = radius_m + h_max;
    let eye = camera.eye_view_m();
    let pixel_rad = camera.fov_y_rad() / f64::from(RENDER_H);
    let mut out = Vec::with_capacity((RENDER_W * RENDER_H) as usize);
    for y in 0..RENDER_H {
        for x in 0..RENDER_W {
            let ray = pixel_ray_view(camera, x, y, RENDER_W, RENDER_H);
            let (miss_m, t) = closest_approach(eye, ray);
            let margin_m = 2.0 * pixel_rad * t.abs().max(1.0);
            out.push(if t > 0.0 && miss_m < ground_radius_m - margin_m {
                Certain::Ground
            } else if eye.length() > sky_radius_m && (t <= 0.0 || miss_m > sky_radius_m + margin_m)
            {
                Certain::Sky
            } else {
                Certain::Either
            });
        }
    }
    out
}

/// Sky pixels below the first terrain pixel of their column (a crack: a height field seen from
/// above has none).
fn holes(frame: &FloatFrame) -> usize {
    (0..RENDER_W)
        .map(
            |x| match (0..RENDER_H).find(|&y| frame.depth_at(x, y) > 0.0) {
                Some(first) => (first..RENDER_H)
                    .filter(|&y| frame.depth_at(x, y) == 0.0)
                    .count(),
                None => 0,
            },
        )
        .sum()
}

/// Renders of random cameras (the analytic planet, 64×36) have a finite depth in [0, 1] and a
/// finite colour at every pixel; every pixel whose ray must reach the terrain shows terrain and
/// every pixel whose ray must miss it shows sky. NaN anywhere in the vertex or fragment path
/// would show up as a non-finite colour or a missing surface.
#[test]
fn renders_of_random_cameras_are_finite_and_cover_what_geometry_predicts() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let r = RefCell::new(
        TerrainRenderer::new(
            &ctx.device,
            ClipmapSettings::default(),
            Terrain::analytic_earth(),
            FLOAT_COLOR,
        )
        .unwrap(),
    );
    let counts = Cell::new((0u64, 0u64, 0u64));
    let started = std::time::Instant::now();
    let cases = check("GPU renders (random cameras)", 12, viewer(), |v| {
        let mut r = r.borrow_mut();
        let ground = r.terrain_height_m(v.camera.lat_deg, v.camera.lon_deg);
        let camera = Camera {
            altitude_m: ground + v.above_m(),
            ..v.camera
        };
        let frame = render_float(ctx, &mut r, &camera);
        prop_assert!(
            frame
                .depth
                .iter()
                .all(|d| d.is_finite() && (0.0..=1.0).contains(d)),
            "{camera:?}: depth outside [0, 1]"
        );
        prop_assert!(
            frame.rgba.iter().all(|c| c.iter().all(|v| v.is_finite())),
            "{camera:?}: non-finite colour"
        );
        let classes = classify_pixels(&r, &camera);
        let (mut ground_px, mut sky_px, mut terrain_px) = counts.get();
        for (i, class) in classes.iter().enumerate() {
            let terrain = frame.depth[i] > 0.0;
            terrain_px += u64::from(terrain);
            match class {
                Certain::Ground => {
                    prop_assert!(terrain, "{camera:?}: pixel {i} must be terrain");
                    ground_px += 1;
                }
                Certain::Sky => {
                    prop_assert!(!terrain, "{camera:?}: pixel {i} must be sky");
                    sky_px += 1;
                }
                Certain::Either => {}
            }
        }
        counts.set((ground_px, sky_px, terrain_px));
        Ok(())
    });
    let (ground_px, sky_px, terrain_px) = counts.get();
    eprintln!(
        "GPU renders (random cameras): {cases} frames in {:.1} s; {terrain_px} terrain pixels; \
         {ground_px} certain-ground and {sky_px} certain-sky pixels all as predicted",
        started.elapsed().as_secs_f64()
    );
}

/// Looking down (pitch −90° … −5°, no roll) from anywhere up to 100 km, where the bottom row of
/// the image must be ground: no column has sky below its first terrain pixel (a crack or a
/// NaN vertex would leave one).
/// Even levels at full density, odd ones at the coarsest, all half-way through a morph.
fn alternating_densities(level: u32, _: Density, max_k: u32) -> Density {
    let k = if level.is_multiple_of(2) { 0 } else { max_k };
    Density {
        k,
        morph: if k < max_k { 0.5 } else { 0.0 },
    }
}

#[test]
fn renders_looking_down_have_no_sky_below_terrain() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let r = RefCell::new(
        TerrainRenderer::new(
            &ctx.device,
            ClipmapSettings::default(),
            Terrain::analytic_earth(),
            FLOAT_COLOR,
        )
        .unwrap(),
    );
    let looking_down = (
        viewer(),
        prop_oneof![1 => Just(-90.0), 3 => -90.0..=-5.0f64],
        prop_oneof![3 => (-3.0..=5.0f64).prop_map(|e| 10f64.powf(e)), 1 => Just(1e-3)],
    )
        .prop_map(|(mut v, pitch, above)| {
            v.camera.pitch_deg = pitch;
            v.camera.roll_deg = 0.0;
            v.camera.altitude_m = v.ground_m + above;
            v
        });
    let counts = Cell::new((0u64, 0u64));
    let started = std::time::Instant::now();
    let cases = check("GPU renders (looking down)", 12, looking_down, |v| {
        let mut r = r.borrow_mut();
        let ground = r.terrain_height_m(v.camera.lat_deg, v.camera.lon_deg);
        let camera = Camera {
            altitude_m: ground + v.above_m(),
            ..v.camera
        };
        // Every other frame with mixed ring densities: neighbouring levels three densities
        // apart, half-way through a morph, so every seam is a stitched one.
        let (frames, _) = counts.get();
        r.switches.density_map = (frames % 2 == 1).then_some(DensityMap(alternating_densities));
        let frame = render_float(ctx, &mut r, &camera);
        prop_assert!(frame.depth.iter().all(|d| d.is_finite()));
        prop_assert!(frame.rgba.iter().all(|c| c.iter().all(|v| v.is_finite())));
        let classes = classify_pixels(&r, &camera);
        let bottom = (RENDER_H - 1) * RENDER_W;
        let bottom_is_ground =
            (0..RENDER_W).all(|x| classes[(bottom + x) as usize] == Certain::Ground);
        prop_assert!(
            bottom_is_ground,
            "{camera:?}: the bottom row must be ground"
        );
        let n = holes(&frame);
        prop_assert_eq!(n, 0, "{:?}: {} sky pixels below terrain", camera, n);
        let (frames, drawn) = counts.get();
        counts.set((frames + 1, drawn + frame.info.draw.triangles));
        Ok(())
    });
    let (frames, triangles) = counts.get();
    eprintln!(
        "GPU renders (looking down): {cases} frames in {:.1} s, no sky below terrain; \
         {} triangles per frame on average",
        started.elapsed().as_secs_f64(),
        triangles / frames.max(1)
    );
}
