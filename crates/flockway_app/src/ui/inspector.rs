//! The inspector: every field of the selected road, control point, spawner, destroyer or
//! trigger, edited in place (each edit an undoable command; a dragged value is one step).

use super::widgets::{choice, count, error, lane, number, row, text, weight};
use crate::app::{AppState, Selection, Tool};
use flockway_edit::{Command, MarkerKind};
use flockway_level::{
    DestroyerPlaceSpec, DestroyerSpec, Level, ProfileShare, RouteSpec, SpawnerSpec,
    TriggerEffectSpec, TriggerSpec,
};
use flockway_road::{
    BANK_DEG, COORD_M, LANE_WIDTH_M, LANES, LinkSpec, RoadSpec, SPEED_LIMIT_KMH, WIDTH_M,
};
use glam::DVec3;

/// The inspector of whatever is selected.
pub(super) fn inspector(ui: &mut egui::Ui, app: &mut AppState) {
    let level = app.editor.level().clone();
    match app.selection {
        Selection::None | Selection::Vehicle(_) => overview(ui, app, &level),
        Selection::Road(r) | Selection::Point(r, _) => road(ui, app, &level, r),
        Selection::Marker(MarkerKind::Spawner, i) => {
            if let Some(s) = level.spawners.get(i) {
                spawner(ui, app, &level, i, s);
            }
        }
        Selection::Marker(MarkerKind::Destroyer, i) => {
            if let Some(d) = level.destroyers.get(i) {
                destroyer(ui, app, &level, i, d);
            }
        }
        Selection::Marker(MarkerKind::Trigger, i) => {
            if let Some(t) = level.triggers.get(i) {
                trigger(ui, app, &level, i, t);
            }
        }
        Selection::Junction(i) => {
            if let Some(j) = level.junctions.get(i) {
                super::junction::junction(ui, app, i, j);
            }
        }
    }
}

fn overview(ui: &mut egui::Ui, app: &mut AppState, level: &Level) {
    ui.label(format!(
        "{} road(s), {} spawner(s), {} destroyer(s), {} trigger(s)",
        level.roads.len(),
        level.spawners.len(),
        level.destroyers.len(),
        level.triggers.len()
    ));
    if !level.junctions.is_empty() {
        ui.horizontal_wrapped(|ui| {
            ui.label("junctions:");
            for (i, j) in level.junctions.iter().enumerate() {
                if ui.link(&j.name).clicked() {
                    app.selection = Selection::Junction(i);
                }
            }
        });
    }
    let hint = match app.tool {
        Tool::Select => {
            "Click a road, a control point, a marker or a junction to edit it here; drag \
                         points and markers to move them."
        }
        Tool::Road => {
            "Click on the ground to start a road, click again to add points, Enter to \
                       finish it."
        }
        Tool::Spawner => "Click on a lane to place a spawner there.",
        Tool::Destroyer => "Click on a road to place a destroyer: vehicles that reach it leave.",
        Tool::Trigger => "Click on a road to place a trigger stretch (a new speed limit).",
        Tool::Roundabout => {
            "Click on the ground to place a single-lane roundabout there: a ring of 24 m radius \
             with four arms, each entry giving way to the ring."
        }
        Tool::Crossroads => {
            "Click on the ground to place a crossroads there: four arms, a lane each way, under \
             a fixed-time two-phase signal with permitted left turns."
        }
    };
    ui.add(egui::Label::new(egui::RichText::new(hint).weak()).wrap());
}

fn road_names(level: &Level) -> Vec<String> {
    level
        .roads
        .iter()
        .filter(|r| r.points.len() >= 2)
        .map(|r| r.name.clone())
        .collect()
}

