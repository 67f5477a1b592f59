//! Recorded camera paths (issue 38's record and replay): the viewer's camera as keys of time
//! and view, saved as JSON, replayed by the viewer, rendered frame by frame by `globe render
//! --path` and timed by `globe bench --path`.
//!
//! The file:
//!
//! ```json
//! {"format": "globe camera path", "version": 1,
//!  "keys": [{"t_s": 0.0, "lat_deg": 45.65, "lon_deg": 10.65, "altitude_m": 10000.0,
//!            "heading_deg": 315.0, "pitch_deg": -20.0, "roll_deg": 0.0, "fov_y_deg": 60.0}, …]}
//! ```
//!
//! `altitude_m` is above the sphere of radius R, so a path replays the same views whatever
//! the terrain. Between keys the camera moves along the great circle between their nadirs
//! (spherical interpolation), its altitude, pitch, roll and field of view linearly, its heading
//! the shorter way round; before the first key and after the last it stays there.

use std::path::{Path, PathBuf};

use glam::DVec3;
use serde::{Deserialize, Serialize};

use crate::geo::camera::Camera;
use crate::geo::sphere;

/// The `format` field's value.
pub const FORMAT: &str = "globe camera path";
pub const VERSION: u32 = 1;

/// One key: a time and the camera then.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PathKey {
    pub t_s: f64,
    pub lat_deg: f64,
    pub lon_deg: f64,
    /// Above the sphere of radius R, metres.
    pub altitude_m: f64,
    pub heading_deg: f64,
    pub pitch_deg: f64,
    #[serde(default)]
    pub roll_deg: f64,
    #[serde(default = "default_fov")]
    pub fov_y_deg: f64,
}

fn default_fov() -> f64 {
    super::SCENE_FOV_Y_DEG
}

impl PathKey {
    pub fn of(t_s: f64, c: &Camera) -> Self {
        Self {
            t_s,
            lat_deg: c.lat_deg,
            lon_deg: c.lon_deg,
            altitude_m: c.altitude_m,
            heading_deg: c.heading_deg,
            pitch_deg: c.pitch_deg,
            roll_deg: c.roll_deg,
            fov_y_deg: c.fov_y_deg,
        }
    }

    pub fn camera(&self) -> Camera {
        Camera {
            lat_deg: self.lat_deg,
            lon_deg: self.lon_deg,
            altitude_m: self.altitude_m,
            heading_deg: self.heading_deg,
            pitch_deg: self.pitch_deg,
            roll_deg: self.roll_deg,
            fov_y_deg: self.fov_y_deg,
        }
    }
}

#[derive(Serialize, Deserialize)]
struct PathFile {
    format: String,
    version: u32,
    keys: Vec<PathKey>,
}

/// Why a path cannot be read or written.
#[derive(Debug, thiserror::Error)]
pub enum PathError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: not a camera path (line {line}, column {column}): {message}")]
    Json {
        path: PathBuf,
        line: usize,
        column: usize,
        message: String,
    },
    #[error("{path}: field `format` is '{found}'; expected '{FORMAT}'")]
    Format { path: PathBuf, found: String },
    #[error("{path}: version {found} is not one this globe reads (it reads {VERSION})")]
    Version { path: PathBuf, found: u32 },
    #[error("{path}: the path has no keys")]
    Empty { path: PathBuf },
    #[error("{path}: key {index}: `{field}` is {value}; expected {expected}")]
    Field {
        path: PathBuf,
        index: usize,
        field: &'static str,
        value: f64,
        expected: &'static str,
    },
}

/// A recorded path: keys in increasing time.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraPath {
    keys: Vec<PathKey>,
}

impl CameraPath {
    /// A path of `keys`, checked as a file's would be (`origin` names it in errors).
    pub fn new(keys: Vec<PathKey>, origin: &Path) -> Result<Self, PathError> {
        let path = || origin.to_path_buf();
        if keys.is_empty() {
            return Err(PathError::Empty { path: path() });
        }
        let mut previous_t = f64::NEG_INFINITY;
        for (index, k) in keys.iter().enumerate() {
            let field = |field, value, expected| {
                Err(PathError::Field {
                    path: path(),
                    index,
                    field,
                    value,
                    expected,
                })
            };
            if !(k.t_s.is_finite() && k.t_s >= 0.0) {
                return field("t_s", k.t_s, "a time ≥ 0 s");
            }
            if k.t_s <= previous_t {
                return field("t_s", k.t_s, "a time later than the key before");
            }
            previous_t = k.t_s;
            if !(-90.0..=90.0).contains(&k.lat_deg) {
                return field("lat_deg", k.lat_deg, "−90…90");
            }
            if !k.lon_deg.is_finite() {
                return field("lon_deg", k.lon_deg, "a finite longitude");
            }
            if !(k.altitude_m.is_finite() && k.altitude_m > -crate::geo::EARTH_RADIUS_M) {
                return field("altitude_m", k.altitude_m, "a finite height above −R");
            }
            if !(k.heading_deg.is_finite() && k.roll_deg.is_finite()) {
                return field("heading_deg", k.heading_deg, "finite heading and roll");
            }
            if !(-90.0..=90.0).contains(&k.pitch_deg) {
                return field("pitch_deg", k.pitch_deg, "−90…90");
            }
            if !(k.fov_y_deg > 1.0 && k.fov_y_deg < 170.0) {
                return field("fov_y_deg", k.fov_y_deg, "1…170");
            }
        }
        Ok(Self { keys })
    }

