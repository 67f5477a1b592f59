//! The report's error-against-time scatter plot (`error_vs_time.png` and `.svg`): one marker
//! per setting, time on x and error on y, the Pareto front drawn through the settings nothing
//! beats on both. Drawn with `plotters` (bitmap and SVG backends); its text uses DejaVu Sans,
//! embedded from `assets/fonts/` so that a machine without fonts (CI) renders it the same.
//! Ours are the Pareto front, the axis ranges and their ticks (decades, with 2 and 5 between
//! them where there is room, and linear steps on a log axis narrower than one of those), and
//! where each point's label goes.
//!
//! Degenerate inputs still give a readable plot rather than an error:
//!
//! | input | plot |
//! | --- | --- |
//! | a point with a NaN or infinite coordinate | skipped, also by [`pareto_front`], and counted in a note under the legend |
//! | a value ≤ 0 on a log axis | that axis falls back to linear (its title says so): clamping would hide the point |
//! | all points with one x (or y) | the axis spans ±10 % of the value (±1 around 0, half a decade on a log axis) |
//! | no (finite) points | axes only, spanning 0…1 (1…10 on log axes), with a "no data" note |

use std::ops::Range;
use std::path::Path;
use std::sync::Once;

use image::RgbImage;
use plotters::coord::Shift;
use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};
use plotters::prelude::*;
use plotters::style::{FontStyle, RGBColor, register_font};

use crate::measure::MeasureError;

/// One setting of the plot: `x` its time in ms, `y` its error in px. Points of one `group`
/// share a marker colour and shape; `label` is written beside the marker.
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    pub label: String,
    pub group: String,
    pub x: f64,
    pub y: f64,
}

/// What to draw around the points.
#[derive(Clone, Debug, PartialEq)]
pub struct PlotSpec {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub log_x: bool,
    pub log_y: bool,
}

/// One panel of a figure: its axes and titles, and its points.
#[derive(Clone, Debug, PartialEq)]
pub struct Panel {
    pub spec: PlotSpec,
    pub points: Vec<Point>,
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

/// Marker pixels of a drawn panel (see [`draw_panel`]), for a caller or a test to find them.
#[derive(Clone, Debug, PartialEq)]
pub struct Drawn {
    /// Pixel (column, row) of each point's marker centre in the whole image; None where the
    /// point was skipped.
    pub markers: Vec<Option<(i32, i32)>>,
    pub x_axis: Axis,
    pub y_axis: Axis,
}

/// The font family every text of the plots uses: DejaVu Sans, registered once.
pub(crate) const FONT: &str = "sans-serif";
static FONT_BYTES: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

pub(crate) fn register_embedded_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The file is in the repository and parsed by a test: it cannot fail to parse.
        if register_font(FONT, FontStyle::Normal, FONT_BYTES).is_err() {
            panic!("assets/fonts/DejaVuSans.ttf is not a font ab_glyph can read");
        }
    });
}

