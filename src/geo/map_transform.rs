//! The spherical-clipmap map transform f(θv, φ̃, θ̃) → (Δφ, Δθ) = (φ − φv, θ − θv)
//! (`spherical-clipmaps.md` eq. 1–4 with the sign of `docs/design.md#conventions`, §4.4 seam, §5.1 eq. 9–14).
//!
//! A static ring mesh lives in view space (viewer at the view-space north pole); each vertex
//! carries p̃ (eq. 2) computed once in f64. Per frame the GPU rotates p̃ by θv about ỹ into the
//! world frame (φv = 0) and converts to map-space offsets from the viewer:
//!
//! | form | Δφ | Δθ | where it is good |
//! | --- | --- | --- | --- |
//! | [`exact_f64`] | atan2(p_y, p_x) | three branches + far-point refinement, f64 | reference (CPU) |
//! | [`direct_f32`] (eq. 3–4) | atan2(p_y, p_x) | acos(p_z) − θv | far rings only: cancels near the viewer and the poles |
//! | [`stable_f32`] (`docs/design.md#numerics`) | atan2(p_y, p_x) | three branches, no cancellation | everywhere |
//! | [`approx_f32`] (eq. 11, 14) | p̃y·stretch | p̃x | inner rings, π/48 < θv < 47π/48 |
//! | [`blended_f32`] (Fig. 14) | mix(stable, approx, w) | mix(stable, approx, w) | per-ring blend between the two |
//!
//! The `*_f32` functions are Rust twins of `shaders/common/map_transform.wgsl`, written line by
//! line in the same order with the same f32 inputs ([`TransformUniformsF32`], p̃ cast from f64), so
//! that tests measure the GPU's arithmetic on the CPU. They differ from the GPU only in the
//! accuracy of `atan2`/`acos` (Rust's libm is within about 1 ulp; WGSL allows more) and in
//! whether the compiler fuses multiply-adds.
//!
//! # The stable Δθ (derivation, checked against the reference vectors)
//!
//! With c = cos θv, s = sin θv, ρ = √(p_x² + p_y²) = sin θ and p_z = cos θ:
//! sin(θ − θv) = c·ρ − s·p_z and cos(θ − θv) = c·p_z + s·ρ. Writing ρ = p_x + q with
//! q = ρ − p_x = p_y²/(ρ + p_x) (exact algebra, no cancellation when p_x > 0) and substituting
//! p_x = c·p̃x + s·p̃z, p_z = −s·p̃x + c·p̃z:
//!
//! * sin(θ − θv) = c²·p̃x + cs·p̃z + c·q + s²·p̃x − sc·p̃z = **p̃x + c·q**
//! * cos(θ − θv) = −cs·p̃x + c²·p̃z + sc·p̃x + s²·p̃z + s·q = **p̃z + s·q**
//!
//! so Δθ = atan2(p̃x + c·q, p̃z + s·q) exactly as `docs/design.md#numerics` states, with this crate's sign
//! (eq. 10's: +x̃ points south). Both atan2 arguments are the true sine and cosine (not merely
//! proportional: |p̃| = 1), and Δθ ∈ [−π, π], so atan2 returns the right branch. Near the viewer
//! p̃x and q are O(θ̃) and carry full relative precision, so the error is O(ulp·θ̃) instead of
//! O(ulp·θv). Beyond a pole (p_x ≤ 0) ρ + p_x can vanish, so two more branches take over; there θ
//! (north) or π − θ (south) is small and atan2(ρ, ±p_z) computes it to full relative precision.

pub use super::trig::atan2_precise_f32;
use glam::{DVec3, Vec3};
use std::f64::consts::{FRAC_PI_2, PI};

/// The low part of π: `PI + PI_LO` is π to about 1e-32, so `(PI − θv) + PI_LO` is π − θv to full
/// relative precision even at θv = `PI` (the f64 south pole, 1.2e-16 rad = 0.8 nm from it).
const PI_LO: f64 = 1.224_646_799_147_353_2e-16;

/// Largest stretch the uniforms carry. 1/sin θv is infinite at a pole; the approximation is
/// useless there anyway (the ring-weight chooser must not use it, see
/// [`APPROX_THETA_V_MIN_RAD`]), but the uniform must stay finite so that a zero blend weight
/// gives exactly the stable value instead of 0·∞ = NaN.
pub const STRETCH_MAX: f64 = 1e30;

