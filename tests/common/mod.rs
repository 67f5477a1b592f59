//! Shared GPU access for the rendering tests: one adapter (a software one on CI: lavapipe),
//! a clear skip when none exists, and a hard failure instead when `GLOBE_REQUIRE_GPU=1` (set by
//! the test script, so CI can never pass by skipping).
#![allow(dead_code)]

use std::sync::{Mutex, MutexGuard, OnceLock};

use globe::render::GpuContext;

static CONTEXT: OnceLock<Option<GpuContext>> = OnceLock::new();
static SERIAL: Mutex<()> = Mutex::new(());

/// The shared context and a guard that serialises GPU tests (a software rasteriser on two
/// cores gains nothing from running them side by side).
pub fn gpu() -> Option<(&'static GpuContext, MutexGuard<'static, ()>)> {
    let ctx = CONTEXT.get_or_init(|| match GpuContext::headless() {
        Ok(ctx) => {
            eprintln!("GPU tests on {}", ctx.adapter_description());
            Some(ctx)
        }
        Err(e) => {
            if std::env::var("GLOBE_REQUIRE_GPU").as_deref() == Ok("1") {
                panic!("GLOBE_REQUIRE_GPU=1 but no adapter: {e}");
            }
            eprintln!("SKIPPED: no graphics adapter ({e}); run ./scripts/test.sh to install one");
            None
        }
    });
    let guard = SERIAL.lock().unwrap_or_else(|p| p.into_inner());
    ctx.as_ref().map(|c| (c, guard))
}

use glam::DVec3;
use globe::geo::camera::Camera;
use globe::geo::projection;
use globe::render::TerrainRenderer;
use globe::render::offscreen::{OffscreenFrame, RenderedFrame};

/// Renders `camera` into a fresh `w`×`h` offscreen target and reads it back.
pub fn render(
    ctx: &GpuContext,
    r: &mut TerrainRenderer,
    camera: &Camera,
    w: u32,
    h: u32,
) -> RenderedFrame {
    OffscreenFrame::new(&ctx.device, w, h)
        .render(ctx, r, camera)
        .unwrap()
}

/// The surface point under pixel (x, y), in view space (planet centre at the origin), from the
/// rendered reversed-Z depth, in f64. None where the pixel shows sky.
pub fn surface_point_view(
    camera: &Camera,
    frame: &RenderedFrame,
    x: u32,
    y: u32,
    radius_m: f64,
) -> Option<DVec3> {
    let depth = frame.depth_at(x, y) as f64;
    if depth <= 0.0 {
        return None;
    }
    let aspect = frame.width as f64 / frame.height as f64;
    let ndc = DVec3::new(
        (x as f64 + 0.5) / frame.width as f64 * 2.0 - 1.0,
        1.0 - (y as f64 + 0.5) / frame.height as f64 * 2.0,
        depth,
    );
    let camera_from_clip =
        projection::camera_from_clip(camera.fov_y_rad(), aspect, frame.info.near_m);
    let p_cam = projection::camera_point_from_ndc(&camera_from_clip, ndc);
    Some(DVec3::new(0.0, 0.0, radius_m + camera.altitude_m) + camera.view_from_camera() * p_cam)
}

/// Fails unless every named scene is in `covered`: a scene added to the registry must add its
/// test to `file` too.
pub fn assert_covers_every_scene(covered: &[&str], file: &str) {
    for scene in globe::scenes::SCENES {
        assert!(
            covered.contains(&scene.name),
            "scene {} has no test in {file}",
            scene.name
        );
    }
}
