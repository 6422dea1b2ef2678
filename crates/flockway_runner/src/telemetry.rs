//! The telemetry CSV contract, owned by the analysis crate (which reads it) and written by the
//! runner: re-exported here for the runner's users.

pub use crate::signals::{SIGNAL_COLUMNS, SignalsWriter, signals_path};
pub use flockway_analysis::{CSV_COLUMNS, Column, TelemetryRow, TelemetryWriter};
