//! The application state behind the window: the editor, play mode, camera, tools and selection,
//! with every user action as a method, so tests drive it without a window.

mod files;
mod pick;
mod session;
#[cfg(test)]
mod tests;
mod tools;
mod view;

use crate::play::{FRAME_BUDGET, PlaySession};
use flockway_edit::{
    Command, EditError, Editor, MarkerKind, PrefabKind, level_network, place_marker, place_prefab,
    playable,
};
use flockway_level::{DestroyerPlaceSpec, DriverProfileSpec, Level, validate};
use flockway_render::Camera;
use flockway_render::{StaticScene, Vertex, box_faces};
use flockway_road::{RoadGeometry, RoadNetwork, lane_offset};
use flockway_runner::{RunError, level_name, load_driver_profiles};
use glam::{DVec3, Vec2, Vec3};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// What a click in the scene does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Tool {
    /// Select and drag control points and roads.
    #[default]
    Select,
    /// Click to add a road, then its points.
    Road,
    /// Click on a road to place a spawner.
    Spawner,
    /// Click on a road to place a destroyer.
    Destroyer,
    /// Click on a road to place a speed-limit trigger.
    Trigger,
    /// Click on the ground to place a four-arm roundabout centred there.
    Roundabout,
    /// Click on the ground to place a four-arm signalised crossroads centred there.
    Crossroads,
}

/// What is selected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Selection {
    /// Nothing.
    #[default]
    None,
    /// A road.
    Road(usize),
    /// A control point of a road.
    Point(usize, usize),
    /// A marker.
    Marker(MarkerKind, usize),
    /// A vehicle in play mode, by its index in the frame.
    Vehicle(usize),
    /// A junction, by its index in the level.
    Junction(usize),
}

/// Something the user asked for that would lose unsaved changes, waiting for a yes.
#[derive(Debug, Clone, PartialEq)]
pub enum Pending {
    /// Start a new level.
    New,
    /// Open a level file.
    Open(PathBuf),
    /// Quit.
    Quit,
}

/// What the left button is dragging.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Drag {
    /// A control point.
    Point(usize, usize),
    /// A marker along its road.
    Marker(MarkerKind, usize),
}

/// What a road's end dropped onto another road does.
#[derive(Debug, Clone, PartialEq)]
enum Join {
    /// Links onto the other road's start.
    End {
        /// The other road.
        onto: String,
    },
    /// Leaves its side as an exit (a road's start dropped there).
    Exit {
        /// The other road.
        onto: String,
        /// Where along it, metres.
        s_m: f64,
    },
    /// Joins its side as an on-ramp.
    Side {
        /// The other road.
        onto: String,
        /// Where along it, metres.
        s_m: f64,
    },
}

/// Pixels within which a click takes a control point.
pub const PICK_PX: f32 = 12.0;

/// A place on a road under the pointer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoadPick {
    /// The road's index in the level.
    pub road: usize,
    /// Arc position, metres (within the road).
    pub s_m: f64,
    /// The lane there (0 is the rightmost).
    pub lane: u32,
    /// The road's length, metres.
    pub length_m: f64,
}

/// Where a spawner's pad is drawn: on its lane's centre line.
pub fn spawner_spot(road: &RoadGeometry, lane: u32, s_m: f64) -> Vec3 {
    let f = road.frame_at(s_m);
    f.offset(lane_offset(f.width_m, road.lanes(), lane))
        .as_vec3()
}

/// A clicked position to the millimetre: finer means nothing for a click, and the file stays
/// readable.
fn to_mm(p: DVec3) -> DVec3 {
    (p * 1000.0).round() / 1000.0
}

/// Distance from `p` to the segment `a`–`b`, pixels.
fn distance_to_segment(p: Vec2, a: Vec2, b: Vec2) -> f32 {
    let ab = b - a;
    let t = if ab.length_squared() > 0.0 {
        ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0)
    } else {
        0.0
    };
    p.distance(a + t * ab)
}

/// The first letter in upper case, for status lines made from labels.
fn capitalise(text: &str) -> String {
    let mut chars = text.chars();
    match chars.next() {
        Some(c) => c.to_uppercase().chain(chars).collect(),
        None => String::new(),
    }
}

