//! The editor's model, apart from any window: a level, the commands that edit it, undo and
//! redo, and saving (atomic, exactly the RON `flockway run` loads) with autosave and recovery.
//!
//! Every edit is a [`Command`]. [`Editor::apply`] runs it and keeps the level as it was before,
//! so undo restores that state exactly and redo re-applies the command. A drag sends many
//! [`Command::MovePoint`]s (or [`Command::MoveMarker`]s) through [`Editor::drag`]: they merge into
//! one undo step until [`Editor::end_drag`].

use flockway_level::{
    DestroyerPlaceSpec, DestroyerSpec, DriverProfileSpec, Expectation, InitialVehiclesSpec, Level,
    LevelError, SpawnerSpec, TelemetrySpec, Template, TriggerSpec, VehicleTypeSpec,
    level_to_string, parse_level, validate, write_atomic,
};
use flockway_road::{Control, ControlPoint, JunctionSpec, LinkSpec, RoadSpec};
use glam::DVec3;
use std::path::{Path, PathBuf};

/// Which kind of marker a command addresses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MarkerKind {
    /// A spawner.
    Spawner,
    /// A destroyer on a road.
    Destroyer,
    /// A trigger stretch.
    Trigger,
}

/// One edit of a level. Roads and markers are addressed by their index in the level.
#[derive(Debug, Clone, PartialEq)]
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
    /// [`crate::joins::join_end`]).
    JoinEnd {
        /// The road whose end joins.
        road: usize,
        /// The road it leads onto, by name.
        onto: String,
    },
    /// Joins a road's end onto another road's side as an on-ramp with acceleration lanes (see
    /// [`crate::joins::join_side`]).
    JoinSide {
        /// The road whose end joins.
        road: usize,
        /// The road it joins, by name.
        onto: String,
        /// Where along that road, metres.
        s_m: f64,
    },
    /// Joins a road's start onto another road's side as an exit (see
    /// [`crate::joins::join_exit`]).
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
    /// Several edits as one undo step (all or none).
    Batch {
        /// What the undo menu calls it.
        label: &'static str,
        /// The edits, in order.
        commands: Vec<Command>,
    },
}

impl Command {
    /// A short description for the undo menu.
    pub fn label(&self) -> &'static str {
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
            Command::Batch { label, .. } => label,
        }
    }

    /// Whether the level's validation judges this edit: edits of settings and markers may not
    /// add a problem `flockway run` would reject (drawing a road passes through states that are
    /// not roads yet, so geometry edits are not judged).
    fn is_checked(&self) -> bool {
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
    fn drag_target(&self) -> Option<(u8, usize, usize)> {
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
            _ => None,
        }
    }
}

/// Why an edit or a save was refused. The level is unchanged.
#[derive(Debug, thiserror::Error)]
pub enum EditError {
    /// A road, point or marker index that does not exist.
    #[error("{0}")]
    NoSuchThing(String),
    /// A name already taken, or empty.
    #[error("{0}")]
    BadName(String),
    /// A value out of range.
    #[error("{0}")]
    BadValue(String),
    /// Saving would write a level that `flockway run` rejects: fix these first.
    #[error("Not saved, because `flockway run` would refuse the level: {0}")]
    Invalid(String),
    /// Reading or writing a file failed.
    #[error(transparent)]
    File(#[from] LevelError),
}

/// A state in the history: the level before an edit, and that edit.
#[derive(Debug, Clone)]
struct Step {
    command: Command,
    before: Level,
    before_id: u64,
    after_id: u64,
}

/// A level being edited, its file, and its history.
#[derive(Debug, Clone)]
pub struct Editor {
    level: Level,
    path: Option<PathBuf>,
    undo: Vec<Step>,
    redo: Vec<(Step, Level)>,
    /// Identity of the current state; each edit makes a new one, undo returns to an old one.
    state: u64,
    next_state: u64,
    saved_state: Option<u64>,
    autosaved_state: u64,
    dragging: bool,
}

/// How many edits undo remembers.
pub const UNDO_DEPTH: usize = 500;

impl Editor {
    /// A new, unsaved level with no roads yet, but the reference vehicle types and the
    /// `autonomous` and `human` driver profiles, so a spawner placed on the first road drawn
    /// spawns cars.
    pub fn new() -> Editor {
        Editor::with_level(Template::Empty.level("untitled"), None)
    }

    /// Edits `level`, which was loaded from (and saves to) `path`.
    pub fn with_level(level: Level, path: Option<PathBuf>) -> Editor {
        // As loaded (or as made from a template): nothing to save until it is edited.
        let saved = Some(0);
        Editor {
            level,
            path,
            undo: Vec::new(),
            redo: Vec::new(),
            state: 0,
            next_state: 1,
            saved_state: saved,
            autosaved_state: 0,
            dragging: false,
        }
    }

    /// Opens a level file.
    pub fn open(path: &Path) -> Result<Editor, EditError> {
        let level = flockway_level::load_level(path)?;
        Ok(Editor::with_level(level, Some(path.to_owned())))
    }

    /// The level as edited.
    pub fn level(&self) -> &Level {
        &self.level
    }

    /// The file it saves to, if it has one.
    pub fn path(&self) -> Option<&Path> {
        self.path.as_deref()
    }

    /// Whether there are changes that are not saved (the title bar's marker).
    pub fn is_dirty(&self) -> bool {
        self.saved_state != Some(self.state)
    }

