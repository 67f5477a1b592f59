//! The detail editor (infinite-landscapes-projected-grid.md §3): a window of sliders for every
//! parameter of the detail (eq. 1 and the warping), the basis functions shown as images (the
//! composed noise around the view centre, the amplitude map over the globe), the amplitude map
//! painted with a brush (the paper's sketch-pad for the base shape), presets, load/save of the
//! parameter file and reset.
//!
//! The editor only edits a [`DetailParams`] and says when the detail should be rebuilt
//! ([`Editor::show`] returns the parameters); the window code builds the detail and hands it
//! to the renderer, which refills its level textures once (`TerrainRenderer::set_detail`).
//! A rebuild is asked for at most once per frame and never while a slider, the seed or the
//! brush is held: a drag costs one refill, on release.
//!
//! | image | what it shows |
//! | --- | --- |
//! | noise | Σ_{k<N} w_k·t_k (units of σ, first N octaves, warped) over 8 first-octave cells around the view centre, grey: −bound…+bound |
//! | amplitude | σ(u), the first octave's amplitude, over the globe (equirectangular, lon −180…180), √ scale from its smallest to its largest value; paint on it |

use std::path::PathBuf;
use std::sync::Arc;

use egui::{Color32, RichText};
use glam::DVec3;

use crate::geo::sphere;
use crate::procedural::presets::{PRESETS, Preset};
use crate::procedural::{Detail, DetailParams, PARAM_RANGES, ReliefDab};

/// Size of the noise image, pixels.
pub const NOISE_IMAGE_PX: usize = 128;
/// Size of the amplitude map image, pixels (2:1, equirectangular).
pub const AMPLITUDE_IMAGE_PX: [usize; 2] = [256, 128];
/// Width of the noise image in first-octave cells.
const NOISE_PATCH_CELLS: f64 = 8.0;
/// Fields whose sliders are logarithmic (ranges over decades, or warp vectors whose useful
/// values are far below their bound).
const LOGARITHMIC: [&str; 11] = [
    "floor_m",
    "amplitude_min_m",
    "amplitude_max_m",
    "roughness_gain",
    "geometry_cut",
    "warp.lever_cells",
    "warp.c1[0]",
    "warp.c1[1]",
    "warp.c2[0]",
    "warp.c2[1]",
    "warp.c3[0]",
];

/// The brush that paints the amplitude map.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Brush {
    pub radius_deg: f64,
    /// Factor per dab, ≥ 1 (raise multiplies by it, lower divides).
    pub strength: f64,
    pub raise: bool,
}

impl Default for Brush {
    fn default() -> Self {
        Self {
            radius_deg: 3.0,
            strength: 1.25,
            raise: true,
        }
    }
}

impl Brush {
    /// The dab this brush leaves at (lat, lon).
    pub fn dab(&self, lat_deg: f64, lon_deg: f64) -> ReliefDab {
        let factor = if self.raise {
            self.strength
        } else {
            1.0 / self.strength
        };
        ReliefDab {
            lat_deg,
            lon_deg,
            radius_deg: self.radius_deg,
            factor,
        }
    }
}

/// What the editor is shown with this frame.
pub struct EditorView<'a> {
    /// The detail in use (None: the viewer runs without detail).
    pub detail: Option<&'a Arc<Detail>>,
    /// The point under the camera, degrees: the noise image's centre.
    pub centre_lat_deg: f64,
    pub centre_lon_deg: f64,
}

/// The editor's state between frames.
pub struct Editor {
    /// The window is shown.
    pub open: bool,
    /// What the viewer started with (Reset).
    pub initial: DetailParams,
    /// What the sliders show.
    pub params: DetailParams,
    /// The parameters of the last rebuild asked for (or the start).
    pub requested: DetailParams,
    /// The parameter file's path (Load, Save).
    pub path_text: String,
    /// The last failure (load, save, rebuild), shown in red until the next success.
    pub error: Option<String>,
    /// The last success, shown in grey.
    pub message: Option<String>,
    pub brush: Brush,
    /// Octaves the noise image sums.
    pub noise_octaves: usize,
    noise: Option<(NoiseKey, egui::TextureHandle)>,
    /// The amplitude image, the detail it was drawn for and its σ range (metres).
    amplitude: Option<(usize, egui::TextureHandle, [f64; 2])>,
    /// Each slider's rect last frame, by field (tests drive the sliders by pointer).
    pub slider_rects: Vec<(&'static str, egui::Rect)>,
    /// The amplitude map's rect last frame.
    pub map_rect: Option<egui::Rect>,
}

/// What the noise image was drawn for: the detail, the octave count, the centre in patch
/// quarters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct NoiseKey {
    detail: usize,
    octaves: usize,
    centre: (i64, i64),
}

