//! Driver profiles: a built-in model with parameters from RON and overrides by name, ready to put
//! on a vehicle.

use crate::ahead::ReadsRoad;
use crate::control::{DriveTarget, TargetController};
use crate::idm::{IdmDriver, IdmParams};
use crate::models::{FlockDriver, FlockParams, HumanDriver, HumanParams, SpeedFactor, SpeedLimit};
use crate::pipeline::{ActionStep, LaneChoice};
use crate::safety::SafetyParams;
use crate::wave_damper::{WaveDamper, WaveDamperParams};
use bevy_ecs::prelude::*;
use flockway_core::EntityRng;
use flockway_vehicle::VehicleModel;
use serde::Serialize;
use serde::de::DeserializeOwned;
use serde_json::Value;
use std::collections::BTreeMap;
use std::sync::Arc;

/// The driver models Flockway provides.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum BuiltinModel {
    /// Reynolds flocking with free avoidance.
    Flock,
    /// Flocking that keeps its lane (the default autonomous car).
    FlockLanes,
    /// Human-like flocking: shorter range, reaction delay, harsher, own desired speed.
    Human,
    /// The Intelligent Driver Model.
    Idm,
    /// The wave-damping autonomous car (after Stern et al. 2018).
    WaveDamper,
}

impl BuiltinModel {
    /// Every built-in model.
    pub const ALL: [BuiltinModel; 5] = [
        BuiltinModel::Flock,
        BuiltinModel::FlockLanes,
        BuiltinModel::Human,
        BuiltinModel::Idm,
        BuiltinModel::WaveDamper,
    ];

    /// The model's name in levels and telemetry.
    pub fn name(self) -> &'static str {
        match self {
            BuiltinModel::Flock => "Flock",
            BuiltinModel::FlockLanes => "FlockLanes",
            BuiltinModel::Human => "Human",
            BuiltinModel::Idm => "Idm",
            BuiltinModel::WaveDamper => "WaveDamper",
        }
    }

    /// The names a profile's `set` may override for this model (dotted for nested values, such
    /// as `throttle.kp`), sorted.
    pub fn parameter_names(self) -> Vec<String> {
        let mut names = Vec::new();
        if let Some(v) = self.defaults_json() {
            leaf_names(&v, "", &mut names);
        }
        names.sort();
        names
    }

    /// The built-in value of one of its parameters (by the name [`Self::parameter_names`]
    /// gives), or `None` for a parameter unset by default (such as a target speed) or unknown.
    pub fn default_value(self, name: &str) -> Option<f64> {
        self.defaults_json()
            .and_then(|v| name.split('.').try_fold(v, |node, k| node.get(k).cloned()))
            .and_then(|v| v.as_f64())
    }

    fn defaults_json(self) -> Option<Value> {
        match DriverSpec::default_for(self) {
            DriverSpec::Flock(p)
            | DriverSpec::FlockLanes(p)
            | DriverSpec::Custom { base: p, .. } => serde_json::to_value(p),
            DriverSpec::Human(p) => serde_json::to_value(p),
            DriverSpec::Idm(p) => serde_json::to_value(p),
            DriverSpec::WaveDamper(p) => serde_json::to_value(p),
        }
        .ok()
    }

    /// The name a profile's `set` gives its action step (see [`FlockParams::action_step_s`]):
    /// under `flock.` where the model's flocking parameters are nested.
    pub fn action_step_parameter(self) -> &'static str {
        match self {
            BuiltinModel::Human | BuiltinModel::WaveDamper => "flock.action_step_s",
            BuiltinModel::Flock | BuiltinModel::FlockLanes | BuiltinModel::Idm => "action_step_s",
        }
    }

    /// The model with this name (as levels write it: `FlockLanes`, `Human`, …).
    pub fn from_name(name: &str) -> Option<BuiltinModel> {
        BuiltinModel::ALL.into_iter().find(|m| m.name() == name)
    }

    /// The parameter file shipped for this model, under `assets/`.
    pub fn default_params_path(self) -> &'static str {
        match self {
            BuiltinModel::Flock => "drivers/flock.ron",
            BuiltinModel::FlockLanes => "drivers/flock_lanes.ron",
            BuiltinModel::Human => "drivers/human.ron",
            BuiltinModel::Idm => "drivers/idm.ron",
            BuiltinModel::WaveDamper => "drivers/wave_damper.ron",
        }
    }
}

