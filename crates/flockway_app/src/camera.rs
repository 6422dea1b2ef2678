//! Cameras: a top-down view for editing and a perspective orbit view.

use glam::camera::rh::{proj::directx, view::look_at_mat4};
use glam::{Mat4, Vec3};

/// How the scene is looked at.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Camera {
    /// Straight down, orthographic: `centre` in the middle, `half_height_m` metres to the top edge.
    Top {
        /// Point on the ground in the middle of the view.
        centre: Vec3,
        /// Metres from the middle to the top edge.
        half_height_m: f32,
    },
    /// Perspective, orbiting `target` at `distance_m`; yaw from +x counter-clockwise, pitch up.
    Orbit {
        /// The point looked at.
        target: Vec3,
        /// Distance from the target, metres.
        distance_m: f32,
        /// Heading of the camera around the target, radians.
        yaw_rad: f32,
        /// Elevation above the ground plane, radians.
        pitch_rad: f32,
    },
}

/// Vertical field of view of the orbit camera, radians.
pub const ORBIT_FOV_RAD: f32 = 0.8;

impl Camera {
    /// A top view that shows the box `min..max` whole at the given aspect (width / height).
    pub fn top_fit(min: Vec3, max: Vec3, aspect: f32) -> Camera {
        let half = 0.5 * (max - min);
        let half_height_m = (half.y.max(half.x / aspect.max(1e-3)) * 1.08).max(5.0);
        Camera::Top {
            centre: 0.5 * (min + max),
            half_height_m,
        }
    }

    /// An orbit view from the south-west, high enough to see the box `min..max` whole.
    pub fn orbit_fit(min: Vec3, max: Vec3) -> Camera {
        let radius = (0.5 * (max - min)).length().max(5.0);
        Camera::Orbit {
            target: 0.5 * (min + max),
            distance_m: radius / (0.5 * ORBIT_FOV_RAD).sin() * 0.8,
            yaw_rad: -2.2,
            pitch_rad: 0.62,
        }
    }

    /// World to clip space for a viewport of the given aspect (width / height).
    pub fn view_proj(&self, aspect: f32) -> Mat4 {
        match *self {
            Camera::Top {
                centre,
                half_height_m,
            } => {
                let eye = centre + Vec3::Z * 1000.0;
                let view = look_at_mat4(eye, centre, Vec3::Y);
                let (hw, hh) = (half_height_m * aspect, half_height_m);
                directx::orthographic(-hw, hw, -hh, hh, 1.0, 2000.0) * view
            }
            Camera::Orbit {
                target,
                distance_m,
                yaw_rad,
                pitch_rad,
            } => {
                let dir = Vec3::new(
                    pitch_rad.cos() * yaw_rad.cos(),
                    pitch_rad.cos() * yaw_rad.sin(),
                    pitch_rad.sin(),
                );
                let eye = target + dir * distance_m;
                let view = look_at_mat4(eye, target, Vec3::Z);
                let near = (distance_m * 0.01).max(0.1);
                directx::perspective(ORBIT_FOV_RAD, aspect, near, distance_m * 4.0 + 100.0) * view
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fitted_views_see_the_whole_box() {
        let (min, max) = (Vec3::new(-100.0, -40.0, 0.0), Vec3::new(300.0, 60.0, 2.0));
        for cam in [
            Camera::top_fit(min, max, 16.0 / 9.0),
            Camera::orbit_fit(min, max),
        ] {
            let vp = cam.view_proj(16.0 / 9.0);
            for x in [min.x, max.x] {
                for y in [min.y, max.y] {
                    let c = vp * Vec3::new(x, y, 0.0).extend(1.0);
                    let ndc = c.truncate() / c.w;
                    assert!(ndc.x.abs() <= 1.0 && ndc.y.abs() <= 1.0, "{cam:?}: {ndc}");
                    assert!((0.0..=1.0).contains(&ndc.z), "{cam:?}: depth {}", ndc.z);
                }
            }
        }
    }
}