impl Editor {
    /// An editor starting from `initial` (the viewer's detail parameters).
    pub fn new(initial: DetailParams) -> Self {
        Self {
            open: false,
            params: initial.clone(),
            requested: initial.clone(),
            initial,
            path_text: "detail.json".into(),
            error: None,
            message: None,
            brush: Brush::default(),
            noise_octaves: 4,
            noise: None,
            amplitude: None,
            slider_rects: Vec::new(),
            map_rect: None,
        }
    }

    /// The window code's answer to a rebuild: Err shows why in red (the sliders keep the
    /// values; the detail in use stays the last good one).
    pub fn rebuilt(&mut self, result: Result<(), String>) {
        match result {
            Ok(()) => self.error = None,
            Err(e) => self.error = Some(format!("cannot apply the detail: {e}")),
        }
    }

    /// Draws the window (when open); returns the parameters to rebuild the detail with, at
    /// most once per frame and only when nothing is being dragged.
    pub fn show(&mut self, ctx: &egui::Context, view: &EditorView<'_>) -> Option<DetailParams> {
        let mut open = self.open;
        let mut busy = false;
        // Right of the screen, clear of the side panel on the left.
        let right = ctx.content_rect().right();
        egui::Window::new("Detail editor")
            .open(&mut open)
            .default_pos([(right - 340.0).max(0.0), 8.0])
            .default_width(300.0)
            .default_height(960.0)
            .vscroll(true)
            .show(ctx, |ui| busy = self.contents(ui, view));
        self.open = open;
        self.request(busy, view.detail.is_some())
    }

    /// The rebuild to ask for now: the edited parameters when they differ from the last ones
    /// asked for, are valid, and nothing is held.
    fn request(&mut self, busy: bool, has_detail: bool) -> Option<DetailParams> {
        if busy || !has_detail || self.params == self.requested {
            return None;
        }
        if let Err(e) = self.params.validate("editor") {
            self.error = Some(e.to_string());
            return None;
        }
        self.requested = self.params.clone();
        Some(self.params.clone())
    }

    /// The window's contents; returns whether a widget is held (a drag in progress).
    fn contents(&mut self, ui: &mut egui::Ui, view: &EditorView<'_>) -> bool {
        let Some(detail) = view.detail else {
            ui.label(
                "the viewer runs without procedural detail (--detail off): \
                 start it with --detail default or --detail FILE to edit",
            );
            return false;
        };
        let mut busy = false;
        self.file_row(ui);
        ui.separator();
        self.noise_image(ui, detail, view);
        busy |= self.amplitude_image(ui, detail);
        ui.separator();
        busy |= self.sliders(ui);
        busy
    }

    /// Presets, the path field, Load / Save / Reset and the feedback lines.
    fn file_row(&mut self, ui: &mut egui::Ui) {
        ui.horizontal_wrapped(|ui| {
            ui.label("preset");
            for preset in &PRESETS {
                if ui
                    .button(preset.name)
                    .on_hover_text(format!("{} (keeps the paint)", preset.file))
                    .clicked()
                {
                    self.apply_preset(preset);
                }
            }
        });
        ui.horizontal(|ui| {
            ui.add(egui::TextEdit::singleline(&mut self.path_text).desired_width(150.0))
                .on_hover_text("the detail parameter file (JSON), as --detail FILE reads it");
            if ui.button("Load").clicked() {
                self.load();
            }
            if ui.button("Save").clicked() {
                self.save();
            }
            if ui
                .button("Reset")
                .on_hover_text("back to the parameters (and paint) the viewer started with")
                .clicked()
            {
                self.reset();
            }
        });
        if let Some(e) = &self.error {
            ui.label(RichText::new(e).color(Color32::LIGHT_RED));
        } else if let Some(m) = &self.message {
            ui.small(m);
        }
    }

