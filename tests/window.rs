//! The window, for real: play mode gives the same CSV bytes as `flockway run`, and the editor,
//! driven through real X input events under Xvfb, goes from an empty level to cars driving and
//! saves the level it was shown.
#![cfg(feature = "window")]

use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use flockway::app::{AppState, Camera, EMPTY_VIEW_M, Editor, PlaySession, PlaySpeed};
use flockway::level::load_level;
use flockway::road::{RoadGeometry, RoadSpec};
use glam::{DVec3, Vec2, Vec3};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

#[test]
fn play_mode_writes_the_same_csv_bytes_as_a_headless_run() {
    let dir = tempfile::tempdir().expect("tempdir");
    let headless = dir.path().join("headless.csv");
    let out = Command::new(env!("CARGO_BIN_EXE_flockway"))
        .args([
            "run",
            "levels/dense_road_mixed.ron",
            "--quiet",
            "--seconds",
            "12",
            "--csv",
        ])
        .arg(&headless)
        .output()
        .expect("flockway runs");
    assert!(
        out.status.code().is_some_and(|c| c <= 1),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let level = load_level(Path::new("levels/dense_road_mixed.ron")).expect("level");
    let played = dir.path().join("played.csv");
    let assets = flockway::run::find_assets_dir(Some(Path::new("levels/dense_road_mixed.ron")));
    let mut session =
        PlaySession::start(level, "dense_road_mixed", &assets, &played).expect("play starts");
    // Frames of 1/60 s at 5×, as the window steps it, with a pause and single steps between.
    session.speed = PlaySpeed::X5;
    while session.sim_s() < 6.0 {
        session
            .advance(1.0 / 60.0, Duration::from_secs(1))
            .expect("advance");
    }
    session.paused = true;
    assert_eq!(
        session
            .advance(1.0, Duration::from_secs(1))
            .expect("paused"),
        0
    );
    for _ in 0..7 {
        session.step_ticks(1).expect("step");
    }
    session.paused = false;
    session.speed = PlaySpeed::Max;
    while session.sim_s() < 12.5 {
        session
            .advance(1.0 / 60.0, Duration::from_millis(50))
            .expect("advance");
    }
    let exported = dir.path().join("exported.csv");
    session.export_csv(&exported).expect("export");
    let a = std::fs::read(&headless).expect("headless csv");
    let b = std::fs::read(&exported).expect("played csv");
    assert!(a.len() > 1000, "the headless run sampled nothing");
    assert!(
        b.starts_with(&a),
        "the played CSV differs from the headless one within its first {} bytes",
        a.len()
    );
}

/// The window's size under Xvfb, pixels (one pixel per point).
const SIZE: (u32, u32) = (1400, 860);

/// One X server at a time: two started together can pick the same display number, and two
/// editors drawing on lavapipe at once only slow each other down.
static ONE_DISPLAY: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// An X server of our own, closed when dropped; holds [`ONE_DISPLAY`] while it lives, and the
/// read end of the pipe it told its display number on (closed, the server would die of SIGPIPE
/// when it next writes there).
struct Xvfb(
    Child,
    String,
    #[allow(dead_code)] std::sync::MutexGuard<'static, ()>,
    #[allow(dead_code)] Option<std::io::BufReader<std::process::ChildStdout>>,
);

impl Xvfb {
    /// Starts Xvfb on a display number it picks itself (`-displayfd`), so tests running at
    /// the same time never share one.
    fn start() -> Xvfb {
        use std::io::BufRead;
        let guard = ONE_DISPLAY.lock().unwrap_or_else(|e| e.into_inner());
        let screen = format!("{}x{}x24", SIZE.0, SIZE.1);
        let mut child = Command::new("Xvfb")
            .args([
                "-displayfd",
                "1",
                "-screen",
                "0",
                &screen,
                "-nolisten",
                "tcp",
            ])
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("Xvfb runs (scripts/test installs the xvfb package)");
        let mut line = String::new();
        let mut out = child.stdout.take().map(std::io::BufReader::new);
        if let Some(out) = &mut out {
            let _ = out.read_line(&mut line);
        }
        let number = line.trim().to_owned();
        assert!(!number.is_empty(), "Xvfb did not say which display it took");
        let display = format!(":{number}");
        // It names its display as it starts listening; wait until it answers a client.
        let started = Instant::now();
        while !Command::new("xdotool")
            .arg("getmouselocation")
            .env("DISPLAY", &display)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
        {
            assert!(
                started.elapsed() < Duration::from_secs(20),
                "Xvfb on {display} never answered"
            );
            std::thread::sleep(Duration::from_millis(100));
        }
        Xvfb(child, display, guard, out)
    }

    fn xdotool(&self, args: &[&str]) {
        let status = Command::new("xdotool")
            .args(args)
            .env("DISPLAY", &self.1)
            .status()
            .expect("xdotool runs (scripts/test installs the xdotool package)");
        assert!(status.success(), "xdotool {args:?}");
        std::thread::sleep(Duration::from_millis(250));
    }

    fn click(&self, (x, y): (f32, f32)) {
        self.xdotool(&[
            "mousemove",
            &format!("{}", x.round()),
            &format!("{}", y.round()),
            "click",
            "1",
        ]);
    }

    /// Starts `flockway edit` with no file in `dir` and waits for its window, moved to the
    /// screen's corner (there is no window manager to place it).
    fn editor(&self, dir: &Path) -> Child {
        // Now and then the editor's first connection to a server just started is refused
        // ("Failed to open connection to X server") although xdotool's succeeds: try again.
        let mut refusals = Vec::new();
        for _ in 0..3 {
            match self.try_editor(dir) {
                Ok(child) => return child,
                Err(message) => refusals.push(message),
            }
            std::thread::sleep(Duration::from_millis(500));
        }
        panic!(
            "no editor window appeared on display {}: {refusals:#?}",
            self.1
        );
    }

    fn try_editor(&self, dir: &Path) -> Result<Child, String> {
        let mut child = Command::new(env!("CARGO_BIN_EXE_flockway"))
            .arg("edit")
            .current_dir(dir)
            .env("DISPLAY", &self.1)
            .env(
                "FLOCKWAY_ASSETS",
                std::fs::canonicalize("assets").expect("assets"),
            )
            // Its autosave and play telemetry stay in the test's directory: no autosave of
            // another run is offered back, and this run leaves none behind.
            .env("TMPDIR", dir)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("flockway edit starts");
        let started = Instant::now();
        let window = loop {
            let out = Command::new("xdotool")
                .args(["search", "--name", "Flockway"])
                .env("DISPLAY", &self.1)
                .output()
                .expect("xdotool");
            if let Some(id) = String::from_utf8_lossy(&out.stdout).lines().next() {
                break id.to_owned();
            }
            if started.elapsed() > Duration::from_secs(30)
                || child.try_wait().ok().flatten().is_some()
            {
                let _ = child.kill();
                let out = child.wait_with_output().expect("editor output");
                return Err(format!(
                    "{}: {}",
                    out.status,
                    String::from_utf8_lossy(&out.stderr)
                ));
            }
            std::thread::sleep(Duration::from_millis(200));
        };
        self.xdotool(&["windowmove", &window, "0", "0"]);
        // The editor takes the keyboard focus once its first frame is shown (no window
        // manager here hands it out): from then on it takes keys and clicks.
        loop {
            let out = Command::new("xdotool")
                .arg("getwindowfocus")
                .env("DISPLAY", &self.1)
                .output()
                .expect("xdotool");
            if String::from_utf8_lossy(&out.stdout).trim() == window {
                break;
            }
            assert!(
                started.elapsed() < Duration::from_secs(60),
                "the editor window never took the keyboard focus"
            );
            std::thread::sleep(Duration::from_millis(200));
        }
        Ok(child)
    }
}

impl Drop for Xvfb {
    /// Stops the server politely (SIGTERM), so it removes its socket and lock file and the next
    /// test's server cannot meet them.
    fn drop(&mut self) {
        let stopped = Command::new("kill")
            .args(["-TERM", &self.0.id().to_string()])
            .status()
            .is_ok_and(|s| s.success());
        if !stopped {
            let _ = self.0.kill();
        }
        let _ = self.0.wait();
    }
}

/// Where the editor's widgets are: the same UI laid out off screen at the window's size
/// (egui lays out the same way on screen).
fn widget_centre(state: AppState, label: &str) -> (f32, f32) {
    let mut h = Harness::builder()
        .with_size(egui::vec2(SIZE.0 as f32, SIZE.1 as f32))
        .build_ui_state(|ui, app: &mut AppState| flockway::app::ui(ui, app), state);
    h.run();
    let c = h
        .get_by_role_and_label(egui::Role::Button, label)
        .rect()
        .center();
    (c.x, c.y)
}

fn new_app() -> AppState {
    AppState::new(
        Editor::new(),
        std::fs::canonicalize("assets").expect("assets"),
    )
}

/// The camera an empty level opens with, in a window of [`SIZE`]: the view is fitted to the
/// part of the window the panels leave to the scene, which a drawn frame tells.
fn empty_level_camera() -> (Camera, Vec2) {
    let size = Vec2::new(SIZE.0 as f32, SIZE.1 as f32);
    let mut h = Harness::builder()
        .with_size(egui::vec2(size.x, size.y))
        .build_ui_state(
            |ui, app: &mut AppState| flockway::app::ui(ui, app),
            new_app(),
        );
    h.run();
    let (_, lo, hi) = h.state().view_area().expect("a frame was drawn");
    // The harness draws the UI 8 px inside its edges; the panels keep their sizes, so in the
    // window the scene reaches 8 px further each way.
    let margin = Vec2::splat(8.0);
    let half = Vec3::new(EMPTY_VIEW_M, EMPTY_VIEW_M, 0.0);
    let camera = Camera::top_fit_area(-half, half, size, lo - margin, hi + margin);
    (camera, size)
}

#[test]
fn from_an_empty_editor_a_drawn_road_with_a_spawner_and_a_destroyer_gets_cars() {
    let dir = tempfile::tempdir().expect("tempdir");
    let x = Xvfb::start();
    let mut editor = x.editor(dir.path());
    let (camera, size) = empty_level_camera();
    // Find the buttons: the tools in the bar, and Play and `max` in the side panel.
    let spawner_tool = widget_centre(new_app(), "Spawner");
    let destroyer_tool = widget_centre(new_app(), "Destroyer");
    let play_button = widget_centre(new_app(), "Play");
    let mut playing = AppState::new(
        Editor::with_level(flockway::level::Template::Ring.level("r"), None),
        std::fs::canonicalize("assets").expect("assets"),
    );
    playing.play();
    let max_speed = widget_centre(playing, "max");

    // The Road tool by its key, before the mouse has touched the window; then four clicks.
    x.xdotool(&["key", "r"]);
    let clicks = [
        (150.0, 600.0),
        (400.0, 500.0),
        (650.0, 400.0),
        (950.0, 250.0),
    ];
    for c in clicks {
        x.click(c);
    }
    // With the Road tool on, a click on the Spawner button chooses that tool: no point added.
    x.click(spawner_tool);
    // The road as drawn: its points are where the clicks met the ground.
    let points: Vec<DVec3> = clicks
        .iter()
        .map(|&(px, py)| {
            let g = camera
                .ground_point(Vec2::new(px, py), size, 0.0)
                .expect("on the ground");
            (g.as_dvec3() * 1000.0).round() / 1000.0
        })
        .collect();
    let road = RoadGeometry::new(&RoadSpec::through("road 1", 2, 50.0, &points)).expect("a road");
    let on_road = |s: f64| {
        let p = camera
            .to_screen(road.frame_at(s).pos.as_vec3(), size)
            .expect("on screen");
        (p.x, p.y)
    };
    // The spawner 20 m from the start, the destroyer 15 m before the end.
    x.click(on_road(20.0));
    x.click(destroyer_tool);
    x.click(on_road(road.length_m() - 15.0));
    x.click(play_button);
    x.click(max_speed);
    // Play until the run's telemetry has passed 30 simulated seconds.
    let streamed = dir
        .path()
        .join(format!("flockway-play-{}.csv", editor.id()));
    play_until(&streamed, 31.0, Duration::from_secs(180));
    // End the run (its CSV goes beside the level), then save the level.
    x.xdotool(&["mousemove", "500", "780"]);
    x.xdotool(&["key", "Escape"]);
    x.xdotool(&["key", "ctrl+s"]);
    std::thread::sleep(Duration::from_millis(1000));
    let saved = dir.path().join("level.ron");
    let exported = dir.path().join("untitled_run.csv");
    let (saved_exists, exported_exists) = (saved.exists(), exported.exists());
    let _ = editor.kill();
    let output = editor.wait_with_output().expect("editor output");
    let _ = std::fs::remove_file(&streamed);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(saved_exists, "Ctrl+S did not save the level: {stderr}");
    assert!(
        exported_exists,
        "Esc did not export the run's CSV: {stderr}"
    );

    let level = load_level(&saved).expect("the saved level loads");
    assert_eq!(level.roads.len(), 1, "the toolbar click started no road");
    assert_eq!(
        level.roads[0].points.len(),
        4,
        "the toolbar click added no point"
    );
    for (got, want) in level.roads[0].points.iter().zip(&points) {
        assert!((got.pos - *want).length() < 0.01, "{} vs {want}", got.pos);
    }
    assert_eq!((level.spawners.len(), level.destroyers.len()), (1, 1));
    assert!((level.spawners[0].s_m - 20.0).abs() < 2.0);
    assert_eq!(level.spawners[0].profiles.len(), 2, "autonomous and human");

    // The CSV: vehicles were spawned, drove along the road and were destroyed.
    let csv = std::fs::read_to_string(&exported).expect("exported csv");
    let mut seen: std::collections::BTreeMap<u32, (f64, f64, f64)> = Default::default();
    let mut end = 0.0f64;
    for line in csv.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let (t, id, s): (f64, u32, f64) = (
            f[0].parse().expect("time"),
            f[1].parse().expect("id"),
            f[5].parse().expect("s"),
        );
        assert_eq!(f[3], "road 1");
        end = end.max(t);
        let e = seen.entry(id).or_insert((t, s, s));
        e.2 = s;
        e.0 = e.0.min(t);
    }
    assert!(seen.len() >= 5, "only {} vehicles were spawned", seen.len());
    let reached_end = seen
        .values()
        .filter(|(_, first, last)| *first < 25.0 && *last > road.length_m() - 40.0)
        .count();
    assert!(
        reached_end >= 1,
        "no vehicle drove from the spawner to the destroyer"
    );
    let last_sample: Vec<u32> = csv
        .lines()
        .skip(1)
        .filter(|l| l.starts_with(&format!("{end:.3},")))
        .filter_map(|l| l.split(',').nth(1)?.parse().ok())
        .collect();
    let destroyed = seen.keys().filter(|id| !last_sample.contains(id)).count();
    assert!(destroyed >= 1, "no vehicle was destroyed");

    // `flockway run` on the saved file gives the same bytes for the same 30 seconds.
    let headless = dir.path().join("headless.csv");
    let run = Command::new(env!("CARGO_BIN_EXE_flockway"))
        .args(["run", "--quiet", "--seconds", "30", "--csv"])
        .arg(&headless)
        .arg(&saved)
        .env(
            "FLOCKWAY_ASSETS",
            std::fs::canonicalize("assets").expect("assets"),
        )
        .output()
        .expect("flockway run");
    assert!(
        run.status.code().is_some_and(|c| c <= 1),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let a = std::fs::read(&headless).expect("headless csv");
    assert!(a.len() > 1000, "the headless run sampled nothing");
    assert!(
        csv.as_bytes().starts_with(&a),
        "the window's CSV differs from `flockway run`'s within its first {} bytes",
        a.len()
    );
}

#[test]
fn the_editor_driven_by_real_input_events_saves_the_level_it_shows() {
    let dir = tempfile::tempdir().expect("tempdir");
    let x = Xvfb::start();
    let mut editor = x.editor(dir.path());
    // The road tool, four clicks, a drag of the third point, undo, redo, save.
    x.xdotool(&["key", "r"]);
    let clicks = [(200, 600), (400, 300), (650, 500), (900, 250)];
    for (cx, cy) in clicks {
        x.xdotool(&["mousemove", &cx.to_string(), &cy.to_string(), "click", "1"]);
    }
    x.xdotool(&["mousemove", "650", "500", "mousedown", "1"]);
    for step in 1..=5 {
        x.xdotool(&[
            "mousemove",
            &(650 + 10 * step).to_string(),
            &(500 + 20 * step).to_string(),
        ]);
    }
    x.xdotool(&["mouseup", "1"]);
    x.xdotool(&["key", "ctrl+z"]);
    x.xdotool(&["key", "ctrl+shift+z"]);
    x.xdotool(&["key", "ctrl+s"]);
    std::thread::sleep(Duration::from_millis(1000));
    let saved = dir.path().join("level.ron");
    let exists = saved.exists();
    let _ = editor.kill();
    let output = editor.wait_with_output().expect("editor output");
    assert!(
        exists,
        "Ctrl+S did not save {}: {}",
        saved.display(),
        String::from_utf8_lossy(&output.stderr)
    );
    let level = load_level(&saved).expect("the saved level loads");
    assert_eq!(level.roads.len(), 1);
    let points: Vec<_> = level.roads[0].points.iter().map(|p| p.pos).collect();
    assert_eq!(points.len(), 4, "{points:?}");
    // Where each click meets the ground, seen through the editor's camera on an empty level.
    let (camera, size) = empty_level_camera();
    let expect = [
        (200.0, 600.0),
        (400.0, 300.0),
        (700.0, 600.0),
        (900.0, 250.0),
    ];
    for (p, (ex, ey)) in points.iter().zip(expect) {
        let want = camera
            .ground_point(Vec2::new(ex, ey), size, 0.0)
            .expect("on the ground");
        assert!(
            (p.as_vec3() - want).length() < 0.5,
            "point at {p}, expected {want} (the drag, undone and redone, must stand)"
        );
    }
    // And `flockway run` accepts it.
    let run = Command::new(env!("CARGO_BIN_EXE_flockway"))
        .args(["run", "--quiet", "--seconds", "1"])
        .arg(&saved)
        .output()
        .expect("flockway run");
    assert_eq!(
        run.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
}

/// Waits until the play telemetry streamed to `csv` has passed `sim_s` simulated seconds,
/// failing after `within` of wall time.
fn play_until(csv: &Path, sim_s: f64, within: Duration) {
    let started = Instant::now();
    loop {
        let text = std::fs::read_to_string(csv).unwrap_or_default();
        let last = text
            .lines()
            .last()
            .and_then(|l| l.split(',').next())
            .and_then(|t| t.parse::<f64>().ok())
            .unwrap_or(0.0);
        if last >= sim_s {
            break;
        }
        assert!(
            started.elapsed() < within,
            "play reached only {last} s of simulated time"
        );
        std::thread::sleep(Duration::from_millis(300));
    }
}

/// With `FLOCKWAY_SHOTS` set to a directory, saves the screen there as `name` (ImageMagick's
/// `import`), for the docs.
fn shoot(x: &Xvfb, name: &str) {
    if let Some(shots) = std::env::var_os("FLOCKWAY_SHOTS") {
        let _ = Command::new("import")
            .args(["-window", "root"])
            .arg(Path::new(&shots).join(name))
            .env("DISPLAY", &x.1)
            .status();
    }
}

/// Presses the left button at `from`, moves in small steps to `to` and lets go, as a hand would.
fn drag(x: &Xvfb, from: (f32, f32), to: (f32, f32)) {
    let at = |p: (f32, f32)| [format!("{}", p.0.round()), format!("{}", p.1.round())];
    let [fx, fy] = at(from);
    x.xdotool(&["mousemove", &fx, &fy, "mousedown", "1"]);
    for k in 1..=8 {
        let t = k as f32 / 8.0;
        let [mx, my] = at((from.0 + t * (to.0 - from.0), from.1 + t * (to.1 - from.1)));
        x.xdotool(&["mousemove", &mx, &my]);
    }
    x.xdotool(&["mouseup", "1"]);
}

#[test]
fn a_ramp_drawn_and_dragged_onto_a_road_side_joins_it_and_its_cars_merge() {
    let dir = tempfile::tempdir().expect("tempdir");
    let x = Xvfb::start();
    let mut editor = x.editor(dir.path());
    let (camera, size) = empty_level_camera();
    let screen = |wx: f32, wy: f32| {
        let p = camera
            .to_screen(Vec3::new(wx, wy, 0.0), size)
            .expect("on screen");
        assert!(
            p.x > 0.0 && p.y > 0.0 && p.x < 1000.0 && p.y < size.y,
            "{p}"
        );
        (p.x, p.y)
    };
    let spawner_tool = widget_centre(new_app(), "Spawner");
    let destroyer_tool = widget_centre(new_app(), "Destroyer");
    let play_button = widget_centre(new_app(), "Play");
    let mut playing = AppState::new(
        Editor::with_level(flockway::level::Template::Ring.level("r"), None),
        std::fs::canonicalize("assets").expect("assets"),
    );
    playing.play();
    let max_speed = widget_centre(playing, "max");

    // A straight road of 340 m, and a ramp ending beside it.
    x.xdotool(&["key", "r"]);
    for (wx, wy) in [(-170.0, 40.0), (0.0, 40.0), (170.0, 40.0)] {
        x.click(screen(wx, wy));
    }
    x.xdotool(&["key", "Return"]);
    for (wx, wy) in [(-160.0, -90.0), (-110.0, -50.0), (-90.0, -15.0)] {
        x.click(screen(wx, wy));
    }
    x.xdotool(&["key", "Return"]);
    // With the Select tool, the ramp's last point dragged onto the road, 80 m from its start.
    x.xdotool(&["key", "v"]);
    drag(&x, screen(-90.0, -15.0), screen(-90.0, 38.5));
    shoot(&x, "editor_join.png");
    // Spawners near both starts, a destroyer near the far end.
    x.click(spawner_tool);
    x.click(screen(-160.0, 40.0));
    x.click(screen(-152.0, -82.0));
    x.click(destroyer_tool);
    // (Between the control points of the road's last piece, which would take the click.)
    x.click(screen(128.0, 40.0));
    x.click(play_button);
    x.click(max_speed);
    let streamed = dir
        .path()
        .join(format!("flockway-play-{}.csv", editor.id()));
    play_until(&streamed, 61.0, Duration::from_secs(240));
    shoot(&x, "editor_on_ramp.png");
    x.xdotool(&["mousemove", "500", "780"]);
    x.xdotool(&["key", "Escape"]);
    x.xdotool(&["key", "ctrl+s"]);
    std::thread::sleep(Duration::from_millis(1000));
    let saved = dir.path().join("level.ron");
    let exported = dir.path().join("untitled_run.csv");
    let saved_exists = saved.exists();
    let _ = editor.kill();
    let output = editor.wait_with_output().expect("editor output");
    let _ = std::fs::remove_file(&streamed);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(saved_exists, "Ctrl+S did not save the level: {stderr}");

    // The road was cut into itself, a merge stretch and the rest; the ramp leads onto the
    // merge stretch's acceleration lanes.
    let level = load_level(&saved).expect("the saved level loads");
    let names: Vec<&str> = level.roads.iter().map(|r| r.name.as_str()).collect();
    assert_eq!(
        names,
        ["road 1", "road 1 merge", "road 1 on", "road 2"],
        "{stderr}"
    );
    let ramp = &level.roads[3];
    assert_eq!(
        ramp.outgoing().first().map(|l| l.to.as_str()),
        Some("road 1 merge"),
        "{}",
        std::fs::read_to_string(&saved).unwrap_or_default()
    );
    assert_eq!(level.roads[1].lanes, level.roads[0].lanes + ramp.lanes);
    assert_eq!(level.spawners.len(), 2);
    assert_eq!(level.spawners[1].road, "road 2");
    match &level.destroyers[0].place {
        flockway::level::DestroyerPlaceSpec::OnRoad { road, .. } => assert_eq!(road, "road 1 on"),
        other => panic!("{other:?}"),
    }

    // Cars from the ramp went through the merge stretch onto the rest of the road.
    let csv = std::fs::read_to_string(&exported).expect("exported csv");
    let mut roads: std::collections::BTreeMap<u32, Vec<String>> = Default::default();
    for line in csv.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let seen = roads.entry(f[1].parse().expect("id")).or_default();
        if seen.last().map(String::as_str) != Some(f[3]) {
            seen.push(f[3].to_owned());
        }
    }
    let merged = roads
        .values()
        .filter(|r| *r == &["road 2", "road 1 merge", "road 1 on"])
        .count();
    let through = roads
        .values()
        .filter(|r| *r == &["road 1", "road 1 merge", "road 1 on"])
        .count();
    assert!(
        merged >= 3 && through >= 3,
        "{merged} ramp cars and {through} main-road cars drove through: {roads:?}"
    );
}

/// The Play controls' `max` speed button, where it is while a level plays.
fn max_speed_button() -> (f32, f32) {
    let mut playing = AppState::new(
        Editor::with_level(flockway::level::Template::Ring.level("r"), None),
        std::fs::canonicalize("assets").expect("assets"),
    );
    playing.play();
    widget_centre(playing, "max")
}

/// Chooses a placing tool by its `key` and clicks where `at` is on screen; returns the ground
/// point the click met (mm-rounded, as the editor stores it).
fn place_by_key(x: &Xvfb, key: &str, camera: &Camera, size: Vec2, at: Vec3) -> DVec3 {
    x.xdotool(&["key", key]);
    let here = camera.to_screen(at, size).expect("on screen");
    x.click((here.x, here.y));
    let centre = camera
        .ground_point(here, size, 0.0)
        .expect("on the ground")
        .as_dvec3();
    (centre * 1000.0).round() / 1000.0
}

/// Where on screen road `name` of `prefab` is, `s` metres along it.
fn on_prefab(
    prefab: &flockway::level::Prefab,
    (camera, size): (&Camera, Vec2),
    name: &str,
    s: f64,
) -> (f32, f32) {
    let spec = prefab
        .roads
        .iter()
        .find(|r| r.name == name)
        .expect("a prefab road");
    let g = RoadGeometry::new(spec).expect("a road");
    let p = camera
        .to_screen(g.frame_at(s).pos.as_vec3(), size)
        .expect("on screen");
    (p.x, p.y)
}

/// Plays until `sim_s` simulated seconds, ends the run (Esc exports its CSV) and saves
/// (Ctrl+S), then closes the editor; returns the saved level and the exported CSV.
fn play_export_and_save(
    x: &Xvfb,
    mut editor: Child,
    dir: &Path,
    sim_s: f64,
    shot: &str,
) -> (std::path::PathBuf, std::path::PathBuf) {
    let streamed = dir.join(format!("flockway-play-{}.csv", editor.id()));
    play_until(&streamed, sim_s, Duration::from_secs(240));
    shoot(x, shot);
    x.xdotool(&["mousemove", "500", "780"]);
    x.xdotool(&["key", "Escape"]);
    x.xdotool(&["key", "ctrl+s"]);
    std::thread::sleep(Duration::from_millis(1000));
    let saved = dir.join("level.ron");
    let exported = dir.join("untitled_run.csv");
    let (saved_exists, exported_exists) = (saved.exists(), exported.exists());
    let _ = editor.kill();
    let output = editor.wait_with_output().expect("editor output");
    let _ = std::fs::remove_file(&streamed);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(saved_exists, "Ctrl+S did not save the level: {stderr}");
    assert!(exported_exists, "Esc did not export the run: {stderr}");
    (saved, exported)
}

#[test]
fn a_roundabout_placed_by_mouse_in_an_empty_editor_gets_cars_round_it() {
    let dir = tempfile::tempdir().expect("tempdir");
    let x = Xvfb::start();
    let editor = x.editor(dir.path());
    let (camera, size) = empty_level_camera();
    let spawner_tool = widget_centre(new_app(), "Spawner");
    let destroyer_tool = widget_centre(new_app(), "Destroyer");
    let play_button = widget_centre(new_app(), "Play");
    let max_speed = max_speed_button();

    // The Roundabout tool by its key, then one click where the ring's centre goes.
    let centre = place_by_key(&x, "o", &camera, size, Vec3::ZERO);
    shoot(&x, "roundabout_placed.png");
    // A spawner on the east arm's way in, a destroyer on the north arm's way out (the first
    // exit: a car without a route takes it).
    let prefab = flockway::level::roundabout("roundabout 1", centre);
    let on = |name: &str, s: f64| on_prefab(&prefab, (&camera, size), name, s);
    x.click(spawner_tool);
    x.click(on("roundabout 1 east in", 15.0));
    x.click(destroyer_tool);
    x.click(on("roundabout 1 north out", 45.0));
    shoot(&x, "roundabout_markers.png");
    x.click(play_button);
    x.click(max_speed);
    let (saved, exported) =
        play_export_and_save(&x, editor, dir.path(), 61.0, "roundabout_playing.png");

    // The level: the roundabout's twelve roads and four junctions where the click was.
    let level = load_level(&saved).expect("the saved level loads");
    assert_eq!(level.roads, prefab.roads);
    assert_eq!(level.junctions, prefab.junctions);
    assert_eq!(level.spawners.len(), 1);
    assert_eq!(level.spawners[0].road, "roundabout 1 east in");
    assert_eq!(level.destroyers.len(), 1);

    // The run: cars came in from the east, onto the ring, out at the north and were removed.
    let csv = std::fs::read_to_string(&exported).expect("exported csv");
    let mut roads_of: std::collections::BTreeMap<u32, Vec<String>> = Default::default();
    for line in csv.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let roads = roads_of.entry(f[1].parse().expect("id")).or_default();
        if roads.last().map(String::as_str) != Some(f[3]) {
            roads.push(f[3].to_owned());
        }
    }
    assert!(roads_of.len() >= 5, "only {} vehicles", roads_of.len());
    let through = roads_of
        .values()
        .filter(|r| {
            r.first().map(String::as_str) == Some("roundabout 1 east in")
                && r.iter().any(|x| x == "roundabout 1 ring east-north")
                && r.iter().any(|x| x == "roundabout 1 north out")
        })
        .count();
    assert!(through >= 3, "cars through the ring: {roads_of:?}");
    assert!(
        !roads_of
            .values()
            .any(|r| r.iter().any(|x| x == "roundabout 1 ring north-west")),
        "a car without a route went past its first exit: {roads_of:?}"
    );
}