    /// Whether there is an edit to undo, and its label.
    pub fn undo_label(&self) -> Option<&'static str> {
        self.undo.last().map(|s| s.command.label())
    }

    /// Whether there is an edit to redo, and its label.
    pub fn redo_label(&self) -> Option<&'static str> {
        self.redo.last().map(|(s, _)| s.command.label())
    }

    /// Applies an edit as its own undo step.
    pub fn apply(&mut self, command: Command) -> Result<(), EditError> {
        self.dragging = false;
        self.push(command)
    }

    /// Applies one movement of a drag: drags of the same point or marker merge into one undo
    /// step until [`Editor::end_drag`].
    pub fn drag(&mut self, command: Command) -> Result<(), EditError> {
        let target = command.drag_target();
        let merges = self.dragging
            && target.is_some()
            && self.undo.last().and_then(|s| s.command.drag_target()) == target;
        if merges {
            let mut level = self.level.clone();
            apply(&mut level, &command)?;
            self.judge(&command, &level)?;
            self.level = level;
            if let Some(step) = self.undo.last_mut() {
                step.command = command;
            }
            // The merged step ends in a new state (it differs from what was saved mid-drag).
            self.state = self.next_state;
            self.next_state += 1;
            if let Some(step) = self.undo.last_mut() {
                step.after_id = self.state;
            }
            return Ok(());
        }
        self.push(command)?;
        self.dragging = target.is_some();
        Ok(())
    }

    /// Ends a drag (the mouse button was released).
    pub fn end_drag(&mut self) {
        self.dragging = false;
    }

    /// Refuses an edit that adds a problem to the level (see [`Command`]'s checked edits), with
    /// the problem in words.
    fn judge(&self, command: &Command, after: &Level) -> Result<(), EditError> {
        if !command.is_checked() {
            return Ok(());
        }
        let before = validate(&self.level);
        match validate(after).into_iter().find(|i| !before.contains(i)) {
            Some(issue) => Err(EditError::BadValue(issue.describe(after))),
            None => Ok(()),
        }
    }

    fn push(&mut self, command: Command) -> Result<(), EditError> {
        let mut level = self.level.clone();
        apply(&mut level, &command)?;
        self.judge(&command, &level)?;
        let before = std::mem::replace(&mut self.level, level);
        let before_id = self.state;
        self.state = self.next_state;
        self.next_state += 1;
        self.undo.push(Step {
            command,
            before,
            before_id,
            after_id: self.state,
        });
        if self.undo.len() > UNDO_DEPTH {
            self.undo.remove(0);
        }
        self.redo.clear();
        Ok(())
    }

    /// Undoes the last edit; false if there is none.
    pub fn undo(&mut self) -> bool {
        self.dragging = false;
        let Some(step) = self.undo.pop() else {
            return false;
        };
        let after = std::mem::replace(&mut self.level, step.before.clone());
        self.state = step.before_id;
        self.redo.push((step, after));
        true
    }

    /// Redoes the last undone edit; false if there is none.
    pub fn redo(&mut self) -> bool {
        self.dragging = false;
        let Some((step, after)) = self.redo.pop() else {
            return false;
        };
        self.level = after;
        self.state = step.after_id;
        self.undo.push(step);
        true
    }

    /// Saves to its file (atomically). Refuses, saying why, a level `flockway run` would reject.
    pub fn save(&mut self) -> Result<PathBuf, EditError> {
        let path = self.path.clone().ok_or_else(|| {
            EditError::BadName("the level has no file yet: use Save As".to_owned())
        })?;
        self.save_as(&path)
    }

    /// Saves to `path` (atomically), which becomes its file.
    pub fn save_as(&mut self, path: &Path) -> Result<PathBuf, EditError> {
        let text = self.checked_text(path)?;
        write_atomic(path, text.as_bytes())?;
        self.path = Some(path.to_owned());
        self.saved_state = Some(self.state);
        // The autosave is older than the file now.
        if let Some(a) = autosave_path(Some(path)) {
            let _ = std::fs::remove_file(a);
        }
        Ok(path.to_owned())
    }

    /// The level's RON text, checked by the same parser and validation `flockway run` uses.
    pub fn checked_text(&self, path: &Path) -> Result<String, EditError> {
        let issues = validate(&self.level);
        if let Some(first) = issues.first() {
            let more = match issues.len() {
                1 => String::new(),
                n => format!(" (and {} more problem(s))", n - 1),
            };
            return Err(EditError::Invalid(format!(
                "{}{more}",
                first.describe(&self.level)
            )));
        }
        let text = level_to_string(&self.level)?;
        parse_level(&text, path).map_err(|e| EditError::Invalid(e.to_string()))?;
        Ok(text)
    }

    /// Writes the autosave file if anything changed since the last autosave (valid or not: it
    /// keeps work in progress). Returns the file written.
    pub fn autosave(&mut self) -> Result<Option<PathBuf>, EditError> {
        if self.autosaved_state == self.state || !self.is_dirty() {
            return Ok(None);
        }
        let Some(path) = autosave_path(self.path.as_deref()) else {
            return Ok(None);
        };
        let text = level_to_string(&self.level)?;
        write_atomic(&path, text.as_bytes())?;
        self.autosaved_state = self.state;
        Ok(Some(path))
    }
}

impl Default for Editor {
    fn default() -> Self {
        Editor::new()
    }
}