    fn outcome(&mut self, result: Result<String, crate::procedural::DetailError>) {
        match result {
            Ok(message) => {
                self.message = Some(message);
                self.error = None;
            }
            Err(e) => self.error = Some(e.to_string()),
        }
    }

    /// The preset's parameters, keeping the paint.
    pub fn apply_preset(&mut self, preset: &Preset) {
        let result = preset.params().map(|p| {
            self.params = DetailParams {
                relief_paint: std::mem::take(&mut self.params.relief_paint),
                ..p
            };
            format!("preset '{}'", preset.name)
        });
        self.outcome(result);
    }

    /// Loads the file named in the path field (an error line names the file and the field).
    pub fn load(&mut self) {
        let path = PathBuf::from(self.path_text.trim());
        let result = DetailParams::load(&path).map(|p| {
            self.params = p;
            format!("loaded {}", path.display())
        });
        self.outcome(result);
    }

    /// Saves the edited parameters (with the paint) to the file named in the path field.
    pub fn save(&mut self) {
        let path = PathBuf::from(self.path_text.trim());
        let result = self
            .params
            .save(&path)
            .map(|()| format!("saved {}", path.display()));
        self.outcome(result);
    }

    /// Back to the parameters the viewer started with.
    pub fn reset(&mut self) {
        self.params = self.initial.clone();
        self.outcome(Ok("reset".into()));
    }

    /// The seed and one slider per [`PARAM_RANGES`] entry; returns whether one is held.
    fn sliders(&mut self, ui: &mut egui::Ui) -> bool {
        let mut busy = false;
        self.slider_rects.clear();
        egui::Grid::new("detail sliders")
            .num_columns(2)
            .show(ui, |ui| {
                ui.label("seed")
                    .on_hover_text("seed of the lattice hash: another seed, another surface");
                let r = ui.add(egui::DragValue::new(&mut self.params.seed));
                busy |= r.is_pointer_button_down_on() || r.dragged();
                ui.end_row();
                for range in &PARAM_RANGES {
                    let hover = format!("{} (allowed {})", range.help, range.allowed());
                    ui.label(range.field).on_hover_text(&hover);
                    let value = (range.get_mut)(&mut self.params);
                    let mut slider = egui::Slider::new(value, range.min..=range.max)
                        .clamping(egui::SliderClamping::Always);
                    if LOGARITHMIC.contains(&range.field) || range.field == "warp.c3[1]" {
                        slider = slider.logarithmic(true).smallest_positive(1e-3);
                    }
                    let r = ui.add(slider).on_hover_text(hover);
                    busy |= r.is_pointer_button_down_on() || r.dragged();
                    self.slider_rects.push((range.field, r.rect));
                    ui.end_row();
                }
            });
        busy
    }

    /// The composed noise of the first octaves around the view centre.
    fn noise_image(&mut self, ui: &mut egui::Ui, detail: &Arc<Detail>, view: &EditorView<'_>) {
        let n = detail.octave_count();
        ui.horizontal(|ui| {
            ui.label("noise: octaves");
            ui.add(egui::Slider::new(&mut self.noise_octaves, 1..=n.max(1)))
                .on_hover_text("how many octaves the image sums (eq. 1 with the warp)");
        });
        let Some(first) = detail.octaves().first() else {
            ui.label("(no octaves: the floor is above the first octave's cell)");
            return;
        };
        let width_m = NOISE_PATCH_CELLS * first.cell_m;
        let quarter_deg = (0.25 * width_m / detail.radius_m()).to_degrees();
        let key = NoiseKey {
            detail: Arc::as_ptr(detail) as usize,
            octaves: self.noise_octaves.min(n),
            centre: (
                (view.centre_lat_deg / quarter_deg).round() as i64,
                (view.centre_lon_deg / quarter_deg).round() as i64,
            ),
        };
        if self.noise.as_ref().map(|(k, _)| *k) != Some(key) {
            let image = noise_image(
                detail,
                view.centre_lat_deg,
                view.centre_lon_deg,
                width_m,
                key.octaves,
            );
            self.noise = Some((key, texture(ui.ctx(), "detail noise", image)));
        }
        if let Some((_, tex)) = &self.noise {
            ui.add(egui::Image::new(tex).fit_to_exact_size(egui::vec2(128.0, 128.0)))
                .on_hover_text(format!(
                    "Σ of the first {} octaves (units of σ) over {:.0} m around the view centre",
                    key.octaves, width_m
                ));
        }
    }