/// A built-in model with its parameters.
#[derive(Debug, Clone, PartialEq)]
pub enum DriverSpec {
    /// Free flocking.
    Flock(FlockParams),
    /// Lane-keeping flocking.
    FlockLanes(FlockParams),
    /// Human-like.
    Human(HumanParams),
    /// IDM.
    Idm(IdmParams),
    /// Wave-damping autonomous car.
    WaveDamper(WaveDamperParams),
    /// A model driven from outside the step (`Custom(NAME)` in a level, a Python controller):
    /// an [`External`](crate::External) vehicle. Until it is told what to do it drives as a
    /// lane-keeping flocking car with these parameters.
    Custom {
        /// The model's name.
        name: std::sync::Arc<str>,
        /// How it drives until (and between) commands.
        base: FlockParams,
    },
}

/// Why a driver profile could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DriverParamsError {
    /// The parameter text is not valid RON for the model.
    #[error("{path}:{line}:{column}: {message}")]
    Parse {
        /// File (or a description of the text).
        path: String,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What was expected.
        message: String,
    },
    /// An override names no parameter of the model.
    #[error("`{name}` is not a parameter of {model}; its parameters are {known}")]
    UnknownParameter {
        /// The name given.
        name: String,
        /// The model.
        model: &'static str,
        /// The names it has.
        known: String,
    },
    /// An override's value does not fit the parameter, or a value is out of range.
    #[error("{model}: {message}")]
    Invalid {
        /// The model.
        model: &'static str,
        /// What is wrong.
        message: String,
    },
}

impl DriverSpec {
    /// The model's built-in defaults.
    pub fn default_for(model: BuiltinModel) -> DriverSpec {
        match model {
            BuiltinModel::Flock => DriverSpec::Flock(FlockParams::default()),
            BuiltinModel::FlockLanes => DriverSpec::FlockLanes(FlockParams::lanes()),
            BuiltinModel::Human => DriverSpec::Human(HumanParams::default()),
            BuiltinModel::Idm => DriverSpec::Idm(IdmParams::default()),
            BuiltinModel::WaveDamper => DriverSpec::WaveDamper(WaveDamperParams::default()),
        }
    }

    /// Which model this is.
    pub fn model(&self) -> BuiltinModel {
        match self {
            DriverSpec::Flock(_) => BuiltinModel::Flock,
            DriverSpec::FlockLanes(_) => BuiltinModel::FlockLanes,
            DriverSpec::Human(_) => BuiltinModel::Human,
            DriverSpec::Idm(_) => BuiltinModel::Idm,
            DriverSpec::WaveDamper(_) => BuiltinModel::WaveDamper,
            DriverSpec::Custom { .. } => BuiltinModel::FlockLanes,
        }
    }

    /// The model's name as telemetry writes it: a built-in model's name, or `Custom(NAME)`.
    pub fn model_name(&self) -> String {
        match self {
            DriverSpec::Custom { name, .. } => format!("Custom({name})"),
            other => other.model().name().to_owned(),
        }
    }

    /// An externally driven model `name`, which drives as `base` (a lane-keeping flocking car)
    /// until told otherwise: [`BuiltinModel::FlockLanes`]'s parameters from `params` with
    /// `overrides`, as [`DriverSpec::build`] reads them.
    pub fn custom(
        name: &str,
        params: Option<(&str, &str)>,
        overrides: &BTreeMap<String, f64>,
    ) -> Result<DriverSpec, DriverParamsError> {
        let base: FlockParams = load(
            BuiltinModel::FlockLanes,
            params,
            overrides,
            FlockParams::lanes(),
        )?;
        ActionStep::ticks_of(base.action_step_s).map_err(|message| DriverParamsError::Invalid {
            model: BuiltinModel::FlockLanes.name(),
            message,
        })?;
        Ok(DriverSpec::Custom {
            name: std::sync::Arc::from(name),
            base,
        })
    }

