//! The application state behind the window: the editor, play mode, camera, tools and selection,
//! with every user action as a method, so tests drive it without a window.

use crate::camera::Camera;
use crate::editor::{Command, EditError, Editor, MarkerKind};
use crate::play::{FRAME_BUDGET, PlaySession};
use crate::scene::{StaticScene, Vertex, box_faces};
use flockway_level::{
    Destroyer, DestroyerPlace, Level, ProfileShare, Range, Spawner, Trigger, TriggerEffect,
};
use flockway_road::{RoadGeometry, RoadNetwork, RoadSpec};
use glam::{DVec3, Vec2, Vec3};
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

/// Pixels within which a click takes a control point.
pub const PICK_PX: f32 = 12.0;

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
    network: RoadNetwork,
    scene_version: u64,
    drag: Option<Drag>,
    edited_level: Option<Level>,
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
            network: RoadNetwork::default(),
            scene_version: 0,
            drag: None,
            edited_level: None,
        };
        app.rebuild_network();
        app.fit_view(16.0 / 9.0);
        app
    }

    /// The roads as drawn: every road that forms a road on its own (a road of one point does
    /// not yet), connections kept where both ends exist.
    fn rebuild_network(&mut self) {
        let level = self.editor.level();
        let ok: Vec<RoadSpec> = level
            .roads
            .iter()
            .filter(|r| {
                let mut alone = (*r).clone();
                alone.next = None;
                RoadGeometry::new(&alone).is_ok()
            })
            .cloned()
            .collect();
        self.network = RoadNetwork::build(&ok).unwrap_or_else(|_| {
            let alone: Vec<RoadSpec> = ok
                .into_iter()
                .map(|mut r| {
                    r.next = None;
                    r
                })
                .collect();
            RoadNetwork::build(&alone).unwrap_or_default()
        });
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

    /// The static scene to draw: roads and markers, and in edit mode the control points.
    pub fn static_scene(&self) -> StaticScene {
        let level = match &self.play {
            Some(p) => p.runner().level(),
            None => self.editor.level(),
        };
        let mut scene = StaticScene::build(self.network(), level);
        if self.play.is_none() {
            add_handles(&mut scene, level, self.selection);
        }
        scene
    }

    /// Frames the whole level.
    pub fn fit_view(&mut self, aspect: f32) {
        let s = self.static_scene();
        self.camera = match self.camera {
            Camera::Top { .. } => Camera::top_fit(s.min, s.max, aspect),
            Camera::Orbit { .. } => Camera::orbit_fit(s.min, s.max),
        };
    }

    /// Switches between the top and the orbit view.
    pub fn toggle_camera(&mut self, aspect: f32) {
        let s = self.static_scene();
        self.camera = match self.camera {
            Camera::Top { .. } => Camera::orbit_fit(s.min, s.max),
            Camera::Orbit { .. } => Camera::top_fit(s.min, s.max, aspect),
        };
    }

    fn edit(&mut self, command: Command, drag: bool) -> bool {
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

    /// The control point nearest a pixel, within [`PICK_PX`].
    pub fn pick_point(&self, px: Vec2, size: Vec2) -> Option<(usize, usize)> {
        let mut best = None;
        for (r, road) in self.editor.level().roads.iter().enumerate() {
            for (i, p) in road.points.iter().enumerate() {
                if let Some(s) = self.camera.to_screen(p.pos.as_vec3(), size) {
                    let d = s.distance(px);
                    if d <= PICK_PX && best.is_none_or(|(bd, _)| d < bd) {
                        best = Some((d, (r, i)));
                    }
                }
            }
        }
        best.map(|(_, hit)| hit)
    }

    /// Where a marker is drawn (on its road) and the road's name.
    fn marker_anchor(&self, kind: MarkerKind, index: usize) -> Option<(Vec3, String)> {
        let level = self.editor.level();
        let (road, s_m, side) = match kind {
            MarkerKind::Spawner => {
                let sp = level.spawners.get(index)?;
                (sp.road.clone(), sp.s_m, true)
            }
            MarkerKind::Destroyer => match &level.destroyers.get(index)?.place {
                DestroyerPlace::OnRoad { road, s_m } => (road.clone(), *s_m, false),
                DestroyerPlace::Volume { .. } => return None,
            },
            MarkerKind::Trigger => {
                let t = level.triggers.get(index)?;
                (t.road.clone(), t.from_m, false)
            }
        };
        let g = self.network.get(self.network.id(&road)?)?;
        let f = g.frame_at(s_m);
        let lateral = if side { -0.5 * f.width_m - 1.2 } else { 0.0 };
        Some((f.offset(lateral).as_vec3(), road))
    }

    /// The marker nearest a pixel, within twice [`PICK_PX`].
    pub fn pick_marker(&self, px: Vec2, size: Vec2) -> Option<(MarkerKind, usize)> {
        let level = self.editor.level();
        let all = (0..level.spawners.len())
            .map(|i| (MarkerKind::Spawner, i))
            .chain((0..level.destroyers.len()).map(|i| (MarkerKind::Destroyer, i)))
            .chain((0..level.triggers.len()).map(|i| (MarkerKind::Trigger, i)));
        let mut best = None;
        for (kind, i) in all {
            let Some((at, _)) = self.marker_anchor(kind, i) else {
                continue;
            };
            if let Some(s) = self.camera.to_screen(at, size) {
                let d = s.distance(px);
                if d <= 2.0 * PICK_PX && best.is_none_or(|(bd, _)| d < bd) {
                    best = Some((d, (kind, i)));
                }
            }
        }
        best.map(|(_, hit)| hit)
    }

    /// The road under a pixel and the arc position there.
    pub fn pick_road(&self, px: Vec2, size: Vec2) -> Option<(usize, f64)> {
        let g = self.camera.ground_point(px, size, 0.0)?.as_dvec3();
        let level = self.editor.level();
        let mut best: Option<(f64, usize, f64)> = None;
        for (id, geom) in self.network.iter() {
            let proj = geom.project(g);
            let half = 0.5 * geom.frame_at(proj.s_m).width_m + 1.0;
            if proj.lateral_m.abs() <= half {
                let index = level.roads.iter().position(|r| r.name == geom.name());
                if let Some(index) = index
                    && best.is_none_or(|(d, _, _)| proj.lateral_m.abs() < d)
                {
                    best = Some((proj.lateral_m.abs(), index, proj.s_m));
                }
                let _ = id;
            }
        }
        best.map(|(_, r, s)| (r, s))
    }

    /// The left button went down in the scene at `px`.
    pub fn press(&mut self, px: Vec2, size: Vec2) {
        if self.play.is_some() {
            self.select_vehicle(px, size);
            return;
        }
        if let Some((r, i)) = self.pick_point(px, size) {
            self.selection = Selection::Point(r, i);
            self.drag = Some(Drag::Point(r, i));
            return;
        }
        if let Some((kind, i)) = self.pick_marker(px, size) {
            self.selection = Selection::Marker(kind, i);
            self.drag = Some(Drag::Marker(kind, i));
            return;
        }
        let ground = self
            .camera
            .ground_point(px, size, 0.0)
            .map(|g| DVec3::new(f64::from(g.x), f64::from(g.y), 0.0));
        match self.tool {
            Tool::Select => {
                self.selection = match self.pick_road(px, size) {
                    Some((r, _)) => Selection::Road(r),
                    None => Selection::None,
                }
            }
            Tool::Road => {
                let Some(at) = ground else { return };
                let road = match self.selection {
                    Selection::Road(r) | Selection::Point(r, _) => Some(r),
                    _ => None,
                };
                match road {
                    Some(r) => {
                        if self.edit(Command::AppendPoint { road: r, at }, false) {
                            let n = self
                                .editor
                                .level()
                                .roads
                                .get(r)
                                .map_or(1, |d| d.points.len());
                            self.selection = Selection::Point(r, n.saturating_sub(1));
                        }
                    }
                    None => {
                        if self.edit(Command::AddRoad { at }, false) {
                            let r = self.editor.level().roads.len() - 1;
                            self.selection = Selection::Point(r, 0);
                        }
                    }
                }
            }
            Tool::Spawner | Tool::Destroyer | Tool::Trigger => {
                let Some((r, s)) = self.pick_road(px, size) else {
                    self.status = "click on a road to place it".to_owned();
                    return;
                };
                self.place_marker(r, s);
            }
        }
    }

    fn place_marker(&mut self, road: usize, s_m: f64) {
        let level = self.editor.level();
        let Some(spec) = level.roads.get(road) else {
            return;
        };
        let (name, limit) = (spec.name.clone(), spec.speed_limit_kmh);
        let unique = |prefix: &str, taken: &dyn Fn(&str) -> bool| {
            (1..)
                .map(|n| format!("{prefix} {n}"))
                .find(|n| !taken(n))
                .unwrap_or_default()
        };
        let (command, kind, index) = match self.tool {
            Tool::Spawner => {
                let profile = level
                    .driver_profiles
                    .first()
                    .map(|p| p.name.clone())
                    .unwrap_or_else(|| "autonomous".to_owned());
                let n = unique("spawner", &|n| level.spawners.iter().any(|s| s.name == n));
                (
                    Command::AddSpawner(Spawner {
                        name: n,
                        road: name,
                        lane: 0,
                        s_m,
                        interval_s: Range { min: 1.0, max: 2.0 },
                        profiles: vec![ProfileShare {
                            profile,
                            weight: 1.0,
                        }],
                        speed_kmh: None,
                        active: true,
                        max_vehicles: None,
                    }),
                    MarkerKind::Spawner,
                    level.spawners.len(),
                )
            }
            Tool::Destroyer => {
                let n = unique("destroyer", &|n| {
                    level.destroyers.iter().any(|d| d.name == n)
                });
                (
                    Command::AddDestroyer(Destroyer {
                        name: n,
                        place: DestroyerPlace::OnRoad { road: name, s_m },
                    }),
                    MarkerKind::Destroyer,
                    level.destroyers.len(),
                )
            }
            _ => {
                let n = unique("trigger", &|n| level.triggers.iter().any(|t| t.name == n));
                (
                    Command::AddTrigger(Trigger {
                        name: n,
                        road: name,
                        from_m: s_m,
                        to_m: s_m + 20.0,
                        lanes: None,
                        effect: TriggerEffect::SpeedLimit {
                            kmh: (limit + 20.0).min(300.0),
                        },
                    }),
                    MarkerKind::Trigger,
                    level.triggers.len(),
                )
            }
        };
        if self.edit(command, false) {
            self.selection = Selection::Marker(kind, index);
        }
    }

    /// The pointer moved to `px` with the left button down.
    pub fn drag_to(&mut self, px: Vec2, size: Vec2) {
        match self.drag {
            Some(Drag::Point(r, i)) => {
                // The point may have gone (deleted mid-drag): then the drag ends.
                let Some(point) = self
                    .editor
                    .level()
                    .roads
                    .get(r)
                    .and_then(|d| d.points.get(i))
                else {
                    self.drag = None;
                    return;
                };
                let z = point.pos.z as f32;
                if let Some(g) = self.camera.ground_point(px, size, z) {
                    let to = DVec3::new(f64::from(g.x), f64::from(g.y), f64::from(z));
                    self.edit(
                        Command::MovePoint {
                            road: r,
                            index: i,
                            to,
                        },
                        true,
                    );
                }
            }
            Some(Drag::Marker(kind, index)) => {
                // Along its own road: the arc position nearest the pointer.
                let Some((_, road)) = self.marker_anchor(kind, index) else {
                    return;
                };
                let Some(g) = self.network.id(&road).and_then(|id| self.network.get(id)) else {
                    return;
                };
                if let Some(at) = self.camera.ground_point(px, size, 0.0) {
                    let s_m = g.project(at.as_dvec3()).s_m;
                    self.edit(Command::MoveMarker { kind, index, s_m }, true);
                }
            }
            None => {}
        }
    }

    /// The left button went up.
    pub fn release(&mut self) {
        self.drag = None;
        self.editor.end_drag();
    }

    /// Deletes what is selected.
    pub fn delete_selected(&mut self) {
        let command = match self.selection {
            Selection::Point(road, index) => Command::DeletePoint { road, index },
            Selection::Road(road) => Command::DeleteRoad { road },
            Selection::Marker(kind, index) => Command::DeleteMarker { kind, index },
            _ => return,
        };
        if self.edit(command, false) {
            self.selection = Selection::None;
        }
    }

    /// Inserts a point halfway between the selected point and the next one.
    pub fn insert_after_selected(&mut self) {
        let Selection::Point(r, i) = self.selection else {
            return;
        };
        let Some(road) = self.editor.level().roads.get(r) else {
            return;
        };
        if i >= road.points.len() {
            return;
        }
        let Some(next) = road.points.get(i + 1).or(if road.closed {
            road.points.first()
        } else {
            None
        }) else {
            self.status = "select a point that has a next point".to_owned();
            return;
        };
        let at = 0.5 * (road.points[i].pos + next.pos);
        if self.edit(
            Command::InsertPoint {
                road: r,
                index: i + 1,
                at,
            },
            false,
        ) {
            self.selection = Selection::Point(r, i + 1);
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

    fn after_history(&mut self) {
        self.selection = Selection::None;
        self.drag = None;
        self.rebuild_network();
    }

    /// Save (Ctrl+S): to the level's file, or to the file field's path.
    pub fn save(&mut self) -> Result<PathBuf, EditError> {
        let result = match self.editor.path() {
            Some(_) => self.editor.save(),
            None => {
                let path = PathBuf::from(self.file_field.trim());
                self.editor.save_as(&path)
            }
        };
        self.status = match &result {
            Ok(p) => format!("saved {}", p.display()),
            Err(e) => e.to_string(),
        };
        result
    }

    /// Save As: to the file field's path.
    pub fn save_as(&mut self) -> Result<PathBuf, EditError> {
        let path = PathBuf::from(self.file_field.trim());
        let result = self.editor.save_as(&path);
        self.status = match &result {
            Ok(p) => format!("saved {}", p.display()),
            Err(e) => e.to_string(),
        };
        result
    }

    /// Asks for `action`; it happens at once if nothing unsaved would be lost, else it waits
    /// for [`AppState::confirm`].
    pub fn request(&mut self, action: Pending) {
        if self.editor.is_dirty() && !self.editor.level().roads.is_empty() {
            self.pending = Some(action);
        } else {
            self.do_action(action);
        }
    }

    /// Answers the pending "discard unsaved changes?" question.
    pub fn confirm(&mut self, discard: bool) {
        if let Some(action) = self.pending.take()
            && discard
        {
            self.do_action(action);
        }
    }

    fn do_action(&mut self, action: Pending) {
        self.stop();
        match action {
            Pending::New => self.load(Editor::new()),
            Pending::Open(path) => match Editor::open(&path) {
                Ok(e) => {
                    self.load(e);
                    self.status = format!("opened {}", path.display());
                }
                Err(e) => self.status = e.to_string(),
            },
            Pending::Quit => self.quit = true,
        }
    }

    fn load(&mut self, editor: Editor) {
        self.file_field = editor
            .path()
            .map_or_else(|| "level.ron".to_owned(), |p| p.display().to_string());
        self.editor = editor;
        self.selection = Selection::None;
        self.rebuild_network();
        self.fit_view(16.0 / 9.0);
    }

    /// Play: starts the level as edited (or resumes).
    pub fn play(&mut self) {
        if let Some(p) = &mut self.play {
            p.paused = false;
            return;
        }
        let level = self.editor.level().clone();
        let name = level.name.clone();
        let csv = std::env::temp_dir().join(format!("flockway-play-{}.csv", std::process::id()));
        match PlaySession::start(level.clone(), &name, &self.assets, &csv) {
            Ok(session) => {
                self.edited_level = Some(level);
                self.play = Some(session);
                self.selection = Selection::None;
                self.status = "playing".to_owned();
            }
            Err(e) => self.status = e.to_string(),
        }
    }

    /// Pause or resume (Space).
    pub fn toggle_pause(&mut self) {
        if let Some(p) = &mut self.play {
            p.paused = !p.paused;
        }
    }

    /// One fixed step while paused.
    pub fn single_step(&mut self) {
        if let Some(p) = &mut self.play {
            p.paused = true;
            if let Err(e) = p.step_ticks(1) {
                self.status = e.to_string();
            }
        }
    }

    /// Stop: back to the level exactly as edited.
    pub fn stop(&mut self) {
        if self.play.take().is_some() {
            // The editor never saw the run; the check guards against a future change that would.
            debug_assert!(self.edited_level.as_ref() == Some(self.editor.level()));
            self.edited_level = None;
            self.follow = false;
            self.selection = Selection::None;
            self.rebuild_network();
            self.status = "stopped".to_owned();
        }
    }

    /// Writes the run's telemetry CSV to `path`.
    pub fn export(&mut self, path: &Path) {
        self.status = match &self.play {
            Some(p) => match p.export_csv(path) {
                Ok(_) => format!("exported {}", path.display()),
                Err(e) => format!("{}: {e}", path.display()),
            },
            None => "nothing is playing".to_owned(),
        };
    }

    /// Esc: ends the run and exports its CSV next to the level (as in the thesis).
    pub fn end_run(&mut self) {
        if self.play.is_none() {
            self.selection = Selection::None;
            return;
        }
        let stem = self.editor.path().and_then(|p| p.file_stem()).map_or_else(
            || "untitled".to_owned(),
            |s| s.to_string_lossy().into_owned(),
        );
        let dir = self
            .editor
            .path()
            .and_then(Path::parent)
            .map_or_else(|| PathBuf::from("."), Path::to_owned);
        let out = dir.join(format!("{stem}_run.csv"));
        self.export(&out);
        let status = self.status.clone();
        self.stop();
        self.status = status;
    }

    /// Advances play by a frame of `wall_s` seconds.
    pub fn frame(&mut self, wall_s: f64) {
        if let Some(p) = &mut self.play
            && let Err(e) = p.advance(wall_s, FRAME_BUDGET)
        {
            self.status = e.to_string();
            self.play = None;
        }
        if self.follow
            && let (Some(p), Selection::Vehicle(i)) = (&self.play, self.selection)
            && let Some(v) = p.next.instances.get(i)
        {
            self.camera.look_at(Vec3::from_array(v.translation));
        }
    }

    fn select_vehicle(&mut self, px: Vec2, size: Vec2) {
        let Some(p) = &self.play else { return };
        let mut best: Option<(f32, usize)> = None;
        for (i, v) in p.next.instances.iter().enumerate() {
            if let Some(s) = self.camera.to_screen(Vec3::from_array(v.translation), size) {
                let d = s.distance(px);
                if d < 20.0 && best.is_none_or(|(bd, _)| d < bd) {
                    best = Some((d, i));
                }
            }
        }
        self.selection = best.map_or(Selection::None, |(_, i)| Selection::Vehicle(i));
    }

    /// Number key `n` (1-based): loads the n-th shipped level.
    pub fn load_shipped(&mut self, n: usize) {
        if let Some(path) = self.shipped.get(n.wrapping_sub(1)).cloned() {
            self.request(Pending::Open(path));
        }
    }

    /// The window title: file name and the unsaved-changes marker.
    pub fn title(&self) -> String {
        let name = self.editor.path().and_then(|p| p.file_name()).map_or_else(
            || "untitled".to_owned(),
            |n| n.to_string_lossy().into_owned(),
        );
        let dirty = if self.editor.is_dirty() { "● " } else { "" };
        let mode = if self.play.is_some() {
            " — playing"
        } else {
            ""
        };
        format!("{dirty}{name}{mode} — Flockway")
    }
}

/// Control points as small posts: yellow, the selected one white.
fn add_handles(scene: &mut StaticScene, level: &Level, selection: Selection) {
    for (r, road) in level.roads.iter().enumerate() {
        for (i, p) in road.points.iter().enumerate() {
            let selected = selection == Selection::Point(r, i);
            let colour = if selected {
                [1.0, 1.0, 1.0, 1.0]
            } else {
                [1.0, 0.75, 0.0, 1.0]
            };
            let size = Vec3::new(1.6, 1.6, 1.2);
            let centre = p.pos.as_vec3() + Vec3::Z * 0.6;
            for (corners, normal) in box_faces(size) {
                let base = scene.vertices.len() as u32;
                for c in corners {
                    scene.vertices.push(Vertex {
                        position: (centre + c).to_array(),
                        normal: normal.to_array(),
                        colour,
                    });
                }
                // Opaque: before the translucent triggers.
                let at = scene.translucent_from as usize;
                scene
                    .indices
                    .splice(at..at, [base, base + 1, base + 2, base, base + 2, base + 3]);
                scene.translucent_from += 6;
            }
            scene.min = scene.min.min(p.pos.as_vec3());
            scene.max = scene.max.max(p.pos.as_vec3());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn app_on(level: &str) -> AppState {
        let editor = Editor::open(Path::new(level)).expect("shipped level");
        AppState::new(editor, PathBuf::from("../../assets"))
    }

    #[test]
    fn a_marker_dragged_along_its_road_moves_in_one_undo_step() {
        let mut app = app_on("../../levels/speed_limit_change.ron");
        let size = Vec2::new(1600.0, 900.0);
        app.fit_view(size.x / size.y);
        let before = app.editor.level().triggers[0].clone();
        let (anchor, road) = app
            .marker_anchor(MarkerKind::Trigger, 0)
            .expect("on its road");
        // Close up: zoomed out, the control point beside it would take the click first.
        app.camera = Camera::Top {
            centre: anchor,
            half_height_m: 80.0,
        };
        let px = app.camera.to_screen(anchor, size).expect("on screen");
        app.press(px, size);
        assert_eq!(app.selection, Selection::Marker(MarkerKind::Trigger, 0));
        // Drag it 100 m further along the road, in small moves.
        let g = app
            .network
            .get(app.network.id(&road).expect("road"))
            .expect("geometry")
            .clone();
        for k in 1..=10 {
            let to = g
                .frame_at(before.from_m + 10.0 * f64::from(k))
                .pos
                .as_vec3();
            let to_px = app.camera.to_screen(to, size).expect("on screen");
            app.drag_to(to_px, size);
        }
        app.release();
        let after = &app.editor.level().triggers[0];
        assert!(
            (after.from_m - (before.from_m + 100.0)).abs() < 2.0,
            "moved to {} from {}",
            after.from_m,
            before.from_m
        );
        assert!(((after.to_m - after.from_m) - (before.to_m - before.from_m)).abs() < 1e-9);
        app.undo();
        assert_eq!(app.editor.level().triggers[0], before, "one undo step");
    }

    #[test]
    fn stop_restores_the_level_as_edited_and_play_never_touches_it() {
        let mut app = app_on("../../levels/sugiyama_ring.ron");
        let edited = app.editor.level().clone();
        app.play();
        let session = app.play.as_mut().expect("playing");
        session.step_ticks(240).expect("steps");
        assert!(session.sim_s() >= 2.0);
        app.stop();
        assert!(app.play.is_none());
        assert_eq!(app.editor.level(), &edited);
        assert!(!app.editor.is_dirty());
    }
}