/// Where the autosave of a level file lives: a hidden file beside it; for an unsaved level, in
/// the system's temporary directory.
pub fn autosave_path(level_path: Option<&Path>) -> Option<PathBuf> {
    match level_path {
        Some(p) => {
            let name = p.file_name()?.to_string_lossy().into_owned();
            Some(p.with_file_name(format!(".{name}.autosave")))
        }
        None => Some(std::env::temp_dir().join("flockway-untitled.ron.autosave")),
    }
}

/// An autosave left by a session that did not end cleanly (newer than the level file, or of an
/// unsaved level), as an editor to offer the user.
pub fn recover(level_path: Option<&Path>) -> Option<Editor> {
    let auto = autosave_path(level_path)?;
    let auto_time = std::fs::metadata(&auto).and_then(|m| m.modified()).ok()?;
    if let Some(p) = level_path
        && let Ok(file_time) = std::fs::metadata(p).and_then(|m| m.modified())
        && file_time > auto_time
    {
        return None;
    }
    let text = std::fs::read_to_string(&auto).ok()?;
    // Work in progress may not validate: read the schema only.
    let level: Level = ron::Options::default()
        .with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME)
        .from_str(&text)
        .ok()?;
    let mut editor = Editor::with_level(level, level_path.map(Path::to_owned));
    // Recovered work is not what the file holds.
    editor.saved_state = None;
    Some(editor)
}

fn road_mut(level: &mut Level, road: usize) -> Result<&mut RoadSpec, EditError> {
    let n = level.roads.len();
    level.roads.get_mut(road).ok_or_else(|| {
        EditError::NoSuchThing(format!("there is no road {road} (the level has {n})"))
    })
}

fn point_index(spec: &RoadSpec, index: usize) -> Result<usize, EditError> {
    if index < spec.points.len() {
        Ok(index)
    } else {
        Err(EditError::NoSuchThing(format!(
            "road `{}` has no point {index} (it has {})",
            spec.name,
            spec.points.len()
        )))
    }
}

fn finite(v: DVec3) -> Result<DVec3, EditError> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(EditError::BadValue(format!("position {v} is not finite")))
    }
}

fn marker_count(level: &Level, kind: MarkerKind) -> usize {
    match kind {
        MarkerKind::Spawner => level.spawners.len(),
        MarkerKind::Destroyer => level.destroyers.len(),
        MarkerKind::Trigger => level.triggers.len(),
    }
}

