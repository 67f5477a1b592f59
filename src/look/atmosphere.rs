//! The atmosphere: single scattering in exponential Rayleigh and Mie layers (f64 twin of
//! `shaders/common/look.wgsl`).
//!
//! A documented approximation of the physically based models docs/design.md#sky-models names (Bruneton &
//! Neyret 2008, Hillaire 2020): the same media and phase functions, but single scattering only
//! and no lookup tables. Along a view segment the in-scattered light is integrated with a few
//! midpoint samples; the sunlight reaching each sample is attenuated by the column of air
//! towards the sun, which comes in closed form from Schüler's approximation of the Chapman
//! grazing-incidence function (GPU Pro 3, 2012). The same code gives the sky around the disk
//! seen from space, the sky from the ground and the haze over the terrain (aerial
//! perspective), in the window and in PNGs alike.

use glam::DVec3;

/// √(π/2): the Chapman function's value at grazing incidence is ≈ √(πx/2).
const SQRT_HALF_PI: f64 = 1.253_314_137_315_500_3;

/// The media of an Earth-like atmosphere (Bruneton & Neyret 2008's constants).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Atmosphere {
    /// Radius of the planet's sphere, metres.
    pub radius_m: f64,
    /// Height of the atmosphere's top above the sphere, metres (the density there is e⁻⁷·⁵ of
    /// the ground's for Rayleigh).
    pub top_m: f64,
    /// Rayleigh scattering at the ground, per metre, for red, green, blue (680, 550, 440 nm).
    pub rayleigh: DVec3,
    pub rayleigh_height_m: f64,
    /// Mie scattering at the ground, per metre (grey).
    pub mie: f64,
    /// Mie extinction over scattering (aerosols absorb a little).
    pub mie_extinction_ratio: f64,
    pub mie_height_m: f64,
    /// Mie phase asymmetry g (Cornette–Shanks).
    pub mie_g: f64,
    /// Sunlight's scale: in-scattered radiance per unit of phase-weighted scattering. Lit
    /// terrain of albedo 1 is 1 (the terrain shading's unit).
    pub sun_radiance: f64,
}

impl Atmosphere {
    /// The Earth's atmosphere on a sphere of `radius_m`.
    pub fn earth(radius_m: f64) -> Self {
        Self {
            radius_m,
            top_m: 60_000.0,
            rayleigh: DVec3::new(5.802e-6, 13.558e-6, 33.1e-6),
            rayleigh_height_m: 8_000.0,
            mie: 3.996e-6,
            mie_extinction_ratio: 1.11,
            mie_height_m: 1_200.0,
            mie_g: 0.8,
            sun_radiance: 10.0,
        }
    }

    /// Radius of the atmosphere's top, metres.
    pub fn top_radius_m(&self) -> f64 {
        self.radius_m + self.top_m
    }

    /// Column of air (metres at ground density) of a layer of scale height `h_m` from radius
    /// `r` along zenith cosine `mu` to infinity ([`chapman_column_m`] with this sphere).
    pub fn column_m(&self, r: f64, mu: f64, h_m: f64) -> f64 {
        chapman_column_m(r, mu, self.radius_m, h_m)
    }

    /// Transmittance of sunlight reaching radius `r` at sun zenith cosine `mu`.
    pub fn sun_transmittance(&self, r: f64, mu: f64) -> DVec3 {
        let col_r = self.column_m(r, mu, self.rayleigh_height_m);
        let col_m = self.column_m(r, mu, self.mie_height_m);
        exp3(-(self.rayleigh * col_r + DVec3::splat(self.mie * self.mie_extinction_ratio * col_m)))
    }

