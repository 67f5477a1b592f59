//! The vertex pre-pass: every ring vertex a frame's clipmap draws use is placed once, by a
//! compute pass (`cs_place` in `shaders/terrain.wgsl`, the vertex stage's own `ring_vertex`),
//! into a buffer the draws then read as their vertex buffer (`vs_placed`).
//!
//! Why: a CPU rasteriser (llvmpipe, SwiftShader) shades vertices on one thread, and again for
//! every index its small vertex cache misses; the ring mesh's rows are n + 2 vertices apart, so
//! rows evict each other. The placement (map transform, 4–8 texel reads, a morph's two
//! neighbours, then the haze's integral) was 35–43 % of a `ground` frame at 960×540 on llvmpipe, less
//! at 1920×1080, where the fragments outweigh it. A compute pass places
//! each vertex exactly once, on every core. A GPU pays one write and one read of 48 bytes per
//! vertex instead (`TerrainRenderer::set_place_in_vertex_stage` draws the old way, and so does a
//! device whose storage buffers cannot hold one vertex per mesh vertex).
//!
//! Which vertices: the distinct vertices of each drawn sector range (precomputed per range,
//! [`RangeVertices`]), each placed by the variant of the first range that uses it. A vertex
//! shared by two ranges of different variants is placed the same by both (a morph or a blend
//! is zero on every vertex two variants share; the seams between draws rely on that already).

use std::ops::Range;

use crate::clipmap::RingMesh;
use crate::clipmap::draw_list::Variant;
use crate::clipmap::mesh::RangeVertices;

use super::gpu_data::PlacedVertex;
use super::shader::{PLACE_NONE, PLACE_WORKGROUP};

/// The pre-pass's buffers and the frame's work lists.
pub struct Placement {
    /// One [`PlacedVertex`] per mesh vertex (`STORAGE` for the pass, `VERTEX` for the draws).
    placed: wgpu::Buffer,
    /// Group 2 of `cs_place`: the output and the work list.
    layout: wgpu::BindGroupLayout,
    /// Per variant (plain, blend, morph): the work list's buffer and bind group.
    work: [WorkList; 3],
    lists: RangeVertices,
    /// `seen[v] == frame`: vertex v is already in this frame's lists.
    seen: Vec<u32>,
    frame: u32,
    scratch: [Vec<u32>; 3],
    /// The pieces the work lists were built for: a frame drawing the same ones (a camera at
    /// rest, or one that moved within the same sectors) reuses them (1 ms of CPU at `ground`).
    pieces: Vec<(Range<u32>, Variant)>,
    /// Vertices placed by the last frame (tests, the bench's notes).
    placed_last: u64,
    /// The last frame reused the work lists of the frame before.
    reused_last: bool,
}

struct WorkList {
    buffer: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    /// Entries the buffer holds.
    capacity: u64,
}

