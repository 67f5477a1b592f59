//! Compute pass that writes new rows/columns of the clipmap level textures (toroidal update,
//! spherical-clipmaps.md §4.1) from the height source.

use crate::clipmap::levels::{GridRect, LevelGrid};
use crate::terrain::AnalyticPlanet;

use super::shader;

use super::detail::DetailResources;
use super::gpu_data::FillParams;

/// The compute pipeline of a fill: entry point `cs_main`, its own bind group and the detail's
/// (group 1).
pub(super) fn compute_pipeline(
    device: &wgpu::Device,
    label: &str,
    module: &wgpu::ShaderModule,
    layout: &wgpu::BindGroupLayout,
    detail: &wgpu::BindGroupLayout,
) -> wgpu::ComputePipeline {
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: &[Some(layout), Some(detail)],
        immediate_size: 0,
    });
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(label),
        layout: Some(&pipeline_layout),
        module,
        entry_point: Some("cs_main"),
        compilation_options: Default::default(),
        cache: None,
    })
}

/// Per-dispatch parameter blocks of a compute fill: one uniform buffer bound with a dynamic
/// offset, one block per dispatch at the device's offset alignment (both fills use it).
pub(super) struct DispatchParams {
    buffer: wgpu::Buffer,
    size: u64,
    stride: u64,
    capacity: u32,
}

impl DispatchParams {
    /// Room for `capacity` blocks of `T`.
    pub(super) fn new<T: bytemuck::Pod>(device: &wgpu::Device, label: &str, capacity: u32) -> Self {
        let size = std::mem::size_of::<T>() as u64;
        let align = device.limits().min_uniform_buffer_offset_alignment as u64;
        let stride = size.div_ceil(align) * align;
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: stride * capacity as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self {
            buffer,
            size,
            stride,
            capacity,
        }
    }

    /// The compute stage's layout entry for the blocks at `binding` (one block, moved by the
    /// dynamic offset).
    pub(super) fn layout_entry(&self, binding: u32) -> wgpu::BindGroupLayoutEntry {
        wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: true,
                min_binding_size: wgpu::BufferSize::new(self.size),
            },
            count: None,
        }
    }

    /// The binding: one block, moved by the dynamic offset.
    pub(super) fn binding(&self) -> wgpu::BindingResource<'_> {
        wgpu::BindingResource::Buffer(wgpu::BufferBinding {
            buffer: &self.buffer,
            offset: 0,
            size: wgpu::BufferSize::new(self.size),
        })
    }

    pub(super) fn capacity(&self) -> u32 {
        self.capacity
    }

    /// Writes the blocks (at most `capacity`; the rest are the caller's to split over frames).
    pub(super) fn write<T: bytemuck::Pod>(&self, queue: &wgpu::Queue, blocks: &[T]) {
        let mut bytes = vec![0u8; (self.stride * blocks.len() as u64) as usize];
        for (i, b) in blocks.iter().enumerate() {
            let at = i * self.stride as usize;
            bytes[at..at + self.size as usize].copy_from_slice(bytemuck::bytes_of(b));
        }
        queue.write_buffer(&self.buffer, 0, &bytes);
    }

    /// The dynamic offset of block `i`.
    pub(super) fn offset(&self, i: usize) -> u32 {
        (i as u64 * self.stride) as u32
    }
}

/// Pipeline and per-dispatch parameter buffer of the analytic fill.
pub struct FillPass {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    params: DispatchParams,
    bind_group: Option<wgpu::BindGroup>,
}

/// One rectangle to write, as the CPU prepared it.
#[derive(Clone, Copy, Debug)]
pub struct FillJob {
    pub grid: LevelGrid,
    pub rect: GridRect,
}

impl FillPass {
    pub fn new(device: &wgpu::Device, capacity: u32, detail: &DetailResources) -> Self {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("fill_analytic.wgsl"),
            source: wgpu::ShaderSource::Wgsl(shader::assemble(shader::FILL_ANALYTIC).into()),
        });
        let params = DispatchParams::new::<FillParams>(device, "fill params", capacity);
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("fill layout"),
            entries: &[
                params.layout_entry(0),
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::StorageTexture {
                        access: wgpu::StorageTextureAccess::WriteOnly,
                        format: wgpu::TextureFormat::R32Float,
                        view_dimension: wgpu::TextureViewDimension::D2Array,
                    },
                    count: None,
                },
            ],
        });
        let pipeline = compute_pipeline(device, "fill pipeline", &module, &layout, detail.layout());
        Self {
            pipeline,
            layout,
            params,
            bind_group: None,
        }
    }

    /// Binds the level texture array the pass writes into.
    pub fn set_target(&mut self, device: &wgpu::Device, heights: &wgpu::TextureView) {
        self.bind_group = Some(device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("fill bind group"),
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
            ],
        }));
    }

    /// Writes the parameters of `jobs` and records their dispatches. Returns texels written.
    /// More jobs than the buffer holds are an error of the caller (bounded by 2 per level).
    pub fn encode(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        planet: &AnalyticPlanet,
        detail: &DetailResources,
        jobs: &[FillJob],
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) -> u64 {
        // Each rectangle cut along its level's anchor lattice (`GridRect::anchored_pieces`).
        let pieces: Vec<(&FillJob, GridRect, [i64; 2])> = jobs
            .iter()
            .flat_map(|job| {
                job.rect
                    .anchored_pieces(job.grid.anchor_block())
                    .into_iter()
                    .map(move |(piece, anchor)| (job, piece, anchor))
            })
            .collect();
        assert!(
            pieces.len() as u32 <= self.params.capacity(),
            "more fill jobs than the parameter buffer holds"
        );
        if pieces.is_empty() {
            return 0;
        }
        let bind_group = self
            .bind_group
            .as_ref()
            .expect("fill target set before encoding");
        let (details, offsets): (Vec<_>, Vec<_>) = pieces
            .iter()
            .map(|(job, _, anchor)| detail.block(&job.grid, anchor[0], anchor[1]))
            .unzip();
        let blocks: Vec<FillParams> = pieces
            .iter()
            .zip(&offsets)
            .map(|((job, piece, anchor), &offset)| {
                FillParams::new(planet, &job.grid, piece, *anchor)
                    .with_detail_offset(&job.grid, offset)
            })
            .collect();
        self.params.write(queue, &blocks);
        detail.write(queue, &details);
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("clipmap fill"),
            timestamp_writes: timestamps,
        });
        pass.set_pipeline(&self.pipeline);
        let mut texels = 0;
        for (i, (_, piece, _)) in pieces.iter().enumerate() {
            pass.set_bind_group(0, bind_group, &[self.params.offset(i)]);
            detail.set(&mut pass, i);
            pass.dispatch_workgroups(
                piece.width.div_ceil(shader::WORKGROUP_SIZE),
                piece.height.div_ceil(shader::WORKGROUP_SIZE),
                1,
            );
            texels += piece.texels();
        }
        texels
    }
}

/// Ground spacing used for the band limit of a level: twice its θ spacing, a per-level
/// constant (so strips written at different times agree) that bounds the φ spacing away from
/// the poles (anisotropy ≤ 2, see `clipmap::levels`).
pub fn band_limit_texel_m(grid: &LevelGrid, radius_m: f64) -> f64 {
    2.0 * grid.dtheta_rad * radius_m
}
