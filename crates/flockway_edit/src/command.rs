//! The edits a level can take: [`Command`], each with a label for the undo menu. Commands are
//! plain data (serde), so a script can list them in a RON file for `flockway edit --apply`.

use flockway_level::{
    DestroyerSpec, DetectorSpec, DriverProfileSpec, Expectation, InitialVehiclesSpec, SpawnerSpec,
    TelemetrySpec, TriggerSpec, VehicleTypeSpec,
};
use flockway_road::{ControlPoint, JunctionSpec, LinkSpec, RoadSpec};
use glam::DVec3;
use serde::{Deserialize, Serialize};

/// Which kind of marker a command addresses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum MarkerKind {
    /// A spawner.
    Spawner,
    /// A destroyer on a road.
    Destroyer,
    /// A trigger stretch.
    Trigger,
}

/// One edit of a level. Roads and markers are addressed by their index in the level.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Command {
    /// Starts a new road (named `road N`) with its first control point.
    AddRoad {
        /// Where the point goes, metres.
        at: DVec3,
    },
    /// Adds a control point at the end of a road.
    AppendPoint {
        /// The road.
        road: usize,
        /// Where, metres.
        at: DVec3,
    },
    /// Inserts a control point before point `index`.
    InsertPoint {
        /// The road.
        road: usize,
        /// The point it goes before.
        index: usize,
        /// Where, metres.
        at: DVec3,
    },
    /// Moves a control point.
    MovePoint {
        /// The road.
        road: usize,
        /// The point.
        index: usize,
        /// Its new position, metres.
        to: DVec3,
    },
    /// Deletes a control point (the last one deletes the road).
    DeletePoint {
        /// The road.
        road: usize,
        /// The point.
        index: usize,
    },
    /// Deletes a road, the markers on it and the connections onto it.
    DeleteRoad {
        /// The road.
        road: usize,
    },
    /// Closes a road into a loop, or opens it.
    SetClosed {
        /// The road.
        road: usize,
        /// Whether it is a loop.
        closed: bool,
    },
    /// Connects a road's end to another road's start (or removes the connection).
    Connect {
        /// The road whose end connects.
        road: usize,
        /// The road it leads onto, by name.
        next: Option<String>,
    },
    /// Replaces the roads a road's end leads onto, lane by lane (its `next` folds into them).
    SetLinks {
        /// The road.
        road: usize,
        /// Its links, in order.
        links: Vec<LinkSpec>,
    },
    /// Links a road's end onto another road's start, moving the end onto it (see
    /// [`crate::join_end`]).
    JoinEnd {
        /// The road whose end joins.
        road: usize,
        /// The road it leads onto, by name.
        onto: String,
    },
    /// Joins a road's end onto another road's side as an on-ramp with acceleration lanes (see
    /// [`crate::join_side`]).
    JoinSide {
        /// The road whose end joins.
        road: usize,
        /// The road it joins, by name.
        onto: String,
        /// Where along that road, metres.
        s_m: f64,
    },
    /// Joins a road's start onto another road's side as an exit (see
    /// [`crate::join_exit`]).
    JoinExit {
        /// The road whose start joins.
        road: usize,
        /// The road it leaves, by name.
        onto: String,
        /// Where along that road, metres.
        s_m: f64,
    },
    /// Replaces a control point's properties (width, bank, guardrails, elevation in `pos.z`).
    SetPoint {
        /// The road.
        road: usize,
        /// The point.
        index: usize,
        /// The new point.
        point: ControlPoint,
    },
    /// Sets a road's own properties; a new name is followed by everything that refers to it.
    SetRoad {
        /// The road.
        road: usize,
        /// Name.
        name: String,
        /// Lanes.
        lanes: u32,
        /// Lane width, metres.
        lane_width_m: f64,
        /// Speed limit, km/h.
        speed_limit_kmh: f64,
    },
    /// Adds a spawner.
    AddSpawner(SpawnerSpec),
    /// Replaces a spawner.
    SetSpawner(usize, SpawnerSpec),
    /// Adds a destroyer.
    AddDestroyer(DestroyerSpec),
    /// Replaces a destroyer.
    SetDestroyer(usize, DestroyerSpec),
    /// Adds a trigger.
    AddTrigger(TriggerSpec),
    /// Replaces a trigger.
    SetTrigger(usize, TriggerSpec),
    /// Adds a detector (induction loops).
    AddDetector(DetectorSpec),
    /// Replaces a detector.
    SetDetector(usize, DetectorSpec),
    /// Deletes a detector.
    DeleteDetector(usize),
    /// Moves a marker along its road (a trigger keeps its length).
    MoveMarker {
        /// What kind of marker.
        kind: MarkerKind,
        /// Its index.
        index: usize,
        /// New arc position, metres (a trigger's start).
        s_m: f64,
    },
    /// Deletes a marker.
    DeleteMarker {
        /// What kind of marker.
        kind: MarkerKind,
        /// Its index.
        index: usize,
    },
    /// Sets the level's own settings.
    SetLevelInfo {
        /// Name shown in reports (empty: the file name).
        name: String,
        /// What the level shows.
        description: String,
        /// Seed of every random stream.
        seed: u64,
        /// Simulated duration of a run, s.
        duration_s: f64,
        /// Sampling period and warm-up.
        telemetry: TelemetrySpec,
    },
    /// Adds a vehicle type.
    AddVehicleType(VehicleTypeSpec),
    /// Replaces a vehicle type; a new name is followed by the profiles that drive it.
    SetVehicleType(usize, VehicleTypeSpec),
    /// Deletes a vehicle type no profile drives.
    DeleteVehicleType(usize),
    /// Adds a driver profile.
    AddDriverProfile(DriverProfileSpec),
    /// Replaces a driver profile; a new name is followed by everything that refers to it.
    SetDriverProfile(usize, DriverProfileSpec),
    /// Deletes a driver profile no spawner or vehicle group uses.
    DeleteDriverProfile(usize),
    /// Replaces the expectations.
    SetExpectations(Vec<Expectation>),
    /// Adds a group of vehicles present at the start.
    AddVehicles(InitialVehiclesSpec),
    /// Replaces a group of initial vehicles.
    SetVehicles(usize, InitialVehiclesSpec),
    /// Deletes a group of initial vehicles.
    DeleteVehicles(usize),
    /// Places roads and the junctions between them together (a roundabout, a crossroads).
    AddPrefab {
        /// The roads.
        roads: Vec<RoadSpec>,
        /// The junctions.
        junctions: Vec<JunctionSpec>,
    },
    /// Replaces a junction: its name, control, connections and signal program.
    SetJunction(usize, JunctionSpec),
    /// Deletes a junction (its roads stay, no longer connected through it).
    DeleteJunction(usize),
    /// Sets one field of a named item, as a script says it: `Set(item: Road("west in"),
    /// field: "lanes", value: 2)`. `field` is a dotted path into the item as the level file
    /// writes it (`signal.phases.1.duration_s` of a junction, `effect.SpeedLimit.kmh` of a
    /// trigger, `interval_s.min` of a spawner); the change goes through the item's own edit, so
    /// limits are checked and a new name is followed everywhere.
    Set {
        /// The item.
        item: Target,
        /// The field's path.
        field: String,
        /// Its new value.
        value: ron::Value,
    },
    /// Several edits as one undo step (all or none).
    Batch {
        /// What the undo menu calls it.
        label: String,
        /// The edits, in order.
        commands: Vec<Command>,
    },
}