    /// Builds a profile: `params` (RON text of the model's parameters, partial files allowed;
    /// `None` for the defaults; `path` names it in errors) with `overrides` by dotted name
    /// (`"target_speed_kmh"`, `"throttle.kp"`, `"flock.detection_range_m"`).
    pub fn build(
        model: BuiltinModel,
        params: Option<(&str, &str)>,
        overrides: &BTreeMap<String, f64>,
    ) -> Result<DriverSpec, DriverParamsError> {
        let spec = match model {
            BuiltinModel::Flock => {
                DriverSpec::Flock(load(model, params, overrides, Default::default())?)
            }
            BuiltinModel::FlockLanes => {
                DriverSpec::FlockLanes(load(model, params, overrides, FlockParams::lanes())?)
            }
            BuiltinModel::Human => {
                DriverSpec::Human(load(model, params, overrides, Default::default())?)
            }
            BuiltinModel::Idm => {
                DriverSpec::Idm(load(model, params, overrides, Default::default())?)
            }
            BuiltinModel::WaveDamper => {
                DriverSpec::WaveDamper(load(model, params, overrides, Default::default())?)
            }
        };
        spec.safety()
            .validate()
            .and_then(|()| ActionStep::ticks_of(spec.action_step_s()).map(|_| ()))
            .map_err(|message| DriverParamsError::Invalid {
                model: model.name(),
                message,
            })?;
        Ok(spec)
    }

    /// How often it decides, s (0: every tick); see [`FlockParams::action_step_s`].
    pub fn action_step_s(&self) -> f32 {
        match self {
            DriverSpec::Flock(p)
            | DriverSpec::FlockLanes(p)
            | DriverSpec::Custom { base: p, .. } => p.action_step_s,
            DriverSpec::Human(h) => h.flock.action_step_s,
            DriverSpec::Idm(p) => p.action_step_s,
            DriverSpec::WaveDamper(p) => p.flock.action_step_s,
        }
    }

    /// How strongly a vehicle close behind pushes this driver on (the flocking rule; 0 for a
    /// driver that looks ahead only, such as the human-like car and the IDM).
    pub fn rear_weight(&self) -> f32 {
        match self {
            DriverSpec::Flock(p)
            | DriverSpec::FlockLanes(p)
            | DriverSpec::Custom { base: p, .. } => p.rear_weight,
            DriverSpec::Human(h) => h.flock.rear_weight,
            DriverSpec::Idm(_) => 0.0,
            DriverSpec::WaveDamper(p) => p.flock.rear_weight,
        }
    }

    /// Its braking envelope, which the safety layer holds it to.
    pub fn safety(&self) -> &SafetyParams {
        match self {
            DriverSpec::Flock(p)
            | DriverSpec::FlockLanes(p)
            | DriverSpec::Custom { base: p, .. } => &p.safety,
            DriverSpec::Human(h) => &h.flock.safety,
            DriverSpec::Idm(p) => &p.safety,
            DriverSpec::WaveDamper(p) => &p.flock.safety,
        }
    }