    /// The amplitude map and its brush; returns whether the brush is held.
    fn amplitude_image(&mut self, ui: &mut egui::Ui, detail: &Arc<Detail>) -> bool {
        let key = Arc::as_ptr(detail) as usize;
        if self.amplitude.as_ref().map(|(k, _, _)| *k) != Some(key) {
            let (image, range_m) = amplitude_image(detail);
            let tex = texture(ui.ctx(), "detail amplitude", image);
            self.amplitude = Some((key, tex, range_m));
        }
        let Some((_, tex, [lo_m, hi_m])) = &self.amplitude else {
            return false;
        };
        ui.label(format!("amplitude σ, {lo_m:.1}…{hi_m:.1} m (paint with the brush)"))
            .on_hover_text(
                "the first octave's amplitude over the globe (√ scale, black: the smallest, white: the largest), \
                 from the data's relief; drag on the map to paint a multiplier on the relief \
                 under the brush",
            );
        let size = egui::vec2(256.0, 128.0);
        let response = ui.add(
            egui::Image::new(tex)
                .fit_to_exact_size(size)
                .sense(egui::Sense::drag()),
        );
        self.map_rect = Some(response.rect);
        let held = response.is_pointer_button_down_on() || response.dragged();
        if held && let Some(pos) = response.interact_pointer_pos() {
            let (lat_deg, lon_deg) = lat_lon_of_map_point(response.rect, pos);
            let spacing_deg = self.brush.radius_deg / 3.0;
            let near_last = self.params.relief_paint.last().is_some_and(|d| {
                (d.lat_deg - lat_deg).abs() < spacing_deg
                    && (d.lon_deg - lon_deg).abs() < spacing_deg
                    && d.radius_deg == self.brush.radius_deg
            });
            if !near_last || response.drag_started() {
                self.params
                    .relief_paint
                    .push(self.brush.dab(lat_deg, lon_deg));
            }
        }
        // The dabs not yet applied, as circles over the map.
        let pending = self
            .params
            .relief_paint
            .len()
            .saturating_sub(self.requested.relief_paint.len());
        let painter = ui.painter_at(response.rect);
        for dab in &self.params.relief_paint[self.params.relief_paint.len() - pending..] {
            let centre = map_point_of_lat_lon(response.rect, dab.lat_deg, dab.lon_deg);
            let radius = (dab.radius_deg / 360.0) as f32 * response.rect.width();
            let colour = if dab.factor >= 1.0 {
                Color32::from_rgb(255, 140, 60)
            } else {
                Color32::from_rgb(80, 160, 255)
            };
            painter.circle_stroke(centre, radius, egui::Stroke::new(1.0, colour));
        }
        ui.horizontal(|ui| {
            ui.radio_value(&mut self.brush.raise, true, "raise");
            ui.radio_value(&mut self.brush.raise, false, "lower");
            if ui
                .add_enabled(
                    !self.params.relief_paint.is_empty(),
                    egui::Button::new("clear paint"),
                )
                .clicked()
            {
                self.params.relief_paint.clear();
            }
        });
        let (r_lo, r_hi) = ReliefDab::RADIUS_DEG;
        ui.add(
            egui::Slider::new(&mut self.brush.radius_deg, r_lo..=r_hi)
                .logarithmic(true)
                .text("brush radius °"),
        );
        ui.add(egui::Slider::new(&mut self.brush.strength, 1.0..=3.0).text("strength (× per dab)"));
        ui.small(format!(
            "{} dabs (saved with the parameters)",
            self.params.relief_paint.len()
        ));
        held
    }
}

