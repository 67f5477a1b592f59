//! Which levels the clipmap draws this frame: the visible levels (spherical-clipmaps.md §4.5,
//! eq. 5–8) and why each other one is not drawn. The φ̃ sectors inside the view frustum are
//! `clipmap::draw_list`'s.

use std::ops::Range;

use super::settings::level_outer_theta_rad;

/// Why a level is or is not drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LevelStatus {
    Drawn,
    /// All of the level lies beyond θ̃max (eq. 6 with the mountain safety term): hidden by the
    /// planet's curvature.
    BeyondHorizon,
    /// The whole level lies inside θ̃min (eq. 8): it would cover less than one pixel below the
    /// viewer, so the cap of the next coarser level stands in for it.
    SubPixel,
    /// Wanted, but its data has not arrived yet (streaming): the next coarser level's cap
    /// covers it meanwhile.
    Waiting,
    /// Its whole disk around the nadir lies outside the view frustum (and so does every finer
    /// level's): neither filled nor drawn; the cap of the next coarser level stands in.
    OutOfView,
}

impl LevelStatus {
    pub fn label(self) -> &'static str {
        match self {
            Self::Drawn => "drawn",
            Self::BeyondHorizon => "beyond horizon (θ̃ > θ̃max)",
            Self::SubPixel => "sub-pixel (θ̃ < θ̃min)",
            Self::Waiting => "waiting for data",
            Self::OutOfView => "out of view (nadir outside the frustum)",
        }
    }
}

/// The levels drawn this frame: `coarsest..=finest`, with the bounds that chose them.
#[derive(Clone, Debug, PartialEq)]
pub struct LevelSelection {
    pub coarsest: u32,
    pub finest: u32,
    pub theta_max_rad: f64,
    pub theta_min_rad: f64,
    pub status: Vec<LevelStatus>,
}

impl LevelSelection {
    /// Level i is drawn iff its inner edge 2^−(i+1)π lies inside θ̃max and its outer edge
    /// 2^−iπ lies outside θ̃min. The finest level is always at least the coarsest, so a
    /// camera far out still draws one level and its cap.
    pub fn new(levels: u32, theta_max_rad: f64, theta_min_rad: f64) -> Self {
        let mut status = Vec::with_capacity(levels as usize);
        for i in 0..levels {
            let outer = level_outer_theta_rad(i);
            let inner = 0.5 * outer;
            status.push(if inner >= theta_max_rad {
                LevelStatus::BeyondHorizon
            } else if outer < theta_min_rad {
                LevelStatus::SubPixel
            } else {
                LevelStatus::Drawn
            });
        }
        let coarsest = status.iter().position(|s| *s == LevelStatus::Drawn);
        let finest = status.iter().rposition(|s| *s == LevelStatus::Drawn);
        let (coarsest, finest) = match (coarsest, finest) {
            (Some(c), Some(f)) => (c as u32, f as u32),
            _ => {
                // Degenerate bounds (θ̃min beyond θ̃max, only at absurd zoom-outs): draw the
                // level at the horizon so the planet never disappears.
                let c = status
                    .iter()
                    .position(|s| *s != LevelStatus::BeyondHorizon)
                    .unwrap_or(0) as u32;
                let c = c.saturating_sub(1).min(levels - 1);
                status[c as usize] = LevelStatus::Drawn;
                (c, c)
            }
        };
        Self {
            coarsest,
            finest,
            theta_max_rad,
            theta_min_rad,
            status,
        }
    }

    pub fn drawn_levels(&self) -> Range<u32> {
        self.coarsest..self.finest + 1
    }

    /// Draws no level finer than `ready_finest` (the finest level whose data, and that of
    /// every coarser drawn level, has arrived); the wanted levels beyond it are `Waiting`.
    /// `None`: nothing has arrived, every wanted level waits and nothing is drawn.
    pub fn limit_to_ready(&mut self, ready_finest: Option<u32>) {
        let first_waiting = match ready_finest {
            Some(f) if f >= self.coarsest => f.min(self.finest) + 1,
            _ => self.coarsest,
        };
        for level in first_waiting..=self.finest {
            self.status[level as usize] = LevelStatus::Waiting;
        }
        self.finest = first_waiting.saturating_sub(1).max(self.coarsest);
    }

    /// True when at least one level is drawn (false only while streaming has nothing yet).
    pub fn any_drawn(&self) -> bool {
        self.status.contains(&LevelStatus::Drawn)
    }

    /// Levels wanted but waiting for data.
    pub fn waiting(&self) -> Vec<u32> {
        (0..self.status.len() as u32)
            .filter(|&l| self.status[l as usize] == LevelStatus::Waiting)
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn selection_is_contiguous_and_respects_bounds() {
        let sel = LevelSelection::new(30, 0.06, 1e-8);
        for i in 0..30 {
            let drawn = sel.status[i as usize] == LevelStatus::Drawn;
            assert_eq!(drawn, sel.drawn_levels().contains(&i));
        }
        assert_eq!(sel.status[0], LevelStatus::BeyondHorizon);
        assert!(level_outer_theta_rad(sel.coarsest) * 0.5 < 0.06);
        assert!(level_outer_theta_rad(sel.coarsest - 1) * 0.5 >= 0.06);
    }
}
