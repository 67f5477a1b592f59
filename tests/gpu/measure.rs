//! The reference ray caster against closed forms and a brute-force march, and the per-pixel
//! error metric (error-bounded-projective-grid.md eq. 2–3) on real renders.

use crate::common;

use common::render;

use glam::DVec3;
use globe::clipmap::ClipmapSettings;
use globe::geo::EARTH_RADIUS_M;
use globe::geo::camera::Camera;
use globe::measure::metric::{pixels_per_radian, surface_point_view_m};
use globe::measure::{
    ConstantHeight, DEFAULT_THRESHOLD_PX, ErrorStats, HeightField, PixelSet, RayCastOptions,
    RayCaster, RayHit, ReferencePixel, measure_frame, rho_image, write_heat_map_png,
};
use globe::render::formats::COLOR_FORMAT;
use globe::render::{GpuContext, TerrainRenderer};
use globe::scenes::Scene;
use globe::terrain::Terrain;

fn earth() -> Terrain {
    Terrain::embedded_earth().expect("embedded Earth")
}

fn scene_camera(terrain: &Terrain, name: &str) -> Camera {
    Scene::by_name(name)
        .unwrap()
        .camera(|lat, lon| terrain.height_at_lat_lon_m(lat, lon))
}

/// The first hit of o + t·d on the sphere of radius ρ, solved the textbook way (no shared code
/// with the ray caster).
fn closed_form_hit(o: DVec3, d: DVec3, radius: f64) -> Option<f64> {
    let b = o.dot(d);
    let c = o.length_squared() - radius * radius;
    let disc = b * b - c;
    if disc < 0.0 {
        return None;
    }
    let t = -b - disc.sqrt();
    (t >= 0.0).then_some(t)
}

/// Distance tolerance for a ray caster result at distance `t`: its bisection brackets the
/// crossing to `refine_px` pixels, at most 1/focal radians each, plus 0.1 µm for the f64
/// resolution of positions on Earth (~1 nm) over a clearance that changes slowly along a
/// grazing ray.
fn refine_tolerance_m(options: &RayCastOptions, t: f64, focal_px: f64) -> f64 {
    options.refine_px * t / focal_px + 1e-7
}

/// With zero (and constant) heights the first hit is the ray–sphere intersection: from orbit
/// over the whole disk, limb included, and from an aircraft at grazing angles.
#[test]
fn constant_sphere_matches_the_closed_form() {
    let (w, h) = (320, 180);
    for height_m in [0.0, 500.0] {
        let sphere = ConstantHeight {
            radius_m: EARTH_RADIUS_M,
            height_m,
        };
        let radius = EARTH_RADIUS_M + height_m;
        for name in ["space", "aircraft"] {
            let camera = scene_camera(&Terrain::analytic_earth(), name);
            let camera = Camera {
                altitude_m: camera.altitude_m.max(height_m + 1000.0),
                ..camera
            };
            let focal = pixels_per_radian(h, camera.fov_y_rad());
            for options in [
                RayCastOptions::default(),
                RayCastOptions {
                    refine_px: 1e-9,
                    ..Default::default()
                },
            ] {
                let caster = RayCaster::new(&sphere, &camera, w, h).with_options(options);
                let (mut hits, mut sky, mut worst_m, mut worst_rel) = (0, 0, 0.0f64, 0.0f64);
                for y in (0..h).step_by(3) {
                    for x in (0..w).step_by(3) {
                        let d = caster.pixel_ray_view(x, y);
                        let expected = closed_form_hit(caster.eye_view_m(), d, radius);
                        match (caster.cast_pixel(x, y), expected) {
                            (RayHit::Sky, None) => sky += 1,
                            (RayHit::Terrain { distance_m, .. }, Some(t)) => {
                                let tol = refine_tolerance_m(&options, t, focal);
                                assert!(
                                    (distance_m - t).abs() <= tol,
                                    "{name}, h {height_m}: pixel ({x},{y}) at {distance_m} m, closed form {t} m"
                                );
                                worst_m = worst_m.max((distance_m - t).abs());
                                worst_rel = worst_rel.max((distance_m - t).abs() / tol);
                                hits += 1;
                            }
                            (got, expected) => panic!(
                                "{name}, h {height_m}: pixel ({x},{y}): {got:?}, closed form {expected:?}"
                            ),
                        }
                    }
                }
                eprintln!(
                    "{name}, sphere h {height_m} m, refine {} px: {hits} hits, {sky} sky, max |Δt| {worst_m:.3e} m ({worst_rel:.3} of tolerance)",
                    options.refine_px
                );
                assert!(hits > 100 && sky > 100);
            }
        }
    }
}

