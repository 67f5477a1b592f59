//! The normal pass: per-level world-frame normals, computed once per texel after the heights
//! (`shaders/fill_normals.wgsl`), so the terrain pass's fragments read one filtered texel per
//! level instead of evaluating the terrain height four more times (issue 14).
//!
//! A normal depends on the texel's neighbours, so every rectangle a fill wrote is redone one
//! texel wider on each side (clipped to the level's window: beyond it the toroidal texture
//! holds other points). Texels on the window's edge read wrapped neighbours; they lie in the
//! margin the renderer never samples (the window is twice the level's diameter).

use glam::DVec3;

use crate::clipmap::levels::{GridRect, LevelGrid};

use super::dispatch::DispatchParams;
use super::fill_analytic::FillJob;
use super::gpu_data::NormalParams;
use super::imagery::{ImageryTexture, LEVEL_IMAGERY_FORMAT};
use super::shader;

/// Format of the normal textures: a unit world vector (xyz), the texel's height (w).
pub const NORMAL_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// Format of the boundary-noise textures ([`texel_boundary_noise`]).
pub const BOUNDARY_NOISE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

/// The rectangles whose normals a fill of `rect` into `grid` invalidates: `rect` one texel
/// wider on each side, within the window.
pub fn normal_rect(grid: &LevelGrid, rect: &GridRect) -> GridRect {
    let s = grid.size as i64;
    let x0 = (rect.gx0 - grid.gx0).rem_euclid(grid.period_x());
    let y0 = rect.gy0 - grid.gy0;
    let (x_lo, x_hi) = ((x0 - 1).max(0), (x0 + rect.width as i64 + 1).min(s));
    let (y_lo, y_hi) = ((y0 - 1).max(0), (y0 + rect.height as i64 + 1).min(s));
    GridRect {
        gx0: (grid.gx0 + x_lo).rem_euclid(grid.period_x()),
        gy0: grid.gy0 + y_lo,
        width: (x_hi - x_lo).max(0) as u32,
        height: (y_hi - y_lo).max(0) as u32,
    }
}

/// A rectangle of a level texture in texels (toroidal: it may run past the last column or
/// row into the first).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SlotRect {
    pub layer: u32,
    pub x0: u32,
    pub y0: u32,
    pub width: u32,
    pub height: u32,
}

/// Pipeline, parameter blocks and bind group of the normal pass.
pub struct NormalPass {
    pipeline: wgpu::ComputePipeline,
    params: DispatchParams,
    bind_group: wgpu::BindGroup,
    /// The draped image the pass samples into the level imagery (a stand-in without one).
    imagery: ImageryTexture,
}

