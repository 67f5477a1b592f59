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
use plotters::prelude::*;
use plotters::style::{FontStyle, RGBColor, register_font};

use crate::measure::MeasureError;

mod axes;
pub mod profile;

pub use axes::Axis;
use axes::{TickedAxis, resolve_axis};
pub use profile::{profile_png, profile_svg};

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
    let s = Scale::of(w, h);
    let text = s.font(15.0).color(&TEXT);
    let contents = Contents::of(spec, points);
    let legend = Legend::measure(area, &contents, points.len(), s, &text)?;
    let chart_w = (w as i32 - legend.width).max(w as i32 / 2) as u32;
    let (chart_area, legend_area) = area.split_horizontally(chart_w);
    let chart = draw_chart(&chart_area, spec, &contents, (chart_w, h), s, &text)?;
    let markers = marker_centres(points, &contents, &chart);
    let front: Vec<(i32, i32)> = (pareto_front(points).into_iter())
        .filter_map(|i| markers[i])
        .collect();
    // Everything from here is drawn in pixels of the panel.
    let origin = area.get_base_pixel();
    draw_front_and_markers(area, origin, points, &contents.groups, &markers, &front, s)?;
    let (xr, yr) = chart.plotting_area().get_pixel_range();
    let plot_rect = Rect::new(xr.start, yr.start, xr.end - xr.start, yr.end - yr.start);
    draw_labels(area, origin, points, &markers, &front, plot_rect, s)?;
    if contents.valid.is_empty() {
        draw_no_data(area, origin, (xr, yr.clone()), s)?;
    }
    legend.draw(&legend_area, yr.start - origin.1, s, &text)?;
    Ok(Drawn {
        markers,
        x_axis: contents.x_axis,
        y_axis: contents.y_axis,
    })
}

/// A panel's sizes follow its size (15 px text on a 1100 × 620 panel), so that one figure
/// reads the same drawn small or large.
#[derive(Clone, Copy, Debug)]
struct Scale {
    unit: f64,
}

impl Scale {
    fn of(w: u32, h: u32) -> Self {
        Self {
            unit: f64::from(w.min(2 * h)).max(200.0) / 1100.0,
        }
    }

    /// `v` design pixels in the panel's pixels, at least one.
    fn px(self, v: f64) -> i32 {
        (v * self.unit).round().max(1.0) as i32
    }

    /// The plots' font at `size` design pixels.
    fn font(self, size: f64) -> FontDesc<'static> {
        (FONT, size * self.unit).into_font()
    }

    /// A marker's radius.
    fn marker_r(self) -> f64 {
        6.0 * self.unit
    }

    /// The radius of the ring round a front point: just outside its marker.
    fn ring_r(self) -> f64 {
        self.marker_r() + 3.0 * self.unit
    }

    /// The ring that marks a point of the front, centred at `c`.
    fn ring(self, c: (i32, i32)) -> Circle<(i32, i32), i32> {
        Circle::new(c, self.ring_r().round() as i32, FRONT.stroke_width(2))
    }

    /// The Pareto front's line.
    fn front_style(self) -> ShapeStyle {
        FRONT.stroke_width(self.px(3.0) as u32)
    }
}

/// What a panel shows of its points, worked out before anything is drawn: which points can
/// be drawn, the axes they span and the groups they fall in, in order of first appearance.
struct Contents<'p> {
    /// Indices of the points with finite coordinates.
    valid: Vec<usize>,
    x_axis: Axis,
    x_fell_back: bool,
    y_axis: Axis,
    y_fell_back: bool,
    groups: Vec<&'p str>,
}

impl<'p> Contents<'p> {
    fn of(spec: &PlotSpec, points: &'p [Point]) -> Self {
        let valid: Vec<usize> = (0..points.len())
            .filter(|&i| points[i].x.is_finite() && points[i].y.is_finite())
            .collect();
        let xs: Vec<f64> = valid.iter().map(|&i| points[i].x).collect();
        let ys: Vec<f64> = valid.iter().map(|&i| points[i].y).collect();
        let (x_axis, x_fell_back) = resolve_axis(&xs, spec.log_x);
        let (y_axis, y_fell_back) = resolve_axis(&ys, spec.log_y);
        let mut groups: Vec<&str> = Vec::new();
        for &i in &valid {
            if !groups.contains(&points[i].group.as_str()) {
                groups.push(&points[i].group);
            }
        }
        Self {
            valid,
            x_axis,
            x_fell_back,
            y_axis,
            y_fell_back,
            groups,
        }
    }
}

/// An axis title, saying so where a log axis fell back to linear.
fn axis_title(t: &str, fell_back: bool) -> String {
    match fell_back {
        true => format!("{t} (linear: values <= 0)")
            .trim_start()
            .to_string(),
        false => t.to_string(),
    }
}