fn texture(ctx: &egui::Context, name: &str, image: egui::ColorImage) -> egui::TextureHandle {
    ctx.load_texture(name, image, egui::TextureOptions::LINEAR)
}

/// (lat, lon) of a point on the equirectangular map drawn in `rect` (lon −180 at the left).
pub fn lat_lon_of_map_point(rect: egui::Rect, pos: egui::Pos2) -> (f64, f64) {
    let x = f64::from(((pos.x - rect.left()) / rect.width()).clamp(0.0, 1.0));
    let y = f64::from(((pos.y - rect.top()) / rect.height()).clamp(0.0, 1.0));
    (90.0 - 180.0 * y, 360.0 * x - 180.0)
}

/// The point of the map in `rect` at (lat, lon).
pub fn map_point_of_lat_lon(rect: egui::Rect, lat_deg: f64, lon_deg: f64) -> egui::Pos2 {
    let x = ((lon_deg + 180.0).rem_euclid(360.0) / 360.0) as f32;
    let y = ((90.0 - lat_deg) / 180.0) as f32;
    egui::pos2(
        rect.left() + x * rect.width(),
        rect.top() + y * rect.height(),
    )
}

fn unit_at(lat_deg: f64, lon_deg: f64) -> DVec3 {
    let (phi, theta) = sphere::phi_theta_from_lat_lon_deg(lat_deg, lon_deg);
    sphere::unit_vector(phi, theta)
}

/// σ over the globe, one sample per pixel centre, √ scale from the smallest σ in the image
/// (black) to the largest (white); returns the image and that range in metres.
pub fn amplitude_image(detail: &Detail) -> (egui::ColorImage, [f64; 2]) {
    let [w, h] = AMPLITUDE_IMAGE_PX;
    let mut sigma_m = Vec::with_capacity(w * h);
    for y in 0..h {
        let lat = 90.0 - 180.0 * (y as f64 + 0.5) / h as f64;
        for x in 0..w {
            let lon = 360.0 * (x as f64 + 0.5) / w as f64 - 180.0;
            sigma_m.push(detail.amplitude_m(unit_at(lat, lon)));
        }
    }
    let lo = sigma_m.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = sigma_m.iter().copied().fold(0.0, f64::max);
    let pixels = sigma_m
        .iter()
        .map(|s| {
            let v = ((s - lo) / (hi - lo).max(1e-9)).clamp(0.0, 1.0).sqrt();
            let g = 255.0 * v;
            Color32::from_rgb(g as u8, (0.85 * g) as u8, (0.6 * g) as u8)
        })
        .collect();
    (egui::ColorImage::new([w, h], pixels), [lo, hi])
}

