//! The report's error-against-time scatter plot (issue 5, `error_vs_time.png`): one marker per
//! setting, time on x and error on y, the Pareto front drawn through the settings nothing beats
//! on both. Drawn pixel by pixel with a built-in 5×7 bitmap font, so the report needs no font,
//! plotting or rasterising dependency beyond `image`.
//!
//! Degenerate inputs still give a readable plot rather than an error:
//!
//! | input | plot |
//! | --- | --- |
//! | a point with a NaN or infinite coordinate | skipped, also by [`pareto_front`], and counted in a note under the legend |
//! | a value ≤ 0 on a log axis | that axis falls back to linear (its title says so): clamping would hide the point |
//! | all points with one x (or y) | the axis spans ±10 % of the value (±1 around 0, half a decade on a log axis) |
//! | no (finite) points | axes only, spanning 0…1 (1…10 on log axes), with a "no data" note |

use std::path::Path;

use image::{Rgb, RgbImage};

use super::MeasureError;

/// One setting of the plot: `x` its time in ms, `y` its error in px. Points of one `group`
/// share a marker colour and shape; `label` is written beside the marker.
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    pub label: String,
    pub group: String,
    pub x: f64,
    pub y: f64,
}

/// What to draw around the points, and the image size in pixels.
#[derive(Clone, Debug, PartialEq)]
pub struct PlotSpec {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub log_x: bool,
    pub log_y: bool,
    pub width: u32,
    pub height: u32,
}

/// Indices of the non-dominated points, lower x and lower y both better, sorted by x (then y,
/// then index). Points with a NaN or infinite coordinate are skipped. Equal points do not
/// dominate each other, so duplicates on the front are all returned.
pub fn pareto_front(points: &[Point]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..points.len())
        .filter(|&i| points[i].x.is_finite() && points[i].y.is_finite())
        .collect();
    order.sort_by(|&a, &b| {
        (points[a].x.total_cmp(&points[b].x)).then(points[a].y.total_cmp(&points[b].y))
    });
    // Everything sorted before a point has x ≤ its x; it is dominated iff one of those has a
    // lower y, or the same lowest y at a lower x (the same x too makes it a duplicate).
    let mut front = Vec::new();
    let mut best: Option<(f64, f64)> = None;
    for i in order {
        let p = &points[i];
        match best {
            Some((bx, by)) if p.y > by || (p.y == by && p.x != bx) => {}
            Some((_, by)) if p.y == by => front.push(i),
            _ => {
                best = Some((p.x, p.y));
                front.push(i);
            }
        }
    }
    front
}

/// One axis as drawn: the data range and whether it is logarithmic (after any fallback).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Axis {
    pub lo: f64,
    pub hi: f64,
    pub log: bool,
}

impl Axis {
    fn transform(&self, v: f64) -> f64 {
        if self.log { v.log10() } else { v }
    }

    /// Where `v` falls along the axis: 0 at `lo`, 1 at `hi`; None where it cannot be drawn
    /// (not finite, or ≤ 0 on a log axis).
    pub fn fraction(&self, v: f64) -> Option<f64> {
        if !v.is_finite() || (self.log && v <= 0.0) {
            return None;
        }
        let (a, b) = (self.transform(self.lo), self.transform(self.hi));
        Some((self.transform(v) - a) / (b - a))
    }
}

/// The data → pixel mapping of a plot, exposed so a caller (or a test) can find a point's
/// marker in the image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlotFrame {
    /// Pixel columns of the plot area's left and right edges (x = `lo`, x = `hi`).
    pub left: i32,
    pub right: i32,
    /// Pixel rows of the plot area's top and bottom edges (y = `hi`, y = `lo`).
    pub top: i32,
    pub bottom: i32,
    pub x_axis: Axis,
    pub y_axis: Axis,
}

impl PlotFrame {
    /// The frame [`render_plot`] uses for these inputs.
    pub fn new(spec: &PlotSpec, points: &[Point]) -> Self {
        Layout::new(spec, points).frame
    }

    /// Pixel coordinates (column, row; integers at pixel centres) of a data point; markers are
    /// centred on the nearest pixel. None where the point cannot be drawn.
    pub fn to_pixel(&self, x: f64, y: f64) -> Option<(f64, f64)> {
        let (tx, ty) = (self.x_axis.fraction(x)?, self.y_axis.fraction(y)?);
        Some((
            f64::from(self.left) + tx * f64::from(self.right - self.left),
            f64::from(self.bottom) - ty * f64::from(self.bottom - self.top),
        ))
    }

    fn x_px(&self, x: f64) -> Option<f64> {
        self.to_pixel(x, self.y_axis.lo).map(|p| p.0)
    }

    fn y_px(&self, y: f64) -> Option<f64> {
        self.to_pixel(self.x_axis.lo, y).map(|p| p.1)
    }
}

/// Renders the scatter plot: markers coloured and shaped by group, labels beside them, the
/// Pareto front as a polyline, ticks, titles and a legend.
pub fn render_plot(spec: &PlotSpec, points: &[Point]) -> RgbImage {
    let l = Layout::new(spec, points);
    let f = l.frame;
    let mut img = RgbImage::from_pixel(spec.width, spec.height, WHITE);
    let s = l.s as i32;
    let (plot_w, plot_h) = (f.right - f.left + 1, f.bottom - f.top + 1);
    let grid = |t: &Tick| if t.major { GRID } else { GRID_MINOR };

    // Grid, then the plot box over it.
    for t in &l.x_ticks {
        if let Some(x) = f.x_px(t.value) {
            fill_rect(&mut img, x.round() as i32, f.top, 1, plot_h, grid(t));
        }
    }
    for t in &l.y_ticks {
        if let Some(y) = f.y_px(t.value) {
            fill_rect(&mut img, f.left, y.round() as i32, plot_w, 1, grid(t));
        }
    }
    stroke_rect(&mut img, f.left, f.top, f.right, f.bottom, AXIS);

    // Ticks outside the box, with their labels.
    let tick_len = |t: &Tick| if t.major { l.tick_len } else { l.tick_len / 2 };
    for t in &l.x_ticks {
        let Some(x) = f.x_px(t.value) else { continue };
        let x = x.round() as i32;
        fill_rect(&mut img, x, f.bottom + 1, 1, tick_len(t), AXIS);
        if let Some(label) = &t.label {
            let w = text_size(label, l.s).0 as i32;
            let y = f.bottom + 1 + l.tick_len + l.pad;
            // Kept inside the image: an end label may reach past a narrow margin.
            let x = (x - w / 2).clamp(0, (spec.width as i32 - w).max(0));
            draw_text(&mut img, x, y, label, l.s, TEXT);
        }
    }
    for t in &l.y_ticks {
        let Some(y) = f.y_px(t.value) else { continue };
        let y = y.round() as i32;
        fill_rect(&mut img, f.left - tick_len(t), y, tick_len(t), 1, AXIS);
        if let Some(label) = &t.label {
            let w = text_size(label, l.s).0 as i32;
            let x = f.left - l.tick_len - l.pad - w;
            draw_text(&mut img, x, y - CAP_H as i32 * s / 2, label, l.s, TEXT);
        }
    }

    // Titles: x under the tick labels, y turned along the left edge, the plot's on top.
    let (centre_x, centre_y) = ((f.left + f.right) / 2, (f.top + f.bottom) / 2);
    let w = text_size(&l.x_title, l.s).0 as i32;
    let y = f.bottom + 1 + l.tick_len + l.pad + cell_h(l.s) + l.pad;
    draw_text(&mut img, centre_x - w / 2, y, &l.x_title, l.s, TEXT);
    let w = text_size(&l.y_title, l.s).0 as i32;
    draw_text_up(&mut img, l.pad, centre_y + w / 2, &l.y_title, l.s, TEXT);
    let w = text_size(&spec.title, l.title_s).0 as i32;
    let x = (spec.width as i32 - w) / 2;
    draw_text(&mut img, x, l.pad, &spec.title, l.title_s, TEXT);

    if l.valid.is_empty() {
        let note = "no data";
        let (w, h) = text_size(note, l.s + 1);
        let (x, y) = (centre_x - w as i32 / 2, centre_y - h as i32 / 2);
        draw_text(&mut img, x, y, note, l.s + 1, NOTE);
    }

    // The front under the markers, so that every marker stays whole; rings over them.
    let pixel = |i: usize| {
        let (x, y) = f.to_pixel(points[i].x, points[i].y)?;
        Some((x.round() as i32, y.round() as i32))
    };
    let front: Vec<(i32, i32)> = (pareto_front(points).into_iter())
        .filter_map(pixel)
        .collect();
    for pair in front.windows(2) {
        let [a, b] = [pair[0], pair[1]].map(|(x, y)| (f64::from(x), f64::from(y)));
        draw_line(&mut img, a, b, l.front_width, FRONT);
    }
    for &i in &l.valid {
        let Some((x, y)) = pixel(i) else { continue };
        draw_marker(&mut img, x, y, l.marker_r, l.style(&points[i].group));
    }
    for &(x, y) in &front {
        draw_ring(&mut img, x, y, l.ring_r(), FRONT);
    }
    for (i, (x, y)) in l.place_labels(points) {
        draw_text(&mut img, x, y, &points[i].label, l.label_s, LABEL);
    }

    l.draw_legend(&mut img);
    img
}

