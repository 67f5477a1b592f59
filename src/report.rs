//! `globe report`: every method and setting over the named scenes, measured the same way —
//! triangles, CPU and GPU time, and the per-pixel error ρ against the terrain function with
//! coverage against the reference ray caster — written as `report.csv`, `report.md` (tables
//! in the shape of the error-bounded paper's Tables 1–2) and `error_vs_time.png` (one panel
//! per scene, one point per setting, the Pareto front drawn).

use std::fmt::Write as _;
use std::path::Path;

use crate::bench::{BenchError, summary};
use crate::clipmap::{ClipmapSettings, TransformForm};
use crate::measure::{self, ErrorStats, PixelSet, RayCaster, ReferenceImage};
use crate::render::offscreen::{COLOR_FORMAT, OffscreenFrame, SETTLE_TIMEOUT};
use crate::render::timing::GpuTimer;
use crate::render::{GpuContext, RenderError, TerrainRenderer};
use crate::scenes::{self, CAMERA_VIEW_NAME, CameraSpec};
use crate::stream::StreamSettings;
use crate::terrain::Terrain;

/// One method or setting: clipmap settings plus the overlays drawn.
#[derive(Clone, Debug)]
pub struct Setting {
    pub name: String,
    pub settings: ClipmapSettings,
    pub overlay_levels: bool,
}

/// The settings the report runs: the defaults, then one parameter changed at a time (mesh
/// resolution n and m, texture size, each map-transform form), and the level overlay on (to
/// show what an overlay costs; every other row has overlays off).
pub fn settings_grid(base: &ClipmapSettings) -> Vec<Setting> {
    let with = |name: String, f: &dyn Fn(&mut ClipmapSettings)| {
        let mut s = base.clone();
        f(&mut s);
        Setting {
            name,
            settings: s,
            overlay_levels: false,
        }
    };
    let mut v = vec![with("default".into(), &|_| {})];
    for n in [256, 1024] {
        v.push(with(format!("n={n}"), &|s| s.phi_steps = n));
    }
    for m in [16, 64] {
        v.push(with(format!("m={m}"), &|s| s.rings_per_level = m));
    }
    for t in [256, 1024] {
        v.push(with(format!("texture={t}"), &|s| s.texture_size = t));
    }
    for form in TransformForm::ALL {
        if form != base.transform {
            v.push(with(format!("transform={}", form.name()), &|s| {
                s.transform = form
            }));
        }
    }
    let mut overlay = with("overlay=levels".into(), &|_| {});
    overlay.overlay_levels = true;
    v.push(overlay);
    v.retain(|s| s.settings.validate().is_ok());
    v
}

#[derive(Clone, Debug)]
pub struct ReportOptions {
    /// Named scenes, run in this order.
    pub scenes: Vec<String>,
    /// A view given as such (`--camera`), run after the scenes as [`CAMERA_VIEW_NAME`].
    pub camera: Option<CameraSpec>,
    pub width: u32,
    pub height: u32,
    /// Timed frames per setting (after two warm-up frames); medians are reported.
    pub frames: usize,
    pub base: ClipmapSettings,
    pub stream: StreamSettings,
}

/// One row: a scene under one setting.
#[derive(Clone, Debug)]
pub struct Row {
    pub scene: String,
    pub setting: String,
    pub triangles: u64,
    pub levels_drawn: u32,
    pub cpu_ms: f64,
    pub frame_ms: f64,
    pub gpu_ms: Option<f64>,
    pub error: ErrorStats,
}

impl Row {
    /// The time axis of the plot: GPU time where measured, else the frame's wall time.
    pub fn time_ms(&self) -> f64 {
        self.gpu_ms.unwrap_or(self.frame_ms)
    }

    pub fn mismatch_px(&self) -> usize {
        self.error.coverage.map_or(0, |c| c.mismatched())
    }
}

/// The views the report runs, with their names: the scenes, then the `--camera` view.
pub fn views(options: &ReportOptions) -> Result<Vec<(String, CameraSpec)>, scenes::UnknownScene> {
    let mut views = Vec::new();
    for name in &options.scenes {
        views.push((name.clone(), scenes::find(name)?.view()));
    }
    if let Some(view) = options.camera {
        views.push((CAMERA_VIEW_NAME.to_owned(), view));
    }
    Ok(views)
}

