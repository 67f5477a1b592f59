//! The static ring mesh of the spherical clipmap (spherical-clipmaps.md §3.4, §4.4).
//!
//! Built once in f64 and uploaded once: concentric rings around the viewer in view space, level
//! i covering θ̃ ∈ (2^−(i+1)π, 2^−iπ] with m rings θ̃_{i,j} = θ̃_{i,0}·2^(−j/m) and n φ̃ steps.
//! Every level keeps its own vertices, so a boundary ring exists twice (once as the outer ring
//! of the finer level, once as the inner ring of the coarser); both copies have the same p̃,
//! so the seam between levels has no T-junction (the constant φ̃ discretisation, §3.4).
//!
//! Each level is split into φ̃ sectors, each a contiguous index range, so sectors outside the
//! frustum are simply not drawn. A fill cap (a fan of n triangles from the nadir to the inner
//! ring) exists per level; the renderer draws the cap of the finest drawn level only.
//!
//! Seam meridians (§4.4): a vertex on φ̃ = 0 or φ̃ = π has p̃y = 0 exactly. Beyond a pole
//! (p_x < 0) atan2 cannot tell which side of the ±π cut it belongs to, so such vertices are
//! duplicated, each copy carrying `seam_side` = ±1, the sign of p̃y of the triangles it belongs
//! to. The paper needed one duplicated line; with our sign convention (docs/design.md#conventions) the north pole
//! lies beyond φ̃ = π and the south pole beyond φ̃ = 0, so both are handled.

use std::collections::HashMap;
use std::ops::Range;

use bytemuck::{Pod, Zeroable};

use super::settings::{ClipmapSettings, ring_theta_rad};

/// One vertex of the ring mesh. The GPU twin is `RingVertex` in `shaders/terrain.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RingVertex {
    /// p̃ of eq. 2, computed in f64 and rounded once.
    pub p_tilde: [f32; 3],
    /// 1 − cos θ̃ written as 2·sin²(θ̃/2) in f64 (never formed in f32: docs/design.md#numerics).
    pub one_minus_cos: f32,
    /// θ̃ in radians.
    pub theta_tilde_rad: f32,
    /// j/m: 0 on the level's outer ring, 1 on its inner ring; drives the blend into the
    /// coarser level and the approximation blend.
    pub ring_t: f32,
    /// Level i (0 = coarsest).
    pub level: u32,
    /// −1, 0 or +1: which side of the ±π cut this seam vertex belongs to (§4.4).
    pub seam_side: f32,
}

/// Index ranges of one level at one density, per φ̃ sector.
#[derive(Debug, Default)]
pub struct LevelRanges {
    /// The quad rows between the level's two edge rows (all rows when it has a single one)
    /// whose vertices all lie inside the blend band's inner edge (no coarse-level blend)…
    pub body: Vec<Range<u32>>,
    /// …and those whose outer ring blends into the coarser level (the renderer draws them
    /// with the blending shader).
    pub body_blend: Vec<Range<u32>>,
    /// Whether the innermost row's vertices blend (only with a blend band of nearly the whole
    /// level); the outermost row's always do.
    pub inner_blends: bool,
    /// `outer[kb − k]`: the outermost row, its outer ring (shared with the next coarser level)
    /// at density `kb` ≥ k, fanned onto the row's inner ring at density k.
    pub outer: Vec<Vec<Range<u32>>>,
    /// `inner[kb − k]`: the innermost row, its inner ring (shared with the next finer level)
    /// at density `kb` ≥ k.
    pub inner: Vec<Vec<Range<u32>>>,
    /// The fill cap (a fan from the nadir to the inner ring at density k).
    pub cap: Vec<Range<u32>>,
}

