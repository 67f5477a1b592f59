//! The procedural detail on the CPU (f64 reference, `globe::procedural`): what a user of the
//! detail relies on. It looks the same in every direction at the pole and at the equator, is
//! continuous across the antimeridian, is reproducible from its seed, is band-limited by λ
//! (octave k enters only between λ = k and k + 1), stays within its stated height and slope
//! bounds (the reference ray caster's safe step), survives every extreme of its parameter
//! ranges, rejects bad detail files with a message naming the field and the file, and gives
//! each clipmap level the octaves its points need.
//!
//! Figures go to stdout (`cargo test --test cpu -- procedural:: --nocapture`).

use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::path::Path;

use glam::DVec3;
use globe::geo::EARTH_RADIUS_M;
use globe::geo::sphere;
use globe::procedural::{
    Detail, DetailError, DetailParams, LevelOctaves, MAX_OCTAVES, MAX_PARTIAL, RoughnessMap,
    WarpParams, detail_texel_f32,
};

const DATA_SPACING_M: f64 = 1000.0;

/// splitmix64: a small deterministic generator (the same points on every run).
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform on the sphere.
    fn unit_vector(&mut self) -> DVec3 {
        let z = 2.0 * self.unit() - 1.0;
        let phi = TAU * self.unit();
        let rho = (1.0 - z * z).max(0.0).sqrt();
        DVec3::new(rho * phi.cos(), rho * phi.sin(), z)
    }

    /// A uniformly random unit tangent vector at `u`.
    fn tangent(&mut self, u: DVec3) -> DVec3 {
        let (a, b) = tangent_basis(u);
        let angle = TAU * self.unit();
        a * angle.cos() + b * angle.sin()
    }
}

/// Two perpendicular unit tangents at `u` (any pair: only used for random directions).
fn tangent_basis(u: DVec3) -> (DVec3, DVec3) {
    let helper = if u.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
    let a = u.cross(helper).normalize();
    (a, u.cross(a))
}

/// The point `distance_m` along the great circle from `u` in tangent direction `t`.
fn walk(u: DVec3, t: DVec3, distance_m: f64) -> DVec3 {
    let a = distance_m / EARTH_RADIUS_M;
    (u * a.cos() + t * a.sin()).normalize()
}

/// A relief map of `cols × cols/2` cells, all `relief_m`.
fn constant_relief(cols: u32, relief_m: f32) -> RoughnessMap {
    let rows = cols / 2;
    RoughnessMap::from_values(
        cols,
        rows,
        vec![relief_m; (cols * rows) as usize],
        EARTH_RADIUS_M,
    )
}

/// A relief map that varies everywhere and jumps between the last column and the first (so
/// the amplitude's own wrap at the antimeridian is exercised).
fn varying_relief() -> RoughnessMap {
    let (cols, rows) = (144u32, 72u32);
    let values = (0..rows)
        .flat_map(|r| {
            (0..cols).map(move |c| {
                (300.0 + 8.0 * c as f64 + 400.0 * (0.13 * r as f64).sin().abs()) as f32
            })
        })
        .collect();
    RoughnessMap::from_values(cols, rows, values, EARTH_RADIUS_M)
}

/// The detail over Earth data of 1 km spacing with a constant relief of 1000 m.
fn detail_with(params: DetailParams) -> Detail {
    Detail::new(
        params,
        EARTH_RADIUS_M,
        DATA_SPACING_M,
        constant_relief(720, 1000.0),
    )
}

fn unit_at_lat_lon(lat_deg: f64, lon_deg: f64) -> DVec3 {
    let (phi, theta) = sphere::phi_theta_from_lat_lon_deg(lat_deg, lon_deg);
    sphere::unit_vector(phi, theta)
}

// ---------------------------------------------------------------------------------------------
// Isotropy

/// Samples per line and their spacing; lines per direction and their spacing.
const LINE_SAMPLES: usize = 400;
const SAMPLE_STEP_M: f64 = 10.0;
const LINES: usize = 96;
const LINE_STEP_M: f64 = 260.0;
const MAX_LAG: usize = 120;

