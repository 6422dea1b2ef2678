//! What every signal shows, tick by tick. A signalised junction runs its level's fixed-time
//! program by the clock until a controller — a script, an environment's agent — takes it over:
//! by switching phase, running a program of its own, or holding a state it sets (with an amber
//! first, when asked, for every movement that loses its green).

use bevy_ecs::prelude::*;
use flockway_core::SimClock;
use flockway_road::{
    JunctionError, RoadNetwork, SignalProgram, SignalState, check_program, check_state,
};

/// Two times closer than this are the same instant, s (phase ends fall on ticks).
const SAME_INSTANT_S: f64 = 1e-6;

/// How a signalised junction is being run.
#[derive(Debug, Clone, PartialEq)]
pub enum SignalMode {
    /// The level's program by the clock, shifted by its offset: what a level does on its own.
    Plan,
    /// The program running from phase `phase`, which began at `started_s`: after a phase switch
    /// or a new program.
    Running {
        /// The phase showing.
        phase: usize,
        /// When it began, s.
        started_s: f64,
    },
    /// A state set from outside, held until changed; `then` are the states an amber leads to
    /// (an all-red clearance, then the state asked for), each with when it shows, s.
    Held {
        /// After an amber: the states still to show and when, in order.
        then: Vec<(f64, Vec<SignalState>)>,
    },
}

/// One signalised junction's controller: its program, how it runs, and what it shows.
#[derive(Debug, Clone, PartialEq)]
pub struct SignalController {
    /// The junction's name.
    pub junction: String,
    /// The program in force: the level's, or one set from outside.
    pub program: SignalProgram,
    /// Whether `program` was set from outside (not the level's).
    pub custom: bool,
    /// How it runs now.
    pub mode: SignalMode,
    level_program: SignalProgram,
    phase_states: Vec<Vec<SignalState>>,
    /// What each connection shows.
    states: Vec<SignalState>,
    /// When each connection's state began, s.
    since_s: Vec<f64>,
    /// What each connection showed before that.
    before: Vec<SignalState>,
    /// When the junction's state (any connection) last changed, s.
    changed_s: f64,
    /// How many times the state changed.
    changes: u64,
}

/// What a controller is asked that it cannot do.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SignalError {
    /// No junction of that name has a signal.
    #[error("there is no signalised junction `{name}`; the signalised junctions are: {known}")]
    NoSignal {
        /// The name asked for.
        name: String,
        /// The ones there are, comma-separated.
        known: String,
    },
    /// A phase the program lacks.
    #[error("junction `{junction}` has no phase {phase}: its program has {phases} (0 to {last})", last = phases.saturating_sub(1))]
    Phase {
        /// The junction.
        junction: String,
        /// The phase asked for.
        phase: usize,
        /// How many phases it has.
        phases: usize,
    },
    /// A state string of the wrong length or with an unknown letter.
    #[error("junction `{junction}`: {problem}")]
    State {
        /// The junction.
        junction: String,
        /// What is wrong.
        problem: String,
    },
    /// A program that does not fit the junction.
    #[error(transparent)]
    Program(#[from] JunctionError),
    /// An amber or all-red time that is not a number of seconds from 0.
    #[error("{what} time {seconds} s: expected a number of seconds from 0")]
    Clearance {
        /// Which: `amber` or `all-red`.
        what: &'static str,
        /// The time given.
        seconds: f64,
    },
}

impl SignalController {
    fn new(junction: &str, program: &SignalProgram, connections: usize) -> SignalController {
        let phase_states = program.states(connections);
        // What the plan shows at time 0 (its offset may start it in any phase).
        let states = program
            .phase_at(0.0)
            .and_then(|(i, _)| phase_states.get(i).cloned())
            .unwrap_or_else(|| vec![SignalState::Red; connections]);
        SignalController {
            junction: junction.to_owned(),
            program: program.clone(),
            custom: false,
            mode: SignalMode::Plan,
            level_program: program.clone(),
            phase_states,
            before: states.clone(),
            since_s: vec![0.0; connections],
            states,
            changed_s: 0.0,
            changes: 0,
        }
    }

    /// What each connection shows, in the junction's order.
    pub fn states(&self) -> &[SignalState] {
        &self.states
    }

