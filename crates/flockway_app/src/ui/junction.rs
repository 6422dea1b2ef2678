//! The junction inspector: its name, how right of way is decided, and for a signal the phase
//! table — a row per phase (its duration and one state per connection), a column per
//! connection, each cell clicked through green, green-that-gives-way, amber and red.

use super::widgets::{choice, error, number, row, text};
use crate::app::AppState;
use flockway_edit::Command;
use flockway_road::{Control, Junction, JunctionSpec, Phase, SignalState, Turn};

/// The controls offered, as the inspector names them.
const CONTROLS: [&str; 4] = ["priority", "all-way stop", "right before left", "signal"];

/// The inspector of junction `i`.
pub(super) fn junction(ui: &mut egui::Ui, app: &mut AppState, i: usize, spec: &JunctionSpec) {
    ui.label(egui::RichText::new(format!("junction `{}`", spec.name)).strong());
    let built = app.built_junction(&spec.name).cloned();
    match &built {
        Some(b) => {
            let conflicts: usize = b.paths.iter().map(|p| p.conflicts.len()).sum();
            ui.label(format!(
                "{} connection(s), {} crossing or merging pair(s)",
                b.paths.len(),
                conflicts / 2
            ));
        }
        None => error(
            ui,
            "This junction cannot be built as drawn: a road it connects was moved, renamed \
             or deleted.",
        ),
    }
    let mut new = spec.clone();
    let mut control = control_name(&spec.control).to_owned();
    let mut live = false;
    let mut clicked = false;
    egui::Grid::new("junction").num_columns(2).show(ui, |ui| {
        row(ui, "name", |ui, by| {
            if let Some(n) = text(ui, by, ("junction name", i), &spec.name) {
                new.name = n;
                clicked = true;
            }
        });
        let options: Vec<String> = CONTROLS.iter().map(|&c| c.to_owned()).collect();
        if row(ui, "right of way", |ui, by| {
            choice(ui, by, ("junction control", i), &mut control, &options)
        }) {
            set_control(&mut new, &control, built.as_ref());
            clicked = true;
        }
    });
    match &spec.control {
        Control::Priority { major, stop } => {
            clicked |= priority(ui, &mut new, major, *stop);
        }
        Control::Signal => {
            let (l, c) = signal(ui, app, &mut new);
            live |= l;
            clicked |= c;
        }
        Control::AllWayStop => {
            ui.weak("Every driver stops at the line; they go in the order they stopped.");
        }
        Control::RightBeforeLeft => {
            ui.weak("Traffic from the right goes first; a turn across oncoming traffic gives way.");
        }
    }
    connections(ui, spec, built.as_ref());
    if live {
        app.edit_live(Command::SetJunction(i, new));
    } else if clicked {
        app.apply(Command::SetJunction(i, new));
    }
    ui.separator();
    if ui
        .button("Delete junction")
        .on_hover_text("its roads stay, no longer connected through it (Del)")
        .clicked()
    {
        app.delete_selected();
    }
}

fn control_name(c: &Control) -> &'static str {
    match c {
        Control::Priority { .. } => CONTROLS[0],
        Control::AllWayStop => CONTROLS[1],
        Control::RightBeforeLeft => CONTROLS[2],
        Control::Signal => CONTROLS[3],
    }
}

/// Switches `spec` to the control named `name`. A priority junction starts with the roads along
/// the first connection's axis as its major roads, a signal with a two-phase program; a signal's
/// program goes when the control is no longer a signal (undo brings it back).
fn set_control(spec: &mut JunctionSpec, name: &str, built: Option<&Junction>) {
    spec.control = match name {
        "priority" => Control::Priority {
            major: built.map_or_else(
                || {
                    spec.connections
                        .first()
                        .map(|c| c.from.clone())
                        .into_iter()
                        .collect()
                },
                along_first_axis,
            ),
            stop: false,
        },
        "all-way stop" => Control::AllWayStop,
        "right before left" => Control::RightBeforeLeft,
        _ => Control::Signal,
    };
    if spec.control == Control::Signal {
        if spec.signal.is_none() {
            spec.signal = Some(built.map_or_else(
                || flockway_road::SignalProgram {
                    offset_s: 0.0,
                    phases: vec![Phase {
                        duration_s: 30.0,
                        state: "G".repeat(spec.connections.len()),
                    }],
                },
                Junction::two_phase_program,
            ));
        }
    } else {
        spec.signal = None;
    }
}

/// The roads coming in along the first connection's axis, either way.
fn along_first_axis(j: &Junction) -> Vec<String> {
    let Some(first) = j.paths.first() else {
        return Vec::new();
    };
    let mut major: Vec<String> = Vec::new();
    for (p, c) in j.paths.iter().zip(&j.spec.connections) {
        if first.heading_in.dot(p.heading_in).abs() >= 0.7 && !major.contains(&c.from) {
            major.push(c.from.clone());
        }
    }
    major
}

