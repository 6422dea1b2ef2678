//! The end of a run: every metric measured from the world and the telemetry, the level's
//! expectations checked against them, the [`Summary`].

use flockway_analysis::{
    CapacitySample, ExpectationResult, Summary, Trace, WaveSettings, measure_wave,
};
use flockway_core::{RunStats, Sim, TICKS_PER_SECOND};
use flockway_drivers::RouteStats;
use flockway_level::{Expectation, Level, Metric};
use flockway_road::RoadNetwork;
use flockway_traffic::{
    CapacityWindows, Conflicts, JunctionMeasures, TelemetrySettings, TrafficStats,
};
use std::collections::BTreeMap;
use std::path::Path;
use std::time::Duration;

/// Every metric of a finished run, keyed as expectations and the summary name them
/// ([`Metric::key`], [`Metric::key_for`]).
pub fn metrics(sim: &Sim, level: &Level, trace: &Trace) -> BTreeMap<String, f64> {
    metrics_with(sim, level, trace, &capacity_samples(sim, level))
}

/// [`metrics`], with the run's capacity samples already taken.
fn metrics_with(
    sim: &Sim,
    level: &Level,
    trace: &Trace,
    samples: &[CapacitySample],
) -> BTreeMap<String, f64> {
    let world = sim.world();
    let ticks = sim.tick().0;
    let stats = *world.resource::<RunStats>();
    let mut out = BTreeMap::new();
    let mut put = |key: String, v: f64| {
        out.insert(key, v);
    };
    put(Metric::Ticks.key(), ticks as f64);
    put(Metric::SimSeconds.key(), sim.tick().seconds());
    put(Metric::VehicleSteps.key(), stats.vehicle_steps as f64);
    put(
        Metric::VehiclesAliveMean.key(),
        stats.vehicle_steps as f64 / ticks.max(1) as f64,
    );
    let network = world.resource::<RoadNetwork>();
    for (_, road) in network.iter() {
        put(Metric::RoadLengthM.key_for(road.name()), road.length_m());
    }
    let traffic = world.resource::<TrafficStats>();
    let settings = *world.resource::<TelemetrySettings>();
    put(Metric::VehiclesSpawned.key(), traffic.spawned as f64);
    put(Metric::VehiclesDestroyed.key(), traffic.destroyed as f64);
    if level.spawners.iter().any(|s| !s.departures.is_empty()) {
        put(
            Metric::InsertionBacklog.key(),
            traffic.insertion_backlog as f64,
        );
    }
    put(
        Metric::CollisionsGuardrail.key(),
        traffic.collisions_guardrail as f64,
    );
    // Every profile of the level, hits or none: an expectation on one always finds its key.
    for profile in &level.driver_profiles {
        let hits = traffic.guardrail_by_profile.get(&profile.name);
        put(
            Metric::CollisionsGuardrail.key_for(&profile.name),
            hits.copied().unwrap_or(0) as f64,
        );
    }
    put(
        Metric::CollisionsVehicle.key(),
        traffic.collisions_vehicle as f64,
    );
    put(
        Metric::Collisions.key(),
        (traffic.collisions_guardrail + traffic.collisions_vehicle) as f64,
    );
    if let Some(v) = traffic.mean_speed_kmh() {
        put(Metric::MeanSpeedKmh.key(), v);
    }
    if let Some(v) = traffic.speed_std_kmh() {
        put(Metric::SpeedStdKmh.key(), v);
    }
    for (profile, st) in &traffic.speed_by_profile {
        if let (Some(m), Some(sd)) = (st.mean(), st.std()) {
            put(Metric::MeanSpeedKmh.key_for(profile), m);
            put(Metric::SpeedStdKmh.key_for(profile), sd);
        }
    }
    if let Some(v) = traffic.final_speed.mean() {
        put(Metric::FinalSpeedKmh.key(), v);
    }
    for (profile, st) in &traffic.final_speed_by_profile {
        if let Some(m) = st.mean() {
            put(Metric::FinalSpeedKmh.key_for(profile), m);
        }
    }
    if let Some(v) = traffic.final_at_limit.share() {
        put(Metric::FinalLimitShare.key(), v);
    }
    for (profile, st) in &traffic.final_at_limit_by_profile {
        if let Some(v) = st.share() {
            put(Metric::FinalLimitShare.key_for(profile), v);
        }
    }
    if let Some(v) = traffic.mean_travel_time_s() {
        put(Metric::MeanTravelTimeS.key(), v);
    }
    if let Some(v) = traffic.delay.mean_s() {
        put(Metric::MeanDelayS.key(), v);
    }
    for (profile, d) in &traffic.delay_by_profile {
        if let Some(v) = d.mean_s() {
            put(Metric::MeanDelayS.key_for(profile), v);
        }
    }
    let routes = world.resource::<RouteStats>();
    put(Metric::MissedExits.key(), routes.missed_exits as f64);
    for profile in &level.driver_profiles {
        let n = routes.missed_by_profile.get(&profile.name);
        put(
            Metric::MissedExits.key_for(&profile.name),
            n.copied().unwrap_or(0) as f64,
        );
    }
    // Flow through each destroyer over the measured part of the run.
    let measured_s =
        (ticks.saturating_sub(settings.stats_from_tick)) as f64 / f64::from(TICKS_PER_SECOND);
    for d in &level.destroyers {
        let n = traffic.destroyed_by.get(&d.name).copied().unwrap_or(0);
        let flow = if measured_s > 0.0 {
            n as f64 * 3600.0 / measured_s
        } else {
            0.0
        };
        put(Metric::FlowVehPerH.key_for(&d.name), flow);
    }
    // Each junction's measures over the same part of the run.
    let junctions = world.resource::<JunctionMeasures>();
    for (junction, totals) in level.junctions.iter().zip(&junctions.totals) {
        let name = &junction.name;
        if measured_s > 0.0 {
            put(
                Metric::JunctionFlowVehPerH.key_for(name),
                totals.entered as f64 * 3600.0 / measured_s,
            );
        }
        put(Metric::MaxQueueM.key_for(name), totals.max_queue_m);
        if let Some(v) = totals.mean_delay_s() {
            put(Metric::JunctionDelayS.key_for(name), v);
        }
        if let Some(v) = totals.discharge_headway_s() {
            put(Metric::DischargeHeadwayS.key_for(name), v);
        }
        if junction.signal.is_some() {
            put(Metric::RedEntries.key_for(name), totals.red_entries as f64);
        }
    }
    // How close each junction's yielding approaches came to the capacity models.
    for junction in &level.junctions {
        let mine = || {
            samples
                .iter()
                .filter(|c| c.junction == junction.name && c.saturated_share >= SATURATED_SHARE)
        };
        let worst = |model: fn(&CapacitySample) -> f64| {
            mine()
                .map(|c| (c.capacity_veh_per_h / model(c) - 1.0).abs())
                .fold(None, |w: Option<f64>, e| Some(w.map_or(e, |w| w.max(e))))
        };
        if let Some(e) = worst(|c| c.gap_model_veh_per_h) {
            put(Metric::GapModelError.key_for(&junction.name), e);
        }
        if let Some(e) = worst(|c| c.hcm_model_veh_per_h) {
            put(Metric::HcmModelError.key_for(&junction.name), e);
        }
    }
    let stats = world.resource::<flockway_drivers::JunctionStats>();
    for (j, junction) in level.junctions.iter().enumerate() {
        let broken = stats.deadlocks.get(&j).copied().unwrap_or(0);
        put(Metric::Deadlocks.key_for(&junction.name), broken as f64);
    }
    conflict_metrics(world.resource::<Conflicts>(), level, &mut put);
    let road_lengths: BTreeMap<String, f64> = network
        .iter()
        .map(|(_, r)| (r.name().to_owned(), r.length_m()))
        .collect();
    let wave_settings = WaveSettings {
        from_s: settings.stats_from_tick as f64 / f64::from(TICKS_PER_SECOND),
        ..WaveSettings::default()
    };
    if let Some(w) = measure_wave(trace, &road_lengths, &wave_settings) {
        put(Metric::WaveDetected.key(), f64::from(u8::from(w.detected)));
        if let Some(c) = w.speed_kmh() {
            put(Metric::WaveSpeedKmh.key(), c);
        }
        if let Some(p) = w.period_s() {
            put(Metric::WavePeriodS.key(), p);
        }
    }
    out
}

