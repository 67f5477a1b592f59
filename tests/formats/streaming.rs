//! The DEM's streaming path: tiles from the pyramid through the tokio streamer, the LRU and
//! the GPU tile cache into the level textures.

use crate::common;

use globe::clipmap::ClipmapSettings;
use globe::render::TerrainRenderer;
use globe::render::formats::COLOR_FORMAT;
use globe::scenes::Scene;
use globe::terrain::Terrain;

/// The GPU fill from streamed tiles equals the CPU's f64 sampling of the same pyramid level
/// (the terrain function's twin) at every texel of every filled level.
#[test]
fn gpu_fill_from_tiles_matches_the_cpu_sampler() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let terrain = Terrain::embedded_earth().unwrap();
    let Some(dem) = terrain.dem().cloned() else {
        unreachable!()
    };
    for name in ["aircraft", "north-pole", "antimeridian"] {
        let scene = Scene::by_name(name).unwrap();
        let camera = scene.camera(|lat, lon| terrain.height_at_lat_lon_m(lat, lon));
        let mut r = TerrainRenderer::new(
            &ctx.device,
            ClipmapSettings::default(),
            terrain.clone(),
            COLOR_FORMAT,
        )
        .unwrap();
        let frame = common::render(ctx, &mut r, &camera, 320, 180);
        let sel = &frame.info.selection;
        let mut worst = (0.0f64, 0u32);
        for level in sel.coarsest.saturating_sub(1)..=sel.finest {
            let (grid, heights) = r.read_level(ctx, level).unwrap().expect("filled level");
            let pl = dem.level_for_texel(grid.band_limit_texel_m(dem.radius_m()));
            let s = grid.size as i64;
            for j in (0..s).step_by(7) {
                for i in (0..s).step_by(5) {
                    let (phi, theta) = grid.phi_theta_of(grid.gx0 + i, grid.gy0 + j);
                    let want = dem.height_band_limited_m(phi, theta, pl);
                    let got = heights[(j * s + i) as usize] as f64 + grid.ref_m;
                    let err = (got - want).abs();
                    if err > worst.0 {
                        worst = (err, level);
                    }
                }
            }
        }
        eprintln!(
            "{name}: levels {}..={}, worst |GPU − CPU| {:.4} m (level {})",
            sel.coarsest, sel.finest, worst.0, worst.1
        );
        assert!(worst.0 < 0.05, "{name}: fill differs by {} m", worst.0);
    }
}

use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use globe::instruments::bench::{self, BenchOptions};
use globe::render::offscreen::OffscreenFrame;
use globe::scenes::flight;
use globe::stream::source::TileSource;
use globe::stream::{FaultSettings, StreamSettings, TileData, TileError, TileKey, TileStreamer};

fn flight_options(latency_ms: u64, fail_rate: f64, cache_bytes: u64) -> BenchOptions {
    BenchOptions {
        scene: flight::NAME.into(),
        camera: None,
        path: None,
        frames: 24,
        warmup: 0,
        width: 192,
        height: 108,
        settings: ClipmapSettings::default(),
        stream: StreamSettings {
            cache_bytes,
            faults: FaultSettings {
                latency_ms,
                fail_rate,
                seed: 7,
                ..Default::default()
            },
            ..StreamSettings::default()
        },
        frame_interval: Some(Duration::from_millis(16)),
        look: globe::look::LookSettings::default(),
        lod: Default::default(),
        compare_plain_look: false,
        compare_vertex_stage: false,
        measure_error: false,
        passthrough: false,
    }
}

/// The flight from space to the ground with 0, 50 and 500 ms per tile: the decoded-tile cache
/// never exceeds its budget (set below the flight's 12 tiles, so it evicts), and once
/// streaming settles the last frame is pixel-identical to a render that had everything loaded.
/// (Frame times against latency are a benchmark: `globe bench --scene flight
/// --tile-latency-ms 0,50,500`.)
#[test]
fn flight_settles_to_the_loaded_image_within_the_memory_budget() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let terrain = Terrain::embedded_earth().unwrap();
    let budget = 3 << 20;
    for latency in [0, 50, 500] {
        let run = bench::run(
            ctx,
            &terrain,
            &flight_options(latency, 0.0, budget),
            |_, _| {},
        )
        .unwrap();
        let s = run.last_stream().unwrap().clone();
        eprintln!(
            "latency {latency} ms: cache max {} of {budget} B, loaded {}, settled {} in {:.2} s, \
             final vs loaded {:?} px, frames with levels waiting {}",
            run.cache_bytes_max(),
            s.stream.tiles_loaded,
            run.settled,
            run.settle_s.unwrap(),
            run.final_vs_loaded_px,
            run.frames.iter().filter(|f| f.levels_waiting > 0).count()
        );
        assert!(run.cache_bytes_max() <= budget);
        assert!(run.settled);
        assert_eq!(run.final_vs_loaded_px, Some(0));
    }
}

