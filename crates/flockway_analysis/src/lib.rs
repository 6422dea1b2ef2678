//! Flockway's run analysis: reads a run's telemetry (the CSV of `flockway run --csv`, or samples
//! a runner pushes), measures stop-and-go waves, draws speed-history, space–time, mean-speed and
//! fundamental-diagram plots, and writes a self-contained HTML report.
//!
//! The crate owns two file contracts and knows nothing of the simulation: the telemetry CSV
//! ([`Column`], [`TelemetryRow`], written with [`TelemetryWriter`], read by [`Trace`]; any CSV
//! with the [`REQUIRED_COLUMNS`] can be analysed) and the run summary JSON ([`Summary`]).

pub mod compare;
mod plot;
mod report;
mod summary;
mod telemetry;
mod trace;
mod wave;

pub use plot::{
    FlowDensity, PLOT_NAMES, PLOT_SIZE, PlotFormat, PlotInfo, flow_density, render_plot,
    write_plots, write_plots_sized,
};
pub use report::write_report;
pub use summary::{
    CapacitySample, ExpectationResult, SATURATED_SHARE, Summary, plot_info, wave_of,
};
pub use telemetry::{CSV_COLUMNS, Column, TelemetryRow, TelemetryWriter};
pub use trace::{NamedSample, REQUIRED, REQUIRED_COLUMNS, Sample, Trace};
pub use wave::{Wave, WaveSettings, measure_wave};

use std::path::PathBuf;

/// Why an analysis could not be done.
#[derive(Debug, thiserror::Error)]
pub enum AnalysisError {
    /// A file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The CSV lacks a column analysis needs (a foreign file).
    #[error(
        "{}: missing column `{column}`: expected a telemetry CSV from `flockway run --csv` \
         (header found: {found})",
        path.display()
    )]
    MissingColumn {
        /// The file.
        path: PathBuf,
        /// The missing column.
        column: &'static str,
        /// The header that was there.
        found: String,
    },
    /// A value does not parse.
    #[error("{}:{line}: column `{column}`: expected {expected}, found `{value}`", path.display())]
    BadValue {
        /// The file.
        path: PathBuf,
        /// Line number (1 is the header).
        line: u64,
        /// The column.
        column: &'static str,
        /// The text found.
        value: String,
        /// What was expected.
        expected: &'static str,
    },
    /// The CSV itself is malformed (e.g. a row with the wrong number of fields).
    #[error("{}:{line}: {message}", path.display())]
    Csv {
        /// The file.
        path: PathBuf,
        /// Line number (1 is the header).
        line: u64,
        /// What the CSV reader said.
        message: String,
    },
    /// The CSV has a header but no samples.
    #[error("{}: no samples (the run recorded nothing)", path.display())]
    Empty {
        /// The file.
        path: PathBuf,
    },
    /// Drawing a plot failed.
    #[error("{}: plotting failed: {message}", path.display())]
    Plot {
        /// The file being drawn.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// A SUMO output file does not read as one.
    #[error("{}: {message}", path.display())]
    Sumo {
        /// The file.
        path: PathBuf,
        /// Where and what is wrong.
        message: String,
    },
    /// The summary JSON given to a report is not one `flockway run --summary` writes.
    #[error("{}: {message}", path.display())]
    Summary {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        message: String,
    },
}
