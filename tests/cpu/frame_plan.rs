//! The frame plan (`globe::plan`) built without a GPU: what a frame draws, fills and waits for,
//! decided in f64 from the camera and the level textures' current windows alone.

use globe::clipmap::draw_list::SectorBounds;
use globe::clipmap::levels::LevelGrid;
use globe::clipmap::selection::LevelStatus;
use globe::clipmap::{ClipmapSettings, RingMesh};
use globe::geo::camera::Camera;
use globe::plan::{ClipmapPlan, HeightSource, TerrainQuery, ViewPlan};
use globe::scenes::Scene;
use globe::terrain::Terrain;

const WIDTH: u32 = 960;
const HEIGHT: u32 = 540;

fn scene_camera(terrain: &Terrain, name: &str) -> Camera {
    Scene::by_name(name)
        .expect("named scene")
        .camera(|lat, lon| terrain.height_at_lat_lon_m(lat, lon))
}

fn plan(
    terrain: &Terrain,
    settings: &ClipmapSettings,
    camera: &Camera,
    held: &[Option<LevelGrid>],
) -> (ViewPlan, ClipmapPlan) {
    let view = ViewPlan::new(camera, WIDTH, HEIGHT, terrain);
    let clipmap = ClipmapPlan::new(&view, settings, held, terrain.height_range_m(), false, true);
    (view, clipmap)
}

/// What the level textures hold after every fill of `clipmap` ran.
fn fill_all(held: &mut [Option<LevelGrid>], clipmap: &ClipmapPlan) {
    for f in &clipmap.fills {
        held[f.grid.level as usize] = Some(f.grid);
    }
}

#[test]
fn the_view_knows_the_ground_and_its_source() {
    let terrain = Terrain::analytic_earth();
    let camera = scene_camera(&terrain, "ground");
    let view = ViewPlan::new(&camera, WIDTH, HEIGHT, &terrain);
    assert_eq!(view.ground_source, HeightSource::Exact);
    assert!((view.height_above_terrain_m - 2.0).abs() < 1e-9);
    assert!(view.near_m > 0.0 && view.near_m < 2.0);
    assert!((0.0..std::f64::consts::TAU).contains(&view.phi_v_rad));
    assert!((view.sun_view.length() - 1.0).abs() < 1e-12);
    assert!(view.sun_view.z > 0.0, "the sun is above the horizon");
    // Near the ground the sky is blue; from space it is black.
    assert!(view.sky_linear[2] > 0.5);
    let space = ViewPlan::new(&scene_camera(&terrain, "space"), WIDTH, HEIGHT, &terrain);
    assert!(space.sky_linear.iter().all(|c| *c < 0.01));
}

#[test]
fn a_first_frame_fills_every_wanted_level_and_a_still_camera_fills_nothing() {
    let terrain = Terrain::analytic_earth();
    let settings = ClipmapSettings::default();
    let s = settings.texture_size as u64;
    for name in ["space", "aircraft", "ground", "north-pole", "antimeridian"] {
        let camera = scene_camera(&terrain, name);
        let mut held = vec![None; settings.levels as usize];
        let (_, first) = plan(&terrain, &settings, &camera, &held);
        let sel = &first.selection;
        // The drawn levels and the one their outer rings blend into, coarse to fine.
        let levels: Vec<u32> = first.fills.iter().map(|f| f.grid.level).collect();
        let expected: Vec<u32> = (sel.coarsest.saturating_sub(1)..=sel.finest).collect();
        assert_eq!(levels, expected, "{name}");
        assert_eq!(
            first.texels_to_fill(),
            s * s * first.fills.len() as u64,
            "{name}: a never-filled texture is filled whole"
        );
        fill_all(&mut held, &first);
        let (_, again) = plan(&terrain, &settings, &camera, &held);
        assert_eq!(again.texels_to_fill(), 0, "{name}");
        assert_eq!(again.selection, first.selection, "{name}");
    }
}

#[test]
fn a_small_move_refills_strips_only() {
    let terrain = Terrain::analytic_earth();
    let settings = ClipmapSettings::default();
    let mut camera = scene_camera(&terrain, "aircraft");
    let mut held = vec![None; settings.levels as usize];
    let (_, first) = plan(&terrain, &settings, &camera, &held);
    fill_all(&mut held, &first);
    // Three texels of the finest level east: each level shifts by a few texels at most.
    let finest = first.fills.last().expect("fills").grid;
    camera.lon_deg += (3.0 * finest.dphi_rad).to_degrees();
    let (_, moved) = plan(&terrain, &settings, &camera, &held);
    let s = settings.texture_size as u64;
    assert!(moved.texels_to_fill() > 0);
    for f in &moved.fills {
        assert!(
            f.texels() <= 4 * s,
            "level {}: strips of a few columns, not {} texels",
            f.grid.level,
            f.texels()
        );
    }
    let coarsest = &moved.fills[0];
    assert!(
        coarsest.rects.is_empty(),
        "level {} moved",
        coarsest.grid.level
    );
}

