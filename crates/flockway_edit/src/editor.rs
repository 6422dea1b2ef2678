//! The editor's history: a level, the commands that edited it, undo and redo, and saving
//! (atomic, exactly the RON `flockway run` loads) with autosave and recovery.
//!
//! Every edit is a [`Command`]. [`Editor::apply`] runs it and keeps the level as it was before,
//! so undo restores that state exactly and redo re-applies the command. A drag sends many
//! [`Command::MovePoint`]s (or [`Command::MoveMarker`]s) through [`Editor::drag`]: they merge into
//! one undo step until [`Editor::end_drag`].

use crate::apply::apply;
use crate::command::Command;
use crate::error::EditError;
use flockway_level::{Level, Template, level_to_string, parse_level, validate, write_atomic};
use std::path::{Path, PathBuf};

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
    pub fn undo_label(&self) -> Option<&str> {
        self.undo.last().map(|s| s.command.label())
    }

    /// Whether there is an edit to redo, and its label.
    pub fn redo_label(&self) -> Option<&str> {
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
            Some(issue) => Err(EditError::AddsProblem(issue.describe(after))),
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
        let path = self.path.clone().ok_or(EditError::NoFile)?;
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::command::MarkerKind;
    use flockway_road::{Control, ControlPoint, LinkSpec};
    use glam::DVec3;

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
        assert!(matches!(e.save(), Err(EditError::NoFile)), "no file yet");
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
