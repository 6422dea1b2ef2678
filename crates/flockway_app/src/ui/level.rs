//! The Level panel: the level's own settings, its vehicle types and driver profiles (with the
//! parameters each model offers), the groups of vehicles present at the start, and the
//! expectations a run must meet (each checked as it is typed).

use super::widgets::{choice, count, error, lane, number, row, text, text_sized};
use crate::app::AppState;
use flockway_drivers::BuiltinModel;
use flockway_edit::Command;
use flockway_level::{
    DriverModel, DriverProfileSpec, Expectation, InitialVehiclesSpec, Level, MAX_DURATION_S,
    VehicleTypeSpec, validate,
};
use std::collections::BTreeMap;

/// The Level panel.
pub(super) fn level_panel(ui: &mut egui::Ui, app: &mut AppState) {
    let level = app.editor.level().clone();
    settings(ui, app, &level);
    ui.separator();
    vehicle_types(ui, app, &level);
    ui.separator();
    profiles(ui, app, &level);
    ui.separator();
    initial_vehicles(ui, app, &level);
    ui.separator();
    expectations(ui, app, &level);
}

fn settings(ui: &mut egui::Ui, app: &mut AppState, level: &Level) {
    ui.label(egui::RichText::new("level").strong());
    let mut name = level.name.clone();
    let mut description = level.description.clone();
    let mut seed = level.seed;
    let mut duration = level.duration_s;
    let mut telemetry = level.telemetry.clone();
    let mut changed = false;
    egui::Grid::new("level settings")
        .num_columns(2)
        .show(ui, |ui| {
            row(ui, "name", |ui, by| {
                if let Some(n) = text(ui, by, "level name", &level.name) {
                    name = n;
                    changed = true;
                }
            });
            row(ui, "description", |ui, by| {
                if let Some(d) = text(ui, by, "level description", &level.description) {
                    description = d;
                    changed = true;
                }
            });
            row(ui, "seed", |ui, by| {
                if let Some(t) = text(ui, by, "level seed", &level.seed.to_string()) {
                    match t.trim().parse::<u64>() {
                        Ok(v) => {
                            seed = v;
                            changed = true;
                        }
                        Err(_) => {
                            app.status = format!(
                                "Seed not changed: `{}` is not a whole number from 0 to {}",
                                t.trim(),
                                u64::MAX
                            );
                        }
                    }
                }
            });
            changed |= row(ui, "duration", |ui, by| {
                number(ui, by, &mut duration, 1.0..=MAX_DURATION_S, 1.0, " s")
            });
            changed |= row(ui, "sample every", |ui, by| {
                // Whole steps of 1/120 s, so every sample falls on a step.
                let mut steps = (telemetry.period_s * 120.0).round() as u32;
                let r = ui
                    .add(
                        egui::DragValue::new(&mut steps)
                            .range(1..=120 * 60)
                            .speed(1.0)
                            .custom_formatter(|v, _| format!("{:.3} s", v / 120.0))
                            .custom_parser(|t| {
                                t.trim_end_matches('s')
                                    .trim()
                                    .parse::<f64>()
                                    .ok()
                                    .map(|s| (s * 120.0).round())
                            }),
                    )
                    .labelled_by(by)
                    .changed();
                telemetry.period_s = f64::from(steps) / 120.0;
                r
            });
            changed |= row(ui, "statistics from", |ui, by| {
                number(
                    ui,
                    by,
                    &mut telemetry.stats_from_s,
                    0.0..=MAX_DURATION_S,
                    0.5,
                    " s",
                )
            });
        });
    ui.weak("Statistics (mean speeds, flows, the wave) leave out the warm-up before that time.");
    if changed {
        app.edit_live(Command::SetLevelInfo {
            name,
            description,
            seed,
            duration_s: duration,
            telemetry,
        });
    }
}

fn vehicle_types(ui: &mut egui::Ui, app: &mut AppState, level: &Level) {
    ui.label(egui::RichText::new("vehicle types").strong());
    let files = app.asset_files("vehicles");
    let mut remove = None;
    for (i, v) in level.vehicle_types.iter().enumerate() {
        ui.horizontal(|ui| {
            let mut edited = v.clone();
            let mut changed = false;
            let by = ui.label(format!("{}.", i + 1)).id;
            if let Some(n) = text_sized(ui, by, ("vehicle type", i), &v.name, 80.0) {
                edited.name = n.trim().to_owned();
                changed = true;
            }
            ui.scope(|ui| {
                ui.set_max_width(150.0);
                changed |= choice(ui, by, ("vehicle file", i), &mut edited.path, &files);
            });
            if ui.small_button("x").on_hover_text("remove").clicked() {
                remove = Some(i);
            }
            if changed {
                app.edit_live(Command::SetVehicleType(i, edited));
            }
        });
    }
    if let Some(i) = remove {
        app.apply(Command::DeleteVehicleType(i));
    }
    if ui.button("Add vehicle type").clicked() {
        let name = unique("vehicle", |n| {
            level.vehicle_types.iter().any(|v| v.name == n)
        });
        app.apply(Command::AddVehicleType(VehicleTypeSpec {
            name,
            path: files
                .first()
                .cloned()
                .unwrap_or_else(|| "vehicles/sedan.ron".to_owned()),
        }));
    }
}