    /// Single scattering along the segment from `o` (relative to the planet's centre) in unit
    /// direction `d` for at most `t_max` metres, clipped to the atmosphere, with `samples`
    /// midpoint samples: (in-scattered radiance, transmittance). The shader's
    /// `atmosphere_scatter` does the same operations in f32.
    pub fn scatter(
        &self,
        o: DVec3,
        d: DVec3,
        t_max: f64,
        sun: DVec3,
        samples: u32,
    ) -> (DVec3, DVec3) {
        let top = self.top_radius_m();
        let b = o.dot(d);
        let perp = o - b * d;
        let p2 = perp.length_squared();
        if p2 >= top * top {
            return (DVec3::ZERO, DVec3::ONE);
        }
        let half_chord = ((top - p2.sqrt()) * (top + p2.sqrt())).sqrt();
        let t0 = (-b - half_chord).max(0.0);
        let t1 = (-b + half_chord).min(t_max);
        if t1 <= t0 {
            return (DVec3::ZERO, DVec3::ONE);
        }
        let dt = (t1 - t0) / samples as f64;
        let mie_ext = self.mie * self.mie_extinction_ratio;
        let (mut col_r, mut col_m) = (0.0, 0.0);
        let (mut sum_r, mut sum_m) = (DVec3::ZERO, DVec3::ZERO);
        for i in 0..samples {
            let t = t0 + (i as f64 + 0.5) * dt;
            let p = o + t * d;
            let r = p.length();
            let h = (r - self.radius_m).max(0.0);
            let dens_r = (-h / self.rayleigh_height_m).exp() * dt;
            let dens_m = (-h / self.mie_height_m).exp() * dt;
            let here_r = col_r + 0.5 * dens_r;
            let here_m = col_m + 0.5 * dens_m;
            col_r += dens_r;
            col_m += dens_m;
            let mu_s = p.dot(sun) / r;
            let sun_r = self.column_m(r, mu_s, self.rayleigh_height_m);
            let sun_m = self.column_m(r, mu_s, self.mie_height_m);
            let tau = self.rayleigh * (here_r + sun_r) + DVec3::splat(mie_ext * (here_m + sun_m));
            let tr = exp3(-tau);
            sum_r += dens_r * tr;
            sum_m += dens_m * tr;
        }
        let mu = d.dot(sun);
        let inscatter = self.sun_radiance
            * (self.rayleigh * rayleigh_phase(mu) * sum_r
                + DVec3::splat(self.mie * mie_phase(mu, self.mie_g)) * sum_m);
        let transmittance = exp3(-(self.rayleigh * col_r + DVec3::splat(mie_ext * col_m)));
        (inscatter, transmittance)
    }

    /// The sky's radiance seen from `o` in unit direction `d` (the ray stops at the sphere).
    pub fn sky_radiance(&self, o: DVec3, d: DVec3, sun: DVec3, samples: u32) -> DVec3 {
        let t_max = ray_sphere_hit(o, d, self.radius_m).unwrap_or(f64::INFINITY);
        self.scatter(o, d, t_max, sun, samples).0
    }
}

/// Distance along the unit ray (o, d) to its first hit of the sphere of radius `r` about the
/// origin, if it hits it ahead.
pub fn ray_sphere_hit(o: DVec3, d: DVec3, r: f64) -> Option<f64> {
    let b = o.dot(d);
    let perp = o - b * d;
    let p = perp.length();
    if p >= r {
        return None;
    }
    let t = -b - ((r - p) * (r + p)).sqrt();
    (t > 0.0).then_some(t)
}

