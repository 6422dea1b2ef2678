//! The window, for real: play mode gives the same CSV bytes as `flockway run`, and the editor,
//! driven through real X input events under Xvfb, saves the level it was shown.
#![cfg(feature = "window")]

use flockway::app::{Camera, PlaySession, PlaySpeed};
use flockway::level::load_level;
use glam::{Vec2, Vec3};
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

/// An X server of our own, closed when dropped.
struct Xvfb(Child, String);

impl Xvfb {
    fn start() -> Xvfb {
        let display = format!(":{}", 50 + std::process::id() % 200);
        let child = Command::new("Xvfb")
            .args([
                display.as_str(),
                "-screen",
                "0",
                "1400x860x24",
                "-nolisten",
                "tcp",
            ])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("Xvfb runs (CI installs the xvfb package)");
        std::thread::sleep(Duration::from_millis(800));
        Xvfb(child, display)
    }

    fn xdotool(&self, args: &[&str]) {
        let status = Command::new("xdotool")
            .args(args)
            .env("DISPLAY", &self.1)
            .status()
            .expect("xdotool runs (CI installs the xdotool package)");
        assert!(status.success(), "xdotool {args:?}");
        std::thread::sleep(Duration::from_millis(250));
    }
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

#[test]
fn the_editor_driven_by_real_input_events_saves_the_level_it_shows() {
    let dir = tempfile::tempdir().expect("tempdir");
    let x = Xvfb::start();
    let mut editor = Command::new(env!("CARGO_BIN_EXE_flockway"))
        .arg("edit")
        .current_dir(dir.path())
        .env("DISPLAY", &x.1)
        .env(
            "FLOCKWAY_ASSETS",
            std::fs::canonicalize("assets").expect("assets"),
        )
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("flockway edit starts");
    let started = Instant::now();
    let window = loop {
        let out = Command::new("xdotool")
            .args(["search", "--name", "Flockway"])
            .env("DISPLAY", &x.1)
            .output()
            .expect("xdotool");
        let id = String::from_utf8_lossy(&out.stdout)
            .lines()
            .next()
            .map(str::to_owned);
        if let Some(id) = id {
            break id;
        }
        assert!(
            started.elapsed() < Duration::from_secs(30),
            "no editor window appeared"
        );
        std::thread::sleep(Duration::from_millis(200));
    };
    std::thread::sleep(Duration::from_millis(1500));
    x.xdotool(&["windowmove", &window, "0", "0"]);
    x.xdotool(&["windowfocus", "--sync", &window]);
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
    let size = Vec2::new(1400.0, 860.0);
    let camera = Camera::top_fit(
        Vec3::new(-50.0, -50.0, 0.0),
        Vec3::new(50.0, 50.0, 0.0),
        size.x / size.y,
    );
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
