//! The GPU tile cache of a DEM pyramid, which the DEM fill (`render::fill_dem`) reads.
//!
//! Tiles live in an `R16Sint` texture array (one layer per slot, the avg plane only: min/max
//! serve the CPU's bounds) and a page table (one `u32` per tile of the pyramid, every level)
//! maps a tile to its slot. Slots are reused least recently used first, never while the
//! current frame needs the tile.

use std::collections::HashMap;

use wgpu::util::DeviceExt;

use crate::dem::pyramid::Pyramid;
use crate::stream::{TileData, TileKey};

use super::shader::NO_SLOT;

/// Tiles resident on the GPU.
pub struct GpuTileCache {
    texture: wgpu::Texture,
    /// The slots (an `R16Sint` array) and the page table, as the DEM fill binds them.
    pub(super) view: wgpu::TextureView,
    pub(super) page: wgpu::Buffer,
    tile_size: u32,
    /// Per slot: the tile and the frame it was last needed in.
    slots: Vec<Option<(TileKey, u64)>>,
    resident: HashMap<TileKey, u32>,
    /// First page-table entry and tiles across, per pyramid level.
    level_base: Vec<u32>,
    tiles_x: Vec<u32>,
    pub uploads: u64,
    pub bytes_uploaded: u64,
}

impl GpuTileCache {
    /// A cache of `slots` tiles (clamped to the device's array-layer limit) for `pyramid`.
    pub fn new(device: &wgpu::Device, pyramid: &Pyramid, slots: u32) -> Self {
        let slots = slots
            .clamp(1, device.limits().max_texture_array_layers)
            .max(1);
        let tile_size = pyramid.tile_size() as u32;
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("GPU tile cache"),
            size: wgpu::Extent3d {
                width: tile_size,
                height: tile_size,
                depth_or_array_layers: slots,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::R16Sint,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let view = texture.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        let mut level_base = Vec::new();
        let mut tiles_x = Vec::new();
        let mut total = 0u32;
        for l in pyramid.levels() {
            level_base.push(total);
            tiles_x.push(l.tiles_x as u32);
            total += l.tile_count() as u32;
        }
        let page = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("tile page table"),
            contents: &vec![0xff; 4 * total.max(1) as usize],
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        });
        Self {
            texture,
            view,
            page,
            tile_size,
            slots: vec![None; slots as usize],
            resident: HashMap::new(),
            level_base,
            tiles_x,
            uploads: 0,
            bytes_uploaded: 0,
        }
    }

    pub fn capacity(&self) -> usize {
        self.slots.len()
    }

    pub fn resident_count(&self) -> usize {
        self.resident.len()
    }

    pub fn contains(&self, key: &TileKey) -> bool {
        self.resident.contains_key(key)
    }

    /// Marks a resident tile as needed in `frame` (so it is not evicted this frame).
    pub fn touch(&mut self, key: &TileKey, frame: u64) -> bool {
        match self.resident.get(key) {
            Some(&slot) => {
                if let Some((_, used)) = &mut self.slots[slot as usize] {
                    *used = frame;
                }
                true
            }
            None => false,
        }
    }

    fn entry(&self, key: &TileKey) -> u64 {
        (self.level_base[key.level as usize] + key.ty * self.tiles_x[key.level as usize] + key.tx)
            as u64
    }

    /// Uploads `tile` into a free slot or the least recently used one not needed in `frame`.
    /// False when every slot is needed this frame (the cache is too small for the view).
    pub fn upload(&mut self, queue: &wgpu::Queue, tile: &TileData, frame: u64) -> bool {
        if self.resident.contains_key(&tile.key) {
            self.touch(&tile.key, frame);
            return true;
        }
        let slot = match self.slots.iter().position(Option::is_none) {
            Some(s) => s,
            None => {
                let Some((s, _)) = self
                    .slots
                    .iter()
                    .enumerate()
                    .filter_map(|(i, s)| s.map(|(_, used)| (i, used)))
                    .filter(|&(_, used)| used < frame)
                    .min_by_key(|&(_, used)| used)
                else {
                    return false;
                };
                let (old, _) = self.slots[s].take().expect("occupied slot");
                self.resident.remove(&old);
                queue.write_buffer(&self.page, 4 * self.entry(&old), &NO_SLOT.to_le_bytes());
                s
            }
        };
        let t = self.tile_size;
        queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &self.texture,
                mip_level: 0,
                origin: wgpu::Origin3d {
                    x: 0,
                    y: 0,
                    z: slot as u32,
                },
                aspect: wgpu::TextureAspect::All,
            },
            bytemuck::cast_slice(&tile.avg),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(2 * t),
                rows_per_image: Some(t),
            },
            wgpu::Extent3d {
                width: t,
                height: t,
                depth_or_array_layers: 1,
            },
        );
        queue.write_buffer(
            &self.page,
            4 * self.entry(&tile.key),
            &(slot as u32).to_le_bytes(),
        );
        self.slots[slot] = Some((tile.key, frame));
        self.resident.insert(tile.key, slot as u32);
        self.uploads += 1;
        self.bytes_uploaded += 2 * tile.avg.len() as u64;
        true
    }

    /// First page-table entry and tiles across of a pyramid level (for the fill parameters).
    pub fn level_page(&self, level: usize) -> (u32, u32) {
        (self.level_base[level], self.tiles_x[level])
    }
}
