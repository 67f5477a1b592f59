//! GPU side of the look (`crate::look`): the proto-texture array and the wave texture with
//! their mip chains, their sampler, the look uniforms and the sky pass.

use crate::look::proto::{self, MIP_LEVELS, MipKind, TEXTURE_SIZE};
use crate::look::{SKY_RING_SEGMENTS, SkyRing};

use super::formats::DEPTH_FORMAT;
use super::gpu_data::LookUniforms;
use super::shader;

/// Texels of the sky-view table (azimuth, elevation): 1.4° of azimuth per column (the sun's
/// forward-scattering lobe is tens of degrees wide), rows crowded at the horizon.
pub const SKY_TABLE_SIZE: [u32; 2] = [256, 128];

pub struct LookResources {
    pub uniforms: wgpu::Buffer,
    albedo: wgpu::Texture,
    pub albedo_view: wgpu::TextureView,
    waves: wgpu::Texture,
    pub waves_view: wgpu::TextureView,
    pub sampler: wgpu::Sampler,
    sky_pipeline: wgpu::RenderPipeline,
    /// The per-pixel sky over the ring of directions that can meet the shell (from outside it).
    sky_ring_pipeline: wgpu::RenderPipeline,
    sky_bind_group: wgpu::BindGroup,
    /// The sky from the table (`TABLE` on), the pass that fills the table and its bind
    /// groups (group 0: the look uniforms; group 1: the table to write).
    sky_table_pipeline: wgpu::RenderPipeline,
    table_pass: wgpu::ComputePipeline,
    table_uniforms: wgpu::BindGroup,
    table_target: wgpu::BindGroup,
    /// Whether this frame's sky reads the table (set by [`LookResources::prepare_sky`]).
    table_frame: bool,
    /// The mip chain the textures hold (None: not uploaded yet; the first frame does it).
    uploaded: Option<MipKind>,
}

