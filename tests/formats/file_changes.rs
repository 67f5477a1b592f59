//! Files changing under a running viewer (issue 16, item 5): the pyramid replaced by a rename,
//! deleted, truncated in place, appended to, each while a stream is open on a copy of the
//! embedded Earth's pyramid. Each change is reported once with its kind and the file's name,
//! nothing faults, and the stream (and, on the GPU, the view) goes on with what it can read.
//!
//! A SIGBUS would kill the test process, so a passing run is itself the evidence that none of
//! these reads touched a page past a file's end.

use crate::common;

use std::collections::HashMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use globe::clipmap::ClipmapSettings;
use globe::dem::{FileChange, Pyramid};
use globe::render::formats::COLOR_FORMAT;
use globe::render::offscreen::OffscreenFrame;
use globe::render::{RenderError, TerrainRenderer};
use globe::scenes::Scene;
use globe::stream::source::TileSource;
use globe::stream::{Completion, MmapTileSource, StreamSettings, TileData, TileKey, TileStreamer};
use globe::terrain::{DemTerrain, Terrain};

/// The watcher looks every 20 ms here (1 s by default) so the tests wait little.
fn settings() -> StreamSettings {
    StreamSettings {
        watch_interval: Duration::from_millis(20),
        retries: 0,
        ..StreamSettings::default()
    }
}

/// A copy of the embedded Earth's pyramid in `dir`, and its original bytes.
fn earth_copy(dir: &Path) -> (PathBuf, Vec<u8>) {
    let terrain = Terrain::embedded_earth().unwrap();
    let original = terrain.dem().unwrap().pyramid().path().to_path_buf();
    let path = dir.join("earth.globepyr");
    std::fs::copy(&original, &path).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    (path, bytes)
}

