//! Rendering tests on the (software) adapter: the named scenes against geometry and against the
//! analytic planet's closed-form heights.

use crate::common;

use common::{render, surface_point_view};

use glam::DVec3;
use globe::clipmap::selection::LevelStatus;
use globe::clipmap::settings::level_outer_theta_rad;
use globe::clipmap::{ClipmapSettings, TransformForm};
use globe::geo::camera::Camera;
use globe::render::formats::COLOR_FORMAT;
use globe::render::offscreen::{OffscreenFrame, RenderedFrame};
use globe::render::{GpuContext, TerrainRenderer};
use globe::scenes::Scene;
use globe::terrain::analytic::band_weight;
use globe::terrain::{AnalyticPlanet, Terrain};

fn renderer(ctx: &GpuContext) -> TerrainRenderer {
    renderer_with(ctx, ClipmapSettings::default())
}

/// A renderer of the analytic test planet with `settings`.
fn renderer_with(ctx: &GpuContext, settings: ClipmapSettings) -> TerrainRenderer {
    TerrainRenderer::new(
        &ctx.device,
        settings,
        Terrain::analytic_earth(),
        COLOR_FORMAT,
    )
    .unwrap()
}

fn scene_camera(r: &TerrainRenderer, name: &str) -> Camera {
    Scene::by_name(name)
        .unwrap()
        .camera(|lat, lon| r.terrain_height_m(lat, lon))
}

/// ρ (the error-bounded paper's screen-space error, eq. 3: λ·δ/distance in pixels) of every
/// `step`-th pixel against the analytic planet: mean, p99 and max.
fn rho_stats(
    camera: &Camera,
    frame: &RenderedFrame,
    planet: &AnalyticPlanet,
    step: usize,
) -> (f64, f64, f64) {
    let view = camera.view_frame();
    let radius = planet.radius_m;
    let px_per_rad = frame.height as f64 / camera.fov_y_rad();
    let eye = DVec3::new(0.0, 0.0, radius + camera.altitude_m);
    let mut rho = Vec::new();
    for y in (0..frame.height).step_by(step) {
        for x in (0..frame.width).step_by(step) {
            let Some(p) = surface_point_view(camera, frame, x, y, radius) else {
                continue;
            };
            let err =
                (p.length() - radius - planet.height_m(view.world_from_view * p.normalize())).abs();
            rho.push(err * px_per_rad / (p - eye).length());
        }
    }
    rho.sort_by(f64::total_cmp);
    let mean = rho.iter().sum::<f64>() / rho.len() as f64;
    (
        mean,
        rho[(rho.len() as f64 * 0.99) as usize],
        rho[rho.len() - 1],
    )
}

/// Pixels whose colour differs at all between two frames of the same size.
fn pixels_differing(a: &RenderedFrame, b: &RenderedFrame) -> usize {
    a.rgba
        .chunks(4)
        .zip(b.rgba.chunks(4))
        .filter(|(x, y)| x != y)
        .count()
}

/// `space`: the disk's radius is the one geometry predicts within 1 px, centred on the image.
#[test]
fn space_disk_radius_and_centre_match_geometry() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let mut r = renderer(ctx);
    let camera = scene_camera(&r, "space");
    let (w, h) = (1920, 1080);
    let frame = render(ctx, &mut r, &camera, w, h);
    let (mut count, mut sx, mut sy) = (0u64, 0.0, 0.0);
    for y in 0..h {
        for x in 0..w {
            if frame.depth_at(x, y) > 0.0 {
                count += 1;
                sx += x as f64 + 0.5;
                sy += y as f64 + 0.5;
            }
        }
    }
    let radius_px = (count as f64 / std::f64::consts::PI).sqrt();
    // The silhouette cone of a sphere of radius R seen from distance R + H: sin α = R/(R + H).
    let alpha = (r.terrain.radius_m() / (r.terrain.radius_m() + camera.altitude_m)).asin();
    let focal_px = 0.5 * h as f64 / (0.5 * camera.fov_y_rad()).tan();
    let predicted_px = focal_px * alpha.tan();
    let (cx, cy) = (sx / count as f64, sy / count as f64);
    eprintln!(
        "space disk: radius {radius_px:.2} px, predicted {predicted_px:.2} px; centre ({cx:.2}, {cy:.2})"
    );
    assert!(
        (radius_px - predicted_px).abs() <= 1.0,
        "radius {radius_px} vs {predicted_px}"
    );
    // Looking at the planet's centre: its projection is the image centre.
    assert!((cx - w as f64 / 2.0).abs() <= 1.0 && (cy - h as f64 / 2.0).abs() <= 1.0);
    // Only the coarsest levels: level 0 lies beyond the horizon.
    assert_eq!(frame.info.selection.status[0], LevelStatus::BeyondHorizon);
}