/// Rays grazing the sphere within a few millimetres: the caster agrees with the closed form
/// on which rays hit.
#[test]
fn constant_sphere_grazing_rays() {
    let sphere = ConstantHeight {
        radius_m: EARTH_RADIUS_M,
        height_m: 0.0,
    };
    let camera = Camera {
        lat_deg: 10.0,
        lon_deg: 20.0,
        altitude_m: 10_000.0,
        heading_deg: 30.0,
        pitch_deg: 0.0,
        roll_deg: 0.0,
        fov_y_deg: 60.0,
    };
    let caster = RayCaster::new(&sphere, &camera, 1920, 1080);
    let e = caster.eye_view_m();
    let radius = EARTH_RADIUS_M;
    // The tangent ray's depression below the horizontal: cos γ = R/(R + H).
    let gamma = (radius / e.z).acos();
    let horizontal = DVec3::new(0.0, 1.0, 0.0);
    for miss_m in [-1.0, -1e-2, 1e-2, 1.0] {
        // Tilted so that the line passes `miss_m` from the sphere (positive: misses).
        let g = gamma - miss_m / (e.z * gamma.sin());
        let d = horizontal * g.cos() - DVec3::Z * g.sin();
        let expected = closed_form_hit(e, d, radius);
        let got = caster.cast_ray(d);
        eprintln!("grazing, {miss_m} m clear: {got:?}, closed form {expected:?}");
        match (got, expected) {
            (RayHit::Sky, None) => assert!(miss_m > 0.0),
            (RayHit::Terrain { distance_m, .. }, Some(t)) => {
                assert!(miss_m < 0.0);
                // Grazing: an along-ray error of s changes the height by ~s·sin(angle).
                assert!((distance_m - t).abs() < 1e-4 * t, "{distance_m} vs {t}");
            }
            _ => panic!("grazing ray {miss_m} m: {got:?} vs {expected:?}"),
        }
    }
}

/// The brute-force march's step at distance t: 10⁻⁴·t, between 1 µm and 1 m.
fn brute_step_m(t: f64) -> f64 {
    (1e-4 * t).clamp(1e-6, 1.0)
}

/// Where a brute-force march from `start_m` first finds the ray under the terrain: the
/// crossing t, bisected to 1 nm, and where the ray comes out again within
/// `out_within`·t (None: not that soon). None: sky (the ray leaves the terrain's shell first).
fn brute_force_crossing<H: HeightField>(
    field: &H,
    camera: &Camera,
    d: DVec3,
    start_m: f64,
    out_within: f64,
) -> Option<(f64, Option<f64>)> {
    let radius = field.radius_m();
    let world_from_view = camera.view_frame().world_from_view;
    let e = camera.eye_view_at_radius_m(radius);
    let clearance = |t: f64| {
        let p = e + t * d;
        p.length() - radius - field.height_m(world_from_view * p.normalize())
    };
    let top = radius + field.height_range_m().1 + 1.0;
    if clearance(start_m) <= 0.0 {
        return Some((start_m, None));
    }
    let mut a = start_m;
    loop {
        let b = a + brute_step_m(a);
        let p = e + b * d;
        if p.length() > top && p.dot(d) > 0.0 {
            return None;
        }
        if clearance(b) <= 0.0 {
            let (mut lo, mut hi) = (a, b);
            while hi - lo > 1e-9 {
                let m = 0.5 * (lo + hi);
                if clearance(m) > 0.0 { lo = m } else { hi = m }
            }
            let t_in = 0.5 * (lo + hi);
            let mut t = b;
            while t < t_in * (1.0 + out_within) {
                t += brute_step_m(t);
                if clearance(t) > 0.0 {
                    return Some((t_in, Some(t)));
                }
            }
            return Some((t_in, None));
        }
        a = b;
    }
}

/// The deepest the ray runs under the terrain between `a` and `b`, metres.
fn deepest_under_m<H: HeightField>(field: &H, camera: &Camera, d: DVec3, a: f64, b: f64) -> f64 {
    let radius = field.radius_m();
    let world_from_view = camera.view_frame().world_from_view;
    let e = camera.eye_view_at_radius_m(radius);
    (0..=1000)
        .map(|i| {
            let p = e + (a + (b - a) * i as f64 / 1000.0) * d;
            field.height_m(world_from_view * p.normalize()) - (p.length() - radius)
        })
        .fold(0.0, f64::max)
}

