//! The `flockway` command end to end: exit codes, error messages, summaries and determinism.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn flockway(args: &[&str]) -> Output {
    flockway_with(args, &[])
}

/// `flockway` with these environment variables set.
fn flockway_with(args: &[&str], env: &[(&str, &str)]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_flockway"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env("RUST_BACKTRACE", "1")
        .envs(env.iter().copied())
        .output()
        .expect("the flockway binary runs")
}

fn shipped_levels() -> Vec<PathBuf> {
    let mut levels: Vec<PathBuf> =
        std::fs::read_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join("levels"))
            .expect("levels/ exists")
            .map(|e| e.expect("dir entry").path())
            .filter(|p| p.extension().is_some_and(|e| e == "ron"))
            .collect();
    levels.sort();
    assert!(
        levels.len() >= 3,
        "expected the shipped levels, found {levels:?}"
    );
    levels
}

#[test]
fn malformed_levels_exit_2_with_a_positioned_one_screen_error() {
    // (fixture, line:col the error must point at, words the message must contain)
    let cases = [
        ("truncated.ron", "19:41", "expected closing"),
        ("wrong_type.ron", "8:19", "expected integer"),
        ("unknown_field.ron", "9:13", "speed_limt_kmh"),
        ("unknown_road.ron", "13:19", "unknown road `mian`"),
        ("lane_out_of_range.ron", "11:30", "lane 2 is out of range"),
        ("nan_width.ron", "12:51", "width NaN"),
        ("billion_vehicles.ron", "11:31", "1000000000 vehicles"),
    ];
    for (file, at, words) in cases {
        let path = format!("tests/fixtures/bad/{file}");
        for command in [&["check", path.as_str()][..], &["run", path.as_str()][..]] {
            let out = flockway(command);
            let stderr = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(2), "{command:?}: {stderr}");
            assert!(
                stderr.contains(&format!("{path}:{at}: ")),
                "{command:?} should point at {at}: {stderr}"
            );
            assert!(
                stderr.contains(words),
                "{command:?} should say `{words}`: {stderr}"
            );
            assert!(
                !stderr.contains("panicked") && !stderr.contains("backtrace"),
                "{command:?} panicked: {stderr}"
            );
            assert!(
                stderr.lines().count() <= 20,
                "{command:?}: more than a screen: {stderr}"
            );
        }
    }
}

