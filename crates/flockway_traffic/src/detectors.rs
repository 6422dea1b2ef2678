//! Induction loops: points across a road's lanes that count the vehicles passing, measure how
//! long a vehicle covers them and how fast vehicles pass, and close a reading per lane at the
//! end of every period — what a traffic engineer's loop detectors give, and what signal
//! controllers are fed in the field.

use crate::zones::Travel;
use bevy_ecs::prelude::*;
use flockway_core::TICKS_PER_SECOND;
use flockway_road::{RoadId, RoadNetwork};
use flockway_vehicle::{RoadTrack, VehicleModel};
use std::collections::BTreeMap;

/// One detector: a point across some lanes of a road.
#[derive(Debug, Clone, PartialEq)]
pub struct Detector {
    /// Name.
    pub name: String,
    /// Road.
    pub road: RoadId,
    /// Arc position, m.
    pub s_m: f64,
    /// Lanes it covers, ascending (a loop each).
    pub lanes: Vec<u32>,
    /// Length of a period, ticks.
    pub period_ticks: u64,
}

/// What one loop (a lane of a detector) measured over one period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DetectorReading {
    /// The detector, by its position in [`Detectors::list`].
    pub detector: usize,
    /// The lane.
    pub lane: u32,
    /// Start of the period, s.
    pub begin_s: f64,
    /// End of the period, s (the run's end for a last, shorter period).
    pub end_s: f64,
    /// Vehicles whose front passed the point.
    pub count: u32,
    /// Share of the period a vehicle covered the point, % (0–100).
    pub occupancy_pct: f64,
    /// Arithmetic mean of the passing vehicles' speeds, km/h (`None` with no vehicle).
    pub mean_speed_kmh: Option<f64>,
    /// Harmonic mean of the passing vehicles' speeds, km/h (the space-mean speed that flow
    /// and density relate by; `None` with no vehicle or one passing at a standstill).
    pub harmonic_speed_kmh: Option<f64>,
    /// Mean length of the passing vehicles, m (`None` with no vehicle).
    pub mean_length_m: Option<f64>,
}

impl DetectorReading {
    /// Vehicles per hour over the period.
    pub fn flow_veh_h(&self) -> f64 {
        let span = self.end_s - self.begin_s;
        if span > 0.0 {
            f64::from(self.count) * 3600.0 / span
        } else {
            0.0
        }
    }
}

/// What a loop gathers during its current period.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LoopCounters {
    /// Vehicles that passed.
    pub count: u32,
    /// Sum of their speeds, m/s.
    pub speed_sum_mps: f64,
    /// Sum of the inverses of their speeds, s/m (standstills left out).
    pub pace_sum_s_per_m: f64,
    /// Vehicles counted into the pace sum.
    pub paced: u32,
    /// Sum of their lengths, m.
    pub length_sum_m: f64,
    /// Ticks a vehicle covered the point.
    pub occupied_ticks: u64,
    /// Vehicles over the point in the last tick measured.
    pub on_now: u32,
}

/// Every detector of the run, its current period's counters and every closed period's reading.
/// The runner inserts it when a level has detectors; without it nothing is measured.
#[derive(Resource, Debug, Clone, Default)]
pub struct Detectors {
    /// The detectors, in the level's order.
    pub list: Vec<Detector>,
    /// Per detector, per lane (in its `lanes` order): the current period's counters.
    pub counters: Vec<Vec<LoopCounters>>,
    /// Every period closed so far, in time order, then detector and lane order.
    pub readings: Vec<DetectorReading>,
    /// Per detector, the tick its current period began.
    begun: Vec<u64>,
    /// Ticks measured so far (the run's time measured, in ticks).
    measured: u64,
    /// Detectors by road, as positions in `list`.
    by_road: BTreeMap<RoadId, Vec<usize>>,
}

impl Detectors {
    /// The detectors, measuring from tick 0.
    pub fn new(list: Vec<Detector>) -> Detectors {
        let mut by_road: BTreeMap<RoadId, Vec<usize>> = BTreeMap::new();
        for (k, d) in list.iter().enumerate() {
            by_road.entry(d.road).or_default().push(k);
        }
        Detectors {
            counters: list
                .iter()
                .map(|d| vec![LoopCounters::default(); d.lanes.len()])
                .collect(),
            begun: vec![0; list.len()],
            list,
            readings: Vec::new(),
            measured: 0,
            by_road,
        }
    }

    /// The tick detector `k`'s current period began.
    pub fn period_begin_tick(&self, k: usize) -> u64 {
        self.begun.get(k).copied().unwrap_or(0)
    }

    /// Ticks measured so far.
    pub fn measured_ticks(&self) -> u64 {
        self.measured
    }

