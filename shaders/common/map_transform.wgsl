// Spherical-clipmap map transform (spherical-clipmaps.md eq. 2–4, 11, 14, §4.4;
// docs/design.md#numerics): view-space unit point p̃ of the static ring mesh → map-space offsets from the viewer,
// returned as vec2(Δφ, Δθ) = (φ − φv, θ − θv) in radians, matching map space (s, t) = (φ, θ).
//
// A function library: no entry points, no bindings; it is concatenated before the pass shaders.
// Each function has a Rust twin in src/geo/map_transform.rs (named in its doc comment), written
// line by line in the same order; tests/cpu/geo_math.rs measures the twins against f64.
//
// Conventions (src/geo/mod.rs): view +x̃ points south at the viewer, +ỹ east, +z̃ up; for φv = 0 the
// world point is p = (cos θv·p̃x + sin θv·p̃z, p̃y, −sin θv·p̃x + cos θv·p̃z) (eq. 10's sign).

// Per-frame inputs, computed in f64 on the CPU and rounded once.
// Rust twin: TransformUniformsF32 (same fields, same order, 32 bytes).
struct TransformUniforms {
    sin_theta_v: f32,
    cos_theta_v: f32,
    theta_v: f32,
    // π − θv from f64 (forming it here would lose everything near the south pole).
    pi_minus_theta_v: f32,
    // Approximation stretch ≈ 1/sin θv (eq. 11 or exact), finite.
    stretch: f32,
    _pad0: f32,
    _pad1: f32,
    _pad2: f32,
}

// The world point for φv = 0. Rust twin: rotate_f32.
fn map_transform_rotate(u: TransformUniforms, p_tilde: vec3<f32>) -> vec3<f32> {
    let p_x = u.cos_theta_v * p_tilde.x + u.sin_theta_v * p_tilde.z;
    let p_y = p_tilde.y;
    let p_z = -u.sin_theta_v * p_tilde.x + u.cos_theta_v * p_tilde.z;
    return vec3<f32>(p_x, p_y, p_z);
}

// Seam meridian beyond a pole (§4.4): the duplicated vertices on φ̃ = 0/π have p̃y = 0 exactly and
// atan2(±0, p_x < 0) = ±π is ambiguous; the copy's seam_side (sign of p̃y on its triangles, 0 for
// other vertices) picks the side. |atan2| is exactly π there, so no π constant is needed.
// Rust twin: seam_dphi_f32.
fn map_transform_seam_dphi(dphi: f32, p_y: f32, p_x: f32, seam_side: f32) -> f32 {
    let beyond_pole_on_seam = seam_side != 0.0 && p_y == 0.0 && p_x < 0.0;
    return select(dphi, seam_side * abs(dphi), beyond_pole_on_seam);
}

// The paper's eq. 3–4: Δθ = acos(p_z) − θv (cancels near the viewer and the poles; baseline).
// Rust twin: direct_f32.
fn map_transform_direct(u: TransformUniforms, p_tilde: vec3<f32>, seam_side: f32) -> vec2<f32> {
    let p = map_transform_rotate(u, p_tilde);
    let dphi = map_transform_seam_dphi(atan2_precise(p.y, p.x), p.y, p.x, seam_side);
    let dtheta = acos(clamp(p.z, -1.0, 1.0)) - u.theta_v;
    return vec2<f32>(dphi, dtheta);
}

// The cancellation-free form of docs/design.md#numerics: three branches, accurate to O(ulp·θ̃) near the viewer and
// at the poles. Rust twin: stable_f32.
fn map_transform_stable(u: TransformUniforms, p_tilde: vec3<f32>, seam_side: f32) -> vec2<f32> {
    let p = map_transform_rotate(u, p_tilde);
    let rho = sqrt(p.x * p.x + p.y * p.y);
    var dtheta: f32;
    if p.x > 0.0 {
        // The viewer's side: sin(Δθ) = p̃x + cos θv·q, cos(Δθ) = p̃z + sin θv·q.
        let q = p.y * p.y / (rho + p.x);
        dtheta = atan2_precise(p_tilde.x + u.cos_theta_v * q, p_tilde.z + u.sin_theta_v * q);
    } else if p.z > 0.0 {
        // Beyond the north pole: θ is small.
        dtheta = atan2_precise(rho, p.z) - u.theta_v;
    } else {
        // Beyond the south pole: π − θ is small.
        dtheta = u.pi_minus_theta_v - atan2_precise(rho, -p.z);
    }
    let dphi = map_transform_seam_dphi(atan2_precise(p.y, p.x), p.y, p.x, seam_side);
    return vec2<f32>(dphi, dtheta);
}

// The paper's approximation for inner rings (eq. 11, 14): Δφ ≈ p̃y·stretch, Δθ ≈ p̃x. Never
// wraps, so no seam rule. Rust twin: approx_f32.
fn map_transform_approx(u: TransformUniforms, p_tilde: vec3<f32>) -> vec2<f32> {
    return vec2<f32>(p_tilde.y * u.stretch, p_tilde.x);
}

// Fig. 14: stable·(1 − w) + approx·w with a per-ring weight w ∈ [0, 1] (0 = stable, exact at both
// ends), so neighbouring levels agree on their shared ring. Rust twin: blended_f32.
fn map_transform_blended(approx_weight: f32, u: TransformUniforms, p_tilde: vec3<f32>, seam_side: f32) -> vec2<f32> {
    let stable = map_transform_stable(u, p_tilde, seam_side);
    let approx = map_transform_approx(u, p_tilde);
    let keep = 1.0 - approx_weight;
    return stable * keep + approx * approx_weight;
}