    /// The state as SUMO writes it: a letter per connection.
    pub fn state_string(&self) -> String {
        self.states.iter().map(|s| s.letter()).collect()
    }

    /// The phase showing at `t_s` and how long it has shown, s; `None` while a state set from
    /// outside is held.
    pub fn phase(&self, t_s: f64) -> Option<(usize, f64)> {
        match &self.mode {
            SignalMode::Plan => self
                .program
                .phase_at(t_s)
                .map(|(i, left)| (i, self.program.phases[i].duration_s - left)),
            SignalMode::Running { phase, started_s } => Some((*phase, t_s - started_s)),
            SignalMode::Held { .. } => None,
        }
    }

    /// How long the junction's state has been what it is at `t_s`, s.
    pub fn unchanged_for_s(&self, t_s: f64) -> f64 {
        (t_s - self.changed_s).max(0.0)
    }

    /// How many times the state changed so far.
    pub fn changes(&self) -> u64 {
        self.changes
    }

    /// Which cycle `t_s` falls in, for telling one green's queue from the next: by the clock
    /// under the level's plan, otherwise counted in changes of state.
    pub fn cycle(&self, t_s: f64) -> i64 {
        match self.mode {
            SignalMode::Plan if self.program.cycle_s() > 0.0 => {
                ((t_s + self.program.offset_s) / self.program.cycle_s()).floor() as i64
            }
            _ => self.changes as i64,
        }
    }

    /// What connection `k` showed at `t_s`, a moment ago or now: exact by the clock under the
    /// level's plan; otherwise the current state from when it began, the one before it before.
    pub fn state_at(&self, k: usize, t_s: f64) -> SignalState {
        if self.mode == SignalMode::Plan {
            return self
                .program
                .phase_at(t_s)
                .map_or(SignalState::Red, |(i, _)| {
                    self.phase_states[i]
                        .get(k)
                        .copied()
                        .unwrap_or(SignalState::Red)
                });
        }
        match (self.states.get(k), self.since_s.get(k)) {
            (Some(&now), Some(&since)) if t_s + SAME_INSTANT_S >= since => now,
            _ => self.before.get(k).copied().unwrap_or(SignalState::Red),
        }
    }

    /// Moves to time `t_s`: the plan by the clock, a running program's phases as they end, a
    /// held state's amber as it ends.
    pub fn update(&mut self, t_s: f64) {
        let next: Option<Vec<SignalState>> = match &mut self.mode {
            SignalMode::Plan => self
                .program
                .phase_at(t_s)
                .map(|(i, _)| self.phase_states[i].clone()),
            SignalMode::Running { phase, started_s } => {
                let n = self.program.phases.len();
                let mut moved = false;
                while t_s - *started_s + SAME_INSTANT_S >= self.program.phases[*phase].duration_s {
                    *started_s += self.program.phases[*phase].duration_s;
                    *phase = (*phase + 1) % n;
                    moved = true;
                }
                moved.then(|| self.phase_states[*phase].clone())
            }
            SignalMode::Held { then } => {
                let due = then
                    .iter()
                    .take_while(|(at_s, _)| t_s + SAME_INSTANT_S >= *at_s)
                    .count();
                then.drain(..due).next_back().map(|(_, s)| s)
            }
        };
        if let Some(next) = next {
            self.show(next, t_s);
        }
    }

    /// Shows `next` from `t_s`.
    fn show(&mut self, next: Vec<SignalState>, t_s: f64) {
        if next == self.states {
            return;
        }
        for (k, state) in next.iter().enumerate() {
            if self.states[k] != *state {
                self.before[k] = self.states[k];
                self.since_s[k] = t_s;
            }
        }
        self.states = next;
        self.changed_s = t_s;
        self.changes += 1;
    }

    /// Switches to phase `phase` of the program in force from `t_s`; the program runs on from
    /// there, each phase for its duration.
    pub fn set_phase(&mut self, phase: usize, t_s: f64) -> Result<(), SignalError> {
        if phase >= self.program.phases.len() {
            return Err(SignalError::Phase {
                junction: self.junction.clone(),
                phase,
                phases: self.program.phases.len(),
            });
        }
        self.mode = SignalMode::Running {
            phase,
            started_s: t_s,
        };
        self.show(self.phase_states[phase].clone(), t_s);
        Ok(())
    }

