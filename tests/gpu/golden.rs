//! Golden images: small renders of every named scene over the embedded Earth, the level overlay
//! and the error (ρ) overlay, compared with the PNGs stored in `tests/golden/`. The other
//! rendering tests check geometry; these are the ones that notice a change of shading, colour
//! or overlay. Every scene twice: with the plain look (tint, one light, flat sky, no water;
//! the images of the versions before the look, unchanged) and with the full look
//! (`<scene>-look.png`: surface types, water, sky, detail on).
//!
//! Tolerance (one place, quoted in docs/testing.md#golden-images): a pixel *differs* when any of its sRGB channels
//! differs from the golden by more than [`CHANNEL_TOLERANCE`]; an image fails when more than
//! [`MAX_DIFFERING_SHARE`] of its pixels differ, or when the mean absolute channel difference
//! over the whole image exceeds [`MAX_MEAN_CHANNEL_DIFF`] (a shift of every pixel too small to
//! count per pixel). Silhouette pixels may legitimately flip between sky and terrain across
//! drivers, so no single pixel has a hard bound. Measured on lavapipe: run to run (and with
//! `LP_NUM_THREADS=1`) the renders are bit-identical; scaling the shader's Lambert term by
//! 1.0007 changes ≤ 1/255 in up to 7 % of the pixels and passes; a 6 % change of one hypsometric
//! colour stop stays within 9/255 per pixel and fails on the mean (0.9–1.4/255).
//!
//! `GLOBE_BLESS=1 cargo test --test gpu golden::` writes the renders as the new goldens instead of
//! comparing. A missing golden fails and says so. On failure `<name>-actual.png` and
//! `<name>-diff.png` are written under `target/tmp/golden/` (the path is in the message).

use crate::common;

use std::path::{Path, PathBuf};

use globe::clipmap::ClipmapSettings;
use globe::look::LookSettings;
use globe::render::formats::COLOR_FORMAT;
use globe::render::{GpuContext, TerrainRenderer};
use globe::scenes::Scene;
use globe::terrain::Terrain;

/// Size of every golden: small enough for lavapipe on two cores, large enough to show the
/// levels and the heat map.
const WIDTH_PX: u32 = 192;
const HEIGHT_PX: u32 = 108;

/// A pixel differs when any channel (0–255, sRGB) differs by more than this.
const CHANNEL_TOLERANCE: u8 = 8;
/// An image fails when more than this share of its pixels differ.
const MAX_DIFFERING_SHARE: f64 = 0.005;
/// An image fails when its mean absolute channel difference (0–255 scale, RGB over all
/// pixels) exceeds this.
const MAX_MEAN_CHANNEL_DIFF: f64 = 0.5;

/// Environment variable that rewrites the goldens from the current renders.
const BLESS_VAR: &str = "GLOBE_BLESS";

/// The look a golden is drawn with.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Look {
    Plain,
    /// The default look without imagery (the surface types by height, slope and latitude).
    Full,
    /// The default look with the embedded imagery (what the CLI draws by default).
    Imagery,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Overlay {
    None,
    /// Each level in its own colour (`--overlay levels`).
    Levels,
    /// The ρ heat map (`--overlay error`).
    Error,
}

/// How one image differs from its golden.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Comparison {
    pixels: usize,
    /// Pixels with a channel off by more than [`CHANNEL_TOLERANCE`].
    differing: usize,
    /// Pixels with any channel off at all.
    touched: usize,
    max_channel_diff: u8,
    mean_channel_diff: f64,
}

impl Comparison {
    fn of(actual: &[u8], golden: &[u8]) -> Self {
        assert_eq!(actual.len(), golden.len(), "compare images of one size");
        let (mut differing, mut touched, mut max, mut sum) = (0, 0, 0u8, 0u64);
        for (a, g) in actual.chunks_exact(4).zip(golden.chunks_exact(4)) {
            let d = (0..4).map(|i| a[i].abs_diff(g[i])).max().unwrap_or(0);
            sum += (0..3).map(|i| u64::from(a[i].abs_diff(g[i]))).sum::<u64>();
            max = max.max(d);
            touched += usize::from(d > 0);
            differing += usize::from(d > CHANNEL_TOLERANCE);
        }
        let pixels = actual.len() / 4;
        Self {
            pixels,
            differing,
            touched,
            max_channel_diff: max,
            mean_channel_diff: sum as f64 / (3 * pixels.max(1)) as f64,
        }
    }

    fn differing_share(&self) -> f64 {
        self.differing as f64 / self.pixels.max(1) as f64
    }

