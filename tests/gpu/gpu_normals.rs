//! The normal pass (`shaders/fill_normals.wgsl`) on the adapter against its f64 twin
//! `render::normals::texel_normal`, both fed the level's own heights and partial octaves as
//! the GPU holds them: every texel of every filled level whose stencil lies in the window,
//! including the pole rows and the rows next to a pole (north-pole scene), the antimeridian,
//! and the detail's partial octaves (ground). The same pass's boundary noise (issue 35: the
//! look's view-independent part per texel) against its f64 twin
//! `render::normals::texel_boundary_noise` over the same texels.

use crate::common;

use globe::clipmap::ClipmapSettings;
use globe::render::TerrainRenderer;
use globe::render::formats::COLOR_FORMAT;
use globe::render::normals::{texel_boundary_noise, texel_normal};
use globe::scenes::Scene;
use globe::terrain::Terrain;

#[test]
fn gpu_normals_match_the_f64_twin() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let terrain = Terrain::embedded_earth()
        .unwrap()
        .with_detail(Some(Default::default()));
    let settings = ClipmapSettings::default();
    let mut pole_rows = 0;
    for name in ["north-pole", "antimeridian", "ground"] {
        let scene = Scene::by_name(name).unwrap();
        let camera = scene.camera(|lat, lon| terrain.height_at_lat_lon_m(lat, lon));
        let mut r =
            TerrainRenderer::new(&ctx.device, settings.clone(), terrain.clone(), COLOR_FORMAT)
                .unwrap();
        let frame = common::render(ctx, &mut r, &camera, 320, 180);
        let sel = &frame.info.selection;
        let mut worst = (0.0f64, 0u32, 0i64, 0i64);
        let mut worst_noise = (0.0f64, 0u32, 0i64, 0i64);
        let mut checked = 0u64;
        let mut noise_range = (f64::INFINITY, f64::NEG_INFINITY);
        for level in sel.coarsest.saturating_sub(1)..=sel.finest {
            let (grid, heights) = r.read_level(ctx, level).unwrap().expect("filled level");
            let (_, _, partials) = r.read_level_partials(ctx, level).unwrap().unwrap();
            let (_, normals) = r.read_level_normals(ctx, level).unwrap().unwrap();
            let (_, noise) = r.read_level_boundary_noise(ctx, level).unwrap().unwrap();
            let count = terrain.detail().map_or(0, |d| {
                d.level_octaves(level, settings.blend_fraction as f64)
                    .partial
            });
            let s = grid.size as i64;
            let period = grid.period_x();
            // Heights relative to the texel's own (as the shader's differences are; the texture
            // holds h − grid.ref_m).
            let parts = |gx: i64, gy: i64| -> Option<(f64, f64)> {
                let i = (gx - grid.gx0).rem_euclid(period);
                let j = gy - grid.gy0;
                if i >= s || !(0..s).contains(&j) {
                    return None;
                }
                let k = (j * s + i) as usize;
                let p: f32 = partials[k][..count as usize].iter().sum();
                Some((heights[k] as f64, p as f64))
            };
            let south = (s << level) / 4;
            for j in 1..s - 1 {
                for i in 1..s - 1 {
                    let (gx, gy) = (grid.gx0 + i, grid.gy0 + j);
                    let (h0, p0) = parts(gx, gy).unwrap();
                    let height =
                        |x: i64, y: i64| parts(x, y).map_or(f64::NAN, |(h, p)| (h - h0) + (p - p0));
                    let radius = terrain.radius_m() + grid.ref_m + h0 + p0;
                    let want = texel_normal(&grid, gx, gy, radius, height);
                    if !want.is_finite() {
                        continue;
                    }
                    let h = grid.ref_m + h0 + p0;
                    let want_noise = texel_boundary_noise(&grid, gx, gy, terrain.radius_m(), h);
                    let got_noise = noise[(j * s + i) as usize];
                    for c in 0..2 {
                        let e = (f64::from(got_noise[c]) - want_noise[c]).abs();
                        if e > worst_noise.0 {
                            worst_noise = (e, level, gx, gy);
                        }
                    }
                    noise_range = (
                        noise_range.0.min(want_noise[0]),
                        noise_range.1.max(want_noise[0]),
                    );
                    let got = normals[(j * s + i) as usize];
                    let got = glam::DVec3::new(got[0] as f64, got[1] as f64, got[2] as f64);
                    let err = got.angle_between(want);
                    assert!(err.is_finite(), "{name} level {level} ({gx},{gy}): {got}");
                    if err > worst.0 {
                        worst = (err, level, gx, gy);
                    }
                    checked += 1;
                    if gy == 0 || gy == south {
                        pole_rows += 1;
                    }
                }
            }
        }
        println!(
            "{name}: {checked} texels, worst {:.2e} rad at level {} ({}, {})",
            worst.0, worst.1, worst.2, worst.3
        );
        println!(
            "{name}: boundary noise worst {:.4} at level {} ({}, {}), na/2 + 1/2 over {:.3}..{:.3}",
            worst_noise.0,
            worst_noise.1,
            worst_noise.2,
            worst_noise.3,
            noise_range.0,
            noise_range.1
        );
        assert!(checked > 100_000, "{name}: only {checked} texels checked");
        // The noise is not constant (the twin is not trivially met by a flat texture)…
        assert!(
            noise_range.1 - noise_range.0 > 0.2,
            "{name}: the boundary noise barely varies ({noise_range:?})"
        );
        // …and the GPU's 8 bits hold it: half a step of rounding plus the f32 position.
        assert!(
            worst_noise.0 < 2.5 / 255.0,
            "{name}: GPU boundary noise off the twin by {:.4} at level {} ({}, {})",
            worst_noise.0,
            worst_noise.1,
            worst_noise.2,
            worst_noise.3
        );
        // RGBA16F: 2^−11 per component.
        assert!(
            worst.0 < 2e-3,
            "{name}: GPU normal off the twin by {:.2e} rad at level {} ({}, {})",
            worst.0,
            worst.1,
            worst.2,
            worst.3
        );
    }
    assert!(pole_rows > 100, "only {pole_rows} pole-row texels checked");
}
