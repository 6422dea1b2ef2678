//! Surrogate safety measures: the near misses traffic engineers count instead of crashes (after
//! FHWA's Surrogate Safety Assessment Model, SSAM, Gettman & Head 2003, and SUMO's SSM device).
//!
//! - **Time to collision** (TTC, Hayward 1972): for a vehicle closing on the one ahead of its
//!   body, bumper gap over closing speed — how long until they touch if neither changes speed.
//! - **Deceleration rate to avoid a crash** (DRAC, Almqvist et al. 1991): the closing speed
//!   squared over twice the gap — the braking that would just match the speed ahead in the room
//!   left.
//! - **Post-encroachment time** (PET, Allen et al. 1978): at a junction, where two paths cross,
//!   the time from one vehicle's body leaving the conflict area to the next one's, on the
//!   crossing path, entering it.
//!
//! A follower–leader pair is in a *conflict episode* while its TTC is below
//! [`SsmThresholds::ttc_s`] or its DRAC above [`SsmThresholds::drac_mps2`]; the episode ends
//! once the pair has been out of conflict for [`EPISODE_END_S`] (or either vehicle is gone) and
//! is reported once, with its worst TTC and DRAC, where and when its TTC was lowest. A PET below
//! [`SsmThresholds::pet_s`] is a conflict at the moment the second vehicle enters.
//!
//! Measured each tick in `StepSet::Sense`, once perception is done, on what the drivers see (the lane index of perception
//! and the places it was built from), for every vehicle: the one ahead of its body is found as
//! the safety layer finds it ([`nearest_ahead`]).

use crate::VehicleId;
use bevy_ecs::prelude::*;
use bevy_ecs::query::QueryItem;
use flockway_core::{SimClock, for_each_car};
use flockway_drivers::{
    Ahead, AheadMemo, DriverLabel, LaneIndex, LaneSignal, SafetyParams, SafetyView, nearest_ahead,
};
use flockway_road::{RoadId, RoadNetwork};
use flockway_vehicle::{Motion, PARALLEL_MIN_VEHICLES, RoadTrack, VehicleModel};
use glam::Vec3;
use std::collections::BTreeMap;
use std::sync::Arc;

/// A pair stays in one episode through breaks in its conflict shorter than this, s (a TTC
/// hovering about the threshold is one near miss, not many).
pub const EPISODE_END_S: f64 = 1.0;

/// The thresholds of the conflict measures (a level's `ssm`).
#[derive(Resource, Debug, Clone, Copy, PartialEq)]
pub struct SsmThresholds {
    /// A TTC below this is a conflict, s.
    pub ttc_s: f64,
    /// A PET below this is a conflict, s.
    pub pet_s: f64,
    /// A DRAC above this is a conflict, m/s².
    pub drac_mps2: f64,
}

impl Default for SsmThresholds {
    /// TTC 1.5 s (SSAM's default), PET 1.0 s, DRAC 3.0 m/s² (SUMO's SSM default).
    fn default() -> Self {
        SsmThresholds {
            ttc_s: 1.5,
            pet_s: 1.0,
            drac_mps2: 3.0,
        }
    }
}

/// What a conflict was found by.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ConflictKind {
    /// A follower–leader episode whose TTC fell below the threshold.
    Ttc,
    /// A follower–leader episode whose DRAC rose above the threshold (its TTC never below).
    Drac,
    /// Two vehicles through a junction's crossing conflict less than the PET threshold apart.
    Pet,
}

impl ConflictKind {
    /// Its name in the conflicts CSV: `ttc`, `drac` or `pet`.
    pub fn name(self) -> &'static str {
        match self {
            ConflictKind::Ttc => "ttc",
            ConflictKind::Drac => "drac",
            ConflictKind::Pet => "pet",
        }
    }
}

/// One conflict, as the conflicts CSV reports it.
#[derive(Debug, Clone, PartialEq)]
pub struct ConflictRecord {
    /// When: the lowest TTC of an episode, or the second vehicle's entry for a PET, s.
    pub time_s: f64,
    /// What found it.
    pub kind: ConflictKind,
    /// The follower, or the vehicle that entered second.
    pub vehicle: u32,
    /// The leader, or the vehicle that left first.
    pub other: u32,
    /// `vehicle`'s driver profile.
    pub driver: Arc<str>,
    /// `other`'s driver profile.
    pub other_driver: Arc<str>,
    /// The road `vehicle` was on.
    pub road: RoadId,
    /// The junction, when `vehicle` was on one of its paths.
    pub junction: Option<usize>,
    /// The episode's lowest TTC, s (`None` for a PET, or when it never closed in).
    pub min_ttc_s: Option<f64>,
    /// The PET, s.
    pub pet_s: Option<f64>,
    /// The episode's highest DRAC, m/s².
    pub max_drac_mps2: Option<f64>,
    /// `vehicle`'s position then, m.
    pub position: Vec3,
}