fn road(ui: &mut egui::Ui, app: &mut AppState, level: &Level, r: usize) {
    let Some(road) = level.roads.get(r) else {
        return;
    };
    ui.label(egui::RichText::new(format!("road `{}`", road.name)).strong());
    match app.road_length_m(&road.name) {
        Some(len) => {
            ui.label(format!(
                "{len:.1} m long, {} lane(s), {} point(s){}",
                road.lanes,
                road.points.len(),
                if road.closed { ", a loop" } else { "" }
            ));
        }
        None if road.points.len() < 2 => error(
            ui,
            "One point: not a road yet. With the Road tool, click to add the next point.",
        ),
        None => error(
            ui,
            &app.road_problem(r)
                .unwrap_or_else(|| "This road cannot be built as drawn.".to_owned()),
        ),
    }
    let mut name = road.name.clone();
    let (mut lanes, mut width, mut limit) = (road.lanes, road.lane_width_m, road.speed_limit_kmh);
    let mut changed = false;
    egui::Grid::new("road").num_columns(2).show(ui, |ui| {
        row(ui, "name", |ui, by| {
            if let Some(n) = text(ui, by, ("road name", r), &road.name) {
                name = n;
                changed = true;
            }
        });
        changed |= row(ui, "lanes", |ui, by| count(ui, by, &mut lanes, LANES));
        changed |= row(ui, "lane width", |ui, by| {
            number(ui, by, &mut width, LANE_WIDTH_M, 0.05, " m")
        });
        changed |= row(ui, "speed limit", |ui, by| {
            number(ui, by, &mut limit, SPEED_LIMIT_KMH, 0.5, " km/h")
        });
    });
    if changed {
        app.edit_live(Command::SetRoad {
            road: r,
            name,
            lanes,
            lane_width_m: width,
            speed_limit_kmh: limit,
        });
    }
    let mut closed = road.closed;
    if ui.checkbox(&mut closed, "closed loop").changed() {
        app.apply(Command::SetClosed { road: r, closed });
    }
    if !road.closed
        && let Some(links) = links(ui, level, road)
    {
        app.apply(Command::SetLinks { road: r, links });
    }
    if let Selection::Point(_, i) = app.selection
        && let Some(point) = road.points.get(i)
    {
        ui.separator();
        ui.label(egui::RichText::new(format!("point {i}")).strong());
        let mut p = point.clone();
        let mut width_m = p
            .width_m
            .unwrap_or(road.lane_width_m * f64::from(road.lanes));
        let mut changed = false;
        egui::Grid::new("point").num_columns(2).show(ui, |ui| {
            changed |= row(ui, "x", |ui, by| {
                number(ui, by, &mut p.pos.x, COORD_M, 0.1, " m")
            });
            changed |= row(ui, "y", |ui, by| {
                number(ui, by, &mut p.pos.y, COORD_M, 0.1, " m")
            });
            changed |= row(ui, "elevation", |ui, by| {
                number(ui, by, &mut p.pos.z, COORD_M, 0.05, " m")
            });
            changed |= row(ui, "width", |ui, by| {
                number(ui, by, &mut width_m, WIDTH_M, 0.05, " m")
            });
            changed |= row(ui, "bank", |ui, by| {
                number(ui, by, &mut p.bank_deg, BANK_DEG, 0.05, "°")
            });
        });
        changed |= ui
            .checkbox(&mut p.guardrail_left, "guardrail left")
            .changed();
        changed |= ui
            .checkbox(&mut p.guardrail_right, "guardrail right")
            .changed();
        if changed {
            let lanes_width = road.lane_width_m * f64::from(road.lanes);
            // Left at the lanes' width, the width follows the lanes; set, it stays.
            p.width_m = ((width_m - lanes_width).abs() > 1e-9 || point.width_m.is_some())
                .then_some(width_m);
            app.edit_live(Command::SetPoint {
                road: r,
                index: i,
                point: p,
            });
        }
        ui.horizontal(|ui| {
            if ui.button("Insert after").clicked() {
                app.insert_after_selected();
            }
            if ui.button("Delete").on_hover_text("Del").clicked() {
                app.delete_selected();
            }
        });
    } else if ui.button("Delete road").clicked() {
        app.delete_selected();
    }
}

