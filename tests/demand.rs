//! SUMO demand in: `flockway import NET --routes DEMAND` turns vehicle types, routes, vehicles,
//! trips and flows into driver profiles and spawners' timetables; the vehicles leave at their
//! times on their routes, wait when there is no room (counted), and bad demand is an error at
//! its line and column.

#[allow(dead_code, reason = "shared with the tests that run shipped levels")]
mod common;

use common::run;
use flockway::level::{DriverModel, Level, import_sumo};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/sumo")
        .join(name)
}

/// The crossroads network with `demand` (the text of a `.rou.xml` named `demand.rou.xml`).
fn import_cross(demand: &str) -> Result<Level, String> {
    let net = fixture("cross.net.xml");
    let text = std::fs::read_to_string(&net).expect("the fixture");
    import_sumo(
        &text,
        &net,
        "demand",
        &[(PathBuf::from("demand.rou.xml"), demand.to_owned())],
    )
    .map(|(level, _)| level)
    .map_err(|e| e.to_string())
}

/// Each vehicle's first telemetry row: (time s, driver profile, route).
fn first_rows(csv: &Path) -> Vec<(f64, String, String)> {
    let mut reader = csv::Reader::from_path(csv).expect("the csv");
    let headers = reader.headers().expect("a header").clone();
    let col = |name: &str| headers.iter().position(|h| h == name).expect(name);
    let (t, id, driver, route) = (
        col("time_s"),
        col("vehicle_id"),
        col("driver"),
        col("route"),
    );
    let mut first: BTreeMap<u32, (f64, String, String)> = BTreeMap::new();
    for row in reader.records() {
        let row = row.expect("a row");
        let vehicle: u32 = row[id].parse().expect("an id");
        first.entry(vehicle).or_insert_with(|| {
            (
                row[t].parse().expect("a time"),
                row[driver].to_owned(),
                row[route].to_owned(),
            )
        });
    }
    let mut rows: Vec<_> = first.into_values().collect();
    rows.sort_by(|a, b| a.0.total_cmp(&b.0).then_with(|| a.2.cmp(&b.2)));
    rows
}