/// Conflict totals: of one driver profile's vehicles, or of the run.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ProfileConflicts {
    /// Finished follower–leader episodes (by TTC, DRAC or both).
    pub episodes: u64,
    /// Episodes with a TTC below the threshold.
    pub ttc: u64,
    /// Episodes with a DRAC above the threshold.
    pub drac: u64,
    /// PET conflicts.
    pub pet: u64,
    /// Lowest TTC of a pair closing in, s.
    pub min_ttc_s: Option<f64>,
    /// Highest DRAC of a pair, m/s².
    pub max_drac_mps2: Option<f64>,
    /// Distance its vehicles drove, km.
    pub veh_km: f64,
}

impl ProfileConflicts {
    /// Notes one observation's TTC and DRAC in the extremes.
    fn note(&mut self, ttc: Option<f64>, drac: Option<f64>) {
        if let Some(x) = ttc {
            self.min_ttc_s = Some(self.min_ttc_s.map_or(x, |m| m.min(x)));
        }
        if let Some(x) = drac {
            self.max_drac_mps2 = Some(self.max_drac_mps2.map_or(x, |m| m.max(x)));
        }
    }
}

/// The profiles a conflict between vehicles of profiles `a` and `b` counts for: each once.
fn involved<'a>(a: &'a Arc<str>, b: &'a Arc<str>) -> impl Iterator<Item = &'a str> {
    // Vehicles of one profile share its name: told apart by address before by their bytes.
    let other = !Arc::ptr_eq(a, b) && a != b;
    std::iter::once(&**a).chain(other.then_some(&**b))
}

/// The TTC of a follower at speed `v` closing on a leader at `v_lead` with bumper gap `gap_m`,
/// s; `None` unless it closes in.
pub fn ttc_s(gap_m: f64, v: f64, v_lead: f64) -> Option<f64> {
    let closing = v - v_lead;
    (closing > 0.0).then(|| gap_m.max(0.0) / closing)
}

/// The DRAC of the same follower, m/s²; `None` unless it closes in.
pub fn drac_mps2(gap_m: f64, v: f64, v_lead: f64) -> Option<f64> {
    let closing = v - v_lead;
    (closing > 0.0).then(|| closing * closing / (2.0 * gap_m.max(0.01)))
}

/// One observation of a follower behind its leader (the drivers' profiles borrowed: this is
/// made for every closing pair every tick).
#[derive(Debug, Clone, PartialEq)]
pub struct PairObservation<'a> {
    /// The follower.
    pub vehicle: Entity,
    /// The vehicle ahead of its body.
    pub leader: Entity,
    /// The follower's id and profile.
    pub who: (u32, &'a Arc<str>),
    /// The leader's id and profile.
    pub other: (u32, &'a Arc<str>),
    /// Bumper gap, m.
    pub gap_m: f64,
    /// Follower's speed, m/s.
    pub speed_mps: f64,
    /// Leader's speed, m/s.
    pub leader_mps: f64,
    /// Where the follower is: its road, junction and position.
    pub place: (RoadId, Option<usize>, Vec3),
}

/// An open follower–leader episode.
#[derive(Debug, Clone, PartialEq)]
struct Episode {
    record: ConflictRecord,
    last_in_conflict_s: f64,
}

/// A vehicle in a junction's conflict area: (junction, its path, the crossing path).
type ZoneKey = (usize, usize, usize);

/// A vehicle's id and driver profile.
pub type Who = (u32, Arc<str>);

/// A crossing conflict area along a junction path: the crossing path, and where along this
/// path the area starts and ends (centre positions), m.
pub type ConflictArea = (usize, f64, f64);

/// Where a vehicle is on a junction path.
#[derive(Debug, Clone, Copy)]
pub struct OnPath<'a> {
    /// The junction, by index.
    pub junction: usize,
    /// Its path, by index.
    pub path: usize,
    /// Its centre's arc position along the path, m.
    pub s_m: f64,
    /// The path's crossing conflict areas.
    pub areas: &'a [ConflictArea],
}

/// The last vehicle to leave one side of a conflict area.
#[derive(Debug, Clone, PartialEq)]
struct Exit {
    vehicle: Entity,
    who: Who,
    time_s: f64,
}

