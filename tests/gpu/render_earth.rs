//! The embedded real Earth (ETOPO5 at 10′ through the pyramid file) in the named scenes.

use crate::common;

use common::{render, surface_point_view};

use glam::DVec3;
use globe::clipmap::ClipmapSettings;
use globe::render::formats::COLOR_FORMAT;
use globe::render::{GpuContext, TerrainRenderer};
use globe::scenes::{SCENES, Scene};
use globe::terrain::Terrain;

fn earth_renderer(ctx: &GpuContext) -> TerrainRenderer {
    let terrain = Terrain::embedded_earth().expect("embedded Earth");
    TerrainRenderer::new(
        &ctx.device,
        ClipmapSettings::default(),
        terrain,
        COLOR_FORMAT,
    )
    .unwrap()
}

/// The terrain function has one height at each pole, whatever the longitude it is approached
/// from, and is continuous across it.
#[test]
fn the_terrain_is_continuous_at_the_poles() {
    let Some(dem) = Terrain::embedded_earth().unwrap().dem().cloned() else {
        unreachable!()
    };
    for pole in [90.0f64, -90.0] {
        let at_pole: Vec<f64> = (0..36)
            .map(|i| dem.height_at_m(pole, i as f64 * 10.0))
            .collect();
        let spread = at_pole
            .iter()
            .fold(0.0f64, |m, h| m.max((h - at_pole[0]).abs()));
        assert!(
            spread < 1e-9,
            "pole {pole}: heights at the pole differ by {spread} m"
        );
        // 1 m from the pole every longitude is within the slope of the nearest row times 1 m.
        let near: Vec<f64> = (0..36)
            .map(|i| dem.height_at_m(pole - pole.signum() * 9e-6, i as f64 * 10.0))
            .collect();
        let near_spread = near
            .iter()
            .fold(0.0f64, |m, h| m.max((h - at_pole[0]).abs()));
        eprintln!(
            "pole {pole}: height {:.1} m; 1 m away within {near_spread:.3} m",
            at_pole[0]
        );
        assert!(
            near_spread < 0.5,
            "pole {pole}: 1 m from the pole heights spread {near_spread} m"
        );
    }
}

#[test]
fn every_scene_over_the_earth_renders_without_cracks() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let mut r = earth_renderer(ctx);
    for scene in SCENES {
        let camera = scene.camera(|lat, lon| r.terrain_height_m(lat, lon));
        let frame = render(ctx, &mut r, &camera, 320, 180);
        let mut holes = 0;
        if scene.name == "space" {
            // The whole disk the sphere predicts (less a pixel for its rim) is terrain.
            let alpha = (r.terrain.radius_m() / (r.terrain.radius_m() + camera.altitude_m)).asin();
            let radius_px =
                0.5 * frame.height as f64 / (0.5 * camera.fov_y_rad()).tan() * alpha.tan() - 1.5;
            for y in 0..frame.height {
                for x in 0..frame.width {
                    let (dx, dy) = (
                        x as f64 + 0.5 - frame.width as f64 / 2.0,
                        y as f64 + 0.5 - frame.height as f64 / 2.0,
                    );
                    if dx.hypot(dy) < radius_px && frame.depth_at(x, y) == 0.0 {
                        holes += 1;
                    }
                }
            }
        } else {
            // Below the first terrain pixel of a column, all terrain (a height field from above).
            for x in 0..frame.width {
                if let Some(first) = (0..frame.height).find(|&y| frame.depth_at(x, y) > 0.0) {
                    holes += (first..frame.height)
                        .filter(|&y| frame.depth_at(x, y) == 0.0)
                        .count();
                }
            }
        }
        assert_eq!(
            holes, 0,
            "{}: {holes} sky pixels inside the terrain",
            scene.name
        );
        assert!(
            frame.depth.iter().any(|d| *d > 0.0),
            "{}: no terrain drawn",
            scene.name
        );
    }
}

/// Rendered heights near the viewer against the terrain function: in `ground` the level
/// textures are finer than the 10′ data, so they hold its bilinear surface and the mesh
/// follows it; the screen-space error ρ stays below one pixel.
#[test]
fn ground_heights_follow_the_dem() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let mut r = earth_renderer(ctx);
    let camera = Scene::by_name("ground")
        .unwrap()
        .camera(|lat, lon| r.terrain_height_m(lat, lon));
    let (w, h) = (480, 270);
    let frame = render(ctx, &mut r, &camera, w, h);
    let view = camera.view_frame();
    let radius = r.terrain.radius_m();
    let eye = DVec3::new(0.0, 0.0, radius + camera.altitude_m);
    let px_per_rad = h as f64 / camera.fov_y_rad();
    let (mut n, mut max_rho, mut max_err) = (0, 0.0f64, 0.0f64);
    for y in (0..h).step_by(5) {
        for x in (0..w).step_by(5) {
            let Some(p) = surface_point_view(&camera, &frame, x, y, radius) else {
                continue;
            };
            let distance = (p - eye).length();
            if distance > 20_000.0 {
                continue; // beyond the levels finer than the data
            }
            let err =
                (p.length() - radius - r.terrain.height_m(view.world_from_view * p.normalize()))
                    .abs();
            max_err = max_err.max(err);
            max_rho = max_rho.max(err * px_per_rad / distance);
            n += 1;
        }
    }
    eprintln!(
        "ground over the Earth: {n} pixels within 20 km, max |Δh| {max_err:.3} m, max ρ {max_rho:.3} px"
    );
    assert!(n > 500);
    assert!(max_rho < 1.0, "max ρ {max_rho} px");
}