fn unique(prefix: &str, taken: impl Fn(&str) -> bool) -> String {
    (1..)
        .map(|k| format!("{prefix} {k}"))
        .find(|n| !taken(n))
        .unwrap_or_else(|| prefix.to_owned())
}

fn model_name(m: &DriverModel) -> String {
    match m {
        DriverModel::Flock => "Flock".to_owned(),
        DriverModel::FlockLanes => "FlockLanes".to_owned(),
        DriverModel::Human => "Human".to_owned(),
        DriverModel::Idm => "Idm".to_owned(),
        DriverModel::WaveDamper => "WaveDamper".to_owned(),
        DriverModel::Custom(_) => "Custom".to_owned(),
    }
}

fn builtin(m: &DriverModel) -> Option<BuiltinModel> {
    flockway_runner::builtin_model(m).ok()
}

fn profiles(ui: &mut egui::Ui, app: &mut AppState, level: &Level) {
    ui.label(egui::RichText::new("driver profiles").strong());
    let vehicles: Vec<String> = level.vehicle_types.iter().map(|v| v.name.clone()).collect();
    let mut models: Vec<String> = BuiltinModel::ALL
        .iter()
        .map(|m| m.name().to_owned())
        .collect();
    models.push("Custom".to_owned());
    let driver_files = app.asset_files("drivers");
    let mut remove = None;
    for (i, p) in level.driver_profiles.iter().enumerate() {
        let header = format!("{} — {}", p.name, model_name(&p.model));
        egui::CollapsingHeader::new(header)
            .id_salt(("profile", i))
            .default_open(false)
            .show(ui, |ui| {
                let mut edited = p.clone();
                let mut changed = false;
                egui::Grid::new(("profile grid", i)).num_columns(2).show(ui, |ui| {
                    row(ui, "name", |ui, by| {
                        if let Some(n) = text_sized(ui, by, ("profile name", i), &p.name, 190.0) {
                            edited.name = n.trim().to_owned();
                            changed = true;
                        }
                    });
                    let mut model = model_name(&p.model);
                    if row(ui, "model", |ui, by| choice(ui, by, ("profile model", i), &mut model, &models)) {
                        edited.model = match BuiltinModel::from_name(&model) {
                            Some(m) => flockway_runner::level_model(m),
                            None => DriverModel::Custom(p.name.clone()),
                        };
                        // Parameters belong to a model: a new model starts from its own file.
                        edited.params = BuiltinModel::from_name(&model)
                            .map(|m| m.default_params_path().to_owned());
                        edited.set.clear();
                        changed = true;
                    }
                    if let DriverModel::Custom(name) = &p.model {
                        row(ui, "plugin name", |ui, by| {
                            if let Some(n) = text_sized(ui, by, ("custom", i), name, 190.0) {
                                edited.model = DriverModel::Custom(n.trim().to_owned());
                                changed = true;
                            }
                        });
                    }
                    changed |= row(ui, "vehicle", |ui, by| {
                        choice(ui, by, ("profile vehicle", i), &mut edited.vehicle, &vehicles)
                    });
                    if builtin(&p.model).is_some() {
                        let defaults = "built-in defaults".to_owned();
                        let mut file = p.params.clone().unwrap_or_else(|| defaults.clone());
                        let mut options = vec![defaults.clone()];
                        options.extend(driver_files.iter().cloned());
                        if row(ui, "parameters", |ui, by| {
                            choice(ui, by, ("profile file", i), &mut file, &options)
                        }) {
                            edited.params = (file != defaults).then_some(file);
                            changed = true;
                        }
                    }
                });
                if let Some(m) = builtin(&p.model) {
                    changed |= overrides(ui, &mut edited.set, m, i);
                } else {
                    ui.weak("A custom model is driven by a plugin of that name (see the docs on writing a driver).");
                }
                if let Some(problem) = app.profile_problem(p) {
                    error(ui, &problem);
                }
                if changed {
                    app.edit_live(Command::SetDriverProfile(i, edited));
                }
                if ui.button("Remove profile").clicked() {
                    remove = Some(i);
                }
            });
    }
    if let Some(i) = remove {
        app.apply(Command::DeleteDriverProfile(i));
    }
    if ui.button("Add profile").clicked() {
        let name = unique("profile", |n| {
            level.driver_profiles.iter().any(|p| p.name == n)
        });
        app.apply(Command::AddDriverProfile(DriverProfileSpec {
            name,
            model: DriverModel::FlockLanes,
            vehicle: vehicles.first().cloned().unwrap_or_default(),
            params: Some(BuiltinModel::FlockLanes.default_params_path().to_owned()),
            set: BTreeMap::new(),
        }));
    }
}

