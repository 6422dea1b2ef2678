//! The egui panels: file and tool bar, inspector, level settings, play controls, HUD with its
//! live chart, the status bar, and the scene's mouse and keyboard input. Pure functions of
//! [`AppState`], so they are tested without a window (egui_kittest) and with one (Xvfb).

mod input;
mod inspector;
mod junction;
mod level;
mod widgets;

use crate::app::{AppState, Pending, Selection, SideTab, Tool};
use crate::play::PlaySpeed;
use flockway_drivers::DriverLabel;
use flockway_render::ColourBy;
use flockway_vehicle::{Controls, Motion, VehicleState};
use std::path::PathBuf;

/// Width of the side panel, points.
pub const PANEL_WIDTH: f32 = 340.0;

/// Draws every panel and handles the scene's input; the rest of the window is the 3D scene.
pub fn ui(ui: &mut egui::Ui, app: &mut AppState) {
    input::shortcuts(ui.ctx(), app);
    egui::Panel::top("bar").show(ui, |ui| top_bar(ui, app));
    egui::Panel::bottom("status").show(ui, |ui| {
        ui.horizontal(|ui| {
            ui.label(&app.status);
            ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
                ui.weak(
                    "left: select / draw · drag: move · right-drag: orbit · middle-drag: pan · \
                     wheel: zoom",
                );
            });
        });
    });
    egui::Panel::right("side")
        .resizable(false)
        .exact_size(PANEL_WIDTH)
        .show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| {
                if app.play.is_some() {
                    play_panel(ui, app);
                } else {
                    play_controls(ui, app);
                    ui.separator();
                    ui.horizontal(|ui| {
                        ui.selectable_value(&mut app.side_tab, SideTab::Inspector, "Inspector");
                        ui.selectable_value(&mut app.side_tab, SideTab::Level, "Level");
                    });
                    ui.separator();
                    match app.side_tab {
                        SideTab::Inspector => inspector::inspector(ui, app),
                        SideTab::Level => level::level_panel(ui, app),
                    }
                }
            });
        });
    input::scene(ui, app);
    dialogs(ui, app);
    // A value dragged in a panel is one undo step: it ends when the button is let go.
    if !ui.input(|i| i.pointer.any_down()) {
        app.end_live_edit();
    }
}

fn top_bar(ui: &mut egui::Ui, app: &mut AppState) {
    ui.horizontal_wrapped(|ui| {
        if ui.button("New").clicked() {
            app.request(Pending::New);
        }
        let label = ui.label("file");
        ui.add(egui::TextEdit::singleline(&mut app.file_field).desired_width(150.0))
            .labelled_by(label.id);
        if ui.button("Open").clicked() {
            let path = PathBuf::from(app.file_field.trim());
            app.request(Pending::Open(path));
        }
        if ui.button("Save").on_hover_text("Ctrl+S").clicked() {
            let _ = app.save();
        }
        if ui.button("Save As").clicked() {
            let _ = app.save_as();
        }
        ui.separator();
        let editing = app.play.is_none();
        ui.add_enabled_ui(editing, |ui| {
            let undo = app.editor.undo_label();
            if ui
                .add_enabled(undo.is_some(), egui::Button::new("Undo"))
                .on_hover_text(format!("Ctrl+Z: {}", undo.unwrap_or("nothing")))
                .clicked()
            {
                app.undo();
            }
            let redo = app.editor.redo_label();
            if ui
                .add_enabled(redo.is_some(), egui::Button::new("Redo"))
                .on_hover_text(format!("Ctrl+Shift+Z: {}", redo.unwrap_or("nothing")))
                .clicked()
            {
                app.redo();
            }
            ui.separator();
            for (tool, label, hint) in [
                (
                    Tool::Select,
                    "Select",
                    "V: select and drag points, roads and markers",
                ),
                (
                    Tool::Road,
                    "Road",
                    "R: click to add points, Enter to finish the road",
                ),
                (
                    Tool::Spawner,
                    "Spawner",
                    "click on a lane to place a spawner",
                ),
                (
                    Tool::Destroyer,
                    "Destroyer",
                    "click on a road to place a destroyer",
                ),
                (
                    Tool::Trigger,
                    "Trigger",
                    "click on a road to place a speed-limit trigger",
                ),
                (
                    Tool::Roundabout,
                    "Roundabout",
                    "O: click on the ground to place a four-arm roundabout",
                ),
                (
                    Tool::Crossroads,
                    "Crossroads",
                    "C: click on the ground to place a four-arm signalised crossroads",
                ),
            ] {
                if ui
                    .selectable_label(app.tool == tool, label)
                    .on_hover_text(hint)
                    .clicked()
                {
                    app.set_tool(tool);
                }
            }
        });
        ui.separator();
        if ui.button("Top / Orbit").on_hover_text("Tab").clicked() {
            app.toggle_camera(16.0 / 9.0);
        }
        if ui.button("Fit").clicked() {
            app.fit_view(16.0 / 9.0);
        }
        ui.separator();
        ui.label(app.file_label());
        if app.editor.is_dirty() {
            ui.colored_label(egui::Color32::from_rgb(230, 160, 40), "unsaved");
        }
    });
}