const WHITE_C: RGBColor = RGBColor(255, 255, 255);
const TEXT: RGBColor = RGBColor(30, 30, 30);
const LABEL: RGBColor = RGBColor(70, 70, 70);
const NOTE: RGBColor = RGBColor(130, 130, 130);
const AXIS: RGBColor = RGBColor(40, 40, 40);
const GRID: RGBColor = RGBColor(218, 218, 218);
const GRID_MINOR: RGBColor = RGBColor(240, 240, 240);
/// Crimson: apart from every group colour.
const FRONT: RGBColor = RGBColor(220, 20, 60);
/// Okabe–Ito colours (distinguishable with the common colour-vision deficiencies), without
/// vermillion and yellow: too close to the front and too faint on white.
const PALETTE: [RGBColor; 7] = [
    RGBColor(0, 114, 178),
    RGBColor(230, 159, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(86, 180, 233),
    RGBColor(110, 110, 110),
    RGBColor(140, 86, 40),
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
    colour: RGBColor,
    shape: Shape,
}

/// The style of the `index`-th group in order of first appearance.
fn group_style(index: usize) -> Style {
    Style {
        colour: PALETTE[index % PALETTE.len()],
        shape: SHAPES[index % SHAPES.len()],
    }
}

/// The outline of a marker of radius `r` around (0, 0), in pixels (y down).
fn marker_outline(shape: Shape, r: f64) -> Vec<(i32, i32)> {
    let at = |pts: &[(f64, f64)]| -> Vec<(i32, i32)> {
        (pts.iter())
            .map(|&(x, y)| ((x * r).round() as i32, (y * r).round() as i32))
            .collect()
    };
    match shape {
        Shape::Circle => {
            let pts: Vec<(f64, f64)> = (0..24)
                .map(|k| f64::from(k) * std::f64::consts::TAU / 24.0)
                .map(|a| (a.cos(), a.sin()))
                .collect();
            at(&pts)
        }
        Shape::Square => at(&[(-0.85, -0.85), (0.85, -0.85), (0.85, 0.85), (-0.85, 0.85)]),
        Shape::Diamond => at(&[(0.0, -1.2), (1.2, 0.0), (0.0, 1.2), (-1.2, 0.0)]),
        Shape::TriangleUp => at(&[(0.0, -1.15), (1.05, 0.75), (-1.05, 0.75)]),
        Shape::TriangleDown => at(&[(0.0, 1.15), (1.05, -0.75), (-1.05, -0.75)]),
    }
}

/// A filled marker at `at` (pixels within `area`), with a darker outline so that light colours
/// hold on white and overlapping markers stay apart.
fn draw_marker<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    at: (i32, i32),
    r: f64,
    style: Style,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let RGBColor(red, green, blue) = style.colour;
    let outline = RGBColor(red / 2 + 10, green / 2 + 10, blue / 2 + 10);
    let mut edge = marker_outline(style.shape, r);
    area.draw(&(EmptyElement::at(at) + Polygon::new(edge.clone(), style.colour.filled())))?;
    edge.push(edge[0]);
    area.draw(&(EmptyElement::at(at) + PathElement::new(edge, outline.stroke_width(2))))
}

/// A tick: its value, and its label (labelled ticks are the bold grid lines).
#[derive(Clone, Debug, PartialEq)]
struct Tick {
    value: f64,
    label: Option<String>,
}

/// An axis with its ticks chosen: the coordinate `plotters` maps through. Its bold key points
/// are the labelled ticks, its light ones every tick.
#[derive(Clone, Debug)]
struct TickedAxis {
    axis: Axis,
    ticks: Vec<Tick>,
}

impl TickedAxis {
    fn new(axis: Axis, target: f64) -> Self {
        Self {
            ticks: axis_ticks(&axis, target),
            axis,
        }
    }

    fn label(&self, v: f64) -> String {
        (self.ticks.iter())
            .filter(|t| t.label.is_some())
            .min_by(|a, b| (a.value - v).abs().total_cmp(&(b.value - v).abs()))
            .and_then(|t| t.label.clone())
            .unwrap_or_default()
    }
}

impl Ranged for TickedAxis {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        let t = self.axis.fraction(*value).unwrap_or(f64::NAN);
        let px = f64::from(limit.0) + t * f64::from(limit.1 - limit.0);
        // Off-axis values (never drawn: the caller skips them) land on the low end.
        if px.is_finite() {
            px.round().clamp(-1e6, 1e6) as i32
        } else {
            limit.0
        }
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        let light = hint.weight().allow_light_points();
        (self.ticks.iter())
            .filter(|t| light || t.label.is_some())
            .map(|t| t.value)
            .collect()
    }

    fn range(&self) -> Range<f64> {
        self.axis.lo..self.axis.hi
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
        (f64::MIN / 4.0, f64::MAX / 4.0)
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

/// About `target` ticks: on a linear axis labelled 1-2-5 steps; on a log axis decades, with
/// ticks at 2 and 5 between them where fewer than `target` decades show, labelled too when
/// fewer than three do, at every 1…9 × 10^k within less than a decade, and only every 2nd,
/// 5th… decade over very many. A log axis narrower than a 1-2-5 step gets linear steps.
fn axis_ticks(axis: &Axis, target: f64) -> Vec<Tick> {
    let target = target.clamp(2.0, 12.0);
    if !axis.log {
        return linear_ticks(axis.lo, axis.hi, target);
    }
    let (a, b) = (axis.lo.log10(), axis.hi.log10());
    if !(a.is_finite() && b.is_finite() && b > a) {
        return Vec::new();
    }
    let minors = b - a <= target;
    let mantissas: &[i32] = if b - a < 1.0 {
        &[1, 2, 3, 4, 5, 6, 7, 8, 9]
    } else {
        &[1, 2, 5]
    };
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
        for &m in mantissas {
            let v = f64::from(m) * 10f64.powi(k);
            let lv = v.log10();
            if (m != 1 && !minors) || lv < a - 1e-9 || lv > b + 1e-9 {
                continue;
            }
            ticks.push(Tick {
                value: v,
                label: Some(log_label(m, k)),
            });
        }
    }
    if ticks.len() < 2 {
        return linear_ticks(axis.lo, axis.hi, target);
    }
    let decades = ticks.iter().filter(|t| is_decade(t.value)).count();
    if decades >= 3 {
        for t in ticks.iter_mut().filter(|t| !is_decade(t.value)) {
            t.label = None;
        }
    }
    ticks
}

