//! `[cloth]`: the cloth's size, resolution, material and collision sphere.

use crate::math::{Real, Vec3};

/// The cloth (`[cloth]` in a scene file): a square grid of particles, flat in the xz plane.
#[derive(Clone, Debug, PartialEq)]
pub struct ClothParams {
    /// Extent along x and z, m. Default (0.30, 0.30) (thesis ch. 4); each in [1e-3, 1e3].
    pub size: [Real; 2],
    /// Particles along x and z. Default (50, 50) (thesis: 2500 particles); each in [2, 4096].
    pub resolution: [usize; 2],
    /// Centre of the cloth at t = 0, m. Default (0, 0.002, 0).
    pub position: Vec3,
    /// Mass of the whole cloth, kg, shared equally by the particles. Default 0.02; range
    /// [1e-6, 1e4].
    pub mass: Real,
    /// Stiffness of the structural springs (4 grid neighbours), N/m. Default 500; range
    /// [0, 1e7]. With the shear stiffness and the particle mass it sets the explicit stability
    /// limit of the time step, see [`crate::SimConfig::stable_time_step`].
    pub structural_stiffness: Real,
    /// Stiffness of the shear springs (4 diagonal neighbours), N/m. Default 125 (shear is
    /// softer than the weave); range [0, 1e7].
    pub shear_stiffness: Real,
    /// Velocity damping rate, 1/s: every particle feels `-damping * m * v`, so free motion decays
    /// as `exp(-damping * t)`. Default 0 (none); range [0, 1e4].
    pub damping: Real,
    /// Cloth thickness, m. Default 0.001; range [0, 0.1].
    pub thickness: Real,
    /// Collision margin added to the thickness, m: particles are spheres of diameter
    /// `thickness + collision_margin` (thesis 3.1). Default 0.0005; range [0, 0.1].
    pub collision_margin: Real,
    /// Whether particles collide with each other (thesis 3.1). Default true.
    pub self_collision: bool,
    /// Provot strain limit: the largest relative stretch allowed for a structural or shear
    /// spring (0.1 = 10 %); 0 turns it off. Default 0 (off, as in the thesis); range [0, 10].
    pub strain_limit: Real,
    /// Most Gauss-Seidel sweeps of the strain limiter per step; it stops as soon as every spring
    /// is within 0.5 % of the limit, which takes one sweep while nothing is over-stretched and a
    /// few where the cloth pulls against it. Default 100; range [1, 10000].
    pub strain_limit_iterations: usize,
    /// How wet the cloth is, 0 (dry) to 1 (soaked), everywhere but where `paint` says
    /// otherwise. Wetness seals (at `[air] seal_wetness` and above, with the pockets model), adds
    /// water's mass (`water_mass`), and moves friction and the fabric's permeability between
    /// their dry and wet values. Default 1 (the thesis' wet satin); range [0, 1].
    pub wetness: Real,
    /// Regions painted with another wetness, in order (a later one paints over an earlier).
    /// Default none.
    pub paint: Vec<WetPaint>,
    /// Mass of the water a soaked cloth holds, kg per m^2 of cloth: a particle of wetness `w`
    /// weighs `mass / n + water_mass * w * S`. Default 0 (`mass` is the cloth as simulated,
    /// water included, as in the thesis); range [0, 100].
    pub water_mass: Real,
    /// Friction of dry cloth as a share of the colliders' (wet) friction: a particle of wetness
    /// `w` has friction `mu * (f + (1 - f) w)`. Default 1 (friction does not depend on
    /// wetness); range [0, 10].
    pub dry_friction_factor: Real,
    /// With the pockets model: the water film's suction on a sealed particle of a soaked
    /// cloth, Pa (a particle of wetness `w` is pulled onto the surface by `wet_adhesion * w * S`
    /// newtons while it seals, that is within `[air] seal_distance` of touching). Peeling a
    /// sealed particle off costs `wet_adhesion * seal_distance` joules per m^2, the water
    /// film's work of adhesion `2 gamma` = 0.144 J/m^2 (`gamma` = 0.072 N/m) over the default
    /// 0.5 mm: about 300 Pa. It keeps a pocket's rim sealed against the air pushing out; a
    /// larger value (1000 Pa, the capillary pressure `2 gamma / d` of a 0.15 mm film) keeps
    /// bubbles under a soft cloth from peeling their own rims. Default 300; range [0, 1e6].
    pub wet_adhesion: Real,
    /// A cloth of any shape (`[cloth] mesh`): the triangle or polygon mesh it is, placed by
    /// `position`; `None` (the default) for the built-in grid of `size` and `resolution`.
    pub mesh: Option<ClothMeshSource>,
    /// The cloth's mechanics (`[cloth] model`): the thesis' springs (the default) or membrane
    /// and bending elements on its triangles.
    pub model: ClothModel,
    /// The membrane of `model = "membrane"` (`[cloth.membrane]`).
    pub membrane: MembraneParams,
    /// The bending of `model = "membrane"` (`[cloth.bending]`).
    pub bending: BendingParams,
    /// Areal density of the dry cloth, kg/m^2 (`[cloth] density`): when given, the cloth's
    /// mass is `density` times its rest area and `mass` is not used. Default none; range
    /// [1e-6, 1e3].
    pub density: Option<Real>,
    /// The measured fabric the cloth's values came from (`[cloth] material`), if any: the scene
    /// reader fills `model`, `density`, `membrane`, `bending`, `water_mass` and
    /// `dry_friction_factor` from its table ([`crate::params::materials`]) at the cloth's
    /// wetness, except the keys the scene writes.
    pub material: Option<String>,
    /// Seams (`[[cloth.seam]]`): particle pairs of two panels pulled together by zero-length
    /// springs ([`crate::forces::seam`]). Default none. A mesh cloth's (or `model =
    /// "membrane"`'s) only.
    pub seams: Vec<crate::forces::seam::SeamSpec>,
    /// Shrink of the cloth's rest shape, a fraction (`[cloth] shrink`): its springs' rest
    /// lengths and its membrane's and bending elements' rest triangles are `1 - shrink` of
    /// their size at t = 0 (the rest shape scaled, its angles kept), so a garment made to the
    /// body's size is pulled onto it as a snug, wet one clings (Blender's cloth "shrinking").
    /// Mass, areas and the air's `S` keep the cloth as placed. Default 0; range [0, 0.5].
    pub shrink: Real,
}

