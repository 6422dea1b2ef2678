//! Engine, clutch, automatic gearbox and differential, and the implicit spin update that couples
//! them to the wheels.

use crate::params::{EngineParams, GearboxParams, VehicleParams, curve_at};
use flockway_core::arrays::array4;
use wide::f32x4;

/// Radians per second in one rpm.
pub const RPM_TO_RAD_S: f32 = std::f32::consts::TAU / 60.0;

/// Forward speed below which the car counts as standing, m/s: throttle below zero then
/// selects reverse instead of braking.
pub const STANDSTILL_MPS: f32 = 0.5;

/// What the driver's single throttle axis means right now, after the gearbox has interpreted it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Pedals {
    /// Accelerator, 0..1.
    pub accelerator: f32,
    /// Service brake, 0..1.
    pub brake: f32,
}

/// The automatic gearbox: the selected gear and an in-progress shift.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gearbox {
    /// −1 reverse, 0 neutral, 1.. forward gears.
    pub gear: i8,
    /// Gear being shifted into while `shift_left_s > 0`.
    pub target: i8,
    /// Time left in the current shift, s (clutch open meanwhile).
    pub shift_left_s: f32,
}

impl Default for Gearbox {
    fn default() -> Self {
        Gearbox {
            gear: 1,
            target: 1,
            shift_left_s: 0.0,
        }
    }
}

impl Gearbox {
    /// Whether a shift is in progress.
    pub fn shifting(&self) -> bool {
        self.shift_left_s > 0.0
    }

    /// Signed overall ratio (gear × final drive) of a gear; reverse is negative, neutral 0.
    pub fn ratio_of(p: &GearboxParams, gear: i8) -> f32 {
        match gear {
            g if g < 0 => -p.reverse_ratio * p.final_drive,
            0 => 0.0,
            g => p.ratios.get(g as usize - 1).copied().unwrap_or(0.0) * p.final_drive,
        }
    }

    /// Signed overall ratio of the current gear.
    pub fn ratio(&self, p: &GearboxParams) -> f32 {
        Gearbox::ratio_of(p, self.gear)
    }

    /// Picks the gear whose engine speed at `forward_mps` lies in the shift band, for a car that
    /// starts moving.
    pub fn for_speed(p: &GearboxParams, forward_mps: f32, wheel_radius_m: f32) -> Gearbox {
        let mut gear = 1i8;
        for g in 1..=p.ratios.len() as i8 {
            let rpm = forward_mps / wheel_radius_m * Gearbox::ratio_of(p, g) / RPM_TO_RAD_S;
            gear = g;
            if rpm < p.upshift_rpm * 0.9 {
                break;
            }
        }
        Gearbox {
            gear,
            target: gear,
            shift_left_s: 0.0,
        }
    }

    /// Advances one step: interprets the throttle axis (negative brakes, or selects reverse
    /// from a standstill) and shifts on the speed of the gearbox input, `input_rpm` (the wheels'
    /// speed through the current ratio, not the slipping engine).
    // Inlined into both builds (x86-64 and AVX2) of the per-car functions that call it.
    #[inline(always)]
    pub fn update(
        &mut self,
        p: &GearboxParams,
        throttle: f32,
        forward_mps: f32,
        input_rpm: f32,
        dt_s: f32,
    ) -> Pedals {
        let throttle = if throttle.is_finite() {
            throttle.clamp(-1.0, 1.0)
        } else {
            0.0
        };
        if self.shifting() {
            self.shift_left_s -= dt_s;
            // A quarter step of slack absorbs the rounding of summed steps.
            if self.shift_left_s <= 0.25 * dt_s {
                self.shift_left_s = 0.0;
                self.gear = self.target;
            }
        }
        let reversing = self.target < 0;
        let pedals = if !reversing {
            if throttle >= 0.0 {
                Pedals {
                    accelerator: throttle,
                    brake: 0.0,
                }
            } else if forward_mps > STANDSTILL_MPS {
                Pedals {
                    accelerator: 0.0,
                    brake: -throttle,
                }
            } else {
                self.select(-1);
                Pedals {
                    accelerator: -throttle,
                    brake: 0.0,
                }
            }
        } else if throttle <= 0.0 {
            Pedals {
                accelerator: -throttle,
                brake: 0.0,
            }
        } else if forward_mps < -STANDSTILL_MPS {
            Pedals {
                accelerator: 0.0,
                brake: throttle,
            }
        } else {
            self.select(1);
            Pedals {
                accelerator: throttle,
                brake: 0.0,
            }
        };
        if !self.shifting() && self.gear > 0 {
            let top = p.ratios.len() as i8;
            if input_rpm > p.upshift_rpm && self.gear < top {
                self.shift_to(self.gear + 1, p.shift_time_s);
            } else if input_rpm < p.downshift_rpm && self.gear > 1 {
                self.shift_to(self.gear - 1, p.shift_time_s);
            }
        }
        pedals
    }

