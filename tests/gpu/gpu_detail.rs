//! The WGSL procedural detail itself (`shaders/common/detail_fill.wgsl` `detail_texel` over
//! `shaders/common/noise.wgsl`), run in a compute shader on the adapter (lavapipe on CI), for
//! 64 × 64 texels of a clipmap level's grid, against
//! (a) its f32 Rust twin `procedural::detail_texel_f32` (Δu from a Rust copy of the WGSL
//!     `delta_unit_from`): the same operations, so they agree to rounding;
//! (b) the f64 reference `Detail::height_m`: the whole octaves plus the partial ones weighted
//!     by λ are the detail the renderer shows.
//!
//! Sites: the equator, 45°N, 5 m from the north pole (the block crosses the pole at the
//! coarser level) and across the antimeridian, each at a mid level and a fine level that both
//! hold whole and partial octaves. The relief map is constant, so σ is the same number on both
//! sides. Figures go to stdout (`-- --nocapture`).

use crate::common;

use std::f64::consts::PI;

use globe::clipmap::levels::LevelGrid;
use globe::geo::EARTH_RADIUS_M;
use globe::geo::sphere;
use globe::geo::trig::sin_precise_f32;
use globe::procedural::{
    Detail, DetailParams, LevelOctaves, RoughnessMap, delta_texel_f32, detail_texel_f32,
};
use globe::render::GpuContext;
use globe::render::gpu_data::{DetailFillParams, delta_block_at};
use wgpu::util::DeviceExt;

const DETAIL_FILL: &str = include_str!("../../shaders/common/detail_fill.wgsl");

/// Texels per side of the block (and of the partials texture).
const SIDE: u32 = 64;
const RELIEF_M: f32 = 1000.0;
const BLEND: f64 = 0.25;
const TEXTURE_SIZE: u32 = 512;

const KERNEL: &str = r#"
@group(0) @binding(0) var<storage, read_write> full_out: array<f32>;

@compute @workgroup_size(8, 8, 1)
fn cs_main(@builtin(global_invocation_id) id: vec3<u32>) {
    let side = 64u;
    if id.x >= side || id.y >= side {
        return;
    }
    full_out[id.y * side + id.x] = detail_texel(id.xy, id.xy, 0u);
}
"#;

/// An IEEE half float's value.
fn f16_to_f32(h: u16) -> f32 {
    let sign = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exp = ((h >> 10) & 0x1f) as i32;
    let mant = (h & 0x3ff) as f32;
    match exp {
        0 => sign * mant * (-24f32).exp2(),
        31 if mant == 0.0 => sign * f32::INFINITY,
        31 => f32::NAN,
        e => sign * (1.0 + mant / 1024.0) * ((e - 15) as f32).exp2(),
    }
}

/// Rust copies of the WGSL `delta_sin`, `delta_cos`, `delta_unit_from` (noise.wgsl), same
/// operations in the same order.
fn delta_sin(s: f32, c: f32, d: f32) -> f32 {
    let h = sin_precise_f32(0.5 * d);
    -2.0 * s * h * h + c * sin_precise_f32(d)
}

fn delta_cos(s: f32, c: f32, d: f32) -> f32 {
    let h = sin_precise_f32(0.5 * d);
    -2.0 * c * h * h - s * sin_precise_f32(d)
}

fn delta_unit_from(ref_trig: [f32; 4], dphi: f32, dtheta: f32) -> [f32; 3] {
    let [st, ct, sp, cp] = ref_trig;
    let d_st = delta_sin(st, ct, dtheta);
    let d_ct = delta_cos(st, ct, dtheta);
    let d_sp = delta_sin(sp, cp, dphi);
    let d_cp = delta_cos(sp, cp, dphi);
    [
        st * d_cp + d_st * cp + d_st * d_cp,
        st * d_sp + d_st * sp + d_st * d_sp,
        d_ct,
    ]
}

/// One f32 ulp of `x`.
fn ulp(x: f32) -> f32 {
    let a = x.abs().max(f32::MIN_POSITIVE);
    f32::from_bits(a.to_bits() + 1) - a
}

struct Kernel {
    pipeline: wgpu::ComputePipeline,
    relief: wgpu::Buffer,
    partials: wgpu::Texture,
    partials_view: wgpu::TextureView,
}