/// Fig. 12's domain for the paper's approximation: π/48 < θv < π − π/48 ...
pub const APPROX_THETA_V_MIN_RAD: f64 = PI / 48.0;
/// ... and θ̃ < π/1024. Inside it eq. 11's relative error at φ̃ = π/2 is below 0.001.
pub const APPROX_THETA_TILDE_MAX_RAD: f64 = PI / 1024.0;

/// View-space point on the unit sphere, eq. 2: p̃(φ̃, θ̃) = (cos φ̃ sin θ̃, sin φ̃ sin θ̃, cos θ̃).
///
/// The ring mesh sets p̃y = 0 exactly on its seam meridian (φ̃ = 0 and π, where f64 `sin(PI)`
/// would give 1.2e-16); see [`seam_dphi_f32`].
pub fn p_tilde(phi_tilde_rad: f64, theta_tilde_rad: f64) -> DVec3 {
    let (sin_theta, cos_theta) = theta_tilde_rad.sin_cos();
    let (sin_phi, cos_phi) = phi_tilde_rad.sin_cos();
    DVec3::new(cos_phi * sin_theta, sin_phi * sin_theta, cos_theta)
}

/// 1 − cos θ̃ written as 2·sin²(θ̃/2), which keeps full relative precision for small θ̃
/// (`docs/design.md#numerics`: never form 1 − cos θ̃ in f32; precompute this per vertex in f64).
pub fn one_minus_cos(theta_tilde_rad: f64) -> f64 {
    let half_sin = (0.5 * theta_tilde_rad).sin();
    2.0 * half_sin * half_sin
}

/// Rotates a view-space point into the world frame for φv = 0 (eq. 10's sign; `docs/design.md#conventions`):
/// p = (cos θv·p̃x + sin θv·p̃z, p̃y, −sin θv·p̃x + cos θv·p̃z).
pub fn world_from_view_point(theta_v_rad: f64, p_tilde: DVec3) -> DVec3 {
    let (sin_theta_v, cos_theta_v) = theta_v_rad.sin_cos();
    DVec3::new(
        cos_theta_v * p_tilde.x + sin_theta_v * p_tilde.z,
        p_tilde.y,
        -sin_theta_v * p_tilde.x + cos_theta_v * p_tilde.z,
    )
}

/// Accurate f64 map transform: (Δφ, Δθ) = (φ − φv, θ − θv) for the unit view-space point
/// `p_tilde`, Δφ ∈ (−π, π], Δθ ∈ [−π, π].
///
/// The cancellation-free form of `docs/design.md#numerics` (derivation in the module docs) evaluated in f64, with one
/// refinement for far points: its viewer-side branch is used only while |Δθ| ≤ π/4; elsewhere θ is
/// measured from whichever of 0, π/2 or π is nearest (so the atan2 result is at most π/4) and the
/// constant minus θv is carried in double-double, leaving a single final rounding. Near the viewer
/// the error is O(ulp·θ̃); far away it is within about one ulp of the result (1.4e-9 m on Earth at
/// |Δθ| ≈ 1.5, 2.8e-9 m at ≈ 3, which is f64's own resolution there), poles and antipode included.
/// It is the reference the f32 forms are measured against. At the poles (θ = 0 or π) Δφ is whatever
/// atan2 gives and carries no meaning.
pub fn exact_f64(theta_v_rad: f64, p_tilde: DVec3) -> (f64, f64) {
    let (sin_theta_v, cos_theta_v) = theta_v_rad.sin_cos();
    // Products are fused so p_x keeps full precision when its two terms nearly cancel (points
    // just beyond a pole).
    let p_x = cos_theta_v.mul_add(p_tilde.x, sin_theta_v * p_tilde.z);
    let p_y = p_tilde.y;
    let p_z = (-sin_theta_v).mul_add(p_tilde.x, cos_theta_v * p_tilde.z);
    let rho = p_x.hypot(p_y);
    let dphi_rad = p_y.atan2(p_x);
    if p_x > 0.0 {
        let q = p_y * p_y / (rho + p_x);
        let sin_dtheta = cos_theta_v.mul_add(q, p_tilde.x);
        let cos_dtheta = sin_theta_v.mul_add(q, p_tilde.z);
        if sin_dtheta.abs() <= cos_dtheta {
            return (dphi_rad, sin_dtheta.atan2(cos_dtheta));
        }
    }
    let dtheta_rad = if p_z >= rho {
        // θ ≤ π/4.
        rho.atan2(p_z) - theta_v_rad
    } else if -p_z >= rho {
        // θ ≥ 3π/4: θ = π − atan2(ρ, −p_z).
        constant_minus_two(PI, PI_LO, theta_v_rad, rho.atan2(-p_z))
    } else {
        // π/4 < θ < 3π/4: θ = π/2 − atan2(p_z, ρ).
        constant_minus_two(FRAC_PI_2, FRAC_PI_2_LO, theta_v_rad, p_z.atan2(rho))
    };
    (dphi_rad, dtheta_rad)
}

