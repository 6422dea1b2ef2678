//! The detectors CSV: beside a run's telemetry CSV, a row per induction loop (a lane of a
//! detector) and period, streamed as each period closes.

use flockway_road::RoadNetwork;
use flockway_traffic::{DetectorReading, Detectors};
use std::fs::File;
use std::path::{Path, PathBuf};

/// The detectors CSV's columns, in order (a contract, like the telemetry CSV's).
pub const DETECTOR_COLUMNS: [&str; 12] = [
    "begin_s",
    "end_s",
    "detector",
    "road",
    "lane",
    "s_m",
    "count",
    "flow_veh_h",
    "occupancy_pct",
    "mean_speed_kmh",
    "harmonic_speed_kmh",
    "mean_length_m",
];

/// Where the detectors CSV of a telemetry CSV goes: `run.csv` → `run.detectors.csv`.
pub fn detectors_path(csv: &Path) -> PathBuf {
    crate::signals::beside(csv, "detectors")
}

/// One reading as the CSV's cells (an empty cell for a speed or length with no vehicle).
pub fn reading_row(
    network: &RoadNetwork,
    detectors: &Detectors,
    r: &DetectorReading,
) -> [String; 12] {
    let d = &detectors.list[r.detector];
    let opt =
        |v: Option<f64>, places: usize| v.map_or_else(String::new, |v| format!("{v:.places$}"));
    [
        format!("{:.3}", r.begin_s),
        format!("{:.3}", r.end_s),
        d.name.clone(),
        network
            .get(d.road)
            .map_or_else(String::new, |g| g.name().to_owned()),
        r.lane.to_string(),
        format!("{:.3}", d.s_m),
        r.count.to_string(),
        format!("{:.1}", r.flow_veh_h()),
        format!("{:.3}", r.occupancy_pct),
        opt(r.mean_speed_kmh, 3),
        opt(r.harmonic_speed_kmh, 3),
        opt(r.mean_length_m, 3),
    ]
}

/// Streams the detectors' readings to a CSV as their periods close.
pub struct DetectorsWriter {
    path: PathBuf,
    out: csv::Writer<File>,
    /// Readings written so far.
    written: usize,
}

impl DetectorsWriter {
    /// Creates (or truncates) the file and writes the header.
    pub fn create(path: &Path) -> std::io::Result<DetectorsWriter> {
        let mut out = csv::Writer::from_writer(File::create(path)?);
        out.write_record(DETECTOR_COLUMNS)?;
        out.flush()?;
        Ok(DetectorsWriter {
            path: path.to_owned(),
            out,
            written: 0,
        })
    }

    /// The file being written.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Writes the readings closed since the last call.
    pub fn record(&mut self, network: &RoadNetwork, detectors: &Detectors) -> std::io::Result<()> {
        let new = detectors.readings.get(self.written..).unwrap_or_default();
        if new.is_empty() {
            return Ok(());
        }
        for r in new {
            self.out.write_record(reading_row(network, detectors, r))?;
        }
        self.written = detectors.readings.len();
        self.out.flush()
    }

    /// Flushes what is left.
    pub fn finish(mut self) -> std::io::Result<()> {
        self.out.flush()
    }
}

/// Every loop (a lane of a detector) now, a column per quantity, in the level's detector order
/// then lane order: its current period so far and its last closed period.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DetectorColumns {
    /// The detector names the `detector` column indexes.
    pub detectors: Vec<String>,
    /// Detector, as an index into `detectors`.
    pub detector: Vec<u32>,
    /// Road, as an index into [`crate::Session::road_names`].
    pub road: Vec<u32>,
    /// Lane.
    pub lane: Vec<u32>,
    /// Arc position of the detector, m.
    pub s_m: Vec<f64>,
    /// Vehicles over the point in the last step.
    pub vehicles: Vec<u32>,
    /// When the current period began, s.
    pub period_begin_s: Vec<f64>,
    /// Vehicles that passed in the current period so far.
    pub count: Vec<u32>,
    /// Share of the current period so far that a vehicle covered the point, %.
    pub occupancy_pct: Vec<f64>,
    /// Mean speed of the vehicles that passed in the current period so far, km/h (NaN: none).
    pub mean_speed_kmh: Vec<f64>,
    /// Vehicles that passed in the last closed period (0 before the first closes).
    pub last_count: Vec<u32>,
    /// Flow in the last closed period, vehicles per hour.
    pub last_flow_veh_h: Vec<f64>,
    /// Occupancy in the last closed period, %.
    pub last_occupancy_pct: Vec<f64>,
    /// Mean speed in the last closed period, km/h (NaN: none, or no period closed yet).
    pub last_mean_speed_kmh: Vec<f64>,
}

impl DetectorColumns {
    /// The columns of `detectors` now.
    pub fn of(detectors: &Detectors) -> DetectorColumns {
        let mut out = DetectorColumns {
            detectors: detectors.list.iter().map(|d| d.name.clone()).collect(),
            ..DetectorColumns::default()
        };
        // The last closed reading of each loop: the latest in the time-ordered list, found from
        // its end (a long run's list is long; every loop closed lately).
        let loops: usize = detectors.list.iter().map(|d| d.lanes.len()).sum();
        let mut last: std::collections::BTreeMap<(usize, u32), &DetectorReading> =
            std::collections::BTreeMap::new();
        for r in detectors.readings.iter().rev() {
            if last.len() == loops {
                break;
            }
            last.entry((r.detector, r.lane)).or_insert(r);
        }
        for (k, d) in detectors.list.iter().enumerate() {
            for (r, c) in detectors.current(k).iter().zip(&detectors.counters[k]) {
                let closed = last.get(&(k, r.lane));
                out.detector.push(k as u32);
                out.road.push(d.road.0);
                out.lane.push(r.lane);
                out.s_m.push(d.s_m);
                out.vehicles.push(c.on_now);
                out.period_begin_s.push(r.begin_s);
                out.count.push(r.count);
                out.occupancy_pct.push(r.occupancy_pct);
                out.mean_speed_kmh
                    .push(r.mean_speed_kmh.unwrap_or(f64::NAN));
                out.last_count.push(closed.map_or(0, |c| c.count));
                out.last_flow_veh_h
                    .push(closed.map_or(0.0, |c| c.flow_veh_h()));
                out.last_occupancy_pct
                    .push(closed.map_or(0.0, |c| c.occupancy_pct));
                out.last_mean_speed_kmh
                    .push(closed.and_then(|c| c.mean_speed_kmh).unwrap_or(f64::NAN));
            }
        }
        out
    }
}

/// Every closed reading of `detectors` as the detectors CSV's text (header included), and with
/// `current` each loop's current period so far after them (ending now).
pub fn readings_csv(network: &RoadNetwork, detectors: &Detectors, current: bool) -> String {
    let mut out = csv::Writer::from_writer(Vec::new());
    let open: Vec<DetectorReading> = if current {
        (0..detectors.list.len())
            .flat_map(|k| detectors.current(k))
            .filter(|r| r.end_s > r.begin_s)
            .collect()
    } else {
        Vec::new()
    };
    // Writing to memory cannot fail.
    let _ = out.write_record(DETECTOR_COLUMNS);
    for r in detectors.readings.iter().chain(&open) {
        let _ = out.write_record(reading_row(network, detectors, r));
    }
    String::from_utf8(out.into_inner().unwrap_or_default()).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_detectors_file_sits_beside_the_csv_with_its_stem() {
        assert_eq!(
            detectors_path(Path::new("out/run.csv")),
            PathBuf::from("out/run.detectors.csv")
        );
    }
}