/// A priori bound on |rendered − true| height for a point at angle θ̃ from the nadir: what the
/// level's texture leaves out by its band limit (the LOD drops it on purpose, paper §4.2), plus
/// two stacked linear interpolations (texture, then mesh) of each kept scale: a product of two
/// sines of wavenumber k has curvature ≤ 2k²A, so each step Δ costs ≤ k²Δ²A/4.
fn height_tolerance_m(
    planet: &AnalyticPlanet,
    settings: &ClipmapSettings,
    theta_tilde: f64,
    distance_m: f64,
) -> f64 {
    let level = ((std::f64::consts::PI / theta_tilde.max(1e-30))
        .log2()
        .floor() as u32)
        .min(settings.levels - 1);
    let outer = level_outer_theta_rad(level);
    let r = planet.radius_m;
    let texel_m = 4.0 * outer / settings.texture_size as f64 * r;
    let band_texel_m = 2.0 * texel_m;
    let ring_step_m = outer * (1.0 - (-1.0 / settings.rings_per_level as f64).exp2()) * r;
    let step_m = ring_step_m.max(texel_m);
    let mut tol = planet.band_limit_bound_m(band_texel_m);
    for s in &planet.scales {
        let k = std::f64::consts::TAU / s.wavelength_m;
        tol += band_weight(s.wavelength_m, band_texel_m)
            * s.amplitude_m
            * (0.5 * (k * step_m).powi(2)).min(2.0);
    }
    // Depth precision (f32 reversed-Z ~1e-7 relative) and 1 mm of f32 slack.
    tol + 1e-6 * distance_m + 1e-3
}

fn check_heights(name: &str) {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let mut r = renderer(ctx);
    let camera = scene_camera(&r, name);
    let (w, h) = (640, 360);
    let frame = render(ctx, &mut r, &camera, w, h);
    let view = camera.view_frame();
    let radius = r.terrain.radius_m();
    let (mut checked, mut worst_ratio, mut max_err, mut max_rho) = (0, 0.0f64, 0.0f64, 0.0f64);
    let px_per_rad = h as f64 / camera.fov_y_rad();
    for y in (0..h).step_by(7) {
        for x in (0..w).step_by(7) {
            let Some(p_view) = surface_point_view(&camera, &frame, x, y, radius) else {
                continue;
            };
            let u_world = view.world_from_view * p_view.normalize();
            let rendered_h = p_view.length() - radius;
            let true_h = r.terrain.height_m(u_world);
            let err = (rendered_h - true_h).abs();
            let eye = DVec3::new(0.0, 0.0, radius + camera.altitude_m);
            let distance = (p_view - eye).length();
            let theta_tilde = p_view.normalize().z.clamp(-1.0, 1.0).acos();
            let tol = height_tolerance_m(
                r.terrain.analytic().unwrap(),
                &r.settings,
                theta_tilde,
                distance,
            );
            assert!(
                err <= tol,
                "{name}: pixel ({x},{y}) at {distance:.1} m: rendered {rendered_h:.4} m, true {true_h:.4} m, tolerance {tol:.4} m"
            );
            checked += 1;
            worst_ratio = worst_ratio.max(err / tol);
            max_err = max_err.max(err);
            max_rho = max_rho.max(err * px_per_rad / distance);
        }
    }
    eprintln!(
        "{name}: {checked} pixels, max |Δh| {max_err:.4} m, max error/tolerance {worst_ratio:.3}, max ρ {max_rho:.3} px"
    );
    assert!(checked > 1000, "{name}: too few terrain pixels ({checked})");
}