    pub fn load(path: &Path) -> Result<Self, PathError> {
        let text = std::fs::read_to_string(path).map_err(|source| PathError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let file: PathFile = serde_json::from_str(&text).map_err(|e| PathError::Json {
            path: path.to_path_buf(),
            line: e.line(),
            column: e.column(),
            message: e.to_string(),
        })?;
        if file.format != FORMAT {
            return Err(PathError::Format {
                path: path.to_path_buf(),
                found: file.format,
            });
        }
        if file.version != VERSION {
            return Err(PathError::Version {
                path: path.to_path_buf(),
                found: file.version,
            });
        }
        Self::new(file.keys, path)
    }

    pub fn save(&self, path: &Path) -> Result<(), PathError> {
        let file = PathFile {
            format: FORMAT.into(),
            version: VERSION,
            keys: self.keys.clone(),
        };
        let text = serde_json::to_string_pretty(&file).expect("a path serialises");
        std::fs::write(path, text + "\n").map_err(|source| PathError::Io {
            path: path.to_path_buf(),
            source,
        })
    }

    pub fn keys(&self) -> &[PathKey] {
        &self.keys
    }

    /// From the first key's time to the last's.
    pub fn duration_s(&self) -> f64 {
        self.keys.last().map_or(0.0, |l| l.t_s) - self.keys[0].t_s
    }

    /// The frames of a replay at `fps`: the times k / fps after the first key, as many as fit
    /// before the path ends (a 20 s path at 10 fps: 200 frames), at least one.
    pub fn frame_times_s(&self, fps: f64) -> Vec<f64> {
        let n = ((self.duration_s() * fps) - 1e-9).ceil().max(1.0) as usize;
        (0..n).map(|k| k as f64 / fps).collect()
    }

    /// The camera `t_s` after the first key.
    pub fn camera_at(&self, t_s: f64) -> Camera {
        let t = self.keys[0].t_s + t_s;
        let i = self.keys.partition_point(|k| k.t_s <= t);
        if i == 0 {
            return self.keys[0].camera();
        }
        if i == self.keys.len() {
            return self.keys[i - 1].camera();
        }
        let (a, b) = (&self.keys[i - 1], &self.keys[i]);
        let s = (t - a.t_s) / (b.t_s - a.t_s);
        let u = |k: &PathKey| {
            let (phi, theta) = sphere::phi_theta_from_lat_lon_deg(k.lat_deg, k.lon_deg);
            sphere::unit_vector(phi, theta)
        };
        let (ua, ub) = (u(a), u(b));
        let omega = ua.cross(ub).length().atan2(ua.dot(ub));
        let nadir: DVec3 = if omega < 1e-12 {
            ua
        } else {
            ((((1.0 - s) * omega).sin() * ua + (s * omega).sin() * ub) / omega.sin()).normalize()
        };
        let (phi, theta, _) = sphere::phi_theta_height_from_ecef_m(nadir, 1.0);
        let (lat_deg, lon_deg) = sphere::lat_lon_deg_from_phi_theta(phi, theta);
        let turn =
            |x: f64, y: f64| x + s * sphere::wrap_angle_rad((y - x).to_radians()).to_degrees();
        let lerp = |x: f64, y: f64| x + s * (y - x);
        Camera {
            lat_deg,
            lon_deg,
            altitude_m: lerp(a.altitude_m, b.altitude_m),
            heading_deg: turn(a.heading_deg, b.heading_deg).rem_euclid(360.0),
            pitch_deg: lerp(a.pitch_deg, b.pitch_deg),
            roll_deg: turn(a.roll_deg, b.roll_deg),
            fov_y_deg: lerp(a.fov_y_deg, b.fov_y_deg),
        }
    }
}

/// The viewer's recorder: a key whenever the camera changed, at most every
/// [`Recorder::MIN_INTERVAL_S`], and always the last view.
#[derive(Clone, Debug, Default)]
pub struct Recorder {
    keys: Vec<PathKey>,
    pending: Option<PathKey>,
}

impl Recorder {
    /// Keys closer than this are not kept (30 a second is smooth; the viewer draws more).
    pub const MIN_INTERVAL_S: f64 = 1.0 / 30.0;

    /// The camera at `t_s` since recording started.
    pub fn record(&mut self, t_s: f64, camera: &Camera) {
        let key = PathKey::of(t_s, camera);
        match self.keys.last() {
            Some(last) if t_s - last.t_s < Self::MIN_INTERVAL_S => self.pending = Some(key),
            _ => {
                self.keys.push(key);
                self.pending = None;
            }
        }
    }