impl NormalPass {
    /// A pass reading `heights` and `partials` and writing `normals`, `boundary_noise` and
    /// `level_imagery` (all level arrays; the last sampled from `imagery`), with room for
    /// `capacity` dispatches per frame.
    pub fn new(
        device: &wgpu::Device,
        capacity: u32,
        heights: &wgpu::TextureView,
        partials: &wgpu::TextureView,
        out: [&wgpu::TextureView; 3],
        imagery: ImageryTexture,
    ) -> Self {
        let [normals, boundary_noise, level_imagery] = out;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("fill_normals.wgsl"),
            source: wgpu::ShaderSource::Wgsl(shader::assemble(shader::FILL_NORMALS).into()),
        });
        let params = DispatchParams::new::<NormalParams>(device, "normal params", capacity);
        let texture = |binding| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Float { filterable: false },
                view_dimension: wgpu::TextureViewDimension::D2Array,
                multisampled: false,
            },
            count: None,
        };
        let storage = |binding, format| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::StorageTexture {
                access: wgpu::StorageTextureAccess::WriteOnly,
                format,
                view_dimension: wgpu::TextureViewDimension::D2Array,
            },
            count: None,
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("normal layout"),
            entries: &[
                params.layout_entry(0),
                texture(1),
                texture(2),
                storage(3, NORMAL_FORMAT),
                storage(4, BOUNDARY_NOISE_FORMAT),
                storage(5, LEVEL_IMAGERY_FORMAT),
                wgpu::BindGroupLayoutEntry {
                    binding: 6,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: true },
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 7,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                    count: None,
                },
            ],
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("normal bind group"),
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: params.binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(heights),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(partials),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: wgpu::BindingResource::TextureView(normals),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: wgpu::BindingResource::TextureView(boundary_noise),
                },
                wgpu::BindGroupEntry {
                    binding: 5,
                    resource: wgpu::BindingResource::TextureView(level_imagery),
                },
                wgpu::BindGroupEntry {
                    binding: 6,
                    resource: wgpu::BindingResource::TextureView(&imagery.view),
                },
                wgpu::BindGroupEntry {
                    binding: 7,
                    resource: wgpu::BindingResource::Sampler(&imagery.sampler),
                },
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("normal pipeline layout"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("normal pipeline"),
            layout: Some(&pipeline_layout),
            module: &module,
            entry_point: Some("cs_main"),
            compilation_options: Default::default(),
            cache: None,
        });
        Self {
            pipeline,
            params,
            bind_group,
            imagery,
        }
    }

    /// The draped image as the pass samples it.
    pub fn imagery(&self) -> &ImageryTexture {
        &self.imagery
    }

    /// Records the normals of the rectangles the fills of `jobs` wrote (each widened by a
    /// texel); `partials(level)` is the number of partial octaves a level holds. Returns the
    /// texture rectangles written (the water cull's blocks to redo). Call after the fills, in
    /// the same encoder.
    pub fn encode(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        jobs: &[FillJob],
        radius_m: f64,
        partials: impl Fn(u32) -> u32,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) -> Vec<SlotRect> {
        let blocks: Vec<(NormalParams, GridRect)> = jobs
            .iter()
            .map(|j| normal_rect(&j.grid, &j.rect))
            .zip(jobs)
            .filter(|(r, _)| r.texels() > 0)
            .flat_map(|(r, j)| {
                let partial_count = partials(j.grid.level);
                let imagery = self.imagery.geometry();
                r.anchored_pieces(j.grid.anchor_block())
                    .into_iter()
                    .map(move |(piece, anchor)| {
                        (
                            NormalParams::new(&j.grid, &piece, anchor, radius_m, partial_count)
                                .with_imagery(imagery, &j.grid, anchor),
                            piece,
                        )
                    })
            })
            .collect();
        assert!(
            blocks.len() as u32 <= self.params.capacity(),
            "more normal jobs than the parameter buffer holds"
        );
        if blocks.is_empty() {
            return Vec::new();
        }
        self.imagery.upload(queue);
        let params: Vec<NormalParams> = blocks.iter().map(|(p, _)| *p).collect();
        self.params.write(queue, &params);
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("clipmap normals"),
            timestamp_writes: timestamps,
        });
        pass.set_pipeline(&self.pipeline);
        for (i, (_, rect)) in blocks.iter().enumerate() {
            pass.set_bind_group(0, &self.bind_group, &[self.params.offset(i)]);
            pass.dispatch_workgroups(
                rect.width.div_ceil(shader::WORKGROUP_SIZE),
                rect.height.div_ceil(shader::WORKGROUP_SIZE),
                1,
            );
        }
        blocks
            .iter()
            .map(|(p, _)| SlotRect {
                layer: p.layer,
                x0: p.slot0[0],
                y0: p.slot0[1],
                width: p.extent[0],
                height: p.extent[1],
            })
            .collect()
    }
}

/// f64 twin of `fill_normals.wgsl`: the world-frame normal of grid point (gx, gy) of `grid`
/// (rows past a pole unfolded) from `height(gx, gy)`, the level's height with its partial
/// octaves.
pub fn texel_normal(
    grid: &LevelGrid,
    gx: i64,
    gy: i64,
    radius_m: f64,
    height: impl Fn(i64, i64) -> f64,
) -> DVec3 {
    let (dphi, dtheta) = (grid.dphi_rad, grid.dtheta_rad);
    let (st, ct) = (gy as f64 * dtheta).sin_cos();
    let (sp, cp) = (gx as f64 * dphi).sin_cos();
    let up = DVec3::new(st * cp, st * sp, ct);
    let e_theta = DVec3::new(ct * cp, ct * sp, -st);
    let r = radius_m + height(gx, gy);
    let chord_theta = 2.0 * r * dtheta.sin();
    let s_theta = (height(gx, gy + 1) - height(gx, gy - 1)) / chord_theta;
    let south = ((grid.size as i64) << grid.level) / 4;
    let n = if gy == 0 || gy == south {
        let q = grid.size as i64 / 4;
        let e_theta_q = DVec3::new(-ct * sp, ct * cp, -st);
        let s_q = (height(gx + q, gy + 1) - height(gx + q, gy - 1)) / chord_theta;
        up - s_theta * e_theta - s_q * e_theta_q
    } else {
        let e_phi = DVec3::new(-sp, cp, 0.0);
        let steps = dtheta / (st.abs() * dphi).max(1e-30);
        let w = (steps.clamp(1.0, (grid.size / 4) as f64) + 0.5) as i64;
        let chord_phi = 2.0 * r * st * (w as f64 * dphi).sin();
        let s_phi = (height(gx + w, gy) - height(gx - w, gy)) / chord_phi;
        up - s_theta * e_theta - s_phi * e_phi
    };
    n.normalize()
}