impl Command {
    /// A short description for the undo menu.
    pub fn label(&self) -> &str {
        match self {
            Command::AddRoad { .. } => "add road",
            Command::AppendPoint { .. } | Command::InsertPoint { .. } => "add point",
            Command::MovePoint { .. } => "move point",
            Command::DeletePoint { .. } => "delete point",
            Command::DeleteRoad { .. } => "delete road",
            Command::SetClosed { .. } => "close/open loop",
            Command::Connect { .. } => "connect roads",
            Command::SetLinks { .. } => "edit links",
            Command::JoinEnd { .. } => "join roads",
            Command::JoinSide { .. } => "join from the side",
            Command::JoinExit { .. } => "leave from the side",
            Command::SetPoint { .. } => "edit point",
            Command::SetRoad { .. } => "edit road",
            Command::AddSpawner(_) => "add spawner",
            Command::AddDestroyer(_) => "add destroyer",
            Command::AddTrigger(_) => "add trigger",
            Command::SetSpawner(..) | Command::SetDestroyer(..) | Command::SetTrigger(..) => {
                "edit marker"
            }
            Command::AddDetector(_) => "add detector",
            Command::SetDetector(..) => "edit detector",
            Command::DeleteDetector(_) => "delete detector",
            Command::MoveMarker { .. } => "move marker",
            Command::DeleteMarker { .. } => "delete marker",
            Command::SetLevelInfo { .. } => "edit level settings",
            Command::AddVehicleType(_) => "add vehicle type",
            Command::SetVehicleType(..) => "edit vehicle type",
            Command::DeleteVehicleType(_) => "delete vehicle type",
            Command::AddDriverProfile(_) => "add driver profile",
            Command::SetDriverProfile(..) => "edit driver profile",
            Command::DeleteDriverProfile(_) => "delete driver profile",
            Command::SetExpectations(_) => "edit expectations",
            Command::AddVehicles(_) => "add vehicle group",
            Command::SetVehicles(..) => "edit vehicle group",
            Command::DeleteVehicles(_) => "delete vehicle group",
            Command::AddPrefab { .. } => "place junction",
            Command::SetJunction(..) => "edit junction",
            Command::DeleteJunction(_) => "delete junction",
            Command::Set { .. } => "set a field",
            Command::Batch { label, .. } => label,
        }
    }

