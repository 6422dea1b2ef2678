//! Flockway's runner: [`Runner`] turns a [`flockway_level::Level`] into a world, steps it at the
//! fixed step, streams telemetry to CSV, measures the [`Summary`] and checks the level's
//! expectations. `flockway run` uses it headless; the window uses the same runner, so a level
//! and seed give the same CSV bytes in both. [`batch`] runs many levels and seeds at once, as
//! `flockway test` does.
//!
//! Modules: `assets` (where a level's vehicle and driver files are, loaded), `world` (a level
//! turned into a world), `runner` (stepping and streamed telemetry), `summary` (the metrics and
//! the expectations at the end), [`batch`], `session` (a run stepped from outside), `approach`
//! (signals and junction lanes read and set between steps), `detectors` (the induction loops'
//! CSV), `routes` (routes set from outside).

mod approach;
mod assets;
pub mod batch;
mod conflicts;
mod detectors;
mod routes;
mod runner;
mod session;
mod signals;
mod summary;
pub mod telemetry;
#[cfg(test)]
mod tests;
mod world;

pub use approach::{APPROACHING_M, ApproachColumns, QUEUE_FRONT_M, QUEUE_GAP_M, SignalView};
pub use assets::{
    ASSETS_ENV, DriverProfiles, VehicleTypes, builtin_model, find_assets_dir, level_model,
    load_driver_profiles, load_profiles, load_vehicle_types,
};
pub use conflicts::{CONFLICT_COLUMNS, ConflictsWriter};
pub use detectors::{
    DETECTOR_COLUMNS, DetectorColumns, DetectorsWriter, detectors_path, reading_row, readings_csv,
};
pub use flockway_analysis::{ExpectationResult, Summary};
pub use routes::{Heading, route_from};
pub use runner::{
    MAX_RUN_SECONDS, RunError, RunOptions, Runner, assign_action_step, assign_models, parse_driver,
};
pub use session::{
    LEADER_RANGE_M, Leaders, Override, Session, SessionError, VehicleColumns, apply_overrides,
};
pub use signals::{SIGNAL_COLUMNS, signals_path};
pub use summary::{evaluate, level_name, measure, metrics};
pub use world::{build_sim, populate};