fn play_controls(ui: &mut egui::Ui, app: &mut AppState) {
    ui.heading("Play");
    ui.horizontal(|ui| {
        let playing = app.play.as_ref().is_some_and(|p| !p.paused);
        if ui
            .add_enabled(!playing, egui::Button::new("Play"))
            .on_hover_text("Space")
            .clicked()
        {
            app.play();
        }
        if ui
            .add_enabled(playing, egui::Button::new("Pause"))
            .on_hover_text("Space")
            .clicked()
        {
            app.toggle_pause();
        }
        if ui
            .add_enabled(app.play.is_some(), egui::Button::new("Stop"))
            .on_hover_text("back to the level as edited")
            .clicked()
        {
            app.stop();
        }
        if ui.button("Step").on_hover_text("one fixed step").clicked() {
            if app.play.is_none() {
                app.play();
            }
            app.single_step();
        }
    });
    if let Some(p) = &mut app.play {
        ui.horizontal(|ui| {
            ui.label("speed");
            for s in [PlaySpeed::X1, PlaySpeed::X2, PlaySpeed::X5, PlaySpeed::Max] {
                ui.selectable_value(&mut p.speed, s, s.label());
            }
        });
    }
}

/// A linear RGB paint as the sRGB colour egui draws.
fn linear_to_colour32(c: [f32; 4]) -> egui::Color32 {
    egui::Rgba::from_rgb(c[0], c[1], c[2]).into()
}

