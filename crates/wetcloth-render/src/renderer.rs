//! The scene renderer: wgpu pipelines, GPU buffers and the per-frame upload, independent of
//! where it draws (an offscreen texture or the viewer's window through egui's paint callback).

use std::mem::size_of;

use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use wgpu::util::DeviceExt;

use crate::camera::Camera;
use crate::mesh::{GroundPlane, Solid, bounds_of, smooth_normals};

/// A triangle mesh to draw: positions, per-vertex normals and triangle indices (in threes,
/// front side where `(p1 - p0) x (p2 - p0)` points). When `normals` does not have one entry per
/// position, smooth normals are computed from the triangles.
#[derive(Clone, Copy, Debug, Default)]
pub struct MeshView<'a> {
    /// Vertex positions, m.
    pub positions: &'a [[f32; 3]],
    /// Unit vertex normals (may be empty: then computed).
    pub normals: &'a [[f32; 3]],
    /// Triangle vertex indices, three per triangle.
    pub indices: &'a [u32],
}

/// Everything one frame shows. Particle indices (`highlight`, `pinned`) refer to `particles`
/// when it is given, else to the cloth's vertices.
#[derive(Clone, Copy, Debug)]
pub struct SceneView<'a> {
    /// The cloth mesh.
    pub cloth: MeshView<'a>,
    /// The table, if any.
    pub ground: Option<GroundPlane>,
    /// Particle positions to draw as dots (the viewer's pick mode), m.
    pub particles: Option<&'a [[f32; 3]]>,
    /// Radius of a particle dot, m; 0 or less picks one from the cloth's edge length.
    pub particle_radius: f32,
    /// One particle drawn as the pick cursor (an amber ring).
    pub highlight: Option<usize>,
    /// Particles drawn as pins (red dots), whether or not `particles` is given.
    pub pinned: &'a [usize],
    /// Solid obstacles (every collider but the ground, see [`crate::collider_scene`]).
    pub solids: &'a [Solid],
    /// The camera.
    pub camera: Camera,
    /// 0 dry .. 1 wet: wet cloth is darker and glossier.
    pub wetness: f32,
    /// A colour per cloth vertex over the cloth's own (linear RGB and a weight 0..1: 0 keeps
    /// the cloth's colour, 1 replaces it), e.g. the air pockets tinted by their pressure. Used
    /// only when it has one entry per cloth vertex.
    pub tint: Option<&'a [[f32; 4]]>,
}

impl<'a> SceneView<'a> {
    /// A scene with only `cloth` on the plane y = 0, seen by `camera`, fully wet.
    pub fn new(cloth: MeshView<'a>, camera: Camera) -> Self {
        Self {
            cloth,
            ground: Some(GroundPlane::default()),
            particles: None,
            particle_radius: 0.0,
            highlight: None,
            pinned: &[],
            solids: &[],
            camera,
            wetness: 1.0,
            tint: None,
        }
    }
}

/// Surface colours and gloss of one drawn object, in linear RGB.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// Albedo of the front side.
    pub front: [f32; 3],
    /// Albedo of the back side.
    pub back: [f32; 3],
    /// Specular strength (dry), 0..1.
    pub specular: f32,
    /// Blinn-Phong exponent (dry): higher is a tighter highlight.
    pub exponent: f32,
    /// Glow at grazing angles (satin sheen), 0..1.
    pub sheen: f32,
    /// How much `SceneView::wetness` changes this material, 0..1.
    pub wet_response: f32,
}

/// Converts an sRGB-encoded 8-bit colour to linear RGB.
pub fn srgb_to_linear(c: [u8; 3]) -> [f32; 3] {
    c.map(|v| {
        let v = v as f32 / 255.0;
        if v <= 0.04045 {
            v / 12.92
        } else {
            ((v + 0.055) / 1.055).powf(2.4)
        }
    })
}

impl Material {
    /// Polyester satin in a warm pastel (a pale dusty rose): glossy front, matte back.
    pub fn satin() -> Self {
        Self {
            front: srgb_to_linear([228, 170, 176]),
            back: srgb_to_linear([214, 170, 174]),
            specular: 0.35,
            exponent: 18.0,
            sheen: 0.35,
            wet_response: 1.0,
        }
    }

