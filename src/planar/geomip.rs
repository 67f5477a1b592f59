//! Geomipmapping with geomorphing (geomipmapping-geomorphing.md), on the tangent plane of
//! [`super::LocalFrame`].
//!
//! The plane near the viewer is cut into square patches of `size` × `size` lattice vertices
//! (`size` = 2^n + 1, the paper's 17), neighbours sharing their border vertices. A patch draws
//! at tessellation level k ∈ 0..=n (every 2^k-th vertex). Its level is chosen from the patch's
//! precomputed maximum vertical error per level, δ_k, projected to the screen at the patch's
//! distance (ρ_k = λ·δ_k/d, λ pixels per radian): the coarsest k with ρ_k ≤ τ.
//!
//! - **No cracks, no T-vertices**: a border between two patches is tessellated at the coarser
//!   of their two levels by both (the finer patch adapts, as the paper says), and each patch's
//!   interior is joined to its four borders by strips of adapting triangles ([`patch_indices`];
//!   checked on the generated indices for every level combination in the tests).
//! - **Geomorphing**: the level is continuous, ℓ = k + f. A vertex that level k + 1 drops moves
//!   by f toward the midpoint of the two coarser vertices it lies between (the paper's cases A,
//!   B, C; B along the diagonal the coarser quad is split by), so ℓ crossing an integer moves
//!   nothing. Interior vertices morph by the patch's own ℓ, border vertices by the border's
//!   ℓ_e = max(ℓ_self, ℓ_neighbour), which both patches compute alike: the paper's five tween
//!   factors (self and four sides). The paper's inner-neighbour factors are not needed: heights
//!   are sampled per vertex in the vertex shader, not stored as per-level offsets, so a vertex's
//!   morph target is always the midpoint of its neighbours' current surface.

use std::ops::Range;

use glam::DVec2;

/// Settings of the geomipmapping mode (validated: [`GeomipSettings::validate`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GeomipSettings {
    /// Lattice vertices per patch side, 2^n + 1 (the paper: 17).
    pub patch_size: u32,
    /// Patches per side of the square around the viewer (even).
    pub patches: u32,
    /// Level threshold τ: the largest projected error a patch may have, pixels.
    pub tau_px: f64,
    /// Geomorphing on (off: levels switch whole, the popping the paper removes).
    pub geomorph: bool,
}

impl Default for GeomipSettings {
    fn default() -> Self {
        Self {
            patch_size: 17,
            patches: 32,
            tau_px: 1.0,
            geomorph: true,
        }
    }
}

/// A bad geomipmapping setting, naming its flag.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum GeomipError {
    #[error("--patch-size {0}: a patch has 2^n + 1 vertices per side: 5, 9, 17 or 33")]
    PatchSize(u32),
    #[error(
        "--patches {0}: the patches per side of the square around the viewer must be even, 2 to 64"
    )]
    Patches(u32),
    #[error("--tau {0}: the level threshold τ is a screen-space error in pixels and must be > 0")]
    Tau(f64),
}

impl GeomipSettings {
    pub fn validate(&self) -> Result<(), GeomipError> {
        let cells = self.patch_size.wrapping_sub(1);
        if !(4..=32).contains(&cells) || !cells.is_power_of_two() {
            return Err(GeomipError::PatchSize(self.patch_size));
        }
        if !(2..=64).contains(&self.patches) || !self.patches.is_multiple_of(2) {
            return Err(GeomipError::Patches(self.patches));
        }
        if !(self.tau_px > 0.0 && self.tau_px.is_finite()) {
            return Err(GeomipError::Tau(self.tau_px));
        }
        Ok(())
    }

    /// The coarsest level n (a patch of 2^n cells drawn as one quad).
    pub fn max_level(&self) -> u32 {
        (self.patch_size - 1).trailing_zeros()
    }
}

/// Borders of a patch, in the order of every `[_; 4]` here.
pub const SOUTH: usize = 0;
pub const EAST: usize = 1;
pub const NORTH: usize = 2;
pub const WEST: usize = 3;

