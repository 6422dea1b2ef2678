//! The road networks SUMO's own distribution carries, which nobody here wrote: OpenStreetMap
//! extracts (streets of Braunschweig and Ingolstadt, a motorway interchange, a motorway with its
//! junctions), the RiLSA guideline junctions, game and tutorial scenarios, written by netconvert
//! and netedit from SUMO 0.13 to 1.20, plain and as multi-member `.net.xml.gz`. They
//! come with the `eclipse-sumo` package `scripts/test` installs; without it every test here says
//! so on stderr and passes.
//!
//! Each is imported as a user would (`flockway import`) and run for [`SECONDS`] s on a seed
//! nobody tuned for: vehicles come in and leave. The networks no passenger car may use (rail, a
//! race track for a `vip` class) are refused with a message that says so.
//!
//! OSM's bridges come flat unless netconvert is asked for their height: roads that cross
//! without meeting are at different levels, and their cars must pass without touching (the
//! motorway interchange has ramps drawn along and across the motorway).
//!
//! Maps come in through netconvert too: an OpenStreetMap town (`tests/fixtures/osm/`) and an
//! OpenDRIVE road (`tests/fixtures/opendrive/`) are made into SUMO networks here with the
//! options docs/import.md recommends, then imported, checked and run the same way.
//!
//! Known defect, held where it stands rather than hidden: on several of these networks cars
//! still touch (junctions where a sharp turn's car swings out of its lane, motorway merges);
//! [`NETWORKS`] lets each have no more contacts than it has today, so that a regression fails
//! and a fix shows.

#[allow(dead_code, reason = "shared with the tests that run shipped levels")]
mod common;

use common::{run, sumo_tool};
use flockway::level::load_level;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

/// How long each network runs, s.
const SECONDS: f64 = 120.0;
/// The seed every network runs with.
const SEED: u64 = 7;