/// The major roads (a tick per road coming in) and the stop sign. True when changed.
fn priority(ui: &mut egui::Ui, new: &mut JunctionSpec, major: &[String], stop: bool) -> bool {
    ui.label(egui::RichText::new("major roads (right of way)").strong());
    let mut incoming: Vec<&str> = Vec::new();
    for c in &new.connections {
        if !incoming.contains(&c.from.as_str()) {
            incoming.push(&c.from);
        }
    }
    let mut chosen: Vec<String> = major.to_vec();
    let mut changed = false;
    for road in &incoming {
        let mut on = major.iter().any(|m| m == road);
        if ui.checkbox(&mut on, format!("`{road}`")).changed() {
            if on {
                chosen.push((*road).to_owned());
            } else {
                chosen.retain(|m| m != road);
            }
            changed = true;
        }
    }
    let mut stop_now = stop;
    changed |= ui
        .checkbox(&mut stop_now, "minor roads stop at the line (stop sign)")
        .changed();
    // Keep the level's order of roads, whatever order they were ticked in.
    chosen.sort_by_key(|m| incoming.iter().position(|r| r == m));
    new.control = Control::Priority {
        major: chosen,
        stop: stop_now,
    };
    changed
}

/// The signal's offset and phase table. Returns (a value being dragged, a click).
fn signal(ui: &mut egui::Ui, app: &AppState, new: &mut JunctionSpec) -> (bool, bool) {
    let n = new.connections.len();
    let Some(program) = new.signal.as_mut() else {
        error(
            ui,
            "A signal without a program: choose another control, then signal again.",
        );
        return (false, false);
    };
    let (mut live, mut clicked) = (false, false);
    let cycle = program.cycle_s();
    egui::Grid::new("signal").num_columns(2).show(ui, |ui| {
        live |= row(ui, "offset", |ui, by| {
            number(
                ui,
                by,
                &mut program.offset_s,
                0.0..=cycle.max(0.0),
                0.1,
                " s",
            )
        });
        row(ui, "cycle", |ui, _| ui.label(format!("{cycle:.1} s")));
    });
    ui.label(egui::RichText::new("phases").strong());
    ui.weak(
        "Click a state to change it (right-click: back): G green, g green giving way, y amber, \
         r red. A phase's number opens copy, move and remove.",
    );
    // The phase showing now, while the level plays.
    let now = app
        .play
        .as_ref()
        .and_then(|p| program.phase_at(p.sim_s()))
        .map(|(k, _)| k);
    let mut action: Option<(usize, RowAction)> = None;
    egui::ScrollArea::horizontal()
        .id_salt("phase table")
        .show(ui, |ui| {
            // Narrow cells, so a four-arm junction's twelve connections fit the panel.
            ui.spacing_mut().button_padding = egui::vec2(3.0, 1.0);
            egui::Grid::new("phases")
                .num_columns(3 + n)
                .min_col_width(15.0)
                .spacing(egui::vec2(1.0, 3.0))
                .show(ui, |ui| {
                    ui.weak("#");
                    ui.weak("time");
                    for k in 0..n {
                        ui.weak(k.to_string());
                    }
                    ui.end_row();
                    let count = program.phases.len();
                    for (p, phase) in program.phases.iter_mut().enumerate() {
                        // The phase's number opens what can be done with the whole phase.
                        let number_text = if now == Some(p) {
                            egui::RichText::new(format!("{p}>")).strong()
                        } else {
                            egui::RichText::new(p.to_string())
                        };
                        let name = format!("phase {p}");
                        let button = ui
                            .add(egui::Button::new(number_text))
                            .on_hover_text("copy, move or remove this phase");
                        button.widget_info(|| {
                            egui::WidgetInfo::labeled(egui::Role::Button, true, &name)
                        });
                        egui::Popup::menu(&button).show(|ui| {
                            let items = [
                                (RowAction::Copy, format!("copy phase {p} after it"), true),
                                (RowAction::Up, format!("move phase {p} up"), p > 0),
                                (RowAction::Remove, format!("remove phase {p}"), count > 1),
                            ];
                            for (what, text, enabled) in items {
                                if ui.add_enabled(enabled, egui::Button::new(&text)).clicked() {
                                    action = Some((p, what));
                                    ui.close();
                                }
                            }
                        });
                        let duration = ui.add(
                            egui::DragValue::new(&mut phase.duration_s)
                                .range(0.5..=600.0)
                                .speed(0.1)
                                .max_decimals(3)
                                .suffix(" s"),
                        );
                        duration.widget_info(|| {
                            egui::WidgetInfo::labeled(
                                egui::Role::SpinButton,
                                true,
                                format!("phase {p} duration"),
                            )
                        });
                        live |= duration.changed();
                        clicked |= states(ui, p, &mut phase.state, n);
                        ui.end_row();
                    }
                });
        });
    if let Some((p, a)) = action {
        let phases = &mut program.phases;
        match a {
            RowAction::Copy => phases.insert(p + 1, phases[p].clone()),
            RowAction::Up => phases.swap(p - 1, p),
            RowAction::Remove => {
                phases.remove(p);
            }
        }
        clicked = true;
    }
    (live, clicked)
}

