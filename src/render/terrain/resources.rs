//! The terrain pass's GPU resources that live as long as the renderer: the ring mesh's and
//! the frame's buffers, the level textures, and the bind group (group 0) that hands them to
//! every clipmap pipeline, the vertex pre-pass and the planar methods.

use wgpu::util::DeviceExt;

use crate::clipmap::{ClipmapSettings, RingMesh};
use crate::render::detail::{self, DetailResources};
use crate::render::gpu_data::{BumpUniforms, FrameUniforms, LevelUniforms};
use crate::render::imagery::LEVEL_IMAGERY_FORMAT;
use crate::render::look::LookResources;
use crate::render::normals::{BOUNDARY_NOISE_FORMAT, NORMAL_FORMAT};
use crate::render::shader::MAX_LEVELS;

/// The static ring mesh on the GPU and the uniform buffers each frame rewrites.
pub(super) struct FrameBuffers {
    pub(super) vertices: wgpu::Buffer,
    pub(super) indices: wgpu::Buffer,
    pub(super) frame: wgpu::Buffer,
    pub(super) levels: wgpu::Buffer,
    pub(super) bump: wgpu::Buffer,
}

impl FrameBuffers {
    pub(super) fn new(device: &wgpu::Device, mesh: &RingMesh) -> Self {
        let vertex_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("ring vertices"),
            contents: bytemuck::cast_slice(&mesh.vertices),
            // Also read by index: the morph's neighbours.
            usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::STORAGE,
        });
        let index_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("ring indices"),
            contents: bytemuck::cast_slice(&mesh.indices),
            // Also read by the wireframe draw.
            usage: wgpu::BufferUsages::INDEX | wgpu::BufferUsages::STORAGE,
        });
        let frame_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("frame uniforms"),
            size: std::mem::size_of::<FrameUniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let levels_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("level uniforms"),
            size: (std::mem::size_of::<LevelUniforms>() * MAX_LEVELS as usize) as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bump_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("bump uniforms"),
            size: std::mem::size_of::<BumpUniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self {
            vertices: vertex_buffer,
            indices: index_buffer,
            frame: frame_buffer,
            levels: levels_buffer,
            bump: bump_buffer,
        }
    }
}

/// The level textures, one layer per clipmap level: the heights the fills write, the detail's
/// partial octaves, and the normals and surface types the normal pass derives from both.
pub(super) struct LevelTextures {
    pub(super) heights: wgpu::Texture,
    pub(super) heights_view: wgpu::TextureView,
    pub(super) partials: wgpu::Texture,
    pub(super) partials_view: wgpu::TextureView,
    pub(super) normals: wgpu::Texture,
    pub(super) normals_view: wgpu::TextureView,
    pub(super) boundary_noise: wgpu::Texture,
    pub(super) boundary_noise_view: wgpu::TextureView,
    /// The draped imagery per texel (`render::imagery`; sRGB-encoded RGBA, alpha coverage).
    pub(super) imagery: wgpu::Texture,
    pub(super) imagery_view: wgpu::TextureView,
    pub(super) normal_sampler: wgpu::Sampler,
}

impl LevelTextures {
    /// The textures for `settings`; the imagery layers are full-size only `with_imagery`
    /// (otherwise 1 × 1 stand-ins: the normal pass writes none).
    pub(super) fn new(
        device: &wgpu::Device,
        settings: &ClipmapSettings,
        with_imagery: bool,
    ) -> Self {
        let heights = level_array(
            device,
            settings,
            "clipmap heights",
            wgpu::TextureFormat::R32Float,
            wgpu::TextureUsages::COPY_DST,
        );
        let heights_view = array_view(&heights);
        let partials = detail::partials_texture(device, settings.texture_size, settings.levels);
        let partials_view = array_view(&partials);
        let normals = level_array(
            device,
            settings,
            "clipmap normals",
            NORMAL_FORMAT,
            wgpu::TextureUsages::empty(),
        );
        let normals_view = array_view(&normals);
        let boundary_noise = level_array(
            device,
            settings,
            "clipmap boundary noise",
            BOUNDARY_NOISE_FORMAT,
            wgpu::TextureUsages::empty(),
        );
        let boundary_noise_view = array_view(&boundary_noise);
        let stand_in = ClipmapSettings {
            texture_size: 1,
            ..settings.clone()
        };
        let imagery = level_array(
            device,
            if with_imagery { settings } else { &stand_in },
            "clipmap imagery",
            LEVEL_IMAGERY_FORMAT,
            wgpu::TextureUsages::empty(),
        );
        let imagery_view = array_view(&imagery);
        // Bilinear and toroidal: texel (x, y) holds grid point x, y mod S.
        let normal_sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("normal sampler"),
            address_mode_u: wgpu::AddressMode::Repeat,
            address_mode_v: wgpu::AddressMode::Repeat,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        Self {
            heights,
            heights_view,
            partials,
            partials_view,
            normals,
            normals_view,
            boundary_noise,
            boundary_noise_view,
            imagery,
            imagery_view,
            normal_sampler,
        }
    }
}

