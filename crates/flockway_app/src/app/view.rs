//! What the scene shows and from where: the static scene, the camera's fit to the level, and
//! the selected junction's paths.

use super::*;

/// Where the scene is drawn, and the camera the last fit chose.
#[derive(Debug, Default)]
pub(super) struct Framing {
    /// The window's size and the part of it the panels leave to the scene, pixels.
    pub(super) view_area: Option<(Vec2, Vec2, Vec2)>,
    /// The camera the last fit chose, while the user has not moved it: a change of the
    /// scene's area (the first frame, a resize, a panel) fits the view again.
    pub(super) fitted: Option<Camera>,
}

impl AppState {
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
        self.camera = match (self.camera, self.framing.view_area) {
            (Camera::Top { .. }, Some((viewport, lo, hi))) => {
                Camera::top_fit_area(s.min, s.max, viewport, lo, hi)
            }
            (Camera::Top { .. }, None) => Camera::top_fit(s.min, s.max, aspect),
            (Camera::Orbit { .. }, _) => Camera::orbit_fit(s.min, s.max),
        };
        self.framing.fitted = Some(self.camera);
    }

    /// Where the scene is drawn: the window's size and the part of it no panel covers, pixels.
    /// When it changes, a fitted view the user has not moved since is fitted again.
    pub fn set_view_area(&mut self, viewport: Vec2, area_min: Vec2, area_max: Vec2) {
        let area = Some((viewport, area_min, area_max));
        if area == self.framing.view_area {
            return;
        }
        self.framing.view_area = area;
        if self.framing.fitted == Some(self.camera) {
            self.fit_view(viewport.x / viewport.y.max(1.0));
        }
    }

    /// The window's size and the part of it the panels leave to the scene, pixels, once a frame
    /// has been drawn.
    pub fn view_area(&self) -> Option<(Vec2, Vec2, Vec2)> {
        self.framing.view_area
    }

    /// Switches between the top and the orbit view.
    pub fn toggle_camera(&mut self, aspect: f32) {
        let s = self.static_scene();
        self.camera = match (self.camera, self.framing.view_area) {
            (Camera::Top { .. }, _) => Camera::orbit_fit(s.min, s.max),
            (Camera::Orbit { .. }, Some((viewport, lo, hi))) => {
                Camera::top_fit_area(s.min, s.max, viewport, lo, hi)
            }
            (Camera::Orbit { .. }, None) => Camera::top_fit(s.min, s.max, aspect),
        };
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

    /// The junction with this name as built from the level as drawn (its paths, how each
    /// turns), if it can be built.
    pub fn built_junction(&self, name: &str) -> Option<&flockway_road::Junction> {
        self.network
            .junctions()
            .iter()
            .find(|j| j.spec.name == name)
    }

    /// The length of the road with this name as drawn, if it forms a road.
    pub fn road_length_m(&self, name: &str) -> Option<f64> {
        self.network
            .id(name)
            .and_then(|id| self.network.get(id))
            .map(|g| g.length_m())
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
