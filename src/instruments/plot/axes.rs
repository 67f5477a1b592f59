//! A plot's axes: the range an axis spans over its values (log or linear, padded, with the
//! fallbacks for degenerate inputs) and the ticks it is drawn with (decades, with 2 and 5
//! between them where there is room, and linear steps on a log axis narrower than one of those).

use std::ops::Range;

use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};

/// One axis as drawn: the data range and whether it is logarithmic (after any fallback).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Axis {
    pub lo: f64,
    pub hi: f64,
    pub log: bool,
}

impl Axis {
    fn transform(&self, v: f64) -> f64 {
        if self.log { v.log10() } else { v }
    }

    /// Where `v` falls along the axis: 0 at `lo`, 1 at `hi`; None where it cannot be drawn
    /// (not finite, or ≤ 0 on a log axis).
    pub fn fraction(&self, v: f64) -> Option<f64> {
        if !v.is_finite() || (self.log && v <= 0.0) {
            return None;
        }
        let (a, b) = (self.transform(self.lo), self.transform(self.hi));
        Some((self.transform(v) - a) / (b - a))
    }
}

/// A tick: its value, and its label (labelled ticks are the bold grid lines).
#[derive(Clone, Debug, PartialEq)]
struct Tick {
    value: f64,
    label: Option<String>,
}

/// An axis with its ticks chosen: the coordinate `plotters` maps through. Its bold key points
/// are the labelled ticks, its light ones every tick.
#[derive(Clone, Debug)]
pub(super) struct TickedAxis {
    axis: Axis,
    ticks: Vec<Tick>,
}

impl TickedAxis {
    pub(super) fn new(axis: Axis, target: f64) -> Self {
        Self {
            ticks: axis_ticks(&axis, target),
            axis,
        }
    }

    /// The label of the labelled tick nearest `v` (the mesh asks for its bold key points).
    pub(super) fn label(&self, v: f64) -> String {
        (self.ticks.iter())
            .filter(|t| t.label.is_some())
            .min_by(|a, b| (a.value - v).abs().total_cmp(&(b.value - v).abs()))
            .and_then(|t| t.label.clone())
            .unwrap_or_default()
    }
}

impl Ranged for TickedAxis {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        let t = self.axis.fraction(*value).unwrap_or(f64::NAN);
        let px = f64::from(limit.0) + t * f64::from(limit.1 - limit.0);
        // Off-axis values (never drawn: the caller skips them) land on the low end.
        if px.is_finite() {
            px.round().clamp(-1e6, 1e6) as i32
        } else {
            limit.0
        }
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        let light = hint.weight().allow_light_points();
        (self.ticks.iter())
            .filter(|t| light || t.label.is_some())
            .map(|t| t.value)
            .collect()
    }

    fn range(&self) -> Range<f64> {
        self.axis.lo..self.axis.hi
    }
}

/// Range of an axis over `values` (finite), padded so that markers clear the box; whether a
/// log axis fell back to linear because of a value ≤ 0.
pub(super) fn resolve_axis(values: &[f64], log: bool) -> (Axis, bool) {
    let fell_back = log && values.iter().any(|&v| v <= 0.0);
    let log = log && !fell_back;
    let f = |v: f64| if log { v.log10() } else { v };
    let inv = |t: f64| if log { 10f64.powf(t) } else { t };
    let (mut lo, mut hi) = (values.iter())
        .map(|&v| f(v))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if values.is_empty() {
        (lo, hi) = (0.0, 1.0);
    } else if lo == hi {
        let d = match (log, lo == 0.0) {
            (true, _) => 0.5,
            (false, true) => 1.0,
            (false, false) => 0.1 * lo.abs(),
        };
        (lo, hi) = (lo - d, hi + d);
    } else {
        let p = 0.06 * (hi - lo);
        (lo, hi) = (lo - p, hi + p);
    }
    // The padding must not leave f64 at the extremes of its range.
    let (min, max) = if log {
        (-307.0, 308.0)
    } else {
        (f64::MIN / 4.0, f64::MAX / 4.0)
    };
    (lo, hi) = (lo.max(min), hi.min(max));
    let axis = Axis {
        lo: inv(lo),
        hi: inv(hi),
        log,
    };
    (axis, fell_back)
}