/// The whole static mesh: one full-density vertex grid per level, and index ranges for every
/// level, density and sector.
///
/// Density k draws every 2^k-th φ̃ step and every 2^k-th ring of the same vertices (issue 14:
/// triangles by projected size). Where two levels of different densities meet, the shared
/// ring is drawn at the coarser of the two by both (the finer level's edge row fans onto it),
/// so the seam has neither cracks nor T-junctions; the vertex shader morphs the vertices a
/// coarser density drops onto the coarser surface before the switch (no popping).
#[derive(Debug)]
pub struct RingMesh {
    pub vertices: Vec<RingVertex>,
    pub indices: Vec<u32>,
    /// `levels[level][k]`: the index ranges of that level at density k.
    pub levels: Vec<Vec<LevelRanges>>,
    pub phi_steps: u32,
    pub rings_per_level: u32,
    pub sectors: u32,
    /// Densities 0..=max_density exist.
    pub max_density: u32,
}

/// The coarsest density a level can be drawn at (at most `MAX_DENSITY`): every density k has
/// m/2^k ≥ 2 rings (distinct edge rows) and whole, even φ̃ steps per sector (n/2^k a multiple
/// of the sector count, and even so that the φ̃ = π meridian stays a vertex).
pub fn max_density(settings: &ClipmapSettings) -> u32 {
    let (n, m) = (settings.phi_steps, settings.rings_per_level);
    let mut k = 0;
    while k < MAX_DENSITY {
        let s = 2u32 << k; // the stride of density k + 1
        let rings_ok = m.is_multiple_of(s) && m / s >= 2;
        let steps_ok = n.is_multiple_of(s * settings.sectors) && (n / s).is_multiple_of(2);
        if !(rings_ok && steps_ok) {
            break;
        }
        k += 1;
    }
    k
}

/// A bound on the densities built, so that the index ranges per level stay few: density 5
/// already draws 1/1024 of a level's full-density triangles.
pub const MAX_DENSITY: u32 = 5;

impl RingMesh {
    /// Builds the mesh for validated settings.
    pub fn build(settings: &ClipmapSettings) -> Self {
        let n = settings.phi_steps;
        let m = settings.rings_per_level;
        let sectors = settings.sectors;
        let half = n / 2;
        let columns = n + 2; // k = 0..=n plus the duplicate of k = n/2
        let per_level = (m + 1) * columns + 1;
        let total_vertices = settings.levels as usize * per_level as usize;
        let max_k = max_density(settings);
        let mut vertices = Vec::with_capacity(total_vertices);
        let mut indices = Vec::new();
        let mut levels = Vec::with_capacity(settings.levels as usize);

        for level in 0..settings.levels {
            let base = vertices.len() as u32;
            push_level_vertices(&mut vertices, level, n, m);
            let grid = LevelGrid {
                base,
                n,
                m,
                half,
                columns,
                sectors,
                centre: base + per_level - 1,
            };
            let mut per_density = Vec::with_capacity(max_k as usize + 1);
            for k in 0..=max_k {
                per_density.push(grid.ranges(&mut indices, k, max_k, settings.blend_fraction));
            }
            levels.push(per_density);
        }

        Self {
            vertices,
            indices,
            levels,
            phi_steps: n,
            rings_per_level: m,
            sectors,
            max_density: max_k,
        }
    }

    /// φ̃ range [start, end) of a sector in radians.
    pub fn sector_phi_range_rad(&self, sector: u32) -> (f64, f64) {
        let w = std::f64::consts::TAU / self.sectors as f64;
        (sector as f64 * w, (sector + 1) as f64 * w)
    }

    /// Vertices of one level (the full-density grid, its nadir last).
    pub fn vertices_per_level(&self) -> u32 {
        (self.rings_per_level + 1) * (self.phi_steps + 2) + 1
    }

    /// Triangles of one whole level at density k whose edge rings are drawn at `outer` and
    /// `inner` (≥ k), without its cap.
    pub fn triangles(&self, level: u32, k: u32, outer: u32, inner: u32) -> u64 {
        let r = &self.levels[level as usize][k as usize];
        let count = |v: &[Range<u32>]| v.iter().map(|r| (r.end - r.start) as u64 / 3).sum::<u64>();
        count(&r.body)
            + count(&r.body_blend)
            + count(&r.outer[(outer - k) as usize])
            + count(&r.inner[(inner - k) as usize])
    }
}

