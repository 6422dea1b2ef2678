//! Unit tests of road geometry against exact shapes.

use crate::*;
use glam::DVec3;
use std::f64::consts::{PI, TAU};

fn curved_road(lanes: u32) -> RoadGeometry {
    // An S-bend with a hill: curves both ways, climbs and falls.
    let pts = [
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(80.0, 10.0, 2.0),
        DVec3::new(150.0, 70.0, 5.0),
        DVec3::new(160.0, 160.0, 3.0),
        DVec3::new(230.0, 220.0, 0.0),
        DVec3::new(330.0, 210.0, 0.0),
    ];
    RoadGeometry::new(&RoadSpec::through("s-bend", lanes, 60.0, &pts)).expect("valid road")
}

/// A tiny deterministic generator for test inputs (no dependency, no global state).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

#[test]
fn circle_arc_length_is_two_pi_r() {
    for (radius, n) in [(36.6, 12), (100.0, 16), (500.0, 24)] {
        let g = RoadGeometry::new(&RoadSpec::ring("ring", 1, 30.0, DVec3::ZERO, radius, n))
            .expect("ring");
        let exact = TAU * radius;
        let rel = (g.length_m() - exact).abs() / exact;
        assert!(
            rel < 5e-4,
            "R={radius} n={n}: length {} vs {exact} ({:.4} %)",
            g.length_m(),
            rel * 100.0
        );
        // And the curve stays on the circle, not just the right length.
        for k in 0..200 {
            let p = g.pos_at(g.length_m() * k as f64 / 200.0);
            assert!(
                (p.truncate().length() - radius).abs() / radius < 1e-4,
                "off the circle at {p}"
            );
        }
    }
}

#[test]
fn arc_length_parameterisation_is_unit_speed() {
    let g = curved_road(2);
    let h = 0.01;
    let mut s = 0.0;
    while s + h < g.length_m() {
        let d = (g.pos_at(s + h) - g.pos_at(s)).length();
        assert!((d - h).abs() < 1e-6, "at s={s}: |Δp| = {d} for Δs = {h}");
        s += 3.7;
    }
}

#[test]
fn straight_road_length_and_frame_are_exact() {
    let g = RoadGeometry::new(&RoadSpec::through(
        "straight",
        3,
        60.0,
        &[DVec3::ZERO, DVec3::new(500.0, 0.0, 0.0)],
    ))
    .expect("road");
    assert!((g.length_m() - 500.0).abs() < 1e-9);
    let f = g.frame_at(123.0);
    assert!((f.pos - DVec3::new(123.0, 0.0, 0.0)).length() < 1e-9);
    assert!((f.tangent - DVec3::X).length() < 1e-12);
    assert!((f.left - DVec3::Y).length() < 1e-12);
    assert!((f.up - DVec3::Z).length() < 1e-12);
    assert_eq!(f.width_m, 9.0);
    // Lane 0 is the rightmost: negative lateral offset.
    assert!((g.lane_offset_m(0, 10.0) + 3.0).abs() < 1e-12);
    assert!((g.lane_offset_m(1, 10.0)).abs() < 1e-12);
    assert!((g.lane_offset_m(2, 10.0) - 3.0).abs() < 1e-12);
}

#[test]
fn lane_centre_lines_are_three_metres_apart_on_a_curved_road() {
    let g = curved_road(4);
    for s in g.stations(0.5) {
        for lane in 0..3 {
            let a = g.lane_point(lane, s);
            let b = g.lane_point(lane + 1, s);
            assert!(
                ((a - b).length() - 3.0).abs() < 1e-9,
                "s={s} lanes {lane},{}",
                lane + 1
            );
            // Parallel curves: lane `lane + 1`'s point projects onto the same arc position.
            let p = g.project(b);
            assert!(
                g.delta_s(s, p.s_m).abs() < 1e-6,
                "s={s} projected to {}",
                p.s_m
            );
            assert_eq!(p.lane, lane + 1);
        }
    }
}