    /// The components that make `entity` drive this way in `lane`: the model's component, a
    /// [`DriveTarget`], a [`TargetController`] with the model's gains and a [`SpeedLimit`]. A
    /// human-like driver draws its desired speed from `rng` (the vehicle's own stream).
    pub fn insert(&self, entity: &mut EntityWorldMut, lane: u32, rng: &mut EntityRng) {
        let target = DriveTarget {
            speed_mps: 0.0,
            heading_rad: 0.0,
            curvature_per_m: 0.0,
            accel_mps2: None,
        };
        entity.insert((
            target,
            LaneChoice::new(lane),
            SpeedLimit::default(),
            DriverLabel::new(self.model_name(), self.model_name()),
        ));
        // The tyres' grip the driver trusts for the road ahead: the vehicle's own, if it has one.
        let grip = entity
            .get::<VehicleModel>()
            .map_or(1.0, |m| m.0.params.tyres.friction);
        let (ahead, safety, factor, (critical_gap_s, follow_up_s)) = match self {
            DriverSpec::Custom { name, base: p } => {
                entity.insert((
                    FlockDriver::new(p.clone(), true),
                    TargetController::new(p.throttle, p.steering),
                    crate::External::new(name.clone()),
                ));
                (
                    p.road_ahead,
                    p.safety,
                    p.speed_factor.draw(rng),
                    (p.critical_gap_s, p.follow_up_s),
                )
            }
            DriverSpec::Flock(p) | DriverSpec::FlockLanes(p) => {
                let keep = matches!(self, DriverSpec::FlockLanes(_));
                entity.insert((
                    FlockDriver::new(p.clone(), keep),
                    TargetController::new(p.throttle, p.steering),
                ));
                (
                    p.road_ahead,
                    p.safety,
                    p.speed_factor.draw(rng),
                    (p.critical_gap_s, p.follow_up_s),
                )
            }
            DriverSpec::Human(h) => {
                let spread = f64::from(h.speed_spread.clamp(0.0, 0.9));
                let uniform = rng.uniform(1.0 - spread, 1.0 + spread) as f32;
                entity.insert((
                    FlockDriver::new(h.flock.clone(), true),
                    HumanDriver::new(h.reaction_time_s).with_noise(
                        h.speed_noise_kmh / 3.6,
                        h.noise_time_s,
                        rng.fork(),
                    ),
                    TargetController::new(h.flock.throttle, h.flock.steering),
                ));
                // The spread around the profile's factor: the two multiply.
                (
                    h.flock.road_ahead,
                    h.flock.safety,
                    h.flock.speed_factor.draw(rng) * uniform,
                    (h.flock.critical_gap_s, h.flock.follow_up_s),
                )
            }
            DriverSpec::WaveDamper(p) => {
                entity.insert((
                    WaveDamper::new(p.clone()),
                    TargetController::new(p.flock.throttle, p.flock.steering),
                ));
                (
                    p.flock.road_ahead,
                    p.flock.safety,
                    p.flock.speed_factor.draw(rng),
                    (p.flock.critical_gap_s, p.flock.follow_up_s),
                )
            }
            DriverSpec::Idm(p) => {
                entity.insert((
                    IdmDriver { params: p.clone() },
                    TargetController::new(p.throttle, p.steering),
                ));
                (
                    p.road_ahead,
                    p.safety,
                    p.speed_factor.draw(rng),
                    (p.critical_gap_s, p.follow_up_s),
                )
            }
        };
        // A driver deciding every tick carries no action step (nor pays for one); a driver
        // put in another's place (a trigger's new profile) does not keep the old one's.
        let every = ActionStep::ticks_of(self.action_step_s()).unwrap_or(1);
        if every > 1 {
            entity.insert(ActionStep::new(every));
        } else if entity.contains::<ActionStep>() {
            entity.remove::<ActionStep>();
        }
        entity.insert((
            SpeedFactor(factor),
            safety,
            ReadsRoad::new(ahead, grip),
            crate::GapAcceptance {
                critical_gap_s,
                follow_up_s,
            },
        ));
    }
}

/// Who drives a vehicle, for telemetry and statistics: its driver profile's name and its
/// driver model's.
#[derive(Component, Debug, Clone, PartialEq, Eq)]
pub struct DriverLabel {
    /// The profile's name in the level (the model's name for a vehicle placed without one).
    pub profile: Arc<str>,
    /// The model: a built-in one's name (`FlockLanes`, `Human`, …) or `Custom(NAME)`.
    pub model: Arc<str>,
}

impl DriverLabel {
    /// A label for a vehicle of `profile` driven by `model`.
    pub fn new(profile: impl Into<Arc<str>>, model: impl Into<Arc<str>>) -> DriverLabel {
        DriverLabel {
            profile: profile.into(),
            model: model.into(),
        }
    }

    /// The label of a vehicle a plugin drives with its model `name` (`Custom(name)`).
    pub fn custom(profile: impl Into<Arc<str>>, name: &str) -> DriverLabel {
        DriverLabel::new(profile, format!("Custom({name})"))
    }
}

