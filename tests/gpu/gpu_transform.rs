//! The WGSL map transform itself, run in a compute shader on the adapter (lavapipe on CI),
//! against the f64 reference: the f32 texture-coordinate error on the ground, for rings within
//! 1 km of a viewer 2 m above ground, at the equator, at 45°, 10 m from a pole, exactly at both
//! poles, and across the antimeridian. The stable form (docs/design.md#numerics) must stay ≤ 1 cm; the paper's
//! direct form is measured beside it.

use crate::common;

use std::f64::consts::{PI, TAU};

use glam::{DVec3, Vec3};
use globe::geo::EARTH_RADIUS_M;
use globe::geo::map_transform::{self, Stretch, TransformUniformsF32};
use wgpu::util::DeviceExt;

const KERNEL: &str = r#"
@group(0) @binding(0) var<uniform> u: TransformUniforms;
@group(0) @binding(1) var<storage, read> cases: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> results: array<vec4<f32>>;

@compute @workgroup_size(64)
fn cs_main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= arrayLength(&cases) {
        return;
    }
    let c = cases[id.x];
    results[id.x] = vec4<f32>(map_transform_direct(u, c.xyz, c.w), map_transform_stable(u, c.xyz, c.w));
}
"#;

struct Viewer {
    name: &'static str,
    theta_v: f64,
    phi_v: f64,
}

/// (p̃ in f64, seam side) for rings at the given ground distances, 64 directions including the
/// seam meridians φ̃ = 0 and π (both copies).
fn cases(distances_m: &[f64]) -> Vec<(DVec3, f32)> {
    let mut out = Vec::new();
    for &d in distances_m {
        let theta_tilde = d / EARTH_RADIUS_M;
        for k in 0..64 {
            let phi_tilde = TAU * k as f64 / 64.0;
            let mut p = map_transform::p_tilde(phi_tilde, theta_tilde);
            let seam = if k == 0 || k == 32 {
                p.y = 0.0;
                p.x = if k == 0 {
                    theta_tilde.sin()
                } else {
                    -theta_tilde.sin()
                };
                out.push((p, -1.0));
                1.0
            } else {
                0.0
            };
            out.push((p, seam));
        }
    }
    out
}

/// Ground distance in metres between two map positions (Δφ, Δθ) relative to the same viewer.
fn ground_error_m(viewer: &Viewer, got: (f64, f64), want: (f64, f64)) -> f64 {
    let theta = viewer.theta_v + want.1;
    let dtheta = got.1 - want.1;
    // Compare absolute longitudes modulo 2π (across the antimeridian and the ±π seam).
    let phi_got = (viewer.phi_v + got.0).rem_euclid(TAU);
    let phi_want = (viewer.phi_v + want.0).rem_euclid(TAU);
    let mut dphi = (phi_got - phi_want).rem_euclid(TAU);
    if dphi > PI {
        dphi -= TAU;
    }
    EARTH_RADIUS_M * dtheta.hypot(dphi * theta.sin().abs())
}

#[test]
fn wgsl_map_transform_error_on_the_ground() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let device = &ctx.device;
    let source = format!("{}\n{KERNEL}", globe::render::shader::assemble(""));
    let pipeline = common::compute_pipeline(ctx, source, "map transform test");

    let m = 10.0 / EARTH_RADIUS_M;
    let viewers = [
        Viewer {
            name: "equator",
            theta_v: PI / 2.0,
            phi_v: 0.3,
        },
        Viewer {
            name: "45°N",
            theta_v: PI / 4.0,
            phi_v: 0.1859,
        },
        Viewer {
            name: "10 m from N pole",
            theta_v: m,
            phi_v: 1.0,
        },
        Viewer {
            name: "10 m from S pole",
            theta_v: PI - m,
            phi_v: -2.0,
        },
        Viewer {
            name: "N pole",
            theta_v: 0.0,
            phi_v: 0.0,
        },
        Viewer {
            name: "S pole",
            theta_v: PI,
            phi_v: 0.0,
        },
        Viewer {
            name: "antimeridian",
            theta_v: PI / 2.0,
            phi_v: PI - 1e-7,
        },
    ];
    let distances = [0.01, 0.1, 1.0, 10.0, 100.0, 1000.0];
    let cases = cases(&distances);
    let input: Vec<[f32; 4]> = cases
        .iter()
        .map(|(p, s)| [p.x as f32, p.y as f32, p.z as f32, *s])
        .collect();
    let input_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: None,
        contents: bytemuck::cast_slice(&input),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let size = (input.len() * 16) as u64;

    eprintln!(
        "{:<18} {:>14} {:>14} {:>14}",
        "viewer", "stable (GPU)", "direct (GPU)", "GPU vs Rust twin"
    );
    for viewer in &viewers {
        let uniforms = TransformUniformsF32::from_theta_v(viewer.theta_v, Stretch::Exact);
        let uniform_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: None,
            contents: bytemuck::bytes_of(&uniforms),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let output = common::output_buffer(ctx, size);
        let bytes = common::run_compute(
            ctx,
            &pipeline,
            &[&uniform_buf, &input_buf, &output],
            &output,
            (input.len() as u32).div_ceil(64),
        );
        let results: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&bytes);

        let (mut stable_max, mut direct_max, mut twin_max) = (0.0f64, 0.0f64, 0.0f64);
        for ((p, seam), r) in cases.iter().zip(&results) {
            let want = map_transform::exact_f64(viewer.theta_v, *p);
            let stable = ground_error_m(viewer, (r[2] as f64, r[3] as f64), want);
            let direct = ground_error_m(viewer, (r[0] as f64, r[1] as f64), want);
            let twin = map_transform::stable_f32(
                &uniforms,
                Vec3::new(p.x as f32, p.y as f32, p.z as f32),
                *seam,
            );
            let twin_err = ground_error_m(
                viewer,
                (r[2] as f64, r[3] as f64),
                (twin.0 as f64, twin.1 as f64),
            );
            assert!(
                stable.is_finite() && direct.is_finite(),
                "{}: non-finite result",
                viewer.name
            );
            assert!(
                stable <= 0.01,
                "{}: stable form off by {stable} m at p̃ = {p:?}",
                viewer.name
            );
            stable_max = stable_max.max(stable);
            direct_max = direct_max.max(direct);
            twin_max = twin_max.max(twin_err);
        }
        eprintln!(
            "{:<18} {:>12.2e} m {:>12.2e} m {:>12.2e} m",
            viewer.name, stable_max, direct_max, twin_max
        );
        // The Rust twin mirrors the WGSL: it must agree to well below the error budget.
        assert!(
            twin_max <= 0.005,
            "{}: GPU and Rust twin differ by {twin_max} m",
            viewer.name
        );
    }
}
