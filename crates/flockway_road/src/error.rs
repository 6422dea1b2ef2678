//! Why a road spec cannot be built.

use thiserror::Error;

/// A road spec that does not describe a drivable road.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum RoadError {
    /// The road has no name.
    #[error("a road needs a non-empty name")]
    EmptyName,
    /// Not enough control points.
    #[error("road `{road}` needs at least {needed} points, has {got}")]
    TooFewPoints {
        /// Road name.
        road: String,
        /// Minimum for this kind of road.
        needed: usize,
        /// Points given.
        got: usize,
    },
    /// Too many control points.
    #[error("road `{road}` has {got} points; at most {max} are allowed")]
    TooManyPoints {
        /// Road name.
        road: String,
        /// Points given.
        got: usize,
        /// Limit.
        max: usize,
    },
    /// Lane count out of range.
    #[error("road `{road}` has {got} lanes; expected {} to {max}", crate::validate::LANES.start())]
    Lanes {
        /// Road name.
        road: String,
        /// Lanes given.
        got: u32,
        /// Limit.
        max: u32,
    },
    /// Lane width out of range.
    #[error(
        "road `{road}` has lane width {got} m; expected a number from {} to {}",
        crate::validate::LANE_WIDTH_M.start(), crate::validate::LANE_WIDTH_M.end()
    )]
    LaneWidth {
        /// Road name.
        road: String,
        /// Width given.
        got: f64,
    },
    /// Speed limit out of range.
    #[error(
        "road `{road}` has speed limit {got} km/h; expected a number from {} to {}",
        crate::validate::SPEED_LIMIT_KMH.start(), crate::validate::SPEED_LIMIT_KMH.end()
    )]
    SpeedLimit {
        /// Road name.
        road: String,
        /// Limit given.
        got: f64,
    },
    /// A closed loop cannot also lead onto another road.
    #[error(
        "road `{road}` is a closed loop, so it cannot lead onto other roads (`next` or `links`)"
    )]
    ClosedWithNext {
        /// Road name.
        road: String,
    },
    /// A control point position is not finite or too far out.
    #[error("road `{road}` point {point}: position must be finite and within ±1000 km")]
    Position {
        /// Road name.
        road: String,
        /// Point index.
        point: usize,
    },
    /// A width is not finite or out of range.
    #[error(
        "road `{road}` point {point}: width {got} m; expected a number from {} to {}",
        crate::validate::WIDTH_M.start(), crate::validate::WIDTH_M.end()
    )]
    Width {
        /// Road name.
        road: String,
        /// Point index.
        point: usize,
        /// Width given.
        got: f64,
    },
    /// A bank angle is not finite or too steep.
    #[error("road `{road}` point {point}: bank {got}°; expected a number from -{max} to {max}")]
    Bank {
        /// Road name.
        road: String,
        /// Point index.
        point: usize,
        /// Bank given.
        got: f64,
        /// Limit.
        max: f64,
    },
    /// A tangent override is zero or not finite.
    #[error("road `{road}` point {point}: tangent must be a finite, non-zero direction")]
    Tangent {
        /// Road name.
        road: String,
        /// Point index.
        point: usize,
    },
    /// Two consecutive points (nearly) coincide.
    #[error(
        "road `{road}`: points {a} and {b} are {distance_m:.3} m apart; they must be at least 0.1 m apart"
    )]
    PointsTooClose {
        /// Road name.
        road: String,
        /// First point.
        a: usize,
        /// Second point.
        b: usize,
        /// Their distance.
        distance_m: f64,
    },
    /// Two consecutive points are too far apart.
    #[error(
        "road `{road}`: points {a} and {b} are {distance_m:.0} m apart; at most 2000 m is allowed"
    )]
    PointsTooFar {
        /// Road name.
        road: String,
        /// First point.
        a: usize,
        /// Second point.
        b: usize,
        /// Their distance.
        distance_m: f64,
    },
}