fn is_decade(v: f64) -> bool {
    let l = v.log10();
    (l - l.round()).abs() < 1e-9
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

/// Top-left corners of the point labels, greedily: each takes the first of six places around
/// its marker that overlaps no marker, front segment or earlier label and stays in `area`,
/// else the place that overlaps least. `sizes` are the labels' pixel sizes.
fn place_labels(
    centres: &[Option<(i32, i32)>],
    front: &[(i32, i32)],
    sizes: &[(i32, i32)],
    clearance: i32,
    area: Rect,
) -> Vec<Option<(i32, i32)>> {
    let r = clearance;
    let mut taken: Vec<Rect> = (centres.iter().flatten())
        .map(|&(x, y)| Rect::new(x - r, y - r, 2 * r + 1, 2 * r + 1))
        .collect();
    // The front's segments, as small squares every two pixels.
    for pair in front.windows(2) {
        let ((x0, y0), (x1, y1)) = (pair[0], pair[1]);
        let steps = ((x1 - x0).abs().max((y1 - y0).abs()) / 2).max(1);
        for k in 0..=steps {
            let x = x0 + (x1 - x0) * k / steps;
            let y = y0 + (y1 - y0) * k / steps;
            taken.push(Rect::new(x - 2, y - 2, 5, 5));
        }
    }
    let mut placed = Vec::with_capacity(centres.len());
    for (c, &(w, h)) in centres.iter().zip(sizes) {
        let Some((x, y)) = *c else {
            placed.push(None);
            continue;
        };
        let g = r + 5;
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
        placed.push(Some(best));
    }
    placed
}

type DrawResult<T, DB> = Result<T, DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

/// Draws one panel into `area`: the chart (grid, log or linear axes, titles), markers coloured
/// and shaped by group with their labels, the Pareto front as a line with rings on its points,
/// and the legend right of the chart. Text sizes follow the panel's size.
pub fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    spec: &PlotSpec,
    points: &[Point],
) -> DrawResult<Drawn, DB> {
    register_embedded_font();
    let (w, h) = area.dim_in_pixel();
    // 15 px text on a 1100 × 620 panel.
    let unit = f64::from(w.min(2 * h)).max(200.0) / 1100.0;
    let px = |v: f64| (v * unit).round().max(1.0) as i32;
    let font = |size: f64| (FONT, size * unit).into_font();
    let text = font(15.0).color(&TEXT);
    let label_text = font(13.0).color(&LABEL);

    let valid: Vec<usize> = (0..points.len())
        .filter(|&i| points[i].x.is_finite() && points[i].y.is_finite())
        .collect();
    let skipped = points.len() - valid.len();
    let xs: Vec<f64> = valid.iter().map(|&i| points[i].x).collect();
    let ys: Vec<f64> = valid.iter().map(|&i| points[i].y).collect();
    let (x_axis, x_fell_back) = resolve_axis(&xs, spec.log_x);
    let (y_axis, y_fell_back) = resolve_axis(&ys, spec.log_y);
    let title_of = |t: &str, fell_back: bool| match fell_back {
        true => format!("{t} (linear: values <= 0)")
            .trim_start()
            .to_string(),
        false => t.to_string(),
    };

    let mut groups: Vec<&str> = Vec::new();
    for &i in &valid {
        if !groups.contains(&points[i].group.as_str()) {
            groups.push(&points[i].group);
        }
    }
    let mut entries: Vec<String> = (groups.iter())
        .map(|g| match g.is_empty() {
            true => "(no group)".to_string(),
            false => g.to_string(),
        })
        .collect();
    if !valid.is_empty() {
        entries.push("Pareto front".into());
    }
    let skipped_note = match skipped {
        0 => None,
        1 => Some("1 point skipped (not finite)".to_string()),
        n => Some(format!("{n} points skipped (not finite)")),
    };

    // The legend's column right of the chart, as wide as its longest line.
    let marker_r = 6.0 * unit;
    let symbol_w = px(36.0);
    let pad = px(8.0);
    let mut legend_text_w = 0;
    for e in entries.iter().chain(skipped_note.as_ref()) {
        legend_text_w = legend_text_w.max(area.estimate_text_size(e, &text)?.0 as i32);
    }
    let legend_w = match legend_text_w {
        0 => 0,
        t => 4 * pad + symbol_w + t,
    };
    let chart_w = (w as i32 - legend_w).max(w as i32 / 2) as u32;
    let (chart_area, legend_area) = area.split_horizontally(chart_w);

    let x = TickedAxis::new(x_axis, f64::from(chart_w) / (110.0 * unit));
    let y = TickedAxis::new(y_axis, f64::from(h) / (70.0 * unit));
    let mut chart = ChartBuilder::on(&chart_area)
        .caption(&spec.title, font(20.0).color(&TEXT))
        .margin(px(10.0))
        .x_label_area_size(px(52.0))
        .y_label_area_size(px(74.0))
        .build_cartesian_2d(x.clone(), y.clone())?;
    let (x_fmt, y_fmt) = (|v: &f64| x.label(*v), |v: &f64| y.label(*v));
    chart
        .configure_mesh()
        .bold_line_style(GRID.stroke_width(1))
        .light_line_style(GRID_MINOR.stroke_width(1))
        .axis_style(AXIS.stroke_width(1))
        .label_style(text.clone())
        .axis_desc_style(text.clone())
        .x_desc(title_of(&spec.x_label, x_fell_back))
        .y_desc(title_of(&spec.y_label, y_fell_back))
        .x_label_formatter(&x_fmt)
        .y_label_formatter(&y_fmt)
        .x_max_light_lines(12)
        .y_max_light_lines(12)
        .draw()?;

    let markers: Vec<Option<(i32, i32)>> = (0..points.len())
        .map(|i| {
            let q = &points[i];
            let drawable = valid.contains(&i) && x_axis.fraction(q.x).is_some();
            (drawable && y_axis.fraction(q.y).is_some()).then(|| chart.backend_coord(&(q.x, q.y)))
        })
        .collect();
    let front: Vec<(i32, i32)> = (pareto_front(points).into_iter())
        .filter_map(|i| markers[i])
        .collect();
    // Everything from here is drawn in pixels of the panel.
    let (ox, oy) = area.get_base_pixel();
    let local = |(x, y): (i32, i32)| (x - ox, y - oy);
    let front_style = FRONT.stroke_width(px(3.0) as u32);
    let ring_r = marker_r + 3.0 * unit;
    let ring = |c: (i32, i32)| Circle::new(c, ring_r.round() as i32, FRONT.stroke_width(2));

    // The front under the markers, so that every marker stays whole; rings over them.
    area.draw(&PathElement::new(
        front.iter().map(|&c| local(c)).collect::<Vec<_>>(),
        front_style,
    ))?;
    let style_of = |g: &str| group_style(groups.iter().position(|x| *x == g).unwrap_or(0));
    for (i, m) in markers.iter().enumerate() {
        if let Some(c) = *m {
            draw_marker(area, local(c), marker_r, style_of(&points[i].group))?;
        }
    }
    for &c in &front {
        area.draw(&ring(local(c)))?;
    }
    let (xr, yr) = chart.plotting_area().get_pixel_range();
    let plot_rect = Rect::new(xr.start, yr.start, xr.end - xr.start, yr.end - yr.start);
    let mut sizes = Vec::with_capacity(points.len());
    for (q, m) in points.iter().zip(&markers) {
        let (lw, lh) = match (m, q.label.is_empty()) {
            (Some(_), false) => area.estimate_text_size(&q.label, &label_text)?,
            _ => (0, 0),
        };
        sizes.push((lw as i32, lh as i32));
    }
    let clearance = ring_r.ceil() as i32 + 1;
    let labels = place_labels(&markers, &front, &sizes, clearance, plot_rect);
    for (q, at) in points.iter().zip(labels) {
        if let (Some(at), false) = (at, q.label.is_empty()) {
            area.draw(&Text::new(q.label.clone(), local(at), label_text.clone()))?;
        }
    }
    if valid.is_empty() {
        let note = font(20.0)
            .color(&NOTE)
            .pos(plotters::style::text_anchor::Pos::new(
                plotters::style::text_anchor::HPos::Center,
                plotters::style::text_anchor::VPos::Center,
            ));
        let centre = ((xr.start + xr.end) / 2, (yr.start + yr.end) / 2);
        area.draw(&Text::new("no data", local(centre), note))?;
    }

    // The legend: one row per group, then the front.
    let row_h = px(26.0);
    let top = yr.start - oy;
    let (sym_x, text_x) = (pad + symbol_w / 2, 2 * pad + symbol_w);
    let centred = text.pos(plotters::style::text_anchor::Pos::new(
        plotters::style::text_anchor::HPos::Left,
        plotters::style::text_anchor::VPos::Center,
    ));
    for (row, entry) in entries.iter().enumerate() {
        let cy = top + pad + row as i32 * row_h + row_h / 2;
        if row < groups.len() {
            draw_marker(&legend_area, (sym_x, cy), marker_r, group_style(row))?;
        } else {
            let half = symbol_w / 2;
            let line = vec![(sym_x - half, cy), (sym_x + half, cy)];
            legend_area.draw(&PathElement::new(line, front_style))?;
            legend_area.draw(&ring((sym_x, cy)))?;
        }
        legend_area.draw(&Text::new(entry.clone(), (text_x, cy), centred.clone()))?;
    }
    let bottom = top + 2 * pad + entries.len() as i32 * row_h;
    if !entries.is_empty() {
        let frame = [(0, top), (legend_w - pad - 1, bottom)];
        legend_area.draw(&Rectangle::new(frame, GRID.stroke_width(1)))?;
    }
    if let Some(note) = skipped_note {
        let at = (0, bottom + pad);
        legend_area.draw(&Text::new(note, at, text.color(&NOTE)))?;
    }
    Ok(Drawn {
        markers,
        x_axis,
        y_axis,
    })
}

