//! The close-up LOD methods on real renders (docs/close-up.md#close-up-modes): geomipmapping near the
//! viewer meets the error bar the clipmap meets, leaves no gap where it meets the clipmap
//! (coverage against the reference ray caster), and the wireframe overlay draws the edges of
//! every method.

use crate::common;

use common::render;

use globe::clipmap::ClipmapSettings;
use globe::geo::camera::Camera;
use globe::measure::{DEFAULT_THRESHOLD_PX, PixelSet, RayCaster, measure_frame};
use globe::plan::{LodMode, LodSettings};
use globe::planar::projgrid::ProjGridSettings;
use globe::procedural::DetailParams;
use globe::render::formats::COLOR_FORMAT;
use globe::render::{GpuContext, TerrainRenderer};
use globe::scenes::Scene;
use globe::terrain::Terrain;

fn renderer(ctx: &GpuContext, mode: LodMode) -> TerrainRenderer {
    renderer_with(
        ctx,
        LodSettings {
            mode,
            ..Default::default()
        },
    )
}

fn renderer_with(ctx: &GpuContext, lod: LodSettings) -> TerrainRenderer {
    let terrain = Terrain::embedded_earth()
        .expect("embedded Earth")
        .with_detail(Some(DetailParams::default()))
        .with_water_level(Some(0.0));
    let mut r = TerrainRenderer::new(
        &ctx.device,
        ClipmapSettings::default(),
        terrain,
        COLOR_FORMAT,
    )
    .unwrap();
    r.set_lod(&ctx.device, lod);
    r
}

fn cameras(terrain: &Terrain) -> Vec<(&'static str, Camera)> {
    let ground = Scene::by_name("ground")
        .unwrap()
        .camera(|lat, lon| terrain.height_at_lat_lon_m(lat, lon));
    // 30 m above the Alps north-west of Lake Garda, looking down a slope.
    let (lat, lon) = (46.0, 10.3);
    let alps = Camera {
        lat_deg: lat,
        lon_deg: lon,
        altitude_m: terrain.height_at_lat_lon_m(lat, lon) + 30.0,
        heading_deg: 45.0,
        pitch_deg: -20.0,
        roll_deg: 0.0,
        fov_y_deg: 60.0,
    };
    vec![("ground", ground), ("alps-30m", alps)]
}

#[test]
fn geomipmapping_meets_the_error_bar_without_gaps() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let (w, h) = (240, 135);
    let mut clip = renderer(ctx, LodMode::Clipmap);
    let mut geo = renderer(ctx, LodMode::Geomip);
    for (name, camera) in cameras(&geo.terrain) {
        let reference = RayCaster::new(&geo.terrain, &camera, w, h).cast(&PixelSet::All);
        let mut mismatches = Vec::new();
        for (mode, r) in [("clipmap", &mut clip), ("geomip", &mut geo)] {
            let frame = render(ctx, r, &camera, w, h);
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
                "{name} {mode}: ρ mean {:.3} p99 {:.3} max {:.3} px; coverage mismatches {} of {}",
                stats.mean_px,
                stats.p99_px,
                stats.max_px,
                coverage.mismatched(),
                coverage.compared
            );
            assert!(
                stats.pixels_measured > 10_000,
                "{name} {mode}: terrain in view"
            );
            assert!(
                stats.p99_px <= 1.0 && stats.max_px <= 2.0,
                "{name} {mode}: {stats:?}"
            );
            mismatches.push(coverage.mismatched());
            // The geomipmapping frame did draw patches (not the clipmap alone).
            if mode == "geomip" {
                let planar = frame.info.planar.as_ref().expect("geomipmapping drew");
                assert!(planar.patches > 10 && planar.triangles > 100, "{planar:?}");
            } else {
                assert!(frame.info.planar.is_none());
            }
        }
        // No gap where geomipmapping meets the clipmap: no more sky-versus-terrain
        // disagreements with the reference than the clipmap alone has, give or take 0.1 %.
        assert!(
            mismatches[1] <= mismatches[0] + (w * h / 1000) as usize,
            "{name}: coverage mismatches {} (clipmap {})",
            mismatches[1],
            mismatches[0]
        );
    }
}