#[test]
fn every_kind_of_demand_leaves_at_its_time_on_its_route() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("cross_demand.ron");
    let import = Command::new(env!("CARGO_BIN_EXE_flockway"))
        .arg("import")
        .arg(fixture("cross.net.xml"))
        .arg("--routes")
        .arg(fixture("cross.rou.xml"))
        .arg("-o")
        .arg(&out)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("flockway runs");
    assert!(import.status.success(), "{import:?}");
    let stdout = String::from_utf8_lossy(&import.stdout);
    let stderr = String::from_utf8_lossy(&import.stderr);
    assert!(stdout.contains("demand: "), "{stdout}");
    // The bus and the bus flow are left out, and said to be.
    assert!(stderr.contains("2 bus"), "{stderr}");
    let level = flockway::level::load_level(&out).expect("the written level loads");
    // A profile per vehicle type used, each driven by the nearest built-in model.
    let model = |name: &str| {
        level
            .driver_profiles
            .iter()
            .find(|p| p.name == name)
            .map(|p| (p.model.clone(), p.set.clone()))
            .unwrap_or_else(|| panic!("profile {name}"))
    };
    let (idm, set) = model("idm");
    assert_eq!(idm, DriverModel::Idm);
    assert_eq!(set["time_headway_s"], 1.2);
    assert_eq!(set["max_accel_mps2"], 1.5);
    let (car, set) = model("car");
    assert_eq!(car, DriverModel::FlockLanes);
    assert_eq!(
        (set["speed_factor.mean"], set["speed_factor.dev"]),
        (1.0, 0.1)
    );
    let (acc, set) = model("acc");
    assert_eq!((acc, set["time_gap_s"]), (DriverModel::FlockLanes, 1.4));
    assert_eq!(model("DEFAULT_VEHTYPE").0, DriverModel::FlockLanes);
    assert!(level.driver_profiles.iter().all(|p| p.name != "bus"));

    let csv = dir.path().join("run.csv");
    let m = run(level, &out, 3, None, Some(csv.clone()));
    let rows = first_rows(&csv);
    // The vehicles whose times are fixed, at their times (the telemetry samples every 0.5 s).
    let fixed: Vec<(f64, &str, &str)> = vec![
        (0.0, "car", "we"),
        (2.5, "idm", "v1"),
        (5.0, "idm", "f_period"),
        (10.0, "car", "ns"),
        (20.0, "car", "ns"),
        (25.0, "idm", "f_period"),
        (30.0, "car", "ns"),
        (40.0, "car", "ns"),
        (45.0, "idm", "f_period"),
        (50.0, "car", "ns"),
        (60.0, "car", "ns"),
        (60.0, "acc", "t0"),
        (61.0, "DEFAULT_VEHTYPE", "t1"),
        (100.0, "DEFAULT_VEHTYPE", "we"),
        (125.0, "DEFAULT_VEHTYPE", "we"),
        (150.0, "DEFAULT_VEHTYPE", "we"),
        (175.0, "DEFAULT_VEHTYPE", "we"),
    ];
    let seen: Vec<(f64, &str, &str)> = rows
        .iter()
        .filter(|r| r.2 != "f_prob")
        .map(|r| (r.0, r.1.as_str(), r.2.as_str()))
        .collect();
    assert_eq!(seen, fixed);
    // The random flow: one draw a second for 120 s at 0.05, on whole seconds.
    let random: Vec<f64> = rows
        .iter()
        .filter(|r| r.2 == "f_prob")
        .map(|r| r.0)
        .collect();
    assert!((1..=15).contains(&random.len()), "{random:?}");
    assert!(
        random.iter().all(|t| t.fract() == 0.0 && *t < 120.0),
        "{random:?}"
    );
    let total = (fixed.len() + random.len()) as f64;
    assert_eq!(m["vehicles_spawned"], total, "{m:#?}");
    // Every one arrives: at the network's edge, or where its route ends.
    assert_eq!(m["vehicles_destroyed"], total, "{m:#?}");
    assert_eq!(m["insertion_backlog"], 0.0, "{m:#?}");
    assert_eq!(m["collisions"], 0.0, "{m:#?}");
}

#[test]
fn vehicles_with_no_room_to_depart_wait_and_are_counted() {
    // Thirty cars due at once on one lane: they leave one after another as room clears.
    let flow = r#"<routes>
        <flow id="rush" route="we" begin="0" end="1" number="30"/>
        <route id="we" edges="WC CE"/>
    </routes>"#;
    let err = import_cross(flow).expect_err("the route is defined after its use");
    assert!(
        err.contains("demand.rou.xml:2:9: unknown route `we`"),
        "{err}"
    );
    let flow = r#"<routes>
        <route id="we" edges="WC CE"/>
        <flow id="rush" route="we" begin="0" end="1" number="30" departSpeed="max"/>
    </routes>"#;
    let level = import_cross(flow).expect("imports");
    assert_eq!(level.spawners.len(), 1);
    assert_eq!(level.spawners[0].departures.len(), 30);
    let path = fixture("cross.net.xml");
    let early = run(level.clone(), &path, 1, Some(10.0), None);
    assert!(early["insertion_backlog"] >= 20.0, "{early:#?}");
    assert_eq!(
        early["vehicles_spawned"] + early["insertion_backlog"],
        30.0,
        "{early:#?}"
    );
    let all = run(level, &path, 1, Some(120.0), None);
    assert_eq!(all["insertion_backlog"], 0.0, "{all:#?}");
    assert_eq!(all["vehicles_spawned"], 30.0, "{all:#?}");
    assert_eq!(all["collisions"], 0.0, "{all:#?}");
}

