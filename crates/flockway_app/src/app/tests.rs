//! The application state driven as the window drives it, without a window.

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