#[test]
fn closest_point_round_trip_is_within_a_millimetre() {
    let mut rng = Lcg(9);
    for g in [
        curved_road(4),
        RoadGeometry::new(&RoadSpec::ring("ring", 2, 30.0, DVec3::ZERO, 36.6, 10)).expect("ring"),
    ] {
        let half = 0.5 * g.frame_at(0.0).width_m;
        for _ in 0..5000 {
            let s = rng.next() * g.length_m();
            let lateral = (rng.next() * 2.0 - 1.0) * half;
            let height = rng.next() * 2.0;
            let f = g.frame_at(s);
            let q = f.offset(lateral) + f.up * height;
            let p = g.project(q);
            let back = g.frame_at(p.s_m);
            let q2 = back.offset(p.lateral_m) + back.up * p.height_m;
            assert!(
                (q2 - q).length() < 1e-3,
                "{}: s={s} lat={lateral}: {} mm off",
                g.name(),
                (q2 - q).length() * 1e3
            );
            assert!(g.delta_s(s, p.s_m).abs() < 1e-3, "s={s} vs {}", p.s_m);
            assert!((p.lateral_m - lateral).abs() < 1e-3 && (p.height_m - height).abs() < 1e-3);
            assert!(p.on_road);
            // The hinted and tracked queries agree.
            let near = g.project_near(q, s + 3.0);
            assert!(g.delta_s(near.s_m, p.s_m).abs() < 1e-6);
            let mut cursor = g.cursor_at(s - 2.0);
            let tracked = g.project_tracked(q, &mut cursor);
            assert!(g.delta_s(tracked.s_m, p.s_m).abs() < 1e-6);
            // The cursor now sits at the answer: projecting again from it is the same.
            assert!((g.project_tracked(q, &mut cursor).s_m - tracked.s_m).abs() < 1e-7);
        }
    }
}

#[test]
fn tracked_projection_finds_a_point_far_from_its_cursor() {
    let g = curved_road(2);
    let len = g.length_m();
    for (from, to) in [
        (5.0, len - 5.0),
        (len - 5.0, 5.0),
        (10.0, 60.0),
        (60.0, 30.0),
    ] {
        let mut cursor = g.cursor_at(from);
        let q = g.frame_at(to).offset(1.0);
        let tracked = g.project_tracked(q, &mut cursor);
        assert!(
            (tracked.s_m - to).abs() < 1e-3,
            "from {from} to {to}: {}",
            tracked.s_m
        );
        // The cursor moved with the answer: a small step from there is tracked, not searched.
        let q2 = g.frame_at(to + 0.2).offset(1.0);
        assert!((g.project_tracked(q2, &mut cursor).s_m - (to + 0.2)).abs() < 1e-3);
    }
}

#[test]
fn projection_matches_brute_force_for_points_anywhere() {
    let g = curved_road(2);
    let dense: Vec<(f64, DVec3)> = g
        .stations(0.05)
        .into_iter()
        .map(|s| (s, g.pos_at(s)))
        .collect();
    let mut rng = Lcg(3);
    for _ in 0..300 {
        let q = DVec3::new(
            rng.next() * 600.0 - 150.0,
            rng.next() * 600.0 - 150.0,
            rng.next() * 20.0 - 10.0,
        );
        let best = dense
            .iter()
            .map(|(s, p)| ((*p - q).length(), *s))
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .expect("samples");
        let p = g.project(q);
        // Far from the road, near a centre of curvature, the distance is almost flat along the
        // road: any point there is a fine answer, so allow a relative 1e-5 there.
        assert!(
            p.distance_m <= best.0 * (1.0 + 1e-5) + 1e-6,
            "q={q}: {} vs brute {}",
            p.distance_m,
            best.0
        );
        assert!(
            p.distance_m >= best.0 - 0.01,
            "q={q}: {} vs brute {}",
            p.distance_m,
            best.0
        );
    }
}

