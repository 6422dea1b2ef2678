//! Vehicle definitions: every physical parameter of a car, with its unit, loadable from RON.

use serde::{Deserialize, Serialize};
use std::path::Path;

/// Everything that defines one kind of car. `Default` is the reference sedan (thesis §3.2.2).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct VehicleParams {
    /// Name shown in the HUD and telemetry.
    pub name: String,
    /// Body, mass distribution and aerodynamics.
    pub chassis: ChassisParams,
    /// Wheel geometry and spin properties.
    pub wheels: WheelParams,
    /// Springs, dampers and anti-roll bars.
    pub suspension: SuspensionParams,
    /// Tyre force model.
    pub tyres: TyreParams,
    /// Engine torque and losses.
    pub engine: EngineParams,
    /// Clutch between engine and gearbox.
    pub clutch: ClutchParams,
    /// Gear ratios and the automatic shift logic.
    pub gearbox: GearboxParams,
    /// How engine torque is split between the wheels.
    pub differential: Differential,
    /// Service brake, handbrake and ABS.
    pub brakes: BrakeParams,
    /// Steering geometry and its speed curve.
    pub steering: SteeringParams,
}

impl Default for VehicleParams {
    fn default() -> Self {
        VehicleParams {
            name: "sedan".into(),
            chassis: ChassisParams::default(),
            wheels: WheelParams::default(),
            suspension: SuspensionParams::default(),
            tyres: TyreParams::default(),
            engine: EngineParams::default(),
            clutch: ClutchParams::default(),
            gearbox: GearboxParams::default(),
            differential: Differential::default(),
            brakes: BrakeParams::default(),
            steering: SteeringParams::default(),
        }
    }
}

/// The body of the car.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ChassisParams {
    /// Total mass including wheels, kg.
    pub mass_kg: f32,
    /// Body length, m (collider and inertia).
    pub length_m: f32,
    /// Body width, m.
    pub width_m: f32,
    /// Body height above the road at rest, m.
    pub height_m: f32,
    /// Gap between the road and the underside of the body collider at rest, m.
    pub ground_clearance_m: f32,
    /// Height of the centre of mass above the road at rest, m. Lower is more stable in turns.
    pub com_height_m: f32,
    /// Centre of mass ahead of the middle of the wheelbase, m (negative: behind). Moving it
    /// forward loads the front tyres and makes the car understeer.
    pub com_forward_m: f32,
    /// Aerodynamic drag coefficient Cd, dimensionless.
    pub drag_coefficient: f32,
    /// Frontal area for drag, m².
    pub frontal_area_m2: f32,
    /// Air density, kg/m³.
    pub air_density_kg_m3: f32,
    /// Rolling resistance coefficient: resisting torque = coefficient × wheel load × radius.
    pub rolling_resistance: f32,
}

impl Default for ChassisParams {
    fn default() -> Self {
        ChassisParams {
            mass_kg: 1500.0,
            length_m: 4.6,
            width_m: 1.8,
            height_m: 1.4,
            ground_clearance_m: 0.18,
            com_height_m: 0.45,
            com_forward_m: 0.0,
            drag_coefficient: 0.3,
            frontal_area_m2: 2.2,
            air_density_kg_m3: 1.225,
            rolling_resistance: 0.013,
        }
    }
}

/// Wheel geometry and spin.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WheelParams {
    /// Rolling radius, m.
    pub radius_m: f32,
    /// Tyre width, m (drawn only).
    pub width_m: f32,
    /// Mass of one wheel, kg: its spin inertia is that of a disc, m r² / 2.
    pub mass_kg: f32,
    /// Spin damping torque per unit wheel speed, N·m·s/rad (bearing and hub losses).
    pub damping_nms: f32,
    /// Distance between front and rear axles, m.
    pub wheelbase_m: f32,
    /// Distance between left and right wheel centres, m.
    pub track_m: f32,
}

impl Default for WheelParams {
    fn default() -> Self {
        WheelParams {
            radius_m: 0.35,
            width_m: 0.10,
            mass_kg: 20.0,
            damping_nms: 0.25,
            wheelbase_m: 2.8,
            track_m: 1.56,
        }
    }
}

