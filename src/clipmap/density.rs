//! Triangles by projected size (issue 14): each drawn level picks the ring density of its mesh
//! from how far apart its full-density vertices lie on screen.
//!
//! Density k draws every 2^k-th φ̃ step and ring (`clipmap::mesh`). A level whose full-density
//! vertices are `s` pixels apart (the largest over the level) wants D = log2(T/s), with T the
//! target spacing in pixels: k = ⌊D⌋ clamped to the mesh's densities. Over the upper half of
//! each step, D ∈ [k + ½, k + 1), the vertices density k + 1 drops move onto the coarser
//! surface (morph 0 → 1), so a switch moves nothing on screen (geomorphing). Triangle counts
//! then follow the frame's size: halve the resolution and every level drops a density (¼ of the
//! triangles) until the coarsest.
//!
//! Where two drawn levels meet, the shared ring is drawn at the coarser of their densities by
//! both; its morph is the coarser side's (the larger one when they are equal), so both draws
//! place every shared vertex identically and the ring's dropped vertices are already in place
//! whichever side switches first.

use super::selection::LevelSelection;
use super::settings::{ClipmapSettings, level_outer_theta_rad};

/// The density a level is drawn at, and how far its dropped vertices have moved.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Density {
    /// k: every 2^k-th φ̃ step and ring.
    pub k: u32,
    /// 0..1: how far the vertices density k + 1 drops have moved onto its surface.
    pub morph: f32,
}

/// One drawn level's density and those of its two edge rings.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LevelDensity {
    pub body: Density,
    /// The outer ring (shared with the next coarser drawn level).
    pub outer: Density,
    /// The inner ring (shared with the next finer drawn level, or the cap's rim).
    pub inner: Density,
}

/// What a view needs to know to size the levels on screen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScreenScale {
    pub radius_m: f64,
    /// The eye's altitude above the sphere and the ground's height under it (metres).
    pub altitude_m: f64,
    pub ground_m: f64,
    /// Pixels per radian at the image centre: height_px / (2·tan(fov_y/2)).
    pub focal_px: f64,
}

impl ScreenScale {
    /// Distance from the eye to the surface point at view angle θ̃ (on a sphere through the
    /// ground under the eye), without cancellation: d² = (a − g)² + 2(R+a)(R+g)(1 − cos θ̃).
    pub fn distance_m(&self, theta: f64) -> f64 {
        let (r_eye, r_ground) = (
            self.radius_m + self.altitude_m,
            self.radius_m + self.ground_m,
        );
        let half = (0.5 * theta).sin();
        let dz = self.altitude_m - self.ground_m;
        (dz * dz + 4.0 * r_eye * r_ground * half * half).sqrt()
    }

    /// The largest on-screen distance (pixels) between neighbouring full-density vertices of
    /// `level`: along a ring R·sin θ̃·2π/n, across rings R·θ̃·(1 − 2^(−1/m)), each over the
    /// distance from the eye (no foreshortening: an upper bound), sampled over the level.
    pub fn full_density_spacing_px(&self, level: u32, settings: &ClipmapSettings) -> f64 {
        let outer = level_outer_theta_rad(level);
        let n = settings.phi_steps as f64;
        let m = settings.rings_per_level as f64;
        let across = 1.0 - (-1.0 / m).exp2();
        (0..=8)
            .map(|i| {
                let theta = outer * (-(i as f64) / 8.0).exp2();
                let along_ring = theta.sin() * std::f64::consts::TAU / n;
                let spacing_m = self.radius_m * along_ring.max(theta * across);
                spacing_m / self.distance_m(theta).max(1e-9) * self.focal_px
            })
            .fold(0.0, f64::max)
    }

