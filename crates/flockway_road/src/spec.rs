//! What the user edits: a road's control points and per-road settings, as stored in a level.

use glam::DVec3;
use serde::{Deserialize, Serialize};

/// Default width of one lane, in metres.
pub const DEFAULT_LANE_WIDTH_M: f64 = 3.0;

/// One control point the road passes through, with the road data that applies there.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControlPoint {
    /// Position in metres: x east, y north, z up.
    pub pos: DVec3,
    /// Road width here in metres; `None` means lanes × lane width.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub width_m: Option<f64>,
    /// Roll of the road surface about the direction of travel, in degrees. Positive raises the
    /// left edge (suits a right-hand curve); negative raises the right edge (a left-hand curve).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub bank_deg: f64,
    /// Whether a guardrail runs along the left edge from this point to the next.
    #[serde(default = "yes", skip_serializing_if = "is_true")]
    pub guardrail_left: bool,
    /// Whether a guardrail runs along the right edge from this point to the next.
    #[serde(default = "yes", skip_serializing_if = "is_true")]
    pub guardrail_right: bool,
    /// Direction the road leaves this point in (any length); `None` lets the spline choose
    /// (centripetal Catmull-Rom). Its magnitude is always the spline's own.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tangent: Option<DVec3>,
}

impl ControlPoint {
    /// A point at `pos` with default road data: lane-derived width, no bank, guardrails both sides.
    pub fn at(pos: DVec3) -> ControlPoint {
        ControlPoint {
            pos,
            width_m: None,
            bank_deg: 0.0,
            guardrail_left: true,
            guardrail_right: true,
            tangent: None,
        }
    }
}

/// A road as the user defines it: a spline through control points, with lanes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RoadSpec {
    /// Unique name within the level; spawners, triggers and connections refer to it.
    pub name: String,
    /// Whether the road is a closed loop (the last point joins the first, seamlessly).
    #[serde(default, skip_serializing_if = "is_false")]
    pub closed: bool,
    /// Number of lanes, all in the direction of travel. Lane 0 is the rightmost.
    #[serde(default = "one")]
    pub lanes: u32,
    /// Width of each lane in metres where a point does not set the road width.
    #[serde(
        default = "default_lane_width",
        skip_serializing_if = "is_default_lane_width"
    )]
    pub lane_width_m: f64,
    /// Speed limit in km/h.
    pub speed_limit_kmh: f64,
    /// Name of the road that traffic continues onto at this road's end (open roads only): the
    /// same as one entry in `links` that maps its lanes by position.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub next: Option<String>,
    /// Roads that traffic continues onto at this road's end, lane by lane (open roads only).
    /// Several entries make a split; several roads linking onto one make a merge.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub links: Vec<LinkSpec>,
    /// Control points in driving order; at least 2 (3 for a closed loop).
    pub points: Vec<ControlPoint>,
}

impl RoadSpec {
    /// An open road through `points` with `lanes` lanes of the default width and defaults elsewhere.
    pub fn through(name: &str, lanes: u32, speed_limit_kmh: f64, points: &[DVec3]) -> RoadSpec {
        RoadSpec {
            name: name.to_owned(),
            closed: false,
            lanes,
            lane_width_m: DEFAULT_LANE_WIDTH_M,
            speed_limit_kmh,
            next: None,
            links: Vec::new(),
            points: points.iter().copied().map(ControlPoint::at).collect(),
        }
    }

    /// A closed ring of radius `radius_m` centred on `centre`, with `n` control points, driven
    /// counter-clockwise (seen from above).
    pub fn ring(
        name: &str,
        lanes: u32,
        speed_limit_kmh: f64,
        centre: DVec3,
        radius_m: f64,
        n: usize,
    ) -> RoadSpec {
        let points: Vec<DVec3> = (0..n)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / n as f64;
                centre + DVec3::new(radius_m * libm::cos(a), radius_m * libm::sin(a), 0.0)
            })
            .collect();
        RoadSpec {
            closed: true,
            ..RoadSpec::through(name, lanes, speed_limit_kmh, &points)
        }
    }

    /// Every link at this road's end: `next` (as a link by lane position) first, then `links`.
    pub fn outgoing(&self) -> Vec<LinkSpec> {
        self.next
            .iter()
            .map(|n| LinkSpec::to(n))
            .chain(self.links.iter().cloned())
            .collect()
    }

    /// Width of the road at control point `i`, in metres.
    pub fn width_at_point(&self, i: usize) -> f64 {
        self.points
            .get(i)
            .and_then(|p| p.width_m)
            .unwrap_or(f64::from(self.lanes) * self.lane_width_m)
    }
}

fn yes() -> bool {
    true
}
fn one() -> u32 {
    1
}
fn default_lane_width() -> f64 {
    DEFAULT_LANE_WIDTH_M
}
fn is_true(b: &bool) -> bool {
    *b
}
fn is_false(b: &bool) -> bool {
    !*b
}
fn is_zero(x: &f64) -> bool {
    *x == 0.0
}
fn is_default_lane_width(x: &f64) -> bool {
    *x == DEFAULT_LANE_WIDTH_M
}

/// Where traffic goes at a road's end: onto the start of road `to`, from each lane to a lane.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinkSpec {
    /// Name of the road it leads onto.
    pub to: String,
    /// `(lane here, lane there)` pairs. Empty maps lanes by position: lane `i` onto lane `i`, and
    /// any lane beyond the other road's onto its leftmost (lanes merge).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub lanes: Vec<(u32, u32)>,
}

impl LinkSpec {
    /// A link onto `to` mapping lanes by position.
    pub fn to(to: &str) -> LinkSpec {
        LinkSpec {
            to: to.to_owned(),
            lanes: Vec::new(),
        }
    }

    /// The lane pairs of this link between a road of `from_lanes` and one of `to_lanes` lanes.
    pub fn lane_pairs(&self, from_lanes: u32, to_lanes: u32) -> Vec<(u32, u32)> {
        if self.lanes.is_empty() {
            (0..from_lanes)
                .map(|l| (l, l.min(to_lanes.saturating_sub(1))))
                .collect()
        } else {
            self.lanes.clone()
        }
    }
}