/// Springs and dampers, one per wheel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SuspensionParams {
    /// Spring rate, N/m. About m/4 × (2π f)² for a body frequency f of 1–1.5 Hz.
    pub stiffness_n_per_m: f32,
    /// Damper rate, N·s/m. Increase it if the body keeps bouncing after a bump.
    pub damping_n_s_per_m: f32,
    /// Suspension travel from full extension to the bump stop, m.
    pub travel_m: f32,
    /// Anti-roll bar rate per axle, N/m of left–right compression difference.
    pub anti_roll_n_per_m: f32,
}

impl Default for SuspensionParams {
    fn default() -> Self {
        SuspensionParams {
            stiffness_n_per_m: 35_000.0,
            damping_n_s_per_m: 3_500.0,
            travel_m: 0.3,
            anti_roll_n_per_m: 15_000.0,
        }
    }
}

/// One direction of the Pacejka magic formula `sin(C·atan(B·x − E·(B·x − atan(B·x))))`,
/// with the peak D given by friction × load.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MagicFormula {
    /// Stiffness factor B: the slope at zero slip is B·C·D.
    pub b: f32,
    /// Shape factor C: above 1 the force falls after its peak (sliding).
    pub c: f32,
    /// Curvature factor E: shapes the curve around and after the peak (≤ 1).
    pub e: f32,
}

/// Tyre forces.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TyreParams {
    /// Peak friction coefficient on dry asphalt: the peak force is friction × load. A trigger can
    /// scale it per wheel (wet road).
    pub friction: f32,
    /// Force against slip ratio (dimensionless, (ω r − v) / |v|).
    pub longitudinal: MagicFormula,
    /// Force against slip angle (radians).
    pub lateral: MagicFormula,
    /// Below this speed, m/s, slips are measured against it instead of the wheel speed, so they stay
    /// finite at a standstill; the force is then held to what stops the slip within one step.
    pub low_speed_mps: f32,
}

impl Default for TyreParams {
    fn default() -> Self {
        TyreParams {
            friction: 1.0,
            longitudinal: MagicFormula {
                b: 10.0,
                c: 1.9,
                e: 0.97,
            },
            lateral: MagicFormula {
                b: 12.0,
                c: 1.4,
                e: -0.5,
            },
            low_speed_mps: 0.5,
        }
    }
}

/// The engine: a torque curve, an inertia and speed-dependent losses.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EngineParams {
    /// Full-throttle torque, N·m, at engine speeds in rpm: `(rpm, torque)` points in rising rpm,
    /// linearly interpolated, flat beyond the ends.
    pub torque_curve: Vec<(f32, f32)>,
    /// Rev limiter: no torque above this speed, rpm.
    pub max_rpm: f32,
    /// The engine never turns slower than this, rpm.
    pub idle_rpm: f32,
    /// Rotating inertia of crank and flywheel, kg·m².
    pub inertia_kg_m2: f32,
    /// Loss torque per unit engine speed at full throttle, N·m·s/rad.
    pub damping_full_throttle: f32,
    /// Loss torque per unit engine speed off throttle with the clutch engaged, N·m·s/rad
    /// (engine braking).
    pub damping_zero_throttle_clutch_engaged: f32,
    /// Loss torque per unit engine speed off throttle with the clutch open, N·m·s/rad.
    pub damping_zero_throttle_clutch_disengaged: f32,
}

impl Default for EngineParams {
    fn default() -> Self {
        EngineParams {
            torque_curve: vec![
                (0.0, 320.0),
                (1000.0, 400.0),
                (1900.0, 500.0),
                (2800.0, 410.0),
                (4000.0, 290.0),
                (5800.0, 195.0),
            ],
            max_rpm: 5800.0,
            idle_rpm: 900.0,
            inertia_kg_m2: 0.4,
            damping_full_throttle: 0.15,
            damping_zero_throttle_clutch_engaged: 2.0,
            damping_zero_throttle_clutch_disengaged: 0.35,
        }
    }
}

