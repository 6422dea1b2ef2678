//! Junctions: where links cross or meet inside an area. Every connection through a junction is a
//! path of its own — a one-lane internal road, a smooth curve from one lane's end to another
//! lane's start, driven like any road — and the junction knows which paths conflict, where, and
//! who gives way to whom: by a priority rule, an all-way stop, right before left, or a signal.

use crate::geometry::RoadGeometry;
use crate::spec::{ControlPoint, RoadSpec};
use glam::DVec3;
use serde::{Deserialize, Serialize};

/// A junction as stored in a level: its connections and how right of way is decided.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JunctionSpec {
    /// Unique name within the level; its paths are the roads `NAME#0`, `NAME#1`, ….
    pub name: String,
    /// How right of way is decided.
    pub control: Control,
    /// The movements through the junction, each from a lane's end to a lane's start; a signal
    /// program's states are given in this order.
    pub connections: Vec<ConnectionSpec>,
    /// The signal program, for a junction whose control is `Signal`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub signal: Option<SignalProgram>,
}

/// One movement through a junction: from the end of lane `from_lane` of road `from` to the
/// start of lane `to_lane` of road `to`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConnectionSpec {
    /// Road whose end leads into the junction.
    pub from: String,
    /// Lane of `from`.
    #[serde(default)]
    pub from_lane: u32,
    /// Road whose start leads out of the junction.
    pub to: String,
    /// Lane of `to`.
    #[serde(default)]
    pub to_lane: u32,
}

/// How a junction decides right of way.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Control {
    /// Traffic from the roads in `major` has right of way; the rest gives way, coming to a full
    /// stop first when `stop` is set. Between movements of the same rank a turn across oncoming
    /// traffic gives way, then traffic from the right goes first.
    Priority {
        /// Roads entering the junction whose traffic has right of way.
        major: Vec<String>,
        /// Whether minor-road traffic must stop at the line before it may go (a stop sign).
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        stop: bool,
    },
    /// Everyone stops at the line; then they go in the order they stopped.
    AllWayStop,
    /// Traffic from the right goes first; a turn across oncoming traffic gives way.
    RightBeforeLeft,
    /// Traffic lights: the junction's `signal` program.
    Signal,
}

/// A fixed-time signal program: phases repeated in a cycle, shifted by an offset.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SignalProgram {
    /// Where in its cycle the program is at time 0, s: neighbouring signals coordinate by it.
    #[serde(default)]
    pub offset_s: f64,
    /// The phases, in order.
    pub phases: Vec<Phase>,
}

/// One phase of a signal program.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Phase {
    /// How long it lasts, s.
    pub duration_s: f64,
    /// One letter per connection, in the junction's order: `G` green, `g` green that gives way
    /// (a permitted turn), `y` amber, `r` red — as SUMO writes them.
    pub state: String,
}

/// What a signal shows one connection.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SignalState {
    /// Go, with right of way.
    Green,
    /// Go, giving way to conflicting traffic that has green.
    GreenYield,
    /// Stop if it can do so comfortably.
    Amber,
    /// Stop.
    Red,
}

impl SignalState {
    /// The state a letter of a phase's `state` stands for.
    pub fn from_letter(c: char) -> Option<SignalState> {
        match c {
            'G' => Some(SignalState::Green),
            'g' => Some(SignalState::GreenYield),
            'y' | 'Y' => Some(SignalState::Amber),
            'r' | 'R' => Some(SignalState::Red),
            _ => None,
        }
    }

    /// The letter a phase's `state` writes for it.
    pub fn letter(self) -> char {
        match self {
            SignalState::Green => 'G',
            SignalState::GreenYield => 'g',
            SignalState::Amber => 'y',
            SignalState::Red => 'r',
        }
    }

    /// Whether a vehicle may enter on it.
    pub fn is_go(self) -> bool {
        matches!(self, SignalState::Green | SignalState::GreenYield)
    }
}

impl SignalProgram {
    /// One cycle's length, s.
    pub fn cycle_s(&self) -> f64 {
        self.phases.iter().map(|p| p.duration_s.max(0.0)).sum()
    }

    /// The phase showing at time `t_s`, and the time it has left, s. `None` without phases.
    pub fn phase_at(&self, t_s: f64) -> Option<(usize, f64)> {
        let cycle = self.cycle_s();
        if self.phases.is_empty() || cycle <= 0.0 {
            return None;
        }
        let mut t = (t_s + self.offset_s).rem_euclid(cycle);
        for (i, p) in self.phases.iter().enumerate() {
            if t < p.duration_s {
                return Some((i, p.duration_s - t));
            }
            t -= p.duration_s.max(0.0);
        }
        // Rounding at the cycle's end: the last phase's final instant.
        Some((self.phases.len() - 1, 0.0))
    }

    /// Each phase's state per connection, for `connections` connections (red where a state
    /// has no letter, or an unknown one).
    pub fn states(&self, connections: usize) -> Vec<Vec<SignalState>> {
        self.phases
            .iter()
            .map(|phase| {
                let mut letters = phase.state.chars();
                (0..connections)
                    .map(|_| {
                        letters
                            .next()
                            .and_then(SignalState::from_letter)
                            .unwrap_or(SignalState::Red)
                    })
                    .collect()
            })
            .collect()
    }

    /// What connection `k` is shown at time `t_s` (red for a letter the program lacks).
    pub fn state_at(&self, t_s: f64, k: usize) -> SignalState {
        self.phase_at(t_s)
            .and_then(|(i, _)| self.phases[i].state.chars().nth(k))
            .and_then(SignalState::from_letter)
            .unwrap_or(SignalState::Red)
    }
}

/// How a path turns, by its heading change.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Turn {
    /// Within 30° of straight on.
    Straight,
    /// Left by 30° to 150°.
    Left,
    /// Right by 30° to 150°.
    Right,
    /// More than 150° either way.
    UTurn,
}

impl Turn {
    fn of(heading_change_rad: f64) -> Turn {
        let deg = heading_change_rad.to_degrees();
        if deg.abs() > 150.0 {
            Turn::UTurn
        } else if deg > 30.0 {
            Turn::Left
        } else if deg < -30.0 {
            Turn::Right
        } else {
            Turn::Straight
        }
    }

    /// Whether it crosses the path of oncoming traffic (right-hand traffic).
    fn across(self) -> bool {
        matches!(self, Turn::Left | Turn::UTurn)
    }
}

/// The body conflicts are found for: a car this long, m.
pub const BODY_LENGTH_M: f64 = 4.8;
/// The body conflicts are found for: a car this wide, m.
pub const BODY_WIDTH_M: f64 = 1.9;
/// Room a body on one path keeps from the traffic of another, beyond half a car's width, m.
pub const CONFLICT_CLEARANCE_M: f64 = 0.3;
/// How far the body conflicts are found for has its centre ahead of its rear axle, m (half a
/// sedan's wheelbase): turning at a crawl, the body turns about that axle, and its nose points
/// out of the bend by `atan(κ · this)` while its centre keeps to the path.
pub const BODY_CENTRE_AHEAD_OF_REAR_AXLE_M: f64 = 1.35;

/// The tightest bend the centre of the body conflicts are found for can follow, 1/m: a sedan
/// with its rear axle [`BODY_CENTRE_AHEAD_OF_REAR_AXLE_M`] behind the centre and as far again
/// to the front axle, at 35° of lock, turns its rear axle on a radius of 2.7 m / tan 35° =
/// 3.856 m and its centre on √(3.856² + 1.35²) = 4.086 m.
pub const FULL_LOCK_CURVATURE_PER_M: f64 = 0.2448;

/// Gain of [`driven`]'s steering on the car's distance from the path, 1/m².
const DRIVEN_OFFSET_GAIN: f64 = 0.36;
/// Gain of [`driven`]'s steering on the sine of its heading off the path's, 1/m.
const DRIVEN_HEADING_GAIN: f64 = 1.2;
/// Travel over which [`driven`]'s steering reaches the bend it asks for (a first-order lag),
/// m: a driver's steering turns into a tightening bend about a metre late (a sedan taking a
/// netconvert right turn at a crawl has half the lock the path's curvature asks for where the
/// path has already tightened a metre further).
const DRIVEN_STEER_LAG_M: f64 = 1.0;
/// Step of [`driven`]'s integration, m of travel.
const DRIVEN_STEP_M: f64 = 0.05;

