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
//! to. The paper needed one duplicated line; with our sign convention (DESIGN.md) the north pole
//! lies beyond φ̃ = π and the south pole beyond φ̃ = 0, so both are handled.

use std::ops::Range;

use bytemuck::{Pod, Zeroable};

use super::settings::{ClipmapSettings, ring_theta_rad};

/// One vertex of the ring mesh. The GPU twin is `RingVertex` in `shaders/terrain.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RingVertex {
    /// p̃ of eq. 2, computed in f64 and rounded once.
    pub p_tilde: [f32; 3],
    /// 1 − cos θ̃ written as 2·sin²(θ̃/2) in f64 (never formed in f32: DESIGN.md).
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

/// The whole static mesh plus the index range of every (level, sector) and cap.
#[derive(Debug)]
pub struct RingMesh {
    pub vertices: Vec<RingVertex>,
    pub indices: Vec<u32>,
    /// `bands[level][sector]`: indices of the ring band of that sector.
    pub bands: Vec<Vec<Range<u32>>>,
    /// `caps[level][sector]`: indices of the fill cap inside level `level`.
    pub caps: Vec<Vec<Range<u32>>>,
    pub phi_steps: u32,
    pub rings_per_level: u32,
    pub sectors: u32,
}

impl RingMesh {
    /// Builds the mesh for validated settings.
    pub fn build(settings: &ClipmapSettings) -> Self {
        let n = settings.phi_steps;
        let m = settings.rings_per_level;
        let sectors = settings.sectors;
        let per_sector = n / sectors;
        let half = n / 2;
        let columns = n + 2; // k = 0..=n plus the duplicate of k = n/2
        let per_level = (m + 1) * columns + 1;
        let total_vertices = settings.levels as usize * per_level as usize;
        let mut vertices = Vec::with_capacity(total_vertices);
        let mut indices = Vec::new();
        let mut bands = Vec::with_capacity(settings.levels as usize);

        for level in 0..settings.levels {
            let base = vertices.len() as u32;
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

            // Column index of φ̃ step k as seen by the triangles of the sector holding
            // [k0, k0+1]: the π meridian's left copy closes the east half, its right copy opens
            // the west half.
            let column =
                |k: u32, k0: u32| -> u32 { if k == half && k0 >= half { n + 1 } else { k } };
            let vid = |j: u32, col: u32| base + j * columns + col;

            let mut level_bands = Vec::with_capacity(sectors as usize);
            for s in 0..sectors {
                let start = indices.len() as u32;
                for j in 0..m {
                    for k0 in s * per_sector..(s + 1) * per_sector {
                        let (c0, c1) = (column(k0, k0), column(k0 + 1, k0));
                        let (a, b) = (vid(j, c0), vid(j, c1));
                        let (c, d) = (vid(j + 1, c0), vid(j + 1, c1));
                        // Counter-clockwise seen from outside the sphere.
                        indices.extend_from_slice(&[a, b, c, b, d, c]);
                    }
                }
                level_bands.push(start..indices.len() as u32);
            }
            bands.push(level_bands);
        }

        let mut caps = Vec::with_capacity(settings.levels as usize);
        for level in 0..settings.levels {
            let base = level * per_level;
            let centre = base + per_level - 1;
            let mut level_caps = Vec::with_capacity(sectors as usize);
            for s in 0..sectors {
                let start = indices.len() as u32;
                for k0 in s * per_sector..(s + 1) * per_sector {
                    let c0 = if k0 == half { n + 1 } else { k0 };
                    let c1 = if k0 + 1 == half { half } else { k0 + 1 };
                    let rim = |col: u32| base + m * columns + col;
                    indices.extend_from_slice(&[centre, rim(c0), rim(c1)]);
                }
                level_caps.push(start..indices.len() as u32);
            }
            caps.push(level_caps);
        }

        Self {
            vertices,
            indices,
            bands,
            caps,
            phi_steps: n,
            rings_per_level: m,
            sectors,
        }
    }

    /// φ̃ range [start, end) of a sector in radians.
    pub fn sector_phi_range_rad(&self, sector: u32) -> (f64, f64) {
        let w = std::f64::consts::TAU / self.sectors as f64;
        (sector as f64 * w, (sector + 1) as f64 * w)
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

    #[test]
    fn index_counts_match_formula() {
        let s = small();
        let mesh = RingMesh::build(&s);
        for level in 0..s.levels as usize {
            let band: u32 = mesh.bands[level].iter().map(|r| r.end - r.start).sum();
            assert_eq!(band as u64, 3 * s.triangles_per_level());
            let cap: u32 = mesh.caps[level].iter().map(|r| r.end - r.start).sum();
            assert_eq!(cap as u64, 3 * s.triangles_per_cap());
        }
        assert!(
            mesh.indices
                .iter()
                .all(|&i| (i as usize) < mesh.vertices.len())
        );
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