/// Runs one command on a level; on error the level may be partly changed (callers apply to a
/// copy).
fn apply(level: &mut Level, command: &Command) -> Result<(), EditError> {
    match command {
        Command::AddRoad { at } => {
            let at = finite(*at)?;
            let mut n = level.roads.len() + 1;
            while level.road(&format!("road {n}")).is_some() {
                n += 1;
            }
            let mut spec = RoadSpec::through(&format!("road {n}"), 2, 50.0, &[]);
            spec.points.push(ControlPoint::at(at));
            level.roads.push(spec);
        }
        Command::AppendPoint { road, at } => {
            let at = finite(*at)?;
            road_mut(level, *road)?.points.push(ControlPoint::at(at));
        }
        Command::InsertPoint { road, index, at } => {
            let at = finite(*at)?;
            let spec = road_mut(level, *road)?;
            if *index > spec.points.len() {
                return Err(EditError::NoSuchThing(format!(
                    "road `{}` has no point {index} to insert before",
                    spec.name
                )));
            }
            spec.points.insert(*index, ControlPoint::at(at));
        }
        Command::MovePoint { road, index, to } => {
            let to = finite(*to)?;
            let spec = road_mut(level, *road)?;
            let i = point_index(spec, *index)?;
            spec.points[i].pos = to;
        }
        Command::DeletePoint { road, index } => {
            let spec = road_mut(level, *road)?;
            let i = point_index(spec, *index)?;
            spec.points.remove(i);
            if spec.points.is_empty() {
                return apply(level, &Command::DeleteRoad { road: *road });
            }
        }
        Command::DeleteRoad { road } => {
            let name = road_mut(level, *road)?.name.clone();
            level.roads.remove(*road);
            for r in &mut level.roads {
                if r.next.as_deref() == Some(&name) {
                    r.next = None;
                }
                r.links.retain(|l| l.to != name);
            }
            level.spawners.retain(|s| s.road != name);
            for s in &mut level.spawners {
                s.routes.retain(|r| !r.roads.contains(&name));
                if s.destination.as_deref() == Some(name.as_str()) {
                    s.destination = None;
                }
            }
            level.triggers.retain(|t| t.road != name);
            level.vehicles.retain(|v| v.road != name);
            let on_road = |d: &DestroyerSpec| matches!(&d.place, DestroyerPlaceSpec::OnRoad { road, .. } if *road == name);
            let gone: Vec<String> = level
                .destroyers
                .iter()
                .filter(|d| on_road(d))
                .map(|d| d.name.clone())
                .collect();
            level.destroyers.retain(|d| !on_road(d));
            // Expectations on the road, or on a destroyer that stood on it, go with them.
            level.expect.retain(|e| {
                let qualifier = flockway_level::metric_info(&e.metric).map(|m| m.qualifier);
                match (qualifier, e.qualifier.as_deref()) {
                    (Some(flockway_level::Qualifier::Road), Some(q)) => q != name,
                    (Some(flockway_level::Qualifier::Destroyer), Some(q)) => {
                        !gone.iter().any(|g| g == q)
                    }
                    _ => true,
                }
            });
        }
        Command::SetClosed { road, closed } => {
            let spec = road_mut(level, *road)?;
            spec.closed = *closed;
            if *closed {
                spec.next = None;
            }
        }
        Command::Connect { road, next } => {
            if let Some(n) = next
                && level.road(n).is_none()
            {
                return Err(EditError::NoSuchThing(format!(
                    "there is no road named `{n}`"
                )));
            }
            let spec = road_mut(level, *road)?;
            if next.as_deref() == Some(spec.name.as_str()) {
                return Err(EditError::BadValue(
                    "a road cannot lead onto itself: close it into a loop instead".to_owned(),
                ));
            }
            spec.next = next.clone();
            if next.is_some() {
                spec.closed = false;
            }
        }
        Command::SetLinks { road, links } => {
            let from = road_mut(level, *road)?.clone();
            for l in links {
                let Some(to) = level.road(&l.to) else {
                    return Err(EditError::NoSuchThing(format!(
                        "there is no road named `{}`",
                        l.to
                    )));
                };
                if l.to == from.name {
                    return Err(EditError::BadValue(
                        "a road cannot lead onto itself: close it into a loop instead".to_owned(),
                    ));
                }
                if let Some((a, b)) = l
                    .lanes
                    .iter()
                    .find(|(a, b)| *a >= from.lanes || *b >= to.lanes)
                {
                    return Err(EditError::BadValue(format!(
                        "lane {a} onto lane {b}: `{}` has {} lane(s), `{}` has {}",
                        from.name, from.lanes, to.name, to.lanes
                    )));
                }
            }
            let spec = road_mut(level, *road)?;
            spec.next = None;
            spec.links = links.clone();
            if !links.is_empty() {
                spec.closed = false;
            }
        }
        Command::JoinEnd { road, onto } => {
            crate::joins::join_end(level, *road, onto).map_err(EditError::BadValue)?;
        }
        Command::JoinSide { road, onto, s_m } => {
            crate::joins::join_side(level, *road, onto, *s_m).map_err(EditError::BadValue)?;
        }
        Command::JoinExit { road, onto, s_m } => {
            crate::joins::join_exit(level, *road, onto, *s_m).map_err(EditError::BadValue)?;
        }
        Command::SetPoint { road, index, point } => {
            finite(point.pos)?;
            let spec = road_mut(level, *road)?;
            let i = point_index(spec, *index)?;
            spec.points[i] = point.clone();
        }
        Command::SetRoad {
            road,
            name,
            lanes,
            lane_width_m,
            speed_limit_kmh,
        } => {
            let name = name.trim().to_owned();
            let old = road_mut(level, *road)?.name.clone();
            if name.is_empty() {
                return Err(EditError::BadName("a road needs a name".to_owned()));
            }
            if name != old && level.road(&name).is_some() {
                return Err(EditError::BadName(format!(
                    "another road is named `{name}`"
                )));
            }
            if !(1..=16).contains(lanes) {
                return Err(EditError::BadValue(format!(
                    "{lanes} lanes: expected 1 to 16"
                )));
            }
            if !(lane_width_m.is_finite() && (2.0..=6.0).contains(lane_width_m)) {
                return Err(EditError::BadValue(format!(
                    "lane width {lane_width_m} m: expected 2 to 6 m"
                )));
            }
            if !(speed_limit_kmh.is_finite() && (1.0..=300.0).contains(speed_limit_kmh)) {
                return Err(EditError::BadValue(format!(
                    "speed limit {speed_limit_kmh} km/h: expected 1 to 300 km/h"
                )));
            }
            let spec = road_mut(level, *road)?;
            spec.name = name.clone();
            spec.lanes = *lanes;
            spec.lane_width_m = *lane_width_m;
            spec.speed_limit_kmh = *speed_limit_kmh;
            if name != old {
                rename_road(level, &old, &name);
            }
            // Fewer lanes: what stood in a lane that is gone moves to the new leftmost one.
            let top = *lanes - 1;
            for s in level.spawners.iter_mut().filter(|s| s.road == name) {
                s.lane = s.lane.min(top);
            }
            for v in level.vehicles.iter_mut().filter(|v| v.road == name) {
                v.lane = v.lane.min(top);
            }
            for t in level.triggers.iter_mut().filter(|t| t.road == name) {
                if let Some(l) = &mut t.lanes {
                    l.retain(|k| *k <= top);
                    if l.is_empty() {
                        t.lanes = None;
                    }
                }
            }
        }
        Command::SetLevelInfo {
            name,
            description,
            seed,
            duration_s,
            telemetry,
        } => {
            level.name = name.trim().to_owned();
            level.description = description.clone();
            level.seed = *seed;
            level.duration_s = *duration_s;
            level.telemetry = telemetry.clone();
        }
        Command::AddVehicleType(v) => level.vehicle_types.push(v.clone()),
        Command::SetVehicleType(i, v) => {
            let old = marker(&mut level.vehicle_types, *i)?.name.clone();
            level.vehicle_types[*i] = v.clone();
            for p in &mut level.driver_profiles {
                if p.vehicle == old {
                    p.vehicle = v.name.clone();
                }
            }
        }
        Command::DeleteVehicleType(i) => {
            let name = marker(&mut level.vehicle_types, *i)?.name.clone();
            let users: Vec<String> = level
                .driver_profiles
                .iter()
                .filter(|p| p.vehicle == name)
                .map(|p| format!("`{}`", p.name))
                .collect();
            if !users.is_empty() {
                return Err(EditError::BadValue(format!(
                    "vehicle type `{name}` is driven by driver profile {}: give {} another \
                     vehicle first",
                    users.join(", "),
                    if users.len() == 1 { "it" } else { "them" }
                )));
            }
            level.vehicle_types.remove(*i);
        }
        Command::AddDriverProfile(p) => level.driver_profiles.push(p.clone()),
        Command::SetDriverProfile(i, p) => {
            let old = marker(&mut level.driver_profiles, *i)?.name.clone();
            level.driver_profiles[*i] = p.clone();
            if p.name != old {
                rename_profile(level, &old, &p.name);
            }
        }
        Command::DeleteDriverProfile(i) => {
            let name = marker(&mut level.driver_profiles, *i)?.name.clone();
            let mut users: Vec<String> = level
                .spawners
                .iter()
                .filter(|s| s.profiles.iter().any(|p| p.profile == name))
                .map(|s| format!("spawner `{}`", s.name))
                .collect();
            users.extend(
                level
                    .vehicles
                    .iter()
                    .enumerate()
                    .filter(|(_, v)| v.profile == name)
                    .map(|(k, _)| format!("vehicle group {}", k + 1)),
            );
            if !users.is_empty() {
                return Err(EditError::BadValue(format!(
                    "driver profile `{name}` is used by {}: remove it there first",
                    users.join(", ")
                )));
            }
            level.driver_profiles.remove(*i);
            level.expect.retain(|e| {
                e.qualifier.as_deref() != Some(name.as_str()) || !profile_metric(&e.metric)
            });
        }
        Command::SetExpectations(list) => level.expect = list.clone(),
        Command::AddVehicles(v) => level.vehicles.push(v.clone()),
        Command::SetVehicles(i, v) => *marker(&mut level.vehicles, *i)? = v.clone(),
        Command::DeleteVehicles(i) => {
            marker(&mut level.vehicles, *i)?;
            level.vehicles.remove(*i);
        }
        Command::Batch { commands, .. } => {
            for c in commands {
                apply(level, c)?;
            }
        }
        Command::AddPrefab { roads, junctions } => {
            level.roads.extend(roads.iter().cloned());
            level.junctions.extend(junctions.iter().cloned());
        }
        Command::SetJunction(i, j) => {
            let taken = level
                .junctions
                .iter()
                .enumerate()
                .any(|(k, o)| k != *i && o.name == j.name);
            if j.name.trim().is_empty() || taken {
                return Err(EditError::BadName(format!(
                    "a junction needs a name of its own, and `{}` is {}",
                    j.name,
                    if taken { "taken" } else { "empty" }
                )));
            }
            let old = junction(level, *i)?.name.clone();
            *junction(level, *i)? = j.clone();
            // Expectations on the junction follow its new name.
            for e in &mut level.expect {
                let on_junction = flockway_level::metric_info(&e.metric)
                    .is_some_and(|m| m.qualifier == flockway_level::Qualifier::Junction);
                if on_junction && e.qualifier.as_deref() == Some(old.as_str()) {
                    e.qualifier = Some(j.name.clone());
                }
            }
        }
        Command::DeleteJunction(i) => {
            junction(level, *i)?;
            level.junctions.remove(*i);
        }
        Command::AddSpawner(s) => level.spawners.push(s.clone()),
        Command::AddDestroyer(d) => level.destroyers.push(d.clone()),
        Command::AddTrigger(t) => level.triggers.push(t.clone()),
        Command::SetSpawner(i, s) => *marker(&mut level.spawners, *i)? = s.clone(),
        Command::SetDestroyer(i, d) => {
            let old = marker(&mut level.destroyers, *i)?.name.clone();
            level.destroyers[*i] = d.clone();
            for e in &mut level.expect {
                if e.metric == "flow_veh_per_h" && e.qualifier.as_deref() == Some(old.as_str()) {
                    e.qualifier = Some(d.name.clone());
                }
            }
        }
        Command::SetTrigger(i, t) => *marker(&mut level.triggers, *i)? = t.clone(),
        Command::MoveMarker { kind, index, s_m } => {
            if !s_m.is_finite() || *s_m < 0.0 {
                return Err(EditError::BadValue(format!("arc position {s_m} m")));
            }
            match kind {
                MarkerKind::Spawner => marker(&mut level.spawners, *index)?.s_m = *s_m,
                MarkerKind::Destroyer => match &mut marker(&mut level.destroyers, *index)?.place {
                    DestroyerPlaceSpec::OnRoad { s_m: at, .. } => *at = *s_m,
                    DestroyerPlaceSpec::Volume { .. } => {
                        return Err(EditError::BadValue(
                            "a volume destroyer is not on a road: edit its corners".to_owned(),
                        ));
                    }
                },
                MarkerKind::Trigger => {
                    let t = marker(&mut level.triggers, *index)?;
                    let len = t.to_m - t.from_m;
                    t.from_m = *s_m;
                    t.to_m = *s_m + len;
                }
            }
        }
        Command::DeleteMarker { kind, index } => {
            let n = marker_count(level, *kind);
            if *index >= n {
                return Err(EditError::NoSuchThing(format!(
                    "there is no {kind:?} {index}"
                )));
            }
            match kind {
                MarkerKind::Spawner => drop(level.spawners.remove(*index)),
                MarkerKind::Destroyer => drop(level.destroyers.remove(*index)),
                MarkerKind::Trigger => drop(level.triggers.remove(*index)),
            }
        }
    }
    Ok(())
}