/// Renders the plot ([`render_plot`]) and writes it as an RGB PNG.
pub fn write_plot_png(path: &Path, spec: &PlotSpec, points: &[Point]) -> Result<(), MeasureError> {
    render_plot(spec, points)
        .save_with_format(path, image::ImageFormat::Png)
        .map_err(|source| MeasureError::Image {
            path: path.to_path_buf(),
            source,
        })
}

const WHITE: Rgb<u8> = Rgb([255, 255, 255]);
const TEXT: Rgb<u8> = Rgb([30, 30, 30]);
const LABEL: Rgb<u8> = Rgb([70, 70, 70]);
const NOTE: Rgb<u8> = Rgb([130, 130, 130]);
const AXIS: Rgb<u8> = Rgb([40, 40, 40]);
const GRID: Rgb<u8> = Rgb([218, 218, 218]);
const GRID_MINOR: Rgb<u8> = Rgb([238, 238, 238]);
/// Crimson: apart from every group colour.
const FRONT: Rgb<u8> = Rgb([220, 20, 60]);
/// Okabe–Ito colours (distinguishable with the common colour-vision deficiencies), without
/// vermillion and yellow: too close to the front and too faint on white.
const PALETTE: [Rgb<u8>; 7] = [
    Rgb([0, 114, 178]),
    Rgb([230, 159, 0]),
    Rgb([0, 158, 115]),
    Rgb([204, 121, 167]),
    Rgb([86, 180, 233]),
    Rgb([110, 110, 110]),
    Rgb([140, 86, 40]),
];

/// Marker shapes, cycled apart from the colours so that groups stay apart in grey print.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Shape {
    Circle,
    Square,
    TriangleUp,
    Diamond,
    TriangleDown,
}

const SHAPES: [Shape; 5] = [
    Shape::Circle,
    Shape::Square,
    Shape::TriangleUp,
    Shape::Diamond,
    Shape::TriangleDown,
];

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Style {
    colour: Rgb<u8>,
    shape: Shape,
}

/// The style of the `index`-th group in order of first appearance.
fn group_style(index: usize) -> Style {
    Style {
        colour: PALETTE[index % PALETTE.len()],
        shape: SHAPES[index % SHAPES.len()],
    }
}

struct Tick {
    value: f64,
    major: bool,
    label: Option<String>,
}

/// Everything placed before drawing: sizes scale with the image so that a large plot stays
/// legible.
struct Layout {
    frame: PlotFrame,
    /// Text scale of ticks, point labels, axis titles and legend; the title's is one larger.
    s: u32,
    label_s: u32,
    title_s: u32,
    pad: i32,
    tick_len: i32,
    marker_r: f64,
    front_width: f64,
    x_ticks: Vec<Tick>,
    y_ticks: Vec<Tick>,
    x_title: String,
    y_title: String,
    groups: Vec<String>,
    /// Indices of the drawable points (finite coordinates).
    valid: Vec<usize>,
    skipped: usize,
    /// Top-left corner and width of the legend box, right of the plot area.
    legend: (i32, i32, i32),
}

impl Layout {
    fn new(spec: &PlotSpec, points: &[Point]) -> Self {
        let (w, h) = (spec.width as i32, spec.height as i32);
        let s = (spec.width.min(spec.height) / 280).clamp(1, 6);
        let (label_s, title_s) = (s, s + 1);
        let pad = 4 * s as i32;
        let tick_len = 3 * s as i32;

        let valid: Vec<usize> = (0..points.len())
            .filter(|&i| points[i].x.is_finite() && points[i].y.is_finite())
            .collect();
        let xs: Vec<f64> = valid.iter().map(|&i| points[i].x).collect();
        let ys: Vec<f64> = valid.iter().map(|&i| points[i].y).collect();
        let (x_axis, x_fell_back) = resolve_axis(&xs, spec.log_x);
        let (y_axis, y_fell_back) = resolve_axis(&ys, spec.log_y);
        let fallback_note = |title: &str, fell_back| {
            let note = if fell_back {
                " (linear: values <= 0)"
            } else {
                ""
            };
            format!("{title}{note}").trim_start().to_string()
        };
        let x_title = fallback_note(&spec.x_label, x_fell_back);
        let y_title = fallback_note(&spec.y_label, y_fell_back);

        let mut groups: Vec<String> = Vec::new();
        for &i in &valid {
            if !groups.contains(&points[i].group) {
                groups.push(points[i].group.clone());
            }
        }

        let marker_r = 2.0 + 2.0 * f64::from(s);
        let mut layout = Layout {
            frame: PlotFrame {
                left: 0,
                right: 0,
                top: 0,
                bottom: 0,
                x_axis,
                y_axis,
            },
            s,
            label_s,
            title_s,
            pad,
            tick_len,
            marker_r,
            front_width: 1.0 + f64::from(s),
            x_ticks: Vec::new(),
            y_ticks: Vec::new(),
            x_title,
            y_title,
            groups,
            skipped: points.len() - valid.len(),
            valid,
            legend: (0, 0, 0),
        };

        // Margins outward in: title on top; tick labels and x title below; y title and tick
        // labels left; the legend right. The y ticks depend on the height only, so their
        // labels' width is known before the left margin is.
        let title_h = if spec.title.is_empty() {
            0
        } else {
            cell_h(title_s) + pad
        };
        let top = pad + title_h + pad;
        let x_title_h = if layout.x_title.is_empty() {
            0
        } else {
            cell_h(s) + pad
        };
        let bottom = h - (tick_len + pad + cell_h(s) + pad + x_title_h + pad) - 1;
        let mut y_ticks = axis_ticks(&y_axis, f64::from(bottom - top), s);
        let y_px = |v: f64| {
            let t = y_axis.fraction(v).unwrap_or(0.0);
            f64::from(bottom) - t * f64::from(bottom - top)
        };
        let gap = 2.0 * f64::from(s);
        thin_labels(&mut y_ticks, y_px, |_| f64::from(cell_h(s)) + gap);
        let y_label_w = (y_ticks.iter())
            .filter_map(|t| t.label.as_deref())
            .map(|l| text_size(l, s).0 as i32)
            .max()
            .unwrap_or(0);
        let y_title_w = if layout.y_title.is_empty() {
            0
        } else {
            cell_h(s) + pad
        };
        let left = pad + y_title_w + y_label_w + pad + tick_len;
        let legend_w = layout.legend_width();
        let right = w - 1 - pad - if legend_w > 0 { legend_w + 2 * pad } else { 0 };
        let right = right.max(left + 1);
        let bottom = bottom.max(top + 1);

        let mut x_ticks = axis_ticks(&x_axis, f64::from(right - left), s);
        let x_px = |v: f64| {
            let t = x_axis.fraction(v).unwrap_or(0.0);
            f64::from(left) + t * f64::from(right - left)
        };
        let sep = f64::from(2 * GLYPH_ADVANCE * s);
        thin_labels(&mut x_ticks, x_px, |l| f64::from(text_size(l, s).0) + sep);

        layout.frame = PlotFrame {
            left,
            right,
            top,
            bottom,
            x_axis,
            y_axis,
        };
        layout.x_ticks = x_ticks;
        layout.y_ticks = y_ticks;
        layout.legend = (right + 2 * pad, top, legend_w);
        layout
    }

