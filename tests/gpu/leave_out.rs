//! "Leave out what the scene does not need" (issue 5 item 8; `docs/design.md#data-flow`), shown
//! with counters rather than assumed: for every named scene over the embedded Earth (the real
//! DEM, streamed), the levels outside the visibility bounds are neither drawn nor filled, the
//! sectors outside the frustum are not drawn, the pyramid tiles the view does not need are never
//! requested, and the level overlay costs nothing when off.
//!
//! Each test prints its counts (`cargo test --test gpu -- leave_out:: --nocapture`), so they can be
//! quoted. `render_scenes.rs` shows on the analytic planet that what is skipped is invisible
//! (images with and without the skipping are the same); this file shows it is really skipped.

use crate::common;

use std::time::{Duration, Instant};

use globe::clipmap::RingMesh;
use globe::clipmap::density::DensityPlan;
use globe::clipmap::selection::{LevelSelection, LevelStatus};
use globe::geo::camera::Camera;
use globe::render::{FrameInfo, GpuContext, TerrainRenderer};
use globe::scenes::Scene;
use globe::terrain::Terrain;

const WIDTH: u32 = 320;
const HEIGHT: u32 = 180;
/// Longest a scene may take to stream in from the memory-mapped file.
const SETTLE_TIMEOUT: Duration = Duration::from_secs(120);

/// What streaming a view in from a fresh renderer did.
struct StreamIn {
    /// The last frame's decisions.
    info: FrameInfo,
    /// Texels written over all frames.
    texels: u64,
    frames: u32,
    /// Every level some frame targeted (its drawn or waiting levels and the coarser blend level).
    targeted: Vec<bool>,
    /// The first frame that reported itself settled.
    first_settled: FrameInfo,
}

/// Frames of `camera` until two frames in a row are settled with the same selection (the
/// camera's height, and so θ̃min, is read from the tiles at hand, so the frame in which the
/// camera's tile arrives may still have chosen its levels from a coarser one), counting the
/// texels filled and the levels targeted.
fn stream_in(ctx: &GpuContext, r: &mut TerrainRenderer, camera: &Camera) -> StreamIn {
    let started = Instant::now();
    let mut texels = 0;
    let mut frames = 0;
    let mut targeted = vec![false; r.settings.levels as usize];
    let mut first_settled = None;
    let mut previous: Option<FrameInfo> = None;
    loop {
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        let info = r.prepare(&ctx.queue, &mut encoder, camera, WIDTH, HEIGHT);
        ctx.queue.submit([encoder.finish()]);
        frames += 1;
        texels += info.texels_filled;
        for level in targeted_levels(&info.selection) {
            targeted[level as usize] = true;
        }
        if info.settled() {
            first_settled.get_or_insert_with(|| info.clone());
            if previous
                .as_ref()
                .is_some_and(|p| p.settled() && p.selection == info.selection)
            {
                ctx.wait_idle().unwrap();
                return StreamIn {
                    info,
                    texels,
                    frames,
                    targeted,
                    first_settled: first_settled.expect("set above"),
                };
            }
        }
        assert!(
            started.elapsed() < SETTLE_TIMEOUT,
            "streaming did not settle: {:?}",
            info.stream
        );
        previous = Some(info);
        std::thread::sleep(Duration::from_millis(2));
    }
}

/// Levels whose texture window a frame targets: the wanted ones (drawn, or waiting for data)
/// and the one coarser level their outer rings blend into.
fn targeted_levels(sel: &LevelSelection) -> std::ops::RangeInclusive<u32> {
    let finest = sel
        .status
        .iter()
        .rposition(|s| matches!(s, LevelStatus::Drawn | LevelStatus::Waiting))
        .map_or(sel.finest, |l| l as u32);
    sel.coarsest.saturating_sub(1)..=finest
}

