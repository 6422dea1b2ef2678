//! Telemetry samples and run statistics.

use crate::spawn::{SpawnerRate, VehicleId};
use bevy_ecs::prelude::*;
use flockway_core::SimClock;
use flockway_drivers::{DriverLabel, Route};
use flockway_road::RoadId;
use flockway_vehicle::{Controls, Motion, RoadTrack, VehicleState};
use glam::Vec3;
use std::collections::BTreeMap;
use std::sync::Arc;

/// How telemetry is sampled.
#[derive(Resource, Debug, Clone, Copy, PartialEq)]
pub struct TelemetrySettings {
    /// Sampling period, ticks.
    pub period_ticks: u64,
    /// Samples before this tick are left out of the summary statistics (warm-up).
    pub stats_from_tick: u64,
}

impl Default for TelemetrySettings {
    fn default() -> Self {
        TelemetrySettings {
            period_ticks: 60,
            stats_from_tick: 0,
        }
    }
}

/// One vehicle at one sample time.
#[derive(Debug, Clone, PartialEq)]
pub struct TelemetrySample {
    /// Stable vehicle number.
    pub vehicle_id: u32,
    /// Driver profile.
    pub driver: Arc<str>,
    /// Driver model.
    pub model: Arc<str>,
    /// Route name (empty: it follows the road).
    pub route: Arc<str>,
    /// Road.
    pub road: RoadId,
    /// Lane.
    pub lane: u32,
    /// Arc position, m.
    pub s_m: f64,
    /// Centre of mass, m.
    pub position: Vec3,
    /// Speed along the body's forward axis, km/h.
    pub speed_kmh: f32,
    /// Its rate of change, m/s².
    pub accel_mps2: f32,
    /// Throttle input.
    pub throttle: f32,
    /// Steering input.
    pub steering: f32,
    /// Gear.
    pub gear: i8,
    /// Engine speed, rpm.
    pub rpm: f32,
}

/// Samples taken since the runner last drained them: `(tick, rows sorted by vehicle id)`.
#[derive(Resource, Debug, Clone, Default)]
pub struct TelemetrySamples {
    /// Pending sample times and their rows.
    pub pending: Vec<(u64, Vec<TelemetrySample>)>,
}

/// What a run measured so far.
#[derive(Resource, Debug, Clone, Default, PartialEq)]
pub struct TrafficStats {
    /// Vehicles spawned (spawners and initial vehicles).
    pub spawned: u64,
    /// Vehicles removed by destroyers.
    pub destroyed: u64,
    /// Vehicles removed after hitting a guardrail.
    pub collisions_guardrail: u64,
    /// The same per driver profile.
    pub guardrail_by_profile: BTreeMap<String, u64>,
    /// Vehicle–vehicle contacts (one per pair per episode of contact).
    pub collisions_vehicle: u64,
    /// Vehicles each destroyer removed after the warm-up.
    pub destroyed_by: BTreeMap<String, u64>,
    /// Travel times of vehicles removed after the warm-up, s.
    pub travel_times_s: Vec<f64>,
    /// Their delays: travel time above the time the same distance takes at the speed limits in
    /// force, s; the sum and count over all, and per profile.
    pub delay: DelayStats,
    /// The same per driver profile.
    pub delay_by_profile: BTreeMap<String, DelayStats>,
    /// Speed samples after the warm-up: count, sum and sum of squares (km/h).
    pub speed_samples: u64,
    /// Sum of sampled speeds, km/h.
    pub speed_sum: f64,
    /// Sum of squared sampled speeds, (km/h)².
    pub speed_sq_sum: f64,
    /// Speed samples after the warm-up, per driver profile.
    pub speed_by_profile: BTreeMap<String, SpeedStats>,
    /// Speeds of vehicles as destroyers removed them (after the warm-up), all and per profile.
    pub final_speed: SpeedStats,
    /// The same per driver profile.
    pub final_speed_by_profile: BTreeMap<String, SpeedStats>,
    /// How many of those vehicles left at their speed limit (all, and per profile).
    pub final_at_limit: LimitShare,
    /// The same per driver profile.
    pub final_at_limit_by_profile: BTreeMap<String, LimitShare>,
    /// Timetabled vehicles now due that have not yet found room to depart.
    pub insertion_backlog: u64,
}

/// Sum and count of vehicles' delays, s.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct DelayStats {
    /// Vehicles counted.
    pub n: u64,
    /// Sum of their delays, s.
    pub sum_s: f64,
}

impl DelayStats {
    /// Counts one vehicle's delay.
    pub fn add(&mut self, delay_s: f64) {
        self.n += 1;
        self.sum_s += delay_s;
    }

    /// Mean delay, s.
    pub fn mean_s(&self) -> Option<f64> {
        (self.n > 0).then(|| self.sum_s / self.n as f64)
    }
}

/// Of the vehicles counted, how many reached their speed limit.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LimitShare {
    /// Vehicles counted.
    pub n: u64,
    /// Of those, vehicles at [`AT_LIMIT_SHARE`] of their limit or faster.
    pub reached: u64,
}

