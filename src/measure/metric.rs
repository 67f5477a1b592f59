//! The per-pixel error metric of docs/design.md#measuring, from a rendered frame's depth:
//!
//! surface point p (reversed-Z depth → view space) → (φ, θ, h) → δ = |h − h_true(φ, θ)| →
//! ρ = λ·δ/‖p − e‖ pixels,
//!
//! the object-space error of `error-bounded-projective-grid.md` eq. 2, measured against the
//! terrain function rather than bounded by min/max, projected as its eq. 3 does. λ is the
//! focal length in pixels, (H/2)/tan(fov_y/2): pixels per radian at the image centre (the
//! paper's w/φ; about 10 % below H/fov_y at 60°).
//!
//! δ is the vertical error at the rendered point's (φ, θ), so ρ is defined for every rendered
//! terrain pixel, also where the reference sees sky. Coverage mismatches against the reference
//! ray caster are counted separately, in pixels.

use std::path::Path;

use glam::DVec3;

use super::MeasureError;
use super::reference::{HeightField, ReferenceImage, ReferencePixel};
use crate::geo::camera::Camera;
use crate::geo::projection::{camera_from_clip, camera_point_from_ndc};
use crate::render::offscreen::RenderedFrame;

/// The paper's threshold γ for "error pixels" (its Table 1 counts ρ > γ), by default 1 px.
pub const DEFAULT_THRESHOLD_PX: f64 = 1.0;

/// λ of eq. 3: pixels per radian at the centre of an image (the focal length in pixels).
pub use crate::geo::projection::focal_length_px as pixels_per_radian;

/// The surface point under pixel (x, y) in view space (planet centre at the origin), from the
/// frame's reversed-Z depth; None where it shows sky (depth 0).
pub fn surface_point_view_m(
    frame: &RenderedFrame,
    camera: &Camera,
    radius_m: f64,
    x: u32,
    y: u32,
) -> Option<DVec3> {
    let depth = f64::from(frame.depth_at(x, y));
    if depth <= 0.0 {
        return None;
    }
    let aspect = f64::from(frame.width) / f64::from(frame.height);
    let ndc = DVec3::new(
        (f64::from(x) + 0.5) / f64::from(frame.width) * 2.0 - 1.0,
        1.0 - (f64::from(y) + 0.5) / f64::from(frame.height) * 2.0,
        depth,
    );
    let camera_from_clip = camera_from_clip(camera.fov_y_rad(), aspect, frame.info.near_m);
    let point_camera_m = camera_point_from_ndc(&camera_from_clip, ndc);
    Some(camera.eye_view_at_radius_m(radius_m) + camera.view_from_camera() * point_camera_m)
}

/// One rendered pixel against the terrain function.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelError {
    pub point_view_m: DVec3,
    /// Rendered height above the sphere, |p| − R.
    pub height_m: f64,
    /// The terrain function at the rendered point's (φ, θ).
    pub true_height_m: f64,
    /// δ (eq. 2, measured): |height − true height|.
    pub delta_m: f64,
    /// ‖p − e‖.
    pub distance_m: f64,
    /// ρ (eq. 3): λ·δ/‖p − e‖.
    pub rho_px: f64,
}

/// The error of pixel (x, y) of `frame`, rendered from `camera` over `field`; None for sky.
pub fn pixel_error<H: HeightField + ?Sized>(
    frame: &RenderedFrame,
    camera: &Camera,
    field: &H,
    x: u32,
    y: u32,
) -> Option<PixelError> {
    let radius_m = field.radius_m();
    let world_from_view = camera.view_frame().world_from_view;
    let lambda = pixels_per_radian(frame.height, camera.fov_y_rad());
    let point_view_m = surface_point_view_m(frame, camera, radius_m, x, y)?;
    Some(error_at(
        field,
        point_view_m,
        camera.eye_view_at_radius_m(radius_m),
        world_from_view,
        lambda,
    ))
}