/// What a phase row's buttons do.
#[derive(Clone, Copy)]
enum RowAction {
    Copy,
    Up,
    Remove,
}

/// One phase's states as buttons, a letter each; a click moves one on to the next state (a
/// right click back). True when one changed.
fn states(ui: &mut egui::Ui, p: usize, state: &mut String, n: usize) -> bool {
    let mut letters: Vec<char> = state.chars().collect();
    letters.resize(n.max(letters.len()), 'r');
    let mut changed = false;
    for (k, letter) in letters.iter_mut().enumerate().take(n) {
        let s = SignalState::from_letter(*letter).unwrap_or(SignalState::Red);
        let (fill, ink) = colours(s);
        let button = egui::Button::new(
            egui::RichText::new(s.letter().to_string())
                .color(ink)
                .monospace(),
        )
        .fill(fill)
        .min_size(egui::vec2(15.0, 18.0));
        let r = ui
            .add(button)
            .on_hover_text(format!("phase {p}, connection {k}: {}", describe(s)));
        r.widget_info(|| {
            egui::WidgetInfo::labeled(
                egui::Role::Button,
                true,
                format!("phase {p} connection {k}"),
            )
        });
        let next = if r.clicked() {
            Some(cycle(s, true))
        } else if r.secondary_clicked() {
            Some(cycle(s, false))
        } else {
            None
        };
        if let Some(next) = next {
            *letter = next.letter();
            changed = true;
        }
    }
    if changed || letters.len() != state.chars().count() {
        *state = letters.into_iter().take(n).collect();
    }
    changed
}

/// The next state a click shows: green, green giving way, amber, red, green again.
fn cycle(s: SignalState, forward: bool) -> SignalState {
    const ORDER: [SignalState; 4] = [
        SignalState::Green,
        SignalState::GreenYield,
        SignalState::Amber,
        SignalState::Red,
    ];
    let k = ORDER.iter().position(|o| *o == s).unwrap_or(3);
    ORDER[if forward { (k + 1) % 4 } else { (k + 3) % 4 }]
}

fn describe(s: SignalState) -> &'static str {
    match s {
        SignalState::Green => "green",
        SignalState::GreenYield => "green, giving way",
        SignalState::Amber => "amber",
        SignalState::Red => "red",
    }
}

/// A state's button colours (fill, letter), as the signal heads in the scene show them.
fn colours(s: SignalState) -> (egui::Color32, egui::Color32) {
    match s {
        SignalState::Green => (egui::Color32::from_rgb(40, 170, 60), egui::Color32::WHITE),
        SignalState::GreenYield => (egui::Color32::from_rgb(150, 215, 130), egui::Color32::BLACK),
        SignalState::Amber => (egui::Color32::from_rgb(240, 175, 30), egui::Color32::BLACK),
        SignalState::Red => (egui::Color32::from_rgb(200, 45, 40), egui::Color32::WHITE),
    }
}

/// The connections, numbered as the phase table's columns: where each comes from and goes.
fn connections(ui: &mut egui::Ui, spec: &JunctionSpec, built: Option<&Junction>) {
    ui.label(egui::RichText::new("connections").strong());
    egui::Grid::new("connections")
        .num_columns(3)
        .striped(true)
        .show(ui, |ui| {
            for (k, c) in spec.connections.iter().enumerate() {
                ui.weak(k.to_string());
                // Roads named after their junction (as placed by a tool) without that name.
                let short = |road: &'_ str| -> String {
                    road.strip_prefix(&format!("{} ", spec.name))
                        .unwrap_or(road)
                        .to_owned()
                };
                ui.label(format!(
                    "`{}` {} -> `{}` {}",
                    short(&c.from),
                    c.from_lane,
                    short(&c.to),
                    c.to_lane
                ))
                .on_hover_text(format!(
                    "from lane {} of `{}` to lane {} of `{}`",
                    c.from_lane, c.from, c.to_lane, c.to
                ));
                let turn = built
                    .and_then(|b| b.paths.get(k))
                    .map_or("", |p| match p.turn {
                        Turn::Straight => "straight",
                        Turn::Left => "left",
                        Turn::Right => "right",
                        Turn::UTurn => "U-turn",
                    });
                ui.weak(turn);
                ui.end_row();
            }
        });
}
