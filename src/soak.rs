//! `globe bench --scene soak`: a long seeded random flight under failing, slow reads, watched
//! for what a short test cannot see — memory that creeps, a frame that blocks on the file, a
//! tile lost or wrong after hundreds of evictions and retries.
//!
//! The path ([`SoakPath`]) is drawn from a seed: legs between waypoints in space, at aircraft
//! height, a few metres above the ground, at and around both poles and across the
//! antimeridian; most legs fly (great circle, height eased in log space with a climb that
//! keeps the camera above the ground it crosses), some jump and hold there, turning. Time on
//! the path is the soak's own clock, which runs only while frames are drawn.
//!
//! At the end of every leg the flight stops at a **settle point**: the renderer (with its
//! faults) waits until the view is complete, and its frame is compared with a second renderer
//! that reads the same file without faults and waits for everything: they must be equal
//! (0 px differ). Every frame records the process's memory (anonymous RSS, from
//! `/proc/self/status`), the decoded-tile cache's bytes, the GPU tiles resident, and the file
//! reads made while the frame was prepared (`dem::frame_reads`: a frame must make none).
//!
//! The findings ([`SoakFindings`]) hold the budgets: the decoded-tile cache within
//! `--cache-mb`, GPU tiles within `--gpu-tiles`, and anonymous RSS over the second half of the
//! soak within its most over the first half plus the cache's budget plus a slack: memory may
//! grow while new kinds of views still compile pipelines (a software GPU keeps their code in
//! anonymous memory), then it must stop growing. File-backed RSS is reported but not held to
//! a budget: the kernel maps the pyramid's pages in as they are read and drops them under
//! pressure.

use std::path::Path;
use std::time::{Duration, Instant};

use glam::DVec3;
use serde::Serialize;

use crate::bench::{BenchError, pixels_differing};
use crate::clipmap::ClipmapSettings;
use crate::dem::frame_reads;
use crate::geo::camera::Camera;
use crate::look::LookSettings;
use crate::measure::MeasureError;
use crate::render::offscreen::{COLOR_FORMAT, OffscreenFrame, RenderedFrame};
use crate::render::{GpuContext, TerrainRenderer};
use crate::scenes::SCENE_FOV_Y_DEG;
use crate::stream::{FaultSettings, StreamSettings};
use crate::terrain::Terrain;

/// The `globe bench --scene` name of the soak.
pub const NAME: &str = "soak";
/// What the soak injects unless told otherwise: one read in twenty fails, and each read
/// waits 0–200 ms (drawn per read).
pub const DEFAULT_FAIL_RATE: f64 = 0.05;
pub const DEFAULT_LATENCY_MS: (u64, u64) = (0, 200);
/// Anonymous memory allowed beyond the first settle point's and the cache's budget.
pub const DEFAULT_RSS_SLACK_BYTES: u64 = 96 << 20;

/// Where a waypoint is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Place {
    /// 1 000–30 000 km up, looking down.
    Space,
    /// 300 m – 20 km above the ground, looking ahead and down.
    Aircraft,
    /// 1–100 m above the ground, looking at the horizon.
    Ground,
    /// Within 8° of a pole (a fifth of them on it), 10 m – 2 000 km up.
    Pole,
    /// Within 0.5° of the antimeridian, heading across it.
    Antimeridian,
}

impl Place {
    pub const ALL: [Place; 5] = [
        Place::Space,
        Place::Aircraft,
        Place::Ground,
        Place::Pole,
        Place::Antimeridian,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Place::Space => "space",
            Place::Aircraft => "aircraft",
            Place::Ground => "ground",
            Place::Pole => "pole",
            Place::Antimeridian => "antimeridian",
        }
    }
}

/// A view on the path: where, how high above the ground, which way.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Waypoint {
    pub place: Place,
    pub lat_deg: f64,
    pub lon_deg: f64,
    pub above_ground_m: f64,
    pub heading_deg: f64,
    pub pitch_deg: f64,
}

/// How long legs take on the soak's clock (seconds, drawn uniformly in each range).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LegSeconds {
    pub fly: (f64, f64),
    /// A jump's hold at its destination.
    pub hold: (f64, f64),
    /// Fraction of legs (after the first few) that jump.
    pub jump_fraction: f64,
}

impl Default for LegSeconds {
    fn default() -> Self {
        Self {
            fly: (8.0, 20.0),
            hold: (3.0, 6.0),
            jump_fraction: 0.25,
        }
    }
}

/// One leg of the path.
#[derive(Clone, Debug)]
pub struct Leg {
    pub from: Waypoint,
    pub to: Waypoint,
    /// Arrives at `to` at once and holds there, turning 30°.
    pub jump: bool,
    pub start_s: f64,
    pub seconds: f64,
    /// Great-circle length, metres.
    pub distance_m: f64,
    /// Terrain heights at `GROUND_SAMPLES + 1` even steps along the track (fly legs), or at
    /// `to` alone (jumps): read once when the path is made, so no frame reads the file.
    ground_m: Vec<f64>,
}

/// Terrain samples along a fly leg.
const GROUND_SAMPLES: usize = 64;
/// The climb over a fly leg's middle, as a fraction of its length: with the eased progress
/// the camera rises at least ~2 m per metre flown near either end, steeper than any terrain
/// at the data's resolution, so it stays above the ground between the samples.
const CLIMB: f64 = 0.7;

impl Leg {
    pub fn end_s(&self) -> f64 {
        self.start_s + self.seconds
    }