#[test]
fn projection_past_the_end_of_an_open_road_clamps() {
    let g = RoadGeometry::new(&RoadSpec::through(
        "straight",
        1,
        60.0,
        &[DVec3::ZERO, DVec3::new(100.0, 0.0, 0.0)],
    ))
    .expect("road");
    let p = g.project(DVec3::new(130.0, 1.0, 0.0));
    assert!((p.s_m - 100.0).abs() < 1e-9);
    assert!((p.distance_m - (900.0f64 + 1.0).sqrt()).abs() < 1e-9);
    let p = g.project(DVec3::new(-5.0, 0.0, 0.0));
    assert!(p.s_m.abs() < 1e-9);
}

#[test]
fn closed_loop_join_is_seamless() {
    // An irregular loop so the join is not helped by symmetry.
    let pts = [
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(120.0, -20.0, 3.0),
        DVec3::new(160.0, 80.0, 6.0),
        DVec3::new(60.0, 140.0, 2.0),
        DVec3::new(-40.0, 70.0, 0.0),
    ];
    let mut spec = RoadSpec::through("loop", 2, 50.0, &pts);
    spec.closed = true;
    let g = RoadGeometry::new(&spec).expect("loop");
    let l = g.length_m();
    let eps = 1e-7;
    let before = g.frame_at(l - eps);
    let after = g.frame_at(0.0);
    let wrapped = g.frame_at(l + eps);
    assert!((before.pos - after.pos).length() < 1e-6);
    assert!((wrapped.pos - after.pos).length() < 1e-6);
    assert!(
        before.tangent.angle_between(after.tangent) < 1e-6,
        "kink at the join"
    );
    assert!((before.up - after.up).length() < 1e-6);
    // Every control point, including the join, is G1: no kink anywhere.
    for (i, point) in pts.iter().enumerate() {
        let s = g.point_s(i).expect("point");
        let a = g.frame_at(s - 1e-6).tangent;
        let b = g.frame_at(s + 1e-6).tangent;
        assert!(a.angle_between(b) < 1e-5, "kink at point {i}");
        assert!(
            (g.pos_at(s) - *point).length() < 1e-9,
            "spline misses point {i}"
        );
    }
    assert_eq!(g.normalize_s(l), 0.0);
    assert!((g.delta_s(l - 1.0, 1.0) - 2.0).abs() < 1e-9);
}

#[test]
fn bank_tilts_the_surface_normal() {
    let mut spec = RoadSpec::through(
        "banked",
        2,
        60.0,
        &[
            DVec3::ZERO,
            DVec3::new(100.0, 0.0, 0.0),
            DVec3::new(200.0, 0.0, 0.0),
        ],
    );
    for p in &mut spec.points {
        p.bank_deg = 10.0;
    }
    let g = RoadGeometry::new(&spec).expect("road");
    let f = g.frame_at(50.0);
    let bank = 10f64.to_radians();
    assert!((f.up.dot(DVec3::Z) - bank.cos()).abs() < 1e-12);
    // Positive bank raises the left edge, so the normal leans to the right (−y here).
    assert!((f.up.y + bank.sin()).abs() < 1e-12);
    assert!(f.offset(2.0).z > 0.0 && f.offset(-2.0).z < 0.0);
    assert!(f.up.dot(f.left).abs() < 1e-12 && f.up.dot(f.tangent).abs() < 1e-12);
    assert!((f.bank_rad - bank).abs() < 1e-12);
    // Bank blends smoothly from one point's value to the next.
    spec.points[2].bank_deg = -10.0;
    let g = RoadGeometry::new(&spec).expect("road");
    assert!(g.frame_at(150.0).bank_rad.abs() < 1e-9);
    assert!(g.frame_at(100.0).bank_rad > 0.0 && g.frame_at(199.0).bank_rad < 0.0);
}

