//! The WGSL atmosphere (`shaders/common/look.wgsl`: `atmosphere_scatter`, `chapman_column`)
//! run in a compute shader on the adapter, against its f64 Rust twin
//! (`look::atmosphere::Atmosphere::scatter`, `chapman_column_m`) for rays from the ground,
//! from an aircraft and from space (through the glow at the limb and onto the disk): the sky,
//! the haze and the sunlight a frame shows are the ones the twin's tests check (blue sky, red
//! low sun, glow only inside the shell).

use crate::common;

use bytemuck::Zeroable;
use glam::DVec3;
use globe::geo::EARTH_RADIUS_M;
use globe::look::Atmosphere;
use globe::look::atmosphere::{chapman_column_m, ray_sphere_hit};
use globe::render::GpuContext;
use globe::render::gpu_data::LookUniforms;
use wgpu::util::DeviceExt;

const SAMPLES: u32 = 16;

const KERNEL: &str = r#"
@group(0) @binding(0) var<storage, read> rays: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read_write> results: array<vec4<f32>>;
@group(0) @binding(2) var<uniform> look: LookUniforms;

@compute @workgroup_size(1, 1, 1)
fn cs_main(@builtin(global_invocation_id) id: vec3<u32>) {
    let o = rays[2u * id.x];
    let d = rays[2u * id.x + 1u];
    let s = atmosphere_scatter(o.xyz, d.xyz, o.w, look.sun.xyz, 16u);
    let mu = dot(o.xyz, d.xyz) / length(o.xyz);
    let column = chapman_column(length(o.xyz), mu, look.shell.x, look.rayleigh.w);
    results[2u * id.x] = vec4<f32>(s.inscatter, column);
    results[2u * id.x + 1u] = vec4<f32>(s.transmittance, 0.0);
}
"#;

struct Ray {
    what: &'static str,
    o: DVec3,
    d: DVec3,
    t_max: f64,
}

fn rays(r: f64) -> Vec<Ray> {
    let mut out = Vec::new();
    let mut push = |what, o: DVec3, d: DVec3| {
        let d = d.normalize();
        // Rays that meet the planet stop there (the sky pass and the haze do the same).
        let t_max = ray_sphere_hit(o, d, r).unwrap_or(1e30);
        out.push(Ray { what, o, d, t_max });
    };
    let ground = DVec3::new(0.0, 0.0, r + 2.0);
    push("ground, zenith", ground, DVec3::Z);
    push("ground, 30° up", ground, DVec3::new(0.87, 0.0, 0.5));
    push("ground, 3° up", ground, DVec3::new(1.0, 0.2, 0.05));
    push("ground, toward the sun", ground, DVec3::new(-0.5, 0.5, 0.6));
    let aircraft = DVec3::new(0.0, 0.0, r + 10_000.0);
    push("aircraft, horizontal", aircraft, DVec3::new(0.3, 1.0, 0.0));
    push("aircraft, 20° down", aircraft, DVec3::new(0.94, 0.0, -0.34));
    let space = DVec3::new(0.0, 0.0, r + 20_000_000.0);
    push("space, nadir", space, -DVec3::Z);
    for h in [5_000.0, 20_000.0, 45_000.0] {
        let sin_a = (r + h) / space.z;
        let label = match h as u32 {
            5_000 => "space, limb 5 km",
            20_000 => "space, limb 20 km",
            _ => "space, limb 45 km",
        };
        // Toward the sunlit limb (the sun is over −x).
        push(
            label,
            space,
            DVec3::new(-sin_a, 0.0, -(1.0 - sin_a * sin_a).sqrt()),
        );
    }
    out
}

