//! The named scenes of docs/design.md#scenes, shared by the viewer's bookmarks, `globe render`, the tests,
//! the report and the benchmarks. Keep the numbers: other tools compare against the same views.
//!
//! Every name is looked up through [`find`] (one registry, one error listing the names), and any
//! other view is a [`CameraSpec`], parsed from the `--camera` / "go to" text
//! `LAT,LON,HEIGHT,HEADING,PITCH[,ROLL]` and validated ([`ViewError`] names the bad value).
//!
//! Recorded paths (`path`: the viewer's camera as keys of time and view) replay through
//! the viewer, `globe render --path` and `globe bench --path`.

use std::fmt;
use std::str::FromStr;

use crate::geo::EARTH_RADIUS_M;
use crate::geo::camera::Camera;

pub mod flight;
pub mod path;
pub mod soak_path;

/// Vertical field of view of every named scene (docs/design.md#scenes).
pub const SCENE_FOV_Y_DEG: f64 = 60.0;

/// How a scene's camera height is given.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SceneHeight {
    /// Metres above the sphere of radius R.
    AboveSphere(f64),
    /// Metres above the terrain of the height source in use, at the scene's point.
    AboveTerrain(f64),
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scene {
    pub name: &'static str,
    pub lat_deg: f64,
    pub lon_deg: f64,
    pub height: SceneHeight,
    pub heading_deg: f64,
    /// Negative looks down; −90 looks at the planet's centre.
    pub pitch_deg: f64,
    pub stresses: &'static str,
}

pub const SCENES: [Scene; 6] = [
    Scene {
        name: "space",
        lat_deg: 45.65,
        lon_deg: 10.65,
        height: SceneHeight::AboveSphere(20_000_000.0),
        heading_deg: 0.0,
        pitch_deg: -90.0,
        stresses: "whole disk, coarsest levels only",
    },
    Scene {
        name: "aircraft",
        lat_deg: 45.65,
        lon_deg: 10.65,
        height: SceneHeight::AboveSphere(10_000.0),
        heading_deg: 315.0,
        pitch_deg: -20.0,
        stresses: "Alps to the horizon, many levels",
    },
    Scene {
        name: "ground",
        lat_deg: 45.65,
        lon_deg: 10.65,
        height: SceneHeight::AboveTerrain(2.0),
        heading_deg: 0.0,
        pitch_deg: -5.0,
        stresses: "finest levels, f32 limits, detail below data",
    },
    Scene {
        name: "north-pole",
        lat_deg: 90.0,
        lon_deg: 0.0,
        height: SceneHeight::AboveTerrain(100.0),
        heading_deg: 0.0,
        pitch_deg: -30.0,
        stresses: "the pole inside the view, seam meridian",
    },
    Scene {
        name: "antimeridian",
        lat_deg: 0.0,
        lon_deg: 180.0,
        height: SceneHeight::AboveSphere(1_000.0),
        heading_deg: 90.0,
        pitch_deg: -30.0,
        stresses: "φ wrap-around at ±180°",
    },
    Scene {
        name: "everest",
        lat_deg: 27.95,
        lon_deg: 86.90,
        height: SceneHeight::AboveSphere(9_000.0),
        heading_deg: 0.0,
        pitch_deg: -10.0,
        stresses: "steepest relief, horizon bound with mountains",
    },
];

/// The scene called `name`: the one lookup every command, the viewer and the benchmarks use.
pub fn find(name: &str) -> Result<&'static Scene, UnknownScene> {
    SCENES
        .iter()
        .find(|s| s.name == name)
        .ok_or_else(|| UnknownScene {
            name: name.to_owned(),
            known: SCENES.iter().map(|s| s.name).collect(),
        })
}

/// A name that is not in the registry, with the names that are.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown scene '{name}' (known: {})", known.join(", "))]
pub struct UnknownScene {
    pub name: String,
    /// The names accepted where the lookup failed.
    pub known: Vec<&'static str>,
}

impl UnknownScene {
    /// The same error where `more` names (e.g. `flight`, `jump` for `globe bench`) are accepted
    /// besides the scenes.
    pub fn also_known(mut self, more: &[&'static str]) -> Self {
        self.known.extend_from_slice(more);
        self
    }
}

impl Scene {
    /// The registry lookup as an Option (see [`find`] for the error naming the scenes).
    pub fn by_name(name: &str) -> Option<&'static Scene> {
        find(name).ok()
    }

    /// This scene as a view (roll 0).
    pub fn view(&self) -> CameraSpec {
        CameraSpec {
            lat_deg: self.lat_deg,
            lon_deg: self.lon_deg,
            height: self.height,
            heading_deg: self.heading_deg,
            pitch_deg: self.pitch_deg,
            roll_deg: 0.0,
        }
    }