/// A texture of one `settings.texture_size`² layer per level that compute passes write and
/// the terrain pass samples (and tests read back), with `extra` usages.
fn level_array(
    device: &wgpu::Device,
    settings: &ClipmapSettings,
    label: &str,
    format: wgpu::TextureFormat,
    extra: wgpu::TextureUsages,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width: settings.texture_size,
            height: settings.texture_size,
            depth_or_array_layers: settings.levels,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::STORAGE_BINDING
            | wgpu::TextureUsages::COPY_SRC
            | extra,
        view_formats: &[],
    })
}

/// All layers of `texture` as one 2-D array view.
fn array_view(texture: &wgpu::Texture) -> wgpu::TextureView {
    texture.create_view(&wgpu::TextureViewDescriptor {
        dimension: Some(wgpu::TextureViewDimension::D2Array),
        ..Default::default()
    })
}

/// Group 0 of the terrain pass: what every binding holds is `render::contracts`' to check.
pub(super) fn bind_group_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    // Compute too where the vertex pre-pass reads it (render::placement).
    let place = wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::COMPUTE;
    let uniform_entry = |binding| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::VERTEX_FRAGMENT | wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    };
    let texture_entry = |binding, visibility, filterable| wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable },
            view_dimension: wgpu::TextureViewDimension::D2Array,
            multisampled: false,
        },
        count: None,
    };
    let storage_entry = |binding, visibility| wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: true },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    };
    let (both, fragment) = (
        wgpu::ShaderStages::VERTEX_FRAGMENT | wgpu::ShaderStages::COMPUTE,
        wgpu::ShaderStages::FRAGMENT,
    );
    let volume_entry = |binding| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable: true },
            view_dimension: wgpu::TextureViewDimension::D3,
            multisampled: false,
        },
        count: None,
    };
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("terrain layout"),
        entries: &[
            uniform_entry(0),
            uniform_entry(1),
            texture_entry(2, both, false),
            texture_entry(3, both, false),
            uniform_entry(4),
            storage_entry(5, place),
            texture_entry(6, fragment, true),
            wgpu::BindGroupLayoutEntry {
                binding: 7,
                visibility: fragment,
                ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                count: None,
            },
            storage_entry(8, place),
            uniform_entry(9),
            texture_entry(10, fragment, true),
            wgpu::BindGroupLayoutEntry {
                binding: 11,
                visibility: fragment,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: true },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
                count: None,
            },
            wgpu::BindGroupLayoutEntry {
                binding: 12,
                visibility: fragment,
                ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                count: None,
            },
            texture_entry(13, fragment, true),
            volume_entry(14),
            storage_entry(15, wgpu::ShaderStages::VERTEX),
            volume_entry(16),
            wgpu::BindGroupLayoutEntry {
                binding: 17,
                visibility: fragment,
                ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                count: None,
            },
            texture_entry(18, fragment, true),
        ],
    })
}

/// The bind group of [`bind_group_layout`] over the renderer's resources.
pub(super) fn bind_group(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    buffers: &FrameBuffers,
    textures: &LevelTextures,
    detail: &DetailResources,
    look: &LookResources,
) -> wgpu::BindGroup {
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("terrain bind group"),
        layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: buffers.frame.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: buffers.levels.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: wgpu::BindingResource::TextureView(&textures.heights_view),
            },
            wgpu::BindGroupEntry {
                binding: 3,
                resource: wgpu::BindingResource::TextureView(&textures.partials_view),
            },
            wgpu::BindGroupEntry {
                binding: 4,
                resource: buffers.bump.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 5,
                resource: detail.relief().as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 6,
                resource: wgpu::BindingResource::TextureView(&textures.normals_view),
            },
            wgpu::BindGroupEntry {
                binding: 7,
                resource: wgpu::BindingResource::Sampler(&textures.normal_sampler),
            },
            wgpu::BindGroupEntry {
                binding: 8,
                resource: buffers.vertices.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 9,
                resource: look.uniforms.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 10,
                resource: wgpu::BindingResource::TextureView(&look.albedo_view),
            },
            wgpu::BindGroupEntry {
                binding: 11,
                resource: wgpu::BindingResource::TextureView(&look.waves_view),
            },
            wgpu::BindGroupEntry {
                binding: 12,
                resource: wgpu::BindingResource::Sampler(&look.sampler),
            },
            wgpu::BindGroupEntry {
                binding: 13,
                resource: wgpu::BindingResource::TextureView(&textures.boundary_noise_view),
            },
            wgpu::BindGroupEntry {
                binding: 14,
                resource: wgpu::BindingResource::TextureView(&look.aerial.inscatter_view),
            },
            wgpu::BindGroupEntry {
                binding: 15,
                resource: buffers.indices.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 16,
                resource: wgpu::BindingResource::TextureView(&look.aerial.transmittance_view),
            },
            wgpu::BindGroupEntry {
                binding: 17,
                resource: wgpu::BindingResource::Sampler(&look.aerial.sampler),
            },
            wgpu::BindGroupEntry {
                binding: 18,
                resource: wgpu::BindingResource::TextureView(&textures.imagery_view),
            },
        ],
    })
}