    /// The table: a light, warm grey laminate, nearly matte.
    pub fn table() -> Self {
        Self {
            front: srgb_to_linear([146, 145, 142]),
            back: srgb_to_linear([146, 145, 142]),
            specular: 0.08,
            exponent: 24.0,
            sheen: 0.0,
            wet_response: 0.0,
        }
    }

    /// Solid obstacles: a neutral blue-grey, a little glossy.
    pub fn solid() -> Self {
        Self {
            front: srgb_to_linear([120, 132, 150]),
            back: srgb_to_linear([90, 96, 110]),
            specular: 0.3,
            exponent: 40.0,
            sheen: 0.1,
            wet_response: 0.0,
        }
    }

    fn uniform(&self) -> MaterialUniform {
        MaterialUniform {
            front: [self.front[0], self.front[1], self.front[2], self.specular],
            back: [self.back[0], self.back[1], self.back[2], self.sheen],
            spec: [self.exponent, self.wet_response, 0.0, 0.0],
        }
    }
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Globals {
    view_proj: [[f32; 4]; 4],
    light_view_proj: [[f32; 4]; 4],
    eye: [f32; 4],
    key_dir: [f32; 4],
    cam_right: [f32; 4],
    cam_up: [f32; 4],
    ground_point: [f32; 4],
    ground_normal: [f32; 4],
    focus: [f32; 4],
    shadow: [f32; 4],
    params: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct MaterialUniform {
    front: [f32; 4],
    back: [f32; 4],
    spec: [f32; 4],
}

/// One mesh vertex: position, normal and tint (linear RGB, weight).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Vertex {
    pos: [f32; 3],
    normal: [f32; 3],
    tint: [f32; 4],
}

/// One particle dot: centre and kind (0 particle, 1 cursor, 2 pin).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Dot {
    center: [f32; 3],
    kind: f32,
}

/// Side of the square shadow map, texels.
const SHADOW_SIZE: u32 = 1024;
const SHADOW_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// Unit direction towards the key light, fixed in the world (up, from -x and +z) so that the
/// light does not swing with an orbiting camera. It grazes enough to model the folds.
pub const KEY_LIGHT_DIR: [f32; 3] = [-0.52, 0.74, 0.42];

/// A GPU buffer that grows (never shrinks) to fit what is written to it.
struct GrowBuffer {
    buffer: wgpu::Buffer,
    usage: wgpu::BufferUsages,
    label: &'static str,
}

impl GrowBuffer {
    fn new(device: &wgpu::Device, label: &'static str, usage: wgpu::BufferUsages) -> Self {
        let usage = usage | wgpu::BufferUsages::COPY_DST;
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: 1024,
            usage,
            mapped_at_creation: false,
        });
        Self {
            buffer,
            usage,
            label,
        }
    }

    fn write(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, bytes: &[u8]) {
        if bytes.is_empty() {
            return;
        }
        if bytes.len() as u64 > self.buffer.size() {
            let size = (bytes.len() as u64).next_power_of_two().max(1024);
            self.buffer = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(self.label),
                size,
                usage: self.usage,
                mapped_at_creation: false,
            });
        }
        // Writes must be a multiple of 4 bytes; every element type here is.
        queue.write_buffer(&self.buffer, 0, bytes);
    }
}

/// Draws a [`SceneView`]: owns the pipelines (WGSL in `scene.wgsl`), the GPU buffers and the
/// key light's shadow map. Call [`ClothRenderer::prepare`] once per frame with the scene, then
/// [`ClothRenderer::paint`] inside a render pass whose colour (and depth, if any) formats and
/// sample count are those given to [`ClothRenderer::new`].
pub struct ClothRenderer {
    has_depth: bool,
    encode_srgb: bool,
    globals: wgpu::Buffer,
    globals_bind: wgpu::BindGroup,
    shadow_globals_bind: wgpu::BindGroup,
    cloth_material: wgpu::BindGroup,
    cloth_material_buffer: wgpu::Buffer,
    solid_material_buffer: wgpu::Buffer,
    table_material_buffer: wgpu::Buffer,
    solid_material: wgpu::BindGroup,
    table_material: wgpu::BindGroup,
    background: wgpu::RenderPipeline,
    mesh: wgpu::RenderPipeline,
    ground: wgpu::RenderPipeline,
    dots: wgpu::RenderPipeline,
    shadow: wgpu::RenderPipeline,
    shadow_view: wgpu::TextureView,
    cloth_vertices: GrowBuffer,
    cloth_indices: GrowBuffer,
    cloth_index_count: u32,
    solid_vertices: GrowBuffer,
    solid_indices: GrowBuffer,
    solid_index_count: u32,
    solid_key: Vec<Solid>,
    ground_vertices: GrowBuffer,
    ground_on: bool,
    dot_instances: GrowBuffer,
    dot_count: u32,
}

