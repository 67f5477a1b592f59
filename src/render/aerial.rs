//! The aerial-perspective volume (`shaders/aerial.wgsl`, issue 35): the haze between the eye
//! and every distance along every cell of a froxel grid over the frame, integrated once per
//! frame, so a terrain fragment reads its haze at its pixel and distance instead of
//! interpolating what its triangle's vertices integrated (the image no longer depends on the
//! mesh: from space, per-vertex haze drew rings on the disk).

use super::gpu_data::LookUniforms;
use super::shader::{self, AERIAL_SIZE};

/// The volumes' format: in-scattered light (rgb) and transmittance (rgb), one texture each.
const AERIAL_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// The slices of a frame (`shaders/aerial.wgsl`), as `LookUniforms::aerial` takes them.
/// With the eye inside the atmosphere (below `top_radius_m`), by distance: from the nearest
/// distance terrain can be at (the eye's height above the highest terrain, at least 1 m) to
/// the farthest it can be seen at (the tangent from the eye to a sphere under all terrain,
/// continued to the atmosphere's top): (d0, 1/ln(d1/d0), ln(d1/d0), 0). From above it, by
/// altitude, from the highest terrain to the lowest (each 100 m beyond):
/// (a_lo, 1/(a_hi − a_lo), a_hi − a_lo, 1).
pub fn slices(
    eye_radius_m: f64,
    radius_m: f64,
    (lowest_m, highest_m): (f64, f64),
    top_radius_m: f64,
) -> [f32; 4] {
    if eye_radius_m >= top_radius_m {
        let (lo, hi) = (lowest_m - 100.0, highest_m + 100.0);
        return [lo as f32, (1.0 / (hi - lo)) as f32, (hi - lo) as f32, 1.0];
    }
    let d0 = (eye_radius_m - radius_m - highest_m).max(1.0);
    let low = (radius_m + lowest_m - 1_000.0).min(eye_radius_m);
    let tangent = |r: f64| ((r - low) * (r + low)).max(0.0).sqrt();
    let d1 = (tangent(eye_radius_m) + tangent(top_radius_m)).max(d0 * 1.001);
    let ln = (d1 / d0).ln();
    [d0 as f32, (1.0 / ln) as f32, ln as f32, 0.0]
}

/// The volumes, their sampler and the compute pass that fills them.
pub struct AerialPass {
    pipeline: wgpu::ComputePipeline,
    uniforms: wgpu::BindGroup,
    targets: wgpu::BindGroup,
    pub inscatter_view: wgpu::TextureView,
    pub transmittance_view: wgpu::TextureView,
    /// Trilinear, clamped at every edge (a pixel beyond the last slice's distance keeps it).
    pub sampler: wgpu::Sampler,
    /// What the volume was last filled for ([`VolumeKey`]): a still camera under a still sun
    /// fills it once.
    filled_for: Option<VolumeKey>,
}

/// Everything of the look uniforms the volume depends on: the rays (clip → view), the eye's
/// radius, the sun, the atmosphere and the slices (not the time, which only moves the waves).
#[derive(Clone, Copy, PartialEq)]
struct VolumeKey {
    view_from_clip: [[f32; 4]; 4],
    sun: [f32; 4],
    eye_radius_m: f32,
    media: [[f32; 4]; 4],
    aerial: [f32; 4],
}

impl VolumeKey {
    fn of(look: &LookUniforms) -> Self {
        Self {
            view_from_clip: look.view_from_clip,
            sun: look.sun,
            eye_radius_m: look.eye_radius_m,
            media: [look.rayleigh, look.mie, look.shell, look.light],
            aerial: look.aerial,
        }
    }
}

impl AerialPass {
    /// The pass over the look uniforms `uniforms`.
    pub fn new(device: &wgpu::Device, uniforms: &wgpu::Buffer) -> Self {
        let volume = |label| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d {
                    width: AERIAL_SIZE[0],
                    height: AERIAL_SIZE[1],
                    depth_or_array_layers: AERIAL_SIZE[2],
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D3,
                format: AERIAL_FORMAT,
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::STORAGE_BINDING,
                view_formats: &[],
            })
        };
        let inscatter_view = volume("aerial inscatter").create_view(&Default::default());
        let transmittance_view = volume("aerial transmittance").create_view(&Default::default());
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("aerial sampler"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let uniforms_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("aerial uniforms layout"),
            entries: &[super::compute_uniform_entry(0)],
        });
        let storage = |binding| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::StorageTexture {
                access: wgpu::StorageTextureAccess::WriteOnly,
                format: AERIAL_FORMAT,
                view_dimension: wgpu::TextureViewDimension::D3,
            },
            count: None,
        };
        let targets_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("aerial targets layout"),
            entries: &[storage(0), storage(1)],
        });
        let uniforms = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("aerial uniforms"),
            layout: &uniforms_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: uniforms.as_entire_binding(),
            }],
        });
        let targets = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("aerial targets"),
            layout: &targets_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&inscatter_view),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&transmittance_view),
                },
            ],
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("aerial.wgsl"),
            source: wgpu::ShaderSource::Wgsl(shader::assemble(shader::AERIAL).into()),
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("aerial volume"),
            layout: Some(
                &device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                    label: Some("aerial pipeline layout"),
                    bind_group_layouts: &[Some(&uniforms_layout), Some(&targets_layout)],
                    immediate_size: 0,
                }),
            ),
            module: &module,
            entry_point: Some("cs_aerial"),
            compilation_options: Default::default(),
            cache: None,
        });
        Self {
            pipeline,
            uniforms,
            targets,
            inscatter_view,
            transmittance_view,
            sampler,
            filled_for: None,
        }
    }

    /// Records this frame's volume for the look uniforms `look` (after they are written,
    /// before the terrain pass reads it), unless it already holds it.
    pub fn encode(&mut self, encoder: &mut wgpu::CommandEncoder, look: &LookUniforms) {
        let key = VolumeKey::of(look);
        if self.filled_for == Some(key) {
            return;
        }
        self.filled_for = Some(key);
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("aerial volume"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.uniforms, &[]);
        pass.set_bind_group(1, &self.targets, &[]);
        pass.dispatch_workgroups(AERIAL_SIZE[0].div_ceil(8), AERIAL_SIZE[1].div_ceil(8), 1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Inside the atmosphere the slices span from the eye's height above the highest
    /// terrain to the farthest terrain visible: from 10 km up, the horizon of a sphere under
    /// the lowest terrain plus the atmosphere beyond it; from space, the terrain's altitudes.
    #[test]
    fn slices_span_the_visible_terrain() {
        let r = 6_371_000.0;
        let top = r + 100_000.0;
        let range = (-11_000.0, 4_800.0);
        let [d0, inv_ln, ln, mode] = slices(r + 10_000.0, r, range, top);
        assert_eq!((d0, mode), (5_200.0, 0.0));
        assert!((f64::from(inv_ln) * f64::from(ln) - 1.0).abs() < 1e-6);
        let d1 = f64::from(d0) * f64::from(ln).exp();
        let horizon = ((r + 10_000.0f64).powi(2) - (r - 12_000.0f64).powi(2)).sqrt();
        assert!(d1 > horizon && d1 < horizon + 1_300_000.0, "d1 {d1}");
        // Standing on the highest point: the first slice at 1 m, not 0.
        assert_eq!(slices(r + 4_800.5, r, range, top)[0], 1.0);
        // From space: by altitude, the terrain's range and 100 m beyond.
        assert_eq!(
            slices(r + 2e7, r, range, top),
            [-11_100.0, 1.0 / 16_000.0, 16_000.0, 1.0]
        );
    }
}
