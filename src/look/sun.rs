//! Where the sun stands (issue 38's sun and time): by default a fixed sun in every viewer's
//! own sky (35° above the south-east horizon, so every view is lit from the same side), or the
//! real sun at a moment, fixed in the Earth's frame, so a sunset over the Alps is one flag.
//!
//! The sun's apparent right ascension α and declination δ follow Jean Meeus, *Astronomical
//! Algorithms* (2nd ed., 1998), chapter 25's low-accuracy method (about 0.01°): the geometric
//! mean longitude L₀ and mean anomaly M (eq. 25.2–25.3), the equation of the centre C, the
//! apparent longitude λ = L₀ + C − 0.00569° − 0.00478° sin Ω, the obliquity ε (eq. 22.2 plus
//! 0.00256° cos Ω), then tan α = cos ε sin λ / cos λ and sin δ = sin ε sin λ (eq. 25.6–25.7).
//! The Earth's rotation is Greenwich mean sidereal time θ₀ (eq. 12.4). The sub-solar point is
//! then at latitude δ and longitude α − θ₀. Time is UTC taken as UT and TT alike: ΔT (about
//! 69 s) moves the sun by under 0.001° along its path, and UT1 − UTC (under 0.9 s) turns the
//! Earth by under 0.004°.

use glam::DVec3;

use crate::geo::sphere;

/// The viewer-relative sun's elevation and azimuth (clockwise from north), degrees.
pub const FIXED_SUN_ELEVATION_DEG: f64 = 35.0;
pub const FIXED_SUN_AZIMUTH_DEG: f64 = 135.0;

/// Which sun lights the planet.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Sun {
    /// The same sun in every viewer's sky: 35° above the south-east horizon.
    #[default]
    Fixed,
    /// The real sun at this moment.
    At(Utc),
}

/// A moment in UTC, whole seconds since 1970-01-01T00:00:00Z.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct Utc {
    pub unix_s: i64,
}

/// A time that cannot be read.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum TimeError {
    #[error(
        "'{0}': expected a UTC time as YYYY-MM-DDTHH:MMZ (or with :SS), e.g. 2026-06-21T19:30Z"
    )]
    Form(String),
    #[error("'{text}': {field} {value} is outside {range}")]
    Field {
        text: String,
        field: &'static str,
        value: i64,
        range: &'static str,
    },
}

