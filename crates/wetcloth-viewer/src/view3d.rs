//! The 3D view: the shared [`wetcloth_render::ClothRenderer`] (the renderer of the offline
//! `render` command) drawn inside egui's render pass through a paint callback.

use std::sync::Arc;

use eframe::egui;
use eframe::egui_wgpu::{self, CallbackResources, CallbackTrait, RenderState, ScreenDescriptor};
use wetcloth_render::{ClothRenderer, GroundPlane, MeshView, SceneView, Solid};

use crate::camera::OrbitCamera;

/// Depth buffer bits the window asks eframe for (the renderer depth-tests the cloth against
/// the table and itself).
pub(crate) const DEPTH_BITS: u8 = 24;

/// MSAA samples of the window (1: none; software rendering pays for every sample).
pub(crate) const SAMPLES: u16 = 4;

/// The ground and the solids around the cloth ([`wetcloth_render::collider_scene`]).
pub(crate) type ColliderScene = (Option<GroundPlane>, Vec<Solid>);

/// Everything one frame of the 3D view shows, owned so the callback can outlive the UI pass.
pub(crate) struct Frame {
    pub positions: Vec<[f32; 3]>,
    pub normals: Vec<[f32; 3]>,
    pub indices: Arc<Vec<u32>>,
    pub scene: Arc<ColliderScene>,
    pub show_particles: bool,
    pub particle_radius: f32,
    pub highlight: Option<usize>,
    pub pinned: Vec<usize>,
    pub camera: OrbitCamera,
    pub wetness: f32,
    /// A tint per cloth vertex (the air pockets by pressure), or none.
    pub tint: Option<Vec<[f32; 4]>>,
}

/// Creates the renderer for the window's surface and keeps it in egui's callback resources.
pub(crate) fn install(rs: &RenderState) {
    let depth = egui_wgpu::depth_format_from_bits(DEPTH_BITS, 0);
    let renderer = ClothRenderer::new(&rs.device, rs.target_format, depth, u32::from(SAMPLES));
    rs.renderer.write().callback_resources.insert(renderer);
}

/// The paint callback drawing `frame` into `rect`.
pub(crate) fn callback(rect: egui::Rect, frame: Frame) -> egui::PaintCallback {
    egui_wgpu::Callback::new_paint_callback(rect, SceneCallback { frame, rect })
}

struct SceneCallback {
    frame: Frame,
    rect: egui::Rect,
}

impl CallbackTrait for SceneCallback {
    fn prepare(
        &self,
        device: &eframe::wgpu::Device,
        queue: &eframe::wgpu::Queue,
        screen: &ScreenDescriptor,
        _encoder: &mut eframe::wgpu::CommandEncoder,
        resources: &mut CallbackResources,
    ) -> Vec<eframe::wgpu::CommandBuffer> {
        let Some(renderer) = resources.get_mut::<ClothRenderer>() else {
            return Vec::new();
        };
        let f = &self.frame;
        let ppp = screen.pixels_per_point;
        let viewport = [
            (self.rect.width() * ppp).round().max(1.0) as u32,
            (self.rect.height() * ppp).round().max(1.0) as u32,
        ];
        let scene = SceneView {
            cloth: MeshView {
                positions: &f.positions,
                normals: &f.normals,
                indices: &f.indices,
            },
            ground: f.scene.0,
            particles: f.show_particles.then_some(f.positions.as_slice()),
            particle_radius: f.particle_radius,
            highlight: f.highlight,
            pinned: &f.pinned,
            solids: &f.scene.1,
            camera: f.camera.to_camera(),
            wetness: f.wetness,
            tint: f.tint.as_deref(),
        };
        renderer.prepare(device, queue, &scene, viewport);
        Vec::new()
    }

    fn paint(
        &self,
        _info: egui::PaintCallbackInfo,
        pass: &mut eframe::wgpu::RenderPass<'static>,
        resources: &CallbackResources,
    ) {
        if let Some(renderer) = resources.get::<ClothRenderer>() {
            renderer.paint(pass);
        }
    }
}