/// The legend's column right of the chart: its lines (one per group, then the front), the
/// note on skipped points, and its width, measured before the chart takes the rest.
struct Legend {
    entries: Vec<String>,
    groups: usize,
    skipped_note: Option<String>,
    symbol_w: i32,
    pad: i32,
    /// As wide as its longest line; 0 with no lines.
    width: i32,
}

impl Legend {
    fn measure<DB: DrawingBackend>(
        area: &DrawingArea<DB, Shift>,
        contents: &Contents<'_>,
        points: usize,
        s: Scale,
        text: &TextStyle<'_>,
    ) -> DrawResult<Self, DB> {
        let skipped = points - contents.valid.len();
        let mut entries: Vec<String> = (contents.groups.iter())
            .map(|g| match g.is_empty() {
                true => "(no group)".to_string(),
                false => g.to_string(),
            })
            .collect();
        if !contents.valid.is_empty() {
            entries.push("Pareto front".into());
        }
        let skipped_note = match skipped {
            0 => None,
            1 => Some("1 point skipped (not finite)".to_string()),
            n => Some(format!("{n} points skipped (not finite)")),
        };
        let symbol_w = s.px(36.0);
        let pad = s.px(8.0);
        let mut legend_text_w = 0;
        for e in entries.iter().chain(skipped_note.as_ref()) {
            legend_text_w = legend_text_w.max(area.estimate_text_size(e, text)?.0 as i32);
        }
        let width = match legend_text_w {
            0 => 0,
            t => 4 * pad + symbol_w + t,
        };
        Ok(Self {
            entries,
            groups: contents.groups.len(),
            skipped_note,
            symbol_w,
            pad,
            width,
        })
    }

    /// One row per group, then the front, framed, with the skipped note under the frame;
    /// `top` is the plotting area's top, in the legend's pixels.
    fn draw<DB: DrawingBackend>(
        self,
        legend_area: &DrawingArea<DB, Shift>,
        top: i32,
        s: Scale,
        text: &TextStyle<'_>,
    ) -> DrawResult<(), DB> {
        let (pad, symbol_w) = (self.pad, self.symbol_w);
        let row_h = s.px(26.0);
        let (sym_x, text_x) = (pad + symbol_w / 2, 2 * pad + symbol_w);
        let centred = text.pos(plotters::style::text_anchor::Pos::new(
            plotters::style::text_anchor::HPos::Left,
            plotters::style::text_anchor::VPos::Center,
        ));
        for (row, entry) in self.entries.iter().enumerate() {
            let cy = top + pad + row as i32 * row_h + row_h / 2;
            if row < self.groups {
                draw_marker(legend_area, (sym_x, cy), s.marker_r(), group_style(row))?;
            } else {
                let half = symbol_w / 2;
                let line = vec![(sym_x - half, cy), (sym_x + half, cy)];
                legend_area.draw(&PathElement::new(line, s.front_style()))?;
                legend_area.draw(&s.ring((sym_x, cy)))?;
            }
            legend_area.draw(&Text::new(entry.clone(), (text_x, cy), centred.clone()))?;
        }
        let bottom = top + 2 * pad + self.entries.len() as i32 * row_h;
        if !self.entries.is_empty() {
            let frame = [(0, top), (self.width - pad - 1, bottom)];
            legend_area.draw(&Rectangle::new(frame, GRID.stroke_width(1)))?;
        }
        if let Some(note) = self.skipped_note {
            let at = (0, bottom + pad);
            legend_area.draw(&Text::new(note, at, text.color(&NOTE)))?;
        }
        Ok(())
    }
}

/// The chart `plotters` maps the points through.
type PanelChart<'c, DB> = ChartContext<'c, DB, Cartesian2d<TickedAxis, TickedAxis>>;