impl Kernel {
    /// `coarse`: every builtin `sin`/`cos` left in the source made as coarse as NVIDIA's
    /// (`shader::with_coarse_builtin_trig`), as a real GPU would run it.
    fn new(ctx: &GpuContext, detail: &Detail, coarse: bool) -> Self {
        let device = &ctx.device;
        let mut source = format!(
            "{}\n{DETAIL_FILL}\n{KERNEL}",
            globe::render::shader::assemble("")
        );
        if coarse {
            source = globe::render::shader::with_coarse_builtin_trig(&source);
        }
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("detail twin test"),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: None,
            layout: None,
            module: &module,
            entry_point: Some("cs_main"),
            compilation_options: Default::default(),
            cache: None,
        });
        let relief = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("relief map"),
            contents: bytemuck::cast_slice(&detail.roughness().values),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let partials = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("partials"),
            size: wgpu::Extent3d {
                width: SIDE,
                height: SIDE,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba16Float,
            usage: wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let partials_view = partials.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        Self {
            pipeline,
            relief,
            partials,
            partials_view,
        }
    }

    /// Runs `detail_texel` for texels (0..SIDE)²: the returned whole-octave sums and the
    /// stored partials, row-major (index y·SIDE + x).
    fn run(&self, ctx: &GpuContext, params: &DetailFillParams) -> (Vec<f32>, Vec<[f32; 4]>) {
        let device = &ctx.device;
        let texels = (SIDE * SIDE) as u64;
        let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: None,
            contents: bytemuck::bytes_of(params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let output = device.create_buffer(&wgpu::BufferDescriptor {
            label: None,
            size: texels * 4,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let readback = |size| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: None,
                size,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let full_back = readback(texels * 4);
        let partials_back = readback(texels * 8);
        let group0 = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &self.pipeline.get_bind_group_layout(0),
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: output.as_entire_binding(),
            }],
        });
        let group1 = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &self.pipeline.get_bind_group_layout(1),
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: uniform.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: self.relief.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(&self.partials_view),
                },
            ],
        });
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &group0, &[]);
            pass.set_bind_group(1, &group1, &[]);
            pass.dispatch_workgroups(SIDE / 8, SIDE / 8, 1);
        }
        encoder.copy_buffer_to_buffer(&output, 0, &full_back, 0, texels * 4);
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &self.partials,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &partials_back,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    // 64 texels × 8 bytes = 512: a multiple of 256.
                    bytes_per_row: Some(SIDE * 8),
                    rows_per_image: Some(SIDE),
                },
            },
            wgpu::Extent3d {
                width: SIDE,
                height: SIDE,
                depth_or_array_layers: 1,
            },
        );
        ctx.queue.submit([encoder.finish()]);
        full_back.map_async(wgpu::MapMode::Read, .., |r| r.unwrap());
        partials_back.map_async(wgpu::MapMode::Read, .., |r| r.unwrap());
        ctx.wait_idle().unwrap();
        let full: Vec<f32> =
            bytemuck::cast_slice(&full_back.get_mapped_range(..).unwrap()).to_vec();
        let halves: Vec<u16> =
            bytemuck::cast_slice(&partials_back.get_mapped_range(..).unwrap()).to_vec();
        full_back.unmap();
        partials_back.unmap();
        let partials = halves
            .chunks_exact(4)
            .map(|c| [0, 1, 2, 3].map(|i| f16_to_f32(c[i])))
            .collect();
        (full, partials)
    }
}

struct Site {
    name: &'static str,
    phi_v: f64,
    theta_v: f64,
}

/// Worst errors of one site and level, metres.
#[derive(Default)]
struct Errors {
    twin: f64,
    twin_partial: f64,
    f64_all: f64,
    f64_weighted: f64,
}

