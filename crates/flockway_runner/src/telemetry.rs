//! The telemetry CSV: one tidy row per vehicle per sample, streamed as the run goes.

use std::fs::File;
use std::path::{Path, PathBuf};

/// The CSV columns, in order. A documented contract: columns may be added at the end, never
/// renamed or reordered.
pub const CSV_COLUMNS: [&str; 15] = [
    "time_s",
    "vehicle_id",
    "driver",
    "road",
    "lane",
    "s_m",
    "x_m",
    "y_m",
    "z_m",
    "speed_kmh",
    "accel_mps2",
    "throttle",
    "steering",
    "gear",
    "rpm",
];

/// One vehicle at one sample time.
#[derive(Debug, Clone, PartialEq)]
pub struct TelemetryRow {
    /// Simulated time, seconds (an exact multiple of the sampling period).
    pub time_s: f64,
    /// Stable vehicle number (spawn order).
    pub vehicle_id: u32,
    /// Driver profile name.
    pub driver: String,
    /// Road name.
    pub road: String,
    /// Lane index (0 is the rightmost).
    pub lane: u32,
    /// Arc position along the road, metres.
    pub s_m: f64,
    /// World position, metres.
    pub pos_m: [f64; 3],
    /// Speed along the direction of travel, km/h.
    pub speed_kmh: f64,
    /// Longitudinal acceleration, m/s².
    pub accel_mps2: f64,
    /// Throttle input in [-1, 1].
    pub throttle: f64,
    /// Steering input in [-1, 1].
    pub steering: f64,
    /// Gear (0 neutral, −1 reverse).
    pub gear: i32,
    /// Engine speed, rpm.
    pub rpm: f64,
}

/// Writes telemetry rows to a CSV file, flushing after every sample time so that a run stopped
/// at any moment leaves a valid file of everything sampled before it.
pub struct TelemetryWriter {
    path: PathBuf,
    out: csv::Writer<File>,
    rows: u64,
}

impl TelemetryWriter {
    /// Creates (or truncates) the file and writes the header.
    pub fn create(path: &Path) -> std::io::Result<TelemetryWriter> {
        let file = File::create(path)?;
        // csv buffers internally, and its flush also flushes the file.
        let mut out = csv::Writer::from_writer(file);
        out.write_record(CSV_COLUMNS)?;
        out.flush()?;
        Ok(TelemetryWriter {
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

    /// Appends the rows of one sample time and flushes them to the file.
    pub fn write_sample(&mut self, rows: &[TelemetryRow]) -> std::io::Result<()> {
        for r in rows {
            // Fixed decimals keep files byte-identical across platforms' float formatting and diffable.
            self.out.write_record([
                format!("{:.3}", r.time_s),
                r.vehicle_id.to_string(),
                r.driver.clone(),
                r.road.clone(),
                r.lane.to_string(),
                format!("{:.3}", r.s_m),
                format!("{:.3}", r.pos_m[0]),
                format!("{:.3}", r.pos_m[1]),
                format!("{:.3}", r.pos_m[2]),
                format!("{:.3}", r.speed_kmh),
                format!("{:.3}", r.accel_mps2),
                format!("{:.4}", r.throttle),
                format!("{:.4}", r.steering),
                r.gear.to_string(),
                format!("{:.1}", r.rpm),
            ])?;
            self.rows += 1;
        }
        self.out.flush()
    }

    /// Flushes everything and syncs the file to disk.
    pub fn finish(mut self) -> std::io::Result<()> {
        self.out.flush()?;
        let file = self
            .out
            .into_inner()
            .map_err(|e| std::io::Error::other(e.to_string()))?;
        file.sync_all()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_are_flushed_per_sample_with_the_contract_header() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("run.csv");
        let mut w = TelemetryWriter::create(&path).expect("create");
        let row = TelemetryRow {
            time_s: 0.5,
            vehicle_id: 3,
            driver: "auto".into(),
            road: "main".into(),
            lane: 1,
            s_m: 12.34567,
            pos_m: [1.0, 2.0, 0.25],
            speed_kmh: 59.99,
            accel_mps2: -0.5,
            throttle: 0.25,
            steering: -0.01,
            gear: 3,
            rpm: 2100.0,
        };
        w.write_sample(std::slice::from_ref(&row)).expect("write");
        // Readable before finish: a killed run keeps what it measured.
        let text = std::fs::read_to_string(&path).expect("read");
        assert_eq!(
            text,
            "time_s,vehicle_id,driver,road,lane,s_m,x_m,y_m,z_m,speed_kmh,accel_mps2,throttle,steering,gear,rpm\n\
             0.500,3,auto,main,1,12.346,1.000,2.000,0.250,59.990,-0.500,0.2500,-0.0100,3,2100.0\n"
        );
        assert_eq!(w.rows(), 1);
        w.finish().expect("finish");
    }
}