/// The surrogate safety measures: per profile (every profile of the level, so an expectation on
/// one always finds its count) and in all, and the PET conflicts per junction.
fn conflict_metrics(conflicts: &Conflicts, level: &Level, put: &mut impl FnMut(String, f64)) {
    let per_million = |n: u64, km: f64| if km > 0.0 { n as f64 * 1.0e6 / km } else { 0.0 };
    let all = conflicts.total;
    let (ttc, drac, episodes, pet, km) = (all.ttc, all.drac, all.episodes, all.pet, all.veh_km);
    let (min_ttc, max_drac) = (all.min_ttc_s, all.max_drac_mps2);
    put(Metric::VehKm.key(), km);
    put(Metric::ConflictsTtc.key(), ttc as f64);
    put(Metric::ConflictsDrac.key(), drac as f64);
    put(Metric::ConflictsPet.key(), pet as f64);
    put(
        Metric::ConflictsPerMillionVehKm.key(),
        per_million(episodes + pet, km),
    );
    if let Some(x) = min_ttc {
        put(Metric::MinTtcS.key(), x);
    }
    if let Some(x) = max_drac {
        put(Metric::MaxDracMps2.key(), x);
    }
    for profile in &level.driver_profiles {
        let p = conflicts
            .by_profile
            .get(&profile.name)
            .copied()
            .unwrap_or_default();
        let name = &profile.name;
        put(Metric::VehKm.key_for(name), p.veh_km);
        put(Metric::ConflictsTtc.key_for(name), p.ttc as f64);
        put(Metric::ConflictsDrac.key_for(name), p.drac as f64);
        put(
            Metric::ConflictsPerMillionVehKm.key_for(name),
            per_million(p.episodes + p.pet, p.veh_km),
        );
        if let Some(x) = p.min_ttc_s {
            put(Metric::MinTtcS.key_for(name), x);
        }
        if let Some(x) = p.max_drac_mps2 {
            put(Metric::MaxDracMps2.key_for(name), x);
        }
    }
    for (j, junction) in level.junctions.iter().enumerate() {
        let n = conflicts.pet_by_junction.get(&j).copied().unwrap_or(0);
        put(Metric::ConflictsPet.key_for(&junction.name), n as f64);
    }
}