/// Compares GPU, f32 twin and f64 reference over the block of `level` centred on the site.
fn check_site(ctx: &GpuContext, kernel: &Kernel, detail: &Detail, site: &Site, level: u32) {
    let grid = LevelGrid::for_viewer(level, TEXTURE_SIZE, site.phi_v, site.theta_v, None);
    let octaves = detail.level_octaves(level, BLEND);
    assert!(
        octaves.full > 0 && octaves.partial > 0,
        "level {level} must hold whole and partial octaves: {octaves:?}"
    );
    // The block's first grid point: the viewer's grid point minus half a block (columns not
    // reduced, so the block crosses φ = π at the antimeridian; rows unfolded past a pole).
    let half = SIDE as i64 / 2;
    let gx = (site.phi_v / grid.dphi_rad).floor() as i64 - half;
    let gy = (site.theta_v / grid.dtheta_rad).floor() as i64 - half;
    let (params, offset) = DetailFillParams::with_offset(Some(detail), &grid, gx, gy, BLEND);
    assert_eq!(params.counts[0], octaves.full);
    assert_eq!(params.counts[1], octaves.partial);
    // The same block with every held octave summed as whole: the GPU's f32 sum at
    // λ = full + partial, without the half floats of the partials texture.
    let mut all_params = params;
    all_params.counts[0] = octaves.full + octaves.partial;
    all_params.counts[1] = 0;

    let (full_gpu, partials_gpu) = kernel.run(ctx, &params);
    let (all_gpu, _) = kernel.run(ctx, &all_params);

    // Twin inputs: the anchors and constants DetailFillParams was built from.
    let (phi_r, theta_r) = (gx as f64 * grid.dphi_rad, gy as f64 * grid.dtheta_rad);
    let u_ref = sphere::unit_vector(phi_r, theta_r);
    let count = (octaves.full + octaves.partial) as usize;
    let anchors = detail.anchors(u_ref, count);
    let amplitudes = detail.amplitudes_f32();
    let constants = detail.constants_f32();
    let block = delta_block_at(detail, &grid, gx, gy, octaves);
    assert_eq!(params.delta[0] as usize, block.count);
    // σ as the WGSL forms it from the (constant) relief map.
    let sigma_f32 = (params.sigma[0] + params.sigma[1] * RELIEF_M).clamp(0.0, params.sigma[2]);
    let sigma = detail.amplitude_m(u_ref);
    assert!(
        ((sigma_f32 as f64) - sigma).abs() <= 1e-6 * sigma,
        "σ: f32 {sigma_f32} vs f64 {sigma}"
    );
    // λ halfway through the level's partial octaves.
    let lambda_mid = octaves.full as f64 + 0.5 * octaves.partial as f64;

    let mut e = Errors::default();
    for y in 0..SIDE {
        for x in 0..SIDE {
            let i = (y * SIDE + x) as usize;
            let dphi = x as f32 * params.ref_angles[2];
            let dtheta = y as f32 * params.ref_angles[3];
            let du = delta_unit_from(params.ref_trig, dphi, dtheta);
            let twin_of = |octaves| {
                if block.count > 0 {
                    let map = detail.roughness();
                    delta_texel_f32(
                        &block,
                        &amplitudes,
                        &constants,
                        map,
                        du,
                        dphi,
                        dtheta,
                        octaves,
                    )
                } else {
                    detail_texel_f32(&anchors, &amplitudes, &constants, du, sigma_f32, octaves)
                }
            };
            let twin = twin_of(octaves);
            let twin_all = twin_of(LevelOctaves {
                full: count as u32,
                partial: 0,
            });
            let u = sphere::unit_vector(
                phi_r + x as f64 * grid.dphi_rad,
                theta_r + y as f64 * grid.dtheta_rad,
            );
            let at = format!(
                "{} level {level}, texel ({x}, {y}) (φ {}, θ {})",
                site.name,
                phi_r + x as f64 * grid.dphi_rad,
                theta_r + y as f64 * grid.dtheta_rad
            );

            // (a) GPU vs f32 twin: rounding only (sin of tiny angles, fused multiply-adds).
            let (g, t) = (full_gpu[i], twin.full_m);
            assert!(g.is_finite(), "{at}: GPU gives {g}");
            let allowed = 1e-5 * sigma_f32 + 4.0 * ulp(t);
            assert!(
                (g - t).abs() <= allowed,
                "{at}: GPU whole octaves {g} m vs f32 twin {t} m (allowed {allowed} m)"
            );
            e.twin = e.twin.max((g - t).abs() as f64);
            let (g, t) = (all_gpu[i], twin_all.full_m);
            assert!(
                (g - t).abs() <= 1e-5 * sigma_f32 + 4.0 * ulp(t),
                "{at}: GPU all octaves {g} m vs f32 twin {t} m"
            );
            e.twin = e.twin.max((g - t).abs() as f64);
            for (k, (&g, &t)) in partials_gpu[i].iter().zip(&twin.partial_m).enumerate() {
                if k >= octaves.partial as usize {
                    assert_eq!(g, 0.0, "{at}: unused partial slot {k} holds {g}");
                    continue;
                }
                // Half floats: 11 significant bits, one ulp (2^−10 relative): Vulkan lets the
                // store round toward zero, and llvmpipe does.
                let allowed = t.abs() * (-10f32).exp2() + 1e-5 * sigma_f32 + 6e-8;
                assert!(
                    (g - t).abs() <= allowed,
                    "{at}: GPU partial {k} {g} m vs f32 twin {t} m (allowed {allowed} m)"
                );
                e.twin_partial = e.twin_partial.max((g - t).abs() as f64);
            }

            // (b) GPU vs the f64 reference.
            let reference = detail.height_m(u, count as f64);
            let err = (all_gpu[i] as f64 + offset - reference).abs();
            assert!(
                err <= 1e-4 * sigma,
                "{at}: GPU {} m vs f64 {reference} m at λ = {count}",
                all_gpu[i]
            );
            e.f64_all = e.f64_all.max(err);
            // Whole + λ-weighted partials (as the vertex weights them), half floats included.
            let mut shown = full_gpu[i] as f64 + offset;
            let mut half_slack = 0.0;
            for (k, &p) in partials_gpu[i][..octaves.partial as usize]
                .iter()
                .enumerate()
            {
                let w = Detail::weight(octaves.full as usize + k, lambda_mid);
                shown += w * p as f64;
                half_slack += w * (p as f64).abs() * (-10f64).exp2();
            }
            let reference = detail.height_m(u, lambda_mid);
            let err = (shown - reference).abs();
            assert!(
                err <= 1e-4 * sigma + half_slack,
                "{at}: GPU whole + weighted partials {shown} m vs f64 {reference} m at \
                 λ = {lambda_mid}"
            );
            e.f64_weighted = e.f64_weighted.max(err);
        }
    }
    println!(
        "detail twin {} L{level}: max |gpu − f32 twin| = {:.2e} m, max |gpu − f64| = {:.2e} m \
         over {} texels ({octaves:?}, σ {sigma:.3} m; f64 error {:.2e} σ at λ = {count}; \
         partials through half floats: {:.2e} m from the twin, whole + weighted partials \
         {:.2e} m from f64 at λ = {lambda_mid})",
        site.name,
        e.twin,
        e.f64_all,
        SIDE * SIDE,
        e.f64_all / sigma,
        e.twin_partial,
        e.f64_weighted,
    );
}

