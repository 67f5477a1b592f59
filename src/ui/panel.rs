//! The egui side panel: what the renderer did this frame and why, the camera, and the settings.
//!
//! The panel only reads and edits typed values ([`Readout`], [`LiveSettings`], [`MeshDraft`]) and
//! returns [`PanelAction`]s; the window code (`app.rs`) applies them. No wgpu here.

use egui::{Color32, RichText};

use crate::clipmap::selection::LevelStatus;
use crate::clipmap::settings::level_outer_theta_rad;
use crate::clipmap::{ClipmapSettings, TransformForm};
use crate::geo::camera::Camera;
use crate::plan::HeightSource;
use crate::render::FrameInfo;
use crate::scenes::{CameraSpec, SCENES, Scene, VIEW_SYNTAX};

/// Sector counts offered in the panel.
pub const SECTOR_CHOICES: [u32; 5] = [4, 8, 16, 32, 64];
/// Values of n offered in the panel (those that are multiples of 2 · sectors).
pub const PHI_STEP_CANDIDATES: [u32; 12] =
    [64, 96, 128, 192, 256, 384, 512, 768, 1024, 1536, 2048, 4096];
/// Texture sizes offered in the panel (those within the device limit).
pub const TEXTURE_SIZE_CHOICES: [u32; 7] = [64, 128, 256, 512, 1024, 2048, 4096];
/// Largest m offered in the panel (the settings allow more, but 2·n·m triangles per level grows
/// quickly).
pub const MAX_RINGS_PER_LEVEL: u32 = 128;

/// Frame time, smoothed exponentially so the readout is legible.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameStats {
    /// Smoothed frame time in milliseconds (0 before the first frame).
    pub frame_ms: f64,
}

impl FrameStats {
    /// Weight of the newest frame in the average.
    const ALPHA: f64 = 0.1;

    pub fn record(&mut self, dt_s: f64) {
        if !(dt_s.is_finite() && dt_s > 0.0) {
            return;
        }
        let ms = dt_s * 1000.0;
        self.frame_ms = if self.frame_ms == 0.0 {
            ms
        } else {
            self.frame_ms + Self::ALPHA * (ms - self.frame_ms)
        };
    }

    pub fn fps(&self) -> f64 {
        if self.frame_ms > 0.0 {
            1000.0 / self.frame_ms
        } else {
            0.0
        }
    }
}

/// Mesh settings being edited; they take effect (a new renderer) only on Apply.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MeshDraft {
    /// n
    pub phi_steps: u32,
    /// m
    pub rings_per_level: u32,
    pub texture_size: u32,
    pub sectors: u32,
}

impl MeshDraft {
    pub fn from_settings(settings: &ClipmapSettings) -> Self {
        Self {
            phi_steps: settings.phi_steps,
            rings_per_level: settings.rings_per_level,
            texture_size: settings.texture_size,
            sectors: settings.sectors,
        }
    }

    /// `base` with this draft's mesh fields.
    pub fn apply_to(&self, base: &ClipmapSettings) -> ClipmapSettings {
        ClipmapSettings {
            phi_steps: self.phi_steps,
            rings_per_level: self.rings_per_level,
            texture_size: self.texture_size,
            sectors: self.sectors,
            ..base.clone()
        }
    }

    /// Sets the sector count and moves n to the nearest value still valid for it.
    pub fn set_sectors(&mut self, sectors: u32) {
        self.sectors = sectors.max(1);
        self.phi_steps = snap_phi_steps(self.phi_steps, self.sectors);
    }
}

/// The values of n the panel offers for `sectors`: the candidates that are multiples of
/// 2 · sectors, or the smallest such multiple if none is.
pub fn phi_step_choices(sectors: u32) -> Vec<u32> {
    let step = 2 * sectors.max(1);
    let choices: Vec<u32> = PHI_STEP_CANDIDATES
        .into_iter()
        .filter(|n| n.is_multiple_of(step))
        .collect();
    if choices.is_empty() {
        vec![step]
    } else {
        choices
    }
}

/// The offered value of n (for `sectors`) nearest to `n`.
pub fn snap_phi_steps(n: u32, sectors: u32) -> u32 {
    phi_step_choices(sectors)
        .into_iter()
        .min_by_key(|c| c.abs_diff(n))
        .unwrap_or(2 * sectors.max(1))
}

/// Settings that take effect on the next frame without rebuilding anything.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LiveSettings {
    pub transform: TransformForm,
    pub approx_start_level: u32,
    pub overlay_levels: bool,
    /// Every triangle's edges (`--overlay wireframe`).
    pub overlay_wireframe: bool,
    /// The LOD method near the ground (`--mode`).
    pub mode: crate::plan::LodMode,
    /// The detail editor's window is open (`ui::editor`).
    pub detail_editor: bool,
    /// The look's proto-textured surface types and its atmosphere (`look::LookSettings`).
    pub textures: bool,
    pub sky: bool,
    /// Where the sun stands (`--time`): fixed in every view's sky, or the real one at a UTC time.
    pub sun: crate::look::Sun,
    /// Clicks on the terrain add points to the measure tool.
    pub measure: bool,
}

