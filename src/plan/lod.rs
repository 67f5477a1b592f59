//! The LOD methods behind one trait: what each has the clipmap fill, what it draws near the
//! viewer and what the clipmap draws beside it, so a frame's plan asks the method (`--mode`)
//! instead of branching on it. Each method's plan is f64 ([`super::geomip`],
//! [`super::projgrid`]); `render::planar` encodes whichever [`CloseUpPlan`] comes out.

use crate::planar::geomip::GeomipSettings;
use crate::planar::projgrid::ProjGridSettings;

use super::{ClipmapPlan, GeomipPlan, GeomipState, LodMode, LodSettings, ProjGridPlan};
use super::{TerrainQuery, ViewPlan};

/// What a close-up method draws this frame (f64), for the renderer to encode.
#[derive(Clone, Debug, PartialEq)]
pub enum CloseUpPlan {
    /// Geomipmapping's patches around the nadir; the clipmap draws outside their square.
    Geomip(GeomipPlan),
    /// The projected grid over the whole view, its cells above γ ray cast when `ray_cast`.
    Grid { plan: ProjGridPlan, ray_cast: bool },
}

/// A level-of-detail method: the spherical clipmap alone, or a close-up method with it.
pub trait LodMethod: Send {
    /// Whether the clipmap fills only the levels in view. A close-up method samples the
    /// levels around the nadir whether or not they are in view, so it fills them all.
    fn fills_only_levels_in_view(&self) -> bool;
    /// The close-up's plan for this frame (None: the clipmap alone draws), built from the
    /// levels just filled; tells the clipmap how far the close-up covers (`clipmap`'s cut).
    fn plan_close_up(
        &mut self,
        view: &ViewPlan,
        query: &dyn TerrainQuery,
        clipmap: &mut ClipmapPlan,
    ) -> Option<CloseUpPlan>;
    /// Whether the clipmap's levels draw: the projected grid covers the whole view (the levels
    /// still fill the textures it samples).
    fn clipmap_draws(&self) -> bool {
        true
    }
}

/// The method `lod.mode` names, fresh (no state from earlier frames).
pub fn method(lod: &LodSettings) -> Box<dyn LodMethod> {
    match lod.mode {
        LodMode::Clipmap => Box::new(ClipmapAlone),
        LodMode::Geomip => Box::new(Geomip::new(lod.geomip, false)),
        LodMode::Auto => Box::new(Geomip::new(lod.geomip, true)),
        LodMode::Projgrid => Box::new(ProjGrid(lod.projgrid)),
    }
}

/// The spherical clipmap alone (spherical-clipmaps.md).
struct ClipmapAlone;

impl LodMethod for ClipmapAlone {
    fn fills_only_levels_in_view(&self) -> bool {
        true
    }
    fn plan_close_up(
        &mut self,
        _: &ViewPlan,
        _: &dyn TerrainQuery,
        _: &mut ClipmapPlan,
    ) -> Option<CloseUpPlan> {
        None
    }
}

/// Geomipmapping with geomorphing near the viewer (geomipmapping-geomorphing.md), the clipmap beyond;
/// with `auto`, only below [`super::AUTO_ON_BELOW_M`] above the terrain (with hysteresis).
struct Geomip {
    settings: GeomipSettings,
    state: GeomipState,
    auto: bool,
    /// Whether it drew the frame before (`auto`'s hysteresis).
    was_on: bool,
}

impl Geomip {
    fn new(settings: GeomipSettings, auto: bool) -> Self {
        Self {
            settings,
            state: GeomipState::default(),
            auto,
            was_on: false,
        }
    }
}

impl LodMethod for Geomip {
    fn fills_only_levels_in_view(&self) -> bool {
        false
    }
    fn plan_close_up(
        &mut self,
        view: &ViewPlan,
        query: &dyn TerrainQuery,
        clipmap: &mut ClipmapPlan,
    ) -> Option<CloseUpPlan> {
        let mode = if self.auto {
            LodMode::Auto
        } else {
            LodMode::Geomip
        };
        self.was_on = mode.planar(view.height_above_terrain_m, self.was_on);
        if !self.was_on {
            return None;
        }
        let plan = self.state.plan(view, &self.settings, query);
        clipmap.covered_rad = plan.covered_rad;
        clipmap.cut_rad = plan.cut_reach_rad;
        Some(CloseUpPlan::Geomip(plan))
    }
}

/// The error-bounded projected grid over the whole view (error-bounded-projective-grid.md).
struct ProjGrid(ProjGridSettings);

impl LodMethod for ProjGrid {
    fn fills_only_levels_in_view(&self) -> bool {
        false
    }
    fn plan_close_up(
        &mut self,
        view: &ViewPlan,
        query: &dyn TerrainQuery,
        _: &mut ClipmapPlan,
    ) -> Option<CloseUpPlan> {
        Some(CloseUpPlan::Grid {
            plan: super::projgrid::plan(view, &self.0, query),
            ray_cast: self.0.ray_cast,
        })
    }
    fn clipmap_draws(&self) -> bool {
        false
    }
}
