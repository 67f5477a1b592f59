//! Tiles PNGs of one size into one image: `strip OUT.png COLUMNS IN.png…` (docs/look.md#the-look:
//! the flight strip and the before/after sheets).
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let out = &args[1];
    let cols: u32 = args[2].parse().unwrap();
    let imgs: Vec<image::RgbaImage> = args[3..]
        .iter()
        .map(|p| image::open(p).unwrap().into_rgba8())
        .collect();
    let (w, h) = imgs[0].dimensions();
    let rows = (imgs.len() as u32).div_ceil(cols);
    let mut canvas = image::RgbaImage::new(w * cols, h * rows);
    for (i, im) in imgs.iter().enumerate() {
        image::imageops::overlay(
            &mut canvas,
            im,
            ((i as u32 % cols) * w) as i64,
            ((i as u32 / cols) * h) as i64,
        );
    }
    canvas.save(out).unwrap();
}
