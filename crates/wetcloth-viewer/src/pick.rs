//! Picking and dragging particles with the mouse, as pure functions of the camera matrix, the
//! viewport and the cursor (no window needed, so all of it is unit-tested).
//!
//! Screen coordinates are in pixels (egui points) from the top-left corner of the 3D view, y
//! down. The view-projection matrix maps world space to wgpu clip space (NDC z in [0, 1], y up).
//!
//! The thesis' pick mode (fig. 4.1, items 5 and 6): the particle whose projection is nearest
//! the cursor is picked; dragging moves it in the plane through the particle facing the camera,
//! so it stays under the cursor at its depth; a vertical move (modifier or wheel) slides it along
//! world Y; a right click while dragging pins it where it is.

use glam::{Mat4, Vec2, Vec3, Vec4};

/// Default pick radius around the cursor, pixels.
pub const PICK_RADIUS_PX: f32 = 12.0;

/// Size of the 3D view, pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Viewport {
    /// Width, pixels (> 0).
    pub width: f32,
    /// Height, pixels (> 0).
    pub height: f32,
}

impl Viewport {
    /// Width / height.
    pub fn aspect(&self) -> f32 {
        self.width / self.height.max(1.0)
    }

    /// Pixel position of normalised device coordinates (x, y in [-1, 1], y up).
    pub fn ndc_to_pixel(&self, ndc: Vec2) -> Vec2 {
        Vec2::new(
            (ndc.x + 1.0) * 0.5 * self.width,
            (1.0 - ndc.y) * 0.5 * self.height,
        )
    }

    /// Normalised device coordinates of a pixel position.
    pub fn pixel_to_ndc(&self, pixel: Vec2) -> Vec2 {
        Vec2::new(
            2.0 * pixel.x / self.width - 1.0,
            1.0 - 2.0 * pixel.y / self.height,
        )
    }
}

/// A ray `origin + t * dir`, `t >= 0`, with `dir` of unit length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Start point, on the near plane, m.
    pub origin: Vec3,
    /// Unit direction.
    pub dir: Vec3,
}

impl Ray {
    /// The point at parameter `t`.
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.dir * t
    }
}

/// A projected point: its pixel position and its clip-space depth (NDC z, 0 at the near plane).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Projected {
    /// Pixel position in the view.
    pub pixel: Vec2,
    /// NDC depth in [0, 1] inside the frustum; smaller is nearer.
    pub depth: f32,
}

/// Projects a world point to the screen; `None` when it is behind the camera.
pub fn project(view_proj: Mat4, viewport: Viewport, p: Vec3) -> Option<Projected> {
    let clip = view_proj * p.extend(1.0);
    if clip.w <= 1e-6 {
        return None;
    }
    let ndc = clip.truncate() / clip.w;
    Some(Projected {
        pixel: viewport.ndc_to_pixel(ndc.truncate()),
        depth: ndc.z,
    })
}

fn unproject(inv: Mat4, ndc: Vec2, z: f32) -> Vec3 {
    let p: Vec4 = inv * Vec4::new(ndc.x, ndc.y, z, 1.0);
    p.truncate() / p.w
}

/// The ray from the camera through a pixel (from the near plane into the scene).
pub fn ray_through(view_proj: Mat4, viewport: Viewport, pixel: Vec2) -> Ray {
    let inv = view_proj.inverse();
    let ndc = viewport.pixel_to_ndc(pixel);
    let near = unproject(inv, ndc, 0.0);
    let far = unproject(inv, ndc, 0.5);
    Ray {
        origin: near,
        dir: (far - near).normalize(),
    }
}

/// The particle whose projection is nearest `cursor`, if one lies within `radius_px` and in
/// front of the camera. Among particles at nearly the same screen distance (within a pixel) the
/// one nearer the camera wins, so a fold's top layer is picked.
pub fn pick_particle(
    view_proj: Mat4,
    viewport: Viewport,
    positions: &[[f32; 3]],
    cursor: Vec2,
    radius_px: f32,
) -> Option<usize> {
    let mut best: Option<(usize, f32, f32)> = None;
    for (k, p) in positions.iter().enumerate() {
        let Some(q) = project(view_proj, viewport, Vec3::from_array(*p)) else {
            continue;
        };
        if !(0.0..=1.0).contains(&q.depth) {
            continue;
        }
        let d = q.pixel.distance(cursor);
        if d > radius_px {
            continue;
        }
        let better = match best {
            None => true,
            Some((_, bd, bz)) => d < bd - 1.0 || (d < bd + 1.0 && q.depth < bz),
        };
        if better {
            best = Some((k, d, q.depth));
        }
    }
    best.map(|(k, _, _)| k)
}

