//! The draped imagery on the GPU: one sRGB texture with its area-averaged mipmaps
//! (`imagery::Imagery::mips`), which the normal pass (`shaders/fill_normals.wgsl`) samples
//! per texel into each level's imagery layer, band-limited to the texel: the terrain pass
//! then reads one filtered texel per level, as it reads the normal (issue 35's
//! view-independent part per texel, issue 36's imagery).

use std::sync::atomic::{AtomicBool, Ordering};

use crate::imagery::{Imagery, Mip};

/// Format of the image (filtered in linear light) and of the level layers the normal pass
/// writes (sRGB-encoded by hand: a storage texture cannot be sRGB).
pub const IMAGERY_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
pub const LEVEL_IMAGERY_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

/// Where the uploaded image lies: its west and north edges, pixel size (degrees), size and
/// whether its columns go round the globe.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageryGeometry {
    pub west_deg: f64,
    pub north_deg: f64,
    pub dlon_deg: f64,
    pub dlat_deg: f64,
    pub width: u32,
    pub height: u32,
    pub wraps: bool,
}

impl ImageryGeometry {
    /// Continuous pixel coordinates (edges at integers) of grid point (gx, gy) of a level
    /// whose steps are `dphi`, `dtheta` (radians): rows past a pole unfolded to the point
    /// across it, longitude taken modulo the image's period. f64: the twin of the shader's
    /// f32 sums.
    pub fn pixel_of(&self, gx: i64, gy: i64, dphi: f64, dtheta: f64) -> (f64, f64) {
        let (dx, dy) = self.steps(dphi, dtheta);
        let (x, y) = (gx as f64 * dx, gy as f64 * dy);
        self.fold(
            x - self.west_deg / self.dlon_deg,
            y + (self.north_deg - 90.0) / self.dlat_deg,
        )
    }

    /// Image pixels per grid step, east and south.
    pub fn steps(&self, dphi: f64, dtheta: f64) -> (f64, f64) {
        (
            dphi.to_degrees() / self.dlon_deg,
            dtheta.to_degrees() / self.dlat_deg,
        )
    }

    /// The pixel coordinates of a point whose y may lie past a pole (y < y of 90° N or
    /// y > y of 90° S): the point across, half a turn on; x then modulo the period.
    pub fn fold(&self, x: f64, y: f64) -> (f64, f64) {
        let (north, south) = self.pole_rows();
        let period = 360.0 / self.dlon_deg;
        let (mut x, mut y) = (x, y);
        if y < north {
            y = 2.0 * north - y;
            x += 0.5 * period;
        } else if y > south {
            y = 2.0 * south - y;
            x += 0.5 * period;
        }
        (x.rem_euclid(period), y)
    }

    /// Pixel rows of 90° N and 90° S.
    pub fn pole_rows(&self) -> (f64, f64) {
        (
            (self.north_deg - 90.0) / self.dlat_deg,
            (self.north_deg + 90.0) / self.dlat_deg,
        )
    }

    /// The mip level a texel of `(dx, dy)` image pixels reads: its larger side.
    pub fn lod(dx: f64, dy: f64) -> f64 {
        dx.max(dy).max(1e-30).log2().max(0.0)
    }
}

/// The image's texture, its sampler and where it lies (`None` when no imagery is draped: a
/// 1 × 1 texture stands in for the bindings).
pub struct ImageryTexture {
    texture: wgpu::Texture,
    pub(crate) view: wgpu::TextureView,
    pub(crate) sampler: wgpu::Sampler,
    geometry: Option<ImageryGeometry>,
    mips: Vec<Mip>,
    /// Written to the GPU yet ([`upload`](Self::upload) runs inside `&self` encoders).
    uploaded: AtomicBool,
}

