//! Measuring the renderer honestly (docs/design.md#measuring): an f64 reference ray caster over
//! the terrain function and the per-pixel screen-space error of a rendered frame.
//!
//! Source: `error-bounded-projective-grid.md` §4, eq. 2 (object-space error δ) and eq. 3
//! (screen-space error ρ = λ·δ/‖p − e‖, λ in pixels per radian). The paper bounds δ a priori
//! from its min/max pyramids; here δ is measured a posteriori, per pixel, against the terrain
//! function itself, and the same pyramids accelerate the reference ray caster instead.
//!
//! | file | concern |
//! | --- | --- |
//! | [`reference`] | [`HeightField`] (the terrain function and its local bounds), the ray caster giving each pixel's true hit or sky |
//! | [`probe`] | the surface point through one pixel (latitude, longitude, height), from the ray caster |
//! | [`profile`] | the terrain's heights along a great circle, and its length along the sphere and along the terrain |
//! | [`metric`] | per-pixel δ and ρ from a rendered depth buffer, coverage against the reference, statistics, heat map |
//!
//! | frame | convention (as [`crate::geo`]) |
//! | --- | --- |
//! | view | planet centre at the origin, eye at (0, 0, R + altitude), +z̃ up at the viewer |
//! | pixel | centre of pixel (x, y) at NDC (2(x + ½)/W − 1, 1 − 2(y + ½)/H), row 0 at the top |
//! | distance | metres along the unit ray from the eye ([`crate::geo::pixel_ray_view`]) |

pub mod metric;
pub mod probe;
pub mod profile;
pub mod reference;

pub use metric::{
    Coverage, DEFAULT_THRESHOLD_PX, ERROR_OVERLAY_OPACITY, ErrorStats, PixelError, evaluate,
    evaluate_within, heat_rgb, measure_frame, overlay_heat, pixel_error, rho_image,
    write_heat_map_png,
};
pub use probe::{ProbeHit, probe_pixel};
pub use profile::{Profile, ProfileError, ProfilePoint, great_circle_profile};
pub use reference::{
    ConstantHeight, HeightField, LocalBounds, PROGRESS_INTERVAL, PixelSet, RayCastOptions,
    RayCaster, RayHit, ReferenceImage, ReferencePixel, SPLITS, ScaleSplit,
};

/// Errors of the measurements.
#[derive(Debug, thiserror::Error)]
pub enum MeasureError {
    /// A reference or ρ image of another size than the frame it is compared with.
    #[error("{what} is {actual_w}×{actual_h}, the frame {expected_w}×{expected_h}")]
    SizeMismatch {
        what: &'static str,
        actual_w: u32,
        actual_h: u32,
        expected_w: u32,
        expected_h: u32,
    },
    #[error("{path}: {source}")]
    Image {
        path: std::path::PathBuf,
        source: image::ImageError,
    },
    #[error("{path}: {source}")]
    Write {
        path: std::path::PathBuf,
        source: std::io::Error,
    },
    /// The reference ray cast ran past its time limit ([`RayCaster::cast_within`]).
    #[error(
        "the reference ray cast reached its time limit of {limit_s} s with {done} of {total} pixels cast ({:.1} %)",
        100.0 * *done as f64 / (*total).max(1) as f64
    )]
    TimedOut {
        limit_s: f64,
        done: usize,
        total: usize,
    },
    /// A time limit that is neither 0 (none) nor a number of seconds ([`time_limit`]).
    #[error("--measure-timeout must be 0 (no limit) or a number of seconds (got {0})")]
    BadTimeLimit(f64),
    /// `plotters` failed to draw (its error is generic over the backend, hence boxed).
    #[error("drawing the plot: {0}")]
    Plot(Box<dyn std::error::Error + Send + Sync>),
}

/// A reference ray cast's time limit from `seconds` (0: none), refused when negative or not a
/// number.
pub fn time_limit(seconds: f64) -> Result<Option<std::time::Duration>, MeasureError> {
    if !(seconds >= 0.0 && seconds.is_finite()) {
        return Err(MeasureError::BadTimeLimit(seconds));
    }
    Ok((seconds > 0.0).then(|| std::time::Duration::from_secs_f64(seconds)))
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_time_limit_is_none_at_zero_and_refused_unless_a_number_of_seconds() {
        assert_eq!(super::time_limit(0.0).unwrap(), None);
        assert_eq!(
            super::time_limit(1.5).unwrap(),
            Some(std::time::Duration::from_millis(1500))
        );
        for bad in [-1.0, f64::NAN, f64::INFINITY] {
            let e = super::time_limit(bad).unwrap_err().to_string();
            assert!(e.contains("--measure-timeout must be 0"), "{bad}: {e}");
        }
    }
}
