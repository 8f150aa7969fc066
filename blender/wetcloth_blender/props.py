"""The add-on's settings: per object (``Object.wetcloth``), per scene (``Scene.wetcloth``) and
the preferences (``cli_path``).

The cloth's parameters carry the scene file's key names (docs/scene-format.md), with ``air_``
before the two ``[air]`` keys whose names alone say too little (``air_enabled``,
``air_model``). Their ranges are the scene format's; the command checks them again and names
the key when a value is refused. ``PARAMETERS`` lists them with their scene table and key, which
the exporter and the panel both follow.
"""

import bpy
from bpy.props import (
    BoolProperty,
    CollectionProperty,
    EnumProperty,
    FloatProperty,
    IntProperty,
    PointerProperty,
    StringProperty,
)


def _package():
    return __package__ or "wetcloth_blender"


# (property, scene table, scene key, enum values or None). Enum identifiers are the scene
# values in capitals.
PARAMETERS = [
    ("integrator", "simulation", "integrator", ("verlet", "implicit")),
    ("time_step", "simulation", "time_step", None),
    ("implicit_budget", "simulation", "implicit_budget", ("converged", "interactive")),
    ("mass", "cloth", "mass", None),
    ("structural_stiffness", "cloth", "structural_stiffness", None),
    ("shear_stiffness", "cloth", "shear_stiffness", None),
    ("damping", "cloth", "damping", None),
    ("thickness", "cloth", "thickness", None),
    ("collision_margin", "cloth", "collision_margin", None),
    ("self_collision", "cloth", "self_collision", None),
    ("strain_limit", "cloth", "strain_limit", None),
    ("wetness", "cloth", "wetness", None),
    ("water_mass", "cloth", "water_mass", None),
    ("dry_friction_factor", "cloth", "dry_friction_factor", None),
    ("wet_adhesion", "cloth", "wet_adhesion", None),
    ("flip_normals", "cloth", "flip_normals", None),
    ("air_enabled", "air", "enabled", None),
    ("air_model", "air", "model", ("thesis", "pockets")),
    ("atmospheric_pressure", "air", "atmospheric_pressure", None),
    ("trapped_air", "air", "trapped_air", None),
    ("leak_conductance", "air", "leak_conductance", None),
    ("pressure_solve", "air", "pressure_solve", ("implicit", "explicit")),
    ("pressure_force", "air", "pressure_force", ("thesis", "area")),
    ("seal_distance", "air", "seal_distance", None),
    ("seal_hysteresis", "air", "seal_hysteresis", None),
    ("seal_wetness", "air", "seal_wetness", None),
    ("permeability", "air", "permeability", None),
    ("dry_permeability", "air", "dry_permeability", None),
]

# The property that a scene key names, for messages from the command (``cloth.mass`` -> mass).
PROPERTY_OF_KEY = {f"{table}.{key}": prop for prop, table, key, _ in PARAMETERS}


class WetclothPreferences(bpy.types.AddonPreferences):
    bl_idname = _package()

    cli_path: StringProperty(
        name="wetcloth command",
        description="The wetcloth program; empty: the one found on PATH",
        subtype="FILE_PATH",
        default="",
    )

    def draw(self, context):
        from . import runner

        self.layout.prop(self, "cli_path")
        found = runner.find_cli(quiet=True)
        self.layout.label(text=f"Uses: {found}" if found else "Not found: set the path above or put it on PATH")


class WetclothHand(bpy.types.PropertyGroup):
    vertex_group: StringProperty(
        name="Vertex Group",
        description="The cloth's vertices this hand holds; they follow the target's motion",
    )
    target: PointerProperty(
        name="Target",
        type=bpy.types.Object,
        description="The object (an empty) whose animation the held vertices follow, sampled every frame",
    )


def _air_default_note():
    return "pockets: sealed pockets on any sticky collider; thesis: one bubble over the first plane"