    /// Whether the level's validation judges this edit: edits of settings and markers may not
    /// add a problem `flockway run` would reject (drawing a road passes through states that are
    /// not roads yet, so geometry edits are not judged).
    pub(crate) fn is_checked(&self) -> bool {
        match self {
            Command::AddRoad { .. }
            | Command::AppendPoint { .. }
            | Command::InsertPoint { .. }
            | Command::MovePoint { .. }
            | Command::DeletePoint { .. }
            | Command::DeleteRoad { .. }
            | Command::SetClosed { .. }
            | Command::Connect { .. }
            | Command::JoinEnd { .. }
            | Command::JoinSide { .. }
            | Command::JoinExit { .. }
            | Command::SetPoint { .. }
            | Command::DeleteMarker { .. }
            | Command::DeleteDetector(_)
            | Command::DeleteVehicleType(_)
            | Command::DeleteDriverProfile(_)
            | Command::DeleteVehicles(_)
            | Command::DeleteJunction(_) => false,
            Command::Batch { commands, .. } => commands.iter().any(Command::is_checked),
            _ => true,
        }
    }

    /// What a drag (of a point or marker in the scene, or of a value in a panel) changes:
    /// consecutive edits of the same thing merge into one undo step until the drag ends.
    pub(crate) fn drag_target(&self) -> Option<(u8, usize, usize)> {
        match self {
            Command::MovePoint { road, index, .. } => Some((0, *road, *index)),
            Command::MoveMarker { kind, index, .. } => Some((1 + *kind as u8, *index, 0)),
            Command::SetPoint { road, index, .. } => Some((4, *road, *index)),
            Command::SetRoad { road, .. } => Some((5, *road, 0)),
            Command::SetSpawner(i, _) => Some((6, *i, 0)),
            Command::SetDestroyer(i, _) => Some((7, *i, 0)),
            Command::SetTrigger(i, _) => Some((8, *i, 0)),
            Command::SetLevelInfo { .. } => Some((9, 0, 0)),
            Command::SetVehicleType(i, _) => Some((10, *i, 0)),
            Command::SetDriverProfile(i, _) => Some((11, *i, 0)),
            Command::SetVehicles(i, _) => Some((12, *i, 0)),
            Command::SetJunction(i, _) => Some((13, *i, 0)),
            Command::SetDetector(i, _) => Some((14, *i, 0)),
            _ => None,
        }
    }
}

/// An item a [`Command::Set`] addresses by name (the level's own settings by `Level`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub enum Target {
    /// The level's settings: `name`, `description`, `seed`, `duration_s`, `telemetry`, `ssm`.
    Level,
    /// A road, by name.
    Road(String),
    /// A junction, by name.
    Junction(String),
    /// A spawner, by name.
    Spawner(String),
    /// A destroyer, by name.
    Destroyer(String),
    /// A trigger, by name.
    Trigger(String),
    /// A detector, by name.
    Detector(String),
    /// A driver profile, by name.
    Profile(String),
    /// A vehicle type, by name.
    VehicleType(String),
}

impl std::fmt::Display for Target {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Target::Level => f.write_str("the level"),
            Target::Road(n) => write!(f, "road `{n}`"),
            Target::Junction(n) => write!(f, "junction `{n}`"),
            Target::Spawner(n) => write!(f, "spawner `{n}`"),
            Target::Destroyer(n) => write!(f, "destroyer `{n}`"),
            Target::Trigger(n) => write!(f, "trigger `{n}`"),
            Target::Detector(n) => write!(f, "detector `{n}`"),
            Target::Profile(n) => write!(f, "driver profile `{n}`"),
            Target::VehicleType(n) => write!(f, "vehicle type `{n}`"),
        }
    }
}
