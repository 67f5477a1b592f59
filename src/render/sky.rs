//! The sky pass (`shaders/sky.wgsl`): the sky-view table filled once per frame where the eye
//! is inside the atmosphere, and the draw into the pixels the terrain left empty (from the
//! table, per pixel over the whole frame, or per pixel over the ring of directions that can
//! meet the shell from outside it).

use crate::look::{SKY_RING_SEGMENTS, SkyRing};

use super::formats::DEPTH_FORMAT;
use super::shader;

/// Texels of the sky-view table (azimuth, elevation): 1.4° of azimuth per column (the sun's
/// forward-scattering lobe is tens of degrees wide), rows crowded at the horizon.
pub const SKY_TABLE_SIZE: [u32; 2] = [256, 128];

pub struct SkyPass {
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
    /// Whether this frame's sky reads the table (set by [`SkyPass::prepare`]).
    table_frame: bool,
}

/// The sky's bind groups over the look uniforms and the table, with their layouts.
struct SkyBindings {
    layout: wgpu::BindGroupLayout,
    sky: wgpu::BindGroup,
    table_uniforms_layout: wgpu::BindGroupLayout,
    table_target_layout: wgpu::BindGroupLayout,
    table_uniforms: wgpu::BindGroup,
    table_target: wgpu::BindGroup,
}

impl SkyBindings {
    fn new(device: &wgpu::Device, uniforms: &wgpu::Buffer) -> Self {
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
        Self {
            layout,
            sky: sky_bind_group,
            table_uniforms_layout,
            table_target_layout,
            table_uniforms,
            table_target,
        }
    }
}

impl SkyPass {
    /// The pass over the look uniforms `uniforms`, drawing into `color_format`.
    pub fn new(
        device: &wgpu::Device,
        color_format: wgpu::TextureFormat,
        uniforms: &wgpu::Buffer,
    ) -> Self {
        let b = SkyBindings::new(device, uniforms);
        let (layout, table_uniforms_layout, table_target_layout) =
            (&b.layout, &b.table_uniforms_layout, &b.table_target_layout);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("sky.wgsl"),
            source: wgpu::ShaderSource::Wgsl(shader::assemble(shader::SKY).into()),
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("sky pipeline layout"),
            bind_group_layouts: &[Some(layout)],
            immediate_size: 0,
        });
        let table_pass = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("sky table"),
            layout: Some(
                &device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                    label: Some("sky table pipeline layout"),
                    bind_group_layouts: &[Some(table_uniforms_layout), Some(table_target_layout)],
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
            sky_pipeline: sky_pipeline(false, "vs_sky"),
            sky_ring_pipeline: sky_pipeline(false, "vs_sky_ring"),
            sky_table_pipeline: sky_pipeline(true, "vs_sky"),
            table_pass,
            sky_bind_group: b.sky,
            table_uniforms: b.table_uniforms,
            table_target: b.table_target,
            table_frame: false,
        }
    }

    /// Records this frame's sky-view table when `table` (the sky is on and the eye inside the
    /// atmosphere); without it the sky pass integrates every pixel's ray. After the look
    /// uniforms are written, before the terrain pass.
    pub fn prepare(&mut self, encoder: &mut wgpu::CommandEncoder, table: bool) {
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
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>, ring: Option<SkyRing>) {
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
