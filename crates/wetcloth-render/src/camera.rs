//! A look-at perspective camera, with orbit and auto-framing constructors.
//!
//! World space is right-handed with Y up (the simulator's convention). Projections follow the
//! WebGPU convention: clip-space depth in [0, 1], NDC y up.

use glam::{Mat4, Vec3};

/// A perspective camera looking from `eye` at `target`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Position of the eye, m.
    pub eye: [f32; 3],
    /// Point the camera looks at, m.
    pub target: [f32; 3],
    /// Up direction (need not be unit or orthogonal to the view direction).
    pub up: [f32; 3],
    /// Vertical field of view, radians.
    pub fov_y: f32,
    /// Near clipping distance, m (> 0).
    pub near: f32,
    /// Far clipping distance, m (> `near`).
    pub far: f32,
}

/// Default vertical field of view: 35 degrees, a slightly long lens that keeps the cloth's
/// proportions (a wide lens exaggerates the near corner of the table).
pub const DEFAULT_FOV_Y: f32 = 35.0 * std::f32::consts::PI / 180.0;

/// Yaw of [`Camera::framing`]'s view, radians (35 degrees: a 3/4 view).
pub const FRAMING_YAW: f32 = 35.0 * std::f32::consts::PI / 180.0;

/// Pitch of [`Camera::framing`]'s view above the horizon, radians (32 degrees).
pub const FRAMING_PITCH: f32 = 32.0 * std::f32::consts::PI / 180.0;

impl Camera {
    /// A camera on a sphere around `target`: `yaw` turns about the vertical (0 looks from +Z
    /// towards -Z, positive turns towards +X), `pitch` raises the eye above the horizon (both
    /// radians), at `distance` metres. Near and far planes scale with the distance.
    pub fn orbit(target: [f32; 3], yaw: f32, pitch: f32, distance: f32) -> Self {
        let distance = distance.max(1e-4);
        let t = Vec3::from(target);
        let dir = Vec3::new(
            pitch.cos() * yaw.sin(),
            pitch.sin(),
            pitch.cos() * yaw.cos(),
        );
        let eye = t + dir * distance;
        Self {
            eye: eye.to_array(),
            target,
            up: [0.0, 1.0, 0.0],
            fov_y: DEFAULT_FOV_Y,
            near: distance * 0.01,
            far: distance * 100.0,
        }
    }

    /// A pleasant 3/4 view from above (yaw [`FRAMING_YAW`], pitch [`FRAMING_PITCH`]) that fits
    /// the box `bounds_min..bounds_max` in a frame of aspect ratio 4:3 or wider with a small
    /// margin, looking at the box centre.
    pub fn framing(bounds_min: [f32; 3], bounds_max: [f32; 3]) -> Self {
        Self::framing_from(bounds_min, bounds_max, FRAMING_YAW, FRAMING_PITCH)
    }

    /// Like [`Camera::framing`], from the given `yaw` and `pitch` (radians, as in
    /// [`Camera::orbit`]), for a 4:3 frame.
    pub fn framing_from(bounds_min: [f32; 3], bounds_max: [f32; 3], yaw: f32, pitch: f32) -> Self {
        Self::framing_aspect(bounds_min, bounds_max, yaw, pitch, 4.0 / 3.0)
    }