/// The projected grid (error-bounded-projective-grid.md): its mesh alone errs where its cells'
/// a-priori bound exceeds γ; with those cells ray cast the frame's worst pixel is within γ
/// (1 px), and it covers what the reference sees as the clipmap does.
#[test]
fn projected_grid_ray_cast_bounds_the_error_by_gamma() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let (w, h) = (240, 135);
    let grid = ProjGridSettings {
        cols: 96,
        rows: 64,
        ..Default::default()
    };
    let lod = |ray_cast| LodSettings {
        mode: LodMode::Projgrid,
        projgrid: ProjGridSettings { ray_cast, ..grid },
        ..Default::default()
    };
    let mut clip = renderer(ctx, LodMode::Clipmap);
    let mut mesh = renderer_with(ctx, lod(false));
    let mut cast = renderer_with(ctx, lod(true));
    // One view (each renderer compiles its pipelines: minutes on a CPU rasteriser).
    let (name, camera) = cameras(&cast.terrain)[1];
    {
        let reference = RayCaster::new(&cast.terrain, &camera, w, h).cast(&PixelSet::All);
        let mut seen = Vec::new();
        for (mode, r) in [
            ("clipmap", &mut clip),
            ("grid", &mut mesh),
            ("grid+ray", &mut cast),
        ] {
            let frame = render(ctx, r, &camera, w, h);
            let stats = measure_frame(
                &frame,
                &camera,
                &r.terrain,
                Some(&reference),
                DEFAULT_THRESHOLD_PX,
            )
            .unwrap();
            let mismatched = stats.coverage.unwrap().mismatched();
            eprintln!(
                "{name} {mode}: ρ mean {:.3} p99 {:.3} max {:.3} px, error px {:.2} %; coverage mismatches {mismatched}; {:?}",
                stats.mean_px,
                stats.p99_px,
                stats.max_px,
                100.0 * stats.error_pixel_share,
                frame.info.planar.as_ref().and_then(|p| p.grid.clone())
            );
            assert!(
                stats.pixels_measured > 10_000,
                "{name} {mode}: terrain in view"
            );
            if mode != "clipmap" {
                let g = frame.info.planar.as_ref().and_then(|p| p.grid.as_ref());
                assert!(
                    g.is_some_and(|g| !g.indices.is_empty()),
                    "{name}: the grid drew"
                );
                assert_eq!(
                    frame.info.draw.ranges.len(),
                    0,
                    "{name}: the clipmap drew nothing"
                );
            }
            seen.push((stats, mismatched));
        }
        let (mesh_stats, cast_stats) = (seen[1].0, seen[2].0);
        assert!(
            cast_stats.max_px <= 1.0 && cast_stats.max_px <= mesh_stats.max_px,
            "{name}: ray cast max ρ {} px (mesh alone {} px)",
            cast_stats.max_px,
            mesh_stats.max_px
        );
        assert!(
            seen[2].1 <= seen[0].1 + (w * h / 200) as usize,
            "{name}: coverage mismatches {} (clipmap {})",
            seen[2].1,
            seen[0].1
        );
    }
}

/// The wireframe overlay darkens many terrain pixels (the edges) in both modes, leaves the sky
/// and the depth as they were.
#[test]
fn wireframe_overlay_draws_every_method_s_edges() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let (w, h) = (192, 108);
    for mode in [LodMode::Clipmap, LodMode::Geomip, LodMode::Projgrid] {
        let mut r = renderer(ctx, mode);
        let camera = cameras(&r.terrain)[1].1;
        let plain = render(ctx, &mut r, &camera, w, h);
        r.set_wireframe(&ctx.device, true);
        let wired = render(ctx, &mut r, &camera, w, h);
        // Terrain pixels the overlay darkened by more than a quarter of the range.
        let mut darkened = 0;
        let mut sky_changed = 0;
        for i in 0..(w * h) as usize {
            let mean = |f: &globe::render::RenderedFrame| {
                f.rgba[i * 4..i * 4 + 3]
                    .iter()
                    .map(|&c| c as f32)
                    .sum::<f32>()
                    / 3.0
            };
            if plain.depth[i] > 0.0 {
                darkened += usize::from(mean(&plain) - mean(&wired) > 64.0);
            } else {
                sky_changed +=
                    usize::from(plain.rgba[i * 4..i * 4 + 4] != wired.rgba[i * 4..i * 4 + 4]);
            }
        }
        eprintln!(
            "{mode:?}: {darkened} terrain pixels darkened by the edges, of {}",
            w * h
        );
        assert!(darkened > (w * h / 20) as usize, "{mode:?}: {darkened}");
        assert_eq!(sky_changed, 0, "{mode:?}: the overlay changed the sky");
        // The same depth everywhere: the overlay changes colours only.
        for y in (0..h).step_by(7) {
            for x in (0..w).step_by(7) {
                assert_eq!(
                    plain.depth_at(x, y),
                    wired.depth_at(x, y),
                    "{mode:?} ({x}, {y})"
                );
            }
        }
    }
}