#[test]
fn a_route_that_ends_inside_the_network_arrives_there_and_through_traffic_drives_on() {
    // `CE` leads on to nothing but the destroyer at its end; a route ending on `WC` (before the
    // junction) arrives there, while the cars going on through stay on their way.
    let demand = r#"<routes>
        <flow id="short" from="WC" to="WC" begin="0" end="60" period="10"/>
        <flow id="long" from="WC" to="CE" begin="5" end="65" period="10"/>
    </routes>"#;
    let level = import_cross(demand).expect("imports");
    let arrive: Vec<_> = level
        .destroyers
        .iter()
        .filter(|d| d.arrivals_only)
        .collect();
    assert_eq!(arrive.len(), 1, "{:#?}", level.destroyers);
    assert_eq!(arrive[0].name, "arrive WC");
    let m = run(level, &fixture("cross.net.xml"), 2, Some(200.0), None);
    assert_eq!(m["vehicles_spawned"], 12.0, "{m:#?}");
    assert_eq!(m["vehicles_destroyed"], 12.0, "{m:#?}");
    // Only the six that go on through reach the far end.
    assert!(m["flow_veh_per_h.CE"] > 0.0, "{m:#?}");
    let through = m["flow_veh_per_h.CE"] * 200.0 / 3600.0;
    assert!((through - 6.0).abs() < 0.01, "{m:#?}");
}

/// Route and type distributions: each vehicle draws its own route and type, in proportion to
/// the members' probabilities, the same way for the same seed.
#[test]
fn route_and_type_distributions_are_drawn_per_vehicle() {
    let demand = r#"<routes>
  <route id="straight" edges="WC CE"/>
  <vTypeDistribution id="mix">
    <vType id="calm" accel="1.5" probability="3"/>
    <vType id="brisk" accel="3.0" probability="1"/>
    <vType id="lorry" vClass="truck" probability="1"/>
  </vTypeDistribution>
  <vTypeDistribution id="listed" vTypes="calm brisk" probabilities="0 1"/>
  <routeDistribution id="ways">
    <route refId="straight" probability="1"/>
    <route edges="WC CN" probability="1"/>
    <route id="right" edges="WC CS" probability="0"/>
  </routeDistribution>
  <flow id="f" type="mix" route="ways" begin="0" end="400" period="1"/>
  <vehicle id="v" type="listed" route="ways" depart="3"/>
</routes>"#;
    let level = import_cross(demand).expect("the demand imports");
    let departures: Vec<&flockway::level::DepartureSpec> =
        level.spawners.iter().flat_map(|s| &s.departures).collect();
    let count =
        |f: &dyn Fn(&&&flockway::level::DepartureSpec) -> bool| departures.iter().filter(f).count();
    // 400 from the flow, a fifth of them lorries left out, and the one vehicle.
    let total = departures.len();
    assert!((310..=330).contains(&total), "{total} departures");
    let calm = count(&|d| d.profile == "calm");
    let brisk = count(&|d| d.profile == "brisk");
    assert_eq!(calm + brisk, total);
    // 3 : 1, within what 400 draws allow.
    assert!(
        (2.4..3.8).contains(&(calm as f64 / (brisk as f64 - 1.0))),
        "{calm} : {brisk}"
    );
    let route = |name: &str| count(&|d| d.route.as_deref() == Some(name));
    assert_eq!(route("right"), 0);
    assert_eq!(route("straight") + route("ways#1"), total);
    let straight = route("straight") as f64 / total as f64;
    assert!((0.42..0.58).contains(&straight), "{straight}");
    assert_eq!(import_cross(demand).expect("imports"), level);
    let bad =
        import_cross("<routes>\n  <routeDistribution id=\"d\" routes=\"nowhere\"/>\n</routes>")
            .expect_err("an unknown member");
    assert!(
        bad.contains("demand.rou.xml:2:3: routeDistribution `d`: unknown route `nowhere`"),
        "{bad}"
    );
}