/// GPU (all held octaves as whole) vs f64 `height_m` with a relief map that varies: σ from
/// the WGSL `relief_at` (bilinear, columns wrapping at φ = 0, rows folded past a pole) against
/// `RoughnessMap::relief_at_m`. Returns the worst error in units of σ.
fn check_relief_site(
    ctx: &GpuContext,
    kernel: &Kernel,
    detail: &Detail,
    site: &Site,
    level: u32,
) -> f64 {
    let grid = LevelGrid::for_viewer(level, TEXTURE_SIZE, site.phi_v, site.theta_v, None);
    let octaves = detail.level_octaves(level, BLEND);
    let count = octaves.full + octaves.partial;
    let half = SIDE as i64 / 2;
    let gx = (site.phi_v / grid.dphi_rad).floor() as i64 - half;
    let gy = (site.theta_v / grid.dtheta_rad).floor() as i64 - half;
    let (mut params, offset) = DetailFillParams::with_offset(Some(detail), &grid, gx, gy, BLEND);
    params.counts[0] = count;
    params.counts[1] = 0;
    let (gpu, _) = kernel.run(ctx, &params);
    let (phi_r, theta_r) = (gx as f64 * grid.dphi_rad, gy as f64 * grid.dtheta_rad);
    let mut worst = 0f64;
    for y in 0..SIDE {
        for x in 0..SIDE {
            let (phi, theta) = (
                phi_r + x as f64 * grid.dphi_rad,
                theta_r + y as f64 * grid.dtheta_rad,
            );
            let u = sphere::unit_vector(phi, theta);
            let sigma = detail.amplitude_m(u);
            let reference = detail.height_m(u, count as f64);
            let g = gpu[(y * SIDE + x) as usize] as f64 + offset;
            let err = (g - reference).abs();
            assert!(
                err <= 1e-4 * sigma,
                "{} level {level}, texel ({x}, {y}) (φ {phi}, θ {theta}): GPU {g} m vs f64 \
                 {reference} m (σ {sigma} m)",
                site.name
            );
            worst = worst.max(err / sigma);
        }
    }
    worst
}

