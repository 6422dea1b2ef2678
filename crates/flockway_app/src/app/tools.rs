//! The scene's tools: what a press, a drag and a release do with each tool, and the edits of
//! the selection (delete, insert a point, finish a road).

use super::*;

/// The drag in progress: what is dragged, and where the pointer last was.
#[derive(Debug, Default)]
pub(super) struct Pointer {
    /// The point or marker being dragged.
    pub(super) drag: Option<Drag>,
    /// Where the pointer last was while dragging, and the window's size, pixels.
    pub(super) drag_px: Option<(Vec2, Vec2)>,
}

impl AppState {
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

    /// The left button went down in the scene at `px`.
    pub fn press(&mut self, px: Vec2, size: Vec2) {
        if self.play.is_some() {
            self.select_vehicle(px, size);
            return;
        }
        if let Some((r, i)) = self.pick_point(px, size) {
            self.selection = Selection::Point(r, i);
            self.pointer.drag = Some(Drag::Point(r, i));
            return;
        }
        if let Some((kind, i)) = self.pick_marker(px, size) {
            self.selection = Selection::Marker(kind, i);
            self.pointer.drag = Some(Drag::Marker(kind, i));
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

    pub(super) fn place_marker(&mut self, pick: RoadPick) {
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
        self.pointer.drag_px = Some((px, size));
        match self.pointer.drag {
            Some(Drag::Point(r, i)) => {
                // The point may have gone (deleted mid-drag): then the drag ends.
                let Some(point) = self
                    .editor
                    .level()
                    .roads
                    .get(r)
                    .and_then(|d| d.points.get(i))
                else {
                    self.pointer.drag = None;
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
        let join = match (self.pointer.drag, self.pointer.drag_px) {
            (Some(Drag::Point(r, i)), Some((px, size))) => {
                self.join_target(r, i, px, size).map(|j| (r, j))
            }
            _ => None,
        };
        self.pointer.drag = None;
        self.pointer.drag_px = None;
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
}