/// The low part of π/2 (see [`PI_LO`]).
const FRAC_PI_2_LO: f64 = 0.5 * PI_LO;

/// Knuth's two-sum: a + b = sum + error exactly.
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let sum = a + b;
    let b_part = sum - a;
    let error = (a - (sum - b_part)) + (b - b_part);
    (sum, error)
}

/// (constant_hi + constant_lo) − a − b with a single significant rounding at the end.
fn constant_minus_two(constant_hi: f64, constant_lo: f64, a: f64, b: f64) -> f64 {
    let (partial, error_a) = two_sum(constant_hi, -a);
    let (result, error_b) = two_sum(partial, -b);
    result + (error_a + error_b + constant_lo)
}

/// How the per-frame stretch of the approximation (eq. 11) is computed on the CPU.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stretch {
    /// The paper's empirical polynomial in θv, [`paper_stretch`].
    Paper,
    /// 1/sin θv, which the CPU can give exactly each frame (`docs/design.md#numerics`).
    Exact,
}

impl Stretch {
    /// The stretch factor for viewer colatitude `theta_v_rad` (may be infinite at a pole).
    pub fn factor(self, theta_v_rad: f64) -> f64 {
        match self {
            Stretch::Paper => paper_stretch(theta_v_rad),
            Stretch::Exact => 1.0 / theta_v_rad.sin(),
        }
    }
}

/// Eq. 11's empirical approximation of 1/sin θv:
/// 1 + (1/π)/(1/4 − t²) − t²/6 − 4/π with t = θv/π − 1/2.
///
/// Exact at θv = π/2 (= 1) and asymptotic to 1/θv at the poles, where it is infinite.
pub fn paper_stretch(theta_v_rad: f64) -> f64 {
    let t = theta_v_rad / PI - 0.5;
    let t2 = t * t;
    1.0 + (1.0 / PI) / (0.25 - t2) - t2 / 6.0 - 4.0 / PI
}

/// Fig. 12's quantity: the relative error 1 − approximated/exact of Δφ at φ̃ = π/2 for the
/// paper's stretch (eq. 11), with the exact Δφ from [`exact_f64`].
pub fn paper_stretch_relative_error(theta_v_rad: f64, theta_tilde_rad: f64) -> f64 {
    // φ̃ = π/2 exactly: p̃x = 0 (f64 cos(π/2) would add 6e-17).
    let p = DVec3::new(0.0, theta_tilde_rad.sin(), theta_tilde_rad.cos());
    let (dphi_exact_rad, _) = exact_f64(theta_v_rad, p);
    let dphi_approx_rad = p.y * paper_stretch(theta_v_rad);
    1.0 - dphi_approx_rad / dphi_exact_rad
}

/// Per-frame f32 inputs of the map transform, computed in f64 and rounded once, shared by the GPU
/// (`TransformUniforms` in `shaders/common/map_transform.wgsl`, same field order, 32 bytes) and
/// the Rust f32 twins so both see bit-identical values.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct TransformUniformsF32 {
    /// sin θv.
    pub sin_theta_v: f32,
    /// cos θv.
    pub cos_theta_v: f32,
    /// θv in radians (used beyond the north pole, where θ is small).
    pub theta_v: f32,
    /// π − θv in radians from f64 (used beyond the south pole, where π − θ is small; forming it
    /// in f32 would lose everything near θv = π).
    pub pi_minus_theta_v: f32,
    /// Δφ ≈ p̃y·stretch in the approximation (eq. 11), ≈ 1/sin θv, at most [`STRETCH_MAX`].
    pub stretch: f32,
    /// Padding to a 16-byte multiple (uniform buffer layout).
    pub _pad0: f32,
    /// Padding.
    pub _pad1: f32,
    /// Padding.
    pub _pad2: f32,
}