#[test]
fn tangent_override_sets_the_direction() {
    let mut spec = RoadSpec::through(
        "t",
        1,
        60.0,
        &[
            DVec3::ZERO,
            DVec3::new(100.0, 0.0, 0.0),
            DVec3::new(200.0, 50.0, 0.0),
        ],
    );
    spec.points[1].tangent = Some(DVec3::new(1.0, 1.0, 0.0));
    let g = RoadGeometry::new(&spec).expect("road");
    let s1 = g.point_s(1).expect("point");
    let t = g.frame_at(s1).tangent;
    assert!((t - DVec3::new(1.0, 1.0, 0.0).normalize()).length() < 1e-9);
}

#[test]
fn invalid_specs_are_errors() {
    let ok = RoadSpec::through("r", 2, 60.0, &[DVec3::ZERO, DVec3::new(50.0, 0.0, 0.0)]);
    let mut s = ok.clone();
    s.points.pop();
    assert!(matches!(
        RoadGeometry::new(&s),
        Err(RoadError::TooFewPoints { .. })
    ));
    let mut s = ok.clone();
    s.points[1].width_m = Some(f64::NAN);
    assert!(matches!(
        RoadGeometry::new(&s),
        Err(RoadError::Width { .. })
    ));
    let mut s = ok.clone();
    s.points[1].pos = s.points[0].pos;
    assert!(matches!(
        RoadGeometry::new(&s),
        Err(RoadError::PointsTooClose { .. })
    ));
    let mut s = ok.clone();
    s.lanes = 0;
    assert!(matches!(
        RoadGeometry::new(&s),
        Err(RoadError::Lanes { .. })
    ));
    let mut s = ok.clone();
    s.speed_limit_kmh = -1.0;
    assert!(matches!(
        RoadGeometry::new(&s),
        Err(RoadError::SpeedLimit { .. })
    ));
    let mut s = ok;
    s.points[0].pos.x = f64::INFINITY;
    assert!(matches!(
        RoadGeometry::new(&s),
        Err(RoadError::Position { .. })
    ));
}

#[test]
fn meshes_cover_the_road_and_close_the_loop() {
    let ring =
        RoadGeometry::new(&RoadSpec::ring("ring", 2, 30.0, DVec3::ZERO, 36.6, 12)).expect("ring");
    let m = RoadMeshes::build(&ring);
    let stations = ring.stations(STATION_STEP_M).len();
    assert_eq!(m.surface.triangle_count(), (stations - 1) * 2 * 2);
    // Seamless: the last row of vertices coincides with the first.
    let cols = 3;
    let last = m.surface.positions.len() - cols;
    for b in 0..cols {
        let (p, q) = (m.surface.positions[b], m.surface.positions[last + b]);
        let d = glam::Vec3::from(p) - glam::Vec3::from(q);
        assert!(d.length() < 1e-3, "gap at the join: {d}");
    }
    // Surface normals point up and triangles wind counter-clockwise seen from above.
    for tri in m.surface.indices.chunks(3) {
        let [a, b, c] =
            [tri[0], tri[1], tri[2]].map(|i| glam::Vec3::from(m.surface.positions[i as usize]));
        assert!((b - a).cross(c - a).z > 0.0);
    }
    // Both guardrails run the whole way round, as one run each.
    assert_eq!(m.guardrail_runs.len(), 2);
    assert!(
        m.guardrail_runs
            .iter()
            .all(|r| (r.to_s_m - ring.length_m()).abs() < 1e-9 && r.from_s_m == 0.0)
    );
    assert!(m.markings.triangle_count() > 0 && m.guardrails.triangle_count() > 0);
    // The left rail sits outside the left edge.
    let left = m
        .guardrail_runs
        .iter()
        .find(|r| r.side == Side::Left)
        .expect("left rail");
    let p = ring.project(left.foot[10]);
    assert!((p.lateral_m - (3.0 + GUARDRAIL_OFFSET_M)).abs() < 1e-6);
}

