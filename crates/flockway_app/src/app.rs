//! The application state behind the window: the editor, play mode, camera, tools and selection,
//! with every user action as a method, so tests drive it without a window.

use crate::camera::Camera;
use crate::play::{FRAME_BUDGET, PlaySession};
use crate::scene::{StaticScene, Vertex, box_faces};
use flockway_edit::{
    Command, EditError, Editor, MarkerKind, PrefabKind, level_network, place_marker, place_prefab,
    playable,
};
use flockway_level::{DestroyerPlaceSpec, DriverProfileSpec, Level, validate};
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
    drag: Option<Drag>,
    /// Where the pointer last was while dragging, and the window's size, pixels.
    drag_px: Option<(Vec2, Vec2)>,
    edited_level: Option<Level>,
    asset_listing: BTreeMap<String, Vec<String>>,
    profile_checks: BTreeMap<String, Option<String>>,
    /// The window's size and the part of it the panels leave to the scene, pixels.
    view_area: Option<(Vec2, Vec2, Vec2)>,
    /// The camera the last fit chose, while the user has not moved it: a change of the
    /// scene's area (the first frame, a resize, a panel) fits the view again.
    fitted: Option<Camera>,
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
            drag: None,
            drag_px: None,
            edited_level: None,
            asset_listing: BTreeMap::new(),
            profile_checks: BTreeMap::new(),
            view_area: None,
            fitted: None,
        };
        app.rebuild_network();
        app.fit_view(16.0 / 9.0);
        app
    }

    /// The roads as drawn: every road that forms a road on its own (a road of one point does
    /// not yet), connections kept where both ends exist.
    fn rebuild_network(&mut self) {
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

    /// The static scene to draw: roads and markers, and in edit mode the control points.
    pub fn static_scene(&self) -> StaticScene {
        let level = match &self.play {
            Some(p) => p.runner().level(),
            None => self.editor.level(),
        };
        let mut scene = StaticScene::build(self.network(), level);
        scene.add_grid();
        if self.play.is_none() {
            scene.add_links(self.network());
            add_handles(&mut scene, level, self.selection);
        }
        scene
    }

    /// Frames the whole level: in the part of the window the panels leave free, once the
    /// window has said where that is ([`AppState::set_view_area`]).
    pub fn fit_view(&mut self, aspect: f32) {
        let s = self.static_scene();
        self.camera = match (self.camera, self.view_area) {
            (Camera::Top { .. }, Some((viewport, lo, hi))) => {
                Camera::top_fit_area(s.min, s.max, viewport, lo, hi)
            }
            (Camera::Top { .. }, None) => Camera::top_fit(s.min, s.max, aspect),
            (Camera::Orbit { .. }, _) => Camera::orbit_fit(s.min, s.max),
        };
        self.fitted = Some(self.camera);
    }

    /// Where the scene is drawn: the window's size and the part of it no panel covers, pixels.
    /// When it changes, a fitted view the user has not moved since is fitted again.
    pub fn set_view_area(&mut self, viewport: Vec2, area_min: Vec2, area_max: Vec2) {
        let area = Some((viewport, area_min, area_max));
        if area == self.view_area {
            return;
        }
        self.view_area = area;
        if self.fitted == Some(self.camera) {
            self.fit_view(viewport.x / viewport.y.max(1.0));
        }
    }

    /// The window's size and the part of it the panels leave to the scene, pixels, once a frame
    /// has been drawn.
    pub fn view_area(&self) -> Option<(Vec2, Vec2, Vec2)> {
        self.view_area
    }

    /// Switches between the top and the orbit view.
    pub fn toggle_camera(&mut self, aspect: f32) {
        let s = self.static_scene();
        self.camera = match (self.camera, self.view_area) {
            (Camera::Top { .. }, _) => Camera::orbit_fit(s.min, s.max),
            (Camera::Orbit { .. }, Some((viewport, lo, hi))) => {
                Camera::top_fit_area(s.min, s.max, viewport, lo, hi)
            }
            (Camera::Orbit { .. }, None) => Camera::top_fit(s.min, s.max, aspect),
        };
    }

    fn edit(&mut self, command: Command, drag: bool) -> bool {
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
        if self.drag.is_none() {
            self.editor.end_drag();
        }
    }

    /// Chooses the scene's tool.
    pub fn set_tool(&mut self, tool: Tool) {
        if self.tool == tool {
            return;
        }
        self.tool = tool;
        self.status = match tool {
            Tool::Select => "Select: click to select, drag points and markers to move them.",
            Tool::Road => "Road: click on the ground to add points, Enter to finish the road.",
            Tool::Spawner => "Spawner: click on a lane to place a spawner.",
            Tool::Destroyer => "Destroyer: click on a road where vehicles should leave.",
            Tool::Trigger => "Trigger: click on a road to place a speed-limit stretch.",
            Tool::Roundabout => {
                "Roundabout: click on the ground to place a four-arm roundabout centred there."
            }
            Tool::Crossroads => {
                "Crossroads: click on the ground to place a four-arm signalised crossroads there."
            }
        }
        .to_owned();
    }

    /// Why a driver profile cannot drive, if it cannot: its parameter file or an override is
    /// wrong. Profiles of plugin models are left to their plugin.
    pub fn profile_problem(&mut self, profile: &DriverProfileSpec) -> Option<String> {
        let key = format!("{profile:?}");
        if let Some(known) = self.profile_checks.get(&key) {
            return known.clone();
        }
        let mut one = Level::new(1, 1.0);
        one.driver_profiles = vec![profile.clone()];
        let problem = load_driver_profiles(&one, "level", &self.assets)
            .err()
            .map(|e| match e {
                RunError::Driver { name, message, .. } => {
                    format!("driver profile `{name}`: {message}")
                }
                other => other.to_string(),
            });
        if self.profile_checks.len() > 256 {
            self.profile_checks.clear();
        }
        self.profile_checks.insert(key, problem.clone());
        problem
    }

    /// The `.ron` files under `assets/SUB/`, as level paths (`SUB/NAME.ron`), sorted.
    pub fn asset_files(&mut self, sub: &str) -> Vec<String> {
        let assets = self.assets.clone();
        self.asset_listing
            .entry(sub.to_owned())
            .or_insert_with(|| {
                let mut files: Vec<String> = std::fs::read_dir(assets.join(sub))
                    .into_iter()
                    .flatten()
                    .filter_map(|e| e.ok())
                    .filter_map(|e| {
                        let name = e.file_name().to_string_lossy().into_owned();
                        name.ends_with(".ron").then(|| format!("{sub}/{name}"))
                    })
                    .collect();
                files.sort();
                files
            })
            .clone()
    }

    /// The length of the road with this name as drawn, if it forms a road.
    pub fn road_length_m(&self, name: &str) -> Option<f64> {
        self.network
            .id(name)
            .and_then(|id| self.network.get(id))
            .map(|g| g.length_m())
    }

    /// The junction with this name as built from the level as drawn (its paths, how each
    /// turns), if it can be built.
    pub fn built_junction(&self, name: &str) -> Option<&flockway_road::Junction> {
        self.network
            .junctions()
            .iter()
            .find(|j| j.spec.name == name)
    }

    /// The selected junction's paths as drawn, in connection order: each as points along its
    /// centre line (every 2 m), to outline them and number them in the scene.
    pub fn selected_junction_paths(&self) -> Vec<Vec<Vec3>> {
        let Selection::Junction(i) = self.selection else {
            return Vec::new();
        };
        let Some(spec) = self.editor.level().junctions.get(i) else {
            return Vec::new();
        };
        let Some(j) = self.built_junction(&spec.name) else {
            return Vec::new();
        };
        j.paths
            .iter()
            .filter_map(|p| {
                self.network
                    .id(&p.spec.name)
                    .and_then(|id| self.network.get(id))
            })
            .map(|g| {
                let n = (g.length_m() / 2.0).ceil().max(1.0) as usize;
                (0..=n)
                    .map(|k| {
                        let s = g.length_m() * k as f64 / n as f64;
                        (g.frame_at(s).pos + DVec3::Z * 0.05).as_vec3()
                    })
                    .collect()
            })
            .collect()
    }

    /// Why road `r` does not form a road as drawn, if it does not.
    pub fn road_problem(&self, r: usize) -> Option<String> {
        let mut spec = self.editor.level().roads.get(r)?.clone();
        spec.next = None;
        RoadGeometry::new(&spec).err().map(|e| e.to_string())
    }

    /// Where a marker stands in the world.
    pub fn marker_position(&self, kind: MarkerKind, index: usize) -> Option<DVec3> {
        self.marker_anchor(kind, index).map(|(p, _)| p.as_dvec3())
    }

    /// Metres on the ground per pixel at the middle of the view.
    pub fn metres_per_pixel(&self, size: Vec2) -> Option<f32> {
        let mid = 0.5 * size;
        let a = self.camera.ground_point(mid, size, 0.0)?;
        let b = self
            .camera
            .ground_point(mid + Vec2::new(100.0, 0.0), size, 0.0)?;
        let m = a.distance(b) / 100.0;
        (m.is_finite() && m > 0.0).then_some(m)
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

    /// Where a marker is drawn (a spawner on its lane, a destroyer and a trigger's start on the
    /// centre line) and the road's name.
    fn marker_anchor(&self, kind: MarkerKind, index: usize) -> Option<(Vec3, String)> {
        let level = self.editor.level();
        let (road, s_m, lane) = match kind {
            MarkerKind::Spawner => {
                let sp = level.spawners.get(index)?;
                (sp.road.clone(), sp.s_m, Some(sp.lane))
            }
            MarkerKind::Destroyer => match &level.destroyers.get(index)?.place {
                DestroyerPlaceSpec::OnRoad { road, s_m } => (road.clone(), *s_m, None),
                DestroyerPlaceSpec::Volume { .. } => return None,
            },
            MarkerKind::Trigger => {
                let t = level.triggers.get(index)?;
                (t.road.clone(), t.from_m, None)
            }
        };
        let g = self.network.get(self.network.id(&road)?)?;
        let at = match lane {
            Some(lane) => spawner_spot(g, lane, s_m),
            None => g.frame_at(s_m).pos.as_vec3(),
        };
        Some((at, road))
    }

    /// The marker under a pixel: a spawner within twice [`PICK_PX`] of its pad, a destroyer
    /// within [`PICK_PX`] of its gate across the road, or a trigger whose stretch is under the
    /// pointer (the nearest of these; a stretch counts only when nothing else is that near).
    pub fn pick_marker(&self, px: Vec2, size: Vec2) -> Option<(MarkerKind, usize)> {
        let level = self.editor.level();
        let road = |name: &str| self.network.id(name).and_then(|id| self.network.get(id));
        let screen = |p: Vec3| self.camera.to_screen(p, size);
        let mut best: Option<(f32, (MarkerKind, usize))> = None;
        let offer = |best: &mut Option<(f32, (MarkerKind, usize))>, d: f32, hit| {
            if best.is_none_or(|(bd, _)| d < bd) {
                *best = Some((d, hit));
            }
        };
        for i in 0..level.spawners.len() {
            if let Some((at, _)) = self.marker_anchor(MarkerKind::Spawner, i)
                && let Some(s) = screen(at)
                && s.distance(px) <= 2.0 * PICK_PX
            {
                offer(&mut best, s.distance(px), (MarkerKind::Spawner, i));
            }
        }
        for (i, d) in level.destroyers.iter().enumerate() {
            let DestroyerPlaceSpec::OnRoad { road: name, s_m } = &d.place else {
                continue;
            };
            let Some(g) = road(name) else { continue };
            let f = g.frame_at(*s_m);
            let half = 0.5 * f.width_m + 0.8;
            if let (Some(a), Some(b)) = (
                screen(f.offset(-half).as_vec3()),
                screen(f.offset(half).as_vec3()),
            ) {
                let d = distance_to_segment(px, a, b);
                if d <= PICK_PX {
                    offer(&mut best, d, (MarkerKind::Destroyer, i));
                }
            }
        }
        if best.is_none()
            && let Some(ground) = self.camera.ground_point(px, size, 0.0)
        {
            for (i, t) in level.triggers.iter().enumerate() {
                let Some(g) = road(&t.road) else { continue };
                let proj = g.project(ground.as_dvec3());
                let inside = if t.from_m <= t.to_m {
                    (t.from_m..=t.to_m).contains(&proj.s_m)
                } else {
                    proj.s_m >= t.from_m || proj.s_m <= t.to_m
                };
                if inside && proj.lateral_m.abs() <= 0.5 * g.frame_at(proj.s_m).width_m {
                    offer(&mut best, PICK_PX, (MarkerKind::Trigger, i));
                }
            }
        }
        best.map(|(_, hit)| hit)
    }

    /// The road under a pixel: which road (by its index in the level), the arc position and the
    /// lane there. Roads still being drawn (one point) are not roads yet.
    pub fn pick_road(&self, px: Vec2, size: Vec2) -> Option<RoadPick> {
        let g = self.camera.ground_point(px, size, 0.0)?.as_dvec3();
        let level = self.editor.level();
        let mut best: Option<(f64, RoadPick)> = None;
        for (_, geom) in self.network.iter() {
            let proj = geom.project(g);
            let half = 0.5 * geom.frame_at(proj.s_m).width_m + 1.0;
            let Some(road) = level.roads.iter().position(|r| r.name == geom.name()) else {
                continue;
            };
            // The distance to the centre line, not just across it: beyond an open road's end
            // the projection stops at the end, and a road carried on by another is not there.
            let d = proj.distance_m;
            if d <= half && best.as_ref().is_none_or(|(bd, _)| d < *bd) {
                let pick = RoadPick {
                    road,
                    // Centimetres: what a click can mean, and what reads well in the file.
                    s_m: ((proj.s_m * 100.0).round() / 100.0).clamp(0.0, geom.length_m()),
                    lane: proj.lane,
                    length_m: geom.length_m(),
                };
                best = Some((d, pick));
            }
        }
        best.map(|(_, p)| p)
    }

    /// The junction under a pixel, by its index in the level: the one with a path (as drawn)
    /// nearest the pointer, within the path's half width and a metre.
    pub fn pick_junction(&self, px: Vec2, size: Vec2) -> Option<usize> {
        let g = self.camera.ground_point(px, size, 0.0)?.as_dvec3();
        let mut best: Option<(f64, usize)> = None;
        for j in self.network.junctions() {
            let Some(index) = self
                .editor
                .level()
                .junctions
                .iter()
                .position(|s| s.name == j.spec.name)
            else {
                continue;
            };
            for path in &j.paths {
                let Some(geom) = self
                    .network
                    .id(&path.spec.name)
                    .and_then(|id| self.network.get(id))
                else {
                    continue;
                };
                let proj = geom.project(g);
                let d = proj.distance_m;
                if d <= 0.5 * geom.frame_at(proj.s_m).width_m + 1.0
                    && best.is_none_or(|(bd, _)| d < bd)
                {
                    best = Some((d, index));
                }
            }
        }
        best.map(|(_, j)| j)
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
            .map(|g| to_mm(DVec3::new(f64::from(g.x), f64::from(g.y), 0.0)));
        match self.tool {
            Tool::Select => {
                self.selection = match self.pick_road(px, size) {
                    Some(pick) => Selection::Road(pick.road),
                    None => self
                        .pick_junction(px, size)
                        .map_or(Selection::None, Selection::Junction),
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
            Tool::Roundabout | Tool::Crossroads => {
                let Some(at) = ground else { return };
                let (kind, what) = if self.tool == Tool::Roundabout {
                    (
                        PrefabKind::Roundabout,
                        "a ring with four arms, each entry giving way to the ring; a car \
                         without a route leaves at the first exit",
                    )
                } else {
                    (
                        PrefabKind::Crossroads,
                        "four arms under a two-phase signal with permitted left turns; a car \
                         without a route goes straight on",
                    )
                };
                let (command, name) = place_prefab(self.editor.level(), kind, at);
                if self.edit(command, false) {
                    self.selection = Selection::None;
                    self.status = format!(
                        "Placed `{name}`: {what}. Put spawners on its `… in` roads and \
                         destroyers on its `… out` roads."
                    );
                }
            }
            Tool::Spawner | Tool::Destroyer | Tool::Trigger => {
                let Some(pick) = self.pick_road(px, size) else {
                    let what = match self.tool {
                        Tool::Spawner => "spawner",
                        Tool::Destroyer => "destroyer",
                        _ => "trigger",
                    };
                    self.status = if self
                        .editor
                        .level()
                        .roads
                        .iter()
                        .any(|r| r.points.len() >= 2)
                    {
                        format!("No road here: click on a road to place the {what} there.")
                    } else {
                        format!(
                            "There is no road yet: draw one with the Road tool (R), then place \
                             the {what} on it."
                        )
                    };
                    return;
                };
                self.place_marker(pick);
            }
        }
    }

    fn place_marker(&mut self, pick: RoadPick) {
        let kind = match self.tool {
            Tool::Spawner => MarkerKind::Spawner,
            Tool::Destroyer => MarkerKind::Destroyer,
            _ => MarkerKind::Trigger,
        };
        let level = self.editor.level();
        let Some(placed) = place_marker(level, kind, pick.road, pick.lane, pick.s_m, pick.length_m)
        else {
            return;
        };
        let note = if placed.added_profiles {
            " The level had no driver profiles, so it got the standard `autonomous` and `human` \
             ones (Level panel)."
        } else {
            ""
        };
        let label = capitalise(placed.command.label());
        if self.edit(placed.command, false) {
            self.selection = Selection::Marker(placed.kind, placed.index);
            self.status = format!("{label}{note}");
        }
    }

    /// The pointer moved to `px` with the left button down.
    pub fn drag_to(&mut self, px: Vec2, size: Vec2) {
        self.drag_px = Some((px, size));
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
                    let to = to_mm(DVec3::new(f64::from(g.x), f64::from(g.y), f64::from(z)));
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
                    let s_m = (g.project(at.as_dvec3()).s_m * 100.0).round() / 100.0;
                    self.edit(Command::MoveMarker { kind, index, s_m }, true);
                }
            }
            None => {}
        }
    }

    /// The left button went up: a road's end dragged onto another road joins it there.
    pub fn release(&mut self) {
        let join = match (self.drag, self.drag_px) {
            (Some(Drag::Point(r, i)), Some((px, size))) => {
                self.join_target(r, i, px, size).map(|j| (r, j))
            }
            _ => None,
        };
        self.drag = None;
        self.drag_px = None;
        self.editor.end_drag();
        if let Some((r, join)) = join {
            let (command, done) = match join {
                Join::End { onto } => (
                    Command::JoinEnd {
                        road: r,
                        onto: onto.clone(),
                    },
                    format!("Linked onto `{onto}`: its lanes are in the inspector."),
                ),
                Join::Exit { onto, s_m } => (
                    Command::JoinExit {
                        road: r,
                        onto: onto.clone(),
                        s_m,
                    },
                    format!(
                        "Leaves `{onto}` at {s_m:.0} m: its rightmost lane now goes on or takes \
                         this road (routes choose)."
                    ),
                ),
                Join::Side { onto, s_m } => (
                    Command::JoinSide {
                        road: r,
                        onto: onto.clone(),
                        s_m,
                    },
                    format!(
                        "Joined `{onto}` from the side at {s_m:.0} m: its lanes run on as \
                         acceleration lanes in `{onto} merge` and end into the road."
                    ),
                ),
            };
            let name = self.editor.level().roads.get(r).map(|d| d.name.clone());
            if self.edit(command, false) {
                // A side join puts the cut road's pieces before it: find it by name.
                let level = self.editor.level();
                let at = level
                    .roads
                    .iter()
                    .position(|d| Some(&d.name) == name.as_ref());
                self.selection = at.map_or(Selection::None, Selection::Road);
                self.status = done;
            }
        }
    }

    /// What releasing the pointer at `px` would join point `i` of road `r` to. Its last point
    /// (of an open road) over another road's start (within that road's half width or
    /// [`PICK_PX`]) links onto it, over its side joins it as an on-ramp; its first point over
    /// another road's side leaves it as an exit. Joins that exist already are not offered.
    fn join_target(&self, r: usize, i: usize, px: Vec2, size: Vec2) -> Option<Join> {
        let level = self.editor.level();
        let road = level.roads.get(r)?;
        let first = i == 0;
        if road.closed || road.points.len() < 2 || !(first || i + 1 == road.points.len()) {
            return None;
        }
        let ground = self.camera.ground_point(px, size, 0.0)?.as_dvec3();
        let linked = road.outgoing();
        let mut best: Option<(f64, Join)> = None;
        for (id, g) in self.network.iter() {
            let name = g.name();
            // A junction's paths are built from its connections, never joined by hand.
            if name == road.name
                || g.is_closed()
                || linked.iter().any(|l| l.to == name)
                || self.network.junction_path(id).is_some()
            {
                continue;
            }
            let proj = g.project(ground);
            let on_side = proj.distance_m <= 0.5 * g.frame_at(proj.s_m).width_m + 1.0
                && proj.s_m > 0.0
                && proj.s_m < g.length_m();
            let s_m = (proj.s_m * 100.0).round() / 100.0;
            let onto = name.to_owned();
            let (d, join) = if first {
                let leads_here = level
                    .road(name)
                    .is_some_and(|o| o.outgoing().iter().any(|l| l.to == road.name));
                if leads_here || !on_side {
                    continue;
                }
                (proj.distance_m, Join::Exit { onto, s_m })
            } else {
                let start = g.frame_at(0.0);
                let to_start = (ground - start.pos).length();
                let near_start = to_start <= 0.5 * start.width_m
                    || self
                        .camera
                        .to_screen(start.pos.as_vec3(), size)
                        .is_some_and(|s| s.distance(px) <= PICK_PX);
                let d = to_start.min(proj.distance_m);
                if near_start {
                    (d, Join::End { onto })
                } else if on_side {
                    (d, Join::Side { onto, s_m })
                } else {
                    continue;
                }
            };
            if best.as_ref().is_none_or(|(bd, _)| d < *bd) {
                best = Some((d, join));
            }
        }
        best.map(|(_, j)| j)
    }

    /// The hint shown while a road's end is dragged over another road: what releasing it does.
    pub fn join_hint(&self) -> Option<(Vec3, String)> {
        let (Some(Drag::Point(r, i)), Some((px, size))) = (self.drag, self.drag_px) else {
            return None;
        };
        let join = self.join_target(r, i, px, size)?;
        let at = self
            .editor
            .level()
            .roads
            .get(r)?
            .points
            .get(i)?
            .pos
            .as_vec3();
        Some((
            at,
            match join {
                Join::End { onto } => format!("release to link onto `{onto}`"),
                Join::Side { onto, s_m } => {
                    format!("release to join `{onto}` from the side at {s_m:.0} m (on-ramp)")
                }
                Join::Exit { onto, s_m } => {
                    format!("release to leave `{onto}` at {s_m:.0} m (exit)")
                }
            },
        ))
    }

    /// Deletes what is selected.
    pub fn delete_selected(&mut self) {
        let command = match self.selection {
            Selection::Point(road, index) => Command::DeletePoint { road, index },
            Selection::Road(road) => Command::DeleteRoad { road },
            Selection::Marker(kind, index) => Command::DeleteMarker { kind, index },
            Selection::Junction(index) => Command::DeleteJunction(index),
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
        if self.editor.is_dirty() {
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
        // The work is saved or was discarded on purpose: nothing to offer back next time.
        if let Some(auto) = flockway_edit::autosave_path(self.editor.path()) {
            let _ = std::fs::remove_file(auto);
        }
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

    /// Play: starts the level as edited (or resumes). Roads still being drawn (a single point)
    /// are left out; anything else `flockway run` would reject is refused, saying what and where.
    pub fn play(&mut self) {
        if let Some(p) = &mut self.play {
            p.paused = false;
            return;
        }
        let (level, drafts) = playable(self.editor.level());
        if let Some(issue) = validate(&level).first() {
            self.status = format!("Cannot play: {}", issue.describe(&level));
            return;
        }
        let name = level_name(&level, self.editor.path().unwrap_or(Path::new("untitled")));
        let csv = std::env::temp_dir().join(format!("flockway-play-{}.csv", std::process::id()));
        match PlaySession::start(level, &name, &self.assets, &csv) {
            Ok(session) => {
                self.edited_level = Some(self.editor.level().clone());
                self.play = Some(session);
                // The scene drops the control-point handles while playing.
                self.scene_version += 1;
                self.selection = Selection::None;
                self.status = match drafts {
                    0 => "Playing.".to_owned(),
                    n => format!("Playing, without {n} road(s) of a single point (not roads yet)."),
                };
            }
            Err(e) => self.status = format!("Cannot play: {e}"),
        }
    }

    /// Ends the road being drawn (Enter): the next click of the Road tool starts a new road.
    pub fn finish_road(&mut self) {
        if let Selection::Road(r) | Selection::Point(r, _) = self.selection
            && let Some(road) = self.editor.level().roads.get(r)
        {
            self.status = if road.points.len() < 2 {
                format!(
                    "Road `{}` has one point: it is not a road yet. Select it and click to add \
                     its next point, or press Delete.",
                    road.name
                )
            } else {
                format!("Road `{}` finished.", road.name)
            };
        }
        self.selection = Selection::None;
    }

    /// The hint shown beside a road being drawn with the Road tool: where (its last point) and
    /// what to do next.
    pub fn drawing_hint(&self) -> Option<(Vec3, &'static str)> {
        if self.play.is_some() || self.tool != Tool::Road {
            return None;
        }
        let (Selection::Road(r) | Selection::Point(r, _)) = self.selection else {
            return None;
        };
        let road = self.editor.level().roads.get(r)?;
        let last = road.points.last()?.pos.as_vec3();
        Some(if road.points.len() < 2 {
            (last, "click to add the next point, Enter to finish")
        } else {
            (last, "click to extend the road, Enter to finish")
        })
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

    /// Writes the run's telemetry CSV to `path` (and its signals CSV beside it).
    pub fn export(&mut self, path: &Path) {
        self.status = match &self.play {
            Some(p) => match p.export_csv(path) {
                Ok(false) => format!("exported {}", path.display()),
                Ok(true) => format!(
                    "exported {} and {}",
                    path.display(),
                    flockway_runner::signals_path(path).display()
                ),
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

    /// The level's file name (or "untitled") and, in play mode, that it is playing.
    pub fn file_label(&self) -> String {
        let name = self.editor.path().and_then(|p| p.file_name()).map_or_else(
            || "untitled".to_owned(),
            |n| n.to_string_lossy().into_owned(),
        );
        let mode = if self.play.is_some() {
            " — playing"
        } else {
            ""
        };
        format!("{name}{mode}")
    }

    /// The window title: file name and `*` when there are unsaved changes.
    pub fn title(&self) -> String {
        let dirty = if self.editor.is_dirty() { "* " } else { "" };
        format!("{dirty}{} — Flockway", self.file_label())
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
    use flockway_road::RoadSpec;

    fn app_on(level: &str) -> AppState {
        let editor = Editor::open(Path::new(level)).expect("shipped level");
        AppState::new(editor, PathBuf::from("../../assets"))
    }

    #[test]
    fn the_editor_draws_a_junctions_paths_and_a_click_on_one_picks_no_road() {
        let mut app = app_on("../../levels/signal_queue.ron");
        let path = app
            .network
            .id("signal#0")
            .expect("the junction's path is drawn");
        assert_eq!(app.network.junction_path(path), Some((0, 0)));
        // The path's middle, between the two roads: nothing to select there.
        let size = Vec2::new(1600.0, 900.0);
        app.camera = Camera::Top {
            centre: glam::Vec3::new(408.0, 0.0, 0.0),
            half_height_m: 20.0,
        };
        let px = app
            .camera
            .to_screen(glam::Vec3::new(408.0, 0.0, 0.0), size)
            .expect("on screen");
        assert!(app.pick_road(px, size).is_none());
        // A junction whose road is gone is left out; the roads still show.
        let mut roads = app.editor.level().roads.clone();
        roads.remove(1);
        let network = flockway_edit::network_as_drawn(roads, app.editor.level().junctions.clone());
        assert_eq!(network.len(), 1);
        assert!(network.junctions().is_empty());
    }

    #[test]
    fn a_click_on_a_junction_selects_it_and_del_deletes_it_in_one_undo_step() {
        let mut app = app_on("../../levels/crossroads_signal.ron");
        let size = Vec2::new(1600.0, 900.0);
        app.camera = Camera::Top {
            centre: Vec3::ZERO,
            half_height_m: 30.0,
        };
        // Its centre, where the paths cross: no road there, the junction.
        let px = app.camera.to_screen(Vec3::ZERO, size).expect("on screen");
        app.press(px, size);
        app.release();
        assert_eq!(app.selection, Selection::Junction(0));
        assert_eq!(app.selected_junction_paths().len(), 12);
        // An arm's road is still the road, not the junction.
        let arm = app
            .camera
            .to_screen(Vec3::new(-40.0, -1.75, 0.0), size)
            .expect("on screen");
        app.press(arm, size);
        app.release();
        assert!(
            matches!(app.selection, Selection::Road(_)),
            "{:?}",
            app.selection
        );
        app.selection = Selection::Junction(0);
        app.delete_selected();
        assert!(app.editor.level().junctions.is_empty());
        assert_eq!(app.selection, Selection::None);
        app.undo();
        assert_eq!(app.editor.level().junctions.len(), 1);
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

    /// An app on a level of two straight roads: `main` (two lanes, 0 to 800 m along x) and
    /// `ramp` (one lane, ending beside it), viewed from above at `size`.
    fn two_roads(size: Vec2) -> AppState {
        let mut level = Level::new(1, 60.0);
        level.roads = vec![
            RoadSpec::through(
                "main",
                2,
                100.0,
                &[
                    DVec3::ZERO,
                    DVec3::new(400.0, 0.0, 0.0),
                    DVec3::new(800.0, 0.0, 0.0),
                ],
            ),
            RoadSpec::through(
                "ramp",
                1,
                80.0,
                &[
                    DVec3::new(0.0, -120.0, 0.0),
                    DVec3::new(150.0, -90.0, 0.0),
                    DVec3::new(250.0, -60.0, 0.0),
                ],
            ),
        ];
        let mut app = AppState::new(
            Editor::with_level(level, None),
            PathBuf::from("../../assets"),
        );
        app.fit_view(size.x / size.y);
        app
    }

    /// Drags the ramp's end point to `to` (world metres) in small moves and releases it.
    fn drag_ramp_end(app: &mut AppState, to: Vec3, size: Vec2) {
        let end = app.editor.level().roads[1].points[2].pos.as_vec3();
        let px = app.camera.to_screen(end, size).expect("on screen");
        app.press(px, size);
        assert_eq!(app.selection, Selection::Point(1, 2));
        for k in 1..=8 {
            let at = end.lerp(to, k as f32 / 8.0);
            app.drag_to(app.camera.to_screen(at, size).expect("on screen"), size);
        }
    }

    #[test]
    fn a_road_end_dragged_onto_a_start_links_onto_a_side_joins_and_a_start_on_a_side_leaves() {
        let size = Vec2::new(1600.0, 900.0);
        // Onto the start of `main`: a link, the end on its start, one undo step for the join.
        let mut app = two_roads(size);
        drag_ramp_end(&mut app, Vec3::new(1.0, 2.0, 0.0), size);
        let (_, hint) = app.join_hint().expect("a hint while over the start");
        assert!(hint.contains("link onto `main`"), "{hint}");
        app.release();
        let ramp = &app.editor.level().roads[1];
        assert_eq!(ramp.outgoing()[0].to, "main");
        assert!(
            app.network
                .link(
                    app.network.id("ramp").expect("ramp"),
                    app.network.id("main").expect("main")
                )
                .is_some()
        );
        assert!(app.status.contains("Linked onto `main`"), "{}", app.status);
        app.undo();
        assert!(
            app.editor.level().roads[1].outgoing().is_empty(),
            "undo unlinks"
        );

        // Onto its side at 300 m: an on-ramp with a 250 m acceleration lane.
        let mut app = two_roads(size);
        drag_ramp_end(&mut app, Vec3::new(300.0, -3.0, 0.0), size);
        let (_, hint) = app.join_hint().expect("a hint while over the side");
        assert!(hint.contains("from the side"), "{hint}");
        app.release();
        let names: Vec<&str> = app
            .editor
            .level()
            .roads
            .iter()
            .map(|r| r.name.as_str())
            .collect();
        assert_eq!(names, ["main", "main merge", "main on", "ramp"]);
        assert_eq!(app.selection, Selection::Road(3), "the ramp stays selected");
        let net = &app.network;
        let merge = net.id("main merge").expect("merge");
        assert_eq!(
            net.lane_next(net.id("ramp").expect("ramp"), 0, None),
            Some((merge, 0))
        );
        let g = net.get(merge).expect("merge");
        assert!((g.length_m() - 250.0).abs() < 1.0 && g.lanes() == 3);
        assert!(flockway_level::validate(app.editor.level()).is_empty());
        // A click beyond the first piece's end is on the piece that carries the road on.
        let px = app
            .camera
            .to_screen(Vec3::new(700.0, 0.0, 0.0), size)
            .expect("on screen");
        let pick = app.pick_road(px, size).expect("a road");
        assert_eq!(app.editor.level().roads[pick.road].name, "main on");
        assert!((pick.s_m - 150.0).abs() < 1.0, "{pick:?}");

        // The ramp's start dragged onto the road's side at 500 m: an exit there.
        let mut app = two_roads(size);
        let start = app.editor.level().roads[1].points[0].pos.as_vec3();
        let px = app.camera.to_screen(start, size).expect("on screen");
        app.press(px, size);
        for k in 1..=8 {
            let at = start.lerp(Vec3::new(500.0, -2.0, 0.0), k as f32 / 8.0);
            app.drag_to(app.camera.to_screen(at, size).expect("on screen"), size);
        }
        let (_, hint) = app.join_hint().expect("a hint");
        assert!(hint.contains("leave `main`"), "{hint}");
        app.release();
        let level = app.editor.level();
        let main = &level.roads[0];
        assert_eq!(main.links.len(), 2, "{:?}", main.links);
        assert_eq!(main.links[1].to, "ramp");
        assert!(app.network.id("main on").is_some());

        // Released away from any road: the point just moved.
        let mut app = two_roads(size);
        drag_ramp_end(&mut app, Vec3::new(300.0, -60.0, 0.0), size);
        assert!(app.join_hint().is_none());
        app.release();
        assert!(app.editor.level().roads[1].outgoing().is_empty());
        assert_eq!(app.editor.level().roads.len(), 2);
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