/// The rays of `camera` to test: the image centre and bottom, and around the horizon of a
/// few columns (the last terrain pixel from the top, the sky pixel above, two below).
fn test_pixels<H: HeightField>(caster: &RayCaster<'_, H>, w: u32, h: u32) -> Vec<(u32, u32)> {
    let mut pixels = vec![(w / 2, h / 2), (w / 2, h - 1), (3, h - 1)];
    for x in [0, w / 3, w - 1] {
        let column: Vec<(u32, u32)> = (0..h).map(|y| (x, y)).collect();
        let hits = caster.cast_pixels(&column);
        if let Some(first) = hits.iter().position(|hit| *hit != RayHit::Sky) {
            let y = first as u32;
            for yy in [y.saturating_sub(1), y, y + 1, y + 2] {
                if yy < h {
                    pixels.push((x, yy));
                }
            }
        }
    }
    pixels.sort();
    pixels.dedup();
    pixels
}

/// The caster against the brute-force march on a few rays of `camera`. The hits agree within
/// the caster's bisection tolerance, except where the march finds a sliver the caster may
/// skip by its guarantee (reference.rs): under the terrain for less than one minimum step
/// (`min_step_px`·t/λ), and then at most (1 + L)·`min_step_px`/2 px deep; after a sliver the
/// next crossing must agree.
fn check_against_brute_force<H: HeightField>(what: &str, field: &H, camera: &Camera) {
    check_against_brute_force_of(what, field, field, camera);
}

/// [`check_against_brute_force`] with the caster on `cast` and the brute force on `field`
/// (the same terrain function, as seen from the camera).
fn check_against_brute_force_of<C: HeightField, H: HeightField>(
    what: &str,
    cast: &C,
    field: &H,
    camera: &Camera,
) {
    let (w, h) = (320, 180);
    let caster = RayCaster::new(cast, camera, w, h);
    let focal = pixels_per_radian(h, camera.fov_y_rad());
    let options = RayCastOptions::default();
    let camera_from_view = camera.view_from_camera().transpose();
    let mut pixels = test_pixels(&caster, w, h);
    pixels.truncate(16);
    let (mut hits, mut slivers, mut worst) = (0, 0, 0.0f64);
    for (x, y) in pixels {
        let d = caster.pixel_ray_view(x, y);
        // Pixels per radian along this ray, as the caster uses it: focal / cos²(off axis).
        let cos_off_axis = -(camera_from_view * d).z;
        let lambda = focal / (cos_off_axis * cos_off_axis);
        let min_step = |t: f64| options.min_step_px * t / lambda;
        let got = caster.cast_ray(d);
        let mut from = 0.0;
        let expected = loop {
            match brute_force_crossing(field, camera, d, from, options.min_step_px / lambda) {
                Some((t_in, Some(t_out)))
                    if got.distance_m().is_some_and(|g| g > t_in + 1e-3 * t_in)
                        && t_out - t_in < min_step(t_in) =>
                {
                    let u = camera.view_frame().world_from_view
                        * (caster.eye_view_m() + t_in * d).normalize();
                    let slope = field
                        .local_bounds(u, (t_out - t_in) / field.radius_m())
                        .slope_max;
                    let deepest_px = deepest_under_m(field, camera, d, t_in, t_out) * lambda / t_in;
                    let bound_px = (1.0 + slope) * options.min_step_px / 2.0;
                    eprintln!(
                        "{what}: pixel ({x},{y}): sliver skipped at {t_in:.3} m: {:.1} m long (min step {:.1} m), {deepest_px:.2e} px deep (bound {bound_px:.2} px)",
                        t_out - t_in,
                        min_step(t_in)
                    );
                    assert!(deepest_px <= bound_px);
                    slivers += 1;
                    from = t_out;
                }
                crossing => break crossing.map(|(t_in, _)| t_in),
            }
        };
        match (got, expected) {
            (RayHit::Sky, None) => eprintln!("{what}: pixel ({x},{y}) sky"),
            (
                RayHit::Terrain {
                    distance_m,
                    point_view_m,
                },
                Some(t),
            ) => {
                let tol = refine_tolerance_m(&options, t, focal);
                let u = camera.view_frame().world_from_view * point_view_m.normalize();
                let off_surface = point_view_m.length() - field.radius_m() - field.height_m(u);
                eprintln!(
                    "{what}: pixel ({x},{y}) at {distance_m:.6} m, brute force {t:.6} m, Δ {:.2e} m (tolerance {tol:.1e}), {off_surface:.1e} m off the surface",
                    distance_m - t
                );
                assert!(
                    (distance_m - t).abs() <= tol,
                    "{what}: pixel ({x},{y}): {distance_m} m vs brute force {t} m"
                );
                worst = worst.max((distance_m - t).abs() / tol);
                hits += 1;
            }
            _ => panic!("{what}: pixel ({x},{y}): {got:?}, brute force {expected:?}"),
        }
    }
    eprintln!("{what}: {hits} hits, {slivers} slivers skipped, worst |Δt|/tolerance {worst:.3}");
    assert!(hits > 0);
}