/// The conflicts of a run: open episodes, finished records waiting to be written, totals.
#[derive(Resource, Debug, Default)]
pub struct Conflicts {
    episodes: BTreeMap<(Entity, Entity), Episode>,
    /// Conflict areas each vehicle is in now, with its id and profile.
    inside: BTreeMap<Entity, (Who, Vec<ZoneKey>)>,
    /// The last exit from each side of each conflict area.
    exits: BTreeMap<ZoneKey, Exit>,
    /// Records of finished conflicts not yet taken by [`Conflicts::take_finished`].
    finished: Vec<ConflictRecord>,
    /// Totals by driver profile: the conflicts a vehicle of the profile took part in (either
    /// vehicle of a pair; once for a pair of two of its vehicles), and the distance its
    /// vehicles drove.
    pub by_profile: BTreeMap<String, ProfileConflicts>,
    /// The run's totals, each conflict once.
    pub total: ProfileConflicts,
    /// PET conflicts by junction index.
    pub pet_by_junction: BTreeMap<usize, u64>,
}

impl Conflicts {
    /// Records one tick's observation of a follower closing on (or keeping behind) its leader.
    pub fn observe_pair(&mut self, t: &SsmThresholds, time_s: f64, o: PairObservation) {
        let mut extremes = Extremes::default();
        self.observe_pair_noting(t, time_s, &o, &mut extremes);
        extremes.write_to(self);
    }