/// Days from 1970-01-01 to the proleptic Gregorian date (Howard Hinnant's `days_from_civil`).
fn days_from_civil(y: i64, m: i64, d: i64) -> i64 {
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let mp = (m + 9) % 12;
    let doy = (153 * mp + 2) / 5 + d - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

fn days_in_month(y: i64, m: i64) -> i64 {
    match m {
        2 if (y % 4 == 0 && y % 100 != 0) || y % 400 == 0 => 29,
        2 => 28,
        4 | 6 | 9 | 11 => 30,
        _ => 31,
    }
}

impl Utc {
    /// Reads `YYYY-MM-DDTHH:MMZ` or `YYYY-MM-DDTHH:MM:SSZ` (a space may stand for the `T`).
    pub fn parse(text: &str) -> Result<Self, TimeError> {
        let form = || TimeError::Form(text.to_string());
        let body = text.trim().strip_suffix(['Z', 'z']).ok_or_else(form)?;
        let (date, time) = body.split_once(['T', 't', ' ']).ok_or_else(form)?;
        let number = |s: &str, digits: usize| -> Result<i64, TimeError> {
            if s.len() != digits || !s.bytes().all(|b| b.is_ascii_digit()) {
                return Err(form());
            }
            s.parse().map_err(|_| form())
        };
        let d: Vec<&str> = date.split('-').collect();
        let t: Vec<&str> = time.split(':').collect();
        if d.len() != 3 || !(2..=3).contains(&t.len()) {
            return Err(form());
        }
        let (year, month, day) = (number(d[0], 4)?, number(d[1], 2)?, number(d[2], 2)?);
        let (hour, minute) = (number(t[0], 2)?, number(t[1], 2)?);
        let second = if t.len() == 3 { number(t[2], 2)? } else { 0 };
        let field = |field, value, ok: bool, range| {
            if ok {
                Ok(())
            } else {
                Err(TimeError::Field {
                    text: text.to_string(),
                    field,
                    value,
                    range,
                })
            }
        };
        field("month", month, (1..=12).contains(&month), "1…12")?;
        let days = days_in_month(year, month);
        field("day", day, (1..=days).contains(&day), "the month's days")?;
        field("hour", hour, (0..=23).contains(&hour), "0…23")?;
        field("minute", minute, (0..=59).contains(&minute), "0…59")?;
        field("second", second, (0..=59).contains(&second), "0…59")?;
        let unix_s =
            days_from_civil(year, month, day) * 86_400 + hour * 3600 + minute * 60 + second;
        Ok(Self { unix_s })
    }

    /// Midnight UTC of January 1 of `year`, plus `day_of_year − 1` days and `seconds`.
    pub fn from_year_day(year: i64, day_of_year: i64, seconds: i64) -> Self {
        Self {
            unix_s: (days_from_civil(year, 1, 1) + day_of_year - 1) * 86_400 + seconds,
        }
    }

    /// The year, the day of the year (1 on January 1) and the seconds into the day.
    pub fn year_day(self) -> (i64, i64, i64) {
        let (midnight, seconds) = self.split_day();
        let year: i64 = midnight.to_string()[..4].parse().unwrap_or(1970);
        let day = midnight.unix_s / 86_400 - days_from_civil(year, 1, 1) + 1;
        (year, day, seconds)
    }

    /// The Julian day (Meeus ch. 7): 2 440 587.5 at the Unix epoch.
    pub fn julian_day(self) -> f64 {
        2_440_587.5 + self.unix_s as f64 / 86_400.0
    }

    /// Seconds into the UTC day, and the day's midnight.
    pub fn split_day(self) -> (Utc, i64) {
        let day = self.unix_s.div_euclid(86_400);
        (
            Utc {
                unix_s: day * 86_400,
            },
            self.unix_s - day * 86_400,
        )
    }
}

impl std::fmt::Display for Utc {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // Inverse of days_from_civil (Hinnant's `civil_from_days`).
        let z = self.unix_s.div_euclid(86_400) + 719_468;
        let secs = self.unix_s.rem_euclid(86_400);
        let era = z.div_euclid(146_097);
        let doe = z - era * 146_097;
        let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
        let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
        let mp = (5 * doy + 2) / 153;
        let d = doy - (153 * mp + 2) / 5 + 1;
        let m = if mp < 10 { mp + 3 } else { mp - 9 };
        let y = yoe + era * 400 + i64::from(m <= 2);
        write!(
            f,
            "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
            secs / 3600,
            secs / 60 % 60,
            secs % 60
        )
    }
}

/// The sun's apparent right ascension and declination, degrees, at Julian day `jd` (Meeus
/// ch. 25, low accuracy; `jd` in TT, for which UTC stands here).
pub fn right_ascension_declination_deg(jd: f64) -> (f64, f64) {
    let t = (jd - 2_451_545.0) / 36_525.0;
    let l0 = 280.466_46 + 36_000.769_83 * t + 0.000_303_2 * t * t;
    let m = (357.529_11 + 35_999.050_29 * t - 0.000_153_7 * t * t).to_radians();
    let c = (1.914_602 - 0.004_817 * t - 0.000_014 * t * t) * m.sin()
        + (0.019_993 - 0.000_101 * t) * (2.0 * m).sin()
        + 0.000_289 * (3.0 * m).sin();
    let omega = (125.04 - 1934.136 * t).to_radians();
    let lambda = (l0 + c - 0.005_69 - 0.004_78 * omega.sin()).to_radians();
    // ε₀ = 23°26′21.448″ − 46.8150″T − 0.00059″T² + 0.001813″T³ (eq. 22.2).
    let eps0 =
        23.0 + 26.0 / 60.0 + (21.448 - t * (46.815 + t * (0.000_59 - 0.001_813 * t))) / 3600.0;
    let eps = (eps0 + 0.002_56 * omega.cos()).to_radians();
    let alpha = (eps.cos() * lambda.sin()).atan2(lambda.cos());
    let delta = (eps.sin() * lambda.sin()).asin();
    (alpha.to_degrees().rem_euclid(360.0), delta.to_degrees())
}