fn marker<T>(list: &mut [T], index: usize) -> Result<&mut T, EditError> {
    let n = list.len();
    list.get_mut(index).ok_or_else(|| {
        EditError::NoSuchThing(format!("there is no marker {index} (there are {n})"))
    })
}

/// Junction `index` of a level, or why there is none.
fn junction(level: &mut Level, index: usize) -> Result<&mut JunctionSpec, EditError> {
    let n = level.junctions.len();
    level.junctions.get_mut(index).ok_or_else(|| {
        EditError::NoSuchThing(format!("there is no junction {index} (there are {n})"))
    })
}

/// Whether a metric's qualifier names a driver profile.
fn profile_metric(metric: &str) -> bool {
    flockway_level::metric_info(metric)
        .is_some_and(|m| m.qualifier == flockway_level::Qualifier::Profile)
}

/// Follows a driver profile's new name everywhere the level refers to it.
fn rename_profile(level: &mut Level, old: &str, new: &str) {
    for s in &mut level.spawners {
        for share in &mut s.profiles {
            if share.profile == old {
                share.profile = new.to_owned();
            }
        }
    }
    for v in &mut level.vehicles {
        if v.profile == old {
            v.profile = new.to_owned();
        }
    }
    for e in &mut level.expect {
        if profile_metric(&e.metric) && e.qualifier.as_deref() == Some(old) {
            e.qualifier = Some(new.to_owned());
        }
    }
}