#[test]
fn aircraft_heights_match_the_analytic_planet() {
    check_heights("aircraft");
}

#[test]
fn ground_heights_match_the_analytic_planet() {
    check_heights("ground");
}

/// Levels outside [θ̃min, θ̃max] or out of view are not drawn, and drawing them anyway changes
/// (almost) nothing: horizon-culled levels are hidden, pixel-bound ones are inside the finest
/// cap, out-of-view ones outside the frustum.
#[test]
fn skipped_levels_are_really_invisible() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let mut r = renderer(ctx);
    for name in ["north-pole", "space", "ground"] {
        let camera = scene_camera(&r, name);
        let (w, h) = (480, 270);
        r.switches.draw_all_levels = false;
        let selected = render(ctx, &mut r, &camera, w, h);
        let sel = &selected.info.selection;
        for (i, status) in sel.status.iter().enumerate() {
            let outer = level_outer_theta_rad(i as u32);
            match status {
                LevelStatus::Drawn => {
                    assert!(outer / 2.0 < sel.theta_max_rad && outer >= sel.theta_min_rad)
                }
                LevelStatus::BeyondHorizon => assert!(outer / 2.0 >= sel.theta_max_rad),
                LevelStatus::SubPixel => assert!(outer < sel.theta_min_rad),
                LevelStatus::Waiting => panic!("the analytic planet never waits for data"),
                LevelStatus::OutOfView => assert!(i as u32 > sel.finest),
            }
        }
        r.switches.draw_all_levels = true;
        let everything = render(ctx, &mut r, &camera, w, h);
        r.switches.draw_all_levels = false;
        let differing = pixels_differing(&selected, &everything);
        eprintln!(
            "{name}: drew levels {:?} ({} triangles); all {} levels ({} triangles) differ in {differing} px",
            sel.drawn_levels(),
            selected.info.draw.triangles,
            r.settings.levels,
            everything.info.draw.triangles
        );
        assert!(
            differing <= 4,
            "{name}: skipped levels changed {differing} pixels"
        );
        assert!(everything.info.draw.triangles > selected.info.draw.triangles);
    }
}

/// Stiff cameras: exactly at a pole, 1 mm and 10⁹ m up, straight down and straight up. No
/// panic, finite depths, and the coverage geometry predicts.
#[test]
fn extreme_cameras_render_finite_frames() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let mut r = renderer(ctx);
    let (w, h) = (96, 64);
    for lat in [90.0, -90.0, 45.65] {
        for above_terrain in [1e-3, 2.0, 1e9] {
            for pitch in [-90.0, 90.0, -30.0] {
                let ground = r.terrain_height_m(lat, 10.0);
                let camera = Camera {
                    lat_deg: lat,
                    lon_deg: 10.0,
                    altitude_m: ground + above_terrain,
                    heading_deg: 0.0,
                    pitch_deg: pitch,
                    roll_deg: 0.0,
                    fov_y_deg: 60.0,
                };
                let frame = render(ctx, &mut r, &camera, w, h);
                assert!(
                    frame
                        .depth
                        .iter()
                        .all(|d| d.is_finite() && (0.0..=1.0).contains(d))
                );
                let covered = frame.depth.iter().filter(|d| **d > 0.0).count();
                let all = (w * h) as usize;
                let what = format!(
                    "lat {lat}, {above_terrain} m above terrain, pitch {pitch}: {covered}/{all} px terrain"
                );
                eprintln!("{what}");
                if pitch == -90.0 && above_terrain < 1e3 {
                    assert_eq!(
                        covered, all,
                        "{what}: looking down from near the ground must see only ground"
                    );
                }
                if pitch == 90.0 && above_terrain < 1e3 {
                    assert_eq!(covered, 0, "{what}: looking straight up must see only sky");
                }
                if pitch == -90.0 && above_terrain >= 1e9 {
                    let alpha =
                        (r.terrain.radius_m() / (r.terrain.radius_m() + camera.altitude_m)).asin();
                    let radius_px = 0.5 * h as f64 / (0.5 * camera.fov_y_rad()).tan() * alpha.tan();
                    let predicted = std::f64::consts::PI * radius_px * radius_px;
                    assert!(
                        (covered as f64 - predicted).abs()
                            <= 2.0 * std::f64::consts::PI * radius_px + 4.0,
                        "{what}: predicted {predicted:.1} px"
                    );
                }
            }
        }
    }
}