#[test]
fn ray_caster_matches_brute_force_analytic() {
    let terrain = Terrain::analytic_earth();
    check_against_brute_force(
        "analytic aircraft",
        &terrain,
        &scene_camera(&terrain, "aircraft"),
    );
}

#[test]
fn ray_caster_matches_brute_force_earth() {
    let terrain = earth();
    check_against_brute_force(
        "earth aircraft",
        &terrain,
        &scene_camera(&terrain, "aircraft"),
    );
    check_against_brute_force(
        "earth everest",
        &terrain,
        &scene_camera(&terrain, "everest"),
    );
}

/// Stiff rays: straight down at both poles, and from a camera 1 mm above the terrain (looking
/// just below the horizontal, so some rays run far across the ground).
#[test]
fn ray_caster_matches_brute_force_stiff_rays() {
    for (what, terrain) in [("analytic", Terrain::analytic_earth()), ("earth", earth())] {
        for lat in [90.0, -90.0] {
            let camera = Camera {
                lat_deg: lat,
                lon_deg: 0.0,
                altitude_m: terrain.height_at_lat_lon_m(lat, 0.0) + 100.0,
                heading_deg: 0.0,
                pitch_deg: -90.0,
                roll_deg: 0.0,
                fov_y_deg: 60.0,
            };
            let caster = RayCaster::new(&terrain, &camera, 320, 180);
            let down = -DVec3::Z;
            let got = caster.cast_ray(down).distance_m().expect("ground below");
            let (t, _) = brute_force_crossing(&terrain, &camera, down, 0.0, 0.0).unwrap();
            eprintln!("{what}: straight down at lat {lat}: {got:.9} m, brute force {t:.9} m");
            // The bisection's bracket at the image centre: 10⁻⁴ px of 100 m.
            let tol = refine_tolerance_m(&RayCastOptions::default(), 100.0, 156.0);
            assert!((got - t).abs() < tol, "{got} vs {t}");
            // The pole is 100 m below (the height there is one value).
            assert!((got - 100.0).abs() < tol, "{got}");
        }
        for pitch in [-5.0, -30.0] {
            let camera = Camera {
                lat_deg: 45.65,
                lon_deg: 10.65,
                altitude_m: terrain.height_at_lat_lon_m(45.65, 10.65) + 1e-3,
                heading_deg: 0.0,
                pitch_deg: pitch,
                roll_deg: 0.0,
                fov_y_deg: 60.0,
            };
            check_against_brute_force(&format!("{what} 1 mm up, pitch {pitch}"), &terrain, &camera);
        }
    }
}

/// A terrain with detail as the reference sees it from one viewer ([`HeightField::height_seen_m`]
/// as its plain height), through the default trait methods only: the brute force's field, and
/// with them the march without split steps.
struct SeenFrom<'a> {
    terrain: &'a Terrain,
    viewer_u: DVec3,
}

impl HeightField for SeenFrom<'_> {
    fn radius_m(&self) -> f64 {
        self.terrain.radius_m()
    }
    fn height_m(&self, u: DVec3) -> f64 {
        self.terrain.height_seen_m(u, self.viewer_u)
    }
    fn height_range_m(&self) -> (f64, f64) {
        HeightField::height_range_m(self.terrain)
    }
    fn local_bounds(&self, u: DVec3, angle_rad: f64) -> globe::measure::LocalBounds {
        self.terrain.local_bounds_seen(u, angle_rad, self.viewer_u)
    }
    fn finest_bound_angle_rad(&self) -> f64 {
        self.terrain.finest_bound_angle_rad()
    }
}

fn earth_with_detail() -> Terrain {
    earth().with_detail(Some(globe::procedural::DetailParams::default()))
}

/// The march's split steps (coarse octaves evaluated, fine ones bounded) on rays that graze
/// the detail: the `ground` scene (2 m up) and 1 mm above Lake Garda's shore, horizon rays
/// included, against the brute-force march over the same terrain as seen from the camera.
#[test]
fn ray_caster_matches_brute_force_with_detail() {
    let terrain = earth_with_detail();
    let ground = scene_camera(&terrain, "ground");
    let low = Camera {
        altitude_m: terrain.height_at_lat_lon_m(ground.lat_deg, ground.lon_deg) + 1e-3,
        ..ground
    };
    for (what, camera) in [("detail ground", ground), ("detail 1 mm up", low)] {
        let seen = SeenFrom {
            terrain: &terrain,
            viewer_u: camera.view_frame().world_from_view * DVec3::Z,
        };
        check_against_brute_force_of(what, &terrain, &seen, &camera);
    }
}

