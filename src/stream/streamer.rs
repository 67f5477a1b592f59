//! The tile streamer: a tokio runtime off the render thread that reads what the view asks for,
//! most urgent first, and hands the tiles back over a channel.
//!
//! Each frame the render thread states everything it still lacks ([`TileStreamer::want`]):
//! new tiles are queued, queued tiles no longer wanted are dropped before they are read
//! (counted as cancelled), and reads in flight that are no longer wanted stop at their next
//! retry. A dispatcher task starts the best-priority queued read whenever fewer than
//! `max_in_flight` are running; reads run on the blocking pool (the source may block on I/O or
//! injected latency) and failed reads are retried with exponential back-off, then reported.
//!
//! A watcher task looks at the source's file every `watch_interval` (one `fstat`, one `stat`:
//! cheap, and off the render thread) and hands each change of its state over once
//! ([`TileStreamer::poll_file`]).

use std::collections::{HashMap, HashSet};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, mpsc};
use std::time::{Duration, Instant};

use tokio::sync::{Notify, Semaphore};

use super::source::{TileData, TileSource};
use super::{Priority, StreamSettings, TileError, TileKey};
use crate::dem::FileChange;

/// What a finished request delivers.
#[derive(Debug)]
pub enum Completion {
    Loaded(Arc<TileData>),
    /// Every attempt failed; the last error. The tile may be asked for again.
    Failed(TileKey, TileError),
    /// Dropped between attempts because the view no longer wanted it.
    Cancelled(TileKey),
}

impl Completion {
    pub fn key(&self) -> TileKey {
        match self {
            Self::Loaded(tile) => tile.key,
            Self::Failed(key, _) | Self::Cancelled(key) => *key,
        }
    }
}

/// Counters since the streamer started (cumulative) and gauges (now).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StreamStats {
    /// Requests queued (a tile asked for again after a failure counts again).
    pub tiles_requested: u64,
    pub tiles_loaded: u64,
    /// Requests dropped before being read because the view no longer wanted them.
    pub tiles_cancelled: u64,
    /// Requests whose every attempt failed.
    pub tiles_failed: u64,
    /// Failed attempts that were retried.
    pub retries: u64,
    /// Tile reads that started (each attempt).
    pub reads_started: u64,
    pub bytes_read: u64,
    pub queued: u64,
    pub in_flight: u64,
}

struct Request {
    priority: Priority,
    cancel: Arc<AtomicBool>,
}

#[derive(Default)]
struct Queue {
    queued: HashMap<TileKey, Request>,
    in_flight: HashMap<TileKey, Arc<AtomicBool>>,
    /// Finished requests whose completion the render thread has not received yet: `want`
    /// must not queue them again (a tile that arrives between a frame's `poll` and its `want`
    /// would otherwise be read twice).
    unpolled: HashSet<TileKey>,
    closed: bool,
}

impl Queue {
    fn pop_best(&mut self) -> Option<(TileKey, Arc<AtomicBool>)> {
        let key = *self.queued.iter().min_by_key(|(k, r)| (r.priority, **k))?.0;
        let r = self.queued.remove(&key)?;
        self.in_flight.insert(key, r.cancel.clone());
        Some((key, r.cancel))
    }
}

#[derive(Default)]
struct Counters {
    requested: AtomicU64,
    loaded: AtomicU64,
    cancelled: AtomicU64,
    failed: AtomicU64,
    retries: AtomicU64,
    reads: AtomicU64,
    bytes: AtomicU64,
}

struct Shared {
    queue: Mutex<Queue>,
    notify: Notify,
    counters: Counters,
}

impl Shared {
    fn lock(&self) -> std::sync::MutexGuard<'_, Queue> {
        self.queue.lock().unwrap_or_else(|p| p.into_inner())
    }
}

pub struct TileStreamer {
    runtime: Option<tokio::runtime::Runtime>,
    shared: Arc<Shared>,
    completions: mpsc::Receiver<Completion>,
    file_states: mpsc::Receiver<Option<FileChange>>,
}

