//! The simulation: a world, the fixed-step schedule and the plugins that fill it.

use crate::{RngStreams, RunStats, SimClock, SplitTuner, Tick, count_vehicles};
use bevy_ecs::{
    schedule::{
        IntoScheduleConfigs, LogLevel, Schedule, ScheduleBuildSettings, ScheduleLabel,
        SingleThreadedExecutor, SystemSet,
    },
    system::ScheduleSystem,
    world::World,
};
use std::any::type_name;

/// The label of the schedule that runs once per fixed step.
#[derive(ScheduleLabel, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct FixedStep;

/// The ordered phases of one fixed step. Every system belongs to exactly one; the sets run in
/// declaration order, so a system only needs ordering against others in its own set.
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum StepSet {
    /// Bring derived data up to date after edits (road geometry, indices rebuilt from components).
    Prepare,
    /// Create entities: spawners, initial vehicles.
    Spawn,
    /// Build perception: per-lane indices, leaders, followers, neighbours.
    Sense,
    /// Drivers decide what they want (target speed and heading).
    Decide,
    /// Turn decisions into vehicle controls (throttle, steering, brakes).
    Actuate,
    /// Integrate vehicle dynamics and rigid bodies by one step.
    Physics,
    /// React to where vehicles are now: speed-limit and friction zones, contacts.
    Triggers,
    /// Sample telemetry and statistics.
    Record,
    /// Remove entities: destroyers, crashed vehicles.
    Despawn,
}

impl StepSet {
    /// Every set, in the order it runs.
    pub const ALL: [StepSet; 9] = [
        StepSet::Prepare,
        StepSet::Spawn,
        StepSet::Sense,
        StepSet::Decide,
        StepSet::Actuate,
        StepSet::Physics,
        StepSet::Triggers,
        StepSet::Record,
        StepSet::Despawn,
    ];
}

/// A feature of the simulation: registers its resources and systems on a [`Sim`].
pub trait SimPlugin {
    /// Adds this plugin's resources and systems.
    fn build(&self, sim: &mut Sim);

    /// A name unique to the plugin; adding a plugin whose name is already present does nothing.
    fn name(&self) -> &str {
        type_name::<Self>()
    }
}

/// A deterministic fixed-step world: what the command line and the window both step.
pub struct Sim {
    world: World,
    schedule: Schedule,
    plugins: Vec<String>,
    /// Whether the step's passes split over the threads, timed as the run goes.
    split: SplitTuner,
}

/// The environment variable that sets how many threads the task pool has (one per core
/// without it): N processes stepping side by side each want fewer than all the cores.
pub const THREADS_ENV: &str = "FLOCKWAY_THREADS";

/// The thread count [`THREADS_ENV`] asks for: `Ok(None)` when it is not set, an error that says
/// why when it is not a whole number from 1 to 1024.
pub fn threads_from_env() -> Result<Option<usize>, String> {
    count_from_env(THREADS_ENV, 1..=1024, "a whole number from 1 to 1024")
}

/// The whole number in environment variable `var`: `Ok(None)` when it is not set, an error
/// naming the variable, its value and `expected` when it is not a number within `range`.
pub(crate) fn count_from_env(
    var: &str,
    range: std::ops::RangeInclusive<usize>,
    expected: &str,
) -> Result<Option<usize>, String> {
    match std::env::var(var) {
        Err(std::env::VarError::NotPresent) => Ok(None),
        Err(std::env::VarError::NotUnicode(v)) => Err(format!("{var}={v:?}: expected {expected}")),
        Ok(v) => match v.trim().parse::<usize>() {
            Ok(n) if range.contains(&n) => Ok(Some(n)),
            _ => Err(format!("{var}={v:?}: expected {expected}")),
        },
    }
}

/// Starts the process's task pool (the threads systems split per-vehicle work over) with
/// `threads` threads — or as [`THREADS_ENV`] says, or one per core — unless it is running
/// already, and beside it the join pool small levels' passes are split over
/// ([`for_each_car`](crate::for_each_car)). Returns the pool's size. Results do not depend on
/// it.
pub fn init_task_pool(threads: Option<usize>) -> usize {
    bevy_tasks::ComputeTaskPool::get_or_init(|| {
        let pool = match threads.or_else(|| threads_from_env().ok().flatten()) {
            Some(n) => bevy_tasks::TaskPoolBuilder::new()
                .num_threads(n.max(1))
                .build(),
            None => bevy_tasks::TaskPool::default(),
        };
        // The join pool's threads help the calling one: one fewer than the pool's.
        if pool.thread_num() >= 2 {
            micropool::ThreadPoolBuilder::default()
                .num_threads(pool.thread_num() - 1)
                .build_global();
        }
        pool
    })
    .thread_num()
}

impl Sim {
    /// An empty simulation for a run with this seed, at tick 0.
    pub fn new(seed: u64) -> Sim {
        let mut world = World::new();
        world.insert_resource(SimClock::default());
        world.insert_resource(RngStreams::new(seed));
        world.init_resource::<RunStats>();
        let mut schedule = Schedule::new(FixedStep);
        // Systems run one after another in their fixed order; parallelism lives inside systems
        // that split independent per-entity work over the task pool (`par_iter`).
        schedule.set_executor(SingleThreadedExecutor::new());
        init_task_pool(None);
        // Two systems that touch the same data without an order between them could run either way
        // round, which would make results depend on the scheduler: refuse to build such a step.
        schedule.set_build_settings(ScheduleBuildSettings {
            ambiguity_detection: LogLevel::Error,
            hierarchy_detection: LogLevel::Error,
            ..Default::default()
        });
        schedule.configure_sets(
            (
                StepSet::Prepare,
                StepSet::Spawn,
                StepSet::Sense,
                StepSet::Decide,
                StepSet::Actuate,
                StepSet::Physics,
                StepSet::Triggers,
                StepSet::Record,
                StepSet::Despawn,
            )
                .chain(),
        );
        // Vehicles alive are counted once per step; systems reading RunStats order after it.
        schedule.add_systems(count_vehicles.in_set(StepSet::Record));
        Sim {
            world,
            schedule,
            plugins: Vec::new(),
            split: SplitTuner::for_pool(),
        }
    }

