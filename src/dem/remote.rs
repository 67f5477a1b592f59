//! The bytes of pyramids on an HTTP server or an S3 object store (`--dem https://…`, `s3://bucket/key`),
//! read through the `object_store` crate (HTTP, S3 and local files behind one trait).
//!
//! ```text
//! open:   HEAD (size) → GET header prefix → GET rest of header + tile index (CRC-checked)
//!         → GET the coarsest levels in one request (kept in memory: the synchronous queries)
//! stream: `crate::stream::RemoteTileSource::read(tile)` on the streamer's blocking pool
//!           resident (prefetched) tile? → disk cache (CRC re-checked)? → batched range GET
//!           tiles asked for in the same round whose byte ranges touch → one request
//!           every tile's CRC and codes checked before it is accepted or written to disk
//! ```
//!
//! Retries: `object_store`'s own retries are off, so a failed request is a failed read that
//! the streamer retries with its back-off and counts (`StreamStats::retries`, `tiles_failed`);
//! a tile that fails every attempt is asked for again by the view on a later frame. Each
//! request has a timeout; at most `max_requests` are in flight. Cancellation is the streamer's:
//! a tile the view no longer wants is dropped before its request is made.
//!
//! The synchronous readers of a pyramid (camera placement, culling bounds, the relief map,
//! the reference ray caster) read codes through [`crate::dem::pyramid::Pyramid`]: for a remote
//! pyramid a tile they touch is fetched once, blocking, through the same store and disk
//! cache, and kept (they touch few tiles, mostly the coarse levels fetched at open).

use std::collections::{BTreeMap, HashMap};
use std::ops::Range;
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex, OnceLock};
use std::time::Duration;

use object_store::ObjectStore;
use object_store::path::Path as ObjPath;

use super::DemError;

/// How a remote pyramid is read (`globe --disk-cache-mb`, `--remote-latency-ms`).
#[derive(Clone, Debug, PartialEq)]
pub struct RemoteOptions {
    /// Budget of the local disk cache of fetched tiles; 0 turns it off.
    pub disk_cache_bytes: u64,
    /// Where the disk cache lives; None: no disk cache (`DemTerrain::open_remote` puts it in
    /// the cache folder's `remote/`).
    pub disk_cache_dir: Option<PathBuf>,
    /// Requests in flight at most.
    pub max_requests: usize,
    /// Limit on one request (connect, headers and body).
    pub timeout: Duration,
    /// Added before every request (a simulated round trip, for measurements).
    pub latency: Duration,
    /// The coarsest levels whose tiles together fit in this many bytes are fetched at open,
    /// in one request, and kept.
    pub prefetch_bytes: u64,
    /// Attempts of a synchronous (blocking) tile read before it gives up.
    pub sync_attempts: u32,
    /// S3 settings over the `AWS_*` environment variables, as `object_store`'s config keys
    /// (`aws_endpoint`, `aws_access_key_id`, `aws_secret_access_key`, `aws_region`, …).
    pub s3_config: Vec<(String, String)>,
}

impl Default for RemoteOptions {
    fn default() -> Self {
        Self {
            disk_cache_bytes: 512 << 20,
            disk_cache_dir: None,
            max_requests: 8,
            timeout: Duration::from_secs(30),
            latency: Duration::ZERO,
            prefetch_bytes: 4 << 20,
            sync_attempts: 4,
            s3_config: Vec::new(),
        }
    }
}

/// Why a remote read failed.
#[derive(Debug, thiserror::Error)]
pub enum RemoteError {
    #[error("{url}: not a remote pyramid URL: {message}")]
    Url { url: String, message: String },
    #[error("{url}: cannot set up the store: {message}")]
    Store { url: String, message: String },
    #[error("{url}: bytes {start}..{end}: {message}")]
    Request {
        url: String,
        start: u64,
        end: u64,
        message: String,
    },
}

/// True for `--dem` arguments that name a remote pyramid.
pub fn is_remote_url(spec: &str) -> bool {
    ["http://", "https://", "s3://"]
        .iter()
        .any(|p| spec.starts_with(p))
}

