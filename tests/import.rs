//! SUMO networks in: `flockway import` on networks made with SUMO's `netconvert` (the node and
//! edge files they were made from are beside them in `tests/fixtures/sumo/`), element by element,
//! and the imported signalised crossroads run.

#[allow(dead_code, reason = "shared with the tests that run shipped levels")]
mod common;

use common::run;
use flockway::level::{Level, import_sumo_net, load_level};
use flockway_road::{Control, SignalState};
use std::path::{Path, PathBuf};
use std::process::Command;

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/sumo")
        .join(name)
}

fn import(name: &str) -> Level {
    let path = fixture(name);
    let text = std::fs::read_to_string(&path).expect("the fixture");
    import_sumo_net(&text, &path, "imported").expect("the network imports")
}

#[test]
fn edges_become_roads_with_their_lanes_shapes_and_speeds() {
    let level = import("tee.net.xml");
    let road = |name: &str| {
        level
            .roads
            .iter()
            .find(|r| r.name == name)
            .unwrap_or_else(|| panic!("road {name}"))
    };
    // Six edges, no internal ones.
    assert_eq!(level.roads.len(), 6);
    // `WT`: two lanes at 13.89 m/s, 3.2 m wide (SUMO's default), its centre line midway
    // between the lanes' (SUMO: lane 0 at y = 145.2, lane 1 at y = 148.4, from x = 0 east to
    // the junction's edge at x = 142.8).
    let wt = road("WT");
    assert_eq!(wt.lanes, 2);
    assert!((wt.speed_limit_kmh - 13.89 * 3.6).abs() < 1e-9);
    assert!((wt.lane_width_m - 3.2).abs() < 1e-9);
    let (first, last) = (wt.points[0].pos, wt.points[wt.points.len() - 1].pos);
    assert!(
        first.x.abs() < 1e-9 && (first.y - 146.8).abs() < 1e-9,
        "{first}"
    );
    assert!(
        (last.x - 142.8).abs() < 1e-9 && (last.y - 146.8).abs() < 1e-9,
        "{last}"
    );
    // The minor road: one lane at 40 km/h.
    let st = road("ST");
    assert_eq!(st.lanes, 1);
    assert!((st.speed_limit_kmh - 11.11 * 3.6).abs() < 1e-9);
    assert!(level.roads.iter().all(|r| {
        !r.points
            .iter()
            .any(|p| p.guardrail_left || p.guardrail_right)
    }));
}

#[test]
fn connections_and_right_of_way_come_from_the_junction() {
    let level = import("tee.net.xml");
    assert_eq!(level.junctions.len(), 1);
    let t = &level.junctions[0];
    assert_eq!(t.name, "T");
    // A priority junction: the edges of the highest priority (3) have right of way.
    assert_eq!(
        t.control,
        Control::Priority {
            major: vec!["ET".to_owned(), "WT".to_owned()],
            stop: false
        }
    );
    // Every connection, lane to lane, as SUMO has them (lane 0 the rightmost in both).
    let got: Vec<(&str, u32, &str, u32)> = t
        .connections
        .iter()
        .map(|c| (c.from.as_str(), c.from_lane, c.to.as_str(), c.to_lane))
        .collect();
    assert_eq!(
        got,
        vec![
            ("ET", 0, "TW", 0),
            ("ET", 1, "TW", 1),
            ("ET", 1, "TS", 0),
            ("ST", 0, "TE", 0),
            ("ST", 0, "TW", 1),
            ("WT", 0, "TS", 0),
            ("WT", 0, "TE", 0),
            ("WT", 1, "TE", 1),
        ]
    );
    // Traffic enters where nothing leads in (a spawner per lane) and leaves where nothing
    // leads on, routed there.
    let mut sources: Vec<(&str, u32)> = level
        .spawners
        .iter()
        .map(|s| (s.road.as_str(), s.lane))
        .collect();
    sources.sort();
    assert_eq!(
        sources,
        vec![("ET", 0), ("ET", 1), ("ST", 0), ("WT", 0), ("WT", 1)]
    );
    let st = level.spawners.iter().find(|s| s.road == "ST").expect("ST");
    let mut routes: Vec<Vec<&str>> = st
        .routes
        .iter()
        .map(|r| r.roads.iter().map(String::as_str).collect())
        .collect();
    routes.sort();
    assert_eq!(routes, vec![vec!["ST", "TE"], vec!["ST", "TW"]]);
    let mut sinks: Vec<&str> = level.destroyers.iter().map(|d| d.name.as_str()).collect();
    sinks.sort();
    assert_eq!(sinks, vec!["TE", "TS", "TW"]);
}