fn error_at<H: HeightField + ?Sized>(
    field: &H,
    point_view_m: DVec3,
    eye_view_m: DVec3,
    world_from_view: glam::DMat3,
    lambda: f64,
) -> PixelError {
    let r = point_view_m.length();
    let height_m = r - field.radius_m();
    let viewer_u = world_from_view * DVec3::Z;
    let true_height_m = field.height_seen_m(world_from_view * (point_view_m / r), viewer_u);
    let delta_m = (height_m - true_height_m).abs();
    let distance_m = (point_view_m - eye_view_m).length();
    PixelError {
        point_view_m,
        height_m,
        true_height_m,
        delta_m,
        distance_m,
        rho_px: lambda * delta_m / distance_m,
    }
}

/// ρ of every pixel, row-major from the top-left; NaN where the frame shows sky. For an error
/// heat-map overlay ([`heat_rgb`], [`write_heat_map_png`]).
pub fn rho_image<H: HeightField + ?Sized>(
    frame: &RenderedFrame,
    camera: &Camera,
    field: &H,
) -> Vec<f32> {
    let radius_m = field.radius_m();
    let eye_view_m = camera.eye_view_at_radius_m(radius_m);
    let world_from_view = camera.view_frame().world_from_view;
    let lambda = pixels_per_radian(frame.height, camera.fov_y_rad());
    let mut rho = Vec::with_capacity(frame.depth.len());
    for y in 0..frame.height {
        for x in 0..frame.width {
            rho.push(match surface_point_view_m(frame, camera, radius_m, x, y) {
                // Narrowed for the image only; statistics are taken in f64 from it.
                Some(p) => error_at(field, p, eye_view_m, world_from_view, lambda).rho_px,
                None => f64::NAN,
            } as f32);
        }
    }
    rho
}

/// Coverage of a frame against the reference, over the pixels the reference cast.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Coverage {
    /// Pixels the reference cast.
    pub compared: usize,
    /// Rendered terrain where the reference sees sky.
    pub terrain_where_reference_sky: usize,
    /// Rendered sky where the reference sees terrain.
    pub sky_where_reference_terrain: usize,
    /// March steps the reference took ([`ReferenceImage::steps`]): its cost, free of the
    /// machine's speed.
    pub reference_steps: u64,
}

impl Coverage {
    pub fn mismatched(&self) -> usize {
        self.terrain_where_reference_sky + self.sky_where_reference_terrain
    }

    /// Compares `frame`'s depth (0 = sky) with `reference` pixel by pixel.
    pub fn of(frame: &RenderedFrame, reference: &ReferenceImage) -> Result<Self, MeasureError> {
        if (reference.width, reference.height) != (frame.width, frame.height) {
            return Err(MeasureError::SizeMismatch {
                what: "the reference",
                actual_w: reference.width,
                actual_h: reference.height,
                expected_w: frame.width,
                expected_h: frame.height,
            });
        }
        let mut c = Coverage {
            reference_steps: reference.steps,
            ..Coverage::default()
        };
        for (reference, depth) in reference.pixels.iter().zip(&frame.depth) {
            let rendered_terrain = *depth > 0.0;
            match reference {
                ReferencePixel::NotCast => continue,
                ReferencePixel::Sky if rendered_terrain => c.terrain_where_reference_sky += 1,
                ReferencePixel::Terrain { .. } if !rendered_terrain => {
                    c.sky_where_reference_terrain += 1
                }
                _ => {}
            }
            c.compared += 1;
        }
        Ok(c)
    }
}

/// Statistics of one frame: the paper's Table 1 columns (error pixels, average and maximum
/// error) plus p99 and the coverage.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorStats {
    /// Rendered terrain pixels (ρ is defined for each).
    pub pixels_measured: usize,
    pub mean_px: f64,
    /// The 99th percentile (nearest rank).
    pub p99_px: f64,
    pub max_px: f64,
    /// γ of [`ErrorStats::error_pixels`].
    pub threshold_px: f64,
    /// Pixels with ρ > γ (the paper's "error pixels").
    pub error_pixels: usize,
    /// error_pixels / pixels_measured (the paper reports it in %).
    pub error_pixel_share: f64,
    /// Against the reference, when one was given.
    pub coverage: Option<Coverage>,
}