/// Runs every setting over every view. `progress` gets a line per step.
pub fn run(
    ctx: &GpuContext,
    terrain: &Terrain,
    options: &ReportOptions,
    mut progress: impl FnMut(&str),
) -> Result<Vec<Row>, BenchError> {
    let grid = settings_grid(&options.base);
    let views = views(options)?;
    let timer = GpuTimer::new(ctx);
    let target = OffscreenFrame::new(&ctx.device, options.width, options.height);
    let mut rows = Vec::new();
    for (si, (name, view)) in views.iter().enumerate() {
        let camera = view.camera(|lat, lon| terrain.height_at_lat_lon_m(lat, lon));
        progress(&format!(
            "[{}/{}] {name}: reference ray cast at {}×{}…",
            si + 1,
            views.len(),
            options.width,
            options.height
        ));
        let reference: ReferenceImage =
            RayCaster::new(terrain, &camera, options.width, options.height).cast(&PixelSet::All);
        for (k, setting) in grid.iter().enumerate() {
            progress(&format!(
                "[{}/{}] {name}: setting {}/{} {}",
                si + 1,
                views.len(),
                k + 1,
                grid.len(),
                setting.name
            ));
            let mut r = TerrainRenderer::with_streaming(
                &ctx.device,
                setting.settings.clone(),
                terrain.clone(),
                COLOR_FORMAT,
                options.stream,
            )?;
            r.overlays.levels = setting.overlay_levels;
            r.settle(ctx, &camera, options.width, options.height, SETTLE_TIMEOUT);
            let mut timed = Vec::new();
            for i in 0..options.frames + 2 {
                let f = target.draw_timed(ctx, &mut r, &camera, timer.as_ref())?;
                if i >= 2 {
                    timed.push(f);
                }
            }
            // The error is measured with overlays off (an overlay recolours, not reshapes).
            r.overlays.levels = false;
            let frame = target.render(ctx, &mut r, &camera)?;
            let error = measure::measure_frame(
                &frame,
                &camera,
                terrain,
                Some(&reference),
                measure::DEFAULT_THRESHOLD_PX,
            )
            .map_err(|e| RenderError::Readback(e.to_string()))?;
            let med = |f: &dyn Fn(&crate::render::offscreen::TimedFrame) -> Option<f64>| {
                summary(&timed.iter().filter_map(f).collect::<Vec<_>>()).map(|s| s.0)
            };
            let info = &timed.last().expect("timed frames").info;
            rows.push(Row {
                scene: name.clone(),
                setting: setting.name.clone(),
                triangles: info.draw.triangles,
                levels_drawn: info.selection.finest - info.selection.coarsest + 1,
                cpu_ms: med(&|f| Some(f.cpu_ms)).unwrap_or(f64::NAN),
                frame_ms: med(&|f| Some(f.frame_ms)).unwrap_or(f64::NAN),
                gpu_ms: med(&|f| f.gpu_ms),
                error,
            });
        }
    }
    Ok(rows)
}

/// The CSV: one row per scene × setting.
pub fn csv(rows: &[Row]) -> String {
    let mut out = String::from(
        "scene,setting,triangles,levels_drawn,cpu_ms,frame_ms,gpu_ms,mean_px,p99_px,max_px,\
         error_pixels_pct,mismatch_px,pixels_measured\n",
    );
    for r in rows {
        let _ = writeln!(
            out,
            "{},{},{},{},{:.4},{:.4},{},{:.5},{:.5},{:.5},{:.5},{},{}",
            r.scene,
            r.setting,
            r.triangles,
            r.levels_drawn,
            r.cpu_ms,
            r.frame_ms,
            r.gpu_ms.map_or(String::new(), |g| format!("{g:.4}")),
            r.error.mean_px,
            r.error.p99_px,
            r.error.max_px,
            100.0 * r.error.error_pixel_share,
            r.mismatch_px(),
            r.error.pixels_measured
        );
    }
    out
}

/// Settings not dominated in (time, p99 ρ) within one scene, sorted by time.
pub fn pareto(rows: &[&Row]) -> Vec<String> {
    let mut front: Vec<&Row> = rows
        .iter()
        .copied()
        .filter(|a| {
            !rows.iter().any(|b| {
                b.time_ms() <= a.time_ms()
                    && b.error.p99_px <= a.error.p99_px
                    && (b.time_ms() < a.time_ms() || b.error.p99_px < a.error.p99_px)
            })
        })
        .collect();
    front.sort_by(|a, b| a.time_ms().total_cmp(&b.time_ms()));
    front.iter().map(|r| r.setting.clone()).collect()
}

/// Triangles the spherical-clipmaps paper draws in its scenes (its Table 1).
pub const PAPER_TRIANGLES: [(&str, u64); 3] = [
    ("space", 1_300_000),
    ("aircraft", 2_300_000),
    ("ground", 5_200_000),
];