/// The model's parameters: `defaults`, with the fields `params` (a RON struct, possibly partial)
/// gives, then `overrides`. A field a partial file leaves out takes the model's own default
/// (which may differ from the parameter type's: the lane-keeping car keeps its lane harder).
fn load<P: Serialize + DeserializeOwned + Default>(
    model: BuiltinModel,
    params: Option<(&str, &str)>,
    overrides: &BTreeMap<String, f64>,
    defaults: P,
) -> Result<P, DriverParamsError> {
    let invalid = |message: String| DriverParamsError::Invalid {
        model: model.name(),
        message,
    };
    let base: P = match params {
        Some((path, text)) => {
            let parse_error = |e: ron::error::SpannedError| DriverParamsError::Parse {
                path: path.to_owned(),
                line: e.span.start.line,
                column: e.span.start.col,
                message: e.code.to_string(),
            };
            // Parsed as the type first, so that a wrong or misspelt field is reported where it is.
            let parsed: P = ron::Options::default()
                .from_str(text)
                .map_err(parse_error)?;
            let given: ron::Value = ron::Options::default()
                .from_str(text)
                .map_err(parse_error)?;
            let given_fields: Vec<String> = match &given {
                ron::Value::Map(map) => map
                    .keys()
                    .filter_map(|k| match k {
                        ron::Value::String(name) => Some(name.clone()),
                        _ => None,
                    })
                    .collect(),
                _ => Vec::new(),
            };
            let mut merged = serde_json::to_value(&defaults).map_err(|e| invalid(e.to_string()))?;
            let parsed = serde_json::to_value(&parsed).map_err(|e| invalid(e.to_string()))?;
            if let (Value::Object(merged), Value::Object(parsed)) = (&mut merged, parsed) {
                for (name, value) in parsed {
                    if given_fields.contains(&name) {
                        merged.insert(name, value);
                    }
                }
            }
            serde_json::from_value(merged).map_err(|e| invalid(e.to_string()))?
        }
        None => defaults,
    };
    if overrides.is_empty() {
        return Ok(base);
    }
    let mut value = serde_json::to_value(&base).map_err(|e| invalid(e.to_string()))?;
    let mut known = Vec::new();
    leaf_names(&value, "", &mut known);
    for (name, v) in overrides {
        let Some(slot) = name
            .split('.')
            .try_fold(&mut value, |node, key| node.get_mut(key))
        else {
            return Err(DriverParamsError::UnknownParameter {
                name: name.clone(),
                model: model.name(),
                known: known.join(", "),
            });
        };
        if slot.is_object() {
            return Err(DriverParamsError::UnknownParameter {
                name: name.clone(),
                model: model.name(),
                known: known.join(", "),
            });
        }
        if !v.is_finite() {
            return Err(invalid(format!("{name}: {v} is not a finite number")));
        }
        *slot = Value::from(*v);
    }
    serde_json::from_value(value).map_err(|e| invalid(e.to_string()))
}