/// The 1-2-5 step nearest above `raw`.
fn nice_step(raw: f64) -> f64 {
    let mag = 10f64.powf(raw.log10().floor());
    let f = raw / mag;
    let m = match f {
        f if f < 1.5 => 1.0,
        f if f < 3.5 => 2.0,
        f if f < 7.5 => 5.0,
        _ => 10.0,
    };
    m * mag
}

/// About `target` ticks: on a linear axis labelled 1-2-5 steps; on a log axis decades, with
/// ticks at 2 and 5 between them where fewer than `target` decades show, labelled too when
/// fewer than three do, at every 1…9 × 10^k within less than a decade, and only every 2nd,
/// 5th… decade over very many. A log axis narrower than a 1-2-5 step gets linear steps.
fn axis_ticks(axis: &Axis, target: f64) -> Vec<Tick> {
    let target = target.clamp(2.0, 12.0);
    if !axis.log {
        return linear_ticks(axis.lo, axis.hi, target);
    }
    let (a, b) = (axis.lo.log10(), axis.hi.log10());
    if !(a.is_finite() && b.is_finite() && b > a) {
        return Vec::new();
    }
    let minors = b - a <= target;
    let mantissas: &[i32] = if b - a < 1.0 {
        &[1, 2, 3, 4, 5, 6, 7, 8, 9]
    } else {
        &[1, 2, 5]
    };
    // Over many decades, every 2nd, 5th, 10th… decade, so that ticks stay apart.
    let every = if b - a <= 1.5 * target {
        1
    } else {
        nice_step((b - a) / target) as i32
    };
    let mut ticks = Vec::new();
    for k in (a.floor().max(-330.0) as i32)..=(b.ceil().min(330.0) as i32) {
        if k.rem_euclid(every) != 0 {
            continue;
        }
        for &m in mantissas {
            let v = f64::from(m) * 10f64.powi(k);
            let lv = v.log10();
            if (m != 1 && !minors) || lv < a - 1e-9 || lv > b + 1e-9 {
                continue;
            }
            ticks.push(Tick {
                value: v,
                label: Some(log_label(m, k)),
            });
        }
    }
    if ticks.len() < 2 {
        return linear_ticks(axis.lo, axis.hi, target);
    }
    let decades = ticks.iter().filter(|t| is_decade(t.value)).count();
    if decades >= 3 {
        for t in ticks.iter_mut().filter(|t| !is_decade(t.value)) {
            t.label = None;
        }
    }
    ticks
}

fn is_decade(v: f64) -> bool {
    let l = v.log10();
    (l - l.round()).abs() < 1e-9
}

fn linear_ticks(lo: f64, hi: f64, target: f64) -> Vec<Tick> {
    let step = nice_step((hi - lo) / target);
    let (first, last) = ((lo / step).ceil(), (hi / step).floor());
    if !(step > 0.0 && step.is_finite() && (0.0..=100.0).contains(&(last - first))) {
        return Vec::new();
    }
    // Plain numbers over the usual range; beyond it e-notation with the digits the step needs.
    let step_exp = step.log10().floor();
    let top_exp = lo.abs().max(hi.abs()).log10().floor();
    let plain = (-4.0..=6.0).contains(&step_exp) && top_exp <= 6.0;
    (first as i64..=last as i64)
        .map(|i| {
            let v = if i == 0 { 0.0 } else { i as f64 * step };
            let label = match plain {
                true => format!("{:.*}", (-step_exp).max(0.0) as usize, v),
                false if v == 0.0 => "0".into(),
                false => {
                    let digits = (v.abs().log10().floor() - step_exp).clamp(0.0, 3.0);
                    format!("{:.*e}", digits as usize, v)
                }
            };
            Tick {
                value: v,
                label: Some(label),
            }
        })
        .collect()
}