/// What the split steps buy: the `ground` scene over the detail (2 m up, its rays grazing the
/// relief to the horizon) in march steps per pixel (not wall time), with and without them.
/// Every pixel agrees (sky against terrain, and hits within twice the refinement tolerance).
#[test]
fn split_steps_cut_the_march_over_detail() {
    let terrain = earth_with_detail();
    let camera = scene_camera(&terrain, "ground");
    let (w, h) = (96, 54);
    let seen = SeenFrom {
        terrain: &terrain,
        viewer_u: camera.view_frame().world_from_view * DVec3::Z,
    };
    let split = RayCaster::new(&terrain, &camera, w, h).cast(&PixelSet::All);
    let whole = RayCaster::new(&seen, &camera, w, h).cast(&PixelSet::All);
    let focal = pixels_per_radian(h, camera.fov_y_rad());
    let options = RayCastOptions::default();
    for y in 0..h {
        for x in 0..w {
            match (split.pixel(x, y), whole.pixel(x, y)) {
                (ReferencePixel::Sky, ReferencePixel::Sky) => {}
                (
                    ReferencePixel::Terrain { distance_m: a, .. },
                    ReferencePixel::Terrain { distance_m: b, .. },
                ) => {
                    let tol = 2.0 * refine_tolerance_m(&options, a.max(b), focal);
                    assert!((a - b).abs() <= tol, "({x},{y}): {a} m vs {b} m");
                }
                (a, b) => panic!("({x},{y}): {a:?} with split steps, {b:?} without"),
            }
        }
    }
    let per_pixel =
        |image: &globe::measure::ReferenceImage| image.steps as f64 / image.cast_count() as f64;
    let (with, without) = (per_pixel(&split), per_pixel(&whole));
    eprintln!("ground with detail, march steps per pixel: split {with:.1}, whole {without:.1}");
    assert!(split.terrain_count() > 0);
    assert!(with < 0.8 * without, "{with:.1} vs {without:.1}");
}

/// A subset cast gives the same pixels as casting them one by one, and nothing else.
#[test]
fn subsets_cast_the_same_pixels() {
    let terrain = Terrain::analytic_earth();
    let camera = scene_camera(&terrain, "aircraft");
    let (w, h) = (64, 36);
    let caster = RayCaster::new(&terrain, &camera, w, h);
    let every = caster.cast(&PixelSet::Every(5));
    assert_eq!(every.cast_count(), 13 * 8);
    let list = caster.cast(&PixelSet::List(vec![(7, 30), (63, 0)]));
    assert_eq!(list.cast_count(), 2);
    for (x, y) in [(0, 0), (5, 30), (60, 35), (7, 30), (63, 0)] {
        let single = match caster.cast_pixel(x, y) {
            RayHit::Sky => ReferencePixel::Sky,
            RayHit::Terrain { distance_m, .. } => ReferencePixel::Terrain { distance_m },
        };
        let from_every = every.pixel(x, y);
        let from_list = list.pixel(x, y);
        if x % 5 == 0 && y % 5 == 0 {
            assert_eq!(from_every, single);
        } else {
            assert_eq!(from_every, ReferencePixel::NotCast);
        }
        if (x, y) == (7, 30) || (x, y) == (63, 0) {
            assert_eq!(from_list, single);
        }
    }
}

fn renderer(ctx: &GpuContext, terrain: Terrain) -> TerrainRenderer {
    TerrainRenderer::new(
        &ctx.device,
        ClipmapSettings::default(),
        terrain,
        COLOR_FORMAT,
    )
    .unwrap()
}