impl ClothRenderer {
    /// Builds the pipelines for a render pass drawing into `color_format`, with a depth
    /// attachment of `depth_format` (or none: then the cloth's triangles are sorted back to
    /// front on the CPU each frame, which is right for a single cloth), at `sample_count`
    /// samples per pixel.
    pub fn new(
        device: &wgpu::Device,
        color_format: wgpu::TextureFormat,
        depth_format: Option<wgpu::TextureFormat>,
        sample_count: u32,
    ) -> Self {
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("wetcloth scene"),
            source: wgpu::ShaderSource::Wgsl(include_str!("scene.wgsl").into()),
        });

        let globals_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("wetcloth globals"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Depth,
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Comparison),
                    count: None,
                },
            ],
        });
        // The shadow pass cannot bind the shadow map it writes: it gets the uniforms alone.
        let shadow_globals_layout =
            device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("wetcloth shadow globals"),
                entries: &[wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::VERTEX,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                }],
            });
        let material_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("wetcloth material"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            }],
        });

        let globals = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("wetcloth globals"),
            size: size_of::<Globals>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let shadow_texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("wetcloth shadow map"),
            size: wgpu::Extent3d {
                width: SHADOW_SIZE,
                height: SHADOW_SIZE,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: SHADOW_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        });
        let shadow_view = shadow_texture.create_view(&wgpu::TextureViewDescriptor::default());
        let shadow_sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("wetcloth shadow sampler"),
            address_mode_u: wgpu::AddressMode::ClampToEdge,
            address_mode_v: wgpu::AddressMode::ClampToEdge,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            compare: Some(wgpu::CompareFunction::LessEqual),
            ..Default::default()
        });
        let globals_bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("wetcloth globals"),
            layout: &globals_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: globals.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&shadow_view),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::Sampler(&shadow_sampler),
                },
            ],
        });
        let shadow_globals_bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("wetcloth shadow globals"),
            layout: &shadow_globals_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: globals.as_entire_binding(),
            }],
        });
        let material = |m: Material| {
            let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("wetcloth material"),
                contents: bytemuck::bytes_of(&m.uniform()),
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            });
            let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("wetcloth material"),
                layout: &material_layout,
                entries: &[wgpu::BindGroupEntry {
                    binding: 0,
                    resource: buffer.as_entire_binding(),
                }],
            });
            (buffer, bind)
        };
        let (cloth_material_buffer, cloth_material) = material(Material::satin());
        let (solid_material_buffer, solid_material) = material(Material::solid());
        let (table_material_buffer, table_material) = material(Material::table());

        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("wetcloth scene"),
            bind_group_layouts: &[Some(&globals_layout), Some(&material_layout)],
            immediate_size: 0,
        });
        let shadow_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("wetcloth shadow"),
            bind_group_layouts: &[Some(&shadow_globals_layout)],
            immediate_size: 0,
        });

        let mesh_buffers = [Some(wgpu::VertexBufferLayout {
            array_stride: size_of::<Vertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x4],
        })];
        let dot_buffers = [Some(wgpu::VertexBufferLayout {
            array_stride: size_of::<Dot>() as u64,
            step_mode: wgpu::VertexStepMode::Instance,
            attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32],
        })];
        let depth = |write: bool, compare: wgpu::CompareFunction| {
            depth_format.map(|format| wgpu::DepthStencilState {
                format,
                depth_write_enabled: Some(write),
                depth_compare: Some(compare),
                stencil: wgpu::StencilState::default(),
                bias: wgpu::DepthBiasState::default(),
            })
        };
        let pipeline = |label: &str,
                        vs: &str,
                        fs: &str,
                        buffers: &[Option<wgpu::VertexBufferLayout>],
                        depth_stencil: Option<wgpu::DepthStencilState>| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&layout),
                vertex: wgpu::VertexState {
                    module: &shader,
                    entry_point: Some(vs),
                    compilation_options: Default::default(),
                    buffers,
                },
                primitive: wgpu::PrimitiveState {
                    topology: wgpu::PrimitiveTopology::TriangleList,
                    front_face: wgpu::FrontFace::Ccw,
                    cull_mode: None,
                    ..Default::default()
                },
                depth_stencil,
                multisample: wgpu::MultisampleState {
                    count: sample_count.max(1),
                    mask: !0,
                    alpha_to_coverage_enabled: false,
                },
                fragment: Some(wgpu::FragmentState {
                    module: &shader,
                    entry_point: Some(fs),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState {
                        format: color_format,
                        blend: None,
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        use wgpu::CompareFunction::{Always, Less, LessEqual};
        let background = pipeline(
            "wetcloth background",
            "vs_background",
            "fs_background",
            &[],
            depth(false, Always),
        );
        let ground = pipeline(
            "wetcloth table",
            "vs_mesh",
            "fs_ground",
            &mesh_buffers,
            depth(true, Less),
        );
        let mesh = pipeline(
            "wetcloth mesh",
            "vs_mesh",
            "fs_mesh",
            &mesh_buffers,
            depth(true, LessEqual),
        );
        let dots = pipeline(
            "wetcloth dots",
            "vs_dot",
            "fs_dot",
            &dot_buffers,
            depth(true, LessEqual),
        );
        let shadow = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("wetcloth shadow"),
            layout: Some(&shadow_layout),
            vertex: wgpu::VertexState {
                module: &shader,
                entry_point: Some("vs_shadow"),
                compilation_options: Default::default(),
                buffers: &mesh_buffers,
            },
            primitive: wgpu::PrimitiveState {
                cull_mode: None,
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: SHADOW_FORMAT,
                depth_write_enabled: Some(true),
                depth_compare: Some(Less),
                stencil: wgpu::StencilState::default(),
                bias: wgpu::DepthBiasState {
                    constant: 2,
                    slope_scale: 1.5,
                    clamp: 0.0,
                },
            }),
            multisample: wgpu::MultisampleState::default(),
            fragment: None,
            multiview_mask: None,
            cache: None,
        });

        let vb = wgpu::BufferUsages::VERTEX;
        let ib = wgpu::BufferUsages::INDEX;
        Self {
            has_depth: depth_format.is_some(),
            encode_srgb: !color_format.is_srgb(),
            globals,
            globals_bind,
            shadow_globals_bind,
            cloth_material,
            cloth_material_buffer,
            solid_material_buffer,
            table_material_buffer,
            solid_material,
            table_material,
            background,
            mesh,
            ground,
            dots,
            shadow,
            shadow_view,
            cloth_vertices: GrowBuffer::new(device, "wetcloth cloth vertices", vb),
            cloth_indices: GrowBuffer::new(device, "wetcloth cloth indices", ib),
            cloth_index_count: 0,
            solid_vertices: GrowBuffer::new(device, "wetcloth solid vertices", vb),
            solid_indices: GrowBuffer::new(device, "wetcloth solid indices", ib),
            solid_index_count: 0,
            solid_key: Vec::new(),
            ground_vertices: GrowBuffer::new(device, "wetcloth table vertices", vb),
            ground_on: false,
            dot_instances: GrowBuffer::new(device, "wetcloth dots", vb),
            dot_count: 0,
        }
    }

    /// Replaces the materials (defaults: [`Material::satin`], [`Material::table`],
    /// [`Material::solid`]); `None` keeps one as it is.
    pub fn set_materials(
        &self,
        queue: &wgpu::Queue,
        cloth: Option<&Material>,
        table: Option<&Material>,
        solids: Option<&Material>,
    ) {
        for (m, buffer) in [
            (cloth, &self.cloth_material_buffer),
            (table, &self.table_material_buffer),
            (solids, &self.solid_material_buffer),
        ] {
            if let Some(m) = m {
                queue.write_buffer(buffer, 0, bytemuck::bytes_of(&m.uniform()));
            }
        }
    }

    /// Uploads `scene` for a viewport of `[width, height]` pixels and renders the key light's
    /// shadow map (submitted on `queue` right away, so it is ready before the frame's pass).
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &SceneView,
        viewport: [u32; 2],
    ) {
        let cam = &scene.camera;
        let aspect = viewport[0].max(1) as f32 / viewport[1].max(1) as f32;
        let view_proj = cam.view_proj(aspect);
        let eye = Vec3::from(cam.eye);
        let view = cam.view();
        let cam_right = view.row(0).truncate();
        let cam_up = view.row(1).truncate();

        // --- Cloth -------------------------------------------------------------------------
        let positions = scene.cloth.positions;
        let computed;
        let normals = if scene.cloth.normals.len() == positions.len() {
            scene.cloth.normals
        } else {
            computed = smooth_normals(positions, scene.cloth.indices);
            &computed
        };
        let tints = scene.tint.filter(|t| t.len() == positions.len());
        let vertices: Vec<Vertex> = positions
            .iter()
            .zip(normals)
            .enumerate()
            .map(|(k, (p, n))| Vertex {
                pos: *p,
                normal: *n,
                tint: tints.map_or([0.0; 4], |t| t[k]),
            })
            .collect();
        let n = positions.len() as u32;
        let mut indices: Vec<u32> = scene
            .cloth
            .indices
            .chunks_exact(3)
            .filter(|t| t.iter().all(|&k| k < n))
            .flatten()
            .copied()
            .collect();
        if !self.has_depth {
            sort_back_to_front(&mut indices, positions, eye);
        }
        self.cloth_vertices
            .write(device, queue, bytemuck::cast_slice(&vertices));
        self.cloth_indices
            .write(device, queue, bytemuck::cast_slice(&indices));
        self.cloth_index_count = indices.len() as u32;

        // --- Solids (rebuilt only when they change) ----------------------------------------
        if self.solid_key != scene.solids {
            let mut v = Vec::new();
            let mut i = Vec::new();
            for s in scene.solids {
                s.append_mesh(&mut v, &mut i);
            }
            let v: Vec<Vertex> = v
                .into_iter()
                .map(|[pos, normal]| Vertex {
                    pos,
                    normal,
                    tint: [0.0; 4],
                })
                .collect();
            self.solid_vertices
                .write(device, queue, bytemuck::cast_slice(&v));
            self.solid_indices
                .write(device, queue, bytemuck::cast_slice(&i));
            self.solid_index_count = i.len() as u32;
            self.solid_key = scene.solids.to_vec();
        }

        // --- Scene extent: what the shadow map covers and where the table fades -----------
        let mut pts: Vec<[f32; 3]> = Vec::new();
        if let Some(b) = bounds_of(positions) {
            pts.extend([b.0, b.1]);
        }
        for s in scene.solids {
            let b = s.bounds();
            pts.extend([b.0, b.1]);
        }
        let (lo, hi) = bounds_of(&pts).unwrap_or(([-0.15, 0.0, -0.15], [0.15, 0.02, 0.15]));
        let (lo, hi) = (Vec3::from(lo), Vec3::from(hi));
        let centre = (lo + hi) * 0.5;
        let extent = ((hi - lo).length() * 0.5).max(0.05);

        // --- Table -------------------------------------------------------------------------
        let ground = scene.ground.map(|g| {
            let normal = Vec3::from(g.normal).normalize_or(Vec3::Y);
            let point = Vec3::from(g.point);
            // The scene centre dropped onto the plane.
            let focus = centre - normal * normal.dot(centre - point);
            (point, normal, focus)
        });
        // The table fades out at a few scene sizes from the centre, and at most at a fraction of
        // the far plane (depth precision), and never closer than what the camera frames.
        let fade_radius = (extent * 6.0).min(cam.far * 0.4).max(extent * 1.5);
        self.ground_on = ground.is_some();
        if let Some((_, normal, focus)) = ground {
            let helper = if normal.x.abs() > 0.9 {
                Vec3::Z
            } else {
                Vec3::X
            };
            let t1 = normal.cross(helper).normalize();
            let t2 = normal.cross(t1);
            let r = fade_radius * 1.05;
            let corner = |u: f32, v: f32| Vertex {
                pos: (focus + (t1 * u + t2 * v) * r).to_array(),
                normal: normal.to_array(),
                tint: [0.0; 4],
            };
            let quad = [
                corner(-1.0, -1.0),
                corner(1.0, -1.0),
                corner(1.0, 1.0),
                corner(-1.0, -1.0),
                corner(1.0, 1.0),
                corner(-1.0, 1.0),
            ];
            self.ground_vertices
                .write(device, queue, bytemuck::cast_slice(&quad));
        }

        // --- Particle dots -----------------------------------------------------------------
        let source = scene.particles.unwrap_or(positions);
        let mut dots: Vec<Dot> = Vec::new();
        if let Some(ps) = scene.particles {
            dots.extend(ps.iter().map(|p| Dot {
                center: *p,
                kind: 0.0,
            }));
        }
        for &k in scene.pinned {
            if let Some(p) = source.get(k) {
                dots.push(Dot {
                    center: *p,
                    kind: 2.0,
                });
            }
        }
        if let Some(p) = scene.highlight.and_then(|k| source.get(k)) {
            dots.push(Dot {
                center: *p,
                kind: 1.0,
            });
        }
        if !self.has_depth {
            dots.sort_by(|a, b| {
                let da = Vec3::from(a.center).distance_squared(eye);
                let db = Vec3::from(b.center).distance_squared(eye);
                db.total_cmp(&da)
            });
        }
        self.dot_instances
            .write(device, queue, bytemuck::cast_slice(&dots));
        self.dot_count = dots.len() as u32;
        let dot_radius = if scene.particle_radius > 0.0 {
            scene.particle_radius
        } else {
            0.35 * mean_edge(positions, scene.cloth.indices).unwrap_or(0.003)
        };

        // --- Key light's shadow map: an orthographic box around the scene --------------------
        let key = Vec3::from(KEY_LIGHT_DIR).normalize();
        let light_eye = centre + key * extent * 4.0;
        let light_up = if key.cross(Vec3::Y).length_squared() < 1e-6 {
            Vec3::Z
        } else {
            Vec3::Y
        };
        let light_view = glam::camera::rh::view::look_at_mat4(light_eye, centre, light_up);
        let half = extent * 1.15;
        let light_proj = glam::camera::rh::proj::directx::orthographic(
            -half,
            half,
            -half,
            half,
            extent * 1.0,
            extent * 8.0,
        );
        let light_view_proj = light_proj * light_view;
        let shadows = self.cloth_index_count > 0 || self.solid_index_count > 0;

        let (gp, gn) = ground.map_or((Vec3::ZERO, Vec3::Y), |(p, n, _)| (p, n));
        let focus = ground.map_or(centre, |(_, _, f)| f);
        let globals = Globals {
            view_proj: view_proj.to_cols_array_2d(),
            light_view_proj: light_view_proj.to_cols_array_2d(),
            eye: eye.extend(1.0).to_array(),
            key_dir: key.extend(0.0).to_array(),
            cam_right: cam_right.extend(0.0).to_array(),
            cam_up: cam_up.extend(0.0).to_array(),
            ground_point: gp.extend(grid_spacing(extent)).to_array(),
            ground_normal: gn.extend(fade_radius).to_array(),
            focus: focus.extend(dot_radius).to_array(),
            shadow: [
                2.0 * half / SHADOW_SIZE as f32,
                if shadows { 1.0 } else { 0.0 },
                SHADOW_SIZE as f32,
                0.0,
            ],
            params: [
                scene.wetness.clamp(0.0, 1.0),
                if self.encode_srgb { 1.0 } else { 0.0 },
                viewport[0] as f32,
                viewport[1] as f32,
            ],
        };
        queue.write_buffer(&self.globals, 0, bytemuck::bytes_of(&globals));

        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("wetcloth shadow"),
        });
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("wetcloth shadow"),
                color_attachments: &[],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &self.shadow_view,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.shadow);
            pass.set_bind_group(0, &self.shadow_globals_bind, &[]);
            self.draw_meshes(&mut pass);
        }
        queue.submit([encoder.finish()]);
    }

    fn draw_meshes(&self, pass: &mut wgpu::RenderPass<'_>) {
        if self.solid_index_count > 0 {
            pass.set_vertex_buffer(0, self.solid_vertices.buffer.slice(..));
            pass.set_index_buffer(
                self.solid_indices.buffer.slice(..),
                wgpu::IndexFormat::Uint32,
            );
            pass.draw_indexed(0..self.solid_index_count, 0, 0..1);
        }
        if self.cloth_index_count > 0 {
            pass.set_vertex_buffer(0, self.cloth_vertices.buffer.slice(..));
            pass.set_index_buffer(
                self.cloth_indices.buffer.slice(..),
                wgpu::IndexFormat::Uint32,
            );
            pass.draw_indexed(0..self.cloth_index_count, 0, 0..1);
        }
    }

    /// Records the frame prepared last into `pass`: backdrop, table, solids, cloth, dots.
    pub fn paint(&self, pass: &mut wgpu::RenderPass<'_>) {
        pass.set_bind_group(0, &self.globals_bind, &[]);
        pass.set_bind_group(1, &self.table_material, &[]);
        pass.set_pipeline(&self.background);
        pass.draw(0..3, 0..1);
        if self.ground_on {
            pass.set_pipeline(&self.ground);
            pass.set_vertex_buffer(0, self.ground_vertices.buffer.slice(..));
            pass.draw(0..6, 0..1);
        }
        pass.set_pipeline(&self.mesh);
        if self.solid_index_count > 0 {
            pass.set_bind_group(1, &self.solid_material, &[]);
            pass.set_vertex_buffer(0, self.solid_vertices.buffer.slice(..));
            pass.set_index_buffer(
                self.solid_indices.buffer.slice(..),
                wgpu::IndexFormat::Uint32,
            );
            pass.draw_indexed(0..self.solid_index_count, 0, 0..1);
        }
        if self.cloth_index_count > 0 {
            pass.set_bind_group(1, &self.cloth_material, &[]);
            pass.set_vertex_buffer(0, self.cloth_vertices.buffer.slice(..));
            pass.set_index_buffer(
                self.cloth_indices.buffer.slice(..),
                wgpu::IndexFormat::Uint32,
            );
            pass.draw_indexed(0..self.cloth_index_count, 0, 0..1);
        }
        if self.dot_count > 0 {
            pass.set_pipeline(&self.dots);
            pass.set_vertex_buffer(0, self.dot_instances.buffer.slice(..));
            pass.draw(0..6, 0..self.dot_count);
        }
    }
}