/// A profile's parameter overrides: one row per override, and a menu of the parameters the
/// model has that are not overridden yet.
fn overrides(
    ui: &mut egui::Ui,
    set: &mut BTreeMap<String, f64>,
    model: BuiltinModel,
    i: usize,
) -> bool {
    let mut changed = false;
    let mut remove = None;
    egui::Grid::new(("overrides", i))
        .num_columns(3)
        .show(ui, |ui| {
            for (name, value) in set.iter_mut() {
                let by = ui.monospace(name).id;
                changed |= number(ui, by, value, -1e6..=1e6, 0.01, "");
                if ui
                    .small_button("x")
                    .on_hover_text("back to the file's value")
                    .clicked()
                {
                    remove = Some(name.clone());
                }
                ui.end_row();
            }
        });
    if let Some(name) = remove {
        set.remove(&name);
        changed = true;
    }
    let free: Vec<String> = model
        .parameter_names()
        .into_iter()
        .filter(|n| !set.contains_key(n))
        .collect();
    ui.horizontal(|ui| {
        let by = ui.label("override").id;
        egui::ComboBox::from_id_salt(("add override", i))
            .selected_text("a parameter…")
            .width(ui.available_width().min(220.0))
            .show_ui(ui, |ui| {
                for n in free {
                    if ui.selectable_label(false, &n).clicked() {
                        let start = default_value(model, &n);
                        set.insert(n, start);
                        changed = true;
                    }
                }
            })
            .response
            .labelled_by(by);
    });
    changed
}

/// The model's built-in value of a parameter (0 when it has none, such as an unset speed).
fn default_value(model: BuiltinModel, name: &str) -> f64 {
    model.default_value(name).unwrap_or(0.0)
}

fn initial_vehicles(ui: &mut egui::Ui, app: &mut AppState, level: &Level) {
    ui.label(egui::RichText::new("vehicles at the start").strong());
    let roads: Vec<String> = level
        .roads
        .iter()
        .filter(|r| r.points.len() >= 2)
        .map(|r| r.name.clone())
        .collect();
    let profiles: Vec<String> = level
        .driver_profiles
        .iter()
        .map(|p| p.name.clone())
        .collect();
    let mut remove = None;
    for (i, g) in level.vehicles.iter().enumerate() {
        egui::CollapsingHeader::new(format!("{} × {} on `{}`", g.count, g.profile, g.road))
            .id_salt(("group", i))
            .show(ui, |ui| {
                let mut e = g.clone();
                let mut changed = false;
                let len = app.road_length_m(&g.road).unwrap_or(1.0);
                egui::Grid::new(("group grid", i))
                    .num_columns(2)
                    .show(ui, |ui| {
                        changed |= row(ui, "road", |ui, by| {
                            choice(ui, by, ("group road", i), &mut e.road, &roads)
                        });
                        let lanes = level.road(&e.road).map_or(1, |r| r.lanes);
                        e.lane = e.lane.min(lanes - 1);
                        changed |= row(ui, "lane", |ui, by| {
                            lane(ui, by, ("group lane", i), &mut e.lane, lanes)
                        });
                        changed |= row(ui, "how many", |ui, by| {
                            count(ui, by, &mut e.count, 1..=10_000)
                        });
                        changed |= row(ui, "profile", |ui, by| {
                            choice(ui, by, ("group profile", i), &mut e.profile, &profiles)
                        });
                        changed |= row(ui, "from", |ui, by| {
                            number(ui, by, &mut e.from_m, 0.0..=len, 0.5, " m")
                        });
                        let mut whole = e.to_m.is_none();
                        row(ui, "to", |ui, by| {
                            ui.horizontal(|ui| {
                                if ui.checkbox(&mut whole, "the road's end").changed() {
                                    e.to_m = (!whole).then_some(len);
                                    changed = true;
                                }
                                if let Some(to) = &mut e.to_m {
                                    changed |= number(ui, by, to, 0.0..=len, 0.5, " m");
                                }
                            });
                        });
                        let mut standing = e.speed_kmh.is_none();
                        row(ui, "speed", |ui, by| {
                            ui.horizontal(|ui| {
                                if ui.checkbox(&mut standing, "standing").changed() {
                                    e.speed_kmh = (!standing).then_some(30.0);
                                    changed = true;
                                }
                                if let Some(v) = &mut e.speed_kmh {
                                    changed |= number(ui, by, v, 0.0..=300.0, 0.5, " km/h");
                                }
                            });
                        });
                        changed |= row(ui, "jitter", |ui, by| {
                            number(ui, by, &mut e.jitter_m, 0.0..=50.0, 0.05, " m")
                        });
                    });
                if changed {
                    app.edit_live(Command::SetVehicles(i, e));
                }
                if ui.button("Remove group").clicked() {
                    remove = Some(i);
                }
            });
    }
    if let Some(i) = remove {
        app.apply(Command::DeleteVehicles(i));
    }
    if let (Some(road), Some(profile)) = (roads.first(), profiles.first())
        && ui
            .button("Add vehicles")
            .on_hover_text("cars spaced evenly along a lane at the start")
            .clicked()
    {
        app.apply(Command::AddVehicles(InitialVehiclesSpec {
            road: road.clone(),
            lane: 0,
            count: 10,
            profile: profile.clone(),
            from_m: 0.0,
            to_m: None,
            speed_kmh: None,
            jitter_m: 0.0,
        }));
    }
}

