//! `globe report`: every method and setting over the named scenes, measured the same way —
//! triangles, CPU and GPU time, and the per-pixel error ρ against the terrain function with
//! coverage against the reference ray caster — written as `report.csv`, `report.json` (the
//! same rows and names; NaN or infinite figures as `null`), `report.md` (tables in the shape of
//! the error-bounded paper's Tables 1–2) and `error_vs_time.png` / `.svg` (one panel per scene,
//! one point per setting, the Pareto front drawn).

use std::fmt::Write as _;
use std::path::Path;

use serde::Serialize;

use crate::clipmap::{ClipmapSettings, TransformForm};
use crate::instruments::bench::{BenchError, summary};
use crate::instruments::plot::{self, Panel, PlotSpec, Point, pareto_front};
use crate::look::LookSettings;
use crate::measure::{self, ErrorStats, PixelSet, RayCaster, ReferenceImage};
use crate::plan::{LodMode, LodSettings};
use crate::render::formats::COLOR_FORMAT;
use crate::render::offscreen::{OffscreenFrame, SETTLE_TIMEOUT};
use crate::render::timing::GpuTimer;
use crate::render::{GpuContext, RenderError, TerrainRenderer};
use crate::scenes::{self, CAMERA_VIEW_NAME, CameraSpec};
use crate::stream::StreamSettings;
use crate::terrain::Terrain;

/// What one setting changes from the base settings: typed, so that nothing is parsed back
/// from its label (`n=256`), which exists for output only.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Change {
    /// The base settings as given.
    Default,
    /// Mesh resolution n: steps per ring.
    PhiSteps(u32),
    /// Mesh resolution m: rings per level.
    RingsPerLevel(u32),
    /// Texels per side of each level's height texture.
    TextureSize(u32),
    /// Another map-transform form.
    Transform(TransformForm),
    /// The level overlay drawn (to show what an overlay costs).
    OverlayLevels,
    /// The one error knob at this many hundredths of a pixel (`--error-budget`: vertex
    /// spacing, texture size and mesh resolution together).
    ErrorBudget(u32),
    /// Another LOD method near the ground (`--mode`).
    Lod(LodMode),
    /// The projected grid of this size, uniform or warped, with or without ray casting (the
    /// error-bounded paper's Tables 1–2, `--projgrid-tables`).
    ProjGrid {
        cols: u32,
        rows: u32,
        warp: bool,
        ray_cast: bool,
    },
}

impl Change {
    /// The settings this change makes of `base`.
    pub fn apply(self, base: &ClipmapSettings) -> ClipmapSettings {
        let mut s = base.clone();
        match self {
            Change::Default | Change::OverlayLevels | Change::Lod(_) | Change::ProjGrid { .. } => {}
            Change::PhiSteps(n) => s.phi_steps = n,
            Change::RingsPerLevel(m) => s.rings_per_level = m,
            Change::TextureSize(t) => s.texture_size = t,
            Change::Transform(form) => s.transform = form,
            Change::ErrorBudget(centi) => {
                if let Ok(b) = ClipmapSettings::for_error_budget(centi as f32 / 100.0) {
                    s.phi_steps = b.phi_steps;
                    s.rings_per_level = b.rings_per_level;
                    s.texture_size = b.texture_size;
                    s.target_spacing_px = b.target_spacing_px;
                }
            }
        }
        s
    }

    pub fn overlay_levels(self) -> bool {
        self == Change::OverlayLevels
    }

    /// The kind of change, for the plot's legend.
    pub fn group(self) -> &'static str {
        match self {
            Change::Default => "default",
            Change::PhiSteps(_) => "mesh n (steps per ring)",
            Change::RingsPerLevel(_) => "mesh m (rings)",
            Change::TextureSize(_) => "texture size",
            Change::Transform(_) => "map transform",
            Change::OverlayLevels => "overlay on",
            Change::ErrorBudget(_) => "error budget",
            Change::Lod(_) => "LOD method",
            Change::ProjGrid { warp: false, .. } => "uniform projected grid",
            Change::ProjGrid { warp: true, .. } => "warped projected grid",
        }
    }

    /// The LOD methods this change draws with, from the run's.
    pub fn lod(self, base: LodSettings) -> LodSettings {
        match self {
            Change::Lod(mode) => LodSettings { mode, ..base },
            Change::ProjGrid {
                cols,
                rows,
                warp,
                ray_cast,
            } => LodSettings {
                mode: LodMode::Projgrid,
                projgrid: crate::planar::projgrid::ProjGridSettings {
                    cols,
                    rows,
                    warp,
                    ray_cast,
                    ..base.projgrid
                },
                ..base
            },
            _ => base,
        }
    }
}

