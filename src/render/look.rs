//! GPU side of the look (`crate::look`): the proto-texture array and the wave texture with
//! their mip chains, their sampler and the look uniforms, with the sky pass (`render::sky`)
//! and the aerial-perspective volume (`render::aerial`) that read the same uniforms.

use crate::look::SkyRing;
use crate::look::proto::{self, MIP_LEVELS, MipKind, TEXTURE_SIZE};

use super::aerial::AerialPass;
use super::gpu_data::LookUniforms;
use super::sky::SkyPass;

pub struct LookResources {
    pub uniforms: wgpu::Buffer,
    albedo: wgpu::Texture,
    pub albedo_view: wgpu::TextureView,
    waves: wgpu::Texture,
    pub waves_view: wgpu::TextureView,
    pub sampler: wgpu::Sampler,
    sky: SkyPass,
    /// The haze per pixel: the aerial-perspective volume the terrain pass reads.
    pub aerial: AerialPass,
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
        let sky = SkyPass::new(device, color_format, &uniforms);
        let aerial = AerialPass::new(device, &uniforms);
        Self {
            uniforms,
            albedo,
            albedo_view,
            waves,
            waves_view,
            sampler,
            sky,
            aerial,
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

    /// Records this frame's sky-view table when `table` ([`SkyPass::prepare`]).
    pub fn prepare_sky(&mut self, encoder: &mut wgpu::CommandEncoder, table: bool) {
        self.sky.prepare(encoder, table);
    }

    /// Whether this frame's sky reads the table.
    pub fn sky_from_table(&self) -> bool {
        self.sky.sky_from_table()
    }

    /// Draws the sky into the pixels the terrain left empty ([`SkyPass::draw`]).
    pub fn draw_sky(&self, pass: &mut wgpu::RenderPass<'_>, ring: Option<SkyRing>) {
        self.sky.draw(pass, ring);
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