/// Triangles (local vertex indices i + j·size, counter-clockwise seen from above: x east, y
/// north) of a patch drawn at interior level `k` with its borders at `sides` (each ≥ k).
///
/// The interior quads between the lines s = 2^k and N − s (N = size − 1) are split along the
/// diagonal [`main_diagonal`] gives, the one geomorphing's case B moves onto.
/// Each border strip zips the border's vertices (step 2^side) to the interior's outermost line
/// (step s), taking the same diagonals wherever both steps agree; the strips meet at the four
/// corner diagonals, which are their quadrants' diagonals too.
pub fn patch_indices(size: u32, k: u32, sides: [u32; 4]) -> Vec<u32> {
    let n = size - 1;
    let s = 1u32 << k;
    let id = |x: u32, y: u32| x + y * size;
    let mut tris: Vec<[u32; 3]> = Vec::new();
    if s >= n {
        tris.push([id(0, 0), id(n, 0), id(n, n)]);
        tris.push([id(0, 0), id(n, n), id(0, n)]);
    } else {
        let mut y = s;
        while y + s <= n - s {
            let mut x = s;
            while x + s <= n - s {
                if main_diagonal(x, y, s) {
                    tris.push([id(x, y), id(x + s, y), id(x + s, y + s)]);
                    tris.push([id(x, y), id(x + s, y + s), id(x, y + s)]);
                } else {
                    tris.push([id(x, y), id(x + s, y), id(x, y + s)]);
                    tris.push([id(x + s, y), id(x + s, y + s), id(x, y + s)]);
                }
                x += s;
            }
            y += s;
        }
        let inner: Vec<u32> = (s..=n - s).step_by(s as usize).collect();
        for side in [SOUTH, EAST, NORTH, WEST] {
            let se = 1u32 << sides[side].max(k);
            let outer: Vec<u32> = (0..=n).step_by(se as usize).collect();
            // (border vertex, inner-line vertex) at parameter t along the side.
            // The border's vertex and the inner line's vertex at parameter t along the side.
            let line = |t: u32, depth: u32| match side {
                SOUTH => id(t, depth),
                NORTH => id(t, n - depth),
                WEST => id(depth, t),
                _ => id(n - depth, t),
            };
            let a = |t: u32| line(t, 0);
            let b = |t: u32| line(t, s);
            // A tie closes a quad [p − s, p] of the strip's row: advancing the inner line
            // first gives it the diagonal from the border's vertex at p − s (main on the south
            // and west strips, the other one on the north and east strips).
            let row = if side == SOUTH || side == WEST {
                0
            } else {
                n - s
            };
            let inner_first_is_main = side == SOUTH || side == WEST;
            let (mut i, mut j) = (0, 0);
            while i + 1 < outer.len() || j + 1 < inner.len() {
                let advance_outer = if i + 1 >= outer.len() {
                    false
                } else if j + 1 >= inner.len() {
                    true
                } else if outer[i + 1] == inner[j + 1] {
                    main_diagonal(outer[i + 1] - s, row, s) != inner_first_is_main
                } else {
                    outer[i + 1] < inner[j + 1]
                };
                if advance_outer {
                    tris.push([a(outer[i]), a(outer[i + 1]), b(inner[j])]);
                    i += 1;
                } else {
                    tris.push([a(outer[i]), b(inner[j + 1]), b(inner[j])]);
                    j += 1;
                }
            }
        }
    }
    // Counter-clockwise from above, whatever the strip's direction.
    let xy = |v: u32| ((v % size) as i64, (v / size) as i64);
    let mut out = Vec::with_capacity(tris.len() * 3);
    for [p, q, r] in tris {
        let ((x0, y0), (x1, y1), (x2, y2)) = (xy(p), xy(q), xy(r));
        let area2 = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0);
        debug_assert!(area2 != 0, "degenerate triangle");
        if area2 > 0 {
            out.extend([p, q, r]);
        } else {
            out.extend([p, r, q]);
        }
    }
    out
}

/// Whether the quad [x, x + s] × [y, y + s] (x, y multiples of s) is split along its
/// (x, y)–(x + s, y + s) diagonal rather than the other one: alternating with the quad's parity
/// (a 4-8 pattern). The four quads of every coarser quad then meet in an X at its centre, which
/// lies on the coarser quad's diagonal whichever it is, so a fully morphed level is exactly
/// the next coarser one; along a border the pattern forms the V that a border one level
/// coarser turns into a fan (the strips nest too), and the four strips' corner diagonals
/// (corner to inner corner) follow it.
pub fn main_diagonal(x: u32, y: u32, s: u32) -> bool {
    (x / s + y / s).is_multiple_of(2)
}

/// Lowers each patch's level so that neighbours differ by at most one (ℓ_i ≤ ℓ_j + 1): then a
/// border is never more than one level coarser than a patch's interior, the case the strips
/// nest exactly for. Lowering only refines, so every patch still meets τ; the result is
/// continuous in the levels given. Negative levels mark absent patches (culled), which
/// constrain nothing.
pub fn restrict_levels(levels: &mut [f64], cols: usize) {
    let rows = levels.len() / cols;
    loop {
        let mut changed = false;
        for i in 0..levels.len() {
            if levels[i] < 0.0 {
                continue;
            }
            let (c, r) = (i % cols, i / cols);
            let neighbours = [
                (c > 0).then(|| i - 1),
                (c + 1 < cols).then(|| i + 1),
                (r > 0).then(|| i - cols),
                (r + 1 < rows).then(|| i + cols),
            ];
            for j in neighbours.into_iter().flatten() {
                if levels[j] >= 0.0 && levels[i] > levels[j] + 1.0 {
                    levels[i] = levels[j] + 1.0;
                    changed = true;
                }
            }
        }
        if !changed {
            break;
        }
    }
}