/// The clutch: a viscous coupling whose torque grows with the speed difference across it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ClutchParams {
    /// Torque per unit slip speed when fully engaged, N·m·s/rad. Higher locks engine to wheels
    /// more tightly.
    pub strength_nms: f32,
}

impl Default for ClutchParams {
    fn default() -> Self {
        ClutchParams { strength_nms: 10.0 }
    }
}

/// Gear ratios and the automatic gearbox.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GearboxParams {
    /// Forward ratios, first gear first (engine turns per gearbox output turn).
    pub ratios: Vec<f32>,
    /// Reverse ratio (positive; the sign is applied by the gearbox).
    pub reverse_ratio: f32,
    /// Final drive ratio in the differential.
    pub final_drive: f32,
    /// Shift up when the engine reaches this speed, rpm.
    pub upshift_rpm: f32,
    /// Shift down when the engine falls to this speed, rpm.
    pub downshift_rpm: f32,
    /// Time with the clutch open during a shift, s.
    pub shift_time_s: f32,
}

impl Default for GearboxParams {
    fn default() -> Self {
        GearboxParams {
            ratios: vec![4.0, 2.0, 1.5, 1.1, 1.0],
            reverse_ratio: 4.0,
            final_drive: 4.0,
            upshift_rpm: 4800.0,
            downshift_rpm: 1700.0,
            shift_time_s: 0.5,
        }
    }
}

/// Which wheels the engine drives, and how an open differential splits its torque.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Differential {
    /// Front wheels only.
    FrontWheelDrive,
    /// Rear wheels only.
    RearWheelDrive,
    /// All four; `front_share` of the torque (0..1) goes to the front axle.
    AllWheelDrive {
        /// Share of torque to the front axle.
        front_share: f32,
    },
}

impl Default for Differential {
    fn default() -> Self {
        Differential::AllWheelDrive { front_share: 0.45 }
    }
}

impl Differential {
    /// Torque share of each wheel, in wheel order FL, FR, RL, RR; sums to 1.
    pub fn shares(self) -> [f32; 4] {
        match self {
            Differential::FrontWheelDrive => [0.5, 0.5, 0.0, 0.0],
            Differential::RearWheelDrive => [0.0, 0.0, 0.5, 0.5],
            Differential::AllWheelDrive { front_share } => {
                let f = front_share.clamp(0.0, 1.0);
                [f / 2.0, f / 2.0, (1.0 - f) / 2.0, (1.0 - f) / 2.0]
            }
        }
    }
}

/// Brakes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BrakeParams {
    /// Largest service-brake torque on each wheel, N·m (throttle −1).
    pub max_brake_torque_nm: f32,
    /// Handbrake torque on each rear wheel, N·m.
    pub max_handbrake_torque_nm: f32,
    /// Anti-lock brakes: the service brake never asks more of a tyre than its grip.
    pub abs: bool,
}

impl Default for BrakeParams {
    fn default() -> Self {
        BrakeParams {
            max_brake_torque_nm: 1500.0,
            max_handbrake_torque_nm: 3000.0,
            abs: true,
        }
    }
}

/// Steering.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SteeringParams {
    /// Road-wheel angle of a virtual centre wheel at full lock, degrees. The inner and outer
    /// wheels get their Ackermann angles from it.
    pub max_steer_deg: f32,
    /// Share of full lock available at a speed: `(km/h, share)` points, linearly interpolated.
    pub speed_curve: Vec<(f32, f32)>,
    /// Steering rate: how fast the wheels can turn lock to lock, 1/s of full range.
    pub rate_per_s: f32,
}

impl Default for SteeringParams {
    fn default() -> Self {
        SteeringParams {
            max_steer_deg: 35.0,
            speed_curve: vec![(0.0, 1.0), (173.0, 0.7)],
            rate_per_s: 4.0,
        }
    }
}

/// Why a vehicle definition could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum VehicleParamsError {
    /// The file could not be read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
    /// The file is not valid RON for a vehicle.
    #[error("{path}:{line}:{column}: {message}")]
    Parse {
        /// The file.
        path: String,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What was expected.
        message: String,
    },
    /// A value is out of its physical range.
    #[error("{path}: {field}: {message}")]
    Invalid {
        /// The file.
        path: String,
        /// Dotted path of the field.
        field: String,
        /// What is wrong.
        message: String,
    },
}