    /// Like [`Camera::framing_from`], filling a frame of the given width / height `aspect`.
    pub fn framing_aspect(
        bounds_min: [f32; 3],
        bounds_max: [f32; 3],
        yaw: f32,
        pitch: f32,
        aspect: f32,
    ) -> Self {
        let aspect = if aspect.is_finite() && aspect > 0.0 {
            aspect
        } else {
            4.0 / 3.0
        };
        let (target, radius) = framing_target_radius(bounds_min, bounds_max);
        let (lo, hi) = (
            Vec3::from(target) - Vec3::splat(radius),
            Vec3::from(target) + Vec3::splat(radius),
        );
        let (lo, hi) = if Vec3::from(bounds_min).cmple(Vec3::from(bounds_max)).all()
            && Vec3::from(bounds_min).is_finite()
            && Vec3::from(bounds_max).is_finite()
        {
            (Vec3::from(bounds_min), Vec3::from(bounds_max))
        } else {
            (lo, hi)
        };
        let corners: Vec<Vec3> = (0..8)
            .map(|i| {
                Vec3::new(
                    if i & 1 == 0 { lo.x } else { hi.x },
                    if i & 2 == 0 { lo.y } else { hi.y },
                    if i & 4 == 0 { lo.z } else { hi.z },
                )
            })
            .collect();
        // NDC bounds (min x, min y, max x, max y) of the corners; None if one is behind the eye.
        let ndc_box = |cam: &Self| {
            let m = cam.view_proj(aspect);
            let mut b = [
                f32::INFINITY,
                f32::INFINITY,
                f32::NEG_INFINITY,
                f32::NEG_INFINITY,
            ];
            for p in &corners {
                let c = m * p.extend(1.0);
                if c.w <= 0.0 {
                    return None;
                }
                let (x, y) = (c.x / c.w, c.y / c.w);
                b = [b[0].min(x), b[1].min(y), b[2].max(x), b[3].max(y)];
            }
            Some(b)
        };
        // The smallest distance at which every corner lies within 85 % of the frame, found by
        // bisection; then the target moves so that the corners' picture is centred, and again.
        let mut target = Vec3::from(target);
        let mut distance = radius * 20.0;
        for _ in 0..3 {
            let fits = |d: f32| {
                ndc_box(&Self::orbit(target.to_array(), yaw, pitch, d))
                    .is_some_and(|b| b[0] >= -0.85 && b[1] >= -0.85 && b[2] <= 0.85 && b[3] <= 0.85)
            };
            let (mut near, mut far) = (radius * 0.2, radius * 20.0);
            if !fits(far) {
                break;
            }
            for _ in 0..40 {
                let mid = 0.5 * (near + far);
                if fits(mid) {
                    far = mid;
                } else {
                    near = mid;
                }
            }
            distance = far;
            let cam = Self::orbit(target.to_array(), yaw, pitch, distance);
            let Some(b) = ndc_box(&cam) else { break };
            let view = cam.view();
            let (right, up) = (view.row(0).truncate(), view.row(1).truncate());
            let half_h = distance * (cam.fov_y * 0.5).tan();
            target += right * (0.5 * (b[0] + b[2]) * half_h * aspect)
                + up * (0.5 * (b[1] + b[3]) * half_h);
        }
        Self::orbit(target.to_array(), yaw, pitch, distance)
    }

    /// The view matrix (world to eye space, right-handed, looking down -Z).
    pub fn view(&self) -> Mat4 {
        let eye = Vec3::from(self.eye);
        let target = Vec3::from(self.target);
        let mut up = Vec3::from(self.up).normalize_or(Vec3::Y);
        // Looking straight along `up` would make the basis degenerate: pick another up.
        if (target - eye)
            .normalize_or_zero()
            .cross(up)
            .length_squared()
            < 1e-8
        {
            up = Vec3::Z;
        }
        glam::camera::rh::view::look_at_mat4(eye, target, up)
    }

    /// The projection matrix for a viewport of the given width / height ratio.
    pub fn proj(&self, aspect: f32) -> Mat4 {
        let near = self.near.max(1e-6);
        let far = self.far.max(near * 1.001);
        let fov = self.fov_y.clamp(1e-3, std::f32::consts::PI - 1e-3);
        glam::camera::rh::proj::directx::perspective(fov, aspect.max(1e-6), near, far)
    }

    /// Projection times view: world space to clip space (WebGPU depth range [0, 1]).
    pub fn view_proj(&self, aspect: f32) -> Mat4 {
        self.proj(aspect) * self.view()
    }

    /// Where a world point lands on a `viewport` of `[width, height]` pixels: `[x, y]` with the
    /// origin at the top-left corner and y down (image convention), or `None` behind the eye.
    /// Useful to pick particles and to test images.
    pub fn project(&self, point: [f32; 3], viewport: [u32; 2]) -> Option<[f32; 2]> {
        let [w, h] = [viewport[0].max(1) as f32, viewport[1].max(1) as f32];
        let clip = self.view_proj(w / h) * Vec3::from(point).extend(1.0);
        if clip.w <= 1e-9 {
            return None;
        }
        let ndc = clip.truncate() / clip.w;
        Some([(ndc.x * 0.5 + 0.5) * w, (0.5 - ndc.y * 0.5) * h])
    }