    fn style(&self, group: &str) -> Style {
        group_style(self.groups.iter().position(|g| g == group).unwrap_or(0))
    }

    /// Legend rows: each group, then the front; none without data.
    fn legend_entries(&self) -> Vec<String> {
        if self.valid.is_empty() {
            return Vec::new();
        }
        let mut entries: Vec<String> = (self.groups.iter())
            .map(|g| {
                if g.is_empty() {
                    "(no group)".into()
                } else {
                    g.clone()
                }
            })
            .collect();
        entries.push("Pareto front".into());
        entries
    }

    fn skipped_note(&self) -> Option<String> {
        match self.skipped {
            0 => None,
            1 => Some("1 point skipped (not finite)".into()),
            n => Some(format!("{n} points skipped (not finite)")),
        }
    }

    /// Width of the symbol column: a marker, or a stretch of the front with its ring.
    fn legend_symbol_w(&self) -> i32 {
        (4.0 * self.marker_r) as i32 + 2 * self.pad
    }

    /// Radius of the ring around a point on the front.
    fn ring_r(&self) -> f64 {
        self.marker_r + 2.0
    }

    fn legend_row_h(&self) -> i32 {
        cell_h(self.s).max((2.0 * self.marker_r) as i32 + 4) + self.pad
    }

    fn legend_width(&self) -> i32 {
        let entries = self.legend_entries();
        let text_w = (entries.iter().chain(self.skipped_note().as_ref()))
            .map(|e| text_size(e, self.s).0 as i32)
            .max();
        match text_w {
            Some(t) => self.pad + self.legend_symbol_w() + self.pad + t + self.pad,
            None => 0,
        }
    }

    fn draw_legend(&self, img: &mut RgbImage) {
        let entries = self.legend_entries();
        let (x0, y0, w) = self.legend;
        let row_h = self.legend_row_h();
        let text_x = x0 + self.pad + self.legend_symbol_w() + self.pad;
        let sym_centre = x0 + self.pad + self.legend_symbol_w() / 2;
        for (row, entry) in entries.iter().enumerate() {
            let cy = y0 + self.pad + row as i32 * row_h + row_h / 2;
            if row < self.groups.len() {
                draw_marker(img, sym_centre, cy, self.marker_r, group_style(row));
            } else {
                let half = f64::from(self.legend_symbol_w() / 2 - self.pad / 2);
                let c = f64::from(sym_centre);
                let a = (c - half, f64::from(cy));
                draw_line(img, a, (c + half, f64::from(cy)), self.front_width, FRONT);
                draw_ring(img, sym_centre, cy, self.ring_r(), FRONT);
            }
            let text_y = cy - (CAP_H * self.s) as i32 / 2;
            draw_text(img, text_x, text_y, entry, self.s, TEXT);
        }
        if !entries.is_empty() {
            let y1 = y0 + 2 * self.pad + entries.len() as i32 * row_h;
            stroke_rect(img, x0, y0, x0 + w - 1, y1, GRID);
            if let Some(note) = self.skipped_note() {
                draw_text(img, x0, y1 + self.pad, &note, self.s, NOTE);
            }
        } else if let Some(note) = self.skipped_note() {
            draw_text(img, x0, y0, &note, self.s, NOTE);
        }
    }

    /// Top-left corners of the point labels, greedily: each takes the first of six places
    /// around its marker that overlaps no marker or earlier label and stays in the plot area,
    /// else the place that overlaps least.
    fn place_labels(&self, points: &[Point]) -> Vec<(usize, (i32, i32))> {
        let f = self.frame;
        let centre = |i: usize| {
            let (x, y) = f.to_pixel(points[i].x, points[i].y)?;
            Some((x.round() as i32, y.round() as i32))
        };
        let r = self.ring_r().ceil() as i32 + 1;
        let mut taken: Vec<Rect> = (self.valid.iter())
            .filter_map(|&i| centre(i))
            .map(|(x, y)| Rect::new(x - r, y - r, 2 * r + 1, 2 * r + 1))
            .collect();
        // The front's segments, as small squares every two pixels.
        let front: Vec<(i32, i32)> = (pareto_front(points).into_iter())
            .filter_map(centre)
            .collect();
        let half = (self.front_width / 2.0).ceil() as i32 + 1;
        for pair in front.windows(2) {
            let ((x0, y0), (x1, y1)) = (pair[0], pair[1]);
            let steps = ((x1 - x0).abs().max((y1 - y0).abs()) / 2).max(1);
            for k in 0..=steps {
                let x = x0 + (x1 - x0) * k / steps;
                let y = y0 + (y1 - y0) * k / steps;
                taken.push(Rect::new(x - half, y - half, 2 * half + 1, 2 * half + 1));
            }
        }
        let area = Rect::new(f.left, f.top, f.right - f.left + 1, f.bottom - f.top + 1);
        let mut placed = Vec::new();
        for &i in &self.valid {
            let (Some((x, y)), false) = (centre(i), points[i].label.is_empty()) else {
                continue;
            };
            let (w, _) = text_size(&points[i].label, self.label_s);
            let (w, h) = (w as i32, (CAP_H * self.label_s) as i32);
            let g = r + 2 * self.label_s as i32;
            let candidates = [
                (x + g, y - h / 2),
                (x - g - w, y - h / 2),
                (x + g / 2, y - g - h),
                (x + g / 2, y + g),
                (x - g / 2 - w, y - g - h),
                (x - g / 2 - w, y + g),
            ];
            let cost = |&(cx, cy): &(i32, i32)| {
                let rect = Rect::new(cx, cy, w, h);
                let overlap: i32 = taken.iter().map(|t| rect.overlap(t)).sum();
                let outside = w * h - rect.overlap(&area);
                overlap + 4 * outside
            };
            let best = (candidates.iter().enumerate())
                .min_by_key(|&(k, c)| (cost(c), k))
                .map(|(_, c)| *c)
                .expect("six candidates");
            taken.push(Rect::new(best.0, best.1, w, h));
            placed.push((i, best));
        }
        placed
    }
}