impl VehicleParams {
    /// Loads and validates a vehicle definition from a RON file.
    pub fn load(path: &Path) -> Result<VehicleParams, VehicleParamsError> {
        let text = std::fs::read_to_string(path).map_err(|source| VehicleParamsError::Io {
            path: path.display().to_string(),
            source,
        })?;
        VehicleParams::parse(&text, &path.display().to_string())
    }

    /// Parses and validates a vehicle definition; `path` names it in errors.
    pub fn parse(text: &str, path: &str) -> Result<VehicleParams, VehicleParamsError> {
        let params: VehicleParams =
            ron::Options::default()
                .from_str(text)
                .map_err(|e| VehicleParamsError::Parse {
                    path: path.to_owned(),
                    line: e.span.start.line,
                    column: e.span.start.col,
                    message: e.code.to_string(),
                })?;
        params
            .validate()
            .map_err(|(field, message)| VehicleParamsError::Invalid {
                path: path.to_owned(),
                field,
                message,
            })?;
        Ok(params)
    }

    /// Checks every value is finite and physically meaningful: `Err((field, message))`.
    pub fn validate(&self) -> Result<(), (String, String)> {
        let c = &self.chassis;
        let w = &self.wheels;
        let positive: [(&str, f32); 27] = [
            ("chassis.mass_kg", c.mass_kg),
            ("chassis.length_m", c.length_m),
            ("chassis.width_m", c.width_m),
            ("chassis.height_m", c.height_m),
            ("chassis.com_height_m", c.com_height_m),
            ("chassis.frontal_area_m2", c.frontal_area_m2),
            ("chassis.air_density_kg_m3", c.air_density_kg_m3),
            ("wheels.radius_m", w.radius_m),
            ("wheels.width_m", w.width_m),
            ("wheels.mass_kg", w.mass_kg),
            ("wheels.wheelbase_m", w.wheelbase_m),
            ("wheels.track_m", w.track_m),
            (
                "suspension.stiffness_n_per_m",
                self.suspension.stiffness_n_per_m,
            ),
            ("suspension.travel_m", self.suspension.travel_m),
            ("tyres.friction", self.tyres.friction),
            ("tyres.longitudinal.b", self.tyres.longitudinal.b),
            ("tyres.longitudinal.c", self.tyres.longitudinal.c),
            ("tyres.lateral.b", self.tyres.lateral.b),
            ("tyres.lateral.c", self.tyres.lateral.c),
            ("tyres.low_speed_mps", self.tyres.low_speed_mps),
            ("engine.max_rpm", self.engine.max_rpm),
            ("engine.idle_rpm", self.engine.idle_rpm),
            ("engine.inertia_kg_m2", self.engine.inertia_kg_m2),
            ("gearbox.reverse_ratio", self.gearbox.reverse_ratio),
            ("gearbox.final_drive", self.gearbox.final_drive),
            ("gearbox.upshift_rpm", self.gearbox.upshift_rpm),
            ("steering.max_steer_deg", self.steering.max_steer_deg),
        ];
        for (field, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err((field.into(), format!("must be a positive number, got {v}")));
            }
        }
        let non_negative: [(&str, f32); 12] = [
            ("chassis.ground_clearance_m", c.ground_clearance_m),
            ("chassis.drag_coefficient", c.drag_coefficient),
            ("chassis.rolling_resistance", c.rolling_resistance),
            ("wheels.damping_nms", w.damping_nms),
            (
                "suspension.damping_n_s_per_m",
                self.suspension.damping_n_s_per_m,
            ),
            (
                "suspension.anti_roll_n_per_m",
                self.suspension.anti_roll_n_per_m,
            ),
            (
                "engine.damping_full_throttle",
                self.engine.damping_full_throttle,
            ),
            (
                "engine.damping_zero_throttle_clutch_engaged",
                self.engine.damping_zero_throttle_clutch_engaged,
            ),
            (
                "engine.damping_zero_throttle_clutch_disengaged",
                self.engine.damping_zero_throttle_clutch_disengaged,
            ),
            ("clutch.strength_nms", self.clutch.strength_nms),
            ("gearbox.shift_time_s", self.gearbox.shift_time_s),
            (
                "brakes.max_brake_torque_nm",
                self.brakes.max_brake_torque_nm,
            ),
        ];
        for (field, v) in non_negative {
            if !(v.is_finite() && v >= 0.0) {
                return Err((field.into(), format!("must be zero or more, got {v}")));
            }
        }
        let finite: [(&str, f32); 3] = [
            ("chassis.com_forward_m", c.com_forward_m),
            ("tyres.longitudinal.e", self.tyres.longitudinal.e),
            ("tyres.lateral.e", self.tyres.lateral.e),
        ];
        for (field, v) in finite {
            if !v.is_finite() {
                return Err((field.into(), format!("must be a finite number, got {v}")));
            }
        }
        if !(self.brakes.max_handbrake_torque_nm.is_finite()
            && self.brakes.max_handbrake_torque_nm >= 0.0)
        {
            return Err((
                "brakes.max_handbrake_torque_nm".into(),
                "must be zero or more".into(),
            ));
        }
        if c.com_forward_m.abs() >= w.wheelbase_m / 2.0 {
            return Err((
                "chassis.com_forward_m".into(),
                "the centre of mass must lie between the axles".into(),
            ));
        }
        if c.ground_clearance_m >= c.height_m {
            return Err((
                "chassis.ground_clearance_m".into(),
                "must be below chassis.height_m".into(),
            ));
        }
        if self.tyres.longitudinal.e > 1.0 || self.tyres.lateral.e > 1.0 {
            return Err((
                "tyres".into(),
                "the curvature factor e must be at most 1 or the curve folds back".into(),
            ));
        }
        if self.gearbox.ratios.is_empty() || self.gearbox.ratios.len() > 12 {
            return Err((
                "gearbox.ratios".into(),
                "give 1 to 12 forward ratios".into(),
            ));
        }
        if let Some(r) = self
            .gearbox
            .ratios
            .iter()
            .find(|r| !(r.is_finite() && **r > 0.0))
        {
            return Err((
                "gearbox.ratios".into(),
                format!("ratios must be positive, got {r}"),
            ));
        }
        if self.gearbox.ratios.windows(2).any(|p| p[1] > p[0]) {
            return Err((
                "gearbox.ratios".into(),
                "list ratios from first gear up: each no larger than the one before".into(),
            ));
        }
        let g = &self.gearbox;
        if g.upshift_rpm > self.engine.max_rpm {
            return Err((
                "gearbox.upshift_rpm".into(),
                "must not exceed engine.max_rpm".into(),
            ));
        }
        if self.engine.idle_rpm >= self.engine.max_rpm {
            return Err((
                "engine.idle_rpm".into(),
                "must be below engine.max_rpm".into(),
            ));
        }
        // After an upshift the engine falls by the ratio step; if that lands below the downshift
        // point the box would hunt between two gears.
        for (i, p) in g.ratios.windows(2).enumerate() {
            if g.upshift_rpm * p[1] / p[0] <= g.downshift_rpm {
                return Err((
                    "gearbox.downshift_rpm".into(),
                    format!(
                        "an upshift from gear {} lands at {:.0} rpm, at or below the downshift \
                         point: the gearbox would hunt; lower downshift_rpm",
                        i + 1,
                        g.upshift_rpm * p[1] / p[0]
                    ),
                ));
            }
        }
        check_curve("engine.torque_curve", &self.engine.torque_curve, 0.0)?;
        check_curve("steering.speed_curve", &self.steering.speed_curve, 0.0)?;
        if self.steering.speed_curve.iter().any(|p| p.1 > 1.0) {
            return Err((
                "steering.speed_curve".into(),
                "shares are between 0 and 1".into(),
            ));
        }
        if self.steering.max_steer_deg >= 60.0 {
            return Err((
                "steering.max_steer_deg".into(),
                "must be below 60 degrees".into(),
            ));
        }
        if !(self.steering.rate_per_s.is_finite() && self.steering.rate_per_s > 0.0) {
            return Err((
                "steering.rate_per_s".into(),
                "must be a positive number".into(),
            ));
        }
        if let Differential::AllWheelDrive { front_share } = self.differential
            && !(0.0..=1.0).contains(&front_share)
        {
            return Err((
                "differential.front_share".into(),
                "must be between 0 and 1".into(),
            ));
        }
        Ok(())
    }
}

