//! What drivers see: a per-lane index of vehicles sorted by arc position, rebuilt every tick.

use bevy_ecs::prelude::*;
use flockway_road::{Link, RoadId, RoadNetwork};
use flockway_vehicle::{RoadTrack, VehicleModel};

/// One vehicle in a lane of the index.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LaneEntry {
    /// The vehicle.
    pub entity: Entity,
    /// Arc position of its centre of mass, m.
    pub s_m: f64,
    /// Lateral offset from the road centre line, m (positive left).
    pub lateral_m: f32,
    /// Speed along the road direction, m/s.
    pub speed_mps: f32,
    /// Body length, m.
    pub length_m: f32,
    /// The lane change it signals: +1 left, -1 right (waiting for a gap), ±2 (moving across),
    /// 0 none.
    pub signal: i8,
}

/// A vehicle seen from another: its entry and the arc distance to it (positive ahead).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Seen {
    /// Arc distance from the observer's centre to this vehicle's centre, m (positive ahead,
    /// along loops and through a connection onto the next road).
    pub gap_m: f64,
    /// Lane it is in.
    pub lane: u32,
    /// The vehicle.
    pub entry: LaneEntry,
}

#[derive(Debug, Clone, Default)]
struct RoadLanes {
    length_m: f64,
    closed: bool,
    links: Vec<Link>,
    /// Per lane: the `(road, lane)` pairs leading onto it.
    prev: Vec<Vec<(RoadId, u32)>>,
    lanes: Vec<Vec<LaneEntry>>,
    /// Per lane: how its vehicles spread sideways.
    spread: Vec<Spread>,
    /// For a junction path: the other paths whose vehicles are in this one's lane somewhere —
    /// those from the same lane while they overlap, those merging into the same lane once they
    /// meet.
    beside: Vec<Beside>,
}

/// How the vehicles of one lane spread sideways: the least and the greatest lateral offset,
/// whether any is not a number (then nothing can be said of how far aside they all are), and
/// whether any is moving across into the lane left (signal +2) or right (−2) of it.
#[derive(Debug, Clone, Copy)]
struct Spread {
    least_m: f32,
    most_m: f32,
    any_nan: bool,
    crossing_left: bool,
    crossing_right: bool,
}

impl Default for Spread {
    fn default() -> Self {
        Spread {
            least_m: f32::INFINITY,
            most_m: f32::NEG_INFINITY,
            any_nan: false,
            crossing_left: false,
            crossing_right: false,
        }
    }
}

impl Spread {
    fn add(&mut self, lateral_m: f32, signal: i8) {
        self.least_m = self.least_m.min(lateral_m);
        self.most_m = self.most_m.max(lateral_m);
        self.any_nan |= lateral_m.is_nan();
        self.crossing_left |= signal == 2;
        self.crossing_right |= signal == -2;
    }
}

/// A junction path sharing part of another's lane: its vehicles between `from_m` and `to_m`
/// (on their own path) are at `s + offset_m` on the other.
#[derive(Debug, Clone, Copy)]
struct Beside {
    road: RoadId,
    offset_m: f64,
    from_m: f64,
    to_m: f64,
}

impl Beside {
    /// Its vehicles that count on the other path, at their positions there, from `lo` on.
    fn entries<'a>(
        &self,
        index: &'a LaneIndex,
        lo: f64,
    ) -> impl Iterator<Item = LaneEntry> + use<'a> {
        let entries = index
            .road(self.road)
            .and_then(|r| r.lanes.first())
            .map_or(&[][..], Vec::as_slice);
        let (offset, to) = (self.offset_m, self.to_m);
        let a = entries.partition_point(|e| e.s_m < self.from_m.max(lo - offset));
        entries[a..]
            .iter()
            .take_while(move |e| e.s_m < to)
            .map(move |e| LaneEntry {
                s_m: e.s_m + offset,
                ..*e
            })
    }
}

impl RoadLanes {
    /// Where `lane` leads at the road's end: onto `prefer` if it can, else its first link.
    fn lane_next(&self, lane: u32, prefer: Option<RoadId>) -> Option<(RoadId, u32)> {
        prefer
            .and_then(|p| self.links.iter().find(|l| l.to == p))
            .and_then(|l| l.lane_to(lane).map(|b| (l.to, b)))
            .or_else(|| {
                self.links
                    .iter()
                    .find_map(|l| l.lane_to(lane).map(|b| (l.to, b)))
            })
    }
}

/// Most roads a leader or follower search crosses (short roads in a row).
const MAX_HOPS: usize = 8;

/// Lanes with fewer vehicles than this are searched by plain bisection (they fit in a few
/// cache lines).
const GALLOP_FROM: usize = 64;

/// `entries.partition_point(pred)` for a lane's vehicles (sorted by arc position) and a
/// predicate that holds short of about `s_m`: the search starts where `s_m` would fall were the
/// vehicles spread evenly over the `length_m` lane, and gallops out from there. On a long, busy
/// lane the answer is a cache line or two from that guess, where bisection misses the cache a
/// dozen times; the answer is the same either way.
fn partition_near(
    entries: &[LaneEntry],
    s_m: f64,
    length_m: f64,
    pred: impl Fn(&LaneEntry) -> bool,
) -> usize {
    let n = entries.len();
    if n < GALLOP_FROM || length_m <= 0.0 {
        return entries.partition_point(&pred);
    }
    // The conversion saturates: short of the lane (or NaN) is 0, past it is clamped below.
    let guess = ((s_m / length_m * n as f64) as usize).min(n - 1);
    let mut step = 1;
    if pred(&entries[guess]) {
        // The answer is past the guess: gallop forwards.
        let mut lo = guess + 1;
        loop {
            let probe = guess + step;
            if probe >= n {
                return lo + entries[lo..].partition_point(&pred);
            }
            if !pred(&entries[probe]) {
                return lo + entries[lo..probe].partition_point(&pred);
            }
            lo = probe + 1;
            step *= 2;
        }
    }
    // The answer is at the guess or before it: gallop backwards.
    let mut hi = guess;
    loop {
        if step > hi {
            return entries[..hi].partition_point(&pred);
        }
        let probe = hi - step;
        if pred(&entries[probe]) {
            return probe + 1 + entries[probe + 1..hi].partition_point(&pred);
        }
        hi = probe;
        step *= 2;
    }
}

/// The vehicles of a lane (sorted by arc position, `length_m` long) from `from` to `to`, in
/// order. Inlined into each of its uses in a window search (called, its arguments and the call
/// were a good part of the search's instructions).
#[inline(always)]
fn window(
    entries: &[LaneEntry],
    length_m: f64,
    from: f64,
    to: f64,
) -> impl Iterator<Item = &LaneEntry> {
    let a = partition_near(entries, from, length_m, |e| e.s_m < from);
    // A window holds a few vehicles: taking them while walking to its end beats a second binary
    // search (which misses the cache on long lanes), and beats counting them first.
    entries[a..].iter().take_while(move |e| e.s_m <= to)
}

