//! The window: winit's `ApplicationHandler`, the frame loop (clock, camera, terrain, panel,
//! present: each its own step of [`App::redraw`]), the panel's actions and the routing of input
//! to the panel or the camera. The surface and the encoding live in `gpu.rs`.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Instant, SystemTime, UNIX_EPOCH};

use winit::application::ApplicationHandler;
use winit::dpi::PhysicalPosition;
use winit::error::EventLoopError;
use winit::event::{ElementState, KeyEvent, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop, OwnedDisplayHandle};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::WindowId;

use crate::geo::camera::Camera;
use crate::geo::sphere;
use crate::render::formats;
use crate::render::offscreen::OffscreenFrame;
use crate::render::{FrameInfo, RenderError};
use crate::scenes::CameraSpec;
use crate::terrain::Terrain;

use super::controls;
use super::editor::{Editor, EditorView};
use super::fly_to::{FlyTo, closer_look};
use super::gpu::{Acquired, Gpu};
use super::input::{Drag, Input};
use super::measure_tool::{MeasureTool, MeasuredPoint};
use super::panel::{FrameStats, LiveSettings, MeshDraft, Panel, PanelAction, Readout};
use super::pick::{PickRequest, Picker};
use super::{UiError, ViewerOptions};
use crate::scenes::path::{CameraPath, Recorder};

/// Environment variable of the smoke check: screenshot after this many frames, then quit.
pub const SMOKE_FRAMES_ENV: &str = "GLOBE_VIEWER_SMOKE_FRAMES";
/// Smoke check: half way through, load this detail preset through the editor (the live path:
/// one rebuild, the levels refill).
pub const SMOKE_PRESET_ENV: &str = "GLOBE_VIEWER_SMOKE_PRESET";
/// Opens the detail editor's window at start (any value).
pub const EDITOR_ENV: &str = "GLOBE_VIEWER_EDITOR";

/// Runs the viewer; `smoke_frames` (from [`SMOKE_FRAMES_ENV`] when None) ends it after a
/// screenshot.
pub(super) fn run(options: ViewerOptions, smoke_frames: Option<u64>) -> Result<(), UiError> {
    let smoke_frames = smoke_frames.or_else(|| {
        std::env::var(SMOKE_FRAMES_ENV)
            .ok()
            .and_then(|v| v.trim().parse().ok())
    });
    let event_loop = create_event_loop()?;
    let mut app = App::new(options, event_loop.owned_display_handle(), smoke_frames);
    let result = event_loop.run_app(&mut app);
    // Release the GPU objects before the event loop (and its X connection) goes away.
    app.gpu = None;
    if let Some(error) = app.error.take() {
        return Err(error);
    }
    result.map_err(|e| UiError::Window(e.to_string()))
}

/// Opens the X11 event loop, mapping every way of not having a display to `NoDisplay`.
fn create_event_loop() -> Result<EventLoop<()>, UiError> {
    use winit::platform::x11::EventLoopBuilderExtX11;
    // winit returns errors for a missing or unreachable X server; the unwind guard is only a
    // second line of defence so the viewer never takes the process down for want of a display.
    let built = std::panic::catch_unwind(|| {
        EventLoop::builder()
            .with_x11()
            // Tests run the viewer off the main thread; X11 has no main-thread requirement.
            .with_any_thread(true)
            .build()
    });
    match built {
        Ok(Ok(event_loop)) => Ok(event_loop),
        Ok(Err(e @ (EventLoopError::Os(_) | EventLoopError::NotSupported(_)))) => {
            Err(UiError::no_display(e))
        }
        Ok(Err(e)) => Err(UiError::Window(e.to_string())),
        Err(panic) => {
            let text = panic
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "the window system panicked".to_owned());
            Err(UiError::no_display(text))
        }
    }
}

/// Terrain height at (lat, lon) of `planet`, as `TerrainRenderer::terrain_height_m` computes it.
fn terrain_height_m(planet: &Terrain, lat_deg: f64, lon_deg: f64) -> f64 {
    let (phi, theta) = sphere::phi_theta_from_lat_lon_deg(lat_deg, lon_deg);
    planet.height_m(sphere::unit_vector(phi, theta))
}

