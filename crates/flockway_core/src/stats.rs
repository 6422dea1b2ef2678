//! Run-wide counters every run keeps, whatever plugins it has.

use bevy_ecs::prelude::*;

/// Marks an entity as a vehicle: counted in [`RunStats`], sampled by telemetry.
#[derive(Component, Debug, Clone, Copy, Default)]
pub struct Vehicle;

/// Counters of the run so far.
#[derive(Resource, Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RunStats {
    /// Sum over steps of vehicles alive at the end of each step's Record phase.
    pub vehicle_steps: u64,
    /// Vehicles alive at the last Record phase.
    pub vehicles_alive: u64,
}

/// Counts vehicles alive this step into [`RunStats`].
pub fn count_vehicles(vehicles: Query<(), With<Vehicle>>, mut stats: ResMut<RunStats>) {
    let alive = vehicles.iter().count() as u64;
    stats.vehicles_alive = alive;
    stats.vehicle_steps += alive;
}