#[test]
fn guardrail_flags_split_runs() {
    let mut spec = RoadSpec::through(
        "r",
        1,
        60.0,
        &[
            DVec3::ZERO,
            DVec3::new(50.0, 0.0, 0.0),
            DVec3::new(100.0, 0.0, 0.0),
            DVec3::new(150.0, 0.0, 0.0),
        ],
    );
    spec.points[1].guardrail_left = false;
    let g = RoadGeometry::new(&spec).expect("road");
    let m = RoadMeshes::build(&g);
    let lefts: Vec<_> = m
        .guardrail_runs
        .iter()
        .filter(|r| r.side == Side::Left)
        .collect();
    assert_eq!(lefts.len(), 2);
    assert!((lefts[0].to_s_m - 50.0).abs() < 1e-6 && (lefts[1].from_s_m - 100.0).abs() < 1e-6);
    assert_eq!(
        m.guardrail_runs
            .iter()
            .filter(|r| r.side == Side::Right)
            .count(),
        1
    );
}

#[test]
fn network_follows_connections() {
    let a = RoadSpec {
        next: Some("b".into()),
        ..RoadSpec::through("a", 2, 60.0, &[DVec3::ZERO, DVec3::new(100.0, 0.0, 0.0)])
    };
    let b = RoadSpec::through(
        "b",
        2,
        60.0,
        &[DVec3::new(100.0, 0.0, 0.0), DVec3::new(200.0, 0.0, 0.0)],
    );
    let net = RoadNetwork::build(&[a.clone(), b.clone()]).expect("network");
    let (ia, ib) = (net.id("a").expect("a"), net.id("b").expect("b"));
    assert_eq!(net.next(ia), Some(ib));
    let (road, s) = net.advance(ia, 90.0, 25.0).expect("continues");
    assert_eq!(road, ib);
    assert!((s - 15.0).abs() < 1e-9);
    assert_eq!(net.advance(ib, 90.0, 25.0), None);
    let (road, p) = net.project(DVec3::new(150.0, 1.0, 0.0)).expect("a road");
    assert_eq!(road, ib);
    assert!((p.s_m - 50.0).abs() < 1e-9);

    let far = RoadSpec::through(
        "b",
        2,
        60.0,
        &[DVec3::new(110.0, 0.0, 0.0), DVec3::new(200.0, 0.0, 0.0)],
    );
    assert!(matches!(
        RoadNetwork::build(&[a.clone(), far]),
        Err(NetworkError::Gap { .. })
    ));
    assert!(matches!(
        RoadNetwork::build(std::slice::from_ref(&a)),
        Err(NetworkError::UnknownNext { .. })
    ));
    assert!(matches!(
        RoadNetwork::build(&[b.clone(), b]),
        Err(NetworkError::DuplicateName(_))
    ));
}

#[test]
fn ring_advance_wraps() {
    let net = RoadNetwork::build(&[RoadSpec::ring("ring", 1, 30.0, DVec3::ZERO, 36.6, 12)])
        .expect("ring");
    let id = net.id("ring").expect("ring");
    let l = net.get(id).expect("ring").length_m();
    let (_, s) = net.advance(id, l - 1.0, 3.0).expect("wraps");
    assert!((s - 2.0).abs() < 1e-9);
    let (_, s) = net.advance(id, 1.0, -3.0).expect("wraps back");
    assert!((s - (l - 2.0)).abs() < 1e-9);
    assert!(l > 0.0 && l < 2.0 * PI * 36.6 * 1.001);
}

#[test]
fn arc_table_interpolation_matches_quadrature() {
    let g = curved_road(2);
    let mut rng = Lcg(5);
    for _ in 0..2000 {
        let s = rng.next() * g.length_m();
        let p = g.param_at(s);
        // Exact arc position of that parameter by quadrature from the segment start.
        let start = g.point_s(p.seg).expect("segment start");
        let c = g.segment_cubic(p.seg);
        let exact = start
            + (0..200)
                .map(|k| c.length(p.u * k as f64 / 200.0, p.u * (k + 1) as f64 / 200.0))
                .sum::<f64>();
        assert!((exact - s).abs() < 1e-6, "s={s}: quadrature says {exact}");
        assert!(
            (g.s_of(p) - s).abs() < 1e-6,
            "s_of(param_at(s)) = {} for {s}",
            g.s_of(p)
        );
    }
}

