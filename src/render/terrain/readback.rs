//! Reading the level textures back (tests and the instruments compare them with the
//! terrain function).

use super::TerrainRenderer;
use crate::clipmap::levels::LevelGrid;

/// A level's imagery texels with their grid (`TerrainRenderer::read_level_imagery`).
pub type LevelImagery = (LevelGrid, Vec<[u8; 4]>);
use crate::render::{GpuContext, RenderError, water_cull};

impl TerrainRenderer {
    /// The grid a level's texture holds and its heights in grid order (row gy0 first, column
    /// gx0 first), read back from the GPU as stored: h − `grid.ref_m` (tests compare the fill
    /// with the terrain function).
    pub fn read_level(
        &self,
        ctx: &GpuContext,
        level: u32,
    ) -> Result<Option<(LevelGrid, Vec<f32>)>, RenderError> {
        let Some(grid) = self.grids.get(level as usize).copied().flatten() else {
            return Ok(None);
        };
        let texels = self.read_layer(ctx, &self.textures.heights, &grid, 4)?;
        let out = texels
            .iter()
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        Ok(Some((grid, out)))
    }

    /// The level's partial detail octaves (σ·t_k of octaves `detail_full`… in RGBA), in grid
    /// order as [`TerrainRenderer::read_level`], with the index of the first one.
    pub fn read_level_partials(
        &self,
        ctx: &GpuContext,
        level: u32,
    ) -> Result<Option<LevelPartials>, RenderError> {
        let Some(grid) = self.grids.get(level as usize).copied().flatten() else {
            return Ok(None);
        };
        let first = self.terrain.detail().map_or(0, |d| {
            d.level_octaves(level, self.settings.blend_fraction as f64)
                .full
        });
        let texels = self.read_layer(ctx, &self.textures.partials, &grid, 8)?;
        let out = texels
            .iter()
            .map(|b| {
                std::array::from_fn(|c| f16_to_f32(u16::from_le_bytes([b[2 * c], b[2 * c + 1]])))
            })
            .collect();
        Ok(Some((grid, first, out)))
    }

    /// The lowest height in level `level`'s normal texture (the w the fragments compare with
    /// the water level) over the blocks `b` touches (`render::water_cull::in_box_blocks`),
    /// read back: the water cull's input, for its tests. None for a level never filled.
    pub fn read_level_lowest_m(
        &self,
        ctx: &GpuContext,
        level: u32,
        b: [u32; 4],
    ) -> Result<Option<f32>, RenderError> {
        let Some(grid) = self.grids.get(level as usize).copied().flatten() else {
            return Ok(None);
        };
        let texels = self.read_layer(ctx, &self.textures.normals, &grid, 8)?;
        let s = grid.size as i64;
        let mut lo = f32::INFINITY;
        for (k, t) in texels.iter().enumerate() {
            // Grid order back to the texture's slots.
            let (i, j) = (k as i64 % s, k as i64 / s);
            let x = (grid.gx0 + i).rem_euclid(s) as u32;
            let y = (grid.gy0 + j).rem_euclid(s) as u32;
            if water_cull::in_box_blocks(b, x, y, grid.size) {
                lo = lo.min(f16_to_f32(u16::from_le_bytes([t[6], t[7]])));
            }
        }
        Ok(Some(lo))
    }

    /// Whether the last frame's sky came from the sky-view table (`render::look`).
    pub fn sky_from_table(&self) -> bool {
        self.look_resources.sky_from_table()
    }

    /// The water cull's boxes of the last frame (`render::water_cull::level_boxes`).
    pub fn water_cull_boxes(&self) -> Option<&[[u32; 4]]> {
        self.passes.water_cull.as_ref().map(|c| c.boxes())
    }

    /// The water cull's choice for each draw range of the last frame prepared: true where the
    /// pipeline without the water's code draws it (None: no water, no cull).
    pub fn read_dry_draws(&self, ctx: &GpuContext) -> Result<Option<Vec<bool>>, RenderError> {
        match &self.passes.water_cull {
            Some(cull) => cull.read_dry(ctx).map(Some),
            None => Ok(None),
        }
    }

    /// The level's world-frame normals (`render::normals`) in grid order as
    /// [`TerrainRenderer::read_level`].
    pub fn read_level_normals(
        &self,
        ctx: &GpuContext,
        level: u32,
    ) -> Result<Option<LevelNormals>, RenderError> {
        let Some(grid) = self.grids.get(level as usize).copied().flatten() else {
            return Ok(None);
        };
        let texels = self.read_layer(ctx, &self.textures.normals, &grid, 8)?;
        let out = texels
            .iter()
            .map(|b| {
                std::array::from_fn(|c| f16_to_f32(u16::from_le_bytes([b[2 * c], b[2 * c + 1]])))
            })
            .collect();
        Ok(Some((grid, out)))
    }