impl TileStreamer {
    /// Starts the runtime (two worker threads; reads go to the blocking pool) and the
    /// dispatcher.
    pub fn new(source: Arc<dyn TileSource>, settings: &StreamSettings) -> std::io::Result<Self> {
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .thread_name("globe-stream")
            .enable_time()
            .build()?;
        let shared = Arc::new(Shared {
            queue: Mutex::new(Queue::default()),
            notify: Notify::new(),
            counters: Counters::default(),
        });
        let (tx, rx) = mpsc::channel();
        let (file_tx, file_rx) = mpsc::channel();
        runtime.spawn(watch(source.clone(), file_tx, settings.watch_interval));
        runtime.spawn(dispatch(shared.clone(), source, tx, *settings));
        Ok(Self {
            runtime: Some(runtime),
            shared,
            completions: rx,
            file_states: file_rx,
        })
    }

    /// The file's states the watcher saw since the last call, oldest first, each once: a
    /// change ([`FileChange`]) or None, back as it was opened (never blocks).
    pub fn poll_file(&self) -> Vec<Option<FileChange>> {
        self.file_states.try_iter().collect()
    }

    /// States everything the view lacks, with priorities (lower is sooner). Tiles already
    /// queued get the new priority; queued tiles missing from `wanted` are dropped before they
    /// are read; reads in flight that are no longer wanted stop at their next attempt.
    pub fn want(&self, wanted: &HashMap<TileKey, Priority>) {
        let mut q = self.shared.lock();
        let before = q.queued.len();
        q.queued.retain(|k, _| wanted.contains_key(k));
        let dropped = before - q.queued.len();
        self.shared
            .counters
            .cancelled
            .fetch_add(dropped as u64, Ordering::Relaxed);
        for (k, cancel) in &q.in_flight {
            cancel.store(!wanted.contains_key(k), Ordering::Relaxed);
        }
        let mut added = 0;
        for (&key, &priority) in wanted {
            if q.in_flight.contains_key(&key) || q.unpolled.contains(&key) {
                continue;
            }
            q.queued
                .entry(key)
                .and_modify(|r| r.priority = priority)
                .or_insert_with(|| {
                    added += 1;
                    Request {
                        priority,
                        cancel: Arc::new(AtomicBool::new(false)),
                    }
                });
        }
        drop(q);
        if added > 0 {
            self.shared
                .counters
                .requested
                .fetch_add(added, Ordering::Relaxed);
            self.shared.notify.notify_one();
        }
    }

    /// What has finished since the last call (never blocks).
    pub fn poll(&self) -> Vec<Completion> {
        let done: Vec<Completion> = self.completions.try_iter().collect();
        self.received(&done);
        done
    }

    /// Waits up to `timeout` for the next completion (the headless renderer waiting for data).
    pub fn wait(&self, timeout: Duration) -> Option<Completion> {
        let done = self.completions.recv_timeout(timeout).ok();
        self.received(done.as_slice());
        done
    }

    /// The render thread has these completions: their tiles may be asked for again.
    fn received(&self, done: &[Completion]) {
        if done.is_empty() {
            return;
        }
        let mut q = self.shared.lock();
        for d in done {
            q.unpolled.remove(&d.key());
        }
    }

    /// Nothing queued and nothing in flight.
    pub fn is_idle(&self) -> bool {
        let q = self.shared.lock();
        q.queued.is_empty() && q.in_flight.is_empty()
    }

    pub fn stats(&self) -> StreamStats {
        let c = &self.shared.counters;
        let q = self.shared.lock();
        StreamStats {
            tiles_requested: c.requested.load(Ordering::Relaxed),
            tiles_loaded: c.loaded.load(Ordering::Relaxed),
            tiles_cancelled: c.cancelled.load(Ordering::Relaxed),
            tiles_failed: c.failed.load(Ordering::Relaxed),
            retries: c.retries.load(Ordering::Relaxed),
            reads_started: c.reads.load(Ordering::Relaxed),
            bytes_read: c.bytes.load(Ordering::Relaxed),
            queued: q.queued.len() as u64,
            in_flight: q.in_flight.len() as u64,
        }
    }
}