/// Greenwich mean sidereal time, degrees in [0, 360), at Julian day `jd` in UT (Meeus eq. 12.4).
pub fn greenwich_sidereal_deg(jd: f64) -> f64 {
    let t = (jd - 2_451_545.0) / 36_525.0;
    (280.460_618_37 + 360.985_647_366_29 * (jd - 2_451_545.0) + 0.000_387_933 * t * t
        - t * t * t / 38_710_000.0)
        .rem_euclid(360.0)
}

/// The sub-solar point at `utc`: (latitude, longitude) in degrees, longitude in (−180, 180].
pub fn subsolar_lat_lon_deg(utc: Utc) -> (f64, f64) {
    let jd = utc.julian_day();
    let (alpha, delta) = right_ascension_declination_deg(jd);
    let lon =
        sphere::wrap_angle_rad((alpha - greenwich_sidereal_deg(jd)).to_radians()).to_degrees();
    (delta, lon)
}

/// The unit vector toward the sun at `utc` in the Earth-fixed world frame (x toward 0° E on
/// the equator, z toward the north pole; the sun's parallax, under 0.003°, is left out).
pub fn sun_world(utc: Utc) -> DVec3 {
    let (lat, lon) = subsolar_lat_lon_deg(utc);
    let (phi, theta) = sphere::phi_theta_from_lat_lon_deg(lat, lon);
    sphere::unit_vector(phi, theta)
}

impl Sun {
    /// The unit vector toward the sun in the view space of a viewer whose frame is
    /// `world_from_view` (columns: south, east, up at the viewer).
    pub fn view_direction(self, world_from_view: glam::DMat3) -> DVec3 {
        match self {
            Sun::Fixed => {
                let (el, az) = (
                    FIXED_SUN_ELEVATION_DEG.to_radians(),
                    FIXED_SUN_AZIMUTH_DEG.to_radians(),
                );
                // Local east-north-up → view space: east = ỹ, north = −x̃, up = z̃.
                DVec3::new(-el.cos() * az.cos(), el.cos() * az.sin(), el.sin())
            }
            Sun::At(utc) => world_from_view.transpose() * sun_world(utc),
        }
    }

