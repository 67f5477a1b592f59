//! The sky-view table (`render::look`, `shaders/sky.wgsl`): with the eye inside the atmosphere
//! the sky pass reads one filtered texel of a per-frame table instead of integrating each
//! pixel's ray. It must look the same: every pixel within 2/255 of the per-pixel sky, the
//! sun's disk and its glow included; from space the per-pixel integral stays.
//!
//! Also here, the other two savings of a view from afar, each of which must change no pixel:
//! the sky pass over the ring of directions that can meet the shell, and the terrain's
//! look without the texture work that is constant there (`FrameInfo::far`).

use crate::common;

use globe::geo::camera::Camera;
use globe::render::TerrainRenderer;
use globe::scenes::{CameraSpec, Scene};

const WIDTH_PX: u32 = 320;
const HEIGHT_PX: u32 = 180;

/// The full look without the detail; `per_pixel`: the sky integrated per pixel throughout.
fn renderer(ctx: &globe::render::GpuContext, per_pixel: bool) -> TerrainRenderer {
    let mut r = common::full_look_renderer(ctx, false);
    r.switches.sky_per_pixel = per_pixel;
    r
}

/// The camera of a named scene (`spec` None) or of a `--camera` text, over `r`'s terrain.
fn camera_of(r: &TerrainRenderer, name: &str, spec: Option<&str>) -> Camera {
    match spec {
        Some(text) => CameraSpec::parse(text, globe::geo::EARTH_RADIUS_M)
            .unwrap()
            .camera(|lat, lon| r.terrain_height_m(lat, lon)),
        None => Scene::by_name(name)
            .unwrap()
            .camera(|lat, lon| r.terrain_height_m(lat, lon)),
    }
}

/// Per pixel, the largest difference of the colour channels of two frames (0–255).
fn channel_diffs(a: &[u8], b: &[u8]) -> Vec<u8> {
    a.chunks(4)
        .zip(b.chunks(4))
        .map(|(p, q)| (0..3).map(|c| p[c].abs_diff(q[c])).max().unwrap())
        .collect()
}

#[test]
fn the_table_sky_matches_the_per_pixel_sky() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    // Two named scenes and a view into the sun (35° up in the south-east) from 2 km.
    let views = [
        ("aircraft", None),
        ("ground", None),
        ("space", None),
        ("toward the sun", Some("45.6,10.6,2000,135,30")),
    ];
    for (name, spec) in views {
        let mut table = renderer(ctx, false);
        let camera = camera_of(&table, name, spec);
        let a = common::render(ctx, &mut table, &camera, WIDTH_PX, HEIGHT_PX);
        let from_table = table.sky_from_table();
        let mut per_pixel = renderer(ctx, true);
        let b = common::render(ctx, &mut per_pixel, &camera, WIDTH_PX, HEIGHT_PX);
        assert!(!per_pixel.sky_from_table());
        // Inside the atmosphere the table serves; from space every pixel integrates.
        assert_eq!(from_table, name != "space", "{name}: sky from the table");
        let diffs = channel_diffs(&a.rgba, &b.rgba);
        let max = diffs.iter().copied().max().unwrap();
        let mean = diffs.iter().map(|&d| d as f64).sum::<f64>() / diffs.len() as f64;
        let differing = diffs.iter().filter(|&&d| d > 0).count();
        println!("{name}: {differing} pixels differ, by at most {max}/255, mean {mean:.4}/255");
        assert!(max <= 2, "{name}: a pixel differs by {max}/255");
        assert!(mean <= 0.25, "{name}: mean difference {mean}/255");
    }
}

