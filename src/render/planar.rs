//! GPU resources of the planar LOD methods (`planar`, `plan::geomip`): the patch index buffer
//! (every interior and border level combination, and the skirts), the frame's patches and the
//! tangent frame's uniforms. The pipelines that draw them are built with the terrain's
//! (`render::terrain`), from the same module (shaders/planar.wgsl is appended to terrain.wgsl).

use std::ops::Range;

use wgpu::util::DeviceExt;

use crate::plan::projgrid::grid_indices;
use crate::plan::{GeomipPlan, ProjGridPlan, ViewPlan};
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
    /// The projected grid's (drawn instead of the clipmap, not beside it), or None for
    /// geomipmapping.
    pub grid: Option<GridDraw>,
}

/// What the projected grid draws this frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GridDraw {
    pub indices: Range<u32>,
    /// Cells whose ρ exceeds γ, and whether their fragments ray cast.
    pub cells_above_gamma: usize,
    pub ray_cast: bool,
    /// The error buffer's largest and mean ρ (the a-priori bound), pixels.
    pub max_rho_px: f64,
    pub mean_rho_px: f64,
}

/// The planar methods' buffers and their bind group (group 1 of every terrain pipeline: the
/// clipmap reads the uniforms to cut the planar square out).
pub struct PlanarResources {
    pub uniforms: wgpu::Buffer,
    pub patches: wgpu::Buffer,
    mesh: PatchMesh,
    index_buffer: wgpu::Buffer,
    grid: GridBuffers,
    layout: wgpu::BindGroupLayout,
    bind_group: wgpu::BindGroup,
}

/// The projected grid's vertices, cells and triangle list, sized for `cols` × `rows`.
struct GridBuffers {
    cols: u32,
    rows: u32,
    vertices: wgpu::Buffer,
    cells: wgpu::Buffer,
    indices: wgpu::Buffer,
}

impl GridBuffers {
    fn new(device: &wgpu::Device, cols: u32, rows: u32) -> Self {
        let vertices = ((cols as u64 + 1) * (rows as u64 + 1)).max(1);
        let cells = (cols as u64 * rows as u64).max(1);
        let storage = |label, size| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let mut idx = grid_indices(cols, rows);
        if idx.is_empty() {
            idx.push(0);
        }
        Self {
            cols,
            rows,
            vertices: storage("projected grid vertices", 16 * vertices),
            cells: storage("projected grid cells", 16 * cells),
            indices: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("projected grid indices"),
                contents: bytemuck::cast_slice(&idx),
                usage: wgpu::BufferUsages::INDEX | wgpu::BufferUsages::STORAGE,
            }),
        }
    }
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
        // Sized when the projected grid is first used (`set_grid_size`).
        let grid = GridBuffers::new(device, 0, 0);
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
                entry(3, storage),
                entry(4, storage),
                entry(5, storage),
            ],
        });
        let bind_group = Self::bind(device, &layout, &uniforms, &patches, &index_buffer, &grid);
        Self {
            uniforms,
            patches,
            mesh,
            index_buffer,
            grid,
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
        grid: &GridBuffers,
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
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: grid.vertices.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: grid.cells.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 5,
                    resource: grid.indices.as_entire_binding(),
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
            self.rebind(device);
        }
    }

    /// Sizes the projected grid's buffers for `cols` × `rows` cells.
    pub fn set_grid_size(&mut self, device: &wgpu::Device, cols: u32, rows: u32) {
        if (self.grid.cols, self.grid.rows) != (cols, rows) {
            self.grid = GridBuffers::new(device, cols, rows);
            self.rebind(device);
        }
    }

    fn rebind(&mut self, device: &wgpu::Device) {
        self.bind_group = Self::bind(
            device,
            &self.layout,
            &self.uniforms,
            &self.patches,
            &self.index_buffer,
            &self.grid,
        );
    }

    pub fn grid_index_buffer(&self) -> &wgpu::Buffer {
        &self.grid.indices
    }

    /// Writes the projected grid's plan (vertices, error buffer, uniforms) and its draw.
    pub fn write_grid(
        &self,
        queue: &wgpu::Queue,
        view: &ViewPlan,
        plan: &ProjGridPlan,
        ray_cast: bool,
    ) -> PlanarDraw {
        let fits = (plan.cols, plan.rows) == (self.grid.cols, self.grid.rows);
        let drawn = plan.sees_terrain && fits;
        if drawn {
            queue.write_buffer(&self.grid.vertices, 0, bytemuck::cast_slice(&plan.vertices));
            queue.write_buffer(&self.grid.cells, 0, bytemuck::cast_slice(&plan.cells));
        }
        let uniforms = PlanarUniforms::from_grid(view, plan.cols, plan.rows);
        queue.write_buffer(&self.uniforms, 0, bytemuck::bytes_of(&uniforms));
        let cells = if drawn { plan.cols * plan.rows } else { 0 };
        PlanarDraw {
            triangles: 2 * u64::from(cells),
            grid: Some(GridDraw {
                indices: 0..6 * cells,
                cells_above_gamma: plan.cells_above_gamma,
                ray_cast,
                max_rho_px: plan.max_rho_px,
                mean_rho_px: plan.mean_rho_px,
            }),
            ..Default::default()
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
