//! The conflicts CSV (`flockway run --conflicts FILE.csv`): one row per conflict the surrogate
//! safety measures find, streamed as the run goes (a follower–leader episode when it ends, a
//! PET conflict when the second vehicle enters).

use flockway_road::RoadNetwork;
use flockway_traffic::ConflictRecord;
use std::fs::File;
use std::path::{Path, PathBuf};

/// The conflicts CSV's columns, in order (a contract, like the telemetry CSV's).
pub const CONFLICT_COLUMNS: [&str; 13] = [
    "time_s",
    "kind",
    "vehicle_id",
    "other_id",
    "driver",
    "other_driver",
    "road",
    "junction",
    "min_ttc_s",
    "pet_s",
    "max_drac_mps2",
    "x_m",
    "y_m",
];

/// Streams conflict records to a CSV, flushed after every tick that found one.
pub struct ConflictsWriter {
    path: PathBuf,
    out: csv::Writer<File>,
    rows: u64,
}

impl ConflictsWriter {
    /// Creates (or truncates) the file and writes the header.
    pub fn create(path: &Path) -> std::io::Result<ConflictsWriter> {
        let mut out = csv::Writer::from_writer(File::create(path)?);
        out.write_record(CONFLICT_COLUMNS)?;
        out.flush()?;
        Ok(ConflictsWriter {
            path: path.to_owned(),
            out,
            rows: 0,
        })
    }

    /// The file being written.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Rows written so far.
    pub fn rows(&self) -> u64 {
        self.rows
    }

    /// Writes `records`, naming roads and junctions as the level does.
    pub fn write(
        &mut self,
        network: &RoadNetwork,
        records: &[ConflictRecord],
    ) -> std::io::Result<()> {
        if records.is_empty() {
            return Ok(());
        }
        for r in records {
            self.out.write_record(row(network, r))?;
            self.rows += 1;
        }
        self.out.flush()
    }

    /// Flushes what is left.
    pub fn finish(mut self) -> std::io::Result<()> {
        self.out.flush()
    }
}

/// A value rounded to `digits` decimals, as the CSV writes it; empty when absent.
fn number(v: Option<f64>, digits: i32) -> String {
    v.map_or_else(String::new, |v| {
        let k = 10f64.powi(digits);
        format!("{}", (v * k).round() / k)
    })
}

fn row(network: &RoadNetwork, r: &ConflictRecord) -> [String; 13] {
    let road = network
        .get(r.road)
        .map_or_else(String::new, |g| g.name().to_owned());
    let junction = r
        .junction
        .and_then(|j| network.junctions().get(j))
        .map_or_else(String::new, |j| j.spec.name.clone());
    [
        number(Some(r.time_s), 4),
        r.kind.name().to_owned(),
        r.vehicle.to_string(),
        r.other.to_string(),
        r.driver.to_string(),
        r.other_driver.to_string(),
        road,
        junction,
        number(r.min_ttc_s, 4),
        number(r.pet_s, 4),
        number(r.max_drac_mps2, 3),
        number(Some(f64::from(r.position.x)), 3),
        number(Some(f64::from(r.position.y)), 3),
    ]
}