impl TransformUniformsF32 {
    /// Builds the uniforms for viewer colatitude `theta_v_rad` (from f64, rounded once).
    pub fn from_theta_v(theta_v_rad: f64, stretch: Stretch) -> Self {
        let (sin_theta_v, cos_theta_v) = theta_v_rad.sin_cos();
        let stretch_factor = stretch.factor(theta_v_rad);
        let stretch_finite = if stretch_factor.is_finite() {
            stretch_factor.clamp(-STRETCH_MAX, STRETCH_MAX)
        } else {
            STRETCH_MAX
        };
        Self {
            sin_theta_v: sin_theta_v as f32,
            cos_theta_v: cos_theta_v as f32,
            theta_v: theta_v_rad as f32,
            pi_minus_theta_v: ((PI - theta_v_rad) + PI_LO) as f32,
            stretch: stretch_finite as f32,
            _pad0: 0.0,
            _pad1: 0.0,
            _pad2: 0.0,
        }
    }
}

/// The seam rule of §4.4, twin of `map_transform_seam_dphi`.
///
/// The ring mesh duplicates its vertices on the meridian φ̃ = 0/π (p̃y = 0 exactly). Beyond a pole
/// those points lie on the meridian opposite the viewer, where Δφ = ±π: `atan2(±0, p_x < 0)`
/// picks the sign from the sign of zero, which is arbitrary, so a triangle could interpolate from
/// almost +π to −π across the whole map (Fig. 8). Each copy carries `seam_side`, the sign of p̃y
/// on the triangles it belongs to (+1 for the copy used by φ̃ just above 0 or just below π, −1 for
/// the other; 0 for every other vertex), and gets Δφ = seam_side·π there. π is taken as |atan2|,
/// which is exactly the f32 π, so no constant is duplicated in the shader.
pub fn seam_dphi_f32(dphi_rad: f32, p_y: f32, p_x: f32, seam_side: f32) -> f32 {
    let beyond_pole_on_seam = seam_side != 0.0 && p_y == 0.0 && p_x < 0.0;
    if beyond_pole_on_seam {
        seam_side * dphi_rad.abs()
    } else {
        dphi_rad
    }
}

/// Twin of `map_transform_rotate`: the world point for φv = 0 in f32 (eq. 10's sign).
pub fn rotate_f32(u: &TransformUniformsF32, p_tilde: Vec3) -> Vec3 {
    let p_x = u.cos_theta_v * p_tilde.x + u.sin_theta_v * p_tilde.z;
    let p_y = p_tilde.y;
    let p_z = -u.sin_theta_v * p_tilde.x + u.cos_theta_v * p_tilde.z;
    Vec3::new(p_x, p_y, p_z)
}

/// Twin of `map_transform_direct`: the paper's eq. 3–4 in f32, Δθ = acos(p_z) − θv,
/// Δφ = atan2(p_y, p_x). Returns (Δφ, Δθ).
///
/// acos near p_z = ±1 and the subtraction of θv lose ~0.4 m at the equator and hundreds of metres
/// near a pole (`docs/design.md#numerics`); kept as the baseline. p_z is clamped to [−1, 1] since the
/// rounded rotation can exceed 1 by an ulp (acos would return NaN).
pub fn direct_f32(u: &TransformUniformsF32, p_tilde: Vec3, seam_side: f32) -> (f32, f32) {
    let p = rotate_f32(u, p_tilde);
    let dphi = seam_dphi_f32(atan2_precise_f32(p.y, p.x), p.y, p.x, seam_side);
    let dtheta = p.z.clamp(-1.0, 1.0).acos() - u.theta_v;
    (dphi, dtheta)
}

/// Twin of `map_transform_stable`: the cancellation-free three branches of `docs/design.md#numerics` in f32.
/// Returns (Δφ, Δθ).
///
/// p_x > 0: Δθ = atan2(p̃x + cos θv·q, p̃z + sin θv·q), q = p̃y²/(ρ + p_x); beyond the north pole
/// (p_x ≤ 0, p_z > 0): atan2(ρ, p_z) − θv; beyond the south pole: (π − θv) − atan2(ρ, −p_z).
/// ρ is formed as √(p_x² + p_y²), fine for θ̃ ≥ 1e-18 (no mesh vertex is nearer than that without
/// being exactly the centre, where ρ = sin θv or 0 and every branch is exact).
pub fn stable_f32(u: &TransformUniformsF32, p_tilde: Vec3, seam_side: f32) -> (f32, f32) {
    let p = rotate_f32(u, p_tilde);
    let rho = (p.x * p.x + p.y * p.y).sqrt();
    let dtheta = if p.x > 0.0 {
        let q = p.y * p.y / (rho + p.x);
        atan2_precise_f32(p_tilde.x + u.cos_theta_v * q, p_tilde.z + u.sin_theta_v * q)
    } else if p.z > 0.0 {
        atan2_precise_f32(rho, p.z) - u.theta_v
    } else {
        u.pi_minus_theta_v - atan2_precise_f32(rho, -p.z)
    };
    let dphi = seam_dphi_f32(atan2_precise_f32(p.y, p.x), p.y, p.x, seam_side);
    (dphi, dtheta)
}

