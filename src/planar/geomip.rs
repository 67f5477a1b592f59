//! Geomipmapping with geomorphing (geomipmapping-geomorphing.md): filled in by its own change.