    /// The camera at `u` ∈ [0, 1] of the leg.
    pub fn camera_at(&self, u: f64) -> Camera {
        let u = u.clamp(0.0, 1.0);
        let camera =
            |lat_deg: f64, lon_deg: f64, altitude_m: f64, heading: f64, pitch: f64| Camera {
                lat_deg,
                lon_deg,
                altitude_m,
                heading_deg: heading.rem_euclid(360.0),
                pitch_deg: pitch,
                roll_deg: 0.0,
                fov_y_deg: SCENE_FOV_Y_DEG,
            };
        let to = &self.to;
        let to_ground = *self.ground_m.last().expect("a leg has ground samples");
        if self.jump {
            return camera(
                to.lat_deg,
                to.lon_deg,
                to_ground + to.above_ground_m,
                to.heading_deg + 30.0 * u,
                to.pitch_deg,
            );
        }
        let from = &self.from;
        if u >= 1.0 {
            return camera(
                to.lat_deg,
                to.lon_deg,
                to_ground + to.above_ground_m,
                to.heading_deg,
                to.pitch_deg,
            );
        }
        let s = u * u * (3.0 - 2.0 * u);
        let (a, b) = (
            unit(from.lat_deg, from.lon_deg),
            unit(to.lat_deg, to.lon_deg),
        );
        let (lat, lon) = if u <= 0.0 {
            (from.lat_deg, from.lon_deg)
        } else {
            let d = slerp(a, b, s);
            let lat = d.z.clamp(-1.0, 1.0).asin().to_degrees();
            // On a pole the longitude is the destination's (any would do; this one is steady).
            let lon = if d.x.hypot(d.y) < 1e-12 {
                to.lon_deg
            } else {
                d.y.atan2(d.x).to_degrees()
            };
            (lat, lon)
        };
        // Between samples, the upper envelope (each sample's max with its neighbours,
        // interpolated): continuous, and above both samples around the camera. The ends keep
        // their own samples, so a leg ends exactly at its waypoint.
        let x = s * GROUND_SAMPLES as f64;
        let k = (x.floor() as usize).min(GROUND_SAMPLES - 1);
        let g = &self.ground_m;
        let envelope = |i: usize| {
            if i == 0 || i == GROUND_SAMPLES {
                g[i]
            } else {
                g[i - 1].max(g[i]).max(g[i + 1])
            }
        };
        let f = x - k as f64;
        let ground = envelope(k) + f * (envelope(k + 1) - envelope(k));
        let height = (from.above_ground_m.ln()
            + s * (to.above_ground_m.ln() - from.above_ground_m.ln()))
        .exp()
            + CLIMB * self.distance_m * (std::f64::consts::PI * s).sin();
        let turn = (to.heading_deg - from.heading_deg + 180.0).rem_euclid(360.0) - 180.0;
        camera(
            lat,
            lon,
            ground + height,
            from.heading_deg + s * turn,
            from.pitch_deg + s * (to.pitch_deg - from.pitch_deg),
        )
    }
}

fn unit(lat_deg: f64, lon_deg: f64) -> DVec3 {
    let (lat, lon) = (lat_deg.to_radians(), lon_deg.to_radians());
    DVec3::new(lat.cos() * lon.cos(), lat.cos() * lon.sin(), lat.sin())
}

/// Spherical interpolation of unit vectors (nearly equal ones: linear, normalised).
fn slerp(a: DVec3, b: DVec3, s: f64) -> DVec3 {
    let angle = a.angle_between(b);
    if angle < 1e-9 {
        return a.lerp(b, s).normalize();
    }
    ((a * ((1.0 - s) * angle).sin() + b * (s * angle).sin()) / angle.sin()).normalize()
}

/// A small seeded generator (splitmix64): the path is the same for a seed on every machine.
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut x = self.0;
        x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        x ^ (x >> 31)
    }

    fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    fn log_range(&mut self, lo: f64, hi: f64) -> f64 {
        self.range(lo.ln(), hi.ln()).exp()
    }

    /// A latitude uniform over the sphere's area between ±`max_deg`.
    fn latitude(&mut self, max_deg: f64) -> f64 {
        let z = max_deg.to_radians().sin();
        self.range(-z, z).asin().to_degrees()
    }

    fn sign(&mut self) -> f64 {
        if self.unit() < 0.5 { -1.0 } else { 1.0 }
    }
}

fn draw_waypoint(rng: &mut Rng, place: Place) -> Waypoint {
    let (lat, lon, above, heading, pitch) = match place {
        Place::Space => (
            rng.latitude(90.0),
            rng.range(-180.0, 180.0),
            rng.log_range(1.0e6, 3.0e7),
            rng.range(0.0, 360.0),
            -90.0,
        ),
        Place::Aircraft => (
            rng.latitude(70.0),
            rng.range(-180.0, 180.0),
            rng.log_range(300.0, 2.0e4),
            rng.range(0.0, 360.0),
            rng.range(-60.0, -10.0),
        ),
        Place::Ground => (
            rng.latitude(70.0),
            rng.range(-180.0, 180.0),
            rng.log_range(1.0, 100.0),
            rng.range(0.0, 360.0),
            rng.range(-15.0, 5.0),
        ),
        Place::Pole => {
            let sign = rng.sign();
            let lat = if rng.unit() < 0.2 {
                90.0
            } else {
                90.0 - 8.0 * rng.unit().powi(2)
            };
            (
                sign * lat,
                rng.range(-180.0, 180.0),
                rng.log_range(10.0, 2.0e6),
                rng.range(0.0, 360.0),
                rng.range(-90.0, -5.0),
            )
        }
        Place::Antimeridian => (
            rng.latitude(60.0),
            rng.sign() * (180.0 - rng.range(0.0, 0.5)),
            rng.log_range(5.0, 2.0e5),
            // East or west, within 30°: the view crosses the seam.
            if rng.unit() < 0.5 { 90.0 } else { 270.0 } + rng.range(-30.0, 30.0),
            rng.range(-60.0, 0.0),
        ),
    };
    Waypoint {
        place,
        lat_deg: lat,
        lon_deg: lon,
        above_ground_m: above,
        heading_deg: heading,
        pitch_deg: pitch,
    }
}

/// The seeded random flight.
#[derive(Clone, Debug)]
pub struct SoakPath {
    legs: Vec<Leg>,
}

