//! The instruments: what globe reports about itself, built on the truth in `measure` (the f64
//! reference and the per-pixel metric) and the scenes they fly.
//!
//! | module | what it answers |
//! |---|---|
//! | [`bench`] | `globe bench`: frame and pass times, the streaming throughput, ratios in one run |
//! | [`report`] | `globe report`: screen-space error against run time over the scenes, as tables and plots |
//! | [`soak`] | `globe bench --scene soak`: a long random flight under faults, its budgets held |
//! | [`plot`] | the figures (PNG and SVG, text from the embedded font) |

pub mod bench;
pub mod plot;
pub mod report;
pub mod soak;
