//! Which tile source serves a pyramid: its memory map, or the remote store it names, with
//! the fault injection wrapped around either. Apart from both sources so that neither imports
//! the other.

use std::sync::Arc;

use super::remote::RemoteTileSource;
use super::source::{FaultSettings, FaultyTileSource, MmapTileSource, TileSource};
use crate::dem::pyramid::Pyramid;

/// The source for a pyramid with `faults` applied (none when inactive).
/// A remote pyramid's source is [`RemoteTileSource`] (faults wrap it the same way).
pub fn open_source(pyramid: Arc<Pyramid>, faults: FaultSettings) -> Arc<dyn TileSource> {
    if let Some(remote) = RemoteTileSource::new(pyramid.clone()) {
        return if faults.is_active() {
            Arc::new(FaultyTileSource::new(remote, faults))
        } else {
            Arc::new(remote)
        };
    }
    let mmap = MmapTileSource::new(pyramid);
    if faults.is_active() {
        Arc::new(FaultyTileSource::new(mmap, faults))
    } else {
        Arc::new(mmap)
    }
}