/// Range of an axis over `values` (finite), padded so that markers clear the box; whether a
/// log axis fell back to linear because of a value ≤ 0.
fn resolve_axis(values: &[f64], log: bool) -> (Axis, bool) {
    let fell_back = log && values.iter().any(|&v| v <= 0.0);
    let log = log && !fell_back;
    let f = |v: f64| if log { v.log10() } else { v };
    let inv = |t: f64| if log { 10f64.powf(t) } else { t };
    let (mut lo, mut hi) = (values.iter())
        .map(|&v| f(v))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if values.is_empty() {
        (lo, hi) = (0.0, 1.0);
    } else if lo == hi {
        let d = match (log, lo == 0.0) {
            (true, _) => 0.5,
            (false, true) => 1.0,
            (false, false) => 0.1 * lo.abs(),
        };
        (lo, hi) = (lo - d, hi + d);
    } else {
        let p = 0.06 * (hi - lo);
        (lo, hi) = (lo - p, hi + p);
    }
    // The padding must not leave f64 at the extremes of its range.
    let (min, max) = if log {
        (-307.0, 308.0)
    } else {
        (f64::MIN, f64::MAX)
    };
    (lo, hi) = (lo.max(min), hi.min(max));
    let axis = Axis {
        lo: inv(lo),
        hi: inv(hi),
        log,
    };
    (axis, fell_back)
}

/// The 1-2-5 step nearest above `raw`.
fn nice_step(raw: f64) -> f64 {
    let mag = 10f64.powf(raw.log10().floor());
    let f = raw / mag;
    let m = match f {
        f if f < 1.5 => 1.0,
        f if f < 3.5 => 2.0,
        f if f < 7.5 => 5.0,
        _ => 10.0,
    };
    m * mag
}

/// Ticks of an axis `len_px` long: on a linear axis labelled 1-2-5 steps about every 50·s
/// pixels; on a log axis decades, with minor ticks at 2 and 5 where a decade is wide enough,
/// labelled too when fewer than three decades show, and only every 2nd, 5th… decade over
/// very many. A log axis narrower than a 1-2-5 step gets linear steps.
fn axis_ticks(axis: &Axis, len_px: f64, s: u32) -> Vec<Tick> {
    let target = (len_px / (50.0 * f64::from(s))).clamp(2.0, 10.0);
    if !axis.log {
        return linear_ticks(axis.lo, axis.hi, target);
    }
    let (a, b) = (axis.lo.log10(), axis.hi.log10());
    if !(a.is_finite() && b.is_finite() && b > a) {
        return Vec::new();
    }
    let minors = len_px / (b - a) >= 40.0;
    // Over many decades, every 2nd, 5th, 10th… decade, so that ticks stay apart.
    let every = if b - a <= 1.5 * target {
        1
    } else {
        nice_step((b - a) / target) as i32
    };
    let mut ticks = Vec::new();
    for k in (a.floor().max(-330.0) as i32)..=(b.ceil().min(330.0) as i32) {
        if k.rem_euclid(every) != 0 {
            continue;
        }
        for m in [1, 2, 5] {
            let v = f64::from(m) * 10f64.powi(k);
            let lv = v.log10();
            if (m != 1 && !minors) || lv < a - 1e-9 || lv > b + 1e-9 {
                continue;
            }
            let label = Some(log_label(m, k));
            ticks.push(Tick {
                value: v,
                major: m == 1,
                label,
            });
        }
    }
    if ticks.len() < 2 {
        return linear_ticks(axis.lo, axis.hi, target);
    }
    if ticks.iter().filter(|t| t.major).count() >= 3 {
        for t in ticks.iter_mut().filter(|t| !t.major) {
            t.label = None;
        }
    }
    ticks
}

fn linear_ticks(lo: f64, hi: f64, target: f64) -> Vec<Tick> {
    let step = nice_step((hi - lo) / target);
    let (first, last) = ((lo / step).ceil(), (hi / step).floor());
    if !(step > 0.0 && step.is_finite() && (0.0..=100.0).contains(&(last - first))) {
        return Vec::new();
    }
    // Plain numbers over the usual range; beyond it e-notation with the digits the step needs.
    let step_exp = step.log10().floor();
    let top_exp = lo.abs().max(hi.abs()).log10().floor();
    let plain = (-4.0..=6.0).contains(&step_exp) && top_exp <= 6.0;
    (first as i64..=last as i64)
        .map(|i| {
            let v = if i == 0 { 0.0 } else { i as f64 * step };
            let label = match plain {
                true => format!("{:.*}", (-step_exp).max(0.0) as usize, v),
                false if v == 0.0 => "0".into(),
                false => {
                    let digits = (v.abs().log10().floor() - step_exp).clamp(0.0, 3.0);
                    format!("{:.*e}", digits as usize, v)
                }
            };
            Tick {
                value: v,
                major: true,
                label: Some(label),
            }
        })
        .collect()
}

/// `m`·10^`k` written plainly over the usual range, in e-notation beyond.
fn log_label(m: i32, k: i32) -> String {
    match k {
        0..=5 => (i64::from(m) * 10i64.pow(k as u32)).to_string(),
        -4..=-1 => format!("{:.*}", (-k) as usize, f64::from(m) * 10f64.powi(k)),
        _ => format!("{m}e{k}"),
    }
}

/// Drops labels that would overlap an earlier kept one along the axis, majors kept first.
fn thin_labels(ticks: &mut [Tick], centre: impl Fn(f64) -> f64, extent: impl Fn(&str) -> f64) {
    let mut order: Vec<usize> = (0..ticks.len())
        .filter(|&i| ticks[i].label.is_some())
        .collect();
    order.sort_by_key(|&i| !ticks[i].major);
    let mut kept: Vec<(f64, f64)> = Vec::new();
    for i in order {
        let c = centre(ticks[i].value);
        let e = extent(ticks[i].label.as_deref().unwrap_or_default()) / 2.0;
        if kept.iter().any(|&(a, b)| c - e < b && c + e > a) {
            ticks[i].label = None;
        } else {
            kept.push((c - e, c + e));
        }
    }
}

#[derive(Clone, Copy, Debug)]
struct Rect {
    x: i32,
    y: i32,
    w: i32,
    h: i32,
}

impl Rect {
    fn new(x: i32, y: i32, w: i32, h: i32) -> Self {
        Rect { x, y, w, h }
    }

    fn overlap(&self, o: &Rect) -> i32 {
        let w = (self.x + self.w).min(o.x + o.w) - self.x.max(o.x);
        let h = (self.y + self.h).min(o.y + o.h) - self.y.max(o.y);
        w.max(0) * h.max(0)
    }
}

fn put(img: &mut RgbImage, x: i32, y: i32, c: Rgb<u8>) {
    if x >= 0 && y >= 0 && (x as u32) < img.width() && (y as u32) < img.height() {
        img.put_pixel(x as u32, y as u32, c);
    }
}

fn fill_rect(img: &mut RgbImage, x: i32, y: i32, w: i32, h: i32, c: Rgb<u8>) {
    for yy in y..y + h {
        for xx in x..x + w {
            put(img, xx, yy, c);
        }
    }
}

/// One-pixel outline through the corners (inclusive).
fn stroke_rect(img: &mut RgbImage, x0: i32, y0: i32, x1: i32, y1: i32, c: Rgb<u8>) {
    fill_rect(img, x0, y0, x1 - x0 + 1, 1, c);
    fill_rect(img, x0, y1, x1 - x0 + 1, 1, c);
    fill_rect(img, x0, y0, 1, y1 - y0 + 1, c);
    fill_rect(img, x1, y0, 1, y1 - y0 + 1, c);
}

/// A line `width` pixels thick, stamped as discs every half pixel: simple, and thick lines
/// need no joins.
fn draw_line(img: &mut RgbImage, a: (f64, f64), b: (f64, f64), width: f64, c: Rgb<u8>) {
    let len = (b.0 - a.0).hypot(b.1 - a.1);
    if !len.is_finite() {
        return;
    }
    let steps = (2.0 * len).ceil().max(1.0) as i32;
    let r = width / 2.0;
    let ri = r.ceil() as i32;
    for i in 0..=steps {
        let t = f64::from(i) / f64::from(steps);
        let (x, y) = (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1));
        let (cx, cy) = (x.round() as i32, y.round() as i32);
        for dy in -ri..=ri {
            for dx in -ri..=ri {
                if f64::from(dx * dx + dy * dy) <= r * r {
                    put(img, cx + dx, cy + dy, c);
                }
            }
        }
    }
}