/// Where a road's end leads: each link with its lane pairs as a grid of checkboxes (a row per
/// lane here, a column per lane there), a button to remove it, and a choice to add one. Returns
/// the edited links.
fn links(ui: &mut egui::Ui, level: &Level, road: &RoadSpec) -> Option<Vec<LinkSpec>> {
    ui.separator();
    ui.label(egui::RichText::new("leads onto").strong());
    let mut links = road.outgoing();
    let mut changed = false;
    let mut remove = None;
    if links.is_empty() {
        ui.weak(
            "nothing: drag this road's last point onto another road's start to link it, or \
             onto its side to join as an on-ramp",
        );
    }
    for (k, link) in links.iter_mut().enumerate() {
        let Some(to) = level.road(&link.to) else {
            error(ui, &format!("`{}` does not exist", link.to));
            continue;
        };
        ui.horizontal(|ui| {
            ui.label(format!("onto `{}`", link.to));
            if ui
                .small_button("x")
                .on_hover_text("remove this link")
                .clicked()
            {
                remove = Some(k);
            }
        });
        let mut by_position = link.lanes.is_empty();
        if ui
            .checkbox(&mut by_position, "lanes by position")
            .on_hover_text("lane i onto lane i; lanes beyond the other road's onto its leftmost")
            .changed()
        {
            link.lanes = if by_position {
                Vec::new()
            } else {
                link.lane_pairs(road.lanes, to.lanes)
            };
            changed = true;
        }
        let pairs = link.lane_pairs(road.lanes, to.lanes);
        egui::Grid::new(("link lanes", k))
            .num_columns(1 + to.lanes as usize)
            .show(ui, |ui| {
                ui.weak("here \\ there");
                for b in 0..to.lanes {
                    ui.weak(format!("{b}"));
                }
                ui.end_row();
                // Leftmost lane first, as seen driving.
                for a in (0..road.lanes).rev() {
                    ui.weak(format!("lane {a}"));
                    for b in 0..to.lanes {
                        let mut on = pairs.contains(&(a, b));
                        let what = format!("lane {a} here onto lane {b} of `{}`", to.name);
                        let tick = ui
                            .add_enabled(!by_position, egui::Checkbox::without_text(&mut on))
                            .on_hover_text(&what);
                        tick.widget_info(|| {
                            egui::WidgetInfo::selected(
                                egui::Role::CheckBox,
                                !by_position,
                                on,
                                &what,
                            )
                        });
                        if tick.changed() {
                            link.lanes.retain(|&(x, _)| x != a);
                            if on {
                                link.lanes.push((a, b));
                            }
                            link.lanes.sort_unstable();
                            changed = true;
                        }
                    }
                    ui.end_row();
                }
            });
    }
    if let Some(k) = remove {
        links.remove(k);
        changed = true;
    }
    let candidates: Vec<&RoadSpec> = level
        .roads
        .iter()
        .filter(|o| o.name != road.name && !o.closed && o.points.len() >= 2)
        .filter(|o| !links.iter().any(|l| l.to == o.name))
        .collect();
    if !candidates.is_empty() {
        let mut pick: Option<String> = None;
        egui::ComboBox::new(("add link", &road.name), "add a link")
            .selected_text("onto…")
            .show_ui(ui, |ui| {
                for o in &candidates {
                    ui.selectable_value(&mut pick, Some(o.name.clone()), &o.name);
                }
            });
        if let Some(to) = pick {
            links.push(LinkSpec::to(&to));
            changed = true;
        }
    }
    changed.then_some(links)
}