/// Where a car's body goes on a path with a bend tighter than it can turn
/// ([`FULL_LOCK_CURVATURE_PER_M`]; netconvert draws a right turn inside a small junction on a
/// radius of 2.5 m): its centre steered onto the path at no more than full lock, turning in a
/// little late, it runs wide of the bend and comes back to the path, or to the next lane's line
/// past the path's end, later. Samples every [`SAMPLE_M`] of travel, each at its nearest point's distance along the
/// path (the path's length once past its end), the body turned out of the bend it drives.
fn driven(g: &RoadGeometry) -> Vec<Sample> {
    let length = g.length_m();
    let end = g.pos_at(length);
    let end_tangent = flat(g.frame_at(length).tangent);
    // The path, and past its end the straight on along its last heading: point, unit
    // tangent, curvature.
    let path = |s: f64| {
        if s < length {
            (g.pos_at(s), flat(g.frame_at(s).tangent), g.curvature_at(s))
        } else {
            (end + end_tangent * (s - length), end_tangent, 0.0)
        }
    };
    let (mut centre, mut heading, _) = path(0.0);
    let mut s = 0.0;
    let mut travelled = 0.0;
    let mut next_sample = 0.0;
    let mut bend = 0.0;
    let mut samples = Vec::new();
    // Bounded for a path that loops back on itself: by then it is far past any conflict.
    let farthest = 2.0 * length + 4.0 * BODY_LENGTH_M;
    while travelled <= farthest {
        // The nearest point of the path, from the last one on (two Newton steps suffice at
        // this step length).
        for _ in 0..2 {
            let (p, t, _) = path(s);
            s = (s + (centre - p).dot(t)).max(0.0);
        }
        let (p, t, k) = path(s);
        let offset = (centre - p).dot(DVec3::new(-t.y, t.x, 0.0));
        let off_heading = t.x * heading.y - t.y * heading.x;
        let asked = (k - DRIVEN_OFFSET_GAIN * offset - DRIVEN_HEADING_GAIN * off_heading)
            .clamp(-FULL_LOCK_CURVATURE_PER_M, FULL_LOCK_CURVATURE_PER_M);
        bend += (asked - bend) * (DRIVEN_STEP_M / DRIVEN_STEER_LAG_M);
        let back_on = s >= length && offset.abs() < 0.05 && off_heading.abs() < 0.02;
        if travelled >= next_sample || back_on {
            samples.push(Sample::in_bend(s.min(length), centre, heading, bend));
            next_sample += SAMPLE_M;
        }
        if back_on {
            break;
        }
        // Along the arc of this step, by its middle heading.
        let (sin, cos) = libm::sincos(0.5 * bend * DRIVEN_STEP_M);
        let mid = DVec3::new(
            heading.x * cos - heading.y * sin,
            heading.x * sin + heading.y * cos,
            0.0,
        );
        centre += mid * DRIVEN_STEP_M;
        let (sin, cos) = libm::sincos(bend * DRIVEN_STEP_M);
        heading = DVec3::new(
            heading.x * cos - heading.y * sin,
            heading.x * sin + heading.y * cos,
            0.0,
        )
        .normalize();
        travelled += DRIVEN_STEP_M;
    }
    samples
}

/// A point along a path with the corners of a car centred there.
#[derive(Debug, Clone, Copy)]
struct Sample {
    s: f64,
    pos: DVec3,
    /// The body's corners and the middle of its front and rear, in the plane.
    outline: [DVec3; 6],
    /// How far the body's ends stand out sideways from the path beyond half its width, for
    /// the car here turned off the path's heading (its sideslip in a bend), m.
    overhang_m: f64,
}

impl Sample {
    /// A car centred at `pos` heading along `tangent`.
    fn new(s: f64, pos: DVec3, tangent: DVec3) -> Self {
        Self::turned(s, pos, tangent, 0.0)
    }

    /// A car centred at `pos` on a path heading along `tangent` that bends with curvature
    /// `curvature_per_m` there: its body turned out of the bend as a car's is at a crawl.
    fn in_bend(s: f64, pos: DVec3, tangent: DVec3, curvature_per_m: f64) -> Self {
        let slip = libm::atan(BODY_CENTRE_AHEAD_OF_REAR_AXLE_M * curvature_per_m);
        Self::turned(s, pos, tangent, slip)
    }

    /// A car centred at `pos` whose body points `slip_rad` right of `tangent`.
    fn turned(s: f64, pos: DVec3, tangent: DVec3, slip_rad: f64) -> Self {
        let along = flat(tangent);
        let (sin, cos) = libm::sincos(-slip_rad);
        let t = if slip_rad == 0.0 {
            along
        } else {
            DVec3::new(
                along.x * cos - along.y * sin,
                along.x * sin + along.y * cos,
                0.0,
            )
        };
        let n = DVec3::new(-t.y, t.x, 0.0);
        let (l, w) = (0.5 * BODY_LENGTH_M * t, 0.5 * BODY_WIDTH_M * n);
        Self {
            s,
            pos,
            overhang_m: 0.5 * BODY_LENGTH_M * sin.abs(),
            outline: [
                pos + l + w,
                pos + l - w,
                pos - l + w,
                pos - l - w,
                pos + l,
                pos - l,
            ],
        }
    }

    /// Whether the body here, grown by the clearance, overlaps the body of `other`: what
    /// [`touches`](Self::touches) misses where the other's body is turned in a bend and its
    /// nose stands out sideways a body's length from its centre.
    fn overlaps(&self, other: &Sample) -> bool {
        let (dx, dy) = (self.pos.x - other.pos.x, self.pos.y - other.pos.y);
        let apart = BODY_LENGTH_M + 2.0 * CONFLICT_CLEARANCE_M;
        if dx * dx + dy * dy > apart * apart {
            return false;
        }
        // Separating axes: the sides of either body. No gap along one of them is an overlap.
        let axes = [self.axes(), other.axes()];
        axes.iter().flatten().all(|axis| {
            let span = |x: &Sample| {
                x.outline[..4]
                    .iter()
                    .map(|p| p.x * axis.x + p.y * axis.y)
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), d| {
                        (lo.min(d), hi.max(d))
                    })
            };
            let (a, b) = (span(self), span(other));
            a.0 - CONFLICT_CLEARANCE_M < b.1 && b.0 < a.1 + CONFLICT_CLEARANCE_M
        })
    }

    /// The unit directions of the body's length and width in the plane.
    fn axes(&self) -> [DVec3; 2] {
        let along = (self.outline[4] - self.outline[5]).normalize_or_zero();
        [along, DVec3::new(-along.y, along.x, 0.0)]
    }

    /// Whether a car here comes within the clearance of a car on the path `other` (its centre
    /// line plus half a car's width, and what that car's ends stand out in a bend).
    fn touches(&self, other: &Swept) -> bool {
        self.outline.iter().any(|&p| {
            // Outside every run's box at once: most of a junction's pairs of paths never meet.
            other.whole.near(p)
                && other.runs.iter().any(|run| {
                    run.near(p)
                        && other.samples[run.first..=run.last].windows(2).any(|seg| {
                            let (q0, q1) = (seg[0].pos, seg[1].pos);
                            let d = q1 - q0;
                            let u =
                                ((p - q0).dot(d) / d.length_squared().max(1e-12)).clamp(0.0, 1.0);
                            let q = q0 + u * d;
                            let (dx, dy) = (p.x - q.x, p.y - q.y);
                            let reach = REACH_M + seg[0].overhang_m.max(seg[1].overhang_m);
                            dx * dx + dy * dy < reach * reach
                        })
                })
        })
    }
}

/// How close a body's outline may come to another path's centre line before it touches a car
/// there, m: half a car's width and the clearance.
const REACH_M: f64 = 0.5 * BODY_WIDTH_M + CONFLICT_CLEARANCE_M;

/// Segments of a path's centre line measured together for [`Sample::touches`].
const RUN_SEGMENTS: usize = 8;

