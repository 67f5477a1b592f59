//! The DEM's streaming path: tiles from the pyramid through the tokio streamer, the LRU and
//! the GPU tile cache into the level textures (issue 4).

mod common;

use globe::clipmap::ClipmapSettings;
use globe::render::TerrainRenderer;
use globe::render::fill::band_limit_texel_m;
use globe::render::offscreen::COLOR_FORMAT;
use globe::render::upload::grid_point_phi_theta;
use globe::scenes::Scene;
use globe::terrain::Terrain;

/// The GPU fill from streamed tiles equals the CPU's f64 sampling of the same pyramid level
/// (the terrain function's twin) at every texel of every filled level.
#[test]
fn gpu_fill_from_tiles_matches_the_cpu_sampler() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let terrain = Terrain::embedded_earth().unwrap();
    let Terrain::Dem(dem) = terrain.clone() else {
        unreachable!()
    };
    for name in ["aircraft", "north-pole", "antimeridian"] {
        let scene = Scene::by_name(name).unwrap();
        let camera = scene.camera(|lat, lon| terrain.height_at_lat_lon_m(lat, lon));
        let mut r = TerrainRenderer::new(
            &ctx.device,
            ClipmapSettings::default(),
            terrain.clone(),
            COLOR_FORMAT,
        )
        .unwrap();
        let frame = common::render(ctx, &mut r, &camera, 320, 180);
        let sel = &frame.info.selection;
        let mut worst = (0.0f64, 0u32);
        for level in sel.coarsest.saturating_sub(1)..=sel.finest {
            let (grid, heights) = r.read_level(ctx, level).unwrap().expect("filled level");
            let pl = dem.level_for_texel(band_limit_texel_m(&grid, dem.radius_m()));
            let s = grid.size as i64;
            for j in (0..s).step_by(7) {
                for i in (0..s).step_by(5) {
                    let (phi, theta) = grid_point_phi_theta(&grid, grid.gx0 + i, grid.gy0 + j);
                    let want = dem.height_band_limited_m(phi, theta, pl);
                    let got = heights[(j * s + i) as usize] as f64;
                    let err = (got - want).abs();
                    if err > worst.0 {
                        worst = (err, level);
                    }
                }
            }
        }
        eprintln!(
            "{name}: levels {}..={}, worst |GPU − CPU| {:.4} m (level {})",
            sel.coarsest, sel.finest, worst.0, worst.1
        );
        assert!(worst.0 < 0.05, "{name}: fill differs by {} m", worst.0);
    }
}
