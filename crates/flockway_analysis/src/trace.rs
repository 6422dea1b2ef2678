//! A run's telemetry in memory: the columns analysis needs, read from a CSV or pushed by a runner.

use crate::AnalysisError;
use crate::telemetry::{
    Column, S_DECIMALS, SPEED_DECIMALS, TIME_DECIMALS, TelemetryRow, rounded_as_written,
};
use std::collections::BTreeMap;
use std::path::Path;

/// One vehicle at one sample time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Simulated time, seconds.
    pub time_s: f64,
    /// Stable vehicle number.
    pub vehicle_id: u32,
    /// Index into [`Trace::drivers`].
    pub driver: u16,
    /// Index into [`Trace::roads`].
    pub road: u16,
    /// Lane index (0 is the rightmost).
    pub lane: u32,
    /// Arc position along the road, metres.
    pub s_m: f64,
    /// Speed along the direction of travel, km/h.
    pub speed_kmh: f64,
    /// Index into [`Trace::models`] (its entry is empty when the CSV has no `model` column).
    pub model: u16,
}

/// One vehicle at one sample time, its names as text: what [`Trace::push_as_written`] takes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NamedSample<'a> {
    /// Simulated time, seconds.
    pub time_s: f64,
    /// Stable vehicle number.
    pub vehicle_id: u32,
    /// Driver profile name.
    pub driver: &'a str,
    /// Road name.
    pub road: &'a str,
    /// Lane index (0 is the rightmost).
    pub lane: u32,
    /// Arc position along the road, metres.
    pub s_m: f64,
    /// Speed along the direction of travel, km/h.
    pub speed_kmh: f64,
    /// Driver model name (empty when not known).
    pub model: &'a str,
}

/// The columns [`Trace::read_csv`] needs; any others are ignored (and `model` is used when
/// there).
pub const REQUIRED: [Column; 7] = [
    Column::TimeS,
    Column::VehicleId,
    Column::Driver,
    Column::Road,
    Column::Lane,
    Column::SM,
    Column::SpeedKmh,
];

/// The names of [`REQUIRED`], in order.
pub const REQUIRED_COLUMNS: [&str; 7] = {
    let mut out = [""; 7];
    let mut i = 0;
    while i < 7 {
        out[i] = REQUIRED[i].name();
        i += 1;
    }
    out
};

/// Telemetry samples of one run, in time order, with driver, road and model names interned.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Trace {
    samples: Vec<Sample>,
    drivers: Vec<String>,
    roads: Vec<String>,
    models: Vec<String>,
    /// The model of each driver profile, by [`Sample::driver`]: the one its first sample names.
    driver_models: Vec<u16>,
}

impl Trace {
    /// An empty trace.
    pub fn new() -> Trace {
        Trace::default()
    }