/// The plane a dragged particle moves in: through the particle, facing the camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DragPlane {
    /// A point on the plane (the particle when the drag began), m.
    pub point: Vec3,
    /// Unit normal, pointing from the plane towards the camera.
    pub normal: Vec3,
}

impl DragPlane {
    /// The plane through `point` perpendicular to the camera's viewing direction `forward`
    /// (from the eye towards the scene).
    pub fn facing_camera(point: Vec3, forward: Vec3) -> Self {
        Self {
            point,
            normal: -forward.normalize(),
        }
    }

    /// Where `ray` meets the plane; `None` when it is parallel to it or meets it behind its start.
    pub fn intersect(&self, ray: &Ray) -> Option<Vec3> {
        let denom = ray.dir.dot(self.normal);
        if denom.abs() < 1e-6 {
            return None;
        }
        let t = (self.point - ray.origin).dot(self.normal) / denom;
        (t >= 0.0).then(|| ray.at(t))
    }

    /// The plane moved along world Y by `dy`, m.
    pub fn lifted(&self, dy: f32) -> Self {
        Self {
            point: self.point + Vec3::Y * dy,
            normal: self.normal,
        }
    }
}

/// World distance covered by one pixel at the depth of `p` (for vertical moves with the mouse).
pub fn metres_per_pixel(view_proj: Mat4, viewport: Viewport, p: Vec3) -> f32 {
    let Some(a) = project(view_proj, viewport, p) else {
        return 0.0;
    };
    let ray = ray_through(view_proj, viewport, a.pixel + Vec2::new(0.0, 1.0));
    let ray0 = ray_through(view_proj, viewport, a.pixel);
    // Both rays meet the plane through p facing the first ray at points one pixel apart.
    let plane = DragPlane::facing_camera(p, ray0.dir);
    match (plane.intersect(&ray0), plane.intersect(&ray)) {
        (Some(u), Some(v)) => u.distance(v),
        _ => 0.0,
    }
}

/// A drag in progress: which particle, in which plane, and where it is being pulled to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Drag {
    /// The dragged particle.
    pub particle: usize,
    /// The plane it moves in.
    pub plane: DragPlane,
    /// Where it is pulled to, m.
    pub target: Vec3,
}

impl Drag {
    /// Starts dragging `particle`, now at `position`, for a camera looking along `forward`.
    pub fn begin(particle: usize, position: Vec3, forward: Vec3) -> Self {
        Self {
            particle,
            plane: DragPlane::facing_camera(position, forward),
            target: position,
        }
    }

    /// Moves the target to where the ray through the cursor meets the drag plane. Returns
    /// false (and keeps the target) when the ray misses the plane.
    pub fn follow(&mut self, ray: &Ray) -> bool {
        match self.plane.intersect(ray) {
            Some(p) => {
                self.target = p;
                true
            }
            None => false,
        }
    }

    /// Moves the target, and the plane with it, along world Y by `dy`, m.
    pub fn lift(&mut self, dy: f32) {
        self.plane = self.plane.lifted(dy);
        self.target += Vec3::Y * dy;
    }
}

/// The pinned particles and where each is held.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Pins {
    pins: Vec<(usize, Vec3)>,
}

impl Pins {
    /// Pins `particle` at `target`, replacing an earlier pin of the same particle.
    pub fn pin(&mut self, particle: usize, target: Vec3) {
        self.unpin(particle);
        self.pins.push((particle, target));
    }

    /// Releases `particle`; returns whether it was pinned.
    pub fn unpin(&mut self, particle: usize) -> bool {
        let before = self.pins.len();
        self.pins.retain(|(p, _)| *p != particle);
        self.pins.len() != before
    }

    /// Whether `particle` is pinned.
    pub fn is_pinned(&self, particle: usize) -> bool {
        self.pins.iter().any(|(p, _)| *p == particle)
    }