#[test]
fn missing_files_and_bad_arguments_exit_2() {
    let out = flockway(&["run", "levels/no_such_level.ron"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no_such_level.ron"));
    let out = flockway(&["run", "levels/dense_road.ron", "--seconds", "-3"]);
    assert_eq!(
        out.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = flockway(&["run", "levels/dense_road.ron", "--seed", "not-a-number"]);
    assert_eq!(out.status.code(), Some(2));
    // An action step that is not a whole number of ticks says what one is.
    let out = flockway(&["run", "levels/dense_road.ron", "--action-step", "0.013"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("--action-step 0.013") && stderr.contains("whole number"),
        "{stderr}"
    );
    let out = flockway(&["check"]);
    assert_eq!(out.status.code(), Some(2));
    // compare: a missing level, a missing network, no SUMO where it is said to be.
    let net = "tests/fixtures/sumo/cross.net.xml";
    let routes = "tests/fixtures/sumo/cross.rou.xml";
    let out = flockway(&["compare", "no_such.ron", "--net", net, "--routes", routes]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no_such.ron"));
    let level = "levels/sumo_grid_demand.ron";
    let out = flockway(&[
        "compare",
        level,
        "--net",
        "none.net.xml",
        "--routes",
        routes,
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("none.net.xml: no such file"));
    let out = flockway(&[
        "compare",
        level,
        "--net",
        net,
        "--routes",
        routes,
        "--sumo-bin",
        "/no/sumo/here",
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("eclipse-sumo"), "{stderr}");
    let out = flockway(&["compare", level]);
    assert_eq!(out.status.code(), Some(2), "neither --sumo nor --net");
}

/// Output read only in part (`flockway run … | head -1`) is no crash: the command finishes
/// and exits with its own status.
#[test]
fn a_reader_that_stops_early_is_no_crash() {
    let mut child = Command::new(env!("CARGO_BIN_EXE_flockway"))
        .args(["check", "levels/dense_road.ron", "levels/on_ramp.ron"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("the flockway binary runs");
    // Nothing reads its output: the first line written finds the pipe closed.
    drop(child.stdout.take());
    let out = child.wait_with_output().expect("it finishes");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(out.status.code(), Some(0), "{stderr}");
}

#[test]
fn help_documents_every_run_option() {
    let out = flockway(&["run", "--help"]);
    assert!(out.status.success());
    let help = String::from_utf8_lossy(&out.stdout);
    for flag in [
        "--seconds",
        "--seed",
        "--csv",
        "--summary",
        "--action-step",
        "--quiet",
        "LEVEL",
        "Exit status",
    ] {
        assert!(help.contains(flag), "run --help lacks {flag}:\n{help}");
    }
}

#[test]
fn every_shipped_level_checks_and_runs_passing_its_expectations() {
    let dir = tempfile::tempdir().expect("tempdir");
    let levels = shipped_levels();
    // The levels run side by side, one process per core: each run is single-threaded at this
    // size, and one after another they are the slowest test of the suite.
    let workers = std::thread::available_parallelism().map_or(1, |n| n.get());
    let next = std::sync::atomic::AtomicUsize::new(0);
    let measured: Vec<(String, Vec<String>)> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..workers)
            .map(|w| {
                let (levels, next, dir) = (&levels, &next, dir.path());
                scope.spawn(move || {
                    let mut out = Vec::new();
                    loop {
                        let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        let Some(level) = levels.get(i) else {
                            break out;
                        };
                        let summary = dir.join(format!("s{w}.json"));
                        out.push(check_and_run(level, &summary));
                    }
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().expect("a worker"))
            .collect()
    });
    // Every metric an expectation may name, seen measured by some shipped level's run.
    let mut seen = std::collections::BTreeSet::new();
    for (path, keys) in measured {
        for key in keys {
            let name = key.split('.').next().unwrap_or_default().to_owned();
            assert!(
                flockway::level::Metric::from_name(&name).is_some(),
                "{path}: the run measured `{key}`, which is not in the metric table"
            );
            seen.insert(name);
        }
    }
    for m in flockway::level::Metric::ALL {
        assert!(
            seen.contains(m.name()),
            "no shipped level's run measures `{}`: an expectation on it could never pass",
            m.name()
        );
    }
}

/// `flockway check` and `flockway run --quiet` on a level, which must pass: the level and the
/// metric names its run measured.
fn check_and_run(level: &Path, summary: &Path) -> (String, Vec<String>) {
    let path = level.to_string_lossy().into_owned();
    let out = flockway(&["check", &path]);
    assert!(
        out.status.success(),
        "check {path}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let summary_text = summary.to_string_lossy().into_owned();
    let out = flockway(&["run", &path, "--quiet", "--summary", &summary_text]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "run {path}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        out.stdout.is_empty(),
        "--quiet printed: {}",
        String::from_utf8_lossy(&out.stdout)
    );
    let s = flockway::run::Summary::read(summary).expect("the summary reads");
    (path, s.metrics.keys().cloned().collect())
}

#[test]
fn a_failed_expectation_exits_1_and_says_which() {
    let dir = tempfile::tempdir().expect("tempdir");
    let level = dir.path().join("short.ron");
    let text = std::fs::read_to_string("levels/sugiyama_ring.ron").expect("level");
    std::fs::write(
        &level,
        text.replace(
            "road_length_m.ring in 229.5..230.5",
            "road_length_m.ring > 300",
        ),
    )
    .expect("write");
    let out = flockway(&["run", level.to_str().expect("utf-8 path"), "--seconds", "1"]);
    assert_eq!(out.status.code(), Some(1));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("FAIL road_length_m.ring > 300  (measured 230.000)"),
        "{stdout}"
    );
    // One second is inside the warm-up: the speed statistics are not measured, and say so.
    assert!(
        stdout.contains("FAIL speed_std_kmh > 6  (not measured)"),
        "{stdout}"
    );
    assert!(
        stdout.contains("PASS collisions_guardrail == 0"),
        "{stdout}"
    );
    assert!(stdout.contains("1 passed, 5 failed"), "{stdout}");
}

/// Runs a level with CSV and summary output into `dir`; returns (csv bytes, summary JSON).
fn run_with_outputs(level: &Path, dir: &Path, tag: &str) -> (Vec<u8>, serde_json::Value) {
    let csv = dir.join(format!("{tag}.csv"));
    let summary = dir.join(format!("{tag}.json"));
    let out = flockway(&[
        "run",
        level.to_str().expect("utf-8 path"),
        "--quiet",
        "--csv",
        csv.to_str().expect("utf-8 path"),
        "--summary",
        summary.to_str().expect("utf-8 path"),
    ]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json = serde_json::from_slice(&std::fs::read(&summary).expect("summary written"))
        .expect("summary is JSON");
    (std::fs::read(&csv).expect("csv written"), json)
}

#[test]
fn runs_are_byte_identical_and_summaries_keep_their_contract() {
    let dir = tempfile::tempdir().expect("tempdir");
    for level in shipped_levels() {
        // The two runs side by side (two processes): the same result either way.
        let ((csv_a, mut a), (csv_b, mut b)) = std::thread::scope(|scope| {
            let first = scope.spawn(|| run_with_outputs(&level, dir.path(), "a"));
            let second = run_with_outputs(&level, dir.path(), "b");
            (first.join().expect("the first run"), second)
        });
        assert_eq!(
            csv_a,
            csv_b,
            "{}: CSV differs between runs",
            level.display()
        );
        let header = String::from_utf8(csv_a.clone()).expect("utf-8");
        assert!(header.starts_with("time_s,vehicle_id,driver,road,lane,s_m,x_m,y_m,z_m,speed_kmh,accel_mps2,throttle,steering,gear,rpm,model,route\n"));
        // It parses as CSV, has rows, and every sample time is a whole multiple of the period.
        let mut reader = csv::Reader::from_reader(csv_a.as_slice());
        let mut rows = 0;
        for record in reader.records() {
            let record = record.unwrap_or_else(|e| panic!("{}: {e}", level.display()));
            let t: f64 = record[0].parse().expect("time_s is a number");
            assert!(
                (t * 2.0 - (t * 2.0).round()).abs() < 1e-9,
                "time {t} is not a multiple of 0.5 s"
            );
            rows += 1;
        }
        assert!(rows > 0, "{}: no telemetry rows", level.display());
        for key in flockway::run::Summary::keys() {
            assert!(
                a.get(&key).is_some(),
                "{}: summary lacks `{key}`",
                level.display()
            );
        }
        assert_eq!(a["passed"], serde_json::Value::Bool(true));
        for e in a["expectations"].as_array().expect("a list") {
            assert!(
                e["name"].is_string() && e["passed"].is_boolean() && e["value"].is_number(),
                "{e}"
            );
        }
        assert!(a["ticks"].as_u64().expect("integer") > 0);
        // Everything but the wall-clock figures is identical.
        for v in [&mut a, &mut b] {
            let obj = v.as_object_mut().expect("an object");
            obj.remove("wall_seconds");
            obj.remove("realtime_factor");
        }
        assert_eq!(a, b, "{}: summaries differ", level.display());

        // The run's plots, drawn from its CSV, are real pictures.
        let plots = dir.path().join(level.file_stem().expect("a file name"));
        let out = flockway(&[
            "plot",
            dir.path().join("a.csv").to_str().expect("utf-8 path"),
            "--summary",
            dir.path().join("a.json").to_str().expect("utf-8 path"),
            "-o",
            plots.to_str().expect("utf-8 path"),
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let has_destroyers = a["flow_veh_per_h"]
            .as_object()
            .is_some_and(|f| !f.is_empty());
        for name in [
            "speed_history",
            "space_time",
            "mean_speed",
            "fundamental_diagram",
        ] {
            let path = plots.join(format!("{name}.png"));
            if name == "fundamental_diagram" && !has_destroyers {
                assert!(
                    !path.exists(),
                    "{}: a ring has no fundamental diagram",
                    level.display()
                );
                continue;
            }
            let (w, h, ink) = png_ink(&path);
            assert_eq!((w, h), (1600, 900), "{}", path.display());
            assert!(
                (0.01..0.7).contains(&ink),
                "{}: {:.1} % of the pixels are drawn",
                path.display(),
                ink * 100.0
            );
        }
    }
}

/// Size of a PNG and the share of its pixels that are not the white background.
fn png_ink(path: &Path) -> (u32, u32, f64) {
    let file = std::fs::File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut decoder = png::Decoder::new(std::io::BufReader::new(file));
    decoder.set_transformations(png::Transformations::normalize_to_color8());
    let mut reader = decoder.read_info().expect("a valid PNG");
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).expect("a PNG frame");
    let channels = info.color_type.samples();
    let pixels = buf[..info.buffer_size()].chunks(channels);
    let total = (info.width * info.height) as f64;
    let ink = pixels
        .filter(|p| p.iter().take(3).any(|&c| c < 245))
        .count() as f64;
    (info.width, info.height, ink / total)
}

#[test]
fn plots_come_as_svg_with_labelled_axes_and_reports_are_self_contained() {
    let dir = tempfile::tempdir().expect("tempdir");
    let d = |name: &str| {
        dir.path()
            .join(name)
            .to_str()
            .expect("utf-8 path")
            .to_owned()
    };
    let out = flockway(&[
        "run",
        "levels/dense_road_mixed.ron",
        "--quiet",
        "--seconds",
        "40",
        "--csv",
        &d("run.csv"),
        "--summary",
        &d("run.json"),
        "--plots",
        &d("plots"),
        "--plot-format",
        "svg",
    ]);
    // 40 s is inside the warm-up, so some expectations are not measured: exit 1, plots written.
    assert_eq!(
        out.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for (name, labels) in [
        (
            "speed_history",
            &[
                "time (s)",
                "speed (km/h)",
                "dense_road_mixed",
                "seed 43",
                "human",
            ][..],
        ),
        (
            "space_time",
            &["time (s)", "arc position (m)", "speed (km/h)"][..],
        ),
        (
            "mean_speed",
            &["time (s)", "speed (km/h)", "standard deviation"][..],
        ),
        (
            "fundamental_diagram",
            &["density (veh/km)", "flow (veh/h)"][..],
        ),
    ] {
        let svg = std::fs::read_to_string(dir.path().join("plots").join(format!("{name}.svg")))
            .unwrap_or_else(|e| panic!("{name}.svg: {e}"));
        assert!(
            svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"),
            "{name}"
        );
        for label in labels {
            assert!(svg.contains(label), "{name}.svg lacks `{label}`");
        }
    }

    let out = flockway(&[
        "report",
        &d("run.csv"),
        "--summary",
        &d("run.json"),
        "-o",
        &d("report.html"),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let html = std::fs::read_to_string(dir.path().join("report.html")).expect("report");
    assert_eq!(html.matches("<img").count(), 4, "four plots embedded");
    assert_eq!(html.matches("data:image/png;base64,").count(), 4);
    assert!(
        !html.contains("http://") && !html.contains("https://"),
        "no network"
    );
    for text in [
        "Expectations",
        "FAIL",
        "vehicles_spawned",
        "wave_detected",
        "mean_speed_kmh &lt; 52",
    ] {
        assert!(html.contains(text), "report lacks `{text}`");
    }
    // Without a summary it still reports what the CSV shows, and says what is missing.
    let out = flockway(&["report", &d("run.csv"), "-o", &d("bare.html")]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let bare = std::fs::read_to_string(dir.path().join("bare.html")).expect("report");
    assert!(bare.contains("No run summary was given") && bare.contains("vehicles seen"));
}

#[test]
fn foreign_or_malformed_csv_gives_a_clear_error() {
    let dir = tempfile::tempdir().expect("tempdir");
    let foreign = dir.path().join("foreign.csv");
    std::fs::write(&foreign, "t,id,v\n0,1,2\n").expect("write");
    for cmd in ["plot", "report"] {
        let mut args = vec![cmd, foreign.to_str().expect("utf-8 path")];
        let html = dir.path().join("r.html");
        if cmd == "report" {
            args.extend(["-o", html.to_str().expect("utf-8 path")]);
        }
        let out = flockway(&args);
        assert_eq!(out.status.code(), Some(2));
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains("foreign.csv") && err.contains("missing column `time_s`"),
            "{err}"
        );
    }
    let bad = dir.path().join("bad.csv");
    std::fs::write(
        &bad,
        "time_s,vehicle_id,driver,road,lane,s_m,x_m,y_m,z_m,speed_kmh,accel_mps2,throttle,steering,gear,rpm\n\
         0.500,1,auto,main,0,12.0,0,0,0,fast,0,0,0,3,2000\n",
    )
    .expect("write");
    let out = flockway(&[
        "plot",
        bad.to_str().expect("utf-8 path"),
        "-o",
        dir.path().to_str().expect("utf-8 path"),
    ]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("bad.csv:2") && err.contains("speed_kmh") && err.contains("`fast`"),
        "{err}"
    );
    let good = dir.path().join("good.csv");
    std::fs::write(
        &good,
        "time_s,vehicle_id,driver,road,lane,s_m,x_m,y_m,z_m,speed_kmh,accel_mps2,throttle,steering,gear,rpm\n\
         0.500,1,auto,main,0,12.0,0,0,0,50,0,0,0,3,2000\n",
    )
    .expect("write");
    let summary = dir.path().join("s.json");
    std::fs::write(&summary, "{\"x\": 1}").expect("write");
    let out = flockway(&[
        "plot",
        good.to_str().expect("utf-8 path"),
        "--summary",
        summary.to_str().expect("utf-8 path"),
        "-o",
        dir.path().to_str().expect("utf-8 path"),
    ]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("s.json") && err.contains("missing key `level`"),
        "{err}"
    );
}

#[test]
fn the_sugiyama_jam_travels_backwards_at_sugiyamas_speed_for_five_seeds() {
    // The level's expectations include `wave_speed_kmh in -25..-12`; `flockway test` runs them.
    let out = flockway(&["test", "levels/sugiyama_ring.ron", "--seeds", "5"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && stdout.contains("5 passed, 0 failed"),
        "{stdout}"
    );
}

#[test]
fn the_summary_is_readable_by_jq_when_jq_is_installed() {
    let Ok(jq) = Command::new("jq").arg("--version").output() else {
        // jq is a user convenience, not a dependency: the JSON itself is checked above.
        return;
    };
    assert!(jq.status.success());
    let dir = tempfile::tempdir().expect("tempdir");
    let (_, _) = run_with_outputs(Path::new("levels/dense_road.ron"), dir.path(), "j");
    let out = Command::new("jq")
        .args(["-r", ".level, .ticks, .passed, (.expectations | length)"])
        .arg(dir.path().join("j.json"))
        .output()
        .expect("jq runs");
    assert_eq!(
        String::from_utf8_lossy(&out.stdout),
        "dense_road\n14400\ntrue\n5\n"
    );
}

#[test]
fn dyno_json_has_exactly_the_contract_keys_and_the_reference_figures() {
    let out = flockway(&["dyno", "assets/vehicles/sedan.ron", "--json"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let v: serde_json::Value =
        serde_json::from_slice(&out.stdout).expect("dyno --json prints one JSON object");
    let obj = v.as_object().expect("an object");
    let mut keys: Vec<&str> = obj.keys().map(String::as_str).collect();
    keys.sort_unstable();
    assert_eq!(
        keys,
        [
            "braking_100_0_m",
            "max_lateral_g",
            "standstill_drift_m",
            "top_speed_kmh",
            "zero_to_100_kmh_s"
        ]
    );
    let get = |k: &str| obj[k].as_f64().unwrap_or(f64::NAN);
    assert!((9.0..=11.0).contains(&get("zero_to_100_kmh_s")), "{v}");
    assert!((168.0..=178.0).contains(&get("top_speed_kmh")), "{v}");
    assert!((33.0..=45.0).contains(&get("braking_100_0_m")), "{v}");
    assert!((0.75..=1.0).contains(&get("max_lateral_g")), "{v}");
    assert!(get("standstill_drift_m") < 0.01, "{v}");
    // Without a file it measures the same reference car, as a table.
    let out = flockway(&["dyno"]);
    let table = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success());
    for row in [
        "0-100 km/h",
        "top speed",
        "braking 100-0 km/h",
        "max lateral",
        "standstill drift",
    ] {
        assert!(table.contains(row), "table lacks {row}:\n{table}");
    }
}

#[test]
fn dyno_rejects_a_bad_vehicle_file_with_its_position() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("broken.ron");
    std::fs::write(
        &path,
        "(\n  name: \"broken\",\n  wheels: (radius_m: \"big\"),\n)\n",
    )
    .expect("write");
    let out = flockway(&["dyno", path.to_str().expect("utf-8 path")]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("broken.ron:3:"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    let path = dir.path().join("negative.ron");
    std::fs::write(&path, "(chassis: (mass_kg: -1.0))").expect("write");
    let out = flockway(&["dyno", path.to_str().expect("utf-8 path")]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("chassis.mass_kg"), "{stderr}");
}

#[test]
fn a_killed_run_leaves_a_valid_csv_of_what_it_sampled() {
    let dir = tempfile::tempdir().expect("tempdir");
    let csv = dir.path().join("killed.csv");
    let mut child = Command::new(env!("CARGO_BIN_EXE_flockway"))
        .args(["run", "levels/dense_road.ron", "--quiet", "--csv"])
        .arg(&csv)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .spawn()
        .expect("the flockway binary runs");
    // Wait until a few hundred rows are on disk, then kill it mid-run.
    let started = std::time::Instant::now();
    loop {
        let lines = std::fs::read_to_string(&csv).map_or(0, |t| t.lines().count());
        if lines > 300 || started.elapsed().as_secs() > 120 {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    child.kill().expect("kill");
    let _ = child.wait();
    let text = std::fs::read_to_string(&csv).expect("the csv exists");
    assert!(text.ends_with('\n'), "the last sample was flushed whole");
    let mut reader = csv::Reader::from_reader(text.as_bytes());
    let mut rows = 0;
    for record in reader.records() {
        let record = record.expect("every row is complete");
        assert_eq!(record.len(), flockway::telemetry::CSV_COLUMNS.len());
        rows += 1;
    }
    assert!(rows > 300, "{rows} rows");
}

/// Runs a level for `seconds` with `env` set and returns its CSV bytes.
fn csv_of_run(level: &str, seconds: &str, csv: &Path, env: &[(&str, &str)]) -> Vec<u8> {
    let out = Command::new(env!("CARGO_BIN_EXE_flockway"))
        .args(["run", level, "--quiet", "--seconds", seconds, "--csv"])
        .arg(csv)
        .envs(env.iter().copied())
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("the flockway binary runs");
    // A shortened run may miss its expectations (exit 1); it must not be refused (exit 2).
    assert!(
        matches!(out.status.code(), Some(0 | 1)),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    std::fs::read(csv).expect("csv written")
}

/// A C library whose every transcendental function (sin, atan2f, powf, exp...) answers one
/// floating-point step above the true C library: preloaded, it stands for a machine whose maths
/// round differently (another glibc, or its FMA variants on another CPU).
const NUDGED_LIBM: &str = r#"
#define _GNU_SOURCE
#include <dlfcn.h>
#include <math.h>
#define F1(name, T, up) T name(T x) { static T (*real)(T); \
    if (!real) real = (T (*)(T))dlsym(RTLD_NEXT, #name); return up(real(x), (T)INFINITY); }
#define F2(name, T, up) T name(T x, T y) { static T (*real)(T, T); \
    if (!real) real = (T (*)(T, T))dlsym(RTLD_NEXT, #name); return up(real(x, y), (T)INFINITY); }
#define BOTH1(n) F1(n, double, nextafter) F1(n##f, float, nextafterf)
#define BOTH2(n) F2(n, double, nextafter) F2(n##f, float, nextafterf)
BOTH1(sin) BOTH1(cos) BOTH1(tan) BOTH1(asin) BOTH1(acos) BOTH1(atan) BOTH1(sinh) BOTH1(cosh)
BOTH1(tanh) BOTH1(asinh) BOTH1(acosh) BOTH1(atanh) BOTH1(exp) BOTH1(exp2) BOTH1(expm1)
BOTH1(log) BOTH1(log2) BOTH1(log10) BOTH1(log1p) BOTH1(cbrt)
BOTH2(atan2) BOTH2(pow) BOTH2(hypot)
void sincos(double x, double *s, double *c) { *s = sin(x); *c = cos(x); }
void sincosf(float x, float *s, float *c) { *s = sinf(x); *c = cosf(x); }
/* Proof that the loader took it: it touches the file NUDGED_LIBM_LOADED names. */
#include <stdio.h>
#include <stdlib.h>
__attribute__((constructor)) static void loaded(void) {
    const char *mark = getenv("NUDGED_LIBM_LOADED");
    FILE *f = mark ? fopen(mark, "w") : NULL;
    if (f) fclose(f);
}
"#;

/// The same level must give the same bytes on every machine, whatever its C library's maths
/// round to: a CI machine once drew the play HUD's chart differently because glibc's atan2f and
/// powf fed the drivers. The simulation takes its maths from the `libm` crate, so running it
/// over a C library that answers differently must change nothing.
#[test]
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn the_simulation_does_not_depend_on_the_c_librarys_maths() {
    let dir = tempfile::tempdir().expect("tempdir");
    let source = dir.path().join("nudged_libm.c");
    let library = dir.path().join("nudged_libm.so");
    std::fs::write(&source, NUDGED_LIBM).expect("write the C source");
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".to_owned());
    let built = Command::new(&cc)
        .args(["-O2", "-shared", "-fPIC", "-o"])
        .arg(&library)
        .arg(&source)
        .args(["-lm", "-ldl"])
        .output()
        .unwrap_or_else(|e| panic!("`{cc}` (gcc, which CI installs) runs: {e}"));
    assert!(
        built.status.success(),
        "{}",
        String::from_utf8_lossy(&built.stderr)
    );
    let mark = dir.path().join("loaded");
    let nudged = [
        ("LD_PRELOAD", library.to_str().expect("utf-8 path")),
        ("NUDGED_LIBM_LOADED", mark.to_str().expect("utf-8 path")),
    ];
    // The Sugiyama ring is chaotic: a last-bit difference anywhere grows into a visible one.
    for (level, seconds) in [
        ("levels/sugiyama_ring.ron", "40"),
        ("levels/dense_road_mixed.ron", "20"),
    ] {
        let here = csv_of_run(level, seconds, &dir.path().join("here.csv"), &[]);
        let other = csv_of_run(level, seconds, &dir.path().join("other.csv"), &nudged);
        // A library the loader refused would prove nothing.
        assert!(mark.exists(), "the nudged maths library was not loaded");
        std::fs::remove_file(&mark).expect("remove the mark");
        assert!(here.len() > 1000, "{level}: the run sampled");
        assert!(
            here == other,
            "{level}: the CSV changes with the C library's maths"
        );
    }
}

#[test]
fn new_writes_each_template_as_a_level_that_runs_and_never_overwrites() {
    let dir = tempfile::tempdir().expect("tempdir");
    let assets = std::fs::canonicalize("assets").expect("assets");
    for template in ["straight", "ring", "empty"] {
        let path = dir.path().join(format!("{template}.ron"));
        let path_text = path.display().to_string();
        let out = flockway(&["new", &path_text, "--template", template]);
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert_eq!(
            out.status.code(),
            Some(0),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(
            stdout.contains(&format!("flockway run {path_text}")),
            "`new` prints the command that runs what it wrote: {stdout}"
        );
        // A second `new` on the same file refuses and leaves it as it was.
        let before = std::fs::read(&path).expect("written");
        let again = flockway(&["new", &path_text]);
        assert_eq!(again.status.code(), Some(2));
        assert!(String::from_utf8_lossy(&again.stderr).contains("already exists"));
        assert_eq!(std::fs::read(&path).expect("still there"), before);
        // `flockway run` runs it as it is, from anywhere (assets found by the variable).
        let summary = dir.path().join(format!("{template}.json"));
        let run = Command::new(env!("CARGO_BIN_EXE_flockway"))
            .args(["run", "--quiet", "--summary"])
            .arg(&summary)
            .arg(&path)
            .env("FLOCKWAY_ASSETS", &assets)
            .output()
            .expect("flockway run");
        assert_eq!(
            run.status.code(),
            Some(0),
            "{template}: {}",
            String::from_utf8_lossy(&run.stderr)
        );
        let s: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&summary).expect("summary"))
                .expect("json");
        let spawned = s["vehicles_spawned"].as_f64().unwrap_or(0.0);
        let destroyed = s["vehicles_destroyed"].as_f64().unwrap_or(0.0);
        let collisions = s["collisions_guardrail"].as_f64().unwrap_or(0.0)
            + s["collisions_vehicle"].as_f64().unwrap_or(0.0);
        match template {
            "straight" => {
                assert!(spawned > 10.0 && destroyed > 5.0, "{template}: {s}");
                assert_eq!(collisions, 0.0, "{template}: {s}");
            }
            "ring" => {
                assert_eq!(spawned, 20.0, "{template}: {s}");
                assert_eq!(collisions, 0.0, "{template}: {s}");
            }
            _ => {
                assert_eq!(spawned, 0.0, "{template}: {s}");
                // An empty world is run as asked, and said to be empty.
                let stderr = String::from_utf8_lossy(&run.stderr);
                assert!(stderr.contains("no vehicle drove"), "{template}: {stderr}");
            }
        }
        if template != "empty" {
            assert!(!String::from_utf8_lossy(&run.stderr).contains("no vehicle drove"));
        }
    }
    let bad = flockway(&["new", "x.ron", "--template", "circle"]);
    assert_eq!(bad.status.code(), Some(2));
}

#[test]
fn test_writes_every_run_s_summary_as_a_json_line_the_same_as_run_s() {
    let dir = tempfile::tempdir().expect("tempdir");
    let lines = dir.path().join("summaries.jsonl");
    let out = flockway(&[
        "test",
        "levels/sugiyama_ring.ron",
        "--seed-list",
        "4,2",
        "--seconds",
        "10",
        "--summaries",
        lines.to_str().expect("utf-8"),
    ]);
    // Ten seconds is too short for the ring's expectations: they fail (exit 1), and the
    // summaries are written all the same.
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    let text = std::fs::read_to_string(&lines).expect("the summaries");
    let summaries: Vec<serde_json::Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).expect("a JSON line"))
        .collect();
    assert_eq!(summaries.len(), 2);
    assert_eq!(summaries[0]["seed"], 4);
    assert_eq!(summaries[1]["seed"], 2);
    let one = dir.path().join("one.json");
    let run = flockway(&[
        "run",
        "levels/sugiyama_ring.ron",
        "--seed",
        "2",
        "--seconds",
        "10",
        "--summary",
        one.to_str().expect("utf-8"),
    ]);
    assert_eq!(run.status.code(), Some(1), "{run:?}");
    let single: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&one).expect("summary")).expect("json");
    assert_eq!(summaries[1]["metrics"], single["metrics"]);
}

#[test]
fn edit_apply_changes_a_level_headless_all_or_none_and_names_the_refused_edit() {
    let dir = tempfile::tempdir().expect("tempdir");
    let level = dir.path().join("crossroads.ron");
    std::fs::copy("levels/crossroads_signal.ron", &level).expect("copy");
    let before = std::fs::read(&level).expect("read");
    let edits = dir.path().join("edits.ron");
    // The third edit asks for more lanes than a road may have.
    std::fs::write(
        &edits,
        "// a variant\n[\n    Set(item: Road(\"west in\"), field: \"lanes\", value: 2),\n    \
         Set(item: Junction(\"crossroads\"), field: \"signal.phases.0.duration_s\", value: 20),\n    \
         Set(item: Road(\"east in\"), field: \"lanes\", value: 17),\n]\n",
    )
    .expect("write");
    let level_arg = level.to_str().expect("utf-8");
    let edits_arg = edits.to_str().expect("utf-8");
    let out = flockway(&["edit", level_arg, "--apply", edits_arg]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains(&format!("{edits_arg}:5:5: edit 3 of 3")),
        "the refused edit by number and line:col: {stderr}"
    );
    assert!(stderr.contains("lanes 17: expected 1 to 16"), "{stderr}");
    assert_eq!(
        std::fs::read(&level).expect("read"),
        before,
        "nothing written"
    );

    // Without the bad edit: written to another file, which checks and runs.
    let text = std::fs::read_to_string(&edits).expect("read");
    std::fs::write(&edits, text.replace("value: 17", "value: 1")).expect("write");
    let variant = dir.path().join("variant.ron");
    let variant_arg = variant.to_str().expect("utf-8");
    let out = flockway(&["edit", level_arg, "--apply", edits_arg, "-o", variant_arg]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains("applied 3 edit(s)"));
    let edited = flockway::level::load_level(&variant).expect("the variant loads");
    assert_eq!(edited.road("west in").expect("road").lanes, 2);
    let program = edited.junctions[0].signal.as_ref().expect("signal");
    assert_eq!(program.phases[0].duration_s, 20.0);
    assert_eq!(
        std::fs::read(&level).expect("read"),
        before,
        "the original is kept"
    );
    // It runs (a run shortened to 20 s may miss expectations meant for the whole level: exit 1).
    let out = flockway(&["run", variant_arg, "--seconds", "20"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(matches!(out.status.code(), Some(0 | 1)), "{stderr}");
    assert!(!stderr.contains("error:"), "{stderr}");

    // A script that is not a list of edits is an error at its position.
    std::fs::write(
        &edits,
        "[\n    Set(item: Road(\"west in\"), feld: \"lanes\"),\n]\n",
    )
    .expect("write");
    let out = flockway(&["edit", level_arg, "--apply", edits_arg]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains(&format!("{edits_arg}:2:")), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}

/// A ring of 52.5 km with 2 100 cars, autonomous and human-like: enough that every per-car
/// pass of the step runs over the task pool (the controls from 512 cars, the close-car search
/// from 2 048); 1 and 3 threads give the same bytes.
#[test]
fn the_thread_count_changes_no_byte_of_two_thousand_cars() {
    let dir = tempfile::tempdir().expect("tempdir");
    let radius = 52_500.0 / std::f64::consts::TAU;
    let points: Vec<String> = (0..40)
        .map(|k| {
            let a = std::f64::consts::TAU * f64::from(k) / 40.0;
            format!(
                "(pos: ({:.3}, {:.3}, 0.0))",
                radius * a.cos(),
                radius * a.sin()
            )
        })
        .collect();
    let level = format!(
        r#"(
    version: 1,
    name: "big_ring",
    seed: 5,
    duration_s: 3.0,
    roads: [(name: "ring", closed: true, lanes: 2, lane_width_m: 3.5, speed_limit_kmh: 90.0,
        points: [{points}])],
    vehicle_types: [
        (name: "sedan", path: "vehicles/sedan.ron"),
        (name: "sedan_human", path: "vehicles/sedan_human.ron"),
    ],
    driver_profiles: [
        (name: "autonomous", model: FlockLanes, vehicle: "sedan", params: "drivers/flock_lanes.ron"),
        (name: "human", model: Human, vehicle: "sedan_human", params: "drivers/human.ron"),
    ],
    vehicles: [
        (road: "ring", count: 1400, profile: "autonomous", from_m: 0.0, to_m: 35000.0, speed_kmh: 70.0, jitter_m: 2.0),
        (road: "ring", count: 700, profile: "human", from_m: 35000.0, to_m: 52400.0, speed_kmh: 70.0, jitter_m: 2.0),
    ],
)"#,
        points = points.join(", ")
    );
    let path = dir.path().join("big_ring.ron");
    std::fs::write(&path, level).expect("write");
    let mut outputs: Vec<Vec<u8>> = Vec::new();
    for threads in ["1", "3"] {
        let csv = dir.path().join(format!("run_{threads}.csv"));
        let env = [("FLOCKWAY_THREADS", threads)];
        outputs.push(csv_of_run(
            path.to_str().expect("a UTF-8 path"),
            "3",
            &csv,
            &env,
        ));
    }
    let rows = outputs[0].iter().filter(|&&b| b == b'\n').count();
    assert!(rows > 2_100, "every car in the telemetry: {rows} rows");
    assert!(
        outputs[0] == outputs[1],
        "the same bytes on 1 and 3 threads"
    );
}

#[test]
fn the_thread_count_changes_no_byte_of_a_run_and_a_bad_one_is_refused() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut outputs: Vec<Vec<u8>> = Vec::new();
    // Every per-car pass over the pool from one car: dense_road's hundred-odd cars are below
    // the passes' own thresholds.
    for threads in ["1", "2", "3"] {
        let csv = dir.path().join(format!("run_{threads}.csv"));
        let env = [
            ("FLOCKWAY_THREADS", threads),
            ("FLOCKWAY_PARALLEL_MIN", "1"),
        ];
        outputs.push(csv_of_run("levels/dense_road.ron", "30", &csv, &env));
    }
    // And with the passes' own thresholds, which split its hundred-odd cars over the join pool
    // (in two parts, and in three on three threads): as the step's timing chooses, switching
    // between split and one thread every few steps while it times both, and always.
    let csv = dir.path().join("run_default.csv");
    outputs.push(csv_of_run("levels/dense_road.ron", "30", &csv, &[]));
    let csv = dir.path().join("run_default_3.csv");
    outputs.push(csv_of_run(
        "levels/dense_road.ron",
        "30",
        &csv,
        &[("FLOCKWAY_THREADS", "3"), ("FLOCKWAY_SPLIT", "always")],
    ));
    assert!(outputs[0].len() > 10_000);
    assert!(
        outputs.iter().all(|o| *o == outputs[0]),
        "the same bytes on 1, 2 and 3 threads, every pass over the pool or each its own way"
    );
    let out = flockway_with(
        &["check", "levels/dense_road.ron"],
        &[("FLOCKWAY_THREADS", "many")],
    );
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("FLOCKWAY_THREADS=\"many\""));
    let out = flockway_with(
        &["check", "levels/dense_road.ron"],
        &[("FLOCKWAY_PARALLEL_MIN", "0")],
    );
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("FLOCKWAY_PARALLEL_MIN=\"0\""));
    let out = flockway_with(
        &["check", "levels/dense_road.ron"],
        &[("FLOCKWAY_SPLIT", "sometimes")],
    );
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("FLOCKWAY_SPLIT=\"sometimes\": expected auto or always"),
        "{err}"
    );
}
