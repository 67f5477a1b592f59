use globe::geo::map_transform::{exact_f64, p_tilde};
use globe::geo::sphere::wrap_angle_rad;
use std::f64::consts::PI;
#[test]
fn probe() {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../shared/data/map_transform_vectors.csv"
    ))
    .unwrap();
    let mut n = 0;
    let mut fails = 0;
    let mut worst = 0.0f64;
    for line in text.lines().filter(|l| !l.starts_with('#')).skip(1) {
        let f: Vec<f64> = line.split(',').map(|s| s.parse().unwrap()).collect();
        let (tv, tt, pt, th, dth, dph) = (f[1], f[3], f[4], f[5], f[7], f[8]);
        let (dp, dt) = exact_f64(tv, p_tilde(pt, tt));
        let et = (dt - dth).abs() * 6371000.0;
        let ep = if th == 0.0 || th == PI {
            0.0
        } else {
            wrap_angle_rad(dp - dph).abs() * th.sin() * 6371000.0
        };
        n += 1;
        let e = et.max(ep);
        if e > 1e-9 {
            fails += 1;
            println!(
                "case {} tv {tv:e} tt {tt:e} pt {pt} dth {dth} err_t {et:e} ({:.2} ulp) err_p {ep:e}",
                f[0],
                (dt - dth).abs() / (dth.abs() * f64::EPSILON).max(1e-300)
            );
        }
        worst = worst.max(e);
    }
    println!("n {n} fails {fails} worst {worst:e}");
}