// The viewer keeps the renderer in egui-wgpu's callback resources, which must be Send + Sync.
const _: fn() = || {
    fn send_sync<T: Send + Sync + 'static>() {}
    send_sync::<ClothRenderer>();
};

/// Sorts triangles far to near from `eye` (painter's algorithm, for passes without depth).
fn sort_back_to_front(indices: &mut [u32], positions: &[[f32; 3]], eye: Vec3) {
    let mut tris: Vec<(f32, [u32; 3])> = indices
        .chunks_exact(3)
        .map(|t| {
            let c = (Vec3::from(positions[t[0] as usize])
                + Vec3::from(positions[t[1] as usize])
                + Vec3::from(positions[t[2] as usize]))
                / 3.0;
            (c.distance_squared(eye), [t[0], t[1], t[2]])
        })
        .collect();
    tris.sort_by(|a, b| b.0.total_cmp(&a.0));
    for (dst, (_, t)) in indices.chunks_exact_mut(3).zip(tris) {
        dst.copy_from_slice(&t);
    }
}

/// Mean length of the mesh's triangle edges, m.
fn mean_edge(positions: &[[f32; 3]], indices: &[u32]) -> Option<f32> {
    let mut sum = 0.0;
    let mut count = 0usize;
    for t in indices.chunks_exact(3).take(2000) {
        let (a, b) = (t[0] as usize, t[1] as usize);
        if let (Some(a), Some(b)) = (positions.get(a), positions.get(b)) {
            sum += Vec3::from(*a).distance(Vec3::from(*b));
            count += 1;
        }
    }
    (count > 0 && sum > 0.0).then(|| sum / count as f32)
}

/// Grid spacing on the table for a scene of half-size `extent`: a round number (1, 2 or 5
/// times a power of ten) near a sixth of the extent, so a 30 cm cloth shows 5 cm squares.
fn grid_spacing(extent: f32) -> f32 {
    let target = (extent / 4.0).max(1e-4);
    let decade = 10f32.powf(target.log10().floor());
    let m = target / decade;
    let step = if m < 1.5 {
        1.0
    } else if m < 3.5 {
        2.0
    } else {
        5.0
    };
    step * decade
}