/// The problem with one expectation in this level, if any: its syntax, or what the level's
/// validation says of it (an unknown metric, road, destroyer or profile).
pub fn expectation_problem(level: &Level, text: &str) -> Result<Expectation, String> {
    let e = Expectation::parse(text).map_err(|e| e.to_string())?;
    let mut trial = level.clone();
    trial.expect = vec![e.clone()];
    let issues = validate(&trial);
    match issues.iter().find(|i| {
        matches!(
            i.path.first(),
            Some(flockway_level::PathStep::Field("expect"))
        )
    }) {
        Some(issue) => Err(issue.message.clone()),
        None => Ok(e),
    }
}

fn expectations(ui: &mut egui::Ui, app: &mut AppState, level: &Level) {
    ui.label(egui::RichText::new("expectations").strong());
    ui.add(
        egui::Label::new(
            egui::RichText::new(
                "What a run must show, e.g. `collisions == 0` or `mean_speed_kmh in 50..60`.",
            )
            .weak(),
        )
        .wrap(),
    );
    let mut list = level.expect.clone();
    let mut changed = false;
    let mut remove = None;
    egui::Grid::new("expectations")
        .num_columns(3)
        .show(ui, |ui| {
            for (i, e) in level.expect.iter().enumerate() {
                let current = e.to_string();
                let id = ui.make_persistent_id(("expectation", i));
                let by = ui.label(format!("{}.", i + 1)).id;
                let mut draft: String = ui
                    .data(|d| d.get_temp(id))
                    .unwrap_or_else(|| current.clone());
                let r = ui
                    .add_sized(
                        [PANEL_TEXT, ui.spacing().interact_size.y],
                        egui::TextEdit::singleline(&mut draft),
                    )
                    .labelled_by(by);
                if r.has_focus() {
                    ui.data_mut(|d| d.insert_temp(id, draft.clone()));
                } else {
                    ui.data_mut(|d| d.remove::<String>(id));
                }
                if r.lost_focus() && draft != current {
                    match expectation_problem(level, &draft) {
                        Ok(parsed) => {
                            list[i] = parsed;
                            changed = true;
                        }
                        Err(p) => app.status = format!("Expectation not changed: {p}"),
                    }
                }
                if ui.small_button("x").on_hover_text("remove").clicked() {
                    remove = Some(i);
                }
                ui.end_row();
                if r.has_focus()
                    && let Err(p) = expectation_problem(level, &draft)
                {
                    ui.label("");
                    error(ui, &p);
                    ui.end_row();
                }
            }
        });
    if let Some(i) = remove {
        list.remove(i);
        changed = true;
    }
    // A new expectation is typed into its own field and added once it is valid.
    let id = ui.make_persistent_id("new expectation");
    let mut draft: String = ui.data(|d| d.get_temp(id)).unwrap_or_default();
    let r = ui
        .horizontal(|ui| {
            let by = ui.label("add").id;
            ui.add(
                egui::TextEdit::singleline(&mut draft)
                    .hint_text("METRIC OP VALUE")
                    .desired_width(PANEL_TEXT),
            )
            .labelled_by(by)
        })
        .inner;
    let problem = (!draft.trim().is_empty()).then(|| expectation_problem(level, &draft));
    match &problem {
        Some(Err(p)) => error(ui, p),
        Some(Ok(_)) => {
            ui.weak("valid: press Enter to add it");
        }
        None => {}
    }
    if r.lost_focus()
        && ui.input(|i| i.key_pressed(egui::Key::Enter))
        && let Some(Ok(e)) = problem
    {
        list.push(e);
        changed = true;
        draft.clear();
    }
    ui.data_mut(|d| d.insert_temp(id, draft));
    if changed {
        app.apply(Command::SetExpectations(list));
    }
}

/// Width of the expectation fields, points.
const PANEL_TEXT: f32 = 230.0;