fn leaf_names(v: &Value, prefix: &str, out: &mut Vec<String>) {
    match v {
        Value::Object(map) => {
            for (k, child) in map {
                let name = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                leaf_names(child, &name, out);
            }
        }
        _ => out.push(prefix.to_owned()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn overrides_set_nested_values_and_unknown_names_are_errors() {
        let mut set = BTreeMap::new();
        set.insert("target_speed_kmh".to_owned(), 80.0);
        set.insert("throttle.kp".to_owned(), 0.9);
        let spec = DriverSpec::build(BuiltinModel::FlockLanes, None, &set).expect("valid");
        let DriverSpec::FlockLanes(p) = spec else {
            panic!("wrong model")
        };
        assert_eq!(p.target_speed_kmh, Some(80.0));
        assert_eq!(p.throttle.kp, 0.9);
        let mut set = BTreeMap::new();
        set.insert("flock.detection_range_m".to_owned(), 12.0);
        let DriverSpec::Human(h) =
            DriverSpec::build(BuiltinModel::Human, None, &set).expect("valid")
        else {
            panic!("wrong model")
        };
        assert_eq!(h.flock.detection_range_m, 12.0);
        let mut bad = BTreeMap::new();
        bad.insert("detection_rnage_m".to_owned(), 12.0);
        let err = DriverSpec::build(BuiltinModel::Flock, None, &bad).expect_err("typo");
        let text = err.to_string();
        assert!(
            text.contains("detection_rnage_m") && text.contains("detection_range_m"),
            "{text}"
        );
    }

    #[test]
    fn every_model_takes_an_action_step_by_name_and_refuses_one_that_is_not_whole_ticks() {
        for model in BuiltinModel::ALL {
            let name = model.action_step_parameter();
            assert!(model.parameter_names().iter().any(|n| n == name), "{name}");
            let set = BTreeMap::from([(name.to_owned(), 0.1)]);
            let spec = DriverSpec::build(model, None, &set).expect("valid");
            assert_eq!(spec.action_step_s(), 0.1, "{}", model.name());
            let default = DriverSpec::build(model, None, &BTreeMap::new()).expect("valid");
            assert_eq!(default.action_step_s(), 0.0, "{}", model.name());
            let bad = BTreeMap::from([(name.to_owned(), 0.013)]);
            let err = DriverSpec::build(model, None, &bad).expect_err("not whole ticks");
            assert!(err.to_string().contains("action_step_s"), "{err}");
        }
        let bad = BTreeMap::from([("action_step_s".to_owned(), 2.0)]);
        let err = DriverSpec::custom("mine", None, &bad).expect_err("longer than a second");
        assert!(err.to_string().contains("action_step_s"), "{err}");
    }

    #[test]
    fn a_partial_file_takes_the_models_own_defaults_for_what_it_leaves_out() {
        let text = "(target_speed_kmh: Some(70.0), throttle: (kp: 0.7, ki: 0.2, kd: 0.0))";
        let DriverSpec::FlockLanes(lanes) = DriverSpec::build(
            BuiltinModel::FlockLanes,
            Some(("p.ron", text)),
            &BTreeMap::new(),
        )
        .expect("valid") else {
            panic!("wrong model")
        };
        assert_eq!(lanes.target_speed_kmh, Some(70.0));
        assert_eq!(lanes.throttle.kp, 0.7);
        assert_eq!(
            lanes.road_weight_per_s,
            FlockParams::lanes().road_weight_per_s
        );
        let DriverSpec::Flock(flock) =
            DriverSpec::build(BuiltinModel::Flock, Some(("p.ron", text)), &BTreeMap::new())
                .expect("valid")
        else {
            panic!("wrong model")
        };
        assert_eq!(
            flock.road_weight_per_s,
            FlockParams::default().road_weight_per_s
        );
        assert_ne!(lanes.road_weight_per_s, flock.road_weight_per_s);
        let given = "(road_weight_per_s: 0.8)";
        let DriverSpec::FlockLanes(lanes) = DriverSpec::build(
            BuiltinModel::FlockLanes,
            Some(("p.ron", given)),
            &BTreeMap::new(),
        )
        .expect("valid") else {
            panic!("wrong model")
        };
        assert_eq!(lanes.road_weight_per_s, 0.8);
        let err = DriverSpec::build(
            BuiltinModel::FlockLanes,
            Some(("p.ron", "(\n  road_wieght_per_s: 0.8)")),
            &BTreeMap::new(),
        )
        .expect_err("misspelt");
        assert!(err.to_string().starts_with("p.ron:2:"), "{err}");
    }

    #[test]
    fn every_offered_parameter_name_is_accepted_as_an_override() {
        for model in BuiltinModel::ALL {
            let names = model.parameter_names();
            assert!(
                names.contains(&"throttle.kp".to_owned())
                    || names.contains(&"flock.throttle.kp".to_owned()),
                "{model:?}: {names:?}"
            );
            for name in names {
                let set = BTreeMap::from([(name.clone(), 1.0)]);
                let built = DriverSpec::build(model, None, &set);
                assert!(
                    !matches!(built, Err(DriverParamsError::UnknownParameter { .. })),
                    "{model:?} {name}: {built:?}"
                );
            }
            assert_eq!(BuiltinModel::from_name(model.name()), Some(model));
        }
    }

    #[test]
    fn parameter_text_errors_have_positions() {
        let err = DriverSpec::build(
            BuiltinModel::Idm,
            Some(("idm.ron", "(\n  time_headway_s: \"long\",\n)")),
            &BTreeMap::new(),
        )
        .expect_err("a string is not a number");
        assert!(err.to_string().starts_with("idm.ron:2:"), "{err}");
    }
}