    /// Changes direction at a standstill at once (no clutch time: the car is not moving).
    fn select(&mut self, gear: i8) {
        self.gear = gear;
        self.target = gear;
        self.shift_left_s = 0.0;
    }

    fn shift_to(&mut self, gear: i8, time_s: f32) {
        self.target = gear;
        if time_s > 0.0 {
            self.shift_left_s = time_s;
        } else {
            self.gear = gear;
        }
    }
}

impl EngineParams {
    /// Full-throttle torque at an engine speed, N·m (zero above the rev limiter).
    pub fn torque_at(&self, rpm: f32) -> f32 {
        if rpm > self.max_rpm {
            0.0
        } else {
            curve_at(&self.torque_curve, rpm)
        }
    }
}

/// The inputs of one spin update for the four wheels, in order FL, FR, RL, RR.
#[derive(Debug, Clone, Copy)]
pub struct SpinInput {
    /// Wheel spin speeds at the start of the update (after brakes), rad/s.
    pub omega: [f32; 4],
    /// Wheel spin speeds at which the tyre forces were evaluated, rad/s.
    pub omega_tyre: [f32; 4],
    /// Longitudinal tyre force on each wheel at `omega_tyre`, N (positive pushes the car
    /// forward, so it slows a forward-spinning wheel).
    pub tyre_force_n: [f32; 4],
    /// How fast that force grows with wheel speed, N·s/rad: the tyre is integrated implicitly,
    /// as it is far stiffer than a wheel's inertia at low speed.
    pub tyre_slope: [f32; 4],
    /// Engine speed now, rad/s.
    pub engine_omega: f32,
    /// Accelerator, 0..1.
    pub accelerator: f32,
    /// Signed overall ratio, gearbox × final drive.
    pub ratio: f32,
    /// Clutch engagement, 0 (open) ..1.
    pub clutch: f32,
}

/// The result of a spin update.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpinOutput {
    /// Wheel spin speeds after drive and tyre torques, rad/s.
    pub omega: [f32; 4],
    /// Longitudinal tyre force consistent with the new spin speeds, N.
    pub tyre_force_n: [f32; 4],
    /// Engine speed, rad/s.
    pub engine_omega: f32,
    /// Torque the driveline put on each wheel this step, N·m.
    pub drive_torque_nm: [f32; 4],
}

/// Derived drivetrain constants of one vehicle type.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Driveline {
    /// Spin inertia of one wheel, kg·m².
    pub wheel_inertia: f32,
    /// Wheel radius, m.
    pub radius_m: f32,
    /// Torque share of each wheel.
    pub shares: [f32; 4],
    /// Wheel spin damping, N·m·s/rad.
    pub wheel_damping: f32,
    /// Engine inertia, kg·m².
    pub engine_inertia: f32,
    /// Clutch strength, N·m·s/rad.
    pub clutch_strength: f32,
    /// Idle speed, rad/s.
    pub idle_omega: f32,
    /// Rev limiter, rad/s.
    pub max_omega: f32,
    /// The idle governor's most torque, a third of the torque at idle, N·m.
    pub governor_max_nm: f32,
}