/// f64 twin of `fill_normals.wgsl`'s `texel_boundary_noise`: (½ + ½·na, ½ + ½·nb, 0, 0)
/// of grid point (gx, gy) of `grid` at height `height_m` (its level's texel size the band
/// limit). The noise is evaluated at the texel's world point in f64 (the shader's
/// anchor-relative sum in f32 differs by far less than its 8-bit output).
pub fn texel_boundary_noise(
    grid: &LevelGrid,
    gx: i64,
    gy: i64,
    radius_m: f64,
    height_m: f64,
) -> [f64; 4] {
    use crate::look::{BOUNDARY_CELLS_M, BOUNDARY_SEEDS};
    use crate::procedural::noise::value_noise;
    let (dphi, dtheta) = (grid.dphi_rad, grid.dtheta_rad);
    let (st, ct) = (gy as f64 * dtheta).sin_cos();
    let (sp, cp) = (gx as f64 * dphi).sin_cos();
    let world = DVec3::new(st * cp, st * sp, ct) * (radius_m + height_m);
    let footprint_m = radius_m * dtheta.max(st.abs() * dphi);
    let octave = |k: usize| {
        let x = world / BOUNDARY_CELLS_M[k];
        let c = x.floor();
        let v = value_noise(
            [c.x as i32, c.y as i32, c.z as i32],
            (x - c).to_array(),
            BOUNDARY_SEEDS[k],
        );
        v * (1.0 - smoothstep(0.5, 1.0, footprint_m / BOUNDARY_CELLS_M[k]))
    };
    [0.5 + 0.5 * octave(0), 0.5 + 0.5 * octave(1), 0.0, 0.0]
}

/// WGSL's `smoothstep`.
fn smoothstep(e0: f64, e1: f64, x: f64) -> f64 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A widened rectangle stays inside the window and covers the original plus a texel.
    #[test]
    fn normal_rects_widen_within_the_window() {
        let g = LevelGrid::for_viewer(6, 64, 0.5, 1.0, None);
        let p = g.period_x();
        // A strip of new columns on the window's right edge: widened only to the left.
        let strip = GridRect {
            gx0: (g.gx0 + 60).rem_euclid(p),
            gy0: g.gy0,
            width: 4,
            height: 64,
        };
        let r = normal_rect(&g, &strip);
        assert_eq!(r.gx0, (g.gx0 + 59).rem_euclid(p));
        assert_eq!((r.width, r.gy0, r.height), (5, g.gy0, 64));
        // Rows in the middle: one more on each side.
        let rows = GridRect {
            gx0: g.gx0,
            gy0: g.gy0 + 10,
            width: 64,
            height: 3,
        };
        let r = normal_rect(&g, &rows);
        assert_eq!((r.gx0, r.gy0, r.width, r.height), (g.gx0, g.gy0 + 9, 64, 5));
    }

    /// On a tilted plane through the sphere's surface, the twin gives the plane's normal away
    /// from the poles, on a pole row, and on the rows next to it.
    #[test]
    fn twin_recovers_a_tilted_plane_everywhere() {
        let radius = 1000.0;
        let tilt = DVec3::new(0.3, -0.2, 0.0);
        for (level, theta_v) in [(6, 1.0), (6, 1e-3), (6, std::f64::consts::PI - 1e-3)] {
            let g = LevelGrid::for_viewer(level, 64, 0.4, theta_v, None);
            // Heights of the plane through the viewer's point: h = tilt · (point − viewer).
            let point = |gx: i64, gy: i64| {
                let (phi, theta) = (gx as f64 * g.dphi_rad, gy as f64 * g.dtheta_rad);
                DVec3::new(
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                )
            };
            let height = |gx: i64, gy: i64| tilt.dot(point(gx, gy)) * radius;
            for (gx, gy) in [(g.gx0 + 32, g.gy0 + 32), (g.gx0 + 5, 0), (g.gx0 + 7, 1)] {
                if !(g.gy0..g.gy0 + 64).contains(&gy) {
                    continue;
                }
                let n = texel_normal(&g, gx, gy, radius, height);
                let up = point(gx, gy);
                // The surface r = R + tilt·p has normal ∝ up − (tilt − (tilt·up)·up)·R/r.
                let r = radius + height(gx, gy);
                let expected = (up - (tilt - tilt.dot(up) * up) * radius / r).normalize();
                let err = n.angle_between(expected);
                assert!(
                    err < 2e-3,
                    "level {level} θv {theta_v} ({gx},{gy}): normal off by {err} rad"
                );
            }
        }
    }
}