/// Error against cost over mesh settings, to choose the defaults (docs/design.md#choosing-n-m-and-the-texture-size).
/// Slow on a software adapter, so ignored; run with
/// `cargo test --release --test gpu -- --ignored --nocapture render_scenes::settings_sweep`.
#[test]
#[ignore]
fn settings_sweep() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let (w, h) = (960, 540);
    eprintln!(
        "{:<10} {:>5} {:>4} {:>6} {:>10} {:>9} {:>9} {:>9}",
        "scene", "n", "m", "tex", "triangles", "mean ρ", "p99 ρ", "max ρ"
    );
    for (n, m, tex) in [
        (256, 16, 256),
        (512, 16, 256),
        (512, 16, 512),
        (512, 32, 512),
        (512, 48, 512),
        (1024, 32, 512),
        (1024, 64, 1024),
    ] {
        let settings = ClipmapSettings {
            phi_steps: n,
            rings_per_level: m,
            texture_size: tex,
            ..Default::default()
        };
        let mut r = renderer_with(ctx, settings);
        for name in ["aircraft", "ground"] {
            let camera = scene_camera(&r, name);
            let frame = render(ctx, &mut r, &camera, w, h);
            let (mean, p99, max) = rho_stats(&camera, &frame, r.terrain.analytic().unwrap(), 3);
            eprintln!(
                "{name:<10} {n:>5} {m:>4} {tex:>6} {:>10} {mean:>9.4} {p99:>9.4} {max:>9.4}",
                frame.info.draw.triangles
            );
        }
    }
}

/// Crossing the antimeridian (φ = ±π) and Greenwich (where the level grids wrap, φ = 0 = 2π) by
/// 0.2 mm moves the image by almost nothing, with the toroidal update path (same renderer) and
/// from scratch (fresh renderer).
#[test]
fn crossing_the_antimeridian_and_greenwich_is_continuous() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let (w, h) = (320, 180);
    let deg_per_0_1mm = 1e-4 / globe::geo::EARTH_RADIUS_M * 180.0 / std::f64::consts::PI;
    for lon in [180.0, 0.0] {
        let mut r = renderer(ctx);
        let at = |lon_deg: f64| Camera {
            lat_deg: 0.3,
            lon_deg,
            altitude_m: 1000.0,
            heading_deg: 90.0,
            pitch_deg: -30.0,
            roll_deg: 0.0,
            fov_y_deg: 60.0,
        };
        let west = render(ctx, &mut r, &at(lon - deg_per_0_1mm), w, h);
        let east_updated = render(ctx, &mut r, &at(lon + deg_per_0_1mm), w, h);
        let east_fresh = render(ctx, &mut renderer(ctx), &at(lon + deg_per_0_1mm), w, h);
        let diff = |a: &RenderedFrame, b: &RenderedFrame| {
            a.rgba
                .iter()
                .zip(&b.rgba)
                .filter(|(x, y)| (**x as i32 - **y as i32).abs() > 2)
                .count()
        };
        let (across, fresh) = (diff(&west, &east_updated), diff(&east_updated, &east_fresh));
        eprintln!(
            "lon {lon}: 0.2 mm across changes {across} channel values; updated vs fresh {fresh}"
        );
        assert!(
            across <= 16,
            "crossing lon {lon} changed {across} channel values"
        );
        assert!(
            fresh <= 16,
            "toroidal update differs from a fresh fill at lon {lon} in {fresh} channel values"
        );
    }
}