impl ErrorStats {
    /// Statistics of a ρ image (NaN: sky, skipped) against threshold γ = `threshold_px`.
    pub fn of_rho(rho_px: &[f32], threshold_px: f64) -> Self {
        let mut rho: Vec<f64> = rho_px
            .iter()
            .filter(|r| !r.is_nan())
            .map(|&r| f64::from(r))
            .collect();
        let n = rho.len();
        let (mean_px, p99_px, max_px) = if n == 0 {
            (f64::NAN, f64::NAN, f64::NAN)
        } else {
            let mean = rho.iter().sum::<f64>() / n as f64;
            let max = rho.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let rank = ((0.99 * n as f64).ceil() as usize).clamp(1, n) - 1;
            let (_, p99, _) = rho.select_nth_unstable_by(rank, f64::total_cmp);
            (mean, *p99, max)
        };
        let error_pixels = rho.iter().filter(|r| **r > threshold_px).count();
        Self {
            pixels_measured: n,
            mean_px,
            p99_px,
            max_px,
            threshold_px,
            error_pixels,
            error_pixel_share: if n == 0 {
                0.0
            } else {
                error_pixels as f64 / n as f64
            },
            coverage: None,
        }
    }
}

/// ρ statistics of `frame` (rendered from `camera` over `field`) and, given a reference of the
/// same viewport, its coverage mismatches.
pub fn measure_frame<H: HeightField + ?Sized>(
    frame: &RenderedFrame,
    camera: &Camera,
    field: &H,
    reference: Option<&ReferenceImage>,
    threshold_px: f64,
) -> Result<ErrorStats, MeasureError> {
    let coverage = reference.map(|r| Coverage::of(frame, r)).transpose()?;
    let mut stats = ErrorStats::of_rho(&rho_image(frame, camera, field), threshold_px);
    stats.coverage = coverage;
    Ok(stats)
}

/// Colour stops of the heat map (ρ in pixels, sRGB); see [`heat_rgb`].
const HEAT_STOPS: [(f64, [f64; 3]); 5] = [
    (0.0, [10.0, 20.0, 100.0]),
    (0.5, [0.0, 150.0, 170.0]),
    (1.0, [250.0, 225.0, 30.0]),
    (2.0, [255.0, 130.0, 0.0]),
    (4.0, [215.0, 0.0, 0.0]),
];

/// The heat-map colour (sRGB) of ρ in pixels, linear between these stops, so that the default
/// threshold γ = 1 px is where the map turns warm:
///
/// | ρ (px) | colour |
/// | --- | --- |
/// | 0 | dark blue (10, 20, 100) |
/// | 0.5 | teal (0, 150, 170) |
/// | 1 | yellow (250, 225, 30) |
/// | 2 | orange (255, 130, 0) |
/// | ≥ 4 | red (215, 0, 0) |
///
/// Negative ρ is clamped to 0; NaN (sky) is black.
pub fn heat_rgb(rho_px: f64) -> [u8; 3] {
    if rho_px.is_nan() {
        return [0, 0, 0];
    }
    let rho = rho_px.max(0.0);
    let upper = HEAT_STOPS
        .iter()
        .position(|(at, _)| rho < *at)
        .unwrap_or(HEAT_STOPS.len());
    let rgb = match upper {
        0 => HEAT_STOPS[0].1,
        n if n == HEAT_STOPS.len() => HEAT_STOPS[n - 1].1,
        n => {
            let ((a, ca), (b, cb)) = (HEAT_STOPS[n - 1], HEAT_STOPS[n]);
            let t = (rho - a) / (b - a);
            std::array::from_fn(|i| ca[i] + (cb[i] - ca[i]) * t)
        }
    };
    rgb.map(|c| c.round().clamp(0.0, 255.0) as u8)
}

/// RGBA8 heat map of a ρ image: [`heat_rgb`] with alpha 255, and sky (NaN) transparent so it
/// can lie over the frame.
pub fn heat_map_rgba(rho_px: &[f32]) -> Vec<u8> {
    rho_px
        .iter()
        .flat_map(|&r| {
            if r.is_nan() {
                [0, 0, 0, 0]
            } else {
                let [red, green, blue] = heat_rgb(f64::from(r));
                [red, green, blue, 255]
            }
        })
        .collect()
}