fn play_panel(ui: &mut egui::Ui, app: &mut AppState) {
    play_controls(ui, app);
    let Some(p) = &mut app.play else { return };
    ui.separator();
    ui.heading("Level monitor");
    let s = p.stats();
    let score = p.score();
    egui::Grid::new("hud").num_columns(2).show(ui, |ui| {
        let mut row = |k: &str, v: String| {
            ui.label(k);
            ui.monospace(v);
            ui.end_row();
        };
        row("sim time", format!("{:.1} s", s.sim_s));
        row("real-time factor", format!("{:.2}×", s.realtime_factor));
        row("vehicles", s.alive.to_string());
        row("spawned / s", format!("{:.2}", s.spawned_per_s));
        row("mean speed", format!("{:.1} km/h", s.mean_speed_kmh));
        row(
            "collisions",
            format!(
                "{} guardrail, {} vehicle",
                s.collisions_guardrail, s.collisions_vehicle
            ),
        );
        if let Some((value, medal)) = score {
            row("score", value);
            if !medal.is_empty() {
                row("medal", medal);
            }
        }
    });
    ui.separator();
    let mut by = p.colour_by();
    ui.horizontal(|ui| {
        ui.label("paint cars by");
        ui.radio_value(&mut by, ColourBy::Driver, "driver");
        ui.radio_value(&mut by, ColourBy::Destination, "destination");
    });
    if by != p.colour_by() {
        p.set_colour_by(by);
    }
    if by == ColourBy::Destination {
        for (road, n, colour) in p.destinations() {
            ui.horizontal(|ui| {
                let (rect, _) =
                    ui.allocate_exact_size(egui::vec2(14.0, 14.0), egui::Sense::hover());
                ui.painter()
                    .rect_filled(rect, 3.0, linear_to_colour32(colour));
                ui.label(match road {
                    Some(r) => format!("to `{r}`: {n}"),
                    None => format!("no destination (follow the links): {n}"),
                });
            });
        }
    }
    let spawners = p.spawners();
    if !spawners.is_empty() {
        ui.separator();
        ui.heading("Spawners");
        for (name, mut lo, mut hi, mut share) in spawners {
            ui.label(&name);
            let a = ui.add(egui::Slider::new(&mut lo, 0.1..=10.0).text("min interval s"));
            let b = ui.add(egui::Slider::new(&mut hi, 0.1..=10.0).text("max interval s"));
            let c = ui.add(egui::Slider::new(&mut share, 0.0..=1.0).text("autonomous share"));
            if a.changed() || b.changed() || c.changed() {
                p.set_spawner(&name, lo, hi.max(lo), share);
            }
        }
    }
    ui.separator();
    ui.heading("Speeds");
    let series = |k: usize| -> egui_plot::PlotPoints<'_> {
        p.history.iter().map(|h| [h[0], h[k]]).collect()
    };
    let (mean, slowest, fastest) = (series(1), series(2), series(3));
    // The speed axis spans 0 to the next 10 km/h above the fastest car (1 km/h of room each
    // side): a scale that does not twitch as the slowest car's speed moves by a hair.
    let top = p.history.iter().map(|h| h[3]).fold(0.0, f64::max);
    let top = (top / 10.0).ceil().max(1.0) * 10.0;
    egui_plot::Plot::new("speeds")
        .height(160.0)
        .include_y(-1.0)
        .include_y(top + 1.0)
        .set_margin_fraction(egui::vec2(0.05, 0.0))
        .x_axis_label("time (s)")
        .y_axis_label("km/h")
        .allow_scroll(false)
        .legend(egui_plot::Legend::default())
        .show(ui, |plot| {
            plot.line(egui_plot::Line::new("fastest", fastest));
            plot.line(egui_plot::Line::new("mean", mean));
            plot.line(egui_plot::Line::new("slowest", slowest));
        });
    if let Selection::Vehicle(i) = app.selection
        && let Some(p) = &mut app.play
        && let Some(&entity) = p.next.ids.get(i)
    {
        ui.separator();
        ui.heading("Vehicle");
        let world = p.runner_mut().sim_mut().world_mut();
        if let Ok(e) = world.get_entity(entity) {
            let driver = e
                .get::<DriverLabel>()
                .map_or("?".into(), |d| format!("{} ({})", d.profile, d.model));
            let speed = e.get::<Motion>().map_or(0.0, |m| m.forward_mps * 3.6);
            let (gear, rpm) = e
                .get::<VehicleState>()
                .map_or((0, 0.0), |s| (s.gearbox.gear, s.rpm()));
            let (thr, steer) = e
                .get::<Controls>()
                .map_or((0.0, 0.0), |c| (c.throttle, c.steering));
            egui::Grid::new("vehicle").num_columns(2).show(ui, |ui| {
                for (k, v) in [
                    ("driver", driver),
                    ("speed", format!("{speed:.1} km/h")),
                    ("gear", gear.to_string()),
                    ("rpm", format!("{rpm:.0}")),
                    ("throttle", format!("{thr:+.2}")),
                    ("steering", format!("{steer:+.2}")),
                ] {
                    ui.label(k);
                    ui.monospace(v);
                    ui.end_row();
                }
            });
            ui.checkbox(&mut app.follow, "follow (F)");
        }
    }
    ui.separator();
    if ui.button("Export CSV").clicked() {
        let path = PathBuf::from(app.file_field.trim()).with_extension("csv");
        app.export(&path);
    }
    ui.weak("Esc ends the run and exports its CSV next to the level.");
}

fn dialogs(ui: &mut egui::Ui, app: &mut AppState) {
    if app.pending.is_some() {
        egui::Modal::new(egui::Id::unique("discard")).show(ui.ctx(), |ui| {
            ui.heading("Unsaved changes");
            ui.label("The level has changes that are not saved. Discard them?");
            ui.horizontal(|ui| {
                if ui.button("Discard").clicked() {
                    app.confirm(true);
                }
                if ui.button("Cancel").clicked() {
                    app.confirm(false);
                }
            });
        });
    }
    if app.recovered.is_some() {
        egui::Modal::new(egui::Id::unique("recover")).show(ui.ctx(), |ui| {
            ui.heading("Recover unsaved work?");
            ui.label("Flockway found an autosave newer than the level: it did not close cleanly.");
            ui.horizontal(|ui| {
                if ui.button("Recover").clicked()
                    && let Some(e) = app.recovered.take()
                {
                    app.editor = e;
                    app.apply_recovered();
                }
                if ui.button("Discard").clicked() {
                    app.recovered = None;
                }
            });
        });
    }
}