/// The sun's controls: fixed, or at a UTC time chosen by day of the year and time of day.
fn sun_controls(ui: &mut egui::Ui, sun: &mut crate::look::Sun) {
    use crate::look::{Sun, Utc};
    let mut at_time = matches!(sun, Sun::At(_));
    ui.checkbox(&mut at_time, "sun at a time (UTC)")
        .on_hover_text(
            "the real sun at that moment (off: 35° above every view's south-east horizon)",
        );
    match (at_time, *sun) {
        (true, Sun::Fixed) => {
            let now = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_secs() as i64);
            *sun = Sun::At(Utc { unix_s: now });
        }
        (false, Sun::At(_)) => *sun = Sun::Fixed,
        (true, Sun::At(t)) => {
            let (year, mut day, seconds) = t.year_day();
            let mut hours = seconds as f64 / 3600.0;
            ui.add(egui::Slider::new(&mut day, 1..=366).text("day of the year"));
            ui.add(
                egui::Slider::new(&mut hours, 0.0..=23.99)
                    .step_by(1.0 / 60.0)
                    .text("hour (UTC)"),
            );
            *sun = Sun::At(Utc::from_year_day(
                year,
                day,
                (hours * 3600.0).round() as i64,
            ));
            if let Sun::At(t) = sun {
                ui.label(t.to_string());
            }
        }
        (false, Sun::Fixed) => {}
    }
}

/// What the panel shows this frame.
pub struct Readout<'a> {
    /// What lies under the cursor (None: the cursor is off the terrain's part of the window,
    /// or the first answer has not come yet).
    pub picked: Option<&'a crate::ui::pick::Picked>,
    /// The measure tool's points, totals and profile (None: not shown).
    pub measure: Option<&'a crate::ui::measure_tool::MeasureTool>,
    pub stats: &'a FrameStats,
    /// What the renderer decided for the last frame (None before the first frame).
    pub info: Option<&'a FrameInfo>,
    pub camera: &'a Camera,
    /// Terrain height under the camera.
    pub terrain_height_m: f64,
    /// The planet's radius R (a "go to" height must stay above −R).
    pub radius_m: f64,
    /// The settings of the renderer now in use.
    pub active: &'a ClipmapSettings,
    pub adapter: &'a str,
    /// Surface format and present mode, for the record.
    pub surface: &'a str,
    /// Largest texture side the device supports.
    pub max_texture_size: u32,
}

/// What the user asked for; the window code carries it out after the frame.
#[derive(Clone, Debug, PartialEq)]
pub enum PanelAction {
    /// Rebuild the renderer with these (validated) settings.
    ApplyMesh(ClipmapSettings),
    GoToScene(&'static Scene),
    /// Go to a view typed into the "go to" field.
    GoToView(CameraSpec),
    /// Fly the `flight` path (space → aircraft → ground) over 30 s.
    PlayFlight,
    /// Render the view offscreen, measure ρ per pixel on the CPU and lay the heat map over the
    /// view until the camera moves.
    MeasureError,
    Screenshot,
    /// Clear the measure tool's points.
    ClearMeasure,
}

/// The panel's own state between frames.
pub struct Panel {
    pub draft: MeshDraft,
    /// A line of feedback (an applied setting, an error).
    pub message: Option<String>,
    /// Path of the last screenshot.
    pub last_screenshot: Option<String>,
    /// Where the panel was drawn last frame, in points.
    pub rect: Option<egui::Rect>,
    /// The "go to" field's text: a view as `--camera` takes it.
    pub goto_text: String,
    /// Why the last "go to" text was refused, shown under the field until it is edited.
    pub goto_error: Option<String>,
}

impl Panel {
    pub fn new(settings: &ClipmapSettings) -> Self {
        Self {
            draft: MeshDraft::from_settings(settings),
            message: None,
            last_screenshot: None,
            rect: None,
            goto_text: String::new(),
            goto_error: None,
        }
    }

    /// Parses the "go to" text for a planet of radius `radius_m`: the action to go there, or
    /// None with the reason kept in [`Panel::goto_error`].
    pub fn submit_goto(&mut self, radius_m: f64) -> Option<PanelAction> {
        match CameraSpec::parse(&self.goto_text, radius_m) {
            Ok(view) => {
                self.goto_error = None;
                Some(PanelAction::GoToView(view))
            }
            Err(e) => {
                self.goto_error = Some(e.to_string());
                None
            }
        }
    }