    /// Shows `state` (a letter per connection) from `t_s` and holds it until told otherwise.
    /// With `amber_s` above 0, a movement losing its green shows amber for that long first, and
    /// one gaining green stays as it is until then, so no two conflicting greens overlap; with
    /// `all_red_s` above 0 as well, every movement that changes then shows red that long (the
    /// clearance for a vehicle still in the junction) before the state asked for.
    pub fn set_state(
        &mut self,
        state: &str,
        amber_s: f64,
        all_red_s: f64,
        t_s: f64,
    ) -> Result<(), SignalError> {
        for (what, s) in [("amber", amber_s), ("all-red", all_red_s)] {
            if !(s.is_finite() && s >= 0.0) {
                return Err(SignalError::Clearance { what, seconds: s });
            }
        }
        let target =
            check_state(state, self.states.len()).map_err(|problem| SignalError::State {
                junction: self.junction.clone(),
                problem,
            })?;
        let loses_green = |k: usize| self.states[k].is_go() && !target[k].is_go();
        if amber_s > 0.0 && (0..target.len()).any(loses_green) {
            let amber: Vec<SignalState> = (0..target.len())
                .map(|k| {
                    if loses_green(k) {
                        SignalState::Amber
                    } else if target[k].is_go() && !self.states[k].is_go() {
                        self.states[k]
                    } else {
                        target[k]
                    }
                })
                .collect();
            let mut then = Vec::new();
            if all_red_s > 0.0 {
                let red: Vec<SignalState> = (0..target.len())
                    .map(|k| {
                        if amber[k] == SignalState::Amber || amber[k] != target[k] {
                            SignalState::Red
                        } else {
                            target[k]
                        }
                    })
                    .collect();
                then.push((t_s + amber_s, red));
            }
            then.push((t_s + amber_s + all_red_s, target));
            self.mode = SignalMode::Held { then };
            self.show(amber, t_s);
        } else {
            self.mode = SignalMode::Held { then: Vec::new() };
            self.show(target, t_s);
        }
        Ok(())
    }

    /// Runs `program` from its phase `phase` at `t_s`; `None` goes back to the level's program
    /// by the clock (its offset as the level has it).
    pub fn set_program(
        &mut self,
        program: Option<SignalProgram>,
        phase: usize,
        t_s: f64,
    ) -> Result<(), SignalError> {
        let Some(program) = program else {
            self.program = self.level_program.clone();
            self.phase_states = self.program.states(self.states.len());
            self.custom = false;
            self.mode = SignalMode::Plan;
            self.update(t_s);
            return Ok(());
        };
        check_program(&self.junction, self.states.len(), &program)?;
        if phase >= program.phases.len() {
            return Err(SignalError::Phase {
                junction: self.junction.clone(),
                phase,
                phases: program.phases.len(),
            });
        }
        self.phase_states = program.states(self.states.len());
        self.program = program;
        self.custom = true;
        self.set_phase(phase, t_s)
    }
}

/// Every signalised junction's controller, in the network's junction order (`None` for a
/// junction without a signal).
#[derive(Resource, Debug, Clone, Default, PartialEq)]
pub struct Signals {
    controllers: Vec<Option<SignalController>>,
    built: bool,
}

impl Signals {
    /// Controllers for `network`'s signals, each on its level's plan.
    pub fn from_network(network: &RoadNetwork) -> Signals {
        Signals {
            controllers: network
                .junctions()
                .iter()
                .map(|j| {
                    j.spec
                        .signal
                        .as_ref()
                        .filter(|_| j.spec.control == flockway_road::Control::Signal)
                        .map(|p| SignalController::new(&j.spec.name, p, j.paths.len()))
                })
                .collect(),
            built: true,
        }
    }

    /// Builds the controllers from `network` the first time; then keeps them.
    pub fn ensure(&mut self, network: &RoadNetwork) {
        if !self.built {
            *self = Signals::from_network(network);
        }
    }

