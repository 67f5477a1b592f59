//! Map-space windows of the clipmap level textures and their toroidal updates
//! (spherical-clipmaps.md §4.1).
//!
//! Level i's texture is an S×S grid of height samples in map space (φ, θ). Grid point (gx, gy)
//! sits at φ = gx·dφ, θ = gy·dθ and is stored in texel (gx mod S, gy mod S): toroidal
//! addressing, so when the viewer moves only the new rows and columns are written.
//!
//! - θ: the texture spans 4·θ̃_{i,0} (twice the level's diameter), so dθ = 4·2^−i·π / S. The
//!   margin lets the blend and the fragment normals read a little beyond the level.
//! - φ: the span is 2π/2^k, the smallest power-of-two fraction of the circle that covers the
//!   level's footprint at the viewer's colatitude (§4.1: power-of-two steps, so a small move in
//!   θv does not rescale the texture); 2π (k = 0) when the footprint contains a pole. Because the
//!   span divides 2π, φ's own wrap-around and the toroidal wrap agree.

use std::f64::consts::{PI, TAU};

use super::settings::level_outer_theta_rad;

/// The map-space grid of one level for one viewer position.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LevelGrid {
    pub level: u32,
    /// log2 of 2π / (φ span): the span is 2π/2^k.
    pub phi_pow: u32,
    pub dphi_rad: f64,
    pub dtheta_rad: f64,
    /// First grid column of the window, reduced modulo the φ period `period_x()`.
    pub gx0: i64,
    /// First grid row of the window (θ does not wrap; rows beyond a pole are valid samples of
    /// the points across it).
    pub gy0: i64,
    pub size: u32,
    /// The height the level's texture stores its heights from (metres, exact in f32): h − ref
    /// keeps f32's relative precision near the eye, where absolute heights would step by
    /// ulp(h) (0.5 mm at 4 km; [`reference_height_m`]). A new reference rewrites the level.
    pub ref_m: f64,
}

/// A rectangle of grid points to (re)compute: columns gx0..gx0+width (modulo the φ period),
/// rows gy0..gy0+height.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GridRect {
    pub gx0: i64,
    pub gy0: i64,
    pub width: u32,
    pub height: u32,
}

impl GridRect {
    pub fn texels(&self) -> u64 {
        self.width as u64 * self.height as u64
    }

    /// The rectangle cut along a lattice of `block` × `block` grid points, each piece with its
    /// block's corner (a multiple of `block` in gx and gy). The fills compute a texel from its
    /// block's corner: a texel's f32 sums are then a function of its grid point alone, not of
    /// the rectangle that happened to hold it when it was filled, so a settled view does not
    /// depend on the path to it (`globe bench --scene soak`).
    pub fn anchored_pieces(&self, block: i64) -> Vec<(GridRect, [i64; 2])> {
        let cuts = |start: i64, len: u32| {
            let end = start + len as i64;
            let mut out = Vec::new();
            let mut a = start;
            while a < end {
                let corner = a.div_euclid(block) * block;
                let b = (corner + block).min(end);
                out.push((a, (b - a) as u32, corner));
                a = b;
            }
            out
        };
        let rows = cuts(self.gy0, self.height);
        let mut out = Vec::new();
        for (x, w, cx) in cuts(self.gx0, self.width) {
            for &(y, h, cy) in &rows {
                let piece = GridRect {
                    gx0: x,
                    gy0: y,
                    width: w,
                    height: h,
                };
                out.push((piece, [cx, cy]));
            }
        }
        out
    }
}

impl LevelGrid {
    /// Ground spacing used for the band limit of the level: twice its θ spacing, a per-level
    /// constant (so strips written at different times agree) that bounds the φ spacing away
    /// from the poles (anisotropy ≤ 2, see the module docs).
    pub fn band_limit_texel_m(&self, radius_m: f64) -> f64 {
        2.0 * self.dtheta_rad * radius_m
    }

