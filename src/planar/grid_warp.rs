//! Geometry-image warping of the projected grid (geometry-image-warping.md §3): filled in by its own change.