class WetclothObject(bpy.types.PropertyGroup):
    role: EnumProperty(
        name="Role",
        description="What this object is to the wet cloth simulation",
        items=[
            ("NONE", "None", "Not part of the simulation"),
            ("CLOTH", "Cloth", "The wet cloth (one per scene); its mesh is the cloth, vertex k particle k"),
            ("COLLIDER", "Collider", "A solid the cloth rests on, sticks to and slides over"),
        ],
        default="NONE",
    )

    # --- cloth: simulation -------------------------------------------------------------------
    integrator: EnumProperty(
        name="Integrator",
        description="simulation.integrator: the time integrator",
        items=[
            ("VERLET", "Verlet", "Position Verlet (the thesis): explicit, needs small steps (about 1/12000 s)"),
            ("IMPLICIT", "Implicit", "Backward Euler with a conjugate gradient: large steps (1/600 s to 1/60 s)"),
        ],
        default="IMPLICIT",
    )
    time_step: FloatProperty(
        name="Time Step",
        description=(
            "simulation.time_step, s: the integration step, rounded down so that a whole number "
            "of steps fits in a frame. Verlet: [1e-7, 1e-2]; implicit: [1e-7, 0.05]"
        ),
        default=1.0 / 1200.0,
        min=1e-7,
        max=0.05,
        precision=6,
        step=0.01,
    )
    implicit_budget: EnumProperty(
        name="Solve Budget",
        description="simulation.implicit_budget: how far the implicit integrator solves each step",
        items=[
            ("CONVERGED", "Converged", "Until contacts, friction and pressure settle (accurate)"),
            ("INTERACTIVE", "Interactive", "At most three solves per step (fast, less accurate)"),
        ],
        default="CONVERGED",
    )

    # --- cloth: material ---------------------------------------------------------------------
    mass: FloatProperty(
        name="Mass", description="cloth.mass, kg: the whole cloth's mass", default=0.02,
        min=1e-6, max=1e4, unit="MASS", precision=4,
    )
    structural_stiffness: FloatProperty(
        name="Structural Stiffness", description="cloth.structural_stiffness, N/m: springs along the weave",
        default=500.0, min=0.0, max=1e7,
    )
    shear_stiffness: FloatProperty(
        name="Shear Stiffness", description="cloth.shear_stiffness, N/m: springs across the weave",
        default=125.0, min=0.0, max=1e7,
    )
    damping: FloatProperty(
        name="Damping", description="cloth.damping, 1/s: velocity damping rate", default=0.0, min=0.0, max=1e4,
    )
    thickness: FloatProperty(
        name="Thickness", description="cloth.thickness, m", default=0.001, min=0.0, max=0.1,
        unit="LENGTH", precision=4,
    )
    collision_margin: FloatProperty(
        name="Collision Margin",
        description="cloth.collision_margin, m: added to the thickness; particles are spheres of diameter thickness + margin",
        default=0.0005, min=0.0, max=0.1, unit="LENGTH", precision=4,
    )
    self_collision: BoolProperty(
        name="Self Collision", description="cloth.self_collision: particles collide with each other", default=True,
    )
    strain_limit: FloatProperty(
        name="Strain Limit", description="cloth.strain_limit: the largest stretch (0.1 = 10 %); 0 is off",
        default=0.0, min=0.0, max=10.0,
    )
    wetness: FloatProperty(
        name="Wetness", description="cloth.wetness, 0..1: how wet the cloth is (0.5 and above seals)",
        default=1.0, min=0.0, max=1.0, subtype="FACTOR",
    )
    water_mass: FloatProperty(
        name="Water Mass", description="cloth.water_mass, kg/m^2: water a soaked cloth holds",
        default=0.0, min=0.0, max=100.0,
    )
    dry_friction_factor: FloatProperty(
        name="Dry Friction Factor", description="cloth.dry_friction_factor: friction of dry cloth as a share of the colliders'",
        default=1.0, min=0.0, max=10.0,
    )
    wet_adhesion: FloatProperty(
        name="Film Pull", description="cloth.wet_adhesion, Pa: the water film's pull on a sealed particle (pockets model)",
        default=300.0, min=0.0, max=1e6,
    )
    flip_normals: BoolProperty(
        name="Flip Normals",
        description="cloth.flip_normals: the air is on the other side (the faces' normals should point away from the surface the cloth lies on)",
        default=False,
    )

    # --- cloth: air ----------------------------------------------------------------------------
    air_enabled: BoolProperty(
        name="Air", description="air.enabled: the trapped air's pressure (and, with pockets, the film's pull) acts",
        default=True,
    )
    air_model: EnumProperty(
        name="Air Model",
        description="air.model: " + _air_default_note(),
        items=[
            ("POCKETS", "Pockets", "Sealed air pockets form wherever the wet cloth touches a sticky collider"),
            ("THESIS", "Bubble", "The thesis' single bubble over the first plane collider (mark one as Plane)"),
        ],
        default="POCKETS",
    )
    atmospheric_pressure: FloatProperty(
        name="Atmospheric Pressure", description="air.atmospheric_pressure, Pa", default=101325.0, min=0.0, max=1e7,
    )
    trapped_air: FloatProperty(
        name="Trapped Air", description="air.trapped_air, m^3: air under the cloth at atmospheric pressure (bubble model)",
        default=0.0, min=0.0, max=1e3, precision=6,
    )
    leak_conductance: FloatProperty(
        name="Leak Conductance", description="air.leak_conductance, m^2/s: air flowing in where the border lifts",
        default=0.0, min=0.0, max=10.0, precision=5,
    )
    pressure_solve: EnumProperty(
        name="Pressure Solve",
        description="air.pressure_solve",
        items=[
            ("IMPLICIT", "Implicit", "Boyle's law solved at the end of each step (stable for small bubbles)"),
            ("EXPLICIT", "Explicit", "The thesis' pressure from the step's start"),
        ],
        default="IMPLICIT",
    )
    pressure_force: EnumProperty(
        name="Pressure Force",
        description="air.pressure_force",
        items=[
            ("THESIS", "Thesis", "(P_b - P_a) S N with equal areas"),
            ("AREA", "Area", "Each particle's share of the area vector"),
        ],
        default="THESIS",
    )
    seal_distance: FloatProperty(
        name="Seal Distance", description="air.seal_distance, m: how far beyond its radius a particle still seals",
        default=0.0005, min=0.0, max=0.1, unit="LENGTH", precision=4,
    )
    seal_hysteresis: FloatProperty(
        name="Seal Hysteresis", description="air.seal_hysteresis: the seal's wetting hysteresis, a share of the seal distance",
        default=0.0, min=0.0, max=1.0, subtype="FACTOR",
    )
    seal_wetness: FloatProperty(
        name="Seal Wetness", description="air.seal_wetness: the least wetness that seals",
        default=0.5, min=1e-6, max=1.0, subtype="FACTOR",
    )
    permeability: FloatProperty(
        name="Permeability", description="air.permeability, m/(s Pa): air through the soaked weave",
        default=0.0, min=0.0, max=1.0, precision=7,
    )
    dry_permeability: FloatProperty(
        name="Dry Permeability", description="air.dry_permeability, m/(s Pa): air through dry weave",
        default=1e-4, min=0.0, max=1.0, precision=7,
    )

    # --- cloth: pins and hands -----------------------------------------------------------------
    pin_group: StringProperty(
        name="Pin Group", description="The vertex group held still (every vertex of weight above 0)",
    )
    hands: CollectionProperty(type=WetclothHand)
    active_hand: IntProperty(default=0)

    # --- collider ------------------------------------------------------------------------------
    collider_shape: EnumProperty(
        name="Shape",
        description="How the collider is written",
        items=[
            ("MESH", "Mesh", "The object's evaluated mesh (OBJ), moved by its transform"),
            ("PLANE", "Plane", "An infinite plane through the origin, normal along the local Z axis"),
            ("SPHERE", "Sphere", "A sphere filling the bounding box (radius: half the largest dimension)"),
            ("BOX", "Box", "The bounding box, turning with the object"),
        ],
        default="MESH",
    )
    friction: FloatProperty(
        name="Friction", description="collider.friction: Coulomb friction coefficient", default=0.6, min=0.0, max=10.0,
    )
    sticky: BoolProperty(
        name="Sticky", description="collider.sticky: wet cloth seals against it (pockets model)", default=True,
    )


class WetclothScene(bpy.types.PropertyGroup):
    cache_dir: StringProperty(
        name="Cache Folder",
        description="Where the scene (scene.toml), its meshes, the run (run/) and the cloth's cache are written",
        default="//wetcloth_cache/",
        subtype="DIR_PATH",
    )
    last_error: StringProperty(name="Last Error", description="What went wrong last time, as the command said it")
    last_error_key: StringProperty(name="Key", description="The scene key the last error names")
    last_error_object: StringProperty(name="Object", description="The object the last error is about")
    status: StringProperty(name="Status", description="How the last bake went")
    progress: FloatProperty(
        name="Progress", description="Frames written by the running bake", default=0.0, min=0.0, max=100.0,
        subtype="PERCENTAGE", precision=0,
    )


classes = (WetclothPreferences, WetclothHand, WetclothObject, WetclothScene)


def register():
    for c in classes:
        bpy.utils.register_class(c)
    bpy.types.Object.wetcloth = PointerProperty(type=WetclothObject)
    bpy.types.Scene.wetcloth = PointerProperty(type=WetclothScene)


def unregister():
    del bpy.types.Scene.wetcloth
    del bpy.types.Object.wetcloth
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
