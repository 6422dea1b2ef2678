//! The editor's panels and the play-mode HUD, rendered by egui_kittest (wgpu on lavapipe in CI)
//! and compared with the PNGs in `tests/snapshots/`, and the input rules of the scene (what a
//! click on a panel or on the scene does), driven through egui's own event queue.
//!
//! To accept a deliberate change of a picture, run once with `FLOCKWAY_BLESS=1` (as for every
//! golden output): it rewrites the snapshot and fails, so it can never be left on. Look at the
//! new pictures before committing them.

use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use flockway_app::{AppState, Editor, MarkerKind, Selection, SideTab, Tool};
use std::path::Path;

const LEVEL: &str = "../../levels/sugiyama_ring.ron";
const SIZE: egui::Vec2 = egui::vec2(1400.0, 860.0);

fn app() -> AppState {
    let editor = Editor::open(Path::new(LEVEL)).expect("shipped level");
    let mut app = AppState::new(editor, Path::new("../../assets").to_owned());
    // A fixed file field: the snapshot must not show a machine's paths.
    app.file_field = "levels/sugiyama_ring.ron".to_owned();
    app
}

/// Compares the harness's picture with `tests/snapshots/NAME.png`, or rewrites that file (and
/// fails) when `FLOCKWAY_BLESS` is set.
fn snapshot(h: &mut Harness<'static, AppState>, name: &str) {
    if std::env::var_os("FLOCKWAY_BLESS").is_some() {
        let image = h.render().expect("the harness renders");
        image
            .save(format!("tests/snapshots/{name}.png"))
            .expect("write the snapshot");
        panic!(
            "FLOCKWAY_BLESS is set: {name}.png was rewritten; look at it, commit it, and run \
             again without it"
        );
    }
    h.snapshot(name);
}

fn harness(state: AppState) -> Harness<'static, AppState> {
    Harness::builder()
        .with_size(SIZE)
        .build_ui_state(|ui, app: &mut AppState| flockway_app::ui(ui, app), state)
}

/// A press and release of the left button at `pos` (points), as one frame's events.
fn click_at(h: &mut Harness<'static, AppState>, pos: egui::Pos2) {
    h.event(egui::Event::PointerMoved(pos));
    for pressed in [true, false] {
        h.event(egui::Event::PointerButton {
            pos,
            button: egui::PointerButton::Primary,
            pressed,
            modifiers: egui::Modifiers::NONE,
        });
    }
    h.run();
}

fn key(h: &mut Harness<'static, AppState>, key: egui::Key) {
    h.key_press(key);
    h.run();
}

#[test]
fn the_editor_panels_show_the_selected_point_and_road() {
    let mut state = app();
    state.tool = Tool::Road;
    state.selection = Selection::Point(0, 2);
    let mut harness = harness(state);
    harness.run();
    for label in [
        "Inspector",
        "road `ring`",
        "point 2",
        "closed loop",
        "Insert after",
        "230.0 m long, 1 lane(s), 12 point(s), a loop",
    ] {
        assert!(
            harness.query_by_label_contains(label).is_some(),
            "the inspector lacks `{label}`"
        );
    }
    snapshot(&mut harness, "editor_panels");
}

#[test]
fn the_spawner_inspector_edits_every_field_of_a_spawner() {
    let mut state = app_on("../../levels/dense_road_mixed.ron");
    state.selection = Selection::Marker(MarkerKind::Spawner, 1);
    let mut harness = harness(state);
    harness.run();
    for label in [
        "spawner `lane1`",
        "road",
        "at",
        "lane",
        "every",
        "initial speed",
        "vehicles",
        "active",
        "driver profiles",
        "Delete spawner",
    ] {
        assert!(
            harness.query_all_by_label_contains(label).next().is_some(),
            "the spawner inspector lacks `{label}`"
        );
    }
    snapshot(&mut harness, "spawner_inspector");
    // Switching the lane in its menu is one undoable edit.
    harness.get_by_label("lane").click();
    harness.run();
    harness.get_by_label("3 (leftmost)").click();
    harness.run();
    let state = harness.state_mut();
    assert_eq!(state.editor.level().spawners[1].lane, 3);
    state.undo();
    assert_eq!(state.editor.level().spawners[1].lane, 1);
}

fn app_on(level: &str) -> AppState {
    let editor = Editor::open(Path::new(level)).expect("shipped level");
    let mut app = AppState::new(editor, Path::new("../../assets").to_owned());
    app.file_field = "level.ron".to_owned();
    app
}