/// The metric on real renders: finite statistics, max ρ within a few pixels, and coverage
/// mismatches a tiny fraction of the frame. Writes the aircraft heat maps to the temporary
/// folder.
#[test]
fn metric_on_real_renders() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let (w, h) = (320, 180);
    for (what, terrain) in [("analytic", Terrain::analytic_earth()), ("earth", earth())] {
        let mut r = renderer(ctx, terrain);
        for name in ["aircraft", "ground"] {
            let camera = scene_camera(&r.terrain, name);
            let frame = render(ctx, &mut r, &camera, w, h);
            let started = std::time::Instant::now();
            let reference = RayCaster::new(&r.terrain, &camera, w, h).cast(&PixelSet::All);
            let cast_s = started.elapsed().as_secs_f64();
            let stats = measure_frame(
                &frame,
                &camera,
                &r.terrain,
                Some(&reference),
                DEFAULT_THRESHOLD_PX,
            )
            .unwrap();
            let coverage = stats.coverage.unwrap();
            eprintln!(
                "{what} {name}: {} px measured, ρ mean {:.4} p99 {:.4} max {:.4} px, {:.3} % above {} px; coverage: {} terrain where the reference sees sky, {} the reverse, of {} (reference {cast_s:.2} s)",
                stats.pixels_measured,
                stats.mean_px,
                stats.p99_px,
                stats.max_px,
                100.0 * stats.error_pixel_share,
                stats.threshold_px,
                coverage.terrain_where_reference_sky,
                coverage.sky_where_reference_terrain,
                coverage.compared
            );
            assert_eq!(coverage.compared, (w * h) as usize);
            assert!(stats.pixels_measured > 1000);
            assert!(stats.mean_px.is_finite() && stats.p99_px.is_finite());
            assert!(
                stats.max_px.is_finite() && stats.max_px < 4.0,
                "max ρ {}",
                stats.max_px
            );
            assert!(
                coverage.mismatched() * 200 <= coverage.compared,
                "{what} {name}: {} coverage mismatches",
                coverage.mismatched()
            );
            if name == "aircraft" {
                let dir = tempfile::tempdir().unwrap();
                let path = dir.path().join(format!("globe-measure-{what}-{name}.png"));
                write_heat_map_png(&path, w, h, &rho_image(&frame, &camera, &r.terrain)).unwrap();
                let png = image::open(&path).unwrap();
                assert_eq!((png.width(), png.height()), (w, h));
                eprintln!("heat map: {}", path.display());
            }
        }
    }
}

/// The metric can fail: moving every surface point 10 % further along its ray (depth × 0.9)
/// raises ρ far above the unperturbed frame's, and shifting the image down by three rows
/// shows up as sky where the reference sees terrain.
#[test]
fn metric_detects_perturbed_depth() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let (w, h) = (320, 180);
    let mut r = renderer(ctx, earth());
    let camera = scene_camera(&r.terrain, "aircraft");
    let mut frame = render(ctx, &mut r, &camera, w, h);
    let reference = RayCaster::new(&r.terrain, &camera, w, h).cast(&PixelSet::Every(2));
    let measure = |frame: &_| {
        measure_frame(
            frame,
            &camera,
            &r.terrain,
            Some(&reference),
            DEFAULT_THRESHOLD_PX,
        )
        .unwrap()
    };
    let before = measure(&frame);
    let original_depth = frame.depth.clone();
    for d in &mut frame.depth {
        *d *= 0.9;
    }
    let scaled = measure(&frame);
    frame.depth = vec![0.0; (3 * w) as usize];
    frame
        .depth
        .extend_from_slice(&original_depth[..((h - 3) * w) as usize]);
    let shifted = measure(&frame);
    let show = |what: &str, s: &ErrorStats| {
        let c = s.coverage.unwrap();
        eprintln!(
            "{what}: ρ mean {:.3} p99 {:.3} max {:.3} px, {:.2} % above 1 px; mismatches {} + {} of {}",
            s.mean_px,
            s.p99_px,
            s.max_px,
            100.0 * s.error_pixel_share,
            c.terrain_where_reference_sky,
            c.sky_where_reference_terrain,
            c.compared
        );
    };
    show("as rendered", &before);
    show("depth × 0.9", &scaled);
    show("shifted 3 rows down", &shifted);
    assert!(scaled.mean_px > 10.0 * before.mean_px.max(0.01));
    assert!(scaled.max_px > 4.0 && scaled.error_pixel_share > 0.5);
    let (c0, c1) = (before.coverage.unwrap(), shifted.coverage.unwrap());
    // Three rows of each even column turn to sky below the horizon; one or two are even rows.
    assert!(c1.sky_where_reference_terrain >= c0.sky_where_reference_terrain + (w / 2) as usize);
    assert!(shifted.mean_px > 2.0 * before.mean_px);
}

/// The library's depth → surface point is the tests' (tests/common).
#[test]
fn surface_points_agree_with_the_test_helper() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let mut r = renderer(ctx, Terrain::analytic_earth());
    let camera = scene_camera(&r.terrain, "aircraft");
    let frame = render(ctx, &mut r, &camera, 96, 54);
    let radius = r.terrain.radius_m();
    for y in 0..54 {
        for x in 0..96 {
            assert_eq!(
                surface_point_view_m(&frame, &camera, radius, x, y),
                common::surface_point_view(&camera, &frame, x, y, radius)
            );
        }
    }
}