/// The WGSL detail matches its f32 Rust twin to rounding and the f64 reference to 10⁻⁴ σ, at
/// the equator, 45°N, 5 m from the north pole and across the antimeridian; also with the
/// builtins as coarse as an NVIDIA GPU's (its sines once moved the detail by metres there).
#[test]
fn wgsl_detail_matches_its_twins() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let (cols, rows) = (720u32, 360u32);
    let relief = RoughnessMap::from_values(
        cols,
        rows,
        vec![RELIEF_M; (cols * rows) as usize],
        EARTH_RADIUS_M,
    );
    let detail = Detail::new(DetailParams::default(), EARTH_RADIUS_M, 1000.0, relief);
    let kernels = [false, true].map(|coarse| Kernel::new(ctx, &detail, coarse));
    let sites = [
        Site {
            name: "equator",
            phi_v: 0.3,
            theta_v: PI / 2.0,
        },
        Site {
            name: "45°N",
            phi_v: 0.1859,
            theta_v: PI / 4.0,
        },
        Site {
            name: "5 m from N pole",
            phi_v: 1.0,
            theta_v: 5.0 / EARTH_RADIUS_M,
        },
        Site {
            name: "antimeridian",
            phi_v: PI - 1e-9,
            theta_v: PI / 2.0 - 0.4,
        },
    ];
    // Level 16: cells of 500 m down to 15.6 m over 2.4 m texels; level 24: down to 6 cm over
    // 1 cm texels.
    for kernel in &kernels {
        for site in &sites {
            for level in [16, 24] {
                check_site(ctx, kernel, &detail, site, level);
            }
        }
    }
    // The blocks do cross the pole (level 16: rows unfolded past θ = 0) and φ = π.
    let grid = LevelGrid::for_viewer(16, TEXTURE_SIZE, 1.0, 5.0 / EARTH_RADIUS_M, None);
    assert!((5.0 / EARTH_RADIUS_M / grid.dtheta_rad).floor() < (SIDE / 2) as f64);
    for level in [16, 24] {
        let s = &sites[3];
        let grid = LevelGrid::for_viewer(level, TEXTURE_SIZE, s.phi_v, s.theta_v, None);
        let gx = (s.phi_v / grid.dphi_rad).floor() as i64 - (SIDE / 2) as i64;
        assert!(gx as f64 * grid.dphi_rad < PI && (gx + SIDE as i64) as f64 * grid.dphi_rad > PI);
    }
}

/// The amplitude σ the WGSL takes from the relief map matches the f64 reference's where the
/// map varies: across its column wrap at φ = 0 (Greenwich), across the antimeridian, at 45°N
/// and through the north pole.
#[test]
fn wgsl_relief_amplitude_matches_the_reference() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let (cols, rows) = (720u32, 360u32);
    let values = (0..rows)
        .flat_map(|r| {
            (0..cols).map(move |c| {
                let a = std::f64::consts::TAU * c as f64 / cols as f64 + 0.3;
                let b = 3.0 * PI * r as f64 / rows as f64;
                (1000.0 + 500.0 * a.sin() + 300.0 * b.cos()) as f32
            })
        })
        .collect();
    let relief = RoughnessMap::from_values(cols, rows, values, EARTH_RADIUS_M);
    let detail = Detail::new(DetailParams::default(), EARTH_RADIUS_M, 1000.0, relief);
    let kernel = Kernel::new(ctx, &detail, false);
    let sites = [
        Site {
            name: "Greenwich (column wrap)",
            phi_v: 1e-9,
            theta_v: PI / 2.0 + 0.2,
        },
        Site {
            name: "antimeridian",
            phi_v: PI - 1e-9,
            theta_v: PI / 2.0 - 0.4,
        },
        Site {
            name: "45°N",
            phi_v: 0.1859,
            theta_v: PI / 4.0,
        },
        Site {
            name: "5 m from N pole",
            phi_v: 1.0,
            theta_v: 5.0 / EARTH_RADIUS_M,
        },
    ];
    for site in &sites {
        for level in [16, 24] {
            let worst = check_relief_site(ctx, &kernel, &detail, site, level);
            println!(
                "detail relief {} L{level}: max |gpu − f64| = {worst:.2e} σ over {} texels",
                site.name,
                SIDE * SIDE
            );
        }
    }
}
