//! Timing a run's steps one at a time, with the vehicles alive at each, for the benchmarks that
//! report µs per vehicle-step.

use flockway::run::Runner;
use flockway::vehicle::VehicleModel;
use std::time::{Duration, Instant};

/// The steps timed so far: how many, the vehicle-steps they made, and the wall time they took.
#[derive(Debug, Default)]
pub struct Timed {
    pub steps: u64,
    pub vehicle_steps: u64,
    pub spent: Duration,
}

impl Timed {
    /// Steps `runner` once and returns how long the step took (counting the vehicles alive
    /// before it, outside the timing).
    pub fn step(&mut self, runner: &mut Runner) -> Duration {
        let world = runner.sim_mut().world_mut();
        let alive = world.query::<&VehicleModel>().iter(world).count() as u64;
        let started = Instant::now();
        runner.step(1).unwrap_or_else(|e| panic!("{e}"));
        let took = started.elapsed();
        self.spent += took;
        self.vehicle_steps += alive;
        self.steps += 1;
        took
    }

    /// Vehicles alive on average over the timed steps.
    pub fn mean_alive(&self) -> f64 {
        self.vehicle_steps as f64 / self.steps as f64
    }

    /// Wall time per vehicle-step, µs.
    pub fn us_per_vehicle_step(&self) -> f64 {
        self.spent.as_secs_f64() * 1e6 / self.vehicle_steps as f64
    }

    /// Simulated seconds per wall second (1/120 s per step).
    pub fn real_time_factor(&self) -> f64 {
        self.steps as f64 / 120.0 / self.spent.as_secs_f64()
    }
}
