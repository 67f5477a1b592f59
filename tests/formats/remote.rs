//! Remote pyramids over real servers started here on loopback (free ports): nginx serving the
//! file with range requests, moto's S3 server (`python3 -m moto.server`), and a misbehaving
//! server written below (500s, short bodies, a wrong Content-Range, corrupt bytes). Each test
//! skips when its server is missing, and fails instead with `GLOBE_REQUIRE_DATA=1`
//! (`scripts/test.sh` installs nginx from apt and moto from pip).

use crate::common;

use std::collections::HashMap;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU8, Ordering};
use std::time::{Duration, Instant};

use globe::dem::pyramid::Pyramid;
use globe::stream::source::{MmapTileSource, TileSource};
use globe::stream::{
    Completion, RemoteOptions, RemoteTileSource, StreamSettings, TileKey, TileStreamer,
};
use globe::terrain::Terrain;

/// False (skip) when a server is missing; a failure with `GLOBE_REQUIRE_DATA=1`.
fn have(tool: &str, found: bool, install: &str) -> bool {
    if !found {
        assert!(
            std::env::var("GLOBE_REQUIRE_DATA").as_deref() != Ok("1"),
            "GLOBE_REQUIRE_DATA=1 but {tool} is missing ({install})"
        );
        eprintln!("skipped: {tool} is missing ({install})");
    }
    found
}

fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// Waits until something accepts connections on `port` (or the child exited).
fn wait_listening(port: u16, child: &mut Child, what: &str) {
    let deadline = Instant::now() + Duration::from_secs(60);
    while TcpStream::connect(("127.0.0.1", port)).is_err() {
        if let Ok(Some(status)) = child.try_wait() {
            panic!("{what} exited before listening on {port}: {status}");
        }
        assert!(Instant::now() < deadline, "{what} never listened on {port}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// A server process this test started; killed (by its pid) when dropped.
struct Server {
    child: Child,
    port: u16,
    _dir: tempfile::TempDir,
}

impl Server {
    fn stop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        self.stop();
    }
}

fn nginx_binary() -> Option<PathBuf> {
    ["/usr/sbin/nginx", "/usr/local/sbin/nginx", "/usr/bin/nginx"]
        .iter()
        .map(PathBuf::from)
        .find(|p| p.is_file())
}

/// nginx as this user, in the foreground, its config, pid and logs in a temp dir, serving
/// `root` on `port` (range requests are nginx's default for static files).
fn nginx_on(root: &Path, port: u16) -> Option<Server> {
    let bin = nginx_binary();
    if !have("nginx", bin.is_some(), "apt-get install nginx") {
        return None;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().display();
    // One process (`master_process off`), so killing it leaves no worker behind. Run as root
    // (a CI container), nginx would switch to `nobody`, who cannot read the temp dir.
    use std::os::unix::fs::MetadataExt;
    let root_user = std::fs::metadata("/proc/self").map(|m| m.uid()).ok() == Some(0);
    let conf = format!(
        "daemon off;\nmaster_process off;\npid {d}/nginx.pid;\nerror_log {d}/error.log;\n{}\
         events {{ worker_connections 64; }}\n\
         http {{\n  access_log {d}/access.log;\n  client_body_temp_path {d}/body;\n  \
         proxy_temp_path {d}/proxy;\n  fastcgi_temp_path {d}/fastcgi;\n  uwsgi_temp_path {d}/uwsgi;\n  \
         scgi_temp_path {d}/scgi;\n  server {{\n    listen 127.0.0.1:{port};\n    root {};\n  }}\n}}\n",
        if root_user { "user root;\n" } else { "" },
        root.display()
    );
    std::fs::write(dir.path().join("nginx.conf"), conf).unwrap();
    let mut child = Command::new(bin.unwrap())
        .arg("-p")
        .arg(dir.path())
        .arg("-e")
        .arg(dir.path().join("error.log"))
        .arg("-c")
        .arg(dir.path().join("nginx.conf"))
        .stdout(Stdio::null())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("start nginx");
    wait_listening(port, &mut child, "nginx");
    Some(Server {
        child,
        port,
        _dir: dir,
    })
}

fn moto_available() -> bool {
    Command::new("python3")
        .args(["-c", "import moto.server, boto3"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// moto's S3 server on a free port, with `file` uploaded as s3://globe-test/earth.globepyr.
fn moto_with(file: &Path) -> Option<Server> {
    if !have(
        "moto (S3 server)",
        moto_available(),
        "python3 -m pip install 'moto[server]'",
    ) {
        return None;
    }
    let dir = tempfile::tempdir().unwrap();
    let port = free_port();
    let mut child = Command::new("python3")
        .args([
            "-m",
            "moto.server",
            "-H",
            "127.0.0.1",
            "-p",
            &port.to_string(),
        ])
        .current_dir(dir.path())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("start moto");
    wait_listening(port, &mut child, "moto");
    let upload = format!(
        "import boto3\n\
         s3 = boto3.client('s3', endpoint_url='http://127.0.0.1:{port}', region_name='us-east-1',\n\
         aws_access_key_id='testing', aws_secret_access_key='testing')\n\
         s3.create_bucket(Bucket='globe-test')\n\
         s3.upload_file('{}', 'globe-test', 'earth.globepyr')\n",
        file.display()
    );
    let status = Command::new("python3")
        .args(["-c", &upload])
        .status()
        .unwrap();
    assert!(status.success(), "uploading to moto failed");
    Some(Server {
        child,
        port,
        _dir: dir,
    })
}

/// The embedded Earth's pyramid (ETOPO5 at 10′, 5 levels), copied into a folder to serve.
fn served_copy() -> (tempfile::TempDir, PathBuf) {
    let terrain = Terrain::embedded_earth().unwrap();
    let src = terrain.dem().unwrap().pyramid().path().to_path_buf();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("earth.globepyr");
    std::fs::copy(src, &path).unwrap();
    (dir, path)
}

/// Options for the tests: nothing prefetched (every tile crosses the network), the disk cache
/// in `cache`.
fn options(cache: &Path) -> RemoteOptions {
    RemoteOptions {
        disk_cache_dir: Some(cache.to_path_buf()),
        prefetch_bytes: 0,
        ..RemoteOptions::default()
    }
}

/// Streams every tile of `remote` through the streamer (all wanted at once, so neighbours
/// share requests) and checks each against the local file's tile; tiles that fail are asked
/// for again until `deadline`. Returns the streamer's failed-request count.
fn stream_all_equal(remote: &Arc<Pyramid>, local: &Arc<Pyramid>, deadline: Duration) -> u64 {
    let source: Arc<dyn TileSource> = Arc::new(RemoteTileSource::new(remote.clone()).unwrap());
    stream_all_from(source, local, deadline)
}

/// As [`stream_all_equal`], from any source of `local`'s tiles.
fn stream_all_from(source: Arc<dyn TileSource>, local: &Arc<Pyramid>, deadline: Duration) -> u64 {
    let keys = common::all_tile_keys(local);
    stream_keys(
        source,
        &keys,
        local,
        deadline,
        &StreamSettings::default(),
        &mut |_, _| {},
    )
}

/// Streams `keys` from `source`, each checked against `local`'s tile; `event(loaded, failed)`
/// is called after each completion. Returns the streamer's failed-request count.
fn stream_keys(
    source: Arc<dyn TileSource>,
    keys: &[TileKey],
    local: &Arc<Pyramid>,
    deadline: Duration,
    settings: &StreamSettings,
    event: &mut dyn FnMut(usize, usize),
) -> u64 {
    let mmap = MmapTileSource::new(local.clone());
    let streamer = TileStreamer::new(source, settings).unwrap();
    let (mut loaded, mut failed) = (0, 0);
    let mut missing: HashMap<TileKey, u64> = keys
        .iter()
        .enumerate()
        .map(|(i, k)| (*k, i as u64))
        .collect();
    let until = Instant::now() + deadline;
    streamer.want(&missing);
    while !missing.is_empty() {
        assert!(
            Instant::now() < until,
            "{} tiles never arrived",
            missing.len()
        );
        match streamer.wait(Duration::from_millis(200)) {
            Some(Completion::Loaded(tile)) => {
                let want = mmap.read(tile.key).unwrap();
                assert_eq!(tile.avg, want.avg, "{}", tile.key);
                assert_eq!(tile.min, want.min, "{}", tile.key);
                assert_eq!(tile.max, want.max, "{}", tile.key);
                missing.remove(&tile.key);
                loaded += 1;
                event(loaded, failed);
            }
            Some(Completion::Failed(key, e)) => {
                eprintln!("failed, asked again: {key}: {e}");
                failed += 1;
                event(loaded, failed);
            }
            Some(Completion::Cancelled(_)) | None => {}
        }
        streamer.want(&missing);
    }
    streamer.stats().tiles_failed
}

/// Over nginx: the header and index validate as the file's; every tile streamed equals the
/// local file's; only the tiles' bytes are requested (coalescing merges touching ranges, never
/// gaps); a second open with the same disk cache reads every tile from disk (no request); a
/// cached tile corrupted on disk is refused by its CRC, removed and fetched again.
#[test]
fn http_tiles_equal_the_local_files_and_a_second_visit_costs_no_request() {
    let (root, path) = served_copy();
    let Some(nginx) = nginx_on(root.path(), free_port()) else {
        return;
    };
    let url = format!("http://127.0.0.1:{}/earth.globepyr", nginx.port);
    let cache = tempfile::tempdir().unwrap();
    let local = Arc::new(Pyramid::open(&path).unwrap());
    let remote = Arc::new(Pyramid::open_remote(&url, options(cache.path())).unwrap());
    assert_eq!(remote.info().tiles, local.info().tiles);
    assert_eq!(remote.levels(), local.levels());
    assert_eq!(remote.path(), Path::new(&url));
    let store = remote.remote().unwrap().clone();
    let opened = store.stats();
    stream_all_equal(&remote, &local, Duration::from_secs(120));
    let s = store.stats();
    // Throughput against the local file's map in one run, the same pipeline and checks, on
    // the level-0 tiles off the polar rows (none of them in memory): a figure.
    let l0 = local.levels()[0];
    let keys: Vec<TileKey> = common::all_tile_keys(&local)
        .into_iter()
        .filter(|k| k.level == 0 && k.ty > 0 && (k.ty as usize) < l0.tiles_y - 1)
        .collect();
    let settings = StreamSettings::default();
    let timed = |source: Arc<dyn TileSource>| {
        let t = Instant::now();
        stream_keys(
            source,
            &keys,
            &local,
            Duration::from_secs(120),
            &settings,
            &mut |_, _| {},
        );
        t.elapsed().as_secs_f64()
    };
    let fresh = tempfile::tempdir().unwrap();
    let cold = Arc::new(Pyramid::open_remote(&url, options(fresh.path())).unwrap());
    let remote_s = timed(Arc::new(RemoteTileSource::new(cold).unwrap()));
    let local_s = timed(Arc::new(MmapTileSource::new(local.clone())));
    eprintln!(
        "{} level-0 tiles through the streamer: nginx {remote_s:.3} s, local map {local_s:.3} s: \
         remote/local throughput {:.3}",
        keys.len(),
        local_s / remote_s
    );
    let tiles = local.info().tiles as u64;
    let tile_bytes = local.info().tile_bytes;
    eprintln!(
        "nginx: {tiles} tiles in {} requests ({} at open), {} B requested for {} B of tiles",
        s.requests - opened.requests,
        opened.requests,
        s.bytes_requested - opened.bytes_requested,
        s.tile_bytes_used
    );
    // The polar rows were fetched at open (DemTerrain's poles): resident, no request.
    assert!(s.resident_hits > 0);
    assert_eq!(s.tiles_fetched + s.resident_hits, tiles);
    assert_eq!(s.tile_bytes_used, s.tiles_fetched * tile_bytes);
    assert_eq!(
        s.bytes_requested - opened.bytes_requested,
        s.tile_bytes_used
    );
    assert!(s.requests - opened.requests <= s.tiles_fetched);
    assert_eq!((s.request_errors, s.rejected_tiles), (0, 0));
    // The synchronous readers agree too (fetched blocking, through the same store).
    for (lat, lon) in [(45.6, 10.6), (27.98, 86.92), (-89.9, 0.0), (0.0, 179.99)] {
        for level in 0..local.level_count() {
            assert_eq!(
                remote.sample(lat, lon, level),
                local.sample(lat, lon, level),
                "{lat}, {lon}, level {level}"
            );
        }
    }

    // A second visit: the disk cache serves every tile.
    let again = Arc::new(Pyramid::open_remote(&url, options(cache.path())).unwrap());
    let store2 = again.remote().unwrap().clone();
    let opened2 = store2.stats();
    let source = RemoteTileSource::new(again.clone()).unwrap();
    for k in common::all_tile_keys(&again) {
        source.read(k).unwrap();
    }
    let s2 = store2.stats();
    eprintln!(
        "second visit: {} disk hits, {} requests after open",
        s2.disk_hits,
        s2.requests - opened2.requests
    );
    assert_eq!(s2.requests, 1, "the header only (one request: it is short)");
    assert_eq!(
        s2.disk_hits, tiles,
        "the polar rows at open, the rest streamed"
    );

    // A cached tile corrupted on disk: refused, removed, fetched again.
    let cached: Vec<PathBuf> = walk(cache.path())
        .into_iter()
        .filter(|p| p.extension().is_some_and(|e| e == "tile"))
        .collect();
    assert_eq!(cached.len() as u64, tiles);
    let victim = cached
        .iter()
        .find(|p| p.file_name().unwrap() == "22.tile")
        .unwrap();
    let mut bytes = std::fs::read(victim).unwrap();
    bytes[100] ^= 0x55;
    std::fs::write(victim, &bytes).unwrap();
    let third = Arc::new(Pyramid::open_remote(&url, options(cache.path())).unwrap());
    let store3 = third.remote().unwrap().clone();
    let before = store3.stats();
    // Index 22: level 0 tile (4, 2) (9 × 5 tiles), not a polar row.
    let key = TileKey {
        level: 0,
        tx: 4,
        ty: 2,
    };
    let tile = RemoteTileSource::new(third.clone())
        .unwrap()
        .read(key)
        .unwrap();
    assert_eq!(
        tile.avg,
        MmapTileSource::new(local.clone()).read(key).unwrap().avg
    );
    let after = store3.stats();
    assert_eq!(after.requests - before.requests, 1);
    assert_eq!(after.disk_hits, before.disk_hits);
    assert_eq!(std::fs::read(victim).unwrap().len(), bytes.len());
    assert_ne!(
        std::fs::read(victim).unwrap(),
        bytes,
        "rewritten from the server"
    );
}

fn walk(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            out.extend(walk(&p));
        } else {
            out.push(p);
        }
    }
    out
}

/// Over moto's S3 server (`s3://bucket/key`, endpoint and credentials as `object_store`'s AWS
/// settings): every tile equals the local file's, CRC-checked.
#[test]
fn s3_tiles_equal_the_local_files() {
    let (_root, path) = served_copy();
    let Some(moto) = moto_with(&path) else {
        return;
    };
    let cache = tempfile::tempdir().unwrap();
    let opts = RemoteOptions {
        s3_config: vec![
            (
                "aws_endpoint".into(),
                format!("http://127.0.0.1:{}", moto.port),
            ),
            ("aws_access_key_id".into(), "testing".into()),
            ("aws_secret_access_key".into(), "testing".into()),
            ("aws_region".into(), "us-east-1".into()),
        ],
        ..options(cache.path())
    };
    let url = "s3://globe-test/earth.globepyr";
    let local = Arc::new(Pyramid::open(&path).unwrap());
    let remote = Arc::new(Pyramid::open_remote(url, opts.clone()).unwrap());
    stream_all_equal(&remote, &local, Duration::from_secs(120));
    let s = remote.remote().unwrap().stats();
    eprintln!("moto: {s:?}");
    assert_eq!(s.tiles_fetched + s.resident_hits, local.info().tiles as u64);
    // A key that is not there: an error naming the URL.
    let e = Pyramid::open_remote("s3://globe-test/missing.globepyr", opts).unwrap_err();
    assert!(
        e.to_string().contains("s3://globe-test/missing.globepyr"),
        "{e}"
    );
}

/// What the misbehaving server does to range requests.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(u8)]
enum Misbehave {
    Serve = 0,
    Status500 = 1,
    /// The body holds half of what Content-Length and Content-Range say.
    Truncated = 2,
    /// The body for a range starting one byte later than asked, and says so.
    WrongContentRange = 3,
    /// The right headers, one byte of the body flipped.
    CorruptByte = 4,
}

/// A small HTTP/1.1 server (one connection at a time, `Connection: close`) serving one file
/// with range requests, and misbehaving as told.
struct BadServer {
    port: u16,
    mode: Arc<AtomicU8>,
    stop: Arc<AtomicBool>,
}

impl BadServer {
    fn start(file: Vec<u8>) -> Self {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let port = listener.local_addr().unwrap().port();
        let mode = Arc::new(AtomicU8::new(0));
        let stop = Arc::new(AtomicBool::new(false));
        let (m, st) = (mode.clone(), stop.clone());
        std::thread::spawn(move || {
            for conn in listener.incoming() {
                if st.load(Ordering::Relaxed) {
                    return;
                }
                if let Ok(c) = conn {
                    let _ = serve_one(c, &file, m.load(Ordering::Relaxed));
                }
            }
        });
        Self { port, mode, stop }
    }

    fn set(&self, m: Misbehave) {
        self.mode.store(m as u8, Ordering::Relaxed);
    }
}

impl Drop for BadServer {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        let _ = TcpStream::connect(("127.0.0.1", self.port));
    }
}

fn serve_one(mut c: TcpStream, file: &[u8], mode: u8) -> std::io::Result<()> {
    let mut r = BufReader::new(c.try_clone()?);
    let mut line = String::new();
    r.read_line(&mut line)?;
    let head = line.starts_with("HEAD");
    let mut range = None;
    loop {
        let mut h = String::new();
        r.read_line(&mut h)?;
        if h.trim().is_empty() {
            break;
        }
        let lower = h.to_ascii_lowercase();
        if let Some(v) = lower.strip_prefix("range: bytes=") {
            let (a, b) = v.trim().split_once('-').unwrap();
            range = Some((a.parse::<usize>().unwrap(), b.parse::<usize>().unwrap()));
        }
    }
    let n = file.len();
    if head || range.is_none() {
        let body: &[u8] = if head { &[] } else { file };
        write!(
            c,
            "HTTP/1.1 200 OK\r\nContent-Length: {n}\r\nAccept-Ranges: bytes\r\n\
             Last-Modified: Sun, 29 Nov 2026 00:00:00 GMT\r\nETag: \"g\"\r\nConnection: close\r\n\r\n"
        )?;
        return c.write_all(body);
    }
    let (a, b) = range.unwrap();
    let b = b.min(n - 1);
    if mode == Misbehave::Status500 as u8 {
        return write!(
            c,
            "HTTP/1.1 500 Internal Server Error\r\nContent-Length: 4\r\nConnection: close\r\n\r\noops"
        );
    }
    let (a2, b2) = if mode == Misbehave::WrongContentRange as u8 {
        (a + 1, (b + 1).min(n - 1))
    } else {
        (a, b)
    };
    let mut body = file[a2..=b2].to_vec();
    let len = body.len();
    if mode == Misbehave::CorruptByte as u8 {
        body[len / 2] ^= 0x40;
    }
    if mode == Misbehave::Truncated as u8 {
        body.truncate(len / 2);
    }
    write!(
        c,
        "HTTP/1.1 206 Partial Content\r\nContent-Length: {}\r\nContent-Range: bytes {a2}-{b2}/{n}\r\n\
         Last-Modified: Sun, 29 Nov 2026 00:00:00 GMT\r\nETag: \"g\"\r\nConnection: close\r\n\r\n",
        body.len()
    )?;
    c.write_all(&body)?;
    c.flush()?;
    drop(r);
    let _ = c.read(&mut [0; 1]);
    Ok(())
}

/// 500s, a short body, a wrong Content-Range and a flipped byte: each read fails with an error
/// naming the URL and what was wrong, the bad tile is never accepted nor written to the disk
/// cache, and once the server behaves the same tile loads and equals the file's.
#[test]
fn a_misbehaving_server_gives_clear_errors_and_no_wrong_tile_is_cached() {
    let (_root, path) = served_copy();
    let server = BadServer::start(std::fs::read(&path).unwrap());
    let url = format!("http://127.0.0.1:{}/earth.globepyr", server.port);
    let cache = tempfile::tempdir().unwrap();
    let local = Arc::new(Pyramid::open(&path).unwrap());
    let remote = Arc::new(Pyramid::open_remote(&url, options(cache.path())).unwrap());
    let source = RemoteTileSource::new(remote.clone()).unwrap();
    let store = remote.remote().unwrap().clone();
    let key = TileKey {
        level: 0,
        tx: 4,
        ty: 2,
    };
    for (mode, says) in [
        (Misbehave::Status500, "500"),
        (Misbehave::Truncated, "truncated"),
        (Misbehave::WrongContentRange, "Requested"),
        (Misbehave::CorruptByte, "checksum mismatch"),
    ] {
        server.set(mode);
        let e = source.read(key).unwrap_err().to_string();
        eprintln!("{mode:?}: {e}");
        assert!(e.contains(&url), "{mode:?}: {e}");
        assert!(e.contains("level 0 tile (4, 2)"), "{mode:?}: {e}");
        assert!(e.contains(says), "{mode:?}: {e}");
        assert!(!cached_22(cache.path()), "{mode:?}: nothing cached");
    }
    let s = store.stats();
    assert_eq!(s.tiles_fetched, 0);
    assert_eq!(s.rejected_tiles, 1, "the corrupt tile, refused by its CRC");
    assert!(s.request_errors >= 3);
    server.set(Misbehave::Serve);
    let tile = source.read(key).unwrap();
    assert_eq!(tile.avg, MmapTileSource::new(local).read(key).unwrap().avg);
    assert!(cached_22(cache.path()), "the good tile is cached");
}

/// Whether level 0 tile (4, 2) (index 22) is in the disk cache.
fn cached_22(cache: &Path) -> bool {
    walk(cache)
        .iter()
        .any(|p| p.file_name().is_some_and(|n| n == "22.tile"))
}

/// nginx killed while every tile is being streamed and started again on the same port: reads
/// fail meanwhile (retried by the streamer, then asked for again), and every tile arrives and
/// equals the file's once the server is back.
#[test]
fn the_view_completes_after_the_server_is_killed_mid_flight_and_restarted() {
    let (root, path) = served_copy();
    let port = free_port();
    let Some(nginx) = nginx_on(root.path(), port) else {
        return;
    };
    let url = format!("http://127.0.0.1:{port}/earth.globepyr");
    let cache = tempfile::tempdir().unwrap();
    let local = Arc::new(Pyramid::open(&path).unwrap());
    let remote = Arc::new(
        Pyramid::open_remote(
            &url,
            RemoteOptions {
                // Slow enough that the kill lands mid-flight.
                latency: Duration::from_millis(100),
                max_requests: 2,
                ..options(cache.path())
            },
        )
        .unwrap(),
    );
    let store = remote.remote().unwrap().clone();
    let source: Arc<dyn TileSource> = Arc::new(RemoteTileSource::new(remote.clone()).unwrap());
    let settings = StreamSettings {
        max_in_flight: 2,
        ..StreamSettings::default()
    };
    // Killed once the first tile has arrived, started again once a read has failed for good.
    let mut server = Some(nginx);
    let mut killed = false;
    let failed = stream_keys(
        source,
        &common::all_tile_keys(&local),
        &local,
        Duration::from_secs(120),
        &settings,
        &mut |loaded, failed| {
            if loaded >= 1 && !killed {
                server.take().unwrap().stop();
                killed = true;
                eprintln!("nginx killed after {loaded} tiles");
            }
            if failed >= 1 && server.is_none() {
                server = nginx_on(root.path(), port);
                eprintln!("nginx started again after {failed} failed reads");
            }
        },
    );
    assert!(killed && server.is_some());
    assert!(failed > 0, "reads failed while the server was down");
    let s = store.stats();
    eprintln!("kill/restart: {failed} failed requests, {s:?}");
    assert!(s.request_errors > 0, "the kill was felt");
    assert_eq!(s.tiles_fetched + s.resident_hits, local.info().tiles as u64);
    assert_eq!(s.rejected_tiles, 0);
}

/// The flight over loopback HTTP (nginx) with 0, 50 and 200 ms added to every request: it
/// settles, and its settled frame equals the local file's pixel for pixel. Prints the CPU time
/// per frame against the local file's, the time to full detail and the bytes requested
/// against the bytes of the tiles used (figures, not asserted).
#[test]
fn the_flight_over_http_settles_to_the_local_files_frame() {
    use globe::instruments::bench::{self, BenchOptions};
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let (root, path) = served_copy();
    let Some(nginx) = nginx_on(root.path(), free_port()) else {
        return;
    };
    let url = format!("http://127.0.0.1:{}/earth.globepyr", nginx.port);
    let opts = BenchOptions {
        scene: globe::scenes::flight::NAME.into(),
        camera: None,
        path: None,
        frames: 24,
        warmup: 0,
        width: 192,
        height: 108,
        settings: globe::clipmap::ClipmapSettings::default(),
        stream: StreamSettings::default(),
        frame_interval: Some(Duration::from_millis(16)),
        look: globe::look::LookSettings::default(),
        lod: Default::default(),
        compare_plain_look: false,
        compare_vertex_stage: false,
        measure_error: false,
        passthrough: false,
    };
    let local_terrain = globe::terrain::open_terrain(path.to_str().unwrap(), |_| {}).unwrap();
    let local = bench::run(ctx, &local_terrain, &opts, |_, _| {}).unwrap();
    assert!(local.settled);
    let median = |run: &bench::BenchRun| {
        let cpu: Vec<f64> = run.frames.iter().map(|f| f.cpu_ms).collect();
        bench::summary(&cpu).unwrap().0
    };
    for latency in [0, 50, 200] {
        let cache = tempfile::tempdir().unwrap();
        let remote_opts = RemoteOptions {
            latency: Duration::from_millis(latency),
            ..options(cache.path())
        };
        let terrain = globe::terrain::open_terrain_with(&url, remote_opts, |_| {}).unwrap();
        let store = terrain.dem().unwrap().pyramid().remote().unwrap().clone();
        let opened = store.stats();
        let run = bench::run(ctx, &terrain, &opts, |_, _| {}).unwrap();
        let s = store.stats();
        let differ = bench::pixels_differing(
            run.final_frame.as_ref().unwrap(),
            local.final_frame.as_ref().unwrap(),
        );
        eprintln!(
            "http + {latency} ms: CPU ms/frame median {:.2} (local {:.2}, ratio {:.2}), full detail \
             {:.2} s after the flight (local {:.2} s); at open {} requests, {} B; then {} requests, \
             {} B requested for {} B of tiles ({} tiles, {} from memory), settled frame vs local \
             {differ} px",
            median(&run),
            median(&local),
            median(&run) / median(&local),
            run.settle_s.unwrap(),
            local.settle_s.unwrap(),
            opened.requests,
            opened.bytes_requested,
            s.requests - opened.requests,
            s.bytes_requested - opened.bytes_requested,
            s.tile_bytes_used,
            s.tiles_fetched,
            s.resident_hits
        );
        assert!(run.settled, "{latency} ms: settled");
        assert_eq!(run.final_vs_loaded_px, Some(0));
        assert_eq!(
            differ, 0,
            "{latency} ms: the settled frame equals the local file's"
        );
        assert_eq!(s.rejected_tiles, 0);
    }
}