#[test]
fn the_level_panel_shows_settings_types_profiles_and_expectations() {
    let mut state = app_on("../../levels/dense_road_mixed.ron");
    state.side_tab = SideTab::Level;
    let mut harness = harness(state);
    harness.run();
    for label in [
        "name",
        "description",
        "seed",
        "duration",
        "sample every",
        "statistics from",
        "vehicle types",
        "Add vehicle type",
        "driver profiles",
        "autonomous — FlockLanes",
        "human — Human",
        "Add profile",
        "vehicles at the start",
        "expectations",
    ] {
        assert!(
            harness.query_all_by_label_contains(label).next().is_some(),
            "the Level panel lacks `{label}`"
        );
    }
    // Open the human profile: its model, vehicle, parameter file and overrides.
    harness.get_by_label("human — Human").click();
    harness.run();
    for label in ["model", "vehicle", "parameters", "override"] {
        assert!(
            harness.query_all_by_label_contains(label).next().is_some(),
            "the profile lacks `{label}`"
        );
    }
    snapshot(&mut harness, "level_panel");
}

#[test]
fn an_expectation_is_checked_as_it_is_typed() {
    let mut state = app_on("../../levels/dense_road.ron");
    state.side_tab = SideTab::Level;
    let before = state.editor.level().expect.len();
    let mut harness = harness(state);
    harness.run();
    let field = harness.get_by_label("add");
    field.click();
    harness.run();
    harness
        .get_by_label("add")
        .type_text("flow_veh_per_h.exit > 1");
    harness.run();
    assert!(
        harness
            .query_by_label_contains("unknown destroyer `exit`")
            .is_some(),
        "a destroyer the level does not have is named as the error"
    );
    // Fix it and press Enter: the expectation is added.
    for _ in 0.."exit > 1".len() {
        harness.key_press(egui::Key::Backspace);
    }
    harness.run();
    harness.get_by_label("add").type_text("end > 1");
    harness.run();
    assert!(
        harness
            .query_by_label_contains("valid: press Enter")
            .is_some()
    );
    harness.key_press(egui::Key::Enter);
    harness.run();
    let level = harness.state().editor.level();
    assert_eq!(level.expect.len(), before + 1);
    assert_eq!(
        level.expect.last().map(|e| e.to_string()),
        Some("flow_veh_per_h.end > 1".to_owned())
    );
}

#[test]
fn the_play_hud_shows_the_level_monitor_and_its_chart() {
    let mut state = app();
    state.play();
    let session = state.play.as_mut().expect("playing");
    // Whole steps, not wall time: the figures are the same on every machine.
    session.step_ticks(120 * 20).expect("steps");
    state.toggle_pause();
    let mut harness = harness(state);
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
    snapshot(&mut harness, "play_hud");
}

#[test]
fn a_challenge_s_hud_shows_its_score_and_medal_as_it_plays() {
    let mut state = app_on("../../levels/challenges/damp_the_wave.ron");
    state.play();
    assert!(state.play.is_some(), "{}", state.status);
    let session = state.play.as_mut().expect("playing");
    session.step_ticks(120 * 10).expect("steps");
    assert_eq!(
        session.score(),
        Some(("measured from 150 s".to_owned(), String::new()))
    );
    // Past the warm-up: the custom car plays untold (a lane-keeping flocking car), which
    // does not damp the wave: no medal, and the line says what bronze takes.
    session.step_ticks(120 * 160).expect("steps");
    let (value, medal) = session.score().expect("a challenge has a score");
    assert!(value.ends_with(" km/h"), "the score: {value}");
    assert_eq!(medal, "no medal (bronze from 2)");
    state.toggle_pause();
    let mut harness = harness(state);
    harness.run();
    for label in ["score", "no medal (bronze from 2)"] {
        assert!(
            harness.query_by_label_contains(label).is_some(),
            "the HUD lacks `{label}`"
        );
    }
    snapshot(&mut harness, "challenge_hud");
}

/// Where a point of a road's lane appears on the screen: `share` of the way along road `road`,
/// on lane `lane`.
fn road_point(app: &AppState, road: usize, share: f64, lane: u32) -> Option<egui::Pos2> {
    let name = &app.editor.level().roads.get(road)?.name;
    let net = app.network();
    let g = net.get(net.id(name)?)?;
    let at = flockway_app::spawner_spot(g, lane, share * g.length_m());
    let p = app.camera.to_screen(at, glam::Vec2::new(SIZE.x, SIZE.y))?;
    Some(egui::pos2(p.x, p.y))
}

