//! Prints the `flight` path's camera at 8 evenly spaced times (space → the ground at Garda) in
//! the form `globe render --camera=…` takes, over the embedded Earth (docs/look.md#the-look: the
//! flight strip).
fn main() {
    let t = globe::terrain::Terrain::embedded_earth().unwrap();
    for i in 0..8 {
        let f = i as f64 / 7.0;
        let c = globe::scenes::flight::camera(f, |a, b| t.height_at_lat_lon_m(a, b));
        println!(
            "{},{},{}@sphere,{},{}",
            c.lat_deg, c.lon_deg, c.altitude_m, c.heading_deg, c.pitch_deg
        );
    }
}