    pub fn len(&self) -> usize {
        self.keys.len() + usize::from(self.pending.is_some())
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The recorded path (`origin` names it in errors: an empty recording has no keys).
    pub fn finish(mut self, origin: &Path) -> Result<CameraPath, PathError> {
        self.keys.extend(self.pending.take());
        CameraPath::new(self.keys, origin)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam(lat: f64, lon: f64, alt: f64, heading: f64) -> Camera {
        Camera {
            lat_deg: lat,
            lon_deg: lon,
            altitude_m: alt,
            heading_deg: heading,
            pitch_deg: -20.0,
            roll_deg: 0.0,
            fov_y_deg: 60.0,
        }
    }

    fn path(keys: &[(f64, Camera)]) -> CameraPath {
        CameraPath::new(
            keys.iter().map(|(t, c)| PathKey::of(*t, c)).collect(),
            Path::new("p"),
        )
        .unwrap()
    }

    /// Keys come back exactly; between them the camera moves along the great circle and turns
    /// the short way round; past the ends it stays there.
    #[test]
    fn replays_the_keys_and_moves_between_them() {
        let (a, b) = (
            cam(0.0, 179.0, 1000.0, 350.0),
            cam(0.0, -179.0, 3000.0, 10.0),
        );
        let p = path(&[(2.0, a), (4.0, b)]);
        assert_eq!(p.duration_s(), 2.0);
        assert_eq!(p.camera_at(0.0), a);
        assert_eq!(p.camera_at(2.0), b);
        assert_eq!(p.camera_at(-1.0), a);
        assert_eq!(p.camera_at(9.0), b);
        let mid = p.camera_at(1.0);
        assert!((mid.lon_deg.abs() - 180.0).abs() < 1e-9, "{mid:?}");
        assert!((mid.altitude_m - 2000.0).abs() < 1e-9);
        assert!(
            mid.heading_deg.abs() < 1e-9 || (mid.heading_deg - 360.0).abs() < 1e-9,
            "{mid:?}"
        );
    }

    #[test]
    fn a_20_s_path_at_10_fps_is_200_frames() {
        let p = path(&[
            (0.0, cam(1.0, 1.0, 10.0, 0.0)),
            (20.0, cam(2.0, 2.0, 10.0, 0.0)),
        ]);
        let times = p.frame_times_s(10.0);
        assert_eq!(times.len(), 200);
        assert_eq!(times[199], 19.9);
        let one = path(&[(5.0, cam(1.0, 1.0, 10.0, 0.0))]);
        assert_eq!(one.frame_times_s(10.0), vec![0.0]);
    }

    /// Saved and loaded, a recording is the same path; bad files name the file, key and field.
    #[test]
    fn files_round_trip_and_bad_ones_say_what_is_wrong() {
        let dir = std::env::temp_dir().join(format!("globe-path-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut rec = Recorder::default();
        for k in 0..100 {
            rec.record(
                f64::from(k) * 0.01,
                &cam(45.0 + f64::from(k) * 1e-3, 10.0, 500.0, 0.0),
            );
        }
        // Keys 1/30 s apart at least (every fourth sample of 0.01 s: 25) and the last one.
        assert_eq!(rec.len(), 26);
        let file = dir.join("p.json");
        let recorded = rec.finish(&file).unwrap();
        recorded.save(&file).unwrap();
        assert_eq!(CameraPath::load(&file).unwrap(), recorded);
        assert_eq!(recorded.keys().last().unwrap().lat_deg, 45.0 + 99.0 * 1e-3);
        let bad = |text: &str| {
            std::fs::write(&file, text).unwrap();
            CameraPath::load(&file).unwrap_err().to_string()
        };
        let key =
            r#"{"t_s":0,"lat_deg":1,"lon_deg":2,"altitude_m":3,"heading_deg":0,"pitch_deg":-10}"#;
        let e = bad(&format!(
            r#"{{"format":"globe camera path","version":1,"keys":[{key},{key}]}}"#
        ));
        assert!(
            e.contains("key 1") && e.contains("t_s") && e.contains("later"),
            "{e}"
        );
        let e = bad(r#"{"format":"other","version":1,"keys":[]}"#);
        assert!(e.contains("`format`"), "{e}");
        let e = bad(r#"{"format":"globe camera path","version":1,"keys":[]}"#);
        assert!(e.contains("no keys"), "{e}");
        let e = bad("{");
        assert!(e.contains("p.json") && e.contains("line 1"), "{e}");
        let e = bad(&format!(
            r#"{{"format":"globe camera path","version":1,"keys":[{}]}}"#,
            key.replace("\"lat_deg\":1", "\"lat_deg\":95")
        ));
        assert!(
            e.contains("key 0") && e.contains("lat_deg") && e.contains("95"),
            "{e}"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