/// A skirt: a vertical strip hanging from border `side` (drawn at level k) down to lowered
/// copies of its vertices (local index size² + side·size + t), both windings, so the grid's
/// outer edge never shows a gap where the surface beyond lies lower.
pub fn skirt_indices(size: u32, side: usize, k: u32) -> Vec<u32> {
    let n = size - 1;
    let s = 1u32 << k;
    let border = |t: u32| match side {
        SOUTH => t,
        NORTH => t + n * size,
        WEST => t * size,
        _ => n + t * size,
    };
    let lowered = |t: u32| size * size + side as u32 * size + t;
    let mut out = Vec::new();
    for t in (0..n).step_by(s as usize) {
        let (a, b, la, lb) = (border(t), border(t + s), lowered(t), lowered(t + s));
        out.extend([a, b, lb, a, lb, la, a, lb, b, a, la, lb]);
    }
    out
}

/// Every patch's index list, for every interior level and border levels, in one static buffer.
#[derive(Debug)]
pub struct PatchMesh {
    pub size: u32,
    pub max_level: u32,
    /// (i, j) lattice position of each local vertex, row-major.
    pub vertices: Vec<[u32; 2]>,
    pub indices: Vec<u32>,
    ranges: Vec<Range<u32>>,
    /// `skirts[side·(n + 1) + k]`: the skirt under border `side` drawn at level k.
    skirts: Vec<Range<u32>>,
}

impl PatchMesh {
    pub fn build(size: u32) -> Self {
        let max_level = (size - 1).trailing_zeros();
        let levels = max_level + 1;
        let vertices = (0..size * size).map(|v| [v % size, v / size]).collect();
        let mut indices = Vec::new();
        let mut ranges = Vec::with_capacity(levels.pow(5) as usize);
        for code in 0..levels.pow(5) {
            let k = code % levels;
            let sides = std::array::from_fn(|i| code / levels.pow(i as u32 + 1) % levels);
            let start = indices.len() as u32;
            if sides.iter().all(|&sd| sd >= k) {
                indices.extend(patch_indices(size, k, sides));
            }
            ranges.push(start..indices.len() as u32);
        }
        let mut skirts = Vec::new();
        for side in [SOUTH, EAST, NORTH, WEST] {
            for k in 0..levels {
                let start = indices.len() as u32;
                indices.extend(skirt_indices(size, side, k));
                skirts.push(start..indices.len() as u32);
            }
        }
        Self {
            size,
            max_level,
            vertices,
            indices,
            ranges,
            skirts,
        }
    }

    /// Index range of the skirt under border `side` drawn at level `k`.
    pub fn skirt(&self, side: usize, k: u32) -> Range<u32> {
        self.skirts[side * (self.max_level as usize + 1) + k.min(self.max_level) as usize].clone()
    }

    /// Index range of a patch at interior level `k` with borders at `sides` (each ≥ k).
    pub fn range(&self, k: u32, sides: [u32; 4]) -> Range<u32> {
        let levels = self.max_level + 1;
        let mut code = k;
        for (i, sd) in sides.iter().enumerate() {
            code += sd.max(&k).min(&self.max_level) * levels.pow(i as u32 + 1);
        }
        self.ranges[code as usize].clone()
    }
}

/// The least growth of δ from one level to the next (see [`continuous_level`]).
pub const DELTA_GROWTH: f64 = 1.5;

/// δ_k of a patch (k = 0..=n): the largest vertical distance between a lattice vertex and the
/// surface level k draws (its vertices' linear interpolation over the interior triangulation),
/// made to grow by at least [`DELTA_GROWTH`] per level so "the coarsest level with ρ_k ≤ τ" is well defined. `heights`
/// are the size × size lattice heights, row-major (the paper's per-level "maxerror vertex").
pub fn patch_deltas(size: u32, heights: &[f64]) -> Vec<f64> {
    let n = size - 1;
    let levels = n.trailing_zeros() + 1;
    let h = |x: u32, y: u32| heights[(x + y * size) as usize];
    let mut deltas = vec![0.0f64; levels as usize];
    for k in 1..levels {
        let s = 1u32 << k;
        let mut worst = 0.0f64;
        for y in 0..=n {
            for x in 0..=n {
                if x % s == 0 && y % s == 0 {
                    continue;
                }
                let surface = coarse_surface(n, s, x, y, &h);
                worst = worst.max((h(x, y) - surface).abs());
            }
        }
        deltas[k as usize] = worst.max(DELTA_GROWTH * deltas[k as usize - 1]);
    }
    deltas
}