impl SoakPath {
    /// Legs from `space` until `seconds` are covered: the first four visit aircraft height,
    /// the ground, a pole and the antimeridian (the third jumps there), then places and jumps
    /// are drawn. `terrain_m(lat, lon)` is the ground height, read only here.
    pub fn new(
        seed: u64,
        seconds: f64,
        legs: &LegSeconds,
        radius_m: f64,
        terrain_m: impl Fn(f64, f64) -> f64,
    ) -> Self {
        let mut rng = Rng(seed ^ 0x50A4_50A4_50A4_50A4);
        let first = [
            Place::Aircraft,
            Place::Ground,
            Place::Pole,
            Place::Antimeridian,
        ];
        let mut from = draw_waypoint(&mut rng, Place::Space);
        let mut out: Vec<Leg> = Vec::new();
        let mut t = 0.0;
        while t < seconds || out.is_empty() {
            let i = out.len();
            let place = match first.get(i) {
                Some(&p) => p,
                None => Place::ALL[(rng.next_u64() % Place::ALL.len() as u64) as usize],
            };
            let to = draw_waypoint(&mut rng, place);
            let jump = i == 2 || (i >= first.len() && rng.unit() < legs.jump_fraction);
            let duration = if jump {
                rng.range(legs.hold.0, legs.hold.1)
            } else {
                rng.range(legs.fly.0, legs.fly.1)
            };
            let (a, b) = (
                unit(from.lat_deg, from.lon_deg),
                unit(to.lat_deg, to.lon_deg),
            );
            let ground_m = if jump {
                vec![terrain_m(to.lat_deg, to.lon_deg)]
            } else {
                (0..=GROUND_SAMPLES)
                    .map(|k| match k {
                        0 => terrain_m(from.lat_deg, from.lon_deg),
                        GROUND_SAMPLES => terrain_m(to.lat_deg, to.lon_deg),
                        _ => {
                            let d = slerp(a, b, k as f64 / GROUND_SAMPLES as f64);
                            let lat = d.z.clamp(-1.0, 1.0).asin().to_degrees();
                            terrain_m(lat, d.y.atan2(d.x).to_degrees())
                        }
                    })
                    .collect()
            };
            out.push(Leg {
                from,
                to,
                jump,
                start_s: t,
                seconds: duration,
                distance_m: a.angle_between(b) * radius_m,
                ground_m,
            });
            t += duration;
            // A jump's hold ends turned by 30°: the next leg starts from there.
            from = Waypoint {
                heading_deg: to.heading_deg + if jump { 30.0 } else { 0.0 },
                ..to
            };
        }
        Self { legs: out }
    }

    pub fn legs(&self) -> &[Leg] {
        &self.legs
    }

    /// The leg at soak time `t_s` and the camera there.
    pub fn camera(&self, t_s: f64) -> (usize, Camera) {
        let i = self
            .legs
            .partition_point(|l| l.end_s() <= t_s)
            .min(self.legs.len() - 1);
        let leg = &self.legs[i];
        (i, leg.camera_at((t_s - leg.start_s) / leg.seconds))
    }
}

/// What the soak runs with.
#[derive(Clone, Debug)]
pub struct SoakOptions {
    /// Seconds of flight on the soak's clock (settle points not counted).
    pub seconds: f64,
    pub seed: u64,
    pub legs: LegSeconds,
    pub width: u32,
    pub height: u32,
    pub settings: ClipmapSettings,
    /// Budgets and the faults injected into the flying renderer's reads.
    pub stream: StreamSettings,
    pub look: LookSettings,
    pub lod: crate::plan::LodSettings,
    /// Frames start at most this often; None: back to back.
    pub frame_interval: Option<Duration>,
    /// How long a settle point may wait for its view to complete.
    pub settle_timeout: Duration,
    pub rss_slack_bytes: u64,
    /// Where to write the three images of a settle point that differs (flying renderer,
    /// reference, fresh renderer), if anywhere.
    pub mismatch_dir: Option<std::path::PathBuf>,
}

impl SoakOptions {
    /// The soak's stream settings: `stream` with the default faults where it has none.
    pub fn default_faults(stream: StreamSettings, seed: u64) -> StreamSettings {
        StreamSettings {
            faults: FaultSettings {
                latency_ms: DEFAULT_LATENCY_MS.0,
                latency_max_ms: DEFAULT_LATENCY_MS.1,
                fail_rate: DEFAULT_FAIL_RATE,
                seed,
            },
            ..stream
        }
    }
}

/// The process's resident memory, bytes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Rss {
    /// Heap and other anonymous pages (the CPU side of a software GPU's memory included).
    pub anon: u64,
    /// Pages of mapped files (the pyramid): the kernel's to drop.
    pub file: u64,
}

impl Rss {
    /// From `/proc/self/status`; None where there is none (not Linux).
    pub fn now() -> Option<Rss> {
        let status = std::fs::read_to_string("/proc/self/status").ok()?;
        let field = |name: &str| -> Option<u64> {
            let line = status.lines().find(|l| l.starts_with(name))?;
            let kb: u64 = line[name.len()..]
                .trim()
                .trim_end_matches("kB")
                .trim()
                .parse()
                .ok()?;
            Some(kb * 1024)
        };
        Some(Rss {
            anon: field("RssAnon:")?,
            file: field("RssFile:")?,
        })
    }
}

/// One frame of the flight.
#[derive(Clone, Debug, Serialize)]
pub struct SoakFrame {
    /// Soak time (the path's clock), seconds.
    pub t_s: f64,
    /// Wall time since the soak started (settle points included), seconds.
    pub wall_s: f64,
    pub leg: usize,
    pub altitude_m: f64,
    pub cpu_ms: f64,
    pub frame_ms: f64,
    /// Pyramid reads made while this frame was prepared (must be 0).
    pub reads_in_frame: u64,
    pub rss: Option<Rss>,
    pub cache_bytes: u64,
    pub cache_budget: u64,
    /// What the frame held beyond the budget (`FeedFrame::cache_kept_bytes`).
    pub cache_kept_bytes: u64,
    pub gpu_tiles: usize,
    pub gpu_capacity: usize,
    pub tiles_loaded: u64,
    pub tiles_failed: u64,
    pub retries: u64,
    pub levels_waiting: u32,
}