/// With one read in ten failing, the flight completes without a panic, failed reads are
/// retried, and every tile is eventually loaded: the settled frame equals the loaded one.
#[test]
fn flight_survives_ten_percent_read_failures() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let terrain = Terrain::embedded_earth().unwrap();
    let run = bench::run(
        ctx,
        &terrain,
        &flight_options(20, 0.1, 256 << 20),
        |_, _| {},
    )
    .unwrap();
    let s = run.last_stream().unwrap().clone();
    eprintln!(
        "10 % failures: retries {}, failed requests {}, loaded {}, requested {}, final vs loaded {:?} px",
        s.stream.retries,
        s.stream.tiles_failed,
        s.stream.tiles_loaded,
        s.stream.tiles_requested,
        run.final_vs_loaded_px
    );
    assert!(
        s.stream.retries > 0,
        "10 % failures but nothing was retried"
    );
    assert!(run.settled);
    assert_eq!(run.final_vs_loaded_px, Some(0));
}

/// A source that records which tiles it read, slowly.
struct Recording {
    reads: Mutex<Vec<TileKey>>,
    latency: Duration,
}

impl TileSource for Recording {
    fn read(&self, key: TileKey) -> Result<TileData, TileError> {
        self.reads.lock().unwrap().push(key);
        std::thread::sleep(self.latency);
        Ok(TileData {
            key,
            tile_size: 4,
            encoding: Default::default(),
            avg: vec![0; 16],
            min: vec![0; 16],
            max: vec![0; 16],
        })
    }
}

/// After a jump, tiles of the old place that were only queued are never read: at most the
/// reads already in flight at the jump finish, the rest are counted as cancelled.
#[test]
fn a_jump_cancels_the_old_places_queued_tiles() {
    let source = Arc::new(Recording {
        reads: Mutex::new(Vec::new()),
        latency: Duration::from_millis(100),
    });
    let settings = StreamSettings {
        max_in_flight: 2,
        ..StreamSettings::default()
    };
    let streamer = TileStreamer::new(source.clone(), &settings).unwrap();
    let place = |level: u32| -> HashMap<TileKey, u64> {
        (0..20)
            .map(|i| {
                (
                    TileKey {
                        level,
                        tx: i,
                        ty: 0,
                    },
                    i as u64,
                )
            })
            .collect()
    };
    streamer.want(&place(0));
    std::thread::sleep(Duration::from_millis(150));
    let read_before_jump = source.reads.lock().unwrap().len();
    streamer.want(&place(1));
    let deadline = Instant::now() + Duration::from_secs(10);
    let mut loaded_new = 0;
    while loaded_new < 20 && Instant::now() < deadline {
        if let Some(globe::stream::Completion::Loaded(t)) = streamer.wait(Duration::from_secs(1))
            && t.key.level == 1
        {
            loaded_new += 1;
        }
    }
    let reads = source.reads.lock().unwrap().clone();
    let old_reads = reads.iter().filter(|k| k.level == 0).count();
    let stats = streamer.stats();
    eprintln!(
        "old place: {read_before_jump} reads before the jump, {old_reads} in all; \
         cancelled {}; new place loaded {loaded_new}/20",
        stats.tiles_cancelled
    );
    assert_eq!(loaded_new, 20);
    // The reads started before the jump plus at most the two then in flight.
    assert!(old_reads <= read_before_jump + settings.max_in_flight);
    assert!(stats.tiles_cancelled as usize >= 20 - old_reads);
    // Most urgent first: the new place's first two reads were its two best priorities. They
    // run side by side (`max_in_flight` 2), so which enters the source first is up to the
    // thread scheduler: compare them as a set.
    let mut first_new: Vec<u32> = reads
        .iter()
        .filter(|k| k.level == 1)
        .take(2)
        .map(|k| k.tx)
        .collect();
    first_new.sort_unstable();
    assert_eq!(first_new, vec![0, 1]);
}

