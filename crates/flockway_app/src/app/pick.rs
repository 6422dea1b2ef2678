//! Picking in the scene: which control point, marker, road or junction is under the pointer,
//! and what releasing a dragged road end there would join it to.

use super::*;

impl AppState {
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
    pub(super) fn marker_anchor(&self, kind: MarkerKind, index: usize) -> Option<(Vec3, String)> {
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

    /// What releasing the pointer at `px` would join point `i` of road `r` to. Its last point
    /// (of an open road) over another road's start (within that road's half width or
    /// [`PICK_PX`]) links onto it, over its side joins it as an on-ramp; its first point over
    /// another road's side leaves it as an exit. Joins that exist already are not offered.
    pub(super) fn join_target(&self, r: usize, i: usize, px: Vec2, size: Vec2) -> Option<Join> {
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
        let (Some(Drag::Point(r, i)), Some((px, size))) = (self.pointer.drag, self.pointer.drag_px)
        else {
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

    /// Where a marker stands in the world.
    pub fn marker_position(&self, kind: MarkerKind, index: usize) -> Option<DVec3> {
        self.marker_anchor(kind, index).map(|(p, _)| p.as_dvec3())
    }

    /// Why road `r` does not form a road as drawn, if it does not.
    pub fn road_problem(&self, r: usize) -> Option<String> {
        let mut spec = self.editor.level().roads.get(r)?.clone();
        spec.next = None;
        RoadGeometry::new(&spec).err().map(|e| e.to_string())
    }
}