fn shape_contains(shape: Shape, dx: f64, dy: f64, r: f64) -> bool {
    let triangle = |dy: f64| dy >= -r && dy <= 0.75 * r && dx.abs() <= 0.62 * (dy + r);
    match shape {
        Shape::Circle => dx * dx + dy * dy <= r * r,
        Shape::Square => dx.abs().max(dy.abs()) <= 0.8 * r,
        Shape::Diamond => dx.abs() + dy.abs() <= 1.15 * r,
        Shape::TriangleUp => triangle(dy),
        Shape::TriangleDown => triangle(-dy),
    }
}

/// A filled marker of radius `r` centred on pixel (cx, cy), with a darker outline so that
/// light colours hold on white and overlapping markers stay apart.
fn draw_marker(img: &mut RgbImage, cx: i32, cy: i32, r: f64, style: Style) {
    let Rgb([red, green, blue]) = style.colour;
    let outline = Rgb([red / 2 + 10, green / 2 + 10, blue / 2 + 10]);
    let ri = r.ceil() as i32 + 1;
    for dy in -ri..=ri {
        for dx in -ri..=ri {
            let (fx, fy) = (f64::from(dx), f64::from(dy));
            if shape_contains(style.shape, fx, fy, r) {
                let inner = shape_contains(style.shape, fx, fy, r - 1.5);
                put(
                    img,
                    cx + dx,
                    cy + dy,
                    if inner { style.colour } else { outline },
                );
            }
        }
    }
}

/// The ring marking a point on the Pareto front.
fn draw_ring(img: &mut RgbImage, cx: i32, cy: i32, r: f64, c: Rgb<u8>) {
    let ri = r.ceil() as i32 + 1;
    for dy in -ri..=ri {
        for dx in -ri..=ri {
            let d = f64::from(dx * dx + dy * dy).sqrt();
            if (r - 0.75..=r + 0.75).contains(&d) {
                put(img, cx + dx, cy + dy, c);
            }
        }
    }
}

// The bitmap font: 5 pixels wide, 7 above the baseline and 2 below for descenders.

const GLYPH_W: u32 = 5;
/// Glyph width plus one column of spacing.
const GLYPH_ADVANCE: u32 = GLYPH_W + 1;
/// Rows from the top of a cell to the baseline (capitals and digits fill them).
const CAP_H: u32 = 7;
/// Rows of a cell, descenders included.
const CELL_H: u32 = 9;

/// Cell height of text at `scale`, in pixels.
fn cell_h(scale: u32) -> i32 {
    (CELL_H * scale) as i32
}

#[derive(Clone, Copy)]
struct Glyph {
    ch: char,
    /// Rows from the top of the cell, bit 4 the leftmost column.
    rows: [u8; CELL_H as usize],
}

/// A glyph from its rows written left to right, top to bottom, '#' set and '.' clear, rows
/// separated by one space: 7 rows (down to the baseline) or 9 (with the descender rows).
/// Checked at compile time.
const fn g(ch: char, pattern: &str) -> Glyph {
    let b = pattern.as_bytes();
    let mut rows = [0u8; CELL_H as usize];
    let (mut i, mut row, mut col) = (0, 0, 0);
    while i < b.len() {
        match b[i] {
            b' ' => {
                assert!(col == GLYPH_W, "a glyph row is 5 wide");
                row += 1;
                col = 0;
            }
            c @ (b'#' | b'.') => {
                assert!(
                    row < CELL_H as usize && col < GLYPH_W,
                    "a glyph is 5 × 7 or 5 × 9"
                );
                if c == b'#' {
                    rows[row] |= 1 << (GLYPH_W - 1 - col);
                }
                col += 1;
            }
            _ => panic!("glyph patterns hold '#', '.' and ' '"),
        }
        i += 1;
    }
    assert!(col == GLYPH_W, "a glyph row is 5 wide");
    assert!(
        row + 1 == CAP_H as usize || row + 1 == CELL_H as usize,
        "7 or 9 rows"
    );
    Glyph { ch, rows }
}

/// Drawn for characters the font lacks: a hollow box, visibly not a letter.
const MISSING: Glyph = g('\u{FFFD}', "##### #...# #...# #...# #...# #...# #####");