/// What the remote store did since it was opened.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RemoteStats {
    /// Range requests made (each attempt).
    pub requests: u64,
    /// Bytes those requests asked for.
    pub bytes_requested: u64,
    /// Requests that failed (status, timeout, short body, wrong range).
    pub request_errors: u64,
    /// Tiles accepted from the network (CRC and codes checked).
    pub tiles_fetched: u64,
    /// Bytes of those tiles.
    pub tile_bytes_used: u64,
    /// Tiles served from the disk cache.
    pub disk_hits: u64,
    /// Tiles served from memory (the coarse levels fetched at open).
    pub resident_hits: u64,
    /// Tiles refused because their payload did not match the index (never cached).
    pub rejected_tiles: u64,
}

#[derive(Default)]
struct Counters {
    requests: AtomicU64,
    bytes_requested: AtomicU64,
    request_errors: AtomicU64,
    tiles_fetched: AtomicU64,
    tile_bytes_used: AtomicU64,
    disk_hits: AtomicU64,
    resident_hits: AtomicU64,
    rejected_tiles: AtomicU64,
}

/// The runtime every remote store's requests run on (two workers; never dropped, so a store
/// may be dropped anywhere, a tokio worker included).
fn runtime() -> &'static tokio::runtime::Runtime {
    static RT: OnceLock<tokio::runtime::Runtime> = OnceLock::new();
    RT.get_or_init(|| {
        tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .thread_name("globe-remote")
            .enable_all()
            .build()
            .expect("cannot start the remote I/O runtime")
    })
}

/// One remote pyramid file: the store, the object's location and size, the request limit, the
/// disk cache and the batcher that coalesces neighbouring tiles.
pub struct RemoteStore {
    url: String,
    store: Arc<dyn ObjectStore>,
    location: ObjPath,
    size: u64,
    options: RemoteOptions,
    limit: Arc<tokio::sync::Semaphore>,
    disk: OnceLock<Option<DiskCache>>,
    counters: Counters,
    batch: Batcher,
}

impl std::fmt::Debug for RemoteStore {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RemoteStore")
            .field("url", &self.url)
            .field("size", &self.size)
            .finish()
    }
}