/// The cloth's mechanics (`[cloth] model`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ClothModel {
    /// The thesis' springs (eq. 3.6): structural and shear on the grid, along and across the
    /// edges of a mesh (`"springs"`, the default). Equal masses on the grid, lumped by area on a
    /// mesh.
    #[default]
    Springs,
    /// An orthotropic membrane element per triangle and a bending element per interior edge
    /// (`"membrane"`), on the grid's triangles or a mesh's; mass lumped by area.
    Membrane,
}

impl ClothModel {
    /// Every model, in the order the docs list them.
    pub const ALL: [ClothModel; 2] = [ClothModel::Springs, ClothModel::Membrane];

    /// The scene-file name.
    pub fn name(self) -> &'static str {
        match self {
            ClothModel::Springs => "springs",
            ClothModel::Membrane => "membrane",
        }
    }
}

/// The membrane of `model = "membrane"` (`[cloth.membrane]`): an orthotropic sheet whose axes
/// are the fabric's warp and weft.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MembraneParams {
    /// Tension per unit width per unit strain along the warp with the weft free, N/m. Default
    /// 600; range (0, 1e7].
    pub warp: Real,
    /// The same along the weft, N/m. Default 600; range (0, 1e7].
    pub weft: Real,
    /// Shear force per unit length per unit engineering shear strain, N/m. Default 125; range
    /// (0, 1e7].
    pub shear: Real,
    /// Lateral contraction of the weft per unit warp strain (Poisson's ratio nu12). Default 0;
    /// range [0, 0.5), and `poisson^2 weft / warp < 1`.
    pub poisson: Real,
}

impl Default for MembraneParams {
    fn default() -> Self {
        Self {
            warp: 600.0,
            weft: 600.0,
            shear: 125.0,
            poisson: 0.0,
        }
    }
}

/// The bending of `model = "membrane"` (`[cloth.bending]`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BendingParams {
    /// Bending rigidity B, N m: the moment per unit width per unit curvature of a narrow strip
    /// (textile testing's B). Default 0 (none, as the thesis' springs); range [0, 1].
    pub stiffness: Real,
    /// B's factor for curvature along the warp. Default 1; range [0, 1e3].
    pub warp: Real,
    /// B's factor for curvature along the weft. Default 1; range [0, 1e3].
    pub weft: Real,
    /// The rest curvature: the rest mesh's own (the default; flat for the grid) or flat.
    pub rest: BendingRest,
}

impl Default for BendingParams {
    fn default() -> Self {
        Self {
            stiffness: 0.0,
            warp: 1.0,
            weft: 1.0,
            rest: BendingRest::Mesh,
        }
    }
}