    /// The camera of this scene over a terrain whose height at (lat, lon) is `terrain_m`.
    pub fn camera(&self, terrain_m: impl Fn(f64, f64) -> f64) -> Camera {
        self.view().camera(terrain_m)
    }

    pub fn height_label(&self) -> String {
        match self.height {
            SceneHeight::AboveSphere(h) => format!("{h} m"),
            SceneHeight::AboveTerrain(h) => format!("{h} m above terrain"),
        }
    }
}

/// The name `globe bench` and `globe report` give a `--camera` view in their outputs.
pub const CAMERA_VIEW_NAME: &str = "camera";

/// Suffix of a height above the sphere of radius R in the view text (`10000@sphere`); a bare
/// number (or `@terrain`) is above the terrain.
pub const SPHERE_SUFFIX: &str = "@sphere";
/// Optional suffix of a height above the terrain (the default).
pub const TERRAIN_SUFFIX: &str = "@terrain";

/// The form of the view text, for help and error messages.
pub const VIEW_SYNTAX: &str = "LAT,LON,HEIGHT,HEADING,PITCH[,ROLL]";

/// Any view: where the camera is and where it looks, with the scenes' field of view. Parsed
/// from `LAT,LON,HEIGHT,HEADING,PITCH[,ROLL]` (degrees and metres; HEIGHT above the terrain,
/// or above the sphere of radius R with the suffix `@sphere`), e.g. `45.65,10.65,500,90,-10`
/// or `27.95,86.90,9000@sphere,0,-10`. [`CameraSpec::new`] and parsing validate; the fields
/// are public for reading, and [`CameraSpec::validate`] checks one built by hand.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraSpec {
    /// Degrees north, [−90, 90].
    pub lat_deg: f64,
    /// Degrees east, [−360, 360] (the camera wraps it to (−180, 180]).
    pub lon_deg: f64,
    pub height: SceneHeight,
    /// Clockwise from north, degrees, any finite value.
    pub heading_deg: f64,
    /// Above the horizontal, degrees, [−90, 90]; −90 looks straight down.
    pub pitch_deg: f64,
    /// About the forward axis, degrees, any finite value; positive banks right.
    pub roll_deg: f64,
}

/// Which field of the view text a value belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ViewField {
    Latitude,
    Longitude,
    Height,
    Heading,
    Pitch,
    Roll,
}

impl ViewField {
    const ORDER: [ViewField; 6] = [
        Self::Latitude,
        Self::Longitude,
        Self::Height,
        Self::Heading,
        Self::Pitch,
        Self::Roll,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Self::Latitude => "latitude",
            Self::Longitude => "longitude",
            Self::Height => "height",
            Self::Heading => "heading",
            Self::Pitch => "pitch",
            Self::Roll => "roll",
        }
    }
}

impl fmt::Display for ViewField {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Why a view was refused; each names the value.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ViewError {
    #[error(
        "'{text}' has {count} comma-separated fields; expected 5 or 6: {VIEW_SYNTAX} \
         (degrees and metres; HEIGHT above the terrain, HEIGHT{SPHERE_SUFFIX} above the sphere)"
    )]
    FieldCount { text: String, count: usize },
    #[error("{field} '{value}' is not a number")]
    NotANumber { field: ViewField, value: String },
    #[error(
        "height '{value}': expected metres, optionally followed by {SPHERE_SUFFIX} (above the \
         sphere of radius R) or {TERRAIN_SUFFIX} (above the terrain, the default)"
    )]
    HeightReference { value: String },
    #[error("{field} {value} is not a finite number")]
    NotFinite { field: ViewField, value: f64 },
    #[error("latitude {0}° is outside [-90, 90]")]
    Latitude(f64),
    #[error("longitude {0}° is outside [-360, 360]")]
    Longitude(f64),
    #[error("pitch {0}° is outside [-90, 90] (-90 looks straight down)")]
    Pitch(f64),
    #[error(
        "height {height_m} m is below -R = -{radius_m} m: the camera would be past the \
         planet's centre"
    )]
    BelowCentre { height_m: f64, radius_m: f64 },
}

impl CameraSpec {
    /// A validated view on a planet of radius `radius_m`.
    pub fn new(
        lat_deg: f64,
        lon_deg: f64,
        height: SceneHeight,
        heading_deg: f64,
        pitch_deg: f64,
        roll_deg: f64,
        radius_m: f64,
    ) -> Result<Self, ViewError> {
        let spec = Self {
            lat_deg,
            lon_deg,
            height,
            heading_deg,
            pitch_deg,
            roll_deg,
        };
        spec.validate(radius_m)?;
        Ok(spec)
    }

