//! Height sources: the terrain function every LOD method approximates (DESIGN.md "One terrain
//! function"). Until the DEM pyramid lands, the source is the analytic test planet, whose height
//! is known in closed form at any (φ, θ) so tests can check rendered heights exactly.

pub mod analytic;

pub use analytic::AnalyticPlanet;