    fn passes(&self) -> bool {
        self.differing_share() <= MAX_DIFFERING_SHARE
            && self.mean_channel_diff <= MAX_MEAN_CHANNEL_DIFF
    }

    fn describe(&self) -> String {
        format!(
            "{} of {} px differ by > {CHANNEL_TOLERANCE}/255 ({:.3} %, allowed {:.3} %); \
             {} px differ at all; max channel difference {}; mean {:.3}/255 (allowed {:.3})",
            self.differing,
            self.pixels,
            100.0 * self.differing_share(),
            100.0 * MAX_DIFFERING_SHARE,
            self.touched,
            self.max_channel_diff,
            self.mean_channel_diff,
            MAX_MEAN_CHANNEL_DIFF,
        )
    }
}

/// A picture of where two images differ: the actual image dimmed to a third in grey, pixels
/// beyond the tolerance in red, pixels that differ only within it in blue.
fn diff_image(actual: &[u8], golden: &[u8]) -> Vec<u8> {
    actual
        .chunks_exact(4)
        .zip(golden.chunks_exact(4))
        .flat_map(|(a, g)| {
            let d = (0..4).map(|i| a[i].abs_diff(g[i])).max().unwrap_or(0);
            let grey = ((u16::from(a[0]) + u16::from(a[1]) + u16::from(a[2])) / 9) as u8;
            if d > CHANNEL_TOLERANCE {
                [255, 0, 0, 255]
            } else if d > 0 {
                [grey, grey, 160, 255]
            } else {
                [grey, grey, grey, 255]
            }
        })
        .collect()
}

fn golden_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden")
}

/// Where failures leave their actual and diff images (`target/tmp/golden/`).
fn failure_dir() -> PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR")).join("golden")
}

fn blessing() -> bool {
    std::env::var(BLESS_VAR).as_deref() == Ok("1")
}

fn save_rgba(path: &Path, rgba: &[u8], width: u32, height: u32) {
    image::save_buffer(path, rgba, width, height, image::ColorType::Rgba8)
        .unwrap_or_else(|e| panic!("cannot write {}: {e}", path.display()));
}

/// A deliberately coarse mesh (`--phi-steps 64 --rings 1 --texture-size 16`): at the golden
/// size the default mesh keeps ρ below 0.05 px, so its heat map is one colour; this one
/// spreads ρ over 0–2.3 px in `everest` and shows the whole heat ramp.
fn coarse() -> ClipmapSettings {
    ClipmapSettings {
        phi_steps: 64,
        rings_per_level: 1,
        texture_size: 16,
        ..ClipmapSettings::default()
    }
}

/// Renders `scene` over the embedded Earth with `settings` and `overlay` at the golden size,
/// from a fresh renderer (no state carried over from another view), after streaming has
/// settled.
fn render(
    ctx: &GpuContext,
    scene: &str,
    settings: ClipmapSettings,
    overlay: Overlay,
    detail: bool,
    look: Look,
) -> Vec<u8> {
    let imagery = (look == Look::Imagery).then(|| {
        let img = globe::imagery::ImagerySource::Embedded
            .open()
            .unwrap()
            .unwrap();
        std::sync::Arc::new(img)
    });
    let terrain = Terrain::embedded_earth()
        .expect("embedded Earth")
        .with_detail(detail.then(globe::procedural::DetailParams::default))
        .with_water_level((look != Look::Plain).then_some(globe::look::SEA_LEVEL_M))
        .with_imagery(imagery);
    let mut r = TerrainRenderer::new(&ctx.device, settings, terrain, COLOR_FORMAT).unwrap();
    r.overlays.levels = overlay == Overlay::Levels;
    r.set_look(
        &ctx.device,
        if look != Look::Plain {
            LookSettings::default()
        } else {
            LookSettings::plain()
        },
    );
    let camera = Scene::by_name(scene)
        .unwrap_or_else(|| panic!("no scene {scene}"))
        .camera(|lat, lon| r.terrain_height_m(lat, lon));
    let mut frame = common::render(ctx, &mut r, &camera, WIDTH_PX, HEIGHT_PX);
    if overlay == Overlay::Error {
        let rho = globe::measure::rho_image(&frame, &camera, &r.terrain);
        globe::measure::overlay_heat(&mut frame.rgba, &rho, globe::measure::ERROR_OVERLAY_OPACITY);
    }
    frame.rgba
}