/// Regression (issue 10): a tile whose read finishes between a frame's `poll` and its `want`
/// is not queued and read a second time (the `leave_out` tile counts jumped now and then).
#[test]
fn issue_10_a_finished_tile_is_not_requested_again_before_it_is_received() {
    let source = Arc::new(Recording {
        reads: Mutex::new(Vec::new()),
        latency: Duration::ZERO,
    });
    let streamer = TileStreamer::new(source.clone(), &StreamSettings::default()).unwrap();
    let key = TileKey {
        level: 0,
        tx: 3,
        ty: 1,
    };
    let wanted = HashMap::from([(key, 0)]);
    streamer.want(&wanted);
    // The read finishes; its completion waits in the channel.
    let deadline = Instant::now() + Duration::from_secs(10);
    while source.reads.lock().unwrap().is_empty() || streamer.stats().in_flight > 0 {
        assert!(Instant::now() < deadline, "the read never finished");
        std::thread::sleep(Duration::from_millis(5));
    }
    // The render thread has not polled yet and still lacks the tile.
    streamer.want(&wanted);
    std::thread::sleep(Duration::from_millis(50));
    assert_eq!(streamer.stats().tiles_requested, 1);
    assert_eq!(source.reads.lock().unwrap().len(), 1, "read twice");
    let done = streamer.poll();
    assert_eq!(done.len(), 1);
    assert_eq!(done[0].key(), key);
    // Received: asking again (say, after the cache dropped it) is a new request.
    streamer.want(&wanted);
    assert_eq!(streamer.stats().tiles_requested, 2);
}

/// Regression (issue 10): the camera's ground height is read from decoded tiles in the CPU
/// cache, but a tile that sat on the GPU was never read again once the small LRU had evicted
/// it, so a view returned to after a trip elsewhere waited for its camera tile forever (the
/// `flight` test hung this way now and then under load). Garda → Everest → Garda with an LRU
/// of 8 tiles and a GPU cache that keeps every tile: the return settles.
#[test]
fn issue_10_a_camera_tile_evicted_from_the_cpu_cache_is_read_again() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let terrain = Terrain::embedded_earth().unwrap();
    let stream = StreamSettings {
        cache_bytes: 3 << 20,
        ..StreamSettings::default()
    };
    let mut r = streaming_renderer(ctx, terrain.clone(), stream);
    let camera = |name: &str| {
        Scene::by_name(name)
            .unwrap()
            .camera(|lat, lon| terrain.height_at_lat_lon_m(lat, lon))
    };
    let timeout = Duration::from_secs(30);
    for name in ["ground", "everest", "ground"] {
        let settled = r.settle(ctx, &camera(name), 320, 180, timeout);
        let feed = &r.feed().expect("a DEM streams").last;
        eprintln!(
            "{name}: settled {settled}, cache {} of {} B, {} tiles loaded",
            feed.cache_bytes, stream.cache_bytes, feed.stream.tiles_loaded
        );
        assert!(settled, "{name} did not settle within {timeout:?}");
    }
}