    /// How far (pixels) the chords of `level` at density k sag below the sphere: a chord of
    /// length d lies up to d²/(8R) inside it, shown whole where the surface turns away (the
    /// planet's limb), over the distance from the eye; the largest over the level.
    pub fn sag_px(&self, level: u32, settings: &ClipmapSettings, k: u32) -> f64 {
        let outer = level_outer_theta_rad(level);
        let n = settings.phi_steps as f64;
        let m = settings.rings_per_level as f64;
        let s = f64::from(1u32 << k);
        let across = 1.0 - (-s / m).exp2();
        (0..=8)
            .map(|i| {
                let theta = outer * (-(i as f64) / 8.0).exp2();
                let along_ring = theta.sin() * std::f64::consts::TAU * s / n;
                let chord_m = self.radius_m * along_ring.max(theta * across);
                let sag_m = chord_m * chord_m / (8.0 * self.radius_m);
                sag_m / self.distance_m(theta).max(1e-9) * self.focal_px
            })
            .fold(0.0, f64::max)
    }

    /// The coarsest density of `level` whose chords sag at most `limit_px` (see
    /// [`ScreenScale::sag_px`]), with the morph toward the next one that takes the sag to the
    /// limit, so that the cap slides continuously as the view moves.
    pub fn sag_cap(
        &self,
        level: u32,
        settings: &ClipmapSettings,
        limit_px: f64,
        max_k: u32,
    ) -> DensityCap {
        let mut sag = self.sag_px(level, settings, 0);
        for k in 0..max_k {
            let next = self.sag_px(level, settings, k + 1);
            if next > limit_px {
                // A morph m puts the surface about (1 − m) of the way from density k + 1's
                // chords to density k's: the sag grows linearly with it.
                let morph = ((limit_px - sag) / (next - sag)).clamp(0.0, 1.0) as f32;
                return DensityCap { k, morph };
            }
            sag = next;
        }
        DensityCap::at_most(max_k)
    }
}

/// The coarsest density of the level holding the horizon (see [`horizon_cap`]). There the
/// per-vertex haze changes fastest (rays grazing the limb), and a linear blend of it over
/// larger triangles shows: `space` at 192×108 with that level morphing toward density 4 drew a
/// bright ring along the limb, 488 pixels off the full-density frame by more than 8/255; with
/// this cap 143 (no ring), and 136 with every level at density 3. From 480×270 up the level's
/// spacing keeps it at density 2 or finer anyway, so the cap changes nothing there.
pub const HORIZON_MAX_DENSITY: u32 = 3;

/// The cap [`HORIZON_MAX_DENSITY`] puts on `level` with the horizon at θ̃ = `theta_max_rad`:
/// whole on the level holding it, and sliding on the next finer one (morph toward the next
/// density from 1, horizon at that level's outer edge doubled, to 0, horizon at its outer
/// edge), so that a level taking over the horizon as the eye descends is already at the cap.
pub fn horizon_cap(level: u32, theta_max_rad: f64) -> Option<DensityCap> {
    let x = (level_outer_theta_rad(level) / theta_max_rad).log2();
    if !x.is_finite() || x < -1.0 {
        return None;
    }
    Some(DensityCap {
        k: HORIZON_MAX_DENSITY,
        morph: (-x).clamp(0.0, 1.0) as f32,
    })
}

/// How far a level's chords may sag below the sphere on screen, as a fraction of the target
/// vertex spacing: 0.3 px at the default 20 px (what density 2 sags at `space` 960×540 and
/// density 3 at 192×108), so that the planet's limb stays within a third of a pixel of the
/// sphere's. The spacing rule alone let `space` at 192×108 take density 4
/// on its outermost level, whose chords across rings then cut 0.7 px into the limb (96
/// coverage mismatches against the reference ray caster, 6 % of the disk's pixels).
pub const SAG_PER_SPACING: f64 = 0.015;

/// The coarsest density a level may take, and how far its vertices may move toward the next
/// one (so that a cap that changes with the view moves the surface continuously).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DensityCap {
    pub k: u32,
    /// 0..1: the morph toward density k + 1 allowed at density k (0 at the mesh's coarsest).
    pub morph: f32,
}