    /// Appends a sample. Samples must come in non-decreasing time order.
    #[expect(
        clippy::too_many_arguments,
        reason = "one sample's columns, each named at the call"
    )]
    pub fn push(
        &mut self,
        time_s: f64,
        vehicle_id: u32,
        driver: &str,
        road: &str,
        lane: u32,
        s_m: f64,
        speed_kmh: f64,
    ) {
        self.push_named(NamedSample {
            time_s,
            vehicle_id,
            driver,
            road,
            lane,
            s_m,
            speed_kmh,
            model: "",
        });
    }

    /// Appends a row of the telemetry CSV contract, as its CSV holds it.
    pub fn push_row(&mut self, row: &TelemetryRow) {
        self.push_named(NamedSample {
            time_s: row.time_s,
            vehicle_id: row.vehicle_id,
            driver: &row.driver,
            road: &row.road,
            lane: row.lane,
            s_m: row.s_m,
            speed_kmh: row.speed_kmh,
            model: &row.model,
        });
    }

    /// Appends a sample as its telemetry CSV row holds it (what [`push_row`](Self::push_row)
    /// of the row's [`as_written`](TelemetryRow::as_written) appends), from the values sampled,
    /// without making the row.
    pub fn push_as_written(&mut self, sample: NamedSample) {
        self.push_named(NamedSample {
            time_s: rounded_as_written(sample.time_s, TIME_DECIMALS),
            s_m: rounded_as_written(sample.s_m, S_DECIMALS),
            speed_kmh: rounded_as_written(sample.speed_kmh, SPEED_DECIMALS),
            ..sample
        });
    }

    /// Appends a sample, its names interned.
    fn push_named(&mut self, named: NamedSample) {
        let driver = intern(&mut self.drivers, named.driver);
        let road = intern(&mut self.roads, named.road);
        let model = intern(&mut self.models, named.model);
        if usize::from(driver) == self.driver_models.len() {
            self.driver_models.push(model);
        }
        self.samples.push(Sample {
            time_s: named.time_s,
            vehicle_id: named.vehicle_id,
            driver,
            road,
            lane: named.lane,
            s_m: named.s_m,
            speed_kmh: named.speed_kmh,
            model,
        });
    }

    /// Driver model names, indexed by [`Sample::model`] (empty for a CSV without the column).
    pub fn models(&self) -> &[String] {
        &self.models
    }

    /// The driver model of a profile's vehicles, if the trace knows it.
    pub fn model_of(&self, driver: u16) -> Option<&str> {
        self.driver_models
            .get(usize::from(driver))
            .and_then(|&m| self.models.get(usize::from(m)))
            .map(String::as_str)
            .filter(|m| !m.is_empty())
    }

    /// Every sample, in time order.
    pub fn samples(&self) -> &[Sample] {
        &self.samples
    }

    /// Driver profile names, indexed by [`Sample::driver`].
    pub fn drivers(&self) -> &[String] {
        &self.drivers
    }

    /// Road names, indexed by [`Sample::road`].
    pub fn roads(&self) -> &[String] {
        &self.roads
    }

    /// Whether the trace has no samples.
    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    /// The last sample time, seconds (0 for an empty trace).
    pub fn end_s(&self) -> f64 {
        self.samples.last().map_or(0.0, |s| s.time_s)
    }

    /// The distinct sample times, in order.
    pub fn times(&self) -> Vec<f64> {
        let mut out: Vec<f64> = Vec::new();
        for s in &self.samples {
            if out.last() != Some(&s.time_s) {
                out.push(s.time_s);
            }
        }
        out
    }

    /// The samples grouped by time: `(time_s, samples at that time)`.
    pub fn by_time(&self) -> impl Iterator<Item = (f64, &[Sample])> {
        self.samples
            .chunk_by(|a, b| a.time_s == b.time_s)
            .map(|chunk| (chunk[0].time_s, chunk))
    }

    /// Each vehicle's samples in time order, by vehicle id.
    pub fn by_vehicle(&self) -> BTreeMap<u32, Vec<Sample>> {
        let mut out: BTreeMap<u32, Vec<Sample>> = BTreeMap::new();
        for s in &self.samples {
            out.entry(s.vehicle_id).or_default().push(*s);
        }
        out
    }

    /// Whether vehicles leave the run before its end (a destroyer, or a crash): the roads are
    /// open, and flow through them is meaningful.
    pub fn vehicles_leave(&self) -> bool {
        let end = self.end_s();
        self.by_vehicle()
            .values()
            .any(|v| v.last().is_some_and(|s| s.time_s < end))
    }

    /// Reads a telemetry CSV written by `flockway run --csv`. Errors name the file and the missing
    /// column, or the line and column of a value that does not parse.
    pub fn read_csv(path: &Path) -> Result<Trace, AnalysisError> {
        let file = std::fs::File::open(path).map_err(|source| AnalysisError::Io {
            path: path.to_owned(),
            source,
        })?;
        Trace::from_reader(file, path)
    }

    /// Reads telemetry CSV from any reader; `path` names it in errors.
    pub fn from_reader(reader: impl std::io::Read, path: &Path) -> Result<Trace, AnalysisError> {
        let mut csv = csv::ReaderBuilder::new()
            .has_headers(true)
            .from_reader(reader);
        let headers = csv.headers().map_err(|e| csv_error(path, e))?.clone();
        let model_at = headers
            .iter()
            .position(|h| h.trim() == Column::Model.name());
        let mut index = [0usize; REQUIRED_COLUMNS.len()];
        for (slot, name) in index.iter_mut().zip(REQUIRED_COLUMNS) {
            *slot = headers
                .iter()
                .position(|h| h.trim() == name)
                .ok_or_else(|| AnalysisError::MissingColumn {
                    path: path.to_owned(),
                    column: name,
                    found: headers
                        .iter()
                        .map(str::to_owned)
                        .collect::<Vec<_>>()
                        .join(","),
                })?;
        }
        let mut trace = Trace::new();
        let mut record = csv::StringRecord::new();
        loop {
            match csv.read_record(&mut record) {
                Ok(false) => break,
                Ok(true) => {}
                Err(e) => return Err(csv_error(path, e)),
            }
            let line = record.position().map_or(0, |p| p.line());
            let field = |i: usize| record.get(index[i]).unwrap_or("").trim();
            let number = |i: usize| -> Result<f64, AnalysisError> {
                field(i)
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| AnalysisError::BadValue {
                        path: path.to_owned(),
                        line,
                        column: REQUIRED_COLUMNS[i],
                        value: field(i).to_owned(),
                        expected: "a finite number",
                    })
            };
            let integer = |i: usize| -> Result<u32, AnalysisError> {
                field(i)
                    .parse::<u32>()
                    .map_err(|_| AnalysisError::BadValue {
                        path: path.to_owned(),
                        line,
                        column: REQUIRED_COLUMNS[i],
                        value: field(i).to_owned(),
                        expected: "a whole number ≥ 0",
                    })
            };
            let time_s = number(0)?;
            if time_s < trace.end_s() {
                return Err(AnalysisError::BadValue {
                    path: path.to_owned(),
                    line,
                    column: "time_s",
                    value: field(0).to_owned(),
                    expected: "times in non-decreasing order",
                });
            }
            let vehicle_id = integer(1)?;
            let lane = integer(4)?;
            let s_m = number(5)?;
            let speed_kmh = number(6)?;
            let model = model_at.and_then(|i| record.get(i)).unwrap_or("").trim();
            trace.push_named(NamedSample {
                time_s,
                vehicle_id,
                driver: field(2),
                road: field(3),
                lane,
                s_m,
                speed_kmh,
                model,
            });
        }
        if trace.is_empty() {
            return Err(AnalysisError::Empty {
                path: path.to_owned(),
            });
        }
        Ok(trace)
    }
}