/// A path's samples, with the bounding box (grown by [`REACH_M`]) of each run of
/// [`RUN_SEGMENTS`] segments between them: a point outside a run's box is out of reach of all
/// its segments, so most of a path is passed over without measuring a segment, and the answer
/// is the one measuring every segment gives (this search dominated importing a city).
struct Swept {
    samples: Vec<Sample>,
    runs: Vec<Run>,
    /// The box of all its runs.
    whole: Run,
}

/// Segments `first`..`last` (sample indices) of a [`Swept`] path and their grown bounding box.
struct Run {
    first: usize,
    last: usize,
    min: DVec3,
    max: DVec3,
}

impl Run {
    /// Whether `p` lies inside the run's box on the ground plan.
    fn near(&self, p: DVec3) -> bool {
        p.x >= self.min.x && p.x <= self.max.x && p.y >= self.min.y && p.y <= self.max.y
    }
}

impl Swept {
    fn new(samples: Vec<Sample>) -> Self {
        // A hair beyond the reach, so that rounding in the measured distance cannot matter.
        let overhang = samples.iter().map(|x| x.overhang_m).fold(0.0, f64::max);
        let grow = DVec3::splat(REACH_M + overhang + 1e-6);
        let segments = samples.len().saturating_sub(1);
        let mut runs = Vec::new();
        let mut first = 0;
        while first < segments {
            let last = (first + RUN_SEGMENTS).min(segments);
            let (min, max) = samples[first..=last]
                .iter()
                .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), x| {
                    (lo.min(x.pos), hi.max(x.pos))
                });
            runs.push(Run {
                first,
                last,
                min: min - grow,
                max: max + grow,
            });
            first = last;
        }
        let whole = Run {
            first: 0,
            last: segments,
            min: runs.iter().fold(DVec3::INFINITY, |lo, r| lo.min(r.min)),
            max: runs.iter().fold(DVec3::NEG_INFINITY, |hi, r| hi.max(r.max)),
        };
        Swept {
            samples,
            runs,
            whole,
        }
    }
}

/// The first and last centre positions along `a` at which a car there touches path `b` (a
/// car's positions: negative ones are short of the path's start).
fn touching(a: &[Sample], b: &Swept) -> Option<(f64, f64)> {
    let first = a.iter().find(|x| x.touches(b))?;
    let last = a.iter().rev().find(|x| x.touches(b))?;
    Some((first.s, last.s))
}

/// Where a car merging from another path is behind one on this path: a body length and a
/// metre past where the paths meet (or where they stop touching, if sooner).
fn merged_ahead((at_m, clear_m): (f64, f64)) -> (f64, f64) {
    (at_m, clear_m.min(at_m + BODY_LENGTH_M + MERGE_GAP_M))
}

/// The gap a car that merged ahead of another leaves it, m (with the clearance on each side).
const MERGE_GAP_M: f64 = 1.0;

/// Spacing of the points two paths are compared at, m.
const SAMPLE_M: f64 = 0.25;

/// Where two paths of a junction come too close for two vehicles at once.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Conflict {
    /// The other path, by its connection index.
    pub other: usize,
    /// Whether both lead onto the same lane (they merge) rather than cross.
    pub merge: bool,
    /// Where along this path the conflict starts: the first position of a car's centre at
    /// which its body ([`BODY_LENGTH_M`] × [`BODY_WIDTH_M`]) comes within
    /// [`CONFLICT_CLEARANCE_M`] of a car on the other path, m (negative where a car whose
    /// front is over the line, its centre still short of the path, already comes that close).
    pub at_m: f64,
    /// Where along the other path it starts, the same way, m.
    pub other_at_m: f64,
    /// Where along this path it ends: the last centre position at which a car touches the
    /// other path, m; for a merge, where a car is far enough past the meeting point that one
    /// on the other path falls in behind it.
    pub clear_m: f64,
    /// Where along the other path it ends, the same way, m.
    pub other_clear_m: f64,
}

/// One movement through a built junction.
#[derive(Debug, Clone)]
pub struct JunctionPath {
    /// The internal road a vehicle drives through the junction.
    pub spec: RoadSpec,
    /// Road and lane it comes from (ids as the network numbers roads).
    pub from: (u32, u32),
    /// Road and lane it leads onto.
    pub to: (u32, u32),
    /// How it turns.
    pub turn: Turn,
    /// Unit heading as it enters the junction (x east, y north).
    pub heading_in: DVec3,
    /// Its conflicts with other paths, by the other's index.
    pub conflicts: Vec<Conflict>,
    /// The other paths from the same lane, each with how far along this path the two still
    /// overlap (a car's centre short of where its body clears the other), m: a car there is
    /// in front of a car on either.
    pub siblings: Vec<(usize, f64)>,
    /// How far before the line a car waiting to enter stops its front bumper so that its body
    /// keeps clear of the other lanes' paths, m: 0 except where a path from another lane passes
    /// close by the end of this one's lane (a tight corner where two lanes meet).
    pub hold_back_m: f64,
}

/// The farthest a car waits back from its line to keep clear of other paths, m.
pub const MAX_HOLD_BACK_M: f64 = 8.0;

/// A junction with its paths built and their conflicts found.
#[derive(Debug, Clone)]
pub struct Junction {
    /// The spec it was built from.
    pub spec: JunctionSpec,
    /// One per connection, in the spec's order.
    pub paths: Vec<JunctionPath>,
    /// The signal program's phases read once: each phase's state per connection (red where
    /// its state string has no letter). Empty without a signal.
    phase_states: Vec<Vec<SignalState>>,
}

/// A junction that cannot be built: what is wrong with which connection.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum JunctionError {
    /// A connection names a road the level lacks.
    #[error("junction `{junction}` connection {k}: there is no road named `{road}`")]
    UnknownRoad {
        /// The junction.
        junction: String,
        /// The connection's index.
        k: usize,
        /// The missing name.
        road: String,
    },
    /// A connection names a lane its road lacks.
    #[error(
        "junction `{junction}` connection {k}: road `{road}` has {lanes} lane(s), numbered 0 to {last}, not lane {lane}",
        last = lanes.saturating_sub(1)
    )]
    Lane {
        /// The junction.
        junction: String,
        /// The connection's index.
        k: usize,
        /// The road.
        road: String,
        /// The lane asked for.
        lane: u32,
        /// The road's lane count.
        lanes: u32,
    },
    /// A connection starts or ends on a closed road, which has no end or start.
    #[error(
        "junction `{junction}` connection {k}: road `{road}` is a closed loop and has no end to connect"
    )]
    Closed {
        /// The junction.
        junction: String,
        /// The connection's index.
        k: usize,
        /// The road.
        road: String,
    },
    /// The two lanes of a connection meet: there is nothing to cross.
    #[error(
        "junction `{junction}` connection {k}: the lanes meet ({gap_m:.2} m apart); link the roads with `links` instead"
    )]
    Meets {
        /// The junction.
        junction: String,
        /// The connection's index.
        k: usize,
        /// Their distance, m.
        gap_m: f64,
    },
    /// Two connections of one junction are the same.
    #[error("junction `{junction}` has connection {k} twice (also as {first})")]
    Duplicate {
        /// The junction.
        junction: String,
        /// The repeated connection's index.
        k: usize,
        /// The first one's.
        first: usize,
    },
    /// A priority junction names a major road that does not enter it.
    #[error("junction `{junction}`: major road `{road}` has no connection through the junction")]
    Major {
        /// The junction.
        junction: String,
        /// The road.
        road: String,
    },
    /// A junction controlled by a signal that has no program.
    #[error("junction `{junction}` is controlled by a signal but has no `signal` program")]
    NoSignal {
        /// The junction.
        junction: String,
    },
    /// A signal program on a junction another rule controls.
    #[error("junction `{junction}` has a `signal` program but its control is not `Signal`")]
    SignalUnused {
        /// The junction.
        junction: String,
    },
    /// A signal program that cannot run.
    #[error("junction `{junction}` signal phase {phase}: {problem}")]
    Signal {
        /// The junction.
        junction: String,
        /// The phase's index.
        phase: usize,
        /// What is wrong.
        problem: String,
    },
}