/// Cost of the reference at 1920×1080 for `aircraft` over the embedded Earth (the target) and
/// the analytic planet. Ignored (the suite runs in debug); run with
/// `cargo test --release --test gpu -- --ignored --nocapture measure::reference_timing`.
#[test]
#[ignore]
fn reference_timing() {
    for (what, terrain) in [
        ("embedded Earth", earth()),
        ("analytic planet", Terrain::analytic_earth()),
    ] {
        let camera = scene_camera(&terrain, "aircraft");
        let caster = RayCaster::new(&terrain, &camera, 1920, 1080);
        let started = std::time::Instant::now();
        let reference = caster.cast(&PixelSet::All);
        let s = started.elapsed().as_secs_f64();
        eprintln!(
            "aircraft over the {what}, 1920×1080: {s:.2} s on {} threads, {} terrain pixels of {}",
            std::thread::available_parallelism().map_or(1, |n| n.get()),
            reference.terrain_count(),
            reference.cast_count()
        );
    }
}

/// An ETOPO5-shaped raster, coarse: 1° pixels with a row of centres on each pole holding one
/// value all round (ETOPO5's −4290 m and 2810 m), a checkerboard of ±500 m around it
/// elsewhere, so that next to the pole neighbouring columns differ by the whole local range.
struct PoleRows;

const POLE_ROWS_DEG: f64 = 1.0;

impl globe::dem::RasterSource for PoleRows {
    fn grid(&self) -> globe::dem::GeoGrid {
        globe::dem::GeoGrid {
            cols: (360.0 / POLE_ROWS_DEG) as usize,
            rows: (180.0 / POLE_ROWS_DEG) as usize + 1,
            lon0_deg: 0.0,
            lat0_deg: 90.0,
            dlon_deg: POLE_ROWS_DEG,
            dlat_deg: POLE_ROWS_DEG,
        }
    }

    fn read_row(&self, row: usize, out: &mut [f32]) -> Result<(), globe::dem::DemError> {
        let rows = self.grid().rows;
        let base = if 2 * row < rows { -4290.0 } else { 2810.0 };
        for (col, v) in out.iter_mut().enumerate() {
            *v = if row == 0 || row == rows - 1 {
                base
            } else if (row + col).is_multiple_of(2) {
                base + 500.0
            } else {
                base - 500.0
            };
        }
        Ok(())
    }

    fn describe(&self) -> String {
        "pole rows (ETOPO5-shaped)".into()
    }
}

/// [`PoleRows`] as the terrain (no detail, no water: the bare bilinear field), built into a
/// file of `test`'s own (tests run in parallel).
fn pole_rows_terrain(test: &str) -> Terrain {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("measure-tests");
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join(format!("pole-rows-{test}.globepyr"));
    globe::dem::pyramid::PyramidBuilder::new()
        .tile_size(64)
        .build(&PoleRows, &path)
        .expect("build the pole-rows pyramid");
    let dem = globe::terrain::DemTerrain::open(&path, EARTH_RADIUS_M).expect("open");
    Terrain::dem_terrain(dem)
}

/// The slope bound across a row of pixel centres on a pole is true and tight: at points up to
/// two pixels from either pole, the terrain's change over a 1 m step in eight directions never
/// exceeds the bound of a cap holding both ends, and comes within a factor 2 of it (the
/// checkerboard next to the pole is as steep as the bound allows). A bound taken at the wrong
/// latitude, or none, fails one or the other.
#[test]
fn pole_row_slope_bound_holds_and_is_tight() {
    use globe::geo::sphere;
    let terrain = pole_rows_terrain("slope");
    let dem = terrain.dem().expect("a DEM");
    let radius = terrain.radius_m();
    let step_m = 1.0;
    let mut worst = 0.0f64;
    for pole in [90.0f64, -90.0] {
        for i in 0..60 {
            // Colatitudes from 1e-4 to 2 pixels, longitudes all round (off the columns).
            let colat = 2.0 * POLE_ROWS_DEG * (i as f64 + 0.5) / 60.0 + 1e-4;
            let lat = pole - colat * pole.signum();
            let lon = 7.3 * i as f64 + 0.37;
            let (phi, theta) = sphere::phi_theta_from_lat_lon_deg(lat, lon);
            let u = sphere::unit_vector(phi, theta);
            let cap = 2.0 * step_m / radius;
            let bound = terrain.local_bounds(u, cap).slope_max;
            assert!(bound.is_finite(), "no slope bound at {lat}°, {lon}°");
            // Tangent directions at u.
            let east = DVec3::Z.cross(u).try_normalize().unwrap_or(DVec3::X);
            let north = u.cross(east);
            for k in 0..8 {
                let a = k as f64 * std::f64::consts::FRAC_PI_4;
                let dir = east * a.cos() + north * a.sin();
                let v = (u + dir * (step_m / radius)).normalize();
                // atan2 of cross and dot: `angle_between`'s acos loses 0.4 % at 1 m.
                let arc_m = u.cross(v).length().atan2(u.dot(v)) * radius;
                let slope = (dem.height_m(v) - dem.height_m(u)).abs() / arc_m;
                assert!(
                    slope <= bound,
                    "{lat}°, {lon}°: slope {slope} over {arc_m} m exceeds the bound {bound}"
                );
                worst = worst.max(slope / bound);
            }
        }
    }
    eprintln!("pole rows: steepest finite difference {worst:.3} of the bound");
    assert!(worst > 0.5, "the bound is loose: {worst:.3}");
}