/// The font: printable ASCII the report needs plus × (a cross centred on the digits, not the
/// lower-case x), ρ (a p with a rounded top), ε, µ and %.
#[rustfmt::skip]
const GLYPHS: &[Glyph] = &[
    g(' ', "..... ..... ..... ..... ..... ..... ....."),
    g('0', ".###. #...# #..## #.#.# ##..# #...# .###."),
    g('1', "..#.. .##.. ..#.. ..#.. ..#.. ..#.. .###."),
    g('2', ".###. #...# ....# ...#. ..#.. .#... #####"),
    g('3', "##### ...#. ..#.. ...#. ....# #...# .###."),
    g('4', "...#. ..##. .#.#. #..#. ##### ...#. ...#."),
    g('5', "##### #.... ####. ....# ....# #...# .###."),
    g('6', "..##. .#... #.... ####. #...# #...# .###."),
    g('7', "##### ....# ...#. ..#.. .#... .#... .#..."),
    g('8', ".###. #...# #...# .###. #...# #...# .###."),
    g('9', ".###. #...# #...# .#### ....# ...#. .##.."),
    g('A', ".###. #...# #...# ##### #...# #...# #...#"),
    g('B', "####. #...# #...# ####. #...# #...# ####."),
    g('C', ".###. #...# #.... #.... #.... #...# .###."),
    g('D', "###.. #..#. #...# #...# #...# #..#. ###.."),
    g('E', "##### #.... #.... ####. #.... #.... #####"),
    g('F', "##### #.... #.... ####. #.... #.... #...."),
    g('G', ".###. #...# #.... #.### #...# #...# .####"),
    g('H', "#...# #...# #...# ##### #...# #...# #...#"),
    g('I', ".###. ..#.. ..#.. ..#.. ..#.. ..#.. .###."),
    g('J', "..### ...#. ...#. ...#. ...#. #..#. .##.."),
    g('K', "#...# #..#. #.#.. ##... #.#.. #..#. #...#"),
    g('L', "#.... #.... #.... #.... #.... #.... #####"),
    g('M', "#...# ##.## #.#.# #.#.# #...# #...# #...#"),
    g('N', "#...# #...# ##..# #.#.# #..## #...# #...#"),
    g('O', ".###. #...# #...# #...# #...# #...# .###."),
    g('P', "####. #...# #...# ####. #.... #.... #...."),
    g('Q', ".###. #...# #...# #...# #.#.# #..#. .##.#"),
    g('R', "####. #...# #...# ####. #.#.. #..#. #...#"),
    g('S', ".#### #.... #.... .###. ....# ....# ####."),
    g('T', "##### ..#.. ..#.. ..#.. ..#.. ..#.. ..#.."),
    g('U', "#...# #...# #...# #...# #...# #...# .###."),
    g('V', "#...# #...# #...# #...# #...# .#.#. ..#.."),
    g('W', "#...# #...# #...# #.#.# #.#.# #.#.# .#.#."),
    g('X', "#...# #...# .#.#. ..#.. .#.#. #...# #...#"),
    g('Y', "#...# #...# .#.#. ..#.. ..#.. ..#.. ..#.."),
    g('Z', "##### ....# ...#. ..#.. .#... #.... #####"),
    g('a', "..... ..... .###. ....# .#### #...# .####"),
    g('b', "#.... #.... #.##. ##..# #...# #...# ####."),
    g('c', "..... ..... .###. #.... #.... #...# .###."),
    g('d', "....# ....# .##.# #..## #...# #...# .####"),
    g('e', "..... ..... .###. #...# ##### #.... .###."),
    g('f', "..##. .#..# .#... ###.. .#... .#... .#..."),
    g('g', "..... ..... .#### #...# #...# #...# .#### ....# .###."),
    g('h', "#.... #.... #.##. ##..# #...# #...# #...#"),
    g('i', "..#.. ..... .##.. ..#.. ..#.. ..#.. .###."),
    g('j', "...#. ..... ..##. ...#. ...#. ...#. ...#. #..#. .##.."),
    g('k', "#.... #.... #..#. #.#.. ##... #.#.. #..#."),
    g('l', ".##.. ..#.. ..#.. ..#.. ..#.. ..#.. .###."),
    g('m', "..... ..... ##.#. #.#.# #.#.# #.#.# #.#.#"),
    g('n', "..... ..... #.##. ##..# #...# #...# #...#"),
    g('o', "..... ..... .###. #...# #...# #...# .###."),
    g('p', "..... ..... ####. #...# #...# #...# ####. #.... #...."),
    g('q', "..... ..... .#### #...# #...# #...# .#### ....# ....#"),
    g('r', "..... ..... #.##. ##..# #.... #.... #...."),
    g('s', "..... ..... .###. #.... .###. ....# ####."),
    g('t', ".#... .#... ###.. .#... .#... .#..# ..##."),
    g('u', "..... ..... #...# #...# #...# #..## .##.#"),
    g('v', "..... ..... #...# #...# #...# .#.#. ..#.."),
    g('w', "..... ..... #...# #...# #.#.# #.#.# .#.#."),
    g('x', "..... ..... #...# .#.#. ..#.. .#.#. #...#"),
    g('y', "..... ..... #...# #...# #...# #...# .#### ....# .###."),
    g('z', "..... ..... ##### ...#. ..#.. .#... #####"),
    g('.', "..... ..... ..... ..... ..... .##.. .##.."),
    g(',', "..... ..... ..... ..... ..... .##.. .##.. ..#.. .#..."),
    g(';', "..... .##.. .##.. ..... .##.. .##.. ..#.. .#... ....."),
    g(':', "..... .##.. .##.. ..... .##.. .##.. ....."),
    g('-', "..... ..... ..... .###. ..... ..... ....."),
    g('+', "..... ..#.. ..#.. ##### ..#.. ..#.. ....."),
    g('=', "..... ..... ##### ..... ##### ..... ....."),
    g('_', "..... ..... ..... ..... ..... ..... ..... ##### ....."),
    g('/', "....# ....# ...#. ..#.. .#... #.... #...."),
    g('(', "...#. ..#.. .#... .#... .#... ..#.. ...#."),
    g(')', ".#... ..#.. ...#. ...#. ...#. ..#.. .#..."),
    g('[', ".###. .#... .#... .#... .#... .#... .###."),
    g(']', ".###. ...#. ...#. ...#. ...#. ...#. .###."),
    g('<', "...#. ..#.. .#... #.... .#... ..#.. ...#."),
    g('>', ".#... ..#.. ...#. ....# ...#. ..#.. .#..."),
    g('%', "##... ##..# ...#. ..#.. .#... #..## ...##"),
    g('!', "..#.. ..#.. ..#.. ..#.. ..#.. ..... ..#.."),
    g('?', ".###. #...# ....# ...#. ..#.. ..... ..#.."),
    g('\'', "..#.. ..#.. .#... ..... ..... ..... ....."),
    g('*', "..... ..#.. #.#.# .###. #.#.# ..#.. ....."),
    g('#', ".#.#. .#.#. ##### .#.#. ##### .#.#. .#.#."),
    g('×', "..... #...# .#.#. ..#.. .#.#. #...# ....."),
    g('ρ', "..... ..... .###. #...# #...# ##..# #.##. #.... #...."),
    g('ε', "..... ..... .###. #.... .##.. #.... .###."),
    g('µ', "..... ..... #...# #...# #...# #..## ###.# #.... #...."),
];

fn glyph(ch: char) -> &'static Glyph {
    GLYPHS.iter().find(|g| g.ch == ch).unwrap_or(&MISSING)
}

/// The characters the font draws (others draw as a hollow box).
pub fn supported_chars() -> impl Iterator<Item = char> {
    GLYPHS.iter().map(|g| g.ch)
}

/// Width and height in pixels of `text` at `scale` (the height includes the descender rows).
pub fn text_size(text: &str, scale: u32) -> (u32, u32) {
    let n = text.chars().count() as u32;
    (
        (n * GLYPH_ADVANCE).saturating_sub(1) * scale,
        CELL_H * scale,
    )
}

/// Calls `put` with the offset (along the text, down the cell) of every set pixel.
fn for_each_text_pixel(text: &str, scale: u32, mut put: impl FnMut(i32, i32)) {
    let s = scale as i32;
    for (n, ch) in text.chars().enumerate() {
        let x0 = n as i32 * (GLYPH_ADVANCE * scale) as i32;
        for (row, bits) in glyph(ch).rows.iter().enumerate() {
            for col in 0..GLYPH_W as i32 {
                if bits & (1 << (GLYPH_W as i32 - 1 - col)) == 0 {
                    continue;
                }
                for dy in 0..s {
                    for dx in 0..s {
                        put(x0 + col * s + dx, row as i32 * s + dy);
                    }
                }
            }
        }
    }
}

/// Draws `text` with the top-left of its first cell at (x, y), each font pixel `scale`
/// pixels square.
pub fn draw_text(img: &mut RgbImage, x: i32, y: i32, text: &str, scale: u32, colour: Rgb<u8>) {
    for_each_text_pixel(text, scale, |u, v| put(img, x + u, y + v, colour));
}