/// The correlation length (lag where the pooled autocorrelation first falls below 1/e,
/// interpolated linearly) of the normalized detail along `along`, over `LINES` parallel lines
/// spread along `across`, on the tangent plane at `u0` (projected back to the sphere: over
/// 25 km the plane's distortion is below 10⁻⁵).
fn correlation_length_m(
    detail: &Detail,
    u0: DVec3,
    along: DVec3,
    across: DVec3,
    lambda: f64,
) -> f64 {
    let lines: Vec<Vec<f64>> = (0..LINES)
        .map(|j| {
            let b = (j as f64 - LINES as f64 / 2.0) * LINE_STEP_M;
            (0..LINE_SAMPLES)
                .map(|i| {
                    let s = (i as f64 - LINE_SAMPLES as f64 / 2.0) * SAMPLE_STEP_M;
                    let p = (u0 + (along * s + across * b) / EARTH_RADIUS_M).normalize();
                    detail.normalized(p, lambda)
                })
                .collect()
        })
        .collect();
    let count = (LINES * LINE_SAMPLES) as f64;
    let mean = lines.iter().flatten().sum::<f64>() / count;
    let cov = |lag: usize| {
        let mut sum = 0.0;
        let mut n = 0usize;
        for line in &lines {
            for i in 0..LINE_SAMPLES - lag {
                sum += (line[i] - mean) * (line[i + lag] - mean);
                n += 1;
            }
        }
        sum / n as f64
    };
    let c0 = cov(0);
    assert!(c0 > 0.0, "the detail is flat along the lines");
    let threshold = (-1f64).exp();
    let mut previous = 1.0;
    for lag in 1..=MAX_LAG {
        let rho = cov(lag) / c0;
        if rho < threshold {
            let t = (previous - threshold) / (previous - rho);
            return (lag as f64 - 1.0 + t) * SAMPLE_STEP_M;
        }
        previous = rho;
    }
    panic!("autocorrelation stays above 1/e up to {MAX_LAG} samples");
}