#[test]
fn frame_near_a_cursor_matches_frame_at_and_crosses_joins() {
    let g = curved_road(3);
    let mut rng = Lcg(11);
    for _ in 0..400 {
        let s = 5.0 + rng.next() * (g.length_m() - 10.0);
        let ds = (rng.next() - 0.5) * 6.0;
        let cursor = g.cursor_at(s);
        let Some(f) = g.frame_near(&cursor, s, ds) else {
            assert!(s + ds < 0.0 || s + ds > g.length_m(), "{s} {ds}");
            continue;
        };
        let exact = g.frame_at(s + ds);
        assert_eq!(f.s_m, s + ds);
        // The frame is exactly on the road: the cross-section frame_at gives at its true arc
        // position, which is within a few millimetres of the one asked for.
        let mut c = g.cursor_at(s + ds);
        let (proj, _) = g.project_tracked_frame(f.pos, &mut c);
        assert!(
            (proj.s_m - (s + ds)).abs() < 2.5e-3,
            "{} vs {}",
            proj.s_m,
            s + ds
        );
        let at = g.frame_at(proj.s_m);
        assert!(f.pos.distance(at.pos) < 1e-6 && f.up.distance(at.up) < 1e-6);
        assert!(f.pos.distance(exact.pos) < 2.5e-3);
    }
    // Off the ends of an open road there is no frame.
    assert!(g.frame_near(&g.cursor_at(1.0), 1.0, -2.0).is_none());
    let end = g.length_m() - 1.0;
    assert!(g.frame_near(&g.cursor_at(end), end, 2.0).is_none());
    // Across the join of a closed loop it wraps.
    let ring =
        RoadGeometry::new(&RoadSpec::ring("r", 1, 30.0, DVec3::ZERO, 50.0, 8)).expect("valid ring");
    let near_end = ring.length_m() - 1.0;
    let f = ring
        .frame_near(&ring.cursor_at(near_end), near_end, 3.0)
        .expect("wraps");
    assert!((f.s_m - 2.0).abs() < 1e-9, "{}", f.s_m);
    assert!(f.pos.distance(ring.frame_at(2.0).pos) < 2.5e-3);
    let f = ring
        .frame_near(&ring.cursor_at(1.0), 1.0, -3.0)
        .expect("wraps back");
    assert!((f.s_m - (ring.length_m() - 2.0)).abs() < 1e-9, "{}", f.s_m);
    assert!(f.pos.distance(ring.frame_at(ring.length_m() - 2.0).pos) < 2.5e-3);
}

#[test]
fn project_tracked_frame_returns_the_frame_at_the_projection() {
    let g = curved_road(2);
    let s = 123.0;
    let f = g.frame_at(s);
    let q = f.offset(1.7) + f.up * 0.3;
    let mut cursor = g.cursor_at(s - 4.0);
    let (proj, frame) = g.project_tracked_frame(q, &mut cursor);
    assert!((proj.s_m - s).abs() < 1e-6 && (proj.lateral_m - 1.7).abs() < 1e-6);
    assert!(frame.pos.distance(f.pos) < 1e-6 && frame.tangent.distance(f.tangent) < 1e-6);
}