    /// Draws the panel on the left of `ui` and returns what the user asked for.
    pub fn show(
        &mut self,
        ui: &mut egui::Ui,
        readout: &Readout<'_>,
        live: &mut LiveSettings,
    ) -> Vec<PanelAction> {
        let mut actions = Vec::new();
        let response = egui::Panel::left("globe panel")
            .resizable(true)
            .default_size(320.0)
            .show(ui, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| {
                    self.contents(ui, readout, live, &mut actions);
                });
            });
        self.rect = Some(response.response.rect);
        actions
    }

    /// Whether a pointer at `pos` (points) is egui's: over the panel, over a popup or tooltip,
    /// or egui is in the middle of a drag. Unlike `egui_wants_pointer_input`, which knows the
    /// pointer only as of the last frame, this uses the position now, so a quick move from the
    /// panel to the terrain followed by a click goes to the terrain.
    pub fn owns_pointer(&self, ctx: &egui::Context, pos: egui::Pos2) -> bool {
        let over_panel = self.rect.is_some_and(|r| r.contains(pos));
        let over_popup = ctx
            .layer_id_at(pos)
            .is_some_and(|layer| layer.order != egui::Order::Background);
        over_panel || over_popup || ctx.egui_is_using_pointer()
    }

    fn contents(
        &mut self,
        ui: &mut egui::Ui,
        readout: &Readout<'_>,
        live: &mut LiveSettings,
        actions: &mut Vec<PanelAction>,
    ) {
        ui.heading("globe");
        ui.small(readout.adapter);
        ui.small(readout.surface);
        ui.separator();

        frame_section(ui, readout);
        ui.separator();
        camera_section(ui, readout);
        ui.separator();
        measure_section(ui, readout, live, actions);
        ui.separator();

        ui.strong("Scenes");
        ui.horizontal_wrapped(|ui| {
            for scene in &SCENES {
                let hover = format!("{}: {}", scene.height_label(), scene.stresses);
                if ui.button(scene.name).on_hover_text(hover).clicked() {
                    actions.push(PanelAction::GoToScene(scene));
                }
            }
            if ui
                .button(crate::scenes::flight::NAME)
                .on_hover_text("fly from space down to the ground at Lake Garda (30 s; any scene button stops it)")
                .clicked()
            {
                actions.push(PanelAction::PlayFlight);
            }
        });
        self.goto_section(ui, readout, actions);
        ui.separator();

        ui.strong("Rendering");
        egui::ComboBox::from_label("map transform")
            .selected_text(live.transform.name())
            .show_ui(ui, |ui| {
                for form in TransformForm::ALL {
                    ui.selectable_value(&mut live.transform, form, form.name());
                }
            });
        ui.horizontal(|ui| {
            let last = readout.active.levels.saturating_sub(1);
            ui.add_enabled(
                live.transform == TransformForm::Approximate,
                egui::DragValue::new(&mut live.approx_start_level).range(0..=last),
            );
            ui.label("approximation from level");
        });
        ui.horizontal(|ui| {
            ui.checkbox(&mut live.overlay_levels, "levels")
                .on_hover_text("colour each clipmap level (geomipmapping patches by level)");
            ui.checkbox(&mut live.overlay_wireframe, "wireframe")
                .on_hover_text("every triangle's edges, for every LOD method");
        });
        ui.horizontal(|ui| {
            use crate::plan::LodMode;
            ui.label("near the ground");
            for (mode, name, tip) in [
                (LodMode::Clipmap, "clipmap", "the spherical clipmap alone"),
                (
                    LodMode::Geomip,
                    "geomip",
                    "geomipmapping with geomorphing around the viewer",
                ),
                (
                    LodMode::Projgrid,
                    "projgrid",
                    "the error-bounded projected grid, ray casting cells whose error exceeds γ",
                ),
                (
                    LodMode::Auto,
                    "auto",
                    "geomipmapping below 1 000 m above the terrain",
                ),
            ] {
                ui.radio_value(&mut live.mode, mode, name)
                    .on_hover_text(tip);
            }
        });
        ui.horizontal(|ui| {
            ui.checkbox(&mut live.textures, "surface types")
                .on_hover_text("proto-textured sand, grass, forest, rock, snow (off: the tint)");
            ui.checkbox(&mut live.sky, "atmosphere")
                .on_hover_text("sky, glow around the disk, haze (off: flat sky, raw colours)");
        });
        sun_controls(ui, &mut live.sun);
        ui.checkbox(&mut live.detail_editor, "detail editor")
            .on_hover_text("edit the procedural detail live: sliders, presets, load/save, paint");
        if ui
            .button("error overlay (ρ)")
            .on_hover_text(
                "measure the screen-space error of this view against the terrain function \
                 (CPU) and show it as a heat map until the camera moves: \
                 blue 0 px, yellow 1 px, red ≥ 4 px",
            )
            .clicked()
        {
            actions.push(PanelAction::MeasureError);
        }
        ui.separator();

        self.mesh_section(ui, readout, actions);
        ui.separator();

        ui.horizontal(|ui| {
            if ui.button("Screenshot").on_hover_text("F12 or P").clicked() {
                actions.push(PanelAction::Screenshot);
            }
        });
        if let Some(path) = &self.last_screenshot {
            ui.small(format!("saved {path}"));
        }
        if let Some(message) = &self.message {
            ui.label(RichText::new(message).color(Color32::from_rgb(230, 180, 80)));
        }
        ui.separator();
        ui.collapsing("Controls", |ui| {
            for line in CONTROLS_HELP {
                ui.small(*line);
            }
        });
    }

    /// The "go to" field: any view as `--camera` takes it; Enter or "Go" jumps there, "here"
    /// fills in the current view, a refused text shows why under the field.
    fn goto_section(
        &mut self,
        ui: &mut egui::Ui,
        readout: &Readout<'_>,
        actions: &mut Vec<PanelAction>,
    ) {
        ui.horizontal(|ui| {
            ui.label("go to").on_hover_text(format!(
                "{VIEW_SYNTAX}: degrees and metres, HEIGHT above the terrain \
                 (HEIGHT@sphere: above the sphere of radius R), as --camera takes it"
            ));
            let edit = ui.add(
                egui::TextEdit::singleline(&mut self.goto_text)
                    .hint_text("45.65,10.65,500,90,-10")
                    .desired_width(170.0),
            );
            if edit.changed() {
                self.goto_error = None;
            }
            let entered = edit.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
            if (ui.button("Go").clicked() || entered)
                && let Some(action) = self.submit_goto(readout.radius_m)
            {
                actions.push(action);
            }
            if ui
                .button("here")
                .on_hover_text("fill in the current view")
                .clicked()
            {
                self.goto_text = CameraSpec::from_camera(readout.camera).to_string();
                self.goto_error = None;
            }
        });
        if let Some(error) = &self.goto_error {
            ui.label(RichText::new(error).color(Color32::LIGHT_RED));
        }
    }

    fn mesh_section(
        &mut self,
        ui: &mut egui::Ui,
        readout: &Readout<'_>,
        actions: &mut Vec<PanelAction>,
    ) {
        ui.strong("Mesh");
        let draft = &mut self.draft;
        egui::Grid::new("mesh settings")
            .num_columns(2)
            .show(ui, |ui| {
                ui.label("sectors");
                let mut sectors = draft.sectors;
                egui::ComboBox::from_id_salt("sectors")
                    .selected_text(sectors.to_string())
                    .show_ui(ui, |ui| {
                        for s in SECTOR_CHOICES {
                            ui.selectable_value(&mut sectors, s, s.to_string());
                        }
                    });
                if sectors != draft.sectors {
                    draft.set_sectors(sectors);
                }
                ui.end_row();

                ui.label("n (φ̃ steps)");
                egui::ComboBox::from_id_salt("phi steps")
                    .selected_text(draft.phi_steps.to_string())
                    .show_ui(ui, |ui| {
                        for n in phi_step_choices(draft.sectors) {
                            ui.selectable_value(&mut draft.phi_steps, n, n.to_string());
                        }
                    });
                ui.end_row();

                ui.label("m (rings/level)");
                ui.add(
                    egui::DragValue::new(&mut draft.rings_per_level)
                        .range(1..=MAX_RINGS_PER_LEVEL)
                        .speed(0.2),
                );
                ui.end_row();

                ui.label("texture size");
                egui::ComboBox::from_id_salt("texture size")
                    .selected_text(draft.texture_size.to_string())
                    .show_ui(ui, |ui| {
                        for s in TEXTURE_SIZE_CHOICES {
                            if s <= readout.max_texture_size {
                                ui.selectable_value(&mut draft.texture_size, s, s.to_string());
                            }
                        }
                    });
                ui.end_row();
            });
        let settings = draft.apply_to(readout.active);
        // Heights (R32F), partial octaves and normals (RGBA16F each) per texel.
        let texture_mib = (settings.texture_size as f64).powi(2) * settings.levels as f64 * 20.0
            / (1024.0 * 1024.0);
        ui.small(format!(
            "{} triangles per level at full density, {:.0} MiB of level textures",
            group_digits(settings.triangles_per_level()),
            texture_mib
        ));
        let validity = settings.validate();
        if let Err(e) = &validity {
            ui.label(RichText::new(e.to_string()).color(Color32::LIGHT_RED));
        }
        let changed = settings != *readout.active;
        ui.horizontal(|ui| {
            if ui
                .add_enabled(changed && validity.is_ok(), egui::Button::new("Apply"))
                .clicked()
            {
                actions.push(PanelAction::ApplyMesh(settings.clone()));
            }
            if ui
                .add_enabled(changed, egui::Button::new("Revert"))
                .clicked()
            {
                self.draft = MeshDraft::from_settings(readout.active);
            }
        });
    }
}