/// Road and arc position of a marker. Returns the edited pair when either changed.
fn place(
    ui: &mut egui::Ui,
    app: &AppState,
    level: &Level,
    salt: &str,
    road: &str,
    s_m: f64,
) -> Option<(String, f64)> {
    let mut road = road.to_owned();
    let mut s = s_m;
    let mut changed = false;
    changed |= row(ui, "road", |ui, by| {
        choice(ui, by, (salt, "road"), &mut road, &road_names(level))
    });
    let len = app.road_length_m(&road).unwrap_or(s_m.max(1.0));
    changed |= row(ui, "at", |ui, by| {
        number(ui, by, &mut s, 0.0..=len, 0.25, " m")
    });
    changed.then(|| (road.clone(), s.min(app.road_length_m(&road).unwrap_or(s))))
}

fn lanes_of(level: &Level, road: &str) -> u32 {
    level.road(road).map_or(1, |r| r.lanes)
}

fn spawner(ui: &mut egui::Ui, app: &mut AppState, level: &Level, i: usize, s: &SpawnerSpec) {
    ui.label(egui::RichText::new(format!("spawner `{}`", s.name)).strong());
    let mut sp = s.clone();
    let mut changed = false;
    egui::Grid::new("spawner").num_columns(2).show(ui, |ui| {
        row(ui, "name", |ui, by| {
            if let Some(n) = text(ui, by, ("spawner name", i), &s.name) {
                sp.name = n.trim().to_owned();
                changed = true;
            }
        });
        if let Some((road, at)) = place(ui, app, level, "spawner", &s.road, s.s_m) {
            sp.lane = sp.lane.min(lanes_of(level, &road) - 1);
            if road != sp.road {
                // Routes start on the spawner's road: on another road they are drawn again.
                sp.routes.clear();
            }
            (sp.road, sp.s_m) = (road, at);
            changed = true;
        }
        changed |= row(ui, "lane", |ui, by| {
            lane(
                ui,
                by,
                ("spawner lane", i),
                &mut sp.lane,
                lanes_of(level, &sp.road),
            )
        });
        changed |= row(ui, "every", |ui, by| {
            ui.horizontal(|ui| {
                let a = number(ui, by, &mut sp.interval_s.min, 0.1..=3600.0, 0.02, " s");
                ui.label("to");
                let b = number(ui, by, &mut sp.interval_s.max, 0.1..=3600.0, 0.02, " s");
                a || b
            })
            .inner
        });
        let mut at_limit = sp.speed_kmh.is_none();
        row(ui, "initial speed", |ui, by| {
            ui.horizontal(|ui| {
                if ui.checkbox(&mut at_limit, "the road's limit").changed() {
                    let limit = level.road(&sp.road).map_or(50.0, |r| r.speed_limit_kmh);
                    sp.speed_kmh = (!at_limit).then_some(limit);
                    changed = true;
                }
                if let Some(v) = &mut sp.speed_kmh {
                    changed |= number(ui, by, v, 0.0..=300.0, 0.5, " km/h");
                }
            });
        });
        let mut limited = sp.max_vehicles.is_some();
        row(ui, "vehicles", |ui, by| {
            ui.horizontal(|ui| {
                if ui.checkbox(&mut limited, "at most").changed() {
                    sp.max_vehicles = limited.then_some(100);
                    changed = true;
                }
                match &mut sp.max_vehicles {
                    Some(n) => changed |= count(ui, by, n, 1..=1_000_000),
                    None => {
                        ui.weak("no limit");
                    }
                }
            });
        });
        changed |= row(ui, "", |ui, _| {
            ui.checkbox(&mut sp.active, "active").changed()
        });
    });
    if sp.interval_s.max < sp.interval_s.min {
        sp.interval_s.max = sp.interval_s.min;
    }
    ui.label(egui::RichText::new("driver profiles").strong());
    changed |= shares(ui, level, &mut sp.profiles, i);
    ui.label(egui::RichText::new("where its vehicles go").strong());
    changed |= routes(ui, level, &mut sp, i);
    if changed {
        app.edit_live(Command::SetSpawner(i, sp));
    }
    if ui.button("Delete spawner").clicked() {
        app.delete_selected();
    }
}