#[test]
fn a_crossroads_placed_by_mouse_gets_cars_through_its_signal() {
    let dir = tempfile::tempdir().expect("tempdir");
    let x = Xvfb::start();
    let editor = x.editor(dir.path());
    let (camera, size) = empty_level_camera();
    let spawner_tool = widget_centre(new_app(), "Spawner");
    let destroyer_tool = widget_centre(new_app(), "Destroyer");
    let play_button = widget_centre(new_app(), "Play");
    let max_speed = max_speed_button();

    // The Crossroads tool by its key, one click where its centre goes.
    let centre = place_by_key(&x, "c", &camera, size, Vec3::new(20.0, -10.0, 0.0));
    shoot(&x, "crossroads_placed.png");
    let prefab = flockway::level::crossroads("crossroads 1", centre);
    let on = |name: &str, s: f64| on_prefab(&prefab, (&camera, size), name, s);
    // Cars from the west, straight on (no route) through the signal to the east.
    x.click(spawner_tool);
    x.click(on("crossroads 1 west in", 10.0));
    x.click(destroyer_tool);
    x.click(on("crossroads 1 east out", 60.0));
    x.click(play_button);
    x.click(max_speed);
    let (saved, exported) =
        play_export_and_save(&x, editor, dir.path(), 121.0, "crossroads_playing.png");

    let level = load_level(&saved).expect("the saved level loads");
    assert_eq!(level.roads, prefab.roads);
    assert_eq!(level.junctions, prefab.junctions);

    // Cars queued at red and went through on green: some stood still at the line, and more
    // than one reached the road beyond.
    let csv = std::fs::read_to_string(&exported).expect("exported csv");
    let mut through = std::collections::BTreeSet::new();
    let mut stood = false;
    for line in csv.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let (road, s, speed): (&str, f64, f64) =
            (f[3], f[5].parse().expect("s"), f[9].parse().expect("speed"));
        if road == "crossroads 1 east out" {
            through.insert(f[1].to_owned());
        }
        stood |= road == "crossroads 1 west in" && s > 80.0 && speed.abs() < 1.0;
    }
    assert!(through.len() >= 5, "only {} cars crossed", through.len());
    assert!(stood, "no car waited at the line");
    // The signals CSV was exported beside it: the program's changes, as a headless run writes.
    let signals = std::fs::read_to_string(dir.path().join("untitled_run.signals.csv"))
        .expect("the signals CSV beside the exported run");
    let mut lines = signals.lines();
    assert_eq!(
        lines.next(),
        Some(flockway::run::SIGNAL_COLUMNS.join(",").as_str())
    );
    // Twelve connections at the start, then changes through the phases of 120 s.
    assert!(lines.count() > 40, "{signals}");
}