/// Shown under "Controls".
pub const CONTROLS_HELP: &[&str] = &[
    "left drag: look around (heading, pitch)",
    "right drag / Shift + left drag: move over the ground",
    "wheel: zoom (height above terrain × 0.85 per notch)",
    "W/S: forward/back   A/D: left/right   Q/E: down/up",
    "arrows: turn and pitch   Shift: 5 × faster",
    "F12 / P: screenshot",
];

fn frame_section(ui: &mut egui::Ui, readout: &Readout<'_>) {
    let stats = readout.stats;
    ui.label(format!(
        "frame {:.2} ms   {:.1} FPS",
        stats.frame_ms,
        stats.fps()
    ));
    let Some(info) = readout.info else {
        ui.label("(no frame yet)");
        return;
    };
    let sel = &info.selection;
    ui.label(format!(
        "triangles drawn: {}",
        group_digits(info.triangles())
    ));
    ui.label(format!(
        "sectors drawn / culled: {} / {}",
        info.draw.sectors_drawn, info.draw.sectors_culled
    ));
    ui.label(format!(
        "levels drawn: {}..{} ({} of {})",
        sel.coarsest,
        sel.finest,
        sel.finest - sel.coarsest + 1,
        sel.status.len()
    ));
    ui.label(format!(
        "texels filled: {}   near: {}",
        group_digits(info.texels_filled),
        format_length_m(info.near_m)
    ));
    if let Some(st) = &info.stream {
        stream_section(ui, st, &sel.waiting());
    }
    egui::CollapsingHeader::new("levels: why each is drawn or not")
        .default_open(false)
        .show(ui, |ui| {
            ui.label(format!(
                "θ̃max = {} (horizon, with mountains)",
                format_deg(sel.theta_max_rad.to_degrees())
            ));
            ui.label(format!(
                "θ̃min = {} (one pixel below the viewer)",
                format_deg(sel.theta_min_rad.to_degrees())
            ));
            ui.small("level i covers θ̃ in (outer/2, outer]");
            egui::Grid::new("level table")
                .striped(true)
                .num_columns(4)
                .show(ui, |ui| {
                    ui.strong("level");
                    ui.strong("θ̃ outer");
                    ui.strong("θ̃ inner");
                    ui.strong("status");
                    ui.end_row();
                    for (level, status) in sel.status.iter().enumerate() {
                        let outer = level_outer_theta_rad(level as u32).to_degrees();
                        let colour = match status {
                            LevelStatus::Drawn => Color32::from_rgb(120, 210, 120),
                            LevelStatus::BeyondHorizon => Color32::GRAY,
                            LevelStatus::SubPixel => Color32::from_rgb(220, 160, 90),
                            LevelStatus::Waiting => Color32::from_rgb(230, 90, 90),
                            LevelStatus::OutOfView => Color32::from_rgb(150, 150, 200),
                        };
                        ui.label(level.to_string());
                        ui.label(format_deg(outer));
                        ui.label(format_deg(0.5 * outer));
                        ui.label(RichText::new(status.label()).color(colour));
                        ui.end_row();
                    }
                });
        });
}