    /// Junction `j`'s controller, if it has a signal.
    pub fn get(&self, j: usize) -> Option<&SignalController> {
        self.controllers.get(j).and_then(Option::as_ref)
    }

    /// Every junction's controller, in the network's order.
    pub fn iter(&self) -> impl Iterator<Item = (usize, &SignalController)> {
        self.controllers
            .iter()
            .enumerate()
            .filter_map(|(j, c)| c.as_ref().map(|c| (j, c)))
    }

    /// The controller of the junction named `name`, for changing it.
    pub fn by_name_mut(&mut self, name: &str) -> Result<&mut SignalController, SignalError> {
        let found = self
            .controllers
            .iter()
            .position(|c| c.as_ref().is_some_and(|c| c.junction == name));
        match found {
            Some(j) => Ok(self.controllers[j].as_mut().expect("found above")),
            None => Err(SignalError::NoSignal {
                name: name.to_owned(),
                known: {
                    let names: Vec<&str> = self.iter().map(|(_, c)| c.junction.as_str()).collect();
                    if names.is_empty() {
                        "none".to_owned()
                    } else {
                        names.join(", ")
                    }
                },
            }),
        }
    }

    /// What junction `j`'s connections show; `None` without a signal.
    pub fn states(&self, j: usize) -> Option<&[SignalState]> {
        self.get(j).map(SignalController::states)
    }

    /// What connection `k` of junction `j` showed at `t_s` (see
    /// [`SignalController::state_at`]); `None` without a signal.
    pub fn state_at(&self, j: usize, k: usize, t_s: f64) -> Option<SignalState> {
        self.get(j).map(|c| c.state_at(k, t_s))
    }

    /// Moves every controller to `t_s`.
    pub fn update(&mut self, t_s: f64) {
        for c in self.controllers.iter_mut().flatten() {
            c.update(t_s);
        }
    }
}

/// Brings every signal to the tick's time, before drivers look at them.
pub fn update_signals(
    network: Res<RoadNetwork>,
    clock: Res<SimClock>,
    mut signals: ResMut<Signals>,
) {
    signals.ensure(&network);
    signals.update(clock.seconds());
}

#[cfg(test)]
mod tests {
    use super::*;
    use flockway_road::Phase;

    fn program() -> SignalProgram {
        let phase = |duration_s: f64, state: &str| Phase {
            duration_s,
            state: state.to_owned(),
        };
        SignalProgram {
            offset_s: 5.0,
            phases: vec![
                phase(20.0, "GGrr"),
                phase(3.0, "yyrr"),
                phase(20.0, "rrGG"),
                phase(3.0, "rryy"),
            ],
        }
    }

    fn controller() -> SignalController {
        let c = SignalController::new("j", &program(), 4);
        // Before any update it shows what the plan shows at 0 (offset 5 s: still phase 0).
        assert_eq!(c.state_string(), "GGrr");
        c
    }

    #[test]
    fn before_the_first_tick_it_shows_the_phase_its_offset_starts_in() {
        let mut p = program();
        p.offset_s = 21.0; // 1 s into the first amber
        let c = SignalController::new("j", &p, 4);
        assert_eq!(c.state_string(), "yyrr");
        assert_eq!(c.phase(0.0).map(|(i, _)| i), Some(1));
    }

    #[test]
    fn on_its_plan_it_shows_the_program_by_the_clock_with_its_offset() {
        let mut c = controller();
        let p = program();
        for tick in 0..(120 * 100) {
            let t = f64::from(tick) / 120.0;
            c.update(t);
            let (i, _) = p.phase_at(t).expect("accepted");
            assert_eq!(c.states(), p.states(4)[i].as_slice(), "at {t} s");
            assert_eq!(c.phase(t).expect("accepted").0, i);
        }
    }

