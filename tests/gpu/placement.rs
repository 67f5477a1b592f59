//! The vertex pre-pass (`render::placement`): the clipmap's vertices placed once per frame by a
//! compute pass and read by the draws as their vertex buffer. It must draw what the vertex
//! stage drew when it placed the vertices itself, in every scene, with the look, the detail and
//! a planar mode's cut, over a pole and across the antimeridian, and place each vertex a frame
//! uses once.

use crate::common;

use globe::plan::{LodMode, LodSettings};
use globe::render::offscreen::OffscreenFrame;
use globe::scenes::Scene;

const WIDTH_PX: u32 = 320;
const HEIGHT_PX: u32 = 180;

/// Pixels that differ, and the largest difference of a channel (in 1/255).
fn compare(a: &[u8], b: &[u8]) -> (usize, u8) {
    let mut differing = 0;
    let mut largest = 0;
    for (p, q) in a.chunks(4).zip(b.chunks(4)) {
        if p != q {
            differing += 1;
            for (x, y) in p.iter().zip(q) {
                largest = largest.max(x.abs_diff(*y));
            }
        }
    }
    (differing, largest)
}

#[test]
fn the_pre_pass_draws_what_the_vertex_stage_drew() {
    let Some((ctx, _guard)) = common::gpu() else {
        return;
    };
    let geomip = LodSettings {
        mode: LodMode::Geomip,
        ..Default::default()
    };
    let mut reused = 0;
    let mut turned_compared = 0;
    let mut settled_compared = 0;
    for (scene, detail, lod) in [
        ("space", true, None),
        ("aircraft", true, None),
        ("ground", true, None),
        ("ground", false, None),
        // The stiff cases: seam vertices carry their side of the ±π cut (§4.4).
        ("north-pole", true, None),
        ("antimeridian", true, None),
        // A planar mode: the clipmap's draws leave its square out (plane coordinates).
        ("ground", true, Some(geomip)),
    ] {
        // One renderer drawn both ways, so that both draw the same plan (two renderers may
        // settle on different levels where their streams differ).
        let mut r = common::full_look_renderer(ctx, detail);
        if let Some(lod) = lod {
            r.set_lod(&ctx.device, lod);
        }
        let camera = Scene::by_name(scene)
            .unwrap()
            .camera(|lat, lon| r.terrain_height_m(lat, lon));
        let mut turned = camera;
        turned.heading_deg += 0.05;
        turned.altitude_m *= 1.001;
        let target = OffscreenFrame::new(&ctx.device, WIDTH_PX, HEIGHT_PX);
        // The settled view with the pre-pass, then again with the vertex stage placing: the
        // same state at rest, so the same plan.
        let a = common::render(ctx, &mut r, &camera, WIDTH_PX, HEIGHT_PX);
        let vertices = r.vertices_placed();
        r.set_place_in_vertex_stage(true);
        let b = common::render(ctx, &mut r, &camera, WIDTH_PX, HEIGHT_PX);
        assert_eq!(
            r.vertices_placed(),
            0,
            "{scene}: the vertex stage placed them"
        );
        // Settled twice at rest, the two frames plan the same (once they did not at
        // `north-pole`: see streaming.rs, `a_settled_view_draws_what_the_next_frame_at_rest_draws`).
        assert_eq!(
            a.info.draw, b.info.draw,
            "{scene}: settled twice, planned differently"
        );
        settled_compared += 1;
        if lod.is_some() {
            let d = &a.info.draw;
            assert!(d.first_cut < d.ranges.len(), "{scene}: no range is cut");
        }
        let (differing, largest) = compare(&a.rgba, &b.rgba);
        println!(
            "{scene} (detail {detail}, lod {:?}): {vertices} vertices placed for {} triangles; \
             {differing} pixels differ, by at most {largest}/255",
            lod.map(|l| l.mode),
            a.info.triangles()
        );
        // Each vertex once: far fewer than the three corners of every triangle.
        assert!(
            vertices > 0 && vertices < a.info.draw.triangles,
            "{scene}: {vertices} vertices placed for {} triangles",
            a.info.draw.triangles
        );
        assert_eq!(differing, 0, "{scene}: pixels the pre-pass changed");

        // The first frame after a small turn, from the settled view, both ways. With the
        // pre-pass it mostly draws the same ranges, so it reuses its work lists and must still
        // place every vertex anew. Where a level's tiles are still on their way after the
        // move (near the pole), the two frames may plan differently: compared only when not.
        r.set_place_in_vertex_stage(false);
        common::render(ctx, &mut r, &camera, WIDTH_PX, HEIGHT_PX);
        let a_turned = target.render_now(ctx, &mut r, &turned).unwrap();
        let reused_here = r.placement_lists_reused();
        common::render(ctx, &mut r, &camera, WIDTH_PX, HEIGHT_PX);
        r.set_place_in_vertex_stage(true);
        let b_turned = target.render_now(ctx, &mut r, &turned).unwrap();
        if a_turned.info.draw != b_turned.info.draw {
            println!("{scene}, turned: the two frames planned differently; not compared");
            continue;
        }
        turned_compared += 1;
        reused += reused_here as u32;
        assert_eq!(
            compare(&a_turned.rgba, &b_turned.rgba),
            (0, 0),
            "{scene}, turned: pixels the pre-pass changed"
        );
    }
    println!(
        "{settled_compared} of 7 settled views and {turned_compared} turned frames compared, \
         {reused} of those with reused work lists"
    );
    assert!(
        turned_compared >= 5,
        "only {turned_compared} turned frames compared"
    );
    assert!(reused > 0, "no compared turned frame reused its work lists");
}
