//! Flockway's runner: [`Runner`] turns a [`flockway_level::Level`] into a world, steps it at the
//! fixed step, streams telemetry to CSV, measures the summary and checks the level's
//! expectations. `flockway run` uses it headless; the window uses the same runner, so a level
//! and seed give the same CSV bytes in both.

mod run;
pub mod telemetry;

pub use run::*;