/// exp(y²)·erfc(y) for y ≥ 0, relative error < 4e-4 (the shader's `erfcx`, in f64):
/// Abramowitz & Stegun 7.1.26 below 2, Laplace's continued fraction above (where the A&S form
/// loses its relative accuracy).
pub fn erfcx(y: f64) -> f64 {
    if y < 2.0 {
        let t = 1.0 / (1.0 + 0.327_591_1 * y);
        return t
            * (0.254_829_592
                + t * (-0.284_496_736
                    + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    }
    1.0 / std::f64::consts::PI.sqrt() / (y + 0.5 / (y + 1.0 / (y + 1.5 / (y + 2.0 / y))))
}

/// Column of an exponential layer of scale height `h_m` above a sphere of radius `radius_m`,
/// from radius `r` along zenith cosine `mu` to infinity, in metres of ground-density air: the
/// Chapman function in its large-x form Ch(X, μ) = √(πX/2)·erfcx(√(X/2)·μ) with X = r/H (exact
/// to O(1/X); X ≥ 800 for the Earth's layers); below the horizon (μ < 0) the column through the
/// tangent point minus the one beyond it, infinite where the ray hits the sphere.
pub fn chapman_column_m(r: f64, mu: f64, radius_m: f64, h_m: f64) -> f64 {
    let x = radius_m / h_m;
    let h = (r - radius_m).max(0.0) / h_m;
    let big_x = x + h;
    let toward = SQRT_HALF_PI * big_x.sqrt() * erfcx((0.5 * big_x).sqrt() * mu.abs()) * (-h).exp();
    if mu >= 0.0 {
        return toward * h_m;
    }
    let x0 = (1.0 - mu * mu).max(0.0).sqrt() * big_x;
    if x0 < x {
        // The tangent point lies inside the planet: the ray hits it.
        return f64::INFINITY;
    }
    (2.0 * SQRT_HALF_PI * x0.sqrt() * (x - x0).exp() - toward) * h_m
}

/// The same column by numerical integration (tests: how good the approximation is).
pub fn column_numeric_m(r: f64, mu: f64, radius_m: f64, h_m: f64) -> f64 {
    let o = DVec3::new(0.0, 0.0, r);
    let d = DVec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    if ray_sphere_hit(o, d, radius_m).is_some() {
        return f64::INFINITY;
    }
    // Out to where the density is e⁻⁴⁰, in steps much finer than the scale height.
    let length = ((radius_m + 40.0 * h_m).powi(2) - r * r * (1.0 - mu * mu)).sqrt() - r * mu;
    let steps = 200_000;
    let dt = length / steps as f64;
    (0..steps)
        .map(|i| {
            let p = o + (i as f64 + 0.5) * dt * d;
            (-(p.length() - radius_m) / h_m).exp() * dt
        })
        .sum()
}

/// Rayleigh phase function 3/(16π)·(1 + μ²).
pub fn rayleigh_phase(mu: f64) -> f64 {
    3.0 / (16.0 * std::f64::consts::PI) * (1.0 + mu * mu)
}

/// Cornette–Shanks phase function with asymmetry g.
pub fn mie_phase(mu: f64, g: f64) -> f64 {
    let denom = (1.0 + g * g - 2.0 * g * mu).max(1e-4);
    3.0 / (8.0 * std::f64::consts::PI) * (1.0 - g * g) * (1.0 + mu * mu)
        / ((2.0 + g * g) * denom * denom.sqrt())
}

fn exp3(v: DVec3) -> DVec3 {
    DVec3::new(v.x.exp(), v.y.exp(), v.z.exp())
}

/// Segments around the sky pass's ring ([`SkyRing`]).
pub const SKY_RING_SEGMENTS: u32 = 128;

/// The directions the sky pass must shade from outside the atmosphere: the annulus between
/// the cone of rays that meet a sphere inside all terrain (those hit the terrain first, which
/// the terrain pass has drawn) and the cone of rays that meet the shell (beyond it the sky is
/// black). Both cones are around the direction to the planet's centre (−z̃ in view space).
/// Drawn as [`SKY_RING_SEGMENTS`] quads whose vertices are directions at tan(angle) from that
/// axis: each edge is a straight line on screen (a great circle of directions), so the outer
/// vertices are pushed out by 1/cos(π/N) to circumscribe the outer cone and the inner ones lie
/// on the inner cone, whose chords then lie inside it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkyRing {
    /// tan of the inner vertices' angle from the axis.
    pub tan_inner: f64,
    /// tan of the outer vertices' angle from the axis.
    pub tan_outer: f64,
}

impl SkyRing {
    /// The ring seen from `eye_radius_m` for terrain everywhere above `inner_radius_m` and the
    /// shell's `outer_radius_m`, each cone widened by `margin_rad` (a few pixels: the shader's
    /// f32 tests against the shell and the rasteriser's edges). None where the eye is inside
    /// the shell or so close above it that the outer cone nears 90° (a full-screen pass then).
    pub fn new(
        eye_radius_m: f64,
        inner_radius_m: f64,
        outer_radius_m: f64,
        margin_rad: f64,
    ) -> Option<Self> {
        if eye_radius_m <= outer_radius_m {
            return None;
        }
        let outer = (outer_radius_m / eye_radius_m).asin() + margin_rad;
        if outer >= 89f64.to_radians() {
            return None;
        }
        let inner = ((inner_radius_m.max(0.0) / eye_radius_m).asin() - margin_rad).max(0.0);
        let half_segment = std::f64::consts::PI / f64::from(SKY_RING_SEGMENTS);
        Some(Self {
            tan_inner: inner.tan(),
            tan_outer: outer.tan() / half_segment.cos(),
        })
    }

    /// The ring's polygon (vertex azimuths k·2π/N) contains direction `d` (view space, the
    /// axis −z̃): between the inner polygon and the outer one. A direction's angle from the
    /// axis along azimuth ψ inside segment k is bounded by the chord between its two vertices.
    pub fn contains(&self, d: DVec3) -> bool {
        if d.z >= 0.0 {
            return false;
        }
        // The direction's point on the plane z = −1.
        let (x, y) = (d.x / -d.z, d.y / -d.z);
        let step = std::f64::consts::TAU / f64::from(SKY_RING_SEGMENTS);
        let psi = y.atan2(x).rem_euclid(std::f64::consts::TAU);
        let k = (psi / step).floor();
        // Distance of the chord between the vertices at azimuths k·step and (k+1)·step, radius
        // t, from the origin along ψ: t·cos(step/2)/cos(ψ − centre).
        let centre = (k + 0.5) * step;
        let along = |t: f64| t * (0.5 * step).cos() / (psi - centre).cos();
        let r = x.hypot(y);
        r >= along(self.tan_inner) && r <= along(self.tan_outer)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const R: f64 = 6_371_000.0;

    /// Every direction that meets the shell but not the inner sphere lies inside the ring's
    /// polygon, with the margin to spare, from just above the shell to the Moon's distance.
    #[test]
    fn the_sky_ring_covers_the_rays_between_the_cones() {
        let (inner_r, outer_r) = (R - 12_000.0, R + 100_000.0);
        for eye in [R + 150_000.0, R + 400_000.0, R + 3.0e6, R + 2.0e7, 3.8e8] {
            let margin = 1e-4;
            let ring = SkyRing::new(eye, inner_r, outer_r, margin).expect("outside the shell");
            let (a_in, a_out) = ((inner_r / eye).asin(), (outer_r / eye).asin());
            for i in 0..2000 {
                let psi = i as f64 * std::f64::consts::TAU / 2000.0 + 0.1234;
                for j in 0..=50 {
                    let a = a_in + (a_out - a_in) * j as f64 / 50.0;
                    for a in [a, a - 0.9 * margin, a + 0.9 * margin] {
                        let d = DVec3::new(a.sin() * psi.cos(), a.sin() * psi.sin(), -a.cos());
                        assert!(ring.contains(d), "eye {eye}: angle {a} azimuth {psi}");
                    }
                }
            }
        }
        // Inside the shell, or just above it with the cone near 90°: the whole frame.
        assert!(SkyRing::new(R + 50_000.0, inner_r, outer_r, 1e-4).is_none());
        assert!(SkyRing::new(R + 100_100.0, inner_r, outer_r, 1e-4).is_none());
    }

    #[test]
    fn chapman_column_is_within_half_a_percent_of_the_integral() {
        for &h_m in &[8_000.0, 1_200.0] {
            for &alt in &[0.0, 2_000.0, 20_000.0] {
                // Down to just above the geometric horizon (its dip is √(2·alt/R)).
                let dip = -(2.0 * alt / R).sqrt();
                for &mu in &[1.0, 0.5, 0.2, 0.05, 0.0, 0.4 * dip, 0.8 * dip] {
                    let approx = chapman_column_m(R + alt, mu, R, h_m);
                    let exact = column_numeric_m(R + alt, mu, R, h_m);
                    let rel = (approx - exact).abs() / exact;
                    assert!(
                        rel < 0.005,
                        "H {h_m} alt {alt} mu {mu}: {approx} vs {exact} ({rel})"
                    );
                }
            }
        }
    }

    #[test]
    fn erfcx_matches_its_series() {
        // exp(y²)·erfc(y) at 0 is 1; for large y it tends to 1/(√π·y)·(1 − 1/(2y²) + 3/(4y⁴)).
        assert!((erfcx(0.0) - 1.0).abs() < 1e-6);
        for y in [5.0, 20.0, 60.0] {
            let series =
                1.0 / (std::f64::consts::PI.sqrt() * y) * (1.0 - 0.5 / (y * y) + 0.75 / y.powi(4));
            assert!((erfcx(y) / series - 1.0).abs() < 1e-3, "{y}");
        }
    }

    #[test]
    fn sunlight_below_the_planet_is_blocked() {
        // From the ground, a sun 10° below the horizon: the ray runs into the planet.
        let t = Atmosphere::earth(R).sun_transmittance(R + 10.0, -0.17);
        assert!(t.max_element() < 1e-6, "{t}");
        assert!(column_numeric_m(R + 10.0, -0.17, R, 8_000.0).is_infinite());
    }

    #[test]
    fn the_midday_sky_is_blue_and_the_low_sun_is_red() {
        let a = Atmosphere::earth(R);
        let o = DVec3::new(0.0, 0.0, R + 2.0);
        let sun = DVec3::new(0.0, 0.57, 0.82).normalize();
        let zenith = a.sky_radiance(o, DVec3::Z, sun, 32);
        assert!(zenith.z > zenith.y && zenith.y > zenith.x, "{zenith}");
        // A sun near the horizon reaches the ground reddened: blue loses more than red.
        let low = a.sun_transmittance(R + 2.0, 0.05);
        assert!(low.x > 2.0 * low.z, "{low}");
        let high = a.sun_transmittance(R + 2.0, 1.0);
        assert!(high.z > 0.7, "{high}");
    }

    #[test]
    fn from_space_the_sky_glows_only_inside_the_shell() {
        let a = Atmosphere::earth(R);
        let o = DVec3::new(0.0, 0.0, R + 10_000_000.0);
        let sun = DVec3::new(0.0, 0.57, 0.82).normalize();
        // Rays whose closest approach to the centre is a given height above the surface.
        let ray_at = |height_m: f64| {
            let sin_a = (R + height_m) / o.z;
            DVec3::new(sin_a, 0.0, -(1.0 - sin_a * sin_a).sqrt())
        };
        let inside = a.sky_radiance(o, ray_at(10_000.0), sun, 32);
        let outside = a.sky_radiance(o, ray_at(70_000.0), sun, 32);
        assert!(inside.z > 0.05, "{inside}");
        assert_eq!(outside, DVec3::ZERO);
    }

    #[test]
    fn more_samples_converge() {
        let a = Atmosphere::earth(R);
        let o = DVec3::new(0.0, 0.0, R + 1_000.0);
        let sun = DVec3::new(0.0, 0.57, 0.82).normalize();
        let d = DVec3::new(0.9, 0.0, 0.1).normalize();
        let fine = a.sky_radiance(o, d, sun, 512);
        let coarse = a.sky_radiance(o, d, sun, 16);
        assert!(
            (fine - coarse).length() / fine.length() < 0.05,
            "{fine} {coarse}"
        );
    }
}
