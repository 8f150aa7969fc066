//! Headless rendering: a device of its own (any adapter, Mesa's lavapipe on a machine without a
//! GPU), multisampled colour and depth targets, and read-back into an image.

use crate::error::RenderError;
use crate::renderer::{ClothRenderer, SceneView};

/// Colour format of offscreen images (8-bit sRGB: PNG's encoding).
pub const OFFSCREEN_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
/// Depth format of offscreen images.
pub const OFFSCREEN_DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// Samples per pixel of offscreen images (4x MSAA smooths the cloth's silhouette).
pub const OFFSCREEN_SAMPLES: u32 = 4;

/// Renders scenes into images without a window.
pub struct Offscreen {
    device: wgpu::Device,
    queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
    renderer: ClothRenderer,
    size: [u32; 2],
    msaa_view: wgpu::TextureView,
    depth_view: wgpu::TextureView,
    resolve: wgpu::Texture,
    readback: wgpu::Buffer,
    padded_row: u32,
    depth: bool,
}

/// Opens a device on the best adapter available. `WGPU_BACKEND` (e.g. `vulkan`, `gl`) and
/// `WGPU_ADAPTER_NAME` narrow the choice, as in every wgpu program.
fn open_device() -> Result<(wgpu::Device, wgpu::Queue, wgpu::AdapterInfo), RenderError> {
    let instance =
        wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let adapter = match pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
        power_preference: wgpu::PowerPreference::HighPerformance,
        force_fallback_adapter: false,
        compatible_surface: None,
        ..Default::default()
    })) {
        Ok(a) => a,
        Err(first) => pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::LowPower,
            force_fallback_adapter: true,
            compatible_surface: None,
            ..Default::default()
        }))
        .map_err(|_| RenderError::NoAdapter(first.to_string()))?,
    };
    let info = adapter.get_info();
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("wetcloth offscreen"),
        required_features: wgpu::Features::empty(),
        required_limits: wgpu::Limits::downlevel_defaults().using_resolution(adapter.limits()),
        ..Default::default()
    }))
    .map_err(|e| RenderError::Device(e.to_string()))?;
    Ok((device, queue, info))
}

struct Targets {
    msaa_view: wgpu::TextureView,
    depth_view: wgpu::TextureView,
    resolve: wgpu::Texture,
    readback: wgpu::Buffer,
    padded_row: u32,
}

fn targets(device: &wgpu::Device, width: u32, height: u32) -> Targets {
    let size = wgpu::Extent3d {
        width,
        height,
        depth_or_array_layers: 1,
    };
    let texture = |label, format, samples, usage| {
        device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size,
            mip_level_count: 1,
            sample_count: samples,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage,
            view_formats: &[],
        })
    };
    let attach = wgpu::TextureUsages::RENDER_ATTACHMENT;
    let msaa = texture(
        "wetcloth msaa colour",
        OFFSCREEN_FORMAT,
        OFFSCREEN_SAMPLES,
        attach,
    );
    let depth = texture("wetcloth depth", OFFSCREEN_DEPTH, OFFSCREEN_SAMPLES, attach);
    let resolve = texture(
        "wetcloth image",
        OFFSCREEN_FORMAT,
        1,
        attach | wgpu::TextureUsages::COPY_SRC,
    );
    // Texture-to-buffer copies need rows padded to 256 bytes.
    let padded_row = (width * 4).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT)
        * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("wetcloth readback"),
        size: padded_row as u64 * height as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    Targets {
        msaa_view: msaa.create_view(&Default::default()),
        depth_view: depth.create_view(&Default::default()),
        resolve,
        readback,
        padded_row,
    }
}

impl Offscreen {
    /// Opens a headless device and allocates `width` x `height` targets.
    pub fn new(width: u32, height: u32) -> Result<Self, RenderError> {
        Self::with_depth(width, height, true)
    }