/// The tile pipeline: what is queued, reading, cached and uploaded, and which levels wait.
fn stream_section(ui: &mut egui::Ui, st: &crate::render::dem_feed::FeedFrame, waiting: &[u32]) {
    let mb = |b: u64| b as f64 / (1 << 20) as f64;
    let s = &st.stream;
    ui.separator();
    ui.strong(if st.complete {
        "streaming: settled"
    } else {
        "streaming: loading"
    });
    ui.label(format!(
        "queued {}   in flight {}   missing {} of {} needed now",
        s.queued, s.in_flight, st.tiles_missing, st.tiles_needed
    ));
    ui.label(format!(
        "tiles requested {}  loaded {}  cancelled {}  failed {}  retries {}",
        s.tiles_requested, s.tiles_loaded, s.tiles_cancelled, s.tiles_failed, s.retries
    ));
    ui.label(format!(
        "cache {:.1} / {:.0} MB ({} tiles), hit rate {}",
        mb(st.cache_bytes),
        mb(st.cache_budget),
        st.cache_tiles,
        st.cache_hit_rate
            .map_or("–".to_string(), |r| format!("{:.1} %", 100.0 * r))
    ));
    ui.label(format!(
        "read {:.1} MB/s   GPU tiles {} / {}   uploads this frame {} (backlog {})",
        st.read_mb_per_s, st.gpu_tiles, st.gpu_capacity, st.uploads, st.upload_backlog
    ));
    if !waiting.is_empty() {
        ui.label(
            RichText::new(format!("levels waiting for data: {waiting:?}"))
                .color(Color32::from_rgb(230, 90, 90)),
        );
    }
    if let Some(change) = &st.file_change {
        ui.label(RichText::new(change.to_string()).color(Color32::from_rgb(230, 170, 60)));
    }
    if let Some(e) = &st.last_error {
        ui.label(RichText::new(format!("last error: {e}")).color(Color32::from_rgb(230, 90, 90)));
    }
}