/// What one scene left out, counted.
fn check_scene(name: &str) {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let terrain = Terrain::embedded_earth().expect("embedded Earth");
    let Some(dem) = terrain.dem() else {
        unreachable!("the embedded Earth is a DEM")
    };
    let pyramid = dem.pyramid().info();
    let scene = Scene::by_name(name).unwrap();
    let camera = scene.camera(|lat, lon| terrain.height_at_lat_lon_m(lat, lon));
    let mut r = common::default_renderer(ctx, &terrain);
    let settings = r.settings.clone();
    let levels = settings.levels;
    let texels_per_level = u64::from(settings.texture_size).pow(2);

    // Stream the view in from a fresh renderer, counting every texel written.
    let streamed = stream_in(ctx, &mut r, &camera);
    let frame = common::render(ctx, &mut r, &camera, WIDTH, HEIGHT);
    let info = &frame.info;
    let sel = &info.selection;
    assert_eq!(
        info.texels_filled, 0,
        "{name}: a settled view fills nothing more"
    );
    assert_eq!(
        sel, &streamed.info.selection,
        "{name}: the selection is stable once settled"
    );
    let early = &streamed.first_settled;
    let settled_early = early.selection.drawn_levels() != sel.drawn_levels();

    // 1. Levels outside [θ̃min, θ̃max] are not drawn.
    let count = |status| sel.status.iter().filter(|s| **s == status).count();
    let (drawn, beyond, sub_pixel, out_of_view) = (
        count(LevelStatus::Drawn),
        count(LevelStatus::BeyondHorizon),
        count(LevelStatus::SubPixel),
        count(LevelStatus::OutOfView),
    );
    assert_eq!(count(LevelStatus::Waiting), 0, "{name}: settled");
    assert_eq!(drawn + beyond + sub_pixel + out_of_view, levels as usize);
    assert_eq!(drawn, sel.drawn_levels().len());
    assert!(beyond > 0, "{name}: {sel:?}");
    // Even at 2 m and 180 px the finest of the 40 levels (0.07 mm) is narrower than a pixel.
    assert!(sub_pixel > 0, "{name}: {sel:?}");
    for (level, status) in sel.status.iter().enumerate() {
        let outer = globe::clipmap::settings::level_outer_theta_rad(level as u32);
        match status {
            LevelStatus::BeyondHorizon => assert!(0.5 * outer >= sel.theta_max_rad),
            LevelStatus::SubPixel => assert!(outer < sel.theta_min_rad),
            LevelStatus::OutOfView => assert!(level as u32 > sel.finest),
            _ => {}
        }
    }

    // 2. ... and their textures are never filled: a level holds data only if some frame's
    // bounds targeted it (drawn or waiting, or the coarser level the drawn ones blend into;
    // a level an early frame wanted may also never be filled if the selection moved on before
    // its tiles came), each filled level is written exactly once in full, and the settled
    // view's levels are all there. Levels that only streaming-in frames targeted (while the
    // camera's height came from a coarser tile or from none, θ̃min was off) are counted apart.
    let final_targets = targeted_levels(sel);
    let mut filled = Vec::new();
    let mut transient = Vec::new();
    for level in 0..levels {
        let held = r.read_level(ctx, level).unwrap().is_some();
        assert!(
            !held || streamed.targeted[level as usize],
            "{name}: level {level} filled, but no frame targeted it"
        );
        if final_targets.contains(&level) {
            assert!(held, "{name}: level {level} of the settled view is empty");
        }
        if held {
            filled.push(level);
            if !final_targets.contains(&level) {
                transient.push(level);
            }
        }
    }
    let texels = streamed.texels;
    assert_eq!(
        texels,
        filled.len() as u64 * texels_per_level,
        "{name}: texels written while streaming in"
    );
    let never_filled = levels as usize - filled.len();
    assert!(never_filled > 0, "{name}: every level was filled");
    let all_texels = u64::from(levels) * texels_per_level;

    // 3. Sectors outside the frustum are not drawn.
    let d = &info.draw;
    let sectors_total = (drawn as u32 + 1) * settings.sectors;
    // Every sector at the densities the frame chose (at most the full mesh).
    let triangles_total = drawn_triangles(r.mesh(), &info.densities, &info.selection);
    assert!(
        triangles_total
            <= drawn as u64 * settings.triangles_per_level() + settings.triangles_per_cap()
    );
    assert_eq!(d.sectors_drawn + d.sectors_culled, sectors_total);
    assert!(d.triangles <= triangles_total);
    if name != "space" {
        assert!(
            d.sectors_culled > 0 && d.triangles < triangles_total,
            "{name}: a narrow view culls sectors"
        );
    }
    r.switches.draw_all_sectors = true;
    let everything = common::render(ctx, &mut r, &camera, WIDTH, HEIGHT);
    r.switches.draw_all_sectors = false;
    assert_eq!(everything.info.draw.sectors_culled, 0);
    assert_eq!(everything.info.draw.triangles, triangles_total);

    // 4. Tiles the view does not need are never requested.
    let stream = info.stream.as_ref().expect("a DEM streams");
    let s = &stream.stream;
    assert_eq!(s.tiles_failed, 0, "{name}: {:?}", stream.last_error);
    // Every request is accounted for (a tile wanted only for culling bounds may still be on
    // its way when the view has settled).
    assert_eq!(
        s.tiles_requested,
        s.tiles_loaded + s.tiles_cancelled + s.queued + s.in_flight
    );
    // Far below the pyramid's tile count: under half of it in every scene (a view sees at
    // most a hemisphere, and only its nearest part at the finest data).
    assert!(
        2 * s.tiles_requested < pyramid.tiles as u64,
        "{name}: requested {} of {} tiles",
        s.tiles_requested,
        pyramid.tiles
    );
    assert!(2 * s.bytes_read < pyramid.file_bytes);

    // 5. The level overlay costs nothing when off: the same draw calls with it on, and no
    // extra fills; it does change the image, so the comparison means something.
    r.overlays.levels = true;
    let overlay = common::render(ctx, &mut r, &camera, WIDTH, HEIGHT);
    r.overlays.levels = false;
    assert_eq!(
        overlay.info.draw, frame.info.draw,
        "{name}: overlay changed the draw list"
    );
    assert_eq!(overlay.info.texels_filled, 0);
    let recoloured = frame
        .rgba
        .chunks(4)
        .zip(overlay.rgba.chunks(4))
        .filter(|(a, b)| a != b)
        .count();
    assert!(recoloured > 0, "{name}: the overlay draws nothing");

    // The same view with every level forced on, from a fresh renderer: what the bounds saved.
    let mut all = common::default_renderer(ctx, &terrain);
    all.switches.draw_all_levels = true;
    let all_streamed = stream_in(ctx, &mut all, &camera);
    let all_written = all_streamed.texels;
    let all_stream = all_streamed.info.stream.as_ref().unwrap().stream;
    assert_eq!(all_written, all_texels, "{name}: every level filled once");
    assert!(all_written > texels);

    eprintln!(
        "{name}: levels {:?} drawn ({drawn} of {levels}; {beyond} beyond the horizon, \
         {sub_pixel} sub-pixel); {} frames to stream in{}; textures filled for levels \
         {filled:?} ({never_filled} never filled; {transient:?} only while streaming in): \
         {texels} texels (every level forced on: {all_written}, {:.1}× as many); sectors {} \
         drawn, {} culled: {} of {} triangles; tiles requested {} of {} ({} with every level \
         on), {} of {} bytes read; level overlay: same {} triangles, {recoloured} px recoloured",
        sel.drawn_levels(),
        streamed.frames,
        if settled_early {
            format!(
                " (first reported settled with levels {:?}, its height above terrain {:.1} m \
                 instead of {:.1} m)",
                early.selection.drawn_levels(),
                early.height_above_terrain_m,
                info.height_above_terrain_m
            )
        } else {
            String::new()
        },
        all_written as f64 / texels as f64,
        d.sectors_drawn,
        d.sectors_culled,
        d.triangles,
        triangles_total,
        s.tiles_requested,
        pyramid.tiles,
        all_stream.tiles_requested,
        s.bytes_read,
        pyramid.file_bytes,
        overlay.info.draw.triangles,
    );
}