/// A tile corrupted in place after the file was opened is caught by its checksum: the read
/// fails with an error naming the tile (retried, reported in the frame's stream state), the
/// renderer keeps drawing the coarser levels and nothing panics. A file that grows under the
/// map keeps its tiles where they were: reads go on (tests/formats/file_changes.rs has the rest).
#[test]
fn corrupt_or_changed_pyramid_files_are_reported_not_fatal() {
    use std::io::{Seek, SeekFrom, Write};
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let Some(dem) = Terrain::embedded_earth().unwrap().dem().cloned() else {
        unreachable!()
    };
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("earth.globepyr");
    std::fs::copy(dem.pyramid().path(), &path).unwrap();
    let copy = globe::terrain::DemTerrain::open(&path, dem.radius_m()).unwrap();
    // Corrupt the finest level's tile under Lake Garda, in place (same length: no SIGBUS).
    let g = copy.pyramid().grid(0);
    let (row, col) = g.row_col_of(45.65, 10.65);
    let t = copy.pyramid().tile_size();
    let entry = copy
        .pyramid()
        .tile_entry(0, col as usize / t, row as usize / t)
        .unwrap();
    let mut f = std::fs::OpenOptions::new().write(true).open(&path).unwrap();
    f.seek(SeekFrom::Start(entry.offset + 100)).unwrap();
    f.write_all(&[0x55; 64]).unwrap();
    f.sync_all().unwrap();

    let camera = Scene::by_name("ground")
        .unwrap()
        .camera(|lat, lon| dem.height_at_m(lat, lon));
    let stream = StreamSettings {
        retries: 1,
        ..StreamSettings::default()
    };
    let mut r = streaming_renderer(ctx, Terrain::dem_terrain(copy.clone()), stream);
    let settled = r.settle(ctx, &camera, 160, 90, Duration::from_secs(3));
    let frame = OffscreenFrame::new(&ctx.device, 160, 90)
        .render_now(ctx, &mut r, &camera)
        .unwrap();
    let s = frame.info.stream.clone().unwrap();
    eprintln!(
        "corrupt tile: settled {settled}, failed {}, levels drawn {:?}, waiting {:?}, error: {:?}",
        s.stream.tiles_failed,
        frame.info.selection.drawn_levels(),
        frame.info.selection.waiting(),
        s.last_error
    );
    assert!(!settled);
    assert!(s.stream.tiles_failed > 0);
    assert!(
        s.last_error
            .as_deref()
            .unwrap_or("")
            .contains("checksum mismatch")
    );
    assert!(
        frame.info.selection.any_drawn(),
        "the coarser levels still show"
    );
    assert!(!frame.info.selection.waiting().is_empty());

    // Growth under the map: the tiles are where they were, so reads go on (CRC-checked), and
    // the corrupt tile still fails its CRC; `verify` still calls the file's growth an error.
    let mut f = std::fs::OpenOptions::new()
        .append(true)
        .open(&path)
        .unwrap();
    f.write_all(&[0; 4096]).unwrap();
    let source = globe::stream::MmapTileSource::new(copy.pyramid_arc());
    let key = |tx, ty| TileKey { level: 0, tx, ty };
    source.read(key(0, 0)).unwrap();
    let (tx, ty) = ((col as usize / t) as u32, (row as usize / t) as u32);
    let err = source.read(key(tx, ty)).unwrap_err();
    assert!(err.to_string().contains("checksum mismatch"), "{err}");
    let err = copy.pyramid().verify().unwrap_err();
    assert!(err.to_string().contains("grew"), "{err}");
}

/// Regression: a settled frame is the frame the view keeps. Tiles wanted only for the culling
/// bounds do not hold a frame back, and the culling runs after the frame's feed update, so a
/// frame whose bounds fell back to a coarser level still counted as settled: `north-pole`,
/// with reads 0–300 ms late, settled on 548 sectors and the next frame at rest drew 172.
/// Settling now waits (briefly) for those tiles too.
#[test]
fn a_settled_view_draws_what_the_next_frame_at_rest_draws() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let terrain = Terrain::embedded_earth().unwrap();
    for (scene, latency_max_ms) in [("north-pole", 300), ("north-pole", 0), ("ground", 300)] {
        let stream = StreamSettings {
            faults: FaultSettings {
                latency_ms: 0,
                latency_max_ms,
                fail_rate: 0.0,
                seed: 0x5EED,
            },
            ..StreamSettings::default()
        };
        let mut r = streaming_renderer(ctx, terrain.clone(), stream);
        let camera = Scene::by_name(scene)
            .unwrap()
            .camera(|lat, lon| r.terrain_height_m(lat, lon));
        let settled = common::render(ctx, &mut r, &camera, 320, 180);
        let again = common::render(ctx, &mut r, &camera, 320, 180);
        assert_eq!(
            settled.info.draw, again.info.draw,
            "{scene}, reads up to {latency_max_ms} ms late: settled on {} triangles, then drew {}",
            settled.info.draw.triangles, again.info.draw.triangles
        );
        assert!(
            settled.rgba == again.rgba,
            "{scene}, reads up to {latency_max_ms} ms late: the image changed after settling"
        );
    }
}

/// A renderer with the default mesh over `terrain`, its tiles streamed with `stream`.
fn streaming_renderer(
    ctx: &globe::render::GpuContext,
    terrain: Terrain,
    stream: StreamSettings,
) -> TerrainRenderer {
    TerrainRenderer::with_streaming(
        &ctx.device,
        ClipmapSettings::default(),
        terrain,
        COLOR_FORMAT,
        stream,
    )
    .unwrap()
}
