//! Flockway's simulation core: a `bevy_ecs` world stepped at exactly 1/120 s per tick.
//!
//! Everything that happens in a Flockway run is a system in one of the ordered [`StepSet`]s of the
//! fixed step. Simulated time is an integer tick count ([`SimClock`]); all randomness comes from
//! ChaCha streams derived from the level seed and a [`StableId`] ([`RngStreams`]), so the same level
//! and seed give the same run whether a command-line runner or a window drives the [`Sim`].

pub mod arrays;
mod clock;
mod ids;
mod parallel;
mod rng;
mod sim;
mod split;
mod stats;
mod stepper;
mod units;
pub mod wrap;

pub use clock::{DT_S, SimClock, TICKS_PER_SECOND, Tick};
pub use ids::{IdKind, StableId};
pub use parallel::{
    Beside, JOIN_MIN_CARS, JOIN_MIN_ITEMS, PARALLEL_MIN_ENV, beside, for_each_car, map_in_order,
    parallel_min, parallel_min_from_env, pool_threads, task_threads,
};
pub use rng::{EntityRng, RngStreams};
pub use sim::{FixedStep, Sim, SimPlugin, StepSet, THREADS_ENV, init_task_pool, threads_from_env};
pub use split::{SPLIT_ENV, SplitTuner, split_always_from_env};
pub use stats::{RunStats, Vehicle, count_vehicles};
pub use stepper::{FixedStepper, SpeedSetting};
pub use units::{Speed, kmh_to_mps, mps_to_kmh};

/// The types most users of the core need, for `use flockway_core::prelude::*`.
pub mod prelude {
    pub use crate::{
        DT_S, EntityRng, IdKind, RngStreams, RunStats, Sim, SimClock, SimPlugin, Speed, StableId,
        StepSet, TICKS_PER_SECOND, Tick, Vehicle,
    };
}