fn camera_section(ui: &mut egui::Ui, readout: &Readout<'_>) {
    let c = readout.camera;
    ui.strong("Camera");
    egui::Grid::new("camera readout")
        .num_columns(2)
        .show(ui, |ui| {
            let mut row = |name: &str, value: String| {
                ui.label(name);
                ui.monospace(value);
                ui.end_row();
            };
            row("lat", format!("{:.6}°", c.lat_deg));
            row("lon", format!("{:.6}°", c.lon_deg));
            row("altitude", format_length_m(c.altitude_m));
            row(
                "above terrain",
                format_length_m(c.altitude_m - readout.terrain_height_m),
            );
            // Where the frame plan's ground height came from (a stand-in keeps it unsettled).
            let source = readout.info.map_or("", |i| match i.ground_source {
                HeightSource::Exact => " (exact)",
                HeightSource::Tiles => " (streamed tiles)",
                HeightSource::CoarserTiles => " (coarser tiles: finer ones on the way)",
            });
            row(
                "terrain",
                format!("{}{source}", format_length_m(readout.terrain_height_m)),
            );
            row("heading", format!("{:.2}°", c.heading_deg));
            row("pitch", format!("{:.2}°", c.pitch_deg));
            row("roll", format!("{:.2}°", c.roll_deg));
        });
    ui.strong("Under the cursor");
    egui::Grid::new("pick readout")
        .num_columns(2)
        .show(ui, |ui| {
            for (name, value) in pick_rows(readout.picked) {
                ui.label(name);
                ui.monospace(value);
                ui.end_row();
            }
        });
}

/// The measure tool: its switch, totals and the profile's plot.
fn measure_section(
    ui: &mut egui::Ui,
    readout: &Readout<'_>,
    live: &mut LiveSettings,
    actions: &mut Vec<PanelAction>,
) {
    ui.horizontal(|ui| {
        ui.checkbox(&mut live.measure, "measure")
            .on_hover_text("click points on the terrain: distances, height difference, area and the profile; Escape clears");
        if ui.button("clear").clicked() {
            actions.push(PanelAction::ClearMeasure);
        }
    });
    let Some(tool) = readout.measure else {
        return;
    };
    let rows = measure_rows(tool, readout.radius_m);
    egui::Grid::new("measure readout")
        .num_columns(2)
        .show(ui, |ui| {
            for (name, value) in rows {
                ui.label(name);
                ui.monospace(value);
                ui.end_row();
            }
        });
    profile_plot(ui, tool.profile());
}

/// The measure tool's rows: a hint before the first point, then the totals.
pub fn measure_rows(
    tool: &crate::ui::measure_tool::MeasureTool,
    radius_m: f64,
) -> Vec<(&'static str, String)> {
    let Some(t) = tool.totals(radius_m) else {
        return vec![("points", "none: click the terrain".to_string())];
    };
    let mut rows = vec![
        ("points", t.points.to_string()),
        ("great circle", format_length_m(t.great_circle_m)),
        ("along terrain", format_length_m(t.along_terrain_m)),
        ("height change", format_length_m(t.height_difference_m)),
    ];
    if let Some(a) = t.area_m2 {
        let text = if a >= 1e6 {
            format!("{:.3} km²", a / 1e6)
        } else {
            format!("{a:.1} m²")
        };
        rows.push(("area", text));
    }
    rows
}

/// The profile as a small plot: height against distance, the ground filled below.
fn profile_plot(ui: &mut egui::Ui, profile: &[crate::measure::ProfilePoint]) {
    if profile.len() < 2 {
        return;
    }
    let width = ui.available_width().max(100.0);
    let (rect, _) = ui.allocate_exact_size(egui::vec2(width, 110.0), egui::Sense::hover());
    let painter = ui.painter_at(rect);
    painter.rect_filled(rect, 2.0, Color32::from_gray(28));
    let (lo, hi) = profile
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.height_m), hi.max(p.height_m))
        });
    let span = (hi - lo).max(1.0);
    let length = profile
        .last()
        .map_or(1.0, |p| p.distance_m)
        .max(f64::MIN_POSITIVE);
    let inner = rect.shrink(6.0);
    let at = |p: &crate::measure::ProfilePoint| {
        egui::pos2(
            inner.left() + (p.distance_m / length) as f32 * inner.width(),
            inner.bottom() - ((p.height_m - lo) / span) as f32 * inner.height(),
        )
    };
    let line: Vec<egui::Pos2> = profile.iter().map(at).collect();
    painter.add(egui::Shape::line(
        line,
        egui::Stroke::new(1.5, Color32::from_rgb(214, 170, 110)),
    ));
    let small = egui::FontId::monospace(10.0);
    painter.text(
        inner.left_top(),
        egui::Align2::LEFT_TOP,
        format!("{hi:.0} m"),
        small.clone(),
        Color32::GRAY,
    );
    painter.text(
        inner.left_bottom(),
        egui::Align2::LEFT_BOTTOM,
        format!("{lo:.0} m"),
        small.clone(),
        Color32::GRAY,
    );
    painter.text(
        inner.right_bottom(),
        egui::Align2::RIGHT_BOTTOM,
        format_length_m(length),
        small,
        Color32::GRAY,
    );
}

