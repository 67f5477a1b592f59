//! globe-data as a user runs it: importing rasters, sampling against GDAL, the synthetic and
//! real-Earth pyramids (each module was its own test binary once; one link step instead of three).

mod import_rasters;
mod sample_gdal;
mod synth;
