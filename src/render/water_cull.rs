//! Which terrain draws may leave the water's shading out (`shaders/water_cull.wgsl`).
//!
//! A CPU rasteriser runs both sides of a branch: every terrain fragment paid for the water's
//! shading even with no water in view, half of a plain frame over the Alps on lavapipe
//! (README "Water only where it can show"). A fragment shows water where the height it reads
//! from its level's normal texture lies below the water level, and that height is a convex
//! combination of texels of the level and, in the blend band, of the next coarser one. So a
//! level whose texels, and its coarser neighbour's, all lie at or above the level shows none.
//!
//! The GPU decides it, from the very texels the fragments read, with nothing read back:
//! the blocks a normal fill rewrote get their minimum height ([`BLOCK`]² texels each), each
//! level its minimum over its blocks, and every draw range is issued twice as an indirect draw,
//! once with the pipeline without the water's code and once with it; the cull writes the
//! instance counts so that exactly one of the two draws anything. The CPU's proof from the
//! data's bounds would fail where the detail's amplitude bound reaches below sea level (Lake
//! Garda's ±630 m), which the drawn texels need not.

use wgpu::util::DeviceExt;

use super::gpu_data::WaterCullParams;
use super::normals::SlotRect;

/// Edge of a block whose minimum height is kept, texels.
pub const BLOCK: u32 = 16;
/// Words of one `DrawIndexedIndirect` argument block.
const ARGS_WORDS: u64 = 5;

/// The lowest texel height (f32, as the normal texture returns it) at which a level is dry
/// for `water_level_m`: the level itself plus a margin for the filter's rounding. At a level
/// of 0 no margin is needed (sums of non-negative values with non-negative weights are never
/// negative under any rounding); elsewhere 1/128 of the level's magnitude covers a filter
/// that rounds to f16 (11 bits).
pub fn dry_from_m(water_level_m: f32) -> f32 {
    water_level_m + water_level_m.abs() / 128.0
}

/// Rust twin of `cs_draws`: whether a draw of `level` shows no water, given each level's lowest
/// texel height; `blends`: its pipeline reads the next coarser level too (the blend band).
pub fn dry(level_min_m: &[f32], level: usize, blends: bool, water_level_m: f32) -> bool {
    let at = dry_from_m(water_level_m);
    level_min_m[level] >= at && (!blends || level == 0 || level_min_m[level - 1] >= at)
}

/// A draw's entry in the cull's level list: its level, and whether its pipeline blends.
pub fn draw_entry(level: u32, blends: bool) -> u32 {
    level | (blends as u32) << 16
}

/// The blocks (layer << 16 | block index) that the texture rectangles `rects` touch, once each.
pub fn touched_blocks(rects: &[SlotRect], texture_size: u32) -> Vec<u32> {
    let per_row = texture_size / BLOCK;
    let mut touched = Vec::new();
    let mut out = Vec::new();
    for r in rects {
        let need = ((r.layer + 1) * per_row * per_row) as usize;
        if touched.len() < need {
            touched.resize(need, false);
        }
        let span = |start: u32, len: u32| {
            let first = start / BLOCK;
            let count = if len >= texture_size {
                per_row
            } else {
                ((start + len - 1) / BLOCK - first + 1).min(per_row)
            };
            (0..count).map(move |i| (first + i) % per_row)
        };
        if r.width == 0 || r.height == 0 {
            continue;
        }
        for by in span(r.y0, r.height) {
            for bx in span(r.x0, r.width) {
                let b = by * per_row + bx;
                let at = (r.layer * per_row * per_row + b) as usize;
                if !touched[at] {
                    touched[at] = true;
                    out.push(r.layer << 16 | b);
                }
            }
        }
    }
    out
}