    /// [`observe_pair`](Self::observe_pair) with the profiles' extremes noted in `extremes`,
    /// which the caller writes to the totals once its pass is done.
    fn observe_pair_noting<'a>(
        &mut self,
        t: &SsmThresholds,
        time_s: f64,
        o: &PairObservation<'a>,
        extremes: &mut Extremes<'a>,
    ) {
        let ttc = ttc_s(o.gap_m, o.speed_mps, o.leader_mps);
        let drac = drac_mps2(o.gap_m, o.speed_mps, o.leader_mps);
        if ttc.is_none() && drac.is_none() {
            // Not closing in: nothing to note.
            return;
        }
        for profile in involved(o.who.1, o.other.1) {
            extremes.slot(self, profile).note(ttc, drac);
        }
        self.total.note(ttc, drac);
        let in_conflict = ttc.is_some_and(|x| x < t.ttc_s) || drac.is_some_and(|x| x > t.drac_mps2);
        let key = (o.vehicle, o.leader);
        if !in_conflict {
            return;
        }
        let episode = self.episodes.entry(key).or_insert_with(|| Episode {
            record: ConflictRecord {
                time_s,
                kind: ConflictKind::Drac,
                vehicle: o.who.0,
                other: o.other.0,
                driver: o.who.1.clone(),
                other_driver: o.other.1.clone(),
                road: o.place.0,
                junction: o.place.1,
                min_ttc_s: None,
                pet_s: None,
                max_drac_mps2: None,
                position: o.place.2,
            },
            last_in_conflict_s: time_s,
        });
        episode.last_in_conflict_s = time_s;
        let r = &mut episode.record;
        if let Some(x) = ttc
            && r.min_ttc_s.is_none_or(|m| x < m)
        {
            r.min_ttc_s = Some(x);
            r.time_s = time_s;
            r.road = o.place.0;
            r.junction = o.place.1;
            r.position = o.place.2;
        }
        if let Some(x) = drac {
            r.max_drac_mps2 = Some(r.max_drac_mps2.map_or(x, |m| m.max(x)));
        }
    }

    /// Closes the episodes out of conflict for [`EPISODE_END_S`] by `time_s`, or of a vehicle
    /// not in `alive` (all of them with `alive` `None`: the run's end).
    pub fn close_episodes(
        &mut self,
        t: &SsmThresholds,
        time_s: f64,
        alive: Option<&dyn Fn(Entity) -> bool>,
    ) {
        let done: Vec<(Entity, Entity)> = self
            .episodes
            .iter()
            .filter(|((a, b), e)| match alive {
                Some(alive) => {
                    time_s - e.last_in_conflict_s >= EPISODE_END_S - 1.0e-9
                        || !alive(*a)
                        || !alive(*b)
                }
                None => true,
            })
            .map(|(k, _)| *k)
            .collect();
        for key in done {
            if let Some(e) = self.episodes.remove(&key) {
                let mut r = e.record;
                let by_ttc = r.min_ttc_s.is_some_and(|x| x < t.ttc_s);
                let by_drac = r.max_drac_mps2.is_some_and(|x| x > t.drac_mps2);
                if by_ttc {
                    r.kind = ConflictKind::Ttc;
                }
                let count = |p: &mut ProfileConflicts| {
                    p.episodes += 1;
                    p.ttc += u64::from(by_ttc);
                    p.drac += u64::from(by_drac);
                };
                for profile in involved(&r.driver, &r.other_driver) {
                    count(self.profile_mut(profile));
                }
                count(&mut self.total);
                self.finished.push(r);
            }
        }
    }

    /// Where a vehicle is on a junction path this tick (`None`: on none). A vehicle entering a
    /// conflict area the crossing side left less than [`SsmThresholds::pet_s`] before (or still
    /// holds) is a PET conflict.
    pub fn observe_junction(
        &mut self,
        t: &SsmThresholds,
        time_s: f64,
        vehicle: Entity,
        who: &Who,
        at: Option<OnPath>,
        place: (RoadId, Vec3),
    ) {
        let was: Vec<ZoneKey> = self
            .inside
            .remove(&vehicle)
            .map(|(_, keys)| keys)
            .unwrap_or_default();
        let mut now: Vec<ZoneKey> = Vec::new();
        if let Some(at) = at {
            for &(other, from, to) in at.areas {
                if at.s_m >= from && at.s_m <= to {
                    now.push((at.junction, at.path, other));
                }
            }
        }
        for key in &was {
            if !now.contains(key) {
                self.exits.insert(
                    *key,
                    Exit {
                        vehicle,
                        who: who.clone(),
                        time_s,
                    },
                );
            }
        }
        for &(j, path, other) in &now {
            if was.contains(&(j, path, other)) {
                continue;
            }
            // Still inside on the crossing side: they are in the area together.
            let occupied = self
                .inside
                .iter()
                .find(|(e, (_, keys))| **e != vehicle && keys.contains(&(j, other, path)))
                .map(|(_, (w, _))| (w.clone(), 0.0));
            let before = occupied.or_else(|| {
                self.exits
                    .get(&(j, other, path))
                    .filter(|x| x.vehicle != vehicle)
                    .map(|x| (x.who.clone(), time_s - x.time_s))
            });
            let Some((first_who, pet)) = before else {
                continue;
            };
            if pet >= t.pet_s {
                continue;
            }
            *self.pet_by_junction.entry(j).or_default() += 1;
            for profile in involved(&who.1, &first_who.1) {
                self.profile_mut(profile).pet += 1;
            }
            self.total.pet += 1;
            self.finished.push(ConflictRecord {
                time_s,
                kind: ConflictKind::Pet,
                vehicle: who.0,
                other: first_who.0,
                driver: who.1.clone(),
                other_driver: first_who.1,
                road: place.0,
                junction: Some(j),
                min_ttc_s: None,
                pet_s: Some(pet),
                max_drac_mps2: None,
                position: place.1,
            });
        }
        if !now.is_empty() {
            self.inside.insert(vehicle, (who.clone(), now));
        }
    }

    /// Adds distance driven by a vehicle of `profile`, m.
    pub fn add_distance(&mut self, profile: &str, metres: f64) {
        self.profile_mut(profile).veh_km += metres / 1000.0;
        self.total.veh_km += metres / 1000.0;
    }

    /// [`add_distance`](Self::add_distance) for each `(profile, metres)` in turn, with the same
    /// sums to the bit, but looking each profile's totals up once, not once per vehicle: a
    /// vehicle's profile is matched by address first (vehicles of one profile share its name).
    pub fn add_distances<'a>(&mut self, trips: impl IntoIterator<Item = (&'a str, f64)>) {
        let mut distances = Distances::default();
        for (profile, metres) in trips {
            distances.add(self, profile, metres);
        }
        distances.write_to(self);
    }

    /// The totals of `profile`, created empty the first time (looked up without allocating
    /// after that: this runs for every vehicle every step).
    fn profile_mut(&mut self, profile: &str) -> &mut ProfileConflicts {
        if !self.by_profile.contains_key(profile) {
            self.by_profile
                .insert(profile.to_owned(), ProfileConflicts::default());
        }
        self.by_profile.get_mut(profile).expect("inserted above")
    }

    /// The finished conflicts not taken yet, oldest first.
    pub fn take_finished(&mut self) -> Vec<ConflictRecord> {
        std::mem::take(&mut self.finished)
    }
}

/// A value per driver profile over one pass of the measures, kept aside from the totals' map:
/// a vehicle's profile is matched by address first (vehicles of one profile share its name), so
/// the map is searched once per profile a pass instead of once per vehicle or pair.
#[derive(Debug)]
struct ProfileSlots<'a, T> {
    /// Each profile met, with its value.
    slots: Vec<(&'a str, T)>,
    /// The slot found last, tried first.
    last: usize,
}

impl<T> Default for ProfileSlots<'_, T> {
    fn default() -> Self {
        ProfileSlots {
            slots: Vec::new(),
            last: 0,
        }
    }
}

