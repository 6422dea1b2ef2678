//! Checks that a road spec describes a drivable road, before any geometry is built from it.
//!
//! The accepted range of every road field is defined here once: validation, the editor's
//! commands and the inspector's widgets all read these constants.

use crate::RoadError;
use crate::spec::RoadSpec;
use std::ops::RangeInclusive;

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
/// Lanes a road may have.
pub const LANES: RangeInclusive<u32> = 1..=MAX_LANES;
/// Lane widths accepted, metres.
pub const LANE_WIDTH_M: RangeInclusive<f64> = 1.0..=10.0;
/// Speed limits accepted, km/h.
pub const SPEED_LIMIT_KMH: RangeInclusive<f64> = 1.0..=400.0;
/// Road widths a control point may set, metres.
pub const WIDTH_M: RangeInclusive<f64> = 1.0..=MAX_WIDTH_M;
/// Banks accepted, degrees (positive raises the right edge).
pub const BANK_DEG: RangeInclusive<f64> = -MAX_BANK_DEG..=MAX_BANK_DEG;
/// Coordinates accepted, metres.
pub const COORD_M: RangeInclusive<f64> = -MAX_COORD_M..=MAX_COORD_M;

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
    if !LANES.contains(&spec.lanes) {
        return Err(RoadError::Lanes {
            road: name(),
            got: spec.lanes,
            max: MAX_LANES,
        });
    }
    if !LANE_WIDTH_M.contains(&spec.lane_width_m) {
        return Err(RoadError::LaneWidth {
            road: name(),
            got: spec.lane_width_m,
        });
    }
    if !SPEED_LIMIT_KMH.contains(&spec.speed_limit_kmh) {
        return Err(RoadError::SpeedLimit {
            road: name(),
            got: spec.speed_limit_kmh,
        });
    }
    if spec.closed && (spec.next.is_some() || !spec.links.is_empty()) {
        return Err(RoadError::ClosedWithNext { road: name() });
    }
    for (i, p) in spec.points.iter().enumerate() {
        if !p.pos.to_array().iter().all(|c| COORD_M.contains(c)) {
            return Err(RoadError::Position {
                road: name(),
                point: i,
            });
        }
        if let Some(w) = p.width_m
            && !WIDTH_M.contains(&w)
        {
            return Err(RoadError::Width {
                road: name(),
                point: i,
                got: w,
            });
        }
        if !BANK_DEG.contains(&p.bank_deg) {
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
    if !WIDTH_M.contains(&width) {
        return Err(RoadError::Width {
            road: name(),
            point: 0,
            got: width,
        });
    }
    Ok(())
}