/// One level's full-density vertex grid, ring by ring (n + 2 columns: the φ̃ = π meridian
/// twice, one copy per side of the seam), then its nadir: every density's triangles index
/// into these same vertices.
fn push_level_vertices(vertices: &mut Vec<RingVertex>, level: u32, n: u32, m: u32) {
    let half = n / 2;
    let columns = n + 2;
    for j in 0..=m {
        let theta = ring_theta_rad(level, j, m);
        let ring_t = j as f32 / m as f32;
        for k in 0..columns {
            // Column n+1 is the second copy of the φ̃ = π meridian.
            let (step, seam_side) = match k {
                0 => (0, 1.0),
                k if k == n => (n, -1.0),
                k if k == half => (half, 1.0),
                k if k == n + 1 => (half, -1.0),
                k => (k, 0.0),
            };
            vertices.push(ring_vertex(theta, step, n, ring_t, level, seam_side));
        }
    }
    // Nadir vertex (θ̃ = 0), the centre of this level's cap.
    vertices.push(RingVertex {
        p_tilde: [0.0, 0.0, 1.0],
        level,
        ring_t: 1.0,
        ..Default::default()
    });
}

/// Where one level's vertices lie in the mesh, so that its triangles can name them: `base`
/// its first vertex, `centre` its nadir.
struct LevelGrid {
    base: u32,
    n: u32,
    m: u32,
    half: u32,
    columns: u32,
    sectors: u32,
    centre: u32,
}

impl LevelGrid {
    /// Column of φ̃ step t as seen by triangles of the coarse segment starting at t0:
    /// the π meridian's left copy closes the east half, its right copy opens the west.
    fn column(&self, t: u32, t0: u32) -> u32 {
        if t == self.half && t0 >= self.half {
            self.n + 1
        } else {
            t
        }
    }

    /// The vertex of ring `j`, column `col`.
    fn vid(&self, j: u32, col: u32) -> u32 {
        self.base + j * self.columns + col
    }

    /// φ̃ steps [start, end) of a sector.
    fn sector_steps(&self, sector: u32) -> (u32, u32) {
        let (n, sectors) = (self.n, self.sectors);
        (sector * n / sectors, (sector + 1) * n / sectors)
    }

    /// The index ranges of the level at density `k`: its body rows (blending or not), its
    /// edge rows against every coarser neighbour density `kb`, and its cap, per sector.
    fn ranges(
        &self,
        indices: &mut Vec<u32>,
        k: u32,
        max_k: u32,
        blend_fraction: f32,
    ) -> LevelRanges {
        let m = self.m;
        let sectors = self.sectors;
        let s = 1u32 << k;
        let rows = m / s;
        let mut ranges = LevelRanges::default();
        // Rows 1..rows−1 (all of them when a level has a single row: then only
        // density 0 exists and every neighbour shares it).
        let body_rows = if rows >= 2 { 1..rows - 1 } else { 0..rows };
        // A row blends when its outer ring does (ring_t < blend fraction, as the
        // vertex shader's weight clamp(1 − ring_t/b, 0, 1) > 0).
        let blends = |r: u32| ((r * s) as f32 / m as f32) < blend_fraction;
        ranges.inner_blends = rows >= 2 && blends(rows - 1);
        for (want, out) in [(true, &mut ranges.body_blend), (false, &mut ranges.body)] {
            for sector in 0..sectors {
                let start = indices.len() as u32;
                for r in body_rows.clone().filter(|&r| blends(r) == want) {
                    self.row(indices, sector, (r * s, k), ((r + 1) * s, k));
                }
                out.push(start..indices.len() as u32);
            }
        }
        for kb in k..=max_k {
            let mut outer = Vec::with_capacity(sectors as usize);
            let mut inner = Vec::with_capacity(sectors as usize);
            for sector in 0..sectors {
                let start = indices.len() as u32;
                if rows >= 2 {
                    self.row(indices, sector, (0, kb), (s, k));
                }
                outer.push(start..indices.len() as u32);
            }
            for sector in 0..sectors {
                let start = indices.len() as u32;
                if rows >= 2 {
                    self.row(indices, sector, (m - s, k), (m, kb));
                }
                inner.push(start..indices.len() as u32);
            }
            ranges.outer.push(outer);
            ranges.inner.push(inner);
        }
        for sector in 0..sectors {
            let start = indices.len() as u32;
            self.cap(indices, sector, s);
            ranges.cap.push(start..indices.len() as u32);
        }
        ranges
    }