/// What a network does: runs, with at most this many vehicle contacts in [`SECONDS`] s; imports
/// (a copy of a network that runs here under another name); or is refused with an error
/// containing the text.
enum Outcome {
    Runs { most_contacts: f64 },
    Imports,
    Refused(&'static str),
}

use Outcome::{Imports, Refused, Runs};

/// Every network in SUMO's `tools` directory (path under it) and what it does.
const NETWORKS: [(&str, Outcome); 28] = [
    ("game/A10KW/osm.net.xml", Runs { most_contacts: 4.0 }),
    ("game/DRT/osm.net.xml", Runs { most_contacts: 0.0 }),
    ("game/bs3d/bs.net.xml", Runs { most_contacts: 1.0 }),
    (
        "game/corridor/corridor.net.xml",
        Runs { most_contacts: 0.0 },
    ),
    ("game/cross/cross.net.xml", Runs { most_contacts: 0.0 }),
    (
        "game/fkk_in/ingolstadt.net.xml.gz",
        Runs { most_contacts: 0.0 },
    ),
    (
        "game/fokr_bs_demo/fokr_bs.net.xml.gz",
        Runs { most_contacts: 6.0 },
    ),
    ("game/grid6/grid6.net.xml", Runs { most_contacts: 0.0 }),
    ("game/highway/highway.net.xml", Runs { most_contacts: 0.0 }),
    ("game/hiking/hiking.net.xml", Runs { most_contacts: 0.0 }),
    ("game/kuehne/kuehne.net.xml", Runs { most_contacts: 0.0 }),
    ("game/ramp/ramp.net.xml", Runs { most_contacts: 0.0 }),
    ("game/square/square.net.xml", Runs { most_contacts: 0.0 }),
    (
        "game/rail/net.net.xml",
        Refused("no edge passenger cars may use"),
    ),
    (
        "game/rail_demo/net.net.xml",
        Refused("no edge passenger cars may use"),
    ),
    (
        "game/racing/spreewaldring.net.xml",
        Refused("no edge passenger cars may use"),
    ),
    (
        "sumolib/scenario/scenarios/net.net.xml",
        Runs { most_contacts: 0.0 },
    ),
    (
        "sumolib/scenario/scenarios/RiLSA1/rilsa1.net.xml",
        Runs { most_contacts: 0.0 },
    ),
    (
        "sumolib/scenario/scenarios/RiLSA1OutTLS/rilsa1.net.xml",
        Runs { most_contacts: 0.0 },
    ),
    (
        "sumolib/scenario/scenarios/RiLSA1BothTLS/rilsa1both.net.xml",
        Runs { most_contacts: 0.0 },
    ),
    (
        "sumolib/scenario/scenarios/RealWorld/RiLSA_example1/rilsa1.net.xml",
        Runs { most_contacts: 0.0 },
    ),
    (
        "sumolib/scenario/scenarios/RealWorld/RiLSA_example2/rilsa2.net.xml",
        Runs { most_contacts: 0.0 },
    ),
    (
        "sumolib/scenario/scenarios/RealWorld/RiLSA_example3/rilsa3.net.xml",
        Runs { most_contacts: 0.0 },
    ),
    (
        "sumolib/scenario/scenarios/RealWorld/RiLSA_example4/rilsa4.net.xml",
        Runs { most_contacts: 0.0 },
    ),
    // The four above again, as the examples' own `net.net.xml`: imported only.
    (
        "sumolib/scenario/scenarios/RealWorld/RiLSA_example1/net.net.xml",
        Imports,
    ),
    (
        "sumolib/scenario/scenarios/RealWorld/RiLSA_example2/net.net.xml",
        Imports,
    ),
    (
        "sumolib/scenario/scenarios/RealWorld/RiLSA_example3/net.net.xml",
        Imports,
    ),
    (
        "sumolib/scenario/scenarios/RealWorld/RiLSA_example4/net.net.xml",
        Imports,
    ),
];

/// SUMO's `tools` directory, from the Python package in the environment `FLOCKWAY_SUMO_BIN`
/// names, else under `SUMO_HOME`; `None` (and a note on stderr) when neither is there.
fn sumo_tools() -> Option<PathBuf> {
    let from_python = std::env::var_os("FLOCKWAY_SUMO_BIN").and_then(|bin| {
        let out = Command::new(Path::new(&bin).join("python"))
            .args([
                "-c",
                "import os, sumo; print(os.path.dirname(sumo.__file__))",
            ])
            .output()
            .ok()?;
        out.status
            .success()
            .then(|| PathBuf::from(String::from_utf8_lossy(&out.stdout).trim()))
    });
    let home = from_python.or_else(|| std::env::var_os("SUMO_HOME").map(PathBuf::from));
    let tools = home.map(|h| h.join("tools")).filter(|t| t.is_dir());
    if tools.is_none() {
        // Past the test harness's capture, so the skip shows in a passing run.
        let _ = writeln!(
            std::io::stderr(),
            "skipped: SUMO's tools directory is not there (install SUMO with `pip install \
             eclipse-sumo==1.28.0` and set FLOCKWAY_SUMO_BIN to its environment's bin directory)"
        );
    }
    tools
}

/// Every `*.net.xml` and `*.net.xml.gz` under `dir`, as paths under it.
fn networks_under(dir: &Path, base: &Path, found: &mut Vec<String>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            networks_under(&path, base, found);
        } else if path
            .file_name()
            .and_then(|n| n.to_str())
            .is_some_and(|n| n.ends_with(".net.xml") || n.ends_with(".net.xml.gz"))
            && let Ok(rel) = path.strip_prefix(base)
        {
            found.push(rel.to_string_lossy().replace('\\', "/"));
        }
    }
}

/// `flockway import NETWORK -o LEVEL`, as a user runs it.
fn import(network: &Path, level: &Path) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_flockway"))
        .arg("import")
        .arg(network)
        .arg("-o")
        .arg(level)
        .output()
        .expect("the flockway binary runs")
}

