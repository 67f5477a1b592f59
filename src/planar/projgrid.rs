//! The error-bounded projected grid (error-bounded-projective-grid.md): filled in by its own change.
