//! The soak's trace plot: memory, caches and frame times against the soak's clock, with the
//! settle points marked.

use std::path::Path;

use super::{SoakFrame, SoakRun, mib};
use crate::measure::MeasureError;

impl SoakRun {
    /// The memory trace as a PNG: camera height, anonymous RSS, the decoded-tile cache and
    /// the GPU tiles against wall time, each with its budget; settle points as ticks.
    pub fn write_plot(&self, png: &Path) -> Result<(), MeasureError> {
        let (w, h) = (1200u32, 1000u32);
        let mut buf = vec![255u8; (w * h * 3) as usize];
        draw_trace(self, &mut buf, w, h).map_err(|e| MeasureError::Plot(e.to_string().into()))?;
        let img = image::RgbImage::from_raw(w, h, buf).expect("buffer of w × h × 3");
        img.save_with_format(png, image::ImageFormat::Png)
            .map_err(|source| MeasureError::Image {
                path: png.to_path_buf(),
                source,
            })
    }
}

fn draw_trace(
    run: &SoakRun,
    buf: &mut [u8],
    w: u32,
    h: u32,
) -> Result<(), Box<dyn std::error::Error>> {
    use plotters::prelude::*;
    crate::instruments::plot::register_embedded_font();
    let font = crate::instruments::plot::FONT;
    let root = BitMapBackend::with_buffer(buf, (w, h)).into_drawing_area();
    root.fill(&WHITE)?;
    let findings = run.findings();
    let t_max = run.wall_s.max(1e-3);
    let title = format!(
        "soak: seed {}, {:.0} s flown ({:.0} s wall), {} frames, {} settle points ({} differ), \
         {} frames read the file",
        run.options.seed,
        findings.flown_s,
        run.wall_s,
        findings.frames,
        findings.settle_points,
        findings.settle_points_differing,
        findings.frames_reading_the_file
    );
    let (top, rest) = root.split_vertically(40);
    top.draw(&Text::new(title, (10, 10), (font, 18).into_font()))?;
    let panels = rest.split_evenly((4, 1));
    let settle_ticks: Vec<f64> = run.settles.iter().map(|p| p.wall_s).collect();
    let line = |area: &DrawingArea<BitMapBackend, plotters::coord::Shift>,
                caption: &str,
                series: Vec<(f64, f64)>,
                budget: Option<f64>,
                log: bool|
     -> Result<(), Box<dyn std::error::Error>> {
        let finite = series.iter().map(|p| p.1).filter(|v| v.is_finite());
        let mut y_max = finite.clone().fold(0.0f64, f64::max);
        if let Some(b) = budget {
            y_max = y_max.max(b);
        }
        let y_max = (y_max * 1.1).max(1e-3);
        let mut chart = ChartBuilder::on(area);
        chart
            .caption(caption, (font, 16).into_font())
            .margin(8)
            .x_label_area_size(28)
            .y_label_area_size(70);
        let style = (font, 13).into_font();
        if log {
            let y_min = finite.fold(f64::INFINITY, f64::min).max(0.1);
            let mut c = chart.build_cartesian_2d(0.0..t_max, (y_min..y_max).log_scale())?;
            c.configure_mesh()
                .label_style(style.clone())
                .x_desc("wall time, s")
                .light_line_style(TRANSPARENT)
                .y_labels(8)
                .y_label_formatter(&|v| format!("{v:.0e}"))
                .draw()?;
            for &t in &settle_ticks {
                c.draw_series(LineSeries::new([(t, y_min), (t, y_max)], BLUE.mix(0.25)))?;
            }
            c.draw_series(LineSeries::new(series, BLACK.stroke_width(1)))?;
        } else {
            let mut c = chart.build_cartesian_2d(0.0..t_max, 0.0..y_max)?;
            c.configure_mesh()
                .label_style(style.clone())
                .x_desc("wall time, s")
                .light_line_style(TRANSPARENT)
                .draw()?;
            for &t in &settle_ticks {
                c.draw_series(LineSeries::new([(t, 0.0), (t, y_max)], BLUE.mix(0.25)))?;
            }
            if let Some(b) = budget {
                c.draw_series(LineSeries::new([(0.0, b), (t_max, b)], RED.stroke_width(2)))?;
            }
            c.draw_series(LineSeries::new(series, BLACK.stroke_width(1)))?;
        }
        Ok(())
    };
    let series = |f: &dyn Fn(&SoakFrame) -> Option<f64>| -> Vec<(f64, f64)> {
        run.frames
            .iter()
            .filter_map(|fr| f(fr).map(|v| (fr.wall_s, v)))
            .collect()
    };
    line(
        &panels[0],
        "camera height above the sphere, m (blue: settle points)",
        series(&|f| Some(f.altitude_m.max(0.1))),
        None,
        true,
    )?;
    line(
        &panels[1],
        "anonymous RSS, MiB (red: the second half's budget)",
        series(&|f| f.rss.map(|r| mib(r.anon))),
        findings.rss_anon_budget.map(mib),
        false,
    )?;
    line(
        &panels[2],
        "decoded-tile cache, MiB (red: --cache-mb)",
        series(&|f| Some(mib(f.cache_bytes))),
        Some(mib(findings.cache_budget)),
        false,
    )?;
    line(
        &panels[3],
        "GPU tiles resident (red: --gpu-tiles)",
        series(&|f| Some(f.gpu_tiles as f64)),
        Some(findings.gpu_capacity as f64),
        false,
    )?;
    root.present()?;
    Ok(())
}