/// The surface of step `s` at lattice point (x, y) of a patch of `n` cells: linear over the
/// quad's two triangles, split as [`main_diagonal`] says.
fn coarse_surface(n: u32, s: u32, x: u32, y: u32, h: &dyn Fn(u32, u32) -> f64) -> f64 {
    let (x0, y0) = ((x / s * s).min(n - s), (y / s * s).min(n - s));
    let (fx, fy) = ((x - x0) as f64 / s as f64, (y - y0) as f64 / s as f64);
    let (h00, h10, h01, h11) = (h(x0, y0), h(x0 + s, y0), h(x0, y0 + s), h(x0 + s, y0 + s));
    if main_diagonal(x0, y0, s) {
        if fx >= fy {
            h00 + fx * (h10 - h00) + fy * (h11 - h10)
        } else {
            h00 + fy * (h01 - h00) + fx * (h11 - h01)
        }
    } else if fx + fy <= 1.0 {
        h00 + fx * (h10 - h00) + fy * (h01 - h00)
    } else {
        h11 + (1.0 - fx) * (h01 - h11) + (1.0 - fy) * (h10 - h11)
    }
}

/// The continuous level ℓ = k + f of a patch with errors `deltas` at distance `distance_m`:
/// k the coarsest level whose projected error ρ_k = λ·δ_k/d is within τ; f, the tween factor
/// toward level k + 1, grows linearly in d from 0 where level k became allowed (ρ_k = τ) to 1
/// where level k + 1 does (ρ_{k+1} = τ), so a level switch moves nothing and the morphed
/// surface's error stays about τ. [`patch_deltas`] keeps δ_{k+1} ≥ 1.5·δ_k, so levels are
/// reached one after another (a plateau would switch several at once).
pub fn continuous_level(
    deltas: &[f64],
    distance_m: f64,
    lambda_px_per_rad: f64,
    tau_px: f64,
) -> f64 {
    let d = distance_m.max(1e-9);
    let rho = |k: usize| lambda_px_per_rad * deltas[k] / d;
    let mut k = 0;
    while k + 1 < deltas.len() && rho(k + 1) <= tau_px {
        k += 1;
    }
    if k + 1 >= deltas.len() {
        return k as f64;
    }
    // τ·d/λ is the error in metres level k's switch point allows.
    let allowed_m = tau_px * d / lambda_px_per_rad;
    let span = deltas[k + 1] - deltas[k];
    let f = if span > 0.0 {
        ((allowed_m - deltas[k]) / span).clamp(0.0, 1.0)
    } else {
        0.0
    };
    // Stay below the next integer: that level is not allowed yet.
    k as f64 + f.min(1.0 - 1e-9)
}

/// One patch of a frame: where it lies on the plane and how it is drawn.
#[derive(Clone, Debug, PartialEq)]
pub struct Patch {
    /// Lattice coordinates of its south-west corner (units of the finest spacing).
    pub corner: [i64; 2],
    /// Interior level ℓ and the four border levels ℓ_e = max(ℓ, ℓ_neighbour).
    pub level: f64,
    pub sides: [f64; 4],
}

impl Patch {
    /// Integer levels for the index buffer: interior k and border k_e.
    pub fn tessellation(&self) -> (u32, [u32; 4]) {
        let k = self.level.floor() as u32;
        (k, self.sides.map(|s| (s.floor() as u32).max(k)))
    }
}

/// Border levels of a square grid of patches (row-major, `cols` per row): each border takes
/// the larger ℓ of the two patches sharing it; borders on the grid's edge keep the patch's own.
pub fn border_levels(levels: &[f64], cols: usize) -> Vec<[f64; 4]> {
    let rows = levels.len() / cols;
    let at = |c: isize, r: isize| -> Option<f64> {
        (c >= 0 && r >= 0 && (c as usize) < cols && (r as usize) < rows)
            .then(|| levels[r as usize * cols + c as usize])
    };
    (0..levels.len())
        .map(|i| {
            let (c, r) = ((i % cols) as isize, (i / cols) as isize);
            let own = levels[i];
            let side = |dc: isize, dr: isize| at(c + dc, r + dr).map_or(own, |o| o.max(own));
            let mut s = [0.0; 4];
            s[SOUTH] = side(0, -1);
            s[EAST] = side(1, 0);
            s[NORTH] = side(0, 1);
            s[WEST] = side(-1, 0);
            s
        })
        .collect()
}

