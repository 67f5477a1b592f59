//! The DEM fill: the compute pass writing new texels of the clipmap level textures from the
//! GPU tile cache (`shaders/fill_dem.wgsl`; toroidal update, spherical-clipmaps.md §4.1).

use super::detail::DetailResources;
use super::dispatch::{DispatchParams, compute_pipeline};
use super::gpu_data::{DemFillParams, DetailFillParams};
use super::shader::{self, WORKGROUP_SIZE};
use super::tiles::GpuTileCache;

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