impl JunctionError {
    /// The junction it is about.
    pub fn junction(&self) -> &str {
        match self {
            JunctionError::UnknownRoad { junction, .. }
            | JunctionError::Lane { junction, .. }
            | JunctionError::Closed { junction, .. }
            | JunctionError::Meets { junction, .. }
            | JunctionError::Duplicate { junction, .. }
            | JunctionError::Major { junction, .. }
            | JunctionError::NoSignal { junction }
            | JunctionError::SignalUnused { junction }
            | JunctionError::Signal { junction, .. } => junction,
        }
    }
}

impl Junction {
    /// Builds the paths of `spec` between the roads `roads` (by name, with their network ids),
    /// finds their conflicts and checks its control.
    pub fn build<'a>(
        spec: &JunctionSpec,
        road: impl Fn(&str) -> Option<(u32, &'a RoadGeometry)>,
    ) -> Result<Junction, JunctionError> {
        let name = &spec.name;
        let mut paths = Vec::with_capacity(spec.connections.len());
        for (k, c) in spec.connections.iter().enumerate() {
            if let Some(first) = spec.connections[..k].iter().position(|o| o == c) {
                return Err(JunctionError::Duplicate {
                    junction: name.clone(),
                    k,
                    first,
                });
            }
            let find = |road_name: &str, lane: u32| {
                let (id, g) = road(road_name).ok_or_else(|| JunctionError::UnknownRoad {
                    junction: name.clone(),
                    k,
                    road: road_name.to_owned(),
                })?;
                if lane >= g.lanes() {
                    return Err(JunctionError::Lane {
                        junction: name.clone(),
                        k,
                        road: road_name.to_owned(),
                        lane,
                        lanes: g.lanes(),
                    });
                }
                if g.is_closed() {
                    return Err(JunctionError::Closed {
                        junction: name.clone(),
                        k,
                        road: road_name.to_owned(),
                    });
                }
                Ok((id, g))
            };
            let (from_id, from) = find(&c.from, c.from_lane)?;
            let (to_id, to) = find(&c.to, c.to_lane)?;
            let end = from.frame_at(from.length_m());
            let start = to.frame_at(0.0);
            let p0 = from.lane_point(c.from_lane, from.length_m());
            let p1 = to.lane_point(c.to_lane, 0.0);
            let gap_m = (p1 - p0).length();
            if gap_m < 1.0 {
                return Err(JunctionError::Meets {
                    junction: name.clone(),
                    k,
                    gap_m,
                });
            }
            let lane_width = end.width_m / f64::from(from.lanes().max(1));
            let point = |pos: DVec3, tangent: DVec3| ControlPoint {
                width_m: Some(lane_width),
                guardrail_left: false,
                guardrail_right: false,
                tangent: Some(tangent),
                ..ControlPoint::at(pos)
            };
            let spec = RoadSpec {
                name: path_name(name, k),
                closed: false,
                lanes: 1,
                lane_width_m: lane_width,
                speed_limit_kmh: from.speed_limit_kmh().min(to.speed_limit_kmh()),
                next: None,
                links: Vec::new(),
                points: vec![point(p0, end.tangent), point(p1, start.tangent)],
            };
            let heading_in = flat(end.tangent);
            let heading_out = flat(start.tangent);
            let change = libm::atan2(
                heading_in.x * heading_out.y - heading_in.y * heading_out.x,
                heading_in.dot(heading_out),
            );
            paths.push(JunctionPath {
                spec,
                from: (from_id, c.from_lane),
                to: (to_id, c.to_lane),
                turn: Turn::of(change),
                heading_in,
                conflicts: Vec::new(),
                siblings: Vec::new(),
                hold_back_m: 0.0,
            });
        }
        check_control(spec)?;
        let phase_states = spec
            .signal
            .as_ref()
            .map_or_else(Vec::new, |program| program.states(paths.len()));
        let mut junction = Junction {
            spec: spec.clone(),
            paths,
            phase_states,
        };
        junction.find_conflicts();
        Ok(junction)
    }

    /// Finds every pair of paths from different lanes where a car on one would come too close
    /// to a car on the other, or that lead onto the same lane.
    fn find_conflicts(&mut self) {
        let samples: Vec<Swept> = self
            .paths
            .iter()
            .map(|p| match RoadGeometry::new(&p.spec) {
                Ok(g) => {
                    let n = (g.length_m() / SAMPLE_M).ceil().max(1.0) as usize;
                    let along: Vec<Sample> = (0..=n)
                        .map(|i| {
                            let s = g.length_m() * i as f64 / n as f64;
                            let tangent = g.frame_at(s).tangent;
                            Sample::in_bend(s, g.pos_at(s), tangent, g.curvature_at(s))
                        })
                        .collect();
                    let tightest = (0..=n)
                        .map(|i| g.curvature_at(g.length_m() * i as f64 / n as f64).abs())
                        .fold(0.0, f64::max);
                    if tightest > FULL_LOCK_CURVATURE_PER_M {
                        Swept::new(driven(&g))
                    } else {
                        Swept::new(along)
                    }
                }
                Err(_) => Swept::new(Vec::new()),
            })
            .collect();
        // A car waiting at the line, its centre half a body before the path's start (and any
        // farther back, along the lane's end): the first place where it touches no path from
        // another lane.
        for i in 0..self.paths.len() {
            let Some(start) = samples[i].samples.first().map(|x| x.pos) else {
                continue;
            };
            let heading = self.paths[i].heading_in;
            let foes: Vec<&Swept> = (0..self.paths.len())
                .filter(|&j| self.paths[j].from != self.paths[i].from)
                .map(|j| &samples[j])
                .collect();
            let mut back = 0.0;
            while back < MAX_HOLD_BACK_M {
                let s = -0.5 * BODY_LENGTH_M - back;
                let waiting = Sample::new(s, start + heading * s, heading);
                if !foes
                    .iter()
                    .any(|b| waiting.touches(b) || b.samples.iter().any(|f| waiting.overlaps(f)))
                {
                    break;
                }
                back += SAMPLE_M;
            }
            self.paths[i].hold_back_m = back;
        }
        // Where a car's body is: from where it waits (its centre half a body and its hold-back
        // before the path's start, along its lane's end) to the path's end.
        let bodies: Vec<Vec<Sample>> = (0..self.paths.len())
            .map(|i| {
                let Some(first) = samples[i].samples.first() else {
                    return Vec::new();
                };
                let heading = self.paths[i].heading_in;
                // Back to where it waits clear of the others: short of there, a body standing
                // at the line is in the way of a turn that sweeps the end of its lane.
                let lead_in = 0.5 * BODY_LENGTH_M + self.paths[i].hold_back_m;
                let n = (lead_in / SAMPLE_M).ceil() as usize;
                let lead_in = (1..=n).rev().map(|k| {
                    let s = -(k as f64) * SAMPLE_M;
                    Sample::new(s, first.pos + heading * s, heading)
                });
                lead_in.chain(samples[i].samples.iter().copied()).collect()
            })
            .collect();
        for i in 0..self.paths.len() {
            for j in 0..self.paths.len() {
                if i == j {
                    continue;
                }
                let (a, b) = (&samples[i], &samples[j]);
                if self.paths[i].from == self.paths[j].from {
                    // Siblings: together until the first point where a body on this one is
                    // clear of the other.
                    let part = a
                        .samples
                        .iter()
                        .find(|x| !x.touches(b))
                        .map_or_else(|| a.samples.last().map_or(0.0, |x| x.s), |x| x.s);
                    self.paths[i].siblings.push((j, part));
                    continue;
                }
                let merge = self.paths[i].to == self.paths[j].to;
                let here = touching(&bodies[i], b);
                let there = touching(&bodies[j], a);
                let conflict = match (here, there) {
                    // Merging: a car a body and a gap past where the two meet is ahead of
                    // whoever comes along the other path, which follows it from then on.
                    (Some(mine), Some(theirs)) if merge => {
                        Some((merged_ahead(mine), merged_ahead(theirs)))
                    }
                    (Some(mine), Some(theirs)) => Some((mine, theirs)),
                    _ if merge => {
                        let end = |s: &Swept| s.samples.last().map_or(0.0, |x| x.s);
                        Some(((end(a), end(a)), (end(b), end(b))))
                    }
                    _ => None,
                };
                if let Some(((at_m, clear_m), (other_at_m, other_clear_m))) = conflict {
                    self.paths[i].conflicts.push(Conflict {
                        other: j,
                        merge,
                        at_m,
                        other_at_m,
                        clear_m,
                        other_clear_m,
                    });
                }
            }
        }
    }

