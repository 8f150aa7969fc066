"""The Wet Cloth panels in the Physics properties."""

import textwrap

import bpy

from . import cache, runner, scene_export
from .props import PROPERTY_OF_KEY


def _error_property(scene):
    """The add-on property the last error is about (highlighted red), or ''."""
    key = scene.wetcloth.last_error_key
    if key in PROPERTY_OF_KEY:
        return PROPERTY_OF_KEY[key]
    if key.startswith("collider["):
        field = key.split(".", 1)[1] if "." in key else ""
        return {"friction": "friction", "sticky": "sticky"}.get(field, "collider_shape")
    if key.startswith("grab["):
        return "pin_group"
    return key


def _wrapped(layout, context, text, icon="NONE"):
    width = max(20, int((context.region.width if context.region else 300) / 7))
    col = layout.column(align=True)
    for i, line in enumerate(textwrap.wrap(text, width) or [""]):
        col.label(text=line, icon=icon if i == 0 else "BLANK1")
    return col


def _prop(layout, data, name, bad, **kw):
    row = layout.row()
    row.alert = name == bad
    row.prop(data, name, **kw)
    return row


class _Base:
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "physics"


class _ClothSub(_Base):
    bl_parent_id = "PHYSICS_PT_wetcloth"

    @classmethod
    def poll(cls, context):
        ob = context.object
        return ob is not None and ob.wetcloth.role == "CLOTH"


class PHYSICS_PT_wetcloth(_Base, bpy.types.Panel):
    bl_label = "Wet Cloth"

    @classmethod
    def poll(cls, context):
        return context.object is not None

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        ob = context.object
        s = ob.wetcloth
        scene = context.scene
        bad = _error_property(scene) if scene.wetcloth.last_error_object in ("", ob.name) else ""
        _prop(layout, s, "role", bad if bad == "role" else "")
        if s.role == "COLLIDER":
            _prop(layout, s, "collider_shape", bad)
            _prop(layout, s, "friction", bad)
            _prop(layout, s, "sticky", bad)
            if scene.wetcloth.last_error and scene.wetcloth.last_error_object == ob.name:
                box = layout.box()
                box.alert = True
                _wrapped(box, context, scene.wetcloth.last_error, icon="ERROR")
            return
        if s.role != "CLOTH":
            return
        self.draw_bake(context, layout, scene)

    def draw_bake(self, context, layout, scene):
        ws = scene.wetcloth
        ob = context.object
        layout.prop(ws, "cache_dir")
        job = runner.job_of(scene)
        col = layout.column()
        col.use_property_split = False
        if job is not None:
            if hasattr(col, "progress"):  # Blender 4.0 and later
                col.progress(factor=ws.progress / 100.0, type="BAR", text=ws.status or "Baking")
            else:
                row = col.row()
                row.enabled = False
                row.prop(ws, "progress", text=ws.status or "Baking", slider=True)
            col.operator("wetcloth.cancel", icon="CANCEL")
        else:
            row = col.row(align=True)
            row.scale_y = 1.3
            row.operator("wetcloth.bake", icon="PHYSICS")
            try:
                folder = scene_export.cache_dir(scene)
            except scene_export.ExportError:
                folder = ""
            if folder and runner.resumable(folder):
                row.operator("wetcloth.resume", icon="PLAY")
            row = col.row(align=True)
            row.operator("wetcloth.export", icon="EXPORT")
            row.operator("wetcloth.load", icon="IMPORT")
            row.operator("wetcloth.free", icon="TRASH")
            if folder:
                status, frames = runner.run_state(folder)
                loaded = cache.modifier(ob) is not None
                if status:
                    total = scene.frame_end - scene.frame_start + 1
                    text = f"Run: {status}, {frames} of {total} frames" + ("; loaded" if loaded else "; not loaded")
                    col.label(text=text, icon="INFO")
            if ws.status:
                _wrapped(col, context, ws.status)
        if ws.last_error:
            box = layout.box()
            box.alert = True
            _wrapped(box, context, ws.last_error, icon="ERROR")
            if ws.last_error_key:
                box.label(text=f"Key: {ws.last_error_key}" + (f" ({ws.last_error_object})" if ws.last_error_object else ""))