    /// Parses `LAT,LON,HEIGHT,HEADING,PITCH[,ROLL]` (spaces around fields allowed) for a planet
    /// of radius `radius_m`.
    pub fn parse(text: &str, radius_m: f64) -> Result<Self, ViewError> {
        let fields: Vec<&str> = text.split(',').map(str::trim).collect();
        if !(5..=6).contains(&fields.len()) {
            return Err(ViewError::FieldCount {
                text: text.to_owned(),
                count: fields.len(),
            });
        }
        let number = |field: ViewField, value: &str| {
            value.parse::<f64>().map_err(|_| ViewError::NotANumber {
                field,
                value: value.to_owned(),
            })
        };
        let mut values = [0.0; 6];
        for (i, (field, value)) in ViewField::ORDER.into_iter().zip(&fields).enumerate() {
            if field != ViewField::Height {
                values[i] = number(field, value)?;
            }
        }
        let height = parse_height(fields[2])?;
        let [lat, lon, _, heading, pitch, roll] = values;
        Self::new(lat, lon, height, heading, pitch, roll, radius_m)
    }

    /// Checks every field (see the field docs); the height against −R of a planet of radius
    /// `radius_m` (above the terrain too: no terrain is R deep).
    pub fn validate(&self, radius_m: f64) -> Result<(), ViewError> {
        let height_m = match self.height {
            SceneHeight::AboveSphere(h) | SceneHeight::AboveTerrain(h) => h,
        };
        let fields = [
            (ViewField::Latitude, self.lat_deg),
            (ViewField::Longitude, self.lon_deg),
            (ViewField::Height, height_m),
            (ViewField::Heading, self.heading_deg),
            (ViewField::Pitch, self.pitch_deg),
            (ViewField::Roll, self.roll_deg),
        ];
        if let Some((field, value)) = fields.into_iter().find(|(_, v)| !v.is_finite()) {
            return Err(ViewError::NotFinite { field, value });
        }
        if !(-90.0..=90.0).contains(&self.lat_deg) {
            return Err(ViewError::Latitude(self.lat_deg));
        }
        if !(-360.0..=360.0).contains(&self.lon_deg) {
            return Err(ViewError::Longitude(self.lon_deg));
        }
        if !(-90.0..=90.0).contains(&self.pitch_deg) {
            return Err(ViewError::Pitch(self.pitch_deg));
        }
        if height_m <= -radius_m {
            return Err(ViewError::BelowCentre { height_m, radius_m });
        }
        Ok(())
    }

    /// The current view of `camera` (height above the sphere, so it comes back exactly).
    pub fn from_camera(camera: &Camera) -> Self {
        Self {
            lat_deg: camera.lat_deg,
            lon_deg: camera.lon_deg,
            height: SceneHeight::AboveSphere(camera.altitude_m),
            heading_deg: camera.heading_deg,
            pitch_deg: camera.pitch_deg,
            roll_deg: camera.roll_deg,
        }
    }

    /// The camera of this view over a terrain whose height at (lat, lon) is `terrain_m`.
    pub fn camera(&self, terrain_m: impl Fn(f64, f64) -> f64) -> Camera {
        let altitude_m = match self.height {
            SceneHeight::AboveSphere(h) => h,
            SceneHeight::AboveTerrain(h) => terrain_m(self.lat_deg, self.lon_deg) + h,
        };
        Camera {
            lat_deg: self.lat_deg,
            lon_deg: self.lon_deg,
            altitude_m,
            heading_deg: self.heading_deg,
            pitch_deg: self.pitch_deg,
            roll_deg: self.roll_deg,
            fov_y_deg: SCENE_FOV_Y_DEG,
        }
    }
}

fn parse_height(value: &str) -> Result<SceneHeight, ViewError> {
    let (number, wrap): (&str, fn(f64) -> SceneHeight) =
        if let Some(n) = value.strip_suffix(SPHERE_SUFFIX) {
            (n, SceneHeight::AboveSphere)
        } else if let Some(n) = value.strip_suffix(TERRAIN_SUFFIX) {
            (n, SceneHeight::AboveTerrain)
        } else if value.contains('@') {
            return Err(ViewError::HeightReference {
                value: value.to_owned(),
            });
        } else {
            (value, SceneHeight::AboveTerrain)
        };
    number
        .trim()
        .parse::<f64>()
        .map(wrap)
        .map_err(|_| ViewError::NotANumber {
            field: ViewField::Height,
            value: value.to_owned(),
        })
}