    /// Whether a vehicle on path `i` gives way to one on conflicting path `j`, with the signal
    /// states `signal` (one per connection) when the junction has a signal. Under an all-way
    /// stop both give way to each other (the order they stopped in decides).
    pub fn gives_way(&self, i: usize, j: usize, signal: Option<&[SignalState]>) -> bool {
        let (a, b) = (&self.paths[i], &self.paths[j]);
        let rank = |k: usize| -> u8 {
            match (&self.spec.control, signal) {
                (Control::Priority { major, .. }, _) => {
                    let from = &self.spec.connections[k].from;
                    u8::from(major.iter().any(|m| m == from))
                }
                (Control::Signal, Some(states)) => match states.get(k) {
                    Some(SignalState::Green) => 2,
                    Some(SignalState::GreenYield) => 1,
                    _ => 0,
                },
                _ => 0,
            }
        };
        match &self.spec.control {
            Control::AllWayStop => true,
            _ => {
                let (ra, rb) = (rank(i), rank(j));
                if ra != rb {
                    return ra < rb;
                }
                // Same rank: a turn across oncoming traffic gives way to it, then the one
                // whose traffic comes from the right goes first.
                let oncoming = a.heading_in.dot(b.heading_in) < -0.5;
                if oncoming && a.turn.across() != b.turn.across() {
                    return a.turn.across();
                }
                if oncoming && a.turn.across() {
                    // Two turns across facing each other (opposing left turns) that pass too
                    // close for both at once: neither comes from the other's right, so one
                    // must wait, always the same one (the later connection).
                    return i > j;
                }
                if a.turn != Turn::Straight
                    && b.turn == Turn::Straight
                    && self.paths[i].to == self.paths[j].to
                {
                    // Merging onto the same lane: the turning car fits in behind the straight one.
                    return true;
                }
                if a.to == b.to {
                    return from_right(a.heading_in, b.heading_in);
                }
                // Two paths that cross: the one with the other's traffic from its right gives
                // way. From headings near parallel or opposite (a multi-arm junction's nearly
                // opposite arms, two lanes of one arm) neither comes clearly from the other's
                // right, yet one must give way: the side the other comes from all the same,
                // and exactly in line the later connection.
                let cross = a.heading_in.x * b.heading_in.y - a.heading_in.y * b.heading_in.x;
                if cross != 0.0 { cross > 0.0 } else { i > j }
            }
        }
    }

    /// Whether a vehicle on path `k` must come to a full stop at the line before it may enter.
    pub fn must_stop(&self, k: usize) -> bool {
        match &self.spec.control {
            Control::AllWayStop => true,
            Control::Priority { major, stop } => {
                *stop && !major.iter().any(|m| *m == self.spec.connections[k].from)
            }
            _ => false,
        }
    }

    /// A fixed-time program that serves the junction's approaches in two phases: the
    /// connections coming in along the first connection's axis (either way), then the others.
    /// Each phase is 30 s of green, 3 s of amber and 2 s of all red (clearance); a turn across
    /// oncoming traffic of its own phase gets a green that gives way (`g`). With one axis only,
    /// every connection is green all the time. What a signal starts from when a junction's
    /// control is switched to `Signal` in the editor.
    pub fn two_phase_program(&self) -> SignalProgram {
        let Some(first) = self.paths.first() else {
            return SignalProgram {
                offset_s: 0.0,
                phases: Vec::new(),
            };
        };
        // Within 45° of the first approach's axis, coming either way.
        let along = |p: &JunctionPath| first.heading_in.dot(p.heading_in).abs() >= 0.7;
        let letters = |group: bool, letter: &dyn Fn(&JunctionPath) -> char| -> String {
            self.paths
                .iter()
                .map(|p| if along(p) == group { letter(p) } else { 'r' })
                .collect()
        };
        let green = |p: &JunctionPath| {
            let opposed = self
                .paths
                .iter()
                .any(|o| along(o) == along(p) && p.heading_in.dot(o.heading_in) < -0.7);
            if p.turn.across() && opposed { 'g' } else { 'G' }
        };
        let phase = |duration_s: f64, state: String| Phase { duration_s, state };
        if self.paths.iter().all(along) {
            return SignalProgram {
                offset_s: 0.0,
                phases: vec![phase(30.0, letters(true, &green))],
            };
        }
        let mut phases = Vec::new();
        for group in [true, false] {
            phases.push(phase(30.0, letters(group, &green)));
            phases.push(phase(3.0, letters(group, &|_| 'y')));
            phases.push(phase(2.0, "r".repeat(self.paths.len())));
        }
        SignalProgram {
            offset_s: 0.0,
            phases,
        }
    }

    /// The signal states at time `t_s`, one per connection; `None` without a signal.
    pub fn signal_at(&self, t_s: f64) -> Option<Vec<SignalState>> {
        let program = self.spec.signal.as_ref()?;
        Some(match program.phase_at(t_s) {
            Some((i, _)) => self.phase_states[i].clone(),
            None => vec![SignalState::Red; self.paths.len()],
        })
    }
}

/// The name of path `k` of junction `junction`: its internal road's name.
pub fn path_name(junction: &str, k: usize) -> String {
    format!("{junction}#{k}")
}

/// Whether traffic heading `b` comes from the right of traffic heading `a` (right-hand traffic:
/// it crosses from right to left in front of it).
fn from_right(a: DVec3, b: DVec3) -> bool {
    a.x * b.y - a.y * b.x > 0.5
}

/// `v` flattened onto the ground and made unit length (x east if it has no horizontal part).
fn flat(v: DVec3) -> DVec3 {
    DVec3::new(v.x, v.y, 0.0)
        .try_normalize()
        .unwrap_or(DVec3::X)
}

/// Checks a junction's control against its connections.
fn check_control(spec: &JunctionSpec) -> Result<(), JunctionError> {
    match &spec.control {
        Control::Priority { major, .. } => {
            for m in major {
                if !spec.connections.iter().any(|c| c.from == *m) {
                    return Err(JunctionError::Major {
                        junction: spec.name.clone(),
                        road: m.clone(),
                    });
                }
            }
        }
        Control::Signal => {
            let Some(program) = &spec.signal else {
                return Err(JunctionError::NoSignal {
                    junction: spec.name.clone(),
                });
            };
            check_program(&spec.name, spec.connections.len(), program)?;
        }
        Control::AllWayStop | Control::RightBeforeLeft => {}
    }
    if spec.signal.is_some() && spec.control != Control::Signal {
        return Err(JunctionError::SignalUnused {
            junction: spec.name.clone(),
        });
    }
    Ok(())
}

/// Checks a signal program for a junction of `connections` connections: at least one phase, a
/// finite offset, durations above 0, one known letter per connection in every state.
pub fn check_program(
    junction: &str,
    connections: usize,
    program: &SignalProgram,
) -> Result<(), JunctionError> {
    let problem = |phase: usize, problem: String| JunctionError::Signal {
        junction: junction.to_owned(),
        phase,
        problem,
    };
    if program.phases.is_empty() {
        return Err(problem(
            0,
            "a signal program needs at least one phase".into(),
        ));
    }
    if !program.offset_s.is_finite() {
        return Err(problem(
            0,
            "the offset must be a finite number of seconds".into(),
        ));
    }
    for (i, p) in program.phases.iter().enumerate() {
        if !(p.duration_s.is_finite() && p.duration_s > 0.0) {
            return Err(problem(
                i,
                format!("duration {} s; it must be more than 0", p.duration_s),
            ));
        }
        check_state(&p.state, connections).map_err(|e| problem(i, e))?;
    }
    Ok(())
}