/// The summary of a finished run: its metrics, the level's expectations checked against them,
/// and the contract keys taken from the metrics.
pub fn measure(sim: &Sim, level: &Level, name: &str, trace: &Trace, stepping: Duration) -> Summary {
    let capacity = capacity_samples(sim, level);
    let metrics = metrics_with(sim, level, trace, &capacity);
    let expectations: Vec<ExpectationResult> =
        level.expect.iter().map(|e| evaluate(e, &metrics)).collect();
    let settings = *sim.world().resource::<TelemetrySettings>();
    let wall_seconds = stepping.as_secs_f64();
    let sim_seconds = sim.tick().seconds();
    let get = |m: Metric| metrics.get(&m.key()).copied();
    let flow_prefix = format!("{}.", Metric::FlowVehPerH.name());
    let score = level
        .score
        .as_ref()
        .and_then(|spec| spec.formula.evaluate(&metrics).ok());
    let medal = level
        .score
        .as_ref()
        .zip(score)
        .and_then(|(spec, s)| spec.medal(s));
    Summary {
        collisions_guardrail: get(Metric::CollisionsGuardrail),
        collisions_vehicle: get(Metric::CollisionsVehicle),
        passed: expectations.iter().all(|e| e.passed),
        expectations,
        flow_veh_per_h: metrics
            .iter()
            .filter_map(|(k, v)| Some((k.strip_prefix(&flow_prefix)?.to_owned(), *v)))
            .collect(),
        level: name.to_owned(),
        mean_delay_s: get(Metric::MeanDelayS),
        mean_speed_kmh: get(Metric::MeanSpeedKmh),
        mean_travel_time_s: get(Metric::MeanTravelTimeS),
        medal: medal.map(|m| m.name().to_owned()),
        realtime_factor: if wall_seconds > 0.0 {
            sim_seconds / wall_seconds
        } else {
            f64::INFINITY
        },
        score,
        seed: sim.seed(),
        sim_seconds,
        speed_std_kmh: get(Metric::SpeedStdKmh),
        stats_from_s: settings.stats_from_tick as f64 / f64::from(TICKS_PER_SECOND),
        ticks: sim.tick().0,
        vehicle_steps: sim.world().resource::<RunStats>().vehicle_steps,
        vehicles_alive_mean: get(Metric::VehiclesAliveMean),
        vehicles_destroyed: get(Metric::VehiclesDestroyed),
        vehicles_spawned: get(Metric::VehiclesSpawned),
        wall_seconds,
        wave_detected: get(Metric::WaveDetected).map(|v| v != 0.0),
        wave_period_s: get(Metric::WavePeriodS),
        wave_speed_kmh: get(Metric::WaveSpeedKmh),
        missed_exits: get(Metric::MissedExits),
        metrics,
        capacity,
    }
}

pub use flockway_analysis::SATURATED_SHARE;