/// The morph of a drawn vertex (CPU twin of `vs_geomip` in shaders/terrain.wgsl): its local
/// lattice position, the patch's tessellation and levels, and the height function at local
/// lattice points → the height it is drawn at.
pub fn morphed_height(
    size: u32,
    patch: &Patch,
    geomorph: bool,
    x: u32,
    y: u32,
    h: &dyn Fn(u32, u32) -> f64,
) -> f64 {
    let n = size - 1;
    let (k, sides) = patch.tessellation();
    let here = h(x, y);
    if !geomorph {
        return here;
    }
    if let Some(sd) = border_of(n, x, y) {
        return border_height(n, patch, sides, sd, x, y, h);
    }
    let s = 1u32 << k;
    let f = patch.level - k as f64;
    if f <= 0.0 || s >= n {
        return here;
    }
    // The coarser surface a dropped vertex moves onto: its neighbours as drawn, which on a
    // border drawn coarser than the interior is that border's line, not the lattice height.
    let at = |x: u32, y: u32| match border_of(n, x, y) {
        Some(sd) if sides[sd] > k => border_height(n, patch, sides, sd, x, y, h),
        _ => h(x, y),
    };
    let (odd_x, odd_y) = ((x / s) % 2 == 1, (y / s) % 2 == 1);
    let target = match (odd_x, odd_y) {
        (false, false) => return here,
        (true, false) => 0.5 * (at(x - s, y) + at(x + s, y)),
        (false, true) => 0.5 * (at(x, y - s) + at(x, y + s)),
        (true, true) if main_diagonal(x - s, y - s, 2 * s) => {
            0.5 * (at(x - s, y - s) + at(x + s, y + s))
        }
        (true, true) => 0.5 * (at(x - s, y + s) + at(x + s, y - s)),
    };
    here + f * (target - here)
}

/// The border a lattice point lies on (a corner counts as its south or north border; corners
/// never move, whichever).
fn border_of(n: u32, x: u32, y: u32) -> Option<usize> {
    if y == 0 {
        Some(SOUTH)
    } else if y == n {
        Some(NORTH)
    } else if x == 0 {
        Some(WEST)
    } else if x == n {
        Some(EAST)
    } else {
        None
    }
}

/// Height of the border `sd` as drawn at lattice point (x, y) on it: its vertices (step
/// 2^k_e) morphed along the border by the border's tween factor, linear in between.
fn border_height(
    n: u32,
    patch: &Patch,
    sides: [u32; 4],
    sd: usize,
    x: u32,
    y: u32,
    h: &dyn Fn(u32, u32) -> f64,
) -> f64 {
    let along = sd == SOUTH || sd == NORTH;
    let t = if along { x } else { y };
    let point = |t: u32| if along { h(t, y) } else { h(x, t) };
    let s = 1u32 << sides[sd];
    let f = patch.sides[sd] - patch.sides[sd].floor();
    let vertex = |t: u32| {
        let here = point(t);
        if (t / s).is_multiple_of(2) || f <= 0.0 || s >= n {
            return here;
        }
        here + f * (0.5 * (point(t - s) + point(t + s)) - here)
    };
    if t % s == 0 {
        return vertex(t);
    }
    let t0 = t / s * s;
    let w = (t - t0) as f64 / s as f64;
    vertex(t0) + w * (vertex(t0 + s) - vertex(t0))
}