    /// (φ, θ) in radians of grid point (gx, gy), folded back onto the sphere: rows past a
    /// pole (θ < 0 or θ > π) hold the point across it, as the GPU fills do (the CPU twin the
    /// tests compare level textures with).
    pub fn phi_theta_of(&self, gx: i64, gy: i64) -> (f64, f64) {
        let mut phi = gx as f64 * self.dphi_rad;
        let mut theta = gy as f64 * self.dtheta_rad;
        if theta < 0.0 {
            theta = -theta;
            phi += PI;
        } else if theta > PI {
            theta = TAU - theta;
            phi += PI;
        }
        (phi.rem_euclid(TAU), theta.clamp(0.0, PI))
    }

    /// The side of the blocks whose corners the fills compute their texels from
    /// ([`GridRect::anchored_pieces`]): S/2, which divides the φ period, so a block's corner
    /// is the same point on either side of the 2π wrap.
    pub fn anchor_block(&self) -> i64 {
        (self.size as i64 / 2).max(1)
    }

    /// φ period of the grid in columns: S·2^k columns make 2π.
    pub fn period_x(&self) -> i64 {
        (self.size as i64) << self.phi_pow
    }

    /// The grid of `level` for a viewer at (φv, θv), keeping `previous`'s φ span when it still
    /// covers the footprint and is at most one step too wide (hysteresis: a span change
    /// rewrites the whole level).
    pub fn for_viewer(
        level: u32,
        size: u32,
        phi_v: f64,
        theta_v: f64,
        previous: Option<&LevelGrid>,
    ) -> Self {
        let half_width = 2.0 * level_outer_theta_rad(level);
        let dtheta_rad = 2.0 * half_width / size as f64;
        // Half-extent in φ of the cap of radius `half_width` (plus two texels of margin for
        // the bilinear footprint) around the viewer; the whole circle if it holds a pole.
        let reach = half_width + 2.0 * dtheta_rad;
        let needed_half_phi = if reach >= theta_v.min(PI - theta_v) || reach >= PI / 2.0 {
            PI
        } else {
            (reach.sin() / theta_v.sin()).clamp(-1.0, 1.0).asin()
        };
        // Texture half-width in φ is span/2 = π/2^k ≥ needed (keeping one texel spare).
        let fits = |k: u32| -> bool {
            let span = TAU / (1u64 << k) as f64;
            span / 2.0 * (1.0 - 2.0 / size as f64) >= needed_half_phi || k == 0
        };
        let mut ideal = 0u32;
        while ideal < 62 && fits(ideal + 1) {
            ideal += 1;
        }
        let phi_pow = match previous {
            Some(p)
                if p.level == level
                    && p.size == size
                    && fits(p.phi_pow)
                    && p.phi_pow + 1 >= ideal =>
            {
                p.phi_pow
            }
            _ => ideal,
        };
        let dphi_rad = TAU / ((size as u64) << phi_pow) as f64;
        let period = (size as i64) << phi_pow;
        let half = size as i64 / 2;
        let gx0 = ((phi_v / dphi_rad).floor() as i64 - half).rem_euclid(period);
        let gy0 = (theta_v / dtheta_rad).floor() as i64 - half;
        Self {
            level,
            phi_pow,
            dphi_rad,
            dtheta_rad,
            gx0,
            gy0,
            size,
            ref_m: 0.0,
        }
    }

    /// The same grid storing heights from `ref_m` (rounded to f32, which the fills subtract).
    pub fn with_reference(self, ref_m: f64) -> Self {
        Self {
            ref_m: ref_m as f32 as f64,
            ..self
        }
    }

    /// Viewer's continuous grid coordinates reduced modulo S, the texture-space anchor the
    /// vertex shader adds its small Δφ/dφ, Δθ/dθ to (kept small so f32 holds them exactly).
    pub fn viewer_texel(&self, phi_v: f64, theta_v: f64) -> (f64, f64) {
        let s = self.size as f64;
        (
            (phi_v / self.dphi_rad).rem_euclid(s),
            (theta_v / self.dtheta_rad).rem_euclid(s),
        )
    }