/// Where a spawner's vehicles go: along their lanes' links, to a destination by the quickest
/// path, or along routes chosen by weight (each a chain of linked roads, extended by choosing
/// among the roads the last one leads onto).
fn routes(ui: &mut egui::Ui, level: &Level, sp: &mut SpawnerSpec, i: usize) -> bool {
    #[derive(PartialEq, Clone, Copy)]
    enum Mode {
        Links,
        Destination,
        Routes,
    }
    let was = if !sp.routes.is_empty() {
        Mode::Routes
    } else if sp.destination.is_some() {
        Mode::Destination
    } else {
        Mode::Links
    };
    let mut mode = was;
    ui.horizontal(|ui| {
        ui.radio_value(&mut mode, Mode::Links, "follow the links")
            .on_hover_text("at a split, the first link that takes the lane");
        ui.radio_value(&mut mode, Mode::Destination, "to a road")
            .on_hover_text("the quickest path at free flow");
        ui.radio_value(&mut mode, Mode::Routes, "routes");
    });
    let names = road_names(level);
    let mut changed = mode != was;
    if changed {
        sp.routes.clear();
        sp.destination = None;
        match mode {
            Mode::Destination => {
                sp.destination = names.iter().find(|n| **n != sp.road).cloned();
            }
            Mode::Routes => sp.routes.push(RouteSpec {
                name: "route 1".to_owned(),
                roads: vec![sp.road.clone()],
                weight: 1.0,
            }),
            Mode::Links => {}
        }
    }
    if let Some(dest) = &mut sp.destination {
        egui::Grid::new(("destination", i)).show(ui, |ui| {
            changed |= row(ui, "road", |ui, by| {
                choice(ui, by, ("destination road", i), dest, &names)
            });
        });
    }
    let total: f64 = sp.routes.iter().map(|r| r.weight.max(0.0)).sum();
    let mut remove = None;
    for (k, route) in sp.routes.iter_mut().enumerate() {
        ui.push_id(("route", i, k), |ui| {
            ui.horizontal(|ui| {
                let by = ui.label(format!("{}.", k + 1)).id;
                if let Some(n) = text(ui, by, ("route name", i, k), &route.name) {
                    route.name = n.trim().to_owned();
                    changed = true;
                }
                changed |= weight(ui, by, &mut route.weight, total);
                if ui
                    .small_button("x")
                    .on_hover_text("remove the route")
                    .clicked()
                {
                    remove = Some(k);
                }
            });
            ui.horizontal_wrapped(|ui| {
                ui.weak(route.roads.join(", then "));
                let last = route
                    .roads
                    .last()
                    .cloned()
                    .unwrap_or_else(|| sp.road.clone());
                let onward: Vec<String> = level
                    .road(&last)
                    .map(|r| r.outgoing().into_iter().map(|l| l.to).collect())
                    .unwrap_or_default();
                if !onward.is_empty() {
                    let mut pick: Option<String> = None;
                    egui::ComboBox::new(("route next", i, k), "next road")
                        .selected_text("then…")
                        .show_ui(ui, |ui| {
                            for n in &onward {
                                ui.selectable_value(&mut pick, Some(n.clone()), n);
                            }
                        });
                    if let Some(n) = pick {
                        route.roads.push(n);
                        changed = true;
                    }
                }
                if route.roads.len() > 1
                    && ui
                        .small_button("−")
                        .on_hover_text("drop the last road")
                        .clicked()
                {
                    route.roads.pop();
                    changed = true;
                }
            });
        });
    }
    if let Some(k) = remove {
        sp.routes.remove(k);
        changed = true;
    }
    if mode == Mode::Routes && ui.button("Add route").clicked() {
        let n = (sp.routes.len() + 1..)
            .map(|n| format!("route {n}"))
            .find(|n| !sp.routes.iter().any(|r| &r.name == n))
            .unwrap_or_default();
        sp.routes.push(RouteSpec {
            name: n,
            roads: vec![sp.road.clone()],
            weight: 1.0,
        });
        changed = true;
    }
    changed
}

