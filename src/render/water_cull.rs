//! Which terrain draws may leave the water's shading out (`shaders/water_cull.wgsl`).
//!
//! A CPU rasteriser runs both sides of a branch: every terrain fragment paid for the water's
//! shading even with no water in view, half of a plain frame over the Alps on lavapipe
//! (docs/measurements.md#water-only-where-it-can-show). A fragment shows water where the height it reads
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

use crate::clipmap::levels::LevelGrid;

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

/// Rust twin of `cs_draws`: whether a draw of `level` shows no water, given the lowest texel
/// height within its reach in its own texture and in the next coarser one's; `blends`: its
/// pipeline reads the coarser level too (the blend band).
pub fn dry(
    own_min_m: f32,
    coarse_min_m: f32,
    level: u32,
    blends: bool,
    water_level_m: f32,
) -> bool {
    let at = dry_from_m(water_level_m);
    own_min_m >= at && (!blends || level == 0 || coarse_min_m >= at)
}

/// How far from the viewer level `level`'s fragments lie in map offsets (|Δφ|, |Δθ|): its rings
/// lie within θ̃ = π·2^−l of the viewer (spherical-clipmaps.md §3.4), so |Δθ| ≤ θ̃ (the
/// triangle inequality) and, where that cap holds no pole, |Δφ| ≤ asin(sin θ̃ / sin θv), the
/// widest longitude span of a cap; one holding a pole spans every longitude.
pub fn reach_rad(level: u32, theta_v_rad: f64) -> (f64, f64) {
    let outer = crate::clipmap::settings::level_outer_theta_rad(level);
    let dphi = if theta_v_rad > outer && std::f64::consts::PI - theta_v_rad > outer {
        (outer.sin() / theta_v_rad.sin()).min(1.0).asin()
    } else {
        std::f64::consts::PI
    };
    (dphi, outer)
}

/// The texels of `grid`'s texture a fragment within `reach` (|Δφ|, |Δθ|) of the viewer may read
/// through the bilinear filter: a toroidal box [x0, y0, width, height] around the viewer's
/// texel. Padded by 2 % and 2 texels beyond the filter's one: the GPU's offsets are f32 (and
/// approximated on the finest levels, spherical-clipmaps.md eq. 9).
pub fn read_box(grid: &LevelGrid, phi_v_rad: f64, theta_v_rad: f64, reach: (f64, f64)) -> [u32; 4] {
    let s = grid.size as f64;
    let (gx, gy) = grid.viewer_texel(phi_v_rad, theta_v_rad);
    let span = |centre: f64, half_texels: f64| {
        let half = half_texels * 1.02 + 3.0;
        if 2.0 * half + 1.0 >= s {
            return (0, grid.size);
        }
        let lo = (centre - half).floor();
        let width = (centre + half).floor() - lo + 1.0;
        (lo.rem_euclid(s) as u32, width as u32)
    };
    let (x0, width) = span(gx, reach.0 / grid.dphi_rad);
    let (y0, height) = span(gy, reach.1 / grid.dtheta_rad);
    [x0, y0, width, height]
}

/// The boxes `cs_draws` reads per level (2 × MAX_LEVELS): level l's own texels within its
/// reach, then level l − 1's at the same offsets; a level not held reads its whole texture.
pub fn level_boxes(grids: &[Option<LevelGrid>], phi_v_rad: f64, theta_v_rad: f64) -> Vec<[u32; 4]> {
    let mut boxes = vec![[0, 0, u32::MAX, u32::MAX]; 2 * super::shader::MAX_LEVELS as usize];
    for (l, grid) in grids.iter().enumerate() {
        let reach = reach_rad(l as u32, theta_v_rad);
        if let Some(g) = grid {
            boxes[2 * l] = read_box(g, phi_v_rad, theta_v_rad, reach);
        }
        if let Some(Some(coarse)) = l.checked_sub(1).map(|c| grids[c]) {
            boxes[2 * l + 1] = read_box(&coarse, phi_v_rad, theta_v_rad, reach);
        }
    }
    boxes
}

/// Whether texel (x, y) of a `size`² texture lies in a block that `b` touches (what `box_min`
/// reads): the Rust side of the twin.
pub fn in_box_blocks(b: [u32; 4], x: u32, y: u32, size: u32) -> bool {
    let inside = |start: u32, len: u32, t: u32| {
        if len >= size {
            return true;
        }
        let first = start / BLOCK;
        let count = (start + len - 1) / BLOCK - first + 1;
        let per_row = size / BLOCK;
        (t / BLOCK + per_row - first) % per_row < count.min(per_row)
    };
    inside(b[0], b[2], x) && inside(b[1], b[3], y)
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

/// What the cull needs of a frame.
pub struct CullFrame<'a> {
    /// The normal pass's rectangles: their blocks' minima are redone.
    pub written: &'a [SlotRect],
    /// The draw ranges and, per range, its [`draw_entry`].
    pub ranges: &'a [std::ops::Range<u32>],
    pub entries: Vec<u32>,
    /// What each level's fragments may read ([`level_boxes`]).
    pub boxes: Vec<[u32; 4]>,
    /// As the terrain pass's look has it (f32).
    pub water_level_m: f32,
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
    /// Per level, what its fragments may read ([`level_boxes`]), and the last frame's.
    boxes: wgpu::Buffer,
    last_boxes: Vec<[u32; 4]>,
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
        let storage = super::compute_storage_entry;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("water cull layout"),
            entries: &[
                super::compute_uniform_entry(0),
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
                storage(6, true),
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
        let boxes = storage_buffer(
            "water cull level boxes",
            16 * 2 * super::shader::MAX_LEVELS as u64,
            wgpu::BufferUsages::empty(),
        );
        let bind_group = Self::bind(
            device,
            &layout,
            &params,
            normals,
            [&block_min, &jobs, &draw_levels, &args, &boxes],
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
            boxes,
            last_boxes: Vec::new(),
            bind_group,
            draws: 0,
        }
    }

    /// The bind group; `storage`: block minima, jobs, draw levels, arguments, boxes
    /// (bindings 2–6).
    fn bind(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        params: &wgpu::Buffer,
        normals: &wgpu::TextureView,
        storage: [&wgpu::Buffer; 5],
    ) -> wgpu::BindGroup {
        let [block_min, jobs, draw_levels, args, boxes] = storage;
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
                buffer(6, boxes),
            ],
        })
    }

    /// Records the cull for a frame: the blocks the normal pass wrote get their minima, then
    /// the frame's draws their instance counts: argument block 2i is the dry pipeline's draw
    /// of range i, 2i + 1 the water's.
    pub fn encode(
        &mut self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        frame: CullFrame<'_>,
    ) {
        let CullFrame {
            written,
            ranges,
            entries,
            boxes,
            water_level_m,
        } = frame;
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
                [
                    &self.block_min,
                    &self.jobs,
                    &self.draw_levels,
                    &self.args,
                    &self.boxes,
                ],
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
        queue.write_buffer(&self.boxes, 0, bytemuck::cast_slice(&boxes));
        self.last_boxes = boxes;
        self.draws = draws as u32;
        if !jobs.is_empty() {
            queue.write_buffer(&self.jobs, 0, bytemuck::cast_slice(&jobs));
        }
        if draws > 0 {
            queue.write_buffer(&self.draw_levels, 0, bytemuck::cast_slice(&entries));
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

    /// The last frame's [`level_boxes`].
    pub fn boxes(&self) -> &[[u32; 4]] {
        &self.last_boxes
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