fn intern(names: &mut Vec<String>, name: &str) -> u16 {
    match names.iter().position(|n| n == name) {
        Some(i) => i as u16,
        None => {
            names.push(name.to_owned());
            (names.len() - 1) as u16
        }
    }
}

fn csv_error(path: &Path, e: csv::Error) -> AnalysisError {
    let line = e.position().map_or(0, |p| p.line());
    AnalysisError::Csv {
        path: path.to_owned(),
        line,
        message: e.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEADER: &str = "time_s,vehicle_id,driver,road,lane,s_m,x_m,y_m,z_m,speed_kmh,accel_mps2,throttle,steering,gear,rpm\n";

    fn read(text: &str) -> Result<Trace, AnalysisError> {
        Trace::from_reader(text.as_bytes(), Path::new("run.csv"))
    }

    #[test]
    fn a_sample_pushed_as_written_is_its_row_as_written() {
        let (mut by_row, mut by_values) = (Trace::new(), Trace::new());
        let mut x = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64
        };
        for i in 0..500u32 {
            // Times in order, some on the halfway points; halfway cases and values either side
            // of them among the random places and speeds.
            let time_s = f64::from(i) * 0.0025;
            let (s_m, speed_kmh) = match i % 4 {
                0 => (0.0005 * f64::from(i), 12.3445),
                1 => (-2.5e-4, 1.0e9 * next()),
                _ => (5000.0 * next() - 10.0, 200.0 * next()),
            };
            let row = TelemetryRow {
                time_s,
                vehicle_id: i % 7,
                driver: ["human", "auto"][(i % 2) as usize].into(),
                road: ["main", "ramp", ""][(i % 3) as usize].into(),
                lane: i % 3,
                s_m,
                pos_m: [next(), next(), next()],
                speed_kmh,
                accel_mps2: next(),
                throttle: next(),
                steering: next(),
                gear: 2,
                rpm: 3000.0 * next(),
                model: ["flock", "idm"][(i % 2) as usize].into(),
                route: String::new(),
            };
            by_row.push_row(&row.as_written());
            by_values.push_as_written(NamedSample {
                time_s,
                vehicle_id: row.vehicle_id,
                driver: &row.driver,
                road: &row.road,
                lane: row.lane,
                s_m,
                speed_kmh,
                model: &row.model,
            });
        }
        assert_eq!(by_row.samples(), by_values.samples());
        assert_eq!(by_row.roads(), by_values.roads());
        assert_eq!(by_row.models(), by_values.models());
    }

    #[test]
    fn a_run_csv_reads_into_samples_with_interned_names() {
        let text = format!(
            "{HEADER}0.500,1,auto,main,0,10.000,0,0,0,50.000,0,0,0,3,2000\n\
             0.500,2,human,main,1,20.000,0,0,0,40.000,0,0,0,3,2000\n\
             1.000,1,auto,exit,0,17.000,0,0,0,51.000,0,0,0,3,2000\n"
        );
        let t = read(&text).expect("reads");
        assert_eq!(t.samples().len(), 3);
        assert_eq!(t.drivers(), ["auto", "human"]);
        assert_eq!(t.roads(), ["main", "exit"]);
        assert_eq!(t.times(), [0.5, 1.0]);
        assert_eq!(t.samples()[2].road, 1);
        assert_eq!(t.samples()[1].speed_kmh, 40.0);
        assert_eq!(t.by_vehicle()[&1].len(), 2);
        assert!(t.vehicles_leave(), "vehicle 2 is gone at 1.0 s");
        // Without a `model` column the models are unknown.
        assert_eq!(t.model_of(0), None);
        let with_model = read(
            "time_s,vehicle_id,driver,road,lane,s_m,speed_kmh,model\n\
             0.5,1,auto,main,0,10,50,FlockLanes\n0.5,2,slow,main,0,20,40,Human\n",
        )
        .expect("reads");
        assert_eq!(with_model.model_of(1), Some("Human"));
        assert_eq!(with_model.model_of(0), Some("FlockLanes"));
    }

    #[test]
    fn foreign_or_broken_csv_names_the_column_or_row() {
        let e = read("time,id,speed\n1,2,3\n").expect_err("foreign");
        let msg = e.to_string();
        assert!(msg.contains("run.csv") && msg.contains("`time_s`"), "{msg}");

        let e = read(&format!(
            "{HEADER}0.5,1,auto,main,0,abc,0,0,0,50,0,0,0,3,2000\n"
        ))
        .expect_err("bad number");
        let msg = e.to_string();
        assert!(
            msg.contains("run.csv:2") && msg.contains("s_m") && msg.contains("abc"),
            "{msg}"
        );

        let e = read(&format!(
            "{HEADER}1.0,1,auto,main,0,1,0,0,0,50,0,0,0,3,2000\n0.5,1,auto,main,0,1,0,0,0,50,0,0,0,3,2000\n"
        ))
        .expect_err("time goes back");
        assert!(e.to_string().contains("run.csv:3"), "{e}");

        let e = read(&format!("{HEADER}0.5,1,auto,main,0,1\n")).expect_err("short row");
        assert!(e.to_string().contains("run.csv:2"), "{e}");

        let e = read(HEADER).expect_err("no rows");
        assert!(e.to_string().contains("no samples"), "{e}");
    }
}
