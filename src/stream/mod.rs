//! Tile streaming: from the memory-mapped pyramid file to the GPU without stalling a frame
//! (docs/design.md#data-flow).
//!
//! ```text
//! TileSource (mmap; a remote object: memory, disk cache or coalesced range requests,
//!             `remote.rs`; or a fault-injecting wrapper around either)
//!     │ blocking reads on tokio's blocking pool, CRC-checked, retried with back-off
//!     ▼
//! TileStreamer: priority queue (coarse levels first, then finer ones nearest the viewer),
//!     │          cancellation of what the view no longer wants, at most N reads in flight
//!     ▼ channel
//! TileCache: decoded tiles, LRU bounded in bytes (render thread)
//!     │ per-frame upload budget
//!     ▼
//! GPU tile cache (render::tiles) ──compute──▶ clipmap level textures
//! ```
//!
//! The render thread never reads the file: it asks for tiles each frame, takes what has
//! arrived, and draws only the levels whose data is complete (the coarser ones cover the rest).
//!
//! ## The mmap SIGBUS risk
//! A mapped file that another process truncates in place raises SIGBUS on the next access to
//! a page past the new end. globe avoids it as far as a reader can: the length is validated at
//! open, each read first checks (`fstat`) that the file still reaches the tile's end, and every
//! tile's CRC-32 is verified when it is read; globe itself never rewrites a pyramid in place
//! (imports write a temporary file and rename it, so a mapped old file stays intact on its
//! inode). The streamer's watcher reports what happened to the file (`crate::dem::FileChange`:
//! replaced, deleted, truncated, appended to, modified). What is left is a truncation racing a
//! read between the `fstat` and the copy; do not truncate a pyramid that a viewer has open
//! (replace it by renaming, as `globe-data import` does).

pub mod cache;
pub mod open;
pub mod remote;
pub mod settings;
pub mod source;
pub mod streamer;

pub use crate::dem::remote::{RemoteOptions, RemoteStats, RemoteStore};
pub use cache::TileCache;
pub use open::open_source;
pub use remote::RemoteTileSource;
pub use settings::{LatencyMs, StreamSettingsError};
pub use source::{FaultSettings, FaultyTileSource, MmapTileSource, TileData, TileSource};
pub use streamer::raw_read_rate;
pub use streamer::{Completion, StreamStats, TileStreamer};

/// One tile of one pyramid level.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct TileKey {
    pub level: u32,
    pub tx: u32,
    pub ty: u32,
}

impl std::fmt::Display for TileKey {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "level {} tile ({}, {})", self.level, self.tx, self.ty)
    }
}

/// Lower is sooner.
pub type Priority = u64;

/// Why a tile could not be read.
#[derive(Debug, thiserror::Error, Clone)]
pub enum TileError {
    #[error("{key}: {message}")]
    Read { key: TileKey, message: String },
    #[error("{key}: injected read failure")]
    Injected { key: TileKey },
}

/// Streaming settings (`globe --cache-mb`, `--gpu-tiles`, …).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StreamSettings {
    /// Budget of the decoded-tile LRU in bytes.
    pub cache_bytes: u64,
    /// Tiles the GPU tile cache holds.
    pub gpu_tiles: u32,
    /// Tiles uploaded into the GPU cache per frame at most.
    pub uploads_per_frame: u32,
    /// Reads in flight at most.
    pub max_in_flight: usize,
    /// Attempts after the first failed read, each after twice the previous back-off.
    pub retries: u32,
    pub backoff_ms: u64,
    /// Fault injection (tests, `--tile-latency-ms`, `--tile-fail-rate`).
    pub faults: FaultSettings,
    /// How often the watcher looks at the file (one `fstat` and one `stat`): a change is
    /// reported within about this long, at no cost per frame.
    pub watch_interval: std::time::Duration,
}

/// Default decoded-tile budget: 256 MiB (≈ 680 tiles of 256² × avg/min/max).
pub const DEFAULT_CACHE_BYTES: u64 = 256 << 20;

impl Default for StreamSettings {
    fn default() -> Self {
        Self {
            cache_bytes: DEFAULT_CACHE_BYTES,
            gpu_tiles: 512,
            uploads_per_frame: 32,
            max_in_flight: 16,
            retries: 6,
            backoff_ms: 5,
            faults: FaultSettings::default(),
            watch_interval: std::time::Duration::from_secs(1),
        }
    }
}