/// Writes the heat map of a `width` × `height` ρ image as an RGBA PNG.
pub fn write_heat_map_png(
    path: &Path,
    width: u32,
    height: u32,
    rho_px: &[f32],
) -> Result<(), MeasureError> {
    if rho_px.len() != width as usize * height as usize {
        return Err(MeasureError::SizeMismatch {
            what: "the ρ image",
            actual_w: rho_px.len() as u32,
            actual_h: 1,
            expected_w: width,
            expected_h: height,
        });
    }
    image::save_buffer(
        path,
        &heat_map_rgba(rho_px),
        width,
        height,
        image::ColorType::Rgba8,
    )
    .map_err(|source| MeasureError::Image {
        path: path.to_path_buf(),
        source,
    })
}

/// Opacity of the heat map over the shading in `--overlay error` (and its golden image).
pub const ERROR_OVERLAY_OPACITY: f32 = 0.75;

/// Lays the heat map of `rho_px` over an RGBA8 frame (`--overlay error`): terrain pixels take
/// the heat colour at `opacity` (0…1) over their shading, so relief stays readable; sky stays.
pub fn overlay_heat(rgba: &mut [u8], rho_px: &[f32], opacity: f32) {
    let a = opacity.clamp(0.0, 1.0);
    for (px, &r) in rgba.chunks_exact_mut(4).zip(rho_px) {
        if r.is_nan() {
            continue;
        }
        let heat = heat_rgb(f64::from(r));
        for i in 0..3 {
            px[i] = (f32::from(px[i]) * (1.0 - a) + f32::from(heat[i]) * a).round() as u8;
        }
    }
}

/// The full measurement of one frame: ρ statistics against the terrain function and, when
/// `with_reference`, coverage against the reference ray caster (the slow part: seconds per
/// megapixel on the embedded Earth).
pub fn evaluate(
    frame: &RenderedFrame,
    camera: &Camera,
    field: &(impl HeightField + ?Sized),
    with_reference: bool,
) -> Result<ErrorStats, MeasureError> {
    let reference = with_reference.then(|| {
        super::reference::RayCaster::new(field, camera, frame.width, frame.height)
            .cast(&super::reference::PixelSet::All)
    });
    measure_frame(
        frame,
        camera,
        field,
        reference.as_ref(),
        DEFAULT_THRESHOLD_PX,
    )
}

/// [`evaluate`] with the reference, cast within `time_limit` (None: none; past it,
/// [`MeasureError::TimedOut`]) and reporting `progress(pixels cast, pixels)` as it goes: a
/// measurement that would take hours says so instead of hanging.
pub fn evaluate_within(
    frame: &RenderedFrame,
    camera: &Camera,
    field: &(impl HeightField + ?Sized),
    time_limit: Option<std::time::Duration>,
    progress: impl FnMut(usize, usize),
) -> Result<ErrorStats, MeasureError> {
    let reference = super::reference::RayCaster::new(field, camera, frame.width, frame.height)
        .cast_within(&super::reference::PixelSet::All, time_limit, progress)?;
    measure_frame(frame, camera, field, Some(&reference), DEFAULT_THRESHOLD_PX)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn heat_map_stops() {
        assert_eq!(heat_rgb(0.0), [10, 20, 100]);
        assert_eq!(heat_rgb(1.0), [250, 225, 30]);
        assert_eq!(heat_rgb(4.0), [215, 0, 0]);
        assert_eq!(heat_rgb(100.0), [215, 0, 0]);
        assert_eq!(heat_rgb(-1.0), [10, 20, 100]);
        assert_eq!(heat_rgb(f64::NAN), [0, 0, 0]);
        // Between stops: halfway from yellow to orange.
        assert_eq!(heat_rgb(1.5), [253, 178, 15]);
    }

    #[test]
    fn stats_of_a_known_rho_image() {
        let mut rho: Vec<f32> = (0..100).map(|i| i as f32 / 10.0).collect();
        rho.push(f32::NAN);
        let s = ErrorStats::of_rho(&rho, DEFAULT_THRESHOLD_PX);
        assert_eq!(s.pixels_measured, 100);
        assert!((s.mean_px - 4.95).abs() < 1e-6);
        assert!((s.max_px - 9.9).abs() < 1e-6);
        assert!((s.p99_px - 9.8).abs() < 1e-6);
        // 1.1 … 9.9 exceed 1 px.
        assert_eq!(s.error_pixels, 89);
        assert!((s.error_pixel_share - 0.89).abs() < 1e-12);
    }
}