/// A spawner's profile shares: profile and weight per row, with each one's percentage.
fn shares(ui: &mut egui::Ui, level: &Level, shares: &mut Vec<ProfileShare>, i: usize) -> bool {
    let names: Vec<String> = level
        .driver_profiles
        .iter()
        .map(|p| p.name.clone())
        .collect();
    let total: f64 = shares.iter().map(|s| s.weight.max(0.0)).sum();
    let mut changed = false;
    let mut remove = None;
    egui::Grid::new(("shares", i))
        .num_columns(5)
        .show(ui, |ui| {
            for (k, share) in shares.iter_mut().enumerate() {
                let by = ui.label(format!("{}.", k + 1)).id;
                changed |= choice(ui, by, ("share", i, k), &mut share.profile, &names);
                changed |= weight(ui, by, &mut share.weight, total);
                if ui.small_button("x").on_hover_text("remove").clicked() {
                    remove = Some(k);
                }
                ui.end_row();
            }
        });
    if let Some(k) = remove {
        shares.remove(k);
        changed = true;
    }
    let unused = names
        .iter()
        .find(|n| !shares.iter().any(|s| &s.profile == *n));
    if let Some(n) = unused
        && ui.button("Add profile").clicked()
    {
        shares.push(ProfileShare {
            profile: n.clone(),
            weight: 1.0,
        });
        changed = true;
    }
    if names.is_empty() {
        error(
            ui,
            "The level has no driver profiles: add one in the Level panel.",
        );
    }
    changed
}

fn destroyer(ui: &mut egui::Ui, app: &mut AppState, level: &Level, i: usize, d: &DestroyerSpec) {
    ui.label(egui::RichText::new(format!("destroyer `{}`", d.name)).strong());
    ui.weak("Vehicles that reach it are removed; their travel times and the flow through it are measured.");
    let mut dest = d.clone();
    let mut changed = false;
    egui::Grid::new("destroyer").num_columns(2).show(ui, |ui| {
        row(ui, "name", |ui, by| {
            if let Some(n) = text(ui, by, ("destroyer name", i), &d.name) {
                dest.name = n.trim().to_owned();
                changed = true;
            }
        });
        let on_road = matches!(d.place, DestroyerPlaceSpec::OnRoad { .. });
        row(ui, "where", |ui, _| {
            ui.horizontal(|ui| {
                if ui.radio(on_road, "across a road").clicked()
                    && !on_road
                    && let Some(road) = level.roads.iter().find(|r| r.points.len() >= 2)
                {
                    dest.place = DestroyerPlaceSpec::OnRoad {
                        road: road.name.clone(),
                        s_m: 0.0,
                    };
                    changed = true;
                }
                if ui.radio(!on_road, "a box").clicked() && on_road {
                    let centre = app
                        .marker_position(MarkerKind::Destroyer, i)
                        .unwrap_or(DVec3::ZERO);
                    dest.place = DestroyerPlaceSpec::Volume {
                        min: centre - DVec3::new(5.0, 5.0, 1.0),
                        max: centre + DVec3::new(5.0, 5.0, 4.0),
                    };
                    changed = true;
                }
            });
        });
        match &mut dest.place {
            DestroyerPlaceSpec::OnRoad { road, s_m } => {
                if let Some((r, s)) = place(ui, app, level, "destroyer", road, *s_m) {
                    (*road, *s_m) = (r, s);
                    changed = true;
                }
            }
            DestroyerPlaceSpec::Volume { min, max } => {
                for (label, corner) in [("lower corner", min), ("upper corner", max)] {
                    changed |= row(ui, label, |ui, by| {
                        ui.horizontal(|ui| {
                            let a = number(ui, by, &mut corner.x, COORD_M, 0.1, " m");
                            let b = number(ui, by, &mut corner.y, COORD_M, 0.1, " m");
                            let c = number(ui, by, &mut corner.z, COORD_M, 0.1, " m");
                            a || b || c
                        })
                        .inner
                    });
                }
            }
        }
    });
    if changed {
        app.edit_live(Command::SetDestroyer(i, dest));
    }
    if ui.button("Delete destroyer").clicked() {
        app.delete_selected();
    }
}