/// The rest curvature of the bending elements (`[cloth.bending] rest`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BendingRest {
    /// The rest mesh's own dihedral angles (`"mesh"`): a garment modelled curved keeps its
    /// shape. The default.
    #[default]
    Mesh,
    /// Flat (`"flat"`).
    Flat,
}

impl BendingRest {
    /// Every value, in the order the docs list them.
    pub const ALL: [BendingRest; 2] = [BendingRest::Mesh, BendingRest::Flat];

    /// The scene-file name.
    pub fn name(self) -> &'static str {
        match self {
            BendingRest::Mesh => "mesh",
            BendingRest::Flat => "flat",
        }
    }
}

/// A cloth read from a mesh file (`[cloth] mesh = "towel.obj"`, with `rotation`, `scale` and
/// `flip_normals`; the scene reader reads the file, the core reads none). Particle `k` is the
/// file's vertex `k`; polygons are split into a fan of triangles for the physics and kept whole
/// for the outputs.
#[derive(Clone, Debug, PartialEq)]
pub struct ClothMeshSource {
    /// The file it was read from (for descriptions; the scene reader gives the absolute path).
    pub file: String,
    /// The vertices as given, in the file's units (before scale, rotation and position).
    pub vertices: std::sync::Arc<Vec<Vec3>>,
    /// The faces as given: each a polygon of 3 or more vertex indices from 0, in the file's
    /// order and winding.
    pub faces: std::sync::Arc<Vec<Vec<u32>>>,
    /// Texture coordinates (`vt`), if the file has any.
    pub uvs: std::sync::Arc<Vec<[Real; 2]>>,
    /// Each face's texture-coordinate indices (from 0), corner by corner; empty when the faces
    /// have none.
    pub face_uvs: std::sync::Arc<Vec<Vec<u32>>>,
    /// Rotation about x, then y, then z (R = Rz Ry Rx), degrees. Default (0, 0, 0); each in
    /// [-1e6, 1e6].
    pub rotation: Vec3,
    /// The file's units to metres, applied first. Default 1; range (0, 1e4].
    pub scale: Real,
    /// Reverses the faces' winding for the physics (the side the air is on); the outputs keep
    /// the file's winding. Default false.
    pub flip_normals: bool,
}

impl ClothMeshSource {
    /// The vertices placed in the scene with their origin at `position` (m).
    pub fn placed(&self, position: Vec3) -> Vec<Vec3> {
        let r = crate::collide::motion::rotation_matrix(self.rotation);
        self.vertices
            .iter()
            .map(|&v| position + r * (v * self.scale))
            .collect()
    }

    /// The physics' triangles: each face as a fan from its first corner, reversed with
    /// `flip_normals`; with the face each came from.
    pub fn triangles(&self) -> (Vec<[u32; 3]>, Vec<u32>) {
        let mut t = Vec::with_capacity(self.faces.iter().map(|f| f.len().saturating_sub(2)).sum());
        let mut from = Vec::with_capacity(t.capacity());
        for (i, f) in self.faces.iter().enumerate() {
            for k in 1..f.len().saturating_sub(1) {
                let tri = [f[0], f[k], f[k + 1]];
                t.push(if self.flip_normals {
                    [tri[0], tri[2], tri[1]]
                } else {
                    tri
                });
                from.push(i as u32);
            }
        }
        (t, from)
    }
}

impl ClothMeshSource {
    /// Each physics triangle's texture coordinates corner by corner (as [`Self::triangles`]
    /// orders them), when every face has them.
    pub fn triangle_uvs(&self) -> Option<Vec<[[Real; 2]; 3]>> {
        if self.face_uvs.len() != self.faces.len() || self.uvs.is_empty() {
            return None;
        }
        let mut out = Vec::new();
        for (f, fu) in self.faces.iter().zip(self.face_uvs.iter()) {
            if fu.len() != f.len() {
                return None;
            }
            let uv = |i: usize| self.uvs.get(fu[i] as usize).copied();
            for k in 1..f.len().saturating_sub(1) {
                let (a, b, c) = (uv(0)?, uv(k)?, uv(k + 1)?);
                out.push(if self.flip_normals {
                    [a, c, b]
                } else {
                    [a, b, c]
                });
            }
        }
        Some(out)
    }
}