#[test]
fn a_traffic_light_keeps_its_program_letter_for_letter_in_link_order() {
    let level = import("cross.net.xml");
    let c = &level.junctions[0];
    assert_eq!(c.control, Control::Signal);
    // SUMO's link indices 0–11: from the north, east, south, west, each right, straight, left.
    let got: Vec<(&str, &str)> = c
        .connections
        .iter()
        .map(|c| (c.from.as_str(), c.to.as_str()))
        .collect();
    assert_eq!(
        got,
        vec![
            ("NC", "CW"),
            ("NC", "CS"),
            ("NC", "CE"),
            ("EC", "CN"),
            ("EC", "CW"),
            ("EC", "CS"),
            ("SC", "CE"),
            ("SC", "CN"),
            ("SC", "CW"),
            ("WC", "CS"),
            ("WC", "CE"),
            ("WC", "CN"),
        ]
    );
    let program = c.signal.as_ref().expect("a program");
    let phases: Vec<(f64, &str)> = program
        .phases
        .iter()
        .map(|p| (p.duration_s, p.state.as_str()))
        .collect();
    assert_eq!(
        phases,
        vec![
            (42.0, "rrrGGgrrrGGg"),
            (3.0, "rrryyyrrryyy"),
            (42.0, "GGgrrrGGgrrr"),
            (3.0, "yyyrrryyyrrr"),
        ]
    );
    assert_eq!(program.offset_s, 0.0);
    // East–west straight on is green from the start, north–south after 45 s.
    assert_eq!(program.state_at(10.0, 4), SignalState::Green);
    assert_eq!(program.state_at(10.0, 1), SignalState::Red);
    assert_eq!(program.state_at(50.0, 1), SignalState::Green);
}

#[test]
fn a_sumo_offset_starts_the_program_that_much_early() {
    // SUMO runs a program with offset 10 as if it had started 10 s before time 0.
    let path = fixture("cross.net.xml");
    let text = std::fs::read_to_string(&path)
        .expect("the fixture")
        .replace(
            r#"programID="0" offset="0""#,
            r#"programID="0" offset="10""#,
        );
    let level = import_sumo_net(&text, &path, "offset").expect("imports");
    let program = level.junctions[0].signal.as_ref().expect("a program");
    assert_eq!(program.offset_s, 80.0);
    // At time 0 it is 10 s before the cycle's end (80 s into its 90): north–south green, then
    // their amber from 7 s, and east–west green again from 10 s.
    assert_eq!(program.state_at(0.0, 1), SignalState::Green);
    assert_eq!(program.state_at(7.5, 1), SignalState::Amber);
    assert_eq!(program.state_at(10.5, 4), SignalState::Green);
}

#[test]
fn the_imported_crossroads_runs_without_a_collision_or_a_red_entry() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("cross.ron");
    let status = Command::new(env!("CARGO_BIN_EXE_flockway"))
        .args(["import"])
        .arg(fixture("cross.net.xml"))
        .arg("-o")
        .arg(&out)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("flockway runs");
    assert!(status.status.success(), "{status:?}");
    // It never overwrites.
    let again = Command::new(env!("CARGO_BIN_EXE_flockway"))
        .args(["import"])
        .arg(fixture("cross.net.xml"))
        .arg("-o")
        .arg(&out)
        .output()
        .expect("flockway runs");
    assert_eq!(again.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&again.stderr).contains("never overwrites"));
    let mut headways = Vec::new();
    for seed in [2, 3] {
        let level = load_level(&out).expect("the written level loads");
        let m = run(level, &out, seed, None, None);
        assert_eq!(m["collisions"], 0.0, "seed {seed}: {m:#?}");
        assert_eq!(m["red_entries.C"], 0.0, "seed {seed}: {m:#?}");
        // The demand (a car every 8–12 s from each arm) gets through.
        assert!(
            m["junction_flow_veh_per_h.C"] > 1_100.0,
            "seed {seed}: {m:#?}"
        );
        headways.push(m["discharge_headway_s.C"]);
    }
    // Queued cars discharge at a saturation flow of 1 500–2 250 veh/h of green: judged over two
    // seeds, as one run's few dozen discharges scatter by a few tenths of a second.
    let headway = headways.iter().sum::<f64>() / headways.len() as f64;
    assert!((1.6..2.4).contains(&headway), "{headways:?}");
}

#[test]
fn a_minor_road_waiting_for_busy_major_streams_is_never_let_go_by_the_deadlock_rule() {
    // The priority tee: two lanes each way on the major road, its left turners waiting for the
    // oncoming stream while minor-road drivers wait for both. A minor-road car behind a standing
    // major left turner still waits for moving traffic: no deadlock, nobody let go into it.
    let level = import("tee.net.xml");
    let out = fixture("tee.ron");
    let m = run(level, &out, 3, None, None);
    assert_eq!(m["deadlocks.T"], 0.0, "{m:#?}");
    assert!(m["junction_flow_veh_per_h.T"] > 1_200.0, "{m:#?}");
}