/// Renders `name` with the default mesh and compares it with `tests/golden/<name>.png` (or
/// writes it when blessing).
fn check(name: &str, scene: &str, overlay: Overlay) {
    check_with(
        name,
        scene,
        ClipmapSettings::default(),
        overlay,
        false,
        Look::Plain,
    );
}

/// `scene` with the full look, water and detail: `tests/golden/<scene>-look.png`.
fn check_look(scene: &str) {
    let name = format!("{scene}-look");
    check_with(
        &name,
        scene,
        ClipmapSettings::default(),
        Overlay::None,
        true,
        Look::Full,
    );
}

/// `scene` with the full look, water, detail and the embedded imagery (the CLI's default):
/// `tests/golden/<scene>-imagery.png`.
fn check_imagery(scene: &str) {
    let name = format!("{scene}-imagery");
    check_with(
        &name,
        scene,
        ClipmapSettings::default(),
        Overlay::None,
        true,
        Look::Imagery,
    );
}

fn check_with(
    name: &str,
    scene: &str,
    settings: ClipmapSettings,
    overlay: Overlay,
    detail: bool,
    look: Look,
) {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let started = std::time::Instant::now();
    let actual = render(ctx, scene, settings, overlay, detail, look);
    let golden_path = golden_dir().join(format!("{name}.png"));
    if blessing() {
        std::fs::create_dir_all(golden_dir()).unwrap();
        save_rgba(&golden_path, &actual, WIDTH_PX, HEIGHT_PX);
        eprintln!("{name}: blessed {}", golden_path.display());
        return;
    }
    let fail_dir = failure_dir();
    let actual_path = fail_dir.join(format!("{name}-actual.png"));
    let diff_path = fail_dir.join(format!("{name}-diff.png"));
    let keep_actual = || {
        std::fs::create_dir_all(&fail_dir).unwrap();
        save_rgba(&actual_path, &actual, WIDTH_PX, HEIGHT_PX);
    };
    let golden = match image::open(&golden_path) {
        Ok(img) => img.into_rgba8(),
        Err(e) => {
            keep_actual();
            panic!(
                "{name}: no usable golden at {} ({e}); look at the render in {}, then write \
                 it with {BLESS_VAR}=1 cargo test --test gpu golden::",
                golden_path.display(),
                actual_path.display()
            )
        }
    };
    if golden.dimensions() != (WIDTH_PX, HEIGHT_PX) {
        keep_actual();
        panic!(
            "{name}: golden {} is {}×{}, renders are {WIDTH_PX}×{HEIGHT_PX}; actual in {}; \
             re-bless with {BLESS_VAR}=1 cargo test --test gpu golden:: if the size changed on purpose",
            golden_path.display(),
            golden.width(),
            golden.height(),
            actual_path.display()
        );
    }
    let cmp = Comparison::of(&actual, golden.as_raw());
    eprintln!(
        "{name}: {} ({:.1} s)",
        cmp.describe(),
        started.elapsed().as_secs_f64()
    );
    if !cmp.passes() {
        keep_actual();
        save_rgba(
            &diff_path,
            &diff_image(&actual, golden.as_raw()),
            WIDTH_PX,
            HEIGHT_PX,
        );
        panic!(
            "{name}: render differs from {}: {}\n  actual: {}\n  diff (red: beyond tolerance, \
             blue: within): {}\n  if the change is intended, re-bless with {BLESS_VAR}=1 cargo \
             test --test gpu golden:: and look at the new PNGs before committing them",
            golden_path.display(),
            cmp.describe(),
            actual_path.display(),
            diff_path.display()
        );
    } else {
        // A passing run leaves no stale failure images behind.
        let _ = std::fs::remove_file(&actual_path);
        let _ = std::fs::remove_file(&diff_path);
    }
}

#[test]
fn space_imagery() {
    check_imagery("space");
}

#[test]
fn ground_imagery() {
    check_imagery("ground");
}

#[test]
fn space() {
    check("space", "space", Overlay::None);
}

#[test]
fn aircraft() {
    check("aircraft", "aircraft", Overlay::None);
}

#[test]
fn ground() {
    check("ground", "ground", Overlay::None);
}

#[test]
fn north_pole() {
    check("north-pole", "north-pole", Overlay::None);
}

#[test]
fn antimeridian() {
    check("antimeridian", "antimeridian", Overlay::None);
}

#[test]
fn everest() {
    check("everest", "everest", Overlay::None);
}

#[test]
fn aircraft_level_overlay() {
    check("aircraft-levels", "aircraft", Overlay::Levels);
}

#[test]
fn north_pole_level_overlay() {
    check("north-pole-levels", "north-pole", Overlay::Levels);
}

