//! GPU resources of the procedural detail shared by both fills (group 1 of their pipelines):
//! the per-dispatch detail blocks, the relief map (a storage buffer) and the level textures of partial octaves.

use std::sync::Arc;

use wgpu::util::DeviceExt;

use crate::clipmap::levels::LevelGrid;
use crate::procedural::Detail;

use super::dispatch::DispatchParams;
use super::gpu_data::DetailFillParams;

/// Format of the partial-octave textures: σ·t_k in metres. An octave's value is small next to
/// the whole height, so half floats keep it to one half-float ulp (2⁻¹⁰) of itself (llvmpipe
/// rounds the store toward zero).
pub const PARTIALS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

pub struct DetailResources {
    detail: Option<Arc<Detail>>,
    blend_fraction: f64,
    layout: wgpu::BindGroupLayout,
    params: DispatchParams,
    relief: wgpu::Buffer,
    bind_group: Option<wgpu::BindGroup>,
}

impl DetailResources {
    /// Room for `capacity` dispatches per frame; `detail` `None`: every block says "no
    /// octaves" (one pipeline either way).
    pub fn new(
        device: &wgpu::Device,
        detail: Option<Arc<Detail>>,
        blend_fraction: f64,
        capacity: u32,
    ) -> Self {
        let params = DispatchParams::new::<DetailFillParams>(device, "detail params", capacity);
        let (cols, rows, values) = match &detail {
            Some(d) => {
                let m = d.roughness();
                (m.cols, m.rows, m.values.clone())
            }
            None => (1, 1, vec![0.0]),
        };
        let relief = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("relief map"),
            contents: bytemuck::cast_slice(&values),
            // COPY_DST: the editor repaints it (`DetailResources::replace_detail`).
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        });
        let _ = (cols, rows);
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("detail layout"),
            entries: &[
                params.layout_entry(0),
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Storage { read_only: true },
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::StorageTexture {
                        access: wgpu::StorageTextureAccess::WriteOnly,
                        format: PARTIALS_FORMAT,
                        view_dimension: wgpu::TextureViewDimension::D2Array,
                    },
                    count: None,
                },
            ],
        });
        Self {
            detail,
            blend_fraction,
            layout,
            params,
            relief,
            bind_group: None,
        }
    }

    /// Replaces the detail (the editor's change) and uploads its relief map; the next fills
    /// use it. Refused (returns false, nothing changed) without a detail before or when the new
    /// relief map has another size than the buffer.
    pub fn replace_detail(&mut self, queue: &wgpu::Queue, detail: Arc<Detail>) -> bool {
        let values = &detail.roughness().values;
        let fits = std::mem::size_of_val(values.as_slice()) as u64 == self.relief.size();
        if self.detail.is_none() || !fits {
            return false;
        }
        queue.write_buffer(&self.relief, 0, bytemuck::cast_slice(values));
        self.detail = Some(detail);
        true
    }

    /// The fills' group-1 layout.
    pub fn layout(&self) -> &wgpu::BindGroupLayout {
        &self.layout
    }

    pub fn detail(&self) -> Option<&Arc<Detail>> {
        self.detail.as_ref()
    }

    /// The relief map (the terrain pass's bump reads it too).
    pub fn relief(&self) -> &wgpu::Buffer {
        &self.relief
    }

    pub fn capacity(&self) -> u32 {
        self.params.capacity()
    }

    /// Binds the partial-octave level textures the fills write.
    pub fn bind(&mut self, device: &wgpu::Device, partials: &wgpu::TextureView) {
        self.bind_group = Some(device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("detail bind group"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: self.params.binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: self.relief.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(partials),
                },
            ],
        }));
    }

    /// The block of a dispatch starting at grid point (gx, gy) of `grid`, and the detail at
    /// that point its texels leave out (metres; the fill takes it off its reference height).
    pub fn block(&self, grid: &LevelGrid, gx: i64, gy: i64) -> (DetailFillParams, f64) {
        DetailFillParams::with_offset(self.detail.as_deref(), grid, gx, gy, self.blend_fraction)
    }

    /// Writes the blocks of this frame's dispatches (index i pairs with the fill's block i).
    pub fn write(&self, queue: &wgpu::Queue, blocks: &[DetailFillParams]) {
        self.params.write(queue, blocks);
    }

    /// Binds block `i` at group 1 of a fill pass.
    pub fn set(&self, pass: &mut wgpu::ComputePass<'_>, i: usize) {
        let bind_group = self.bind_group.as_ref().expect("detail bound before use");
        pass.set_bind_group(1, bind_group, &[self.params.offset(i)]);
    }
}

/// The level textures of partial octaves: one RGBA layer per level, as the heights.
pub fn partials_texture(device: &wgpu::Device, size: u32, layers: u32) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some("clipmap partial octaves"),
        size: wgpu::Extent3d {
            width: size,
            height: size,
            depth_or_array_layers: layers,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: PARTIALS_FORMAT,
        usage: wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::STORAGE_BINDING
            | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    })
}