/// From outside the atmosphere the sky pass shades only the ring of directions that can meet
/// the shell and miss the terrain (`FrameInfo::sky_ring`); every pixel beyond it is black, as
/// the pass would make it, or terrain. Not one byte may differ from the sky shaded over the
/// whole frame: the disk in the middle, the disk running off the frame, a shell the eye's plane
/// cuts, and the limb from low above the shell.
#[test]
fn from_space_the_sky_shades_only_the_shells_ring() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let views = [
        ("space", None, true),
        (
            "the disk off the bottom",
            Some("-20,150,8000000,30,-45"),
            true,
        ),
        (
            "the shell beside the eye",
            Some("45.6,10.6,3000000,0,-40"),
            true,
        ),
        ("the limb from 400 km", Some("60,-40,400000,200,-10"), true),
        ("inside the shell", Some("45.6,10.6,50000,0,-10"), false),
    ];
    for (name, spec, ring) in views {
        let mut with_ring = renderer(ctx, false);
        let camera = camera_of(&with_ring, name, spec);
        let a = common::render(ctx, &mut with_ring, &camera, WIDTH_PX, HEIGHT_PX);
        assert_eq!(
            a.info.sky_ring.is_some(),
            ring,
            "{name}: {:?}",
            a.info.sky_ring
        );
        let mut whole = renderer(ctx, false);
        whole.switches.sky_whole_frame = true;
        let b = common::render(ctx, &mut whole, &camera, WIDTH_PX, HEIGHT_PX);
        assert!(b.info.sky_ring.is_none());
        let differing = a
            .rgba
            .chunks(4)
            .zip(b.rgba.chunks(4))
            .filter(|(p, q)| p != q)
            .count();
        // The ring's share of the frame: pixels whose ray it contains (its Rust twin).
        let share = a.info.sky_ring.map_or(1.0, |r| {
            let inside = (0..WIDTH_PX * HEIGHT_PX)
                .filter(|i| {
                    let d = globe::geo::camera::pixel_ray_view(
                        &camera,
                        i % WIDTH_PX,
                        i / WIDTH_PX,
                        WIDTH_PX,
                        HEIGHT_PX,
                    );
                    r.contains(d)
                })
                .count();
            inside as f64 / f64::from(WIDTH_PX * HEIGHT_PX)
        });
        println!(
            "{name}: sky ring over {:.1} % of the frame, {differing} pixels differ",
            100.0 * share
        );
        assert_eq!(differing, 0, "{name}: pixels the ring changed");
        if name == "space" {
            // The glow of 20 000 km up is a thin ring around a disk a fifth of the frame across.
            assert!(
                share < 0.05,
                "space: the ring covers {share:.3} of the frame"
            );
        }
    }
}

/// From afar (`FrameInfo::shading`: every pixel's footprint at least `FAR_FOOTPRINT_M`) the
/// terrain's shading leaves out the proto-textures' and waves' per-pixel reads and the boundary
/// noise, which are constant there, and from high enough the bump octaves, which no pixel can
/// show there (`bump_can_show`). The image must be the same as with them: views from space,
/// over the Alps (snow, rock and their slopes) and along the horizon from just above the
/// threshold, where footprints are longest and most oblique.
#[test]
fn from_afar_the_look_leaves_out_its_constant_texture_work() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let views = [
        ("space", None),
        ("over the Alps", Some("46.5,9.5,1000000,0,-45")),
        ("the horizon from low", Some("30,-30,300000,60,-12")),
    ];
    for (name, spec) in views {
        let mut far = common::full_look_renderer(ctx, true);
        let camera = camera_of(&far, name, spec);
        let a = common::render(ctx, &mut far, &camera, WIDTH_PX, HEIGHT_PX);
        let shading = a.info.shading;
        assert!(shading.far, "{name}: drawn as seen from afar");
        // From 20 000 km every octave of two pixels is in the levels' geometry.
        if name == "space" {
            assert!(!shading.bump, "space: bump octaves compiled in");
        }
        let mut near = common::full_look_renderer(ctx, true);
        near.switches.all_shading = true;
        let b = common::render(ctx, &mut near, &camera, WIDTH_PX, HEIGHT_PX);
        assert_eq!(b.info.shading, globe::render::terrain::Shading::ALL);
        let diffs = channel_diffs(&a.rgba, &b.rgba);
        let max = diffs.iter().copied().max().unwrap();
        let differing = diffs.iter().filter(|&&d| d > 0).count();
        println!("{name} ({shading:?}): {differing} pixels differ, by at most {max}/255");
        assert!(max <= 1, "{name}: a pixel differs by {max}/255");
        assert!(
            differing * 1000 <= diffs.len(),
            "{name}: {differing} pixels differ"
        );
    }
}
