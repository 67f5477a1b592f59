//! Named detail parameter sets shipped inside the binary (`assets/detail/*.json`, embedded so
//! they work from any directory): starting points for the editor (`ui::editor`) and for
//! `--detail FILE` (the same files).
//!
//! | preset | what makes the name true |
//! | --- | --- |
//! | `default` | [`DetailParams::default`] |
//! | `alpine` | rough (H 0.7), high amplitude (up to 1.5 km), strong height-dependent roughness (g_h 0.7): peaks rougher than valleys |
//! | `dunes` | smooth (H 1), little height-dependent roughness (g_h 0.05), strong warping (lever 6 cells, large c1–c3): long curved ridges |
//! | `rolling hills` | smooth (H 0.95), low amplitude (up to 120 m), gentle |

use std::path::PathBuf;

use super::{DetailError, DetailParams};

/// One shipped parameter file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Preset {
    pub name: &'static str,
    /// The file's path in the repository (for messages).
    pub file: &'static str,
    pub json: &'static str,
}

/// Every preset, `default` first.
pub const PRESETS: [Preset; 4] = [
    Preset {
        name: "default",
        file: "assets/detail/default.json",
        json: include_str!("../../assets/detail/default.json"),
    },
    Preset {
        name: "alpine",
        file: "assets/detail/alpine.json",
        json: include_str!("../../assets/detail/alpine.json"),
    },
    Preset {
        name: "dunes",
        file: "assets/detail/dunes.json",
        json: include_str!("../../assets/detail/dunes.json"),
    },
    Preset {
        name: "rolling hills",
        file: "assets/detail/rolling-hills.json",
        json: include_str!("../../assets/detail/rolling-hills.json"),
    },
];

impl Preset {
    /// The preset's parameters, parsed and validated as a detail file is.
    pub fn params(&self) -> Result<DetailParams, DetailError> {
        DetailParams::parse(self.json, &PathBuf::from(self.file))
    }
}

/// The preset called `name`.
pub fn find(name: &str) -> Option<&'static Preset> {
    PRESETS.iter().find(|p| p.name == name)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(name: &str) -> DetailParams {
        find(name)
            .unwrap_or_else(|| panic!("no preset {name}"))
            .params()
            .unwrap_or_else(|e| panic!("preset {name}: {e}"))
    }

    /// Every preset parses (unknown fields refused) and validates.
    #[test]
    fn presets_load_and_validate() {
        for preset in &PRESETS {
            let p = preset.params().unwrap_or_else(|e| panic!("{e}"));
            p.validate(preset.file).unwrap();
            assert!(p.relief_paint.is_empty(), "{}", preset.name);
        }
        assert_eq!(params("default"), DetailParams::default());
    }

    /// The values make the names true (relative to the default).
    #[test]
    fn presets_are_what_their_names_say() {
        let d = DetailParams::default();
        let alpine = params("alpine");
        assert!(alpine.hurst < d.hurst, "alpine is rougher");
        assert!(alpine.amplitude_max_m > 2.0 * d.amplitude_max_m);
        assert!(alpine.roughness_gain > d.roughness_gain);
        assert!(alpine.height_roughness > 2.0 * d.height_roughness);
        let dunes = params("dunes");
        assert!(dunes.hurst > d.hurst, "dunes are smooth");
        assert!(dunes.height_roughness < 0.5 * d.height_roughness);
        assert!(
            dunes.warp.lever_cells > 4.0 * d.warp.lever_cells,
            "dunes are warped"
        );
        let norm = |c: [f64; 2]| c[0].hypot(c[1]);
        assert!(norm(dunes.warp.c1) > 2.0 * norm(d.warp.c1));
        let hills = params("rolling hills");
        assert!(hills.hurst > d.hurst, "hills are smooth");
        assert!(
            hills.amplitude_max_m < 0.5 * d.amplitude_max_m,
            "hills are low"
        );
        assert!(hills.amplitude_min_m < d.amplitude_min_m);
        assert!(hills.height_roughness < d.height_roughness);
    }
}