/// The Markdown report.
pub fn markdown(rows: &[Row], adapter: &str, terrain: &str, options: &ReportOptions) -> String {
    let mut md = String::new();
    let _ = writeln!(md, "# globe report\n");
    let _ = writeln!(md, "- adapter: {adapter}");
    let _ = writeln!(md, "- terrain: {terrain}");
    if let Some(view) = &options.camera {
        let _ = writeln!(md, "- view `{CAMERA_VIEW_NAME}`: `--camera {view}`");
    }
    let _ = writeln!(
        md,
        "- {}×{}, {} timed frames per setting after 2 warm-up frames (medians); streaming settled first",
        options.width, options.height, options.frames
    );
    let _ = writeln!(
        md,
        "- ρ = λ·δ/distance per rendered pixel against the terrain function (error-bounded paper eq. 2–3, DESIGN.md); \
         error px = share of pixels with ρ > {} px; mismatch = pixels where terrain/sky differs from the reference ray caster",
        measure::DEFAULT_THRESHOLD_PX
    );
    let _ = writeln!(
        md,
        "- GPU ms: the terrain pass from timestamp queries (empty without them). On a software adapter compare ratios within a table, not absolute times.\n"
    );
    let mut scenes: Vec<&str> = Vec::new();
    for r in rows {
        if !scenes.contains(&r.scene.as_str()) {
            scenes.push(&r.scene);
        }
    }
    for scene in &scenes {
        let in_scene: Vec<&Row> = rows.iter().filter(|r| r.scene == *scene).collect();
        let _ = writeln!(md, "## {scene}\n");
        let _ = writeln!(
            md,
            "| setting | triangles | levels | CPU ms | GPU ms | mean ρ px | p99 ρ px | max ρ px | error px % | mismatch px |"
        );
        let _ = writeln!(
            md,
            "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"
        );
        for r in &in_scene {
            let _ = writeln!(
                md,
                "| {} | {} | {} | {:.2} | {} | {:.3} | {:.3} | {:.3} | {:.3} | {} |",
                r.setting,
                r.triangles,
                r.levels_drawn,
                r.cpu_ms,
                r.gpu_ms.map_or("–".to_string(), |g| format!("{g:.2}")),
                r.error.mean_px,
                r.error.p99_px,
                r.error.max_px,
                100.0 * r.error.error_pixel_share,
                r.mismatch_px()
            );
        }
        let _ = writeln!(
            md,
            "\nPareto front (time against p99 ρ): {}\n",
            pareto(&in_scene).join(" → ")
        );
    }
    let _ = writeln!(md, "## Triangles against the spherical-clipmaps paper\n");
    let _ = writeln!(
        md,
        "| scene | paper's triangles | ours (default) | our mean / p99 / max ρ px |"
    );
    let _ = writeln!(md, "| --- | ---: | ---: | --- |");
    for (scene, paper) in PAPER_TRIANGLES {
        if let Some(r) = rows
            .iter()
            .find(|r| r.scene == scene && r.setting == "default")
        {
            let _ = writeln!(
                md,
                "| {scene} | {paper} | {} | {:.3} / {:.3} / {:.3} |",
                r.triangles, r.error.mean_px, r.error.p99_px, r.error.max_px
            );
        }
    }
    let _ = writeln!(
        md,
        "\nThe error-bounded paper's non-uniform grid reached 1.4 px mean and 6.7 px max, its uniform grid 1.6 px and 14.9 px.\n"
    );
    md
}

/// The kind of a setting, for the plot's legend (`n=256` → "mesh n").
fn group_of(setting: &str) -> String {
    match setting.split('=').next().unwrap_or(setting) {
        "n" => "mesh n (steps per ring)".into(),
        "m" => "mesh m (rings)".into(),
        "texture" => "texture size".into(),
        "transform" => "map transform".into(),
        "overlay" => "overlay on".into(),
        other => other.into(),
    }
}

/// `error_vs_time.png`: one panel per scene (p99 ρ against time, log–log), stacked.
pub fn plot(rows: &[Row], adapter: &str) -> image::RgbImage {
    use crate::measure::plot::{PlotSpec, Point, render_plot};
    let mut scenes: Vec<&str> = Vec::new();
    for r in rows {
        if !scenes.contains(&r.scene.as_str()) {
            scenes.push(&r.scene);
        }
    }
    let (w, h) = (1100u32, 620u32);
    let mut out =
        image::RgbImage::from_pixel(w, h * scenes.len().max(1) as u32, image::Rgb([255; 3]));
    let gpu = rows.iter().all(|r| r.gpu_ms.is_some());
    for (i, scene) in scenes.iter().enumerate() {
        let points: Vec<Point> = rows
            .iter()
            .filter(|r| r.scene == *scene)
            .map(|r| Point {
                label: r.setting.clone(),
                group: group_of(&r.setting),
                x: r.time_ms(),
                y: r.error.p99_px,
            })
            .collect();
        let spec = PlotSpec {
            title: format!("{scene}: p99 error against time, {adapter}"),
            x_label: if gpu {
                "GPU time of the terrain pass (ms)".into()
            } else {
                "frame time (ms)".into()
            },
            y_label: "p99 error ρ (px)".into(),
            log_x: true,
            log_y: true,
            width: w,
            height: h,
        };
        let panel = render_plot(&spec, &points);
        image::imageops::replace(&mut out, &panel, 0, i as i64 * h as i64);
    }
    out
}

/// Writes `report.csv`, `report.md` and `error_vs_time.png` into `dir` (created if missing).
pub fn write(
    dir: &Path,
    rows: &[Row],
    adapter: &str,
    terrain: &str,
    options: &ReportOptions,
) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    std::fs::write(dir.join("report.csv"), csv(rows))?;
    std::fs::write(
        dir.join("report.md"),
        markdown(rows, adapter, terrain, options),
    )?;
    let short = adapter.split(" (").next().unwrap_or(adapter);
    plot(rows, short)
        .save(dir.join("error_vs_time.png"))
        .map_err(std::io::Error::other)?;
    Ok(())
}