/// A vehicle counts as at its limit from this share of it (its own speed choice and the
/// controller's tracking keep even a car that wants the limit a little off it).
pub const AT_LIMIT_SHARE: f64 = 0.95;

impl LimitShare {
    /// Counts one vehicle leaving at `kmh` under a `limit_kmh` limit.
    pub fn add(&mut self, kmh: f64, limit_kmh: f64) {
        self.n += 1;
        if kmh >= AT_LIMIT_SHARE * limit_kmh {
            self.reached += 1;
        }
    }

    /// The share that reached the limit, 0–1.
    pub fn share(&self) -> Option<f64> {
        (self.n > 0).then(|| self.reached as f64 / self.n as f64)
    }
}

/// Count, sum and sum of squares of speeds, km/h.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SpeedStats {
    /// Samples.
    pub n: u64,
    /// Sum, km/h.
    pub sum: f64,
    /// Sum of squares, (km/h)².
    pub sq_sum: f64,
}

impl SpeedStats {
    /// Adds a sample.
    pub fn add(&mut self, kmh: f64) {
        self.n += 1;
        self.sum += kmh;
        self.sq_sum += kmh * kmh;
    }

    /// Mean, km/h.
    pub fn mean(&self) -> Option<f64> {
        (self.n > 0).then(|| self.sum / self.n as f64)
    }

    /// Standard deviation, km/h.
    pub fn std(&self) -> Option<f64> {
        let m = self.mean()?;
        Some((self.sq_sum / self.n as f64 - m * m).max(0.0).sqrt())
    }
}

impl TrafficStats {
    /// Mean sampled speed after the warm-up, km/h.
    pub fn mean_speed_kmh(&self) -> Option<f64> {
        (self.speed_samples > 0).then(|| self.speed_sum / self.speed_samples as f64)
    }

    /// Standard deviation of the sampled speeds after the warm-up, km/h.
    pub fn speed_std_kmh(&self) -> Option<f64> {
        let mean = self.mean_speed_kmh()?;
        let var = self.speed_sq_sum / self.speed_samples as f64 - mean * mean;
        Some(var.max(0.0).sqrt())
    }

    /// Mean travel time of destroyed vehicles after the warm-up, s.
    pub fn mean_travel_time_s(&self) -> Option<f64> {
        (!self.travel_times_s.is_empty())
            .then(|| self.travel_times_s.iter().sum::<f64>() / self.travel_times_s.len() as f64)
    }
}

/// Every sampling period: one row per vehicle (sorted by vehicle id) into [`TelemetrySamples`],
/// and its speed into the statistics after the warm-up. Also updates [`SpawnerRate`].
#[allow(clippy::type_complexity)]
pub fn sample_telemetry(
    clock: Res<SimClock>,
    settings: Res<TelemetrySettings>,
    mut samples: ResMut<TelemetrySamples>,
    mut stats: ResMut<TrafficStats>,
    mut rate: ResMut<SpawnerRate>,
    vehicles: Query<(
        &VehicleId,
        &RoadTrack,
        &Motion,
        &Controls,
        &VehicleState,
        Option<&DriverLabel>,
        Option<&Route>,
    )>,
) {
    let tick = clock.tick().0;
    let seconds = clock.seconds();
    if seconds > 0.0 {
        rate.per_s = stats.spawned as f64 / seconds;
    }
    if !tick.is_multiple_of(settings.period_ticks.max(1)) {
        return;
    }
    let mut rows: Vec<TelemetrySample> = vehicles
        .iter()
        .map(
            |(id, track, motion, controls, state, label, route)| TelemetrySample {
                vehicle_id: id.0,
                driver: label.map_or_else(|| Arc::from("none"), |l| l.profile.clone()),
                model: label.map_or_else(|| Arc::from("none"), |l| l.model.clone()),
                route: route.map_or_else(|| Arc::from(""), |r| r.name.clone()),
                road: track.road,
                lane: track.lane,
                s_m: track.s_m,
                position: motion.position,
                speed_kmh: motion.forward_mps * 3.6,
                accel_mps2: motion.accel_mps2,
                throttle: controls.throttle,
                steering: controls.steering,
                gear: state.gearbox.gear,
                rpm: state.rpm(),
            },
        )
        .collect();
    rows.sort_unstable_by_key(|r| r.vehicle_id);
    if tick >= settings.stats_from_tick {
        for r in &rows {
            let v = f64::from(r.speed_kmh);
            stats.speed_samples += 1;
            stats.speed_sum += v;
            stats.speed_sq_sum += v * v;
            match stats.speed_by_profile.get_mut(&*r.driver) {
                Some(p) => p.add(v),
                None => {
                    let mut p = SpeedStats::default();
                    p.add(v);
                    stats.speed_by_profile.insert(r.driver.to_string(), p);
                }
            }
        }
    }
    samples.pending.push((tick, rows));
}
