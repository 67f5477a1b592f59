//! The terrain profile's figure (`globe profile --plot`): height against distance along the
//! great circle, the ground filled below the line, and the totals in the title.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::{AXIS, FONT, GRID, GRID_MINOR, TEXT, plot_error, register_embedded_font};
use crate::measure::{MeasureError, Profile};

/// Earth brown for the line and a light tint of it for the ground below.
const LINE: RGBColor = RGBColor(120, 72, 30);
const GROUND: RGBColor = RGBColor(232, 214, 190);

/// The y range: the profile's heights padded by 5 % (±10 m when it is flat), so the line
/// never lies on the frame.
fn height_axis(profile: &Profile) -> (f64, f64) {
    let (lo, hi) = profile.height_range_m();
    if !(lo.is_finite() && hi.is_finite()) {
        return (0.0, 1.0);
    }
    let pad = if hi > lo { 0.05 * (hi - lo) } else { 10.0 };
    (lo - pad, hi + pad)
}

/// Kilometres along the axis once the profile is longer than 10 km, metres below.
fn distance_unit(profile: &Profile) -> (f64, &'static str) {
    if profile.great_circle_m >= 10_000.0 {
        (1e-3, "km")
    } else {
        (1.0, "m")
    }
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    profile: &Profile,
) -> Result<(), MeasureError>
where
    DB::ErrorType: 'static,
{
    register_embedded_font();
    let (w, h) = root.dim_in_pixel();
    let unit = f64::from(w.min(2 * h)).max(200.0) / 1100.0;
    let px = |v: f64| (v * unit).round().max(1.0) as u32;
    let text = (FONT, 15.0 * unit).into_font().color(&TEXT);
    root.fill(&WHITE).map_err(plot_error)?;
    let (scale, unit_name) = distance_unit(profile);
    let (y_lo, y_hi) = height_axis(profile);
    let x_hi = (profile.great_circle_m * scale).max(f64::MIN_POSITIVE);
    let (lo, hi) = profile.height_range_m();
    let title = format!(
        "Terrain profile: {:.3} {unit_name} along the great circle, {:.3} {unit_name} along the terrain, heights {lo:.1} … {hi:.1} m",
        profile.great_circle_m * scale,
        profile.along_terrain_m * scale
    );
    let mut chart = ChartBuilder::on(&root)
        .caption(title, (FONT, 17.0 * unit).into_font().color(&TEXT))
        .margin(px(12.0))
        .margin_right(px(36.0))
        .x_label_area_size(px(52.0))
        .y_label_area_size(px(80.0))
        .build_cartesian_2d(0.0..x_hi, y_lo..y_hi)
        .map_err(plot_error)?;
    // Whole units where the axis spans enough of them.
    let decimals = |span: f64| {
        if span >= 20.0 {
            0
        } else if span >= 2.0 {
            1
        } else {
            3
        }
    };
    let (xd, yd) = (decimals(x_hi), decimals(y_hi - y_lo));
    let x_fmt = move |v: &f64| format!("{v:.xd$}");
    let y_fmt = move |v: &f64| format!("{v:.yd$}");
    chart
        .configure_mesh()
        .x_label_formatter(&x_fmt)
        .y_label_formatter(&y_fmt)
        .bold_line_style(GRID.stroke_width(1))
        .light_line_style(GRID_MINOR.stroke_width(1))
        .axis_style(AXIS.stroke_width(1))
        .label_style(text.clone())
        .axis_desc_style(text.clone())
        .x_desc(format!("distance along the great circle ({unit_name})"))
        .y_desc("height (m)")
        .draw()
        .map_err(plot_error)?;
    let line: Vec<(f64, f64)> = (profile.points.iter())
        .map(|p| (p.distance_m * scale, p.height_m))
        .collect();
    let mut ground = line.clone();
    ground.push((x_hi, y_lo));
    ground.push((0.0, y_lo));
    chart
        .draw_series(std::iter::once(Polygon::new(ground, GROUND.filled())))
        .map_err(plot_error)?;
    chart
        .draw_series(LineSeries::new(line, LINE.stroke_width(px(2.0).max(2))))
        .map_err(plot_error)?;
    root.present().map_err(plot_error)?;
    Ok(())
}

/// The profile's figure as an RGB image of `width` × `height` pixels.
pub fn profile_png(
    profile: &Profile,
    width: u32,
    height: u32,
) -> Result<image::RgbImage, MeasureError> {
    let mut buf = vec![255u8; width as usize * height as usize * 3];
    draw(
        BitMapBackend::with_buffer(&mut buf, (width, height)).into_drawing_area(),
        profile,
    )?;
    Ok(image::RgbImage::from_raw(width, height, buf).expect("buffer of width × height × 3"))
}

/// The profile's figure as an SVG document.
pub fn profile_svg(profile: &Profile, width: u32, height: u32) -> Result<String, MeasureError> {
    let mut svg = String::new();
    draw(
        SVGBackend::with_string(&mut svg, (width, height)).into_drawing_area(),
        profile,
    )?;
    Ok(svg)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measure::ProfilePoint;

    fn ridge() -> Profile {
        let points = (0..=100)
            .map(|k| ProfilePoint {
                distance_m: 1000.0 * f64::from(k),
                lat_deg: 0.0,
                lon_deg: 0.0,
                height_m: 2000.0 - 20.0 * f64::from((k - 50i32).abs()),
            })
            .collect();
        Profile {
            points,
            great_circle_m: 100_000.0,
            along_terrain_m: 100_080.0,
        }
    }

    /// The ground is drawn where the heights are: under the summit (the middle of the
    /// distance axis) the ground tint reaches far higher than near the ends, and the column
    /// through the summit holds the line's colour just above the ground.
    #[test]
    fn the_ridge_is_drawn_where_its_heights_are() {
        let img = profile_png(&ridge(), 800, 400).unwrap();
        let ground_rows = |x: u32| -> Vec<u32> {
            (0..img.height())
                .filter(|&y| img.get_pixel(x, y).0 == [GROUND.0, GROUND.1, GROUND.2])
                .collect()
        };
        let cols: Vec<u32> = (0..img.width())
            .filter(|&x| !ground_rows(x).is_empty())
            .collect();
        let (x0, x1) = (*cols.first().unwrap(), *cols.last().unwrap());
        let mid = ground_rows((x0 + x1) / 2);
        let end = ground_rows(x0 + 3);
        // 2000 m against 1000 m on a 1000…2000 m axis padded by 5 %: the summit's ground is
        // about ten times as tall.
        assert!(mid.len() > 5 * end.len(), "{} vs {}", mid.len(), end.len());
        let top = *mid.first().unwrap();
        let above: Vec<[u8; 3]> = (top.saturating_sub(4)..top)
            .map(|y| img.get_pixel((x0 + x1) / 2, y).0)
            .collect();
        assert!(
            above
                .iter()
                .any(|p| p.iter().map(|&c| u32::from(c)).sum::<u32>() < 450),
            "no dark line above the ground: {above:?}"
        );
    }

    #[test]
    fn the_svg_holds_the_line_and_the_totals() {
        let svg = profile_svg(&ridge(), 800, 400).unwrap();
        assert!(svg.contains("<polyline"), "{svg}");
        assert!(svg.contains("100.000 km along the great circle"), "{svg}");
        assert!(svg.contains("100.080 km along the terrain"), "{svg}");
    }
}