impl DensityCap {
    /// The mesh's coarsest density k, with nothing further to morph into.
    pub fn at_most(k: u32) -> Self {
        Self { k, morph: 0.0 }
    }

    /// The tighter of two caps (the one with less of the surface's coarsening allowed).
    pub fn min(self, other: Self) -> Self {
        if (other.k as f32 + other.morph) < (self.k as f32 + self.morph) {
            other
        } else {
            self
        }
    }
}

/// The density of a level whose full-density vertices lie `spacing_px` apart, for a target of
/// `target_px`, no coarser than `cap`.
pub fn density_within(spacing_px: f64, target_px: f64, cap: DensityCap) -> Density {
    let d = (target_px / spacing_px.max(1e-12)).log2();
    if !d.is_finite() || d <= 0.0 {
        return Density::default();
    }
    let want = d.floor() as u32;
    let frac = d - want as f64;
    let morph = ((frac - 0.5) * 2.0).clamp(0.0, 1.0) as f32;
    match want.cmp(&cap.k) {
        std::cmp::Ordering::Less => Density { k: want, morph },
        std::cmp::Ordering::Equal => Density {
            k: cap.k,
            morph: morph.min(cap.morph),
        },
        std::cmp::Ordering::Greater => Density {
            k: cap.k,
            morph: cap.morph,
        },
    }
}

/// How coarse a level's vertices may be against the finest detail octave its texture holds as
/// geometry (cells of at least κ·s at distance s, `procedural`): at most this many of those
/// cells between two neighbouring vertices, along and across rings.
///
/// Measured (`tests/gpu/detail_render.rs`, 96×54, camera 0.1 m above the detail, default mesh):
/// density 3 (1.27 cells across rings) gives p99 ρ 0.64 / 0.12 / 0.21 / 0.59 px at the north
/// pole, the south pole, the antimeridian and Garda; density 4 (2.34 cells) gave 1.30 / 0.22 /
/// 0.33 / 1.31 px, past the 1 px the default must keep. The screen-space spacing rule alone
/// cannot see this: on a small image every level there is far below the target spacing.
pub const MAX_DETAIL_CELLS_PER_SPACING: f64 = 1.5;

/// The coarsest density whose vertices stay within [`MAX_DETAIL_CELLS_PER_SPACING`] cells of
/// the finest geometric detail octave (κ = `geometry_cut`) at every distance s: both the
/// spacing (along rings s·2π·2^k/n, across s·(1 − 2^(−2^k/m))) and the cell (κ·s) grow with
/// s, so the bound is the same for every level.
pub fn detail_density_cap(settings: &ClipmapSettings, geometry_cut: f64, max_k: u32) -> u32 {
    let n = settings.phi_steps as f64;
    let m = settings.rings_per_level as f64;
    let mut k = 0;
    while k < max_k {
        let s = f64::from(2u32 << k); // the stride of density k + 1
        let along = std::f64::consts::TAU * s / n;
        let across = 1.0 - (-s / m).exp2();
        if along.max(across) / geometry_cut > MAX_DETAIL_CELLS_PER_SPACING {
            break;
        }
        k += 1;
    }
    k
}

/// The densities of every level of one frame (indexed by level; levels not drawn keep the
/// default).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DensityPlan {
    pub levels: Vec<LevelDensity>,
}

impl DensityPlan {
    /// Every level at full density (the paper's mesh).
    pub fn full(levels: u32) -> Self {
        Self {
            levels: vec![LevelDensity::default(); levels as usize],
        }
    }

