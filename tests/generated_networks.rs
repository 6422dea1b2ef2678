//! Networks nobody here wrote, made as the tests run by SUMO's own `netgenerate` and `netconvert`
//! (from the Python registry's `eclipse-sumo`, which `scripts/test` installs; they are found in
//! the directory `FLOCKWAY_SUMO_BIN` names, else on `PATH`): grids, spiders and random networks
//! of three seeds, each with and without traffic lights (the grid's actuated), a grid with
//! sidewalks and pedestrian crossings, random junctions joined into clusters, a motorway with
//! ramps and a lane drop. Each imports into a valid level that builds and, run with a seed nobody
//! tuned for, spawns vehicles that reach its exits. Without the tools every test here says so on
//! stderr and passes.

#[allow(dead_code, reason = "shared with the tests that run shipped levels")]
mod common;

use common::{run, sumo_tool};
use flockway::level::{Level, import_sumo_net};
use std::path::{Path, PathBuf};
use std::process::Command;

/// A scratch directory for one network's files.
fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("generated_networks")
        .join(name);
    std::fs::create_dir_all(&dir).expect("a scratch directory");
    dir
}

/// Runs SUMO's `tool` with `args` and `-o NAME.net.xml` in the scratch directory, then imports
/// the network; `None` when the tool is not there.
fn generate(tool: &str, name: &str, args: &[&str]) -> Option<(Level, PathBuf)> {
    let bin = sumo_tool(tool)?;
    let dir = scratch(name);
    let net = dir.join(format!("{name}.net.xml"));
    let out = Command::new(bin)
        .current_dir(&dir)
        .args(args)
        .arg("-o")
        .arg(&net)
        .output()
        .expect("the SUMO tool runs");
    assert!(
        out.status.success(),
        "{tool} {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(&net).expect("the network file");
    let level = import_sumo_net(&text, &net, name)
        .unwrap_or_else(|e| panic!("{name} does not import: {e}"));
    Some((level, dir.join(format!("{name}.ron"))))
}

/// Imports, builds and runs `level` for `seconds` with `seed`; asserts that vehicles came in
/// and left; the run's metrics.
fn carries_traffic(
    name: &str,
    (level, path): (Level, PathBuf),
    seed: u64,
    seconds: f64,
) -> std::collections::BTreeMap<String, f64> {
    assert!(!level.spawners.is_empty(), "{name}: no spawner");
    assert!(!level.destroyers.is_empty(), "{name}: no destroyer");
    let m = run(level, &path, seed, Some(seconds), None);
    assert!(m["vehicles_spawned"] > 10.0, "{name}: {m:#?}");
    assert!(m["vehicles_destroyed"] > 0.0, "{name}: {m:#?}");
    m
}

const GRID: &[&str] = &[
    "--grid",
    "--grid.number",
    "3",
    "--grid.length",
    "150",
    "--grid.attach-length",
    "100",
];
const SPIDER: &[&str] = &[
    "--spider",
    "--spider.arm-number",
    "5",
    "--spider.circle-number",
    "2",
    "--spider.space-radius",
    "100",
    "--spider.attach-length",
    "100",
];

/// `args` followed by `more`.
fn with<'a>(args: &[&'a str], more: &[&'a str]) -> Vec<&'a str> {
    args.iter().chain(more).copied().collect()
}

#[test]
fn a_grid_of_priority_junctions_carries_traffic() {
    if let Some(net) = generate("netgenerate", "grid", GRID) {
        carries_traffic("grid", net, 11, 120.0);
    }
}

/// netgenerate's actuated programs (fixed-time ones run side by side with SUMO below): imported
/// by the command as a user would, they run as their fixed-time default with a warning that
/// says so.
#[test]
fn a_grid_of_actuated_traffic_lights_carries_traffic_and_the_import_says_how() {
    let args = with(
        GRID,
        &["-j", "traffic_light", "--tls.default-type", "actuated"],
    );
    let Some((level, path)) = generate("netgenerate", "grid_tls", &args) else {
        return;
    };
    assert!(level.junctions.iter().any(|j| j.signal.is_some()));
    let dir = scratch("grid_tls");
    let out_level = dir.join("grid_tls_cli.ron");
    let _ = std::fs::remove_file(&out_level);
    let out = flockway(&[
        "import".as_ref(),
        dir.join("grid_tls.net.xml").as_os_str(),
        "-o".as_ref(),
        out_level.as_os_str(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert_eq!(
        stderr
            .matches("traffic lights with `actuated` programs run here as fixed-time programs")
            .count(),
        1,
        "{stderr}"
    );
    carries_traffic("grid_tls", (level, path), 11, 120.0);
}

#[test]
fn a_grid_with_sidewalks_and_crossings_carries_traffic() {
    let args = with(
        GRID,
        &[
            "--sidewalks.guess",
            "--crossings.guess",
            "-j",
            "traffic_light",
        ],
    );
    if let Some(net) = generate("netgenerate", "grid_walk", &args) {
        // One car lane per edge: the sidewalks are left out.
        assert!(net.0.roads.iter().all(|r| r.lanes == 1));
        carries_traffic("grid_walk", net, 11, 120.0);
    }
}

#[test]
fn spider_networks_carry_traffic() {
    for (name, more) in [
        ("spider", &[][..]),
        ("spider_tls", &["-j", "traffic_light"][..]),
    ] {
        if let Some(net) = generate("netgenerate", name, &with(SPIDER, more)) {
            carries_traffic(name, net, 11, 120.0);
        }
    }
}

#[test]
fn random_networks_of_three_seeds_carry_traffic() {
    for seed in ["1", "2", "3"] {
        let plain = ["--rand", "--rand.iterations", "30", "--seed", seed];
        let name = format!("rand{seed}");
        if let Some(net) = generate("netgenerate", &name, &plain) {
            carries_traffic(&name, net, 11, 120.0);
        }
        // Every node signalised: the lights where a road simply goes on are left out.
        let name = format!("rand{seed}_tls");
        if let Some(net) = generate(
            "netgenerate",
            &name,
            &with(&plain, &["-j", "traffic_light"]),
        ) {
            carries_traffic(&name, net, 11, 120.0);
        }
    }
}

#[test]
fn joined_junction_clusters_carry_traffic() {
    let args = [
        "--rand",
        "--rand.iterations",
        "40",
        "--seed",
        "5",
        "--rand.min-distance",
        "10",
        "--junctions.join",
        "--junctions.join-dist",
        "20",
    ];
    if let Some(net) = generate("netgenerate", "join", &args) {
        assert!(
            net.0
                .junctions
                .iter()
                .any(|j| j.name.starts_with("cluster")),
            "no joined junction"
        );
        carries_traffic("join", net, 11, 120.0);
    }
}

#[test]
fn a_lane_drop_is_a_link_and_runs_without_a_contact() {
    let dir = scratch("drop");
    std::fs::write(
        dir.join("drop.nod.xml"),
        r#"<nodes>
    <node id="W" x="0" y="0"/><node id="M" x="400" y="0"/><node id="E" x="800" y="0"/>
</nodes>"#,
    )
    .expect("nodes");
    std::fs::write(
        dir.join("drop.edg.xml"),
        r#"<edges>
    <edge id="wide" from="W" to="M" numLanes="3" speed="27.78"/>
    <edge id="narrow" from="M" to="E" numLanes="2" speed="27.78"/>
    <edge id="back" from="E" to="W" numLanes="2" speed="27.78"/>
</edges>"#,
    )
    .expect("edges");
    let args = ["-n", "drop.nod.xml", "-e", "drop.edg.xml"];
    if let Some(net) = generate("netconvert", "drop", &args) {
        let wide = net.0.roads.iter().find(|r| r.name == "wide").expect("wide");
        assert_eq!(wide.links.len(), 1, "{:?}", wide.links);
        let m = carries_traffic("drop", net, 11, 300.0);
        assert_eq!(m["collisions"], 0.0, "{m:#?}");
    }
}

/// `flockway` with `args`, from the repository's root.
fn flockway(args: &[&std::ffi::OsStr]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_flockway"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("the flockway binary runs")
}

/// Imports `net` with the demand `trips` as a user would (`flockway import --routes`), then runs
/// it side by side with SUMO (`flockway compare --json`): every vehicle departs and arrives in
/// both, with no contact, the mean travel time is SUMO's within `band` (a share of it) and the
/// edge counts match SUMO's by GEH on at least `geh_share` of the edges.
fn runs_as_in_sumo(name: &str, net: &Path, trips: &Path, band: (f64, f64), geh_share: f64) {
    let Some(sumo) = sumo_tool("sumo") else {
        return;
    };
    let dir = scratch(name);
    let level = dir.join(format!("{name}.ron"));
    let _ = std::fs::remove_file(&level);
    let os = |p: &Path| p.as_os_str().to_owned();
    let out = flockway(&[
        "import".as_ref(),
        net.as_os_str(),
        "--routes".as_ref(),
        trips.as_os_str(),
        "-o".as_ref(),
        level.as_os_str(),
    ]);
    assert!(
        out.status.success(),
        "{name}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let sumo = os(&sumo);
    let out = flockway(&[
        "compare".as_ref(),
        level.as_os_str(),
        "--net".as_ref(),
        net.as_os_str(),
        "--routes".as_ref(),
        trips.as_os_str(),
        "--sumo-bin".as_ref(),
        &sumo,
        "--json".as_ref(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(matches!(out.status.code(), Some(0 | 1)), "{name}: {stderr}");
    let c: serde_json::Value = serde_json::from_slice(&out.stdout)
        .unwrap_or_else(|e| panic!("{name}: compare --json: {e}: {stderr}"));
    let (s, f) = (&c["totals"]["sumo"], &c["totals"]["flockway"]);
    assert!(s["arrived"].as_u64() > Some(0), "{name}: {c:#}");
    for key in ["departed", "arrived"] {
        assert_eq!(s[key], f[key], "{name}: {key}: {c:#}");
    }
    assert_eq!(
        s["arrived"], s["departed"],
        "{name}: SUMO left some on the roads"
    );
    assert_eq!(f["waiting"], 0, "{name}: {c:#}");
    assert_eq!(f["collisions"], 0, "{name}: {c:#}");
    let ratio = f["mean_travel_time_s"].as_f64().expect("a mean")
        / s["mean_travel_time_s"].as_f64().expect("SUMO's mean");
    assert!(
        (band.0..band.1).contains(&ratio),
        "{name}: mean travel time {} s, SUMO's {} s",
        f["mean_travel_time_s"],
        s["mean_travel_time_s"]
    );
    let share = c["geh_match_share"].as_f64().expect("a share");
    assert!(share >= geh_share, "{name}: GEH < 5 on {share}: {c:#}");
    assert_eq!(
        out.status.code() == Some(0),
        c["verdict"]["all"] == true,
        "{name}: the exit status says the verdict"
    );
}

#[test]
fn sumo_s_own_demand_runs_on_the_grid_as_in_sumo() {
    // randomTrips.py's trips (seed 1, one every 3 s for 300 s) on the grid with sidewalks, and
    // the same trips on the same grid with traffic lights instead of priority junctions.
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/sumo");
    let trips = fixtures.join("grid_sidewalks.trips.xml");
    runs_as_in_sumo(
        "grid_demand",
        &fixtures.join("grid_sidewalks.net.xml"),
        &trips,
        (0.9, 1.35),
        0.85,
    );
    if let Some((_, path)) = generate(
        "netgenerate",
        "grid_tls_demand",
        &with(GRID, &["-j", "traffic_light"]),
    ) {
        let net = path.with_extension("net.xml");
        runs_as_in_sumo("grid_tls_demand", &net, &trips, (0.9, 1.35), 0.85);
    }
}

#[test]
fn a_roundabout_and_a_motorway_with_ramps_run_as_in_sumo() {
    // Flows from every arm to every other exit of a roundabout netconvert built
    // (`--roundabouts.guess`, the ring the major road).
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/sumo");
    runs_as_in_sumo(
        "roundabout_demand",
        &fixtures.join("roundabout.net.xml"),
        &fixtures.join("roundabout.rou.xml"),
        (0.95, 1.25),
        0.85,
    );
    // A motorway with an on- and an off-ramp (`--ramps.guess`): every vehicle through, but
    // 1.6 times SUMO's travel time, the motorway in single file through the junctions at the
    // ramps (see docs/import.md); the band fails when that is fixed, to be narrowed then.
    runs_as_in_sumo(
        "ramps_demand",
        &fixtures.join("ramps.net.xml"),
        &fixtures.join("ramps.rou.xml"),
        (1.4, 1.8),
        0.85,
    );
}