impl<'a, T> ProfileSlots<'a, T> {
    /// The value of `profile`, made by `init` the first time.
    fn get_or_insert_with(&mut self, profile: &'a str, init: impl FnOnce() -> T) -> &mut T {
        let same = |s: &&str| std::ptr::eq(*s, profile) || *s == profile;
        if !self.slots.get(self.last).is_some_and(|(s, _)| same(s)) {
            self.last = match self.slots.iter().position(|(s, _)| same(s)) {
                Some(k) => k,
                None => {
                    self.slots.push((profile, init()));
                    self.slots.len() - 1
                }
            };
        }
        &mut self.slots[self.last].1
    }
}

/// Each profile's lowest TTC and highest DRAC over one pass of the measures, starting from the
/// totals' own and written back to them when the pass is done. Each extreme takes the same
/// values in the same order as noting them one at a time, so the totals come out the same to
/// the bit.
#[derive(Debug, Default)]
struct Extremes<'a>(ProfileSlots<'a, ProfileConflicts>);

impl<'a> Extremes<'a> {
    /// The extremes of `profile`, taken from `conflicts`' totals the first time.
    fn slot(&mut self, conflicts: &mut Conflicts, profile: &'a str) -> &mut ProfileConflicts {
        self.0
            .get_or_insert_with(profile, || *conflicts.profile_mut(profile))
    }

    /// Writes the extremes to `conflicts`' totals (only the extremes: other code may have
    /// counted episodes or PETs in the same totals meanwhile).
    fn write_to(self, conflicts: &mut Conflicts) {
        for (profile, noted) in self.0.slots {
            let totals = conflicts.profile_mut(profile);
            totals.min_ttc_s = noted.min_ttc_s;
            totals.max_drac_mps2 = noted.max_drac_mps2;
        }
    }
}

/// Each profile's distance driven over one pass of the measures, as
/// [`Conflicts::add_distances`] sums it: starting from the totals' own, the run's total added to
/// as it goes, each profile's written back when the pass is done (the same sums to the bit as
/// adding one vehicle at a time).
#[derive(Debug, Default)]
struct Distances<'a>(ProfileSlots<'a, f64>);

impl<'a> Distances<'a> {
    /// Adds `metres` driven by a vehicle of `profile`.
    fn add(&mut self, conflicts: &mut Conflicts, profile: &'a str, metres: f64) {
        *self
            .0
            .get_or_insert_with(profile, || conflicts.profile_mut(profile).veh_km) +=
            metres / 1000.0;
        conflicts.total.veh_km += metres / 1000.0;
    }

    /// Writes each profile's distance to `conflicts`' totals.
    fn write_to(self, conflicts: &mut Conflicts) {
        for (profile, veh_km) in self.0.slots {
            conflicts.profile_mut(profile).veh_km = veh_km;
        }
    }
}

/// A vehicle's driver profile (`none` without a label).
fn profile_of<'a>(label: Option<&'a DriverLabel>, none: &'a Arc<str>) -> &'a Arc<str> {
    label.map_or(none, |l| &l.profile)
}

/// A vehicle as the measures see it.
type Measured = (
    Entity,
    &'static VehicleId,
    &'static RoadTrack,
    &'static Motion,
    &'static VehicleModel,
    Option<&'static DriverLabel>,
    Option<&'static LaneSignal>,
    (
        Option<&'static mut AheadMemo>,
        Option<&'static SafetyParams>,
        Option<&'static mut ConflictAhead>,
    ),
);

/// The vehicle ahead of a car's body as the conflict measures found it this tick (every
/// vehicle has one: each finds its own in parallel, then the measures read them in order).
#[derive(Component, Debug, Clone, Copy, Default, PartialEq)]
pub struct ConflictAhead(Option<Ahead>);

/// One vehicle of the [`Measured`] query.
type MeasuredItem<'w> = QueryItem<'w, 'w, Measured>;

