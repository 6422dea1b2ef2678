//! The telemetry CSV contract: its columns, one row type, the writer runs stream it with, and
//! the parsing every reader shares. The runner writes rows of this type; [`crate::Trace`] reads
//! them back by these column names.

use std::fs::File;
use std::path::{Path, PathBuf};

/// The telemetry CSV's columns. A documented contract: columns may be added at the end, never
/// renamed or reordered.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Column {
    /// Simulated time, s (a whole multiple of the sampling period).
    TimeS,
    /// The vehicle's stable number (spawn order).
    VehicleId,
    /// Its driver profile's name.
    Driver,
    /// The road it is on.
    Road,
    /// Its lane (0 is the rightmost).
    Lane,
    /// Arc position along the road, m.
    SM,
    /// World position east, m.
    XM,
    /// World position north, m.
    YM,
    /// World position up, m.
    ZM,
    /// Speed along the car's forward axis, km/h.
    SpeedKmh,
    /// Its rate of change, m/s².
    AccelMps2,
    /// Throttle input in [−1, 1].
    Throttle,
    /// Steering input in [−1, 1].
    Steering,
    /// Gear (−1 reverse, 0 neutral).
    Gear,
    /// Engine speed, rpm.
    Rpm,
    /// The driver model (`FlockLanes`, `Human`, …; `Custom(name)` for a plugin's).
    Model,
    /// The name of the route its spawner gave it (its destination road's name for a spawner
    /// with a destination); empty when it just follows the road.
    Route,
}

impl Column {
    /// Every column, in file order.
    pub const ALL: [Column; 17] = [
        Column::TimeS,
        Column::VehicleId,
        Column::Driver,
        Column::Road,
        Column::Lane,
        Column::SM,
        Column::XM,
        Column::YM,
        Column::ZM,
        Column::SpeedKmh,
        Column::AccelMps2,
        Column::Throttle,
        Column::Steering,
        Column::Gear,
        Column::Rpm,
        Column::Model,
        Column::Route,
    ];

    /// The column's name in the header.
    pub const fn name(self) -> &'static str {
        match self {
            Column::TimeS => "time_s",
            Column::VehicleId => "vehicle_id",
            Column::Driver => "driver",
            Column::Road => "road",
            Column::Lane => "lane",
            Column::SM => "s_m",
            Column::XM => "x_m",
            Column::YM => "y_m",
            Column::ZM => "z_m",
            Column::SpeedKmh => "speed_kmh",
            Column::AccelMps2 => "accel_mps2",
            Column::Throttle => "throttle",
            Column::Steering => "steering",
            Column::Gear => "gear",
            Column::Rpm => "rpm",
            Column::Model => "model",
            Column::Route => "route",
        }
    }

    /// What the column holds, with its unit (for documentation).
    pub const fn description(self) -> &'static str {
        match self {
            Column::TimeS => "simulated time, s (a whole multiple of the sampling period)",
            Column::VehicleId => {
                "the vehicle's number, in spawn order (stable for a level and seed)"
            }
            Column::Driver => "its driver profile's name",
            Column::Road => "the road it is on",
            Column::Lane => "its lane (0 is the rightmost)",
            Column::SM => "arc position along the road, m",
            Column::XM => "position east, m",
            Column::YM => "position north, m",
            Column::ZM => "position up, m",
            Column::SpeedKmh => "speed along the car's forward axis, km/h",
            Column::AccelMps2 => "its rate of change, m/s²",
            Column::Throttle => "throttle input, −1..1 (negative brakes)",
            Column::Steering => "steering input, −1..1 (positive left)",
            Column::Gear => "gear (−1 reverse, 0 neutral)",
            Column::Rpm => "engine speed, rpm",
            Column::Model => {
                "the driver model (`FlockLanes`, `Human`, …; `Custom(NAME)` for a plugin's)"
            }
            Column::Route => {
                "its route's name (a spawner's route, or its destination road); empty when it follows the road"
            }
        }
    }
}

