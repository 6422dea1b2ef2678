//! The telemetry CSV contract, owned by the analysis crate (which reads it) and written by the
//! runner: re-exported here for the runner's users.

pub use flockway_analysis::{CSV_COLUMNS, Column, TelemetryRow, TelemetryWriter};
