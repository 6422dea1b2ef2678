//! Steering: the speed-dependent lock and Ackermann geometry.

use crate::params::{SteeringParams, curve_at};

/// Road-wheel angles (left, right) in radians, positive turning left, for a centre-line angle.
/// Ackermann geometry: both front wheels point at one turning centre on the rear axle line, so
/// the inner wheel turns more than the outer.
pub fn ackermann(center_rad: f32, wheelbase_m: f32, track_m: f32) -> (f32, f32) {
    if center_rad.abs() < 1.0e-6 {
        return (center_rad, center_rad);
    }
    // Turning radius of the rear-axle centre; signed, positive when the centre is to the left.
    let radius = wheelbase_m / libm::tanf(center_rad);
    let left = libm::atanf(wheelbase_m / (radius - track_m / 2.0));
    let right = libm::atanf(wheelbase_m / (radius + track_m / 2.0));
    (left, right)
}

impl SteeringParams {
    /// Centre-line steering angle, radians, for an input in [-1, 1] at a speed: full lock scaled
    /// by the speed curve.
    pub fn center_angle_rad(&self, input: f32, speed_kmh: f32) -> f32 {
        let share = curve_at(&self.speed_curve, speed_kmh.abs()).clamp(0.0, 1.0);
        input.clamp(-1.0, 1.0) * share * self.max_steer_deg.to_radians()
    }
}

/// Moves the steering position towards the driver's input at the steering rate.
pub fn slew(current: f32, target: f32, rate_per_s: f32, dt_s: f32) -> f32 {
    let target = if target.is_finite() {
        target.clamp(-1.0, 1.0)
    } else {
        0.0
    };
    let max_step = 2.0 * rate_per_s * dt_s;
    current + (target - current).clamp(-max_step, max_step)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ackermann_inner_wheel_turns_more_and_both_meet_one_centre() {
        let (l, r) = ackermann(0.2, 2.8, 1.56);
        assert!(l > 0.2 && r < 0.2 && r > 0.0, "{l} {r}");
        // Hand computation: R = 2.8 / tan 0.2 = 13.8128; inner atan(2.8 / 13.0328) = 0.211625,
        // outer atan(2.8 / 14.5928) = 0.189571.
        assert!((l - 0.211_63).abs() < 1e-4, "{l}");
        assert!((r - 0.189_57).abs() < 1e-4, "{r}");
        // Both axes pass through the same point on the rear axle line.
        let centre_l = 2.8 / l.tan() + 0.78;
        let centre_r = 2.8 / r.tan() - 0.78;
        assert!((centre_l - centre_r).abs() < 1e-3);
        // Turning right mirrors it.
        let (l2, r2) = ackermann(-0.2, 2.8, 1.56);
        assert!((l2 + r).abs() < 1e-6 && (r2 + l).abs() < 1e-6);
        assert_eq!(ackermann(0.0, 2.8, 1.56), (0.0, 0.0));
    }

    #[test]
    fn lock_falls_to_70_percent_at_top_speed() {
        let p = SteeringParams::default();
        let full = p.max_steer_deg.to_radians();
        assert!((p.center_angle_rad(1.0, 0.0) - full).abs() < 1e-6);
        assert!((p.center_angle_rad(-1.0, 173.0) + 0.7 * full).abs() < 1e-6);
        assert!((p.center_angle_rad(1.0, 300.0) - 0.7 * full).abs() < 1e-6);
        assert!(p.center_angle_rad(5.0, 0.0) <= full);
    }

    #[test]
    fn slew_limits_the_steering_rate() {
        let s = slew(0.0, 1.0, 4.0, 1.0 / 120.0);
        assert!((s - 8.0 / 120.0).abs() < 1e-6);
        assert_eq!(slew(0.99, 1.0, 4.0, 1.0 / 120.0), 1.0);
        assert_eq!(slew(0.5, f32::NAN, 4.0, 1.0), 0.0);
    }
}