/// The whole application, without a window.
pub struct AppState {
    /// The level being edited.
    pub editor: Editor,
    /// The level being played, if play mode is on.
    pub play: Option<PlaySession>,
    /// The camera.
    pub camera: Camera,
    /// The tool of the scene's left button.
    pub tool: Tool,
    /// What is selected.
    pub selection: Selection,
    /// The last message for the status bar.
    pub status: String,
    /// The `assets/` directory levels' vehicle and driver files are under.
    pub assets: PathBuf,
    /// Levels the number keys load (1 is the first).
    pub shipped: Vec<PathBuf>,
    /// An action waiting for "discard unsaved changes?".
    pub pending: Option<Pending>,
    /// An autosave offered back after a crash.
    pub recovered: Option<Editor>,
    /// Whether the camera follows the selected vehicle.
    pub follow: bool,
    /// The path typed in the file field.
    pub file_field: String,
    /// Set when the app should close.
    pub quit: bool,
    /// Which page the side panel shows while editing.
    pub side_tab: SideTab,
    network: RoadNetwork,
    scene_version: u64,
    /// The drag in progress (tools).
    pointer: tools::Pointer,
    edited_level: Option<Level>,
    /// What the panels read from disk, cached (files).
    disk: files::DiskCache,
    /// Where the scene is drawn and the last fit (view).
    framing: view::Framing,
}

/// The pages of the side panel while editing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SideTab {
    /// Whatever is selected.
    #[default]
    Inspector,
    /// The level's settings, vehicle types, driver profiles, start vehicles and expectations.
    Level,
}

impl AppState {
    /// An app editing `editor`'s level, with assets under `assets`.
    pub fn new(editor: Editor, assets: PathBuf) -> AppState {
        let file_field = editor
            .path()
            .map_or_else(|| "level.ron".to_owned(), |p| p.display().to_string());
        let mut app = AppState {
            editor,
            play: None,
            camera: Camera::top_fit(Vec3::splat(-100.0), Vec3::splat(100.0), 16.0 / 9.0),
            tool: Tool::Select,
            selection: Selection::None,
            status: String::new(),
            assets,
            shipped: Vec::new(),
            pending: None,
            recovered: None,
            follow: false,
            file_field,
            quit: false,
            side_tab: SideTab::Inspector,
            network: RoadNetwork::default(),
            scene_version: 0,
            pointer: tools::Pointer::default(),
            edited_level: None,
            disk: files::DiskCache::default(),
            framing: view::Framing::default(),
        };
        app.rebuild_network();
        app.fit_view(16.0 / 9.0);
        app
    }

    /// The roads as drawn: every road that forms a road on its own (a road of one point does
    /// not yet), connections kept where both ends exist.
    pub(super) fn rebuild_network(&mut self) {
        self.network = level_network(self.editor.level());
        self.scene_version += 1;
    }

    /// After the editor was replaced by a recovered autosave: redraw and reframe.
    pub fn apply_recovered(&mut self) {
        self.selection = Selection::None;
        self.rebuild_network();
        self.fit_view(16.0 / 9.0);
        self.status = "recovered the autosave (not saved yet)".to_owned();
    }

    /// Bumped whenever the static scene must be rebuilt.
    pub fn scene_version(&self) -> u64 {
        self.scene_version
    }

    /// The roads being shown (the edited level's, or the played level's).
    pub fn network(&self) -> &RoadNetwork {
        match &self.play {
            Some(p) => p.runner().sim().world().resource::<RoadNetwork>(),
            None => &self.network,
        }
    }

    pub(super) fn edit(&mut self, command: Command, drag: bool) -> bool {
        if let Command::AddDriverProfile(p) | Command::SetDriverProfile(_, p) = &command
            && let Some(problem) = self.profile_problem(p)
        {
            self.status = problem;
            return false;
        }
        let result = if drag {
            self.editor.drag(command)
        } else {
            self.editor.apply(command)
        };
        match result {
            Ok(()) => {
                self.rebuild_network();
                true
            }
            Err(e) => {
                self.status = e.to_string();
                false
            }
        }
    }

    /// Applies an edit made by dragging or typing a value in a panel: the edits of one drag
    /// merge into one undo step until [`AppState::end_live_edit`].
    pub fn edit_live(&mut self, command: Command) -> bool {
        self.edit(command, true)
    }

    /// The mouse button is up: a value dragged in a panel is done (a drag in the scene ends on
    /// its own release).
    pub fn end_live_edit(&mut self) {
        if self.pointer.drag.is_none() {
            self.editor.end_drag();
        }
    }

    /// Applies an inspector edit.
    pub fn apply(&mut self, command: Command) -> bool {
        self.edit(command, false)
    }

    /// Undo (Ctrl+Z).
    pub fn undo(&mut self) {
        if self.play.is_none() && self.editor.undo() {
            self.after_history();
        }
    }

    /// Redo (Ctrl+Shift+Z).
    pub fn redo(&mut self) {
        if self.play.is_none() && self.editor.redo() {
            self.after_history();
        }
    }

    pub(super) fn after_history(&mut self) {
        self.selection = Selection::None;
        self.pointer.drag = None;
        self.rebuild_network();
    }
}