    /// Where `particle` is pinned, if it is.
    pub fn target(&self, particle: usize) -> Option<Vec3> {
        self.pins
            .iter()
            .find(|(p, _)| *p == particle)
            .map(|(_, t)| *t)
    }

    /// The pinned particles, in pinning order.
    pub fn particles(&self) -> Vec<usize> {
        self.pins.iter().map(|(p, _)| *p).collect()
    }

    /// Releases every pin; returns the particles that were pinned.
    pub fn clear(&mut self) -> Vec<usize> {
        let out = self.particles();
        self.pins.clear();
        out
    }

    /// Number of pins.
    pub fn len(&self) -> usize {
        self.pins.len()
    }

    /// True when nothing is pinned.
    pub fn is_empty(&self) -> bool {
        self.pins.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::OrbitCamera;

    const VP: Viewport = Viewport {
        width: 800.0,
        height: 600.0,
    };

    fn camera() -> OrbitCamera {
        OrbitCamera {
            target: Vec3::ZERO,
            yaw: 0.3,
            pitch: 0.6,
            distance: 0.6,
            ..OrbitCamera::default()
        }
    }

    fn grid(n: usize, size: f32) -> Vec<[f32; 3]> {
        let mut v = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let s = size / (n - 1) as f32;
                v.push([i as f32 * s - size / 2.0, 0.0, j as f32 * s - size / 2.0]);
            }
        }
        v
    }

    #[test]
    fn the_camera_target_projects_to_the_view_centre() {
        let vp = camera().view_proj(VP.aspect());
        let q = project(vp, VP, Vec3::ZERO).unwrap();
        assert!(q.pixel.distance(Vec2::new(400.0, 300.0)) < 1e-3, "{q:?}");
        assert!((0.0..1.0).contains(&q.depth));
    }

    #[test]
    fn a_point_behind_the_camera_does_not_project() {
        let cam = camera();
        let behind = cam.eye() + (cam.eye() - cam.target);
        assert!(project(cam.view_proj(VP.aspect()), VP, behind).is_none());
    }

    #[test]
    fn the_ray_through_a_projected_point_passes_through_it() {
        let vp = camera().view_proj(VP.aspect());
        let p = Vec3::new(0.07, 0.02, -0.05);
        let q = project(vp, VP, p).unwrap();
        let ray = ray_through(vp, VP, q.pixel);
        // Distance from p to the ray.
        let t = (p - ray.origin).dot(ray.dir);
        assert!(t > 0.0);
        assert!(ray.at(t).distance(p) < 1e-4, "{}", ray.at(t).distance(p));
        // And it starts near the eye, looking into the scene.
        assert!(ray.origin.distance(camera().eye()) < 0.02);
    }

    #[test]
    fn picks_the_particle_under_the_cursor() {
        let vp = camera().view_proj(VP.aspect());
        let pts = grid(11, 0.3);
        let k = 5 * 11 + 7;
        let q = project(vp, VP, Vec3::from_array(pts[k])).unwrap();
        let got = pick_particle(vp, VP, &pts, q.pixel + Vec2::new(2.0, -1.0), PICK_RADIUS_PX);
        assert_eq!(got, Some(k));
    }

    #[test]
    fn picks_nothing_beyond_the_radius() {
        let vp = camera().view_proj(VP.aspect());
        let pts = vec![[0.0, 0.0, 0.0]];
        let centre = Vec2::new(400.0, 300.0);
        assert_eq!(
            pick_particle(vp, VP, &pts, centre + Vec2::new(11.0, 0.0), 12.0),
            Some(0)
        );
        assert_eq!(
            pick_particle(vp, VP, &pts, centre + Vec2::new(13.0, 0.0), 12.0),
            None
        );
    }

    #[test]
    fn of_two_particles_on_one_line_of_sight_the_nearer_is_picked() {
        let cam = camera();
        let vp = cam.view_proj(VP.aspect());
        let dir = (cam.target - cam.eye()).normalize();
        let far = cam.target;
        let near = cam.target - dir * 0.1;
        let pts = vec![far.to_array(), near.to_array()];
        assert_eq!(
            pick_particle(vp, VP, &pts, Vec2::new(400.0, 300.0), 12.0),
            Some(1)
        );
    }

    #[test]
    fn particles_behind_the_camera_are_not_picked() {
        let cam = camera();
        let vp = cam.view_proj(VP.aspect());
        // Mirror image of the target behind the eye: it would project onto the centre if the
        // sign of w were ignored.
        let behind = cam.eye() + (cam.eye() - cam.target);
        assert_eq!(
            pick_particle(vp, VP, &[behind.to_array()], Vec2::new(400.0, 300.0), 50.0),
            None
        );
    }

    #[test]
    fn dragging_keeps_the_particle_under_the_cursor_at_its_depth() {
        let cam = camera();
        let vp = cam.view_proj(VP.aspect());
        let p = Vec3::new(0.0, 0.0, 0.0);
        let mut drag = Drag::begin(3, p, cam.forward());
        let cursor = Vec2::new(430.0, 200.0);
        assert!(drag.follow(&ray_through(vp, VP, cursor)));
        // The target projects back to the cursor ...
        let q = project(vp, VP, drag.target).unwrap();
        assert!(q.pixel.distance(cursor) < 1e-2, "{q:?}");
        // ... and stays in the plane through the particle facing the camera.
        let off = (drag.target - p).dot(cam.forward());
        assert!(off.abs() < 1e-5, "{off}");
        // Moving the cursor up lifts the particle off the table.
        assert!(drag.target.y > 0.01);
    }

    #[test]
    fn the_drag_plane_faces_the_camera() {
        let plane = DragPlane::facing_camera(Vec3::new(1.0, 2.0, 3.0), Vec3::new(0.0, 0.0, -2.0));
        assert_eq!(plane.normal, Vec3::Z);
        let ray = Ray {
            origin: Vec3::new(1.5, 2.5, 10.0),
            dir: -Vec3::Z,
        };
        assert_eq!(plane.intersect(&ray), Some(Vec3::new(1.5, 2.5, 3.0)));
        // Parallel and backwards rays miss.
        let parallel = Ray {
            origin: Vec3::ZERO,
            dir: Vec3::X,
        };
        assert_eq!(plane.intersect(&parallel), None);
        let away = Ray {
            origin: Vec3::new(0.0, 0.0, 10.0),
            dir: Vec3::Z,
        };
        assert_eq!(plane.intersect(&away), None);
    }

    #[test]
    fn a_vertical_move_lifts_target_and_plane() {
        let cam = camera();
        let vp = cam.view_proj(VP.aspect());
        let mut drag = Drag::begin(0, Vec3::ZERO, cam.forward());
        drag.lift(0.03);
        assert!((drag.target - Vec3::new(0.0, 0.03, 0.0)).length() < 1e-7);
        // The cursor that showed the particle now hits the lifted plane higher up.
        let ray = ray_through(vp, VP, Vec2::new(400.0, 300.0));
        assert!(drag.follow(&ray));
        assert!(drag.target.y > 0.0);
        assert!(
            (drag.target - drag.plane.point)
                .dot(drag.plane.normal)
                .abs()
                < 1e-5
        );
    }

    #[test]
    fn metres_per_pixel_matches_the_frustum() {
        let cam = camera();
        let vp = cam.view_proj(VP.aspect());
        // At the target, the view height is 2 d tan(fov/2) over 600 pixels.
        let expect = 2.0 * cam.distance * (cam.fov_y / 2.0).tan() / VP.height;
        let got = metres_per_pixel(vp, VP, cam.target);
        assert!((got - expect).abs() / expect < 1e-2, "{got} vs {expect}");
    }

    #[test]
    fn pins_pin_replace_and_release() {
        let mut pins = Pins::default();
        assert!(pins.is_empty());
        pins.pin(7, Vec3::X);
        pins.pin(9, Vec3::Y);
        pins.pin(7, Vec3::Z);
        assert_eq!(pins.len(), 2);
        assert_eq!(pins.target(7), Some(Vec3::Z));
        assert!(pins.is_pinned(9));
        assert!(pins.unpin(9));
        assert!(!pins.unpin(9));
        assert!(!pins.is_pinned(9));
        assert_eq!(pins.clear(), vec![7]);
        assert!(pins.is_empty());
    }
}