impl RemoteStore {
    /// Connects to `url` (`http://`, `https://`, `s3://bucket/key`) and asks for the object's
    /// size. S3 takes credentials, region and endpoint from the usual `AWS_*` variables
    /// (`AWS_ACCESS_KEY_ID`, `AWS_SECRET_ACCESS_KEY`, `AWS_REGION`, `AWS_ENDPOINT_URL`);
    /// plain HTTP to an endpoint is allowed on loopback or with `AWS_ALLOW_HTTP=true`.
    pub fn connect(url: &str, options: RemoteOptions) -> Result<Self, RemoteError> {
        let store_err = |e: object_store::Error| RemoteError::Store {
            url: url.to_string(),
            message: e.to_string(),
        };
        let client = object_store::ClientOptions::new()
            .with_timeout(options.timeout)
            .with_connect_timeout(options.timeout.min(Duration::from_secs(10)));
        // The streamer retries (and counts) failed reads; the store must not retry behind it.
        let retry = object_store::RetryConfig {
            max_retries: 0,
            retry_timeout: options.timeout,
            ..Default::default()
        };
        let (store, location): (Arc<dyn ObjectStore>, ObjPath) =
            if let Some(rest) = url.strip_prefix("s3://") {
                let (bucket, key) = rest.split_once('/').ok_or_else(|| RemoteError::Url {
                    url: url.to_string(),
                    message: "expected s3://BUCKET/KEY".into(),
                })?;
                if bucket.is_empty() || key.is_empty() {
                    return Err(RemoteError::Url {
                        url: url.to_string(),
                        message: "expected s3://BUCKET/KEY (bucket or key empty)".into(),
                    });
                }
                let endpoint = options
                    .s3_config
                    .iter()
                    .find(|(k, _)| k == "aws_endpoint" || k == "aws_endpoint_url")
                    .map(|(_, v)| v.clone())
                    .or_else(|| std::env::var("AWS_ENDPOINT_URL").ok())
                    .or_else(|| std::env::var("AWS_ENDPOINT").ok())
                    .unwrap_or_default();
                let loopback = ["http://127.", "http://localhost", "http://[::1]"]
                    .iter()
                    .any(|p| endpoint.starts_with(p));
                let client = if loopback {
                    client.with_allow_http(true)
                } else {
                    client
                };
                let mut b = object_store::aws::AmazonS3Builder::from_env()
                    .with_bucket_name(bucket)
                    .with_client_options(client)
                    .with_retry(retry);
                if std::env::var_os("AWS_REGION").is_none()
                    && std::env::var_os("AWS_DEFAULT_REGION").is_none()
                {
                    b = b.with_region("us-east-1");
                }
                for (k, v) in &options.s3_config {
                    let key = k
                        .parse()
                        .map_err(|e: object_store::Error| RemoteError::Url {
                            url: url.to_string(),
                            message: format!("S3 setting {k}: {e}"),
                        })?;
                    b = b.with_config(key, v);
                }
                let store = b.build().map_err(store_err)?;
                let location = ObjPath::parse(key).map_err(|e| RemoteError::Url {
                    url: url.to_string(),
                    message: e.to_string(),
                })?;
                (Arc::new(store), location)
            } else if url.starts_with("http://") || url.starts_with("https://") {
                let (base, name) = url
                    .rsplit_once('/')
                    .filter(|(b, n)| !n.is_empty() && !b.ends_with('/'))
                    .ok_or_else(|| RemoteError::Url {
                        url: url.to_string(),
                        message: "expected http(s)://HOST/…/FILE".into(),
                    })?;
                let store = object_store::http::HttpBuilder::new()
                    .with_url(base)
                    .with_client_options(client.with_allow_http(true))
                    .with_retry(retry)
                    .build()
                    .map_err(store_err)?;
                (Arc::new(store), ObjPath::from(name))
            } else {
                return Err(RemoteError::Url {
                    url: url.to_string(),
                    message: "expected http://, https:// or s3://".into(),
                });
            };
        let limit = Arc::new(tokio::sync::Semaphore::new(options.max_requests.max(1)));
        let mut s = Self {
            url: url.to_string(),
            store,
            location,
            size: 0,
            options,
            limit,
            disk: OnceLock::new(),
            counters: Counters::default(),
            batch: Batcher::default(),
        };
        let (store, location) = (s.store.clone(), s.location.clone());
        let timeout = s.options.timeout;
        let meta = runtime()
            .block_on(async move { tokio::time::timeout(timeout, store.head(&location)).await })
            .map_err(|_| RemoteError::Store {
                url: url.to_string(),
                message: format!("no answer to HEAD within {timeout:?}"),
            })?
            .map_err(store_err)?;
        s.size = meta.size;
        Ok(s)
    }

    pub fn url(&self) -> &str {
        &self.url
    }

    /// The object's size in bytes (from HEAD).
    pub fn size(&self) -> u64 {
        self.size
    }

    pub fn options(&self) -> &RemoteOptions {
        &self.options
    }

    pub fn stats(&self) -> RemoteStats {
        let c = &self.counters;
        let l = |a: &AtomicU64| a.load(Ordering::Relaxed);
        RemoteStats {
            requests: l(&c.requests),
            bytes_requested: l(&c.bytes_requested),
            request_errors: l(&c.request_errors),
            tiles_fetched: l(&c.tiles_fetched),
            tile_bytes_used: l(&c.tile_bytes_used),
            disk_hits: l(&c.disk_hits),
            resident_hits: l(&c.resident_hits),
            rejected_tiles: l(&c.rejected_tiles),
        }
    }

    /// Opens the disk cache for this object, keyed by its URL and its header's CRC (a changed
    /// file gets a new cache). Called once the header is verified.
    pub(crate) fn open_disk_cache(&self, header_crc: u32) {
        self.disk.get_or_init(|| {
            if self.options.disk_cache_bytes == 0 {
                return None;
            }
            let root = self.options.disk_cache_dir.clone()?;
            let dir = root.join(format!(
                "{:08x}-{header_crc:08x}",
                crc32fast::hash(self.url.as_bytes())
            ));
            match DiskCache::open(dir.clone(), self.options.disk_cache_bytes) {
                Ok(c) => Some(c),
                Err(e) => {
                    eprintln!(
                        "globe: {}: disk cache {} unusable, tiles are not cached: {e}",
                        self.url,
                        dir.display()
                    );
                    None
                }
            }
        });
    }

