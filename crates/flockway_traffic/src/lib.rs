//! Flockway's traffic: spawners, destroyers, triggers, collision accounting, telemetry samples,
//! surrogate safety measures (conflicts by TTC, DRAC and PET) and the run statistics that
//! levels' expectations check.
//!
//! Everything here is a system over components the headless runner (or the editor) creates from
//! a level: [`Spawner`] in `Spawn`, [`Trigger`] and collisions in `Triggers`, telemetry in
//! `Record`, [`Destroyer`] in `Despawn`. Vehicles get a [`VehicleId`] (spawn order, stable across
//! runs) that keys their random stream and their telemetry rows.

mod detectors;
mod junctions;
mod spawn;
mod ssm;
mod stats;
mod trips;
mod waiting;
mod zones;

pub use detectors::{Detector, DetectorReading, Detectors, LoopCounters, measure_detectors};
pub use junctions::{
    APPROACH_ZONE_M, CapacityWindows, DISCHARGE_FROM, JunctionMeasures, JunctionTotals, LaneWindow,
    OnApproach, QUEUE_FRONT_M, QUEUE_GAP_M, QUEUED_MPS, SATURATED_M, measure_junctions,
    queue_at_line,
};
pub use spawn::{
    Departure, SpawnChoice, SpawnRoute, Spawner, SpawnerRate, VehicleId, VehicleIds, run_spawners,
    spawn_driven,
};
pub use ssm::{
    ConflictArea, ConflictKind, ConflictRecord, Conflicts, EPISODE_END_S, OnPath, PairObservation,
    ProfileConflicts, SsmThresholds, Who, drac_mps2, measure_conflicts, ttc_s,
};
pub use stats::{
    AT_LIMIT_SHARE, DelayStats, LimitShare, SpeedStats, TelemetrySample, TelemetrySamples,
    TelemetrySettings, TrafficStats, sample_telemetry,
};
pub use trips::{RoadCounts, TripLog, TripRecord};
pub use waiting::{HALTING_MPS, WaitingTimes, track_waiting};
pub use zones::{
    Destroyer, DestroyerPlace, Travel, Trigger, TriggerEffect, apply_triggers, count_collisions,
    run_destroyers, sync_road_surface,
};

use bevy_ecs::prelude::*;
use flockway_core::{Sim, SimPlugin, StepSet};
use flockway_drivers::DriversPlugin;

/// Adds the traffic systems and resources. Needs (and adds) the driver plugin.
pub struct TrafficPlugin;

impl SimPlugin for TrafficPlugin {
    fn build(&self, sim: &mut Sim) {
        sim.add_plugin(DriversPlugin);
        // Registration fails only once a vehicle exists; such vehicles are measured all the same.
        let _ = sim
            .world_mut()
            .try_register_required_components::<flockway_vehicle::Motion, ssm::ConflictAhead>();
        let world = sim.world_mut();
        world.init_resource::<VehicleIds>();
        world.init_resource::<TrafficStats>();
        world.init_resource::<TelemetrySettings>();
        world.init_resource::<TelemetrySamples>();
        world.init_resource::<SpawnerRate>();
        sim.add_systems(StepSet::Spawn, (run_spawners, sync_road_surface));
        sim.add_systems(
            StepSet::Triggers,
            (count_collisions, apply_triggers).chain(),
        );
        sim.world_mut().init_resource::<JunctionMeasures>();
        sim.world_mut().init_resource::<CapacityWindows>();
        sim.world_mut().init_resource::<Conflicts>();
        sim.add_systems(
            StepSet::Record,
            (
                sample_telemetry,
                measure_junctions,
                track_waiting,
                measure_detectors,
            ),
        );
        // On what the drivers see: the lane index and the places it was built from.
        sim.add_systems(
            StepSet::Sense,
            measure_conflicts.after(flockway_drivers::DriverSystems::Perceive),
        );
        sim.add_systems(StepSet::Despawn, run_destroyers);
    }
}
