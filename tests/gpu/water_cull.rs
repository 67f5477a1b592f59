//! The water cull (`render::water_cull`): draws of levels whose texels all lie above the water
//! level go to the pipeline without the water's shading. It must change no pixel, decide each
//! draw from the texels the fragments read (its Rust twin over the read-back textures), and
//! actually leave the water out where none can show.

use crate::common;

use globe::look::SEA_LEVEL_M;
use globe::render::TerrainRenderer;
use globe::render::water_cull;
use globe::scenes::Scene;

const WIDTH_PX: u32 = 320;
const HEIGHT_PX: u32 = 180;

fn renderer(ctx: &globe::render::GpuContext, detail: bool) -> TerrainRenderer {
    common::full_look_renderer(ctx, detail)
}

#[test]
fn the_cull_changes_no_pixel_and_follows_the_texels() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    for (scene, detail, expect_dry, expect_wet) in [
        // Over the Alps the levels near the viewer hold no water; their coarser ones the sea.
        ("aircraft", true, true, true),
        ("ground", true, true, true),
        // The whole Earth: every drawn level holds sea.
        ("space", true, false, true),
    ] {
        let mut with_cull = renderer(ctx, detail);
        let camera = Scene::by_name(scene)
            .unwrap()
            .camera(|lat, lon| with_cull.terrain_height_m(lat, lon));
        let culled = common::render(ctx, &mut with_cull, &camera, WIDTH_PX, HEIGHT_PX);
        let dry = with_cull.read_dry_draws(ctx).unwrap().expect("water is on");
        let levels = &culled.info.draw.levels;
        assert_eq!(dry.len(), levels.len(), "{scene}: one choice per range");

        // The GPU's choice is the Rust twin's over the read-back normal textures.
        let boxes = with_cull.water_cull_boxes().unwrap().to_vec();
        let lowest = |l: u32, b: [u32; 4]| {
            with_cull
                .read_level_lowest_m(ctx, l, b)
                .unwrap()
                .unwrap_or(f32::NEG_INFINITY)
        };
        let top = levels.iter().copied().max().unwrap_or(0);
        let own: Vec<f32> = (0..=top)
            .map(|l| lowest(l, boxes[2 * l as usize]))
            .collect();
        let coarse: Vec<f32> = (0..=top)
            .map(|l| match l {
                0 => f32::NEG_INFINITY,
                _ => lowest(l - 1, boxes[2 * l as usize + 1]),
            })
            .collect();
        let variants = &culled.info.draw.variants;
        for (i, ((&l, &d), &v)) in levels.iter().zip(&dry).zip(variants).enumerate() {
            let blends = v != globe::clipmap::draw_list::Variant::Plain;
            let (o, c) = (own[l as usize], coarse[l as usize]);
            assert_eq!(
                d,
                water_cull::dry(o, c, l, blends, SEA_LEVEL_M as f32),
                "{scene}: range {i} of level {l} (lowest texels within reach {o}, coarser {c})"
            );
        }
        let drawn: Vec<(u32, bool)> = culled
            .info
            .draw
            .ranges
            .iter()
            .zip(levels.iter().zip(&dry))
            .filter(|(r, _)| !r.is_empty())
            .map(|(_, (&l, &d))| (l, d))
            .collect();
        let dry_levels: Vec<u32> = drawn.iter().filter(|d| d.1).map(|d| d.0).collect();
        println!(
            "{scene}: {} of {} draws dry (levels {:?}); lowest texel within reach per level {:?}",
            dry_levels.len(),
            drawn.len(),
            dry_levels,
            own
        );
        assert_eq!(dry_levels.is_empty(), !expect_dry, "{scene}: dry draws");
        assert_eq!(
            drawn.iter().any(|d| !d.1),
            expect_wet,
            "{scene}: draws with the water's code"
        );

        // The same frame drawn with the water's shading everywhere: not one byte differs.
        let mut without = renderer(ctx, detail);
        without.switches.ignore_water_cull = true;
        let plain = common::render(ctx, &mut without, &camera, WIDTH_PX, HEIGHT_PX);
        let differing = culled
            .rgba
            .chunks(4)
            .zip(plain.rgba.chunks(4))
            .filter(|(a, b)| a != b)
            .count();
        assert_eq!(differing, 0, "{scene}: pixels the cull changed");
    }
}

#[test]
fn a_block_list_covers_each_written_texel_once() {
    use globe::render::normals::SlotRect;
    let s = 64;
    let rect = |layer, x0, y0, width, height| SlotRect {
        layer,
        x0,
        y0,
        width,
        height,
    };
    // A rectangle across the texture's last column and row wraps into the first blocks.
    let blocks = water_cull::touched_blocks(&[rect(2, 60, 50, 10, 20)], s);
    let per_row = s / water_cull::BLOCK;
    let mut expected: Vec<u32> = [3u32, 0]
        .iter()
        .flat_map(|&by| [3u32, 0].map(move |bx| 2 << 16 | (by * per_row + bx)))
        .collect();
    let mut got = blocks.clone();
    expected.sort();
    got.sort();
    assert_eq!(got, expected);
    // Overlapping rectangles name a block once; a whole-width one names every column.
    let blocks = water_cull::touched_blocks(&[rect(0, 5, 0, 64, 1), rect(0, 0, 0, 16, 16)], s);
    assert_eq!(blocks.len(), per_row as usize);
    // Nothing written, nothing to redo.
    assert!(water_cull::touched_blocks(&[rect(1, 3, 3, 0, 5)], s).is_empty());
}