/// The ground height the controls steer by and the panel shows: the drawn surface (every
/// octave of the detail, the water), from the streamed tiles at hand when the terrain is a
/// DEM (the render thread never waits for the file), else the terrain function. It is the
/// ground the frame plan stands the camera on. Jumps to a scene use the terrain function
/// itself, to place the camera exactly.
fn ground<'a>(gpu: Option<&'a Gpu>, planet: &'a Terrain) -> impl Fn(f64, f64) -> f64 + Copy + 'a {
    move |lat, lon| match gpu.and_then(|g| g.terrain.feed()) {
        Some(feed) => feed.tiles().ground_m(lat, lon).0,
        None => terrain_height_m(planet, lat, lon),
    }
}

/// The measure tool's line and points over the view (pixels of a window whose egui scale is
/// the context's): drawn under the panel, over the terrain.
fn draw_measure(ctx: &egui::Context, line: &[Option<(f64, f64)>], points: &[Option<(f64, f64)>]) {
    let scale = f64::from(ctx.pixels_per_point());
    let pos = |(x, y): (f64, f64)| egui::pos2((x / scale) as f32, (y / scale) as f32);
    let painter = ctx.layer_painter(egui::LayerId::background());
    let stroke = egui::Stroke::new(2.0, egui::Color32::from_rgb(255, 210, 60));
    // Runs of points in front of the eye, each a polyline.
    for run in line.split(|p| p.is_none()) {
        let run: Vec<egui::Pos2> = run.iter().flatten().map(|&p| pos(p)).collect();
        if run.len() >= 2 {
            painter.add(egui::Shape::line(run, stroke));
        }
    }
    for p in points.iter().flatten() {
        painter.circle(pos(*p), 4.0, egui::Color32::from_rgb(255, 120, 40), stroke);
    }
}

/// Two presses of the left button this close in time and place make a double-click.
const DOUBLE_CLICK_S: f64 = 0.4;
const DOUBLE_CLICK_PX: f64 = 5.0;

struct App {
    display: OwnedDisplayHandle,
    options: ViewerOptions,
    planet: Terrain,
    camera: Camera,
    gpu: Option<Gpu>,
    error: Option<UiError>,
    input: Input,
    panel: Panel,
    stats: FrameStats,
    last_frame: Option<Instant>,
    last_info: Option<FrameInfo>,
    frames: u64,
    smoke_frames: Option<u64>,
    /// When the `flight` path started playing.
    flight_started: Option<Instant>,
    /// When the window opened: the water's waves move with it.
    opened: Instant,
    /// The error heat map of the view it was measured for.
    error_overlay: Option<(Camera, egui::TextureHandle)>,
    /// The detail editor's window (opened from the panel).
    editor: Editor,
    /// What lies under the cursor, cast on its own thread.
    picker: Picker,
    /// A flight to a view under way, and when it started.
    fly: Option<(FlyTo, Instant)>,
    /// The measure tool's points.
    measure: MeasureTool,
    /// The camera being recorded (R), and since when.
    recording: Option<(Recorder, Instant)>,
    /// A recorded path being replayed, and since when (from the first frame drawn).
    replay: Option<(CameraPath, Option<Instant>)>,
    /// The last left press on the terrain (a second one soon after is a double-click).
    last_press: Option<(Instant, PhysicalPosition<f64>)>,
    /// File changes already printed on stderr (each is printed once).
    file_changes_printed: u64,
}

/// How long the viewer takes to fly the `flight` path.
const FLIGHT_SECONDS: f64 = 30.0;

impl App {
    fn new(options: ViewerOptions, display: OwnedDisplayHandle, smoke_frames: Option<u64>) -> Self {
        let planet = options.terrain.clone();
        let replay = options.replay.clone().map(|p| (p, None));
        let mut camera = options
            .start
            .camera(|lat, lon| terrain_height_m(&planet, lat, lon));
        controls::normalize(&mut camera, |lat, lon| terrain_height_m(&planet, lat, lon));
        let panel = Panel::new(&options.settings);
        let mut editor = Editor::new(
            planet
                .detail()
                .map(|d| d.params().clone())
                .unwrap_or_default(),
        );
        editor.open = std::env::var_os(EDITOR_ENV).is_some();
        Self {
            display,
            options,
            planet,
            camera,
            gpu: None,
            error: None,
            input: Input::default(),
            panel,
            stats: FrameStats::default(),
            last_frame: None,
            last_info: None,
            frames: 0,
            smoke_frames,
            flight_started: None,
            opened: Instant::now(),
            error_overlay: None,
            editor,
            picker: Picker::new(),
            fly: None,
            measure: MeasureTool::default(),
            recording: None,
            replay,
            last_press: None,
            file_changes_printed: 0,
        }
    }