    /// Grid points that `self` holds and `old` did not: the strips to recompute after a move.
    /// Everything when there is no old window or the grid changed.
    pub fn dirty_since(&self, old: Option<&LevelGrid>) -> Vec<GridRect> {
        let s = self.size as i64;
        let full = vec![GridRect {
            gx0: self.gx0,
            gy0: self.gy0,
            width: self.size,
            height: self.size,
        }];
        let Some(old) = old else { return full };
        if old.phi_pow != self.phi_pow
            || old.size != self.size
            || old.level != self.level
            || old.ref_m != self.ref_m
        {
            return full;
        }
        let period = self.period_x();
        // Shortest signed column shift, modulo the φ period (crossing φ = 0 is not a jump).
        let mut dx = (self.gx0 - old.gx0).rem_euclid(period);
        if dx > period / 2 {
            dx -= period;
        }
        let dy = self.gy0 - old.gy0;
        if dx.abs() >= s || dy.abs() >= s {
            return full;
        }
        let mut rects = Vec::new();
        // New columns, full height of the new window.
        if dx > 0 {
            rects.push(GridRect {
                gx0: (old.gx0 + s).rem_euclid(period),
                gy0: self.gy0,
                width: dx as u32,
                height: self.size,
            });
        } else if dx < 0 {
            rects.push(GridRect {
                gx0: self.gx0,
                gy0: self.gy0,
                width: (-dx) as u32,
                height: self.size,
            });
        }
        // New rows, over the columns not already covered above.
        let (cx0, cw) = if dx >= 0 {
            (self.gx0, s - dx)
        } else {
            ((self.gx0 - dx).rem_euclid(period), s + dx)
        };
        if cw > 0 {
            if dy > 0 {
                rects.push(GridRect {
                    gx0: cx0,
                    gy0: old.gy0 + s,
                    width: cw as u32,
                    height: dy as u32,
                });
            } else if dy < 0 {
                rects.push(GridRect {
                    gx0: cx0,
                    gy0: self.gy0,
                    width: cw as u32,
                    height: (-dy) as u32,
                });
            }
        }
        rects
    }
}

/// The reference height of level `level`'s texture for an eye `above_m` over ground at
/// `ground_m` (a terrain within `range_m`). The texture holds h − ref, so what matters is that
/// the heights it holds near the eye are small against the distance they are seen from, which
/// is at least s = max(eye's height above ground, a quarter of the level's diameter d): within
/// 16s of the ground their f32 steps stay below 2·10⁻⁶·s (a millimetre above a 4 km deep sea
/// floor: 10⁻⁹ m steps, not 0.5 mm). The ideal reference is the ground truncated to a power of
/// two q ≤ d, a function of the ground alone (so a camera that comes to rest over the ground
/// it was filled for refills nothing); `held`, a moving camera's current one, is kept while
/// within 16s of the ground (a descent refills nothing, a flight over hills a level once per
/// 16 of its quarter-diameters of climb). Levels wider than 8 km keep 0 (absolute heights) for
/// any ground within ±8 km.
pub fn reference_height_m(
    level: u32,
    radius_m: f64,
    ground_m: f64,
    above_m: f64,
    range_m: (f64, f64),
    held: Option<f64>,
) -> f64 {
    let quarter_m = 0.5 * level_outer_theta_rad(level) * radius_m;
    let s = above_m.max(0.0).max(quarter_m);
    let g = ground_m.clamp(range_m.0.min(range_m.1), range_m.1.max(range_m.0));
    if let Some(r) = held
        && (g - r).abs() <= 16.0 * s
    {
        return r;
    }
    let q = (4.0 * quarter_m).log2().floor().exp2();
    ((g / q).trunc() * q) as f32 as f64
}

/// Whether some ground within `range_m` gives level `level` a reference other than 0: the
/// fine levels, whose fill must wait for the ground under the eye.
pub fn reference_depends_on_ground(level: u32, radius_m: f64, range_m: (f64, f64)) -> bool {
    [range_m.0, range_m.1]
        .iter()
        .any(|&g| reference_height_m(level, radius_m, g, 0.0, range_m, None) != 0.0)
}