    /// The level's boundary noise (`render::normals::texel_boundary_noise`, 8 bits a channel,
    /// as 0..1) in grid order as [`TerrainRenderer::read_level`].
    pub fn read_level_boundary_noise(
        &self,
        ctx: &GpuContext,
        level: u32,
    ) -> Result<Option<LevelBoundaryNoise>, RenderError> {
        let Some(grid) = self.grids.get(level as usize).copied().flatten() else {
            return Ok(None);
        };
        let texels = self.read_layer(ctx, &self.textures.boundary_noise, &grid, 4)?;
        let out = texels
            .iter()
            .map(|b| std::array::from_fn(|c| f32::from(b[c]) / 255.0))
            .collect();
        Ok(Some((grid, out)))
    }

    /// The level's imagery (`render::imagery::texel_imagery`, sRGB-encoded bytes, alpha the
    /// coverage) in grid order as [`TerrainRenderer::read_level`].
    pub fn read_level_imagery(
        &self,
        ctx: &GpuContext,
        level: u32,
    ) -> Result<Option<LevelImagery>, RenderError> {
        let Some(grid) = self.grids.get(level as usize).copied().flatten() else {
            return Ok(None);
        };
        let texels = self.read_layer(ctx, &self.textures.imagery, &grid, 4)?;
        let out = texels.iter().map(|b| [b[0], b[1], b[2], b[3]]).collect();
        Ok(Some((grid, out)))
    }

    /// The draped image as the normal pass samples it (its geometry and mips), if any.
    pub fn imagery(&self) -> &crate::render::imagery::ImageryTexture {
        self.passes.normals.imagery()
    }

    /// The texels of `texture`'s layer `grid.level` in grid order (row gy0 first, column gx0
    /// first), `bytes` each.
    fn read_layer(
        &self,
        ctx: &GpuContext,
        texture: &wgpu::Texture,
        grid: &LevelGrid,
        bytes: u32,
    ) -> Result<Vec<Vec<u8>>, RenderError> {
        let size = self.settings.texture_size;
        let row_bytes = (size * bytes).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT)
            * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let buffer = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("level readback"),
            size: row_bytes as u64 * size as u64,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture,
                mip_level: 0,
                origin: wgpu::Origin3d {
                    x: 0,
                    y: 0,
                    z: grid.level,
                },
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(row_bytes),
                    rows_per_image: Some(size),
                },
            },
            wgpu::Extent3d {
                width: size,
                height: size,
                depth_or_array_layers: 1,
            },
        );
        ctx.queue.submit([encoder.finish()]);
        let (tx, rx) = std::sync::mpsc::channel();
        buffer.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        ctx.wait_idle()?;
        rx.recv()
            .map_err(|e| RenderError::Readback(e.to_string()))?
            .map_err(|e| RenderError::Readback(e.to_string()))?;
        let data = buffer
            .get_mapped_range(..)
            .map_err(|e| RenderError::Readback(e.to_string()))?;
        let s = size as i64;
        let b = bytes as usize;
        let mut out = Vec::with_capacity((size * size) as usize);
        for j in 0..s {
            let ty = (grid.gy0 + j).rem_euclid(s) as usize;
            for i in 0..s {
                let tx = (grid.gx0 + i).rem_euclid(s) as usize;
                let at = ty * row_bytes as usize + b * tx;
                out.push(data[at..at + b].to_vec());
            }
        }
        Ok(out)
    }
}

/// A level's grid and its world-frame normal per grid point.
pub type LevelNormals = (LevelGrid, Vec<[f32; 3]>);
/// A level's grid and its boundary noise (RGBA, 0..1) in grid order.
pub type LevelBoundaryNoise = (LevelGrid, Vec<[f32; 4]>);

/// A level's grid, the index of its first partial octave and the partials per grid point.
pub type LevelPartials = (LevelGrid, u32, Vec<[f32; 4]>);

/// IEEE half → f32 (the partial-octave textures are RGBA16F).
fn f16_to_f32(h: u16) -> f32 {
    let sign = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exp = ((h >> 10) & 0x1f) as i32;
    let frac = (h & 0x3ff) as f32;
    match exp {
        0 => sign * frac * (-24f32).exp2(),
        31 if frac == 0.0 => sign * f32::INFINITY,
        31 => f32::NAN,
        e => sign * (1.0 + frac / 1024.0) * ((e - 15) as f32).exp2(),
    }
}