/// Draws `panels` stacked top to bottom, each `width` × `panel_height` pixels.
fn draw_figure<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    panels: &[Panel],
) -> DrawResult<Vec<Drawn>, DB> {
    root.fill(&WHITE_C)?;
    let mut drawn = Vec::with_capacity(panels.len());
    if !panels.is_empty() {
        for (area, panel) in root.split_evenly((panels.len(), 1)).iter().zip(panels) {
            drawn.push(draw_panel(area, &panel.spec, &panel.points)?);
        }
    }
    root.present()?;
    Ok(drawn)
}

fn plot_error<E: std::error::Error + Send + Sync + 'static>(
    e: DrawingAreaErrorKind<E>,
) -> MeasureError {
    MeasureError::Plot(Box::new(e))
}

/// The figure as an RGB image (antialiased text), with where each panel's markers are.
pub fn render_png(
    panels: &[Panel],
    width: u32,
    panel_height: u32,
) -> Result<(RgbImage, Vec<Drawn>), MeasureError> {
    let height = panel_height * panels.len().max(1) as u32;
    let mut buf = vec![255u8; width as usize * height as usize * 3];
    let drawn = {
        let root = BitMapBackend::with_buffer(&mut buf, (width, height)).into_drawing_area();
        draw_figure(root, panels).map_err(plot_error)?
    };
    let img = RgbImage::from_raw(width, height, buf).expect("buffer of width × height × 3");
    Ok((img, drawn))
}