/// Every vehicle on the roads, per road and lane, sorted by arc position (ties by entity), as of
/// the start of this tick. Queries cost O(log n + k) for k vehicles returned.
#[derive(Resource, Debug, Clone, Default)]
pub struct LaneIndex {
    /// By road id (the network's slots: a road's id is its index).
    roads: Vec<Option<RoadLanes>>,
    vehicles: usize,
    /// Vehicles signalling a lane change.
    signalling: usize,
    /// The [`RoadNetwork::revision`] the roads' links, lanes and paths beside were read from.
    read_from: Option<u64>,
}

impl LaneIndex {
    /// Rebuilds the index from vehicles' `(entity, track, body length in m, signal)`.
    pub fn rebuild<'a>(
        &mut self,
        network: &RoadNetwork,
        vehicles: impl Iterator<Item = (Entity, &'a RoadTrack, f32, i8)>,
    ) {
        self.begin(network);
        vehicles.for_each(|(entity, track, length_m, signal)| {
            self.add(entity, track, length_m, signal);
        });
        self.finish();
    }

    /// Empties the index for a [`rebuild`](Self::rebuild) on `network`, keeping its lanes'
    /// allocations.
    fn begin(&mut self, network: &RoadNetwork) {
        for road in self.roads.iter_mut().flatten() {
            road.lanes.iter_mut().for_each(Vec::clear);
            road.spread.fill(Spread::default());
        }
        self.signalling = 0;
        if self.read_from != Some(network.revision()) {
            self.read_network(network);
        }
        self.vehicles = 0;
    }

    /// Adds a vehicle to its lane, unsorted, if it is on a road of the index.
    // Inlined into the walk over the vehicles' query.
    #[inline(always)]
    fn add(&mut self, entity: Entity, track: &RoadTrack, length_m: f32, signal: i8) {
        if !track.on_road {
            return;
        }
        let Some(road) = self
            .roads
            .get_mut(track.road.0 as usize)
            .and_then(Option::as_mut)
        else {
            return;
        };
        let Some(lane) = road.lanes.get_mut(track.lane as usize) else {
            return;
        };
        self.signalling += usize::from(signal != 0);
        let lateral_m = track.lateral_m as f32;
        if let Some(spread) = road.spread.get_mut(track.lane as usize) {
            spread.add(lateral_m, signal);
        }
        lane.push(LaneEntry {
            entity,
            s_m: track.s_m,
            lateral_m,
            speed_mps: track.speed_along_mps,
            length_m,
            signal,
        });
        self.vehicles += 1;
    }

    /// Sorts every lane by place once its vehicles are in.
    fn finish(&mut self) {
        // The vehicles come in the query's order, which a running simulation keeps from tick to
        // tick, so each lane arrives as a few long runs (a ring's cars past its join, cars that
        // changed lane): the stable sort merges runs in linear time where the unstable one
        // sorts from scratch. Cars spawned first come first and are the farthest along, so a
        // lane mostly arrives descending, which the sort (insertion on a short lane) takes
        // quadratic time over: such a lane is turned round first. Every `(s, entity)` is
        // distinct, so the order is the same either way.
        let by_place =
            |a: &LaneEntry, b: &LaneEntry| a.s_m.total_cmp(&b.s_m).then(a.entity.cmp(&b.entity));
        for road in self.roads.iter_mut().flatten() {
            for lane in &mut road.lanes {
                let descents = lane
                    .windows(2)
                    .filter(|w| by_place(&w[0], &w[1]).is_gt())
                    .count();
                if 2 * descents > lane.len() {
                    lane.reverse();
                }
                lane.sort_by(by_place);
            }
        }
    }

    /// Reads what the index needs of `network` apart from its vehicles: each road's length,
    /// links and lanes in, and the paths beside each junction path.
    fn read_network(&mut self, network: &RoadNetwork) {
        let slots = network.iter().last().map_or(0, |(id, _)| id.0 as usize + 1);
        self.roads.resize_with(slots, || None);
        for (i, road) in self.roads.iter_mut().enumerate() {
            if network.get(RoadId(i as u32)).is_none() {
                *road = None;
            }
        }
        for (id, g) in network.iter() {
            let road = self.roads[id.0 as usize].get_or_insert_with(RoadLanes::default);
            road.length_m = g.length_m();
            road.closed = g.is_closed();
            let links = network.links(id);
            if road.links.as_slice() != links {
                road.links = links.to_vec();
            }
            road.prev.resize_with(g.lanes() as usize, Vec::new);
            for (lane, prev) in road.prev.iter_mut().enumerate() {
                let now = network.lane_prev(id, lane as u32);
                if prev.as_slice() != now {
                    *prev = now.to_vec();
                }
            }
            road.lanes.resize_with(g.lanes() as usize, Vec::new);
            road.spread.resize(g.lanes() as usize, Spread::default());
            road.beside.clear();
            if let Some((j, k)) = network.junction_path(id) {
                let path = &network.junctions()[j].paths[k];
                road.beside
                    .extend(path.siblings.iter().filter_map(|&(o, part)| {
                        Some(Beside {
                            road: network.path_road(j, o)?,
                            offset_m: 0.0,
                            from_m: f64::NEG_INFINITY,
                            to_m: part,
                        })
                    }));
                // Paths merging into its lane: aligned at their common end, from where they
                // meet.
                let length = g.length_m();
                road.beside
                    .extend(path.conflicts.iter().filter(|c| c.merge).filter_map(|c| {
                        let other = network.path_road(j, c.other)?;
                        Some(Beside {
                            road: other,
                            offset_m: length - network.get(other)?.length_m(),
                            from_m: c.other_at_m,
                            to_m: f64::INFINITY,
                        })
                    }));
            }
        }
        self.read_from = Some(network.revision());
    }

    /// The indexed road with this id.
    fn road(&self, id: RoadId) -> Option<&RoadLanes> {
        self.roads.get(id.0 as usize)?.as_ref()
    }

    /// Number of vehicles indexed.
    pub fn len(&self) -> usize {
        self.vehicles
    }

    /// Whether no vehicle is indexed.
    pub fn is_empty(&self) -> bool {
        self.vehicles == 0
    }

    /// The vehicles of one lane, sorted by arc position.
    pub fn lane(&self, road: RoadId, lane: u32) -> &[LaneEntry] {
        self.road(road)
            .and_then(|r| r.lanes.get(lane as usize))
            .map_or(&[], Vec::as_slice)
    }

    /// Whether any vehicle signals a lane change (so a driver can skip looking for one to make
    /// room for).
    pub fn any_signal(&self) -> bool {
        self.signalling > 0
    }

    /// Number of lanes of a road in the index.
    pub fn lanes(&self, road: RoadId) -> u32 {
        self.road(road).map_or(0, |r| r.lanes.len() as u32)
    }

    /// Whether any vehicle in `lane` of `road` is moving across into the lane beside it on the
    /// side `signal` tells (+2 left, −2 right; see [`LaneEntry::signal`]). `false` for any
    /// other signal, or a lane not in the index.
    pub fn any_crossing(&self, road: RoadId, lane: u32, signal: i8) -> bool {
        self.road(road)
            .and_then(|r| r.spread.get(lane as usize))
            .is_some_and(|s| match signal {
                2 => s.crossing_left,
                -2 => s.crossing_right,
                _ => false,
            })
    }

