//! CPU-side fill of clipmap level textures, for height sources the GPU cannot evaluate itself
//! (the DEM pyramid until tiles are streamed into a GPU cache, issue 4): heights of a dirty grid
//! rectangle are computed on the CPU and written into their toroidal slots.

use crate::clipmap::levels::{GridRect, LevelGrid};

/// (φ, θ) in radians of grid point (gx, gy) of `grid`, folded back onto the sphere: rows past a
/// pole (θ < 0 or θ > π) hold the point across it, as the GPU fill does.
pub fn grid_point_phi_theta(grid: &LevelGrid, gx: i64, gy: i64) -> (f64, f64) {
    use std::f64::consts::{PI, TAU};
    let mut phi = gx as f64 * grid.dphi_rad;
    let mut theta = gy as f64 * grid.dtheta_rad;
    if theta < 0.0 {
        theta = -theta;
        phi += PI;
    } else if theta > PI {
        theta = TAU - theta;
        phi += PI;
    }
    (phi.rem_euclid(TAU), theta.clamp(0.0, PI))
}

/// Computes `rect` with `height_m(φ, θ)` (row-major, `rect.width` per row), splitting the rows
/// between the available cores.
pub fn compute_rect(
    grid: &LevelGrid,
    rect: &GridRect,
    height_m: &(dyn Fn(f64, f64) -> f64 + Sync),
) -> Vec<f32> {
    let (w, h) = (rect.width as usize, rect.height as usize);
    let mut out = vec![0.0f32; w * h];
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(h.max(1));
    let rows_per = h.div_ceil(threads.max(1)).max(1);
    std::thread::scope(|scope| {
        for (chunk_index, chunk) in out.chunks_mut(rows_per * w).enumerate() {
            scope.spawn(move || {
                for (r, row) in chunk.chunks_mut(w).enumerate() {
                    let gy = rect.gy0 + (chunk_index * rows_per + r) as i64;
                    for (i, v) in row.iter_mut().enumerate() {
                        let (phi, theta) = grid_point_phi_theta(grid, rect.gx0 + i as i64, gy);
                        *v = height_m(phi, theta) as f32;
                    }
                }
            });
        }
    });
    out
}

/// Writes `heights` (row-major over `rect`) into layer `grid.level` of `texture`, texel
/// (gx mod S, gy mod S): up to four pieces where the rectangle wraps around the texture.
pub fn upload_rect(
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
    grid: &LevelGrid,
    rect: &GridRect,
    heights: &[f32],
) {
    let s = grid.size as i64;
    let spans = |start: i64, len: u32| -> Vec<(u32, u32, u32)> {
        // (slot, offset into the rectangle, length)
        let slot = start.rem_euclid(s) as u32;
        let first = len.min(grid.size - slot);
        let mut v = vec![(slot, 0, first)];
        if first < len {
            v.push((0, first, len - first));
        }
        v
    };
    for (sx, ox, wx) in spans(rect.gx0, rect.width) {
        for (sy, oy, hy) in spans(rect.gy0, rect.height) {
            let mut piece = Vec::with_capacity((wx * hy) as usize);
            for row in oy..oy + hy {
                let at = (row * rect.width + ox) as usize;
                piece.extend_from_slice(&heights[at..at + wx as usize]);
            }
            queue.write_texture(
                wgpu::TexelCopyTextureInfo {
                    texture,
                    mip_level: 0,
                    origin: wgpu::Origin3d {
                        x: sx,
                        y: sy,
                        z: grid.level,
                    },
                    aspect: wgpu::TextureAspect::All,
                },
                bytemuck::cast_slice(&piece),
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(wx * 4),
                    rows_per_image: Some(hy),
                },
                wgpu::Extent3d {
                    width: wx,
                    height: hy,
                    depth_or_array_layers: 1,
                },
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_past_a_pole_hold_the_point_across_it() {
        let g = LevelGrid::for_viewer(3, 64, 0.5, 0.01, None);
        let (phi, theta) = grid_point_phi_theta(&g, 10, -4);
        assert!((theta - 4.0 * g.dtheta_rad).abs() < 1e-12);
        let expected = (10.0 * g.dphi_rad + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU);
        assert!((phi - expected).abs() < 1e-12);
    }
}