/// The drawn surface's height at every lattice point of a patch (vertices at their morphed
/// heights, the rest interpolated inside the triangle that covers them): what the viewer sees,
/// for the popping measurement.
pub fn drawn_surface(
    mesh: &PatchMesh,
    patch: &Patch,
    geomorph: bool,
    h: &dyn Fn(u32, u32) -> f64,
) -> Vec<f64> {
    let size = mesh.size;
    let (k, sides) = patch.tessellation();
    let range = mesh.range(k, sides);
    let tris = &mesh.indices[range.start as usize..range.end as usize];
    let mut out = vec![f64::NAN; (size * size) as usize];
    let pos = |v: u32| DVec2::new((v % size) as f64, (v / size) as f64);
    for t in tris.chunks_exact(3) {
        let p = [pos(t[0]), pos(t[1]), pos(t[2])];
        let z = [t[0], t[1], t[2]]
            .map(|v| morphed_height(size, patch, geomorph, v % size, v / size, h));
        let (lo, hi) = (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]));
        let det = (p[1] - p[0]).perp_dot(p[2] - p[0]);
        for y in lo.y as u32..=hi.y as u32 {
            for x in lo.x as u32..=hi.x as u32 {
                let q = DVec2::new(x as f64, y as f64);
                let w1 = (q - p[0]).perp_dot(p[2] - p[0]) / det;
                let w2 = (p[1] - p[0]).perp_dot(q - p[0]) / det;
                let w0 = 1.0 - w1 - w2;
                if w0 >= -1e-12 && w1 >= -1e-12 && w2 >= -1e-12 {
                    out[(x + y * size) as usize] = w0 * z[0] + w1 * z[1] + w2 * z[2];
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::{HashMap, HashSet};

    /// Five patches in a plus (centre and its four neighbours), each with its own level:
    /// triangles in global lattice coordinates.
    fn plus_mesh(mesh: &PatchMesh, levels: [f64; 5]) -> Vec<[(i64, i64); 3]> {
        // 3 × 3 grid; the corners are absent (NAN) and never neighbours of anything drawn.
        let grid = [
            f64::NAN,
            levels[1],
            f64::NAN,
            levels[4],
            levels[0],
            levels[2],
            f64::NAN,
            levels[3],
            f64::NAN,
        ];
        // Absent patches must not raise a border: treat NAN as "no neighbour".
        let filled: Vec<f64> = grid
            .iter()
            .map(|l| if l.is_nan() { -1.0 } else { *l })
            .collect();
        let borders = border_levels(&filled, 3);
        let n = (mesh.size - 1) as i64;
        let mut tris = Vec::new();
        for (i, &level) in grid.iter().enumerate() {
            if level.is_nan() {
                continue;
            }
            let patch = Patch {
                corner: [(i % 3) as i64 * n, (i / 3) as i64 * n],
                level,
                sides: borders[i],
            };
            let (k, sides) = patch.tessellation();
            let r = mesh.range(k, sides);
            for t in mesh.indices[r.start as usize..r.end as usize].chunks_exact(3) {
                tris.push([t[0], t[1], t[2]].map(|v| {
                    (
                        patch.corner[0] + (v % mesh.size) as i64,
                        patch.corner[1] + (v / mesh.size) as i64,
                    )
                }));
            }
        }
        tris
    }

    /// Every edge shared by two triangles in opposite directions (or on the union's outline
    /// once), no vertex inside another triangle's edge (no T-junction), area = 5 patches.
    fn assert_watertight(tris: &[[(i64, i64); 3]], n: i64, what: &str) {
        type Edge = ((i64, i64), (i64, i64));
        let mut edges: HashMap<Edge, u32> = HashMap::new();
        let mut verts = HashSet::new();
        let mut area2 = 0i64;
        for t in tris {
            let a = (t[1].0 - t[0].0) * (t[2].1 - t[0].1) - (t[2].0 - t[0].0) * (t[1].1 - t[0].1);
            assert!(a > 0, "{what}: triangle {t:?} not counter-clockwise");
            area2 += a;
            for e in 0..3 {
                *edges.entry((t[e], t[(e + 1) % 3])).or_default() += 1;
                verts.insert(t[e]);
            }
        }
        assert_eq!(
            area2,
            2 * 5 * n * n,
            "{what}: the patches are not tiled exactly"
        );
        let on_outline = |(a, b): ((i64, i64), (i64, i64))| {
            // The plus's outline: edges whose midpoint has only one patch around it.
            let m = ((a.0 + b.0) as f64 / 2.0, (a.1 + b.1) as f64 / 2.0);
            let inside = |x: f64, y: f64| {
                let (c, r) = ((x / n as f64).floor() as i64, (y / n as f64).floor() as i64);
                (0..3).contains(&c) && (0..3).contains(&r) && (c == 1 || r == 1)
            };
            let d = if a.0 == b.0 { (0.25, 0.0) } else { (0.0, 0.25) };
            inside(m.0 + d.0, m.1 + d.1) != inside(m.0 - d.0, m.1 - d.1)
        };
        for (&(a, b), &count) in &edges {
            assert_eq!(count, 1, "{what}: edge {a:?}→{b:?} used {count}×");
            let twin = edges.contains_key(&(b, a));
            assert!(
                twin || on_outline((a, b)),
                "{what}: edge {a:?}→{b:?} has no neighbour (crack)"
            );
            // No vertex strictly inside the edge (lattice points on the segment).
            let (dx, dy) = (b.0 - a.0, b.1 - a.1);
            let g = gcd(dx.abs(), dy.abs());
            for step in 1..g {
                let p = (a.0 + dx / g * step, a.1 + dy / g * step);
                assert!(
                    !verts.contains(&p),
                    "{what}: T-junction at {p:?} on {a:?}→{b:?}"
                );
            }
        }
    }

    fn gcd(a: i64, b: i64) -> i64 {
        if b == 0 { a } else { gcd(b, a % b) }
    }

    #[test]
    fn watertight_for_every_neighbour_level_combination() {
        for size in [5u32, 9, 17] {
            let mesh = PatchMesh::build(size);
            let levels = mesh.max_level + 1;
            let n = (size - 1) as i64;
            let mut combos = 0;
            for code in 0..levels.pow(5) {
                let l: [f64; 5] = std::array::from_fn(|i| {
                    (code / levels.pow(i as u32) % levels) as f64 + 0.25 * (i % 2) as f64
                });
                let tris = plus_mesh(&mesh, l);
                assert_watertight(&tris, n, &format!("size {size}, levels {l:?}"));
                combos += 1;
            }
            assert_eq!(combos, levels.pow(5));
        }
    }

    #[test]
    fn full_level_is_the_whole_lattice() {
        let mesh = PatchMesh::build(17);
        assert_eq!(mesh.range(0, [0; 4]).len(), 16 * 16 * 2 * 3);
        assert_eq!(mesh.range(4, [4; 4]).len(), 2 * 3);
        // Level 1 inside with coarsest borders still covers the patch exactly.
        let tris = patch_indices(17, 1, [4, 4, 4, 4]);
        assert!(tris.len() >= 3 * (6 * 6 * 2 + 4));
    }

    #[test]
    fn deltas_and_level_choice() {
        let size = 17;
        // A plane has no error at any level; a bump in the middle costs from level 1 on.
        let plane: Vec<f64> = (0..size * size).map(|v| (v % size) as f64 * 0.5).collect();
        assert!(patch_deltas(size, &plane).iter().all(|d| d.abs() < 1e-12));
        let mut bump = plane.clone();
        bump[(7 + 7 * size) as usize] += 2.0;
        let d = patch_deltas(size, &bump);
        assert_eq!(d[0], 0.0);
        assert!((d[1] - 2.0).abs() < 1e-12);
        assert!(d.windows(2).all(|w| w[1] >= DELTA_GROWTH * w[0]));
        // ρ_1 = 1000 · 2 / d: level 1 allowed from d = 2000 m on, tweened toward it before.
        assert!((continuous_level(&d, 100.0, 1000.0, 1.0) - 0.05).abs() < 1e-12);
        assert!((continuous_level(&d, 2000.0, 1000.0, 1.0) - 1.0).abs() < 1e-9);
        let far = 1000.0 * d[4];
        assert_eq!(continuous_level(&d, far, 1000.0, 1.0), 4.0);
        // Continuous in distance.
        let mut prev = continuous_level(&d, 1.0, 1000.0, 1.0);
        for i in 1..4000 {
            let l = continuous_level(&d, 1.0 + i as f64, 1000.0, 1.0);
            assert!(
                (l - prev).abs() < 0.01 || l.floor() == prev.floor() + 1.0 && l.fract() < 0.01,
                "{prev} → {l}"
            );
            prev = l;
        }
    }

    #[test]
    fn bad_settings_name_their_flag() {
        let ok = GeomipSettings::default();
        assert_eq!(ok.validate(), Ok(()));
        assert_eq!(ok.max_level(), 4);
        for size in [0, 1, 2, 3, 16, 18, 65, 129] {
            let e = GeomipSettings {
                patch_size: size,
                ..ok
            }
            .validate()
            .unwrap_err();
            assert!(e.to_string().starts_with("--patch-size"), "{e}");
        }
        for tau in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let e = GeomipSettings { tau_px: tau, ..ok }.validate().unwrap_err();
            assert!(e.to_string().starts_with("--tau"), "{e}");
        }
        for patches in [0, 1, 3, 66, 512] {
            let e = GeomipSettings { patches, ..ok }.validate().unwrap_err();
            assert!(e.to_string().starts_with("--patches"), "{e}");
        }
    }

    /// On-screen jumps between consecutive frames of a slow move (0.5 m per frame, about 25 m
    /// above rolling terrain, 1024 × 800, 60°, τ = 1 px), with or without geomorphing: the
    /// largest jump of a drawn vertex (one drawn in both frames moves; one that appears or
    /// goes is compared with the surface drawn where it was) and of the drawn surface at any
    /// lattice point (which also sees the adapting strips change shape), and the level switches.
    fn slow_move_jumps(geomorph: bool) -> (f64, f64, usize) {
        let size = 17u32;
        let mesh = PatchMesh::build(size);
        let cols = 12usize;
        let n = (size - 1) as i64;
        let extent = cols as i64 * n;
        // Rolling terrain with some short waves, spacing 1 m.
        let terrain = |x: i64, y: i64| {
            let (x, y) = (x as f64, y as f64);
            6.0 * (x / 37.0).sin() * (y / 23.0).cos() + 0.3 * (x / 5.3 + y / 7.1).sin()
        };
        let patches: Vec<[i64; 2]> = (0..cols * cols)
            .map(|i| [(i % cols) as i64 * n, (i / cols) as i64 * n])
            .collect();
        let heights: Vec<Vec<f64>> = patches
            .iter()
            .map(|c| {
                (0..size * size)
                    .map(|v| terrain(c[0] + (v % size) as i64, c[1] + (v / size) as i64))
                    .collect()
            })
            .collect();
        let deltas: Vec<Vec<f64>> = heights.iter().map(|h| patch_deltas(size, h)).collect();
        let lambda = 800.0 / (2.0 * (30f64).to_radians().tan());
        let tau = 1.0;
        type Heights = HashMap<(i64, i64), f64>;
        let mut prev: Option<(Heights, Heights)> = None;
        let (mut worst_vertex, mut worst_surface, mut switches) = (0.0f64, 0.0f64, 0usize);
        let mut prev_k: Vec<u32> = Vec::new();
        for frame in 0..200 {
            let eye = glam::DVec3::new(20.0 + 0.5 * frame as f64, 60.0, 28.0);
            let levels: Vec<f64> = patches
                .iter()
                .zip(&deltas)
                .zip(&heights)
                .map(|((c, d), h)| {
                    let (lo, hi) = h
                        .iter()
                        .fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
                    let nearest = glam::DVec3::new(
                        eye.x.clamp(c[0] as f64, (c[0] + n) as f64),
                        eye.y.clamp(c[1] as f64, (c[1] + n) as f64),
                        eye.z.clamp(lo, hi),
                    );
                    continuous_level(d, (nearest - eye).length(), lambda, tau)
                })
                .collect();
            let mut levels = levels;
            restrict_levels(&mut levels, cols);
            let borders = border_levels(&levels, cols);
            let (mut surface, mut vertices) = (Heights::new(), Heights::new());
            let mut ks = Vec::new();
            for (i, c) in patches.iter().enumerate() {
                let patch = Patch {
                    corner: *c,
                    level: levels[i],
                    sides: borders[i],
                };
                let (k, sides) = patch.tessellation();
                ks.push(k);
                let h = |x: u32, y: u32| heights[i][(x + y * size) as usize];
                for (v, z) in drawn_surface(&mesh, &patch, geomorph, &h)
                    .into_iter()
                    .enumerate()
                {
                    assert!(z.is_finite(), "lattice point not covered");
                    let key = (
                        c[0] + (v as u32 % size) as i64,
                        c[1] + (v as u32 / size) as i64,
                    );
                    surface.insert(key, z);
                }
                let r = mesh.range(k, sides);
                for &v in &mesh.indices[r.start as usize..r.end as usize] {
                    let (x, y) = (v % size, v / size);
                    let z = morphed_height(size, &patch, geomorph, x, y, &h);
                    let key = (c[0] + x as i64, c[1] + y as i64);
                    // A vertex two patches share is placed alike by both (no crack).
                    if let Some(old) = vertices.insert(key, z) {
                        assert!(
                            (old - z).abs() < 1e-9,
                            "shared vertex {key:?}: {old} vs {z}"
                        );
                    }
                }
            }
            assert_eq!(surface.len() as i64, (extent + 1) * (extent + 1));
            let px = |key: &(i64, i64), z: f64, dz: f64| {
                let dist = (glam::DVec3::new(key.0 as f64, key.1 as f64, z) - eye).length();
                lambda * dz.abs() / dist
            };
            if let Some((p_surface, p_vertices)) = &prev {
                switches += ks.iter().zip(&prev_k).filter(|(a, b)| a != b).count();
                for (key, &z) in &surface {
                    worst_surface = worst_surface.max(px(key, z, z - p_surface[key]));
                }
                for (key, &z) in &vertices {
                    let before = p_vertices.get(key).unwrap_or(&p_surface[key]);
                    worst_vertex = worst_vertex.max(px(key, z, z - before));
                }
                for (key, &z) in p_vertices {
                    if !vertices.contains_key(key) {
                        worst_vertex = worst_vertex.max(px(key, z, z - surface[key]));
                    }
                }
            }
            prev = Some((surface, vertices));
            prev_k = ks;
        }
        (worst_vertex, worst_surface, switches)
    }

    #[test]
    fn geomorphing_removes_popping_under_a_slow_move() {
        let (vertex_on, surface_on, switches_on) = slow_move_jumps(true);
        let (vertex_off, surface_off, switches_off) = slow_move_jumps(false);
        println!(
            "largest jump between frames, geomorphing on / off: vertices {vertex_on:.3} / \
             {vertex_off:.3} px, surface {surface_on:.3} / {surface_off:.3} px \
             ({switches_on} / {switches_off} level switches)"
        );
        assert!(
            switches_on > 10 && switches_off > 10,
            "the move must switch levels"
        );
        assert!(
            vertex_on <= 0.5,
            "geomorphing: a vertex jumps {vertex_on} px"
        );
        assert!(
            vertex_off > 2.0 * vertex_on,
            "without geomorphing vertices must pop: {vertex_off} vs {vertex_on}"
        );
        assert!(
            surface_on <= 0.5,
            "geomorphing: the surface jumps {surface_on} px"
        );
        assert!(
            surface_off > 2.0 * surface_on,
            "{surface_off} vs {surface_on}"
        );
    }
}