/// The cull's buffers and pipelines.
pub struct WaterCull {
    /// Kept to grow the per-draw buffers when a frame has more ranges than they hold.
    device: wgpu::Device,
    params: wgpu::Buffer,
    block_min: wgpu::Buffer,
    normals: wgpu::TextureView,
    layout: wgpu::BindGroupLayout,
    blocks_pipeline: wgpu::ComputePipeline,
    draws_pipeline: wgpu::ComputePipeline,
    texture_size: u32,
    /// Sized on demand: the blocks to redo, each range's level, the indirect arguments.
    jobs: wgpu::Buffer,
    draw_levels: wgpu::Buffer,
    args: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    /// Ranges of the last frame encoded.
    draws: u32,
}

impl WaterCull {
    /// A cull over `levels` level textures of `texture_size`² texels in `normals`.
    pub fn new(
        device: &wgpu::Device,
        normals: &wgpu::TextureView,
        levels: u32,
        texture_size: u32,
    ) -> Self {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("water_cull.wgsl"),
            source: wgpu::ShaderSource::Wgsl(
                super::shader::assemble(super::shader::WATER_CULL).into(),
            ),
        });
        let storage = |binding, read_only| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("water cull layout"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: false },
                        view_dimension: wgpu::TextureViewDimension::D2Array,
                        multisampled: false,
                    },
                    count: None,
                },
                storage(2, false),
                storage(3, true),
                storage(4, true),
                storage(5, false),
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("water cull pipeline layout"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = |entry: &str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("water cull params"),
            size: std::mem::size_of::<WaterCullParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        // Every block starts wet (−3e38): a level never filled shows what its texture holds.
        let per_row = texture_size / BLOCK;
        let blocks = (super::shader::MAX_LEVELS.max(levels) * per_row * per_row) as usize;
        let block_min = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("water cull block minima"),
            contents: bytemuck::cast_slice(&vec![-3.0e38f32; blocks]),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let storage_buffer = |label, size: u64, usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: size.max(16),
                usage: usage | wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let jobs = storage_buffer(
            "water cull jobs",
            4 * blocks as u64,
            wgpu::BufferUsages::empty(),
        );
        let draw_levels = storage_buffer(
            "water cull draw levels",
            4 * 256,
            wgpu::BufferUsages::empty(),
        );
        let args = storage_buffer(
            "water cull indirect args",
            4 * ARGS_WORDS * 2 * 256,
            wgpu::BufferUsages::INDIRECT | wgpu::BufferUsages::COPY_SRC,
        );
        let bind_group = Self::bind(
            device,
            &layout,
            &params,
            normals,
            &block_min,
            &jobs,
            &draw_levels,
            &args,
        );
        Self {
            device: device.clone(),
            params,
            block_min,
            normals: normals.clone(),
            layout,
            blocks_pipeline: pipeline("cs_main"),
            draws_pipeline: pipeline("cs_draws"),
            texture_size,
            jobs,
            draw_levels,
            args,
            bind_group,
            draws: 0,
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn bind(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        params: &wgpu::Buffer,
        normals: &wgpu::TextureView,
        block_min: &wgpu::Buffer,
        jobs: &wgpu::Buffer,
        draw_levels: &wgpu::Buffer,
        args: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        fn buffer(binding: u32, b: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
            wgpu::BindGroupEntry {
                binding,
                resource: b.as_entire_binding(),
            }
        }
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("water cull bind group"),
            layout,
            entries: &[
                buffer(0, params),
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(normals),
                },
                buffer(2, block_min),
                buffer(3, jobs),
                buffer(4, draw_levels),
                buffer(5, args),
            ],
        })
    }

    /// Records the cull for a frame: the blocks of `written` (the normal pass's rectangles)
    /// get their minima, then the draws of `ranges` (each with its [`draw_entry`] in
    /// `entries`) their instance counts: argument block 2i is the dry pipeline's draw of range
    /// i, 2i + 1 the water's.
    pub fn encode(
        &mut self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        written: &[SlotRect],
        ranges: &[std::ops::Range<u32>],
        entries: &[u32],
        water_level_m: f32,
    ) {
        let jobs = touched_blocks(written, self.texture_size);
        let draws = ranges.len() as u64;
        let need_args = 4 * ARGS_WORDS * 2 * draws;
        if need_args > self.args.size() || 4 * draws > self.draw_levels.size() {
            let grown = draws.next_power_of_two();
            let device = &self.device;
            self.draw_levels = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("water cull draw levels"),
                size: 4 * grown,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            self.args = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("water cull indirect args"),
                size: 4 * ARGS_WORDS * 2 * grown,
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::INDIRECT
                    | wgpu::BufferUsages::COPY_SRC
                    | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            self.bind_group = Self::bind(
                device,
                &self.layout,
                &self.params,
                &self.normals,
                &self.block_min,
                &self.jobs,
                &self.draw_levels,
                &self.args,
            );
        }
        let params = WaterCullParams {
            dry_from_m: dry_from_m(water_level_m),
            block: BLOCK,
            blocks_per_row: self.texture_size / BLOCK,
            job_count: jobs.len() as u32,
            draw_count: draws as u32,
            ..Default::default()
        };
        queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        self.draws = draws as u32;
        if !jobs.is_empty() {
            queue.write_buffer(&self.jobs, 0, bytemuck::cast_slice(&jobs));
        }
        if draws > 0 {
            queue.write_buffer(&self.draw_levels, 0, bytemuck::cast_slice(entries));
            // Both draws of a range start with no instance; the cull gives one of them one.
            let args: Vec<u32> = ranges
                .iter()
                .flat_map(|r| {
                    let block = [r.end - r.start, 0, r.start, 0, 0];
                    block.into_iter().chain(block)
                })
                .collect();
            queue.write_buffer(&self.args, 0, bytemuck::cast_slice(&args));
        }
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("water cull"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, &self.bind_group, &[]);
        if !jobs.is_empty() {
            pass.set_pipeline(&self.blocks_pipeline);
            pass.dispatch_workgroups((jobs.len() as u32).div_ceil(64), 1, 1);
        }
        if draws > 0 {
            pass.set_pipeline(&self.draws_pipeline);
            pass.dispatch_workgroups(1, 1, 1);
        }
    }

    /// Reads back the last frame's choice per range (true: the dry pipeline draws it). Panics
    /// (a broken invariant, not an input) if both or neither of a range's draws have an
    /// instance.
    pub fn read_dry(&self, ctx: &super::GpuContext) -> Result<Vec<bool>, super::RenderError> {
        let size = (4 * ARGS_WORDS * 2 * self.draws as u64).max(4);
        let buffer = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("water cull readback"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        encoder.copy_buffer_to_buffer(&self.args, 0, &buffer, 0, size);
        ctx.queue.submit([encoder.finish()]);
        let (tx, rx) = std::sync::mpsc::channel();
        buffer.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        ctx.wait_idle()?;
        let failed = |e: String| super::RenderError::Readback(e);
        rx.recv()
            .map_err(|e| failed(e.to_string()))?
            .map_err(|e| failed(e.to_string()))?;
        let data = buffer
            .get_mapped_range(..)
            .map_err(|e| failed(e.to_string()))?;
        let words: &[u32] = bytemuck::cast_slice(&data);
        Ok((0..self.draws as usize)
            .map(|i| {
                let (dry, wet) = (words[10 * i + 1], words[10 * i + 6]);
                assert_eq!(dry + wet, 1, "range {i}: instances dry {dry}, wet {wet}");
                dry == 1
            })
            .collect())
    }

    /// The indirect arguments of the frame's draws (block 2i: range i without the water's
    /// code, 2i + 1: with it).
    pub fn args(&self) -> &wgpu::Buffer {
        &self.args
    }

    /// Byte offset of the dry (`wet` false) or water draw of range `i` in [`Self::args`].
    pub fn offset(i: usize, wet: bool) -> u64 {
        4 * ARGS_WORDS * (2 * i as u64 + wet as u64)
    }
}
