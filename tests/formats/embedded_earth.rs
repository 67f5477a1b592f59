//! The embedded Earth (ETOPO5 decimated to 10′) has the known places where they are, at its
//! resolution: 10′ is 18.5 km, so narrow features (Lake Garda, the Dead Sea) are averaged with
//! their surroundings; each check says what 10′ can show.

use globe::dem::embedded::EmbeddedEarth;
use globe::dem::{GeoGrid, RasterSource};

/// Min and max of the pixels whose centres lie in the box.
fn min_max(earth: &EmbeddedEarth, lat: (f64, f64), lon: (f64, f64)) -> (f32, f32) {
    let g: GeoGrid = earth.grid();
    let mut row = vec![0.0; g.cols];
    let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
    for r in 0..g.rows {
        let la = g.lat_of_row(r as f64);
        if la < lat.0 || la > lat.1 {
            continue;
        }
        earth.read_row(r, &mut row).unwrap();
        for (c, v) in row.iter().enumerate() {
            let lo_c = g.lon_of_col(c as f64);
            if lo_c >= lon.0 && lo_c <= lon.1 {
                lo = lo.min(*v);
                hi = hi.max(*v);
            }
        }
    }
    (lo, hi)
}

#[test]
fn known_places_at_the_embedded_resolution() {
    let earth = EmbeddedEarth::load().unwrap();
    let everest = min_max(&earth, (27.5, 28.5), (86.4, 87.4));
    let dead_sea = min_max(&earth, (31.2, 31.9), (35.3, 35.7));
    let garda = min_max(&earth, (45.45, 45.85), (10.45, 10.85));
    let alps = min_max(&earth, (46.0, 47.0), (10.0, 11.0));
    let po_plain = min_max(&earth, (45.0, 45.3), (10.0, 11.0));
    let mariana = min_max(&earth, (10.8, 11.9), (141.7, 142.7));
    eprintln!(
        "Everest box max {} m; Dead Sea box min {} m; Garda box min {} m; Alps max {} m; Po plain max {} m; Mariana min {} m",
        everest.1, dead_sea.0, garda.0, alps.1, po_plain.1, mariana.0
    );
    // ETOPO5's Himalaya is 1000-ft contours; its max near Everest is 6552 m, decimated here.
    assert!(everest.1 > 5000.0, "Everest box max {}", everest.1);
    // The Dead Sea's −430 m surface is one ETOPO5 node wide: at 10′ its pixel stays below sea level.
    assert!(dead_sea.0 < 0.0, "Dead Sea box min {}", dead_sea.0);
    // Garda (65 m surface, 3–17 km wide) averages with its shores but stays lowland, with the
    // Alps high to its north and the Po plain low to its south.
    assert!(garda.0 < 300.0, "Garda box min {}", garda.0);
    assert!(alps.1 > 2000.0, "Alps max {}", alps.1);
    assert!(po_plain.1 < 200.0, "Po plain max {}", po_plain.1);
    // Bathymetry is included: the Mariana trench is deep.
    assert!(mariana.0 < -8000.0, "Mariana min {}", mariana.0);
}

/// A culling-bounds query near a pole spans every longitude; `bounds_level_at` coarsens it
/// until it reads at most `MAX_BOUNDS_PIXELS` pixels (it read all 2160 columns of the finest
/// level for every drawn level: 8 ms of CPU a frame at `north-pole`). The coarser bounds still
/// hold the finer ones, and away from the poles nothing changes.
#[test]
fn culling_bounds_near_a_pole_read_a_bounded_number_of_pixels() {
    use globe::geo::sphere;
    use globe::terrain::Terrain;
    use globe::terrain::dem::MAX_BOUNDS_PIXELS;
    let terrain = Terrain::embedded_earth().unwrap();
    let dem = terrain.dem().unwrap();
    let pyramid = dem.pyramid();
    let code = |l, p, r, c| pyramid.pixel_code(l, p, r, c);
    let mut coarsened = 0;
    for (lat, lon) in [
        (90.0, 0.0),
        (-90.0, 0.0),
        (89.99, 30.0),
        (-89.9, -170.0),
        (45.65, 10.65),
    ] {
        let (phi, theta) = sphere::phi_theta_from_lat_lon_deg(lat, lon);
        let u = sphere::unit_vector(phi, theta);
        for angle in [1e-7, 1e-5, 1e-3, 1e-2, 0.1] {
            let level = dem.bounds_level_at(u, angle);
            let fine = dem.bounds_level(angle);
            assert!(level >= fine);
            if lat.abs() < 80.0 {
                assert_eq!(level, fine, "{lat}°: a cap of {angle} rad was coarsened");
            }
            let g = pyramid.grid(level);
            if level + 1 < pyramid.level_count() && lat.abs() + angle.to_degrees() >= 90.0 {
                // A cap over the pole reads every column of its rows: those stay bounded.
                let rows = 2.0 * angle.to_degrees() / g.dlat_deg + 3.0;
                assert!(
                    rows * (g.cols as f64 + 3.0) <= MAX_BOUNDS_PIXELS,
                    "{lat}°, {angle} rad: level {level} has {} columns",
                    g.cols
                );
            }
            let coarse = dem
                .height_bounds_near_m_at_level_with(u, angle, level, &code)
                .unwrap();
            let finest = dem
                .height_bounds_near_m_at_level_with(u, angle, fine, &code)
                .unwrap();
            assert!(
                coarse.0 <= finest.0 && coarse.1 >= finest.1,
                "{lat}°, {angle} rad: level {level} bounds {coarse:?} do not hold level {fine}'s {finest:?}"
            );
            coarsened += usize::from(level > fine);
        }
    }
    assert!(coarsened > 0, "no polar cap was coarsened");
}