    fn disk(&self) -> Option<&DiskCache> {
        self.disk.get().and_then(|d| d.as_ref())
    }

    /// One range request, awaited on the remote runtime (blocking the calling thread, which
    /// is never a tokio worker: the streamer's blocking pool or the render thread).
    pub fn fetch_blocking(&self, range: Range<u64>) -> Result<Vec<u8>, RemoteError> {
        runtime().block_on(self.fetch(range))
    }

    /// Several ranges at once: touching ones coalesced, the requests concurrent (within the
    /// request limit); the ranges' bytes in their order, or the first error.
    pub fn fetch_many_blocking(&self, ranges: &[Range<u64>]) -> Result<Vec<Vec<u8>>, RemoteError> {
        let runs = coalesce(ranges, MAX_RUN_BYTES);
        let results = runtime().block_on(join_all(
            runs.iter()
                .map(|(run, _)| self.fetch(run.clone()))
                .collect(),
        ));
        let mut parts: Vec<Vec<u8>> = vec![Vec::new(); ranges.len()];
        for ((run, members), got) in runs.iter().zip(results) {
            let bytes = got?;
            for i in members {
                let r = &ranges[*i];
                parts[*i] =
                    bytes[(r.start - run.start) as usize..(r.end - run.start) as usize].to_vec();
            }
        }
        Ok(parts)
    }

    async fn fetch(&self, range: Range<u64>) -> Result<Vec<u8>, RemoteError> {
        let _permit = self.limit.acquire().await;
        if !self.options.latency.is_zero() {
            tokio::time::sleep(self.options.latency).await;
        }
        let c = &self.counters;
        c.requests.fetch_add(1, Ordering::Relaxed);
        c.bytes_requested
            .fetch_add(range.end - range.start, Ordering::Relaxed);
        let err = |message: String| {
            c.request_errors.fetch_add(1, Ordering::Relaxed);
            RemoteError::Request {
                url: self.url.clone(),
                start: range.start,
                end: range.end,
                message,
            }
        };
        let got = tokio::time::timeout(
            self.options.timeout,
            self.store.get_range(&self.location, range.clone()),
        )
        .await
        .map_err(|_| err(format!("no answer within {:?}", self.options.timeout)))?
        .map_err(|e| err(e.to_string()))?;
        let want = (range.end - range.start) as usize;
        if got.len() != want {
            return Err(err(format!(
                "the body has {} bytes, expected {want} (truncated?)",
                got.len()
            )));
        }
        Ok(got.to_vec())
    }

    /// Tile `index` at `range`: from the disk cache when there (its CRC re-checked), else
    /// fetched in the current batch with any neighbours asked for at the same time.
    /// `check` accepts or refuses the payload; a refused payload is never written to disk.
    pub(crate) fn tile_payload(
        &self,
        index: usize,
        range: Range<u64>,
        crc: u32,
        batched: bool,
        check: &dyn Fn(&[u8]) -> Result<(), DemError>,
    ) -> Result<Vec<u8>, DemError> {
        if let Some(bytes) = self.disk_get(index, crc, check) {
            return Ok(bytes);
        }
        let bytes = if batched {
            self.batch.fetch(self, range)
        } else {
            self.fetch_blocking(range)
        }
        .map_err(DemError::from)?;
        if let Err(e) = check(&bytes) {
            self.counters.rejected_tiles.fetch_add(1, Ordering::Relaxed);
            return Err(e);
        }
        self.counters.tiles_fetched.fetch_add(1, Ordering::Relaxed);
        self.counters
            .tile_bytes_used
            .fetch_add(bytes.len() as u64, Ordering::Relaxed);
        if let Some(d) = self.disk() {
            d.put(index, &bytes);
        }
        Ok(bytes)
    }

