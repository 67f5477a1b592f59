//! GPU resources of the planar LOD methods (`planar`, `plan::geomip`): the patch index buffer
//! (every interior and border level combination, and the skirts), the frame's patches and the
//! tangent frame's uniforms. The pipelines that draw them are built with the terrain's
//! (`render::terrain`), from the same module (shaders/planar.wgsl is appended to terrain.wgsl).

use std::ops::Range;

use wgpu::util::DeviceExt;

use crate::plan::{GeomipPlan, ViewPlan};
use crate::planar::geomip::{PatchMesh, SOUTH, WEST};

use super::gpu_data::{PatchGpu, PlanarUniforms};

/// Patches a frame can hold (64 × 64: `--patches` at most 64).
pub const MAX_PATCHES: usize = 64 * 64;

/// What the planar method draws this frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PlanarDraw {
    /// Index ranges of the planar index buffer and the patch (instance) each draws.
    pub draws: Vec<(Range<u32>, u32)>,
    /// Triangles drawn (skirts included).
    pub triangles: u64,
    /// Patches drawn, and those in view still waiting for their δ (drawn at level 0).
    pub patches: usize,
    pub waiting: usize,
    /// Finest lattice spacing, metres.
    pub spacing_m: f64,
}

/// The planar methods' buffers and their bind group (group 1 of every terrain pipeline: the
/// clipmap reads the uniforms to cut the planar square out).
pub struct PlanarResources {
    pub uniforms: wgpu::Buffer,
    pub patches: wgpu::Buffer,
    mesh: PatchMesh,
    index_buffer: wgpu::Buffer,
    layout: wgpu::BindGroupLayout,
    bind_group: wgpu::BindGroup,
}

impl PlanarResources {
    pub fn new(device: &wgpu::Device, patch_size: u32) -> Self {
        let uniforms = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("planar uniforms"),
            contents: bytemuck::bytes_of(&PlanarUniforms::inactive()),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let patches = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("geomipmapping patches"),
            size: (MAX_PATCHES * std::mem::size_of::<PatchGpu>()) as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let (mesh, index_buffer) = Self::mesh(device, patch_size);
        let entry = |binding, ty| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
            ty: wgpu::BindingType::Buffer {
                ty,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let storage = wgpu::BufferBindingType::Storage { read_only: true };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("planar layout"),
            entries: &[
                entry(0, wgpu::BufferBindingType::Uniform),
                entry(1, storage),
                entry(2, storage),
            ],
        });
        let bind_group = Self::bind(device, &layout, &uniforms, &patches, &index_buffer);
        Self {
            uniforms,
            patches,
            mesh,
            index_buffer,
            layout,
            bind_group,
        }
    }

    fn bind(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        uniforms: &wgpu::Buffer,
        patches: &wgpu::Buffer,
        indices: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("planar bind group"),
            layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: uniforms.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: patches.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: indices.as_entire_binding(),
                },
            ],
        })
    }

    pub fn layout(&self) -> &wgpu::BindGroupLayout {
        &self.layout
    }

    pub fn bind_group(&self) -> &wgpu::BindGroup {
        &self.bind_group
    }

    fn mesh(device: &wgpu::Device, patch_size: u32) -> (PatchMesh, wgpu::Buffer) {
        let mesh = PatchMesh::build(patch_size);
        let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("geomipmapping indices"),
            contents: bytemuck::cast_slice(&mesh.indices),
            // Also read by the wireframe draw.
            usage: wgpu::BufferUsages::INDEX | wgpu::BufferUsages::STORAGE,
        });
        (mesh, buffer)
    }

    /// Rebuilds the index buffer for another patch size.
    pub fn set_patch_size(&mut self, device: &wgpu::Device, patch_size: u32) {
        if self.mesh.size != patch_size {
            (self.mesh, self.index_buffer) = Self::mesh(device, patch_size);
            self.bind_group = Self::bind(
                device,
                &self.layout,
                &self.uniforms,
                &self.patches,
                &self.index_buffer,
            );
        }
    }

    pub fn index_buffer(&self) -> &wgpu::Buffer {
        &self.index_buffer
    }

    /// Nothing planar this frame.
    pub fn write_inactive(&self, queue: &wgpu::Queue) {
        queue.write_buffer(
            &self.uniforms,
            0,
            bytemuck::bytes_of(&PlanarUniforms::inactive()),
        );
    }

    /// Writes the plan's frame and patches (the f64 → f32 step) and lists its draws.
    pub fn write_geomip(
        &self,
        queue: &wgpu::Queue,
        view: &ViewPlan,
        plan: &GeomipPlan,
    ) -> PlanarDraw {
        let cells = self.mesh.size - 1;
        let uniforms = PlanarUniforms::from_geomip(view, plan, cells);
        queue.write_buffer(&self.uniforms, 0, bytemuck::bytes_of(&uniforms));
        let patches: Vec<PatchGpu> = plan
            .patches
            .iter()
            .take(MAX_PATCHES)
            .map(|p| PatchGpu::new(view, plan, p, cells))
            .collect();
        queue.write_buffer(&self.patches, 0, bytemuck::cast_slice(&patches));
        let mut draw = PlanarDraw {
            patches: patches.len(),
            waiting: plan.waiting,
            spacing_m: plan.spacing_m,
            ..Default::default()
        };
        for (i, (patch, outer)) in plan
            .patches
            .iter()
            .zip(&plan.outer_sides)
            .take(MAX_PATCHES)
            .enumerate()
        {
            let (k, sides) = patch.tessellation();
            draw.draws.push((self.mesh.range(k, sides), i as u32));
            for side in SOUTH..=WEST {
                if outer[side] {
                    draw.draws
                        .push((self.mesh.skirt(side, sides[side]), i as u32));
                }
            }
        }
        draw.triangles = draw.draws.iter().map(|(r, _)| (r.len() / 3) as u64).sum();
        draw
    }
}