fn check_curve(field: &str, points: &[(f32, f32)], min_y: f32) -> Result<(), (String, String)> {
    if points.is_empty() {
        return Err((field.into(), "give at least one point".into()));
    }
    if points
        .iter()
        .any(|(x, y)| !x.is_finite() || !y.is_finite() || *y < min_y)
    {
        return Err((
            field.into(),
            format!("points must be finite with values of at least {min_y}"),
        ));
    }
    if points.windows(2).any(|p| p[1].0 <= p[0].0) {
        return Err((
            field.into(),
            "points must be in strictly rising order".into(),
        ));
    }
    Ok(())
}

/// Linear interpolation in a `(x, y)` table, flat beyond its ends.
pub(crate) fn curve_at(points: &[(f32, f32)], x: f32) -> f32 {
    let Some(first) = points.first() else {
        return 0.0;
    };
    if x <= first.0 {
        return first.1;
    }
    for p in points.windows(2) {
        let ((x0, y0), (x1, y1)) = (p[0], p[1]);
        if x <= x1 {
            return y0 + (y1 - y0) * (x - x0) / (x1 - x0);
        }
    }
    points.last().map_or(0.0, |p| p.1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_match_the_spec() {
        let p = VehicleParams::default();
        assert_eq!(p.validate(), Ok(()));
        assert_eq!(p.chassis.mass_kg, 1500.0);
        assert_eq!(p.gearbox.ratios, vec![4.0, 2.0, 1.5, 1.1, 1.0]);
        let peak = p
            .engine
            .torque_curve
            .iter()
            .copied()
            .fold((0.0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
        assert_eq!(peak, (1900.0, 500.0));
        assert_eq!(curve_at(&p.steering.speed_curve, 173.0), 0.7);
    }

    #[test]
    fn curve_interpolates_and_clamps() {
        let c = [(0.0, 1.0), (10.0, 3.0)];
        assert_eq!(curve_at(&c, -5.0), 1.0);
        assert_eq!(curve_at(&c, 5.0), 2.0);
        assert_eq!(curve_at(&c, 50.0), 3.0);
    }

    #[test]
    fn parse_errors_name_line_and_column() {
        let err = VehicleParams::parse(
            "(\n  name: \"x\",\n  chassis: (mass_kg: \"heavy\"),\n)",
            "car.ron",
        )
        .expect_err("a string mass must not parse");
        let text = err.to_string();
        assert!(text.starts_with("car.ron:3:"), "{text}");
    }

    #[test]
    fn unknown_fields_are_rejected() {
        let err = VehicleParams::parse("(chassis: (mass: 1000.0))", "car.ron")
            .expect_err("a misspelt field must not parse");
        assert!(err.to_string().contains("mass"), "{err}");
    }

    #[test]
    fn invalid_values_name_the_field() {
        let err = VehicleParams::parse("(chassis: (mass_kg: -3.0))", "car.ron")
            .expect_err("negative mass");
        assert_eq!(
            err.to_string(),
            "car.ron: chassis.mass_kg: must be a positive number, got -3"
        );
        let err = VehicleParams::parse("(gearbox: (downshift_rpm: 3000.0))", "car.ron")
            .expect_err("hunting gearbox");
        assert!(err.to_string().contains("hunt"), "{err}");
    }

    #[test]
    fn partial_files_inherit_the_reference_car() {
        let p = VehicleParams::parse("(name: \"light\", chassis: (mass_kg: 1000.0))", "x")
            .expect("valid");
        assert_eq!(p.chassis.mass_kg, 1000.0);
        assert_eq!(p.chassis.width_m, 1.8);
        assert_eq!(p.engine, EngineParams::default());
    }
}