    /// Tile `index` from the disk cache when there and it checks (else it is removed).
    pub(crate) fn disk_get(
        &self,
        index: usize,
        crc: u32,
        check: &dyn Fn(&[u8]) -> Result<(), DemError>,
    ) -> Option<Vec<u8>> {
        let d = self.disk()?;
        let bytes = d.get(index)?;
        if crc32fast::hash(&bytes) == crc && check(&bytes).is_ok() {
            self.counters.disk_hits.fetch_add(1, Ordering::Relaxed);
            return Some(bytes);
        }
        d.remove(index);
        None
    }

    /// Keeps a checked tile in the disk cache.
    pub(crate) fn disk_put(&self, index: usize, bytes: &[u8]) {
        if let Some(d) = self.disk() {
            d.put(index, bytes);
        }
    }

    pub(crate) fn count_resident_hit(&self) {
        self.counters.resident_hits.fetch_add(1, Ordering::Relaxed);
    }
}

impl From<RemoteError> for DemError {
    fn from(e: RemoteError) -> Self {
        DemError::Remote(e.to_string())
    }
}

/// How long the first reader of a round waits for the others before the round's requests go
/// out: the streamer starts its reads within microseconds of each other, so this gathers a
/// round at the cost of this much latency per request.
const GATHER: Duration = Duration::from_millis(2);
/// Longest coalesced request.
const MAX_RUN_BYTES: u64 = 16 << 20;

type Slot = Arc<(Mutex<Option<Result<Vec<u8>, RemoteError>>>, Condvar)>;

/// Coalesces the byte ranges that readers ask for at about the same time: the first reader of
/// a round waits [`GATHER`], takes every range asked for by then, merges those that touch into
/// one request each, and hands every reader its slice.
#[derive(Default)]
struct Batcher {
    state: Mutex<BatchState>,
}

#[derive(Default)]
struct BatchState {
    pending: Vec<(Range<u64>, Slot)>,
    collecting: bool,
}

impl Batcher {
    fn lock(&self) -> std::sync::MutexGuard<'_, BatchState> {
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn fetch(&self, store: &RemoteStore, range: Range<u64>) -> Result<Vec<u8>, RemoteError> {
        let slot: Slot = Arc::new((Mutex::new(None), Condvar::new()));
        let leader = {
            let mut s = self.lock();
            s.pending.push((range, slot.clone()));
            !std::mem::replace(&mut s.collecting, true)
        };
        if leader {
            std::thread::sleep(GATHER);
            let round = {
                let mut s = self.lock();
                s.collecting = false;
                std::mem::take(&mut s.pending)
            };
            runtime().block_on(run_round(store, round));
        }
        let (m, cv) = &*slot;
        let mut got = m.lock().unwrap_or_else(|p| p.into_inner());
        loop {
            if let Some(r) = got.take() {
                return r;
            }
            got = cv.wait(got).unwrap_or_else(|p| p.into_inner());
        }
    }
}

/// Groups byte ranges into runs of ranges that touch (one ends where the next starts), each
/// run at most `max_bytes` long unless one range alone is longer: (the run's range, the
/// positions in `ranges` of its members, in order). Ranges that merely lie near each other
/// are not merged: no byte is requested that no tile needs.
pub fn coalesce(ranges: &[Range<u64>], max_bytes: u64) -> Vec<(Range<u64>, Vec<usize>)> {
    let mut order: Vec<usize> = (0..ranges.len()).collect();
    order.sort_by_key(|&i| (ranges[i].start, ranges[i].end));
    let mut runs: Vec<(Range<u64>, Vec<usize>)> = Vec::new();
    for i in order {
        let r = &ranges[i];
        match runs.last_mut() {
            Some((run, members)) if run.end == r.start && r.end - run.start <= max_bytes => {
                run.end = r.end;
                members.push(i);
            }
            _ => runs.push((r.clone(), vec![i])),
        }
    }
    runs
}

