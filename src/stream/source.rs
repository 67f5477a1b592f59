//! Where tiles come from: the memory-mapped pyramid, or a wrapper that injects latency and
//! failures (for tests and `--tile-latency-ms` / `--tile-fail-rate`).

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use super::{TileError, TileKey};
use crate::dem::FileChange;
use crate::dem::pyramid::{Encoding, Plane, Pyramid, TileView};

/// A decoded tile: the three planes (rows north to south, `tile_size²` codes each; codes past
/// the level's last row/column repeat it, as in the file).
#[derive(Clone, Debug)]
pub struct TileData {
    pub key: TileKey,
    pub tile_size: usize,
    pub encoding: Encoding,
    pub avg: Vec<i16>,
    pub min: Vec<i16>,
    pub max: Vec<i16>,
}

impl TileData {
    /// The tile `key` read as `view` (verified by the caller), copied out of the file.
    pub fn from_view(key: TileKey, view: TileView<'_>) -> Self {
        Self {
            key,
            tile_size: view.tile_size,
            encoding: view.encoding,
            avg: view.avg.into_owned(),
            min: view.min.into_owned(),
            max: view.max.into_owned(),
        }
    }

    /// Bytes this tile holds in memory (what the LRU budget counts).
    pub fn bytes(&self) -> u64 {
        (2 * (self.avg.len() + self.min.len() + self.max.len()) + std::mem::size_of::<Self>())
            as u64
    }

    /// The code of plane `p` at tile sample (x, y).
    pub fn code(&self, p: Plane, x: usize, y: usize) -> i16 {
        let at = y * self.tile_size + x;
        match p {
            Plane::Avg => self.avg[at],
            Plane::Min => self.min[at],
            Plane::Max => self.max[at],
        }
    }
}

/// Reads tiles. Called from tokio's blocking pool, so a read may block (that is the point).
pub trait TileSource: Send + Sync {
    fn read(&self, key: TileKey) -> Result<TileData, TileError>;

    /// What happened to the file behind the source since it was opened (the streamer's
    /// watcher asks about once a second); None when nothing did or there is no file.
    fn file_change(&self) -> Option<FileChange> {
        None
    }
}

/// Tiles from a memory-mapped pyramid: before each read, the file's length is checked to still
/// reach the tile's end, and the tile's CRC-32 is verified (see "The mmap SIGBUS risk" in the module docs).
pub struct MmapTileSource {
    pyramid: Arc<Pyramid>,
}

impl MmapTileSource {
    pub fn new(pyramid: Arc<Pyramid>) -> Self {
        Self { pyramid }
    }
}

impl TileSource for MmapTileSource {
    fn read(&self, key: TileKey) -> Result<TileData, TileError> {
        let err = |e: crate::dem::DemError| TileError::Read {
            key,
            message: e.to_string(),
        };
        let (level, tx, ty) = (key.level as usize, key.tx as usize, key.ty as usize);
        self.pyramid
            .check_tile_in_file(level, tx, ty)
            .map_err(err)?;
        let view = self.pyramid.tile_verified(level, tx, ty).map_err(err)?;
        Ok(TileData::from_view(key, view))
    }

    fn file_change(&self) -> Option<FileChange> {
        self.pyramid.file_change()
    }
}

/// What the fault injector does to each read.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FaultSettings {
    /// Added to every read (a slow disk or a remote store), blocking like real I/O.
    pub latency_ms: u64,
    /// With a value above `latency_ms`, each read's latency is drawn uniformly from
    /// `latency_ms..=latency_max_ms` instead (seeded, like the failures): a store whose
    /// answers arrive out of order.
    pub latency_max_ms: u64,
    /// Fraction of reads that fail, 0…1, decided by a seeded generator (repeatable runs).
    pub fail_rate: f64,
    pub seed: u64,
}

impl FaultSettings {
    pub fn is_active(&self) -> bool {
        self.latency_ms > 0 || self.latency_max_ms > 0 || self.fail_rate > 0.0
    }

    /// The latency of read number `n`, in milliseconds.
    pub fn latency_of_read_ms(&self, n: u64) -> u64 {
        if self.latency_max_ms <= self.latency_ms {
            return self.latency_ms;
        }
        let span = self.latency_max_ms - self.latency_ms + 1;
        let draw = splitmix64(!self.seed ^ n.wrapping_mul(0xD1B5_4A32_D192_ED03));
        self.latency_ms + draw % span
    }
}

/// Wraps a source with latency and a fraction of failing reads.
pub struct FaultyTileSource<S> {
    inner: S,
    settings: FaultSettings,
    reads: AtomicU64,
}

impl<S: TileSource> FaultyTileSource<S> {
    pub fn new(inner: S, settings: FaultSettings) -> Self {
        Self {
            inner,
            settings,
            reads: AtomicU64::new(0),
        }
    }
}

impl<S: TileSource> TileSource for FaultyTileSource<S> {
    fn read(&self, key: TileKey) -> Result<TileData, TileError> {
        let n = self.reads.fetch_add(1, Ordering::Relaxed);
        let latency = self.settings.latency_of_read_ms(n);
        if latency > 0 {
            std::thread::sleep(Duration::from_millis(latency));
        }
        let draw = splitmix64(self.settings.seed ^ n.wrapping_mul(0x9E37_79B9_7F4A_7C15));
        let uniform = (draw >> 11) as f64 / (1u64 << 53) as f64;
        if uniform < self.settings.fail_rate {
            return Err(TileError::Injected { key });
        }
        self.inner.read(key)
    }

    fn file_change(&self) -> Option<FileChange> {
        self.inner.file_change()
    }
}

fn splitmix64(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_latency_range_draws_each_read_within_it_repeatably() {
        let f = FaultSettings {
            latency_ms: 20,
            latency_max_ms: 200,
            seed: 9,
            ..Default::default()
        };
        let draws: Vec<u64> = (0..4000).map(|n| f.latency_of_read_ms(n)).collect();
        assert!(draws.iter().all(|&ms| (20..=200).contains(&ms)));
        // Spread over the range, both ends reached, and the same again for the same seed.
        assert_eq!(*draws.iter().min().unwrap(), 20);
        assert_eq!(*draws.iter().max().unwrap(), 200);
        let mean = draws.iter().sum::<u64>() as f64 / draws.len() as f64;
        assert!((mean - 110.0).abs() < 5.0, "mean {mean}");
        assert_eq!(draws[17], f.latency_of_read_ms(17));
        // A fixed latency stays fixed.
        let fixed = FaultSettings {
            latency_ms: 50,
            ..Default::default()
        };
        assert!((0..100).all(|n| fixed.latency_of_read_ms(n) == 50));
    }
}