    /// Whether every vehicle [`visit_within`](Self::visit_within) would hand over for the same
    /// window is at least `apart_m` sideways of `lateral_m`, as `|entry.lateral_m - lateral_m|
    /// >= apart_m` computes it, so that a caller looking only for vehicles nearer than that can
    /// skip the walk: the window stays on this road (no links, no lanes leading on, no junction
    /// paths sharing the lane) and the lane's least or greatest lateral offset is that far
    /// aside. `false` whenever that is not certain.
    #[expect(
        clippy::too_many_arguments,
        reason = "a query's coordinates, each one number"
    )]
    pub fn window_apart(
        &self,
        road: RoadId,
        lane: u32,
        s_m: f64,
        behind_m: f64,
        ahead_m: f64,
        lateral_m: f32,
        apart_m: f32,
    ) -> bool {
        let Some(r) = self.road(road) else {
            return false;
        };
        let Some(spread) = r.spread.get(lane as usize) else {
            return false;
        };
        // The bounds as `visit_within` computes them: open roads' windows stay on the road.
        let (lo, hi) = (s_m - behind_m, s_m + ahead_m);
        let on_road = r.closed || (lo >= 0.0 && hi <= r.length_m);
        // Subtraction rounds monotonically, so the nearest of the lane's offsets bounds them
        // all (and a NaN anywhere fails every comparison, as in the caller's test).
        on_road
            && r.beside.is_empty()
            && !spread.any_nan
            && (spread.least_m - lateral_m >= apart_m || lateral_m - spread.most_m >= apart_m)
    }

    /// Every vehicle in `lane` whose arc distance from `s_m` lies in `[-behind_m, ahead_m]`,
    /// except `exclude`, appended to `out` in arc order. Wraps around loops. (`out` is the
    /// caller's, so a driver reuses one buffer for every query of a tick.)
    #[expect(
        clippy::too_many_arguments,
        reason = "a query's coordinates, each one number"
    )]
    pub fn within(
        &self,
        road: RoadId,
        lane: u32,
        s_m: f64,
        behind_m: f64,
        ahead_m: f64,
        exclude: Option<Entity>,
        out: &mut Vec<Seen>,
    ) {
        self.visit_within(road, lane, s_m, behind_m, ahead_m, exclude, |s| out.push(s));
    }

    /// [`within`](Self::within), each vehicle handed to `out` in the same order instead of
    /// appended to a buffer: for a caller that keeps few of them.
    #[expect(
        clippy::too_many_arguments,
        reason = "a query's coordinates, each one number"
    )]
    pub fn visit_within(
        &self,
        road: RoadId,
        lane: u32,
        s_m: f64,
        behind_m: f64,
        ahead_m: f64,
        exclude: Option<Entity>,
        out: impl FnMut(Seen),
    ) {
        if let Some(r) = self.road(road) {
            self.visit_on(r, lane, s_m, behind_m, ahead_m, exclude, out);
        }
    }

    /// [`visit_within`](Self::visit_within) for several lanes of one road around the same arc
    /// position, each `(lane, range)` a window of `range` behind and ahead: each vehicle handed
    /// to `out` with the position of its window in `lanes`, window after window in the order
    /// given, as that many calls would hand them over, the road looked up once (a flocking
    /// driver's own lane and the two beside it, every tick).
    pub fn visit_lanes(
        &self,
        road: RoadId,
        lanes: &[(u32, f64)],
        s_m: f64,
        exclude: Option<Entity>,
        mut out: impl FnMut(usize, Seen),
    ) {
        let Some(r) = self.road(road) else {
            return;
        };
        for (k, &(lane, range)) in lanes.iter().enumerate() {
            self.visit_on(r, lane, s_m, range, range, exclude, |s| out(k, s));
        }
    }

    /// [`visit_within`](Self::visit_within) on the indexed road `r`.
    #[expect(
        clippy::too_many_arguments,
        reason = "a query's coordinates, each one number"
    )]
    // Inlined into each caller, so that a caller walking several lanes makes one call.
    #[inline(always)]
    fn visit_on(
        &self,
        r: &RoadLanes,
        lane: u32,
        s_m: f64,
        behind_m: f64,
        ahead_m: f64,
        exclude: Option<Entity>,
        mut out: impl FnMut(Seen),
    ) {
        let Some(entries) = r.lanes.get(lane as usize) else {
            return;
        };
        let mut push = |e: &LaneEntry, gap: f64| {
            if Some(e.entity) != exclude {
                out(Seen {
                    gap_m: gap,
                    lane,
                    entry: *e,
                });
            }
        };
        let (lo, hi) = (s_m - behind_m, s_m + ahead_m);
        if r.closed && (behind_m + ahead_m) >= r.length_m {
            // The window covers the whole loop: every vehicle once, at its nearest signed gap.
            for e in entries {
                let mut gap = flockway_core::wrap::rem_euclid(e.s_m - s_m, r.length_m);
                if gap > ahead_m {
                    gap -= r.length_m;
                }
                push(e, gap);
            }
            return;
        }
        let range = |from: f64, to: f64| window(entries, r.length_m, from, to);
        if r.closed && lo < 0.0 {
            for e in range(lo + r.length_m, r.length_m) {
                push(e, e.s_m - r.length_m - s_m);
            }
        }
        for e in range(lo.max(0.0), hi.min(r.length_m)) {
            push(e, e.s_m - s_m);
        }
        if r.closed && hi > r.length_m {
            for e in range(0.0, hi - r.length_m) {
                push(e, e.s_m + r.length_m - s_m);
            }
        }
        // Inside a junction, the cars on paths sharing this one's lane (from the same lane while
        // they overlap, merging into the same lane once they meet).
        if !r.beside.is_empty() {
            self.push_beside(r, lo, hi, -s_m, lane, exclude, &mut out);
        }
        if !r.closed && hi > r.length_m {
            // Traffic continues onto its lane's link.
            if let Some((next, lane2)) = r.lane_next(lane, None)
                && let Some(r2) = self.road(next)
                && let Some(e2) = r2.lanes.get(lane2 as usize)
            {
                let end = e2.partition_point(|e| e.s_m <= hi - r.length_m);
                for e in &e2[..end] {
                    if Some(e.entity) != exclude {
                        out(Seen {
                            gap_m: r.length_m - s_m + e.s_m,
                            lane: lane2,
                            entry: *e,
                        });
                    }
                }
                self.push_beside(
                    r2,
                    f64::NEG_INFINITY,
                    hi - r.length_m,
                    r.length_m - s_m,
                    lane2,
                    exclude,
                    &mut out,
                );
            }
        }
        if !r.closed && lo < 0.0 {
            // And back along the lanes that lead onto this one.
            for &(prev, lane0) in r.prev.get(lane as usize).map_or(&[][..], Vec::as_slice) {
                let Some(r0) = self.road(prev) else {
                    continue;
                };
                let Some(e0) = r0.lanes.get(lane0 as usize) else {
                    continue;
                };
                let from = e0.partition_point(|e| e.s_m < r0.length_m + lo);
                for e in &e0[from..] {
                    if Some(e.entity) != exclude {
                        out(Seen {
                            gap_m: e.s_m - r0.length_m - s_m,
                            lane: lane0,
                            entry: *e,
                        });
                    }
                }
            }
        }
    }

    /// The nearest vehicle ahead in `lane` within `range_m` (strictly ahead of `s_m`, or level
    /// with it but later in entity order), following loops and the lane's links at a road's end
    /// (onto `next` where the lane leads there: the vehicle's route). O(log n) per road crossed.
    pub fn leader(
        &self,
        road: RoadId,
        lane: u32,
        s_m: f64,
        me: Entity,
        range_m: f64,
        next: Option<RoadId>,
    ) -> Option<Seen> {
        let r = self.road(road)?;
        let entries = r.lanes.get(lane as usize)?;
        let ahead = |e: &LaneEntry| e.s_m > s_m || (e.s_m == s_m && e.entity > me);
        let seen = |e: &LaneEntry, gap_m: f64, lane: u32| {
            (gap_m <= range_m).then_some(Seen {
                gap_m,
                lane,
                entry: *e,
            })
        };
        let i = partition_near(entries, s_m, r.length_m, |e| !ahead(e));
        // Inside a junction a car on a path from the same lane is still in front while the
        // two paths overlap, and one merging into the same lane once they meet.
        let sibling = self.beside_ahead(r, s_m, me).map(|e| Seen {
            gap_m: e.s_m - s_m,
            lane,
            entry: e,
        });
        if let Some(e) = entries.get(i) {
            let own = seen(e, e.s_m - s_m, lane);
            return match (own, sibling) {
                (Some(o), Some(s)) if s.gap_m < o.gap_m => Some(s),
                (o, _) => o.or(sibling.filter(|s| s.gap_m <= range_m)),
            };
        }
        if let Some(s) = sibling.filter(|s| s.gap_m <= range_m) {
            return Some(s);
        }
        if r.closed {
            // Round the loop: the first vehicle of the lane (never ourselves, unless alone).
            return entries
                .first()
                .filter(|e| e.entity != me)
                .and_then(|e| seen(e, e.s_m + r.length_m - s_m, lane));
        }
        // Along the lane's links, road after road, until someone is found or out of range.
        let mut gap = r.length_m - s_m;
        let (mut road, mut lane) = r.lane_next(lane, next)?;
        for hop in 0..MAX_HOPS {
            if gap > range_m {
                return None;
            }
            let r = self.road(road)?;
            let first = r.lanes.get(lane as usize)?.first();
            // Into a junction: a car on a path sharing its lane there counts.
            let sibling = if hop == 0 {
                self.beside_ahead(r, f64::NEG_INFINITY, me)
            } else {
                None
            };
            let nearest = match (first, sibling.as_ref()) {
                (Some(e), Some(s)) if s.s_m < e.s_m => Some(s),
                (Some(e), _) => Some(e),
                (None, s) => s,
            };
            if let Some(e) = nearest {
                return seen(e, gap + e.s_m, lane);
            }
            if r.closed {
                return None;
            }
            gap += r.length_m;
            (road, lane) = r.lane_next(lane, None)?;
        }
        None
    }

    /// On a junction path `r`: every vehicle on a path sharing its lane between `lo` and `hi`
    /// (arc positions on `r`), at gap `s + offset`.
    /// A window on its own road tests for paths beside before the call: most roads have none,
    /// and calling to find none was a good part of a window search's instructions.
    #[expect(
        clippy::too_many_arguments,
        reason = "a query's coordinates, each one number"
    )]
    #[inline(never)]
    fn push_beside(
        &self,
        r: &RoadLanes,
        lo: f64,
        hi: f64,
        offset: f64,
        lane: u32,
        exclude: Option<Entity>,
        out: &mut impl FnMut(Seen),
    ) {
        for b in &r.beside {
            for e in b.entries(self, lo).take_while(|e| e.s_m <= hi) {
                if Some(e.entity) != exclude {
                    out(Seen {
                        gap_m: e.s_m + offset,
                        lane,
                        entry: e,
                    });
                }
            }
        }
    }

    /// On a junction path `r`, the nearest vehicle ahead of `s_m` on a path sharing its lane
    /// there (at its position on `r`).
    // The test for paths beside inlined, the search not (as in `push_beside`).
    #[inline(always)]
    fn beside_ahead(&self, r: &RoadLanes, s_m: f64, me: Entity) -> Option<LaneEntry> {
        if r.beside.is_empty() {
            return None;
        }
        self.beside_ahead_search(r, s_m, me)
    }

    /// [`beside_ahead`](Self::beside_ahead)'s search over the paths beside.
    #[inline(never)]
    fn beside_ahead_search(&self, r: &RoadLanes, s_m: f64, me: Entity) -> Option<LaneEntry> {
        r.beside
            .iter()
            .filter_map(|b| b.entries(self, s_m).find(|e| e.s_m > s_m && e.entity != me))
            .min_by(|a, b| a.s_m.total_cmp(&b.s_m).then(a.entity.cmp(&b.entity)))
    }

    /// The nearest vehicle behind in `lane` within `range_m` (strictly behind, or level with
    /// `s_m` but earlier in entity order), following loops and back along every lane that leads
    /// onto this one (the nearest of them). O(log n) per road crossed.
    pub fn follower(
        &self,
        road: RoadId,
        lane: u32,
        s_m: f64,
        me: Entity,
        range_m: f64,
    ) -> Option<Seen> {
        let r = self.road(road)?;
        let entries = r.lanes.get(lane as usize)?;
        let behind = |e: &LaneEntry| e.s_m < s_m || (e.s_m == s_m && e.entity < me);
        let i = partition_near(entries, s_m, r.length_m, behind);
        if i > 0 {
            let e = &entries[i - 1];
            return (s_m - e.s_m <= range_m).then_some(Seen {
                gap_m: e.s_m - s_m,
                lane,
                entry: *e,
            });
        }
        if r.closed {
            return entries
                .last()
                .filter(|e| e.entity != me)
                .filter(|e| s_m + r.length_m - e.s_m <= range_m)
                .map(|e| Seen {
                    gap_m: e.s_m - r.length_m - s_m,
                    lane,
                    entry: *e,
                });
        }
        self.follower_before(road, lane, s_m, range_m, MAX_HOPS)
    }

    /// The nearest vehicle on the lanes leading onto `lane` of `road`, behind arc position
    /// `s_m` of it.
    fn follower_before(
        &self,
        road: RoadId,
        lane: u32,
        s_m: f64,
        range_m: f64,
        hops: usize,
    ) -> Option<Seen> {
        if hops == 0 || s_m > range_m {
            return None;
        }
        let r = self.road(road)?;
        let mut best: Option<Seen> = None;
        for &(prev, lane0) in r.prev.get(lane as usize)? {
            let Some(r0) = self.road(prev) else {
                continue;
            };
            if r0.closed {
                continue;
            }
            let found = match r0.lanes.get(lane0 as usize).and_then(|l| l.last()) {
                Some(e) => {
                    let gap_m = e.s_m - r0.length_m - s_m;
                    (-gap_m <= range_m).then_some(Seen {
                        gap_m,
                        lane: lane0,
                        entry: *e,
                    })
                }
                None => self.follower_before(prev, lane0, s_m + r0.length_m, range_m, hops - 1),
            };
            if let Some(f) = found
                && best.is_none_or(|b| f.gap_m > b.gap_m)
            {
                best = Some(f);
            }
        }
        best
    }
}