#[test]
fn wgsl_atmosphere_matches_its_f64_twin() {
    let Some((ctx, _lock)) = common::gpu() else {
        return;
    };
    let atmosphere = Atmosphere::earth(EARTH_RADIUS_M);
    let sun = DVec3::new(-0.57, 0.57, 0.57).normalize();
    let rays = rays(atmosphere.radius_m);
    let gpu = run(ctx, &atmosphere, sun, &rays);
    let mut worst = 0.0f64;
    for (ray, (inscatter, column, transmittance)) in rays.iter().zip(&gpu) {
        let (want_in, want_t) = atmosphere.scatter(ray.o, ray.d, ray.t_max, sun, SAMPLES);
        let mu = ray.o.dot(ray.d) / ray.o.length();
        let want_column = chapman_column_m(ray.o.length(), mu, atmosphere.radius_m, 8_000.0);
        println!(
            "{:<24} inscatter GPU {:.4} {:.4} {:.4} twin {:.4} {:.4} {:.4}; transmittance GPU {:.4} twin {:.4}",
            ray.what,
            inscatter.x,
            inscatter.y,
            inscatter.z,
            want_in.x,
            want_in.y,
            want_in.z,
            transmittance.z,
            want_t.z
        );
        for c in 0..3 {
            // f32 positions at R ≈ 6.4e6 m are good to half a metre: 1 % plus a floor of
            // 1e-4 (the scale of a lit white surface is 1).
            let err_in = (inscatter[c] - want_in[c]).abs();
            assert!(
                err_in <= 0.01 * want_in[c] + 1e-4,
                "{}: inscatter {c}: {} vs {}",
                ray.what,
                inscatter[c],
                want_in[c]
            );
            let err_t = (transmittance[c] - want_t[c]).abs();
            assert!(err_t <= 0.005, "{}: transmittance {c}", ray.what);
            worst = worst.max(err_in / want_in[c].max(1e-4));
        }
        assert!(!column.is_nan(), "{}: the column is NaN", ray.what);
        if want_column.is_finite() {
            let rel = (column - want_column).abs() / want_column;
            assert!(rel < 1e-3, "{}: column {column} vs {want_column}", ray.what);
        } else {
            // Into the planet: no sunlight along it (the GPU's column is huge or infinite).
            assert!(*column > 1e9, "{}: {column}", ray.what);
        }
    }
    println!("worst relative inscatter difference {worst:.2e}");
}

/// (inscatter, Rayleigh column from the origin along the ray, transmittance) per ray.
fn run(ctx: &GpuContext, a: &Atmosphere, sun: DVec3, rays: &[Ray]) -> Vec<(DVec3, f64, DVec3)> {
    let device = &ctx.device;
    let source = format!(
        "{}\n{}\n{KERNEL}",
        globe::render::shader::assemble(""),
        globe::render::shader::LOOK
    );
    let pipeline = common::compute_pipeline(ctx, source, "atmosphere twin test");
    let mut look = LookUniforms::zeroed();
    look.rayleigh = [
        a.rayleigh.x as f32,
        a.rayleigh.y as f32,
        a.rayleigh.z as f32,
        (1.0 / a.rayleigh_height_m) as f32,
    ];
    look.mie = [a.mie as f32; 4];
    look.mie[3] = (1.0 / a.mie_height_m) as f32;
    look.shell = [
        a.radius_m as f32,
        a.top_radius_m() as f32,
        a.mie_extinction_ratio as f32,
        a.mie_g as f32,
    ];
    look.light[0] = a.sun_radiance as f32;
    look.sun = [sun.x as f32, sun.y as f32, sun.z as f32, 0.0];
    let input: Vec<[f32; 4]> = rays
        .iter()
        .flat_map(|r| {
            [
                [r.o.x as f32, r.o.y as f32, r.o.z as f32, r.t_max as f32],
                [r.d.x as f32, r.d.y as f32, r.d.z as f32, 0.0],
            ]
        })
        .collect();
    let size = (input.len() * 16) as u64;
    let rays_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: None,
        contents: bytemuck::cast_slice(&input),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: None,
        contents: bytemuck::bytes_of(&look),
        usage: wgpu::BufferUsages::UNIFORM,
    });
    let output = common::output_buffer(ctx, size);
    let data = common::run_compute(
        ctx,
        &pipeline,
        &[&rays_buf, &output, &uniform],
        &output,
        rays.len() as u32,
    );
    let v: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&data);
    v.chunks(2)
        .map(|p| {
            (
                DVec3::new(p[0][0] as f64, p[0][1] as f64, p[0][2] as f64),
                p[0][3] as f64,
                DVec3::new(p[1][0] as f64, p[1][1] as f64, p[1][2] as f64),
            )
        })
        .collect()
}