/// The centre of a widget, in points.
fn centre_of(h: &Harness<'static, AppState>, label: &str) -> egui::Pos2 {
    h.get_by_label(label).rect().center()
}

#[test]
fn clicks_on_panels_never_reach_the_scene_and_the_first_click_on_the_scene_counts() {
    let editor = Editor::new();
    let mut h = harness(AppState::new(editor, Path::new("../../assets").to_owned()));
    h.run();
    // The very first event the window gets is a click on the scene, with the Road tool chosen
    // by its key: it starts a road.
    key(&mut h, egui::Key::R);
    assert_eq!(h.state().tool, Tool::Road);
    click_at(&mut h, egui::pos2(300.0, 500.0));
    assert_eq!(
        h.state().editor.level().roads.len(),
        1,
        "the first click counts"
    );
    click_at(&mut h, egui::pos2(700.0, 300.0));
    assert_eq!(h.state().editor.level().roads[0].points.len(), 2);
    // With the Road tool still on, a click on a toolbar button chooses that tool and adds no
    // point, even when the pointer jumps there and clicks within one frame.
    let spawner = centre_of(&h, "Spawner");
    click_at(&mut h, spawner);
    assert_eq!(h.state().tool, Tool::Spawner);
    assert_eq!(h.state().editor.level().roads.len(), 1);
    assert_eq!(h.state().editor.level().roads[0].points.len(), 2);
    // A click on the side panel and on the status bar: nothing is added either.
    click_at(&mut h, egui::pos2(1300.0, 600.0));
    click_at(&mut h, egui::pos2(300.0, 850.0));
    assert_eq!(h.state().editor.level().spawners.len(), 0);
    // On the road: a spawner with the level's two profiles, half and half, on the lane clicked.
    let on_road = road_point(h.state(), 0, 0.5, 0).expect("road on screen");
    click_at(&mut h, on_road);
    let level = h.state().editor.level();
    assert_eq!(level.spawners.len(), 1, "{}", h.state().status);
    let s = &level.spawners[0];
    assert_eq!(s.lane, 0);
    assert_eq!(s.speed_kmh, None, "the road's speed limit");
    let weights: Vec<(&str, f64)> = s
        .profiles
        .iter()
        .map(|p| (p.profile.as_str(), p.weight))
        .collect();
    assert_eq!(weights, [("autonomous", 0.5), ("human", 0.5)]);
    let on_left_lane = road_point(h.state(), 0, 0.3, 1).expect("road on screen");
    click_at(&mut h, on_left_lane);
    assert_eq!(h.state().editor.level().spawners[1].lane, 1);
}

#[test]
fn a_road_of_one_point_shows_a_hint_and_blocks_neither_tools_nor_play() {
    let editor = Editor::new();
    let mut h = harness(AppState::new(editor, Path::new("../../assets").to_owned()));
    h.run();
    key(&mut h, egui::Key::R);
    for p in [(300.0, 500.0), (700.0, 300.0), (900.0, 400.0)] {
        click_at(&mut h, egui::pos2(p.0, p.1));
    }
    key(&mut h, egui::Key::Enter);
    // A second road of one point, left as it is.
    click_at(&mut h, egui::pos2(300.0, 200.0));
    assert!(
        h.query_by_label_contains("click to add the next point, Enter to finish")
            .is_some()
            || h.state().drawing_hint().is_some()
    );
    assert_eq!(h.state().editor.level().roads[1].points.len(), 1);
    // Spawner and destroyer on the first road still go where they are clicked.
    h.state_mut().set_tool(Tool::Spawner);
    let a = road_point(h.state(), 0, 0.05, 0).expect("on screen");
    click_at(&mut h, a);
    h.state_mut().set_tool(Tool::Destroyer);
    let b = road_point(h.state(), 0, 0.97, 0).expect("on screen");
    click_at(&mut h, b);
    let level = h.state().editor.level();
    assert_eq!((level.spawners.len(), level.destroyers.len()), (1, 1));
    // Play runs without the unfinished road and says so.
    h.state_mut().play();
    assert!(h.state().play.is_some(), "{}", h.state().status);
    assert!(
        h.state().status.contains("single point"),
        "{}",
        h.state().status
    );
}