impl ImageryTexture {
    /// The texture for `imagery`; the mipmaps are computed now and written on the first
    /// [`upload`](Self::upload). Mip levels wider than the device allows are left out (the
    /// texture starts at the first one that fits; the geometry says its size).
    pub fn new(device: &wgpu::Device, imagery: Option<&Imagery>) -> Self {
        let max = device.limits().max_texture_dimension_2d;
        let (mips, geometry) = match imagery {
            Some(img) => {
                let mips: Vec<Mip> = img
                    .mips()
                    .into_iter()
                    .skip_while(|m| m.width > max || m.height > max)
                    .collect();
                let base = &mips[0];
                let geometry = ImageryGeometry {
                    west_deg: img.extent.west,
                    north_deg: img.extent.north,
                    dlon_deg: (img.extent.east - img.extent.west) / base.width as f64,
                    dlat_deg: (img.extent.north - img.extent.south) / base.height as f64,
                    width: base.width,
                    height: base.height,
                    wraps: img.wraps(),
                };
                (mips, Some(geometry))
            }
            None => (
                vec![Mip {
                    width: 1,
                    height: 1,
                    rgba: vec![0; 4],
                }],
                None,
            ),
        };
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("imagery"),
            size: wgpu::Extent3d {
                width: mips[0].width,
                height: mips[0].height,
                depth_or_array_layers: 1,
            },
            mip_level_count: mips.len() as u32,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: IMAGERY_FORMAT,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let view = texture.create_view(&Default::default());
        let wraps = geometry.is_some_and(|g| g.wraps);
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("imagery sampler"),
            address_mode_u: if wraps {
                wgpu::AddressMode::Repeat
            } else {
                wgpu::AddressMode::ClampToEdge
            },
            address_mode_v: wgpu::AddressMode::ClampToEdge,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            mipmap_filter: wgpu::MipmapFilterMode::Linear,
            ..Default::default()
        });
        Self {
            texture,
            view,
            sampler,
            geometry,
            mips,
            uploaded: AtomicBool::new(false),
        }
    }

    /// Where the image lies, if there is one.
    pub fn geometry(&self) -> Option<&ImageryGeometry> {
        self.geometry.as_ref()
    }

    /// The mip chain as uploaded (the f64 twin samples it).
    pub fn mips(&self) -> &[Mip] {
        &self.mips
    }

    /// Bytes the texture holds on the GPU.
    pub fn gpu_bytes(&self) -> u64 {
        self.mips.iter().map(|m| m.rgba.len() as u64).sum()
    }

    /// Writes the mipmaps once (before the first normal pass that samples them).
    pub fn upload(&self, queue: &wgpu::Queue) {
        if self.uploaded.swap(true, Ordering::Relaxed) {
            return;
        }
        for (level, m) in self.mips.iter().enumerate() {
            queue.write_texture(
                wgpu::TexelCopyTextureInfo {
                    texture: &self.texture,
                    mip_level: level as u32,
                    origin: wgpu::Origin3d::ZERO,
                    aspect: wgpu::TextureAspect::All,
                },
                &m.rgba,
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(4 * m.width),
                    rows_per_image: Some(m.height),
                },
                wgpu::Extent3d {
                    width: m.width,
                    height: m.height,
                    depth_or_array_layers: 1,
                },
            );
        }
    }
}

/// f64 twin of `fill_normals.wgsl`'s `texel_imagery`: the linear-light RGBA the normal pass
/// writes for grid point (gx, gy) of a level with steps `dphi`, `dtheta` (0 outside the
/// image), trilinear over `mips` as the GPU samples them.
pub fn texel_imagery(
    geometry: &ImageryGeometry,
    mips: &[Mip],
    gx: i64,
    gy: i64,
    dphi: f64,
    dtheta: f64,
) -> [f64; 4] {
    let (x, y) = geometry.pixel_of(gx, gy, dphi, dtheta);
    let (w, h) = (geometry.width as f64, geometry.height as f64);
    if x > w || !(0.0..=h).contains(&y) {
        return [0.0; 4];
    }
    let (dx, dy) = geometry.steps(dphi, dtheta);
    let lod = ImageryGeometry::lod(dx, dy).min((mips.len() - 1) as f64);
    let k0 = lod.floor() as usize;
    let k1 = (k0 + 1).min(mips.len() - 1);
    let t = lod - k0 as f64;
    let a = mips[k0].sample_uv(x / w, y / h, geometry.wraps);
    let b = mips[k1].sample_uv(x / w, y / h, geometry.wraps);
    std::array::from_fn(|c| a[c] + t * (b[c] - a[c]))
}