/// The rows of the "under the cursor" section: the surface point the f64 ray caster finds
/// there (detail and water included), sky, or a dash while there is no answer.
pub fn pick_rows(picked: Option<&crate::ui::pick::Picked>) -> Vec<(&'static str, String)> {
    match picked.map(|p| p.hit) {
        None => vec![("point", "–".to_string())],
        Some(None) => vec![("point", "sky".to_string())],
        Some(Some((hit, _))) => vec![
            ("lat", format!("{:.6}°", hit.lat_deg)),
            ("lon", format!("{:.6}°", hit.lon_deg)),
            ("height", format_length_m(hit.height_m)),
            ("distance", format_length_m(hit.distance_m)),
        ],
    }
}

/// Metres, with kilometres beside them from 1 km up; millimetres stay visible near the ground.
pub fn format_length_m(m: f64) -> String {
    if !m.is_finite() {
        format!("{m} m")
    } else if m.abs() >= 1000.0 {
        format!("{:.1} m ({:.3} km)", m, m / 1000.0)
    } else {
        format!("{m:.3} m")
    }
}

/// Degrees, switching to scientific notation for the tiny angles of fine levels.
pub fn format_deg(deg: f64) -> String {
    if deg != 0.0 && deg.abs() < 0.01 {
        format!("{deg:.3e}°")
    } else {
        format!("{deg:.3}°")
    }
}