    /// Triangles of one quad row of one sector: its outer ring j_out at density a, its inner
    /// ring j_in at density b. The coarser ring's segments fan onto the finer ring's vertices
    /// (a plain quad strip when a == b).
    fn row(
        &self,
        indices: &mut Vec<u32>,
        sector: u32,
        (j_out, a): (u32, u32),
        (j_in, b): (u32, u32),
    ) {
        let outer_coarse = a >= b;
        let (coarse, fine) = if outer_coarse { (a, b) } else { (b, a) };
        let (big, small) = (1u32 << coarse, 1u32 << fine);
        let r = big / small;
        let (t_start, t_end) = self.sector_steps(sector);
        let mut c0 = t_start;
        while c0 < t_end {
            let c1 = c0 + big;
            let f = |i: u32| self.column(c0 + i * small, c0);
            if outer_coarse {
                let (b0, b1) = (
                    self.vid(j_out, self.column(c0, c0)),
                    self.vid(j_out, self.column(c1, c0)),
                );
                let fi = |i: u32| self.vid(j_in, f(i));
                for i in 0..r / 2 {
                    indices.extend_from_slice(&[b0, fi(i + 1), fi(i)]);
                }
                indices.extend_from_slice(&[b0, b1, fi(r / 2)]);
                for i in r / 2..r {
                    indices.extend_from_slice(&[b1, fi(i + 1), fi(i)]);
                }
            } else {
                let (b0, b1) = (
                    self.vid(j_in, self.column(c0, c0)),
                    self.vid(j_in, self.column(c1, c0)),
                );
                let fi = |i: u32| self.vid(j_out, f(i));
                for i in 0..r / 2 {
                    indices.extend_from_slice(&[fi(i), fi(i + 1), b0]);
                }
                indices.extend_from_slice(&[fi(r / 2), b1, b0]);
                for i in r / 2..r {
                    indices.extend_from_slice(&[fi(i), fi(i + 1), b1]);
                }
            }
            c0 = c1;
        }
    }

    /// One sector of the fill cap at stride `s`: a fan from the nadir to the inner ring.
    fn cap(&self, indices: &mut Vec<u32>, sector: u32, s: u32) {
        let (n, half, m) = (self.n, self.half, self.m);
        let (t_start, t_end) = self.sector_steps(sector);
        let mut t0 = t_start;
        while t0 < t_end {
            let t1 = t0 + s;
            let c0 = if t0 == half { n + 1 } else { t0 };
            let c1 = if t1 == half { half } else { t1 };
            indices.extend_from_slice(&[self.centre, self.vid(m, c0), self.vid(m, c1)]);
            t0 = t1;
        }
    }
}

/// The distinct vertices of every index range of a [`RingMesh`], for the vertex pre-pass
/// (`render::placement`): a frame places each vertex its drawn ranges use once, instead of
/// once per triangle-list position a vertex cache happens to miss.
#[derive(Debug, Default)]
pub struct RangeVertices {
    /// Every range's vertex ids, ascending, one range after the other.
    ids: Vec<u32>,
    /// Index range → its slice of `ids`.
    of: HashMap<(u32, u32), Range<u32>>,
}

impl RangeVertices {
    /// The lists of every non-empty range of every level, density and part of `mesh`.
    pub fn build(mesh: &RingMesh) -> Self {
        let mut out = Self::default();
        // `seen[v] == stamp`: v already listed for the range being built.
        let mut seen = vec![0u32; mesh.vertices.len()];
        let mut stamp = 0u32;
        let ranges = mesh.levels.iter().flatten().flat_map(|r| {
            r.body
                .iter()
                .chain(&r.body_blend)
                .chain(r.outer.iter().flatten())
                .chain(r.inner.iter().flatten())
                .chain(&r.cap)
        });
        for range in ranges {
            if range.is_empty() || out.of.contains_key(&(range.start, range.end)) {
                continue;
            }
            stamp += 1;
            let start = out.ids.len();
            for &i in &mesh.indices[range.start as usize..range.end as usize] {
                if seen[i as usize] != stamp {
                    seen[i as usize] = stamp;
                    out.ids.push(i);
                }
            }
            out.ids[start..].sort_unstable();
            out.of
                .insert((range.start, range.end), start as u32..out.ids.len() as u32);
        }
        out
    }

