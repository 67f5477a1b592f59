//! The soak (`globe bench --scene soak`), short: a seeded random flight over the embedded
//! Earth with one read in twenty failing and 0–200 ms per read, short legs so that it visits
//! the ground, a pole, the antimeridian and jumps within seconds. Every settle point must equal
//! a fault-free render, no frame may read the file, memory stays within its budgets. The
//! ten-minute run over a 30″ pyramid is in docs/streaming.md#soak.

use crate::common;

use std::time::Duration;

use globe::clipmap::ClipmapSettings;
use globe::dem::frame_reads;
use globe::instruments::soak::{self, SoakOptions};
use globe::scenes::soak_path::{LegSeconds, Place};
use globe::stream::StreamSettings;
use globe::terrain::Terrain;

#[test]
fn a_short_soak_holds_its_budgets_and_settles_to_the_fault_free_image() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let terrain = Terrain::embedded_earth().unwrap();
    let cache_bytes = 4 << 20;
    let options = SoakOptions {
        seconds: 14.0,
        seed: 3,
        legs: LegSeconds {
            fly: (1.5, 2.5),
            hold: (0.8, 1.2),
            jump_fraction: 0.3,
        },
        width: 160,
        height: 90,
        settings: ClipmapSettings::default(),
        stream: SoakOptions::default_faults(
            StreamSettings {
                // Ten tiles: the flight evicts.
                cache_bytes,
                ..StreamSettings::default()
            },
            3,
        ),
        look: Default::default(),
        lod: Default::default(),
        frame_interval: None,
        settle_timeout: Duration::from_secs(120),
        // Fourteen seconds are mostly warm-up (each new kind of view compiles pipelines in
        // both renderers): memory is held to its budget by the ten-minute soak (docs/streaming.md#soak), here
        // only against gross growth.
        rss_slack_bytes: 512 << 20,
        mismatch_dir: None,
    };
    let run = soak::run(ctx, &terrain, &options, |_| {}).unwrap();
    let f = run.findings();
    eprintln!("{}", run.to_json());
    assert_eq!(f.frames_reading_the_file, 0);
    assert!(f.settle_points >= 5, "{} settle points", f.settle_points);
    assert_eq!(f.settle_failures, 0);
    // Every settle point equals the fault-free render, to the bit (docs/streaming.md#a-settled-view-does-not-depend-on-the-path-to-it: what made
    // a renderer's past show in its settled frame).
    assert!(f.passed(), "{:?}", f.failures());
    assert_eq!(f.settle_points_differing, 0);
    for place in [Place::Ground, Place::Pole, Place::Antimeridian] {
        assert!(
            run.settles.iter().any(|p| p.place == place),
            "no settle point at {place:?}"
        );
    }
    assert!(f.jumps >= 1);
    assert!(f.retries > 0, "5 % of reads fail, yet none was retried");
    // Within its budget, or holding only the tiles the frame needs (docs/streaming.md#budgets-at-their-edges).
    assert_eq!(f.frames_over_cache_budget, 0);
    assert!(f.cache_bytes_max <= cache_bytes.max(f.cache_kept_bytes_max));
    assert_eq!(f.rss_anon_max.is_some(), cfg!(target_os = "linux"));
}

/// The count behind "no frame reads the file" sees a real read: the terrain's height (read
/// straight from the pyramid) asked for inside a frame scope counts, outside it does not.
#[test]
fn a_pyramid_read_inside_a_frame_is_counted() {
    let terrain = Terrain::embedded_earth().unwrap();
    let here = frame_reads::reads_in_frames_on_this_thread;
    let before = here();
    let h = terrain.height_at_lat_lon_m(27.988, 86.925);
    assert!(h > 3000.0, "Everest at {h} m");
    assert_eq!(here(), before);
    {
        let _frame = frame_reads::frame_scope();
        terrain.height_at_lat_lon_m(45.65, 10.65);
    }
    assert!(here() > before, "a read in a frame was not counted");
}

/// A settled view is the same however the renderer got there: one that flew in from 40 km
/// away in small steps (its level textures filled strip by strip, toroidally) draws the same
/// pixels as a fresh renderer that filled every level at once.
#[test]
fn a_settled_view_does_not_depend_on_the_path_to_it() {
    use globe::render::offscreen::OffscreenFrame;
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let terrain = Terrain::embedded_earth().unwrap();
    let ground = |lat: f64, lon: f64| terrain.height_at_lat_lon_m(lat, lon);
    let view = globe::scenes::find("aircraft").unwrap().camera(ground);
    let target = OffscreenFrame::new(&ctx.device, 240, 135);
    let new = || common::default_renderer(ctx, &terrain);
    let mut flown = new();
    let steps = 24;
    for i in 0..=steps {
        let f = i as f64 / steps as f64;
        let mut c = view;
        c.lat_deg += 0.25 * (1.0 - f);
        c.lon_deg -= 0.3 * (1.0 - f);
        c.heading_deg += 20.0 * (1.0 - f);
        // Settled at each step: every strip is filled from complete data.
        target.render(ctx, &mut flown, &c).unwrap();
    }
    let a = target.render(ctx, &mut flown, &view).unwrap();
    let b = target.render(ctx, &mut new(), &view).unwrap();
    let differ = globe::instruments::bench::pixels_differing(&a, &b);
    assert_eq!(
        differ, 0,
        "{differ} px differ between the flown and the fresh renderer"
    );
}