/// Reads a signal state string for `connections` connections: one letter each, `G`, `g`, `y`
/// or `r`; what is wrong with it otherwise.
pub fn check_state(state: &str, connections: usize) -> Result<Vec<SignalState>, String> {
    let n = state.chars().count();
    if n != connections {
        return Err(format!(
            "state `{state}` has {n} letter(s) for {connections} connection(s); give one per connection"
        ));
    }
    state
        .chars()
        .map(|c| {
            SignalState::from_letter(c)
                .ok_or_else(|| format!("state `{state}` has `{c}`; the letters are G, g, y and r"))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{NetworkError, RoadNetwork};

    /// A crossroads 16 m across: one lane in and one out on each arm (right-hand traffic),
    /// arms `w`, `e`, `s`, `n`, roads `w in`, `w out`, …; 100 m each.
    fn arms() -> Vec<RoadSpec> {
        arms_ending(8.0)
    }

    /// [`arms`], their ends `half` m from the centre.
    fn arms_ending(half: f64) -> Vec<RoadSpec> {
        let far = half + 100.0;
        let road = |name: &str, a: (f64, f64), b: (f64, f64)| {
            RoadSpec::through(
                name,
                1,
                50.0,
                &[DVec3::new(a.0, a.1, 0.0), DVec3::new(b.0, b.1, 0.0)],
            )
        };
        vec![
            road("w in", (-far, -1.5), (-half, -1.5)),
            road("e out", (half, -1.5), (far, -1.5)),
            road("e in", (far, 1.5), (half, 1.5)),
            road("w out", (-half, 1.5), (-far, 1.5)),
            road("s in", (1.5, -far), (1.5, -half)),
            road("n out", (1.5, half), (1.5, far)),
            road("n in", (-1.5, far), (-1.5, half)),
            road("s out", (-1.5, -half), (-1.5, -far)),
        ]
    }

    /// A priority crossroads of [`movements`] with its arms 4 m from the centre.
    fn tight_crossroads() -> RoadNetwork {
        let junction = JunctionSpec {
            name: "x".into(),
            control: priority(),
            connections: movements(),
            signal: None,
        };
        RoadNetwork::build_with(&arms_ending(4.0), &[junction]).expect("valid")
    }

    #[test]
    fn a_bend_tighter_than_full_lock_is_driven_wide_and_back_onto_the_lane_after() {
        // Arms 4 m from the centre: the right turn from `n in` to `w out` bends on about
        // 2.5 m, no car's lock.
        let net = tight_crossroads();
        let right = net
            .get(net.path_road(0, N_RIGHT).expect("path"))
            .expect("geometry");
        let tightest = (0..=40)
            .map(|i| {
                right
                    .curvature_at(right.length_m() * f64::from(i) / 40.0)
                    .abs()
            })
            .fold(0.0, f64::max);
        assert!(tightest > 1.5 * FULL_LOCK_CURVATURE_PER_M, "{tightest}");
        let driven = driven(right);
        // Out of the bend: the path turns right from south to west and keeps north of `w
        // out`'s line (y = 1.5); the car runs south of it, and is back on it by the last
        // sample.
        // At least what full lock's radius (4.1 m) has over the path's, at most a metre
        // more for turning in late.
        let wide = driven.iter().map(|x| 1.5 - x.pos.y).fold(0.0, f64::max);
        assert!(wide > 1.0 && wide < 3.0, "{wide}");
        let last = driven.last().expect("samples");
        assert!((last.pos.y - 1.5).abs() < 0.06, "{:?}", last.pos);
        assert!(
            last.pos.x < right.pos_at(right.length_m()).x,
            "{:?}",
            last.pos
        );
        // A car waiting on `w in` (heading east at y = -1.5) just before where the right
        // turner runs wide holds back from the line; in the 16 m crossroads it need not.
        let x = &net.junctions()[0];
        assert!(
            x.paths[W_STRAIGHT].hold_back_m >= 1.0,
            "{}",
            x.paths[W_STRAIGHT].hold_back_m
        );
        let roomy = crossroads(priority());
        assert_eq!(roomy.junctions()[0].paths[W_STRAIGHT].hold_back_m, 0.0);
    }

    #[test]
    fn a_turn_driven_wide_across_a_lanes_end_conflicts_with_a_car_there_back_to_its_hold_back() {
        // The right turn from `n in` runs wide across the end of `w in`: a car on `w in` with
        // its body in that sweep is in their conflict area, back to where it waits clear of
        // it (half a body and its hold-back before the line), not only over the line.
        let net = tight_crossroads();
        let x = &net.junctions()[0];
        let straight = &x.paths[W_STRAIGHT];
        let conflict = straight
            .conflicts
            .iter()
            .find(|c| c.other == N_RIGHT)
            .expect("the straight on and the wide right turn conflict");
        let waits_at = -0.5 * BODY_LENGTH_M - straight.hold_back_m;
        assert!(
            conflict.at_m < -0.5 * BODY_LENGTH_M - SAMPLE_M,
            "{} (hold-back {})",
            conflict.at_m,
            straight.hold_back_m
        );
        assert!(
            conflict.at_m >= waits_at - SAMPLE_M,
            "{} {waits_at}",
            conflict.at_m
        );
        // The turn's side of it starts on its path.
        let other = x.paths[N_RIGHT]
            .conflicts
            .iter()
            .find(|c| c.other == W_STRAIGHT)
            .expect("both ways");
        assert_eq!(other.other_at_m, conflict.at_m);
    }

    /// Every movement of [`arms`]: straight, left and right from each arm, in that order per arm
    /// (`w`, `e`, `s`, `n`): connection `3 * arm + {0 straight, 1 left, 2 right}`.
    fn movements() -> Vec<ConnectionSpec> {
        let c = |from: &str, to: &str| ConnectionSpec {
            from: from.into(),
            from_lane: 0,
            to: to.into(),
            to_lane: 0,
        };
        vec![
            c("w in", "e out"),
            c("w in", "n out"),
            c("w in", "s out"),
            c("e in", "w out"),
            c("e in", "s out"),
            c("e in", "n out"),
            c("s in", "n out"),
            c("s in", "w out"),
            c("s in", "e out"),
            c("n in", "s out"),
            c("n in", "e out"),
            c("n in", "w out"),
        ]
    }

    const W_STRAIGHT: usize = 0;
    const W_LEFT: usize = 1;
    const W_RIGHT: usize = 2;
    const E_STRAIGHT: usize = 3;
    const S_STRAIGHT: usize = 6;
    const N_STRAIGHT: usize = 9;
    const N_RIGHT: usize = 11;

    fn crossroads(control: Control) -> RoadNetwork {
        crossroads_with(control, None)
    }

    fn crossroads_with(control: Control, signal: Option<SignalProgram>) -> RoadNetwork {
        let junction = JunctionSpec {
            name: "x".into(),
            control,
            connections: movements(),
            signal,
        };
        RoadNetwork::build_with(&arms(), &[junction]).expect("a valid crossroads")
    }

    fn priority() -> Control {
        Control::Priority {
            major: vec!["w in".into(), "e in".into()],
            stop: false,
        }
    }

    #[test]
    fn a_junction_s_paths_and_arms_meet_there_and_a_bridge_over_it_crosses_them() {
        let net = crossroads(priority());
        assert!(net.crossings().is_empty(), "{:?}", net.crossings());
        // A road over the junction, joined to nothing: it crosses the paths and the arms.
        let mut roads = arms();
        roads.push(RoadSpec::through(
            "bridge",
            2,
            80.0,
            &[DVec3::new(-60.0, -60.0, 0.0), DVec3::new(60.0, 60.0, 0.0)],
        ));
        // And one over the western arms, far from the junction.
        roads.push(RoadSpec::through(
            "flyover",
            2,
            80.0,
            &[DVec3::new(-50.0, -60.0, 0.0), DVec3::new(-50.0, 60.0, 0.0)],
        ));
        let junction = JunctionSpec {
            name: "x".into(),
            control: priority(),
            connections: movements(),
            signal: None,
        };
        let net = RoadNetwork::build_with(&roads, &[junction]).expect("valid");
        let name = |id: crate::RoadId| net.get(id).expect("a road").name();
        let pairs: Vec<(&str, &str)> = net
            .crossings()
            .iter()
            .map(|&(a, b)| (name(a), name(b)))
            .collect();
        // The flyover crosses the two western arms; the bridge the junction's paths through
        // its centre (and the flyover); no path crosses another or an arm.
        assert!(pairs.contains(&("w in", "flyover")), "{pairs:?}");
        assert!(pairs.contains(&("w out", "flyover")), "{pairs:?}");
        assert!(pairs.contains(&("bridge", "flyover")), "{pairs:?}");
        assert!(pairs.contains(&("bridge", "x#0")), "{pairs:?}");
        assert!(
            pairs.iter().all(
                |(a, b)| ["bridge", "flyover"].contains(a) || ["bridge", "flyover"].contains(b)
            ),
            "{pairs:?}"
        );
    }

    #[test]
    fn each_connection_is_a_road_from_its_lane_end_to_its_lane_start_linked_both_ways() {
        let net = crossroads(priority());
        assert_eq!(net.len(), 8 + 12);
        let x = &net.junctions()[0];
        let w_in = net.id("w in").expect("w in");
        let straight = net.id("x#0").expect("the first path is a road");
        assert_eq!(net.junction_path(straight), Some((0, W_STRAIGHT)));
        assert_eq!(net.path_road(0, W_STRAIGHT), Some(straight));
        let g = net.get(straight).expect("geometry");
        assert!((g.length_m() - 16.0).abs() < 0.01, "{}", g.length_m());
        assert!((g.pos_at(0.0) - DVec3::new(-8.0, -1.5, 0.0)).length() < 1e-6);
        // In from the approach, out onto the exit, lane by lane.
        assert!(net.link(w_in, straight).is_some());
        assert_eq!(
            net.lane_next(straight, 0, None),
            Some((net.id("e out").expect("e out"), 0))
        );
        assert_eq!(net.lane_prev(straight, 0), &[(w_in, 0)]);
        // Turns: the right turn is the shortest path (a quarter circle of 6.5 m radius), the
        // left one a quarter circle of 9.5 m radius.
        let len = |k: usize| {
            net.get(net.path_road(0, k).expect("path"))
                .expect("g")
                .length_m()
        };
        assert!((len(W_RIGHT) - 10.2).abs() < 0.3, "{}", len(W_RIGHT));
        assert!((len(W_LEFT) - 14.9).abs() < 0.4, "{}", len(W_LEFT));
        assert_eq!(
            (
                x.paths[W_STRAIGHT].turn,
                x.paths[W_LEFT].turn,
                x.paths[W_RIGHT].turn
            ),
            (Turn::Straight, Turn::Left, Turn::Right)
        );
        let right = net
            .get(net.path_road(0, W_RIGHT).expect("right"))
            .expect("g");
        assert!(right.curvature_at(0.5 * right.length_m()) < -0.05);
        // No rails inside a junction; the speed limit is the lower of the two roads'.
        assert_eq!(right.guardrails_at(1.0), (false, false));
        // Routing goes through the junction.
        let n_out = net.id("n out").expect("n out");
        assert_eq!(
            net.shortest_path(w_in, n_out),
            Some(vec![w_in, net.path_road(0, W_LEFT).expect("left"), n_out])
        );
    }

    #[test]
    fn crossing_and_merging_paths_conflict_parallel_and_diverging_ones_do_not() {
        let net = crossroads(priority());
        let x = &net.junctions()[0];
        let conflict = |i: usize, j: usize| x.paths[i].conflicts.iter().find(|c| c.other == j);
        // Straight across each other: from where a car's front corner comes within the
        // clearance of the crossing lane's traffic (its centre 3.5 m before the lanes cross,
        // which they do 9.5 m in) until its rear has left it.
        let c = conflict(W_STRAIGHT, S_STRAIGHT).expect("they cross");
        assert!(!c.merge);
        assert!((c.at_m - 6.0).abs() < 0.5, "{c:?}");
        assert!((c.clear_m - 13.0).abs() < 0.5, "{c:?}");
        assert!(c.clear_m > c.at_m);
        assert!(conflict(S_STRAIGHT, W_STRAIGHT).is_some());
        // Opposite straights pass 3 m apart; a lane's movements diverge from one point.
        assert!(conflict(W_STRAIGHT, E_STRAIGHT).is_none());
        assert!(conflict(W_STRAIGHT, W_LEFT).is_none());
        // A left turn crosses the oncoming straight.
        assert!(conflict(W_LEFT, E_STRAIGHT).is_some());
        // The right turn and the straight from the north both lead onto `s out`: a merge.
        let m = conflict(W_RIGHT, N_STRAIGHT).expect("they merge");
        assert!(m.merge);
        // Merged a body and a metre past where they meet, it is ahead: no longer in the way.
        assert!(
            (m.clear_m - m.at_m - (BODY_LENGTH_M + MERGE_GAP_M)).abs() < 1e-9,
            "{m:?}"
        );
        let right = net
            .path_road(0, W_RIGHT)
            .and_then(|r| net.get(r))
            .expect("path");
        assert!(m.clear_m < right.length_m(), "{m:?}");
        // The straight and the right turn from one lane overlap for their first metres.
        let part = |i: usize, j: usize| {
            x.paths[i]
                .siblings
                .iter()
                .find(|s| s.0 == j)
                .map(|s| s.1)
                .expect("siblings")
        };
        assert!(
            (2.0..10.0).contains(&part(W_STRAIGHT, W_RIGHT)),
            "{}",
            part(W_STRAIGHT, W_RIGHT)
        );
        assert!(part(W_LEFT, W_RIGHT) < 10.0);
        assert!(
            x.paths[W_STRAIGHT]
                .siblings
                .iter()
                .all(|s| s.0 == W_LEFT || s.0 == W_RIGHT)
        );
        // Conflicts are found both ways round.
        for (i, p) in x.paths.iter().enumerate() {
            for c in &p.conflicts {
                assert!(x.paths[c.other].conflicts.iter().any(|d| d.other == i));
            }
        }
    }

    #[test]
    fn right_of_way_by_priority_turn_and_the_right() {
        let net = crossroads(priority());
        let x = &net.junctions()[0];
        // The minor road gives way to the major one, never the other way round.
        assert!(x.gives_way(S_STRAIGHT, W_STRAIGHT, None));
        assert!(!x.gives_way(W_STRAIGHT, S_STRAIGHT, None));
        // On the major road a left turn gives way to the oncoming straight.
        assert!(x.gives_way(W_LEFT, E_STRAIGHT, None));
        assert!(!x.gives_way(E_STRAIGHT, W_LEFT, None));
        assert!(!x.must_stop(S_STRAIGHT));
        // Of the two opposing left turns there, exactly one waits for the other.
        const E_LEFT: usize = 4;
        assert!(x.gives_way(E_LEFT, W_LEFT, None));
        assert!(!x.gives_way(W_LEFT, E_LEFT, None));

        let net = crossroads(Control::RightBeforeLeft);
        let x = &net.junctions()[0];
        // Eastbound, traffic from the south comes from the right.
        assert!(x.gives_way(W_STRAIGHT, S_STRAIGHT, None));
        assert!(!x.gives_way(S_STRAIGHT, W_STRAIGHT, None));
        assert!(
            x.gives_way(S_STRAIGHT, E_STRAIGHT, None),
            "from the east is the right of the south"
        );

        let net = crossroads(Control::AllWayStop);
        let x = &net.junctions()[0];
        assert!(
            x.gives_way(W_STRAIGHT, S_STRAIGHT, None) && x.gives_way(S_STRAIGHT, W_STRAIGHT, None)
        );
        assert!(x.must_stop(W_STRAIGHT));

        let stop = Control::Priority {
            major: vec!["w in".into(), "e in".into()],
            stop: true,
        };
        let net = crossroads(stop);
        assert!(net.junctions()[0].must_stop(S_STRAIGHT));
        assert!(!net.junctions()[0].must_stop(W_STRAIGHT));
    }

    /// Seven arms of one lane each way, 360°/7 apart, their ends 12 m from the centre (as
    /// netgenerate's spider has them), and every movement from each arm into each other.
    fn star() -> RoadNetwork {
        let mut roads = Vec::new();
        let mut connections = Vec::new();
        for k in 0..7 {
            let angle = f64::from(k) * std::f64::consts::TAU / 7.0;
            let (out, left) = (
                DVec3::new(libm::cos(angle), libm::sin(angle), 0.0),
                DVec3::new(-libm::sin(angle), libm::cos(angle), 0.0),
            );
            let at = |r: f64, side: f64| out * r + left * side;
            roads.push(RoadSpec::through(
                &format!("{k} in"),
                1,
                50.0,
                &[at(112.0, 1.6), at(12.0, 1.6)],
            ));
            roads.push(RoadSpec::through(
                &format!("{k} out"),
                1,
                50.0,
                &[at(12.0, -1.6), at(112.0, -1.6)],
            ));
        }
        for a in 0..7 {
            for b in (0..7).filter(|b| *b != a) {
                connections.push(ConnectionSpec {
                    from: format!("{a} in"),
                    from_lane: 0,
                    to: format!("{b} out"),
                    to_lane: 0,
                });
            }
        }
        let junction = JunctionSpec {
            name: "star".into(),
            control: Control::RightBeforeLeft,
            connections,
            signal: None,
        };
        RoadNetwork::build_with(&roads, &[junction]).expect("a valid star")
    }

    #[test]
    fn of_two_paths_that_cross_exactly_one_gives_way_even_from_nearly_opposite_arms() {
        let net = star();
        let x = &net.junctions()[0];
        let mut crossings = 0;
        let mut near_opposite = 0;
        for (i, path) in x.paths.iter().enumerate() {
            for c in path.conflicts.iter().filter(|c| !c.merge) {
                let j = c.other;
                crossings += 1;
                let (a, b) = (path.heading_in, x.paths[j].heading_in);
                if a.dot(b) < -0.8 {
                    near_opposite += 1;
                }
                assert_ne!(
                    x.gives_way(i, j, None),
                    x.gives_way(j, i, None),
                    "paths {i} and {j} cross: exactly one gives way"
                );
            }
        }
        // Arms three apart meet at 154°: too near opposite for either to come clearly from
        // the other's right, and their paths cross.
        assert!(near_opposite > 0, "{near_opposite} of {crossings}");
    }

    /// Two phases of 30 s green and 3 s amber: east–west first (left turns permitted, giving
    /// way), then north–south.
    fn two_phase(offset_s: f64) -> SignalProgram {
        let phase = |duration_s: f64, state: &str| Phase {
            duration_s,
            state: state.into(),
        };
        SignalProgram {
            offset_s,
            phases: vec![
                phase(30.0, "GgGGgGrrrrrr"),
                phase(3.0, "yyyyyyrrrrrr"),
                phase(30.0, "rrrrrrGgGGgG"),
                phase(3.0, "rrrrrryyyyyy"),
            ],
        }
    }

    #[test]
    fn a_signal_program_cycles_with_its_offset_and_its_states_decide_right_of_way() {
        let net = crossroads_with(Control::Signal, Some(two_phase(0.0)));
        let x = &net.junctions()[0];
        let program = x.spec.signal.as_ref().expect("a signal");
        assert_eq!(program.cycle_s(), 66.0);
        assert_eq!(program.phase_at(0.0), Some((0, 30.0)));
        assert_eq!(program.phase_at(31.0), Some((1, 2.0)));
        assert_eq!(program.phase_at(66.0 + 40.0), Some((2, 23.0)));
        assert_eq!(program.state_at(10.0, W_STRAIGHT), SignalState::Green);
        assert_eq!(program.state_at(10.0, W_LEFT), SignalState::GreenYield);
        assert_eq!(program.state_at(10.0, S_STRAIGHT), SignalState::Red);
        assert_eq!(program.state_at(32.0, W_STRAIGHT), SignalState::Amber);
        let states = x.signal_at(10.0).expect("a signal");
        // The permitted left turn gives way to the oncoming straight on green.
        assert!(x.gives_way(W_LEFT, E_STRAIGHT, Some(&states)));
        assert!(!x.gives_way(E_STRAIGHT, W_LEFT, Some(&states)));
        // An offset shifts the cycle: 40 s into it at time 0.
        let shifted = crossroads_with(Control::Signal, Some(two_phase(40.0)));
        assert_eq!(
            shifted.junctions()[0].signal_at(0.0).expect("signal")[S_STRAIGHT],
            SignalState::Green
        );
        assert_eq!(
            SignalState::from_letter('G').map(SignalState::letter),
            Some('G')
        );
        assert!(!SignalState::Amber.is_go() && SignalState::GreenYield.is_go());
    }

    #[test]
    fn a_junction_that_cannot_be_built_says_which_connection_and_why() {
        let build_with = |control: Control, connections: Vec<ConnectionSpec>, signal| {
            let junction = JunctionSpec {
                name: "x".into(),
                control,
                connections,
                signal,
            };
            match RoadNetwork::build_with(&arms(), &[junction]) {
                Err(NetworkError::Junction(e)) => e.to_string(),
                Err(other) => panic!("expected a junction error, got {other}"),
                Ok(_) => panic!("expected a junction error, got a network"),
            }
        };
        let build = |control, connections| build_with(control, connections, None);
        let mut bad = movements();
        bad[4].to = "nowhere".into();
        assert_eq!(
            build(priority(), bad),
            "junction `x` connection 4: there is no road named `nowhere`"
        );
        let mut bad = movements();
        bad[2].from_lane = 1;
        assert!(
            build(priority(), bad)
                .contains("connection 2: road `w in` has 1 lane(s), numbered 0 to 0, not lane 1")
        );
        let mut bad = movements();
        bad.push(bad[0].clone());
        assert!(build(priority(), bad).contains("has connection 12 twice (also as 0)"));
        let major = Control::Priority {
            major: vec!["s out".into()],
            stop: false,
        };
        assert!(build(major, movements()).contains("major road `s out` has no connection"));
        let mut program = two_phase(0.0);
        let signal = |p: &SignalProgram| build_with(Control::Signal, movements(), Some(p.clone()));
        program.phases[2].state.pop();
        assert!(
            signal(&program)
                .contains("phase 2: state `rrrrrrGgGGg` has 11 letter(s) for 12 connection(s)")
        );
        program.phases[2].state.push('x');
        assert!(signal(&program).contains("has `x`; the letters are G, g, y and r"));
        program.phases[2].state = "rrrrrrGgGGgG".into();
        program.phases[1].duration_s = 0.0;
        assert!(signal(&program).contains("phase 1: duration 0 s"));
        assert!(build(Control::Signal, movements()).contains("has no `signal` program"));
        assert!(
            build_with(priority(), movements(), Some(two_phase(0.0)))
                .contains("its control is not `Signal`")
        );
        // Lanes that meet need a link, not a junction; a loop has no end to leave by.
        let mut roads = arms();
        roads.push(RoadSpec::through(
            "on",
            1,
            50.0,
            &[DVec3::new(108.0, -1.5, 0.0), DVec3::new(200.0, -1.5, 0.0)],
        ));
        roads.push(RoadSpec::ring(
            "loop",
            1,
            50.0,
            DVec3::new(0.0, 400.0, 0.0),
            50.0,
            8,
        ));
        let one = |from: &str, to: &str| {
            let junction = JunctionSpec {
                name: "x".into(),
                control: Control::RightBeforeLeft,
                connections: vec![ConnectionSpec {
                    from: from.into(),
                    from_lane: 0,
                    to: to.into(),
                    to_lane: 0,
                }],
                signal: None,
            };
            RoadNetwork::build_with(&roads, &[junction])
                .err()
                .map(|e| e.to_string())
                .unwrap_or_default()
        };
        assert!(one("e out", "on").contains("the lanes meet (0.00 m apart); link the roads"));
        assert!(one("loop", "on").contains("road `loop` is a closed loop"));
        // Two junctions of one name.
        let j = JunctionSpec {
            name: "x".into(),
            control: priority(),
            connections: movements(),
            signal: None,
        };
        assert_eq!(
            RoadNetwork::build_with(&arms(), &[j.clone(), j]).err(),
            Some(NetworkError::DuplicateJunction("x".into()))
        );
    }
}