    /// The distinct vertices of the mesh's index range `range` (one of its sector ranges, not
    /// a merged one); empty for a range the mesh does not have.
    pub fn get(&self, range: &Range<u32>) -> &[u32] {
        self.of
            .get(&(range.start, range.end))
            .map_or(&[], |r| &self.ids[r.start as usize..r.end as usize])
    }
}

fn ring_vertex(
    theta: f64,
    step: u32,
    n: u32,
    ring_t: f32,
    level: u32,
    seam_side: f32,
) -> RingVertex {
    let (sin_t, cos_t) = theta.sin_cos();
    // Exact values on the seam meridians so that p̃y == 0 there (§4.4).
    let (px, py) = if step == 0 || step == n {
        (sin_t, 0.0)
    } else if 2 * step == n {
        (-sin_t, 0.0)
    } else {
        let phi = std::f64::consts::TAU * step as f64 / n as f64;
        (phi.cos() * sin_t, phi.sin() * sin_t)
    };
    let half_sin = (0.5 * theta).sin();
    RingVertex {
        p_tilde: [px as f32, py as f32, cos_t as f32],
        one_minus_cos: (2.0 * half_sin * half_sin) as f32,
        theta_tilde_rad: theta as f32,
        ring_t,
        level,
        seam_side,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small() -> ClipmapSettings {
        ClipmapSettings {
            phi_steps: 32,
            rings_per_level: 4,
            levels: 5,
            sectors: 4,
            ..Default::default()
        }
    }

    /// Density 0 with density-0 neighbours is the paper's mesh: 2·n·m triangles per level and
    /// an n-triangle cap; every index is a vertex.
    #[test]
    fn index_counts_match_formula() {
        let s = small();
        let mesh = RingMesh::build(&s);
        for level in 0..s.levels {
            assert_eq!(mesh.triangles(level, 0, 0, 0), s.triangles_per_level());
            let cap: u32 = mesh.levels[level as usize][0]
                .cap
                .iter()
                .map(|r| r.end - r.start)
                .sum();
            assert_eq!(cap as u64, 3 * s.triangles_per_cap());
        }
        assert!(
            mesh.indices
                .iter()
                .all(|&i| (i as usize) < mesh.vertices.len())
        );
    }

    /// Each range's list holds exactly the distinct vertices its triangles index, once each.
    #[test]
    fn range_vertices_are_the_distinct_indices() {
        let mesh = RingMesh::build(&dense());
        let lists = RangeVertices::build(&mesh);
        let mut checked = 0;
        for r in mesh.levels.iter().flatten() {
            for range in r
                .body
                .iter()
                .chain(&r.body_blend)
                .chain(r.outer.iter().flatten())
                .chain(r.inner.iter().flatten())
                .chain(&r.cap)
            {
                let mut want: Vec<u32> =
                    mesh.indices[range.start as usize..range.end as usize].to_vec();
                want.sort_unstable();
                want.dedup();
                assert_eq!(lists.get(range), &want[..], "range {range:?}");
                checked += !range.is_empty() as u32;
            }
        }
        assert!(checked > 100, "only {checked} ranges");
        // A merged range is not one of the mesh's: nothing to place.
        assert!(lists.get(&(0..u32::MAX)).is_empty());
    }

    fn dense() -> ClipmapSettings {
        ClipmapSettings {
            phi_steps: 128,
            rings_per_level: 16,
            levels: 4,
            sectors: 4,
            ..Default::default()
        }
    }

    type Key = [u32; 4];

    /// A vertex's position key (seam copies share it).
    fn key(v: &RingVertex) -> Key {
        [
            v.p_tilde[0].to_bits(),
            v.p_tilde[1].to_bits(),
            v.p_tilde[2].to_bits(),
            v.level,
        ]
    }

    /// Undirected edges by position of a set of index ranges, with their triangle counts.
    fn edges(
        mesh: &RingMesh,
        ranges: &[&Range<u32>],
    ) -> std::collections::HashMap<(Key, Key), u32> {
        let mut e = std::collections::HashMap::new();
        for r in ranges {
            for tri in mesh.indices[r.start as usize..r.end as usize].chunks(3) {
                let k: Vec<Key> = tri
                    .iter()
                    .map(|&i| key(&mesh.vertices[i as usize]))
                    .collect();
                assert!(
                    k[0] != k[1] && k[1] != k[2] && k[0] != k[2],
                    "degenerate triangle"
                );
                for (a, b) in [(k[0], k[1]), (k[1], k[2]), (k[2], k[0])] {
                    *e.entry(if a < b { (a, b) } else { (b, a) }).or_insert(0) += 1;
                }
            }
        }
        e
    }

    /// Every density with every pair of edge densities is a closed band: interior edges
    /// belong to exactly two triangles (no T-junction, no hole), the edge rings to one, and
    /// the outer and inner rings are cut into exactly n/2^kb segments.
    #[test]
    fn every_density_combination_is_watertight() {
        watertight(&dense(), 3);
        // Densities 4 and 5 (2 rings of 2^k, one φ̃ step per sector at the coarsest).
        watertight(
            &ClipmapSettings {
                phi_steps: 256,
                rings_per_level: 64,
                levels: 3,
                sectors: 4,
                ..Default::default()
            },
            5,
        );
    }

    fn watertight(s: &ClipmapSettings, max_density: u32) {
        let mesh = RingMesh::build(s);
        assert_eq!(mesh.max_density, max_density);
        let n = s.phi_steps;
        let m = s.rings_per_level;
        let level = 2;
        let rings: HashMap<Key, u32> = mesh
            .vertices
            .iter()
            .map(|v| (key(v), (v.ring_t * m as f32).round() as u32))
            .collect();
        let ring_of = |k: &Key| rings[k];
        for k in 0..=mesh.max_density {
            let lr = &mesh.levels[level][k as usize];
            for ko in k..=mesh.max_density {
                for ki in k..=mesh.max_density {
                    let mut ranges: Vec<&Range<u32>> =
                        lr.body.iter().chain(&lr.body_blend).collect();
                    ranges.extend(lr.outer[(ko - k) as usize].iter());
                    ranges.extend(lr.inner[(ki - k) as usize].iter());
                    let e = edges(&mesh, &ranges);
                    let (mut outer, mut inner) = (0, 0);
                    for ((a, b), count) in &e {
                        let (ra, rb) = (ring_of(a), ring_of(b));
                        if ra == 0 && rb == 0 {
                            assert_eq!(*count, 1);
                            outer += 1;
                        } else if ra == m && rb == m {
                            assert_eq!(*count, 1);
                            inner += 1;
                        } else {
                            assert_eq!(*count, 2, "k {k} outer {ko} inner {ki}: open edge");
                        }
                    }
                    assert_eq!(outer, n >> ko, "k {k}: outer ring segments");
                    assert_eq!(inner, n >> ki, "k {k}: inner ring segments");
                    assert_eq!(
                        mesh.triangles(level as u32, k, ko, ki),
                        ranges
                            .iter()
                            .map(|r| ((r.end - r.start) / 3) as u64)
                            .sum::<u64>()
                    );
                }
            }
            // The cap closes the inner ring at the level's own density.
            let e = edges(&mesh, &lr.cap.iter().collect::<Vec<_>>());
            let nadir = |k: &Key| k[..3] == [0.0f32.to_bits(), 0.0f32.to_bits(), 1.0f32.to_bits()];
            let rim = e
                .keys()
                .filter(|(a, b)| !nadir(a) && !nadir(b) && ring_of(a) == m && ring_of(b) == m)
                .count();
            assert_eq!(rim, (n >> k) as usize);
        }
    }

    /// Where level l (outer ring) meets level l−1 (inner ring), both draw the shared ring at
    /// the coarser density: the same segments, position for position.
    #[test]
    fn shared_rings_match_across_levels() {
        let s = dense();
        let mesh = RingMesh::build(&s);
        let m = s.rings_per_level;
        let ring_edges = |level: u32, ranges: &[Range<u32>], ring: u32| {
            let e = edges(&mesh, &ranges.iter().collect::<Vec<_>>());
            let mut out: Vec<[[u32; 3]; 2]> = e
                .keys()
                .filter(|(a, b)| {
                    let on = |k: &Key| {
                        mesh.vertices.iter().any(|v| {
                            key(v) == *k
                                && v.level == level
                                && (v.ring_t * m as f32).round() as u32 == ring
                        })
                    };
                    on(a) && on(b)
                })
                .map(|(a, b)| {
                    let mut p = [[a[0], a[1], a[2]], [b[0], b[1], b[2]]];
                    p.sort();
                    p
                })
                .collect();
            out.sort();
            out
        };
        for (k_fine, k_coarse) in [(0, 2), (3, 1), (1, 1)] {
            let kb = k_fine.max(k_coarse);
            let fine = &mesh.levels[2][k_fine as usize].outer[(kb - k_fine) as usize];
            let coarse = &mesh.levels[1][k_coarse as usize].inner[(kb - k_coarse) as usize];
            let a = ring_edges(2, fine, 0);
            let b = ring_edges(1, coarse, m);
            assert_eq!(a.len(), (s.phi_steps >> kb) as usize);
            assert_eq!(a, b, "fine {k_fine} coarse {k_coarse}");
        }
    }

    /// Level boundaries have no T-junctions: the outer ring of level i and the inner ring of
    /// level i−1 have the same vertices (bitwise equal p̃ and 1 − cos θ̃), column by column.
    #[test]
    fn level_boundaries_coincide() {
        let s = small();
        let mesh = RingMesh::build(&s);
        let columns = (s.phi_steps + 2) as usize;
        let per_level = (s.rings_per_level as usize + 1) * columns + 1;
        for level in 1..s.levels as usize {
            let outer = &mesh.vertices[level * per_level..][..columns];
            let inner_of_coarser = &mesh.vertices
                [(level - 1) * per_level + s.rings_per_level as usize * columns..][..columns];
            for (a, b) in outer.iter().zip(inner_of_coarser) {
                assert_eq!(a.p_tilde, b.p_tilde);
                assert_eq!(a.one_minus_cos, b.one_minus_cos);
                assert_eq!(a.seam_side, b.seam_side);
                // The finer level's copy blends fully into the coarser texture (ring_t 0), the
                // coarser level's copy not at all (ring_t 1): both sample the same heights.
                assert_eq!((a.ring_t, b.ring_t), (0.0, 1.0));
            }
        }
    }

    /// Every seam vertex (p̃y = 0 on φ̃ = 0 or π) exists twice, once per side, and every
    /// triangle touching a seam uses the copy of its own side.
    #[test]
    fn seam_meridians_are_duplicated_per_side() {
        let s = small();
        let mesh = RingMesh::build(&s);
        let seam: Vec<&RingVertex> = mesh
            .vertices
            .iter()
            .filter(|v| v.seam_side != 0.0)
            .collect();
        // Two meridians × two copies × (m+1) rings × levels.
        assert_eq!(seam.len() as u32, 4 * (s.rings_per_level + 1) * s.levels);
        for v in &seam {
            assert_eq!(v.p_tilde[1], 0.0, "seam vertex with p̃y ≠ 0");
            let twins = seam
                .iter()
                .filter(|w| w.p_tilde == v.p_tilde && w.level == v.level && w.ring_t == v.ring_t)
                .count();
            assert_eq!(twins, 2);
        }
        for tri in mesh.indices.chunks(3) {
            let vs: Vec<&RingVertex> = tri.iter().map(|&i| &mesh.vertices[i as usize]).collect();
            let side: f32 = vs
                .iter()
                .filter(|v| v.seam_side == 0.0)
                .map(|v| v.p_tilde[1].signum())
                .sum();
            for v in vs.iter().filter(|v| v.seam_side != 0.0) {
                if side != 0.0 {
                    assert_eq!(
                        v.seam_side,
                        side.signum(),
                        "triangle uses the wrong seam copy"
                    );
                }
            }
        }
    }
}