impl Driveline {
    /// Derives the constants from a vehicle definition.
    pub fn new(p: &VehicleParams) -> Driveline {
        Driveline {
            wheel_inertia: 0.5 * p.wheels.mass_kg * p.wheels.radius_m * p.wheels.radius_m,
            radius_m: p.wheels.radius_m,
            shares: p.differential.shares(),
            wheel_damping: p.wheels.damping_nms,
            engine_inertia: p.engine.inertia_kg_m2,
            clutch_strength: p.clutch.strength_nms,
            idle_omega: p.engine.idle_rpm * RPM_TO_RAD_S,
            max_omega: p.engine.max_rpm * RPM_TO_RAD_S,
            governor_max_nm: p.engine.torque_at(p.engine.idle_rpm) / 3.0,
        }
    }

    /// One backward-Euler step of engine and wheel spin, coupled through clutch, gearbox and
    /// differential, with the tyre forces held fixed. The clutch is stiff next to a wheel's small
    /// inertia (explicit integration would diverge in low gears), but the coupling has rank one —
    /// every wheel sees the same clutch slip through the differential — so the implicit system
    /// solves in closed form.
    // Inlined into both builds (x86-64 and AVX2) of the per-car functions that call it.
    #[inline(always)]
    pub fn spin(&self, engine: &EngineParams, input: &SpinInput, dt_s: f32) -> SpinOutput {
        let h = dt_s;
        let g = input.ratio;
        let k = self.clutch_strength * input.clutch.clamp(0.0, 1.0);
        let thr = input.accelerator.clamp(0.0, 1.0);
        let zero_throttle_damping = if input.clutch > 0.5 {
            engine.damping_zero_throttle_clutch_engaged
        } else {
            engine.damping_zero_throttle_clutch_disengaged
        };
        let c_e =
            zero_throttle_damping + (engine.damping_full_throttle - zero_throttle_damping) * thr;
        let rpm = input.engine_omega / RPM_TO_RAD_S;
        // An idle governor opens the throttle as the engine sags below idle, with at most a
        // third of the idle torque, so a dragging clutch can pull it down but not stall it.
        let governor =
            (50.0 * (self.idle_omega - input.engine_omega)).clamp(0.0, self.governor_max_nm);
        let t_e = thr * engine.torque_at(rpm) + governor * (1.0 - thr);

        // Wheel i: I (ω_i' − ω_i) = h (T_i − F_i(ω_i') r − c_w ω_i'), with the tyre linearised,
        // F_i(ω') = F_i + k_i (ω' − ω_tyre). That gives ω_i' = a_i + b_i (ω_e' − G ω̄'), where
        // ω̄' = Σ s_i ω_i' is the gearbox output speed.
        let iw = self.wheel_inertia;
        let r = self.radius_m;
        // The four wheels at once, each lane in the scalar order of operations (the slope's
        // `f32::max` and the sums, in wheel order, stay scalar).
        let slope = f32x4::new(array4(|i| input.tyre_slope[i].max(0.0)));
        let (h4, iw4) = (f32x4::splat(h), f32x4::splat(iw));
        let shares = f32x4::new(self.shares);
        let tyre_force = f32x4::new(input.tyre_force_n);
        let omega_tyre = f32x4::new(input.omega_tyre);
        let kr = slope * f32x4::splat(r);
        let denom = (iw4 + f32x4::splat(h * self.wheel_damping)) + h4 * kr;
        let a = ((iw4 * f32x4::new(input.omega) - f32x4::splat(h * r) * tyre_force)
            + (h4 * kr) * omega_tyre)
            / denom;
        let b = ((h4 * shares) * f32x4::splat(g)) * f32x4::splat(k) / denom;
        let (a_share, b_share) = ((shares * a).to_array(), (shares * b).to_array());
        let (mut sa, mut sb) = (0.0f32, 0.0f32);
        for i in 0..4 {
            sa += a_share[i];
            sb += b_share[i];
        }
        // ω̄' = (A + B ω_e') / (1 + G B); substitute into the engine equation
        // I_e (ω_e' − ω_e) = h (T_e − c ω_e' − K (ω_e' − G ω̄')).
        let q = 1.0 + g * sb;
        let lhs = self.engine_inertia + h * c_e + h * k - h * k * g * sb / q;
        let rhs = self.engine_inertia * input.engine_omega + h * t_e + h * k * g * sa / q;
        let mut we = rhs / lhs;
        // The rev limiter already cut the torque; the clamp only guards the extremes.
        we = we.clamp(0.5 * self.idle_omega, self.max_omega * 1.05);
        let wbar = (sa + sb * we) / q;
        let clutch_torque = k * (we - g * wbar);
        let drive = (shares * f32x4::splat(g)) * f32x4::splat(clutch_torque);
        let omega = a + b * f32x4::splat(we - g * wbar);
        let force = tyre_force + slope * (omega - omega_tyre);
        let (omega, drive, force) = (omega.to_array(), drive.to_array(), force.to_array());
        SpinOutput {
            omega,
            tyre_force_n: force,
            engine_omega: we,
            drive_torque_nm: drive,
        }
    }
}

