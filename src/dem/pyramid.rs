//! The tiled elevation pyramid file: the unit of streaming (docs/design.md#data), read tile by
//! tile by `crate::stream`.
//!
//! A pyramid holds a geographic (equirectangular, pixel-centre) grid of heights at levels
//! from the source's resolution down to one tile, each level half the resolution of the one
//! before in latitude and in longitude, each cut into fixed-size square tiles of three planes:
//! **avg** (the filtered height), **min** and **max** (conservative bounds of the terrain under
//! the pixel). [`PyramidBuilder`] writes one from any [`RasterSource`](crate::dem::RasterSource)
//! in a single streaming pass; [`Pyramid`] memory-maps and validates it.
//!
//! # Grid
//!
//! Level 0 *is* the source grid (its [`GeoGrid`](crate::dem::GeoGrid): pixel centres, row 0
//! northernmost). Its footprint — pixel *edges*: `west = lon0 − dlon/2`, `east = west +
//! cols·dlon` (exactly `west + 360°` when the columns cover the circle), `north = lat0 +
//! dlat/2`, `south = north − rows·dlat` — is the data's **extents**, stored in the header and
//! the same for every level. Level k+1 has ⌈cols/2⌉ × ⌈rows/2⌉ pixels spread evenly over those
//! extents, so a global grid wraps exactly at every level even where a count is odd (the
//! spacing is then `n/⌈n/2⌉` < 2 times the finer one, and coarse pixels overlap fine pixels
//! fractionally; the filter below integrates the exact overlaps). The last level is the
//! first whose grid fits in one tile. Sources may be regional: outside the extents the
//! pyramid has no data and says so ([`Pyramid::covers`], `sample` → `None`,
//! [`HeightBounds::complete`]). Footprints may reach past a pole (a grid whose rows are
//! centred on ±90°, like ETOPO5's): areas are clamped to the sphere.
//!
//! # Heights: `i16` codes with a recorded quantum
//!
//! Every plane stores `code: i16` with `metres = offset_m + quantum_m · code` (header fields;
//! the builder's default is 1 m and 0). Why not `f32`:
//!
//! * **size**: a 30″ global pyramid is 0.93 G samples at level 0, 1.24 G in all; three planes
//!   take 7.5 GB as `i16` and 15 GB as `f32`. A 256² tile is 384 KiB instead of 768 KiB, so
//!   the streamer's byte budget, the LRU cache and the GPU upload budget hold twice the
//!   terrain.
//! * **precision is not lost where it exists**: GTOPO30 is integer metres and ETOPO5 integer
//!   valued, so level 0 round-trips them exactly; Earth's −10 994 … 8 849 m (and Mars's
//!   −8 200 … 21 229 m) fit the ±32 767 codes at 1 m. A source that does not fit is an error
//!   naming the pixel and suggesting a coarser quantum — never a clamp; a regional DEM with
//!   little relief may choose a finer quantum (e.g. 0.1 m).
//! * **rounding**: avg rounds to the nearest code (ties away from zero; error ≤ quantum/2,
//!   far below any DEM's vertical accuracy — GTOPO30 states ±30 m); **min rounds down and max
//!   rounds up** (checked exactly in f64), so the bounds stay conservative; avg is clamped into
//!   [min, max] after rounding, so min ≤ avg ≤ max holds for the stored codes. Levels are
//!   built from the unquantised `f32` values of the finer level, so rounding never
//!   accumulates from level to level. `i16::MIN` is reserved (never written).
//!
//! # Filtering (paper §4.3: the sphere, not the map)
//!
//! Level 0's avg is the source itself (NaN → 0 m by default, see [`NanPolicy`]); its min/max
//! are the min/max of the pixel's **3 × 3 neighbourhood** (wrapping in longitude, clamped at
//! the grid's edges): the terrain function is the bilinear interpolation between pixel
//! centres, which over a pixel's footprint is a convex combination of those nine centres, so
//! level 0's bounds hold for the continuous surface, not just for the samples.
//!
//! Level k+1 from level k — an **area-weighted box, widened in longitude to the ground
//! width it has in latitude**:
//!
//! ```text
//! avg(R, C) = Σ_r w_r · ∫_{W_R(C)} f_r(λ) dλ  /  Σ_r w_r · |W_R(C)|
//!   r       : fine rows overlapping coarse row R's latitude footprint
//!   w_r     : sin φ_top − sin φ_bottom of that overlap (clamped to ±90°): the exact
//!             spherical area per radian of longitude, ∝ cos φ · Δφ
//!   f_r     : fine row r as a piecewise-constant function of longitude (exact partial
//!             overlaps at both ends of a window)
//!   W_R(C)  : the longitude window centred on the coarse pixel's centre, of width
//!             max(Δλ_{k+1}, min(360°, Δφ_{k+1} / c̄_R)),  c̄_R = Δ sin φ / Δφ over row R
//! ```
//!
//! Within a coarse row the kernel is separable (a latitude box of exact areas times one
//! longitude box), so the average is a true area-weighted mean over a map-space rectangle:
//! a source that is constant along each latitude gets exactly the cos-weighted mean of the
//! rows under the footprint, and the global area-weighted mean of such a source is conserved
//! from level to level (tested). On the ground the window spans R·c̄_R·W = R·Δφ_{k+1} in
//! longitude, the same as the kernel's extent in latitude, so the band limit is isotropic on
//! the sphere: with square pixels the window is the 2 × 2 footprint at the equator, 1.15 ×
//! as wide at 30°, 2 × at 60°, 5.8 × at 80°; in a row that ends at a pole c̄ ≈ Δφ/2, so the
//! window is 2 rad ≈ 115° of longitude at every level (≈ 229° for a row centred on the pole,
//! as in ETOPO5), and the cap at the full circle binds only where Δφ is large against Δλ or
//! a regional row is narrower than its window (passes counted in
//! [`BuildReport::widened_passes`] / [`BuildReport::full_circle_passes`]).
//! A box rather than a wider tent: it keeps the footprint's mean exact in latitude, keeps the
//! support (and so the min/max bounds) as narrow as isotropy allows, and k cascaded boxes
//! already approximate a B-spline of width 2^k (the clipmap's bilinear reconstruction adds a
//! tent on top); the cost is somewhat more aliasing per step than a [1 3 3 1] tent.
//!
//! min/max at level k+1 are the exact min/max of the level-k min/max over every fine pixel
//! that overlaps the kernel's support with positive area. The support contains the pixel's
//! footprint (it *is* the footprint in latitude, and at the equator), so the bounds are
//! conservative for the footprint and also bound avg, which is computed from that support
//! (min ≤ avg ≤ max by construction); off the equator they are looser than the footprint's
//! own by the widening, up to the whole latitude ring next to a pole. By induction a
//! pixel's bounds hold for the level-0 bilinear surface over its footprint and for every finer
//! level's avg under it; [`Pyramid::min_max_in`] reads the pixels whose centres lie within one
//! pixel of a region, so its bounds hold for the bilinear surface of *every* level ≤ the one
//! asked, everywhere in the region (for the horizon safety term and sector culling).
//!
//! # File layout (little-endian; version 1)
//!
//! | offset | size | field |
//! | --- | --- | --- |
//! | 0 | 8 | magic `GLOBEPYR` |
//! | 8 | u32 | format version (1) |
//! | 12 | u32 | header length H: bytes from 0 to the end of the header CRC |
//! | 16 | u32 | tile size T (samples per tile edge, 4 … 4096; default 256) |
//! | 20 | u32 | level count |
//! | 24 | u32 | flags: bit 0 = the columns cover the whole circle (longitude wraps) |
//! | 28 | u32 | sample format: 1 = three planes of `i16` |
//! | 32 | f64 | quantum (m per code) |
//! | 40 | f64 | offset (m at code 0) |
//! | 48 | 4 × f64 | extents: west, east, south, north (pixel edges, degrees) |
//! | 80 | u64 | offset of the first tile (a multiple of 4096) |
//! | 88 | u64 | file length |
//! | 96 | u64 | tile count |
//! | 104 | u64 | no-data pixels replaced (NaN policy) |
//! | 112 | 2 × f64 | lowest min, highest max of level 0 (m) |
//! | 128 | u32 | description length D (≤ 4096), then u32 0 |
//! | 136 | D, padded to 8 | source description (UTF-8) |
//! | … | 64 per level | level table: u32 cols, rows, tiles_x, tiles_y; f64 lon0, lat0 (centre of pixel 0, 0), dlon, dlat; u64 offset of the level's first index entry; u64 0 |
//! | … | 16 per tile | tile index, level by level, tile rows north → south, west → east: u64 offset, u32 length, u32 CRC-32 of the payload |
//! | H − 4 | u32 | header CRC-32 of bytes 0 … H − 4 |
//! | ⌈H⌉₄₀₉₆ | 6·T² per tile | tiles, contiguous, in index order; each: avg plane, min plane, max plane, each T rows (north → south) of T codes; edge tiles repeat the last column / row |
//!
//! [`Pyramid::open`] checks magic, version (before the CRC, so a future version gets a
//! version message), header CRC, that the level table is exactly what level 0 and T imply,
//! that every index entry lies in order inside the file, and the file's real length against
//! the header (a truncated file names the first incomplete tile and how much is missing).
//! Tile payloads are checked by CRC, and their codes against the rules above (min ≤ avg ≤ max,
//! no `i16::MIN`: a CRC vouches for the bytes, not for the writer), in [`Pyramid::verify`] (all,
//! reporting the first bad tile by level and tile x/y, and the header's height range against
//! level 0) and [`Pyramid::tile_verified`] (one, the streamer's path). `open` checks that the
//! header's height range is finite, lowest first, within what the codes hold.
//!
//! # Memory (the writer streams)
//!
//! The source is read once, row by row; every level is built in a cascade as rows arrive.
//! Each level holds one band of T quantised rows (3 planes × 2 bytes × T × cols_k, written as
//! a row of tiles when complete, to offsets known before the first row is read) and the
//! downsampler holds at most two coarse rows of accumulators. Peak:
//!
//! ```text
//! 6·T·Σ_k cols_k + O(cols_0) ≈ 12·T·cols_0 bytes  (+ 6·T² tile buffer + 16 bytes per tile)
//! ```
//!
//! independent of the number of rows. [`BuildReport::buffer_bytes`] gives the exact figure;
//! the test `memory_bound` measures the growth of VmHWM (peak RSS) during a build in a child
//! process:
//!
//! | source (global, T = 256) | raster as f32 | buffers (computed) | peak RSS growth | build (release) |
//! | --- | --- | --- | --- | --- |
//! | 8 640 × 4 320 (2.5′) | 149 MB | 27.5 MB | 27.5 MB | 2.4 – 3.5 s, 11 – 15 M samples/s |
//! | 43 200 × 21 600 (30″) | 3 733 MB | 138.1 MB | 138.2 MB | 72 s, 13 M samples/s; 7.59 GB file, 19 301 tiles |
//!
//! (2-core VM, synthetic source, single-threaded build, `fsync` included; reading a real
//! raster adds its own I/O.) Reading a pyramid maps it: pages a reader touches count towards
//! its RSS as file-backed, reclaimable memory (`verify` touches them all).
//!
//! # SIGBUS: files truncated while mapped
//!
//! A mapped file that shrinks under the mapping raises SIGBUS on the next access to a page
//! past the new end; Rust cannot turn that into an error without a process-wide signal
//! handler, which this crate does not install. What is done instead:
//!
//! * `open` compares the real length with the header's and every tile's extent, so a file
//!   truncated *before* it is opened is an error, never a fault.
//! * The builder writes `<out>.partial` and renames it over `out`: rebuilding a pyramid
//!   replaces the directory entry, while a viewer's mapping keeps the old inode (and its
//!   data) alive — the common "file replaced while mapped" case is safe.
//! * [`Pyramid::check_tile_in_file`] (one `fstat`) refuses, before every streamed read, a
//!   tile the file no longer reaches; [`Pyramid::check_length`] re-checks the whole length for
//!   `verify`. [`Pyramid::file_change`] says what happened to the file and its path
//!   (replaced, deleted, truncated, appended to, modified) for the streamer's watcher.
//! * Contents changed in place without a size change are caught by the tile CRCs.
//!
//! The remaining risk: another process truncating *the same inode in place* (`truncate`,
//! a shell `>` redirection, a copy tool opening with `O_TRUNC`) between a check and an
//! access still faults, as does a CPU-side reader that reads the map without the per-tile
//! check (the reference ray caster, `DemTerrain`'s samplers) after such a truncation. Do not edit pyramid files in place; a reader that must survive that
//! should read tiles with positioned reads (`pread`) instead of the map.
//!
//! The map itself is made by `crate::dem::mapped`, shared with the EHdr and netCDF readers.

mod build;
mod filter;
mod format;
mod read;

pub use build::{BuildProgress, BuildReport, DEFAULT_TILE_SIZE, NanPolicy, PyramidBuilder};
pub use format::{
    Encoding, Extents, FORMAT_VERSION, LevelGeom, MAGIC, MAX_TILE_SIZE, MIN_TILE_SIZE, TileEntry,
};
pub use read::{
    CodeFn, HeightBounds, NotResident, Plane, Pyramid, PyramidInfo, Region, TileView, VerifyReport,
};