    fn fail(&mut self, event_loop: &ActiveEventLoop, error: UiError) {
        eprintln!("globe viewer: {error}");
        self.error.get_or_insert(error);
        event_loop.exit();
    }

    fn radius_m(&self) -> f64 {
        self.planet.radius_m()
    }

    /// One frame: clock, camera, terrain, panel, present; then the panel's actions.
    fn redraw(&mut self, event_loop: &ActiveEventLoop) {
        let dt_s = self.tick();
        let terrain_here_m = self.move_camera(dt_s);
        let Some(gpu) = self.gpu.as_mut() else {
            return;
        };
        let (texture, suboptimal) = match gpu.acquire() {
            Acquired::Frame {
                texture,
                suboptimal,
            } => (texture, suboptimal),
            Acquired::Skip => return,
            Acquired::Validation => {
                self.panel.message = Some("the surface reported a validation error".into());
                return;
            }
            Acquired::Failed(e) => {
                self.fail(event_loop, e);
                return;
            }
        };
        let mut encoder = gpu
            .ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("window frame"),
            });
        let (width, height) = (gpu.config.width, gpu.config.height);
        gpu.terrain.look_time_s = self.opened.elapsed().as_secs_f64();
        let info = gpu
            .terrain
            .prepare(&gpu.ctx.queue, &mut encoder, &self.camera, width, height);
        if let Some(st) = &info.stream {
            for change in st.file_changes_after(self.file_changes_printed) {
                eprintln!("globe viewer: {change}");
            }
            self.file_changes_printed = st.file_changes_total;
        }
        self.ask_pick(width, height);
        let Some((output, actions, detail)) = self.run_panel(&info, terrain_here_m) else {
            return;
        };
        if let Some(gpu) = self.gpu.as_mut() {
            gpu.present(texture, suboptimal, encoder, &info, output);
        }
        self.last_info = Some(info);
        self.frames += 1;
        if let Some(params) = detail {
            self.apply_detail(params);
        }
        self.after_frame(event_loop, actions);
    }

    /// Advances the frame clock; returns the seconds since the last frame (0 for the first).
    fn tick(&mut self) -> f64 {
        let now = Instant::now();
        let dt_s = self
            .last_frame
            .map_or(0.0, |t| now.duration_since(t).as_secs_f64());
        self.last_frame = Some(now);
        self.stats.record(dt_s);
        dt_s
    }

    /// Moves the camera by `dt_s` of the playing flight and of the held keys; returns the
    /// terrain height under it.
    fn move_camera(&mut self, dt_s: f64) -> f64 {
        let terrain = ground(self.gpu.as_ref(), &self.planet);
        let radius_m = self.planet.radius_m();
        if let Some(started) = self.flight_started {
            let t = started.elapsed().as_secs_f64() / FLIGHT_SECONDS;
            self.camera = crate::scenes::flight::camera(t, terrain);
            if t >= 1.0 {
                self.flight_started = None;
                self.panel.message = Some("flight: arrived at the ground".into());
            }
        }
        let keys = self.input.fly_input();
        if let Some((path, started)) = &mut self.replay {
            let t = started
                .get_or_insert_with(Instant::now)
                .elapsed()
                .as_secs_f64();
            self.camera = path.camera_at(t);
            if t >= path.duration_s() {
                self.replay = None;
                self.panel.message = Some("replay: the path has ended".into());
            }
        }
        if let Some((flight, started)) = &self.fly {
            if keys.is_idle() {
                let (camera, arrived) = flight.at(started.elapsed().as_secs_f64(), terrain);
                self.camera = camera;
                if arrived {
                    self.fly = None;
                }
            } else {
                // A key takes the controls back where the flight has got to.
                self.fly = None;
            }
        }
        controls::fly(&mut self.camera, &keys, dt_s, radius_m, terrain);
        if let Some((recorder, started)) = &mut self.recording {
            recorder.record(started.elapsed().as_secs_f64(), &self.camera);
        }
        terrain(self.camera.lat_deg, self.camera.lon_deg)
    }

    /// Runs egui for this frame: the error overlay (while the camera has not moved) under the
    /// panel, which shows `info`, and the detail editor's window; applies the live settings the
    /// panel changed. Returns egui's output to paint, the actions to carry out after the frame
    /// and the detail parameters to rebuild with (at most one rebuild a frame).
    fn run_panel(
        &mut self,
        info: &FrameInfo,
        terrain_here_m: f64,
    ) -> Option<(
        egui::FullOutput,
        Vec<PanelAction>,
        Option<crate::procedural::DetailParams>,
    )> {
        let gpu = self.gpu.as_mut()?;
        let raw_input = gpu.egui_state.take_egui_input(&gpu.window);
        let mut live = LiveSettings {
            transform: gpu.terrain.settings.transform,
            approx_start_level: gpu.terrain.settings.approx_start_level,
            overlay_levels: gpu.terrain.overlays.levels,
            overlay_wireframe: gpu.terrain.overlays.wireframe,
            mode: gpu.terrain.lod().mode,
            detail_editor: self.editor.open,
            textures: gpu.terrain.look().textures,
            sky: gpu.terrain.look().sky,
            sun: gpu.terrain.look().sun,
            measure: self.measure.on,
        };
        let picked = self.picker.poll().copied();
        let (width, height) = (gpu.config.width, gpu.config.height);
        let radius_m = self.planet.radius_m();
        let measure_line = self
            .measure
            .on_screen(&self.camera, width, height, radius_m);
        let measure_points = (self.measure).points_on_screen(&self.camera, width, height, radius_m);
        let readout = Readout {
            picked: picked.as_ref(),
            measure: Some(&self.measure),
            stats: &self.stats,
            info: Some(info),
            camera: &self.camera,
            terrain_height_m: terrain_here_m,
            radius_m: self.planet.radius_m(),
            active: &gpu.terrain.settings,
            adapter: &gpu.adapter_text,
            surface: &gpu.surface_text,
            max_texture_size: gpu.ctx.device.limits().max_texture_dimension_2d,
        };
        let panel = &mut self.panel;
        let editor = &mut self.editor;
        let editor_view = EditorView {
            detail: gpu.terrain.terrain.detail(),
            centre_lat_deg: self.camera.lat_deg,
            centre_lon_deg: self.camera.lon_deg,
        };
        let mut detail = None;
        let mut actions = Vec::new();
        let egui_ctx = gpu.egui_state.egui_ctx().clone();
        if self
            .error_overlay
            .as_ref()
            .is_some_and(|(c, _)| *c != self.camera)
        {
            self.error_overlay = None;
        }
        let overlay = self.error_overlay.as_ref().map(|(_, t)| t.id());
        let output = egui_ctx.run_ui(raw_input, |ui| {
            if let Some(id) = overlay {
                // Under the panel, over the terrain (the egui pass loads the terrain's image).
                let screen = ui.ctx().content_rect();
                ui.ctx().layer_painter(egui::LayerId::background()).image(
                    id,
                    screen,
                    egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0)),
                    egui::Color32::from_white_alpha(235),
                );
            }
            draw_measure(ui.ctx(), &measure_line, &measure_points);
            actions = panel.show(ui, &readout, &mut live);
            editor.open = live.detail_editor;
            detail = editor.show(ui.ctx(), &editor_view);
        });
        self.measure.on = live.measure;
        // Takes effect from the next frame's uniforms.
        gpu.terrain.settings.transform = live.transform;
        gpu.terrain.settings.approx_start_level = live.approx_start_level;
        gpu.terrain.overlays.levels = live.overlay_levels;
        if live.overlay_wireframe != gpu.terrain.overlays.wireframe {
            gpu.terrain
                .set_wireframe(&gpu.ctx.device, live.overlay_wireframe);
        }
        if live.mode != gpu.terrain.lod().mode {
            let lod = crate::plan::LodSettings {
                mode: live.mode,
                ..gpu.terrain.lod()
            };
            gpu.terrain.set_lod(&gpu.ctx.device, lod);
        }
        let look = crate::look::LookSettings {
            textures: live.textures,
            sky: live.sky,
            sun: live.sun,
            ..gpu.terrain.look()
        };
        if look != gpu.terrain.look() {
            // Rebuilds the terrain pipelines when textures or sky changed (compiled per look):
            // one slow frame; the sun only moves the frame's uniforms.
            gpu.terrain.set_look(&gpu.ctx.device, look);
        }
        Some((output, actions, detail))
    }

    /// Rebuilds the detail with `params` (same relief map, the editor's paint) and hands it to
    /// the renderer, which refills its levels on the next frame; the editor shows a refusal.
    /// The camera stays at its height above the ground.
    fn apply_detail(&mut self, params: crate::procedural::DetailParams) {
        let Some(gpu) = self.gpu.as_mut() else {
            return;
        };
        let Some(current) = gpu.terrain.terrain.detail() else {
            return;
        };
        let detail = Arc::new(current.with_params(params));
        let result = gpu
            .terrain
            .set_detail(&gpu.ctx.queue, detail.clone())
            .map_err(|e| e.to_string());
        if result.is_ok() {
            // The camera keeps its height above the ground, which moved with the detail.
            let (lat, lon) = (self.camera.lat_deg, self.camera.lon_deg);
            let old_ground_m = terrain_height_m(&self.planet, lat, lon);
            self.planet = self.planet.clone().with_detail_of(Some(detail));
            self.camera.altitude_m += terrain_height_m(&self.planet, lat, lon) - old_ground_m;
        }
        self.editor.rebuilt(result);
    }

    /// After a presented frame: the panel's actions, then the smoke check's exit.
    fn after_frame(&mut self, event_loop: &ActiveEventLoop, actions: Vec<PanelAction>) {
        for action in actions {
            self.apply(action);
        }
        if let Some(limit) = self.smoke_frames
            && self.frames == limit / 2
            && let Ok(name) = std::env::var(SMOKE_PRESET_ENV)
        {
            match crate::procedural::presets::find(&name) {
                Some(preset) => self.editor.apply_preset(preset),
                None => eprintln!("globe viewer: no detail preset '{name}'"),
            }
        }
        if let Some(limit) = self.smoke_frames
            && self.frames >= limit
        {
            self.finish_smoke(event_loop);
        }
    }

    fn apply(&mut self, action: PanelAction) {
        match action {
            PanelAction::ApplyMesh(settings) => self.rebuild_renderer(settings),
            PanelAction::PlayFlight => {
                self.flight_started = Some(Instant::now());
                self.panel.message = Some(format!(
                    "flight: space → aircraft → ground over {FLIGHT_SECONDS} s"
                ));
            }
            PanelAction::MeasureError => match self.measure_error() {
                Ok(line) => self.panel.message = Some(line),
                Err(e) => self.panel.message = Some(format!("error measurement failed: {e}")),
            },
            PanelAction::GoToScene(scene) => {
                self.go_to(&scene.view());
                self.panel.message = Some(format!("scene '{}'", scene.name));
            }
            PanelAction::GoToView(view) => {
                self.go_to(&view);
                self.panel.message = Some(format!("view {view}"));
            }
            PanelAction::Screenshot => {
                let _ = self.screenshot();
            }
            PanelAction::ClearMeasure => self.measure.clear(),
        }
    }

    /// Flies the camera to `view` (stopping the `flight` path), placed on the terrain function
    /// itself.
    fn go_to(&mut self, view: &CameraSpec) {
        self.flight_started = None;
        let planet = &self.planet;
        let terrain = |lat: f64, lon: f64| terrain_height_m(planet, lat, lon);
        let mut target = view.camera(terrain);
        controls::normalize(&mut target, terrain);
        self.fly_to(target);
    }

    /// R: starts recording the camera, or stops and saves the path beside the screenshots.
    fn toggle_recording(&mut self) {
        let Some((recorder, _)) = self.recording.take() else {
            self.recording = Some((Recorder::default(), Instant::now()));
            self.panel.message = Some("recording the camera: press R again to save".into());
            return;
        };
        let seconds = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| d.as_secs());
        let file = PathBuf::from(format!("globe-path-{seconds}.json"));
        let saved = recorder
            .finish(&file)
            .and_then(|p| p.save(&file).map(|()| p));
        self.panel.message = Some(match saved {
            Ok(path) => {
                println!("camera path saved to {}", file.display());
                format!(
                    "path saved to {} ({} keys, {:.1} s); replay: globe --path {}",
                    file.display(),
                    path.keys().len(),
                    path.duration_s(),
                    file.display()
                )
            }
            Err(e) => format!("the path was not saved: {e}"),
        });
    }

    /// Starts a flight from the camera to `target`.
    fn fly_to(&mut self, target: Camera) {
        let terrain = ground(self.gpu.as_ref(), &self.planet);
        let flight = FlyTo::new(&self.camera, &target, self.planet.radius_m(), terrain);
        self.fly = Some((flight, Instant::now()));
    }

    /// Asks the picker for the pixel under the cursor (the window's `width` × `height`), or
    /// forgets it while the cursor is off the terrain.
    fn ask_pick(&mut self, width: u32, height: u32) {
        let over_egui = self
            .gpu
            .as_ref()
            .is_some_and(|g| self.pointer_over_egui(g.egui_state.egui_ctx()));
        let pixel = self.input.cursor.filter(|_| !over_egui).and_then(|c| {
            let (x, y) = (c.x.floor(), c.y.floor());
            (x >= 0.0 && y >= 0.0 && x < f64::from(width) && y < f64::from(height))
                .then_some((x as u32, y as u32))
        });
        match pixel {
            Some((x, y)) => self.picker.ask(
                PickRequest {
                    camera: self.camera,
                    width,
                    height,
                    x,
                    y,
                },
                &self.planet,
            ),
            None => self.picker.clear(),
        }
    }

    /// A double-click flies to the point under the cursor (the newest pick's).
    fn double_click(&mut self) {
        let Some(picked) = self.picker.poll().copied() else {
            return;
        };
        let Some((hit, world)) = picked.hit else {
            self.panel.message = Some("double-click: only sky under the cursor".into());
            return;
        };
        let target = closer_look(&self.camera, world, self.planet.radius_m());
        self.fly_to(target);
        self.panel.message = Some(format!(
            "flying to {:.6}°, {:.6}° ({})",
            hit.lat_deg,
            hit.lon_deg,
            super::panel::format_length_m(hit.height_m)
        ));
    }

    fn rebuild_renderer(&mut self, settings: crate::clipmap::ClipmapSettings) {
        let Some(gpu) = self.gpu.as_mut() else {
            return;
        };
        // Keep the live settings (transform form, approximation level) of the old renderer.
        let settings = crate::clipmap::ClipmapSettings {
            transform: gpu.terrain.settings.transform,
            approx_start_level: gpu.terrain.settings.approx_start_level,
            ..settings
        };
        match gpu.build_renderer(settings.clone(), gpu.config.format) {
            Ok(renderer) => {
                gpu.terrain = renderer;
                self.panel.draft = MeshDraft::from_settings(&settings);
                self.panel.message = Some(format!(
                    "mesh rebuilt: n = {}, m = {}, texture {}, {} sectors",
                    settings.phi_steps,
                    settings.rings_per_level,
                    settings.texture_size,
                    settings.sectors
                ));
                self.options.settings = settings;
            }
            Err(e) => {
                self.panel.message = Some(format!("could not apply the mesh settings: {e}"));
            }
        }
    }

    /// Renders the current view offscreen at window size and saves it as
    /// `globe-screenshot-<unix seconds>.png` in the current directory.
    fn screenshot(&mut self) -> Result<PathBuf, UiError> {
        let result = self.try_screenshot();
        match &result {
            Ok(path) => {
                println!("screenshot saved to {}", path.display());
                self.panel.last_screenshot = Some(path.display().to_string());
            }
            Err(e) => {
                eprintln!("globe viewer: {e}");
                self.panel.message = Some(e.to_string());
            }
        }
        result
    }

    fn try_screenshot(&mut self) -> Result<PathBuf, UiError> {
        let seconds = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| d.as_secs());
        let mut path = PathBuf::from(format!("globe-screenshot-{seconds}.png"));
        let mut n = 2;
        while path.exists() {
            path = PathBuf::from(format!("globe-screenshot-{seconds}-{n}.png"));
            n += 1;
        }
        let frame = self.render_offscreen()?;
        frame
            .save_png(&path)
            .map_err(|e| UiError::Screenshot(format!("{}: {e}", path.display())))?;
        Ok(path)
    }

    /// The current view rendered offscreen at the window's size (after streaming settles).
    fn render_offscreen(&mut self) -> Result<crate::render::RenderedFrame, UiError> {
        let Some(gpu) = self.gpu.as_mut() else {
            return Err(UiError::Screenshot("no window yet".into()));
        };
        let target = OffscreenFrame::new(&gpu.ctx.device, gpu.config.width, gpu.config.height);
        Ok(if gpu.config.format == formats::COLOR_FORMAT {
            target.render(&gpu.ctx, &mut gpu.terrain, &self.camera)?
        } else {
            // The terrain pipeline is built for the surface format; a one-off renderer for the
            // offscreen format draws the same view.
            let mut renderer = gpu
                .build_renderer(gpu.terrain.settings.clone(), formats::COLOR_FORMAT)
                .map_err(|e| UiError::Render(RenderError::Gpu(e)))?;
            target.render(&gpu.ctx, &mut renderer, &self.camera)?
        })
    }

    /// Measures ρ of the current view and keeps its heat map as the overlay; returns a line of
    /// statistics for the panel.
    fn measure_error(&mut self) -> Result<String, UiError> {
        let frame = self.render_offscreen()?;
        let rho = crate::measure::rho_image(&frame, &self.camera, &self.planet);
        let stats = crate::measure::ErrorStats::of_rho(&rho, crate::measure::DEFAULT_THRESHOLD_PX);
        let rgba = crate::measure::metric::heat_map_rgba(&rho);
        let image = egui::ColorImage::from_rgba_unmultiplied(
            [frame.width as usize, frame.height as usize],
            &rgba,
        );
        if let Some(gpu) = &self.gpu {
            let texture = gpu.egui_state.egui_ctx().load_texture(
                "error overlay",
                image,
                egui::TextureOptions::NEAREST,
            );
            self.error_overlay = Some((self.camera, texture));
        }
        Ok(format!(
            "ρ: mean {:.3} px, p99 {:.3} px, max {:.3} px; {:.2} % above {} px",
            stats.mean_px,
            stats.p99_px,
            stats.max_px,
            100.0 * stats.error_pixel_share,
            stats.threshold_px
        ))
    }

    fn finish_smoke(&mut self, event_loop: &ActiveEventLoop) {
        // Once only, even if more frames are drawn before the loop stops.
        self.smoke_frames = None;
        match self.screenshot() {
            Ok(path) => {
                let info = self.last_info.as_ref();
                println!(
                    "smoke: {} frames, {:.2} ms/frame, levels {}..{}, {} triangles, camera {:?}, screenshot {}",
                    self.frames,
                    self.stats.frame_ms,
                    info.map_or(0, |i| i.selection.coarsest),
                    info.map_or(0, |i| i.selection.finest),
                    info.map_or(0, |i| i.draw.triangles),
                    self.camera,
                    path.display()
                );
                event_loop.exit();
            }
            Err(e) => self.fail(event_loop, e),
        }
    }

    /// Whether the pointer, where it is now, belongs to the panel (or a popup of it).
    fn pointer_over_egui(&self, egui_ctx: &egui::Context) -> bool {
        let Some(cursor) = self.input.cursor else {
            return egui_ctx.egui_is_using_pointer();
        };
        let scale = f64::from(egui_ctx.pixels_per_point());
        let pos = egui::pos2((cursor.x / scale) as f32, (cursor.y / scale) as f32);
        self.panel.owns_pointer(egui_ctx, pos)
    }

    fn on_key(&mut self, event: &KeyEvent, egui_wants_keys: bool) {
        let PhysicalKey::Code(code) = event.physical_key else {
            return;
        };
        match event.state {
            ElementState::Pressed => {
                if egui_wants_keys {
                    return;
                }
                if !event.repeat && matches!(code, KeyCode::F12 | KeyCode::KeyP) {
                    let _ = self.screenshot();
                }
                if !event.repeat && code == KeyCode::KeyR {
                    self.toggle_recording();
                }
                if code == KeyCode::Escape {
                    self.measure.clear();
                }
                self.input.keys.insert(code);
            }
            ElementState::Released => {
                self.input.keys.remove(&code);
            }
        }
    }

    fn on_mouse_button(&mut self, button: MouseButton, state: ElementState, over_egui: bool) {
        match state {
            ElementState::Pressed => {
                if over_egui || self.input.drag.is_some() {
                    return;
                }
                self.fly = None;
                if button == MouseButton::Left
                    && let Some(cursor) = self.input.cursor
                {
                    let now = Instant::now();
                    let double = self.last_press.is_some_and(|(t, p)| {
                        now.duration_since(t).as_secs_f64() < DOUBLE_CLICK_S
                            && (p.x - cursor.x).hypot(p.y - cursor.y) < DOUBLE_CLICK_PX
                    });
                    if double {
                        self.last_press = None;
                        self.double_click();
                        return;
                    }
                    self.last_press = Some((now, cursor));
                }
                let drag = match button {
                    MouseButton::Left if self.input.modifiers.shift_key() => Drag::Pan,
                    MouseButton::Left => Drag::Look,
                    MouseButton::Right => Drag::Pan,
                    _ => return,
                };
                self.input.drag = Some((button, drag));
            }
            ElementState::Released => {
                if self.input.drag.is_some_and(|(b, _)| b == button) {
                    self.input.drag = None;
                    if button == MouseButton::Left && self.measure.on {
                        self.measure_click();
                    }
                }
            }
        }
    }

    /// A left click that did not drag, with the measure tool on, adds the point under it.
    fn measure_click(&mut self) {
        let (Some((_, pressed)), Some(cursor)) = (self.last_press, self.input.cursor) else {
            return;
        };
        if (pressed.x - cursor.x).hypot(pressed.y - cursor.y) >= DOUBLE_CLICK_PX {
            return; // a drag: the view turned
        }
        let Some(picked) = self.picker.poll().copied() else {
            return;
        };
        match picked.hit {
            Some((hit, world_m)) => self
                .measure
                .add(MeasuredPoint { hit, world_m }, &self.planet),
            None => self.panel.message = Some("measure: only sky under the cursor".into()),
        }
    }

    fn on_cursor_moved(&mut self, position: PhysicalPosition<f64>) {
        let previous = self.input.cursor.replace(position);
        let (Some(previous), Some((_, drag))) = (previous, self.input.drag) else {
            return;
        };
        let (dx, dy) = (position.x - previous.x, position.y - previous.y);
        let height_px = self
            .gpu
            .as_ref()
            .map_or(800.0, |g| f64::from(g.config.height));
        let radius_m = self.radius_m();
        let terrain = ground(self.gpu.as_ref(), &self.planet);
        match drag {
            Drag::Look => controls::look_drag(&mut self.camera, dx, dy, height_px),
            Drag::Pan => controls::pan_drag(&mut self.camera, dx, dy, height_px, radius_m, terrain),
        }
    }

    fn on_wheel(&mut self, delta: MouseScrollDelta) {
        let notches = match delta {
            MouseScrollDelta::LineDelta(_, y) => f64::from(y),
            // Touchpads: about 40 pixels per notch.
            MouseScrollDelta::PixelDelta(p) => p.y / 40.0,
        };
        self.fly = None;
        let terrain = ground(self.gpu.as_ref(), &self.planet);
        controls::zoom(&mut self.camera, notches, terrain);
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.gpu.is_some() {
            return;
        }
        match Gpu::new(
            event_loop,
            &self.display,
            self.options.settings.clone(),
            self.planet.clone(),
            self.options.overlay_levels,
            self.options.stream,
        ) {
            Ok(mut gpu) => {
                gpu.terrain.set_look(&gpu.ctx.device, self.options.look);
                gpu.terrain.set_lod(&gpu.ctx.device, self.options.lod);
                gpu.terrain
                    .set_wireframe(&gpu.ctx.device, self.options.overlay_wireframe);
                gpu.window.request_redraw();
                self.gpu = Some(gpu);
            }
            Err(e) => self.fail(event_loop, e),
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        let Some(gpu) = self.gpu.as_mut() else {
            return;
        };
        let response = gpu.egui_state.on_window_event(&gpu.window, &event);
        if response.repaint {
            gpu.window.request_redraw();
        }
        let egui_ctx = gpu.egui_state.egui_ctx().clone();
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => gpu.resize(size),
            WindowEvent::RedrawRequested => self.redraw(event_loop),
            WindowEvent::Focused(false) => self.input.release_all(),
            WindowEvent::ModifiersChanged(modifiers) => self.input.modifiers = modifiers.state(),
            WindowEvent::KeyboardInput { event, .. } => {
                let egui_wants_keys = response.consumed || egui_ctx.egui_wants_keyboard_input();
                self.on_key(&event, egui_wants_keys);
            }
            WindowEvent::MouseInput { state, button, .. } => {
                let over_egui = self.pointer_over_egui(&egui_ctx);
                self.on_mouse_button(button, state, over_egui);
            }
            WindowEvent::CursorMoved { position, .. } => self.on_cursor_moved(position),
            WindowEvent::CursorLeft { .. } => self.input.cursor = None,
            WindowEvent::MouseWheel { delta, .. } if !self.pointer_over_egui(&egui_ctx) => {
                self.on_wheel(delta);
            }
            _ => {}
        }
    }

    fn about_to_wait(&mut self, _: &ActiveEventLoop) {
        if let Some(gpu) = &self.gpu {
            gpu.window.request_redraw();
        }
    }
}