#[cfg(test)]
mod tests {
    /// The pieces tile the rectangle, each within one block whose corner is its anchor: a
    /// grid point gets the same anchor from any rectangle that holds it.
    #[test]
    fn anchored_pieces_tile_the_rectangle_one_block_each() {
        let block = 64;
        let rects = [
            GridRect {
                gx0: -70,
                gy0: 5,
                width: 200,
                height: 129,
            },
            GridRect {
                gx0: 0,
                gy0: -64,
                width: 64,
                height: 64,
            },
            GridRect {
                gx0: 127,
                gy0: 1000,
                width: 1,
                height: 3,
            },
        ];
        for r in rects {
            let mut seen = std::collections::HashMap::new();
            for (p, [ax, ay]) in r.anchored_pieces(block) {
                assert_eq!((ax.rem_euclid(block), ay.rem_euclid(block)), (0, 0));
                assert!(p.gx0 >= ax && p.gx0 + p.width as i64 <= ax + block, "{p:?}");
                assert!(
                    p.gy0 >= ay && p.gy0 + p.height as i64 <= ay + block,
                    "{p:?}"
                );
                for x in p.gx0..p.gx0 + p.width as i64 {
                    for y in p.gy0..p.gy0 + p.height as i64 {
                        assert!(seen.insert((x, y), (ax, ay)).is_none(), "({x}, {y}) twice");
                        // The anchor is the point's own block corner, whatever the rectangle.
                        assert_eq!(
                            (ax, ay),
                            (x.div_euclid(block) * block, y.div_euclid(block) * block)
                        );
                    }
                }
            }
            assert_eq!(seen.len() as u64, r.texels());
        }
    }

    use super::*;

    #[test]
    fn rows_past_a_pole_hold_the_point_across_it() {
        let g = LevelGrid::for_viewer(3, 64, 0.5, 0.01, None);
        let (phi, theta) = g.phi_theta_of(10, -4);
        assert!((theta - 4.0 * g.dtheta_rad).abs() < 1e-12);
        let expected = (10.0 * g.dphi_rad + PI).rem_euclid(TAU);
        assert!((phi - expected).abs() < 1e-12);
    }

    /// Every grid point of the new window is either in the old window or in a dirty rect, and
    /// no dirty point is counted twice.
    fn check_cover(old: &LevelGrid, new: &LevelGrid) {
        let rects = new.dirty_since(Some(old));
        let p = new.period_x();
        let s = new.size as i64;
        let in_old = |gx: i64, gy: i64| {
            (gx - old.gx0).rem_euclid(p) < s && (gy - old.gy0) >= 0 && (gy - old.gy0) < s
        };
        let mut covered = std::collections::HashSet::new();
        for r in &rects {
            for i in 0..r.width as i64 {
                for j in 0..r.height as i64 {
                    let key = ((r.gx0 + i).rem_euclid(p), r.gy0 + j);
                    assert!(covered.insert(key), "point {key:?} written twice");
                }
            }
        }
        for i in 0..s {
            for j in 0..s {
                let (gx, gy) = ((new.gx0 + i).rem_euclid(p), new.gy0 + j);
                assert!(
                    in_old(gx, gy) || covered.contains(&(gx, gy)),
                    "point ({gx},{gy}) not refreshed"
                );
            }
        }
    }

    #[test]
    fn toroidal_moves_refresh_exactly_the_new_strips() {
        let size = 32;
        for (dphi, dtheta) in [(0.01, 0.0), (-0.013, 0.004), (0.0, -0.02), (0.05, 0.05)] {
            let a = LevelGrid::for_viewer(6, size, 0.5, 1.0, None);
            let b = LevelGrid::for_viewer(6, size, 0.5 + dphi, 1.0 + dtheta, Some(&a));
            assert_eq!(a.phi_pow, b.phi_pow);
            check_cover(&a, &b);
        }
    }