/// `m`·10^`k` written plainly over the usual range, in e-notation beyond.
fn log_label(m: i32, k: i32) -> String {
    match k {
        0..=5 => (i64::from(m) * 10i64.pow(k as u32)).to_string(),
        -4..=-1 => format!("{:.*}", (-k) as usize, f64::from(m) * 10f64.powi(k)),
        _ => format!("{m}e{k}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nice_steps_and_ticks() {
        assert_eq!(nice_step(0.13), 0.1);
        assert_eq!(nice_step(0.3), 0.2);
        assert_eq!(nice_step(4.0), 5.0);
        assert_eq!(nice_step(80.0), 100.0);
        let labels =
            |t: &[Tick]| -> Vec<String> { t.iter().filter_map(|t| t.label.clone()).collect() };
        assert_eq!(
            labels(&linear_ticks(-0.05, 1.05, 5.0)),
            ["0.0", "0.2", "0.4", "0.6", "0.8", "1.0"]
        );
        // Three decades: decades labelled, 2 and 5 ticks unlabelled.
        let axis = Axis {
            lo: 0.08,
            hi: 120.0,
            log: true,
        };
        let t = axis_ticks(&axis, 8.0);
        assert_eq!(labels(&t), ["0.1", "1", "10", "100"]);
        let values: Vec<f64> = t.iter().map(|t| t.value).collect();
        let expected = [0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0];
        assert_eq!(values.len(), expected.len());
        assert!(
            values
                .iter()
                .zip(expected)
                .all(|(a, b)| (a - b).abs() < 1e-12 * b)
        );
        // Under two decades: the 2 and 5 ticks are labelled too.
        let axis = Axis {
            lo: 1.5,
            hi: 60.0,
            log: true,
        };
        assert_eq!(
            labels(&axis_ticks(&axis, 8.0)),
            ["2", "5", "10", "20", "50"]
        );
        // Under one decade: every 1…9 × 10^k.
        let axis = Axis {
            lo: 1.9,
            hi: 8.2,
            log: true,
        };
        assert_eq!(
            labels(&axis_ticks(&axis, 8.0)),
            ["2", "3", "4", "5", "6", "7", "8"]
        );
        // Inside one 1-2-5 step: linear steps.
        let axis = Axis {
            lo: 2.1,
            hi: 2.9,
            log: true,
        };
        let t = labels(&axis_ticks(&axis, 8.0));
        assert!(
            t.len() >= 3 && t.iter().all(|l| l.starts_with("2.")),
            "{t:?}"
        );
        assert_eq!(
            labels(&linear_ticks(0.0, 3e8, 3.0)),
            ["0", "1e8", "2e8", "3e8"]
        );
        assert_eq!(
            labels(&linear_ticks(1.1e9, 1.35e9, 3.0)),
            ["1.1e9", "1.2e9", "1.3e9"]
        );
        // 600 decades with room for 12 ticks: every 50th decade.
        let axis = Axis {
            lo: 1e-300,
            hi: 1e300,
            log: true,
        };
        let t = labels(&axis_ticks(&axis, 12.0));
        assert_eq!(t.len(), 13);
        assert_eq!(t[..3], ["1e-300", "1e-250", "1e-200"]);
        assert_eq!(log_label(5, -3), "0.005");
        assert_eq!(log_label(2, 7), "2e7");
    }

    #[test]
    fn axes_resolve_degenerate_ranges() {
        let (a, fell_back) = resolve_axis(&[2.0, 2.0], false);
        assert!(!fell_back && a.lo < 2.0 && a.hi > 2.0 && !a.log);
        let (a, _) = resolve_axis(&[0.0], false);
        assert_eq!((a.lo, a.hi), (-1.0, 1.0));
        let (a, _) = resolve_axis(&[10.0], true);
        assert!(a.log && (a.lo * a.hi - 100.0).abs() < 1e-9 && a.lo < 10.0);
        let (a, fell_back) = resolve_axis(&[0.0, 3.0, 5.0], true);
        assert!(fell_back && !a.log && a.lo < 0.0);
        let (a, fell_back) = resolve_axis(&[], true);
        assert!(!fell_back && a.log && a.lo == 1.0 && a.hi == 10.0);
    }
}