/// The figure as an SVG document (text as text, in the `sans-serif` family).
pub fn render_svg(panels: &[Panel], width: u32, panel_height: u32) -> Result<String, MeasureError> {
    let height = panel_height * panels.len().max(1) as u32;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (width, height)).into_drawing_area();
        draw_figure(root, panels).map_err(plot_error)?;
    }
    Ok(svg)
}

/// Writes the figure as a PNG at `png` and an SVG at `svg`.
pub fn write_figure(
    png: &Path,
    svg: &Path,
    panels: &[Panel],
    width: u32,
    panel_height: u32,
) -> Result<(), MeasureError> {
    let (img, _) = render_png(panels, width, panel_height)?;
    img.save_with_format(png, image::ImageFormat::Png)
        .map_err(|source| MeasureError::Image {
            path: png.to_path_buf(),
            source,
        })?;
    let text = render_svg(panels, width, panel_height)?;
    std::fs::write(svg, text).map_err(|source| MeasureError::Write {
        path: svg.to_path_buf(),
        source,
    })
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
        }
    }

    fn panel(spec: PlotSpec, points: Vec<Point>) -> Panel {
        Panel { spec, points }
    }

    fn rgb(c: RGBColor) -> image::Rgb<u8> {
        image::Rgb([c.0, c.1, c.2])
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
        // Three decades: decades labelled, 2 and 5 ticks unlabelled.
        let axis = Axis {
            lo: 0.08,
            hi: 120.0,
            log: true,
        };
        let t = axis_ticks(&axis, 8.0);
        assert_eq!(labels(&t), ["0.1", "1", "10", "100"]);
        let values: Vec<f64> = t.iter().map(|t| t.value).collect();
        let expected = [0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0];
        assert_eq!(values.len(), expected.len());
        assert!(
            values
                .iter()
                .zip(expected)
                .all(|(a, b)| (a - b).abs() < 1e-12 * b)
        );
        // Under two decades: the 2 and 5 ticks are labelled too.
        let axis = Axis {
            lo: 1.5,
            hi: 60.0,
            log: true,
        };
        assert_eq!(
            labels(&axis_ticks(&axis, 8.0)),
            ["2", "5", "10", "20", "50"]
        );
        // Under one decade: every 1…9 × 10^k.
        let axis = Axis {
            lo: 1.9,
            hi: 8.2,
            log: true,
        };
        assert_eq!(
            labels(&axis_ticks(&axis, 8.0)),
            ["2", "3", "4", "5", "6", "7", "8"]
        );
        // Inside one 1-2-5 step: linear steps.
        let axis = Axis {
            lo: 2.1,
            hi: 2.9,
            log: true,
        };
        let t = labels(&axis_ticks(&axis, 8.0));
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
        // 600 decades with room for 12 ticks: every 50th decade.
        let axis = Axis {
            lo: 1e-300,
            hi: 1e300,
            log: true,
        };
        let t = labels(&axis_ticks(&axis, 12.0));
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

    #[test]
    fn the_embedded_font_parses() {
        assert!(ab_glyph_parses(FONT_BYTES));
    }

    fn ab_glyph_parses(bytes: &'static [u8]) -> bool {
        register_font("globe-test-font", FontStyle::Normal, bytes).is_ok()
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
            let pts = sample();
            let (img, drawn) =
                render_png(&[panel(spec(log_x, log_y), pts.clone())], 800, 560).expect("renders");
            assert_eq!(img.dimensions(), (800, 560));
            let groups = ["alpha", "beta", "gamma", "delta"];
            for (q, m) in pts.iter().zip(&drawn[0].markers) {
                let (x, y) = m.expect("drawable");
                let g = groups.iter().position(|&g| g == q.group).unwrap();
                let c = *img.get_pixel(x as u32, y as u32);
                assert_eq!(c, rgb(group_style(g).colour), "{}", q.label);
            }
            assert_eq!(*img.get_pixel(0, 0), rgb(WHITE_C));
            assert_eq!(*img.get_pixel(799, 559), rgb(WHITE_C));
        }
    }

    #[test]
    fn the_front_is_drawn_between_its_points() {
        let pts = sample();
        let (img, drawn) = render_png(&[panel(spec(true, true), pts.clone())], 800, 560).unwrap();
        // Front: b1 (1, 6) → a1 (2, 3) → a2 (8, 1) → c1 (20, 0.3); a2 → c1 is long.
        assert_eq!(pareto_front(&pts), vec![2, 0, 1, 4]);
        let (a, b) = (drawn[0].markers[1].unwrap(), drawn[0].markers[4].unwrap());
        let (mx, my) = ((a.0 + b.0) / 2, (a.1 + b.1) / 2);
        let front_near = (-1..=1)
            .flat_map(|dy| (-1..=1).map(move |dx| (mx + dx, my + dy)))
            .any(|(x, y)| *img.get_pixel(x as u32, y as u32) == rgb(FRONT));
        assert!(front_near);
        // A dominated point (b2) has no front through it: nothing crimson at its ring.
        let (x, y) = drawn[0].markers[3].unwrap();
        let r = 9;
        let crimson = (-r..=r)
            .flat_map(|dy| (-r..=r).map(move |dx| (x + dx, y + dy)))
            .filter(|&(x, y)| *img.get_pixel(x as u32, y as u32) == rgb(FRONT))
            .count();
        assert_eq!(crimson, 0);
    }

    /// Text is antialiased: the labels leave grey levels between the ink and the paper.
    #[test]
    fn text_is_antialiased() {
        let only_text = PlotSpec {
            title: "Antialiased title text".into(),
            ..spec(false, false)
        };
        let (img, _) = render_png(&[panel(only_text, vec![])], 600, 300).unwrap();
        // The title's band: above the plot area, all text.
        let mut levels = std::collections::BTreeSet::new();
        for y in 0..30 {
            for x in 0..600 {
                let c = img.get_pixel(x, y);
                if c[0] == c[1] && c[1] == c[2] {
                    levels.insert(c[0]);
                }
            }
        }
        assert!(levels.len() > 20, "grey levels in the title: {levels:?}");
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
                let (img, drawn) =
                    render_png(&[panel(spec(log_x, log_y), pts.clone())], 640, 400).expect(name);
                assert_eq!(img.dimensions(), (640, 400), "{name}");
                for (q, m) in pts.iter().zip(&drawn[0].markers) {
                    let finite = q.x.is_finite() && q.y.is_finite();
                    assert_eq!(m.is_some(), finite, "{name}");
                    if let Some((x, y)) = *m {
                        assert!((0..640).contains(&x) && (0..400).contains(&y), "{name}");
                        assert_ne!(*img.get_pixel(x as u32, y as u32), rgb(WHITE_C), "{name}");
                    }
                }
                render_svg(&[panel(spec(log_x, log_y), pts.clone())], 640, 400).expect(name);
            }
        }
        // Zero on a log axis: that axis falls back to linear and says so.
        let pts = xy(&[(0.0, 1.0), (3.0, 2.0)]);
        let (_, drawn) = render_png(&[panel(spec(true, true), pts)], 640, 400).unwrap();
        assert!(!drawn[0].x_axis.log && drawn[0].y_axis.log);
    }

    /// Writes the example of the report's plot, 12 settings in 4 groups, log-log, as PNG and
    /// SVG; both read back.
    #[test]
    fn writes_the_example_png_and_svg() {
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
        };
        let dir = tempfile::tempdir().unwrap();
        let (png, svg) = (dir.path().join("plot.png"), dir.path().join("plot.svg"));
        write_figure(&png, &svg, &[panel(spec, pts)], 1100, 620).unwrap();
        let back = image::open(&png).unwrap();
        assert_eq!((back.width(), back.height()), (1100, 620));
        let text = std::fs::read_to_string(&svg).unwrap();
        assert!(text.starts_with("<svg") && text.contains("ε=0.5") && text.contains("ray march"));
        if let Ok(keep) = std::env::var("GLOBE_PLOT_EXAMPLE") {
            std::fs::copy(&png, format!("{keep}.png")).unwrap();
            std::fs::copy(&svg, format!("{keep}.svg")).unwrap();
        }
    }
}
