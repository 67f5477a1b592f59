//! What a user may ask of the streaming (`--tile-latency-ms`, `--tile-fail-rate`,
//! `--max-in-flight`, `--uploads-per-frame`), checked here so that a test reaches the same rule
//! the command line applies, and every refusal names the flag and the smallest value that works.

use super::{FaultSettings, StreamSettings};

/// Settings the streamer could never finish a view with.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StreamSettingsError {
    #[error("--tile-fail-rate must be between 0 and 1 (got {0})")]
    FailRateRange(f64),
    #[error("--tile-fail-rate 1 would fail every read: no tile could ever load")]
    FailRateOne,
    #[error("--max-in-flight 0 would never read a tile: the smallest that works is 1")]
    NoReads,
    #[error(
        "--uploads-per-frame 0 would never upload a tile to the GPU: the smallest that works is 1"
    )]
    NoUploads,
}

impl StreamSettings {
    /// Checks the settings a view could never complete with. `gpu_tiles` has no fixed
    /// smallest value (it depends on the view: the renderer names it on the view's first
    /// frames, `GpuTilesShort`) and `cache_bytes` none at all (the LRU keeps what the frame in
    /// progress needs even beyond its budget).
    pub fn validate(&self) -> Result<(), StreamSettingsError> {
        let fail_rate = self.faults.fail_rate;
        if !(0.0..=1.0).contains(&fail_rate) {
            return Err(StreamSettingsError::FailRateRange(fail_rate));
        }
        if fail_rate >= 1.0 {
            return Err(StreamSettingsError::FailRateOne);
        }
        if self.max_in_flight == 0 {
            return Err(StreamSettingsError::NoReads);
        }
        if self.uploads_per_frame == 0 {
            return Err(StreamSettingsError::NoUploads);
        }
        Ok(())
    }
}

/// A tile read's added latency (`--tile-latency-ms`): fixed (`MS`), or drawn per read from a
/// range (`MIN-MAX`), in whole milliseconds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LatencyMs {
    pub min: u64,
    pub max: u64,
}

impl LatencyMs {
    /// The latency `faults` injects.
    pub fn of(faults: &FaultSettings) -> Self {
        Self {
            min: faults.latency_ms,
            max: faults.latency_max_ms.max(faults.latency_ms),
        }
    }
}

impl std::fmt::Display for LatencyMs {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.max > self.min {
            write!(f, "{}-{}", self.min, self.max)
        } else {
            write!(f, "{}", self.min)
        }
    }
}

impl std::str::FromStr for LatencyMs {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, String> {
        let number = |t: &str| {
            t.trim()
                .parse::<u64>()
                .map_err(|_| format!("`{text}` is not MS or MIN-MAX in whole milliseconds"))
        };
        match text.split_once('-') {
            None => number(text).map(|ms| LatencyMs { min: ms, max: ms }),
            Some((a, b)) => {
                let (min, max) = (number(a)?, number(b)?);
                if max < min {
                    return Err(format!(
                        "`{text}`: the range's maximum is below its minimum"
                    ));
                }
                Ok(LatencyMs { min, max })
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_no_view_could_complete_are_refused_by_name() {
        assert_eq!(StreamSettings::default().validate(), Ok(()));
        let with = |f: fn(&mut StreamSettings)| {
            let mut s = StreamSettings::default();
            f(&mut s);
            s.validate().unwrap_err().to_string()
        };
        assert!(with(|s| s.max_in_flight = 0).contains("--max-in-flight 0"));
        assert!(with(|s| s.uploads_per_frame = 0).contains("--uploads-per-frame 0"));
        assert!(with(|s| s.faults.fail_rate = 1.0).contains("--tile-fail-rate 1"));
        assert!(with(|s| s.faults.fail_rate = -0.1).contains("between 0 and 1"));
        assert!(with(|s| s.faults.fail_rate = f64::NAN).contains("between 0 and 1"));
        // The smallest that works is accepted.
        let mut s = StreamSettings::default();
        (s.max_in_flight, s.uploads_per_frame, s.faults.fail_rate) = (1, 1, 0.999);
        assert_eq!(s.validate(), Ok(()));
    }

    #[test]
    fn latencies_parse_as_the_flag_takes_them_and_print_back() {
        for (text, min, max) in [
            ("0", 0, 0),
            ("250", 250, 250),
            ("0-200", 0, 200),
            (" 5 - 9", 5, 9),
        ] {
            let l: LatencyMs = text.parse().unwrap();
            assert_eq!((l.min, l.max), (min, max), "{text}");
            assert_eq!(l.to_string().parse::<LatencyMs>(), Ok(l));
        }
        for bad in ["", "x", "-5", "5-", "9-5", "1.5"] {
            assert!(bad.parse::<LatencyMs>().is_err(), "{bad:?} accepted");
        }
        assert!(
            "9-5"
                .parse::<LatencyMs>()
                .unwrap_err()
                .contains("maximum is below")
        );
        let faults = FaultSettings {
            latency_ms: 7,
            latency_max_ms: 3,
            ..Default::default()
        };
        assert_eq!(LatencyMs::of(&faults), LatencyMs { min: 7, max: 7 });
    }
}