/// A stop at the end of a leg: the faulty renderer settled and compared with a fault-free one.
#[derive(Clone, Debug, Serialize)]
pub struct SettlePoint {
    pub t_s: f64,
    pub wall_s: f64,
    pub leg: usize,
    pub place: Place,
    pub camera: [f64; 5],
    /// Seconds until the view was complete.
    pub settle_s: f64,
    pub settled: bool,
    /// Why not, when it did not settle (or the reference could not render).
    pub error: Option<String>,
    /// Pixels differing from the fault-free render (None when either failed).
    pub differing_px: Option<usize>,
    /// Of those, pixels differing visibly: by more than [`VISIBLE_CHANNEL_DIFF`] in a channel.
    pub visibly_differing_px: Option<usize>,
    /// Where they differ: what a third, fresh renderer (fault-free, default budgets) says.
    pub mismatch: Option<Mismatch>,
}

/// A channel difference (0–255) above this is visible; the goldens' tolerance.
pub const VISIBLE_CHANNEL_DIFF: u8 = 8;

fn pixels_differing_by_more_than(a: &RenderedFrame, b: &RenderedFrame, tolerance: u8) -> usize {
    a.rgba
        .chunks_exact(4)
        .zip(b.rgba.chunks_exact(4))
        .filter(|(p, q)| {
            p.iter()
                .zip(q.iter())
                .any(|(x, y)| x.abs_diff(*y) > tolerance)
        })
        .count()
}

/// A settle point that differs, seen by a third renderer made for it: whichever of the two
/// long-lived renderers it disagrees with carries state from its history.
#[derive(Clone, Debug, Serialize)]
pub struct Mismatch {
    pub fresh_vs_flying_px: usize,
    pub fresh_vs_reference_px: usize,
    /// Flying, reference, fresh.
    pub triangles: [u64; 3],
    pub levels: [(u32, u32); 3],
    pub height_above_terrain_m: [f64; 3],
}

/// What the soak found, against its budgets.
#[derive(Clone, Debug, Serialize)]
pub struct SoakFindings {
    pub frames: usize,
    pub flown_s: f64,
    pub wall_s: f64,
    pub legs: usize,
    pub jumps: usize,
    pub places: Vec<(Place, usize)>,
    /// Frames that read the pyramid while they were prepared.
    pub frames_reading_the_file: usize,
    pub cpu_ms_median: f64,
    pub cpu_ms_p99: f64,
    pub cpu_ms_max: f64,
    pub settle_points: usize,
    pub settle_failures: usize,
    pub settle_points_differing: usize,
    pub max_differing_px: usize,
    /// The largest share of an image's pixels that differ visibly at a settle point.
    pub max_visibly_differing_share: f64,
    pub settle_s_median: f64,
    pub settle_s_max: f64,
    pub cache_budget: u64,
    pub cache_bytes_max: u64,
    /// The most a frame held beyond the budget (the tiles it needs), and the frames whose
    /// cache went over both (must be 0).
    pub cache_kept_bytes_max: u64,
    pub frames_over_cache_budget: usize,
    pub gpu_capacity: usize,
    pub gpu_tiles_max: usize,
    /// Anonymous RSS: its most over the first half of the soak (wall time), the budget of the
    /// second half (that plus the cache's budget and the slack), and its most there.
    pub rss_anon_baseline: Option<u64>,
    pub rss_anon_budget: Option<u64>,
    pub rss_anon_max: Option<u64>,
    pub rss_file_max: Option<u64>,
    /// Least-squares slope of anonymous RSS over the second half of the flight, MiB/min: a
    /// leak shows as a steady rise.
    pub rss_anon_slope_mib_per_min: Option<f64>,
    pub tiles_loaded: u64,
    pub tiles_failed: u64,
    pub retries: u64,
}

impl SoakFindings {
    /// Every budget held, no frame read the file, every settle point settled and equal.
    pub fn passed(&self) -> bool {
        self.failures().is_empty()
    }

    /// What failed, in words.
    pub fn failures(&self) -> Vec<String> {
        let mut out = Vec::new();
        if self.frames_reading_the_file > 0 {
            out.push(format!(
                "{} frames read the pyramid while being prepared",
                self.frames_reading_the_file
            ));
        }
        if self.settle_failures > 0 {
            out.push(format!(
                "{} settle points did not settle",
                self.settle_failures
            ));
        }
        if self.settle_points_differing > 0 {
            out.push(format!(
                "{} settle points differ from the fault-free render (up to {} px)",
                self.settle_points_differing, self.max_differing_px
            ));
        }
        if self.frames_over_cache_budget > 0 {
            out.push(format!(
                "in {} frames the decoded-tile cache held more than its budget of {} B and \
                 more than the tiles the frame needed",
                self.frames_over_cache_budget, self.cache_budget
            ));
        }
        if self.gpu_tiles_max > self.gpu_capacity {
            out.push(format!(
                "{} GPU tiles resident, over the {} slots",
                self.gpu_tiles_max, self.gpu_capacity
            ));
        }
        if let (Some(max), Some(budget)) = (self.rss_anon_max, self.rss_anon_budget)
            && max > budget
        {
            out.push(format!(
                "anonymous RSS reached {:.1} MiB, over its budget of {:.1} MiB",
                mib(max),
                mib(budget)
            ));
        }
        out
    }
}

fn mib(bytes: u64) -> f64 {
    bytes as f64 / (1u64 << 20) as f64
}

/// Where the soak stands, for a progress line.
#[derive(Clone, Copy, Debug)]
pub struct SoakProgress {
    pub t_s: f64,
    pub seconds: f64,
    pub frames: usize,
    pub settle_points: usize,
    pub settle_points_bad: usize,
    pub reads_in_frames: u64,
}

/// One soak's frames, settle points and findings.
pub struct SoakRun {
    pub adapter: String,
    pub options: SoakOptions,
    pub path: SoakPath,
    pub frames: Vec<SoakFrame>,
    pub settles: Vec<SettlePoint>,
    pub wall_s: f64,
}