    /// Like [`Offscreen::new`], with (`depth`) or without a depth buffer. Without one the
    /// renderer sorts the cloth's triangles as it does for a viewer pass that has none.
    pub fn with_depth(width: u32, height: u32, depth: bool) -> Result<Self, RenderError> {
        let (device, queue, info) = open_device()?;
        let max = device.limits().max_texture_dimension_2d;
        if width == 0 || height == 0 || width > max || height > max {
            return Err(RenderError::Size {
                width,
                height,
                reason: format!("each side must be 1..={max} pixels on this device"),
            });
        }
        let renderer = ClothRenderer::new(
            &device,
            OFFSCREEN_FORMAT,
            depth.then_some(OFFSCREEN_DEPTH),
            OFFSCREEN_SAMPLES,
        );
        let t = targets(&device, width, height);
        Ok(Self {
            device,
            queue,
            info,
            renderer,
            size: [width, height],
            msaa_view: t.msaa_view,
            depth_view: t.depth_view,
            resolve: t.resolve,
            readback: t.readback,
            padded_row: t.padded_row,
            depth,
        })
    }

    /// The device and queue, to create more GPU resources on the same device.
    pub fn device_queue(&self) -> (&wgpu::Device, &wgpu::Queue) {
        (&self.device, &self.queue)
    }

    /// Replaces the renderer's materials (see [`ClothRenderer::set_materials`]).
    pub fn set_materials(
        &mut self,
        cloth: Option<&crate::renderer::Material>,
        table: Option<&crate::renderer::Material>,
        solids: Option<&crate::renderer::Material>,
    ) {
        self.renderer
            .set_materials(&self.queue, cloth, table, solids);
    }

    /// Image size `[width, height]`, px.
    pub fn size(&self) -> [u32; 2] {
        self.size
    }

    /// The adapter in use, e.g. `llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan, Cpu)`.
    pub fn adapter_info(&self) -> String {
        format!(
            "{} ({:?}, {:?})",
            self.info.name, self.info.backend, self.info.device_type
        )
    }

    /// Renders `scene` and reads the image back.
    pub fn render(&mut self, scene: &SceneView) -> Result<image::RgbaImage, RenderError> {
        let [width, height] = self.size;
        self.renderer
            .prepare(&self.device, &self.queue, scene, self.size);
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("wetcloth frame"),
            });
        {
            let resolve_view = self.resolve.create_view(&Default::default());
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("wetcloth frame"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &self.msaa_view,
                    depth_slice: None,
                    resolve_target: Some(&resolve_view),
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Discard,
                    },
                })],
                depth_stencil_attachment: self.depth.then_some({
                    wgpu::RenderPassDepthStencilAttachment {
                        view: &self.depth_view,
                        depth_ops: Some(wgpu::Operations {
                            load: wgpu::LoadOp::Clear(1.0),
                            store: wgpu::StoreOp::Discard,
                        }),
                        stencil_ops: None,
                    }
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            self.renderer.paint(&mut pass);
        }
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &self.resolve,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &self.readback,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(self.padded_row),
                    rows_per_image: Some(height),
                },
            },
            wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
        );
        self.queue.submit([encoder.finish()]);

        let slice = self.readback.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| RenderError::Readback(e.to_string()))?;
        rx.recv()
            .map_err(|e| RenderError::Readback(e.to_string()))?
            .map_err(|e| RenderError::Readback(e.to_string()))?;
        let mut pixels = Vec::with_capacity((width * height * 4) as usize);
        {
            let data = slice
                .get_mapped_range()
                .map_err(|e| RenderError::Readback(e.to_string()))?;
            for row in data.chunks_exact(self.padded_row as usize) {
                pixels.extend_from_slice(&row[..(width * 4) as usize]);
            }
        }
        self.readback.unmap();
        image::RgbaImage::from_raw(width, height, pixels)
            .ok_or_else(|| RenderError::Readback("image size mismatch".into()))
    }
}
