//! The contract each assembled shader module must keep: which struct every buffer binding
//! holds, the vertex input and the workgroup size Rust's dispatch counts use.
//! `tests/cpu/shader_contract.rs` checks each against naga's reflection of the module.

use super::gpu_data::*;
use super::shader::{self, MAX_LEVELS};
use crate::clipmap::RingVertex;
use crate::geo::map_transform::TransformUniformsF32;

/// A buffer binding: `@group(group) @binding(binding)` holds the WGSL type `wgsl_type`.
#[derive(Clone, Debug)]
pub struct BufferBinding {
    pub group: u32,
    pub binding: u32,
    pub wgsl_type: String,
}

/// What Rust assumes of one assembled shader module.
#[derive(Clone, Debug)]
pub struct PassContract {
    pub file: &'static str,
    /// The assembled source: generated constants, the shared library, the pass.
    pub source: String,
    pub structs: Vec<StructLayout>,
    pub buffers: Vec<BufferBinding>,
    /// The vertex input struct and the buffer layout Rust gives it.
    pub vertex: Option<(StructLayout, &'static [wgpu::VertexAttribute])>,
    /// `@workgroup_size` of the compute entry point `cs_main`, which Rust's dispatch counts use.
    pub workgroup_size: Option<[u32; 3]>,
}

/// Every shader module globe builds, with what Rust assumes of it.
pub fn pass_contracts() -> Vec<PassContract> {
    vec![
        terrain_contract(),
        fill_analytic_contract(),
        fill_dem_contract(),
        sky_contract(),
        fill_normals_contract(),
        water_cull_contract(),
    ]
}

/// A binding of group 0, where every pass keeps its own buffers.
fn buffer(binding: u32, wgsl_type: String) -> BufferBinding {
    BufferBinding {
        group: 0,
        binding,
        wgsl_type,
    }
}

/// Both height fills: the detail's block at group 1.
fn detail_buffer() -> BufferBinding {
    BufferBinding {
        group: 1,
        binding: 0,
        wgsl_type: DetailFillParams::wgsl_type(),
    }
}

/// The compute passes' workgroup, whose size the dispatch counts divide by.
const WORKGROUP: [u32; 3] = [shader::WORKGROUP_SIZE, shader::WORKGROUP_SIZE, 1];

/// The terrain draw, the one module with a vertex input (the ring mesh): the clipmap's
/// levels, the planar methods' group and the vertex pre-pass's output all bind here.
fn terrain_contract() -> PassContract {
    PassContract {
        file: "terrain.wgsl",
        source: shader::assemble(shader::TERRAIN),
        structs: vec![
            FrameUniforms::layout(),
            LevelUniforms::layout(),
            TransformUniformsF32::layout(),
            BumpUniforms::layout(),
            DetailOctaveParams::layout(),
            StructLayout {
                wgsl_name: "MeshVertex",
                ..RingVertex::layout()
            },
            LookUniforms::layout(),
            PlanarUniforms::layout(),
            PatchGpu::layout(),
            PlacedVertex::layout(),
        ],
        buffers: vec![
            buffer(0, FrameUniforms::wgsl_type()),
            // The ring mesh's triangle list again, read by the wireframe draw.
            buffer(15, "array<u32>".to_string()),
            // The planar methods' group (render::planar).
            BufferBinding {
                group: 1,
                binding: 0,
                wgsl_type: PlanarUniforms::wgsl_type(),
            },
            BufferBinding {
                group: 1,
                binding: 1,
                wgsl_type: "array<PatchGpu>".to_string(),
            },
            BufferBinding {
                group: 1,
                binding: 2,
                wgsl_type: "array<u32>".to_string(),
            },
            buffer(1, <[LevelUniforms; MAX_LEVELS as usize]>::wgsl_type()),
            buffer(4, BumpUniforms::wgsl_type()),
            buffer(5, "array<f32>".to_string()),
            // The ring vertices again, read by index for the morph's neighbours.
            buffer(8, "array<MeshVertex>".to_string()),
            buffer(9, LookUniforms::wgsl_type()),
            // The vertex pre-pass's output and work list (render::placement).
            BufferBinding {
                group: 2,
                binding: 0,
                wgsl_type: "array<PlacedVertex>".to_string(),
            },
            BufferBinding {
                group: 2,
                binding: 1,
                wgsl_type: "array<u32>".to_string(),
            },
        ],
        vertex: Some((RingVertex::layout(), &RING_VERTEX_ATTRIBUTES)),
        workgroup_size: None,
    }
}

/// The analytic planet's fill of a level texture: its waves' phases, then the detail.
fn fill_analytic_contract() -> PassContract {
    PassContract {
        file: "fill_analytic.wgsl",
        source: shader::assemble(shader::FILL_ANALYTIC),
        structs: vec![
            FillParams::layout(),
            WaveParams::layout(),
            DetailFillParams::layout(),
            DetailOctaveParams::layout(),
            DeltaOctaveParams::layout(),
        ],
        buffers: vec![buffer(0, FillParams::wgsl_type()), detail_buffer()],
        vertex: None,
        workgroup_size: Some(WORKGROUP),
    }
}

/// The DEM's fill of a level texture: the GPU tile cache through its page table, then the
/// detail.
fn fill_dem_contract() -> PassContract {
    PassContract {
        file: "fill_dem.wgsl",
        source: shader::assemble(shader::FILL_DEM),
        structs: vec![
            DemFillParams::layout(),
            DetailFillParams::layout(),
            DetailOctaveParams::layout(),
            DeltaOctaveParams::layout(),
        ],
        buffers: vec![buffer(0, DemFillParams::wgsl_type()), detail_buffer(), {
            // The page table: one slot index per pyramid tile.
            buffer(3, "array<u32>".to_string())
        }],
        vertex: None,
        workgroup_size: Some(WORKGROUP),
    }
}

/// The sky pass, drawn after the terrain: the look's uniforms only.
fn sky_contract() -> PassContract {
    PassContract {
        file: "sky.wgsl",
        source: shader::assemble(shader::SKY),
        structs: vec![LookUniforms::layout()],
        buffers: vec![buffer(0, LookUniforms::wgsl_type())],
        vertex: None,
        workgroup_size: None,
    }
}

/// The normals' fill, once per texel after a level's heights: the terrain pass reads them.
fn fill_normals_contract() -> PassContract {
    PassContract {
        file: "fill_normals.wgsl",
        source: shader::assemble(shader::FILL_NORMALS),
        structs: vec![NormalParams::layout()],
        buffers: vec![buffer(0, NormalParams::wgsl_type())],
        vertex: None,
        workgroup_size: Some(WORKGROUP),
    }
}

/// The water's cull, which writes the draws' instance counts: its workgroup is its own.
fn water_cull_contract() -> PassContract {
    PassContract {
        file: "water_cull.wgsl",
        source: shader::assemble(shader::WATER_CULL),
        structs: vec![WaterCullParams::layout()],
        buffers: vec![
            buffer(0, WaterCullParams::wgsl_type()),
            buffer(2, "array<f32>".to_string()),
            buffer(3, "array<u32>".to_string()),
            buffer(4, "array<u32>".to_string()),
            buffer(5, "array<u32>".to_string()),
        ],
        vertex: None,
        workgroup_size: Some([64, 1, 1]),
    }
}