impl Drop for TileStreamer {
    fn drop(&mut self) {
        self.shared.lock().closed = true;
        self.shared.notify.notify_one();
        if let Some(rt) = self.runtime.take() {
            // Reads sleeping in injected latency are not waited for.
            rt.shutdown_background();
        }
    }
}

/// Looks at the source's file every `interval` and sends each new state once; ends with the
/// runtime or when nobody listens.
async fn watch(
    source: Arc<dyn TileSource>,
    tx: mpsc::Sender<Option<FileChange>>,
    interval: Duration,
) {
    let mut last: Option<FileChange> = None;
    loop {
        tokio::time::sleep(interval.max(Duration::from_millis(1))).await;
        let src = source.clone();
        let Ok(now) = tokio::task::spawn_blocking(move || src.file_change()).await else {
            return;
        };
        if now != last {
            if tx.send(now.clone()).is_err() {
                return;
            }
            last = now;
        }
    }
}

async fn dispatch(
    shared: Arc<Shared>,
    source: Arc<dyn TileSource>,
    tx: mpsc::Sender<Completion>,
    settings: StreamSettings,
) {
    let slots = Arc::new(Semaphore::new(settings.max_in_flight.max(1)));
    loop {
        let Ok(permit) = slots.clone().acquire_owned().await else {
            return;
        };
        let (key, cancel) = loop {
            let notified = shared.notify.notified();
            {
                let mut q = shared.lock();
                if q.closed {
                    return;
                }
                if let Some(job) = q.pop_best() {
                    break job;
                }
            }
            notified.await;
        };
        let (shared, source, tx) = (shared.clone(), source.clone(), tx.clone());
        tokio::spawn(async move {
            let done = fetch(&shared, source, key, &cancel, &settings).await;
            {
                let mut q = shared.lock();
                q.in_flight.remove(&key);
                q.unpolled.insert(key);
            }
            let _ = tx.send(done);
            drop(permit);
        });
    }
}

/// One request: attempts with exponential back-off until it succeeds, is cancelled, or runs
/// out of retries.
async fn fetch(
    shared: &Shared,
    source: Arc<dyn TileSource>,
    key: TileKey,
    cancel: &AtomicBool,
    settings: &StreamSettings,
) -> Completion {
    let c = &shared.counters;
    let mut backoff = Duration::from_millis(settings.backoff_ms.max(1));
    let mut attempt = 0;
    loop {
        if cancel.load(Ordering::Relaxed) {
            c.cancelled.fetch_add(1, Ordering::Relaxed);
            return Completion::Cancelled(key);
        }
        c.reads.fetch_add(1, Ordering::Relaxed);
        let src = source.clone();
        let result = tokio::task::spawn_blocking(move || src.read(key))
            .await
            .unwrap_or_else(|e| {
                Err(TileError::Read {
                    key,
                    message: format!("read task failed: {e}"),
                })
            });
        match result {
            Ok(tile) => {
                c.loaded.fetch_add(1, Ordering::Relaxed);
                c.bytes
                    .fetch_add(2 * 3 * tile.avg.len() as u64, Ordering::Relaxed);
                return Completion::Loaded(Arc::new(tile));
            }
            Err(e) if attempt < settings.retries => {
                attempt += 1;
                c.retries.fetch_add(1, Ordering::Relaxed);
                let _ = e;
                tokio::time::sleep(backoff).await;
                backoff *= 2;
            }
            Err(e) => {
                c.failed.fetch_add(1, Ordering::Relaxed);
                return Completion::Failed(key, e);
            }
        }
    }
}

/// Measures how fast `source` delivers `keys` read one after another on this thread (the raw
/// rate the pipeline is compared with): (tiles, bytes, seconds).
pub fn raw_read_rate(source: &dyn TileSource, keys: &[TileKey]) -> (u64, u64, f64) {
    let t = Instant::now();
    let mut bytes = 0;
    let mut n = 0;
    for &k in keys {
        if let Ok(tile) = source.read(k) {
            bytes += 2 * 3 * tile.avg.len() as u64;
            n += 1;
        }
    }
    (n, bytes, t.elapsed().as_secs_f64())
}