/// A region of the cloth painted with its own wetness (`[[cloth.paint]]`): a disc (`radius`)
/// or a box (`half_size`) in the cloth's rest coordinates: x and z in metres from the cloth's
/// centre, before it moves.
#[derive(Clone, Debug, PartialEq)]
pub struct WetPaint {
    /// Centre of the region, m, as (x, z) from the cloth's centre at rest. Default (0, 0); each
    /// in [-1e3, 1e3].
    pub center: [Real; 2],
    /// The region's shape.
    pub shape: PaintShape,
    /// Wetness inside the region, 0..1. Required.
    pub wetness: Real,
    /// On a mesh cloth: the region's centre in scene coordinates at t = 0, m (a 3-component
    /// `center`); the region is then a ball (`radius`) or a box (`half_size`, 3 components).
    /// `None` on the grid.
    pub point: Option<Vec3>,
}

/// The shape of a [`WetPaint`] region.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PaintShape {
    /// A disc of this radius, m; range (0, 1e3].
    Disc(Real),
    /// A box of these half sizes along x and z, m; each in (0, 1e3].
    Box([Real; 2]),
    /// On a mesh cloth: a box of these half sizes along x, y and z, m; each in (0, 1e3].
    Cuboid([Real; 3]),
}

impl WetPaint {
    /// Whether the point `p` (m, scene coordinates at t = 0) is inside a mesh cloth's region.
    pub fn contains_point(&self, p: Vec3) -> bool {
        let d = p - self.point.unwrap_or(Vec3::ZERO);
        match self.shape {
            PaintShape::Disc(r) => d.length_squared() <= r * r,
            PaintShape::Box([hx, hz]) => d.x.abs() <= hx && d.z.abs() <= hz,
            PaintShape::Cuboid(h) => d.x.abs() <= h[0] && d.y.abs() <= h[1] && d.z.abs() <= h[2],
        }
    }

    /// Whether the rest point (x, z) (m from the cloth's centre) is inside the region.
    pub fn contains(&self, x: Real, z: Real) -> bool {
        let (dx, dz) = (x - self.center[0], z - self.center[1]);
        match self.shape {
            PaintShape::Disc(r) => dx * dx + dz * dz <= r * r,
            PaintShape::Box([hx, hz]) => dx.abs() <= hx && dz.abs() <= hz,
            PaintShape::Cuboid([hx, _, hz]) => dx.abs() <= hx && dz.abs() <= hz,
        }
    }
}

impl Default for ClothParams {
    fn default() -> Self {
        Self {
            size: [0.30, 0.30],
            resolution: [50, 50],
            position: Vec3::new(0.0, 0.002, 0.0),
            mass: 0.02,
            structural_stiffness: 500.0,
            shear_stiffness: 125.0,
            damping: 0.0,
            thickness: 0.001,
            collision_margin: 0.0005,
            self_collision: true,
            strain_limit: 0.0,
            strain_limit_iterations: 100,
            wetness: 1.0,
            paint: Vec::new(),
            water_mass: 0.0,
            dry_friction_factor: 1.0,
            wet_adhesion: 300.0,
            mesh: None,
            model: ClothModel::Springs,
            membrane: MembraneParams::default(),
            bending: BendingParams::default(),
            density: None,
            material: None,
            seams: Vec::new(),
            shrink: 0.0,
        }
    }
}

impl ClothParams {
    /// Radius of a particle's collision sphere, m: `(thickness + collision_margin) / 2`.
    pub fn particle_radius(&self) -> Real {
        0.5 * (self.thickness + self.collision_margin)
    }

    /// Number of particles: the grid's, or the mesh's vertices.
    pub fn particle_count(&self) -> usize {
        match &self.mesh {
            Some(m) => m.vertices.len(),
            None => self.resolution[0] * self.resolution[1],
        }
    }

    /// Wetness at the rest point (x, z) (m from the cloth's centre): the last paint region that
    /// holds it, else `wetness`.
    pub fn wetness_at(&self, x: Real, z: Real) -> Real {
        self.paint
            .iter()
            .rev()
            .find(|p| p.contains(x, z))
            .map_or(self.wetness, |p| p.wetness)
    }

    /// Wetness of a mesh cloth at the point `p` (m, scene coordinates at t = 0): the last paint
    /// region that holds it, else `wetness`.
    pub fn wetness_at_point(&self, p: Vec3) -> Real {
        self.paint
            .iter()
            .rev()
            .find(|r| r.contains_point(p))
            .map_or(self.wetness, |r| r.wetness)
    }

    /// Whether the cloth is equally wet everywhere.
    pub fn uniformly_wet(&self) -> bool {
        self.paint.iter().all(|p| p.wetness == self.wetness)
    }
}