    /// The world-space ray through pixel `pixel` (top-left origin) of a `viewport`: its origin
    /// (the eye) and unit direction. The inverse of [`Camera::project`].
    pub fn ray(&self, pixel: [f32; 2], viewport: [u32; 2]) -> ([f32; 3], [f32; 3]) {
        let [w, h] = [viewport[0].max(1) as f32, viewport[1].max(1) as f32];
        let inv = self.view_proj(w / h).inverse();
        let ndc_x = pixel[0] / w * 2.0 - 1.0;
        let ndc_y = 1.0 - pixel[1] / h * 2.0;
        let far = inv.project_point3(Vec3::new(ndc_x, ndc_y, 1.0));
        let eye = Vec3::from(self.eye);
        (self.eye, (far - eye).normalize_or(Vec3::NEG_Z).to_array())
    }

    /// Unit vector from the eye towards the target.
    pub fn forward(&self) -> [f32; 3] {
        (Vec3::from(self.target) - Vec3::from(self.eye))
            .normalize_or(Vec3::NEG_Z)
            .to_array()
    }
}

impl Default for Camera {
    /// [`Camera::framing`] of a 30 cm cloth lying on the plane y = 0 (the thesis' set-up).
    fn default() -> Self {
        Self::framing([-0.15, 0.0, -0.15], [0.15, 0.02, 0.15])
    }
}

/// Centre and bounding-sphere radius of a box (a 30 cm box at the origin if it is empty or
/// not finite).
fn framing_target_radius(bounds_min: [f32; 3], bounds_max: [f32; 3]) -> ([f32; 3], f32) {
    let lo = Vec3::from(bounds_min);
    let hi = Vec3::from(bounds_max);
    let (lo, hi) = if lo.is_finite() && hi.is_finite() && lo.cmple(hi).all() {
        (lo, hi)
    } else {
        (Vec3::splat(-0.15), Vec3::splat(0.15))
    };
    (
        ((lo + hi) * 0.5).to_array(),
        ((hi - lo).length() * 0.5).max(1e-3),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orbit_places_the_eye_at_distance_and_looks_at_target() {
        let c = Camera::orbit([1.0, 2.0, 3.0], 0.3, 0.4, 5.0);
        let d = Vec3::from(c.eye) - Vec3::from(c.target);
        assert!((d.length() - 5.0).abs() < 1e-5);
        assert!(d.y > 0.0);
        let p = c.project(c.target, [200, 100]).unwrap();
        assert!((p[0] - 100.0).abs() < 1e-3 && (p[1] - 50.0).abs() < 1e-3);
    }

    #[test]
    fn project_and_ray_are_inverse() {
        let c = Camera::default();
        let (o, d) = c.ray([30.0, 70.0], [160, 120]);
        let q = Vec3::from(o) + Vec3::from(d) * 0.4;
        let p = c.project(q.to_array(), [160, 120]).unwrap();
        assert!(
            (p[0] - 30.0).abs() < 1e-2 && (p[1] - 70.0).abs() < 1e-2,
            "{p:?}"
        );
    }

    #[test]
    fn framing_sees_every_corner_of_the_box() {
        let lo = [-0.15, 0.0, -0.15];
        let hi = [0.15, 0.05, 0.15];
        let c = Camera::framing(lo, hi);
        for i in 0..8 {
            let p = [
                if i & 1 == 0 { lo[0] } else { hi[0] },
                if i & 2 == 0 { lo[1] } else { hi[1] },
                if i & 4 == 0 { lo[2] } else { hi[2] },
            ];
            let s = c.project(p, [400, 300]).unwrap();
            assert!(
                (0.0..400.0).contains(&s[0]) && (0.0..300.0).contains(&s[1]),
                "{s:?}"
            );
        }
    }
}
