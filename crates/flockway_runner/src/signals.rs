//! The signals CSV: beside a run's telemetry CSV, every change of what a junction's signal shows
//! each of its connections, streamed as the run goes — by its level's program or by a
//! controller that took it over.

use flockway_drivers::Signals;
use flockway_road::{Junction, RoadNetwork, SignalState};
use std::fs::File;
use std::path::{Path, PathBuf};

/// The signals CSV's columns, in order (a contract, like the telemetry CSV's).
pub const SIGNAL_COLUMNS: [&str; 8] = [
    "time_s",
    "junction",
    "connection",
    "from",
    "from_lane",
    "to",
    "to_lane",
    "state",
];

/// Where the signals CSV of a telemetry CSV goes: `run.csv` → `run.signals.csv`.
pub fn signals_path(csv: &Path) -> PathBuf {
    beside(csv, "signals")
}

/// A file written beside a telemetry CSV: `run.csv` → `run.KIND.csv`.
pub(crate) fn beside(csv: &Path, kind: &str) -> PathBuf {
    let stem = csv
        .file_stem()
        .map_or_else(|| "run".into(), |s| s.to_string_lossy().into_owned());
    csv.with_file_name(format!("{stem}.{kind}.csv"))
}

/// Streams signal changes to a CSV: a row per connection when the run starts, then one per
/// connection whose state changes, at the time vehicles first see it.
pub struct SignalsWriter {
    path: PathBuf,
    out: csv::Writer<File>,
    /// Per junction (in the network's order): the states last written, empty before the first.
    last: Vec<Vec<SignalState>>,
}

impl SignalsWriter {
    /// Creates (or truncates) the file and writes the header.
    pub fn create(path: &Path) -> std::io::Result<SignalsWriter> {
        let mut out = csv::Writer::from_writer(File::create(path)?);
        out.write_record(SIGNAL_COLUMNS)?;
        out.flush()?;
        Ok(SignalsWriter {
            path: path.to_owned(),
            out,
            last: Vec::new(),
        })
    }

    /// The file being written.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Writes the changes of every signal at `time_s` (the time the step's vehicles saw).
    pub fn record(
        &mut self,
        network: &RoadNetwork,
        signals: &Signals,
        time_s: f64,
    ) -> std::io::Result<()> {
        let junctions = network.junctions();
        self.last.resize_with(junctions.len(), Vec::new);
        let mut wrote = false;
        for (j, junction) in junctions.iter().enumerate() {
            let Some(states) = signals.states(j) else {
                continue;
            };
            for (k, state) in states.iter().enumerate() {
                if self.last[j].get(k) == Some(state) {
                    continue;
                }
                self.out
                    .write_record(row(network, junction, k, *state, time_s))?;
                wrote = true;
            }
            self.last[j] = states.to_vec();
        }
        if wrote {
            self.out.flush()?;
        }
        Ok(())
    }

    /// Flushes what is left.
    pub fn finish(mut self) -> std::io::Result<()> {
        self.out.flush()
    }
}

/// One row: connection `k` of `junction` showing `state` from `time_s`.
fn row(
    network: &RoadNetwork,
    junction: &Junction,
    k: usize,
    state: SignalState,
    time_s: f64,
) -> [String; 8] {
    let path = &junction.paths[k];
    let name = |id: u32| {
        network
            .get(flockway_road::RoadId(id))
            .map_or_else(String::new, |g| g.name().to_owned())
    };
    [
        format!("{time_s:.3}"),
        junction.spec.name.clone(),
        k.to_string(),
        name(path.from.0),
        path.from.1.to_string(),
        name(path.to.0),
        path.to.1.to_string(),
        state.letter().to_string(),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_signals_file_sits_beside_the_csv_with_its_stem() {
        assert_eq!(
            signals_path(Path::new("out/run.csv")),
            PathBuf::from("out/run.signals.csv")
        );
        assert_eq!(
            signals_path(Path::new("run")),
            PathBuf::from("run.signals.csv")
        );
    }
}