/// The label of the tables, the CSV and the plot: `default`, `n=256`, `transform=direct`…
impl std::fmt::Display for Change {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Change::Default => write!(f, "default"),
            Change::PhiSteps(n) => write!(f, "n={n}"),
            Change::RingsPerLevel(m) => write!(f, "m={m}"),
            Change::TextureSize(t) => write!(f, "texture={t}"),
            Change::Transform(form) => write!(f, "transform={}", form.name()),
            Change::OverlayLevels => write!(f, "overlay=levels"),
            Change::ErrorBudget(centi) => write!(f, "budget={}", *centi as f32 / 100.0),
            Change::Lod(mode) => write!(f, "mode={}", mode.name()),
            Change::ProjGrid {
                cols,
                rows,
                warp,
                ray_cast,
            } => write!(
                f,
                "grid={cols}x{rows} {} {}",
                if *warp { "warped" } else { "uniform" },
                if *ray_cast { "ray-cast" } else { "mesh" }
            ),
        }
    }
}

/// One method or setting: the change and the clipmap settings it makes.
#[derive(Clone, Debug)]
pub struct Setting {
    pub change: Change,
    pub settings: ClipmapSettings,
}

/// The settings the report runs: the defaults, then one parameter changed at a time (mesh
/// resolution n and m, texture size, each map-transform form), the level overlay on (to
/// show what an overlay costs; every other row has overlays off), and the error budget swept
/// over 0.5–8 px, geomipmapping near the viewer and the projected grid. Changes that make invalid settings are
/// left out.
pub fn settings_grid(base: &ClipmapSettings) -> Vec<Setting> {
    let mut changes = vec![Change::Default];
    changes.extend([256, 1024].map(Change::PhiSteps));
    changes.extend([16, 64].map(Change::RingsPerLevel));
    changes.extend([256, 1024].map(Change::TextureSize));
    changes.extend(
        (TransformForm::ALL.into_iter())
            .filter(|&form| form != base.transform)
            .map(Change::Transform),
    );
    changes.push(Change::OverlayLevels);
    // The knob's sweep: error against time as a curve (the default budget is the base row).
    changes.extend([50, 100, 400, 800].map(Change::ErrorBudget));
    // The close-up methods against the clipmap alone (docs/close-up.md#close-up-modes).
    changes.push(Change::Lod(LodMode::Geomip));
    changes.push(Change::Lod(LodMode::Projgrid));
    (changes.into_iter())
        .map(|change| Setting {
            change,
            settings: change.apply(base),
        })
        .filter(|s| s.settings.validate().is_ok())
        .collect()
}

/// The error-bounded paper's grid sizes (Tables 1–2).
pub const PAPER_GRIDS: [(u32, u32); 5] =
    [(1024, 512), (512, 256), (600, 600), (300, 900), (400, 1900)];

/// The rows of `--projgrid-tables`: the clipmap as the base row, then every paper grid size
/// uniform and warped, first without ray casting (Table 1), then with it (Table 2, the costly
/// half on a CPU rasteriser, last so an interrupted run keeps the whole of Table 1).
pub fn projgrid_grid(base: &ClipmapSettings) -> Vec<Setting> {
    let mut changes = vec![Change::Default];
    for ray_cast in [false, true] {
        for warp in [false, true] {
            for (cols, rows) in PAPER_GRIDS {
                changes.push(Change::ProjGrid {
                    cols,
                    rows,
                    warp,
                    ray_cast,
                });
            }
        }
    }
    (changes.into_iter())
        .map(|change| Setting {
            change,
            settings: change.apply(base),
        })
        .collect()
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
    /// What of the look is drawn in every row.
    pub look: LookSettings,
    /// The LOD methods every row starts from.
    pub lod: crate::plan::LodSettings,
    /// The reference is cast at pixels whose x and y are multiples of this (1: every pixel;
    /// the error statistics then cover that sample at the full resolution's footprint).
    pub every: u32,
    /// Run the projected grid's tables ([`projgrid_grid`]) instead of the settings grid.
    pub projgrid_tables: bool,
}