/// The chart's frame on `chart_area` (`size` its pixels): caption, grid, ticked axes and
/// their titles. The chart comes back to map the points through.
fn draw_chart<'c, DB: DrawingBackend>(
    chart_area: &DrawingArea<DB, Shift>,
    spec: &PlotSpec,
    contents: &Contents<'_>,
    (chart_w, h): (u32, u32),
    s: Scale,
    text: &TextStyle<'_>,
) -> DrawResult<PanelChart<'c, DB>, DB> {
    let unit = s.unit;
    let x = TickedAxis::new(contents.x_axis, f64::from(chart_w) / (110.0 * unit));
    let y = TickedAxis::new(contents.y_axis, f64::from(h) / (70.0 * unit));
    let mut chart = ChartBuilder::on(chart_area)
        .caption(&spec.title, s.font(20.0).color(&TEXT))
        .margin(s.px(10.0))
        .x_label_area_size(s.px(52.0))
        .y_label_area_size(s.px(74.0))
        .build_cartesian_2d(x.clone(), y.clone())?;
    let (x_fmt, y_fmt) = (|v: &f64| x.label(*v), |v: &f64| y.label(*v));
    chart
        .configure_mesh()
        .bold_line_style(GRID.stroke_width(1))
        .light_line_style(GRID_MINOR.stroke_width(1))
        .axis_style(AXIS.stroke_width(1))
        .label_style(text.clone())
        .axis_desc_style(text.clone())
        .x_desc(axis_title(&spec.x_label, contents.x_fell_back))
        .y_desc(axis_title(&spec.y_label, contents.y_fell_back))
        .x_label_formatter(&x_fmt)
        .y_label_formatter(&y_fmt)
        .x_max_light_lines(12)
        .y_max_light_lines(12)
        .draw()?;
    Ok(chart)
}

/// Each point's marker centre in the whole image; None for a point that was skipped or
/// cannot be drawn on an axis.
fn marker_centres<DB: DrawingBackend>(
    points: &[Point],
    contents: &Contents<'_>,
    chart: &PanelChart<'_, DB>,
) -> Vec<Option<(i32, i32)>> {
    (0..points.len())
        .map(|i| {
            let q = &points[i];
            let drawable = contents.valid.contains(&i) && contents.x_axis.fraction(q.x).is_some();
            (drawable && contents.y_axis.fraction(q.y).is_some())
                .then(|| chart.backend_coord(&(q.x, q.y)))
        })
        .collect()
}

/// `c` (pixels of the whole image) in pixels of the panel whose top-left is `origin`.
fn local((ox, oy): (i32, i32), (x, y): (i32, i32)) -> (i32, i32) {
    (x - ox, y - oy)
}

/// The front under the markers, so that every marker stays whole; rings over them.
fn draw_front_and_markers<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    origin: (i32, i32),
    points: &[Point],
    groups: &[&str],
    markers: &[Option<(i32, i32)>],
    front: &[(i32, i32)],
    s: Scale,
) -> DrawResult<(), DB> {
    area.draw(&PathElement::new(
        front.iter().map(|&c| local(origin, c)).collect::<Vec<_>>(),
        s.front_style(),
    ))?;
    let style_of = |g: &str| group_style(groups.iter().position(|x| *x == g).unwrap_or(0));
    for (i, m) in markers.iter().enumerate() {
        if let Some(c) = *m {
            draw_marker(
                area,
                local(origin, c),
                s.marker_r(),
                style_of(&points[i].group),
            )?;
        }
    }
    for &c in front {
        area.draw(&s.ring(local(origin, c)))?;
    }
    Ok(())
}

/// Each drawn point's label, placed by [`place_labels`] clear of the rings, the front and
/// the other labels within the plotting area `plot_rect`.
fn draw_labels<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    origin: (i32, i32),
    points: &[Point],
    markers: &[Option<(i32, i32)>],
    front: &[(i32, i32)],
    plot_rect: Rect,
    s: Scale,
) -> DrawResult<(), DB> {
    let label_text = &s.font(13.0).color(&LABEL);
    let mut sizes = Vec::with_capacity(points.len());
    for (q, m) in points.iter().zip(markers) {
        let (lw, lh) = match (m, q.label.is_empty()) {
            (Some(_), false) => area.estimate_text_size(&q.label, label_text)?,
            _ => (0, 0),
        };
        sizes.push((lw as i32, lh as i32));
    }
    let clearance = s.ring_r().ceil() as i32 + 1;
    let labels = place_labels(markers, front, &sizes, clearance, plot_rect);
    for (q, at) in points.iter().zip(labels) {
        if let (Some(at), false) = (at, q.label.is_empty()) {
            area.draw(&Text::new(
                q.label.clone(),
                local(origin, at),
                label_text.clone(),
            ))?;
        }
    }
    Ok(())
}

/// An empty panel says so, centred on its plotting area (`xr`, `yr`).
fn draw_no_data<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    origin: (i32, i32),
    (xr, yr): (Range<i32>, Range<i32>),
    s: Scale,
) -> DrawResult<(), DB> {
    let note = s
        .font(20.0)
        .color(&NOTE)
        .pos(plotters::style::text_anchor::Pos::new(
            plotters::style::text_anchor::HPos::Center,
            plotters::style::text_anchor::VPos::Center,
        ));
    let centre = ((xr.start + xr.end) / 2, (yr.start + yr.end) / 2);
    area.draw(&Text::new("no data", local(origin, centre), note))?;
    Ok(())
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