/// Flies the soak. Errors are those that stop it (no adapter, settings the renderer refuses);
/// what goes wrong during the flight is a finding.
pub fn run(
    ctx: &GpuContext,
    terrain: &Terrain,
    options: &SoakOptions,
    mut progress: impl FnMut(&SoakProgress),
) -> Result<SoakRun, BenchError> {
    let started = Instant::now();
    let path = SoakPath::new(
        options.seed,
        options.seconds,
        &options.legs,
        terrain.radius_m(),
        |lat, lon| terrain.height_at_lat_lon_m(lat, lon),
    );
    let make = |stream: StreamSettings| -> Result<TerrainRenderer, BenchError> {
        let mut r = TerrainRenderer::with_streaming(
            &ctx.device,
            options.settings.clone(),
            terrain.clone(),
            COLOR_FORMAT,
            stream,
        )?;
        r.set_look(&ctx.device, options.look);
        r.set_lod(&ctx.device, options.lod);
        Ok(r)
    };
    let mut renderer = make(options.stream)?;
    // The reference reads without faults and holds only what its frame needs (cache 0), so
    // its memory stays out of the flying renderer's budget.
    let mut reference = make(StreamSettings {
        faults: FaultSettings::default(),
        cache_bytes: 0,
        ..options.stream
    })?;
    let target = OffscreenFrame::new(&ctx.device, options.width, options.height);
    let mut frames: Vec<SoakFrame> = Vec::new();
    let mut settles: Vec<SettlePoint> = Vec::new();
    let mut flown = 0.0f64;
    let mut reads_total = 0u64;
    let mut settle =
        |leg: usize, t_s: f64, camera: &Camera, renderer: &mut TerrainRenderer| -> SettlePoint {
            let t = Instant::now();
            let waited = renderer.settle_or_explain(
                ctx,
                camera,
                options.width,
                options.height,
                options.settle_timeout,
            );
            let settle_s = t.elapsed().as_secs_f64();
            let compared = waited.map_err(|e| e.to_string()).and_then(|()| {
                let got = target
                    .render_now(ctx, renderer, camera)
                    .map_err(|e| e.to_string())?;
                let want = target
                    .render_settled_within(ctx, &mut reference, camera, options.settle_timeout)
                    .map_err(|e| format!("the fault-free reference: {e}"))?;
                let differing = pixels_differing(&got, &want);
                let visibly = pixels_differing_by_more_than(&got, &want, VISIBLE_CHANNEL_DIFF);
                let mut mismatch = None;
                if differing > 0 {
                    let mut fresh = make(StreamSettings {
                        faults: FaultSettings::default(),
                        ..StreamSettings::default()
                    })
                    .map_err(|e| e.to_string())?;
                    let third = target
                        .render_settled_within(ctx, &mut fresh, camera, options.settle_timeout)
                        .map_err(|e| format!("a fresh renderer: {e}"))?;
                    let frames = [&got, &want, &third];
                    mismatch = Some(Mismatch {
                        fresh_vs_flying_px: pixels_differing(&third, &got),
                        fresh_vs_reference_px: pixels_differing(&third, &want),
                        triangles: frames.map(|f| f.info.triangles()),
                        levels: frames
                            .map(|f| (f.info.selection.coarsest, f.info.selection.finest)),
                        height_above_terrain_m: frames.map(|f| f.info.height_above_terrain_m),
                    });
                    if let Some(dir) = &options.mismatch_dir {
                        for (frame, who) in frames.iter().zip(["flying", "reference", "fresh"]) {
                            let png = dir.join(format!("settle-{leg:03}-{who}.png"));
                            frame
                                .save_png(&png)
                                .map_err(|e| format!("cannot write {}: {e}", png.display()))?;
                        }
                    }
                }
                Ok((differing, visibly, mismatch))
            });
            SettlePoint {
                t_s,
                wall_s: started.elapsed().as_secs_f64(),
                leg,
                place: path.legs()[leg].to.place,
                camera: [
                    camera.lat_deg,
                    camera.lon_deg,
                    camera.altitude_m,
                    camera.heading_deg,
                    camera.pitch_deg,
                ],
                settle_s,
                settled: compared.is_ok(),
                differing_px: compared.as_ref().ok().map(|c| c.0),
                visibly_differing_px: compared.as_ref().ok().map(|c| c.1),
                mismatch: compared.as_ref().ok().and_then(|c| c.2.clone()),
                error: compared.err(),
            }
        };
    let mut next_start = Instant::now();
    loop {
        // Every leg that ended gets its settle point, at its end's view.
        let done = settles.len();
        if done < path.legs().len() && path.legs()[done].end_s() <= flown.min(options.seconds) {
            let leg = &path.legs()[done];
            let camera = leg.camera_at(1.0);
            settles.push(settle(done, leg.end_s(), &camera, &mut renderer));
            continue;
        }
        if flown >= options.seconds {
            break;
        }
        if let Some(dt) = options.frame_interval {
            let now = Instant::now();
            if next_start > now {
                std::thread::sleep(next_start - now);
            }
            next_start = next_start.max(now) + dt;
        }
        let clock = Instant::now();
        let (leg, camera) = path.camera(flown);
        let reads_before = frame_reads::reads_in_frames_on_this_thread();
        let f = target.draw_timed(ctx, &mut renderer, &camera, None)?;
        let reads_in_frame = frame_reads::reads_in_frames_on_this_thread() - reads_before;
        reads_total += reads_in_frame;
        let s = f.info.stream.clone().unwrap_or_default();
        frames.push(SoakFrame {
            t_s: flown,
            wall_s: started.elapsed().as_secs_f64(),
            leg,
            altitude_m: camera.altitude_m,
            cpu_ms: f.cpu_ms,
            frame_ms: f.frame_ms,
            reads_in_frame,
            rss: Rss::now(),
            cache_bytes: s.cache_bytes,
            cache_budget: s.cache_budget,
            cache_kept_bytes: s.cache_kept_bytes,
            gpu_tiles: s.gpu_tiles,
            gpu_capacity: s.gpu_capacity,
            tiles_loaded: s.stream.tiles_loaded,
            tiles_failed: s.stream.tiles_failed,
            retries: s.stream.retries,
            levels_waiting: f.info.selection.waiting().len() as u32,
        });
        flown += clock.elapsed().as_secs_f64();
        progress(&SoakProgress {
            t_s: flown.min(options.seconds),
            seconds: options.seconds,
            frames: frames.len(),
            settle_points: settles.len(),
            settle_points_bad: settles.iter().filter(|p| p.differing_px != Some(0)).count(),
            reads_in_frames: reads_total,
        });
    }
    // The view where the flight stopped, mid-leg: one more settle point.
    if settles.len() < path.legs().len() {
        let (leg, camera) = path.camera(options.seconds);
        settles.push(settle(leg, options.seconds, &camera, &mut renderer));
    }
    Ok(SoakRun {
        adapter: ctx.adapter_description(),
        options: options.clone(),
        path,
        frames,
        settles,
        wall_s: started.elapsed().as_secs_f64(),
    })
}

