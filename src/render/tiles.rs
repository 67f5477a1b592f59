//! The GPU tile cache of a DEM pyramid and the compute pass that fills clipmap level textures
//! from it.
//!
//! Tiles live in an `R16Sint` texture array (one layer per slot, the avg plane only: min/max
//! serve the CPU's bounds) and a page table (one `u32` per tile of the pyramid, every level)
//! maps a tile to its slot. Slots are reused least recently used first, never while the
//! current frame needs the tile.

use std::collections::HashMap;

use wgpu::util::DeviceExt;

use crate::dem::pyramid::Pyramid;
use crate::stream::{TileData, TileKey};

use super::detail::DetailResources;
use super::dispatch::{DispatchParams, compute_pipeline};
use super::shader;

pub use super::gpu_data::DemFillParams;
use super::gpu_data::DetailFillParams;
use super::shader::{NO_SLOT, WORKGROUP_SIZE};

/// Tiles resident on the GPU.
pub struct GpuTileCache {
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    page: wgpu::Buffer,
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

/// The compute pass writing level textures from the tile cache.
pub struct DemFillPass {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    params: DispatchParams,
    bind_group: Option<wgpu::BindGroup>,
}

impl DemFillPass {
    pub fn new(device: &wgpu::Device, capacity: u32, detail: &DetailResources) -> Self {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("fill_dem.wgsl"),
            source: wgpu::ShaderSource::Wgsl(shader::assemble(shader::FILL_DEM).into()),
        });
        let params = DispatchParams::new::<DemFillParams>(device, "DEM fill params", capacity);
        let entry = |binding, ty| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty,
            count: None,
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("DEM fill layout"),
            entries: &[
                params.layout_entry(0),
                entry(
                    1,
                    wgpu::BindingType::StorageTexture {
                        access: wgpu::StorageTextureAccess::WriteOnly,
                        format: wgpu::TextureFormat::R32Float,
                        view_dimension: wgpu::TextureViewDimension::D2Array,
                    },
                ),
                entry(
                    2,
                    wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Sint,
                        view_dimension: wgpu::TextureViewDimension::D2Array,
                        multisampled: false,
                    },
                ),
                entry(
                    3,
                    wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Storage { read_only: true },
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                ),
            ],
        });
        let pipeline = compute_pipeline(
            device,
            "DEM fill pipeline",
            &module,
            &layout,
            detail.layout(),
        );
        Self {
            pipeline,
            layout,
            params,
            bind_group: None,
        }
    }

    /// Binds the level texture array written and the tile cache read.
    pub fn bind(
        &mut self,
        device: &wgpu::Device,
        heights: &wgpu::TextureView,
        tiles: &GpuTileCache,
    ) {
        self.bind_group = Some(device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("DEM fill bind group"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: self.params.binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(heights),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(&tiles.view),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: tiles.page.as_entire_binding(),
                },
            ],
        }));
    }

    /// Writes the parameters and records one dispatch per job; returns texels written. Jobs
    /// beyond the parameter buffer's capacity are left for the caller to split over frames
    /// (it never has that many: a few per level).
    pub fn encode(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        jobs: &[DemFillParams],
        detail: &DetailResources,
        details: &[DetailFillParams],
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) -> u64 {
        let n = jobs.len().min(self.params.capacity() as usize);
        let n = n.min(detail.capacity() as usize);
        let jobs = &jobs[..n];
        if jobs.is_empty() {
            return 0;
        }
        let bind_group = self.bind_group.as_ref().expect("DEM fill bound before use");
        self.params.write(queue, jobs);
        detail.write(queue, &details[..n]);
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("clipmap DEM fill"),
            timestamp_writes: timestamps,
        });
        pass.set_pipeline(&self.pipeline);
        let mut texels = 0;
        for (i, p) in jobs.iter().enumerate() {
            pass.set_bind_group(0, bind_group, &[self.params.offset(i)]);
            detail.set(&mut pass, i);
            pass.dispatch_workgroups(
                p.extent[0].div_ceil(WORKGROUP_SIZE),
                p.extent[1].div_ceil(WORKGROUP_SIZE),
                1,
            );
            texels += p.extent[0] as u64 * p.extent[1] as u64;
        }
        texels
    }

    pub fn capacity(&self) -> u32 {
        self.params.capacity()
    }
}
