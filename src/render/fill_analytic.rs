//! Compute pass that writes new rows/columns of the clipmap level textures (toroidal update,
//! spherical-clipmaps.md §4.1) from the height source.

use crate::clipmap::levels::{GridRect, LevelGrid};
use crate::terrain::AnalyticPlanet;

use super::shader;

use super::detail::DetailResources;
use super::dispatch::{DispatchParams, compute_pipeline};
use super::gpu_data::FillParams;

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
