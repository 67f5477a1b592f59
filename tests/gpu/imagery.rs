//! The draped imagery (issue 36): the normal pass's per-texel imagery
//! (`shaders/fill_normals.wgsl` `texel_imagery`) against its f64 twin
//! `render::imagery::texel_imagery` over every texel of every filled level (pole rows and the
//! antimeridian included, fine levels at the image's own pixels and coarse ones on its
//! mipmaps), and what it does to the image: the Sahara sand-coloured from orbit, where the
//! surface types' rule alone paints it green.

use std::sync::Arc;

use crate::common;

use globe::clipmap::ClipmapSettings;
use globe::imagery::{ImagerySource, encode};
use globe::render::TerrainRenderer;
use globe::render::formats::COLOR_FORMAT;
use globe::render::imagery::texel_imagery;
use globe::scenes::{CameraSpec, Scene};
use globe::terrain::Terrain;

fn earth_with_imagery() -> Terrain {
    let imagery = ImagerySource::Embedded.open().unwrap().map(Arc::new);
    Terrain::embedded_earth()
        .unwrap()
        .with_water_level(Some(0.0))
        .with_imagery(imagery)
}

#[test]
fn level_imagery_matches_the_f64_twin() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let terrain = earth_with_imagery();
    let settings = ClipmapSettings::default();
    for name in ["north-pole", "antimeridian", "space"] {
        let scene = Scene::by_name(name).unwrap();
        let camera = scene.camera(|lat, lon| terrain.height_at_lat_lon_m(lat, lon));
        let mut r =
            TerrainRenderer::new(&ctx.device, settings.clone(), terrain.clone(), COLOR_FORMAT)
                .unwrap();
        let frame = common::render(ctx, &mut r, &camera, 320, 180);
        let sel = &frame.info.selection;
        let geometry = *r.imagery().geometry().expect("imagery uploaded");
        let mips = r.imagery().mips().to_vec();
        let (mut worst, mut checked) = ((0u8, 0u32, 0i64, 0i64), 0u64);
        for level in sel.coarsest.saturating_sub(1)..=sel.finest {
            let (grid, texels) = r.read_level_imagery(ctx, level).unwrap().expect("filled");
            let s = grid.size as i64;
            for j in 0..s {
                for i in 0..s {
                    let (gx, gy) = (grid.gx0 + i, grid.gy0 + j);
                    let want = encode(texel_imagery(
                        &geometry,
                        &mips,
                        gx,
                        gy,
                        grid.dphi_rad,
                        grid.dtheta_rad,
                    ));
                    let got = texels[(j * s + i) as usize];
                    for c in 0..4 {
                        let e = want[c].abs_diff(got[c]);
                        if e > worst.0 {
                            worst = (e, level, gx, gy);
                        }
                    }
                    checked += 1;
                }
            }
        }
        eprintln!("{name}: {checked} texels, worst {worst:?} (8-bit steps)");
        assert!(checked > 10_000, "{name}: only {checked} texels checked");
        // The GPU's bilinear and mip weights carry 8 bits of fraction: a few steps where
        // neighbouring pixels differ most (coastlines).
        assert!(
            worst.0 <= 4,
            "{name}: level {} texel ({}, {}) off by {} steps",
            worst.1,
            worst.2,
            worst.3,
            worst.0
        );
    }
}

/// Mean sRGB colour of the frame's centre quarter.
fn centre_mean(frame: &globe::render::offscreen::RenderedFrame) -> [f64; 3] {
    let (w, h) = (frame.width as usize, frame.height as usize);
    let mut acc = [0.0; 3];
    let mut n = 0.0;
    for y in h * 3 / 8..h * 5 / 8 {
        for x in w * 3 / 8..w * 5 / 8 {
            let k = (y * w + x) * 4;
            for (a, v) in acc.iter_mut().zip(&frame.rgba[k..k + 3]) {
                *a += *v as f64;
            }
            n += 1.0;
        }
    }
    acc.map(|v| v / n)
}

#[test]
fn the_sahara_is_sand_coloured_from_orbit() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let with = earth_with_imagery();
    let without = with.clone().with_imagery(None);
    let view: CameraSpec = "23,10,8000000,0,-90".parse().unwrap();
    let mut means = Vec::new();
    for terrain in [with, without] {
        let camera = view.camera(|lat, lon| terrain.height_at_lat_lon_m(lat, lon));
        let mut r = TerrainRenderer::new(
            &ctx.device,
            ClipmapSettings::default(),
            terrain,
            COLOR_FORMAT,
        )
        .unwrap();
        means.push(centre_mean(&common::render(ctx, &mut r, &camera, 320, 180)));
    }
    let [r, g, b] = means[0];
    eprintln!(
        "Sahara from 8 000 km: with imagery {:?}, without {:?}",
        means[0], means[1]
    );
    // Through the haze from 8 000 km (which pales everything): still red over green over blue.
    assert!(
        r > g && g > b && r - b > 15.0,
        "with imagery not sand: {:?}",
        means[0]
    );
    assert!(
        means[1][1] >= means[1][0],
        "without imagery expected green: {:?}",
        means[1]
    );
}