/// Sky pixels below the first terrain pixel of their column: a crack in the surface (a
/// height field seen from above has none). Fig. 14: the approximation needs its blend.
fn holes(frame: &RenderedFrame) -> usize {
    let mut holes = 0;
    for x in 0..frame.width {
        let first = (0..frame.height).find(|&y| frame.depth_at(x, y) > 0.0);
        if let Some(first) = first {
            holes += (first..frame.height)
                .filter(|&y| frame.depth_at(x, y) == 0.0)
                .count();
        }
    }
    holes
}

#[test]
fn every_transform_form_renders_without_cracks() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    for form in TransformForm::ALL {
        let settings = ClipmapSettings {
            transform: form,
            ..Default::default()
        };
        let mut r = renderer_with(ctx, settings);
        for name in [
            "aircraft",
            "ground",
            "north-pole",
            "antimeridian",
            "everest",
        ] {
            let camera = scene_camera(&r, name);
            let frame = render(ctx, &mut r, &camera, 320, 180);
            let n = holes(&frame);
            assert_eq!(
                n,
                0,
                "{} form, {name}: {n} sky pixels inside the terrain",
                form.name()
            );
        }
    }
}

/// Each map-transform form's error and cost, for docs/design.md#the-three-map-transform-forms. Ignored (slow); run with
/// `cargo test --release --test gpu -- --ignored --nocapture render_scenes::transform_forms`.
#[test]
#[ignore]
fn transform_forms() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let (w, h) = (960, 540);
    eprintln!(
        "{:<10} {:<12} {:>9} {:>9} {:>9} {:>10}",
        "scene", "form", "mean ρ", "p99 ρ", "max ρ", "frame ms"
    );
    for name in ["aircraft", "ground"] {
        for form in TransformForm::ALL {
            let settings = ClipmapSettings {
                transform: form,
                ..Default::default()
            };
            let mut r = renderer_with(ctx, settings);
            let camera = scene_camera(&r, name);
            let target = OffscreenFrame::new(&ctx.device, w, h);
            let mut frame = target.render(ctx, &mut r, &camera).unwrap();
            // Later frames draw the same view with nothing left to fill: the median of five is
            // the cost of the terrain pass (and the readback) alone.
            let mut times = Vec::new();
            for _ in 0..5 {
                let t = std::time::Instant::now();
                frame = target.render(ctx, &mut r, &camera).unwrap();
                times.push(t.elapsed().as_secs_f64() * 1e3);
            }
            times.sort_by(f64::total_cmp);
            let (mean, p99, max) = rho_stats(&camera, &frame, r.terrain.analytic().unwrap(), 3);
            eprintln!(
                "{name:<10} {:<12} {mean:>9.4} {p99:>9.4} {max:>9.4} {:>10.1}",
                form.name(),
                times[2]
            );
        }
    }
}

/// Frustum culling of sectors never removes anything visible: drawing every sector gives the
/// same image in every named scene.
#[test]
fn culled_sectors_are_really_outside_the_view() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let mut r = renderer(ctx);
    for scene in globe::scenes::SCENES {
        let camera = scene_camera(&r, scene.name);
        let (w, h) = (320, 180);
        r.switches.draw_all_sectors = false;
        let culled = render(ctx, &mut r, &camera, w, h);
        r.switches.draw_all_sectors = true;
        let everything = render(ctx, &mut r, &camera, w, h);
        r.switches.draw_all_sectors = false;
        let differing = pixels_differing(&culled, &everything);
        eprintln!(
            "{}: {} of {} sectors culled, {} → {} triangles, {differing} px differ",
            scene.name,
            culled.info.draw.sectors_culled,
            culled.info.draw.sectors_culled + culled.info.draw.sectors_drawn,
            everything.info.draw.triangles,
            culled.info.draw.triangles
        );
        assert_eq!(
            differing, 0,
            "{}: culling removed visible terrain",
            scene.name
        );
    }
}