/// The reference at the pole of the ETOPO5-shaped field agrees with the brute-force march, on
/// rays from 100 m above each pole (as `north-pole`) and straight down.
#[test]
fn ray_caster_matches_brute_force_on_a_pole_row() {
    let terrain = pole_rows_terrain("brute-force");
    for lat in [90.0, -90.0] {
        let camera = Camera {
            lat_deg: lat,
            lon_deg: 0.0,
            altitude_m: terrain.height_at_lat_lon_m(lat, 0.0) + 100.0,
            heading_deg: 0.0,
            pitch_deg: -30.0,
            roll_deg: 0.0,
            fov_y_deg: 60.0,
        };
        check_against_brute_force(&format!("pole row at {lat}°"), &terrain, &camera);
    }
}

/// The field of [`PoleRows`] as the march saw it before the pole-row bound: no slope bound in
/// a cap reaching a pole (the reference fell back to its smallest steps there).
struct WithoutPoleBound<'a>(&'a Terrain);

impl HeightField for WithoutPoleBound<'_> {
    fn radius_m(&self) -> f64 {
        self.0.radius_m()
    }
    fn height_m(&self, u: DVec3) -> f64 {
        HeightField::height_m(self.0, u)
    }
    fn height_range_m(&self) -> (f64, f64) {
        HeightField::height_range_m(self.0)
    }
    fn local_bounds(&self, u: DVec3, angle_rad: f64) -> globe::measure::LocalBounds {
        let mut b = self.0.local_bounds(u, angle_rad);
        let reach = angle_rad + (2.0 * POLE_ROWS_DEG).to_radians();
        if u.z.abs().acos() <= reach {
            b.slope_max = f64::INFINITY;
        }
        b
    }
    fn finest_bound_angle_rad(&self) -> f64 {
        self.0.finest_bound_angle_rad()
    }
}

/// The pole costs the reference about what a mid-latitude view costs, in march steps per pixel
/// (not wall time): the `north-pole` pose over the ETOPO5-shaped field against the same pose at
/// 45° N, within a factor 5 (the field is steepest next to the pole: 3 measured); without the
/// pole-row bound the pole takes more than 100 times the mid-latitude steps (500 measured).
#[test]
fn the_pole_costs_about_what_mid_latitudes_cost() {
    let terrain = pole_rows_terrain("steps");
    let (w, h) = (64, 36);
    let pose = |lat: f64| Camera {
        lat_deg: lat,
        lon_deg: 10.0,
        altitude_m: terrain.height_at_lat_lon_m(lat, 10.0) + 100.0,
        heading_deg: 0.0,
        pitch_deg: -30.0,
        roll_deg: 0.0,
        fov_y_deg: 60.0,
    };
    let per_pixel = |field: &dyn HeightField, camera: &Camera| {
        let image = RayCaster::new(field, camera, w, h).cast(&PixelSet::All);
        assert!(image.terrain_count() > 0);
        image.steps as f64 / image.cast_count() as f64
    };
    let mid = per_pixel(&terrain, &pose(45.0));
    let pole = per_pixel(&terrain, &pose(90.0));
    let south = per_pixel(&terrain, &pose(-90.0));
    let unbounded = per_pixel(&WithoutPoleBound(&terrain), &pose(90.0));
    eprintln!(
        "march steps per pixel: 45° N {mid:.1}, North Pole {pole:.1}, South Pole {south:.1}; \
         North Pole without the pole-row bound {unbounded:.1}"
    );
    assert!(
        pole <= 5.0 * mid && south <= 5.0 * mid,
        "{pole} / {south} vs {mid}"
    );
    assert!(unbounded > 100.0 * mid, "{unbounded} vs {mid}");
}