/// Twin of `map_transform_approx`: the paper's trigonometry-free approximation for inner rings,
/// Δφ ≈ p̃y·stretch (eq. 11) and Δθ ≈ p̃x (eq. 14: the ring is a circle stretched in φ only; +x̃ is
/// south). Returns (Δφ, Δθ). Valid where Fig. 12 says ([`APPROX_THETA_V_MIN_RAD`],
/// [`APPROX_THETA_TILDE_MAX_RAD`]); it never wraps, so it needs no seam rule.
pub fn approx_f32(u: &TransformUniformsF32, p_tilde: Vec3) -> (f32, f32) {
    (p_tilde.y * u.stretch, p_tilde.x)
}

/// Twin of `map_transform_blended`: stable·(1 − w) + approx·w with the per-vertex weight
/// `approx_weight` = w ∈ [0, 1] (0 = stable, 1 = approximation; exact at both ends). Fig. 14: the
/// weight must be a function of the ring only, so that the shared boundary ring of two levels gets
/// the same value from both and the surface has no gaps. Returns (Δφ, Δθ).
pub fn blended_f32(
    approx_weight: f32,
    u: &TransformUniformsF32,
    p_tilde: Vec3,
    seam_side: f32,
) -> (f32, f32) {
    let (stable_dphi, stable_dtheta) = stable_f32(u, p_tilde, seam_side);
    let (approx_dphi, approx_dtheta) = approx_f32(u, p_tilde);
    let keep = 1.0 - approx_weight;
    (
        stable_dphi * keep + approx_dphi * approx_weight,
        stable_dtheta * keep + approx_dtheta * approx_weight,
    )
}

/// The Fig. 12 condition as a predicate: whether eq. 11's approximation is within 0.1 % for rings
/// out to `theta_tilde_rad` when the viewer is at `theta_v_rad`.
pub fn approx_is_accurate(theta_v_rad: f64, theta_tilde_rad: f64) -> bool {
    theta_v_rad > APPROX_THETA_V_MIN_RAD
        && theta_v_rad < PI - APPROX_THETA_V_MIN_RAD
        && theta_tilde_rad < APPROX_THETA_TILDE_MAX_RAD
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_minus_cos_matches_for_large_angles() {
        for &t in &[0.1, 1.0, 3.0] {
            assert!((one_minus_cos(t) - (1.0 - f64::cos(t))).abs() < 1e-15);
        }
        assert!((one_minus_cos(1e-8) - 5e-17).abs() < 1e-30);
    }

    #[test]
    fn uniforms_are_finite_at_poles() {
        for &tv in &[0.0, PI, 1e-300] {
            for stretch in [Stretch::Paper, Stretch::Exact] {
                let u = TransformUniformsF32::from_theta_v(tv, stretch);
                let fields = bytemuck::cast::<_, [f32; 8]>(u);
                assert!(fields.iter().all(|f| f.is_finite()), "{u:?}");
            }
        }
        let u = TransformUniformsF32::from_theta_v(PI, Stretch::Exact);
        assert!(u.pi_minus_theta_v > 0.0 && u.pi_minus_theta_v < 2e-16);
    }

    #[test]
    fn blend_endpoints_are_exact() {
        let u = TransformUniformsF32::from_theta_v(0.7, Stretch::Exact);
        let p = p_tilde(0.3, 1e-4).as_vec3();
        assert_eq!(blended_f32(0.0, &u, p, 0.0), stable_f32(&u, p, 0.0));
        assert_eq!(blended_f32(1.0, &u, p, 0.0), approx_f32(&u, p));
        let u_pole = TransformUniformsF32::from_theta_v(0.0, Stretch::Exact);
        let (dphi, dtheta) = blended_f32(0.0, &u_pole, p, 0.0);
        assert!(dphi.is_finite() && dtheta.is_finite());
    }
}