/// One row: a scene under one setting.
#[derive(Clone, Debug)]
pub struct Row {
    pub scene: String,
    pub setting: Change,
    pub triangles: u64,
    pub levels_drawn: u32,
    pub cpu_ms: f64,
    pub frame_ms: f64,
    pub gpu_ms: Option<f64>,
    pub error: ErrorStats,
    /// The projected grid's cells whose a-priori ρ exceeds γ, and all its cells.
    pub grid_cells: Option<(usize, usize)>,
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

/// One step of [`run`], for a progress display: `index` of `total` steps (a reference ray cast
/// per view, then one per setting), about to start.
#[derive(Clone, Debug, PartialEq)]
pub struct Step {
    pub index: usize,
    pub total: usize,
    pub message: String,
    /// Within a reference ray cast: (pixels cast, pixels), told again as it goes.
    pub pixels: Option<(usize, usize)>,
}

/// Runs every setting over every view. `progress` is told of each step before it starts.
pub fn run(
    ctx: &GpuContext,
    terrain: &Terrain,
    options: &ReportOptions,
    progress: impl FnMut(&Step),
) -> Result<Vec<Row>, BenchError> {
    run_within(ctx, terrain, options, None, progress, |_| {})
}

/// [`run`], each view's reference ray cast within `measure_limit` (None: none; past it,
/// [`crate::measure::MeasureError::TimedOut`]) and its progress told as [`Step::pixels`].
/// `rows_so_far` sees the rows after each one is measured, so a long run (the projected
/// grid's tables take an hour on a CPU rasteriser) can keep its files current.
pub fn run_within(
    ctx: &GpuContext,
    terrain: &Terrain,
    options: &ReportOptions,
    measure_limit: Option<std::time::Duration>,
    mut progress: impl FnMut(&Step),
    mut rows_so_far: impl FnMut(&[Row]),
) -> Result<Vec<Row>, BenchError> {
    let grid = if options.projgrid_tables {
        projgrid_grid(&options.base)
    } else {
        settings_grid(&options.base)
    };
    let views = views(options)?;
    let total = views.len() * (1 + grid.len());
    let mut index: usize = 0;
    let mut step = |message: String, pixels: Option<(usize, usize)>| {
        let within = pixels.is_some();
        progress(&Step {
            index: if within {
                index.saturating_sub(1)
            } else {
                index
            },
            total,
            message,
            pixels,
        });
        if !within {
            index += 1;
        }
    };
    let timer = GpuTimer::new(ctx);
    let target = OffscreenFrame::new(&ctx.device, options.width, options.height);
    let mut rows = Vec::new();
    for (si, (name, view)) in views.iter().enumerate() {
        let camera = view.camera(|lat, lon| terrain.height_at_lat_lon_m(lat, lon));
        let message = format!(
            "[{}/{}] {name}: reference ray cast at {}×{}",
            si + 1,
            views.len(),
            options.width,
            options.height
        );
        step(message.clone(), None);
        let reference: ReferenceImage =
            RayCaster::new(terrain, &camera, options.width, options.height).cast_within(
                &PixelSet::Every(options.every.max(1)),
                measure_limit,
                |done, all| step(message.clone(), Some((done, all))),
            )?;
        for (k, setting) in grid.iter().enumerate() {
            step(
                format!(
                    "[{}/{}] {name}: setting {}/{} {}",
                    si + 1,
                    views.len(),
                    k + 1,
                    grid.len(),
                    setting.change
                ),
                None,
            );
            let mut r = TerrainRenderer::with_streaming(
                &ctx.device,
                setting.settings.clone(),
                terrain.clone(),
                COLOR_FORMAT,
                options.stream,
            )?;
            r.overlays.levels = setting.change.overlay_levels();
            r.set_look(&ctx.device, options.look);
            r.set_lod(&ctx.device, setting.change.lod(options.lod));
            r.settle_or_explain(ctx, &camera, options.width, options.height, SETTLE_TIMEOUT)?;
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
                setting: setting.change,
                triangles: info.triangles(),
                levels_drawn: info.selection.finest - info.selection.coarsest + 1,
                cpu_ms: med(&|f| Some(f.cpu_ms)).unwrap_or(f64::NAN),
                frame_ms: med(&|f| Some(f.frame_ms)).unwrap_or(f64::NAN),
                gpu_ms: med(&|f| f.gpu_ms),
                error,
                grid_cells: info.planar.as_ref().and_then(|p| p.grid.as_ref()).map(|g| {
                    let s = setting.change.lod(options.lod).projgrid;
                    (g.cells_above_gamma, (s.cols * s.rows) as usize)
                }),
            });
            rows_so_far(&rows);
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

/// The plot's points of one scene's rows: time against p99 ρ, labelled and grouped by setting.
fn points(rows: &[&Row]) -> Vec<Point> {
    (rows.iter())
        .map(|r| Point {
            label: r.setting.to_string(),
            group: r.setting.group().to_string(),
            x: r.time_ms(),
            y: r.error.p99_px,
        })
        .collect()
}

/// Settings not dominated in (time, p99 ρ) within one scene, sorted by time
/// ([`pareto_front`]).
pub fn pareto(rows: &[&Row]) -> Vec<Change> {
    (pareto_front(&points(rows)).into_iter())
        .map(|i| rows[i].setting)
        .collect()
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
        "- ρ = λ·δ/distance per rendered pixel against the terrain function (error-bounded paper eq. 2–3, docs/design.md#measuring); \
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
            (pareto(&in_scene).iter())
                .map(Change::to_string)
                .collect::<Vec<_>>()
                .join(" → ")
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
            .find(|r| r.scene == scene && r.setting == Change::Default)
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

/// The error-bounded paper's Tables 1 (uniform grid) and 2 (non-uniform) in their shape: per
/// grid size, frame time, error pixels %, mean and max ρ, without and with ray casting.
pub fn projgrid_tables(
    rows: &[Row],
    adapter: &str,
    terrain: &str,
    options: &ReportOptions,
) -> String {
    let mut md = String::new();
    let _ = writeln!(
        md,
        "# The error-bounded projected grid: Tables 1–2
"
    );
    let _ = writeln!(md, "- adapter: {adapter}");
    let _ = writeln!(md, "- terrain: {terrain}");
    let _ = writeln!(
        md,
        "- {}×{}, γ = {} px; GPU ms: the terrain pass (timestamp queries), CPU ms: the frame's plan (the grid, its warp and error buffer in f64); medians of {} frames",
        options.width, options.height, options.lod.projgrid.gamma_px, options.frames
    );
    let _ = writeln!(
        md,
        "- ρ per pixel against the reference ray caster; error px = share of pixels with ρ > {} px; cells > γ = share of cells whose a-priori bound (eq. 3) exceeds γ (ray cast when on)
",
        measure::DEFAULT_THRESHOLD_PX
    );
    let mut scenes: Vec<&str> = Vec::new();
    for r in rows {
        if !scenes.contains(&r.scene.as_str()) {
            scenes.push(&r.scene);
        }
    }
    let cell = |r: Option<&Row>, f: &dyn Fn(&Row) -> String| r.map_or("–".into(), f);
    for scene in scenes {
        let find = |change: Change| {
            rows.iter()
                .find(|r| r.scene == scene && r.setting == change)
        };
        if let Some(c) = find(Change::Default) {
            let _ = writeln!(
                md,
                "## {scene}

The clipmap at the same view: {} triangles, GPU {} ms, error px {:.2} %, mean {:.3} px, max {:.3} px.
",
                c.triangles,
                c.gpu_ms.map_or("–".into(), |g| format!("{g:.1}")),
                100.0 * c.error.error_pixel_share,
                c.error.mean_px,
                c.error.max_px
            );
        }
        for (table, warp) in [
            ("Table 1: uniform grid", false),
            ("Table 2: non-uniform (warped) grid", true),
        ] {
            let _ = writeln!(
                md,
                "### {table}
"
            );
            let _ = writeln!(
                md,
                "| grid | triangles | CPU ms | GPU ms | error px % | mean ρ | max ρ | cells > γ % | ray cast: GPU ms | error px % | mean ρ | max ρ | mismatch px |"
            );
            let _ = writeln!(
                md,
                "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"
            );
            for (cols, grid_rows) in PAPER_GRIDS {
                let at = |ray_cast| {
                    find(Change::ProjGrid {
                        cols,
                        rows: grid_rows,
                        warp,
                        ray_cast,
                    })
                };
                let (m, rc) = (at(false), at(true));
                let gpu = |r: &Row| r.gpu_ms.map_or("–".into(), |g| format!("{g:.1}"));
                let _ = writeln!(
                    md,
                    "| {cols}×{grid_rows} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                    cell(m, &|r| r.triangles.to_string()),
                    cell(m, &|r| format!("{:.0}", r.cpu_ms)),
                    cell(m, &gpu),
                    cell(m, &|r| format!("{:.2}", 100.0 * r.error.error_pixel_share)),
                    cell(m, &|r| format!("{:.3}", r.error.mean_px)),
                    cell(m, &|r| format!("{:.2}", r.error.max_px)),
                    cell(m, &|r| r.grid_cells.map_or("–".into(), |(a, n)| format!(
                        "{:.1}",
                        100.0 * a as f64 / n.max(1) as f64
                    ))),
                    cell(rc, &gpu),
                    cell(rc, &|r| format!("{:.2}", 100.0 * r.error.error_pixel_share)),
                    cell(rc, &|r| format!("{:.3}", r.error.mean_px)),
                    cell(rc, &|r| format!("{:.2}", r.error.max_px)),
                    cell(rc, &|r| r.mismatch_px().to_string()),
                );
            }
            let _ = writeln!(md);
        }
    }
    let _ = writeln!(
        md,
        "The paper (1024×800): non-uniform 512×256 gave mean 1.40 px, max 6.9 px, 12.1 % error pixels without ray casting.\n"
    );
    md
}

/// Size of one panel of `error_vs_time.png` in pixels; panels stack downwards.
pub const PLOT_PANEL_PX: (u32, u32) = (1100, 620);

/// The panels of `error_vs_time`: one per scene (p99 ρ against time, log–log).
pub fn plot_panels(rows: &[Row], adapter: &str) -> Vec<Panel> {
    let mut scenes: Vec<&str> = Vec::new();
    for r in rows {
        if !scenes.contains(&r.scene.as_str()) {
            scenes.push(&r.scene);
        }
    }
    let gpu = rows.iter().all(|r| r.gpu_ms.is_some());
    (scenes.iter())
        .map(|scene| {
            let in_scene: Vec<&Row> = rows.iter().filter(|r| r.scene == *scene).collect();
            Panel {
                spec: PlotSpec {
                    title: format!("{scene}: p99 error against time, {adapter}"),
                    x_label: if gpu {
                        "GPU time of the terrain pass (ms)".into()
                    } else {
                        "frame time (ms)".into()
                    },
                    y_label: "p99 error ρ (px)".into(),
                    log_x: true,
                    log_y: true,
                },
                points: points(&in_scene),
            }
        })
        .collect()
}

/// One row of `report.json`: the CSV's columns under the CSV's names.
#[derive(Clone, Debug, Serialize)]
pub struct JsonRow {
    pub scene: String,
    pub setting: String,
    pub triangles: u64,
    pub levels_drawn: u32,
    pub cpu_ms: f64,
    pub frame_ms: f64,
    pub gpu_ms: Option<f64>,
    pub mean_px: f64,
    pub p99_px: f64,
    pub max_px: f64,
    pub error_pixels_pct: f64,
    pub mismatch_px: usize,
    pub pixels_measured: usize,
}

impl From<&Row> for JsonRow {
    fn from(r: &Row) -> Self {
        JsonRow {
            scene: r.scene.clone(),
            setting: r.setting.to_string(),
            triangles: r.triangles,
            levels_drawn: r.levels_drawn,
            cpu_ms: r.cpu_ms,
            frame_ms: r.frame_ms,
            gpu_ms: r.gpu_ms,
            mean_px: r.error.mean_px,
            p99_px: r.error.p99_px,
            max_px: r.error.max_px,
            error_pixels_pct: 100.0 * r.error.error_pixel_share,
            mismatch_px: r.mismatch_px(),
            pixels_measured: r.error.pixels_measured,
        }
    }
}

/// `report.json`: an array of [`JsonRow`]s. A NaN or infinite figure (a median of no frames)
/// is written as `null`, as a missing one (`gpu_ms` without timestamp queries) is.
pub fn json(rows: &[Row]) -> String {
    let rows: Vec<JsonRow> = rows.iter().map(JsonRow::from).collect();
    serde_json::to_string_pretty(&rows).expect("rows of numbers and strings serialise")
}

/// Writes `report.csv`, `report.json`, `report.md`, `error_vs_time.png` and
/// `error_vs_time.svg` into `dir` (created if missing).
pub fn write(
    dir: &Path,
    rows: &[Row],
    adapter: &str,
    terrain: &str,
    options: &ReportOptions,
) -> Result<(), ReportError> {
    write_text(dir, rows, adapter, terrain, options)?;
    let short = adapter.split(" (").next().unwrap_or(adapter);
    let (w, h) = PLOT_PANEL_PX;
    plot::write_figure(
        &dir.join("error_vs_time.png"),
        &dir.join("error_vs_time.svg"),
        &plot_panels(rows, short),
        w,
        h,
    )?;
    Ok(())
}

/// The text files of [`write`] alone (no figure): cheap enough to rewrite after every row.
pub fn write_text(
    dir: &Path,
    rows: &[Row],
    adapter: &str,
    terrain: &str,
    options: &ReportOptions,
) -> Result<(), ReportError> {
    let io = |path: std::path::PathBuf| move |source| ReportError::Write { path, source };
    std::fs::create_dir_all(dir).map_err(io(dir.to_path_buf()))?;
    let text_files = [
        ("report.csv", csv(rows)),
        ("report.json", json(rows)),
        ("report.md", markdown(rows, adapter, terrain, options)),
    ];
    for (name, text) in text_files {
        let path = dir.join(name);
        std::fs::write(&path, text).map_err(io(path))?;
    }
    if options.projgrid_tables {
        let path = dir.join("projgrid_tables.md");
        std::fs::write(&path, projgrid_tables(rows, adapter, terrain, options))
            .map_err(io(path))?;
    }
    Ok(())
}

/// Errors writing the report's files.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    #[error("cannot write {path}: {source}")]
    Write {
        path: std::path::PathBuf,
        source: std::io::Error,
    },
    #[error(transparent)]
    Plot(#[from] measure::MeasureError),
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(scene: &str, setting: Change, time_ms: f64, p99_px: f64) -> Row {
        Row {
            scene: scene.into(),
            setting,
            triangles: 1000,
            levels_drawn: 9,
            cpu_ms: 0.5,
            frame_ms: time_ms,
            gpu_ms: None,
            grid_cells: None,
            error: ErrorStats {
                pixels_measured: 100,
                mean_px: p99_px / 3.0,
                p99_px,
                max_px: 2.0 * p99_px,
                threshold_px: 1.0,
                error_pixels: 1,
                error_pixel_share: 0.01,
                coverage: None,
            },
        }
    }

    #[test]
    fn settings_are_typed_and_labelled_for_output_only() {
        let base = ClipmapSettings::default();
        let grid = settings_grid(&base);
        let labels: Vec<String> = grid.iter().map(|s| s.change.to_string()).collect();
        assert_eq!(labels[0], "default");
        for want in [
            "n=256",
            "m=64",
            "texture=1024",
            "transform=direct",
            "overlay=levels",
        ] {
            assert!(
                labels.iter().any(|l| l == want),
                "{want} missing: {labels:?}"
            );
        }
        for s in &grid {
            assert_eq!(s.settings, s.change.apply(&base));
            assert!(s.settings.validate().is_ok());
            assert_eq!(s.change.overlay_levels(), s.change == Change::OverlayLevels);
        }
        let n = grid
            .iter()
            .find(|s| s.change == Change::PhiSteps(256))
            .unwrap();
        assert_eq!(n.settings.phi_steps, 256);
        assert_eq!(n.settings.rings_per_level, base.rings_per_level);
        // The base form is not repeated as a change.
        assert!(
            !grid
                .iter()
                .any(|s| s.change == Change::Transform(base.transform))
        );
    }

    /// A NaN figure (a median of no frames) and an infinite one give valid JSON, as null.
    #[test]
    fn json_writes_nan_and_infinity_as_null() {
        let mut a = row("ground", Change::Default, 4.0, 0.5);
        a.cpu_ms = f64::NAN;
        a.error.max_px = f64::INFINITY;
        let b = row("ground", Change::PhiSteps(256), 3.0, 1.5);
        let text = json(&[a, b]);
        let v: serde_json::Value = serde_json::from_str(&text).expect("valid JSON");
        let rows = v.as_array().unwrap();
        assert_eq!(rows.len(), 2);
        assert!(rows[0]["cpu_ms"].is_null() && rows[0]["max_px"].is_null());
        assert!(rows[0]["gpu_ms"].is_null());
        assert_eq!(rows[0]["setting"], "default");
        assert_eq!(rows[1]["setting"], "n=256");
        assert_eq!(rows[1]["p99_px"], 1.5);
        assert_eq!(rows[1]["error_pixels_pct"], 1.0);
        // The JSON has the CSV's columns, by the same names.
        let header = csv(&[]);
        let mut columns: Vec<&str> = header.trim().split(',').collect();
        let mut keys: Vec<&str> = rows[1]
            .as_object()
            .unwrap()
            .keys()
            .map(|k| k.as_str())
            .collect();
        columns.sort();
        keys.sort();
        assert_eq!(keys, columns);
    }

    #[test]
    fn pareto_names_the_settings_nothing_beats() {
        let rows = [
            row("space", Change::Default, 4.0, 0.5),
            row("space", Change::PhiSteps(256), 3.0, 1.5),
            row("space", Change::PhiSteps(1024), 9.0, 0.6),
            row("space", Change::OverlayLevels, 5.0, 0.5),
        ];
        let refs: Vec<&Row> = rows.iter().collect();
        assert_eq!(pareto(&refs), [Change::PhiSteps(256), Change::Default]);
    }

    /// The report's figure from synthetic rows of two scenes: one panel each, PNG and SVG.
    #[test]
    fn writes_the_figure_for_two_scenes() {
        let mut rows = Vec::new();
        for (scene, scale) in [("space", 1.0), ("ground", 3.0)] {
            for (k, s) in settings_grid(&ClipmapSettings::default())
                .iter()
                .enumerate()
            {
                let t = scale * (2.0 + k as f64 * 0.7);
                rows.push(row(
                    scene,
                    s.change,
                    t,
                    2.5 / (1.0 + k as f64 * 0.4) / scale,
                ));
            }
        }
        let panels = plot_panels(&rows, "test adapter");
        assert_eq!(panels.len(), 2);
        assert_eq!(panels[0].points.len(), rows.len() / 2);
        let dir = tempfile::tempdir().unwrap();
        let (png, svg) = (dir.path().join("e.png"), dir.path().join("e.svg"));
        let (w, h) = PLOT_PANEL_PX;
        plot::write_figure(&png, &svg, &panels, w, h).unwrap();
        let img = image::open(&png).unwrap();
        assert_eq!((img.width(), img.height()), (w, 2 * h));
        assert!(
            std::fs::read_to_string(&svg)
                .unwrap()
                .contains("transform=direct")
        );
        if let Ok(keep) = std::env::var("GLOBE_PLOT_EXAMPLE") {
            std::fs::copy(&png, format!("{keep}-report.png")).unwrap();
        }
    }
}