/// The header line's names, in order.
pub const CSV_COLUMNS: [&str; 17] = {
    let mut out = [""; 17];
    let mut i = 0;
    while i < 17 {
        out[i] = Column::ALL[i].name();
        i += 1;
    }
    out
};

/// One vehicle at one sample time: one line of the telemetry CSV.
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
    /// Driver model.
    pub model: String,
    /// Route name (empty: it follows the road).
    pub route: String,
}

impl TelemetryRow {
    /// The row's fields as the CSV writes them, in [`CSV_COLUMNS`] order. Fixed decimals keep
    /// files byte-identical across platforms' float formatting, and diffable.
    pub fn to_record(&self) -> [String; 17] {
        [
            format!("{:.*}", TIME_DECIMALS as usize, self.time_s),
            self.vehicle_id.to_string(),
            self.driver.clone(),
            self.road.clone(),
            self.lane.to_string(),
            format!("{:.*}", S_DECIMALS as usize, self.s_m),
            format!("{:.3}", self.pos_m[0]),
            format!("{:.3}", self.pos_m[1]),
            format!("{:.3}", self.pos_m[2]),
            format!("{:.*}", SPEED_DECIMALS as usize, self.speed_kmh),
            format!("{:.3}", self.accel_mps2),
            format!("{:.4}", self.throttle),
            format!("{:.4}", self.steering),
            self.gear.to_string(),
            format!("{:.1}", self.rpm),
            self.model.clone(),
            self.route.clone(),
        ]
    }

    /// The row as a reader of its CSV sees it: every number rounded to the decimals it is
    /// written with, so what is measured from a run and from its CSV agrees.
    pub fn as_written(&self) -> TelemetryRow {
        let round = rounded_as_written;
        TelemetryRow {
            time_s: round(self.time_s, TIME_DECIMALS),
            s_m: round(self.s_m, S_DECIMALS),
            pos_m: self.pos_m.map(|v| round(v, 3)),
            speed_kmh: round(self.speed_kmh, SPEED_DECIMALS),
            accel_mps2: round(self.accel_mps2, 3),
            throttle: round(self.throttle, 4),
            steering: round(self.steering, 4),
            rpm: round(self.rpm, 1),
            ..self.clone()
        }
    }
}

/// Decimals the CSV writes `time_s` with.
pub const TIME_DECIMALS: i32 = 3;
/// Decimals the CSV writes `s_m` with.
pub const S_DECIMALS: i32 = 3;
/// Decimals the CSV writes `speed_kmh` with.
pub const SPEED_DECIMALS: i32 = 3;

/// `v` as a reader of the CSV sees it, written with `decimals` decimals.
pub fn rounded_as_written(v: f64, decimals: i32) -> f64 {
    let k = 10f64.powi(decimals);
    (v * k).round() / k
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
            self.out.write_record(r.to_record())?;
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
            model: "FlockLanes".into(),
            route: "north".into(),
        };
        w.write_sample(std::slice::from_ref(&row)).expect("write");
        // Readable before finish: a killed run keeps what it measured.
        let text = std::fs::read_to_string(&path).expect("read");
        assert_eq!(
            text,
            "time_s,vehicle_id,driver,road,lane,s_m,x_m,y_m,z_m,speed_kmh,accel_mps2,throttle,steering,gear,rpm,model,route\n\
             0.500,3,auto,main,1,12.346,1.000,2.000,0.250,59.990,-0.500,0.2500,-0.0100,3,2100.0,FlockLanes,north\n"
        );
        assert_eq!(w.rows(), 1);
        w.finish().expect("finish");
        assert_eq!(row.as_written().s_m, 12.346);
    }

    #[test]
    fn the_column_list_is_the_enum_in_order() {
        for (i, c) in Column::ALL.iter().enumerate() {
            assert_eq!(CSV_COLUMNS[i], c.name());
            assert!(!c.description().is_empty());
        }
        assert_eq!(CSV_COLUMNS[15], "model", "new columns go at the end");
        assert_eq!(CSV_COLUMNS[16], "route", "new columns go at the end");
    }
}
