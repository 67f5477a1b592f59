use globe::clipmap::ClipmapSettings;
use globe::render::offscreen::OffscreenFrame;
use globe::render::{GpuContext, TerrainRenderer};
use globe::scenes::Scene;
use globe::terrain::AnalyticPlanet;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let scene = Scene::by_name(&args[1]).unwrap();
    let ctx = GpuContext::headless()?;
    eprintln!("{}", ctx.adapter_description());
    let mut settings = ClipmapSettings::default();
    if let Ok(m) = std::env::var("GLOBE_M") {
        settings.rings_per_level = m.parse()?;
    }
    if let Ok(m) = std::env::var("GLOBE_N") {
        settings.phi_steps = m.parse()?;
    }
    let mut r = TerrainRenderer::new(
        &ctx.device,
        settings,
        AnalyticPlanet::earth(),
        globe::render::offscreen::COLOR_FORMAT,
    )?;
    r.overlays.levels = args.get(3).is_some();
    let cam = scene.camera(|a, b| r.terrain_height_m(a, b));
    let target = OffscreenFrame::new(&ctx.device, 960, 540);
    let t = std::time::Instant::now();
    let f = target.render(&ctx, &mut r, &cam)?;
    eprintln!(
        "{:?} {:?} tris {} filled {}",
        t.elapsed(),
        f.info.selection.drawn_levels(),
        f.info.draw.triangles,
        f.info.texels_filled
    );
    f.save_png(std::path::Path::new(&args[2]))?;
    Ok(())
}