/// Imports the network at `rel` under SUMO's tools with `flockway import`, then does what
/// [`NETWORKS`] says it does.
fn imports_and_runs(rel: &str) {
    let Some(tools) = sumo_tools() else {
        return;
    };
    let (_, outcome) = NETWORKS
        .iter()
        .find(|(path, _)| *path == rel)
        .expect("a network in the table");
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("sumo_networks");
    std::fs::create_dir_all(&dir).expect("a scratch directory");
    let level = dir.join(format!("{}.ron", rel.replace(['/', '.'], "_")));
    let _ = std::fs::remove_file(&level);
    let out = import(&tools.join(rel), &level);
    let stderr = String::from_utf8_lossy(&out.stderr);
    match outcome {
        Refused(words) => {
            assert_eq!(out.status.code(), Some(2), "{rel}: {stderr}");
            assert!(stderr.contains(words), "{rel}: {stderr}");
        }
        Imports => {
            assert!(out.status.success(), "{rel}: {stderr}");
            load_level(&level).unwrap_or_else(|e| panic!("{rel}: {e}"));
        }
        Runs { most_contacts } => {
            assert!(out.status.success(), "{rel}: {stderr}");
            let loaded = load_level(&level).unwrap_or_else(|e| panic!("{rel}: {e}"));
            let m = run(loaded, &level, SEED, Some(SECONDS), None);
            assert!(m["vehicles_spawned"] > 10.0, "{rel}: {m:#?}");
            assert!(m["vehicles_destroyed"] > 0.0, "{rel}: {m:#?}");
            assert!(
                m["collisions_vehicle"] <= *most_contacts,
                "{rel}: {} vehicle contacts in {SECONDS} s (at most {most_contacts} known)",
                m["collisions_vehicle"]
            );
            assert_eq!(m["collisions_guardrail"], 0.0, "{rel}: {m:#?}");
        }
    }
}

/// The table lists every network SUMO's tools directory has, so a network a new SUMO brings is
/// not left untried.
#[test]
fn the_table_lists_every_network_sumo_carries() {
    let Some(tools) = sumo_tools() else {
        return;
    };
    let mut found = Vec::new();
    networks_under(&tools, &tools, &mut found);
    found.sort();
    let mut listed: Vec<String> = NETWORKS.iter().map(|(p, _)| (*p).to_owned()).collect();
    listed.sort();
    assert_eq!(found, listed);
}

macro_rules! networks {
    ($($test:ident => $path:literal,)*) => {
        $(
            #[test]
            fn $test() {
                imports_and_runs($path);
            }
        )*
    };
}

networks! {
    a10_osm => "game/A10KW/osm.net.xml",
    drt_osm => "game/DRT/osm.net.xml",
    braunschweig => "game/bs3d/bs.net.xml",
    corridor => "game/corridor/corridor.net.xml",
    cross => "game/cross/cross.net.xml",
    ingolstadt_gz => "game/fkk_in/ingolstadt.net.xml.gz",
    fokr_bs_gz => "game/fokr_bs_demo/fokr_bs.net.xml.gz",
    grid6 => "game/grid6/grid6.net.xml",
    highway_interchange => "game/highway/highway.net.xml",
    hiking => "game/hiking/hiking.net.xml",
    kuehne => "game/kuehne/kuehne.net.xml",
    ramp => "game/ramp/ramp.net.xml",
    square => "game/square/square.net.xml",
    rail => "game/rail/net.net.xml",
    rail_demo => "game/rail_demo/net.net.xml",
    race_track => "game/racing/spreewaldring.net.xml",
    scenario_net => "sumolib/scenario/scenarios/net.net.xml",
    rilsa1 => "sumolib/scenario/scenarios/RiLSA1/rilsa1.net.xml",
    rilsa1_out_tls => "sumolib/scenario/scenarios/RiLSA1OutTLS/rilsa1.net.xml",
    rilsa1_both_tls => "sumolib/scenario/scenarios/RiLSA1BothTLS/rilsa1both.net.xml",
    rilsa_example1 => "sumolib/scenario/scenarios/RealWorld/RiLSA_example1/rilsa1.net.xml",
    rilsa_example2 => "sumolib/scenario/scenarios/RealWorld/RiLSA_example2/rilsa2.net.xml",
    rilsa_example3 => "sumolib/scenario/scenarios/RealWorld/RiLSA_example3/rilsa3.net.xml",
    rilsa_example4 => "sumolib/scenario/scenarios/RealWorld/RiLSA_example4/rilsa4.net.xml",
    rilsa_example1_net => "sumolib/scenario/scenarios/RealWorld/RiLSA_example1/net.net.xml",
    rilsa_example2_net => "sumolib/scenario/scenarios/RealWorld/RiLSA_example2/net.net.xml",
    rilsa_example3_net => "sumolib/scenario/scenarios/RealWorld/RiLSA_example3/net.net.xml",
    rilsa_example4_net => "sumolib/scenario/scenarios/RealWorld/RiLSA_example4/net.net.xml",
}