fn quantile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    sorted[((sorted.len() - 1) as f64 * q).round() as usize]
}

impl SoakRun {
    pub fn findings(&self) -> SoakFindings {
        let mut cpu: Vec<f64> = self.frames.iter().map(|f| f.cpu_ms).collect();
        cpu.sort_by(f64::total_cmp);
        let mut settle_s: Vec<f64> = self.settles.iter().map(|p| p.settle_s).collect();
        settle_s.sort_by(f64::total_cmp);
        let legs = &self.path.legs()[..self.settles.len().min(self.path.legs().len())];
        let places = Place::ALL
            .iter()
            .map(|&p| (p, legs.iter().filter(|l| l.to.place == p).count()))
            .collect();
        // Each renderer compiles a pipeline the first time a kind of view needs it (a software
        // GPU keeps the code in anonymous memory), so memory grows while new kinds of views
        // come; the first half is the warm-up, the second must stay within it plus what the
        // cache may still take.
        let half_s = self.frames.last().map_or(0.0, |f| f.wall_s) / 2.0;
        let anon_max = |first: bool| {
            self.frames
                .iter()
                .filter(|f| (f.wall_s <= half_s) == first)
                .filter_map(|f| f.rss.map(|r| r.anon))
                .max()
        };
        let (rss_anon_baseline, rss_anon_max) = (anon_max(true), anon_max(false));
        let last = self.frames.last();
        let cache_budget = self.options.stream.cache_bytes;
        SoakFindings {
            frames: self.frames.len(),
            flown_s: last.map_or(0.0, |f| f.t_s),
            wall_s: self.wall_s,
            legs: legs.len(),
            jumps: legs.iter().filter(|l| l.jump).count(),
            places,
            frames_reading_the_file: self.frames.iter().filter(|f| f.reads_in_frame > 0).count(),
            cpu_ms_median: quantile(&cpu, 0.5),
            cpu_ms_p99: quantile(&cpu, 0.99),
            cpu_ms_max: cpu.last().copied().unwrap_or(f64::NAN),
            settle_points: self.settles.len(),
            settle_failures: self.settles.iter().filter(|p| !p.settled).count(),
            settle_points_differing: self
                .settles
                .iter()
                .filter(|p| p.differing_px.is_some_and(|d| d > 0))
                .count(),
            max_differing_px: self
                .settles
                .iter()
                .filter_map(|p| p.differing_px)
                .max()
                .unwrap_or(0),
            max_visibly_differing_share: self
                .settles
                .iter()
                .filter_map(|p| p.visibly_differing_px)
                .max()
                .unwrap_or(0) as f64
                / (self.options.width as f64 * self.options.height as f64),
            settle_s_median: quantile(&settle_s, 0.5),
            settle_s_max: settle_s.last().copied().unwrap_or(f64::NAN),
            cache_budget,
            cache_bytes_max: self.frames.iter().map(|f| f.cache_bytes).max().unwrap_or(0),
            cache_kept_bytes_max: self
                .frames
                .iter()
                .map(|f| f.cache_kept_bytes)
                .max()
                .unwrap_or(0),
            frames_over_cache_budget: self
                .frames
                .iter()
                .filter(|f| f.cache_bytes > f.cache_budget.max(f.cache_kept_bytes))
                .count(),
            gpu_capacity: self.frames.first().map_or(0, |f| f.gpu_capacity),
            gpu_tiles_max: self.frames.iter().map(|f| f.gpu_tiles).max().unwrap_or(0),
            rss_anon_baseline,
            rss_anon_budget: rss_anon_baseline
                .map(|b| b + cache_budget + self.options.rss_slack_bytes),
            rss_anon_max,
            rss_file_max: self
                .frames
                .iter()
                .filter_map(|f| f.rss.map(|r| r.file))
                .max(),
            rss_anon_slope_mib_per_min: self.rss_slope_mib_per_min(),
            tiles_loaded: last.map_or(0, |f| f.tiles_loaded),
            tiles_failed: last.map_or(0, |f| f.tiles_failed),
            retries: last.map_or(0, |f| f.retries),
        }
    }

    /// Anonymous RSS against wall time over the second half of the frames, least squares.
    fn rss_slope_mib_per_min(&self) -> Option<f64> {
        let pts: Vec<(f64, f64)> = self.frames[self.frames.len() / 2..]
            .iter()
            .filter_map(|f| f.rss.map(|r| (f.wall_s / 60.0, mib(r.anon))))
            .collect();
        if pts.len() < 3 {
            return None;
        }
        let n = pts.len() as f64;
        let (mx, my) = (
            pts.iter().map(|p| p.0).sum::<f64>() / n,
            pts.iter().map(|p| p.1).sum::<f64>() / n,
        );
        let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
        let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
        (sxx > 0.0).then(|| sxy / sxx)
    }

