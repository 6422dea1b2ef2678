//! Checks that a road spec describes a drivable road, before any geometry is built from it.

use crate::RoadError;
use crate::spec::RoadSpec;

/// Most control points one road may have.
pub const MAX_POINTS: usize = 10_000;
/// Most lanes one road may have.
pub const MAX_LANES: u32 = 16;
/// Largest coordinate magnitude accepted, in metres (a 2000 km square world).
pub const MAX_COORD_M: f64 = 1.0e6;
/// Largest bank accepted, in degrees.
pub const MAX_BANK_DEG: f64 = 45.0;
/// Closest two consecutive control points may be, in metres.
pub const MIN_POINT_SPACING_M: f64 = 0.1;
/// Longest chord between two consecutive control points, in metres.
pub const MAX_POINT_SPACING_M: f64 = 2_000.0;
/// Widest road accepted, in metres.
pub const MAX_WIDTH_M: f64 = 100.0;

pub(crate) fn validate(spec: &RoadSpec) -> Result<(), RoadError> {
    let name = || spec.name.clone();
    if spec.name.trim().is_empty() {
        return Err(RoadError::EmptyName);
    }
    let needed = if spec.closed { 3 } else { 2 };
    if spec.points.len() < needed {
        return Err(RoadError::TooFewPoints {
            road: name(),
            needed,
            got: spec.points.len(),
        });
    }
    if spec.points.len() > MAX_POINTS {
        return Err(RoadError::TooManyPoints {
            road: name(),
            got: spec.points.len(),
            max: MAX_POINTS,
        });
    }
    if spec.lanes == 0 || spec.lanes > MAX_LANES {
        return Err(RoadError::Lanes {
            road: name(),
            got: spec.lanes,
            max: MAX_LANES,
        });
    }
    if !(spec.lane_width_m.is_finite() && spec.lane_width_m >= 1.0 && spec.lane_width_m <= 10.0) {
        return Err(RoadError::LaneWidth {
            road: name(),
            got: spec.lane_width_m,
        });
    }
    if !(spec.speed_limit_kmh.is_finite()
        && spec.speed_limit_kmh > 0.0
        && spec.speed_limit_kmh <= 400.0)
    {
        return Err(RoadError::SpeedLimit {
            road: name(),
            got: spec.speed_limit_kmh,
        });
    }
    if spec.closed && (spec.next.is_some() || !spec.links.is_empty()) {
        return Err(RoadError::ClosedWithNext { road: name() });
    }
    for (i, p) in spec.points.iter().enumerate() {
        if !p.pos.is_finite() || p.pos.abs().max_element() > MAX_COORD_M {
            return Err(RoadError::Position {
                road: name(),
                point: i,
            });
        }
        if let Some(w) = p.width_m
            && !(w.is_finite() && w > 0.0 && w <= MAX_WIDTH_M)
        {
            return Err(RoadError::Width {
                road: name(),
                point: i,
                got: w,
            });
        }
        if !(p.bank_deg.is_finite() && p.bank_deg.abs() <= MAX_BANK_DEG) {
            return Err(RoadError::Bank {
                road: name(),
                point: i,
                got: p.bank_deg,
                max: MAX_BANK_DEG,
            });
        }
        if let Some(t) = p.tangent
            && (!t.is_finite() || t.length() < 1e-6)
        {
            return Err(RoadError::Tangent {
                road: name(),
                point: i,
            });
        }
    }
    let pairs = if spec.closed {
        spec.points.len()
    } else {
        spec.points.len() - 1
    };
    for i in 0..pairs {
        let j = (i + 1) % spec.points.len();
        let d = (spec.points[j].pos - spec.points[i].pos).length();
        if d < MIN_POINT_SPACING_M {
            return Err(RoadError::PointsTooClose {
                road: name(),
                a: i,
                b: j,
                distance_m: d,
            });
        }
        if d > MAX_POINT_SPACING_M {
            return Err(RoadError::PointsTooFar {
                road: name(),
                a: i,
                b: j,
                distance_m: d,
            });
        }
    }
    let width = spec.width_at_point(0);
    if !(width.is_finite() && width > 0.0 && width <= MAX_WIDTH_M) {
        return Err(RoadError::Width {
            road: name(),
            point: 0,
            got: width,
        });
    }
    Ok(())
}