#[test]
fn a_ring_has_the_curvature_of_its_circle_and_a_straight_none() {
    // A ring drawn counter-clockwise turns left: +1/R everywhere, also in every bin.
    for (radius, n) in [(20.0, 12), (36.6, 12), (150.0, 16)] {
        let g = RoadGeometry::new(&RoadSpec::ring("ring", 1, 30.0, DVec3::ZERO, radius, n))
            .expect("valid");
        for i in 0..50 {
            let s = g.length_m() * f64::from(i) / 50.0;
            let k = g.curvature_at(s);
            assert!((k * radius - 1.0).abs() < 0.01, "R={radius} at {s}: κ={k}");
        }
        let bins = g.curvature_bins();
        assert_eq!(bins.len(), (g.length_m() / CURVATURE_BIN_M).ceil() as usize);
        assert!(
            bins.iter()
                .all(|&k| (f64::from(k) * radius - 1.0).abs() < 0.01),
            "R={radius}"
        );
    }
    let straight = RoadGeometry::new(&RoadSpec::through(
        "s",
        2,
        50.0,
        &[
            DVec3::ZERO,
            DVec3::new(150.0, 0.0, 4.0),
            DVec3::new(300.0, 0.0, 0.0),
        ],
    ))
    .expect("valid");
    assert!(straight.curvature_bins().iter().all(|&k| k.abs() < 1e-9));
    // Drawn clockwise, the same circle turns right.
    let mut spec = RoadSpec::ring("cw", 1, 30.0, DVec3::ZERO, 50.0, 12);
    spec.points.reverse();
    let cw = RoadGeometry::new(&spec).expect("valid");
    assert!((cw.curvature_at(10.0) * 50.0 + 1.0).abs() < 0.01);
}

#[test]
fn two_frames_near_a_cursor_at_once_have_each_frame_s_bits() {
    let mut spec = RoadSpec::through(
        "banked curve",
        3,
        60.0,
        &[
            DVec3::ZERO,
            DVec3::new(60.0, 10.0, 1.0),
            DVec3::new(110.0, 60.0, 3.0),
            DVec3::new(120.0, 130.0, 2.0),
        ],
    );
    spec.points[1].bank_deg = 6.0;
    spec.points[2].bank_deg = -4.0;
    let banked = RoadGeometry::new(&spec).expect("road");
    let bits = |f: &RoadFrame| {
        [
            f.s_m,
            f.pos.x,
            f.pos.y,
            f.pos.z,
            f.tangent.x,
            f.tangent.y,
            f.tangent.z,
            f.left.x,
            f.left.y,
            f.left.z,
            f.up.x,
            f.up.y,
            f.up.z,
            f.bank_rad,
            f.width_m,
        ]
        .map(f64::to_bits)
    };
    for g in [curved_road(3), banked] {
        let mut rng = Lcg(7);
        for _ in 0..400 {
            let s = rng.next() * g.length_m();
            let ds = [1.3 + rng.next() * 2.0, -1.3 - rng.next() * 2.0];
            let cursor = g.cursor_at(s);
            let two = g.frames_near(&cursor, s, ds);
            for i in 0..2 {
                let one = g.frame_near(&cursor, s, ds[i]);
                assert_eq!(
                    two[i].map(|f| bits(&f)),
                    one.map(|f| bits(&f)),
                    "{s} {}",
                    ds[i]
                );
            }
        }
    }
}

#[test]
fn the_tangent_near_a_cursor_has_its_frame_s_bits() {
    let mut spec = RoadSpec::ring("banked ring", 2, 50.0, DVec3::ZERO, 80.0, 10);
    spec.points[3].bank_deg = 5.0;
    let ring = RoadGeometry::new(&spec).expect("road");
    for g in [curved_road(3), ring] {
        let mut rng = Lcg(11);
        for _ in 0..400 {
            let s = rng.next() * g.length_m();
            // Ahead and behind, far enough to cross segments, past the ends of the open road
            // and round the ring's join.
            let ds = (rng.next() - 0.3) * 120.0;
            let cursor = g.cursor_at(s);
            let frame = g.frame_near(&cursor, s, ds).map(|f| f.tangent.to_array());
            let tangent = g.tangent_near(&cursor, ds).map(|t| t.to_array());
            assert_eq!(
                tangent.map(|t| t.map(f64::to_bits)),
                frame.map(|t| t.map(f64::to_bits)),
                "{s} {ds}"
            );
        }
    }
}