/// Requests the round's runs concurrently (the store's semaphore bounds how many are in
/// flight) and fills every slot with its slice or the run's error.
async fn run_round(store: &RemoteStore, round: Vec<(Range<u64>, Slot)>) {
    let ranges: Vec<Range<u64>> = round.iter().map(|(r, _)| r.clone()).collect();
    let round = &round;
    let fetches = coalesce(&ranges, MAX_RUN_BYTES)
        .into_iter()
        .map(|(run, members)| async move {
            let got = store.fetch(run.clone()).await;
            for i in members {
                let (r, slot) = &round[i];
                let part = match &got {
                    Ok(bytes) => Ok(bytes
                        [(r.start - run.start) as usize..(r.end - run.start) as usize]
                        .to_vec()),
                    Err(e) => Err(RemoteError::Request {
                        url: store.url.clone(),
                        start: r.start,
                        end: r.end,
                        message: match e {
                            RemoteError::Request { message, .. } if run == *r => message.clone(),
                            RemoteError::Request { message, .. } => format!(
                                "in the request for bytes {}..{}: {message}",
                                run.start, run.end
                            ),
                            other => other.to_string(),
                        },
                    }),
                };
                let (m, cv) = &**slot;
                *m.lock().unwrap_or_else(|p| p.into_inner()) = Some(part);
                cv.notify_all();
            }
        })
        .collect();
    join_all(fetches).await;
}

/// Awaits every future, polling them concurrently, and returns their outputs in order (no
/// `futures` dependency for one loop).
async fn join_all<T, F: std::future::Future<Output = T>>(futures: Vec<F>) -> Vec<T> {
    let mut futures: Vec<_> = futures.into_iter().map(Box::pin).collect();
    let mut out: Vec<Option<T>> = futures.iter().map(|_| None).collect();
    std::future::poll_fn(|cx| {
        let mut pending = false;
        for (f, slot) in futures.iter_mut().zip(out.iter_mut()) {
            if slot.is_none() {
                match f.as_mut().poll(cx) {
                    std::task::Poll::Ready(v) => *slot = Some(v),
                    std::task::Poll::Pending => pending = true,
                }
            }
        }
        if pending {
            std::task::Poll::Pending
        } else {
            std::task::Poll::Ready(())
        }
    })
    .await;
    out.into_iter()
        .map(|v| v.expect("every future finished"))
        .collect()
}

/// Fetched tiles on local disk, one file per tile (named by its index in the pyramid's tile
/// index), bounded in bytes, least recently used evicted first. Every tile read back is
/// CRC-checked by the caller; a bad one is removed.
struct DiskCache {
    dir: PathBuf,
    budget: u64,
    state: Mutex<DiskState>,
}

#[derive(Default)]
struct DiskState {
    total: u64,
    seq: u64,
    /// Use order → tile index.
    order: BTreeMap<u64, usize>,
    /// Tile index → (use sequence, bytes).
    files: HashMap<usize, (u64, u64)>,
}