#[test]
fn space_leaves_out_what_it_does_not_need() {
    check_scene("space");
}

#[test]
fn aircraft_leaves_out_what_it_does_not_need() {
    check_scene("aircraft");
}

#[test]
fn ground_leaves_out_what_it_does_not_need() {
    check_scene("ground");
}

#[test]
fn north_pole_leaves_out_what_it_does_not_need() {
    check_scene("north-pole");
}

#[test]
fn antimeridian_leaves_out_what_it_does_not_need() {
    check_scene("antimeridian");
}

#[test]
fn everest_leaves_out_what_it_does_not_need() {
    check_scene("everest");
}

/// Every named scene has its test above.
#[test]
fn every_scene_is_covered() {
    common::assert_covers_every_scene(
        &[
            "space",
            "aircraft",
            "ground",
            "north-pole",
            "antimeridian",
            "everest",
        ],
        "tests/gpu/leave_out.rs",
    );
}

/// Triangles of every sector of the drawn levels of `selection` at `densities`, with the
/// finest level's cap: what a frame draws when nothing is culled.
fn drawn_triangles(mesh: &RingMesh, densities: &DensityPlan, selection: &LevelSelection) -> u64 {
    let mut total = 0;
    for level in selection.drawn_levels() {
        let d = densities.levels[level as usize];
        total += mesh.triangles(level, d.body.k, d.outer.k, d.inner.k);
    }
    let f = selection.finest as usize;
    let k = densities.levels[f].body.k as usize;
    total
        + mesh.levels[f][k]
            .cap
            .iter()
            .map(|r| u64::from(r.end - r.start) / 3)
            .sum::<u64>()
}