fn trigger(ui: &mut egui::Ui, app: &mut AppState, level: &Level, i: usize, t: &TriggerSpec) {
    ui.label(egui::RichText::new(format!("trigger `{}`", t.name)).strong());
    let mut tr = t.clone();
    let mut changed = false;
    let lanes = lanes_of(level, &t.road);
    egui::Grid::new("trigger").num_columns(2).show(ui, |ui| {
        row(ui, "name", |ui, by| {
            if let Some(n) = text(ui, by, ("trigger name", i), &t.name) {
                tr.name = n.trim().to_owned();
                changed = true;
            }
        });
        let mut road = t.road.clone();
        if row(ui, "road", |ui, by| {
            choice(ui, by, ("trigger", "road"), &mut road, &road_names(level))
        }) {
            let len = app.road_length_m(&road).unwrap_or(20.0);
            tr.road = road;
            tr.from_m = tr.from_m.min(len);
            tr.to_m = tr.to_m.min(len);
            tr.lanes = None;
            changed = true;
        }
        let len = app
            .road_length_m(&tr.road)
            .unwrap_or(t.to_m.max(t.from_m).max(1.0));
        changed |= row(ui, "from", |ui, by| {
            number(ui, by, &mut tr.from_m, 0.0..=len, 0.25, " m")
        });
        changed |= row(ui, "to", |ui, by| {
            number(ui, by, &mut tr.to_m, 0.0..=len, 0.25, " m")
        });
        row(ui, "lanes", |ui, _| {
            ui.horizontal_wrapped(|ui| {
                let mut all = tr.lanes.is_none();
                if ui.checkbox(&mut all, "all").changed() {
                    tr.lanes = (!all).then(|| vec![0]);
                    changed = true;
                }
                if let Some(list) = &mut tr.lanes {
                    for k in 0..lanes {
                        let mut on = list.contains(&k);
                        if ui.checkbox(&mut on, k.to_string()).changed() {
                            if on {
                                list.push(k);
                                list.sort_unstable();
                            } else if list.len() > 1 {
                                list.retain(|x| *x != k);
                            }
                            changed = true;
                        }
                    }
                }
            });
        });
        let speed = matches!(t.effect, TriggerEffectSpec::SpeedLimit { .. });
        row(ui, "effect", |ui, _| {
            ui.horizontal(|ui| {
                if ui.radio(speed, "speed limit").clicked() && !speed {
                    tr.effect = TriggerEffectSpec::SpeedLimit {
                        kmh: level.road(&t.road).map_or(50.0, |r| r.speed_limit_kmh),
                    };
                    changed = true;
                }
                if ui.radio(!speed, "friction").clicked() && speed {
                    tr.effect = TriggerEffectSpec::Friction { scale: 0.6 };
                    changed = true;
                }
            });
        });
        match &mut tr.effect {
            TriggerEffectSpec::SpeedLimit { kmh } => {
                changed |= row(ui, "new limit", |ui, by| {
                    number(ui, by, kmh, SPEED_LIMIT_KMH, 0.5, " km/h")
                });
            }
            TriggerEffectSpec::Friction { scale } => {
                changed |= row(ui, "friction ×", |ui, by| {
                    number(ui, by, scale, 0.05..=2.0, 0.01, "")
                })
            }
        }
    });
    if matches!(tr.effect, TriggerEffectSpec::Friction { .. }) {
        ui.weak("Tyre friction is scaled while a vehicle is inside (0.6: wet asphalt).");
    } else {
        ui.weak("A vehicle entering gets the new limit and keeps it.");
    }
    if changed {
        app.edit_live(Command::SetTrigger(i, tr));
    }
    if ui.button("Delete trigger").clicked() {
        app.delete_selected();
    }
}