/// How long the OpenStreetMap town runs, s: its fringe fills it with hundreds of cars.
const TOWN_SECONDS: f64 = 40.0;
/// The vehicle contacts the town has in [`TOWN_SECONDS`] s today: none (its contacts come
/// later, as its streets jam; a known defect, as above).
const TOWN_CONTACTS: f64 = 0.0;

/// The options docs/import.md recommends for netconvert on OpenStreetMap.
const OSM_OPTIONS: [&str; 8] = [
    "--geometry.remove",
    "--ramps.guess",
    "--junctions.join",
    "--tls.guess-signals",
    "--tls.discard-simple",
    "--tls.join",
    "--roundabouts.guess",
    "--remove-edges.isolated",
];

/// Runs SUMO's netconvert on the fixture `input` (under tests/fixtures) read as `kind`
/// (`osm` or `opendrive`) with `options`, imports the network with `flockway import`, checks
/// the level with `flockway check`: the level, where it is; `None` (and a note on stderr)
/// without netconvert ([`sumo_tool`]).
fn through_netconvert(
    kind: &str,
    input: &str,
    options: &[&str],
) -> Option<(flockway::level::Level, PathBuf)> {
    let netconvert = sumo_tool("netconvert")?;
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("sumo_networks");
    std::fs::create_dir_all(&dir).expect("a scratch directory");
    let name = input.rsplit('/').next().and_then(|f| f.split('.').next());
    let name = name.expect("a file name");
    let net = dir.join(format!("{name}.net.xml"));
    let out = Command::new(netconvert)
        .arg(format!("--{kind}-files"))
        .arg(
            Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("tests/fixtures")
                .join(input),
        )
        .args(options)
        .args(["--no-warnings", "-o"])
        .arg(&net)
        .output()
        .expect("netconvert runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{input}: {stderr}");
    let level = dir.join(format!("{name}.ron"));
    let _ = std::fs::remove_file(&level);
    let flockway = |args: &[&std::ffi::OsStr]| {
        let out = Command::new(env!("CARGO_BIN_EXE_flockway"))
            .args(args)
            .output()
            .expect("the flockway binary runs");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{input}: {stderr}");
    };
    flockway(&[
        "import".as_ref(),
        net.as_ref(),
        "-o".as_ref(),
        level.as_ref(),
    ]);
    flockway(&["check".as_ref(), level.as_ref()]);
    let loaded = load_level(&level).unwrap_or_else(|e| panic!("{input}: {e}"));
    Some((loaded, level))
}

/// A real OpenStreetMap extract (`tests/fixtures/osm/town.osm`) made into a SUMO network by
/// netconvert with the options docs/import.md recommends, then imported, checked and run as a
/// user would: streets, a motorway with its links, cycle tracks and footways the importer
/// leaves out.
#[test]
fn an_openstreetmap_town_through_netconvert_imports_and_runs() {
    let Some((level, path)) = through_netconvert("osm", "osm/town.osm", &OSM_OPTIONS) else {
        return;
    };
    assert!(level.roads.len() > 500, "{} roads", level.roads.len());
    assert!(
        level.spawners.len() > 50,
        "{} spawners",
        level.spawners.len()
    );
    let m = run(level, &path, SEED, Some(TOWN_SECONDS), None);
    assert!(m["vehicles_spawned"] > 200.0, "{m:#?}");
    assert!(m["vehicles_destroyed"] > 5.0, "{m:#?}");
    assert!(
        m["collisions_vehicle"] <= TOWN_CONTACTS,
        "{} vehicle contacts in {TOWN_SECONDS} s (at most {TOWN_CONTACTS} known)",
        m["collisions_vehicle"]
    );
    assert_eq!(m["collisions_guardrail"], 0.0, "{m:#?}");
}