#[test]
fn a_route_that_turns_back_leaves_its_vehicles_out_and_a_route_that_jumps_is_an_error() {
    // `WC` then `CW` turns back at the centre, as SUMO may (randomTrips' routes often do); an
    // imported level has no such turn: those vehicles are left out, the rest run.
    let demand = r#"<routes>
  <route id="back" edges="WC CW"/>
  <vehicle id="a" depart="0" route="back"/>
  <vehicle id="b" depart="1"><route edges="WC CE"/></vehicle>
  <vehicle id="c" depart="2"><route edges="NC CN"/></vehicle>
</routes>"#;
    let net = fixture("cross.net.xml");
    let text = std::fs::read_to_string(&net).expect("the fixture");
    let (level, report) = import_sumo(
        &text,
        &net,
        "demand",
        &[(PathBuf::from("demand.rou.xml"), demand.to_owned())],
    )
    .expect("imports");
    assert_eq!(report.vehicles, 1, "{report:?}");
    let departures: usize = level.spawners.iter().map(|s| s.departures.len()).sum();
    assert_eq!(departures, 1);
    assert!(
        report.warnings[0].starts_with(
            "demand.rou.xml:3:3: `a`: route `back`: edge `WC` does not lead onto `CW`"
        ) && report.warnings[0].ends_with("such trips are left out"),
        "{:?}",
        report.warnings
    );
    assert_eq!(
        report.warnings.last().map(String::as_str),
        Some("2 trips and flows left out in all")
    );
    // Edges that do not meet are a mistake in the demand, inline as on their own.
    let jump = import_cross(
        "<routes>\n  <vehicle id=\"v\" depart=\"0\"><route edges=\"WC NC\"/></vehicle>\n</routes>",
    )
    .expect_err("a route between edges that do not meet");
    assert!(
        jump.contains("demand.rou.xml:2:3: edge `WC` does not lead onto `NC`"),
        "{jump}"
    );
}

#[test]
fn bad_demand_is_an_error_at_its_line_and_column() {
    let cases = [
        (
            "<routes>\n  <route id=\"r\" edges=\"WC nowhere\"/>\n</routes>",
            "demand.rou.xml:2:3: unknown edge `nowhere`",
        ),
        (
            "<routes>\n  <route id=\"r\" edges=\"WC EC\"/>\n</routes>",
            "demand.rou.xml:2:3: edge `WC` does not lead onto `EC`",
        ),
        (
            "<routes>\n  <vehicle id=\"v\" type=\"lorry\" depart=\"0\" from=\"WC\" to=\"CE\"/>\n</routes>",
            "demand.rou.xml:2:3: unknown vType `lorry`",
        ),
        (
            "<routes>\n  <trip id=\"v\" depart=\"soon\" from=\"WC\" to=\"CE\"/>\n</routes>",
            "demand.rou.xml:2:3: vehicle `v`: `depart` must be a time in seconds",
        ),
        (
            "<routes>\n  <flow id=\"f\" from=\"WC\" to=\"CE\" begin=\"0\" end=\"10\"/>\n</routes>",
            "demand.rou.xml:2:3: flow `f` needs one of `vehsPerHour`, `period`, `probability` or `number`",
        ),
        (
            "<routes>\n  <trip id=\"v\" depart=\"0\" from=\"WC\" to=\"CE\" departLane=\"3\"/>\n</routes>",
            "demand.rou.xml:2:3: `departLane` 3: edge `WC` has no such lane cars may use",
        ),
        (
            "<routes>\n  <vType id=\"t\" speedFactor=\"fast\"/>\n</routes>",
            "demand.rou.xml:2:3: vType `t`: `speedFactor` must be a number",
        ),
        ("<net/>", "demand.rou.xml:1:1: expected SUMO demand"),
        (
            "<routes>\n  <trip",
            "demand.rou.xml:1:1: not a well-formed XML file",
        ),
        ("<routes/>", "the demand has no vehicle a car can drive"),
    ];
    for (text, expected) in cases {
        let err = import_cross(text).expect_err(text);
        assert!(err.contains(expected), "{text}: {err}");
    }
}