    #[test]
    fn a_phase_switch_runs_the_program_on_from_there_each_phase_for_its_duration() {
        let mut c = controller();
        c.set_phase(2, 10.0).expect("accepted");
        assert_eq!(c.state_string(), "rrGG");
        assert_eq!(c.phase(10.0), Some((2, 0.0)));
        c.update(29.99);
        assert_eq!(c.state_string(), "rrGG");
        c.update(30.0);
        assert_eq!(c.state_string(), "rryy");
        c.update(33.0);
        assert_eq!(c.state_string(), "GGrr");
        assert_eq!(c.phase(34.0), Some((0, 1.0)));
        // What it showed a moment ago, for counting entries on red.
        assert_eq!(c.state_at(0, 32.9), SignalState::Red);
        assert_eq!(c.state_at(0, 33.0), SignalState::Green);
        let err = c.set_phase(4, 40.0).expect_err("refused").to_string();
        assert!(
            err.contains("no phase 4") && err.contains("0 to 3"),
            "{err}"
        );
    }

    #[test]
    fn a_held_state_stays_and_an_amber_comes_first_for_movements_losing_green() {
        let mut c = controller();
        c.update(6.0);
        assert_eq!(c.state_string(), "GGrr");
        c.set_state("rrGG", 3.0, 0.0, 6.0).expect("accepted");
        // Losing green: amber; gaining green: still red until the amber ends.
        assert_eq!(c.state_string(), "yyrr");
        c.update(8.99);
        assert_eq!(c.state_string(), "yyrr");
        c.update(9.0);
        assert_eq!(c.state_string(), "rrGG");
        c.update(500.0);
        assert_eq!(c.state_string(), "rrGG");
        assert_eq!(c.phase(500.0), None);
        assert_eq!(c.unchanged_for_s(500.0), 491.0);
        // Without an amber, at once.
        c.set_state("GGrr", 0.0, 0.0, 500.0).expect("accepted");
        assert_eq!(c.state_string(), "GGrr");
        for (bad, says) in [
            ("GGr", "3 letter(s) for 4"),
            ("GGrx", "has `x`"),
            ("", "0 letter(s)"),
        ] {
            let err = c
                .set_state(bad, 0.0, 0.0, 501.0)
                .expect_err("refused")
                .to_string();
            assert!(err.contains(says), "{bad}: {err}");
        }
        assert!(c.set_state("rrrr", -1.0, 0.0, 501.0).is_err());
        assert!(c.set_state("rrrr", f64::NAN, 0.0, 501.0).is_err());
        assert!(c.set_state("rrrr", 3.0, -2.0, 501.0).is_err());
        assert_eq!(c.state_string(), "GGrr", "a refused state changes nothing");
        // An all-red clearance between the amber and the new green.
        c.set_state("rGGr", 3.0, 2.0, 600.0).expect("accepted");
        assert_eq!(c.state_string(), "yGrr");
        c.update(603.0);
        assert_eq!(c.state_string(), "rGrr");
        c.update(604.99);
        assert_eq!(c.state_string(), "rGrr");
        c.update(605.0);
        assert_eq!(c.state_string(), "rGGr");
        // Stepped over in one go, the last due state shows.
        c.set_state("GGrr", 3.0, 2.0, 700.0).expect("accepted");
        c.update(710.0);
        assert_eq!(c.state_string(), "GGrr");
    }

    #[test]
    fn a_new_program_runs_from_its_phase_and_none_goes_back_to_the_plan() {
        let mut c = controller();
        let mine = SignalProgram {
            offset_s: 0.0,
            phases: vec![
                Phase {
                    duration_s: 10.0,
                    state: "GrGr".into(),
                },
                Phase {
                    duration_s: 10.0,
                    state: "rGrG".into(),
                },
            ],
        };
        c.set_program(Some(mine), 1, 2.0).expect("accepted");
        assert!(c.custom);
        assert_eq!(c.state_string(), "rGrG");
        c.update(12.0);
        assert_eq!(c.state_string(), "GrGr");
        let bad = SignalProgram {
            offset_s: 0.0,
            phases: vec![Phase {
                duration_s: 0.0,
                state: "GGGG".into(),
            }],
        };
        let err = c
            .set_program(Some(bad), 0, 13.0)
            .expect_err("refused")
            .to_string();
        assert!(err.contains("more than 0"), "{err}");
        c.set_program(None, 0, 13.0).expect("accepted");
        assert!(!c.custom);
        let (i, _) = program().phase_at(13.0).expect("accepted");
        assert_eq!(c.states(), program().states(4)[i].as_slice());
    }
}