/// The lane change a vehicle signals to the others: +1 left or -1 right while it waits for a
/// gap, +2 or -2 while it moves across, 0 none. Its driver sets it; the others see it in the
/// [`LaneIndex`] next tick.
#[derive(Component, Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LaneSignal(pub i8);

/// Rebuilds the [`LaneIndex`] from every vehicle's track, once per tick before drivers decide.
pub fn rebuild_lane_index(
    network: Res<RoadNetwork>,
    mut index: ResMut<LaneIndex>,
    vehicles: Query<(Entity, &RoadTrack, &VehicleModel, Option<&LaneSignal>)>,
) {
    let index = &mut *index;
    index.begin(&network);
    // The query's fold walks its tables directly, and the step inlined into it makes each car's
    // item in registers: fewer instructions a car than the iterator's `next`.
    vehicles.iter().fold(
        (),
        #[inline(always)]
        |(), (e, t, model, signal)| {
            index.add(
                e,
                t,
                model.0.params.chassis.length_m,
                signal.map_or(0, |s| s.0),
            );
        },
    );
    index.finish();
}

/// Placements for the driver tests.
#[cfg(test)]
pub(crate) mod fixtures {
    use super::*;
    use flockway_road::RoadSpec;
    use glam::DVec3;

    /// A tiny deterministic generator for test placements.
    pub(crate) struct Lcg(pub(crate) u64);
    impl Lcg {
        /// The next number, uniform in [0, 1).
        pub(crate) fn next(&mut self) -> f64 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// A three-lane `approach` (900 m) splitting into `south` (from lane 0) and the two-lane
    /// `north` (from lanes 1 and 2), and an index over 4.6 m vehicles at
    /// `(road, lane, s, speed along the road)`.
    pub(crate) fn split_with(
        cars: &[(RoadId, u32, f64, f32)],
    ) -> (RoadNetwork, LaneIndex, Vec<(Entity, RoadTrack)>) {
        use flockway_road::LinkSpec;
        let mut a = RoadSpec::through(
            "approach",
            3,
            100.0,
            &[DVec3::ZERO, DVec3::new(900.0, 0.0, 0.0)],
        );
        a.links = vec![
            LinkSpec {
                to: "south".into(),
                lanes: vec![(0, 0)],
            },
            LinkSpec {
                to: "north".into(),
                lanes: vec![(1, 0), (2, 1)],
            },
        ];
        let south = RoadSpec::through(
            "south",
            1,
            100.0,
            &[
                DVec3::new(900.0, -3.5, 0.0),
                DVec3::new(1_200.0, -40.0, 0.0),
            ],
        );
        let north = RoadSpec::through(
            "north",
            2,
            100.0,
            &[DVec3::new(900.0, 1.75, 0.0), DVec3::new(1_200.0, 40.0, 0.0)],
        );
        let network = RoadNetwork::build(&[a, south, north]).expect("a valid split");
        index_over(network, cars)
    }

