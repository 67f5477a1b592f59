//! Measuring the renderer honestly (DESIGN.md "Measuring"): an f64 reference ray caster over
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
//!
//! | frame | convention (as [`crate::geo`]) |
//! | --- | --- |
//! | view | planet centre at the origin, eye at (0, 0, R + altitude), +z̃ up at the viewer |
//! | pixel | centre of pixel (x, y) at NDC (2(x + ½)/W − 1, 1 − 2(y + ½)/H), row 0 at the top |
//! | distance | metres along the unit ray from the eye ([`crate::geo::pixel_ray_view`]) |

pub mod reference;

pub use reference::{
    ConstantHeight, HeightField, LocalBounds, PixelSet, RayCastOptions, RayCaster, RayHit,
    ReferenceImage, ReferencePixel,
};
