//! Flockway: a deterministic traffic sandbox. Spline roads, rigid-body sedans, flocking and
//! human-like drivers, stepped at a fixed 1/120 s, headless or in a window.
//!
//! This crate is the facade over the workspace's crates and holds the headless runner that the
//! `flockway` command uses: [`run::Runner`] turns a [`level::Level`] into a world, steps it,
//! streams telemetry and checks the level's expectations.

pub use flockway_runner as run;
pub use flockway_runner::telemetry;

pub use flockway_analysis as analysis;
#[cfg(feature = "window")]
pub use flockway_app as app;
pub use flockway_core as core;
pub use flockway_drivers as drivers;
pub use flockway_edit as edit;
pub use flockway_level as level;
pub use flockway_road as road;
pub use flockway_traffic as traffic;
pub use flockway_vehicle as vehicle;

/// The types most programs that drive Flockway need.
pub mod prelude {
    pub use crate::run::{ExpectationResult, RunOptions, Runner, Summary, build_sim};
    pub use flockway_core::prelude::*;
    pub use flockway_level::{Level, load_level};
    pub use flockway_road::prelude::*;
}