    /// Every frame, one CSV row each.
    pub fn frames_csv(&self) -> String {
        let mut out = String::from(
            "t_s,wall_s,leg,altitude_m,cpu_ms,frame_ms,reads_in_frame,rss_anon_bytes,\
             rss_file_bytes,cache_bytes,cache_budget,cache_kept_bytes,gpu_tiles,gpu_capacity,\
             tiles_loaded,\
             tiles_failed,retries,levels_waiting\n",
        );
        for f in &self.frames {
            let (anon, file) = f.rss.map_or((String::new(), String::new()), |r| {
                (r.anon.to_string(), r.file.to_string())
            });
            out += &format!(
                "{:.3},{:.3},{},{:.3},{:.3},{:.3},{},{anon},{file},{},{},{},{},{},{},{},{},{}\n",
                f.t_s,
                f.wall_s,
                f.leg,
                f.altitude_m,
                f.cpu_ms,
                f.frame_ms,
                f.reads_in_frame,
                f.cache_bytes,
                f.cache_budget,
                f.cache_kept_bytes,
                f.gpu_tiles,
                f.gpu_capacity,
                f.tiles_loaded,
                f.tiles_failed,
                f.retries,
                f.levels_waiting
            );
        }
        out
    }

    /// The findings, the settle points and the legs, one JSON object.
    pub fn to_json(&self) -> String {
        #[derive(Serialize)]
        struct Json<'a> {
            adapter: &'a str,
            seed: u64,
            seconds: f64,
            width: u32,
            height: u32,
            fail_rate: f64,
            latency_ms: (u64, u64),
            passed: bool,
            failures: Vec<String>,
            findings: SoakFindings,
            settle_points: &'a [SettlePoint],
        }
        let f = &self.options.stream.faults;
        let findings = self.findings();
        crate::bench::to_json_line(&Json {
            adapter: &self.adapter,
            seed: self.options.seed,
            seconds: self.options.seconds,
            width: self.options.width,
            height: self.options.height,
            fail_rate: f.fail_rate,
            latency_ms: (f.latency_ms, f.latency_max_ms.max(f.latency_ms)),
            passed: findings.passed(),
            failures: findings.failures(),
            findings,
            settle_points: &self.settles,
        })
    }

    /// The memory trace as a PNG: camera height, anonymous RSS, the decoded-tile cache and
    /// the GPU tiles against wall time, each with its budget; settle points as ticks.
    pub fn write_plot(&self, png: &Path) -> Result<(), MeasureError> {
        let (w, h) = (1200u32, 1000u32);
        let mut buf = vec![255u8; (w * h * 3) as usize];
        draw_trace(self, &mut buf, w, h).map_err(|e| MeasureError::Plot(e.to_string().into()))?;
        let img = image::RgbImage::from_raw(w, h, buf).expect("buffer of w × h × 3");
        img.save_with_format(png, image::ImageFormat::Png)
            .map_err(|source| MeasureError::Image {
                path: png.to_path_buf(),
                source,
            })
    }
}

