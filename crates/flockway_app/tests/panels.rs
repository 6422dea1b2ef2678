//! The editor's panels and the play-mode HUD, rendered by egui_kittest (wgpu on lavapipe in CI)
//! and compared with the PNGs in `tests/snapshots/`. Run with `UPDATE_SNAPSHOTS=1` to accept a
//! deliberate change, then look at the new pictures before committing them.

use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use flockway_app::{AppState, Editor, Selection, Tool};
use std::path::Path;

const LEVEL: &str = "../../levels/sugiyama_ring.ron";

fn app() -> AppState {
    let editor = Editor::open(Path::new(LEVEL)).expect("shipped level");
    let mut app = AppState::new(editor, Path::new("../../assets").to_owned());
    // A fixed file field: the snapshot must not show a machine's paths.
    app.file_field = "levels/sugiyama_ring.ron".to_owned();
    app
}

#[test]
fn the_editor_panels_show_the_selected_point_and_road() {
    let mut state = app();
    state.tool = Tool::Road;
    state.selection = Selection::Point(0, 2);
    let mut harness = Harness::builder()
        .with_size(egui::vec2(1400.0, 860.0))
        .build_ui_state(|ui, app: &mut AppState| flockway_app::ui(ui, app), state);
    harness.run();
    for label in [
        "Inspector",
        "road `ring`",
        "point 2",
        "closed loop",
        "Insert after",
    ] {
        assert!(
            harness.query_by_label_contains(label).is_some(),
            "the inspector lacks `{label}`"
        );
    }
    harness.snapshot("editor_panels");
}

#[test]
fn the_play_hud_shows_the_level_monitor_and_its_chart() {
    let mut state = app();
    state.play();
    let session = state.play.as_mut().expect("playing");
    // Whole steps, not wall time: the figures are the same on every machine.
    session.step_ticks(120 * 20).expect("steps");
    state.toggle_pause();
    let mut harness = Harness::builder()
        .with_size(egui::vec2(1400.0, 860.0))
        .build_ui_state(|ui, app: &mut AppState| flockway_app::ui(ui, app), state);
    harness.run();
    for label in [
        "Level monitor",
        "sim time",
        "20.0 s",
        "mean speed",
        "Export CSV",
    ] {
        assert!(
            harness.query_by_label_contains(label).is_some(),
            "the HUD lacks `{label}`"
        );
    }
    harness.snapshot("play_hud");
}
