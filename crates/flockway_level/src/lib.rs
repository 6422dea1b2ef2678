//! Flockway's level format: versioned RON files holding roads, traffic, telemetry settings and
//! the expectations a run must meet.
//!
//! [`load_level`] parses and validates a file; every problem comes back as a [`LevelError`] that
//! names the file, line and column and says what was expected. [`save_level`] writes atomically,
//! and load → save → load gives back an equal [`Level`].

mod expect;
mod io;
mod locate;
mod prefab;
mod refs;
mod schema;
mod score;
mod sumo;
mod template;
mod validate;

pub use expect::{Check, Expectation, METRICS, Metric, MetricInfo, Qualifier, metric_info};
pub use io::{
    Diagnostic, LevelError, MAX_FILE_BYTES, level_to_string, level_warnings, load_level,
    parse_level, save_level, write_atomic,
};
pub use locate::{PathStep, Pos, locate};
pub use prefab::{Prefab, RING_RADIUS_M, crossroads, roundabout};
pub use refs::{
    ItemKind, ItemRef, Site, blocks_removal, references, remove_item, rename, visit_references,
};
pub use schema::{
    Arrivals, CURRENT_VERSION, DEFAULT_DETECTOR_PERIOD_S, DemandStep, DepartureSpec,
    DestroyerPlaceSpec, DestroyerSpec, DetectorSpec, DriverModel, DriverProfileSpec,
    InitialVehiclesSpec, Level, ProfileShare, Range, RouteSpec, SpawnerSpec, SsmSpec,
    TelemetrySpec, TriggerEffectSpec, TriggerSpec, VehicleTypeSpec,
};
pub use score::{Better, Formula, Medal, Medals, ScoreError, ScoreSpec};
pub use sumo::{DemandReport, ImportError, import_sumo, import_sumo_net};
pub use template::{
    AUTONOMOUS_PROFILE, HUMAN_PROFILE, Template, mixed_shares, reference_profiles,
    reference_vehicle_types,
};
pub use validate::{
    Issue, MAX_DURATION_S, MAX_INITIAL_VEHICLES, MAX_LIST_LEN, MIN_INITIAL_SPACING_M,
    MIN_SPAWN_INTERVAL_S, validate, warnings,
};
