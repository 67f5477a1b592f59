//! The editor's path to the GPU (`TerrainRenderer::set_detail`, what `ui::editor` triggers):
//! a new detail refills the levels once on the next frame, exactly as a renderer built from
//! scratch with that detail fills them, and the rendered heights change.

use crate::common;

use std::sync::Arc;

use globe::clipmap::ClipmapSettings;
use globe::procedural::{DetailParams, ReliefDab, presets};
use globe::render::TerrainRenderer;
use globe::render::formats::COLOR_FORMAT;
use globe::render::offscreen::{OffscreenFrame, RenderedFrame};
use globe::scenes::Scene;
use globe::terrain::Terrain;

const W: u32 = 96;
const H: u32 = 54;

/// A level's heights plus its partial octaves (where the level keeps the detail), in grid order.
fn level_total(ctx: &globe::render::GpuContext, r: &TerrainRenderer, level: u32) -> Vec<f32> {
    let (grid, heights) = r.read_level(ctx, level).unwrap().expect("level filled");
    let (grid_p, _, partials) = r.read_level_partials(ctx, level).unwrap().unwrap();
    assert_eq!(grid, grid_p);
    heights
        .iter()
        .zip(&partials)
        .map(|(h, p)| h + p.iter().sum::<f32>())
        .collect()
}

/// One frame, no settling (the analytic planet needs none): its `texels_filled` is its own.
fn frame(
    ctx: &globe::render::GpuContext,
    r: &mut TerrainRenderer,
    camera: &globe::geo::camera::Camera,
) -> RenderedFrame {
    OffscreenFrame::new(&ctx.device, W, H)
        .render_now(ctx, r, camera)
        .unwrap()
}

#[test]
fn set_detail_refills_the_levels_as_a_fresh_renderer_would() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let terrain = Terrain::analytic_earth().with_detail(Some(Default::default()));
    // Another preset and paint under the camera: the relief buffer is re-uploaded too.
    let spot = Scene::by_name("ground").unwrap().view();
    let alpine = DetailParams {
        relief_paint: vec![ReliefDab {
            lat_deg: spot.lat_deg,
            lon_deg: spot.lon_deg,
            radius_deg: 2.0,
            factor: 4.0,
        }],
        ..presets::find("alpine").unwrap().params().unwrap()
    };
    let detail = Arc::new(terrain.detail().unwrap().with_params(alpine));
    let edited = terrain.clone().with_detail_of(Some(detail.clone()));
    let settings = ClipmapSettings {
        texture_size: 128,
        ..ClipmapSettings::default()
    };
    // Above the ground of both details.
    let camera = Scene::by_name("ground").unwrap().camera(|lat, lon| {
        terrain
            .height_at_lat_lon_m(lat, lon)
            .max(edited.height_at_lat_lon_m(lat, lon))
    });
    let mut live =
        TerrainRenderer::new(&ctx.device, settings.clone(), terrain.clone(), COLOR_FORMAT).unwrap();
    let before = frame(ctx, &mut live, &camera);
    let settled = frame(ctx, &mut live, &camera);
    assert_eq!(
        settled.info.texels_filled, 0,
        "a settled frame fills nothing"
    );

    live.set_detail(&ctx.queue, detail).unwrap();
    let after = frame(ctx, &mut live, &camera);
    let again = frame(ctx, &mut live, &camera);
    assert_eq!(again.info.texels_filled, 0, "refilled once only");

    // The same as a renderer built with the new detail from the start: what its first frame
    // filled, the level textures and the depth.
    let mut fresh = TerrainRenderer::new(&ctx.device, settings, edited, COLOR_FORMAT).unwrap();
    let reference = frame(ctx, &mut fresh, &camera);
    assert!(after.info.texels_filled > 0);
    assert_eq!(after.info.texels_filled, reference.info.texels_filled);
    let sel = &after.info.selection;
    assert_eq!(sel.finest, reference.info.selection.finest);
    for level in sel.coarsest..=sel.finest {
        let (a, b) = (
            level_total(ctx, &live, level),
            level_total(ctx, &fresh, level),
        );
        let differ = a.iter().zip(&b).filter(|(x, y)| x != y).count();
        assert_eq!(
            differ, 0,
            "level {level}: {differ} texels refilled ≠ freshly filled"
        );
    }
    let mut depth_changed = 0;
    for y in 0..H {
        for x in 0..W {
            assert_eq!(
                after.depth_at(x, y),
                reference.depth_at(x, y),
                "pixel {x},{y}"
            );
            depth_changed += usize::from(after.depth_at(x, y) != before.depth_at(x, y));
        }
    }
    assert!(
        depth_changed > (W * H / 4) as usize,
        "the rendered heights changed at only {depth_changed} of {} pixels",
        W * H
    );
    // And the levels' contents changed where both frames drew the same level.
    let level = before.info.selection.finest.min(sel.finest);
    let mut old =
        TerrainRenderer::new(&ctx.device, live.settings.clone(), terrain, COLOR_FORMAT).unwrap();
    frame(ctx, &mut old, &camera);
    let (a, b) = (
        level_total(ctx, &old, level),
        level_total(ctx, &live, level),
    );
    let changed = a
        .iter()
        .zip(&b)
        .filter(|(x, y)| (*x - *y).abs() > 0.01)
        .count();
    assert!(
        changed > a.len() / 2,
        "level {level}: {changed} of {} texels changed",
        a.len()
    );
}