/// Σ_{k<octaves} w_k·t_k over a square `width_m` wide around (lat, lon) in the local east/north
/// frame, grey from −bound (black) to +bound (white).
pub fn noise_image(
    detail: &Detail,
    lat_deg: f64,
    lon_deg: f64,
    width_m: f64,
    octaves: usize,
) -> egui::ColorImage {
    let s = NOISE_IMAGE_PX;
    let centre = unit_at(lat_deg, lon_deg);
    let north_pole = if centre.z.abs() > 0.999 {
        DVec3::X
    } else {
        DVec3::Z
    };
    let east = north_pole.cross(centre).normalize();
    let north = centre.cross(east);
    let step_rad = width_m / detail.radius_m() / s as f64;
    let lambda = detail.lambda_full();
    let bound = detail
        .octaves()
        .iter()
        .take(octaves)
        .map(|o| o.amplitude)
        .sum::<f64>()
        .max(1e-12)
        * (1.0 + detail.params().height_roughness);
    let mut pixels = Vec::with_capacity(s * s);
    for y in 0..s {
        let dy = (s as f64 / 2.0 - y as f64 - 0.5) * step_rad;
        for x in 0..s {
            let dx = (x as f64 + 0.5 - s as f64 / 2.0) * step_rad;
            let u = (centre + east * dx + north * dy).normalize();
            let v = detail.normalized_first(u, lambda, octaves) / bound;
            let g = (255.0 * (0.5 + 0.5 * v).clamp(0.0, 1.0)) as u8;
            pixels.push(Color32::from_gray(g));
        }
    }
    egui::ColorImage::new([s, s], pixels)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::procedural::RoughnessMap;

    fn detail(params: DetailParams) -> Arc<Detail> {
        let (cols, rows) = (72, 36);
        let values = (0..cols * rows).map(|i| (i % 97) as f32 * 50.0).collect();
        let map = RoughnessMap::from_values(cols, rows, values, crate::geo::EARTH_RADIUS_M);
        Arc::new(Detail::new(params, crate::geo::EARTH_RADIUS_M, 1000.0, map))
    }

    fn input(events: Vec<egui::Event>) -> egui::RawInput {
        egui::RawInput {
            screen_rect: Some(egui::Rect::from_min_size(
                egui::Pos2::ZERO,
                egui::vec2(1280.0, 2000.0),
            )),
            events,
            ..Default::default()
        }
    }

    fn frame(
        ctx: &egui::Context,
        editor: &mut Editor,
        view: &EditorView<'_>,
        events: Vec<egui::Event>,
    ) -> Option<DetailParams> {
        let mut request = None;
        let mut output = ctx.run_ui(input(events), |ui| {
            request = editor.show(ui.ctx(), view);
        });
        output.textures_delta.clear();
        request
    }

    fn button(pos: egui::Pos2, pressed: bool) -> egui::Event {
        egui::Event::PointerButton {
            pos,
            button: egui::PointerButton::Primary,
            pressed,
            modifiers: Default::default(),
        }
    }

    /// The editor lays out headless; a slider dragged by the pointer changes its field and
    /// asks for exactly one rebuild, on release; nothing is asked while it is held.
    #[test]
    fn slider_drag_changes_params_and_requests_one_rebuild() {
        let d = detail(DetailParams::default());
        let view = EditorView {
            detail: Some(&d),
            centre_lat_deg: 45.0,
            centre_lon_deg: 10.0,
        };
        let mut editor = Editor::new(DetailParams::default());
        editor.open = true;
        let ctx = egui::Context::default();
        for _ in 0..2 {
            assert_eq!(frame(&ctx, &mut editor, &view, vec![]), None);
        }
        assert_eq!(editor.slider_rects.len(), PARAM_RANGES.len());
        let (_, rect) = *editor
            .slider_rects
            .iter()
            .find(|(f, _)| *f == "hurst")
            .unwrap();
        // Press near the slider's left end, drag right, release.
        let start = egui::pos2(rect.left() + 0.3 * rect.width(), rect.center().y);
        let end = egui::pos2(rect.left() + 0.1 * rect.width(), rect.center().y);
        let mut requests = Vec::new();
        let steps: Vec<Vec<egui::Event>> = vec![
            vec![egui::Event::PointerMoved(start)],
            vec![button(start, true)],
            vec![egui::Event::PointerMoved(egui::pos2(
                start.x - 10.0,
                start.y,
            ))],
            vec![egui::Event::PointerMoved(end)],
        ];
        for events in steps {
            requests.extend(frame(&ctx, &mut editor, &view, events));
        }
        assert!(requests.is_empty(), "asked while held: {requests:?}");
        let held_hurst = editor.params.hurst;
        assert!(held_hurst < 0.85 - 0.05, "hurst {held_hurst}");
        requests.extend(frame(&ctx, &mut editor, &view, vec![button(end, false)]));
        for _ in 0..3 {
            requests.extend(frame(&ctx, &mut editor, &view, vec![]));
        }
        assert_eq!(requests.len(), 1, "{requests:?}");
        assert_eq!(requests[0].hurst, editor.params.hurst);
        assert_ne!(requests[0], DetailParams::default());
        assert_eq!(
            DetailParams {
                hurst: 0.85,
                ..requests[0].clone()
            },
            DetailParams::default(),
            "only hurst changed"
        );
    }

    /// A drag on the amplitude map paints dabs where the pointer is and asks for one rebuild
    /// on release; the rebuilt detail's amplitude changes under the brush only.
    #[test]
    fn painting_the_map_asks_for_one_rebuild_with_the_dabs() {
        let d = detail(DetailParams::default());
        let mut editor = Editor::new(DetailParams::default());
        editor.open = true;
        let ctx = egui::Context::default();
        let view = EditorView {
            detail: Some(&d),
            centre_lat_deg: 0.0,
            centre_lon_deg: 0.0,
        };
        for _ in 0..2 {
            frame(&ctx, &mut editor, &view, vec![]);
        }
        let rect = editor_map_rect(&ctx, &mut editor, &view);
        let at = map_point_of_lat_lon(rect, 47.5, 12.5);
        let mut requests = Vec::new();
        for events in [
            vec![egui::Event::PointerMoved(at)],
            vec![button(at, true)],
            vec![egui::Event::PointerMoved(at + egui::vec2(0.5, 0.0))],
            vec![button(at + egui::vec2(0.5, 0.0), false)],
            vec![],
        ] {
            requests.extend(frame(&ctx, &mut editor, &view, events));
        }
        assert_eq!(requests.len(), 1, "{requests:?}");
        let dabs = &requests[0].relief_paint;
        assert!(!dabs.is_empty());
        assert!((dabs[0].lat_deg - 47.5).abs() < 1.0 && (dabs[0].lon_deg - 12.5).abs() < 2.0);
        let painted = d.with_params(requests[0].clone());
        let here = unit_at(dabs[0].lat_deg, dabs[0].lon_deg);
        let far = unit_at(-40.0, -150.0);
        assert!(painted.roughness().relief_at_m(here) > d.roughness().relief_at_m(here));
        assert_eq!(painted.amplitude_m(far), d.amplitude_m(far));
    }

    /// The amplitude map's rect as the editor laid it out.
    fn editor_map_rect(
        ctx: &egui::Context,
        editor: &mut Editor,
        view: &EditorView<'_>,
    ) -> egui::Rect {
        frame(ctx, editor, view, vec![]);
        editor.map_rect.expect("the map was laid out")
    }

    /// Save then Load gives the same parameters (paint included), a preset keeps the paint,
    /// Reset goes back to the start, and a bad file is a red line naming the file and the
    /// field, not a panic.
    #[test]
    fn presets_load_save_reset() {
        let dir = tempfile::tempdir().unwrap();
        let mut editor = Editor::new(DetailParams::default());
        editor.params.hurst = 0.5;
        editor
            .params
            .relief_paint
            .push(Brush::default().dab(10.0, 20.0));
        let edited = editor.params.clone();
        editor.path_text = dir.path().join("d.json").display().to_string();
        editor.save();
        assert_eq!(editor.error, None);
        editor.reset();
        assert_eq!(editor.params, DetailParams::default());
        assert_eq!(editor.request(false, true), None, "reset to what is in use");
        editor.load();
        assert_eq!(editor.params, edited);
        let dunes = crate::procedural::presets::find("dunes").unwrap();
        editor.apply_preset(dunes);
        assert_eq!(editor.params.relief_paint, edited.relief_paint);
        assert_eq!(editor.params.warp, dunes.params().unwrap().warp);
        std::fs::write(dir.path().join("bad.json"), r#"{"hurst": 7}"#).unwrap();
        editor.path_text = dir.path().join("bad.json").display().to_string();
        editor.load();
        let shown = editor.error.clone().unwrap();
        assert!(
            shown.contains("bad.json") && shown.contains("hurst"),
            "{shown}"
        );
        assert_eq!(
            editor.params.warp,
            dunes.params().unwrap().warp,
            "unchanged"
        );
        editor.path_text = dir.path().join("missing/x.json").display().to_string();
        editor.save();
        assert!(editor.error.clone().unwrap().contains("cannot write"));
    }

    #[test]
    fn map_points_round_trip() {
        let rect = egui::Rect::from_min_size(egui::pos2(10.0, 20.0), egui::vec2(256.0, 128.0));
        for (lat, lon) in [(0.0, 0.0), (45.0, 10.0), (-60.0, -170.0)] {
            let (la, lo) = lat_lon_of_map_point(rect, map_point_of_lat_lon(rect, lat, lon));
            assert!(
                (la - lat).abs() < 1e-3 && (lo - lon).abs() < 1e-3,
                "{lat} {lon}"
            );
        }
    }
}