/// 1234567 → "1 234 567".
pub fn group_digits(value: u64) -> String {
    let digits = value.to_string();
    let mut out = String::with_capacity(digits.len() + digits.len() / 3);
    for (i, ch) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(' ');
        }
        out.push(ch);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn phi_step_choices_are_valid_for_every_sector_count() {
        for sectors in SECTOR_CHOICES {
            let choices = phi_step_choices(sectors);
            assert!(!choices.is_empty());
            for n in choices {
                let settings = ClipmapSettings {
                    phi_steps: n,
                    sectors,
                    ..Default::default()
                };
                assert!(settings.validate().is_ok(), "n {n} sectors {sectors}");
            }
        }
        assert_eq!(phi_step_choices(1000), vec![2000]);
    }

    #[test]
    fn changing_sectors_keeps_n_valid() {
        let mut draft = MeshDraft::from_settings(&ClipmapSettings::default());
        draft.phi_steps = 96;
        draft.set_sectors(64);
        assert_eq!(draft.phi_steps, 128);
        draft.set_sectors(4);
        assert_eq!(draft.phi_steps, 128);
        let settings = draft.apply_to(&ClipmapSettings::default());
        assert!(settings.validate().is_ok());
    }

    #[test]
    fn frame_stats_smooth() {
        let mut stats = FrameStats::default();
        assert_eq!(stats.fps(), 0.0);
        stats.record(0.010);
        assert!((stats.frame_ms - 10.0).abs() < 1e-9);
        for _ in 0..200 {
            stats.record(0.020);
        }
        assert!((stats.frame_ms - 20.0).abs() < 1e-3);
        assert!((stats.fps() - 50.0).abs() < 1e-2);
        stats.record(f64::NAN);
        assert!(stats.frame_ms.is_finite());
    }

    #[test]
    fn formatting() {
        assert_eq!(group_digits(0), "0");
        assert_eq!(group_digits(1234567), "1 234 567");
        assert_eq!(group_digits(123456), "123 456");
        assert_eq!(format_length_m(0.001), "0.001 m");
        assert_eq!(format_length_m(20_000_000.0), "20000000.0 m (20000.000 km)");
        assert_eq!(format_deg(45.0), "45.000°");
        assert_eq!(format_deg(1.5e-7), "1.500e-7°");
    }

    #[test]
    fn goto_field_parses_or_keeps_the_error() {
        let mut panel = Panel::new(&ClipmapSettings::default());
        let r = crate::geo::EARTH_RADIUS_M;
        for (text, error) in [
            ("91,0,10,0,0", "latitude 91° is outside [-90, 90]"),
            ("0,0,NaN,0,0", "height NaN is not a finite number"),
            ("0,0,-7000000@sphere,0,0", "height -7000000 m is below -R"),
            ("1,2,3", "'1,2,3' has 3 comma-separated fields"),
            ("0,x,10,0,0", "longitude 'x' is not a number"),
        ] {
            panel.goto_text = text.into();
            assert_eq!(panel.submit_goto(r), None, "{text}");
            let shown = panel.goto_error.clone().unwrap();
            assert!(shown.starts_with(error), "{text}: {shown}");
        }
        panel.goto_text = "45.65,10.65,500,90,-10".into();
        let Some(PanelAction::GoToView(view)) = panel.submit_goto(r) else {
            panic!("a valid view was refused: {:?}", panel.goto_error);
        };
        assert_eq!(panel.goto_error, None);
        assert_eq!(view, "45.65,10.65,500,90,-10".parse().unwrap());
        // The radius is the planet's.
        panel.goto_text = "0,0,-2000@sphere,0,0".into();
        assert!(panel.submit_goto(r).is_some());
        assert!(panel.submit_goto(1000.0).is_none());
    }

    /// The panel lays out without a window (egui runs headless) for every kind of readout.
    #[test]
    fn panel_lays_out_headless() {
        let settings = ClipmapSettings::default();
        let camera = SCENES[1].camera(|_, _| 0.0);
        let selection = crate::clipmap::selection::LevelSelection::new(settings.levels, 0.06, 1e-8);
        let info = FrameInfo {
            selection,
            densities: crate::clipmap::density::DensityPlan::full(settings.levels),
            draw: Default::default(),
            texels_filled: 0,
            near_m: 1.0,
            height_above_terrain_m: 10_000.0,
            ground_source: HeightSource::Tiles,
            sky_linear: [0.0; 3],
            sky_ring: None,
            shading: crate::render::terrain::Shading::ALL,
            stream: Some(Default::default()),
            planar: None,
        };
        let stats = FrameStats { frame_ms: 16.0 };
        let mut panel = Panel::new(&settings);
        let mut live = LiveSettings {
            transform: settings.transform,
            approx_start_level: settings.approx_start_level,
            overlay_levels: false,
            overlay_wireframe: false,
            mode: crate::plan::LodMode::Clipmap,
            detail_editor: true,
            textures: true,
            sky: true,
            sun: crate::look::Sun::At(crate::look::Utc::parse("2026-06-21T19:00Z").unwrap()),
            measure: true,
        };
        let ctx = egui::Context::default();
        let mut tool = crate::ui::measure_tool::MeasureTool::default();
        let flat = crate::measure::ConstantHeight {
            radius_m: crate::geo::EARTH_RADIUS_M,
            height_m: 10.0,
        };
        for lat in [1.0, 2.0, 2.5] {
            let (phi, theta) = crate::geo::sphere::phi_theta_from_lat_lon_deg(lat, lat * lat);
            tool.add(
                crate::ui::measure_tool::MeasuredPoint {
                    hit: crate::measure::ProbeHit {
                        lat_deg: lat,
                        lon_deg: lat * lat,
                        height_m: 10.0,
                        distance_m: 1.0,
                    },
                    world_m: crate::geo::sphere::ecef_m(phi, theta, 10.0, flat.radius_m),
                },
                &flat,
            );
        }
        assert_eq!(measure_rows(&tool, flat.radius_m).len(), 5);
        // The "go to" field's error line lays out too.
        panel.goto_text = "91,0,10,0,0".into();
        assert!(panel.submit_goto(crate::geo::EARTH_RADIUS_M).is_none());
        for info in [None, Some(&info)] {
            let readout = Readout {
                picked: None,
                measure: Some(&tool),
                stats: &stats,
                info,
                camera: &camera,
                terrain_height_m: 0.0,
                radius_m: crate::geo::EARTH_RADIUS_M,
                active: &settings,
                adapter: "test adapter",
                surface: "test surface",
                max_texture_size: 8192,
            };
            let input = egui::RawInput {
                screen_rect: Some(egui::Rect::from_min_size(
                    egui::Pos2::ZERO,
                    egui::vec2(1280.0, 800.0),
                )),
                ..Default::default()
            };
            let mut actions = Vec::new();
            let mut output = ctx.run_ui(input, |ui| {
                actions = panel.show(ui, &readout, &mut live);
            });
            output.textures_delta.clear();
            assert!(actions.is_empty());
            assert!(!output.shapes.is_empty());
        }
    }

    /// The cursor's rows say what the pick found: a dash before any answer, sky, or the point.
    #[test]
    fn the_cursor_rows_say_what_the_pick_found() {
        use crate::ui::pick::{PickRequest, Picked};
        let request = PickRequest {
            camera: crate::geo::camera::Camera {
                lat_deg: 0.0,
                lon_deg: 0.0,
                altitude_m: 10.0,
                heading_deg: 0.0,
                pitch_deg: -90.0,
                roll_deg: 0.0,
                fov_y_deg: 60.0,
            },
            width: 3,
            height: 3,
            x: 1,
            y: 1,
        };
        assert_eq!(pick_rows(None), vec![("point", "–".to_string())]);
        let sky = Picked { request, hit: None };
        assert_eq!(pick_rows(Some(&sky)), vec![("point", "sky".to_string())]);
        let hit = crate::measure::ProbeHit {
            lat_deg: 46.5,
            lon_deg: -7.25,
            height_m: 1234.5678,
            distance_m: 2.0,
        };
        let point = Picked {
            request,
            hit: Some((hit, glam::DVec3::X)),
        };
        let rows = pick_rows(Some(&point));
        assert_eq!(rows[0], ("lat", "46.500000°".to_string()));
        assert_eq!(rows[1], ("lon", "-7.250000°".to_string()));
        assert_eq!(rows[2], ("height", "1234.6 m (1.235 km)".to_string()));
        assert_eq!(rows[3], ("distance", "2.000 m".to_string()));
    }
}