/// An OpenDRIVE road (`tests/fixtures/opendrive/curve.xodr`: a line then an arc, climbing 2 %,
/// a lane each way and a sidewalk) through netconvert: both directions carry traffic, the
/// sidewalk is left out, the climb is kept.
#[test]
fn an_opendrive_road_through_netconvert_imports_and_runs() {
    let Some((level, path)) = through_netconvert("opendrive", "opendrive/curve.xodr", &[]) else {
        return;
    };
    assert_eq!(level.roads.len(), 2, "{:#?}", level.roads);
    for road in &level.roads {
        assert_eq!(road.lanes, 1, "{}: the sidewalk is not a lane", road.name);
        let (first, last) = (&road.points[0].pos, &road.points[road.points.len() - 1].pos);
        assert!(
            (last.z - first.z).abs() > 3.0,
            "{}: the 2 % climb is kept",
            road.name
        );
    }
    let m = run(level, &path, SEED, Some(120.0), None);
    assert!(m["vehicles_destroyed"] > 10.0, "{m:#?}");
    assert_eq!(m["collisions_vehicle"], 0.0, "{m:#?}");
}

/// On a real town's network, every per-car pass split over the threads from one car
/// (`FLOCKWAY_PARALLEL_MIN=1`: the junction rule's passes and the conflict measures included),
/// 1 and 3 threads give the same bytes: telemetry and conflicts; and so do 3 threads with the
/// passes' own thresholds, which split the town's hundred-odd cars over the join pool.
#[test]
fn the_thread_count_changes_no_byte_of_a_busy_town() {
    let Some(tools) = sumo_tools() else {
        return;
    };
    let dir = tempfile::tempdir().expect("tempdir");
    let level = dir.path().join("a10.ron");
    let out = import(&tools.join("game/A10KW/osm.net.xml"), &level);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut outputs: Vec<(Vec<u8>, Vec<u8>, String)> = Vec::new();
    for (threads, parallel_min) in [("1", Some("1")), ("3", Some("1")), ("3", None)] {
        let name = format!("{threads}_{}", parallel_min.unwrap_or("own"));
        let csv = dir.path().join(format!("run_{name}.csv"));
        let conflicts = dir.path().join(format!("conflicts_{name}.csv"));
        let summary = dir.path().join(format!("summary_{name}.json"));
        let mut command = Command::new(env!("CARGO_BIN_EXE_flockway"));
        command.env("FLOCKWAY_THREADS", threads);
        match parallel_min {
            Some(min) => command.env("FLOCKWAY_PARALLEL_MIN", min),
            None => command.env_remove("FLOCKWAY_PARALLEL_MIN"),
        };
        let out = command
            .arg("run")
            .arg(&level)
            .args(["--seconds", "120", "--seed", "7", "--csv"])
            .arg(&csv)
            .arg("--conflicts")
            .arg(&conflicts)
            .arg("--summary")
            .arg(&summary)
            .output()
            .expect("the flockway binary runs");
        // Its known contacts fail the level's expectation: exit 1.
        assert!(
            matches!(out.status.code(), Some(0 | 1)),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        outputs.push((
            std::fs::read(&csv).expect("telemetry"),
            std::fs::read(&conflicts).expect("conflicts"),
            std::fs::read_to_string(&summary).expect("summary"),
        ));
    }
    let summary: serde_json::Value = serde_json::from_str(&outputs[0].2).expect("JSON");
    let alive = summary["metrics"]["vehicles_alive_mean"]
        .as_f64()
        .expect("a figure");
    assert!(alive > 100.0, "busy enough to split over threads: {alive}");
    let conflict_rows = outputs[0].1.iter().filter(|&&b| b == b'\n').count() - 1;
    assert!(
        conflict_rows >= 5,
        "conflicts were recorded: {conflict_rows}"
    );
    assert!(
        outputs[0].0 == outputs[1].0,
        "the same telemetry on 1 and 3 threads"
    );
    assert!(
        outputs[0].1 == outputs[1].1,
        "the same conflicts on 1 and 3 threads"
    );
    assert!(
        outputs[0].0 == outputs[2].0 && outputs[0].1 == outputs[2].1,
        "the same telemetry and conflicts with the join pool's split"
    );
}