    #[test]
    fn crossing_phi_zero_is_a_small_move() {
        let size = 64;
        let a = LevelGrid::for_viewer(10, size, TAU - 1e-5, 1.2, None);
        let b = LevelGrid::for_viewer(10, size, 1e-5, 1.2, Some(&a));
        let rects = b.dirty_since(Some(&a));
        let texels: u64 = rects.iter().map(GridRect::texels).sum();
        assert!(
            texels < (size as u64) * 8,
            "crossing φ=0 refilled {texels} texels"
        );
        check_cover(&a, &b);
    }

    /// The reference a level stores its heights from: 0 for the coarse levels (absolute
    /// heights, as before), near the ground under the eye for the fine ones (so a millimetre
    /// above a 4 km deep sea floor the stored numbers are millimetres), exact in f32, kept
    /// while the ground stays within 16s of it.
    #[test]
    fn the_reference_height_follows_the_ground_on_fine_levels_only() {
        const R: f64 = 6_371_000.0;
        let range = (-11_000.0, 9_000.0);
        let ground = -4_257.395;
        // Levels 39 km across and wider: q ≥ 8 km, so 0 for this ground.
        for level in 0..=10 {
            assert_eq!(reference_height_m(level, R, ground, 1.0, range, None), 0.0);
        }
        for (level, above) in [(16, 1.0), (20, 2.0), (25, 0.5), (29, 0.001), (34, 0.001)] {
            let quarter = 0.5 * level_outer_theta_rad(level) * R;
            let s = f64::max(above, quarter);
            let r = reference_height_m(level, R, ground, above, range, None);
            assert_eq!(r, r as f32 as f64);
            assert!(
                (r - ground).abs() <= 4.0 * quarter,
                "level {level}: {r} for {ground}"
            );
            // What the level stores near the eye: f32 steps far below what a pixel there spans.
            let stored = ((ground - r) as f32).abs();
            let step = f32::from_bits(stored.to_bits() + 1) - stored;
            assert!((step as f64) < 1e-6 * s, "level {level}: f32 step {step} m");
        }
        // Hysteresis: kept within 16s of the ground, replaced beyond.
        let (level, above) = (25, 0.5);
        let s = f64::max(above, 0.5 * level_outer_theta_rad(level) * R);
        let held = reference_height_m(level, R, ground, above, range, None);
        let kept = |g: f64| reference_height_m(level, R, g, above, range, Some(held));
        assert_eq!(kept(held + 15.9 * s), held);
        assert_ne!(kept(held + 16.1 * s), held);
        // The ideal depends on the ground alone: a descent over it keeps the reference, and
        // the camera at rest takes the one it was filled with.
        let high = reference_height_m(level, R, ground, 100.0, range, None);
        assert_eq!(
            reference_height_m(level, R, ground, 0.001, range, Some(high)),
            high
        );
        assert_eq!(
            reference_height_m(level, R, ground, 0.001, range, None),
            high
        );
    }

    /// A new reference rewrites the whole level (its texels hold h − ref).
    #[test]
    fn a_new_reference_refills_the_level() {
        let a = LevelGrid::for_viewer(20, 64, 0.5, 1.0, None).with_reference(100.0);
        let b = a.with_reference(100.0);
        assert!(b.dirty_since(Some(&a)).is_empty());
        let c = a.with_reference(104.0);
        let rects = c.dirty_since(Some(&a));
        assert_eq!(rects.iter().map(GridRect::texels).sum::<u64>(), 64 * 64);
    }

    #[test]
    fn levels_containing_a_pole_span_the_whole_circle() {
        let g = LevelGrid::for_viewer(8, 256, 1.0, 1e-4, None);
        assert_eq!(g.phi_pow, 0);
        let g = LevelGrid::for_viewer(8, 256, 1.0, PI, None);
        assert_eq!(g.phi_pow, 0);
        // At the equator a fine level covers a small φ range.
        let g = LevelGrid::for_viewer(20, 256, 1.0, PI / 2.0, None);
        assert!(g.phi_pow > 15);
        // Its φ texel is between one and two θ texels on the ground (anisotropy ≤ 2).
        let ratio = g.dphi_rad / g.dtheta_rad;
        assert!((0.99..2.01).contains(&ratio), "ratio {ratio}");
    }
}