/// Measures every vehicle's TTC and DRAC behind the vehicle ahead of its body and its passes
/// through junction conflict areas, each tick.
pub fn measure_conflicts(
    network: Res<RoadNetwork>,
    index: Res<LaneIndex>,
    clock: Res<SimClock>,
    thresholds: Option<Res<SsmThresholds>>,
    mut conflicts: ResMut<Conflicts>,
    mut vehicles: Query<Measured>,
    ids: Query<(&VehicleId, Option<&DriverLabel>)>,
) {
    let t = thresholds.map(|t| *t).unwrap_or_default();
    let time_s = clock.seconds();
    let tick = clock.tick();
    let h = clock.dt_s();
    let none: Arc<str> = Arc::from("none");
    let label = |l: Option<&DriverLabel>| l.map_or_else(|| none.clone(), |l| l.profile.clone());
    // Far enough to see every pair the thresholds can flag.
    let reach_of = |motion: &Motion| {
        let v = f64::from(motion.forward_mps);
        (t.ttc_s * v).max(v * v / (2.0 * t.drac_mps2.max(0.1))) as f32 + 5.0
    };
    // The search for the vehicle ahead of each body reads only the shared index and network,
    // and each car keeps its own answer: over the task pool from a threshold. It reaches as
    // far as the car's safety layer will look too and is kept in the car's memo, which the
    // safety layer then reads its answer off instead of searching again.
    let search = |_: &mut (), item: MeasuredItem| {
        let (me, _, track, motion, model, _, signal, (memo, safety, found)) = item;
        let Some(mut found) = found else {
            return;
        };
        let view = SafetyView::new(me, track, motion, model, signal);
        let reach = reach_of(motion);
        let narrowed = memo.and_then(|mut memo| {
            let safety_reach = safety.copied().unwrap_or_default().reach_m(view.speed_mps);
            let wide = reach.max(safety_reach);
            memo.search(&network, &index, &view, wide, tick);
            memo.narrowed(&view, reach)
        });
        found.0 = narrowed.unwrap_or_else(|| nearest_ahead(&network, &index, &view, reach));
    };
    for_each_car(&mut vehicles, PARALLEL_MIN_VEHICLES, || (), search);
    // The distances driven, summed as `add_distances` sums them in the same pass as the pairs
    // and areas: nothing else in the pass reads or writes a distance.
    let mut distances = Distances::default();
    let mut extremes = Extremes::default();
    for (me, id, track, motion, model, driver, signal, (_, _, found)) in vehicles.iter() {
        let metres = f64::from(motion.forward_mps).abs() * h;
        distances.add(
            &mut conflicts,
            driver.map_or("none", |l| &*l.profile),
            metres,
        );
        // A vehicle without its own answer (spawned before the measures were added) is
        // searched for here.
        let ahead = found.map_or_else(
            || {
                let view = SafetyView::new(me, track, motion, model, signal);
                nearest_ahead(&network, &index, &view, reach_of(motion))
            },
            |f| f.0,
        );
        let v = f64::from(motion.forward_mps);
        let junction = network.junction_path(track.road);
        if let Some(ahead) = ahead
            && ahead.entity != me
            && v > f64::from(ahead.speed_mps)
            && let Ok((other_id, other_label)) = ids.get(ahead.entity)
        {
            let observed = PairObservation {
                vehicle: me,
                leader: ahead.entity,
                who: (id.0, profile_of(driver, &none)),
                other: (other_id.0, profile_of(other_label, &none)),
                gap_m: f64::from(ahead.gap_m),
                speed_mps: v,
                leader_mps: f64::from(ahead.speed_mps),
                place: (track.road, junction.map(|(j, _)| j), motion.position),
            };
            conflicts.observe_pair_noting(&t, time_s, &observed, &mut extremes);
        }
        // Off junctions, only a vehicle just leaving a conflict area has anything to record.
        if junction.is_none() && !conflicts.inside.contains_key(&me) {
            continue;
        }
        let areas: Vec<ConflictArea> = junction
            .and_then(|(j, k)| network.junctions().get(j)?.paths.get(k))
            .map(|p| {
                p.conflicts
                    .iter()
                    .filter(|c| !c.merge)
                    .map(|c| (c.other, c.at_m, c.clear_m))
                    .collect()
            })
            .unwrap_or_default();
        conflicts.observe_junction(
            &t,
            time_s,
            me,
            &(id.0, label(driver)),
            junction.map(|(junction, path)| OnPath {
                junction,
                path,
                s_m: track.s_m,
                areas: &areas,
            }),
            (track.road, motion.position),
        );
    }
    extremes.write_to(&mut conflicts);
    distances.write_to(&mut conflicts);
    let alive = |e: Entity| vehicles.contains(e);
    conflicts.close_episodes(&t, time_s, Some(&alive));
    // Vehicles gone leave the areas they were in.
    let gone: Vec<Entity> = conflicts
        .inside
        .keys()
        .copied()
        .filter(|e| !vehicles.contains(*e))
        .collect();
    for e in gone {
        conflicts.inside.remove(&e);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const H: f64 = 1.0 / 120.0;

    fn pair(gap: f64, v: f64, vl: f64) -> PairObservation<'static> {
        static HUMAN: std::sync::LazyLock<Arc<str>> =
            std::sync::LazyLock::new(|| Arc::from("human"));
        static AUTO: std::sync::LazyLock<Arc<str>> = std::sync::LazyLock::new(|| Arc::from("auto"));
        PairObservation {
            vehicle: Entity::from_raw_u32(1).expect("an entity"),
            leader: Entity::from_raw_u32(2).expect("an entity"),
            who: (1, &HUMAN),
            other: (2, &AUTO),
            gap_m: gap,
            speed_mps: v,
            leader_mps: vl,
            place: (RoadId(0), None, Vec3::ZERO),
        }
    }

    #[test]
    fn ttc_and_drac_follow_their_definitions() {
        assert_eq!(ttc_s(10.0, 15.0, 10.0), Some(2.0));
        assert_eq!(ttc_s(10.0, 10.0, 15.0), None);
        assert_eq!(drac_mps2(10.0, 15.0, 10.0), Some(1.25));
        assert_eq!(drac_mps2(10.0, 10.0, 10.0), None);
    }

    /// A follower at 10 m/s behind a leader at 5 m/s from 20 m back; when the gap is 5 m the
    /// leader speeds up to 12 m/s: the lowest TTC is 1.0 s, and one episode reports it.
    #[test]
    fn a_scripted_approach_reports_its_lowest_ttc_within_a_step() {
        let t = SsmThresholds::default();
        let mut c = Conflicts::default();
        let (mut gap, mut vl) = (20.0f64, 5.0f64);
        let mut time = 0.0;
        for _ in 0..(20.0 / H) as usize {
            c.observe_pair(&t, time, pair(gap, 10.0, vl));
            c.close_episodes(&t, time, Some(&|_| true));
            if gap <= 5.0 {
                vl = 12.0;
            }
            gap += (vl - 10.0) * H;
            time += H;
        }
        c.close_episodes(&t, time, None);
        let found = c.take_finished();
        assert_eq!(found.len(), 1, "{found:?}");
        let r = &found[0];
        assert_eq!(r.kind, ConflictKind::Ttc);
        let ttc = r.min_ttc_s.expect("a TTC");
        assert!((ttc - 1.0).abs() <= H, "{ttc}");
        // The gap closes at 5 m/s from 20 m: 5 m are reached at 3 s.
        assert!((r.time_s - 3.0).abs() <= H, "{}", r.time_s);
        // DRAC then: 5² / (2·5) = 2.5 m/s², under the threshold.
        assert!((r.max_drac_mps2.expect("a DRAC") - 2.5).abs() < 0.05);
        // It counts for both drivers' profiles, and once in all.
        for totals in [c.by_profile["human"], c.by_profile["auto"], c.total] {
            assert_eq!((totals.episodes, totals.ttc, totals.drac), (1, 1, 0));
        }
    }

    #[test]
    fn distances_added_together_sum_as_one_at_a_time() {
        // Two names of one profile at different addresses, and a third profile, interleaved.
        let human: Arc<str> = Arc::from("human");
        let human_too = String::from("human");
        let trips: Vec<(&str, f64)> = (0..1000)
            .map(|k| {
                let profile = match k % 5 {
                    0 | 1 => &*human,
                    2 => human_too.as_str(),
                    _ => "auto",
                };
                (profile, 0.1 + f64::from(k) * 0.013_7)
            })
            .collect();
        let (mut one, mut all) = (Conflicts::default(), Conflicts::default());
        one.add_distance("auto", 3.3);
        all.add_distance("auto", 3.3);
        for &(profile, metres) in &trips {
            one.add_distance(profile, metres);
        }
        all.add_distances(trips.iter().copied());
        assert_eq!(one.by_profile.len(), 2);
        for (profile, totals) in &one.by_profile {
            assert_eq!(
                totals.veh_km.to_bits(),
                all.by_profile[profile].veh_km.to_bits()
            );
        }
        assert_eq!(one.total.veh_km.to_bits(), all.total.veh_km.to_bits());
    }

    #[test]
    fn extremes_noted_over_a_pass_match_noting_each_pair_alone() {
        // Two names of one profile at different addresses, and a third profile, interleaved;
        // some pairs in conflict (so episodes open), most only closing in.
        let human: Arc<str> = Arc::from("human");
        let human_too: Arc<str> = Arc::from("human");
        let auto: Arc<str> = Arc::from("auto");
        let t = SsmThresholds::default();
        let (mut one, mut all) = (Conflicts::default(), Conflicts::default());
        for tick in 0..50u32 {
            let time = f64::from(tick) * H;
            let mut extremes = Extremes::default();
            for k in 0..40u32 {
                let profile = |j: u32| match (j + tick) % 5 {
                    0 | 1 => &human,
                    2 => &human_too,
                    _ => &auto,
                };
                let o = PairObservation {
                    vehicle: Entity::from_raw_u32(k + 1).expect("an entity"),
                    leader: Entity::from_raw_u32(k + 100).expect("an entity"),
                    who: (k, profile(k)),
                    other: (k + 100, profile(k + 3)),
                    gap_m: 2.0 + f64::from((k * 7 + tick * 3) % 23),
                    speed_mps: 10.0 + f64::from(k % 4),
                    leader_mps: 9.0 + f64::from((k + tick) % 6) * 0.37,
                    place: (RoadId(0), None, Vec3::ZERO),
                };
                one.observe_pair(&t, time, o.clone());
                all.observe_pair_noting(&t, time, &o, &mut extremes);
            }
            extremes.write_to(&mut all);
            one.close_episodes(&t, time, Some(&|_| true));
            all.close_episodes(&t, time, Some(&|_| true));
        }
        one.close_episodes(&t, 1.0, None);
        all.close_episodes(&t, 1.0, None);
        assert_eq!(one.take_finished(), all.take_finished());
        assert_eq!(one.by_profile.len(), 2);
        assert_eq!(one.by_profile, all.by_profile);
        for (profile, totals) in &one.by_profile {
            let bits = |x: Option<f64>| x.map(f64::to_bits);
            let noted = &all.by_profile[profile];
            assert!(totals.min_ttc_s.is_some() && totals.max_drac_mps2.is_some());
            assert_eq!(bits(totals.min_ttc_s), bits(noted.min_ttc_s));
            assert_eq!(bits(totals.max_drac_mps2), bits(noted.max_drac_mps2));
        }
        assert_eq!(one.total, all.total);
        assert!(one.total.episodes > 0, "{:?}", one.total);
    }

    #[test]
    fn a_ttc_hovering_at_the_threshold_is_one_episode() {
        let t = SsmThresholds::default();
        let mut c = Conflicts::default();
        let mut time = 0.0;
        for k in 0..600 {
            // TTC alternates 1.4 s and 1.6 s every 0.25 s.
            let gap = if (k / 30) % 2 == 0 { 7.0 } else { 8.0 };
            c.observe_pair(&t, time, pair(gap, 10.0, 5.0));
            c.close_episodes(&t, time, Some(&|_| true));
            time += H;
        }
        c.close_episodes(&t, time, None);
        assert_eq!(c.take_finished().len(), 1);
    }

    /// One vehicle leaves a crossing's conflict area at 10 s; another enters it from the
    /// crossing path at 10.5 s: a PET of 0.5 s.
    #[test]
    fn a_scripted_crossing_reports_its_pet_within_a_step() {
        let t = SsmThresholds::default();
        let mut c = Conflicts::default();
        let a = Entity::from_raw_u32(1).expect("an entity");
        let b = Entity::from_raw_u32(2).expect("an entity");
        let who_a = (1, Arc::<str>::from("auto"));
        let who_b = (2, Arc::<str>::from("human"));
        // Path 0 crosses path 1 over [10, 16] m along 0 and [4, 12] m along 1.
        let area0 = [(1usize, 10.0, 16.0)];
        let area1 = [(0usize, 4.0, 12.0)];
        let place = (RoadId(3), Vec3::ZERO);
        for k in 0..(15.0 / H) as usize {
            let now = k as f64 * H;
            // a at 10 m/s, past 16 m (out of the area) at 10 s.
            let sa = 10.0 * (now - 8.4);
            let on = |path, s_m, areas| OnPath {
                junction: 0,
                path,
                s_m,
                areas,
            };
            c.observe_junction(&t, now, a, &who_a, Some(on(0, sa, &area0)), place);
            // b at 8 m/s reaching 4 m at 10.5 s.
            let sb = 4.0 + 8.0 * (now - 10.5);
            c.observe_junction(&t, now, b, &who_b, Some(on(1, sb, &area1)), place);
        }
        let found = c.take_finished();
        assert_eq!(found.len(), 1, "{found:?}");
        let r = &found[0];
        assert_eq!(r.kind, ConflictKind::Pet);
        assert_eq!((r.vehicle, r.other), (2, 1));
        let pet = r.pet_s.expect("a PET");
        assert!((pet - 0.5).abs() <= H + 1.0e-9, "{pet}");
        assert_eq!(c.pet_by_junction[&0], 1);
        assert_eq!(c.by_profile["human"].pet, 1);
        assert_eq!(c.by_profile["auto"].pet, 1);
        assert_eq!(c.total.pet, 1);
    }
}