#[test]
fn a_broken_network_is_an_error_at_its_line_and_column() {
    let path = fixture("cross.net.xml");
    let text = std::fs::read_to_string(&path).expect("the fixture");
    let line_of = |needle: &str| {
        text.lines()
            .position(|l| l.contains(needle))
            .map(|i| i as u32 + 1)
            .expect(needle)
    };
    let cases = [
        // Not XML at all where it breaks off.
        (
            text.replace("</net>", "</nte>"),
            line_of("</net>"),
            "not a well-formed XML file",
        ),
        // A connection to an edge the network does not have.
        (
            text.replace(
                r#"<connection from="EC" to="CN""#,
                r#"<connection from="EC" to="XX""#,
            ),
            line_of(r#"<connection from="EC" to="CN""#),
            "connection to unknown edge `XX`",
        ),
        // A signal state SUMO does not write.
        (
            text.replace(r#"state="rrrGGgrrrGGg""#, r#"state="rrrGGgrrrGGq""#),
            line_of(r#"state="rrrGGgrrrGGg""#),
            "unknown signal state letter 'q'",
        ),
        // A lane shape that is not points.
        (
            text.replace(
                r#"shape="207.20,198.40 400.00,198.40""#,
                r#"shape="207.20""#,
            ),
            line_of(r#"shape="207.20,198.40 400.00,198.40""#),
            "`shape` must be at least two points",
        ),
    ];
    for (broken, line, words) in cases {
        let e = import_sumo_net(&broken, &path, "broken").expect_err(words);
        assert_eq!(e.line, line, "{e}");
        assert!(e.to_string().contains(words), "{e}");
        assert!(
            e.to_string()
                .starts_with(&format!("{}:{line}:", path.display())),
            "{e}"
        );
    }
    // Something that is not a SUMO network.
    let e = import_sumo_net("<routes/>", &path, "x").expect_err("not a net");
    assert!(e.to_string().contains("expected a SUMO network"), "{e}");
}

/// Networks netgenerate wrote, not written here (`tests/fixtures/sumo/`):
/// - `rand_seed4.net.xml`: `netgenerate --rand --rand.iterations 25 --seed 4 --tls.guess`, with
///   dead ends, lanes added and dropped along roads (connections whose lanes meet) and a guessed
///   traffic light;
/// - `grid_sidewalks.net.xml`: `netgenerate --grid --grid.number 3 --grid.length 150
///   --grid.attach-length 100 --sidewalks.guess --crossings.guess`, every edge with a sidewalk,
///   walking areas and pedestrian crossings at every junction.
#[test]
fn netgenerate_networks_import_with_joins_sidewalks_and_fringes_and_carry_traffic() {
    let rand = import("rand_seed4.net.xml");
    // Lanes that continue one another are linked, not made a junction of.
    let links: usize = rand.roads.iter().map(|r| r.links.len()).sum();
    assert!(links > 0, "no road linked");
    assert!(
        rand.junctions
            .iter()
            .any(|j| matches!(j.control, Control::Signal)),
        "the guessed traffic light"
    );
    // Dead ends are where traffic comes and goes (a turn back is not a way in).
    assert!(!rand.spawners.is_empty() && !rand.destroyers.is_empty());

    let grid = import("grid_sidewalks.net.xml");
    // Sidewalks, walking areas and crossings are left out: one car lane per edge.
    assert!(
        grid.roads.iter().all(|r| r.lanes == 1),
        "a sidewalk became a lane"
    );
    assert!(grid.roads.iter().all(|r| !r.name.starts_with(':')));
    // The fringe roads netgenerate attached bring traffic in: 12 of them, each way.
    assert_eq!(grid.spawners.len(), 12, "{:?}", grid.spawners.len());
    assert_eq!(grid.destroyers.len(), 12);

    for (name, level) in [("rand_seed4", rand), ("grid_sidewalks", grid)] {
        let path = fixture(&format!("{name}.ron"));
        let m = run(level, &path, 1, Some(120.0), None);
        assert!(m["vehicles_spawned"] > 20.0, "{name}: {m:#?}");
        assert!(m["vehicles_destroyed"] > 0.0, "{name}: {m:#?}");
    }
}

#[test]
fn a_network_nothing_can_enter_is_an_error_that_says_so() {
    // Three one-way roads in a triangle: every road is reached from another.
    let edge = |id: &str, from: &str, to: &str, shape: &str| {
        format!(
            r#"<edge id="{id}" from="{from}" to="{to}" priority="1"><lane id="{id}_0" index="0" speed="13.89" length="100" shape="{shape}"/></edge>"#
        )
    };
    let text = format!(
        r#"<net version="1.20">
{}
{}
{}
<junction id="a" type="priority" x="0" y="0"/>
<junction id="b" type="priority" x="100" y="0"/>
<junction id="c" type="priority" x="50" y="90"/>
<connection from="ab" to="bc" fromLane="0" toLane="0"/>
<connection from="bc" to="ca" fromLane="0" toLane="0"/>
<connection from="ca" to="ab" fromLane="0" toLane="0"/>
</net>"#,
        edge("ab", "a", "b", "5,0 95,0"),
        edge("bc", "b", "c", "97,5 53,85"),
        edge("ca", "c", "a", "47,85 3,5"),
    );
    let err = import_sumo_net(&text, Path::new("ring.net.xml"), "ring").expect_err("no entry");
    let message = err.to_string();
    assert!(message.contains("has no entry"), "{message}");
    assert!(message.contains("--grid.attach-length"), "{message}");
}

/// `ramps.net.xml`: `netconvert -n ramps.nod.xml -e ramps.edg.xml --ramps.guess`, a two-lane
/// motorway with an on-ramp and an off-ramp; netconvert adds a lane for each (an acceleration
/// lane that ends, a deceleration lane that opens) at nodes of their own.
#[test]
fn a_motorway_s_ramps_come_in_as_lanes_that_end_and_open_and_exits_are_taken() {
    let level = import("ramps.net.xml");
    // The nodes where a lane is added or dropped are not junctions: the roads go on through
    // links, the lanes that continue one another paired, netconvert's gap between them closed.
    let links = |name: &str| {
        level
            .roads
            .iter()
            .find(|r| r.name == name)
            .map(|r| r.links.clone())
            .unwrap_or_default()
    };
    assert_eq!(links("m2")[0].to, "m2-AddedOffRampEdge");
    assert_eq!(links("m2")[0].lanes, vec![(0, 1), (1, 2)]);
    assert_eq!(links("m2-AddedOnRampEdge")[0].to, "m2");
    assert_eq!(links("m2-AddedOnRampEdge")[0].lanes, vec![(1, 0), (2, 1)]);
    assert!(
        level
            .junctions
            .iter()
            .all(|j| j.name == "A" || j.name == "B"),
        "{:?}",
        level.junctions.iter().map(|j| &j.name).collect::<Vec<_>>()
    );
    // A 300 s run: ramp cars merge off their ending lane, exit cars slow on the motorway
    // enough to cross into the short deceleration lane, and traffic flows at motorway speed.
    let m = run(level, &fixture("ramps.ron"), 2, Some(300.0), None);
    assert_eq!(m["collisions"], 0.0, "{m:#?}");
    assert_eq!(m["missed_exits"], 0.0, "{m:#?}");
    assert!(m["vehicles_destroyed"] > 50.0, "{m:#?}");
    assert!(m["mean_speed_kmh"] > 60.0, "{m:#?}");
}

#[test]
fn a_gzip_compressed_network_imports_as_the_plain_one_does() {
    use std::io::Write;
    let dir = tempfile::tempdir().expect("tempdir");
    let plain = std::fs::read(fixture("tee.net.xml")).expect("the fixture");
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    gz.write_all(&plain).expect("compress");
    let packed = gz.finish().expect("compress");
    let net = dir.path().join("tee.net.xml.gz");
    std::fs::write(&net, &packed).expect("write");
    let import = |net: &Path, out: &Path| {
        Command::new(env!("CARGO_BIN_EXE_flockway"))
            .arg("import")
            .arg(net)
            .arg("-o")
            .arg(out)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .expect("flockway runs")
    };
    let (a, b) = (dir.path().join("a.ron"), dir.path().join("b.ron"));
    assert!(import(&net, &a).status.success());
    assert!(import(&fixture("tee.net.xml"), &b).status.success());
    // The same level, but for the file name it says it came from.
    let a = std::fs::read_to_string(&a).expect("a");
    let b = std::fs::read_to_string(&b).expect("b");
    assert_eq!(
        a.replace("tee.net.xml.gz", "tee.net.xml")
            .replace("\"a\"", "\"b\"")
            .replace("// a:", "// b:"),
        b
    );
    // A file cut short is an error that says what it is, not a panic.
    let cut = dir.path().join("cut.net.xml.gz");
    std::fs::write(&cut, &packed[..packed.len() / 2]).expect("write");
    let out = import(&cut, &dir.path().join("c.ron"));
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("gzip-compressed"), "{err}");
}