fn draw_trace(
    run: &SoakRun,
    buf: &mut [u8],
    w: u32,
    h: u32,
) -> Result<(), Box<dyn std::error::Error>> {
    use plotters::prelude::*;
    crate::measure::plot::register_embedded_font();
    let font = crate::measure::plot::FONT;
    let root = BitMapBackend::with_buffer(buf, (w, h)).into_drawing_area();
    root.fill(&WHITE)?;
    let findings = run.findings();
    let t_max = run.wall_s.max(1e-3);
    let title = format!(
        "soak: seed {}, {:.0} s flown ({:.0} s wall), {} frames, {} settle points ({} differ), \
         {} frames read the file",
        run.options.seed,
        findings.flown_s,
        run.wall_s,
        findings.frames,
        findings.settle_points,
        findings.settle_points_differing,
        findings.frames_reading_the_file
    );
    let (top, rest) = root.split_vertically(40);
    top.draw(&Text::new(title, (10, 10), (font, 18).into_font()))?;
    let panels = rest.split_evenly((4, 1));
    let settle_ticks: Vec<f64> = run.settles.iter().map(|p| p.wall_s).collect();
    let line = |area: &DrawingArea<BitMapBackend, plotters::coord::Shift>,
                caption: &str,
                series: Vec<(f64, f64)>,
                budget: Option<f64>,
                log: bool|
     -> Result<(), Box<dyn std::error::Error>> {
        let finite = series.iter().map(|p| p.1).filter(|v| v.is_finite());
        let mut y_max = finite.clone().fold(0.0f64, f64::max);
        if let Some(b) = budget {
            y_max = y_max.max(b);
        }
        let y_max = (y_max * 1.1).max(1e-3);
        let mut chart = ChartBuilder::on(area);
        chart
            .caption(caption, (font, 16).into_font())
            .margin(8)
            .x_label_area_size(28)
            .y_label_area_size(70);
        let style = (font, 13).into_font();
        if log {
            let y_min = finite.fold(f64::INFINITY, f64::min).max(0.1);
            let mut c = chart.build_cartesian_2d(0.0..t_max, (y_min..y_max).log_scale())?;
            c.configure_mesh()
                .label_style(style.clone())
                .x_desc("wall time, s")
                .light_line_style(TRANSPARENT)
                .y_labels(8)
                .y_label_formatter(&|v| format!("{v:.0e}"))
                .draw()?;
            for &t in &settle_ticks {
                c.draw_series(LineSeries::new([(t, y_min), (t, y_max)], BLUE.mix(0.25)))?;
            }
            c.draw_series(LineSeries::new(series, BLACK.stroke_width(1)))?;
        } else {
            let mut c = chart.build_cartesian_2d(0.0..t_max, 0.0..y_max)?;
            c.configure_mesh()
                .label_style(style.clone())
                .x_desc("wall time, s")
                .light_line_style(TRANSPARENT)
                .draw()?;
            for &t in &settle_ticks {
                c.draw_series(LineSeries::new([(t, 0.0), (t, y_max)], BLUE.mix(0.25)))?;
            }
            if let Some(b) = budget {
                c.draw_series(LineSeries::new([(0.0, b), (t_max, b)], RED.stroke_width(2)))?;
            }
            c.draw_series(LineSeries::new(series, BLACK.stroke_width(1)))?;
        }
        Ok(())
    };
    let series = |f: &dyn Fn(&SoakFrame) -> Option<f64>| -> Vec<(f64, f64)> {
        run.frames
            .iter()
            .filter_map(|fr| f(fr).map(|v| (fr.wall_s, v)))
            .collect()
    };
    line(
        &panels[0],
        "camera height above the sphere, m (blue: settle points)",
        series(&|f| Some(f.altitude_m.max(0.1))),
        None,
        true,
    )?;
    line(
        &panels[1],
        "anonymous RSS, MiB (red: the second half's budget)",
        series(&|f| f.rss.map(|r| mib(r.anon))),
        findings.rss_anon_budget.map(mib),
        false,
    )?;
    line(
        &panels[2],
        "decoded-tile cache, MiB (red: --cache-mb)",
        series(&|f| Some(mib(f.cache_bytes))),
        Some(mib(findings.cache_budget)),
        false,
    )?;
    line(
        &panels[3],
        "GPU tiles resident (red: --gpu-tiles)",
        series(&|f| Some(f.gpu_tiles as f64)),
        Some(findings.gpu_capacity as f64),
        false,
    )?;
    root.present()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const R: f64 = 6_371_000.0;

    /// Smooth relief on the sphere (a function of the unit vector: one value at a pole).
    fn terrain(lat: f64, lon: f64) -> f64 {
        let u = unit(lat, lon);
        1000.0 * (3.0 * u.x).sin() * (2.0 * u.y + u.z).cos()
    }

    fn path(seed: u64, seconds: f64) -> SoakPath {
        SoakPath::new(seed, seconds, &LegSeconds::default(), R, terrain)
    }

    #[test]
    fn the_path_is_the_seeds_and_covers_every_place_and_a_jump() {
        let a = path(7, 600.0);
        let b = path(7, 600.0);
        let c = path(8, 600.0);
        assert_eq!(a.legs().len(), b.legs().len());
        for (x, y) in a.legs().iter().zip(b.legs()) {
            assert_eq!(x.to, y.to);
            assert_eq!(x.seconds, y.seconds);
        }
        assert_ne!(a.legs()[0].to, c.legs()[0].to);
        let legs = a.legs();
        assert!(legs.last().unwrap().end_s() >= 600.0);
        for p in Place::ALL {
            assert!(legs.iter().any(|l| l.to.place == p), "{p:?} never visited");
        }
        assert!(legs[2].jump);
        assert!(legs.iter().filter(|l| l.jump).count() >= 3);
        assert!(legs.iter().any(|l| l.to.lat_deg.abs() == 90.0), "on a pole");
        for l in legs {
            if l.to.place == Place::Antimeridian {
                assert!(l.to.lon_deg.abs() >= 179.5);
            }
        }
    }

    #[test]
    fn legs_are_continuous_and_end_at_their_waypoints_above_the_ground() {
        let p = path(3, 900.0);
        for (i, leg) in p.legs().iter().enumerate() {
            let end = leg.camera_at(1.0);
            assert!((end.lat_deg - leg.to.lat_deg).abs() < 1e-12);
            let above = end.altitude_m - terrain(leg.to.lat_deg, leg.to.lon_deg);
            assert!(
                (above - leg.to.above_ground_m).abs() < 1e-6 * above.max(1.0),
                "leg {i}: {above} m above, {:?}",
                leg.to
            );
            if let Some(next) = p.legs().get(i + 1) {
                // The next leg starts where this one ended (a jump jumps within its own leg).
                let start = next.camera_at(0.0);
                if !next.jump {
                    assert!(
                        (start.altitude_m - end.altitude_m).abs()
                            < 1e-6 * end.altitude_m.abs().max(1.0),
                        "leg {i}: {end:?} then {start:?}"
                    );
                    assert!((start.lat_deg - end.lat_deg).abs() < 1e-9);
                    let dh = (start.heading_deg - end.heading_deg).rem_euclid(360.0);
                    assert!(dh.min(360.0 - dh) < 1e-9, "heading {dh}");
                }
            }
            // Along a fly leg: small steps move the camera little, and it stays above the
            // terrain under it.
            if !leg.jump {
                let n = 2000;
                for k in 0..n {
                    let (c0, c1) = (
                        leg.camera_at(k as f64 / n as f64),
                        leg.camera_at((k + 1) as f64 / n as f64),
                    );
                    let (u0, u1) = (unit(c0.lat_deg, c0.lon_deg), unit(c1.lat_deg, c1.lon_deg));
                    let step = u0.angle_between(u1) * R;
                    assert!(
                        step <= 2.0 * leg.distance_m / n as f64 + 1e-6,
                        "step {step}"
                    );
                    let above = c0.altitude_m - terrain(c0.lat_deg, c0.lon_deg);
                    assert!(above > 0.5, "leg {i} at {k}/{n}: {above} m above, {leg:?}");
                }
            }
        }
    }

    #[test]
    fn camera_picks_the_leg_by_time() {
        let p = path(5, 120.0);
        let l1 = &p.legs()[1];
        let (i, c) = p.camera(l1.start_s + 0.5 * l1.seconds);
        assert_eq!(i, 1);
        let want = l1.camera_at(0.5);
        assert!((c.altitude_m - want.altitude_m).abs() < 1e-6 * want.altitude_m);
        assert!((c.lat_deg - want.lat_deg).abs() < 1e-9);
        let (last, _) = p.camera(1e9);
        assert_eq!(last, p.legs().len() - 1);
    }

    #[test]
    fn rss_reads_this_process() {
        if cfg!(target_os = "linux") {
            let before = Rss::now().expect("/proc/self/status");
            let block = vec![1u8; 64 << 20];
            let after = Rss::now().unwrap();
            assert!(block.iter().all(|&b| b == 1));
            // Pages touched by the 64 MiB block show in anonymous RSS (other tests' threads
            // allocate and free meanwhile: half is plenty of margin).
            assert!(
                after.anon >= before.anon + (32 << 20),
                "{before:?} then {after:?}"
            );
        }
    }
}