/// The error overlay as `globe render --overlay error` draws it with the default mesh.
#[test]
fn aircraft_error_overlay() {
    check("aircraft-error", "aircraft", Overlay::Error);
}

/// The error overlay over the coarse mesh: the heat ramp from blue to orange.
#[test]
fn everest_coarse_error_overlay() {
    check_with(
        "everest-coarse-error",
        "everest",
        coarse(),
        Overlay::Error,
        false,
        Look::Plain,
    );
}

/// The procedural detail (on by default in the viewer; the goldens above are the data alone):
/// the rolling ground at Garda with its bump shading, and Everest's rock.
#[test]
fn ground_with_detail() {
    check_with(
        "ground-detail",
        "ground",
        ClipmapSettings::default(),
        Overlay::None,
        true,
        Look::Plain,
    );
}

#[test]
fn everest_with_detail() {
    check_with(
        "everest-detail",
        "everest",
        ClipmapSettings::default(),
        Overlay::None,
        true,
        Look::Plain,
    );
}

#[test]
fn space_look() {
    check_look("space");
}

#[test]
fn aircraft_look() {
    check_look("aircraft");
}

#[test]
fn ground_look() {
    check_look("ground");
}

#[test]
fn north_pole_look() {
    check_look("north-pole");
}

#[test]
fn antimeridian_look() {
    check_look("antimeridian");
}

#[test]
fn everest_look() {
    check_look("everest");
}

/// Every named scene has a golden test above (a scene added to the registry must add one).
#[test]
fn every_named_scene_has_a_golden() {
    common::assert_covers_every_scene(
        &[
            "space",
            "aircraft",
            "ground",
            "north-pole",
            "antimeridian",
            "everest",
        ],
        "tests/gpu/golden.rs",
    );
}

/// The comparison itself, without a GPU: it fails when it should and the diff marks exactly
/// the pixels beyond the tolerance.
#[test]
fn comparison_fails_beyond_the_tolerance() {
    let pixels = 200 * 100;
    let golden: Vec<u8> = (0..pixels)
        .flat_map(|i| [(i % 251) as u8, (i % 163) as u8, (i % 97) as u8, 255])
        .collect();
    assert!(Comparison::of(&golden, &golden).passes());
    assert_eq!(Comparison::of(&golden, &golden).touched, 0);

    // Changes within the channel tolerance do not count, beyond it they do.
    let nudge = |img: &mut [u8], every: usize, by: u8| {
        for px in img.chunks_exact_mut(4).step_by(every) {
            px[1] = px[1].wrapping_add(by);
        }
    };
    let mut small = golden.clone();
    nudge(&mut small, 1, CHANNEL_TOLERANCE);
    let cmp = Comparison::of(&small, &golden);
    assert_eq!(cmp.differing, 0);
    assert_eq!(cmp.touched, pixels);

    // A share of pixels just under and just over the limit.
    let allowed = (MAX_DIFFERING_SHARE * pixels as f64) as usize;
    let mut few = golden.clone();
    nudge(&mut few, pixels / allowed, CHANNEL_TOLERANCE + 1);
    assert!(
        Comparison::of(&few, &golden).passes(),
        "{:?}",
        Comparison::of(&few, &golden)
    );
    let mut many = golden.clone();
    nudge(&mut many, pixels / (allowed + 2), 2 * CHANNEL_TOLERANCE);
    let cmp = Comparison::of(&many, &golden);
    assert!(cmp.differing > allowed && !cmp.passes(), "{cmp:?}");

    // A shift of every pixel below the per-pixel tolerance fails on the mean.
    let shift = MAX_MEAN_CHANNEL_DIFF.ceil() as u8 + 1;
    assert!(shift <= CHANNEL_TOLERANCE);
    let shifted: Vec<u8> = golden
        .chunks_exact(4)
        .flat_map(|p| {
            [
                p[0].saturating_add(shift),
                p[1].saturating_add(shift),
                p[2].saturating_add(shift),
                255,
            ]
        })
        .collect();
    let cmp = Comparison::of(&shifted, &golden);
    assert_eq!(cmp.differing, 0);
    assert!(!cmp.passes(), "{cmp:?}");

    // The diff is red exactly where a pixel is beyond the tolerance.
    let diff = diff_image(&many, &golden);
    let red = diff
        .chunks_exact(4)
        .filter(|p| p[..3] == [255, 0, 0])
        .count();
    assert_eq!(red, Comparison::of(&many, &golden).differing);
}