/// The capacity of every yielding approach lane (a non-major road of a `Priority` junction) in
/// every capacity window, with the flow it gives way to and both models' capacity.
pub fn capacity_samples(sim: &Sim, level: &Level) -> Vec<CapacitySample> {
    let world = sim.world();
    let network = world.resource::<RoadNetwork>();
    let measures = world.resource::<JunctionMeasures>();
    let windows = &world.resource::<CapacityWindows>().0;
    let tick_s = 1.0 / f64::from(TICKS_PER_SECOND);
    let mut out = Vec::new();
    for ((j, road, lane, w), lw) in &measures.lane_windows {
        let (Some(junction), Some(spec), Some(&(from, to))) = (
            network.junctions().get(*j),
            level.junctions.get(*j),
            windows.get(*w),
        ) else {
            continue;
        };
        let flockway_road::Control::Priority { major, .. } = &spec.control else {
            continue;
        };
        let Some(approach) = network.get(*road).map(|g| g.name().to_owned()) else {
            continue;
        };
        if major.contains(&approach) || lw.entries == 0 {
            continue;
        }
        // The paths from this lane, and the major ones they give way to.
        let mut foes: Vec<usize> = Vec::new();
        for (k, p) in junction.paths.iter().enumerate() {
            if p.from != (road.0, *lane) {
                continue;
            }
            for c in &p.conflicts {
                if junction.gives_way(k, c.other, None) && !foes.contains(&c.other) {
                    foes.push(c.other);
                }
            }
        }
        let window_s = (to - from) as f64 * tick_s;
        let saturated_s = lw.saturated_ticks as f64 * tick_s;
        let conflicting: u64 = foes
            .iter()
            .map(|&k| {
                measures
                    .path_windows
                    .get(&(*j, k, *w))
                    .copied()
                    .unwrap_or(0)
            })
            .sum();
        let q = conflicting as f64 / window_s;
        let n = lw.entries as f64;
        let (t_c, t_f) = (lw.critical_gap_sum_s / n, lw.follow_up_sum_s / n);
        out.push(CapacitySample {
            junction: spec.name.clone(),
            approach,
            lane: *lane,
            from_s: from as f64 * tick_s,
            to_s: to as f64 * tick_s,
            saturated_share: saturated_s / window_s,
            capacity_veh_per_h: n * 3600.0 / saturated_s.max(tick_s),
            conflicting_veh_per_h: q * 3600.0,
            critical_gap_s: t_c,
            follow_up_s: t_f,
            gap_model_veh_per_h: gap_model_veh_per_h(q * 3600.0, t_c, t_f),
            hcm_model_veh_per_h: hcm_roundabout_veh_per_h(q * 3600.0),
        });
    }
    out
}

/// Capacity of a stream giving way to a random major stream of `q_veh_per_h` (Harders'
/// gap-acceptance formula with critical gap `t_c` and follow-up time `t_f`, s), veh/h.
pub fn gap_model_veh_per_h(q_veh_per_h: f64, t_c: f64, t_f: f64) -> f64 {
    let q = q_veh_per_h / 3600.0;
    if q <= 0.0 {
        return 3600.0 / t_f;
    }
    3600.0 * q * libm::exp(-q * t_c) / (1.0 - libm::exp(-q * t_f))
}

/// Entry capacity of a single-lane roundabout against a circulating flow of `v_c_veh_per_h`
/// (Highway Capacity Manual, 6th edition), veh/h.
pub fn hcm_roundabout_veh_per_h(v_c_veh_per_h: f64) -> f64 {
    1380.0 * libm::exp(-0.00102 * v_c_veh_per_h)
}

/// One expectation checked against the measured metrics; a metric the run did not measure
/// fails rather than passing silently.
pub fn evaluate(e: &Expectation, metrics: &BTreeMap<String, f64>) -> ExpectationResult {
    let value = metrics.get(&e.key()).copied();
    ExpectationResult {
        name: e.to_string(),
        passed: value.is_some_and(|v| e.holds(v)),
        value,
    }
}

/// The name a level is reported under: its `name`, or the file stem.
pub fn level_name(level: &Level, path: &Path) -> String {
    if level.name.trim().is_empty() {
        path.file_stem()
            .map_or_else(|| "level".to_owned(), |s| s.to_string_lossy().into_owned())
    } else {
        level.name.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_capacity_models_give_their_textbook_values() {
        // No major traffic: one car per follow-up time.
        assert!((gap_model_veh_per_h(0.0, 6.2, 3.3) - 3600.0 / 3.3).abs() < 1e-9);
        // 600 veh/h, t_c 6.2 s, t_f 3.3 s: q = 1/6 veh/s, c = q e^(−q t_c) / (1 − e^(−q t_f)).
        let q: f64 = 1.0 / 6.0;
        let c = 3600.0 * q * (-q * 6.2).exp() / (1.0 - (-q * 3.3).exp());
        assert!((gap_model_veh_per_h(600.0, 6.2, 3.3) - c).abs() < 1e-6);
        assert!((c - 504.6).abs() < 0.1, "{c}");
        // More traffic to give way to, less capacity.
        assert!(gap_model_veh_per_h(900.0, 6.2, 3.3) < c);
        // HCM 6 single-lane roundabout: 1 380 veh/h with nothing circulating, about 829 at
        // 500 veh/h circulating.
        assert!((hcm_roundabout_veh_per_h(0.0) - 1380.0).abs() < 1e-9);
        assert!((hcm_roundabout_veh_per_h(500.0) - 1380.0 * (-0.51f64).exp()).abs() < 1e-9);
        assert!((hcm_roundabout_veh_per_h(500.0) - 828.7).abs() < 0.1);
    }
}