    /// Adds a plugin unless one of the same name is already there.
    pub fn add_plugin(&mut self, plugin: impl SimPlugin) -> &mut Self {
        let name = plugin.name().to_owned();
        if !self.plugins.contains(&name) {
            self.plugins.push(name);
            plugin.build(self);
        }
        self
    }

    /// Whether a plugin of this name has been added.
    pub fn has_plugin(&self, name: &str) -> bool {
        self.plugins.iter().any(|p| p == name)
    }

    /// Adds systems to one phase of the step.
    pub fn add_systems<M>(
        &mut self,
        set: StepSet,
        systems: impl IntoScheduleConfigs<ScheduleSystem, M>,
    ) -> &mut Self {
        self.schedule.add_systems(systems.in_set(set));
        self
    }

    /// The world, to read results.
    pub fn world(&self) -> &World {
        &self.world
    }

    /// The world, to insert entities and resources before or between steps.
    pub fn world_mut(&mut self) -> &mut World {
        &mut self.world
    }

    /// The step schedule, for ordering constraints a plugin needs beyond [`StepSet`].
    pub fn schedule_mut(&mut self) -> &mut Schedule {
        &mut self.schedule
    }

    /// The run's seed.
    pub fn seed(&self) -> u64 {
        self.world.resource::<RngStreams>().seed()
    }

    /// The tick the next step will simulate.
    pub fn tick(&self) -> Tick {
        self.world.resource::<SimClock>().tick()
    }

    /// Builds the step schedule, reporting conflicts (ambiguous system order, cycles) as an error
    /// instead of a panic at the first step. Cheap when nothing changed.
    pub fn prepare(&mut self) -> Result<(), String> {
        match self.schedule.initialize(&mut self.world) {
            Ok(_) => Ok(()),
            Err(e) => Err(e.to_string(self.schedule.graph(), &self.world)),
        }
    }

    /// Runs one fixed step and advances the clock by one tick.
    ///
    /// # Panics
    /// If the schedule cannot be built; call [`Sim::prepare`] first to get that as an error.
    pub fn step(&mut self) {
        let (schedule, world) = (&mut self.schedule, &mut self.world);
        self.split.run(|| schedule.run(world));
        self.world.resource_mut::<SimClock>().advance();
    }

    /// Runs `ticks` fixed steps.
    pub fn run_ticks(&mut self, ticks: u64) {
        for _ in 0..ticks {
            self.step();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy_ecs::prelude::*;

    #[derive(Resource, Default)]
    struct Log(Vec<(u64, StepSet)>);

    fn recorder(set: StepSet) -> impl FnMut(ResMut<Log>, Res<SimClock>) {
        move |mut log: ResMut<Log>, clock: Res<SimClock>| log.0.push((clock.tick().0, set))
    }

    #[test]
    fn sets_run_in_order_every_tick() {
        let mut sim = Sim::new(1);
        sim.world_mut().init_resource::<Log>();
        // Register in reverse to prove the order comes from the sets, not registration.
        for set in StepSet::ALL.iter().rev() {
            sim.add_systems(*set, recorder(*set));
        }
        sim.prepare().expect("schedule builds");
        sim.run_ticks(2);
        let log = &sim.world().resource::<Log>().0;
        let expected: Vec<(u64, StepSet)> = (0..2)
            .flat_map(|t| StepSet::ALL.iter().map(move |s| (t, *s)))
            .collect();
        assert_eq!(log, &expected);
        assert_eq!(sim.tick(), Tick(2));
    }

    #[derive(Resource, Default)]
    struct Counter(u32);

    fn bump_a(mut c: ResMut<Counter>) {
        c.0 += 1;
    }

    fn bump_b(mut c: ResMut<Counter>) {
        c.0 *= 2;
    }

    #[test]
    fn ambiguous_systems_are_an_error() {
        let mut sim = Sim::new(1);
        sim.world_mut().init_resource::<Counter>();
        sim.add_systems(StepSet::Decide, (bump_a, bump_b));
        let err = sim
            .prepare()
            .expect_err("two unordered writers of one resource");
        assert!(err.to_lowercase().contains("ambigu"), "{err}");

        let mut ordered = Sim::new(1);
        ordered.world_mut().init_resource::<Counter>();
        ordered.add_systems(StepSet::Decide, (bump_a, bump_b).chain());
        ordered.prepare().expect("ordered systems are fine");
        ordered.step();
        assert_eq!(ordered.world().resource::<Counter>().0, 2);
    }

    struct Once;
    impl SimPlugin for Once {
        fn build(&self, sim: &mut Sim) {
            sim.world_mut().init_resource::<Counter>();
            sim.add_systems(StepSet::Spawn, bump_a);
        }
    }

    #[test]
    fn a_plugin_is_added_once() {
        let mut sim = Sim::new(1);
        sim.add_plugin(Once).add_plugin(Once);
        assert!(sim.has_plugin(Once.name()));
        sim.prepare().expect("builds");
        sim.step();
        assert_eq!(sim.world().resource::<Counter>().0, 1);
    }
}