impl DiskCache {
    fn open(dir: PathBuf, budget: u64) -> std::io::Result<Self> {
        std::fs::create_dir_all(&dir)?;
        let mut found = Vec::new();
        for e in std::fs::read_dir(&dir)? {
            let e = e?;
            let name = e.file_name().to_string_lossy().into_owned();
            let Some(index) = name
                .strip_suffix(".tile")
                .and_then(|n| n.parse::<usize>().ok())
            else {
                // Leftover temporary files of an interrupted write.
                let _ = std::fs::remove_file(e.path());
                continue;
            };
            let m = e.metadata()?;
            found.push((m.modified().ok(), index, m.len()));
        }
        found.sort();
        let cache = Self {
            dir,
            budget,
            state: Mutex::new(DiskState::default()),
        };
        {
            let mut s = cache.lock();
            for (_, index, len) in found {
                s.seq += 1;
                let seq = s.seq;
                s.order.insert(seq, index);
                s.files.insert(index, (seq, len));
                s.total += len;
            }
        }
        cache.evict();
        Ok(cache)
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, DiskState> {
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn path(&self, index: usize) -> PathBuf {
        self.dir.join(format!("{index}.tile"))
    }

    fn get(&self, index: usize) -> Option<Vec<u8>> {
        {
            let mut s = self.lock();
            let (seq, len) = *s.files.get(&index)?;
            s.order.remove(&seq);
            s.seq += 1;
            let now = s.seq;
            s.order.insert(now, index);
            s.files.insert(index, (now, len));
        }
        std::fs::read(self.path(index)).ok()
    }

    fn remove(&self, index: usize) {
        let mut s = self.lock();
        if let Some((seq, len)) = s.files.remove(&index) {
            s.order.remove(&seq);
            s.total -= len;
        }
        drop(s);
        let _ = std::fs::remove_file(self.path(index));
    }

    fn put(&self, index: usize, bytes: &[u8]) {
        let len = bytes.len() as u64;
        if len > self.budget || self.lock().files.contains_key(&index) {
            return;
        }
        let tmp = self
            .dir
            .join(format!("{index}.{:?}.partial", std::thread::current().id()));
        if std::fs::write(&tmp, bytes).is_err() || std::fs::rename(&tmp, self.path(index)).is_err()
        {
            let _ = std::fs::remove_file(&tmp);
            return;
        }
        {
            let mut s = self.lock();
            s.seq += 1;
            let seq = s.seq;
            s.order.insert(seq, index);
            if let Some((old, old_len)) = s.files.insert(index, (seq, len)) {
                s.order.remove(&old);
                s.total -= old_len;
            }
            s.total += len;
        }
        self.evict();
    }

    fn evict(&self) {
        loop {
            let victim = {
                let mut s = self.lock();
                if s.total <= self.budget {
                    return;
                }
                let Some((&seq, &index)) = s.order.iter().next() else {
                    return;
                };
                s.order.remove(&seq);
                if let Some((_, len)) = s.files.remove(&index) {
                    s.total -= len;
                }
                index
            };
            let _ = std::fs::remove_file(self.path(victim));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_touching_ranges_are_coalesced_and_runs_are_bounded() {
        let r = |a: u64, b: u64| a..b;
        // Out of order; 0..10 and 10..20 touch, 25..30 does not, 30..40 touches 25..30.
        let ranges = [r(10, 20), r(30, 40), r(0, 10), r(25, 30), r(50, 60)];
        let runs = coalesce(&ranges, 100);
        assert_eq!(
            runs,
            vec![
                (r(0, 20), vec![2, 0]),
                (r(25, 40), vec![3, 1]),
                (r(50, 60), vec![4])
            ]
        );
        // A bound of 15 bytes splits the first run.
        let runs = coalesce(&ranges, 15);
        assert_eq!(runs[0], (r(0, 10), vec![2]));
        assert_eq!(runs[1], (r(10, 20), vec![0]));
        // Every byte requested is some range's.
        let asked: u64 = ranges.iter().map(|r| r.end - r.start).sum();
        let requested: u64 = coalesce(&ranges, 100)
            .iter()
            .map(|(r, _)| r.end - r.start)
            .sum();
        assert_eq!(asked, requested);
    }

    #[test]
    fn the_disk_cache_stays_within_its_budget_least_recently_used_out() {
        let dir = tempfile::tempdir().unwrap();
        let c = DiskCache::open(dir.path().join("c"), 250).unwrap();
        c.put(1, &[1; 100]);
        c.put(2, &[2; 100]);
        assert_eq!(c.get(1).unwrap(), vec![1; 100]);
        c.put(3, &[3; 100]);
        // 2 was the least recently used.
        assert!(c.get(2).is_none());
        assert_eq!(c.get(1).unwrap(), vec![1; 100]);
        assert_eq!(c.get(3).unwrap(), vec![3; 100]);
        // Reopened, it finds its files and its total again.
        drop(c);
        let c = DiskCache::open(dir.path().join("c"), 150).unwrap();
        assert!(c.lock().total <= 150);
        // A tile larger than the budget is not written.
        c.put(9, &[9; 200]);
        assert!(c.get(9).is_none());
    }

    #[test]
    fn urls_are_checked() {
        assert!(is_remote_url("https://example.org/a.globepyr"));
        assert!(is_remote_url("s3://b/k"));
        assert!(!is_remote_url("earth.globepyr"));
        for bad in ["s3://bucket", "s3:///key", "http://host/"] {
            let e = RemoteStore::connect(bad, RemoteOptions::default()).unwrap_err();
            assert!(e.to_string().starts_with(bad), "{e}");
        }
    }
}