#[test]
fn refusals_say_what_is_wrong_and_what_to_do() {
    let editor = Editor::new();
    let mut state = AppState::new(editor, Path::new("../../assets").to_owned());
    let size = glam::Vec2::new(1400.0, 860.0);
    state.set_tool(Tool::Spawner);
    state.press(glam::Vec2::new(500.0, 400.0), size);
    assert!(
        state.status.contains("There is no road yet"),
        "{}",
        state.status
    );
    // A profile a spawner still uses cannot be deleted; the message names the spawner.
    let mut state = app_on("../../levels/dense_road_mixed.ron");
    assert!(!state.apply(flockway_app::Command::DeleteDriverProfile(1)));
    assert!(
        state.status.contains("is used by spawner"),
        "{}",
        state.status
    );
    // An edit that would make the level invalid is refused in words.
    let mut spawner = state.editor.level().spawners[0].clone();
    spawner.s_m = 5000.0;
    assert!(!state.apply(flockway_app::Command::SetSpawner(0, spawner)));
    assert!(
        state
            .status
            .starts_with("spawner `lane0`: spawn position 5000 m is outside road"),
        "{}",
        state.status
    );
}

#[test]
fn shortcuts_work_with_the_pointer_over_the_scene_even_after_typing_in_a_field() {
    let mut state = app();
    state.side_tab = SideTab::Level;
    let mut h = harness(state);
    h.run();
    // Type into the level's name field, then move the pointer over the scene and press V.
    h.get_by_label("name").click();
    h.run();
    h.event(egui::Event::PointerMoved(egui::pos2(400.0, 400.0)));
    h.run();
    h.state_mut().tool = Tool::Road;
    key(&mut h, egui::Key::V);
    assert_eq!(h.state().tool, Tool::Select);
}

#[test]
fn the_junction_inspector_edits_the_control_and_the_phase_table() {
    let mut harness = harness(app_on("../../levels/crossroads_signal.ron"));
    harness.run();
    // The overview lists the junction; a click selects it.
    harness
        .get_by_role_and_label(egui::Role::Link, "crossroads")
        .click();
    harness.run();
    harness.run();
    assert_eq!(harness.state().selection, Selection::Junction(0));
    for label in [
        "junction `crossroads`",
        "12 connection(s)",
        "right of way",
        "offset",
        "phases",
        "connections",
        "`west in` 0 -> `east out` 0",
        "Delete junction",
    ] {
        assert!(
            harness.query_all_by_label_contains(label).next().is_some(),
            "the junction inspector lacks `{label}`"
        );
    }
    snapshot(&mut harness, "junction_inspector");
    let program = |h: &Harness<'static, AppState>| -> Vec<(f64, String)> {
        h.state().editor.level().junctions[0]
            .signal
            .as_ref()
            .map(|s| {
                s.phases
                    .iter()
                    .map(|p| (p.duration_s, p.state.clone()))
                    .collect()
            })
            .unwrap_or_default()
    };
    let before = program(&harness);
    assert_eq!(before[0].1, "GgGGgGrrrrrr");
    // A click moves a state on: the permitted left (g) of connection 1 becomes amber.
    harness.get_by_label("phase 0 connection 1").click();
    harness.run();
    assert_eq!(program(&harness)[0].1, "GyGGgGrrrrrr");
    // A phase copied after itself, then removed again: each one step.
    harness.get_by_label("phase 3").click();
    harness.run();
    harness.run();
    harness.get_by_label("copy phase 3 after it").click();
    harness.run();
    assert_eq!(program(&harness).len(), 7);
    assert_eq!(program(&harness)[4], program(&harness)[3]);
    harness.get_by_label("phase 4").click();
    harness.run();
    harness.run();
    harness.get_by_label("remove phase 4").click();
    harness.run();
    assert_eq!(program(&harness).len(), 6);
    harness.get_by_label("phase 3").click();
    harness.run();
    harness.run();
    harness.get_by_label("move phase 3 up").click();
    harness.run();
    assert_eq!(program(&harness)[2].1, "rrrrrrGgGGgG");
    // Another control: a priority junction, its major roads along the first connection's axis,
    // and no signal program left behind.
    harness.get_by_label("right of way").click();
    harness.run();
    harness.get_by_label("priority").click();
    harness.run();
    let j = harness.state().editor.level().junctions[0].clone();
    assert_eq!(
        j.control,
        flockway_road::Control::Priority {
            major: vec!["west in".into(), "east in".into()],
            stop: false
        }
    );
    assert!(j.signal.is_none());
    // Every edit undoes on its own, back to the program the level had.
    for _ in 0..5 {
        harness.state_mut().undo();
    }
    harness.run();
    assert_eq!(program(&harness), before);
}