    /// The reading of detector `k`'s current period so far (its `end_s` is now).
    pub fn current(&self, k: usize) -> Vec<DetectorReading> {
        let (Some(d), Some(counters)) = (self.list.get(k), self.counters.get(k)) else {
            return Vec::new();
        };
        d.lanes
            .iter()
            .zip(counters)
            .map(|(&lane, c)| reading(k, lane, c, self.begun[k], self.measured))
            .collect()
    }

    /// Closes every detector's current period at the end of the ticks measured, if it measured
    /// any (the last, shorter period of a run).
    pub fn close_all(&mut self) {
        for k in 0..self.list.len() {
            if self.measured > self.begun[k] {
                self.close(k);
            }
        }
    }

    /// Closes detector `k`'s period at the end of the ticks measured and starts the next.
    fn close(&mut self, k: usize) {
        let begun = self.begun[k];
        for (lane, c) in self.list[k].lanes.iter().zip(&mut self.counters[k]) {
            self.readings
                .push(reading(k, *lane, c, begun, self.measured));
            *c = LoopCounters::default();
        }
        self.begun[k] = self.measured;
    }

    /// Measures one tick: `vehicles` are where each vehicle is now, where it was the tick
    /// before ([`Travel`], not yet moved on) and its length.
    fn measure<'a>(
        &mut self,
        network: &RoadNetwork,
        vehicles: impl Iterator<Item = (&'a RoadTrack, &'a Travel, f64)>,
    ) {
        for c in self.counters.iter_mut().flatten() {
            c.on_now = 0;
        }
        for (track, travel, length_m) in vehicles {
            let Some(here) = self.by_road.get(&track.road) else {
                continue;
            };
            let Some(g) = network.get(track.road) else {
                continue;
            };
            for &k in here {
                let d = &self.list[k];
                let Some(slot) = d.lanes.iter().position(|&l| l == track.lane) else {
                    continue;
                };
                let c = &mut self.counters[k][slot];
                // Over the point: the body (centred on the track's position) covers it.
                if g.delta_s(d.s_m, track.s_m).abs() <= 0.5 * length_m {
                    c.on_now += 1;
                }
                // The front passed the point between last tick and this one (forwards, across a
                // loop's join too), or the vehicle came onto the road with its front past it.
                let front = |s: f64| s + 0.5 * length_m;
                let passed = if travel.road == track.road {
                    let moved = g.delta_s(travel.s_m, track.s_m);
                    let to_point = g.delta_s(front(travel.s_m), d.s_m);
                    moved > 0.0 && to_point > 0.0 && to_point <= moved
                } else {
                    (0.0..50.0).contains(&g.delta_s(d.s_m, front(track.s_m)))
                };
                if passed {
                    let speed = f64::from(track.speed_along_mps).max(0.0);
                    c.count += 1;
                    c.speed_sum_mps += speed;
                    if speed > 0.0 {
                        c.pace_sum_s_per_m += 1.0 / speed;
                        c.paced += 1;
                    }
                    c.length_sum_m += length_m;
                }
            }
        }
        for c in self.counters.iter_mut().flatten() {
            if c.on_now > 0 {
                c.occupied_ticks += 1;
            }
        }
        self.measured += 1;
        for k in 0..self.list.len() {
            let period = self.list[k].period_ticks.max(1);
            if self.measured - self.begun[k] >= period {
                self.close(k);
            }
        }
    }
}

/// A loop's reading from its counters over ticks `begun..end`.
fn reading(k: usize, lane: u32, c: &LoopCounters, begun: u64, end: u64) -> DetectorReading {
    let seconds = |t: u64| t as f64 / f64::from(TICKS_PER_SECOND);
    let span = end.saturating_sub(begun);
    let n = f64::from(c.count);
    DetectorReading {
        detector: k,
        lane,
        begin_s: seconds(begun),
        end_s: seconds(end),
        count: c.count,
        occupancy_pct: if span > 0 {
            100.0 * c.occupied_ticks as f64 / span as f64
        } else {
            0.0
        },
        mean_speed_kmh: (c.count > 0).then(|| 3.6 * c.speed_sum_mps / n),
        harmonic_speed_kmh: (c.paced > 0 && c.paced == c.count)
            .then(|| 3.6 * f64::from(c.paced) / c.pace_sum_s_per_m),
        mean_length_m: (c.count > 0).then(|| c.length_sum_m / n),
    }
}

/// Measures every detector this tick (when the run has [`Detectors`]). Runs in `Record`, before
/// the destroyers move each vehicle's [`Travel`] on, so it sees where each vehicle was.
pub fn measure_detectors(
    detectors: Option<ResMut<Detectors>>,
    network: Res<RoadNetwork>,
    vehicles: Query<(&RoadTrack, &Travel, &VehicleModel)>,
) {
    let Some(mut detectors) = detectors else {
        return;
    };
    detectors.measure(
        &network,
        vehicles
            .iter()
            .map(|(t, tr, m)| (t, tr, f64::from(m.0.params.chassis.length_m))),
    );
}