/// Parses for a planet of radius [`EARTH_RADIUS_M`] (every terrain of this program): what
/// `--camera` uses.
impl FromStr for CameraSpec {
    type Err = ViewError;

    fn from_str(text: &str) -> Result<Self, ViewError> {
        Self::parse(text, EARTH_RADIUS_M)
    }
}

/// The view text that parses back to this view (`{}` of f64 is exact); ROLL only when not 0.
impl fmt::Display for CameraSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let height = match self.height {
            SceneHeight::AboveSphere(h) => format!("{h}{SPHERE_SUFFIX}"),
            SceneHeight::AboveTerrain(h) => format!("{h}"),
        };
        write!(
            f,
            "{},{},{height},{},{}",
            self.lat_deg, self.lon_deg, self.heading_deg, self.pitch_deg
        )?;
        if self.roll_deg != 0.0 {
            write!(f, ",{}", self.roll_deg)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const R: f64 = EARTH_RADIUS_M;

    fn parse(text: &str) -> Result<CameraSpec, ViewError> {
        CameraSpec::parse(text, R)
    }

    #[test]
    fn find_returns_scenes_and_names_them_on_a_miss() {
        for scene in &SCENES {
            assert_eq!(find(scene.name).unwrap(), scene);
        }
        let e = find("nowhere").unwrap_err();
        assert_eq!(e.name, "nowhere");
        assert_eq!(e.known.len(), SCENES.len());
        assert_eq!(
            e.to_string(),
            "unknown scene 'nowhere' (known: space, aircraft, ground, north-pole, antimeridian, \
             everest)"
        );
        let e = e.also_known(&["flight"]);
        assert!(e.to_string().ends_with("everest, flight)"), "{e}");
    }

    #[test]
    fn parses_heights_above_terrain_and_sphere() {
        let v = parse("45.65,10.65,500,90,-10").unwrap();
        assert_eq!(
            v,
            CameraSpec {
                lat_deg: 45.65,
                lon_deg: 10.65,
                height: SceneHeight::AboveTerrain(500.0),
                heading_deg: 90.0,
                pitch_deg: -10.0,
                roll_deg: 0.0,
            }
        );
        let v = parse(" 27.95, 86.9 , 9000@sphere, 0, -10, 5 ").unwrap();
        assert_eq!(v.height, SceneHeight::AboveSphere(9000.0));
        assert_eq!(v.roll_deg, 5.0);
        assert_eq!(
            parse("0,0,2@terrain,0,0").unwrap().height,
            SceneHeight::AboveTerrain(2.0)
        );
        // Just above the centre and the limits of each range are accepted.
        assert!(parse(&format!("-90,-360,{}@sphere,-720,-90,1e3", 1.0 - R)).is_ok());
        assert!(parse("90,360,-11000,720,90").is_ok());
    }

    #[test]
    fn camera_of_a_view_uses_the_terrain_only_above_terrain() {
        let terrain = |_: f64, _: f64| 1234.0;
        let c = parse("10,20,100,30,-40,5").unwrap().camera(terrain);
        assert_eq!(
            (
                c.lat_deg,
                c.lon_deg,
                c.altitude_m,
                c.heading_deg,
                c.pitch_deg,
                c.roll_deg
            ),
            (10.0, 20.0, 1334.0, 30.0, -40.0, 5.0)
        );
        assert_eq!(c.fov_y_deg, SCENE_FOV_Y_DEG);
        let c = parse("10,20,100@sphere,30,-40").unwrap().camera(terrain);
        assert_eq!(c.altitude_m, 100.0);
        for scene in &SCENES {
            let c = scene.camera(terrain);
            assert_eq!(c, scene.view().camera(terrain));
            assert_eq!(c.roll_deg, 0.0);
        }
    }

    #[test]
    fn display_parses_back() {
        let mut views: Vec<CameraSpec> = SCENES.iter().map(Scene::view).collect();
        views.push(parse("-33.3,-70.1,0.001,359.5,12.25,-3").unwrap());
        let camera = SCENES[1].camera(|_, _| 0.0);
        views.push(CameraSpec::from_camera(&camera));
        for v in views {
            let text = v.to_string();
            assert_eq!(parse(&text).unwrap(), v, "{text}");
        }
        assert_eq!(SCENES[5].view().to_string(), "27.95,86.9,9000@sphere,0,-10");
        assert_eq!(
            CameraSpec::from_camera(&camera).camera(|_, _| f64::NAN),
            camera
        );
    }

    #[test]
    fn wrong_field_counts_are_refused() {
        for (text, count) in [("", 1), ("1,2,3,4", 4), ("1,2,3,4,5,6,7", 7)] {
            let e = parse(text).unwrap_err();
            assert_eq!(
                e,
                ViewError::FieldCount {
                    text: text.into(),
                    count
                }
            );
            let message = e.to_string();
            assert!(
                message.contains(&format!("'{text}' has {count}")),
                "{message}"
            );
            assert!(message.contains(VIEW_SYNTAX), "{message}");
        }
    }

    #[test]
    fn non_numbers_name_their_field() {
        let cases = [
            ("abc,0,10,0,0", ViewField::Latitude, "abc"),
            ("0,east,10,0,0", ViewField::Longitude, "east"),
            ("0,0,10m,0,0", ViewField::Height, "10m"),
            ("0,0,,0,0", ViewField::Height, ""),
            ("0,0,x@sphere,0,0", ViewField::Height, "x@sphere"),
            ("0,0,10,north,0", ViewField::Heading, "north"),
            ("0,0,10,0,1e", ViewField::Pitch, "1e"),
            ("0,0,10,0,0,r", ViewField::Roll, "r"),
        ];
        for (text, field, value) in cases {
            let e = parse(text).unwrap_err();
            assert_eq!(
                e,
                ViewError::NotANumber {
                    field,
                    value: value.into()
                },
                "{text}"
            );
            assert_eq!(e.to_string(), format!("{field} '{value}' is not a number"));
        }
        let e = parse("0,0,10@moon,0,0").unwrap_err();
        assert_eq!(
            e,
            ViewError::HeightReference {
                value: "10@moon".into()
            }
        );
        assert!(
            e.to_string()
                .starts_with("height '10@moon': expected metres")
        );
    }

    #[test]
    fn nan_and_infinity_are_refused_in_every_field() {
        for (i, field) in ViewField::ORDER.into_iter().enumerate() {
            for bad in ["NaN", "inf", "-infinity"] {
                let mut fields = ["1", "2", "3", "4", "5", "6"];
                fields[i] = bad;
                let text = fields.join(",");
                let e = parse(&text).unwrap_err();
                let ViewError::NotFinite { field: f, value } = e else {
                    panic!("{text}: {e:?}");
                };
                assert_eq!(f, field, "{text}");
                assert!(!value.is_finite());
                assert!(e.to_string().starts_with(&format!("{field} ")), "{e}");
                assert!(e.to_string().ends_with("is not a finite number"), "{e}");
            }
        }
        let e = parse("0,0,NaN@sphere,0,0").unwrap_err();
        assert!(matches!(
            e,
            ViewError::NotFinite {
                field: ViewField::Height,
                ..
            }
        ));
    }

    #[test]
    fn out_of_range_values_are_named() {
        let e = parse("91,0,10,0,0").unwrap_err();
        assert_eq!(e, ViewError::Latitude(91.0));
        assert_eq!(e.to_string(), "latitude 91° is outside [-90, 90]");
        assert_eq!(
            parse("-90.5,0,10,0,0").unwrap_err(),
            ViewError::Latitude(-90.5)
        );
        assert_eq!(
            parse("0,400,10,0,0").unwrap_err(),
            ViewError::Longitude(400.0)
        );
        let e = parse("0,0,10,0,-91").unwrap_err();
        assert_eq!(e, ViewError::Pitch(-91.0));
        assert!(e.to_string().starts_with("pitch -91° is outside"));
        for height in ["-7000000", "-7000000@sphere", "-6371000@sphere"] {
            let e = parse(&format!("0,0,{height},0,0")).unwrap_err();
            let ViewError::BelowCentre { height_m, radius_m } = e else {
                panic!("{height}: {e:?}");
            };
            assert_eq!(radius_m, R);
            assert!(height.starts_with(&height_m.to_string()));
            assert!(
                e.to_string()
                    .starts_with(&format!("height {height_m} m is below -R = -6371000 m")),
                "{e}"
            );
        }
        // The radius is the planet's: −R of a small planet is not −R of the Earth.
        assert!(CameraSpec::parse("0,0,-2000@sphere,0,0", 1000.0).is_err());
        // A view built by hand is checked the same way.
        let bad = CameraSpec {
            lat_deg: 91.0,
            ..SCENES[0].view()
        };
        assert_eq!(bad.validate(R), Err(ViewError::Latitude(91.0)));
        assert!(matches!(
            CameraSpec::new(
                0.0,
                0.0,
                SceneHeight::AboveTerrain(1.0),
                0.0,
                0.0,
                f64::NAN,
                R
            ),
            Err(ViewError::NotFinite {
                field: ViewField::Roll,
                ..
            })
        ));
    }
}