/// The detail is isotropic where a (φ, θ) lattice would not be: the correlation length along
/// east–west and along north–south agrees within [0.8, 1.25] at latitude 89.99° (1.1 km from
/// the pole, the lines cross it), at the equator and exactly at the pole (two perpendicular
/// great circles). λ = 4: octaves of 500, 250, 125 and 62.5 m cells.
#[test]
fn detail_is_isotropic_at_the_pole_and_the_equator() {
    let detail = detail_with(DetailParams::default());
    let lambda = 4.0;
    let sites = [
        ("lat 89.99", 89.99, 30.0),
        ("lat 0", 0.0, 10.0),
        ("lat 90 (pole)", 90.0, 0.0),
    ];
    for (name, lat, lon) in sites {
        let (u0, east, north) = if lat == 90.0 {
            // At the pole: two perpendicular great circles (the x and y meridians).
            (DVec3::Z, DVec3::X, DVec3::Y)
        } else {
            let (phi, theta) = sphere::phi_theta_from_lat_lon_deg(lat, lon);
            (
                sphere::unit_vector(phi, theta),
                sphere::east_unit_vector(phi),
                -sphere::south_unit_vector(phi, theta),
            )
        };
        let ew = correlation_length_m(&detail, u0, east, north, lambda);
        let ns = correlation_length_m(&detail, u0, north, east, lambda);
        let ratio = ew / ns;
        println!("isotropy {name}: corr EW {ew:.1} m, NS {ns:.1} m, ratio {ratio:.3}");
        assert!(
            (0.8..=1.25).contains(&ratio),
            "{name}: correlation lengths EW {ew} m and NS {ns} m differ (ratio {ratio})"
        );
        // A sanity check on the estimate: the first octave's cell is 500 m.
        assert!(
            (50.0..500.0).contains(&ew) && (50.0..500.0).contains(&ns),
            "{name}: implausible correlation lengths {ew} m, {ns} m"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Antimeridian, seed

/// The detail does not notice the antimeridian: at ±179.999999° (a few decimetres apart) the
/// heights differ by no more than the slope bound times the distance, with a relief map whose
/// values jump between its last and first column; at ±180° they are the same point and the
/// same height.
#[test]
fn detail_is_continuous_across_the_antimeridian() {
    let detail = Detail::new(
        DetailParams::default(),
        EARTH_RADIUS_M,
        DATA_SPACING_M,
        varying_relief(),
    );
    let mut worst_ratio = 0f64;
    for lat in [-89.9, -60.0, -12.5, 0.0, 33.3, 71.0, 89.999] {
        let east = unit_at_lat_lon(lat, 179.999_999);
        let west = unit_at_lat_lon(lat, -179.999_999);
        let distance_m = sphere::great_circle_distance_m(east, west, EARTH_RADIUS_M);
        for lambda in [3.0, 9.5, detail.lambda_full()] {
            let a = detail.height_m(east, lambda);
            let b = detail.height_m(west, lambda);
            let slope = detail
                .bounds_near(east, 2.0 * distance_m / EARTH_RADIUS_M, lambda)
                .1;
            let allowed = slope * distance_m;
            assert!(
                (a - b).abs() <= allowed,
                "lat {lat}, λ {lambda}: {a} m vs {b} m over {distance_m} m (slope bound {slope})"
            );
            worst_ratio = worst_ratio.max((a - b).abs() / allowed);

            // ±180° by latitude/longitude: one point, one height.
            let plus = unit_at_lat_lon(lat, 180.0);
            let minus = unit_at_lat_lon(lat, -180.0);
            assert_eq!(
                detail.height_m(plus, lambda),
                detail.height_m(minus, lambda),
                "lat {lat}: ±180° differ"
            );
            // φ = ±π as given (the unit vectors differ in the last bit of y).
            let (_, theta) = sphere::phi_theta_from_lat_lon_deg(lat, 0.0);
            let (p, m) = (
                sphere::unit_vector(PI, theta),
                sphere::unit_vector(-PI, theta),
            );
            let d = (detail.height_m(p, lambda) - detail.height_m(m, lambda)).abs();
            assert!(d <= 1e-6, "lat {lat}: φ = ±π differ by {d} m");
        }
    }
    println!("antimeridian: worst |ΔD| / (slope bound × distance) = {worst_ratio:.3}");
}

/// Same parameters, same planet (bit for bit, also across two `Detail`s); another seed,
/// another surface.
#[test]
fn detail_is_deterministic_and_the_seed_changes_it() {
    let a = detail_with(DetailParams::default());
    let b = detail_with(DetailParams::default());
    let other = detail_with(DetailParams {
        seed: 2,
        ..DetailParams::default()
    });
    let mut rng = Rng(7);
    let (mut differ, n) = (0, 500);
    let sigma = a.amplitude_m(DVec3::Z);
    for _ in 0..n {
        let u = rng.unit_vector();
        let lambda = a.lambda_full();
        let h = a.height_m(u, lambda);
        assert_eq!(h.to_bits(), a.height_m(u, lambda).to_bits());
        assert_eq!(h.to_bits(), b.height_m(u, lambda).to_bits());
        if (h - other.height_m(u, lambda)).abs() > 1e-3 * sigma {
            differ += 1;
        }
    }
    assert!(
        differ > n * 9 / 10,
        "seed 2 gives the same heights as seed 1 at {} of {n} points",
        n - differ
    );
}

// ---------------------------------------------------------------------------------------------
// Band limit and bounds

/// λ limits the detail to its octaves: going from λ = k to k + 1 adds exactly octave k, whose
/// size is at most a_k·(1 + g_h) (in units of σ); a fractional λ adds that fraction of it.
#[test]
fn lambda_adds_one_bounded_octave_at_a_time() {
    let detail = detail_with(DetailParams::default());
    let g = detail.params().height_roughness;
    let n = detail.octave_count();
    assert_eq!(n, 16, "500 m down to 1 cm by halves");
    let mut rng = Rng(11);
    let mut largest = vec![0f64; n];
    for _ in 0..200 {
        let u = rng.unit_vector();
        for (k, o) in detail.octaves().iter().enumerate() {
            let lo = detail.normalized(u, k as f64);
            let hi = detail.normalized(u, k as f64 + 1.0);
            let t = hi - lo;
            let bound = o.amplitude * (1.0 + g);
            assert!(
                t.abs() <= bound * (1.0 + 1e-12),
                "octave {k}: |t| = {} > a_k (1 + g_h) = {bound}",
                t.abs()
            );
            let part = detail.normalized(u, k as f64 + 0.3) - lo;
            assert!(
                (part - 0.3 * t).abs() <= 1e-12 * (1.0 + lo.abs()),
                "octave {k}: λ = k + 0.3 adds {part}, not 0.3 × {t}"
            );
            largest[k] = largest[k].max(t.abs() / o.amplitude);
        }
        // Beyond the last octave nothing is added.
        assert_eq!(
            detail.normalized(u, n as f64),
            detail.normalized(u, n as f64 + 5.0)
        );
    }
    // The bound is not vacuous: every octave reaches a good part of its amplitude.
    for (k, l) in largest.iter().enumerate() {
        assert!(*l > 0.4, "octave {k} never exceeds {l} of its amplitude");
    }
}

/// The slope bound (the reference ray caster's safe step) holds: finite differences of the
/// height between random point pairs 1 mm to 700 m apart, at several λ, never exceed
/// `bounds_near(..).1` of a cap containing both, with a relief map that varies everywhere.
#[test]
fn slope_bound_holds() {
    let detail = Detail::new(
        DetailParams::default(),
        EARTH_RADIUS_M,
        DATA_SPACING_M,
        varying_relief(),
    );
    let mut rng = Rng(13);
    for lambda in [1.0, 3.5, 8.0, detail.lambda_full()] {
        let mut worst = 0f64;
        for i in 0..400 {
            // Some pairs at and around the poles.
            let u = match i {
                0 => DVec3::Z,
                1 => -DVec3::Z,
                2 => unit_at_lat_lon(89.9999, 12.0),
                _ => rng.unit_vector(),
            };
            let t = rng.tangent(u);
            for step_m in [1e-3, 0.05, 1.0, 30.0, 700.0] {
                let v = walk(u, t, step_m);
                let distance_m = sphere::great_circle_distance_m(u, v, EARTH_RADIUS_M);
                let slope = detail
                    .bounds_near(u, 1.001 * distance_m / EARTH_RADIUS_M, lambda)
                    .1;
                let d = (detail.height_m(v, lambda) - detail.height_m(u, lambda)).abs();
                assert!(
                    d <= slope * distance_m * (1.0 + 1e-9) + 1e-12,
                    "λ {lambda}: |ΔD| = {d} m over {distance_m} m exceeds the slope bound {slope}"
                );
                worst = worst.max(d / (slope * distance_m));
            }
        }
        println!("slope bound λ {lambda:.1}: worst |ΔD| / (bound × distance) = {worst:.3}");
        assert!(
            worst > 0.01,
            "λ {lambda}: the slope bound is vacuous ({worst})"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Extreme parameters

/// Checks one parameter set: finite heights within the height bound at the poles, on the
/// antimeridian and at random points, for λ from 0 to every octave and at 1 mm from the
/// viewer; the slope bound between a point and one 1 mm away; finite f32 twin.
fn check_stiff(name: &str, params: DetailParams, data_spacing_m: f64) -> Detail {
    params.validate(name).expect("the stiff case is in range");
    let detail = Detail::new(
        params,
        EARTH_RADIUS_M,
        data_spacing_m,
        constant_relief(720, 1000.0),
    );
    let n = detail.lambda_full();
    assert_eq!(
        detail.lambda_at_arc_m(1e-3),
        n,
        "{name}: 1 mm from the viewer every octave is geometry"
    );
    let mut points = vec![
        DVec3::Z,
        -DVec3::Z,
        sphere::unit_vector(PI, FRAC_PI_2),
        sphere::unit_vector(-PI, FRAC_PI_2),
        unit_at_lat_lon(45.0, 180.0),
        unit_at_lat_lon(-45.0, -180.0),
        unit_at_lat_lon(89.999_999, 179.999_999),
    ];
    let mut rng = Rng(17);
    points.extend((0..40).map(|_| rng.unit_vector()));
    let lambdas = [
        0.0,
        0.5,
        1.0,
        2.7,
        0.5 * n,
        n - 0.25,
        n,
        detail.lambda_at_arc_m(1e-3),
    ];
    for &u in &points {
        for &lambda in &lambdas {
            let h = detail.height_m(u, lambda);
            let (bound, slope) = detail.bounds_near(u, 1e-9, lambda);
            assert!(h.is_finite(), "{name}: D({u}, {lambda}) = {h}");
            assert!(
                slope.is_finite() && slope >= 0.0,
                "{name}: slope bound {slope}"
            );
            assert!(
                h.abs() <= bound * (1.0 + 1e-12),
                "{name}: |D({u}, {lambda})| = {} > bound {bound}",
                h.abs()
            );
        }
        // 1 mm away, every octave.
        let v = walk(u, rng.tangent(u), 1e-3);
        let distance_m = sphere::great_circle_distance_m(u, v, EARTH_RADIUS_M);
        let slope = detail
            .bounds_near(u, 1.001 * distance_m / EARTH_RADIUS_M, n)
            .1;
        let d = (detail.height_m(v, n) - detail.height_m(u, n)).abs();
        assert!(
            d <= slope * distance_m * (1.0 + 1e-9) + 1e-12,
            "{name}: {d} m over 1 mm exceeds the slope bound {slope}"
        );
        // The f32 twin at its own anchor point stays finite.
        let count = detail.octave_count();
        let anchors = detail.anchors(u, count);
        let texel = detail_texel_f32(
            &anchors,
            &detail.amplitudes_f32(),
            &detail.constants_f32(),
            [0.0; 3],
            detail.amplitude_m(u) as f32,
            LevelOctaves {
                full: count as u32,
                partial: 0,
            },
        );
        assert!(texel.full_m.is_finite(), "{name}: f32 twin {texel:?}");
    }
    for level in 0..48 {
        let o = detail.level_octaves(level, 0.25);
        assert!(o.full + o.partial <= detail.octave_count() as u32);
        assert!(o.partial as usize <= MAX_PARTIAL);
    }
    detail
}

/// Every extreme of the parameter ranges evaluates without NaN or panic and within its
/// bounds: lacunarity 1.4 and 4, Hurst 0.05 and 1, a floor so fine that the 32-octave table is
/// full, a warp that folds the domain, and a floor above the data (no octaves: height 0).
#[test]
fn extreme_parameters_stay_finite_and_bounded() {
    let d = DetailParams::default;
    check_stiff(
        "lacunarity 1.4",
        DetailParams {
            lacunarity: 1.4,
            ..d()
        },
        DATA_SPACING_M,
    );
    check_stiff(
        "lacunarity 4",
        DetailParams {
            lacunarity: 4.0,
            ..d()
        },
        DATA_SPACING_M,
    );
    check_stiff(
        "hurst 0.05",
        DetailParams { hurst: 0.05, ..d() },
        DATA_SPACING_M,
    );
    check_stiff(
        "hurst 1",
        DetailParams { hurst: 1.0, ..d() },
        DATA_SPACING_M,
    );
    let deep = check_stiff(
        "32 octaves",
        DetailParams {
            // The floor is raised to R/2³⁰ (5.9 mm): lattice indices stay within i32.
            floor_m: 0.001,
            lacunarity: 1.4,
            hurst: 0.05,
            octaves_below_data: 0.0,
            ..d()
        },
        DATA_SPACING_M,
    );
    assert_eq!(deep.octave_count(), MAX_OCTAVES);
    check_stiff(
        "folding warp",
        DetailParams {
            warp: WarpParams {
                c1: [100.0, 100.0],
                c2: [-100.0, 100.0],
                c3: [100.0, -100.0],
                lever_cells: 64.0,
            },
            height_roughness: 0.95,
            ..d()
        },
        DATA_SPACING_M,
    );
    let none = check_stiff(
        "floor above the data",
        DetailParams {
            floor_m: 1e5,
            ..d()
        },
        DATA_SPACING_M,
    );
    assert_eq!(none.octave_count(), 0);
    assert_eq!(none.lambda_full(), 0.0);
    assert_eq!(none.height_m(DVec3::Z, 3.0), 0.0);
    assert_eq!(none.lambda_at_arc_m(1.0), 0.0);
    assert_eq!(none.level_octaves(30, 0.25), LevelOctaves::default());
    assert_eq!(none.bounds_near(DVec3::X, 0.1, 5.0), (0.0, 0.0));
}

// ---------------------------------------------------------------------------------------------
// Detail files

fn write(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// A bad detail file is refused with a message that names the file and says what is wrong:
/// the field and its allowed range for a value out of range, the unknown field, the wrong
/// type, the syntax error.
#[test]
fn bad_detail_files_are_refused_with_a_useful_message() {
    let dir = tempfile::tempdir().unwrap();
    let cases: [(&str, &str, &[&str]); 9] = [
        (
            "hurst.json",
            r#"{"hurst": 2}"#,
            &["hurst", "[0.05, 1]", "2"],
        ),
        (
            "lacunarity.json",
            r#"{"lacunarity": 1.0}"#,
            &["lacunarity", "[1.4, 4]"],
        ),
        (
            "floor.json",
            r#"{"floor_m": -1}"#,
            &["floor_m", "[0.001, 1e6]", "-1"],
        ),
        (
            "lever.json",
            r#"{"warp": {"lever_cells": 65}}"#,
            &["warp.lever_cells", "[0, 64]"],
        ),
        (
            "unknown.json",
            r#"{"hurst": 0.5, "hurts": 0.5}"#,
            &["unknown field", "hurts"],
        ),
        (
            "unknown_warp.json",
            r#"{"warp": {"lever": 1}}"#,
            &["unknown field", "lever"],
        ),
        (
            "type.json",
            r#"{"seed": "one"}"#,
            &["invalid type", "string", "u32"],
        ),
        ("malformed.json", "{\"hurst\": 0.5,\n", &["EOF", "line 2"]),
        (
            "negative_seed.json",
            r#"{"seed": -3}"#,
            &["invalid value", "-3"],
        ),
    ];
    for (file, text, wanted) in cases {
        let path = write(dir.path(), file, text);
        let err = DetailParams::load(&path).expect_err(file);
        let message = err.to_string();
        println!("{file}: {message}");
        assert!(
            message.contains(&path.display().to_string()),
            "{file}: the message does not name the file: {message}"
        );
        for w in wanted {
            assert!(message.contains(w), "{file}: no `{w}` in: {message}");
        }
        match (&err, file) {
            (DetailError::Range { field, .. }, "hurst.json") => assert_eq!(*field, "hurst"),
            (DetailError::Range { .. }, _) => assert!(
                ["lacunarity.json", "floor.json", "lever.json"].contains(&file),
                "{file}: a range error for a parse problem"
            ),
            (DetailError::Parse { .. }, _) => assert!(
                !["hurst.json", "lacunarity.json", "floor.json", "lever.json"].contains(&file),
                "{file}: a parse error for a range problem"
            ),
            (e, _) => panic!("{file}: unexpected error {e:?}"),
        }
    }
    // A missing file names itself.
    let missing = dir.path().join("missing.json");
    let message = DetailParams::load(&missing).unwrap_err().to_string();
    assert!(
        message.contains(&missing.display().to_string()),
        "{message}"
    );
}

/// Every field has a default (an empty file is the default detail, a partial `warp` keeps the
/// other warp defaults), and save → load gives back the same parameters.
#[test]
fn detail_files_round_trip_and_default_missing_fields() {
    let dir = tempfile::tempdir().unwrap();
    let empty = write(dir.path(), "empty.json", "{}");
    assert_eq!(DetailParams::load(&empty).unwrap(), DetailParams::default());
    let partial = write(
        dir.path(),
        "partial.json",
        r#"{"warp": {"lever_cells": 2}}"#,
    );
    let loaded = DetailParams::load(&partial).unwrap();
    assert_eq!(loaded.warp.lever_cells, 2.0);
    assert_eq!(loaded.warp.c1, WarpParams::default().c1);

    let params = DetailParams {
        seed: 4_000_000_007,
        hurst: 1.0 / 3.0,
        lacunarity: 2.75,
        floor_m: 0.004,
        octaves_below_data: 2.5,
        amplitude_min_m: 1.25,
        roughness_gain: 0.7,
        amplitude_max_m: 900.0,
        height_roughness: 0.1,
        geometry_cut: 0.3,
        warp: WarpParams {
            c1: [0.1, -0.2],
            c2: [0.3, 0.4],
            c3: [-0.5, 0.6],
            lever_cells: 3.0,
        },
        // The editor's paint round-trips too.
        relief_paint: vec![globe::procedural::ReliefDab {
            lat_deg: 45.5,
            lon_deg: -120.25,
            radius_deg: 2.0,
            factor: 0.5,
        }],
    };
    params.validate("test").unwrap();
    let path = dir.path().join("saved.json");
    params.save(&path).unwrap();
    assert_eq!(DetailParams::load(&path).unwrap(), params);
}

// ---------------------------------------------------------------------------------------------
// Clipmap levels

/// Each clipmap level holds the octaves its points need: over the level and the finer level's
/// blend band (θ̃ from π·2^−i down to π·2^−i·2^−(1+b)) every whole octave (k < full) has
/// weight 1 and every octave with a weight above 0 is held, so the ones with a weight strictly
/// between 0 and 1 lie in [full, full + partial). Four partial octaves (one RGBA texel)
/// suffice wherever λ spans at most 3 over that band, (1 + b)·log_r 2 ≤ 3: for the default
/// blend b = 0.25 at every lacunarity ≥ 1.4, and for every b ≤ 1 from r = 2^(2/3). Where it
/// spans more (r = 1.4 with b ≥ 0.5) the levels that lack an octave are printed, not failed
/// (a known limit of MAX_PARTIAL). Finer levels hold at least the coarser ones' whole octaves
/// and in total at least as many.
#[test]
fn level_octaves_cover_each_level() {
    let variants = [
        ("default", DetailParams::default()),
        (
            "lacunarity 1.4",
            DetailParams {
                lacunarity: 1.4,
                ..DetailParams::default()
            },
        ),
        (
            "lacunarity 4",
            DetailParams {
                lacunarity: 4.0,
                ..DetailParams::default()
            },
        ),
        (
            "32 octaves, κ 4",
            DetailParams {
                lacunarity: 1.5,
                floor_m: 0.001,
                geometry_cut: 4.0,
                ..DetailParams::default()
            },
        ),
        (
            "κ 0.001",
            DetailParams {
                geometry_cut: 0.001,
                ..DetailParams::default()
            },
        ),
    ];
    for (name, params) in variants {
        let r = params.lacunarity;
        let detail = detail_with(params);
        let n = detail.octave_count();
        for blend in [0.1, 0.25, 0.5, 1.0] {
            // λ spans (1 + b)·log_r 2 over a level and its finer neighbour's blend band: four
            // partial octaves hold every fractional weight when that span is at most 3.
            let span = (1.0 + blend) * std::f64::consts::LN_2 / r.ln();
            let fits = span <= 3.0;
            let mut previous: Option<LevelOctaves> = None;
            let mut partial_seen = false;
            // (level, octave, weight) of an octave with weight > 0 that the level lacks.
            let mut dropped: Vec<(u32, usize, f64)> = Vec::new();
            for level in 0..48u32 {
                let o = detail.level_octaves(level, blend);
                let (full, end) = (o.full as usize, (o.full + o.partial) as usize);
                assert!(end <= n && o.partial as usize <= MAX_PARTIAL);
                partial_seen |= o.partial > 0;
                let outer = PI * (-(level as f64)).exp2();
                let inner = outer * (-(1.0 + blend)).exp2();
                for s in 0..=200 {
                    let theta = outer * (inner / outer).powf(s as f64 / 200.0);
                    let lambda = detail.lambda_at_angle(theta);
                    for k in 0..n {
                        let w = Detail::weight(k, lambda);
                        if k < full {
                            assert_eq!(
                                w, 1.0,
                                "{name}, blend {blend}, level {level}: whole octave {k} has \
                                 weight {w} at θ̃ {theta} (λ {lambda}, {o:?})"
                            );
                        }
                        if w > 0.0 && k >= end {
                            assert!(
                                !fits,
                                "{name}, blend {blend}, level {level}: octave {k} (weight \
                                 {w} at θ̃ {theta}, λ {lambda}) is not held: {o:?}"
                            );
                            match dropped.iter_mut().find(|d| d.0 == level && d.1 == k) {
                                Some(d) => d.2 = d.2.max(w),
                                None => dropped.push((level, k, w)),
                            }
                        }
                    }
                }
                if let Some(p) = previous {
                    assert!(
                        o.full >= p.full && o.full + o.partial >= p.full + p.partial,
                        "{name}, blend {blend}: level {level} {o:?} after {p:?}"
                    );
                }
                previous = Some(o);
            }
            assert!(
                partial_seen,
                "{name}, blend {blend}: no level has partial octaves"
            );
            if !dropped.is_empty() {
                // A known limit (MAX_PARTIAL = 4), reported rather than asserted.
                let worst = dropped.iter().map(|d| d.2).fold(0.0, f64::max);
                println!(
                    "level_octaves {name}, blend {blend} (λ span {span:.2} per level): {} \
                     (level, octave) pairs not held, weight up to {worst:.3}, first {:?}",
                    dropped.len(),
                    dropped.first().unwrap()
                );
            }
        }
    }
}