impl LookResources {
    pub fn new(device: &wgpu::Device, color_format: wgpu::TextureFormat) -> Self {
        let uniforms = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("look uniforms"),
            size: std::mem::size_of::<LookUniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let texture = |label, layers, format| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d {
                    width: TEXTURE_SIZE,
                    height: TEXTURE_SIZE,
                    depth_or_array_layers: layers,
                },
                mip_level_count: MIP_LEVELS,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            })
        };
        // Linear values (the colours the shading uses directly, like the tint's). The albedo
        // array is half floats: lavapipe (Mesa 22.3) crashes sampling an RGBA8 array layer
        // chosen at run time (its 8-bit fast path); the wave texture has no layers.
        let albedo = texture(
            "proto-textures",
            proto::Material::ALL.len() as u32,
            wgpu::TextureFormat::Rgba16Float,
        );
        let albedo_view = albedo.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        let waves = texture("waves", 1, wgpu::TextureFormat::Rgba8Unorm);
        let waves_view = waves.create_view(&Default::default());
        // Trilinear and repeating: the shader passes fract(uv) with the unwrapped gradients.
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("look sampler"),
            address_mode_u: wgpu::AddressMode::Repeat,
            address_mode_v: wgpu::AddressMode::Repeat,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            mipmap_filter: wgpu::MipmapFilterMode::Linear,
            ..Default::default()
        });

        let uniform_entry = |visibility| wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("sky layout"),
            entries: &[
                uniform_entry(wgpu::ShaderStages::VERTEX_FRAGMENT),
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: true },
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                    count: None,
                },
            ],
        });
        let table = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("sky-view table"),
            size: wgpu::Extent3d {
                width: SKY_TABLE_SIZE[0],
                height: SKY_TABLE_SIZE[1],
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba16Float,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::STORAGE_BINDING,
            view_formats: &[],
        });
        let table_view = table.create_view(&Default::default());
        // Azimuth wraps; elevation stops at the zenith and the nadir.
        let table_sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("sky-view table sampler"),
            address_mode_u: wgpu::AddressMode::Repeat,
            address_mode_v: wgpu::AddressMode::ClampToEdge,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let sky_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("sky bind group"),
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: uniforms.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&table_view),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::Sampler(&table_sampler),
                },
            ],
        });
        let table_uniforms_layout =
            device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("sky table uniforms layout"),
                entries: &[uniform_entry(wgpu::ShaderStages::COMPUTE)],
            });
        let table_target_layout =
            device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("sky table target layout"),
                entries: &[wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::StorageTexture {
                        access: wgpu::StorageTextureAccess::WriteOnly,
                        format: wgpu::TextureFormat::Rgba16Float,
                        view_dimension: wgpu::TextureViewDimension::D2,
                    },
                    count: None,
                }],
            });
        let table_uniforms = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("sky table uniforms"),
            layout: &table_uniforms_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: uniforms.as_entire_binding(),
            }],
        });
        let table_target = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("sky table target"),
            layout: &table_target_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(&table_view),
            }],
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("sky.wgsl"),
            source: wgpu::ShaderSource::Wgsl(shader::assemble(shader::SKY).into()),
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("sky pipeline layout"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let table_pass = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("sky table"),
            layout: Some(
                &device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                    label: Some("sky table pipeline layout"),
                    bind_group_layouts: &[Some(&table_uniforms_layout), Some(&table_target_layout)],
                    immediate_size: 0,
                }),
            ),
            module: &module,
            entry_point: Some("cs_sky_table"),
            compilation_options: Default::default(),
            cache: None,
        });
        let sky_pipeline = |table: bool, vs: &str| {
            let constants = [("TABLE", if table { 1.0 } else { 0.0 })];
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(&format!("sky pipeline ({vs}, table {table})")),
                layout: Some(&pipeline_layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some(vs),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                primitive: Default::default(),
                // At the far depth (reversed-Z 0): drawn only where the terrain left the clear value.
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: DEPTH_FORMAT,
                    depth_write_enabled: Some(false),
                    depth_compare: Some(wgpu::CompareFunction::GreaterEqual),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some("fs_sky"),
                    compilation_options: wgpu::PipelineCompilationOptions {
                        constants: &constants,
                        ..Default::default()
                    },
                    targets: &[Some(wgpu::ColorTargetState {
                        format: color_format,
                        blend: None,
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        Self {
            uniforms,
            albedo,
            albedo_view,
            waves,
            waves_view,
            sampler,
            sky_pipeline: sky_pipeline(false, "vs_sky"),
            sky_ring_pipeline: sky_pipeline(false, "vs_sky_ring"),
            sky_bind_group,
            sky_table_pipeline: sky_pipeline(true, "vs_sky"),
            table_pass,
            table_uniforms,
            table_target,
            table_frame: false,
            uploaded: None,
        }
    }

    /// Uploads the textures of `mips` unless they are already there.
    pub fn upload(&mut self, queue: &wgpu::Queue, mips: MipKind) {
        if self.uploaded == Some(mips) {
            return;
        }
        let t = proto::textures(mips);
        for (layer, chain) in t.albedo.iter().enumerate() {
            let halves: Vec<Vec<[u16; 4]>> = chain
                .levels
                .iter()
                .map(|level| level.iter().map(|t| t.map(unorm8_to_f16)).collect())
                .collect();
            write_chain(queue, &self.albedo, layer as u32, &halves, 8);
        }
        write_chain(queue, &self.waves, 0, &t.waves.levels, 4);
        self.uploaded = Some(mips);
    }

    /// Records this frame's sky-view table when `table` (the sky is on and the eye inside the
    /// atmosphere); without it the sky pass integrates every pixel's ray. After the look
    /// uniforms are written, before the terrain pass.
    pub fn prepare_sky(&mut self, encoder: &mut wgpu::CommandEncoder, table: bool) {
        self.table_frame = table;
        if !table {
            return;
        }
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("sky-view table"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.table_pass);
        pass.set_bind_group(0, &self.table_uniforms, &[]);
        pass.set_bind_group(1, &self.table_target, &[]);
        pass.dispatch_workgroups(SKY_TABLE_SIZE[0] / 8, SKY_TABLE_SIZE[1] / 8, 1);
    }

    /// Whether this frame's sky reads the table.
    pub fn sky_from_table(&self) -> bool {
        self.table_frame
    }

    /// Draws the sky into the pixels the terrain left empty: with `ring` (from outside the
    /// shell, the per-pixel sky) only over its directions, else over the whole frame.
    pub fn draw_sky(&self, pass: &mut wgpu::RenderPass<'_>, ring: Option<SkyRing>) {
        pass.set_bind_group(0, &self.sky_bind_group, &[]);
        match ring {
            Some(_) if !self.table_frame => {
                pass.set_pipeline(&self.sky_ring_pipeline);
                pass.draw(0..6 * SKY_RING_SEGMENTS, 0..1);
            }
            _ => {
                pass.set_pipeline(if self.table_frame {
                    &self.sky_table_pipeline
                } else {
                    &self.sky_pipeline
                });
                pass.draw(0..3, 0..1);
            }
        }
    }
}

/// An 8-bit unorm value as an IEEE half (exact: v/255 needs 8 significant bits at most).
fn unorm8_to_f16(v: u8) -> u16 {
    if v == 0 {
        return 0;
    }
    let x = v as f32 / 255.0;
    let bits = x.to_bits();
    let exp = ((bits >> 23) & 0xff) as i32 - 127 + 15;
    // Round the 23-bit mantissa to 10 bits (to nearest).
    let mant = ((bits & 0x7f_ffff) + 0x1000) >> 13;
    ((exp as u32) << 10).wrapping_add(mant) as u16
}

fn write_chain<T: bytemuck::Pod>(
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
    layer: u32,
    levels: &[Vec<T>],
    bytes_per_texel: u32,
) {
    for (mip, level) in levels.iter().enumerate() {
        let size = (TEXTURE_SIZE >> mip).max(1);
        queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture,
                mip_level: mip as u32,
                origin: wgpu::Origin3d {
                    x: 0,
                    y: 0,
                    z: layer,
                },
                aspect: wgpu::TextureAspect::All,
            },
            bytemuck::cast_slice(level),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(bytes_per_texel * size),
                rows_per_image: Some(size),
            },
            wgpu::Extent3d {
                width: size,
                height: size,
                depth_or_array_layers: 1,
            },
        );
    }
}