/// Moves a wheel speed towards zero by a braking torque's worth of change, never past zero
/// (a brake holds; it does not spin the wheel backwards).
pub fn apply_brake(omega: f32, torque_nm: f32, inertia: f32, dt_s: f32) -> f32 {
    let dw = torque_nm.max(0.0) * dt_s / inertia;
    if omega > dw {
        omega - dw
    } else if omega < -dw {
        omega + dw
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::{Differential, VehicleParams};

    const H: f32 = 1.0 / 120.0;

    fn rpm_at(p: &GearboxParams, gear: i8, v: f32) -> f32 {
        v / 0.35 * Gearbox::ratio_of(p, gear) / RPM_TO_RAD_S
    }

    #[test]
    fn gearbox_shifts_up_through_all_gears_and_back_down() {
        let p = GearboxParams::default();
        let mut gb = Gearbox::default();
        let mut v = 0.0f32;
        let mut seen = vec![1i8];
        for _ in 0..(120 * 60) {
            v += 2.0 * H;
            gb.update(&p, 1.0, v, rpm_at(&p, gb.gear, v), H);
            if *seen.last().expect("non-empty") != gb.gear {
                seen.push(gb.gear);
            }
        }
        assert_eq!(seen, vec![1, 2, 3, 4, 5]);
        // Decelerating, it comes back down to first.
        let mut down = vec![5i8];
        while v > 1.0 {
            v -= 2.0 * H;
            gb.update(&p, 0.0, v, rpm_at(&p, gb.gear, v), H);
            if *down.last().expect("non-empty") != gb.gear {
                down.push(gb.gear);
            }
        }
        assert_eq!(down, vec![5, 4, 3, 2, 1]);
    }

    #[test]
    fn upshift_waits_for_the_shift_time_with_the_clutch_open() {
        let p = GearboxParams::default();
        let mut gb = Gearbox::default();
        gb.update(&p, 1.0, 10.0, p.upshift_rpm + 1.0, H);
        assert!(gb.shifting());
        assert_eq!((gb.gear, gb.target), (1, 2));
        let steps = (p.shift_time_s / H).ceil() as usize;
        for _ in 0..steps {
            gb.update(&p, 1.0, 10.0, 3000.0, H);
        }
        assert!(!gb.shifting());
        assert_eq!(gb.gear, 2);
    }

    #[test]
    fn negative_throttle_brakes_when_moving_and_reverses_at_a_standstill() {
        let p = GearboxParams::default();
        let mut gb = Gearbox::default();
        let pedals = gb.update(&p, -0.6, 10.0, 2000.0, H);
        assert_eq!(
            pedals,
            Pedals {
                accelerator: 0.0,
                brake: 0.6
            }
        );
        assert_eq!(gb.gear, 1);
        let pedals = gb.update(&p, -0.6, 0.1, 0.0, H);
        assert_eq!(
            pedals,
            Pedals {
                accelerator: 0.6,
                brake: 0.0
            }
        );
        assert_eq!(gb.gear, -1);
        assert!(gb.ratio(&p) < 0.0);
        // Going backwards, positive throttle brakes; at a standstill it selects first again.
        let pedals = gb.update(&p, 0.5, -3.0, 500.0, H);
        assert_eq!(
            pedals,
            Pedals {
                accelerator: 0.0,
                brake: 0.5
            }
        );
        gb.update(&p, 0.5, 0.0, 0.0, H);
        assert_eq!(gb.gear, 1);
        // Non-finite input is treated as no input.
        assert_eq!(gb.update(&p, f32::NAN, 5.0, 1500.0, H), Pedals::default());
    }

    #[test]
    fn gear_for_speed_keeps_the_engine_in_its_band() {
        let p = GearboxParams::default();
        assert_eq!(Gearbox::for_speed(&p, 0.0, 0.35).gear, 1);
        for kmh in [20.0f32, 50.0, 80.0, 120.0, 160.0] {
            let v = kmh / 3.6;
            let gb = Gearbox::for_speed(&p, v, 0.35);
            let rpm = rpm_at(&p, gb.gear, v);
            let top = p.ratios.len() as i8;
            assert!(
                gb.gear == top || rpm < p.upshift_rpm,
                "{kmh} km/h: gear {} at {rpm} rpm",
                gb.gear
            );
            assert!(
                rpm > p.downshift_rpm,
                "{kmh} km/h: gear {} at {rpm} rpm",
                gb.gear
            );
        }
    }

    #[test]
    fn brake_stops_a_wheel_without_reversing_it() {
        assert_eq!(apply_brake(1.0, 1500.0, 1.225, H), 0.0);
        assert_eq!(apply_brake(-1.0, 1500.0, 1.225, H), 0.0);
        let w = apply_brake(100.0, 1500.0, 1.225, H);
        assert!((w - (100.0 - 1500.0 * H / 1.225)).abs() < 1e-4);
    }

    #[test]
    fn implicit_spin_is_stable_with_free_wheels_in_first_gear() {
        // Wheels in the air (no tyre force) at full throttle in first: an explicit step would
        // diverge; the implicit one converges to engine and wheels turning together.
        let p = VehicleParams::default();
        let d = Driveline::new(&p);
        let g = Gearbox::ratio_of(&p.gearbox, 1);
        let mut omega = [0.0f32; 4];
        let mut we = d.idle_omega;
        for _ in 0..240 {
            let out = d.spin(
                &p.engine,
                &SpinInput {
                    omega,
                    omega_tyre: omega,
                    tyre_force_n: [0.0; 4],
                    tyre_slope: [0.0; 4],
                    engine_omega: we,
                    accelerator: 1.0,
                    ratio: g,
                    clutch: 1.0,
                },
                H,
            );
            omega = out.omega;
            we = out.engine_omega;
            assert!(omega.iter().all(|w| w.is_finite() && *w >= -1e-3));
        }
        // Free-revving it reaches the rev limiter, with the wheels following through the ratio.
        assert!(we >= d.max_omega * 0.95, "{we}");
        let wbar: f32 = (0..4).map(|i| d.shares[i] * omega[i]).sum();
        assert!(
            (we - g * wbar).abs() < we * 0.25,
            "engine {we}, wheels {}",
            g * wbar
        );
    }

    #[test]
    fn engine_torque_follows_the_curve_and_the_limiter() {
        let e = EngineParams::default();
        assert_eq!(e.torque_at(1900.0), 500.0);
        assert!(e.torque_at(5000.0) < e.torque_at(1900.0));
        assert_eq!(e.torque_at(5801.0), 0.0);
    }

    /// The spin update wheel by wheel, in scalar arithmetic: what the four-wide one must
    /// reproduce bit for bit.
    fn spin_per_wheel(d: &Driveline, e: &EngineParams, input: &SpinInput, h: f32) -> SpinOutput {
        let (g, k) = (
            input.ratio,
            d.clutch_strength * input.clutch.clamp(0.0, 1.0),
        );
        let thr = input.accelerator.clamp(0.0, 1.0);
        let zero = if input.clutch > 0.5 {
            e.damping_zero_throttle_clutch_engaged
        } else {
            e.damping_zero_throttle_clutch_disengaged
        };
        let c_e = zero + (e.damping_full_throttle - zero) * thr;
        let governor =
            (50.0 * (d.idle_omega - input.engine_omega)).clamp(0.0, e.torque_at(e.idle_rpm) / 3.0);
        let t_e = thr * e.torque_at(input.engine_omega / RPM_TO_RAD_S) + governor * (1.0 - thr);
        let (iw, r) = (d.wheel_inertia, d.radius_m);
        let (mut a, mut b) = ([0.0f32; 4], [0.0f32; 4]);
        let (mut sa, mut sb) = (0.0f32, 0.0f32);
        for i in 0..4 {
            let kr = input.tyre_slope[i].max(0.0) * r;
            let denom = iw + h * d.wheel_damping + h * kr;
            a[i] = (iw * input.omega[i] - h * r * input.tyre_force_n[i]
                + h * kr * input.omega_tyre[i])
                / denom;
            b[i] = h * d.shares[i] * g * k / denom;
            sa += d.shares[i] * a[i];
            sb += d.shares[i] * b[i];
        }
        let q = 1.0 + g * sb;
        let lhs = d.engine_inertia + h * c_e + h * k - h * k * g * sb / q;
        let rhs = d.engine_inertia * input.engine_omega + h * t_e + h * k * g * sa / q;
        let we = (rhs / lhs).clamp(0.5 * d.idle_omega, d.max_omega * 1.05);
        let wbar = (sa + sb * we) / q;
        let clutch_torque = k * (we - g * wbar);
        let mut out = SpinOutput {
            omega: [0.0; 4],
            tyre_force_n: [0.0; 4],
            engine_omega: we,
            drive_torque_nm: [0.0; 4],
        };
        for i in 0..4 {
            out.drive_torque_nm[i] = d.shares[i] * g * clutch_torque;
            out.omega[i] = a[i] + b[i] * (we - g * wbar);
            out.tyre_force_n[i] = input.tyre_force_n[i]
                + input.tyre_slope[i].max(0.0) * (out.omega[i] - input.omega_tyre[i]);
        }
        out
    }

    #[test]
    fn the_four_wide_spin_has_the_per_wheel_bits() {
        // Every differential (front, rear, all-wheel drive), gears forward and reverse and
        // neutral, the clutch open, slipping and closed, wheels spinning either way, and
        // slopes and forces of either sign including signed zeros.
        let bits = |o: &SpinOutput| {
            let words = |v: [f32; 4]| v.map(f32::to_bits);
            (
                words(o.omega),
                words(o.tyre_force_n),
                o.engine_omega.to_bits(),
                words(o.drive_torque_nm),
            )
        };
        let mut next = crate::lanes::uniform(0x2545_f491);
        let signed = [0.0f32, -0.0, 1.0e-30, -250.0];
        let mut checked = 0;
        for drive in [
            Differential::FrontWheelDrive,
            Differential::RearWheelDrive,
            Differential::AllWheelDrive { front_share: 0.4 },
        ] {
            let p = VehicleParams {
                differential: drive,
                ..VehicleParams::default()
            };
            let d = Driveline::new(&p);
            for gear in [-1i8, 0, 1, 2, 5] {
                let ratio = Gearbox::ratio_of(&p.gearbox, gear);
                for clutch in [0.0f32, 0.3, 1.0] {
                    for n in 0..40 {
                        let omega = array4(|_| next(-30.0, 120.0));
                        let input = SpinInput {
                            omega,
                            omega_tyre: array4(|i| omega[i] + next(-2.0, 2.0)),
                            tyre_force_n: array4(|i| {
                                if n % 5 == 0 {
                                    signed[i]
                                } else {
                                    next(-6000.0, 6000.0)
                                }
                            }),
                            tyre_slope: array4(|i| {
                                if n % 7 == 0 {
                                    signed[3 - i]
                                } else {
                                    next(-500.0, 40_000.0)
                                }
                            }),
                            engine_omega: next(20.0, 700.0),
                            accelerator: next(-0.2, 1.2),
                            ratio,
                            clutch,
                        };
                        let want = spin_per_wheel(&d, &p.engine, &input, H);
                        let got = d.spin(&p.engine, &input, H);
                        assert_eq!(bits(&got), bits(&want), "{input:?}");
                        checked += 1;
                    }
                }
            }
        }
        assert_eq!(checked, 3 * 5 * 3 * 40);
    }
}