    /// An index over 4.6 m vehicles at `(road, lane, s, speed along the road)` on `network`.
    pub(crate) fn index_over(
        network: RoadNetwork,
        cars: &[(RoadId, u32, f64, f32)],
    ) -> (RoadNetwork, LaneIndex, Vec<(Entity, RoadTrack)>) {
        let mut world = World::new();
        let tracks: Vec<(Entity, RoadTrack)> = cars
            .iter()
            .map(|&(road, lane, s, speed)| {
                let g = network.get(road).expect("road");
                let lateral = flockway_road::lane_offset(g.frame_at(s).width_m, g.lanes(), lane);
                let mut track = RoadTrack::new(road, g, s, lateral);
                track.speed_along_mps = speed;
                assert_eq!(track.lane, lane);
                (world.spawn_empty().id(), track)
            })
            .collect();
        let mut index = LaneIndex::default();
        index.rebuild(&network, tracks.iter().map(|(e, t)| (*e, t, 4.6, 0)));
        (network, index, tracks)
    }
}

#[cfg(test)]
mod tests {
    use super::fixtures::{Lcg, split_with};
    use super::*;
    use flockway_road::RoadSpec;
    use glam::DVec3;

    /// A three-lane ring of 60 m radius, or a three-lane 300 m road leading onto a 200 m road
    /// of `next_lanes` lanes.
    fn ring_or_road_on(closed: bool, next_lanes: u32) -> Vec<RoadSpec> {
        if closed {
            return vec![RoadSpec::ring("ring", 3, 50.0, DVec3::ZERO, 60.0, 12)];
        }
        let mut a = RoadSpec::through("a", 3, 50.0, &[DVec3::ZERO, DVec3::new(300.0, 0.0, 0.0)]);
        a.next = Some("b".into());
        let b = RoadSpec::through(
            "b",
            next_lanes,
            50.0,
            &[DVec3::new(300.0, 0.0, 0.0), DVec3::new(500.0, 0.0, 0.0)],
        );
        vec![a, b]
    }

    /// An index over `n` random placements on road 0 (a ring or an open road) and road 1 (its
    /// connected successor when open), built directly from entries.
    fn placements(closed: bool, n: usize, seed: u64) -> (LaneIndex, Vec<(RoadId, u32, LaneEntry)>) {
        let mut rng = Lcg(seed);
        let network = RoadNetwork::build(&ring_or_road_on(closed, 2)).expect("valid roads");
        let mut world = World::new();
        let mut all = Vec::new();
        let mut index = LaneIndex::default();
        index.rebuild(&network, std::iter::empty());
        for _ in 0..n {
            let road = if closed || rng.next() < 0.7 {
                RoadId(0)
            } else {
                RoadId(1)
            };
            let g = network.get(road).expect("road");
            let lane = (rng.next() * f64::from(g.lanes())) as u32;
            // Some vehicles share an arc position exactly, to test tie-breaking.
            let s = if rng.next() < 0.05 {
                100.0
            } else {
                rng.next() * g.length_m()
            };
            let e = LaneEntry {
                entity: world.spawn_empty().id(),
                s_m: s,
                lateral_m: 0.0,
                speed_mps: 10.0,
                length_m: 4.6,
                signal: 0,
            };
            index.roads[road.0 as usize]
                .as_mut()
                .expect("indexed road")
                .lanes[lane as usize]
                .push(e);
            all.push((road, lane, e));
        }
        for r in index.roads.iter_mut().flatten() {
            for l in &mut r.lanes {
                l.sort_unstable_by(|a, b| a.s_m.total_cmp(&b.s_m).then(a.entity.cmp(&b.entity)));
            }
        }
        index.vehicles = n;
        (index, all)
    }

    /// The signed arc gap from (road 0 or 1, s) to a vehicle by brute force, if it is reachable
    /// within the window.
    fn brute_gap(closed: bool, len0: f64, from: (RoadId, f64), to: (RoadId, f64)) -> Vec<f64> {
        let mut gaps = Vec::new();
        if from.0 == to.0 {
            gaps.push(to.1 - from.1);
            if closed {
                gaps.push(to.1 - from.1 + len0);
                gaps.push(to.1 - from.1 - len0);
            }
        } else if from.0 == RoadId(0) && to.0 == RoadId(1) {
            gaps.push(len0 - from.1 + to.1);
        }
        gaps
    }