    /// Densities of the drawn levels of `selection` for a target vertex spacing of
    /// `settings.target_spacing_px` pixels, level l no coarser than `cap(l)` nor than its
    /// chords' sag allows ([`SAG_PER_SPACING`]).
    pub fn new(
        scale: &ScreenScale,
        selection: &LevelSelection,
        settings: &ClipmapSettings,
        cap: impl Fn(u32) -> DensityCap,
    ) -> Self {
        let mut plan = Self::full(settings.levels);
        if settings.target_spacing_px <= 0.0 {
            return plan;
        }
        let target = settings.target_spacing_px as f64;
        let body: Vec<Density> = selection
            .drawn_levels()
            .map(|l| {
                let mut given = cap(l);
                if let Some(h) = horizon_cap(l, selection.theta_max_rad) {
                    given = given.min(h);
                }
                let sag = scale.sag_cap(l, settings, target * SAG_PER_SPACING, given.k);
                density_within(
                    scale.full_density_spacing_px(l, settings),
                    target,
                    given.min(sag),
                )
            })
            .collect();
        plan.set_drawn(selection, &body);
        plan
    }

    /// Sets the drawn levels of `selection` to the densities `body` (coarse to fine) and their
    /// edge rings to what the neighbours share.
    pub fn set_drawn(&mut self, selection: &LevelSelection, body: &[Density]) {
        // The ring between two drawn levels: the coarser density, the coarser side's morph.
        let shared = |a: Density, b: Density| match a.k.cmp(&b.k) {
            std::cmp::Ordering::Greater => a,
            std::cmp::Ordering::Less => b,
            std::cmp::Ordering::Equal => Density {
                k: a.k,
                morph: a.morph.max(b.morph),
            },
        };
        for (i, level) in selection.drawn_levels().enumerate() {
            let own = body[i];
            let outer = if i > 0 { shared(body[i - 1], own) } else { own };
            let inner = body.get(i + 1).map_or(own, |&finer| shared(own, finer));
            self.levels[level as usize] = LevelDensity {
                body: own,
                outer,
                inner,
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn density_steps_and_morphs_continuously() {
        let density_for = |s: f64, t: f64, k: u32| density_within(s, t, DensityCap::at_most(k));
        // Spacing equal to the target: full density, no morph.
        assert_eq!(density_for(4.0, 4.0, 3), Density { k: 0, morph: 0.0 });
        // Half the target: the next density starts, no morph yet.
        assert_eq!(density_for(2.0, 4.0, 3), Density { k: 1, morph: 0.0 });
        // D = 1.75: three quarters along, half morphed.
        let d = density_for(4.0 / 1.75f64.exp2(), 4.0, 3);
        assert_eq!(d.k, 1);
        assert!((d.morph - 0.5).abs() < 1e-6);
        // Tiny on screen: the coarsest density, nothing left to morph into.
        assert_eq!(density_for(0.001, 4.0, 3), Density { k: 3, morph: 0.0 });
        // Larger than the target: full density.
        assert_eq!(density_for(40.0, 4.0, 3), Density { k: 0, morph: 0.0 });
        // Just below a switch the dropped vertices are (almost) in place.
        let d = density_for(4.0 / (2.0 - 1e-9f64).exp2(), 4.0, 3);
        assert_eq!(d.k, 1);
        assert!(d.morph > 0.999);
    }

    /// A cap holds the level at its density, morphed no further than the cap allows: the
    /// surface then moves continuously as the cap itself slides.
    #[test]
    fn a_cap_limits_density_and_morph() {
        let cap = DensityCap { k: 2, morph: 0.25 };
        // Far finer than the target: the cap's density and morph.
        assert_eq!(
            density_within(0.001, 4.0, cap),
            Density { k: 2, morph: 0.25 }
        );
        // At the cap's density, three quarters along: the spacing's morph (0.5), capped.
        let d = density_within(4.0 / 2.75f64.exp2(), 4.0, cap);
        assert_eq!((d.k, d.morph), (2, 0.25));
        // Below the cap: the cap does not matter.
        let d = density_within(4.0 / 1.75f64.exp2(), 4.0, cap);
        assert_eq!(d.k, 1);
        assert!((d.morph - 0.5).abs() < 1e-6);
    }

    /// From space on a small image the outermost levels' chords would cut into the limb: the
    /// sag holds them finer, and leaves the small levels around the nadir alone.
    #[test]
    fn the_limb_holds_the_outer_levels() {
        let settings = ClipmapSettings::default();
        let scale = ScreenScale {
            radius_m: 6.371e6,
            altitude_m: 2.0e7,
            ground_m: 0.0,
            focal_px: 108.0 / (2.0 * (30f64.to_radians()).tan()),
        };
        let limit = 0.5;
        assert!(scale.sag_px(1, &settings, 4) > limit);
        let cap = scale.sag_cap(1, &settings, limit, 4);
        assert!(cap.k < 4 && (0.0..=1.0).contains(&cap.morph), "{cap:?}");
        assert!(scale.sag_px(1, &settings, cap.k) <= limit);
        assert_eq!(
            scale.sag_cap(6, &settings, limit, 4),
            DensityCap { k: 4, morph: 0.0 }
        );
        // Sag grows fourfold per density (both chords double), a little less across rings.
        let ratio = scale.sag_px(6, &settings, 3) / scale.sag_px(6, &settings, 2);
        assert!((3.0..=4.01).contains(&ratio), "{ratio}");
    }

    /// The horizon's cap: whole on its level, sliding on the next finer one, none beyond.
    #[test]
    fn the_horizon_cap_slides_onto_the_next_level() {
        let outer = level_outer_theta_rad(3);
        // Horizon inside level 3 (θ̃ in (outer/2, outer]).
        let h = 0.75 * outer;
        assert_eq!(horizon_cap(3, h), Some(DensityCap { k: 3, morph: 0.0 }));
        let next = horizon_cap(4, h).unwrap();
        assert!((next.morph - (0.75f64 / 0.5).log2() as f32).abs() < 1e-6);
        assert_eq!(horizon_cap(5, h), None);
        // As the horizon reaches level 4's outer edge, level 4's morph reaches 0: continuous.
        let at_edge = horizon_cap(4, level_outer_theta_rad(4) * (1.0 + 1e-9)).unwrap();
        assert!(at_edge.morph < 1e-6);
    }

    /// With the default mesh and κ = 1/8, levels holding detail geometry stop at density 3
    /// (1.27 finest cells between vertices across rings; density 4 would put 2.34).
    #[test]
    fn detail_geometry_caps_the_density() {
        let settings = ClipmapSettings::default();
        assert_eq!(detail_density_cap(&settings, 0.125, 4), 3);
        assert_eq!(detail_density_cap(&settings, 0.125, 2), 2);
        // A coarser geometry cut (larger cells at each distance) allows coarser meshes.
        assert_eq!(detail_density_cap(&settings, 0.5, 4), 4);
        // A finer one allows fewer.
        assert!(detail_density_cap(&settings, 0.03, 4) < 3);
    }

    /// From space the levels around the nadir shrink by half each: the finer the level the
    /// coarser its density. Halving the image halves every spacing.
    #[test]
    fn spacing_follows_the_image() {
        let settings = ClipmapSettings::default();
        let scale = |h: f64| ScreenScale {
            radius_m: 6.371e6,
            altitude_m: 2.0e7,
            ground_m: 0.0,
            focal_px: h / (2.0 * (30f64.to_radians()).tan()),
        };
        let big = scale(1080.0);
        let small = scale(540.0);
        for level in 2..10 {
            let a = big.full_density_spacing_px(level, &settings);
            let b = small.full_density_spacing_px(level, &settings);
            assert!((a / b - 2.0).abs() < 1e-9);
            let finer = big.full_density_spacing_px(level + 1, &settings);
            assert!(finer < 0.6 * a, "level {level}: {a} → {finer}");
        }
    }
}