#[test]
fn levels_wait_until_they_and_every_coarser_one_hold_their_window() {
    let terrain = Terrain::analytic_earth();
    let settings = ClipmapSettings::default();
    let camera = scene_camera(&terrain, "aircraft");
    let empty = vec![None; settings.levels as usize];

    // Nothing arrived: nothing is drawn, every wanted level waits.
    let (_, mut nothing) = plan(&terrain, &settings, &camera, &empty);
    let wanted: Vec<u32> = nothing.selection.drawn_levels().collect();
    nothing.limit_to_held(&empty);
    assert!(!nothing.selection.any_drawn());
    assert_eq!(nothing.waiting(), wanted);

    // The blend level and the three coarsest drawn levels arrived, then a gap: the gap and
    // everything finer wait even where a finer level arrived.
    let (_, mut partial) = plan(&terrain, &settings, &camera, &empty);
    let mut held = empty.clone();
    for f in partial.fills.iter().take(4) {
        held[f.grid.level as usize] = Some(f.grid);
    }
    let last = partial.fills.last().expect("fills").grid;
    held[last.level as usize] = Some(last);
    partial.limit_to_held(&held);
    let c = partial.selection.coarsest;
    assert_eq!(partial.selection.finest, c + 2);
    assert_eq!(partial.waiting(), (c + 3..=last.level).collect::<Vec<_>>());
    assert_eq!(
        partial.selection.status[last.level as usize],
        LevelStatus::Waiting
    );

    // A window from an earlier position does not count as held.
    let mut stale = held.clone();
    let g = partial.fills[1].grid;
    stale[g.level as usize] = Some(LevelGrid {
        gx0: g.gx0 + 1,
        ..g
    });
    let (_, mut with_stale) = plan(&terrain, &settings, &camera, &empty);
    with_stale.limit_to_held(&stale);
    assert!(!with_stale.selection.any_drawn());
}

#[test]
fn culling_keeps_what_the_camera_sees_and_counts_the_rest() {
    let terrain = Terrain::analytic_earth();
    let settings = ClipmapSettings::default();
    let mesh = RingMesh::build(&settings);
    let bounds = SectorBounds::new(&mesh);
    for (name, expect_culled) in [("space", false), ("aircraft", true), ("ground", true)] {
        let camera = scene_camera(&terrain, name);
        let mut held = vec![None; settings.levels as usize];
        let (view, mut clipmap) = plan(&terrain, &settings, &camera, &held);
        fill_all(&mut held, &clipmap);
        clipmap.limit_to_held(&held);
        clipmap.cull(&view, &settings, &mesh, &bounds, &terrain, false);
        let levels = clipmap.selection.drawn_levels().len() as u32;
        let d = &clipmap.draw;
        // Every sector of every drawn level, and the finest level's cap, is drawn or culled.
        assert_eq!(
            d.sectors_drawn + d.sectors_culled,
            (levels + 1) * settings.sectors,
            "{name}"
        );
        assert!(d.sectors_drawn > 0 && d.triangles > 0, "{name}");
        assert_eq!(d.sectors_culled > 0, expect_culled, "{name}: {d:?}");
        // Without the frustum nothing is culled and more is drawn.
        let mut all = clipmap.clone();
        all.cull(&view, &settings, &mesh, &bounds, &terrain, true);
        assert_eq!(all.draw.sectors_culled, 0);
        assert!(all.draw.triangles >= d.triangles);
    }
}

#[test]
fn the_approximation_is_off_near_the_poles() {
    let terrain = Terrain::analytic_earth();
    let settings = ClipmapSettings::default();
    let empty = vec![None; settings.levels as usize];
    let pole = scene_camera(&terrain, "north-pole");
    let (_, at_pole) = plan(&terrain, &settings, &pole, &empty);
    assert_eq!(at_pole.approx_start_level, None);
    let garda = scene_camera(&terrain, "aircraft");
    let (_, mid) = plan(&terrain, &settings, &garda, &empty);
    assert_eq!(mid.approx_start_level, Some(settings.approx_start_level));
}

/// A terrain query that answers from coarser tiles: the plan carries the source through.
struct Coarse<'a>(&'a Terrain);

impl TerrainQuery for Coarse<'_> {
    fn radius_m(&self) -> f64 {
        self.0.radius_m()
    }
    fn height_range_m(&self) -> (f64, f64) {
        self.0.height_range_m()
    }
    fn ground_m(&self, lat_deg: f64, lon_deg: f64) -> (f64, HeightSource) {
        (
            self.0.height_at_lat_lon_m(lat_deg, lon_deg) + 50.0,
            HeightSource::CoarserTiles,
        )
    }
    fn height_bounds_near_m(&self, u: glam::DVec3, angle_rad: f64) -> (f64, f64) {
        self.0.height_bounds_near_m(u, angle_rad)
    }
    fn height_drawn_m(&self, u: glam::DVec3, arc_rad: f64) -> f64 {
        TerrainQuery::height_drawn_m(self.0, u, arc_rad) + 50.0
    }
}

#[test]
fn a_stand_in_ground_height_is_marked_as_such() {
    let terrain = Terrain::analytic_earth();
    let camera = scene_camera(&terrain, "aircraft");
    let exact = ViewPlan::new(&camera, WIDTH, HEIGHT, &terrain);
    let coarse = ViewPlan::new(&camera, WIDTH, HEIGHT, &Coarse(&terrain));
    assert_eq!(coarse.ground_source, HeightSource::CoarserTiles);
    assert!((exact.height_above_terrain_m - coarse.height_above_terrain_m - 50.0).abs() < 1e-6);
}