    #[test]
    fn a_lane_is_in_place_order_however_its_cars_arrive() {
        let network = RoadNetwork::build(&ring_or_road_on(false, 2)).expect("valid roads");
        let g = network.get(RoadId(0)).expect("road");
        let mut world = World::new();
        let mut rng = Lcg(11);
        for n in [0, 1, 2, 3, 12, 20, 21, 40] {
            // Ascending, descending (the query's usual order), descending but for one car put
            // in another's place (a despawn), shuffled; two cars at the same place among them.
            let mut tracks: Vec<(Entity, RoadTrack)> = (0..n)
                .map(|i| {
                    let s = if i == 1 {
                        150.0
                    } else {
                        10.0 + 250.0 * rng.next()
                    };
                    let lateral = flockway_road::lane_offset(g.frame_at(s).width_m, g.lanes(), 1);
                    (
                        world.spawn_empty().id(),
                        RoadTrack::new(RoadId(0), g, s, lateral),
                    )
                })
                .collect();
            if n > 2 {
                tracks[2].1 = tracks[1].1;
            }
            let mut expected: Vec<(f64, Entity)> =
                tracks.iter().map(|(e, t)| (t.s_m, *e)).collect();
            expected.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            let mut orders = vec![expected.clone()];
            orders.push(expected.iter().rev().copied().collect());
            let mut despawned = orders[1].clone();
            if n > 3 {
                let last = despawned.pop().expect("cars");
                despawned.insert(1, last);
            }
            orders.push(despawned);
            let mut shuffled = expected.clone();
            for i in (1..shuffled.len()).rev() {
                shuffled.swap(i, (rng.next() * (i + 1) as f64) as usize);
            }
            orders.push(shuffled);
            for (k, order) in orders.iter().enumerate() {
                let by_entity = |e: &Entity| &tracks.iter().find(|(t, _)| t == e).expect("car").1;
                let mut index = LaneIndex::default();
                index.rebuild(
                    &network,
                    order.iter().map(|(_, e)| (*e, by_entity(e), 4.6, 0)),
                );
                let got: Vec<(f64, Entity)> = index
                    .lane(RoadId(0), 1)
                    .iter()
                    .map(|e| (e.s_m, e.entity))
                    .collect();
                assert_eq!(got, expected, "{n} cars, order {k}");
            }
        }
    }

    #[test]
    fn the_galloping_search_finds_what_bisection_finds() {
        let mut world = World::new();
        let mut rng = Lcg(7);
        let length = 1000.0;
        for n in [0, 1, 63, 64, 65, 300, 2500] {
            // Spread evenly, bunched at one end, in a few clumps, all level.
            for shape in 0..4 {
                let mut lane: Vec<LaneEntry> = (0..n)
                    .map(|i| {
                        let u = rng.next();
                        let s_m = match shape {
                            0 => u * length,
                            1 => u * u * u * length,
                            2 => f64::from(i as u32 % 5) * 200.0 + u * 3.0,
                            _ => 500.0,
                        };
                        LaneEntry {
                            entity: world.spawn_empty().id(),
                            s_m,
                            lateral_m: 0.0,
                            speed_mps: 0.0,
                            length_m: 4.6,
                            signal: 0,
                        }
                    })
                    .collect();
                lane.sort_unstable_by(|a, b| a.s_m.total_cmp(&b.s_m).then(a.entity.cmp(&b.entity)));
                let mut queries: Vec<f64> = (0..200).map(|_| rng.next() * 1200.0 - 100.0).collect();
                queries.extend(lane.iter().step_by(7).map(|e| e.s_m));
                queries.extend([f64::NEG_INFINITY, -1.0, 0.0, 500.0, length, 2.0e6, f64::NAN]);
                for s in queries {
                    let before = |e: &LaneEntry| e.s_m < s;
                    assert_eq!(
                        partition_near(&lane, s, length, before),
                        lane.partition_point(before),
                        "n {n} shape {shape} s {s}"
                    );
                    let me = lane.get(n / 2).map_or(Entity::PLACEHOLDER, |e| e.entity);
                    let not_ahead = |e: &LaneEntry| !(e.s_m > s || (e.s_m == s && e.entity > me));
                    assert_eq!(
                        partition_near(&lane, s, length, not_ahead),
                        lane.partition_point(not_ahead),
                        "n {n} shape {shape} s {s}"
                    );
                }
            }
        }
    }

