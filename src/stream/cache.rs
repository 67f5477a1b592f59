//! The decoded-tile cache: least recently used tiles go first once the byte budget is full.

use std::sync::Arc;

use lru::LruCache;

use super::TileKey;
use super::source::TileData;

pub struct TileCache {
    tiles: LruCache<TileKey, Arc<TileData>>,
    bytes: u64,
    budget: u64,
    pub hits: u64,
    pub misses: u64,
    pub evicted: u64,
}

impl TileCache {
    pub fn new(budget_bytes: u64) -> Self {
        Self {
            tiles: LruCache::unbounded(),
            bytes: 0,
            budget: budget_bytes,
            hits: 0,
            misses: 0,
            evicted: 0,
        }
    }

    /// The tile, marked as used now; counts a hit or a miss.
    pub fn get(&mut self, key: &TileKey) -> Option<Arc<TileData>> {
        let found = self.tiles.get(key).cloned();
        if found.is_some() {
            self.hits += 1;
        } else {
            self.misses += 1;
        }
        found
    }

    /// The tile without touching its age or the statistics.
    pub fn peek(&self, key: &TileKey) -> Option<&Arc<TileData>> {
        self.tiles.peek(key)
    }

    /// Marks a tile as used now (a hit seen through [`TileCache::peek`]), so tiles the CPU
    /// keeps reading stay while tiles that only passed through to the GPU go first.
    pub fn promote(&mut self, key: &TileKey) {
        self.tiles.promote(key);
    }

    pub fn contains(&self, key: &TileKey) -> bool {
        self.tiles.contains(key)
    }

    /// Inserts a tile and evicts the least recently used ones until the budget holds again.
    /// A single tile larger than the budget is still kept (the budget is then exceeded by it).
    pub fn insert(&mut self, tile: Arc<TileData>) {
        let key = tile.key;
        self.insert_keeping(tile, |k| *k == key);
    }

    /// Inserts a tile, then evicts the least recently used tiles that `keep` does not name
    /// until the budget holds again; the kept ones (what the frame in progress needs) stay even
    /// beyond it, so a budget smaller than one frame's tiles, or 0, still lets every frame
    /// complete instead of evicting a tile before it is used.
    pub fn insert_keeping(&mut self, tile: Arc<TileData>, keep: impl Fn(&TileKey) -> bool) {
        let bytes = tile.bytes();
        if let Some(old) = self.tiles.put(tile.key, tile) {
            self.bytes -= old.bytes();
        }
        self.bytes += bytes;
        self.trim_keeping(keep);
    }

    /// Evicts the least recently used tiles that `keep` does not name until the budget holds
    /// (or only kept tiles are left).
    pub fn trim_keeping(&mut self, keep: impl Fn(&TileKey) -> bool) {
        while self.bytes > self.budget {
            // `iter` runs from the most recently used; the victim is the last one not kept.
            let Some(victim) = self.tiles.iter().rev().map(|(k, _)| *k).find(|k| !keep(k)) else {
                return;
            };
            if let Some(t) = self.tiles.pop(&victim) {
                self.bytes -= t.bytes();
                self.evicted += 1;
            }
        }
    }

    pub fn bytes(&self) -> u64 {
        self.bytes
    }

    /// Bytes of the tiles `keep` names (what a trim may keep beyond the budget).
    pub fn bytes_kept(&self, keep: impl Fn(&TileKey) -> bool) -> u64 {
        self.tiles
            .iter()
            .filter(|(k, _)| keep(k))
            .map(|(_, t)| t.bytes())
            .sum()
    }

    pub fn budget(&self) -> u64 {
        self.budget
    }

    pub fn len(&self) -> usize {
        self.tiles.len()
    }

    pub fn is_empty(&self) -> bool {
        self.tiles.is_empty()
    }

    /// Hits / (hits + misses), or None before the first lookup.
    pub fn hit_rate(&self) -> Option<f64> {
        let n = self.hits + self.misses;
        (n > 0).then(|| self.hits as f64 / n as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dem::pyramid::Encoding;

    fn tile(tx: u32) -> Arc<TileData> {
        Arc::new(TileData {
            key: TileKey {
                level: 0,
                tx,
                ty: 0,
            },
            tile_size: 16,
            encoding: Encoding::default(),
            avg: vec![0; 256],
            min: vec![0; 256],
            max: vec![0; 256],
        })
    }

    #[test]
    fn stays_within_the_byte_budget_and_evicts_the_least_recently_used() {
        let one = tile(0).bytes();
        let mut c = TileCache::new(3 * one);
        for tx in 0..3 {
            c.insert(tile(tx));
        }
        assert!(
            c.get(&TileKey {
                level: 0,
                tx: 0,
                ty: 0
            })
            .is_some()
        );
        c.insert(tile(3));
        assert!(c.bytes() <= c.budget());
        assert_eq!(c.len(), 3);
        // Tile 1 was the least recently used (0 was touched by `get`).
        assert!(!c.contains(&TileKey {
            level: 0,
            tx: 1,
            ty: 0
        }));
        assert!(c.contains(&TileKey {
            level: 0,
            tx: 0,
            ty: 0
        }));
        assert_eq!(c.evicted, 1);
    }

    /// A budget of 0 keeps exactly what the frame needs, and nothing else.
    #[test]
    fn kept_tiles_stay_beyond_the_budget() {
        let key = |tx| TileKey {
            level: 0,
            tx,
            ty: 0,
        };
        let mut c = TileCache::new(0);
        let needed = [key(1), key(3)];
        for tx in 0..5 {
            c.insert_keeping(tile(tx), |k| needed.contains(k));
        }
        assert_eq!(c.len(), 2);
        assert!(needed.iter().all(|k| c.contains(k)));
        // Once no longer needed, they go at the next trim.
        c.trim_keeping(|k| *k == key(3));
        assert_eq!(c.len(), 1);
        assert!(c.contains(&key(3)) && c.bytes() == tile(3).bytes());
    }
}