class PHYSICS_PT_wetcloth_cloth(_ClothSub, bpy.types.Panel):
    bl_label = "Cloth"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        s = context.object.wetcloth
        bad = _error_property(context.scene)
        col = layout.column()
        for name in ("mass", "structural_stiffness", "shear_stiffness", "damping", "thickness",
                     "collision_margin", "self_collision", "strain_limit", "flip_normals"):
            _prop(col, s, name, bad)


class PHYSICS_PT_wetcloth_wet(_ClothSub, bpy.types.Panel):
    bl_label = "Wetness and Air"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        s = context.object.wetcloth
        bad = _error_property(context.scene)
        col = layout.column()
        for name in ("wetness", "water_mass", "dry_friction_factor", "wet_adhesion"):
            _prop(col, s, name, bad)
        col.separator()
        _prop(col, s, "air_enabled", bad)
        sub = col.column()
        sub.active = s.air_enabled
        _prop(sub, s, "air_model", bad)
        if s.air_model == "THESIS":
            _prop(sub, s, "trapped_air", bad)
            _prop(sub, s, "leak_conductance", bad)
        else:
            for name in ("seal_distance", "seal_hysteresis", "seal_wetness", "permeability", "dry_permeability"):
                _prop(sub, s, name, bad)
        for name in ("pressure_solve", "pressure_force", "atmospheric_pressure"):
            _prop(sub, s, name, bad)


class PHYSICS_PT_wetcloth_simulation(_ClothSub, bpy.types.Panel):
    bl_label = "Simulation"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        s = context.object.wetcloth
        scene = context.scene
        bad = _error_property(scene)
        col = layout.column()
        _prop(col, s, "integrator", bad)
        _prop(col, s, "time_step", bad)
        if s.integrator == "IMPLICIT":
            _prop(col, s, "implicit_budget", bad)
        fps = scene_export.frame_rate(scene)
        n = scene.frame_end - scene.frame_start
        box = col.box()
        box.label(text=f"Frames {scene.frame_start}-{scene.frame_end} at {fps:g} fps: {n / fps:.3g} s (scene)")
        steps = scene_export.steps_per_frame(fps, s.time_step)
        box.label(text=f"{steps} step(s) of {1 / (fps * steps):.4g} s per frame")


class WETCLOTH_UL_hands(bpy.types.UIList):
    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index=0):
        ob = context.object
        row = layout.row(align=True)
        row.prop_search(item, "vertex_group", ob, "vertex_groups", text="")
        row.prop(item, "target", text="")


class PHYSICS_PT_wetcloth_hands(_ClothSub, bpy.types.Panel):
    bl_label = "Pins and Hands"

    def draw(self, context):
        layout = self.layout
        ob = context.object
        s = ob.wetcloth
        bad = _error_property(context.scene)
        row = layout.row()
        row.alert = bad == "pin_group"
        row.prop_search(s, "pin_group", ob, "vertex_groups", text="Pin Group")
        layout.label(text="Hands: vertex groups that follow an object")
        row = layout.row()
        row.template_list("WETCLOTH_UL_hands", "", s, "hands", s, "active_hand", rows=2)
        col = row.column(align=True)
        col.operator("wetcloth.hand_add", icon="ADD", text="")
        col.operator("wetcloth.hand_remove", icon="REMOVE", text="")


classes = (
    PHYSICS_PT_wetcloth,
    PHYSICS_PT_wetcloth_cloth,
    PHYSICS_PT_wetcloth_wet,
    PHYSICS_PT_wetcloth_simulation,
    WETCLOTH_UL_hands,
    PHYSICS_PT_wetcloth_hands,
)


def register():
    for c in classes:
        bpy.utils.register_class(c)


def unregister():
    for c in reversed(classes):
        bpy.utils.unregister_class(c)