#[test]
fn a_junctions_phase_table_is_edited_by_mouse_and_saved() {
    let dir = tempfile::tempdir().expect("tempdir");
    let x = Xvfb::start();
    let mut editor = x.editor(dir.path());
    let (camera, size) = empty_level_camera();

    // A crossroads placed, the Select tool (V), a click on the junction's middle.
    let centre = place_by_key(&x, "c", &camera, size, Vec3::new(10.0, 5.0, 0.0));
    let prefab = flockway::level::crossroads("crossroads 1", centre);
    x.xdotool(&["key", "v"]);
    let middle = camera.to_screen(centre.as_vec3(), size).expect("on screen");
    x.click((middle.x, middle.y));
    // Where the inspector's cells are, laid out for the same level and selection.
    let cell = |label: &str| {
        let mut state = AppState::new(
            Editor::with_level(
                flockway::level::Level {
                    roads: prefab.roads.clone(),
                    junctions: prefab.junctions.clone(),
                    ..Editor::new().level().clone()
                },
                None,
            ),
            std::fs::canonicalize("assets").expect("assets"),
        );
        state.selection = flockway::app::Selection::Junction(0);
        // The harness draws 8 px inside its edges: the side panel, held to the right edge,
        // is 8 px further right in the window and starts 8 px higher.
        let (x, y) = widget_centre(state, label);
        (x + 8.0, y - 8.0)
    };
    // The west arm's left turn (g) made amber in phase 0; the north arm's left turn in phase
    // 3 stepped back with a right click, from green-giving-way to green.
    x.click(cell("phase 0 connection 1"));
    let (cx, cy) = cell("phase 3 connection 10");
    x.xdotool(&[
        "mousemove",
        &format!("{}", cx.round()),
        &format!("{}", cy.round()),
        "click",
        "3",
    ]);
    // Closer, to see the numbered paths (the docs' picture of the phase table).
    // (The view zooms about the window's middle: the junction is dragged there first with the
    // middle button.)
    let (mx, my) = (
        format!("{}", middle.x.round()),
        format!("{}", middle.y.round()),
    );
    x.xdotool(&["mousemove", &mx, &my, "mousedown", "2"]);
    for k in 1..=10 {
        let f = k as f32 / 10.0;
        let (px, py) = (
            middle.x + f * (700.0 - middle.x),
            middle.y + f * (430.0 - middle.y),
        );
        x.xdotool(&[
            "mousemove",
            &format!("{}", px.round()),
            &format!("{}", py.round()),
        ]);
    }
    x.xdotool(&["mouseup", "2"]);
    for _ in 0..6 {
        x.xdotool(&["click", "4"]);
    }
    shoot(&x, "phase_table.png");
    x.xdotool(&["mousemove", "500", "780"]);
    x.xdotool(&["key", "ctrl+s"]);
    std::thread::sleep(Duration::from_millis(1000));
    let saved = dir.path().join("level.ron");
    let saved_exists = saved.exists();
    let _ = editor.kill();
    let output = editor.wait_with_output().expect("editor output");
    assert!(
        saved_exists,
        "Ctrl+S did not save the level: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    let level = load_level(&saved).expect("the saved level loads");
    let phases: Vec<String> = level.junctions[0]
        .signal
        .as_ref()
        .expect("a signal")
        .phases
        .iter()
        .map(|p| p.state.clone())
        .collect();
    let mut expected: Vec<String> = prefab.junctions[0]
        .signal
        .as_ref()
        .expect("a signal")
        .phases
        .iter()
        .map(|p| p.state.clone())
        .collect();
    expected[0] = "GyGGgGrrrrrr".to_owned();
    expected[3] = "rrrrrrGgGGGG".to_owned();
    assert_eq!(phases, expected);
    assert!(flockway::level::validate(&level).is_empty());
}
