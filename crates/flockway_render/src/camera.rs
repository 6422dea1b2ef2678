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

    /// A top view that shows the box `min..max` whole inside the part `area_min..area_max` of
    /// a viewport of `viewport` pixels (the part the panels leave free), centred there.
    pub fn top_fit_area(
        min: Vec3,
        max: Vec3,
        viewport: glam::Vec2,
        area_min: glam::Vec2,
        area_max: glam::Vec2,
    ) -> Camera {
        let area = (area_max - area_min).max(glam::Vec2::splat(1.0));
        let size = (max - min).truncate().max(glam::Vec2::splat(1e-3));
        // Metres per pixel that fit the box in the area, with a margin.
        let k = (size.x / area.x).max(size.y / area.y) * 1.08;
        let half_height_m = (0.5 * k * viewport.y).max(5.0);
        let k = 2.0 * half_height_m / viewport.y.max(1.0);
        // The box's centre appears at the area's centre: x right is east, y down is south.
        let offset = 0.5 * (area_min + area_max) - 0.5 * viewport;
        let centre = 0.5 * (min + max) - Vec3::new(offset.x * k, -offset.y * k, 0.0);
        Camera::Top {
            centre,
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

impl Camera {
    /// The ray through a pixel (`px` from the top-left, in a viewport of `size` pixels):
    /// `(origin, unit direction)` in world space.
    pub fn ray(&self, px: glam::Vec2, size: glam::Vec2) -> (Vec3, Vec3) {
        let inv = self.view_proj(size.x / size.y.max(1.0)).inverse();
        let ndc = glam::Vec2::new(2.0 * px.x / size.x - 1.0, 1.0 - 2.0 * px.y / size.y);
        let near = inv.project_point3(ndc.extend(0.0));
        let far = inv.project_point3(ndc.extend(1.0));
        (near, (far - near).normalize_or(-Vec3::Z))
    }

    /// Where the ray through a pixel meets the horizontal plane at height `z`.
    pub fn ground_point(&self, px: glam::Vec2, size: glam::Vec2, z: f32) -> Option<Vec3> {
        let (o, d) = self.ray(px, size);
        if d.z.abs() < 1e-6 {
            return None;
        }
        let t = (z - o.z) / d.z;
        (t > 0.0).then(|| o + d * t)
    }

    /// The pixel a world point is drawn at, if it is in front of the camera.
    pub fn to_screen(&self, p: Vec3, size: glam::Vec2) -> Option<glam::Vec2> {
        let c = self.view_proj(size.x / size.y.max(1.0)) * p.extend(1.0);
        if c.w <= 0.0 {
            return None;
        }
        let ndc = c.truncate() / c.w;
        Some(glam::Vec2::new(
            (ndc.x + 1.0) * 0.5 * size.x,
            (1.0 - ndc.y) * 0.5 * size.y,
        ))
    }

    /// Zooms by `factor` (below 1 zooms in).
    pub fn zoom(&mut self, factor: f32) {
        match self {
            Camera::Top { half_height_m, .. } => {
                *half_height_m = (*half_height_m * factor).clamp(2.0, 50_000.0)
            }
            Camera::Orbit { distance_m, .. } => {
                *distance_m = (*distance_m * factor).clamp(3.0, 50_000.0)
            }
        }
    }

    /// Moves what is looked at by a screen drag of `delta` pixels.
    pub fn pan(&mut self, delta: glam::Vec2, size: glam::Vec2) {
        match self {
            Camera::Top {
                centre,
                half_height_m,
            } => {
                let m_per_px = 2.0 * *half_height_m / size.y.max(1.0);
                *centre += Vec3::new(-delta.x, delta.y, 0.0) * m_per_px;
            }
            Camera::Orbit {
                target,
                distance_m,
                yaw_rad,
                ..
            } => {
                let m_per_px = *distance_m * ORBIT_FOV_RAD / size.y.max(1.0);
                let right = Vec3::new(-yaw_rad.sin(), yaw_rad.cos(), 0.0);
                let fwd = Vec3::new(-yaw_rad.cos(), -yaw_rad.sin(), 0.0);
                *target += (-right * delta.x + fwd * delta.y) * m_per_px;
            }
        }
    }

    /// Turns the orbit view by a drag of `delta` pixels (the top view pans instead).
    pub fn orbit(&mut self, delta: glam::Vec2, size: glam::Vec2) {
        match self {
            Camera::Orbit {
                yaw_rad, pitch_rad, ..
            } => {
                *yaw_rad -= delta.x * 0.01;
                *pitch_rad = (*pitch_rad + delta.y * 0.01).clamp(0.05, 1.55);
            }
            Camera::Top { .. } => self.pan(delta, size),
        }
    }

    /// Centres the view on `p`, keeping the zoom.
    pub fn look_at(&mut self, p: Vec3) {
        match self {
            Camera::Top { centre, .. } => *centre = p,
            Camera::Orbit { target, .. } => *target = p,
        }
    }
}

#[cfg(test)]
mod picking_tests {
    use super::*;
    use glam::Vec2;

    #[test]
    fn a_pixel_and_its_ground_point_round_trip_in_both_views() {
        let (min, max) = (Vec3::new(-100.0, -50.0, 0.0), Vec3::new(100.0, 50.0, 0.0));
        let size = Vec2::new(1280.0, 720.0);
        for cam in [
            Camera::top_fit(min, max, size.x / size.y),
            Camera::orbit_fit(min, max),
        ] {
            for px in [
                Vec2::new(640.0, 360.0),
                Vec2::new(300.0, 500.0),
                Vec2::new(1000.0, 200.0),
            ] {
                let Some(g) = cam.ground_point(px, size, 0.0) else {
                    continue;
                };
                let back = cam.to_screen(g, size).expect("in front");
                assert!((back - px).length() < 0.5, "{cam:?}: {px} → {g} → {back}");
            }
        }
    }

    #[test]
    fn a_fit_to_the_free_area_shows_the_box_whole_and_centred_there() {
        let (min, max) = (Vec3::new(-100.0, -50.0, 0.0), Vec3::new(60.0, 90.0, 0.0));
        let size = Vec2::new(1400.0, 860.0);
        let (lo, hi) = (Vec2::new(0.0, 25.0), Vec2::new(1060.0, 835.0));
        let cam = Camera::top_fit_area(min, max, size, lo, hi);
        let centre = cam.to_screen(0.5 * (min + max), size).expect("in view");
        assert!((centre - 0.5 * (lo + hi)).length() < 0.5, "{centre}");
        for corner in [
            min,
            max,
            Vec3::new(min.x, max.y, 0.0),
            Vec3::new(max.x, min.y, 0.0),
        ] {
            let p = cam.to_screen(corner, size).expect("in view");
            assert!(p.cmpge(lo).all() && p.cmple(hi).all(), "{corner} at {p}");
        }
    }
}