    #[test]
    fn queries_match_a_brute_force_scan() {
        for closed in [true, false] {
            for seed in 1..=20u64 {
                let (index, all) = placements(closed, 60, seed);
                let len0 = index.road(RoadId(0)).expect("indexed road").length_m;
                let mut rng = Lcg(seed * 77);
                for _ in 0..40 {
                    let lane = (rng.next() * 3.0) as u32;
                    let s = rng.next() * len0;
                    let behind = rng.next() * 80.0;
                    let ahead = rng.next() * 80.0;
                    let mut got = Vec::new();
                    index.within(RoadId(0), lane, s, behind, ahead, None, &mut got);
                    let mut got: Vec<(Entity, i64)> = got
                        .iter()
                        .map(|v| (v.entry.entity, (v.gap_m * 1e6).round() as i64))
                        .collect();
                    got.sort();
                    let mut want: Vec<(Entity, i64)> = Vec::new();
                    for (road, l, e) in &all {
                        let lane_matches = if *road == RoadId(0) {
                            *l == lane
                        } else {
                            *l == lane.min(1)
                        };
                        if !lane_matches {
                            continue;
                        }
                        let gaps = brute_gap(closed, len0, (RoadId(0), s), (*road, e.s_m));
                        // The nearest in-window gap (a ring window shorter than the ring has one).
                        if let Some(g) = gaps
                            .into_iter()
                            .filter(|g| *g >= -behind && *g <= ahead)
                            .min_by(|a, b| a.abs().total_cmp(&b.abs()))
                        {
                            want.push((e.entity, (g * 1e6).round() as i64));
                        }
                    }
                    want.sort();
                    assert_eq!(got, want, "closed {closed} seed {seed} lane {lane} s {s}");

                    // Leader and follower: the nearest strictly ahead / behind within 80 m, by
                    // brute force over every placement.
                    let me = Entity::PLACEHOLDER;
                    let gaps_all: Vec<(Entity, f64)> = all
                        .iter()
                        .filter(|(road, l, _)| {
                            if *road == RoadId(0) {
                                *l == lane
                            } else {
                                *l == lane.min(1)
                            }
                        })
                        .flat_map(|(road, _, e)| {
                            brute_gap(closed, len0, (RoadId(0), s), (*road, e.s_m))
                                .into_iter()
                                .map(move |g| (e.entity, g))
                        })
                        .collect();
                    let best_ahead = gaps_all
                        .iter()
                        .filter(|(_, g)| *g > 0.0 && *g <= 80.0)
                        .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)))
                        .map(|(e, _)| *e);
                    let best_behind = gaps_all
                        .iter()
                        .filter(|(_, g)| *g < 0.0 && *g >= -80.0)
                        // Level vehicles are ordered by entity: the later one is nearer.
                        .max_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)))
                        .map(|(e, _)| *e);
                    assert_eq!(
                        index
                            .leader(RoadId(0), lane, s, me, 80.0, None)
                            .map(|v| v.entry.entity),
                        best_ahead,
                        "leader: closed {closed} seed {seed} lane {lane} s {s}"
                    );
                    assert_eq!(
                        index
                            .follower(RoadId(0), lane, s, me, 80.0)
                            .map(|v| v.entry.entity),
                        best_behind,
                        "follower: closed {closed} seed {seed} lane {lane} s {s}"
                    );
                }
            }
        }
    }

    #[test]
    fn several_lanes_at_once_are_the_windows_one_after_another() {
        for closed in [true, false] {
            for seed in 1..=10u64 {
                let (index, _) = placements(closed, 60, seed);
                let len0 = index.road(RoadId(0)).expect("indexed road").length_m;
                let mut rng = Lcg(seed * 31);
                for _ in 0..40 {
                    // Up to three windows, lanes in any order (one past the road's lanes too),
                    // near the ends as well, so some reach onto the next road.
                    let s = rng.next() * len0;
                    let exclude = (rng.next() < 0.5).then_some(Entity::PLACEHOLDER);
                    let windows: Vec<(u32, f64)> = (0..1 + (rng.next() * 3.0) as usize)
                        .map(|_| ((rng.next() * 4.0) as u32, rng.next() * 120.0))
                        .collect();
                    let mut want = Vec::new();
                    let mut ends = Vec::new();
                    for &(lane, range) in &windows {
                        index.within(RoadId(0), lane, s, range, range, exclude, &mut want);
                        ends.push(want.len());
                    }
                    let mut got = Vec::new();
                    index.visit_lanes(RoadId(0), &windows, s, exclude, |k, seen| {
                        got.push((k, seen));
                    });
                    let which: Vec<usize> = (0..want.len())
                        .map(|i| ends.iter().position(|&end| i < end).expect("a window"))
                        .collect();
                    assert_eq!(
                        got,
                        which.into_iter().zip(want).collect::<Vec<_>>(),
                        "closed {closed} seed {seed} s {s} windows {windows:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn a_window_said_to_be_apart_holds_no_vehicle_nearer_sideways() {
        // Cars wandering about their lanes' centres on a ring and on a three-lane road leading
        // onto a one-lane road (whose cars are at other offsets); windows from random places,
        // some reaching past the road's end.
        let apart = 2.1f32;
        let (mut skipped, mut walked_empty) = (0, 0);
        for closed in [true, false] {
            let network = RoadNetwork::build(&ring_or_road_on(closed, 1)).expect("valid roads");
            for seed in 1..=20u64 {
                let mut rng = Lcg(seed);
                let mut world = World::new();
                // Most lanes keep to their centres; on some seeds one car is half across.
                let tracks: Vec<(Entity, RoadTrack)> = (0..40)
                    .map(|i| {
                        let road = RoadId(u32::from(!closed && i % 4 == 3));
                        let g = network.get(road).expect("road");
                        let s = rng.next() * g.length_m();
                        let lane = (rng.next() * f64::from(g.lanes())) as u32;
                        let centre =
                            flockway_road::lane_offset(g.frame_at(s).width_m, g.lanes(), lane);
                        let wander = if i == 0 && seed % 3 == 0 { 1.6 } else { 0.5 };
                        let lateral = centre + (rng.next() - 0.5) * 2.0 * wander;
                        (
                            world.spawn_empty().id(),
                            RoadTrack::new(road, g, s, lateral),
                        )
                    })
                    .collect();
                let mut index = LaneIndex::default();
                index.rebuild(&network, tracks.iter().map(|(e, t)| (*e, t, 4.6, 0)));
                let length = network.get(RoadId(0)).expect("road").length_m();
                for _ in 0..60 {
                    let lane = (rng.next() * 3.0) as u32;
                    let s = rng.next() * length;
                    let (behind, ahead) = (rng.next() * 20.0, rng.next() * 80.0);
                    let me = flockway_road::lane_offset(10.5, 3, (rng.next() * 3.0) as u32) as f32
                        + (rng.next() as f32 - 0.5);
                    let mut nearest = f32::INFINITY;
                    index.visit_within(RoadId(0), lane, s, behind, ahead, None, |v| {
                        nearest = nearest.min((v.entry.lateral_m - me).abs());
                    });
                    if index.window_apart(RoadId(0), lane, s, behind, ahead, me, apart) {
                        assert!(nearest >= apart, "closed {closed} seed {seed}: {nearest}");
                        skipped += 1;
                    } else if nearest >= apart {
                        walked_empty += 1;
                    }
                }
            }
        }
        // Most windows into another lane are skipped; some are walked, past an end or with a
        // car half across.
        assert!(skipped > 800, "{skipped} windows skipped");
        assert!(
            walked_empty > 20,
            "{walked_empty} windows walked for nothing"
        );
    }

    #[test]
    fn leader_follows_the_loop_and_the_connection() {
        let (index, _) = placements(true, 0, 1);
        assert!(index.is_empty());
        let (index, all) = placements(false, 200, 3);
        // From near the end of road a, the leader may be on road b.
        let len0 = index.road(RoadId(0)).expect("indexed road").length_m;
        let lane0_last = index
            .lane(RoadId(0), 0)
            .last()
            .map(|e| e.s_m)
            .unwrap_or(0.0);
        if let Some(l) = index.leader(
            RoadId(0),
            0,
            lane0_last + 0.001,
            Entity::PLACEHOLDER,
            500.0,
            None,
        ) {
            assert!(l.gap_m > 0.0);
            assert!(l.gap_m >= len0 - lane0_last - 1e-9, "{:?}", l);
            assert!(
                all.iter()
                    .any(|(r, _, e)| *r == RoadId(1) && e.entity == l.entry.entity)
            );
        }
    }
    #[test]
    fn a_leader_is_found_across_a_split_on_the_route_not_on_the_other_branch() {
        let (approach, south, north) = (RoadId(0), RoadId(1), RoadId(2));
        let (_, index, cars) = split_with(&[
            (approach, 1, 880.0, 20.0),
            (south, 0, 10.0, 20.0),
            (north, 0, 30.0, 20.0),
            (north, 1, 5.0, 20.0),
        ]);
        let me = cars[0].0;
        // Lane 1 leads onto north lane 0: the car there, 50 m on, not the nearer one on south.
        let l = index
            .leader(approach, 1, 880.0, me, 200.0, Some(north))
            .expect("a leader on north");
        assert_eq!(l.entry.entity, cars[2].0);
        assert!((l.gap_m - 50.0).abs() < 0.5, "{l:?}");
        // Lane 0 leads only onto south, whatever road is preferred.
        let l = index
            .leader(approach, 0, 880.0, me, 200.0, Some(north))
            .expect("a leader on south");
        assert_eq!(l.entry.entity, cars[1].0);
        // Lane 2 leads onto north lane 1.
        let l = index
            .leader(approach, 2, 880.0, me, 200.0, Some(north))
            .expect("a leader on north lane 1");
        assert_eq!(l.entry.entity, cars[3].0);
        // Out of range: nobody.
        assert!(
            index
                .leader(approach, 1, 880.0, me, 40.0, Some(north))
                .is_none()
        );
    }

    #[test]
    fn a_follower_is_found_back_through_the_lane_that_leads_in() {
        let (approach, south, north) = (RoadId(0), RoadId(1), RoadId(2));
        let (_, index, cars) = split_with(&[
            (north, 0, 5.0, 20.0),
            (approach, 1, 870.0, 20.0),
            (approach, 0, 895.0, 20.0),
            (approach, 2, 890.0, 20.0),
        ]);
        // North lane 0 is reached from approach lane 1 only.
        let f = index
            .follower(north, 0, 5.0, cars[0].0, 100.0)
            .expect("a follower on approach lane 1");
        assert_eq!(f.entry.entity, cars[1].0);
        assert!((f.gap_m + 35.0).abs() < 0.5, "{f:?}");
        // South lane 0 from approach lane 0; north lane 1 from approach lane 2.
        let f = index.follower(south, 0, 0.0, Entity::PLACEHOLDER, 100.0);
        assert_eq!(f.map(|f| f.entry.entity), Some(cars[2].0));
        let f = index.follower(north, 1, 0.0, Entity::PLACEHOLDER, 100.0);
        assert_eq!(f.map(|f| f.entry.entity), Some(cars[3].0));
    }

    #[test]
    fn in_a_junction_a_car_merging_into_the_same_lane_is_in_front_once_the_paths_meet() {
        use flockway_road::{ConnectionSpec, Control, JunctionSpec, RoadSpec};
        use glam::DVec3;
        // `w` from the west and `s` from the south both lead onto `e`, east of the junction.
        let w = RoadSpec::through(
            "w",
            1,
            50.0,
            &[DVec3::new(-100.0, 0.0, 0.0), DVec3::new(-10.0, 0.0, 0.0)],
        );
        let s = RoadSpec::through(
            "s",
            1,
            50.0,
            &[DVec3::new(10.0, -100.0, 0.0), DVec3::new(10.0, -10.0, 0.0)],
        );
        let e = RoadSpec::through(
            "e",
            1,
            50.0,
            &[DVec3::new(10.0, 0.0, 0.0), DVec3::new(100.0, 0.0, 0.0)],
        );
        let to_e = |from: &str| ConnectionSpec {
            from: from.into(),
            from_lane: 0,
            to: "e".into(),
            to_lane: 0,
        };
        let junction = JunctionSpec {
            name: "j".into(),
            control: Control::Priority {
                major: vec!["w".into()],
                stop: false,
            },
            connections: vec![to_e("w"), to_e("s")],
            signal: None,
        };
        let build = || {
            RoadNetwork::build_with(
                &[w.clone(), s.clone(), e.clone()],
                std::slice::from_ref(&junction),
            )
            .expect("a junction")
        };
        let network = build();
        let (straight, turn) = (
            network.id("j#0").expect("straight"),
            network.id("j#1").expect("turn"),
        );
        let length = |r: RoadId| network.get(r).expect("a path").length_m();
        let (l_straight, l_turn) = (length(straight), length(turn));
        let merge = network.junctions()[0].paths[1]
            .conflicts
            .iter()
            .find(|c| c.merge)
            .copied()
            .expect("they merge");
        // The turning car 1 m short of its path's end; the straight car 3 m into its own.
        let (_, index, cars) = crate::perception::fixtures::index_over(
            network,
            &[(turn, 0, l_turn - 1.0, 3.0), (straight, 0, 3.0, 8.0)],
        );
        let (turning, _) = cars[0];
        let (me, track) = &cars[1];
        let ahead = index
            .leader(straight, 0, track.s_m, *me, 50.0, None)
            .expect("the merged car");
        assert_eq!(ahead.entry.entity, turning);
        // As far ahead as it is nearer the common end.
        let gap = (l_straight - 1.0) - 3.0;
        assert!((ahead.gap_m - gap).abs() < 1e-9, "{} vs {gap}", ahead.gap_m);
        // Short of where the paths meet it is not in the lane yet.
        let (_, index, cars) = crate::perception::fixtures::index_over(
            build(),
            &[(turn, 0, merge.at_m - 1.0, 3.0), (straight, 0, 0.5, 8.0)],
        );
        let (me, track) = &cars[1];
        assert!(
            index
                .leader(straight, 0, track.s_m, *me, 50.0, None)
                .is_none_or(|l| l.entry.entity != cars[0].0)
        );
    }

    #[test]
    fn in_a_junction_a_car_on_a_path_from_the_same_lane_is_in_front_while_they_overlap() {
        use flockway_road::{ConnectionSpec, Control, JunctionSpec, RoadSpec};
        use glam::DVec3;
        // `a` ends 16 m before `b` starts; `c` starts 8 m to the left of the gap, heading north.
        let a = RoadSpec::through("a", 1, 50.0, &[DVec3::ZERO, DVec3::new(100.0, 0.0, 0.0)]);
        let b = RoadSpec::through(
            "b",
            1,
            50.0,
            &[DVec3::new(116.0, 0.0, 0.0), DVec3::new(200.0, 0.0, 0.0)],
        );
        let c = RoadSpec::through(
            "c",
            1,
            50.0,
            &[DVec3::new(108.0, 8.0, 0.0), DVec3::new(108.0, 100.0, 0.0)],
        );
        let to = |to: &str| ConnectionSpec {
            from: "a".into(),
            from_lane: 0,
            to: to.into(),
            to_lane: 0,
        };
        let junction = JunctionSpec {
            name: "j".into(),
            control: Control::RightBeforeLeft,
            connections: vec![to("b"), to("c")],
            signal: None,
        };
        let build = || {
            RoadNetwork::build_with(
                &[a.clone(), b.clone(), c.clone()],
                std::slice::from_ref(&junction),
            )
            .expect("a junction")
        };
        let network = build();
        let (a, straight, left) = (
            RoadId(0),
            network.id("j#0").expect("straight"),
            network.id("j#1").expect("left"),
        );
        // A car turning left 2 m into the junction, one going straight behind it: on its own
        // path the straight car has nobody ahead, but the turning car is in front of it.
        let (_, index, cars) = crate::perception::fixtures::index_over(
            network,
            &[(left, 0, 2.0, 3.0), (a, 0, 95.0, 10.0)],
        );
        let (turning, _) = cars[0];
        let (me, track) = &cars[1];
        let ahead = index
            .leader(a, 0, track.s_m, *me, 50.0, Some(straight))
            .expect("the turning car");
        assert_eq!(ahead.entry.entity, turning);
        assert!((ahead.gap_m - 7.0).abs() < 1e-9, "{}", ahead.gap_m);
        let mut seen = Vec::new();
        index.within(a, 0, track.s_m, 0.0, 20.0, Some(*me), &mut seen);
        assert_eq!(
            seen.iter().map(|s| s.entry.entity).collect::<Vec<_>>(),
            vec![turning]
        );
        // Once the paths have parted the turning car is no longer in the way.
        let (_, index, cars) = crate::perception::fixtures::index_over(
            build(),
            &[(left, 0, 12.0, 3.0), (a, 0, 95.0, 10.0)],
        );
        let (me, track) = &cars[1];
        assert!(
            index
                .leader(a, 0, track.s_m, *me, 50.0, Some(straight))
                .is_none()
        );
    }
}