    /// The sun's elevation above the horizon at (lat, lon), degrees (no refraction).
    pub fn elevation_deg(self, lat_deg: f64, lon_deg: f64) -> f64 {
        let (phi, theta) = sphere::phi_theta_from_lat_lon_deg(lat_deg, lon_deg);
        let up = sphere::unit_vector(phi, theta);
        match self {
            Sun::Fixed => FIXED_SUN_ELEVATION_DEG,
            Sun::At(utc) => sun_world(utc).dot(up).clamp(-1.0, 1.0).asin().to_degrees(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn angle_deg(a: f64, b: f64) -> f64 {
        sphere::wrap_angle_rad((a - b).to_radians())
            .to_degrees()
            .abs()
    }

    #[test]
    fn times_read_and_write_back() {
        for text in [
            "1970-01-01T00:00:00Z",
            "2024-02-29T23:59:59Z",
            "1899-12-31T12:00:00Z",
        ] {
            assert_eq!(Utc::parse(text).unwrap().to_string(), text);
        }
        assert_eq!(Utc::parse("1970-01-02T00:00Z").unwrap().unix_s, 86_400);
        let t = Utc::parse("2024-12-31T18:30:05Z").unwrap();
        assert_eq!(t.year_day(), (2024, 366, 18 * 3600 + 30 * 60 + 5));
        assert_eq!(Utc::from_year_day(2024, 366, 66_605), t);
        // J2000.0 is JD 2451545.0: 2000-01-01 12:00 TT (here UTC).
        let j2000 = Utc::parse("2000-01-01T12:00Z").unwrap();
        assert_eq!(j2000.julian_day(), 2_451_545.0);
        for bad in [
            "2024-13-01T00:00Z",
            "2023-02-29T00:00Z",
            "2024-01-01T24:00Z",
            "2024-01-01T12:00",
        ] {
            assert!(Utc::parse(bad).is_err(), "{bad}");
        }
        let e = Utc::parse("2023-02-29T10:00Z").unwrap_err().to_string();
        assert!(e.contains("day 29"), "{e}");
    }

    /// Meeus's Example 25.a: 1992 October 13.0 TD, α = 198.38083°, δ = −7.78507°.
    #[test]
    fn meeus_example_25a() {
        let jd = 2_448_908.5;
        let (alpha, delta) = right_ascension_declination_deg(jd);
        assert!(angle_deg(alpha, 198.380_83) < 0.001, "α {alpha}");
        assert!((delta + 7.785_07).abs() < 0.001, "δ {delta}");
    }

    /// Meeus's Examples 12.a and 12.b: 1987 April 10 at 0h UT θ₀ = 13h10m46.3668s, at
    /// 19h21m00s UT θ₀ = 8h34m57.0896s.
    #[test]
    fn meeus_examples_12a_12b() {
        let hms = |h: f64, m: f64, s: f64| 15.0 * (h + m / 60.0 + s / 3600.0);
        let midnight = Utc::parse("1987-04-10T00:00Z").unwrap();
        assert!(
            angle_deg(
                greenwich_sidereal_deg(midnight.julian_day()),
                hms(13.0, 10.0, 46.3668)
            ) < 1e-5
        );
        let evening = Utc::parse("1987-04-10T19:21:00Z").unwrap();
        assert!(
            angle_deg(
                greenwich_sidereal_deg(evening.julian_day()),
                hms(8.0, 34.0, 57.0896)
            ) < 1e-5
        );
    }

    /// The seasons of 2024 as the U.S. Naval Observatory lists them (Earth's Seasons and
    /// Apsides, UTC to the minute): the sun over the equator at the March equinox, over the
    /// tropics at the solstices, within 0.01°.
    #[test]
    fn the_seasons_of_2024() {
        let eps = 23.4362; // the obliquity in 2024 (eq. 22.2 at T = 0.24)
        for (time, lat) in [
            ("2024-03-20T03:06Z", 0.0),
            ("2024-06-20T20:51Z", eps),
            ("2024-09-22T12:44Z", 0.0),
            ("2024-12-21T09:20Z", -eps),
        ] {
            let (sub_lat, _) = subsolar_lat_lon_deg(Utc::parse(time).unwrap());
            assert!((sub_lat - lat).abs() < 0.01, "{time}: {sub_lat}");
        }
    }

    /// At 12:00 UTC the sun stands over 0° E but for the equation of time (at most 16.5 min,
    /// 4.1°); at the March equinox the sub-solar point's longitude is −θ₀ + α with α ≈ 0.
    #[test]
    fn noon_at_greenwich() {
        for day in ["2024-01-15", "2024-04-15", "2024-07-15", "2024-11-03"] {
            let (_, lon) = subsolar_lat_lon_deg(Utc::parse(&format!("{day}T12:00Z")).unwrap());
            assert!(lon.abs() < 4.2, "{day}: {lon}");
        }
        // The equation of time near its November maximum is +16.4 min: the sun crosses 0° E
        // 16.4 min before noon, so at noon it stands 4.1° west.
        let (_, lon) = subsolar_lat_lon_deg(Utc::parse("2024-11-03T12:00Z").unwrap());
        assert!((lon + 4.1).abs() < 0.1, "{lon}");
    }

    /// The fixed sun is the same in every view; the real one is fixed in the world.
    #[test]
    fn the_view_direction() {
        let frame = crate::geo::camera::Camera {
            lat_deg: 46.0,
            lon_deg: 8.0,
            altitude_m: 100.0,
            heading_deg: 0.0,
            pitch_deg: 0.0,
            roll_deg: 0.0,
            fov_y_deg: 60.0,
        }
        .view_frame()
        .world_from_view;
        let fixed = Sun::Fixed.view_direction(frame);
        assert!((fixed.z - FIXED_SUN_ELEVATION_DEG.to_radians().sin()).abs() < 1e-12);
        let t = Utc::parse("2024-06-20T20:51Z").unwrap();
        let v = Sun::At(t).view_direction(frame);
        assert!((frame * v - sun_world(t)).length() < 1e-12);
        assert!((v.z.asin().to_degrees() - Sun::At(t).elevation_deg(46.0, 8.0)).abs() < 1e-9);
    }
}