/// Waits for the watcher's next state that is a change.
fn next_change(streamer: &TileStreamer, timeout: Duration) -> Option<FileChange> {
    let deadline = Instant::now() + timeout;
    while Instant::now() < deadline {
        if let Some(change) = streamer.poll_file().into_iter().flatten().next() {
            return Some(change);
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    None
}

/// Streams `keys` and returns every completion, by key.
fn stream(streamer: &TileStreamer, keys: &[TileKey]) -> HashMap<TileKey, Completion> {
    let wanted: HashMap<TileKey, u64> = keys
        .iter()
        .enumerate()
        .map(|(i, k)| (*k, i as u64))
        .collect();
    streamer.want(&wanted);
    let mut done = HashMap::new();
    let deadline = Instant::now() + Duration::from_secs(60);
    while done.len() < keys.len() && Instant::now() < deadline {
        if let Some(c) = streamer.wait(Duration::from_millis(100)) {
            done.insert(c.key(), c);
        }
    }
    assert_eq!(done.len(), keys.len(), "every read finished");
    done
}

/// The tile as the file held it when it was copied.
fn same_as(reference: &Pyramid, tile: &TileData) -> bool {
    let k = tile.key;
    let want = reference
        .tile_verified(k.level as usize, k.tx as usize, k.ty as usize)
        .unwrap();
    *want.avg == *tile.avg && *want.min == *tile.min && *want.max == *tile.max
}

/// Opens `path` and starts a streamer on it; the first half of the tiles is read before the
/// change, so it happens mid-stream. Also checks that an unchanged file is reported as nothing.
fn open_and_stream(
    path: &Path,
) -> (
    Arc<Pyramid>,
    Arc<dyn TileSource>,
    TileStreamer,
    Vec<TileKey>,
) {
    let pyramid = Arc::new(Pyramid::open(path).unwrap());
    let source: Arc<dyn TileSource> = Arc::new(MmapTileSource::new(pyramid.clone()));
    let streamer = TileStreamer::new(source.clone(), &settings()).unwrap();
    let keys = common::all_tile_keys(&pyramid);
    let first = stream(&streamer, &keys[..keys.len() / 2]);
    assert!(first.values().all(|c| matches!(c, Completion::Loaded(_))));
    std::thread::sleep(Duration::from_millis(100));
    assert_eq!(
        streamer.poll_file(),
        Vec::<Option<FileChange>>::new(),
        "an unchanged file is no change"
    );
    (pyramid, source, streamer, keys)
}

/// Every tile of the mapping reads and equals the original, through the streamer and straight
/// from the source.
fn every_tile_reads_unchanged(
    source: &dyn TileSource,
    streamer: &TileStreamer,
    keys: &[TileKey],
    reference: &Pyramid,
) {
    for (k, c) in stream(streamer, keys) {
        match c {
            Completion::Loaded(tile) => assert!(same_as(reference, &tile), "{k} changed"),
            other => panic!("{k}: {other:?}"),
        }
    }
    for &k in keys {
        let tile = source.read(k).unwrap_or_else(|e| panic!("{k}: {e}"));
        assert!(same_as(reference, &tile), "{k} changed");
    }
}

/// The supported replacement: another file, shorter than the old one, written beside it and
/// renamed over the path mid-stream. The watcher says "replaced", and every tile of the old
/// mapping still reads and equals the old content: the map holds the old inode, whose length
/// no rename changes, so no access can fall past its end (SIGBUS cannot be hit this way).
#[test]
fn renamed_over_the_old_mapping_still_reads_every_tile_unchanged() {
    let dir = tempfile::tempdir().unwrap();
    let (path, bytes) = earth_copy(dir.path());
    let reference = Pyramid::from_bytes(bytes.clone(), "reference").unwrap();
    let (_pyramid, source, streamer, keys) = open_and_stream(&path);

    // A different, much shorter file: were the old mapping to see it, most tiles would lie
    // past its end.
    let partial = dir.path().join("earth.globepyr.partial");
    std::fs::write(&partial, &bytes[..bytes.len() / 5]).unwrap();
    std::fs::rename(&partial, &path).unwrap();

    let change = next_change(&streamer, Duration::from_secs(5)).expect("reported");
    eprintln!("{change}");
    assert_eq!(change, FileChange::Replaced { path: path.clone() });
    assert!(change.to_string().contains("earth.globepyr was replaced"));
    every_tile_reads_unchanged(source.as_ref(), &streamer, &keys, &reference);
    eprintln!("all {} tiles of the old mapping read and match", keys.len());
    std::thread::sleep(Duration::from_millis(100));
    assert!(streamer.poll_file().is_empty(), "reported once");
}

/// Deleted: the mapped inode lives on; every tile still reads, unchanged.
#[test]
fn deleted_file_keeps_reading_from_its_mapping() {
    let dir = tempfile::tempdir().unwrap();
    let (path, bytes) = earth_copy(dir.path());
    let reference = Pyramid::from_bytes(bytes, "reference").unwrap();
    let (_pyramid, source, streamer, keys) = open_and_stream(&path);
    std::fs::remove_file(&path).unwrap();
    let change = next_change(&streamer, Duration::from_secs(5)).expect("reported");
    eprintln!("{change}");
    assert_eq!(change, FileChange::Deleted { path: path.clone() });
    assert!(change.to_string().contains("earth.globepyr was deleted"));
    every_tile_reads_unchanged(source.as_ref(), &streamer, &keys, &reference);
}

/// Truncated in place (the unsupported case) to a length that is not a page multiple: the
/// watcher reports how many tiles, of which levels, are gone; each read of one of those is
/// refused with an error naming the tile (its pages are never touched), and every tile still
/// within the file reads unchanged.
#[test]
fn truncated_in_place_refuses_the_tiles_past_the_new_end() {
    let dir = tempfile::tempdir().unwrap();
    let (path, bytes) = earth_copy(dir.path());
    let reference = Pyramid::from_bytes(bytes.clone(), "reference").unwrap();
    let (pyramid, source, streamer, keys) = open_and_stream(&path);
    let cut_at = keys[keys.len() / 3];
    let entry = pyramid
        .tile_entry(
            cut_at.level as usize,
            cut_at.tx as usize,
            cut_at.ty as usize,
        )
        .unwrap();
    let new_len = entry.offset + 1000;
    std::fs::OpenOptions::new()
        .write(true)
        .open(&path)
        .unwrap()
        .set_len(new_len)
        .unwrap();

    let gone: Vec<TileKey> = keys
        .iter()
        .copied()
        .filter(|k| {
            let e = pyramid
                .tile_entry(k.level as usize, k.tx as usize, k.ty as usize)
                .unwrap();
            e.offset + e.len as u64 > new_len
        })
        .collect();
    let mut gone_levels: Vec<u32> = gone.iter().map(|k| k.level).collect();
    gone_levels.dedup();
    let change = next_change(&streamer, Duration::from_secs(5)).expect("reported");
    eprintln!("{change}");
    assert_eq!(
        change,
        FileChange::Truncated {
            path: path.clone(),
            from: bytes.len() as u64,
            to: new_len,
            unavailable: gone.len(),
            tiles: keys.len(),
            levels: gone_levels,
        }
    );
    assert!(
        change
            .to_string()
            .contains("earth.globepyr was truncated in place")
    );

    let done = stream(&streamer, &keys);
    for &k in &keys {
        let past_end = gone.contains(&k);
        match (&done[&k], source.read(k)) {
            (Completion::Loaded(a), Ok(b)) if !past_end => {
                assert!(
                    same_as(&reference, a) && same_as(&reference, &b),
                    "{k} changed"
                );
            }
            (Completion::Failed(_, a), Err(b)) if past_end => {
                for e in [a.to_string(), b.to_string()] {
                    assert!(e.contains(&k.to_string()), "names the tile: {e}");
                    assert!(e.contains("truncated in place"), "{e}");
                }
            }
            (a, b) => panic!("{k} (past the end: {past_end}): {a:?}, {b:?}"),
        }
    }
    eprintln!(
        "{} tiles within the file read, {} past its end refused",
        keys.len() - gone.len(),
        gone.len()
    );
    assert!(!gone.is_empty() && gone.len() < keys.len());
}

/// Appended to: the tiles are where they were and their CRCs still match, so the stream goes
/// on; each growth is reported once, with the lengths.
#[test]
fn appended_to_keeps_streaming_and_reports_each_growth_once() {
    let dir = tempfile::tempdir().unwrap();
    let (path, bytes) = earth_copy(dir.path());
    let reference = Pyramid::from_bytes(bytes.clone(), "reference").unwrap();
    let (_pyramid, source, streamer, keys) = open_and_stream(&path);
    let len = bytes.len() as u64;
    let mut f = std::fs::OpenOptions::new()
        .append(true)
        .open(&path)
        .unwrap();
    f.write_all(&[0xAB; 5000]).unwrap();
    let change = next_change(&streamer, Duration::from_secs(5)).expect("reported");
    eprintln!("{change}");
    assert_eq!(
        change,
        FileChange::Appended {
            path: path.clone(),
            from: len,
            to: len + 5000
        }
    );
    every_tile_reads_unchanged(source.as_ref(), &streamer, &keys, &reference);
    std::thread::sleep(Duration::from_millis(100));
    assert!(streamer.poll_file().is_empty(), "reported once");
    f.write_all(&[0xCD; 100]).unwrap();
    let again = next_change(&streamer, Duration::from_secs(5)).expect("reported");
    assert_eq!(
        again,
        FileChange::Appended {
            path,
            from: len,
            to: len + 5100
        }
    );
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Action {
    Rename,
    Delete,
    Truncate,
    Append,
}

/// The renderer through each change at 64×36: the view it had settles again at once (what is
/// cached keeps drawing), the frame's stream state carries the change (what the panel shows
/// and `globe render`/`bench` print), and a new view completes, except after a truncation,
/// where a view needing tiles past the new end waits and the settle error says why.
#[test]
fn the_view_keeps_drawing_through_each_change() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let earth = Terrain::embedded_earth().unwrap();
    let dem = earth.dem().unwrap().clone();
    let camera = |name: &str| {
        Scene::by_name(name)
            .unwrap()
            .camera(|lat, lon| dem.height_at_m(lat, lon))
    };
    let (a, b) = (camera("aircraft"), camera("everest"));
    for action in [
        Action::Rename,
        Action::Delete,
        Action::Truncate,
        Action::Append,
    ] {
        let dir = tempfile::tempdir().unwrap();
        let (path, bytes) = earth_copy(dir.path());
        let copy = DemTerrain::open(&path, dem.radius_m()).unwrap();
        let stream = StreamSettings {
            retries: 1,
            ..settings()
        };
        let mut r = TerrainRenderer::with_streaming(
            &ctx.device,
            ClipmapSettings::default(),
            Terrain::dem_terrain(copy),
            COLOR_FORMAT,
            stream,
        )
        .unwrap();
        let t = Instant::now();
        assert!(r.settle(ctx, &a, 64, 36, Duration::from_secs(60)));
        let settled_s = t.elapsed().as_secs_f64();
        match action {
            Action::Rename => {
                let partial = dir.path().join("earth.globepyr.partial");
                std::fs::write(&partial, &bytes[..4096]).unwrap();
                std::fs::rename(&partial, &path).unwrap();
            }
            Action::Delete => std::fs::remove_file(&path).unwrap(),
            // To the end of the finest level: the coarser levels (after it in the file) are
            // gone, so only what view `a` left cached of them still draws.
            Action::Truncate => {
                let pyr = Pyramid::from_bytes(bytes.clone(), "reference").unwrap();
                let e = pyr.tile_entry(1, 0, 0).unwrap();
                let f = std::fs::OpenOptions::new().write(true).open(&path).unwrap();
                f.set_len(e.offset).unwrap();
            }
            Action::Append => {
                let mut f = std::fs::OpenOptions::new()
                    .append(true)
                    .open(&path)
                    .unwrap();
                f.write_all(&[0; 4096]).unwrap();
            }
        }
        std::thread::sleep(Duration::from_millis(200));
        // The view it had: all cached, it settles again and draws.
        assert!(
            r.settle(ctx, &a, 64, 36, Duration::from_secs(10)),
            "{action:?}"
        );
        let frame = OffscreenFrame::new(&ctx.device, 64, 36)
            .render_now(ctx, &mut r, &a)
            .unwrap();
        let s = frame.info.stream.clone().unwrap();
        let change = s.file_change.clone().expect("the frame carries the change");
        eprintln!("{action:?} (first view settled in {settled_s:.2} s): {change}");
        assert!(frame.info.selection.any_drawn());
        assert_eq!(s.file_changes_total, 1, "{:?}", s.file_changes);
        assert_eq!(s.file_changes_after(0), std::slice::from_ref(&change));
        assert!(s.file_changes_after(1).is_empty());
        assert!(change.to_string().contains("earth.globepyr"));
        let kind_ok = match action {
            Action::Rename => matches!(change, FileChange::Replaced { .. }),
            Action::Delete => matches!(change, FileChange::Deleted { .. }),
            Action::Truncate => matches!(change, FileChange::Truncated { .. }),
            Action::Append => matches!(change, FileChange::Appended { .. }),
        };
        assert!(kind_ok, "{action:?}: {change:?}");

        // A new view.
        let t = Instant::now();
        let settled = r.settle_or_explain(
            ctx,
            &b,
            64,
            36,
            Duration::from_secs(if action == Action::Truncate { 3 } else { 60 }),
        );
        let frame = OffscreenFrame::new(&ctx.device, 64, 36)
            .render_now(ctx, &mut r, &b)
            .unwrap();
        eprintln!(
            "  new view in {:.2} s: {:?}; levels drawn {:?}, waiting {:?}",
            t.elapsed().as_secs_f64(),
            settled.as_ref().map_err(|e| e.to_string()),
            frame.info.selection.drawn_levels(),
            frame.info.selection.waiting()
        );
        if action == Action::Truncate {
            // Everest's coarse tiles were never cached and now lie past the end: the view waits
            // (nothing of it to draw), and the error says which tile and why.
            match settled {
                Err(e @ RenderError::NotSettled { .. }) => {
                    let msg = e.to_string();
                    assert!(msg.contains("the file was truncated in place"), "{msg}");
                    assert!(
                        msg.contains("earth.globepyr was truncated in place"),
                        "{msg}"
                    );
                }
                other => panic!("after the truncation: {other:?}"),
            }
            let failed = frame.info.stream.as_ref().unwrap().stream.tiles_failed;
            assert!(failed > 0, "the tiles past the end were refused");
            // Back to the first view: what is cached still draws it, settled.
            assert!(r.settle(ctx, &a, 64, 36, Duration::from_secs(10)));
        } else {
            settled.unwrap_or_else(|e| panic!("{action:?}: {e}"));
            assert!(frame.info.selection.any_drawn(), "{action:?}");
        }
    }
}