impl Placement {
    /// None where the device's storage buffers cannot hold one placed vertex per mesh vertex
    /// (the vertex stage places them then).
    pub fn new(device: &wgpu::Device, mesh: &RingMesh) -> Option<Self> {
        let size = (mesh.vertices.len() * std::mem::size_of::<PlacedVertex>()) as u64;
        let limits = device.limits();
        if size
            > limits
                .max_storage_buffer_binding_size
                .min(limits.max_buffer_size)
        {
            return None;
        }
        let placed = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("placed vertices"),
            size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::VERTEX,
            mapped_at_creation: false,
        });
        let storage = super::compute_storage_entry;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("vertex placement layout"),
            entries: &[storage(0, false), storage(1, true)],
        });
        let work =
            [0, 1, 2].map(|_| WorkList::new(device, &layout, &placed, PLACE_WORKGROUP as u64 * 64));
        Some(Self {
            placed,
            layout,
            work,
            lists: RangeVertices::build(mesh),
            seen: vec![0; mesh.vertices.len()],
            frame: 0,
            scratch: Default::default(),
            pieces: Vec::new(),
            placed_last: 0,
            reused_last: false,
        })
    }

    /// Group 2 of `cs_place`'s pipeline layout.
    pub fn layout(&self) -> &wgpu::BindGroupLayout {
        &self.layout
    }

    /// The placed vertices, the clipmap draws' vertex buffer.
    pub fn vertex_buffer(&self) -> &wgpu::Buffer {
        &self.placed
    }

    /// Vertices the last [`encode`](Self::encode) placed.
    pub fn placed_last_frame(&self) -> u64 {
        self.placed_last
    }

    /// Whether the last [`encode`](Self::encode) reused the work lists of the one before.
    pub fn reused_last_frame(&self) -> bool {
        self.reused_last
    }

    /// Records the pass that places the vertices of `pieces` (the frame's drawn ranges and
    /// their variants, `DrawList::pieces`) with `pipelines` (plain, blend, morph), reading the
    /// terrain's bind group `terrain` (group 0). After the frame's uniforms are written and its
    /// textures filled; before the terrain pass.
    pub fn encode(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        pieces: &[(Range<u32>, Variant)],
        pipelines: &[wgpu::ComputePipeline; 3],
        terrain: &wgpu::BindGroup,
    ) {
        self.reused_last = pieces == self.pieces;
        if !self.reused_last {
            self.write_lists(device, queue, pieces);
        }
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("vertex placement"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, terrain, &[]);
        for ((list, work), pipeline) in self.scratch.iter().zip(&self.work).zip(pipelines) {
            if list.is_empty() {
                continue;
            }
            pass.set_pipeline(pipeline);
            pass.set_bind_group(2, &work.bind_group, &[]);
            pass.dispatch_workgroups(list.len() as u32 / PLACE_WORKGROUP, 1, 1);
        }
    }

    /// Builds and uploads the work lists of `pieces`: each vertex once, under the variant of
    /// the first piece that uses it, padded to whole workgroups.
    fn write_lists(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        pieces: &[(Range<u32>, Variant)],
    ) {
        self.pieces = pieces.to_vec();
        self.frame = self.frame.wrapping_add(1);
        if self.frame == 0 {
            self.seen.fill(0);
            self.frame = 1;
        }
        for list in &mut self.scratch {
            list.clear();
        }
        for (range, variant) in pieces {
            let list = &mut self.scratch[variant_index(*variant)];
            for &v in self.lists.get(range) {
                let seen = &mut self.seen[v as usize];
                if *seen != self.frame {
                    *seen = self.frame;
                    list.push(v);
                }
            }
        }
        self.placed_last = self.scratch.iter().map(|l| l.len() as u64).sum();
        for (list, work) in self.scratch.iter_mut().zip(&mut self.work) {
            if list.is_empty() {
                continue;
            }
            let whole = list.len().next_multiple_of(PLACE_WORKGROUP as usize);
            list.resize(whole, PLACE_NONE);
            if whole as u64 > work.capacity {
                *work = WorkList::new(
                    device,
                    &self.layout,
                    &self.placed,
                    (whole as u64).next_power_of_two(),
                );
            }
            queue.write_buffer(&work.buffer, 0, bytemuck::cast_slice(list));
        }
    }
}

impl WorkList {
    fn new(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        placed: &wgpu::Buffer,
        capacity: u64,
    ) -> Self {
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("vertex placement work"),
            size: capacity * 4,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("vertex placement bind group"),
            layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: placed.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: buffer.as_entire_binding(),
                },
            ],
        });
        Self {
            buffer,
            bind_group,
            capacity,
        }
    }
}

/// The pipeline of a variant in `[plain, blend, morph]`.
pub fn variant_index(variant: Variant) -> usize {
    match variant {
        Variant::Plain => 0,
        Variant::Blend => 1,
        Variant::Morph => 2,
    }
}
