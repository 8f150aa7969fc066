//! The orbit camera of the 3D view: it circles a target point, Y up.

use glam::{Mat4, Vec2, Vec3};

/// A camera orbiting `target` at `distance`, turned by `yaw` about world Y and raised by
/// `pitch` above the horizon.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrbitCamera {
    /// The point looked at, m.
    pub target: Vec3,
    /// Angle about world Y, rad; 0 looks along -Z (the eye is on +Z).
    pub yaw: f32,
    /// Elevation above the horizon, rad, in (-pi/2, pi/2).
    pub pitch: f32,
    /// Eye-to-target distance, m (> 0).
    pub distance: f32,
    /// Vertical field of view, rad.
    pub fov_y: f32,
    /// Near clipping distance, m.
    pub near: f32,
    /// Far clipping distance, m.
    pub far: f32,
}

impl Default for OrbitCamera {
    /// Looks at the thesis' 30 cm cloth from the front and above, as in its fig. 4.1.
    fn default() -> Self {
        Self {
            target: Vec3::new(0.0, 0.02, 0.0),
            yaw: 0.35,
            pitch: 0.55,
            distance: 0.62,
            fov_y: 40f32.to_radians(),
            near: 0.005,
            far: 50.0,
        }
    }
}

/// Largest pitch magnitude, rad: just short of looking straight down, where yaw degenerates.
const MAX_PITCH: f32 = 1.55;

impl OrbitCamera {
    /// The renderer's framing of a cloth `size` wide lying around `centre`, with room above it
    /// for lifting (the same view `wetcloth render` chooses for a flat cloth).
    pub fn framing(centre: Vec3, size: f32) -> Self {
        let half = Vec3::new(0.5 * size, 0.0, 0.5 * size);
        let lo = centre - half;
        let hi = centre + half + Vec3::Y * (0.3 * size);
        Self::from_camera(&wetcloth_render::Camera::framing(
            lo.to_array(),
            hi.to_array(),
        ))
    }

    /// The 3/4 view of a cloth within the bounds `lo..hi` (m), with room above it for 0.3 of
    /// its largest extent, as [`OrbitCamera::framing`] leaves above the grid (a cloth of any
    /// shape, as placed).
    pub fn framing_bounds(lo: Vec3, hi: Vec3) -> Self {
        let size = (hi - lo).max_element();
        let hi = hi + Vec3::Y * (0.3 * size);
        Self::from_camera(&wetcloth_render::Camera::framing(
            lo.to_array(),
            hi.to_array(),
        ))
    }

    /// The orbit camera with the same eye, target and projection as a renderer camera (its up
    /// vector is taken to be +Y).
    pub fn from_camera(c: &wetcloth_render::Camera) -> Self {
        let target = Vec3::from_array(c.target);
        let d = Vec3::from_array(c.eye) - target;
        let distance = d.length().max(1e-6);
        Self {
            target,
            yaw: d.x.atan2(d.z),
            pitch: (d.y / distance).clamp(-1.0, 1.0).asin(),
            distance,
            fov_y: c.fov_y,
            near: c.near,
            far: c.far,
        }
    }

    /// The renderer's camera for this view.
    pub fn to_camera(&self) -> wetcloth_render::Camera {
        wetcloth_render::Camera {
            eye: self.eye().to_array(),
            target: self.target.to_array(),
            up: [0.0, 1.0, 0.0],
            fov_y: self.fov_y,
            near: self.near,
            far: self.far,
        }
    }

    /// Eye position, m.
    pub fn eye(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        self.target + self.distance * Vec3::new(cp * sy, sp, cp * cy)
    }

    /// Unit viewing direction, from the eye towards the target.
    pub fn forward(&self) -> Vec3 {
        (self.target - self.eye()).normalize()
    }

    /// World-to-view matrix (right-handed, Y up).
    pub fn view(&self) -> Mat4 {
        glam::camera::rh::view::look_at_mat4(self.eye(), self.target, Vec3::Y)
    }

    /// World-to-clip matrix for a view of the given aspect ratio, with wgpu's depth range
    /// [0, 1].
    pub fn view_proj(&self, aspect: f32) -> Mat4 {
        let proj = glam::camera::rh::proj::directx::perspective(
            self.fov_y,
            aspect.max(1e-3),
            self.near,
            self.far,
        );
        proj * self.view()
    }

    /// Turns the camera by a mouse drag of `delta` pixels.
    pub fn orbit(&mut self, delta: Vec2) {
        self.yaw -= delta.x * 0.008;
        self.pitch = (self.pitch + delta.y * 0.008).clamp(-MAX_PITCH, MAX_PITCH);
    }

    /// Slides the target (and the eye with it) so that the scene follows a mouse drag of
    /// `delta` pixels in a view `height_px` pixels high.
    pub fn pan(&mut self, delta: Vec2, height_px: f32) {
        let per_px = 2.0 * self.distance * (self.fov_y / 2.0).tan() / height_px.max(1.0);
        let fwd = self.forward();
        let right = fwd.cross(Vec3::Y).normalize_or(Vec3::X);
        let up = right.cross(fwd);
        self.target += (-delta.x * right + delta.y * up) * per_px;
    }

    /// Moves towards the target (`steps > 0`) or away from it, 10 % per step.
    pub fn zoom(&mut self, steps: f32) {
        self.distance = (self.distance * 0.9f32.powf(steps)).clamp(self.near * 4.0, self.far * 0.5);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eye_is_at_the_distance_and_looks_at_the_target() {
        let c = OrbitCamera::default();
        assert!((c.eye().distance(c.target) - c.distance).abs() < 1e-5);
        assert!(c.eye().y > c.target.y, "looks down at the table");
        assert!(c.forward().dot(c.target - c.eye()) > 0.0);
    }

    #[test]
    fn matches_the_renderer_camera() {
        let c = OrbitCamera::framing(Vec3::ZERO, 0.3);
        let r = c.to_camera();
        let back = OrbitCamera::from_camera(&r);
        assert!((back.yaw - c.yaw).abs() < 1e-5 && (back.pitch - c.pitch).abs() < 1e-5);
        // Same matrix as the renderer draws with, so picks land where the cloth is drawn.
        let (a, b) = (c.view_proj(1.5), r.view_proj(1.5));
        assert!(a.abs_diff_eq(b, 1e-4), "{a:?} vs {b:?}");
        // The whole cloth is in view.
        for corner in [[-0.15, 0.0, -0.15], [0.15, 0.0, 0.15], [0.15, 0.0, -0.15]] {
            let p = c.view_proj(1.5) * Vec3::from_array(corner).extend(1.0);
            assert!((p.x / p.w).abs() < 1.0 && (p.y / p.w).abs() < 1.0);
        }
    }

    #[test]
    fn orbit_clamps_the_pitch() {
        let mut c = OrbitCamera::default();
        c.orbit(Vec2::new(0.0, 1e5));
        assert!(c.pitch <= MAX_PITCH);
        c.orbit(Vec2::new(0.0, -1e5));
        assert!(c.pitch >= -MAX_PITCH);
    }

    #[test]
    fn pan_moves_the_target_across_the_view() {
        let mut c = OrbitCamera::default();
        let before = c.target;
        c.pan(Vec2::new(100.0, 0.0), 600.0);
        let moved = c.target - before;
        assert!(moved.dot(c.forward()).abs() < 1e-6);
        assert!(moved.length() > 0.0);
    }

    #[test]
    fn zoom_in_gets_closer() {
        let mut c = OrbitCamera::default();
        let d = c.distance;
        c.zoom(1.0);
        assert!(c.distance < d);
    }
}