/// Follows a road's new name everywhere the level refers to it.
fn rename_road(level: &mut Level, old: &str, new: &str) {
    let fix = |s: &mut String| {
        if s == old {
            *s = new.to_owned();
        }
    };
    for r in &mut level.roads {
        if let Some(n) = &mut r.next {
            fix(n);
        }
        r.links.iter_mut().for_each(|l| fix(&mut l.to));
    }
    level.spawners.iter_mut().for_each(|s| fix(&mut s.road));
    for s in &mut level.spawners {
        s.routes
            .iter_mut()
            .for_each(|r| r.roads.iter_mut().for_each(fix));
        if let Some(d) = &mut s.destination {
            fix(d);
        }
    }
    level.triggers.iter_mut().for_each(|t| fix(&mut t.road));
    level.vehicles.iter_mut().for_each(|v| fix(&mut v.road));
    for d in &mut level.destroyers {
        if let DestroyerPlaceSpec::OnRoad { road, .. } = &mut d.place {
            fix(road);
        }
    }
    for e in &mut level.expect {
        if e.metric == "road_length_m"
            && let Some(q) = &mut e.qualifier
        {
            fix(q);
        }
    }
    for j in &mut level.junctions {
        for c in &mut j.connections {
            fix(&mut c.from);
            fix(&mut c.to);
        }
        if let Control::Priority { major, .. } = &mut j.control {
            major.iter_mut().for_each(fix);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(x: f64, y: f64) -> DVec3 {
        DVec3::new(x, y, 0.0)
    }

    /// Four clicks: a road and three more points.
    fn four_points(e: &mut Editor) {
        e.apply(Command::AddRoad { at: p(0.0, 0.0) })
            .expect("add road");
        for at in [p(100.0, 0.0), p(200.0, 50.0), p(300.0, 50.0)] {
            e.apply(Command::AppendPoint { road: 0, at })
                .expect("append");
        }
    }

    #[test]
    fn clicks_drag_undo_redo_and_save_give_the_level_run_loads() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("drawn.ron");
        let mut e = Editor::new();
        assert!(!e.is_dirty() || e.path().is_none());
        four_points(&mut e);
        assert_eq!(e.level().roads[0].points.len(), 4);
        // A drag: many small moves, one undo step.
        for k in 1..=10 {
            e.drag(Command::MovePoint {
                road: 0,
                index: 2,
                to: p(200.0, 50.0 + f64::from(k)),
            })
            .expect("drag");
        }
        e.end_drag();
        assert_eq!(e.level().roads[0].points[2].pos, p(200.0, 60.0));
        assert!(e.undo());
        assert_eq!(
            e.level().roads[0].points[2].pos,
            p(200.0, 50.0),
            "one undo undoes the drag"
        );
        assert_eq!(e.redo_label(), Some("move point"));
        assert!(e.redo());
        assert_eq!(e.level().roads[0].points[2].pos, p(200.0, 60.0));
        assert!(e.is_dirty());
        assert!(
            matches!(e.save(), Err(EditError::BadName(_))),
            "no file yet"
        );
        e.save_as(&path).expect("save");
        assert!(!e.is_dirty());
        let loaded = flockway_level::load_level(&path).expect("flockway run loads it");
        assert_eq!(&loaded, e.level());
        // Undo after saving makes it dirty; redo back to the saved state makes it clean.
        assert!(e.undo());
        assert!(e.is_dirty());
        assert!(e.redo());
        assert!(!e.is_dirty());
    }

    #[test]
    fn every_edit_undoes_to_the_exact_level_before_it() {
        let mut e = Editor::with_level(
            flockway_level::load_level(Path::new("../../levels/speed_limit_change.ron"))
                .expect("shipped level"),
            None,
        );
        let original = e.level().clone();
        let road_name = original.roads[0].name.clone();
        let commands = vec![
            Command::InsertPoint {
                road: 0,
                index: 1,
                at: p(5.0, 5.0),
            },
            Command::SetPoint {
                road: 0,
                index: 0,
                point: ControlPoint {
                    width_m: Some(16.0),
                    bank_deg: 2.0,
                    guardrail_left: false,
                    ..original.roads[0].points[0].clone()
                },
            },
            Command::SetRoad {
                road: 0,
                name: "highway".to_owned(),
                lanes: 3,
                lane_width_m: 3.5,
                speed_limit_kmh: 80.0,
            },
            Command::MoveMarker {
                kind: MarkerKind::Trigger,
                index: 0,
                s_m: 300.0,
            },
            Command::MoveMarker {
                kind: MarkerKind::Spawner,
                index: 0,
                s_m: 2.0,
            },
            Command::DeleteMarker {
                kind: MarkerKind::Destroyer,
                index: 0,
            },
            Command::SetClosed {
                road: 0,
                closed: true,
            },
            Command::AddRoad {
                at: p(-50.0, -50.0),
            },
            Command::DeletePoint { road: 1, index: 0 },
            Command::DeleteRoad { road: 0 },
        ];
        let mut states = vec![e.level().clone()];
        for c in commands {
            e.apply(c.clone())
                .unwrap_or_else(|err| panic!("{c:?}: {err}"));
            states.push(e.level().clone());
        }
        // The rename followed the road into every marker before the road was deleted.
        assert!(states[3].spawners.iter().all(|s| s.road == "highway"));
        assert!(states[3].triggers.iter().all(|t| t.road == "highway"));
        assert_ne!(road_name, "highway");
        // Deleting the road took its markers with it.
        assert!(e.level().roads.is_empty() && e.level().spawners.is_empty());
        for want in states.iter().rev().skip(1) {
            assert!(e.undo());
            assert_eq!(e.level(), want);
        }
        assert!(!e.undo(), "nothing left to undo");
        assert_eq!(e.level(), &original);
        // Redo walks forward through the same states.
        for want in states.iter().skip(1) {
            assert!(e.redo());
            assert_eq!(e.level(), want);
        }
    }

    #[test]
    fn refused_edits_leave_the_level_and_history_alone() {
        let mut e = Editor::new();
        four_points(&mut e);
        let before = e.level().clone();
        let depth = e.undo.len();
        for bad in [
            Command::MovePoint {
                road: 0,
                index: 9,
                to: p(0.0, 0.0),
            },
            Command::MovePoint {
                road: 3,
                index: 0,
                to: p(0.0, 0.0),
            },
            Command::AppendPoint {
                road: 0,
                at: DVec3::new(f64::NAN, 0.0, 0.0),
            },
            Command::Connect {
                road: 0,
                next: Some("nowhere".to_owned()),
            },
            Command::SetRoad {
                road: 0,
                name: " ".to_owned(),
                lanes: 2,
                lane_width_m: 3.0,
                speed_limit_kmh: 50.0,
            },
            Command::SetRoad {
                road: 0,
                name: "r".to_owned(),
                lanes: 0,
                lane_width_m: 3.0,
                speed_limit_kmh: 50.0,
            },
            Command::DeleteMarker {
                kind: MarkerKind::Spawner,
                index: 0,
            },
        ] {
            assert!(e.apply(bad.clone()).is_err(), "{bad:?} was accepted");
            assert_eq!(e.level(), &before);
            assert_eq!(e.undo.len(), depth);
        }
    }

    #[test]
    fn an_invalid_level_is_not_saved_but_is_autosaved_and_recovered() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("wip.ron");
        let mut e = Editor::new();
        e.apply(Command::AddRoad { at: p(0.0, 0.0) }).expect("add");
        // One point is not a road yet: saving says so and writes nothing.
        let err = e.save_as(&path).expect_err("invalid");
        assert!(matches!(err, EditError::Invalid(_)), "{err}");
        assert!(!path.exists());
        e.apply(Command::AppendPoint {
            road: 0,
            at: p(50.0, 0.0),
        })
        .expect("append");
        e.save_as(&path).expect("valid now");
        // Work after the save is autosaved beside the file, and offered back after a crash.
        e.apply(Command::AppendPoint {
            road: 0,
            at: p(90.0, 20.0),
        })
        .expect("append");
        let auto = e.autosave().expect("autosave").expect("written");
        assert_eq!(auto, autosave_path(Some(&path)).expect("a path"));
        assert_eq!(
            e.autosave().expect("again"),
            None,
            "nothing new to autosave"
        );
        let back = recover(Some(&path)).expect("recovered");
        assert_eq!(back.level().roads[0].points.len(), 3);
        assert!(back.is_dirty());
        // Saving removes the autosave: nothing to recover.
        e.save().expect("save");
        assert!(!auto.exists());
        assert!(recover(Some(&path)).is_none());
    }

    #[test]
    fn junction_edits_are_checked_and_renames_follow_roads_and_expectations() {
        let mut e = Editor::with_level(
            flockway_level::load_level(Path::new("../../levels/crossroads_priority.ron"))
                .expect("shipped level"),
            None,
        );
        let name = e.level().junctions[0].name.clone();
        assert!(
            e.level()
                .expect
                .iter()
                .any(|x| x.qualifier.as_deref() == Some(name.as_str()))
        );
        // A renamed junction takes its expectations with it.
        let mut j = e.level().junctions[0].clone();
        j.name = "main junction".to_owned();
        e.apply(Command::SetJunction(0, j)).expect("renames");
        assert!(
            e.level()
                .expect
                .iter()
                .all(|x| x.qualifier.as_deref() != Some(name.as_str()))
        );
        assert!(validate(e.level()).is_empty(), "{:?}", validate(e.level()));
        // A renamed road is renamed in the junction's connections and major roads.
        let Control::Priority { major, .. } = &e.level().junctions[0].control else {
            panic!("a priority junction");
        };
        let major_road = major[0].clone();
        let r = e
            .level()
            .roads
            .iter()
            .position(|r| r.name == major_road)
            .expect("the major road");
        let spec = e.level().roads[r].clone();
        e.apply(Command::SetRoad {
            road: r,
            name: "main street".to_owned(),
            lanes: spec.lanes,
            lane_width_m: spec.lane_width_m,
            speed_limit_kmh: spec.speed_limit_kmh,
        })
        .expect("renames");
        let j = &e.level().junctions[0];
        assert!(j.connections.iter().any(|c| c.from == "main street"));
        assert!(j.connections.iter().all(|c| c.from != major_road));
        assert!(matches!(&j.control, Control::Priority { major, .. } if major[0] == "main street"));
        assert!(validate(e.level()).is_empty(), "{:?}", validate(e.level()));
        // A signal whose phases lack a connection's state is refused, the level unchanged.
        let mut bad = e.level().junctions[0].clone();
        bad.control = Control::Signal;
        bad.signal = Some(flockway_road::SignalProgram {
            offset_s: 0.0,
            phases: vec![flockway_road::Phase {
                duration_s: 30.0,
                state: "G".to_owned(),
            }],
        });
        let before = e.level().clone();
        let err = e
            .apply(Command::SetJunction(0, bad))
            .expect_err("one letter");
        assert!(err.to_string().contains("letter"), "{err}");
        assert_eq!(e.level(), &before);
        // Two junctions may not share a name.
        let mut copy = e.level().junctions[0].clone();
        copy.name = String::new();
        assert!(e.apply(Command::SetJunction(0, copy)).is_err());
    }

    #[test]
    fn network_edits_follow_renames_and_deletions_and_undo_exactly() {
        let mut e = Editor::with_level(
            flockway_level::load_level(Path::new("../../levels/exit_split.ron"))
                .expect("shipped level"),
            None,
        );
        let original = e.level().clone();
        let road = |e: &Editor, name: &str| {
            e.level()
                .roads
                .iter()
                .position(|r| r.name == name)
                .expect(name)
        };
        let (approach, south) = (road(&e, "approach"), road(&e, "south"));
        // A rename follows the road into links, routes and markers.
        let spec = e.level().roads[south].clone();
        e.apply(Command::SetRoad {
            road: south,
            name: "exit".to_owned(),
            lanes: spec.lanes,
            lane_width_m: spec.lane_width_m,
            speed_limit_kmh: spec.speed_limit_kmh,
        })
        .expect("renames");
        let level = e.level();
        assert!(level.roads[approach].links.iter().any(|l| l.to == "exit"));
        assert!(
            level
                .spawners
                .iter()
                .all(|s| s.routes[0].roads == ["approach", "exit"]),
            "{:?}",
            level.spawners[0].routes
        );
        assert!(validate(level).is_empty(), "the renamed level is valid");
        // Lane pairs are checked against both roads' lanes.
        let mut links = level.roads[approach].links.clone();
        links[0].lanes = vec![(0, 3)];
        let err = e
            .apply(Command::SetLinks {
                road: approach,
                links,
            })
            .expect_err("lane 3 of a one-lane road");
        assert!(err.to_string().contains("lane 0 onto lane 3"), "{err}");
        // Removing a link that routes use is refused with the route's problem.
        let north_only: Vec<LinkSpec> = e.level().roads[approach]
            .links
            .iter()
            .filter(|l| l.to == "north")
            .cloned()
            .collect();
        let err = e
            .apply(Command::SetLinks {
                road: approach,
                links: north_only,
            })
            .expect_err("routes use the exit");
        assert!(err.to_string().contains("exit"), "{err}");
        // Deleting the exit road takes the links and routes onto it.
        e.apply(Command::DeleteRoad { road: south })
            .expect("deletes");
        let level = e.level();
        assert!(
            level
                .roads
                .iter()
                .all(|r| r.links.iter().all(|l| l.to != "exit"))
        );
        assert!(level.spawners.iter().all(|s| s.routes.len() == 1));
        assert!(validate(level).is_empty(), "{:?}", validate(level));
        assert!(e.undo() && e.undo());
        assert_eq!(e.level(), &original);
    }

    #[test]
    fn connecting_roads_opens_loops_and_refuses_itself() {
        let mut e = Editor::new();
        four_points(&mut e);
        e.apply(Command::AddRoad { at: p(300.0, 50.0) })
            .expect("second road");
        e.apply(Command::AppendPoint {
            road: 1,
            at: p(400.0, 50.0),
        })
        .expect("append");
        e.apply(Command::SetClosed {
            road: 0,
            closed: true,
        })
        .expect("close");
        e.apply(Command::Connect {
            road: 0,
            next: Some("road 2".to_owned()),
        })
        .expect("connect");
        assert!(!e.level().roads[0].closed);
        assert_eq!(e.level().roads[0].next.as_deref(), Some("road 2"));
        assert!(
            e.apply(Command::Connect {
                road: 1,
                next: Some("road 2".to_owned())
            })
            .is_err()
        );
        // Renaming the target keeps the connection.
        e.apply(Command::SetRoad {
            road: 1,
            name: "exit".to_owned(),
            lanes: 2,
            lane_width_m: 3.0,
            speed_limit_kmh: 50.0,
        })
        .expect("rename");
        assert_eq!(e.level().roads[0].next.as_deref(), Some("exit"));
    }
}