/// Draws `text` reading upwards (turned 90° anticlockwise), starting at row `y` with the top
/// of its cells at column `x`: for a y axis title.
pub fn draw_text_up(img: &mut RgbImage, x: i32, y: i32, text: &str, scale: u32, colour: Rgb<u8>) {
    for_each_text_pixel(text, scale, |u, v| put(img, x + v, y - u, colour));
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(label: &str, group: &str, x: f64, y: f64) -> Point {
        Point {
            label: label.into(),
            group: group.into(),
            x,
            y,
        }
    }

    fn xy(coords: &[(f64, f64)]) -> Vec<Point> {
        coords.iter().map(|&(x, y)| p("", "", x, y)).collect()
    }

    fn spec(log_x: bool, log_y: bool) -> PlotSpec {
        PlotSpec {
            title: "Error against time".into(),
            x_label: "time (ms)".into(),
            y_label: "error ρ (px)".into(),
            log_x,
            log_y,
            width: 800,
            height: 560,
        }
    }

    fn is_white(img: &RgbImage, x: u32, y: u32) -> bool {
        *img.get_pixel(x, y) == WHITE
    }

    /// Non-white pixels in a square of radius `r` around (x, y).
    fn ink_near(img: &RgbImage, x: i32, y: i32, r: i32) -> usize {
        let mut n = 0;
        for yy in y - r..=y + r {
            for xx in x - r..=x + r {
                let inside = xx >= 0 && yy >= 0 && xx < img.width() as i32;
                if inside && yy < img.height() as i32 && !is_white(img, xx as u32, yy as u32) {
                    n += 1;
                }
            }
        }
        n
    }

    #[test]
    fn pareto_front_of_small_sets() {
        assert_eq!(pareto_front(&[]), Vec::<usize>::new());
        assert_eq!(pareto_front(&xy(&[(3.0, 4.0)])), vec![0]);
        // (2, 2) dominates (3, 3); (1, 5) and (4, 1) are trade-offs; sorted by x.
        let pts = xy(&[(3.0, 3.0), (4.0, 1.0), (1.0, 5.0), (2.0, 2.0)]);
        assert_eq!(pareto_front(&pts), vec![2, 3, 1]);
    }

    #[test]
    fn pareto_front_ties_and_duplicates() {
        // Same x: the lower y wins. Same y: the lower x wins.
        assert_eq!(pareto_front(&xy(&[(1.0, 3.0), (1.0, 2.0)])), vec![1]);
        assert_eq!(pareto_front(&xy(&[(2.0, 1.0), (1.0, 1.0)])), vec![1]);
        // Equal points do not dominate each other: both stay, in index order.
        let pts = xy(&[(5.0, 0.5), (1.0, 2.0), (3.0, 1.0), (1.0, 2.0)]);
        assert_eq!(pareto_front(&pts), vec![1, 3, 2, 0]);
        // A duplicate of a dominated point stays dominated.
        assert_eq!(
            pareto_front(&xy(&[(2.0, 2.0), (2.0, 2.0), (1.0, 1.0)])),
            vec![2]
        );
        // All equal.
        assert_eq!(pareto_front(&xy(&[(1.0, 1.0); 3])), vec![0, 1, 2]);
    }

    #[test]
    fn pareto_front_skips_nan_and_infinity() {
        let pts = xy(&[
            (f64::NAN, 0.0),
            (1.0, 1.0),
            (0.5, f64::INFINITY),
            (2.0, f64::NAN),
        ]);
        assert_eq!(pareto_front(&pts), vec![1]);
        assert_eq!(
            pareto_front(&xy(&[(f64::NAN, f64::NAN)])),
            Vec::<usize>::new()
        );
    }

    #[test]
    fn pareto_front_matches_brute_force() {
        // Small integer grid: many ties and duplicates.
        let mut state = 12345u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 33) % 6) as f64
        };
        for _ in 0..200 {
            let pts: Vec<Point> = (0..12).map(|_| p("", "", next(), next())).collect();
            let dominated = |i: usize| {
                let (a, b) = (&pts[i], &pts);
                b.iter()
                    .any(|q| q.x <= a.x && q.y <= a.y && (q.x < a.x || q.y < a.y))
            };
            let mut expected: Vec<usize> = (0..pts.len()).filter(|&i| !dominated(i)).collect();
            expected.sort_by(|&a, &b| {
                (pts[a].x.total_cmp(&pts[b].x)).then(pts[a].y.total_cmp(&pts[b].y))
            });
            assert_eq!(pareto_front(&pts), expected);
        }
    }

    #[test]
    fn nice_steps_and_ticks() {
        assert_eq!(nice_step(0.13), 0.1);
        assert_eq!(nice_step(0.3), 0.2);
        assert_eq!(nice_step(4.0), 5.0);
        assert_eq!(nice_step(80.0), 100.0);
        let labels =
            |t: &[Tick]| -> Vec<String> { t.iter().filter_map(|t| t.label.clone()).collect() };
        assert_eq!(
            labels(&linear_ticks(-0.05, 1.05, 5.0)),
            ["0.0", "0.2", "0.4", "0.6", "0.8", "1.0"]
        );
        // Three decades: decades labelled, 2 and 5 minor ticks unlabelled.
        let axis = Axis {
            lo: 0.08,
            hi: 120.0,
            log: true,
        };
        let t = axis_ticks(&axis, 600.0, 1);
        assert_eq!(labels(&t), ["0.1", "1", "10", "100"]);
        let values: Vec<f64> = t.iter().map(|t| t.value).collect();
        let expected = [0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0];
        assert!(
            values
                .iter()
                .zip(expected)
                .all(|(a, b)| (a - b).abs() < 1e-12 * b)
        );
        // Under two decades: the minor ticks are labelled too.
        let axis = Axis {
            lo: 1.5,
            hi: 60.0,
            log: true,
        };
        assert_eq!(
            labels(&axis_ticks(&axis, 600.0, 1)),
            ["2", "5", "10", "20", "50"]
        );
        // Inside one 1-2-5 step: linear steps.
        let axis = Axis {
            lo: 2.1,
            hi: 2.9,
            log: true,
        };
        let t = labels(&axis_ticks(&axis, 600.0, 1));
        assert!(
            t.len() >= 3 && t.iter().all(|l| l.starts_with("2.")),
            "{t:?}"
        );
        assert_eq!(
            labels(&linear_ticks(0.0, 3e8, 3.0)),
            ["0", "1e8", "2e8", "3e8"]
        );
        assert_eq!(
            labels(&linear_ticks(1.1e9, 1.35e9, 3.0)),
            ["1.1e9", "1.2e9", "1.3e9"]
        );
        // 600 decades on 600 pixels: ticks every 50 decades.
        let axis = Axis {
            lo: 1e-300,
            hi: 1e300,
            log: true,
        };
        let t = labels(&axis_ticks(&axis, 600.0, 1));
        assert_eq!(t.len(), 13);
        assert_eq!(t[..3], ["1e-300", "1e-250", "1e-200"]);
        assert_eq!(log_label(5, -3), "0.005");
        assert_eq!(log_label(2, 7), "2e7");
    }

    #[test]
    fn axes_resolve_degenerate_ranges() {
        let (a, fell_back) = resolve_axis(&[2.0, 2.0], false);
        assert!(!fell_back && a.lo < 2.0 && a.hi > 2.0 && !a.log);
        let (a, _) = resolve_axis(&[0.0], false);
        assert_eq!((a.lo, a.hi), (-1.0, 1.0));
        let (a, _) = resolve_axis(&[10.0], true);
        assert!(a.log && (a.lo * a.hi - 100.0).abs() < 1e-9 && a.lo < 10.0);
        let (a, fell_back) = resolve_axis(&[0.0, 3.0, 5.0], true);
        assert!(fell_back && !a.log && a.lo < 0.0);
        let (a, fell_back) = resolve_axis(&[], true);
        assert!(!fell_back && a.log && a.lo == 1.0 && a.hi == 10.0);
    }

    fn sample() -> Vec<Point> {
        vec![
            p("a1", "alpha", 2.0, 3.0),
            p("a2", "alpha", 8.0, 1.0),
            p("b1", "beta", 1.0, 6.0),
            p("b2", "beta", 5.0, 5.0),
            p("c1", "gamma", 20.0, 0.3),
            p("d1", "delta", 12.0, 2.5),
        ]
    }

    #[test]
    fn markers_are_where_the_mapping_says() {
        for (log_x, log_y) in [(false, false), (true, true), (true, false)] {
            let (spec, pts) = (spec(log_x, log_y), sample());
            let img = render_plot(&spec, &pts);
            assert_eq!(img.dimensions(), (spec.width, spec.height));
            let frame = PlotFrame::new(&spec, &pts);
            let groups = ["alpha", "beta", "gamma", "delta"];
            for q in &pts {
                let (x, y) = frame.to_pixel(q.x, q.y).expect("drawable");
                let (x, y) = (x.round() as u32, y.round() as u32);
                let g = groups.iter().position(|&g| g == q.group).unwrap();
                assert_eq!(*img.get_pixel(x, y), group_style(g).colour, "{}", q.label);
            }
            // Inside the plot area, well away from every point: background or grid.
            let (x, y) = frame.to_pixel(18.0, 5.5).unwrap();
            let c = img.get_pixel(x.round() as u32, y.round() as u32);
            assert!([WHITE, GRID, GRID_MINOR].contains(c), "{c:?}");
            assert!(is_white(&img, 0, 0));
            assert!(is_white(&img, spec.width - 1, spec.height - 1));
        }
    }

    #[test]
    fn the_front_is_drawn_between_its_points() {
        let (spec, pts) = (spec(true, true), sample());
        let img = render_plot(&spec, &pts);
        let frame = PlotFrame::new(&spec, &pts);
        // Front: b1 (1, 6) → a1 (2, 3) → a2 (8, 1) → c1 (20, 0.3); a2 → c1 is long.
        assert_eq!(pareto_front(&pts), vec![2, 0, 1, 4]);
        let a = frame.to_pixel(8.0, 1.0).unwrap();
        let b = frame.to_pixel(20.0, 0.3).unwrap();
        let (mx, my) = ((a.0 + b.0) / 2.0, (a.1 + b.1) / 2.0);
        let (mx, my) = (mx.round() as i32, my.round() as i32);
        let front_near = (-1..=1)
            .flat_map(|dy| (-1..=1).map(move |dx| (mx + dx, my + dy)))
            .any(|(x, y)| *img.get_pixel(x as u32, y as u32) == FRONT);
        assert!(front_near);
    }

    #[test]
    fn degenerate_inputs_render() {
        let cases: Vec<(&str, Vec<Point>)> = vec![
            ("empty", vec![]),
            ("one point", xy(&[(3.0, 2.0)])),
            ("same x", xy(&[(3.0, 2.0), (3.0, 5.0), (3.0, 1.0)])),
            ("same y", xy(&[(1.0, 2.0), (3.0, 2.0), (9.0, 2.0)])),
            (
                "zero and negative",
                xy(&[(0.0, -1.0), (3.0, 2.0), (5.0, 0.0)]),
            ),
            ("NaN only", xy(&[(f64::NAN, 1.0), (1.0, f64::INFINITY)])),
            (
                "NaN among others",
                xy(&[(f64::NAN, 1.0), (1.0, 2.0), (2.0, 1.0)]),
            ),
            ("huge range", xy(&[(1e-300, 1e300), (1e300, 1e-300)])),
        ];
        for (log_x, log_y) in [(false, false), (true, true)] {
            for (name, pts) in &cases {
                let spec = spec(log_x, log_y);
                let img = render_plot(&spec, pts);
                assert_eq!(img.dimensions(), (spec.width, spec.height), "{name}");
                let frame = PlotFrame::new(&spec, pts);
                assert!(
                    frame.left < frame.right && frame.top < frame.bottom,
                    "{name}"
                );
                for q in pts.iter().filter(|q| q.x.is_finite() && q.y.is_finite()) {
                    let (x, y) = frame.to_pixel(q.x, q.y).expect(name);
                    assert!(
                        x >= f64::from(frame.left) && x <= f64::from(frame.right),
                        "{name}"
                    );
                    assert!(
                        y >= f64::from(frame.top) && y <= f64::from(frame.bottom),
                        "{name}"
                    );
                    let ink = ink_near(&img, x.round() as i32, y.round() as i32, 0);
                    assert_eq!(ink, 1, "{name}");
                }
            }
        }
        // Zero on a log axis: that axis falls back to linear and says so.
        let pts = xy(&[(0.0, 1.0), (3.0, 2.0)]);
        let frame = PlotFrame::new(&spec(true, true), &pts);
        assert!(!frame.x_axis.log && frame.y_axis.log);
        // No data: a note in the middle of the plot area.
        let spec = spec(false, false);
        let frame = PlotFrame::new(&spec, &[]);
        let img = render_plot(&spec, &[]);
        let (cx, cy) = (
            (frame.left + frame.right) / 2,
            (frame.top + frame.bottom) / 2,
        );
        assert!(ink_near(&img, cx, cy, 30) > 20);
        // Too small for the margins: no panic.
        for (w, h) in [(1, 1), (40, 30), (0, 0)] {
            let small = PlotSpec {
                width: w,
                height: h,
                ..spec.clone()
            };
            assert_eq!(render_plot(&small, &sample()).dimensions(), (w, h));
        }
    }

    #[test]
    fn every_glyph_draws_within_its_cell() {
        let mut seen = Vec::new();
        for ch in supported_chars() {
            assert!(!seen.contains(&ch), "{ch:?} twice");
            seen.push(ch);
            let text = ch.to_string();
            let (w, h) = text_size(&text, 2);
            let mut img = RgbImage::from_pixel(w + 8, h + 8, WHITE);
            draw_text(&mut img, 4, 4, &text, 2, TEXT);
            let ink = ink_near(&img, 0, 0, (w + h + 16) as i32);
            assert_eq!(ink == 0, ch == ' ', "{ch:?} draws {ink} pixels");
            // Nothing outside the cell.
            for (x, y, c) in img.enumerate_pixels() {
                let inside = (4..4 + w).contains(&x) && (4..4 + h).contains(&y);
                assert!(inside || *c == WHITE, "{ch:?} at ({x}, {y})");
            }
        }
        for ch in "0123456789 .,-+_/():=×%ρ"
            .chars()
            .chain('a'..='z')
            .chain('A'..='Z')
        {
            assert!(seen.contains(&ch), "{ch:?} missing");
        }
        // Unknown characters draw a box, distinct from every glyph.
        assert!(!seen.contains(&'λ') && glyph('λ').rows == MISSING.rows);
        assert!(GLYPHS.iter().all(|g| g.rows != MISSING.rows));
        assert_eq!(text_size("ab", 3), (33, 27));
        assert_eq!(text_size("", 3), (0, 27));
    }

    #[test]
    fn upward_text_is_the_turned_horizontal_text() {
        let text = "ρ (px)";
        let (w, h) = text_size(text, 1);
        let mut across = RgbImage::from_pixel(w, h, WHITE);
        draw_text(&mut across, 0, 0, text, 1, TEXT);
        let mut up = RgbImage::from_pixel(h, w, WHITE);
        draw_text_up(&mut up, 0, w as i32 - 1, text, 1, TEXT);
        for (u, v, c) in across.enumerate_pixels() {
            assert_eq!(up.get_pixel(v, w - 1 - u), c);
        }
    }

    /// Writes the example of the report's plot: 12 settings in 4 groups, log-log.
    #[test]
    fn writes_the_example_png() {
        let pts = vec![
            p("n=32", "projective grid", 0.9, 4.2),
            p("n=64", "projective grid", 1.6, 1.9),
            p("n=128", "projective grid", 3.1, 0.85),
            p("L=8", "clipmap", 1.2, 6.5),
            p("L=10", "clipmap", 2.0, 2.4),
            p("L=12", "clipmap", 3.4, 1.1),
            p("ε=2", "refined grid", 2.2, 0.9),
            p("ε=1", "refined grid", 4.0, 0.42),
            p("ε=0.5", "refined grid", 7.5, 0.2),
            p("step 4", "ray march", 12.0, 0.35),
            p("step 2", "ray march", 22.0, 0.12),
            p("step 1", "ray march", 41.0, 0.05),
        ];
        let spec = PlotSpec {
            title: "Error against frame time (12 settings)".into(),
            x_label: "GPU time per frame (ms)".into(),
            y_label: "p99 error ρ (px)".into(),
            log_x: true,
            log_y: true,
            width: 960,
            height: 640,
        };
        let path = std::env::temp_dir().join("globe-plot-example.png");
        write_plot_png(&path, &spec, &pts).unwrap();
        let back = image::open(&path).unwrap();
        assert_eq!((back.width(), back.height()), (960, 640));
    }
}
