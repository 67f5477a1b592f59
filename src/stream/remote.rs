//! The streamer's source for a remote pyramid (`crate::dem::remote` has the store: requests,
//! coalescing, the disk cache).

use std::sync::Arc;

use super::source::{TileData, TileSource};
use super::{TileError, TileKey};
use crate::dem::DemError;
use crate::dem::pyramid::Pyramid;

/// Tiles of a remote pyramid for the streamer: each read is a resident tile, a disk-cache hit
/// or a (batched) range request, accepted only when its CRC and codes check.
pub struct RemoteTileSource {
    pyramid: Arc<Pyramid>,
}

impl RemoteTileSource {
    /// None when the pyramid is a local file.
    pub fn new(pyramid: Arc<Pyramid>) -> Option<Self> {
        pyramid.remote()?;
        Some(Self { pyramid })
    }
}

impl TileSource for RemoteTileSource {
    fn read(&self, key: TileKey) -> Result<TileData, TileError> {
        let err = |e: DemError| TileError::Read {
            key,
            message: e.to_string(),
        };
        let (level, tx, ty) = (key.level as usize, key.tx as usize, key.ty as usize);
        let bytes = self
            .pyramid
            .remote_tile_payload(level, tx, ty)
            .map_err(err)?;
        let view = self
            .pyramid
            .tile_of_payload(level, tx, ty, &bytes)
            .map_err(err)?;
        Ok(TileData::from_view(key, view))
    }
}
